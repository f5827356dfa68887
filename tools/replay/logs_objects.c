/* The objects log: the world `shop` (the terrain as `floor`, the crates twice: `crate_a`
 * half a unit up, `crate_b` a quarter turn about z and four up) edited between queries.
 * Rays from above, a triangle batch and the probe at poses are asked before and after a
 * move, adds (a third copy of the crates' file, which shares their tree, and an inline
 * box), and a remove; then every edit error, an edit list whose second edit fails (the
 * listing after it shows the first did not apply either), and a seed-mode query of the
 * moved world, which is refused. The ordered daemon answers in log order, so each query
 * sees exactly the edits before it. */
#include <math.h>
#include <string.h>

#include "logs_cases.h"
#include "logs_requests.h"
#include "logs_shapes.h"
#include "logs_world.h"

enum { OBJECTS_CLIENT = 0x80 };

#define WORLD_ACC TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD

static trioct_pose_t pose_of(double angle_z, double x, double y, double z)
{
    double c = cos(angle_z), s = sin(angle_z);
    return (trioct_pose_t){{c, -s, 0, s, c, 0, 0, 0, 1}, {x, y, z}};
}

static trioct_object_edit_t edit(int8_t op, const char *name, const char *mesh, trioct_pose_t at)
{
    return (trioct_object_edit_t){op, (char *)name, (char *)(mesh ? mesh : ""), at, TRIOCT_OBJECT_EDIT_T_MATRIX, {0},
                                  0, NULL};
}

/* The queries asked after each edit: the same rays, triangles and poses every time. */
typedef struct probe_set {
    trioct_vec3_t o[24], d[24];
    trioct_triangle_t tris[12];
    trioct_pose_t poses[12];
} probe_set;

static void ask(logs_writer *w, lr_req *q, const probe_set *p)
{
    q->id++;
    lr_rays_contact(w, q, TRIOCT_RAY_REQUEST_T_CLOSEST, WORLD_ACC, TRIOCT_RAY_REQUEST_T_CROSSING, 0, INFINITY, 1, 24,
                    p->o, p->d);
    q->id++;
    lr_rays_contact(w, q, TRIOCT_RAY_REQUEST_T_ALL, WORLD_ACC, TRIOCT_RAY_REQUEST_T_CROSSING, 0, INFINITY, 8, 24,
                    p->o, p->d);
    q->id++;
    lr_triangles(w, q, TRIOCT_TRIANGLE_REQUEST_T_SEGMENTS, WORLD_ACC, 12, p->tris);
    q->id++;
    lr_mesh(w, q, TRIOCT_MESH_REQUEST_T_PAIRS, WORLD_ACC, "probe", 0, NULL, 12, p->poses);
}

int logs_write_objects(const char *dir)
{
    logs_writer w;
    lw_init(&w);
    rng r = rng_seeded(LOGS_SEED + 12);
    probe_set p;
    ls_rays_from_above(&r, 24, p.o, p.d);
    ls_triangles_at_ground(&r, 12, 1.5, p.tris);
    ls_poses(&r, 12, ls_vec(-6, -6, 0), ls_vec(6, 6, 6), p.poses);
    lr_req q = {OBJECTS_CLIENT, 0, "REPLAY_OBJECTS", "shop", NULL, 0};

    q.id++;
    lr_objects(&w, &q, 1, 0, NULL); /* the scene's objects */
    ask(&w, &q, &p);

    /* A move: crate_b turned back and set on the floor beside crate_a. */
    trioct_object_edit_t move = edit(TRIOCT_OBJECT_EDIT_T_MOVE, "crate_b", NULL, pose_of(0, 1, 1, 0.25));
    q.id++;
    lr_objects(&w, &q, 0, 1, &move);
    ask(&w, &q, &p);

    /* Adds in one list: a third copy of the crates (its tree shared), and an inline box. */
    trioct_triangle_t box[12];
    const double h = 0.75;
    const trioct_vec3_t c[8] = {{-h, -h, -h}, {h, -h, -h}, {h, h, -h}, {-h, h, -h},
                                {-h, -h, h},  {h, -h, h},  {h, h, h},  {-h, h, h}};
    static const int faces[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                                     {1, 2, 6}, {1, 6, 5}, {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};
    for (int f = 0; f < 12; f++)
        box[f] = (trioct_triangle_t){c[faces[f][0]], c[faces[f][1]], c[faces[f][2]]};
    trioct_object_edit_t adds[2] = {edit(TRIOCT_OBJECT_EDIT_T_ADD, "crate_c", "crates.obj", (trioct_pose_t){{-1, 0, 0, 0, -1, 0, 0, 0, 1}, {0, 0, 2.5}}),
                                    edit(TRIOCT_OBJECT_EDIT_T_ADD, "box.1", NULL, pose_of(0.3, -1, 2, 3))};
    adds[1].num_triangles = 12;
    adds[1].triangles = box;
    q.id++;
    lr_objects(&w, &q, 1, 2, adds);
    ask(&w, &q, &p);

    /* A remove. */
    trioct_object_edit_t removal = edit(TRIOCT_OBJECT_EDIT_T_REMOVE, "crate_a", NULL, pose_of(0, 0, 0, 0));
    q.id++;
    lr_objects(&w, &q, 0, 1, &removal);
    ask(&w, &q, &p);

    /* Every edit error, each naming its edit; the world stays as it was. */
    trioct_object_edit_t bad[8] = {
        edit(TRIOCT_OBJECT_EDIT_T_MOVE, "crate_a", NULL, pose_of(0, 0, 0, 0)),  /* removed: UNKNOWN_OBJECT */
        edit(TRIOCT_OBJECT_EDIT_T_ADD, "crate_b", "crates.obj", pose_of(0, 0, 0, 0)), /* OBJECT_EXISTS */
        edit(TRIOCT_OBJECT_EDIT_T_MOVE, "crate_b", NULL, pose_of(0, 0, 0, 0)),   /* scaled below: BAD_POSE */
        edit(TRIOCT_OBJECT_EDIT_T_ADD, "far", "../scene.ini", pose_of(0, 0, 0, 0)), /* BAD_PATH */
        edit(TRIOCT_OBJECT_EDIT_T_ADD, "junk", "garbage.obj", pose_of(0, 0, 0, 0)), /* LOAD_FAILED */
        edit(TRIOCT_OBJECT_EDIT_T_ADD, "bad name", "crates.obj", pose_of(0, 0, 0, 0)), /* BAD_REQUEST */
        edit(TRIOCT_OBJECT_EDIT_T_MOVE, "crate_b", NULL, pose_of(0, 0, 0, 0)),   /* a NaN below: NONFINITE */
        edit(5, "crate_b", NULL, pose_of(0, 0, 0, 0)),                          /* no such op */
    };
    bad[2].pose.r[0] = 2;
    bad[6].pose.r[4] = NAN;
    for (int i = 0; i < 8; i++) {
        q.id++;
        lr_objects(&w, &q, 0, 1, &bad[i]);
    }
    /* All or none: the first edit applies alone, the second fails, so neither does. */
    trioct_object_edit_t half[2] = {edit(TRIOCT_OBJECT_EDIT_T_MOVE, "crate_b", NULL, pose_of(1, 5, 5, 5)),
                                    edit(TRIOCT_OBJECT_EDIT_T_REMOVE, "nothing", NULL, pose_of(0, 0, 0, 0))};
    q.id++;
    lr_objects(&w, &q, 0, 2, half);
    q.id++;
    lr_objects(&w, &q, 1, 0, NULL);
    ask(&w, &q, &p);

    /* A world of moved objects is answered exactly only; a fast world takes no edits. */
    q.id++;
    lr_rays_contact(&w, &q, TRIOCT_RAY_REQUEST_T_CLOSEST, TRIOCT_RAY_REQUEST_T_SEED, TRIOCT_RAY_REQUEST_T_CROSSING, 0,
                    INFINITY, 1, 4, p.o, p.d);
    lr_req spare = {OBJECTS_CLIENT, 0, "REPLAY_OBJECTS", "spare", NULL, 0};
    spare.id = ++q.id;
    lr_objects(&w, &spare, 0, 1, &move);
    /* A plain section is one object named after its world: it can be moved like any. */
    lr_req yard = {OBJECTS_CLIENT, 0, "REPLAY_OBJECTS", "yard", NULL, 0};
    trioct_object_edit_t lift = edit(TRIOCT_OBJECT_EDIT_T_MOVE, "yard", NULL, pose_of(0, 0, 0, 1));
    yard.id = ++q.id;
    lr_objects(&w, &yard, 1, 1, &lift);
    yard.id = ++q.id;
    lr_rays_contact(&w, &yard, TRIOCT_RAY_REQUEST_T_CLOSEST, WORLD_ACC, TRIOCT_RAY_REQUEST_T_CROSSING, 0, INFINITY, 1,
                    24, p.o, p.d);

    /* Robot states against the shop as it now stands: a hand (the probe) and a finger (an
     * inline box) at twelve states near the crates, first each state's verdict, then every
     * contact, then with the floor allowed for the hand, the finger allowed on crate_b and
     * the two checked against each other (contact is surface contact: the finger is set
 * through the hand's side, not inside it). */
    trioct_triangle_t finger[12];
    const double fh = 0.2;
    const trioct_vec3_t fc[8] = {{-fh, -fh, -fh}, {fh, -fh, -fh}, {fh, fh, -fh}, {-fh, fh, -fh},
                                 {-fh, -fh, fh},  {fh, -fh, fh},  {fh, fh, fh},  {-fh, fh, fh}};
    for (int f = 0; f < 12; f++)
        finger[f] = (trioct_triangle_t){fc[faces[f][0]], fc[faces[f][1]], fc[faces[f][2]]};
    const trioct_state_link_t links[2] = {{"hand", "probe", 0, NULL}, {"finger", "", 12, finger}};
    enum { STATES = 12 };
    trioct_pose_t at[2 * STATES];
    ls_poses(&r, 2 * STATES, ls_vec(-6, -6, 0), ls_vec(6, 6, 3), at);
    for (int s = 0; s < STATES; s += 3) { /* every third state: the finger through the hand's side */
        at[2 * s + 1] = at[2 * s];
        at[2 * s + 1].t.x += 0.25;
    }
    lr_req st = {OBJECTS_CLIENT, 0, "REPLAY_OBJECTS", "shop", NULL, 0};
    st.id = ++q.id;
    lr_state(&w, &st, TRIOCT_STATE_REQUEST_T_VALID, 0, 2, links, 0, NULL, NULL, 2 * STATES, at);
    st.id = ++q.id;
    lr_state(&w, &st, TRIOCT_STATE_REQUEST_T_CONTACTS, 0, 2, links, 0, NULL, NULL, 2 * STATES, at);
    char *allow_a[2] = {"hand", "crate_b"}, *allow_b[2] = {"floor", "finger"};
    st.id = ++q.id;
    lr_state(&w, &st, TRIOCT_STATE_REQUEST_T_CONTACTS, 1, 2, links, 2, allow_a, allow_b, 2 * STATES, at);
    /* Refused: a shape the world does not register, a pose that is not a rotation, a world
     * that does not serve meshes. */
    const trioct_state_link_t ghost[1] = {{"hand", "nothing", 0, NULL}};
    st.id = ++q.id;
    lr_state(&w, &st, TRIOCT_STATE_REQUEST_T_VALID, 0, 1, ghost, 0, NULL, NULL, 1, at);
    trioct_pose_t skew[2] = {at[0], at[1]};
    skew[1].r[1] += 0.1;
    st.id = ++q.id;
    lr_state(&w, &st, TRIOCT_STATE_REQUEST_T_VALID, 0, 2, links, 0, NULL, NULL, 2, skew);
    lr_req rays_only = {OBJECTS_CLIENT, ++q.id, "REPLAY_OBJECTS", "spare", NULL, 0};
    lr_state(&w, &rays_only, TRIOCT_STATE_REQUEST_T_VALID, 0, 2, links, 0, NULL, NULL, 2, at);

    /* Rotations sent as quaternions: a move (listed, to show the matrix the daemon made),
     * one of length 2 (refused), and states whose links are turned by quaternions. */
    trioct_object_edit_t turn = edit(TRIOCT_OBJECT_EDIT_T_MOVE, "crate_b", NULL, pose_of(0, 1, 1, 0.25));
    turn.rotation = TRIOCT_OBJECT_EDIT_T_QUATERNION;
    const double quarter_z[4] = {0.7071067811865476, 0, 0, 0.7071067811865476};
    memcpy(turn.quaternion, quarter_z, sizeof quarter_z);
    q.id++;
    lr_objects(&w, &q, 1, 1, &turn);
    turn.quaternion[0] = 2 * quarter_z[0];
    turn.quaternion[3] = 2 * quarter_z[3];
    q.id++;
    lr_objects(&w, &q, 0, 1, &turn);
    double qs[4 * 4];
    for (int k = 0; k < 4; k++) {
        double a = 0.4 * k;
        const double qk[4] = {cos(a), sin(a) * 0.6, 0, sin(a) * 0.8};
        memcpy(&qs[4 * k], qk, sizeof qk);
    }
    st.id = ++q.id;
    lr_state_quaternions(&w, &st, TRIOCT_STATE_REQUEST_T_CONTACTS, 1, 2, links, 4, at, qs);
    q.id++;
    lr_rays_contact(&w, &q, TRIOCT_RAY_REQUEST_T_CLOSEST, WORLD_ACC, TRIOCT_RAY_REQUEST_T_CROSSING, 0, INFINITY, 1, 24,
                    p.o, p.d);
    return lw_save(&w, dir, "objects");
}
