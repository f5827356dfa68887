#include "logs_writer.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "channels.h"
#include "replay_key.h"

void lw_init(logs_writer *w)
{
    memset(w, 0, sizeof *w);
    w->clock = LOGS_EPOCH_US;
}

/* Takes ownership of data (malloc'ed, size bytes). */
static void push(logs_writer *w, const char *channel, uint8_t *data, size_t size)
{
    if (data == NULL) {
        w->failed = 1;
        return;
    }
    if (w->count == w->cap) {
        size_t cap = w->cap ? 2 * w->cap : 128;
        replay_event *e = realloc(w->events, cap * sizeof *e);
        if (e == NULL) {
            free(data);
            w->failed = 1;
            return;
        }
        w->events = e;
        w->cap = cap;
    }
    char *ch = strdup(channel);
    if (ch == NULL) {
        free(data);
        w->failed = 1;
        return;
    }
    w->events[w->count++] = (replay_event){w->clock, ch, data, size};
    w->clock += LOGS_STEP_US;
}

void lw_raw(logs_writer *w, const char *channel, const void *data, size_t size)
{
    uint8_t *copy = malloc(size + 1);
    if (copy != NULL && size > 0)
        memcpy(copy, data, size);
    push(w, channel, copy, size);
}

void lw_repeat_last(logs_writer *w)
{
    if (w->count == 0) {
        w->failed = 1;
        return;
    }
    const replay_event *last = &w->events[w->count - 1];
    char channel[256];
    snprintf(channel, sizeof channel, "%s", last->channel);
    lw_raw(w, channel, last->data, last->size);
}

/* One function per type: the generated code has no common signature to share. */
#define ENCODE(type, m, size_out)                                     \
    do {                                                              \
        int n_ = type##_encoded_size(m);                              \
        uint8_t *b_ = malloc((size_t)n_ + 1);                         \
        if (b_ != NULL && type##_encode(b_, 0, n_, m) != n_) {        \
            free(b_);                                                 \
            b_ = NULL;                                                \
        }                                                             \
        *(size_out) = (size_t)n_;                                     \
        return b_;                                                    \
    } while (0)

uint8_t *lw_encode_ray(const trioct_ray_request_t *m, size_t *size)
{
    ENCODE(trioct_ray_request_t, m, size);
}

uint8_t *lw_encode_ray_v1(const trioct_ray_request_v1_t *m, size_t *size)
{
    ENCODE(trioct_ray_request_v1_t, m, size);
}

static uint8_t *encode_triangle(const trioct_triangle_request_t *m, size_t *size)
{
    ENCODE(trioct_triangle_request_t, m, size);
}

static uint8_t *encode_mesh(const trioct_mesh_request_t *m, size_t *size)
{
    ENCODE(trioct_mesh_request_t, m, size);
}

static uint8_t *encode_admin(const trioct_admin_request_t *m, size_t *size)
{
    ENCODE(trioct_admin_request_t, m, size);
}

static uint8_t *encode_objects(const trioct_object_edit_request_t *m, size_t *size)
{
    ENCODE(trioct_object_edit_request_t, m, size);
}

static uint8_t *encode_state(const trioct_state_request_t *m, size_t *size)
{
    ENCODE(trioct_state_request_t, m, size);
}

static uint8_t *encode_distance(const trioct_distance_request_t *m, size_t *size)
{
    ENCODE(trioct_distance_request_t, m, size);
}

void lw_ray(logs_writer *w, const char *channel, const trioct_ray_request_t *m)
{
    size_t n;
    uint8_t *b = lw_encode_ray(m, &n);
    push(w, channel, b, n);
}

void lw_ray_v1(logs_writer *w, const char *channel, const trioct_ray_request_v1_t *m)
{
    size_t n;
    uint8_t *b = lw_encode_ray_v1(m, &n);
    push(w, channel, b, n);
}

void lw_triangle(logs_writer *w, const char *channel, const trioct_triangle_request_t *m)
{
    size_t n;
    uint8_t *b = encode_triangle(m, &n);
    push(w, channel, b, n);
}

void lw_mesh(logs_writer *w, const char *channel, const trioct_mesh_request_t *m)
{
    size_t n;
    uint8_t *b = encode_mesh(m, &n);
    push(w, channel, b, n);
}

/* Signed as a trusted client signs: the event's own time, and a nonce that is the event's
 * number (unique in a log, and the same bytes every time the log is written). */
static void sign(logs_writer *w, const char *channel, uint8_t *b, size_t n)
{
    if (b == NULL || w->unsigned_changes)
        return;
    trioct_admin_key key = replay_logs_key();
    unsigned char nonce[TRIOCT_ADMIN_NONCE_BYTES] = {'l', 'o', 'g', 's'};
    uint64_t serial = (uint64_t)w->count;
    for (int i = 0; i < 8; i++)
        nonce[8 + i] = (unsigned char)(serial >> (8 * i));
    trioct_admin_sign_nonce(&key, channel, b, n, w->clock, nonce);
}

void lw_admin(logs_writer *w, const char *channel, const trioct_admin_request_t *m)
{
    size_t n;
    uint8_t *b = encode_admin(m, &n);
    sign(w, channel, b, n);
    push(w, channel, b, n);
}

void lw_objects(logs_writer *w, const char *channel, const trioct_object_edit_request_t *m)
{
    size_t n;
    uint8_t *b = encode_objects(m, &n);
    sign(w, channel, b, n);
    push(w, channel, b, n);
}

void lw_mark(logs_writer *w, const char *channel, const char *word)
{
    size_t len = strlen(word), n = len + TRIOCT_ADMIN_AUTH_BYTES;
    uint8_t *b = calloc(1, n);
    if (b != NULL)
        memcpy(b, word, len);
    sign(w, channel, b, n);
    push(w, channel, b, n);
}

void lw_state(logs_writer *w, const char *channel, const trioct_state_request_t *m)
{
    size_t n;
    uint8_t *b = encode_state(m, &n);
    push(w, channel, b, n);
}

void lw_distance(logs_writer *w, const char *channel, const trioct_distance_request_t *m)
{
    size_t n;
    uint8_t *b = encode_distance(m, &n);
    push(w, channel, b, n);
}

int lw_save(logs_writer *w, const char *dir, const char *name)
{
    char path[4096], err[4352];
    snprintf(path, sizeof path, "%s/%s.lcmlog", dir, name);
    int rc = -1;
    if (w->failed)
        fprintf(stderr, "trioct-make-logs: %s: out of memory or a request that does not encode\n", path);
    else if (replay_log_write(path, w->events, w->count, err, sizeof err) < 0)
        fprintf(stderr, "trioct-make-logs: %s\n", err);
    else
        rc = 0;
    for (size_t i = 0; i < w->count; i++) {
        free(w->events[i].channel);
        free(w->events[i].data);
    }
    free(w->events);
    lw_init(w);
    return rc;
}

/* The next of eight channel buffers in rotation. */
static char *channel_slot(void)
{
    static char ring[8][TRIOCT_MAX_CHANNEL_LEN + 1];
    static int next;
    return ring[next++ % 8];
}

const char *lw_channel(int kind, const char *name)
{
    char *out = channel_slot();
    if (trioct_channel_name(out, LOGS_PREFIX, (trioct_channel_kind)kind, name) < 0) {
        /* The generator names its own worlds: a bad one is a bug here. */
        fprintf(stderr, "trioct-make-logs: '%s' makes no channel\n", name);
        exit(1);
    }
    return out;
}

const char *lw_mark_channel(int kind)
{
    char *out = channel_slot();
    if (trioct_mark_channel_name(out, LOGS_PREFIX, (trioct_mark_kind)kind, LOGS_DAEMON) < 0) {
        fprintf(stderr, "trioct-make-logs: '%s' makes no mark channel\n", LOGS_DAEMON);
        exit(1);
    }
    return out;
}

trioct_request_header_t lw_header(int64_t client, int64_t id, const char *reply, const char *world)
{
    trioct_request_header_t h;
    memset(&h, 0, sizeof h);
    h.client_id = client;
    h.request_id = id;
    h.reply_channel = (char *)reply;
    h.world = (char *)world;
    h.deadline_utime = 0;
    return h;
}
