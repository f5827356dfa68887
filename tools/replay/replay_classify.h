/* What one event of a log is to a replay: a request the daemon will hear (well-formed or
 * not), a reply, a heartbeat, the reload or stop mark of an ordered replay, or anything else.
 *
 * Requests are told by their channel (<prefix>_RAY_<world>, ..._TRI_, ..._MESH_, ..._ADMIN_,
 * ..._LOAD_<daemon>, <prefix>_LIST); a request whose bytes the validator refuses is
 * MALFORMED: no reply can be addressed to it. Replies are told by their bytes (fingerprint,
 * then the validator), since they travel on channels each client chooses. Nothing is ever
 * decoded before wire_check has passed it. */
#ifndef TRIOCT_REPLAY_CLASSIFY_H
#define TRIOCT_REPLAY_CLASSIFY_H

#include <stddef.h>
#include <stdint.h>

#include "replay_log.h"
#include "trioct_limits.h"
#include "wire_check.h"

typedef struct replay_proto {
    char prefix[TRIOCT_MAX_PREFIX_LEN + 1];
    char name[TRIOCT_MAX_NAME_LEN + 1]; /* the daemon's, for its LOAD, reload and stop channels */
    char status_channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    char reload_channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    char stop_channel[TRIOCT_MAX_CHANNEL_LEN + 1];
} replay_proto;

/* The channels of a daemon with this prefix and name. 0, or -1 for an invalid name. */
int replay_proto_init(replay_proto *p, const char *prefix, const char *name);

/* The prefix and name the scene's [daemon] section gives (else the daemon's defaults).
 * 0, or -1 with err when the scene does not load. */
int replay_proto_from_scene(replay_proto *p, const char *scene_path, char *err, size_t err_len);

typedef enum replay_kind {
    KIND_REQUEST,   /* on a request channel, passes the validator */
    KIND_MALFORMED, /* on a request channel, refused by the validator */
    KIND_REPLY,     /* a reply type's fingerprint, passes the validator */
    KIND_BAD_REPLY, /* a reply type's fingerprint, refused by the validator */
    KIND_STATUS,    /* <prefix>_STATUS: heartbeats, never compared */
    KIND_RELOAD,    /* <prefix>_RELOAD_<name>: an ordered daemon reloads its scene here */
    KIND_STOP,      /* <prefix>_STOP_<name>: an ordered daemon begins stopping here */
    KIND_OTHER,
} replay_kind;

typedef struct replay_class {
    replay_kind kind;
    wire_type type;       /* REQUEST, MALFORMED: the channel's; REPLY, BAD_REPLY: the bytes' */
    int64_t client_id;    /* REQUEST, REPLY */
    int64_t request_id;
    char reply_channel[TRIOCT_MAX_CHANNEL_LEN + 1]; /* REQUEST */
    int32_t chunk_index;  /* REPLY */
    int32_t chunk_count;
} replay_class;

void replay_classify(const replay_proto *p, const replay_event *ev, replay_class *c);

/* Whether a replay feeds events of this kind to the daemon: everything but replies and
 * heartbeats, so a request log and its golden log (requests and replies) feed the very
 * same input. */
int replay_kind_is_input(replay_kind kind);

#endif
