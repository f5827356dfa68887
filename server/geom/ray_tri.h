/* Ray against triangle. The exact test is watertight: a ray through an edge or vertex
 * shared by triangles of a closed mesh crosses exactly one of them, because boundary ties
 * are broken by a symbolic perturbation of the ray direction that both neighbours see the
 * same way. */
#ifndef TRIOCT_GEOM_RAY_TRI_H
#define TRIOCT_GEOM_RAY_TRI_H

#include "vec3.h"

/* What a hit reports, rounded to double. Hits are ordered exactly by ray_tri_compare_t on
 * the triangles themselves, never by these rounded values. */
typedef struct ray_tri_hit {
    double t;       /* rounded, for reporting */
    double u, v;    /* barycentric weights of v1, v2 (rounded) */
    /* At or above the exact t, so that a walk for the closest hit may drop what starts
     * later: ray_tri_exact and ray_tri_exact_closed take it from the plane's own error
     * bounds (a few ulps above t); INFINITY where no bound was had (the other tests, an
     * in-plane touch, a nearly parallel ray). */
    double t_upper;
} ray_tri_hit;

/* 1 on a hit with tmin <= t <= tmax (exact). A ray parallel to the plane never hits.
 *
 * Semantics, for the ray o + t d and the triangle v0, v1, v2:
 *  - Edge functions w_ij = ((v_i - o) x (v_j - o)) . d for the edges 01, 12, 20 (the sign
 *    of each is ray_edge_sign). They sum exactly to den = ((v1 - v0) x (v2 - v0)) . d; when
 *    all three are zero (den == 0: d parallel to the plane, d == 0, or a degenerate
 *    triangle) there is no hit, even for a ray lying in the plane.
 *  - A zero w_ij is given the sign it takes for d' = d + (e1, e2, e3), e1 >> e2 >> e3 > 0
 *    infinitesimal: the sign of the first nonzero component of (v_i - o) x (v_j - o). When
 *    that vector is zero (o on the edge's line) the sign is +1 if v_i < v_j
 *    lexicographically (x, then y, then z), else -1. Both rules are antisymmetric in
 *    (i, j), so a ray crossing a closed, consistently oriented mesh through a shared edge
 *    is claimed by exactly one of the two triangles, and through a shared vertex by exactly
 *    one triangle of the fan: every answer is that of the perturbed ray, which misses all
 *    edges, so crossing counts keep the right parity. (A ray starting on an edge's line
 *    gets the fixed rule instead, which still makes the edge's two triangles disagree.)
 *  - A hit needs the three (tie-broken) signs equal; den then has that sign.
 *  - t = num / den with num = det[v0 - o, v1 - o, v2 - o] = ((v1 - v0) x (v2 - v0)) . (v0 - o).
 *    The range is closed and decided exactly: tmin <= num / den <= tmax. tmin may be 0,
 *    negative or -INFINITY, tmax may be INFINITY; NaN limits or tmin > tmax never hit. A
 *    ray leaving the inside of the triangle (not along its plane) hits at t = 0 iff
 *    tmin <= 0 <= tmax.
 *  - hit (may be NULL) gets t within a few ulps of the exact value (plain double when that
 *    is accurate enough, else a double-double or exact evaluation), clamped into
 *    [tmin, tmax], and u, v = w_20 / sum, w_01 / sum over the sign-corrected edge
 *    functions: finite, in [0, 1], with u + v <= 1 (up to rounding).
 *  - A floating-point filter decides almost every call; exact expansion arithmetic decides
 *    the rest and is counted through predicates_note_fallback (and the predicates' own
 *    counters). The exact stage first scales origin, direction and vertices by one power
 *    of two (t unchanged), so it is exact at any magnitude while the binary exponents of
 *    their nonzero components span at most 633 (the range test; 283 for ordering two
 *    hits): 1e9 offsets with 1e-9 features are inside. The span is sufficient, not
 *    necessary: the tests also get exact answers from coordinates near 1e308 with
 *    features of 2^1000 and a unit direction. Finite limits are exact between about
 *    2^-120 and 2^160. */
int ray_tri_exact(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3], ray_tri_hit *hit);

/* The candidates among triangles ids[0 .. count) (count <= 4) of an indexed mesh
 * (triangle t's vertices are vertices[corners[t][0..2]]) that ray_tri_exact surely misses
 * by its own first tests (a repeated vertex, then the edge filter), as a bit mask (bit i
 * for ids[i]). The filter is computed with the same operations in the same order, four
 * triangles side by side in AVX2 when `avx2` is set (the caller checked the processor), so
 * a rejected candidate is exactly one for which ray_tri_exact returns 0 without going
 * further; the others still need ray_tri_exact. */
unsigned ray_tri_exact_misses4(vec3 o, vec3 d, const vec3 *vertices, const uint32_t (*corners)[3],
                               const uint32_t *ids, unsigned count, int avx2);

/* Rays from one origin (a camera's or a lidar's), up to RAY_FAN_MAX of them, laid out for
 * testing one triangle against all of them at once: ray_fan_misses is
 * ray_tri_exact_misses4 turned around, one triangle against many rays. With a shared
 * origin the cross products of the edge function, (v_k - o) x (v_j - v_k), are the same
 * for every ray; only the dot product with each direction is the ray's own. */
#define RAY_FAN_MAX 8
typedef struct ray_fan {
    vec3 o;
    unsigned count;
    /* Per axis the rays' direction components and their magnitudes, side by side. */
    double d[3][RAY_FAN_MAX], dabs[3][RAY_FAN_MAX];
} ray_fan;

/* A fan of directions[0 .. count) from o (count <= RAY_FAN_MAX). */
void ray_fan_init(ray_fan *fan, vec3 o, const vec3 *directions, unsigned count);

/* The rays of the fan (bit i for ray i) that ray_tri_exact surely misses on tri by its own
 * first tests (all of them when tri has a repeated vertex, else by its edge filter): the
 * same products, sums and bounds in the same order as ray_tri_exact computes them for each
 * ray, so a rejected ray is exactly one for which ray_tri_exact returns 0 without going
 * further. */
unsigned ray_fan_misses(const ray_fan *fan, const vec3 tri[3], int avx2);

/* Compare the exact t of two exact hits of the same ray: -1, 0, +1 for t_a <, =, > t_b.
 * Exact (filter, then expansions) for any two triangles whose planes the ray is not
 * parallel to, hit or not; 0 when either den is 0. */
int ray_tri_compare_t(vec3 o, vec3 d, const vec3 a[3], const vec3 b[3]);

/* ---- The touch rule (ray_touch.c): the closed segment against the closed triangle ----
 *
 * 1 when the segment {o + t d : tmin <= t <= tmax} and the closed triangle share a point,
 * exactly, with no tie-breaking: boundary contacts count, a ray lying in the triangle's
 * plane hits when it meets the triangle there, a zero-area triangle is the segment or the
 * point it is, and an origin on the triangle hits at t = tmin. tmin must be finite (0
 * otherwise), tmax may be INFINITY; tmin > tmax or NaN never hits; d must not be zero.
 *
 * The cases, for den = ((v1 - v0) x (v2 - v0)) . d:
 *  - den != 0: the line meets the plane in one point, t = num / den as in ray_tri_exact;
 *    a hit when that point is in the closed triangle (the three edge functions' exact
 *    signs, zeros included, do not disagree) and tmin <= t <= tmax;
 *  - den == 0 with a nonzero-area triangle: a miss unless the line lies in the plane
 *    (orient3d of o is 0); then the line meets the triangle in an interval [ta, tb], where
 *    ta is the largest of the edges' entry parameters, and the hit is at max(ta, tmin) when
 *    that is <= min(tb, tmax);
 *  - a zero-area triangle: the segment between its two extreme vertices (collinear
 *    vertices) or its one point, against the ray: crossing it at one point, lying along it
 *    (an interval again), or missing it.
 * hit (may be NULL) gets the smallest common t, within a few ulps (the exact value is a
 * ratio of exact expansions, rounded from their compressed forms), clamped to
 * [tmin, tmax], and u, v the barycentric weights of v1, v2 at that point, in [0, 1]: for a
 * den != 0 hit those of ray_tri_exact, in the plane those of the rounded point, on a
 * zero-area triangle the position along its segment (all weight on v0 for a point).
 * Exact (scaled expansions) within the range ray_tri_exact states. */
int ray_tri_touch(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3], ray_tri_hit *hit);

/* Compares the smallest common t of two triangles that ray_tri_touch hits with the same
 * ray and limits: -1, 0, +1 for t_a <, =, > t_b, exactly. Two hits with den != 0 compare
 * as ray_tri_compare_t; otherwise the two values (each the plane parameter, an edge's
 * entry parameter, a vertex's parameter or tmin itself) compare as exact rationals. */
int ray_tri_touch_compare(vec3 o, vec3 d, double tmin, double tmax, const vec3 a[3], const vec3 b[3]);

/* ray_tri_exact with the closed rule, for ray_tri_touch: zero edge functions are not
 * tie-broken but count as on the triangle, and den == 0 exactly (all three zero, or a
 * repeated vertex) returns RAY_TRI_DEN_ZERO, which ray_tri_touch decides on its own. */
#define RAY_TRI_DEN_ZERO 2
int ray_tri_exact_closed(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3], ray_tri_hit *hit);

/* The seed's plane + point-in-triangle test with epsilon, and Moller-Trumbore.
 * ray_tri_seed: t = n.(v0 - o) / (n.d + eps) with the unit normal n, accepted when
 * tmin - eps < t < tmax + eps, then the hit point's signed distance along each edge's
 * unit outward normal must be below eps; zero-area triangles never hit. A t accepted
 * outside [tmin, tmax] (by the epsilon) is reported clamped to it, so every reported hit
 * lies in the closed interval.
 * ray_tri_fast: Moller-Trumbore in plain double, rejecting rays within a relative 2^-20 of
 * parallel (|det| <= 2^-20 |e1| |e2| |d|, max norms). Neither is watertight: shared edges
 * and vertices may be counted twice or missed. */
int ray_tri_seed(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3], double eps,
                 ray_tri_hit *hit);
int ray_tri_fast(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3], ray_tri_hit *hit);

#endif
