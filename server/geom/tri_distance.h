/* The distance between two closed triangles, with proven bounds. Found in two steps: the
 * nearest pair of points is searched in plain doubles (each vertex against the other
 * triangle, each edge against each edge), and the answer is then proven in outward-rounded
 * interval arithmetic (interval.h): the upper bound is the distance between the two points
 * found, both real points of the triangles; the lower bound is the triangles' gap along a
 * direction (the feature pair's own: a face normal, an edge pair's cross product, or the
 * line between the points), which no pair of points can be closer than. Triangles the
 * lower bound cannot part are tested for contact exactly (tri_tri.h): touching ones are at
 * distance 0 exactly. */
#ifndef TRIOCT_GEOM_TRI_DISTANCE_H
#define TRIOCT_GEOM_TRI_DISTANCE_H

#include "../engine.h"
#include "interval.h"

typedef struct triangle_pair_distance {
    /* Bounds on the squared distance: lo2 <= |x - y|^2 <= hi2 for the real nearest x in a,
     * y in b. */
    double lo2, hi2;
    vec3 a_point, b_point; /* the nearest points found, rounded */
} triangle_pair_distance;

void triangle_pair_distance_bounds(const vec3 a[3], const vec3 b[3], triangle_pair_distance *out);

/* The same for a walk with a search radius: 1 with the bounds when the pair may be
 * within limit2 (lo2 <= limit2); 0 when it is proven farther, and then only lo2 (a lower
 * bound past the limit) is meant. Most pairs a walk measures are past its radius, and
 * their proof needs no interval arithmetic: the gap along the line between the points
 * the search found, in doubles with their error bound (convex_gap_lower2), parts them. */
int triangle_pair_distance_within(const vec3 a[3], const vec3 b[3], double limit2, triangle_pair_distance *out);

/* A lower bound of the squared distance between the convex hulls of a[0..na) and
 * b[0..nb) from their gap along n (either way along it): 0 when they overlap along n or
 * n is no direction. Cheap (one dot product a point): what prunes pairs before the full
 * bounds are worth their cost, with n a face normal. */
double convex_gap_lower2(const vec3 *a, int na, const vec3 *b, int nb, vec3 n);

/* Bounds on x - p for the real point x = t0 + v (t1 - t0) + w (t2 - t0) of the closed
 * triangle (v, w first clamped into it), computed as offsets so that coordinates far from
 * the origin do not round into the bounds. */
interval3 triangle_point_minus(const vec3 t[3], double v, double w, vec3 p);

/* The plain double search alone: the squared distance of the points found, and the points.
 * What the bound above starts from; exposed for tests. */
double triangle_pair_distance_estimate(const vec3 a[3], const vec3 b[3], vec3 *a_point, vec3 *b_point);

#endif
