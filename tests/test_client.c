/* Tests of libtrioct over memq://, without a network. The test plays the daemons: fake
 * daemons subscribe to the request channels on the client's own LCM instance, decode each
 * request with the generated decoder (after the wire check, which the client's bytes must
 * pass), and answer from inside the handler with replies built by the generated encoder,
 * cut into chunks and published in the order a script says, with foreign, malformed,
 * duplicate, missing and inconsistent chunks where a test wants them. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <inttypes.h>
#include <lcm/lcm.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "../client/trioct.h"
#include "channels.h"
#include "wire_check.h"

#include "trioct_admin_reply_t.h"
#include "trioct_admin_request_t.h"
#include "trioct_mesh_reply_t.h"
#include "trioct_mesh_request_t.h"
#include "trioct_ray_reply_t.h"
#include "trioct_ray_request_t.h"
#include "trioct_status_t.h"
#include "trioct_triangle_reply_t.h"
#include "trioct_triangle_request_t.h"

/* How late a timed-out call may return on a loaded two-core machine. */
#define LATE_MS 300

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return 1e3 * (double)ts.tv_sec + 1e-6 * (double)ts.tv_nsec;
}

/* ---------- the fake daemon ---------- */

typedef struct blob {
    uint8_t *data;
    int size;
} blob;

/* How the next answers are given. */
typedef struct script {
    int silent;          /* publish none of the answer's chunks */
    int chunks;          /* cut the answer into this many (0: 1) */
    int order[64];       /* publish these chunk indexes in this order (repeats, gaps allowed) */
    int order_len;       /* 0: every chunk in order */
    int status;          /* != 0: answer with this error status, no records */
    const char *message; /* NULL: "ok" */
    int foreign_first;   /* first a copy for another client, and one for another request */
    int malformed_first; /* first a cut-short copy and one with a foreign fingerprint */
    int bad_count;       /* the last chunk claims one chunk more */
} script;

enum { MAX_FAKE_WORLDS = 4 };

typedef struct fake {
    lcm_t *lcm;
    const char *name;
    int64_t version;
    script script;
    lcm_subscription_t *subs[8];
    int num_subs;
    int requests;     /* requests received */
    int bad_requests; /* requests failing the wire check or the decoder */
    char last_channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    /* deep copies of the last request of each type */
    trioct_ray_request_t *ray;
    trioct_triangle_request_t *tri;
    trioct_mesh_request_t *mesh;
    trioct_admin_request_t *admin;
    /* what the last answer held, whole, for exact comparison */
    int32_t *found;
    int num_found;
    trioct_ray_hit_t *hits;
    trioct_contact_t *contacts;
    trioct_segment_t *segments;
    trioct_mesh_pair_t *pairs;
    int num_records;
    /* the worlds a LIST answer names; world_daemon_field: whether world_info.daemon is
     * filled (else the client tags each world with the answering daemon) */
    const char *worlds[MAX_FAKE_WORLDS];
    int num_worlds;
    int world_daemon_field;
} fake;

static void fake_forget_answer(fake *f)
{
    free(f->found);
    free(f->hits);
    free(f->contacts);
    free(f->segments);
    free(f->pairs);
    f->found = NULL;
    f->hits = NULL;
    f->contacts = NULL;
    f->segments = NULL;
    f->pairs = NULL;
    f->num_found = f->num_records = 0;
}

static void put_be(uint8_t *p, uint64_t v, int bytes)
{
    for (int i = bytes - 1; i >= 0; i--, v >>= 8)
        p[i] = (uint8_t)v;
}

/* Offset of chunk_count in an encoded reply: fingerprint, client_id, request_id, daemon,
 * world, world_version, status, message, chunk_index. */
static size_t chunk_count_offset(const trioct_reply_header_t *h)
{
    return 8 + 8 + 8 + (4 + strlen(h->daemon) + 1) + (4 + strlen(h->world) + 1) + 8 + 2 +
           (4 + strlen(h->message) + 1) + 4;
}

static void publish(fake *f, const char *channel, const uint8_t *data, int size)
{
    assert_int_equal(lcm_publish(f->lcm, channel, data, (unsigned)size), 0);
}

/* Publishes the encoded chunks of one answer as the script says, then frees them. */
static void publish_script(fake *f, const char *channel, blob *chunks, int k,
                           const trioct_reply_header_t *h)
{
    const script *s = &f->script;
    if (s->foreign_first) {
        uint8_t *copy = malloc((size_t)chunks[0].size);
        memcpy(copy, chunks[0].data, (size_t)chunks[0].size);
        put_be(copy + 8, (uint64_t)h->client_id ^ 0x1, 8);
        publish(f, channel, copy, chunks[0].size);
        memcpy(copy, chunks[0].data, (size_t)chunks[0].size);
        put_be(copy + 16, (uint64_t)h->request_id + 1000, 8);
        publish(f, channel, copy, chunks[0].size);
        free(copy);
    }
    if (s->malformed_first) {
        publish(f, channel, chunks[0].data, chunks[0].size - 1);
        uint8_t *copy = malloc((size_t)chunks[0].size);
        memcpy(copy, chunks[0].data, (size_t)chunks[0].size);
        copy[3] ^= 0x40; /* the fingerprint */
        publish(f, channel, copy, chunks[0].size);
        free(copy);
    }
    if (s->bad_count)
        put_be(chunks[k - 1].data + chunk_count_offset(h), (uint64_t)(k + 1), 4);
    if (!s->silent) {
        if (s->order_len == 0) {
            for (int i = 0; i < k; i++)
                publish(f, channel, chunks[i].data, chunks[i].size);
        } else {
            for (int i = 0; i < s->order_len; i++)
                publish(f, channel, chunks[s->order[i]].data, chunks[s->order[i]].size);
        }
    }
    for (int i = 0; i < k; i++)
        free(chunks[i].data);
}

static trioct_reply_header_t reply_header(const fake *f, const trioct_request_header_t *rq,
                                          int index, int count)
{
    trioct_reply_header_t h = {
        .client_id = rq->client_id,
        .request_id = rq->request_id,
        .daemon = (char *)f->name,
        .world = rq->world,
        .world_version = f->version,
        .status = (int16_t)f->script.status,
        .message = (char *)(f->script.message ? f->script.message : "ok"),
        .chunk_index = index,
        .chunk_count = count,
    };
    return h;
}

static int script_chunks(const fake *f)
{
    return f->script.status != 0 ? 1 : f->script.chunks > 0 ? f->script.chunks : 1;
}

/* Records [lo, hi) of m that chunk i of k carries. */
static void slice(int m, int i, int k, int *lo, int *hi)
{
    *lo = (int)((int64_t)m * i / k);
    *hi = (int)((int64_t)m * (i + 1) / k);
}

#define ENCODE(type, msg, out)                                                   \
    do {                                                                         \
        int size_ = type##_encoded_size(msg);                                    \
        (out)->data = malloc((size_t)size_);                                     \
        (out)->size = type##_encode((out)->data, 0, size_, msg);                 \
        assert_int_equal((out)->size, size_);                                    \
    } while (0)

/* The objects every fake answer's records name, alternately. */
static char *fake_objects[2] = {"arm_base", "shelf.left"};

/* A deterministic answer to a ray request: ray i crosses i % 5 triangles for ALL (stored up
 * to max_hits), else 1 unless i % 3 == 2; the values depend on the ray so that a mixed-up
 * ray shows. */
static void answer_rays(fake *f, const trioct_ray_request_t *q)
{
    fake_forget_answer(f);
    int n = q->num_rays, m = 0;
    f->found = calloc((size_t)n + 1, sizeof *f->found);
    f->hits = calloc((size_t)n * 5 + 1, sizeof *f->hits);
    f->num_found = n;
    for (int i = 0; i < n; i++) {
        int crossings = q->detail == TRIOCT_RAY_ALL ? i % 5 : i % 3 != 2;
        int stored = q->detail == TRIOCT_RAY_ALL && crossings > q->max_hits ? q->max_hits : crossings;
        f->found[i] = crossings;
        for (int j = 0; j < stored; j++, m++) {
            f->hits[m] = (trioct_ray_hit_t){
                .ray = i,
                .t = q->tmin + 0.125 * (j + 1) + q->origin[i].x * 1e-3,
                .object = (i + j) % 2,
                .triangle = 1000 * i + j,
                .u = 0.1 + 0.01 * j,
                .v = 1.0 / 3.0,
                .normal = {q->direction[i].x, q->direction[i].y, -q->direction[i].z},
            };
        }
    }
    f->num_records = m;
    int k = script_chunks(f);
    blob chunks[64];
    trioct_reply_header_t h0 = reply_header(f, &q->header, 0, k);
    for (int c = 0; c < k; c++) {
        int lo, hi;
        slice(f->script.status ? 0 : m, c, k, &lo, &hi);
        trioct_ray_reply_t rep = {
            .header = reply_header(f, &q->header, c, k),
            .detail = q->detail,
            .num_rays = c == 0 && !f->script.status ? n : 0,
            .found = f->found,
            .num_objects = c == 0 && !f->script.status ? 2 : 0,
            .objects = fake_objects,
            .num_hits = hi - lo,
            .hits = f->hits + lo,
        };
        ENCODE(trioct_ray_reply_t, &rep, &chunks[c]);
    }
    publish_script(f, q->header.reply_channel, chunks, k, &h0);
}

/* Query triangle i touches i % 4 world triangles (YESNO: says 0 or 1, lists none). */
static void answer_triangles(fake *f, const trioct_triangle_request_t *q)
{
    fake_forget_answer(f);
    int n = q->num_triangles, m = 0;
    f->found = calloc((size_t)n + 1, sizeof *f->found);
    f->contacts = calloc((size_t)n * 4 + 1, sizeof *f->contacts);
    f->segments = calloc((size_t)n * 4 + 1, sizeof *f->segments);
    f->num_found = n;
    for (int i = 0; i < n; i++) {
        int touched = i % 4;
        f->found[i] = q->detail == TRIOCT_TRI_YESNO ? touched > 0 : touched;
        if (q->detail == TRIOCT_TRI_YESNO)
            continue;
        for (int j = 0; j < touched; j++, m++) {
            f->contacts[m] = (trioct_contact_t){.query = i, .object = (i + j) % 2, .triangle = 7 * i + j};
            trioct_vec3_t a = q->triangles[i].a, b = q->triangles[i].b;
            f->segments[m] = (trioct_segment_t){
                .p = {a.x + j, a.y, a.z},
                .q = {b.x * 0.5, b.y * 0.5, b.z + 0.1 * j},
            };
        }
    }
    f->num_records = m;
    int segments = q->detail == TRIOCT_TRI_SEGMENTS;
    int k = script_chunks(f);
    blob chunks[64];
    trioct_reply_header_t h0 = reply_header(f, &q->header, 0, k);
    for (int c = 0; c < k; c++) {
        int lo, hi;
        slice(f->script.status ? 0 : m, c, k, &lo, &hi);
        trioct_triangle_reply_t rep = {
            .header = reply_header(f, &q->header, c, k),
            .detail = q->detail,
            .num_triangles = c == 0 && !f->script.status ? n : 0,
            .found = f->found,
            .num_objects = c == 0 && !f->script.status ? 2 : 0,
            .objects = fake_objects,
            .num_contacts = hi - lo,
            .contacts = f->contacts + lo,
            .num_segments = segments ? hi - lo : 0,
            .segments = f->segments + lo,
        };
        ENCODE(trioct_triangle_reply_t, &rep, &chunks[c]);
    }
    publish_script(f, q->header.reply_channel, chunks, k, &h0);
}

/* Pose i touches in i % 3 pairs (YESNO: 0 or 1, no pairs). */
static void answer_mesh(fake *f, const trioct_mesh_request_t *q)
{
    fake_forget_answer(f);
    int n = q->num_poses, m = 0;
    f->found = calloc((size_t)n + 1, sizeof *f->found);
    f->pairs = calloc((size_t)n * 3 + 1, sizeof *f->pairs);
    f->num_found = n;
    for (int i = 0; i < n; i++) {
        int touching = i % 3;
        f->found[i] = q->detail == TRIOCT_MESH_YESNO ? touching > 0 : touching;
        if (q->detail == TRIOCT_MESH_YESNO)
            continue;
        for (int j = 0; j < touching; j++, m++)
            f->pairs[m] = (trioct_mesh_pair_t){.pose = i, .shape_triangle = j, .object = (i + j) % 2,
                                               .world_triangle = 50 * i + j};
    }
    f->num_records = m;
    int k = script_chunks(f);
    blob chunks[64];
    trioct_reply_header_t h0 = reply_header(f, &q->header, 0, k);
    for (int c = 0; c < k; c++) {
        int lo, hi;
        slice(f->script.status ? 0 : m, c, k, &lo, &hi);
        trioct_mesh_reply_t rep = {
            .header = reply_header(f, &q->header, c, k),
            .detail = q->detail,
            .num_poses = c == 0 && !f->script.status ? n : 0,
            .found = f->found,
            .num_objects = c == 0 && !f->script.status ? 2 : 0,
            .objects = fake_objects,
            .num_pairs = hi - lo,
            .pairs = f->pairs + lo,
        };
        ENCODE(trioct_mesh_reply_t, &rep, &chunks[c]);
    }
    publish_script(f, q->header.reply_channel, chunks, k, &h0);
}

static char *shape_names[] = {"gripper", "probe", "wrist"};
static char *accuracy_names[] = {"exact", "seed", "fast"};

/* World k's info, every field distinct; strings point at name, daemon, source or literals. */
static trioct_world_info_t world_info(const char *name, const char *daemon, const char *source,
                                      int k)
{
    trioct_world_info_t w = {
        .name = (char *)name,
        .daemon = (char *)daemon,
        .version = 3 + k,
        .source = (char *)source,
        .accuracy = accuracy_names[k % 3],
        .seed_epsilon = 1e-9 * (k + 1),
        .effects = 1 + k % 7,
        .triangles = 100000 + k,
        .vertices = 50000 + k,
        .degenerate = k,
        .duplicates = 2 * k,
        .bbox_min = {-1.5 - k, -2.25, -3.0},
        .bbox_max = {1.5 + k, 2.25, 3.0 / 7.0},
        .nodes = 9000 + k,
        .leaves = 8000 + k,
        .max_level = 10 + k % 6,
        .resolution = 0.05 + 0.001 * k,
        .world_size = 51.2 + k,
        .world_min = {-25.6, -25.6 - k, -1e-3},
        .bytes_nodes = 72000 + k,
        .bytes_leaf_lists = 64000 + k,
        .bytes_triangles = 7200000 + k,
        .bytes_effects = k % 2 ? 0 : 123456,
        .bytes_total = 7336000 + k,
        .build_seconds = 0.125 * (k + 1),
        .load_seconds = 0.0625 * (k + 3),
        .queries = 42 * k,
        .last_error = k % 2 ? "reload failed: mesh has NaN at triangle 3" : "",
        .num_shapes = k % 4,
        .shapes = shape_names,
    };
    return w;
}

static void check_world(const trioct_world_info *got, const char *name, const char *daemon,
                        const char *source, int k)
{
    trioct_world_info_t w = world_info(name, daemon, source, k);
    assert_string_equal(got->name, w.name);
    assert_string_equal(got->daemon, w.daemon);
    assert_int_equal(got->version, w.version);
    assert_string_equal(got->source, w.source);
    assert_string_equal(got->accuracy, w.accuracy);
    assert_true(got->seed_epsilon == w.seed_epsilon);
    assert_int_equal(got->effects, w.effects);
    assert_int_equal(got->triangles, w.triangles);
    assert_int_equal(got->vertices, w.vertices);
    assert_int_equal(got->degenerate, w.degenerate);
    assert_int_equal(got->duplicates, w.duplicates);
    assert_true(got->bbox_min.x == w.bbox_min.x && got->bbox_min.y == w.bbox_min.y &&
                got->bbox_min.z == w.bbox_min.z);
    assert_true(got->bbox_max.x == w.bbox_max.x && got->bbox_max.y == w.bbox_max.y &&
                got->bbox_max.z == w.bbox_max.z);
    assert_int_equal(got->nodes, w.nodes);
    assert_int_equal(got->leaves, w.leaves);
    assert_int_equal(got->max_level, w.max_level);
    assert_true(got->resolution == w.resolution);
    assert_true(got->world_size == w.world_size);
    assert_true(got->world_min.x == w.world_min.x && got->world_min.y == w.world_min.y &&
                got->world_min.z == w.world_min.z);
    assert_int_equal(got->bytes_nodes, w.bytes_nodes);
    assert_int_equal(got->bytes_leaf_lists, w.bytes_leaf_lists);
    assert_int_equal(got->bytes_triangles, w.bytes_triangles);
    assert_int_equal(got->bytes_effects, w.bytes_effects);
    assert_int_equal(got->bytes_total, w.bytes_total);
    assert_true(got->build_seconds == w.build_seconds);
    assert_true(got->load_seconds == w.load_seconds);
    assert_int_equal(got->queries, w.queries);
    assert_string_equal(got->last_error, w.last_error);
    assert_int_equal(got->num_shapes, w.num_shapes);
    for (int i = 0; i < w.num_shapes; i++)
        assert_string_equal(got->shapes[i], shape_names[i]);
}

/* LOAD answers with the world built from the request (k = its effects), INFO with world k=1,
 * UNLOAD with none, LIST with the daemon's worlds (k = their index), cut into chunks. */
static void answer_admin(fake *f, const trioct_admin_request_t *q)
{
    trioct_world_info_t worlds[MAX_FAKE_WORLDS];
    int n = 0;
    const char *tag = f->world_daemon_field ? f->name : "";
    if (f->script.status == 0) {
        if (q->op == TRIOCT_ADMIN_REQUEST_T_LOAD)
            worlds[n++] = world_info(q->header.world, tag,
                                     q->mesh_path[0] ? q->mesh_path : q->header.world, q->effects);
        else if (q->op == TRIOCT_ADMIN_REQUEST_T_INFO)
            worlds[n++] = world_info(q->header.world, tag, q->header.world, 1);
        else if (q->op == TRIOCT_ADMIN_REQUEST_T_LIST)
            for (int i = 0; i < f->num_worlds; i++)
                worlds[n++] = world_info(f->worlds[i], tag, f->worlds[i], i);
    }
    int k = script_chunks(f);
    blob chunks[64];
    trioct_reply_header_t h0 = reply_header(f, &q->header, 0, k);
    for (int c = 0; c < k; c++) {
        int lo, hi;
        slice(n, c, k, &lo, &hi);
        trioct_admin_reply_t rep = {
            .header = reply_header(f, &q->header, c, k),
            .op = q->op,
            .num_worlds = hi - lo,
            .worlds = worlds + lo,
        };
        ENCODE(trioct_admin_reply_t, &rep, &chunks[c]);
    }
    publish_script(f, q->header.reply_channel, chunks, k, &h0);
}

#define TAKE_REQUEST(type, wire, slot, bytes, size)                               \
    do {                                                                          \
        type msg_;                                                                \
        if (wire_check(wire, bytes, size, NULL) != 0 ||                          \
            type##_decode(bytes, 0, (int)(size), &msg_) != (int)(size)) {        \
            f->bad_requests++;                                                    \
            return;                                                               \
        }                                                                         \
        if (f->slot != NULL)                                                      \
            type##_destroy(f->slot);                                              \
        f->slot = type##_copy(&msg_);                                             \
        type##_decode_cleanup(&msg_);                                             \
    } while (0)

static void on_request(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
    fake *f = user;
    f->requests++;
    snprintf(f->last_channel, sizeof f->last_channel, "%s", channel);
    trioct_channel_kind kind;
    char name[TRIOCT_MAX_NAME_LEN + 1];
    if (trioct_channel_parse(channel, "TRIOCT", &kind, name) != 0) {
        f->bad_requests++;
        return;
    }
    const void *b = rbuf->data;
    size_t n = rbuf->data_size;
    switch (kind) {
    case TRIOCT_CHANNEL_RAY:
        TAKE_REQUEST(trioct_ray_request_t, WIRE_RAY_REQUEST, ray, b, n);
        answer_rays(f, f->ray);
        break;
    case TRIOCT_CHANNEL_TRI:
        TAKE_REQUEST(trioct_triangle_request_t, WIRE_TRIANGLE_REQUEST, tri, b, n);
        answer_triangles(f, f->tri);
        break;
    case TRIOCT_CHANNEL_MESH:
        TAKE_REQUEST(trioct_mesh_request_t, WIRE_MESH_REQUEST, mesh, b, n);
        answer_mesh(f, f->mesh);
        break;
    default:
        TAKE_REQUEST(trioct_admin_request_t, WIRE_ADMIN_REQUEST, admin, b, n);
        answer_admin(f, f->admin);
        break;
    }
}

static void fake_start(fake *f, lcm_t *lcm, const char *name, const char *const *channels)
{
    memset(f, 0, sizeof *f);
    f->lcm = lcm;
    f->name = name;
    f->version = 7;
    for (; *channels != NULL; channels++) {
        lcm_subscription_t *s = lcm_subscribe(lcm, *channels, on_request, f);
        assert_non_null(s);
        f->subs[f->num_subs++] = s;
    }
}

static void fake_stop(fake *f)
{
    for (int i = 0; i < f->num_subs; i++)
        lcm_unsubscribe(f->lcm, f->subs[i]);
    if (f->ray)
        trioct_ray_request_t_destroy(f->ray);
    if (f->tri)
        trioct_triangle_request_t_destroy(f->tri);
    if (f->mesh)
        trioct_mesh_request_t_destroy(f->mesh);
    if (f->admin)
        trioct_admin_request_t_destroy(f->admin);
    fake_forget_answer(f);
}

/* ---------- fixture: one memq bus, daemon d1 holding w1, one client ---------- */

typedef struct env {
    lcm_t *lcm;
    fake d1;
    trioct_client *client;
} env;

static int setup(void **state)
{
    env *e = calloc(1, sizeof *e);
    e->lcm = lcm_create("memq://");
    if (e->lcm == NULL)
        return -1;
    static const char *const channels[] = {"TRIOCT_RAY_w1", "TRIOCT_TRI_w1", "TRIOCT_MESH_w1",
                                           "TRIOCT_ADMIN_w1", "TRIOCT_LOAD_d1", NULL};
    fake_start(&e->d1, e->lcm, "d1", channels);
    trioct_connect_options opt = {.url = "memq://", .lcm = e->lcm};
    int status = -1;
    char err[256];
    e->client = trioct_connect(&opt, &status, err, sizeof err);
    if (e->client == NULL || status != TRIOCT_OK)
        return -1;
    *state = e;
    return 0;
}

static int teardown(void **state)
{
    env *e = *state;
    /* The client's bytes passed the wire check and decoded whole in every test. */
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

static void make_rays(size_t n, trioct_vec3 *origins, trioct_vec3 *directions)
{
    for (size_t i = 0; i < n; i++) {
        origins[i] = (trioct_vec3){0.1 * (double)i, -2.0 / 3.0, 1e9 + (double)i};
        directions[i] = (trioct_vec3){1.0, 1e-300 * (double)(i + 1), -0.7 * (double)i};
    }
}

static void check_ray_request(const trioct_ray_request_t *got, const trioct_ray_query *q)
{
    assert_int_equal(got->detail, q->detail);
    assert_int_equal(got->accuracy, q->accuracy);
    assert_true(got->tmin == q->tmin);
    assert_true(got->tmax == q->tmax);
    assert_int_equal(got->max_hits, q->max_hits);
    assert_int_equal(got->num_rays, (int)q->count);
    assert_string_equal(got->header.world, q->world);
    for (size_t i = 0; i < q->count; i++) {
        assert_memory_equal(&got->origin[i], &q->origins[i], sizeof(trioct_vec3));
        assert_memory_equal(&got->direction[i], &q->directions[i], sizeof(trioct_vec3));
    }
}

/* The result is exactly what the fake daemon sent. */
static void check_ray_result(const trioct_ray_result *res, const fake *f)
{
    assert_int_equal(res->num_rays, (size_t)f->num_found);
    assert_memory_equal(res->found, f->found, (size_t)f->num_found * sizeof(int32_t));
    assert_int_equal(res->num_hits, (size_t)f->num_records);
    for (int k = 0; k < f->num_records; k++) {
        const trioct_ray_hit_t *w = &f->hits[k];
        const trioct_ray_hit *g = &res->hits[k];
        assert_int_equal(g->ray, w->ray);
        assert_true(g->t == w->t);
        assert_int_equal(g->triangle, w->triangle);
        assert_true(g->u == w->u && g->v == w->v);
        assert_true(g->normal.x == w->normal.x && g->normal.y == w->normal.y &&
                    g->normal.z == w->normal.z);
    }
}

/* ---------- connection ---------- */

static void test_connect_ids_channels_and_refusals(void **state)
{
    env *e = *state;
    trioct_client *c1 = e->client;
    uint64_t id1 = trioct_client_id(c1);
    assert_true(id1 != 0);
    char want[64];
    snprintf(want, sizeof want, "TRIOCT_R_%016" PRIx64, id1);
    assert_string_equal(trioct_reply_channel(c1), want);
    assert_int_equal(strlen(want), 9 + 16);
    assert_true(trioct_name_valid(want, TRIOCT_MAX_CHANNEL_LEN));
    assert_string_equal(trioct_url(c1), "memq://");
    assert_string_equal(trioct_prefix(c1), "TRIOCT");
    assert_true(trioct_fileno(c1) >= 0);

    trioct_connect_options opt = {.prefix = "ROBOT_2", .lcm = e->lcm};
    int status = -1;
    char err[200];
    trioct_client *c2 = trioct_connect(&opt, &status, err, sizeof err);
    assert_non_null(c2);
    assert_int_equal(status, TRIOCT_OK);
    assert_true(trioct_client_id(c2) != 0 && trioct_client_id(c2) != id1);
    snprintf(want, sizeof want, "ROBOT_2_R_%016" PRIx64, trioct_client_id(c2));
    assert_string_equal(trioct_reply_channel(c2), want);
    assert_string_equal(trioct_url(c2), "the caller's LCM instance");
    trioct_disconnect(c2);

    opt.prefix = "bad-prefix";
    assert_null(trioct_connect(&opt, &status, err, sizeof err));
    assert_int_equal(status, TRIOCT_ERR_BAD_REQUEST);
    assert_string_equal(err, "invalid channel prefix \"bad-prefix\": 1..16 characters of [A-Za-z0-9_]");
    opt.prefix = "PREFIX_OF_17_CHAR";
    assert_null(trioct_connect(&opt, &status, err, sizeof err));
    assert_int_equal(status, TRIOCT_ERR_BAD_REQUEST);

    /* Its own bus: a memq instance it creates and closes. */
    trioct_connect_options own = {.url = "memq://"};
    trioct_client *c3 = trioct_connect(&own, &status, err, sizeof err);
    assert_non_null(c3);
    assert_int_equal(trioct_pump(c3), 0);
    trioct_disconnect(c3);
    trioct_disconnect(NULL);

    own.url = "nosuchprovider://";
    assert_null(trioct_connect(&own, &status, err, sizeof err));
    assert_int_equal(status, TRIOCT_ERR_TRANSPORT);
    assert_string_equal(err, "cannot open LCM on nosuchprovider://");

    assert_string_equal(trioct_status_text(TRIOCT_ERR_NO_DAEMON), "no daemon serves the world");
    assert_string_equal(trioct_status_name(TRIOCT_ERR_TIMEOUT), "ERR_TIMEOUT");
}

/* ---------- rays ---------- */

static void test_rays_closest_exact(void **state)
{
    env *e = *state;
    trioct_vec3 o[5], d[5];
    make_rays(5, o, d);
    trioct_ray_query q = trioct_ray_query_default("w1");
    q.accuracy = TRIOCT_ACCURACY_FAST;
    q.tmin = 0.5;
    q.tmax = 1e6;
    q.count = 5;
    q.origins = o;
    q.directions = d;
    trioct_ray_result res;
    assert_int_equal(trioct_rays(e->client, &q, 2000, &res), TRIOCT_OK);
    assert_int_equal(e->d1.requests, 1);
    assert_string_equal(e->d1.last_channel, "TRIOCT_RAY_w1");
    check_ray_request(e->d1.ray, &q);
    assert_true((uint64_t)e->d1.ray->header.client_id == trioct_client_id(e->client));
    assert_string_equal(e->d1.ray->header.reply_channel, trioct_reply_channel(e->client));
    assert_int_equal(e->d1.ray->header.deadline_utime, 0);
    int64_t first_id = e->d1.ray->header.request_id;
    assert_int_equal(first_id, 1);

    assert_int_equal(res.reply.status, TRIOCT_OK);
    assert_string_equal(res.reply.message, "ok");
    assert_string_equal(res.reply.daemon, "d1");
    assert_string_equal(res.reply.world, "w1");
    assert_int_equal(res.reply.world_version, 7);
    assert_int_equal(res.reply.request_id, first_id);
    assert_int_equal(res.reply.chunks, 1);
    assert_int_equal(res.detail, TRIOCT_RAY_CLOSEST);
    /* Rays 0, 1, 3, 4 hit; ray 2 misses. */
    assert_int_equal(res.num_hits, 4);
    assert_int_equal(res.found[2], 0);
    assert_int_equal(res.hits[2].ray, 3);
    check_ray_result(&res, &e->d1);
    trioct_ray_result_free(&res);
    trioct_ray_result_free(&res); /* twice is fine */

    /* Request ids count up; ANY and an infinite tmax travel as they are. */
    q.detail = TRIOCT_RAY_ANY;
    q.tmax = INFINITY;
    assert_int_equal(trioct_rays(e->client, &q, 2000, &res), TRIOCT_OK);
    assert_int_equal(e->d1.ray->header.request_id, first_id + 1);
    check_ray_request(e->d1.ray, &q);
    check_ray_result(&res, &e->d1);
    trioct_ray_result_free(&res);

    trioct_client_stats s = stats_of(e->client);
    assert_int_equal(s.requests_sent, 2);
    assert_int_equal(s.chunks_accepted, 2);
    assert_int_equal(s.foreign_client + s.unmatched + s.duplicate_chunks + s.malformed, 0);
    assert_int_equal(e->d1.ray->contact, TRIOCT_CONTACT_CROSSING); /* what trioct_rays asks */
}

/* trioct_rays_contact puts its rule on the wire; an unknown rule never leaves the client. */
static void test_rays_contact_travels(void **state)
{
    env *e = *state;
    trioct_vec3 o[3], d[3];
    make_rays(3, o, d);
    trioct_ray_query q = trioct_ray_query_default("w1");
    q.detail = TRIOCT_RAY_ANY;
    q.count = 3;
    q.origins = o;
    q.directions = d;
    trioct_ray_result res;
    assert_int_equal(trioct_rays_contact(e->client, &q, TRIOCT_CONTACT_TOUCH, 2000, &res), TRIOCT_OK);
    check_ray_request(e->d1.ray, &q);
    assert_int_equal(e->d1.ray->contact, TRIOCT_CONTACT_TOUCH);
    check_ray_result(&res, &e->d1);
    trioct_ray_result_free(&res);
    assert_int_equal(trioct_rays_contact(e->client, &q, TRIOCT_CONTACT_CROSSING, 2000, &res), TRIOCT_OK);
    assert_int_equal(e->d1.ray->contact, TRIOCT_CONTACT_CROSSING);
    trioct_ray_result_free(&res);
    int sent = e->d1.requests;
    assert_int_equal(trioct_rays_contact(e->client, &q, 2, 2000, &res), TRIOCT_ERR_BAD_REQUEST);
    assert_string_equal(res.reply.message, "unknown contact 2 (TRIOCT_CONTACT_CROSSING or _TOUCH)");
    assert_int_equal(e->d1.requests, sent);
}

static void test_rays_all_many_chunks_out_of_order_with_duplicates(void **state)
{
    env *e = *state;
    enum { N = 1000 };
    static trioct_vec3 o[N], d[N];
    make_rays(N, o, d);
    trioct_ray_query q = trioct_ray_query_default("w1");
    q.detail = TRIOCT_RAY_ALL;
    q.max_hits = 3;
    q.count = N;
    q.origins = o;
    q.directions = d;
    /* Nine chunks, shuffled, with chunks 4 and 0 sent twice before the last new one. */
    script s = {.chunks = 9, .order = {6, 2, 8, 4, 0, 4, 1, 7, 0, 3, 5}, .order_len = 11};
    e->d1.script = s;
    trioct_ray_result res;
    assert_int_equal(trioct_rays(e->client, &q, 2000, &res), TRIOCT_OK);
    assert_int_equal(res.reply.chunks, 9);
    assert_int_equal(res.detail, TRIOCT_RAY_ALL);
    /* i % 5 crossings, at most 3 stored: 200 * (0+1+2+3+3) = 1800 hits; found keeps 4. */
    assert_int_equal(res.num_hits, 1800);
    assert_int_equal(res.found[4], 4);
    check_ray_result(&res, &e->d1);
    trioct_ray_result_free(&res);
    trioct_client_stats st = stats_of(e->client);
    assert_int_equal(st.chunks_accepted, 9);
    assert_int_equal(st.duplicate_chunks, 2);
    assert_int_equal(trioct_pump(e->client), 0);
}

static void test_foreign_replies_ignored(void **state)
{
    env *e = *state;
    trioct_vec3 o[3], d[3];
    make_rays(3, o, d);
    trioct_ray_query q = trioct_ray_query_default("w1");
    q.count = 3;
    q.origins = o;
    q.directions = d;
    e->d1.script = (script){.foreign_first = 1};
    trioct_ray_result res;
    assert_int_equal(trioct_rays(e->client, &q, 2000, &res), TRIOCT_OK);
    check_ray_result(&res, &e->d1);
    trioct_ray_result_free(&res);
    trioct_client_stats s = stats_of(e->client);
    assert_int_equal(s.foreign_client, 1);
    assert_int_equal(s.unmatched, 1);
    assert_int_equal(s.chunks_accepted, 1);

    /* A reply to a request that gave up arrives later: counted when the bus is pumped. */
    e->d1.script = (script){.chunks = 2, .order = {0}, .order_len = 1};
    assert_int_equal(trioct_rays(e->client, &q, 30, &res), TRIOCT_ERR_TIMEOUT);
    trioct_ray_result_free(&res);
    int64_t late_id = e->d1.ray->header.request_id;
    trioct_ray_reply_t late = {
        .header = {.client_id = (int64_t)trioct_client_id(e->client), .request_id = late_id,
                   .daemon = "d1", .world = "w1", .message = "ok", .chunk_index = 1,
                   .chunk_count = 2},
    };
    blob b;
    ENCODE(trioct_ray_reply_t, &late, &b);
    publish(&e->d1, trioct_reply_channel(e->client), b.data, b.size);
    free(b.data);
    assert_int_equal(trioct_pump(e->client), 1);
    assert_int_equal(stats_of(e->client).unmatched, 2);
}

static void test_malformed_reply_ignored_then_good_one_accepted(void **state)
{
    env *e = *state;
    trioct_vec3 o[4], d[4];
    make_rays(4, o, d);
    trioct_ray_query q = trioct_ray_query_default("w1");
    q.count = 4;
    q.origins = o;
    q.directions = d;
    e->d1.script = (script){.malformed_first = 1, .chunks = 2};
    trioct_ray_result res;
    assert_int_equal(trioct_rays(e->client, &q, 2000, &res), TRIOCT_OK);
    check_ray_result(&res, &e->d1);
    trioct_ray_result_free(&res);
    trioct_client_stats s = stats_of(e->client);
    assert_int_equal(s.malformed, 2);
    assert_int_equal(s.chunks_accepted, 2);

    /* Too short to carry ids at all: malformed too. */
    publish(&e->d1, trioct_reply_channel(e->client), (const uint8_t *)"abc", 3);
    assert_int_equal(trioct_pump(e->client), 1);
    assert_int_equal(stats_of(e->client).malformed, 3);

    /* Nothing but malformed replies: a bad reply, not "no daemon". */
    e->d1.script = (script){.malformed_first = 1, .silent = 1};
    double t0 = now_ms();
    assert_int_equal(trioct_rays(e->client, &q, 100, &res), TRIOCT_ERR_BAD_REPLY);
    assert_true(now_ms() - t0 >= 100.0);
    assert_string_equal(res.reply.message, "2 malformed replies and no good one within 100 ms");
    assert_null(res.found);
    trioct_ray_result_free(&res);
}

static void test_error_status_passed_through(void **state)
{
    env *e = *state;
    trioct_vec3 o[2], d[2];
    make_rays(2, o, d);
    trioct_ray_query q = trioct_ray_query_default("w1");
    q.count = 2;
    q.origins = o;
    q.directions = d;
    e->d1.script = (script){.status = TRIOCT_ERR_EFFECT,
                            .message = "world w1 does not serve rays (effects: triangles)"};
    trioct_ray_result res;
    assert_int_equal(trioct_rays(e->client, &q, 2000, &res), TRIOCT_ERR_EFFECT);
    assert_int_equal(res.reply.status, TRIOCT_ERR_EFFECT);
    assert_string_equal(res.reply.message, "world w1 does not serve rays (effects: triangles)");
    assert_string_equal(res.reply.daemon, "d1");
    assert_int_equal(res.reply.world_version, 7);
    assert_int_equal(res.reply.request_id, e->d1.ray->header.request_id);
    assert_null(res.found);
    assert_null(res.hits);
    assert_int_equal(res.num_hits, 0);
    trioct_ray_result_free(&res);
}

static void test_timeout_without_reply_is_no_daemon(void **state)
{
    env *e = *state;
    trioct_vec3 o[1], d[1];
    make_rays(1, o, d);
    trioct_ray_query q = trioct_ray_query_default("ghost");
    q.count = 1;
    q.origins = o;
    q.directions = d;
    trioct_ray_result res;
    double t0 = now_ms();
    assert_int_equal(trioct_rays(e->client, &q, 150, &res), TRIOCT_ERR_NO_DAEMON);
    double took = now_ms() - t0;
    assert_true(took >= 150.0);
    assert_true(took < 150.0 + LATE_MS);
    assert_string_equal(res.reply.message, "no daemon serves world ghost on memq:// (no reply within 150 ms)");
    assert_int_equal(res.reply.request_id, 1);
    trioct_ray_result_free(&res);

    /* The holder hears the request and stays silent: the same. */
    q.world = "w1";
    e->d1.script = (script){.silent = 1};
    t0 = now_ms();
    assert_int_equal(trioct_rays(e->client, &q, 120, &res), TRIOCT_ERR_NO_DAEMON);
    took = now_ms() - t0;
    assert_true(took >= 120.0 && took < 120.0 + LATE_MS);
    assert_int_equal(e->d1.requests, 1);
    trioct_ray_result_free(&res);
}

static void test_timeout_with_partial_chunks(void **state)
{
    env *e = *state;
    trioct_vec3 o[40], d[40];
    make_rays(40, o, d);
    trioct_ray_query q = trioct_ray_query_default("w1");
    q.count = 40;
    q.origins = o;
    q.directions = d;
    e->d1.script = (script){.chunks = 4, .order = {0, 2, 2}, .order_len = 3};
    trioct_ray_result res;
    double t0 = now_ms();
    assert_int_equal(trioct_rays(e->client, &q, 150, &res), TRIOCT_ERR_TIMEOUT);
    double took = now_ms() - t0;
    assert_true(took >= 150.0 && took < 150.0 + LATE_MS);
    assert_string_equal(res.reply.message, "reply from daemon d1 incomplete: 2 of 4 chunks within 150 ms");
    assert_string_equal(res.reply.daemon, "d1");
    assert_null(res.found);
    trioct_ray_result_free(&res);
    assert_int_equal(stats_of(e->client).duplicate_chunks, 1);
}

static void test_inconsistent_chunk_count_is_bad_reply(void **state)
{
    env *e = *state;
    trioct_vec3 o[30], d[30];
    make_rays(30, o, d);
    trioct_ray_query q = trioct_ray_query_default("w1");
    q.count = 30;
    q.origins = o;
    q.directions = d;
    e->d1.script = (script){.chunks = 3, .bad_count = 1};
    trioct_ray_result res;
    double t0 = now_ms();
    assert_int_equal(trioct_rays(e->client, &q, 5000, &res), TRIOCT_ERR_BAD_REPLY);
    assert_true(now_ms() - t0 < 1000.0); /* known bad at once, not at the timeout */
    assert_string_equal(res.reply.message,
                        "bad reply from daemon d1: chunk 2 says 4 chunks, an earlier one said 3");
    trioct_ray_result_free(&res);
}

/* ---------- triangles ---------- */

static void make_triangles(size_t n, trioct_triangle *t)
{
    for (size_t i = 0; i < n; i++) {
        double x = (double)i;
        t[i] = (trioct_triangle){{x, 0.1, -x}, {x + 1.0 / 3.0, 2.0, 1e-12}, {-x, 1e8, 0.5}};
    }
}

static void test_triangles_ids_and_segments_chunked(void **state)
{
    env *e = *state;
    enum { N = 41 };
    trioct_triangle t[N];
    make_triangles(N, t);
    trioct_triangle_query q = {.world = "w1", .detail = TRIOCT_TRI_SEGMENTS,
                               .accuracy = TRIOCT_ACCURACY_EXACT, .count = N, .triangles = t};
    e->d1.script = (script){.chunks = 3, .order = {2, 1, 0}, .order_len = 3};
    trioct_triangle_result res;
    assert_int_equal(trioct_triangles(e->client, &q, 2000, &res), TRIOCT_OK);
    assert_string_equal(e->d1.last_channel, "TRIOCT_TRI_w1");
    const trioct_triangle_request_t *got = e->d1.tri;
    assert_int_equal(got->detail, TRIOCT_TRI_SEGMENTS);
    assert_int_equal(got->accuracy, TRIOCT_ACCURACY_EXACT);
    assert_int_equal(got->num_triangles, N);
    for (int i = 0; i < N; i++)
        assert_memory_equal(&got->triangles[i], &t[i], sizeof t[i]);

    assert_int_equal(res.reply.chunks, 3);
    assert_int_equal(res.detail, TRIOCT_TRI_SEGMENTS);
    assert_int_equal(res.num_triangles, N);
    assert_memory_equal(res.found, e->d1.found, N * sizeof(int32_t));
    /* i % 4 contacts each: 10 * (0 + 1 + 2 + 3) for i < 40, none for i = 40. */
    assert_int_equal(res.num_contacts, 60);
    assert_non_null(res.segments);
    for (int k = 0; k < e->d1.num_records; k++) {
        assert_int_equal(res.contacts[k].query, e->d1.contacts[k].query);
        assert_int_equal(res.contacts[k].triangle, e->d1.contacts[k].triangle);
        assert_memory_equal(&res.segments[k], &e->d1.segments[k], sizeof res.segments[k]);
    }
    trioct_triangle_result_free(&res);

    q.detail = TRIOCT_TRI_IDS;
    e->d1.script = (script){0};
    assert_int_equal(trioct_triangles(e->client, &q, 2000, &res), TRIOCT_OK);
    assert_int_equal(res.num_contacts, 60);
    assert_null(res.segments);
    assert_int_equal(res.contacts[59].query, e->d1.contacts[59].query);
    assert_int_equal(res.contacts[59].triangle, e->d1.contacts[59].triangle);
    trioct_triangle_result_free(&res);

    q.detail = TRIOCT_TRI_YESNO;
    q.count = 5;
    assert_int_equal(trioct_triangles(e->client, &q, 2000, &res), TRIOCT_OK);
    int32_t yesno[5] = {0, 1, 1, 1, 0};
    assert_memory_equal(res.found, yesno, sizeof yesno);
    assert_int_equal(res.num_contacts, 0);
    trioct_triangle_result_free(&res);
}

/* ---------- mesh ---------- */

static void make_poses(size_t n, trioct_pose *p)
{
    for (size_t i = 0; i < n; i++) {
        double c = cos(0.1 * (double)i), s = sin(0.1 * (double)i);
        p[i] = (trioct_pose){{c, -s, 0, s, c, 0, 0, 0, 1}, {(double)i, -0.5, 1.0 / 7.0}};
    }
}

static void test_mesh_named_shape_pairs_and_inline_yesno(void **state)
{
    env *e = *state;
    enum { N = 100 };
    trioct_pose poses[N];
    make_poses(N, poses);
    trioct_mesh_query q = {.world = "w1", .detail = TRIOCT_MESH_PAIRS,
                           .accuracy = TRIOCT_ACCURACY_SEED, .shape = "gripper",
                           .num_poses = N, .poses = poses};
    e->d1.script = (script){.chunks = 4, .order = {3, 0, 2, 1}, .order_len = 4};
    trioct_mesh_result res;
    assert_int_equal(trioct_mesh(e->client, &q, 2000, &res), TRIOCT_OK);
    const trioct_mesh_request_t *got = e->d1.mesh;
    assert_string_equal(e->d1.last_channel, "TRIOCT_MESH_w1");
    assert_string_equal(got->shape, "gripper");
    assert_int_equal(got->detail, TRIOCT_MESH_PAIRS);
    assert_int_equal(got->accuracy, TRIOCT_ACCURACY_SEED);
    assert_int_equal(got->num_shape_triangles, 0);
    assert_int_equal(got->num_poses, N);
    for (int i = 0; i < N; i++) {
        assert_memory_equal(got->poses[i].r, poses[i].r, sizeof poses[i].r);
        assert_memory_equal(&got->poses[i].t, &poses[i].t, sizeof poses[i].t);
    }
    assert_int_equal(res.reply.chunks, 4);
    assert_int_equal(res.num_poses, N);
    assert_memory_equal(res.found, e->d1.found, N * sizeof(int32_t));
    /* i % 3 pairs: 33 poses with 1 and 33 with 2 (i < 99), so 99. */
    assert_int_equal(res.num_pairs, 99);
    for (int k = 0; k < e->d1.num_records; k++) {
        assert_int_equal(res.pairs[k].pose, e->d1.pairs[k].pose);
        assert_int_equal(res.pairs[k].shape_triangle, e->d1.pairs[k].shape_triangle);
        assert_int_equal(res.pairs[k].world_triangle, e->d1.pairs[k].world_triangle);
    }
    trioct_mesh_result_free(&res);

    trioct_triangle shape[3];
    make_triangles(3, shape);
    q = (trioct_mesh_query){.world = "w1", .detail = TRIOCT_MESH_YESNO,
                            .accuracy = TRIOCT_ACCURACY_WORLD, .num_shape_triangles = 3,
                            .shape_triangles = shape, .num_poses = 4, .poses = poses};
    e->d1.script = (script){0};
    assert_int_equal(trioct_mesh(e->client, &q, 2000, &res), TRIOCT_OK);
    got = e->d1.mesh;
    assert_string_equal(got->shape, "");
    assert_int_equal(got->num_shape_triangles, 3);
    for (int i = 0; i < 3; i++)
        assert_memory_equal(&got->shape_triangles[i], &shape[i], sizeof shape[i]);
    int32_t yesno[4] = {0, 1, 1, 0};
    assert_memory_equal(res.found, yesno, sizeof yesno);
    assert_int_equal(res.num_pairs, 0);
    trioct_mesh_result_free(&res);
}

/* ---------- world admin ---------- */

static void test_load_info_unload(void **state)
{
    env *e = *state;
    e->d1.world_daemon_field = 1;
    trioct_load_options load = {.world = "w1", .daemon = "d1", .mesh_path = "meshes/arm.stl",
                                .resolution = 0.05, .accuracy = TRIOCT_ACCURACY_SEED,
                                .seed_epsilon = 1e-9,
                                .effects = TRIOCT_EFFECT_RAYS | TRIOCT_EFFECT_MESHES};
    trioct_admin_result res;
    assert_int_equal(trioct_load(e->client, &load, 2000, &res), TRIOCT_OK);
    const trioct_admin_request_t *got = e->d1.admin;
    assert_string_equal(e->d1.last_channel, "TRIOCT_LOAD_d1");
    assert_int_equal(got->op, TRIOCT_ADMIN_REQUEST_T_LOAD);
    assert_string_equal(got->header.world, "w1");
    assert_string_equal(got->mesh_path, "meshes/arm.stl");
    assert_true(got->resolution == 0.05);
    assert_int_equal(got->accuracy, TRIOCT_ACCURACY_SEED);
    assert_true(got->seed_epsilon == 1e-9);
    assert_int_equal(got->effects, 5);
    assert_int_equal(res.num_worlds, 1);
    check_world(&res.worlds[0], "w1", "d1", "meshes/arm.stl", 5);
    trioct_admin_result_free(&res);

    /* From the scene's section: an empty mesh path. */
    load = (trioct_load_options){.world = "w1", .daemon = "d1"};
    assert_int_equal(trioct_load(e->client, &load, 2000, &res), TRIOCT_OK);
    assert_string_equal(e->d1.admin->mesh_path, "");
    assert_int_equal(e->d1.admin->effects, 0);
    check_world(&res.worlds[0], "w1", "d1", "w1", 0);
    trioct_admin_result_free(&res);

    assert_int_equal(trioct_info(e->client, "w1", 2000, &res), TRIOCT_OK);
    assert_string_equal(e->d1.last_channel, "TRIOCT_ADMIN_w1");
    assert_int_equal(e->d1.admin->op, TRIOCT_ADMIN_REQUEST_T_INFO);
    assert_int_equal(res.num_worlds, 1);
    check_world(&res.worlds[0], "w1", "d1", "w1", 1);
    trioct_admin_result_free(&res);

    e->d1.script = (script){.message = "unloaded w1"};
    assert_int_equal(trioct_unload(e->client, "w1", 2000, &res), TRIOCT_OK);
    assert_int_equal(e->d1.admin->op, TRIOCT_ADMIN_REQUEST_T_UNLOAD);
    assert_string_equal(res.reply.message, "unloaded w1");
    assert_int_equal(res.num_worlds, 0);
    trioct_admin_result_free(&res);

    e->d1.script = (script){.status = TRIOCT_ERR_BAD_PATH,
                            .message = "../etc/passwd is outside the world directory"};
    load = (trioct_load_options){.world = "w1", .daemon = "d1", .mesh_path = "../etc/passwd"};
    assert_int_equal(trioct_load(e->client, &load, 2000, &res), TRIOCT_ERR_BAD_PATH);
    assert_string_equal(res.reply.message, "../etc/passwd is outside the world directory");
    trioct_admin_result_free(&res);

    /* No daemon named trioctd (the default) listens on this bus. */
    load.daemon = NULL;
    double t0 = now_ms();
    assert_int_equal(trioct_load(e->client, &load, 60, &res), TRIOCT_ERR_NO_DAEMON);
    assert_true(now_ms() - t0 >= 60.0);
    assert_string_equal(res.reply.message, "no daemon named trioctd on memq:// (no reply within 60 ms)");
    trioct_admin_result_free(&res);
    assert_int_equal(trioct_info(e->client, "w2", 40, &res), TRIOCT_ERR_NO_DAEMON);
    assert_string_equal(res.reply.message, "no daemon serves world w2 on memq:// (no reply within 40 ms)");
    trioct_admin_result_free(&res);
}

static void test_list_gathers_two_daemons(void **state)
{
    env *e = *state;
    static const char *const list[] = {"TRIOCT_LIST", NULL};
    fake a, b;
    fake_start(&a, e->lcm, "d1", list);
    fake_start(&b, e->lcm, "d2", list);
    a.worlds[0] = "w1";
    a.worlds[1] = "w2";
    a.num_worlds = 2;
    a.world_daemon_field = 1;
    b.worlds[0] = "w3";
    b.worlds[1] = "w4";
    b.worlds[2] = "w5";
    b.num_worlds = 3;
    b.script = (script){.chunks = 2, .order = {1, 0}, .order_len = 2};

    trioct_list_options opt = {.expect_daemons = 2};
    trioct_list_result res;
    double t0 = now_ms();
    assert_int_equal(trioct_list(e->client, &opt, 5000, &res), TRIOCT_OK);
    assert_true(now_ms() - t0 < 1000.0); /* both answered: no need to wait on */
    assert_string_equal(a.last_channel, "TRIOCT_LIST");
    assert_int_equal(a.admin->op, TRIOCT_ADMIN_REQUEST_T_LIST);
    assert_int_equal(res.num_daemons, 2);
    assert_string_equal(res.daemons[0].daemon, "d1");
    assert_string_equal(res.daemons[1].daemon, "d2");
    assert_int_equal(res.daemons[1].chunks, 2);
    assert_int_equal(res.daemons[0].status, TRIOCT_OK);
    assert_int_equal(res.num_worlds, 5);
    check_world(&res.worlds[0], "w1", "d1", "w1", 0);
    check_world(&res.worlds[1], "w2", "d1", "w2", 1);
    /* d2's worlds do not name their daemon: the answer tags them. */
    check_world(&res.worlds[2], "w3", "d2", "w3", 0);
    check_world(&res.worlds[3], "w4", "d2", "w4", 1);
    check_world(&res.worlds[4], "w5", "d2", "w5", 2);
    assert_string_equal(res.reply.message, "5 worlds from 2 daemons");
    trioct_list_result_free(&res);

    /* Without an expected count: gathers for the window, shorter than the timeout. */
    opt = (trioct_list_options){.gather_ms = 120};
    t0 = now_ms();
    assert_int_equal(trioct_list(e->client, &opt, 10000, &res), TRIOCT_OK);
    double took = now_ms() - t0;
    assert_true(took >= 120.0 && took < 120.0 + LATE_MS);
    assert_int_equal(res.num_daemons, 2);
    assert_int_equal(res.num_worlds, 5);
    trioct_list_result_free(&res);

    /* One daemon's answer comes in part: the whole one is kept, the status says so. */
    b.script = (script){.chunks = 2, .order = {1}, .order_len = 1};
    assert_int_equal(trioct_list(e->client, NULL, 100, &res), TRIOCT_ERR_TIMEOUT);
    assert_int_equal(res.num_daemons, 2);
    assert_int_equal(res.num_worlds, 2);
    assert_int_equal(res.daemons[1].status, TRIOCT_ERR_TIMEOUT);
    assert_string_equal(res.reply.message, "daemon d2: incomplete: 1 of 2 chunks within 100 ms");
    trioct_list_result_free(&res);

    fake_stop(&a);
    fake_stop(&b);
    assert_int_equal(a.bad_requests + b.bad_requests, 0);

    assert_int_equal(trioct_list(e->client, NULL, -1, &res), TRIOCT_ERR_BAD_REQUEST);
    assert_string_equal(res.reply.message,
                        "a LIST without a timeout needs a gather window or an expected count");
    t0 = now_ms();
    assert_int_equal(trioct_list(e->client, NULL, 80, &res), TRIOCT_ERR_NO_DAEMON);
    assert_true(now_ms() - t0 >= 80.0);
    assert_string_equal(res.reply.message, "no daemon answered on memq:// (no reply within 80 ms)");
    assert_int_equal(res.num_worlds, 0);
    trioct_list_result_free(&res);
}

/* Two daemons holding the same world both answer: the first whole answer stands. */
static void test_second_answer_to_one_request_ignored(void **state)
{
    env *e = *state;
    static const char *const rays[] = {"TRIOCT_RAY_w1", NULL};
    fake twin;
    fake_start(&twin, e->lcm, "d1b", rays);
    trioct_vec3 o[2], d[2];
    make_rays(2, o, d);
    trioct_ray_query q = trioct_ray_query_default("w1");
    q.count = 2;
    q.origins = o;
    q.directions = d;
    trioct_ray_result res;
    assert_int_equal(trioct_rays(e->client, &q, 2000, &res), TRIOCT_OK);
    assert_int_equal(e->d1.requests + twin.requests, 2);
    trioct_pump(e->client);
    assert_int_equal(stats_of(e->client).unmatched, 1);
    assert_int_equal(stats_of(e->client).chunks_accepted, 1);
    trioct_ray_result_free(&res);
    fake_stop(&twin);
}

/* ---------- status ---------- */

static void publish_status(lcm_t *lcm, const char *daemon, int k)
{
    int64_t by_status[TRIOCT_WIRE_STATUS_COUNT] = {0};
    for (int i = 0; i < TRIOCT_WIRE_STATUS_COUNT; i++)
        by_status[i] = 10 * i + k;
    trioct_world_info_t worlds[2] = {world_info("w1", daemon, "w1", 0),
                                     world_info("w2", daemon, "meshes/w2.ply", 3)};
    trioct_load_progress_t loads[1] = {{.world = "big", .client_id = 0x4c7fb7a37e1466d1, .request_id = 2 + k,
                                        .phase = "building octrees", .files_done = 1, .files_total = 2,
                                        .triangles = 405000, .elapsed_seconds = 0.375}};
    trioct_status_t s = {
        .utime = 1763760000000000 + k,
        .daemon = (char *)daemon,
        .version = "trioctd 0.5.0",
        .uptime_us = 123456789 + k,
        .state = TRIOCT_STATUS_T_READY,
        .threads = 2,
        .queue_depth = 3 + k,
        .queue_capacity = 1024,
        .served = {11, 22, 33, 44 + k},
        .malformed = 5,
        .num_status_codes = TRIOCT_WIRE_STATUS_COUNT,
        .replies_by_status = by_status,
        .latency_p50_us = 61,
        .latency_p99_us = 240,
        .latency_count = 900 + k,
        .num_worlds = 2,
        .worlds = worlds,
        .num_loads = 1,
        .loads = loads,
    };
    assert_int_equal(trioct_status_t_publish(lcm, "TRIOCT_STATUS", &s), 0);
}

/* memq drops a message nobody subscribes to when it is published, and the client listens to
 * the heartbeat only while it waits: so heartbeats are published from a handler that runs
 * during the wait, as a daemon's would arrive. */
typedef struct ticker {
    lcm_t *lcm;
    int malformed;          /* a bad heartbeat first */
    const char *daemons[3]; /* then one heartbeat from each (k = index * 8 + 1) */
    int count;
} ticker;

static void on_tick(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
    (void)rbuf;
    (void)channel;
    ticker *t = user;
    if (t->malformed)
        lcm_publish(t->lcm, "TRIOCT_STATUS", "xyzxyzxyzxyz", 12);
    for (int i = 0; i < t->count; i++)
        publish_status(t->lcm, t->daemons[i], 8 * i + 1);
}

static void test_next_status(void **state)
{
    env *e = *state;
    ticker t = {.lcm = e->lcm, .malformed = 1, .daemons = {"d9", "d1"}, .count = 2};
    lcm_subscription_t *tick = lcm_subscribe(e->lcm, "TEST_TICK", on_tick, &t);
    assert_non_null(tick);
    /* A malformed heartbeat, one from another daemon, then d1's. */
    assert_int_equal(lcm_publish(e->lcm, "TEST_TICK", "", 0), 0);
    trioct_daemon_status st;
    assert_int_equal(trioct_next_status(e->client, "d1", 2000, &st), TRIOCT_OK);
    assert_string_equal(st.reply.daemon, "d1");
    assert_string_equal(st.reply.message, "status of daemon d1");
    assert_int_equal(st.utime, 1763760000000009);
    assert_string_equal(st.version, "trioctd 0.5.0");
    assert_int_equal(st.uptime_us, 123456798);
    assert_int_equal(st.state, TRIOCT_DAEMON_READY);
    assert_int_equal(st.threads, 2);
    assert_int_equal(st.queue_depth, 12);
    assert_int_equal(st.queue_capacity, 1024);
    assert_int_equal(st.served[0], 11);
    assert_int_equal(st.served[1], 22);
    assert_int_equal(st.served[2], 33);
    assert_int_equal(st.served[3], 53);
    assert_int_equal(st.malformed, 5);
    assert_int_equal(st.num_status_codes, TRIOCT_WIRE_STATUS_COUNT);
    for (int i = 0; i < TRIOCT_WIRE_STATUS_COUNT; i++)
        assert_int_equal(st.replies_by_status[i], 10 * i + 9);
    assert_int_equal(st.latency_p50_us, 61);
    assert_int_equal(st.latency_p99_us, 240);
    assert_int_equal(st.latency_count, 909);
    assert_int_equal(st.num_worlds, 2);
    check_world(&st.worlds[0], "w1", "d1", "w1", 0);
    check_world(&st.worlds[1], "w2", "d1", "meshes/w2.ply", 3);
    assert_int_equal(st.num_loads, 1);
    assert_string_equal(st.loads[0].world, "big");
    assert_true(st.loads[0].client_id == 0x4c7fb7a37e1466d1);
    assert_int_equal(st.loads[0].request_id, 11);
    assert_string_equal(st.loads[0].phase, "building octrees");
    assert_int_equal(st.loads[0].files_done, 1);
    assert_int_equal(st.loads[0].files_total, 2);
    assert_int_equal(st.loads[0].triangles, 405000);
    assert_true(st.loads[0].elapsed_seconds == 0.375);
    trioct_daemon_status_free(&st);
    assert_null(st.worlds);
    assert_null(st.loads);
    assert_int_equal(stats_of(e->client).malformed, 1);

    /* Any daemon: the first heard. */
    t.malformed = 0;
    assert_int_equal(lcm_publish(e->lcm, "TEST_TICK", "", 0), 0);
    assert_int_equal(trioct_next_status(e->client, NULL, 2000, &st), TRIOCT_OK);
    assert_string_equal(st.reply.daemon, "d9");
    assert_int_equal(st.queue_depth, 4);
    trioct_daemon_status_free(&st);

    /* Between calls nobody listens: d1's heartbeat of that tick, still queued when the call
     * returned, and one published now are not kept for the next call. */
    assert_int_equal(trioct_pump(e->client), 1);
    publish_status(e->lcm, "d1", 2);
    assert_int_equal(trioct_pump(e->client), 0);
    double t0 = now_ms();
    assert_int_equal(trioct_next_status(e->client, NULL, 60, &st), TRIOCT_ERR_NO_DAEMON);
    double took = now_ms() - t0;
    assert_true(took >= 60.0 && took < 60.0 + LATE_MS);
    assert_string_equal(st.reply.message, "no status from any daemon on memq:// (none within 60 ms)");
    trioct_daemon_status_free(&st);
    t.count = 1; /* only d9 beats */
    assert_int_equal(lcm_publish(e->lcm, "TEST_TICK", "", 0), 0);
    assert_int_equal(trioct_next_status(e->client, "d7", 20, &st), TRIOCT_ERR_NO_DAEMON);
    assert_string_equal(st.reply.message, "no status from daemon d7 on memq:// (none within 20 ms)");
    trioct_daemon_status_free(&st);
    lcm_unsubscribe(e->lcm, tick);
}

/* ---------- refusals before sending ---------- */

static void test_over_cap_and_bad_requests_refused_before_sending(void **state)
{
    env *e = *state;
    static trioct_vec3 o[TRIOCT_MAX_RAYS + 1], d[TRIOCT_MAX_RAYS + 1];
    make_rays(TRIOCT_MAX_RAYS + 1, o, d);
    trioct_ray_query q = trioct_ray_query_default("w1");
    q.count = TRIOCT_MAX_RAYS + 1;
    q.origins = o;
    q.directions = d;
    trioct_ray_result rr;
    assert_int_equal(trioct_rays(e->client, &q, 1000, &rr), TRIOCT_ERR_OVER_CAP);
    assert_string_equal(rr.reply.message,
                        "1281 rays is over the cap of 1280 rays per request (TRIOCT_MAX_RAYS)");
    assert_int_equal(rr.reply.request_id, 0);
    trioct_ray_result_free(&rr);
    q.count = 2;
    q.detail = TRIOCT_RAY_ALL;
    q.max_hits = TRIOCT_MAX_HITS_PER_RAY + 1;
    assert_int_equal(trioct_rays(e->client, &q, 1000, &rr), TRIOCT_ERR_OVER_CAP);
    assert_string_equal(rr.reply.message, "max_hits 1001 is over the cap of 1000 hits per ray "
                                          "(TRIOCT_MAX_HITS_PER_RAY)");
    q.max_hits = 0;
    assert_int_equal(trioct_rays(e->client, &q, 1000, &rr), TRIOCT_ERR_BAD_REQUEST);
    q.max_hits = 1;
    q.origins = NULL;
    assert_int_equal(trioct_rays(e->client, &q, 1000, &rr), TRIOCT_ERR_BAD_REQUEST);
    q.origins = o;
    q.world = "no-such/world";
    assert_int_equal(trioct_rays(e->client, &q, 1000, &rr), TRIOCT_ERR_BAD_REQUEST);
    assert_string_equal(rr.reply.message,
                        "invalid world name \"no-such/world\": 1..32 characters of [A-Za-z0-9_]");
    q.world = "w1";
    q.detail = 7;
    assert_int_equal(trioct_rays(e->client, &q, 1000, &rr), TRIOCT_ERR_BAD_REQUEST);
    assert_int_equal(trioct_rays(e->client, NULL, 1000, &rr), TRIOCT_ERR_BAD_REQUEST);

    static trioct_triangle t[TRIOCT_MAX_TRIANGLES + 1];
    trioct_triangle_query tq = {.world = "w1", .count = TRIOCT_MAX_TRIANGLES + 1, .triangles = t};
    trioct_triangle_result tr;
    assert_int_equal(trioct_triangles(e->client, &tq, 1000, &tr), TRIOCT_ERR_OVER_CAP);
    assert_string_equal(tr.reply.message, "801 triangles is over the cap of 800 triangles per "
                                          "request (TRIOCT_MAX_TRIANGLES)");

    static trioct_pose poses[TRIOCT_MAX_POSES + 1];
    static trioct_triangle shape[TRIOCT_MAX_INLINE_SHAPE_TRIANGLES + 1];
    trioct_mesh_query mq = {.world = "w1", .shape = "gripper", .num_poses = TRIOCT_MAX_POSES + 1,
                            .poses = poses};
    trioct_mesh_result mr;
    assert_int_equal(trioct_mesh(e->client, &mq, 1000, &mr), TRIOCT_ERR_OVER_CAP);
    assert_string_equal(mr.reply.message,
                        "513 poses is over the cap of 512 poses per request (TRIOCT_MAX_POSES)");
    mq = (trioct_mesh_query){.world = "w1", .num_shape_triangles = 513,
                             .shape_triangles = shape, .num_poses = 1, .poses = poses};
    assert_int_equal(trioct_mesh(e->client, &mq, 1000, &mr), TRIOCT_ERR_OVER_CAP);
    assert_string_equal(mr.reply.message, "513 inline shape triangles is over the cap of 512 "
                                          "(TRIOCT_MAX_INLINE_SHAPE_TRIANGLES)");
    /* Every count within its cap, the whole over one datagram's request bytes. */
    mq = (trioct_mesh_query){.world = "w1", .num_shape_triangles = 512, .shape_triangles = shape,
                             .num_poses = 512, .poses = poses};
    assert_int_equal(trioct_mesh(e->client, &mq, 1000, &mr), TRIOCT_ERR_OVER_CAP);
    assert_non_null(strstr(mr.reply.message, "over the cap of 65000 bytes per request "
                                             "(TRIOCT_MAX_REQUEST_BYTES)"));
    assert_int_equal(mr.reply.request_id, 0);
    mq = (trioct_mesh_query){.world = "w1", .shape = "gripper", .num_shape_triangles = 1,
                             .shape_triangles = shape, .num_poses = 1, .poses = poses};
    assert_int_equal(trioct_mesh(e->client, &mq, 1000, &mr), TRIOCT_ERR_BAD_REQUEST);
    assert_string_equal(mr.reply.message, "both a shape name (gripper) and 1 inline triangles: give one");

    trioct_admin_result ar;
    static char long_path[TRIOCT_MAX_PATH_LEN + 2];
    memset(long_path, 'a', TRIOCT_MAX_PATH_LEN + 1);
    trioct_load_options lo = {.world = "w1", .mesh_path = long_path};
    assert_int_equal(trioct_load(e->client, &lo, 1000, &ar), TRIOCT_ERR_OVER_CAP);
    assert_string_equal(ar.reply.message,
                        "a mesh path of 1025 characters is over the cap of 1024 (TRIOCT_MAX_PATH_LEN)");
    lo = (trioct_load_options){.world = "", .daemon = "d1"};
    assert_int_equal(trioct_load(e->client, &lo, 1000, &ar), TRIOCT_ERR_BAD_REQUEST);
    lo = (trioct_load_options){.world = "w1", .daemon = "d 1"};
    assert_int_equal(trioct_load(e->client, &lo, 1000, &ar), TRIOCT_ERR_BAD_REQUEST);
    assert_string_equal(ar.reply.message,
                        "invalid daemon name \"d 1\": 1..32 characters of [A-Za-z0-9_]");
    assert_int_equal(trioct_info(e->client, NULL, 1000, &ar), TRIOCT_ERR_BAD_REQUEST);
    trioct_daemon_status st;
    assert_int_equal(trioct_next_status(e->client, "bad name", 1000, &st), TRIOCT_ERR_BAD_REQUEST);

    /* Nothing was sent, nothing was waited for. */
    assert_int_equal(e->d1.requests, 0);
    assert_int_equal(stats_of(e->client).requests_sent, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_connect_ids_channels_and_refusals, setup, teardown),
        cmocka_unit_test_setup_teardown(test_rays_closest_exact, setup, teardown),
        cmocka_unit_test_setup_teardown(test_rays_contact_travels, setup, teardown),
        cmocka_unit_test_setup_teardown(test_rays_all_many_chunks_out_of_order_with_duplicates,
                                        setup, teardown),
        cmocka_unit_test_setup_teardown(test_foreign_replies_ignored, setup, teardown),
        cmocka_unit_test_setup_teardown(test_malformed_reply_ignored_then_good_one_accepted, setup,
                                        teardown),
        cmocka_unit_test_setup_teardown(test_error_status_passed_through, setup, teardown),
        cmocka_unit_test_setup_teardown(test_timeout_without_reply_is_no_daemon, setup, teardown),
        cmocka_unit_test_setup_teardown(test_timeout_with_partial_chunks, setup, teardown),
        cmocka_unit_test_setup_teardown(test_inconsistent_chunk_count_is_bad_reply, setup, teardown),
        cmocka_unit_test_setup_teardown(test_triangles_ids_and_segments_chunked, setup, teardown),
        cmocka_unit_test_setup_teardown(test_mesh_named_shape_pairs_and_inline_yesno, setup,
                                        teardown),
        cmocka_unit_test_setup_teardown(test_load_info_unload, setup, teardown),
        cmocka_unit_test_setup_teardown(test_list_gathers_two_daemons, setup, teardown),
        cmocka_unit_test_setup_teardown(test_second_answer_to_one_request_ignored, setup, teardown),
        cmocka_unit_test_setup_teardown(test_next_status, setup, teardown),
        cmocka_unit_test_setup_teardown(test_over_cap_and_bad_requests_refused_before_sending,
                                        setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
