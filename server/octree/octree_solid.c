/* Where a point lies against a closed mesh placed by a pose: on its surface, inside or
 * outside (octree_point_side_posed, engine.h), from the exact queries the engine already
 * answers: a triangle query for the surface, the parity of a watertight ray for the rest. */
#include <math.h>

#include "../geom/vec3.h"
#include "octree_internal.h"

/* The axis direction from p whose ray leaves the box soonest: any direction gives the same
 * parity, and the shortest way out visits the fewest nodes. */
static vec3 shortest_way_out(vec3 p, box3 b)
{
    const double gaps[6] = {b.hi.x - p.x, p.x - b.lo.x, b.hi.y - p.y, p.y - b.lo.y, b.hi.z - p.z, p.z - b.lo.z};
    static const vec3 ways[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    int best = 0;
    for (int k = 1; k < 6; k++)
        if (gaps[k] < gaps[best])
            best = k;
    return ways[best];
}

static int inside_closed_box(vec3 p, box3 b)
{
    return p.x >= b.lo.x && p.x <= b.hi.x && p.y >= b.lo.y && p.y <= b.hi.y && p.z >= b.lo.z && p.z <= b.hi.z;
}

octree_status octree_point_side_posed(const octree *tree, const pose *at, vec3 p, point_side *side,
                                      query_stats *stats)
{
    if (!tree || !at || !side)
        return OCTREE_ERR_INVALID;
    *side = POINT_OUTSIDE;
    if (!vec3_is_finite(p))
        return OCTREE_ERR_NONFINITE;
    octree_status st = octree_pose_check(at);
    if (st != OCTREE_OK)
        return st;
    /* Every posed vertex lies in the posed cube's box, so a point outside it is on no
     * triangle and inside no closed surface of them. */
    box3 reach = octree_pose_box(at, tree->world);
    if (!inside_closed_box(p, reach))
        return OCTREE_OK;

    /* The point as a triangle of zero area: the exact closed test then says whether it lies
     * on a face, an edge or a vertex. */
    const vec3 point[3] = {p, p, p};
    tri_output touched = {0};
    st = octree_triangle_posed(tree, at, point, TRI_YESNO, ACCURACY_EXACT, &touched, stats);
    if (st != OCTREE_OK)
        return st;
    if (touched.hit) {
        *side = POINT_ON_SURFACE;
        return OCTREE_OK;
    }

    /* Off the surface, no crossing is at t = 0, and RAY_CROSSING counts each crossing of
     * the perturbed ray once: on a closed mesh an odd count is inside. No hit is stored;
     * RAY_ALL still counts every one. */
    ray_input ray = {.origin = p, .direction = shortest_way_out(p, reach), .tmin = 0.0, .tmax = INFINITY,
                     .contact = RAY_CROSSING};
    ray_output crossings = {.hits = NULL, .max_hits = 0};
    st = octree_ray_posed(tree, at, &ray, RAY_ALL, ACCURACY_EXACT, &crossings, stats);
    if (st != OCTREE_OK)
        return st;
    *side = (crossings.hit_count & 1) ? POINT_INSIDE : POINT_OUTSIDE;
    return OCTREE_OK;
}
