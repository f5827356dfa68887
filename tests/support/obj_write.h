/* Writes meshes as Wavefront OBJ with every coordinate printed exactly (%.17g), so a mesh
 * written and loaded back through assimp has the same doubles. For tests, the benchmark and
 * the demo scene. */
#ifndef TRIOCT_TESTS_OBJ_WRITE_H
#define TRIOCT_TESTS_OBJ_WRITE_H

#include "world/mesh_data.h"

/* 0, or -1 when the file cannot be written (errno says why). */
int obj_write(const char *path, const mesh_data *mesh);

#endif
