/* The golden log: the input of the log, in its order and with its timestamps, each
 * request followed by the daemon's reply to it, chunks in order.
 *
 * A few things in a reply depend on the moment or the machine, and are never compared as
 * they are (replay_compare.h): a world's build_seconds and load_seconds, the elapsed time an ERR_DEADLINE
 * message states, and the world directory a failed LOAD names. They are written as 0, "N"
 * and ".", so recording a log twice, on any machine, at any thread count, gives the same
 * bytes: that is what makes a checked-in golden log reproducible. Everything else is the
 * daemon's reply as published (decoded and encoded again, which LCM's encoding keeps
 * byte for byte). */
#include <stdlib.h>
#include <string.h>

#include "replay_compare.h"
#include "replay_session.h"
#include "trioct_admin_reply_t.h"
#include "trioct_mesh_reply_t.h"
#include "trioct_ray_reply_t.h"
#include "trioct_status.h"
#include "trioct_object_reply_t.h"
#include "trioct_distance_reply_t.h"
#include "trioct_state_reply_t.h"
#include "trioct_triangle_reply_t.h"

static int encode(wire_type type, const void *m, uint8_t **out, size_t *size)
{
    int n;
    switch (type) {
    case WIRE_RAY_REPLY:
        n = trioct_ray_reply_t_encoded_size(m);
        break;
    case WIRE_TRIANGLE_REPLY:
        n = trioct_triangle_reply_t_encoded_size(m);
        break;
    case WIRE_MESH_REPLY:
        n = trioct_mesh_reply_t_encoded_size(m);
        break;
    case WIRE_OBJECT_REPLY:
        n = trioct_object_reply_t_encoded_size(m);
        break;
    case WIRE_STATE_REPLY:
        n = trioct_state_reply_t_encoded_size(m);
        break;
    case WIRE_DISTANCE_REPLY:
        n = trioct_distance_reply_t_encoded_size(m);
        break;
    default:
        n = trioct_admin_reply_t_encoded_size(m);
        break;
    }
    *out = malloc((size_t)n + 1);
    if (*out == NULL)
        return -1;
    int w;
    switch (type) {
    case WIRE_RAY_REPLY:
        w = trioct_ray_reply_t_encode(*out, 0, n, m);
        break;
    case WIRE_TRIANGLE_REPLY:
        w = trioct_triangle_reply_t_encode(*out, 0, n, m);
        break;
    case WIRE_MESH_REPLY:
        w = trioct_mesh_reply_t_encode(*out, 0, n, m);
        break;
    case WIRE_OBJECT_REPLY:
        w = trioct_object_reply_t_encode(*out, 0, n, m);
        break;
    case WIRE_STATE_REPLY:
        w = trioct_state_reply_t_encode(*out, 0, n, m);
        break;
    case WIRE_DISTANCE_REPLY:
        w = trioct_distance_reply_t_encode(*out, 0, n, m);
        break;
    default:
        w = trioct_admin_reply_t_encode(*out, 0, n, m);
        break;
    }
    if (w != n) {
        free(*out);
        return -1;
    }
    *size = (size_t)n;
    return 0;
}

/* The chunk's bytes with the wall-clock fields fixed: a fresh buffer in *out. */
static int normalise(const replay_event *raw, wire_type type, const char *world_dir, uint8_t **out,
                     size_t *size)
{
    void *m = calloc(1, replay_reply_struct_size(type));
    if (m == NULL || replay_reply_decode(type, raw->data, raw->size, m) < 0) {
        free(m);
        return -1;
    }
    trioct_reply_header_t *h = m; /* every reply starts with its header */
    char canon[TRIOCT_MAX_MESSAGE_LEN + 8];
    char *original = h->message;
    replay_canon_text(h->status, h->message, world_dir, canon, sizeof canon);
    h->message = canon;
    trioct_admin_reply_t *a = type == WIRE_ADMIN_REPLY ? m : NULL;
    int32_t worlds = a != NULL ? a->num_worlds : 0;
    char (*errors)[TRIOCT_MAX_MESSAGE_LEN + 8] = calloc(worlds ? (size_t)worlds : 1, sizeof *errors);
    char **kept = calloc(worlds ? (size_t)worlds : 1, sizeof *kept);
    int rc = -1;
    if (errors != NULL && kept != NULL) {
        for (int32_t i = 0; i < worlds; i++) {
            a->worlds[i].build_seconds = 0;
            a->worlds[i].load_seconds = 0;
            kept[i] = a->worlds[i].last_error;
            replay_canon_text(0, kept[i], world_dir, errors[i], sizeof errors[i]);
            a->worlds[i].last_error = errors[i];
        }
        rc = encode(type, m, out, size);
        for (int32_t i = 0; i < worlds; i++)
            a->worlds[i].last_error = kept[i];
    }
    free(errors);
    free(kept);
    h->message = original;
    replay_reply_cleanup(type, m);
    free(m);
    return rc;
}

typedef struct golden {
    replay_event *events;
    uint8_t **owned; /* normalised payloads to free */
    size_t count, owned_count, cap;
} golden;

static int append(golden *g, int64_t timestamp, const char *channel, uint8_t *data, size_t size, int owned)
{
    if (g->count == g->cap) {
        size_t cap = g->cap ? 2 * g->cap : 256;
        replay_event *e = realloc(g->events, cap * sizeof *e);
        uint8_t **o = realloc(g->owned, cap * sizeof *o);
        if (e != NULL)
            g->events = e;
        if (o != NULL)
            g->owned = o;
        if (e == NULL || o == NULL)
            return -1;
        g->cap = cap;
    }
    g->events[g->count++] = (replay_event){timestamp, (char *)channel, data, size};
    if (owned)
        g->owned[g->owned_count++] = data;
    return 0;
}

static int append_reply(golden *g, int64_t timestamp, const replay_reply *r, const char *world_dir)
{
    for (int32_t i = 0; i < r->chunk_count; i++) {
        const replay_event *raw = r->raw[i];
        if (raw == NULL)
            continue;
        uint8_t *bytes;
        size_t size;
        if (normalise(raw, r->type, world_dir, &bytes, &size) < 0 || append(g, timestamp, raw->channel, bytes, size, 1) < 0)
            return -1;
    }
    return 0;
}

int replay_record_golden(const replay_session *s, const char *path, FILE *out)
{
    golden g = {0};
    size_t replies = 0, answered = 0, nobody = 0;
    int rc = 0;
    for (size_t i = 0; i < s->script_log.count && rc == 0; i++) {
        const replay_event *ev = &s->script_log.events[i];
        replay_class c;
        replay_classify(&s->proto, ev, &c);
        if (!replay_kind_is_input(c.kind))
            continue;
        rc = append(&g, ev->timestamp, ev->channel, ev->data, ev->size, 0);
        if (rc < 0 || c.kind != KIND_REQUEST)
            continue;
        /* A key used twice: its replies follow its first request. */
        const replay_request *first = replay_book_request(&s->script, c.client_id, c.request_id);
        if (first == NULL || first->event != i)
            continue;
        size_t n;
        const replay_reply *r = replay_book_replies(&s->got, c.client_id, c.request_id, &n);
        answered += n > 0;
        for (size_t k = 0; k < n && rc == 0; k++, replies++)
            rc = append_reply(&g, ev->timestamp, &r[k], s->world_dir);
    }
    for (size_t k = 0; k < s->got.reply_count && rc == 0; k++) {
        const replay_reply *r = &s->got.replies[k];
        if (replay_book_request(&s->script, r->client_id, r->request_id) != NULL)
            continue;
        nobody++;
        rc = append_reply(&g, r->raw[0] != NULL ? r->raw[0]->timestamp : 0, r, s->world_dir);
    }
    for (size_t k = 0; k < s->got.reply_count; k++)
        if (s->got.replies[k].problem[0])
            fprintf(stderr, "trioct-replay: warning: reply to request %lld is damaged: %s\n",
                    (long long)s->got.replies[k].request_id, s->got.replies[k].problem);
    char err[REPLAY_PATH_LEN + 256];
    if (rc < 0)
        fprintf(stderr, "trioct-replay: a reply could not be written\n");
    else if ((rc = replay_log_write(path, g.events, g.count, err, sizeof err)) < 0)
        fprintf(stderr, "trioct-replay: %s\n", err);
    if (rc == 0) {
        fprintf(out, "recorded %s: %zu requests (%zu malformed), %zu answered with %zu replies",
                path, s->script.request_count + s->script.malformed, s->script.malformed, answered,
                replies + nobody);
        if (nobody > 0)
            fprintf(out, ", %zu of them to no request of the log", nobody);
        fputc('\n', out);
    }
    for (size_t k = 0; k < g.owned_count; k++)
        free(g.owned[k]);
    free(g.owned);
    free(g.events);
    return rc;
}
