/* Robot state checks (server/world/object_state.h): a state's contacts are exactly those
 * of each link's posed mesh against each object's posed mesh and, with self-collision,
 * each other link's, as octree_mesh finds them against trees built from the posed
 * vertices, less the allowed pairs; yes/no reports one of them. */
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
#include "world/object_state.h"

static object_model *model_of(const char *key, mesh_data m)
{
    octree_def def = octree_default_def();
    def.triangle_boxes = 1; /* as a world serving meshes builds them */
    char err[256];
    object_model *model = object_model_create(key, &m, &def, err, sizeof err);
    if (!model)
        fail_msg("model %s: %s", key, err);
    return model;
}

static pose quat(double x, double y, double z, double qw, double qx, double qy, double qz)
{
    pose p;
    assert_int_equal(octree_pose_from_quaternion((vec3){x, y, z}, qw, qx, qy, qz, &p), OCTREE_OK);
    return p;
}

static pose random_pose(rng *r, box3 where)
{
    vec3 q = rng_unit_vector(r);
    double a = rng_uniform(r, 0, 6.283185307179586);
    return quat(rng_uniform(r, where.lo.x, where.hi.x), rng_uniform(r, where.lo.y, where.hi.y),
                rng_uniform(r, where.lo.z, where.hi.z), cos(a / 2), sin(a / 2) * q.x, sin(a / 2) * q.y,
                sin(a / 2) * q.z);
}

/* A link: its mesh, its shape tree, its bounds. */
typedef struct test_link {
    char name[16];
    mesh_data mesh;
    octree *tree;
} test_link;

static test_link link_of(const char *name, mesh_data m)
{
    test_link l = {{0}, m, NULL};
    snprintf(l.name, sizeof l.name, "%s", name);
    octree_def def = octree_default_def();
    def.node_bounds = 1;
    octree_error e;
    mesh_view v = mesh_data_view(&l.mesh);
    l.tree = octree_build(&v, &def, &e);
    assert_non_null(l.tree);
    return l;
}

static octree *posed_tree(const mesh_data *m, const pose *at)
{
    mesh_data w = {0};
    w.vertex_count = m->vertex_count;
    w.triangle_count = m->triangle_count;
    w.vertices = malloc(w.vertex_count * sizeof *w.vertices);
    w.indices = malloc(3 * w.triangle_count * sizeof *w.indices);
    for (size_t i = 0; i < m->vertex_count; i++)
        w.vertices[i] = octree_pose_point(at, m->vertices[i]);
    memcpy(w.indices, m->indices, 3 * w.triangle_count * sizeof *w.indices);
    mesh_view v = mesh_data_view(&w);
    octree_def def = octree_default_def();
    octree_error e;
    octree *t = octree_build(&v, &def, &e);
    assert_non_null(t);
    mesh_data_free(&w);
    return t;
}

#define MAX_CONTACTS 4096

/* The reference: every pair octree_mesh finds, in the check's order. */
static size_t reference_contacts(const object_set *s, const test_link *links, const pose *poses, size_t n,
                                 const state_allowed *allowed, size_t allowed_count, int self,
                                 state_contact *out)
{
    size_t count = 0;
    static mesh_pair pairs[MAX_CONTACTS];
    for (size_t i = 0; i < n; i++) {
        mesh_view lv = mesh_data_view(&links[i].mesh);
        for (size_t j = 0; j < s->count + (self ? n : 0); j++) {
            int with_link = j >= s->count;
            size_t other = with_link ? j - s->count : j;
            if (with_link && other <= i)
                continue;
            const char *other_name = with_link ? links[other].name : s->objects[other].name;
            int skip = 0;
            for (size_t a = 0; a < allowed_count; a++)
                skip |= (!strcmp(allowed[a].a, links[i].name) && !strcmp(allowed[a].b, other_name)) ||
                        (!strcmp(allowed[a].b, links[i].name) && !strcmp(allowed[a].a, other_name));
            if (skip)
                continue;
            octree *t = with_link ? posed_tree(&links[other].mesh, &poses[other])
                                  : posed_tree(&s->objects[other].model->mesh, &s->objects[other].at);
            mesh_output mo = {.pairs = pairs, .capacity = MAX_CONTACTS};
            assert_int_equal(octree_mesh(t, &lv, &poses[i], 1, ACCURACY_EXACT, &mo, NULL), OCTREE_OK);
            assert_false(mo.truncated);
            for (size_t k = 0; k < mo.count; k++) {
                assert_true(count < MAX_CONTACTS);
                out[count++] = (state_contact){(uint32_t)i, with_link, (uint32_t)other, pairs[k].query_triangle,
                                               pairs[k].world_triangle};
            }
            octree_free(t);
        }
    }
    return count;
}

static int same_contact(const state_contact *a, const state_contact *b)
{
    return a->link == b->link && a->with_link == b->with_link && a->other == b->other &&
           a->link_triangle == b->link_triangle && a->other_triangle == b->other_triangle;
}

static void check_state(const object_set *s, const test_link *links, const pose *poses, size_t n,
                        const state_allowed *allowed, size_t allowed_count, int self, state_scratch *scratch,
                        size_t *invalid)
{
    state_link sl[8];
    for (size_t i = 0; i < n; i++)
        sl[i] = (state_link){links[i].name, links[i].tree, mesh_data_bounds(&links[i].mesh), poses[i]};
    static state_contact got[MAX_CONTACTS], want[MAX_CONTACTS];
    size_t expected = reference_contacts(s, links, poses, n, allowed, allowed_count, self, want);
    state_output all = {.contacts = got, .capacity = MAX_CONTACTS};
    assert_int_equal(object_set_state(s, sl, n, allowed, allowed_count, self, 1, &all, scratch, NULL), OCTREE_OK);
    assert_int_equal(all.valid, expected == 0);
    assert_int_equal(all.count, expected);
    assert_false(all.truncated);
    for (size_t k = 0; k < expected; k++)
        if (!same_contact(&got[k], &want[k]))
            fail_msg("contact %zu: link %u %s %u (%u, %u), expected link %u %s %u (%u, %u)", k, got[k].link,
                     got[k].with_link ? "link" : "object", got[k].other, got[k].link_triangle, got[k].other_triangle,
                     want[k].link, want[k].with_link ? "link" : "object", want[k].other, want[k].link_triangle,
                     want[k].other_triangle);
    state_contact one;
    state_output first = {.contacts = &one, .capacity = 1};
    assert_int_equal(object_set_state(s, sl, n, allowed, allowed_count, self, 0, &first, scratch, NULL), OCTREE_OK);
    assert_int_equal(first.valid, expected == 0);
    if (expected) {
        /* Yes/no names one real contact, whichever the descent met first. */
        assert_int_equal(first.count, 1);
        int found = 0;
        for (size_t k = 0; k < expected; k++)
            found |= same_contact(&one, &want[k]);
        if (!found)
            fail_msg("yes/no names link %u %s %u (%u, %u), not among the %zu contacts (first: link %u %s %u (%u, %u))",
                     one.link, one.with_link ? "link" : "object", one.other, one.link_triangle, one.other_triangle,
                     expected, want[0].link, want[0].with_link ? "link" : "object", want[0].other,
                     want[0].link_triangle, want[0].other_triangle);
        (*invalid)++;
    }
}

/* A cluttered table top and a three-link arm at random states over it. */
static void test_states_equal_the_posed_meshes(void **state)
{
    (void)state;
    object_model *slab = model_of("slab.obj", meshgen_box((box3){{-1, -1, -0.05}, {1, 1, 0.05}}));
    object_model *ball = model_of("ball.obj", meshgen_icosphere((vec3){0, 0, 0}, 0.2, 2));
    object_model *ring = model_of("ring.obj", meshgen_torus((vec3){0, 0, 0}, 0.25, 0.06, 16, 8));
    object_set *empty = object_set_create();
    object_edit edits[] = {
        {OBJECT_EDIT_ADD, "table", slab, quat(0, 0, 0, 1, 0, 0, 0), 0},
        {OBJECT_EDIT_ADD, "ball-1", ball, quat(0.4, 0.3, 0.25, 1, 0, 0, 0), 0},
        {OBJECT_EDIT_ADD, "ball-2", ball, quat(-0.5, 0.2, 0.25, 0.8, 0.6, 0, 0), 0},
        {OBJECT_EDIT_ADD, "ring", ring, quat(0.1, -0.5, 0.12, 0.8, 0, 0.6, 0), 0},
        {OBJECT_EDIT_ADD, "shelf", slab, quat(0, 0.9, 0.6, 0.7071067811865476, 0.7071067811865476, 0, 0), 0},
    };
    char err[256];
    size_t failed;
    object_set *s;
    assert_int_equal(object_set_apply(empty, edits, 5, &s, &failed, err, sizeof err), OBJECT_EDIT_OK);
    test_link links[3] = {
        link_of("upper", meshgen_box((box3){{-0.05, -0.05, 0}, {0.05, 0.05, 0.4}})),
        link_of("fore", meshgen_torus((vec3){0, 0, 0}, 0.1, 0.03, 12, 6)),
        link_of("hand", meshgen_icosphere((vec3){0, 0, 0}, 0.08, 1)),
    };
    rng r = rng_seeded(20261202);
    box3 over_table = {{-0.8, -0.8, 0.0}, {0.8, 0.8, 0.6}};
    size_t invalid = 0;
    state_allowed allowed[] = {{"upper", "table"}, {"fore", "hand"}};
    /* One scratch for every state, as a worker keeps one: what it keeps from a state
     * (each link's caches, against objects and links alike) must not leak into the next;
     * every eighth state makes its own instead. */
    state_scratch *scratch = state_scratch_new();
    assert_non_null(scratch);
    for (int k = 0; k < 80; k++) {
        pose poses[3] = {random_pose(&r, over_table), random_pose(&r, over_table), random_pose(&r, over_table)};
        int self = k % 2;
        state_scratch *use = k % 8 == 7 ? NULL : scratch;
        check_state(s, links, poses, 3, NULL, 0, self, use, &invalid);
        check_state(s, links, poses, 3, allowed, 2, self, use, &invalid);
    }
    state_scratch_free(scratch);
    /* Both valid and colliding states were checked. */
    assert_true(invalid > 10 && invalid < 150);

    /* Allowed pairs: the upper link lying on the table touches it and nothing else. */
    pose lying = quat(0.7, -0.3, 0.05, 0.7071067811865476, 0.7071067811865476, 0, 0);
    state_link one = {"upper", links[0].tree, mesh_data_bounds(&links[0].mesh), lying};
    state_output out = {.contacts = NULL, .capacity = 0};
    assert_int_equal(object_set_state(s, &one, 1, NULL, 0, 0, 0, &out, NULL, NULL), OCTREE_OK);
    assert_int_equal(out.valid, 0);
    assert_int_equal(out.truncated, 1); /* a contact with nowhere to put it */
    state_allowed table_ok = {"table", "upper"}; /* either way round */
    assert_int_equal(object_set_state(s, &one, 1, &table_ok, 1, 0, 0, &out, NULL, NULL), OCTREE_OK);
    assert_int_equal(out.valid, 1);

    /* Two links through each other, away from every object: valid unless self-collision
     * is asked, and then valid again when their pair is allowed. */
    state_link pair[2] = {
        {"fore", links[1].tree, mesh_data_bounds(&links[1].mesh), quat(0, 0, 3, 1, 0, 0, 0)},
        {"hand", links[2].tree, mesh_data_bounds(&links[2].mesh), quat(0.1, 0, 3, 1, 0, 0, 0)},
    };
    state_contact c;
    out = (state_output){.contacts = &c, .capacity = 1};
    assert_int_equal(object_set_state(s, pair, 2, NULL, 0, 0, 0, &out, NULL, NULL), OCTREE_OK);
    assert_int_equal(out.valid, 1);
    assert_int_equal(object_set_state(s, pair, 2, NULL, 0, 1, 0, &out, NULL, NULL), OCTREE_OK);
    assert_int_equal(out.valid, 0);
    assert_int_equal(c.with_link, 1);
    assert_int_equal(c.link, 0);
    assert_int_equal(c.other, 1);
    assert_int_equal(object_set_state(s, pair, 2, &allowed[1], 1, 1, 0, &out, NULL, NULL), OCTREE_OK);
    assert_int_equal(out.valid, 1);

    /* Refused: a pose that is not a rotation, a link without a tree. */
    state_link scaled = one;
    scaled.at.r[0] = 2;
    assert_int_equal(object_set_state(s, &scaled, 1, NULL, 0, 0, 0, &out, NULL, NULL), OCTREE_ERR_INVALID);
    state_link treeless = one;
    treeless.tree = NULL;
    assert_int_equal(object_set_state(s, &treeless, 1, NULL, 0, 0, 0, &out, NULL, NULL), OCTREE_ERR_INVALID);

    for (int i = 0; i < 3; i++) {
        octree_free(links[i].tree);
        mesh_data_free(&links[i].mesh);
    }
    object_set_release(s);
    object_set_release(empty);
    object_model_release(slab);
    object_model_release(ball);
    object_model_release(ring);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_states_equal_the_posed_meshes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
