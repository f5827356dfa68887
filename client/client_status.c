/* The daemons' heartbeat on <prefix>_STATUS: listened to only while a call waits for it, so
 * the status a caller gets is never one that sat in a queue. */
#include "client_internal.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "trioct_status_t.h"

_Static_assert(TRIOCT_DAEMON_STARTING == TRIOCT_STATUS_T_STARTING &&
                   TRIOCT_DAEMON_READY == TRIOCT_STATUS_T_READY &&
                   TRIOCT_DAEMON_RELOADING == TRIOCT_STATUS_T_RELOADING &&
                   TRIOCT_DAEMON_STOPPING == TRIOCT_STATUS_T_STOPPING,
               "trioct.h's daemon states are the wire's");

/* Heartbeats from several daemons can arrive together; the default ~30 would drop some. */
#define STATUS_QUEUE_CAPACITY 256

typedef struct status_wait {
    trioct_client *c;
    const char *daemon; /* NULL: any */
    trioct_daemon_status *out;
    int done;
} status_wait;

static int convert(trioct_daemon_status *out, const trioct_status_t *in)
{
    trioct_reply *r = &out->reply;
    client_copy(r->daemon, sizeof r->daemon, in->daemon);
    if (in->num_worlds > TRIOCT_MAX_WORLDS)
        return client_fail(r, TRIOCT_ERR_BAD_REPLY,
                           "status of %.40s lists %d worlds, over the cap of %d (TRIOCT_MAX_WORLDS)",
                           in->daemon, in->num_worlds, TRIOCT_MAX_WORLDS);
    out->utime = in->utime;
    client_copy(out->version, sizeof out->version, in->version);
    out->uptime_us = in->uptime_us;
    out->state = in->state;
    out->threads = in->threads;
    out->queue_depth = in->queue_depth;
    out->queue_capacity = in->queue_capacity;
    out->memory_used = in->memory_used;
    out->memory_budget = in->memory_budget;
    memcpy(out->served, in->served, sizeof out->served);
    out->malformed = in->malformed;
    out->duplicates_answered = in->duplicates_answered;
    out->duplicates_joined = in->duplicates_joined;
    out->latency_p50_us = in->latency_p50_us;
    out->latency_p99_us = in->latency_p99_us;
    out->latency_count = in->latency_count;
    size_t codes = (size_t)in->num_status_codes, worlds = (size_t)in->num_worlds;
    out->replies_by_status = calloc(codes ? codes : 1, sizeof *out->replies_by_status);
    out->worlds = calloc(worlds ? worlds : 1, sizeof *out->worlds);
    if (out->replies_by_status == NULL || out->worlds == NULL)
        return client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for a status message");
    if (codes > 0)
        memcpy(out->replies_by_status, in->replies_by_status, codes * sizeof(int64_t));
    out->num_status_codes = codes;
    for (size_t i = 0; i < worlds; i++)
        if (client_world_info(&out->worlds[i], &in->worlds[i], in->daemon, r) != TRIOCT_OK)
            return r->status;
    out->num_worlds = worlds;
    if (in->num_loads > TRIOCT_MAX_LOADS)
        return client_fail(r, TRIOCT_ERR_BAD_REPLY, "status of %.40s lists %d builds under way, over the cap of %d",
                           in->daemon, in->num_loads, TRIOCT_MAX_LOADS);
    size_t loads = (size_t)in->num_loads;
    out->loads = calloc(loads ? loads : 1, sizeof *out->loads);
    if (out->loads == NULL)
        return client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for a status message");
    for (size_t i = 0; i < loads; i++) {
        trioct_load_progress *p = &out->loads[i];
        const trioct_load_progress_t *q = &in->loads[i];
        client_copy(p->world, sizeof p->world, q->world);
        p->client_id = q->client_id;
        p->request_id = q->request_id;
        client_copy(p->phase, sizeof p->phase, q->phase);
        p->files_done = q->files_done;
        p->files_total = q->files_total;
        p->triangles = q->triangles;
        p->elapsed_seconds = q->elapsed_seconds;
    }
    out->num_loads = loads;
    return client_fail(r, TRIOCT_OK, "status of daemon %.40s", in->daemon);
}

static void on_status(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
    (void)channel;
    status_wait *w = user;
    if (w->done)
        return; /* a second heartbeat in the same drain */
    if (wire_check(WIRE_STATUS, rbuf->data, rbuf->data_size, NULL) != 0) {
        w->c->stats.malformed++;
        return;
    }
    trioct_status_t msg;
    memset(&msg, 0, sizeof msg);
    if (trioct_status_t_decode(rbuf->data, 0, (int)rbuf->data_size, &msg) < 0) {
        w->c->stats.malformed++; /* the checked bytes decode; this is a guard, not a path */
        return;
    }
    if (w->daemon == NULL || strcmp(msg.daemon, w->daemon) == 0) {
        convert(w->out, &msg);
        w->done = 1;
    }
    trioct_status_t_decode_cleanup(&msg);
}

int trioct_next_status(trioct_client *c, const char *daemon, int timeout_ms,
                       trioct_daemon_status *out)
{
    memset(out, 0, sizeof *out);
    trioct_reply *r = &out->reply;
    if (daemon != NULL && !trioct_name_valid(daemon, TRIOCT_MAX_NAME_LEN))
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST,
                           "invalid daemon name \"%.40s\": 1..%d characters of [A-Za-z0-9_]",
                           daemon, TRIOCT_MAX_NAME_LEN);
    char channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    if (client_channel(c, TRIOCT_CHANNEL_STATUS, NULL, channel, r, "status") != TRIOCT_OK)
        return r->status;
    status_wait w = {.c = c, .daemon = daemon, .out = out};
    int64_t deadline = client_deadline(timeout_ms);
    lcm_subscription_t *sub = lcm_subscribe(c->lcm, channel, on_status, &w);
    if (sub == NULL)
        return client_fail(r, TRIOCT_ERR_TRANSPORT, "cannot subscribe to %s on %s", channel,
                           c->url);
    lcm_subscription_set_queue_capacity(sub, STATUS_QUEUE_CAPACITY);
    int wait_rc = client_wait_flag(c, &w.done, deadline);
    lcm_unsubscribe(c->lcm, sub);
    int rc;
    if (w.done)
        rc = r->status;
    else if (wait_rc < 0)
        rc = client_fail(r, TRIOCT_ERR_TRANSPORT, "the LCM bus %s failed while waiting for status",
                         c->url);
    else if (daemon != NULL)
        rc = client_fail(r, TRIOCT_ERR_NO_DAEMON,
                         "no status from daemon %s on %s (none within %d ms)", daemon, c->url,
                         timeout_ms);
    else
        rc = client_fail(r, TRIOCT_ERR_NO_DAEMON,
                         "no status from any daemon on %s (none within %d ms)", c->url,
                         timeout_ms);
    if (rc != TRIOCT_OK)
        trioct_daemon_status_free(out); /* a failed call leaves no half result */
    return rc;
}

/* Keeps .reply: the status and message stay readable after the arrays are gone. */
void trioct_daemon_status_free(trioct_daemon_status *s)
{
    if (s == NULL)
        return;
    free(s->replies_by_status);
    free(s->worlds);
    free(s->loads);
    s->replies_by_status = NULL;
    s->worlds = NULL;
    s->loads = NULL;
    s->num_loads = 0;
    s->num_status_codes = 0;
    s->num_worlds = 0;
}
