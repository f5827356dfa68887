/* One probe point for each connected part of a tree's mesh (triangles joined through shared
 * vertices): what tells a shape lying wholly inside a solid from one outside it. A part
 * that touches no triangle of a closed surface lies wholly inside or wholly outside it, so
 * one vertex of it decides (docs/engine.md, "Solid objects"). */
#include <stdlib.h>

#include "octree_internal.h"

static uint32_t find_root(uint32_t *parent, uint32_t v)
{
    while (parent[v] != v) {
        parent[v] = parent[parent[v]];
        v = parent[v];
    }
    return v;
}

/* Vertices in coordinate order, so that equal ones (a mesh sent as separate triangles
 * repeats every vertex) are neighbours and join their parts too. Each key carries its
 * coordinates, so the comparison needs no shared state (queries run on many threads). */
typedef struct vertex_key {
    vec3 p;
    uint32_t index;
} vertex_key;

static int by_coordinates(const void *a, const void *b)
{
    vec3 p = ((const vertex_key *)a)->p, q = ((const vertex_key *)b)->p;
    if (p.x != q.x)
        return p.x < q.x ? -1 : 1;
    if (p.y != q.y)
        return p.y < q.y ? -1 : 1;
    return (p.z > q.z) - (p.z < q.z);
}

static void join(uint32_t *parent, uint32_t x, uint32_t y)
{
    uint32_t a = find_root(parent, x), b = find_root(parent, y);
    if (a != b)
        parent[a < b ? b : a] = a < b ? a : b;
}

size_t octree_component_points(const octree *tree, vec3 *points, uint32_t *triangles, size_t cap)
{
    size_t nv = tree->used_vertex_count;
    if (nv == 0 || tree->triangle_count == 0)
        return 0;
    uint32_t *parent = malloc(nv * sizeof *parent);
    if (!parent)
        return SIZE_MAX;
    for (size_t v = 0; v < nv; v++)
        parent[v] = (uint32_t)v;
    for (size_t t = 0; t < tree->triangle_count; t++) {
        const uint32_t *c = tree->corners[t];
        join(parent, c[0], c[1]);
        join(parent, c[0], c[2]);
    }
    vertex_key *order = malloc(nv * sizeof *order);
    if (!order) {
        free(parent);
        return SIZE_MAX;
    }
    for (size_t v = 0; v < nv; v++)
        order[v] = (vertex_key){tree->vertices[v], (uint32_t)v};
    qsort(order, nv, sizeof *order, by_coordinates);
    for (size_t k = 1; k < nv; k++)
        if (vec3_equal(order[k].p, order[k - 1].p))
            join(parent, order[k].index, order[k - 1].index);
    free(order);
    /* Each part once, at the first triangle (internal order) that has its root. */
    size_t count = 0;
    unsigned char *seen = calloc(nv, 1);
    if (!seen) {
        free(parent);
        return SIZE_MAX;
    }
    for (size_t t = 0; t < tree->triangle_count; t++) {
        uint32_t r = find_root(parent, tree->corners[t][0]);
        if (seen[r])
            continue;
        seen[r] = 1;
        if (count < cap) {
            points[count] = tree->vertices[tree->corners[t][0]];
            triangles[count] = tree->original_id[t];
        }
        count++;
    }
    free(seen);
    free(parent);
    return count;
}
