/* Ray batches: the request on <prefix>_RAY_<world>, the answer's chunks joined into one
 * list of hits, synchronously or through a callback. */
#include "client_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "trioct_ray_reply_t.h"
#include "trioct_ray_request_t.h"

_Static_assert(TRIOCT_RAY_ANY == TRIOCT_RAY_REQUEST_T_ANY &&
                   TRIOCT_RAY_CLOSEST == TRIOCT_RAY_REQUEST_T_CLOSEST &&
                   TRIOCT_RAY_ALL == TRIOCT_RAY_REQUEST_T_ALL,
               "trioct.h's ray details are the wire's");
_Static_assert(TRIOCT_ACCURACY_WORLD == TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD &&
                   TRIOCT_ACCURACY_EXACT == TRIOCT_RAY_REQUEST_T_EXACT &&
                   TRIOCT_ACCURACY_SEED == TRIOCT_RAY_REQUEST_T_SEED &&
                   TRIOCT_ACCURACY_FAST == TRIOCT_RAY_REQUEST_T_FAST,
               "trioct.h's accuracy modes are the wire's");
_Static_assert(TRIOCT_CONTACT_CROSSING == TRIOCT_RAY_REQUEST_T_CROSSING &&
                   TRIOCT_CONTACT_TOUCH == TRIOCT_RAY_REQUEST_T_TOUCH,
               "trioct.h's contact rules are the wire's");

static int reply_decode(const void *buf, size_t size, void *msg)
{
    return trioct_ray_reply_t_decode(buf, 0, (int)size, msg) < 0 ? -1 : 0;
}

static void reply_cleanup(void *msg)
{
    trioct_ray_reply_t_decode_cleanup(msg);
}

static const reply_ops ray_reply_ops = {
    .wire = WIRE_RAY_REPLY,
    .msg_size = sizeof(trioct_ray_reply_t),
    .decode = reply_decode,
    .cleanup = reply_cleanup,
};

static int request_size(const void *msg)
{
    return trioct_ray_request_t_encoded_size(msg);
}

static int request_encode(void *buf, int size, const void *msg)
{
    return trioct_ray_request_t_encode(buf, 0, size, msg);
}

static const request_codec ray_codec = {request_size, request_encode, NULL};

trioct_ray_query trioct_ray_query_default(const char *world)
{
    trioct_ray_query q = {
        .world = world,
        .detail = TRIOCT_RAY_CLOSEST,
        .accuracy = TRIOCT_ACCURACY_WORLD,
        .tmin = 0.0,
        .tmax = INFINITY,
        .max_hits = TRIOCT_MAX_HITS_PER_RAY,
    };
    return q;
}

static int check_query(const trioct_ray_query *q, int contact, trioct_reply *r)
{
    if (q == NULL)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "no ray query given");
    if (contact != TRIOCT_CONTACT_CROSSING && contact != TRIOCT_CONTACT_TOUCH)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST,
                           "unknown contact %d (TRIOCT_CONTACT_CROSSING or _TOUCH)", contact);
    if (q->detail < TRIOCT_RAY_ANY || q->detail > TRIOCT_RAY_ALL)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST,
                           "unknown ray detail %d (TRIOCT_RAY_ANY, _CLOSEST or _ALL)", q->detail);
    if (q->accuracy < TRIOCT_ACCURACY_WORLD || q->accuracy > TRIOCT_ACCURACY_FAST)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "unknown accuracy %d", q->accuracy);
    if (q->count > TRIOCT_MAX_RAYS)
        return client_fail(r, TRIOCT_ERR_OVER_CAP,
                           "%zu rays is over the cap of %d rays per request (TRIOCT_MAX_RAYS)",
                           q->count, TRIOCT_MAX_RAYS);
    if (q->count > 0 && (q->origins == NULL || q->directions == NULL))
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "%zu rays without origins or directions",
                           q->count);
    if (q->detail == TRIOCT_RAY_ALL) {
        if (q->max_hits > TRIOCT_MAX_HITS_PER_RAY)
            return client_fail(r, TRIOCT_ERR_OVER_CAP,
                               "max_hits %d is over the cap of %d hits per ray "
                               "(TRIOCT_MAX_HITS_PER_RAY)",
                               q->max_hits, TRIOCT_MAX_HITS_PER_RAY);
        if (q->max_hits < 1)
            return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "max_hits %d: ALL stores 1..%d hits",
                               q->max_hits, TRIOCT_MAX_HITS_PER_RAY);
    }
    return TRIOCT_OK;
}

/* Joins the chunks' hits; found[] comes from chunk 0 only. */
static int build_result(const assembly *a, size_t num_rays, trioct_ray_result *out)
{
    const trioct_ray_reply_t *first = a->chunks[0];
    trioct_reply *r = &out->reply;
    out->detail = first->detail;
    if (first->num_rays < 0 || (size_t)first->num_rays != num_rays)
        return client_fail(r, TRIOCT_ERR_BAD_REPLY,
                           "the reply has %d found[] entries for %zu rays", first->num_rays,
                           num_rays);
    size_t total = 0;
    for (int32_t i = 0; i < a->chunk_count; i++)
        total += (size_t)((const trioct_ray_reply_t *)a->chunks[i])->num_hits;
    out->found = calloc(num_rays ? num_rays : 1, sizeof *out->found);
    out->hits = calloc(total ? total : 1, sizeof *out->hits);
    if (out->found == NULL || out->hits == NULL)
        return client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for %zu hits", total);
    out->num_rays = num_rays;
    if (num_rays > 0)
        memcpy(out->found, first->found, num_rays * sizeof *out->found);
    if (client_object_names(r, first->num_objects, first->objects, &out->objects) != TRIOCT_OK)
        return r->status;
    size_t k = 0;
    for (int32_t i = 0; i < a->chunk_count; i++) {
        const trioct_ray_reply_t *chunk = a->chunks[i];
        for (int32_t j = 0; j < chunk->num_hits; j++, k++) {
            const trioct_ray_hit_t *h = &chunk->hits[j];
            if (h->ray < 0 || (size_t)h->ray >= num_rays)
                return client_fail(r, TRIOCT_ERR_BAD_REPLY, "hit %zu names ray %d of %zu", k,
                                   h->ray, num_rays);
            if (client_check_object(r, h->object, &out->objects, "hit", k) != TRIOCT_OK)
                return r->status;
            out->hits[k] = (trioct_ray_hit){
                .ray = h->ray,
                .t = h->t,
                .object = h->object,
                .triangle = h->triangle,
                .u = h->u,
                .v = h->v,
                .normal = {h->normal.x, h->normal.y, h->normal.z},
            };
        }
    }
    out->num_hits = total;
    return TRIOCT_OK;
}

/* Builds the result, hands it to the callback and frees what the callback left. */
static void complete_rays(trioct_client *c, pending *p)
{
    trioct_ray_result res;
    memset(&res, 0, sizeof res);
    const assembly *answer = client_answer(c, p, &res.reply);
    if (answer != NULL && res.reply.status == TRIOCT_OK)
        build_result(answer, p->count, &res);
    if (res.reply.status != TRIOCT_OK)
        trioct_ray_result_free(&res); /* a failed request leaves no half result */
    ((trioct_ray_done)p->cb)(c, &res, p->user);
    trioct_ray_result_free(&res);
}

/* Checks, encodes and sends q; *out is then the request waiting for its answer. */
static int start_rays(trioct_client *c, const trioct_ray_query *q, int contact, int timeout_ms,
                      trioct_reply *r, pending **out)
{
    char channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    if (check_query(q, contact, r) != TRIOCT_OK ||
        client_channel(c, TRIOCT_CHANNEL_RAY, q->world, channel, r, "world") != TRIOCT_OK)
        return r->status;

    size_t n = q->count;
    trioct_ray_request_t msg = {
        .detail = (int8_t)q->detail,
        .accuracy = (int8_t)q->accuracy,
        .tmin = q->tmin,
        .tmax = q->tmax,
        .max_hits = q->max_hits,
        .num_rays = (int32_t)n,
        .origin = calloc(n ? n : 1, sizeof(trioct_vec3_t)),
        .direction = calloc(n ? n : 1, sizeof(trioct_vec3_t)),
        .contact = (int8_t)contact,
    };
    pending *p = NULL;
    int rc;
    if (msg.origin == NULL || msg.direction == NULL) {
        rc = client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for %zu rays", n);
    } else if ((p = client_pending_new(c, &ray_reply_ops, timeout_ms, r)) == NULL) {
        rc = r->status;
    } else {
        for (size_t i = 0; i < n; i++) {
            msg.origin[i] = (trioct_vec3_t){q->origins[i].x, q->origins[i].y, q->origins[i].z};
            msg.direction[i] =
                (trioct_vec3_t){q->directions[i].x, q->directions[i].y, q->directions[i].z};
        }
        p->count = n;
        p->complete = complete_rays;
        client_no_daemon_world(c, q->world, timeout_ms, p->no_daemon, sizeof p->no_daemon);
        client_request_header(c, &msg.header, p, q->world);
        rc = client_pending_send(c, p, channel, &ray_codec, &msg, r);
    }
    free(msg.origin);
    free(msg.direction);
    *out = rc == TRIOCT_OK ? p : NULL;
    return rc;
}

/* A sync call's callback: the result moves to the caller's struct. */
static void keep_rays(trioct_client *c, trioct_ray_result *res, void *user)
{
    (void)c;
    *(trioct_ray_result *)user = *res;
    memset(res, 0, sizeof *res);
}

int trioct_rays_contact(trioct_client *c, const trioct_ray_query *q, int contact, int timeout_ms,
                        trioct_ray_result *out)
{
    memset(out, 0, sizeof *out);
    pending *p;
    int rc = start_rays(c, q, contact, timeout_ms, &out->reply, &p);
    if (rc != TRIOCT_OK)
        return rc;
    client_sync_finish(c, p, (void (*)(void))keep_rays, out);
    return out->reply.status;
}

int trioct_rays(trioct_client *c, const trioct_ray_query *q, int timeout_ms,
                trioct_ray_result *out)
{
    return trioct_rays_contact(c, q, TRIOCT_CONTACT_CROSSING, timeout_ms, out);
}

int trioct_rays_contact_async(trioct_client *c, const trioct_ray_query *q, int contact, int timeout_ms,
                              trioct_ray_done cb, void *user, int64_t *request_id)
{
    trioct_reply r;
    memset(&r, 0, sizeof r);
    pending *p = NULL;
    int rc = client_async_check(c, cb != NULL, &r);
    if (rc == TRIOCT_OK)
        rc = start_rays(c, q, contact, timeout_ms, &r, &p);
    return client_async_started(c, rc, &r, p, (void (*)(void))cb, user, request_id);
}

int trioct_rays_async(trioct_client *c, const trioct_ray_query *q, int timeout_ms,
                      trioct_ray_done cb, void *user, int64_t *request_id)
{
    return trioct_rays_contact_async(c, q, TRIOCT_CONTACT_CROSSING, timeout_ms, cb, user, request_id);
}

/* Keeps .reply: the status and message stay readable after the arrays are gone. */
void trioct_ray_result_free(trioct_ray_result *res)
{
    if (res == NULL)
        return;
    free(res->found);
    free(res->hits);
    client_object_names_free(&res->objects);
    res->found = NULL;
    res->hits = NULL;
    res->num_rays = 0;
    res->num_hits = 0;
}
