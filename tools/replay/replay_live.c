/* The live replay: the input log played by lcm-logplayer into a daemon on a udpm bus while
 * lcm-logger records the bus; the recording is then compared like the offline output.
 *
 * LCM never runs on the host network: this mode refuses to start when the network
 * namespace has an interface besides lo (run it inside tests/e2e/netns.sh), unless told
 * --host-network. On the bus, replies come in the order the daemon's workers finish and
 * travel by multicast; pairing by (client id, request id) is what makes them comparable.
 *
 * Order of play: the logger first, proven to record by a probe message it must write;
 * then the daemon, until its heartbeat says READY; then the player. The replay ends when
 * every expected reply chunk has come and the bus has stayed quiet a while (so an extra
 * reply would have shown), or when nothing more comes. */
#include <errno.h>
#include <lcm/lcm.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "replay_proc.h"
#include "replay_session.h"
#include "trioct_status_t.h"

#define PROBE_CHANNEL "TRIOCT_REPLAY_PROBE"
#define START_TIMEOUT_MS 20000 /* logger recording, daemon READY */
#define SETTLE_MS 500          /* quiet after the last expected reply: room for extras */
#define QUIET_MS 3000          /* nothing at all for this long: what is missing stays so */

typedef struct live {
    replay_session *s;
    lcm_t *lcm;
    int ready;          /* the daemon said READY */
    size_t chunks;      /* reply chunks heard */
    long last_reply_ms; /* when the last one came */
} live;

static long now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (long)t.tv_sec * 1000 + t.tv_nsec / 1000000;
}

/* Whether this network namespace has no interface but lo: /proc/net/dev lists the
 * interfaces of the reader's own namespace. */
static int private_network(char *other, size_t len)
{
    FILE *f = fopen("/proc/net/dev", "r");
    if (f == NULL) {
        snprintf(other, len, "/proc/net/dev: %s", strerror(errno));
        return 0;
    }
    char line[512];
    int n = 0, alone = 1;
    while (fgets(line, sizeof line, f) != NULL) {
        if (n++ < 2)
            continue; /* the two header lines */
        char *colon = strchr(line, ':');
        if (colon == NULL)
            continue;
        *colon = '\0';
        char *name = line + strspn(line, " ");
        if (strcmp(name, "lo") != 0) {
            snprintf(other, len, "%s", name);
            alone = 0;
            break;
        }
    }
    fclose(f);
    return alone;
}

static void on_message(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
    live *l = user;
    replay_event ev = {0, (char *)channel, rbuf->data, rbuf->data_size};
    replay_class c;
    replay_classify(&l->s->proto, &ev, &c);
    if (c.kind == KIND_REPLY) {
        l->chunks++;
        l->last_reply_ms = now_ms();
    } else if (c.kind == KIND_STATUS && wire_check(WIRE_STATUS, ev.data, ev.size, NULL) == 0) {
        trioct_status_t st;
        if (trioct_status_t_decode(ev.data, 0, (int)ev.size, &st) >= 0) {
            if (strcmp(st.daemon, l->s->proto.name) == 0 && st.state == TRIOCT_STATUS_T_READY)
                l->ready = 1;
            trioct_status_t_decode_cleanup(&st);
        }
    }
}

/* Pumps the bus for up to ms milliseconds. */
static void pump(live *l, int ms)
{
    long until = now_ms() + ms;
    for (long left = ms; left > 0; left = until - now_ms())
        if (lcm_handle_timeout(l->lcm, (int)left) < 0)
            break;
}

/* Whether the logger's file holds the probe yet (it flushes every few ms). */
static int probe_recorded(const char *path)
{
    replay_log log;
    char err[256];
    if (access(path, R_OK) != 0 || replay_log_read(path, &log, err, sizeof err) < 0)
        return 0;
    int found = 0;
    for (size_t i = 0; i < log.count && !found; i++)
        found = strcmp(log.events[i].channel, PROBE_CHANNEL) == 0;
    replay_log_free(&log);
    return found;
}

static size_t expected_chunks(const replay_book *b)
{
    size_t n = 0;
    for (size_t i = 0; i < b->reply_count; i++)
        n += (size_t)b->replies[i].chunk_count;
    return n;
}

static int stop_all(pid_t logger, pid_t daemon, pid_t player)
{
    int rc = 0;
    if (player > 0)
        replay_stop(player, SIGTERM, 2000);
    if (daemon > 0 && replay_stop(daemon, SIGTERM, 10000) != 0) {
        fprintf(stderr, "trioct-replay: the daemon did not stop cleanly on SIGTERM\n");
        rc = -1;
    }
    /* lcm-logger writes out what it holds and closes the file on SIGINT. */
    if (logger > 0)
        replay_stop(logger, SIGINT, 5000);
    return rc;
}

int replay_live_run(replay_session *s)
{
    const replay_options *o = s->opt;
    char other[256];
    if (!o->host_network && !private_network(other, sizeof other)) {
        fprintf(stderr,
                "trioct-replay: live: this network namespace has the interface %s: LCM must not run on the "
                "host's network. Run inside tests/e2e/netns.sh (or pass --host-network).\n",
                other);
        return -1;
    }
    char logger_log[REPLAY_PATH_LEN], player_log[REPLAY_PATH_LEN], err[REPLAY_PATH_LEN + 256];
    snprintf(logger_log, sizeof logger_log, "%s/logger.log", s->dir);
    snprintf(player_log, sizeof player_log, "%s/player.log", s->dir);

    live l = {s, NULL, 0, 0, 0};
    l.lcm = lcm_create(o->url);
    if (l.lcm == NULL) {
        fprintf(stderr, "trioct-replay: live: cannot use the bus %s\n", o->url);
        return -1;
    }
    lcm_subscription_t *sub = lcm_subscribe(l.lcm, ".*", on_message, &l);
    if (sub != NULL)
        lcm_subscription_set_queue_capacity(sub, 100000);
    pid_t logger = -1, daemon = -1, player = -1;
    int rc = -1;

    char url_arg[REPLAY_PATH_LEN], speed_arg[64];
    snprintf(url_arg, sizeof url_arg, "--lcm-url=%s", o->url);
    snprintf(speed_arg, sizeof speed_arg, "--speed=%s", o->speed);
    const char *logger_argv[] = {"lcm-logger", "-f", "-q", "--flush-interval=20", url_arg, s->out_path, NULL};
    if ((logger = replay_spawn(logger_argv, NULL, logger_log, err, sizeof err)) < 0) {
        fprintf(stderr, "trioct-replay: live: %s\n", err);
        goto out;
    }
    long start = now_ms();
    do {
        lcm_publish(l.lcm, PROBE_CHANNEL, "probe", 5);
        pump(&l, 50);
    } while (!probe_recorded(s->out_path) && now_ms() - start < START_TIMEOUT_MS && replay_wait(logger, 0) == -1);
    if (!probe_recorded(s->out_path)) {
        fprintf(stderr, "trioct-replay: live: lcm-logger recorded nothing within %d s; it said:\n",
                START_TIMEOUT_MS / 1000);
        replay_print_tail(logger_log, 8);
        goto out;
    }

    const char *argv[24];
    char store[20][REPLAY_PATH_LEN + 64];
    replay_session_daemon_argv(s, o->url, NULL, 0, argv, 24, store, 20);
    if ((daemon = replay_spawn(argv, s->world_dir, s->daemon_log, err, sizeof err)) < 0) {
        fprintf(stderr, "trioct-replay: live: %s\n", err);
        goto out;
    }
    start = now_ms();
    while (!l.ready && now_ms() - start < START_TIMEOUT_MS && replay_wait(daemon, 0) == -1)
        pump(&l, 100);
    if (!l.ready) {
        fprintf(stderr, "trioct-replay: live: the daemon did not say READY; its last words:\n");
        replay_print_tail(s->daemon_log, 12);
        goto out;
    }

    const char *player_argv[] = {"lcm-logplayer", speed_arg, url_arg, s->input_path, NULL};
    if ((player = replay_spawn(player_argv, NULL, player_log, err, sizeof err)) < 0) {
        fprintf(stderr, "trioct-replay: live: %s\n", err);
        goto out;
    }
    size_t want = expected_chunks(s->expected);
    long deadline = now_ms() + (long)o->timeout_s * 1000;
    int played = 0;
    l.last_reply_ms = now_ms();
    for (;;) {
        pump(&l, 50);
        long t = now_ms();
        if (!played && replay_wait(player, 0) != -1) {
            played = 1;
            player = -1;
            l.last_reply_ms = t > l.last_reply_ms ? t : l.last_reply_ms;
        }
        if (!played && t < deadline)
            continue;
        if (l.chunks >= want && t - l.last_reply_ms >= SETTLE_MS)
            break;
        if (t - l.last_reply_ms >= QUIET_MS || t >= deadline)
            break;
    }
    if (!played)
        fprintf(stderr, "trioct-replay: live: lcm-logplayer did not finish within %d s\n", o->timeout_s);
    rc = 0;
out:
    if (stop_all(logger, daemon, player) < 0) {
        replay_print_tail(s->daemon_log, 12);
        rc = -1;
    }
    if (sub != NULL)
        lcm_unsubscribe(l.lcm, sub);
    lcm_destroy(l.lcm);
    if (rc == 0)
        rc = replay_session_read_output(s);
    return rc;
}
