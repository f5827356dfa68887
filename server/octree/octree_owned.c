/* Owned lists (with octree_def.node_slabs): each triangle owned by exactly one node, the
 * leaf or empty node whose cell holds its centroid, and per node the bounds of every
 * triangle owned in its subtree, whole. The distance walks read these in place of the leaf
 * lists.
 *
 * The seed's leaves list a triangle in every leaf it meets: 3.6 leaves a triangle on a
 * terrain, 4.2 in a small shape's tree. A shape walk meets a pair of triangles in every
 * pair of leaves that list them, about fifteen times, and a point walk meets a triangle
 * in each of its leaves. Owned once, a pair is met in one pair of nodes. The bounds are
 * of the whole triangles, so they reach past the cell by up to a triangle's size: a node
 * pair's lower bound holds for every pair of points its triangles have, which is all the
 * walks need. Which node owns a triangle changes only how tight the bounds are; the
 * centroid keeps each triangle with its neighbours. */
#include <stdlib.h>
#include <string.h>

#include "../geom/box_distance.h"
#include "octree_internal.h"

size_t octree_owned_bytes(size_t node_count, size_t triangle_count)
{
    return node_count * (sizeof(owned_span) + sizeof(box3)) + triangle_count * sizeof(uint32_t);
}

/* The node whose cell holds p: down from the root by the same split points every walk
 * uses, the upper half taken at the split itself, to the first node that is not interior. */
static uint32_t owner_of(const octree *tree, vec3 p)
{
    uint32_t node = 0;
    box3 cell = tree->world;
    while (tree->nodes[node].count == NODE_INTERIOR) {
        vec3 c = octree_split_point(tree, cell);
        unsigned upper = (p.x >= c.x ? 1u : 0u) | (p.y >= c.y ? 2u : 0u) | (p.z >= c.z ? 4u : 0u);
        cell = box_child(cell, c, upper);
        node = tree->nodes[node].first + box_octant_of_upper_bits[upper];
    }
    return node;
}

static const box3 no_bounds = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};

static box3 box_union(box3 a, box3 b)
{
    return (box3){vec3_min(a.lo, b.lo), vec3_max(a.hi, b.hi)};
}

/* Each node's count and bounds over its subtree, from its own triangles (not interior)
 * or its children's. */
static box3 gather(octree *tree, uint32_t node)
{
    octree_node n = tree->nodes[node];
    owned_span *span = &tree->owned[node];
    box3 b = no_bounds;
    if (n.count == NODE_INTERIOR) {
        uint32_t total = 0;
        for (int k = 0; k < 8; k++) {
            b = box_union(b, gather(tree, n.first + (uint32_t)k));
            total += tree->owned[n.first + (uint32_t)k].count;
        }
        span->count = total;
    } else {
        for (uint32_t i = 0; i < span->count; i++) {
            vec3 v[3];
            octree_triangle_vertices(tree, tree->owned_items[span->first + i], v);
            b = box_union(b, triangle_bounds(v));
        }
    }
    tree->owned_bounds[node] = b;
    return b;
}

octree_status octree_owned_build(octree *tree)
{
    size_t n = tree->triangle_count, nodes = tree->node_count;
    tree->owned = calloc(nodes, sizeof *tree->owned);
    tree->owned_items = malloc((n ? n : 1) * sizeof *tree->owned_items);
    tree->owned_bounds = malloc(nodes * sizeof *tree->owned_bounds);
    uint32_t *owner = malloc((n ? n : 1) * sizeof *owner);
    if (!tree->owned || !tree->owned_items || !tree->owned_bounds || !owner) {
        free(owner);
        return OCTREE_ERR_NOMEM;
    }
    for (size_t t = 0; t < n; t++) {
        vec3 v[3];
        octree_triangle_vertices(tree, (uint32_t)t, v);
        /* Rounded, the centroid may leave the triangle; any node would do. */
        vec3 c = {(v[0].x + v[1].x + v[2].x) / 3, (v[0].y + v[1].y + v[2].y) / 3, (v[0].z + v[1].z + v[2].z) / 3};
        owner[t] = owner_of(tree, c);
        tree->owned[owner[t]].count++;
    }
    /* A counting sort by owner: each node's triangles side by side, in id order (the
     * Morton order of their centroids). */
    uint32_t first = 0;
    for (size_t k = 0; k < nodes; k++) {
        tree->owned[k].first = first;
        first += tree->owned[k].count;
        tree->owned[k].count = 0;
    }
    for (size_t t = 0; t < n; t++) {
        owned_span *span = &tree->owned[owner[t]];
        tree->owned_items[span->first + span->count++] = (uint32_t)t;
    }
    free(owner);
    gather(tree, 0);
    return OCTREE_OK;
}
