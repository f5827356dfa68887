/* Compiles the octree into its traversal form (octree_traversal.h): one record per interior
 * node with its children's clipped content bounds, quantized outward. */
#include "octree_traversal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "hot_memory.h"
#include "octree_internal.h"

typedef struct compile_ctx {
    const octree *tree;
    const box3 *bounds; /* each triangle's exact box */
    traversal_node *nodes;
    size_t count, capacity;
} compile_ctx;

/* Bounds in float relative to the world's lower corner; lo > hi when empty. */
typedef struct float_bounds {
    float lo[3], hi[3];
} float_bounds;

static const float_bounds no_bounds = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};

static int bounds_empty(const float_bounds *b)
{
    return !(b->lo[0] <= b->hi[0]);
}

static void bounds_add(float_bounds *into, const float_bounds *b)
{
    for (int a = 0; a < 3; a++) {
        into->lo[a] = b->lo[a] < into->lo[a] ? b->lo[a] : into->lo[a];
        into->hi[a] = b->hi[a] > into->hi[a] ? b->hi[a] : into->hi[a];
    }
}

/* The union over a leaf's triangles of each one's box clipped to the leaf's cube, in
 * doubles (min and max are exact), then rounded outward to floats relative to the world's
 * lower corner. A listed triangle touches the cube, so each clipped box is non-empty. */
static float_bounds leaf_bounds(const compile_ctx *ctx, octree_node leaf, box3 cube)
{
    const octree *tree = ctx->tree;
    vec3 lo = {INFINITY, INFINITY, INFINITY}, hi = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t i = 0; i < leaf.count; i++) {
        box3 b = ctx->bounds[tree->leaf_items[leaf.first + i]];
        lo = vec3_min(lo, vec3_max(b.lo, cube.lo));
        hi = vec3_max(hi, vec3_min(b.hi, cube.hi));
    }
    triangle_box b = triangle_box_around(lo, hi, tree->world.lo);
    float_bounds out;
    memcpy(out.lo, b.lo, sizeof out.lo);
    memcpy(out.hi, b.hi, sizeof out.hi);
    return out;
}

/* The frame of a node whose contents span b: a power-of-two scale with 254 steps covering
 * the widest axis and at least 2^-22 of the largest coordinate (so origin / scale + 255
 * stays below 2^24 and every dequantized bound is a float), and per axis the multiple of
 * it at or below b.lo. All of it is exact in doubles: the inputs are floats. */
static void node_frame(const float_bounds *b, traversal_node *n)
{
    /* Every value here is finite and none is negative where a maximum is taken, so plain
     * comparisons give fmax's answers. */
    double extent = 0, largest = 0;
    for (int a = 0; a < 3; a++) {
        double e = (double)b->hi[a] - (double)b->lo[a];
        extent = e > extent ? e : extent;
        double lo = fabs((double)b->lo[a]), hi = fabs((double)b->hi[a]);
        double m = lo > hi ? lo : hi;
        largest = m > largest ? m : largest;
    }
    double need = extent / 254.0, floor_need = ldexp(largest, -22);
    need = need > floor_need ? need : floor_need;
    need = need > 0x1p-126 ? need : 0x1p-126;
    int e;
    frexp(need, &e); /* need = f * 2^e, 0.5 <= f < 1, so 2^e >= need */
    double scale = ldexp(1.0, e);
    n->scale = (float)scale;
    for (int a = 0; a < 3; a++)
        n->origin[a] = (float)(floor((double)b->lo[a] / scale) * scale);
}

/* (x - origin) / scale rounded down (up) to a step, clamped to 0..255. scale is a power
 * of two in the float range (node_frame), so its reciprocal is an exact power of two too,
 * and the product is the same real value as the quotient, rounded the same way: the
 * division this replaces cost more than the rest of the quantization. Within
 * [0, 255] the conversion's truncation is the floor, and the ceiling is one more when the
 * value is not an integer; outside, the clamps give what floor and ceil would have. */
static int quantize_down(double x, double origin, double inverse_scale)
{
    double q = (x - origin) * inverse_scale;
    if (!(q > 0))
        return 0;
    if (q >= 255)
        return 255;
    return (int)q;
}

static int quantize_up(double x, double origin, double inverse_scale)
{
    double q = (x - origin) * inverse_scale;
    if (!(q > 0))
        return 0;
    if (q > 255)
        return 255;
    int t = (int)q;
    return (double)t < q ? t + 1 : t;
}

/* Compiles the subtree of octree node `index` with cube `cube`: *ref names what the walk
 * visits for it and *bounds what it holds. -1 when memory ran out, 1 when a leaf's
 * reference does not fit. */
static int compile_node(compile_ctx *ctx, uint32_t index, box3 cube, uint32_t *ref, float_bounds *bounds)
{
    const octree *tree = ctx->tree;
    octree_node node = tree->nodes[index];
    if (node.count != NODE_INTERIOR) {
        if (node.count == 0) {
            *ref = TRAVERSAL_EMPTY;
            *bounds = no_bounds;
            return 0;
        }
        if (node.count <= TRAVERSAL_SPAN_COUNT_MAX && node.first < TRAVERSAL_SPAN_FIRST_LIMIT)
            *ref = TRAVERSAL_LEAF | TRAVERSAL_SPAN | (node.count - 1) << TRAVERSAL_SPAN_COUNT_SHIFT | node.first;
        else if (index < TRAVERSAL_SPAN)
            *ref = TRAVERSAL_LEAF | index;
        else
            return 1;
        *bounds = leaf_bounds(ctx, node, cube);
        return 0;
    }
    if (array_reserve((void **)&ctx->nodes, &ctx->capacity, ctx->count + 1, sizeof *ctx->nodes, 1024) != 0)
        return -1;
    size_t at = ctx->count++;
    vec3 c = octree_split_point(tree, cube);
    uint32_t child[8];
    float_bounds kid[8];
    *bounds = no_bounds;
    for (int k = 0; k < 8; k++) {
        unsigned upper = box_octant_upper_bits[k];
        int st = compile_node(ctx, node.first + (uint32_t)k, box_child(cube, c, upper), &child[upper], &kid[upper]);
        if (st != 0)
            return st;
        if (!bounds_empty(&kid[upper]))
            bounds_add(bounds, &kid[upper]);
    }
    if (bounds_empty(bounds)) { /* no child holds anything: nothing to visit */
        ctx->count--;
        *ref = TRAVERSAL_EMPTY;
        return 0;
    }
    traversal_node *n = &ctx->nodes[at];
    node_frame(bounds, n);
    double inverse_scale = 1.0 / (double)n->scale; /* exact: a power of two */
    for (int k = 0; k < 8; k++) {
        n->child[k] = child[k];
        for (int a = 0; a < 3; a++) {
            int lo = 255, hi = 0; /* an empty lane: never met (its child is TRAVERSAL_EMPTY too) */
            if (child[k] != TRAVERSAL_EMPTY) {
                lo = quantize_down(kid[k].lo[a], n->origin[a], inverse_scale);
                hi = quantize_up(kid[k].hi[a], n->origin[a], inverse_scale);
            }
            n->q[a][k] = (uint8_t)lo;
            n->q[3 + a][k] = (uint8_t)hi;
        }
    }
    *ref = (uint32_t)at;
    return 0;
}

int traversal_form_build(const octree *tree, const box3 *triangle_bounds, traversal_form *form)
{
    *form = (traversal_form){.root = TRAVERSAL_EMPTY};
    /* The cube's side as its corners give it (the build fills the tree's info after). */
    double side = fmax(tree->world.hi.x - tree->world.lo.x,
                       fmax(tree->world.hi.y - tree->world.lo.y, tree->world.hi.z - tree->world.lo.z));
    if (!(side >= 0x1p-60 && side <= 0x1p60))
        return 1;
    compile_ctx ctx = {.tree = tree, .bounds = triangle_bounds};
    float_bounds all;
    int st = compile_node(&ctx, 0, tree->world, &form->root, &all);
    if (st != 0) {
        free(ctx.nodes);
        *form = (traversal_form){.root = TRAVERSAL_EMPTY};
        return st;
    }
    /* The final array on 64 bytes (each record then spans exactly two cache lines), sized
     * to what the nodes need. */
    size_t bytes = (ctx.count * sizeof(traversal_node) + 63) & ~(size_t)63;
    if (ctx.count > 0) {
        form->nodes = hot_alloc(bytes);
        if (!form->nodes) {
            free(ctx.nodes);
            *form = (traversal_form){.root = TRAVERSAL_EMPTY};
            return -1;
        }
        memcpy(form->nodes, ctx.nodes, ctx.count * sizeof(traversal_node));
    }
    free(ctx.nodes);
    form->node_count = ctx.count;
    form->bytes = ctx.count > 0 ? bytes : 0;
    form->present = 1;
#if defined(__x86_64__) || defined(__i386__)
    form->avx2 = __builtin_cpu_supports("avx2");
#endif
    return 0;
}

void traversal_form_free(traversal_form *form)
{
    free(form->nodes);
    *form = (traversal_form){.root = TRAVERSAL_EMPTY};
}
