/* Mesh queries through the shape's own octree (octree_mesh_tree and the paths built on
 * it) answer exactly what the per-triangle path and brute force over every pair answer,
 * in every mode: random shapes at random rotated poses near the world's surface, shapes
 * touching at a face, an edge or a vertex, huge offsets, zero-area shape triangles,
 * truncated outputs, poses outside the shape tree's range, and registered trees of
 * several resolutions. */
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
#include "geom/tri_tri.h"
#include "octree/octree_internal.h"
#include "support/brute_force.h"
#include "support/meshgen.h"

static uint64_t base_seed = 20261202;

static const accuracy_mode modes[] = {ACCURACY_EXACT, ACCURACY_SEED, ACCURACY_FAST};

/* boxes: 1 for triangle boxes (a world's), 2 for node bounds (a query shape's). plain: no
 * compiled form, so the descent reads the world's octree nodes and cubes instead of the
 * form's content bounds. */
static octree *build_tree_plain(const mesh_data *m, double resolution, int boxes, double seed_eps, int plain)
{
    octree_def def = octree_default_def();
    def.plain_walk = plain;
    def.resolution = resolution;
    def.triangle_boxes = boxes == 1;
    def.node_bounds = boxes == 2;
    def.seed_epsilon = seed_eps;
    mesh_view v = mesh_data_view(m);
    octree_error err;
    octree *t = octree_build(&v, &def, &err);
    if (!t)
        fail_msg("build failed: %s", err.message);
    if (plain && t->traversal.present)
        fail_msg("a plain walk's tree has a compiled form");
    return t;
}

static octree *build_tree(const mesh_data *m, double resolution, int boxes, double seed_eps)
{
    return build_tree_plain(m, resolution, boxes, seed_eps, 0);
}

static vec3 posed_vertex(const pose *p, vec3 s)
{
    return (vec3){p->r[0] * s.x + p->r[1] * s.y + p->r[2] * s.z + p->t.x,
                  p->r[3] * s.x + p->r[4] * s.y + p->r[5] * s.z + p->t.y,
                  p->r[6] * s.x + p->r[7] * s.y + p->r[8] * s.z + p->t.z};
}

/* Every (shape triangle, world triangle) pair the mode's test accepts, sorted. */
static size_t brute_pairs(const mesh_data *world, const mesh_data *shape, const pose *p, accuracy_mode mode,
                          double eps, mesh_pair *pairs, size_t cap)
{
    mesh_view wv = mesh_data_view(world);
    uint32_t *ids = malloc(world->triangle_count * sizeof *ids);
    size_t n = 0;
    for (size_t q = 0; q < shape->triangle_count; q++) {
        vec3 tri[3];
        for (int k = 0; k < 3; k++)
            tri[k] = posed_vertex(p, mesh_data_corner(shape, q, k));
        size_t hits = brute_triangle(&wv, tri, mode, eps, ids, world->triangle_count);
        for (size_t j = 0; j < hits; j++, n++)
            if (n < cap)
                pairs[n] = (mesh_pair){(uint32_t)q, ids[j]};
    }
    free(ids);
    return n;
}

static void assert_same_output(const mesh_output *a, const mesh_output *b, const char *what)
{
    if (a->hit != b->hit || a->count != b->count || a->truncated != b->truncated)
        fail_msg("%s: hit %d count %zu truncated %d, expected hit %d count %zu truncated %d", what, b->hit, b->count,
                 b->truncated, a->hit, a->count, a->truncated);
    size_t n = a->count < a->capacity ? a->count : a->capacity;
    for (size_t i = 0; i < n; i++)
        if (a->pairs[i].query_triangle != b->pairs[i].query_triangle ||
            a->pairs[i].world_triangle != b->pairs[i].world_triangle)
            fail_msg("%s: pair %zu is (%u, %u), expected (%u, %u)", what, i, b->pairs[i].query_triangle,
                     b->pairs[i].world_triangle, a->pairs[i].query_triangle, a->pairs[i].world_triangle);
}

enum { CAP = 1 << 15 };

typedef struct checker {
    const mesh_data *world_mesh, *shape_mesh;
    const octree *world, *shape;
    mesh_pair *expect, *got;
    int brute; /* also compare with brute force over every pair */
} checker;

/* One pose in one mode: the shape-tree path equals the per-triangle path (and brute
 * force), for every pair, for yes/no, and truncated. Returns the number of pairs. */
static size_t check_pose(const checker *c, const pose *p, accuracy_mode mode, const char *what)
{
    char label[160];
    mesh_view sv = mesh_data_view(c->shape_mesh);
    mesh_output old = {.pairs = c->expect, .capacity = CAP};
    assert_int_equal(octree_mesh_as_triangles(c->world, &sv, p, 1, mode, &old, NULL), OCTREE_OK);
    assert_false(old.truncated);
    if (c->brute) {
        mesh_pair *bp = malloc(CAP * sizeof *bp);
        size_t n = brute_pairs(c->world_mesh, c->shape_mesh, p, mode, c->world->seed_epsilon, bp, CAP);
        mesh_output b = {n > 0, n, 0, bp, CAP};
        snprintf(label, sizeof label, "%s, %s, per-triangle path vs brute force", what, accuracy_mode_name(mode));
        assert_same_output(&b, &old, label);
        free(bp);
    }
    mesh_output got = {.pairs = c->got, .capacity = CAP};
    query_stats stats = {0};
    assert_int_equal(octree_mesh_tree(c->world, c->shape, p, 1, mode, &got, &stats), OCTREE_OK);
    snprintf(label, sizeof label, "%s, %s, all pairs", what, accuracy_mode_name(mode));
    assert_same_output(&old, &got, label);
    assert_true(stats.candidates_tested >= got.count);

    mesh_output yn_old = {0}, yn = {0};
    assert_int_equal(octree_mesh_as_triangles(c->world, &sv, p, 0, mode, &yn_old, NULL), OCTREE_OK);
    assert_int_equal(octree_mesh_tree(c->world, c->shape, p, 0, mode, &yn, NULL), OCTREE_OK);
    snprintf(label, sizeof label, "%s, %s, yes/no", what, accuracy_mode_name(mode));
    assert_same_output(&yn_old, &yn, label);
    assert_int_equal(yn.hit, old.count > 0);
    assert_int_equal(yn.count, 0);

    if (old.count >= 2) {
        size_t room = old.count / 2;
        mesh_output a = {.pairs = c->expect, .capacity = room}, b = {.pairs = c->got, .capacity = room};
        assert_int_equal(octree_mesh_as_triangles(c->world, &sv, p, 1, mode, &a, NULL), OCTREE_OK);
        assert_int_equal(octree_mesh_tree(c->world, c->shape, p, 1, mode, &b, NULL), OCTREE_OK);
        assert_true(a.truncated);
        snprintf(label, sizeof label, "%s, %s, truncated", what, accuracy_mode_name(mode));
        assert_same_output(&a, &b, label);
    }
    return old.count;
}

/* A rotation from a random unit quaternion (rounded: not exactly orthogonal, which the
 * engine does not need). */
static void random_rotation(rng *r, double m[9])
{
    double q[4], n = 0;
    for (int i = 0; i < 4; i++) {
        q[i] = rng_uniform(r, -1, 1);
        n += q[i] * q[i];
    }
    n = sqrt(n);
    double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
    double v[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
                   2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                   2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
    memcpy(m, v, sizeof v);
}

static vec3 shape_centre(const mesh_data *s)
{
    box3 b = mesh_data_bounds(s);
    return vec3_scale(vec3_add(b.lo, b.hi), 0.5);
}

/* A rotated pose that puts the shape's centre near a random world vertex, at a distance of
 * 0 to `reach` from it: some poses collide, others just miss. */
static pose near_surface_pose(rng *r, const mesh_data *world, const mesh_data *shape, double reach)
{
    pose p;
    random_rotation(r, p.r);
    vec3 v = world->vertices[rng_next(r) % world->vertex_count];
    vec3 target = vec3_add(v, vec3_scale(rng_unit_vector(r), rng_uniform(r, 0, reach)));
    vec3 c = shape_centre(shape);
    vec3 rc = {p.r[0] * c.x + p.r[1] * c.y + p.r[2] * c.z, p.r[3] * c.x + p.r[4] * c.y + p.r[5] * c.z,
               p.r[6] * c.x + p.r[7] * c.y + p.r[8] * c.z};
    p.t = vec3_sub(target, rc);
    return p;
}

static double shape_radius(const mesh_data *s)
{
    box3 b = mesh_data_bounds(s);
    return 0.5 * vec3_length(vec3_sub(b.hi, b.lo));
}

typedef struct scene {
    const char *name;
    mesh_data world;
    mesh_data shape;
    int poses;
    /* 1: the shape has zero-area triangles, which the seed test finds touching everything,
     * so no seed pose misses; 2: the world has them too, and the fast test takes two
     * flat triangles to touch at any distance, so no fast pose misses either. */
    int inexact_touches_all;
} scene;

static void run_random_poses(scene *s, uint64_t seed, int boxes, int brute)
{
    printf("scene %s: world %zu triangles, shape %zu, seed %llu%s\n", s->name, s->world.triangle_count,
           s->shape.triangle_count, (unsigned long long)seed, boxes ? ", triangle boxes" : "");
    octree *world = build_tree(&s->world, 0, boxes, 1e-9);
    octree *plain_world = build_tree_plain(&s->world, 0, boxes, 1e-9, 1);
    /* Shape trees with node bounds against worlds without triangle boxes, and plain
     * ones against worlds with them. */
    octree *shape = build_tree(&s->shape, 0, boxes ? 0 : 2, 1e-9);
    checker c = {&s->world, &s->shape, world, shape, malloc(CAP * sizeof(mesh_pair)), malloc(CAP * sizeof(mesh_pair)),
                 brute};
    /* Both ways of reading the world are exercised. */
    assert_true(world->traversal.present);
    checker plain = c;
    plain.world = plain_world;
    plain.brute = 0;
    rng r = rng_seeded(seed);
    double reach = 1.5 * shape_radius(&s->shape);
    for (size_t m = 0; m < 3; m++) {
        int hit = 0, miss = 0;
        for (int i = 0; i < s->poses; i++) {
            pose p = near_surface_pose(&r, &s->world, &s->shape, reach);
            char what[64];
            snprintf(what, sizeof what, "%s pose %d", s->name, i);
            size_t n = check_pose(&c, &p, modes[m], what);
            snprintf(what, sizeof what, "%s pose %d, world without its compiled form", s->name, i);
            assert_int_equal(check_pose(&plain, &p, modes[m], what), n);
            hit += n > 0;
            miss += n == 0;
        }
        /* The poses exercise both answers. */
        if (hit == 0 || (miss == 0 && !(modes[m] == ACCURACY_SEED && s->inexact_touches_all) &&
                         !(modes[m] == ACCURACY_FAST && s->inexact_touches_all == 2)))
            fail_msg("%s, %s: %d poses collide, %d do not", s->name, accuracy_mode_name(modes[m]), hit, miss);
    }
    free(c.expect);
    free(c.got);
    octree_free(world);
    octree_free(plain_world);
    octree_free(shape);
}

static void test_random_poses_equal_per_triangle_path_and_brute_force(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 1;
    box3 unit = {{-1, -1, -1}, {1, 1, 1}};
    scene scenes[] = {
        {"terrain, icosphere", meshgen_terrain(seed, (box3){{0, 0, 0}, {8, 8, 1}}, 12, 12),
         meshgen_icosphere((vec3){0.3, -0.2, 0.1}, 0.6, 2), 14, 0},
        {"icosphere, torus", meshgen_icosphere((vec3){0, 0, 0}, 1.0, 3), meshgen_torus((vec3){0, 0, 0}, 0.4, 0.12, 12, 8),
         14, 0},
        {"soup, soup", meshgen_soup(seed, 300, unit, 0.3), meshgen_soup(seed + 1, 60, (box3){{0, 0, 0}, {0.5, 0.5, 0.5}}, 0.2),
         14, 0},
        {"blocks, icosphere", meshgen_blocks(seed, 4, 3, 2, 0.5), meshgen_icosphere((vec3){0, 0, 0}, 0.3, 2), 14, 0},
    };
    for (size_t i = 0; i < sizeof scenes / sizeof scenes[0]; i++) {
        run_random_poses(&scenes[i], seed + 10 * i, (int)(i % 2), 1);
        mesh_data_free(&scenes[i].world);
        mesh_data_free(&scenes[i].shape);
    }
}

/* Larger meshes, compared with the per-triangle path only. */
static void test_larger_meshes_equal_per_triangle_path(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 2;
    mesh_data sphere = meshgen_icosphere((vec3){0, 0, 0}, 1.0, 4);
    mesh_data torus = meshgen_torus((vec3){0, 0, 0}, 0.3, 0.1, 48, 24);
    scene scenes[] = {
        {"terrain 48x48, torus", meshgen_terrain(seed, (box3){{0, 0, 0}, {8, 8, 1}}, 48, 48),
         meshgen_torus((vec3){0, 0, 0}, 0.3, 0.1, 48, 24), 20, 0},
        {"icosphere 5120, icosphere 1280", meshgen_icosphere((vec3){0, 0, 0}, 1.0, 4),
         meshgen_icosphere((vec3){0, 0, 0}, 0.25, 3), 20, 0},
    };
    for (size_t i = 0; i < sizeof scenes / sizeof scenes[0]; i++) {
        run_random_poses(&scenes[i], seed + 10 * i, (int)(i % 2 == 0), 0);
        mesh_data_free(&scenes[i].world);
        mesh_data_free(&scenes[i].shape);
    }
    mesh_data_free(&sphere);
    mesh_data_free(&torus);
}

/* 1e9 offsets with a metre-sized world and shape: the pose's rounding is a few ulps of
 * 1e9, which the frame's bound and every final test must respect. */
static void test_huge_offsets(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 3;
    mesh_data sphere = meshgen_icosphere((vec3){0, 0, 0}, 1.0, 3);
    mesh_data blocks = meshgen_blocks(seed, 3, 3, 2, 0.5);
    scene scenes[] = {
        {"icosphere at 1e9, torus", meshgen_transformed(&sphere, 1.0, (vec3){1e9, -1e9, 1e9}),
         meshgen_torus((vec3){0, 0, 0}, 0.4, 0.1, 12, 8), 12, 0},
        {"blocks at 1e6, icosphere", meshgen_transformed(&blocks, 1.0, (vec3){1e6, 1e6, 1e6}),
         meshgen_icosphere((vec3){0, 0, 0}, 0.3, 1), 12, 0},
    };
    for (size_t i = 0; i < sizeof scenes / sizeof scenes[0]; i++) {
        run_random_poses(&scenes[i], seed + 10 * i, 1, 1);
        mesh_data_free(&scenes[i].world);
        mesh_data_free(&scenes[i].shape);
    }
    /* The shape far from its own origin too: its local coordinates are at 1e9, and the
     * pose brings it back near the world. */
    mesh_data small = meshgen_icosphere((vec3){0, 0, 0}, 0.3, 2);
    scene far_shape = {"icosphere, shape at 1e9 locally", meshgen_icosphere((vec3){0, 0, 0}, 1.0, 3),
                       meshgen_transformed(&small, 1.0, (vec3){1e9, 1e9, -1e9}), 12, 0};
    run_random_poses(&far_shape, seed + 100, 0, 1);
    mesh_data_free(&far_shape.world);
    mesh_data_free(&far_shape.shape);
    mesh_data_free(&small);
    mesh_data_free(&sphere);
    mesh_data_free(&blocks);
}

/* A soup whose every third triangle is collapsed: to a point, to a segment (collinear
 * vertices), or to a segment with a repeated vertex. */
static mesh_data degenerate_soup(uint64_t seed, size_t n, box3 region, double size)
{
    mesh_data m = meshgen_soup(seed, n, region, size);
    for (size_t t = 0; t < m.triangle_count; t += 3) {
        vec3 *a = &m.vertices[m.indices[3 * t]], *b = &m.vertices[m.indices[3 * t + 1]],
             *c = &m.vertices[m.indices[3 * t + 2]];
        switch ((t / 3) % 3) {
        case 0: *b = *c = *a; break;
        case 1: *c = vec3_add(*a, vec3_scale(vec3_sub(*b, *a), 0.5)); break;
        default: *c = *b; break;
        }
    }
    return m;
}

static void test_zero_area_shape_triangles(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 4;
    box3 unit = {{-1, -1, -1}, {1, 1, 1}};
    scene s = {"soup, degenerate soup", meshgen_soup(seed, 300, unit, 0.3),
               degenerate_soup(seed + 1, 90, (box3){{0, 0, 0}, {0.5, 0.5, 0.5}}, 0.2), 16, 1};
    run_random_poses(&s, seed, 1, 1);
    /* A world with zero-area triangles too (the sliver lists of fast and seed mode). */
    mesh_data_free(&s.world);
    s.name = "degenerate soup, degenerate soup";
    s.world = degenerate_soup(seed + 2, 300, unit, 0.3);
    s.inexact_touches_all = 2;
    run_random_poses(&s, seed + 1, 0, 1);
    mesh_data_free(&s.world);
    mesh_data_free(&s.shape);
}

/* ---------- touching cases, with their answers known ---------- */

static pose translation(double x, double y, double z) { return (pose){{1, 0, 0, 0, 1, 0, 0, 0, 1}, {x, y, z}}; }

/* Under quarter turns about z and exact translations every posed coordinate is exact, so
 * contact is decided on the geometry as written. */
static pose quarter_turn(int turns, double x, double y, double z)
{
    double c = turns % 4 == 0 ? 1 : turns % 4 == 2 ? -1 : 0, s = turns % 4 == 1 ? 1 : turns % 4 == 3 ? -1 : 0;
    return (pose){{c, -s, 0, s, c, 0, 0, 0, 1}, {x, y, z}};
}

static mesh_data tetra(vec3 a, vec3 b, vec3 c, vec3 d) { return meshgen_tetrahedron(a, b, c, d); }

typedef struct touch_case {
    const char *name;
    mesh_data shape;
    pose at;
    int exact_hit; /* the exact answer (-1: only compared) */
} touch_case;

static void test_touching_shapes(void **state)
{
    (void)state;
    /* The world: blocks on a grid of exact values, faces on node faces, and a unit box. */
    mesh_data world = meshgen_box((box3){{0, 0, 0}, {1, 1, 1}});
    mesh_data blocks = meshgen_blocks(base_seed, 3, 3, 1, 0.5);
    mesh_data both = meshgen_transformed(&blocks, 1.0, (vec3){4, 0, 0});
    assert_int_equal(mesh_data_append(&world, &both), 0);
    /* The unit box alone at a quarter's resolution has the cube [0, 1]^3: its corner
     * (1, 1, 1) and its upper faces are the world cube's, held by one leaf each. */
    mesh_data unit_box = meshgen_box((box3){{0, 0, 0}, {1, 1, 1}});
    octree *wt[3] = {build_tree(&world, 0, 0, 1e-9), build_tree(&world, 0.125, 1, 1e-9),
                     build_tree(&unit_box, 0.25, 1, 1e-9)};
    assert_true(wt[2]->world.hi.x == 1.0 && wt[2]->world.hi.y == 1.0 && wt[2]->world.hi.z == 1.0);
    double above = nextafter(1.0, 2.0);
    touch_case cases[] = {
        /* A unit cube on the box's right face: the faces are coplanar and overlap. */
        {"face on face", meshgen_box((box3){{0, 0, 0}, {1, 1, 1}}), translation(1, 0, 0), 1},
        {"face one ulp off", meshgen_box((box3){{0, 0, 0}, {1, 1, 1}}), translation(above, 0, 0), 0},
        /* A half cube turned a quarter, its face on the top face. */
        {"turned face on face", meshgen_box((box3){{0, 0, 0}, {0.5, 0.5, 0.5}}), quarter_turn(1, 0.75, 0.25, 1), 1},
        /* A tetrahedron standing on its apex on the top face. */
        {"vertex on face",
         tetra((vec3){0.5, 0.5, 0}, (vec3){0, 0, 1}, (vec3){1, 0, 1}, (vec3){0.5, 1, 1}), translation(0, 0, 1), 1},
        {"vertex one ulp above",
         tetra((vec3){0.5, 0.5, 0}, (vec3){0, 0, 1}, (vec3){1, 0, 1}, (vec3){0.5, 1, 1}), translation(0, 0, above), 0},
        /* A tetrahedron lying on one edge along the top face. */
        {"edge on face",
         tetra((vec3){0, 0.5, 0}, (vec3){1, 0.5, 0}, (vec3){0.5, 0, 1}, (vec3){0.5, 1, 1}), translation(0, 0, 1), 1},
        /* A tetrahedron in the half-space z >= y + 1, whose boundary plane meets the box
         * only along its edge y = 0, z = 1: one edge of the tetrahedron lies in that plane
         * and crosses the box's edge at (0.5, 0, 1), the one common point. */
        {"edge across edge",
         tetra((vec3){0.5, -1, 0}, (vec3){0.5, 1, 2}, (vec3){0.5, -1, 2}, (vec3){1.5, -1, 2}), translation(0, 0, 0), 1},
        {"edge across edge, one ulp off",
         tetra((vec3){0.5, -1, 0}, (vec3){0.5, 1, 2}, (vec3){0.5, -1, 2}, (vec3){1.5, -1, 2}),
         translation(0, -0x1p-52, 0), 0},
        /* The half cube in a cell of the blocks, its faces on theirs (whether it meets one
         * depends on the blocks drawn: only compared). */
        {"cube among blocks", meshgen_box((box3){{0, 0, 0}, {0.5, 0.5, 0.5}}), quarter_turn(2, 5.0, 1.0, 0.0), -1},
        /* A point-sized shape (a zero-area triangle) on the box's corner, and a tetrahedron
         * whose lower corner is there. */
        {"point on corner", tetra((vec3){0, 0, 0}, (vec3){0, 0, 0}, (vec3){0, 0, 0}, (vec3){0, 0, 0}),
         translation(1, 1, 1), 1},
        {"corner on corner", tetra((vec3){0, 0, 0}, (vec3){1, 0, 0}, (vec3){0, 1, 0}, (vec3){0, 0, 1}),
         translation(1, 1, 1), 1},
    };
    mesh_pair *expect = malloc(CAP * sizeof *expect), *got = malloc(CAP * sizeof *got);
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        touch_case *tc = &cases[i];
        octree_def def = octree_default_def();
        def.node_bounds = (int)(i % 2);
        mesh_view sv = mesh_data_view(&tc->shape);
        octree *st = octree_build(&sv, &def, NULL);
        assert_non_null(st);
        for (int w = 0; w < 3; w++) {
            checker c = {w < 2 ? &world : &unit_box, &tc->shape, wt[w], st, expect, got, 1};
            for (size_t m = 0; m < 3; m++) {
                size_t n = check_pose(&c, &tc->at, modes[m], tc->name);
                if (modes[m] == ACCURACY_EXACT && tc->exact_hit >= 0 && (n > 0) != tc->exact_hit)
                    fail_msg("%s: exact contact %d, expected %d", tc->name, n > 0, tc->exact_hit);
            }
        }
        octree_free(st);
        mesh_data_free(&tc->shape);
    }
    free(expect);
    free(got);
    for (int w = 0; w < 3; w++)
        octree_free(wt[w]);
    mesh_data_free(&unit_box);
    mesh_data_free(&world);
    mesh_data_free(&blocks);
    mesh_data_free(&both);
}

/* A posed shape vertex that is exactly a world vertex, under rotations and translations
 * with full mantissas: the only contact, and it sits on the bounds of both trees (the
 * shape's vertex is its box's lower corner, the world triangle reaches away from it from
 * that point). The posed vertex is fl(R p + t), off from the real R p + t by rounding, so
 * a descent that trusted its rounded box test, or the rounded pose, to the last bit would
 * drop the contact about half the time. */
static void test_contact_at_a_rounded_posed_vertex(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 8;
    printf("posed vertex seed %llu\n", (unsigned long long)seed);
    rng r = rng_seeded(seed);
    mesh_pair *expect = malloc(CAP * sizeof *expect), *got = malloc(CAP * sizeof *got);
    int trials = 300, offsets[3] = {0};
    for (int i = 0; i < trials; i++) {
        pose p;
        random_rotation(&r, p.r);
        double scale = i % 3 == 0 ? 1.0 : i % 3 == 1 ? 1e3 : 1e7;
        p.t = (vec3){rng_uniform(&r, -scale, scale), rng_uniform(&r, -scale, scale), rng_uniform(&r, -scale, scale)};
        vec3 corner = {rng_uniform(&r, -1, 1), rng_uniform(&r, -1, 1), rng_uniform(&r, -1, 1)};
        double size = rng_uniform(&r, 0.1, 1);
        mesh_data shape = tetra(corner, vec3_add(corner, (vec3){size, 0, 0}), vec3_add(corner, (vec3){0, size, 0}),
                                vec3_add(corner, (vec3){0, 0, size}));
        vec3 v = posed_vertex(&p, corner);
        /* The world triangle opens from v away from the posed shape: along -R (1, 1, 1). */
        vec3 away = vec3_scale(vec3_make(p.r[0] + p.r[1] + p.r[2], p.r[3] + p.r[4] + p.r[5], p.r[6] + p.r[7] + p.r[8]),
                               -size);
        vec3 side = vec3_scale(vec3_normalize(vec3_cross(away, rng_unit_vector(&r))), 0.5 * size);
        vec3 wv[3] = {v, vec3_add(v, vec3_add(away, side)), vec3_add(v, vec3_sub(away, side))};
        uint32_t wi[3] = {0, 1, 2};
        mesh_data world = {wv, 3, wi, 1};
        int boxes = i % 2;
        octree *wt = build_tree(&world, 0, boxes, 1e-9), *st = build_tree(&shape, 0, 2 * (i % 4 < 2), 1e-9);
        checker c = {&world, &shape, wt, st, expect, got, 1};
        for (size_t m = 0; m < 3; m++) {
            size_t n = check_pose(&c, &p, modes[m], "posed vertex on a world vertex");
            if (modes[m] == ACCURACY_EXACT && n == 0)
                fail_msg("trial %d: the shared vertex is a contact", i);
        }
        /* The real R p + t differs from v on some axis in most trials: the case the bounds
         * are for. */
        vec3 e = vec3_sub(v, p.t);
        offsets[i % 3] += e.x != p.r[0] * corner.x + p.r[1] * corner.y + p.r[2] * corner.z;
        octree_free(wt);
        octree_free(st);
        mesh_data_free(&shape);
    }
    assert_true(offsets[1] > 0 && offsets[2] > 0);
    free(expect);
    free(got);
}

/* ---------- the public paths ---------- */

/* octree_mesh, octree_mesh_batch and octree_mesh_tree_batch give octree_mesh_tree's
 * answers pose by pose, with each item's own status. */
static void test_batches_and_inline_shapes_agree(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 5;
    mesh_data world = meshgen_terrain(seed, (box3){{0, 0, 0}, {8, 8, 1}}, 16, 16);
    mesh_data shape = meshgen_torus((vec3){0, 0, 0}, 0.5, 0.15, 16, 8);
    octree *wt = build_tree(&world, 0, 1, 1e-9), *st = build_tree(&shape, 0, 0, 1e-9);
    mesh_view sv = mesh_data_view(&shape);
    enum { POSES = 24, ROOM = 512 };
    pose poses[POSES];
    rng r = rng_seeded(seed);
    for (int i = 0; i < POSES; i++)
        poses[i] = near_surface_pose(&r, &world, &shape, 0.8);
    poses[5].r[4] = NAN; /* one bad pose: its own status, the others answered */
    mesh_pair *pool[3];
    for (int k = 0; k < 3; k++)
        pool[k] = malloc(POSES * ROOM * sizeof(mesh_pair));
    for (size_t m = 0; m < 3; m++)
        for (int all = 0; all <= 1; all++) {
            mesh_output outs[3][POSES];
            octree_status sts[3][POSES];
            for (int k = 0; k < 3; k++)
                for (int i = 0; i < POSES; i++)
                    outs[k][i] = (mesh_output){.pairs = pool[k] + i * ROOM, .capacity = ROOM};
            assert_int_equal(octree_mesh_batch(wt, &sv, poses, POSES, all, modes[m], outs[0], sts[0], NULL),
                             OCTREE_OK);
            assert_int_equal(octree_mesh_tree_batch(wt, st, poses, POSES, all, modes[m], outs[1], sts[1], NULL),
                             OCTREE_OK);
            int hits = 0;
            for (int i = 0; i < POSES; i++) {
                sts[2][i] = octree_mesh(wt, &sv, &poses[i], all, modes[m], &outs[2][i], NULL);
                mesh_output one = {.pairs = malloc(ROOM * sizeof(mesh_pair)), .capacity = ROOM};
                octree_status s1 = octree_mesh_tree(wt, st, &poses[i], all, modes[m], &one, NULL);
                mesh_output old = {.pairs = malloc(ROOM * sizeof(mesh_pair)), .capacity = ROOM};
                octree_status s0 = octree_mesh_as_triangles(wt, &sv, &poses[i], all, modes[m], &old, NULL);
                assert_int_equal(s0, i == 5 ? OCTREE_ERR_NONFINITE : OCTREE_OK);
                for (int k = 0; k < 3; k++)
                    assert_int_equal(sts[k][i], s0);
                assert_int_equal(s1, s0);
                if (s0 == OCTREE_OK) {
                    for (int k = 0; k < 3; k++)
                        assert_same_output(&old, &outs[k][i], "batch item");
                    assert_same_output(&old, &one, "single pose");
                    hits += old.hit;
                }
                free(one.pairs);
                free(old.pairs);
            }
            assert_true(hits > 0 && hits < POSES - 1);
        }
    /* An invalid shape gets octree_mesh's status for every pose, batch or not. */
    uint32_t bad_index[3] = {0, 1, 99999};
    mesh_view bad = {shape.vertices, shape.vertex_count, bad_index, 1};
    octree_status sts[POSES];
    mesh_output outs[POSES];
    for (int i = 0; i < POSES; i++)
        outs[i] = (mesh_output){0};
    assert_int_equal(octree_mesh_batch(wt, &bad, poses, POSES, 0, ACCURACY_EXACT, outs, sts, NULL), OCTREE_OK);
    assert_int_equal(sts[0], OCTREE_ERR_INDEX);
    assert_int_equal(sts[5], OCTREE_ERR_NONFINITE);
    assert_int_equal(octree_mesh(wt, &bad, &poses[0], 0, ACCURACY_EXACT, &outs[0], NULL), OCTREE_ERR_INDEX);
    mesh_output out = {0};
    assert_int_equal(octree_mesh_tree(wt, st, &poses[0], 0, (accuracy_mode)7, &out, NULL), OCTREE_ERR_INVALID);
    assert_int_equal(octree_mesh_tree(wt, st, NULL, 0, ACCURACY_EXACT, &out, NULL), OCTREE_ERR_INVALID);
    assert_int_equal(octree_mesh_tree(wt, NULL, &poses[0], 0, ACCURACY_EXACT, &out, NULL), OCTREE_ERR_INVALID);
    for (int k = 0; k < 3; k++)
        free(pool[k]);
    octree_free(wt);
    octree_free(st);
    mesh_data_free(&world);
    mesh_data_free(&shape);
}

/* An inline shape gets a tree only for a batch of 8 poses or more and a shape of 8
 * triangles or more; below either the per-triangle path answers, with the same answers
 * (a small batch here, octree_mesh's single poses in the test above). */
static void test_small_requests_take_the_per_triangle_path(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 7;
    mesh_data world = meshgen_terrain(seed, (box3){{0, 0, 0}, {8, 8, 1}}, 16, 16);
    mesh_data shape = meshgen_torus((vec3){0, 0, 0}, 0.5, 0.15, 16, 8);
    mesh_data tet = tetra((vec3){0, 0, 0}, (vec3){0.5, 0, 0}, (vec3){0, 0.5, 0}, (vec3){0, 0, 0.5});
    mesh_view sv = mesh_data_view(&shape), tv = mesh_data_view(&tet);
    assert_null(octree_shape_tree_for(&sv, 1));
    assert_null(octree_shape_tree_for(&sv, 7));
    octree *t = octree_shape_tree_for(&sv, 8);
    assert_non_null(t);
    assert_non_null(t->node_bounds);
    octree_free(t);
    assert_int_equal(tet.triangle_count, 4);
    assert_null(octree_shape_tree_for(&tv, 1000));

    octree *wt = build_tree(&world, 0, 1, 1e-9);
    enum { POSES = 7, ROOM = 512 };
    pose poses[POSES];
    rng r = rng_seeded(seed);
    for (int i = 0; i < POSES; i++)
        poses[i] = near_surface_pose(&r, &world, &shape, 2.0);
    mesh_pair *a = malloc(POSES * ROOM * sizeof *a), *b = malloc(ROOM * sizeof *b);
    int hits = 0;
    for (size_t m = 0; m < 3; m++) {
        mesh_output outs[POSES];
        octree_status sts[POSES];
        for (int i = 0; i < POSES; i++)
            outs[i] = (mesh_output){.pairs = a + i * ROOM, .capacity = ROOM};
        assert_int_equal(octree_mesh_batch(wt, &sv, poses, POSES, 1, modes[m], outs, sts, NULL), OCTREE_OK);
        for (int i = 0; i < POSES; i++) {
            mesh_output old = {.pairs = b, .capacity = ROOM};
            assert_int_equal(sts[i], OCTREE_OK);
            assert_int_equal(octree_mesh_as_triangles(wt, &sv, &poses[i], 1, modes[m], &old, NULL), OCTREE_OK);
            assert_same_output(&old, &outs[i], "small batch");
            hits += old.hit;
        }
    }
    assert_true(hits > 0 && hits < 3 * POSES);
    free(a);
    free(b);
    octree_free(wt);
    mesh_data_free(&world);
    mesh_data_free(&shape);
    mesh_data_free(&tet);
}

/* Poses outside the range of the shape tree's error bounds (entries past 2^32, offsets
 * past 2^400) are answered by the per-triangle path, including a posed vertex that
 * overflows, which is OCTREE_ERR_NONFINITE as before. */
static void test_poses_out_of_range_answer_as_before(void **state)
{
    (void)state;
    mesh_data world = meshgen_icosphere((vec3){0, 0, 0}, 1.0, 2);
    mesh_data shape = meshgen_icosphere((vec3){0, 0, 0}, 0.5, 1);
    mesh_data far_world = meshgen_transformed(&world, 1e100, (vec3){1e130, 0, 0});
    octree *wt = build_tree(&world, 0, 0, 1e-9), *ft = build_tree(&far_world, 0, 0, 1e-9);
    octree *st = build_tree(&shape, 0, 0, 1e-9);
    mesh_view sv = mesh_data_view(&shape);
    pose poses[] = {
        {{1e10, 0, 0, 0, 1e10, 0, 0, 0, 1e10}, {0, 0, 0}},     /* entries past 2^32, a huge shape on the world */
        {{DBL_MAX, 0, 0, 0, 1, 0, 0, 0, 1}, {DBL_MAX, 0, 0}},  /* the posed shape overflows */
        {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {1e130, 0, 0}},          /* an offset past 2^400 */
        /* the shape at the far world's scale, centred on its surface */
        {{1e100, 0, 0, 0, 1e100, 0, 0, 0, 1e100}, {1e130 + 1e100, 0, 0}},
    };
    mesh_pair *a = malloc(CAP * sizeof *a), *b = malloc(CAP * sizeof *b);
    for (size_t i = 0; i < sizeof poses / sizeof poses[0]; i++)
        for (int w = 0; w < 2; w++) {
            const octree *t = w ? ft : wt;
            for (int all = 0; all <= 1; all++) {
                mesh_output oa = {.pairs = a, .capacity = CAP}, ob = {.pairs = b, .capacity = CAP};
                octree_status sa = octree_mesh_as_triangles(t, &sv, &poses[i], all, ACCURACY_EXACT, &oa, NULL);
                octree_status sb = octree_mesh_tree(t, st, &poses[i], all, ACCURACY_EXACT, &ob, NULL);
                assert_int_equal(sa, sb);
                if (i == 1)
                    assert_int_equal(sa, OCTREE_ERR_NONFINITE);
                if (sa == OCTREE_OK)
                    assert_same_output(&oa, &ob, "pose out of range");
            }
        }
    /* The huge shape holds the world without meeting it; the shape at the far world's
     * scale meets it. */
    mesh_output o = {0};
    assert_int_equal(octree_mesh_tree(wt, st, &poses[0], 0, ACCURACY_EXACT, &o, NULL), OCTREE_OK);
    assert_int_equal(o.hit, 0); /* a sphere of radius 5e9 around a unit sphere: no contact */
    assert_int_equal(octree_mesh_tree(ft, st, &poses[3], 0, ACCURACY_EXACT, &o, NULL), OCTREE_OK);
    assert_int_equal(o.hit, 1);
    free(a);
    free(b);
    octree_free(wt);
    octree_free(ft);
    octree_free(st);
    mesh_data_free(&world);
    mesh_data_free(&far_world);
    mesh_data_free(&shape);
}

/* The shape tree's resolution changes its work, never its answers. */
static void test_shape_tree_resolution_does_not_change_answers(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 6;
    mesh_data world = meshgen_icosphere((vec3){0, 0, 0}, 1.0, 3);
    mesh_data shape = meshgen_torus((vec3){0, 0, 0}, 0.4, 0.12, 16, 8);
    octree *wt = build_tree(&world, 0, 1, 1e-9);
    octree *heuristic = build_tree(&shape, 0, 0, 1e-9);
    double d = heuristic->info.resolution;
    octree_free(heuristic);
    const double factors[] = {1.0 / 8, 1.0 / 2, 1, 4, 64};
    mesh_pair *expect = malloc(CAP * sizeof *expect), *got = malloc(CAP * sizeof *got);
    rng r = rng_seeded(seed);
    pose poses[12];
    for (int i = 0; i < 12; i++)
        poses[i] = near_surface_pose(&r, &world, &shape, 0.6);
    for (size_t f = 0; f < sizeof factors / sizeof factors[0]; f++) {
        octree *st = build_tree(&shape, d * factors[f], 2, 1e-9);
        checker c = {&world, &shape, wt, st, expect, got, 0};
        int hits = 0;
        for (int i = 0; i < 12; i++)
            for (size_t m = 0; m < 3; m++)
                hits += check_pose(&c, &poses[i], modes[m], "shape resolution") > 0;
        assert_true(hits > 0);
        octree_free(st);
    }
    free(expect);
    free(got);
    octree_free(wt);
    mesh_data_free(&world);
    mesh_data_free(&shape);
}

/* octree_def.node_bounds: each leaf's bounds are its triangles' bounds within its box,
 * each interior node's the union of its children's; the bytes are in the info. */
static void check_bounds(const octree *t, uint32_t node, box3 cell, box3 *out)
{
    octree_node n = t->nodes[node];
    box3 want = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    if (n.count == NODE_INTERIOR) {
        vec3 c = octree_split_point(t, cell);
        for (int k = 0; k < 8; k++) {
            box3 kb;
            check_bounds(t, n.first + (uint32_t)k, box_child(cell, c, box_octant_upper_bits[k]), &kb);
            want.lo = vec3_min(want.lo, kb.lo);
            want.hi = vec3_max(want.hi, kb.hi);
        }
    } else {
        for (uint32_t i = 0; i < n.count; i++) {
            vec3 v[3];
            octree_triangle_vertices(t, t->leaf_items[n.first + i], v);
            for (int k = 0; k < 3; k++) {
                want.lo = vec3_min(want.lo, v[k]);
                want.hi = vec3_max(want.hi, v[k]);
            }
        }
        if (n.count)
            want = (box3){vec3_max(want.lo, cell.lo), vec3_min(want.hi, cell.hi)};
    }
    box3 got = t->node_bounds[node];
    assert_true(vec3_equal(got.lo, want.lo) && vec3_equal(got.hi, want.hi));
    if (n.count)
        assert_true(got.lo.x >= cell.lo.x && got.hi.x <= cell.hi.x && got.lo.x <= got.hi.x);
    *out = got;
}

static void test_node_bounds_hold_each_nodes_triangles(void **state)
{
    (void)state;
    mesh_data m = meshgen_torus((vec3){0.25, 0, 0}, 0.5, 0.15, 16, 8);
    octree *plain = build_tree(&m, 0, 0, 1e-9), *bounded = build_tree(&m, 0, 2, 1e-9);
    assert_null(plain->node_bounds);
    assert_int_equal(plain->info.bytes_node_bounds, 0);
    assert_int_equal(bounded->info.bytes_node_bounds,
                     bounded->node_count * sizeof(box3) + bounded->node_count / 8 * sizeof(child_lanes));
    assert_int_equal(bounded->info.bytes_total, plain->info.bytes_total + bounded->info.bytes_node_bounds);
    assert_int_equal(bounded->info.node_count, plain->info.node_count);
    /* The blocks' lanes are their nodes' bounds and counts, as the lane tests would read them. */
    size_t blocks_checked = 0;
    for (size_t b = 1; b < bounded->node_count / 8; b++, blocks_checked++) {
        const child_lanes *g = &bounded->child_lanes[b];
        for (int k = 0; k < 8; k++) {
            box3 nb = bounded->node_bounds[8 * b + (size_t)k];
            const double lo[3] = {nb.lo.x, nb.lo.y, nb.lo.z}, hi[3] = {nb.hi.x, nb.hi.y, nb.hi.z};
            assert_int_equal((g->live >> k) & 1, bounded->nodes[8 * b + (size_t)k].count != 0);
            if (bounded->nodes[8 * b + (size_t)k].count == 0)
                continue;
            for (int a = 0; a < 3; a++) {
                assert_true(g->c[a][k] == 0.5 * (lo[a] + hi[a]));
                assert_true(g->h[a][k] == 0.5 * (hi[a] - lo[a]));
            }
        }
    }
    assert_true(blocks_checked > 10);
    box3 root;
    check_bounds(bounded, 0, bounded->world, &root);
    box3 mb = mesh_data_bounds(&m);
    assert_true(vec3_equal(root.lo, mb.lo) && vec3_equal(root.hi, mb.hi));
    octree_def def = octree_default_def();
    def.node_bounds = 2;
    mesh_view v = mesh_data_view(&m);
    octree_error err;
    assert_null(octree_build(&v, &def, &err));
    assert_int_equal(err.status, OCTREE_ERR_INVALID);
    octree_free(plain);
    octree_free(bounded);
    mesh_data_free(&m);
}

/* The seed's epsilon at a scale that matters (1e-3 of a unit world): its slack widens the
 * descent, and every pair its test accepts is still found. */
static void test_seed_epsilon_that_matters(void **state)
{
    (void)state;
    uint64_t seed = base_seed + 7;
    mesh_data world = meshgen_icosphere((vec3){0, 0, 0}, 1.0, 3);
    mesh_data shape = meshgen_icosphere((vec3){0, 0, 0}, 0.3, 2);
    octree *wt = build_tree(&world, 0, 0, 1e-3), *st = build_tree(&shape, 0, 0, 1e-9);
    checker c = {&world, &shape, wt, st, malloc(CAP * sizeof(mesh_pair)), malloc(CAP * sizeof(mesh_pair)), 1};
    rng r = rng_seeded(seed);
    int hits = 0;
    for (int i = 0; i < 16; i++) {
        pose p = near_surface_pose(&r, &world, &shape, 0.45);
        hits += check_pose(&c, &p, ACCURACY_SEED, "seed epsilon 1e-3") > 0;
    }
    assert_true(hits > 0 && hits < 16);
    free(c.expect);
    free(c.got);
    octree_free(wt);
    octree_free(st);
    mesh_data_free(&world);
    mesh_data_free(&shape);
}

int main(void)
{
    const char *s = getenv("TRIOCT_SEED");
    if (s)
        base_seed = strtoull(s, NULL, 10);
    printf("test_shape_tree base seed %llu (set TRIOCT_SEED to rerun)\n", (unsigned long long)base_seed);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_random_poses_equal_per_triangle_path_and_brute_force),
        cmocka_unit_test(test_larger_meshes_equal_per_triangle_path),
        cmocka_unit_test(test_huge_offsets),
        cmocka_unit_test(test_zero_area_shape_triangles),
        cmocka_unit_test(test_touching_shapes),
        cmocka_unit_test(test_contact_at_a_rounded_posed_vertex),
        cmocka_unit_test(test_batches_and_inline_shapes_agree),
        cmocka_unit_test(test_small_requests_take_the_per_triangle_path),
        cmocka_unit_test(test_poses_out_of_range_answer_as_before),
        cmocka_unit_test(test_shape_tree_resolution_does_not_change_answers),
        cmocka_unit_test(test_seed_epsilon_that_matters),
        cmocka_unit_test(test_node_bounds_hold_each_nodes_triangles),
    };
    /* Twice: the descent's child tests as this machine picks them (AVX2 where it is), and
     * with the baseline lanes, so that both compiled copies answer every case. */
    int failed = cmocka_run_group_tests_name("shape_tree", tests, NULL, NULL);
    octree_shape_lanes_force_portable(1);
    failed += cmocka_run_group_tests_name("shape_tree, baseline lanes", tests, NULL, NULL);
    octree_shape_lanes_force_portable(0);
    return failed;
}
