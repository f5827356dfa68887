/* What the files of libtrioct share and its users never see: the connection, the table of
 * requests waiting for replies, and chunk reassembly. client.c owns all three;
 * client_async.c runs completions, deadlines and cancels; each client_<type>.c encodes its
 * requests and turns reassembled chunks into a result. */
#ifndef TRIOCT_CLIENT_INTERNAL_H
#define TRIOCT_CLIENT_INTERNAL_H

#include <lcm/lcm.h>
#include <stdint.h>

#include "admin_key.h"
#include "channels.h"
#include "trioct.h"
#include "trioct_reply_header_t.h"
#include "trioct_request_header_t.h"
#include "wire_check.h"

/* A reply never legitimately needs more chunks than this (TRIOCT_MAX_RESULTS records of at
 * most 56 bytes in chunks of TRIOCT_MAX_CHUNK_BYTES need under a hundred); a larger count is
 * a bad reply, not an allocation. */
#define CLIENT_MAX_CHUNKS 4096
#define CLIENT_DEFAULT_QUEUE_CAPACITY 4096

/* How one reply type is decoded: every generated reply struct has its header first. */
typedef struct reply_ops {
    wire_type wire;
    size_t msg_size;
    int (*decode)(const void *buf, size_t size, void *msg); /* 0 or -1 */
    void (*cleanup)(void *msg);
} reply_ops;

typedef enum assembly_state { ASSEMBLY_OPEN, ASSEMBLY_COMPLETE, ASSEMBLY_BAD } assembly_state;

/* One daemon's answer to one request, chunk by chunk. */
typedef struct assembly {
    char *daemon;
    assembly_state state;
    int32_t chunk_count;  /* 0 until the first chunk */
    int32_t received;
    void **chunks;        /* chunk_count decoded messages, in chunk order once complete */
    char why[160];        /* ASSEMBLY_BAD: what was wrong */
    uint64_t order;       /* when it finished, for results in arrival order */
} assembly;

typedef struct pending pending;

/* Builds the caller's result from what p gathered (or why it ended), hands it to p's
 * callback and frees what the callback left in it. */
typedef void (*pending_complete_fn)(trioct_client *c, pending *p);

/* A request waiting for its replies, from the moment it is sent until its completion runs.
 * Synchronous and asynchronous requests are the same record: a synchronous call waits for
 * its own and completes it on the spot; an asynchronous one is completed by pump or poll. */
struct pending {
    pending *next;          /* c->waiting */
    pending *next_ready;    /* c->ready, once an async request is done */
    int64_t request_id;
    const reply_ops *ops;
    int gather;             /* LIST: every daemon's answer, until the deadline */
    int expect;             /* gather: finish once this many answers are whole (0: never) */
    assembly *assemblies;
    size_t num_assemblies, cap_assemblies;
    size_t finished;        /* assemblies complete or bad */
    uint64_t malformed;     /* replies for this request that failed the wire check */
    int done;               /* nothing more to wait for: answered, or its deadline passed */
    int ready;              /* in c->ready */
    int bus_failed;         /* the bus failed while a sync call waited for it */
    int closed;             /* the connection closed before it was answered */

    int64_t deadline;       /* monotonic ns (client_deadline); INT64_MAX: none */
    int timeout_ms;         /* as asked (LIST: the gather window), for messages */
    size_t count;           /* rays, triangles, poses or states asked about, to check answers by */
    size_t count2;          /* states: the links of each */
    char no_daemon[TRIOCT_MAX_MESSAGE_LEN + 1]; /* the message of an unanswered request */

    /* What was sent, kept to send again while no answer comes (retries); NULL: never. */
    uint8_t *sent;
    size_t sent_size;
    char sent_channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    int64_t next_retry;     /* monotonic ns */
    int64_t retry_gap;      /* ns until the next one after it */

    int is_async;
    pending_complete_fn complete;
    void (*cb)(void);       /* the caller's callback; complete casts it back to its type */
    void *user;
};

struct trioct_client {
    lcm_t *lcm;
    int own_lcm;
    lcm_subscription_t *reply_sub;
    uint64_t client_id;
    int64_t next_request_id;
    int send_deadlines;     /* requests carry deadline_utime = now + timeout */
    trioct_admin_key admin_key; /* len 0: changes go unsigned */
    int retries;            /* requests without an answer are sent again */
    char url[256];
    char prefix[TRIOCT_MAX_PREFIX_LEN + 1];
    char reply_channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    pending *waiting;       /* every request sent and not yet completed */
    pending *ready_head, *ready_tail; /* async requests done, completions not yet run */
    size_t in_flight;       /* async requests sent and not yet completed or cancelled */
    int dispatching;        /* completions are running (pump, poll or a deferred close) */
    int closing;            /* trioct_disconnect was called from a callback */
    uint64_t finish_counter;
    char last_error[TRIOCT_MAX_MESSAGE_LEN + 1];
    trioct_client_stats stats;
};

/* ---- client.c: time, messages -------------------------------------------------------- */

/* Monotonic nanoseconds. */
int64_t client_now_ns(void);
/* The monotonic deadline, in nanoseconds, of a timeout in ms (< 0: none, as INT64_MAX). */
int64_t client_deadline(int timeout_ms);
/* Bounded copy that always terminates (NULL src gives ""). */
void client_copy(char *dst, size_t dst_len, const char *src);
/* Sets status and a printf-formatted message into r; returns status. */
int client_fail(trioct_reply *r, int status, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
/* The message of a world request nobody answered. */
void client_no_daemon_world(const trioct_client *c, const char *world, int timeout_ms, char *buf,
                            size_t len);
/* Fills r from a reply header (status, message, daemon, world, version, ids). */
void client_reply_from_header(trioct_reply *r, const trioct_reply_header_t *h, int chunks);

/* The names table of a reply's chunk 0 into out; TRIOCT_ERR_BAD_REPLY (a name too long)
 * or TRIOCT_ERR_NOMEM into r. */
int client_object_names(trioct_reply *r, int32_t count, char *const *names, trioct_object_names *out);
/* TRIOCT_OK when object indexes a table of names entries, else TRIOCT_ERR_BAD_REPLY into r
 * naming the record. */
int client_check_object(trioct_reply *r, int32_t object, const trioct_object_names *names, const char *what,
                        size_t record);
void client_object_names_free(trioct_object_names *names);

/* ---- client.c: sending --------------------------------------------------------------- */

/* Channel of kind for name; TRIOCT_ERR_BAD_REQUEST into r when the name is invalid. */
int client_channel(trioct_client *c, trioct_channel_kind kind, const char *name,
                   char out[TRIOCT_MAX_CHANNEL_LEN + 1], trioct_reply *r, const char *what);

/* How one request type is encoded (wrappers over the generated functions). */
typedef struct request_codec {
    int (*encoded_size)(const void *msg);
    int (*encode)(void *buf, int size, const void *msg); /* bytes written or < 0 */
    /* 1 when msg changes what a daemon serves, and so is signed (its auth_t last); NULL:
     * never. */
    int (*is_change)(const void *msg);
} request_codec;

/* A new request with the next request id, its deadline from timeout_ms, waiting for replies
 * of ops; NULL with r filled when out of memory or the connection is closing. */
pending *client_pending_new(trioct_client *c, const reply_ops *ops, int timeout_ms,
                            trioct_reply *r);
/* The fields every request carries for p; h->world points at world (or "") until sent. */
void client_request_header(trioct_client *c, trioct_request_header_t *h, const pending *p,
                           const char *world);
/* Encodes msg, refuses it over TRIOCT_MAX_REQUEST_BYTES, publishes it and puts p in the
 * table. Returns TRIOCT_OK, or a status with r filled and p freed (nothing was sent). */
int client_pending_send(trioct_client *c, pending *p, const char *channel,
                        const request_codec *codec, const void *msg, trioct_reply *r);
/* Unlinks p from the table and the ready queue. */
void client_pending_unlink(trioct_client *c, pending *p);
/* Frees p and what it holds (p must be unlinked). */
void client_pending_free(pending *p);

/* Frees the connection, after completing its async requests as closed. */
void client_destroy(trioct_client *c);

/* ---- client.c: waiting --------------------------------------------------------------- */

/* Handles what is queued on the bus without blocking, until nothing is, *flag is set (flag
 * may be NULL) or the deadline passes. Returns messages handled, or -1 when the bus failed. */
int client_drain(trioct_client *c, const int *flag, int64_t deadline);
/* Sends again every request due for a retry at now. */
void client_retry_due(trioct_client *c, int64_t now);
/* When the next retry is due (monotonic ns), INT64_MAX when none is. */
int64_t client_next_retry(const trioct_client *c);

/* Handles messages until *flag is set or the deadline passes. 0, or -1 when the bus failed. */
int client_wait_flag(trioct_client *c, const int *flag, int64_t deadline);

/* For a one-answer request whose waiting is over: the complete answer with r filled from
 * its first chunk's header (a daemon's error status included), or NULL with r saying why
 * (TRIOCT_ERR_NO_DAEMON with p->no_daemon, _TIMEOUT, _BAD_REPLY, _TRANSPORT). */
const assembly *client_answer(trioct_client *c, const pending *p, trioct_reply *r);
/* r for a request that ended without its answers because the bus failed or the
 * connection closed; returns 1 when that is so, else 0. */
int client_ended_early(const trioct_client *c, const pending *p, trioct_reply *r);

/* ---- client_async.c: completions ----------------------------------------------------- */

/* Queues p's completion when p is async; called once p is done. */
void client_pending_ready(trioct_client *c, pending *p);
/* Before an async call: refuses it (r filled, returns the status) on a NULL callback or a
 * closing connection. */
int client_async_check(trioct_client *c, int has_callback, trioct_reply *r);
/* After an async call's start: on TRIOCT_OK makes p async with cb and user and gives its id;
 * otherwise records r's message as the connection's last error. Returns rc. */
int client_async_started(trioct_client *c, int rc, const trioct_reply *r, pending *p,
                         void (*cb)(void), void *user, int64_t *request_id);
/* Completes every async request still in flight as closed (TRIOCT_ERR_TRANSPORT), so their
 * callers' user data can be released; frees the rest. */
void client_close_requests(trioct_client *c);
/* A sync call's wait: handles messages until p is answered or its deadline passes, then runs
 * its completion with cb and user (which keep the result) and frees it. */
void client_sync_finish(trioct_client *c, pending *p, void (*cb)(void), void *user);

/* ---- per-type encoders and result builders shared across files ----------------------- */

extern const reply_ops client_admin_reply_ops;

struct _trioct_world_info_t;
/* Converts one world; returns 0, or -1 when it breaks the protocol's caps (why in r). */
int client_world_info(trioct_world_info *out, const struct _trioct_world_info_t *in,
                      const char *daemon, trioct_reply *r);

#endif
