/* The daemon's service loop, one concern a file (daemon.h says what the loop does):
 *
 *   daemon.c                start-up, the handles, signals, stopping, tear-down
 *   daemon_requests.c       a message in, a reply out: peek, refuse, cache, answer, count
 *   daemon_pump.c           reading LCM when its descriptor is readable
 *   daemon_subscriptions.c  the channels heard: fixed ones and each held world's
 *   daemon_ordered.c        --ordered: answers a one-thread daemon would give; marks
 *   daemon_builds.c         world builds on the pool, failed worlds, start-up's end
 *   daemon_reload.c         SIGHUP: the scene read again, worlds rebuilt and retired
 *   daemon_status.c         the status message
 *   daemon_systemd.c        READY/RELOADING/STOPPING, the watchdog, the bus self-test
 *
 * Every function here runs on the loop thread, except the work callbacks libuv runs on
 * its pool (they say so). Nothing outside server/service includes this header. */
#ifndef TRIOCT_SERVICE_DAEMON_INTERNAL_H
#define TRIOCT_SERVICE_DAEMON_INTERNAL_H

#include <lcm/lcm.h>
#include <stddef.h>
#include <stdint.h>
#include <time.h>
#include <uv.h>

#include "../../common/channels.h"
#include "../../common/trioct_status.h"
#include "../world/scene.h"
#include "../world/world.h"
#include "daemon.h"
#include "dispatch.h"
#include "failed_worlds.h"
#include "lcm_selftest.h"
#include "notify.h"
#include "options.h"
#include "reply_cache.h"
#include "stats.h"
#include "trioct_status_t.h"

/* The channels a held world is heard on (daemon_subscriptions.c lists them). */
#define DAEMON_WORLD_KINDS 7

typedef struct world_subs {
    char name[TRIOCT_MAX_NAME_LEN + 1];
    lcm_subscription_t *sub[DAEMON_WORLD_KINDS];
    int keep; /* scratch for sync_subscriptions */
} world_subs;

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
    load_table loads;     /* ctx.loads points here */

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
                           "Answering on the loop thread" in
                           daemon_requests.c) */
    int builds;         /* world builds of start-up or of a reload still running */
    /* The builds daemon_queue_builds has still to queue: indices into scene->worlds. */
    size_t *pending;
    size_t pending_count, pending_next;
    build_phase pending_phase;
    int reload_pending; /* a SIGHUP came during start-up or a reload */

    /* --ordered (daemon_ordered.c): the requests one wake-up read, in input order. */
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
} build_job;

typedef enum tell_what {
    TELL_READY,
    TELL_RELOADING,
    TELL_STOPPING,
    TELL_STATUS,
} tell_what;

/* Wall clock in microseconds since the epoch: what deadlines and status utime are in. */
static inline int64_t daemon_wall_utime(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (int64_t)ts.tv_sec * 1000000 + ts.tv_nsec / 1000;
}

/* "starting", "ready", "reloading" or "stopping". */
const char *daemon_state_name(int state);

/* daemon.c: stops once nothing is left in hand, every reply published, every build back. */
void daemon_maybe_finish(daemon *d);

/* daemon_requests.c */
void daemon_on_message(const lcm_recv_buf_t *rbuf, const char *channel, void *user);
/* Answers a peeked request with an error without doing its work (BUSY, STOPPING, NOMEM). */
void daemon_reply_now(daemon *d, const dispatch_request *req, const char *channel, int status,
                      const char *message);
/* Whether req is answered on the loop thread (see "Answering on the loop thread" in
 * daemon_requests.c). */
int daemon_answers_inline(daemon *d, const dispatch_request *req);
void daemon_answer_inline(daemon *d, const dispatch_request *req, const char *channel, const void *bytes,
                          size_t size, uint64_t received_hr, int64_t heard_utime, uint64_t digest);
/* Hands job to the pool; its reply is published when it is back. uv_queue_work's code. */
int daemon_queue_request(daemon *d, request_job *job);

/* daemon_pump.c: watches the LCM descriptor, unless it is watched or at its end. */
void daemon_start_polling(daemon *d);

/* daemon_subscriptions.c */
/* LCM's queue in front of the daemon's for one subscription. */
int daemon_lcm_queue_capacity(int queue_depth);
/* Subscribes handler to channel with the LCM queue d->opt.queue_depth asks. */
lcm_subscription_t *daemon_subscribe_to(daemon *d, const char *channel, lcm_msg_handler_t handler);
/* The list, load and (--ordered) mark channels, heard from the start. */
int daemon_subscribe_fixed(daemon *d);
/* Makes the per-world subscriptions those of the worlds the registry holds. Never from
 * inside lcm_handle. */
void daemon_sync_subscriptions(daemon *d);
/* Sets every subscription's LCM queue to what d->opt.queue_depth asks. */
void daemon_resize_lcm_queues(daemon *d);
void daemon_unsubscribe_all(daemon *d);

/* daemon_ordered.c */
void daemon_ordered_hold(daemon *d, request_job *job);
void daemon_ordered_run(daemon *d);
int daemon_ordered_subscribe(daemon *d);
/* Whether a stop by mark still waits for the end of a file:// input. */
int daemon_ordered_stop_waits(const daemon *d);

/* daemon_builds.c */
int daemon_queue_build(daemon *d, const world_spec *spec, build_phase phase);
/* Builds the scene's worlds of the indices (count of them; the call takes the array):
 * all at once, or with --ordered one after another, so that what a build sees of the
 * others (the daemon's memory in use, say) is the same on every run. Start-up or the
 * reload (phase) ends once the last is back, or at once when there is none. */
void daemon_queue_builds(daemon *d, size_t *indices, size_t count, build_phase phase);
void daemon_startup_done(daemon *d);
/* Records that the scene world spec is not held: its build failed with error. */
void daemon_failed_set(daemon *d, const world_spec *spec, const char *error);

/* daemon_reload.c */
void daemon_start_reload(daemon *d);
void daemon_reload_done(daemon *d);

/* daemon_status.c */
void daemon_publish_status(daemon *d);
void daemon_on_heartbeat(uv_timer_t *timer);

/* daemon_systemd.c */
void daemon_open_notify(daemon *d);
void daemon_tell_systemd(daemon *d, tell_what what);
void daemon_start_watchdog(daemon *d);
void daemon_start_selftest(daemon *d);

#endif
