/* Deterministic test and benchmark geometry: a seeded RNG and mesh generators. */
#ifndef TRIOCT_TESTS_MESHGEN_H
#define TRIOCT_TESTS_MESHGEN_H

#include <stdint.h>

#include "geom/vec3.h"
#include "world/mesh_data.h"

/* splitmix64: small, fast, and the same sequence on every machine. */
typedef struct rng {
    uint64_t state;
} rng;
rng rng_seeded(uint64_t seed);
uint64_t rng_next(rng *r);
double rng_uniform(rng *r, double lo, double hi); /* [lo, hi) */
vec3 rng_point_in_box(rng *r, box3 box);
vec3 rng_unit_vector(rng *r);

/* The one triangle a, b, c, in that order (vertices NULL when memory ran out). */
mesh_data meshgen_triangle(vec3 a, vec3 b, vec3 c);

/* Closed, outward-oriented meshes (every edge shared by exactly two triangles). */
mesh_data meshgen_tetrahedron(vec3 a, vec3 b, vec3 c, vec3 d); /* oriented outward whatever the input order */
mesh_data meshgen_box(box3 box);                               /* 12 triangles */
mesh_data meshgen_icosphere(vec3 centre, double radius, int subdivisions); /* 20 * 4^s triangles */
mesh_data meshgen_torus(vec3 centre, double major, double minor, int nu, int nv); /* non-convex */
/* A height-field grid over [lo, hi] in x, y: 2 * nx * ny triangles (open surface). */
mesh_data meshgen_terrain(uint64_t seed, box3 region, int nx, int ny);
/* n independent random triangles with vertices inside region, each of about `size`. */
mesh_data meshgen_soup(uint64_t seed, size_t n, box3 region, double size);
/* Axis-aligned blocks stacked and touching face to face, all coordinates on a grid of
 * exactly representable values: a CAD-like scene full of coplanar contacts. */
mesh_data meshgen_blocks(uint64_t seed, int nx, int ny, int nz, double cell);
/* Each subdivision splits every triangle into four at edge midpoints (shared midpoints are
 * shared vertices, so closed meshes stay closed). */
mesh_data meshgen_subdivide(const mesh_data *mesh, int times);
/* Copy with every vertex mapped by p -> scale * p + offset. */
mesh_data meshgen_transformed(const mesh_data *mesh, double scale, vec3 offset);

#endif
