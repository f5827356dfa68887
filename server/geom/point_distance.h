/* The distance from a point to a closed triangle, with proven bounds: every quantity is an
 * outward-rounded interval (interval.h), so the real distance of the double inputs lies in
 * the answer's [lo, hi] whatever the triangle's shape. Which part of the triangle is
 * nearest is decided from the intervals where they decide it; where they do not (a point
 * whose nearest point lies on a boundary between two parts, to rounding), both parts'
 * bounds are kept, which is still an enclosure. */
#ifndef TRIOCT_GEOM_POINT_DISTANCE_H
#define TRIOCT_GEOM_POINT_DISTANCE_H

#include "../engine.h"
#include "interval.h"

typedef struct point_triangle_distance {
    /* Bounds on the squared distance: lo2 <= |p - x|^2 <= hi2 for the real nearest x. */
    double lo2, hi2;
    /* The part whose bound gave hi2, and its estimate of the nearest point (rounded). */
    distance_feature feature; /* engine.h */
    int index; /* the edge or vertex number; 0 for the face */
    vec3 point;
} point_triangle_distance;

/* Bounds on the distance between p and the closed triangle v[0..2] (of any shape: a
 * segment or a point when it has no area): the nearest point searched in doubles, then
 * proven (the distance to it is an upper bound, the gap along the line to it a lower
 * one), with point_triangle_distance_intervals where that proof is loose. */
void point_triangle_distance_bounds(vec3 p, const vec3 v[3], point_triangle_distance *out);

/* The same from intervals over every case (the file's header): about five times the cost,
 * tight at any distance, the surface included. */
void point_triangle_distance_intervals(vec3 p, const vec3 v[3], point_triangle_distance *out);

/* The same between p and the closed segment [a, b] (a point when a == b): index 0 means
 * the nearest point is a, 1 b, and an edge feature the interior. */
void point_segment_distance_bounds(vec3 p, vec3 a, vec3 b, point_triangle_distance *out);

#endif
