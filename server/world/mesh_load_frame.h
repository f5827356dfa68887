/* What the loader child (server/loader/trioct_load.c) writes to its stdout and the daemon
 * (mesh_load_child.c) reads: one head, then either an error message or the welded mesh.
 * Both ends are the same build on the same machine, so the head is a plain struct in the
 * host's byte order; the reader still checks every count and index, because a child that
 * a hostile file took over may write anything. */
#ifndef TRIOCT_WORLD_MESH_LOAD_FRAME_H
#define TRIOCT_WORLD_MESH_LOAD_FRAME_H

#include <stdint.h>

#include "mesh_load.h"

#define MESH_LOAD_FRAME_MAGIC 0x544c4431u /* "TLD1" */
#define MESH_LOAD_FRAME_MESH 1u           /* vertices (3 doubles each), then indices (3 uint32 each) */
#define MESH_LOAD_FRAME_ERROR 2u          /* message_len bytes of text, no terminator */
#define MESH_LOAD_FRAME_MAX_MESSAGE 1024u

typedef struct mesh_load_frame_head {
    uint32_t magic;
    uint32_t kind;
    uint64_t vertex_count;
    uint64_t triangle_count;
    uint64_t message_len;
    mesh_load_report report;
} mesh_load_frame_head;

#endif
