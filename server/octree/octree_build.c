/* Building the fixed-resolution octree, in the seed document's shape: one node array, an
 * explicit stack, each node testing only its parent's triangle list. */
#include <math.h>
#include <stddef.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "../geom/box_geometry.h"
#include "../geom/expansion.h"
#include "../geom/tri_box.h"
#include "hot_memory.h"
#include "octree_internal.h"
#include "octree_modes.h"

#if defined(__x86_64__) || defined(__SSE2__)
#include <emmintrin.h>
#define BUILD_SSE2 1
#endif

const char *accuracy_mode_name(accuracy_mode mode)
{
    switch (mode) {
    case ACCURACY_EXACT: return "exact";
    case ACCURACY_SEED: return "seed";
    case ACCURACY_FAST: return "fast";
    }
    return "unknown";
}

const char *octree_status_text(octree_status status)
{
    switch (status) {
#define OCTREE_STATUS_TEXT(name, code, text) \
    case name: return text;
        OCTREE_STATUS_MAP(OCTREE_STATUS_TEXT)
#undef OCTREE_STATUS_TEXT
    }
    return "unknown status";
}

/* The seed's epsilon is relative to nothing in the document; 1e-9 suits metre-scale worlds
 * and is a knob the accuracy report sweeps. */
#define OCTREE_DEFAULT_SEED_EPSILON 1e-9
/* Default depth cap: 2^16 leaves a side is already ~2.8e14 leaf cells. */
#define OCTREE_DEFAULT_MAX_DEPTH 16

size_t octree_default_budget(size_t triangles)
{
    if (triangles > (SIZE_MAX - OCTREE_DEFAULT_BUDGET_BASE) / OCTREE_DEFAULT_BUDGET_PER_TRIANGLE)
        return SIZE_MAX;
    return OCTREE_DEFAULT_BUDGET_BASE + triangles * OCTREE_DEFAULT_BUDGET_PER_TRIANGLE;
}

octree_def octree_default_def(void)
{
    return (octree_def){
        .resolution = 0.0,
        .max_depth = OCTREE_DEFAULT_MAX_DEPTH,
        .mode = ACCURACY_EXACT,
        .seed_epsilon = OCTREE_DEFAULT_SEED_EPSILON,
        .triangle_boxes = 0,
        .node_bounds = 0,
        .node_slabs = 0,
        .budget_bytes = 0,
        .account = NULL,
        .plain_walk = 0,
    };
}

static octree *fail(octree_error *err, octree_status status, size_t triangle, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
static octree *fail(octree_error *err, octree_status status, size_t triangle, const char *fmt, ...)
{
    if (err) {
        err->status = status;
        err->triangle = triangle;
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->message, sizeof err->message, fmt, ap);
        va_end(ap);
    }
    return NULL;
}

static double seconds_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* ---------- growable arrays ---------- */

typedef struct u32_array {
    uint32_t *items;
    size_t count, capacity;
} u32_array;

/* First capacity of a build list. */
#define U32_ARRAY_FIRST 64

/* The eight children's triangle lists of a node that was split, side by side in one block:
 * child k's items are items[first[k] .. first[k] + count[k]), in the order of the node's
 * own list. The node decides every item's children once, in one pass, and writes each
 * item straight into the lists it belongs to, so a child reads its list instead of
 * filtering its parent's (before, each of the eight scanned the parent's list again).
 * Freed when the last child has used its list (the seed's "interior nodes' lists are
 * released after use"). The root's "parent" holds one list, every triangle, as child 0. */
typedef struct shared_list {
    uint32_t *items;
    uint32_t first[8], count[8];
    int pending_children;
    size_t bytes; /* what the block holds, counted against the build's budget */
} shared_list;

typedef struct build_entry {
    uint32_t node;
    int level;
    int octant; /* which of its parent's children this node is (0 for the root) */
    box3 box;
    shared_list *parent;
} build_entry;

/* A triangle's exact bounds: a box3, so the traversal form's compile can read them too. */
typedef box3 triangle_bounds;
_Static_assert(sizeof(triangle_bounds) == 6 * sizeof(double) && offsetof(triangle_bounds, hi) == 3 * sizeof(double),
               "bounds_reach_index reads a triangle's bounds as six doubles");

typedef struct build_ctx {
    octree *tree;
    const octree_def *def;
    triangle_bounds *bounds; /* per triangle, exact min/max of its vertices */
    size_t node_capacity;
    size_t budget; /* bytes the build may hold (octree_def.budget_bytes, resolved) */
    size_t held;   /* bytes it holds now */
    size_t asked;  /* the request that would have passed the budget, when one did */
    int account_full; /* it was the shared account (octree_def.account) that had no room */
    /* box_octants_reached by bounds_reach_index's comparisons */
    uint8_t reach_of_index[64];
} build_ctx;

/* Counts bytes against the budget before they are allocated: 0, or -1 (nothing counted)
 * when they would pass it. */
static int budget_take(build_ctx *ctx, size_t bytes)
{
    if (bytes > ctx->budget - ctx->held) {
        ctx->asked = bytes;
        return -1;
    }
    octree *tree = ctx->tree;
    if (tree->account && memory_account_take(tree->account, bytes) != 0) {
        ctx->asked = bytes;
        ctx->account_full = 1;
        return -1;
    }
    ctx->held += bytes;
    tree->accounted += tree->account ? bytes : 0;
    return 0;
}

static void budget_give_back(build_ctx *ctx, size_t bytes)
{
    ctx->held -= bytes;
    octree *tree = ctx->tree;
    if (tree->account) {
        memory_account_give(tree->account, bytes);
        tree->accounted -= bytes;
    }
}

/* The tree keeps, of the account, what it holds when built: no more, no less. */
static void settle_account(octree *tree, size_t bytes)
{
    if (!tree->account)
        return;
    if (bytes > tree->accounted)
        memory_account_charge(tree->account, bytes - tree->accounted);
    else
        memory_account_give(tree->account, tree->accounted - bytes);
    tree->accounted = bytes;
}

/* Grows a build list to hold extra more items, counting its new capacity first. */
static octree_status u32_reserve(build_ctx *ctx, u32_array *a, size_t extra)
{
    size_t need = a->count + extra;
    size_t cap = array_grown_capacity(a->capacity, need, sizeof *a->items, U32_ARRAY_FIRST);
    size_t grown = (cap - a->capacity) * sizeof *a->items;
    if (budget_take(ctx, grown) != 0)
        return OCTREE_ERR_BUDGET;
    if (array_reserve((void **)&a->items, &a->capacity, need, sizeof *a->items, U32_ARRAY_FIRST) != 0) {
        budget_give_back(ctx, grown);
        return OCTREE_ERR_NOMEM;
    }
    return OCTREE_OK;
}

/* Membership of a node's item in its children's closed boxes: the node decides it for
 * all eight children at once (see shared_list), exactly, whatever the tree's mode.
 *
 * Every mode builds this same tree. Membership must be conservative in every mode (a
 * triangle touching the closed box is in the node), and a tree is queried in every mode
 * (a query names its own), so each mode's queries make up for their own final test on the
 * query side: fast and seed walks and descents grow the node boxes by what their final
 * test can accept beyond the exact geometry (octree_ray.c, octree_triangle.c). The plain
 * double triangle-box test dropped triangles that only touch a node, and the seed's
 * three-step test accepts whatever lies within epsilon, which in a world about as small
 * as epsilon is every node down to the last level; neither is conservative, and both cost
 * more than the exact decision (docs/engine.md has the figures). The root takes every
 * triangle: every one lies inside the world cube. */

/* Bit 8k of spread8[r] is bit k of r: adding it counts, in eight byte lanes at once, how
 * many items each child takes. */
#define SPREAD1(r) ((uint64_t)((r) & 1) | (uint64_t)((r) >> 1 & 1) << 8 | (uint64_t)((r) >> 2 & 1) << 16 | \
                    (uint64_t)((r) >> 3 & 1) << 24 | (uint64_t)((r) >> 4 & 1) << 32 | (uint64_t)((r) >> 5 & 1) << 40 | \
                    (uint64_t)((r) >> 6 & 1) << 48 | (uint64_t)((r) >> 7 & 1) << 56)
#define SPREAD4(r) SPREAD1(r), SPREAD1((r) + 1), SPREAD1((r) + 2), SPREAD1((r) + 3)
#define SPREAD16(r) SPREAD4(r), SPREAD4((r) + 4), SPREAD4((r) + 8), SPREAD4((r) + 12)
#define SPREAD64(r) SPREAD16(r), SPREAD16((r) + 16), SPREAD16((r) + 32), SPREAD16((r) + 48)
static const uint64_t spread8[256] = {SPREAD64(0), SPREAD64(64), SPREAD64(128), SPREAD64(192)};

/* box_octants_reached of a triangle's bounds in two steps: the six comparisons with the
 * split point as an index (bit a: lo_a <= c_a; bit 3 + a: hi_a >= c_a), then reach_of_index
 * (the same table lookups, done once a node). Under SSE2 the comparisons take two lanes
 * at a time: most items reach one child, and this was a fifth of what each cost. */
typedef struct split_lanes {
#ifdef BUILD_SSE2
    __m128d xy, z_any, any_x, yz;
#else
    vec3 c;
#endif
} split_lanes;

static split_lanes split_lanes_of(vec3 c)
{
#ifdef BUILD_SSE2
    /* The infinite lanes always compare true and are masked out. */
    return (split_lanes){_mm_set_pd(c.y, c.x), _mm_set_pd(INFINITY, c.z), _mm_set_pd(c.x, -INFINITY),
                         _mm_set_pd(c.z, c.y)};
#else
    return (split_lanes){c};
#endif
}

static inline unsigned bounds_reach_index(const triangle_bounds *b, const split_lanes *s)
{
#ifdef BUILD_SSE2
    const double *v = (const double *)(const void *)b; /* lo.x lo.y lo.z hi.x hi.y hi.z */
    __m128d lo_xy = _mm_loadu_pd(v), lo_z_hi_x = _mm_loadu_pd(v + 2), hi_yz = _mm_loadu_pd(v + 4);
    unsigned low = (unsigned)_mm_movemask_pd(_mm_cmple_pd(lo_xy, s->xy)) |
                   ((unsigned)_mm_movemask_pd(_mm_cmple_pd(lo_z_hi_x, s->z_any)) & 1) << 2;
    unsigned high = (unsigned)_mm_movemask_pd(_mm_cmpge_pd(lo_z_hi_x, s->any_x)) >> 1 |
                    (unsigned)_mm_movemask_pd(_mm_cmpge_pd(hi_yz, s->yz)) << 1;
    return low | high << 3;
#else
    vec3 c = s->c;
    return (unsigned)(b->lo.x <= c.x) | (unsigned)(b->lo.y <= c.y) << 1 | (unsigned)(b->lo.z <= c.z) << 2 |
           (unsigned)(b->hi.x >= c.x) << 3 | (unsigned)(b->hi.y >= c.y) << 4 | (unsigned)(b->hi.z >= c.z) << 5;
#endif
}

/* The children a new interior node's items touch, exactly: reach[i] gets bit k when item
 * i touches the seed's octant k, and count[k] how many items child k takes. A child the
 * item's bounds do not reach is not touched; tri_box_children_proven settles most of the
 * rest with comparisons; only the other children it reaches take the full test, prepared
 * once for all of them. The child boxes are box_octant's (the same split, the same
 * box_child), the ones the children are built with. */
static void compute_reach(const build_ctx *ctx, const uint32_t *items, uint32_t n, box3 box, uint8_t *reach,
                          uint32_t count[8])
{
    vec3 c = octree_split_point(ctx->tree, box);
    box3 child[8];
    for (int k = 0; k < 8; k++) {
        child[k] = box_child(box, c, box_octant_upper_bits[k]);
        count[k] = 0;
    }
    split_lanes lanes_c = split_lanes_of(c);
    for (uint32_t done = 0; done < n;) {
        /* Byte lanes hold up to 255: counts are carried out every 255 items. */
        uint32_t stop = n - done > 255 ? done + 255 : n;
        uint64_t lanes = 0;
        for (uint32_t i = done; i < stop; i++) {
            const triangle_bounds b = ctx->bounds[items[i]];
            unsigned r = ctx->reach_of_index[bounds_reach_index(&b, &lanes_c)];
            if (r & (r - 1)) {
                const vec3 *tri = ctx->tree->triangles[items[i]];
                unsigned open = r & ~tri_box_children_proven(tri, box, c, r);
                if (open) {
                    tri_box_triangle t;
                    tri_box_prepare(&t, tri);
                    r &= ~(open & ~tri_box_children_touched(&t, child, open));
                }
            }
            reach[i] = (uint8_t)r;
            lanes += spread8[r];
        }
        for (int k = 0; k < 8; k++)
            count[k] += (uint32_t)(lanes >> 8 * k) & 0xff;
        done = stop;
    }
}

/* Writes each item into the lists of the children its reach byte names (first[k]: where
 * child k's list starts in out), keeping the node's order within each list. */
static void split_items(const uint32_t *items, const uint8_t *reach, uint32_t n, const uint32_t first[8],
                        uint32_t *out)
{
    uint32_t at[8];
    memcpy(at, first, sizeof at);
    for (uint32_t i = 0; i < n; i++) {
        unsigned r = reach[i];
        while (r) {
            out[at[__builtin_ctz(r)]++] = items[i];
            r &= r - 1;
        }
    }
}

/* Children blocks start at node indices that are multiples of 8, in an array aligned to
 * 64 bytes: each block of eight 8-byte nodes is then exactly one cache line, and a query
 * expanding a node misses once instead of twice. The root is alone at index 0, so the
 * first block is placed at 8 and slots 1-7 stay unused (OCTREE_BLOCK_PADDING). */
#define OCTREE_BLOCK_PADDING 7

static int add_children(build_ctx *ctx, uint32_t parent_node)
{
    octree *tree = ctx->tree;
    if (tree->node_count == 1) { /* the root's block: skip to index 8 */
        for (size_t k = 1; k <= OCTREE_BLOCK_PADDING; k++)
            tree->nodes[k] = (octree_node){0, 0};
        tree->node_count += OCTREE_BLOCK_PADDING;
    }
    if (tree->node_count + 8 > UINT32_MAX - 1)
        return -1;
    if (tree->node_count + 8 > ctx->node_capacity) {
        size_t cap = ctx->node_capacity * 2;
        size_t grown = (cap - ctx->node_capacity) * sizeof *tree->nodes;
        if (budget_take(ctx, grown) != 0)
            return -3;
        octree_node *nodes = realloc(tree->nodes, cap * sizeof *nodes);
        if (!nodes) {
            budget_give_back(ctx, grown);
            return -2;
        }
        tree->nodes = nodes;
        ctx->node_capacity = cap;
    }
    tree->nodes[parent_node] = (octree_node){(uint32_t)tree->node_count, NODE_INTERIOR};
    for (int k = 0; k < 8; k++)
        tree->nodes[tree->node_count + (size_t)k] = (octree_node){0, 0};
    tree->node_count += 8;
    return 0;
}

static void release_list(build_ctx *ctx, shared_list *list)
{
    if (list && --list->pending_children == 0) {
        budget_give_back(ctx, list->bytes);
        free(list->items);
        free(list);
    }
}

/* The seed's construction loop. */
static octree_status build_nodes(build_ctx *ctx, int max_level)
{
    octree *tree = ctx->tree;
    u32_array leaves = {0};
    /* The reach bytes of the node being split, reused from node to node. */
    uint8_t *reach = NULL;
    size_t reach_capacity = 0;
    octree_status status = OCTREE_OK;

    /* The root's "parent list" is every triangle. */
    size_t all_bytes = sizeof(shared_list) + (tree->triangle_count ? tree->triangle_count : 1) * sizeof(uint32_t);
    if (budget_take(ctx, all_bytes) != 0)
        return OCTREE_ERR_BUDGET;
    shared_list *all = calloc(1, sizeof *all);
    if (!all)
        return OCTREE_ERR_NOMEM;
    all->bytes = all_bytes;
    all->count[0] = (uint32_t)tree->triangle_count;
    all->pending_children = 1;
    all->items = malloc((tree->triangle_count ? tree->triangle_count : 1) * sizeof *all->items);
    if (!all->items) {
        free(all);
        return OCTREE_ERR_NOMEM;
    }
    for (uint32_t i = 0; i < all->count[0]; i++)
        all->items[i] = i;

    build_entry stack[OCTREE_STACK_MAX];
    size_t top = 0;
    stack[top++] = (build_entry){0, 0, 0, tree->world, all};
    tree->nodes[0] = (octree_node){0, 0};
    tree->node_count = 1;

    while (top > 0) {
        build_entry e = stack[--top];
        const uint32_t *items = e.parent->items + e.parent->first[e.octant];
        uint32_t count = e.parent->count[e.octant];

        if (count == 0 || e.level >= max_level) {
            if ((status = u32_reserve(ctx, &leaves, count)) != OCTREE_OK) {
                release_list(ctx, e.parent);
                goto unwind;
            }
            if (leaves.count + count > UINT32_MAX - 1) {
                release_list(ctx, e.parent);
                status = OCTREE_ERR_TOO_BIG;
                goto unwind;
            }
            tree->nodes[e.node] = (octree_node){(uint32_t)leaves.count, count};
            if (count) /* an empty leaf may come before any list exists */
                memcpy(leaves.items + leaves.count, items, count * sizeof *items);
            leaves.count += count;
            release_list(ctx, e.parent);
            continue;
        }

        if (count > reach_capacity) {
            size_t cap = array_grown_capacity(reach_capacity, count, 1, 4096);
            uint8_t *grown = NULL;
            if (budget_take(ctx, cap - reach_capacity) != 0)
                status = OCTREE_ERR_BUDGET;
            else if (!(grown = realloc(reach, cap))) {
                budget_give_back(ctx, cap - reach_capacity);
                status = OCTREE_ERR_NOMEM;
            }
            if (status != OCTREE_OK) {
                release_list(ctx, e.parent);
                goto unwind;
            }
            reach = grown;
            reach_capacity = cap;
        }
        uint32_t child_count[8];
        compute_reach(ctx, items, count, e.box, reach, child_count);

        size_t total = 0;
        for (int k = 0; k < 8; k++)
            total += child_count[k];
        size_t bytes = sizeof(shared_list) + (total ? total : 1) * sizeof(uint32_t);
        shared_list *list = NULL;
        if (total > UINT32_MAX - 1)
            status = OCTREE_ERR_TOO_BIG;
        else if (budget_take(ctx, bytes) != 0)
            status = OCTREE_ERR_BUDGET;
        else if (!(list = malloc(sizeof *list)) || !(list->items = malloc((total ? total : 1) * sizeof *list->items))) {
            free(list);
            list = NULL;
            budget_give_back(ctx, bytes);
            status = OCTREE_ERR_NOMEM;
        }
        if (!list) {
            release_list(ctx, e.parent);
            goto unwind;
        }
        list->bytes = bytes;
        list->pending_children = 8;
        uint32_t at = 0;
        for (int k = 0; k < 8; k++) {
            list->first[k] = at;
            list->count[k] = child_count[k];
            at += child_count[k];
        }
        split_items(items, reach, count, list->first, list->items);
        release_list(ctx, e.parent);

        int added = add_children(ctx, e.node);
        if (added != 0) {
            budget_give_back(ctx, list->bytes);
            free(list->items);
            free(list);
            status = added == -1 ? OCTREE_ERR_TOO_BIG : added == -3 ? OCTREE_ERR_BUDGET : OCTREE_ERR_NOMEM;
            goto unwind;
        }
        uint32_t first = tree->nodes[e.node].first;
        vec3 c = octree_split_point(tree, e.box);
        /* Octants pushed 1..8, so the stack pops them 8..1, as the seed's loop does. */
        for (int k = 0; k < 8; k++)
            stack[top++] = (build_entry){first + (uint32_t)k, e.level + 1, k,
                                         box_child(e.box, c, box_octant_upper_bits[k]), list};
    }

    budget_give_back(ctx, reach_capacity);
    free(reach);
    tree->leaf_items = leaves.items ? leaves.items : malloc(sizeof(uint32_t));
    tree->info.leaf_refs = leaves.count;
    if (!tree->leaf_items)
        return OCTREE_ERR_NOMEM;
    if (leaves.items && leaves.count < leaves.capacity) {
        uint32_t *shrunk = realloc(leaves.items, (leaves.count ? leaves.count : 1) * sizeof *shrunk);
        if (shrunk) {
            tree->leaf_items = shrunk;
            budget_give_back(ctx, (leaves.capacity - (leaves.count ? leaves.count : 1)) * sizeof *shrunk);
        }
    }
    return OCTREE_OK;

unwind:
    while (top > 0)
        release_list(ctx, stack[--top].parent);
    free(reach);
    free(leaves.items);
    return status;
}

/* The seed's heuristic: the side of a square whose area is the mean of |E2 x E0| (twice
 * the triangle areas). A world of zero-area triangles has no such scale; the mean edge
 * length stands in for it, and a world of coincident points gets one leaf. */
static double heuristic_resolution(const octree *tree)
{
    double area_sum = 0.0, edge_sum = 0.0;
    for (size_t i = 0; i < tree->triangle_count; i++) {
        const vec3 *t = tree->triangles[i];
        vec3 e0 = vec3_sub(t[1], t[0]), e2 = vec3_sub(t[0], t[2]);
        area_sum += vec3_length(vec3_cross(e2, e0));
        edge_sum += vec3_length(e0) + vec3_length(vec3_sub(t[2], t[1])) + vec3_length(e2);
    }
    double n = (double)tree->triangle_count;
    double d = sqrt(area_sum / n);
    if (!(d > 0.0) || !isfinite(d))
        d = edge_sum / (3.0 * n);
    return d;
}

static octree_status copy_mesh(octree *tree, const mesh_view *mesh, octree_error *err)
{
    tree->triangle_count = mesh->triangle_count;
    tree->triangles = malloc(mesh->triangle_count * sizeof *tree->triangles);
    if (!tree->triangles) {
        fail(err, OCTREE_ERR_NOMEM, SIZE_MAX, "out of memory copying %zu triangles", mesh->triangle_count);
        return OCTREE_ERR_NOMEM;
    }
    for (size_t i = 0; i < mesh->triangle_count; i++) {
        for (int k = 0; k < 3; k++) {
            uint32_t v = mesh->indices[3 * i + (size_t)k];
            if (v >= mesh->vertex_count) {
                fail(err, OCTREE_ERR_INDEX, i, "triangle %zu refers to vertex %u of %zu", i, v,
                     mesh->vertex_count);
                return OCTREE_ERR_INDEX;
            }
            if (!vec3_is_finite(mesh->vertices[v])) {
                fail(err, OCTREE_ERR_NONFINITE, i, "triangle %zu has a NaN or infinite coordinate (vertex %u)", i, v);
                return OCTREE_ERR_NONFINITE;
            }
            tree->triangles[i][k] = mesh->vertices[v];
        }
    }
    return OCTREE_OK;
}

/* The smallest double at or above the real a + b (finite a, b); DBL_MAX in place of an
 * overflow to +infinity, which is still at or above any finite bound the caller needs. */
static double sum_rounded_up(double a, double b)
{
    double s, err;
    two_sum(a, b, &s, &err);
    if (isinf(s))
        return s > 0 ? DBL_MAX : -DBL_MAX;
    return err > 0 ? nextafter(s, INFINITY) : s;
}

/* The smallest double at or above the real a - b (finite a, b). */
static double difference_rounded_up(double a, double b)
{
    double s, err;
    two_diff(a, b, &s, &err);
    if (isinf(s))
        return s;
    return err > 0 ? nextafter(s, INFINITY) : s;
}

/* Spreads the low 10 bits of v to every third bit. */
static uint32_t spread_bits(uint32_t v)
{
    v &= 0x3ff;
    v = (v | v << 16) & 0x030000ff;
    v = (v | v << 8) & 0x0300f00f;
    v = (v | v << 4) & 0x030c30c3;
    v = (v | v << 2) & 0x09249249;
    return v;
}

typedef struct keyed_id {
    uint32_t key;
    uint32_t id;
} keyed_id;

/* Renumbers the triangles in Morton order of their centroids (see octree_internal.h). The
 * order only affects speed: every decision is made on the same triangles either way. */
static octree_status reorder_triangles(octree *tree, vec3 lo, vec3 hi)
{
    size_t n = tree->triangle_count;
    keyed_id *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
    vec3(*sorted)[3] = malloc(n * sizeof *sorted);
    tree->original_id = malloc(n * sizeof *tree->original_id);
    if (!a || !b || !sorted || !tree->original_id) {
        free(a);
        free(b);
        free(sorted);
        return OCTREE_ERR_NOMEM;
    }
    vec3 ext = vec3_sub(hi, lo);
    /* 1024 cells a side: finer orders gain nothing measurable for caches and cost sort
     * passes. */
    double scale[3] = {ext.x > 0 ? 1023.0 / ext.x : 0, ext.y > 0 ? 1023.0 / ext.y : 0, ext.z > 0 ? 1023.0 / ext.z : 0};
    for (size_t i = 0; i < n; i++) {
        const vec3 *t = tree->triangles[i];
        vec3 c = vec3_scale(vec3_add(vec3_add(t[0], t[1]), t[2]), 1.0 / 3.0);
        double q[3] = {(c.x - lo.x) * scale[0], (c.y - lo.y) * scale[1], (c.z - lo.z) * scale[2]};
        uint32_t cell[3];
        for (int k = 0; k < 3; k++)
            cell[k] = q[k] <= 0 ? 0 : q[k] >= 1023.0 ? 1023 : (uint32_t)q[k];
        a[i] = (keyed_id){spread_bits(cell[0]) | spread_bits(cell[1]) << 1 | spread_bits(cell[2]) << 2, (uint32_t)i};
    }
    /* LSD radix sort, 10 bits a pass over the 30-bit key; stable, so equal keys keep the
     * caller's order and the build is deterministic. */
    for (int shift = 0; shift < 30; shift += 10) {
        size_t count[1025] = {0};
        for (size_t i = 0; i < n; i++)
            count[((a[i].key >> shift) & 0x3ff) + 1]++;
        for (int d = 0; d < 1024; d++)
            count[d + 1] += count[d];
        for (size_t i = 0; i < n; i++)
            b[count[(a[i].key >> shift) & 0x3ff]++] = a[i];
        keyed_id *swap = a;
        a = b;
        b = swap;
    }
    for (size_t i = 0; i < n; i++) {
        memcpy(sorted[i], tree->triangles[a[i].id], sizeof sorted[i]);
        tree->original_id[i] = a[i].id;
    }
    free(tree->triangles);
    tree->triangles = sorted;
    free(a);
    free(b);
    return OCTREE_OK;
}

/* Replaces the build's side-by-side copy of the triangles by the vertices they use and
 * each one's corner indices, from the caller's mesh through original_id (so each caller
 * vertex is kept once). Vertices are numbered in the order the triangles (in their Morton
 * order) first use them. The budget is checked for the peak, while both forms are held. */
static octree_status index_triangles(build_ctx *ctx, const mesh_view *mesh)
{
    octree *tree = ctx->tree;
    size_t n = tree->triangle_count;
    size_t peak = mesh->vertex_count * (sizeof(uint32_t) + sizeof(vec3)) + n * sizeof *tree->corners;
    if (budget_take(ctx, peak) != 0)
        return OCTREE_ERR_BUDGET;
    uint32_t *number = malloc(mesh->vertex_count * sizeof *number);
    /* Where queries read them at random (hot_memory.h), from the start: no copy later. */
    tree->corners = hot_alloc((n ? n : 1) * sizeof *tree->corners);
    vec3 *used = malloc(mesh->vertex_count * sizeof *used);
    if (!number || !tree->corners || !used) {
        free(number);
        free(used);
        return OCTREE_ERR_NOMEM;
    }
    memset(number, 0xff, mesh->vertex_count * sizeof *number);
    size_t count = 0;
    for (size_t i = 0; i < n; i++) {
        const uint32_t *in = &mesh->indices[3 * (size_t)tree->original_id[i]];
        for (int k = 0; k < 3; k++) {
            uint32_t v = in[k];
            if (number[v] == UINT32_MAX) {
                number[v] = (uint32_t)count;
                used[count++] = mesh->vertices[v];
            }
            tree->corners[i][k] = number[v];
        }
    }
    free(number);
    /* Sized to what is used (a mesh may carry vertices no triangle names). */
    vec3 *fit = realloc(used, (count ? count : 1) * sizeof *fit);
    tree->vertices = fit ? fit : used;
    tree->used_vertex_count = count;
    free(tree->triangles);
    tree->triangles = NULL;
    ctx->held -= peak - count * sizeof(vec3) - n * sizeof *tree->corners;
    ctx->held -= n * sizeof(vec3[3]);
    return OCTREE_OK;
}

/* The bounds of node's triangles within its box (bounds: each triangle's, by internal id);
 * an empty node's are inverted (lo > hi). */
static box3 node_bounds_of(octree *tree, const triangle_bounds *bounds, uint32_t node, box3 cell)
{
    octree_node n = tree->nodes[node];
    box3 b = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    if (n.count == NODE_INTERIOR) {
        vec3 c = octree_split_point(tree, cell);
        for (int k = 0; k < 8; k++) {
            box3 kb = node_bounds_of(tree, bounds, n.first + (uint32_t)k, box_child(cell, c, box_octant_upper_bits[k]));
            b.lo = vec3_min(b.lo, kb.lo);
            b.hi = vec3_max(b.hi, kb.hi);
        }
    } else if (n.count) {
        for (uint32_t i = 0; i < n.count; i++) {
            const triangle_bounds *t = &bounds[tree->leaf_items[n.first + i]];
            b.lo = vec3_min(b.lo, t->lo);
            b.hi = vec3_max(b.hi, t->hi);
        }
        b = (box3){vec3_max(b.lo, cell.lo), vec3_min(b.hi, cell.hi)};
    }
    tree->node_bounds[node] = b;
    return b;
}

/* The blocks of eight nodes octree.child_lanes holds (at least one, so the array is never
 * empty). */
static size_t child_lane_blocks(size_t node_count)
{
    return node_count / 8 ? node_count / 8 : 1;
}

/* octree_def.node_bounds: one walk over the finished tree (its depth is at most
 * OCTREE_MAX_DEPTH_CAP, so the recursion is shallow). */
static octree_status compute_node_bounds(octree *tree, const triangle_bounds *bounds)
{
    tree->node_bounds = malloc(tree->node_count * sizeof *tree->node_bounds);
    if (!tree->node_bounds)
        return OCTREE_ERR_NOMEM;
    for (size_t i = 0; i < tree->node_count; i++)
        tree->node_bounds[i] = (box3){{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    node_bounds_of(tree, bounds, 0, tree->world);
    size_t blocks = child_lane_blocks(tree->node_count);
    tree->child_lanes = malloc(blocks * sizeof *tree->child_lanes);
    if (!tree->child_lanes)
        return OCTREE_ERR_NOMEM;
    /* Block 0 holds the root alone (OCTREE_BLOCK_PADDING): no node has it as children. */
    memset(&tree->child_lanes[0], 0, sizeof tree->child_lanes[0]);
    for (size_t b = 1; b < blocks; b++)
        child_lanes_of(&tree->node_bounds[8 * b], &tree->nodes[8 * b], &tree->child_lanes[b]);
    return OCTREE_OK;
}

octree *octree_build(const mesh_view *mesh, const octree_def *def_in, octree_error *err)
{
    double started = seconds_now();
    octree_def def = def_in ? *def_in : octree_default_def();
    if (err)
        *err = (octree_error){OCTREE_OK, SIZE_MAX, ""};
    if (!mesh || (mesh->triangle_count && (!mesh->indices || !mesh->vertices)))
        return fail(err, OCTREE_ERR_INVALID, SIZE_MAX, "no mesh given");
    if (mesh->triangle_count == 0)
        return fail(err, OCTREE_ERR_EMPTY, SIZE_MAX, "the mesh has no triangles");
    if (mesh->triangle_count >= UINT32_MAX || mesh->vertex_count >= UINT32_MAX)
        return fail(err, OCTREE_ERR_TOO_BIG, SIZE_MAX, "%zu triangles, %zu vertices: the engine addresses fewer than 2^32",
                    mesh->triangle_count, mesh->vertex_count);
    if (def.max_depth < 0 || def.max_depth > OCTREE_MAX_DEPTH_CAP)
        return fail(err, OCTREE_ERR_INVALID, SIZE_MAX, "max_depth %d is outside 0..%d", def.max_depth,
                    OCTREE_MAX_DEPTH_CAP);
    if (def.mode != ACCURACY_EXACT && def.mode != ACCURACY_SEED && def.mode != ACCURACY_FAST)
        return fail(err, OCTREE_ERR_INVALID, SIZE_MAX, "unknown accuracy mode %d", (int)def.mode);
    if (!isfinite(def.resolution) || (def.mode == ACCURACY_SEED && !(def.seed_epsilon >= 0.0 && isfinite(def.seed_epsilon))))
        return fail(err, OCTREE_ERR_INVALID, SIZE_MAX, "resolution and seed epsilon must be finite (epsilon >= 0)");
    if (def.triangle_boxes != 0 && def.triangle_boxes != 1)
        return fail(err, OCTREE_ERR_INVALID, SIZE_MAX, "triangle_boxes %d is neither 0 nor 1", def.triangle_boxes);
    if (def.plain_walk != 0 && def.plain_walk != 1)
        return fail(err, OCTREE_ERR_INVALID, SIZE_MAX, "plain_walk %d is neither 0 nor 1", def.plain_walk);
    if (def.node_bounds != 0 && def.node_bounds != 1)
        return fail(err, OCTREE_ERR_INVALID, SIZE_MAX, "node_bounds %d is neither 0 nor 1", def.node_bounds);
    if (def.node_slabs != 0 && def.node_slabs != 1)
        return fail(err, OCTREE_ERR_INVALID, SIZE_MAX, "node_slabs %d is neither 0 nor 1", def.node_slabs);

    /* The budget, and what the build holds before its first node: at its peak (the Morton
     * renumbering holds two copies of the triangles and two key arrays beside the bounds),
     * then for the rest of the build (one copy, the ids, the bounds, the boxes). */
    size_t n = mesh->triangle_count;
    size_t budget = def.budget_bytes ? def.budget_bytes : octree_default_budget(n);
    size_t peak = sizeof(octree) + n * (2 * sizeof(vec3[3]) + 2 * sizeof(keyed_id) + sizeof(uint32_t) +
                                        sizeof(triangle_bounds));
    size_t steady = sizeof(octree) + 1024 * sizeof(octree_node) +
                    n * (sizeof(vec3[3]) + sizeof(uint32_t) + sizeof(triangle_bounds) +
                         (def.triangle_boxes ? sizeof(triangle_box) : 0));
    if (peak > budget || steady > budget)
        return fail(err, OCTREE_ERR_BUDGET, SIZE_MAX,
                    "the build needs %zu bytes for its copy of %zu triangles, over its budget of %zu bytes",
                    peak > steady ? peak : steady, n, budget);

    octree *tree = calloc(1, sizeof *tree);
    if (!tree)
        return fail(err, OCTREE_ERR_NOMEM, SIZE_MAX, "out of memory");
    /* The copy's peak, taken before it is made; what is more than the steady part goes back
     * once the renumbering is done. */
    size_t first = peak > steady ? peak : steady;
    if (def.account) {
        if (memory_account_take(def.account, first) != 0) {
            size_t left = memory_account_left(def.account);
            free(tree);
            return fail(err, OCTREE_ERR_BUDGET, SIZE_MAX,
                        "the build needs %zu bytes for its copy of %zu triangles; the memory budget of %zu bytes has %zu left",
                        first, n, def.account->limit, left);
        }
        tree->account = def.account;
        tree->accounted = first;
    }
    octree_status st = copy_mesh(tree, mesh, err);
    if (st != OCTREE_OK) {
        octree_free(tree);
        return NULL;
    }

    /* World bounds, the Morton renumbering, and each triangle's bounds for the build's
     * cheap exact tests. */
    vec3 lo = tree->triangles[0][0], hi = lo;
    for (size_t i = 0; i < tree->triangle_count; i++)
        for (int k = 0; k < 3; k++) {
            lo = vec3_min(lo, tree->triangles[i][k]);
            hi = vec3_max(hi, tree->triangles[i][k]);
        }
    build_ctx ctx = {.tree = tree, .def = &def, .budget = budget, .held = steady};
    for (unsigned i = 0; i < 64; i++)
        ctx.reach_of_index[i] = box_octants_by_half[0][(i & 1) | (i >> 3 & 1) << 1] &
                                box_octants_by_half[1][(i >> 1 & 1) | (i >> 4 & 1) << 1] &
                                box_octants_by_half[2][(i >> 2 & 1) | (i >> 5 & 1) << 1];
    ctx.bounds = malloc(tree->triangle_count * sizeof *ctx.bounds);
    if (!ctx.bounds || reorder_triangles(tree, lo, hi) != OCTREE_OK) {
        free(ctx.bounds);
        octree_free(tree);
        return fail(err, OCTREE_ERR_NOMEM, SIZE_MAX, "out of memory");
    }
    for (size_t i = 0; i < tree->triangle_count; i++) {
        const vec3 *t = tree->triangles[i];
        ctx.bounds[i] = (triangle_bounds){vec3_min(vec3_min(t[0], t[1]), t[2]), vec3_max(vec3_max(t[0], t[1]), t[2])};
    }
    settle_account(tree, steady);
    /* Rounded up: the cube's side D >= extent must hold for the real extent, which a
     * rounded-to-nearest difference may fall short of by half an ulp. */
    double extent = fmax(difference_rounded_up(hi.x, lo.x),
                         fmax(difference_rounded_up(hi.y, lo.y), difference_rounded_up(hi.z, lo.z)));
    if (!isfinite(extent)) {
        free(ctx.bounds);
        octree_free(tree);
        return fail(err, OCTREE_ERR_INVALID, SIZE_MAX, "the mesh extent overflows a double");
    }

    int explicit_resolution = def.resolution > 0.0;
    double d = explicit_resolution ? def.resolution : heuristic_resolution(tree);
    if (!(d > 0.0) || !isfinite(d))
        d = extent > 0.0 ? extent : 1.0;
    /* L_max = ceil(log2(D / d)) by doubling, which is exact where log2 would round. */
    int levels = 0;
    while (ldexp(d, levels) < extent && levels <= def.max_depth)
        levels++;
    int clamped = 0;
    if (levels > def.max_depth) {
        if (explicit_resolution) {
            free(ctx.bounds);
            octree_free(tree);
            return fail(err, OCTREE_ERR_DEPTH, SIZE_MAX,
                        "resolution %g over a world of size %g needs more than %d levels (the cap); use a resolution of at least %g",
                        def.resolution, extent, def.max_depth, ldexp(extent, -def.max_depth));
        }
        levels = def.max_depth;
        d = ldexp(extent, -levels); /* exact: a power-of-two scaling, so 2^L d == D */
        clamped = 1;
    }
    double size = ldexp(d, levels);
    /* The upper corner is lo + D rounded up on each axis: it lies at or above the real
     * lo + D, which is at or above every vertex since D >= the real extent. Rounded to
     * nearest it can land one ulp below the largest coordinate (when D equals the extent),
     * and a query touching the mesh on that face would then lie outside the root. */
    tree->world = (box3){lo, vec3_make(sum_rounded_up(lo.x, size), sum_rounded_up(lo.y, size),
                                       sum_rounded_up(lo.z, size))};
    tree->splits_in_range = fabs(tree->world.lo.x) <= DBL_MAX / 2 && fabs(tree->world.lo.y) <= DBL_MAX / 2 &&
                            fabs(tree->world.lo.z) <= DBL_MAX / 2 && fabs(tree->world.hi.x) <= DBL_MAX / 2 &&
                            fabs(tree->world.hi.y) <= DBL_MAX / 2 && fabs(tree->world.hi.z) <= DBL_MAX / 2;

    /* Only triangle and mesh queries read the boxes; a world that asks for neither does
     * not pay for them. */
    if (def.triangle_boxes) {
        tree->triangle_boxes = malloc(tree->triangle_count * sizeof *tree->triangle_boxes);
        if (!tree->triangle_boxes) {
            free(ctx.bounds);
            octree_free(tree);
            return fail(err, OCTREE_ERR_NOMEM, SIZE_MAX, "out of memory");
        }
        for (size_t i = 0; i < tree->triangle_count; i++)
            tree->triangle_boxes[i] = triangle_box_around(ctx.bounds[i].lo, ctx.bounds[i].hi, tree->world.lo);
    }

    ctx.node_capacity = 1024;
    tree->nodes = malloc(ctx.node_capacity * sizeof *tree->nodes);
    if (!tree->nodes) {
        free(ctx.bounds);
        octree_free(tree);
        return fail(err, OCTREE_ERR_NOMEM, SIZE_MAX, "out of memory");
    }
    st = build_nodes(&ctx, levels);
    if (st == OCTREE_OK && def.node_bounds)
        st = budget_take(&ctx, tree->node_count * sizeof *tree->node_bounds +
                                   child_lane_blocks(tree->node_count) * sizeof *tree->child_lanes) != 0
                 ? OCTREE_ERR_BUDGET
                 : compute_node_bounds(tree, ctx.bounds);
    if (st == OCTREE_OK)
        st = index_triangles(&ctx, mesh);
    if (st == OCTREE_OK && def.node_slabs)
        st = budget_take(&ctx, octree_owned_bytes(tree->node_count, tree->triangle_count)) != 0 ? OCTREE_ERR_BUDGET
                                                                                              : octree_owned_build(tree);
    if (st == OCTREE_OK && def.node_slabs)
        st = budget_take(&ctx, tree->node_count * sizeof *tree->node_slabs) != 0 ? OCTREE_ERR_BUDGET
                                                                               : octree_slabs_build(tree);
    /* The final array, 64-byte aligned (realloc keeps no alignment, so the build grows a
     * plain array and copies it once). aligned_alloc wants a multiple of the alignment. */
    size_t node_bytes = (tree->node_count * sizeof(octree_node) + 63) & ~(size_t)63;
    if (st == OCTREE_OK)
        st = octree_modes_prepare(tree);
    if (st == OCTREE_OK && budget_take(&ctx, node_bytes) != 0)
        st = OCTREE_ERR_BUDGET;
    if (st == OCTREE_ERR_BUDGET) {
        size_t nodes = tree->node_count;
        free(ctx.bounds);
        octree_free(tree);
        if (ctx.account_full)
            return fail(err, st, SIZE_MAX,
                        "the build held %zu bytes and asked for %zu more, at %zu nodes; the memory budget of %zu bytes "
                        "has %zu left",
                        ctx.held, ctx.asked, nodes, def.account->limit, memory_account_left(def.account));
        return fail(err, st,
                    SIZE_MAX, "the build needs more than its budget of %zu bytes: it held %zu and asked for %zu more, at %zu nodes",
                    budget, ctx.held, ctx.asked, nodes);
    }
    if (st != OCTREE_OK) {
        free(ctx.bounds);
        octree_free(tree);
        return fail(err, st, SIZE_MAX, "building the octree: %s", octree_status_text(st));
    }
    octree_node *aligned = hot_alloc(node_bytes);
    if (!aligned) {
        free(ctx.bounds);
        octree_free(tree);
        return fail(err, OCTREE_ERR_NOMEM, SIZE_MAX, "out of memory");
    }
    memcpy(aligned, tree->nodes, tree->node_count * sizeof(octree_node));
    free(tree->nodes);
    tree->nodes = aligned;

    /* The compiled traversal form, a second stage after the seed's build (one record an
     * interior node). It only makes rays faster, so a build whose budget cannot hold it, or
     * a world outside its float range, goes without: rays then take the double walk. */
    size_t interior = 0;
    for (size_t i = 0; i < tree->node_count; i++)
        interior += tree->nodes[i].count == NODE_INTERIOR;
    /* The triangles' bounds, which the budget counted for the whole build, are kept until
     * here: the compile takes a leaf's content bounds from them instead of reading each
     * listed triangle's vertices again. */
    int form_status = !def.plain_walk && budget_take(&ctx, interior * sizeof(traversal_node) + 64) == 0
                          ? traversal_form_build(tree, ctx.bounds, &tree->traversal)
                          : 0;
    free(ctx.bounds);
    if (form_status < 0) {
        octree_free(tree);
        return fail(err, OCTREE_ERR_NOMEM, SIZE_MAX, "out of memory");
    }
    size_t padding = tree->node_count > 1 ? OCTREE_BLOCK_PADDING : 0;
    /* What queries read at random, onto huge pages where there are any (hot_memory.h). */
    hot_move((void **)&tree->vertices, tree->used_vertex_count * sizeof *tree->vertices);
    hot_move((void **)&tree->leaf_items, (tree->info.leaf_refs + tree->sliver_list_count) * sizeof *tree->leaf_items);

    octree_info *info = &tree->info;
    info->triangle_count = tree->triangle_count;
    info->vertex_count = mesh->vertex_count;
    info->node_count = tree->node_count - padding;
    for (size_t i = 0; i < tree->node_count; i++) {
        if (tree->nodes[i].count == NODE_INTERIOR || (i >= 1 && i <= padding))
            continue;
        info->leaf_count++;
        info->nonempty_leaf_count += tree->nodes[i].count > 0;
    }
    info->max_level = levels;
    info->depth_clamped = clamped;
    info->resolution = d;
    info->world_size = size;
    info->world_min = lo;
    info->bytes_nodes = node_bytes;
    info->bytes_leaf_lists = (info->leaf_refs + tree->sliver_list_count) * sizeof(uint32_t);
    info->bytes_triangles = tree->triangle_count * (sizeof *tree->corners + sizeof *tree->original_id) +
                            tree->used_vertex_count * sizeof *tree->vertices;
    info->bytes_triangle_boxes = tree->triangle_boxes ? tree->triangle_count * sizeof *tree->triangle_boxes : 0;
    info->bytes_traversal = tree->traversal.bytes;
    info->bytes_node_slabs = tree->node_slabs ? tree->node_count * sizeof *tree->node_slabs +
                                                    octree_owned_bytes(tree->node_count, tree->triangle_count)
                                              : 0;
    info->bytes_node_bounds = tree->node_bounds ? tree->node_count * sizeof *tree->node_bounds +
                                                      child_lane_blocks(tree->node_count) * sizeof *tree->child_lanes
                                                : 0;
    info->bytes_total = info->bytes_nodes + info->bytes_leaf_lists + info->bytes_triangles +
                        info->bytes_triangle_boxes + info->bytes_node_bounds + info->bytes_node_slabs +
                        info->bytes_traversal +
                        sizeof *tree;
    info->mode = def.mode;
    settle_account(tree, info->bytes_total);
    tree->seed_epsilon = def.seed_epsilon;
    info->build_seconds = seconds_now() - started;
    return tree;
}

void octree_free(octree *tree)
{
    if (!tree)
        return;
    if (tree->account)
        memory_account_give(tree->account, tree->accounted);
    free(tree->triangles);
    free(tree->vertices);
    free(tree->corners);
    free(tree->original_id);
    free(tree->triangle_boxes);
    free(tree->node_bounds);
    free(tree->node_slabs);
    free(tree->owned);
    free(tree->owned_items);
    free(tree->owned_bounds);
    free(tree->child_lanes);
    free(tree->nodes);
    free(tree->leaf_items);
    traversal_form_free(&tree->traversal);
    free(tree);
}

box3 octree_world_box(const octree *tree)
{
    return tree->world;
}

void octree_get_info(const octree *tree, octree_info *info)
{
    *info = tree->info;
}
