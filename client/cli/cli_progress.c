/* The progress line (see cli_progress.h). */
#include "cli_progress.h"

#include <string.h>
#include <time.h>
#include <unistd.h>

#define SECOND_NS 1000000000LL
#define DELAY_NS SECOND_NS             /* batches shorter than this show nothing */
#define TERMINAL_PERIOD_NS (SECOND_NS / 10)
#define LINES_PERIOD_NS SECOND_NS

cli_progress_mode cli_progress_mode_for(FILE *out, int forced)
{
    if (isatty(fileno(out)))
        return CLI_PROGRESS_TERMINAL;
    return forced ? CLI_PROGRESS_LINES : CLI_PROGRESS_OFF;
}

void cli_progress_begin(cli_progress *p, FILE *out, cli_progress_mode mode, const char *what,
                        size_t total, int64_t now_ns)
{
    memset(p, 0, sizeof *p);
    p->out = out;
    p->mode = mode;
    p->what = what;
    p->total = total;
    p->start_ns = now_ns;
}

static void print_line(cli_progress *p, size_t done, int64_t now_ns)
{
    double percent = p->total ? 100.0 * (double)done / (double)p->total : 100.0;
    double seconds = (double)(now_ns - p->start_ns) / 1e9;
    if (p->mode == CLI_PROGRESS_TERMINAL)
        fputc('\r', p->out);
    /* The trailing blanks clear what a longer earlier line left on a terminal. */
    fprintf(p->out, "%s: %zu of %zu (%.0f%%), %.1f s%s", p->what, done, p->total, percent,
            seconds, p->mode == CLI_PROGRESS_TERMINAL ? "   " : "\n");
    fflush(p->out);
    p->shown = 1;
    p->last_ns = now_ns;
}

void cli_progress_update(cli_progress *p, size_t done, int64_t now_ns)
{
    if (p->mode == CLI_PROGRESS_OFF || now_ns - p->start_ns < DELAY_NS)
        return;
    int64_t period = p->mode == CLI_PROGRESS_TERMINAL ? TERMINAL_PERIOD_NS : LINES_PERIOD_NS;
    if (p->shown && now_ns - p->last_ns < period)
        return;
    print_line(p, done, now_ns);
}

void cli_progress_end(cli_progress *p, size_t done, int64_t now_ns)
{
    if (p->mode == CLI_PROGRESS_OFF || (!p->shown && now_ns - p->start_ns < DELAY_NS))
        return;
    print_line(p, done, now_ns);
    if (p->mode == CLI_PROGRESS_TERMINAL) {
        fputc('\n', p->out);
        fflush(p->out);
    }
}

int64_t cli_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * SECOND_NS + ts.tv_nsec;
}
