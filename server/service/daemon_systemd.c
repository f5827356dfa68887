/* What systemd hears: READY=1 once the worlds are built and the bus is proven by the LCM
 * self-test, RELOADING=1, STOPPING=1, the status line and the watchdog. */

#include "daemon_internal.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../world/registry.h"
#include "log.h"

/* The LCM self-test before READY=1: a lost datagram is sent again each second, and a bus
 * silent for ten seconds is broken (LCM's own udpm self-test waits as long). */
#define DAEMON_SELFTEST_TIMEOUT_MS 10000
#define DAEMON_SELFTEST_RESEND_MS 1000


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
                      d->st.served[REQUEST_MESH] + d->st.served[REQUEST_DISTANCE];
    const char *state = daemon_state_name(d->state);
    if (d->state == TRIOCT_STATUS_T_READY && !bus_proven(d))
        state = "testing the bus";
    snprintf(out, len, "%s: %zu world%s held, %zu failed, %" PRId64 " queries served, queue %d/%d",
             state, held, held == 1 ? "" : "s", failed_worlds_list(d->ctx.failed, NULL, 0), queries, d->in_flight,
             d->opt.queue_depth);
}

void daemon_tell_systemd(daemon *d, tell_what what)
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

void daemon_open_notify(daemon *d)
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
void daemon_start_watchdog(daemon *d)
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
        daemon_tell_systemd(d, TELL_READY);
        return;
    }
    LOG(LOG_ERROR, "LCM self-test failed on %s: %s %s within %" PRIu64 " ms (is the multicast "
        "route set? does a firewall drop multicast?); stopping", d->opt.url,
        status == UV_ETIMEDOUT ? "nothing published on" : "could not publish on", t->channel,
        lcm_selftest_elapsed_ms(t));
    d->exit_code = 1;
    d->state = TRIOCT_STATUS_T_STOPPING;
    daemon_tell_systemd(d, TELL_STOPPING);
    daemon_maybe_finish(d);
}

/* READY=1 waits for proof that the daemon hears its own bus; a file:// log has none. */
void daemon_start_selftest(daemon *d)
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
