/* The real meshes (Debian's assimp-testmodels) that the benchmarks and the accuracy report
 * measure, as loaded and subdivided up to the triangle counts the engine's targets speak
 * of. One list, so every figure names the same files. */
#ifndef TRIOCT_TESTS_REAL_MESHES_H
#define TRIOCT_TESTS_REAL_MESHES_H

#include <stddef.h>

#include "world/mesh_data.h"

typedef enum real_mesh { REAL_WUSON, REAL_SPIDER, REAL_MESH_COUNT } real_mesh;

const char *real_mesh_path(real_mesh which); /* absolute path of the model file */
const char *real_mesh_key(real_mesh which);  /* "wuson", "spider" */

/* The most subdivisions (each x4 triangles) that keep triangles * 4^times <= limit; 0 when
 * even one would exceed it. */
int subdivisions_to_reach(size_t triangles, size_t limit);

/* Loads `which` into *base (the caller frees it) and, when sub is not NULL, subdivides it
 * the most times that stay within limit triangles into *sub, *times saying how often.
 * 0, or -1 with the loader's reason in err (nothing to free then). */
int real_mesh_load(real_mesh which, size_t limit, mesh_data *base, mesh_data *sub, int *times, char *err,
                   size_t err_len);

#endif
