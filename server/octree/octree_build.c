/* Building the fixed-resolution octree, in the seed document's shape: one node array, an
 * explicit stack, each node testing only its parent's triangle list. */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "../geom/box_geometry.h"
#include "../geom/tri_box.h"
#include "octree_internal.h"

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

octree_def octree_default_def(void)
{
    return (octree_def){
        .resolution = 0.0,
        .max_depth = OCTREE_DEFAULT_MAX_DEPTH,
        .mode = ACCURACY_EXACT,
        .seed_epsilon = OCTREE_DEFAULT_SEED_EPSILON,
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

static int u32_reserve(u32_array *a, size_t extra)
{
    if (a->count + extra <= a->capacity)
        return 0;
    size_t cap = a->capacity ? a->capacity : 64;
    while (cap < a->count + extra)
        cap *= 2;
    uint32_t *items = realloc(a->items, cap * sizeof *items);
    if (!items)
        return -1;
    a->items = items;
    a->capacity = cap;
    return 0;
}

/* A triangle list shared by the eight children that test it; freed when the last of them
 * has built its own list (the seed's "interior nodes' lists are released after use"). */
typedef struct shared_list {
    uint32_t *items;
    uint32_t count;
    int pending_children;
    box3 box; /* the box of the node that owns the list: every listed triangle touches it */
} shared_list;

typedef struct build_entry {
    uint32_t node;
    int level;
    box3 box;
    shared_list *parent;
} build_entry;

typedef struct triangle_bounds {
    vec3 lo, hi;
} triangle_bounds;

typedef struct build_ctx {
    octree *tree;
    const octree_def *def;
    triangle_bounds *bounds; /* per triangle, exact min/max of its vertices */
    size_t node_capacity;
} build_ctx;

/* Membership of triangle id in a node's closed box, in the tree's mode. In exact mode the
 * cheap box tests come first: they are exact comparisons and decide most triangles, and a
 * triangle known to touch the parent whose bounds, clipped to the parent, fit inside this
 * child touches this child (the touching point lies in that clipped region). */
static int triangle_in_node(const build_ctx *ctx, uint32_t id, box3 box, box3 parent)
{
    vec3 tri[3];
    if (ctx->def->mode != ACCURACY_EXACT) {
        octree_triangle_vertices(ctx->tree, id, tri);
        return ctx->def->mode == ACCURACY_SEED ? tri_box_overlap_seed(tri, box, ctx->def->seed_epsilon)
                                               : tri_box_overlap_fast(tri, box);
    }
    triangle_bounds b = ctx->bounds[id];
    if (b.lo.x > box.hi.x || b.lo.y > box.hi.y || b.lo.z > box.hi.z ||
        b.hi.x < box.lo.x || b.hi.y < box.lo.y || b.hi.z < box.lo.z)
        return 0;
    vec3 clo = vec3_max(b.lo, parent.lo), chi = vec3_min(b.hi, parent.hi);
    if (clo.x >= box.lo.x && clo.y >= box.lo.y && clo.z >= box.lo.z &&
        chi.x <= box.hi.x && chi.y <= box.hi.y && chi.z <= box.hi.z)
        return 1;
    /* Only triangles straddling a split plane reach the full test and its vertex loads. */
    octree_triangle_vertices(ctx->tree, id, tri);
    return tri_box_overlap_exact(tri, box);
}

static int add_children(build_ctx *ctx, uint32_t parent_node)
{
    octree *tree = ctx->tree;
    if (tree->node_count + 8 > UINT32_MAX - 1)
        return -1;
    if (tree->node_count + 8 > ctx->node_capacity) {
        size_t cap = ctx->node_capacity * 2;
        octree_node *nodes = realloc(tree->nodes, cap * sizeof *nodes);
        if (!nodes)
            return -2;
        tree->nodes = nodes;
        ctx->node_capacity = cap;
    }
    tree->nodes[parent_node] = (octree_node){(uint32_t)tree->node_count, NODE_INTERIOR};
    for (int k = 0; k < 8; k++)
        tree->nodes[tree->node_count + (size_t)k] = (octree_node){0, 0};
    tree->node_count += 8;
    return 0;
}

static void release_list(shared_list *list)
{
    if (list && --list->pending_children == 0) {
        free(list->items);
        free(list);
    }
}

/* The seed's construction loop. */
static octree_status build_nodes(build_ctx *ctx, int max_level)
{
    octree *tree = ctx->tree;
    u32_array leaves = {0};
    u32_array scratch = {0};
    octree_status status = OCTREE_OK;

    /* The root's "parent list" is every triangle. */
    shared_list *all = malloc(sizeof *all);
    if (!all)
        return OCTREE_ERR_NOMEM;
    all->count = (uint32_t)tree->triangle_count;
    all->pending_children = 1;
    all->box = tree->world;
    all->items = malloc((all->count ? all->count : 1) * sizeof *all->items);
    if (!all->items) {
        free(all);
        return OCTREE_ERR_NOMEM;
    }
    for (uint32_t i = 0; i < all->count; i++)
        all->items[i] = i;

    build_entry stack[OCTREE_STACK_MAX];
    size_t top = 0;
    stack[top++] = (build_entry){0, 0, tree->world, all};
    tree->nodes[0] = (octree_node){0, 0};
    tree->node_count = 1;

    while (top > 0) {
        build_entry e = stack[--top];
        scratch.count = 0;
        if (u32_reserve(&scratch, e.parent->count) != 0) {
            status = OCTREE_ERR_NOMEM;
            release_list(e.parent);
            goto unwind;
        }
        for (uint32_t i = 0; i < e.parent->count; i++) {
            uint32_t id = e.parent->items[i];
            if (triangle_in_node(ctx, id, e.box, e.parent->box))
                scratch.items[scratch.count++] = id;
        }
        release_list(e.parent);

        if (scratch.count == 0 || e.level >= max_level) {
            if (u32_reserve(&leaves, scratch.count) != 0) {
                status = OCTREE_ERR_NOMEM;
                goto unwind;
            }
            if (leaves.count + scratch.count > UINT32_MAX - 1) {
                status = OCTREE_ERR_TOO_BIG;
                goto unwind;
            }
            tree->nodes[e.node] = (octree_node){(uint32_t)leaves.count, (uint32_t)scratch.count};
            memcpy(leaves.items + leaves.count, scratch.items, scratch.count * sizeof *scratch.items);
            leaves.count += scratch.count;
            continue;
        }

        shared_list *list = malloc(sizeof *list);
        if (!list) {
            status = OCTREE_ERR_NOMEM;
            goto unwind;
        }
        list->items = scratch.items;
        list->count = (uint32_t)scratch.count;
        list->pending_children = 8;
        list->box = e.box;
        scratch = (u32_array){0};

        int added = add_children(ctx, e.node);
        if (added != 0) {
            free(list->items);
            free(list);
            status = added == -1 ? OCTREE_ERR_TOO_BIG : OCTREE_ERR_NOMEM;
            goto unwind;
        }
        uint32_t first = tree->nodes[e.node].first;
        /* Octants pushed 1..8, so the stack pops them 8..1, as the seed's loop does. */
        for (int k = 0; k < 8; k++)
            stack[top++] = (build_entry){first + (uint32_t)k, e.level + 1, box_octant(e.box, k), list};
    }

    free(scratch.items);
    tree->leaf_items = leaves.items ? leaves.items : malloc(sizeof(uint32_t));
    tree->leaf_item_count = leaves.count;
    if (!tree->leaf_items)
        return OCTREE_ERR_NOMEM;
    if (leaves.items && leaves.count < leaves.capacity) {
        uint32_t *shrunk = realloc(leaves.items, (leaves.count ? leaves.count : 1) * sizeof *shrunk);
        if (shrunk)
            tree->leaf_items = shrunk;
    }
    return OCTREE_OK;

unwind:
    while (top > 0)
        release_list(stack[--top].parent);
    free(scratch.items);
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
        vec3 t[3];
        octree_triangle_vertices(tree, (uint32_t)i, t);
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
    tree->vertex_count = mesh->vertex_count;
    tree->triangle_count = mesh->triangle_count;
    tree->vertices = malloc((mesh->vertex_count ? mesh->vertex_count : 1) * sizeof *tree->vertices);
    tree->indices = malloc(3 * mesh->triangle_count * sizeof *tree->indices);
    if (!tree->vertices || !tree->indices) {
        fail(err, OCTREE_ERR_NOMEM, SIZE_MAX, "out of memory copying %zu triangles", mesh->triangle_count);
        return OCTREE_ERR_NOMEM;
    }
    memcpy(tree->vertices, mesh->vertices, mesh->vertex_count * sizeof *tree->vertices);
    memcpy(tree->indices, mesh->indices, 3 * mesh->triangle_count * sizeof *tree->indices);
    for (size_t i = 0; i < mesh->triangle_count; i++) {
        for (int k = 0; k < 3; k++) {
            uint32_t v = tree->indices[3 * i + (size_t)k];
            if (v >= mesh->vertex_count) {
                fail(err, OCTREE_ERR_INDEX, i, "triangle %zu refers to vertex %u of %zu", i, v,
                     mesh->vertex_count);
                return OCTREE_ERR_INDEX;
            }
            if (!vec3_is_finite(tree->vertices[v])) {
                fail(err, OCTREE_ERR_NONFINITE, i, "triangle %zu has a NaN or infinite coordinate (vertex %u)", i, v);
                return OCTREE_ERR_NONFINITE;
            }
        }
    }
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

    octree *tree = calloc(1, sizeof *tree);
    if (!tree)
        return fail(err, OCTREE_ERR_NOMEM, SIZE_MAX, "out of memory");
    octree_status st = copy_mesh(tree, mesh, err);
    if (st != OCTREE_OK) {
        octree_free(tree);
        return NULL;
    }

    /* World bounds, and each triangle's bounds for the build's cheap exact tests. */
    build_ctx ctx = {.tree = tree, .def = &def};
    ctx.bounds = malloc(tree->triangle_count * sizeof *ctx.bounds);
    if (!ctx.bounds) {
        octree_free(tree);
        return fail(err, OCTREE_ERR_NOMEM, SIZE_MAX, "out of memory");
    }
    vec3 lo = tree->vertices[tree->indices[0]], hi = lo;
    for (size_t i = 0; i < tree->triangle_count; i++) {
        vec3 t[3];
        octree_triangle_vertices(tree, (uint32_t)i, t);
        triangle_bounds b = {vec3_min(vec3_min(t[0], t[1]), t[2]), vec3_max(vec3_max(t[0], t[1]), t[2])};
        ctx.bounds[i] = b;
        lo = vec3_min(lo, b.lo);
        hi = vec3_max(hi, b.hi);
    }
    double extent = fmax(hi.x - lo.x, fmax(hi.y - lo.y, hi.z - lo.z));
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
    /* Rounding lo + size is monotone, so the cube still encloses every vertex. */
    tree->world = (box3){lo, vec3_make(lo.x + size, lo.y + size, lo.z + size)};

    ctx.node_capacity = 1024;
    tree->nodes = malloc(ctx.node_capacity * sizeof *tree->nodes);
    if (!tree->nodes) {
        free(ctx.bounds);
        octree_free(tree);
        return fail(err, OCTREE_ERR_NOMEM, SIZE_MAX, "out of memory");
    }
    st = build_nodes(&ctx, levels);
    free(ctx.bounds);
    if (st != OCTREE_OK) {
        octree_free(tree);
        return fail(err, st, SIZE_MAX, "building the octree: %s", octree_status_text(st));
    }
    octree_node *shrunk = realloc(tree->nodes, tree->node_count * sizeof *shrunk);
    if (shrunk)
        tree->nodes = shrunk;

    octree_info *info = &tree->info;
    info->triangle_count = tree->triangle_count;
    info->vertex_count = tree->vertex_count;
    info->node_count = tree->node_count;
    for (size_t i = 0; i < tree->node_count; i++) {
        if (tree->nodes[i].count == NODE_INTERIOR)
            continue;
        info->leaf_count++;
        info->nonempty_leaf_count += tree->nodes[i].count > 0;
    }
    info->leaf_refs = tree->leaf_item_count;
    info->max_level = levels;
    info->depth_clamped = clamped;
    info->resolution = d;
    info->world_size = size;
    info->world_min = lo;
    info->bytes_nodes = tree->node_count * sizeof(octree_node);
    info->bytes_leaf_lists = tree->leaf_item_count * sizeof(uint32_t);
    info->bytes_triangles = tree->vertex_count * sizeof(vec3) + 3 * tree->triangle_count * sizeof(uint32_t);
    info->bytes_total = info->bytes_nodes + info->bytes_leaf_lists + info->bytes_triangles + sizeof *tree;
    info->mode = def.mode;
    tree->seed_epsilon = def.seed_epsilon;
    info->build_seconds = seconds_now() - started;
    return tree;
}

void octree_free(octree *tree)
{
    if (!tree)
        return;
    free(tree->vertices);
    free(tree->indices);
    free(tree->nodes);
    free(tree->leaf_items);
    free(tree);
}

void octree_get_info(const octree *tree, octree_info *info)
{
    *info = tree->info;
}
