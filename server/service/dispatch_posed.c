/* Queries of a world whose objects are not one tree at the identity: each item asked of
 * the object set (object_set.h), exact mode, with the records naming their object. And
 * the reply's table of object names, which every query reply carries.
 *
 * One pass per item into a scratch of the item's cap, the kept records appended to the
 * reply's arrays: memory stays bounded by the item cap plus TRIOCT_MAX_RESULTS. */
#include <string.h>

#include "../../common/array_reserve.h"
#include "../world/object_state.h"
#include "dispatch_internal.h"

static int posed_nomem(job *j, const char *what)
{
    return dispatch_out_of_memory(j, what);
}

static int posed_over(job *j, size_t total, const char *fewer)
{
    return job_fail(j, TRIOCT_ERR_OVER_CAP,
                    "the request produced more than %zu results, over TRIOCT_MAX_RESULTS=%d; send fewer %s", total,
                    TRIOCT_MAX_RESULTS, fewer);
}

static trioct_vec3_t posed_vec_out(vec3 v)
{
    return (trioct_vec3_t){v.x, v.y, v.z};
}

/* Room for one more record in a reply array that grows by doubling. */
static int grow(void **items, size_t *capacity, size_t need, size_t elem)
{
    return array_reserve(items, capacity, need, elem, 64);
}

int posed_rays(job *j, const ray_input *in, size_t n, ray_detail detail, size_t keep_cap, query_result *res)
{
    object_hit *scratch = dispatch_malloc(keep_cap * sizeof *scratch);
    res->found = dispatch_malloc(n * sizeof *res->found);
    if (!scratch || !res->found) {
        free(scratch);
        return posed_nomem(j, "the rays' hits");
    }
    size_t capacity = 0, total = 0;
    int status = TRIOCT_OK;
    for (size_t i = 0; i < n && status == TRIOCT_OK; i++) {
        object_ray_output out = {.hits = scratch, .max_hits = keep_cap};
        octree_status st = object_set_ray(j->w->objects, &in[i], detail, &out, NULL);
        if (st != OCTREE_OK) {
            status = job_engine_error(j, st, "ray", i);
            break;
        }
        size_t keep = out.hit_count < keep_cap ? out.hit_count : keep_cap;
        res->found[i] = out.hit_count > INT32_MAX ? INT32_MAX : (int32_t)out.hit_count;
        if (total + keep > TRIOCT_MAX_RESULTS) {
            status = posed_over(j, (size_t)TRIOCT_MAX_RESULTS, "rays or a smaller max_hits");
            break;
        }
        if (keep && grow((void **)&res->hits, &capacity, total + keep, sizeof *res->hits) != 0) {
            status = posed_nomem(j, "the reply's hits");
            break;
        }
        for (size_t k = 0; k < keep; k++) {
            const object_hit *h = &scratch[k];
            res->hits[total++] = (trioct_ray_hit_t){.ray = (int32_t)i, .t = h->hit.t, .object = (int32_t)h->object,
                                                    .triangle = (int32_t)h->hit.triangle, .u = h->hit.u,
                                                    .v = h->hit.v, .normal = posed_vec_out(h->hit.normal)};
        }
    }
    free(scratch);
    res->item_count = (int32_t)n;
    res->record_count = total;
    return status;
}

int posed_triangles(job *j, const vec3 (*tris)[3], size_t n, tri_detail detail, query_result *res)
{
    int lists = detail != TRI_YESNO;
    size_t room = lists ? TRIOCT_MAX_CONTACTS_PER_TRIANGLE : 0;
    object_contact *scratch = dispatch_malloc(room * sizeof *scratch);
    res->found = dispatch_malloc(n * sizeof *res->found);
    if (!scratch || !res->found) {
        free(scratch);
        return posed_nomem(j, "the triangles' contacts");
    }
    size_t capacity = 0, segment_capacity = 0, total = 0;
    int status = TRIOCT_OK;
    for (size_t i = 0; i < n && status == TRIOCT_OK; i++) {
        object_tri_output out = {.contacts = scratch, .capacity = room};
        octree_status st = object_set_triangle(j->w->objects, tris[i], detail, &out, NULL);
        if (st != OCTREE_OK) {
            status = job_engine_error(j, st, "triangle", i);
            break;
        }
        if (lists && out.count > TRIOCT_MAX_CONTACTS_PER_TRIANGLE) {
            status = job_fail(j, TRIOCT_ERR_OVER_CAP,
                              "triangle %zu touches %zu world triangles, over TRIOCT_MAX_CONTACTS_PER_TRIANGLE=%d; "
                              "split it into smaller triangles",
                              i, out.count, TRIOCT_MAX_CONTACTS_PER_TRIANGLE);
            break;
        }
        res->found[i] = lists ? (int32_t)out.count : out.hit != 0;
        if (!lists || out.count == 0)
            continue;
        if (total + out.count > TRIOCT_MAX_RESULTS) {
            status = posed_over(j, (size_t)TRIOCT_MAX_RESULTS, "triangles");
            break;
        }
        if (grow((void **)&res->contacts, &capacity, total + out.count, sizeof *res->contacts) != 0 ||
            (detail == TRI_SEGMENTS &&
             grow((void **)&res->segments, &segment_capacity, total + out.count, sizeof *res->segments) != 0)) {
            status = posed_nomem(j, "the reply's contacts");
            break;
        }
        for (size_t k = 0; k < out.count; k++, total++) {
            const object_contact *c = &scratch[k];
            /* Inside a solid, through no triangle of it: -1 on the wire (docs/protocol.md). */
            int32_t triangle = c->contact.triangle == OBJECT_INTERIOR ? -1 : (int32_t)c->contact.triangle;
            res->contacts[total] = (trioct_contact_t){(int32_t)i, (int32_t)c->object, triangle};
            if (detail == TRI_SEGMENTS)
                res->segments[total] = (trioct_segment_t){posed_vec_out(c->contact.p), posed_vec_out(c->contact.q)};
        }
    }
    free(scratch);
    res->item_count = (int32_t)n;
    res->record_count = total;
    return status;
}

int posed_meshes(job *j, const octree *shape_tree, box3 shape_bounds, const pose *poses, size_t n, int all_pairs,
                 query_result *res)
{
    state_scratch *scratch = state_scratch_new();
    state_contact *contacts = all_pairs ? dispatch_malloc(TRIOCT_MAX_RESULTS * sizeof *contacts) : NULL;
    state_contact first;
    res->found = dispatch_malloc(n * sizeof *res->found);
    if (!scratch || (all_pairs && !contacts) || !res->found) {
        state_scratch_free(scratch);
        free(contacts);
        return posed_nomem(j, "the poses' pairs");
    }
    size_t capacity = 0, total = 0;
    int status = TRIOCT_OK;
    for (size_t i = 0; i < n && status == TRIOCT_OK; i++) {
        state_link link = {"shape", shape_tree, shape_bounds, poses[i]};
        size_t room = TRIOCT_MAX_RESULTS - total;
        state_output out = {.contacts = all_pairs ? contacts : &first, .capacity = all_pairs ? room : 1};
        octree_status st = object_set_state(j->w->objects, &link, 1, NULL, 0, 0, all_pairs, &out, scratch, NULL);
        if (st != OCTREE_OK) {
            status = job_engine_error(j, st, "pose", i);
            break;
        }
        res->found[i] = all_pairs ? (int32_t)(out.count > INT32_MAX ? INT32_MAX : out.count) : !out.valid;
        if (!all_pairs || out.count == 0)
            continue;
        if (out.truncated || total + out.count > TRIOCT_MAX_RESULTS) {
            status = posed_over(j, (size_t)TRIOCT_MAX_RESULTS, "poses or a smaller shape");
            break;
        }
        if (grow((void **)&res->pairs, &capacity, total + out.count, sizeof *res->pairs) != 0) {
            status = posed_nomem(j, "the reply's pairs");
            break;
        }
        for (size_t k = 0; k < out.count; k++)
            res->pairs[total++] = (trioct_mesh_pair_t){(int32_t)i, (int32_t)contacts[k].link_triangle,
                                                       (int32_t)contacts[k].other, (int32_t)contacts[k].other_triangle};
    }
    state_scratch_free(scratch);
    free(contacts);
    res->item_count = (int32_t)n;
    res->record_count = total;
    return status;
}

int dispatch_name_objects(job *j, void *records, size_t count, object_field_fn field, int32_t *named_count,
                          char ***names)
{
    const object_set *s = j->w->objects;
    *named_count = 0;
    *names = NULL;
    if (count == 0 || s->count == 0)
        return TRIOCT_OK;
    int32_t *rank = dispatch_calloc(s->count, sizeof *rank);
    if (!rank)
        return posed_nomem(j, "the reply's object names");
    for (size_t i = 0; i < count; i++) {
        int32_t *o = field(records, i);
        if (o)
            rank[*o] = 1;
    }
    int32_t named = 0;
    for (size_t k = 0; k < s->count; k++)
        if (rank[k])
            rank[k] = ++named; /* 1-based while marking */
    *names = dispatch_malloc((size_t)named * sizeof **names);
    if (!*names) {
        free(rank);
        return posed_nomem(j, "the reply's object names");
    }
    for (size_t k = 0; k < s->count; k++)
        if (rank[k])
            (*names)[rank[k] - 1] = (char *)s->objects[k].name;
    *named_count = named;
    for (size_t i = 0; i < count; i++) {
        int32_t *o = field(records, i);
        if (o)
            *o = rank[*o] - 1;
    }
    free(rank);
    return TRIOCT_OK;
}

/* The object field of a query result's record i: hits, contacts or pairs. */
static int32_t *record_object(void *records, size_t i)
{
    query_result *r = records;
    if (r->hits)
        return &r->hits[i].object;
    if (r->contacts)
        return &r->contacts[i].object;
    return &r->pairs[i].object;
}

int posed_name_objects(job *j, query_result *r)
{
    return dispatch_name_objects(j, r, r->record_count, record_object, &r->object_count, &r->objects);
}

int dispatch_triangle_mesh(const trioct_triangle_t *tris, size_t n, vec3 **vertices, uint32_t **indices,
                           mesh_view *view)
{
    *vertices = dispatch_malloc(3 * n * sizeof **vertices);
    *indices = dispatch_malloc(3 * n * sizeof **indices);
    if (!*vertices || !*indices) {
        free(*vertices);
        free(*indices);
        *vertices = NULL;
        *indices = NULL;
        return -1;
    }
    for (size_t i = 0; i < n; i++) {
        const trioct_vec3_t *c[3] = {&tris[i].a, &tris[i].b, &tris[i].c};
        for (int k = 0; k < 3; k++) {
            (*vertices)[3 * i + k] = (vec3){c[k]->x, c[k]->y, c[k]->z};
            (*indices)[3 * i + k] = (uint32_t)(3 * i + k);
        }
    }
    *view = (mesh_view){*vertices, 3 * n, *indices, n};
    return 0;
}
