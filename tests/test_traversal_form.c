/* The compiled traversal form (octree_traversal.h) against the double-precision walk over
 * the seed's nodes and against brute force: the same closest hit to the bit, the same set
 * of hits, the same yes/no, on rays chosen to stress a conservative float walk (through
 * node faces and corners, along split planes, with zero direction components, grazing,
 * from far away, at small and huge offsets), in every mode. And the form's own invariants:
 * each child's bounds enclose its triangles' boxes clipped to its cube. */
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
#include "geom/box_geometry.h"
#include "octree/octree_internal.h"
#include "support/brute_force.h"
#include "support/meshgen.h"

static uint64_t base_seed = 20261202;

static octree *build(const mesh_data *m, double resolution, int plain)
{
    mesh_view v = mesh_data_view(m);
    octree_def def = octree_default_def();
    def.resolution = resolution;
    def.plain_walk = plain;
    octree_error err;
    octree *t = octree_build(&v, &def, &err);
    if (!t)
        fail_msg("build: %s", err.message);
    return t;
}

static uint64_t bits_of(double x)
{
    uint64_t b;
    memcpy(&b, &x, sizeof b);
    return b;
}

enum { HIT_CAP = 64 };

typedef struct tally {
    size_t rays, hits, compared;
} tally;

/* One ray through both trees and brute force, every detail. */
static void compare_ray(const octree *compiled, const octree *plain, const mesh_data *m, const ray_input *ray,
                        accuracy_mode mode, tally *t, const char *scene, size_t index)
{
    mesh_view v = mesh_data_view(m);
    for (int detail = RAY_ANY; detail <= RAY_ALL; detail++) {
        ray_hit a[HIT_CAP], b[HIT_CAP], brute[HIT_CAP];
        ray_output oa = {.hits = a, .max_hits = HIT_CAP}, ob = {.hits = b, .max_hits = HIT_CAP};
        octree_status sa = octree_ray(compiled, ray, (ray_detail)detail, mode, &oa, NULL);
        octree_status sb = octree_ray(plain, ray, (ray_detail)detail, mode, &ob, NULL);
        if (sa != sb)
            fail_msg("%s ray %zu detail %d mode %d: status %d vs plain %d", scene, index, detail, mode, sa, sb);
        if (sa != OCTREE_OK)
            continue;
        if ((oa.hit_count > 0) != (ob.hit_count > 0))
            fail_msg("%s ray %zu detail %d mode %d: %zu hits vs plain %zu", scene, index, detail, mode,
                     oa.hit_count, ob.hit_count);
        if (detail == RAY_ANY) {
            t->hits += oa.hit_count > 0;
            continue;
        }
        if (oa.hit_count != ob.hit_count)
            fail_msg("%s ray %zu detail %d mode %d: %zu hits vs plain %zu", scene, index, detail, mode,
                     oa.hit_count, ob.hit_count);
        size_t stored = oa.hit_count < HIT_CAP ? oa.hit_count : HIT_CAP;
        for (size_t k = 0; k < stored; k++)
            if (a[k].triangle != b[k].triangle || bits_of(a[k].t) != bits_of(b[k].t))
                fail_msg("%s ray %zu detail %d mode %d hit %zu: (%u, %a) vs plain (%u, %a)", scene, index, detail,
                         mode, k, a[k].triangle, a[k].t, b[k].triangle, b[k].t);
        if (mode == ACCURACY_EXACT) {
            size_t n = brute_ray(&v, ray, (ray_detail)detail, mode, 0.0, brute, HIT_CAP);
            if (n != oa.hit_count)
                fail_msg("%s ray %zu detail %d: %zu hits, brute force %zu", scene, index, detail, oa.hit_count, n);
            for (size_t k = 0; k < stored && k < n; k++)
                if (a[k].triangle != brute[k].triangle)
                    fail_msg("%s ray %zu detail %d hit %zu: triangle %u, brute force %u", scene, index, detail, k,
                             a[k].triangle, brute[k].triangle);
        }
        t->compared++;
    }
    t->rays++;
}

/* A point on the grid of node faces of the tree: coordinates that are exactly split
 * planes at some level, where a float walk's rounding matters most. */
static double on_split(rng *r, double lo, double size, int levels)
{
    int level = (int)(rng_next(r) % (uint64_t)(levels + 1));
    uint64_t cells = (uint64_t)1 << level;
    uint64_t k = rng_next(r) % (cells + 1);
    return lo + size * (double)k / (double)cells;
}

/* Rays of the kinds a conservative walk could get wrong, aimed at the mesh. */
static ray_input hard_ray(rng *r, const mesh_data *m, const octree *t, size_t i)
{
    octree_info info;
    octree_get_info(t, &info);
    box3 b = mesh_data_bounds(m);
    vec3 ext = vec3_sub(b.hi, b.lo);
    double D = info.world_size;
    vec3 lo = info.world_min;
    int L = info.max_level;
    size_t k = rng_next(r) % m->triangle_count;
    const vec3 *tri[3] = {&m->vertices[m->indices[3 * k]], &m->vertices[m->indices[3 * k + 1]],
                          &m->vertices[m->indices[3 * k + 2]]};
    double u = rng_uniform(r, 0, 1), w = rng_uniform(r, 0, 1);
    if (u + w > 1) {
        u = 1 - u;
        w = 1 - w;
    }
    vec3 target = vec3_add(*tri[0], vec3_add(vec3_scale(vec3_sub(*tri[1], *tri[0]), u),
                                             vec3_scale(vec3_sub(*tri[2], *tri[0]), w)));
    box3 around = {vec3_sub(b.lo, vec3_scale(ext, 0.3)), vec3_add(b.hi, vec3_scale(ext, 0.3))};
    vec3 o = rng_point_in_box(r, around);
    vec3 d = vec3_sub(target, o);
    switch (i % 8) {
    case 0: /* toward a surface point */
        break;
    case 1: /* toward a vertex, from a point on the node-face grid */
        o = (vec3){on_split(r, lo.x, D, L), on_split(r, lo.y, D, L), on_split(r, lo.z, D, L)};
        d = vec3_sub(*tri[i / 8 % 3], o);
        break;
    case 2: /* along a split plane: one direction component zero */
        o.x = on_split(r, lo.x, D, L);
        d = vec3_sub(target, o);
        d.x = 0;
        if (d.y == 0 && d.z == 0)
            d.y = 1;
        break;
    case 3: /* two components zero: along a line of node edges */
        o.x = on_split(r, lo.x, D, L);
        o.y = on_split(r, lo.y, D, L);
        d = (vec3){0, 0, rng_uniform(r, 0, 1) < 0.5 ? -1 : 1};
        break;
    case 4: /* from far away, a long way toward the target */
        o = vec3_add(target, vec3_scale(rng_unit_vector(r), D * 1e5));
        d = vec3_sub(target, o);
        break;
    case 5: /* through a node corner */
        target = (vec3){on_split(r, lo.x, D, L), on_split(r, lo.y, D, L), on_split(r, lo.z, D, L)};
        d = vec3_sub(target, o);
        break;
    case 6: /* grazing: nearly in a triangle's plane */
    {
        vec3 n = vec3_cross(vec3_sub(*tri[1], *tri[0]), vec3_sub(*tri[2], *tri[0]));
        vec3 e = vec3_sub(*tri[1], *tri[0]);
        double nn = sqrt(vec3_dot(n, n));
        if (nn > 0)
            d = vec3_add(e, vec3_scale(n, 1e-9 * sqrt(vec3_dot(e, e)) / nn));
        o = vec3_sub(target, vec3_scale(d, rng_uniform(r, 0.5, 2)));
        break;
    }
    default: /* from inside the box, any direction, a short range */
        o = rng_point_in_box(r, b);
        d = rng_unit_vector(r);
        break;
    }
    if (d.x == 0 && d.y == 0 && d.z == 0)
        d = (vec3){1, 0, 0};
    double tmax = i % 8 == 7 ? 0.25 * fmax(ext.x, fmax(ext.y, ext.z)) : INFINITY;
    double tmin = i % 16 == 9 ? -1.0 : 0.0;
    return (ray_input){o, d, tmin, tmax, RAY_CROSSING};
}

/* Batches (the stream over the compiled form, the interleaved and grouped walks over the
 * plain one) answer as the same tree answers each ray alone. */
static void compare_batches(const octree *tree, const ray_input *rays, size_t count, const char *scene)
{
    ray_output *outs = calloc(count, sizeof *outs);
    ray_hit *hits = calloc(count, sizeof *hits);
    octree_status *st = calloc(count, sizeof *st);
    ray_input *shared = malloc(count * sizeof *shared);
    for (int pass = 0; pass < 2; pass++) {
        /* pass 1: every ray from the first one's origin, which takes the grouped walks */
        const ray_input *in = rays;
        if (pass == 1) {
            for (size_t i = 0; i < count; i++) {
                shared[i] = rays[i];
                shared[i].origin = rays[0].origin;
            }
            in = shared;
        }
        for (int detail = RAY_ANY; detail <= RAY_CLOSEST; detail++) {
            for (size_t i = 0; i < count; i++)
                outs[i] = (ray_output){.hits = &hits[i], .max_hits = 1};
            assert_int_equal(octree_ray_batch(tree, in, count, (ray_detail)detail, ACCURACY_EXACT, outs, st, NULL),
                             OCTREE_OK);
            for (size_t i = 0; i < count; i++) {
                ray_hit h;
                ray_output one = {.hits = &h, .max_hits = 1};
                assert_int_equal(octree_ray(tree, &in[i], (ray_detail)detail, ACCURACY_EXACT, &one, NULL), st[i]);
                if (one.hit_count != outs[i].hit_count)
                    fail_msg("%s batch pass %d ray %zu detail %d: %zu hits alone, %zu in the batch", scene, pass, i,
                             detail, one.hit_count, outs[i].hit_count);
                if (detail == RAY_CLOSEST && one.hit_count && (h.triangle != hits[i].triangle || bits_of(h.t) != bits_of(hits[i].t)))
                    fail_msg("%s batch pass %d ray %zu: (%u, %a) alone, (%u, %a) in the batch", scene, pass, i,
                             h.triangle, h.t, hits[i].triangle, hits[i].t);
            }
        }
    }
    free(outs);
    free(hits);
    free(st);
    free(shared);
}

static void compare_scene(const char *name, const mesh_data *m, double resolution, size_t rays, uint64_t seed,
                          tally *t)
{
    octree *compiled = build(m, resolution, 0), *plain = build(m, resolution, 1);
    octree_info info;
    octree_get_info(compiled, &info);
    if (info.node_count > 1 && info.bytes_traversal == 0)
        fail_msg("%s: no traversal form was compiled", name);
    octree_get_info(plain, &info);
    assert_int_equal(info.bytes_traversal, 0);
    rng r = rng_seeded(seed);
    const accuracy_mode modes[] = {ACCURACY_EXACT, ACCURACY_FAST, ACCURACY_SEED};
    ray_input *all = malloc(rays * sizeof *all);
    for (size_t i = 0; i < rays; i++) {
        ray_input ray = hard_ray(&r, m, compiled, i);
        all[i] = ray;
        for (size_t k = 0; k < 3; k++)
            compare_ray(compiled, plain, m, &ray, modes[k], t, name, i);
        if (i % 3 == 0) {
            ray.contact = RAY_TOUCH;
            compare_ray(compiled, plain, m, &ray, ACCURACY_EXACT, t, name, i);
        }
    }
    compare_batches(compiled, all, rays, name);
    compare_batches(plain, all, rays, name);
    free(all);
    octree_free(compiled);
    octree_free(plain);
}

static void test_compiled_walk_equals_plain_walk_and_brute_force(void **state)
{
    (void)state;
    uint64_t seed = base_seed;
    printf("traversal form seed %llu\n", (unsigned long long)seed);
    box3 unit = {{-1, -1, -1}, {1, 1, 1}};
    mesh_data soup = meshgen_soup(seed, 600, unit, 0.3);
    mesh_data blocks = meshgen_blocks(seed, 4, 3, 3, 0.5);
    mesh_data sphere = meshgen_icosphere((vec3){0.5, 0.25, 0}, 1.0, 3);
    mesh_data terrain = meshgen_terrain(seed, (box3){{0, 0, 0}, {8, 8, 1}}, 24, 24);
    mesh_data far = meshgen_transformed(&soup, 1e-3, (vec3){1e6, 2e6, -1e6});
    mesh_data huge = meshgen_transformed(&blocks, 1e9, (vec3){3e12, -1e12, 5e11});
    mesh_data tiny = meshgen_transformed(&sphere, 1e-12, (vec3){1e-3, 0, 0});
    tally t = {0};
    compare_scene("soup", &soup, 0, 300, seed + 1, &t);
    compare_scene("soup, fine", &soup, 0.02, 150, seed + 2, &t);
    /* Leaves of a hundred triangles: their references name their nodes, not their lists. */
    compare_scene("soup, coarse", &soup, 1.0, 150, seed + 9, &t);
    compare_scene("blocks on node faces", &blocks, 0.125, 300, seed + 3, &t);
    compare_scene("icosphere", &sphere, 0, 300, seed + 4, &t);
    compare_scene("terrain", &terrain, 0, 300, seed + 5, &t);
    compare_scene("soup far and small", &far, 0, 200, seed + 6, &t);
    compare_scene("blocks at 1e9 scale", &huge, 0, 200, seed + 7, &t);
    compare_scene("icosphere at 1e-12", &tiny, 0, 200, seed + 8, &t);
    printf("%zu rays, %zu any-hit hits, %zu closest/all answers compared\n", t.rays, t.hits, t.compared);
    /* Most aimed rays hit: the comparison is not one of empty answers. */
    assert_true(t.hits > t.rays / 4);
    mesh_data_free(&soup);
    mesh_data_free(&blocks);
    mesh_data_free(&sphere);
    mesh_data_free(&terrain);
    mesh_data_free(&far);
    mesh_data_free(&huge);
    mesh_data_free(&tiny);
}

/* Every triangle of every leaf lies, clipped to the leaf's cube, inside the bounds the
 * form gives that leaf in its parent, and those inside the parent's own bounds. */
typedef struct bounds_check {
    const octree *tree;
    size_t leaves_checked;
    size_t spans, node_leaves; /* leaf references naming their list, and their node */
} bounds_check;

static void check_leaf(bounds_check *c, const traversal_node *parent, int lane, uint32_t index, box3 cube)
{
    const octree *t = c->tree;
    octree_node leaf = t->nodes[index];
    for (int a = 0; a < 3; a++) {
        double lo = (double)parent->origin[a] + (double)parent->q[a][lane] * (double)parent->scale;
        double hi = (double)parent->origin[a] + (double)parent->q[3 + a][lane] * (double)parent->scale;
        double wlo = vec3_get(t->world.lo, a);
        for (uint32_t i = 0; i < leaf.count; i++) {
            vec3 tri[3];
            octree_triangle_vertices(t, t->leaf_items[leaf.first + i], tri);
            double tlo = fmax(fmin(fmin(vec3_get(tri[0], a), vec3_get(tri[1], a)), vec3_get(tri[2], a)),
                              vec3_get(cube.lo, a));
            double thi = fmin(fmax(fmax(vec3_get(tri[0], a), vec3_get(tri[1], a)), vec3_get(tri[2], a)),
                              vec3_get(cube.hi, a));
            /* tlo - wlo >= lo exactly: compare in the world's frame without rounding
             * against us, as the walk's guarantee requires. */
            if (!(tlo - wlo >= lo && thi - wlo <= hi) && !(tlo >= wlo + lo && thi <= wlo + hi))
                fail_msg("leaf %u axis %d: triangle [%a, %a] outside bounds [%a, %a] (world %a)", index, a, tlo, thi,
                         lo, hi, wlo);
        }
    }
    c->leaves_checked++;
}

static void check_node(bounds_check *c, uint32_t ref, uint32_t octree_index, box3 cube)
{
    const octree *t = c->tree;
    const traversal_node *n = &t->traversal.nodes[ref];
    octree_node node = t->nodes[octree_index];
    assert_int_equal(node.count, NODE_INTERIOR);
    vec3 split = octree_split_point(t, cube);
    for (int k = 0; k < 8; k++) {
        unsigned upper = box_octant_upper_bits[k];
        uint32_t child_index = node.first + (uint32_t)k;
        box3 child_cube = box_child(cube, split, upper);
        uint32_t child = n->child[upper];
        octree_node kid = t->nodes[child_index];
        if (child == TRAVERSAL_EMPTY) {
            /* only a child that holds nothing has no lane */
            if (kid.count != NODE_INTERIOR)
                assert_int_equal(kid.count, 0);
            continue;
        }
        if (child & TRAVERSAL_LEAF) {
            /* A short leaf's reference names its list, a long one its node. */
            octree_node named = octree_leaf_of_ref(t, child);
            assert_int_equal(named.first, kid.first);
            assert_int_equal(named.count, kid.count);
            if (kid.count <= TRAVERSAL_SPAN_COUNT_MAX && kid.first < TRAVERSAL_SPAN_FIRST_LIMIT)
                assert_true(child & TRAVERSAL_SPAN);
            else
                assert_int_equal(child & ~TRAVERSAL_LEAF, child_index);
            c->spans += (child & TRAVERSAL_SPAN) != 0;
            c->node_leaves += (child & TRAVERSAL_SPAN) == 0;
            check_leaf(c, n, (int)upper, child_index, child_cube);
        } else {
            assert_true(child > ref && child < t->traversal.node_count);
            check_node(c, child, child_index, child_cube);
        }
    }
}

static void test_child_bounds_enclose_their_triangles(void **state)
{
    (void)state;
    mesh_data sphere = meshgen_icosphere((vec3){0.5, 0.25, 0}, 1.0, 4);
    mesh_data far = meshgen_transformed(&sphere, 1e-3, (vec3){1e6, 2e6, -1e6});
    const mesh_data *meshes[] = {&sphere, &far, &sphere};
    /* The third: leaves a quarter of the sphere across, most of them holding more
     * triangles than a reference can name (their references name their nodes). */
    const double resolutions[] = {0, 0, 0.5};
    for (size_t i = 0; i < 3; i++) {
        octree *t = build(meshes[i], resolutions[i], 0);
        bounds_check c = {t, 0, 0, 0};
        assert_true(t->traversal.present);
        assert_false(t->traversal.root & TRAVERSAL_LEAF);
        check_node(&c, t->traversal.root, 0, t->world);
        assert_true(c.leaves_checked > (i < 2 ? 100 : 10));
        assert_true(c.spans > 0);
        if (i == 2)
            assert_true(c.node_leaves > 0);
        octree_free(t);
    }
    mesh_data_free(&sphere);
    mesh_data_free(&far);
}

/* A one-leaf tree (L_max = 0) has its leaf as the form's root. */
static void test_single_leaf_tree(void **state)
{
    (void)state;
    mesh_data box = meshgen_box((box3){{0, 0, 0}, {1, 1, 1}});
    mesh_view v = mesh_data_view(&box);
    octree_def def = octree_default_def();
    def.max_depth = 0;
    octree_error err;
    octree *t = octree_build(&v, &def, &err);
    assert_non_null(t);
    assert_true(t->traversal.present);
    assert_true(t->traversal.root & TRAVERSAL_LEAF);
    ray_hit h;
    ray_output out = {.hits = &h, .max_hits = 1};
    ray_input ray = {{0.5, 0.5, -1}, {0, 0, 1}, 0, INFINITY, RAY_CROSSING};
    assert_int_equal(octree_ray(t, &ray, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
    assert_int_equal(out.hit_count, 1);
    assert_true(h.t == 1.0);
    octree_free(t);
    mesh_data_free(&box);
}

int main(void)
{
    const char *s = getenv("TRIOCT_TEST_SEED");
    if (s)
        base_seed = strtoull(s, NULL, 0);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_compiled_walk_equals_plain_walk_and_brute_force),
        cmocka_unit_test(test_child_bounds_enclose_their_triangles),
        cmocka_unit_test(test_single_leaf_tree),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
