/* Distance requests (distance_request_t). POINTS is answered here: each point's nearest
 * point of the world, with the proven bound of the engine's walk (octree_point_distance
 * for a world of one object at the identity, object_set_point_distance otherwise). SHAPE
 * and CLEAR are part of the message already but get a refusal naming the kind, so that a
 * client learns this daemon's version does not answer them rather than waiting. Every
 * field is checked before any work, so one bad point fails the request with its index. */
#include <math.h>
#include <string.h>

#include "../world/object_set.h"
#include "dispatch_internal.h"

_Static_assert(DISTANCE_FACE == TRIOCT_DISTANCE_RESULT_T_FACE && DISTANCE_EDGE == TRIOCT_DISTANCE_RESULT_T_EDGE &&
                   DISTANCE_VERTEX == TRIOCT_DISTANCE_RESULT_T_VERTEX,
               "the engine's features are the wire's");

static const char *kind_name(int8_t kind)
{
    switch (kind) {
    case TRIOCT_DISTANCE_REQUEST_T_POINTS:
        return "POINTS (0)";
    case TRIOCT_DISTANCE_REQUEST_T_SHAPE:
        return "SHAPE (1)";
    default:
        return "CLEAR (2)";
    }
}

/* The checks every kind shares: the kind itself, the rotation form and its quaternions. */
static int check_kind(job *j, const trioct_distance_request_t *m)
{
    if (m->kind < TRIOCT_DISTANCE_REQUEST_T_POINTS || m->kind > TRIOCT_DISTANCE_REQUEST_T_CLEAR)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "kind %d is not POINTS (0), SHAPE (1) or CLEAR (2)", m->kind);
    if (m->rotation != TRIOCT_DISTANCE_REQUEST_T_MATRIX && m->rotation != TRIOCT_DISTANCE_REQUEST_T_QUATERNION)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "rotation %d is not MATRIX (0) or QUATERNION (1)", m->rotation);
    if (isnan(m->within))
        return job_fail(j, TRIOCT_ERR_NONFINITE, "within is NaN: send a distance, or a negative one for no limit");
    return TRIOCT_OK;
}

static int check_points(job *j, const trioct_distance_request_t *m)
{
    if (m->num_points > TRIOCT_MAX_POINTS)
        return job_fail(j, TRIOCT_ERR_OVER_CAP, "num_points %d is over TRIOCT_MAX_POINTS=%d; split the batch",
                        m->num_points, TRIOCT_MAX_POINTS);
    /* A point query that also sends a shape is a client mixing up kinds: say so rather
     * than answer half of what it meant. */
    if (m->shape[0] != '\0' || m->num_shape_triangles != 0 || m->num_poses != 0 || m->num_quaternions != 0)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST,
                        "kind POINTS takes points only, but the request has %s, %d shape triangles, %d poses and %d "
                        "quaternions",
                        m->shape[0] != '\0' ? "a shape name" : "no shape name", m->num_shape_triangles, m->num_poses,
                        m->num_quaternions);
    for (int32_t i = 0; i < m->num_points; i++) {
        const trioct_vec3_t *p = &m->points[i];
        if (!isfinite(p->x) || !isfinite(p->y) || !isfinite(p->z))
            return job_fail(j, TRIOCT_ERR_NONFINITE, "points[%d] is (%g, %g, %g): coordinates must be finite", (int)i,
                            p->x, p->y, p->z);
    }
    return TRIOCT_OK;
}

/* Object index of result i for the names table; NULL for a point with nothing found. */
static int32_t *result_object(void *records, size_t i)
{
    trioct_distance_result_t *r = records;
    return r[i].found ? &r[i].object : NULL;
}

/* One point's nearest world point into *out (out->item set by the caller). */
static octree_status point_distance(const world *w, vec3 p, double max_distance, trioct_distance_result_t *out)
{
    distance_output d;
    uint32_t object = 0; /* a world of one object at the identity: that object, index 0 */
    octree_status st;
    if (w->tree) {
        st = octree_point_distance(w->tree, p, max_distance, &d, NULL);
    } else {
        object_distance_output od;
        st = object_set_point_distance(w->objects, p, max_distance, &od, NULL);
        d = od.distance;
        d.found = od.found;
        object = od.object;
    }
    if (st != OCTREE_OK)
        return st;
    out->shape_point = (trioct_vec3_t){p.x, p.y, p.z};
    out->shape_triangle = -1;
    out->inside = 0; /* no object is solid yet: every distance is to the surface */
    if (!d.found) {
        out->object = -1;
        out->triangle = -1;
        return OCTREE_OK;
    }
    out->found = 1;
    out->distance = d.distance;
    out->bound = d.bound;
    out->lower = d.lower;
    out->upper = d.upper;
    out->point = (trioct_vec3_t){d.point.x, d.point.y, d.point.z};
    out->object = (int32_t)object;
    out->triangle = (int32_t)d.triangle;
    out->feature = (int8_t)d.feature;
    out->feature_index = (int8_t)d.feature_index;
    return OCTREE_OK;
}

static int answer_points(job *j, const trioct_distance_request_t *m)
{
    size_t n = (size_t)m->num_points;
    /* Negative means no limit; +infinity says the same in other words. */
    double max_distance = m->within < 0 ? INFINITY : m->within;
    trioct_distance_result_t *results = dispatch_calloc(n, sizeof *results);
    if (!results)
        return dispatch_out_of_memory(j, "the distance results");
    int status = TRIOCT_OK;
    for (size_t i = 0; i < n && status == TRIOCT_OK; i++) {
        results[i].item = (int32_t)i;
        const trioct_vec3_t *p = &m->points[i];
        octree_status st = point_distance(j->w, (vec3){p->x, p->y, p->z}, max_distance, &results[i]);
        if (st != OCTREE_OK)
            status = job_engine_error(j, st, "point", i);
    }
    int32_t object_count = 0;
    char **objects = NULL;
    if (status == TRIOCT_OK)
        status = dispatch_name_objects(j, results, n, result_object, &object_count, &objects);
    if (status == TRIOCT_OK) {
        reply_head h = job_head(j, TRIOCT_OK, "ok");
        status = encode_distance_reply(j->out, &h, m->kind, object_count, objects, results, n);
        if (status == TRIOCT_ERR_NOMEM)
            dispatch_out_of_memory(j, "the reply");
        else if (status != TRIOCT_OK)
            job_fail(j, status, "the reply does not fit chunks of TRIOCT_MAX_CHUNK_BYTES=%d", TRIOCT_MAX_CHUNK_BYTES);
        else
            j->counted = 1;
    }
    free(objects);
    free(results);
    return status;
}

int dispatch_distance(job *j, const trioct_distance_request_t *m)
{
    if (check_kind(j, m) != TRIOCT_OK)
        return j->status;
    /* SHAPE and CLEAR plug in here, as answer_shapes beside answer_points, once the engine walks shapes. */
    if (m->kind != TRIOCT_DISTANCE_REQUEST_T_POINTS)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST,
                        "distance kind %s is not served by this version of trioctd, which answers POINTS (0) only",
                        kind_name(m->kind));
    if (check_points(j, m) != TRIOCT_OK)
        return j->status;
    return answer_points(j, m);
}
