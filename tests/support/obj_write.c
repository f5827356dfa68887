#include "obj_write.h"

#include <stdio.h>

int obj_write(const char *path, const mesh_data *mesh)
{
    FILE *f = fopen(path, "w");
    if (f == NULL)
        return -1;
    for (size_t i = 0; i < mesh->vertex_count; i++) {
        const vec3 *p = &mesh->vertices[i];
        fprintf(f, "v %.17g %.17g %.17g\n", p->x, p->y, p->z);
    }
    /* OBJ indices count from 1. */
    for (size_t t = 0; t < mesh->triangle_count; t++) {
        const uint32_t *i = &mesh->indices[3 * t];
        fprintf(f, "f %u %u %u\n", i[0] + 1, i[1] + 1, i[2] + 1);
    }
    int bad = ferror(f);
    if (fclose(f) != 0 || bad)
        return -1;
    return 0;
}
