/* A shape file into inline triangles (see cli_shape_file.h). */
#include "cli_shape_file.h"

#include <stdio.h>
#include <stdlib.h>

#include "world/mesh_load.h"

static trioct_vec3 corner(const mesh_data *m, size_t t, int k)
{
    vec3 p = mesh_data_corner(m, t, k);
    return (trioct_vec3){p.x, p.y, p.z};
}

int cli_read_shape_file(const char *path, trioct_triangle **out, size_t *count, char *err, size_t err_len)
{
    *out = NULL;
    *count = 0;
    mesh_data mesh;
    char why[512];
    /* Its messages name the file: "cannot open F: ...", "cannot load F: ...", "no triangles
     * in F", "F: triangle 3 has a NaN or infinite coordinate". */
    if (mesh_load_file(path, &mesh, NULL, why, sizeof why) != 0) {
        snprintf(err, err_len, "--shape-file: %s", why);
        return -1;
    }
    size_t n = mesh.triangle_count;
    /* Checked here rather than left to the library's refusal, so that it is a usage error
     * that says what to do instead, before anything is sent. */
    if (n > TRIOCT_MAX_INLINE_SHAPE_TRIANGLES) {
        mesh_data_free(&mesh);
        snprintf(err, err_len,
                 "--shape-file: %s holds %zu triangles, over the cap of %d a request carries inline "
                 "(TRIOCT_MAX_INLINE_SHAPE_TRIANGLES); name it as a query shape of the world's scene "
                 "(shape.NAME = file) instead",
                 path, n, TRIOCT_MAX_INLINE_SHAPE_TRIANGLES);
        return -1;
    }
    trioct_triangle *tris = malloc(n * sizeof *tris);
    if (tris == NULL) {
        mesh_data_free(&mesh);
        snprintf(err, err_len, "--shape-file: out of memory for the %zu triangles of %s", n, path);
        return -1;
    }
    for (size_t t = 0; t < n; t++)
        tris[t] = (trioct_triangle){corner(&mesh, t, 0), corner(&mesh, t, 1), corner(&mesh, t, 2)};
    mesh_data_free(&mesh);
    *out = tris;
    *count = n;
    return 0;
}
