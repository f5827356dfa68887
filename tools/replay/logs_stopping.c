/* The log of a daemon that stops in the middle (stopping). A log cannot carry SIGTERM, so
 * it carries the ordered daemon's stop mark (<prefix>_STOP_<name>) instead: what was read
 * before the mark is answered as usual, every request read after it gets STOPPING, whatever
 * its type and whatever else would be wrong with it, and the daemon reads on to the end of
 * the log before it exits. */
#include <math.h>

#include "channels.h"
#include "logs_cases.h"
#include "logs_requests.h"
#include "logs_shapes.h"

#define WORLD_ACC TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD
#define CLOSEST TRIOCT_RAY_REQUEST_T_CLOSEST

static lr_req ask(int64_t id, const char *world)
{
    return (lr_req){0x5d, id, "REPLAY_STOPPING", world, NULL, 0};
}

/* The daemon at work: one of each query on yard, a LIST, and a LOAD, which ends the wake-up. */
static void before_the_mark(logs_writer *w, int n, const trioct_vec3_t *o, const trioct_vec3_t *d,
                            const trioct_triangle_t *t, const trioct_pose_t *p)
{
    lr_req q;
    lr_rays(w, (q = ask(1, "yard"), &q), CLOSEST, WORLD_ACC, 0, INFINITY, 1, n, o, d);
    lr_triangles(w, (q = ask(2, "yard"), &q), TRIOCT_TRIANGLE_REQUEST_T_IDS, WORLD_ACC, 2, t);
    lr_mesh(w, (q = ask(3, "yard"), &q), TRIOCT_MESH_REQUEST_T_PAIRS, WORLD_ACC, "probe", 0, NULL, 2, p);
    lr_admin(w, (q = ask(4, ""), &q), TRIOCT_ADMIN_REQUEST_T_LIST, NULL);
    lr_admin(w, (q = ask(5, "extra"), &q), TRIOCT_ADMIN_REQUEST_T_LOAD, "ball.obj");
}

/* Every type and op after the mark, in the wake-up the mark is read in. A deadline long
 * gone and an effect the world does not serve would be errors of their own: STOPPING is
 * said before any request is looked into. */
static void after_the_mark(logs_writer *w, int n, const trioct_vec3_t *o, const trioct_vec3_t *d,
                           const trioct_triangle_t *t, const trioct_pose_t *p)
{
    trioct_triangle_t tet[4];
    ls_tetrahedron(0.5, tet);
    lr_req q;
    lr_rays(w, (q = ask(8, "yard"), &q), TRIOCT_RAY_REQUEST_T_ANY, WORLD_ACC, 0, INFINITY, 1, n, o, d);
    lr_triangles(w, (q = ask(9, "yard"), &q), TRIOCT_TRIANGLE_REQUEST_T_SEGMENTS, WORLD_ACC, 2, t);
    lr_mesh(w, (q = ask(10, "yard"), &q), TRIOCT_MESH_REQUEST_T_YESNO, WORLD_ACC, NULL, 4, tet, 2, p);
    lr_admin(w, (q = ask(11, "yard"), &q), TRIOCT_ADMIN_REQUEST_T_INFO, NULL);
    lr_admin(w, (q = ask(12, ""), &q), TRIOCT_ADMIN_REQUEST_T_LIST, NULL);
    lr_admin(w, (q = ask(13, "more"), &q), TRIOCT_ADMIN_REQUEST_T_LOAD, "ball.obj");
    lr_admin(w, (q = ask(14, "cell"), &q), TRIOCT_ADMIN_REQUEST_T_UNLOAD, NULL);
    lr_rays(w, (q = ask(15, "extra"), &q), CLOSEST, WORLD_ACC, 0, INFINITY, 1, n, o, d);
    q = ask(16, "yard");
    q.deadline = 1;
    lr_rays(w, &q, CLOSEST, WORLD_ACC, 0, INFINITY, 1, n, o, d);
    lr_triangles(w, (q = ask(17, "yard_rays"), &q), TRIOCT_TRIANGLE_REQUEST_T_YESNO, WORLD_ACC, 2, t);
}

int logs_write_stopping(const char *dir)
{
    enum { N = 8 };
    logs_writer w;
    lw_init(&w);
    rng r = rng_seeded(LOGS_SEED + 9);
    trioct_vec3_t o[N], d[N];
    ls_rays_from_above(&r, N, o, d);
    trioct_triangle_t t[2];
    ls_triangles_at_ground(&r, 2, 0.5, t);
    trioct_pose_t p[2];
    ls_poses(&r, 2, ls_vec(-5, -5, 0), ls_vec(5, 5, 2), p);
    trioct_vec3_t bo[N], bd[N];
    ls_rays_through_ball(&r, N, bo, bd);
    lr_req q;

    before_the_mark(&w, N, o, d, t, p);
    /* Read with the mark, before it: in hand when stopping begins, so answered OK; the
     * INFO runs alone, after the mark was read, and still counts the query before it. */
    lr_rays(&w, (q = ask(6, "extra"), &q), CLOSEST, WORLD_ACC, 0, INFINITY, 1, N, bo, bd);
    lr_admin(&w, (q = ask(7, "extra"), &q), TRIOCT_ADMIN_REQUEST_T_INFO, NULL);
    lr_stop(&w);
    after_the_mark(&w, N, o, d, t, p);

    /* Stopping hears no new world (no reply), still drops bytes that are no request,
     * takes a second stop mark and a reload mark as nothing, and answers STOPPING in the
     * wake-ups after (the reload mark ends this one) up to the end of the log. */
    lr_rays(&w, (q = ask(18, "nowhere"), &q), CLOSEST, WORLD_ACC, 0, INFINITY, 1, N, o, d);
    lw_raw(&w, lw_channel(TRIOCT_CHANNEL_RAY, "yard"), "stop", 4);
    lr_stop(&w);
    lr_reload(&w);
    lr_rays(&w, (q = ask(19, "yard"), &q), TRIOCT_RAY_REQUEST_T_ALL, WORLD_ACC, 0, INFINITY, 4, N, o, d);
    lr_admin(&w, (q = ask(20, ""), &q), TRIOCT_ADMIN_REQUEST_T_LIST, NULL);
    return lw_save(&w, dir, "stopping");
}
