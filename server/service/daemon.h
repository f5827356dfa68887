/* trioctd's service loop: libuv around LCM.
 *
 * One loop thread owns LCM, the subscriptions, the counters and every publish. It pumps
 * LCM when its file descriptor is readable, peeks at each request (dispatch_peek), answers
 * BUSY or STOPPING at once when it cannot take one, answers a small one itself
 * (dispatch_is_small, dispatch_handle) and hands the rest to libuv's thread pool
 * (dispatch_handle); their reply is published back on the loop thread. A timer publishes
 * the status message; SIGHUP reloads the scene, SIGTERM and SIGINT finish the work in hand
 * and stop.
 *
 * Start-up builds every world of the scene on the thread pool before the first message is
 * read, so a replayed log (file://) never reaches a world that is still being built. */
#ifndef TRIOCT_SERVICE_DAEMON_H
#define TRIOCT_SERVICE_DAEMON_H

#include "../world/scene.h"
#include "options.h"

/* Messages one wake-up of the loop reads at most before it lets the timers, the signals
 * and the finished work run: a flood of requests must not starve the replies. Replies of
 * work finished meanwhile are published only between wake-ups, so up to this many
 * requests in a row see the same queue depth; a request the loop answers itself counts
 * as in hand until the wake-up ends, so the same goes for those. */
#define DAEMON_PUMP_BUDGET 256

/* Runs the daemon until SIGTERM/SIGINT (or, with opt->exit_at_eof, the end of a file://
 * input) and returns the process exit code: 0 after a clean stop, 1 when LCM could not be
 * set up. opt must have gone through options_apply_scene with sc; daemon_run takes sc's
 * contents (sc is left empty). Sets UV_THREADPOOL_SIZE, which libuv reads once a process:
 * run it once per process. */
int daemon_run(const daemon_options *opt, scene *sc);

#endif
