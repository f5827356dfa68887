/* The systemd notify protocol, heard by a fake NOTIFY_SOCKET listener: an AF_UNIX datagram
 * socket bound in a scratch directory, or in the abstract namespace ('@name').
 *
 *   notify.c alone:  the exact datagrams of every call, on a path and an abstract socket;
 *                    STATUS= sent only when it changes, one line, cut at its cap; WATCHDOG_USEC
 *                    and WATCHDOG_PID; unusable addresses; no socket: every call a no-op;
 *                    a listener that does not read costs -EAGAIN, never a blocked caller;
 *   the real daemon: daemon_run in a forked child with NOTIFY_SOCKET and WATCHDOG_USEC set:
 *                    READY=1 only once every world is installed (its STATUS counts them, the
 *                    daemon's log already holds each world's build), WATCHDOG=1 at half the
 *                    interval, STATUS= following the queries served, RELOADING=1 (with
 *                    MONOTONIC_USEC=) then READY=1 around SIGHUP, STOPPING=1 on SIGTERM and
 *                    exit 0; with memq:// READY=1 waits for the LCM self-test; a WATCHDOG_PID
 *                    of another process means no pings. */
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <math.h>
#include <poll.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <cmocka.h>
#include <lcm/eventlog.h>

#include "service/daemon.h"
#include "support/daemon_proc.h"
#include "support/scratch.h"
#include "service/log.h"
#include "service/notify.h"
#include "service/options.h"
#include "trioct_ray_request_t.h"

#define PREFIX "TNFY"
#define CHILD_TIMEOUT_MS 120000
#define MSG_MAX 1024

/* ---------- clocks ---------- */

static int64_t mono_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000 + ts.tv_nsec / 1000;
}

static int64_t wall_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (int64_t)ts.tv_sec * 1000000 + ts.tv_nsec / 1000;
}

/* ---------- scratch directory ---------- */

static void scratch_setup(scratch *s)
{
    scratch_init(s, "notify");
}

/* Only the names the tests write are removed. */
static void scratch_teardown(const scratch *s)
{
    static const char *const names[] = {"notify.sock", "scene.ini", "scene.tmp", "box.obj", "grid.obj",
                                        "tri.obj", "in.log", "out.log", "daemon.log", NULL};
    scratch_remove(s, names);
}

/* ---------- the fake NOTIFY_SOCKET ---------- */

typedef struct message {
    char text[MSG_MAX];
    int64_t at_us; /* CLOCK_MONOTONIC when the listener read it */
} message;

typedef struct listener {
    int fd;
    char env[128]; /* what NOTIFY_SOCKET says: a path or '@name' */
    char path[128]; /* the file to unlink, "" for an abstract socket */
    message *msgs;
    size_t count, cap;
} listener;

/* Binds a datagram socket where NOTIFY_SOCKET will point: a path inside s, or (s NULL) an
 * abstract name unique to this process. */
static void listener_open(listener *l, const scratch *s)
{
    memset(l, 0, sizeof *l);
    l->fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    assert_true(l->fd >= 0);
    struct sockaddr_un addr;
    memset(&addr, 0, sizeof addr);
    addr.sun_family = AF_UNIX;
    socklen_t len;
    if (s != NULL) {
        scratch_path(s, "notify.sock", l->path, sizeof l->path);
        snprintf(l->env, sizeof l->env, "%s", l->path);
        size_t n = strlen(l->path);
        assert_true(n < sizeof addr.sun_path);
        memcpy(addr.sun_path, l->path, n + 1);
        len = (socklen_t)(offsetof(struct sockaddr_un, sun_path) + n + 1);
    } else {
        snprintf(l->env, sizeof l->env, "@trioct-notify-test-%ld-%" PRId64, (long)getpid(),
                 mono_us());
        size_t n = strlen(l->env);
        memcpy(addr.sun_path, l->env, n);
        addr.sun_path[0] = '\0';
        len = (socklen_t)(offsetof(struct sockaddr_un, sun_path) + n);
    }
    assert_int_equal(bind(l->fd, (struct sockaddr *)&addr, len), 0);
}

static void listener_close(listener *l)
{
    close(l->fd);
    if (l->path[0] != '\0')
        unlink(l->path);
    free(l->msgs);
    memset(l, 0, sizeof *l);
}

/* Reads one datagram within timeout_ms into the record; 1, or 0 on timeout. */
static int listener_read(listener *l, int timeout_ms)
{
    struct pollfd p = {.fd = l->fd, .events = POLLIN, .revents = 0};
    int r;
    do
        r = poll(&p, 1, timeout_ms);
    while (r < 0 && errno == EINTR);
    assert_true(r >= 0);
    if (r == 0)
        return 0;
    if (l->count == l->cap) {
        l->cap = l->cap ? l->cap * 2 : 64;
        l->msgs = realloc(l->msgs, l->cap * sizeof *l->msgs);
        assert_non_null(l->msgs);
    }
    message *m = &l->msgs[l->count];
    ssize_t n = recv(l->fd, m->text, sizeof m->text - 1, 0);
    assert_true(n >= 0);
    m->text[n] = '\0';
    m->at_us = mono_us();
    l->count++;
    return 1;
}

/* The next datagram, which must come within timeout_ms. */
static const char *listener_expect(listener *l, int timeout_ms)
{
    if (!listener_read(l, timeout_ms))
        fail_msg("no datagram within %d ms", timeout_ms);
    return l->msgs[l->count - 1].text;
}

static void listener_expect_silence(listener *l, int ms)
{
    if (listener_read(l, ms))
        fail_msg("unexpected datagram '%s'", l->msgs[l->count - 1].text);
}

/* ---------- notify.c alone ---------- */

static void clear_env(void)
{
    unsetenv("NOTIFY_SOCKET");
    unsetenv("WATCHDOG_USEC");
    unsetenv("WATCHDOG_PID");
}

static void test_no_socket_every_call_is_a_noop(void **state)
{
    (void)state;
    clear_env();
    setenv("WATCHDOG_USEC", "1000000", 1); /* no socket: no watchdog either */
    notifier n;
    assert_int_equal(notify_open(&n), 0);
    assert_false(notify_enabled(&n));
    assert_int_equal(notify_watchdog_usec(&n), 0);
    assert_int_equal(notify_ready(&n, "ready"), 0);
    assert_int_equal(notify_reloading(&n, "reloading"), 0);
    assert_int_equal(notify_stopping(&n, "stopping"), 0);
    assert_int_equal(notify_status(&n, "status"), 0);
    assert_int_equal(notify_watchdog(&n), 0);
    assert_int_equal(notify_send(&n, "X=1"), 0);
    notify_close(&n);

    setenv("NOTIFY_SOCKET", "", 1); /* empty is unset */
    assert_int_equal(notify_open(&n), 0);
    assert_false(notify_enabled(&n));
    notify_close(&n);
    clear_env();
}

/* Every call's datagram, byte for byte, on the socket l. */
static void check_exact_messages(listener *l)
{
    clear_env();
    setenv("NOTIFY_SOCKET", l->env, 1);
    notifier n;
    assert_int_equal(notify_open(&n), 0);
    assert_true(notify_enabled(&n));
    assert_int_equal(notify_watchdog_usec(&n), 0);

    assert_int_equal(notify_ready(&n, "ready: 2 worlds"), 0);
    assert_string_equal(listener_expect(l, 1000), "READY=1\nSTATUS=ready: 2 worlds");

    int64_t before = mono_us();
    assert_int_equal(notify_reloading(&n, "reloading"), 0);
    int64_t after = mono_us();
    const char *text = listener_expect(l, 1000);
    unsigned long long usec = 0;
    int consumed = 0;
    assert_int_equal(sscanf(text, "RELOADING=1\nMONOTONIC_USEC=%llu%n", &usec, &consumed), 1);
    assert_string_equal(text + consumed, "\nSTATUS=reloading");
    /* CLOCK_MONOTONIC now, as systemd reads it: between our two readings. */
    assert_true((int64_t)usec >= before && (int64_t)usec <= after);

    assert_int_equal(notify_stopping(&n, "stopping: bye"), 0);
    assert_string_equal(listener_expect(l, 1000), "STOPPING=1\nSTATUS=stopping: bye");
    assert_int_equal(notify_watchdog(&n), 0);
    assert_string_equal(listener_expect(l, 1000), "WATCHDOG=1");
    assert_int_equal(notify_send(&n, "A=1\nB=2"), 0);
    assert_string_equal(listener_expect(l, 1000), "A=1\nB=2");

    /* STATUS= alone only when it changes; the last line sent by any call counts. */
    assert_int_equal(notify_status(&n, "stopping: bye"), 0);
    listener_expect_silence(l, 50);
    assert_int_equal(notify_status(&n, "ready: 3 worlds"), 0);
    assert_string_equal(listener_expect(l, 1000), "STATUS=ready: 3 worlds");
    assert_int_equal(notify_status(&n, "ready: 3 worlds"), 0);
    listener_expect_silence(l, 50);
    /* READY=1 is sent again even with the same line: it is an event, not a state. */
    assert_int_equal(notify_ready(&n, "ready: 3 worlds"), 0);
    assert_string_equal(listener_expect(l, 1000), "READY=1\nSTATUS=ready: 3 worlds");

    /* One line: a newline would start an assignment of its own. */
    assert_int_equal(notify_status(&n, "bad\nREADY=1\r"), 0);
    assert_string_equal(listener_expect(l, 1000), "STATUS=bad READY=1 ");

    /* Cut at NOTIFY_STATUS_MAX - 1 bytes. */
    char longer[NOTIFY_STATUS_MAX + 100];
    memset(longer, 'x', sizeof longer - 1);
    longer[sizeof longer - 1] = '\0';
    assert_int_equal(notify_status(&n, longer), 0);
    text = listener_expect(l, 1000);
    assert_int_equal(strlen(text), strlen("STATUS=") + NOTIFY_STATUS_MAX - 1);
    assert_int_equal(strncmp(text, "STATUS=xxxx", 11), 0);
    notify_close(&n);
    assert_false(notify_enabled(&n));
    assert_int_equal(notify_ready(&n, "closed"), 0);
    listener_expect_silence(l, 50);
    clear_env();
}

static void test_path_socket_gets_exact_messages(void **state)
{
    (void)state;
    scratch s;
    scratch_setup(&s);
    listener l;
    listener_open(&l, &s);
    check_exact_messages(&l);
    listener_close(&l);
    scratch_teardown(&s);
}

static void test_abstract_socket_gets_exact_messages(void **state)
{
    (void)state;
    listener l;
    listener_open(&l, NULL);
    assert_int_equal(l.env[0], '@');
    check_exact_messages(&l);
    listener_close(&l);
}

static uint64_t watchdog_with(const char *usec, const char *pid)
{
    clear_env();
    setenv("NOTIFY_SOCKET", "@trioct-notify-test-unbound", 1);
    if (usec != NULL)
        setenv("WATCHDOG_USEC", usec, 1);
    if (pid != NULL)
        setenv("WATCHDOG_PID", pid, 1);
    notifier n;
    assert_int_equal(notify_open(&n), 0);
    uint64_t v = notify_watchdog_usec(&n);
    notify_close(&n);
    clear_env();
    return v;
}

static void test_watchdog_environment(void **state)
{
    (void)state;
    char self[32], other[32];
    snprintf(self, sizeof self, "%ld", (long)getpid());
    snprintf(other, sizeof other, "%ld", (long)getpid() + 1);
    assert_int_equal(watchdog_with(NULL, NULL), 0);
    assert_int_equal(watchdog_with("30000000", NULL), 30000000);
    assert_int_equal(watchdog_with("30000000", self), 30000000);
    /* Meant for another process (a parent whose environment we inherited). */
    assert_int_equal(watchdog_with("30000000", other), 0);
    assert_int_equal(watchdog_with("30000000", "x"), 0);
    assert_int_equal(watchdog_with("0", NULL), 0);
    assert_int_equal(watchdog_with("-5", NULL), 0);
    assert_int_equal(watchdog_with("12abc", NULL), 0);
    assert_int_equal(watchdog_with(" 5", NULL), 0);
    assert_int_equal(watchdog_with("99999999999999999999999", NULL), 0);
    assert_int_equal(watchdog_with("18446744073709551615", NULL), UINT64_MAX);
}

static void test_unusable_addresses(void **state)
{
    (void)state;
    const struct {
        const char *env;
        int rc;
    } cases[] = {
        {"relative/notify", -EINVAL},
        {"@", -EINVAL},
        {"/", -EINVAL},
        {"vsock:2:1234", -EAFNOSUPPORT},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        clear_env();
        setenv("NOTIFY_SOCKET", cases[i].env, 1);
        notifier n;
        assert_int_equal(notify_open(&n), cases[i].rc);
        assert_false(notify_enabled(&n));
        assert_int_equal(notify_ready(&n, "x"), 0);
        notify_close(&n);
    }
    char too_long[200];
    memset(too_long, 'a', sizeof too_long - 1);
    too_long[0] = '/';
    too_long[sizeof too_long - 1] = '\0';
    setenv("NOTIFY_SOCKET", too_long, 1);
    notifier n;
    assert_int_equal(notify_open(&n), -EINVAL);
    /* A well-formed address where nobody listens: the send says so. */
    setenv("NOTIFY_SOCKET", "/nonexistent-trioct-dir/notify", 1);
    assert_int_equal(notify_open(&n), 0);
    assert_int_equal(notify_ready(&n, "x"), -ENOENT);
    notify_close(&n);
    clear_env();
}

static void test_full_listener_never_blocks(void **state)
{
    (void)state;
    listener l;
    listener_open(&l, NULL);
    clear_env();
    setenv("NOTIFY_SOCKET", l.env, 1);
    notifier n;
    assert_int_equal(notify_open(&n), 0);
    /* Nobody reads: the queue fills (net.unix.max_dgram_qlen datagrams or the buffer) and
     * the next send is dropped with -EAGAIN at once instead of waiting. */
    int rc = 0, sent = 0;
    int64_t t0 = mono_us();
    while (sent < 100000 && (rc = notify_watchdog(&n)) == 0)
        sent++;
    assert_int_equal(rc, -EAGAIN);
    assert_true(sent > 0);
    assert_true(mono_us() - t0 < 5000000);
    /* Once the listener reads, messages flow again. */
    while (listener_read(&l, 0))
        ;
    assert_int_equal(l.count, (size_t)sent);
    assert_int_equal(notify_ready(&n, "again"), 0);
    assert_string_equal(listener_expect(&l, 1000), "READY=1\nSTATUS=again");
    notify_close(&n);
    listener_close(&l);
    clear_env();
}

/* ---------- the real daemon ---------- */

typedef struct run {
    pid_t pid;
    char log_path[256];
} run;

/* The daemon child not yet reaped: a failed assertion jumps out of its test, and the
 * teardown must not leave it serving forever. */
static pid_t live_child;

static int kill_live_child(void **state)
{
    (void)state;
    if (live_child > 0) {
        kill(live_child, SIGKILL);
        waitpid(live_child, NULL, 0);
    }
    live_child = 0;
    return 0;
}

static void print_daemon_log(const run *r)
{
    FILE *f = fopen(r->log_path, "r");
    if (f == NULL)
        return;
    char line[2048];
    fprintf(stderr, "---- daemon log ----\n");
    while (fgets(line, sizeof line, f) != NULL)
        fputs(line, stderr);
    fprintf(stderr, "--------------------\n");
    fclose(f);
}

static int count_in_file(const char *path, const char *needle)
{
    FILE *f = fopen(path, "r");
    if (f == NULL)
        return 0;
    int n = 0;
    char line[2048];
    while (fgets(line, sizeof line, f) != NULL)
        if (strstr(line, needle) != NULL)
            n++;
    fclose(f);
    return n;
}

/* The environment the child sets before daemon_run: NOTIFY_SOCKET, WATCHDOG_USEC and
 * WATCHDOG_PID ("self": the child's own pid, "parent": the test's, NULL: unset). */
typedef struct child_env {
    const char *notify_socket;
    const char *watchdog_usec;
    const char *watchdog_pid;
} child_env;

static void daemon_start(run *r, const scratch *s, const char *url, const char *publish_url,
                         const child_env *env)
{
    char scene_file[256];
    scratch_path(s, "scene.ini", scene_file, sizeof scene_file);
    scratch_path(s, "daemon.log", r->log_path, sizeof r->log_path);
    char *argv[] = {"trioctd", "--scene", scene_file, "--url", (char *)url, "--publish-url",
                    (char *)publish_url, "--status-interval", "100", "--log-level", "debug",
                    "--loader", (char *)daemon_proc_loader(), NULL};
    int argc = (int)(sizeof argv / sizeof argv[0]) - 1;

    fflush(NULL); /* the child must not write the parent's buffered output again */
    r->pid = fork();
    assert_true(r->pid >= 0);
    live_child = r->pid;
    if (r->pid == 0) {
        if (freopen(r->log_path, "w", stdout) == NULL)
            _exit(97);
        dup2(fileno(stdout), STDERR_FILENO);
        clear_env();
        setenv("NOTIFY_SOCKET", env->notify_socket, 1);
        if (env->watchdog_usec != NULL)
            setenv("WATCHDOG_USEC", env->watchdog_usec, 1);
        if (env->watchdog_pid != NULL) {
            char pid[32];
            long which = strcmp(env->watchdog_pid, "self") == 0 ? (long)getpid() : (long)getppid();
            snprintf(pid, sizeof pid, "%ld", which);
            setenv("WATCHDOG_PID", pid, 1);
        }
        log_init();
        daemon_options opt;
        scene sc;
        char err[2048];
        if (options_load(&opt, argc, argv, &sc, err, sizeof err) != OPTIONS_RUN) {
            printf("options: %s\n", err);
            fflush(stdout);
            _exit(98);
        }
        int rc = daemon_run(&opt, &sc);
        fflush(stdout);
        exit(rc); /* exit, not _exit: LeakSanitizer checks the daemon here */
    }
}

static void daemon_expect_exit(run *r, int want)
{
    for (int waited = 0; waited < CHILD_TIMEOUT_MS; waited += 10) {
        int st;
        if (waitpid(r->pid, &st, WNOHANG) == r->pid) {
            live_child = 0;
            if (WIFSIGNALED(st)) {
                print_daemon_log(r);
                fail_msg("the daemon died of signal %d", WTERMSIG(st));
            }
            if (WEXITSTATUS(st) != want) {
                print_daemon_log(r);
                fail_msg("the daemon exited with %d, expected %d", WEXITSTATUS(st), want);
            }
            return;
        }
        struct timespec ten_ms = {0, 10 * 1000 * 1000};
        nanosleep(&ten_ms, NULL);
    }
    kill(r->pid, SIGKILL);
    waitpid(r->pid, NULL, 0);
    live_child = 0;
    print_daemon_log(r);
    fail_msg("the daemon did not exit within %d ms", CHILD_TIMEOUT_MS);
}

/* Reads datagrams until one that is not a WATCHDOG=1 ping and returns it; the pings stay
 * in the record. Fails, with the daemon's log, when none comes in time. */
static const message *next_event(listener *l, run *r)
{
    int64_t deadline = mono_us() + (int64_t)CHILD_TIMEOUT_MS * 1000;
    while (mono_us() < deadline) {
        if (!listener_read(l, 100)) {
            int st;
            if (waitpid(r->pid, &st, WNOHANG) == r->pid) {
                live_child = 0;
                print_daemon_log(r);
                fail_msg("the daemon exited (status 0x%x) while a message was awaited", st);
            }
            continue;
        }
        const message *m = &l->msgs[l->count - 1];
        if (strcmp(m->text, "WATCHDOG=1") != 0)
            return m;
    }
    kill(r->pid, SIGKILL);
    waitpid(r->pid, NULL, 0);
    live_child = 0;
    print_daemon_log(r);
    fail_msg("no message from the daemon");
    return NULL;
}

static void expect_event(listener *l, run *r, const char *want)
{
    const message *m = next_event(l, r);
    if (strcmp(m->text, want) != 0) {
        print_daemon_log(r);
        fail_msg("got '%s', expected '%s'", m->text, want);
    }
}

/* Reads until a message equal to want; every message between must start with
 * allowed_prefix (or be a ping). */
static const message *expect_eventually(listener *l, run *r, const char *want,
                                        const char *allowed_prefix)
{
    for (;;) {
        const message *m = next_event(l, r);
        if (strcmp(m->text, want) == 0)
            return m;
        if (strncmp(m->text, allowed_prefix, strlen(allowed_prefix)) != 0) {
            print_daemon_log(r);
            fail_msg("got '%s' while waiting for '%s'", m->text, want);
        }
    }
}

/* Reads until the monotonic time until_us; anything but a ping fails. */
static void expect_only_pings(listener *l, run *r, int64_t until_us)
{
    int64_t now;
    while ((now = mono_us()) < until_us) {
        if (!listener_read(l, (int)((until_us - now) / 1000) + 1))
            continue;
        const char *text = l->msgs[l->count - 1].text;
        if (strcmp(text, "WATCHDOG=1") != 0) {
            print_daemon_log(r);
            fail_msg("unexpected '%s'", text);
        }
    }
}

static size_t count_pings(const listener *l, int64_t from_us, int64_t to_us)
{
    size_t n = 0;
    for (size_t i = 0; i < l->count; i++)
        if (strcmp(l->msgs[i].text, "WATCHDOG=1") == 0 && l->msgs[i].at_us >= from_us &&
            l->msgs[i].at_us < to_us)
            n++;
    return n;
}

/* A flat grid of 2 n^2 triangles: a world that takes a measurable while to build. */
static void write_grid(const scratch *s, const char *name, int n)
{
    char path[256];
    scratch_path(s, name, path, sizeof path);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    for (int j = 0; j <= n; j++)
        for (int i = 0; i <= n; i++)
            fprintf(f, "v %d %d %d\n", i, j, (i * 7 + j * 13) % 5);
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            int a = j * (n + 1) + i + 1, b = a + 1, c = a + n + 1, d = c + 1;
            fprintf(f, "f %d %d %d\nf %d %d %d\n", a, b, d, a, d, c);
        }
    assert_int_equal(fclose(f), 0);
}

static const char box_obj[] = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                              "v 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                              "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\n"
                              "f 1 2 6\nf 1 6 5\nf 4 8 7\nf 4 7 3\n"
                              "f 1 5 8\nf 1 8 4\nf 2 3 7\nf 2 7 6\n";

/* n CLOSEST rays up into the box, as the input log of a file:// daemon. */
static void write_ray_log(const scratch *s, int n)
{
    char path[256];
    scratch_path(s, "in.log", path, sizeof path);
    lcm_eventlog_t *log = lcm_eventlog_create(path, "w");
    assert_non_null(log);
    for (int i = 0; i < n; i++) {
        trioct_vec3_t o = {0.25, 0.5, -1}, d = {0, 0, 1};
        trioct_ray_request_t m;
        memset(&m, 0, sizeof m);
        m.header.client_id = 7;
        m.header.request_id = i + 1;
        m.header.reply_channel = "CLIENT_RAY";
        m.header.world = "box";
        m.detail = TRIOCT_RAY_REQUEST_T_CLOSEST;
        m.accuracy = TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD;
        m.tmax = INFINITY;
        m.max_hits = 1;
        m.num_rays = 1;
        m.origin = &o;
        m.direction = &d;
        int len = trioct_ray_request_t_encoded_size(&m);
        uint8_t *buf = malloc((size_t)len);
        assert_non_null(buf);
        assert_int_equal(trioct_ray_request_t_encode(buf, 0, len, &m), len);
        lcm_eventlog_event_t ev;
        memset(&ev, 0, sizeof ev);
        ev.timestamp = wall_us();
        ev.channel = PREFIX "_RAY_box";
        ev.channellen = (int32_t)strlen(ev.channel);
        ev.data = buf;
        ev.datalen = len;
        assert_int_equal(lcm_eventlog_write_event(log, &ev), 0);
        free(buf);
    }
    lcm_eventlog_destroy(log);
}

#define SCENE_HEAD "[daemon]\nprefix = " PREFIX "\nname = d1\n\n"

static void test_daemon_tells_systemd_every_state(void **state)
{
    (void)state;
    scratch s;
    scratch_setup(&s);
    scratch_write(&s, "box.obj", box_obj);
    scratch_write(&s, "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    write_grid(&s, "grid.obj", 200);
    scratch_write_scene(&s, SCENE_HEAD "[box]\nmesh = box.obj\n\n[grid]\nmesh = grid.obj\n");
    write_ray_log(&s, 3);
    listener l;
    listener_open(&l, &s);

    char in_url[320], out_url[320], in[256], out[256];
    scratch_path(&s, "in.log", in, sizeof in);
    scratch_path(&s, "out.log", out, sizeof out);
    snprintf(in_url, sizeof in_url, "file://%s", in);
    snprintf(out_url, sizeof out_url, "file://%s?mode=w", out);
    /* 200 ms: a ping every 100 ms. */
    child_env env = {l.env, "200000", "self"};
    run r;
    daemon_start(&r, &s, in_url, out_url, &env);

    /* Start-up: the first status says nothing is held yet, and READY=1 follows only when
     * both worlds are installed: its STATUS counts them, and by then the daemon's log holds
     * both builds. A file:// input has no bus: the self-test is skipped and said so. */
    expect_event(&l, &r, "STATUS=starting: 0 worlds held, 0 failed, 0 queries served, queue 0/1024");
    const message *ready = expect_eventually(
        &l, &r, "READY=1\nSTATUS=ready: 2 worlds held, 0 failed, 0 queries served, queue 0/1024",
        "STATUS=starting: ");
    assert_int_equal(count_in_file(r.log_path, "world 'box' version 1 ready"), 1);
    assert_int_equal(count_in_file(r.log_path, "world 'grid' version 1 ready"), 1);
    assert_int_equal(count_in_file(r.log_path, "LCM self-test skipped: the input is a file:// log"), 1);
    int64_t ready_at = ready->at_us;

    /* The three logged queries are answered, and a heartbeat's STATUS says so (one may
     * catch them half done). */
    expect_eventually(&l, &r, "STATUS=ready: 2 worlds held, 0 failed, 3 queries served, queue 0/1024",
                      "STATUS=ready: 2 worlds held, 0 failed, ");

    /* Pings at half of WATCHDOG_USEC: ten in a second (at least nine: the window may cut
     * one), never a burst. */
    expect_only_pings(&l, &r, ready_at + 1200000);
    size_t pings = count_pings(&l, ready_at, ready_at + 1000000);
    if (pings < 9 || pings > 11) {
        print_daemon_log(&r);
        fail_msg("%zu WATCHDOG=1 in the second after READY=1, expected 10", pings);
    }

    /* SIGHUP with a third world: RELOADING=1 stamped with CLOCK_MONOTONIC, then READY=1
     * once the new world is in. */
    scratch_write_scene(&s, SCENE_HEAD "[box]\nmesh = box.obj\n\n[grid]\nmesh = grid.obj\n\n"
                               "[tri]\nmesh = tri.obj\n");
    int64_t before = mono_us();
    assert_int_equal(kill(r.pid, SIGHUP), 0);
    const message *m = next_event(&l, &r);
    unsigned long long usec = 0;
    int consumed = 0;
    if (sscanf(m->text, "RELOADING=1\nMONOTONIC_USEC=%llu%n", &usec, &consumed) != 1)
        fail_msg("got '%s', expected RELOADING=1", m->text);
    assert_string_equal(m->text + consumed,
                        "\nSTATUS=reloading: 2 worlds held, 0 failed, 3 queries served, queue 0/1024");
    assert_true((int64_t)usec >= before && (int64_t)usec <= m->at_us);
    expect_event(&l, &r, "READY=1\nSTATUS=ready: 3 worlds held, 0 failed, 3 queries served, queue 0/1024");
    assert_int_equal(count_in_file(r.log_path, "world 'tri' version 1 ready"), 1);

    /* SIGTERM: STOPPING=1 at once, then a clean exit with nothing more to say. */
    assert_int_equal(kill(r.pid, SIGTERM), 0);
    expect_event(&l, &r, "STOPPING=1\nSTATUS=stopping: 3 worlds held, 0 failed, 3 queries served, queue 0/1024");
    daemon_expect_exit(&r, 0);
    while (listener_read(&l, 100)) {
        const char *late = l.msgs[l.count - 1].text;
        if (strcmp(late, "WATCHDOG=1") != 0)
            fail_msg("'%s' after STOPPING=1", late);
    }
    listener_close(&l);
    scratch_teardown(&s);
}

/* On the bus url: READY=1 once the self-test heard its token through the daemon's loop. */
static void check_ready_after_self_test(const char *url)
{
    scratch s;
    scratch_setup(&s);
    scratch_write(&s, "box.obj", box_obj);
    scratch_write_scene(&s, SCENE_HEAD "[box]\nmesh = box.obj\n");
    listener l;
    listener_open(&l, NULL); /* abstract, as some managers hand out */
    /* The watchdog is meant for another process (the test): this daemon must not ping. */
    child_env env = {l.env, "100000", "parent"};
    run r;
    daemon_start(&r, &s, url, url, &env);

    expect_event(&l, &r, "STATUS=starting: 0 worlds held, 0 failed, 0 queries served, queue 0/1024");
    /* The worlds are in, the bus is not proven yet: no READY=1. */
    expect_eventually(&l, &r, "STATUS=testing the bus: 1 world held, 0 failed, 0 queries served, queue 0/1024",
                      "STATUS=starting: ");
    expect_event(&l, &r, "READY=1\nSTATUS=ready: 1 world held, 0 failed, 0 queries served, queue 0/1024");
    assert_int_equal(count_in_file(r.log_path, "LCM self-test passed in "), 1);
    assert_int_equal(count_in_file(r.log_path, "hears what it publishes on " PREFIX "_SELFTEST_d1"), 1);

    listener_expect_silence(&l, 500);
    assert_int_equal(kill(r.pid, SIGTERM), 0);
    expect_event(&l, &r, "STOPPING=1\nSTATUS=stopping: 1 world held, 0 failed, 0 queries served, queue 0/1024");
    daemon_expect_exit(&r, 0);
    for (size_t i = 0; i < l.count; i++)
        assert_string_not_equal(l.msgs[i].text, "WATCHDOG=1");
    assert_int_equal(count_in_file(r.log_path, "watchdog: WATCHDOG=1 every"), 0);
    listener_close(&l);
    scratch_teardown(&s);
}

static void test_daemon_on_a_bus_is_ready_after_the_self_test(void **state)
{
    (void)state;
    check_ready_after_self_test("memq://");
}

/* Over udpm the token goes out as multicast and comes back through LCM's receive thread:
 * tests/e2e/systemd_test.sh runs this alone, inside tests/e2e/netns.sh, with
 * TRIOCT_TEST_UDPM_URL set. */
static void test_daemon_on_udpm_is_ready_after_the_self_test(void **state)
{
    (void)state;
    check_ready_after_self_test(getenv("TRIOCT_TEST_UDPM_URL"));
}

int main(void)
{
    if (getenv("TRIOCT_TEST_UDPM_URL") != NULL) {
        const struct CMUnitTest udpm[] = {
            cmocka_unit_test_teardown(test_daemon_on_udpm_is_ready_after_the_self_test,
                                      kill_live_child),
        };
        return cmocka_run_group_tests(udpm, NULL, NULL);
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_no_socket_every_call_is_a_noop),
        cmocka_unit_test(test_path_socket_gets_exact_messages),
        cmocka_unit_test(test_abstract_socket_gets_exact_messages),
        cmocka_unit_test(test_watchdog_environment),
        cmocka_unit_test(test_unusable_addresses),
        cmocka_unit_test(test_full_listener_never_blocks),
        cmocka_unit_test_teardown(test_daemon_tells_systemd_every_state, kill_live_child),
        cmocka_unit_test_teardown(test_daemon_on_a_bus_is_ready_after_the_self_test,
                                  kill_live_child),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
