/* The progress line of long batches on stderr. Nothing shows for a batch that ends within
 * a second; after that a terminal gets one line redrawn in place (at most ten times a
 * second), anything else (with --progress) a plain line each second. The clock is passed
 * in, so the logic is tested without waiting. */
#ifndef TRIOCT_CLI_PROGRESS_H
#define TRIOCT_CLI_PROGRESS_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

typedef enum cli_progress_mode {
    CLI_PROGRESS_OFF,
    CLI_PROGRESS_TERMINAL, /* "\r...": one line rewritten */
    CLI_PROGRESS_LINES,    /* one line per update, for logs */
} cli_progress_mode;

typedef struct cli_progress {
    FILE *out;
    cli_progress_mode mode;
    const char *what; /* "rays", "poses" */
    size_t total;
    int64_t start_ns, last_ns;
    int shown; /* a line was printed: the end prints the final count */
} cli_progress;

/* The mode for a stream: TERMINAL when it is a terminal, LINES when forced, else OFF. */
cli_progress_mode cli_progress_mode_for(FILE *out, int forced);

void cli_progress_begin(cli_progress *p, FILE *out, cli_progress_mode mode, const char *what,
                        size_t total, int64_t now_ns);
void cli_progress_update(cli_progress *p, size_t done, int64_t now_ns);
/* After the batch: the final count when the batch took a second or more (and the newline
 * a terminal line still needs). */
void cli_progress_end(cli_progress *p, size_t done, int64_t now_ns);

/* CLOCK_MONOTONIC in nanoseconds. */
int64_t cli_now_ns(void);

#endif
