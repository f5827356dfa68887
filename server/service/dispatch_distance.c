/* Distance requests (distance_request_t): POINTS, each point's nearest point of the world;
 * SHAPE, the minimum distance of a shape (registered, or inline triangles given a tree
 * here) at each pose, with both witnesses; CLEAR, whether anything lies within the radius
 * of it. Each with the proven bounds of the engine's walks (octree_point_distance,
 * octree_shape_distance, octree_shape_clearance for a world of one object at the
 * identity; their object_set_ forms otherwise). Every field is checked before any work,
 * so one bad point or pose fails the request with its index. */
#include <math.h>
#include <string.h>

#include "../world/object_set.h"
#include "../world/world.h"
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

/* The reply of n results: their objects named, encoded into chunks. */
static int send_results(job *j, const trioct_distance_request_t *m, trioct_distance_result_t *results, size_t n,
                        object_field_fn field)
{
    int32_t object_count = 0;
    char **objects = NULL;
    int status = dispatch_name_objects(j, results, n, field, &object_count, &objects);
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
    return status;
}

/* One point's nearest world point into *out (out->item set by the caller). */
static octree_status point_distance(const world *w, vec3 p, double max_distance, trioct_distance_result_t *out)
{
    distance_output d;
    uint32_t object = 0; /* a world of one object at the identity: that object, index 0 */
    octree_status st;
    /* A solid's inside signs the distance, which only the objects' path asks. */
    if (w->tree && w->objects->solids == 0) {
        st = octree_point_distance(w->tree, p, max_distance, &d, NULL);
    } else {
        object_distance_output od;
        st = object_set_point_distance(w->objects, p, max_distance, &od, NULL);
        d = od.distance;
        d.found = od.found;
        object = od.object;
        out->inside = (int8_t)od.inside; /* inside a solid: the distance is negative */
    }
    if (st != OCTREE_OK)
        return st;
    out->shape_point = (trioct_vec3_t){p.x, p.y, p.z};
    out->shape_triangle = -1;
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
    if (status == TRIOCT_OK)
        status = send_results(j, m, results, n, result_object);
    free(results);
    return status;
}

static int finite3(const trioct_vec3_t *v)
{
    return isfinite(v->x) && isfinite(v->y) && isfinite(v->z);
}

/* SHAPE and CLEAR: a shape (a name or inline triangles, one of them) and 1..TRIOCT_MAX_POSES
 * rigid poses, no points; CLEAR's radius >= 0. */
static int check_shape(job *j, const trioct_distance_request_t *m)
{
    int named = m->shape[0] != '\0';
    if (m->num_points != 0)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "kind %s takes a shape and poses, but the request has %d points",
                        kind_name(m->kind), m->num_points);
    if (m->kind == TRIOCT_DISTANCE_REQUEST_T_CLEAR && !(m->within >= 0))
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "within %g: CLEAR's radius must be >= 0", m->within);
    if (named && m->num_shape_triangles != 0)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "both shape and %d inline shape_triangles were sent; send one of them",
                        m->num_shape_triangles);
    if (!named && (m->num_shape_triangles < 1 || m->num_shape_triangles > TRIOCT_MAX_INLINE_SHAPE_TRIANGLES))
        return job_fail(j, m->num_shape_triangles < 1 ? TRIOCT_ERR_BAD_REQUEST : TRIOCT_ERR_OVER_CAP,
                        "num_shape_triangles %d: name a shape of the world's scene or send "
                        "1..TRIOCT_MAX_INLINE_SHAPE_TRIANGLES=%d triangles",
                        m->num_shape_triangles, TRIOCT_MAX_INLINE_SHAPE_TRIANGLES);
    for (int i = 0; i < m->num_shape_triangles; i++) {
        const trioct_triangle_t *t = &m->shape_triangles[i];
        if (!finite3(&t->a) || !finite3(&t->b) || !finite3(&t->c))
            return job_fail(j, TRIOCT_ERR_NONFINITE, "shape_triangles[%d] has a coordinate that is not finite", i);
    }
    if (m->num_poses < 1 || m->num_poses > TRIOCT_MAX_POSES)
        return job_fail(j, m->num_poses < 1 ? TRIOCT_ERR_BAD_REQUEST : TRIOCT_ERR_OVER_CAP,
                        "num_poses %d: send 1..TRIOCT_MAX_POSES=%d poses", m->num_poses, TRIOCT_MAX_POSES);
    int quaternions = m->rotation == TRIOCT_DISTANCE_REQUEST_T_QUATERNION;
    if (m->num_quaternions != (quaternions ? 4 * m->num_poses : 0))
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "num_quaternions %d: %s", m->num_quaternions,
                        quaternions ? "QUATERNION rotations are 4 numbers a pose" : "MATRIX rotations send none");
    for (int i = 0; i < m->num_poses; i++) {
        pose at;
        octree_status st = dispatch_wire_pose(&m->poses[i], quaternions ? &m->quaternions[4 * i] : NULL, &at);
        if (st == OCTREE_ERR_NONFINITE)
            return job_fail(j, TRIOCT_ERR_NONFINITE, "poses[%d] has an entry that is not finite", i);
        if (st != OCTREE_OK)
            return job_fail(j, TRIOCT_ERR_BAD_POSE,
                            quaternions ? "poses[%d]: its quaternion's length is not 1 within 1e-3"
                                        : "poses[%d].r is not a rotation: R^T R must be I within 1e-6 in every entry "
                                          "and det(R) +1 (a scale, shear or mirror is refused)",
                            i);
    }
    return TRIOCT_OK;
}

/* The inline triangles' own tree, built as a registered shape's is (node bounds and
 * slabs), within the world's default budget for that many triangles. */
static octree *inline_shape_tree(job *j, const trioct_distance_request_t *m)
{
    vec3 *vertices;
    uint32_t *indices;
    mesh_view view;
    octree *tree = NULL;
    if (dispatch_triangle_mesh(m->shape_triangles, (size_t)m->num_shape_triangles, &vertices, &indices, &view) == 0) {
        octree_def def = octree_default_def();
        def.node_bounds = 1;
        def.node_slabs = 1;
        octree_error e;
        tree = octree_build(&view, &def, &e);
        if (!tree && e.status != OCTREE_ERR_NOMEM)
            job_fail(j, TRIOCT_ERR_BAD_REQUEST, "the inline shape: %s: %s", octree_status_text(e.status), e.message);
    }
    if (!tree && j->status == TRIOCT_OK)
        dispatch_out_of_memory(j, "the inline shape's tree");
    free(vertices);
    free(indices);
    return tree;
}

/* One pose's answer into *out (out->item set by the caller). */
static octree_status shape_answer(const world *w, const octree *shape, const pose *at, int8_t kind, double within,
                                  trioct_distance_result_t *out)
{
    out->object = -1;
    out->triangle = -1;
    out->shape_triangle = -1;
    out->feature = -1; /* a shape's witness is on a triangle pair, not one feature */
    out->feature_index = -1;
    octree_status st;
    /* A solid's inside counts, which only the objects' path asks. */
    const octree *tree = w->objects->solids == 0 ? w->tree : NULL;
    if (kind == TRIOCT_DISTANCE_REQUEST_T_CLEAR) {
        int clear;
        long first = tree ? 0 : -1;
        st = tree ? octree_shape_clearance(tree, NULL, shape, at, within, &clear, NULL)
                  : object_set_shape_clearance(w->objects, shape, at, within, &clear, &first, NULL);
        if (st == OCTREE_OK) {
            out->clear = (int8_t)clear;
            out->object = clear ? -1 : (int32_t)first; /* the first object not proven clear */
        }
        return st;
    }
    double max_distance = within < 0 ? INFINITY : within;
    shape_distance_output d;
    uint32_t object = 0;
    if (tree) {
        st = octree_shape_distance(tree, NULL, shape, at, max_distance, &d, NULL);
    } else {
        object_shape_distance_output od;
        st = object_set_shape_distance(w->objects, shape, at, max_distance, &od, NULL);
        d = od.distance;
        d.found = od.found;
        object = od.object;
        out->inside = (int8_t)od.inside; /* inside a solid: the distance is negative */
    }
    if (st != OCTREE_OK || !d.found)
        return st;
    out->found = 1;
    out->distance = d.distance;
    out->bound = d.bound;
    out->lower = d.lower;
    out->upper = d.upper;
    out->point = (trioct_vec3_t){d.world_point.x, d.world_point.y, d.world_point.z};
    out->shape_point = (trioct_vec3_t){d.shape_point.x, d.shape_point.y, d.shape_point.z};
    out->object = (int32_t)object;
    out->triangle = (int32_t)d.world_triangle;
    out->shape_triangle = (int32_t)d.shape_triangle;
    return OCTREE_OK;
}

/* Object index of a shape result for the names table: a found distance's, or the object
 * a CLEAR could not prove clear of. */
static int32_t *shape_result_object(void *records, size_t i)
{
    trioct_distance_result_t *r = records;
    return r[i].object >= 0 ? &r[i].object : NULL;
}

static int answer_shapes(job *j, const trioct_distance_request_t *m)
{
    const octree *shape = NULL;
    octree *own = NULL;
    if (m->shape[0] != '\0') {
        const world_shape *ws = world_find_shape(j->w, m->shape);
        if (!ws) {
            char q[48];
            return job_fail(j, TRIOCT_ERR_UNKNOWN_SHAPE, "world %s has no query shape \"%s\" (it has %zu)",
                            j->w->spec.name, dispatch_quote(m->shape, q, sizeof q), j->w->shape_count);
        }
        shape = ws->model->tree;
    } else if (!(shape = own = inline_shape_tree(j, m))) {
        return j->status;
    }
    size_t n = (size_t)m->num_poses;
    trioct_distance_result_t *results = dispatch_calloc(n, sizeof *results);
    int status = results ? TRIOCT_OK : dispatch_out_of_memory(j, "the distance results");
    int quaternions = m->rotation == TRIOCT_DISTANCE_REQUEST_T_QUATERNION;
    for (size_t i = 0; i < n && status == TRIOCT_OK; i++) {
        pose at;
        dispatch_wire_pose(&m->poses[i], quaternions ? &m->quaternions[4 * i] : NULL, &at); /* checked */
        results[i].item = (int32_t)i;
        octree_status st = shape_answer(j->w, shape, &at, m->kind, m->within, &results[i]);
        if (st != OCTREE_OK)
            status = job_engine_error(j, st, "pose", i);
    }
    octree_free(own);
    if (status == TRIOCT_OK)
        status = send_results(j, m, results, n, shape_result_object);
    free(results);
    return status;
}

int dispatch_distance(job *j, const trioct_distance_request_t *m)
{
    if (check_kind(j, m) != TRIOCT_OK)
        return j->status;
    if (m->kind != TRIOCT_DISTANCE_REQUEST_T_POINTS)
        return check_shape(j, m) != TRIOCT_OK ? j->status : answer_shapes(j, m);
    if (check_points(j, m) != TRIOCT_OK)
        return j->status;
    return answer_points(j, m);
}
