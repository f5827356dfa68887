/* libFuzzer target: what the daemon reads from a loader child (mesh_load_frame_read), the
 * bytes a child that a hostile file took over could write: every count, index and
 * coordinate is checked before the engine sees them, and nothing is allocated past the
 * budget. */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "world/mesh_load_child.h"

#define BUDGET ((size_t)16 << 20)

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    FILE *f = tmpfile();
    if (!f)
        return 0;
    if (size)
        fwrite(data, 1, size, f);
    fflush(f);
    rewind(f);
    mesh_data mesh;
    mesh_load_report report;
    char err[1200];
    mesh_load_outcome outcome = mesh_load_frame_read(fileno(f), "fuzzed.obj", BUDGET, &mesh, &report, err, sizeof err);
    if (outcome == MESH_LOAD_OK) {
        if (mesh_data_bytes_for(mesh.vertex_count, mesh.triangle_count) > BUDGET)
            abort();
        for (size_t i = 0; i < 3 * mesh.triangle_count; i++)
            if (mesh.indices[i] >= mesh.vertex_count)
                abort();
        mesh_data_free(&mesh);
    } else if (mesh.vertices || mesh.indices) {
        abort(); /* a refusal hands back nothing */
    }
    fclose(f);
    return 0;
}
