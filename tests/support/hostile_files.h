/* The files of issue 20 that took down or filled the daemon when it parsed them itself,
 * written by the tests that show they no longer do. Each returns 0, or -1 when the file
 * cannot be written. */
#ifndef TRIOCT_TESTS_HOSTILE_FILES_H
#define TRIOCT_TESTS_HOSTILE_FILES_H

#include <stddef.h>

/* COLLADA nodes nested depth deep: assimp's reader recurses once per level (10,000 levels
 * overflowed a default stack; tests use 100,000). */
int hostile_write_deep_collada(const char *path, size_t depth);

/* A 177-byte binary PLY header claiming 268,435,456 vertices, and 12 bytes of body: it drove
 * a daemon parsing it in process to 3.2 GB. */
int hostile_write_lying_ply(const char *path);

#endif
