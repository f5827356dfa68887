/* Starting and stopping trioctd processes for the end-to-end tests and the daemon
 * benchmark. They run inside a private network and pid namespace (tests/e2e/netns.sh), so
 * every daemon dies with the namespace even when a test fails half-way. */
#ifndef TRIOCT_TESTS_DAEMON_PROC_H
#define TRIOCT_TESTS_DAEMON_PROC_H

#include <sys/types.h>

#include "trioct.h"

/* Starts `daemon_bin --scene scene --url url --name name` plus the extra arguments (a NULL
 * terminated list, may be NULL), stdout and stderr to log_path. Returns the pid, or -1. */
pid_t daemon_proc_start(const char *daemon_bin, const char *scene, const char *url, const char *name,
                        const char *const *extra_args, const char *log_path);

/* Waits until the daemon's heartbeat says READY (through c), at most timeout_ms. 0 or -1. */
int daemon_proc_wait_ready(trioct_client *c, const char *name, int timeout_ms);

/* Sends sig and waits for the process to exit, at most timeout_ms (then SIGKILL). Returns
 * its exit status (0..255), 128 + signal when killed by one, or -1 on timeout. */
int daemon_proc_stop(pid_t pid, int sig, int timeout_ms);

/* Waits for an exit already under way; same returns as daemon_proc_stop. */
int daemon_proc_wait_exit(pid_t pid, int timeout_ms);

/* The admin key the end-to-end daemons and their clients share, as hex. */
#define DAEMON_PROC_KEY_HEX "e2e0e2e1e2e2e2e3e2e4e2e5e2e6e2e7e2e8e2e9e2eae2ebe2ece2ede2eee2ef"

/* Writes DAEMON_PROC_KEY_HEX to path, readable by its owner only, and points
 * TRIOCT_KEY_FILE at it, so every client of this process and its children signs with it.
 * 0 or -1. */
int daemon_proc_write_key(const char *path);

/* This build's mesh loader, for a daemon_run inside a test program (which finds no loader
 * beside itself): BUILD/trioct-load for a program in BUILD/tests or BUILD/bench. */
const char *daemon_proc_loader(void);

#endif
