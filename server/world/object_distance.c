/* Distances over a world's objects (object_set.h): each object's posed tree walked for
 * the point (octree_point_distance_posed), nearest object box first, each walk bounded by
 * the best upper bound so far, so that an object whose box is farther is never entered. */
#include <math.h>
#include <stdlib.h>

#include "../geom/box_distance.h"
#include "../geom/interval.h"
#include "object_set.h"
#include "object_state.h"

typedef struct object_candidate {
    double lb2; /* a lower bound of the squared distance to the object's posed box */
    uint32_t object;
} object_candidate;

/* A limit on a distance as one on its square, rounded up. */
static double squared_limit(double limit)
{
    return limit == INFINITY ? INFINITY : iv_up(limit * limit);
}

static int by_bound(const void *a, const void *b)
{
    const object_candidate *x = a, *y = b;
    if (x->lb2 != y->lb2)
        return x->lb2 < y->lb2 ? -1 : 1;
    return (x->object > y->object) - (x->object < y->object);
}

/* The objects in order of their boxes' distance from box b (a lower bound of every
 * distance to them): the candidates, in local when there is room (64), else on the heap;
 * NULL when out of memory. */
static object_candidate *objects_by_box(const object_set *s, box3 b, object_candidate local[64])
{
    object_candidate *cand = s->count <= 64 ? local : malloc(s->count * sizeof *cand);
    if (!cand)
        return NULL;
    for (size_t i = 0; i < s->count; i++)
        cand[i] = (object_candidate){boxes_distance2_below(s->objects[i].bounds, b), (uint32_t)i};
    qsort(cand, s->count, sizeof *cand, by_bound);
    return cand;
}

static void candidates_free(object_candidate *cand, object_candidate local[64])
{
    if (cand != local)
        free(cand);
}

/* A distance enclosure made signed: the point or shape lies inside a solid, so its
 * distance to the surface counts below zero. */
static void negate_enclosure(double *distance, double *lower, double *upper)
{
    double was_lower = *lower;
    *lower = -*upper;
    *upper = -was_lower;
    *distance = -*distance;
}

octree_status object_set_point_distance(const object_set *s, vec3 p, double max_distance, object_distance_output *out,
                                        query_stats *stats)
{
    if (!s || !out)
        return OCTREE_ERR_INVALID;
    *out = (object_distance_output){0};
    out->inside_object = UINT32_MAX;
    if (!vec3_is_finite(p))
        return OCTREE_ERR_NONFINITE;
    if (!(max_distance >= 0))
        return OCTREE_ERR_INVALID;
    if (s->count == 0)
        return OCTREE_OK;
    object_candidate local[64];
    object_candidate *cand = objects_by_box(s, point_box(p), local);
    if (!cand)
        return OCTREE_ERR_NOMEM;

    double limit = max_distance;
    octree_status st = OCTREE_OK;
    for (size_t k = 0; k < s->count; k++) {
        double limit2 = squared_limit(limit);
        if (cand[k].lb2 > limit2)
            break; /* sorted: every later box is farther too */
        const world_object *o = &s->objects[cand[k].object];
        distance_output d;
        st = octree_point_distance_posed(o->model->tree, &o->at, p, limit, &d, stats);
        if (st != OCTREE_OK)
            break;
        if (!d.found)
            continue;
        /* The smallest upper bound names the answer (ties: the smaller object index, then
         * the engine's smaller triangle); the smallest lower bound is the answer's. */
        double lower = out->found && out->distance.lower < d.lower ? out->distance.lower : d.lower;
        if (!out->found || d.upper < out->distance.upper ||
            (d.upper == out->distance.upper && cand[k].object < out->object)) {
            out->distance = d;
            out->object = cand[k].object;
        }
        out->found = 1;
        out->distance.lower = lower;
        limit = out->distance.upper < limit ? out->distance.upper : limit;
    }
    candidates_free(cand, local);
    if (st != OCTREE_OK || !out->found)
        return st;
    /* The midpoint and bound of the merged enclosure, as the engine states them. */
    distance_output *d = &out->distance;
    iv_distance_report(vec3_length(vec3_sub(p, d->point)), d->lower, d->upper, &d->distance, &d->bound);
    if (s->solids > 0) {
        object_point_output side;
        st = object_set_point(s, p, &side, stats);
        if (st == OCTREE_OK && side.side == POINT_INSIDE) {
            negate_enclosure(&d->distance, &d->lower, &d->upper);
            out->inside = 1;
            out->inside_object = side.object;
        }
    }
    return st;
}

/* Merges one object's answer into the set's, as object_set_point_distance does. */
static void merge_shape(object_shape_distance_output *out, const shape_distance_output *d, uint32_t object)
{
    double lower = out->found && out->distance.lower < d->lower ? out->distance.lower : d->lower;
    if (!out->found || d->upper < out->distance.upper || (d->upper == out->distance.upper && object < out->object)) {
        out->distance = *d;
        out->object = object;
    }
    out->found = 1;
    out->distance.lower = lower;
}

/* A merged shape answer's reported value and bound (iv_distance_report), from its own
 * witness points and the merged enclosure. */
static void finish_bounds(shape_distance_output *d)
{
    iv_distance_report(vec3_length(vec3_sub(d->world_point, d->shape_point)), d->lower, d->upper, &d->distance,
                       &d->bound);
}

octree_status object_set_shape_distance(const object_set *s, const octree *shape, const pose *at,
                                        double max_distance, object_shape_distance_output *out, query_stats *stats)
{
    if (!s || !shape || !at || !out)
        return OCTREE_ERR_INVALID;
    *out = (object_shape_distance_output){0};
    out->inside_object = UINT32_MAX;
    if (!(max_distance >= 0))
        return OCTREE_ERR_INVALID;
    octree_status st = octree_pose_check(at);
    if (st != OCTREE_OK || s->count == 0)
        return st;
    /* Every posed shape vertex lies in the posed box of its tree's cube. */
    object_candidate local[64];
    object_candidate *cand = objects_by_box(s, octree_pose_box(at, octree_world_box(shape)), local);
    if (!cand)
        return OCTREE_ERR_NOMEM;
    double limit = max_distance;
    for (size_t k = 0; k < s->count; k++) {
        double limit2 = squared_limit(limit);
        if (cand[k].lb2 > limit2)
            break;
        const world_object *o = &s->objects[cand[k].object];
        shape_distance_output d;
        st = octree_shape_distance(o->model->tree, &o->at, shape, at, limit, &d, stats);
        if (st != OCTREE_OK)
            break;
        if (!d.found)
            continue;
        merge_shape(out, &d, cand[k].object);
        limit = out->distance.upper < limit ? out->distance.upper : limit;
        if (out->distance.upper == 0)
            break; /* touching: nothing is nearer */
    }
    candidates_free(cand, local);
    if (st != OCTREE_OK || !out->found)
        return st;
    finish_bounds(&out->distance);
    if (out->distance.upper > 0 && s->solids > 0) {
        long solid;
        uint32_t triangle;
        state_link link = {"shape", shape, octree_world_box(shape), *at};
        st = object_set_link_inside(s, &link, &solid, &triangle, stats);
        if (st == OCTREE_OK && solid >= 0) {
            shape_distance_output *d = &out->distance;
            negate_enclosure(&d->distance, &d->lower, &d->upper);
            out->inside = 1;
            out->inside_object = (uint32_t)solid;
        }
    }
    return st;
}

octree_status object_set_shape_clearance(const object_set *s, const octree *shape, const pose *at, double radius,
                                         int *clear, long *object, query_stats *stats)
{
    if (!s || !shape || !at || !clear)
        return OCTREE_ERR_INVALID;
    *clear = 0;
    if (object)
        *object = -1;
    if (!(radius >= 0))
        return OCTREE_ERR_INVALID;
    octree_status st = octree_pose_check(at);
    if (st != OCTREE_OK)
        return st;
    *clear = 1;
    if (s->count == 0)
        return OCTREE_OK;
    object_candidate local[64];
    object_candidate *cand = objects_by_box(s, octree_pose_box(at, octree_world_box(shape)), local);
    if (!cand)
        return OCTREE_ERR_NOMEM;
    double limit2 = squared_limit(radius);
    for (size_t k = 0; k < s->count && cand[k].lb2 <= limit2; k++) {
        const world_object *o = &s->objects[cand[k].object];
        int one;
        st = octree_shape_clearance(o->model->tree, &o->at, shape, at, radius, &one, stats);
        if (st != OCTREE_OK || !one) {
            *clear = 0;
            if (object && st == OCTREE_OK)
                *object = cand[k].object;
            break;
        }
    }
    candidates_free(cand, local);
    if (st == OCTREE_OK && *clear && s->solids > 0) {
        /* Clear of every surface, but perhaps inside a solid: that is contact. */
        long solid;
        uint32_t triangle;
        state_link link = {"shape", shape, octree_world_box(shape), *at};
        st = object_set_link_inside(s, &link, &solid, &triangle, stats);
        if (st == OCTREE_OK && solid >= 0) {
            *clear = 0;
            if (object)
                *object = solid;
        }
    }
    return st;
}

octree_status object_set_state_distance(const object_set *s, const state_link *links, size_t link_count,
                                        const state_allowed *allowed, size_t allowed_count, double max_distance,
                                        state_distance_output *out, query_stats *stats)
{
    if (!s || !out || !(max_distance >= 0))
        return OCTREE_ERR_INVALID;
    *out = (state_distance_output){0};
    octree_status checked = state_links_check(links, link_count, allowed, allowed_count);
    if (checked != OCTREE_OK)
        return checked;
    if (s->count == 0)
        return OCTREE_OK;
    double limit = max_distance;
    octree_status st = OCTREE_OK;
    for (size_t l = 0; l < link_count && st == OCTREE_OK; l++) {
        const state_link *link = &links[l];
        object_candidate local[64];
        object_candidate *cand = objects_by_box(s, octree_pose_box(&link->at, link->bounds), local);
        if (!cand) {
            st = OCTREE_ERR_NOMEM;
            break;
        }
        for (size_t k = 0; k < s->count; k++) {
            double limit2 = squared_limit(limit);
            if (cand[k].lb2 > limit2)
                break;
            const world_object *o = &s->objects[cand[k].object];
            if (state_pair_allowed(allowed, allowed_count, link->name, o->name))
                continue;
            shape_distance_output d;
            st = octree_shape_distance(o->model->tree, &o->at, link->tree, &link->at, limit, &d, stats);
            if (st != OCTREE_OK)
                break;
            if (!d.found)
                continue;
            double lower = out->found && out->distance.lower < d.lower ? out->distance.lower : d.lower;
            /* Links come in order, so a tie keeps the earlier link; within a link, the
             * smaller object index. */
            if (!out->found || d.upper < out->distance.upper ||
                (d.upper == out->distance.upper && out->link == l && cand[k].object < out->object)) {
                out->distance = d;
                out->link = (uint32_t)l;
                out->object = cand[k].object;
            }
            out->found = 1;
            out->distance.lower = lower;
            limit = out->distance.upper < limit ? out->distance.upper : limit;
            if (out->distance.upper == 0)
                break; /* touching: nothing is nearer */
        }
        candidates_free(cand, local);
        if (out->found && out->distance.upper == 0)
            break;
    }
    if (st == OCTREE_OK && out->found)
        finish_bounds(&out->distance);
    return st;
}
