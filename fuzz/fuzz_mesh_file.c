/* libFuzzer target: the loader child's parsing, as the daemon runs it: the bytes as a file,
 * its format chosen by the first byte (OBJ, PLY, STL, OFF, COLLADA, glTF), handed to the
 * build's trioct-load through mesh_load_child. Assimp asserts, crashes and leaks on some
 * mutated files (run it in process and it aborts within seconds): that is what the child is
 * for, so here each of those must come back as an error naming the file, and a mesh that
 * comes back must be sound. The child's coverage is not seen (a process apart), so the
 * mutations are guided by this side's code only: a robustness run, not a search of
 * assimp. */
#include <limits.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "world/mesh_load_child.h"

static const char *const suffixes[] = {".obj", ".ply", ".stl", ".off", ".dae", ".gltf"};
static mesh_loader loader;

/* BUILD/trioct-load, beside this program's directory (BUILD/fuzz). */
static int find_loader(void)
{
    char self[PATH_MAX];
    ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    if (n <= 0)
        return -1;
    self[n] = '\0';
    for (int up = 0; up < 2; up++) {
        char *slash = strrchr(self, '/');
        if (!slash)
            return -1;
        *slash = '\0';
    }
    snprintf(loader.program, sizeof loader.program, "%s/trioct-load", self);
    loader.memory_bytes = (size_t)512 << 20;
    loader.cpu_seconds = 10;
    loader.wall_seconds = 20;
    return access(loader.program, X_OK);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (!loader.program[0] && find_loader() != 0) {
        fprintf(stderr, "fuzz_mesh_file: no trioct-load beside the fuzz directory\n");
        abort();
    }
    if (size < 1)
        return 0;
    char path[64];
    snprintf(path, sizeof path, "/tmp/trioct-fuzz-%d%s", (int)getpid(),
             suffixes[data[0] % (sizeof suffixes / sizeof suffixes[0])]);
    FILE *f = fopen(path, "wb");
    if (!f)
        return 0;
    fwrite(data + 1, 1, size - 1, f);
    fclose(f);
    mesh_data mesh;
    mesh_load_report report;
    char err[1200];
    mesh_load_outcome outcome = mesh_load_child(&loader, path, (size_t)64 << 20, &mesh, &report, err, sizeof err);
    if (outcome == MESH_LOAD_OK) {
        for (size_t i = 0; i < 3 * mesh.triangle_count; i++)
            if (mesh.indices[i] >= mesh.vertex_count)
                abort();
        if (report.triangles != mesh.triangle_count)
            abort();
        mesh_data_free(&mesh);
    } else if (mesh.vertices || mesh.indices || !strstr(err, path)) {
        fprintf(stderr, "fuzz_mesh_file: a refusal that keeps memory or does not name the file: %s\n", err);
        abort();
    }
    unlink(path);
    return 0;
}
