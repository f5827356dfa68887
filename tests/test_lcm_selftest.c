/* The LCM self-test READY=1 waits for (server/service/lcm_selftest.c), on a real libuv loop:
 *   memq://, pumped the way the daemon pumps: the token comes back, the test passes once,
 *       and its subscription is gone afterwards;
 *   a bus that never delivers (a file:// log opened for writing takes the publishes and
 *       gives nothing back): the token is sent again every resend interval and the test
 *       fails with UV_ETIMEDOUT at the timeout, not before;
 *   closing a test under way: no callback, nothing leaked (the sanitizer run checks);
 *   a channel too long for LCM is refused. */
#include <errno.h>
#include <poll.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>
#include <lcm/lcm.h>
#include <uv.h>

#include "service/lcm_selftest.h"

typedef struct fixture {
    uv_loop_t loop;
    uv_poll_t poll;
    int polling;
    lcm_t *lcm;
    int fd;
    lcm_selftest t;
    int calls;
    int status;
    int others; /* messages on the channel seen by a second subscriber */
} fixture;

/* As the daemon does: lcm_handle only while poll(2) says a message is there (memq's
 * lcm_handle on an empty queue crashes). */
static void on_readable(uv_poll_t *handle, int status, int events)
{
    (void)status;
    (void)events;
    fixture *f = handle->data;
    for (;;) {
        struct pollfd p = {.fd = f->fd, .events = POLLIN, .revents = 0};
        if (poll(&p, 1, 0) <= 0 || !(p.revents & POLLIN))
            return;
        if (lcm_handle(f->lcm) < 0)
            return;
    }
}

static void on_done(lcm_selftest *t, int status)
{
    fixture *f = t->data;
    f->calls++;
    f->status = status;
    /* Stop the loop: close every handle, as the daemon does when it stops. */
    if (f->polling)
        uv_close((uv_handle_t *)&f->poll, NULL);
    f->polling = 0;
}

static void on_other(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
    (void)rbuf;
    (void)channel;
    ((fixture *)user)->others++;
}

static void fixture_open(fixture *f, const char *url)
{
    memset(f, 0, sizeof *f);
    assert_int_equal(uv_loop_init(&f->loop), 0);
    f->lcm = lcm_create(url);
    assert_non_null(f->lcm);
    f->fd = lcm_get_fileno(f->lcm);
    lcm_selftest_init(&f->t, &f->loop);
    f->t.data = f;
    if (f->fd >= 0) {
        assert_int_equal(uv_poll_init(&f->loop, &f->poll, f->fd), 0);
        f->poll.data = f;
        assert_int_equal(uv_poll_start(&f->poll, UV_READABLE, on_readable), 0);
        f->polling = 1;
    }
}

static void fixture_close(fixture *f)
{
    lcm_selftest_close(&f->t);
    if (f->polling)
        uv_close((uv_handle_t *)&f->poll, NULL);
    f->polling = 0;
    uv_run(&f->loop, UV_RUN_DEFAULT);
    assert_int_equal(uv_loop_close(&f->loop), 0);
    lcm_destroy(f->lcm);
}

/* Runs the loop until the callback, at most limit_ms (a hung test must fail, not hang). */
static void run_until_done(fixture *f, uint64_t limit_ms)
{
    uint64_t start = uv_now(&f->loop);
    while (f->calls == 0 && uv_now(&f->loop) - start < limit_ms)
        uv_run(&f->loop, UV_RUN_ONCE);
}

static void test_memq_token_comes_back(void **state)
{
    (void)state;
    fixture f;
    fixture_open(&f, "memq://");
    /* Another subscriber of the channel sees the token too: the test is a real publish. */
    lcm_subscription_t *other = lcm_subscribe(f.lcm, "T_SELFTEST_d", on_other, &f);
    assert_non_null(other);
    assert_int_equal(lcm_selftest_get_state(&f.t), LCM_SELFTEST_IDLE);
    assert_int_equal(lcm_selftest_start(&f.t, f.lcm, "T_SELFTEST_d", 2000, 500, on_done), 0);
    assert_int_equal(lcm_selftest_get_state(&f.t), LCM_SELFTEST_RUNNING);
    assert_int_equal(f.calls, 0); /* only through the loop */
    run_until_done(&f, 5000);
    assert_int_equal(f.calls, 1);
    assert_int_equal(f.status, 0);
    assert_int_equal(lcm_selftest_get_state(&f.t), LCM_SELFTEST_PASSED);
    assert_int_equal(f.t.published, 1);
    assert_int_equal(f.others, 1);
    assert_true(lcm_selftest_elapsed_ms(&f.t) < 2000);
    /* A second start is refused: one test a daemon run. */
    assert_int_equal(lcm_selftest_start(&f.t, f.lcm, "T_SELFTEST_d", 2000, 500, on_done), UV_EINVAL);

    /* The subscription goes on the next turn of the loop: a later copy of the token on
     * the channel reaches only the other subscriber, and nothing is called again. */
    uv_run(&f.loop, UV_RUN_NOWAIT);
    assert_null(f.t.sub);
    assert_int_equal(lcm_publish(f.lcm, "T_SELFTEST_d", f.t.token, (unsigned)strlen(f.t.token)), 0);
    on_readable(&f.poll, 0, 0);
    assert_int_equal(f.others, 2);
    assert_int_equal(f.calls, 1);
    lcm_unsubscribe(f.lcm, other);
    fixture_close(&f);
}

static void test_silent_bus_times_out(void **state)
{
    (void)state;
    char path[] = "/tmp/trioct_selftest_XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    close(fd);
    char url[128];
    snprintf(url, sizeof url, "file://%s?mode=w", path);
    fixture f;
    fixture_open(&f, url);
    uint64_t start = uv_now(&f.loop);
    /* Published at 0, 100, 200 and 300 ms; at 350 ms it gives up. */
    assert_int_equal(lcm_selftest_start(&f.t, f.lcm, "T_SELFTEST_d", 350, 100, on_done), 0);
    run_until_done(&f, 5000);
    uv_update_time(&f.loop);
    assert_int_equal(f.calls, 1);
    assert_int_equal(f.status, UV_ETIMEDOUT);
    assert_int_equal(lcm_selftest_get_state(&f.t), LCM_SELFTEST_FAILED);
    assert_int_equal(f.t.published, 4);
    assert_true(uv_now(&f.loop) - start >= 350);
    assert_true(lcm_selftest_elapsed_ms(&f.t) >= 350);
    assert_null(f.t.sub);
    fixture_close(&f);
    unlink(path);
}

static void test_close_while_running_calls_nothing(void **state)
{
    (void)state;
    fixture f;
    fixture_open(&f, "memq://");
    assert_int_equal(lcm_selftest_start(&f.t, f.lcm, "T_SELFTEST_d", 2000, 500, on_done), 0);
    /* Closed before the loop ever ran: the token waits in memq's queue, unheard. */
    fixture_close(&f);
    assert_int_equal(f.calls, 0);
}

static void test_channel_too_long_is_refused(void **state)
{
    (void)state;
    fixture f;
    fixture_open(&f, "memq://");
    char channel[TRIOCT_MAX_CHANNEL_LEN + 2];
    memset(channel, 'C', sizeof channel - 1);
    channel[sizeof channel - 1] = '\0';
    assert_int_equal(lcm_selftest_start(&f.t, f.lcm, channel, 1000, 100, on_done), UV_EINVAL);
    assert_int_equal(lcm_selftest_get_state(&f.t), LCM_SELFTEST_IDLE);
    assert_int_equal(lcm_selftest_elapsed_ms(&f.t), 0);
    fixture_close(&f);
    assert_int_equal(f.calls, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_memq_token_comes_back),
        cmocka_unit_test(test_silent_bus_times_out),
        cmocka_unit_test(test_close_while_running_calls_nothing),
        cmocka_unit_test(test_channel_too_long_is_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
