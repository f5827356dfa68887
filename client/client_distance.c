/* Distances: the request on <prefix>_DISTANCE_<world> for points (POINTS) or a shape at
 * poses (SHAPE, CLEAR), the answer's chunks joined into one result per item,
 * synchronously or through a callback. One start function serves the three kinds, since
 * they share the message and its answer. */
#include "client_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "trioct_distance_reply_t.h"
#include "trioct_distance_request_t.h"

_Static_assert(TRIOCT_FEATURE_FACE == TRIOCT_DISTANCE_RESULT_T_FACE &&
                   TRIOCT_FEATURE_EDGE == TRIOCT_DISTANCE_RESULT_T_EDGE &&
                   TRIOCT_FEATURE_VERTEX == TRIOCT_DISTANCE_RESULT_T_VERTEX,
               "trioct.h's features are the wire's");

static int reply_decode(const void *buf, size_t size, void *msg)
{
    return trioct_distance_reply_t_decode(buf, 0, (int)size, msg) < 0 ? -1 : 0;
}

static void reply_cleanup(void *msg)
{
    trioct_distance_reply_t_decode_cleanup(msg);
}

static const reply_ops distance_reply_ops = {
    .wire = WIRE_DISTANCE_REPLY,
    .msg_size = sizeof(trioct_distance_reply_t),
    .decode = reply_decode,
    .cleanup = reply_cleanup,
};

static int request_size(const void *msg)
{
    return trioct_distance_request_t_encoded_size(msg);
}

static int request_encode(void *buf, int size, const void *msg)
{
    return trioct_distance_request_t_encode(buf, 0, size, msg);
}

static const request_codec distance_codec = {request_size, request_encode, NULL};

static trioct_vec3_t wire_vec(trioct_vec3 v)
{
    return (trioct_vec3_t){v.x, v.y, v.z};
}

static trioct_vec3 vec_of(trioct_vec3_t v)
{
    return (trioct_vec3){v.x, v.y, v.z};
}

trioct_point_distance_query trioct_point_distance_query_default(const char *world)
{
    return (trioct_point_distance_query){.world = world, .within = -1.0, .count = 0, .points = NULL};
}

/* What one request asks, whatever its kind: points, or a shape at poses. */
typedef struct distance_ask {
    const char *world;
    int8_t kind;
    double within;
    size_t num_points;
    const trioct_vec3 *points;
    const char *shape;
    size_t num_shape_triangles;
    const trioct_triangle *shape_triangles;
    size_t num_poses;
    const trioct_pose *poses;
} distance_ask;

static int check_ask(const distance_ask *a, trioct_reply *r)
{
    if (isnan(a->within))
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "within is NaN: give a distance, or < 0 for no limit");
    if (a->kind == TRIOCT_DISTANCE_REQUEST_T_POINTS) {
        if (a->num_points > TRIOCT_MAX_POINTS)
            return client_fail(r, TRIOCT_ERR_OVER_CAP,
                               "%zu points is over the cap of %d points per request (TRIOCT_MAX_POINTS)",
                               a->num_points, TRIOCT_MAX_POINTS);
        if (a->num_points > 0 && a->points == NULL)
            return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "%zu points without their array", a->num_points);
        return TRIOCT_OK;
    }
    if (a->kind == TRIOCT_DISTANCE_REQUEST_T_CLEAR && !(a->within >= 0))
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "a clearance radius must be >= 0, not %g", a->within);
    if (a->num_poses > TRIOCT_MAX_POSES)
        return client_fail(r, TRIOCT_ERR_OVER_CAP, "%zu poses is over the cap of %d poses per request (TRIOCT_MAX_POSES)",
                           a->num_poses, TRIOCT_MAX_POSES);
    if (a->num_shape_triangles > TRIOCT_MAX_INLINE_SHAPE_TRIANGLES)
        return client_fail(r, TRIOCT_ERR_OVER_CAP,
                           "%zu inline shape triangles is over the cap of %d (TRIOCT_MAX_INLINE_SHAPE_TRIANGLES)",
                           a->num_shape_triangles, TRIOCT_MAX_INLINE_SHAPE_TRIANGLES);
    if (a->num_poses > 0 && a->poses == NULL)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "%zu poses without their array", a->num_poses);
    if (a->num_shape_triangles > 0 && a->shape_triangles == NULL)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "%zu shape triangles without their array",
                           a->num_shape_triangles);
    int named = a->shape != NULL && a->shape[0] != '\0';
    if (named && !trioct_name_valid(a->shape, TRIOCT_MAX_NAME_LEN))
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "invalid shape name \"%.40s\": 1..%d characters of [A-Za-z0-9_]",
                           a->shape, TRIOCT_MAX_NAME_LEN);
    if (named && a->num_shape_triangles > 0)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "both a shape name (%s) and %zu inline triangles: give one",
                           a->shape, a->num_shape_triangles);
    return TRIOCT_OK;
}

/* One result per item, in item order: anything else is a reply this library cannot trust. */
static int build_result(const assembly *a, size_t n, trioct_distance_result *out)
{
    const trioct_distance_reply_t *first = a->chunks[0];
    trioct_reply *r = &out->reply;
    size_t total = 0;
    for (int32_t i = 0; i < a->chunk_count; i++)
        total += (size_t)((const trioct_distance_reply_t *)a->chunks[i])->num_results;
    if (total != n)
        return client_fail(r, TRIOCT_ERR_BAD_REPLY, "the reply has %zu results for %zu items", total, n);
    out->results = calloc(n ? n : 1, sizeof *out->results);
    if (out->results == NULL)
        return client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for %zu distance results", n);
    if (client_object_names(r, first->num_objects, first->objects, &out->objects) != TRIOCT_OK)
        return r->status;
    size_t k = 0;
    for (int32_t i = 0; i < a->chunk_count; i++) {
        const trioct_distance_reply_t *chunk = a->chunks[i];
        for (int32_t j = 0; j < chunk->num_results; j++, k++) {
            const trioct_distance_result_t *d = &chunk->results[j];
            if (d->item < 0 || (size_t)d->item != k)
                return client_fail(r, TRIOCT_ERR_BAD_REPLY, "result %zu names item %d", k, d->item);
            /* A found distance names its object, and so does a clearance that is not clear
             * (the object it could not be proven clear of). */
            int named = d->found || (d->object >= 0 && !d->clear);
            if (named && client_check_object(r, d->object, &out->objects, "result", k) != TRIOCT_OK)
                return r->status;
            out->results[k] = (trioct_distance){
                .item = d->item,
                .found = d->found != 0,
                .clear = d->clear != 0,
                .distance = d->distance,
                .bound = d->bound,
                .lower = d->lower,
                .upper = d->upper,
                .point = vec_of(d->point),
                .shape_point = vec_of(d->shape_point),
                .object = named ? d->object : -1,
                .triangle = d->triangle,
                .shape_triangle = d->shape_triangle,
                .feature = d->feature,
                .feature_index = d->feature_index,
                .inside = d->inside != 0,
            };
        }
    }
    out->num_results = n;
    return TRIOCT_OK;
}

static void complete_distance(trioct_client *c, pending *p)
{
    trioct_distance_result res;
    memset(&res, 0, sizeof res);
    const assembly *answer = client_answer(c, p, &res.reply);
    if (answer != NULL && res.reply.status == TRIOCT_OK)
        build_result(answer, p->count, &res);
    if (res.reply.status != TRIOCT_OK)
        trioct_distance_result_free(&res); /* a failed request leaves no half result */
    ((trioct_distance_done)p->cb)(c, &res, p->user);
    trioct_distance_result_free(&res);
}

/* Checks, encodes and sends a; *out is then the request waiting for its answer. */
static int start_distance(trioct_client *c, const distance_ask *a, int timeout_ms, trioct_reply *r, pending **out)
{
    *out = NULL;
    char channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    if (check_ask(a, r) != TRIOCT_OK ||
        client_channel(c, TRIOCT_CHANNEL_DISTANCE, a->world, channel, r, "world") != TRIOCT_OK)
        return r->status;
    size_t npt = a->num_points, nt = a->num_shape_triangles, np = a->num_poses;
    trioct_distance_request_t msg = {
        .kind = a->kind,
        .within = a->within,
        .num_points = (int32_t)npt,
        .points = calloc(npt ? npt : 1, sizeof(trioct_vec3_t)),
        .shape = (char *)(a->shape ? a->shape : ""), /* the encoder only reads it */
        .num_shape_triangles = (int32_t)nt,
        .shape_triangles = calloc(nt ? nt : 1, sizeof(trioct_triangle_t)),
        .num_poses = (int32_t)np,
        .poses = calloc(np ? np : 1, sizeof(trioct_pose_t)),
        .rotation = TRIOCT_DISTANCE_REQUEST_T_MATRIX,
        .num_quaternions = 0,
        .quaternions = NULL,
    };
    pending *p = NULL;
    int rc;
    if (msg.points == NULL || msg.shape_triangles == NULL || msg.poses == NULL) {
        rc = client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for %zu points and %zu poses", npt, np);
    } else if ((p = client_pending_new(c, &distance_reply_ops, timeout_ms, r)) == NULL) {
        rc = r->status;
    } else {
        for (size_t i = 0; i < npt; i++)
            msg.points[i] = wire_vec(a->points[i]);
        for (size_t i = 0; i < nt; i++)
            msg.shape_triangles[i] = (trioct_triangle_t){wire_vec(a->shape_triangles[i].a),
                                                         wire_vec(a->shape_triangles[i].b),
                                                         wire_vec(a->shape_triangles[i].c)};
        for (size_t i = 0; i < np; i++) {
            memcpy(msg.poses[i].r, a->poses[i].r, sizeof msg.poses[i].r);
            msg.poses[i].t = wire_vec(a->poses[i].t);
        }
        p->count = a->kind == TRIOCT_DISTANCE_REQUEST_T_POINTS ? npt : np;
        p->complete = complete_distance;
        client_no_daemon_world(c, a->world, timeout_ms, p->no_daemon, sizeof p->no_daemon);
        client_request_header(c, &msg.header, p, a->world);
        rc = client_pending_send(c, p, channel, &distance_codec, &msg, r);
    }
    free(msg.points);
    free(msg.shape_triangles);
    free(msg.poses);
    *out = rc == TRIOCT_OK ? p : NULL;
    return rc;
}

static distance_ask ask_points(const trioct_point_distance_query *q)
{
    return (distance_ask){.world = q->world, .kind = TRIOCT_DISTANCE_REQUEST_T_POINTS, .within = q->within,
                          .num_points = q->count, .points = q->points};
}

static distance_ask ask_shape(const trioct_shape_distance_query *q, int8_t kind)
{
    return (distance_ask){.world = q->world,
                          .kind = kind,
                          .within = q->within,
                          .shape = q->shape,
                          .num_shape_triangles = q->num_shape_triangles,
                          .shape_triangles = q->shape_triangles,
                          .num_poses = q->num_poses,
                          .poses = q->poses};
}

/* A sync call's callback: the result moves to the caller's struct. */
static void keep_distance(trioct_client *c, trioct_distance_result *res, void *user)
{
    (void)c;
    *(trioct_distance_result *)user = *res;
    memset(res, 0, sizeof *res);
}

static int distance_sync(trioct_client *c, const distance_ask *a, int timeout_ms, trioct_distance_result *out)
{
    pending *p;
    int rc = start_distance(c, a, timeout_ms, &out->reply, &p);
    if (rc != TRIOCT_OK)
        return rc;
    client_sync_finish(c, p, (void (*)(void))keep_distance, out);
    return out->reply.status;
}

static int distance_async(trioct_client *c, const distance_ask *a, int timeout_ms, trioct_distance_done cb,
                          void *user, int64_t *request_id)
{
    trioct_reply r;
    memset(&r, 0, sizeof r);
    pending *p = NULL;
    int rc = client_async_check(c, cb != NULL, &r);
    if (rc == TRIOCT_OK)
        rc = start_distance(c, a, timeout_ms, &r, &p);
    return client_async_started(c, rc, &r, p, (void (*)(void))cb, user, request_id);
}

int trioct_point_distance(trioct_client *c, const trioct_point_distance_query *q, int timeout_ms,
                          trioct_distance_result *out)
{
    memset(out, 0, sizeof *out);
    if (q == NULL)
        return client_fail(&out->reply, TRIOCT_ERR_BAD_REQUEST, "no distance query given");
    distance_ask a = ask_points(q);
    return distance_sync(c, &a, timeout_ms, out);
}

int trioct_shape_distance(trioct_client *c, const trioct_shape_distance_query *q, int timeout_ms,
                          trioct_distance_result *out)
{
    memset(out, 0, sizeof *out);
    if (q == NULL)
        return client_fail(&out->reply, TRIOCT_ERR_BAD_REQUEST, "no shape distance query given");
    distance_ask a = ask_shape(q, TRIOCT_DISTANCE_REQUEST_T_SHAPE);
    return distance_sync(c, &a, timeout_ms, out);
}

int trioct_clearance(trioct_client *c, const trioct_shape_distance_query *q, int timeout_ms,
                     trioct_distance_result *out)
{
    memset(out, 0, sizeof *out);
    if (q == NULL)
        return client_fail(&out->reply, TRIOCT_ERR_BAD_REQUEST, "no clearance query given");
    distance_ask a = ask_shape(q, TRIOCT_DISTANCE_REQUEST_T_CLEAR);
    return distance_sync(c, &a, timeout_ms, out);
}

/* A NULL query is refused as an async call's other refusals are: through last_error. */
static int refuse_null(trioct_client *c, const char *what)
{
    trioct_reply r;
    memset(&r, 0, sizeof r);
    client_fail(&r, TRIOCT_ERR_BAD_REQUEST, "no %s query given", what);
    return client_async_started(c, r.status, &r, NULL, NULL, NULL, NULL);
}

int trioct_point_distance_async(trioct_client *c, const trioct_point_distance_query *q, int timeout_ms,
                                trioct_distance_done cb, void *user, int64_t *request_id)
{
    if (q == NULL)
        return refuse_null(c, "distance");
    distance_ask a = ask_points(q);
    return distance_async(c, &a, timeout_ms, cb, user, request_id);
}

int trioct_shape_distance_async(trioct_client *c, const trioct_shape_distance_query *q, int timeout_ms,
                                trioct_distance_done cb, void *user, int64_t *request_id)
{
    if (q == NULL)
        return refuse_null(c, "shape distance");
    distance_ask a = ask_shape(q, TRIOCT_DISTANCE_REQUEST_T_SHAPE);
    return distance_async(c, &a, timeout_ms, cb, user, request_id);
}

int trioct_clearance_async(trioct_client *c, const trioct_shape_distance_query *q, int timeout_ms,
                           trioct_distance_done cb, void *user, int64_t *request_id)
{
    if (q == NULL)
        return refuse_null(c, "clearance");
    distance_ask a = ask_shape(q, TRIOCT_DISTANCE_REQUEST_T_CLEAR);
    return distance_async(c, &a, timeout_ms, cb, user, request_id);
}

/* Keeps .reply: the status and message stay readable after the arrays are gone. */
void trioct_distance_result_free(trioct_distance_result *res)
{
    if (res == NULL)
        return;
    free(res->results);
    client_object_names_free(&res->objects);
    res->results = NULL;
    res->num_results = 0;
}
