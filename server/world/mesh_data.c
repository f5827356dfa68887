/* Ownership helpers for mesh_data. */
#include "mesh_data.h"

#include <stdlib.h>
#include <string.h>

void mesh_data_free(mesh_data *mesh)
{
    free(mesh->vertices);
    free(mesh->indices);
    memset(mesh, 0, sizeof *mesh);
}

mesh_view mesh_data_view(const mesh_data *mesh)
{
    return (mesh_view){mesh->vertices, mesh->vertex_count, mesh->indices, mesh->triangle_count};
}

box3 mesh_data_bounds(const mesh_data *mesh)
{
    if (mesh->vertex_count == 0)
        return (box3){{0, 0, 0}, {0, 0, 0}};
    box3 b = {mesh->vertices[0], mesh->vertices[0]};
    for (size_t i = 1; i < mesh->vertex_count; i++) {
        b.lo = vec3_min(b.lo, mesh->vertices[i]);
        b.hi = vec3_max(b.hi, mesh->vertices[i]);
    }
    return b;
}

int mesh_data_append(mesh_data *dst, const mesh_data *src)
{
    size_t nv = dst->vertex_count + src->vertex_count;
    size_t nt = dst->triangle_count + src->triangle_count;
    if (nv > UINT32_MAX)
        return -1;
    vec3 *v = realloc(dst->vertices, (nv ? nv : 1) * sizeof *v);
    if (!v)
        return -1;
    dst->vertices = v;
    uint32_t *ix = realloc(dst->indices, (nt ? 3 * nt : 1) * sizeof *ix);
    if (!ix)
        return -1;
    dst->indices = ix;
    memcpy(v + dst->vertex_count, src->vertices, src->vertex_count * sizeof *v);
    uint32_t shift = (uint32_t)dst->vertex_count;
    for (size_t i = 0; i < 3 * src->triangle_count; i++)
        ix[3 * dst->triangle_count + i] = src->indices[i] + shift;
    dst->vertex_count = nv;
    dst->triangle_count = nt;
    return 0;
}
