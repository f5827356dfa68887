/* Channel names of the trioct protocol, in one place for the daemon, libtrioct and tests.
 *   <prefix>_RAY_<world>, <prefix>_TRI_<world>, <prefix>_MESH_<world>: queries, heard only by
 *       the daemon that holds the world, so a fleet of daemons on one bus never answers twice;
 *   <prefix>_ADMIN_<world>: INFO and UNLOAD, heard by the holder;
 *   <prefix>_OBJECTS_<world>: object edits and listings, heard by the holder;
 *   <prefix>_STATE_<world>: robot state checks, heard by the holder;
 *   <prefix>_DISTANCE_<world>: distances and clearance, heard by the holder;
 *   <prefix>_LOAD_<daemon>: LOAD, heard by the named daemon;
 *   <prefix>_LIST: every daemon answers with the worlds it holds;
 *   <prefix>_STATUS: every daemon's heartbeat. */
#ifndef TRIOCT_CHANNELS_H
#define TRIOCT_CHANNELS_H

#include <stddef.h>

#include "trioct_limits.h"

#define TRIOCT_DEFAULT_PREFIX "TRIOCT"
#define TRIOCT_DEFAULT_DAEMON "trioctd"

typedef enum trioct_channel_kind {
    TRIOCT_CHANNEL_RAY,
    TRIOCT_CHANNEL_TRI,
    TRIOCT_CHANNEL_MESH,
    TRIOCT_CHANNEL_ADMIN,
    TRIOCT_CHANNEL_LOAD,
    TRIOCT_CHANNEL_LIST,
    TRIOCT_CHANNEL_STATUS,
    TRIOCT_CHANNEL_OBJECTS,
    TRIOCT_CHANNEL_STATE,
    TRIOCT_CHANNEL_DISTANCE,
    TRIOCT_CHANNEL_KIND_COUNT
} trioct_channel_kind;

/* 1 when s is 1..max_len characters of [A-Za-z0-9_], else 0. */
int trioct_name_valid(const char *s, size_t max_len);

/* Writes the channel of kind for prefix and name (world or daemon; ignored for LIST and
 * STATUS) into out[TRIOCT_MAX_CHANNEL_LEN + 1]. Returns 0, or -1 for an invalid prefix or
 * name (out is then the empty string). */
int trioct_channel_name(char *out, const char *prefix, trioct_channel_kind kind, const char *name);

/* Splits a channel of this prefix into its kind and name (the world or daemon; "" for LIST
 * and STATUS). Returns 0, or -1 when the channel is not one of the protocol's. */
int trioct_channel_parse(const char *channel, const char *prefix, trioct_channel_kind *kind,
                         char name[TRIOCT_MAX_NAME_LEN + 1]);

/* The marks of a daemon run with --ordered on a recorded log, which can carry neither
 * SIGHUP nor SIGTERM: a message on <prefix>_RELOAD_<daemon> reloads the scene at its
 * place in the input, one on <prefix>_STOP_<daemon> begins stopping there. They are not
 * protocol channels (a daemon not run with --ordered never hears them). */
typedef enum trioct_mark_kind { TRIOCT_MARK_RELOAD, TRIOCT_MARK_STOP } trioct_mark_kind;

/* Writes the mark channel of kind for prefix and daemon into
 * out[TRIOCT_MAX_CHANNEL_LEN + 1]. Returns 0, or -1 for an invalid prefix or daemon name
 * (out is then the empty string). */
int trioct_mark_channel_name(char *out, const char *prefix, trioct_mark_kind kind, const char *daemon);

#endif
