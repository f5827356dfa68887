/* The logs that change what the daemon holds: admin requests (admin), a reload in the
 * middle (reload), and a queue too small for a burst (busy). They rely on the ordered
 * daemon (trioctd --ordered): a LOAD or a reload mark ends the messages read in one go,
 * so what follows it sees its outcome, while the requests read with an UNLOAD run after it. */
#include <math.h>

#include "channels.h"
#include "logs_cases.h"
#include "logs_requests.h"
#include "logs_shapes.h"

#define WORLD_ACC TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD
#define LIST TRIOCT_ADMIN_REQUEST_T_LIST
#define INFO TRIOCT_ADMIN_REQUEST_T_INFO
#define LOAD TRIOCT_ADMIN_REQUEST_T_LOAD
#define UNLOAD TRIOCT_ADMIN_REQUEST_T_UNLOAD

static void closest(logs_writer *w, const lr_req *q, int n, const trioct_vec3_t *o, const trioct_vec3_t *d)
{
    lr_rays(w, q, TRIOCT_RAY_REQUEST_T_CLOSEST, WORLD_ACC, 0, INFINITY, 1, n, o, d);
}

static lr_req ask(int64_t client, const char *reply, int64_t id, const char *world)
{
    return (lr_req){client, id, reply, world, NULL, 0};
}

int logs_write_admin(const char *dir)
{
    enum { C = 0xad };
    const char *R = "REPLAY_ADMIN";
    logs_writer w;
    lw_init(&w);
    rng r = rng_seeded(LOGS_SEED + 3);
    trioct_vec3_t o[12], d[12];
    ls_rays_through_ball(&r, 12, o, d);
    trioct_triangle_t t[4];
    ls_triangles_at_ground(&r, 4, 0.5, t);
    lr_req q;

    lr_admin(&w, (q = ask(C, R, 1, ""), &q), LIST, NULL);
    lr_admin(&w, (q = ask(C, R, 2, "yard"), &q), INFO, NULL);
    lr_admin(&w, (q = ask(C, R, 3, "cell"), &q), INFO, NULL);
    lr_admin(&w, (q = ask(C, R, 4, "spare"), &q), INFO, NULL);

    /* A world from a path with every option; then asked about and queried. */
    lr_load(&w, (q = ask(C, R, 5, "extra"), &q), "ball.obj", 0.25, TRIOCT_RAY_REQUEST_T_SEED, 1e-9,
            1 /* EFFECT_RAYS */);
    lr_admin(&w, (q = ask(C, R, 6, "extra"), &q), INFO, NULL);
    closest(&w, (q = ask(C, R, 7, "extra"), &q), 12, o, d);
    lr_triangles(&w, (q = ask(C, R, 8, "extra"), &q), TRIOCT_TRIANGLE_REQUEST_T_YESNO, WORLD_ACC, 4, t);
    /* A scene section loaded again: version 2. */
    lr_admin(&w, (q = ask(C, R, 9, "cell"), &q), LOAD, "");
    lr_admin(&w, (q = ask(C, R, 10, "cell"), &q), INFO, NULL);
    lr_admin(&w, (q = ask(C, R, 11, ""), &q), LIST, NULL);

    /* UNLOAD, and what was read with it: taken while extra was held, run after it left. */
    lr_admin(&w, (q = ask(C, R, 12, "extra"), &q), UNLOAD, NULL);
    closest(&w, (q = ask(C, R, 13, "extra"), &q), 12, o, d);
    lr_admin(&w, (q = ask(C, R, 14, "extra"), &q), INFO, NULL);
    lr_admin(&w, (q = ask(C, R, 15, "extra"), &q), UNLOAD, NULL);

    /* Every LOAD that fails, each ending its wake-up: after the first, nobody hears extra. */
    lr_admin(&w, (q = ask(C, R, 16, "esc"), &q), LOAD, "../outside.obj");
    closest(&w, (q = ask(C, R, 17, "extra"), &q), 12, o, d); /* unheard: no reply */
    lr_admin(&w, (q = ask(C, R, 18, "abs"), &q), LOAD, "/etc/hostname");
    lr_admin(&w, (q = ask(C, R, 19, "gone"), &q), LOAD, "missing.obj");
    lr_admin(&w, (q = ask(C, R, 20, "junk"), &q), LOAD, "garbage.obj");
    lr_admin(&w, (q = ask(C, R, 21, "nan"), &q), LOAD, "nan.obj");
    lr_admin(&w, (q = ask(C, R, 22, "nosuch"), &q), LOAD, "");
    lr_admin(&w, (q = ask(C, R, 23, "bad name!"), &q), LOAD, "ball.obj");
    lr_load(&w, (q = ask(C, R, 24, "odd"), &q), "ball.obj", NAN, WORLD_ACC, 0, 0);
    lr_load(&w, (q = ask(C, R, 25, "odd"), &q), "ball.obj", 0, 7, 0, 0);
    lr_load(&w, (q = ask(C, R, 26, "odd"), &q), "ball.obj", 0, WORLD_ACC, 0, 0x10);

    /* An op on a channel that does not serve it. */
    q = ask(C, R, 27, "yard");
    q.channel = lw_channel(TRIOCT_CHANNEL_LIST, "");
    lr_admin(&w, &q, INFO, NULL);
    q = ask(C, R, 28, "yard");
    q.channel = lw_channel(TRIOCT_CHANNEL_LOAD, LOGS_DAEMON);
    lr_admin(&w, &q, UNLOAD, NULL);
    q = ask(C, R, 29, "yard");
    lr_admin(&w, &q, LIST, NULL);
    /* LIST on a world's admin channel: the op says LIST, the channel says INFO/UNLOAD. */
    q.id = 30;
    q.channel = lw_channel(TRIOCT_CHANNEL_ADMIN, "yard");
    lr_admin(&w, &q, LIST, NULL);
    /* Another daemon's LOAD channel: not ours, no reply. */
    q = ask(C, R, 31, "theirs");
    q.channel = lw_channel(TRIOCT_CHANNEL_LOAD, "otherd");
    lr_admin(&w, &q, LOAD, "ball.obj");
    /* A deadline long gone. */
    q = ask(C, R, 32, "yard");
    q.deadline = 1;
    lr_admin(&w, &q, INFO, NULL);

    lr_admin(&w, (q = ask(C, R, 33, ""), &q), LIST, NULL);

    /* The guard and the budget (issue 20). A section whose meshes pass its memory_budget:
     * BUDGET, as at start. A LOAD and an UNLOAD without the admin key's code: DENIED, and
     * yard stays. A signed LOAD, then the very same bytes again (a retry, or a replay
     * captured off the bus): the reply cache answers it with the first reply, and the world
     * is built once (its nonce would refuse it once the cache has let it go). */
    lr_admin(&w, (q = ask(C, R, 34, "tight"), &q), LOAD, "");
    w.unsigned_changes = 1;
    lr_admin(&w, (q = ask(C, R, 35, "yard"), &q), LOAD, "ball.obj");
    lr_admin(&w, (q = ask(C, R, 36, "yard"), &q), UNLOAD, NULL);
    w.unsigned_changes = 0;
    lr_admin(&w, (q = ask(C, R, 37, "yard"), &q), INFO, NULL);
    lr_admin(&w, (q = ask(C, R, 38, "again"), &q), LOAD, "ball.obj");
    lw_repeat_last(&w);
    lr_admin(&w, (q = ask(C, R, 39, ""), &q), LIST, NULL);
    return lw_save(&w, dir, "admin");
}

int logs_write_reload(const char *dir)
{
    enum { C = 0x4e };
    const char *R = "REPLAY_RELOAD";
    logs_writer w;
    lw_init(&w);
    rng r = rng_seeded(LOGS_SEED + 4);
    trioct_vec3_t o[16], d[16];
    ls_rays_from_above(&r, 16, o, d);
    lr_req q;

    closest(&w, (q = ask(C, R, 1, "yard"), &q), 16, o, d);
    /* yard rebuilt from a path over its section: the crates alone, version 2. */
    lr_admin(&w, (q = ask(C, R, 2, "yard"), &q), LOAD, "crates.obj");
    closest(&w, (q = ask(C, R, 3, "yard"), &q), 16, o, d);
    /* A world of no section: a reload leaves it alone. */
    lr_admin(&w, (q = ask(C, R, 4, "kept"), &q), LOAD, "ball.obj");
    lr_admin(&w, (q = ask(C, R, 5, "spare"), &q), UNLOAD, NULL);
    closest(&w, (q = ask(C, R, 6, "spare"), &q), 16, o, d); /* UNKNOWN_WORLD */
    lr_admin(&w, (q = ask(C, R, 7, "yard"), &q), INFO, NULL);

    /* The reload: yard is built from its section again (version 3), spare comes back
     * (version 1), kept stays, cell and yard_rays are unchanged. */
    lr_reload(&w);
    closest(&w, (q = ask(C, R, 8, "yard"), &q), 16, o, d);
    closest(&w, (q = ask(C, R, 9, "spare"), &q), 16, o, d);
    closest(&w, (q = ask(C, R, 10, "kept"), &q), 16, o, d);
    lr_admin(&w, (q = ask(C, R, 11, ""), &q), LIST, NULL);
    /* Again: nothing changed, so nothing is rebuilt. */
    lr_reload(&w);
    lr_admin(&w, (q = ask(C, R, 12, ""), &q), LIST, NULL);
    return lw_save(&w, dir, "reload");
}

int logs_write_busy(const char *dir)
{
    static const char *const replies[] = {"REPLAY_BUSY_A", "REPLAY_BUSY_B", "REPLAY_BUSY_C"};
    logs_writer w;
    lw_init(&w);
    rng r = rng_seeded(LOGS_SEED + 5);
    trioct_vec3_t o[8], d[8];
    ls_rays_from_above(&r, 8, o, d);
    trioct_triangle_t t[4];
    ls_triangles_at_ground(&r, 4, 0.5, t);
    lr_req q;

    /* The first wake-up: three rays and a LOAD fill the queue of four; the LOAD ends it. */
    for (int i = 0; i < 3; i++)
        closest(&w, (q = ask(0xb0 + i, replies[i], 1, "yard"), &q), 8, o, d);
    lr_admin(&w, (q = ask(0xb0, replies[0], 2, "extra"), &q), LOAD, "ball.obj");

    /* The second starts with an empty queue: four are taken, the rest answered BUSY at
     * once, admin requests and a LOAD among them. */
    for (int i = 0; i < 24; i++) {
        q = ask(0xb0 + i % 3, replies[i % 3], 10 + i, i % 2 ? "yard" : "extra");
        if (i == 9)
            lr_admin(&w, &q, INFO, NULL);
        else if (i % 3 == 2 && i % 2)
            lr_triangles(&w, &q, TRIOCT_TRIANGLE_REQUEST_T_YESNO, WORLD_ACC, 4, t);
        else
            closest(&w, &q, 8, o, d);
    }
    lr_admin(&w, (q = ask(0xb1, replies[1], 40, "more"), &q), LOAD, "ball.obj");
    closest(&w, (q = ask(0xb2, replies[2], 41, "yard"), &q), 8, o, d);
    return lw_save(&w, dir, "busy");
}
