/* Node slabs (octree_def.node_slabs): per node a direction n, the sum of the area normals
 * of the triangles its subtree owns (octree_owned.c), and the range [lo, hi] of n . x over
 * their vertices, so that every point of those triangles lies in the slab
 * lo <= n . x <= hi. A distance walk bounds a node by the slab as well as by its box: for
 * a piece of a surface the slab is as thin as the piece is flat, where the box is as thick
 * as the piece is wide, and a point facing a curved
 * surface (from inside a sphere, above a plain) sees most cells' boxes about as near as
 * the surface itself and their slabs much farther.
 *
 * The range is rounded outward: each n . x is computed within 3.01u |n|_1 M of the real
 * one (M the largest coordinate magnitude of the node's vertices), and lo and hi are
 * moved out by 4u |n|_1 M. A node whose normals cancel (a closed part of a surface, or
 * none) gets n = 0, which bounds nothing. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

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

/* The area normal sum over the triangles the node's subtree owns (interior nodes: their
 * children's). */
static vec3 normals_of(const octree *tree, uint32_t node, vec3 *sums)
{
    octree_node n = tree->nodes[node];
    vec3 s = {0, 0, 0};
    if (n.count == NODE_INTERIOR) {
        for (int k = 0; k < 8; k++)
            s = vec3_add(s, normals_of(tree, n.first + (uint32_t)k, sums));
    } else {
        owned_span own = tree->owned[node];
        for (uint32_t i = 0; i < own.count; i++) {
            vec3 v[3];
            octree_triangle_vertices(tree, tree->owned_items[own.first + i], v);
            s = vec3_add(s, vec3_cross(vec3_sub(v[1], v[0]), vec3_sub(v[2], v[0])));
        }
    }
    sums[node] = s;
    return s;
}

void octree_slab_frame(const double n[3], double u[3], double v[3])
{
    double ax = fabs(n[0]), ay = fabs(n[1]), az = fabs(n[2]);
    /* a x n for a the axis least along n: never near parallel to n. */
    double c[3];
    if (ax <= ay && ax <= az)
        c[0] = 0, c[1] = -n[2], c[2] = n[1]; /* (1, 0, 0) x n */
    else if (ay <= az)
        c[0] = n[2], c[1] = 0, c[2] = -n[0]; /* (0, 1, 0) x n */
    else
        c[0] = -n[1], c[1] = n[0], c[2] = 0; /* (0, 0, 1) x n */
    double len = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    for (int k = 0; k < 3; k++)
        u[k] = c[k] / len;
    v[0] = n[1] * u[2] - n[2] * u[1];
    v[1] = n[2] * u[0] - n[0] * u[2];
    v[2] = n[0] * u[1] - n[1] * u[0];
}

typedef struct slab_range {
    double lo[3], hi[3], magnitude;
} slab_range;

static inline double dot3(const double a[3], vec3 x)
{
    return a[0] * x.x + a[1] * x.y + a[2] * x.z;
}

/* The ranges of n . x, u . x and v . x over the vertices of the triangles the node's
 * subtree owns. */
static void range_under(const octree *tree, uint32_t node, const double axes[3][3], slab_range *r)
{
    octree_node nd = tree->nodes[node];
    if (nd.count == NODE_INTERIOR) {
        for (int k = 0; k < 8; k++)
            range_under(tree, nd.first + (uint32_t)k, axes, r);
        return;
    }
    owned_span own = tree->owned[node];
    for (uint32_t i = 0; i < own.count; i++) {
        vec3 v[3];
        octree_triangle_vertices(tree, tree->owned_items[own.first + i], v);
        for (int k = 0; k < 3; k++) {
            for (int a = 0; a < 3; a++) {
                double d = dot3(axes[a], v[k]);
                r->lo[a] = d < r->lo[a] ? d : r->lo[a];
                r->hi[a] = d > r->hi[a] ? d : r->hi[a];
            }
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
    const node_slab none = {{0, 0, 0}, 0, 0, {{0, 0}, {0, 0}}};
    for (size_t i = 0; i < tree->node_count; i++) {
        node_slab *slab = &tree->node_slabs[i];
        *slab = none;
        vec3 n = sums[i];
        double len = vec3_length(n);
        if (tree->owned[i].count == 0 || !(len > 0) || !(len < INFINITY))
            continue;
        double axes[3][3] = {{n.x / len, n.y / len, n.z / len}};
        octree_slab_frame(axes[0], axes[1], axes[2]);
        slab_range r = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}, 0};
        range_under(tree, (uint32_t)i, axes, &r);
        double out[3];
        for (int a = 0; a < 3; a++) {
            double norm1 = fabs(axes[a][0]) + fabs(axes[a][1]) + fabs(axes[a][2]);
            out[a] = 4 * 0x1p-53 * norm1 * r.magnitude * (1 + 0x1p-40) + 0x1p-1060;
        }
        *slab = (node_slab){{axes[0][0], axes[0][1], axes[0][2]},
                            r.lo[0] - out[0],
                            r.hi[0] + out[0],
                            {{r.lo[1] - out[1], r.hi[1] + out[1]}, {r.lo[2] - out[2], r.hi[2] + out[2]}}};
        if (!(slab->lo <= slab->hi) || !(slab->hi - slab->lo < INFINITY))
            *slab = none;
    }
    free(sums);
    return OCTREE_OK;
}

/* The gap of d from [lo, hi], less err, or 0. */
static inline double range_gap(double d, double lo, double hi, double err)
{
    double gap = lo - d > d - hi ? lo - d : d - hi;
    gap -= err + 0x1p-52 * (gap > 0 ? gap : 0);
    return gap > 0 ? gap : 0.0;
}

double octree_slab_point_distance2_below(const node_slab *slab, vec3 p, double grow)
{
    if (slab->n[0] == 0 && slab->n[1] == 0 && slab->n[2] == 0)
        return 0.0;
    double u[3], v[3];
    octree_slab_frame(slab->n, u, v);
    const double *axes[3] = {slab->n, u, v};
    const double lo[3] = {slab->lo, slab->range[0][0], slab->range[1][0]};
    const double hi[3] = {slab->hi, slab->range[0][1], slab->range[1][1]};
    double m = max_abs(p), sum = 0;
    for (int a = 0; a < 3; a++) {
        /* axis . p within 3.01u |axis|_1 |p|_max of the real one; grow: points within it
         * of the triangles' (max norm) move axis . x by |axis|_1 grow. */
        double norm1 = fabs(axes[a][0]) + fabs(axes[a][1]) + fabs(axes[a][2]);
        double g = range_gap(dot3(axes[a], p), lo[a], hi[a], 4 * 0x1p-53 * norm1 * m + norm1 * grow * (1 + 0x1p-50));
        sum += g * g;
    }
    /* The frame is orthonormal to within some u, so |B y|^2 <= (1 + 2^-40) |y|^2 for the
     * matrix B of its rows: the gaps' squares sum to at most that much more than the
     * distance's square; 2^-40 more covers the sum's own roundings. */
    return sum * (1 - 0x1p-39);
}

oriented_box octree_slab_box(const node_slab *slab)
{
    oriented_box o = {{{slab->n[0], slab->n[1], slab->n[2]}},
                      {slab->lo, slab->range[0][0], slab->range[1][0]},
                      {slab->hi, slab->range[0][1], slab->range[1][1]},
                      0x1p-40};
    octree_slab_frame(slab->n, o.axes[1], o.axes[2]);
    return o;
}

/* The gap between the box's projection on axis x, [d - r, d + r], and [lo, hi], less what
 * the projection's roundings may hide (8u of |x|_1 (|c| + |h|)), or 0. */
static inline double axis_box_gap(const double x[3], double lo, double hi, const double c[3], const double h[3],
                                  double m)
{
    double d = x[0] * c[0] + x[1] * c[1] + x[2] * c[2];
    double r = fabs(x[0]) * h[0] + fabs(x[1]) * h[1] + fabs(x[2]) * h[2];
    double norm1 = fabs(x[0]) + fabs(x[1]) + fabs(x[2]);
    double err = 8 * 0x1p-53 * norm1 * 2 * m + 0x1p-1060;
    double gap = lo - (d + r) > (d - r) - hi ? lo - (d + r) : (d - r) - hi;
    if (!(gap < INFINITY))
        return 0.0;
    gap -= err + 0x1p-52 * (gap > 0 ? gap : 0);
    return gap > 0 ? gap : 0.0;
}

double octree_slab_normal_box_distance2_below(const node_slab *slab, box3 b)
{
    double c[3] = {0.5 * b.lo.x + 0.5 * b.hi.x, 0.5 * b.lo.y + 0.5 * b.hi.y, 0.5 * b.lo.z + 0.5 * b.hi.z};
    double h[3] = {0.5 * b.hi.x - 0.5 * b.lo.x, 0.5 * b.hi.y - 0.5 * b.lo.y, 0.5 * b.hi.z - 0.5 * b.lo.z};
    double g = axis_box_gap(slab->n, slab->lo, slab->hi, c, h, larger(max_abs(b.lo), max_abs(b.hi)));
    /* n is of unit length to within 2^-40 (it was divided by its rounded length); 2^-48
     * covers the square's rounding. */
    return g * g * (1 - 0x1p-48) / ((1 + 0x1p-40) * (1 + 0x1p-40));
}

double octree_oriented_box_distance2_below(const oriented_box *o, box3 b)
{
    double c[3] = {0.5 * b.lo.x + 0.5 * b.hi.x, 0.5 * b.lo.y + 0.5 * b.hi.y, 0.5 * b.lo.z + 0.5 * b.hi.z};
    double h[3] = {0.5 * b.hi.x - 0.5 * b.lo.x, 0.5 * b.hi.y - 0.5 * b.lo.y, 0.5 * b.hi.z - 0.5 * b.lo.z};
    double m = larger(max_abs(b.lo), max_abs(b.hi)), sum = 0;
    /* In the oriented box's frame, every difference x - y of its points and the box's lies
     * in the box of the ranges less the box's projections [d - r, d + r] along each axis:
     * the distance from 0 to that box, the root of the gaps' squares summed, bounds the
     * distance between the two. The projection holds the real one's to within the
     * roundings of c, h and the sums of products: 8u of |axis|_1 (|c| + |h|) covers
     * them. */
    for (int a = 0; a < 3; a++) {
        const double *x = o->axes[a];
        double d = x[0] * c[0] + x[1] * c[1] + x[2] * c[2];
        double r = fabs(x[0]) * h[0] + fabs(x[1]) * h[1] + fabs(x[2]) * h[2];
        double norm1 = fabs(x[0]) + fabs(x[1]) + fabs(x[2]);
        double err = 8 * 0x1p-53 * norm1 * 2 * m + 0x1p-1060;
        double gap = o->lo[a] - (d + r) > (d - r) - o->hi[a] ? o->lo[a] - (d + r) : (d - r) - o->hi[a];
        if (!(gap < INFINITY))
            continue;
        gap -= err + 0x1p-52 * (gap > 0 ? gap : 0);
        if (gap > 0)
            sum += gap * gap;
    }
    /* The frame is orthonormal to within `stretch` (|B y| <= (1 + stretch) |y| for the
     * matrix B of its rows, stretch at least 2^-40 for the frame's own rounding); 2^-48
     * covers the sum's roundings. */
    return sum * (1 - 0x1p-48) / ((1 + o->stretch) * (1 + o->stretch));
}
