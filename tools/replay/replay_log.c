#include "replay_log.h"

#include <errno.h>
#include <lcm/eventlog.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* An event's framing: sync word, event number, timestamp, channel and data lengths, all
 * big-endian, then the channel and the data. */
#define LOG_HEADER_BYTES 28
#define LOG_MAX_CHANNEL 999

static uint32_t be32(const unsigned char *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | (uint32_t)p[3];
}

/* Counts the whole events of the file and checks their framing. */
static int scan(const char *path, size_t *events, int *truncated, uint64_t *truncated_at, char *err,
                size_t err_len)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        snprintf(err, err_len, "%s: %s", path, strerror(errno));
        return -1;
    }
    struct stat st;
    if (fstat(fileno(f), &st) != 0 || !S_ISREG(st.st_mode)) {
        snprintf(err, err_len, "%s: not a regular file", path);
        fclose(f);
        return -1;
    }
    uint64_t size = (uint64_t)st.st_size, at = 0;
    *events = 0;
    *truncated = 0;
    int rc = 0;
    while (at < size) {
        unsigned char h[LOG_HEADER_BYTES];
        size_t got = fread(h, 1, sizeof h, f);
        /* What there is of the sync word must be the sync word: else this is no log. */
        static const unsigned char sync[4] = {0xED, 0xA1, 0xDA, 0x01};
        if (memcmp(h, sync, got < 4 ? got : 4) != 0) {
            snprintf(err, err_len, "%s: byte %llu: no LCM event starts here (not a log, or damaged)",
                     path, (unsigned long long)at);
            rc = -1;
            break;
        }
        if (got < sizeof h) {
            *truncated = 1;
            *truncated_at = at;
            break;
        }
        int32_t channel_len = (int32_t)be32(h + 20), data_len = (int32_t)be32(h + 24);
        if (channel_len <= 0 || channel_len > LOG_MAX_CHANNEL || data_len < 0 || data_len == INT32_MAX) {
            snprintf(err, err_len, "%s: event %zu at byte %llu: impossible lengths (channel %d, data %d)",
                     path, *events, (unsigned long long)at, channel_len, data_len);
            rc = -1;
            break;
        }
        uint64_t body = (uint64_t)channel_len + (uint64_t)data_len;
        if (size - at - LOG_HEADER_BYTES < body) {
            *truncated = 1;
            *truncated_at = at;
            break;
        }
        if (fseeko(f, (off_t)body, SEEK_CUR) != 0) {
            snprintf(err, err_len, "%s: %s", path, strerror(errno));
            rc = -1;
            break;
        }
        at += LOG_HEADER_BYTES + body;
        (*events)++;
    }
    fclose(f);
    return rc;
}

int replay_log_read(const char *path, replay_log *log, char *err, size_t err_len)
{
    memset(log, 0, sizeof *log);
    size_t count;
    int truncated;
    uint64_t truncated_at = 0;
    if (scan(path, &count, &truncated, &truncated_at, err, err_len) < 0)
        return -1;
    log->truncated = truncated;
    log->truncated_at = truncated_at;
    if (count == 0)
        return 0;
    log->events = calloc(count, sizeof *log->events);
    lcm_eventlog_t *in = lcm_eventlog_create(path, "r");
    if (log->events == NULL || in == NULL) {
        snprintf(err, err_len, "%s: %s", path, in == NULL ? strerror(errno) : "out of memory");
        if (in != NULL)
            lcm_eventlog_destroy(in);
        replay_log_free(log);
        return -1;
    }
    for (size_t i = 0; i < count; i++) {
        lcm_eventlog_event_t *ev = lcm_eventlog_read_next_event(in);
        if (ev == NULL) {
            snprintf(err, err_len, "%s: event %zu could not be read", path, i);
            lcm_eventlog_destroy(in);
            replay_log_free(log);
            return -1;
        }
        replay_event *e = &log->events[log->count++];
        e->timestamp = ev->timestamp;
        e->size = (size_t)ev->datalen;
        e->channel = strdup(ev->channel);
        /* One byte more, so an empty payload still has a buffer. */
        e->data = malloc(e->size + 1);
        if (e->channel == NULL || e->data == NULL) {
            snprintf(err, err_len, "%s: out of memory at event %zu", path, i);
            lcm_eventlog_free_event(ev);
            lcm_eventlog_destroy(in);
            replay_log_free(log);
            return -1;
        }
        memcpy(e->data, ev->data, e->size);
        lcm_eventlog_free_event(ev);
    }
    lcm_eventlog_destroy(in);
    return 0;
}

void replay_log_free(replay_log *log)
{
    for (size_t i = 0; i < log->count; i++) {
        free(log->events[i].channel);
        free(log->events[i].data);
    }
    free(log->events);
    memset(log, 0, sizeof *log);
}

int replay_log_write(const char *path, const replay_event *events, size_t count, char *err,
                     size_t err_len)
{
    lcm_eventlog_t *out = lcm_eventlog_create(path, "w");
    if (out == NULL) {
        snprintf(err, err_len, "%s: %s", path, strerror(errno));
        return -1;
    }
    int rc = 0;
    for (size_t i = 0; i < count && rc == 0; i++) {
        lcm_eventlog_event_t ev;
        memset(&ev, 0, sizeof ev);
        ev.timestamp = events[i].timestamp;
        ev.channellen = (int32_t)strlen(events[i].channel);
        ev.datalen = (int32_t)events[i].size;
        ev.channel = events[i].channel;
        ev.data = events[i].data;
        if (lcm_eventlog_write_event(out, &ev) != 0) {
            snprintf(err, err_len, "%s: writing event %zu: %s", path, i, strerror(errno));
            rc = -1;
        }
    }
    /* lcm_eventlog_destroy flushes and closes but cannot say whether that worked. */
    if (rc == 0 && fflush(out->f) != 0) {
        snprintf(err, err_len, "%s: %s", path, strerror(errno));
        rc = -1;
    }
    lcm_eventlog_destroy(out);
    return rc;
}
