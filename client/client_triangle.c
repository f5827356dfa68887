/* Triangle batches: the request on <prefix>_TRI_<world>, the answer's chunks joined into
 * one list of contacts (and their segments), synchronously or through a callback. */
#include "client_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "trioct_triangle_reply_t.h"
#include "trioct_triangle_request_t.h"

_Static_assert(TRIOCT_TRI_YESNO == TRIOCT_TRIANGLE_REQUEST_T_YESNO &&
                   TRIOCT_TRI_IDS == TRIOCT_TRIANGLE_REQUEST_T_IDS &&
                   TRIOCT_TRI_SEGMENTS == TRIOCT_TRIANGLE_REQUEST_T_SEGMENTS,
               "trioct.h's triangle details are the wire's");

static int reply_decode(const void *buf, size_t size, void *msg)
{
    return trioct_triangle_reply_t_decode(buf, 0, (int)size, msg) < 0 ? -1 : 0;
}

static void reply_cleanup(void *msg)
{
    trioct_triangle_reply_t_decode_cleanup(msg);
}

static const reply_ops triangle_reply_ops = {
    .wire = WIRE_TRIANGLE_REPLY,
    .msg_size = sizeof(trioct_triangle_reply_t),
    .decode = reply_decode,
    .cleanup = reply_cleanup,
};

static int request_size(const void *msg)
{
    return trioct_triangle_request_t_encoded_size(msg);
}

static int request_encode(void *buf, int size, const void *msg)
{
    return trioct_triangle_request_t_encode(buf, 0, size, msg);
}

static const request_codec triangle_codec = {request_size, request_encode, NULL};

static trioct_vec3_t wire_vec(trioct_vec3 v)
{
    return (trioct_vec3_t){v.x, v.y, v.z};
}

static trioct_vec3 api_vec(trioct_vec3_t v)
{
    return (trioct_vec3){v.x, v.y, v.z};
}

static int check_query(const trioct_triangle_query *q, trioct_reply *r)
{
    if (q == NULL)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "no triangle query given");
    if (q->detail < TRIOCT_TRI_YESNO || q->detail > TRIOCT_TRI_SEGMENTS)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST,
                           "unknown triangle detail %d (TRIOCT_TRI_YESNO, _IDS or _SEGMENTS)",
                           q->detail);
    if (q->accuracy < TRIOCT_ACCURACY_WORLD || q->accuracy > TRIOCT_ACCURACY_FAST)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "unknown accuracy %d", q->accuracy);
    if (q->count > TRIOCT_MAX_TRIANGLES)
        return client_fail(r, TRIOCT_ERR_OVER_CAP,
                           "%zu triangles is over the cap of %d triangles per request "
                           "(TRIOCT_MAX_TRIANGLES)",
                           q->count, TRIOCT_MAX_TRIANGLES);
    if (q->count > 0 && q->triangles == NULL)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "%zu triangles without their array",
                           q->count);
    return TRIOCT_OK;
}

/* Joins the chunks' contacts and segments (a SEGMENTS chunk carries one segment per
 * contact); found[] comes from chunk 0 only. */
static int build_result(const assembly *a, size_t n, trioct_triangle_result *out)
{
    const trioct_triangle_reply_t *first = a->chunks[0];
    trioct_reply *r = &out->reply;
    out->detail = first->detail;
    if (first->num_triangles < 0 || (size_t)first->num_triangles != n)
        return client_fail(r, TRIOCT_ERR_BAD_REPLY,
                           "the reply has %d found[] entries for %zu triangles",
                           first->num_triangles, n);
    size_t contacts = 0, segments = 0;
    for (int32_t i = 0; i < a->chunk_count; i++) {
        const trioct_triangle_reply_t *chunk = a->chunks[i];
        contacts += (size_t)chunk->num_contacts;
        segments += (size_t)chunk->num_segments;
    }
    if (segments != 0 && segments != contacts)
        return client_fail(r, TRIOCT_ERR_BAD_REPLY, "the reply has %zu segments for %zu contacts",
                           segments, contacts);
    if (first->detail == TRIOCT_TRI_SEGMENTS && segments != contacts)
        return client_fail(r, TRIOCT_ERR_BAD_REPLY,
                           "a SEGMENTS reply without segments for its %zu contacts", contacts);
    out->found = calloc(n ? n : 1, sizeof *out->found);
    out->contacts = calloc(contacts ? contacts : 1, sizeof *out->contacts);
    if (segments > 0)
        out->segments = calloc(segments, sizeof *out->segments);
    if (out->found == NULL || out->contacts == NULL || (segments > 0 && out->segments == NULL))
        return client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for %zu contacts", contacts);
    out->num_triangles = n;
    if (n > 0)
        memcpy(out->found, first->found, n * sizeof *out->found);
    if (client_object_names(r, first->num_objects, first->objects, &out->objects) != TRIOCT_OK)
        return r->status;
    size_t k = 0, s = 0;
    for (int32_t i = 0; i < a->chunk_count; i++) {
        const trioct_triangle_reply_t *chunk = a->chunks[i];
        for (int32_t j = 0; j < chunk->num_contacts; j++, k++) {
            const trioct_contact_t *ct = &chunk->contacts[j];
            if (ct->query < 0 || (size_t)ct->query >= n)
                return client_fail(r, TRIOCT_ERR_BAD_REPLY,
                                   "contact %zu names query triangle %d of %zu", k, ct->query, n);
            if (client_check_object(r, ct->object, &out->objects, "contact", k) != TRIOCT_OK)
                return r->status;
            out->contacts[k] = (trioct_contact){ct->query, ct->object, ct->triangle};
        }
        for (int32_t j = 0; j < chunk->num_segments; j++, s++)
            out->segments[s] = (trioct_segment){api_vec(chunk->segments[j].p),
                                                api_vec(chunk->segments[j].q)};
    }
    out->num_contacts = contacts;
    return TRIOCT_OK;
}

/* Builds the result, hands it to the callback and frees what the callback left. */
static void complete_triangles(trioct_client *c, pending *p)
{
    trioct_triangle_result res;
    memset(&res, 0, sizeof res);
    const assembly *answer = client_answer(c, p, &res.reply);
    if (answer != NULL && res.reply.status == TRIOCT_OK)
        build_result(answer, p->count, &res);
    if (res.reply.status != TRIOCT_OK)
        trioct_triangle_result_free(&res); /* a failed request leaves no half result */
    ((trioct_triangle_done)p->cb)(c, &res, p->user);
    trioct_triangle_result_free(&res);
}

/* Checks, encodes and sends q; *out is then the request waiting for its answer. */
static int start_triangles(trioct_client *c, const trioct_triangle_query *q, int timeout_ms,
                           trioct_reply *r, pending **out)
{
    char channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    if (check_query(q, r) != TRIOCT_OK ||
        client_channel(c, TRIOCT_CHANNEL_TRI, q->world, channel, r, "world") != TRIOCT_OK)
        return r->status;

    size_t n = q->count;
    trioct_triangle_request_t msg = {
        .detail = (int8_t)q->detail,
        .accuracy = (int8_t)q->accuracy,
        .num_triangles = (int32_t)n,
        .triangles = calloc(n ? n : 1, sizeof(trioct_triangle_t)),
    };
    pending *p = NULL;
    int rc;
    if (msg.triangles == NULL) {
        rc = client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for %zu triangles", n);
    } else if ((p = client_pending_new(c, &triangle_reply_ops, timeout_ms, r)) == NULL) {
        rc = r->status;
    } else {
        for (size_t i = 0; i < n; i++)
            msg.triangles[i] = (trioct_triangle_t){wire_vec(q->triangles[i].a),
                                                   wire_vec(q->triangles[i].b),
                                                   wire_vec(q->triangles[i].c)};
        p->count = n;
        p->complete = complete_triangles;
        client_no_daemon_world(c, q->world, timeout_ms, p->no_daemon, sizeof p->no_daemon);
        client_request_header(c, &msg.header, p, q->world);
        rc = client_pending_send(c, p, channel, &triangle_codec, &msg, r);
    }
    free(msg.triangles);
    *out = rc == TRIOCT_OK ? p : NULL;
    return rc;
}

/* A sync call's callback: the result moves to the caller's struct. */
static void keep_triangles(trioct_client *c, trioct_triangle_result *res, void *user)
{
    (void)c;
    *(trioct_triangle_result *)user = *res;
    memset(res, 0, sizeof *res);
}

int trioct_triangles(trioct_client *c, const trioct_triangle_query *q, int timeout_ms,
                     trioct_triangle_result *out)
{
    memset(out, 0, sizeof *out);
    pending *p;
    int rc = start_triangles(c, q, timeout_ms, &out->reply, &p);
    if (rc != TRIOCT_OK)
        return rc;
    client_sync_finish(c, p, (void (*)(void))keep_triangles, out);
    return out->reply.status;
}

int trioct_triangles_async(trioct_client *c, const trioct_triangle_query *q, int timeout_ms,
                           trioct_triangle_done cb, void *user, int64_t *request_id)
{
    trioct_reply r;
    memset(&r, 0, sizeof r);
    pending *p = NULL;
    int rc = client_async_check(c, cb != NULL, &r);
    if (rc == TRIOCT_OK)
        rc = start_triangles(c, q, timeout_ms, &r, &p);
    return client_async_started(c, rc, &r, p, (void (*)(void))cb, user, request_id);
}

/* Keeps .reply: the status and message stay readable after the arrays are gone. */
void trioct_triangle_result_free(trioct_triangle_result *res)
{
    if (res == NULL)
        return;
    free(res->found);
    free(res->contacts);
    free(res->segments);
    client_object_names_free(&res->objects);
    res->found = NULL;
    res->contacts = NULL;
    res->segments = NULL;
    res->num_triangles = 0;
    res->num_contacts = 0;
}
