/* The octree's private layout, shared by the build and the query files. */
#ifndef TRIOCT_OCTREE_INTERNAL_H
#define TRIOCT_OCTREE_INTERNAL_H

#include <float.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "../../common/array_reserve.h"
#include "../engine.h"
#include "../geom/box_geometry.h"
#include "../geom/vec3.h"
#include "octree_traversal.h"

/* count == NODE_INTERIOR marks an interior node whose eight children, in the seed's octant
 * order, are nodes first .. first + 7. Otherwise the node is a leaf whose triangles are
 * leaf_items[first .. first + count). Eight bytes a node: the box is derived on the way
 * down from the world cube and the octant numbers. */
#define NODE_INTERIOR UINT32_MAX

typedef struct octree_node {
    uint32_t first;
    uint32_t count;
} octree_node;

/* A block of eight sibling nodes' bounds (octree.child_lanes): per axis the centres
 * 0.5 (lo + hi) and half sides 0.5 (hi - lo), computed as the lane tests compute them from
 * the boxes, so the values are the same; live has bit k set when child k holds triangles. */
typedef struct child_lanes {
    double c[3][8], h[3][8];
    unsigned live;
} child_lanes;

/* The lanes of the children of b from their boxes and counts. */
static inline void child_lanes_of(const box3 b[8], const octree_node kids[8], child_lanes *out)
{
    out->live = 0;
    for (int k = 0; k < 8; k++) {
        const double lo[3] = {b[k].lo.x, b[k].lo.y, b[k].lo.z}, hi[3] = {b[k].hi.x, b[k].hi.y, b[k].hi.z};
        for (int a = 0; a < 3; a++) {
            out->c[a][k] = 0.5 * (lo[a] + hi[a]);
            out->h[a][k] = 0.5 * (hi[a] - lo[a]);
        }
        out->live |= (unsigned)(kids[k].count != 0) << k;
    }
}

/* A triangle's axis-aligned box as offsets from the world's lower corner, in floats
 * rounded outward: corner + lo <= every vertex <= corner + hi holds exactly, so a box
 * strictly disjoint from a query's proves the triangle misses the query. Offsets rather
 * than coordinates because a float's step at a georeferenced 5e6 or a 1e9 offset is
 * metres, which would make every box overlap every query; within the world cube the step
 * is the cube's side times 2^-24. */
typedef struct triangle_box {
    float lo[3], hi[3];
} triangle_box;
_Static_assert(sizeof(triangle_box) == 24, "engine.h documents 24 bytes a triangle");

/* A node's slab (octree_slabs.c): every point of its triangles has lo <= n . x <= hi, n a
 * unit direction, and likewise along the two directions u, v that make an orthonormal
 * frame with n (octree_slab_frame, computed from n alone): an oriented box, as thin along
 * n as the node's surface is flat. n = 0 bounds nothing. */
typedef struct node_slab {
    double n[3];
    double lo, hi;
    double range[2][2]; /* [u, v][lo, hi] */
} node_slab;

/* A node's share of the owned lists (octree_owned.c). */
typedef struct owned_span {
    uint32_t first; /* into owned_items, for a node that is not interior */
    uint32_t count; /* owned by the node, or within an interior node's subtree */
} owned_span;

_Static_assert(sizeof(node_slab) + sizeof(owned_span) + sizeof(box3) == 128,
               "engine.h documents 128 bytes a node with node_slabs");

/* An oriented box: lo[a] <= axes[a] . x <= hi[a] for the three axes (each of length 1 to
 * within `stretch`: |axes[a]| <= 1 + stretch). A node slab in its own frame, or taken
 * into another (a posed shape's). */
typedef struct oriented_box {
    double axes[3][3];
    double lo[3], hi[3];
    double stretch;
} oriented_box;

/* A node slab as an oriented box (its frame from octree_slab_frame). */
oriented_box octree_slab_box(const node_slab *slab);
/* A lower bound of the squared distance between an oriented box and a closed box: in the
 * oriented box's frame, the gaps between its ranges and the box's projections, squared
 * and summed (the distance from 0 to a box holding every difference of their points); 0
 * when they overlap along every axis. */
double octree_oriented_box_distance2_below(const oriented_box *o, box3 b);

/* The frame's other two directions, u = normalised (a x n) for the axis a least along n,
 * and v = n x u: the same doubles at build and query. */
void octree_slab_frame(const double n[3], double u[3], double v[3]);

struct octree {
    /* The account the build took from (octree_def.account) and what this tree holds of it:
     * given back by octree_free. */
    memory_account *account;
    size_t accounted;
    /* While the seed's build runs, each triangle's three vertices side by side (its
     * membership tests read them in turn); freed once the nodes are built. */
    vec3 (*triangles)[3];
    /* What queries read: the vertices the triangles use, once each, in the order the
     * triangles first use them (so neighbours' vertices sit together), and per triangle
     * its three corners' indices. A vertex is shared by about six triangles: 24 bytes a
     * vertex and 12 a triangle instead of 72 a triangle. */
    vec3 *vertices;
    size_t used_vertex_count;
    uint32_t (*corners)[3];
    size_t triangle_count;
    /* Triangles are stored, listed in leaves and tested under internal ids that follow a
     * Morton order of their centroids, so that a node's list, a leaf's candidates and
     * their vertices sit close together in memory. original_id maps an internal id back to
     * the caller's, which is what every answer reports and every tie is broken by. */
    uint32_t *original_id;
    /* Per internal id when the tree was built with triangle_boxes, else NULL. */
    triangle_box *triangle_boxes;
    /* Per node when the tree was built with node_bounds, else NULL: the exact bounds of the
     * node's triangles within its box (inverted for an empty node). A query shape's tree
     * has them, so that a node pair whose posed shape bounds miss the world node is
     * dropped before its box would be (octree_shape.c). Indexed like nodes. */
    box3 *node_bounds;
    /* With node_bounds, per block of eight children (block b holds nodes 8b .. 8b + 7):
     * their bounds' centres and half sides side by side, as a shape expansion's lanes read
     * them, and which of them hold anything. */
    struct child_lanes *child_lanes;
    /* Per node when the tree was built with node_slabs, else NULL; over the owned lists
     * below. */
    node_slab *node_slabs;
    /* With node_slabs, the owned lists the distance walks take in place of the leaf lists
     * (octree_owned.c): each triangle owned by one node, per node the span of owned_items
     * it owns (a leaf or empty node) or the number owned in its subtree (an interior
     * node), and the bounds of every triangle owned in its subtree, whole. */
    owned_span *owned;
    uint32_t *owned_items;
    box3 *owned_bounds;

    octree_node *nodes;
    size_t node_count;
    /* The leaves' lists (info.leaf_refs ids), then the sliver list (sliver_list_count ids). */
    uint32_t *leaf_items;
    /* What fast and seed queries need beyond exact membership (octree_modes.c): the seed
     * reach factor, the largest 2 / sin of a triangle's smallest angle (rounded up); and
     * k with 2^k at or below the smallest nonzero product of the max norms of a triangle's
     * edges v1 - v0 and v2 - v0 (INT_MAX when there is none). */
    float seed_reach_factor;
    int fast_edge_product_log2;

    box3 world; /* the cube [lo, lo + D] */
    /* Every coordinate of the world within DBL_MAX / 2: no node's lo + hi overflows, so a
     * split is box_split_in_range. */
    short splits_in_range;
    /* e with 2^e at or above the longest edge of any triangle in max norm (fast triangle
     * queries' coplanar reach, octree_modes.c); FAST_NO_EDGE_LOG2 when every edge is
     * zero, FAST_HUGE_EDGE_LOG2 when one overflowed. The two shorts share the four
     * bytes the flag's int had, so the tree's size (which the daemon reports) is kept. */
    short fast_longest_edge_log2;
    /* The slivers (zero area, or the smallest angle's sine below 2^-10), which the seed
     * tests may accept anywhere, and the fast test may accept anywhere against another
     * sliver: every seed query and every fast sliver query tests them. Internal ids,
     * after the leaf lists in leaf_items. */
    uint32_t sliver_list_count;
    double seed_epsilon;
    /* The compiled form rays walk (octree_traversal.h); empty when the world is outside
     * its range, and then every ray takes the double-precision walk over nodes. */
    traversal_form traversal;
    octree_info info;
};

/* Bits set in an eight-bit mask. __builtin_popcount is a libgcc call where the baseline
 * target has no popcount instruction, which cost a ray's filter more than this. */
static inline unsigned bits_set8(unsigned m)
{
    m = (m & 0x55u) + (m >> 1 & 0x55u);
    m = (m & 0x33u) + (m >> 2 & 0x33u);
    return (m & 0x0fu) + (m >> 4);
}

static inline const uint32_t *octree_sliver_list(const struct octree *tree)
{
    return tree->leaf_items + tree->info.leaf_refs;
}

/* A node's split point, as box_split_point computes it, without its overflow checks when
 * no node of the tree can need them. */
static inline vec3 octree_split_point(const struct octree *tree, box3 box)
{
    if (tree->splits_in_range)
        return (vec3){box_split_in_range(box.lo.x, box.hi.x), box_split_in_range(box.lo.y, box.hi.y),
                      box_split_in_range(box.lo.z, box.hi.z)};
    return box_split_point(box);
}

/* A built tree's triangle id's three vertices (the same doubles the caller gave). */
static inline void octree_triangle_vertices(const struct octree *tree, uint32_t id, vec3 out[3])
{
    const uint32_t *c = tree->corners[id];
    out[0] = tree->vertices[c[0]];
    out[1] = tree->vertices[c[1]];
    out[2] = tree->vertices[c[2]];
}

/* The leaf a compiled form's leaf reference names (octree_traversal.h): its list's first
 * index and length, from the reference itself or from its node. */
static inline octree_node octree_leaf_of_ref(const struct octree *tree, uint32_t ref)
{
    if (ref & TRAVERSAL_SPAN)
        return (octree_node){ref & TRAVERSAL_SPAN_FIRST_LIMIT,
                             ((ref >> TRAVERSAL_SPAN_COUNT_SHIFT) & (TRAVERSAL_SPAN_COUNT_MAX - 1)) + 1};
    return tree->nodes[ref & ~TRAVERSAL_LEAF];
}

/* The next float above (below) a finite f, as nextafterf gives it, from its bits: a libm
 * call cost a ray's setup more than its arithmetic. */
static inline float float_next_up(float f)
{
    if (f == 0.0f)
        return FLT_TRUE_MIN;
    uint32_t b;
    memcpy(&b, &f, sizeof b);
    b = f > 0.0f ? b + 1 : b - 1;
    memcpy(&f, &b, sizeof f);
    return f;
}

static inline float float_next_down(float f)
{
    return -float_next_up(-f);
}

/* The largest float <= x, and the smallest float >= x; past the float range they give
 * the nearest float on the safe side or an infinity. The explicit range checks keep the
 * conversion defined (C leaves an out-of-range double-to-float conversion undefined). */
static inline float float_at_or_below(double x)
{
    if (!(x >= -FLT_MAX))
        return -INFINITY;
    if (x > FLT_MAX)
        return FLT_MAX;
    float f = (float)x;
    return (double)f > x ? float_next_down(f) : f;
}

static inline float float_at_or_above(double x)
{
    if (!(x <= FLT_MAX))
        return INFINITY;
    if (x < -FLT_MAX)
        return -FLT_MAX;
    float f = (float)x;
    return (double)f < x ? float_next_up(f) : f;
}

/* A float at or below y, without a branch on how y rounded: y is lowered by more than a
 * float's half ulp (2^-23 of itself, and 2^-148 for the subnormal range, where a step is
 * 2^-149) before rounding to nearest, which then cannot land above y (the lowering's own
 * two roundings are 2^-53 of it). Past 2^100 the bound is 2^100 or -INFINITY. A filter's box
 * is a float step or two looser so; float_at_or_below gives the tight one. */
static inline float float_below_loosely(double y)
{
    if (!(y >= -0x1p100))
        return -INFINITY;
    if (y > 0x1p100)
        return 0x1p100f;
    return (float)(y - (fabs(y) * 0x1p-23 + 0x1p-148));
}

static inline float float_above_loosely(double y)
{
    return -float_below_loosely(-y);
}

/* Bounds in float of the real difference x - o, which the double subtraction may round
 * either way. The rounding error is recovered exactly (Knuth's two-sum; it needs each
 * operation rounded on its own, which -ffp-contract=off guarantees), and only a float
 * equal to the rounded difference can lie on the wrong side of the real one: any other
 * float below (above) the rounded difference is at most its predecessor (successor),
 * which the real difference cannot pass. An infinite difference gives a NaN error, which
 * no comparison accepts, and the float bounds above handle it. */
static inline double rounding_error_of_difference(double x, double o, double d)
{
    double back = d - x;
    return (x - (d - back)) + (-o - back);
}

static inline float float_below_difference(double x, double o)
{
    double d = x - o;
    float f = float_at_or_below(d);
    return (double)f == d && rounding_error_of_difference(x, o, d) < 0 ? float_next_down(f) : f;
}

static inline float float_above_difference(double x, double o)
{
    double d = x - o;
    float f = float_at_or_above(d);
    return (double)f == d && rounding_error_of_difference(x, o, d) > 0 ? float_next_up(f) : f;
}

/* Both float bounds of the real difference x - o at once, as float_below_difference and
 * float_above_difference give them: one subtraction, one conversion, and the rounding
 * error only when the conversion was exact. */
static inline __attribute__((always_inline)) void float_bounds_of_difference(double x, double o, float *below, float *above)
{
    double d = x - o;
    if (!(d >= -FLT_MAX && d <= FLT_MAX)) {
        *below = float_below_difference(x, o);
        *above = float_above_difference(x, o);
        return;
    }
    float f = (float)d;
    if ((double)f == d) {
        double err = rounding_error_of_difference(x, o, d);
        *below = err < 0 ? float_next_down(f) : f;
        *above = err > 0 ? float_next_up(f) : f;
    } else if ((double)f > d) {
        *below = float_next_down(f);
        *above = f;
    } else {
        *below = f;
        *above = float_next_up(f);
    }
}

/* The outward float box of the closed box [lo, hi] relative to origin. */
static inline triangle_box triangle_box_around(vec3 lo, vec3 hi, vec3 origin)
{
    return (triangle_box){{float_below_difference(lo.x, origin.x), float_below_difference(lo.y, origin.y),
                           float_below_difference(lo.z, origin.z)},
                          {float_above_difference(hi.x, origin.x), float_above_difference(hi.y, origin.y),
                           float_above_difference(hi.z, origin.z)}};
}

/* The outward float box of the point p relative to origin: each difference rounded once,
 * both bounds from it (float_bounds_of_difference). */
static inline triangle_box triangle_box_of_point(vec3 p, vec3 origin)
{
    triangle_box b;
    float_bounds_of_difference(p.x, origin.x, &b.lo[0], &b.hi[0]);
    float_bounds_of_difference(p.y, origin.y, &b.lo[1], &b.hi[1]);
    float_bounds_of_difference(p.z, origin.z, &b.lo[2], &b.hi[2]);
    return b;
}

/* Grows *into to hold b as well (the union of two outward boxes is outward). */
static inline void triangle_box_add(triangle_box *into, const triangle_box *b)
{
    for (int k = 0; k < 3; k++) {
        into->lo[k] = b->lo[k] < into->lo[k] ? b->lo[k] : into->lo[k];
        into->hi[k] = b->hi[k] > into->hi[k] ? b->hi[k] : into->hi[k];
    }
}

/* 1 when two outward boxes are strictly apart along some axis, so the closed sets they
 * hold cannot share a point. Boxes that touch are not apart: triangles meeting exactly on
 * a box face touch. */
static inline int triangle_boxes_apart(const triangle_box *a, const triangle_box *b)
{
    return (a->lo[0] > b->hi[0]) | (a->lo[1] > b->hi[1]) | (a->lo[2] > b->hi[2]) | (a->hi[0] < b->lo[0]) |
           (a->hi[1] < b->lo[1]) | (a->hi[2] < b->lo[2]);
}

/* triangle_boxes_apart(a, b) for one b and many a: b's bounds laid out once, so that each
 * test is two four-lane comparisons. The leaf loops of mesh queries run it for every pair
 * of a world triangle and a shape box, where six scalar comparisons and their branches
 * were the largest single line of a collision-free pose. */
#if defined(__SSE2__)
#include <emmintrin.h>

typedef struct triangle_box_probe {
    __m128 hi; /* b->hi[0..2], +inf */
    __m128 lo; /* -inf, b->lo[0..2] */
} triangle_box_probe;

static inline triangle_box_probe triangle_box_probe_of(const triangle_box *b)
{
    return (triangle_box_probe){_mm_setr_ps(b->hi[0], b->hi[1], b->hi[2], INFINITY),
                                _mm_setr_ps(-INFINITY, b->lo[0], b->lo[1], b->lo[2])};
}

/* Lanes 0-2 compare a->lo with b->hi, lanes 1-3 a->hi with b->lo; the other lane of each
 * compares with an infinity and is false, as every comparison with a NaN is, so the answer
 * is triangle_boxes_apart's. Both loads stay within *a. */
static inline int triangle_box_probe_apart(const triangle_box *a, const triangle_box_probe *p)
{
    __m128 lows = _mm_loadu_ps(a->lo), highs = _mm_loadu_ps(a->lo + 2);
    return _mm_movemask_ps(_mm_or_ps(_mm_cmpgt_ps(lows, p->hi), _mm_cmplt_ps(highs, p->lo))) != 0;
}
#else
typedef struct triangle_box_probe {
    triangle_box b;
} triangle_box_probe;

static inline triangle_box_probe triangle_box_probe_of(const triangle_box *b)
{
    return (triangle_box_probe){*b};
}

static inline int triangle_box_probe_apart(const triangle_box *a, const triangle_box_probe *p)
{
    return triangle_boxes_apart(a, &p->b);
}
#endif

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

/* Answers a batch of rays from one origin as octree_ray answers each, walking the tree in
 * groups of rays that share a visiting order. */
octree_status octree_ray_packets(const struct octree *tree, const ray_input *rays, size_t count, ray_detail detail,
                                 accuracy_mode mode, ray_output *outs, octree_status *statuses,
                                 query_stats *stats);

/* Answers a batch of rays from one origin, exact crossings for the closest or any hit, as
 * octree_ray answers each, eight rays side by side over the compiled form. Only for a tree
 * with the form on a processor with AVX2 (traversal.avx2). */
octree_status octree_ray_fans(const struct octree *tree, const ray_input *rays, size_t count, ray_detail detail,
                              accuracy_mode mode, ray_output *outs, octree_status *statuses, query_stats *stats);

/* A shape vertex under a pose, p' = R p + t, rounded to doubles once. Every mesh query
 * poses vertices through this one expression, so the per-triangle path and the shape-tree
 * path test the same doubles and give the same answers. */
static inline vec3 octree_apply_pose(const pose *at, vec3 p)
{
    const double *r = at->r;
    return (vec3){r[0] * p.x + r[1] * p.y + r[2] * p.z + at->t.x, r[3] * p.x + r[4] * p.y + r[5] * p.z + at->t.y,
                  r[6] * p.x + r[7] * p.y + r[8] * p.z + at->t.z};
}

/* A world ray taken into a posed tree's local frame (octree_posed_ray_setup). */
typedef struct posed_ray {
    pose at;
    ray_input world; /* the caller's ray: the final tests use it */
    ray_input local; /* R^T (o - t) and R^T d, the same parameter range */
    double grow;     /* the walk's widening, a max-norm distance in the local frame */
    /* Its parts (octree_pose.c), kept for the tests that measure each: how far a posed
     * triangle's preimage may be from the tree's, and the local ray from the world ray's
     * preimage at parameter s, origin_reach + |s| direction_reach, for |s| <= s_bound. */
    double vertex_reach, origin_reach, direction_reach, s_bound;
    int misses;      /* the ray cannot reach the posed tree's world cube: no hit */
} posed_ray;

/* Fills out for the ray against tree placed at `at`: OCTREE_OK, or the pose's error
 * (octree_pose_check), or OCTREE_ERR_NONFINITE when the local ray or the bounds overflow. */
octree_status octree_posed_ray_setup(const octree *tree, const pose *at, const ray_input *ray, posed_ray *out);

/* A world triangle taken into a posed tree's frame (R^T (q_k - t)) and the widening its
 * descent needs so that every posed tree triangle touching it is found: OCTREE_OK, or the
 * pose's error, or OCTREE_ERR_NONFINITE when the local triangle or the bound overflows. */
octree_status octree_posed_triangle_setup(const octree *tree, const pose *at, const vec3 tri[3], vec3 local[3],
                                          double *grow);

/* A shape tree placed at shape_at against a world tree placed at world_at: the shape's
 * pose in the world tree's frame, and what the descent in that frame must widen the
 * world's boxes by so that every contact of the two posed meshes is reached. */
octree_status octree_posed_pair_setup(const octree *world, const pose *world_at, const octree *shape,
                                      const pose *shape_at, pose *relative, double *grow);

/* A world point taken into a posed tree's frame for a distance walk (octree_pose.c): the
 * local point, what node boxes grow by, and the factor a squared box distance takes to
 * stay a lower bound of the world distance. */
octree_status octree_posed_point_setup(const octree *tree, const pose *at, vec3 p, vec3 *local, double *grow,
                                       double *shrink2);

/* How far, in the max norm, a point of a tree's triangle placed at `at` (the triangle of
 * posed vertices) may be from octree_pose_box of a box holding its preimage point: what a
 * posed node's world box grows by. The pose must have passed octree_pose_check. */
double octree_pose_reach(const octree *tree, const pose *at);

/* octree_def.node_slabs: the owned lists, then the slabs over them, of a finished tree
 * (its vertices and nodes in place). */
octree_status octree_owned_build(octree *tree);
octree_status octree_slabs_build(octree *tree);
/* The bytes the owned lists of a tree of this size take. */
size_t octree_owned_bytes(size_t node_count, size_t triangle_count);

/* What a distance walk reads of a node, from the owned lists where the tree has them, else
 * from the leaf lists and the node's bounds within its cell (or the cell itself): whether
 * it holds nothing, a lower box of every triangle point it holds, and, not interior, the
 * triangles it holds. With leaf lists a triangle is met in every leaf it is listed in, so
 * those walks also remember what they have tested. */
static inline int octree_distance_empty(const octree *tree, uint32_t node)
{
    return tree->owned ? tree->owned[node].count == 0 : tree->nodes[node].count == 0;
}

static inline box3 octree_distance_bounds(const octree *tree, uint32_t node, box3 cell)
{
    return tree->owned ? tree->owned_bounds[node] : tree->node_bounds ? tree->node_bounds[node] : cell;
}

static inline const uint32_t *octree_distance_items(const octree *tree, octree_node node, uint32_t index,
                                                    uint32_t *count)
{
    if (tree->owned) {
        *count = tree->owned[index].count;
        return tree->owned_items + tree->owned[index].first;
    }
    *count = node.count;
    return tree->leaf_items + node.first;
}
/* Lower bounds of the squared distance from a slab to a point (the slab's points moved by
 * up to grow in the max norm first) and to a closed box: 0 when the slab bounds nothing
 * there. */
double octree_slab_point_distance2_below(const node_slab *slab, vec3 p, double grow);
/* Along the slab's normal alone: no frame to make, and across it a node's box is about as
 * tight as its slab. */
double octree_slab_normal_box_distance2_below(const node_slab *slab, box3 b);
static inline double octree_slab_box_distance2_below(const node_slab *slab, box3 b)
{
    if (slab->n[0] == 0 && slab->n[1] == 0 && slab->n[2] == 0)
        return 0.0;
    oriented_box o = octree_slab_box(slab);
    return octree_oriented_box_distance2_below(&o, b);
}

/* tau, a bound on the spectral norm of R^T R - I of a pose (INFINITY for one
 * octree_pose_check refuses), and e, how far (max norm) a posed vertex of the tree may be
 * from its real image R v + t. */
double octree_pose_defect(const pose *at);
double octree_pose_vertex_error(const octree *tree, const pose *at);

/* octree_mesh's argument checks: OCTREE_OK, or the status octree_mesh returns for them. */
octree_status octree_mesh_check(const mesh_view *shape, const pose *at, accuracy_mode mode);

/* Tests only: 1 makes the shape-tree descent test its children with the baseline lanes
 * even where AVX2 is there, so both copies are checked on one machine; 0 lets it choose. */
void octree_shape_lanes_force_portable(int on);

/* The caller's shape triangle i, in the shape's local frame. */
typedef void (*octree_shape_triangle_fn)(const void *shape, size_t i, vec3 out[3]);

/* The per-triangle mesh query: each posed shape triangle, in the caller's order, searched
 * from the root as octree_triangle searches it. Pairs name shape triangles by their index
 * i. The arguments are checked already (octree_mesh_check). */
octree_status octree_mesh_per_triangle(const struct octree *tree, const void *shape, size_t triangle_count,
                                       octree_shape_triangle_fn triangle_of, const pose *at, int all_pairs,
                                       accuracy_mode mode, mesh_output *out, query_stats *stats);

/* The shape's own octree for a mesh query of `poses` poses, or NULL when the per-triangle
 * path is the better one (a tiny shape) or the tree cannot be built. */
octree *octree_shape_tree_for(const mesh_view *shape, size_t poses);

/* octree_mesh by the per-triangle path, whatever the shape. */
octree_status octree_mesh_as_triangles(const struct octree *tree, const mesh_view *shape, const pose *at,
                                       int all_pairs, accuracy_mode mode, mesh_output *out, query_stats *stats);

/* Deepest traversal stack a query needs: 7 siblings waiting per level plus the node. */
#define OCTREE_STACK_MAX (8 * (OCTREE_MAX_DEPTH_CAP + 1) + 1)

#endif
