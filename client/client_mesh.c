/* A query shape at a batch of poses: the request on <prefix>_MESH_<world>, the answer's
 * chunks joined into one list of touching pairs, synchronously or through a callback. */
#include "client_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "trioct_mesh_reply_t.h"
#include "trioct_mesh_request_t.h"

_Static_assert(TRIOCT_MESH_YESNO == TRIOCT_MESH_REQUEST_T_YESNO &&
                   TRIOCT_MESH_PAIRS == TRIOCT_MESH_REQUEST_T_PAIRS,
               "trioct.h's mesh details are the wire's");

static int reply_decode(const void *buf, size_t size, void *msg)
{
    return trioct_mesh_reply_t_decode(buf, 0, (int)size, msg) < 0 ? -1 : 0;
}

static void reply_cleanup(void *msg)
{
    trioct_mesh_reply_t_decode_cleanup(msg);
}

static const reply_ops mesh_reply_ops = {
    .wire = WIRE_MESH_REPLY,
    .msg_size = sizeof(trioct_mesh_reply_t),
    .decode = reply_decode,
    .cleanup = reply_cleanup,
};

static int request_size(const void *msg)
{
    return trioct_mesh_request_t_encoded_size(msg);
}

static int request_encode(void *buf, int size, const void *msg)
{
    return trioct_mesh_request_t_encode(buf, 0, size, msg);
}

static const request_codec mesh_codec = {request_size, request_encode, NULL};

static trioct_vec3_t wire_vec(trioct_vec3 v)
{
    return (trioct_vec3_t){v.x, v.y, v.z};
}

static int check_query(const trioct_mesh_query *q, trioct_reply *r)
{
    if (q == NULL)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "no mesh query given");
    if (q->detail < TRIOCT_MESH_YESNO || q->detail > TRIOCT_MESH_PAIRS)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST,
                           "unknown mesh detail %d (TRIOCT_MESH_YESNO or _PAIRS)", q->detail);
    if (q->accuracy < TRIOCT_ACCURACY_WORLD || q->accuracy > TRIOCT_ACCURACY_FAST)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "unknown accuracy %d", q->accuracy);
    if (q->num_poses > TRIOCT_MAX_POSES)
        return client_fail(r, TRIOCT_ERR_OVER_CAP,
                           "%zu poses is over the cap of %d poses per request (TRIOCT_MAX_POSES)",
                           q->num_poses, TRIOCT_MAX_POSES);
    if (q->num_shape_triangles > TRIOCT_MAX_INLINE_SHAPE_TRIANGLES)
        return client_fail(r, TRIOCT_ERR_OVER_CAP,
                           "%zu inline shape triangles is over the cap of %d "
                           "(TRIOCT_MAX_INLINE_SHAPE_TRIANGLES)",
                           q->num_shape_triangles, TRIOCT_MAX_INLINE_SHAPE_TRIANGLES);
    if (q->num_poses > 0 && q->poses == NULL)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "%zu poses without their array",
                           q->num_poses);
    if (q->num_shape_triangles > 0 && q->shape_triangles == NULL)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "%zu shape triangles without their array",
                           q->num_shape_triangles);
    int named = q->shape != NULL && q->shape[0] != '\0';
    if (named && !trioct_name_valid(q->shape, TRIOCT_MAX_NAME_LEN))
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST,
                           "invalid shape name \"%.40s\": 1..%d characters of [A-Za-z0-9_]",
                           q->shape, TRIOCT_MAX_NAME_LEN);
    /* The daemon would ignore the triangles of a named shape; say so rather than guess. */
    if (named && q->num_shape_triangles > 0)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST,
                           "both a shape name (%s) and %zu inline triangles: give one", q->shape,
                           q->num_shape_triangles);
    return TRIOCT_OK;
}

static int build_result(const assembly *a, size_t n, trioct_mesh_result *out)
{
    const trioct_mesh_reply_t *first = a->chunks[0];
    trioct_reply *r = &out->reply;
    out->detail = first->detail;
    if (first->num_poses < 0 || (size_t)first->num_poses != n)
        return client_fail(r, TRIOCT_ERR_BAD_REPLY, "the reply has %d found[] entries for %zu poses",
                           first->num_poses, n);
    size_t total = 0;
    for (int32_t i = 0; i < a->chunk_count; i++)
        total += (size_t)((const trioct_mesh_reply_t *)a->chunks[i])->num_pairs;
    out->found = calloc(n ? n : 1, sizeof *out->found);
    out->pairs = calloc(total ? total : 1, sizeof *out->pairs);
    if (out->found == NULL || out->pairs == NULL)
        return client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for %zu pairs", total);
    out->num_poses = n;
    if (n > 0)
        memcpy(out->found, first->found, n * sizeof *out->found);
    if (client_object_names(r, first->num_objects, first->objects, &out->objects) != TRIOCT_OK)
        return r->status;
    size_t k = 0;
    for (int32_t i = 0; i < a->chunk_count; i++) {
        const trioct_mesh_reply_t *chunk = a->chunks[i];
        for (int32_t j = 0; j < chunk->num_pairs; j++, k++) {
            const trioct_mesh_pair_t *pr = &chunk->pairs[j];
            if (pr->pose < 0 || (size_t)pr->pose >= n)
                return client_fail(r, TRIOCT_ERR_BAD_REPLY, "pair %zu names pose %d of %zu", k,
                                   pr->pose, n);
            if (client_check_object(r, pr->object, &out->objects, "pair", k) != TRIOCT_OK)
                return r->status;
            out->pairs[k] = (trioct_mesh_pair){pr->pose, pr->shape_triangle, pr->object, pr->world_triangle};
        }
    }
    out->num_pairs = total;
    return TRIOCT_OK;
}

/* Builds the result, hands it to the callback and frees what the callback left. */
static void complete_mesh(trioct_client *c, pending *p)
{
    trioct_mesh_result res;
    memset(&res, 0, sizeof res);
    const assembly *answer = client_answer(c, p, &res.reply);
    if (answer != NULL && res.reply.status == TRIOCT_OK)
        build_result(answer, p->count, &res);
    if (res.reply.status != TRIOCT_OK)
        trioct_mesh_result_free(&res); /* a failed request leaves no half result */
    ((trioct_mesh_done)p->cb)(c, &res, p->user);
    trioct_mesh_result_free(&res);
}

/* Checks, encodes and sends q; *out is then the request waiting for its answer. */
static int start_mesh(trioct_client *c, const trioct_mesh_query *q, int timeout_ms,
                      trioct_reply *r, pending **out)
{
    char channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    if (check_query(q, r) != TRIOCT_OK ||
        client_channel(c, TRIOCT_CHANNEL_MESH, q->world, channel, r, "world") != TRIOCT_OK)
        return r->status;

    size_t nt = q->num_shape_triangles, np = q->num_poses;
    trioct_mesh_request_t msg = {
        .detail = (int8_t)q->detail,
        .accuracy = (int8_t)q->accuracy,
        .shape = (char *)(q->shape ? q->shape : ""), /* the encoder only reads it */
        .num_shape_triangles = (int32_t)nt,
        .shape_triangles = calloc(nt ? nt : 1, sizeof(trioct_triangle_t)),
        .num_poses = (int32_t)np,
        .poses = calloc(np ? np : 1, sizeof(trioct_pose_t)),
    };
    pending *p = NULL;
    int rc;
    if (msg.shape_triangles == NULL || msg.poses == NULL) {
        rc = client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for %zu poses", np);
    } else if ((p = client_pending_new(c, &mesh_reply_ops, timeout_ms, r)) == NULL) {
        rc = r->status;
    } else {
        for (size_t i = 0; i < nt; i++)
            msg.shape_triangles[i] = (trioct_triangle_t){wire_vec(q->shape_triangles[i].a),
                                                         wire_vec(q->shape_triangles[i].b),
                                                         wire_vec(q->shape_triangles[i].c)};
        for (size_t i = 0; i < np; i++) {
            memcpy(msg.poses[i].r, q->poses[i].r, sizeof msg.poses[i].r);
            msg.poses[i].t = wire_vec(q->poses[i].t);
        }
        p->count = np;
        p->complete = complete_mesh;
        client_no_daemon_world(c, q->world, timeout_ms, p->no_daemon, sizeof p->no_daemon);
        client_request_header(c, &msg.header, p, q->world);
        rc = client_pending_send(c, p, channel, &mesh_codec, &msg, r);
    }
    free(msg.shape_triangles);
    free(msg.poses);
    *out = rc == TRIOCT_OK ? p : NULL;
    return rc;
}

/* A sync call's callback: the result moves to the caller's struct. */
static void keep_mesh(trioct_client *c, trioct_mesh_result *res, void *user)
{
    (void)c;
    *(trioct_mesh_result *)user = *res;
    memset(res, 0, sizeof *res);
}

int trioct_mesh(trioct_client *c, const trioct_mesh_query *q, int timeout_ms,
                trioct_mesh_result *out)
{
    memset(out, 0, sizeof *out);
    pending *p;
    int rc = start_mesh(c, q, timeout_ms, &out->reply, &p);
    if (rc != TRIOCT_OK)
        return rc;
    client_sync_finish(c, p, (void (*)(void))keep_mesh, out);
    return out->reply.status;
}

int trioct_mesh_async(trioct_client *c, const trioct_mesh_query *q, int timeout_ms,
                      trioct_mesh_done cb, void *user, int64_t *request_id)
{
    trioct_reply r;
    memset(&r, 0, sizeof r);
    pending *p = NULL;
    int rc = client_async_check(c, cb != NULL, &r);
    if (rc == TRIOCT_OK)
        rc = start_mesh(c, q, timeout_ms, &r, &p);
    return client_async_started(c, rc, &r, p, (void (*)(void))cb, user, request_id);
}

/* Keeps .reply: the status and message stay readable after the arrays are gone. */
void trioct_mesh_result_free(trioct_mesh_result *res)
{
    if (res == NULL)
        return;
    free(res->found);
    free(res->pairs);
    client_object_names_free(&res->objects);
    res->found = NULL;
    res->pairs = NULL;
    res->num_poses = 0;
    res->num_pairs = 0;
}
