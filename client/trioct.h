/* libtrioct: the client of trioctd, the collision-query daemon. The one public header.
 *
 * A connection (trioct_client) joins an LCM bus, picks a random client id and its own reply
 * channel, and sends ray, triangle, mesh, distance and world-admin requests to whichever
 * daemon holds the world. Every request comes in two forms: a synchronous call with a timeout in
 * milliseconds (< 0: no limit; 0: only what is already queued) that returns a status code,
 * and an asynchronous one (trioct_rays_async, ...) that returns at once and hands the result
 * to a callback later, from trioct_pump or trioct_poll (see "Asynchronous calls" below;
 * docs/client.md shows both). The status codes:
 *
 *   0 TRIOCT_OK, and the daemon's codes 1..13 (TRIOCT_ERR_BAD_REQUEST, _UNKNOWN_WORLD,
 *   _NONFINITE, _ZERO_DIRECTION, _OVER_CAP, _EFFECT, _BAD_PATH, _DEADLINE, _BUSY,
 *   _LOAD_FAILED, _STOPPING, _UNKNOWN_SHAPE, _NOMEM), passed through with the daemon's message
 *   (TRIOCT_ERR_NOMEM also when this process runs out of memory for a request or result);
 *   100 TRIOCT_ERR_TIMEOUT      part of the reply came, not all of it, within the timeout;
 *   101 TRIOCT_ERR_NO_DAEMON    nothing came back: no daemon serves the world (or answers);
 *   102 TRIOCT_ERR_TRANSPORT    the LCM bus could not be opened or used (or, for a request in
 *                               flight, the connection was closed before the answer came);
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
 * overlap, including from inside an LCM handler of a shared LCM instance); callbacks run on
 * the thread that calls trioct_pump or trioct_poll. Separate connections are independent and
 * may be used from separate threads at once.
 */
#ifndef TRIOCT_H
#define TRIOCT_H

#include <stddef.h>
#include <stdint.h>

/* The headers beside this one, wherever it is installed. */
#include "trioct_limits.h"
#include "trioct_status.h"

/* The shared library exports what this header declares and nothing else (it is built with
 * -fvisibility=hidden); TRIOCT_API marks each declaration. */
#if defined(__GNUC__) || defined(__clang__)
#define TRIOCT_API __attribute__((visibility("default")))
#else
#define TRIOCT_API
#endif

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
    TRIOCT_EFFECT_MESHES = 4,
    TRIOCT_EFFECT_DISTANCE = 8
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
    /* Nonzero: every request with a timeout carries deadline_utime = now + timeout (the
     * wall clock, microseconds), and a daemon that cannot start it by then answers
     * TRIOCT_ERR_DEADLINE at once instead of working for a caller that has given up. Needs
     * the clocks of client and daemon hosts in step. 0: no deadline is sent. */
    int send_deadlines;
    /* A file holding the daemon's admin key (hex, see trioctd(8)): LOAD, UNLOAD and object
     * edits are signed with it, and a daemon refuses them unsigned (TRIOCT_ERR_DENIED).
     * NULL: $TRIOCT_KEY_FILE when set; else requests go unsigned. A file that cannot be
     * used (missing, not hex, readable by others) fails the connect. */
    const char *admin_key_file;
    /* A request whose answer has not come is sent again, the same bytes, after 250 ms, then
     * after twice as long each time (at most 4 s apart), until its timeout: UDP drops
     * messages on a busy host, and a daemon answers a retry from its reply cache without
     * working it twice. Nonzero: never (each request is sent once). */
    int no_retries;
} trioct_connect_options;

/* Connects (opt may be NULL for all defaults). On failure returns NULL, sets *status
 * (TRIOCT_ERR_TRANSPORT or TRIOCT_ERR_BAD_REQUEST) and writes why into err (both optional). */
TRIOCT_API trioct_client *trioct_connect(const trioct_connect_options *opt, int *status,
                                         char *err, size_t err_len);

/* Unsubscribes and, when the connection created it, closes the LCM instance. NULL is fine.
 * Asynchronous requests still in flight complete first, their callbacks called with
 * TRIOCT_ERR_TRANSPORT ("closed before the answer came") unless their answer was already
 * whole, so that what their user pointers hold can be released. Called from a completion
 * callback, it takes effect when the trioct_pump or trioct_poll running the callback returns
 * (the connection must not be used after that). */
TRIOCT_API void trioct_disconnect(trioct_client *c);

/* The file descriptor that becomes readable when messages wait; for poll/select/libuv
 * loops, which then call trioct_pump (and also when trioct_next_timeout_ms says so). It is
 * LCM's notification pipe, not a socket: readable does not promise a whole reply. */
TRIOCT_API int trioct_fileno(const trioct_client *c);

/* Handles the messages already queued without blocking (replies that arrive after their
 * call gave up are dropped and counted here), then fires the timeouts of asynchronous
 * requests whose deadline has passed and runs the completions that are due. Returns how
 * many messages were handled, or -1 when the bus failed or when called from inside a
 * completion callback (trioct_last_error says which). */
TRIOCT_API int trioct_pump(trioct_client *c);

TRIOCT_API uint64_t trioct_client_id(const trioct_client *c); /* random, nonzero */
TRIOCT_API const char *trioct_reply_channel(const trioct_client *c); /* <prefix>_R_<16 hex> */
TRIOCT_API const char *trioct_url(const trioct_client *c);
TRIOCT_API const char *trioct_prefix(const trioct_client *c);

/* What the connection saw; for diagnostics and tests. */
typedef struct trioct_client_stats {
    uint64_t requests_sent;
    uint64_t chunks_accepted;    /* reply chunks taken into a result */
    uint64_t foreign_client;     /* replies carrying another client's id */
    uint64_t unmatched;          /* replies to no request waiting (another or a past one) */
    uint64_t duplicate_chunks;   /* chunks already received (or of a finished answer) */
    uint64_t malformed;          /* replies failing the wire check; dropped */
    uint64_t retries;            /* requests sent again because no answer had come (the
                                    same bytes: a daemon answers a retry from its cache) */
} trioct_client_stats;

TRIOCT_API void trioct_client_get_stats(const trioct_client *c, trioct_client_stats *out);

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

/* The objects a result's records name: each record's `object` indexes names. A world is
 * a set of named objects; a scene section without objects is one object named after the
 * world. Only objects some record names are listed, in the world's object (name) order. */
typedef struct trioct_object_names {
    size_t count;
    char (*names)[TRIOCT_MAX_NAME_LEN + 1];
} trioct_object_names;

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
TRIOCT_API trioct_ray_query trioct_ray_query_default(const char *world);

typedef struct trioct_ray_hit {
    int32_t ray;      /* index of the ray in the query */
    double t;
    int32_t object;   /* index into the result's objects.names */
    int32_t triangle; /* triangle id within that object's mesh */
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
    trioct_object_names objects;
} trioct_ray_result;

TRIOCT_API int trioct_rays(trioct_client *c, const trioct_ray_query *q, int timeout_ms,
                           trioct_ray_result *out);
TRIOCT_API void trioct_ray_result_free(trioct_ray_result *r);

/* How a ray meets a triangle (docs/client.md, "Contact rules"). CROSSING, what trioct_rays
 * asks: each crossing of a surface counted once (watertight), so a ray grazing an edge or
 * sliding along a face may pass. TOUCH: every triangle the segment [tmin, tmax] shares a
 * point with, edges, vertices, faces it lies in and zero-area triangles included, at the
 * smallest such t: ANY becomes a conservative line-of-sight test. TOUCH is decided exactly:
 * with TRIOCT_ACCURACY_WORLD it runs exact whatever the world's mode, and SEED or FAST with
 * it is TRIOCT_ERR_BAD_REQUEST. */
enum { TRIOCT_CONTACT_CROSSING = 0, TRIOCT_CONTACT_TOUCH = 1 };

/* trioct_rays with a contact rule (an unknown one is TRIOCT_ERR_BAD_REQUEST). A separate
 * call rather than a field of trioct_ray_query, so that programs built against an earlier
 * trioct.h keep working with this library unchanged. */
TRIOCT_API int trioct_rays_contact(trioct_client *c, const trioct_ray_query *q, int contact,
                                   int timeout_ms, trioct_ray_result *out);

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
    int32_t object;   /* index into the result's objects.names */
    int32_t triangle; /* triangle id within that object's mesh */
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
    trioct_object_names objects;
} trioct_triangle_result;

TRIOCT_API int trioct_triangles(trioct_client *c, const trioct_triangle_query *q,
                                int timeout_ms, trioct_triangle_result *out);
TRIOCT_API void trioct_triangle_result_free(trioct_triangle_result *r);

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
    int32_t object;         /* index into the result's objects.names */
    int32_t world_triangle; /* triangle id within that object's mesh */
} trioct_mesh_pair;

typedef struct trioct_mesh_result {
    trioct_reply reply;
    int detail;
    size_t num_poses;
    int32_t *found;          /* per pose: touching pairs (0/1 for YESNO) */
    size_t num_pairs;
    trioct_mesh_pair *pairs; /* PAIRS: sorted by (pose, shape triangle, object, world
                                triangle) in a world of one object at the identity, else by
                                (pose, object, shape triangle, world triangle) */
    trioct_object_names objects;
} trioct_mesh_result;

TRIOCT_API int trioct_mesh(trioct_client *c, const trioct_mesh_query *q, int timeout_ms,
                           trioct_mesh_result *out);
TRIOCT_API void trioct_mesh_result_free(trioct_mesh_result *r);

/* ---- Distance ------------------------------------------------------------------------ */

/* Distances to a world that serves the distance effect (docs/client.md, "Distance"). Each
 * answer comes with a proven bound: the real distance of the double inputs lies in
 * [lower, upper], distance is the plain distance between the points found (clamped into
 * that) and |distance - real| <= bound. Contact is surface contact, except that a point
 * inside a solid object is inside (1) with a negative distance, its depth. */
enum { TRIOCT_FEATURE_FACE = 0, TRIOCT_FEATURE_EDGE = 1, TRIOCT_FEATURE_VERTEX = 2 };

typedef struct trioct_point_distance_query {
    const char *world;
    double within;  /* the largest distance looked for (a point with nothing nearer is
                       found = 0); < 0: no limit */
    size_t count;   /* points, at most TRIOCT_MAX_POINTS */
    const trioct_vec3 *points;
} trioct_point_distance_query;

/* No limit (within -1); no points. */
TRIOCT_API trioct_point_distance_query trioct_point_distance_query_default(const char *world);

/* A shape at poses: SHAPE (nearest pair, both witnesses) and CLEAR (anything within r?). */
typedef struct trioct_shape_distance_query {
    const char *world;
    double within;     /* shape distance: as for points; clearance: the radius r >= 0 */
    const char *shape; /* a query shape the world's scene names; NULL or "": the triangles */
    size_t num_shape_triangles; /* at most TRIOCT_MAX_INLINE_SHAPE_TRIANGLES */
    const trioct_triangle *shape_triangles;
    size_t num_poses;  /* at most TRIOCT_MAX_POSES */
    const trioct_pose *poses;
} trioct_shape_distance_query;

typedef struct trioct_distance {
    int32_t item;      /* the point's (or pose's) index in the query */
    int found;         /* 1: something within the query's `within` */
    int clear;         /* clearance: 1 when nothing lies within the radius */
    double distance, bound, lower, upper; /* 0 when not found */
    trioct_vec3 point;          /* the nearest point on the world */
    trioct_vec3 shape_point;    /* shapes: the shape's witness, posed; points: the point */
    int32_t object;             /* index into the result's objects.names; -1: not found */
    int32_t triangle;           /* the world triangle in that object's mesh; -1: not found */
    int32_t shape_triangle;     /* shapes: the shape's triangle; -1 for points */
    int feature;                /* TRIOCT_FEATURE_*: where on the triangle point lies */
    int feature_index;          /* the edge (vertex k to k + 1 mod 3) or vertex; 0: face */
    int inside;                 /* 1: inside a solid object, distance < 0 (none yet) */
} trioct_distance;

typedef struct trioct_distance_result {
    trioct_reply reply;
    size_t num_results;
    trioct_distance *results; /* one per point or pose, in query order */
    trioct_object_names objects;
} trioct_distance_result;

TRIOCT_API int trioct_point_distance(trioct_client *c, const trioct_point_distance_query *q, int timeout_ms,
                                     trioct_distance_result *out);
TRIOCT_API int trioct_shape_distance(trioct_client *c, const trioct_shape_distance_query *q, int timeout_ms,
                                     trioct_distance_result *out);
TRIOCT_API int trioct_clearance(trioct_client *c, const trioct_shape_distance_query *q, int timeout_ms,
                                trioct_distance_result *out);
TRIOCT_API void trioct_distance_result_free(trioct_distance_result *r);

/* ---- Poses --------------------------------------------------------------------------- */

/* The pose of translation (x, y, z) and the rotation of quaternion (qw, qx, qy, qz),
 * normalised first, into *out: TRIOCT_OK, TRIOCT_ERR_NONFINITE for a NaN or infinite
 * component, or TRIOCT_ERR_BAD_POSE when the quaternion's length is not 1 within 1e-3 (a
 * mistake, not rounding). The daemon makes the same matrix from the same numbers; quarter and
 * half turns about the axes come out with exact 0, 1, -1 entries. */
TRIOCT_API int trioct_pose_from_quaternion(double x, double y, double z, double qw, double qx, double qy,
                                           double qz, trioct_pose *out);

/* ---- Objects ------------------------------------------------------------------------- */

/* A world is a set of named objects, each a mesh with its own octree placed by a pose; a
 * scene section without objects is one object named after the world. An edit list applies
 * in order and all or none, and makes a new version of the world; queries in flight finish
 * on the version they started on. Objects are edited in exact worlds only. */
enum { TRIOCT_OBJECT_ADD = 0, TRIOCT_OBJECT_MOVE = 1, TRIOCT_OBJECT_REMOVE = 2 };

typedef struct trioct_object_edit {
    int op;           /* TRIOCT_OBJECT_ADD, _MOVE or _REMOVE */
    const char *name; /* 1..32 characters of [A-Za-z0-9_.-] */
    const char *mesh; /* ADD: a mesh file relative to the daemon's world directory (objects
                         of one file share its loaded mesh and tree); NULL or "": the
                         inline triangles */
    trioct_pose pose; /* ADD and MOVE: t, and unless quaternion is given r, a rotation
                         (orthonormal within 1e-6, det +1) */
    const double *quaternion; /* NULL, or the rotation as (w, x, y, z), sent as it is and
                                 normalised by the daemon (length 1 within 1e-3) */
    size_t num_triangles; /* ADD without a mesh: 1..TRIOCT_MAX_INLINE_SHAPE_TRIANGLES */
    const trioct_triangle *triangles;
} trioct_object_edit;

typedef struct trioct_object_info {
    char name[TRIOCT_MAX_NAME_LEN + 1];
    char mesh[TRIOCT_MAX_PATH_LEN + 1]; /* its file, "inline", or "section:WORLD" */
    int64_t triangles;
    trioct_pose pose;
    trioct_vec3 bbox_min, bbox_max;     /* a box holding every posed vertex */
    int64_t bytes;                      /* its mesh and tree (shared ones counted in each) */
    int shared;                         /* objects using the same mesh and tree (1: none other) */
} trioct_object_info;

typedef struct trioct_object_result {
    trioct_reply reply;   /* world_version: the version the edits made, or the one served */
    int failed_edit;      /* on an error about one edit, its index; else -1 */
    int64_t objects;      /* objects in that version */
    int64_t triangles;
    size_t num_objects;   /* listed: with list, every object, in name order */
    trioct_object_info *list;
} trioct_object_result;

/* Applies count edits (at most TRIOCT_MAX_EDITS; 0 just describes the version served) to
 * world; with list the result lists the objects of the version it names. */
TRIOCT_API int trioct_objects_edit(trioct_client *c, const char *world, const trioct_object_edit *edits,
                                   size_t count, int list, int timeout_ms, trioct_object_result *out);
TRIOCT_API void trioct_object_result_free(trioct_object_result *r);

/* ---- Robot states -------------------------------------------------------------------- */

/* A robot state is its links at their poses, checked against the world's objects and, with
 * self_collision, against each other; allowed pairs (a link and an object, or two links, by
 * name, either way round) are left out. The world must serve meshes. */
enum { TRIOCT_STATE_VALID = 0, TRIOCT_STATE_CONTACTS = 1 };

typedef struct trioct_state_link {
    const char *name;  /* 1..32 characters of [A-Za-z0-9_.-], unique in the query */
    const char *shape; /* a query shape the world's scene names; NULL or "": the triangles */
    size_t num_triangles; /* inline: all links' together at most TRIOCT_MAX_INLINE_SHAPE_TRIANGLES */
    const trioct_triangle *triangles;
} trioct_state_link;

typedef struct trioct_allowed_pair {
    const char *a, *b;
} trioct_allowed_pair;

typedef struct trioct_state_query {
    const char *world;
    int detail;         /* TRIOCT_STATE_VALID (each state's first contact) or _CONTACTS (all) */
    int self_collision; /* 1: the links against each other too */
    size_t num_links;   /* 1..64 */
    const trioct_state_link *links;
    size_t num_allowed;
    const trioct_allowed_pair *allowed;
    size_t num_states;  /* num_states x num_links at most TRIOCT_MAX_POSES */
    const trioct_pose *poses; /* num_links per state, state after state */
    const double *quaternions; /* NULL, or 4 a pose (w, x, y, z): the rotations, sent as they
                                  are and normalised by the daemon; poses[k].r is then unused */
} trioct_state_query;

typedef struct trioct_state_contact {
    int32_t state, link;   /* indexes in the query */
    int with_link;         /* 0: other indexes the result's objects.names; 1: the query's links */
    int32_t other;
    int32_t link_triangle, other_triangle;
} trioct_state_contact;

typedef struct trioct_state_result {
    trioct_reply reply;
    int detail;
    size_t num_states;
    uint8_t *valid;   /* per state: 1 when no contact outside the allowed pairs */
    int32_t *found;   /* per state: contacts listed (VALID: 0 or 1, the first found) */
    size_t num_contacts;
    trioct_state_contact *contacts; /* by state, link, objects before links, other, triangles */
    trioct_object_names objects;
} trioct_state_result;

TRIOCT_API int trioct_states(trioct_client *c, const trioct_state_query *q, int timeout_ms, trioct_state_result *out);
TRIOCT_API void trioct_state_result_free(trioct_state_result *r);

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
    int64_t memory_bytes;  /* its meshes and trees: what its memory_budget bounds */
    int64_t memory_budget; /* the world's own budget; 0: only the daemon's bounds it */
    double build_seconds;  /* building the octrees, after the mesh files were read */
    double load_seconds;   /* reading the mesh files (the daemon's loader child) */

    int64_t objects;                             /* objects in this version */
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

TRIOCT_API void trioct_admin_result_free(trioct_admin_result *r);

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
TRIOCT_API int trioct_load(trioct_client *c, const trioct_load_options *opt, int timeout_ms,
                           trioct_admin_result *out);
TRIOCT_API int trioct_unload(trioct_client *c, const char *world, int timeout_ms,
                             trioct_admin_result *out);
TRIOCT_API int trioct_info(trioct_client *c, const char *world, int timeout_ms,
                           trioct_admin_result *out);

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
TRIOCT_API int trioct_list(trioct_client *c, const trioct_list_options *opt, int timeout_ms,
                           trioct_list_result *out);
TRIOCT_API void trioct_list_result_free(trioct_list_result *r);

/* ---- Daemon status (heartbeat) ------------------------------------------------------- */

enum {
    TRIOCT_DAEMON_STARTING = 0,
    TRIOCT_DAEMON_READY = 1,
    TRIOCT_DAEMON_RELOADING = 2,
    TRIOCT_DAEMON_STOPPING = 3
};

/* A world build under way on a daemon: a LOAD (client_id and request_id name it; see
 * trioct_client_id) or a scene world at start-up or in a reload (both 0). */
typedef struct trioct_load_progress {
    char world[TRIOCT_MAX_NAME_LEN + 1];
    int64_t client_id, request_id;
    char phase[32];       /* "queued", "reading meshes" or "building octrees" */
    int files_done, files_total; /* mesh and shape files read, and to read */
    int64_t triangles;    /* read so far */
    double elapsed_seconds;
} trioct_load_progress;

typedef struct trioct_daemon_status {
    trioct_reply reply; /* .daemon: who sent it; .status: the call's outcome */
    int64_t utime;
    char version[64];
    int64_t uptime_us;
    int state; /* TRIOCT_DAEMON_* */
    int threads, queue_depth, queue_capacity;
    int64_t memory_used, memory_budget; /* bytes all worlds hold, and what they may */
    int64_t served[7]; /* answered requests: ray, triangle, mesh, admin, objects, state, distance */
    int64_t malformed; /* messages the daemon dropped before decoding */
    /* Retries (same client, request id and bytes) answered from the daemon's reply cache,
     * and those that came while the original was in work, answered by its one reply. */
    int64_t duplicates_answered, duplicates_joined;
    size_t num_status_codes;
    int64_t *replies_by_status; /* indexed by status code */
    int64_t latency_p50_us, latency_p99_us, latency_count;
    size_t num_worlds;
    trioct_world_info *worlds;
    size_t num_loads;
    trioct_load_progress *loads; /* the world builds under way */
} trioct_daemon_status;

/* Waits for the next status message heard while the call runs (from daemon, or from any
 * daemon when daemon is NULL): the connection listens to the heartbeat only during this
 * call, so a status is never stale. TRIOCT_ERR_NO_DAEMON when none came in time. */
TRIOCT_API int trioct_next_status(trioct_client *c, const char *daemon, int timeout_ms,
                                  trioct_daemon_status *out);
TRIOCT_API void trioct_daemon_status_free(trioct_daemon_status *s);

/* ---- Asynchronous calls -------------------------------------------------------------- */

/* Each call below checks and sends its request like its synchronous twin and returns at
 * once, without waiting:
 *
 *   TRIOCT_OK   the request is in flight; *request_id (when request_id is not NULL) is its
 *               id, and cb will be called exactly once with the result (unless the request
 *               is cancelled first);
 *   otherwise   the refusal of the synchronous twin (a bad or over-cap request, no callback,
 *               a closing connection, a publish that failed); nothing is in flight, cb is
 *               never called, *request_id is 0, and trioct_last_error(c) says why.
 *
 * The query is encoded and sent before the call returns: its arrays may be reused at once.
 * Any number of requests may be in flight on one connection; they complete in the order
 * their answers become whole (or their deadlines pass), whatever order they were sent in.
 *
 * Completions run only from trioct_pump and trioct_poll (and, as closed, from
 * trioct_disconnect), on the calling thread, never from inside lcm_handle. The timeout
 * works as for the synchronous calls, measured from the call: when it passes, the next pump
 * or poll completes the request with TRIOCT_ERR_NO_DAEMON or TRIOCT_ERR_TIMEOUT, and
 * trioct_next_timeout_ms says when that is due. A timeout < 0 never fires.
 *
 * The callback gets the result in the same struct the synchronous call fills, with
 * res->reply.status the outcome and res->reply.request_id the id. The library owns *res and
 * frees it with its _free function when the callback returns; to keep it, move it out:
 * `*mine = *res; memset(res, 0, sizeof *res);` (the free then finds nothing to free). A
 * callback may send new requests (synchronous ones too), cancel others and disconnect; it
 * may not call trioct_pump or trioct_poll (they refuse, returning -1). */

typedef void (*trioct_ray_done)(trioct_client *c, trioct_ray_result *res, void *user);
typedef void (*trioct_triangle_done)(trioct_client *c, trioct_triangle_result *res, void *user);
typedef void (*trioct_mesh_done)(trioct_client *c, trioct_mesh_result *res, void *user);
typedef void (*trioct_admin_done)(trioct_client *c, trioct_admin_result *res, void *user);
typedef void (*trioct_list_done)(trioct_client *c, trioct_list_result *res, void *user);
typedef void (*trioct_object_done)(trioct_client *c, trioct_object_result *res, void *user);
typedef void (*trioct_state_done)(trioct_client *c, trioct_state_result *res, void *user);
typedef void (*trioct_distance_done)(trioct_client *c, trioct_distance_result *res, void *user);

TRIOCT_API int trioct_rays_async(trioct_client *c, const trioct_ray_query *q, int timeout_ms,
                                 trioct_ray_done cb, void *user, int64_t *request_id);
TRIOCT_API int trioct_rays_contact_async(trioct_client *c, const trioct_ray_query *q, int contact,
                                         int timeout_ms, trioct_ray_done cb, void *user,
                                         int64_t *request_id);
TRIOCT_API int trioct_triangles_async(trioct_client *c, const trioct_triangle_query *q,
                                      int timeout_ms, trioct_triangle_done cb, void *user,
                                      int64_t *request_id);
TRIOCT_API int trioct_mesh_async(trioct_client *c, const trioct_mesh_query *q, int timeout_ms,
                                 trioct_mesh_done cb, void *user, int64_t *request_id);
TRIOCT_API int trioct_load_async(trioct_client *c, const trioct_load_options *opt,
                                 int timeout_ms, trioct_admin_done cb, void *user,
                                 int64_t *request_id);
TRIOCT_API int trioct_unload_async(trioct_client *c, const char *world, int timeout_ms,
                                   trioct_admin_done cb, void *user, int64_t *request_id);
TRIOCT_API int trioct_info_async(trioct_client *c, const char *world, int timeout_ms,
                                 trioct_admin_done cb, void *user, int64_t *request_id);
TRIOCT_API int trioct_objects_edit_async(trioct_client *c, const char *world, const trioct_object_edit *edits,
                                         size_t count, int list, int timeout_ms, trioct_object_done cb, void *user,
                                         int64_t *request_id);
TRIOCT_API int trioct_states_async(trioct_client *c, const trioct_state_query *q, int timeout_ms,
                                   trioct_state_done cb, void *user, int64_t *request_id);
TRIOCT_API int trioct_point_distance_async(trioct_client *c, const trioct_point_distance_query *q, int timeout_ms,
                                           trioct_distance_done cb, void *user, int64_t *request_id);
TRIOCT_API int trioct_shape_distance_async(trioct_client *c, const trioct_shape_distance_query *q, int timeout_ms,
                                           trioct_distance_done cb, void *user, int64_t *request_id);
TRIOCT_API int trioct_clearance_async(trioct_client *c, const trioct_shape_distance_query *q, int timeout_ms,
                                      trioct_distance_done cb, void *user, int64_t *request_id);
/* Gathers until the timeout, the gather window or the expected count, as trioct_list. */
TRIOCT_API int trioct_list_async(trioct_client *c, const trioct_list_options *opt,
                                 int timeout_ms, trioct_list_done cb, void *user,
                                 int64_t *request_id);

/* Waits up to timeout_ms (< 0: no limit) for the bus or the next deadline of a request in
 * flight, handles what came and runs the completions due. Returns as soon as at least one
 * completion ran (how many ran), 0 when the timeout passed with none (at once when
 * timeout_ms < 0 and nothing is in flight, as nothing could end the wait), or -1 when the
 * bus failed or when called from inside a completion callback (trioct_last_error says). */
TRIOCT_API int trioct_poll(trioct_client *c, int timeout_ms);

/* How long an external loop may sleep before it must call trioct_pump even if
 * trioct_fileno stays quiet: milliseconds until the earliest deadline of a request in
 * flight (rounded up), 0 when one has passed or completions wait to run, -1 when no request
 * in flight has a deadline. Read it again after every pump and after any call that sends a
 * request or waits (a synchronous call handles the replies of async requests too and leaves
 * their completions for the next pump). */
TRIOCT_API int trioct_next_timeout_ms(const trioct_client *c);

/* Asynchronous requests sent and not yet completed or cancelled. */
TRIOCT_API size_t trioct_in_flight(const trioct_client *c);

/* Forgets an asynchronous request in flight: its callback will not be called (the user
 * pointer is the caller's again) and replies that still come are dropped and counted as
 * unmatched. TRIOCT_OK, or TRIOCT_ERR_BAD_REQUEST when no such request is in flight (it
 * completed, its callback is running, it was cancelled, or it was never sent). */
TRIOCT_API int trioct_cancel(trioct_client *c, int64_t request_id);

/* Why the last asynchronous call, trioct_cancel, trioct_pump or trioct_poll on c failed;
 * "" after one that succeeded. Valid until the next such call on c. */
TRIOCT_API const char *trioct_last_error(const trioct_client *c);

#ifdef __cplusplus
}
#endif

#endif
