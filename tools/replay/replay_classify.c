#include "replay_classify.h"

#include <stdio.h>
#include <string.h>

#include "channels.h"
#include "trioct_reply_header_t.h"
#include "trioct_request_header_t.h"
#include "world/scene.h"

int replay_proto_init(replay_proto *p, const char *prefix, const char *name)
{
    memset(p, 0, sizeof *p);
    if (!trioct_name_valid(prefix, TRIOCT_MAX_PREFIX_LEN) || !trioct_name_valid(name, TRIOCT_MAX_NAME_LEN))
        return -1;
    snprintf(p->prefix, sizeof p->prefix, "%s", prefix);
    snprintf(p->name, sizeof p->name, "%s", name);
    if (trioct_channel_name(p->status_channel, prefix, TRIOCT_CHANNEL_STATUS, NULL) < 0)
        return -1;
    if (trioct_mark_channel_name(p->reload_channel, prefix, TRIOCT_MARK_RELOAD, name) < 0 ||
        trioct_mark_channel_name(p->stop_channel, prefix, TRIOCT_MARK_STOP, name) < 0)
        return -1;
    return 0;
}

int replay_proto_from_scene(replay_proto *p, const char *scene_path, char *err, size_t err_len)
{
    scene sc;
    if (scene_load(scene_path, &sc, err, err_len) < 0)
        return -1;
    const char *prefix = TRIOCT_DEFAULT_PREFIX, *name = TRIOCT_DEFAULT_DAEMON;
    for (size_t i = 0; i < sc.daemon_option_count; i++) {
        if (strcmp(sc.daemon_options[i].key, "prefix") == 0)
            prefix = sc.daemon_options[i].value;
        else if (strcmp(sc.daemon_options[i].key, "name") == 0)
            name = sc.daemon_options[i].value;
    }
    int rc = replay_proto_init(p, prefix, name);
    if (rc < 0)
        snprintf(err, err_len, "%s: prefix '%s' or name '%s' is not a channel name", scene_path,
                 prefix, name);
    scene_free(&sc);
    return rc;
}

static int request_type_of(trioct_channel_kind kind, wire_type *type)
{
    switch (kind) {
    case TRIOCT_CHANNEL_RAY:
        *type = WIRE_RAY_REQUEST;
        return 1;
    case TRIOCT_CHANNEL_TRI:
        *type = WIRE_TRIANGLE_REQUEST;
        return 1;
    case TRIOCT_CHANNEL_MESH:
        *type = WIRE_MESH_REQUEST;
        return 1;
    case TRIOCT_CHANNEL_ADMIN:
    case TRIOCT_CHANNEL_LOAD:
    case TRIOCT_CHANNEL_LIST:
        *type = WIRE_ADMIN_REQUEST;
        return 1;
    case TRIOCT_CHANNEL_OBJECTS:
        *type = WIRE_OBJECT_EDIT_REQUEST;
        return 1;
    case TRIOCT_CHANNEL_STATE:
        *type = WIRE_STATE_REQUEST;
        return 1;
    case TRIOCT_CHANNEL_DISTANCE:
        *type = WIRE_DISTANCE_REQUEST;
        return 1;
    default:
        return 0;
    }
}

/* The reply type whose fingerprint the bytes start with, if any. */
static int reply_type_of(const replay_event *ev, wire_type *type)
{
    static const wire_type replies[] = {WIRE_RAY_REPLY, WIRE_TRIANGLE_REPLY, WIRE_MESH_REPLY, WIRE_ADMIN_REPLY,
                                        WIRE_OBJECT_REPLY, WIRE_STATE_REPLY, WIRE_DISTANCE_REPLY};
    if (ev->size < 8)
        return 0;
    uint64_t fp = 0;
    for (int i = 0; i < 8; i++)
        fp = fp << 8 | ev->data[i];
    for (size_t i = 0; i < sizeof replies / sizeof replies[0]; i++) {
        if ((uint64_t)wire_fingerprint(replies[i]) == fp) {
            *type = replies[i];
            return 1;
        }
    }
    return 0;
}

void replay_classify(const replay_proto *p, const replay_event *ev, replay_class *c)
{
    memset(c, 0, sizeof *c);
    c->kind = KIND_OTHER;
    if (strcmp(ev->channel, p->status_channel) == 0) {
        c->kind = KIND_STATUS;
        return;
    }
    if (strcmp(ev->channel, p->reload_channel) == 0) {
        c->kind = KIND_RELOAD;
        return;
    }
    if (strcmp(ev->channel, p->stop_channel) == 0) {
        c->kind = KIND_STOP;
        return;
    }
    trioct_channel_kind kind;
    char name[TRIOCT_MAX_NAME_LEN + 1];
    if (trioct_channel_parse(ev->channel, p->prefix, &kind, name) == 0 && request_type_of(kind, &c->type)) {
        /* A RAY channel carries either ray request type; both are paired and compared. */
        if (c->type == WIRE_RAY_REQUEST)
            c->type = wire_ray_request_type(ev->data, ev->size);
        if (wire_check(c->type, ev->data, ev->size, NULL) != 0) {
            c->kind = KIND_MALFORMED;
            return;
        }
        /* Checked: the header decoder reads only bytes the validator vouched for. */
        trioct_request_header_t h;
        if (__trioct_request_header_t_decode_array(ev->data, 8, (int)ev->size - 8, &h, 1) < 0) {
            c->kind = KIND_MALFORMED;
            return;
        }
        c->kind = KIND_REQUEST;
        c->client_id = h.client_id;
        c->request_id = h.request_id;
        snprintf(c->reply_channel, sizeof c->reply_channel, "%s", h.reply_channel);
        __trioct_request_header_t_decode_array_cleanup(&h, 1);
        return;
    }
    if (!reply_type_of(ev, &c->type))
        return;
    trioct_reply_header_t h;
    if (wire_check(c->type, ev->data, ev->size, NULL) != 0 ||
        __trioct_reply_header_t_decode_array(ev->data, 8, (int)ev->size - 8, &h, 1) < 0) {
        c->kind = KIND_BAD_REPLY;
        return;
    }
    c->kind = KIND_REPLY;
    c->client_id = h.client_id;
    c->request_id = h.request_id;
    c->chunk_index = h.chunk_index;
    c->chunk_count = h.chunk_count;
    __trioct_reply_header_t_decode_array_cleanup(&h, 1);
}

int replay_kind_is_input(replay_kind kind)
{
    return kind == KIND_REQUEST || kind == KIND_MALFORMED || kind == KIND_RELOAD || kind == KIND_STOP ||
           kind == KIND_OTHER;
}
