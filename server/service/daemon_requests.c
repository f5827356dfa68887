/* A request from its message to its reply: peek, refuse what cannot be taken (BUSY,
 * STOPPING), answer a retry from the reply cache, answer small queries on the loop thread
 * and hand the rest to the pool, then publish and count the reply. */

#include "daemon_internal.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "log.h"

static const char *const type_names[REQUEST_TYPE_COUNT] = {
    [REQUEST_RAY] = "ray",
    [REQUEST_TRIANGLE] = "triangle",
    [REQUEST_MESH] = "mesh",
    [REQUEST_ADMIN] = "admin",
    [REQUEST_OBJECTS] = "objects",
    [REQUEST_STATE] = "state",
    [REQUEST_DISTANCE] = "distance",
};

static const char *type_name(int type)
{
    return type >= 0 && type < REQUEST_TYPE_COUNT ? type_names[type] : "unknown";
}

/* ---- Publishing ------------------------------------------------------------------------- */

static void publish_reply(daemon *d, const dispatch_reply *reply)
{
    for (size_t i = 0; i < reply->chunk_count; i++) {
        const dispatch_chunk *c = &reply->chunks[i];
        if (lcm_publish(d->lcm_out, reply->channel, c->data, (unsigned)c->size) < 0)
            LOG(LOG_WARN, "could not publish chunk %zu of %zu (%zu bytes) on %s", i + 1,
                reply->chunk_count, c->size, reply->channel);
    }
}

static void count_reply(daemon *d, const dispatch_reply *reply)
{
    if (stats_count_reply(&d->st, (int)reply->type, reply->status) < 0)
        LOG(LOG_WARN, "a reply with type %d and status %d fits no counter", (int)reply->type,
            reply->status);
}

void daemon_reply_now(daemon *d, const dispatch_request *req, const char *channel, int status,
                      const char *message)
{
    dispatch_reply reply;
    memset(&reply, 0, sizeof reply);
    if (dispatch_error(&d->ctx, req, status, message, &reply) != 0) {
        LOG(LOG_WARN, "could not build a %s reply to request %" PRId64 " of client %" PRId64,
            trioct_status_name(status), req->request_id, req->client_id);
        return;
    }
    publish_reply(d, &reply);
    count_reply(d, &reply);
    reply_cache_forget(d->replies, req->client_id, req->request_id); /* a retry is worked afresh */
    LOG(LOG_DEBUG, "%s request %" PRId64 " of client %" PRId64 " on %s answered %s on %s at once",
        type_name(req->type), req->request_id, req->client_id, channel, trioct_status_name(status),
        reply.channel);
    dispatch_reply_free(&reply);
}

/* ---- Requests --------------------------------------------------------------------------- */

/* Publishes the reply dispatch_handle made (rc its return) to a request received at
 * received_hr, and counts it; where says on which thread it was answered, for the log.
 * Returns whether the reply changed the worlds held (a LOAD or an UNLOAD). */
static int deliver(daemon *d, const dispatch_request *req, const char *channel, uint64_t received_hr, int rc,
                   dispatch_reply *reply, uint64_t digest, const char *where)
{
    if (rc != 0) {
        /* The peek took these bytes, so dispatch_handle's -1 means it could not even encode
         * an error reply: out of memory. A well-formed request still gets its answer. */
        daemon_reply_now(d, req, channel, TRIOCT_ERR_NOMEM, "the daemon ran out of memory for this request");
        return 0;
    }
    publish_reply(d, reply);
    int64_t us = (int64_t)((uv_hrtime() - received_hr) / 1000);
    stats_add_latency(&d->st, us);
    count_reply(d, reply);
    LOG(LOG_DEBUG, "%s request %" PRId64 " of client %" PRId64 " on %s answered %s on %s in %" PRId64
        " us (%zu chunk%s) %s", type_name(reply->type), req->request_id, req->client_id, channel,
        trioct_status_name(reply->status), reply->channel, us, reply->chunk_count,
        reply->chunk_count == 1 ? "" : "s", where);
    int changed = reply->worlds_changed;
    /* Kept for a retry of this very request; what the cache does not keep is freed. */
    reply_cache_finish(d->replies, req->client_id, req->request_id, digest, reply);
    dispatch_reply_free(reply);
    return changed;
}

/* ---- Answering on the loop thread -------------------------------------------------------
 *
 * A small request (dispatch_is_small: a few rays, a small triangle or two) is answered
 * where it was read, inside lcm_handle, and its reply published at once: the hand-off to a
 * worker and back costs two thread wake-ups, more than such a request's work. Large
 * requests, meshes and admin requests keep the workers, so the loop stays free to read,
 * refuse and publish; so a daemon computes on up to --threads workers plus the loop. A
 * wake-up reads at most DAEMON_PUMP_BUDGET messages, so the loop answers at most that many
 * before the timers and the workers' replies have their turn.
 *
 * Nothing else changes. The answer is dispatch_handle's, as on a worker, and counted and
 * timed the same way. Backpressure is the same: a request answered here counts as in hand
 * until its wake-up ends (d->inline_taken), as if it had gone to a worker, whose reply
 * would only be published after the wake-up; so the requests one wake-up reads get BUSY
 * exactly as they would without this. With --ordered a small held request is answered
 * here when its turn comes in daemon_ordered_run, where it would have gone to a worker, so every
 * answer is still the one a single thread gives.
 * Only queries come here, never a request that changes the worlds held: those re-sync the
 * subscriptions, which must not happen inside lcm_handle. --no-inline turns it off. */

int daemon_answers_inline(daemon *d, const dispatch_request *req)
{
    return !d->opt.no_inline && req->type != REQUEST_ADMIN && dispatch_is_small(&d->ctx, req);
}

void daemon_answer_inline(daemon *d, const dispatch_request *req, const char *channel, const void *bytes,
                          size_t size, uint64_t received_hr, int64_t heard_utime, uint64_t digest)
{
    dispatch_reply reply;
    int rc = dispatch_handle_heard(&d->ctx, channel, bytes, size, daemon_wall_utime(), heard_utime, &reply);
    (void)deliver(d, req, channel, received_hr, rc, &reply, digest, "on the loop thread");
}

static void work_request(uv_work_t *work)
{
    request_job *job = work->data;
    daemon *d = job->d;
    job->rc = dispatch_handle_heard(&d->ctx, job->channel, job->bytes, job->size, daemon_wall_utime(), job->heard_utime,
                                    &job->reply);
}

static void after_request(uv_work_t *work, int status)
{
    request_job *job = work->data;
    daemon *d = job->d;
    d->in_flight--;
    if (d->opt.ordered) {
        d->pool_running--;
        if (job->alone)
            d->alone_running = 0;
    }

    if (status != 0) {
        /* Only uv_cancel makes this happen, and nothing cancels requests. */
        LOG(LOG_ERROR, "a request on %s was not run: %s", job->channel, uv_strerror(status));
    } else if (deliver(d, &job->req, job->channel, job->received_hr, job->rc, &job->reply, job->digest, "on a worker") &&
               d->state != TRIOCT_STATUS_T_STOPPING) {
        daemon_sync_subscriptions(d);
    }
    free(job);
    daemon_maybe_finish(d);
    if (d->opt.ordered)
        daemon_ordered_run(d);
}

int daemon_queue_request(daemon *d, request_job *job)
{
    return uv_queue_work(&d->loop, &job->work, work_request, after_request);
}

/* Every message of every subscription lands here, on the loop thread, inside lcm_handle. */
void daemon_on_message(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
    daemon *d = user;
    uint64_t received_hr = uv_hrtime();
    size_t size = rbuf->data_size;
    size_t channel_len = strlen(channel);
    dispatch_request req;
    memset(&req, 0, sizeof req);

    /* Only our own channels are subscribed, each at most TRIOCT_MAX_CHANNEL_LEN long: a
     * longer one is not a channel of this protocol. */
    if (channel_len > TRIOCT_MAX_CHANNEL_LEN)
        return;
    /* rbuf->data lives only during this call: peek at it here, copy it for a worker. */
    switch (dispatch_peek(&d->ctx, channel, rbuf->data, size, &req)) {
    case PEEK_MALFORMED:
        stats_count_malformed(&d->st);
        LOG(LOG_DEBUG, "dropped a malformed %zu-byte message on %s", size, channel);
        return;
    case PEEK_NOT_MINE:
        return;
    case PEEK_REQUEST:
        break;
    }
    /* A retry (the same client, request id and bytes) is answered by the original. */
    uint64_t digest = reply_cache_digest(rbuf->data, size);
    const dispatch_reply *cached = NULL;
    switch (reply_cache_find(d->replies, req.client_id, req.request_id, digest, &cached)) {
    case REPLY_CACHE_DONE:
        publish_reply(d, cached);
        d->st.duplicates_answered++;
        LOG(LOG_DEBUG, "request %" PRId64 " of client %" PRId64 " on %s again: its reply sent again",
            req.request_id, req.client_id, channel);
        return;
    case REPLY_CACHE_IN_WORK:
        d->st.duplicates_joined++;
        LOG(LOG_DEBUG, "request %" PRId64 " of client %" PRId64 " on %s again while in work: the one reply answers both",
            req.request_id, req.client_id, channel);
        return;
    case REPLY_CACHE_NEW:
        break;
    }

    if (d->state == TRIOCT_STATUS_T_STOPPING) {
        daemon_reply_now(d, &req, channel, TRIOCT_ERR_STOPPING,
                  "the daemon is stopping and takes no new requests");
        return;
    }
    int in_hand = d->in_flight + d->inline_taken;
    if (in_hand >= d->opt.queue_depth) {
        char msg[128];
        snprintf(msg, sizeof msg, "the queue is full: %d requests in hand (queue_depth %d)", in_hand,
                 d->opt.queue_depth);
        daemon_reply_now(d, &req, channel, TRIOCT_ERR_BUSY, msg);
        return;
    }
    if (!d->opt.ordered && daemon_answers_inline(d, &req)) {
        d->inline_taken++;
        reply_cache_start(d->replies, req.client_id, req.request_id, digest);
        daemon_answer_inline(d, &req, channel, rbuf->data, size, received_hr, rbuf->recv_utime, digest);
        return;
    }
    request_job *job = malloc(sizeof *job + size);
    if (job == NULL) {
        daemon_reply_now(d, &req, channel, TRIOCT_ERR_NOMEM, "the daemon could not take the request");
        return;
    }
    memset(job, 0, sizeof *job);
    job->work.data = job;
    job->d = d;
    job->received_hr = received_hr;
    job->heard_utime = rbuf->recv_utime;
    job->digest = digest;
    reply_cache_start(d->replies, req.client_id, req.request_id, digest);
    job->req = req;
    memcpy(job->channel, channel, channel_len + 1);
    job->size = size;
    memcpy(job->bytes, rbuf->data, size);
    if (d->opt.ordered) {
        job->alone = req.type == REQUEST_ADMIN || req.type == REQUEST_OBJECTS; /* both change what queries see */
        if (req.channel_kind == TRIOCT_CHANNEL_LOAD)
            d->wakeup_over = 1;
        daemon_ordered_hold(d, job);
        d->in_flight++;
        return;
    }
    int rc = daemon_queue_request(d, job);
    if (rc != 0) {
        free(job);
        LOG(LOG_ERROR, "could not queue a request: %s", uv_strerror(rc));
        daemon_reply_now(d, &req, channel, TRIOCT_ERR_NOMEM, "the daemon could not queue the request");
        return;
    }
    d->in_flight++;
}
