/* realpath(3) is XSI. */
#define _XOPEN_SOURCE 700

#include "replay_session.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "replay_key.h"
#include "replay_proc.h"

static int fail(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static int fail(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "trioct-replay: ");
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return -1;
}

static int read_log(const char *path, replay_log *log)
{
    char err[REPLAY_PATH_LEN + 256];
    if (replay_log_read(path, log, err, sizeof err) < 0)
        return fail("%s", err);
    if (log->truncated)
        fprintf(stderr, "trioct-replay: %s: the event at byte %llu runs past the end of the file: left out\n",
                path, (unsigned long long)log->truncated_at);
    return 0;
}

static int build_book(const char *path, const replay_log *log, const replay_proto *p, replay_book *b)
{
    char err[256];
    if (replay_book_build(b, log, p, err, sizeof err) < 0)
        return fail("%s: %s", path, err);
    return 0;
}

/* The scene as the daemon, run in the world directory, should be told of it. */
static int place_scene(replay_session *s)
{
    const replay_options *o = s->opt;
    char scene_abs[PATH_MAX];
    if (realpath(o->scene, scene_abs) == NULL)
        return fail("%s: %s", o->scene, strerror(errno));
    char dir[PATH_MAX];
    if (o->world_dir != NULL) {
        if (realpath(o->world_dir, dir) == NULL)
            return fail("%s: %s", o->world_dir, strerror(errno));
    } else {
        snprintf(dir, sizeof dir, "%s", scene_abs);
        char *slash = strrchr(dir, '/');
        if (slash == dir)
            slash[1] = '\0';
        else
            *slash = '\0';
    }
    snprintf(s->world_dir, sizeof s->world_dir, "%s", dir);
    size_t n = strlen(dir);
    if (strncmp(scene_abs, dir, n) == 0 && scene_abs[n] == '/')
        snprintf(s->scene_arg, sizeof s->scene_arg, "%s", scene_abs + n + 1);
    else
        snprintf(s->scene_arg, sizeof s->scene_arg, "%s", scene_abs);
    return 0;
}

static int find_daemon(replay_session *s)
{
    if (s->opt->daemon != NULL) {
        snprintf(s->daemon_bin, sizeof s->daemon_bin, "%s", s->opt->daemon);
    } else {
        char dir[REPLAY_PATH_LEN - 16];
        if (replay_own_dir(dir, sizeof dir) < 0)
            return fail("cannot tell where this program is: give --daemon PATH");
        snprintf(s->daemon_bin, sizeof s->daemon_bin, "%s/trioctd", dir);
    }
    /* The child runs in the world directory: a relative path would go astray there. */
    char abs[PATH_MAX];
    if (realpath(s->daemon_bin, abs) == NULL || access(abs, X_OK) != 0)
        return fail("no daemon to run at %s (give --daemon PATH)", s->daemon_bin);
    snprintf(s->daemon_bin, sizeof s->daemon_bin, "%s", abs);
    return 0;
}

static int write_input(replay_session *s)
{
    replay_event *in = calloc(s->script_log.count ? s->script_log.count : 1, sizeof *in);
    if (in == NULL)
        return fail("out of memory");
    size_t n = 0;
    for (size_t i = 0; i < s->script_log.count; i++) {
        replay_class c;
        replay_classify(&s->proto, &s->script_log.events[i], &c);
        if (replay_kind_is_input(c.kind))
            in[n++] = s->script_log.events[i];
    }
    s->inputs = n;
    char err[REPLAY_PATH_LEN + 256];
    int rc = 0;
    if (n == 0)
        rc = fail("%s holds nothing to replay (no requests for prefix %s)", s->opt->log, s->proto.prefix);
    else if (replay_log_write(s->input_path, in, n, err, sizeof err) < 0)
        rc = fail("%s", err);
    free(in);
    return rc;
}

/* The daemon checks the logs' signed changes with their key, written where only this user
 * reads it (a key file others may read is refused); or with the one --key-file names. */
static int write_key(replay_session *s)
{
    if (s->opt->key_file) {
        snprintf(s->key_path, sizeof s->key_path, "%s", s->opt->key_file);
        return 0;
    }
    snprintf(s->key_path, sizeof s->key_path, "%s/admin.key", s->dir);
    int fd = open(s->key_path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (fd < 0)
        return fail("cannot write %s: %s", s->key_path, strerror(errno));
    const char *text = REPLAY_LOGS_KEY_HEX "\n";
    ssize_t n = write(fd, text, strlen(text));
    close(fd);
    if (n != (ssize_t)strlen(text))
        return fail("cannot write %s", s->key_path);
    return 0;
}

int replay_session_open(replay_session *s, const replay_options *opt)
{
    memset(s, 0, sizeof *s);
    s->opt = opt;
    char err[REPLAY_PATH_LEN + 256];
    if (replay_proto_from_scene(&s->proto, opt->scene, err, sizeof err) < 0)
        return fail("%s", err);
    if (place_scene(s) < 0 || find_daemon(s) < 0)
        return -1;
    if (read_log(opt->log, &s->script_log) < 0 || build_book(opt->log, &s->script_log, &s->proto, &s->script) < 0)
        return -1;
    s->expected = &s->script;
    if (opt->golden != NULL) {
        if (read_log(opt->golden, &s->golden_log) < 0 ||
            build_book(opt->golden, &s->golden_log, &s->proto, &s->golden) < 0)
            return -1;
        s->expected = &s->golden;
        if (s->golden.request_count != 0 && s->golden.request_count != s->script.request_count)
            fprintf(stderr, "trioct-replay: warning: %s has %zu requests, %s %zu: is it the golden log of this one?\n",
                    opt->golden, s->golden.request_count, opt->log, s->script.request_count);
    } else if (s->script.reply_count == 0 && strcmp(opt->mode, "record") != 0) {
        fprintf(stderr, "trioct-replay: warning: %s holds no replies and no --golden was given: every reply "
                        "will count as extra (make a golden log with `trioct-replay record`)\n", opt->log);
    }

    snprintf(s->dir, sizeof s->dir, "/tmp/trioct-replay-XXXXXX");
    if (mkdtemp(s->dir) == NULL) {
        s->dir[0] = '\0';
        return fail("cannot make a scratch directory: %s", strerror(errno));
    }
    snprintf(s->input_path, sizeof s->input_path, "%s/input.lcmlog", s->dir);
    snprintf(s->out_path, sizeof s->out_path, "%s/out.lcmlog", s->dir);
    snprintf(s->daemon_log, sizeof s->daemon_log, "%s/daemon.log", s->dir);
    if (write_key(s) != 0)
        return -1;
    return write_input(s);
}

void replay_session_close(replay_session *s)
{
    replay_book_free(&s->script);
    replay_book_free(&s->golden);
    replay_book_free(&s->got);
    replay_log_free(&s->script_log);
    replay_log_free(&s->golden_log);
    replay_log_free(&s->out_log);
    if (s->dir[0] == '\0')
        return;
    if (s->opt->keep) {
        fprintf(stderr, "trioct-replay: kept %s (input.lcmlog, out.lcmlog, daemon.log)\n", s->dir);
        return;
    }
    /* Only files of our own making live there. */
    DIR *d = opendir(s->dir);
    if (d != NULL) {
        struct dirent *e;
        while ((e = readdir(d)) != NULL) {
            if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0)
                continue;
            char path[REPLAY_PATH_LEN];
            snprintf(path, sizeof path, "%s/%.255s", s->dir, e->d_name);
            unlink(path);
        }
        closedir(d);
    }
    rmdir(s->dir);
}

void replay_session_daemon_argv(const replay_session *s, const char *url, const char *publish_url,
                                int exit_at_eof, const char **argv, size_t argv_cap,
                                char store[][REPLAY_PATH_LEN + 64], size_t store_cap)
{
    size_t n = 0, k = 0;
#define ARG(...)                                                             \
    do {                                                                     \
        if (n + 1 < argv_cap && k < store_cap) {                             \
            snprintf(store[k], sizeof store[k], __VA_ARGS__);                \
            argv[n++] = store[k++];                                          \
        }                                                                    \
    } while (0)
    ARG("%s", s->daemon_bin);
    ARG("--scene");
    ARG("%s", s->scene_arg);
    ARG("--world-dir");
    ARG(".");
    ARG("--url");
    ARG("%s", url);
    if (publish_url != NULL) {
        ARG("--publish-url");
        ARG("%s", publish_url);
    }
    if (exit_at_eof)
        ARG("--exit-at-eof");
    ARG("--ordered");
    ARG("--admin-key-file");
    ARG("%s", s->key_path);
    if (s->opt->threads > 0) {
        ARG("--threads");
        ARG("%d", s->opt->threads);
    }
#undef ARG
    argv[n] = NULL;
}

int replay_session_read_output(replay_session *s)
{
    if (read_log(s->out_path, &s->out_log) < 0)
        return -1;
    return build_book(s->out_path, &s->out_log, &s->proto, &s->got);
}

int replay_session_run_offline(replay_session *s)
{
    char in_url[REPLAY_PATH_LEN + 32], out_url[REPLAY_PATH_LEN + 32];
    snprintf(in_url, sizeof in_url, "file://%s?speed=0", s->input_path);
    snprintf(out_url, sizeof out_url, "file://%s?mode=w", s->out_path);
    const char *argv[24];
    char store[20][REPLAY_PATH_LEN + 64];
    replay_session_daemon_argv(s, in_url, out_url, 1, argv, 24, store, 20);

    char err[REPLAY_PATH_LEN + 256];
    pid_t pid = replay_spawn(argv, s->world_dir, s->daemon_log, err, sizeof err);
    if (pid < 0)
        return fail("%s", err);
    int rc = replay_wait(pid, s->opt->timeout_s * 1000);
    if (rc == -1) {
        replay_stop(pid, SIGKILL, 5000);
        fprintf(stderr, "trioct-replay: the daemon did not finish within %d s; its last words:\n",
                s->opt->timeout_s);
        replay_print_tail(s->daemon_log, 12);
        return -1;
    }
    if (rc != 0) {
        fprintf(stderr, "trioct-replay: the daemon exited with status %d; its last words:\n", rc);
        replay_print_tail(s->daemon_log, 12);
        return -1;
    }
    return replay_session_read_output(s);
}

int replay_session_compare(replay_session *s, FILE *diffs, FILE *summary)
{
    replay_counts c;
    replay_rules rules = {s->opt->ignore, s->world_dir};
    if (replay_match(&s->script, s->expected, &s->got, &rules, s->opt->max_lines, s->opt->verbose, diffs, &c) < 0)
        return fail("out of memory comparing");
    replay_counts_print(summary, &c);
    if (c.bad_replies > 0)
        fprintf(summary, "(%zu reply messages the validator refused were left out)\n", c.bad_replies);
    return replay_counts_pass(&c) ? 0 : 1;
}
