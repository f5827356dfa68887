/* libtrioct: the client of trioctd, the collision-query daemon. The one public header.
 *
 * A connection (trioct_client) joins an LCM bus, picks a random client id and its own reply
 * channel, and sends ray, triangle, mesh and world-admin requests to whichever daemon holds
 * the world. Every call here is synchronous with a timeout in milliseconds (< 0: no limit;
 * 0: only what is already queued) and returns a status code:
 *
 *   0 TRIOCT_OK, and the daemon's codes 1..13 (TRIOCT_ERR_BAD_REQUEST, _UNKNOWN_WORLD,
 *   _NONFINITE, _ZERO_DIRECTION, _OVER_CAP, _EFFECT, _BAD_PATH, _DEADLINE, _BUSY,
 *   _LOAD_FAILED, _STOPPING, _UNKNOWN_SHAPE, _NOMEM), passed through with the daemon's message
 *   (TRIOCT_ERR_NOMEM also when this process runs out of memory for a request or result);
 *   100 TRIOCT_ERR_TIMEOUT      part of the reply came, not all of it, within the timeout;
 *   101 TRIOCT_ERR_NO_DAEMON    nothing came back: no daemon serves the world (or answers);
 *   102 TRIOCT_ERR_TRANSPORT    the LCM bus could not be opened or used;
 *   103 TRIOCT_ERR_BAD_REPLY    replies came back but could not be made sense of.
 *
 * The table and its texts are trioct_status.h, included below: trioct_status_text(code) and
 * trioct_status_name(code). Codes are plain ints here so that a newer daemon's code still
 * passes through an older client unharmed.
 *
 * Client-side refusals happen before anything is sent: a request over a documented cap
 * (trioct_limits.h) gets TRIOCT_ERR_OVER_CAP with a message naming the cap, a malformed one
 * (NULL arrays, a name that is not [A-Za-z0-9_], an unknown detail) TRIOCT_ERR_BAD_REQUEST.
 *
 * Results: every call fills its result struct, whatever happens: .reply.status equals the
 * returned code and .reply.message says why in words. Free every result with its _free
 * function (safe on a result that a failed call filled, and twice). Nothing here aborts
 * the process or keeps global state.
 *
 * Threads: a connection is used by one thread at a time (calls on one connection must not
 * overlap, including from inside an LCM handler of a shared LCM instance). Separate
 * connections are independent and may be used from separate threads at once.
 */
#ifndef TRIOCT_H
#define TRIOCT_H

#include <stddef.h>
#include <stdint.h>

#include "trioct_limits.h"
#include "trioct_status.h"

#ifdef __cplusplus
extern "C" {
#endif

struct _lcm_t; /* lcm_t of <lcm/lcm.h>, for callers that share their own LCM instance */

typedef struct trioct_client trioct_client;

typedef struct trioct_vec3 {
    double x, y, z;
} trioct_vec3;

typedef struct trioct_triangle {
    trioct_vec3 a, b, c;
} trioct_triangle;

/* A rigid pose: p' = R p + t, R row-major 3x3. */
typedef struct trioct_pose {
    double r[9];
    trioct_vec3 t;
} trioct_pose;

/* Accuracy modes (the wire's values). */
enum {
    TRIOCT_ACCURACY_WORLD = -1, /* the world's own mode */
    TRIOCT_ACCURACY_EXACT = 0,
    TRIOCT_ACCURACY_SEED = 1,
    TRIOCT_ACCURACY_FAST = 2
};

/* What a world serves (world info .effects bits; 0 in a load means all). */
enum {
    TRIOCT_EFFECT_RAYS = 1,
    TRIOCT_EFFECT_TRIANGLES = 2,
    TRIOCT_EFFECT_MESHES = 4
};

/* ---- Connection ---------------------------------------------------------------------- */

typedef struct trioct_connect_options {
    const char *url;    /* LCM URL; NULL: $LCM_DEFAULT_URL, else LCM's default */
    const char *prefix; /* channel prefix, [A-Za-z0-9_] up to TRIOCT_MAX_PREFIX_LEN;
                           NULL: "TRIOCT" */
    /* Non-NULL: use this LCM instance instead of creating one (url then only names the bus
     * in messages). The caller keeps owning it, must not call lcm_handle on it while a
     * trioct call runs, and should know that trioct calls dispatch its other subscriptions'
     * messages too when they drain the bus. */
    struct _lcm_t *lcm;
    int queue_capacity; /* messages the reply subscription buffers; 0: 4096 (a chunked
                           reply is many messages at once) */
} trioct_connect_options;

/* Connects (opt may be NULL for all defaults). On failure returns NULL, sets *status
 * (TRIOCT_ERR_TRANSPORT or TRIOCT_ERR_BAD_REQUEST) and writes why into err (both optional). */
trioct_client *trioct_connect(const trioct_connect_options *opt, int *status, char *err,
                              size_t err_len);

/* Unsubscribes and, when the connection created it, closes the LCM instance. NULL is fine. */
void trioct_disconnect(trioct_client *c);

/* The file descriptor that becomes readable when messages wait; for poll/select/libuv
 * loops, which then call trioct_pump. */
int trioct_fileno(const trioct_client *c);

/* Handles the messages already queued without blocking (replies that arrive after their
 * call gave up are dropped and counted here). Returns how many were handled, or -1 when the
 * bus failed. */
int trioct_pump(trioct_client *c);

uint64_t trioct_client_id(const trioct_client *c);     /* random, nonzero */
const char *trioct_reply_channel(const trioct_client *c); /* <prefix>_R_<16 hex digits> */
const char *trioct_url(const trioct_client *c);
const char *trioct_prefix(const trioct_client *c);

/* What the connection saw; for diagnostics and tests. */
typedef struct trioct_client_stats {
    uint64_t requests_sent;
    uint64_t chunks_accepted;    /* reply chunks taken into a result */
    uint64_t foreign_client;     /* replies carrying another client's id */
    uint64_t unmatched;          /* replies to no request waiting (another or a past one) */
    uint64_t duplicate_chunks;   /* chunks already received (or of a finished answer) */
    uint64_t malformed;          /* replies failing the wire check; dropped */
} trioct_client_stats;

void trioct_client_get_stats(const trioct_client *c, trioct_client_stats *out);

/* ---- Replies ------------------------------------------------------------------------- */

/* What every result carries. For a daemon's answer: the daemon's status and message and
 * who answered; for a client-side outcome (timeout, refusal): the code and why. Strings
 * longer than these buffers (longer than the protocol allows) are truncated. */
typedef struct trioct_reply {
    int status;
    char message[TRIOCT_MAX_MESSAGE_LEN + 1];
    char daemon[TRIOCT_MAX_NAME_LEN + 1];
    char world[TRIOCT_MAX_NAME_LEN + 1];
    int64_t world_version; /* the world's build the answer comes from */
    int64_t request_id;    /* 0 when nothing was sent */
    int chunks;            /* how many messages the answer came in */
} trioct_reply;

/* ---- Rays ---------------------------------------------------------------------------- */

enum { TRIOCT_RAY_ANY = 0, TRIOCT_RAY_CLOSEST = 1, TRIOCT_RAY_ALL = 2 };

typedef struct trioct_ray_query {
    const char *world;
    int detail;   /* TRIOCT_RAY_ANY, _CLOSEST or _ALL */
    int accuracy; /* TRIOCT_ACCURACY_* */
    double tmin;  /* finite */
    double tmax;  /* may be INFINITY */
    int max_hits; /* ALL: hits stored per ray, 1..TRIOCT_MAX_HITS_PER_RAY; else ignored */
    size_t count; /* rays, at most TRIOCT_MAX_RAYS */
    const trioct_vec3 *origins;    /* count each */
    const trioct_vec3 *directions;
} trioct_ray_query;

/* CLOSEST, the world's accuracy, t in [0, INFINITY), TRIOCT_MAX_HITS_PER_RAY; no rays. */
trioct_ray_query trioct_ray_query_default(const char *world);

typedef struct trioct_ray_hit {
    int32_t ray;      /* index of the ray in the query */
    double t;
    int32_t triangle; /* world triangle id */
    double u, v;      /* barycentric weights of the triangle's vertices b and c */
    trioct_vec3 normal;
} trioct_ray_hit;

typedef struct trioct_ray_result {
    trioct_reply reply;
    int detail;
    size_t num_rays;
    int32_t *found;        /* per ray: crossings (0 or 1 unless ALL; for ALL it may exceed
                              the hits stored for the ray when max_hits cut the list) */
    size_t num_hits;
    trioct_ray_hit *hits;  /* by ray, then by increasing t */
} trioct_ray_result;

int trioct_rays(trioct_client *c, const trioct_ray_query *q, int timeout_ms,
                trioct_ray_result *out);
void trioct_ray_result_free(trioct_ray_result *r);

/* ---- Triangles ----------------------------------------------------------------------- */

enum { TRIOCT_TRI_YESNO = 0, TRIOCT_TRI_IDS = 1, TRIOCT_TRI_SEGMENTS = 2 };

typedef struct trioct_triangle_query {
    const char *world;
    int detail;   /* TRIOCT_TRI_YESNO, _IDS or _SEGMENTS */
    int accuracy; /* TRIOCT_ACCURACY_* */
    size_t count; /* at most TRIOCT_MAX_TRIANGLES */
    const trioct_triangle *triangles;
} trioct_triangle_query;

typedef struct trioct_contact {
    int32_t query;    /* index of the query triangle */
    int32_t triangle; /* world triangle id */
} trioct_contact;

typedef struct trioct_segment {
    trioct_vec3 p, q; /* p == q for a point contact */
} trioct_segment;

typedef struct trioct_triangle_result {
    trioct_reply reply;
    int detail;
    size_t num_triangles;
    int32_t *found;            /* per query triangle: world triangles touched (0/1: YESNO) */
    size_t num_contacts;
    trioct_contact *contacts;  /* IDS, SEGMENTS: sorted by (query, triangle) */
    trioct_segment *segments;  /* SEGMENTS: one per contact; else NULL */
} trioct_triangle_result;

int trioct_triangles(trioct_client *c, const trioct_triangle_query *q, int timeout_ms,
                     trioct_triangle_result *out);
void trioct_triangle_result_free(trioct_triangle_result *r);

/* ---- Mesh at poses ------------------------------------------------------------------- */

enum { TRIOCT_MESH_YESNO = 0, TRIOCT_MESH_PAIRS = 1 };

typedef struct trioct_mesh_query {
    const char *world;
    int detail;        /* TRIOCT_MESH_YESNO or _PAIRS */
    int accuracy;      /* TRIOCT_ACCURACY_* */
    const char *shape; /* a query shape the world's scene names; NULL or "": the inline
                          triangles below */
    size_t num_shape_triangles; /* at most TRIOCT_MAX_INLINE_SHAPE_TRIANGLES */
    const trioct_triangle *shape_triangles;
    size_t num_poses;  /* at most TRIOCT_MAX_POSES */
    const trioct_pose *poses;
} trioct_mesh_query;

typedef struct trioct_mesh_pair {
    int32_t pose; /* index of the pose in the query */
    int32_t shape_triangle;
    int32_t world_triangle;
} trioct_mesh_pair;

typedef struct trioct_mesh_result {
    trioct_reply reply;
    int detail;
    size_t num_poses;
    int32_t *found;          /* per pose: touching pairs (0/1 for YESNO) */
    size_t num_pairs;
    trioct_mesh_pair *pairs; /* PAIRS: sorted by (pose, shape triangle, world triangle) */
} trioct_mesh_result;

int trioct_mesh(trioct_client *c, const trioct_mesh_query *q, int timeout_ms,
                trioct_mesh_result *out);
void trioct_mesh_result_free(trioct_mesh_result *r);

/* ---- Worlds -------------------------------------------------------------------------- */

typedef struct trioct_world_info {
    char name[TRIOCT_MAX_NAME_LEN + 1];
    char daemon[TRIOCT_MAX_NAME_LEN + 1]; /* the daemon holding it */
    int64_t version;                      /* 1 at the first load, +1 at every rebuild */
    char source[TRIOCT_MAX_PATH_LEN + 1]; /* scene section or mesh path */
    char accuracy[16];                    /* "exact", "seed" or "fast" */
    double seed_epsilon;
    int effects; /* TRIOCT_EFFECT_* bits */

    int64_t triangles, vertices, degenerate, duplicates;
    trioct_vec3 bbox_min, bbox_max;

    int64_t nodes, leaves;
    int max_level;     /* L_max */
    double resolution; /* d */
    double world_size; /* D */
    trioct_vec3 world_min;

    int64_t bytes_nodes, bytes_leaf_lists, bytes_triangles, bytes_effects, bytes_total;
    double build_seconds;

    int64_t queries;                             /* requests answered for this world */
    char last_error[TRIOCT_MAX_MESSAGE_LEN + 1]; /* why the last reload failed, or "" */
    int num_shapes;
    char shapes[TRIOCT_MAX_SHAPES][TRIOCT_MAX_NAME_LEN + 1];
} trioct_world_info;

/* Load, unload and info answer with the world(s) concerned. */
typedef struct trioct_admin_result {
    trioct_reply reply;
    size_t num_worlds;
    trioct_world_info *worlds;
} trioct_admin_result;

void trioct_admin_result_free(trioct_admin_result *r);

typedef struct trioct_load_options {
    const char *world;     /* the name it is served under */
    const char *daemon;    /* the daemon that builds it; NULL: "trioctd" */
    const char *mesh_path; /* relative to the daemon's world directory; NULL or "": the
                              daemon scene's section named world */
    double resolution;     /* <= 0: the seed's heuristic */
    int accuracy;          /* TRIOCT_ACCURACY_*; WORLD means exact */
    double seed_epsilon;   /* <= 0: default */
    int effects;           /* TRIOCT_EFFECT_* bits; 0: all */
} trioct_load_options;

/* Loads (or rebuilds) a world; the answer comes when it is built, so give the timeout room. */
int trioct_load(trioct_client *c, const trioct_load_options *opt, int timeout_ms,
                trioct_admin_result *out);
int trioct_unload(trioct_client *c, const char *world, int timeout_ms, trioct_admin_result *out);
int trioct_info(trioct_client *c, const char *world, int timeout_ms, trioct_admin_result *out);

typedef struct trioct_list_options {
    int gather_ms;      /* > 0: stop gathering after this long even when the timeout is later */
    int expect_daemons; /* > 0: stop as soon as this many daemons' answers are in (whole, or
                           found bad) */
} trioct_list_options;

typedef struct trioct_list_result {
    /* TRIOCT_OK when at least one daemon answered and every answer came whole;
     * TRIOCT_ERR_NO_DAEMON when none answered; TRIOCT_ERR_TIMEOUT or TRIOCT_ERR_BAD_REPLY
     * when some answer came in part or wrong (the whole answers are still below). */
    trioct_reply reply;
    size_t num_daemons;
    trioct_reply *daemons;     /* each answering daemon: its name, status and message */
    size_t num_worlds;
    trioct_world_info *worlds; /* the union, each with .daemon set; by daemon, in the order
                                  the daemons' answers completed */
} trioct_list_result;

/* Asks every daemon on the bus for its worlds and gathers the answers until the timeout,
 * the gather window or the expected count, whichever comes first (opt may be NULL: the
 * whole timeout). Without a timeout, one of the other two is needed. */
int trioct_list(trioct_client *c, const trioct_list_options *opt, int timeout_ms,
                trioct_list_result *out);
void trioct_list_result_free(trioct_list_result *r);

/* ---- Daemon status (heartbeat) ------------------------------------------------------- */

enum {
    TRIOCT_DAEMON_STARTING = 0,
    TRIOCT_DAEMON_READY = 1,
    TRIOCT_DAEMON_RELOADING = 2,
    TRIOCT_DAEMON_STOPPING = 3
};

typedef struct trioct_daemon_status {
    trioct_reply reply; /* .daemon: who sent it; .status: the call's outcome */
    int64_t utime;
    char version[64];
    int64_t uptime_us;
    int state; /* TRIOCT_DAEMON_* */
    int threads, queue_depth, queue_capacity;
    int64_t served[4]; /* answered requests: ray, triangle, mesh, admin */
    int64_t malformed; /* messages the daemon dropped before decoding */
    size_t num_status_codes;
    int64_t *replies_by_status; /* indexed by status code */
    int64_t latency_p50_us, latency_p99_us, latency_count;
    size_t num_worlds;
    trioct_world_info *worlds;
} trioct_daemon_status;

/* Waits for the next status message heard while the call runs (from daemon, or from any
 * daemon when daemon is NULL): the connection listens to the heartbeat only during this
 * call, so a status is never stale. TRIOCT_ERR_NO_DAEMON when none came in time. */
int trioct_next_status(trioct_client *c, const char *daemon, int timeout_ms,
                       trioct_daemon_status *out);
void trioct_daemon_status_free(trioct_daemon_status *s);

#ifdef __cplusplus
}
#endif

#endif
