/* Where a point lies among a world's solid objects (object_set_point, object_set.h). */
#include "object_set.h"

#include <stdlib.h>

#include "../geom/vec3.h"

octree_status object_set_point(const object_set *s, vec3 p, object_point_output *out, query_stats *stats)
{
    if (!s || !out)
        return OCTREE_ERR_INVALID;
    *out = (object_point_output){POINT_OUTSIDE, UINT32_MAX};
    if (!vec3_is_finite(p))
        return OCTREE_ERR_NONFINITE;
    if (s->solids == 0)
        return OCTREE_OK;
    uint32_t *near = malloc(s->count * sizeof *near);
    if (!near)
        return OCTREE_ERR_NOMEM;
    /* Only an object whose posed box holds p can hold it (ascending: object order). */
    size_t near_count = object_set_near(s, (box3){p, p}, near);
    octree_status st = OCTREE_OK;
    for (size_t k = 0; k < near_count; k++) {
        const world_object *o = &s->objects[near[k]];
        if (!o->solid)
            continue;
        point_side side;
        st = octree_point_side_posed(o->model->tree, &o->at, p, &side, stats);
        if (st != OCTREE_OK)
            break;
        if (side != POINT_OUTSIDE) {
            *out = (object_point_output){side, near[k]};
            break;
        }
    }
    free(near);
    return st;
}
