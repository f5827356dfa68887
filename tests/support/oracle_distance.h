/* Exact point-to-triangle distances for tests, in GMP rationals, by a method that shares
 * nothing with the engine's: the squared distance is the smallest of the vertices', the
 * edges' interior feet (the exact parameter of the foot on each line, kept when strictly
 * inside), and the face's foot (its barycentric weights from the 2x2 normal equations,
 * kept when all are >= 0). Slow on purpose. */
#ifndef TRIOCT_TESTS_ORACLE_DISTANCE_H
#define TRIOCT_TESTS_ORACLE_DISTANCE_H

#include "geom/vec3.h"
#include "oracle.h"

/* sign(real distance - d) for d >= 0, exactly: -1, 0, +1. */
int oracle_point_triangle_compare(vec3 p, const vec3 v[3], double d);

/* The real squared distance rounded to a double, and what attains it: 0 face, 1 edge,
 * 2 vertex (the engine's distance_feature numbers); on a tie, the lower number. */
double oracle_point_triangle_distance2(vec3 p, const vec3 v[3], int *feature);

/* The same between two closed triangles: 0 when they touch (oracle.h's exact test), else
 * the smallest of the six vertices' distances to the other triangle and the nine edge
 * pairs' interior critical points (both parameters strictly inside, from their 2x2
 * normal equations). */
int oracle_triangle_pair_compare(const vec3 a[3], const vec3 b[3], double d);
double oracle_triangle_pair_distance2(const vec3 a[3], const vec3 b[3]);

#endif
