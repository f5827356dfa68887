/* Child processes of a replay: the daemon, and in live mode lcm-logger and lcm-logplayer.
 * Each runs in a directory of our choosing with its output in a file, and is waited for
 * with a time limit, so a daemon that hangs fails the replay instead of stalling it. */
#ifndef TRIOCT_REPLAY_PROC_H
#define TRIOCT_REPLAY_PROC_H

#include <stddef.h>
#include <sys/types.h>

/* Starts argv[0] (looked up in PATH when it has no '/') in directory cwd (NULL: ours),
 * stdout and stderr appended to log_path. The pid, or -1 with err. */
pid_t replay_spawn(const char *const *argv, const char *cwd, const char *log_path, char *err,
                   size_t err_len);

/* Waits for pid at most timeout_ms. Its exit status (0..255), 128 + the signal that killed
 * it, or -1 when it was still running (it is then left running). */
int replay_wait(pid_t pid, int timeout_ms);

/* Sends sig, waits at most timeout_ms, then SIGKILL. Same returns as replay_wait. */
int replay_stop(pid_t pid, int sig, int timeout_ms);

/* Prints the last lines of a file (a child's output) to stderr, each indented. */
void replay_print_tail(const char *path, int lines);

/* The directory holding this program, for finding trioctd beside it. 0 or -1. */
int replay_own_dir(char *out, size_t len);

#endif
