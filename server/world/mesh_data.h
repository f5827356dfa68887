/* An owned triangle mesh (vertex array + index triples), as loaded from a file or generated. */
#ifndef TRIOCT_WORLD_MESH_DATA_H
#define TRIOCT_WORLD_MESH_DATA_H

#include <stddef.h>
#include <stdint.h>

#include "../engine.h"
#include "../geom/vec3.h"

typedef struct mesh_data {
    vec3 *vertices;
    size_t vertex_count;
    uint32_t *indices; /* 3 per triangle */
    size_t triangle_count;
} mesh_data;

/* Corner k (0-2) of triangle t. */
static inline vec3 mesh_data_corner(const mesh_data *mesh, size_t t, int k)
{
    return mesh->vertices[mesh->indices[3 * t + (size_t)k]];
}

/* Frees the arrays and zeroes the struct; safe on a zeroed struct. */
void mesh_data_free(mesh_data *mesh);
/* A borrowed view for octree_build and the queries. */
mesh_view mesh_data_view(const mesh_data *mesh);
/* The axis-aligned bounds of the vertices (a zero box for an empty mesh). */
box3 mesh_data_bounds(const mesh_data *mesh);
/* Appends src's triangles to dst (vertices copied, indices shifted). 0 or -1 (no memory). */
int mesh_data_append(mesh_data *dst, const mesh_data *src);

#endif
