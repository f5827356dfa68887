/* The front of the protocol: which channel a message came on, whether its bytes are a
 * message at all, and the checks every request passes before any work. Everything after
 * the header is the handlers' (dispatch_query.c, dispatch_admin.c). */
#include <ctype.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "../../common/wire_check.h"
#include "dispatch_internal.h"

atomic_long dispatch_alloc_countdown;

void dispatch_fail_allocation(long nth)
{
    atomic_store(&dispatch_alloc_countdown, nth > 0 ? nth : 0);
}

int job_fail(job *j, int status, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(j->message, sizeof j->message, fmt, ap);
    va_end(ap);
    j->status = status;
    return status;
}

const char *dispatch_quote(const char *s, char *buf, size_t len)
{
    enum { SHOWN = 40 };
    if (len < SHOWN + 4) {
        if (len)
            buf[0] = '\0';
        return buf;
    }
    size_t n = 0;
    for (; s[n] != '\0' && n < SHOWN; n++) {
        unsigned char c = (unsigned char)s[n];
        buf[n] = c < 128 && isprint(c) ? (char)c : '?';
    }
    if (s[n] != '\0') {
        memcpy(&buf[n], "...", 3);
        n += 3;
    }
    buf[n] = '\0';
    return buf;
}

int dispatch_out_of_memory(job *j, const char *what)
{
    return job_fail(j, TRIOCT_ERR_NOMEM, "out of memory for %s", what);
}

octree_status dispatch_wire_pose(const trioct_pose_t *p, const double *quaternion, pose *out)
{
    vec3 t = {p->t.x, p->t.y, p->t.z};
    if (!isfinite(t.x) || !isfinite(t.y) || !isfinite(t.z))
        return OCTREE_ERR_NONFINITE;
    if (quaternion) {
        octree_status st = octree_pose_from_quaternion(t, quaternion[0], quaternion[1], quaternion[2], quaternion[3],
                                                       out);
        return st != OCTREE_OK ? st : octree_pose_check(out);
    }
    memcpy(out->r, p->r, sizeof out->r);
    out->t = t;
    return octree_pose_check(out); /* OCTREE_ERR_NONFINITE for a NaN or infinite entry of r */
}

int job_engine_error(job *j, octree_status st, const char *item, size_t i)
{
    switch (st) {
    case OCTREE_ERR_NOMEM:
        return job_fail(j, TRIOCT_ERR_NOMEM, "out of memory answering %s %zu", item, i);
    case OCTREE_ERR_NONFINITE:
        return job_fail(j, TRIOCT_ERR_NONFINITE, "%s %zu has or produces a NaN or infinite coordinate",
                        item, i);
    default:
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "the engine refused %s %zu: %s", item, i,
                        octree_status_text(st));
    }
}

/* ---------- peek ---------- */

static const wire_type wire_of[REQUEST_TYPE_COUNT] = {
    [REQUEST_RAY] = WIRE_RAY_REQUEST,
    [REQUEST_TRIANGLE] = WIRE_TRIANGLE_REQUEST,
    [REQUEST_MESH] = WIRE_MESH_REQUEST,
    [REQUEST_ADMIN] = WIRE_ADMIN_REQUEST,
    [REQUEST_OBJECTS] = WIRE_OBJECT_EDIT_REQUEST,
    [REQUEST_STATE] = WIRE_STATE_REQUEST,
    [REQUEST_DISTANCE] = WIRE_DISTANCE_REQUEST,
};

/* Offsets after the header of the fields dispatch_is_small reads: ray_request_t (and v1)
 * detail, accuracy, tmin, tmax, max_hits, then num_rays; triangle_request_t detail,
 * accuracy, then num_triangles and the triangles, nine doubles each. */
#define RAY_COUNT_AT 22
#define TRIANGLE_COUNT_AT 2
#define TRIANGLE_BYTES 72

/* The longest side of the bounding boxes of count wire triangles at bytes + at; NaN when a
 * coordinate is not finite. wire_check has vouched for the bytes. */
static double triangles_extent(const void *bytes, int at, int left, int32_t count)
{
    double extent = 0.0;
    for (int32_t t = 0; t < count; t++) {
        double v[9];
        if (__double_decode_array(bytes, at + TRIANGLE_BYTES * t, left - TRIANGLE_BYTES * t, v, 9) !=
            TRIANGLE_BYTES)
            return NAN;
        for (int k = 0; k < 9; k++)
            if (!isfinite(v[k]))
                return NAN;
        for (int axis = 0; axis < 3; axis++) {
            double lo = fmin(v[axis], fmin(v[3 + axis], v[6 + axis]));
            double hi = fmax(v[axis], fmax(v[3 + axis], v[6 + axis]));
            extent = fmax(extent, hi - lo);
        }
    }
    return extent;
}

/* Reads what dispatch_is_small weighs: the item count and, for a few triangles, their size.
 * at is where the field after the header begins. */
static void peek_cost(dispatch_request *req, const void *bytes, int at, int size)
{
    req->items = 0;
    req->extent = INFINITY;
    int count_at = req->type == REQUEST_RAY ? RAY_COUNT_AT : req->type == REQUEST_TRIANGLE ? TRIANGLE_COUNT_AT : -1;
    if (count_at < 0)
        return;
    int32_t items = 0;
    if (__int32_t_decode_array(bytes, at + count_at, size - at - count_at, &items, 1) != 4)
        return;
    req->items = items;
    if (req->type == REQUEST_TRIANGLE && items <= DISPATCH_INLINE_MAX_TRIANGLES) {
        int first = at + count_at + 4;
        req->extent = triangles_extent(bytes, first, size - first, items);
    }
}

/* Peeks and, on PEEK_REQUEST, leaves the decoded header in *hdr for the caller to clean up.
 * The header decoder is safe here: wire_check has vouched for every byte it reads. */
static dispatch_peek_result peek(const dispatch_ctx *ctx, const char *channel, const void *bytes, size_t size,
                                 dispatch_request *req, trioct_request_header_t *hdr)
{
    memset(req, 0, sizeof *req);
    memset(hdr, 0, sizeof *hdr);
    trioct_channel_kind kind;
    char name[TRIOCT_MAX_NAME_LEN + 1];
    if (!channel || trioct_channel_parse(channel, ctx->prefix, &kind, name) != 0)
        return PEEK_NOT_MINE;
    request_type type;
    switch (kind) {
    case TRIOCT_CHANNEL_RAY:
        type = REQUEST_RAY;
        break;
    case TRIOCT_CHANNEL_TRI:
        type = REQUEST_TRIANGLE;
        break;
    case TRIOCT_CHANNEL_MESH:
        type = REQUEST_MESH;
        break;
    case TRIOCT_CHANNEL_LOAD:
        /* Every daemon of the fleet may hear every LOAD channel; only the named one builds. */
        if (strcmp(name, ctx->daemon) != 0)
            return PEEK_NOT_MINE;
        type = REQUEST_ADMIN;
        break;
    case TRIOCT_CHANNEL_ADMIN:
    case TRIOCT_CHANNEL_LIST:
        type = REQUEST_ADMIN;
        break;
    case TRIOCT_CHANNEL_OBJECTS:
        type = REQUEST_OBJECTS;
        break;
    case TRIOCT_CHANNEL_STATE:
        type = REQUEST_STATE;
        break;
    case TRIOCT_CHANNEL_DISTANCE:
        type = REQUEST_DISTANCE;
        break;
    default:
        return PEEK_NOT_MINE; /* STATUS: another daemon's heartbeat */
    }
    /* The generated decoders count in int; LCM's own cap (256 MiB) is far below. */
    /* A RAY channel takes ray_request_t and the older ray_request_v1_t alike. */
    wire_type wire = type == REQUEST_RAY ? wire_ray_request_type(bytes, size) : wire_of[type];
    if (!bytes || size > INT_MAX || wire_check(wire, bytes, size, NULL) != 0)
        return PEEK_MALFORMED;

    int len = __trioct_request_header_t_decode_array(bytes, 8, (int)size - 8, hdr, 1);
    if (len < 0)
        return PEEK_MALFORMED;
    /* Every request type carries one int8 right after its header: detail, the admin op or
     * the distance kind. */
    int8_t after = 0;
    if (__int8_t_decode_array(bytes, 8 + len, (int)size - 8 - len, &after, 1) != 1) {
        __trioct_request_header_t_decode_array_cleanup(hdr, 1);
        return PEEK_MALFORMED;
    }
    trioct_channel_kind reply_kind;
    char reply_name[TRIOCT_MAX_NAME_LEN + 1];
    if (!trioct_name_valid(hdr->reply_channel, TRIOCT_MAX_CHANNEL_LEN) ||
        trioct_channel_parse(hdr->reply_channel, ctx->prefix, &reply_kind, reply_name) == 0) {
        __trioct_request_header_t_decode_array_cleanup(hdr, 1);
        return PEEK_MALFORMED;
    }

    req->type = type;
    req->channel_kind = kind;
    strcpy(req->channel_name, name);
    req->client_id = hdr->client_id;
    req->request_id = hdr->request_id;
    strcpy(req->reply_channel, hdr->reply_channel);
    if (trioct_name_valid(hdr->world, TRIOCT_MAX_NAME_LEN))
        strcpy(req->world, hdr->world);
    req->deadline_utime = hdr->deadline_utime;
    if (type == REQUEST_ADMIN)
        req->admin_op = after;
    else
        req->detail = after;
    peek_cost(req, bytes, 8 + len, (int)size);
    return PEEK_REQUEST;
}

dispatch_peek_result dispatch_peek(const dispatch_ctx *ctx, const char *channel, const void *bytes, size_t size,
                                   dispatch_request *req)
{
    trioct_request_header_t hdr;
    dispatch_peek_result r = peek(ctx, channel, bytes, size, req, &hdr);
    if (r == PEEK_REQUEST)
        __trioct_request_header_t_decode_array_cleanup(&hdr, 1);
    return r;
}

int dispatch_is_small(dispatch_ctx *ctx, const dispatch_request *req)
{
    switch (req->type) {
    case REQUEST_RAY:
        return req->items <= DISPATCH_INLINE_MAX_RAYS;
    case REQUEST_TRIANGLE: {
        if (req->items > DISPATCH_INLINE_MAX_TRIANGLES)
            return 0;
        if (req->items == 0)
            return 1;
        world *w = registry_acquire(ctx->worlds, req->channel_name);
        if (!w)
            return 1;
        octree_info info;
        world_tree_info(w, &info);
        world_release(w);
        /* NaN (a coordinate not finite) is not small: the workers answer it, with an error. */
        return req->extent <= DISPATCH_INLINE_MAX_TRIANGLE_LEAVES * info.resolution;
    }
    default:
        return 0;
    }
}

/* ---------- replies ---------- */

static reply_head head_of(const dispatch_ctx *ctx, const dispatch_request *req, int64_t version, int status,
                          const char *message)
{
    return (reply_head){
        .client_id = req->client_id,
        .request_id = req->request_id,
        .daemon = ctx->daemon,
        .world = req->world,
        .world_version = version,
        .status = status,
        .message = message,
    };
}

reply_head job_head(const job *j, int status, const char *message)
{
    return head_of(j->ctx, &j->req, j->world_version, status, message);
}

static int8_t echoed_detail(const dispatch_request *req)
{
    return req->type == REQUEST_ADMIN ? req->admin_op : req->detail;
}

static void reply_start(dispatch_reply *out, const dispatch_request *req)
{
    memset(out, 0, sizeof *out);
    strcpy(out->channel, req->reply_channel);
    out->type = req->type;
}

int dispatch_error(const dispatch_ctx *ctx, const dispatch_request *req, int status, const char *message,
                   dispatch_reply *out)
{
    reply_start(out, req);
    out->status = status;
    reply_head h = head_of(ctx, req, 0, status, message ? message : trioct_status_text(status));
    return encode_error_reply(out, req->type, &h, echoed_detail(req)) == TRIOCT_OK ? 0 : -1;
}

/* ---------- handle ---------- */

static const char *const op_name[] = {"LIST", "INFO", "LOAD", "UNLOAD"};

static const char *admin_op_name(int8_t op)
{
    return op >= 0 && op <= TRIOCT_ADMIN_REQUEST_T_UNLOAD ? op_name[op] : "unknown";
}

/* The op a channel admits: LIST on LIST, LOAD on LOAD, INFO and UNLOAD on ADMIN. Keeping
 * them apart is what routes each to the right daemon of a fleet. */
static int check_admin_channel(job *j)
{
    int8_t op = j->req.admin_op;
    int ok;
    const char *wants;
    switch (j->req.channel_kind) {
    case TRIOCT_CHANNEL_LIST:
        ok = op == TRIOCT_ADMIN_REQUEST_T_LIST;
        wants = "LIST (0)";
        break;
    case TRIOCT_CHANNEL_LOAD:
        ok = op == TRIOCT_ADMIN_REQUEST_T_LOAD;
        wants = "LOAD (2)";
        break;
    default:
        ok = op == TRIOCT_ADMIN_REQUEST_T_INFO || op == TRIOCT_ADMIN_REQUEST_T_UNLOAD;
        wants = "INFO (1) or UNLOAD (3)";
        break;
    }
    if (ok)
        return TRIOCT_OK;
    return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "admin op %d (%s) is not served on this channel, which takes %s",
                    op, admin_op_name(op), wants);
}

static int channel_has_world(trioct_channel_kind kind)
{
    return kind == TRIOCT_CHANNEL_RAY || kind == TRIOCT_CHANNEL_TRI || kind == TRIOCT_CHANNEL_MESH ||
           kind == TRIOCT_CHANNEL_ADMIN || kind == TRIOCT_CHANNEL_OBJECTS || kind == TRIOCT_CHANNEL_STATE ||
           kind == TRIOCT_CHANNEL_DISTANCE;
}

static const struct {
    unsigned bit;
    const char *effect;
    const char *query;
} effect_of[REQUEST_TYPE_COUNT] = {
    [REQUEST_RAY] = {EFFECT_RAYS, "rays", "ray"},
    [REQUEST_TRIANGLE] = {EFFECT_TRIANGLES, "triangles", "triangle"},
    [REQUEST_MESH] = {EFFECT_MESHES, "meshes", "mesh"},
    [REQUEST_STATE] = {EFFECT_MESHES, "meshes", "state"},
    [REQUEST_DISTANCE] = {EFFECT_DISTANCE, "distance", "distance"},
};

/* The effects in the order a person reads them, each once (state queries share meshes). */
static const request_type effect_order[] = {REQUEST_RAY, REQUEST_TRIANGLE, REQUEST_MESH, REQUEST_DISTANCE};
#define EFFECT_ORDER_COUNT (sizeof effect_order / sizeof effect_order[0])

/* "rays", "rays and meshes", "rays, meshes and distance": what a world serves, for a person. */
static const char *effects_words(unsigned effects, char *buf, size_t len)
{
    const char *names[EFFECT_ORDER_COUNT];
    size_t n = 0;
    for (size_t k = 0; k < EFFECT_ORDER_COUNT; k++)
        if (effects & effect_of[effect_order[k]].bit)
            names[n++] = effect_of[effect_order[k]].effect;
    if (n == 0) {
        snprintf(buf, len, "nothing");
        return buf;
    }
    size_t used = 0;
    buf[0] = '\0';
    for (size_t k = 0; k < n && used < len; k++) {
        const char *sep = k == 0 ? "" : k + 1 == n ? " and " : ", ";
        int w = snprintf(buf + used, len - used, "%s%s", sep, names[k]);
        if (w < 0)
            break;
        used += (size_t)w;
    }
    return buf;
}

/* Checks that need only the header, in the order the protocol documents. */
static int check_header(job *j, int64_t now_utime)
{
    dispatch_request *req = &j->req;
    char q[48];
    if (req->type == REQUEST_ADMIN && check_admin_channel(j) != TRIOCT_OK)
        return j->status;
    if (channel_has_world(req->channel_kind) && strcmp(j->hdr.world, req->channel_name) != 0)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST,
                        "header.world \"%s\" differs from world %s named by the channel",
                        dispatch_quote(j->hdr.world, q, sizeof q), req->channel_name);
    if (req->channel_kind == TRIOCT_CHANNEL_LOAD && req->world[0] == '\0')
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST,
                        "LOAD needs header.world to name the world: \"%s\" is not 1..%d characters of "
                        "[A-Za-z0-9_]",
                        dispatch_quote(j->hdr.world, q, sizeof q), TRIOCT_MAX_NAME_LEN);
    if (req->deadline_utime != 0 && req->deadline_utime < now_utime) {
        /* A deadline far in the past (any peer may send INT64_MIN) is later than an int64
         * counts: the subtraction must not overflow. */
        int64_t late;
        if (__builtin_sub_overflow(now_utime, req->deadline_utime, &late))
            return job_fail(j, TRIOCT_ERR_DEADLINE, "deadline_utime %lld passed more than %lld us before the work could start",
                            (long long)req->deadline_utime, (long long)INT64_MAX);
        return job_fail(j, TRIOCT_ERR_DEADLINE, "deadline_utime %lld passed %lld us before the work could start",
                        (long long)req->deadline_utime, (long long)late);
    }
    if (channel_has_world(req->channel_kind)) {
        j->w = registry_acquire(j->ctx->worlds, req->channel_name);
        failed_world failed;
        if (!j->w && j->ctx->failed != NULL && failed_worlds_find(j->ctx->failed, req->channel_name, &failed))
            return job_fail(j, TRIOCT_ERR_LOAD_FAILED, "world %s of daemon %s is not served: its build failed: %s",
                            req->channel_name, j->ctx->daemon, failed.error);
        if (!j->w)
            return job_fail(j, TRIOCT_ERR_UNKNOWN_WORLD, "world %s is not held by daemon %s",
                            req->channel_name, j->ctx->daemon);
        j->world_version = (int64_t)j->w->version;
    }
    if (req->type != REQUEST_ADMIN && req->type != REQUEST_OBJECTS && !(j->w->spec.effects & effect_of[req->type].bit)) {
        char words[64];
        return job_fail(j, TRIOCT_ERR_EFFECT, "world %s serves %s only; %s queries need effects = %s",
                        req->channel_name, effects_words(j->w->spec.effects, words, sizeof words),
                        effect_of[req->type].query, effect_of[req->type].effect);
    }
    return TRIOCT_OK;
}

/* Decodes the whole (checked, size-capped) message and hands it to its handler. */
static int run_request(job *j, const void *bytes, size_t size)
{
    int status;
    int len = (int)size;
    switch (j->req.type) {
    case REQUEST_RAY: {
        if (wire_ray_request_type(bytes, size) == WIRE_RAY_REQUEST_V1) {
            /* The layout before contact: the same request, each crossing once. */
            trioct_ray_request_v1_t old;
            if (trioct_ray_request_v1_t_decode(bytes, 0, len, &old) < 0)
                break;
            trioct_ray_request_t m = {
                .header = old.header,
                .detail = old.detail,
                .accuracy = old.accuracy,
                .tmin = old.tmin,
                .tmax = old.tmax,
                .max_hits = old.max_hits,
                .num_rays = old.num_rays,
                .origin = old.origin,
                .direction = old.direction,
                .contact = TRIOCT_RAY_REQUEST_T_CROSSING,
            };
            status = dispatch_ray(j, &m);
            trioct_ray_request_v1_t_decode_cleanup(&old);
            return status;
        }
        trioct_ray_request_t m;
        if (trioct_ray_request_t_decode(bytes, 0, len, &m) < 0)
            break;
        status = dispatch_ray(j, &m);
        trioct_ray_request_t_decode_cleanup(&m);
        return status;
    }
    case REQUEST_TRIANGLE: {
        trioct_triangle_request_t m;
        if (trioct_triangle_request_t_decode(bytes, 0, len, &m) < 0)
            break;
        status = dispatch_triangle(j, &m);
        trioct_triangle_request_t_decode_cleanup(&m);
        return status;
    }
    case REQUEST_MESH: {
        trioct_mesh_request_t m;
        if (trioct_mesh_request_t_decode(bytes, 0, len, &m) < 0)
            break;
        status = dispatch_mesh(j, &m);
        trioct_mesh_request_t_decode_cleanup(&m);
        return status;
    }
    case REQUEST_STATE: {
        trioct_state_request_t m;
        if (trioct_state_request_t_decode(bytes, 0, len, &m) < 0)
            break;
        status = dispatch_state(j, &m);
        trioct_state_request_t_decode_cleanup(&m);
        return status;
    }
    case REQUEST_DISTANCE: {
        trioct_distance_request_t m;
        if (trioct_distance_request_t_decode(bytes, 0, len, &m) < 0)
            break;
        status = dispatch_distance(j, &m);
        trioct_distance_request_t_decode_cleanup(&m);
        return status;
    }
    case REQUEST_OBJECTS: {
        trioct_object_edit_request_t m;
        if (trioct_object_edit_request_t_decode(bytes, 0, len, &m) < 0)
            break;
        status = dispatch_objects(j, &m);
        trioct_object_edit_request_t_decode_cleanup(&m);
        return status;
    }
    default: {
        trioct_admin_request_t m;
        if (trioct_admin_request_t_decode(bytes, 0, len, &m) < 0)
            break;
        status = dispatch_admin(j, &m);
        trioct_admin_request_t_decode_cleanup(&m);
        return status;
    }
    }
    /* wire_check accepted what the generated decoder refuses: the two disagree about the
     * format, which is a bug here, not the client's; say so rather than drop it. */
    return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "the request passed the validator but not the decoder");
}

int dispatch_authorize(job *j)
{
    char why[TRIOCT_MAX_MESSAGE_LEN];
    if (admin_auth_check(j->ctx->auth, j->channel, j->bytes, j->size, j->heard_utime, why, sizeof why) != 0)
        return job_fail(j, TRIOCT_ERR_DENIED, "%s", why);
    return TRIOCT_OK;
}

int dispatch_handle(dispatch_ctx *ctx, const char *channel, const void *bytes, size_t size, int64_t now_utime,
                    dispatch_reply *out)
{
    return dispatch_handle_heard(ctx, channel, bytes, size, now_utime, now_utime, out);
}

int dispatch_handle_heard(dispatch_ctx *ctx, const char *channel, const void *bytes, size_t size, int64_t now_utime,
                          int64_t heard_utime, dispatch_reply *out)
{
    memset(out, 0, sizeof *out);
    job j = {.ctx = ctx, .out = out, .status = TRIOCT_OK, .failed_edit = -1, .channel = channel, .bytes = bytes,
             .size = size, .heard_utime = heard_utime};
    if (peek(ctx, channel, bytes, size, &j.req, &j.hdr) != PEEK_REQUEST)
        return -1;
    reply_start(out, &j.req);

    int status = check_header(&j, now_utime);
    if (status == TRIOCT_OK && size > TRIOCT_MAX_REQUEST_BYTES)
        status = job_fail(&j, TRIOCT_ERR_OVER_CAP,
                          "the request is %zu bytes, over TRIOCT_MAX_REQUEST_BYTES=%d; send fewer items",
                          size, TRIOCT_MAX_REQUEST_BYTES);
    if (status == TRIOCT_OK)
        status = run_request(&j, bytes, size);
    if (status == TRIOCT_OK && j.w && j.counted)
        atomic_fetch_add(&j.w->queries, 1);

    int rc = 0;
    if (status != TRIOCT_OK) {
        /* A handler that failed after encoding part of a reply leaves nothing half-sent. */
        dispatch_reply_free(out);
        reply_head h = job_head(&j, status, j.message);
        int encoded = j.req.type == REQUEST_OBJECTS
                          ? encode_object_reply(out, &h, j.failed_edit, j.w ? (int64_t)j.w->objects->count : 0,
                                                j.w ? (int64_t)j.w->objects->triangles : 0, NULL, 0)
                          : encode_error_reply(out, j.req.type, &h, echoed_detail(&j.req));
        if (encoded != TRIOCT_OK)
            rc = -1;
    }
    out->status = status;
    if (j.w)
        world_release(j.w);
    __trioct_request_header_t_decode_array_cleanup(&j.hdr, 1);
    return rc;
}
