/* What the files of libtrioct share and its users never see: the connection, the table of
 * requests waiting for replies, and chunk reassembly. client.c owns all three; each
 * client_<type>.c encodes its requests and turns reassembled chunks into a result. */
#ifndef TRIOCT_CLIENT_INTERNAL_H
#define TRIOCT_CLIENT_INTERNAL_H

#include <lcm/lcm.h>
#include <stdint.h>

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

/* A request waiting for its replies. Sync calls keep it on their stack. */
typedef struct pending {
    struct pending *next;
    int64_t request_id;
    const reply_ops *ops;
    int gather;             /* LIST: every daemon's answer, until the deadline */
    int expect;             /* gather: finish once this many answers are whole (0: never) */
    assembly *assemblies;
    size_t num_assemblies, cap_assemblies;
    size_t finished;        /* assemblies complete or bad */
    uint64_t malformed;     /* replies for this request that failed the wire check */
    int done;               /* nothing more to wait for */
} pending;

struct trioct_client {
    lcm_t *lcm;
    int own_lcm;
    lcm_subscription_t *reply_sub;
    uint64_t client_id;
    int64_t next_request_id;
    char url[256];
    char prefix[TRIOCT_MAX_PREFIX_LEN + 1];
    char reply_channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    pending *waiting;       /* requests waiting for replies */
    uint64_t finish_counter;
    trioct_client_stats stats;
};

/* ---- client.c: time, messages -------------------------------------------------------- */

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

/* ---- client.c: sending --------------------------------------------------------------- */

/* Channel of kind for name; TRIOCT_ERR_BAD_REQUEST into r when the name is invalid. */
int client_channel(trioct_client *c, trioct_channel_kind kind, const char *name,
                   char out[TRIOCT_MAX_CHANNEL_LEN + 1], trioct_reply *r, const char *what);
/* Request ids count up from 1 per connection. */
int64_t client_next_request_id(trioct_client *c);
/* The fields every request carries; h->world points at world (or "") until sent. */
void client_request_header(trioct_client *c, trioct_request_header_t *h, int64_t request_id,
                           const char *world);

/* How one request type is encoded (wrappers over the generated functions). */
typedef struct request_codec {
    int (*encoded_size)(const void *msg);
    int (*encode)(void *buf, int size, const void *msg); /* bytes written or < 0 */
} request_codec;

/* Encodes msg, refuses it over TRIOCT_MAX_REQUEST_BYTES (nothing sent), publishes it.
 * Returns TRIOCT_OK, or a status with r filled. */
int client_send(trioct_client *c, const char *channel, const request_codec *codec,
                const void *msg, trioct_reply *r);

/* One request, one answer: sends msg (whose header carries p's request id; p begun by the
 * caller, who also ends it), waits, and on TRIOCT_OK or a daemon's error status gives the
 * complete answer in *answer with r filled from its first chunk's header. Otherwise *answer
 * is NULL and r says why. Returns r->status. */
int client_call(trioct_client *c, pending *p, const char *channel, const request_codec *codec,
                const void *msg, int timeout_ms, const char *no_daemon_msg, trioct_reply *r,
                const assembly **answer);

/* ---- client.c: waiting --------------------------------------------------------------- */

void client_pending_begin(trioct_client *c, pending *p, const reply_ops *ops, int64_t request_id);
/* Unlinks p and frees what it holds. */
void client_pending_end(trioct_client *c, pending *p);
/* Handles messages until p is done or the deadline (client_deadline) passes. Returns 0, or
 * -1 when the bus failed. */
int client_wait(trioct_client *c, pending *p, int64_t deadline);
/* Handles messages until *flag is set or the deadline passes (status waits). */
int client_wait_flag(trioct_client *c, const int *flag, int64_t deadline);

/* After client_wait for a one-answer request: the complete answer, or NULL with r filled
 * (TRIOCT_ERR_NO_DAEMON with no_daemon_msg, TRIOCT_ERR_TIMEOUT, TRIOCT_ERR_BAD_REPLY,
 * TRIOCT_ERR_TRANSPORT when wait_rc < 0). */
const assembly *client_single_answer(trioct_client *c, pending *p, int wait_rc, int timeout_ms,
                                     const char *no_daemon_msg, trioct_reply *r);

/* ---- per-type encoders and result builders shared across files ----------------------- */

extern const reply_ops client_admin_reply_ops;

struct _trioct_world_info_t;
/* Converts one world; returns 0, or -1 when it breaks the protocol's caps (why in r). */
int client_world_info(trioct_world_info *out, const struct _trioct_world_info_t *in,
                      const char *daemon, trioct_reply *r);

#endif
