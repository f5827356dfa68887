/* What the dispatch files share and nobody else needs: the state of one request being
 * handled, the wire form of a query's results, the chunking encoders and the allocator.
 *
 *   dispatch.c          peek, the checks every request goes through, error replies
 *   dispatch_query.c    ray, triangle and mesh requests: validation and the engine's work
 *   dispatch_posed.c    the same asked of a world of posed objects; the replies' object names
 *   dispatch_admin.c    LIST, INFO, LOAD, UNLOAD and world_info_t
 *   dispatch_objects.c  object edits and listings
 *   dispatch_state.c    robot state checks
 *   dispatch_distance.c distances from points (and, later, shapes) and clearance
 *   dispatch_encode.c   replies cut into chunks that each fit TRIOCT_MAX_CHUNK_BYTES */
#ifndef TRIOCT_SERVICE_DISPATCH_INTERNAL_H
#define TRIOCT_SERVICE_DISPATCH_INTERNAL_H

#include <stdatomic.h>
#include <stdlib.h>

#include "../../common/trioct_status.h"
#include "dispatch.h"
#include "trioct_admin_reply_t.h"
#include "trioct_admin_request_t.h"
#include "trioct_distance_reply_t.h"
#include "trioct_distance_request_t.h"
#include "trioct_mesh_reply_t.h"
#include "trioct_mesh_request_t.h"
#include "trioct_object_edit_request_t.h"
#include "trioct_object_reply_t.h"
#include "trioct_state_reply_t.h"
#include "trioct_state_request_t.h"
#include "trioct_ray_reply_t.h"
#include "trioct_ray_request_t.h"
#include "trioct_ray_request_v1_t.h"
#include "trioct_request_header_t.h"
#include "trioct_triangle_reply_t.h"
#include "trioct_triangle_request_t.h"
#include "trioct_world_info_t.h"

/* ---------- allocation ---------- */

/* Every allocation dispatch makes for a request goes through these, so a test can make the
 * n-th one fail and see a NOMEM reply where a crash would otherwise be. Zero bytes still
 * get a distinct block: an empty batch is not out of memory. */
extern atomic_long dispatch_alloc_countdown;

static inline int dispatch_alloc_should_fail(void)
{
    if (atomic_load_explicit(&dispatch_alloc_countdown, memory_order_relaxed) <= 0)
        return 0;
    return atomic_fetch_sub(&dispatch_alloc_countdown, 1) == 1;
}

static inline void *dispatch_malloc(size_t n)
{
    return dispatch_alloc_should_fail() ? NULL : malloc(n ? n : 1);
}

static inline void *dispatch_calloc(size_t count, size_t size)
{
    return dispatch_alloc_should_fail() ? NULL : calloc(count ? count : 1, size ? size : 1);
}

/* Makes the nth allocation from now fail once (1: the next one); 0 turns it off. For tests;
 * set it while no request is being handled. */
void dispatch_fail_allocation(long nth);

/* ---------- one request ---------- */

typedef struct job {
    dispatch_ctx *ctx;
    dispatch_request req;
    trioct_request_header_t hdr;   /* decoded header, owned (the world as sent, in full) */
    world *w;                      /* the world asked about, with a reference, or NULL */
    int64_t world_version;         /* echoed in the reply; 0 when there is no world */
    int status;
    char message[TRIOCT_MAX_MESSAGE_LEN + 1];
    dispatch_reply *out;
    int counted;                   /* the request was answered on w (w->queries) */
    int32_t failed_edit;           /* object edits: the edit an error is about, or -1 */
    /* The request as heard, for the change guard (admin_auth.h). */
    const char *channel;
    const void *bytes;
    size_t size;
    int64_t heard_utime;
} job;

/* A change (LOAD, UNLOAD, edits) passes the change guard, or gets ERR_DENIED saying why. */
int dispatch_authorize(job *j);

/* Records an error (status and a printf message) and returns status, so a check reads
 * `return job_fail(j, TRIOCT_ERR_..., "...", ...)`. */
int job_fail(job *j, int status, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

/* A client's string quoted for a message: at most 40 characters, anything outside printable
 * ASCII shown as '?', "..." when cut. buf holds at least 48 bytes. */
const char *dispatch_quote(const char *s, char *buf, size_t len);

/* The engine's status for item i turned into a reply status and message. */
int job_engine_error(job *j, octree_status st, const char *item, size_t i);

/* Handlers: each validates its decoded request and either encodes the OK reply into
 * j->out and returns TRIOCT_OK, or returns an error status with j->message set. */
int dispatch_ray(job *j, const trioct_ray_request_t *m);
int dispatch_triangle(job *j, const trioct_triangle_request_t *m);
int dispatch_mesh(job *j, const trioct_mesh_request_t *m);
int dispatch_admin(job *j, const trioct_admin_request_t *m);
int dispatch_objects(job *j, const trioct_object_edit_request_t *m);
int dispatch_state(job *j, const trioct_state_request_t *m);
int dispatch_distance(job *j, const trioct_distance_request_t *m);

/* ---------- replies ---------- */

/* What every chunk's header carries. */
typedef struct reply_head {
    int64_t client_id;
    int64_t request_id;
    const char *daemon;
    const char *world;
    int64_t world_version;
    int status;
    const char *message;
} reply_head;

reply_head job_head(const job *j, int status, const char *message);

/* A query's results in wire form. found has item_count entries (chunk 0 carries them all);
 * the records (one of hits, contacts, pairs) are cut over the chunks in order. segments,
 * when not NULL, runs beside contacts. */
typedef struct query_result {
    int32_t item_count;
    int32_t *found;
    size_t record_count;
    trioct_ray_hit_t *hits;
    trioct_contact_t *contacts;
    trioct_segment_t *segments;
    trioct_mesh_pair_t *pairs;
    /* The names of the objects the records name (chunk 0), pointing into the world's
     * object set: only the array is the result's. */
    int32_t object_count;
    char **objects;
} query_result;

void query_result_free(query_result *r);

/* A world of posed objects (j->w->tree is NULL): each item asked of the object set, the
 * records' object fields indexes in the set. Fill res (found, records, counts) and return
 * TRIOCT_OK, or an error status with j->message set. */
int posed_rays(job *j, const ray_input *in, size_t n, ray_detail detail, size_t keep_cap, query_result *res);
int posed_triangles(job *j, const vec3 (*tris)[3], size_t n, tri_detail detail, query_result *res);
int posed_meshes(job *j, const octree *shape_tree, box3 shape_bounds, const pose *poses, size_t n, int all_pairs,
                 query_result *res);

/* Turns the records' object fields from indexes in the world's set into indexes in the
 * reply's table of names, which it makes: each named object once, in set (name) order. */
int posed_name_objects(job *j, query_result *r);

/* The same for any records: field gives record i's object index, or NULL for a record that
 * names no object (a state contact with another link). The names point into the world's
 * set; *names is the caller's to free. */
typedef int32_t *(*object_field_fn)(void *records, size_t i);
int dispatch_name_objects(job *j, void *records, size_t count, object_field_fn field, int32_t *named_count,
                          char ***names);

/* Triangles of the wire as a mesh of three vertices a triangle (inline shapes and links:
 * the engine tests triangles, so no vertex need be shared), in *vertices and *indices (the
 * caller frees both) and *view; 0, or -1 when out of memory, with nothing left allocated. */
int dispatch_triangle_mesh(const trioct_triangle_t *tris, size_t n, vec3 **vertices, uint32_t **indices,
                           mesh_view *view);

/* TRIOCT_ERR_NOMEM with "out of memory for <what>". */
int dispatch_out_of_memory(job *j, const char *what);

/* A pose of the wire into *out: t, and pose.r or, when quaternion is not NULL, the rotation
 * of that quaternion (w, x, y, z), normalised. OCTREE_ERR_NONFINITE for a NaN or infinite
 * entry, OCTREE_ERR_INVALID for a quaternion far from unit length or a matrix that is no
 * rotation (octree_pose_check). */
octree_status dispatch_wire_pose(const trioct_pose_t *p, const double *quaternion, pose *out);

/* Each encodes a whole reply into out->chunks (every chunk <= TRIOCT_MAX_CHUNK_BYTES) and
 * returns TRIOCT_OK, or TRIOCT_ERR_NOMEM (or TRIOCT_ERR_OVER_CAP for a record that fits no
 * chunk) with out->chunks left empty. A NULL result encodes one chunk without results. */
int encode_ray_reply(dispatch_reply *out, const reply_head *h, int8_t detail, const query_result *r);
int encode_triangle_reply(dispatch_reply *out, const reply_head *h, int8_t detail,
                          const query_result *r);
int encode_mesh_reply(dispatch_reply *out, const reply_head *h, int8_t detail, const query_result *r);
int encode_admin_reply(dispatch_reply *out, const reply_head *h, int8_t op,
                       const trioct_world_info_t *worlds, size_t count);

/* An object reply: count objects of infos (NULL: none listed) split over the chunks. */
int encode_object_reply(dispatch_reply *out, const reply_head *h, int32_t failed_edit, int64_t objects,
                        int64_t triangles, const trioct_object_info_t *infos, size_t count);

/* A state reply: chunk 0 carries found[] of the states and the object names;
 * the count contacts are split over the chunks. */
int encode_state_reply(dispatch_reply *out, const reply_head *h, int8_t detail, int32_t states, const int32_t *found, int32_t object_count, char **objects,
                       const trioct_state_contact_t *contacts, size_t count);

/* A distance reply: chunk 0 carries the object names; the count results, all of one size,
 * are split over the chunks in order. */
int encode_distance_reply(dispatch_reply *out, const reply_head *h, int8_t kind, int32_t object_count, char **objects,
                          const trioct_distance_result_t *results, size_t count);

/* One chunk, no results, of the reply type for type. */
int encode_error_reply(dispatch_reply *out, request_type type, const reply_head *h, int8_t detail);

#endif
