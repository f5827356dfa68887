/* One replay: the logs read and paired, a scratch directory, and the daemon run on the
 * input. Shared by the three modes (replay_main.c):
 *
 *   check   feeds the log's input to a fresh daemon through file:// logs and compares its
 *           replies with the golden ones;
 *   record  the same run, then writes the golden log (replay_record.c);
 *   live    plays the input over udpm with lcm-logplayer (replay_live.c).
 *
 * The input is every event of the log but its replies and heartbeats (replay_classify), so
 * a request log and the golden log made from it feed the daemon the very same messages.
 * The daemon runs with --ordered (answers as one thread gives them, whatever --threads; a
 * message on <prefix>_RELOAD_<name> reloads its scene, one on <prefix>_STOP_<name> begins
 * stopping), in the world directory, with the scene named relative to it: world sources
 * and messages then name no directory of this machine, and a golden log recorded here
 * replays anywhere. */
#ifndef TRIOCT_REPLAY_SESSION_H
#define TRIOCT_REPLAY_SESSION_H

#include <limits.h>
#include <stddef.h>
#include <stdio.h>
#include <sys/types.h>

#include "replay_book.h"
#include "replay_classify.h"
#include "replay_log.h"
#include "replay_match.h"

#define REPLAY_PATH_LEN 4096

typedef struct replay_options {
    const char *mode;      /* "check", "record" or "live" */
    const char *log;       /* the log replayed */
    const char *golden;    /* NULL: the replies of `log` itself */
    const char *output;    /* record: the golden log written */
    const char *scene;
    const char *world_dir; /* NULL: the scene's directory */
    const char *daemon;    /* NULL: trioctd beside this program */
    const char *key_file;  /* the daemon's admin key; NULL: the logs' (replay_key.h) */
    int threads;           /* 0: the daemon's own default */
    unsigned ignore;       /* REPLAY_IGNORE_* */
    size_t max_lines;      /* difference lines per reply */
    int timeout_s;         /* for the daemon to answer everything */
    int keep;              /* keep the scratch directory */
    int quiet;
    int verbose;           /* also a line for every reply that matched */
    /* live */
    const char *url;
    const char *speed;     /* lcm-logplayer -s */
    int host_network;      /* allow a network namespace with more than lo */
} replay_options;

typedef struct replay_session {
    const replay_options *opt;
    replay_proto proto;
    char dir[64];                         /* scratch */
    char input_path[REPLAY_PATH_LEN];     /* the input log fed to the daemon */
    char out_path[REPLAY_PATH_LEN];       /* what the daemon (or the bus) said */
    char daemon_log[REPLAY_PATH_LEN];
    char daemon_bin[REPLAY_PATH_LEN];
    char world_dir[REPLAY_PATH_LEN];      /* absolute */
    char scene_arg[REPLAY_PATH_LEN];      /* relative to world_dir when inside it */
    char key_path[REPLAY_PATH_LEN];       /* the key file given to the daemon */
    replay_log script_log, golden_log, out_log;
    replay_book script, golden, got;
    const replay_book *expected;          /* &golden, or &script when it holds the replies */
    size_t inputs;
} replay_session;

/* Reads the logs, pairs them and writes the input. 0, or -1 with the reason printed. */
int replay_session_open(replay_session *s, const replay_options *opt);
void replay_session_close(replay_session *s);

/* The daemon's arguments for this session: argv (NULL-terminated) pointing into store. */
void replay_session_daemon_argv(const replay_session *s, const char *url, const char *publish_url,
                                int exit_at_eof, const char **argv, size_t argv_cap,
                                char store[][REPLAY_PATH_LEN + 64], size_t store_cap);

/* Runs the daemon on the input through file:// logs until it exits at the input's end,
 * then reads its output into s->got. 0, or -1 with the reason (and the daemon's last
 * words) printed. */
int replay_session_run_offline(replay_session *s);

/* Reads s->out_path into s->got. 0 or -1. */
int replay_session_read_output(replay_session *s);

/* Pairs and compares, prints the differences to diffs (NULL: none) and the counts to
 * summary. 0 when the replay passed, 1 when it did not, -1 on error. */
int replay_session_compare(replay_session *s, FILE *diffs, FILE *summary);

/* Writes the golden log (replay_record.c). 0 or -1. */
int replay_record_golden(const replay_session *s, const char *path, FILE *out);

/* The live replay (replay_live.c): fills s->got from lcm-logger's recording. 0 or -1. */
int replay_live_run(replay_session *s);

#endif
