/* A world of named objects (server/world/object_set.h): rays and triangles over posed
 * objects answer as one tree of all their posed triangles would, to the bit, ties between
 * coincident faces of two objects included, and so do point and shape distances; edit lists apply all or nothing and make new versions while
 * old ones keep answering as they did; objects that share a mesh share one model. */
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
#include "support/meshgen.h"
#include "world/object_set.h"
#include "world/object_state.h"

static object_model *model_of(const char *key, mesh_data m)
{
    octree_def def = octree_default_def();
    char err[256];
    object_model *model = object_model_create(key, &m, &def, err, sizeof err);
    if (!model)
        fail_msg("model %s: %s", key, err);
    return model;
}

static pose at(double x, double y, double z, double qw, double qx, double qy, double qz)
{
    pose p;
    assert_int_equal(octree_pose_from_quaternion((vec3){x, y, z}, qw, qx, qy, qz, &p), OCTREE_OK);
    return p;
}

static object_set *apply_ok(const object_set *from, const object_edit *edits, size_t n)
{
    object_set *out;
    char err[256];
    size_t failed;
    object_edit_status st = object_set_apply(from, edits, n, &out, &failed, err, sizeof err);
    if (st != OBJECT_EDIT_OK)
        fail_msg("edit %zu: %s", failed, err);
    return out;
}

/* The set's objects' posed meshes, in object order, as one mesh, with where each
 * object's triangles start. */
static mesh_data union_mesh(const object_set *s, size_t *offsets)
{
    mesh_data all = {0};
    for (size_t i = 0; i < s->count; i++) {
        const world_object *o = &s->objects[i];
        mesh_data m = {0};
        m.vertex_count = o->model->mesh.vertex_count;
        m.triangle_count = o->model->mesh.triangle_count;
        m.vertices = malloc(m.vertex_count * sizeof *m.vertices);
        m.indices = malloc(3 * m.triangle_count * sizeof *m.indices);
        for (size_t v = 0; v < m.vertex_count; v++)
            m.vertices[v] = octree_pose_point(&o->at, o->model->mesh.vertices[v]);
        memcpy(m.indices, o->model->mesh.indices, 3 * m.triangle_count * sizeof *m.indices);
        offsets[i] = all.triangle_count;
        assert_int_equal(mesh_data_append(&all, &m), 0);
        mesh_data_free(&m);
    }
    return all;
}

#define MAX_HITS 64

/* The union tree's triangle id as (object, triangle). */
static void split_id(const object_set *s, const size_t *offsets, uint32_t id, uint32_t *object, uint32_t *triangle)
{
    size_t k = s->count - 1;
    while (offsets[k] > id)
        k--;
    *object = (uint32_t)k;
    *triangle = id - (uint32_t)offsets[k];
}

static void check_ray(const object_set *s, const octree *u, const size_t *offsets, const ray_input *ray,
                      size_t *hits)
{
    for (int detail = RAY_ANY; detail <= RAY_ALL; detail++) {
        object_hit oh[MAX_HITS];
        ray_hit uh[MAX_HITS];
        object_ray_output oo = {.hits = oh, .max_hits = MAX_HITS};
        ray_output uo = {.hits = uh, .max_hits = MAX_HITS};
        assert_int_equal(object_set_ray(s, ray, (ray_detail)detail, &oo, NULL), OCTREE_OK);
        assert_int_equal(octree_ray(u, ray, (ray_detail)detail, ACCURACY_EXACT, &uo, NULL), OCTREE_OK);
        assert_int_equal(oo.hit_count, uo.hit_count);
        assert_int_equal(oo.truncated, uo.truncated);
        *hits += uo.hit_count > 0;
        if (detail == RAY_ANY) /* which hit ends the search depends on the visiting order */
            continue;
        size_t n = uo.hit_count < MAX_HITS ? uo.hit_count : MAX_HITS;
        for (size_t i = 0; i < n; i++) {
            uint32_t object, triangle;
            split_id(s, offsets, uh[i].triangle, &object, &triangle);
            const ray_hit *a = &oh[i].hit, *b = &uh[i];
            if (oh[i].object != object || a->triangle != triangle || a->t != b->t || a->u != b->u || a->v != b->v ||
                a->normal.x != b->normal.x || a->normal.y != b->normal.y || a->normal.z != b->normal.z)
                fail_msg("detail %d hit %zu: objects give %s:%u at t %.17g, the union tree %s:%u at t %.17g", detail,
                         i, s->objects[oh[i].object].name, a->triangle, a->t, s->objects[object].name, triangle,
                         b->t);
        }
    }
}

#define MAX_CONTACTS 256

static void check_triangle(const object_set *s, const octree *u, const size_t *offsets, const vec3 q[3],
                           size_t *touched)
{
    for (int detail = TRI_YESNO; detail <= TRI_SEGMENTS; detail++) {
        object_contact oc[MAX_CONTACTS];
        tri_contact uc[MAX_CONTACTS];
        object_tri_output oo = {.contacts = oc, .capacity = MAX_CONTACTS};
        tri_output uo = {.contacts = uc, .capacity = MAX_CONTACTS};
        assert_int_equal(object_set_triangle(s, q, (tri_detail)detail, &oo, NULL), OCTREE_OK);
        assert_int_equal(octree_triangle(u, q, (tri_detail)detail, ACCURACY_EXACT, &uo, NULL), OCTREE_OK);
        assert_int_equal(oo.hit, uo.hit);
        assert_int_equal(oo.count, uo.count);
        assert_int_equal(oo.truncated, uo.truncated);
        if (detail == TRI_YESNO)
            *touched += uo.hit;
        /* Three kept: the first three of the union's order, and every contact counted. */
        object_contact oc3[3];
        tri_contact uc3[3];
        object_tri_output oo3 = {.contacts = oc3, .capacity = 3};
        tri_output uo3 = {.contacts = uc3, .capacity = 3};
        assert_int_equal(object_set_triangle(s, q, (tri_detail)detail, &oo3, NULL), OCTREE_OK);
        assert_int_equal(octree_triangle(u, q, (tri_detail)detail, ACCURACY_EXACT, &uo3, NULL), OCTREE_OK);
        assert_int_equal(oo3.count, uo3.count);
        assert_int_equal(oo3.truncated, uo3.truncated);
        for (size_t i = 0; i < 3 && i < uo3.count && detail != TRI_YESNO; i++)
            assert_int_equal(oc3[i].contact.triangle, oc[i].contact.triangle);
        size_t n = uo.count < MAX_CONTACTS ? uo.count : MAX_CONTACTS;
        for (size_t i = 0; i < n; i++) {
            uint32_t object, triangle;
            split_id(s, offsets, uc[i].triangle, &object, &triangle);
            const tri_contact *a = &oc[i].contact, *b = &uc[i];
            if (oc[i].object != object || a->triangle != triangle || a->p.x != b->p.x || a->p.y != b->p.y ||
                a->p.z != b->p.z || a->q.x != b->q.x || a->q.y != b->q.y || a->q.z != b->q.z)
                fail_msg("detail %d contact %zu: objects give %s:%u, the union tree %s:%u", detail, i,
                         s->objects[oc[i].object].name, a->triangle, s->objects[object].name, triangle);
        }
    }
}

static void check_against_union(const object_set *s, int rays, uint64_t seed)
{
    size_t offsets[16];
    assert_true(s->count <= 16);
    mesh_data all = union_mesh(s, offsets);
    mesh_view v = mesh_data_view(&all);
    octree_def def = octree_default_def();
    octree_error e;
    octree *u = octree_build(&v, &def, &e);
    assert_non_null(u);
    box3 b = mesh_data_bounds(&all);
    vec3 ext = vec3_sub(b.hi, b.lo);
    box3 around = {vec3_sub(b.lo, vec3_scale(ext, 0.3)), vec3_add(b.hi, vec3_scale(ext, 0.3))};
    rng r = rng_seeded(seed);
    size_t hits = 0;
    for (int i = 0; i < rays; i++) {
        size_t t = rng_next(&r) % all.triangle_count;
        vec3 a = mesh_data_corner(&all, t, 0), c1 = mesh_data_corner(&all, t, 1), c2 = mesh_data_corner(&all, t, 2);
        vec3 target = i % 4 == 1 ? a
                      : i % 4 == 2 ? vec3_scale(vec3_add(a, c1), 0.5)
                                   : vec3_scale(vec3_add(vec3_add(a, c1), c2), 1.0 / 3);
        vec3 o = rng_point_in_box(&r, around);
        ray_input toward = {o, vec3_sub(target, o), 0, INFINITY, i % 3 == 0 ? RAY_TOUCH : RAY_CROSSING};
        check_ray(s, u, offsets, &toward, &hits);
        ray_input inside = {rng_point_in_box(&r, b), rng_unit_vector(&r), 0, i % 5 ? INFINITY : 0.5, RAY_CROSSING};
        check_ray(s, u, offsets, &inside, &hits);
    }
    assert_true(hits > (size_t)rays); /* rays that all missed would check nothing */
    /* Triangles on the objects' surfaces (two in three), sharing a vertex or coincident
     * with one of theirs, and across the scene. */
    size_t touched = 0;
    for (int i = 0; i < rays / 2; i++) {
        size_t t = rng_next(&r) % all.triangle_count;
        vec3 q[3] = {mesh_data_corner(&all, t, 0), mesh_data_corner(&all, t, 1), mesh_data_corner(&all, t, 2)};
        double size = vec3_length(vec3_sub(q[1], q[0]));
        if (i % 3 == 1) {
            q[1] = vec3_add(q[0], vec3_scale(rng_unit_vector(&r), size));
            q[2] = vec3_add(q[0], vec3_scale(rng_unit_vector(&r), size));
        } else if (i % 3 == 2) {
            for (int k = 0; k < 3; k++)
                q[k] = rng_point_in_box(&r, b);
        }
        check_triangle(s, u, offsets, q, &touched);
    }
    assert_true(touched >= (size_t)rays / 2 * 2 / 3);
    /* Point distances: the union tree's nearest triangle and upper bound, to the bit; on
     * the surface (a vertex, an edge's midpoint) and around it. */
    for (int i = 0; i < rays / 2; i++) {
        size_t t = rng_next(&r) % all.triangle_count;
        vec3 a = mesh_data_corner(&all, t, 0), c1 = mesh_data_corner(&all, t, 1);
        vec3 p = i % 3 == 0 ? a : i % 3 == 1 ? vec3_scale(vec3_add(a, c1), 0.5) : rng_point_in_box(&r, around);
        object_distance_output got;
        distance_output want;
        assert_int_equal(object_set_point_distance(s, p, INFINITY, &got, NULL), OCTREE_OK);
        assert_int_equal(octree_point_distance(u, p, INFINITY, &want, NULL), OCTREE_OK);
        assert_true(got.found && want.found);
        uint32_t object, triangle;
        split_id(s, offsets, want.triangle, &object, &triangle);
        assert_int_equal(got.object, object);
        assert_int_equal(got.distance.triangle, triangle);
        assert_true(got.distance.upper == want.upper);
        assert_true(got.distance.lower <= got.distance.upper);
        assert_true(got.distance.distance - got.distance.bound <= got.distance.lower);
        /* Nothing within half the lower bound. */
        if (got.distance.lower > 0) {
            assert_int_equal(object_set_point_distance(s, p, got.distance.lower / 2, &got, NULL), OCTREE_OK);
            assert_false(got.found);
        }
    }
    /* Shape distance and clearance: a small sphere at poses around the scene answers as
     * against the union tree: the same pair and upper bound when apart, 0 when touching. */
    mesh_data ball = meshgen_icosphere((vec3){0, 0, 0}, 0.3, 1);
    mesh_view bv = mesh_data_view(&ball);
    octree_def bdef = octree_default_def();
    bdef.node_bounds = 1;
    octree *ball_tree = octree_build(&bv, &bdef, &e);
    assert_non_null(ball_tree);
    for (int i = 0; i < rays / 8; i++) {
        pose at;
        vec3 axis = rng_unit_vector(&r);
        double angle = rng_uniform(&r, -3, 3);
        assert_int_equal(octree_pose_from_quaternion(rng_point_in_box(&r, around), cos(angle / 2),
                                                     axis.x * sin(angle / 2), axis.y * sin(angle / 2),
                                                     axis.z * sin(angle / 2), &at),
                         OCTREE_OK);
        object_shape_distance_output got;
        shape_distance_output want;
        assert_int_equal(object_set_shape_distance(s, ball_tree, &at, INFINITY, &got, NULL), OCTREE_OK);
        assert_int_equal(octree_shape_distance(u, NULL, ball_tree, &at, INFINITY, &want, NULL), OCTREE_OK);
        assert_true(got.found && want.found);
        if (want.upper == 0) {
            assert_true(got.distance.upper == 0 && got.distance.lower == 0);
        } else {
            uint32_t object, triangle;
            split_id(s, offsets, want.world_triangle, &object, &triangle);
            assert_int_equal(got.object, object);
            assert_int_equal(got.distance.world_triangle, triangle);
            assert_int_equal(got.distance.shape_triangle, want.shape_triangle);
            assert_true(got.distance.upper == want.upper);
            int clear;
            long first;
            assert_int_equal(object_set_shape_clearance(s, ball_tree, &at, want.lower * 0.5, &clear, &first, NULL),
                             OCTREE_OK);
            assert_true(clear && first == -1);
        }
        /* A state of two links: the ball here and at the scene's centre; its distance is
         * the smaller of the two links' (the first on a tie), and an allowed pair naming
         * the nearest object leaves that object out for that link. */
        pose centre = {{1, 0, 0, 0, 1, 0, 0, 0, 1}, vec3_scale(vec3_add(b.lo, b.hi), 0.5)};
        state_link links[2] = {{"near", ball_tree, mesh_data_bounds(&ball), at},
                               {"centre", ball_tree, mesh_data_bounds(&ball), centre}};
        shape_distance_output other;
        assert_int_equal(octree_shape_distance(u, NULL, ball_tree, &centre, INFINITY, &other, NULL), OCTREE_OK);
        state_distance_output sd;
        assert_int_equal(object_set_state_distance(s, links, 2, NULL, 0, INFINITY, &sd, NULL), OCTREE_OK);
        assert_true(sd.found);
        double smaller = want.upper <= other.upper ? want.upper : other.upper;
        assert_true(sd.distance.upper == smaller);
        if (smaller > 0)
            assert_int_equal(sd.link, want.upper <= other.upper ? 0 : 1);
        if (sd.distance.upper > 0) {
            state_allowed skip = {links[sd.link].name, s->objects[sd.object].name};
            state_distance_output without;
            assert_int_equal(object_set_state_distance(s, links, 2, &skip, 1, INFINITY, &without, NULL), OCTREE_OK);
            assert_true(!without.found || without.link != sd.link || without.object != sd.object);
            assert_true(!without.found || without.distance.upper >= sd.distance.upper);
        }
        int clear;
        long first;
        assert_int_equal(object_set_shape_clearance(s, ball_tree, &at, want.upper * 2 + 1e-9, &clear, &first, NULL),
                         OCTREE_OK);
        assert_false(clear);
        assert_true(first >= 0 && (size_t)first < s->count);
    }
    octree_free(ball_tree);
    mesh_data_free(&ball);
    octree_free(u);
    mesh_data_free(&all);
}

/* Two spheres sharing one model, a rotated box, two unit cubes side by side whose shared
 * face is coincident in both (rays through it tie between the two objects at one t), and a
 * torus at a georeferenced offset, far from the rest. */
static void test_rays_answer_as_the_union_tree(void **state)
{
    (void)state;
    object_model *sphere = model_of("sphere.obj", meshgen_icosphere((vec3){0, 0, 0}, 1.0, 3));
    object_model *cube = model_of("cube.obj", meshgen_box((box3){{0, 0, 0}, {1, 1, 1}}));
    object_model *torus = model_of("torus.obj", meshgen_torus((vec3){0, 0, 0}, 2.0, 0.5, 24, 12));
    object_set *empty = object_set_create();
    object_edit edits[] = {
        {OBJECT_EDIT_ADD, "ball-a", sphere, at(0, 0, 0, 1, 0, 0, 0), 0},
        {OBJECT_EDIT_ADD, "ball-b", sphere, at(2.5, 0.5, 0, 0.9, 0.1, 0.3, 0.3), 0},
        {OBJECT_EDIT_ADD, "crate", cube, at(-1, 2, 0.5, 0.8, 0.0, 0.6, 0.0), 0},
        {OBJECT_EDIT_ADD, "cube-left", cube, at(0, -3, 0, 1, 0, 0, 0), 0},
        {OBJECT_EDIT_ADD, "cube-right", cube, at(1, -3, 0, 1, 0, 0, 0), 0},
        {OBJECT_EDIT_ADD, "ring", torus, at(1e6 + 0.25, 2e6, -30, 0.7, 0.7, 0.1, 0.1), 0},
    };
    object_set *s = apply_ok(empty, edits, 6);
    assert_int_equal(s->count, 6);
    assert_int_equal(s->version, 1);
    /* Sorted by name: answers do not depend on the order objects came in. */
    assert_string_equal(s->objects[0].name, "ball-a");
    assert_string_equal(s->objects[5].name, "ring");

    /* Without the far torus the others share one tree's resolution range. */
    object_edit drop = {OBJECT_EDIT_REMOVE, "ring", NULL, {{0}, {0, 0, 0}}, 0};
    object_set *near = apply_ok(s, &drop, 1);
    check_against_union(near, 400, 11);

    /* The shared face x = 1 of the two cubes, straight on: the two objects' triangles
     * there are coincident, and the tie goes to the smaller index, cube-left. */
    ray_input through = {{3, -2.75, 0.4}, {-1, 0, 0}, 0, INFINITY, RAY_CROSSING};
    object_hit h;
    object_ray_output out = {.hits = &h, .max_hits = 1};
    assert_int_equal(object_set_ray(near, &through, RAY_CLOSEST, &out, NULL), OCTREE_OK);
    assert_int_equal(out.hit_count, 1);
    assert_string_equal(near->objects[h.object].name, "cube-right");
    assert_true(h.hit.t == 1.0);
    ray_input between = {{0.5, -2.75, 0.4}, {1, 0, 0}, 0, INFINITY, RAY_CROSSING};
    assert_int_equal(object_set_ray(near, &between, RAY_CLOSEST, &out, NULL), OCTREE_OK);
    assert_int_equal(out.hit_count, 1);
    assert_true(h.hit.t == 0.5);
    assert_string_equal(near->objects[h.object].name, "cube-left");

    /* The torus alone, at its offset. */
    object_edit keep_ring[] = {
        {OBJECT_EDIT_REMOVE, "ball-a", NULL, {{0}, {0, 0, 0}}, 0}, {OBJECT_EDIT_REMOVE, "ball-b", NULL, {{0}, {0, 0, 0}}, 0},
        {OBJECT_EDIT_REMOVE, "crate", NULL, {{0}, {0, 0, 0}}, 0}, {OBJECT_EDIT_REMOVE, "cube-left", NULL, {{0}, {0, 0, 0}}, 0},
        {OBJECT_EDIT_REMOVE, "cube-right", NULL, {{0}, {0, 0, 0}}, 0},
    };
    object_set *far = apply_ok(s, keep_ring, 5);
    assert_int_equal(far->count, 1);
    check_against_union(far, 200, 12);

    object_set_release(far);
    object_set_release(near);
    object_set_release(s);
    object_set_release(empty);
    object_model_release(sphere);
    object_model_release(cube);
    object_model_release(torus);
}

static double closest_t(const object_set *s, const ray_input *ray, const char **name)
{
    object_hit h;
    object_ray_output out = {.hits = &h, .max_hits = 1};
    assert_int_equal(object_set_ray(s, ray, RAY_CLOSEST, &out, NULL), OCTREE_OK);
    *name = out.hit_count ? s->objects[h.object].name : "";
    return out.hit_count ? h.hit.t : INFINITY;
}

/* A query on version n sees version n's objects, whatever was applied since; a failing
 * edit list changes nothing. */
static void test_versions_and_edits(void **state)
{
    (void)state;
    object_model *cube = model_of("cube.obj", meshgen_box((box3){{0, 0, 0}, {1, 1, 1}}));
    object_set *v0 = object_set_create();
    assert_int_equal(v0->version, 0);
    object_edit add[] = {
        {OBJECT_EDIT_ADD, "near", cube, at(2, 0, 0, 1, 0, 0, 0), 0},
        {OBJECT_EDIT_ADD, "far", cube, at(6, 0, 0, 1, 0, 0, 0), 0},
    };
    object_set *v1 = apply_ok(v0, add, 2);
    assert_int_equal(v1->version, 1);
    ray_input ray = {{0, 0.5, 0.5}, {1, 0, 0}, 0, INFINITY, RAY_CROSSING};
    const char *name;
    assert_true(closest_t(v1, &ray, &name) == 2.0);
    assert_string_equal(name, "near");
    /* Every hit, two kept: all four counted, the nearest two stored in order. */
    object_hit two[2];
    object_ray_output out = {.hits = two, .max_hits = 2};
    assert_int_equal(object_set_ray(v1, &ray, RAY_ALL, &out, NULL), OCTREE_OK);
    assert_int_equal(out.hit_count, 4);
    assert_int_equal(out.truncated, 1);
    assert_true(two[0].hit.t == 2.0 && two[1].hit.t == 3.0);
    assert_string_equal(v1->objects[two[1].object].name, "near");
    /* One kept: each object is asked for one, and still counts all of its own. */
    out.max_hits = 1;
    assert_int_equal(object_set_ray(v1, &ray, RAY_ALL, &out, NULL), OCTREE_OK);
    assert_int_equal(out.hit_count, 4);
    assert_int_equal(out.truncated, 1);
    assert_true(two[0].hit.t == 2.0);

    /* Move the near cube out of the ray's way: the new version sees the far one, the old
     * version still the near one. No model is rebuilt. */
    object_edit move = {OBJECT_EDIT_MOVE, "near", NULL, at(2, 5, 0, 1, 0, 0, 0), 0};
    object_set *v2 = apply_ok(v1, &move, 1);
    assert_int_equal(v2->version, 2);
    assert_true(closest_t(v2, &ray, &name) == 6.0);
    assert_string_equal(name, "far");
    assert_true(closest_t(v1, &ray, &name) == 2.0);
    assert_string_equal(name, "near");
    assert_ptr_equal(v2->objects[object_set_find(v2, "near")].model, cube);

    /* All or nothing: the second edit names no object, so the first does not apply. */
    object_edit bad[] = {
        {OBJECT_EDIT_REMOVE, "far", NULL, {{0}, {0, 0, 0}}, 0},
        {OBJECT_EDIT_MOVE, "missing", NULL, at(0, 0, 0, 1, 0, 0, 0), 0},
    };
    object_set *none = (object_set *)1;
    size_t failed = 99;
    char err[256] = "";
    assert_int_equal(object_set_apply(v2, bad, 2, &none, &failed, err, sizeof err), OBJECT_EDIT_UNKNOWN);
    assert_null(none);
    assert_int_equal(failed, 1);
    assert_non_null(strstr(err, "missing"));
    assert_int_equal(v2->count, 2);
    assert_true(closest_t(v2, &ray, &name) == 6.0);

    object_edit dup = {OBJECT_EDIT_ADD, "far", cube, at(0, 0, 0, 1, 0, 0, 0), 0};
    assert_int_equal(object_set_apply(v2, &dup, 1, &none, &failed, err, sizeof err), OBJECT_EDIT_EXISTS);
    object_edit scaled = {OBJECT_EDIT_MOVE, "far", NULL, {{2, 0, 0, 0, 2, 0, 0, 0, 2}, {0, 0, 0}}, 0};
    assert_int_equal(object_set_apply(v2, &scaled, 1, &none, &failed, err, sizeof err), OBJECT_EDIT_BAD_POSE);
    assert_non_null(strstr(err, "not a rotation"));
    object_edit nan_pose = {OBJECT_EDIT_MOVE, "far", NULL, {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {NAN, 0, 0}}, 0};
    assert_int_equal(object_set_apply(v2, &nan_pose, 1, &none, &failed, err, sizeof err), OBJECT_EDIT_BAD_POSE);
    object_edit bad_name = {OBJECT_EDIT_ADD, "a b", cube, at(0, 0, 0, 1, 0, 0, 0), 0};
    assert_int_equal(object_set_apply(v2, &bad_name, 1, &none, &failed, err, sizeof err), OBJECT_EDIT_BAD_NAME);
    object_edit no_model = {OBJECT_EDIT_ADD, "ghost", NULL, at(0, 0, 0, 1, 0, 0, 0), 0};
    assert_int_equal(object_set_apply(v2, &no_model, 1, &none, &failed, err, sizeof err), OBJECT_EDIT_BAD_EDIT);
    assert_null(none);

    /* Remove, then add again under the same name in one list. */
    object_edit swap[] = {
        {OBJECT_EDIT_REMOVE, "far", NULL, {{0}, {0, 0, 0}}, 0},
        {OBJECT_EDIT_ADD, "far", cube, at(4, 0, 0, 1, 0, 0, 0), 0},
    };
    object_set *v3 = apply_ok(v2, swap, 2);
    assert_true(closest_t(v3, &ray, &name) == 4.0);
    object_edit gone = {OBJECT_EDIT_REMOVE, "far", NULL, {{0}, {0, 0, 0}}, 0};
    object_set *v4 = apply_ok(v3, &gone, 1);
    assert_true(closest_t(v4, &ray, &name) == INFINITY);
    assert_int_equal(object_set_find(v4, "far"), -1);

    object_set *all[] = {v0, v1, v2, v3, v4};
    for (int i = 0; i < 5; i++)
        object_set_release(all[i]);
    object_model_release(cube);
}

/* Objects of one mesh hold one model; the model lives while any version uses it. */
static void test_instances_share_one_model(void **state)
{
    (void)state;
    object_model *cube = model_of("cube.obj", meshgen_box((box3){{0, 0, 0}, {1, 1, 1}}));
    object_set *v0 = object_set_create();
    object_edit add[] = {
        {OBJECT_EDIT_ADD, "one", cube, at(0, 0, 0, 1, 0, 0, 0), 0},
        {OBJECT_EDIT_ADD, "two", cube, at(3, 0, 0, 1, 0, 0, 0), 0},
        {OBJECT_EDIT_ADD, "three", cube, at(6, 0, 0, 1, 0, 0, 0), 0},
    };
    object_set *v1 = apply_ok(v0, add, 3);
    assert_int_equal(atomic_load(&cube->refs), 4);
    object_edit move = {OBJECT_EDIT_MOVE, "two", NULL, at(3, 1, 0, 1, 0, 0, 0), 0};
    object_set *v2 = apply_ok(v1, &move, 1);
    assert_int_equal(atomic_load(&cube->refs), 7);
    assert_int_equal(v2->triangles, 36);
    object_set_release(v1);
    assert_int_equal(atomic_load(&cube->refs), 4);
    /* Each instance answers at its own place. */
    ray_input ray = {{3.5, 1.5, -1}, {0, 0, 1}, 0, INFINITY, RAY_CROSSING};
    const char *name;
    assert_true(closest_t(v2, &ray, &name) == 1.0);
    assert_string_equal(name, "two");
    object_set_release(v2);
    object_set_release(v0);
    assert_int_equal(atomic_load(&cube->refs), 1);
    object_model_release(cube);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rays_answer_as_the_union_tree),
        cmocka_unit_test(test_versions_and_edits),
        cmocka_unit_test(test_instances_share_one_model),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
