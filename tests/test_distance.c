/* Point distances: one triangle's bounds (point_triangle_distance_bounds) and the octree's
 * nearest-first walk (octree_point_distance, _posed), against exact rational distances
 * (support/oracle_distance.c). Every answer's [lower, upper] must hold the real distance of
 * the double inputs, decided exactly; the walk must name the triangle a scan of every
 * triangle names; and the bound must stay small where the triangle's shape allows:
 * slivers, zero-area triangles, points on the surface, on edges and vertices, and
 * features 1e-9 across at 1e9 offsets. */
#include <float.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "engine.h"
#include "geom/point_distance.h"
#include "geom/tri_distance.h"
#include "support/meshgen.h"
#include "support/oracle_distance.h"

static uint64_t seed = 20261203;

/* [sqrt(lo2), sqrt(hi2)] rounded outward, as the walk reports them. */
static void bounds_of(const point_triangle_distance *r, double *lower, double *upper)
{
    interval lo = iv_sqrt_nonnegative((interval){r->lo2, r->lo2});
    interval hi = iv_sqrt_nonnegative((interval){r->hi2, r->hi2});
    *lower = lo.lo;
    *upper = hi.hi;
}

/* The real distance of p to v lies in [lower, upper], exactly. */
static void assert_encloses(vec3 p, const vec3 v[3], double lower, double upper)
{
    if (oracle_point_triangle_compare(p, v, lower) < 0 || oracle_point_triangle_compare(p, v, upper) > 0) {
        fprintf(stderr, "p (%.17g %.17g %.17g) tri (%.17g %.17g %.17g) (%.17g %.17g %.17g) (%.17g %.17g %.17g)\n"
                        "lower %.17g upper %.17g exact^2 %.17g\n",
                p.x, p.y, p.z, v[0].x, v[0].y, v[0].z, v[1].x, v[1].y, v[1].z, v[2].x, v[2].y, v[2].z, lower,
                upper, oracle_point_triangle_distance2(p, v, NULL));
        fail();
    }
}

static double max_norm_from(vec3 p, const vec3 v[3])
{
    double m = 0;
    for (int k = 0; k < 3; k++) {
        vec3 d = vec3_abs(vec3_sub(v[k], p));
        m = fmax(m, fmax(d.x, fmax(d.y, d.z)));
    }
    return m;
}

/* One triangle: enclosed, and (when tight is given) bound <= tight * scale. */
static void check_triangle(vec3 p, const vec3 v[3], double tight)
{
    point_triangle_distance r;
    point_triangle_distance_bounds(p, v, &r);
    double lower, upper;
    bounds_of(&r, &lower, &upper);
    assert_true(lower <= upper);
    assert_encloses(p, v, lower, upper);
    if (tight > 0 && !(upper - lower <= tight * max_norm_from(p, v))) {
        fprintf(stderr, "loose: lower %.17g upper %.17g scale %.3g\n", lower, upper, max_norm_from(p, v));
        fail();
    }
}

/* Cases whose answer is known by construction: distance, feature and its number. */
static void test_exact_answers(void **state)
{
    (void)state;
    const vec3 t[3] = {{0, 0, 0}, {4, 0, 0}, {0, 4, 0}};
    const struct {
        vec3 p;
        double distance;
        distance_feature feature;
        int index;
    } cases[] = {
        {{1, 1, 3}, 3, DISTANCE_FACE, 0},      /* above the face */
        {{1, 1, -0.5}, 0.5, DISTANCE_FACE, 0}, /* below it */
        {{1, 1, 0}, 0, DISTANCE_FACE, 0},      /* on it */
        {{2, -3, 0}, 3, DISTANCE_EDGE, 0},     /* beside edge 0, in the plane */
        {{2, -3, 4}, 5, DISTANCE_EDGE, 0},     /* beside edge 0, off the plane */
        {{-6, 2, 8}, 10, DISTANCE_EDGE, 2},    /* edge 2 joins v2 and v0 */
        {{-3, -4, 0}, 5, DISTANCE_VERTEX, 0},
        {{7, -4, 0}, 5, DISTANCE_VERTEX, 1},
        {{0, 7, 4}, 5, DISTANCE_VERTEX, 2},
        {{4, 0, 0}, 0, DISTANCE_VERTEX, 1},    /* on a vertex */
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        point_triangle_distance r;
        point_triangle_distance_bounds(cases[i].p, t, &r);
        double lower, upper;
        bounds_of(&r, &lower, &upper);
        assert_true(lower <= cases[i].distance && cases[i].distance <= upper);
        if (!(upper - lower <= 0x1p-44 * 10)) {
            fprintf(stderr, "case %zu: [%.17g, %.17g]\n", i, lower, upper);
            fail();
        }
        if (cases[i].distance > 0) {
            assert_int_equal(r.feature, cases[i].feature);
            assert_int_equal(r.index, cases[i].index);
        }
        assert_encloses(cases[i].p, t, lower, upper);
    }
    /* On an edge's interior: the distance is 0, and the bound is the rounding's only. */
    point_triangle_distance r;
    point_triangle_distance_bounds((vec3){2, 2, 0}, t, &r);
    assert_true(r.lo2 == 0 && r.hi2 <= 0x1p-90);
}

/* Random triangles and points at many scales and offsets: every answer enclosed, and
 * tight (a relative 2^-40 of the vertices' distance) for triangles that are not slivers. */
static void test_random_triangles(void **state)
{
    (void)state;
    rng r = rng_seeded(seed);
    for (int i = 0; i < 20000; i++) {
        double scale = ldexp(1.0, (int)rng_uniform(&r, -30, 30));
        vec3 offset = {0, 0, 0};
        if (i % 3 == 1)
            offset = (vec3){1e9, -1e9, 1e9};
        if (i % 3 == 2)
            offset = vec3_scale(rng_point_in_box(&r, (box3){{-1, -1, -1}, {1, 1, 1}}), 1e6);
        box3 unit = {{-1, -1, -1}, {1, 1, 1}};
        vec3 v[3];
        for (int k = 0; k < 3; k++)
            v[k] = vec3_add(offset, vec3_scale(rng_point_in_box(&r, unit), scale));
        vec3 p = vec3_add(offset, vec3_scale(rng_point_in_box(&r, unit), scale * (i % 2 ? 3 : 0.5)));
        /* A well-shaped triangle (smallest angle's sine above 0.1) must be tight. */
        vec3 e0 = vec3_sub(v[1], v[0]), e1 = vec3_sub(v[2], v[1]), e2 = vec3_sub(v[0], v[2]);
        double area2 = vec3_length(vec3_cross(e0, e2));
        double l0 = vec3_length(e0), l1 = vec3_length(e1), l2 = vec3_length(e2);
        double sine = fmin(area2 / (l0 * l2), fmin(area2 / (l0 * l1), area2 / (l1 * l2)));
        check_triangle(p, v, sine > 0.1 ? 0x1p-40 : 0);
    }
}

/* Zero-area triangles (a segment, a point, three collinear points), slivers, points on
 * the surface and by one step off it, and 1e-9 features at 1e9. */
static void test_hard_triangles(void **state)
{
    (void)state;
    const vec3 segment[3] = {{0, 0, 0}, {2, 2, 2}, {1, 1, 1}};
    const vec3 point[3] = {{1, 2, 3}, {1, 2, 3}, {1, 2, 3}};
    const vec3 doubled[3] = {{0, 0, 0}, {0, 0, 0}, {3, 0, 0}};
    const vec3 sliver[3] = {{0, 0, 0}, {1, 0, 0}, {0.5, 1e-12, 0}};
    const vec3 needle[3] = {{0, 0, 0}, {1e6, 0, 0}, {1e6, 1e-9, 1e-9}};
    /* 2^-20 across at 2^30 (about 1e-6 at 1e9; a double's step there is 2^-22). */
    const double F = 0x1p30, f = 0x1p-20;
    const vec3 far[3] = {{F, F, F}, {F + f, F, F}, {F, F + f, F}};
    const vec3 *tris[] = {segment, point, doubled, sliver, needle, far};
    rng r = rng_seeded(seed + 1);
    for (size_t t = 0; t < sizeof tris / sizeof tris[0]; t++) {
        const vec3 *v = tris[t];
        box3 b = {vec3_min(vec3_min(v[0], v[1]), v[2]), vec3_max(vec3_max(v[0], v[1]), v[2])};
        vec3 size = vec3_sub(b.hi, b.lo);
        double s = fmax(size.x, fmax(size.y, size.z));
        s = s > 0 ? s : 1;
        box3 around = {vec3_sub(b.lo, (vec3){s, s, s}), vec3_add(b.hi, (vec3){s, s, s})};
        for (int i = 0; i < 2000; i++)
            check_triangle(rng_point_in_box(&r, around), v, 0);
        /* Points on it (its vertices, edge midpoints) and one step off them. */
        for (int k = 0; k < 3; k++) {
            vec3 on = v[k], mid = vec3_scale(vec3_add(v[k], v[(k + 1) % 3]), 0.5);
            check_triangle(on, v, 0);
            check_triangle(mid, v, 0);
            check_triangle((vec3){nextafter(mid.x, INFINITY), mid.y, nextafter(mid.z, -INFINITY)}, v, 0);
            point_triangle_distance d;
            point_triangle_distance_bounds(on, v, &d);
            assert_true(d.lo2 == 0);
        }
    }
    /* A point 2^-20 above the far triangle: its differences from the vertices are exact,
     * so the bound is the arithmetic's alone, far below the feature's size. */
    vec3 p = {F + f / 4, F + f / 4, F + f};
    point_triangle_distance d;
    point_triangle_distance_bounds(p, far, &d);
    double lower, upper;
    bounds_of(&d, &lower, &upper);
    assert_encloses(p, far, lower, upper);
    assert_true(lower <= f && f <= upper);
    assert_true(upper - lower < f * 0x1p-45);
    assert_int_equal(d.feature, DISTANCE_FACE);
}

/* The smallest squared upper bound over every triangle, with the smallest id on ties:
 * what the walk must name. */
static void scan(const mesh_data *m, vec3 p, point_triangle_distance *best, uint32_t *id)
{
    *best = (point_triangle_distance){INFINITY, INFINITY, DISTANCE_FACE, 0, {0, 0, 0}};
    *id = UINT32_MAX;
    for (size_t i = 0; i < m->triangle_count; i++) {
        vec3 v[3];
        for (int k = 0; k < 3; k++)
            v[k] = m->vertices[m->indices[3 * i + k]];
        point_triangle_distance r;
        point_triangle_distance_bounds(p, v, &r);
        if (r.hi2 < best->hi2) {
            *best = r;
            *id = (uint32_t)i;
        }
    }
}

/* The real distance to the mesh lies in [lower, upper]: no triangle is nearer than lower
 * (those whose box is not surely farther are checked exactly) and the named one is within
 * upper. */
static void assert_mesh_encloses(const mesh_data *m, vec3 p, const distance_output *out)
{
    vec3 v[3];
    for (int k = 0; k < 3; k++)
        v[k] = m->vertices[m->indices[3 * out->triangle + k]];
    assert_true(oracle_point_triangle_compare(p, v, out->upper) <= 0);
    for (size_t i = 0; i < m->triangle_count; i++) {
        box3 b = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
        for (int k = 0; k < 3; k++) {
            v[k] = m->vertices[m->indices[3 * i + k]];
            b.lo = vec3_min(b.lo, v[k]);
            b.hi = vec3_max(b.hi, v[k]);
        }
        vec3 gap = vec3_max(vec3_max(vec3_sub(b.lo, p), vec3_sub(p, b.hi)), (vec3){0, 0, 0});
        if (vec3_length(gap) * (1 - 1e-9) > out->lower)
            continue;
        assert_true(oracle_point_triangle_compare(p, v, out->lower) >= 0);
    }
}

/* boxes: 0 none, 1 triangle boxes, 2 triangle boxes and node slabs. */
static octree *build(const mesh_data *m, int boxes)
{
    mesh_view view = mesh_data_view(m);
    octree_def def = octree_default_def();
    def.triangle_boxes = boxes >= 1;
    def.node_slabs = boxes >= 2;
    octree_error err;
    octree *t = octree_build(&view, &def, &err);
    assert_non_null(t);
    return t;
}

static void check_walk(const mesh_data *m, int points, double spread, uint64_t s)
{
    for (int boxes = 0; boxes <= 2; boxes++) {
        octree *tree = build(m, boxes);
        rng r = rng_seeded(s);
        box3 b = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
        for (size_t i = 0; i < m->vertex_count; i++) {
            b.lo = vec3_min(b.lo, m->vertices[i]);
            b.hi = vec3_max(b.hi, m->vertices[i]);
        }
        vec3 size = vec3_scale(vec3_sub(b.hi, b.lo), spread);
        box3 around = {vec3_sub(b.lo, size), vec3_add(b.hi, size)};
        for (int i = 0; i < points; i++) {
            /* Random points, and every fifth one a vertex or an edge midpoint. */
            vec3 p = rng_point_in_box(&r, around);
            if (i % 5 == 4) {
                size_t t = rng_next(&r) % m->triangle_count;
                vec3 a = m->vertices[m->indices[3 * t]], c = m->vertices[m->indices[3 * t + 1]];
                p = i % 2 ? a : vec3_scale(vec3_add(a, c), 0.5);
            }
            distance_output out;
            query_stats stats = {0};
            assert_int_equal(octree_point_distance(tree, p, INFINITY, &out, &stats), OCTREE_OK);
            assert_true(out.found);
            point_triangle_distance best;
            uint32_t id;
            scan(m, p, &best, &id);
            double lower, upper;
            bounds_of(&best, &lower, &upper);
            assert_int_equal(out.triangle, id);
            assert_true(out.upper == upper);
            assert_true(out.lower <= out.distance && out.distance <= out.upper);
            assert_true(out.distance - out.bound <= out.lower && out.distance + out.bound >= out.upper);
            assert_int_equal(out.feature, best.feature);
            assert_mesh_encloses(m, p, &out);
            /* Pruning works: a point off the surface bounds few triangles. (On the surface,
             * every triangle through the point is a candidate, and many may be.) */
            if (out.lower > 0 && !(stats.candidates_tested < m->triangle_count / 2)) {
                fprintf(stderr, "%llu candidates of %zu triangles, p %.17g %.17g %.17g, d %g, boxes %d\n",
                        (unsigned long long)stats.candidates_tested, m->triangle_count, p.x, p.y, p.z, out.distance, boxes);
                fail();
            }

            /* A radius below the distance finds nothing only when every triangle is
             * proven farther; at the upper bound it always finds the answer. */
            distance_output near;
            assert_int_equal(octree_point_distance(tree, p, out.upper, &near, NULL), OCTREE_OK);
            assert_true(near.found && near.triangle == out.triangle && near.upper == out.upper);
            if (out.lower > 0) {
                double below = out.lower * 0.5;
                assert_int_equal(octree_point_distance(tree, p, below, &near, NULL), OCTREE_OK);
                assert_false(near.found);
            }
        }
        octree_free(tree);
    }
}

static void test_walk_matches_scan(void **state)
{
    (void)state;
    box3 region = {{-10, -10, -10}, {10, 10, 10}};
    mesh_data soup = meshgen_soup(seed, 3000, region, 1.0);
    check_walk(&soup, 300, 0.2, seed + 2);
    mesh_data_free(&soup);
    mesh_data sphere = meshgen_icosphere((vec3){1, 2, 3}, 5, 3);
    check_walk(&sphere, 300, 0.5, seed + 3);
    mesh_data_free(&sphere);
    /* Faces on node faces, coplanar neighbours, grid coordinates: ties everywhere. */
    mesh_data blocks = meshgen_blocks(seed, 4, 4, 3, 1.0);
    check_walk(&blocks, 300, 0.3, seed + 4);
    mesh_data_free(&blocks);
    mesh_data terrain = meshgen_terrain(seed, region, 30, 30);
    check_walk(&terrain, 300, 0.3, seed + 5);
    /* The same at a 1e9 offset, and scaled down to 1e-6. */
    mesh_data far = meshgen_transformed(&terrain, 1.0, (vec3){1e9, -1e9, 1e9});
    check_walk(&far, 200, 0.3, seed + 6);
    mesh_data_free(&far);
    mesh_data tiny = meshgen_transformed(&terrain, 1e-6, (vec3){0, 0, 0});
    check_walk(&tiny, 200, 0.3, seed + 7);
    mesh_data_free(&tiny);
    mesh_data_free(&terrain);
}

/* A tree placed by a pose answers as a tree of the posed vertices: the same triangle and
 * upper bound, and a lower bound that holds. */
static void test_posed_matches_built(void **state)
{
    (void)state;
    mesh_data torus = meshgen_torus((vec3){0.5, -0.25, 1}, 4, 1, 24, 12);
    octree *local = build(&torus, 2);
    rng r = rng_seeded(seed + 8);
    for (int n = 0; n < 8; n++) {
        vec3 axis = rng_unit_vector(&r);
        double angle = rng_uniform(&r, -3, 3);
        vec3 t = n % 2 ? (vec3){1e6, 2e6, -3e6} : (vec3){1, -2, 0.5};
        pose at;
        assert_int_equal(octree_pose_from_quaternion(t, cos(angle / 2), axis.x * sin(angle / 2),
                                                     axis.y * sin(angle / 2), axis.z * sin(angle / 2), &at),
                         OCTREE_OK);
        mesh_data placed = meshgen_transformed(&torus, 1.0, (vec3){0, 0, 0});
        for (size_t i = 0; i < placed.vertex_count; i++)
            placed.vertices[i] = octree_pose_point(&at, torus.vertices[i]);
        octree *built = build(&placed, 1);
        for (int i = 0; i < 100; i++) {
            vec3 p = vec3_add(t, vec3_scale(rng_point_in_box(&r, (box3){{-1, -1, -1}, {1, 1, 1}}), 8));
            if (i % 10 == 9)
                p = placed.vertices[rng_next(&r) % placed.vertex_count];
            distance_output a, b;
            assert_int_equal(octree_point_distance_posed(local, &at, p, INFINITY, &a, NULL), OCTREE_OK);
            assert_int_equal(octree_point_distance(built, p, INFINITY, &b, NULL), OCTREE_OK);
            assert_true(a.found && b.found);
            assert_int_equal(a.triangle, b.triangle);
            assert_true(a.upper == b.upper);
            assert_mesh_encloses(&placed, p, &a);
        }
        octree_free(built);
        mesh_data_free(&placed);
    }
    octree_free(local);
    mesh_data_free(&torus);
}

/* triangle_pair_distance_within at a search radius: the full bounds when it says within,
 * and always within a radius at or past the upper bound; when it says farther, a lower
 * bound past the radius that the exact distance is not below. */
static void check_within(const vec3 a[3], const vec3 b[3], const triangle_pair_distance *full, double limit2)
{
    triangle_pair_distance w;
    if (triangle_pair_distance_within(a, b, limit2, &w)) {
        assert_true(w.lo2 == full->lo2 && w.hi2 == full->hi2 && w.lo2 <= limit2);
        return;
    }
    assert_true(limit2 < full->hi2 && w.lo2 > limit2);
    assert_true(oracle_triangle_pair_compare(a, b, iv_sqrt_nonnegative((interval){w.lo2, w.lo2}).lo) >= 0);
}

/* Two triangles: enclosed exactly, and (when tight is given) upper - lower within
 * tight times the pair's extent; and the same bounds at search radii about them. */
static void check_pair(const vec3 a[3], const vec3 b[3], double tight)
{
    triangle_pair_distance r;
    triangle_pair_distance_bounds(a, b, &r);
    const double radii[] = {0.25 * r.lo2, r.lo2 * (1 - 0x1p-30), r.lo2, r.hi2, 2 * r.hi2};
    for (int k = 0; k < 5; k++)
        check_within(a, b, &r, radii[k]);
    double lower = iv_sqrt_nonnegative((interval){r.lo2, r.lo2}).lo;
    double upper = iv_sqrt_nonnegative((interval){r.hi2, r.hi2}).hi;
    if (!(lower <= upper) || oracle_triangle_pair_compare(a, b, lower) < 0 ||
        oracle_triangle_pair_compare(a, b, upper) > 0) {
        fprintf(stderr, "a (%.17g %.17g %.17g) (%.17g %.17g %.17g) (%.17g %.17g %.17g)\n"
                        "b (%.17g %.17g %.17g) (%.17g %.17g %.17g) (%.17g %.17g %.17g)\n"
                        "lower %.17g upper %.17g exact^2 %.17g\n",
                a[0].x, a[0].y, a[0].z, a[1].x, a[1].y, a[1].z, a[2].x, a[2].y, a[2].z, b[0].x, b[0].y, b[0].z,
                b[1].x, b[1].y, b[1].z, b[2].x, b[2].y, b[2].z, lower, upper, oracle_triangle_pair_distance2(a, b));
        fail();
    }
    if (tight > 0) {
        double m = 0;
        for (int k = 0; k < 3; k++)
            m = fmax(m, fmax(max_norm_from(a[k], b), max_norm_from(b[k], a)));
        if (!(upper - lower <= tight * m)) {
            fprintf(stderr, "loose pair: lower %.17g upper %.17g extent %.3g exact %.17g\n", lower, upper, m,
                    sqrt(oracle_triangle_pair_distance2(a, b)));
            fprintf(stderr, "a (%.17g %.17g %.17g) (%.17g %.17g %.17g) (%.17g %.17g %.17g)\n"
                            "b (%.17g %.17g %.17g) (%.17g %.17g %.17g) (%.17g %.17g %.17g)\n",
                    a[0].x, a[0].y, a[0].z, a[1].x, a[1].y, a[1].z, a[2].x, a[2].y, a[2].z, b[0].x, b[0].y, b[0].z,
                    b[1].x, b[1].y, b[1].z, b[2].x, b[2].y, b[2].z);
            fail();
        }
    }
}

static int well_shaped(const vec3 v[3])
{
    vec3 e0 = vec3_sub(v[1], v[0]), e1 = vec3_sub(v[2], v[1]), e2 = vec3_sub(v[0], v[2]);
    double area2 = vec3_length(vec3_cross(e0, e2));
    double l0 = vec3_length(e0), l1 = vec3_length(e1), l2 = vec3_length(e2);
    return fmin(area2 / (l0 * l2), fmin(area2 / (l0 * l1), area2 / (l1 * l2))) > 0.1;
}

/* Random pairs at many scales and offsets, apart (tight unless nearly touching) and
 * crossing (exactly 0). */
static void test_random_pairs(void **state)
{
    (void)state;
    rng r = rng_seeded(seed + 10);
    box3 unit = {{-1, -1, -1}, {1, 1, 1}};
    for (int i = 0; i < 6000; i++) {
        double scale = ldexp(1.0, (int)rng_uniform(&r, -20, 20));
        vec3 offset = i % 3 == 1 ? (vec3){1e9, -1e9, 1e9} : (vec3){0, 0, 0};
        vec3 shift = vec3_scale(rng_point_in_box(&r, unit), scale * (i % 2 ? 4 : 1));
        vec3 a[3], b[3];
        for (int k = 0; k < 3; k++) {
            a[k] = vec3_add(offset, vec3_scale(rng_point_in_box(&r, unit), scale));
            b[k] = vec3_add(vec3_add(offset, shift), vec3_scale(rng_point_in_box(&r, unit), scale));
        }
        vec3 pa, pb;
        double d2 = triangle_pair_distance_estimate(a, b, &pa, &pb);
        /* Tight when apart by more than a millionth of the size (nearer, the gap's
         * direction is itself a rounding: still enclosed, with a bound of that size). */
        int apart = sqrt(d2) > 1e-6 * scale;
        check_pair(a, b, apart && well_shaped(a) && well_shaped(b) ? 0x1p-36 : 0);
    }
}

/* Pairs built to be hard: a shared vertex, a shared edge, coplanar overlap and coplanar
 * apart, parallel faces, parallel and crossing edges, rotated copies whose edges are
 * parallel only to rounding, zero-area triangles, and the same at 2^30. */
static void test_hard_pairs(void **state)
{
    (void)state;
    const vec3 t[3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    struct {
        vec3 b[3];
        double distance; /* exact; -1 when only enclosure is checked */
    } cases[] = {
        {{{0, 0, 0}, {-1, 0, 0}, {0, -1, 0}}, 0},        /* a shared vertex */
        {{{1, 0, 0}, {0, 1, 0}, {1, 1, 0}}, 0},          /* a shared edge, coplanar */
        {{{1, 0, 0}, {0, 1, 0}, {1, 1, 1}}, 0},          /* a shared edge, folded */
        {{{0.25, 0.25, 0}, {2, 0.25, 0}, {0.25, 2, 0}}, 0}, /* coplanar overlap */
        {{{2, 0, 0}, {3, 0, 0}, {2, 1, 0}}, 1},          /* coplanar apart, vertex to vertex */
        {{{0, 0, 2}, {1, 0, 2}, {0, 1, 2}}, 2},          /* parallel faces */
        {{{0.25, 0.25, 3}, {0.5, 0.25, 3}, {0.25, 0.5, 5}}, 3}, /* a vertex above the face */
        {{{0.5, -1, 1}, {0.5, 1, 1}, {0.5, 0, 5}}, -1},  /* an edge across, above */
        {{{2, 0, 0}, {3, 0, 0}, {3, 0, 0}}, 1},          /* a segment (zero area) */
        {{{-2, -2, 0}, {-2, -2, 0}, {-2, -2, 0}}, -1},   /* a point */
        {{{0.25, 0.25, -1}, {0.25, 0.25, 1}, {0.3, 0.3, 1}}, 0}, /* piercing */
        {{{0, -1, 0.5}, {0, 1, 0.5}, {0, 0, 1}}, 0.5},   /* parallel edges */
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        for (int scaled = 0; scaled < 3; scaled++) {
            /* As built, at a 2^30 offset, and shrunk by 2^-40: all exact. */
            vec3 a[3], b[3];
            double f = scaled == 2 ? 0x1p-40 : 1, o = scaled == 1 ? 0x1p30 : 0;
            for (int k = 0; k < 3; k++) {
                a[k] = (vec3){t[k].x * f + o, t[k].y * f - o, t[k].z * f + o};
                b[k] = (vec3){cases[i].b[k].x * f + o, cases[i].b[k].y * f - o, cases[i].b[k].z * f + o};
            }
            check_pair(a, b, 0);
            check_pair(b, a, 0);
            if (cases[i].distance >= 0) {
                triangle_pair_distance r;
                triangle_pair_distance_bounds(a, b, &r);
                double want = cases[i].distance * f;
                double lower = sqrt(r.lo2), upper = sqrt(r.hi2);
                assert_true(fabs(lower - want) <= 0x1p-40 * fmax(f, o) && fabs(upper - want) <= 0x1p-40 * fmax(f, o));
                if (cases[i].distance == 0)
                    assert_true(r.lo2 == 0 && r.hi2 == 0);
            }
        }
    }
    /* Two copies of a box's face triangles rotated alike and set apart: their edges are
     * parallel only to rounding, and the bound must still be tight. */
    rng r = rng_seeded(seed + 11);
    for (int i = 0; i < 500; i++) {
        vec3 axis = rng_unit_vector(&r);
        double angle = rng_uniform(&r, -3, 3);
        pose at;
        assert_int_equal(octree_pose_from_quaternion((vec3){0, 0, 0}, cos(angle / 2), axis.x * sin(angle / 2),
                                                     axis.y * sin(angle / 2), axis.z * sin(angle / 2), &at),
                         OCTREE_OK);
        const vec3 face[3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}};
        vec3 lift = {rng_uniform(&r, -0.5, 0.5), rng_uniform(&r, -0.5, 0.5), i % 2 ? 0.25 : 1e-3};
        vec3 a[3], b[3];
        for (int k = 0; k < 3; k++) {
            a[k] = octree_pose_point(&at, face[k]);
            b[k] = octree_pose_point(&at, vec3_add(face[k], lift));
        }
        check_pair(a, b, 0x1p-36);
    }
}

/* slabs: also the owned lists and slabs a distance world's shapes get, which the walk
 * reads in place of the leaf lists. */
static octree *build_shape(const mesh_data *m, int slabs)
{
    mesh_view view = mesh_data_view(m);
    octree_def def = octree_default_def();
    def.node_bounds = 1;
    def.node_slabs = slabs;
    octree_error err;
    octree *t = octree_build(&view, &def, &err);
    assert_non_null(t);
    return t;
}

static void mesh_triangle(const mesh_data *m, size_t i, const pose *at, vec3 out[3])
{
    for (int k = 0; k < 3; k++) {
        out[k] = m->vertices[m->indices[3 * i + k]];
        if (at)
            out[k] = octree_pose_point(at, out[k]);
    }
}

/* One placed shape against a (placed) world: the walk names the pair a scan of every pair
 * names, with its upper bound to the bit; no pair is nearer than the lower bound (the
 * pairs whose boxes are not surely farther are checked exactly); clearance agrees. */
static void check_shape(const octree *world, const mesh_data *wm, const pose *world_at, const octree *shape,
                        const mesh_data *sm, const pose *shape_at)
{
    shape_distance_output out;
    query_stats stats = {0};
    assert_int_equal(octree_shape_distance(world, world_at, shape, shape_at, INFINITY, &out, &stats), OCTREE_OK);
    assert_true(out.found);
    double best = INFINITY;
    uint32_t bw = 0, bs = 0;
    vec3 a[3], b[3];
    for (size_t i = 0; i < wm->triangle_count; i++) {
        mesh_triangle(wm, i, world_at, a);
        for (size_t j = 0; j < sm->triangle_count; j++) {
            mesh_triangle(sm, j, shape_at, b);
            triangle_pair_distance r;
            triangle_pair_distance_bounds(a, b, &r);
            if (r.hi2 < best) {
                best = r.hi2;
                bw = (uint32_t)i;
                bs = (uint32_t)j;
            }
        }
    }
    if (best == 0) {
        /* Touching: distance 0 exactly, and the pair named (the first touching pair the
         * walk met) touches. */
        assert_true(out.lower == 0 && out.upper == 0);
        mesh_triangle(wm, out.world_triangle, world_at, a);
        mesh_triangle(sm, out.shape_triangle, shape_at, b);
        assert_true(oracle_tri_tri(a, b));
        return;
    }
    assert_int_equal(out.world_triangle, bw);
    assert_int_equal(out.shape_triangle, bs);
    assert_true(out.upper == iv_sqrt_nonnegative((interval){best, best}).hi);
    assert_true(out.lower <= out.distance && out.distance <= out.upper);
    assert_true(out.distance - out.bound <= out.lower && out.distance + out.bound >= out.upper);
    mesh_triangle(wm, bw, world_at, a);
    mesh_triangle(sm, bs, shape_at, b);
    assert_true(oracle_triangle_pair_compare(a, b, out.upper) <= 0);
    size_t exact = 0;
    for (size_t i = 0; i < wm->triangle_count; i++) {
        mesh_triangle(wm, i, world_at, a);
        box3 ba = {vec3_min(vec3_min(a[0], a[1]), a[2]), vec3_max(vec3_max(a[0], a[1]), a[2])};
        for (size_t j = 0; j < sm->triangle_count; j++) {
            mesh_triangle(sm, j, shape_at, b);
            box3 bb = {vec3_min(vec3_min(b[0], b[1]), b[2]), vec3_max(vec3_max(b[0], b[1]), b[2])};
            vec3 gap = vec3_max(vec3_max(vec3_sub(ba.lo, bb.hi), vec3_sub(bb.lo, ba.hi)), (vec3){0, 0, 0});
            if (vec3_length(gap) * (1 - 1e-9) > out.lower)
                continue;
            exact++;
            assert_true(oracle_triangle_pair_compare(a, b, out.lower) >= 0);
        }
    }
    assert_true(exact >= 1);
    if (!(stats.candidates_tested < wm->triangle_count * sm->triangle_count / 2 || out.lower == 0)) {
        fprintf(stderr, "%llu candidates of %zu x %zu, distance %g, nodes %llu\n",
                (unsigned long long)stats.candidates_tested, wm->triangle_count, sm->triangle_count, out.distance,
                (unsigned long long)stats.nodes_visited);
        fail();
    }
    /* Clearance: clear below the lower bound, never at or above the upper one. */
    int clear;
    if (out.lower > 0) {
        assert_int_equal(octree_shape_clearance(world, world_at, shape, shape_at, out.lower * 0.999, &clear, NULL),
                         OCTREE_OK);
        assert_true(clear);
        shape_distance_output none;
        assert_int_equal(octree_shape_distance(world, world_at, shape, shape_at, out.lower * 0.5, &none, NULL),
                         OCTREE_OK);
        assert_false(none.found);
    }
    assert_int_equal(octree_shape_clearance(world, world_at, shape, shape_at, out.upper, &clear, NULL), OCTREE_OK);
    assert_false(clear);
}

static pose random_pose(rng *r, vec3 t)
{
    vec3 axis = rng_unit_vector(r);
    double angle = rng_uniform(r, -3, 3);
    pose at;
    assert_int_equal(octree_pose_from_quaternion(t, cos(angle / 2), axis.x * sin(angle / 2), axis.y * sin(angle / 2),
                                                 axis.z * sin(angle / 2), &at),
                     OCTREE_OK);
    return at;
}

/* Shapes near, touching and inside worlds, placed by random poses and exact quarter
 * turns, the world itself placed or not, and at a 1e6 offset; each shape as a tree with
 * leaf lists alone and with owned lists and slabs, against worlds of either kind. */
static void test_shape_distance(void **state)
{
    (void)state;
    rng r = rng_seeded(seed + 20);
    mesh_data sphere = meshgen_icosphere((vec3){0, 0, 0}, 0.5, 1);
    mesh_data box = meshgen_box((box3){{-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5}});
    octree *sphere_trees[2] = {build_shape(&sphere, 0), build_shape(&sphere, 1)};
    octree *box_trees[2] = {build_shape(&box, 0), build_shape(&box, 1)};
    box3 region = {{-4, -4, -1}, {4, 4, 1}};
    mesh_data terrain = meshgen_terrain(seed, region, 12, 12);
    mesh_data blocks = meshgen_blocks(seed, 3, 3, 2, 1.0);
    const mesh_data *worlds[] = {&terrain, &blocks};
    for (int wi = 0; wi < 2; wi++) {
        const mesh_data *wm = worlds[wi];
        octree *world = build(wm, 1 + wi);
        box3 wb = mesh_data_bounds(wm);
        for (int i = 0; i < 24; i++) {
            vec3 t = rng_point_in_box(&r, (box3){vec3_sub(wb.lo, (vec3){1, 1, 1}), vec3_add(wb.hi, (vec3){1, 1, 1})});
            pose at = random_pose(&r, t);
            if (i % 4 == 3) /* a quarter turn: faces parallel to the blocks' */
                at = (pose){{0, -1, 0, 1, 0, 0, 0, 0, 1}, {floor(t.x) + 0.5, floor(t.y) + 0.5, wb.hi.z + 0.5 + (i % 8 == 3)}};
            for (int slabs = 0; slabs < 2; slabs++)
                check_shape(world, wm, NULL, i % 2 ? sphere_trees[slabs] : box_trees[slabs], i % 2 ? &sphere : &box,
                            &at);
        }
        /* The world placed too, far from the origin. */
        pose wat = random_pose(&r, (vec3){1e6, -1e6, 5});
        for (int i = 0; i < 8; i++) {
            vec3 local = rng_point_in_box(&r, wb);
            pose at = random_pose(&r, octree_pose_point(&wat, local));
            for (int slabs = 0; slabs < 2; slabs++)
                check_shape(world, wm, &wat, i % 2 ? sphere_trees[slabs] : box_trees[slabs], i % 2 ? &sphere : &box,
                            &at);
        }
        octree_free(world);
    }
    mesh_data_free(&terrain);
    mesh_data_free(&blocks);
    for (int slabs = 0; slabs < 2; slabs++) {
        octree_free(sphere_trees[slabs]);
        octree_free(box_trees[slabs]);
    }
    mesh_data_free(&sphere);
    mesh_data_free(&box);
}

static void test_bad_input(void **state)
{
    (void)state;
    mesh_data m = meshgen_box((box3){{0, 0, 0}, {1, 1, 1}});
    octree *tree = build(&m, 0);
    distance_output out;
    assert_int_equal(octree_point_distance(tree, (vec3){NAN, 0, 0}, INFINITY, &out, NULL), OCTREE_ERR_NONFINITE);
    assert_int_equal(octree_point_distance(tree, (vec3){INFINITY, 0, 0}, INFINITY, &out, NULL),
                     OCTREE_ERR_NONFINITE);
    assert_int_equal(octree_point_distance(tree, (vec3){0, 0, 0}, -1, &out, NULL), OCTREE_ERR_INVALID);
    assert_int_equal(octree_point_distance(tree, (vec3){0, 0, 0}, NAN, &out, NULL), OCTREE_ERR_INVALID);
    pose bad = {{2, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0}};
    assert_int_equal(octree_point_distance_posed(tree, &bad, (vec3){0, 0, 0}, INFINITY, &out, NULL),
                     OCTREE_ERR_INVALID);
    /* A point at the far end of the double range: the answer still holds. */
    assert_int_equal(octree_point_distance(tree, (vec3){1e300, -1e300, 1e300}, INFINITY, &out, NULL), OCTREE_OK);
    assert_true(out.found && out.lower <= 1.8e300 && out.upper >= 1.7e300);
    octree_free(tree);
    mesh_data_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exact_answers),
        cmocka_unit_test(test_random_triangles),
        cmocka_unit_test(test_hard_triangles),
        cmocka_unit_test(test_random_pairs),
        cmocka_unit_test(test_hard_pairs),
        cmocka_unit_test(test_walk_matches_scan),
        cmocka_unit_test(test_posed_matches_built),
        cmocka_unit_test(test_shape_distance),
        cmocka_unit_test(test_bad_input),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
