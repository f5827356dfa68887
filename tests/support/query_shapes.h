/* Query triangles drawn around a mesh, shared by the benchmarks and the accuracy report so
 * that their figures describe the same workload. */
#ifndef TRIOCT_TEST_QUERY_SHAPES_H
#define TRIOCT_TEST_QUERY_SHAPES_H

#include "meshgen.h"

typedef enum query_triangle_kind {
    QUERY_TRI_NEAR,      /* about `leaf` across, first corner within leaf / 2 of a mesh vertex */
    QUERY_TRI_AT_VERTEX, /* about `leaf` across, first corner exactly on a mesh vertex */
    QUERY_TRI_SAME,      /* a mesh triangle itself */
} query_triangle_kind;

/* A query triangle of the given kind at a random mesh triangle's first vertex. */
void query_triangle_sample(const mesh_data *m, rng *r, double leaf, query_triangle_kind kind, vec3 out[3]);

#endif
