/* Per-triangle boxes (octree_def.triangle_boxes): the float bounds enclose exactly, the
 * memory is what info reports, and triangle and mesh queries answer the same with boxes as
 * without, in every mode, including contacts exactly on a box face. */
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
#include <gmp.h>

#include "engine.h"
#include "geom/tri_tri.h"
#include "octree/octree_internal.h"
#include "support/brute_force.h"
#include "support/hard_cases.h"
#include "support/meshgen.h"

static uint64_t base_seed = 20261121;

static const accuracy_mode modes[] = {ACCURACY_EXACT, ACCURACY_SEED, ACCURACY_FAST};

static octree *build_with(const mesh_view *v, double resolution, accuracy_mode mode, int boxes)
{
    octree_def def = octree_default_def();
    def.resolution = resolution;
    def.mode = mode;
    def.triangle_boxes = boxes;
    octree_error err;
    octree *t = octree_build(v, &def, &err);
    if (!t)
        fail_msg("build failed: %s", err.message);
    return t;
}

/* ---------- the float bounds ---------- */

/* Compares o + f with x exactly: -1, 0 or 1. f may be infinite. */
static int compare_offset(double o, float f, double x)
{
    if (isinf(f))
        return f < 0 ? -1 : 1;
    mpq_t a, b;
    mpq_inits(a, b, NULL);
    mpq_set_d(a, o);
    mpq_set_d(b, (double)f);
    mpq_add(a, a, b);
    mpq_set_d(b, x);
    int c = mpq_cmp(a, b);
    mpq_clears(a, b, NULL);
    return (c > 0) - (c < 0);
}

/* lo is the largest float with o + lo <= x, hi the smallest with o + hi >= x (and
 * float_bounds_of_difference gives both); past the
 * float range the bound is the extreme float on the safe side or an infinity. */
static void check_bounds(double x, double o)
{
    float lo = float_below_difference(x, o), hi = float_above_difference(x, o);
    /* The ray setup takes both at once: the same floats, to the bit. */
    float both_lo, both_hi;
    float_bounds_of_difference(x, o, &both_lo, &both_hi);
    if (memcmp(&both_lo, &lo, sizeof lo) != 0 || memcmp(&both_hi, &hi, sizeof hi) != 0)
        fail_msg("x %a, o %a: bounds taken together %a, %a, apart %a, %a", x, o, (double)both_lo, (double)both_hi,
                 (double)lo, (double)hi);
    if (compare_offset(o, lo, x) > 0 || compare_offset(o, hi, x) < 0)
        fail_msg("x %a, o %a: bounds %a, %a do not enclose", x, o, (double)lo, (double)hi);
    if (isfinite(lo) && lo < FLT_MAX && compare_offset(o, nextafterf(lo, INFINITY), x) <= 0)
        fail_msg("x %a, o %a: lower bound %a is not the largest", x, o, (double)lo);
    if (isfinite(hi) && hi > -FLT_MAX && compare_offset(o, nextafterf(hi, -INFINITY), x) >= 0)
        fail_msg("x %a, o %a: upper bound %a is not the smallest", x, o, (double)hi);
    if (isinf(lo))
        assert_true(compare_offset(o, -FLT_MAX, x) > 0);
    if (isinf(hi))
        assert_true(compare_offset(o, FLT_MAX, x) < 0);
}

static void test_float_bounds_enclose_and_are_tight(void **state)
{
    (void)state;
    static const double values[] = {
        0.0, -0.0, 0.1, -0.1, 1.0 / 3.0, 0.2, 0.3, 1e9 + 0.1, -1e9 - 0.1, 5e6 + 0.3, 1.0, 0x1p-60, -0x1p-60,
        0x1p-1074, 1e-310, 1e-40, 3e38, 0x1.fffffefffffffp127, 0x1.ffffffp127, 0x1p128, 1e300, -1e300, DBL_MAX,
        -DBL_MAX, 16777217.0, 0.7,
    };
    size_t n = sizeof values / sizeof values[0];
    /* Every pair, so that x - o rounds in both directions, lands on floats and between
     * them, underflows and overflows the float range. */
    for (size_t i = 0; i < n; i++)
        for (size_t j = 0; j < n; j++)
            if (isfinite(values[i] - values[j]))
                check_bounds(values[i], values[j]);
    /* The rounded difference is a float while the real one is not: 1 - (-2^-60) rounds to
     * 1.0, so the upper bound must step up past it, and 1 - 2^-60 the lower one down. */
    assert_true(float_above_difference(1.0, -0x1p-60) == nextafterf(1.0f, 2.0f));
    assert_true(float_below_difference(1.0, -0x1p-60) == 1.0f);
    assert_true(float_below_difference(1.0, 0x1p-60) == nextafterf(1.0f, 0.0f));
    assert_true(float_above_difference(1.0, 0x1p-60) == 1.0f);

    rng r = rng_seeded(base_seed + 40);
    for (int i = 0; i < 200000; i++) {
        double o = ldexp(rng_uniform(&r, -1, 1), (int)(rng_next(&r) % 80) - 40);
        double x = o + ldexp(rng_uniform(&r, -1, 1), (int)(rng_next(&r) % 80) - 40);
        if (i % 3 == 0)
            x = 1e9 + rng_uniform(&r, -1, 1), o = 1e9 - rng_uniform(&r, 0, 1e3);
        check_bounds(x, o);
    }
}

/* The loose bounds a filter takes: at or below (above) y exactly, NaN and the far range
 * on the safe side, and within a few float steps of the tight bound. */
static void check_loose(double y)
{
    float lo = float_below_loosely(y), hi = float_above_loosely(y);
    if (!((double)lo <= y) || !((double)hi >= y))
        fail_msg("y %a: loose bounds %a, %a do not enclose", y, (double)lo, (double)hi);
    float tight_lo = float_at_or_below(y), tight_hi = float_at_or_above(y);
    if (fabs(y) <= 0x1p100) {
        /* Two steps of the float grid at y at most: 2^-22 of |y| covers them, 2^-147 the
         * subnormal ones. */
        float step = (float)(fabs(y) * 0x1p-22 + 0x1p-147);
        if (!(tight_lo - lo <= step) || !(hi - tight_hi <= step))
            fail_msg("y %a: loose bounds %a, %a, tight %a, %a", y, (double)lo, (double)hi, (double)tight_lo,
                     (double)tight_hi);
    }
}

static void test_loose_float_bounds_enclose(void **state)
{
    (void)state;
    static const double values[] = {0.0, -0.0, 0.1, -0.1, 1.0 / 3.0, 1e9 + 0.1, -1e9 - 0.1, 1.0, -1.0, 0x1p-60,
                                    0x1p-1074, -0x1p-1074, 1e-310, 0x1p-126, 0x1p-149, 1e-40, 3e38, 0x1p100,
                                    -0x1p100, 0x1.0000000000001p100, 1e300, -1e300, DBL_MAX, -DBL_MAX,
                                    16777217.0, -16777217.0, 0x1.fffffffffffffp-1, 0x1.000001p0};
    for (size_t i = 0; i < sizeof values / sizeof values[0]; i++) {
        check_loose(values[i]);
        check_loose(nextafter(values[i], INFINITY));
        check_loose(nextafter(values[i], -INFINITY));
    }
    assert_true(float_below_loosely(NAN) == -INFINITY && float_above_loosely(NAN) == INFINITY);
    rng r = rng_seeded(base_seed + 41);
    for (int i = 0; i < 200000; i++)
        check_loose(ldexp(rng_uniform(&r, -1, 1), (int)(rng_next(&r) % 300) - 150));
}

/* The four-lane box test gives triangle_boxes_apart's answer: on boxes that touch, overlap,
 * are apart along one axis, and hold infinities or NaN (which make no comparison true). */
static void test_box_probe_is_the_scalar_test(void **state)
{
    (void)state;
    static const float values[] = {0.0f, -0.0f, 1.0f, -1.0f, 0.5f, 2.0f, INFINITY, -INFINITY, NAN, 0x1p-149f};
    const size_t n = sizeof values / sizeof values[0];
    rng r = rng_seeded(base_seed + 42);
    size_t apart = 0, close = 0;
    for (int i = 0; i < 400000; i++) {
        triangle_box a, b;
        float *fa = a.lo, *fb = b.lo;
        for (int k = 0; k < 6; k++) {
            /* Mostly small integers, so bounds often coincide; now and then a special value. */
            uint64_t pick = rng_next(&r);
            fa[k] = pick % 8 == 0 ? values[(pick >> 3) % n] : (float)((int)(pick >> 8 & 7) - 3);
            pick = rng_next(&r);
            fb[k] = pick % 8 == 0 ? values[(pick >> 3) % n] : (float)((int)(pick >> 8 & 7) - 3);
        }
        triangle_box_probe p = triangle_box_probe_of(&b);
        int want = triangle_boxes_apart(&a, &b);
        assert_int_equal(triangle_box_probe_apart(&a, &p), want);
        apart += want;
        close += !want;
    }
    assert_true(apart > 1000 && close > 1000);
}

/* ---------- memory ---------- */

static void test_bytes_are_as_documented(void **state)
{
    (void)state;
    mesh_data m = meshgen_icosphere((vec3){0.1, 0.2, 0.3}, 1.0, 3);
    mesh_view v = mesh_data_view(&m);
    octree *plain = build_with(&v, 0, ACCURACY_EXACT, 0), *boxed = build_with(&v, 0, ACCURACY_EXACT, 1);
    octree_info a, b;
    octree_get_info(plain, &a);
    octree_get_info(boxed, &b);
    assert_int_equal(a.bytes_triangle_boxes, 0);
    assert_int_equal(b.bytes_triangle_boxes, 24 * m.triangle_count);
    assert_int_equal(b.bytes_total, a.bytes_total + 24 * m.triangle_count);
    assert_int_equal(b.bytes_nodes, a.bytes_nodes);
    assert_int_equal(b.bytes_leaf_lists, a.bytes_leaf_lists);
    assert_int_equal(b.bytes_triangles, a.bytes_triangles);
    assert_int_equal(b.bytes_traversal, a.bytes_traversal);
    assert_true(a.bytes_traversal > 0);
    assert_int_equal(a.bytes_total, a.bytes_nodes + a.bytes_leaf_lists + a.bytes_triangles + a.bytes_traversal +
                                        sizeof(struct octree));
    assert_null(plain->triangle_boxes);
    assert_non_null(boxed->triangle_boxes);
    octree_free(plain);
    octree_free(boxed);

    octree_def def = octree_default_def();
    def.triangle_boxes = 2;
    octree_error err;
    assert_null(octree_build(&v, &def, &err));
    assert_int_equal(err.status, OCTREE_ERR_INVALID);
    assert_int_equal(octree_default_def().triangle_boxes, 0);
    mesh_data_free(&m);
}

/* Each stored box encloses its triangle exactly, relative to the world's lower corner. */
static void test_stored_boxes_enclose_their_triangles(void **state)
{
    (void)state;
    mesh_data soup = meshgen_soup(base_seed + 41, 400, (box3){{-1, -1, -1}, {1, 1, 1}}, 0.3);
    mesh_data far = meshgen_transformed(&soup, 0.1, (vec3){1e9 + 0.1, -5e6 + 0.3, 0.7});
    mesh_view v = mesh_data_view(&far);
    octree *t = build_with(&v, 0, ACCURACY_EXACT, 1);
    vec3 o = t->world.lo;
    for (uint32_t id = 0; id < t->triangle_count; id++) {
        const triangle_box *b = &t->triangle_boxes[id];
        vec3 tri[3];
        octree_triangle_vertices(t, id, tri);
        for (int k = 0; k < 3; k++) {
            vec3 p = tri[k];
            double c[3] = {p.x, p.y, p.z}, oc[3] = {o.x, o.y, o.z};
            for (int a = 0; a < 3; a++) {
                assert_true(compare_offset(oc[a], b->lo[a], c[a]) <= 0);
                assert_true(compare_offset(oc[a], b->hi[a], c[a]) >= 0);
            }
        }
        /* Relative to the corner the boxes stay tight: a float's step at x = 1e9 is 64;
         * within this world it is below 1e-7. */
        for (int a = 0; a < 3; a++)
            assert_true(b->hi[a] - b->lo[a] < 0.1f);
    }
    octree_free(t);
    mesh_data_free(&far);
    mesh_data_free(&soup);
}

/* ---------- answers with boxes equal answers without ---------- */

typedef struct answer_totals {
    uint64_t candidates[2]; /* without, with boxes */
    uint64_t queries, contacts;
} answer_totals;

static void assert_same_contacts(const tri_output *a, const tri_output *b, tri_detail detail)
{
    assert_int_equal(a->hit, b->hit);
    assert_int_equal(a->count, b->count);
    assert_int_equal(a->truncated, b->truncated);
    size_t n = a->count < a->capacity ? a->count : a->capacity;
    for (size_t i = 0; i < n && detail != TRI_YESNO; i++) {
        assert_int_equal(a->contacts[i].triangle, b->contacts[i].triangle);
        /* The same decisions on the same doubles: the segments agree to the bit. */
        assert_memory_equal(&a->contacts[i].p, &b->contacts[i].p, sizeof(vec3));
        assert_memory_equal(&a->contacts[i].q, &b->contacts[i].q, sizeof(vec3));
    }
}

/* One query triangle in every mode and detail on both trees; returns the exact answer's
 * contact count. */
static size_t compare_triangle_query(const octree *plain, const octree *boxed, const vec3 q[3], answer_totals *tot)
{
    enum { CAP = 512 };
    static tri_contact ca[CAP], cb[CAP];
    size_t exact_count = 0;
    for (size_t m = 0; m < sizeof modes / sizeof modes[0]; m++)
        for (int detail = TRI_YESNO; detail <= TRI_SEGMENTS; detail++) {
            tri_output a = {.contacts = ca, .capacity = CAP}, b = {.contacts = cb, .capacity = CAP};
            query_stats sa = {0}, sb = {0};
            assert_int_equal(octree_triangle(plain, q, (tri_detail)detail, modes[m], &a, &sa), OCTREE_OK);
            assert_int_equal(octree_triangle(boxed, q, (tri_detail)detail, modes[m], &b, &sb), OCTREE_OK);
            assert_same_contacts(&a, &b, (tri_detail)detail);
            assert_int_equal(sa.nodes_visited, sb.nodes_visited);
            assert_true(sb.candidates_tested <= sa.candidates_tested);
            if (modes[m] != ACCURACY_EXACT) {
                /* Seed and fast mode never skip (see octree_triangle.c). */
                assert_int_equal(sa.candidates_tested, sb.candidates_tested);
            } else if (detail == TRI_IDS) {
                tot->candidates[0] += sa.candidates_tested;
                tot->candidates[1] += sb.candidates_tested;
                tot->queries++;
                tot->contacts += a.count;
                exact_count = a.count;
            }
        }
    return exact_count;
}

static void compare_mesh_query(const octree *plain, const octree *boxed, const mesh_view *shape, const pose *p)
{
    enum { CAP = 4096 };
    static mesh_pair pa[CAP], pb[CAP];
    for (size_t m = 0; m < sizeof modes / sizeof modes[0]; m++)
        for (int all = 0; all <= 1; all++) {
            mesh_output a = {.pairs = pa, .capacity = CAP}, b = {.pairs = pb, .capacity = CAP};
            query_stats sa = {0}, sb = {0};
            assert_int_equal(octree_mesh(plain, shape, p, all, modes[m], &a, &sa), OCTREE_OK);
            assert_int_equal(octree_mesh(boxed, shape, p, all, modes[m], &b, &sb), OCTREE_OK);
            assert_int_equal(a.hit, b.hit);
            assert_int_equal(a.count, b.count);
            assert_int_equal(a.truncated, b.truncated);
            size_t n = a.count < CAP ? a.count : CAP;
            if (n)
                assert_memory_equal(pa, pb, n * sizeof *pa);
            assert_true(sb.candidates_tested <= sa.candidates_tested);
        }
}

/* A query triangle sharing one vertex of world triangle w and opening away from w's
 * centroid: it touches w, often at that vertex only, where w's box has a corner. */
static void touching_triangle(rng *r, const mesh_data *m, size_t w, double size, vec3 q[3])
{
    vec3 v[3];
    for (int k = 0; k < 3; k++)
        v[k] = m->vertices[m->indices[3 * w + (size_t)k]];
    int k = (int)(rng_next(r) % 3);
    vec3 c = vec3_scale(vec3_add(vec3_add(v[0], v[1]), v[2]), 1.0 / 3.0);
    vec3 away = vec3_normalize(vec3_sub(v[k], c));
    q[0] = v[k];
    for (int j = 1; j < 3; j++)
        q[j] = vec3_add(v[k], vec3_scale(vec3_normalize(vec3_add(away, vec3_scale(rng_unit_vector(r), 0.5))), size));
}

static void compare_scene(const char *name, const mesh_data *m, double resolution, uint64_t seed, int queries,
                          answer_totals *tot)
{
    printf("scene %s: %zu triangles, seed %llu\n", name, m->triangle_count, (unsigned long long)seed);
    mesh_view v = mesh_data_view(m);
    box3 b = mesh_data_bounds(m);
    vec3 ext = vec3_sub(b.hi, b.lo);
    double extent = fmax(ext.x, fmax(ext.y, ext.z));
    box3 around = {vec3_sub(b.lo, vec3_scale(ext, 0.1)), vec3_add(b.hi, vec3_scale(ext, 0.1))};
    /* Trees built in exact and fast mode: membership differs, the prefilter must not. */
    accuracy_mode build_modes[] = {ACCURACY_EXACT, ACCURACY_FAST};
    for (size_t bm = 0; bm < 2; bm++) {
        octree *plain = build_with(&v, resolution, build_modes[bm], 0);
        octree *boxed = build_with(&v, resolution, build_modes[bm], 1);
        octree_info info;
        octree_get_info(plain, &info);
        rng r = rng_seeded(seed);
        for (int i = 0; i < queries; i++) {
            vec3 q[3];
            size_t w = rng_next(&r) % m->triangle_count;
            int kind = i % 4;
            double size = (i % 8 < 4 ? 1.0 : 4.0) * info.resolution;
            if (kind == 0) {
                for (int k = 0; k < 3; k++)
                    q[k] = m->vertices[m->indices[3 * w + (size_t)k]];
            } else if (kind == 1) {
                touching_triangle(&r, m, w, size, q);
            } else {
                q[0] = kind == 2 ? m->vertices[m->indices[3 * w]] : rng_point_in_box(&r, around);
                q[0] = vec3_add(q[0], vec3_scale(rng_unit_vector(&r), 0.5 * size));
                for (int k = 1; k < 3; k++)
                    q[k] = vec3_add(q[0], vec3_scale(rng_unit_vector(&r), size * rng_uniform(&r, 0.1, 1.0)));
            }
            size_t n = compare_triangle_query(plain, boxed, q, tot);
            if (kind <= 1 && bm == 0)
                assert_true(n >= 1); /* touches w at least: the prefilter kept the contact */
        }
        /* Mesh queries: a small sphere posed over the scene. */
        mesh_data shape = meshgen_icosphere((vec3){0, 0, 0}, 0.08 * extent, 1);
        mesh_view sv = mesh_data_view(&shape);
        for (int i = 0; i < 12; i++) {
            double a = rng_uniform(&r, 0, 6.283185307179586);
            pose p = {{cos(a), -sin(a), 0, sin(a), cos(a), 0, 0, 0, 1},
                      m->vertices[m->indices[3 * (rng_next(&r) % m->triangle_count)]]};
            compare_mesh_query(plain, boxed, &sv, &p);
        }
        mesh_data_free(&shape);
        octree_free(plain);
        octree_free(boxed);
    }
}

static void test_generated_scenes_answer_the_same_with_boxes(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 42;
    box3 unit = {{-1, -1, -1}, {1, 1, 1}};
    mesh_data soup = meshgen_soup(seed, 600, unit, 0.3);
    struct {
        const char *name;
        mesh_data mesh;
        double resolution;
    } scenes[] = {
        {"soup", meshgen_soup(seed, 600, unit, 0.3), 0},
        {"soup far and small", meshgen_transformed(&soup, 1e-3, (vec3){1e6, 2e6, -1e6}), 0},
        {"soup at 1e9", meshgen_transformed(&soup, 1.0, (vec3){1e9, 1e9, 1e9}), 0},
        {"soup at 1e9 + 0.1", meshgen_transformed(&soup, 0.1, (vec3){1e9 + 0.1, -5e6 + 0.3, 0.7}), 0},
        {"terrain", meshgen_terrain(seed, (box3){{0, 0, 0}, {8, 8, 1}}, 16, 16), 0},
        {"terrain at 0.1", meshgen_terrain(seed, (box3){{0.1, 0.1, 0.1}, {0.9, 0.7, 0.2}}, 16, 16), 0},
        {"icosphere", meshgen_icosphere((vec3){0.5, 0.25, 0}, 1.0, 3), 0},
        {"blocks", meshgen_blocks(seed, 4, 3, 3, 0.5), 0.125},
        {"torus coarse", meshgen_torus((vec3){0, 0, 0}, 2.0, 0.5, 24, 12), 2.0},
    };
    answer_totals tot = {0};
    for (size_t i = 0; i < sizeof scenes / sizeof scenes[0]; i++) {
        compare_scene(scenes[i].name, &scenes[i].mesh, scenes[i].resolution, seed + i, 200, &tot);
        mesh_data_free(&scenes[i].mesh);
    }
    mesh_data_free(&soup);
    printf("exact ids queries %llu, contacts %llu, candidates tested %llu without boxes, %llu with\n",
           (unsigned long long)tot.queries, (unsigned long long)tot.contacts, (unsigned long long)tot.candidates[0],
           (unsigned long long)tot.candidates[1]);
    /* The boxes do skip work: at least a third of the candidates on these scenes. */
    assert_true(3 * tot.candidates[1] < 2 * tot.candidates[0]);
    assert_true(tot.candidates[1] >= tot.contacts);
}

/* ---------- hard cases ---------- */

/* The case's triangle a is world triangle 0; two small triangles beyond everything the case
 * touches give the tree depth without moving its lower corner. */
static void hard_case_world(const hard_case *c, vec3 world[9])
{
    vec3 lo = vec3_min(vec3_min(c->a[0], c->a[1]), c->a[2]), hi = vec3_max(vec3_max(c->a[0], c->a[1]), c->a[2]);
    for (int i = 0; i < 3; i++) {
        lo = vec3_min(lo, c->b[i]);
        hi = vec3_max(hi, c->b[i]);
    }
    vec3 extent = vec3_sub(hi, lo);
    double size = fmax(extent.x, fmax(extent.y, extent.z));
    if (size == 0.0)
        size = fmax(fmax(fabs(hi.x), fabs(hi.y)), fmax(fabs(hi.z), 1.0)) * 0x1p-30;
    for (int k = 0; k < 3; k++)
        world[k] = c->a[k];
    for (int k = 0; k < 2; k++) {
        vec3 corner = vec3_add(hi, vec3_make((2 + 2 * k) * size, (2 + 2 * k) * size, (2 + 2 * k) * size));
        world[3 + 3 * k] = corner;
        world[4 + 3 * k] = vec3_add(corner, vec3_make(0.5 * size, 0, 0));
        world[5 + 3 * k] = vec3_add(corner, vec3_make(0, 0.5 * size, 0.25 * size));
    }
}

static void test_hard_cases_answer_the_same_with_boxes(void **state)
{
    (void)state;
    hard_case *cases;
    size_t count = hard_cases_generate(&cases);
    assert_true(count > 0);
    static const uint32_t indices[9] = {0, 1, 2, 3, 4, 5, 6, 7, 8};
    static const pose identity = {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0}};
    size_t tried = 0, touching = 0, skipped = 0;
    answer_totals tot = {0};
    for (size_t i = 0; i < count; i++) {
        const hard_case *c = &cases[i];
        if (c->kind != HARD_TRI_TRI)
            continue;
        vec3 world[9];
        hard_case_world(c, world);
        mesh_view v = {world, 9, indices, 3};
        octree *plain = build_with(&v, 0, ACCURACY_EXACT, 0), *boxed = build_with(&v, 0, ACCURACY_EXACT, 1);
        uint64_t before = tot.candidates[1];
        compare_triangle_query(plain, boxed, c->b, &tot);
        tried++;
        /* The exact answer with boxes is the catalogue's. */
        tri_contact contacts[3];
        tri_output out = {.contacts = contacts, .capacity = 3};
        assert_int_equal(octree_triangle(boxed, c->b, TRI_IDS, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
        int touches = out.count > 0 && contacts[0].triangle == 0;
        if (touches != c->expected)
            fail_msg("case %zu (%s, transform %u): %d with boxes, expected %d", i, c->category, c->transform, touches,
                     c->expected);
        touching += touches;
        skipped += tot.candidates[1] == before;
        mesh_view shape = {c->b, 3, indices, 1};
        compare_mesh_query(plain, boxed, &shape, &identity);
        octree_free(plain);
        octree_free(boxed);
    }
    printf("%zu triangle-triangle cases (%zu touching), the boxes skipped every candidate of %zu\n", tried, touching,
           skipped);
    assert_true(tried > 1000 && touching > 0 && touching < tried);
    free(cases);
}

/* ---------- contact exactly on a box face ---------- */

enum { FACE_CASES = 3 };

/* World triangle and query triangle meeting only where their boxes meet, around p, at
 * scale h: (0) a shared corner vertex, (1) a query vertex on the world triangle's
 * interior in the plane z = p.z, (2) an edge of each crossing at p in the plane x = p.x.
 * apart_axis says which coordinate to push one step up to separate them. */
static void face_case(int which, vec3 p, double h, vec3 w[3], vec3 q[3], int *apart_axis)
{
    if (which == 0) {
        vec3 wt[3] = {p, vec3_sub(p, vec3_make(h, 0.3 * h, 0.1 * h)), vec3_sub(p, vec3_make(0.2 * h, h, 0.5 * h))};
        vec3 qt[3] = {p, vec3_add(p, vec3_make(h, 0.2 * h, 0.4 * h)), vec3_add(p, vec3_make(0.3 * h, h, 0.1 * h))};
        memcpy(w, wt, sizeof wt);
        memcpy(q, qt, sizeof qt);
        *apart_axis = 0;
    } else if (which == 1) {
        vec3 wt[3] = {{p.x - h, p.y - h, p.z}, {p.x + h, p.y - h, p.z}, {p.x, p.y + h, p.z}};
        vec3 qt[3] = {p, {p.x + 0.3 * h, p.y, p.z + h}, {p.x, p.y + 0.3 * h, p.z + h}};
        memcpy(w, wt, sizeof wt);
        memcpy(q, qt, sizeof qt);
        *apart_axis = 2;
    } else {
        vec3 wt[3] = {{p.x, p.y - h, p.z}, {p.x, p.y + h, p.z}, {p.x - h, p.y, p.z + 0.5 * h}};
        vec3 qt[3] = {{p.x, p.y, p.z - h}, {p.x, p.y, p.z + h}, {p.x + h, p.y + 0.5 * h, p.z}};
        memcpy(w, wt, sizeof wt);
        memcpy(q, qt, sizeof qt);
        *apart_axis = 0;
    }
}

static double coord(vec3 v, int axis) { return axis == 0 ? v.x : axis == 1 ? v.y : v.z; }

/* 1 when world triangle 0 is among the query's contacts, checked in every detail, as a
 * one-triangle mesh, with and without boxes alike. */
static int finds_world_triangle(const octree *plain, const octree *boxed, const vec3 q[3])
{
    answer_totals tot = {0};
    compare_triangle_query(plain, boxed, q, &tot);
    tri_contact contacts[4];
    tri_output out = {.contacts = contacts, .capacity = 4};
    assert_int_equal(octree_triangle(boxed, q, TRI_SEGMENTS, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
    int found = out.count > 0 && contacts[0].triangle == 0;
    static const uint32_t indices[3] = {0, 1, 2};
    static const pose identity = {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0}};
    mesh_view shape = {q, 3, indices, 1};
    compare_mesh_query(plain, boxed, &shape, &identity);
    mesh_pair pairs[4];
    mesh_output mo = {.pairs = pairs, .capacity = 4};
    assert_int_equal(octree_mesh(boxed, &shape, &identity, 1, ACCURACY_EXACT, &mo, NULL), OCTREE_OK);
    assert_int_equal(mo.count > 0 && pairs[0].world_triangle == 0, found);
    return found;
}

static void test_contacts_on_box_faces_are_found(void **state)
{
    (void)state;
    /* Anchors below every case set the world's corner, so that offsets from it round too. */
    static const vec3 points[] = {{0.1, 0.2, 0.3}, {1e9 + 0.1, 1e9 + 0.2, 1e9 + 0.3}, {-0.7, 1.0 / 3.0, 5e6 + 0.3}};
    static const double scales[] = {0.05, 0.25, 0.01};
    static const vec3 anchors[] = {{-0.3, -0.7, -1.0 / 3.0}, {1e9 - 1.2345678, 1e9 - 0.3, 1e9 - 1.7}, {-1.1, -0.1, 5e6 - 0.9}};
    static const uint32_t indices[9] = {0, 1, 2, 3, 4, 5, 6, 7, 8};
    int inexact = 0;
    for (size_t s = 0; s < sizeof points / sizeof points[0]; s++)
        for (int which = 0; which < 2 * FACE_CASES; which++) {
            vec3 p = points[s], w[3], q[3];
            int axis;
            face_case(which % FACE_CASES, p, scales[s], w, q, &axis);
            /* The world triangle on either side of the face where the boxes meet. */
            int swapped = which >= FACE_CASES;
            if (swapped) {
                vec3 t[3];
                memcpy(t, w, sizeof t);
                memcpy(w, q, sizeof t);
                memcpy(q, t, sizeof t);
            }
            vec3 a = anchors[s];
            vec3 far = vec3_add(p, vec3_make(3 * scales[s], 3 * scales[s], 3 * scales[s]));
            vec3 world[9] = {w[0], w[1], w[2], a, vec3_add(a, vec3_make(0.01, 0, 0)), vec3_add(a, vec3_make(0, 0.01, 0)),
                             far, vec3_add(far, vec3_make(0.01, 0, 0)), vec3_add(far, vec3_make(0, 0, 0.01))};
            mesh_view v = {world, 9, indices, 3};
            for (int fine = 0; fine < 2; fine++) {
                double res = fine ? scales[s] / 8 : 0;
                octree *plain = build_with(&v, res, ACCURACY_EXACT, 0), *boxed = build_with(&v, res, ACCURACY_EXACT, 1);
                /* The contact coordinate relative to the corner is no float: a bound
                 * rounded to nearest instead of outward could fall on either side. */
                double rel = coord(p, axis) - coord(boxed->world.lo, axis);
                inexact += (double)(float)rel != rel;
                if (!finds_world_triangle(plain, boxed, q))
                    fail_msg("point %zu, case %d, resolution %g: the touching query was not found", s, which, res);
                /* One step apart along the axis where the boxes met: no contact. */
                vec3 apart[3];
                double away = swapped ? -INFINITY : INFINITY;
                for (int k = 0; k < 3; k++) {
                    apart[k] = q[k];
                    if (axis == 0)
                        apart[k].x = nextafter(q[k].x, away);
                    else
                        apart[k].z = nextafter(q[k].z, away);
                }
                assert_false(tri_tri_overlap_exact(w, apart));
                assert_false(finds_world_triangle(plain, boxed, apart));
                octree_free(plain);
                octree_free(boxed);
            }
        }
    assert_true(inexact >= 4 * FACE_CASES);
}

/* ---------- why seed and fast mode do not use the boxes ---------- */

/* In these pairs the boxes are strictly apart, so the exact answer is no, yet the seed's
 * epsilon test (a plane 1e-10 above) and the plain double test (two horizontal triangles
 * one ulp apart at 1e9, whose plane distances round to zero) say yes. A prefilter in those
 * modes would change their answers; the octree with boxes must still give them. */
static void test_seed_and_fast_answers_are_kept(void **state)
{
    (void)state;
    const double z = 1e9, up = nextafter(1e9, INFINITY) - 1e9;
    /* A small second triangle at `anchor` from the pair: for the fast pair it goes below, so
     * that the pair lies inside the world cube rather than on its face, where the fast node
     * test would not reach it; for the seed pair above, so that the 1e-10 gap stays wide in
     * floats relative to the world's corner. */
    struct {
        accuracy_mode mode;
        vec3 w[3], q[3];
        double anchor;
    } pairs[] = {
        {ACCURACY_SEED, {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0.1, 0.1, 1e-10}, {0.5, 0.1, 1e-10}, {0.1, 0.5, 1e-10}}, 2},
        {ACCURACY_FAST,
         {{z + 0.48645508289337158, z + 0.31278383731842041, z},
          {z + 0.9977724552154541, z + 0.40928828716278076, z},
          {z + 0.20797741413116455, z + 0.071289658546447754, z}},
         {{z + 0.57417404651641846, z + 0.34623908996582031, z + up},
          {z + 0.98702085018157959, z + 0.79971301555633545, z + up},
          {z + 0.64239335060119629, z + 0.22047567367553711, z + up}},
         -0.5},
    };
    static const uint32_t indices[6] = {0, 1, 2, 3, 4, 5};
    for (size_t i = 0; i < sizeof pairs / sizeof pairs[0]; i++) {
        assert_false(tri_tri_overlap_exact(pairs[i].q, pairs[i].w));
        double d = pairs[i].anchor;
        vec3 a = vec3_add(pairs[i].w[0], vec3_make(d, d, d));
        vec3 world[6] = {pairs[i].w[0], pairs[i].w[1], pairs[i].w[2], a, vec3_add(a, vec3_make(0.25, 0, 0)),
                         vec3_add(a, vec3_make(0, 0.25, 0))};
        mesh_view v = {world, 6, indices, 2};
        octree *plain = build_with(&v, 0, pairs[i].mode, 0), *boxed = build_with(&v, 0, pairs[i].mode, 1);
        uint32_t internal = boxed->original_id[0] == 0 ? 0 : 1;
        triangle_box wb = boxed->triangle_boxes[internal];
        vec3 qlo = vec3_min(vec3_min(pairs[i].q[0], pairs[i].q[1]), pairs[i].q[2]);
        vec3 qhi = vec3_max(vec3_max(pairs[i].q[0], pairs[i].q[1]), pairs[i].q[2]);
        triangle_box qb = triangle_box_around(qlo, qhi, boxed->world.lo);
        assert_true(triangle_boxes_apart(&wb, &qb));
        for (int with = 0; with < 2; with++) {
            tri_output out = {0};
            assert_int_equal(octree_triangle(with ? boxed : plain, pairs[i].q, TRI_YESNO, pairs[i].mode, &out, NULL),
                             OCTREE_OK);
            assert_int_equal(out.hit, 1);
            assert_int_equal(octree_triangle(with ? boxed : plain, pairs[i].q, TRI_YESNO, ACCURACY_EXACT, &out, NULL),
                             OCTREE_OK);
            assert_int_equal(out.hit, 0);
        }
        answer_totals tot = {0};
        compare_triangle_query(plain, boxed, pairs[i].q, &tot);
        assert_true(tot.candidates[1] < tot.candidates[0]); /* exact mode skipped it */
        octree_free(plain);
        octree_free(boxed);
    }
}

int main(void)
{
    const char *env = getenv("TRIOCT_SEED");
    if (env)
        base_seed = strtoull(env, NULL, 10);
    printf("seed %llu (TRIOCT_SEED reruns with another)\n", (unsigned long long)base_seed);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_float_bounds_enclose_and_are_tight),
        cmocka_unit_test(test_loose_float_bounds_enclose),
        cmocka_unit_test(test_box_probe_is_the_scalar_test),
        cmocka_unit_test(test_bytes_are_as_documented),
        cmocka_unit_test(test_stored_boxes_enclose_their_triangles),
        cmocka_unit_test(test_generated_scenes_answer_the_same_with_boxes),
        cmocka_unit_test(test_hard_cases_answer_the_same_with_boxes),
        cmocka_unit_test(test_contacts_on_box_faces_are_found),
        cmocka_unit_test(test_seed_and_fast_answers_are_kept),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
