/* Tests of the touch rule (ray_tri_touch, ray_tri_touch_compare): hand-made cases with
 * their exact answers for each branch (a line crossing the plane through the inside, an
 * edge or a vertex; a line in the plane entering, missing, grazing a vertex; zero-area
 * triangles as segments and points; origins on the triangle; the closed range), then
 * seeded random cases built to land on those branches, checked against the GMP oracle's
 * "closed segment meets closed triangle" and its exact smallest common t. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "geom/ray_tri.h"
#include "geom/vec3.h"
#include "support/oracle.h"

/* ------------------------------------------------------------------ seeded RNG */

static uint64_t base_seed = 0x70c4ed9e0b5eedULL;

typedef struct rng {
    uint64_t state;
} rng;

static uint64_t rng_u64(rng *r)
{
    uint64_t z = (r->state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

static rng rng_for(uint64_t salt)
{
    rng r = {base_seed ^ (salt * 0xd1b54a32d192ed03ULL)};
    return r;
}

static double rng_unit(rng *r) { return (double)(rng_u64(r) >> 11) * 0x1p-53; }
static double rng_range(rng *r, double lo, double hi) { return lo + (hi - lo) * rng_unit(r); }
static int rng_int(rng *r, int lo, int hi) { return lo + (int)(rng_u64(r) % (uint64_t)(hi - lo + 1)); }

static vec3 pt(double x, double y, double z) { return vec3_make(x, y, z); }

/* ------------------------------------------------------------------ checking one case */

/* Ulps between two doubles of the same sign region (for t near 0, absolute 2^-1000). */
static double ulps_apart(double a, double b)
{
    double scale = fmax(fabs(a), fabs(b));
    double ulp = scale > 0x1p-1000 ? nextafter(scale, INFINITY) - scale : 0x1p-1000;
    return fabs(a - b) / ulp;
}

/* The primitive against the oracle on one case: the same yes/no, and on a hit a t within a
 * few ulps of the exact smallest common t, clamped into the range, and barycentrics in
 * [0, 1] summing to at most 1. Returns the hit. */
static int check_against_oracle(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3], ray_tri_hit *out)
{
    ray_tri_hit h = {NAN, NAN, NAN, NAN};
    int got = ray_tri_touch(o, d, tmin, tmax, tri, &h);
    int want = oracle_ray_tri(o, d, tmin, tmax, tri);
    if (got != want)
        fail_msg("touch %d, oracle %d: o (%a %a %a) d (%a %a %a) t [%a, %a] tri (%a %a %a) (%a %a %a) (%a %a %a)",
                 got, want, o.x, o.y, o.z, d.x, d.y, d.z, tmin, tmax, tri[0].x, tri[0].y, tri[0].z, tri[1].x,
                 tri[1].y, tri[1].z, tri[2].x, tri[2].y, tri[2].z);
    if (got) {
        double exact = oracle_ray_tri_first_t(o, d, tmin, tmax, tri);
        if (!(ulps_apart(h.t, exact) <= 4.0))
            fail_msg("t %a, exact %a (%g ulps): o (%a %a %a) d (%a %a %a) tri (%a %a %a) (%a %a %a) (%a %a %a)",
                     h.t, exact, ulps_apart(h.t, exact), o.x, o.y, o.z, d.x, d.y, d.z, tri[0].x, tri[0].y,
                     tri[0].z, tri[1].x, tri[1].y, tri[1].z, tri[2].x, tri[2].y, tri[2].z);
        assert_true(h.t >= tmin && h.t <= tmax);
        assert_true(h.u >= 0.0 && h.u <= 1.0 && h.v >= 0.0 && h.v <= 1.0);
        assert_true(h.u + h.v <= 1.0 + 0x1p-50);
    }
    if (out)
        *out = h;
    return got;
}

/* ------------------------------------------------------------------ hand-made cases */

/* The plane z = C with a full mantissa, and a triangle in it; the ray's z stays C. */
#define C 0.1

static void test_in_plane_ray_enters_at_an_edge(void **state)
{
    (void)state;
    const vec3 tri[3] = {pt(0, 0, C), pt(4, 0, C), pt(0, 4, C)};
    /* From x = -0.3 along +x at half speed: the edge x = 0 is reached at t = 0.3 / 0.5,
     * which is 2 * 0.3 exactly (a power-of-two ratio). */
    vec3 o = pt(-0.3, 1.0, C), d = pt(0.5, 0, 0);
    ray_tri_hit h;
    assert_int_equal(check_against_oracle(o, d, 0, INFINITY, tri, &h), 1);
    assert_true(h.t == 2 * 0.3);
    assert_true(fabs(h.u) < 1e-15);          /* on the edge v0-v2: no weight on v1 */
    assert_true(fabs(h.v - 0.25) < 1e-15);   /* y = 1 of 4 along v0 -> v2 */
    /* The watertight rule never hits a ray lying in the plane. */
    assert_int_equal(ray_tri_exact(o, d, 0, INFINITY, tri, NULL), 0);
    /* The range is closed at both ends: tmax at the entry still hits, one ulp less not. */
    assert_int_equal(check_against_oracle(o, d, 0, 2 * 0.3, tri, &h), 1);
    assert_true(h.t == 2 * 0.3);
    assert_int_equal(check_against_oracle(o, d, 0, nextafter(2 * 0.3, 0), tri, NULL), 0);
    /* tmin inside the triangle: the segment starts there. */
    assert_int_equal(check_against_oracle(o, d, 3.0, 5.0, tri, &h), 1);
    assert_true(h.t == 3.0);
    /* tmin at the far side's exit, x = 3 at y = 1: t = 3.3 / 0.5 exactly = 6.6 rounded;
     * past it, nothing. */
    assert_int_equal(check_against_oracle(o, d, 7.0, INFINITY, tri, NULL), 0);
}

static void test_in_plane_ray_missing_and_behind(void **state)
{
    (void)state;
    const vec3 tri[3] = {pt(0, 0, C), pt(4, 0, C), pt(0, 4, C)};
    /* y = 4.5 runs above the hypotenuse x + y = 4 for every x >= 0. */
    assert_int_equal(check_against_oracle(pt(-1, 4.5, C), pt(1, 0, 0), 0, INFINITY, tri, NULL), 0);
    /* Along the line through the triangle but pointing away, with tmin = 0. */
    assert_int_equal(check_against_oracle(pt(-1, 1, C), pt(-1, 0, 0), 0, INFINITY, tri, NULL), 0);
    /* ... which a negative tmin reaches back to: x in [0, 3] is t in [-4, -1]. */
    ray_tri_hit h;
    assert_int_equal(check_against_oracle(pt(-1, 1, C), pt(-1, 0, 0), -10, INFINITY, tri, &h), 1);
    assert_true(h.t == -4.0); /* the smallest t is the far end x = 3, not the near x = 0 */
    /* Parallel to the plane one ulp above it: no common point. */
    assert_int_equal(check_against_oracle(pt(-1, 1, nextafter(C, 1)), pt(1, 0, 0), 0, INFINITY, tri, NULL), 0);
}

static void test_in_plane_ray_touching_only_a_vertex(void **state)
{
    (void)state;
    const vec3 tri[3] = {pt(0, 0, C), pt(4, 0, C), pt(0, 4, C)};
    /* y = 4 meets the closed triangle only at v2 = (0, 4). */
    ray_tri_hit h;
    assert_int_equal(check_against_oracle(pt(-1.5, 4, C), pt(1, 0, 0), 0, INFINITY, tri, &h), 1);
    assert_true(h.t == 1.5);
    assert_true(h.u == 0.0 && h.v == 1.0);
    /* The line x + y = 4 + 2^-50 misses by the least amount the grid allows. */
    assert_int_equal(check_against_oracle(pt(-1.5, 4 + 0x1p-50, C), pt(1, 0, 0), 0, INFINITY, tri, NULL), 0);
    /* Sliding along the edge y = 0 from outside: enters at v0. */
    assert_int_equal(check_against_oracle(pt(-2, 0, C), pt(1, 0, 0), 0, INFINITY, tri, &h), 1);
    assert_true(h.t == 2.0);
    assert_true(h.u == 0.0 && h.v == 0.0);
    /* In-plane origin inside the triangle: t = tmin. */
    assert_int_equal(check_against_oracle(pt(1, 1, C), pt(0.3, -0.7, 0), 0, INFINITY, tri, &h), 1);
    assert_true(h.t == 0.0);
}

/* A strip of two triangles sharing the edge (0,0)-(0,1) in z = 0, both counter-clockwise
 * seen from +z, and a fan of six around the origin. */
static void test_ray_through_shared_edge_touches_both(void **state)
{
    (void)state;
    const vec3 left[3] = {pt(0, 0, 0), pt(0, 1, 0), pt(-1, 0.5, 0)};
    const vec3 right[3] = {pt(0, 1, 0), pt(0, 0, 0), pt(1, 0.5, 0)};
    vec3 o = pt(0, 0.3, 5), d = pt(0, 0, -2); /* meets the edge at (0, 0.3, 0), t = 2.5 */
    ray_tri_hit hl, hr;
    assert_int_equal(check_against_oracle(o, d, 0, INFINITY, left, &hl), 1);
    assert_int_equal(check_against_oracle(o, d, 0, INFINITY, right, &hr), 1);
    assert_true(hl.t == 2.5 && hr.t == 2.5);
    assert_int_equal(ray_tri_touch_compare(o, d, 0, INFINITY, left, right), 0);
    assert_int_equal(ray_tri_exact(o, d, 0, INFINITY, left, NULL) + ray_tri_exact(o, d, 0, INFINITY, right, NULL),
                     1);
}

static void test_ray_through_fan_vertex_touches_all(void **state)
{
    (void)state;
    /* A closed fan of six around a raised hub, rim points on a grid so every t is exact. */
    const vec3 ring[6] = {pt(1, 0, 0),     pt(0.5, 0.875, 0.25),   pt(-0.5, 0.875, 0),
                          pt(-1, 0, 0.25), pt(-0.5, -0.875, 0), pt(0.5, -0.875, 0.25)};
    vec3 hub = pt(0, 0, 0.125);
    vec3 o = pt(0, 0, 3.125), d = pt(0, 0, -1);
    int touch = 0, cross = 0;
    for (int i = 0; i < 6; i++) {
        vec3 tri[3] = {hub, ring[i], ring[(i + 1) % 6]};
        ray_tri_hit h;
        touch += check_against_oracle(o, d, 0, INFINITY, tri, &h);
        assert_true(h.t == 3.0);
        cross += ray_tri_exact(o, d, 0, INFINITY, tri, NULL);
    }
    assert_int_equal(touch, 6);
    assert_int_equal(cross, 1);
}

static void test_zero_area_segment_crossed_missed_and_along(void **state)
{
    (void)state;
    /* Collinear vertices (v2 - v0 = 3 (v1 - v0)): the extreme ones are v0 and v2. */
    const vec3 s3[3] = {pt(0.5, 0.25, 3), pt(1, 0.5, 3.5), pt(2, 1, 4.5)};
    ray_tri_hit h;
    /* Down the z axis through (1, 0.5, 3.5), the middle vertex: t = 6.5 - 3.5 = 3. */
    assert_int_equal(check_against_oracle(pt(1, 0.5, 6.5), pt(0, 0, -1), 0, INFINITY, s3, &h), 1);
    assert_true(h.t == 3.0);
    assert_true(h.u == 0.0 && fabs(h.v - 1.0 / 3.0) < 1e-15); /* a third of the way from v0 to v2 */
    assert_int_equal(ray_tri_exact(pt(1, 0.5, 6.5), pt(0, 0, -1), 0, INFINITY, s3, NULL), 0);
    /* Beside it by 2^-40 in x: skew lines. */
    assert_int_equal(check_against_oracle(pt(1 + 0x1p-40, 0.5, 6.5), pt(0, 0, -1), 0, INFINITY, s3, NULL), 0);
    /* Coplanar, crossing the segment's line past its end (2, 1, 4.5): nothing. */
    assert_int_equal(check_against_oracle(pt(3, 1.5, 10), pt(0, 0, -1), 0, INFINITY, s3, NULL), 0);
    /* Along the segment from before its start: enters at v0, t = 1. */
    assert_int_equal(check_against_oracle(pt(0, 0, 2.5), pt(0.5, 0.25, 0.5), 0, INFINITY, s3, &h), 1);
    assert_true(h.t == 1.0);
    assert_true(h.u == 0.0 && h.v == 0.0);
    /* Backwards along it from beyond its end: enters at v2, t = 2. */
    assert_int_equal(check_against_oracle(pt(3, 1.5, 5.5), pt(-0.5, -0.25, -0.5), 0, INFINITY, s3, &h), 1);
    assert_true(h.t == 2.0);
    assert_true(h.u == 0.0 && h.v == 1.0);
    /* Starting inside it: t = tmin. */
    assert_int_equal(check_against_oracle(pt(1.5, 0.75, 4), pt(-0.5, -0.25, -0.5), 0, INFINITY, s3, &h), 1);
    assert_true(h.t == 0.0);
    /* On its line, but the window [0, 0.5] ends before it. */
    assert_int_equal(check_against_oracle(pt(0, 0, 2.5), pt(0.5, 0.25, 0.5), 0, 0.5, s3, NULL), 0);
    /* Two repeated vertices: the segment between the distinct ones. */
    const vec3 twice[3] = {pt(0.5, 0.25, 3), pt(2, 1, 4.5), pt(0.5, 0.25, 3)};
    assert_int_equal(check_against_oracle(pt(1, 0.5, 6.5), pt(0, 0, -1), 0, INFINITY, twice, &h), 1);
    assert_true(h.t == 3.0);
}

static void test_zero_area_point(void **state)
{
    (void)state;
    const vec3 p[3] = {pt(0.1, 0.2, 0.3), pt(0.1, 0.2, 0.3), pt(0.1, 0.2, 0.3)};
    ray_tri_hit h;
    assert_int_equal(check_against_oracle(pt(0.1, 0.2, -2), pt(0, 0, 1), 0, INFINITY, p, &h), 1);
    assert_true(h.t == 0.3 + 2.0); /* the exact 0.3 + 2, correctly rounded once */
    assert_true(h.u == 0.0 && h.v == 0.0);
    assert_int_equal(check_against_oracle(pt(nextafter(0.1, 1), 0.2, -2), pt(0, 0, 1), 0, INFINITY, p, NULL), 0);
    /* The point at the origin: t = tmin; and with tmin past 0, missed. */
    assert_int_equal(check_against_oracle(p[0], pt(0.7, -0.1, 0.3), 0, INFINITY, p, &h), 1);
    assert_true(h.t == 0.0);
    assert_int_equal(check_against_oracle(p[0], pt(0.7, -0.1, 0.3), 0x1p-1000, INFINITY, p, NULL), 0);
}

static void test_origin_on_triangle_and_range_ends(void **state)
{
    (void)state;
    const vec3 tri[3] = {pt(0, 0, C), pt(4, 0, C), pt(0, 4, C)};
    ray_tri_hit h;
    /* Off the plane's direction, starting on an edge: t = 0 in both rules' sense. */
    assert_int_equal(check_against_oracle(pt(2, 0, C), pt(0.1, 0.2, 1), 0, INFINITY, tri, &h), 1);
    assert_true(h.t == 0.0);
    /* A crossing at exactly tmax, and at exactly tmin, is inside the closed range. */
    const vec3 low[3] = {pt(0, 0, 0.25), pt(4, 0, 0.25), pt(0, 4, 0.25)};
    vec3 o = pt(1.1, 0.7, 2.25), d = pt(0, 0, -0.5); /* meets the plane at t = 2 / 0.5 = 4 */
    assert_int_equal(check_against_oracle(o, d, 0, 4, low, &h), 1);
    assert_true(h.t == 4.0);
    assert_int_equal(check_against_oracle(o, d, 4, 10, low, &h), 1);
    assert_true(h.t == 4.0);
    assert_int_equal(check_against_oracle(o, d, nextafter(4, 5), 10, low, NULL), 0);
    assert_int_equal(check_against_oracle(o, d, 0, nextafter(4, 0), low, NULL), 0);
    /* Limits the rule refuses: NaN, tmin > tmax, an infinite tmin. */
    assert_int_equal(ray_tri_touch(o, d, NAN, 10, tri, NULL), 0);
    assert_int_equal(ray_tri_touch(o, d, 5, 4, tri, NULL), 0);
    assert_int_equal(ray_tri_touch(o, d, -INFINITY, 10, tri, NULL), 0);
}

/* 1e9 away from the origin, features of 2^-20: the rule is exact there too. */
static void test_huge_offsets_tiny_features(void **state)
{
    (void)state;
    const double B = 1e9, f = 0x1p-20;
    const vec3 tri[3] = {pt(B, B, B), pt(B + f, B, B), pt(B, B + f, B)};
    ray_tri_hit h;
    /* In the plane z = B, along +x from f before the edge: t = 1. */
    assert_int_equal(check_against_oracle(pt(B - f, B + f / 4, B), pt(f, 0, 0), 0, INFINITY, tri, &h), 1);
    assert_true(h.t == 1.0);
    /* Grazing the hypotenuse's end v2 along y = B + f: only that vertex. */
    assert_int_equal(check_against_oracle(pt(B - f, B + f, B), pt(f, 0, 0), 0, INFINITY, tri, &h), 1);
    assert_true(h.t == 1.0);
    /* One ulp of B above it: missed. */
    assert_int_equal(check_against_oracle(pt(B - f, nextafter(B + f, INFINITY), B), pt(f, 0, 0), 0, INFINITY,
                                          tri, NULL), 0);
    /* Down through v1 from far above: the vertex is touched, crossing may pick another. */
    assert_int_equal(check_against_oracle(pt(B + f, B, B + 1e6), pt(0, 0, -1), 0, INFINITY, tri, &h), 1);
    assert_true(h.t == 1e6);
}

/* Order across the value kinds: a crossing (plane), an in-plane entry (edge), a point and
 * tmin itself, each pair compared exactly and against the oracle. */
static void test_compare_orders_every_kind(void **state)
{
    (void)state;
    vec3 o = pt(-0.3, 1, C), d = pt(0.5, 0, 0);
    const vec3 flat[3] = {pt(0, 0, C), pt(4, 0, C), pt(0, 4, C)};          /* entry t = 0.6 */
    const vec3 wall[3] = {pt(0.2, -1, -1), pt(0.2, 3, -1), pt(0.2, 1, 3)}; /* x = 0.2: t = 1 */
    const vec3 dot[3] = {pt(-0.05, 1, C), pt(-0.05, 1, C), pt(-0.05, 1, C)}; /* t = 0.25 / 0.5 */
    const vec3 start[3] = {pt(-0.3, 0, C), pt(-0.3, 2, C), pt(-1, 1, C)};   /* holds o: t = 0 */
    const vec3 *all[4] = {flat, wall, dot, start};
    for (int a = 0; a < 4; a++) {
        for (int b = 0; b < 4; b++) {
            assert_int_equal(check_against_oracle(o, d, 0, INFINITY, all[a], NULL), 1);
            int got = ray_tri_touch_compare(o, d, 0, INFINITY, all[a], all[b]);
            int want = oracle_ray_tri_first_t_order(o, d, 0, INFINITY, all[a], all[b]);
            if (got != want)
                fail_msg("kinds %d vs %d: %d, oracle %d", a, b, got, want);
        }
    }
    /* The order is start < dot < flat < wall. */
    assert_int_equal(ray_tri_touch_compare(o, d, 0, INFINITY, start, dot), -1);
    assert_int_equal(ray_tri_touch_compare(o, d, 0, INFINITY, dot, flat), -1);
    assert_int_equal(ray_tri_touch_compare(o, d, 0, INFINITY, flat, wall), -1);
}

/* ------------------------------------------------------------------ random cases */

/* A coordinate: full mantissa or on a coarse grid (where lines pass exactly through
 * vertices and along edges). */
static double draw(rng *r, int grid)
{
    return grid ? rng_int(r, -8, 8) / 4.0 : rng_range(r, -2, 2);
}

static vec3 draw_vec(rng *r, int grid) { return pt(draw(r, grid), draw(r, grid), draw(r, grid)); }

/* A triangle in the plane `axis` = c, or a zero-area one, or a general one. */
static void draw_triangle(rng *r, int kind, int axis, double c, int grid, vec3 tri[3])
{
    for (int i = 0; i < 3; i++)
        tri[i] = vec3_with(draw_vec(r, grid), axis, c);
    if (kind == 1) { /* collinear on the grid: v2 = v0 + m (v1 - v0), exact */
        tri[0] = draw_vec(r, 1);
        tri[1] = draw_vec(r, 1);
        double m = (double)rng_int(r, -2, 3) / 2;
        tri[2] = vec3_add(tri[0], vec3_scale(vec3_sub(tri[1], tri[0]), m));
        if (rng_int(r, 0, 2) == 0) { /* shuffled */
            vec3 t = tri[0];
            tri[0] = tri[2];
            tri[2] = t;
        }
    } else if (kind == 2) { /* a point, or two vertices repeated */
        tri[0] = draw_vec(r, grid);
        tri[1] = rng_int(r, 0, 1) ? tri[0] : draw_vec(r, 1);
        tri[2] = tri[0];
    } else if (kind == 3) { /* a general triangle */
        for (int i = 0; i < 3; i++)
            tri[i] = draw_vec(r, grid);
    }
}

/* A ray in the plane (for kind 0), or aimed at a vertex or a point of the triangle's
 * edge lines, or anywhere. */
static void draw_ray(rng *r, int kind, int axis, double c, int grid, const vec3 tri[3], vec3 *o, vec3 *d)
{
    *d = pt(rng_int(r, -2, 2), rng_int(r, -2, 2), rng_int(r, -2, 2));
    if (grid == 0)
        *d = draw_vec(r, 0);
    if (kind == 0)
        *d = vec3_with(*d, axis, 0.0);
    if (d->x == 0 && d->y == 0 && d->z == 0)
        *d = vec3_with(*d, (axis + 1) % 3, 1.0);
    int aim = rng_int(r, 0, 3);
    if (aim == 0) {
        *o = draw_vec(r, grid);
    } else {
        /* o = target - s d for a grid target: the line passes it exactly when s d is exact
         * (small integers times a grid direction). */
        vec3 target = aim == 1 ? tri[rng_int(r, 0, 2)]
                               : vec3_scale(vec3_add(tri[rng_int(r, 0, 2)], tri[rng_int(r, 0, 2)]), 0.5);
        *o = vec3_sub(target, vec3_scale(*d, rng_int(r, -2, 3)));
    }
    if (kind == 0)
        *o = vec3_with(*o, axis, c);
}

static void draw_limits(rng *r, double *tmin, double *tmax)
{
    static const double mins[] = {0.0, 0.0, -1.0, 0.5, 1.0, -3.0};
    static const double spans[] = {INFINITY, INFINITY, 1.0, 2.0, 0.0, 0.5};
    *tmin = mins[rng_int(r, 0, 5)];
    *tmax = *tmin + spans[rng_int(r, 0, 5)];
}

static void test_random_special_cases_match_oracle(void **state)
{
    (void)state;
    rng r = rng_for(1);
    int hits[4] = {0}, total[4] = {0};
    for (int i = 0; i < 6000; i++) {
        int kind = i % 4, grid = rng_int(&r, 0, 3) != 0, axis = rng_int(&r, 0, 2);
        /* The plane's offset: a full mantissa, or a grid value. */
        double c = grid && rng_int(&r, 0, 1) ? draw(&r, 1) : rng_range(&r, -3, 3);
        vec3 tri[3], o, d;
        double tmin, tmax;
        draw_triangle(&r, kind, axis, c, grid, tri);
        draw_ray(&r, kind, axis, c, grid, tri, &o, &d);
        draw_limits(&r, &tmin, &tmax);
        total[kind]++;
        hits[kind] += check_against_oracle(o, d, tmin, tmax, tri, NULL);
    }
    printf("    touch hits: in-plane %d/%d, collinear %d/%d, point %d/%d, general %d/%d\n", hits[0], total[0],
           hits[1], total[1], hits[2], total[2], hits[3], total[3]);
    /* The draws are built to land on contacts: a run where a branch never hits tests
     * nothing there. */
    for (int k = 0; k < 4; k++)
        assert_true(hits[k] > total[k] / 10 && hits[k] < total[k]);
}

/* The same branches 1e9 away: grid features stay exact there (1e9 + k/4 is a double), and
 * the expansions keep every decision exact. */
static void test_random_special_cases_far_away(void **state)
{
    (void)state;
    rng r = rng_for(4);
    const vec3 far = pt(1e9, -2e9, 1e9);
    int hits = 0;
    for (int i = 0; i < 3000; i++) {
        int kind = i % 4, grid = rng_int(&r, 0, 3) != 0, axis = rng_int(&r, 0, 2);
        double c = grid ? draw(&r, 1) : rng_range(&r, -3, 3);
        vec3 tri[3], o, d;
        double tmin, tmax;
        draw_triangle(&r, kind, axis, c, grid, tri);
        draw_ray(&r, kind, axis, c, grid, tri, &o, &d);
        draw_limits(&r, &tmin, &tmax);
        for (int k = 0; k < 3; k++)
            tri[k] = vec3_add(tri[k], far);
        o = vec3_add(o, far);
        hits += check_against_oracle(o, d, tmin, tmax, tri, NULL);
    }
    printf("    far away: %d of 3000 touch\n", hits);
    assert_true(hits > 300 && hits < 2700);
}

/* A triangle of the given kind with a point exactly on the ray's line (o + s d on the
 * grid), lying in a coordinate plane that holds the line when kind is 0 and the ray allows. */
static void draw_triangle_on_ray(rng *r, int kind, vec3 o, vec3 d, vec3 tri[3])
{
    static const double steps[] = {-1.0, 0.0, 0.5, 1.0, 2.0, 3.0};
    vec3 on = vec3_add(o, vec3_scale(d, steps[rng_int(r, 0, 5)]));
    int axis = d.x == 0 ? 0 : d.y == 0 ? 1 : d.z == 0 ? 2 : -1;
    for (int i = 0; i < 3; i++) {
        tri[i] = draw_vec(r, 1);
        if (kind == 0 && axis >= 0)
            tri[i] = vec3_with(tri[i], axis, vec3_get(o, axis));
    }
    if (kind == 1) {
        double m = (double)rng_int(r, -2, 3) / 2;
        tri[2] = vec3_add(tri[0], vec3_scale(vec3_sub(tri[1], tri[0]), m));
    } else if (kind == 2) {
        tri[1] = tri[2] = tri[0];
    }
    /* Move the whole triangle so that one of its points (a vertex, or an edge's midpoint)
     * lands on the line; grid values keep every step exact. */
    vec3 anchor = rng_int(r, 0, 1) ? tri[rng_int(r, 0, 2)]
                                   : vec3_scale(vec3_add(tri[rng_int(r, 0, 2)], tri[rng_int(r, 0, 2)]), 0.5);
    vec3 shift = vec3_sub(on, anchor);
    for (int i = 0; i < 3; i++)
        tri[i] = vec3_add(tri[i], shift);
}

/* Pairs of triangles touched by one ray, of every kind: the exact order against the
 * oracle's, antisymmetric. */
static void test_random_pairs_ordered_as_oracle(void **state)
{
    (void)state;
    rng r = rng_for(2);
    int compared = 0, ties = 0;
    for (int i = 0; i < 20000 && compared < 2000; i++) {
        vec3 o = draw_vec(&r, 1), d = pt(rng_int(&r, -2, 2), rng_int(&r, -2, 2), rng_int(&r, -2, 2));
        if (rng_int(&r, 0, 1))
            d = vec3_with(d, rng_int(&r, 0, 2), 0.0); /* room for in-plane triangles */
        if (d.x == 0 && d.y == 0 && d.z == 0)
            continue;
        vec3 a[3], b[3];
        double tmin, tmax;
        draw_triangle_on_ray(&r, rng_int(&r, 0, 3), o, d, a);
        draw_triangle_on_ray(&r, rng_int(&r, 0, 3), o, d, b);
        draw_limits(&r, &tmin, &tmax);
        if (!check_against_oracle(o, d, tmin, tmax, a, NULL) || !check_against_oracle(o, d, tmin, tmax, b, NULL))
            continue;
        int got = ray_tri_touch_compare(o, d, tmin, tmax, a, b);
        int want = oracle_ray_tri_first_t_order(o, d, tmin, tmax, a, b);
        if (got != want)
            fail_msg("order %d, oracle %d: o (%a %a %a) d (%a %a %a) t [%a, %a]", got, want, o.x, o.y, o.z, d.x,
                     d.y, d.z, tmin, tmax);
        assert_int_equal(ray_tri_touch_compare(o, d, tmin, tmax, b, a), -got);
        compared++;
        ties += got == 0;
    }
    printf("    %d pairs compared, %d ties\n", compared, ties);
    assert_true(compared >= 1000 && ties > 0 && ties < compared);
}

/* Generic rays at generic triangles: the closed rule and the watertight one agree except
 * on boundaries, which full-mantissa draws essentially never reach. */
static void test_generic_cases_agree_with_crossing(void **state)
{
    (void)state;
    rng r = rng_for(3);
    int hits = 0;
    for (int i = 0; i < 3000; i++) {
        vec3 tri[3] = {draw_vec(&r, 0), draw_vec(&r, 0), draw_vec(&r, 0)};
        vec3 o = vec3_scale(draw_vec(&r, 0), 3);
        /* Aimed at a point near the triangle, so about half hit. */
        double a = rng_range(&r, -0.3, 1), b = rng_range(&r, -0.3, 1);
        vec3 at = vec3_add(tri[0], vec3_add(vec3_scale(vec3_sub(tri[1], tri[0]), a),
                                            vec3_scale(vec3_sub(tri[2], tri[0]), b)));
        vec3 d = vec3_sub(at, o);
        ray_tri_hit ht, hc;
        int t = check_against_oracle(o, d, 0, INFINITY, tri, &ht);
        int x = ray_tri_exact(o, d, 0, INFINITY, tri, &hc);
        assert_int_equal(t, x);
        if (t) {
            assert_true(ht.t == hc.t && ht.u == hc.u && ht.v == hc.v);
            hits++;
        }
    }
    printf("    %d of 3000 hit\n", hits);
    assert_true(hits > 500 && hits < 2500);
}

int main(void)
{
    const char *env = getenv("TRIOCT_SEED");
    if (env && *env)
        base_seed = strtoull(env, NULL, 0);
    printf("test_ray_touch: seed %#llx (set TRIOCT_SEED to rerun with another)\n", (unsigned long long)base_seed);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_in_plane_ray_enters_at_an_edge),
        cmocka_unit_test(test_in_plane_ray_missing_and_behind),
        cmocka_unit_test(test_in_plane_ray_touching_only_a_vertex),
        cmocka_unit_test(test_ray_through_shared_edge_touches_both),
        cmocka_unit_test(test_ray_through_fan_vertex_touches_all),
        cmocka_unit_test(test_zero_area_segment_crossed_missed_and_along),
        cmocka_unit_test(test_zero_area_point),
        cmocka_unit_test(test_origin_on_triangle_and_range_ends),
        cmocka_unit_test(test_huge_offsets_tiny_features),
        cmocka_unit_test(test_compare_orders_every_kind),
        cmocka_unit_test(test_random_special_cases_match_oracle),
        cmocka_unit_test(test_random_special_cases_far_away),
        cmocka_unit_test(test_random_pairs_ordered_as_oracle),
        cmocka_unit_test(test_generic_cases_agree_with_crossing),
    };
    return cmocka_run_group_tests_name("ray_touch", tests, NULL, NULL);
}
