/* The query shape of `trioct mesh --shape-file FILE`: a mesh file read on this side with the
 * daemon's own assimp reader (server/world/mesh_load.c: every format assimp reads, node
 * transforms applied, NaN and infinite coordinates refused), so that a file gives the
 * triangles it would give as a scene's shape, and sent inline in each request. */
#ifndef TRIOCT_CLI_SHAPE_FILE_H
#define TRIOCT_CLI_SHAPE_FILE_H

#include <stddef.h>

#include "trioct.h"

/* Reads path into *out (*count triangles, in the file's order; free(*out)). 0, or -1 with
 * err naming the file and why: it cannot be read, holds no triangles, or holds more than
 * TRIOCT_MAX_INLINE_SHAPE_TRIANGLES. */
int cli_read_shape_file(const char *path, trioct_triangle **out, size_t *count, char *err, size_t err_len);

#endif
