/* A hand-written validator for every trioct message, run before any generated decoder: the
 * lcm-gen decoders allocate count * size before checking the bytes exist, leak on failure
 * and accept strings without a terminator, so hostile bytes must never reach them.
 *
 * wire_check accepts exactly the messages the generated encoder can produce for its type:
 * the type's fingerprint first, every count >= 0 and backed by the bytes that remain,
 * every string a length (>= 1, counting its NUL) followed by that many bytes of which only
 * the last is NUL, and no byte left over. Semantic limits (caps, name characters, finite
 * coordinates) are the dispatcher's, so they get an error reply rather than a silent drop. */
#ifndef TRIOCT_WIRE_CHECK_H
#define TRIOCT_WIRE_CHECK_H

#include <stddef.h>
#include <stdint.h>

typedef enum wire_type {
    WIRE_RAY_REQUEST,
    WIRE_TRIANGLE_REQUEST,
    WIRE_MESH_REQUEST,
    WIRE_ADMIN_REQUEST,
    WIRE_RAY_REPLY,
    WIRE_TRIANGLE_REPLY,
    WIRE_MESH_REPLY,
    WIRE_ADMIN_REPLY,
    WIRE_STATUS,
    WIRE_RAY_REQUEST_V1, /* ray_request_t before its contact field, still taken on RAY */
    WIRE_OBJECT_EDIT_REQUEST,
    WIRE_OBJECT_REPLY,
    WIRE_STATE_REQUEST,
    WIRE_STATE_REPLY,
    WIRE_DISTANCE_REQUEST,
    WIRE_DISTANCE_REPLY,
    WIRE_TYPE_COUNT
} wire_type;

typedef struct wire_error {
    size_t offset;      /* byte where the message went wrong */
    char what[160];     /* "ray_request_t: num_rays -5 is negative at byte 77" */
} wire_error;

/* 0 when bytes hold one well-formed message of type, else -1 with err (may be NULL). Safe
 * on any bytes and any size, allocates nothing. An unknown type, NULL bytes and a size
 * above INT32_MAX (more than the generated code can encode) are rejected too. */
int wire_check(wire_type type, const void *bytes, size_t size, wire_error *err);

/* The type of the request bytes on a RAY channel: WIRE_RAY_REQUEST_V1 when they start with
 * that type's fingerprint (old clients, recorded logs), else WIRE_RAY_REQUEST, which
 * wire_check then holds them to. Safe on any bytes. */
wire_type wire_ray_request_type(const void *bytes, size_t size);

/* The type's name ("ray_request_t") and its fingerprint as the generated code computes it;
 * "unknown" and 0 for a value outside wire_type. */
const char *wire_type_name(wire_type type);
int64_t wire_fingerprint(wire_type type);

#endif
