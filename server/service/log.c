#include "log.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

atomic_int log_threshold = LOG_INFO;
static atomic_int log_stamps = 1;

static const char *const level_names[] = {
    [LOG_ERROR] = "error",
    [LOG_WARN] = "warn",
    [LOG_INFO] = "info",
    [LOG_DEBUG] = "debug",
};

void log_init(void)
{
    /* Line buffering: a log read through a pipe or a file must not lag behind the daemon
     * by a 4 KB buffer, and a crash must not eat the lines that explain it. */
    setvbuf(stdout, NULL, _IOLBF, 0);
    const char *journal = getenv("JOURNAL_STREAM");
    log_set_timestamps(journal == NULL || journal[0] == '\0');
}

void log_set_level(log_level level)
{
    if ((int)level < LOG_ERROR)
        level = LOG_ERROR;
    if ((int)level > LOG_DEBUG)
        level = LOG_DEBUG;
    atomic_store(&log_threshold, (int)level);
}

log_level log_get_level(void)
{
    return (log_level)atomic_load(&log_threshold);
}

void log_set_timestamps(int on)
{
    atomic_store(&log_stamps, on != 0);
}

int log_level_parse(const char *text, log_level *out)
{
    if (text == NULL)
        return -1;
    for (int i = LOG_ERROR; i <= LOG_DEBUG; i++) {
        if (strcmp(text, level_names[i]) == 0) {
            *out = (log_level)i;
            return 0;
        }
    }
    return -1;
}

const char *log_level_name(log_level level)
{
    if ((int)level < LOG_ERROR || (int)level > LOG_DEBUG)
        return "?";
    return level_names[level];
}

void log_write(log_level level, const char *fmt, ...)
{
    char stamp[40] = "";
    if (atomic_load_explicit(&log_stamps, memory_order_relaxed)) {
        struct timespec ts;
        struct tm tm;
        clock_gettime(CLOCK_REALTIME, &ts);
        localtime_r(&ts.tv_sec, &tm);
        size_t n = strftime(stamp, sizeof stamp, "%Y-%m-%d %H:%M:%S", &tm);
        snprintf(stamp + n, sizeof stamp - n, ".%03ld ", ts.tv_nsec / 1000000);
    }

    /* One lock around the three writes keeps a line whole when workers log at once. */
    va_list ap;
    va_start(ap, fmt);
    flockfile(stdout);
    fprintf(stdout, "%s%-5s ", stamp, log_level_name(level));
    vfprintf(stdout, fmt, ap);
    fputc('\n', stdout);
    funlockfile(stdout);
    va_end(ap);
}
