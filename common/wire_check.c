/* The wire validator: walks a message's bytes in field order with a bounds-checked cursor,
 * the way the generated decoder would, but only looking, so that the decoder never sees
 * bytes it could misread. */
#include "wire_check.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "trioct_admin_reply_t.h"
#include "trioct_admin_request_t.h"
#include "trioct_distance_reply_t.h"
#include "trioct_distance_request_t.h"
#include "trioct_mesh_reply_t.h"
#include "trioct_object_edit_request_t.h"
#include "trioct_object_reply_t.h"
#include "trioct_state_reply_t.h"
#include "trioct_state_request_t.h"
#include "trioct_mesh_request_t.h"
#include "trioct_ray_reply_t.h"
#include "trioct_ray_request_t.h"
#include "trioct_ray_request_v1_t.h"
#include "trioct_status_t.h"
#include "trioct_triangle_reply_t.h"
#include "trioct_triangle_request_t.h"

/* Encoded sizes of the nested types made of fixed-width numbers only. */
enum {
    VEC3_BYTES = 3 * 8,
    TRIANGLE_BYTES = 3 * VEC3_BYTES,
    POSE_BYTES = 9 * 8 + VEC3_BYTES,
    RAY_HIT_BYTES = 4 + 8 + 4 + 4 + 8 + 8 + VEC3_BYTES,
    CONTACT_BYTES = 3 * 4,
    MESH_PAIR_BYTES = 4 * 4,
    SEGMENT_BYTES = 2 * VEC3_BYTES,
    FINGERPRINT_BYTES = 8,
    AUTH_BYTES = 8 + 16 + 32,
    /* The shortest string: a length of 1 and the NUL it counts. */
    MIN_STRING_BYTES = 4 + 1,
    /* The shortest world_info_t: five empty strings, sixteen int64, five doubles, three
     * int32, three vec3 and no shapes. Only bounds a count early; each world is then walked
     * field by field. */
    MIN_WORLD_INFO_BYTES = 5 * MIN_STRING_BYTES + 16 * 8 + 5 * 8 + 3 * 4 + 3 * VEC3_BYTES,
    /* load_progress_t: two strings, two int64 ids, two int32, an int64 and a double. */
    MIN_LOAD_PROGRESS_BYTES = 2 * MIN_STRING_BYTES + 2 * 8 + 2 * 4 + 8 + 8,
};

/* The generated code counts offsets in int: nothing larger can have come from it. */
#define WIRE_MAX_MESSAGE_BYTES ((size_t)INT32_MAX)

typedef struct wire_cursor {
    const uint8_t *bytes;
    size_t size;
    size_t pos;
    const char *type_name;
    const char *scope;   /* prefix of field names inside a nested array element, or "" */
    int scope_index;
    int element_index;   /* >= 0 while reading an element of a string array */
    wire_error *err;
    int failed;          /* once set, every read is a no-op: the first error is the one kept */
} wire_cursor;

static size_t cursor_remaining(const wire_cursor *c)
{
    return c->size - c->pos;
}

static void write_error(wire_error *err, size_t offset, const char *fmt, va_list args)
{
    if (err == NULL)
        return;
    err->offset = offset;
    vsnprintf(err->what, sizeof err->what, fmt, args);
}

static void error_at(wire_error *err, size_t offset, const char *fmt, ...)
{
    va_list args;
    va_start(args, fmt);
    write_error(err, offset, fmt, args);
    va_end(args);
}

/* Records "<type>: <scope><field> <problem> at byte <offset>" unless an error is already
 * recorded. Names are put together only here, so a valid message formats nothing. */
static void cursor_fail(wire_cursor *c, size_t offset, const char *field, const char *fmt, ...)
{
    if (c->failed)
        return;
    c->failed = 1;
    if (c->err == NULL)
        return;
    char scope[32] = "";
    if (c->scope[0] != '\0')
        snprintf(scope, sizeof scope, "%s[%d].", c->scope, c->scope_index);
    char element[16] = "";
    if (c->element_index >= 0)
        snprintf(element, sizeof element, "[%d]", c->element_index);
    char problem[sizeof c->err->what];
    va_list args;
    va_start(args, fmt);
    vsnprintf(problem, sizeof problem, fmt, args);
    va_end(args);
    error_at(c->err, offset, "%s: %s%s%s %s at byte %zu", c->type_name, scope, field, element, problem,
             offset);
}

/* Steps over n bytes of field, or fails when fewer remain. */
static void cursor_skip(wire_cursor *c, size_t n, const char *field)
{
    if (c->failed)
        return;
    if (n > cursor_remaining(c)) {
        cursor_fail(c, c->pos, field, "needs %zu bytes, %zu remain", n, cursor_remaining(c));
        return;
    }
    c->pos += n;
}

static uint64_t load_big_endian(const uint8_t *p, size_t n)
{
    uint64_t v = 0;
    for (size_t i = 0; i < n; i++)
        v = (v << 8) | p[i];
    return v;
}

/* LCM writes two's complement big-endian; converting through the unsigned value keeps the
 * bit pattern without relying on an implementation-defined cast. */
static int32_t cursor_read_i32(wire_cursor *c, const char *field)
{
    size_t at = c->pos;
    cursor_skip(c, 4, field);
    if (c->failed)
        return 0;
    uint32_t u = (uint32_t)load_big_endian(c->bytes + at, 4);
    int32_t v;
    memcpy(&v, &u, sizeof v);
    return v;
}

static void cursor_int8(wire_cursor *c, const char *field) { cursor_skip(c, 1, field); }
static void cursor_int16(wire_cursor *c, const char *field) { cursor_skip(c, 2, field); }
static void cursor_int32(wire_cursor *c, const char *field) { cursor_skip(c, 4, field); }
static void cursor_int64(wire_cursor *c, const char *field) { cursor_skip(c, 8, field); }
static void cursor_double(wire_cursor *c, const char *field) { cursor_skip(c, 8, field); }
static void cursor_vec3(wire_cursor *c, const char *field) { cursor_skip(c, VEC3_BYTES, field); }

/* An array count: not negative, and no more elements than the remaining bytes could hold
 * at min_element_bytes each (every array it sizes, together), so no walk over the elements
 * can run long and no decoder allocation can exceed the message. */
static int32_t cursor_count(wire_cursor *c, const char *field, size_t min_element_bytes)
{
    size_t at = c->pos;
    int32_t count = cursor_read_i32(c, field);
    if (c->failed)
        return 0;
    if (count < 0) {
        cursor_fail(c, at, field, "%ld is negative", (long)count);
        return 0;
    }
    size_t remaining = cursor_remaining(c);
    if ((size_t)count > remaining / min_element_bytes) {
        cursor_fail(c, at, field, "%ld needs at least %zu bytes per element, %zu remain", (long)count,
                    min_element_bytes, remaining);
        return 0;
    }
    return count;
}

/* count elements of element_bytes each. cursor_count's bound already covers them; the
 * check stays so that a bound edited out of step with its arrays fails safe, not out of
 * bounds. */
static void cursor_fixed_array(wire_cursor *c, int32_t count, size_t element_bytes, const char *field)
{
    if (c->failed)
        return;
    if ((size_t)count > cursor_remaining(c) / element_bytes) {
        cursor_fail(c, c->pos, field, "needs %ld x %zu bytes, %zu remain", (long)count, element_bytes,
                    cursor_remaining(c));
        return;
    }
    c->pos += (size_t)count * element_bytes;
}

static void cursor_string_text(wire_cursor *c, const char *field, size_t at, int32_t length)
{
    if (length < 1) {
        cursor_fail(c, at, field, "length %ld is below 1", (long)length);
        return;
    }
    if ((size_t)length > cursor_remaining(c)) {
        cursor_fail(c, at, field, "length %ld runs past the end (%zu bytes remain)", (long)length,
                    cursor_remaining(c));
        return;
    }
    const uint8_t *text = c->bytes + c->pos;
    const uint8_t *nul = memchr(text, '\0', (size_t)length);
    if (nul == NULL) {
        cursor_fail(c, c->pos + (size_t)length - 1, field, "does not end in NUL");
        return;
    }
    if (nul != text + length - 1) {
        cursor_fail(c, c->pos + (size_t)(nul - text), field, "has a NUL before its end");
        return;
    }
    c->pos += (size_t)length;
}

/* A string as the encoder writes it: int32 length counting the NUL, then exactly that many
 * bytes of which only the last is NUL (an earlier NUL would decode as a shorter string and
 * re-encode differently). index >= 0 names an element of a string array. */
static void cursor_string_element(wire_cursor *c, const char *field, int index)
{
    c->element_index = index;
    size_t at = c->pos;
    int32_t length = cursor_read_i32(c, field);
    if (!c->failed)
        cursor_string_text(c, field, at, length);
    c->element_index = -1;
}

static void cursor_string(wire_cursor *c, const char *field)
{
    cursor_string_element(c, field, -1);
}

static void cursor_expect_end(wire_cursor *c)
{
    if (c->failed || c->pos == c->size)
        return;
    c->failed = 1;
    size_t extra = cursor_remaining(c);
    error_at(c->err, c->pos, "%s: %zu byte%s left over after the message at byte %zu", c->type_name, extra,
             extra == 1 ? "" : "s", c->pos);
}

/* ---- nested types ---- */

static void walk_request_header(wire_cursor *c)
{
    cursor_int64(c, "header.client_id");
    cursor_int64(c, "header.request_id");
    cursor_string(c, "header.reply_channel");
    cursor_string(c, "header.world");
    cursor_int64(c, "header.deadline_utime");
}

static void walk_reply_header(wire_cursor *c)
{
    cursor_int64(c, "header.client_id");
    cursor_int64(c, "header.request_id");
    cursor_string(c, "header.daemon");
    cursor_string(c, "header.world");
    cursor_int64(c, "header.world_version");
    cursor_int16(c, "header.status");
    cursor_string(c, "header.message");
    cursor_int32(c, "header.chunk_index");
    cursor_int32(c, "header.chunk_count");
}

static void walk_world_info(wire_cursor *c)
{
    cursor_string(c, "name");
    cursor_string(c, "daemon");
    cursor_int64(c, "version");
    cursor_string(c, "source");
    cursor_string(c, "accuracy");
    cursor_double(c, "seed_epsilon");
    cursor_int32(c, "effects");
    cursor_int64(c, "triangles");
    cursor_int64(c, "vertices");
    cursor_int64(c, "degenerate");
    cursor_int64(c, "duplicates");
    cursor_vec3(c, "bbox_min");
    cursor_vec3(c, "bbox_max");
    cursor_int64(c, "nodes");
    cursor_int64(c, "leaves");
    cursor_int32(c, "max_level");
    cursor_double(c, "resolution");
    cursor_double(c, "world_size");
    cursor_vec3(c, "world_min");
    cursor_int64(c, "bytes_nodes");
    cursor_int64(c, "bytes_leaf_lists");
    cursor_int64(c, "bytes_triangles");
    cursor_int64(c, "bytes_effects");
    cursor_int64(c, "bytes_total");
    cursor_int64(c, "memory_bytes");
    cursor_int64(c, "memory_budget");
    cursor_double(c, "build_seconds");
    cursor_double(c, "load_seconds");
    cursor_int64(c, "objects");
    cursor_int64(c, "queries");
    cursor_string(c, "last_error");
    int32_t num_shapes = cursor_count(c, "num_shapes", MIN_STRING_BYTES);
    for (int32_t i = 0; i < num_shapes && !c->failed; i++)
        cursor_string_element(c, "shapes", i);
}

/* num_worlds has been checked against MIN_WORLD_INFO_BYTES, so this loop is bounded by the
 * message size whatever the count says. */
static void walk_worlds(wire_cursor *c)
{
    int32_t num_worlds = cursor_count(c, "num_worlds", MIN_WORLD_INFO_BYTES);
    c->scope = "worlds";
    for (int32_t i = 0; i < num_worlds && !c->failed; i++) {
        c->scope_index = i;
        walk_world_info(c);
    }
    c->scope = "";
}

/* ---- messages, one function each, fields in declaration order ---- */

static void walk_ray_request_v1(wire_cursor *c)
{
    walk_request_header(c);
    cursor_int8(c, "detail");
    cursor_int8(c, "accuracy");
    cursor_double(c, "tmin");
    cursor_double(c, "tmax");
    cursor_int32(c, "max_hits");
    int32_t num_rays = cursor_count(c, "num_rays", 2 * VEC3_BYTES);
    cursor_fixed_array(c, num_rays, VEC3_BYTES, "origin");
    cursor_fixed_array(c, num_rays, VEC3_BYTES, "direction");
}

/* ray_request_v1_t's fields, then contact. */
static void walk_ray_request(wire_cursor *c)
{
    walk_ray_request_v1(c);
    cursor_int8(c, "contact");
}

static void walk_triangle_request(wire_cursor *c)
{
    walk_request_header(c);
    cursor_int8(c, "detail");
    cursor_int8(c, "accuracy");
    int32_t num_triangles = cursor_count(c, "num_triangles", TRIANGLE_BYTES);
    cursor_fixed_array(c, num_triangles, TRIANGLE_BYTES, "triangles");
}

static void walk_mesh_request(wire_cursor *c)
{
    walk_request_header(c);
    cursor_int8(c, "detail");
    cursor_int8(c, "accuracy");
    cursor_string(c, "shape");
    int32_t num_shape_triangles = cursor_count(c, "num_shape_triangles", TRIANGLE_BYTES);
    cursor_fixed_array(c, num_shape_triangles, TRIANGLE_BYTES, "shape_triangles");
    int32_t num_poses = cursor_count(c, "num_poses", POSE_BYTES);
    cursor_fixed_array(c, num_poses, POSE_BYTES, "poses");
}

static void walk_admin_request(wire_cursor *c)
{
    walk_request_header(c);
    cursor_int8(c, "op");
    cursor_string(c, "mesh_path");
    cursor_double(c, "resolution");
    cursor_int8(c, "accuracy");
    cursor_double(c, "seed_epsilon");
    cursor_int32(c, "effects");
    cursor_skip(c, AUTH_BYTES, "auth");
}

/* A reply's table of object names (chunk 0; empty in the others). */
static void walk_object_names(wire_cursor *c)
{
    int32_t num_objects = cursor_count(c, "num_objects", MIN_STRING_BYTES);
    for (int32_t i = 0; i < num_objects && !c->failed; i++)
        cursor_string_element(c, "objects", i);
}

/* The shortest object_edit_t: an op, two empty strings, a pose, the rotation's form and
 * quaternion, and no triangles. */
enum { MIN_OBJECT_EDIT_BYTES = 1 + 2 * MIN_STRING_BYTES + POSE_BYTES + 1 + 4 * 8 + 4 };

static void walk_object_edit_request(wire_cursor *c)
{
    walk_request_header(c);
    cursor_int8(c, "list");
    int32_t num_edits = cursor_count(c, "num_edits", MIN_OBJECT_EDIT_BYTES);
    c->scope = "edits";
    for (int32_t i = 0; i < num_edits && !c->failed; i++) {
        c->scope_index = i;
        cursor_int8(c, "op");
        cursor_string(c, "name");
        cursor_string(c, "mesh");
        cursor_skip(c, POSE_BYTES, "pose");
        cursor_int8(c, "rotation");
        cursor_skip(c, 4 * 8, "quaternion");
        int32_t num_triangles = cursor_count(c, "num_triangles", TRIANGLE_BYTES);
        cursor_fixed_array(c, num_triangles, TRIANGLE_BYTES, "triangles");
    }
    c->scope = "";
    cursor_skip(c, AUTH_BYTES, "auth");
}

/* The shortest object_info_t: two empty strings, two int64, a pose, two vec3, an int32. */
enum { MIN_OBJECT_INFO_BYTES = 2 * MIN_STRING_BYTES + 2 * 8 + POSE_BYTES + 2 * VEC3_BYTES + 4 };

static void walk_object_reply(wire_cursor *c)
{
    walk_reply_header(c);
    cursor_int32(c, "failed_edit");
    cursor_int64(c, "objects");
    cursor_int64(c, "triangles");
    int32_t num_objects = cursor_count(c, "num_objects", MIN_OBJECT_INFO_BYTES);
    c->scope = "list";
    for (int32_t i = 0; i < num_objects && !c->failed; i++) {
        c->scope_index = i;
        cursor_string(c, "name");
        cursor_string(c, "mesh");
        cursor_int64(c, "triangles");
        cursor_skip(c, POSE_BYTES + 2 * VEC3_BYTES, "pose and box");
        cursor_int64(c, "bytes");
        cursor_int32(c, "shared");
    }
    c->scope = "";
}

/* The shortest state_link_t: two empty strings and no triangles. */
enum { MIN_STATE_LINK_BYTES = 2 * MIN_STRING_BYTES + 4, STATE_CONTACT_BYTES = 4 + 4 + 1 + 3 * 4 };

static void walk_state_request(wire_cursor *c)
{
    walk_request_header(c);
    cursor_int8(c, "detail");
    cursor_int8(c, "self_collision");
    int32_t num_links = cursor_count(c, "num_links", MIN_STATE_LINK_BYTES);
    c->scope = "links";
    for (int32_t i = 0; i < num_links && !c->failed; i++) {
        c->scope_index = i;
        cursor_string(c, "name");
        cursor_string(c, "shape");
        int32_t num_triangles = cursor_count(c, "num_triangles", TRIANGLE_BYTES);
        cursor_fixed_array(c, num_triangles, TRIANGLE_BYTES, "triangles");
    }
    c->scope = "";
    int32_t num_allowed = cursor_count(c, "num_allowed", 2 * MIN_STRING_BYTES);
    for (int32_t i = 0; i < num_allowed && !c->failed; i++)
        cursor_string_element(c, "allowed_a", i);
    for (int32_t i = 0; i < num_allowed && !c->failed; i++)
        cursor_string_element(c, "allowed_b", i);
    int32_t num_poses = cursor_count(c, "num_poses", POSE_BYTES);
    cursor_fixed_array(c, num_poses, POSE_BYTES, "poses");
    cursor_int8(c, "rotation");
    int32_t num_quaternions = cursor_count(c, "num_quaternions", 8);
    cursor_fixed_array(c, num_quaternions, 8, "quaternions");
}

static void walk_state_reply(wire_cursor *c)
{
    walk_reply_header(c);
    cursor_int8(c, "detail");
    int32_t num_states = cursor_count(c, "num_states", 4);
    cursor_fixed_array(c, num_states, 4, "found");
    walk_object_names(c);
    int32_t num_contacts = cursor_count(c, "num_contacts", STATE_CONTACT_BYTES);
    cursor_fixed_array(c, num_contacts, STATE_CONTACT_BYTES, "contacts");
}

static void walk_distance_request(wire_cursor *c)
{
    walk_request_header(c);
    cursor_int8(c, "kind");
    cursor_double(c, "within");
    int32_t num_points = cursor_count(c, "num_points", VEC3_BYTES);
    cursor_fixed_array(c, num_points, VEC3_BYTES, "points");
    cursor_string(c, "shape");
    int32_t num_shape_triangles = cursor_count(c, "num_shape_triangles", TRIANGLE_BYTES);
    cursor_fixed_array(c, num_shape_triangles, TRIANGLE_BYTES, "shape_triangles");
    int32_t num_poses = cursor_count(c, "num_poses", POSE_BYTES);
    cursor_fixed_array(c, num_poses, POSE_BYTES, "poses");
    cursor_int8(c, "rotation");
    int32_t num_quaternions = cursor_count(c, "num_quaternions", 8);
    cursor_fixed_array(c, num_quaternions, 8, "quaternions");
}

/* distance_result_t: item, found, clear, four doubles, two vec3, three int32, three int8. */
enum { DISTANCE_RESULT_BYTES = 4 + 1 + 1 + 4 * 8 + 2 * VEC3_BYTES + 3 * 4 + 3 };

static void walk_distance_reply(wire_cursor *c)
{
    walk_reply_header(c);
    cursor_int8(c, "kind");
    walk_object_names(c);
    int32_t num_results = cursor_count(c, "num_results", DISTANCE_RESULT_BYTES);
    cursor_fixed_array(c, num_results, DISTANCE_RESULT_BYTES, "results");
}

static void walk_ray_reply(wire_cursor *c)
{
    walk_reply_header(c);
    cursor_int8(c, "detail");
    int32_t num_rays = cursor_count(c, "num_rays", 4);
    cursor_fixed_array(c, num_rays, 4, "found");
    walk_object_names(c);
    int32_t num_hits = cursor_count(c, "num_hits", RAY_HIT_BYTES);
    cursor_fixed_array(c, num_hits, RAY_HIT_BYTES, "hits");
}

static void walk_triangle_reply(wire_cursor *c)
{
    walk_reply_header(c);
    cursor_int8(c, "detail");
    int32_t num_triangles = cursor_count(c, "num_triangles", 4);
    cursor_fixed_array(c, num_triangles, 4, "found");
    walk_object_names(c);
    int32_t num_contacts = cursor_count(c, "num_contacts", CONTACT_BYTES);
    cursor_fixed_array(c, num_contacts, CONTACT_BYTES, "contacts");
    int32_t num_segments = cursor_count(c, "num_segments", SEGMENT_BYTES);
    cursor_fixed_array(c, num_segments, SEGMENT_BYTES, "segments");
}

static void walk_mesh_reply(wire_cursor *c)
{
    walk_reply_header(c);
    cursor_int8(c, "detail");
    int32_t num_poses = cursor_count(c, "num_poses", 4);
    cursor_fixed_array(c, num_poses, 4, "found");
    walk_object_names(c);
    int32_t num_pairs = cursor_count(c, "num_pairs", MESH_PAIR_BYTES);
    cursor_fixed_array(c, num_pairs, MESH_PAIR_BYTES, "pairs");
}

static void walk_admin_reply(wire_cursor *c)
{
    walk_reply_header(c);
    cursor_int8(c, "op");
    walk_worlds(c);
}

static void walk_status(wire_cursor *c)
{
    cursor_int64(c, "utime");
    cursor_string(c, "daemon");
    cursor_string(c, "version");
    cursor_int64(c, "uptime_us");
    cursor_int8(c, "state");
    cursor_int32(c, "threads");
    cursor_int32(c, "queue_depth");
    cursor_int32(c, "queue_capacity");
    cursor_int64(c, "memory_used");
    cursor_int64(c, "memory_budget");
    cursor_skip(c, 7 * 8, "served");
    cursor_int64(c, "malformed");
    cursor_int64(c, "duplicates_answered");
    cursor_int64(c, "duplicates_joined");
    int32_t num_status_codes = cursor_count(c, "num_status_codes", 8);
    cursor_fixed_array(c, num_status_codes, 8, "replies_by_status");
    cursor_int64(c, "latency_p50_us");
    cursor_int64(c, "latency_p99_us");
    cursor_int64(c, "latency_count");
    walk_worlds(c);
    int32_t num_loads = cursor_count(c, "num_loads", MIN_LOAD_PROGRESS_BYTES);
    c->scope = "loads";
    for (int32_t i = 0; i < num_loads && !c->failed; i++) {
        c->scope_index = i;
        cursor_string(c, "world");
        cursor_int64(c, "client_id");
        cursor_int64(c, "request_id");
        cursor_string(c, "phase");
        cursor_int32(c, "files_done");
        cursor_int32(c, "files_total");
        cursor_int64(c, "triangles");
        cursor_double(c, "elapsed_seconds");
    }
    c->scope = "";
}

typedef struct wire_type_info {
    const char *name;
    int64_t (*fingerprint)(void);
    void (*walk)(wire_cursor *c);
} wire_type_info;

static const wire_type_info type_table[WIRE_TYPE_COUNT] = {
    [WIRE_RAY_REQUEST] = {"ray_request_t", __trioct_ray_request_t_get_hash, walk_ray_request},
    [WIRE_TRIANGLE_REQUEST] = {"triangle_request_t", __trioct_triangle_request_t_get_hash,
                               walk_triangle_request},
    [WIRE_MESH_REQUEST] = {"mesh_request_t", __trioct_mesh_request_t_get_hash, walk_mesh_request},
    [WIRE_ADMIN_REQUEST] = {"admin_request_t", __trioct_admin_request_t_get_hash, walk_admin_request},
    [WIRE_RAY_REPLY] = {"ray_reply_t", __trioct_ray_reply_t_get_hash, walk_ray_reply},
    [WIRE_TRIANGLE_REPLY] = {"triangle_reply_t", __trioct_triangle_reply_t_get_hash, walk_triangle_reply},
    [WIRE_MESH_REPLY] = {"mesh_reply_t", __trioct_mesh_reply_t_get_hash, walk_mesh_reply},
    [WIRE_ADMIN_REPLY] = {"admin_reply_t", __trioct_admin_reply_t_get_hash, walk_admin_reply},
    [WIRE_STATUS] = {"status_t", __trioct_status_t_get_hash, walk_status},
    [WIRE_RAY_REQUEST_V1] = {"ray_request_v1_t", __trioct_ray_request_v1_t_get_hash, walk_ray_request_v1},
    [WIRE_OBJECT_EDIT_REQUEST] = {"object_edit_request_t", __trioct_object_edit_request_t_get_hash,
                                  walk_object_edit_request},
    [WIRE_OBJECT_REPLY] = {"object_reply_t", __trioct_object_reply_t_get_hash, walk_object_reply},
    [WIRE_STATE_REQUEST] = {"state_request_t", __trioct_state_request_t_get_hash, walk_state_request},
    [WIRE_STATE_REPLY] = {"state_reply_t", __trioct_state_reply_t_get_hash, walk_state_reply},
    [WIRE_DISTANCE_REQUEST] = {"distance_request_t", __trioct_distance_request_t_get_hash, walk_distance_request},
    [WIRE_DISTANCE_REPLY] = {"distance_reply_t", __trioct_distance_reply_t_get_hash, walk_distance_reply},
};

static int wire_type_valid(wire_type type)
{
    return (int)type >= 0 && (int)type < WIRE_TYPE_COUNT;
}

/* A message sent on the wrong channel is the likely cause of a foreign fingerprint, so the
 * error names the type it belongs to when it is one of ours. */
static void cursor_fingerprint(wire_cursor *c, const wire_type_info *expected)
{
    size_t at = c->pos;
    cursor_skip(c, FINGERPRINT_BYTES, "fingerprint");
    if (c->failed)
        return;
    uint64_t found = load_big_endian(c->bytes + at, FINGERPRINT_BYTES);
    if (found == (uint64_t)expected->fingerprint())
        return;
    c->failed = 1;
    for (int t = 0; t < WIRE_TYPE_COUNT; t++) {
        if (found == (uint64_t)type_table[t].fingerprint()) {
            error_at(c->err, at, "%s: the fingerprint is that of %s", c->type_name, type_table[t].name);
            return;
        }
    }
    error_at(c->err, at, "%s: fingerprint 0x%016llx is not 0x%016llx", c->type_name,
             (unsigned long long)found, (unsigned long long)(uint64_t)expected->fingerprint());
}

int wire_check(wire_type type, const void *bytes, size_t size, wire_error *err)
{
    if (err != NULL) {
        err->offset = 0;
        err->what[0] = '\0';
    }
    if (!wire_type_valid(type)) {
        error_at(err, 0, "wire type %d is unknown", (int)type);
        return -1;
    }
    const wire_type_info *info = &type_table[type];
    if (bytes == NULL) {
        error_at(err, 0, "%s: no bytes", info->name);
        return -1;
    }
    if (size > WIRE_MAX_MESSAGE_BYTES) {
        error_at(err, 0, "%s: %zu bytes is more than LCM can encode", info->name, size);
        return -1;
    }
    wire_cursor c = {
        .bytes = bytes, .size = size, .pos = 0, .type_name = info->name, .scope = "", .element_index = -1,
        .err = err,
    };
    cursor_fingerprint(&c, info);
    if (!c.failed)
        info->walk(&c);
    cursor_expect_end(&c);
    return c.failed ? -1 : 0;
}

const char *wire_type_name(wire_type type)
{
    return wire_type_valid(type) ? type_table[type].name : "unknown";
}

int64_t wire_fingerprint(wire_type type)
{
    return wire_type_valid(type) ? type_table[type].fingerprint() : 0;
}

wire_type wire_ray_request_type(const void *bytes, size_t size)
{
    if (bytes != NULL && size >= FINGERPRINT_BYTES &&
        load_big_endian(bytes, FINGERPRINT_BYTES) == (uint64_t)wire_fingerprint(WIRE_RAY_REQUEST_V1))
        return WIRE_RAY_REQUEST_V1;
    return WIRE_RAY_REQUEST;
}
