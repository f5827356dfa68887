/* Reads LCM on the loop thread when its descriptor is readable, a bounded number of
 * messages a wake-up, and notices the end of a file:// input. */

#include "daemon_internal.h"

#include <errno.h>
#include <poll.h>

#include "log.h"


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
        daemon_tell_systemd(d, TELL_STOPPING);
        daemon_maybe_finish(d);
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
        daemon_ordered_run(d);
    }
}

void daemon_start_polling(daemon *d)
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
