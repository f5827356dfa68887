#include "daemon.h"

#include <errno.h>
#include <inttypes.h>
#include <limits.h>
#include <lcm/lcm.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <time.h>
#include <uv.h>

#include "../../common/channels.h"
#include "../../common/trioct_status.h"
#include "../../common/wire_check.h"
#include "../world/registry.h"
#include "../world/world.h"
#include "dispatch.h"
#include "lcm_selftest.h"
#include "reply_cache.h"
#include "log.h"
#include "notify.h"
#include "stats.h"
#include "trioct_status_t.h"
#include "trioct_world_info_t.h"

_Static_assert(STATS_REQUEST_TYPES == REQUEST_TYPE_COUNT, "status_t.served has one slot a type");

/* The channels a held world is heard on, in this order. */
static const trioct_channel_kind world_kinds[] = {
    TRIOCT_CHANNEL_RAY,
    TRIOCT_CHANNEL_TRI,
    TRIOCT_CHANNEL_MESH,
    TRIOCT_CHANNEL_ADMIN,
    TRIOCT_CHANNEL_OBJECTS,
    TRIOCT_CHANNEL_STATE,
};
#define WORLD_KINDS (sizeof world_kinds / sizeof world_kinds[0])

/* LCM's queue in front of the daemon's, per subscription, in units of --queue-depth. */
#define DAEMON_LCM_QUEUE_FACTOR 4

/* The LCM self-test before READY=1: a lost datagram is sent again each second, and a bus
 * silent for ten seconds is broken (LCM's own udpm self-test waits as long). */
#define DAEMON_SELFTEST_TIMEOUT_MS 10000
#define DAEMON_SELFTEST_RESEND_MS 1000

typedef struct world_subs {
    char name[TRIOCT_MAX_NAME_LEN + 1];
    lcm_subscription_t *sub[WORLD_KINDS];
    int keep; /* scratch for sync_subscriptions */
} world_subs;

/* A scene world that is not held because its build failed: reported in status (version 0,
 * with the error) until it loads or leaves the scene. A world that is held and fails to
 * rebuild keeps its entry in the registry instead, with registry_set_error. */
typedef struct failed_world {
    char name[TRIOCT_MAX_NAME_LEN + 1];
    char source[TRIOCT_MAX_PATH_LEN];
    char error[256];
} failed_world;

typedef enum build_phase {
    BUILD_STARTUP,
    BUILD_RELOAD,
} build_phase;

typedef struct daemon {
    uv_loop_t loop;
    daemon_options opt;
    dispatch_ctx ctx;
    scene *scene; /* owned; ctx.scene points at it */
    reply_cache *replies; /* recent answers, for clients' retries (loop thread only) */

    lcm_t *lcm_in;
    lcm_t *lcm_out; /* lcm_in unless --publish-url differs */
    int lcm_fd;
    int input_is_file;

    uv_poll_t poll;
    uv_timer_t heartbeat;
    uv_signal_t sig_term, sig_int, sig_hup;
    int handles_ready; /* the five handles above and the two below are initialised */
    int polling;
    int closing;

    /* systemd: readiness, reload, stop and the watchdog (notify.c), and the self-test of
     * the bus that READY=1 waits for. */
    notifier nt;
    uv_timer_t watchdog;
    lcm_selftest selftest;
    int exit_code; /* 1 when the self-test failed */

    int state;          /* TRIOCT_STATUS_T_* */
    int in_flight;      /* requests taken whose reply is not yet published */
    int inline_taken;   /* requests this wake-up answered on the loop thread (see
                           "Answering on the loop thread") */
    int builds;         /* world builds of start-up or of a reload still running */
    int reload_pending; /* a SIGHUP came during start-up or a reload */

    /* --ordered (see "Ordered replay"): the requests one wake-up read, in input order. */
    struct request_job *held, *held_tail;
    int pool_running;    /* held requests handed to the pool and not yet back */
    int alone_running;   /* one of them is an admin request, which runs alone */
    int reload_in_order; /* a reload asked on <prefix>_RELOAD_<name> is under way */
    int wakeup_over;     /* a LOAD or a reload was read: read no more until it is done */
    int ordered_busy;    /* ordered_run is on the stack */
    int stop_marked;     /* stopping since a mark on <prefix>_STOP_<name> */
    int eof;
    uint64_t start_hr;

    stats st;
    char status_channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    lcm_subscription_t *sub_list;
    lcm_subscription_t *sub_load;
    lcm_subscription_t *sub_reload; /* --ordered only */
    lcm_subscription_t *sub_stop;   /* --ordered only */
    world_subs *subs;
    size_t sub_count, sub_alloc;
    failed_world *failed;
    size_t failed_count, failed_alloc;
    size_t status_worlds_left_out; /* last heartbeat's, to log a change once */

    /* The reload under way. */
    char (*unload)[TRIOCT_MAX_NAME_LEN + 1];
    size_t unload_count;
    int reload_built, reload_failed, reload_unchanged;
} daemon;

typedef struct request_job {
    uv_work_t work;
    daemon *d;
    uint64_t received_hr;
    dispatch_request req; /* what the peek found: enough to answer if the worker cannot */
    char channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    int rc;
    dispatch_reply reply;
    struct request_job *next; /* --ordered: the next one held */
    int alone;                /* --ordered: an admin request or a reload runs by itself */
    int reload;               /* --ordered: no request, the reload channel's mark */
    int64_t heard_utime;      /* the bus's receive time, or the log's time of the event */
    uint64_t digest;          /* of the bytes: the reply cache's key with the ids */
    size_t size;
    uint8_t bytes[];
} request_job;

typedef struct build_job {
    uv_work_t work;
    daemon *d;
    build_phase phase;
    world_spec spec;
    char world_dir[TRIOCT_MAX_PATH_LEN];
    world *result;
    int status;
    char err[512];
    double seconds;
} build_job;

static const char *const state_names[] = {
    [TRIOCT_STATUS_T_STARTING] = "starting",
    [TRIOCT_STATUS_T_READY] = "ready",
    [TRIOCT_STATUS_T_RELOADING] = "reloading",
    [TRIOCT_STATUS_T_STOPPING] = "stopping",
};
static const char *const type_names[REQUEST_TYPE_COUNT] = {
    [REQUEST_RAY] = "ray",
    [REQUEST_TRIANGLE] = "triangle",
    [REQUEST_MESH] = "mesh",
    [REQUEST_ADMIN] = "admin",
    [REQUEST_OBJECTS] = "objects",
    [REQUEST_STATE] = "state",
};

static void publish_status(daemon *d);
static void sync_subscriptions(daemon *d);
static void maybe_finish(daemon *d);
static void start_reload(daemon *d);

typedef enum tell_what {
    TELL_READY,
    TELL_RELOADING,
    TELL_STOPPING,
    TELL_STATUS,
} tell_what;
static void tell_systemd(daemon *d, tell_what what);
static void start_selftest(daemon *d);

/* Wall clock in microseconds since the epoch: what deadlines and status utime are in. */
static int64_t wall_utime(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (int64_t)ts.tv_sec * 1000000 + ts.tv_nsec / 1000;
}

static const char *type_name(int type)
{
    return type >= 0 && type < REQUEST_TYPE_COUNT ? type_names[type] : "unknown";
}

/* ---- Failed worlds ---------------------------------------------------------------------- */

static failed_world *failed_find(daemon *d, const char *name)
{
    for (size_t i = 0; i < d->failed_count; i++)
        if (strcmp(d->failed[i].name, name) == 0)
            return &d->failed[i];
    return NULL;
}

static void failed_remove(daemon *d, const char *name)
{
    failed_world *f = failed_find(d, name);
    if (f != NULL)
        *f = d->failed[--d->failed_count];
}

static void failed_set(daemon *d, const world_spec *spec, const char *error)
{
    failed_world *f = failed_find(d, spec->name);
    if (f == NULL) {
        if (d->failed_count == d->failed_alloc) {
            size_t want = d->failed_alloc ? d->failed_alloc * 2 : 8;
            failed_world *grown = realloc(d->failed, want * sizeof *grown);
            if (grown == NULL)
                return; /* the error is logged already; status just will not show it */
            d->failed = grown;
            d->failed_alloc = want;
        }
        f = &d->failed[d->failed_count++];
    }
    snprintf(f->name, sizeof f->name, "%s", spec->name);
    snprintf(f->source, sizeof f->source, "%s", spec->source);
    snprintf(f->error, sizeof f->error, "%s", error);
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

/* Answers a peeked request with an error without doing its work (BUSY, STOPPING, NOMEM). */
static void reply_now(daemon *d, const dispatch_request *req, const char *channel, int status,
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

/* --ordered; see "Ordered replay". */
static void ordered_hold(daemon *d, request_job *job);
static void ordered_run(daemon *d);
static int ordered_subscribe(daemon *d);
static int ordered_stop_waits(const daemon *d);
static void start_polling(daemon *d);

/* Publishes the reply dispatch_handle made (rc its return) to a request received at
 * received_hr, and counts it; where says on which thread it was answered, for the log.
 * Returns whether the reply changed the worlds held (a LOAD or an UNLOAD). */
static int deliver(daemon *d, const dispatch_request *req, const char *channel, uint64_t received_hr, int rc,
                   dispatch_reply *reply, uint64_t digest, const char *where)
{
    if (rc != 0) {
        /* The peek took these bytes, so dispatch_handle's -1 means it could not even encode
         * an error reply: out of memory. A well-formed request still gets its answer. */
        reply_now(d, req, channel, TRIOCT_ERR_NOMEM, "the daemon ran out of memory for this request");
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
 * here when its turn comes in ordered_run, where it would have gone to a worker, so every
 * answer is still the one a single thread gives.
 * Only queries come here, never a request that changes the worlds held: those re-sync the
 * subscriptions, which must not happen inside lcm_handle. --no-inline turns it off. */

static int answers_inline(daemon *d, const dispatch_request *req)
{
    return !d->opt.no_inline && req->type != REQUEST_ADMIN && dispatch_is_small(&d->ctx, req);
}

static void answer_inline(daemon *d, const dispatch_request *req, const char *channel, const void *bytes,
                          size_t size, uint64_t received_hr, int64_t heard_utime, uint64_t digest)
{
    dispatch_reply reply;
    int rc = dispatch_handle_heard(&d->ctx, channel, bytes, size, wall_utime(), heard_utime, &reply);
    (void)deliver(d, req, channel, received_hr, rc, &reply, digest, "on the loop thread");
}

static void work_request(uv_work_t *work)
{
    request_job *job = work->data;
    daemon *d = job->d;
    job->rc = dispatch_handle_heard(&d->ctx, job->channel, job->bytes, job->size, wall_utime(), job->heard_utime,
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
        sync_subscriptions(d);
    }
    free(job);
    maybe_finish(d);
    if (d->opt.ordered)
        ordered_run(d);
}

/* Every message of every subscription lands here, on the loop thread, inside lcm_handle. */
static void on_message(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
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
        reply_now(d, &req, channel, TRIOCT_ERR_STOPPING,
                  "the daemon is stopping and takes no new requests");
        return;
    }
    int in_hand = d->in_flight + d->inline_taken;
    if (in_hand >= d->opt.queue_depth) {
        char msg[128];
        snprintf(msg, sizeof msg, "the queue is full: %d requests in hand (queue_depth %d)", in_hand,
                 d->opt.queue_depth);
        reply_now(d, &req, channel, TRIOCT_ERR_BUSY, msg);
        return;
    }
    if (!d->opt.ordered && answers_inline(d, &req)) {
        d->inline_taken++;
        reply_cache_start(d->replies, req.client_id, req.request_id, digest);
        answer_inline(d, &req, channel, rbuf->data, size, received_hr, rbuf->recv_utime, digest);
        return;
    }
    request_job *job = malloc(sizeof *job + size);
    if (job == NULL) {
        reply_now(d, &req, channel, TRIOCT_ERR_NOMEM, "the daemon could not take the request");
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
        ordered_hold(d, job);
        d->in_flight++;
        return;
    }
    int rc = uv_queue_work(&d->loop, &job->work, work_request, after_request);
    if (rc != 0) {
        free(job);
        LOG(LOG_ERROR, "could not queue a request: %s", uv_strerror(rc));
        reply_now(d, &req, channel, TRIOCT_ERR_NOMEM, "the daemon could not queue the request");
        return;
    }
    d->in_flight++;
}

/* ---- Subscriptions ---------------------------------------------------------------------- */

/* LCM keeps about 30 messages a subscription between its receive thread and lcm_handle
 * and drops the rest without a word. A burst must reach the loop to be answered, if only
 * with BUSY, so LCM's queue holds several times the requests the daemon takes in hand: a
 * replay at full speed on two cores was seen to run the loop 1,500 messages behind its
 * receive thread. Bounded still, so a flood cannot take all memory. */
static int lcm_queue_capacity(int queue_depth)
{
    return queue_depth > INT_MAX / DAEMON_LCM_QUEUE_FACTOR ? INT_MAX
                                                           : queue_depth * DAEMON_LCM_QUEUE_FACTOR;
}

static lcm_subscription_t *subscribe(daemon *d, const char *channel)
{
    /* Channel names are [A-Za-z0-9_], so the regular expression LCM makes of them matches
     * exactly themselves. */
    lcm_subscription_t *sub = lcm_subscribe(d->lcm_in, channel, on_message, d);
    if (sub == NULL) {
        LOG(LOG_ERROR, "could not subscribe to %s", channel);
        return NULL;
    }
    lcm_subscription_set_queue_capacity(sub, lcm_queue_capacity(d->opt.queue_depth));
    LOG(LOG_DEBUG, "subscribed to %s", channel);
    return sub;
}

static int subscribe_fixed(daemon *d)
{
    char ch[TRIOCT_MAX_CHANNEL_LEN + 1];
    if (trioct_channel_name(ch, d->opt.prefix, TRIOCT_CHANNEL_LIST, NULL) < 0 ||
        (d->sub_list = subscribe(d, ch)) == NULL)
        return -1;
    if (trioct_channel_name(ch, d->opt.prefix, TRIOCT_CHANNEL_LOAD, d->opt.name) < 0 ||
        (d->sub_load = subscribe(d, ch)) == NULL)
        return -1;
    if (d->opt.ordered && ordered_subscribe(d) < 0)
        return -1;
    return 0;
}

static void unsubscribe_world(daemon *d, world_subs *ws)
{
    for (size_t k = 0; k < WORLD_KINDS; k++) {
        if (ws->sub[k] != NULL)
            lcm_unsubscribe(d->lcm_in, ws->sub[k]);
        ws->sub[k] = NULL;
    }
    LOG(LOG_DEBUG, "no longer listening for world '%s'", ws->name);
}

static int subscribe_world(daemon *d, world_subs *ws, const char *name)
{
    memset(ws, 0, sizeof *ws);
    snprintf(ws->name, sizeof ws->name, "%s", name);
    for (size_t k = 0; k < WORLD_KINDS; k++) {
        char ch[TRIOCT_MAX_CHANNEL_LEN + 1];
        if (trioct_channel_name(ch, d->opt.prefix, world_kinds[k], name) < 0) {
            LOG(LOG_ERROR, "world '%s' has no valid channel under prefix %s", name, d->opt.prefix);
            unsubscribe_world(d, ws);
            return -1;
        }
        if ((ws->sub[k] = subscribe(d, ch)) == NULL) {
            unsubscribe_world(d, ws);
            return -1;
        }
    }
    return 0;
}

/* Makes the per-world subscriptions those of the worlds the registry holds: a daemon hears
 * the queries of its own worlds only, so daemons sharing a bus never answer twice. Called
 * after start-up, after a reload and after a reply that loaded or unloaded a world; never
 * from inside lcm_handle. */
static void sync_subscriptions(daemon *d)
{
    registry_entry entries[TRIOCT_MAX_WORLDS];
    size_t n = registry_entries(d->ctx.worlds, entries, TRIOCT_MAX_WORLDS);
    if (n > TRIOCT_MAX_WORLDS)
        n = TRIOCT_MAX_WORLDS;

    for (size_t i = 0; i < d->sub_count; i++)
        d->subs[i].keep = 0;
    for (size_t e = 0; e < n; e++) {
        const char *name = entries[e].w->spec.name;
        failed_remove(d, name);
        size_t i = 0;
        while (i < d->sub_count && strcmp(d->subs[i].name, name) != 0)
            i++;
        if (i < d->sub_count) {
            d->subs[i].keep = 1;
            continue;
        }
        if (d->sub_count == d->sub_alloc) {
            size_t want = d->sub_alloc ? d->sub_alloc * 2 : 16;
            world_subs *grown = realloc(d->subs, want * sizeof *grown);
            if (grown == NULL) {
                LOG(LOG_ERROR, "out of memory: world '%s' gets no subscriptions", name);
                continue;
            }
            d->subs = grown;
            d->sub_alloc = want;
        }
        if (subscribe_world(d, &d->subs[d->sub_count], name) == 0) {
            d->subs[d->sub_count].keep = 1;
            d->sub_count++;
            LOG(LOG_DEBUG, "listening for world '%s'", name);
        }
    }
    for (size_t i = 0; i < d->sub_count;) {
        if (d->subs[i].keep) {
            i++;
            continue;
        }
        unsubscribe_world(d, &d->subs[i]);
        d->subs[i] = d->subs[--d->sub_count];
    }
    registry_entries_free(entries, n);
}

static void unsubscribe_all(daemon *d)
{
    for (size_t i = 0; i < d->sub_count; i++)
        unsubscribe_world(d, &d->subs[i]);
    d->sub_count = 0;
    if (d->sub_list != NULL)
        lcm_unsubscribe(d->lcm_in, d->sub_list);
    if (d->sub_load != NULL)
        lcm_unsubscribe(d->lcm_in, d->sub_load);
    if (d->sub_reload != NULL)
        lcm_unsubscribe(d->lcm_in, d->sub_reload);
    if (d->sub_stop != NULL)
        lcm_unsubscribe(d->lcm_in, d->sub_stop);
    d->sub_list = d->sub_load = d->sub_reload = d->sub_stop = NULL;
}

/* ---- The LCM pump ----------------------------------------------------------------------- */

static void input_ended(daemon *d)
{
    /* A file:// input at its end keeps its descriptor readable while lcm_handle fails:
     * stop watching it or the loop spins. */
    if (d->polling) {
        uv_poll_stop(&d->poll);
        d->polling = 0;
    }
    d->eof = 1;
    LOG(LOG_INFO, "end of the input log %s", d->opt.url);
    if (d->opt.exit_at_eof && d->state != TRIOCT_STATUS_T_STOPPING) {
        LOG(LOG_INFO, "stopping at the end of the input: finishing %d requests in hand",
            d->in_flight);
        d->state = TRIOCT_STATUS_T_STOPPING;
        tell_systemd(d, TELL_STOPPING);
        maybe_finish(d);
    }
}

static void on_lcm_readable(uv_poll_t *handle, int status, int events)
{
    (void)events;
    daemon *d = handle->data;
    if (status < 0) {
        LOG(LOG_ERROR, "watching the LCM descriptor failed: %s", uv_strerror(status));
        return;
    }
    /* lcm_handle on a descriptor with nothing queued blocks, fails, or (memq) crashes, and
     * libuv may call us when nothing is there: ask poll(2) before every single message. */
    d->inline_taken = 0;
    for (int i = 0; i < DAEMON_PUMP_BUDGET && d->polling && !d->wakeup_over; i++) {
        struct pollfd p = {.fd = d->lcm_fd, .events = POLLIN, .revents = 0};
        int r = poll(&p, 1, 0);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0 || !(p.revents & POLLIN))
            break;
        if (lcm_handle(d->lcm_in) < 0) {
            if (d->input_is_file)
                input_ended(d);
            else
                LOG(LOG_DEBUG, "lcm_handle found no message");
            break;
        }
    }
    d->inline_taken = 0; /* the wake-up is over: what it answered is no longer in hand */
    if (d->opt.ordered) {
        if (d->polling) {
            uv_poll_stop(&d->poll);
            d->polling = 0;
        }
        ordered_run(d);
    }
}

/* ---- Ordered replay (--ordered) --------------------------------------------------------- */

/* With --ordered every answer is the one a one-thread daemon gives, whatever --threads, so
 * a replayed log answers alike on every machine. The requests one wake-up reads wait in
 * d->held, in input order, and go to the pool from there: queries side by side, an admin
 * request or an object edit alone (after all read before it, before all read after it). The next wake-up
 * reads only once every one is answered. A LOAD ends its wake-up, so the messages after it
 * hear the world it brings, as a client asks only once the LOAD is answered; the requests
 * read after an UNLOAD in its wake-up were taken while the world was held, and get
 * UNKNOWN_WORLD, as from one thread. A log cannot carry a signal, so a message on
 * <prefix>_RELOAD_<name> reloads the scene at its place in the input, as SIGHUP would, and
 * ends its wake-up too; one on <prefix>_STOP_<name> begins stopping there, as SIGTERM
 * would. */

static void ordered_hold(daemon *d, request_job *job)
{
    job->next = NULL;
    if (d->held_tail != NULL)
        d->held_tail->next = job;
    else
        d->held = job;
    d->held_tail = job;
}

static void ordered_run(daemon *d)
{
    if (d->ordered_busy)
        return; /* a reload that finished at once calls back; the loop below goes on */
    d->ordered_busy = 1;
    while (d->held != NULL && !d->alone_running && !d->reload_in_order) {
        request_job *job = d->held;
        if (job->alone && d->pool_running > 0)
            break;
        d->held = job->next;
        if (d->held == NULL)
            d->held_tail = NULL;
        if (job->reload) {
            free(job);
            d->reload_in_order = 1;
            start_reload(d);
            if (d->state != TRIOCT_STATUS_T_RELOADING)
                d->reload_in_order = 0; /* done at once, or refused (and logged) */
            continue;
        }
        if (!job->alone && answers_inline(d, &job->req)) {
            /* A query among queries: answering it now is answering it side by side. */
            answer_inline(d, &job->req, job->channel, job->bytes, job->size, job->received_hr, job->heard_utime,
                          job->digest);
            d->in_flight--;
            free(job);
            continue;
        }
        int rc = uv_queue_work(&d->loop, &job->work, work_request, after_request);
        if (rc != 0) {
            LOG(LOG_ERROR, "could not queue a request: %s", uv_strerror(rc));
            d->in_flight--;
            reply_now(d, &job->req, job->channel, TRIOCT_ERR_NOMEM,
                      "the daemon could not queue the request");
            free(job);
            continue;
        }
        d->pool_running++;
        d->alone_running = job->alone;
    }
    d->ordered_busy = 0;
    if (d->held == NULL && d->pool_running == 0 && !d->reload_in_order && !d->closing) {
        d->wakeup_over = 0;
        start_polling(d);
    }
    maybe_finish(d);
}

/* A mark changes what is served (a reload) or stops the daemon: like any change over the
 * bus it must carry the admin key's code (its bytes end in an auth_t's 56). One that does
 * not is ignored, and said so. */
static int mark_authorized(daemon *d, const lcm_recv_buf_t *rbuf, const char *channel)
{
    char why[256];
    if (admin_auth_check(d->ctx.auth, channel, rbuf->data, rbuf->data_size, rbuf->recv_utime, why, sizeof why) == 0)
        return 1;
    LOG(LOG_WARN, "%s: mark ignored: %s", channel, why);
    return 0;
}

static void on_reload_message(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
    daemon *d = user;
    if (!mark_authorized(d, rbuf, channel))
        return;
    request_job *mark = calloc(1, sizeof *mark);
    if (mark == NULL) {
        LOG(LOG_ERROR, "out of memory: the reload asked on %s is not done", channel);
        return;
    }
    mark->reload = mark->alone = 1;
    ordered_hold(d, mark);
    d->wakeup_over = 1;
    if (d->state == TRIOCT_STATUS_T_STOPPING) /* start_reload will refuse, as for SIGHUP */
        LOG(LOG_INFO, "%s: stopping, so the scene is not reloaded", channel);
    else
        LOG(LOG_INFO, "%s: the scene reloads at this point of the input", channel);
}

/* A log cannot carry SIGTERM either. Stopping begins at the mark's place in the input: the
 * requests held before it were in hand and are answered as usual, and on_message answers
 * every one read after it STOPPING at once. The mark does not end its wake-up, since what
 * follows it gets the same answer whenever it is read. */
static void on_stop_message(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
    daemon *d = user;
    if (!mark_authorized(d, rbuf, channel))
        return;
    if (d->state == TRIOCT_STATUS_T_STOPPING) {
        LOG(LOG_INFO, "%s: already stopping", channel);
        return;
    }
    LOG(LOG_INFO, "%s: stopping at this point of the input; new requests get STOPPING, %d "
        "requests in hand finish first", channel, d->in_flight);
    d->stop_marked = 1;
    d->state = TRIOCT_STATUS_T_STOPPING;
    tell_systemd(d, TELL_STOPPING);
    /* No maybe_finish here, inside lcm_handle: ordered_run calls it after the read. */
}

/* SIGTERM stops once the work in hand is done, and a bus has no end to wait for. A file://
 * input stopped by its mark is read to its end first: the requests after the mark are
 * part of the replay and must get their STOPPING. */
static int ordered_stop_waits(const daemon *d)
{
    return d->stop_marked && d->input_is_file && !d->eof;
}

static lcm_subscription_t *ordered_listen(daemon *d, trioct_mark_kind kind, lcm_msg_handler_t handler)
{
    /* prefix and name are checked names: this fits, and is its own regular expression. */
    char ch[TRIOCT_MAX_CHANNEL_LEN + 1];
    if (trioct_mark_channel_name(ch, d->opt.prefix, kind, d->opt.name) < 0) {
        LOG(LOG_ERROR, "prefix %s and name %s make no mark channel", d->opt.prefix, d->opt.name);
        return NULL;
    }
    lcm_subscription_t *sub = lcm_subscribe(d->lcm_in, ch, handler, d);
    if (sub == NULL) {
        LOG(LOG_ERROR, "could not subscribe to %s", ch);
        return NULL;
    }
    lcm_subscription_set_queue_capacity(sub, lcm_queue_capacity(d->opt.queue_depth));
    LOG(LOG_DEBUG, "ordered: subscribed to %s", ch);
    return sub;
}

static int ordered_subscribe(daemon *d)
{
    d->sub_reload = ordered_listen(d, TRIOCT_MARK_RELOAD, on_reload_message);
    d->sub_stop = ordered_listen(d, TRIOCT_MARK_STOP, on_stop_message);
    return d->sub_reload != NULL && d->sub_stop != NULL ? 0 : -1;
}

/* ---- Worlds: start-up and reload builds ------------------------------------------------- */

static void work_build(uv_work_t *work)
{
    build_job *job = work->data;
    uint64_t t0 = uv_hrtime();
    job->status = TRIOCT_OK;
    job->result = world_build(&job->spec, job->world_dir, &job->d->ctx.env, &job->status, job->err, sizeof job->err);
    job->seconds = (double)(uv_hrtime() - t0) / 1e9;
}

static void startup_done(daemon *d);
static void reload_done(daemon *d);

static void after_build(uv_work_t *work, int status)
{
    build_job *job = work->data;
    daemon *d = job->d;
    d->builds--;
    const char *name = job->spec.name;

    if (status != 0 && job->result == NULL)
        snprintf(job->err, sizeof job->err, "the build did not run: %s", uv_strerror(status));

    if (d->state == TRIOCT_STATUS_T_STOPPING) {
        if (job->result != NULL)
            world_release(job->result);
    } else if (job->result != NULL) {
        world *w = job->result;
        /* Our own reference for the log line: once installed, an UNLOAD on a worker may
         * drop the registry's at any moment. */
        world_retain(w);
        if (registry_install(d->ctx.worlds, w) < 0) {
            char err[128];
            snprintf(err, sizeof err, "the daemon already holds %d worlds", TRIOCT_MAX_WORLDS);
            LOG(LOG_ERROR, "world '%s' was built but not installed: %s", name, err);
            world_release(w);
            failed_set(d, &job->spec, err);
            d->reload_failed++;
        } else {
            /* The registry holds w now; its version was set by the install. */
            const mesh_load_report *r = &w->report;
            LOG(LOG_INFO,
                "world '%s' version %" PRIu64 " ready: %zu triangles (%zu degenerate, %zu duplicate), "
                "bounds (%g %g %g)-(%g %g %g), built in %.3f s",
                name, w->version, r->triangles, r->degenerate, r->duplicates, r->bbox_lo.x, r->bbox_lo.y,
                r->bbox_lo.z, r->bbox_hi.x, r->bbox_hi.y, r->bbox_hi.z, job->seconds);
            failed_remove(d, name);
            d->reload_built++;
        }
        world_release(w);
    } else {
        world *old = registry_acquire(d->ctx.worlds, name);
        if (old != NULL) {
            registry_set_error(d->ctx.worlds, name, job->err);
            LOG(LOG_ERROR, "world '%s' could not be rebuilt (%s), version %" PRIu64
                " keeps serving: %s", name, trioct_status_name(job->status), old->version, job->err);
            world_release(old);
        } else {
            failed_set(d, &job->spec, job->err);
            LOG(LOG_ERROR, "world '%s' could not be loaded (%s): %s", name,
                trioct_status_name(job->status), job->err);
        }
        d->reload_failed++;
    }
    build_phase phase = job->phase;
    free(job);

    if (d->builds > 0)
        return;
    if (d->state == TRIOCT_STATUS_T_STOPPING)
        maybe_finish(d);
    else if (phase == BUILD_STARTUP)
        startup_done(d);
    else
        reload_done(d);
}

static int queue_build(daemon *d, const world_spec *spec, build_phase phase)
{
    build_job *job = calloc(1, sizeof *job);
    if (job == NULL) {
        LOG(LOG_ERROR, "out of memory: world '%s' is not built", spec->name);
        return -1;
    }
    job->work.data = job;
    job->d = d;
    job->phase = phase;
    job->spec = *spec;
    snprintf(job->world_dir, sizeof job->world_dir, "%s", d->ctx.world_dir);
    int rc = uv_queue_work(&d->loop, &job->work, work_build, after_build);
    if (rc != 0) {
        LOG(LOG_ERROR, "world '%s' is not built: %s", spec->name, uv_strerror(rc));
        free(job);
        return -1;
    }
    d->builds++;
    return 0;
}

static void start_polling(daemon *d)
{
    if (d->polling || d->eof)
        return;
    int rc = uv_poll_start(&d->poll, UV_READABLE, on_lcm_readable);
    if (rc != 0) {
        LOG(LOG_ERROR, "cannot watch the LCM descriptor: %s", uv_strerror(rc));
        return;
    }
    d->polling = 1;
}

static void startup_done(daemon *d)
{
    sync_subscriptions(d);
    d->state = TRIOCT_STATUS_T_READY;
    LOG(LOG_INFO, "ready: %zu world(s) held, %zu failed; listening on %s, publishing on %s, "
        "prefix %s, name %s, %d threads, queue depth %d", d->sub_count, d->failed_count,
        d->opt.url, d->opt.publish_url, d->opt.prefix, d->opt.name, d->opt.threads,
        d->opt.queue_depth);
    /* Only now: a replayed log must not reach a world that is still being built. */
    start_polling(d);
    start_selftest(d);
    tell_systemd(d, TELL_READY); /* at once for a file:// input, else once the bus is heard */
    publish_status(d);
    if (d->reload_pending) {
        d->reload_pending = 0;
        start_reload(d);
    }
}

/* ---- Reload ----------------------------------------------------------------------------- */

/* Whether the held world w came from the scene s (its section there), rather than from an
 * admin LOAD of a mesh path: only those leave with their section. A LOAD of a section
 * copies the section's spec, source text included. */
static int world_from_scene(const world *w, const scene *s)
{
    const world_spec *section = scene_find(s, w->spec.name);
    if (section == NULL)
        return 0;
    return strcmp(section->source, w->spec.source) == 0 || world_spec_equal(section, &w->spec);
}

/* Options a reload can change without a restart take effect; the others are kept and the
 * log says so. */
static void apply_reloaded_options(daemon *d, const daemon_options *next)
{
    daemon_options *cur = &d->opt;
    if (next->log_level != cur->log_level) {
        cur->log_level = next->log_level;
        log_set_level(next->log_level);
        LOG(LOG_INFO, "reload: log level %s", log_level_name(next->log_level));
    }
    if (next->status_interval_ms != cur->status_interval_ms) {
        cur->status_interval_ms = next->status_interval_ms;
        uv_timer_set_repeat(&d->heartbeat, (uint64_t)next->status_interval_ms);
        uv_timer_again(&d->heartbeat);
        LOG(LOG_INFO, "reload: status every %d ms", next->status_interval_ms);
    }
    if (next->queue_depth != cur->queue_depth) {
        cur->queue_depth = next->queue_depth;
        int capacity = lcm_queue_capacity(cur->queue_depth);
        if (d->sub_list != NULL)
            lcm_subscription_set_queue_capacity(d->sub_list, capacity);
        if (d->sub_load != NULL)
            lcm_subscription_set_queue_capacity(d->sub_load, capacity);
        for (size_t i = 0; i < d->sub_count; i++)
            for (size_t k = 0; k < WORLD_KINDS; k++)
                if (d->subs[i].sub[k] != NULL)
                    lcm_subscription_set_queue_capacity(d->subs[i].sub[k], capacity);
        LOG(LOG_INFO, "reload: queue depth %d", next->queue_depth);
    }
    struct {
        int changed;
        const char *key;
    } restart[] = {
        {strcmp(next->url, cur->url) != 0, "url"},
        {strcmp(next->publish_url, cur->publish_url) != 0, "publish_url"},
        {strcmp(next->prefix, cur->prefix) != 0, "prefix"},
        {strcmp(next->name, cur->name) != 0, "name"},
        {next->threads != cur->threads, "threads"},
        {strcmp(next->world_dir, cur->world_dir) != 0, "world_dir"},
    };
    for (size_t i = 0; i < sizeof restart / sizeof restart[0]; i++)
        if (restart[i].changed)
            LOG(LOG_WARN, "reload: the scene changes %s, which takes effect at the next start",
                restart[i].key);
}

static void start_reload(daemon *d)
{
    if (d->state == TRIOCT_STATUS_T_STOPPING)
        return;
    if (d->state != TRIOCT_STATUS_T_READY) {
        d->reload_pending = 1;
        LOG(LOG_INFO, "SIGHUP while %s: the reload follows", state_names[d->state]);
        return;
    }

    char err[1024];
    scene *next = calloc(1, sizeof *next);
    if (next == NULL) {
        LOG(LOG_ERROR, "reload: out of memory; the running scene stays");
        return;
    }
    if (scene_load(d->opt.scene_path, next, err, sizeof err) < 0) {
        LOG(LOG_ERROR, "reload: %s; the running scene stays", err);
        free(next);
        return;
    }
    daemon_options opt = d->opt;
    if (options_apply_scene(&opt, next, err, sizeof err) < 0) {
        LOG(LOG_ERROR, "reload: %s; the running scene stays", err);
        scene_free(next);
        free(next);
        return;
    }
    d->state = TRIOCT_STATUS_T_RELOADING;
    tell_systemd(d, TELL_RELOADING);
    LOG(LOG_INFO, "reloading %s", d->opt.scene_path);
    apply_reloaded_options(d, &opt);
    d->reload_built = d->reload_failed = d->reload_unchanged = 0;

    /* Scene worlds whose section is gone leave at the end of the reload. */
    registry_entry entries[TRIOCT_MAX_WORLDS];
    size_t n = registry_entries(d->ctx.worlds, entries, TRIOCT_MAX_WORLDS);
    if (n > TRIOCT_MAX_WORLDS)
        n = TRIOCT_MAX_WORLDS;
    free(d->unload);
    d->unload = calloc(n ? n : 1, sizeof *d->unload);
    d->unload_count = 0;
    for (size_t i = 0; i < n && d->unload != NULL; i++) {
        const world *w = entries[i].w;
        if (scene_find(next, w->spec.name) == NULL && world_from_scene(w, d->scene))
            snprintf(d->unload[d->unload_count++], sizeof d->unload[0], "%s", w->spec.name);
    }
    registry_entries_free(entries, n);

    /* A failed world whose section left is no longer a failure of this scene. */
    for (size_t i = 0; i < d->failed_count;) {
        if (scene_find(next, d->failed[i].name) == NULL)
            d->failed[i] = d->failed[--d->failed_count];
        else
            i++;
    }

    /* New and changed sections are rebuilt while the held versions keep answering; a
     * world held but failed before (its error set) is retried only when its spec changed. */
    for (size_t i = 0; i < next->world_count; i++) {
        const world_spec *spec = &next->worlds[i];
        world *held = registry_acquire(d->ctx.worlds, spec->name);
        int same = held != NULL && world_spec_equal(&held->spec, spec);
        if (held != NULL)
            world_release(held);
        if (same)
            d->reload_unchanged++;
        else if (queue_build(d, spec, BUILD_RELOAD) < 0)
            d->reload_failed++;
    }

    /* Admin LOADs of a section read the new scene from now on. Workers copy the spec they
     * need under the lock, so once the pointer is swapped nobody reads the old scene. */
    pthread_mutex_lock(&d->ctx.scene_lock);
    scene *old = d->scene;
    d->scene = next;
    d->ctx.scene = next;
    pthread_mutex_unlock(&d->ctx.scene_lock);
    scene_free(old);
    free(old);

    if (d->builds == 0)
        reload_done(d);
}

static void reload_done(daemon *d)
{
    int unloaded = 0;
    for (size_t i = 0; i < d->unload_count; i++) {
        const char *name = d->unload[i];
        /* Still absent from the scene, which cannot change during a reload; removed by an
         * admin UNLOAD meanwhile is fine too. */
        if (scene_find(d->scene, name) == NULL && registry_remove(d->ctx.worlds, name) == 0) {
            LOG(LOG_INFO, "world '%s' unloaded: its section left the scene", name);
            unloaded++;
        }
    }
    free(d->unload);
    d->unload = NULL;
    d->unload_count = 0;

    sync_subscriptions(d);
    d->state = TRIOCT_STATUS_T_READY;
    LOG(LOG_INFO, "reload done: %d built, %d failed, %d unloaded, %d unchanged", d->reload_built,
        d->reload_failed, unloaded, d->reload_unchanged);
    tell_systemd(d, TELL_READY);
    publish_status(d);
    if (d->reload_pending) {
        d->reload_pending = 0;
        start_reload(d);
    }
    if (d->reload_in_order && d->state != TRIOCT_STATUS_T_RELOADING) {
        d->reload_in_order = 0;
        ordered_run(d);
    }
}

/* ---- Status ----------------------------------------------------------------------------- */

/* A world whose build failed and that is not held: what status can say about it. */
static void failed_info(daemon *d, const failed_world *f, trioct_world_info_t *info)
{
    static char empty[] = "";
    memset(info, 0, sizeof *info);
    info->name = (char *)f->name;
    info->daemon = d->opt.name;
    info->version = 0;
    info->source = (char *)f->source;
    info->accuracy = empty;
    info->last_error = (char *)f->error;
    info->num_shapes = 0;
    info->shapes = NULL;
}

typedef struct world_info_space {
    char *shapes[TRIOCT_MAX_SHAPES];
} world_info_space;

static void publish_status(daemon *d)
{
    latency_summary lat;
    stats_take_interval(&d->st, &lat);

    registry_entry entries[TRIOCT_MAX_WORLDS];
    size_t held = registry_entries(d->ctx.worlds, entries, TRIOCT_MAX_WORLDS);
    if (held > TRIOCT_MAX_WORLDS)
        held = TRIOCT_MAX_WORLDS;
    size_t total = held + d->failed_count;
    trioct_world_info_t *infos = calloc(total ? total : 1, sizeof *infos);
    world_info_space *space = calloc(held ? held : 1, sizeof *space);

    trioct_status_t msg;
    memset(&msg, 0, sizeof msg);
    msg.utime = wall_utime();
    msg.daemon = d->opt.name;
    msg.version = TRIOCT_VERSION;
    msg.uptime_us = (int64_t)((uv_hrtime() - d->start_hr) / 1000);
    msg.state = (int8_t)d->state;
    msg.threads = d->opt.threads;
    msg.queue_depth = d->in_flight;
    msg.queue_capacity = d->opt.queue_depth;
    msg.memory_used = (int64_t)memory_account_used(&d->ctx.memory);
    msg.memory_budget = (int64_t)d->ctx.memory.limit;
    memcpy(msg.served, d->st.served, sizeof msg.served);
    msg.malformed = d->st.malformed;
    msg.duplicates_answered = d->st.duplicates_answered;
    msg.duplicates_joined = d->st.duplicates_joined;
    msg.num_status_codes = TRIOCT_WIRE_STATUS_COUNT;
    msg.replies_by_status = d->st.replies_by_status;
    msg.latency_p50_us = lat.p50_us;
    msg.latency_p99_us = lat.p99_us;
    msg.latency_count = lat.count;
    msg.num_worlds = 0;
    msg.worlds = infos;
    if (infos != NULL && space != NULL) {
        for (size_t i = 0; i < held; i++)
            dispatch_world_info(&d->ctx, &entries[i], &infos[msg.num_worlds++], space[i].shapes);
        for (size_t i = 0; i < d->failed_count; i++)
            failed_info(d, &d->failed[i], &infos[msg.num_worlds++]);
    }

    /* One datagram or nothing: a status that LCM had to fragment could be lost whole. With
     * long sources and errors 64 worlds may not fit; the ones left out are logged. */
    int size = trioct_status_t_encoded_size(&msg);
    size_t all = (size_t)msg.num_worlds;
    while (size > TRIOCT_MAX_CHUNK_BYTES && msg.num_worlds > 0) {
        msg.num_worlds--;
        size = trioct_status_t_encoded_size(&msg);
    }
    size_t left_out = all - (size_t)msg.num_worlds;
    if (left_out != d->status_worlds_left_out) {
        if (left_out > 0)
            LOG(LOG_WARN, "status: %zu of %zu worlds left out to fit one datagram", left_out, all);
        d->status_worlds_left_out = left_out;
    }

    void *buf = malloc((size_t)size);
    if (buf != NULL && trioct_status_t_encode(buf, 0, size, &msg) == size) {
        if (lcm_publish(d->lcm_out, d->status_channel, buf, (unsigned)size) < 0)
            LOG(LOG_WARN, "could not publish the status on %s", d->status_channel);
    } else {
        LOG(LOG_ERROR, "could not encode the status message (%d bytes)", size);
    }
    free(buf);

    LOG(LOG_DEBUG, "status: %s, %zu worlds (%zu failed), queue %d/%d, served ray %" PRId64
        " triangle %" PRId64 " mesh %" PRId64 " admin %" PRId64 ", malformed %" PRId64
        ", latency p50 %" PRId64 " us p99 %" PRId64 " us over %" PRId64,
        state_names[d->state], held, d->failed_count, d->in_flight, d->opt.queue_depth,
        d->st.served[0], d->st.served[1], d->st.served[2], d->st.served[3], d->st.malformed,
        lat.p50_us, lat.p99_us, lat.count);

    free(space);
    free(infos);
    registry_entries_free(entries, held);
    tell_systemd(d, TELL_STATUS);
}

static void on_heartbeat(uv_timer_t *timer)
{
    publish_status(timer->data);
}

/* ---- Stopping --------------------------------------------------------------------------- */

static void close_handles(daemon *d)
{
    if (!d->handles_ready)
        return;
    d->polling = 0;
    uv_close((uv_handle_t *)&d->poll, NULL);
    uv_close((uv_handle_t *)&d->heartbeat, NULL);
    uv_close((uv_handle_t *)&d->sig_term, NULL);
    uv_close((uv_handle_t *)&d->sig_int, NULL);
    uv_close((uv_handle_t *)&d->sig_hup, NULL);
    uv_close((uv_handle_t *)&d->watchdog, NULL);
    lcm_selftest_close(&d->selftest);
    d->handles_ready = 0;
}

/* Stops once nothing is left in hand: every reply published, every build back. */
static void maybe_finish(daemon *d)
{
    if (d->state != TRIOCT_STATUS_T_STOPPING || d->closing || d->in_flight > 0 || d->builds > 0 ||
        ordered_stop_waits(d))
        return;
    publish_status(d);
    LOG(LOG_INFO, "stopped: served ray %" PRId64 " triangle %" PRId64 " mesh %" PRId64
        " admin %" PRId64 ", malformed %" PRId64, d->st.served[0], d->st.served[1],
        d->st.served[2], d->st.served[3], d->st.malformed);
    d->closing = 1;
    close_handles(d);
}

static void on_signal(uv_signal_t *handle, int signum)
{
    daemon *d = handle->data;
    if (signum == SIGHUP) {
        LOG(LOG_INFO, "SIGHUP: reloading the scene");
        start_reload(d);
        return;
    }
    if (d->state == TRIOCT_STATUS_T_STOPPING) {
        LOG(LOG_INFO, "%s: already stopping, %d requests and %d builds in hand",
            signum == SIGINT ? "SIGINT" : "SIGTERM", d->in_flight, d->builds);
        return;
    }
    LOG(LOG_INFO, "%s: stopping; new requests get STOPPING, %d requests in hand finish first",
        signum == SIGINT ? "SIGINT" : "SIGTERM", d->in_flight);
    d->state = TRIOCT_STATUS_T_STOPPING;
    tell_systemd(d, TELL_STOPPING);
    maybe_finish(d);
}

/* ---- systemd ----------------------------------------------------------------------------- */

/* READY=1 wants the worlds built (state READY) and the bus proven: the self-test heard its
 * token, or the input is a file:// log, which has no bus to prove. */
static int bus_proven(daemon *d)
{
    return d->input_is_file || lcm_selftest_get_state(&d->selftest) == LCM_SELFTEST_PASSED;
}

/* The line `systemctl status trioctd` shows; resent only when it changes. */
static void service_summary(daemon *d, char *out, size_t len)
{
    size_t held = registry_entries(d->ctx.worlds, NULL, 0);
    int64_t queries = d->st.served[REQUEST_RAY] + d->st.served[REQUEST_TRIANGLE] +
                      d->st.served[REQUEST_MESH];
    const char *state = state_names[d->state];
    if (d->state == TRIOCT_STATUS_T_READY && !bus_proven(d))
        state = "testing the bus";
    snprintf(out, len, "%s: %zu world%s held, %zu failed, %" PRId64 " queries served, queue %d/%d",
             state, held, held == 1 ? "" : "s", d->failed_count, queries, d->in_flight,
             d->opt.queue_depth);
}

static void tell_systemd(daemon *d, tell_what what)
{
    static const char *const names[] = {
        [TELL_READY] = "READY=1",
        [TELL_RELOADING] = "RELOADING=1",
        [TELL_STOPPING] = "STOPPING=1",
        [TELL_STATUS] = "STATUS=",
    };
    if (!notify_enabled(&d->nt) || (what == TELL_READY && (d->state != TRIOCT_STATUS_T_READY ||
                                                           !bus_proven(d))))
        return;
    char line[NOTIFY_STATUS_MAX];
    service_summary(d, line, sizeof line);
    int rc = what == TELL_READY       ? notify_ready(&d->nt, line)
             : what == TELL_RELOADING ? notify_reloading(&d->nt, line)
             : what == TELL_STOPPING  ? notify_stopping(&d->nt, line)
                                      : notify_status(&d->nt, line);
    if (rc < 0)
        LOG(LOG_WARN, "could not tell systemd %s: %s", names[what], strerror(-rc));
    else if (what != TELL_STATUS)
        LOG(LOG_DEBUG, "told systemd %s (%s)", names[what], line);
}

static void open_notify(daemon *d)
{
    const char *where = getenv("NOTIFY_SOCKET");
    int rc = notify_open(&d->nt);
    if (rc < 0) {
        LOG(LOG_WARN, "NOTIFY_SOCKET=%s cannot be used (%s): systemd will not hear from trioctd",
            where, strerror(-rc));
    } else if (notify_enabled(&d->nt)) {
        LOG(LOG_INFO, "telling systemd on %s; watchdog %s", where,
            notify_watchdog_usec(&d->nt) > 0 ? "on" : "off");
    }
}

static void on_watchdog(uv_timer_t *timer)
{
    daemon *d = timer->data;
    int rc = notify_watchdog(&d->nt);
    if (rc < 0)
        LOG(LOG_WARN, "could not tell systemd WATCHDOG=1: %s", strerror(-rc));
}

/* Pings at half the interval systemd asked for: the loop answers for itself, so a loop
 * stuck anywhere stops the pings and systemd restarts the daemon. */
static void start_watchdog(daemon *d)
{
    uint64_t usec = notify_watchdog_usec(&d->nt);
    if (usec == 0)
        return;
    uint64_t every_ms = usec / 2000 > 0 ? usec / 2000 : 1;
    uv_timer_start(&d->watchdog, on_watchdog, every_ms, every_ms);
    LOG(LOG_INFO, "watchdog: WATCHDOG=1 every %" PRIu64 " ms", every_ms);
}

static void on_selftest(lcm_selftest *t, int status)
{
    daemon *d = t->data;
    if (d->state == TRIOCT_STATUS_T_STOPPING)
        return;
    if (status == 0) {
        LOG(LOG_INFO, "LCM self-test passed in %" PRIu64 " ms: %s hears what it publishes on %s",
            lcm_selftest_elapsed_ms(t), d->opt.url, t->channel);
        tell_systemd(d, TELL_READY);
        return;
    }
    LOG(LOG_ERROR, "LCM self-test failed on %s: %s %s within %" PRIu64 " ms (is the multicast "
        "route set? does a firewall drop multicast?); stopping", d->opt.url,
        status == UV_ETIMEDOUT ? "nothing published on" : "could not publish on", t->channel,
        lcm_selftest_elapsed_ms(t));
    d->exit_code = 1;
    d->state = TRIOCT_STATUS_T_STOPPING;
    tell_systemd(d, TELL_STOPPING);
    maybe_finish(d);
}

/* READY=1 waits for proof that the daemon hears its own bus; a file:// log has none. */
static void start_selftest(daemon *d)
{
    if (d->input_is_file) {
        LOG(LOG_INFO, "LCM self-test skipped: the input is a file:// log, not a bus");
        return;
    }
    char channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    snprintf(channel, sizeof channel, "%s_SELFTEST_%s", d->opt.prefix, d->opt.name);
    int rc = lcm_selftest_start(&d->selftest, d->lcm_in, channel, DAEMON_SELFTEST_TIMEOUT_MS,
                                DAEMON_SELFTEST_RESEND_MS, on_selftest);
    if (rc < 0)
        on_selftest(&d->selftest, rc);
}

/* ---- Running ---------------------------------------------------------------------------- */

static int init_handles(daemon *d)
{
    int rc;
    if ((rc = uv_poll_init(&d->loop, &d->poll, d->lcm_fd)) != 0) {
        LOG(LOG_ERROR, "cannot watch the LCM descriptor: %s", uv_strerror(rc));
        return -1;
    }
    uv_timer_init(&d->loop, &d->heartbeat);
    uv_signal_init(&d->loop, &d->sig_term);
    uv_signal_init(&d->loop, &d->sig_int);
    uv_signal_init(&d->loop, &d->sig_hup);
    d->poll.data = d->heartbeat.data = d->sig_term.data = d->sig_int.data = d->sig_hup.data = d;
    uv_timer_init(&d->loop, &d->watchdog);
    lcm_selftest_init(&d->selftest, &d->loop);
    d->watchdog.data = d->selftest.data = d;
    d->handles_ready = 1;
    uv_signal_start(&d->sig_term, on_signal, SIGTERM);
    uv_signal_start(&d->sig_int, on_signal, SIGINT);
    uv_signal_start(&d->sig_hup, on_signal, SIGHUP);
    uint64_t every = (uint64_t)d->opt.status_interval_ms;
    uv_timer_start(&d->heartbeat, on_heartbeat, every, every);
    start_watchdog(d);
    return 0;
}

static void destroy(daemon *d)
{
    notify_close(&d->nt);
    unsubscribe_all(d);
    if (d->lcm_out != NULL && d->lcm_out != d->lcm_in)
        lcm_destroy(d->lcm_out);
    if (d->lcm_in != NULL)
        lcm_destroy(d->lcm_in);
    if (d->ctx.worlds != NULL)
        registry_free(d->ctx.worlds);
    if (d->scene != NULL) {
        scene_free(d->scene);
        free(d->scene);
    }
    pthread_mutex_destroy(&d->ctx.scene_lock);
    admin_auth_free(d->ctx.auth);
    reply_cache_free(d->replies);
    stats_free(&d->st);
    while (d->held != NULL) {
        request_job *job = d->held;
        d->held = job->next;
        free(job);
    }
    free(d->subs);
    free(d->failed);
    free(d->unload);
    free(d);
}

/* Changes over the bus need the key of admin_key_file; without one they are all refused,
 * and a key file that cannot be used stops the start (a configuration error). */
static int setup_admin_auth(daemon *d)
{
    const char *path = d->opt.admin_key_file;
    trioct_admin_key key;
    char err[TRIOCT_MAX_PATH_LEN + 256];
    if (path[0] != '\0' && trioct_admin_key_load(path, &key, err, sizeof err) != 0) {
        LOG(LOG_ERROR, "%s", err);
        return -1;
    }
    d->ctx.auth = admin_auth_create(path[0] != '\0' ? &key : NULL, !d->input_is_file);
    memset(&key, 0, sizeof key);
    if (!d->ctx.auth) {
        LOG(LOG_ERROR, "out of memory for the change guard");
        return -1;
    }
    if (path[0] != '\0')
        LOG(LOG_INFO, "changes over the bus are accepted when signed with the key of %s", path);
    else
        LOG(LOG_INFO, "no admin_key_file: LOAD, UNLOAD and object edits over the bus are refused");
    return 0;
}

/* Every mesh file is parsed in the loader child, within limits drawn from the budget;
 * a daemon that cannot find its loader does not start (a configuration error, exit 2). */
static int setup_world_env(daemon *d)
{
    const daemon_options *opt = &d->opt;
    char err[TRIOCT_MAX_PATH_LEN * 2 + 128];
    mesh_loader *ld = &d->ctx.loader;
    if (opt->loader[0] != '\0') {
        if (access(opt->loader, X_OK) != 0) {
            LOG(LOG_ERROR, "the mesh loader %s is not an executable: %s", opt->loader, strerror(errno));
            return -1;
        }
        snprintf(ld->program, sizeof ld->program, "%s", opt->loader);
    } else if (mesh_loader_find(ld->program, sizeof ld->program, err, sizeof err) != 0) {
        LOG(LOG_ERROR, "%s (give --loader or loader in [daemon])", err);
        return -1;
    }
    /* What the parser may take while it reads a file: never more than the budget, never
     * less than a parser needs for the libraries and a middling mesh. */
    size_t memory = opt->memory_budget < MESH_LOADER_MAX_MEMORY ? opt->memory_budget : MESH_LOADER_MAX_MEMORY;
    ld->memory_bytes = memory < MESH_LOADER_MIN_MEMORY ? MESH_LOADER_MIN_MEMORY : memory;
    ld->cpu_seconds = MESH_LOADER_CPU_SECONDS;
    ld->wall_seconds = MESH_LOADER_WALL_SECONDS;
    memory_account_init(&d->ctx.memory, opt->memory_budget);
    if (setup_admin_auth(d) != 0)
        return -1;
    d->ctx.env.loader = ld;
    d->ctx.env.account = &d->ctx.memory;
    LOG(LOG_INFO, "memory budget %zu MiB; meshes parsed by %s (at most %zu MiB, %u s of CPU each)",
        opt->memory_budget >> 20, ld->program, ld->memory_bytes >> 20, ld->cpu_seconds);
    return 0;
}

int daemon_run(const daemon_options *opt, scene *sc)
{
    log_set_level(opt->log_level);

    /* libuv sizes its pool from the environment at the first queued work, once a process. */
    char threads[16];
    snprintf(threads, sizeof threads, "%d", opt->threads);
    setenv("UV_THREADPOOL_SIZE", threads, 1);
    /* A peer closing a socket must cost a failed write, not the daemon. */
    signal(SIGPIPE, SIG_IGN);
    /* lcm-gen's code computes each type's fingerprint on first use into an unlocked static;
     * computing them all here, before any worker exists, keeps the workers from racing. */
    for (int t = 0; t < WIRE_TYPE_COUNT; t++)
        (void)wire_fingerprint((wire_type)t);

    daemon *d = calloc(1, sizeof *d);
    scene *owned = calloc(1, sizeof *owned);
    if (d == NULL || owned == NULL) {
        LOG(LOG_ERROR, "out of memory");
        free(d);
        free(owned);
        scene_free(sc);
        memset(sc, 0, sizeof *sc);
        return 1;
    }
    *owned = *sc;
    memset(sc, 0, sizeof *sc);
    d->opt = *opt;
    d->scene = owned;
    open_notify(d); /* first: destroy() closes its socket */
    d->state = TRIOCT_STATUS_T_STARTING;
    d->start_hr = uv_hrtime();
    d->input_is_file = options_url_is_file(opt->url);
    stats_init(&d->st, 0);
    pthread_mutex_init(&d->ctx.scene_lock, NULL);
    d->ctx.scene = owned;
    snprintf(d->ctx.prefix, sizeof d->ctx.prefix, "%s", opt->prefix);
    snprintf(d->ctx.daemon, sizeof d->ctx.daemon, "%s", opt->name);
    snprintf(d->ctx.world_dir, sizeof d->ctx.world_dir, "%s", opt->world_dir);
    if (setup_world_env(d) != 0) {
        destroy(d);
        return 2;
    }
    d->ctx.worlds = registry_create();
    d->replies = reply_cache_create(REPLY_CACHE_ENTRIES, REPLY_CACHE_BYTES);
    if (d->ctx.worlds == NULL || d->replies == NULL) {
        LOG(LOG_ERROR, "out of memory");
        destroy(d);
        return 1;
    }

    LOG(LOG_INFO, "trioctd %s starting: scene %s, world directory %s", TRIOCT_VERSION,
        opt->scene_path, opt->world_dir);
    d->lcm_in = lcm_create(opt->url);
    if (d->lcm_in == NULL) {
        LOG(LOG_ERROR, "cannot open LCM on %s%s", opt->url,
            d->input_is_file ? " (a log must exist and hold at least one event)" : "");
        destroy(d);
        return 1;
    }
    if (strcmp(opt->publish_url, opt->url) == 0) {
        d->lcm_out = d->lcm_in;
    } else if ((d->lcm_out = lcm_create(opt->publish_url)) == NULL) {
        LOG(LOG_ERROR, "cannot open LCM on %s to publish", opt->publish_url);
        destroy(d);
        return 1;
    }
    d->lcm_fd = lcm_get_fileno(d->lcm_in);
    if (trioct_channel_name(d->status_channel, opt->prefix, TRIOCT_CHANNEL_STATUS, NULL) < 0 ||
        subscribe_fixed(d) < 0) {
        LOG(LOG_ERROR, "cannot subscribe with prefix %s and name %s", opt->prefix, opt->name);
        destroy(d);
        return 1;
    }

    int rc = uv_loop_init(&d->loop);
    if (rc != 0) {
        LOG(LOG_ERROR, "cannot start the event loop: %s", uv_strerror(rc));
        destroy(d);
        return 1;
    }
    if (init_handles(d) < 0) {
        uv_loop_close(&d->loop);
        destroy(d);
        return 1;
    }
    publish_status(d);

    /* Every world of the scene builds on the pool at once; the loop reads no message
     * until the last one is back (startup_done). */
    for (size_t i = 0; i < owned->world_count; i++) {
        LOG(LOG_INFO, "building world '%s' from %s", owned->worlds[i].name, owned->worlds[i].source);
        if (queue_build(d, &owned->worlds[i], BUILD_STARTUP) < 0)
            failed_set(d, &owned->worlds[i], "the build could not be queued");
    }
    if (d->builds == 0)
        startup_done(d);

    uv_run(&d->loop, UV_RUN_DEFAULT);
    /* Run again until every closed handle has had its close callback. */
    while (uv_loop_close(&d->loop) == UV_EBUSY)
        uv_run(&d->loop, UV_RUN_NOWAIT);

    int code = d->exit_code;
    destroy(d);
    return code;
}
