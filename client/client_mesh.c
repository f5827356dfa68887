/* A query shape at a batch of poses: the request on <prefix>_MESH_<world>, the answer's
 * chunks joined into one list of touching pairs. */
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

static const request_codec mesh_codec = {request_size, request_encode};

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
    size_t k = 0;
    for (int32_t i = 0; i < a->chunk_count; i++) {
        const trioct_mesh_reply_t *chunk = a->chunks[i];
        for (int32_t j = 0; j < chunk->num_pairs; j++, k++) {
            const trioct_mesh_pair_t *pr = &chunk->pairs[j];
            if (pr->pose < 0 || (size_t)pr->pose >= n)
                return client_fail(r, TRIOCT_ERR_BAD_REPLY, "pair %zu names pose %d of %zu", k,
                                   pr->pose, n);
            out->pairs[k] = (trioct_mesh_pair){pr->pose, pr->shape_triangle, pr->world_triangle};
        }
    }
    out->num_pairs = total;
    return TRIOCT_OK;
}

int trioct_mesh(trioct_client *c, const trioct_mesh_query *q, int timeout_ms,
                trioct_mesh_result *out)
{
    memset(out, 0, sizeof *out);
    trioct_reply *r = &out->reply;
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
    if (msg.shape_triangles == NULL || msg.poses == NULL) {
        free(msg.shape_triangles);
        free(msg.poses);
        return client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for %zu poses", np);
    }
    for (size_t i = 0; i < nt; i++)
        msg.shape_triangles[i] = (trioct_triangle_t){wire_vec(q->shape_triangles[i].a),
                                                     wire_vec(q->shape_triangles[i].b),
                                                     wire_vec(q->shape_triangles[i].c)};
    for (size_t i = 0; i < np; i++) {
        memcpy(msg.poses[i].r, q->poses[i].r, sizeof msg.poses[i].r);
        msg.poses[i].t = wire_vec(q->poses[i].t);
    }

    pending p;
    client_pending_begin(c, &p, &mesh_reply_ops, client_next_request_id(c));
    client_request_header(c, &msg.header, p.request_id, q->world);
    char no_daemon[TRIOCT_MAX_MESSAGE_LEN + 1];
    client_no_daemon_world(c, q->world, timeout_ms, no_daemon, sizeof no_daemon);
    const assembly *answer;
    int rc = client_call(c, &p, channel, &mesh_codec, &msg, timeout_ms, no_daemon, r, &answer);
    free(msg.shape_triangles);
    free(msg.poses);
    if (answer != NULL && rc == TRIOCT_OK)
        rc = build_result(answer, np, out);
    client_pending_end(c, &p);
    if (rc != TRIOCT_OK)
        trioct_mesh_result_free(out); /* a failed call leaves no half result */
    return rc;
}

/* Keeps .reply: the status and message stay readable after the arrays are gone. */
void trioct_mesh_result_free(trioct_mesh_result *res)
{
    if (res == NULL)
        return;
    free(res->found);
    free(res->pairs);
    res->found = NULL;
    res->pairs = NULL;
    res->num_poses = 0;
    res->num_pairs = 0;
}
