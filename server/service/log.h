/* The daemon's log: one macro, four levels, one line per call on stdout.
 *
 *   LOG(LOG_INFO, "world '%s' loaded: %zu triangles", name, n);
 *
 * stdout rather than syslog because trioctd runs under systemd, whose journal captures
 * stdout and stamps each line; run by hand, the lines carry their own time. A call below
 * the threshold costs one comparison and never formats its arguments.
 *
 * Do not include <syslog.h> next to this header: it defines LOG_INFO and LOG_DEBUG too. */
#ifndef TRIOCT_SERVICE_LOG_H
#define TRIOCT_SERVICE_LOG_H

#include <stdatomic.h>

typedef enum log_level {
    LOG_ERROR = 0,
    LOG_WARN = 1,
    LOG_INFO = 2,
    LOG_DEBUG = 3,
} log_level;

/* The most verbose level written. Atomic because workers may log while the loop thread
 * changes the level on a reload. */
extern atomic_int log_threshold;

#define LOG(level, ...)                                                    \
    do {                                                                   \
        if ((int)(level) <= atomic_load_explicit(&log_threshold,           \
                                                 memory_order_relaxed))    \
            log_write((level), __VA_ARGS__);                               \
    } while (0)

/* Makes stdout line-buffered (a pipe or the journal sees each line as it is written) and
 * decides on timestamps: none when stdout goes to the journal (JOURNAL_STREAM is set),
 * which stamps lines itself. Call once before the first LOG. */
void log_init(void);

void log_set_level(log_level level);
log_level log_get_level(void);
void log_set_timestamps(int on);

/* "error" | "warn" | "info" | "debug" to a level: 0, or -1 for any other text. */
int log_level_parse(const char *text, log_level *out);
const char *log_level_name(log_level level);

/* Writes one line whatever the threshold; use LOG. Lines from several threads never
 * interleave. */
void log_write(log_level level, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

#endif
