/* Robot state checks: the request on <prefix>_STATE_<world>, the answer's chunks joined
 * into per-state verdicts and one list of contacts, synchronously or through a callback. */
#include "client_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "trioct_state_reply_t.h"
#include "trioct_state_request_t.h"

_Static_assert(TRIOCT_STATE_VALID == TRIOCT_STATE_REQUEST_T_VALID &&
                   TRIOCT_STATE_CONTACTS == TRIOCT_STATE_REQUEST_T_CONTACTS,
               "trioct.h's state details are the wire's");

static int reply_decode(const void *buf, size_t size, void *msg)
{
    return trioct_state_reply_t_decode(buf, 0, (int)size, msg) < 0 ? -1 : 0;
}

static void reply_cleanup(void *msg)
{
    trioct_state_reply_t_decode_cleanup(msg);
}

static const reply_ops state_reply_ops = {
    .wire = WIRE_STATE_REPLY,
    .msg_size = sizeof(trioct_state_reply_t),
    .decode = reply_decode,
    .cleanup = reply_cleanup,
};

static int request_size(const void *msg)
{
    return trioct_state_request_t_encoded_size(msg);
}

static int request_encode(void *buf, int size, const void *msg)
{
    return trioct_state_request_t_encode(buf, 0, size, msg);
}

static const request_codec state_codec = {request_size, request_encode, NULL};

static trioct_vec3_t wire_vec(trioct_vec3 v)
{
    return (trioct_vec3_t){v.x, v.y, v.z};
}

static int check_query(const trioct_state_query *q, trioct_reply *r)
{
    if (q == NULL)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "no state query given");
    if (q->detail != TRIOCT_STATE_VALID && q->detail != TRIOCT_STATE_CONTACTS)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "unknown state detail %d (TRIOCT_STATE_VALID or _CONTACTS)",
                           q->detail);
    if (q->num_links < 1 || q->num_links > 64 || q->links == NULL)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "a state has 1..64 links; %zu given", q->num_links);
    if (q->num_states > 0 && q->poses == NULL)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "%zu states without their poses", q->num_states);
    if (q->num_states > TRIOCT_MAX_POSES / q->num_links)
        return client_fail(r, TRIOCT_ERR_OVER_CAP,
                           "%zu states of %zu links is over the cap of %d poses per request (TRIOCT_MAX_POSES)",
                           q->num_states, q->num_links, TRIOCT_MAX_POSES);
    if (q->num_allowed > 0 && q->allowed == NULL)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "%zu allowed pairs without their array", q->num_allowed);
    size_t inline_total = 0;
    for (size_t i = 0; i < q->num_links; i++) {
        const trioct_state_link *l = &q->links[i];
        if (l->name == NULL || l->name[0] == '\0' || strlen(l->name) > TRIOCT_MAX_NAME_LEN)
            return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "link %zu: a name is 1..%d characters", i,
                               TRIOCT_MAX_NAME_LEN);
        if (l->num_triangles > 0 && l->triangles == NULL)
            return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "link %zu: %zu triangles without their array", i,
                               l->num_triangles);
        inline_total += l->num_triangles;
    }
    if (inline_total > TRIOCT_MAX_INLINE_SHAPE_TRIANGLES)
        return client_fail(r, TRIOCT_ERR_OVER_CAP,
                           "%zu inline link triangles is over the cap of %d (TRIOCT_MAX_INLINE_SHAPE_TRIANGLES)",
                           inline_total, TRIOCT_MAX_INLINE_SHAPE_TRIANGLES);
    for (size_t i = 0; i < q->num_allowed; i++)
        if (q->allowed[i].a == NULL || q->allowed[i].b == NULL)
            return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "allowed pair %zu names nothing", i);
    return TRIOCT_OK;
}

static int build_result(const assembly *a, size_t states, size_t links, trioct_state_result *out)
{
    const trioct_state_reply_t *first = a->chunks[0];
    trioct_reply *r = &out->reply;
    out->detail = first->detail;
    if (first->num_states < 0 || (size_t)first->num_states != states)
        return client_fail(r, TRIOCT_ERR_BAD_REPLY, "the reply has %d verdicts for %zu states", first->num_states,
                           states);
    size_t total = 0;
    for (int32_t i = 0; i < a->chunk_count; i++)
        total += (size_t)((const trioct_state_reply_t *)a->chunks[i])->num_contacts;
    out->valid = calloc(states ? states : 1, sizeof *out->valid);
    out->found = calloc(states ? states : 1, sizeof *out->found);
    out->contacts = calloc(total ? total : 1, sizeof *out->contacts);
    if (out->valid == NULL || out->found == NULL || out->contacts == NULL)
        return client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for %zu contacts", total);
    out->num_states = states;
    for (size_t i = 0; i < states; i++) {
        out->valid[i] = first->found[i] == 0;
        out->found[i] = first->found[i];
    }
    if (client_object_names(r, first->num_objects, first->objects, &out->objects) != TRIOCT_OK)
        return r->status;
    size_t k = 0;
    for (int32_t i = 0; i < a->chunk_count; i++) {
        const trioct_state_reply_t *chunk = a->chunks[i];
        for (int32_t j = 0; j < chunk->num_contacts; j++, k++) {
            const trioct_state_contact_t *ct = &chunk->contacts[j];
            if (ct->state < 0 || (size_t)ct->state >= states || ct->link < 0 || (size_t)ct->link >= links)
                return client_fail(r, TRIOCT_ERR_BAD_REPLY, "contact %zu names state %d, link %d", k, ct->state,
                                   ct->link);
            if (ct->with_link ? (ct->other < 0 || (size_t)ct->other >= links)
                              : client_check_object(r, ct->other, &out->objects, "contact", k) != TRIOCT_OK)
                return client_fail(r, TRIOCT_ERR_BAD_REPLY, "contact %zu names other %d", k, ct->other);
            out->contacts[k] = (trioct_state_contact){ct->state,     ct->link,          ct->with_link != 0,
                                                      ct->other,     ct->link_triangle, ct->other_triangle};
        }
    }
    out->num_contacts = total;
    return TRIOCT_OK;
}

static void complete_states(trioct_client *c, pending *p)
{
    trioct_state_result res;
    memset(&res, 0, sizeof res);
    const assembly *answer = client_answer(c, p, &res.reply);
    if (answer != NULL && res.reply.status == TRIOCT_OK)
        build_result(answer, p->count, p->count2, &res);
    if (res.reply.status != TRIOCT_OK)
        trioct_state_result_free(&res); /* a failed request leaves no half result */
    ((trioct_state_done)p->cb)(c, &res, p->user);
    trioct_state_result_free(&res);
}

static int start_states(trioct_client *c, const trioct_state_query *q, int timeout_ms, trioct_reply *r, pending **out)
{
    char channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    if (check_query(q, r) != TRIOCT_OK ||
        client_channel(c, TRIOCT_CHANNEL_STATE, q->world, channel, r, "world") != TRIOCT_OK)
        return r->status;
    size_t nl = q->num_links, np = q->num_states * q->num_links, na = q->num_allowed, nt = 0;
    for (size_t i = 0; i < nl; i++)
        nt += q->links[i].num_triangles;
    trioct_state_request_t msg = {
        .detail = (int8_t)q->detail,
        .self_collision = (int8_t)(q->self_collision != 0),
        .num_links = (int32_t)nl,
        .links = calloc(nl, sizeof(trioct_state_link_t)),
        .num_allowed = (int32_t)na,
        .allowed_a = calloc(na ? na : 1, sizeof(char *)),
        .allowed_b = calloc(na ? na : 1, sizeof(char *)),
        .num_poses = (int32_t)np,
        .poses = calloc(np ? np : 1, sizeof(trioct_pose_t)),
        .rotation = q->quaternions ? TRIOCT_STATE_REQUEST_T_QUATERNION : TRIOCT_STATE_REQUEST_T_MATRIX,
        .num_quaternions = q->quaternions ? (int32_t)(4 * np) : 0,
        .quaternions = (double *)q->quaternions, /* the encoder only reads them */
    };
    trioct_triangle_t *tris = calloc(nt ? nt : 1, sizeof *tris);
    pending *p = NULL;
    int rc;
    if (!msg.links || !msg.allowed_a || !msg.allowed_b || !msg.poses || !tris) {
        rc = client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for the state query");
    } else if ((p = client_pending_new(c, &state_reply_ops, timeout_ms, r)) == NULL) {
        rc = r->status;
    } else {
        size_t at = 0;
        for (size_t i = 0; i < nl; i++) {
            const trioct_state_link *l = &q->links[i];
            msg.links[i] = (trioct_state_link_t){(char *)l->name, (char *)(l->shape ? l->shape : ""),
                                                 (int32_t)l->num_triangles, tris + at};
            for (size_t t = 0; t < l->num_triangles; t++, at++)
                tris[at] = (trioct_triangle_t){wire_vec(l->triangles[t].a), wire_vec(l->triangles[t].b),
                                               wire_vec(l->triangles[t].c)};
        }
        for (size_t i = 0; i < na; i++) {
            msg.allowed_a[i] = (char *)q->allowed[i].a;
            msg.allowed_b[i] = (char *)q->allowed[i].b;
        }
        for (size_t i = 0; i < np; i++) {
            memcpy(msg.poses[i].r, q->poses[i].r, sizeof msg.poses[i].r);
            msg.poses[i].t = wire_vec(q->poses[i].t);
        }
        p->count = q->num_states;
        p->count2 = nl;
        p->complete = complete_states;
        client_no_daemon_world(c, q->world, timeout_ms, p->no_daemon, sizeof p->no_daemon);
        client_request_header(c, &msg.header, p, q->world);
        rc = client_pending_send(c, p, channel, &state_codec, &msg, r);
    }
    free(msg.links);
    free(msg.allowed_a);
    free(msg.allowed_b);
    free(msg.poses);
    free(tris);
    *out = rc == TRIOCT_OK ? p : NULL;
    return rc;
}

static void keep_states(trioct_client *c, trioct_state_result *res, void *user)
{
    (void)c;
    *(trioct_state_result *)user = *res;
    memset(res, 0, sizeof *res);
}

int trioct_states(trioct_client *c, const trioct_state_query *q, int timeout_ms, trioct_state_result *out)
{
    memset(out, 0, sizeof *out);
    pending *p;
    int rc = start_states(c, q, timeout_ms, &out->reply, &p);
    if (rc != TRIOCT_OK)
        return rc;
    client_sync_finish(c, p, (void (*)(void))keep_states, out);
    return out->reply.status;
}

int trioct_states_async(trioct_client *c, const trioct_state_query *q, int timeout_ms, trioct_state_done cb,
                        void *user, int64_t *request_id)
{
    trioct_reply r;
    memset(&r, 0, sizeof r);
    pending *p = NULL;
    int rc = client_async_check(c, cb != NULL, &r);
    if (rc == TRIOCT_OK)
        rc = start_states(c, q, timeout_ms, &r, &p);
    return client_async_started(c, rc, &r, p, (void (*)(void))cb, user, request_id);
}

/* Keeps .reply: the status and message stay readable after the arrays are gone. */
void trioct_state_result_free(trioct_state_result *res)
{
    if (res == NULL)
        return;
    free(res->valid);
    free(res->found);
    free(res->contacts);
    client_object_names_free(&res->objects);
    res->valid = NULL;
    res->found = NULL;
    res->contacts = NULL;
    res->num_states = 0;
    res->num_contacts = 0;
}
