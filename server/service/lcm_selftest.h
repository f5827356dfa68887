/* The LCM self-test trioctd passes before it tells systemd READY=1: a daemon that cannot
 * hear its own bus must not be reported ready.
 *
 * The test subscribes to a private channel on the daemon's own LCM instance, publishes a
 * token there through the same instance and waits for the token to come back through the
 * daemon's event loop, the path every request takes (for udpm: multicast out, the
 * loopback, the receive thread, the notify pipe, the loop's poll and lcm_handle). It
 * publishes again every resend_ms, since one datagram may be lost, and gives up after
 * timeout_ms. Whoever pumps the instance's file descriptor (the daemon's on_lcm_readable)
 * drives it; the test needs nothing else from the caller.
 *
 *   lcm_selftest_init(&t, loop);                  with the other handles
 *   lcm_selftest_start(&t, lcm, "TRIOCT_SELFTEST_trioctd", 10000, 1000, on_done);
 *   ... on_done(&t, 0) once the token is heard, or on_done(&t, UV_ETIMEDOUT) ...
 *   lcm_selftest_close(&t);                       with the other handles, before lcm_destroy
 *
 * A file:// input has no bus to test (it cannot publish in read mode): the daemon skips the
 * test and says so. Loop thread only. */
#ifndef TRIOCT_SERVICE_LCM_SELFTEST_H
#define TRIOCT_SERVICE_LCM_SELFTEST_H

#include <lcm/lcm.h>
#include <stdint.h>
#include <uv.h>

#include "../../common/trioct_limits.h"

typedef struct lcm_selftest lcm_selftest;

/* status: 0 when the token came back, UV_ETIMEDOUT when it did not within the timeout, or
 * another negative libuv code when the test could not run on (publishing failed). Called
 * once, on the loop thread, possibly from inside lcm_handle. */
typedef void (*lcm_selftest_cb)(lcm_selftest *t, int status);

typedef enum lcm_selftest_state {
    LCM_SELFTEST_IDLE = 0,
    LCM_SELFTEST_RUNNING,
    LCM_SELFTEST_PASSED,
    LCM_SELFTEST_FAILED,
} lcm_selftest_state;

struct lcm_selftest {
    void *data; /* the caller's */
    uv_timer_t timer;
    lcm_t *lcm;
    lcm_subscription_t *sub;
    char channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    char token[64]; /* this process and this start: another daemon's token never passes */
    uint64_t started_ms; /* uv_now at the start */
    uint64_t timeout_ms, resend_ms;
    uint64_t elapsed_ms; /* from the start to the pass or the failure */
    int published;       /* tokens sent */
    int closing;
    lcm_selftest_state state;
    lcm_selftest_cb cb;
};

/* Initialises the timer on loop; the test is idle until started. */
void lcm_selftest_init(lcm_selftest *t, uv_loop_t *loop);

/* Subscribes to channel on lcm and publishes the first token. 0, or a negative libuv code
 * (UV_EINVAL for a channel longer than TRIOCT_MAX_CHANNEL_LEN, UV_EIO when LCM refused the
 * subscription or the first publish); cb is not called then. */
int lcm_selftest_start(lcm_selftest *t, lcm_t *lcm, const char *channel, uint64_t timeout_ms,
                       uint64_t resend_ms, lcm_selftest_cb cb);

lcm_selftest_state lcm_selftest_get_state(const lcm_selftest *t);

/* Milliseconds from the start to the pass or failure (or to now while running). */
uint64_t lcm_selftest_elapsed_ms(const lcm_selftest *t);

/* Drops the subscription and closes the timer: call before lcm_destroy and uv_loop_close.
 * A test still running ends without its callback. */
void lcm_selftest_close(lcm_selftest *t);

#endif
