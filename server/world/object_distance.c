/* Distances over a world's objects (object_set.h): each object's posed tree walked for
 * the point (octree_point_distance_posed), nearest object box first, each walk bounded by
 * the best upper bound so far, so that an object whose box is farther is never entered. */
#include <math.h>
#include <stdlib.h>

#include "../geom/interval.h"
#include "object_set.h"

typedef struct object_candidate {
    double lb2; /* a lower bound of the squared distance to the object's posed box */
    uint32_t object;
} object_candidate;

static int by_bound(const void *a, const void *b)
{
    const object_candidate *x = a, *y = b;
    if (x->lb2 != y->lb2)
        return x->lb2 < y->lb2 ? -1 : 1;
    return (x->object > y->object) - (x->object < y->object);
}

/* Rounded down: each gap, square and sum within a relative u of the real one. */
static double box_distance2_below(vec3 p, box3 b)
{
    const double lo[3] = {b.lo.x, b.lo.y, b.lo.z}, hi[3] = {b.hi.x, b.hi.y, b.hi.z}, q[3] = {p.x, p.y, p.z};
    double s = 0;
    for (int k = 0; k < 3; k++) {
        double below = iv_down(lo[k] - q[k]), above = iv_down(q[k] - hi[k]);
        double g = below > above ? below : above;
        if (g > 0)
            s = iv_down(s + iv_down(g * g));
    }
    return s;
}

octree_status object_set_point_distance(const object_set *s, vec3 p, double max_distance, object_distance_output *out,
                                        query_stats *stats)
{
    if (!s || !out)
        return OCTREE_ERR_INVALID;
    *out = (object_distance_output){0};
    if (!vec3_is_finite(p))
        return OCTREE_ERR_NONFINITE;
    if (!(max_distance >= 0))
        return OCTREE_ERR_INVALID;
    if (s->count == 0)
        return OCTREE_OK;
    object_candidate local[64];
    object_candidate *cand = s->count <= 64 ? local : malloc(s->count * sizeof *cand);
    if (!cand)
        return OCTREE_ERR_NOMEM;
    for (size_t i = 0; i < s->count; i++)
        cand[i] = (object_candidate){box_distance2_below(p, s->objects[i].bounds), (uint32_t)i};
    qsort(cand, s->count, sizeof *cand, by_bound);

    double limit = max_distance;
    octree_status st = OCTREE_OK;
    for (size_t k = 0; k < s->count; k++) {
        double limit2 = limit == INFINITY ? INFINITY : iv_up(limit * limit);
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
    if (cand != local)
        free(cand);
    if (st != OCTREE_OK || !out->found)
        return st;
    /* The midpoint and bound of the merged enclosure, as the engine states them. */
    distance_output *d = &out->distance;
    d->distance = 0.5 * d->lower + 0.5 * d->upper;
    double below = iv_up(d->distance - d->lower), above = iv_up(d->upper - d->distance);
    d->bound = below > above ? below : above;
    return OCTREE_OK;
}
