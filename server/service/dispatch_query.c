/* Ray, triangle and mesh requests: every item is checked before any work, so one bad item
 * fails the whole request with its index in the message, then the engine answers the batch.
 *
 * Output arrays: the engine writes into caller-sized arrays and reports the full count when
 * they were too small. Sizing every item for its cap would reserve hundreds of megabytes
 * (800 triangles x 10,000 contacts), so the first pass gives each item an equal share of
 * TRIOCT_MAX_RESULTS; the few items that needed more, when the whole reply is still under
 * the cap, are asked again with exactly the room they need. Memory stays bounded by the
 * reply cap, and nothing is cut. */
#include <math.h>
#include <string.h>

#include "../geom/vec3.h"
#include "dispatch_internal.h"

/* ---------- shared checks ---------- */

static int vec_finite(const trioct_vec3_t *v)
{
    return isfinite(v->x) && isfinite(v->y) && isfinite(v->z);
}

static vec3 vec_in(const trioct_vec3_t *v)
{
    return (vec3){v->x, v->y, v->z};
}

static trioct_vec3_t vec_out(vec3 v)
{
    return (trioct_vec3_t){v.x, v.y, v.z};
}

/* Every request type uses ray_request_t's accuracy constants. A world of posed objects is
 * answered exactly: the world's mode means exact there, and an explicit seed or fast mode
 * is refused rather than silently upgraded. */
static int request_mode(job *j, int8_t accuracy, accuracy_mode *mode)
{
    if (!j->w->tree && (accuracy == TRIOCT_RAY_REQUEST_T_SEED || accuracy == TRIOCT_RAY_REQUEST_T_FAST))
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST,
                        "world %s holds %zu objects, not one at the identity, and answers them exactly only: send "
                        "accuracy EXACT (0) or ACCURACY_WORLD (-1), not %s",
                        j->w->spec.name, j->w->objects->count,
                        accuracy == TRIOCT_RAY_REQUEST_T_SEED ? "SEED (1)" : "FAST (2)");
    if (!j->w->tree) {
        *mode = ACCURACY_EXACT;
        return TRIOCT_OK;
    }
    if (accuracy == TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD) {
        *mode = j->w->spec.def.mode;
        return TRIOCT_OK;
    }
    if (accuracy >= TRIOCT_RAY_REQUEST_T_EXACT && accuracy <= TRIOCT_RAY_REQUEST_T_FAST) {
        *mode = (accuracy_mode)accuracy;
        return TRIOCT_OK;
    }
    return job_fail(j, TRIOCT_ERR_BAD_REQUEST,
                    "accuracy %d is not ACCURACY_WORLD (-1), EXACT (0), SEED (1) or FAST (2)", accuracy);
}

static int triangle_finite(job *j, const trioct_triangle_t *t, const char *what, int i)
{
    const trioct_vec3_t *v[3] = {&t->a, &t->b, &t->c};
    for (int k = 0; k < 3; k++)
        if (!vec_finite(v[k]))
            return job_fail(j, TRIOCT_ERR_NONFINITE, "%s[%d].%c is (%g, %g, %g): coordinates must be finite",
                            what, i, "abc"[k], v[k]->x, v[k]->y, v[k]->z);
    return TRIOCT_OK;
}

/* The first pass's room per item: an equal share of the reply cap, at most the item's cap,
 * at least one. */
static size_t first_room(size_t items, size_t item_cap)
{
    size_t share = items ? TRIOCT_MAX_RESULTS / items : TRIOCT_MAX_RESULTS;
    if (share < 1)
        share = 1;
    return share < item_cap ? share : item_cap;
}

static int32_t clamp_i32(size_t v)
{
    return v > INT32_MAX ? INT32_MAX : (int32_t)v;
}

static int over_results(job *j, size_t total, const char *fewer)
{
    return job_fail(j, TRIOCT_ERR_OVER_CAP,
                    "the request produced %zu results, over TRIOCT_MAX_RESULTS=%d; send fewer %s", total,
                    TRIOCT_MAX_RESULTS, fewer);
}

static int out_of_memory(job *j, const char *what)
{
    return dispatch_out_of_memory(j, what);
}

/* The OK reply of a query, encoded; the world's query counter goes up once it is. */
static int answer(job *j, int (*encode)(dispatch_reply *, const reply_head *, int8_t, const query_result *),
                  int8_t detail, query_result *r)
{
    if (posed_name_objects(j, r) != TRIOCT_OK)
        return j->status;
    reply_head h = job_head(j, TRIOCT_OK, "ok");
    int status = encode(j->out, &h, detail, r);
    if (status == TRIOCT_ERR_NOMEM)
        return out_of_memory(j, "the reply");
    if (status != TRIOCT_OK)
        return job_fail(j, status, "the reply does not fit chunks of TRIOCT_MAX_CHUNK_BYTES=%d",
                        TRIOCT_MAX_CHUNK_BYTES);
    j->counted = 1;
    return TRIOCT_OK;
}

/* ---------- rays ---------- */

static int check_rays(job *j, const trioct_ray_request_t *m, accuracy_mode *mode)
{
    if (m->num_rays > TRIOCT_MAX_RAYS)
        return job_fail(j, TRIOCT_ERR_OVER_CAP, "num_rays %d is over TRIOCT_MAX_RAYS=%d; split the batch",
                        m->num_rays, TRIOCT_MAX_RAYS);
    if (m->detail < TRIOCT_RAY_REQUEST_T_ANY || m->detail > TRIOCT_RAY_REQUEST_T_ALL)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "detail %d is not ANY (0), CLOSEST (1) or ALL (2)",
                        m->detail);
    if (request_mode(j, m->accuracy, mode) != TRIOCT_OK)
        return j->status;
    if (m->contact != TRIOCT_RAY_REQUEST_T_CROSSING && m->contact != TRIOCT_RAY_REQUEST_T_TOUCH)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "contact %d is not CROSSING (0) or TOUCH (1)", m->contact);
    if (m->contact == TRIOCT_RAY_REQUEST_T_TOUCH) {
        /* Touch is decided exactly or not at all: the world's mode means exact here, an
         * explicit seed or fast mode is refused rather than silently upgraded. */
        if (m->accuracy == TRIOCT_RAY_REQUEST_T_SEED || m->accuracy == TRIOCT_RAY_REQUEST_T_FAST)
            return job_fail(j, TRIOCT_ERR_BAD_REQUEST,
                            "contact TOUCH is decided exactly only: send accuracy EXACT (0) or "
                            "ACCURACY_WORLD (-1), not %s",
                            m->accuracy == TRIOCT_RAY_REQUEST_T_SEED ? "SEED (1)" : "FAST (2)");
        if (m->accuracy == TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD)
            *mode = ACCURACY_EXACT;
    }
    if (m->detail == TRIOCT_RAY_REQUEST_T_ALL) {
        if (m->max_hits > TRIOCT_MAX_HITS_PER_RAY)
            return job_fail(j, TRIOCT_ERR_OVER_CAP, "max_hits %d is over TRIOCT_MAX_HITS_PER_RAY=%d",
                            m->max_hits, TRIOCT_MAX_HITS_PER_RAY);
        if (m->max_hits < 1)
            return job_fail(j, TRIOCT_ERR_BAD_REQUEST,
                            "max_hits %d: ALL stores 1..TRIOCT_MAX_HITS_PER_RAY=%d hits per ray", m->max_hits,
                            TRIOCT_MAX_HITS_PER_RAY);
    }
    if (!isfinite(m->tmin))
        return job_fail(j, TRIOCT_ERR_NONFINITE, "tmin is %g; it must be finite", m->tmin);
    if (isnan(m->tmax))
        return job_fail(j, TRIOCT_ERR_NONFINITE, "tmax is NaN; send +infinity for no limit");
    if (m->tmin > m->tmax)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "tmin %.17g is greater than tmax %.17g", m->tmin, m->tmax);
    for (int i = 0; i < m->num_rays; i++) {
        const trioct_vec3_t *o = &m->origin[i], *d = &m->direction[i];
        if (!vec_finite(o))
            return job_fail(j, TRIOCT_ERR_NONFINITE, "origin[%d] is (%g, %g, %g): coordinates must be finite",
                            i, o->x, o->y, o->z);
        if (!vec_finite(d))
            return job_fail(j, TRIOCT_ERR_NONFINITE,
                            "direction[%d] is (%g, %g, %g): coordinates must be finite", i, d->x, d->y, d->z);
        if (d->x == 0.0 && d->y == 0.0 && d->z == 0.0)
            return job_fail(j, TRIOCT_ERR_ZERO_DIRECTION, "direction[%d] of ray %d is (0, 0, 0)", i, i);
    }
    return TRIOCT_OK;
}

static int ray_work(job *j, const trioct_ray_request_t *m, accuracy_mode mode, ray_input *in, ray_output *outs,
                    octree_status *st, query_result *res)
{
    size_t n = (size_t)m->num_rays;
    ray_detail detail = (ray_detail)m->detail;
    size_t keep_cap = detail == RAY_ALL ? (size_t)m->max_hits : 1;
    size_t room = first_room(n, keep_cap);
    ray_hit *pool = dispatch_malloc(n * room * sizeof *pool);
    if (!pool)
        return out_of_memory(j, "the rays' hits");
    for (size_t i = 0; i < n; i++) {
        in[i] = (ray_input){vec_in(&m->origin[i]), vec_in(&m->direction[i]), m->tmin, m->tmax,
                            m->contact == TRIOCT_RAY_REQUEST_T_TOUCH ? RAY_TOUCH : RAY_CROSSING};
        outs[i] = (ray_output){.hits = pool + i * room, .max_hits = room};
    }
    int status = TRIOCT_OK;
    if (octree_ray_batch(j->w->tree, in, n, detail, mode, outs, st, NULL) == OCTREE_ERR_NOMEM)
        status = out_of_memory(j, "the ray batch");
    size_t total = 0;
    for (size_t i = 0; i < n && status == TRIOCT_OK; i++) {
        if (st[i] != OCTREE_OK)
            status = job_engine_error(j, st[i], "ray", i);
        else
            total += outs[i].hit_count < keep_cap ? outs[i].hit_count : keep_cap;
    }
    if (status == TRIOCT_OK && total > TRIOCT_MAX_RESULTS)
        status = over_results(j, total, "rays or a smaller max_hits");
    /* Second pass: rays that crossed more than their share, each with the room it needs,
     * all from one block. */
    size_t extra_total = 0;
    for (size_t i = 0; i < n && status == TRIOCT_OK; i++) {
        size_t need = outs[i].hit_count < keep_cap ? outs[i].hit_count : keep_cap;
        if (need > room)
            extra_total += need;
    }
    ray_hit *extra = NULL;
    if (status == TRIOCT_OK && extra_total > 0 && !(extra = dispatch_malloc(extra_total * sizeof *extra)))
        status = out_of_memory(j, "the rays' hits");
    for (size_t i = 0, at = 0; i < n && status == TRIOCT_OK && extra; i++) {
        size_t need = outs[i].hit_count < keep_cap ? outs[i].hit_count : keep_cap;
        if (need <= room)
            continue;
        size_t found = outs[i].hit_count;
        outs[i] = (ray_output){.hits = extra + at, .max_hits = need};
        at += need;
        octree_status s = octree_ray(j->w->tree, &in[i], detail, mode, &outs[i], NULL);
        if (s != OCTREE_OK)
            status = job_engine_error(j, s, "ray", i);
        else if (outs[i].hit_count != found) /* the engine is deterministic: never expected */
            status = job_fail(j, TRIOCT_ERR_BAD_REQUEST, "ray %zu gave %zu and then %zu hits", i, found,
                              outs[i].hit_count);
    }
    if (status == TRIOCT_OK) {
        res->item_count = (int32_t)n;
        res->found = dispatch_malloc(n * sizeof *res->found);
        res->hits = dispatch_malloc(total * sizeof *res->hits);
        if (!res->found || !res->hits)
            status = out_of_memory(j, "the reply's hits");
    }
    if (status == TRIOCT_OK) {
        size_t r = 0;
        for (size_t i = 0; i < n; i++) {
            size_t keep = outs[i].hit_count < keep_cap ? outs[i].hit_count : keep_cap;
            res->found[i] = clamp_i32(outs[i].hit_count);
            for (size_t k = 0; k < keep; k++, r++) {
                const ray_hit *h = &outs[i].hits[k];
                res->hits[r] = (trioct_ray_hit_t){.ray = (int32_t)i, .t = h->t, .object = 0, .triangle = (int32_t)h->triangle,
                                                  .u = h->u, .v = h->v, .normal = vec_out(h->normal)};
            }
        }
        res->record_count = total;
    }
    free(extra);
    free(pool);
    return status;
}

int dispatch_ray(job *j, const trioct_ray_request_t *m)
{
    accuracy_mode mode = ACCURACY_EXACT;
    if (check_rays(j, m, &mode) != TRIOCT_OK)
        return j->status;
    size_t n = (size_t)m->num_rays;
    ray_input *in = dispatch_malloc(n * sizeof *in);
    ray_output *outs = dispatch_malloc(n * sizeof *outs);
    octree_status *st = dispatch_malloc(n * sizeof *st);
    query_result res = {0};
    int status;
    if (!in || !outs || !st) {
        status = out_of_memory(j, "the rays");
    } else if (j->w->tree) {
        status = ray_work(j, m, mode, in, outs, st, &res);
    } else {
        for (size_t i = 0; i < n; i++)
            in[i] = (ray_input){vec_in(&m->origin[i]), vec_in(&m->direction[i]), m->tmin, m->tmax,
                                m->contact == TRIOCT_RAY_REQUEST_T_TOUCH ? RAY_TOUCH : RAY_CROSSING};
        status = posed_rays(j, in, n, (ray_detail)m->detail,
                            m->detail == TRIOCT_RAY_REQUEST_T_ALL ? (size_t)m->max_hits : 1, &res);
    }
    free(in);
    free(outs);
    free(st);
    if (status == TRIOCT_OK)
        status = answer(j, encode_ray_reply, m->detail, &res);
    query_result_free(&res);
    return status;
}

/* ---------- triangles ---------- */

static int check_triangles(job *j, const trioct_triangle_request_t *m, accuracy_mode *mode)
{
    if (m->num_triangles > TRIOCT_MAX_TRIANGLES)
        return job_fail(j, TRIOCT_ERR_OVER_CAP,
                        "num_triangles %d is over TRIOCT_MAX_TRIANGLES=%d; split the batch", m->num_triangles,
                        TRIOCT_MAX_TRIANGLES);
    if (m->detail < TRIOCT_TRIANGLE_REQUEST_T_YESNO || m->detail > TRIOCT_TRIANGLE_REQUEST_T_SEGMENTS)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "detail %d is not YESNO (0), IDS (1) or SEGMENTS (2)",
                        m->detail);
    if (request_mode(j, m->accuracy, mode) != TRIOCT_OK)
        return j->status;
    for (int i = 0; i < m->num_triangles; i++)
        if (triangle_finite(j, &m->triangles[i], "triangles", i) != TRIOCT_OK)
            return j->status;
    return TRIOCT_OK;
}

static int triangle_work(job *j, const trioct_triangle_request_t *m, accuracy_mode mode, vec3 (*tris)[3],
                         tri_output *outs, octree_status *st, query_result *res)
{
    size_t n = (size_t)m->num_triangles;
    tri_detail detail = (tri_detail)m->detail;
    int lists = detail != TRI_YESNO;
    size_t room = lists ? first_room(n, TRIOCT_MAX_CONTACTS_PER_TRIANGLE) : 0;
    tri_contact *pool = lists ? dispatch_malloc(n * room * sizeof *pool) : NULL;
    if (lists && !pool)
        return out_of_memory(j, "the triangles' contacts");
    for (size_t i = 0; i < n; i++) {
        const trioct_triangle_t *t = &m->triangles[i];
        tris[i][0] = vec_in(&t->a);
        tris[i][1] = vec_in(&t->b);
        tris[i][2] = vec_in(&t->c);
        outs[i] = (tri_output){.contacts = lists ? pool + i * room : NULL, .capacity = room};
    }
    int status = TRIOCT_OK;
    if (octree_triangle_batch(j->w->tree, (const vec3(*)[3])tris, n, detail, mode, outs, st, NULL) ==
        OCTREE_ERR_NOMEM)
        status = out_of_memory(j, "the triangle batch");
    size_t total = 0;
    for (size_t i = 0; i < n && status == TRIOCT_OK; i++) {
        if (st[i] != OCTREE_OK)
            status = job_engine_error(j, st[i], "triangle", i);
        else if (outs[i].count > TRIOCT_MAX_CONTACTS_PER_TRIANGLE)
            status = job_fail(j, TRIOCT_ERR_OVER_CAP,
                              "triangle %zu touches %zu world triangles, over "
                              "TRIOCT_MAX_CONTACTS_PER_TRIANGLE=%d; split it into smaller triangles",
                              i, outs[i].count, TRIOCT_MAX_CONTACTS_PER_TRIANGLE);
        else
            total += outs[i].count;
    }
    if (status == TRIOCT_OK && total > TRIOCT_MAX_RESULTS)
        status = over_results(j, total, "triangles");
    size_t extra_total = 0;
    for (size_t i = 0; i < n && status == TRIOCT_OK; i++)
        if (outs[i].truncated)
            extra_total += outs[i].count;
    tri_contact *extra = NULL;
    if (status == TRIOCT_OK && extra_total > 0 && !(extra = dispatch_malloc(extra_total * sizeof *extra)))
        status = out_of_memory(j, "the triangles' contacts");
    for (size_t i = 0, at = 0; i < n && status == TRIOCT_OK && extra; i++) {
        size_t need = outs[i].count;
        if (!outs[i].truncated)
            continue;
        outs[i] = (tri_output){.contacts = extra + at, .capacity = need};
        at += need;
        octree_status s = octree_triangle(j->w->tree, (const vec3 *)tris[i], detail, mode, &outs[i], NULL);
        if (s != OCTREE_OK)
            status = job_engine_error(j, s, "triangle", i);
        else if (outs[i].truncated || outs[i].count != need) /* deterministic: never expected */
            status = job_fail(j, TRIOCT_ERR_BAD_REQUEST, "triangle %zu gave %zu and then %zu contacts", i, need,
                              outs[i].count);
    }
    if (status == TRIOCT_OK) {
        res->item_count = (int32_t)n;
        res->found = dispatch_malloc(n * sizeof *res->found);
        res->contacts = dispatch_malloc(total * sizeof *res->contacts);
        if (detail == TRI_SEGMENTS)
            res->segments = dispatch_malloc(total * sizeof *res->segments);
        if (!res->found || !res->contacts || (detail == TRI_SEGMENTS && !res->segments))
            status = out_of_memory(j, "the reply's contacts");
    }
    if (status == TRIOCT_OK) {
        size_t r = 0;
        for (size_t i = 0; i < n; i++) {
            res->found[i] = lists ? clamp_i32(outs[i].count) : outs[i].hit != 0;
            for (size_t k = 0; lists && k < outs[i].count; k++, r++) {
                const tri_contact *c = &outs[i].contacts[k];
                res->contacts[r] = (trioct_contact_t){(int32_t)i, 0, (int32_t)c->triangle};
                if (res->segments)
                    res->segments[r] = (trioct_segment_t){vec_out(c->p), vec_out(c->q)};
            }
        }
        res->record_count = total;
    }
    free(extra);
    free(pool);
    return status;
}

int dispatch_triangle(job *j, const trioct_triangle_request_t *m)
{
    accuracy_mode mode = ACCURACY_EXACT;
    if (check_triangles(j, m, &mode) != TRIOCT_OK)
        return j->status;
    size_t n = (size_t)m->num_triangles;
    vec3(*tris)[3] = dispatch_malloc(n * sizeof *tris);
    tri_output *outs = dispatch_malloc(n * sizeof *outs);
    octree_status *st = dispatch_malloc(n * sizeof *st);
    query_result res = {0};
    int status;
    /* A world with solid objects answers exact triangle queries through its objects, where
     * a solid's inside counts; seed and fast ones see surfaces only. */
    int solids = j->w->objects->solids > 0 && mode == ACCURACY_EXACT;
    if (!tris || !outs || !st) {
        status = out_of_memory(j, "the triangles");
    } else if (j->w->tree && !solids) {
        status = triangle_work(j, m, mode, tris, outs, st, &res);
    } else {
        for (size_t i = 0; i < n; i++) {
            const trioct_triangle_t *t = &m->triangles[i];
            tris[i][0] = vec_in(&t->a);
            tris[i][1] = vec_in(&t->b);
            tris[i][2] = vec_in(&t->c);
        }
        status = posed_triangles(j, (const vec3(*)[3])tris, n, (tri_detail)m->detail, &res);
    }
    free(tris);
    free(outs);
    free(st);
    if (status == TRIOCT_OK)
        status = answer(j, encode_triangle_reply, m->detail, &res);
    query_result_free(&res);
    return status;
}

/* ---------- meshes ---------- */

static int check_mesh(job *j, const trioct_mesh_request_t *m, accuracy_mode *mode)
{
    if (m->num_poses > TRIOCT_MAX_POSES)
        return job_fail(j, TRIOCT_ERR_OVER_CAP, "num_poses %d is over TRIOCT_MAX_POSES=%d; split the batch",
                        m->num_poses, TRIOCT_MAX_POSES);
    int named = m->shape[0] != '\0';
    if (!named && m->num_shape_triangles > TRIOCT_MAX_INLINE_SHAPE_TRIANGLES)
        return job_fail(j, TRIOCT_ERR_OVER_CAP,
                        "num_shape_triangles %d is over TRIOCT_MAX_INLINE_SHAPE_TRIANGLES=%d; load the shape "
                        "into the world's scene and send its name",
                        m->num_shape_triangles, TRIOCT_MAX_INLINE_SHAPE_TRIANGLES);
    if (m->detail < TRIOCT_MESH_REQUEST_T_YESNO || m->detail > TRIOCT_MESH_REQUEST_T_PAIRS)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "detail %d is not YESNO (0) or PAIRS (1)", m->detail);
    if (request_mode(j, m->accuracy, mode) != TRIOCT_OK)
        return j->status;
    if (named && m->num_shape_triangles != 0)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST,
                        "both shape and %d inline shape_triangles were sent; send one of them",
                        m->num_shape_triangles);
    if (!named && m->num_shape_triangles < 1)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST,
                        "no query shape: name one in shape or send 1..TRIOCT_MAX_INLINE_SHAPE_TRIANGLES=%d "
                        "shape_triangles",
                        TRIOCT_MAX_INLINE_SHAPE_TRIANGLES);
    for (int i = 0; i < m->num_shape_triangles; i++)
        if (triangle_finite(j, &m->shape_triangles[i], "shape_triangles", i) != TRIOCT_OK)
            return j->status;
    for (int i = 0; i < m->num_poses; i++) {
        const trioct_pose_t *p = &m->poses[i];
        for (int k = 0; k < 9; k++)
            if (!isfinite(p->r[k]))
                return job_fail(j, TRIOCT_ERR_NONFINITE, "poses[%d].r[%d] is %g: coordinates must be finite", i,
                                k, p->r[k]);
        if (!vec_finite(&p->t))
            return job_fail(j, TRIOCT_ERR_NONFINITE, "poses[%d].t is (%g, %g, %g): coordinates must be finite",
                            i, p->t.x, p->t.y, p->t.z);
        /* A scale, shear or mirror would pose a different shape than the one registered,
         * and the exact answers would be exact about the wrong thing. */
        pose at;
        memcpy(at.r, p->r, sizeof at.r);
        at.t = vec_in(&p->t);
        if (octree_pose_check(&at) != OCTREE_OK)
            return job_fail(j, TRIOCT_ERR_BAD_POSE,
                            "poses[%d].r is not a rotation: R^T R must be I within %g in every entry and det(R) "
                            "+1 (a scale, shear or mirror is refused)",
                            i, OCTREE_ROTATION_TOLERANCE);
    }
    return TRIOCT_OK;
}

/* shape_tree: a registered shape's octree (the engine descends it with the world's), or
 * NULL for an inline shape (the engine decides). The answers are the same either way. */
static int mesh_work(job *j, const trioct_mesh_request_t *m, accuracy_mode mode, const mesh_view *shape,
                     const octree *shape_tree, pose *poses, mesh_output *outs, octree_status *st,
                     query_result *res)
{
    size_t n = (size_t)m->num_poses;
    int all_pairs = m->detail == TRIOCT_MESH_REQUEST_T_PAIRS;
    size_t room = all_pairs ? first_room(n, TRIOCT_MAX_RESULTS) : 0;
    mesh_pair *pool = all_pairs ? dispatch_malloc(n * room * sizeof *pool) : NULL;
    if (all_pairs && !pool)
        return out_of_memory(j, "the poses' pairs");
    for (size_t i = 0; i < n; i++) {
        const trioct_pose_t *p = &m->poses[i];
        memcpy(poses[i].r, p->r, sizeof poses[i].r);
        poses[i].t = vec_in(&p->t);
        outs[i] = (mesh_output){.pairs = all_pairs ? pool + i * room : NULL, .capacity = room};
    }
    int status = TRIOCT_OK;
    octree_status batch = shape_tree
                              ? octree_mesh_tree_batch(j->w->tree, shape_tree, poses, n, all_pairs, mode, outs, st, NULL)
                              : octree_mesh_batch(j->w->tree, shape, poses, n, all_pairs, mode, outs, st, NULL);
    if (batch == OCTREE_ERR_NOMEM)
        status = out_of_memory(j, "the mesh batch");
    size_t total = 0;
    for (size_t i = 0; i < n && status == TRIOCT_OK; i++) {
        if (st[i] != OCTREE_OK)
            status = job_engine_error(j, st[i], "pose", i);
        else
            total += outs[i].count;
    }
    if (status == TRIOCT_OK && total > TRIOCT_MAX_RESULTS)
        status = over_results(j, total, "poses or a smaller shape");
    size_t extra_total = 0;
    for (size_t i = 0; i < n && status == TRIOCT_OK; i++)
        if (outs[i].truncated)
            extra_total += outs[i].count;
    mesh_pair *extra = NULL;
    if (status == TRIOCT_OK && extra_total > 0 && !(extra = dispatch_malloc(extra_total * sizeof *extra)))
        status = out_of_memory(j, "the poses' pairs");
    for (size_t i = 0, at = 0; i < n && status == TRIOCT_OK && extra; i++) {
        size_t need = outs[i].count;
        if (!outs[i].truncated)
            continue;
        outs[i] = (mesh_output){.pairs = extra + at, .capacity = need};
        at += need;
        octree_status s = shape_tree ? octree_mesh_tree(j->w->tree, shape_tree, &poses[i], all_pairs, mode, &outs[i], NULL)
                                     : octree_mesh(j->w->tree, shape, &poses[i], all_pairs, mode, &outs[i], NULL);
        if (s != OCTREE_OK)
            status = job_engine_error(j, s, "pose", i);
        else if (outs[i].truncated || outs[i].count != need) /* deterministic: never expected */
            status = job_fail(j, TRIOCT_ERR_BAD_REQUEST, "pose %zu gave %zu and then %zu pairs", i, need,
                              outs[i].count);
    }
    if (status == TRIOCT_OK) {
        res->item_count = (int32_t)n;
        res->found = dispatch_malloc(n * sizeof *res->found);
        res->pairs = dispatch_malloc(total * sizeof *res->pairs);
        if (!res->found || !res->pairs)
            status = out_of_memory(j, "the reply's pairs");
    }
    if (status == TRIOCT_OK) {
        size_t r = 0;
        for (size_t i = 0; i < n; i++) {
            res->found[i] = all_pairs ? clamp_i32(outs[i].count) : outs[i].hit != 0;
            for (size_t k = 0; all_pairs && k < outs[i].count; k++, r++)
                res->pairs[r] = (trioct_mesh_pair_t){(int32_t)i, (int32_t)outs[i].pairs[k].query_triangle, 0,
                                                     (int32_t)outs[i].pairs[k].world_triangle};
        }
        res->record_count = total;
    }
    free(extra);
    free(pool);
    return status;
}

/* A world of posed objects asks the shape as a one-link state at each pose (the two
 * trees descended together); an inline shape gets its tree here. */
static int posed_mesh_work(job *j, const trioct_mesh_request_t *m, const mesh_view *shape, const octree *shape_tree,
                           pose *poses, query_result *res)
{
    size_t n = (size_t)m->num_poses;
    for (size_t i = 0; i < n; i++) {
        memcpy(poses[i].r, m->poses[i].r, sizeof poses[i].r);
        poses[i].t = vec_in(&m->poses[i].t);
    }
    octree *own = NULL;
    if (!shape_tree) {
        octree_def def = octree_default_def();
        def.node_bounds = 1;
        octree_error e;
        own = octree_build(shape, &def, &e);
        if (!own)
            return e.status == OCTREE_ERR_NOMEM ? out_of_memory(j, "the inline shape's tree")
                                                : job_fail(j, TRIOCT_ERR_BAD_REQUEST, "the inline shape: %s: %s",
                                                           octree_status_text(e.status), e.message);
        shape_tree = own;
    }
    box3 bounds = {shape->vertices[0], shape->vertices[0]};
    for (size_t v = 1; v < shape->vertex_count; v++) {
        bounds.lo = vec3_min(bounds.lo, shape->vertices[v]);
        bounds.hi = vec3_max(bounds.hi, shape->vertices[v]);
    }
    int status = posed_meshes(j, shape_tree, bounds, poses, n, m->detail == TRIOCT_MESH_REQUEST_T_PAIRS, res);
    octree_free(own);
    return status;
}

int dispatch_mesh(job *j, const trioct_mesh_request_t *m)
{
    accuracy_mode mode = ACCURACY_EXACT;
    if (check_mesh(j, m, &mode) != TRIOCT_OK)
        return j->status;
    mesh_view shape;
    const octree *shape_tree = NULL;
    vec3 *vertices = NULL;
    uint32_t *indices = NULL;
    if (m->shape[0] != '\0') {
        const world_shape *s = world_find_shape(j->w, m->shape);
        if (!s) {
            char q[48];
            return job_fail(j, TRIOCT_ERR_UNKNOWN_SHAPE, "world %s has no query shape \"%s\" (it has %zu)",
                            j->w->spec.name, dispatch_quote(m->shape, q, sizeof q), j->w->shape_count);
        }
        shape = mesh_data_view(&s->model->mesh);
        shape_tree = s->model->tree;
    } else if (dispatch_triangle_mesh(m->shape_triangles, (size_t)m->num_shape_triangles, &vertices, &indices,
                                      &shape) != 0) {
        return out_of_memory(j, "the inline shape");
    }
    size_t n = (size_t)m->num_poses;
    pose *poses = dispatch_malloc(n * sizeof *poses);
    mesh_output *outs = dispatch_malloc(n * sizeof *outs);
    octree_status *st = dispatch_malloc(n * sizeof *st);
    query_result res = {0};
    int status;
    if (!poses || !outs || !st)
        status = out_of_memory(j, "the poses");
    else if (j->w->tree && !(j->w->objects->solids > 0 && mode == ACCURACY_EXACT))
        status = mesh_work(j, m, mode, &shape, shape_tree, poses, outs, st, &res);
    else
        status = posed_mesh_work(j, m, &shape, shape_tree, poses, &res);
    free(poses);
    free(outs);
    free(st);
    free(vertices);
    free(indices);
    if (status == TRIOCT_OK)
        status = answer(j, encode_mesh_reply, m->detail, &res);
    query_result_free(&res);
    return status;
}
