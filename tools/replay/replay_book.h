/* What a log holds, ready for pairing: its well-formed requests, in log order, and its
 * replies, each reassembled from its chunks. Built from a request log, a golden log or the
 * daemon's output alike.
 *
 * A reply is known by (client id, request id) and nothing else: never by its position or
 * its timestamp, since a daemon publishes in the order its workers finish. The chunks of one
 * reply share that key, their type, channel and chunk count; a chunk goes to the first reply
 * of its key still lacking that chunk index, so even a key used twice (a client's bug) gives
 * whole replies. A reply whose chunks disagree or do not all come says so in `problem`. */
#ifndef TRIOCT_REPLAY_BOOK_H
#define TRIOCT_REPLAY_BOOK_H

#include <stddef.h>
#include <stdint.h>

#include "replay_classify.h"
#include "replay_log.h"
#include "trioct_reply_header_t.h"
#include "trioct_segment_t.h"

typedef struct replay_request {
    size_t event;        /* its index in the log */
    size_t ordinal;      /* 1 for the log's first request, ... */
    const char *channel; /* the log's */
    wire_type type;
    int64_t client_id;
    int64_t request_id;
    char reply_channel[TRIOCT_MAX_CHANNEL_LEN + 1];
} replay_request;

typedef struct replay_reply {
    wire_type type;
    const char *channel; /* where it came: the log's */
    int64_t client_id;
    int64_t request_id;
    size_t first_event;  /* the log index of its first chunk */
    int32_t chunk_count; /* as its chunks say */
    void **chunk;        /* chunk i decoded (the generated struct of type), or NULL */
    const replay_event **raw; /* the event of chunk i, or NULL */
    char problem[192];   /* "" when whole and consistent */

    /* The whole reply across its chunks. */
    const trioct_reply_header_t *header; /* the first chunk present */
    int8_t detail;       /* the detail echoed; for admin replies the op */
    int32_t num_items;   /* rays, query triangles or poses: found[] of chunk 0 */
    const int32_t *found;
    size_t num_records;  /* hits, contacts, pairs or worlds, in chunk order */
    const void **records;
    size_t num_segments; /* triangle SEGMENTS only */
    const trioct_segment_t **segments;
    int32_t num_names;   /* query replies: the object names of chunk 0 */
    const char *const *names;
} replay_reply;

typedef struct replay_book {
    replay_request *requests; /* well-formed, in log order */
    size_t request_count;
    size_t *by_key;           /* request indices sorted by key, then log order */
    replay_reply *replies;    /* sorted by key, then by first chunk's position */
    size_t reply_count;
    size_t malformed;         /* events on request channels the validator refused */
    size_t statuses;          /* heartbeats, ignored */
    size_t reloads;           /* reload marks */
    size_t stops;             /* stop marks */
    size_t bad_replies;       /* reply fingerprints the validator refused */
    size_t others;
} replay_book;

/* 0, or -1 with err (out of memory). The book points into log, which must outlive it. */
int replay_book_build(replay_book *b, const replay_log *log, const replay_proto *p, char *err,
                      size_t err_len);
void replay_book_free(replay_book *b);

/* The first request of the log with this key, or NULL. */
const replay_request *replay_book_request(const replay_book *b, int64_t client_id, int64_t request_id);

/* The replies with this key: the first one and how many follow it (0 when none). */
const replay_reply *replay_book_replies(const replay_book *b, int64_t client_id, int64_t request_id,
                                        size_t *count);

/* The generated struct of a reply type: its size, its decoding (of bytes wire_check has
 * passed: 0 or -1) and its cleanup. */
size_t replay_reply_struct_size(wire_type type);
int replay_reply_decode(wire_type type, const void *bytes, size_t size, void *msg);
void replay_reply_cleanup(wire_type type, void *msg);

#endif
