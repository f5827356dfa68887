/* The real daemon loop end to end over LCM logs, no network: each test writes a scene, an
 * OBJ world and a request log (requests encoded with the generated encoders, plus bytes
 * that are not requests), runs daemon_run in a forked child with
 * --url file://IN --publish-url file://OUT, and reads OUT back. Replies are matched by
 * request id, never by position: the workers finish in any order.
 *
 *   replay:  every well-formed request answered once with the right status and answer,
 *            malformed bytes dropped and counted, requests for worlds not held unheard,
 *            status messages from STARTING to a final STOPPING with exact counters;
 *   busy:    a queue depth of 2 against 100 requests read in one wake-up;
 *   reload:  SIGHUP rebuilds a changed world (new answers), keeps a world whose rebuild
 *            fails (old answers, error in status), adds a new one, unloads one whose
 *            section left, keeps the ones an admin LOAD brought, and survives a scene
 *            with a syntax error;
 *   sigterm: the work in hand is answered, newer requests get STOPPING, exit 0;
 *   inline:  small requests answered on the loop thread get the bytes the workers give,
 *            with --ordered too, and the same counters. */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <cmocka.h>
#include <lcm/eventlog.h>

#include "service/daemon.h"
#include "support/daemon_proc.h"
#include "support/scratch.h"
#include "service/dispatch.h"
#include "service/log.h"
#include "service/options.h"
#include "trioct_admin_reply_t.h"
#include "admin_key.h"
#include "trioct_admin_request_t.h"
#include "trioct_mesh_reply_t.h"
#include "trioct_mesh_request_t.h"
#include "trioct_ray_reply_t.h"
#include "trioct_ray_request_t.h"
#include "trioct_ray_request_v1_t.h"
#include "trioct_reply_header_t.h"
#include "trioct_status.h"
#include "trioct_status_t.h"
#include "trioct_triangle_reply_t.h"
#include "trioct_triangle_request_t.h"

#define PREFIX "TLOG"
#define DAEMON_NAME "d1"
#define TEST_KEY_HEX "00112233445566778899aabbccddeeff00112233445566778899aabbccddeeff"
#define CLIENT_ID 4242
#define REPLY_RAY "CLIENT_RAY"
#define REPLY_TRI "CLIENT_TRI"
#define REPLY_MESH "CLIENT_MESH"
#define REPLY_ADMIN "CLIENT_ADMIN"
#define CHILD_TIMEOUT_MS 120000

/* ---------- scratch directory ---------- */

/* The unit cube [0,1]^3, two triangles a face, outward normals. */
static const char box_obj[] = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                              "v 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                              "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\n"
                              "f 1 2 6\nf 1 6 5\nf 4 8 7\nf 4 7 3\n"
                              "f 1 5 8\nf 1 8 4\nf 2 3 7\nf 2 7 6\n";

/* A scratch directory holding the unit cube. */
static void scratch_setup(scratch *s)
{
    scratch_init(s, "daemon_log");
    scratch_write(s, "box.obj", box_obj);
    /* The daemon's admin key, which the logs' LOADs and UNLOADs are signed with. */
    char path[256];
    scratch_path(s, "admin.key", path, sizeof path);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(TEST_KEY_HEX "\n", f);
    assert_int_equal(fclose(f), 0);
    assert_int_equal(chmod(path, 0600), 0);
}

static trioct_admin_key test_key(void)
{
    trioct_admin_key key;
    assert_int_equal(trioct_admin_key_from_hex(TEST_KEY_HEX, sizeof TEST_KEY_HEX - 1, &key), 0);
    return key;
}

/* Only the names the tests write are removed. */
static void scratch_teardown(const scratch *s)
{
    static const char *const names[] = {"scene.ini", "scene.tmp", "box.obj", "big.obj", "in.log", "out.log",
                                        "daemon.log", "admin.key", NULL};
    scratch_remove(s, names);
}

/* ---------- the request log ---------- */

typedef struct request_log {
    lcm_eventlog_t *log;
    int64_t t0;
} request_log;

static int64_t now_utime(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (int64_t)ts.tv_sec * 1000000 + ts.tv_nsec / 1000;
}

static void log_open(request_log *rl, const scratch *s)
{
    char path[256];
    scratch_path(s, "in.log", path, sizeof path);
    rl->log = lcm_eventlog_create(path, "w");
    assert_non_null(rl->log);
    rl->t0 = now_utime();
}

/* Writes one event at t0 + at_us. */
static void log_bytes(request_log *rl, int64_t at_us, const char *channel, const void *data, int len)
{
    lcm_eventlog_event_t ev;
    memset(&ev, 0, sizeof ev);
    ev.timestamp = rl->t0 + at_us;
    ev.channellen = (int32_t)strlen(channel);
    ev.datalen = len;
    ev.channel = (char *)channel;
    ev.data = (void *)data;
    assert_int_equal(lcm_eventlog_write_event(rl->log, &ev), 0);
}

static void log_close(request_log *rl)
{
    lcm_eventlog_destroy(rl->log);
    rl->log = NULL;
}

static trioct_request_header_t header(int64_t id, const char *reply, const char *world)
{
    trioct_request_header_t h;
    memset(&h, 0, sizeof h);
    h.client_id = CLIENT_ID;
    h.request_id = id;
    h.reply_channel = (char *)reply;
    h.world = (char *)world;
    h.deadline_utime = 0;
    return h;
}

static trioct_vec3_t v3(double x, double y, double z)
{
    return (trioct_vec3_t){x, y, z};
}

/* A ray request of n rays, encoded into buf (caller frees). */
static uint8_t *encode_rays(int64_t id, const char *world, int8_t detail, int n,
                            const trioct_vec3_t *origin, const trioct_vec3_t *direction,
                            int64_t deadline, int *len)
{
    trioct_ray_request_t m;
    memset(&m, 0, sizeof m);
    m.header = header(id, REPLY_RAY, world);
    m.header.deadline_utime = deadline;
    m.detail = detail;
    m.accuracy = TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD;
    m.tmin = 0;
    m.tmax = INFINITY;
    m.max_hits = 1;
    m.num_rays = n;
    m.origin = (trioct_vec3_t *)origin;
    m.direction = (trioct_vec3_t *)direction;
    *len = trioct_ray_request_t_encoded_size(&m);
    uint8_t *buf = malloc((size_t)*len);
    assert_non_null(buf);
    assert_int_equal(trioct_ray_request_t_encode(buf, 0, *len, &m), *len);
    return buf;
}

/* One CLOSEST ray up the z axis from below the cube, on the channel of `channel_world`. */
static void log_ray_up(request_log *rl, int64_t at_us, const char *channel_world, int64_t id,
                       const char *header_world, double ox, double oy)
{
    char ch[64];
    snprintf(ch, sizeof ch, PREFIX "_RAY_%s", channel_world);
    trioct_vec3_t o = v3(ox, oy, -1), dir = v3(0, 0, 1);
    int len;
    uint8_t *buf = encode_rays(id, header_world, TRIOCT_RAY_REQUEST_T_CLOSEST, 1, &o, &dir, 0, &len);
    log_bytes(rl, at_us, ch, buf, len);
    free(buf);
}

static void log_admin(request_log *rl, int64_t at_us, const char *channel, int64_t id,
                      const char *world, int8_t op, const char *mesh_path, int32_t effects)
{
    trioct_admin_request_t m;
    memset(&m, 0, sizeof m);
    m.header = header(id, REPLY_ADMIN, world);
    m.op = op;
    m.mesh_path = (char *)mesh_path;
    m.resolution = 0;
    m.accuracy = TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD;
    m.seed_epsilon = 0;
    m.effects = effects;
    int len = trioct_admin_request_t_encoded_size(&m);
    uint8_t *buf = malloc((size_t)len);
    assert_non_null(buf);
    assert_int_equal(trioct_admin_request_t_encode(buf, 0, len, &m), len);
    trioct_admin_key key = test_key();
    trioct_admin_sign(&key, channel, buf, (size_t)len, rl->t0 + at_us);
    log_bytes(rl, at_us, channel, buf, len);
    free(buf);
}

/* ---------- running the daemon ---------- */

static void sleep_ms(int ms)
{
    struct timespec ts = {ms / 1000, (long)(ms % 1000) * 1000000};
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR)
        ;
}

typedef struct run {
    pid_t pid;
    char log_path[256];
} run;

/* Starts daemon_run in a child with the scratch scene and logs plus extra arguments. The
 * child's stdout (the daemon's log) goes to daemon.log. */
static void daemon_start(run *r, const scratch *s, const char *in_query, const char *const *extra)
{
    char scene_file[256], in[256], out[256], in_url[320], out_url[320], key_file[256];
    scratch_path(s, "scene.ini", scene_file, sizeof scene_file);
    scratch_path(s, "admin.key", key_file, sizeof key_file);
    scratch_path(s, "in.log", in, sizeof in);
    scratch_path(s, "out.log", out, sizeof out);
    scratch_path(s, "daemon.log", r->log_path, sizeof r->log_path);
    snprintf(in_url, sizeof in_url, "file://%s%s", in, in_query);
    snprintf(out_url, sizeof out_url, "file://%s?mode=w", out);

    char *argv[32];
    int argc = 0;
    argv[argc++] = "trioctd";
    argv[argc++] = "--scene";
    argv[argc++] = scene_file;
    argv[argc++] = "--url";
    argv[argc++] = in_url;
    argv[argc++] = "--publish-url";
    argv[argc++] = out_url;
    argv[argc++] = "--loader";
    argv[argc++] = (char *)daemon_proc_loader();
    argv[argc++] = "--admin-key-file";
    argv[argc++] = key_file;
    for (int i = 0; extra != NULL && extra[i] != NULL; i++)
        argv[argc++] = (char *)extra[i];
    argv[argc] = NULL;

    fflush(NULL); /* the child must not write the parent's buffered output again */
    r->pid = fork();
    assert_true(r->pid >= 0);
    if (r->pid == 0) {
        if (freopen(r->log_path, "w", stdout) == NULL)
            _exit(97);
        dup2(fileno(stdout), STDERR_FILENO);
        log_init();
        daemon_options opt;
        scene sc;
        char err[2048];
        if (options_load(&opt, argc, argv, &sc, err, sizeof err) != OPTIONS_RUN) {
            printf("options: %s\n", err);
            fflush(stdout);
            _exit(98);
        }
        int rc = daemon_run(&opt, &sc);
        fflush(stdout);
        /* exit, not _exit: under the sanitizers LeakSanitizer checks the daemon here. */
        exit(rc);
    }
}

static void print_daemon_log(const run *r)
{
    FILE *f = fopen(r->log_path, "r");
    if (f == NULL)
        return;
    char line[1024];
    fprintf(stderr, "---- daemon log ----\n");
    while (fgets(line, sizeof line, f) != NULL)
        fputs(line, stderr);
    fprintf(stderr, "--------------------\n");
    fclose(f);
}

/* Waits for the child's exit and checks its exit status; fails the test, with the daemon's
 * log, on another status, a signal or a timeout. */
static void daemon_expect_exit(run *r, int want)
{
    for (int waited = 0; waited < CHILD_TIMEOUT_MS; waited += 10) {
        int st;
        pid_t p = waitpid(r->pid, &st, WNOHANG);
        if (p == r->pid) {
            if (WIFSIGNALED(st)) {
                print_daemon_log(r);
                fail_msg("the daemon died of signal %d", WTERMSIG(st));
            }
            int code = WEXITSTATUS(st);
            if (code != want) {
                print_daemon_log(r);
                fail_msg("the daemon exited with %d, expected %d", code, want);
            }
            return;
        }
        sleep_ms(10);
    }
    kill(r->pid, SIGKILL);
    waitpid(r->pid, NULL, 0);
    print_daemon_log(r);
    fail_msg("the daemon did not exit within %d ms", CHILD_TIMEOUT_MS);
}

static int count_in_file(const char *path, const char *needle)
{
    FILE *f = fopen(path, "r");
    if (f == NULL)
        return 0;
    int n = 0;
    char line[2048];
    while (fgets(line, sizeof line, f) != NULL)
        if (strstr(line, needle) != NULL)
            n++;
    fclose(f);
    return n;
}

/* Waits until the daemon's log holds at least `times` lines containing needle. */
static void wait_for_log(run *r, const char *needle, int times)
{
    for (int waited = 0; waited < CHILD_TIMEOUT_MS; waited += 5) {
        if (count_in_file(r->log_path, needle) >= times)
            return;
        int st;
        if (waitpid(r->pid, &st, WNOHANG) == r->pid) {
            print_daemon_log(r);
            fail_msg("the daemon exited (status 0x%x) before logging '%s'", st, needle);
        }
        sleep_ms(5);
    }
    kill(r->pid, SIGKILL);
    waitpid(r->pid, NULL, 0);
    print_daemon_log(r);
    fail_msg("the daemon never logged '%s'", needle);
}

/* ---------- reading the replies ---------- */

typedef struct reply_rec {
    int type; /* REQUEST_* */
    int64_t client_id, request_id, world_version;
    int status;
    int chunk_index, chunk_count;
    char world[64];
    char message[512];
    int num_found;
    int found[8];
    int num_hits;
    double hit_t[8];
    int num_worlds;
    char world_names[8][64];
    int64_t world_versions[8];
} reply_rec;

typedef struct replay_out {
    reply_rec replies[256];
    size_t reply_count;
    trioct_status_t statuses[512];
    size_t status_count;
    size_t other_events;
} replay_out;

static void fill_head(reply_rec *r, const trioct_reply_header_t *h)
{
    r->client_id = h->client_id;
    r->request_id = h->request_id;
    r->world_version = h->world_version;
    r->status = h->status;
    r->chunk_index = h->chunk_index;
    r->chunk_count = h->chunk_count;
    snprintf(r->world, sizeof r->world, "%s", h->world);
    snprintf(r->message, sizeof r->message, "%s", h->message);
}

static void fill_worlds(reply_rec *r, int n, const trioct_world_info_t *w)
{
    r->num_worlds = n;
    for (int i = 0; i < n && i < 8; i++) {
        snprintf(r->world_names[i], sizeof r->world_names[i], "%s", w[i].name);
        r->world_versions[i] = w[i].version;
    }
}

static void read_out(const scratch *s, replay_out *out)
{
    memset(out, 0, sizeof *out);
    char path[256];
    scratch_path(s, "out.log", path, sizeof path);
    lcm_eventlog_t *log = lcm_eventlog_create(path, "r");
    assert_non_null(log);
    lcm_eventlog_event_t *ev;
    while ((ev = lcm_eventlog_read_next_event(log)) != NULL) {
        const char *ch = ev->channel;
        reply_rec *r = &out->replies[out->reply_count];
        if (strcmp(ch, PREFIX "_STATUS") == 0) {
            assert_true(out->status_count < sizeof out->statuses / sizeof out->statuses[0]);
            assert_true(trioct_status_t_decode(ev->data, 0, ev->datalen,
                                               &out->statuses[out->status_count]) >= 0);
            out->status_count++;
        } else if (strcmp(ch, REPLY_RAY) == 0) {
            trioct_ray_reply_t m;
            assert_true(trioct_ray_reply_t_decode(ev->data, 0, ev->datalen, &m) >= 0);
            r->type = REQUEST_RAY;
            fill_head(r, &m.header);
            r->num_found = m.num_rays;
            for (int i = 0; i < m.num_rays && i < 8; i++)
                r->found[i] = m.found[i];
            r->num_hits = m.num_hits;
            for (int i = 0; i < m.num_hits && i < 8; i++)
                r->hit_t[i] = m.hits[i].t;
            trioct_ray_reply_t_decode_cleanup(&m);
            out->reply_count++;
        } else if (strcmp(ch, REPLY_TRI) == 0) {
            trioct_triangle_reply_t m;
            assert_true(trioct_triangle_reply_t_decode(ev->data, 0, ev->datalen, &m) >= 0);
            r->type = REQUEST_TRIANGLE;
            fill_head(r, &m.header);
            r->num_found = m.num_triangles;
            for (int i = 0; i < m.num_triangles && i < 8; i++)
                r->found[i] = m.found[i];
            trioct_triangle_reply_t_decode_cleanup(&m);
            out->reply_count++;
        } else if (strcmp(ch, REPLY_MESH) == 0) {
            trioct_mesh_reply_t m;
            assert_true(trioct_mesh_reply_t_decode(ev->data, 0, ev->datalen, &m) >= 0);
            r->type = REQUEST_MESH;
            fill_head(r, &m.header);
            trioct_mesh_reply_t_decode_cleanup(&m);
            out->reply_count++;
        } else if (strcmp(ch, REPLY_ADMIN) == 0) {
            trioct_admin_reply_t m;
            assert_true(trioct_admin_reply_t_decode(ev->data, 0, ev->datalen, &m) >= 0);
            r->type = REQUEST_ADMIN;
            fill_head(r, &m.header);
            fill_worlds(r, m.num_worlds, m.worlds);
            trioct_admin_reply_t_decode_cleanup(&m);
            out->reply_count++;
        } else {
            out->other_events++;
        }
        assert_true(out->reply_count < sizeof out->replies / sizeof out->replies[0]);
        lcm_eventlog_free_event(ev);
    }
    lcm_eventlog_destroy(log);
}

static void free_out(replay_out *out)
{
    for (size_t i = 0; i < out->status_count; i++)
        trioct_status_t_decode_cleanup(&out->statuses[i]);
    out->status_count = 0;
}

static size_t count_replies(const replay_out *out, int64_t id)
{
    size_t n = 0;
    for (size_t i = 0; i < out->reply_count; i++)
        if (out->replies[i].request_id == id)
            n++;
    return n;
}

/* The one reply to request id, checked to be whole (one chunk) and to echo the client. */
static const reply_rec *reply_to(const replay_out *out, int64_t id)
{
    const reply_rec *found = NULL;
    for (size_t i = 0; i < out->reply_count; i++) {
        if (out->replies[i].request_id != id)
            continue;
        if (found != NULL)
            fail_msg("request %lld answered twice", (long long)id);
        found = &out->replies[i];
    }
    if (found == NULL)
        fail_msg("request %lld has no reply", (long long)id);
    assert_int_equal(found->client_id, CLIENT_ID);
    assert_int_equal(found->chunk_index, 0);
    assert_int_equal(found->chunk_count, 1);
    return found;
}

static const reply_rec *expect_status(const replay_out *out, int64_t id, int type, int status)
{
    const reply_rec *r = reply_to(out, id);
    if (r->status != status || r->type != type)
        fail_msg("request %lld: type %d status %s (%s), expected type %d status %s", (long long)id,
                 r->type, trioct_status_name(r->status), r->message, type, trioct_status_name(status));
    return r;
}

static const trioct_world_info_t *status_world(const trioct_status_t *st, const char *name)
{
    for (int i = 0; i < st->num_worlds; i++)
        if (strcmp(st->worlds[i].name, name) == 0)
            return &st->worlds[i];
    return NULL;
}

/* What every status message says whatever the test. */
static void check_statuses(const replay_out *out, int64_t want_latency_count)
{
    assert_true(out->status_count >= 3);
    int64_t latency_count = 0;
    for (size_t i = 0; i < out->status_count; i++) {
        const trioct_status_t *st = &out->statuses[i];
        assert_string_equal(st->daemon, DAEMON_NAME);
        assert_string_equal(st->version, TRIOCT_VERSION);
        assert_int_equal(st->num_status_codes, TRIOCT_WIRE_STATUS_COUNT);
        assert_true(st->uptime_us >= 0);
        assert_true(st->queue_depth >= 0 && st->queue_depth <= st->queue_capacity);
        if (i > 0) {
            assert_true(st->uptime_us >= out->statuses[i - 1].uptime_us);
            assert_true(st->malformed >= out->statuses[i - 1].malformed);
        }
        latency_count += st->latency_count;
        /* Every answered request is counted once by type and once by status. */
        int64_t served = 0, by_status = 0;
        for (int t = 0; t < 4; t++)
            served += st->served[t];
        for (int c = 0; c < st->num_status_codes; c++)
            by_status += st->replies_by_status[c];
        assert_int_equal(served, by_status);
    }
    /* Published at start, before any world is built, and last as the daemon stops. */
    assert_int_equal(out->statuses[0].state, TRIOCT_STATUS_T_STARTING);
    const trioct_status_t *last = &out->statuses[out->status_count - 1];
    assert_int_equal(last->state, TRIOCT_STATUS_T_STOPPING);
    assert_int_equal(last->queue_depth, 0);
    /* Each interval's latencies are reported once: over the run they add up to the
     * requests that went through the workers. */
    assert_int_equal(latency_count, want_latency_count);
}

/* ---------- replay: every request type, every kind of bad input ---------- */

static void test_replay_answers_every_request(void **state)
{
    (void)state;
    scratch s;
    scratch_setup(&s);
    scratch_write_scene(&s, "[daemon]\n"
                    "prefix = " PREFIX "\n"
                    "name = " DAEMON_NAME "\n"
                    "status_interval = 50\n"
                    "\n"
                    "[box]\n"
                    "mesh = box.obj\n"
                    "effects = rays triangles\n"
                    "\n"
                    "[broken]\n"
                    "mesh = missing.obj\n");

    request_log rl;
    log_open(&rl, &s);
    int len;
    uint8_t *buf;

    /* 1: one closest hit, on the bottom face at t = 1. */
    log_ray_up(&rl, 0, "box", 1, "box", 0.25, 0.6);
    /* 2: ANY over two rays, the second beside the cube. */
    {
        trioct_vec3_t o[2] = {v3(0.7, 0.2, -1), v3(5, 5, -1)}, d[2] = {v3(0, 0, 1), v3(0, 0, 1)};
        buf = encode_rays(2, "box", TRIOCT_RAY_REQUEST_T_ANY, 2, o, d, 0, &len);
        log_bytes(&rl, 0, PREFIX "_RAY_box", buf, len);
        free(buf);
    }
    /* 3: a zero direction; 4: a NaN origin; 5: a deadline in 1970. */
    {
        trioct_vec3_t o = v3(0.5, 0.5, -1), zero = v3(0, 0, 0), up = v3(0, 0, 1), bad = v3(NAN, 0, 0);
        buf = encode_rays(3, "box", TRIOCT_RAY_REQUEST_T_CLOSEST, 1, &o, &zero, 0, &len);
        log_bytes(&rl, 0, PREFIX "_RAY_box", buf, len);
        free(buf);
        buf = encode_rays(4, "box", TRIOCT_RAY_REQUEST_T_CLOSEST, 1, &bad, &up, 0, &len);
        log_bytes(&rl, 0, PREFIX "_RAY_box", buf, len);
        free(buf);
        buf = encode_rays(5, "box", TRIOCT_RAY_REQUEST_T_CLOSEST, 1, &o, &up, 1, &len);
        log_bytes(&rl, 0, PREFIX "_RAY_box", buf, len);
        free(buf);
    }
    /* 6: two triangles, yes/no: one through the bottom face, one far away. */
    {
        trioct_triangle_t tris[2] = {
            {v3(0.3, 0.3, -0.5), v3(0.6, 0.3, 0.5), v3(0.3, 0.6, 0.5)},
            {v3(5, 5, 5), v3(6, 5, 5), v3(5, 6, 5)},
        };
        trioct_triangle_request_t m;
        memset(&m, 0, sizeof m);
        m.header = header(6, REPLY_TRI, "box");
        m.detail = TRIOCT_TRIANGLE_REQUEST_T_YESNO;
        m.accuracy = TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD;
        m.num_triangles = 2;
        m.triangles = tris;
        len = trioct_triangle_request_t_encoded_size(&m);
        buf = malloc((size_t)len);
        assert_int_equal(trioct_triangle_request_t_encode(buf, 0, len, &m), len);
        log_bytes(&rl, 0, PREFIX "_TRI_box", buf, len);
        free(buf);
    }
    /* 7: a mesh query on a world that serves rays and triangles only. */
    {
        trioct_triangle_t shape = {v3(0, 0, 0), v3(1, 0, 0), v3(0, 1, 0)};
        trioct_pose_t pose;
        memset(&pose, 0, sizeof pose);
        pose.r[0] = pose.r[4] = pose.r[8] = 1;
        trioct_mesh_request_t m;
        memset(&m, 0, sizeof m);
        m.header = header(7, REPLY_MESH, "box");
        m.detail = TRIOCT_MESH_REQUEST_T_YESNO;
        m.accuracy = TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD;
        m.shape = "";
        m.num_shape_triangles = 1;
        m.shape_triangles = &shape;
        m.num_poses = 1;
        m.poses = &pose;
        len = trioct_mesh_request_t_encoded_size(&m);
        buf = malloc((size_t)len);
        assert_int_equal(trioct_mesh_request_t_encode(buf, 0, len, &m), len);
        log_bytes(&rl, 0, PREFIX "_MESH_box", buf, len);
        free(buf);
    }
    /* 8: INFO; 9: LIST; 10: LOAD of a mesh path; 11: LOAD of a path escaping the world
     * directory. */
    log_admin(&rl, 0, PREFIX "_ADMIN_box", 8, "box", TRIOCT_ADMIN_REQUEST_T_INFO, "", 0);
    log_admin(&rl, 0, PREFIX "_LIST", 9, "", TRIOCT_ADMIN_REQUEST_T_LIST, "", 0);
    log_admin(&rl, 0, PREFIX "_LOAD_" DAEMON_NAME, 10, "box2", TRIOCT_ADMIN_REQUEST_T_LOAD, "box.obj",
              TRIOCT_WORLD_INFO_T_EFFECT_RAYS);
    log_admin(&rl, 0, PREFIX "_LOAD_" DAEMON_NAME, 11, "esc", TRIOCT_ADMIN_REQUEST_T_LOAD,
              "../outside.obj", 0);
    /* 12: a header naming another world than its channel. */
    log_ray_up(&rl, 0, "box", 12, "other", 0.5, 0.5);
    /* 13: a world of the scene whose build failed: answered ERR_LOAD_FAILED with why.
     * 14: another daemon's LOAD, whose channel is not heard: no reply, nothing counted. */
    log_ray_up(&rl, 0, "broken", 13, "broken", 0.5, 0.5);
    log_admin(&rl, 0, PREFIX "_LOAD_other", 14, "w", TRIOCT_ADMIN_REQUEST_T_LOAD, "box.obj", 0);

    /* Malformed, all on a heard channel: bytes that are no message, a request cut short, a
     * ray request on the triangle channel (wrong fingerprint), a reply channel that is a
     * protocol channel, and an empty reply channel. */
    log_bytes(&rl, 0, PREFIX "_RAY_box", "hello", 5);
    {
        trioct_vec3_t o = v3(0.5, 0.5, -1), up = v3(0, 0, 1);
        buf = encode_rays(90, "box", TRIOCT_RAY_REQUEST_T_CLOSEST, 1, &o, &up, 0, &len);
        log_bytes(&rl, 0, PREFIX "_RAY_box", buf, len - 3);
        log_bytes(&rl, 0, PREFIX "_TRI_box", buf, len);
        free(buf);

        trioct_ray_request_t m;
        memset(&m, 0, sizeof m);
        m.header = header(91, PREFIX "_STATUS", "box");
        m.detail = TRIOCT_RAY_REQUEST_T_CLOSEST;
        m.tmax = INFINITY;
        m.num_rays = 1;
        m.origin = &o;
        m.direction = &up;
        len = trioct_ray_request_t_encoded_size(&m);
        buf = malloc((size_t)len);
        assert_int_equal(trioct_ray_request_t_encode(buf, 0, len, &m), len);
        log_bytes(&rl, 0, PREFIX "_RAY_box", buf, len);
        free(buf);
        m.header = header(92, "", "box");
        len = trioct_ray_request_t_encoded_size(&m);
        buf = malloc((size_t)len);
        assert_int_equal(trioct_ray_request_t_encode(buf, 0, len, &m), len);
        log_bytes(&rl, 0, PREFIX "_RAY_box", buf, len);
        free(buf);
    }
    log_close(&rl);

    run r;
    const char *extra[] = {"--exit-at-eof", "--log-level", "debug", NULL};
    daemon_start(&r, &s, "?speed=0", extra);
    daemon_expect_exit(&r, 0);

    replay_out *out = calloc(1, sizeof *out);
    assert_non_null(out);
    read_out(&s, out);

    const reply_rec *rr = expect_status(out, 1, REQUEST_RAY, TRIOCT_OK);
    assert_int_equal(rr->world_version, 1);
    assert_string_equal(rr->world, "box");
    assert_int_equal(rr->num_found, 1);
    assert_int_equal(rr->found[0], 1);
    assert_int_equal(rr->num_hits, 1);
    assert_true(rr->hit_t[0] == 1.0);

    rr = expect_status(out, 2, REQUEST_RAY, TRIOCT_OK);
    assert_int_equal(rr->num_found, 2);
    assert_int_equal(rr->found[0], 1);
    assert_int_equal(rr->found[1], 0);

    expect_status(out, 3, REQUEST_RAY, TRIOCT_ERR_ZERO_DIRECTION);
    expect_status(out, 4, REQUEST_RAY, TRIOCT_ERR_NONFINITE);
    expect_status(out, 5, REQUEST_RAY, TRIOCT_ERR_DEADLINE);

    rr = expect_status(out, 6, REQUEST_TRIANGLE, TRIOCT_OK);
    assert_int_equal(rr->num_found, 2);
    assert_int_equal(rr->found[0], 1);
    assert_int_equal(rr->found[1], 0);

    expect_status(out, 7, REQUEST_MESH, TRIOCT_ERR_EFFECT);

    rr = expect_status(out, 8, REQUEST_ADMIN, TRIOCT_OK);
    assert_int_equal(rr->num_worlds, 1);
    assert_string_equal(rr->world_names[0], "box");
    assert_int_equal(rr->world_versions[0], 1);

    /* LIST came before the LOAD in the log but may run after it on another worker: box is
     * there either way, box2 perhaps, and last broken, which failed to build: version 0. */
    rr = expect_status(out, 9, REQUEST_ADMIN, TRIOCT_OK);
    assert_true(rr->num_worlds == 2 || rr->num_worlds == 3);
    assert_string_equal(rr->world_names[0], "box");
    if (rr->num_worlds == 3)
        assert_string_equal(rr->world_names[1], "box2");
    assert_string_equal(rr->world_names[rr->num_worlds - 1], "broken");
    assert_int_equal(rr->world_versions[rr->num_worlds - 1], 0);

    rr = expect_status(out, 10, REQUEST_ADMIN, TRIOCT_OK);
    assert_int_equal(rr->world_version, 1);
    assert_int_equal(rr->num_worlds, 1);
    assert_string_equal(rr->world_names[0], "box2");

    expect_status(out, 11, REQUEST_ADMIN, TRIOCT_ERR_BAD_PATH);
    expect_status(out, 12, REQUEST_RAY, TRIOCT_ERR_BAD_REQUEST);
    rr = expect_status(out, 13, REQUEST_RAY, TRIOCT_ERR_LOAD_FAILED);
    assert_non_null(strstr(rr->message, "its build failed"));
    assert_int_equal(count_replies(out, 14), 0);
    for (int64_t id = 90; id <= 92; id++)
        assert_int_equal(count_replies(out, id), 0);
    assert_int_equal(out->reply_count, 13);
    assert_int_equal(out->other_events, 0);

    check_statuses(out, 13);
    const trioct_status_t *last = &out->statuses[out->status_count - 1];
    assert_int_equal(last->malformed, 5);
    assert_int_equal(last->served[REQUEST_RAY], 7);
    assert_int_equal(last->served[REQUEST_TRIANGLE], 1);
    assert_int_equal(last->served[REQUEST_MESH], 1);
    assert_int_equal(last->served[REQUEST_ADMIN], 4);
    int64_t want[TRIOCT_WIRE_STATUS_COUNT] = {0};
    want[TRIOCT_OK] = 6;
    want[TRIOCT_ERR_ZERO_DIRECTION] = 1;
    want[TRIOCT_ERR_NONFINITE] = 1;
    want[TRIOCT_ERR_DEADLINE] = 1;
    want[TRIOCT_ERR_EFFECT] = 1;
    want[TRIOCT_ERR_BAD_PATH] = 1;
    want[TRIOCT_ERR_BAD_REQUEST] = 1;
    want[TRIOCT_ERR_LOAD_FAILED] = 1;
    for (int c = 0; c < TRIOCT_WIRE_STATUS_COUNT; c++)
        assert_int_equal(last->replies_by_status[c], want[c]);

    /* The worlds: box and the loaded box2 at version 1, broken reported with its error. */
    assert_int_equal(last->num_worlds, 3);
    const trioct_world_info_t *w = status_world(last, "box");
    assert_non_null(w);
    assert_int_equal(w->version, 1);
    assert_int_equal(w->triangles, 12);
    assert_string_equal(w->last_error, "");
    w = status_world(last, "box2");
    assert_non_null(w);
    assert_int_equal(w->version, 1);
    assert_int_equal(w->effects, TRIOCT_WORLD_INFO_T_EFFECT_RAYS);
    w = status_world(last, "broken");
    assert_non_null(w);
    assert_int_equal(w->version, 0);
    assert_non_null(strstr(w->last_error, "missing.obj"));
    assert_string_equal(w->daemon, DAEMON_NAME);

    /* A READY status came before the end, and the log says why broken is missing. */
    int ready = 0;
    for (size_t i = 0; i < out->status_count; i++)
        ready |= out->statuses[i].state == TRIOCT_STATUS_T_READY;
    assert_true(ready);
    assert_int_equal(count_in_file(r.log_path, "world 'broken' could not be loaded"), 1);
    assert_int_equal(count_in_file(r.log_path, "dropped a malformed"), 5);

    free_out(out);
    free(out);
    scratch_teardown(&s);
}

/* ---------- backpressure ---------- */

static void test_replay_busy(void **state)
{
    (void)state;
    /* With speed=0 the whole log is readable at once, so one wake-up of the loop reads all
     * of it (fewer messages than its budget) before any finished work is published: the
     * first two requests fill the queue and the other 98 get BUSY at once. One-ray requests
     * are small, so the loop thread answers the two it takes itself, and they count as in
     * hand until the wake-up ends: BUSY comes exactly as when they go to a worker
     * (--no-inline). */
    enum { N = 100, DEPTH = 2 };
    _Static_assert(N < DAEMON_PUMP_BUDGET, "the test needs every request read in one wake-up");
    scratch s;
    scratch_setup(&s);
    scratch_write_scene(&s, "[daemon]\nprefix = " PREFIX "\nname = " DAEMON_NAME "\n\n[box]\nmesh = box.obj\n");
    request_log rl;
    log_open(&rl, &s);
    for (int i = 0; i < N; i++)
        log_ray_up(&rl, 0, "box", 1000 + i, "box", 0.25, 0.6);
    log_close(&rl);

    static const char *const modes[][10] = {
        {"--exit-at-eof", "--queue-depth", "2", "--threads", "1", "--log-level", "debug", NULL},
        {"--exit-at-eof", "--queue-depth", "2", "--threads", "1", "--log-level", "debug", "--no-inline", NULL},
    };
    static const char *const answered_on[] = {"on the loop thread", "on a worker"};
    for (int mode = 0; mode < 2; mode++) {
        run r;
        daemon_start(&r, &s, "?speed=0", modes[mode]);
        daemon_expect_exit(&r, 0);
        assert_int_equal(count_in_file(r.log_path, answered_on[mode]), DEPTH);

        replay_out *out = calloc(1, sizeof *out);
        assert_non_null(out);
        read_out(&s, out);
        assert_int_equal(out->reply_count, N);
        int ok = 0, busy = 0;
        for (int i = 0; i < N; i++) {
            const reply_rec *rr = reply_to(out, 1000 + i);
            if (rr->status == TRIOCT_OK) {
                ok++;
                assert_true(rr->hit_t[0] == 1.0);
                assert_int_equal(rr->world_version, 1);
            } else {
                assert_int_equal(rr->status, TRIOCT_ERR_BUSY);
                assert_int_equal(rr->world_version, 0);
                assert_string_equal(rr->message, "the queue is full: 2 requests in hand (queue_depth 2)");
                busy++;
            }
        }
        /* The first two in the log are the ones taken. */
        assert_int_equal(reply_to(out, 1000)->status, TRIOCT_OK);
        assert_int_equal(reply_to(out, 1001)->status, TRIOCT_OK);
        assert_int_equal(ok, DEPTH);
        assert_int_equal(busy, N - DEPTH);

        check_statuses(out, DEPTH); /* BUSY replies did no work: no latency */
        const trioct_status_t *last = &out->statuses[out->status_count - 1];
        assert_int_equal(last->served[REQUEST_RAY], N);
        assert_int_equal(last->replies_by_status[TRIOCT_OK], DEPTH);
        assert_int_equal(last->replies_by_status[TRIOCT_ERR_BUSY], N - DEPTH);
        assert_int_equal(last->queue_capacity, DEPTH);
        assert_int_equal(last->threads, 1);
        assert_int_equal(last->malformed, 0);
        free_out(out);
        free(out);
    }
    scratch_teardown(&s);
}

/* ---------- SIGHUP ---------- */

static const char scene_v1[] = "[daemon]\n"
                               "prefix = " PREFIX "\n"
                               "name = " DAEMON_NAME "\n"
                               "status_interval = 100\n"
                               "\n"
                               "[box]\nmesh = box.obj\neffects = rays\n"
                               "\n"
                               "[gone]\nmesh = box.obj\n"
                               "\n"
                               "[flaky]\nmesh = box.obj\n"
                               "\n"
                               "[gone2]\nmesh = box.obj\n";

/* box moves up by 10, gone and gone2 leave, flaky's mesh is missing, fresh is new. */
static const char scene_v2[] = "[daemon]\n"
                               "prefix = " PREFIX "\n"
                               "name = " DAEMON_NAME "\n"
                               "status_interval = 100\n"
                               "\n"
                               "[box]\nmesh = box.obj\ntranslate = 0 0 10\neffects = rays\n"
                               "\n"
                               "[flaky]\nmesh = missing.obj\n"
                               "\n"
                               "[fresh]\nmesh = box.obj\n";

static void test_reload_on_sighup(void **state)
{
    (void)state;
    /* Real-time playback: the first requests run as soon as the daemon is ready, the
     * second group LATER_US afterwards, by which time the test has reloaded the scene
     * (twice: once changed, once with a syntax error). A reload of these worlds takes
     * milliseconds; three seconds leave room for a loaded machine. */
    const int64_t LATER_US = 3000000;
    scratch s;
    scratch_setup(&s);
    scratch_write_scene(&s, scene_v1);

    request_log rl;
    log_open(&rl, &s);
    log_ray_up(&rl, 0, "box", 1, "box", 0.25, 0.6);
    /* kept: loaded by path, in no scene. gone2: reloaded by path over its scene section,
     * so it no longer belongs to the scene and stays when the section leaves. */
    log_admin(&rl, 0, PREFIX "_LOAD_" DAEMON_NAME, 10, "kept", TRIOCT_ADMIN_REQUEST_T_LOAD, "box.obj",
              TRIOCT_WORLD_INFO_T_EFFECT_RAYS);
    log_admin(&rl, 0, PREFIX "_LOAD_" DAEMON_NAME, 11, "gone2", TRIOCT_ADMIN_REQUEST_T_LOAD, "box.obj",
              TRIOCT_WORLD_INFO_T_EFFECT_RAYS);
    log_ray_up(&rl, LATER_US, "box", 2, "box", 0.25, 0.6);
    log_ray_up(&rl, LATER_US, "gone", 3, "gone", 0.25, 0.6);
    log_ray_up(&rl, LATER_US, "kept", 4, "kept", 0.25, 0.6);
    log_ray_up(&rl, LATER_US, "flaky", 5, "flaky", 0.25, 0.6);
    log_ray_up(&rl, LATER_US, "fresh", 6, "fresh", 0.25, 0.6);
    log_ray_up(&rl, LATER_US, "gone2", 7, "gone2", 0.25, 0.6);
    log_close(&rl);

    run r;
    const char *extra[] = {"--exit-at-eof", "--log-level", "debug", NULL};
    daemon_start(&r, &s, "", extra);
    wait_for_log(&r, "ready:", 1);
    wait_for_log(&r, "on " PREFIX "_LOAD_" DAEMON_NAME " answered OK", 2);

    scratch_write_scene(&s, scene_v2);
    kill(r.pid, SIGHUP);
    wait_for_log(&r, "reload done", 1);
    /* A scene that does not parse changes nothing. */
    scratch_write_scene(&s, "[daemon\nprefix = " PREFIX "\n");
    kill(r.pid, SIGHUP);
    wait_for_log(&r, "the running scene stays", 1);
    daemon_expect_exit(&r, 0);

    replay_out *out = calloc(1, sizeof *out);
    assert_non_null(out);
    read_out(&s, out);

    const reply_rec *rr = expect_status(out, 1, REQUEST_RAY, TRIOCT_OK);
    assert_int_equal(rr->world_version, 1);
    assert_true(rr->hit_t[0] == 1.0);
    expect_status(out, 10, REQUEST_ADMIN, TRIOCT_OK);
    rr = expect_status(out, 11, REQUEST_ADMIN, TRIOCT_OK);
    assert_int_equal(rr->world_version, 2); /* gone2's second version */

    /* The rebuilt box: a new version, and the new answer (it moved up by 10). */
    rr = expect_status(out, 2, REQUEST_RAY, TRIOCT_OK);
    assert_int_equal(rr->world_version, 2);
    assert_true(rr->hit_t[0] == 11.0);
    /* gone left with its section: nobody listens any more. */
    assert_int_equal(count_replies(out, 3), 0);
    rr = expect_status(out, 4, REQUEST_RAY, TRIOCT_OK);
    assert_int_equal(rr->world_version, 1);
    /* flaky's rebuild failed: version 1 answers as before. */
    rr = expect_status(out, 5, REQUEST_RAY, TRIOCT_OK);
    assert_int_equal(rr->world_version, 1);
    assert_true(rr->hit_t[0] == 1.0);
    rr = expect_status(out, 6, REQUEST_RAY, TRIOCT_OK);
    assert_int_equal(rr->world_version, 1);
    rr = expect_status(out, 7, REQUEST_RAY, TRIOCT_OK);
    assert_int_equal(rr->world_version, 2);
    assert_int_equal(out->reply_count, 8);

    check_statuses(out, 8);
    const trioct_status_t *last = &out->statuses[out->status_count - 1];
    assert_int_equal(last->num_worlds, 5);
    assert_null(status_world(last, "gone"));
    const trioct_world_info_t *w = status_world(last, "box");
    assert_non_null(w);
    assert_int_equal(w->version, 2);
    w = status_world(last, "flaky");
    assert_non_null(w);
    assert_int_equal(w->version, 1);
    assert_non_null(strstr(w->last_error, "missing.obj"));
    w = status_world(last, "fresh");
    assert_non_null(w);
    assert_int_equal(w->version, 1);
    assert_string_equal(w->last_error, "");
    w = status_world(last, "kept");
    assert_non_null(w);
    assert_int_equal(w->version, 1);
    w = status_world(last, "gone2");
    assert_non_null(w);
    assert_int_equal(w->version, 2);

    assert_int_equal(count_in_file(r.log_path, "world 'gone' unloaded"), 1);
    assert_int_equal(count_in_file(r.log_path, "world 'flaky' could not be rebuilt"), 1);
    assert_int_equal(count_in_file(r.log_path, "reload done: 2 built, 1 failed, 1 unloaded, 0 unchanged"), 1);
    free_out(out);
    free(out);
    scratch_teardown(&s);
}

/* ---------- SIGTERM ---------- */

/* A flat grid of 2 n^2 triangles: slow enough to load that a signal lands mid-build. */
static void write_grid(const scratch *s, const char *name, int n)
{
    char path[256];
    scratch_path(s, name, path, sizeof path);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    for (int j = 0; j <= n; j++)
        for (int i = 0; i <= n; i++)
            fprintf(f, "v %d %d %d\n", i, j, (i * 7 + j * 13) % 5);
    for (int j = 0; j < n; j++) {
        for (int i = 0; i < n; i++) {
            int a = j * (n + 1) + i + 1, b = a + 1, c = a + n + 1, d = c + 1;
            fprintf(f, "f %d %d %d\nf %d %d %d\n", a, b, d, a, d, c);
        }
    }
    assert_int_equal(fclose(f), 0);
}

static void test_sigterm_finishes_work_in_hand(void **state)
{
    (void)state;
    scratch s;
    scratch_setup(&s);
    write_grid(&s, "big.obj", 300);
    scratch_write_scene(&s, "[daemon]\nprefix = " PREFIX "\nname = " DAEMON_NAME "\n\n[box]\nmesh = box.obj\n");

    /* A LOAD that takes a while, then a ray 20 ms later, while the LOAD still runs; the
     * log stays open-ended (no --exit-at-eof): only the signal stops the daemon. */
    request_log rl;
    log_open(&rl, &s);
    log_admin(&rl, 0, PREFIX "_LOAD_" DAEMON_NAME, 1, "big", TRIOCT_ADMIN_REQUEST_T_LOAD, "big.obj", 0);
    log_ray_up(&rl, 20000, "box", 2, "box", 0.25, 0.6);
    log_close(&rl);

    run r;
    const char *extra[] = {"--log-level", "debug", NULL};
    daemon_start(&r, &s, "", extra);
    wait_for_log(&r, "ready:", 1);
    kill(r.pid, SIGTERM);
    daemon_expect_exit(&r, 0);

    replay_out *out = calloc(1, sizeof *out);
    assert_non_null(out);
    read_out(&s, out);
    /* The LOAD was in hand when the signal came: answered, and answered right. */
    const reply_rec *rr = expect_status(out, 1, REQUEST_ADMIN, TRIOCT_OK);
    assert_int_equal(rr->num_worlds, 1);
    assert_string_equal(rr->world_names[0], "big");
    /* The ray came after the signal: STOPPING if the daemon was still finishing the LOAD
     * when it arrived, else unheard (the daemon had gone). Never an answer. */
    if (count_replies(out, 2) == 1)
        expect_status(out, 2, REQUEST_RAY, TRIOCT_ERR_STOPPING);
    else
        assert_int_equal(count_replies(out, 2), 0);

    const trioct_status_t *last = &out->statuses[out->status_count - 1];
    assert_int_equal(last->state, TRIOCT_STATUS_T_STOPPING);
    assert_int_equal(last->served[REQUEST_ADMIN], 1);
    assert_int_equal(last->replies_by_status[TRIOCT_OK], 1);
    assert_non_null(status_world(last, "big"));
    assert_int_equal(count_in_file(r.log_path, "SIGTERM: stopping"), 1);
    assert_int_equal(count_in_file(r.log_path, "stopped:"), 1);
    free_out(out);
    free(out);
    scratch_teardown(&s);
}

/* ---------- answering on the loop thread ---------- */

/* Every reply chunk of a run, as bytes, by request id. */
typedef struct raw_reply {
    int64_t request_id;
    int status;
    char channel[32];
    int size;
    uint8_t *data;
} raw_reply;

typedef struct raw_out {
    raw_reply replies[64];
    size_t count;
} raw_out;

static void read_raw(const scratch *s, raw_out *out)
{
    memset(out, 0, sizeof *out);
    char path[256];
    scratch_path(s, "out.log", path, sizeof path);
    lcm_eventlog_t *log = lcm_eventlog_create(path, "r");
    assert_non_null(log);
    lcm_eventlog_event_t *ev;
    while ((ev = lcm_eventlog_read_next_event(log)) != NULL) {
        if (strncmp(ev->channel, "CLIENT_", 7) == 0) {
            assert_true(out->count < sizeof out->replies / sizeof out->replies[0]);
            raw_reply *r = &out->replies[out->count++];
            /* Every reply type starts with its fingerprint, then reply_header_t. */
            trioct_reply_header_t h;
            assert_true(__trioct_reply_header_t_decode_array(ev->data, 8, ev->datalen - 8, &h, 1) > 0);
            r->request_id = h.request_id;
            r->status = h.status;
            __trioct_reply_header_t_decode_array_cleanup(&h, 1);
            snprintf(r->channel, sizeof r->channel, "%s", ev->channel);
            r->size = ev->datalen;
            r->data = malloc((size_t)ev->datalen);
            assert_non_null(r->data);
            memcpy(r->data, ev->data, (size_t)ev->datalen);
        }
        lcm_eventlog_free_event(ev);
    }
    lcm_eventlog_destroy(log);
}

static void free_raw(raw_out *out)
{
    for (size_t i = 0; i < out->count; i++)
        free(out->replies[i].data);
    out->count = 0;
}

static const raw_reply *raw_reply_to(const raw_out *out, int64_t id)
{
    const raw_reply *found = NULL;
    for (size_t i = 0; i < out->count; i++) {
        if (out->replies[i].request_id != id)
            continue;
        if (found != NULL)
            fail_msg("request %lld answered twice", (long long)id);
        found = &out->replies[i];
    }
    if (found == NULL)
        fail_msg("request %lld has no reply", (long long)id);
    return found;
}

static void log_ray_request(request_log *rl, const char *world, const trioct_ray_request_t *m)
{
    char ch[64];
    snprintf(ch, sizeof ch, PREFIX "_RAY_%s", world);
    int len = trioct_ray_request_t_encoded_size(m);
    uint8_t *buf = malloc((size_t)len);
    assert_non_null(buf);
    assert_int_equal(trioct_ray_request_t_encode(buf, 0, len, m), len);
    log_bytes(rl, 0, ch, buf, len);
    free(buf);
}

/* n vertical rays up through the cube's bottom face, on a grid inside it. */
static void log_rays_up(request_log *rl, int64_t id, int n, int8_t detail, int8_t contact)
{
    trioct_vec3_t o[64], d[64];
    assert_true(n <= 64);
    for (int i = 0; i < n; i++) {
        o[i] = v3(0.05 + 0.9 * (i % 8) / 8.0, 0.05 + 0.9 * (i / 8) / 8.0, -1);
        d[i] = v3(0, 0, 1);
    }
    trioct_ray_request_t m;
    memset(&m, 0, sizeof m);
    m.header = header(id, REPLY_RAY, "box");
    m.detail = detail;
    m.accuracy = TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD;
    m.tmax = INFINITY;
    m.max_hits = 4;
    m.num_rays = n;
    m.origin = o;
    m.direction = d;
    m.contact = contact;
    log_ray_request(rl, "box", &m);
}

static void log_triangles(request_log *rl, int64_t id, const char *world, int8_t detail, int n,
                          const trioct_triangle_t *tris)
{
    char ch[64];
    snprintf(ch, sizeof ch, PREFIX "_TRI_%s", world);
    trioct_triangle_request_t m;
    memset(&m, 0, sizeof m);
    m.header = header(id, REPLY_TRI, world);
    m.detail = detail;
    m.accuracy = TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD;
    m.num_triangles = n;
    m.triangles = (trioct_triangle_t *)tris;
    int len = trioct_triangle_request_t_encoded_size(&m);
    uint8_t *buf = malloc((size_t)len);
    assert_non_null(buf);
    assert_int_equal(trioct_triangle_request_t_encode(buf, 0, len, &m), len);
    log_bytes(rl, 0, ch, buf, len);
    free(buf);
}

/* The same log answered by a daemon that answers small requests on its loop thread (the
 * default), one that hands every request to its workers (--no-inline), and an ordered one
 * (--ordered, which answers its small held requests on the loop thread): every reply is
 * the same bytes (but ERR_DEADLINE's message, which says how late, and INFO's build time and
 * query count, which depend on the clock), every counter the same,
 * and the daemon's log shows which thread answered what. */
static void test_inline_answers_are_the_workers(void **state)
{
    (void)state;
    scratch s;
    scratch_setup(&s);
    scratch_write_scene(&s, "[daemon]\nprefix = " PREFIX "\nname = " DAEMON_NAME "\nstatus_interval = 50\n\n"
                            "[box]\nmesh = box.obj\neffects = rays triangles\n\n"
                            "[raysonly]\nmesh = box.obj\neffects = rays\n");
    /* The cube's triangles make a resolution of 1: triangles within 16 are small. */
    const trioct_triangle_t through_bottom = {v3(0.3, 0.3, -0.5), v3(0.6, 0.3, 0.5), v3(0.3, 0.6, 0.5)};
    const trioct_triangle_t far_away = {v3(5, 5, 5), v3(6, 5, 5), v3(5, 6, 5)};
    const trioct_triangle_t across = {v3(-20, -20, 0.5), v3(20, -20, 0.5), v3(0, 20, 0.5)};
    trioct_triangle_t not_finite = through_bottom;
    not_finite.b.x = NAN;

    request_log rl;
    log_open(&rl, &s);
    int len;
    uint8_t *buf;
    log_rays_up(&rl, 1, 1, TRIOCT_RAY_REQUEST_T_CLOSEST, TRIOCT_RAY_REQUEST_T_CROSSING);  /* small */
    log_rays_up(&rl, 2, 8, TRIOCT_RAY_REQUEST_T_CLOSEST, TRIOCT_RAY_REQUEST_T_CROSSING);  /* small */
    log_rays_up(&rl, 3, 9, TRIOCT_RAY_REQUEST_T_CLOSEST, TRIOCT_RAY_REQUEST_T_CROSSING);  /* large */
    log_rays_up(&rl, 4, 40, TRIOCT_RAY_REQUEST_T_ALL, TRIOCT_RAY_REQUEST_T_CROSSING);     /* large */
    log_rays_up(&rl, 5, 2, TRIOCT_RAY_REQUEST_T_ALL, TRIOCT_RAY_REQUEST_T_TOUCH);         /* small */
    {
        /* 6: the layout before contact, one ray; small. */
        trioct_vec3_t o = v3(0.5, 0.5, 2), d = v3(0, 0, -1);
        trioct_ray_request_v1_t m;
        memset(&m, 0, sizeof m);
        m.header = header(6, REPLY_RAY, "box");
        m.detail = TRIOCT_RAY_REQUEST_T_CLOSEST;
        m.accuracy = TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD;
        m.tmax = INFINITY;
        m.num_rays = 1;
        m.origin = &o;
        m.direction = &d;
        len = trioct_ray_request_v1_t_encoded_size(&m);
        buf = malloc((size_t)len);
        assert_int_equal(trioct_ray_request_v1_t_encode(buf, 0, len, &m), len);
        log_bytes(&rl, 0, PREFIX "_RAY_box", buf, len);
        free(buf);
    }
    {
        /* 7: a zero direction; 8: a NaN origin; 9: a deadline in 1970; 10: a header naming
         * another world than its channel. All small, all errors. */
        trioct_vec3_t o = v3(0.5, 0.5, -1), zero = v3(0, 0, 0), up = v3(0, 0, 1), bad = v3(NAN, 0, 0);
        buf = encode_rays(7, "box", TRIOCT_RAY_REQUEST_T_CLOSEST, 1, &o, &zero, 0, &len);
        log_bytes(&rl, 0, PREFIX "_RAY_box", buf, len);
        free(buf);
        buf = encode_rays(8, "box", TRIOCT_RAY_REQUEST_T_CLOSEST, 1, &bad, &up, 0, &len);
        log_bytes(&rl, 0, PREFIX "_RAY_box", buf, len);
        free(buf);
        buf = encode_rays(9, "box", TRIOCT_RAY_REQUEST_T_CLOSEST, 1, &o, &up, 1, &len);
        log_bytes(&rl, 0, PREFIX "_RAY_box", buf, len);
        free(buf);
        log_ray_up(&rl, 0, "box", 10, "other", 0.5, 0.5);
    }
    log_triangles(&rl, 11, "box", TRIOCT_TRIANGLE_REQUEST_T_YESNO, 1, &through_bottom); /* small */
    {
        trioct_triangle_t two[2] = {through_bottom, far_away};
        log_triangles(&rl, 12, "box", TRIOCT_TRIANGLE_REQUEST_T_SEGMENTS, 2, two); /* small */
        trioct_triangle_t three[3] = {far_away, through_bottom, far_away};
        log_triangles(&rl, 13, "box", TRIOCT_TRIANGLE_REQUEST_T_IDS, 3, three); /* large: three */
    }
    log_triangles(&rl, 14, "box", TRIOCT_TRIANGLE_REQUEST_T_IDS, 1, &across);       /* large: 40 wide */
    log_triangles(&rl, 15, "box", TRIOCT_TRIANGLE_REQUEST_T_YESNO, 1, &not_finite); /* large: no size */
    log_triangles(&rl, 16, "raysonly", TRIOCT_TRIANGLE_REQUEST_T_YESNO, 1, &through_bottom); /* small */
    {
        /* 17: a mesh query (the world serves none); 18: INFO. Never small. */
        trioct_triangle_t shape = far_away;
        trioct_pose_t pose;
        memset(&pose, 0, sizeof pose);
        pose.r[0] = pose.r[4] = pose.r[8] = 1;
        trioct_mesh_request_t m;
        memset(&m, 0, sizeof m);
        m.header = header(17, REPLY_MESH, "box");
        m.detail = TRIOCT_MESH_REQUEST_T_YESNO;
        m.accuracy = TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD;
        m.shape = "";
        m.num_shape_triangles = 1;
        m.shape_triangles = &shape;
        m.num_poses = 1;
        m.poses = &pose;
        len = trioct_mesh_request_t_encoded_size(&m);
        buf = malloc((size_t)len);
        assert_int_equal(trioct_mesh_request_t_encode(buf, 0, len, &m), len);
        log_bytes(&rl, 0, PREFIX "_MESH_box", buf, len);
        free(buf);
        log_admin(&rl, 0, PREFIX "_ADMIN_box", 18, "box", TRIOCT_ADMIN_REQUEST_T_INFO, "", 0);
    }
    log_close(&rl);
    enum { REQUESTS = 18, SMALL = 11, DEADLINE_ID = 9, INFO_ID = 18 };

    static const char *const modes[][8] = {
        {"--exit-at-eof", "--log-level", "debug", "--threads", "2", "--no-inline", NULL},
        {"--exit-at-eof", "--log-level", "debug", "--threads", "2", NULL},
        {"--exit-at-eof", "--log-level", "debug", "--threads", "2", "--ordered", NULL},
    };
    static const int on_loop[] = {0, SMALL, SMALL};
    raw_out *raw = calloc(3, sizeof *raw);
    replay_out *out = calloc(3, sizeof *out);
    assert_non_null(raw);
    assert_non_null(out);
    for (int mode = 0; mode < 3; mode++) {
        run r;
        daemon_start(&r, &s, "?speed=0", modes[mode]);
        daemon_expect_exit(&r, 0);
        read_raw(&s, &raw[mode]);
        read_out(&s, &out[mode]);
        assert_int_equal(raw[mode].count, REQUESTS);
        assert_int_equal(count_in_file(r.log_path, "on the loop thread"), on_loop[mode]);
        assert_int_equal(count_in_file(r.log_path, "on a worker"), REQUESTS - on_loop[mode]);
        check_statuses(&out[mode], REQUESTS);
    }

    /* The workers' answers are right (the rest of this file checks them in detail): */
    const replay_out *pool = &out[0];
    const reply_rec *rr = expect_status(pool, 1, REQUEST_RAY, TRIOCT_OK);
    assert_true(rr->hit_t[0] == 1.0);
    rr = expect_status(pool, 2, REQUEST_RAY, TRIOCT_OK);
    assert_int_equal(rr->num_found, 8);
    for (int i = 0; i < 8; i++)
        assert_int_equal(rr->found[i], 1);
    rr = expect_status(pool, 5, REQUEST_RAY, TRIOCT_OK);
    assert_int_equal(rr->num_found, 2);
    /* Ray 0 runs up the faces' diagonal x = y: it touches both triangles of the bottom and
     * of the top; ray 1 one of each. */
    assert_int_equal(rr->found[0], 4);
    assert_int_equal(rr->found[1], 2);
    assert_int_equal(rr->num_hits, 6);
    const double touch_t[6] = {1, 1, 2, 2, 1, 2};
    for (int i = 0; i < 6; i++)
        assert_true(rr->hit_t[i] == touch_t[i]);
    rr = expect_status(pool, 6, REQUEST_RAY, TRIOCT_OK);
    assert_true(rr->hit_t[0] == 1.0);
    expect_status(pool, 7, REQUEST_RAY, TRIOCT_ERR_ZERO_DIRECTION);
    expect_status(pool, 8, REQUEST_RAY, TRIOCT_ERR_NONFINITE);
    expect_status(pool, DEADLINE_ID, REQUEST_RAY, TRIOCT_ERR_DEADLINE);
    expect_status(pool, 10, REQUEST_RAY, TRIOCT_ERR_BAD_REQUEST);
    rr = expect_status(pool, 11, REQUEST_TRIANGLE, TRIOCT_OK);
    assert_int_equal(rr->found[0], 1);
    rr = expect_status(pool, 12, REQUEST_TRIANGLE, TRIOCT_OK);
    assert_int_equal(rr->found[0], 2); /* it cuts z = 0 across the bottom face's diagonal */
    assert_int_equal(rr->found[1], 0);
    rr = expect_status(pool, 14, REQUEST_TRIANGLE, TRIOCT_OK);
    assert_int_equal(rr->found[0], 8); /* z = 0.5 cuts both triangles of each side face */
    expect_status(pool, 15, REQUEST_TRIANGLE, TRIOCT_ERR_NONFINITE);
    expect_status(pool, 16, REQUEST_TRIANGLE, TRIOCT_ERR_EFFECT);
    expect_status(pool, 17, REQUEST_MESH, TRIOCT_ERR_EFFECT);
    expect_status(pool, INFO_ID, REQUEST_ADMIN, TRIOCT_OK);

    /* ... and the loop thread's are the same bytes. */
    for (int mode = 1; mode < 3; mode++) {
        for (int64_t id = 1; id <= REQUESTS; id++) {
            const raw_reply *a = raw_reply_to(&raw[0], id), *b = raw_reply_to(&raw[mode], id);
            assert_string_equal(a->channel, b->channel);
            assert_int_equal(a->status, b->status);
            /* How late, and a world's build time and query count so far, are the clock's. */
            if (id == DEADLINE_ID || id == INFO_ID)
                continue;
            assert_int_equal(a->size, b->size);
            if (memcmp(a->data, b->data, (size_t)a->size) != 0)
                fail_msg("mode %d: request %lld got other bytes than from a worker", mode, (long long)id);
        }
        const trioct_status_t *x = &pool->statuses[pool->status_count - 1];
        const trioct_status_t *y = &out[mode].statuses[out[mode].status_count - 1];
        for (int t = 0; t < 4; t++)
            assert_int_equal(x->served[t], y->served[t]);
        for (int c = 0; c < TRIOCT_WIRE_STATUS_COUNT; c++)
            assert_int_equal(x->replies_by_status[c], y->replies_by_status[c]);
        assert_int_equal(y->malformed, 0);
        assert_int_equal(y->queue_depth, 0);
    }
    for (int mode = 0; mode < 3; mode++) {
        free_raw(&raw[mode]);
        free_out(&out[mode]);
    }
    free(raw);
    free(out);
    scratch_teardown(&s);
}

static void test_missing_input_log_fails_cleanly(void **state)
{
    (void)state;
    /* LCM cannot open a log that does not exist: the daemon says so and exits 1. */
    scratch s;
    scratch_setup(&s);
    scratch_write_scene(&s, "[daemon]\nprefix = " PREFIX "\nname = " DAEMON_NAME "\n\n[box]\nmesh = box.obj\n");
    run r;
    const char *extra[] = {"--exit-at-eof", NULL};
    daemon_start(&r, &s, "", extra);
    daemon_expect_exit(&r, 1);
    assert_int_equal(count_in_file(r.log_path, "cannot open LCM on file://"), 1);
    scratch_teardown(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_replay_answers_every_request),
        cmocka_unit_test(test_replay_busy),
        cmocka_unit_test(test_reload_on_sighup),
        cmocka_unit_test(test_sigterm_finishes_work_in_hand),
        cmocka_unit_test(test_inline_answers_are_the_workers),
        cmocka_unit_test(test_missing_input_log_fails_cleanly),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
