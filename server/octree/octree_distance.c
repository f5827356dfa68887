/* Point distance: the nearest point of a tree's triangles to a query point, with bounds
 * proven by interval arithmetic (server/geom/point_distance.h).
 *
 * The walk is depth first, nearest child first: a node's eight children are ordered by
 * the distance of their bounds (octree_distance_bounds) from the point, a lower bound of
 * every triangle point in them, and a child is entered only while that bound is within
 * the search radius, the smallest upper bound any candidate has given so far (or the
 * caller's max_distance). Depth first
 * keeps the stack at 8 entries a level, where a best-first heap could hold every node; it
 * visits the same leaves once the radius is small, which the nearest-first order makes it
 * soon. A tree with owned lists meets each triangle once; in one without, a triangle
 * listed in several leaves is bounded once: a small table of the ids tested remembers the
 * recent ones, which are the ones a neighbouring leaf repeats. */
#include <math.h>
#include <string.h>

#include "../geom/box_distance.h"
#include "../geom/interval.h"
#include "../geom/point_distance.h"
#include "../geom/tri_distance.h"
#include "octree_internal.h"

typedef struct distance_entry {
    uint32_t node;
    double lb2;
    box3 box;
} distance_entry;

/* What the walk needs of its query: the point in the tree's frame, the widening and scale
 * of a posed tree's lower bounds (0 and 1 unposed), and the pose its candidates take. */
typedef struct distance_query {
    vec3 world_point, local_point;
    double grow, shrink2;
    const pose *at; /* NULL: the tree stands as built */
    /* local_point - world.lo as bounds, for the triangle boxes' offsets */
    interval offset[3];
} distance_query;

#define RECENT_SLOTS 64

typedef struct distance_search {
    double limit2;  /* candidates proven farther than this are not counted */
    double lower2;  /* the smallest lower bound of a counted candidate */
    int found;
    point_triangle_distance best;
    uint32_t best_id; /* the caller's id */
    uint32_t recent[RECENT_SLOTS];
} distance_search;

/* A node box's lower bound: the box grown by what a pose's rounding can move a point, its
 * distance from the local point, scaled to stay below the world distance. */
static double box_distance2_below(const distance_query *q, box3 b)
{
    return boxes_distance2_below(box_grown(b, q->grow), point_box(q->local_point)) * q->shrink2;
}

/* The same for a triangle's float box, whose offsets are from the world cube's corner (the
 * floats exact as doubles), against the bounds of the local point's offset. */
static double triangle_box_distance2_below(const distance_query *q, const triangle_box *tb)
{
    box3 offsets = {{tb->lo[0], tb->lo[1], tb->lo[2]}, {tb->hi[0], tb->hi[1], tb->hi[2]}};
    box3 point = {{q->offset[0].lo, q->offset[1].lo, q->offset[2].lo}, {q->offset[0].hi, q->offset[1].hi, q->offset[2].hi}};
    return boxes_distance2_below(box_grown(offsets, q->grow), point) * q->shrink2;
}

static void take_triangle(const octree *tree, const distance_query *q, distance_search *s, uint32_t id,
                          query_stats *stats)
{
    uint32_t *slot = &s->recent[id % RECENT_SLOTS];
    if (*slot == id)
        return;
    *slot = id;
    if (tree->triangle_boxes && triangle_box_distance2_below(q, &tree->triangle_boxes[id]) > s->limit2)
        return;
    vec3 v[3];
    octree_triangle_vertices(tree, id, v);
    if (q->at)
        for (int k = 0; k < 3; k++)
            v[k] = octree_apply_pose(q->at, v[k]);
    /* The box of the (posed) vertices is a cheaper lower bound than the triangle's own,
     * and in a tree without triangle boxes the only one. */
    if (boxes_distance2_below(triangle_bounds(v), point_box(q->world_point)) > s->limit2)
        return;
    /* The distance to the triangle's plane is a lower bound too, and a tight one where
     * many triangles stand about as far (a point inside a sphere, above a plain): a
     * tenth of the full bounds' cost. */
    vec3 normal = vec3_cross(vec3_sub(v[1], v[0]), vec3_sub(v[2], v[0]));
    if (convex_gap_lower2(&q->world_point, 1, v, 3, normal) > s->limit2)
        return;
    stats->candidates_tested++;
    point_triangle_distance r;
    point_triangle_distance_bounds(q->world_point, v, &r);
    if (!(r.lo2 <= s->limit2))
        return;
    uint32_t original = tree->original_id[id];
    s->found = 1;
    s->lower2 = r.lo2 < s->lower2 ? r.lo2 : s->lower2;
    if (r.hi2 < s->best.hi2 || (r.hi2 == s->best.hi2 && original < s->best_id)) {
        s->best = r;
        s->best_id = original;
    }
    s->limit2 = s->best.hi2 < s->limit2 ? s->best.hi2 : s->limit2;
}

static void walk(const octree *tree, const distance_query *q, distance_search *s, query_stats *stats)
{
    distance_entry stack[OCTREE_STACK_MAX];
    size_t top = 0;
    stats->nodes_visited++;
    double root = box_distance2_below(q, octree_distance_bounds(tree, 0, tree->world));
    if (!octree_distance_empty(tree, 0) && root <= s->limit2)
        stack[top++] = (distance_entry){0, root, tree->world};
    while (top > 0) {
        distance_entry e = stack[--top];
        if (e.lb2 > s->limit2)
            continue;
        octree_node node = tree->nodes[e.node];
        if (node.count != NODE_INTERIOR) {
            stats->leaves_visited++;
            uint32_t count;
            const uint32_t *items = octree_distance_items(tree, node, e.node, &count);
            for (uint32_t i = 0; i < count; i++)
                take_triangle(tree, q, s, items[i], stats);
            continue;
        }
        vec3 c = octree_split_point(tree, e.box);
        distance_entry near[8];
        int n = 0;
        for (int k = 0; k < 8; k++) {
            uint32_t child = node.first + (uint32_t)k;
            if (octree_distance_empty(tree, child))
                continue;
            box3 cb = box_child(e.box, c, box_octant_upper_bits[k]);
            stats->nodes_visited++;
            double lb2 = box_distance2_below(q, octree_distance_bounds(tree, child, cb));
            if (tree->node_slabs && lb2 <= s->limit2) {
                double slab = octree_slab_point_distance2_below(&tree->node_slabs[child], q->local_point, q->grow) *
                              q->shrink2;
                lb2 = slab > lb2 ? slab : lb2;
            }
            if (lb2 > s->limit2)
                continue;
            /* Insertion by decreasing bound, so the nearest is pushed last, popped first. */
            int j = n++;
            while (j > 0 && near[j - 1].lb2 < lb2) {
                near[j] = near[j - 1];
                j--;
            }
            near[j] = (distance_entry){child, lb2, cb};
        }
        for (int j = 0; j < n; j++)
            stack[top++] = near[j];
    }
}

static octree_status point_distance(const octree *tree, const distance_query *q, double max_distance,
                                    distance_output *out, query_stats *caller)
{
    memset(out, 0, sizeof *out);
    if (!(max_distance >= 0))
        return OCTREE_ERR_INVALID;
    query_stats stats = {0};
    distance_search s;
    s.limit2 = max_distance == INFINITY ? INFINITY : iv_up(max_distance * max_distance);
    s.lower2 = INFINITY;
    s.found = 0;
    s.best = (point_triangle_distance){INFINITY, INFINITY, DISTANCE_FACE, 0, {0, 0, 0}};
    s.best_id = UINT32_MAX;
    memset(s.recent, 0xff, sizeof s.recent);
    if (tree->triangle_count > 0)
        walk(tree, q, &s, &stats);
    query_stats_finish(caller, &stats, 0, 0);
    if (!s.found)
        return OCTREE_OK;
    interval lower = iv_sqrt_nonnegative((interval){s.lower2, s.lower2});
    interval upper = iv_sqrt_nonnegative((interval){s.best.hi2, s.best.hi2});
    out->found = 1;
    out->lower = lower.lo;
    out->upper = upper.hi;
    out->point = s.best.point;
    iv_distance_report(vec3_length(vec3_sub(q->world_point, out->point)), out->lower, out->upper, &out->distance,
                       &out->bound);
    out->triangle = s.best_id;
    out->feature = s.best.feature;
    out->feature_index = s.best.index;
    return OCTREE_OK;
}

static void query_offsets(const octree *tree, distance_query *q)
{
    q->offset[0] = iv_diff(q->local_point.x, tree->world.lo.x);
    q->offset[1] = iv_diff(q->local_point.y, tree->world.lo.y);
    q->offset[2] = iv_diff(q->local_point.z, tree->world.lo.z);
}

octree_status octree_point_distance(const octree *tree, vec3 p, double max_distance, distance_output *out,
                                    query_stats *stats)
{
    if (!vec3_is_finite(p)) {
        memset(out, 0, sizeof *out);
        return OCTREE_ERR_NONFINITE;
    }
    distance_query q = {p, p, 0.0, 1.0, NULL, {{0, 0}, {0, 0}, {0, 0}}};
    query_offsets(tree, &q);
    return point_distance(tree, &q, max_distance, out, stats);
}

octree_status octree_point_distance_posed(const octree *tree, const pose *at, vec3 p, double max_distance,
                                          distance_output *out, query_stats *stats)
{
    memset(out, 0, sizeof *out);
    if (!vec3_is_finite(p))
        return OCTREE_ERR_NONFINITE;
    distance_query q = {p, p, 0.0, 1.0, at, {{0, 0}, {0, 0}, {0, 0}}};
    octree_status st = octree_posed_point_setup(tree, at, p, &q.local_point, &q.grow, &q.shrink2);
    if (st != OCTREE_OK)
        return st;
    query_offsets(tree, &q);
    return point_distance(tree, &q, max_distance, out, stats);
}
