/* From request bytes to reply bytes: the whole protocol of trioctd as pure functions of the
 * message, the worlds held and the clock, so it is tested without a network or a loop. The
 * daemon peeks on the loop thread (cheap: check the bytes, read the header) and handles on
 * a worker thread, or on the loop thread itself when the request is small
 * (dispatch_is_small); publishing stays on the loop thread. */
#ifndef TRIOCT_SERVICE_DISPATCH_H
#define TRIOCT_SERVICE_DISPATCH_H

#include <pthread.h>
#include <stddef.h>
#include <stdint.h>

#include "failed_worlds.h"
#include "load_table.h"
#include "../../common/channels.h"
#include "../world/registry.h"
#include "../world/scene.h"
#include "../world/world.h"
#include "admin_auth.h"

typedef struct dispatch_ctx {
    registry *worlds;
    char prefix[TRIOCT_MAX_PREFIX_LEN + 1];
    char daemon[TRIOCT_MAX_NAME_LEN + 1];
    char world_dir[TRIOCT_MAX_PATH_LEN];
    /* Where builds get meshes and memory: env points into loader and memory, or is zero
     * (files parsed in process, no budget: tests). */
    world_env env;
    mesh_loader loader;
    memory_account memory;
    /* The scene worlds not held because their build failed (NULL: none recorded): LIST
     * shows them and their requests are answered TRIOCT_ERR_LOAD_FAILED with why. */
    failed_worlds *failed;
    /* The builds under way, for status (NULL: not reported). */
    load_table *loads;
    /* The guard on changes over the bus; NULL refuses them all (no key). */
    admin_auth *auth;
    /* The scene LOAD reads sections from; swapped by the loop thread on SIGHUP. */
    pthread_mutex_t scene_lock;
    const scene *scene;
} dispatch_ctx;

/* Request types, for counters (status_t.served). */
typedef enum request_type {
    REQUEST_RAY = 0,
    REQUEST_TRIANGLE = 1,
    REQUEST_MESH = 2,
    REQUEST_ADMIN = 3,
    REQUEST_OBJECTS = 4,
    REQUEST_STATE = 5,
    REQUEST_DISTANCE = 6,
    REQUEST_TYPE_COUNT
} request_type;

/* What peeking a message found. */
typedef struct dispatch_request {
    request_type type;
    trioct_channel_kind channel_kind;
    char channel_name[TRIOCT_MAX_NAME_LEN + 1]; /* world or daemon named by the channel */
    int64_t client_id;
    int64_t request_id;
    char reply_channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    char world[TRIOCT_MAX_NAME_LEN + 1]; /* header.world when it is a valid name, else "" */
    int64_t deadline_utime;
    int8_t admin_op;          /* REQUEST_ADMIN only */
    int8_t detail;            /* REQUEST_RAY/TRIANGLE/MESH: the detail asked for, echoed */
    int32_t items;            /* REQUEST_RAY: num_rays; REQUEST_TRIANGLE: num_triangles; else 0 */
    double extent;            /* REQUEST_TRIANGLE with at most DISPATCH_INLINE_MAX_TRIANGLES:
                                 the longest side of any query triangle's bounding box (NaN
                                 when a coordinate is not finite); else +infinity */
} dispatch_request;

typedef enum dispatch_peek_result {
    PEEK_REQUEST = 0,     /* a well-formed request to answer */
    PEEK_NOT_MINE = 1,    /* a protocol channel this daemon does not answer (a LOAD for
                             another daemon, a status or reply message): ignore, no count */
    PEEK_MALFORMED = -1,  /* bad bytes, wrong fingerprint, a header that cannot be answered
                             (invalid reply channel): drop and count */
} dispatch_peek_result;

/* Checks the bytes with the hand-written validator and reads the header (and the counts
 * dispatch_is_small needs). Never decodes
 * untrusted bytes with the generated decoders. A reply channel that is not a valid name, or
 * that is one of this prefix's protocol channels (a daemon would hear its own reply), cannot
 * be answered: PEEK_MALFORMED. */
dispatch_peek_result dispatch_peek(const dispatch_ctx *ctx, const char *channel, const void *bytes,
                                   size_t size, dispatch_request *req);

typedef struct dispatch_chunk {
    uint8_t *data;
    size_t size;
} dispatch_chunk;

typedef struct dispatch_reply {
    char channel[TRIOCT_MAX_CHANNEL_LEN + 1]; /* where to publish every chunk */
    dispatch_chunk *chunks;                   /* each under TRIOCT_MAX_CHUNK_BYTES */
    size_t chunk_count;
    int status;                               /* the reply's trioct_status */
    request_type type;
    int worlds_changed;                       /* a LOAD or UNLOAD changed the registry:
                                                 the loop re-syncs its subscriptions */
} dispatch_reply;

/* Answers a message that dispatch_peek accepted (it checks again: a pure function must not
 * trust its caller). Runs on any thread, as many at once as wanted; a LOAD builds the
 * world here. Returns 0 with
 * the reply in out (an error reply too: out->status says which), or -1 with out empty when
 * peeking would not give PEEK_REQUEST, or when not even a one-chunk error reply could be
 * allocated. now_utime is the clock the deadline is checked against. */
int dispatch_handle(dispatch_ctx *ctx, const char *channel, const void *bytes, size_t size,
                    int64_t now_utime, dispatch_reply *out);
/* The same, with heard_utime the clock a change's timestamp is checked against: when the
 * bus delivered the message, or, for a file:// input, the log's timestamp of the event
 * (dispatch_handle takes now_utime for both). */
int dispatch_handle_heard(dispatch_ctx *ctx, const char *channel, const void *bytes, size_t size, int64_t now_utime,
                          int64_t heard_utime, dispatch_reply *out);

/* Small requests: the daemon answers them on its loop thread as they are read, instead of
 * handing them to a worker and the reply back (two thread wake-ups, which on a small
 * machine cost more than the work itself); large ones keep the workers, so the loop stays
 * free to read, refuse and publish. Measured with dispatch_handle on one core (a 100,352-
 * and a 1,002,528-triangle terrain, exact mode): one closest-hit ray 2.3-2.9 us, eight
 * 12.6-13.6 us, ANY, ALL and TOUCH alike; one query triangle whose bounding box spans 14
 * leaves 2.7 us yes/no, 10.5 us with ids or segments, 70 leaves 4 us yes/no but 74-131 us
 * with ids or segments (its contacts grow with its size relative to the leaves). Handing a
 * one-ray request to the pool and back cost 20-60 us more than answering it on the loop
 * thread, on this project's 2-core machine (bench/daemon_bench.c: the daemon's own share of
 * the round trip fell from 25-62 us to about 5 us, the round trip from 1.3-1.9x a bare LCM
 * ping-pong to 1.0-1.3x). So a request is small when its work is a fraction of that
 * hand-off: at most 8 rays; at most 2 triangles, each within 16 leaves of the world's
 * resolution. Mesh and admin requests are never small: a named shape may hold thousands of
 * triangles, and a LOAD builds a world. */
#define DISPATCH_INLINE_MAX_RAYS 8
#define DISPATCH_INLINE_MAX_TRIANGLES 2
#define DISPATCH_INLINE_MAX_TRIANGLE_LEAVES 16

/* Whether a request dispatch_peek accepted is small (above). A triangle request asks the
 * registry for its world's resolution; one for a world not held is small (its answer is an
 * error). Any thread. */
int dispatch_is_small(dispatch_ctx *ctx, const dispatch_request *req);

/* An error reply to a peeked request without doing its work (BUSY, STOPPING): one chunk,
 * world_version 0, message or, when NULL, the status table's text. 0, or -1 (no memory). */
int dispatch_error(const dispatch_ctx *ctx, const dispatch_request *req, int status,
                   const char *message, dispatch_reply *out);

void dispatch_reply_free(dispatch_reply *reply);

/* Fills a world_info_t summary of an entry: used by INFO/LIST/LOAD replies and the status
 * message, so there is one conversion. Declared with the generated type's tag so this header
 * does not need the generated code. info's strings point into the entry, ctx and static
 * text, and info->shapes into shape_names: all valid while the entry is held. Allocates
 * nothing. */
struct _trioct_world_info_t;
void dispatch_world_info(const dispatch_ctx *ctx, const registry_entry *entry,
                         struct _trioct_world_info_t *info,
                         char *shape_names[TRIOCT_MAX_SHAPES]);

/* The same for a scene world whose build failed: version 0, its source and the error as
 * last_error, nothing else. info's strings point into f and ctx. */
void dispatch_failed_world_info(const dispatch_ctx *ctx, const failed_world *f, struct _trioct_world_info_t *info);

#endif
