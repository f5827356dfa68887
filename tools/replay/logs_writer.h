/* Writing the request logs of tests/logs: events collected in memory, each stamped by a
 * clock that starts at a fixed instant and advances a millisecond an event, then saved in
 * one go. Nothing here reads the time or the environment, so a log is a function of the
 * code that wrote it.
 *
 * Requests are encoded with the generated encoders; hostile bytes are written as they are.
 * Channels are the replay scene's (LOGS_PREFIX, LOGS_DAEMON). */
#ifndef TRIOCT_LOGS_WRITER_H
#define TRIOCT_LOGS_WRITER_H

#include <stddef.h>
#include <stdint.h>

#include "replay_log.h"
#include "trioct_admin_request_t.h"
#include "trioct_distance_request_t.h"
#include "trioct_mesh_request_t.h"
#include "trioct_object_edit_request_t.h"
#include "trioct_state_request_t.h"
#include "trioct_ray_request_t.h"
#include "trioct_ray_request_v1_t.h"
#include "trioct_triangle_request_t.h"

#define LOGS_PREFIX "TRIOCT"
#define LOGS_DAEMON "replayd"
/* 2023-11-14 22:13:20 UTC, and a millisecond between events: lcm-logplayer plays a live
 * replay at this pace. */
#define LOGS_EPOCH_US INT64_C(1700000000000000)
#define LOGS_STEP_US 1000
/* 2100-01-01: a deadline that never passes while these logs are in use. */
#define LOGS_FAR_DEADLINE INT64_C(4102444800000000)

typedef struct logs_writer {
    replay_event *events;
    size_t count, cap;
    int64_t clock;
    int failed; /* out of memory or an encoder refused: saving fails */
    int unsigned_changes; /* 1: lw_admin, lw_objects and lw_mark leave auth zero */
} logs_writer;

void lw_init(logs_writer *w);

/* Bytes as they are, copied. */
void lw_raw(logs_writer *w, const char *channel, const void *data, size_t size);

/* Encoded requests. lw_ray_v1: the ray request of clients before contact existed. */
void lw_ray(logs_writer *w, const char *channel, const trioct_ray_request_t *m);
void lw_ray_v1(logs_writer *w, const char *channel, const trioct_ray_request_v1_t *m);
void lw_triangle(logs_writer *w, const char *channel, const trioct_triangle_request_t *m);
void lw_mesh(logs_writer *w, const char *channel, const trioct_mesh_request_t *m);
void lw_admin(logs_writer *w, const char *channel, const trioct_admin_request_t *m);
void lw_objects(logs_writer *w, const char *channel, const trioct_object_edit_request_t *m);
void lw_state(logs_writer *w, const char *channel, const trioct_state_request_t *m);
void lw_distance(logs_writer *w, const char *channel, const trioct_distance_request_t *m);
/* An ordered daemon's mark: the word, then an auth_t's bytes signed with the logs' key.
 * lw_admin and lw_objects sign with it too (replay_key.h). */
void lw_mark(logs_writer *w, const char *channel, const char *word);

/* The last event again, byte for byte, a step later: a replayed message. */
void lw_repeat_last(logs_writer *w);

/* The encoding of a request, for hostile variations of it (caller frees); NULL on failure. */
uint8_t *lw_encode_ray(const trioct_ray_request_t *m, size_t *size);
uint8_t *lw_encode_ray_v1(const trioct_ray_request_v1_t *m, size_t *size);

/* Writes dir/name.lcmlog and empties the writer. 0, or -1 with the reason printed. */
int lw_save(logs_writer *w, const char *dir, const char *name);

/* A channel of the scene: lw_channel(TRIOCT_CHANNEL_RAY, "yard") is "TRIOCT_RAY_yard".
 * Returns a static buffer of eight in rotation. */
const char *lw_channel(int kind, const char *name);
/* The ordered daemon's mark channel of kind (a trioct_mark_kind): "TRIOCT_RELOAD_replayd"
 * for TRIOCT_MARK_RELOAD. Same rotation as lw_channel. */
const char *lw_mark_channel(int kind);

/* A header with no deadline. */
trioct_request_header_t lw_header(int64_t client, int64_t id, const char *reply, const char *world);

#endif
