/* LCM logs held in memory: read with lcm/eventlog.h, written with fixed timestamps.
 *
 * LCM's reader trusts the lengths it reads (a hostile data length makes it allocate and
 * read wildly) and skips bytes silently until it finds the next event, so a log is first
 * walked here, event by event, and checked: every event where the previous one ended, a
 * channel of 1..999 bytes (LCM's own bound), data that the file holds. Only a log that
 * passes is handed to LCM. An event that runs past the end of the file (the last one, cut
 * short when a logger was killed mid-write) is left out and said so; anything else wrong is
 * an error naming the byte. */
#ifndef TRIOCT_REPLAY_LOG_H
#define TRIOCT_REPLAY_LOG_H

#include <stddef.h>
#include <stdint.h>

typedef struct replay_event {
    int64_t timestamp; /* microseconds; never compared, only written back */
    char *channel;
    uint8_t *data;
    size_t size;
} replay_event;

typedef struct replay_log {
    replay_event *events;
    size_t count;
    int truncated;         /* the file ended inside an event, which was left out */
    uint64_t truncated_at; /* the byte that event starts at */
} replay_log;

/* 0 with *log filled (free it with replay_log_free), or -1 with err. */
int replay_log_read(const char *path, replay_log *log, char *err, size_t err_len);
void replay_log_free(replay_log *log);

/* Writes events in order, each with its own timestamp. 0, or -1 with err. */
int replay_log_write(const char *path, const replay_event *events, size_t count, char *err,
                     size_t err_len);

#endif
