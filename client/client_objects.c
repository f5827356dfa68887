/* Object edits and listings: the request on <prefix>_OBJECTS_<world>, the answer's chunks
 * joined into one list of objects, synchronously or through a callback; and poses from
 * quaternions, made as the daemon makes them. */
#include "client_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "quaternion.h"
#include "trioct_object_edit_request_t.h"
#include "trioct_object_reply_t.h"

_Static_assert(TRIOCT_OBJECT_ADD == TRIOCT_OBJECT_EDIT_T_ADD && TRIOCT_OBJECT_MOVE == TRIOCT_OBJECT_EDIT_T_MOVE &&
                   TRIOCT_OBJECT_REMOVE == TRIOCT_OBJECT_EDIT_T_REMOVE,
               "trioct.h's edit ops are the wire's");

int trioct_pose_from_quaternion(double x, double y, double z, double qw, double qx, double qy, double qz,
                                trioct_pose *out)
{
    if (!isfinite(x) || !isfinite(y) || !isfinite(z))
        return TRIOCT_ERR_NONFINITE;
    trioct_quaternion_status st = trioct_quaternion_matrix(qw, qx, qy, qz, out->r);
    if (st == TRIOCT_QUATERNION_NONFINITE)
        return TRIOCT_ERR_NONFINITE;
    if (st != TRIOCT_QUATERNION_OK)
        return TRIOCT_ERR_BAD_POSE;
    out->t = (trioct_vec3){x, y, z};
    return TRIOCT_OK;
}

static int reply_decode(const void *buf, size_t size, void *msg)
{
    return trioct_object_reply_t_decode(buf, 0, (int)size, msg) < 0 ? -1 : 0;
}

static void reply_cleanup(void *msg)
{
    trioct_object_reply_t_decode_cleanup(msg);
}

static const reply_ops object_reply_ops = {
    .wire = WIRE_OBJECT_REPLY,
    .msg_size = sizeof(trioct_object_reply_t),
    .decode = reply_decode,
    .cleanup = reply_cleanup,
};

static int request_size(const void *msg)
{
    return trioct_object_edit_request_t_encoded_size(msg);
}

static int request_encode(void *buf, int size, const void *msg)
{
    return trioct_object_edit_request_t_encode(buf, 0, size, msg);
}

static int request_is_change(const void *msg)
{
    return ((const trioct_object_edit_request_t *)msg)->num_edits > 0;
}

static const request_codec object_codec = {request_size, request_encode, request_is_change};

static trioct_vec3_t wire_vec(trioct_vec3 v)
{
    return (trioct_vec3_t){v.x, v.y, v.z};
}

static trioct_vec3 api_vec(trioct_vec3_t v)
{
    return (trioct_vec3){v.x, v.y, v.z};
}

/* The checks the daemon would make that need no world, so a mistake costs no round trip. */
static int check_edits(const trioct_object_edit *edits, size_t count, trioct_reply *r)
{
    if (count > TRIOCT_MAX_EDITS)
        return client_fail(r, TRIOCT_ERR_OVER_CAP, "%zu edits is over the cap of %d (TRIOCT_MAX_EDITS)", count,
                           TRIOCT_MAX_EDITS);
    if (count > 0 && edits == NULL)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "%zu edits without their array", count);
    for (size_t i = 0; i < count; i++) {
        const trioct_object_edit *e = &edits[i];
        if (e->op < TRIOCT_OBJECT_ADD || e->op > TRIOCT_OBJECT_REMOVE)
            return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "edit %zu: unknown op %d", i, e->op);
        if (e->name == NULL || e->name[0] == '\0' || strlen(e->name) > TRIOCT_MAX_NAME_LEN)
            return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "edit %zu: an object name is 1..%d characters", i,
                               TRIOCT_MAX_NAME_LEN);
        if (e->num_triangles > TRIOCT_MAX_INLINE_SHAPE_TRIANGLES)
            return client_fail(r, TRIOCT_ERR_OVER_CAP,
                               "edit %zu: %zu inline triangles is over the cap of %d "
                               "(TRIOCT_MAX_INLINE_SHAPE_TRIANGLES)",
                               i, e->num_triangles, TRIOCT_MAX_INLINE_SHAPE_TRIANGLES);
        if (e->num_triangles > 0 && e->triangles == NULL)
            return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "edit %zu: %zu triangles without their array", i,
                               e->num_triangles);
        if (e->mesh != NULL && strlen(e->mesh) >= TRIOCT_MAX_PATH_LEN)
            return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "edit %zu: the mesh path is longer than %d characters",
                               i, TRIOCT_MAX_PATH_LEN - 1);
    }
    return TRIOCT_OK;
}

static int build_result(const assembly *a, trioct_object_result *out)
{
    const trioct_object_reply_t *first = a->chunks[0];
    trioct_reply *r = &out->reply;
    out->failed_edit = first->failed_edit;
    out->objects = first->objects;
    out->triangles = first->triangles;
    size_t total = 0;
    for (int32_t i = 0; i < a->chunk_count; i++)
        total += (size_t)((const trioct_object_reply_t *)a->chunks[i])->num_objects;
    out->list = calloc(total ? total : 1, sizeof *out->list);
    if (out->list == NULL)
        return client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for %zu objects", total);
    size_t k = 0;
    for (int32_t i = 0; i < a->chunk_count; i++) {
        const trioct_object_reply_t *chunk = a->chunks[i];
        for (int32_t j = 0; j < chunk->num_objects; j++, k++) {
            const trioct_object_info_t *in = &chunk->list[j];
            trioct_object_info *o = &out->list[k];
            client_copy(o->name, sizeof o->name, in->name);
            client_copy(o->mesh, sizeof o->mesh, in->mesh);
            o->triangles = in->triangles;
            memcpy(o->pose.r, in->pose.r, sizeof o->pose.r);
            o->pose.t = api_vec(in->pose.t);
            o->bbox_min = api_vec(in->bbox_min);
            o->bbox_max = api_vec(in->bbox_max);
            o->bytes = in->bytes;
            o->shared = in->shared;
        }
    }
    out->num_objects = total;
    return TRIOCT_OK;
}

/* An error reply still says which edit failed: kept with the reply, not freed with it. */
static void complete_objects(trioct_client *c, pending *p)
{
    trioct_object_result res;
    memset(&res, 0, sizeof res);
    res.failed_edit = -1;
    const assembly *answer = client_answer(c, p, &res.reply);
    if (answer != NULL && res.reply.status == TRIOCT_OK)
        build_result(answer, &res);
    else if (answer != NULL)
        res.failed_edit = ((const trioct_object_reply_t *)answer->chunks[0])->failed_edit;
    if (res.reply.status != TRIOCT_OK)
        trioct_object_result_free(&res); /* a failed request leaves no half result */
    ((trioct_object_done)p->cb)(c, &res, p->user);
    trioct_object_result_free(&res);
}

static int start_objects(trioct_client *c, const char *world, const trioct_object_edit *edits, size_t count, int list,
                         int timeout_ms, trioct_reply *r, pending **out)
{
    char channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    if (check_edits(edits, count, r) != TRIOCT_OK ||
        client_channel(c, TRIOCT_CHANNEL_OBJECTS, world, channel, r, "world") != TRIOCT_OK)
        return r->status;
    trioct_object_edit_request_t msg = {
        .list = (int8_t)(list != 0),
        .num_edits = (int32_t)count,
        .edits = calloc(count ? count : 1, sizeof(trioct_object_edit_t)),
    };
    size_t all_triangles = 0;
    for (size_t i = 0; i < count; i++)
        all_triangles += edits[i].num_triangles;
    trioct_triangle_t *triangles = calloc(all_triangles ? all_triangles : 1, sizeof *triangles);
    pending *p = NULL;
    int rc;
    if (msg.edits == NULL || triangles == NULL) {
        rc = client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for %zu edits", count);
    } else if ((p = client_pending_new(c, &object_reply_ops, timeout_ms, r)) == NULL) {
        rc = r->status;
    } else {
        size_t at = 0;
        for (size_t i = 0; i < count; i++) {
            const trioct_object_edit *e = &edits[i];
            trioct_object_edit_t *w = &msg.edits[i];
            w->op = (int8_t)e->op;
            w->name = (char *)e->name; /* the encoder only reads them */
            w->mesh = (char *)(e->mesh ? e->mesh : "");
            memcpy(w->pose.r, e->pose.r, sizeof w->pose.r);
            w->pose.t = wire_vec(e->pose.t);
            w->rotation = e->quaternion ? TRIOCT_OBJECT_EDIT_T_QUATERNION : TRIOCT_OBJECT_EDIT_T_MATRIX;
            if (e->quaternion)
                memcpy(w->quaternion, e->quaternion, sizeof w->quaternion);
            w->num_triangles = (int32_t)e->num_triangles;
            w->triangles = triangles + at;
            for (size_t t = 0; t < e->num_triangles; t++, at++)
                triangles[at] = (trioct_triangle_t){wire_vec(e->triangles[t].a), wire_vec(e->triangles[t].b),
                                                    wire_vec(e->triangles[t].c)};
        }
        p->complete = complete_objects;
        client_no_daemon_world(c, world, timeout_ms, p->no_daemon, sizeof p->no_daemon);
        client_request_header(c, &msg.header, p, world);
        rc = client_pending_send(c, p, channel, &object_codec, &msg, r);
    }
    free(msg.edits);
    free(triangles);
    *out = rc == TRIOCT_OK ? p : NULL;
    return rc;
}

static void keep_objects(trioct_client *c, trioct_object_result *res, void *user)
{
    (void)c;
    *(trioct_object_result *)user = *res;
    memset(res, 0, sizeof *res);
}

int trioct_objects_edit(trioct_client *c, const char *world, const trioct_object_edit *edits, size_t count, int list,
                        int timeout_ms, trioct_object_result *out)
{
    memset(out, 0, sizeof *out);
    out->failed_edit = -1;
    pending *p;
    int rc = start_objects(c, world, edits, count, list, timeout_ms, &out->reply, &p);
    if (rc != TRIOCT_OK)
        return rc;
    client_sync_finish(c, p, (void (*)(void))keep_objects, out);
    return out->reply.status;
}

int trioct_objects_edit_async(trioct_client *c, const char *world, const trioct_object_edit *edits, size_t count,
                              int list, int timeout_ms, trioct_object_done cb, void *user, int64_t *request_id)
{
    trioct_reply r;
    memset(&r, 0, sizeof r);
    pending *p = NULL;
    int rc = client_async_check(c, cb != NULL, &r);
    if (rc == TRIOCT_OK)
        rc = start_objects(c, world, edits, count, list, timeout_ms, &r, &p);
    return client_async_started(c, rc, &r, p, (void (*)(void))cb, user, request_id);
}

/* Keeps .reply and failed_edit: what went wrong stays readable after the list is gone. */
void trioct_object_result_free(trioct_object_result *res)
{
    if (res == NULL)
        return;
    free(res->list);
    res->list = NULL;
    res->num_objects = 0;
}
