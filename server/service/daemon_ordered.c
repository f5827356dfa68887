/* --ordered: the answers of a one-thread daemon whatever --threads, and the reload and
 * stop marks a log carries in place of signals. */

#include "daemon_internal.h"

#include <stdlib.h>

#include "admin_auth.h"
#include "log.h"


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

void daemon_ordered_hold(daemon *d, request_job *job)
{
    job->next = NULL;
    if (d->held_tail != NULL)
        d->held_tail->next = job;
    else
        d->held = job;
    d->held_tail = job;
}

void daemon_ordered_run(daemon *d)
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
            daemon_start_reload(d);
            if (d->state != TRIOCT_STATUS_T_RELOADING)
                d->reload_in_order = 0; /* done at once, or refused (and logged) */
            continue;
        }
        if (!job->alone && daemon_answers_inline(d, &job->req)) {
            /* A query among queries: answering it now is answering it side by side. */
            daemon_answer_inline(d, &job->req, job->channel, job->bytes, job->size, job->received_hr, job->heard_utime,
                          job->digest);
            d->in_flight--;
            free(job);
            continue;
        }
        int rc = daemon_queue_request(d, job);
        if (rc != 0) {
            LOG(LOG_ERROR, "could not queue a request: %s", uv_strerror(rc));
            d->in_flight--;
            daemon_reply_now(d, &job->req, job->channel, TRIOCT_ERR_NOMEM,
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
        daemon_start_polling(d);
    }
    daemon_maybe_finish(d);
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
    daemon_ordered_hold(d, mark);
    d->wakeup_over = 1;
    if (d->state == TRIOCT_STATUS_T_STOPPING) /* daemon_start_reload will refuse, as for SIGHUP */
        LOG(LOG_INFO, "%s: stopping, so the scene is not reloaded", channel);
    else
        LOG(LOG_INFO, "%s: the scene reloads at this point of the input", channel);
}

/* A log cannot carry SIGTERM either. Stopping begins at the mark's place in the input: the
 * requests held before it were in hand and are answered as usual, and daemon_on_message answers
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
    daemon_tell_systemd(d, TELL_STOPPING);
    /* No daemon_maybe_finish here, inside lcm_handle: daemon_ordered_run calls it after the read. */
}

/* SIGTERM stops once the work in hand is done, and a bus has no end to wait for. A file://
 * input stopped by its mark is read to its end first: the requests after the mark are
 * part of the replay and must get their STOPPING. */
int daemon_ordered_stop_waits(const daemon *d)
{
    return d->stop_marked && d->input_is_file && !d->eof;
}

static lcm_subscription_t *ordered_listen(daemon *d, trioct_mark_kind kind, lcm_msg_handler_t handler)
{
    /* prefix and name are checked names: this fits. */
    char ch[TRIOCT_MAX_CHANNEL_LEN + 1];
    if (trioct_mark_channel_name(ch, d->opt.prefix, kind, d->opt.name) < 0) {
        LOG(LOG_ERROR, "prefix %s and name %s make no mark channel", d->opt.prefix, d->opt.name);
        return NULL;
    }
    return daemon_subscribe_to(d, ch, handler);
}

int daemon_ordered_subscribe(daemon *d)
{
    d->sub_reload = ordered_listen(d, TRIOCT_MARK_RELOAD, on_reload_message);
    d->sub_stop = ordered_listen(d, TRIOCT_MARK_STOP, on_stop_message);
    return d->sub_reload != NULL && d->sub_stop != NULL ? 0 : -1;
}
