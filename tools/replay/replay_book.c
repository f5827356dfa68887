#include "replay_book.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "trioct_admin_reply_t.h"
#include "trioct_distance_reply_t.h"
#include "trioct_mesh_reply_t.h"
#include "trioct_object_reply_t.h"
#include "trioct_state_reply_t.h"
#include "trioct_ray_reply_t.h"
#include "trioct_triangle_reply_t.h"

size_t replay_reply_struct_size(wire_type type)
{
    switch (type) {
    case WIRE_RAY_REPLY:
        return sizeof(trioct_ray_reply_t);
    case WIRE_TRIANGLE_REPLY:
        return sizeof(trioct_triangle_reply_t);
    case WIRE_MESH_REPLY:
        return sizeof(trioct_mesh_reply_t);
    case WIRE_ADMIN_REPLY:
        return sizeof(trioct_admin_reply_t);
    case WIRE_OBJECT_REPLY:
        return sizeof(trioct_object_reply_t);
    case WIRE_STATE_REPLY:
        return sizeof(trioct_state_reply_t);
    case WIRE_DISTANCE_REPLY:
        return sizeof(trioct_distance_reply_t);
    default:
        return 0;
    }
}

/* Only after wire_check has passed the bytes. */
int replay_reply_decode(wire_type type, const void *bytes, size_t size, void *msg)
{
    int n = (int)size;
    switch (type) {
    case WIRE_RAY_REPLY:
        return trioct_ray_reply_t_decode(bytes, 0, n, msg) == n ? 0 : -1;
    case WIRE_TRIANGLE_REPLY:
        return trioct_triangle_reply_t_decode(bytes, 0, n, msg) == n ? 0 : -1;
    case WIRE_MESH_REPLY:
        return trioct_mesh_reply_t_decode(bytes, 0, n, msg) == n ? 0 : -1;
    case WIRE_ADMIN_REPLY:
        return trioct_admin_reply_t_decode(bytes, 0, n, msg) == n ? 0 : -1;
    case WIRE_OBJECT_REPLY:
        return trioct_object_reply_t_decode(bytes, 0, n, msg) == n ? 0 : -1;
    case WIRE_STATE_REPLY:
        return trioct_state_reply_t_decode(bytes, 0, n, msg) == n ? 0 : -1;
    case WIRE_DISTANCE_REPLY:
        return trioct_distance_reply_t_decode(bytes, 0, n, msg) == n ? 0 : -1;
    default:
        return -1;
    }
}

void replay_reply_cleanup(wire_type type, void *msg)
{
    switch (type) {
    case WIRE_RAY_REPLY:
        trioct_ray_reply_t_decode_cleanup(msg);
        break;
    case WIRE_TRIANGLE_REPLY:
        trioct_triangle_reply_t_decode_cleanup(msg);
        break;
    case WIRE_MESH_REPLY:
        trioct_mesh_reply_t_decode_cleanup(msg);
        break;
    case WIRE_ADMIN_REPLY:
        trioct_admin_reply_t_decode_cleanup(msg);
        break;
    case WIRE_OBJECT_REPLY:
        trioct_object_reply_t_decode_cleanup(msg);
        break;
    case WIRE_STATE_REPLY:
        trioct_state_reply_t_decode_cleanup(msg);
        break;
    case WIRE_DISTANCE_REPLY:
        trioct_distance_reply_t_decode_cleanup(msg);
        break;
    default:
        break;
    }
}

/* The largest reply the caps allow, TRIOCT_MAX_RESULTS contacts with their segments (56
 * bytes each), is under 4 MB: 62 chunks of TRIOCT_MAX_CHUNK_BYTES. A chunk count far beyond
 * is hostile, and would cost memory for every reply claiming it. */
#define REPLAY_MAX_CHUNKS 256

/* ---------- keys ---------- */

static int key_cmp(int64_t ca, int64_t ra, int64_t cb, int64_t rb)
{
    if (ca != cb)
        return ca < cb ? -1 : 1;
    if (ra != rb)
        return ra < rb ? -1 : 1;
    return 0;
}

/* A reply chunk waiting to be placed: its key and position. */
typedef struct chunk_ref {
    int64_t client_id, request_id;
    size_t event;
    replay_class cls;
} chunk_ref;

static int chunk_ref_cmp(const void *a, const void *b)
{
    const chunk_ref *x = a, *y = b;
    int k = key_cmp(x->client_id, x->request_id, y->client_id, y->request_id);
    if (k != 0)
        return k;
    return x->event < y->event ? -1 : x->event > y->event;
}

/* ---------- flattening a reassembled reply ---------- */

static const trioct_reply_header_t *chunk_header(const replay_reply *r, int32_t i)
{
    /* Every reply struct starts with its header. */
    return r->chunk[i] != NULL ? (const trioct_reply_header_t *)r->chunk[i] : NULL;
}

static int same_header(const trioct_reply_header_t *a, const trioct_reply_header_t *b)
{
    return a->client_id == b->client_id && a->request_id == b->request_id &&
           strcmp(a->daemon, b->daemon) == 0 && strcmp(a->world, b->world) == 0 &&
           a->world_version == b->world_version && a->status == b->status &&
           strcmp(a->message, b->message) == 0 && a->chunk_count == b->chunk_count;
}

/* Sizes of the per-chunk record arrays, and pointers to them. */
/* A chunk's table of object names (query replies; none in the others). */
static int32_t chunk_names(wire_type type, void *m, char ***names)
{
    switch (type) {
    case WIRE_RAY_REPLY:
        *names = ((trioct_ray_reply_t *)m)->objects;
        return ((trioct_ray_reply_t *)m)->num_objects;
    case WIRE_TRIANGLE_REPLY:
        *names = ((trioct_triangle_reply_t *)m)->objects;
        return ((trioct_triangle_reply_t *)m)->num_objects;
    case WIRE_MESH_REPLY:
        *names = ((trioct_mesh_reply_t *)m)->objects;
        return ((trioct_mesh_reply_t *)m)->num_objects;
    case WIRE_STATE_REPLY:
        *names = ((trioct_state_reply_t *)m)->objects;
        return ((trioct_state_reply_t *)m)->num_objects;
    case WIRE_DISTANCE_REPLY:
        *names = ((trioct_distance_reply_t *)m)->objects;
        return ((trioct_distance_reply_t *)m)->num_objects;
    default:
        *names = NULL;
        return 0;
    }
}

static size_t chunk_records(wire_type type, void *m, const void **base, size_t *stride,
                            const trioct_segment_t **segs, size_t *nsegs, int32_t *items,
                            const int32_t **found, int8_t *detail)
{
    *segs = NULL;
    *nsegs = 0;
    switch (type) {
    case WIRE_DISTANCE_REPLY: {
        /* One result an item, each naming its item: no found[] beside them. */
        trioct_distance_reply_t *r = m;
        *base = r->results;
        *stride = sizeof *r->results;
        *items = 0;
        *found = NULL;
        *detail = r->kind;
        return (size_t)r->num_results;
    }
    case WIRE_STATE_REPLY: {
        trioct_state_reply_t *r = m;
        *base = r->contacts;
        *stride = sizeof *r->contacts;
        *items = r->num_states;
        *found = r->found;
        *detail = r->detail;
        return (size_t)r->num_contacts;
    }
    case WIRE_OBJECT_REPLY: {
        trioct_object_reply_t *r = m;
        *base = r->list;
        *stride = sizeof *r->list;
        *items = 0;
        *found = NULL;
        *detail = 0;
        return (size_t)r->num_objects;
    }
    case WIRE_RAY_REPLY: {
        trioct_ray_reply_t *r = m;
        *base = r->hits;
        *stride = sizeof *r->hits;
        *items = r->num_rays;
        *found = r->found;
        *detail = r->detail;
        return (size_t)r->num_hits;
    }
    case WIRE_TRIANGLE_REPLY: {
        trioct_triangle_reply_t *r = m;
        *base = r->contacts;
        *stride = sizeof *r->contacts;
        *segs = r->segments;
        *nsegs = (size_t)r->num_segments;
        *items = r->num_triangles;
        *found = r->found;
        *detail = r->detail;
        return (size_t)r->num_contacts;
    }
    case WIRE_MESH_REPLY: {
        trioct_mesh_reply_t *r = m;
        *base = r->pairs;
        *stride = sizeof *r->pairs;
        *items = r->num_poses;
        *found = r->found;
        *detail = r->detail;
        return (size_t)r->num_pairs;
    }
    default: {
        trioct_admin_reply_t *r = m;
        *base = r->worlds;
        *stride = sizeof *r->worlds;
        *items = 0;
        *found = NULL;
        *detail = r->op;
        return (size_t)r->num_worlds;
    }
    }
}

static int flatten(replay_reply *r)
{
    size_t records = 0, segments = 0, missing = 0;
    char missing_list[96] = "";
    for (int32_t i = 0; i < r->chunk_count; i++) {
        const trioct_reply_header_t *h = chunk_header(r, i);
        if (h == NULL) {
            size_t used = strlen(missing_list);
            if (used + 16 < sizeof missing_list)
                snprintf(missing_list + used, sizeof missing_list - used, "%s%d", missing ? ", " : "", i);
            missing++;
            continue;
        }
        if (r->header == NULL)
            r->header = h;
        else if (!same_header(r->header, h) && r->problem[0] == '\0')
            snprintf(r->problem, sizeof r->problem, "chunk %d's header differs from chunk %d's", i,
                     r->header->chunk_index);
        const void *base;
        size_t stride, nsegs;
        const trioct_segment_t *segs;
        int32_t items;
        const int32_t *found;
        int8_t detail;
        records += chunk_records(r->type, r->chunk[i], &base, &stride, &segs, &nsegs, &items, &found, &detail);
        segments += nsegs;
        char **names;
        int32_t named = chunk_names(r->type, r->chunk[i], &names);
        if (i == 0) {
            r->num_items = items;
            r->found = found;
            r->detail = detail;
            r->num_names = named;
            r->names = (const char *const *)names;
        } else if (named != 0 && r->problem[0] == '\0') {
            snprintf(r->problem, sizeof r->problem, "chunk %d carries object names; only chunk 0 may", i);
        } else if (items != 0 && r->problem[0] == '\0') {
            snprintf(r->problem, sizeof r->problem, "chunk %d carries found[] (%d items); only chunk 0 may", i,
                     items);
        }
    }
    if (missing > 0)
        snprintf(r->problem, sizeof r->problem, "%zu of %d chunks never came (chunk %s)", missing,
                 r->chunk_count, missing_list);
    r->records = calloc(records ? records : 1, sizeof *r->records);
    r->segments = calloc(segments ? segments : 1, sizeof *r->segments);
    if (r->records == NULL || r->segments == NULL)
        return -1;
    for (int32_t i = 0; i < r->chunk_count; i++) {
        if (r->chunk[i] == NULL)
            continue;
        const void *base;
        size_t stride, nsegs;
        const trioct_segment_t *segs;
        int32_t items;
        const int32_t *found;
        int8_t detail;
        size_t n = chunk_records(r->type, r->chunk[i], &base, &stride, &segs, &nsegs, &items, &found, &detail);
        for (size_t k = 0; k < n; k++)
            r->records[r->num_records++] = (const char *)base + k * stride;
        for (size_t k = 0; k < nsegs; k++)
            r->segments[r->num_segments++] = &segs[k];
    }
    return 0;
}

/* ---------- reassembly ---------- */

/* Places one chunk among the replies of its key, from `first` on. */
static replay_reply *place(replay_book *b, size_t first, const replay_event *ev, const chunk_ref *c)
{
    for (size_t i = first; i < b->reply_count; i++) {
        replay_reply *r = &b->replies[i];
        if (r->type == c->cls.type && r->chunk_count == c->cls.chunk_count &&
            strcmp(r->channel, ev->channel) == 0 && r->chunk[c->cls.chunk_index] == NULL)
            return r;
    }
    replay_reply *r = &b->replies[b->reply_count++];
    memset(r, 0, sizeof *r);
    r->type = c->cls.type;
    r->channel = ev->channel;
    r->client_id = c->client_id;
    r->request_id = c->request_id;
    r->first_event = c->event;
    r->chunk_count = c->cls.chunk_count;
    r->chunk = calloc((size_t)r->chunk_count, sizeof *r->chunk);
    r->raw = calloc((size_t)r->chunk_count, sizeof *r->raw);
    if (r->chunk == NULL || r->raw == NULL)
        return NULL;
    return r;
}

static int reassemble(replay_book *b, const replay_log *log, chunk_ref *refs, size_t n, char *err,
                      size_t err_len)
{
    qsort(refs, n, sizeof *refs, chunk_ref_cmp);
    b->replies = calloc(n ? n : 1, sizeof *b->replies);
    if (b->replies == NULL)
        goto nomem;
    for (size_t i = 0; i < n;) {
        size_t group_end = i, first = b->reply_count;
        while (group_end < n && key_cmp(refs[group_end].client_id, refs[group_end].request_id,
                                        refs[i].client_id, refs[i].request_id) == 0)
            group_end++;
        for (; i < group_end; i++) {
            const replay_event *ev = &log->events[refs[i].event];
            const replay_class *c = &refs[i].cls;
            replay_reply *r = place(b, first, ev, &refs[i]);
            if (r == NULL)
                goto nomem;
            void *m = calloc(1, replay_reply_struct_size(c->type));
            if (m == NULL)
                goto nomem;
            if (replay_reply_decode(c->type, ev->data, ev->size, m) < 0) {
                /* The validator passed it: the decoder and the validator disagree. */
                free(m);
                snprintf(r->problem, sizeof r->problem, "a chunk passed the validator but not the decoder");
                continue;
            }
            r->chunk[c->chunk_index] = m;
            r->raw[c->chunk_index] = ev;
        }
    }
    for (size_t i = 0; i < b->reply_count; i++)
        if (flatten(&b->replies[i]) < 0)
            goto nomem;
    return 0;
nomem:
    snprintf(err, err_len, "out of memory reassembling replies");
    return -1;
}

/* qsort has no context argument: the requests being sorted, for the comparison. */
static const replay_request *sorting;

static int by_key_cmp(const void *a, const void *b)
{
    const replay_request *x = &sorting[*(const size_t *)a], *y = &sorting[*(const size_t *)b];
    int k = key_cmp(x->client_id, x->request_id, y->client_id, y->request_id);
    if (k != 0)
        return k;
    return x->event < y->event ? -1 : x->event > y->event;
}

static int index_requests(replay_book *b)
{
    b->by_key = calloc(b->request_count ? b->request_count : 1, sizeof *b->by_key);
    if (b->by_key == NULL)
        return -1;
    for (size_t i = 0; i < b->request_count; i++)
        b->by_key[i] = i;
    sorting = b->requests;
    qsort(b->by_key, b->request_count, sizeof *b->by_key, by_key_cmp);
    sorting = NULL;
    return 0;
}

int replay_book_build(replay_book *b, const replay_log *log, const replay_proto *p, char *err, size_t err_len)
{
    memset(b, 0, sizeof *b);
    b->requests = calloc(log->count ? log->count : 1, sizeof *b->requests);
    chunk_ref *refs = calloc(log->count ? log->count : 1, sizeof *refs);
    size_t nrefs = 0;
    if (b->requests == NULL || refs == NULL) {
        free(refs);
        replay_book_free(b);
        snprintf(err, err_len, "out of memory");
        return -1;
    }
    for (size_t i = 0; i < log->count; i++) {
        replay_class c;
        replay_classify(p, &log->events[i], &c);
        switch (c.kind) {
        case KIND_REQUEST: {
            replay_request *r = &b->requests[b->request_count++];
            r->event = i;
            r->ordinal = b->request_count;
            r->channel = log->events[i].channel;
            r->type = c.type;
            r->client_id = c.client_id;
            r->request_id = c.request_id;
            memcpy(r->reply_channel, c.reply_channel, sizeof r->reply_channel);
            break;
        }
        case KIND_REPLY:
            /* The validator checks the bytes, not the numbering: a reply that numbers its
             * chunks impossibly is one nobody can reassemble. */
            if (c.chunk_count < 1 || c.chunk_index < 0 || c.chunk_index >= c.chunk_count ||
                c.chunk_count > REPLAY_MAX_CHUNKS) {
                b->bad_replies++;
                break;
            }
            refs[nrefs].client_id = c.client_id;
            refs[nrefs].request_id = c.request_id;
            refs[nrefs].event = i;
            refs[nrefs].cls = c;
            nrefs++;
            break;
        case KIND_MALFORMED:
            b->malformed++;
            break;
        case KIND_BAD_REPLY:
            b->bad_replies++;
            break;
        case KIND_STATUS:
            b->statuses++;
            break;
        case KIND_RELOAD:
            b->reloads++;
            break;
        case KIND_STOP:
            b->stops++;
            break;
        case KIND_OTHER:
            b->others++;
            break;
        }
    }
    int rc = reassemble(b, log, refs, nrefs, err, err_len);
    free(refs);
    if (rc == 0 && index_requests(b) < 0) {
        snprintf(err, err_len, "out of memory");
        rc = -1;
    }
    if (rc < 0)
        replay_book_free(b);
    return rc;
}

void replay_book_free(replay_book *b)
{
    for (size_t i = 0; i < b->reply_count; i++) {
        replay_reply *r = &b->replies[i];
        for (int32_t k = 0; r->chunk != NULL && k < r->chunk_count; k++) {
            if (r->chunk[k] != NULL) {
                replay_reply_cleanup(r->type, r->chunk[k]);
                free(r->chunk[k]);
            }
        }
        free(r->chunk);
        free(r->raw);
        free(r->records);
        free(r->segments);
    }
    free(b->replies);
    free(b->requests);
    free(b->by_key);
    memset(b, 0, sizeof *b);
}

const replay_request *replay_book_request(const replay_book *b, int64_t client_id, int64_t request_id)
{
    size_t lo = 0, hi = b->request_count;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        const replay_request *r = &b->requests[b->by_key[mid]];
        if (key_cmp(r->client_id, r->request_id, client_id, request_id) < 0)
            lo = mid + 1;
        else
            hi = mid;
    }
    if (lo == b->request_count)
        return NULL;
    const replay_request *r = &b->requests[b->by_key[lo]];
    return key_cmp(r->client_id, r->request_id, client_id, request_id) == 0 ? r : NULL;
}

const replay_reply *replay_book_replies(const replay_book *b, int64_t client_id, int64_t request_id,
                                        size_t *count)
{
    size_t lo = 0, hi = b->reply_count;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        const replay_reply *r = &b->replies[mid];
        if (key_cmp(r->client_id, r->request_id, client_id, request_id) < 0)
            lo = mid + 1;
        else
            hi = mid;
    }
    size_t n = 0;
    while (lo + n < b->reply_count &&
           key_cmp(b->replies[lo + n].client_id, b->replies[lo + n].request_id, client_id, request_id) == 0)
        n++;
    *count = n;
    return n ? &b->replies[lo] : NULL;
}
