/* The octree's answers computed the slow way, with the same primitive tests over every
 * triangle: what an octree query must equal, and what the benchmark's speed-up is over. */
#ifndef TRIOCT_TESTS_BRUTE_FORCE_H
#define TRIOCT_TESTS_BRUTE_FORCE_H

#include <stddef.h>

#include "engine.h"

/* hits: capacity max_hits; returns the number of hits (RAY_ALL: all, sorted by exact t then
 * id; RAY_CLOSEST: 0 or 1; RAY_ANY: 0 or 1, the smallest id that hits). ray->contact picks
 * the exact rule (ray_tri_exact or ray_tri_touch) in ACCURACY_EXACT. */
size_t brute_ray(const mesh_view *mesh, const ray_input *ray, ray_detail detail, accuracy_mode mode,
                 double seed_eps, ray_hit *hits, size_t max_hits);
/* ids (capacity cap) of touched triangles, ascending; returns the count. */
size_t brute_triangle(const mesh_view *mesh, const vec3 q[3], accuracy_mode mode, double seed_eps,
                      uint32_t *ids, size_t cap);

#endif
