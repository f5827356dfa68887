/* Robot state checks, trioct against FCL set up as MoveIt sets it up: a seven-link arm
 * (about 9,000 triangles) at random joint states over a table cluttered with 50 objects
 * (shared models, about 40,000 triangles placed), the base link allowed to touch the
 * table. trioct: one object_set_state call a state (yes/no, world collisions). FCL: each
 * link's transform and AABB updated, then the objects' DynamicAABBTree broadphase asked
 * for the link, one fcl::collide with one contact per candidate pair, stopping at the
 * first contact. One core; each figure the median over alternating rounds (the same
 * states on both sides, each side first in turn) of trioct's rate over FCL's, with its
 * range, beside the target. Prints figures; asserts nothing about time. Only this
 * benchmark and bench_peers link FCL. */
#define _GNU_SOURCE
#include <math.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "engine.h"
#include "fcl_peer.h"
#include "support/meshgen.h"
#include "world/object_state.h"

#ifndef STATES_COUNT
#define STATES_COUNT 20000
#endif
enum {
    ROUNDS = 5,
    STATES = STATES_COUNT,
    OBJECTS = 50,
    LINKS = 7,
};
#define LINK_LENGTH 0.16
#define TARGET 1.0

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void pin_to_one_cpu(void)
{
    cpu_set_t set;
    CPU_ZERO(&set);
    if (sched_getaffinity(0, sizeof set, &set) != 0)
        return;
    for (int c = 0; c < CPU_SETSIZE; c++)
        if (CPU_ISSET(c, &set)) {
            CPU_ZERO(&set);
            CPU_SET(c, &set);
            sched_setaffinity(0, sizeof set, &set);
            return;
        }
}

static pose quat_pose(vec3 t, double w, double x, double y, double z)
{
    pose p;
    if (octree_pose_from_quaternion(t, w, x, y, z, &p) != OCTREE_OK) {
        fprintf(stderr, "bench_states: bad quaternion\n");
        exit(1);
    }
    return p;
}

static pose random_rotation(rng *r, vec3 t, double max_angle)
{
    vec3 axis = rng_unit_vector(r);
    double a = rng_uniform(r, -max_angle, max_angle);
    return quat_pose(t, cos(a / 2), sin(a / 2) * axis.x, sin(a / 2) * axis.y, sin(a / 2) * axis.z);
}

/* a * b: the rotation products and a's rotation of b's translation. */
static pose compose(const pose *a, const pose *b)
{
    pose c;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            c.r[3 * i + j] = a->r[3 * i] * b->r[j] + a->r[3 * i + 1] * b->r[3 + j] + a->r[3 * i + 2] * b->r[6 + j];
    const double *m = a->r;
    vec3 v = b->t;
    c.t = (vec3){m[0] * v.x + m[1] * v.y + m[2] * v.z + a->t.x, m[3] * v.x + m[4] * v.y + m[5] * v.z + a->t.y,
                 m[6] * v.x + m[7] * v.y + m[8] * v.z + a->t.z};
    return c;
}

static mesh_data scaled(mesh_data m, vec3 s, vec3 offset)
{
    for (size_t i = 0; i < m.vertex_count; i++)
        m.vertices[i] = (vec3){m.vertices[i].x * s.x + offset.x, m.vertices[i].y * s.y + offset.y,
                               m.vertices[i].z * s.z + offset.z};
    return m;
}

static fcl_peer_model *fcl_of(const mesh_data *m)
{
    fcl_peer_model *f = fcl_peer_model_new(&m->vertices[0].x, m->vertex_count, m->indices, m->triangle_count);
    if (!f)
        exit(1);
    return f;
}

static int by_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

typedef struct bench_case {
    const object_set *world;
    fcl_peer_scene *scene;
    const octree *link_tree;
    box3 link_bounds;
    fcl_peer_model **link_fcl;
    char (*link_names)[8];
    const pose *states;
    const state_allowed *allowed; /* [0] link0-table, then the neighbouring links */
    state_scratch *scratch;
} bench_case;

/* One figure: every state checked by both sides in alternating rounds, world collisions
 * only or with self-collision too; 1 when the two agree on every state. */
static int run_case(const bench_case *c, int self)
{
    static int t_valid[STATES], f_valid[STATES];
    double t_time[ROUNDS], f_time[ROUNDS], ratio[ROUNDS];
    query_stats st = {0};
    size_t allowed_count = self ? LINKS : 1;
    for (int round = 0; round < ROUNDS; round++) {
        for (int side = 0; side < 2; side++) {
            double t0 = now();
            if ((side == 0) == (round % 2 == 0)) {
                for (int s = 0; s < STATES; s++) {
                    state_link links[LINKS];
                    for (int k = 0; k < LINKS; k++)
                        links[k] = (state_link){c->link_names[k], c->link_tree, c->link_bounds, c->states[s * LINKS + k]};
                    state_contact one;
                    state_output out = {.contacts = &one, .capacity = 1};
                    if (object_set_state(c->world, links, LINKS, c->allowed, allowed_count, self, 0, &out, c->scratch,
                                         round == 0 ? &st : NULL) != OCTREE_OK) {
                        fprintf(stderr, "bench_states: a state check failed\n");
                        exit(1);
                    }
                    t_valid[s] = out.valid;
                }
                t_time[round] = now() - t0;
            } else {
                for (int s = 0; s < STATES; s++) {
                    int hit = 0;
                    for (int k = 0; k < LINKS && !hit; k++) {
                        const pose *p = &c->states[s * LINKS + k];
                        double t[3] = {p->t.x, p->t.y, p->t.z};
                        hit = fcl_peer_scene_collide(c->scene, c->link_fcl[k], p->r, t, k == 0 ? 0 : -1);
                    }
                    /* Self-collision once the world is clear (every link has moved): the
                     * pairs that are not neighbours. */
                    for (int i = 0; self && i < LINKS && !hit; i++)
                        for (int j = i + 2; j < LINKS && !hit; j++)
                            hit = fcl_peer_links_collide(c->link_fcl[i], c->link_fcl[j]);
                    f_valid[s] = !hit;
                }
                f_time[round] = now() - t0;
            }
        }
        ratio[round] = f_time[round] / t_time[round];
    }
    size_t agree = 0, colliding = 0;
    for (int s = 0; s < STATES; s++) {
        agree += t_valid[s] == f_valid[s];
        colliding += !t_valid[s];
    }
    double sorted[ROUNDS], ts[ROUNDS], fs[ROUNDS];
    memcpy(sorted, ratio, sizeof sorted);
    memcpy(ts, t_time, sizeof ts);
    memcpy(fs, f_time, sizeof fs);
    qsort(sorted, ROUNDS, sizeof *sorted, by_double);
    qsort(ts, ROUNDS, sizeof *ts, by_double);
    qsort(fs, ROUNDS, sizeof *fs, by_double);
    double med = sorted[ROUNDS / 2];
    printf("%-44s %8.1fk %8.1fk %7.2fx %5.2f-%-6.2f >=%4.1f %5s  colliding %.2f%%, agree %.2f%%; per state %.0f "
           "node pairs, %.0f leaf pairs, %.0f triangle pairs\n",
           self ? "state checks a second (yes/no, world + self)" : "state checks a second (yes/no, world)",
           STATES / ts[ROUNDS / 2] / 1e3, STATES / fs[ROUNDS / 2] / 1e3, med, sorted[0], sorted[ROUNDS - 1], TARGET,
           med >= TARGET ? "yes" : "no", 100.0 * (double)colliding / STATES, 100.0 * (double)agree / STATES,
           (double)st.nodes_visited / STATES, (double)st.leaves_visited / STATES, (double)st.candidates_tested / STATES);
    return agree == STATES;
}

int main(void)
{
    pin_to_one_cpu();
    rng r = rng_seeded(20261202);
    /* The world's models: a table, balls, rings, crates. */
    mesh_data crate = meshgen_box((box3){{-0.05, -0.04, -0.03}, {0.05, 0.04, 0.03}});
    mesh_data meshes[4] = {
        meshgen_box((box3){{-1, -1, -0.05}, {1, 1, 0}}),
        meshgen_icosphere((vec3){0, 0, 0}, 0.06, 3),
        meshgen_torus((vec3){0, 0, 0}, 0.07, 0.02, 32, 16),
        meshgen_subdivide(&crate, 3),
    };
    mesh_data_free(&crate);
    const char *keys[4] = {"table", "ball", "ring", "crate"};
    object_model *models[4];
    fcl_peer_model *fcl_models[4];
    octree_def def = octree_default_def();
    def.triangle_boxes = 1;
    for (int k = 0; k < 4; k++) {
        fcl_models[k] = fcl_of(&meshes[k]);
        mesh_data copy = {0};
        mesh_data_append(&copy, &meshes[k]);
        char err[256];
        models[k] = object_model_create(keys[k], &copy, &def, err, sizeof err);
        if (!models[k]) {
            fprintf(stderr, "bench_states: %s\n", err);
            return 1;
        }
    }
    object_edit edits[OBJECTS];
    char names[OBJECTS][16];
    fcl_peer_scene *scene = fcl_peer_scene_new();
    size_t placed = 0;
    for (int i = 0; i < OBJECTS; i++) {
        int m = i == 0 ? 0 : 1 + i % 3;
        pose at = i == 0 ? quat_pose((vec3){0, 0, 0}, 1, 0, 0, 0)
                         : random_rotation(&r,
                                           (vec3){rng_uniform(&r, -0.95, 0.95), rng_uniform(&r, -0.95, 0.95),
                                                  rng_uniform(&r, 0.05, 0.7)},
                                           3.14159);
        snprintf(names[i], sizeof names[i], "%s-%02d", keys[m], i);
        edits[i] = (object_edit){OBJECT_EDIT_ADD, names[i], models[m], at};
        double t[3] = {at.t.x, at.t.y, at.t.z};
        fcl_peer_scene_add(scene, fcl_models[m], at.r, t);
        placed += meshes[m].triangle_count;
    }
    fcl_peer_scene_setup(scene);
    object_set *empty = object_set_create(), *world;
    char err[256];
    size_t failed;
    if (object_set_apply(empty, edits, OBJECTS, &world, &failed, err, sizeof err) != OBJECT_EDIT_OK) {
        fprintf(stderr, "bench_states: %s\n", err);
        return 1;
    }
    /* The arm: seven elongated links, each along its own z from its origin. */
    mesh_data link_mesh = scaled(meshgen_icosphere((vec3){0, 0, 0}, 1.0, 3), (vec3){0.03, 0.03, LINK_LENGTH / 2},
                                 (vec3){0, 0, LINK_LENGTH / 2});
    octree_def ldef = octree_default_def();
    ldef.node_bounds = 1;
    mesh_view lv = mesh_data_view(&link_mesh);
    octree_error e;
    octree *link_tree = octree_build(&lv, &ldef, &e);
    fcl_peer_model *link_fcl[LINKS];
    for (int k = 0; k < LINKS; k++)
        link_fcl[k] = fcl_of(&link_mesh);
    char link_names[LINKS][8];
    for (int k = 0; k < LINKS; k++)
        snprintf(link_names[k], sizeof link_names[k], "link%d", k);
    /* States: the base on the table, each joint a random rotation of up to 100 degrees. */
    pose *states = malloc((size_t)STATES * LINKS * sizeof *states);
    for (int s = 0; s < STATES; s++) {
        pose at = random_rotation(&r, (vec3){rng_uniform(&r, -0.3, 0.3), rng_uniform(&r, -0.3, 0.3), 0.0}, 0.3);
        for (int k = 0; k < LINKS; k++) {
            states[s * LINKS + k] = at;
            pose joint = random_rotation(&r, (vec3){0, 0, LINK_LENGTH}, 1.75);
            at = compose(&at, &joint);
        }
    }
    /* The base may touch the table; with self-collision, each link its neighbours (the
     * joints), as a robot's allowed-collision matrix says. */
    state_allowed allowed[1 + LINKS - 1];
    allowed[0] = (state_allowed){"link0", names[0]};
    for (int k = 0; k + 1 < LINKS; k++)
        allowed[1 + k] = (state_allowed){link_names[k], link_names[k + 1]};
    state_scratch *scratch = state_scratch_new(); /* as a daemon's worker keeps one */
    bench_case c = {world, scene, link_tree, mesh_data_bounds(&link_mesh), link_fcl, link_names, states, allowed,
                    scratch};
    printf("# states: %d links (%zu triangles each), %d objects (%zu triangles placed, 4 shared models), %d states, "
           "%d alternating rounds, one core\n",
           LINKS, link_mesh.triangle_count, OBJECTS, placed, STATES, ROUNDS);
    printf("%-44s %10s %10s %8s %12s %8s %5s  %s\n", "measure", "trioct", "FCL", "ratio", "range", "target", "met",
           "notes");
    int agreed = run_case(&c, 0) & run_case(&c, 1);
    for (int k = 0; k < LINKS; k++)
        fcl_peer_model_free(link_fcl[k]);
    fcl_peer_scene_free(scene);
    state_scratch_free(scratch);
    for (int k = 0; k < 4; k++) {
        fcl_peer_model_free(fcl_models[k]);
        object_model_release(models[k]);
        mesh_data_free(&meshes[k]);
    }
    object_set_release(world);
    object_set_release(empty);
    octree_free(link_tree);
    mesh_data_free(&link_mesh);
    free(states);
    return agreed ? 0 : 2;
}
