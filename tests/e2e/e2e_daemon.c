/* End to end: the real trioctd over udpm, inside the private network and pid namespace
 * that tests/e2e/netns.sh makes (nothing leaves the machine; every daemon dies with it).
 *
 *   e2e_daemon TRIOCTD_BINARY
 *
 * Two daemons share one bus, each holding its own worlds. Clients on their own connections
 * check every answer against the engine run in this process on the same scene, through a
 * SIGHUP reload under load (no query fails; each answer is right for the world version it
 * names) and a SIGTERM with queries in flight (each answered, exit status 0). */
#include <math.h>
#include <pthread.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmocka.h>
#include <lcm/lcm.h>

#include "engine.h"
#include "support/daemon_proc.h"
#include "support/hostile_files.h"
#include "support/meshgen.h"
#include "support/obj_write.h"
#include "trioct.h"
#include "admin_key.h"
#include "trioct_admin_reply_t.h"
#include "trioct_admin_request_t.h"
#include "trioct_ray_request_t.h"
#include "world/scene.h"
#include "world/world.h"

#define BUS_URL "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
#define TIMEOUT_MS 5000

static const char *daemon_bin;
static char dir[256];
static char scene_a[320], scene_b[320];
static pid_t daemon_a = -1, daemon_b = -1;

/* ---------- the scene, and the same worlds built in this process ---------- */

static void write_file(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    assert_int_equal(fclose(f), 0);
}

static char key_file[320]; /* the daemons' admin key; TRIOCT_KEY_FILE names it */

static void path_in_dir(char *out, size_t len, const char *name)
{
    snprintf(out, len, "%s/%s", dir, name);
}

static void write_mesh(const char *name, mesh_data mesh)
{
    char path[320];
    path_in_dir(path, sizeof path, name);
    assert_int_equal(obj_write(path, &mesh), 0);
    mesh_data_free(&mesh);
}

/* Daemon A holds `ground` (every effect, one shape) and `ground_rays` (rays only); daemon B
 * holds `ring`. translate_z moves ground: the reload test changes it. */
static void write_scene_a(double translate_z)
{
    char text[1024];
    snprintf(text, sizeof text,
             "[ground]\nmesh = terrain.obj\nmesh = ball.obj\ntranslate = 0 0 %.17g\n"
             "effects = rays triangles meshes\nshape.cube = cube.obj\n\n"
             "[ground_rays]\nmesh = terrain.obj\neffects = rays\n",
             translate_z);
    write_file(scene_a, text);
}

static world *build_truth(const char *scene_path, const char *name)
{
    scene s;
    char err[512];
    int rc = scene_load(scene_path, &s, err, sizeof err);
    if (rc != 0)
        fail_msg("%s", err);
    const world_spec *spec = scene_find(&s, name);
    assert_non_null(spec);
    int status = 0;
    world *w = world_build(spec, dir, NULL, &status, err, sizeof err);
    if (w == NULL)
        fail_msg("%s", err);
    scene_free(&s);
    return w;
}

static int group_setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/trioct-e2e-XXXXXX");
    if (mkdtemp(dir) == NULL)
        return -1;
    write_mesh("terrain.obj", meshgen_terrain(3, (box3){{-10, -10, -1}, {10, 10, 1}}, 40, 40));
    write_mesh("ball.obj", meshgen_icosphere(vec3_make(2, 3, 2), 1.5, 3));
    write_mesh("cube.obj", meshgen_box((box3){{-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5}}));
    write_mesh("ring.obj", meshgen_torus(vec3_make(0, 0, 0), 3, 1, 48, 24));
    path_in_dir(scene_a, sizeof scene_a, "a.ini");
    path_in_dir(scene_b, sizeof scene_b, "b.ini");
    write_scene_a(0);
    write_file(scene_b, "[ring]\nmesh = ring.obj\neffects = rays triangles\n");

    char log_a[320], log_b[320];
    path_in_dir(log_a, sizeof log_a, "a.log");
    path_in_dir(log_b, sizeof log_b, "b.log");
    path_in_dir(key_file, sizeof key_file, "admin.key");
    if (daemon_proc_write_key(key_file) != 0)
        return -1;
    const char *extra[] = {"--threads", "2", "--status-interval", "200", "--log-level", "info",
                           "--admin-key-file", key_file, NULL};
    daemon_a = daemon_proc_start(daemon_bin, scene_a, BUS_URL, "dA", extra, log_a);
    daemon_b = daemon_proc_start(daemon_bin, scene_b, BUS_URL, "dB", extra, log_b);
    if (daemon_a < 0 || daemon_b < 0)
        return -1;

    trioct_connect_options opt = {.url = BUS_URL};
    trioct_client *c = trioct_connect(&opt, NULL, NULL, 0);
    if (c == NULL)
        return -1;
    int ready = daemon_proc_wait_ready(c, "dA", 20000) == 0 && daemon_proc_wait_ready(c, "dB", 20000) == 0;
    trioct_disconnect(c);
    if (!ready)
        fprintf(stderr, "e2e: the daemons did not report READY; see %s and %s\n", log_a, log_b);
    return ready ? 0 : -1;
}

static int group_teardown(void **state)
{
    (void)state;
    if (daemon_b > 0)
        daemon_proc_stop(daemon_b, SIGKILL, 2000);
    if (daemon_a > 0)
        daemon_proc_stop(daemon_a, SIGKILL, 2000);
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

static trioct_client *connect_bus(void)
{
    trioct_connect_options opt = {.url = BUS_URL};
    char err[256];
    trioct_client *c = trioct_connect(&opt, NULL, err, sizeof err);
    if (c == NULL)
        fail_msg("connect: %s", err);
    return c;
}

/* ---------- queries and their truth ---------- */

enum { RAYS = 200 };

static void make_rays(uint64_t seed, trioct_vec3 *o, trioct_vec3 *d, size_t n)
{
    rng r = rng_seeded(seed);
    for (size_t i = 0; i < n; i++) {
        vec3 from = rng_point_in_box(&r, (box3){{-12, -12, 4}, {12, 12, 8}});
        vec3 to = rng_point_in_box(&r, (box3){{-10, -10, -1}, {10, 10, 2}});
        o[i] = (trioct_vec3){from.x, from.y, from.z};
        d[i] = (trioct_vec3){to.x - from.x, to.y - from.y, to.z - from.z};
    }
}

/* 1 when a closest-hit reply equals w's octree answer for every ray, bit for bit. Returns
 * rather than asserts: client threads call it too, and cmocka asserts only on the main one. */
static int rays_match(const trioct_ray_result *res, const world *w, const trioct_vec3 *o, const trioct_vec3 *d,
                      size_t n)
{
    if (res->num_rays != n)
        return 0;
    size_t next_hit = 0;
    for (size_t i = 0; i < n; i++) {
        ray_input ray = {{o[i].x, o[i].y, o[i].z}, {d[i].x, d[i].y, d[i].z}, 0, INFINITY, RAY_CROSSING};
        ray_hit hit;
        ray_output out = {.hits = &hit, .max_hits = 1};
        if (octree_ray(w->tree, &ray, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL) != OCTREE_OK)
            return 0;
        if (res->found[i] != (int32_t)out.hit_count)
            return 0;
        if (out.hit_count == 0)
            continue;
        if (next_hit >= res->num_hits)
            return 0;
        const trioct_ray_hit *h = &res->hits[next_hit++];
        if (h->ray != (int32_t)i || h->triangle != (int32_t)hit.triangle || h->t != hit.t || h->u != hit.u ||
            h->v != hit.v || h->normal.x != hit.normal.x || h->normal.y != hit.normal.y ||
            h->normal.z != hit.normal.z)
            return 0;
    }
    return next_hit == res->num_hits;
}

static int ask_rays(trioct_client *c, const char *world_name, uint64_t seed, trioct_vec3 *o, trioct_vec3 *d,
                    trioct_ray_result *res)
{
    make_rays(seed, o, d, RAYS);
    trioct_ray_query q = trioct_ray_query_default(world_name);
    q.count = RAYS;
    q.origins = o;
    q.directions = d;
    return trioct_rays(c, &q, TIMEOUT_MS, res);
}

static void test_answers_equal_the_engine(void **state)
{
    (void)state;
    world *ground = build_truth(scene_a, "ground");
    trioct_client *c = connect_bus();
    trioct_vec3 o[RAYS], d[RAYS];

    trioct_ray_result rays;
    assert_int_equal(ask_rays(c, "ground", 1, o, d, &rays), TRIOCT_OK);
    assert_string_equal(rays.reply.daemon, "dA");
    assert_true(rays_match(&rays, ground, o, d, RAYS));
    trioct_ray_result_free(&rays);

    /* A triangle standing on the terrain: its contact ids, against the engine. */
    trioct_triangle tri = {{-3, 0.2, -2}, {3, 0.3, -2}, {0.1, -0.4, 3}};
    trioct_triangle_query tq = {.world = "ground", .detail = TRIOCT_TRI_IDS, .accuracy = TRIOCT_ACCURACY_WORLD,
                                .count = 1, .triangles = &tri};
    trioct_triangle_result tres;
    assert_int_equal(trioct_triangles(c, &tq, TIMEOUT_MS, &tres), TRIOCT_OK);
    vec3 qt[3] = {{tri.a.x, tri.a.y, tri.a.z}, {tri.b.x, tri.b.y, tri.b.z}, {tri.c.x, tri.c.y, tri.c.z}};
    tri_contact contacts[4096];
    tri_output out = {.contacts = contacts, .capacity = 4096};
    assert_int_equal(octree_triangle(ground->tree, qt, TRI_IDS, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
    assert_true(out.count > 0);
    assert_int_equal(tres.found[0], (int32_t)out.count);
    assert_int_equal(tres.num_contacts, out.count);
    for (size_t i = 0; i < out.count; i++)
        assert_int_equal(tres.contacts[i].triangle, (int32_t)contacts[i].triangle);
    trioct_triangle_result_free(&tres);

    /* The scene's cube shape at two poses: sunk into the ball, and high above everything. */
    trioct_pose poses[2] = {{{1, 0, 0, 0, 1, 0, 0, 0, 1}, {2, 3, 3.2}}, {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 50}}};
    trioct_mesh_query mq = {.world = "ground", .detail = TRIOCT_MESH_PAIRS, .accuracy = TRIOCT_ACCURACY_WORLD,
                            .shape = "cube", .num_poses = 2, .poses = poses};
    trioct_mesh_result mres;
    assert_int_equal(trioct_mesh(c, &mq, TIMEOUT_MS, &mres), TRIOCT_OK);
    const world_shape *cube = world_find_shape(ground, "cube");
    assert_non_null(cube);
    mesh_view shape = mesh_data_view(&cube->model->mesh);
    for (int p = 0; p < 2; p++) {
        pose at;
        memcpy(at.r, poses[p].r, sizeof at.r);
        at.t = vec3_make(poses[p].t.x, poses[p].t.y, poses[p].t.z);
        mesh_pair pairs[4096];
        mesh_output mo = {.pairs = pairs, .capacity = 4096};
        assert_int_equal(octree_mesh(ground->tree, &shape, &at, 1, ACCURACY_EXACT, &mo, NULL), OCTREE_OK);
        assert_int_equal(mres.found[p], (int32_t)mo.count);
    }
    assert_true(mres.found[0] > 0);
    assert_int_equal(mres.found[1], 0);
    trioct_mesh_result_free(&mres);

    trioct_disconnect(c);
    world_release(ground);
}

/* ---------- several clients at once ---------- */

typedef struct client_job {
    int index;
    int rounds;
    int failures, wrong;
    world *truth;
} client_job;

static void *client_thread(void *arg)
{
    client_job *job = arg;
    trioct_connect_options opt = {.url = BUS_URL};
    trioct_client *c = trioct_connect(&opt, NULL, NULL, 0);
    if (c == NULL) {
        job->failures = job->rounds;
        return NULL;
    }
    trioct_vec3 o[RAYS], d[RAYS];
    for (int r = 0; r < job->rounds; r++) {
        trioct_ray_result res;
        int rc = ask_rays(c, "ground", 1000 * (uint64_t)job->index + (uint64_t)r, o, d, &res);
        if (rc != TRIOCT_OK)
            job->failures++;
        else
            job->wrong += !rays_match(&res, job->truth, o, d, RAYS);
        trioct_ray_result_free(&res);
    }
    trioct_disconnect(c);
    return NULL;
}

static void test_concurrent_clients(void **state)
{
    (void)state;
    enum { CLIENTS = 6 };
    world *truth = build_truth(scene_a, "ground");
    pthread_t threads[CLIENTS];
    client_job jobs[CLIENTS];
    for (int i = 0; i < CLIENTS; i++) {
        jobs[i] = (client_job){.index = i, .rounds = 25, .truth = truth};
        assert_int_equal(pthread_create(&threads[i], NULL, client_thread, &jobs[i]), 0);
    }
    for (int i = 0; i < CLIENTS; i++) {
        pthread_join(threads[i], NULL);
        assert_int_equal(jobs[i].failures, 0);
        assert_int_equal(jobs[i].wrong, 0);
    }
    world_release(truth);
}

/* ---------- a fleet: two daemons, each world answered once, by its holder ---------- */

static void test_two_daemons_answer_once(void **state)
{
    (void)state;
    trioct_client *c = connect_bus();
    trioct_vec3 o[RAYS], d[RAYS];
    for (int round = 0; round < 10; round++) {
        trioct_ray_result res;
        const char *name = round % 2 ? "ring" : "ground";
        assert_int_equal(ask_rays(c, name, 77 + (uint64_t)round, o, d, &res), TRIOCT_OK);
        assert_string_equal(res.reply.daemon, round % 2 ? "dB" : "dA");
        trioct_ray_result_free(&res);
    }
    /* A second answer to any of these would arrive within a few ms; give it 300. */
    struct timespec wait = {0, 300 * 1000 * 1000};
    nanosleep(&wait, NULL);
    trioct_pump(c);
    trioct_client_stats st;
    trioct_client_get_stats(c, &st);
    assert_int_equal(st.unmatched, 0);
    assert_int_equal(st.duplicate_chunks, 0);

    trioct_list_options lo = {.expect_daemons = 2};
    trioct_list_result list;
    assert_int_equal(trioct_list(c, &lo, TIMEOUT_MS, &list), TRIOCT_OK);
    assert_int_equal(list.num_daemons, 2);
    assert_int_equal(list.num_worlds, 3);
    int seen = 0;
    for (size_t i = 0; i < list.num_worlds; i++) {
        const trioct_world_info *w = &list.worlds[i];
        if (strcmp(w->name, "ring") == 0 && strcmp(w->daemon, "dB") == 0)
            seen |= 1;
        if (strcmp(w->name, "ground") == 0 && strcmp(w->daemon, "dA") == 0)
            seen |= 2;
        if (strcmp(w->name, "ground_rays") == 0 && strcmp(w->daemon, "dA") == 0)
            seen |= 4;
    }
    assert_int_equal(seen, 7);
    trioct_list_result_free(&list);

    /* Nobody holds this world: silence, reported as such. */
    trioct_ray_result res;
    trioct_ray_query q = trioct_ray_query_default("nowhere");
    q.count = 1;
    q.origins = o;
    q.directions = d;
    assert_int_equal(trioct_rays(c, &q, 300, &res), TRIOCT_ERR_NO_DAEMON);
    assert_non_null(strstr(res.reply.message, "nowhere"));
    trioct_ray_result_free(&res);
    trioct_disconnect(c);
}

/* ---------- error replies over the bus ---------- */

static void test_error_replies(void **state)
{
    (void)state;
    trioct_client *c = connect_bus();
    trioct_vec3 o[2] = {{0, 0, 5}, {0, 0, 5}}, d[2] = {{0, 0, -1}, {0, 0, 0}};
    trioct_ray_query q = trioct_ray_query_default("ground");
    q.count = 2;
    q.origins = o;
    q.directions = d;
    trioct_ray_result res;
    assert_int_equal(trioct_rays(c, &q, TIMEOUT_MS, &res), TRIOCT_ERR_ZERO_DIRECTION);
    trioct_ray_result_free(&res);

    d[1] = (trioct_vec3){NAN, 0, -1};
    assert_int_equal(trioct_rays(c, &q, TIMEOUT_MS, &res), TRIOCT_ERR_NONFINITE);
    trioct_ray_result_free(&res);

    trioct_triangle tri = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    trioct_triangle_query tq = {.world = "ground_rays", .detail = TRIOCT_TRI_YESNO, .count = 1, .triangles = &tri};
    trioct_triangle_result tres;
    assert_int_equal(trioct_triangles(c, &tq, TIMEOUT_MS, &tres), TRIOCT_ERR_EFFECT);
    assert_string_equal(tres.reply.daemon, "dA");
    trioct_triangle_result_free(&tres);

    trioct_load_options lo = {.world = "escape", .daemon = "dA", .mesh_path = "../etc/passwd"};
    trioct_admin_result ares;
    int st = trioct_load(c, &lo, TIMEOUT_MS, &ares);
    if (st != TRIOCT_ERR_BAD_PATH) print_error("load: %s\n", ares.reply.message);
    assert_int_equal(st, TRIOCT_ERR_BAD_PATH);
    trioct_admin_result_free(&ares);
    trioct_disconnect(c);
}

/* ---------- hostile bytes are dropped, counted, and hurt nobody ---------- */

static void test_hostile_bytes_counted(void **state)
{
    (void)state;
    trioct_client *c = connect_bus();
    trioct_daemon_status before;
    assert_int_equal(trioct_next_status(c, "dA", TIMEOUT_MS, &before), TRIOCT_OK);

    lcm_t *raw = lcm_create(BUS_URL);
    assert_non_null(raw);
    /* A real request's bytes, to cut short and to corrupt past its fingerprint. */
    trioct_vec3 origin = {0, 0, 5}, direction = {0, 0, -1};
    trioct_ray_request_t req = {
        .header = {.client_id = 1, .request_id = 1, .reply_channel = "E2E_NOBODY", .world = "ground"},
        .detail = TRIOCT_RAY_REQUEST_T_CLOSEST, .accuracy = TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD,
        .tmax = INFINITY, .num_rays = 1,
        .origin = (trioct_vec3_t *)&origin, .direction = (trioct_vec3_t *)&direction};
    uint8_t good[512], junk[512];
    int size = trioct_ray_request_t_encode(good, 0, sizeof good, &req);
    assert_true(size > 16);
    rng r = rng_seeded(5);
    enum { HOSTILE = 30 };
    for (int i = 0; i < HOSTILE; i++) {
        size_t n;
        if (i % 3 == 0) { /* truncated */
            n = 1 + (size_t)(rng_next(&r) % (size_t)(size - 1));
            memcpy(junk, good, n);
        } else if (i % 3 == 1) { /* the right fingerprint, then a count far beyond the bytes */
            n = (size_t)size;
            memcpy(junk, good, n);
            size_t at = (size_t)size - 2 * 24 - 4; /* num_rays */
            junk[at] = 0x7f;
        } else { /* noise */
            n = 1 + (size_t)(rng_next(&r) % sizeof junk);
            for (size_t k = 0; k < n; k++)
                junk[k] = (uint8_t)rng_next(&r);
        }
        assert_int_equal(lcm_publish(raw, "TRIOCT_RAY_ground", junk, (unsigned)n), 0);
    }
    lcm_destroy(raw);

    /* Still answering, and the junk shows in the heartbeat. */
    trioct_vec3 o[RAYS], d[RAYS];
    trioct_ray_result res;
    assert_int_equal(ask_rays(c, "ground", 9, o, d, &res), TRIOCT_OK);
    trioct_ray_result_free(&res);
    trioct_daemon_status after;
    assert_int_equal(trioct_next_status(c, "dA", TIMEOUT_MS, &after), TRIOCT_OK);
    assert_true(after.malformed - before.malformed == HOSTILE);
    trioct_daemon_status_free(&before);
    trioct_daemon_status_free(&after);
    trioct_disconnect(c);
}

/* ---------- only the key holder changes worlds ---------- */

typedef struct admin_replies {
    int count;
    int status[4];
    char message[4][256];
} admin_replies;

static void on_admin_reply(const lcm_recv_buf_t *rbuf, const char *channel, const trioct_admin_reply_t *m,
                           void *user)
{
    (void)rbuf;
    (void)channel;
    admin_replies *got = user;
    if (got->count < 4) {
        got->status[got->count] = m->header.status;
        snprintf(got->message[got->count], sizeof got->message[0], "%s", m->header.message);
        got->count++;
    }
}

static int64_t ground_version(trioct_client *c)
{
    trioct_admin_result info;
    assert_int_equal(trioct_info(c, "ground", TIMEOUT_MS, &info), TRIOCT_OK);
    assert_int_equal(info.num_worlds, 1);
    int64_t v = info.worlds[0].version;
    assert_true(info.worlds[0].triangles > 12);
    trioct_admin_result_free(&info);
    return v;
}

/* Issue 20: a second process on the bus with another key, or none, cannot unload ground or
 * load a 12-triangle cube under its name; and a change captured off the bus and sent
 * again is refused, though the first copy was honoured. */
static void test_changes_need_the_key_over_the_bus(void **state)
{
    (void)state;
    trioct_client *c = connect_bus();
    int64_t version = ground_version(c);

    char other[320];
    path_in_dir(other, sizeof other, "other.key");
    FILE *f = fopen(other, "w");
    assert_non_null(f);
    fputs("0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef\n", f);
    assert_int_equal(fclose(f), 0);
    assert_int_equal(chmod(other, 0600), 0);
    const char *keys[] = {other, ""}; /* another key; no key */
    for (int k = 0; k < 2; k++) {
        trioct_connect_options opt = {.url = BUS_URL, .admin_key_file = keys[k]};
        trioct_client *intruder = trioct_connect(&opt, NULL, NULL, 0);
        assert_non_null(intruder);
        trioct_admin_result ar;
        assert_int_equal(trioct_unload(intruder, "ground", TIMEOUT_MS, &ar), TRIOCT_ERR_DENIED);
        assert_non_null(strstr(ar.reply.message, "does not match the daemon's admin key"));
        trioct_admin_result_free(&ar);
        trioct_load_options lo = {.world = "ground", .daemon = "dA", .mesh_path = "cube.obj"};
        assert_int_equal(trioct_load(intruder, &lo, TIMEOUT_MS, &ar), TRIOCT_ERR_DENIED);
        trioct_admin_result_free(&ar);
        trioct_disconnect(intruder);
    }
    assert_int_equal(ground_version(c), version);

    /* A signed LOAD, published twice, byte for byte (on the daemon's LOAD channel, which
     * it keeps hearing whatever the load does): the copy is answered from the reply cache,
     * the same reply, and the world is built once. */
    trioct_daemon_status st_before;
    assert_int_equal(trioct_next_status(c, "dA", TIMEOUT_MS, &st_before), TRIOCT_OK);
    trioct_load_options lo = {.world = "scratch_w", .daemon = "dA", .mesh_path = "cube.obj"};
    trioct_admin_result ar;
    assert_int_equal(trioct_load(c, &lo, TIMEOUT_MS, &ar), TRIOCT_OK);
    trioct_admin_result_free(&ar);
    trioct_admin_key key;
    char err[256];
    assert_int_equal(trioct_admin_key_load(key_file, &key, err, sizeof err), 0);
    trioct_admin_request_t req = {
        .header = {.client_id = 77, .request_id = 1, .reply_channel = "E2E_REPLAYED", .world = "scratch_w"},
        .op = TRIOCT_ADMIN_REQUEST_T_LOAD, .mesh_path = "cube.obj", .accuracy = TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD};
    uint8_t bytes[512];
    int size = trioct_admin_request_t_encode(bytes, 0, sizeof bytes, &req);
    assert_true(size > TRIOCT_ADMIN_AUTH_BYTES);
    struct timespec now;
    clock_gettime(CLOCK_REALTIME, &now);
    trioct_admin_sign(&key, "TRIOCT_LOAD_dA", bytes, (size_t)size,
                      (int64_t)now.tv_sec * 1000000 + now.tv_nsec / 1000);
    lcm_t *raw = lcm_create(BUS_URL);
    assert_non_null(raw);
    admin_replies got = {0};
    trioct_admin_reply_t_subscription_t *sub = trioct_admin_reply_t_subscribe(raw, "E2E_REPLAYED", on_admin_reply, &got);
    for (int copy = 0; copy < 2; copy++) {
        assert_int_equal(lcm_publish(raw, "TRIOCT_LOAD_dA", bytes, (unsigned)size), 0);
        for (int waited = 0; got.count <= copy && waited < 50; waited++)
            lcm_handle_timeout(raw, 100);
    }
    trioct_admin_reply_t_unsubscribe(raw, sub);
    lcm_destroy(raw);
    assert_int_equal(got.count, 2);
    assert_int_equal(got.status[0], TRIOCT_OK);
    assert_int_equal(got.status[1], TRIOCT_OK);
    assert_string_equal(got.message[0], got.message[1]);
    assert_int_equal(trioct_info(c, "scratch_w", TIMEOUT_MS, &ar), TRIOCT_OK);
    assert_int_equal(ar.worlds[0].version, 2); /* the client's LOAD, then one of the two copies */
    trioct_admin_result_free(&ar);
    trioct_daemon_status st_after;
    assert_int_equal(trioct_next_status(c, "dA", TIMEOUT_MS, &st_after), TRIOCT_OK);
    assert_int_equal(st_after.duplicates_answered - st_before.duplicates_answered, 1);
    trioct_daemon_status_free(&st_before);
    trioct_daemon_status_free(&st_after);
    assert_int_equal(trioct_unload(c, "scratch_w", TIMEOUT_MS, &ar), TRIOCT_OK);
    trioct_admin_result_free(&ar);
    trioct_disconnect(c);
}

/* ---------- hostile files ---------- */

static long rss_kib(pid_t pid)
{
    char path[64], line[256];
    snprintf(path, sizeof path, "/proc/%d/status", (int)pid);
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    long kib = -1;
    while (fgets(line, sizeof line, f))
        if (sscanf(line, "VmRSS: %ld kB", &kib) == 1)
            break;
    fclose(f);
    return kib;
}

/* Issue 20's files, each LOADed over the bus under ground's name: a COLLADA of 100,000
 * nested nodes (it crashed the daemon), a PLY header claiming 268 million vertices (it
 * filled the daemon to 3.2 GB), a FIFO (it hung a worker). Each is an error reply naming
 * the file, ground keeps its version, and the daemon's memory stays where it was. */
static void test_hostile_files_leave_the_daemon_serving(void **state)
{
    (void)state;
    trioct_client *c = connect_bus();
    int64_t version = ground_version(c);
    long before = rss_kib(daemon_a);

    char path[320];
    path_in_dir(path, sizeof path, "deep.dae");
    assert_int_equal(hostile_write_deep_collada(path, 100000), 0);
    path_in_dir(path, sizeof path, "lying.ply");
    assert_int_equal(hostile_write_lying_ply(path), 0);
    path_in_dir(path, sizeof path, "pipe.obj");
    assert_int_equal(mkfifo(path, 0600), 0);

    const char *files[] = {"deep.dae", "lying.ply", "pipe.obj"};
    for (int i = 0; i < 3; i++) {
        trioct_load_options lo = {.world = "ground", .daemon = "dA", .mesh_path = files[i]};
        trioct_admin_result ar;
        int st = trioct_load(c, &lo, 60000, &ar);
        if (st != TRIOCT_ERR_LOAD_FAILED || !strstr(ar.reply.message, files[i]))
            print_error("%s: status %d: %s\n", files[i], st, ar.reply.message);
        assert_int_equal(st, TRIOCT_ERR_LOAD_FAILED);
        assert_non_null(strstr(ar.reply.message, files[i]));
        trioct_admin_result_free(&ar);
    }
    assert_int_equal(ground_version(c), version);
    trioct_vec3 o[RAYS], d[RAYS];
    trioct_ray_result res;
    assert_int_equal(ask_rays(c, "ground", 9, o, d, &res), TRIOCT_OK);
    trioct_ray_result_free(&res);
    long after = rss_kib(daemon_a);
    print_message("daemon RSS %ld KiB before the hostile loads, %ld KiB after\n", before, after);
    assert_true(after - before < 64 * 1024);
    trioct_disconnect(c);
}

/* ---------- SIGHUP under load ---------- */

typedef struct reload_job {
    world *v1, *v2;
    volatile int stop;
    int answered, failures, wrong, saw_v2;
} reload_job;

static void *reload_client(void *arg)
{
    reload_job *job = arg;
    trioct_connect_options opt = {.url = BUS_URL};
    trioct_client *c = trioct_connect(&opt, NULL, NULL, 0);
    if (c == NULL) {
        job->failures++;
        return NULL;
    }
    trioct_vec3 o[RAYS], d[RAYS];
    for (uint64_t round = 0; !job->stop; round++) {
        trioct_ray_result res;
        if (ask_rays(c, "ground", 500 + round, o, d, &res) != TRIOCT_OK) {
            job->failures++;
        } else {
            job->answered++;
            /* Right for the version it names: v1 before the swap, v2 after. */
            world *truth = res.reply.world_version >= 2 ? job->v2 : job->v1;
            job->saw_v2 |= res.reply.world_version >= 2;
            job->wrong += !rays_match(&res, truth, o, d, RAYS);
        }
        trioct_ray_result_free(&res);
    }
    trioct_disconnect(c);
    return NULL;
}

static void test_sighup_reload_under_load(void **state)
{
    (void)state;
    reload_job job = {.v1 = build_truth(scene_a, "ground")};
    write_scene_a(0.25);
    job.v2 = build_truth(scene_a, "ground");
    write_scene_a(0);

    pthread_t t[3];
    for (int i = 0; i < 3; i++)
        assert_int_equal(pthread_create(&t[i], NULL, reload_client, &job), 0);
    struct timespec wait = {0, 300 * 1000 * 1000};
    nanosleep(&wait, NULL);
    write_scene_a(0.25);
    assert_int_equal(kill(daemon_a, SIGHUP), 0);
    for (int i = 0; i < 40 && !job.saw_v2; i++)
        nanosleep(&wait, NULL);
    nanosleep(&wait, NULL);
    job.stop = 1;
    for (int i = 0; i < 3; i++)
        pthread_join(t[i], NULL);
    assert_int_equal(job.failures, 0);
    assert_int_equal(job.wrong, 0);
    assert_true(job.saw_v2);
    assert_true(job.answered > 10);
    world_release(job.v1);
    world_release(job.v2);
}

/* ---------- SIGTERM: queries in flight are answered, exit 0 ---------- */

typedef struct drain_job {
    int status;
} drain_job;

static void *drain_client(void *arg)
{
    drain_job *job = arg;
    trioct_connect_options opt = {.url = BUS_URL};
    trioct_client *c = trioct_connect(&opt, NULL, NULL, 0);
    if (c == NULL) {
        job->status = -1;
        return NULL;
    }
    enum { MANY = 1280 };
    static __thread trioct_vec3 o[MANY], d[MANY];
    make_rays(42, o, d, MANY);
    trioct_ray_query q = trioct_ray_query_default("ground");
    q.detail = TRIOCT_RAY_ALL;
    q.max_hits = 16;
    q.count = MANY;
    q.origins = o;
    q.directions = d;
    trioct_ray_result res;
    job->status = trioct_rays(c, &q, TIMEOUT_MS, &res);
    trioct_ray_result_free(&res);
    trioct_disconnect(c);
    return NULL;
}

static void test_sigterm_answers_in_flight(void **state)
{
    (void)state;
    enum { CLIENTS = 4 };
    pthread_t t[CLIENTS];
    drain_job jobs[CLIENTS] = {{0}};
    for (int i = 0; i < CLIENTS; i++)
        assert_int_equal(pthread_create(&t[i], NULL, drain_client, &jobs[i]), 0);
    struct timespec wait = {0, 30 * 1000 * 1000};
    nanosleep(&wait, NULL);
    assert_int_equal(kill(daemon_a, SIGTERM), 0);
    int ok = 0;
    for (int i = 0; i < CLIENTS; i++) {
        pthread_join(t[i], NULL);
        /* Taken before the signal: answered. Arrived after: told so, never silence. */
        assert_true(jobs[i].status == TRIOCT_OK || jobs[i].status == TRIOCT_ERR_STOPPING);
        ok += jobs[i].status == TRIOCT_OK;
    }
    assert_true(ok > 0);
    assert_int_equal(daemon_proc_wait_exit(daemon_a, 10000), 0);
    daemon_a = -1;
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: e2e_daemon TRIOCTD (inside tests/e2e/netns.sh)\n");
        return 2;
    }
    daemon_bin = argv[1];
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_answers_equal_the_engine),
        cmocka_unit_test(test_concurrent_clients),
        cmocka_unit_test(test_two_daemons_answer_once),
        cmocka_unit_test(test_error_replies),
        cmocka_unit_test(test_hostile_bytes_counted),
        cmocka_unit_test(test_changes_need_the_key_over_the_bus),
        cmocka_unit_test(test_hostile_files_leave_the_daemon_serving),
        cmocka_unit_test(test_sighup_reload_under_load),
        cmocka_unit_test(test_sigterm_answers_in_flight),
    };
    return cmocka_run_group_tests_name("e2e_daemon", tests, group_setup, group_teardown);
}
