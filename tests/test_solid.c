/* Solid objects: the exact closed-and-oriented check a solid's mesh passes at load
 * (server/world/solid_check.h), where a point lies against a posed solid
 * (octree_point_side_posed, object_set_point), triangles wholly inside a solid colliding
 * (object_set_triangle), and world_build refusing a solid that is not closed. */
#define _XOPEN_SOURCE 700 /* mkdtemp */

#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "engine.h"
#include "geom/ray_tri.h"
#include "geom/tri_tri.h"
#include "support/meshgen.h"
#include "support/obj_write.h"
#include "trioct_status.h"
#include "world/object_set.h"
#include "world/object_state.h"
#include "world/solid_check.h"
#include "world/world.h"

static const box3 unit_box = {{0, 0, 0}, {1, 1, 1}};

/* ---------- the check ---------- */

static solid_check_status check(const mesh_data *m, solid_defect *d)
{
    return solid_check(m, SIZE_MAX, NULL, d);
}

static int same(vec3 a, double x, double y, double z) { return a.x == x && a.y == y && a.z == z; }

/* The edge named is one of the two given (either way round). */
static void assert_edge(const solid_defect *d, vec3 a, vec3 b)
{
    int ab = same(d->from, a.x, a.y, a.z) && same(d->to, b.x, b.y, b.z);
    int ba = same(d->from, b.x, b.y, b.z) && same(d->to, a.x, a.y, a.z);
    if (!ab && !ba)
        fail_msg("edge (%g %g %g)-(%g %g %g) named, expected (%g %g %g)-(%g %g %g)", d->from.x, d->from.y, d->from.z,
                 d->to.x, d->to.y, d->to.z, a.x, a.y, a.z, b.x, b.y, b.z);
}

static void test_closed_meshes_pass(void **state)
{
    (void)state;
    mesh_data box = meshgen_box(unit_box);
    mesh_data ball = meshgen_icosphere((vec3){1, 2, 3}, 0.5, 2);
    mesh_data ring = meshgen_torus((vec3){0, 0, 0}, 2, 0.5, 24, 12);
    mesh_data fine = meshgen_subdivide(&box, 2);
    assert_int_equal(check(&box, NULL), SOLID_CLOSED);
    assert_int_equal(check(&ball, NULL), SOLID_CLOSED);
    assert_int_equal(check(&ring, NULL), SOLID_CLOSED);
    assert_int_equal(check(&fine, NULL), SOLID_CLOSED);
    /* What it takes is bounded and linear in the mesh: here 4 bytes a vertex for the weld,
     * at most 8 for its table, and at most 128 a triangle for the edges. */
    assert_true(solid_check_bytes(box.vertex_count, box.triangle_count) <= 12 * 8 + 128 * 12);
    assert_int_equal(solid_check(&box, solid_check_bytes(8, 12) - 1, NULL, NULL), SOLID_OVER_BUDGET);
    memory_account account;
    memory_account_init(&account, 64);
    assert_int_equal(solid_check(&box, SIZE_MAX, &account, NULL), SOLID_OVER_BUDGET);
    memory_account_init(&account, SIZE_MAX);
    assert_int_equal(solid_check(&box, SIZE_MAX, &account, NULL), SOLID_CLOSED);
    assert_int_equal(memory_account_used(&account), 0); /* lent for the check, given back */
    mesh_data_free(&box);
    mesh_data_free(&ball);
    mesh_data_free(&ring);
    mesh_data_free(&fine);
}

/* Files often give every face its own copies of its corners: they are welded by value,
 * -0 and +0 alike. */
static void test_duplicated_vertices_weld(void **state)
{
    (void)state;
    mesh_data box = meshgen_box(unit_box);
    mesh_data soup = {0};
    soup.vertex_count = 3 * box.triangle_count;
    soup.triangle_count = box.triangle_count;
    soup.vertices = malloc(soup.vertex_count * sizeof *soup.vertices);
    soup.indices = malloc(3 * soup.triangle_count * sizeof *soup.indices);
    for (size_t i = 0; i < soup.vertex_count; i++) {
        vec3 v = box.vertices[box.indices[i]];
        /* Every other copy of a zero coordinate is -0. */
        if (i % 2) {
            v.x = v.x == 0 ? -0.0 : v.x;
            v.y = v.y == 0 ? -0.0 : v.y;
        }
        soup.vertices[i] = v;
        soup.indices[i] = (uint32_t)i;
    }
    assert_int_equal(check(&soup, NULL), SOLID_CLOSED);
    /* One copy moved by an ulp is another vertex: the edges there are open. */
    solid_defect d;
    soup.vertices[0].x = nextafter(soup.vertices[0].x, 1.0);
    assert_int_equal(check(&soup, &d), SOLID_OPEN_EDGE);
    assert_int_equal(d.triangle, 0);
    assert_int_equal(d.uses, 1);
    mesh_data_free(&soup);
    mesh_data_free(&box);
}

static void test_missing_face_names_an_open_edge(void **state)
{
    (void)state;
    mesh_data box = meshgen_box(unit_box);
    /* Drop the z-high face (triangles 10 and 11). */
    box.triangle_count = 10;
    solid_defect d;
    assert_int_equal(check(&box, &d), SOLID_OPEN_EDGE);
    assert_int_equal(d.uses, 1);
    assert_int_equal(d.other, SIZE_MAX);
    /* The open edges are the four of the missing face's rim, all at z = 1. */
    assert_true(d.from.z == 1 && d.to.z == 1);
    assert_true(d.triangle < 10);
    char text[512];
    solid_defect_text(SOLID_OPEN_EDGE, &d, "box.obj triangle 3", "", text, sizeof text);
    assert_non_null(strstr(text, "is open: only box.obj triangle 3 uses it"));
    char coords[256];
    snprintf(coords, sizeof coords, "edge (%.17g %.17g %.17g) -> (%.17g %.17g %.17g)", d.from.x, d.from.y, d.from.z,
             d.to.x, d.to.y, d.to.z);
    assert_non_null(strstr(text, coords));
    mesh_data_free(&box);
}

static void test_flipped_face_names_a_misoriented_edge(void **state)
{
    (void)state;
    mesh_data box = meshgen_box(unit_box);
    /* Triangle 11 (z-high) turned over: its edges now run as its neighbours' do. */
    uint32_t *t = &box.indices[3 * 11];
    uint32_t keep = t[1];
    t[1] = t[2];
    t[2] = keep;
    solid_defect d;
    assert_int_equal(check(&box, &d), SOLID_MISORIENTED_EDGE);
    assert_int_equal(d.uses, 2);
    assert_true(d.triangle < 11);
    assert_int_equal(d.other, 11);
    /* The edge is one of triangle 11's. */
    int found = 0;
    for (int k = 0; k < 3; k++) {
        vec3 a = box.vertices[t[k]], b = box.vertices[t[(k + 1) % 3]];
        found |= (same(d.from, b.x, b.y, b.z) && same(d.to, a.x, a.y, a.z)) ||
                 (same(d.from, a.x, a.y, a.z) && same(d.to, b.x, b.y, b.z));
    }
    assert_true(found);
    char text[512];
    solid_defect_text(SOLID_MISORIENTED_EDGE, &d, "triangle 1", "triangle 11", text, sizeof text);
    assert_non_null(strstr(text, "is run the same way by triangle 1 and triangle 11"));
    mesh_data_free(&box);
}

static void test_edge_used_three_times(void **state)
{
    (void)state;
    mesh_data box = meshgen_box(unit_box);
    /* A fin on the box's edge from (1,1,1) to (1,0,1)... any box edge: a third triangle
     * on the edge of vertices 7 (1,1,1) and 3 (1,1,0). */
    mesh_data fin = meshgen_triangle(box.vertices[7], box.vertices[3], (vec3){2, 2, 0.5});
    assert_int_equal(mesh_data_append(&box, &fin), 0);
    solid_defect d;
    assert_int_equal(check(&box, &d), SOLID_OVERUSED_EDGE);
    assert_int_equal(d.uses, 3);
    assert_edge(&d, (vec3){1, 1, 1}, (vec3){1, 1, 0});
    assert_true(d.triangle < 12); /* met first on a box triangle */
    mesh_data_free(&fin);
    mesh_data_free(&box);
}

/* A triangle with a repeated vertex has no area and its edges cancel in it: left out. A
 * triangle with three distinct collinear corners counts like any other. */
static void test_zero_area_triangles(void **state)
{
    (void)state;
    mesh_data box = meshgen_box(unit_box);
    mesh_data needle = meshgen_triangle(box.vertices[0], box.vertices[0], box.vertices[7]);
    assert_int_equal(mesh_data_append(&box, &needle), 0);
    assert_int_equal(check(&box, NULL), SOLID_CLOSED);
    mesh_data_free(&box);
    mesh_data_free(&needle);

    /* A T-junction closed by a sliver: the square (0,0)-(2,0)-(2,1)-(0,1) of a flat
     * double-sided "pillow" whose bottom edge is split at (1,0) on one side only, the
     * sliver (0,0),(1,0),(2,0) closing it. Closed once the sliver counts. */
    vec3 v[] = {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {0, 1, 0}, {1, 0, 0}, {1, 0.5, 1}};
    uint32_t idx[] = {
        /* top, a tent over the square, split at (1,0) */
        0, 4, 5, 4, 1, 5, 1, 2, 5, 2, 3, 5, 3, 0, 5,
        /* bottom, the square in two, the long edge 0-1 whole */
        0, 2, 1, 0, 3, 2,
        /* the sliver along 0-1 */
        0, 1, 4,
    };
    mesh_data pillow = {v, 6, idx, 8};
    assert_int_equal(check(&pillow, NULL), SOLID_CLOSED);
    pillow.triangle_count = 7; /* without the sliver 0-1 is used once and 0-4, 4-1 once */
    solid_defect d;
    assert_int_equal(check(&pillow, &d), SOLID_OPEN_EDGE);
}

/* ---------- where a point lies ---------- */

static octree *tree_of(const mesh_data *m)
{
    mesh_view view = mesh_data_view(m);
    octree_def def = octree_default_def();
    octree_error err;
    octree *t = octree_build(&view, &def, &err);
    if (!t)
        fail_msg("build: %s", err.message);
    return t;
}

static point_side side_of(const octree *t, const pose *at, double x, double y, double z)
{
    point_side side = (point_side)-1;
    assert_int_equal(octree_point_side_posed(t, at, (vec3){x, y, z}, &side, NULL), OCTREE_OK);
    return side;
}

static void check_box_sides(double o, double s)
{
    box3 b = {{o, o, o}, {o + s, o + s, o + s}};
    mesh_data m = meshgen_box(b);
    octree *t = tree_of(&m);
    pose id = octree_pose_identity();
    double lo = o, hi = o + s, mid = o + s / 2, q = o + s * 0.25;
    assert_int_equal(side_of(t, &id, mid, mid, mid), POINT_INSIDE);
    /* Faces, edges, vertices, and a face's diagonal (a shared edge inside the face). */
    assert_int_equal(side_of(t, &id, mid, mid, hi), POINT_ON_SURFACE);
    assert_int_equal(side_of(t, &id, q, mid, lo), POINT_ON_SURFACE);
    assert_int_equal(side_of(t, &id, q, q, hi), POINT_ON_SURFACE);
    assert_int_equal(side_of(t, &id, mid, lo, lo), POINT_ON_SURFACE);
    assert_int_equal(side_of(t, &id, hi, hi, mid), POINT_ON_SURFACE);
    assert_int_equal(side_of(t, &id, hi, hi, hi), POINT_ON_SURFACE);
    assert_int_equal(side_of(t, &id, lo, lo, lo), POINT_ON_SURFACE);
    /* One ulp inside and outside of a face, of an edge and of a corner. The ray from
     * (q, q, hi - ulp) leaves through the top face's diagonal x = y: two triangles share
     * it and exactly one may count. */
    double in_hi = nextafter(hi, -INFINITY), out_hi = nextafter(hi, INFINITY);
    double in_lo = nextafter(lo, INFINITY), out_lo = nextafter(lo, -INFINITY);
    assert_int_equal(side_of(t, &id, q, q, in_hi), POINT_INSIDE);
    assert_int_equal(side_of(t, &id, q, q, out_hi), POINT_OUTSIDE);
    assert_int_equal(side_of(t, &id, mid, mid, in_lo), POINT_INSIDE);
    assert_int_equal(side_of(t, &id, mid, mid, out_lo), POINT_OUTSIDE);
    assert_int_equal(side_of(t, &id, in_hi, in_hi, mid), POINT_INSIDE);
    assert_int_equal(side_of(t, &id, out_hi, in_hi, mid), POINT_OUTSIDE);
    assert_int_equal(side_of(t, &id, in_hi, in_hi, in_hi), POINT_INSIDE);
    assert_int_equal(side_of(t, &id, out_hi, hi, hi), POINT_OUTSIDE);
    assert_int_equal(side_of(t, &id, in_lo, in_lo, in_lo), POINT_INSIDE);
    assert_int_equal(side_of(t, &id, out_lo, lo, lo), POINT_OUTSIDE);
    /* In the top face's plane, beyond it: outside, not on the surface. */
    assert_int_equal(side_of(t, &id, out_hi, mid, hi), POINT_OUTSIDE);
    /* Far away, on every side. */
    assert_int_equal(side_of(t, &id, mid, mid, o + 1e9 * s), POINT_OUTSIDE);
    assert_int_equal(side_of(t, &id, o - 1e9 * s, mid, mid), POINT_OUTSIDE);
    assert_int_equal(side_of(t, &id, -1e300, 1e300, 0), POINT_OUTSIDE);
    point_side side;
    assert_int_equal(octree_point_side_posed(t, &id, (vec3){NAN, 0, 0}, &side, NULL), OCTREE_ERR_NONFINITE);
    octree_free(t);
    mesh_data_free(&m);
}

static void test_point_side_of_a_box(void **state)
{
    (void)state;
    check_box_sides(0, 1);
    check_box_sides(-3, 0.125);
    check_box_sides(1e9, 1); /* a huge offset: one ulp there is 2^-23 */
    check_box_sides(-1e9, 1e-3);
}

/* The answer from every triangle, with a ray in another direction than the engine takes:
 * parity does not depend on the direction of the ray on a closed mesh. */
static point_side brute_side(const mesh_data *m, const pose *at, vec3 p, vec3 dir)
{
    const vec3 point[3] = {p, p, p};
    size_t crossings = 0;
    for (size_t t = 0; t < m->triangle_count; t++) {
        vec3 tri[3];
        for (int k = 0; k < 3; k++)
            tri[k] = octree_pose_point(at, mesh_data_corner(m, t, k));
        if (tri_tri_overlap_exact(point, tri))
            return POINT_ON_SURFACE;
        crossings += (size_t)ray_tri_exact(p, dir, 0.0, INFINITY, tri, NULL);
    }
    return crossings & 1 ? POINT_INSIDE : POINT_OUTSIDE;
}

static void check_against_brute_force(const mesh_data *m, const pose *at, vec3 centre, double radius, uint64_t seed,
                                      size_t *counts)
{
    octree *t = tree_of(m);
    rng r = rng_seeded(seed);
    const vec3 dirs[2] = {{0.36, -0.8, 0.48}, {-0.6, 0.0, 0.8}};
    for (int i = 0; i < 600; i++) {
        vec3 p;
        int kind = i % 3;
        if (kind == 0) { /* anywhere around it */
            box3 around = {{centre.x - 1.5 * radius, centre.y - 1.5 * radius, centre.z - 1.5 * radius},
                           {centre.x + 1.5 * radius, centre.y + 1.5 * radius, centre.z + 1.5 * radius}};
            p = rng_point_in_box(&r, around);
        } else { /* a posed vertex, or an ulp or a few from one (off and on the surface) */
            p = octree_pose_point(at, m->vertices[rng_next(&r) % m->vertex_count]);
            if (kind == 2) {
                int steps = (int)(rng_next(&r) % 5) - 2;
                double *c = (double *)&p + rng_next(&r) % 3;
                for (int k = 0; k < abs(steps); k++)
                    *c = nextafter(*c, steps > 0 ? INFINITY : -INFINITY);
            }
        }
        point_side got = (point_side)-1;
        assert_int_equal(octree_point_side_posed(t, at, p, &got, NULL), OCTREE_OK);
        point_side want = brute_side(m, at, p, dirs[i & 1]);
        if (got != want)
            fail_msg("seed %llu point %d (%.17g %.17g %.17g): %d, brute force %d", (unsigned long long)seed, i, p.x, p.y,
                     p.z, got, want);
        counts[got]++;
    }
    octree_free(t);
}

static void test_point_side_of_posed_solids_against_brute_force(void **state)
{
    (void)state;
    uint64_t seed = getenv("TRIOCT_SEED") ? strtoull(getenv("TRIOCT_SEED"), NULL, 10) : 2207;
    printf("seed %llu\n", (unsigned long long)seed);
    size_t counts[3] = {0};
    mesh_data ball = meshgen_icosphere((vec3){0, 0, 0}, 1, 2);
    mesh_data ring = meshgen_torus((vec3){0, 0, 0}, 2, 0.6, 20, 10);
    pose turned;
    assert_int_equal(octree_pose_from_quaternion((vec3){0.25, -3, 7}, 0.8, 0.36, 0.48, 0.0, &turned), OCTREE_OK);
    pose far;
    assert_int_equal(octree_pose_from_quaternion((vec3){1e9, -2e9, 5e8}, 0.5, 0.5, 0.5, 0.5, &far), OCTREE_OK);
    pose id = octree_pose_identity();
    check_against_brute_force(&ball, &id, (vec3){0, 0, 0}, 1, seed, counts);
    check_against_brute_force(&ball, &turned, turned.t, 1, seed + 1, counts);
    check_against_brute_force(&ring, &turned, turned.t, 2.6, seed + 2, counts);
    check_against_brute_force(&ring, &far, far.t, 2.6, seed + 3, counts);
    printf("inside %zu, outside %zu, on the surface %zu\n", counts[POINT_INSIDE], counts[POINT_OUTSIDE],
           counts[POINT_ON_SURFACE]);
    /* Every answer was met many times: the comparison tested each. */
    assert_true(counts[POINT_INSIDE] > 100 && counts[POINT_OUTSIDE] > 100 && counts[POINT_ON_SURFACE] > 100);

    /* The torus's hole is outside, its tube inside, whichever way it is turned. */
    octree *t = tree_of(&ring);
    vec3 hole = octree_pose_point(&turned, (vec3){0, 0, 0}), tube = octree_pose_point(&turned, (vec3){2, 0, 0});
    assert_int_equal(side_of(t, &turned, hole.x, hole.y, hole.z), POINT_OUTSIDE);
    assert_int_equal(side_of(t, &turned, tube.x, tube.y, tube.z), POINT_INSIDE);
    octree_free(t);
    mesh_data_free(&ball);
    mesh_data_free(&ring);
}

/* ---------- solid objects in a set ---------- */

static object_model *closed_model(const char *key, mesh_data m)
{
    octree_def def = octree_default_def();
    char err[256];
    object_model *model = object_model_create(key, &m, &def, err, sizeof err);
    if (!model)
        fail_msg("model %s: %s", key, err);
    assert_int_equal(solid_check(&model->mesh, SIZE_MAX, NULL, NULL), SOLID_CLOSED);
    atomic_store(&model->closed, 1);
    return model;
}

static pose placed(double x, double y, double z, double qw, double qx, double qy, double qz)
{
    pose p;
    assert_int_equal(octree_pose_from_quaternion((vec3){x, y, z}, qw, qx, qy, qz, &p), OCTREE_OK);
    return p;
}

/* A box without its top face, as a model (not closed, so never marked so). */
static object_model *model_open_box(void)
{
    mesh_data m = meshgen_box(unit_box);
    m.triangle_count = 10;
    octree_def def = octree_default_def();
    char err[256];
    object_model *model = object_model_create("open", &m, &def, err, sizeof err);
    assert_non_null(model);
    return model;
}

/* A set of a solid crate (a 2-cube turned and moved), a hollow crate (the same mesh, not
 * solid) and a solid ball. */
static object_set *solid_scene(object_model *cube, object_model *ball)
{
    object_edit adds[] = {
        {OBJECT_EDIT_ADD, "crate", cube, placed(10, 0, 0, 0.8, 0, 0, 0.6), 1},
        {OBJECT_EDIT_ADD, "hollow", cube, placed(-10, 0, 0, 1, 0, 0, 0), 0},
        {OBJECT_EDIT_ADD, "ball", ball, placed(0, 5, 1e6, 1, 0, 0, 0), 1},
    };
    object_set *empty = object_set_create(), *s = NULL;
    char err[256];
    size_t failed;
    assert_int_equal(object_set_apply(empty, adds, 3, &s, &failed, err, sizeof err), OBJECT_EDIT_OK);
    object_set_release(empty);
    assert_int_equal(s->solids, 2);
    return s;
}

static void test_point_in_a_set_of_objects(void **state)
{
    (void)state;
    object_model *cube = closed_model("cube", meshgen_box((box3){{-1, -1, -1}, {1, 1, 1}}));
    object_model *ball = closed_model("ball", meshgen_icosphere((vec3){0, 0, 0}, 1, 2));
    object_set *s = solid_scene(cube, ball);
    long crate = object_set_find(s, "crate"), sphere = object_set_find(s, "ball");
    object_point_output out;
    assert_int_equal(object_set_point(s, (vec3){10, 0, 0}, &out, NULL), OCTREE_OK);
    assert_int_equal(out.side, POINT_INSIDE);
    assert_int_equal(out.object, crate);
    /* A corner of the posed crate is on its surface. */
    vec3 corner = octree_pose_point(&s->objects[crate].at, (vec3){1, 1, 1});
    assert_int_equal(object_set_point(s, corner, &out, NULL), OCTREE_OK);
    assert_int_equal(out.side, POINT_ON_SURFACE);
    assert_int_equal(out.object, crate);
    /* Inside the hollow crate is outside every solid. */
    assert_int_equal(object_set_point(s, (vec3){-10, 0, 0}, &out, NULL), OCTREE_OK);
    assert_int_equal(out.side, POINT_OUTSIDE);
    assert_int_equal(out.object, UINT32_MAX);
    assert_int_equal(object_set_point(s, (vec3){0, 5, 1e6 + 0.5}, &out, NULL), OCTREE_OK);
    assert_int_equal(out.side, POINT_INSIDE);
    assert_int_equal(out.object, sphere);
    assert_int_equal(object_set_point(s, (vec3){0, 5, 1e6 + 1.5}, &out, NULL), OCTREE_OK);
    assert_int_equal(out.side, POINT_OUTSIDE);
    assert_int_equal(object_set_point(s, (vec3){0, INFINITY, 0}, &out, NULL), OCTREE_ERR_NONFINITE);

    /* A move keeps an object solid; the point follows the crate. */
    object_edit move = {OBJECT_EDIT_MOVE, "crate", NULL, placed(20, 0, 0, 1, 0, 0, 0), 0};
    object_set *moved = NULL;
    char err[256];
    size_t failed;
    assert_int_equal(object_set_apply(s, &move, 1, &moved, &failed, err, sizeof err), OBJECT_EDIT_OK);
    assert_int_equal(moved->solids, 2);
    assert_int_equal(object_set_point(moved, (vec3){20.5, 0, 0}, &out, NULL), OCTREE_OK);
    assert_int_equal(out.side, POINT_INSIDE);
    assert_int_equal(object_set_point(moved, (vec3){10, 0, 0}, &out, NULL), OCTREE_OK);
    assert_int_equal(out.side, POINT_OUTSIDE);
    object_set_release(moved);

    /* A solid needs a model checked closed. */
    object_model *open = model_open_box();
    object_edit bad = {OBJECT_EDIT_ADD, "leaky", open, placed(0, 0, 0, 1, 0, 0, 0), 1};
    assert_int_equal(object_set_apply(s, &bad, 1, &moved, &failed, err, sizeof err), OBJECT_EDIT_BAD_EDIT);
    assert_non_null(strstr(err, "checked closed"));
    object_model_release(open);
    object_set_release(s);
    object_model_release(cube);
    object_model_release(ball);
}

/* Inside a solid, the point distance is signed: minus the distance to the surface (the
 * penetration depth); inside the hollow copy of the same mesh, plus it. Exact answers on a
 * crate placed at a quarter turn. */
static void test_signed_distance_inside_a_solid(void **state)
{
    (void)state;
    object_model *cube = closed_model("cube", meshgen_box((box3){{-1, -1, -1}, {1, 1, 1}}));
    object_edit adds[] = {
        {OBJECT_EDIT_ADD, "crate", cube, {{0, -1, 0, 1, 0, 0, 0, 0, 1}, {10, 0, 0}}, 1},
        {OBJECT_EDIT_ADD, "hollow", cube, placed(-10, 0, 0, 1, 0, 0, 0), 0},
    };
    object_set *empty = object_set_create(), *s = NULL;
    char err[256];
    size_t failed;
    assert_int_equal(object_set_apply(empty, adds, 2, &s, &failed, err, sizeof err), OBJECT_EDIT_OK);
    long crate = object_set_find(s, "crate");
    object_distance_output out;
    /* 0.25 inside the crate's x = 11 face. */
    assert_int_equal(object_set_point_distance(s, (vec3){10.75, 0.25, 0.5}, INFINITY, &out, NULL), OCTREE_OK);
    assert_true(out.found && out.inside);
    assert_int_equal(out.inside_object, crate);
    assert_int_equal(out.object, crate);
    assert_true(out.distance.lower <= -0.25 && -0.25 <= out.distance.upper);
    if (!(out.distance.upper < 0 && out.distance.bound < 1e-14))
        fail_msg("distance %.17g bound %.3g [%.17g, %.17g]", out.distance.distance, out.distance.bound, out.distance.lower, out.distance.upper);
    assert_true(out.distance.point.x == 11);
    /* 0.25 inside the hollow copy: positive. */
    assert_int_equal(object_set_point_distance(s, (vec3){-9.25, 0.25, 0.5}, INFINITY, &out, NULL), OCTREE_OK);
    assert_true(out.found && !out.inside && out.inside_object == UINT32_MAX);
    assert_true(out.distance.lower <= 0.25 && 0.25 <= out.distance.upper && out.distance.lower > 0);
    /* Outside, and on the crate's surface: 2 and 0. */
    assert_int_equal(object_set_point_distance(s, (vec3){13, 0, 0}, INFINITY, &out, NULL), OCTREE_OK);
    assert_true(!out.inside && out.distance.lower <= 2 && 2 <= out.distance.upper);
    assert_int_equal(object_set_point_distance(s, (vec3){11, 0.5, 0.5}, INFINITY, &out, NULL), OCTREE_OK);
    assert_true(!out.inside && out.distance.lower == 0 && out.distance.upper < 1e-15);
    object_set_release(s);
    object_set_release(empty);
    object_model_release(cube);
}

static void test_triangles_inside_a_solid_collide(void **state)
{
    (void)state;
    object_model *cube = closed_model("cube", meshgen_box((box3){{-1, -1, -1}, {1, 1, 1}}));
    object_model *ball = closed_model("ball", meshgen_icosphere((vec3){0, 0, 0}, 1, 2));
    object_set *s = solid_scene(cube, ball);
    long crate = object_set_find(s, "crate");
    object_contact contacts[16];
    const vec3 inside_crate[3] = {{10.1, 0, 0}, {10, 0.2, 0.1}, {9.9, -0.1, 0.3}};
    const vec3 inside_hollow[3] = {{-10.1, 0, 0}, {-10, 0.2, 0.1}, {-9.9, -0.1, 0.3}};
    const vec3 nowhere[3] = {{0, -30, 0}, {1, -30, 0}, {0, -29, 0}};
    const vec3 through_crate[3] = {{10, 0, 0}, {14, 0, 0}, {10, 0.5, 0}};
    for (int detail = TRI_YESNO; detail <= TRI_SEGMENTS; detail++) {
        object_tri_output out = {.contacts = contacts, .capacity = 16};
        assert_int_equal(object_set_triangle(s, inside_crate, (tri_detail)detail, &out, NULL), OCTREE_OK);
        assert_true(out.hit);
        if (detail != TRI_YESNO) {
            assert_int_equal(out.count, 1);
            assert_int_equal(contacts[0].object, crate);
            assert_int_equal(contacts[0].contact.triangle, OBJECT_INTERIOR);
            assert_true(same(contacts[0].contact.p, 10.1, 0, 0) && same(contacts[0].contact.q, 10.1, 0, 0));
        }
        out = (object_tri_output){.contacts = contacts, .capacity = 16};
        assert_int_equal(object_set_triangle(s, inside_hollow, (tri_detail)detail, &out, NULL), OCTREE_OK);
        assert_false(out.hit);
        assert_int_equal(out.count, 0);
        out = (object_tri_output){.contacts = contacts, .capacity = 16};
        assert_int_equal(object_set_triangle(s, nowhere, (tri_detail)detail, &out, NULL), OCTREE_OK);
        assert_false(out.hit);
        /* Crossing the surface: the surface's triangles, no interior contact. */
        out = (object_tri_output){.contacts = contacts, .capacity = 16};
        assert_int_equal(object_set_triangle(s, through_crate, (tri_detail)detail, &out, NULL), OCTREE_OK);
        assert_true(out.hit);
        for (size_t k = 0; detail != TRI_YESNO && k < out.count; k++)
            assert_true(contacts[k].contact.triangle != OBJECT_INTERIOR);
    }
    /* No room for the contact: counted, marked truncated. */
    object_tri_output none = {.contacts = contacts, .capacity = 0};
    assert_int_equal(object_set_triangle(s, inside_crate, TRI_IDS, &none, NULL), OCTREE_OK);
    assert_true(none.hit);
    assert_int_equal(none.count, 1);
    assert_true(none.truncated);
    object_set_release(s);
    object_model_release(cube);
    object_model_release(ball);
}

/* A link (a shape at a pose) wholly inside a solid collides, through no triangle of it; inside
 * the hollow copy, or away, it does not; a link of two separate parts collides when one part
 * is inside; a link crossing the surface reports surface contacts only. */
static void test_links_inside_a_solid_collide(void **state)
{
    (void)state;
    object_model *cube = closed_model("cube", meshgen_box((box3){{-1, -1, -1}, {1, 1, 1}}));
    object_model *ball = closed_model("ball", meshgen_icosphere((vec3){0, 0, 0}, 1, 2));
    object_set *s = solid_scene(cube, ball);
    long crate = object_set_find(s, "crate");
    /* Two parts: a small cube at the origin and another 5 away along x. */
    mesh_data a = meshgen_box((box3){{-0.1, -0.1, -0.1}, {0.1, 0.1, 0.1}});
    mesh_data b = meshgen_box((box3){{4.9, -0.1, -0.1}, {5.1, 0.1, 0.1}});
    mesh_data two = meshgen_transformed(&a, 1.0, (vec3){0, 0, 0});
    assert_int_equal(mesh_data_append(&two, &b), 0);
    octree *one_tree = tree_of(&a), *two_tree = tree_of(&two);
    const struct {
        const octree *tree;
        box3 bounds;
        pose at;
        int valid;
    } cases[] = {
        {one_tree, mesh_data_bounds(&a), placed(10, 0.2, 0.1, 1, 0, 0, 0), 0},   /* inside the crate */
        {one_tree, mesh_data_bounds(&a), placed(-10, 0.2, 0.1, 1, 0, 0, 0), 1},  /* inside the hollow */
        {one_tree, mesh_data_bounds(&a), placed(0, -30, 0, 1, 0, 0, 0), 1},      /* nowhere */
        {two_tree, mesh_data_bounds(&two), placed(-15, 0, 0.2, 1, 0, 0, 0), 1},  /* parts at -15, -10: the hollow */
        {two_tree, mesh_data_bounds(&two), placed(5, 0, 0.2, 1, 0, 0, 0), 0},    /* parts at 5, 10: one in the crate */
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        for (int all = 0; all <= 1; all++) {
            state_contact contacts[8];
            state_output out = {.contacts = contacts, .capacity = 8};
            state_link link = {"link", cases[i].tree, cases[i].bounds, cases[i].at};
            assert_int_equal(object_set_state(s, &link, 1, NULL, 0, 0, all, &out, NULL, NULL), OCTREE_OK);
            if (out.valid != cases[i].valid)
                fail_msg("case %zu (all %d): valid %d", i, all, out.valid);
            if (!cases[i].valid) {
                assert_int_equal(out.count, 1);
                assert_int_equal(contacts[0].other, crate);
                assert_int_equal(contacts[0].other_triangle, OBJECT_INTERIOR);
                assert_true(contacts[0].link_triangle < (cases[i].tree == one_tree ? 12u : 24u));
            }
        }
    }
    /* Distance and clearance see it too: inside the crate the distance is negative (minus
     * its distance to the surface) and nothing is clear; inside the hollow copy, 0.7 from
     * its y = 1 face, positive and clear of 0.01. */
    state_link in_crate = {"link", one_tree, mesh_data_bounds(&a), placed(10, 0.2, 0.1, 1, 0, 0, 0)};
    state_link in_hollow = {"link", one_tree, mesh_data_bounds(&a), placed(-10, 0.2, 0.1, 1, 0, 0, 0)};
    object_shape_distance_output sd;
    assert_int_equal(object_set_shape_distance(s, one_tree, &in_crate.at, INFINITY, &sd, NULL), OCTREE_OK);
    assert_true(sd.found && sd.inside);
    assert_int_equal(sd.inside_object, crate);
    assert_true(sd.distance.upper < 0 && sd.distance.lower <= sd.distance.distance &&
                sd.distance.distance <= sd.distance.upper && sd.distance.distance > -1);
    assert_int_equal(object_set_shape_distance(s, one_tree, &in_hollow.at, INFINITY, &sd, NULL), OCTREE_OK);
    assert_true(sd.found && !sd.inside && sd.inside_object == UINT32_MAX);
    assert_true(sd.distance.lower <= 0.7 && 0.7 <= sd.distance.upper);
    int clear;
    long first;
    assert_int_equal(object_set_shape_clearance(s, one_tree, &in_crate.at, 0.01, &clear, &first, NULL), OCTREE_OK);
    assert_false(clear);
    assert_int_equal(first, crate);
    assert_int_equal(object_set_shape_clearance(s, one_tree, &in_hollow.at, 0.01, &clear, &first, NULL), OCTREE_OK);
    assert_true(clear && first == -1);

    /* Crossing the crate's face: its triangles, no interior contact. */
    state_contact contacts[64];
    state_output out = {.contacts = contacts, .capacity = 64};
    state_link crossing = {"link", one_tree, mesh_data_bounds(&a), placed(11, 0.2, 0.1, 1, 0, 0, 0)};
    assert_int_equal(object_set_state(s, &crossing, 1, NULL, 0, 0, 1, &out, NULL, NULL), OCTREE_OK);
    assert_false(out.valid);
    assert_true(out.count > 0);
    for (size_t k = 0; k < out.count && k < 64; k++)
        assert_true(contacts[k].other_triangle != OBJECT_INTERIOR);
    octree_free(one_tree);
    octree_free(two_tree);
    mesh_data_free(&a);
    mesh_data_free(&b);
    mesh_data_free(&two);
    object_set_release(s);
    object_model_release(cube);
    object_model_release(ball);
}

/* ---------- worlds: the load refuses a solid that is not closed ---------- */

typedef struct world_dir {
    char dir[64];
    char files[4][96];
    int count;
} world_dir;

static void dir_make(world_dir *d)
{
    memset(d, 0, sizeof *d);
    snprintf(d->dir, sizeof d->dir, "/tmp/trioct_solid_XXXXXX");
    assert_non_null(mkdtemp(d->dir));
}

static void dir_write(world_dir *d, const char *name, mesh_data m)
{
    assert_true(d->count < 4);
    char path[96];
    snprintf(path, sizeof path, "%s/%s", d->dir, name);
    memcpy(d->files[d->count], path, sizeof path);
    assert_int_equal(obj_write(d->files[d->count], &m), 0);
    d->count++;
    mesh_data_free(&m);
}

static void dir_remove(world_dir *d)
{
    for (int i = 0; i < d->count; i++)
        unlink(d->files[i]);
    rmdir(d->dir);
}

static mesh_data open_box(void)
{
    mesh_data m = meshgen_box(unit_box);
    m.triangle_count = 10;
    return m;
}

static mesh_data flipped_box(box3 b)
{
    mesh_data m = meshgen_box(b);
    uint32_t keep = m.indices[3 * 5 + 1];
    m.indices[3 * 5 + 1] = m.indices[3 * 5 + 2];
    m.indices[3 * 5 + 2] = keep;
    return m;
}

static world *build(const world_spec *spec, const char *dir, int *status, char *err, size_t len)
{
    return world_build(spec, dir, NULL, status, err, len);
}

static void test_world_load_checks_solids(void **state)
{
    (void)state;
    world_dir d;
    dir_make(&d);
    dir_write(&d, "box.obj", meshgen_box(unit_box));
    dir_write(&d, "open.obj", open_box());
    dir_write(&d, "flip.obj", flipped_box((box3){{5, 0, 0}, {6, 1, 1}}));
    char err[TRIOCT_MAX_MESSAGE_LEN];
    int status;

    /* A closed section mesh loads solid: its inside counts. */
    world_spec spec;
    world_spec_init(&spec, "cell");
    spec.mesh_count = 1;
    snprintf(spec.meshes[0], sizeof spec.meshes[0], "box.obj");
    spec.solid = 1;
    world *w = build(&spec, d.dir, &status, err, sizeof err);
    if (!w)
        fail_msg("%s", err);
    assert_int_equal(w->objects->solids, 1);
    assert_non_null(w->tree); /* still one object at the identity: rays take its tree */
    object_point_output where;
    assert_int_equal(object_set_point(w->objects, (vec3){0.5, 0.5, 0.5}, &where, NULL), OCTREE_OK);
    assert_int_equal(where.side, POINT_INSIDE);
    world_release(w);

    /* An open one is refused, the edge named by its coordinates and its triangle. */
    snprintf(spec.meshes[0], sizeof spec.meshes[0], "open.obj");
    assert_null(build(&spec, d.dir, &status, err, sizeof err));
    assert_int_equal(status, TRIOCT_ERR_LOAD_FAILED);
    if (!strstr(err, "world 'cell': the section's meshes: declared solid but not a closed surface: edge (") ||
        !strstr(err, ") is open: only open.obj triangle "))
        fail_msg("%s", err);
    /* Not solid, the same file loads. */
    spec.solid = 0;
    w = build(&spec, d.dir, &status, err, sizeof err);
    assert_non_null(w);
    assert_int_equal(w->objects->solids, 0);
    world_release(w);

    /* Merged meshes: the triangle is named in its own file. */
    spec.solid = 1;
    spec.mesh_count = 2;
    snprintf(spec.meshes[0], sizeof spec.meshes[0], "box.obj");
    snprintf(spec.meshes[1], sizeof spec.meshes[1], "flip.obj");
    assert_null(build(&spec, d.dir, &status, err, sizeof err));
    assert_int_equal(status, TRIOCT_ERR_LOAD_FAILED);
    if (!strstr(err, "is run the same way by flip.obj triangle ") || !strstr(err, "and flip.obj triangle "))
        fail_msg("%s", err);

    /* Objects: the section's solid applies to each, solid.NAME overrides it. */
    world_spec objs;
    world_spec_init(&objs, "shelf");
    objs.mesh_count = 2;
    snprintf(objs.meshes[0], sizeof objs.meshes[0], "box.obj");
    snprintf(objs.meshes[1], sizeof objs.meshes[1], "open.obj");
    objs.object_count = 2;
    objs.objects[0] = (world_object_spec){"crate", 0, placed(3, 0, 0, 0.8, 0.6, 0, 0), -1};
    objs.objects[1] = (world_object_spec){"tray", 1, placed(-3, 0, 0, 1, 0, 0, 0), 0};
    objs.solid = 1;
    w = build(&objs, d.dir, &status, err, sizeof err);
    if (!w)
        fail_msg("%s", err);
    assert_int_equal(w->objects->solids, 1);
    assert_true(w->objects->objects[object_set_find(w->objects, "crate")].solid);
    assert_false(w->objects->objects[object_set_find(w->objects, "tray")].solid);
    vec3 centre = octree_pose_point(&objs.objects[0].at, (vec3){0.5, 0.5, 0.5});
    assert_int_equal(object_set_point(w->objects, centre, &where, NULL), OCTREE_OK);
    assert_int_equal(where.side, POINT_INSIDE);
    assert_int_equal(where.object, object_set_find(w->objects, "crate"));
    world_release(w);
    objs.objects[1].solid = -1;
    assert_null(build(&objs, d.dir, &status, err, sizeof err));
    assert_int_equal(status, TRIOCT_ERR_LOAD_FAILED);
    if (!strstr(err, "world 'shelf': open.obj: declared solid but not a closed surface") ||
        !strstr(err, "only open.obj triangle "))
        fail_msg("%s", err);
    dir_remove(&d);
}

/* An object added at runtime is checked too (world_model_check_solid). */
static void test_added_solid_is_checked(void **state)
{
    (void)state;
    world_dir d;
    dir_make(&d);
    dir_write(&d, "box.obj", meshgen_box(unit_box));
    world_spec spec;
    world_spec_init(&spec, "cell");
    spec.mesh_count = 1;
    snprintf(spec.meshes[0], sizeof spec.meshes[0], "box.obj");
    char err[TRIOCT_MAX_MESSAGE_LEN];
    int status;
    world *w = build(&spec, d.dir, &status, err, sizeof err);
    assert_non_null(w);
    mesh_data box = meshgen_box(unit_box);
    vec3(*tris)[3] = malloc(box.triangle_count * sizeof *tris);
    for (size_t t = 0; t < box.triangle_count; t++)
        for (int k = 0; k < 3; k++)
            tris[t][k] = mesh_data_corner(&box, t, k);
    object_model *m = world_model_from_triangles(w, NULL, "lid", (const vec3(*)[3])tris, 12, &status, err, sizeof err);
    assert_non_null(m);
    assert_int_equal(world_model_check_solid(w, NULL, m, "inline", &status, err, sizeof err), 0);
    assert_true(atomic_load(&m->closed));
    object_model_release(m);
    m = world_model_from_triangles(w, NULL, "leaky", (const vec3(*)[3])tris, 11, &status, err, sizeof err);
    assert_non_null(m);
    assert_int_equal(world_model_check_solid(w, NULL, m, "inline", &status, err, sizeof err), -1);
    assert_int_equal(status, TRIOCT_ERR_LOAD_FAILED);
    if (!strstr(err, "inline: declared solid but not a closed surface") || !strstr(err, "is open: only inline triangle"))
        fail_msg("%s", err);
    assert_false(atomic_load(&m->closed));
    object_model_release(m);
    free(tris);
    mesh_data_free(&box);
    world_release(w);
    dir_remove(&d);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_closed_meshes_pass),
        cmocka_unit_test(test_duplicated_vertices_weld),
        cmocka_unit_test(test_missing_face_names_an_open_edge),
        cmocka_unit_test(test_flipped_face_names_a_misoriented_edge),
        cmocka_unit_test(test_edge_used_three_times),
        cmocka_unit_test(test_zero_area_triangles),
        cmocka_unit_test(test_point_side_of_a_box),
        cmocka_unit_test(test_point_side_of_posed_solids_against_brute_force),
        cmocka_unit_test(test_point_in_a_set_of_objects),
        cmocka_unit_test(test_signed_distance_inside_a_solid),
        cmocka_unit_test(test_triangles_inside_a_solid_collide),
        cmocka_unit_test(test_links_inside_a_solid_collide),
        cmocka_unit_test(test_world_load_checks_solids),
        cmocka_unit_test(test_added_solid_is_checked),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
