/* The octree's private layout, shared by the build and the query files. */
#ifndef TRIOCT_OCTREE_INTERNAL_H
#define TRIOCT_OCTREE_INTERNAL_H

#include <stdint.h>

#include "../engine.h"
#include "../geom/vec3.h"

/* count == NODE_INTERIOR marks an interior node whose eight children, in the seed's octant
 * order, are nodes first .. first + 7. Otherwise the node is a leaf whose triangles are
 * leaf_items[first .. first + count). Eight bytes a node: the box is derived on the way
 * down from the world cube and the octant numbers. */
#define NODE_INTERIOR UINT32_MAX

typedef struct octree_node {
    uint32_t first;
    uint32_t count;
} octree_node;

struct octree {
    /* Each triangle's three vertices side by side: a candidate test touches one place in
     * memory instead of an index triple and three scattered vertices. */
    vec3 (*triangles)[3];
    size_t triangle_count;
    /* Triangles are stored, listed in leaves and tested under internal ids that follow a
     * Morton order of their centroids, so that a node's list, a leaf's candidates and
     * their vertices sit close together in memory. original_id maps an internal id back to
     * the caller's, which is what every answer reports and every tie is broken by. */
    uint32_t *original_id;

    octree_node *nodes;
    size_t node_count;
    uint32_t *leaf_items;
    size_t leaf_item_count;

    box3 world; /* the cube [lo, lo + D] */
    double seed_epsilon;
    octree_info info;
};

static inline const vec3 *octree_triangle_at(const struct octree *tree, uint32_t id)
{
    return tree->triangles[id];
}

static inline void octree_triangle_vertices(const struct octree *tree, uint32_t id, vec3 out[3])
{
    const vec3 *t = tree->triangles[id];
    out[0] = t[0];
    out[1] = t[1];
    out[2] = t[2];
}

/* Adds one query's counters to the caller's (when given), with the exact fallbacks this
 * thread ran since fallbacks_before. */
static inline void query_stats_finish(query_stats *caller, query_stats *local, uint64_t fallbacks_before,
                                      uint64_t fallbacks_now)
{
    local->exact_fallbacks = fallbacks_now - fallbacks_before;
    if (!caller)
        return;
    caller->nodes_visited += local->nodes_visited;
    caller->leaves_visited += local->leaves_visited;
    caller->candidates_tested += local->candidates_tested;
    caller->exact_fallbacks += local->exact_fallbacks;
}

/* Answers a batch of rays as octree_ray answers each, with several rays' traversals in
 * flight at once so that one ray's memory latency hides behind the others' work. */
octree_status octree_ray_stream(const struct octree *tree, const ray_input *rays, size_t count, ray_detail detail,
                                accuracy_mode mode, ray_output *outs, octree_status *statuses,
                                query_stats *stats);

/* Deepest traversal stack a query needs: 7 siblings waiting per level plus the node. */
#define OCTREE_STACK_MAX (8 * (OCTREE_MAX_DEPTH_CAP + 1) + 1)

#endif
