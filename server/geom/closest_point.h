/* Nearest points in plain doubles: of a triangle to a point (by its Voronoi regions), and
 * of two segments (by the clamped solution of their 2x2 normal equations). Searches, not
 * proofs: the distance files prove what these find (point_distance.c, tri_distance.c),
 * and a choice rounding made poorly only loosens the proof. */
#ifndef TRIOCT_GEOM_CLOSEST_POINT_H
#define TRIOCT_GEOM_CLOSEST_POINT_H

#include "../engine.h"

/* x clamped to [0, 1]; a NaN to 0. */
static inline double clamp01(double x)
{
    return x > 0 ? (x < 1 ? x : 1.0) : 0.0;
}

/* Where on a triangle its nearest point lies: engine.h's distance_feature and number
 * (edge k joins vertices k and k + 1 mod 3). */
typedef struct closest_region {
    distance_feature feature;
    int index;
} closest_region;

/* The point of triangle t nearest p, as t0 + v (t1 - t0) + w (t2 - t0) with v, w in
 * [0, 1]; a triangle without area gives one of its vertices or edges. */
vec3 closest_point_on_triangle(vec3 p, const vec3 t[3], double *v, double *w, closest_region *region);

/* The nearest points p1 + s (q1 - p1) and p2 + t (q2 - p2) of two segments, s, t in [0, 1]. */
void closest_points_on_segments(vec3 p1, vec3 q1, vec3 p2, vec3 q2, double *s, double *t);

#endif
