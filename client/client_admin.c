/* World administration: LOAD on <prefix>_LOAD_<daemon>, INFO and UNLOAD on
 * <prefix>_ADMIN_<world>, and LIST on <prefix>_LIST, which every daemon answers, so the
 * client gathers answers rather than taking the first; each synchronously or through a
 * callback. */
#include "client_internal.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "trioct_admin_reply_t.h"
#include "trioct_admin_request_t.h"
#include "trioct_world_info_t.h"

_Static_assert(TRIOCT_EFFECT_RAYS == TRIOCT_WORLD_INFO_T_EFFECT_RAYS &&
                   TRIOCT_EFFECT_TRIANGLES == TRIOCT_WORLD_INFO_T_EFFECT_TRIANGLES &&
                   TRIOCT_EFFECT_MESHES == TRIOCT_WORLD_INFO_T_EFFECT_MESHES &&
                   TRIOCT_EFFECT_DISTANCE == TRIOCT_WORLD_INFO_T_EFFECT_DISTANCE,
               "trioct.h's effect bits are the wire's");

static int reply_decode(const void *buf, size_t size, void *msg)
{
    return trioct_admin_reply_t_decode(buf, 0, (int)size, msg) < 0 ? -1 : 0;
}

static void reply_cleanup(void *msg)
{
    trioct_admin_reply_t_decode_cleanup(msg);
}

const reply_ops client_admin_reply_ops = {
    .wire = WIRE_ADMIN_REPLY,
    .msg_size = sizeof(trioct_admin_reply_t),
    .decode = reply_decode,
    .cleanup = reply_cleanup,
};

static int request_size(const void *msg)
{
    return trioct_admin_request_t_encoded_size(msg);
}

static int request_encode(void *buf, int size, const void *msg)
{
    return trioct_admin_request_t_encode(buf, 0, size, msg);
}

static int request_is_change(const void *msg)
{
    int8_t op = ((const trioct_admin_request_t *)msg)->op;
    return op == TRIOCT_ADMIN_REQUEST_T_LOAD || op == TRIOCT_ADMIN_REQUEST_T_UNLOAD;
}

static const request_codec admin_codec = {request_size, request_encode, request_is_change};

static trioct_vec3 api_vec(trioct_vec3_t v)
{
    return (trioct_vec3){v.x, v.y, v.z};
}

int client_world_info(trioct_world_info *out, const trioct_world_info_t *in, const char *daemon,
                      trioct_reply *r)
{
    memset(out, 0, sizeof *out);
    if (in->num_shapes < 0 || in->num_shapes > TRIOCT_MAX_SHAPES)
        return client_fail(r, TRIOCT_ERR_BAD_REPLY,
                           "world %.40s lists %d shapes, over the cap of %d (TRIOCT_MAX_SHAPES)",
                           in->name, in->num_shapes, TRIOCT_MAX_SHAPES);
    client_copy(out->name, sizeof out->name, in->name);
    /* The answering daemon tags the world when the world does not name its holder. */
    client_copy(out->daemon, sizeof out->daemon, in->daemon[0] ? in->daemon : daemon);
    out->version = in->version;
    client_copy(out->source, sizeof out->source, in->source);
    client_copy(out->accuracy, sizeof out->accuracy, in->accuracy);
    out->seed_epsilon = in->seed_epsilon;
    out->effects = in->effects;
    out->triangles = in->triangles;
    out->vertices = in->vertices;
    out->degenerate = in->degenerate;
    out->duplicates = in->duplicates;
    out->bbox_min = api_vec(in->bbox_min);
    out->bbox_max = api_vec(in->bbox_max);
    out->nodes = in->nodes;
    out->leaves = in->leaves;
    out->max_level = in->max_level;
    out->resolution = in->resolution;
    out->world_size = in->world_size;
    out->world_min = api_vec(in->world_min);
    out->bytes_nodes = in->bytes_nodes;
    out->bytes_leaf_lists = in->bytes_leaf_lists;
    out->bytes_triangles = in->bytes_triangles;
    out->bytes_effects = in->bytes_effects;
    out->bytes_total = in->bytes_total;
    out->memory_bytes = in->memory_bytes;
    out->memory_budget = in->memory_budget;
    out->build_seconds = in->build_seconds;
    out->load_seconds = in->load_seconds;
    out->objects = in->objects;
    out->queries = in->queries;
    client_copy(out->last_error, sizeof out->last_error, in->last_error);
    out->num_shapes = in->num_shapes;
    for (int i = 0; i < in->num_shapes; i++)
        client_copy(out->shapes[i], sizeof out->shapes[i], in->shapes[i]);
    return TRIOCT_OK;
}

static size_t answer_worlds(const assembly *a)
{
    size_t n = 0;
    for (int32_t i = 0; i < a->chunk_count; i++)
        n += (size_t)((const trioct_admin_reply_t *)a->chunks[i])->num_worlds;
    return n;
}

/* Appends an answer's worlds, chunk by chunk, to worlds[*count]. */
static int append_worlds(const assembly *a, trioct_world_info *worlds, size_t *count,
                         trioct_reply *r)
{
    for (int32_t i = 0; i < a->chunk_count; i++) {
        const trioct_admin_reply_t *chunk = a->chunks[i];
        for (int32_t j = 0; j < chunk->num_worlds; j++)
            if (client_world_info(&worlds[(*count)++], &chunk->worlds[j], a->daemon, r) != TRIOCT_OK)
                return r->status;
    }
    return TRIOCT_OK;
}

/* Builds the result, hands it to the callback and frees what the callback left. */
static void complete_admin(trioct_client *c, pending *p)
{
    trioct_admin_result res;
    memset(&res, 0, sizeof res);
    trioct_reply *r = &res.reply;
    const assembly *answer = client_answer(c, p, r);
    if (answer != NULL && r->status == TRIOCT_OK) {
        size_t n = answer_worlds(answer);
        res.worlds = calloc(n ? n : 1, sizeof *res.worlds);
        if (res.worlds == NULL)
            client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for %zu worlds", n);
        else
            append_worlds(answer, res.worlds, &res.num_worlds, r);
    }
    if (r->status != TRIOCT_OK)
        trioct_admin_result_free(&res); /* a failed request leaves no half result */
    ((trioct_admin_done)p->cb)(c, &res, p->user);
    trioct_admin_result_free(&res);
}

/* One admin request with one answer (LOAD, INFO, UNLOAD), sent; *out is then the request
 * waiting for its answer. */
static int start_admin(trioct_client *c, int8_t op, trioct_channel_kind kind, const char *target,
                       const char *target_what, const trioct_load_options *load,
                       const char *world, int timeout_ms, trioct_reply *r, pending **out)
{
    *out = NULL;
    char channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    if (client_channel(c, kind, target, channel, r, target_what) != TRIOCT_OK)
        return r->status;
    trioct_admin_request_t msg = {
        .op = op,
        .mesh_path = "",
        .resolution = 0.0,
        .accuracy = TRIOCT_ACCURACY_WORLD,
    };
    if (load != NULL) {
        msg.mesh_path = (char *)(load->mesh_path ? load->mesh_path : ""); /* only read */
        msg.resolution = load->resolution;
        msg.accuracy = (int8_t)load->accuracy;
        msg.seed_epsilon = load->seed_epsilon;
        msg.effects = load->effects;
    }
    pending *p = client_pending_new(c, &client_admin_reply_ops, timeout_ms, r);
    if (p == NULL)
        return r->status;
    p->complete = complete_admin;
    if (op == TRIOCT_ADMIN_REQUEST_T_LOAD)
        snprintf(p->no_daemon, sizeof p->no_daemon,
                 "no daemon named %s on %s (no reply within %d ms)", target, c->url, timeout_ms);
    else
        client_no_daemon_world(c, world, timeout_ms, p->no_daemon, sizeof p->no_daemon);
    client_request_header(c, &msg.header, p, world);
    int rc = client_pending_send(c, p, channel, &admin_codec, &msg, r);
    if (rc == TRIOCT_OK)
        *out = p;
    return rc;
}

static int start_load(trioct_client *c, const trioct_load_options *opt, int timeout_ms,
                      trioct_reply *r, pending **out)
{
    *out = NULL;
    if (opt == NULL)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "no load options given");
    if (!trioct_name_valid(opt->world, TRIOCT_MAX_NAME_LEN))
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST,
                           "invalid world name \"%.40s\": 1..%d characters of [A-Za-z0-9_]",
                           opt->world ? opt->world : "(null)", TRIOCT_MAX_NAME_LEN);
    if (opt->accuracy < TRIOCT_ACCURACY_WORLD || opt->accuracy > TRIOCT_ACCURACY_FAST)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "unknown accuracy %d", opt->accuracy);
    if (opt->mesh_path != NULL && strlen(opt->mesh_path) > TRIOCT_MAX_PATH_LEN)
        return client_fail(r, TRIOCT_ERR_OVER_CAP,
                           "a mesh path of %zu characters is over the cap of %d "
                           "(TRIOCT_MAX_PATH_LEN)",
                           strlen(opt->mesh_path), TRIOCT_MAX_PATH_LEN);
    const char *daemon = opt->daemon ? opt->daemon : TRIOCT_DEFAULT_DAEMON;
    return start_admin(c, TRIOCT_ADMIN_REQUEST_T_LOAD, TRIOCT_CHANNEL_LOAD, daemon, "daemon", opt,
                       opt->world, timeout_ms, r, out);
}

static int start_unload(trioct_client *c, const char *world, int timeout_ms, trioct_reply *r,
                        pending **out)
{
    return start_admin(c, TRIOCT_ADMIN_REQUEST_T_UNLOAD, TRIOCT_CHANNEL_ADMIN, world, "world",
                       NULL, world, timeout_ms, r, out);
}

static int start_info(trioct_client *c, const char *world, int timeout_ms, trioct_reply *r,
                      pending **out)
{
    return start_admin(c, TRIOCT_ADMIN_REQUEST_T_INFO, TRIOCT_CHANNEL_ADMIN, world, "world", NULL,
                       world, timeout_ms, r, out);
}

/* A sync call's callback: the result moves to the caller's struct. */
static void keep_admin(trioct_client *c, trioct_admin_result *res, void *user)
{
    (void)c;
    *(trioct_admin_result *)user = *res;
    memset(res, 0, sizeof *res);
}

/* The sync calls: start, then wait for the answer in place. */
static int admin_sync(trioct_client *c, int rc, pending *p, trioct_admin_result *out)
{
    if (rc != TRIOCT_OK)
        return rc;
    client_sync_finish(c, p, (void (*)(void))keep_admin, out);
    return out->reply.status;
}

int trioct_load(trioct_client *c, const trioct_load_options *opt, int timeout_ms,
                trioct_admin_result *out)
{
    memset(out, 0, sizeof *out);
    pending *p;
    int rc = start_load(c, opt, timeout_ms, &out->reply, &p);
    return admin_sync(c, rc, p, out);
}

int trioct_unload(trioct_client *c, const char *world, int timeout_ms, trioct_admin_result *out)
{
    memset(out, 0, sizeof *out);
    pending *p;
    int rc = start_unload(c, world, timeout_ms, &out->reply, &p);
    return admin_sync(c, rc, p, out);
}

int trioct_info(trioct_client *c, const char *world, int timeout_ms, trioct_admin_result *out)
{
    memset(out, 0, sizeof *out);
    pending *p;
    int rc = start_info(c, world, timeout_ms, &out->reply, &p);
    return admin_sync(c, rc, p, out);
}

int trioct_load_async(trioct_client *c, const trioct_load_options *opt, int timeout_ms,
                      trioct_admin_done cb, void *user, int64_t *request_id)
{
    trioct_reply r;
    memset(&r, 0, sizeof r);
    pending *p = NULL;
    int rc = client_async_check(c, cb != NULL, &r);
    if (rc == TRIOCT_OK)
        rc = start_load(c, opt, timeout_ms, &r, &p);
    return client_async_started(c, rc, &r, p, (void (*)(void))cb, user, request_id);
}

int trioct_unload_async(trioct_client *c, const char *world, int timeout_ms,
                        trioct_admin_done cb, void *user, int64_t *request_id)
{
    trioct_reply r;
    memset(&r, 0, sizeof r);
    pending *p = NULL;
    int rc = client_async_check(c, cb != NULL, &r);
    if (rc == TRIOCT_OK)
        rc = start_unload(c, world, timeout_ms, &r, &p);
    return client_async_started(c, rc, &r, p, (void (*)(void))cb, user, request_id);
}

int trioct_info_async(trioct_client *c, const char *world, int timeout_ms, trioct_admin_done cb,
                      void *user, int64_t *request_id)
{
    trioct_reply r;
    memset(&r, 0, sizeof r);
    pending *p = NULL;
    int rc = client_async_check(c, cb != NULL, &r);
    if (rc == TRIOCT_OK)
        rc = start_info(c, world, timeout_ms, &r, &p);
    return client_async_started(c, rc, &r, p, (void (*)(void))cb, user, request_id);
}

void trioct_admin_result_free(trioct_admin_result *res)
{
    if (res == NULL)
        return;
    free(res->worlds);
    res->worlds = NULL;
    res->num_worlds = 0;
}

/* ---- LIST ---------------------------------------------------------------------------- */

static int by_finish_order(const void *x, const void *y)
{
    const assembly *a = *(const assembly *const *)x, *b = *(const assembly *const *)y;
    /* Finished answers in the order they finished, then the unfinished ones. */
    uint64_t oa = a->state == ASSEMBLY_OPEN ? UINT64_MAX : a->order;
    uint64_t ob = b->state == ASSEMBLY_OPEN ? UINT64_MAX : b->order;
    return oa < ob ? -1 : oa > ob;
}

/* Builds the union from what the gathering found. */
static int list_result(trioct_client *c, const pending *p, int timeout_ms, trioct_list_result *out)
{
    trioct_reply *r = &out->reply;
    size_t n = p->num_assemblies, worlds = 0;
    const assembly **order = calloc(n ? n : 1, sizeof *order);
    out->daemons = calloc(n ? n : 1, sizeof *out->daemons);
    for (size_t i = 0; i < n; i++)
        if (p->assemblies[i].state == ASSEMBLY_COMPLETE)
            worlds += answer_worlds(&p->assemblies[i]);
    out->worlds = calloc(worlds ? worlds : 1, sizeof *out->worlds);
    if (order == NULL || out->daemons == NULL || out->worlds == NULL) {
        free(order);
        return client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for %zu worlds", worlds);
    }
    for (size_t i = 0; i < n; i++)
        order[i] = &p->assemblies[i];
    qsort(order, n, sizeof *order, by_finish_order);

    int status = TRIOCT_OK;
    char why[TRIOCT_MAX_MESSAGE_LEN + 1] = "";
    for (size_t i = 0; i < n; i++) {
        const assembly *a = order[i];
        trioct_reply *d = &out->daemons[out->num_daemons++];
        d->request_id = p->request_id;
        client_copy(d->daemon, sizeof d->daemon, a->daemon);
        if (a->state == ASSEMBLY_COMPLETE) {
            client_reply_from_header(d, a->chunks[0], a->chunk_count);
            size_t before = out->num_worlds;
            if (append_worlds(a, out->worlds, &out->num_worlds, d) != TRIOCT_OK)
                out->num_worlds = before; /* this daemon's answer is bad; keep the others */
        } else if (a->state == ASSEMBLY_BAD) {
            client_fail(d, TRIOCT_ERR_BAD_REPLY, "bad reply: %s", a->why);
        } else {
            d->chunks = a->received;
            client_fail(d, TRIOCT_ERR_TIMEOUT,
                        "incomplete: %" PRId32 " of %" PRId32 " chunks within %d ms", a->received,
                        a->chunk_count, timeout_ms);
        }
        if (d->status == TRIOCT_ERR_BAD_REPLY || d->status == TRIOCT_ERR_TIMEOUT) {
            if (status == TRIOCT_OK) {
                status = d->status;
                snprintf(why, sizeof why, "daemon %.40s: %.400s", d->daemon, d->message);
            }
        }
    }
    free(order);
    r->request_id = p->request_id;
    if (n == 0 && p->malformed > 0)
        return client_fail(r, TRIOCT_ERR_BAD_REPLY,
                           "%" PRIu64 " malformed answers to LIST and no good one within %d ms",
                           p->malformed, timeout_ms);
    if (n == 0)
        return client_fail(r, TRIOCT_ERR_NO_DAEMON, "no daemon answered on %s (no reply within %d ms)",
                           c->url, timeout_ms);
    if (status != TRIOCT_OK)
        return client_fail(r, status, "%s", why);
    return client_fail(r, TRIOCT_OK, "%zu worlds from %zu daemons", out->num_worlds,
                       out->num_daemons);
}

/* Builds the union, hands it to the callback and frees what the callback left. */
static void complete_list(trioct_client *c, pending *p)
{
    trioct_list_result res;
    memset(&res, 0, sizeof res);
    trioct_reply *r = &res.reply;
    r->request_id = p->request_id;
    int rc;
    if (p->bus_failed)
        rc = client_fail(r, TRIOCT_ERR_TRANSPORT,
                         "the LCM bus %s failed while gathering LIST answers", c->url);
    else if (client_ended_early(c, p, r))
        rc = r->status;
    else
        rc = list_result(c, p, p->timeout_ms, &res);
    /* A partial or bad gathering keeps the whole answers: the status says what is missing. */
    if (rc != TRIOCT_OK && rc != TRIOCT_ERR_TIMEOUT && rc != TRIOCT_ERR_BAD_REPLY)
        trioct_list_result_free(&res);
    ((trioct_list_done)p->cb)(c, &res, p->user);
    trioct_list_result_free(&res);
}

static int start_list(trioct_client *c, const trioct_list_options *opt, int timeout_ms,
                      trioct_reply *r, pending **out)
{
    *out = NULL;
    trioct_list_options o = {0};
    if (opt != NULL)
        o = *opt;
    /* Every daemon answers, so nothing says when the last one has: something must end it. */
    if (timeout_ms < 0 && o.gather_ms <= 0 && o.expect_daemons <= 0)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST,
                           "a LIST without a timeout needs a gather window or an expected count");
    char channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    if (client_channel(c, TRIOCT_CHANNEL_LIST, NULL, channel, r, "list") != TRIOCT_OK)
        return r->status;
    int window = timeout_ms;
    if (o.gather_ms > 0 && (timeout_ms < 0 || o.gather_ms < timeout_ms))
        window = o.gather_ms;

    trioct_admin_request_t msg = {
        .op = TRIOCT_ADMIN_REQUEST_T_LIST,
        .mesh_path = "",
        .accuracy = TRIOCT_ACCURACY_WORLD,
    };
    pending *p = client_pending_new(c, &client_admin_reply_ops, window, r);
    if (p == NULL)
        return r->status;
    p->gather = 1;
    p->expect = o.expect_daemons > 0 ? o.expect_daemons : 0;
    p->complete = complete_list;
    client_request_header(c, &msg.header, p, "");
    int rc = client_pending_send(c, p, channel, &admin_codec, &msg, r);
    if (rc == TRIOCT_OK)
        *out = p;
    return rc;
}

/* A sync call's callback: the result moves to the caller's struct. */
static void keep_list(trioct_client *c, trioct_list_result *res, void *user)
{
    (void)c;
    *(trioct_list_result *)user = *res;
    memset(res, 0, sizeof *res);
}

int trioct_list(trioct_client *c, const trioct_list_options *opt, int timeout_ms,
                trioct_list_result *out)
{
    memset(out, 0, sizeof *out);
    pending *p;
    int rc = start_list(c, opt, timeout_ms, &out->reply, &p);
    if (rc != TRIOCT_OK)
        return rc;
    client_sync_finish(c, p, (void (*)(void))keep_list, out);
    return out->reply.status;
}

int trioct_list_async(trioct_client *c, const trioct_list_options *opt, int timeout_ms,
                      trioct_list_done cb, void *user, int64_t *request_id)
{
    trioct_reply r;
    memset(&r, 0, sizeof r);
    pending *p = NULL;
    int rc = client_async_check(c, cb != NULL, &r);
    if (rc == TRIOCT_OK)
        rc = start_list(c, opt, timeout_ms, &r, &p);
    return client_async_started(c, rc, &r, p, (void (*)(void))cb, user, request_id);
}

void trioct_list_result_free(trioct_list_result *res)
{
    if (res == NULL)
        return;
    free(res->daemons);
    free(res->worlds);
    res->daemons = NULL;
    res->worlds = NULL;
    res->num_daemons = 0;
    res->num_worlds = 0;
}
