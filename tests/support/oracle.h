/* Exact reference answers for tests, computed with GMP rationals by a method that shares
 * nothing with the engine: two closed convex hulls meet iff a linear feasibility problem
 * (convex weights of each point set giving the same point) has a solution, found by
 * enumerating basic solutions exactly. */
#ifndef TRIOCT_TESTS_ORACLE_H
#define TRIOCT_TESTS_ORACLE_H

#include "geom/vec3.h"

/* 1 when conv(a[0..na)) and conv(b[0..nb)) share a point (na, nb in 1..8). */
int oracle_hulls_intersect(const vec3 *a, int na, const vec3 *b, int nb);

/* Closed triangle vs closed triangle, and closed triangle vs closed box. */
int oracle_tri_tri(const vec3 a[3], const vec3 b[3]);
int oracle_tri_box(const vec3 tri[3], box3 box);

/* 1 when the ray o + t d, t in [tmin, tmax], meets the closed triangle (no tie-breaking:
 * boundary contacts count). */
int oracle_ray_tri(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3]);

/* The smallest t of the closed segment's common points with the closed triangle (tmin
 * finite), exactly: oracle_ray_tri_first_t_compare gives sign(t_exact - t), or
 * ORACLE_NO_CONTACT when they share no point; oracle_ray_tri_first_t the value rounded
 * toward zero (mpq_get_d), NaN for no contact; oracle_ray_tri_first_t_order compares two
 * triangles' values (both must have contact). */
#define ORACLE_NO_CONTACT 2
int oracle_ray_tri_first_t_compare(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3], double t);
double oracle_ray_tri_first_t(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3]);
int oracle_ray_tri_first_t_order(vec3 o, vec3 d, double tmin, double tmax, const vec3 a[3], const vec3 b[3]);

/* How the ray o + t d, t in [tmin, tmax], meets the closed triangle, in the same exact
 * arithmetic: no contact; one point strictly inside a triangle of nonzero area, the ray
 * crossing its plane; or a contact where crossing rules may differ: the ray meets an edge
 * or a vertex (BOUNDARY), is parallel to the triangle's plane, so lies in it (IN_PLANE),
 * or meets a triangle of no area (ZERO_AREA). */
enum {
    ORACLE_RAY_MISS = 0,
    ORACLE_RAY_INTERIOR = 1,
    ORACLE_RAY_BOUNDARY = 2,
    ORACLE_RAY_IN_PLANE = 3,
    ORACLE_RAY_ZERO_AREA = 4
};
int oracle_ray_tri_contact(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3]);

/* For a ray meeting the triangle's plane at a single point: compares the exact t at which
 * the ray meets planes of a and b (-1, 0, +1). */
int oracle_compare_plane_t(vec3 o, vec3 d, const vec3 a[3], const vec3 b[3]);

/* The exact t at which the ray meets the triangle's plane (not parallel to it), rounded
 * toward zero to a double. */
double oracle_plane_t(vec3 o, vec3 d, const vec3 tri[3]);

#endif
