/* Octree tests: the seed's construction, conservative exact membership, and every query
 * answering exactly what brute force over all triangles answers. */
#include <float.h>
#include <math.h>
#include <pthread.h>
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
#include "geom/tri_box.h"
#include "octree/octree_internal.h"
#include "support/brute_force.h"
#include "support/meshgen.h"
#include "support/oracle.h"
#include "world/mesh_load.h"

static uint64_t base_seed = 20261121;

static octree *build_or_fail(const mesh_data *m, double resolution, accuracy_mode mode)
{
    octree_def def = octree_default_def();
    def.resolution = resolution;
    def.mode = mode;
    mesh_view v = mesh_data_view(m);
    octree_error err;
    octree *t = octree_build(&v, &def, &err);
    if (!t)
        fail_msg("build failed: %s", err.message);
    return t;
}

/* ---------- construction ---------- */

static void test_levels_and_enlarged_world(void **state)
{
    (void)state;
    mesh_data m = meshgen_box((box3){{0, 0, 0}, {10, 3, 2}});
    octree *t = build_or_fail(&m, 1.0, ACCURACY_EXACT);
    octree_info info;
    octree_get_info(t, &info);
    assert_int_equal(info.max_level, 4); /* ceil(log2(10 / 1)) */
    assert_true(info.world_size == 16.0);
    assert_true(info.resolution == 1.0);
    assert_true(info.world_min.x == 0.0 && info.world_min.y == 0.0 && info.world_min.z == 0.0);
    assert_int_equal(info.triangle_count, 12);
    assert_true(info.node_count > 1 && (info.node_count - 1) % 8 == 0);
    assert_true(info.bytes_total > info.bytes_nodes);
    octree_free(t);
    mesh_data_free(&m);
}

static void test_seed_heuristic_resolution(void **state)
{
    (void)state;
    /* Two right triangles with legs 2: |E2 x E0| = 4 each, so d = sqrt(4) = 2. */
    vec3 v[] = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {10, 0, 0}, {12, 0, 0}, {10, 2, 0}};
    uint32_t ix[] = {0, 1, 2, 3, 4, 5};
    mesh_view mv = {v, 6, ix, 2};
    octree *t = octree_build(&mv, NULL, NULL);
    assert_non_null(t);
    octree_info info;
    octree_get_info(t, &info);
    assert_true(info.resolution == 2.0);
    assert_int_equal(info.max_level, 3); /* extent 12: 2 * 2^3 = 16 >= 12 > 8 */
    octree_free(t);
}

static void test_nan_vertex_is_rejected_naming_the_triangle(void **state)
{
    (void)state;
    vec3 v[] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {NAN, 0, 0}};
    uint32_t ix[] = {0, 1, 2, 0, 2, 1, 1, 2, 3};
    mesh_view mv = {v, 4, ix, 3};
    octree_error err;
    assert_null(octree_build(&mv, NULL, &err));
    assert_int_equal(err.status, OCTREE_ERR_NONFINITE);
    assert_int_equal(err.triangle, 2);
    assert_non_null(strstr(err.message, "triangle 2"));
    v[3] = (vec3){0, INFINITY, 0};
    assert_null(octree_build(&mv, NULL, &err));
    assert_int_equal(err.status, OCTREE_ERR_NONFINITE);
}

static void test_bad_index_and_empty_mesh_are_rejected(void **state)
{
    (void)state;
    vec3 v[] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    uint32_t ix[] = {0, 1, 3};
    mesh_view mv = {v, 3, ix, 1};
    octree_error err;
    assert_null(octree_build(&mv, NULL, &err));
    assert_int_equal(err.status, OCTREE_ERR_INDEX);
    assert_int_equal(err.triangle, 0);
    mv.triangle_count = 0;
    assert_null(octree_build(&mv, NULL, &err));
    assert_int_equal(err.status, OCTREE_ERR_EMPTY);
    octree_def def = octree_default_def();
    def.max_depth = OCTREE_MAX_DEPTH_CAP + 1;
    mv.triangle_count = 1;
    ix[2] = 2;
    assert_null(octree_build(&mv, &def, &err));
    assert_int_equal(err.status, OCTREE_ERR_INVALID);
}

static void test_depth_cap_errors_when_explicit_and_clamps_heuristic(void **state)
{
    (void)state;
    /* Extent 1e6 with triangles of 1e-3: log2(1e9) is about 30 levels, over the cap. */
    mesh_data a = meshgen_soup(base_seed, 50, (box3){{0, 0, 0}, {1e6, 1e6, 1e6}}, 1e-3);
    mesh_view v = mesh_data_view(&a);
    octree_def def = octree_default_def();
    def.resolution = 1e-3;
    octree_error err;
    assert_null(octree_build(&v, &def, &err));
    assert_int_equal(err.status, OCTREE_ERR_DEPTH);
    assert_non_null(strstr(err.message, "cap"));
    def.resolution = 0; /* heuristic */
    octree *t = octree_build(&v, &def, &err);
    assert_non_null(t);
    octree_info info;
    octree_get_info(t, &info);
    assert_int_equal(info.max_level, def.max_depth);
    assert_int_equal(info.depth_clamped, 1);
    assert_true(ldexp(info.resolution, info.max_level) == info.world_size);
    octree_free(t);
    mesh_data_free(&a);
}

/* A needle: its area is tiny, so the heuristic leaf is tiny and the tree goes to the depth
 * cap along the needle's length (about 0.9 million nodes, 7.6 MB, for one triangle). */
static mesh_data needle(void)
{
    mesh_data m = meshgen_triangle((vec3){0, 0, 0}, (vec3){1, 0.3, 0.2}, (vec3){0.5, 0.15 + 1e-12, 0.1});
    assert_non_null(m.vertices);
    return m;
}

static void test_build_stops_at_its_budget(void **state)
{
    (void)state;
    mesh_data m = needle();
    mesh_view v = mesh_data_view(&m);
    octree_def def = octree_default_def();
    octree_error err;
    /* The default budget (256 MiB + 4 KiB a triangle) lets the needle build. */
    octree *t = octree_build(&v, &def, &err);
    assert_non_null(t);
    octree_info info;
    octree_get_info(t, &info);
    assert_int_equal(info.max_level, 16);
    assert_true(info.node_count > 100000);
    octree_free(t);
    /* A budget below what it needs stops it, naming the budget; nothing leaks (ASan). */
    def.budget_bytes = info.bytes_total / 4;
    assert_null(octree_build(&v, &def, &err));
    assert_int_equal(err.status, OCTREE_ERR_BUDGET);
    char budget[32];
    snprintf(budget, sizeof budget, "budget of %zu bytes", def.budget_bytes);
    assert_non_null(strstr(err.message, budget));
    assert_string_equal(octree_status_text(OCTREE_ERR_BUDGET), "the build needs more memory than its budget");
    /* A budget smaller than the copy of the mesh stops it before anything is built. */
    def.budget_bytes = 100;
    assert_null(octree_build(&v, &def, &err));
    assert_int_equal(err.status, OCTREE_ERR_BUDGET);
    assert_non_null(strstr(err.message, "over its budget of 100 bytes"));
    /* No budget at all: the same tree as the default's. */
    def.budget_bytes = SIZE_MAX;
    t = octree_build(&v, &def, &err);
    assert_non_null(t);
    octree_info unbounded;
    octree_get_info(t, &unbounded);
    assert_int_equal(unbounded.node_count, info.node_count);
    octree_free(t);
    mesh_data_free(&m);
}

/* A shared account: a tree holds exactly its bytes of it and gives them back when freed;
 * a build the account has no room for stops with the memory budget in its message and
 * leaves the account as it found it; two trees count side by side. */
static void test_build_takes_from_a_shared_account(void **state)
{
    (void)state;
    mesh_data m = needle();
    mesh_view v = mesh_data_view(&m);
    octree_def def = octree_default_def();
    memory_account account;
    memory_account_init(&account, SIZE_MAX);
    def.account = &account;
    octree_error err;
    octree *t = octree_build(&v, &def, &err);
    assert_non_null(t);
    octree_info info;
    octree_get_info(t, &info);
    assert_int_equal(memory_account_used(&account), info.bytes_total);
    octree *second = octree_build(&v, &def, &err);
    assert_non_null(second);
    assert_int_equal(memory_account_used(&account), 2 * info.bytes_total);
    octree_free(second);
    assert_int_equal(memory_account_used(&account), info.bytes_total);

    /* Room for a little more than one tree: the second stops as it grows. */
    account.limit = info.bytes_total + info.bytes_total / 2;
    assert_null(octree_build(&v, &def, &err));
    assert_int_equal(err.status, OCTREE_ERR_BUDGET);
    assert_non_null(strstr(err.message, "memory budget"));
    assert_int_equal(memory_account_used(&account), info.bytes_total);
    /* No room even for the copy of the mesh: stopped at once. */
    account.limit = info.bytes_total + 10;
    assert_null(octree_build(&v, &def, &err));
    assert_int_equal(err.status, OCTREE_ERR_BUDGET);
    assert_non_null(strstr(err.message, "has 10 left"));
    assert_int_equal(memory_account_used(&account), info.bytes_total);
    octree_free(t);
    assert_int_equal(memory_account_used(&account), 0);
    mesh_data_free(&m);
}

/* The seed's epsilon at the scale of the world made every node touch every triangle when
 * the seed's test decided membership (one tiny triangle passed 4 GB). Every mode now builds
 * the exact tree, so the seed build is the exact build and fits a small budget. */
static void test_seed_epsilon_at_the_world_scale_builds_the_exact_tree(void **state)
{
    (void)state;
    mesh_data m = needle();
    mesh_data tiny = meshgen_transformed(&m, 1e-9, (vec3){0, 0, 0});
    mesh_view v = mesh_data_view(&tiny);
    octree_def def = octree_default_def();
    def.budget_bytes = (size_t)16 << 20;
    octree_error err;
    octree *exact = octree_build(&v, &def, &err);
    assert_non_null(exact);
    def.mode = ACCURACY_SEED;
    def.seed_epsilon = 1e-9;
    octree *seed = octree_build(&v, &def, &err);
    if (!seed)
        fail_msg("seed build: %s", err.message);
    octree_info a, b;
    octree_get_info(exact, &a);
    octree_get_info(seed, &b);
    assert_int_equal(a.node_count, b.node_count);
    assert_int_equal(a.leaf_refs, b.leaf_refs);
    octree_free(exact);
    octree_free(seed);
    mesh_data_free(&tiny);
    mesh_data_free(&m);
}

/* Each status's text says what was wrong, whatever was given: a ray's NaN is not a
 * triangle's. */
static void test_status_texts_are_distinct_and_general(void **state)
{
    (void)state;
    const octree_status all[] = {
#define OCTREE_STATUS_LIST(name, code, text) name,
        OCTREE_STATUS_MAP(OCTREE_STATUS_LIST)
#undef OCTREE_STATUS_LIST
    };
    size_t n = sizeof all / sizeof all[0];
    for (size_t i = 0; i < n; i++) {
        assert_true(strlen(octree_status_text(all[i])) > 0);
        for (size_t j = 0; j < i; j++)
            assert_string_not_equal(octree_status_text(all[i]), octree_status_text(all[j]));
    }
    assert_null(strstr(octree_status_text(OCTREE_ERR_NONFINITE), "triangle"));
    assert_string_equal(octree_status_text(OCTREE_ERR_NONFINITE), "a coordinate is NaN or infinite");
}

static void test_children_follow_the_seed_octant_order(void **state)
{
    (void)state;
    mesh_data m = meshgen_icosphere((vec3){0, 0, 0}, 1.0, 2);
    octree *t = build_or_fail(&m, 0.25, ACCURACY_EXACT);
    octree_node root = t->nodes[0];
    assert_int_equal(root.count, NODE_INTERIOR);
    /* Appended after the root, at the first index that starts a cache line: every
     * children block is one 64-byte line. */
    assert_int_equal(root.first, 8);
    assert_true((uintptr_t)t->nodes % 64 == 0);
    for (size_t i = 0; i < t->node_count; i++)
        if (t->nodes[i].count == NODE_INTERIOR)
            assert_int_equal(t->nodes[i].first % 8, 0);
    box3 w = t->world;
    vec3 c = vec3_scale(vec3_add(w.lo, w.hi), 0.5);
    box3 first = box_octant(w, 0), seventh = box_octant(w, 6);
    /* The seed's octant 1 is the upper corner [C, Pmax], octant 7 the lower [Pmin, C]. */
    assert_true(vec3_equal(first.lo, c) && vec3_equal(first.hi, w.hi));
    assert_true(vec3_equal(seventh.lo, w.lo) && vec3_equal(seventh.hi, c));
    octree_free(t);
    mesh_data_free(&m);
}

/* ---------- membership ---------- */

typedef struct leaf_ref {
    uint32_t node;
    box3 box;
} leaf_ref;

static size_t collect_leaves(const octree *t, leaf_ref *out, size_t cap)
{
    size_t n = 0;
    leaf_ref stack[OCTREE_STACK_MAX];
    size_t top = 0;
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

/* Leaves list internal ids; tests speak of the caller's. */
static int leaf_holds(const octree *t, uint32_t node, uint32_t id)
{
    octree_node nd = t->nodes[node];
    for (uint32_t i = 0; i < nd.count; i++)
        if (t->original_id[t->leaf_items[nd.first + i]] == id)
            return 1;
    return 0;
}

static void caller_triangle(const octree *t, const mesh_data *m, uint32_t id, vec3 out[3])
{
    (void)t;
    for (int k = 0; k < 3; k++)
        out[k] = m->vertices[m->indices[3 * (size_t)id + (size_t)k]];
}

static void check_membership(const mesh_data *m, double resolution, uint64_t seed, int oracle_samples)
{
    octree *t = build_or_fail(m, resolution, ACCURACY_EXACT);
    size_t nleaves = collect_leaves(t, NULL, 0);
    leaf_ref *leaves = malloc(nleaves * sizeof *leaves);
    collect_leaves(t, leaves, nleaves);
    rng r = rng_seeded(seed);
    for (int s = 0; s < 200; s++) {
        leaf_ref L = leaves[rng_next(&r) % nleaves];
        for (size_t i = 0; i < m->triangle_count; i++) {
            vec3 tri[3];
            caller_triangle(t, m, (uint32_t)i, tri);
            int touches = tri_box_overlap_exact(tri, L.box);
            if (touches != leaf_holds(t, L.node, (uint32_t)i))
                fail_msg("seed %llu: triangle %zu touches=%d but leaf %u holds=%d", (unsigned long long)seed, i,
                         touches, L.node, !touches);
            if (s < oracle_samples) {
                box3 grown = L.box; /* the GMP oracle is slow: only near triangles */
                vec3 lo = vec3_min(vec3_min(tri[0], tri[1]), tri[2]), hi = vec3_max(vec3_max(tri[0], tri[1]), tri[2]);
                if (lo.x <= grown.hi.x && lo.y <= grown.hi.y && lo.z <= grown.hi.z && hi.x >= grown.lo.x &&
                    hi.y >= grown.lo.y && hi.z >= grown.lo.z)
                    assert_int_equal(oracle_tri_box(tri, L.box), touches);
            }
        }
    }
    free(leaves);
    octree_free(t);
}

static void test_membership_is_exact_on_random_leaves(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 1;
    printf("membership seed %llu\n", (unsigned long long)seed);
    mesh_data soup = meshgen_soup(seed, 400, (box3){{-1, -1, -1}, {1, 1, 1}}, 0.2);
    check_membership(&soup, 0.0, seed, 20);
    mesh_data blocks = meshgen_blocks(seed, 4, 4, 3, 0.5);
    check_membership(&blocks, 0.25, seed + 1, 20); /* block faces lie on node faces */
    mesh_data far = meshgen_transformed(&soup, 1e-3, (vec3){1e6, -1e6, 1e6});
    check_membership(&far, 0.0, seed + 2, 10);
    mesh_data_free(&soup);
    mesh_data_free(&blocks);
    mesh_data_free(&far);
}

static void test_triangles_on_node_faces_are_in_both_neighbours(void **state)
{
    (void)state;
    /* World [0, 4]^3 with d = 1. Triangles lying in the plane x = 2 (the root's centre
     * plane), along the line y = z = 2, and a zero-area point at the centre (2, 2, 2). */
    vec3 v[] = {{0, 0, 0}, {4, 4, 4}, {4, 0, 0},                 /* spans the world */
                {2, 0.5, 0.5}, {2, 1.5, 0.5}, {2, 0.5, 1.5},     /* on x = 2 */
                {0.5, 2, 2}, {1.5, 2, 2}, {1, 2, 2},             /* zero-area on a node edge */
                {2, 2, 2}, {2, 2, 2}, {2, 2, 2}};                /* a point on a node corner */
    uint32_t ix[] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11};
    mesh_view mv = {v, 12, ix, 4};
    octree_def def = octree_default_def();
    def.resolution = 1.0;
    octree *t = octree_build(&mv, &def, NULL);
    assert_non_null(t);
    assert_true(t->world.lo.x == 0 && t->world.hi.x == 4);
    size_t n = collect_leaves(t, NULL, 0);
    leaf_ref *leaves = malloc(n * sizeof *leaves);
    collect_leaves(t, leaves, n);
    int face_leaves = 0, edge_leaves = 0, corner_leaves = 0;
    for (size_t i = 0; i < n; i++) {
        box3 b = leaves[i].box;
        face_leaves += leaf_holds(t, leaves[i].node, 1);
        edge_leaves += leaf_holds(t, leaves[i].node, 2);
        corner_leaves += leaf_holds(t, leaves[i].node, 3);
        /* the point (2,2,2) is a corner of exactly 8 leaves */
        int at_corner = (b.lo.x == 2 || b.hi.x == 2) && (b.lo.y == 2 || b.hi.y == 2) && (b.lo.z == 2 || b.hi.z == 2);
        assert_int_equal(leaf_holds(t, leaves[i].node, 3), at_corner);
    }
    /* x = 2 face: the triangle covers cells y, z in [0, 2] on both sides: 2 sides x 4 cells. */
    assert_int_equal(face_leaves, 8);
    /* segment y = z = 2, x in [0.5, 1.5]: 4 cells around the line, times 2 along x. */
    assert_int_equal(edge_leaves, 8);
    assert_int_equal(corner_leaves, 8);
    free(leaves);

    /* A query triangle touching the face triangle only at its vertex (2, 0.5, 0.5) from
     * the x > 2 side finds it. */
    vec3 q[3] = {{2, 0.5, 0.5}, {3, 0.5, 0.5}, {3, 0.25, 0.25}};
    tri_contact c[8];
    tri_output out = {.contacts = c, .capacity = 8};
    assert_int_equal(octree_triangle(t, q, TRI_IDS, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
    assert_int_equal(out.count, 2);
    assert_int_equal(c[0].triangle, 0); /* the spanning triangle passes through too */
    assert_int_equal(c[1].triangle, 1);
    /* A ray lying in the node face plane x = 2 (zero x direction) grazes the face
     * triangle (parallel: no crossing) and crosses the spanning triangle. */
    ray_hit h[4];
    ray_output ro = {.hits = h, .max_hits = 4};
    ray_input ray = {{2, 1, -1}, {0, 0, 1}, 0, INFINITY, RAY_CROSSING};
    assert_int_equal(octree_ray(t, &ray, RAY_ALL, ACCURACY_EXACT, &ro, NULL), OCTREE_OK);
    ray_hit bh[4];
    size_t bn = brute_ray(&mv, &ray, RAY_ALL, ACCURACY_EXACT, 0, bh, 4);
    assert_int_equal(ro.hit_count, bn);
    for (size_t i = 0; i < bn; i++)
        assert_int_equal(h[i].triangle, bh[i].triangle);
    octree_free(t);
}

/* ---------- queries against brute force ---------- */

typedef struct scene {
    const char *name;
    mesh_data mesh;
    double resolution; /* 0: heuristic */
} scene;

static vec3 random_point_near(rng *r, box3 b)
{
    vec3 ext = vec3_sub(b.hi, b.lo);
    box3 g = {vec3_sub(b.lo, vec3_scale(ext, 0.25)), vec3_add(b.hi, vec3_scale(ext, 0.25))};
    return rng_point_in_box(r, g);
}

/* Rays of several kinds: toward a random vertex (through shared vertices), toward an edge
 * midpoint, axis-aligned, and fully random. */
static ray_input random_ray(rng *r, const mesh_data *m, box3 b)
{
    ray_input ray = {random_point_near(r, b), {0, 0, 0}, 0, INFINITY, RAY_CROSSING};
    uint64_t kind = rng_next(r) % 4;
    vec3 target;
    if (kind == 0) {
        target = m->vertices[rng_next(r) % m->vertex_count];
    } else if (kind == 1) {
        size_t t = rng_next(r) % m->triangle_count;
        vec3 a = m->vertices[m->indices[3 * t]], c = m->vertices[m->indices[3 * t + 1]];
        target = vec3_add(vec3_scale(a, 0.5), vec3_scale(c, 0.5)); /* a + c may overflow */
    } else if (kind == 2) {
        target = ray.origin;
        int axis = (int)(rng_next(r) % 3);
        double s = (rng_next(r) & 1) ? 1.0 : -1.0;
        if (axis == 0) target.x += s;
        if (axis == 1) target.y += s;
        if (axis == 2) target.z += s;
    } else {
        target = random_point_near(r, b);
    }
    ray.direction = vec3_sub(target, ray.origin);
    if (ray.direction.x == 0 && ray.direction.y == 0 && ray.direction.z == 0)
        ray.direction.x = 1;
    if (rng_next(r) % 5 == 0)
        ray.tmax = rng_uniform(r, 0.2, 1.5);
    return ray;
}

static void random_triangle(rng *r, box3 b, double size, vec3 q[3])
{
    q[0] = random_point_near(r, b);
    for (int k = 1; k < 3; k++)
        q[k] = vec3_add(q[0], vec3_scale(rng_unit_vector(r), size * rng_uniform(r, 0.1, 1.0)));
}

static void compare_rays(const octree *t, const mesh_data *m, rng *r, int count, accuracy_mode mode,
                         ray_contact contact)
{
    mesh_view v = mesh_data_view(m);
    box3 b = mesh_data_bounds(m);
    ray_hit got[64], want[64];
    for (int i = 0; i < count; i++) {
        ray_input ray = random_ray(r, m, b);
        ray.contact = contact;
        for (int detail = RAY_ANY; detail <= RAY_ALL; detail++) {
            ray_output out = {.hits = got, .max_hits = 64};
            assert_int_equal(octree_ray(t, &ray, (ray_detail)detail, mode, &out, NULL), OCTREE_OK);
            size_t n = brute_ray(&v, &ray, (ray_detail)detail, mode, t->seed_epsilon, want, 64);
            if (detail == RAY_ANY) {
                assert_int_equal(out.hit_count > 0, n > 0);
                continue;
            }
            if (out.hit_count != n)
                fail_msg("ray %d detail %d: octree %zu hits, brute force %zu", i, detail, out.hit_count, n);
            for (size_t k = 0; k < n && k < 64; k++) {
                if (got[k].triangle != want[k].triangle)
                    fail_msg("ray %d detail %d contact %d hit %zu: octree triangle %u, brute force %u", i, detail,
                             contact, k, got[k].triangle, want[k].triangle);
                assert_true(got[k].t == want[k].t);
            }
        }
    }
}

static void compare_triangles(const octree *t, const mesh_data *m, rng *r, int count, double size)
{
    mesh_view v = mesh_data_view(m);
    box3 b = mesh_data_bounds(m);
    size_t cap = m->triangle_count;
    uint32_t *want = malloc(cap * sizeof *want);
    tri_contact *got = malloc(cap * sizeof *got);
    for (int i = 0; i < count; i++) {
        vec3 q[3];
        if (i % 4 == 0) {
            /* a world triangle itself: touches at least itself and its neighbours */
            size_t w = rng_next(r) % m->triangle_count;
            for (int k = 0; k < 3; k++)
                q[k] = m->vertices[m->indices[3 * w + (size_t)k]];
        } else {
            random_triangle(r, b, size, q);
        }
        size_t n = brute_triangle(&v, q, ACCURACY_EXACT, 0, want, cap);
        tri_output out = {.contacts = got, .capacity = cap};
        assert_int_equal(octree_triangle(t, q, TRI_IDS, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
        if (out.count != n)
            fail_msg("triangle query %d: octree %zu ids, brute force %zu", i, out.count, n);
        for (size_t k = 0; k < n; k++)
            assert_int_equal(got[k].triangle, want[k]);
        tri_output yn = {0};
        assert_int_equal(octree_triangle(t, q, TRI_YESNO, ACCURACY_EXACT, &yn, NULL), OCTREE_OK);
        assert_int_equal(yn.hit, n > 0);
    }
    free(want);
    free(got);
}

static void run_scene(scene *s, uint64_t seed, int rays, int tris)
{
    printf("scene %s: %zu triangles, seed %llu\n", s->name, s->mesh.triangle_count, (unsigned long long)seed);
    octree *t = build_or_fail(&s->mesh, s->resolution, ACCURACY_EXACT);
    rng r = rng_seeded(seed);
    compare_rays(t, &s->mesh, &r, rays, ACCURACY_EXACT, RAY_CROSSING);
    rng rt = rng_seeded(seed);
    compare_rays(t, &s->mesh, &rt, rays, ACCURACY_EXACT, RAY_TOUCH);
    box3 b = mesh_data_bounds(&s->mesh);
    double size = 0.1 * fmax(b.hi.x - b.lo.x, fmax(b.hi.y - b.lo.y, b.hi.z - b.lo.z));
    compare_triangles(t, &s->mesh, &r, tris, size);
    octree_free(t);
}

static void test_random_scenes_equal_brute_force(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 2;
    box3 unit = {{-1, -1, -1}, {1, 1, 1}};
    mesh_data soup = meshgen_soup(seed, 600, unit, 0.3);
    scene scenes[] = {
        {"soup", meshgen_soup(seed, 600, unit, 0.3), 0},
        {"soup far and small", meshgen_transformed(&soup, 1e-3, (vec3){1e6, 2e6, -1e6}), 0},
        {"soup at 1e9", meshgen_transformed(&soup, 1.0, (vec3){1e9, 1e9, 1e9}), 0},
        {"terrain", meshgen_terrain(seed, (box3){{0, 0, 0}, {8, 8, 1}}, 16, 16), 0},
        {"icosphere", meshgen_icosphere((vec3){0.5, 0.25, 0}, 1.0, 3), 0},
        {"blocks", meshgen_blocks(seed, 4, 3, 3, 0.5), 0.125},
        {"torus coarse", meshgen_torus((vec3){0, 0, 0}, 2.0, 0.5, 24, 12), 2.0},
    };
    for (size_t i = 0; i < sizeof scenes / sizeof scenes[0]; i++) {
        run_scene(&scenes[i], seed + i, 1500, 300);
        mesh_data_free(&scenes[i].mesh);
    }
    mesh_data_free(&soup);
}

/* A world near the top of the double range: lo + hi of its boxes overflows, so every split
 * takes box_split's careful path, in the build and in the walks. Rays still find what
 * brute force finds. */
static void test_world_near_double_max_equals_brute_force(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 9;
    box3 unit = {{-1, -1, -1}, {1, 1, 1}};
    mesh_data soup = meshgen_soup(seed, 300, unit, 0.3);
    mesh_data m = meshgen_transformed(&soup, 1e300, (vec3){1e308, -1e308, 1e308});
    octree *t = build_or_fail(&m, 2e300 / 32, ACCURACY_EXACT);
    assert_false(t->splits_in_range);
    assert_true(t->info.max_level >= 4);
    rng r = rng_seeded(seed), rt = rng_seeded(seed);
    compare_rays(t, &m, &r, 800, ACCURACY_EXACT, RAY_CROSSING);
    compare_rays(t, &m, &rt, 800, ACCURACY_EXACT, RAY_TOUCH);
    compare_triangles(t, &m, &r, 100, 2e299);
    /* Rays aimed at vertices from around the soup: most hit, so the agreement above is
     * not the agreement of two empty answers. */
    int hits = 0;
    box3 b = mesh_data_bounds(&m);
    for (int i = 0; i < 200; i++) {
        vec3 o = random_point_near(&r, b);
        ray_input ray = {o, vec3_sub(m.vertices[rng_next(&r) % m.vertex_count], o), 0, INFINITY, RAY_CROSSING};
        ray_hit h;
        ray_output out = {.hits = &h, .max_hits = 1};
        assert_int_equal(octree_ray(t, &ray, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
        hits += out.hit_count > 0;
    }
    assert_true(hits > 100);
    octree_free(t);
    mesh_data_free(&m);
    mesh_data_free(&soup);
}

/* A point near the corner of the double range opposite a world near (+, -, +) 1.5e308. */
static vec3 random_point_at_far_end(rng *r)
{
    return vec3_make(-rng_uniform(r, 1.0, 1.79) * 1e308, rng_uniform(r, 1.0, 1.79) * 1e308,
                     -rng_uniform(r, 1.0, 1.79) * 1e308);
}

/* A point near the centroid of world triangle k, well inside it. */
static vec3 triangle_centroid(const mesh_data *m, size_t k)
{
    vec3 c = {0, 0, 0};
    for (int j = 0; j < 3; j++)
        c = vec3_add(c, vec3_scale(m->vertices[m->indices[3 * k + (size_t)j]], 1.0 / 3.0));
    return c;
}

/* Queries from the far end of the double range into a world near the other end: from there
 * every difference of a query coordinate and a node's face overflows a double (about 3e308),
 * though the crossing parameters themselves are finite and ordinary. The walk must still
 * visit every node the exact ray meets, so the octree answers what brute force answers.
 * Before the walk computed those crossings without the overflow, every such ray missed the
 * world. The world's features (1e300) and the queries' coordinates are within the exact
 * stages' span, so brute force is exact here too. */
static void test_queries_from_the_far_end_of_the_double_range_equal_brute_force(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 13;
    box3 unit = {{-1, -1, -1}, {1, 1, 1}};
    mesh_data soup = meshgen_soup(seed, 300, unit, 0.3);
    mesh_data m = meshgen_transformed(&soup, 1e300, (vec3){1.5e308, -1.5e308, 1.5e308});
    octree *t = build_or_fail(&m, 2e300 / 32, ACCURACY_EXACT);
    mesh_view v = mesh_data_view(&m);
    box3 b = mesh_data_bounds(&m);
    rng r = rng_seeded(seed);
    ray_hit got[64], want[64];
    int hits = 0;
    for (int i = 0; i < 400; i++) {
        vec3 o = random_point_at_far_end(&r), target;
        if (i % 3 == 0)
            target = m.vertices[rng_next(&r) % m.vertex_count];
        else if (i % 3 == 1)
            target = triangle_centroid(&m, rng_next(&r) % m.triangle_count);
        else
            target = rng_point_in_box(&r, b);
        /* Half of target - o, which would overflow; a ray's direction may have any length.
         * Scaled down further, t grows from about 2 to about 2^101. */
        ray_input ray = {o, vec3_scale(vec3_sub(vec3_scale(target, 0.5), vec3_scale(o, 0.5)), ldexp(1.0, -(i % 101))),
                         0, INFINITY, RAY_CROSSING};
        if (i % 5 == 0)
            ray.tmax = ldexp(1.0, i % 101) * rng_uniform(&r, 1.0, 3.0);
        for (int detail = RAY_ANY; detail <= RAY_ALL; detail++) {
            ray_output out = {.hits = got, .max_hits = 64};
            assert_int_equal(octree_ray(t, &ray, (ray_detail)detail, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
            size_t n = brute_ray(&v, &ray, (ray_detail)detail, ACCURACY_EXACT, 0, want, 64);
            if (out.hit_count != n)
                fail_msg("ray %d detail %d from (%a, %a, %a) along (%a, %a, %a): octree %zu hits, brute force %zu",
                         i, detail, o.x, o.y, o.z, ray.direction.x, ray.direction.y, ray.direction.z,
                         out.hit_count, n);
            for (size_t k = 0; detail != RAY_ANY && k < n && k < 64; k++) {
                assert_int_equal(got[k].triangle, want[k].triangle);
                assert_true(got[k].t == want[k].t);
            }
            hits += detail == RAY_CLOSEST && n > 0;
        }
    }
    printf("far-end rays: %d of 400 hit\n", hits);
    assert_true(hits > 150);

    /* The batch walks, on rays from scattered far origins (interleaved walks) and from one
     * far origin (packets), answer as brute force does too. */
    enum { BATCH = 64 };
    ray_input rays[BATCH];
    ray_hit batch_hits[BATCH];
    ray_output outs[BATCH];
    octree_status statuses[BATCH];
    vec3 shared = random_point_at_far_end(&r);
    for (int pass = 0; pass < 2; pass++) {
        int batch_hit_count = 0;
        for (int i = 0; i < BATCH; i++) {
            vec3 o = pass == 0 ? random_point_at_far_end(&r) : shared;
            vec3 target = triangle_centroid(&m, rng_next(&r) % m.triangle_count);
            rays[i] = (ray_input){o, vec3_sub(vec3_scale(target, 0.5), vec3_scale(o, 0.5)), 0, INFINITY, RAY_CROSSING};
            outs[i] = (ray_output){.hits = &batch_hits[i], .max_hits = 1};
        }
        assert_int_equal(octree_ray_batch(t, rays, BATCH, RAY_CLOSEST, ACCURACY_EXACT, outs, statuses, NULL),
                         OCTREE_OK);
        for (int i = 0; i < BATCH; i++) {
            assert_int_equal(statuses[i], OCTREE_OK);
            size_t n = brute_ray(&v, &rays[i], RAY_CLOSEST, ACCURACY_EXACT, 0, want, 64);
            assert_int_equal(outs[i].hit_count, n);
            if (n > 0) {
                assert_int_equal(batch_hits[i].triangle, want[0].triangle);
                batch_hit_count++;
            }
        }
        printf("far-end batch %s: %d of %d hit\n", pass == 0 ? "of scattered origins" : "from one origin",
               batch_hit_count, BATCH);
        assert_true(batch_hit_count > BATCH * 3 / 4);
    }

    /* Long triangles reaching from the far end to a world vertex. */
    uint32_t ids[512];
    tri_contact contacts[512];
    int touching = 0;
    for (int i = 0; i < 100; i++) {
        vec3 w = m.vertices[rng_next(&r) % m.vertex_count];
        vec3 q[3] = {random_point_at_far_end(&r), i % 2 ? w : rng_point_in_box(&r, b), rng_point_in_box(&r, b)};
        size_t n = brute_triangle(&v, q, ACCURACY_EXACT, 0, ids, 512);
        tri_output out = {.contacts = contacts, .capacity = 512};
        assert_int_equal(octree_triangle(t, q, TRI_IDS, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
        if (out.count != n)
            fail_msg("triangle %d: octree %zu ids, brute force %zu", i, out.count, n);
        for (size_t k = 0; k < n; k++)
            assert_int_equal(contacts[k].triangle, ids[k]);
        touching += n > 0;
    }
    printf("far-end triangles: %d of 100 touch\n", touching);
    assert_true(touching > 50);
    octree_free(t);
    mesh_data_free(&m);
    mesh_data_free(&soup);
}

/* A world as wide as a double allows: its extent 1.6e308 is below DBL_MAX, but the cube's
 * side, a power of two times d, is not, so the world's upper corner is clamped to DBL_MAX.
 * Rays from anywhere in the double range, and triangles reaching across it, answer as
 * brute force does. A mesh whose extent itself overflows is refused by name. */
static void test_world_spanning_the_double_range(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 14;
    box3 unit = {{-1, -1, -1}, {1, 1, 1}};
    mesh_data soup = meshgen_soup(seed, 200, unit, 0.3);
    mesh_data m = meshgen_transformed(&soup, 0.8e308, (vec3){0, 0, 0});
    box3 b = mesh_data_bounds(&m);
    double extent = fmax(b.hi.x - b.lo.x, fmax(b.hi.y - b.lo.y, b.hi.z - b.lo.z));
    printf("range-wide world: extent %g\n", extent);
    assert_true(extent > 1.2e308);
    /* d = 3/64 of the extent: five levels, and a cube of side 1.5 extent, beyond DBL_MAX. */
    octree *t = build_or_fail(&m, 0.75 * extent / 16, ACCURACY_EXACT);
    assert_int_equal(t->info.max_level, 5);
    assert_true(t->world.hi.x == DBL_MAX && t->world.hi.y == DBL_MAX && t->world.hi.z == DBL_MAX);
    mesh_view v = mesh_data_view(&m);
    box3 whole = {{-DBL_MAX, -DBL_MAX, -DBL_MAX}, {DBL_MAX, DBL_MAX, DBL_MAX}};
    rng r = rng_seeded(seed);
    ray_hit got[64], want[64];
    int hits = 0;
    for (int i = 0; i < 300; i++) {
        vec3 o = rng_point_in_box(&r, (box3){vec3_scale(whole.lo, 0.5), vec3_scale(whole.hi, 0.5)});
        o = vec3_scale(o, 2.0); /* anywhere in the range; the box's own extent would overflow */
        vec3 target = triangle_centroid(&m, rng_next(&r) % m.triangle_count);
        ray_input ray = {o, vec3_sub(vec3_scale(target, 0.5), vec3_scale(o, 0.5)), 0, INFINITY, RAY_CROSSING};
        ray_output out = {.hits = got, .max_hits = 64};
        assert_int_equal(octree_ray(t, &ray, RAY_ALL, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
        size_t n = brute_ray(&v, &ray, RAY_ALL, ACCURACY_EXACT, 0, want, 64);
        if (out.hit_count != n)
            fail_msg("ray %d: octree %zu hits, brute force %zu", i, out.hit_count, n);
        for (size_t k = 0; k < n && k < 64; k++)
            assert_int_equal(got[k].triangle, want[k].triangle);
        hits += n > 0;
    }
    printf("range-wide world: %d of 300 rays hit\n", hits);
    assert_true(hits > 250);
    uint32_t ids[256];
    tri_contact contacts[256];
    for (int i = 0; i < 60; i++) {
        vec3 q[3] = {vec3_scale(rng_point_in_box(&r, (box3){vec3_scale(whole.lo, 0.5), vec3_scale(whole.hi, 0.5)}), 2.0),
                     triangle_centroid(&m, rng_next(&r) % m.triangle_count),
                     triangle_centroid(&m, rng_next(&r) % m.triangle_count)};
        size_t n = brute_triangle(&v, q, ACCURACY_EXACT, 0, ids, 256);
        tri_output out = {.contacts = contacts, .capacity = 256};
        assert_int_equal(octree_triangle(t, q, TRI_IDS, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
        assert_int_equal(out.count, n);
        for (size_t k = 0; k < n; k++)
            assert_int_equal(contacts[k].triangle, ids[k]);
    }
    octree_free(t);

    /* Vertices at both ends of the range: an extent of 2 DBL_MAX has no double. */
    vec3 wide[3] = {{-DBL_MAX, 0, 0}, {DBL_MAX, 0, 0}, {0, 1, 0}};
    uint32_t tri[3] = {0, 1, 2};
    mesh_view too_wide = {wide, 3, tri, 1};
    octree_def def = octree_default_def();
    octree_error err;
    assert_null(octree_build(&too_wide, &def, &err));
    assert_int_equal(err.status, OCTREE_ERR_INVALID);
    assert_non_null(strstr(err.message, "extent"));
    mesh_data_free(&m);
    mesh_data_free(&soup);
}

static void test_real_meshes_equal_brute_force(void **state)
{
    (void)state;
    const char *files[] = {"/usr/share/assimp/models/PLY/Wuson.ply",
                           "/usr/share/assimp/models/STL/Spider_binary.stl",
                           "/usr/share/assimp/models/OBJ/spider.obj"};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        scene s = {files[i], {0}, 0};
        char err[256];
        if (mesh_load_file(files[i], &s.mesh, NULL, err, sizeof err) != 0)
            fail_msg("%s", err);
        run_scene(&s, base_seed + 10 + i, 300, 60);
        mesh_data_free(&s.mesh);
    }
}

static void test_mesh_query_equals_per_triangle_brute_force(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 3;
    mesh_data world = meshgen_terrain(seed, (box3){{0, 0, 0}, {8, 8, 1}}, 16, 16);
    mesh_data shape = meshgen_icosphere((vec3){0, 0, 0}, 0.6, 1);
    octree *t = build_or_fail(&world, 0, ACCURACY_EXACT);
    mesh_view wv = mesh_data_view(&world), sv = mesh_data_view(&shape);
    rng r = rng_seeded(seed);
    mesh_pair pairs[4096];
    uint32_t ids[4096];
    int hits = 0;
    for (int i = 0; i < 40; i++) {
        double a = rng_uniform(&r, 0, 6.283185307179586);
        pose p = {{cos(a), -sin(a), 0, sin(a), cos(a), 0, 0, 0, 1},
                  {rng_uniform(&r, 0, 8), rng_uniform(&r, 0, 8), rng_uniform(&r, -0.5, 1.5)}};
        mesh_output out = {.pairs = pairs, .capacity = 4096};
        assert_int_equal(octree_mesh(t, &sv, &p, 1, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
        size_t k = 0;
        for (size_t q = 0; q < shape.triangle_count; q++) {
            vec3 tri[3];
            for (int j = 0; j < 3; j++) {
                vec3 s = shape.vertices[shape.indices[3 * q + (size_t)j]];
                tri[j] = (vec3){p.r[0] * s.x + p.r[1] * s.y + p.r[2] * s.z + p.t.x,
                                p.r[3] * s.x + p.r[4] * s.y + p.r[5] * s.z + p.t.y,
                                p.r[6] * s.x + p.r[7] * s.y + p.r[8] * s.z + p.t.z};
            }
            size_t n = brute_triangle(&wv, tri, ACCURACY_EXACT, 0, ids, 4096);
            for (size_t j = 0; j < n; j++, k++) {
                assert_true(k < out.count);
                assert_int_equal(pairs[k].query_triangle, q);
                assert_int_equal(pairs[k].world_triangle, ids[j]);
            }
        }
        assert_int_equal(out.count, k);
        mesh_output yn = {0};
        assert_int_equal(octree_mesh(t, &sv, &p, 0, ACCURACY_EXACT, &yn, NULL), OCTREE_OK);
        assert_int_equal(yn.hit, k > 0);
        hits += k > 0;
    }
    assert_true(hits > 0 && hits < 40); /* the poses exercise both answers */
    octree_free(t);
    mesh_data_free(&world);
    mesh_data_free(&shape);
}

/* ---------- watertightness through the octree ---------- */

static void test_rays_cross_closed_meshes_an_even_number_of_times(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 4;
    mesh_data meshes[] = {meshgen_icosphere((vec3){0, 0, 0}, 1.0, 2), meshgen_torus((vec3){0, 0, 0}, 2, 0.5, 16, 8),
                          meshgen_box((box3){{-1, -1, -1}, {1, 1, 1}})};
    rng r = rng_seeded(seed);
    ray_hit hits[64];
    for (size_t m = 0; m < 3; m++) {
        octree *t = build_or_fail(&meshes[m], 0, ACCURACY_EXACT);
        box3 b = mesh_data_bounds(&meshes[m]);
        int crossing = 0;
        for (int i = 0; i < 2000; i++) {
            ray_input ray = random_ray(&r, &meshes[m], b);
            ray.tmax = INFINITY;
            /* start outside the bounds so the crossing count must be even */
            ray.origin = vec3_add(b.hi, vec3_make(1, 1.5, 2));
            ray.direction = vec3_sub(i % 2 ? meshes[m].vertices[rng_next(&r) % meshes[m].vertex_count]
                                           : random_point_near(&r, b),
                                     ray.origin);
            ray_output out = {.hits = hits, .max_hits = 64};
            assert_int_equal(octree_ray(t, &ray, RAY_ALL, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
            if (out.hit_count % 2 != 0)
                fail_msg("mesh %zu ray %d: %zu crossings (odd) toward (%a, %a, %a)", m, i, out.hit_count,
                         ray.direction.x, ray.direction.y, ray.direction.z);
            crossing += out.hit_count > 0;
        }
        assert_true(crossing > 100);
        octree_free(t);
        mesh_data_free(&meshes[m]);
    }
}

/* ---------- bad queries ---------- */

/* ---------- the touch rule on closed boxes and node faces ---------- */

/* Every detail and both contacts of one ray: octree == brute force; for RAY_TOUCH, ALL
 * lists exactly the triangles the oracle says the segment meets, ordered by the oracle's
 * exact smallest t. Returns the touch ALL count. */
static size_t check_touch_ray(const octree *t, const mesh_data *m, ray_input ray)
{
    mesh_view v = mesh_data_view(m);
    ray_hit got[64], want[64];
    for (int contact = RAY_CROSSING; contact <= RAY_TOUCH; contact++) {
        ray.contact = (ray_contact)contact;
        for (int detail = RAY_ANY; detail <= RAY_ALL; detail++) {
            ray_output out = {.hits = got, .max_hits = 64};
            assert_int_equal(octree_ray(t, &ray, (ray_detail)detail, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
            size_t n = brute_ray(&v, &ray, (ray_detail)detail, ACCURACY_EXACT, 0, want, 64);
            assert_int_equal(out.hit_count, n);
            if (detail == RAY_ANY)
                continue;
            for (size_t k = 0; k < n; k++) {
                assert_int_equal(got[k].triangle, want[k].triangle);
                assert_true(got[k].t == want[k].t);
            }
        }
    }
    ray_output out = {.hits = got, .max_hits = 64};
    assert_int_equal(octree_ray(t, &ray, RAY_ALL, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
    size_t touched = 0;
    for (size_t i = 0; i < m->triangle_count; i++) {
        vec3 tri[3] = {mesh_data_corner(m, i, 0), mesh_data_corner(m, i, 1), mesh_data_corner(m, i, 2)};
        touched += oracle_ray_tri(ray.origin, ray.direction, ray.tmin, ray.tmax, tri) == 1;
    }
    assert_int_equal(out.hit_count, touched);
    for (size_t k = 0; k + 1 < out.hit_count; k++) {
        vec3 a[3], b[3];
        for (int c = 0; c < 3; c++) {
            a[c] = mesh_data_corner(m, got[k].triangle, c);
            b[c] = mesh_data_corner(m, got[k + 1].triangle, c);
        }
        int order = oracle_ray_tri_first_t_order(ray.origin, ray.direction, ray.tmin, ray.tmax, a, b);
        assert_true(order < 0 || (order == 0 && got[k].triangle < got[k + 1].triangle));
    }
    return out.hit_count;
}

/* One ray, one detail, one contact: the hit count and the first hit's t. */
static size_t ray_answer(const octree *t, ray_input ray, ray_contact contact, ray_detail detail, double *t0)
{
    ray_hit h[64];
    ray_output out = {.hits = h, .max_hits = 64};
    ray.contact = contact;
    assert_int_equal(octree_ray(t, &ray, detail, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
    *t0 = out.hit_count > 0 ? h[0].t : NAN;
    return out.hit_count;
}

static void test_touch_rule_on_closed_boxes_and_node_faces(void **state)
{
    (void)state;
    /* Two closed unit boxes side by side: the world is [0, 2]^3, so the shared wall x = 1
     * and the tops z = 1 lie on the root's split planes, and with d = 0.25 every face is a
     * face of leaves. */
    mesh_data m = meshgen_box((box3){{0, 0, 0}, {1, 1, 1}});
    mesh_data right = meshgen_box((box3){{1, 0, 0}, {2, 1, 1}});
    assert_int_equal(mesh_data_append(&m, &right), 0);
    mesh_data_free(&right);
    octree *t = build_or_fail(&m, 0.25, ACCURACY_EXACT);
    assert_true(t->world.lo.x == 0 && t->world.hi.x == 2);
    double t0;

    /* Sliding along the tops at y = 0.5, in the split plane z = 1: crossing sees a clear
     * line of sight (the perturbed ray passes above), touch is blocked where the ray reaches
     * the first box's top edge, t = 1. */
    ray_input slide = {{-1, 0.5, 1}, {1, 0, 0}, 0, INFINITY, RAY_CROSSING};
    assert_int_equal(ray_answer(t, slide, RAY_CROSSING, RAY_ANY, &t0), 0);
    assert_int_equal(ray_answer(t, slide, RAY_TOUCH, RAY_ANY, &t0), 1);
    assert_int_equal(ray_answer(t, slide, RAY_TOUCH, RAY_CLOSEST, &t0), 1);
    assert_true(t0 == 1.0);
    assert_true(check_touch_ray(t, &m, slide) >= 8); /* both tops and four walls at least */

    /* Grazing the corner (0, 1, 1) only, diagonally in the plane z = 1. */
    ray_input corner = {{-0.5, 0.5, 1}, {1, 1, 0}, 0, INFINITY, RAY_CROSSING};
    assert_int_equal(ray_answer(t, corner, RAY_CROSSING, RAY_ANY, &t0), 0);
    assert_int_equal(ray_answer(t, corner, RAY_TOUCH, RAY_CLOSEST, &t0), 1);
    assert_true(t0 == 0.5);
    assert_true(check_touch_ray(t, &m, corner) >= 3); /* the corner's three faces */

    /* Lying in the shared wall x = 1 (the root's split plane, direction zero along x):
     * both boxes' walls are touched from t = 1, where the ray reaches y = 0. */
    ray_input wall = {{1, -1, 0.5}, {0, 1, 0}, 0, INFINITY, RAY_CROSSING};
    assert_int_equal(ray_answer(t, wall, RAY_TOUCH, RAY_CLOSEST, &t0), 1);
    assert_true(t0 == 1.0);
    assert_true(check_touch_ray(t, &m, wall) >= 4);

    /* Along the edge line x = 1, z = 1 where four faces meet, one ulp above it (nothing),
     * and stopping one ulp short of the boxes (tmax: nothing). */
    ray_input edge = {{1, -1, 1}, {0, 1, 0}, 0, INFINITY, RAY_CROSSING};
    assert_int_equal(ray_answer(t, edge, RAY_TOUCH, RAY_CLOSEST, &t0), 1);
    assert_true(t0 == 1.0);
    assert_true(check_touch_ray(t, &m, edge) >= 4);
    ray_input above = {{1, -1, nextafter(1, 2)}, {0, 1, 0}, 0, INFINITY, RAY_CROSSING};
    assert_int_equal(ray_answer(t, above, RAY_TOUCH, RAY_ANY, &t0), 0);
    check_touch_ray(t, &m, above);
    ray_input short_of = edge;
    short_of.tmax = nextafter(1, 0);
    assert_int_equal(ray_answer(t, short_of, RAY_TOUCH, RAY_ANY, &t0), 0);
    short_of.tmax = 1;
    assert_int_equal(ray_answer(t, short_of, RAY_TOUCH, RAY_CLOSEST, &t0), 1);
    assert_true(t0 == 1.0);

    /* Starting on a face, leaving the box: touch answers t = tmin = 0. */
    ray_input leaving = {{0.5, 0.5, 1}, {0.25, -0.125, 1}, 0, INFINITY, RAY_CROSSING};
    assert_int_equal(ray_answer(t, leaving, RAY_TOUCH, RAY_CLOSEST, &t0), 1);
    assert_true(t0 == 0.0);
    check_touch_ray(t, &m, leaving);

    /* Straight through the middle of the shared wall: crossing counts the two coincident
     * walls and the two outer ones; touch the same four here (no boundary is met). */
    ray_input through = {{-1, 0.375, 0.625}, {1, 0, 0}, 0, INFINITY, RAY_CROSSING};
    size_t crossings = ray_answer(t, through, RAY_CROSSING, RAY_ALL, &t0);
    assert_int_equal(crossings, 4);
    assert_int_equal(ray_answer(t, through, RAY_TOUCH, RAY_ALL, &t0), 4);
    octree_free(t);
    mesh_data_free(&m);
}

static void test_bad_queries_get_errors(void **state)
{
    (void)state;
    mesh_data m = meshgen_box((box3){{0, 0, 0}, {1, 1, 1}});
    octree *t = build_or_fail(&m, 0, ACCURACY_EXACT);
    ray_hit h;
    ray_output out = {.hits = &h, .max_hits = 1};
    ray_input zero = {{0, 0, 0}, {0, 0, 0}, 0, 1, RAY_CROSSING};
    assert_int_equal(octree_ray(t, &zero, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL), OCTREE_ERR_INVALID);
    ray_input nan = {{NAN, 0, 0}, {1, 0, 0}, 0, 1, RAY_CROSSING};
    assert_int_equal(octree_ray(t, &nan, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL), OCTREE_ERR_NONFINITE);
    ray_input inf = {{0, 0, 0}, {INFINITY, 0, 0}, 0, 1, RAY_CROSSING};
    assert_int_equal(octree_ray(t, &inf, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL), OCTREE_ERR_NONFINITE);
    ray_input backwards = {{0, 0, 0}, {1, 0, 0}, 2, 1, RAY_CROSSING};
    assert_int_equal(octree_ray(t, &backwards, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL), OCTREE_ERR_INVALID);
    /* The touch rule is exact-only, and a contact outside the enum is refused. */
    ray_input touch = {{-1, 0.5, 0.5}, {1, 0, 0}, 0, INFINITY, RAY_TOUCH};
    assert_int_equal(octree_ray(t, &touch, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
    assert_int_equal(out.hit_count, 1);
    assert_int_equal(octree_ray(t, &touch, RAY_CLOSEST, ACCURACY_SEED, &out, NULL), OCTREE_ERR_INVALID);
    assert_int_equal(octree_ray(t, &touch, RAY_ANY, ACCURACY_FAST, &out, NULL), OCTREE_ERR_INVALID);
    touch.contact = (ray_contact)2;
    assert_int_equal(octree_ray(t, &touch, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL), OCTREE_ERR_INVALID);
    touch.contact = (ray_contact)-1;
    assert_int_equal(octree_ray(t, &touch, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL), OCTREE_ERR_INVALID);
    vec3 q[3] = {{0, 0, 0}, {NAN, 1, 1}, {1, 1, 1}};
    tri_output to = {0};
    assert_int_equal(octree_triangle(t, q, TRI_YESNO, ACCURACY_EXACT, &to, NULL), OCTREE_ERR_NONFINITE);
    /* a zero-area query triangle acts as its segment: this one pierces the box's face */
    vec3 seg[3] = {{0.5, 0.5, -1}, {0.5, 0.5, 0.5}, {0.5, 0.5, -0.25}};
    assert_int_equal(octree_triangle(t, seg, TRI_YESNO, ACCURACY_EXACT, &to, NULL), OCTREE_OK);
    assert_int_equal(to.hit, 1);
    octree_free(t);
    mesh_data_free(&m);
}

/* ---------- batches ---------- */

static uint64_t bits_of(double x)
{
    uint64_t b;
    memcpy(&b, &x, sizeof b);
    return b;
}

/* Every field of two reported hits, compared as bits (padding aside). */
static void assert_same_hit(const ray_hit *a, const ray_hit *b, size_t ray, size_t k)
{
    if (a->triangle != b->triangle || bits_of(a->t) != bits_of(b->t) || bits_of(a->u) != bits_of(b->u) ||
        bits_of(a->v) != bits_of(b->v) || bits_of(a->normal.x) != bits_of(b->normal.x) ||
        bits_of(a->normal.y) != bits_of(b->normal.y) || bits_of(a->normal.z) != bits_of(b->normal.z))
        fail_msg("ray %zu hit %zu: batch (%u, %a) differs from single (%u, %a)", ray, k, a->triangle, a->t,
                 b->triangle, b->t);
}

/* A ray octree_ray refuses, of the four kinds it checks for. */
static ray_input invalid_ray(size_t i)
{
    switch (i % 4) {
    case 0:
        return (ray_input){{0, 0, 0}, {0, 0, 0}, 0, 1, RAY_CROSSING};
    case 1:
        return (ray_input){{NAN, 0, 0}, {1, 0, 0}, 0, 1, RAY_CROSSING};
    case 2:
        return (ray_input){{0, 0, 0}, {0, INFINITY, 0}, 0, 1, RAY_CROSSING};
    default:
        return (ray_input){{0, 0, 0}, {1, 1, 1}, 2, 1, RAY_CROSSING};
    }
}

enum { BATCH_HIT_CAP = 6 };

typedef struct batch_tally {
    size_t rays, invalid, hit_rays, truncated;
    uint64_t fallbacks;
} batch_tally;

/* Answers `rays` through octree_ray_batch in batches of uneven sizes (so the stream starts,
 * refills and drains at every phase) and through octree_ray one by one, and demands the
 * same statuses, outputs and summed counters to the bit. */
static void compare_batch_with_single(const octree *t, const ray_input *rays, size_t count, ray_detail detail,
                                      accuracy_mode mode, batch_tally *tally)
{
    ray_hit *batch_hits = malloc(count * BATCH_HIT_CAP * sizeof *batch_hits);
    ray_hit *single_hits = malloc(count * BATCH_HIT_CAP * sizeof *single_hits);
    ray_output *outs = malloc(count * sizeof *outs);
    octree_status *statuses = malloc(count * sizeof *statuses);
    /* Untouched outputs must stay untouched (invalid rays): both start from the same junk. */
    memset(batch_hits, 0x5a, count * BATCH_HIT_CAP * sizeof *batch_hits);
    memset(single_hits, 0x5a, count * BATCH_HIT_CAP * sizeof *single_hits);
    for (size_t i = 0; i < count; i++) {
        outs[i] = (ray_output){.hit_count = 777, .truncated = 3, .hits = &batch_hits[i * BATCH_HIT_CAP],
                               .max_hits = i % 7 == 3 ? 0 : i % 3 == 1 ? 1 : BATCH_HIT_CAP};
        statuses[i] = (octree_status)99;
    }
    const size_t sizes[] = {1, 3, 17, 256, 5, 1000};
    query_stats batch_stats = {0}, single_stats = {0};
    size_t done = 0;
    for (size_t b = 0; done < count; b++) {
        size_t n = b < sizeof sizes / sizeof sizes[0] ? sizes[b] : count;
        n = n < count - done ? n : count - done;
        assert_int_equal(octree_ray_batch(t, &rays[done], n, detail, mode, &outs[done], &statuses[done], &batch_stats),
                         OCTREE_OK);
        done += n;
    }
    assert_int_equal(octree_ray_batch(t, rays, 0, detail, mode, outs, statuses, &batch_stats), OCTREE_OK);
    for (size_t i = 0; i < count; i++) {
        ray_output one = {.hit_count = 777, .truncated = 3, .hits = &single_hits[i * BATCH_HIT_CAP],
                          .max_hits = outs[i].max_hits};
        octree_status st = octree_ray(t, &rays[i], detail, mode, &one, &single_stats);
        if (statuses[i] != st)
            fail_msg("ray %zu detail %d mode %d: batch status %d, single %d", i, detail, mode, statuses[i], st);
        assert_int_equal(outs[i].hit_count, one.hit_count);
        assert_int_equal(outs[i].truncated, one.truncated);
        size_t stored = one.hit_count < one.max_hits ? one.hit_count : one.max_hits;
        for (size_t k = 0; k < stored; k++)
            assert_same_hit(&outs[i].hits[k], &one.hits[k], i, k);
        /* past the stored hits both buffers keep their junk */
        assert_memory_equal(&outs[i].hits[stored], &one.hits[stored], (BATCH_HIT_CAP - stored) * sizeof(ray_hit));
        tally->rays++;
        tally->invalid += st != OCTREE_OK;
        tally->hit_rays += st == OCTREE_OK && one.hit_count > 0;
        tally->truncated += one.truncated == 1;
    }
    assert_true(batch_stats.nodes_visited == single_stats.nodes_visited);
    assert_true(batch_stats.leaves_visited == single_stats.leaves_visited);
    assert_true(batch_stats.candidates_tested == single_stats.candidates_tested);
    assert_true(batch_stats.exact_fallbacks == single_stats.exact_fallbacks);
    assert_true(single_stats.nodes_visited > 0 && single_stats.candidates_tested > 0);
    tally->fallbacks += single_stats.exact_fallbacks;
    free(batch_hits);
    free(single_hits);
    free(outs);
    free(statuses);
}

/* rays with every other one switched to RAY_TOUCH, through both batch paths and single
 * rays, every detail, exact and seed mode; the touch rays' own tally is kept apart so the
 * comparison is seen to cover touch hits. */
static size_t touch_hit_rays;

static void compare_mixed_contacts(const octree *t, const ray_input *rays, size_t count, batch_tally *tally)
{
    ray_input *mixed = malloc(count * sizeof *mixed);
    for (size_t i = 0; i < count; i++) {
        mixed[i] = rays[i];
        mixed[i].contact = i % 2 ? RAY_TOUCH : RAY_CROSSING;
    }
    const accuracy_mode modes[] = {ACCURACY_EXACT, ACCURACY_SEED};
    for (size_t m = 0; m < 2; m++)
        for (int detail = RAY_ANY; detail <= RAY_ALL; detail++)
            compare_batch_with_single(t, mixed, count, (ray_detail)detail, modes[m], tally);
    for (size_t i = 1; i < count; i += 2) {
        ray_hit h;
        ray_output out = {.hits = &h, .max_hits = 1};
        if (octree_ray(t, &mixed[i], RAY_ANY, ACCURACY_EXACT, &out, NULL) == OCTREE_OK && out.hit_count > 0)
            touch_hit_rays++;
    }
    free(mixed);
}

static void test_ray_batch_equals_single_rays_bit_for_bit(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 6;
    printf("ray batch seed %llu\n", (unsigned long long)seed);
    box3 unit = {{-1, -1, -1}, {1, 1, 1}};
    mesh_data soup = meshgen_soup(seed, 800, unit, 0.3);
    scene scenes[] = {
        {"soup", meshgen_soup(seed, 800, unit, 0.3), 0},
        {"soup far and small", meshgen_transformed(&soup, 1e-3, (vec3){1e6, 2e6, -1e6}), 0},
        {"icosphere", meshgen_icosphere((vec3){0.5, 0.25, 0}, 1.0, 4), 0},
        {"terrain", meshgen_terrain(seed, (box3){{0, 0, 0}, {8, 8, 1}}, 32, 32), 0},
        {"blocks", meshgen_blocks(seed, 4, 3, 3, 0.5), 0.125},
    };
    const accuracy_mode modes[] = {ACCURACY_EXACT, ACCURACY_SEED};
    enum { RAYS = 2500 };
    batch_tally tally = {0};
    ray_input *rays = malloc(RAYS * sizeof *rays);
    for (size_t s = 0; s < sizeof scenes / sizeof scenes[0]; s++) {
        octree *t = build_or_fail(&scenes[s].mesh, scenes[s].resolution, ACCURACY_EXACT);
        rng r = rng_seeded(seed + s);
        box3 b = mesh_data_bounds(&scenes[s].mesh);
        for (size_t i = 0; i < RAYS; i++) {
            rays[i] = i % 41 == 40 ? invalid_ray(i / 41) : random_ray(&r, &scenes[s].mesh, b);
            if (i % 53 == 52) /* pointing away from the world: answered with no hit */
                rays[i].direction = vec3_sub(rays[i].origin, vec3_scale(vec3_add(b.lo, b.hi), 0.5));
        }
        for (size_t m = 0; m < 2; m++)
            for (int detail = RAY_ANY; detail <= RAY_ALL; detail++)
                compare_batch_with_single(t, rays, RAYS, (ray_detail)detail, modes[m], &tally);
        /* The same rays, touch and crossing mixed in one batch (touch rays are refused in
         * seed mode, alike in both). */
        compare_mixed_contacts(t, rays, RAYS, &tally);
        /* Rays from one origin take the batch's other path, walking the tree in groups that
         * share a visiting order: scattered directions (groups of every size, broken by
         * changes of order and by invalid rays), then a camera's grid from a corner, whose
         * neighbours fill whole groups. */
        vec3 eye = vec3_add(b.hi, vec3_make(0.5, 0.75, 1.0));
        for (size_t i = 0; i < RAYS; i++)
            rays[i] = i % 41 == 40 ? (ray_input){eye, {0, 0, 0}, 0, INFINITY, RAY_CROSSING}
                                   : (ray_input){eye, vec3_sub(random_point_near(&r, b), eye), 0, INFINITY, RAY_CROSSING};
        for (size_t m = 0; m < 2; m++)
            for (int detail = RAY_ANY; detail <= RAY_ALL; detail++)
                compare_batch_with_single(t, rays, RAYS, (ray_detail)detail, modes[m], &tally);
        compare_mixed_contacts(t, rays, RAYS, &tally);
        for (size_t i = 0; i < RAYS; i++) {
            double u = (double)(i % 50) / 49.0, v = (double)(i / 50) / 49.0;
            vec3 target = vec3_make(b.lo.x + u * (b.hi.x - b.lo.x), b.lo.y + v * (b.hi.y - b.lo.y), b.lo.z);
            rays[i] = (ray_input){eye, vec3_sub(target, eye), 0, INFINITY, RAY_CROSSING};
        }
        for (int detail = RAY_ANY; detail <= RAY_ALL; detail++)
            compare_batch_with_single(t, rays, RAYS, (ray_detail)detail, ACCURACY_EXACT, &tally);
        compare_mixed_contacts(t, rays, RAYS, &tally);
        octree_free(t);
        mesh_data_free(&scenes[s].mesh);
    }
    printf("ray batch: %zu rays, %zu invalid, %zu with hits, %zu truncated, %llu exact fallbacks\n", tally.rays,
           tally.invalid, tally.hit_rays, tally.truncated, (unsigned long long)tally.fallbacks);
    /* the comparison saw every kind of answer */
    assert_true(tally.invalid > 0 && tally.hit_rays > tally.rays / 4 && tally.truncated > 0);
    assert_true(tally.hit_rays < tally.rays - tally.invalid);
    printf("ray batch: %zu touch rays with hits\n", touch_hit_rays);
    assert_true(touch_hit_rays > 1000);
    free(rays);
    mesh_data_free(&soup);
}

/* ---------- threads ---------- */

typedef struct thread_job {
    const octree *tree;
    const mesh_data *mesh;
    uint64_t seed;
    int first, count;
    uint64_t hash;
} thread_job;

static uint64_t mix(uint64_t h, uint64_t v)
{
    h ^= v + 0x9E3779B97F4A7C15ull + (h << 6) + (h >> 2);
    return h;
}

static void *run_job(void *arg)
{
    thread_job *j = arg;
    box3 b = mesh_data_bounds(j->mesh);
    ray_hit hits[16];
    uint64_t h = 0;
    for (int i = j->first; i < j->first + j->count; i++) {
        rng r = rng_seeded(j->seed + (uint64_t)i);
        ray_input ray = random_ray(&r, j->mesh, b);
        ray_output out = {.hits = hits, .max_hits = 16};
        octree_ray(j->tree, &ray, RAY_ALL, ACCURACY_EXACT, &out, NULL);
        h = mix(h, out.hit_count);
        for (size_t k = 0; k < out.hit_count && k < 16; k++) {
            uint64_t bits;
            memcpy(&bits, &hits[k].t, sizeof bits);
            h = mix(mix(h, hits[k].triangle), bits);
        }
        vec3 q[3];
        random_triangle(&r, b, 0.3, q);
        tri_contact c[64];
        tri_output to = {.contacts = c, .capacity = 64};
        octree_triangle(j->tree, q, TRI_IDS, ACCURACY_EXACT, &to, NULL);
        h = mix(h, to.count);
        for (size_t k = 0; k < to.count && k < 64; k++)
            h = mix(h, c[k].triangle);
    }
    j->hash = h;
    return NULL;
}

static void test_results_identical_for_one_and_four_threads(void **state)
{
    (void)state;
    mesh_data m = meshgen_icosphere((vec3){0, 0, 0}, 1.0, 3);
    octree *t = build_or_fail(&m, 0, ACCURACY_EXACT);
    enum { N = 4000, THREADS = 4 };
    thread_job single = {t, &m, base_seed + 5, 0, N, 0};
    run_job(&single);
    /* Four threads over the same queries in four slices; the per-slice hashes chained in
     * slice order must equal one thread's hashes over the same slices. */
    thread_job jobs[THREADS];
    pthread_t th[THREADS];
    for (int i = 0; i < THREADS; i++) {
        jobs[i] = (thread_job){t, &m, base_seed + 5, i * (N / THREADS), N / THREADS, 0};
        assert_int_equal(pthread_create(&th[i], NULL, run_job, &jobs[i]), 0);
    }
    uint64_t chained = 0, chained_single = 0;
    for (int i = 0; i < THREADS; i++) {
        pthread_join(th[i], NULL);
        thread_job again = {t, &m, base_seed + 5, i * (N / THREADS), N / THREADS, 0};
        run_job(&again);
        chained = mix(chained, jobs[i].hash);
        chained_single = mix(chained_single, again.hash);
    }
    assert_true(chained == chained_single);
    assert_true(single.hash != 0);
    octree_free(t);
    mesh_data_free(&m);
}

int main(void)
{
    const char *s = getenv("TRIOCT_SEED");
    if (s)
        base_seed = strtoull(s, NULL, 10);
    printf("test_octree base seed %llu (set TRIOCT_SEED to rerun)\n", (unsigned long long)base_seed);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_levels_and_enlarged_world),
        cmocka_unit_test(test_seed_heuristic_resolution),
        cmocka_unit_test(test_nan_vertex_is_rejected_naming_the_triangle),
        cmocka_unit_test(test_bad_index_and_empty_mesh_are_rejected),
        cmocka_unit_test(test_depth_cap_errors_when_explicit_and_clamps_heuristic),
        cmocka_unit_test(test_build_stops_at_its_budget),
        cmocka_unit_test(test_build_takes_from_a_shared_account),
        cmocka_unit_test(test_seed_epsilon_at_the_world_scale_builds_the_exact_tree),
        cmocka_unit_test(test_status_texts_are_distinct_and_general),
        cmocka_unit_test(test_children_follow_the_seed_octant_order),
        cmocka_unit_test(test_membership_is_exact_on_random_leaves),
        cmocka_unit_test(test_triangles_on_node_faces_are_in_both_neighbours),
        cmocka_unit_test(test_random_scenes_equal_brute_force),
        cmocka_unit_test(test_world_near_double_max_equals_brute_force),
        cmocka_unit_test(test_queries_from_the_far_end_of_the_double_range_equal_brute_force),
        cmocka_unit_test(test_world_spanning_the_double_range),
        cmocka_unit_test(test_real_meshes_equal_brute_force),
        cmocka_unit_test(test_mesh_query_equals_per_triangle_brute_force),
        cmocka_unit_test(test_rays_cross_closed_meshes_an_even_number_of_times),
        cmocka_unit_test(test_bad_queries_get_errors),
        cmocka_unit_test(test_touch_rule_on_closed_boxes_and_node_faces),
        cmocka_unit_test(test_ray_batch_equals_single_rays_bit_for_bit),
        cmocka_unit_test(test_results_identical_for_one_and_four_threads),
    };
    return cmocka_run_group_tests_name("octree", tests, NULL, NULL);
}
