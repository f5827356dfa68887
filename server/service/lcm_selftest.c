/* Publish a token on a private channel, hear it back through the event loop. */
#include "lcm_selftest.h"

#include <stdio.h>
#include <string.h>
#include <unistd.h>

static int publish_token(lcm_selftest *t)
{
    int rc = lcm_publish(t->lcm, t->channel, t->token, (unsigned)strlen(t->token));
    if (rc >= 0)
        t->published++;
    return rc;
}

static void finish(lcm_selftest *t, lcm_selftest_state state)
{
    t->state = state;
    t->elapsed_ms = uv_now(t->timer.loop) - t->started_ms;
}

/* Dropping the subscription waits for the timer: the pass is seen inside lcm_handle, and
 * unsubscribing from inside a handler is something older LCMs did not all survive. */
static void drop_subscription(lcm_selftest *t)
{
    if (t->sub != NULL)
        lcm_unsubscribe(t->lcm, t->sub);
    t->sub = NULL;
}

static void on_tick(uv_timer_t *timer)
{
    lcm_selftest *t = timer->data;
    if (t->state != LCM_SELFTEST_RUNNING) {
        drop_subscription(t);
        return;
    }
    uint64_t now = uv_now(timer->loop);
    uint64_t waited = now - t->started_ms;
    if (waited >= t->timeout_ms) {
        finish(t, LCM_SELFTEST_FAILED);
        drop_subscription(t);
        /* Nothing published at all is another failure than nothing heard back. */
        t->cb(t, t->published > 0 ? UV_ETIMEDOUT : UV_EIO);
        return;
    }
    /* A lost datagram must not fail the test: send the token again. A failed publish is
     * retried the same way; the timeout decides. */
    publish_token(t);
    uint64_t left = t->timeout_ms - waited;
    uv_timer_start(timer, on_tick, t->resend_ms < left ? t->resend_ms : left, 0);
}

static void on_token(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
    (void)channel;
    lcm_selftest *t = user;
    size_t len = strlen(t->token);
    if (t->state != LCM_SELFTEST_RUNNING || rbuf->data_size != len ||
        memcmp(rbuf->data, t->token, len) != 0)
        return; /* a late copy, or another process's token on a shared channel */
    finish(t, LCM_SELFTEST_PASSED);
    uv_timer_start(&t->timer, on_tick, 0, 0);
    t->cb(t, 0);
}

void lcm_selftest_init(lcm_selftest *t, uv_loop_t *loop)
{
    memset(t, 0, sizeof *t);
    uv_timer_init(loop, &t->timer);
    t->timer.data = t;
}

int lcm_selftest_start(lcm_selftest *t, lcm_t *lcm, const char *channel, uint64_t timeout_ms,
                       uint64_t resend_ms, lcm_selftest_cb cb)
{
    if (strlen(channel) > TRIOCT_MAX_CHANNEL_LEN || resend_ms == 0 || t->state != LCM_SELFTEST_IDLE)
        return UV_EINVAL;
    snprintf(t->channel, sizeof t->channel, "%s", channel);
    /* Unique to this process and this moment: a daemon of the same name elsewhere on the
     * bus (a misconfiguration, but one that happens) must not pass the test for us. */
    snprintf(t->token, sizeof t->token, "trioctd self-test pid %ld t %llu", (long)getpid(),
             (unsigned long long)uv_hrtime());
    t->lcm = lcm;
    t->cb = cb;
    t->published = 0;
    t->sub = lcm_subscribe(lcm, t->channel, on_token, t);
    if (t->sub == NULL)
        return UV_EIO;
    t->started_ms = uv_now(t->timer.loop);
    t->timeout_ms = timeout_ms;
    t->resend_ms = resend_ms;
    t->state = LCM_SELFTEST_RUNNING;
    if (publish_token(t) < 0) {
        drop_subscription(t);
        t->state = LCM_SELFTEST_IDLE;
        return UV_EIO;
    }
    uv_timer_start(&t->timer, on_tick, resend_ms < timeout_ms ? resend_ms : timeout_ms, 0);
    return 0;
}

lcm_selftest_state lcm_selftest_get_state(const lcm_selftest *t)
{
    return t->state;
}

uint64_t lcm_selftest_elapsed_ms(const lcm_selftest *t)
{
    if (t->state == LCM_SELFTEST_RUNNING)
        return uv_now(t->timer.loop) - t->started_ms;
    return t->state == LCM_SELFTEST_IDLE ? 0 : t->elapsed_ms;
}

void lcm_selftest_close(lcm_selftest *t)
{
    if (t->closing)
        return;
    drop_subscription(t);
    t->closing = 1;
    uv_close((uv_handle_t *)&t->timer, NULL);
}
