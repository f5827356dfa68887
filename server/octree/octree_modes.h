/* The slack by which fast and seed queries grow node boxes, so that they visit every node
 * holding a triangle their final test could accept, and the per-tree facts it rests on
 * (octree_modes.c has the derivations). A slack is a max-norm distance; INFINITY means
 * the query must visit every node. */
#ifndef TRIOCT_OCTREE_MODES_H
#define TRIOCT_OCTREE_MODES_H

#include "octree_internal.h"

/* Fills the tree's fast_edge_product_log2, fast_longest_edge_log2, seed_reach_factor and seed
 * list (appended to leaf_items, after info.leaf_refs). */
octree_status octree_modes_prepare(struct octree *tree);

/* A ray o + t d in fast (Moller-Trumbore) or seed mode: a triangle the mode's test accepts
 * at parameter t has a point within the slack of o + t d. */
double octree_fast_ray_slack(const struct octree *tree, vec3 o, vec3 d);
double octree_seed_ray_slack(const struct octree *tree, vec3 o, vec3 d);

/* 1 for a sliver: zero area, or the smallest angle's sine below 2^-10 (the triangles of
 * the tree's sliver list). */
int octree_is_sliver(const vec3 t[3]);

/* A query triangle in fast or seed mode: a world triangle the mode's test accepts lies
 * within the slack of q, unless it is on the tree's sliver list. */
double octree_fast_triangle_slack(const struct octree *tree, const vec3 q[3]);
double octree_seed_triangle_slack(const struct octree *tree, const vec3 q[3]);

#endif
