/* Fast and seed modes through the octree: each mode's answers equal its own primitive run
 * over every triangle (tests/support/brute_force.c), on random scenes and on the cases
 * where rounding decides (shared edges and vertices of closed meshes, rays along node
 * faces, triangles on node faces, large offsets), at several resolutions; membership is
 * conservative in every mode; seed hits lie in the closed [tmin, tmax]. */
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
#include "geom/box_geometry.h"
#include "geom/ray_tri.h"
#include "geom/tri_box.h"
#include "geom/tri_tri.h"
#include "octree/octree_internal.h"
#include "octree/octree_modes.h"
#include "support/brute_force.h"
#include "support/meshgen.h"
#include "support/query_shapes.h"

static uint64_t base_seed = 20261122;

static octree *build_mode(const mesh_data *m, double resolution, accuracy_mode mode, double seed_eps)
{
    octree_def def = octree_default_def();
    def.resolution = resolution;
    def.mode = mode;
    def.seed_epsilon = seed_eps;
    mesh_view v = mesh_data_view(m);
    octree_error err;
    octree *t = octree_build(&v, &def, &err);
    if (!t)
        fail_msg("build failed: %s", err.message);
    return t;
}

/* The tree's seed reach factor is the largest 2 / sin of a triangle's smallest angle,
 * rounded up to a float, and slivers (that sine below 2^-10) are listed apart instead: on
 * triangles whose smallest angle is known, one at a time and together. */
static void test_seed_reach_factor_and_slivers(void **state)
{
    (void)state;
    const double pi = 3.14159265358979323846;
    /* Apex angle a between two unit sides: the smallest angle for a below 60 degrees. */
    static const double degrees[] = {60.0, 45.0, 30.0, 10.0, 1.0, 0.1};
    double largest = 2.0;
    mesh_data all = {0};
    for (size_t i = 0; i < sizeof degrees / sizeof degrees[0]; i++) {
        double a = degrees[i] * pi / 180;
        vec3 v[3] = {{0, 0, 0}, {1, 0, 0}, {cos(a), sin(a), 0}};
        mesh_data m = meshgen_triangle(v[0], v[1], v[2]);
        assert_non_null(m.vertices);
        octree *t = build_mode(&m, 0, ACCURACY_SEED, 1e-9);
        double want = 2.0 / sin(a);
        /* At or above the real factor (sin rounds, so allow it 2^-40 below), within a float
         * step above it. */
        if (!(t->seed_reach_factor >= want * (1 - 0x1p-40) && t->seed_reach_factor <= want * (1 + 0x1p-22)))
            fail_msg("%g degrees: reach factor %.17g, 2 / sin %.17g", degrees[i], t->seed_reach_factor, want);
        assert_int_equal(t->sliver_list_count, 0);
        assert_false(octree_is_sliver(v));
        largest = want > largest ? want : largest;
        assert_int_equal(mesh_data_append(&all, &m), 0);
        octree_free(t);
        mesh_data_free(&m);
    }
    /* Either side of the sliver bound, sin = 2^-10 (1 -+ 2^-20), and a zero-area triangle. */
    double below = 0x1p-10 * (1 - 0x1p-20), above = 0x1p-10 * (1 + 0x1p-20);
    vec3 thin[3][3] = {{{0, 0, 0}, {1, 0, 0}, {sqrt(1 - below * below), below, 0}},
                       {{0, 0, 0}, {1, 0, 0}, {sqrt(1 - above * above), above, 0}},
                       {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}};
    assert_true(octree_is_sliver(thin[0]));
    assert_false(octree_is_sliver(thin[1]));
    assert_true(octree_is_sliver(thin[2]));
    for (int k = 0; k < 3; k++) {
        mesh_data m = meshgen_triangle(thin[k][0], thin[k][1], thin[k][2]);
        assert_non_null(m.vertices);
        assert_int_equal(mesh_data_append(&all, &m), 0);
        mesh_data_free(&m);
    }
    octree *t = build_mode(&all, 0, ACCURACY_SEED, 1e-9);
    assert_int_equal(t->sliver_list_count, 2);
    double want = 2.0 / above; /* the thin triangle that is not a sliver has the smallest sine */
    assert_true(want > largest);
    if (!(t->seed_reach_factor >= want * (1 - 0x1p-40) && t->seed_reach_factor <= want * (1 + 0x1p-22)))
        fail_msg("together: reach factor %.17g, 2 / sin %.17g", t->seed_reach_factor, want);
    octree_free(t);
    mesh_data_free(&all);
}

/* The seed's heuristic leaf side of a mesh, which the resolutions below scale. */
static double heuristic_of(const mesh_data *m)
{
    octree *t = build_mode(m, 0.0, ACCURACY_EXACT, 1e-9);
    double d = t->info.resolution;
    octree_free(t);
    return d;
}

/* ---------- membership ---------- */

typedef struct leaf_ref {
    uint32_t node;
    box3 box;
} leaf_ref;

static size_t collect_leaves(const octree *t, leaf_ref *out, size_t cap)
{
    size_t n = 0, top = 0;
    leaf_ref stack[OCTREE_STACK_MAX];
    stack[top++] = (leaf_ref){0, t->world};
    while (top) {
        leaf_ref e = stack[--top];
        octree_node nd = t->nodes[e.node];
        if (nd.count != NODE_INTERIOR) {
            if (n < cap)
                out[n] = e;
            n++;
            continue;
        }
        for (int k = 0; k < 8; k++)
            stack[top++] = (leaf_ref){nd.first + (uint32_t)k, box_octant(e.box, k)};
    }
    return n;
}

static int leaf_holds(const octree *t, uint32_t node, uint32_t id)
{
    octree_node nd = t->nodes[node];
    for (uint32_t i = 0; i < nd.count; i++)
        if (t->original_id[t->leaf_items[nd.first + i]] == id)
            return 1;
    return 0;
}

static void mesh_triangle(const mesh_data *m, size_t i, vec3 out[3])
{
    for (int k = 0; k < 3; k++)
        out[k] = m->vertices[m->indices[3 * i + (size_t)k]];
}

/* Every triangle that touches a sampled leaf's closed box (decided exactly) is in its list,
 * whatever mode built the tree. */
static void check_membership_conservative(const mesh_data *m, double resolution, accuracy_mode mode, uint64_t seed)
{
    octree *t = build_mode(m, resolution, mode, 1e-9);
    size_t n = collect_leaves(t, NULL, 0);
    leaf_ref *leaves = malloc(n * sizeof *leaves);
    collect_leaves(t, leaves, n);
    rng r = rng_seeded(seed);
    size_t samples = n < 400 ? n : 400;
    for (size_t s = 0; s < samples; s++) {
        leaf_ref L = n < 400 ? leaves[s] : leaves[rng_next(&r) % n];
        for (size_t i = 0; i < m->triangle_count; i++) {
            vec3 tri[3];
            mesh_triangle(m, i, tri);
            if (tri_box_overlap_exact(tri, L.box) && !leaf_holds(t, L.node, (uint32_t)i))
                fail_msg("%s tree, seed %llu: triangle %zu touches leaf %u but is not in it",
                         accuracy_mode_name(mode), (unsigned long long)seed, i, L.node);
        }
    }
    free(leaves);
    octree_free(t);
}

/* Triangles that only touch node boxes: a vertex on a split plane (the other coordinates
 * full-mantissa), an edge lying in a split plane, or a whole triangle in one, all on the
 * one side of the plane otherwise. The world is a cube of side 2 at full-mantissa corners
 * (two corner triangles fix it); with resolution 0.25 it has three levels of split planes. */
static mesh_data touching_scene(uint64_t seed, int count, double gap)
{
    rng r = rng_seeded(seed);
    mesh_data m = {0};
    size_t nv = 6 + 3 * (size_t)count;
    m.vertices = malloc(nv * sizeof *m.vertices);
    m.indices = malloc(nv * sizeof *m.indices);
    m.vertex_count = m.triangle_count = 0;
    /* Full-mantissa world corners, so that the split planes are too. */
    vec3 lo = {-0.98765432101234567, -1.0123456789012345, -0.95310101010101013};
    vec3 hi = {lo.x + 2, lo.y + 2, lo.z + 2};
    vec3 corners[6] = {lo, {lo.x + 0.1, lo.y, lo.z}, {lo.x, lo.y + 0.1, lo.z},
                       hi, {hi.x - 0.1, hi.y, hi.z}, {hi.x, hi.y - 0.1, hi.z}};
    for (int k = 0; k < 6; k++)
        m.vertices[m.vertex_count++] = corners[k];
    for (int i = 0; i < count; i++) {
        int axis = (int)(rng_next(&r) % 3), shape = (int)(rng_next(&r) % 3);
        /* One of the split planes x_axis = c of the tree's three levels, as it splits. */
        unsigned cell = 1 + (unsigned)(rng_next(&r) % 7);
        double l = vec3_get(lo, axis), h = vec3_get(hi, axis);
        for (int j = 2; j >= 0; j--) {
            double mid = box_split(l, h);
            if ((cell >> j) & 1)
                l = mid;
            else
                h = mid;
        }
        double plane = l;
        double side = rng_next(&r) & 1 ? 1 : -1;
        /* gap > 0: the on-plane corners sit that far on the triangle's side instead. */
        double at = plane + side * gap;
        vec3 centre = vec3_with(vec3_scale(vec3_add(lo, hi), 0.5), axis, plane);
        box3 around = {vec3_sub(centre, (vec3){0.9, 0.9, 0.9}), vec3_add(centre, (vec3){0.9, 0.9, 0.9})};
        vec3 p[3];
        for (int k = 0; k < 3; k++) {
            p[k] = rng_point_in_box(&r, around);
            double off = rng_uniform(&r, 1e-3, 0.1);
            double x = k < 1 + shape ? at : plane + side * off;
            p[k] = vec3_with(p[k], axis, x);
        }
        /* keep the triangle small so it stays near the plane's nodes */
        for (int k = 1; k < 3; k++) {
            vec3 dlt = vec3_sub(p[k], p[0]);
            dlt = vec3_with(vec3_scale(dlt, 0.1), axis, vec3_get(dlt, axis));
            p[k] = vec3_add(p[0], dlt);
            p[k] = vec3_with(p[k], axis, k < 1 + shape ? at : vec3_get(p[k], axis));
        }
        for (int k = 0; k < 3; k++)
            m.vertices[m.vertex_count++] = p[k];
    }
    m.triangle_count = m.vertex_count / 3;
    for (size_t i = 0; i < m.vertex_count; i++)
        m.indices[i] = (uint32_t)i;
    return m;
}

static void test_membership_is_conservative_in_fast_and_seed_trees(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 1;
    printf("membership seed %llu\n", (unsigned long long)seed);
    mesh_data blocks = meshgen_blocks(seed, 4, 4, 3, 0.5); /* faces on node faces */
    mesh_data sphere = meshgen_icosphere((vec3){0.1, 0.2, 0.3}, 1.0, 2);
    mesh_data far = meshgen_transformed(&sphere, 1e-3, (vec3){1e6, -1e6, 1e6});
    mesh_data soup = meshgen_soup(seed, 300, (box3){{-1, -1, -1}, {1, 1, 1}}, 0.3);
    mesh_data touching = touching_scene(seed, 400, 0.0);
    const accuracy_mode modes[] = {ACCURACY_FAST, ACCURACY_SEED};
    for (int k = 0; k < 2; k++) {
        check_membership_conservative(&touching, 0.25, modes[k], seed);
        check_membership_conservative(&blocks, 0.25, modes[k], seed);
        check_membership_conservative(&sphere, 0.0, modes[k], seed + 1);
        check_membership_conservative(&far, 0.0, modes[k], seed + 2);
        check_membership_conservative(&soup, 0.0, modes[k], seed + 3);
    }
    mesh_data_free(&touching);
    mesh_data_free(&blocks);
    mesh_data_free(&sphere);
    mesh_data_free(&far);
    mesh_data_free(&soup);
}

/* The triangles seed mode's tests accept against everything are on the tree's list, which
 * every seed triangle query tests. */
static void test_seed_touch_everything_triangles_are_listed(void **state)
{
    (void)state;
    vec3 v[] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0},     /* ordinary */
                {5, 5, 5}, {5, 5, 5}, {5, 5, 5},     /* a point */
                {2, 0, 0}, {3, 0, 0}, {4, 0, 0},     /* a segment */
                {0, 0, 3}, {1, 0, 3}, {0, 1, 3}};    /* ordinary */
    uint32_t ix[] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11};
    mesh_view mv = {v, 12, ix, 4};
    octree_def def = octree_default_def();
    def.mode = ACCURACY_SEED;
    octree *t = octree_build(&mv, &def, NULL);
    assert_non_null(t);
    /* A query far from every triangle: seed's test says the point and the segment touch
     * it, exactly as brute force over the seed test says. */
    vec3 q[3] = {{-7, -7, -7}, {-6, -7, -7}, {-7, -6, -7}};
    uint32_t want[4];
    size_t n = brute_triangle(&mv, q, ACCURACY_SEED, def.seed_epsilon, want, 4);
    assert_int_equal(n, 2);
    tri_contact c[4];
    tri_output out = {.contacts = c, .capacity = 4};
    assert_int_equal(octree_triangle(t, q, TRI_IDS, ACCURACY_SEED, &out, NULL), OCTREE_OK);
    assert_int_equal(out.count, 2);
    assert_int_equal(c[0].triangle, want[0]);
    assert_int_equal(c[1].triangle, want[1]);
    /* A zero-area query touches every triangle in seed mode. */
    vec3 dq[3] = {{-7, -7, -7}, {-7, -7, -7}, {-6, -6, -6}};
    n = brute_triangle(&mv, dq, ACCURACY_SEED, def.seed_epsilon, want, 4);
    assert_int_equal(n, 4);
    assert_int_equal(octree_triangle(t, dq, TRI_IDS, ACCURACY_SEED, &out, NULL), OCTREE_OK);
    assert_int_equal(out.count, 4);
    octree_free(t);
}

/* ---------- queries against brute force ---------- */

typedef struct tally {
    size_t rays, ray_hits, triangles, triangle_hits;
} tally;

static void check_ray(const octree *t, const mesh_data *m, const ray_input *ray, accuracy_mode mode, tally *ty,
                      const char *what)
{
    mesh_view v = mesh_data_view(m);
    enum { CAP = 96 };
    ray_hit got[CAP], want[CAP];
    ty->rays++;
    for (int detail = RAY_ANY; detail <= RAY_ALL; detail++) {
        ray_output out = {.hits = got, .max_hits = CAP};
        assert_int_equal(octree_ray(t, ray, (ray_detail)detail, mode, &out, NULL), OCTREE_OK);
        size_t n = brute_ray(&v, ray, (ray_detail)detail, mode, t->seed_epsilon, want, CAP);
        if (detail == RAY_CLOSEST)
            ty->ray_hits += n > 0;
        if (detail == RAY_ANY) {
            if ((out.hit_count > 0) != (n > 0))
                fail_msg("%s %s ray (%.17g %.17g %.17g) + t (%.17g %.17g %.17g) any: octree %zu, brute force %zu",
                         what, accuracy_mode_name(mode), ray->origin.x, ray->origin.y, ray->origin.z,
                         ray->direction.x, ray->direction.y, ray->direction.z, out.hit_count, n);
            continue;
        }
        if (out.hit_count != n)
            fail_msg("%s %s ray (%.17g %.17g %.17g) + t (%.17g %.17g %.17g) detail %d: octree %zu hits, brute "
                     "force %zu",
                     what, accuracy_mode_name(mode), ray->origin.x, ray->origin.y, ray->origin.z, ray->direction.x,
                     ray->direction.y, ray->direction.z, detail, out.hit_count, n);
        for (size_t k = 0; k < n && k < CAP; k++) {
            if (got[k].triangle != want[k].triangle || !(got[k].t == want[k].t))
                fail_msg("%s %s ray detail %d hit %zu: octree triangle %u t %.17g, brute force %u t %.17g", what,
                         accuracy_mode_name(mode), detail, k, got[k].triangle, got[k].t, want[k].triangle,
                         want[k].t);
            if (!(got[k].t >= ray->tmin && got[k].t <= ray->tmax))
                fail_msg("%s %s ray: hit t %.17g outside [%.17g, %.17g]", what, accuracy_mode_name(mode), got[k].t,
                         ray->tmin, ray->tmax);
        }
    }
}

static void check_triangle(const octree *t, const mesh_data *m, const vec3 q[3], accuracy_mode mode, tally *ty,
                           const char *what)
{
    mesh_view v = mesh_data_view(m);
    size_t cap = m->triangle_count;
    uint32_t *want = malloc(cap * sizeof *want);
    tri_contact *got = malloc(cap * sizeof *got);
    size_t n = brute_triangle(&v, q, mode, t->seed_epsilon, want, cap);
    tri_output out = {.contacts = got, .capacity = cap};
    assert_int_equal(octree_triangle(t, q, TRI_IDS, mode, &out, NULL), OCTREE_OK);
    if (out.count != n)
        fail_msg("%s %s triangle (%.17g %.17g %.17g) (%.17g %.17g %.17g) (%.17g %.17g %.17g): octree %zu ids, "
                 "brute force %zu",
                 what, accuracy_mode_name(mode), q[0].x, q[0].y, q[0].z, q[1].x, q[1].y, q[1].z, q[2].x, q[2].y,
                 q[2].z, out.count, n);
    for (size_t k = 0; k < n; k++)
        if (got[k].triangle != want[k])
            fail_msg("%s %s triangle id %zu: octree %u, brute force %u", what, accuracy_mode_name(mode), k,
                     got[k].triangle, want[k]);
    tri_output yn = {0};
    assert_int_equal(octree_triangle(t, q, TRI_YESNO, mode, &yn, NULL), OCTREE_OK);
    if (yn.hit != (n > 0))
        fail_msg("%s %s triangle yes/no: octree %d, brute force %zu ids", what, accuracy_mode_name(mode), yn.hit, n);
    ty->triangles++;
    ty->triangle_hits += n > 0;
    free(want);
    free(got);
}

static vec3 point_near(rng *r, box3 b)
{
    vec3 ext = vec3_sub(b.hi, b.lo);
    box3 g = {vec3_sub(b.lo, vec3_scale(ext, 0.25)), vec3_add(b.hi, vec3_scale(ext, 0.25))};
    return rng_point_in_box(r, g);
}

/* Rays where rounding decides: at mesh vertices and edge midpoints (shared by the closed
 * meshes' triangles), axis-aligned through vertices, lying in node faces (a zero direction
 * component at a split plane's coordinate), grazing along node faces, and random ones;
 * some with a finite tmax or a tmin above 0. */
static ray_input hard_ray(rng *r, const mesh_data *m, const octree *t)
{
    box3 b = mesh_data_bounds(m);
    ray_input ray = {point_near(r, b), {0, 0, 0}, 0, INFINITY, RAY_CROSSING};
    vec3 target;
    size_t tri = rng_next(r) % m->triangle_count;
    vec3 a = m->vertices[m->indices[3 * tri]], c = m->vertices[m->indices[3 * tri + 1]];
    uint64_t kind = rng_next(r) % 6;
    if (kind == 0) {
        target = a;
    } else if (kind == 1) {
        target = vec3_add(vec3_scale(a, 0.5), vec3_scale(c, 0.5));
    } else if (kind == 2) {
        /* Axis-aligned through a vertex. */
        int axis = (int)(rng_next(r) % 3);
        ray.origin = a;
        ray.origin = vec3_with(ray.origin, axis, vec3_get(a, axis) - (vec3_get(b.hi, axis) - vec3_get(b.lo, axis)));
        target = a;
    } else if (kind == 3 || kind == 4) {
        /* In a node face: one coordinate on a split plane of the tree at some level. */
        int axis = (int)(rng_next(r) % 3);
        int level = 1 + (int)(rng_next(r) % (unsigned)(t->info.max_level > 0 ? t->info.max_level : 1));
        double lo = vec3_get(t->world.lo, axis), hi = vec3_get(t->world.hi, axis);
        uint64_t cells = (uint64_t)1 << level;
        double plane = lo;
        uint64_t k = 1 + rng_next(r) % (cells - 1 ? cells - 1 : 1);
        /* The split planes as the tree computes them: repeated midpoints. */
        double l = lo, h = hi;
        for (int j = level - 1; j >= 0; j--) {
            double mid = box_split(l, h);
            if ((k >> j) & 1)
                l = mid;
            else
                h = mid;
        }
        plane = l;
        ray.origin = vec3_with(ray.origin, axis, plane);
        target = vec3_with(kind == 3 ? a : point_near(r, b), axis, plane);
        if (kind == 4) /* grazing the face: a tiny component across it */
            target = vec3_with(target, axis, plane + (rng_next(r) & 1 ? 1 : -1) * 1e-12 * (hi - lo));
    } else {
        target = point_near(r, b);
    }
    ray.direction = vec3_sub(target, ray.origin);
    if (ray.direction.x == 0 && ray.direction.y == 0 && ray.direction.z == 0)
        ray.direction.x = 1;
    uint64_t range = rng_next(r) % 8;
    if (range == 0)
        ray.tmax = rng_uniform(r, 0.2, 1.5);
    else if (range == 1)
        ray.tmin = rng_uniform(r, 0.2, 0.9);
    else if (range == 2)
        ray.tmin = -rng_uniform(r, 0.0, 1.0);
    return ray;
}

/* Query triangles where rounding decides: a mesh triangle itself, one with a corner on a
 * mesh vertex, one about a leaf across near the surface, one lying in a node face, and a
 * world triangle's edge shared with a thin triangle outside. */
static void hard_triangle(rng *r, const mesh_data *m, const octree *t, vec3 q[3])
{
    double leaf = t->info.resolution;
    uint64_t kind = rng_next(r) % 5;
    if (kind < 3) {
        query_triangle_sample(m, r, leaf, (query_triangle_kind)kind, q);
        return;
    }
    size_t tri = rng_next(r) % m->triangle_count;
    vec3 w[3];
    mesh_triangle(m, tri, w);
    if (kind == 3) {
        /* In the plane of a node face through the triangle's first vertex. */
        int axis = (int)(rng_next(r) % 3);
        double lo = vec3_get(t->world.lo, axis), hi = vec3_get(t->world.hi, axis);
        double l = lo, h = hi, x = vec3_get(w[0], axis);
        for (int j = 0; j < t->info.max_level; j++) {
            double mid = box_split(l, h);
            if (x >= mid)
                l = mid;
            else
                h = mid;
        }
        double plane = x - l < h - x ? l : h;
        for (int k = 0; k < 3; k++)
            q[k] = vec3_with(k == 0 ? w[0] : vec3_add(w[0], vec3_scale(rng_unit_vector(r), leaf)), axis, plane);
        return;
    }
    /* Sharing an edge with a mesh triangle, folded a little out of its plane. */
    vec3 mid = vec3_add(vec3_scale(w[0], 0.5), vec3_scale(w[1], 0.5));
    vec3 out = vec3_sub(mid, w[2]);
    q[0] = w[1];
    q[1] = w[0];
    q[2] = vec3_add(vec3_add(mid, out), vec3_scale(rng_unit_vector(r), 1e-9 * vec3_length(out)));
}

typedef struct mode_scene {
    const char *name;
    mesh_data mesh;
    double resolution; /* 0: the heuristic */
} mode_scene;

static void run_mode_scene(mode_scene *s, accuracy_mode mode, double seed_eps, uint64_t seed, int rays,
                           int tris)
{
    double h = s->resolution > 0 ? s->resolution : heuristic_of(&s->mesh);
    const double factors[] = {0.125, 1.0, 4.0};
    for (int f = 0; f < 3; f++) {
        octree *t = build_mode(&s->mesh, h * factors[f], mode, seed_eps);
        rng r = rng_seeded(seed + (uint64_t)f);
        tally ty = {0};
        char what[160];
        snprintf(what, sizeof what, "%s (resolution x%g, seed %llu)", s->name, factors[f],
                 (unsigned long long)(seed + (uint64_t)f));
        for (int i = 0; i < rays; i++) {
            ray_input ray = hard_ray(&r, &s->mesh, t);
            check_ray(t, &s->mesh, &ray, mode, &ty, what);
        }
        for (int i = 0; i < tris; i++) {
            vec3 q[3];
            hard_triangle(&r, &s->mesh, t, q);
            check_triangle(t, &s->mesh, q, mode, &ty, what);
        }
        /* Both answers occur, so agreement is not that of two empty answers. */
        if (rays >= 50)
            assert_true(ty.ray_hits > 0 && ty.ray_hits < ty.rays);
        if (tris >= 50)
            assert_true(ty.triangle_hits > 0);
        octree_free(t);
    }
}

static mode_scene *make_scenes(uint64_t seed, size_t *count)
{
    static mode_scene scenes[8];
    box3 unit = {{-1, -1, -1}, {1, 1, 1}};
    mesh_data sphere = meshgen_icosphere((vec3){0.125, 0.25, 0}, 1.0, 2);
    mesh_data blocks = meshgen_blocks(seed, 4, 3, 3, 0.5);
    size_t n = 0;
    scenes[n++] = (mode_scene){"icosphere", meshgen_icosphere((vec3){0.125, 0.25, 0}, 1.0, 2), 0};
    scenes[n++] = (mode_scene){"box", meshgen_box((box3){{-1, -0.5, -0.25}, {1, 0.5, 0.25}}), 0};
    scenes[n++] = (mode_scene){"blocks", meshgen_blocks(seed, 4, 3, 3, 0.5), 0};
    scenes[n++] = (mode_scene){"soup", meshgen_soup(seed, 300, unit, 0.3), 0};
    scenes[n++] = (mode_scene){"icosphere at 1e6", meshgen_transformed(&sphere, 1e-3, (vec3){1e6, -1e6, 1e6}), 0};
    scenes[n++] = (mode_scene){"icosphere at 1e9", meshgen_transformed(&sphere, 1.0, (vec3){1e9, 1e9, -1e9}), 0};
    scenes[n++] = (mode_scene){"blocks at 1e6", meshgen_transformed(&blocks, 1.0, (vec3){1e6, 1e6, 1e6}), 0};
    scenes[n++] = (mode_scene){"torus", meshgen_torus((vec3){0, 0, 0}, 2.0, 0.5, 24, 12), 0};
    mesh_data_free(&sphere);
    mesh_data_free(&blocks);
    *count = n;
    return scenes;
}

static void run_mode(accuracy_mode mode, double seed_eps, uint64_t seed, int rays, int tris)
{
    size_t n;
    mode_scene *scenes = make_scenes(seed, &n);
    for (size_t i = 0; i < n; i++) {
        printf("%s %s: %zu triangles, seed %llu\n", accuracy_mode_name(mode), scenes[i].name,
               scenes[i].mesh.triangle_count, (unsigned long long)(seed + 10 * i));
        run_mode_scene(&scenes[i], mode, seed_eps, seed + 10 * i, rays, tris);
        mesh_data_free(&scenes[i].mesh);
    }
}

static void test_fast_answers_equal_brute_force_over_the_fast_primitive(void **state)
{
    (void)state;
    run_mode(ACCURACY_FAST, 1e-9, base_seed + 100, 400, 120);
}

static void test_seed_answers_equal_brute_force_over_the_seed_primitive(void **state)
{
    (void)state;
    run_mode(ACCURACY_SEED, 1e-9, base_seed + 200, 250, 60);
}

/* A large epsilon makes seed's tests reach far past each triangle: the octree must still
 * find every triangle they accept. */
static void test_seed_with_a_large_epsilon_equals_brute_force(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 300;
    mode_scene s = {"icosphere, epsilon 1e-3", meshgen_icosphere((vec3){0.125, 0.25, 0}, 1.0, 2), 0};
    printf("seed epsilon 1e-3: seed %llu\n", (unsigned long long)seed);
    run_mode_scene(&s, ACCURACY_SEED, 1e-3, seed, 150, 40);
    mesh_data_free(&s.mesh);
}

/* Triangles a hair's breadth off node faces (1e-13 of the world, on their own side), and
 * rays from far away (a distant sensor) aimed just past their edges on the face's other
 * side: Moller-Trumbore's rounding, which grows with the distance to the origin, accepts
 * some of those rays, whose exact crossing lies in a leaf the triangle is not in. */
static void test_fast_rays_from_afar_past_edges_near_node_faces(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 800;
    printf("rays from afar seed %llu\n", (unsigned long long)seed);
    mesh_data m = touching_scene(seed, 300, 1e-13);
    const accuracy_mode modes[] = {ACCURACY_FAST, ACCURACY_SEED};
    for (int k = 0; k < 2; k++) {
        octree *t = build_mode(&m, 0.25, modes[k], 1e-12);
        rng r = rng_seeded(seed);
        tally ty = {0};
        for (int i = 0; i < 3000; i++) {
            size_t tri = 2 + rng_next(&r) % (m.triangle_count - 2);
            vec3 w[3];
            mesh_triangle(&m, tri, w);
            /* A point on the edge w0 -> w1, pushed across the nearest split plane. */
            double a = rng_uniform(&r, 0.0, 1.0);
            vec3 target = vec3_add(vec3_scale(w[0], 1 - a), vec3_scale(w[1], a));
            vec3 from_centre = vec3_sub(target, vec3_scale(vec3_add(w[0], vec3_add(w[1], w[2])), 1.0 / 3));
            target = vec3_add(target, vec3_scale(from_centre, 1e-12 * rng_uniform(&r, 0, 4)));
            vec3 o = vec3_add(target, vec3_scale(rng_unit_vector(&r), pow(10.0, rng_uniform(&r, 2, 6))));
            ray_input ray = {o, vec3_sub(target, o), 0, INFINITY, RAY_CROSSING};
            check_ray(t, &m, &ray, modes[k], &ty, "rays from afar");
        }
        printf("  %s: %zu of %zu rays hit\n", accuracy_mode_name(modes[k]), ty.ray_hits, ty.rays);
        octree_free(t);
    }
    mesh_data_free(&m);
}

/* A flat world: one triangle in each cell of a grid on a plane through a random point at a
 * random angle (its vertices rounded off the plane, a third lifted by up to 1e-9 of a
 * cell), and query triangles in the same plane (a quarter lifted so) over one cell, many cells from most of the others.
 * Moller's intervals for such nearly coplanar pairs come from rounding, which accepted
 * pairs cells apart, beyond any slack: the octree then missed what brute force over the
 * same test found. */
static void test_fast_nearly_coplanar_queries_equal_brute_force(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 900;
    printf("nearly coplanar seed %llu\n", (unsigned long long)seed);
    rng r = rng_seeded(seed);
    enum { GRID = 12 };
    mesh_data m = {0};
    m.vertex_count = 3 * GRID * GRID;
    m.triangle_count = GRID * GRID;
    m.vertices = malloc(m.vertex_count * sizeof *m.vertices);
    m.indices = malloc(3 * m.triangle_count * sizeof *m.indices);
    vec3 n = rng_unit_vector(&r);
    vec3 e1 = vec3_cross(n, fabs(n.x) < 0.5 ? (vec3){1, 0, 0} : (vec3){0, 1, 0});
    e1 = vec3_scale(e1, 1 / vec3_length(e1));
    vec3 e2 = vec3_cross(n, e1);
    vec3 o = rng_point_in_box(&r, (box3){{-5, -5, -5}, {5, 5, 5}});
    for (int c = 0; c < GRID * GRID; c++) {
        double lift = c % 3 == 0 ? 1e-9 : 0.0;
        for (int k = 0; k < 3; k++) {
            double s = c % GRID + rng_uniform(&r, 0.1, 0.9), t = c / GRID + rng_uniform(&r, 0.1, 0.9);
            m.vertices[3 * c + k] = vec3_add(vec3_add(o, vec3_add(vec3_scale(e1, s), vec3_scale(e2, t))),
                                             vec3_scale(n, lift * rng_uniform(&r, -1, 1)));
            m.indices[3 * c + k] = (uint32_t)(3 * c + k);
        }
    }
    tally ty = {0};
    const double resolutions[] = {0.25, 1.0};
    for (int f = 0; f < 2; f++) {
        octree *t = build_mode(&m, resolutions[f], ACCURACY_FAST, 1e-9);
        for (int i = 0; i < 300; i++) {
            int c = (int)(rng_next(&r) % (GRID * GRID));
            vec3 q[3];
            double lift = i % 4 == 0 ? 1e-9 : 0.0;
            for (int k = 0; k < 3; k++) {
                double s = c % GRID + rng_uniform(&r, 0.0, 1.0), u = c / GRID + rng_uniform(&r, 0.0, 1.0);
                q[k] = vec3_add(vec3_add(o, vec3_add(vec3_scale(e1, s), vec3_scale(e2, u))),
                                vec3_scale(n, lift * rng_uniform(&r, -1, 1)));
            }
            check_triangle(t, &m, q, ACCURACY_FAST, &ty, "nearly coplanar");
        }
        octree_free(t);
    }
    printf("  %zu of %zu queries hit\n", ty.triangle_hits, ty.triangles);
    assert_true(ty.triangle_hits > 0 && ty.triangle_hits < ty.triangles);
    mesh_data_free(&m);
}

/* A zero-area triangle (a segment) has no normal. Projected as coplanar with the other
 * triangle, the fast test accepted it wherever its projection crossed the other's, however
 * far above it ran, which no slack bounds; it is now tested as the segment it is. Through
 * the octree the fast answers equal the primitive's, world segment or query segment. */
static void test_fast_zero_area_triangles_are_tested_as_segments(void **state)
{
    (void)state;
    mesh_data m = {0};
    m.vertex_count = 12;
    m.triangle_count = 4;
    m.vertices = malloc(m.vertex_count * sizeof *m.vertices);
    m.indices = malloc(m.vertex_count * sizeof *m.indices);
    /* Segment 0 passes through z = 0 at x = 8, far from the query, and runs 0.6 above it;
     * segment 1 crosses the query's plane inside it, at (0.25, 0.25, 0). */
    const vec3 v[12] = {{-2, 0.25, -1}, {8, 0.25, 0}, {18, 0.25, 1},
                        {0.15, 0.05, -0.5}, {0.25, 0.25, 0}, {0.35, 0.45, 0.5},
                        {-9, -9, 0.5}, {-8, -9, 0.5}, {-9, -8, 0.5},
                        {9, 9, -0.5}, {8, 9, -0.5}, {9, 8, -0.5}};
    for (uint32_t i = 0; i < 12; i++) {
        m.vertices[i] = v[i];
        m.indices[i] = i;
    }
    vec3 q[3] = {{-0.5, -0.5, 0}, {1.5, 0, 0}, {0, 1.5, 0}};
    vec3 far_above[3] = {v[0], v[1], v[2]}, through[3] = {v[3], v[4], v[5]};
    assert_int_equal(tri_tri_overlap_fast(q, far_above), 0);
    assert_int_equal(tri_tri_overlap_fast(far_above, q), 0);
    assert_int_equal(tri_tri_overlap_fast(q, through), 1);
    assert_int_equal(tri_tri_overlap_fast(through, q), 1);
    tally ty = {0};
    const double resolutions[] = {0.05, 0.5, 4.0};
    for (int f = 0; f < 3; f++) {
        octree *t = build_mode(&m, resolutions[f], ACCURACY_FAST, 1e-9);
        check_triangle(t, &m, q, ACCURACY_FAST, &ty, "zero-area world triangles");
        check_triangle(t, &m, far_above, ACCURACY_FAST, &ty, "zero-area query far above");
        check_triangle(t, &m, through, ACCURACY_FAST, &ty, "zero-area query through");
        octree_free(t);
    }
    assert_int_equal(ty.triangle_hits, 9); /* each query meets a segment or itself */
    mesh_data_free(&m);

    /* Two segments 5 apart whose projections along x cross: with no normal on either side
     * the fast test projects both along x and accepts them, which no slack bounds; the
     * tree's sliver list holds every such triangle, and a fast sliver query tests it. */
    mesh_data two = {0};
    two.vertex_count = 6;
    two.triangle_count = 2;
    two.vertices = malloc(6 * sizeof *two.vertices);
    two.indices = malloc(6 * sizeof *two.indices);
    const vec3 w[6] = {{5, 0, -1}, {5, 0, 0}, {5, 0, 1}, {-9, -9, 0.5}, {-8, -9, 0.5}, {-9, -8, 0.5}};
    for (uint32_t i = 0; i < 6; i++) {
        two.vertices[i] = w[i];
        two.indices[i] = i;
    }
    vec3 along_y[3] = {{0, -1, 0}, {0, 0, 0}, {0, 1, 0}}, along_z[3] = {w[0], w[1], w[2]};
    assert_int_equal(tri_tri_overlap_fast(along_y, along_z), 1); /* the primitive's answer */
    ty = (tally){0};
    for (int f = 0; f < 3; f++) {
        octree *t = build_mode(&two, resolutions[f], ACCURACY_FAST, 1e-9);
        check_triangle(t, &two, along_y, ACCURACY_FAST, &ty, "zero-area query, zero-area world");
        octree_free(t);
    }
    assert_int_equal(ty.triangle_hits, 3);
    mesh_data_free(&two);
}

/* A fast or seed query on a tree built in another mode gets the same answers: the tree
 * holds what every mode's queries need. */
static void test_queries_of_each_mode_on_trees_of_every_mode(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 400;
    printf("cross-mode seed %llu\n", (unsigned long long)seed);
    mesh_data m = meshgen_blocks(seed, 3, 3, 3, 0.5);
    const accuracy_mode modes[] = {ACCURACY_EXACT, ACCURACY_SEED, ACCURACY_FAST};
    for (int b = 0; b < 3; b++) {
        octree *t = build_mode(&m, 0.25, modes[b], 1e-9);
        for (int q = 0; q < 3; q++) {
            rng r = rng_seeded(seed);
            tally ty = {0};
            char what[64];
            snprintf(what, sizeof what, "blocks, %s tree", accuracy_mode_name(modes[b]));
            for (int i = 0; i < 150; i++) {
                ray_input ray = hard_ray(&r, &m, t);
                check_ray(t, &m, &ray, modes[q], &ty, what);
            }
            for (int i = 0; i < 40; i++) {
                vec3 tri[3];
                hard_triangle(&r, &m, t, tri);
                check_triangle(t, &m, tri, modes[q], &ty, what);
            }
        }
        octree_free(t);
    }
    mesh_data_free(&m);
}

/* Mesh queries under poses equal the per-triangle brute force of the mode. */
static void test_mesh_queries_equal_brute_force_in_fast_and_seed_mode(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 500;
    printf("mesh query seed %llu\n", (unsigned long long)seed);
    mesh_data world = meshgen_blocks(seed, 4, 4, 2, 0.5);
    mesh_data shape = meshgen_box((box3){{0, 0, 0}, {0.5, 0.5, 0.5}});
    mesh_view wv = mesh_data_view(&world), sv = mesh_data_view(&shape);
    const accuracy_mode modes[] = {ACCURACY_FAST, ACCURACY_SEED};
    enum { CAP = 8192 };
    mesh_pair *pairs = malloc(CAP * sizeof *pairs);
    uint32_t *ids = malloc(CAP * sizeof *ids);
    for (int k = 0; k < 2; k++) {
        octree *t = build_mode(&world, 0.25, modes[k], 1e-9);
        rng r = rng_seeded(seed + (uint64_t)k);
        int hits = 0;
        for (int i = 0; i < 40; i++) {
            /* Grid-aligned poses put the shape's faces on block faces and node faces. */
            int turn = (int)(rng_next(&r) % 4);
            double c = turn == 0 ? 1 : turn == 2 ? -1 : 0, s = turn == 1 ? 1 : turn == 3 ? -1 : 0;
            pose p = {{c, -s, 0, s, c, 0, 0, 0, 1},
                      {0.25 * (double)(rng_next(&r) % 9), 0.25 * (double)(rng_next(&r) % 9),
                       0.25 * (double)(rng_next(&r) % 6)}};
            mesh_output out = {.pairs = pairs, .capacity = CAP};
            assert_int_equal(octree_mesh(t, &sv, &p, 1, modes[k], &out, NULL), OCTREE_OK);
            size_t at = 0;
            for (size_t q = 0; q < shape.triangle_count; q++) {
                vec3 tri[3];
                for (int j = 0; j < 3; j++) {
                    vec3 v = shape.vertices[shape.indices[3 * q + (size_t)j]];
                    tri[j] = (vec3){p.r[0] * v.x + p.r[1] * v.y + p.r[2] * v.z + p.t.x,
                                    p.r[3] * v.x + p.r[4] * v.y + p.r[5] * v.z + p.t.y,
                                    p.r[6] * v.x + p.r[7] * v.y + p.r[8] * v.z + p.t.z};
                }
                size_t n = brute_triangle(&wv, tri, modes[k], t->seed_epsilon, ids, CAP);
                for (size_t j = 0; j < n; j++, at++) {
                    if (at >= out.count || pairs[at].query_triangle != q || pairs[at].world_triangle != ids[j])
                        fail_msg("%s mesh query %d: pair %zu differs from brute force", accuracy_mode_name(modes[k]),
                                 i, at);
                }
            }
            assert_int_equal(out.count, at);
            mesh_output yn = {0};
            assert_int_equal(octree_mesh(t, &sv, &p, 0, modes[k], &yn, NULL), OCTREE_OK);
            assert_int_equal(yn.hit, at > 0);
            hits += at > 0;
        }
        assert_true(hits > 0);
        octree_free(t);
    }
    free(pairs);
    free(ids);
    mesh_data_free(&world);
    mesh_data_free(&shape);
}

/* ---------- seed's parameter range ---------- */

/* The seed test accepts t a little outside [tmin, tmax] (its epsilon); what it reports
 * stays inside the closed interval the API promises. */
static void test_seed_hits_lie_in_the_closed_interval(void **state)
{
    (void)state;
    const vec3 tri[3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    ray_tri_hit h;
    /* The origin 1e-10 past the plane: t = -1e-10, within the epsilon of tmin = 0. */
    vec3 o = {0.25, 0.25, 1e-10}, d = {0, 0, 1};
    /* Kept as the seed's epsilon keeps it, reported at tmin. */
    assert_int_equal(ray_tri_seed(o, d, 0.0, INFINITY, tri, 1e-9, &h), 1);
    assert_true(h.t == 0.0);
    /* ... and a tmax short of the plane: the seed's t is 1 / (1 + 1e-9) (the epsilon in
     * its denominator), above a tmax of 1 - 1.5e-9 by less than the epsilon: reported at
     * tmax. */
    vec3 o2 = {0.25, 0.25, -1.0};
    assert_int_equal(ray_tri_seed(o2, d, 0.0, 1.0 - 1.5e-9, tri, 1e-9, &h), 1);
    assert_true(h.t == 1.0 - 1.5e-9);
    /* Through the octree, on a closed mesh, from origins on the surface. */
    mesh_data m = meshgen_icosphere((vec3){0, 0, 0}, 1.0, 2);
    octree *t = build_mode(&m, 0.0, ACCURACY_SEED, 1e-9);
    rng r = rng_seeded(base_seed + 600);
    ray_hit hits[64];
    int checked = 0;
    for (int i = 0; i < 400; i++) {
        size_t k = rng_next(&r) % m.triangle_count;
        vec3 w[3];
        mesh_triangle(&m, k, w);
        double a = rng_uniform(&r, 0.1, 0.8), b = rng_uniform(&r, 0.1, 0.9) * (1 - a);
        vec3 p = vec3_add(w[0], vec3_add(vec3_scale(vec3_sub(w[1], w[0]), a), vec3_scale(vec3_sub(w[2], w[0]), b)));
        ray_input ray = {p, rng_unit_vector(&r), 0.0, INFINITY, RAY_CROSSING};
        ray_output out = {.hits = hits, .max_hits = 64};
        assert_int_equal(octree_ray(t, &ray, RAY_ALL, ACCURACY_SEED, &out, NULL), OCTREE_OK);
        for (size_t j = 0; j < out.hit_count && j < 64; j++) {
            assert_true(hits[j].t >= ray.tmin && hits[j].t <= ray.tmax);
            checked++;
        }
    }
    assert_true(checked > 0);
    octree_free(t);
    mesh_data_free(&m);
}

/* A world about as small as the epsilon: every seed test reaches everything, yet the tree
 * is built as in exact mode, not into every node down to the last level. */
static void test_seed_build_of_a_world_near_the_epsilon_stays_small(void **state)
{
    (void)state;
    mesh_data unit = meshgen_icosphere((vec3){0, 0, 0}, 1.0, 2);
    mesh_data tiny = meshgen_transformed(&unit, 1e-9, (vec3){0, 0, 0});
    octree *seed_tree = build_mode(&tiny, 0.0, ACCURACY_SEED, 1e-9);
    octree *exact_tree = build_mode(&tiny, 0.0, ACCURACY_EXACT, 1e-9);
    assert_true(seed_tree->info.node_count <= exact_tree->info.node_count);
    assert_true(seed_tree->info.leaf_refs <= exact_tree->info.leaf_refs);
    tally ty = {0};
    rng r = rng_seeded(base_seed + 700);
    for (int i = 0; i < 40; i++) {
        ray_input ray = hard_ray(&r, &tiny, seed_tree);
        check_ray(seed_tree, &tiny, &ray, ACCURACY_SEED, &ty, "tiny world");
        vec3 q[3];
        hard_triangle(&r, &tiny, seed_tree, q);
        check_triangle(seed_tree, &tiny, q, ACCURACY_SEED, &ty, "tiny world");
    }
    octree_free(seed_tree);
    octree_free(exact_tree);
    mesh_data_free(&unit);
    mesh_data_free(&tiny);
}

int main(void)
{
    const char *s = getenv("TRIOCT_SEED");
    if (s)
        base_seed = strtoull(s, NULL, 10);
    printf("test_modes base seed %llu (set TRIOCT_SEED to rerun)\n", (unsigned long long)base_seed);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_membership_is_conservative_in_fast_and_seed_trees),
        cmocka_unit_test(test_seed_reach_factor_and_slivers),
        cmocka_unit_test(test_seed_touch_everything_triangles_are_listed),
        cmocka_unit_test(test_fast_answers_equal_brute_force_over_the_fast_primitive),
        cmocka_unit_test(test_seed_answers_equal_brute_force_over_the_seed_primitive),
        cmocka_unit_test(test_seed_with_a_large_epsilon_equals_brute_force),
        cmocka_unit_test(test_fast_rays_from_afar_past_edges_near_node_faces),
        cmocka_unit_test(test_fast_nearly_coplanar_queries_equal_brute_force),
        cmocka_unit_test(test_fast_zero_area_triangles_are_tested_as_segments),
        cmocka_unit_test(test_queries_of_each_mode_on_trees_of_every_mode),
        cmocka_unit_test(test_mesh_queries_equal_brute_force_in_fast_and_seed_mode),
        cmocka_unit_test(test_seed_hits_lie_in_the_closed_interval),
        cmocka_unit_test(test_seed_build_of_a_world_near_the_epsilon_stays_small),
    };
    return cmocka_run_group_tests_name("modes", tests, NULL, NULL);
}
