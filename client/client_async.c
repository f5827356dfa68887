/* Asynchronous requests: the queue of completions, deadlines that fire from pump and poll,
 * cancel, and the wait a synchronous call does for its own request. A request is done when
 * its answer is whole (LIST: the expected count) or its deadline passes; its completion then
 * runs from trioct_pump or trioct_poll, never from inside lcm_handle, so a callback may send
 * new requests, cancel others or disconnect. */
#include "client_internal.h"

#include <errno.h>
#include <inttypes.h>
#include <limits.h>
#include <poll.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

static int set_error(trioct_client *c, int rc, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

static int set_error(trioct_client *c, int rc, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(c->last_error, sizeof c->last_error, fmt, ap);
    va_end(ap);
    return rc;
}

void client_pending_ready(trioct_client *c, pending *p)
{
    if (!p->is_async || p->ready)
        return; /* a sync call watches its own request */
    p->ready = 1;
    p->next_ready = NULL;
    if (c->ready_tail == NULL)
        c->ready_head = p;
    else
        c->ready_tail->next_ready = p;
    c->ready_tail = p;
}

/* The earliest deadline of an async request still waiting; INT64_MAX when none has one. */
/* The next moment something is due: an async request's deadline, or a retry. */
static int64_t next_deadline(const trioct_client *c)
{
    int64_t next = client_next_retry(c);
    for (const pending *p = c->waiting; p != NULL; p = p->next)
        if (p->is_async && !p->done && p->deadline < next)
            next = p->deadline;
    return next;
}

/* Marks the async requests whose deadline has passed as done, earliest deadline first (then
 * the older request), so that timeouts complete in the order they were due. */
static void expire_due(trioct_client *c, int64_t now)
{
    for (;;) {
        pending *due = NULL;
        for (pending *p = c->waiting; p != NULL; p = p->next) {
            if (!p->is_async || p->done || p->deadline > now)
                continue;
            if (due == NULL || p->deadline < due->deadline ||
                (p->deadline == due->deadline && p->request_id < due->request_id))
                due = p;
        }
        if (due == NULL)
            return;
        due->done = 1;
        client_pending_ready(c, due);
    }
}

/* Runs p's completion and frees it; p must be unlinked. */
static void complete(trioct_client *c, pending *p)
{
    if (p->is_async)
        c->in_flight--;
    p->complete(c, p);
    client_pending_free(p);
}

/* Runs the queued completions in the order their requests became done. A callback's
 * trioct_disconnect stops the run; the caller then destroys the connection. */
static int dispatch_ready(trioct_client *c)
{
    int ran = 0;
    c->dispatching = 1;
    while (c->ready_head != NULL && !c->closing) {
        pending *p = c->ready_head;
        client_pending_unlink(c, p);
        complete(c, p);
        ran++;
    }
    c->dispatching = 0;
    return ran;
}

void client_close_requests(trioct_client *c)
{
    c->dispatching = 1; /* a callback here may not pump or poll a connection going away */
    /* Answers already whole (or deadlines already passed) stand, in the order they came;
     * then the rest, oldest first, as closed. A callback may cancel others: rescan. */
    for (;;) {
        pending *p = c->ready_head;
        if (p == NULL) {
            for (pending *q = c->waiting; q != NULL; q = q->next)
                if (q->is_async && (p == NULL || q->request_id < p->request_id))
                    p = q;
            if (p == NULL)
                break;
            p->closed = 1;
        }
        client_pending_unlink(c, p);
        complete(c, p);
    }
    while (c->waiting != NULL) {
        pending *p = c->waiting;
        client_pending_unlink(c, p);
        client_pending_free(p);
    }
}

/* pump and poll run completions, so a completion that called them would nest. */
static int refuse_nested(trioct_client *c, const char *call)
{
    return set_error(c, -1,
                     "%s called from inside a completion callback: callbacks run inside "
                     "trioct_pump and trioct_poll, which do not nest",
                     call);
}

int trioct_pump(trioct_client *c)
{
    if (c->dispatching)
        return refuse_nested(c, "trioct_pump");
    c->last_error[0] = '\0';
    int handled = client_drain(c, NULL, INT64_MAX);
    if (handled < 0)
        set_error(c, -1, "the LCM bus %s failed", c->url);
    client_retry_due(c, client_now_ns());
    expire_due(c, client_now_ns()); /* a failed bus still lets the timeouts fire */
    dispatch_ready(c);
    if (c->closing)
        client_destroy(c);
    return handled;
}

/* Milliseconds from now to deadline, rounded up so that a wake-up is never early. */
static int ms_until(int64_t deadline, int64_t now)
{
    if (deadline == INT64_MAX)
        return -1;
    if (deadline <= now)
        return 0;
    int64_t ms = (deadline - now + 999999) / 1000000;
    return ms > INT_MAX ? INT_MAX : (int)ms;
}

int trioct_poll(trioct_client *c, int timeout_ms)
{
    if (c->dispatching)
        return refuse_nested(c, "trioct_poll");
    c->last_error[0] = '\0';
    int64_t until = client_deadline(timeout_ms);
    int fd = lcm_get_fileno(c->lcm);
    int ran = 0, failed = 0;
    for (;;) {
        int64_t wake = next_deadline(c);
        if (until < wake)
            wake = until;
        if (client_drain(c, NULL, wake) < 0)
            failed = 1;
        int64_t now = client_now_ns();
        client_retry_due(c, now);
        expire_due(c, now);
        ran += dispatch_ready(c);
        if (ran > 0 || failed || c->closing || now >= until)
            break;
        /* Nothing in flight and no timeout: nothing could ever end the wait. */
        if (until == INT64_MAX && c->in_flight == 0)
            break;
        wake = next_deadline(c);
        if (until < wake)
            wake = until;
        struct pollfd pfd = {.fd = fd, .events = POLLIN};
        if (poll(&pfd, 1, ms_until(wake, client_now_ns())) < 0 && errno != EINTR) {
            failed = 1;
            break;
        }
    }
    if (c->closing) {
        client_destroy(c);
        return failed ? -1 : ran;
    }
    if (failed)
        return set_error(c, -1, "the LCM bus %s failed", c->url);
    return ran;
}

int trioct_next_timeout_ms(const trioct_client *c)
{
    if (c->ready_head != NULL)
        return 0; /* answers handled by a sync call or the caller's lcm_handle wait to run */
    return ms_until(next_deadline(c), client_now_ns());
}

size_t trioct_in_flight(const trioct_client *c)
{
    return c->in_flight;
}

int trioct_cancel(trioct_client *c, int64_t request_id)
{
    for (pending *p = c->waiting; p != NULL; p = p->next) {
        if (p->request_id != request_id || !p->is_async)
            continue;
        client_pending_unlink(c, p);
        c->in_flight--;
        client_pending_free(p);
        c->last_error[0] = '\0';
        return TRIOCT_OK;
    }
    return set_error(c, TRIOCT_ERR_BAD_REQUEST,
                     "no asynchronous request %" PRId64 " is in flight (completed, cancelled or "
                     "never sent)",
                     request_id);
}

const char *trioct_last_error(const trioct_client *c)
{
    return c->last_error;
}

int client_async_check(trioct_client *c, int has_callback, trioct_reply *r)
{
    if (!has_callback)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST, "no completion callback given");
    if (c->closing)
        return client_fail(r, TRIOCT_ERR_TRANSPORT, "the connection to %s is closing", c->url);
    return TRIOCT_OK;
}

int client_async_started(trioct_client *c, int rc, const trioct_reply *r, pending *p,
                         void (*cb)(void), void *user, int64_t *request_id)
{
    if (request_id != NULL)
        *request_id = rc == TRIOCT_OK ? p->request_id : 0;
    if (rc != TRIOCT_OK) {
        client_copy(c->last_error, sizeof c->last_error, r->message);
        return rc;
    }
    /* No message is handled between the send and here, so p cannot be done yet. */
    p->is_async = 1;
    p->cb = cb;
    p->user = user;
    c->in_flight++;
    c->last_error[0] = '\0';
    return TRIOCT_OK;
}

void client_sync_finish(trioct_client *c, pending *p, void (*cb)(void), void *user)
{
    p->cb = cb;
    p->user = user;
    if (client_wait_flag(c, &p->done, p->deadline) < 0 && !p->done)
        p->bus_failed = 1;
    client_pending_unlink(c, p);
    complete(c, p);
}
