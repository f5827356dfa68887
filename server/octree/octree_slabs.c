/* Node slabs (octree_def.node_slabs): per node a direction n, the sum of its triangles'
 * area normals, and the range [lo, hi] of n . x over their vertices, so that every point of
 * the node's triangles lies in the slab lo <= n . x <= hi. A distance walk bounds a node
 * by the slab as well as by its box: for a piece of a surface the slab is as thin as the
 * piece is flat, where the box is as thick as the cell, and a point facing a curved
 * surface (from inside a sphere, above a plain) sees most cells' boxes about as near as
 * the surface itself and their slabs much farther.
 *
 * The range is rounded outward: each n . x is computed within 3.01u |n|_1 M of the real
 * one (M the largest coordinate magnitude of the node's vertices), and lo and hi are
 * moved out by 4u |n|_1 M. A node whose normals cancel (a closed part of a surface, or
 * none) gets n = 0, which bounds nothing. */
#include <math.h>
#include <stdlib.h>

#include "octree_internal.h"

/* fmax is a call at -O2; these are not. */
static inline double larger(double a, double b)
{
    return a > b ? a : b;
}

static inline double max_abs(vec3 v)
{
    return larger(fabs(v.x), larger(fabs(v.y), fabs(v.z)));
}

/* The area normal sum over the node's subtree (interior nodes: their children's), each
 * triangle counted once a leaf it is listed in. */
static vec3 normals_of(const octree *tree, uint32_t node, vec3 *sums)
{
    octree_node n = tree->nodes[node];
    vec3 s = {0, 0, 0};
    if (n.count == NODE_INTERIOR) {
        for (int k = 0; k < 8; k++)
            s = vec3_add(s, normals_of(tree, n.first + (uint32_t)k, sums));
    } else {
        for (uint32_t i = 0; i < n.count; i++) {
            vec3 v[3];
            octree_triangle_vertices(tree, tree->leaf_items[n.first + i], v);
            s = vec3_add(s, vec3_cross(vec3_sub(v[1], v[0]), vec3_sub(v[2], v[0])));
        }
    }
    sums[node] = s;
    return s;
}

typedef struct slab_range {
    double lo, hi, magnitude;
} slab_range;

/* The range of n . x over the vertices of the triangles under node. */
static void range_under(const octree *tree, uint32_t node, vec3 n, slab_range *r)
{
    octree_node nd = tree->nodes[node];
    if (nd.count == NODE_INTERIOR) {
        for (int k = 0; k < 8; k++)
            range_under(tree, nd.first + (uint32_t)k, n, r);
        return;
    }
    for (uint32_t i = 0; i < nd.count; i++) {
        vec3 v[3];
        octree_triangle_vertices(tree, tree->leaf_items[nd.first + i], v);
        for (int k = 0; k < 3; k++) {
            double d = n.x * v[k].x + n.y * v[k].y + n.z * v[k].z;
            r->lo = d < r->lo ? d : r->lo;
            r->hi = d > r->hi ? d : r->hi;
            double m = max_abs(v[k]);
            r->magnitude = m > r->magnitude ? m : r->magnitude;
        }
    }
}

octree_status octree_slabs_build(octree *tree)
{
    tree->node_slabs = malloc(tree->node_count * sizeof *tree->node_slabs);
    vec3 *sums = malloc(tree->node_count * sizeof *sums);
    if (!tree->node_slabs || !sums) {
        free(sums);
        return OCTREE_ERR_NOMEM;
    }
    for (size_t i = 0; i < tree->node_count; i++)
        sums[i] = (vec3){0, 0, 0};
    normals_of(tree, 0, sums);
    for (size_t i = 0; i < tree->node_count; i++) {
        node_slab *slab = &tree->node_slabs[i];
        *slab = (node_slab){{0, 0, 0}, 0, 0};
        vec3 n = sums[i];
        double len = vec3_length(n);
        if (tree->nodes[i].count == 0 || !(len > 0) || !(len < INFINITY))
            continue;
        /* Unit length, so that a query need not divide; its rounding is any direction's. */
        n = vec3_scale(n, 1.0 / len);
        slab_range r = {INFINITY, -INFINITY, 0};
        range_under(tree, (uint32_t)i, n, &r);
        double norm1 = fabs(n.x) + fabs(n.y) + fabs(n.z);
        double out = 4 * 0x1p-53 * norm1 * r.magnitude * (1 + 0x1p-40) + 0x1p-1060;
        /* A slab as thick as the node's cube bounds nothing the box does not: kept all
         * the same, the walk's test is cheaper than the check. */
        *slab = (node_slab){{n.x, n.y, n.z}, r.lo - out, r.hi + out};
        if (!(slab->lo <= slab->hi) || !(slab->hi - slab->lo < INFINITY))
            *slab = (node_slab){{0, 0, 0}, 0, 0};
    }
    free(sums);
    return OCTREE_OK;
}

double octree_slab_point_distance2_below(const node_slab *slab, vec3 p, double grow)
{
    /* n . p within 3.01u |n|_1 |p|_max of the real one; the gap's subtraction and the
     * square within 3u more of themselves. */
    double d = slab->n[0] * p.x + slab->n[1] * p.y + slab->n[2] * p.z;
    double gap = slab->lo - d > d - slab->hi ? slab->lo - d : d - slab->hi;
    if (!(gap > 0))
        return 0.0;
    double norm1 = fabs(slab->n[0]) + fabs(slab->n[1]) + fabs(slab->n[2]);
    double m = max_abs(p);
    /* grow: points within it of the triangles' (max norm) move n . x by |n|_1 grow. */
    gap -= 4 * 0x1p-53 * norm1 * m + 0x1p-52 * gap + norm1 * grow * (1 + 0x1p-50);
    if (!(gap > 0))
        return 0.0;
    /* |n| is 1 to within 3u: 2^-48 of the square covers it and the roundings. */
    return gap * gap * (1 - 0x1p-48);
}

double octree_slab_box_distance2_below(const node_slab *slab, box3 b)
{
    double c[3] = {0.5 * b.lo.x + 0.5 * b.hi.x, 0.5 * b.lo.y + 0.5 * b.hi.y, 0.5 * b.lo.z + 0.5 * b.hi.z};
    double h[3] = {0.5 * b.hi.x - 0.5 * b.lo.x, 0.5 * b.hi.y - 0.5 * b.lo.y, 0.5 * b.hi.z - 0.5 * b.lo.z};
    double d = slab->n[0] * c[0] + slab->n[1] * c[1] + slab->n[2] * c[2];
    double r = fabs(slab->n[0]) * h[0] + fabs(slab->n[1]) * h[1] + fabs(slab->n[2]) * h[2];
    double gap = slab->lo - (d + r) > (d - r) - slab->hi ? slab->lo - (d + r) : (d - r) - slab->hi;
    if (!(gap > 0) || !(gap < INFINITY))
        return 0.0;
    /* The box's projection [d - r, d + r] holds the real one's to within the roundings of
     * c, h and the two sums of products: 8u of |n|_1 (|c| + |h|) covers them. */
    double norm1 = fabs(slab->n[0]) + fabs(slab->n[1]) + fabs(slab->n[2]);
    double m = larger(max_abs(b.lo), max_abs(b.hi));
    gap -= 8 * 0x1p-53 * norm1 * 2 * m + 0x1p-52 * gap + 0x1p-1060;
    if (!(gap > 0))
        return 0.0;
    return gap * gap * (1 - 0x1p-48);
}
