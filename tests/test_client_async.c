/* Tests of libtrioct's asynchronous calls over memq://, without a network. A fake daemon
 * subscribes to the request channels on the client's own LCM instance and either answers at
 * once from its handler or holds the requests until the test answers them, in the order,
 * cut into the chunks and interleaved the way the test says. The answers depend on each
 * request's content, so a result handed to the wrong callback shows. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <inttypes.h>
#include <lcm/lcm.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <uv.h>

#include "../client/trioct.h"
#include "channels.h"
#include "wire_check.h"

#include "trioct_admin_reply_t.h"
#include "trioct_admin_request_t.h"
#include "trioct_mesh_reply_t.h"
#include "trioct_mesh_request_t.h"
#include "trioct_ray_reply_t.h"
#include "trioct_ray_request_t.h"
#include "trioct_triangle_reply_t.h"
#include "trioct_triangle_request_t.h"

/* How late a timeout may fire on a loaded two-core machine. */
#define LATE_MS 300

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return 1e3 * (double)ts.tv_sec + 1e-6 * (double)ts.tv_nsec;
}

static void sleep_ms(int ms)
{
    struct timespec ts = {ms / 1000, (long)(ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}

static int64_t wall_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (int64_t)ts.tv_sec * 1000000 + ts.tv_nsec / 1000;
}

/* ---------- the fake daemon ---------- */

typedef struct blob {
    uint8_t *data;
    int size;
} blob;

enum { MAX_HELD = 128, MAX_CHUNKS = 8 };

typedef struct held {
    trioct_channel_kind kind;
    uint8_t *bytes;
    int size;
} held;

typedef struct fake {
    lcm_t *lcm;
    const char *name;
    lcm_subscription_t *subs[8];
    int num_subs;
    int hold;       /* keep requests for fake_answer instead of answering at once */
    int chunks;     /* cut each answer into this many (0: 1) */
    int status;     /* answer with this error status (0: answer) */
    const char *worlds[4]; /* what LIST answers */
    int num_worlds;
    held held[MAX_HELD];
    int num_held;
    int requests, bad_requests;
    int64_t last_deadline_utime;
    int drop;       /* ignore this many requests first, as a lossy bus would */
} fake;

static void put_blob(blob *b, int size)
{
    b->data = malloc((size_t)size);
    b->size = size;
}

#define ENCODE(type, msg, out)                                                   \
    do {                                                                         \
        put_blob(out, type##_encoded_size(msg));                                 \
        assert_int_equal(type##_encode((out)->data, 0, (out)->size, msg), (out)->size); \
    } while (0)

static trioct_reply_header_t reply_header(const fake *f, const trioct_request_header_t *rq,
                                          int index, int count)
{
    trioct_reply_header_t h = {
        .client_id = rq->client_id,
        .request_id = rq->request_id,
        .daemon = (char *)f->name,
        .world = rq->world,
        .world_version = 4,
        .status = (int16_t)f->status,
        .message = f->status ? "refused by the fake" : "ok",
        .chunk_index = index,
        .chunk_count = count,
    };
    return h;
}

/* Records [lo, hi) of m that chunk i of k carries. */
static void slice(int m, int i, int k, int *lo, int *hi)
{
    *lo = m * i / k;
    *hi = m * (i + 1) / k;
}

/* The one object every fake answer's records name. */
static char *one_object[1] = {"yard"};

/* Ray i of a request hits once, at t = 1000 * origin.x + i + 0.25, triangle 7 i + origin.y. */
static int answer_rays(fake *f, const trioct_ray_request_t *q, int k, blob *out)
{
    int n = q->num_rays;
    int32_t *found = calloc((size_t)n + 1, sizeof *found);
    trioct_ray_hit_t *hits = calloc((size_t)n + 1, sizeof *hits);
    for (int i = 0; i < n; i++) {
        found[i] = 1;
        hits[i] = (trioct_ray_hit_t){.ray = i,
                                     .t = 1000.0 * q->origin[i].x + i + 0.25,
                                     .triangle = 7 * i + (int32_t)q->origin[i].y,
                                     .u = 0.125,
                                     .v = 0.5,
                                     .normal = {0, 0, 1}};
    }
    int m = f->status ? 0 : n;
    for (int c = 0; c < k; c++) {
        int lo, hi;
        slice(m, c, k, &lo, &hi);
        trioct_ray_reply_t rep = {.header = reply_header(f, &q->header, c, k),
                                  .detail = q->detail,
                                  .num_rays = c == 0 && !f->status ? n : 0,
                                  .found = found,
                                  .num_objects = c == 0 && !f->status ? 1 : 0,
                                  .objects = one_object,
                                  .num_hits = hi - lo,
                                  .hits = hits + lo};
        ENCODE(trioct_ray_reply_t, &rep, &out[c]);
    }
    free(found);
    free(hits);
    return k;
}

/* Query triangle i touches world triangle 10 a.x + i. */
static int answer_triangles(fake *f, const trioct_triangle_request_t *q, blob *out)
{
    int n = q->num_triangles;
    int32_t *found = calloc((size_t)n + 1, sizeof *found);
    trioct_contact_t *contacts = calloc((size_t)n + 1, sizeof *contacts);
    for (int i = 0; i < n; i++) {
        found[i] = 1;
        contacts[i] = (trioct_contact_t){i, 0, 10 * (int32_t)q->triangles[i].a.x + i};
    }
    trioct_triangle_reply_t rep = {.header = reply_header(f, &q->header, 0, 1),
                                   .detail = q->detail,
                                   .num_triangles = n,
                                   .found = found,
                                   .num_objects = 1,
                                   .objects = one_object,
                                   .num_contacts = n,
                                   .contacts = contacts};
    ENCODE(trioct_triangle_reply_t, &rep, &out[0]);
    free(found);
    free(contacts);
    return 1;
}

/* Pose i touches with shape triangle 0 and world triangle t.x. */
static int answer_mesh(fake *f, const trioct_mesh_request_t *q, blob *out)
{
    int n = q->num_poses;
    int32_t *found = calloc((size_t)n + 1, sizeof *found);
    trioct_mesh_pair_t *pairs = calloc((size_t)n + 1, sizeof *pairs);
    for (int i = 0; i < n; i++) {
        found[i] = 1;
        pairs[i] = (trioct_mesh_pair_t){i, 0, 0, (int32_t)q->poses[i].t.x};
    }
    trioct_mesh_reply_t rep = {.header = reply_header(f, &q->header, 0, 1),
                               .detail = q->detail,
                               .num_poses = n,
                               .found = found,
                               .num_objects = 1,
                               .objects = one_object,
                               .num_pairs = n,
                               .pairs = pairs};
    ENCODE(trioct_mesh_reply_t, &rep, &out[0]);
    free(found);
    free(pairs);
    return 1;
}

static char *no_shapes[1] = {NULL};

static trioct_world_info_t world_info(const char *name, const char *daemon, int64_t triangles)
{
    trioct_world_info_t w = {.name = (char *)name,
                             .daemon = (char *)daemon,
                             .version = 4,
                             .source = (char *)name,
                             .accuracy = "exact",
                             .triangles = triangles,
                             .last_error = "",
                             .shapes = no_shapes};
    return w;
}

/* LOAD: the world with effects as its triangle count; INFO: the world with 100; UNLOAD:
 * none; LIST: the fake's worlds. */
static int answer_admin(fake *f, const trioct_admin_request_t *q, blob *out)
{
    trioct_world_info_t worlds[4];
    int n = 0;
    if (q->op == TRIOCT_ADMIN_REQUEST_T_LOAD)
        worlds[n++] = world_info(q->header.world, f->name, q->effects);
    else if (q->op == TRIOCT_ADMIN_REQUEST_T_INFO)
        worlds[n++] = world_info(q->header.world, f->name, 100);
    else if (q->op == TRIOCT_ADMIN_REQUEST_T_LIST)
        for (int i = 0; i < f->num_worlds; i++)
            worlds[n++] = world_info(f->worlds[i], f->name, i);
    trioct_admin_reply_t rep = {.header = reply_header(f, &q->header, 0, 1),
                                .op = q->op,
                                .num_worlds = n,
                                .worlds = worlds};
    ENCODE(trioct_admin_reply_t, &rep, &out[0]);
    return 1;
}

/* Encodes the answer to a request into chunks; returns how many, and its reply channel. */
static int encode_answer(fake *f, const held *h, blob *out, char reply_channel[64])
{
    int k = f->status ? 1 : f->chunks > 0 ? f->chunks : 1;
    int n = 0;
#define DECODE_AND_ANSWER(type, call)                                                     \
    do {                                                                                  \
        type q;                                                                           \
        assert_int_equal(type##_decode(h->bytes, 0, h->size, &q), h->size);               \
        snprintf(reply_channel, 64, "%s", q.header.reply_channel);                       \
        f->last_deadline_utime = q.header.deadline_utime;                                 \
        n = call;                                                                         \
        type##_decode_cleanup(&q);                                                        \
    } while (0)
    switch (h->kind) {
    case TRIOCT_CHANNEL_RAY:
        DECODE_AND_ANSWER(trioct_ray_request_t, answer_rays(f, &q, k, out));
        break;
    case TRIOCT_CHANNEL_TRI:
        DECODE_AND_ANSWER(trioct_triangle_request_t, answer_triangles(f, &q, out));
        break;
    case TRIOCT_CHANNEL_MESH:
        DECODE_AND_ANSWER(trioct_mesh_request_t, answer_mesh(f, &q, out));
        break;
    default:
        DECODE_AND_ANSWER(trioct_admin_request_t, answer_admin(f, &q, out));
        break;
    }
#undef DECODE_AND_ANSWER
    return n;
}

static void publish(lcm_t *lcm, const char *channel, const blob *b)
{
    assert_int_equal(lcm_publish(lcm, channel, b->data, (unsigned)b->size), 0);
}

static void answer_now(fake *f, const held *h)
{
    blob chunks[MAX_CHUNKS];
    char channel[64];
    int k = encode_answer(f, h, chunks, channel);
    for (int i = 0; i < k; i++) {
        publish(f->lcm, channel, &chunks[i]);
        free(chunks[i].data);
    }
}

static void on_request(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
    fake *f = user;
    f->requests++;
    if (f->drop > 0) {
        f->drop--;
        return;
    }
    trioct_channel_kind kind;
    char name[TRIOCT_MAX_NAME_LEN + 1];
    static const wire_type wires[] = {
        [TRIOCT_CHANNEL_RAY] = WIRE_RAY_REQUEST, [TRIOCT_CHANNEL_TRI] = WIRE_TRIANGLE_REQUEST,
        [TRIOCT_CHANNEL_MESH] = WIRE_MESH_REQUEST, [TRIOCT_CHANNEL_ADMIN] = WIRE_ADMIN_REQUEST,
        [TRIOCT_CHANNEL_LOAD] = WIRE_ADMIN_REQUEST, [TRIOCT_CHANNEL_LIST] = WIRE_ADMIN_REQUEST,
    };
    if (trioct_channel_parse(channel, "TRIOCT", &kind, name) != 0 ||
        kind > TRIOCT_CHANNEL_LIST ||
        wire_check(wires[kind], rbuf->data, rbuf->data_size, NULL) != 0) {
        f->bad_requests++;
        return;
    }
    held h = {.kind = kind, .bytes = malloc(rbuf->data_size), .size = (int)rbuf->data_size};
    memcpy(h.bytes, rbuf->data, rbuf->data_size);
    if (f->hold && f->num_held < MAX_HELD) {
        f->held[f->num_held++] = h;
        return;
    }
    answer_now(f, &h);
    free(h.bytes);
}

static void fake_start(fake *f, lcm_t *lcm, const char *name, const char *const *channels)
{
    memset(f, 0, sizeof *f);
    f->lcm = lcm;
    f->name = name;
    for (; *channels != NULL; channels++) {
        f->subs[f->num_subs] = lcm_subscribe(lcm, *channels, on_request, f);
        assert_non_null(f->subs[f->num_subs]);
        f->num_subs++;
    }
}

/* Encodes held request i's answer without publishing it. */
static int fake_encode_held(fake *f, int i, blob *chunks, char channel[64])
{
    assert_true(i < f->num_held);
    return encode_answer(f, &f->held[i], chunks, channel);
}

/* Publishes held request i's whole answer. */
static void fake_answer(fake *f, int i)
{
    assert_true(i < f->num_held);
    answer_now(f, &f->held[i]);
}

/* Forgets the requests it holds, unanswered. */
static void fake_forget_held(fake *f)
{
    for (int i = 0; i < f->num_held; i++)
        free(f->held[i].bytes);
    f->num_held = 0;
}

static void fake_stop(fake *f)
{
    for (int i = 0; i < f->num_subs; i++)
        lcm_unsubscribe(f->lcm, f->subs[i]);
    f->num_subs = 0;
    fake_forget_held(f);
}

/* ---------- fixture: one memq bus, daemon d1 holding w1, one client ---------- */

typedef struct env {
    lcm_t *lcm;
    fake d1;
    trioct_client *client;
} env;

static const char *const d1_channels[] = {"TRIOCT_RAY_w1",   "TRIOCT_TRI_w1",  "TRIOCT_MESH_w1",
                                          "TRIOCT_ADMIN_w1", "TRIOCT_LOAD_d1", NULL};

/* Without retries: these tests hold and count each request the fake hears (the retries
 * have their own test). */
static trioct_client *connect_to(lcm_t *lcm, int send_deadlines)
{
    trioct_connect_options opt = {.url = "memq://", .lcm = lcm, .send_deadlines = send_deadlines, .no_retries = 1};
    int status = -1;
    char err[200];
    trioct_client *c = trioct_connect(&opt, &status, err, sizeof err);
    assert_non_null(c);
    assert_int_equal(status, TRIOCT_OK);
    return c;
}

static int setup(void **state)
{
    env *e = calloc(1, sizeof *e);
    e->lcm = lcm_create("memq://");
    if (e->lcm == NULL)
        return -1;
    fake_start(&e->d1, e->lcm, "d1", d1_channels);
    e->client = connect_to(e->lcm, 0);
    *state = e;
    return 0;
}

static int teardown(void **state)
{
    env *e = *state;
    int bad = e->d1.bad_requests;
    trioct_disconnect(e->client);
    fake_stop(&e->d1);
    lcm_destroy(e->lcm);
    free(e);
    return bad == 0 ? 0 : -1;
}

static trioct_client_stats stats_of(const trioct_client *c)
{
    trioct_client_stats s;
    trioct_client_get_stats(c, &s);
    return s;
}

/* ---------- what a callback saw ---------- */

enum { MAX_SEEN = 128 };

/* The completions of one test, in the order they ran. */
typedef struct seen {
    int count;
    int64_t ids[MAX_SEEN];
    int status[MAX_SEEN];
    int tag[MAX_SEEN];      /* the request's own tag, from its user pointer */
    double at_ms[MAX_SEEN]; /* when the callback ran */
    char message[MAX_SEEN][TRIOCT_MAX_MESSAGE_LEN + 1];
} seen;

/* One asynchronous ray request: its query data and what its callback must find. */
typedef struct ray_job {
    seen *log;
    int tag;
    int rays;
    trioct_vec3 origins[8], directions[8];
    int checked;     /* the result matched this job's query */
    trioct_ray_result kept; /* a result the callback moved out */
    int keep;
} ray_job;

static void record(seen *log, int tag, const trioct_reply *r)
{
    assert_true(log->count < MAX_SEEN);
    int i = log->count++;
    log->ids[i] = r->request_id;
    log->status[i] = r->status;
    log->tag[i] = tag;
    log->at_ms[i] = now_ms();
    snprintf(log->message[i], sizeof log->message[i], "%s", r->message);
}

/* Tag k's rays start at x = k, so its hits are at t = 1000 k + i + 0.25. */
static void ray_job_init(ray_job *j, seen *log, int tag, int rays)
{
    memset(j, 0, sizeof *j);
    j->log = log;
    j->tag = tag;
    j->rays = rays;
    for (int i = 0; i < rays; i++) {
        j->origins[i] = (trioct_vec3){(double)tag, (double)(3 * i), 0.5};
        j->directions[i] = (trioct_vec3){0, 0, -1};
    }
}

static trioct_ray_query ray_job_query(ray_job *j, const char *world)
{
    trioct_ray_query q = trioct_ray_query_default(world);
    q.count = (size_t)j->rays;
    q.origins = j->origins;
    q.directions = j->directions;
    return q;
}

static void on_rays(trioct_client *c, trioct_ray_result *res, void *user)
{
    (void)c;
    ray_job *j = user;
    record(j->log, j->tag, &res->reply);
    if (res->reply.status != TRIOCT_OK)
        return;
    assert_int_equal(res->num_rays, (size_t)j->rays);
    assert_int_equal(res->num_hits, (size_t)j->rays);
    for (int i = 0; i < j->rays; i++) {
        assert_int_equal(res->found[i], 1);
        assert_int_equal(res->hits[i].ray, i);
        assert_true(res->hits[i].t == 1000.0 * j->tag + i + 0.25);
        assert_int_equal(res->hits[i].triangle, 7 * i + 3 * i);
    }
    j->checked = 1;
    if (j->keep) {
        j->kept = *res;
        memset(res, 0, sizeof *res);
    }
}

/* ---------- many in flight, out of order ---------- */

static void test_many_requests_complete_in_the_order_answers_arrive(void **state)
{
    env *e = *state;
    enum { N = 40 };
    static ray_job jobs[N];
    /* Static: if an assertion fails, teardown's disconnect still runs callbacks into it. */
    static seen log;
    memset(&log, 0, sizeof log);
    e->d1.hold = 1;
    e->d1.chunks = 3;
    int64_t ids[N];
    for (int k = 0; k < N; k++) {
        ray_job_init(&jobs[k], &log, k, 1 + k % 8);
        trioct_ray_query q = ray_job_query(&jobs[k], "w1");
        assert_int_equal(trioct_rays_async(e->client, &q, 5000, on_rays, &jobs[k], &ids[k]),
                         TRIOCT_OK);
        assert_int_equal(ids[k], k + 1);
        assert_string_equal(trioct_last_error(e->client), "");
    }
    assert_int_equal(trioct_in_flight(e->client), N);
    int next = trioct_next_timeout_ms(e->client);
    assert_true(next > 4000 && next <= 5000);

    /* The daemon hears them all and has answered none: pumping completes nothing. */
    assert_int_equal(trioct_pump(e->client), N);
    assert_int_equal(e->d1.num_held, N);
    assert_int_equal(log.count, 0);

    /* Answers in a shuffled order; the first ten have their three chunks interleaved with
     * each other's (a chunk of 7, one of 3, ...) and come in reverse chunk order. */
    int order[N];
    for (int k = 0; k < N; k++)
        order[k] = (k * 17 + 5) % N; /* 17 is prime to 40: a permutation */
    blob chunks[10][MAX_CHUNKS];
    char channel[64];
    for (int a = 0; a < 10; a++)
        assert_int_equal(fake_encode_held(&e->d1, order[a], chunks[a], channel), 3);
    for (int c = 2; c >= 0; c--)
        for (int a = 0; a < 10; a++) {
            publish(e->lcm, channel, &chunks[a][c]);
            free(chunks[a][c].data);
        }
    /* The last chunk of each of the ten is the one that completed it: c == 0 round. */
    assert_int_equal(trioct_pump(e->client), 30);
    assert_int_equal(log.count, 10);
    for (int a = 0; a < 10; a++) {
        assert_int_equal(log.tag[a], order[a]);
        assert_int_equal(log.ids[a], ids[order[a]]);
        assert_int_equal(log.status[a], TRIOCT_OK);
    }
    for (int a = 10; a < N; a++)
        fake_answer(&e->d1, order[a]);
    assert_int_equal(trioct_poll(e->client, 1000), N - 10);
    assert_int_equal(log.count, N);
    for (int a = 0; a < N; a++) {
        assert_int_equal(log.tag[a], order[a]);
        assert_true(jobs[order[a]].checked);
    }
    assert_int_equal(trioct_in_flight(e->client), 0);
    assert_int_equal(trioct_next_timeout_ms(e->client), -1);
    trioct_client_stats s = stats_of(e->client);
    assert_int_equal(s.requests_sent, N);
    assert_int_equal(s.chunks_accepted, 3 * N);
    assert_int_equal(s.unmatched + s.duplicate_chunks + s.malformed + s.foreign_client, 0);
}

/* ---------- every request type, in flight together ---------- */

typedef struct any_job {
    seen *log;
    int tag;
    trioct_triangle_result tri;
    trioct_mesh_result mesh;
    trioct_admin_result admin;
    trioct_list_result list;
} any_job;

static void on_triangles(trioct_client *c, trioct_triangle_result *res, void *user)
{
    (void)c;
    any_job *j = user;
    record(j->log, j->tag, &res->reply);
    j->tri = *res; /* moved out: the library then frees nothing */
    memset(res, 0, sizeof *res);
}

static void on_mesh(trioct_client *c, trioct_mesh_result *res, void *user)
{
    (void)c;
    any_job *j = user;
    record(j->log, j->tag, &res->reply);
    j->mesh = *res;
    memset(res, 0, sizeof *res);
}

static void on_admin(trioct_client *c, trioct_admin_result *res, void *user)
{
    (void)c;
    any_job *j = user;
    record(j->log, j->tag, &res->reply);
    j->admin = *res;
    memset(res, 0, sizeof *res);
}

static void on_list(trioct_client *c, trioct_list_result *res, void *user)
{
    (void)c;
    any_job *j = user;
    record(j->log, j->tag, &res->reply);
    j->list = *res;
    memset(res, 0, sizeof *res);
}

static void test_every_request_type_async(void **state)
{
    env *e = *state;
    static const char *const list[] = {"TRIOCT_LIST", NULL};
    fake d2;
    fake_start(&d2, e->lcm, "d2", list);
    d2.worlds[0] = "w7";
    d2.worlds[1] = "w8";
    d2.num_worlds = 2;
    static const char *const list1[] = {"TRIOCT_LIST", NULL};
    fake d1_list;
    fake_start(&d1_list, e->lcm, "d1", list1);
    d1_list.worlds[0] = "w1";
    d1_list.num_worlds = 1;
    e->d1.hold = 1;

    /* Static: if an assertion fails, teardown's disconnect still runs callbacks into it. */
    static seen log;
    memset(&log, 0, sizeof log);
    static ray_job rays;
    ray_job_init(&rays, &log, 0, 3);
    static any_job jobs[7];
    for (int i = 0; i < 7; i++)
        jobs[i] = (any_job){.log = &log, .tag = i + 1};
    trioct_triangle t[2] = {{{2, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{2, 0, 0}, {0, 2, 0}, {0, 0, 2}}};
    trioct_pose poses[3];
    for (int i = 0; i < 3; i++)
        poses[i] = (trioct_pose){{1, 0, 0, 0, 1, 0, 0, 0, 1}, {40.0 + i, 0, 0}};
    trioct_ray_query rq = ray_job_query(&rays, "w1");
    trioct_triangle_query tq = {.world = "w1", .detail = TRIOCT_TRI_IDS, .count = 2, .triangles = t};
    trioct_mesh_query mq = {.world = "w1", .detail = TRIOCT_MESH_PAIRS, .shape = "gripper",
                            .num_poses = 3, .poses = poses};
    trioct_load_options lo = {.world = "w1", .daemon = "d1", .effects = TRIOCT_EFFECT_RAYS};
    trioct_list_options listo = {.expect_daemons = 2};
    int64_t id[8];
    trioct_client *c = e->client;
    assert_int_equal(trioct_rays_async(c, &rq, 2000, on_rays, &rays, &id[0]), TRIOCT_OK);
    assert_int_equal(trioct_triangles_async(c, &tq, 2000, on_triangles, &jobs[0], &id[1]), TRIOCT_OK);
    assert_int_equal(trioct_mesh_async(c, &mq, 2000, on_mesh, &jobs[1], &id[2]), TRIOCT_OK);
    assert_int_equal(trioct_load_async(c, &lo, 2000, on_admin, &jobs[2], &id[3]), TRIOCT_OK);
    assert_int_equal(trioct_info_async(c, "w1", 2000, on_admin, &jobs[3], &id[4]), TRIOCT_OK);
    assert_int_equal(trioct_unload_async(c, "w1", 2000, on_admin, &jobs[4], &id[5]), TRIOCT_OK);
    assert_int_equal(trioct_list_async(c, &listo, 2000, on_list, &jobs[5], &id[6]), TRIOCT_OK);
    for (int i = 0; i < 7; i++)
        assert_int_equal(id[i], i + 1);
    assert_int_equal(trioct_in_flight(c), 7);

    /* LIST is answered at once by both daemons; d1 holds the rest and answers them last
     * first. */
    assert_int_equal(trioct_poll(c, 2000), 1);
    assert_int_equal(log.count, 1);
    assert_int_equal(log.tag[0], 6);
    assert_int_equal(e->d1.num_held, 6);
    for (int i = 5; i >= 0; i--)
        fake_answer(&e->d1, i);
    while (trioct_in_flight(c) > 0)
        assert_true(trioct_poll(c, 2000) > 0);
    assert_int_equal(log.count, 7);
    int want_tags[7] = {6, 5, 4, 3, 2, 1, 0};
    for (int i = 0; i < 7; i++) {
        assert_int_equal(log.tag[i], want_tags[i]);
        assert_int_equal(log.status[i], TRIOCT_OK);
        assert_int_equal(log.ids[i], id[want_tags[i]]);
    }
    assert_true(rays.checked);

    assert_int_equal(jobs[0].tri.num_contacts, 2);
    assert_int_equal(jobs[0].tri.contacts[0].triangle, 20);
    assert_int_equal(jobs[0].tri.contacts[1].triangle, 21);
    assert_int_equal(jobs[0].tri.reply.request_id, id[1]);
    trioct_triangle_result_free(&jobs[0].tri);
    assert_int_equal(jobs[1].mesh.num_pairs, 3);
    assert_int_equal(jobs[1].mesh.pairs[2].pose, 2);
    assert_int_equal(jobs[1].mesh.pairs[2].world_triangle, 42);
    trioct_mesh_result_free(&jobs[1].mesh);
    assert_int_equal(jobs[2].admin.num_worlds, 1); /* LOAD */
    assert_int_equal(jobs[2].admin.worlds[0].triangles, TRIOCT_EFFECT_RAYS);
    assert_string_equal(jobs[2].admin.worlds[0].daemon, "d1");
    trioct_admin_result_free(&jobs[2].admin);
    assert_int_equal(jobs[3].admin.num_worlds, 1); /* INFO */
    assert_int_equal(jobs[3].admin.worlds[0].triangles, 100);
    trioct_admin_result_free(&jobs[3].admin);
    assert_int_equal(jobs[4].admin.num_worlds, 0); /* UNLOAD */
    trioct_admin_result_free(&jobs[4].admin);
    assert_int_equal(jobs[5].list.num_daemons, 2);
    assert_int_equal(jobs[5].list.num_worlds, 3);
    assert_string_equal(jobs[5].list.reply.message, "3 worlds from 2 daemons");
    trioct_list_result_free(&jobs[5].list);
    fake_stop(&d2);
    fake_stop(&d1_list);
}

/* ---------- timeouts ---------- */

static void test_timeouts_fire_through_poll_in_deadline_order(void **state)
{
    env *e = *state;
    /* Static: if an assertion fails, teardown's disconnect still runs callbacks into it. */
    static seen log;
    memset(&log, 0, sizeof log);
    static ray_job jobs[5];
    int timeouts[5] = {150, 50, -1, 100, 0};
    const char *worlds[5] = {"ghost", "ghost", "ghost", "w1", "ghost"};
    e->d1.chunks = 2;
    e->d1.hold = 1;
    int64_t ids[5];
    double t0 = now_ms();
    for (int k = 0; k < 5; k++) {
        ray_job_init(&jobs[k], &log, k, 2);
        trioct_ray_query q = ray_job_query(&jobs[k], worlds[k]);
        assert_int_equal(trioct_rays_async(e->client, &q, timeouts[k], on_rays, &jobs[k], &ids[k]),
                         TRIOCT_OK);
    }
    /* Timeout 0 is due at once. */
    assert_int_equal(trioct_next_timeout_ms(e->client), 0);
    assert_int_equal(trioct_poll(e->client, 0), 1);
    assert_int_equal(log.tag[0], 4);
    assert_int_equal(log.status[0], TRIOCT_ERR_NO_DAEMON);
    assert_string_equal(log.message[0],
                        "no daemon serves world ghost on memq:// (no reply within 0 ms)");
    int next = trioct_next_timeout_ms(e->client);
    assert_true(next > 0 && next <= 50);

    /* w1's daemon sends one chunk of two: a partial answer is a timeout, not "no daemon". */
    blob chunks[MAX_CHUNKS];
    char channel[64];
    assert_int_equal(e->d1.num_held, 1);
    assert_int_equal(fake_encode_held(&e->d1, 0, chunks, channel), 2);
    publish(e->lcm, channel, &chunks[1]);
    free(chunks[0].data);
    free(chunks[1].data);

    /* Bounded, so that a timeout that never fires fails the test instead of hanging it; a
     * poll that slept past a deadline fails the timing checks. */
    assert_int_equal(trioct_poll(e->client, 5000), 1);
    assert_int_equal(trioct_poll(e->client, 5000), 1);
    assert_int_equal(trioct_poll(e->client, 5000), 1);
    assert_int_equal(log.count, 4);
    int want[4] = {4, 1, 3, 0};
    int due[4] = {0, 50, 100, 150};
    for (int i = 0; i < 4; i++) {
        assert_int_equal(log.tag[i], want[i]);
        assert_int_equal(log.ids[i], ids[want[i]]);
        double at = log.at_ms[i] - t0;
        assert_true(at >= due[i]);
        assert_true(at < due[i] + LATE_MS);
    }
    assert_int_equal(log.status[1], TRIOCT_ERR_NO_DAEMON);
    assert_string_equal(log.message[1],
                        "no daemon serves world ghost on memq:// (no reply within 50 ms)");
    assert_int_equal(log.status[2], TRIOCT_ERR_TIMEOUT);
    assert_string_equal(log.message[2],
                        "reply from daemon d1 incomplete: 1 of 2 chunks within 100 ms");
    assert_int_equal(log.status[3], TRIOCT_ERR_NO_DAEMON);

    /* The one without a timeout never fires: poll waits out its own timeout instead. */
    assert_int_equal(trioct_in_flight(e->client), 1);
    assert_int_equal(trioct_next_timeout_ms(e->client), -1);
    double t1 = now_ms();
    assert_int_equal(trioct_poll(e->client, 40), 0);
    assert_true(now_ms() - t1 >= 40.0);
    assert_int_equal(trioct_cancel(e->client, ids[2]), TRIOCT_OK);
    assert_int_equal(trioct_in_flight(e->client), 0);
    /* Nothing in flight and no timeout: poll returns at once rather than hang. */
    t1 = now_ms();
    assert_int_equal(trioct_poll(e->client, -1), 0);
    assert_true(now_ms() - t1 < 100.0);
    assert_int_equal(log.count, 4);

    /* Several due by the time of one pump complete by deadline, not in the order sent. */
    static ray_job late[3];
    int late_ms[3] = {30, 10, 20};
    for (int k = 0; k < 3; k++) {
        ray_job_init(&late[k], &log, 10 + k, 1);
        trioct_ray_query q = ray_job_query(&late[k], "ghost");
        assert_int_equal(trioct_rays_async(e->client, &q, late_ms[k], on_rays, &late[k], NULL),
                         TRIOCT_OK);
    }
    sleep_ms(60);
    assert_int_equal(trioct_next_timeout_ms(e->client), 0);
    trioct_pump(e->client);
    assert_int_equal(log.count, 7);
    assert_int_equal(log.tag[4], 11);
    assert_int_equal(log.tag[5], 12);
    assert_int_equal(log.tag[6], 10);
}

static void test_list_gathers_for_its_window(void **state)
{
    env *e = *state;
    static const char *const list[] = {"TRIOCT_LIST", NULL};
    fake a, b;
    fake_start(&a, e->lcm, "d1", list);
    fake_start(&b, e->lcm, "d2", list);
    a.worlds[0] = "w1";
    a.num_worlds = 1;
    b.worlds[0] = "w2";
    b.worlds[1] = "w3";
    b.num_worlds = 2;
    /* Static: if an assertion fails, teardown's disconnect still runs callbacks into it. */
    static seen log;
    memset(&log, 0, sizeof log);
    static any_job job;
    job = (any_job){.log = &log, .tag = 9};
    trioct_list_options opt = {.gather_ms = 80};
    double t0 = now_ms();
    int64_t id;
    assert_int_equal(trioct_list_async(e->client, &opt, 5000, on_list, &job, &id), TRIOCT_OK);
    int next = trioct_next_timeout_ms(e->client);
    assert_true(next > 60 && next <= 80);
    /* Both answer at once, but without an expected count the window runs out first. */
    assert_int_equal(trioct_poll(e->client, 5000), 1);
    double took = now_ms() - t0;
    assert_true(took >= 80.0 && took < 80.0 + LATE_MS);
    assert_int_equal(log.status[0], TRIOCT_OK);
    assert_int_equal(job.list.num_daemons, 2);
    assert_int_equal(job.list.num_worlds, 3);
    assert_int_equal(job.list.reply.request_id, id);
    trioct_list_result_free(&job.list);

    /* Nobody answers: no daemon, and a LIST without any end is refused. */
    fake_stop(&a);
    fake_stop(&b);
    assert_int_equal(trioct_list_async(e->client, NULL, 30, on_list, &job, &id), TRIOCT_OK);
    assert_int_equal(trioct_poll(e->client, 5000), 1);
    assert_int_equal(log.status[1], TRIOCT_ERR_NO_DAEMON);
    assert_string_equal(log.message[1], "no daemon answered on memq:// (no reply within 30 ms)");
    trioct_list_result_free(&job.list);
    assert_int_equal(trioct_list_async(e->client, NULL, -1, on_list, &job, &id),
                     TRIOCT_ERR_BAD_REQUEST);
    assert_int_equal(id, 0);
    assert_string_equal(trioct_last_error(e->client),
                        "a LIST without a timeout needs a gather window or an expected count");
    assert_int_equal(log.count, 2);
}

/* ---------- cancel ---------- */

static void test_cancel_forgets_a_request(void **state)
{
    env *e = *state;
    /* Static: if an assertion fails, teardown's disconnect still runs callbacks into it. */
    static seen log;
    memset(&log, 0, sizeof log);
    static ray_job jobs[3];
    int64_t ids[3];
    e->d1.hold = 1;
    for (int k = 0; k < 3; k++) {
        ray_job_init(&jobs[k], &log, k, 2);
        trioct_ray_query q = ray_job_query(&jobs[k], "w1");
        assert_int_equal(trioct_rays_async(e->client, &q, 2000, on_rays, &jobs[k], &ids[k]),
                         TRIOCT_OK);
    }
    assert_int_equal(trioct_cancel(e->client, ids[1]), TRIOCT_OK);
    assert_int_equal(trioct_in_flight(e->client), 2);
    assert_int_equal(trioct_cancel(e->client, ids[1]), TRIOCT_ERR_BAD_REQUEST);
    char want[200];
    snprintf(want, sizeof want,
             "no asynchronous request %" PRId64 " is in flight (completed, cancelled or never sent)",
             ids[1]);
    assert_string_equal(trioct_last_error(e->client), want);
    assert_int_equal(trioct_cancel(e->client, 999), TRIOCT_ERR_BAD_REQUEST);

    trioct_pump(e->client);
    for (int k = 0; k < 3; k++)
        fake_answer(&e->d1, k);
    /* Request 2 is answered whole but not yet completed when it is cancelled: an answer
     * already handled does not resurrect it. */
    assert_int_equal(trioct_triangles(e->client, &(trioct_triangle_query){.world = "w9"}, 0,
                                      &(trioct_triangle_result){0}),
                     TRIOCT_ERR_NO_DAEMON);
    assert_int_equal(trioct_next_timeout_ms(e->client), 0); /* completions wait */
    assert_int_equal(log.count, 0);
    assert_int_equal(trioct_cancel(e->client, ids[2]), TRIOCT_OK);
    assert_int_equal(trioct_pump(e->client), 0);
    assert_int_equal(log.count, 1);
    assert_int_equal(log.tag[0], 0);
    assert_int_equal(trioct_in_flight(e->client), 0);
    /* The cancelled request's answer is dropped as unmatched. */
    trioct_client_stats s = stats_of(e->client);
    assert_int_equal(s.unmatched, 1);
    assert_int_equal(s.chunks_accepted, 2);
    /* Its own id after it completed. */
    assert_int_equal(trioct_cancel(e->client, ids[0]), TRIOCT_ERR_BAD_REQUEST);
}

/* ---------- callbacks that act ---------- */

typedef struct chain {
    seen *log;
    int left;          /* requests still to send from callbacks */
    ray_job job;       /* reused for each link */
    int64_t sibling;   /* a request to cancel from the first callback */
    int sibling_ran;
    int nested_pump, nested_poll;
    char nested_error[TRIOCT_MAX_MESSAGE_LEN + 1];
    int sync_status;
    size_t sync_contacts;
} chain;

static void on_sibling(trioct_client *c, trioct_ray_result *res, void *user)
{
    (void)c;
    (void)res;
    ((chain *)user)->sibling_ran = 1;
}

static void on_link(trioct_client *c, trioct_ray_result *res, void *user)
{
    chain *ch = user;
    record(ch->log, ch->left, &res->reply);
    assert_int_equal(res->reply.status, TRIOCT_OK);
    if (ch->sibling != 0) {
        assert_int_equal(trioct_cancel(c, ch->sibling), TRIOCT_OK);
        ch->sibling = 0;
        /* Completions do not nest. */
        ch->nested_pump = trioct_pump(c);
        ch->nested_poll = trioct_poll(c, 10);
        snprintf(ch->nested_error, sizeof ch->nested_error, "%s", trioct_last_error(c));
        /* A synchronous call is fine here: it waits for its own answer only. */
        trioct_triangle t = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
        trioct_triangle_query tq = {.world = "w1", .detail = TRIOCT_TRI_IDS, .count = 1,
                                    .triangles = &t};
        trioct_triangle_result tr;
        ch->sync_status = trioct_triangles(c, &tq, 1000, &tr);
        ch->sync_contacts = tr.num_contacts;
        trioct_triangle_result_free(&tr);
    }
    if (ch->left > 0) {
        ch->left--;
        trioct_ray_query q = ray_job_query(&ch->job, "w1");
        assert_int_equal(trioct_rays_async(c, &q, 1000, on_link, ch, NULL), TRIOCT_OK);
    }
}

static void test_callback_sends_cancels_and_calls_sync(void **state)
{
    env *e = *state;
    /* Static: if an assertion fails, teardown's disconnect still runs callbacks into it. */
    static seen log;
    memset(&log, 0, sizeof log);
    static chain ch;
    ch = (chain){.log = &log, .left = 4};
    ray_job_init(&ch.job, &log, 1, 2);
    trioct_ray_query q = ray_job_query(&ch.job, "w1");
    e->d1.hold = 1;
    assert_int_equal(trioct_rays_async(e->client, &q, 1000, on_sibling, &ch, NULL), TRIOCT_OK);
    int64_t first;
    assert_int_equal(trioct_rays_async(e->client, &q, 1000, on_link, &ch, &first), TRIOCT_OK);
    ch.sibling = first - 1;
    trioct_pump(e->client);
    e->d1.hold = 0;
    fake_answer(&e->d1, 1);
    fake_answer(&e->d1, 0);
    /* The chain runs on: each link's answer comes while poll drains. */
    while (trioct_in_flight(e->client) > 0)
        assert_true(trioct_poll(e->client, 1000) > 0);
    assert_int_equal(log.count, 5);
    for (int i = 0; i < 5; i++) {
        assert_int_equal(log.tag[i], 4 - i);
        assert_int_equal(log.status[i], TRIOCT_OK);
    }
    /* Ids: the sibling, the first link, the sync call, then the four links. */
    assert_int_equal(log.ids[0], first);
    assert_int_equal(log.ids[1], first + 2);
    assert_int_equal(log.ids[4], first + 5);
    assert_int_equal(ch.sibling_ran, 0);
    assert_int_equal(ch.nested_pump, -1);
    assert_int_equal(ch.nested_poll, -1);
    assert_string_equal(ch.nested_error,
                        "trioct_poll called from inside a completion callback: callbacks run "
                        "inside trioct_pump and trioct_poll, which do not nest");
    assert_int_equal(ch.sync_status, TRIOCT_OK);
    assert_int_equal(ch.sync_contacts, 1);
    /* The sibling's answer had come whole before it was cancelled: accepted, never handed
     * over. */
    assert_int_equal(stats_of(e->client).unmatched, 0);
}

/* A sync call handles the replies of async requests in flight but leaves their
 * completions to the next pump. */
static void test_sync_call_leaves_async_completions_to_pump(void **state)
{
    env *e = *state;
    /* Static: if an assertion fails, teardown's disconnect still runs callbacks into it. */
    static seen log;
    memset(&log, 0, sizeof log);
    static ray_job job;
    ray_job_init(&job, &log, 3, 4);
    job.keep = 1;
    trioct_ray_query q = ray_job_query(&job, "w1");
    e->d1.hold = 1;
    int64_t id;
    assert_int_equal(trioct_rays_async(e->client, &q, 2000, on_rays, &job, &id), TRIOCT_OK);
    trioct_pump(e->client);
    fake_answer(&e->d1, 0);
    e->d1.hold = 0;
    trioct_admin_result ar;
    assert_int_equal(trioct_info(e->client, "w1", 1000, &ar), TRIOCT_OK);
    assert_int_equal(ar.worlds[0].triangles, 100);
    assert_int_equal(ar.reply.request_id, id + 1);
    trioct_admin_result_free(&ar);
    assert_int_equal(log.count, 0);
    assert_int_equal(trioct_next_timeout_ms(e->client), 0);
    assert_int_equal(trioct_pump(e->client), 0);
    assert_int_equal(log.count, 1);
    assert_true(job.checked);
    /* The callback moved the result out: it is the caller's now, whole. */
    assert_int_equal(job.kept.num_hits, 4);
    assert_true(job.kept.hits[3].t == 3003.25);
    assert_int_equal(job.kept.reply.request_id, id);
    trioct_ray_result_free(&job.kept);
    assert_null(job.kept.hits);
}

/* ---------- refusals ---------- */

static void test_async_refusals_send_nothing(void **state)
{
    env *e = *state;
    /* Static: if an assertion fails, teardown's disconnect still runs callbacks into it. */
    static seen log;
    memset(&log, 0, sizeof log);
    static ray_job job;
    ray_job_init(&job, &log, 0, 2);
    trioct_ray_query q = ray_job_query(&job, "w1");
    int64_t id = 77;
    assert_int_equal(trioct_rays_async(e->client, &q, 100, NULL, &job, &id),
                     TRIOCT_ERR_BAD_REQUEST);
    assert_int_equal(id, 0);
    assert_string_equal(trioct_last_error(e->client), "no completion callback given");
    q.count = TRIOCT_MAX_RAYS + 1;
    assert_int_equal(trioct_rays_async(e->client, &q, 100, on_rays, &job, &id), TRIOCT_ERR_OVER_CAP);
    assert_string_equal(trioct_last_error(e->client),
                        "1281 rays is over the cap of 1280 rays per request (TRIOCT_MAX_RAYS)");
    q = ray_job_query(&job, "bad world");
    assert_int_equal(trioct_rays_async(e->client, &q, 100, on_rays, &job, NULL),
                     TRIOCT_ERR_BAD_REQUEST);
    assert_string_equal(trioct_last_error(e->client),
                        "invalid world name \"bad world\": 1..32 characters of [A-Za-z0-9_]");
    trioct_triangle_query tq = {.world = "w1", .count = 1, .triangles = NULL};
    assert_int_equal(trioct_triangles_async(e->client, &tq, 100, on_triangles, &log, NULL),
                     TRIOCT_ERR_BAD_REQUEST);
    trioct_mesh_query mq = {.world = "w1", .detail = 5};
    assert_int_equal(trioct_mesh_async(e->client, &mq, 100, on_mesh, &log, NULL),
                     TRIOCT_ERR_BAD_REQUEST);
    assert_int_equal(trioct_load_async(e->client, NULL, 100, on_admin, &log, NULL),
                     TRIOCT_ERR_BAD_REQUEST);
    assert_string_equal(trioct_last_error(e->client), "no load options given");
    assert_int_equal(trioct_info_async(e->client, NULL, 100, on_admin, &log, NULL),
                     TRIOCT_ERR_BAD_REQUEST);
    assert_int_equal(trioct_unload_async(e->client, "w-1", 100, on_admin, &log, NULL),
                     TRIOCT_ERR_BAD_REQUEST);
    assert_int_equal(trioct_in_flight(e->client), 0);
    assert_int_equal(stats_of(e->client).requests_sent, 0);
    assert_int_equal(trioct_poll(e->client, 20), 0);
    assert_int_equal(log.count, 0);
    assert_int_equal(e->d1.requests, 0);
}

/* ---------- disconnect ---------- */

typedef struct closer {
    seen *log;
    trioct_client *c;
    int close_in_callback;
    int refused_status; /* a request sent after the close, from a callback */
} closer;

static void on_close_test(trioct_client *c, trioct_ray_result *res, void *user)
{
    closer *cl = user;
    record(cl->log, (int)res->reply.request_id, &res->reply);
    if (cl->close_in_callback) {
        cl->close_in_callback = 0;
        trioct_disconnect(c);
        trioct_disconnect(c); /* twice is harmless */
        trioct_vec3 o = {0, 0, 0}, d = {1, 0, 0};
        trioct_ray_query q = trioct_ray_query_default("w1");
        q.count = 1;
        q.origins = &o;
        q.directions = &d;
        cl->refused_status = trioct_rays_async(c, &q, 100, on_close_test, cl, NULL);
    }
}

static void test_disconnect_completes_requests_in_flight(void **state)
{
    env *e = *state;
    /* Static: if an assertion fails, teardown's disconnect still runs callbacks into it. */
    static seen log;
    memset(&log, 0, sizeof log);
    static closer cl;
    cl = (closer){.log = &log};
    trioct_vec3 o[1] = {{0, 0, 0}}, d[1] = {{1, 0, 0}};
    trioct_ray_query q = trioct_ray_query_default("w1");
    q.count = 1;
    q.origins = o;
    q.directions = d;
    e->d1.hold = 1;

    /* Closed from outside: both callbacks run inside trioct_disconnect. */
    trioct_client *c = connect_to(e->lcm, 0);
    assert_int_equal(trioct_rays_async(c, &q, 1000, on_close_test, &cl, NULL), TRIOCT_OK);
    assert_int_equal(trioct_rays_async(c, &q, -1, on_close_test, &cl, NULL), TRIOCT_OK);
    trioct_disconnect(c);
    assert_int_equal(log.count, 2);
    for (int i = 0; i < 2; i++) {
        assert_int_equal(log.status[i], TRIOCT_ERR_TRANSPORT);
        assert_string_equal(log.message[i],
                            "the connection to memq:// was closed before the answer came");
    }

    /* Closed from a callback: the pump finishes the close; the others complete as closed,
     * except one whose answer was already whole. The closed client's two requests reach the
     * daemon first. */
    trioct_pump(e->client);
    assert_int_equal(e->d1.num_held, 2);
    fake_forget_held(&e->d1);
    c = connect_to(e->lcm, 0);
    cl.close_in_callback = 1;
    for (int k = 0; k < 3; k++)
        assert_int_equal(trioct_rays_async(c, &q, 1000, on_close_test, &cl, NULL), TRIOCT_OK);
    trioct_pump(c);
    assert_int_equal(e->d1.num_held, 3);
    fake_answer(&e->d1, 0);
    fake_answer(&e->d1, 2);
    trioct_pump(c); /* c is gone after this */
    /* Answered ones first, in the order they came, then the rest by request id. */
    assert_int_equal(log.count, 5);
    assert_int_equal(log.ids[2], 1);
    assert_int_equal(log.status[2], TRIOCT_OK);
    assert_int_equal(log.ids[3], 3);
    assert_int_equal(log.status[3], TRIOCT_OK);
    assert_int_equal(log.ids[4], 2);
    assert_int_equal(log.status[4], TRIOCT_ERR_TRANSPORT);
    assert_int_equal(cl.refused_status, TRIOCT_ERR_TRANSPORT);
    fake_forget_held(&e->d1);
}

/* ---------- deadlines sent to the daemon ---------- */

static void test_send_deadlines_option(void **state)
{
    env *e = *state;
    trioct_client *c = connect_to(e->lcm, 1);
    trioct_vec3 o[1] = {{0, 0, 0}}, d[1] = {{1, 0, 0}};
    trioct_ray_query q = trioct_ray_query_default("w1");
    q.count = 1;
    q.origins = o;
    q.directions = d;
    trioct_ray_result res;
    int64_t before = wall_us();
    assert_int_equal(trioct_rays(c, &q, 1500, &res), TRIOCT_OK);
    int64_t after = wall_us();
    trioct_ray_result_free(&res);
    assert_true(e->d1.last_deadline_utime >= before + 1500000);
    assert_true(e->d1.last_deadline_utime <= after + 1500000);

    /* Static: if an assertion fails, teardown's disconnect still runs callbacks into it. */
    static seen log;
    memset(&log, 0, sizeof log);
    static any_job job;
    job = (any_job){.log = &log};
    before = wall_us();
    assert_int_equal(trioct_info_async(c, "w1", 250, on_admin, &job, NULL), TRIOCT_OK);
    after = wall_us();
    assert_int_equal(trioct_poll(c, 1000), 1);
    trioct_admin_result_free(&job.admin);
    assert_true(e->d1.last_deadline_utime >= before + 250000);
    assert_true(e->d1.last_deadline_utime <= after + 250000);

    /* No timeout, no deadline; and a connection without the option sends none. */
    assert_int_equal(trioct_rays(c, &q, -1, &res), TRIOCT_OK);
    trioct_ray_result_free(&res);
    assert_int_equal(e->d1.last_deadline_utime, 0);
    trioct_disconnect(c);
    assert_int_equal(trioct_rays(e->client, &q, 1500, &res), TRIOCT_OK);
    trioct_ray_result_free(&res);
    assert_int_equal(e->d1.last_deadline_utime, 0);
}

/* ---------- an external event loop ---------- */

/* libuv drives the connection: a uv_poll on its fd and a uv_timer armed from
 * trioct_next_timeout_ms, re-armed after every pump. */
typedef struct uv_drive {
    trioct_client *c;
    fake *daemon;
    uv_poll_t poll;
    uv_timer_t timer;
    uv_timer_t answer; /* the daemon's delay before it answers the held requests */
    uv_timer_t watchdog; /* ends the loop if the requests never all complete */
    int pumps_from_fd, pumps_from_timer;
    int closed;
} uv_drive;

static void close_all(uv_drive *u);
static void on_uv_timer(uv_timer_t *t);

static void pump_and_rearm(uv_drive *u)
{
    trioct_pump(u->c);
    if (trioct_in_flight(u->c) == 0) {
        close_all(u);
        return;
    }
    int ms = trioct_next_timeout_ms(u->c);
    if (ms >= 0)
        uv_timer_start(&u->timer, on_uv_timer, (uint64_t)ms, 0);
    else
        uv_timer_stop(&u->timer);
}

static void on_uv_timer(uv_timer_t *t)
{
    uv_drive *u = t->data;
    u->pumps_from_timer++;
    pump_and_rearm(u);
}

static void on_uv_readable(uv_poll_t *p, int status, int events)
{
    (void)events;
    uv_drive *u = p->data;
    assert_int_equal(status, 0);
    u->pumps_from_fd++;
    pump_and_rearm(u);
}

static void on_answer_time(uv_timer_t *t)
{
    uv_drive *u = t->data;
    /* Last request first. */
    for (int i = u->daemon->num_held - 1; i >= 0; i--)
        fake_answer(u->daemon, i);
}

static void close_all(uv_drive *u)
{
    if (u->closed)
        return;
    u->closed = 1;
    uv_poll_stop(&u->poll);
    uv_close((uv_handle_t *)&u->poll, NULL);
    uv_close((uv_handle_t *)&u->timer, NULL);
    uv_close((uv_handle_t *)&u->answer, NULL);
    uv_close((uv_handle_t *)&u->watchdog, NULL);
}

static void on_watchdog(uv_timer_t *t)
{
    close_all(t->data);
}

/* A lost request is sent again after 250 ms, the same bytes, and the answer to the copy
 * completes it; next_timeout_ms says when the retry is due, so a caller's own loop makes it
 * happen. A synchronous call retries on its own. */
static void test_lost_requests_are_sent_again(void **state)
{
    env *e = *state;
    trioct_connect_options opt = {.url = "memq://", .lcm = e->lcm};
    trioct_client *c = trioct_connect(&opt, NULL, NULL, 0);
    assert_non_null(c);
    static seen log;
    memset(&log, 0, sizeof log);
    static ray_job job;
    ray_job_init(&job, &log, 1, 3);
    trioct_ray_query q = ray_job_query(&job, "w1");
    e->d1.drop = 1;
    int before = e->d1.requests;
    double t0 = now_ms();
    assert_int_equal(trioct_rays_async(c, &q, 5000, on_rays, &job, NULL), TRIOCT_OK);
    int next = trioct_next_timeout_ms(c);
    assert_true(next > 200 && next <= 250);
    while (log.count == 0 && now_ms() - t0 < 3000)
        trioct_poll(c, 100);
    assert_int_equal(log.count, 1);
    assert_int_equal(log.status[0], TRIOCT_OK);
    assert_true(job.checked);
    assert_true(now_ms() - t0 >= 250.0);
    assert_int_equal(e->d1.requests - before, 2);
    trioct_client_stats st;
    trioct_client_get_stats(c, &st);
    assert_int_equal(st.retries, 1);
    assert_int_equal(st.requests_sent, 1);

    /* Synchronous: two copies lost, the third answered (after 250 + 500 ms). */
    e->d1.drop = 2;
    trioct_ray_result res;
    t0 = now_ms();
    assert_int_equal(trioct_rays(c, &q, 5000, &res), TRIOCT_OK);
    assert_true(now_ms() - t0 >= 750.0);
    trioct_ray_result_free(&res);
    trioct_client_get_stats(c, &st);
    assert_int_equal(st.retries, 3);

    /* With no_retries, a lost request stays lost: the timeout says so. */
    trioct_connect_options once = {.url = "memq://", .lcm = e->lcm, .no_retries = 1};
    trioct_client *c1 = trioct_connect(&once, NULL, NULL, 0);
    e->d1.drop = 1;
    assert_int_equal(trioct_rays(c1, &q, 600, &res), TRIOCT_ERR_NO_DAEMON);
    trioct_ray_result_free(&res);
    trioct_client_get_stats(c1, &st);
    assert_int_equal(st.retries, 0);
    trioct_disconnect(c1);
    trioct_disconnect(c);
}

static void test_driven_from_a_libuv_loop(void **state)
{
    env *e = *state;
    enum { N = 10 };
    /* Static: if an assertion fails, teardown's disconnect still runs callbacks into it. */
    static seen log;
    memset(&log, 0, sizeof log);
    static ray_job jobs[N + 1];
    e->d1.hold = 1;
    for (int k = 0; k < N; k++) {
        ray_job_init(&jobs[k], &log, k, 3);
        trioct_ray_query q = ray_job_query(&jobs[k], "w1");
        assert_int_equal(trioct_rays_async(e->client, &q, 3000, on_rays, &jobs[k], NULL), TRIOCT_OK);
    }
    /* One request nobody answers: only the timer can end it. */
    ray_job_init(&jobs[N], &log, N, 1);
    trioct_ray_query ghost = ray_job_query(&jobs[N], "ghost");
    double t0 = now_ms();
    assert_int_equal(trioct_rays_async(e->client, &ghost, 120, on_rays, &jobs[N], NULL), TRIOCT_OK);

    uv_loop_t loop;
    assert_int_equal(uv_loop_init(&loop), 0);
    uv_drive u = {.c = e->client, .daemon = &e->d1};
    assert_int_equal(uv_poll_init(&loop, &u.poll, trioct_fileno(e->client)), 0);
    assert_int_equal(uv_timer_init(&loop, &u.timer), 0);
    assert_int_equal(uv_timer_init(&loop, &u.answer), 0);
    assert_int_equal(uv_timer_init(&loop, &u.watchdog), 0);
    u.poll.data = u.timer.data = u.answer.data = u.watchdog.data = &u;
    assert_int_equal(uv_poll_start(&u.poll, UV_READABLE, on_uv_readable), 0);
    assert_int_equal(uv_timer_start(&u.timer, on_uv_timer, (uint64_t)trioct_next_timeout_ms(e->client), 0), 0);
    assert_int_equal(uv_timer_start(&u.answer, on_answer_time, 30, 0), 0);
    assert_int_equal(uv_timer_start(&u.watchdog, on_watchdog, 5000, 0), 0);
    assert_int_equal(uv_run(&loop, UV_RUN_DEFAULT), 0);
    assert_int_equal(uv_loop_close(&loop), 0);

    assert_int_equal(log.count, N + 1);
    for (int i = 0; i < N; i++) {
        assert_int_equal(log.tag[i], N - 1 - i);
        assert_int_equal(log.status[i], TRIOCT_OK);
        assert_true(jobs[i].checked);
        /* libuv's loop clock counts whole milliseconds, truncated: a 30 ms timer may
         * fire up to 1 ms early by a finer clock. */
        assert_true(log.at_ms[i] - t0 >= 29.0);
    }
    assert_int_equal(log.tag[N], N);
    assert_int_equal(log.status[N], TRIOCT_ERR_NO_DAEMON);
    double at = log.at_ms[N] - t0;
    assert_true(at >= 120.0 && at < 120.0 + LATE_MS);
    assert_true(u.pumps_from_fd >= 1);
    assert_true(u.pumps_from_timer >= 1);
    assert_int_equal(trioct_in_flight(e->client), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_many_requests_complete_in_the_order_answers_arrive,
                                        setup, teardown),
        cmocka_unit_test_setup_teardown(test_every_request_type_async, setup, teardown),
        cmocka_unit_test_setup_teardown(test_timeouts_fire_through_poll_in_deadline_order, setup,
                                        teardown),
        cmocka_unit_test_setup_teardown(test_list_gathers_for_its_window, setup, teardown),
        cmocka_unit_test_setup_teardown(test_cancel_forgets_a_request, setup, teardown),
        cmocka_unit_test_setup_teardown(test_callback_sends_cancels_and_calls_sync, setup,
                                        teardown),
        cmocka_unit_test_setup_teardown(test_sync_call_leaves_async_completions_to_pump, setup,
                                        teardown),
        cmocka_unit_test_setup_teardown(test_async_refusals_send_nothing, setup, teardown),
        cmocka_unit_test_setup_teardown(test_disconnect_completes_requests_in_flight, setup,
                                        teardown),
        cmocka_unit_test_setup_teardown(test_send_deadlines_option, setup, teardown),
        cmocka_unit_test_setup_teardown(test_driven_from_a_libuv_loop, setup, teardown),
        cmocka_unit_test_setup_teardown(test_lost_requests_are_sent_again, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
