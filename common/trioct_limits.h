/* The caps of the trioct protocol. A request over one gets TRIOCT_ERR_OVER_CAP with a
 * message naming the cap; nothing is cut silently. docs/protocol.md explains each. */
#ifndef TRIOCT_LIMITS_H
#define TRIOCT_LIMITS_H

/* LCM sends a message in one UDP datagram when channel + payload <= 65,499 bytes; beyond
 * that it fragments, and one lost fragment loses the message silently. Requests must fit
 * one datagram; replies are cut into chunks that each do. */
#define TRIOCT_MAX_REQUEST_BYTES 65000
#define TRIOCT_MAX_CHUNK_BYTES 60000

/* Names: channel names are regular expressions to LCM and at most 63 characters, so every
 * name is [A-Za-z0-9_] and short enough that <prefix>_MESH_<world> fits. */
#define TRIOCT_MAX_PREFIX_LEN 16
#define TRIOCT_MAX_NAME_LEN 32   /* world, daemon and shape names */
#define TRIOCT_MAX_CHANNEL_LEN 63
#define TRIOCT_MAX_MESSAGE_LEN 512 /* reply messages */
#define TRIOCT_MAX_PATH_LEN 1024

/* Per request. 1,280 rays of 48 bytes, 800 triangles of 72 bytes fit one datagram. */
#define TRIOCT_MAX_RAYS 1280
#define TRIOCT_MAX_TRIANGLES 800
#define TRIOCT_MAX_POSES 512
/* Query points of one distance request: 2,048 of 24 bytes fit one datagram. */
#define TRIOCT_MAX_POINTS 2048
#define TRIOCT_MAX_INLINE_SHAPE_TRIANGLES 512
/* Stored hits per ray (ALL), contacts per query triangle, and result records (hits,
 * contacts or pairs) in one whole reply, over all its chunks. */
#define TRIOCT_MAX_HITS_PER_RAY 1000
#define TRIOCT_MAX_CONTACTS_PER_TRIANGLE 10000
#define TRIOCT_MAX_RESULTS 65536
/* Edits in one object_edit_request_t (each at least 117 bytes on the wire). */
#define TRIOCT_MAX_EDITS 256
/* Worlds one daemon lists or reports in one status message. */
#define TRIOCT_MAX_WORLDS 64
/* World builds under way one status message reports. */
#define TRIOCT_MAX_LOADS 64
#define TRIOCT_MAX_SHAPES 16

#endif
