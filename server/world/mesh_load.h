/* Loading triangle meshes from any file format assimp reads (OBJ, STL, PLY, glTF, ...). */
#ifndef TRIOCT_WORLD_MESH_LOAD_H
#define TRIOCT_WORLD_MESH_LOAD_H

#include <stddef.h>

#include "mesh_data.h"

typedef struct mesh_load_report {
    size_t meshes;             /* assimp meshes merged */
    size_t triangles;          /* triangles kept */
    size_t skipped_primitives; /* points and lines assimp found, which hold no triangle */
    size_t degenerate;         /* zero-area triangles (kept: they still collide as segments) */
    size_t duplicates;         /* triangles with the same three vertex positions as an earlier one */
    vec3 bbox_lo, bbox_hi;
} mesh_load_report;

/* Loads every triangle of every mesh in the file, node transforms applied, identical
 * vertices joined. Returns 0, or -1 with a message in err naming the file (and the
 * triangle, for a NaN/Inf coordinate). report may be NULL. */
int mesh_load_file(const char *path, mesh_data *out, mesh_load_report *report, char *err,
                   size_t err_len);

#endif
