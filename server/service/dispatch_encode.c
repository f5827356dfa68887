/* Replies cut into chunks. LCM loses a fragmented message whole when one fragment is lost,
 * so every chunk must fit TRIOCT_MAX_CHUNK_BYTES. Chunk 0 carries the per-item array
 * (found[]) and as many records as fit; later chunks carry records only, in order, so a
 * client appends them as they come. Sizes are measured with the generated code itself, so
 * the plan cannot drift from what the encoder writes. */
#include <string.h>

#include "dispatch_internal.h"

/* How one reply type measures and writes a chunk holding records [lo, hi); `first` says
 * whether it is chunk 0 (which carries found[] and the object names). The chunk index and count are fixed-size
 * fields, so the size does not depend on them. */
typedef struct chunk_ops {
    int (*size)(const void *ctx, int first, size_t lo, size_t hi);
    int (*encode)(const void *ctx, int first, size_t lo, size_t hi, int32_t index, int32_t count,
                  void *buf, int len);
    size_t (*record_size)(const void *ctx, size_t i);
} chunk_ops;

static void fill_head(trioct_reply_header_t *out, const reply_head *h, int32_t index, int32_t count)
{
    out->client_id = h->client_id;
    out->request_id = h->request_id;
    out->daemon = (char *)h->daemon;
    out->world = (char *)h->world;
    out->world_version = h->world_version;
    out->status = (int16_t)h->status;
    out->message = (char *)h->message;
    out->chunk_index = index;
    out->chunk_count = count;
}

void dispatch_reply_free(dispatch_reply *reply)
{
    if (!reply)
        return;
    for (size_t i = 0; i < reply->chunk_count; i++)
        free(reply->chunks[i].data);
    free(reply->chunks);
    reply->chunks = NULL;
    reply->chunk_count = 0;
}

/* Plans the chunks greedily (each takes as many records as fit, in order), then encodes
 * them. Greedy is optimal here: records only ever go to the current or a later chunk. */
static int split_encode(dispatch_reply *out, const chunk_ops *ops, const void *ctx, size_t records)
{
    size_t base_first = (size_t)ops->size(ctx, 1, 0, 0);
    size_t base_rest = (size_t)ops->size(ctx, 0, 0, 0);
    if (base_first > TRIOCT_MAX_CHUNK_BYTES)
        return TRIOCT_ERR_OVER_CAP;
    /* At most one chunk per record, plus chunk 0. */
    size_t *bounds = dispatch_malloc((records + 2) * sizeof *bounds);
    if (!bounds)
        return TRIOCT_ERR_NOMEM;
    size_t count = 0, lo = 0;
    bounds[0] = 0;
    do {
        size_t used = count == 0 ? base_first : base_rest;
        size_t hi = lo;
        while (hi < records) {
            size_t rs = ops->record_size(ctx, hi);
            if (used + rs > TRIOCT_MAX_CHUNK_BYTES)
                break;
            used += rs;
            hi++;
        }
        if (hi == lo && lo < records && count > 0) {
            free(bounds);
            return TRIOCT_ERR_OVER_CAP; /* one record larger than an empty chunk */
        }
        bounds[++count] = hi;
        lo = hi;
    } while (lo < records);

    dispatch_chunk *chunks = dispatch_calloc(count, sizeof *chunks);
    if (!chunks) {
        free(bounds);
        return TRIOCT_ERR_NOMEM;
    }
    int status = TRIOCT_OK;
    for (size_t c = 0; c < count && status == TRIOCT_OK; c++) {
        int first = c == 0;
        int size = ops->size(ctx, first, bounds[c], bounds[c + 1]);
        uint8_t *buf = size > 0 ? dispatch_malloc((size_t)size) : NULL;
        if (!buf) {
            status = TRIOCT_ERR_NOMEM;
            break;
        }
        int n = ops->encode(ctx, first, bounds[c], bounds[c + 1], (int32_t)c, (int32_t)count, buf, size);
        chunks[c].data = buf;
        chunks[c].size = n > 0 ? (size_t)n : 0;
        if (n != size || n > TRIOCT_MAX_CHUNK_BYTES)
            status = TRIOCT_ERR_OVER_CAP; /* the plan and the encoder disagree: never send */
    }
    free(bounds);
    if (status != TRIOCT_OK) {
        for (size_t c = 0; c < count; c++)
            free(chunks[c].data);
        free(chunks);
        return status;
    }
    out->chunks = chunks;
    out->chunk_count = count;
    return TRIOCT_OK;
}

/* ---------- per type ---------- */

typedef struct query_chunks {
    const reply_head *head;
    int8_t detail;
    const query_result *r;
    size_t record_bytes;
} query_chunks;

static const query_result empty_result;

/* p + lo without forming NULL + 0, which the sanitizer rightly calls undefined. */
#define SLICE(p, lo) ((p) ? (p) + (lo) : NULL)

static void ray_fill(const query_chunks *q, int first, size_t lo, size_t hi, int32_t index, int32_t count,
                     trioct_ray_reply_t *m)
{
    fill_head(&m->header, q->head, index, count);
    m->detail = q->detail;
    m->num_rays = first ? q->r->item_count : 0;
    m->found = first ? q->r->found : NULL;
    m->num_objects = first ? q->r->object_count : 0;
    m->objects = first ? q->r->objects : NULL;
    m->num_hits = (int32_t)(hi - lo);
    m->hits = SLICE(q->r->hits, lo);
}

static int ray_size(const void *ctx, int first, size_t lo, size_t hi)
{
    trioct_ray_reply_t m;
    ray_fill(ctx, first, lo, hi, 0, 1, &m);
    return trioct_ray_reply_t_encoded_size(&m);
}

static int ray_encode(const void *ctx, int first, size_t lo, size_t hi, int32_t index, int32_t count,
                      void *buf, int len)
{
    trioct_ray_reply_t m;
    ray_fill(ctx, first, lo, hi, index, count, &m);
    return trioct_ray_reply_t_encode(buf, 0, len, &m);
}

static void triangle_fill(const query_chunks *q, int first, size_t lo, size_t hi, int32_t index,
                          int32_t count, trioct_triangle_reply_t *m)
{
    fill_head(&m->header, q->head, index, count);
    m->detail = q->detail;
    m->num_triangles = first ? q->r->item_count : 0;
    m->found = first ? q->r->found : NULL;
    m->num_objects = first ? q->r->object_count : 0;
    m->objects = first ? q->r->objects : NULL;
    m->num_contacts = (int32_t)(hi - lo);
    m->contacts = SLICE(q->r->contacts, lo);
    m->num_segments = q->r->segments ? (int32_t)(hi - lo) : 0;
    m->segments = SLICE(q->r->segments, lo);
}

static int triangle_size(const void *ctx, int first, size_t lo, size_t hi)
{
    trioct_triangle_reply_t m;
    triangle_fill(ctx, first, lo, hi, 0, 1, &m);
    return trioct_triangle_reply_t_encoded_size(&m);
}

static int triangle_encode(const void *ctx, int first, size_t lo, size_t hi, int32_t index, int32_t count,
                           void *buf, int len)
{
    trioct_triangle_reply_t m;
    triangle_fill(ctx, first, lo, hi, index, count, &m);
    return trioct_triangle_reply_t_encode(buf, 0, len, &m);
}

static void mesh_fill(const query_chunks *q, int first, size_t lo, size_t hi, int32_t index, int32_t count,
                      trioct_mesh_reply_t *m)
{
    fill_head(&m->header, q->head, index, count);
    m->detail = q->detail;
    m->num_poses = first ? q->r->item_count : 0;
    m->found = first ? q->r->found : NULL;
    m->num_objects = first ? q->r->object_count : 0;
    m->objects = first ? q->r->objects : NULL;
    m->num_pairs = (int32_t)(hi - lo);
    m->pairs = SLICE(q->r->pairs, lo);
}

static int mesh_size(const void *ctx, int first, size_t lo, size_t hi)
{
    trioct_mesh_reply_t m;
    mesh_fill(ctx, first, lo, hi, 0, 1, &m);
    return trioct_mesh_reply_t_encoded_size(&m);
}

static int mesh_encode(const void *ctx, int first, size_t lo, size_t hi, int32_t index, int32_t count,
                       void *buf, int len)
{
    trioct_mesh_reply_t m;
    mesh_fill(ctx, first, lo, hi, index, count, &m);
    return trioct_mesh_reply_t_encode(buf, 0, len, &m);
}

static size_t fixed_record_size(const void *ctx, size_t i)
{
    (void)i;
    return ((const query_chunks *)ctx)->record_bytes;
}

static int encode_query(dispatch_reply *out, const chunk_ops *ops, const reply_head *h, int8_t detail,
                        const query_result *r, size_t record_bytes)
{
    query_chunks q = {h, detail, r ? r : &empty_result, record_bytes};
    return split_encode(out, ops, &q, q.r->record_count);
}

int encode_ray_reply(dispatch_reply *out, const reply_head *h, int8_t detail, const query_result *r)
{
    static const chunk_ops ops = {ray_size, ray_encode, fixed_record_size};
    trioct_ray_hit_t one = {0};
    return encode_query(out, &ops, h, detail, r, (size_t)__trioct_ray_hit_t_encoded_array_size(&one, 1));
}

int encode_triangle_reply(dispatch_reply *out, const reply_head *h, int8_t detail, const query_result *r)
{
    static const chunk_ops ops = {triangle_size, triangle_encode, fixed_record_size};
    trioct_contact_t contact = {0};
    trioct_segment_t segment = {0};
    size_t bytes = (size_t)__trioct_contact_t_encoded_array_size(&contact, 1);
    if (r && r->segments)
        bytes += (size_t)__trioct_segment_t_encoded_array_size(&segment, 1);
    return encode_query(out, &ops, h, detail, r, bytes);
}

int encode_mesh_reply(dispatch_reply *out, const reply_head *h, int8_t detail, const query_result *r)
{
    static const chunk_ops ops = {mesh_size, mesh_encode, fixed_record_size};
    trioct_mesh_pair_t one = {0};
    return encode_query(out, &ops, h, detail, r, (size_t)__trioct_mesh_pair_t_encoded_array_size(&one, 1));
}

/* Admin replies: the worlds are the records, each of its own size (names, paths, shapes).
 * The op is echoed in every chunk; there is no per-item array, so `first` changes nothing. */
typedef struct admin_chunks {
    const reply_head *head;
    int8_t op;
    const trioct_world_info_t *worlds;
} admin_chunks;

static void admin_fill(const admin_chunks *a, size_t lo, size_t hi, int32_t index, int32_t count,
                       trioct_admin_reply_t *m)
{
    fill_head(&m->header, a->head, index, count);
    m->op = a->op;
    m->num_worlds = (int32_t)(hi - lo);
    m->worlds = (trioct_world_info_t *)SLICE(a->worlds, lo);
}

static int admin_size(const void *ctx, int first, size_t lo, size_t hi)
{
    (void)first;
    trioct_admin_reply_t m;
    admin_fill(ctx, lo, hi, 0, 1, &m);
    return trioct_admin_reply_t_encoded_size(&m);
}

static int admin_encode(const void *ctx, int first, size_t lo, size_t hi, int32_t index, int32_t count,
                        void *buf, int len)
{
    (void)first;
    trioct_admin_reply_t m;
    admin_fill(ctx, lo, hi, index, count, &m);
    return trioct_admin_reply_t_encode(buf, 0, len, &m);
}

static size_t admin_record_size(const void *ctx, size_t i)
{
    const admin_chunks *a = ctx;
    return (size_t)__trioct_world_info_t_encoded_array_size(&a->worlds[i], 1);
}

int encode_admin_reply(dispatch_reply *out, const reply_head *h, int8_t op, const trioct_world_info_t *worlds,
                       size_t count)
{
    static const chunk_ops ops = {admin_size, admin_encode, admin_record_size};
    admin_chunks a = {h, op, count ? worlds : NULL};
    return split_encode(out, &ops, &a, count);
}

/* Object replies: the objects listed are the records, each of its own size. */
typedef struct object_chunks {
    const reply_head *head;
    int32_t failed_edit;
    int64_t objects, triangles;
    const trioct_object_info_t *infos;
} object_chunks;

static void object_fill(const object_chunks *o, size_t lo, size_t hi, int32_t index, int32_t count,
                        trioct_object_reply_t *m)
{
    fill_head(&m->header, o->head, index, count);
    m->failed_edit = o->failed_edit;
    m->objects = o->objects;
    m->triangles = o->triangles;
    m->num_objects = (int32_t)(hi - lo);
    m->list = (trioct_object_info_t *)SLICE(o->infos, lo);
}

static int object_size(const void *ctx, int first, size_t lo, size_t hi)
{
    (void)first;
    trioct_object_reply_t m;
    object_fill(ctx, lo, hi, 0, 1, &m);
    return trioct_object_reply_t_encoded_size(&m);
}

static int object_encode(const void *ctx, int first, size_t lo, size_t hi, int32_t index, int32_t count,
                         void *buf, int len)
{
    (void)first;
    trioct_object_reply_t m;
    object_fill(ctx, lo, hi, index, count, &m);
    return trioct_object_reply_t_encode(buf, 0, len, &m);
}

static size_t object_record_size(const void *ctx, size_t i)
{
    const object_chunks *o = ctx;
    return (size_t)__trioct_object_info_t_encoded_array_size(&o->infos[i], 1);
}

int encode_object_reply(dispatch_reply *out, const reply_head *h, int32_t failed_edit, int64_t objects,
                        int64_t triangles, const trioct_object_info_t *infos, size_t count)
{
    static const chunk_ops ops = {object_size, object_encode, object_record_size};
    object_chunks o = {h, failed_edit, objects, triangles, count ? infos : NULL};
    return split_encode(out, &ops, &o, count);
}

/* State replies: chunk 0 carries found[] and the object names; the contacts,
 * all of one size, are cut over the chunks in order. */
typedef struct state_chunks {
    const reply_head *head;
    int8_t detail;
    int32_t states;
    const int32_t *found;
    int32_t object_count;
    char **objects;
    const trioct_state_contact_t *contacts;
    size_t record_bytes;
} state_chunks;

static void state_fill(const state_chunks *q, int first, size_t lo, size_t hi, int32_t index, int32_t count,
                       trioct_state_reply_t *m)
{
    fill_head(&m->header, q->head, index, count);
    m->detail = q->detail;
    m->num_states = first ? q->states : 0;
    m->found = first ? (int32_t *)q->found : NULL;
    m->num_objects = first ? q->object_count : 0;
    m->objects = first ? q->objects : NULL;
    m->num_contacts = (int32_t)(hi - lo);
    m->contacts = (trioct_state_contact_t *)SLICE(q->contacts, lo);
}

static int state_size(const void *ctx, int first, size_t lo, size_t hi)
{
    trioct_state_reply_t m;
    state_fill(ctx, first, lo, hi, 0, 1, &m);
    return trioct_state_reply_t_encoded_size(&m);
}

static int state_encode(const void *ctx, int first, size_t lo, size_t hi, int32_t index, int32_t count, void *buf,
                        int len)
{
    trioct_state_reply_t m;
    state_fill(ctx, first, lo, hi, index, count, &m);
    return trioct_state_reply_t_encode(buf, 0, len, &m);
}

static size_t state_record_size(const void *ctx, size_t i)
{
    (void)i;
    return ((const state_chunks *)ctx)->record_bytes;
}

int encode_state_reply(dispatch_reply *out, const reply_head *h, int8_t detail, int32_t states, const int32_t *found, int32_t object_count, char **objects,
                       const trioct_state_contact_t *contacts, size_t count)
{
    static const chunk_ops ops = {state_size, state_encode, state_record_size};
    trioct_state_contact_t one = {0};
    state_chunks q = {h,       detail,  states, found, object_count, objects, count ? contacts : NULL,
                      (size_t)__trioct_state_contact_t_encoded_array_size(&one, 1)};
    return split_encode(out, &ops, &q, count);
}

/* Distance replies: chunk 0 carries the object names; the results, one an item and all of
 * one size, are cut over the chunks in order. */
typedef struct distance_chunks {
    const reply_head *head;
    int8_t kind;
    int32_t object_count;
    char **objects;
    const trioct_distance_result_t *results;
    size_t record_bytes;
} distance_chunks;

static void distance_fill(const distance_chunks *q, int first, size_t lo, size_t hi, int32_t index, int32_t count,
                          trioct_distance_reply_t *m)
{
    fill_head(&m->header, q->head, index, count);
    m->kind = q->kind;
    m->num_objects = first ? q->object_count : 0;
    m->objects = first ? q->objects : NULL;
    m->num_results = (int32_t)(hi - lo);
    m->results = (trioct_distance_result_t *)SLICE(q->results, lo);
}

static int distance_size(const void *ctx, int first, size_t lo, size_t hi)
{
    trioct_distance_reply_t m;
    distance_fill(ctx, first, lo, hi, 0, 1, &m);
    return trioct_distance_reply_t_encoded_size(&m);
}

static int distance_encode(const void *ctx, int first, size_t lo, size_t hi, int32_t index, int32_t count,
                           void *buf, int len)
{
    trioct_distance_reply_t m;
    distance_fill(ctx, first, lo, hi, index, count, &m);
    return trioct_distance_reply_t_encode(buf, 0, len, &m);
}

static size_t distance_record_size(const void *ctx, size_t i)
{
    (void)i;
    return ((const distance_chunks *)ctx)->record_bytes;
}

int encode_distance_reply(dispatch_reply *out, const reply_head *h, int8_t kind, int32_t object_count, char **objects,
                          const trioct_distance_result_t *results, size_t count)
{
    static const chunk_ops ops = {distance_size, distance_encode, distance_record_size};
    trioct_distance_result_t one = {0};
    distance_chunks q = {h, kind, object_count, objects, count ? results : NULL,
                         (size_t)__trioct_distance_result_t_encoded_array_size(&one, 1)};
    return split_encode(out, &ops, &q, count);
}

int encode_error_reply(dispatch_reply *out, request_type type, const reply_head *h, int8_t detail)
{
    switch (type) {
    case REQUEST_DISTANCE:
        return encode_distance_reply(out, h, detail, 0, NULL, NULL, 0);
    case REQUEST_OBJECTS:
        return encode_object_reply(out, h, -1, 0, 0, NULL, 0);
    case REQUEST_STATE:
        return encode_state_reply(out, h, detail, 0, NULL, 0, NULL, NULL, 0);
    case REQUEST_RAY:
        return encode_ray_reply(out, h, detail, NULL);
    case REQUEST_TRIANGLE:
        return encode_triangle_reply(out, h, detail, NULL);
    case REQUEST_MESH:
        return encode_mesh_reply(out, h, detail, NULL);
    default:
        return encode_admin_reply(out, h, detail, NULL, 0);
    }
}

void query_result_free(query_result *r)
{
    free(r->found);
    free(r->hits);
    free(r->contacts);
    free(r->segments);
    free(r->pairs);
    free(r->objects);
    memset(r, 0, sizeof *r);
}
