/* Shape distance and clearance: the nearest points of a shape's tree at a pose and a world
 * tree (itself placed, or as built), and whether anything comes within a radius; bounds
 * proven per triangle pair (server/geom/tri_distance.h).
 *
 * The two trees are descended together, nearest pair first: a pair of a world node and a
 * shape node has the distance between their boxes in the world frame as a lower bound of
 * every pair of triangle points they hold, and is entered only while that is within the
 * search radius, the best upper bound so far (or the caller's limit). The larger node of a
 * pair is split. A node's box is octree_distance_bounds': of the triangles it owns, where
 * its tree has owned lists, else of its triangles within its cell, or the cell; placed by
 * a pose, it is the box of its posed corners grown by what the pose's rounding can move a
 * point (octree_pose_reach). Clearance is the same walk with the radius fixed: it stops
 * at the first pair that cannot be proven beyond it. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "../geom/box_distance.h"
#include "../geom/interval.h"
#include "../geom/tri_distance.h"
#include "octree_internal.h"
#include "pair_set.h"

typedef struct pair_entry {
    uint32_t world_node, shape_node;
    double lb2;
    box3 world_cell, shape_cell; /* the nodes' cells in their own frames */
} pair_entry;

typedef struct shape_triangle {
    vec3 v[3];
    box3 bounds;
} shape_triangle;

typedef struct shape_walk {
    const octree *world, *shape;
    const pose *world_at, *shape_at; /* NULL: as built */
    double world_grow, shape_grow;
    double limit2;
    int clearance;   /* stop at the first pair not proven beyond the limit */
    int found;
    double lower2;
    triangle_pair_distance best;
    uint32_t best_world, best_shape; /* caller's ids */
    /* Each triangle pair is tested once: in trees with owned lists a pair is met in one
     * node pair; in others, in every pair of leaves that list its triangles, and this set
     * remembers it. */
    pair_set *tested; /* NULL with owned lists */
    query_stats stats;
    /* Per shape node, its world-frame box and slab, each made on first use (shape_ready):
     * a node is in many pairs. */
    box3 *shape_boxes;
    oriented_box *shape_slabs; /* stretch < 0: none */
    unsigned char *shape_ready;
    /* Per shape triangle, its posed vertices and their bounds, made on first use: a
     * triangle meets many world triangles, and each pair was posing it anew. */
    shape_triangle *shape_triangles;
    unsigned char *shape_triangle_ready;
    double shape_tau, shape_error, shape_reach; /* the pose's defect, vertex error, largest |x| + |t| */
} shape_walk;

/* A node's box in the world frame. */
static box3 world_box_of(box3 local, double grow, const pose *at)
{
    return at ? box_grown(octree_pose_box(at, local), grow) : local;
}

/* A shape slab taken into the world frame: each axis a becomes m = R a, and the range of
 * m . y over the posed points y is that of a . x + a^T (R^T R - I) x + m . t for the real
 * image of x: within tau sqrt(3) P of [lo, hi] + m . t (P the largest |x|, a of unit
 * length), then within |m|_1 e of that for the posed vertices' rounding; m's own rounding
 * (3u an entry, |m|_1 at most 1.8) and the products with t and y add 16u (P + |t|). The
 * whole is doubled. |m| is within tau (and 2^-40) of 1: the stretch. */
static oriented_box posed_slab(const shape_walk *w, const node_slab *local)
{
    oriented_box in = octree_slab_box(local), out;
    const double *r = w->shape_at->r;
    vec3 t = w->shape_at->t;
    for (int a = 0; a < 3; a++) {
        const double *n = in.axes[a];
        double *m = out.axes[a];
        m[0] = r[0] * n[0] + r[1] * n[1] + r[2] * n[2];
        m[1] = r[3] * n[0] + r[4] * n[1] + r[5] * n[2];
        m[2] = r[6] * n[0] + r[7] * n[1] + r[8] * n[2];
        double mt = m[0] * t.x + m[1] * t.y + m[2] * t.z;
        double m1 = fabs(m[0]) + fabs(m[1]) + fabs(m[2]);
        double delta = 2 * (w->shape_tau * 1.75 * w->shape_reach + m1 * w->shape_error + 16 * 0x1p-53 * w->shape_reach);
        out.lo[a] = in.lo[a] + mt - delta;
        out.hi[a] = in.hi[a] + mt + delta;
    }
    out.stretch = w->shape_tau + 0x1p-40;
    return out;
}

static void triangle_in_world(const octree *tree, const pose *at, uint32_t id, vec3 out[3])
{
    octree_triangle_vertices(tree, id, out);
    if (at)
        for (int k = 0; k < 3; k++)
            out[k] = octree_apply_pose(at, out[k]);
}

static const shape_triangle *shape_triangle_of(shape_walk *w, uint32_t sid)
{
    shape_triangle *t = &w->shape_triangles[sid];
    if (!w->shape_triangle_ready[sid]) {
        triangle_in_world(w->shape, w->shape_at, sid, t->v);
        t->bounds = triangle_bounds(t->v);
        w->shape_triangle_ready[sid] = 1;
    }
    return t;
}

/* A posed shape node's box: the box of its posed triangles where it owns few (each
 * triangle posed once a walk, and its bounds those the pairs are measured with, so they
 * need no growing), else the box of its bounds' posed corners, grown. A small node's
 * rotated box reaches up to sqrt(3) times as far as its triangles. */
#define EXACT_POSED_NODE 64

static void shape_node_ready(shape_walk *w, uint32_t node, box3 cell);

static box3 posed_owned_box(shape_walk *w, uint32_t node)
{
    const octree *shape = w->shape;
    octree_node n = shape->nodes[node];
    box3 b = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    if (n.count == NODE_INTERIOR) {
        for (int k = 0; k < 8; k++) {
            uint32_t child = n.first + (uint32_t)k;
            if (octree_distance_empty(shape, child))
                continue;
            shape_node_ready(w, child, shape->world); /* owned lists: the cell is not read */
            b = (box3){vec3_min(b.lo, w->shape_boxes[child].lo), vec3_max(b.hi, w->shape_boxes[child].hi)};
        }
        return b;
    }
    owned_span own = shape->owned[node];
    for (uint32_t i = 0; i < own.count; i++) {
        box3 t = shape_triangle_of(w, shape->owned_items[own.first + i])->bounds;
        b = (box3){vec3_min(b.lo, t.lo), vec3_max(b.hi, t.hi)};
    }
    return b;
}

/* shape_ready bits: the box is made, the slab is made. Slabs are made only for pairs
 * whose boxes do not part them: a frame and three posed axes each. */
enum { SHAPE_BOX_READY = 1, SHAPE_SLAB_READY = 2 };

static void shape_node_ready(shape_walk *w, uint32_t node, box3 cell)
{
    if (w->shape_ready[node] & SHAPE_BOX_READY)
        return;
    if (w->shape_at && w->shape->owned && w->shape->owned[node].count <= EXACT_POSED_NODE)
        w->shape_boxes[node] = posed_owned_box(w, node);
    else
        w->shape_boxes[node] = world_box_of(octree_distance_bounds(w->shape, node, cell), w->shape_grow, w->shape_at);
    w->shape_ready[node] |= SHAPE_BOX_READY;
}

static const oriented_box *shape_node_slab(shape_walk *w, uint32_t node)
{
    oriented_box *o = &w->shape_slabs[node];
    if (w->shape_ready[node] & SHAPE_SLAB_READY)
        return o;
    o->stretch = -1;
    if (w->shape->node_slabs) {
        const node_slab *ls = &w->shape->node_slabs[node];
        if (ls->n[0] != 0 || ls->n[1] != 0 || ls->n[2] != 0)
            *o = w->shape_at ? posed_slab(w, ls) : octree_slab_box(ls);
    }
    w->shape_ready[node] |= SHAPE_SLAB_READY;
    return o;
}

static box3 shape_node_world_box(shape_walk *w, uint32_t node, box3 cell)
{
    shape_node_ready(w, node, cell);
    return w->shape_boxes[node];
}

/* A lower bound of the squared distance between two closed boxes: each gap rounded down,
 * squared and summed rounded down. A box that holds nothing (inverted bounds) is at
 * infinity. */
static double pair_bound(shape_walk *w, uint32_t world_node, box3 world_cell, uint32_t shape_node,
                         box3 shape_cell)
{
    box3 wb = world_box_of(octree_distance_bounds(w->world, world_node, world_cell), w->world_grow, w->world_at);
    box3 sb = shape_node_world_box(w, shape_node, shape_cell);
    double lb2 = boxes_distance2_below(wb, sb);
    if (lb2 > w->limit2)
        return lb2; /* the boxes suffice: the slabs cost a frame each */
    /* Each side's slab against the other's box: a surface's piece is far thinner along its
     * normal than its box. The world's slab is in the world frame only when it is not
     * placed. */
    if (w->world->node_slabs && !w->world_at) {
        double g = octree_slab_normal_box_distance2_below(&w->world->node_slabs[world_node], sb);
        lb2 = g > lb2 ? g : lb2;
    }
    if (w->shape->node_slabs && !(lb2 > w->limit2)) {
        const oriented_box *ss = shape_node_slab(w, shape_node);
        if (ss->stretch >= 0) {
            double g = octree_oriented_box_distance2_below(ss, wb);
            lb2 = g > lb2 ? g : lb2;
        }
    }
    return lb2;
}

static vec3 triangle_normal(const vec3 v[3])
{
    return vec3_cross(vec3_sub(v[1], v[0]), vec3_sub(v[2], v[0]));
}

/* 1 when the walk may stop: a clearance found a pair it cannot prove clear, or the
 * pair touches; -1 when memory ran out. The boxes come first: most pairs a leaf pair
 * holds are parted by them, so the set of pairs tested is asked only for pairs worth the
 * full bounds. */
static int take_pair(shape_walk *w, uint32_t wid, const vec3 wv[3], box3 wb, uint32_t sid)
{
    const shape_triangle *st = shape_triangle_of(w, sid);
    if (boxes_distance2_below(wb, st->bounds) > w->limit2)
        return 0;
    if (w->tested) {
        int fresh = pair_set_insert(w->tested, pair_set_key(wid, sid));
        if (fresh <= 0)
            return fresh;
    }
    const vec3 *sv = st->v;
    /* Each triangle's plane parts the pair when the other lies beyond it by more than the
     * radius: a near-parallel pair of surfaces, which boxes cannot tell apart, is decided
     * at a sixth of the full bounds' cost. */
    if (convex_gap_lower2(sv, 3, wv, 3, triangle_normal(wv)) > w->limit2 ||
        convex_gap_lower2(wv, 3, sv, 3, triangle_normal(sv)) > w->limit2)
        return 0;
    w->stats.candidates_tested++;
    triangle_pair_distance r;
    if (!triangle_pair_distance_within(wv, sv, w->limit2, &r))
        return 0;
    w->found = 1;
    if (w->clearance)
        return 1;
    if (r.hi2 == 0) {
        /* Touching (decided exactly): the distance is 0 and no pair can do better. The
         * first touching pair met is the answer; finding the smallest ids among every
         * touching pair of a deep penetration would cost a contact query's work. */
        w->lower2 = 0;
        w->best = r;
        w->best_world = w->world->original_id[wid];
        w->best_shape = w->shape->original_id[sid];
        w->limit2 = 0;
        return 1;
    }
    uint32_t ow = w->world->original_id[wid], os = w->shape->original_id[sid];
    w->lower2 = r.lo2 < w->lower2 ? r.lo2 : w->lower2;
    if (r.hi2 < w->best.hi2 || (r.hi2 == w->best.hi2 && (ow < w->best_world || (ow == w->best_world && os < w->best_shape)))) {
        w->best = r;
        w->best_world = ow;
        w->best_shape = os;
    }
    w->limit2 = w->best.hi2 < w->limit2 ? w->best.hi2 : w->limit2;
    return 0;
}

/* Every world triangle of the leaf against every shape triangle of the other, a world
 * triangle first against the shape leaf's box as a whole. As take_pair. */
static int leaf_pair(shape_walk *w, const pair_entry *e, box3 shape_box)
{
    w->stats.leaves_visited++;
    uint32_t world_count, shape_count;
    const uint32_t *world_items = octree_distance_items(w->world, w->world->nodes[e->world_node], e->world_node,
                                                        &world_count);
    const uint32_t *shape_items = octree_distance_items(w->shape, w->shape->nodes[e->shape_node], e->shape_node,
                                                        &shape_count);
    for (uint32_t i = 0; i < world_count; i++) {
        uint32_t wid = world_items[i];
        vec3 wv[3];
        triangle_in_world(w->world, w->world_at, wid, wv);
        box3 wb = triangle_bounds(wv);
        if (boxes_distance2_below(wb, shape_box) > w->limit2)
            continue;
        for (uint32_t j = 0; j < shape_count; j++) {
            int r = take_pair(w, wid, wv, wb, shape_items[j]);
            if (r != 0)
                return r;
        }
    }
    return 0;
}

static double box_size(box3 b)
{
    return fmax(b.hi.x - b.lo.x, fmax(b.hi.y - b.lo.y, b.hi.z - b.lo.z));
}

/* The pairs waiting, a binary min-heap by lower bound: the walk always takes the pair
 * that may be nearest, so the first leaf pairs it reaches hold the answer or nearly, the
 * radius falls at once, and every pair whose bound is past it is never taken. Depth first,
 * with each node's children in order, measured 1.5-90x the pairs on a sphere over a
 * terrain (the nearest child's subtree is not where the nearest pair is). */
typedef struct heap_item {
    double lb2;
    uint32_t entry; /* into the pool */
} heap_item;

/* The heap orders small items; the pairs themselves (with their cells, 112 bytes) stay
 * where they were put, in a pool that only grows while a walk lasts. Sifting whole pairs
 * was a sixth of a walk. */
typedef struct pair_heap {
    heap_item *items;
    size_t count, capacity;
    pair_entry *pool;
    size_t pool_count, pool_capacity;
} pair_heap;

static int heap_push(pair_heap *h, const pair_entry *e)
{
    if (h->pool_count >= UINT32_MAX ||
        array_reserve((void **)&h->pool, &h->pool_capacity, h->pool_count + 1, sizeof *h->pool, 64) != 0 ||
        array_reserve((void **)&h->items, &h->capacity, h->count + 1, sizeof *h->items, 64) != 0)
        return -1;
    h->pool[h->pool_count] = *e;
    heap_item item = {e->lb2, (uint32_t)h->pool_count++};
    size_t i = h->count++;
    while (i > 0 && h->items[(i - 1) / 2].lb2 > item.lb2) {
        h->items[i] = h->items[(i - 1) / 2];
        i = (i - 1) / 2;
    }
    h->items[i] = item;
    return 0;
}

static const pair_entry *heap_pop(pair_heap *h)
{
    heap_item top = h->items[0], last = h->items[--h->count];
    size_t i = 0;
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= h->count)
            break;
        if (c + 1 < h->count && h->items[c + 1].lb2 < h->items[c].lb2)
            c++;
        if (!(h->items[c].lb2 < last.lb2))
            break;
        h->items[i] = h->items[c];
        i = c;
    }
    if (h->count > 0)
        h->items[i] = last;
    return &h->pool[top.entry];
}

static void heap_free(pair_heap *h)
{
    free(h->items);
    free(h->pool);
}

/* OCTREE_ERR_NOMEM when the heap cannot grow. */
static octree_status walk_pairs(shape_walk *w)
{
    const octree *world = w->world, *shape = w->shape;
    pair_heap heap = {0};
    octree_status st = OCTREE_OK;
    if (octree_distance_empty(world, 0) || octree_distance_empty(shape, 0))
        return OCTREE_OK;
    double root = pair_bound(w, 0, world->world, 0, shape->world);
    pair_entry first = {0, 0, root, world->world, shape->world};
    if (root <= w->limit2 && heap_push(&heap, &first) != 0)
        st = OCTREE_ERR_NOMEM;
    while (st == OCTREE_OK && heap.count > 0) {
        pair_entry e = *heap_pop(&heap); /* a copy: the pool may move as pairs are pushed */
        if (e.lb2 > w->limit2)
            break; /* every pair left is as far */
        w->stats.nodes_visited++;
        octree_node wn = world->nodes[e.world_node], sn = shape->nodes[e.shape_node];
        int world_leaf = wn.count != NODE_INTERIOR, shape_leaf = sn.count != NODE_INTERIOR;
        if (world_leaf && shape_leaf) {
            int r = leaf_pair(w, &e, shape_node_world_box(w, e.shape_node, e.shape_cell));
            if (r < 0)
                st = OCTREE_ERR_NOMEM;
            if (r != 0)
                break;
            continue;
        }
        /* Split the world node unless it is a leaf or the shape's box is the larger (the
         * boxes the bounds use: measured 4% fewer instructions than comparing cells). */
        double world_size = box_size(octree_distance_bounds(world, e.world_node, e.world_cell));
        double shape_size = box_size(shape_node_world_box(w, e.shape_node, e.shape_cell));
        int split_world = !world_leaf && (shape_leaf || world_size >= shape_size);
        box3 cell = split_world ? e.world_cell : e.shape_cell;
        const octree *tree = split_world ? world : shape;
        octree_node node = split_world ? wn : sn;
        vec3 c = octree_split_point(tree, cell);
        for (int k = 0; k < 8 && st == OCTREE_OK; k++) {
            uint32_t child = node.first + (uint32_t)k;
            if (octree_distance_empty(tree, child))
                continue;
            box3 cb = box_child(cell, c, box_octant_upper_bits[k]);
            pair_entry p = split_world ? (pair_entry){child, e.shape_node, 0, cb, e.shape_cell}
                                       : (pair_entry){e.world_node, child, 0, e.world_cell, cb};
            p.lb2 = pair_bound(w, p.world_node, p.world_cell, p.shape_node, p.shape_cell);
            if (p.lb2 <= w->limit2 && heap_push(&heap, &p) != 0)
                st = OCTREE_ERR_NOMEM;
        }
    }
    heap_free(&heap);
    return st;
}

static void walk_release(shape_walk *w)
{
    free(w->shape_boxes);
    free(w->shape_slabs);
    free(w->shape_ready);
    free(w->shape_triangles);
    free(w->shape_triangle_ready);
    if (w->tested)
        pair_set_release(w->tested);
    free(w->tested);
    w->tested = NULL;
    w->shape_triangles = NULL;
    w->shape_triangle_ready = NULL;
    w->shape_boxes = NULL;
    w->shape_slabs = NULL;
    w->shape_ready = NULL;
}

static octree_status walk_setup(shape_walk *w, const octree *world, const pose *world_at, const octree *shape,
                                const pose *shape_at, double limit)
{
    memset(w, 0, sizeof *w);
    if (!(limit >= 0))
        return OCTREE_ERR_INVALID;
    octree_status st = world_at ? octree_pose_check(world_at) : OCTREE_OK;
    if (st == OCTREE_OK && shape_at)
        st = octree_pose_check(shape_at);
    if (st != OCTREE_OK)
        return st;
    w->world = world;
    w->shape = shape;
    w->world_at = world_at;
    w->shape_at = shape_at;
    w->world_grow = world_at ? octree_pose_reach(world, world_at) : 0.0;
    w->shape_grow = shape_at ? octree_pose_reach(shape, shape_at) : 0.0;
    if (!(w->world_grow < INFINITY) || !(w->shape_grow < INFINITY))
        return OCTREE_ERR_NONFINITE;
    w->shape_boxes = malloc(shape->node_count * sizeof *w->shape_boxes);
    w->shape_slabs = malloc(shape->node_count * sizeof *w->shape_slabs);
    w->shape_ready = calloc(shape->node_count, 1);
    w->shape_triangles = malloc(shape->triangle_count * sizeof *w->shape_triangles);
    w->shape_triangle_ready = calloc(shape->triangle_count, 1);
    if (!world->owned || !shape->owned) {
        w->tested = malloc(sizeof *w->tested);
        if (w->tested)
            pair_set_init(w->tested);
    }
    if (!w->shape_boxes || !w->shape_slabs || !w->shape_ready || !w->shape_triangles || !w->shape_triangle_ready ||
        (!w->tested && (!world->owned || !shape->owned))) {
        walk_release(w);
        return OCTREE_ERR_NOMEM;
    }
    if (shape_at) {
        box3 c = shape->world;
        double p = fmax(fmax(fabs(c.lo.x), fabs(c.hi.x)), fmax(fmax(fabs(c.lo.y), fabs(c.hi.y)), fmax(fabs(c.lo.z), fabs(c.hi.z))));
        vec3 t = shape_at->t;
        w->shape_tau = octree_pose_defect(shape_at);
        w->shape_error = octree_pose_vertex_error(shape, shape_at);
        w->shape_reach = p + fmax(fabs(t.x), fmax(fabs(t.y), fabs(t.z)));
    }
    w->limit2 = limit == INFINITY ? INFINITY : iv_up(limit * limit);
    w->lower2 = INFINITY;
    w->best = (triangle_pair_distance){INFINITY, INFINITY, {0, 0, 0}, {0, 0, 0}};
    w->best_world = w->best_shape = UINT32_MAX;
    return OCTREE_OK;
}

octree_status octree_shape_distance(const octree *world, const pose *world_at, const octree *shape,
                                    const pose *shape_at, double max_distance, shape_distance_output *out,
                                    query_stats *stats)
{
    memset(out, 0, sizeof *out);
    shape_walk w;
    octree_status st = walk_setup(&w, world, world_at, shape, shape_at, max_distance);
    if (st != OCTREE_OK)
        return st;
    st = walk_pairs(&w);
    walk_release(&w);
    query_stats_finish(stats, &w.stats, 0, 0);
    if (st != OCTREE_OK || !w.found)
        return st;
    out->found = 1;
    out->lower = iv_sqrt_nonnegative((interval){w.lower2, w.lower2}).lo;
    out->upper = iv_sqrt_nonnegative((interval){w.best.hi2, w.best.hi2}).hi;
    out->world_point = w.best.a_point;
    out->shape_point = w.best.b_point;
    iv_distance_report(vec3_length(vec3_sub(out->world_point, out->shape_point)), out->lower, out->upper,
                       &out->distance, &out->bound);
    out->world_triangle = w.best_world;
    out->shape_triangle = w.best_shape;
    return OCTREE_OK;
}

octree_status octree_shape_clearance(const octree *world, const pose *world_at, const octree *shape,
                                     const pose *shape_at, double radius, int *clear, query_stats *stats)
{
    *clear = 0;
    shape_walk w;
    octree_status st = walk_setup(&w, world, world_at, shape, shape_at, radius);
    if (st != OCTREE_OK)
        return st;
    w.clearance = 1;
    st = walk_pairs(&w);
    walk_release(&w);
    if (st != OCTREE_OK)
        return st;
    query_stats_finish(stats, &w.stats, 0, 0);
    *clear = !w.found;
    return OCTREE_OK;
}
