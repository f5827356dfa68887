/* Closed and consistently oriented, exactly (solid_check.h): vertices welded by their
 * coordinates' values, then every undirected edge counted per direction. */
#include "solid_check.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define EMPTY_SLOT UINT32_MAX

/* One undirected edge: its two welded ends (lo < hi) and how many triangles run it each
 * way. */
typedef struct edge_entry {
    uint64_t key; /* lo << 32 | hi; 0 is no edge, since lo < hi makes hi at least 1 */
    uint32_t up;  /* triangles running it lo -> hi */
    uint32_t down;
} edge_entry;

/* The smallest power of two at least n (n >= 1), or 0 past size_t. */
static size_t power_of_two_at_least(size_t n)
{
    size_t p = 1;
    while (p < n) {
        if (p > SIZE_MAX / 2)
            return 0;
        p *= 2;
    }
    return p;
}

/* Slots for the welding table (load at most 1/2) and the edge table (at most 3 edges a
 * triangle, load at most 3/4). */
static size_t vertex_slots(size_t vertex_count) { return power_of_two_at_least(2 * vertex_count + 1); }
static size_t edge_slots(size_t triangle_count) { return power_of_two_at_least(4 * triangle_count + 1); }

size_t solid_check_bytes(size_t vertex_count, size_t triangle_count)
{
    size_t vs = vertex_slots(vertex_count), es = edge_slots(triangle_count);
    if (vs == 0 || es == 0 || vertex_count > SIZE_MAX / 64 || es > SIZE_MAX / 64)
        return SIZE_MAX;
    return vertex_count * sizeof(uint32_t) + vs * sizeof(uint32_t) + es * sizeof(edge_entry);
}

/* Equal coordinates hash alike: -0 and +0 are one value, so both go in as +0. */
static uint64_t coordinate_bits(double c)
{
    double v = c + 0.0;
    uint64_t bits;
    memcpy(&bits, &v, sizeof bits);
    return bits;
}

static uint64_t mix64(uint64_t x)
{
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ull;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebull;
    x ^= x >> 31;
    return x;
}

static uint64_t vertex_hash(vec3 v)
{
    return mix64(coordinate_bits(v.x) ^ mix64(coordinate_bits(v.y) ^ mix64(coordinate_bits(v.z))));
}

static int same_point(vec3 a, vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

/* weld[v]: the first vertex with v's coordinates. */
static void weld_vertices(const mesh_data *mesh, uint32_t *weld, uint32_t *slots, size_t slot_count)
{
    memset(slots, 0xff, slot_count * sizeof *slots);
    size_t mask = slot_count - 1;
    for (size_t v = 0; v < mesh->vertex_count; v++) {
        vec3 p = mesh->vertices[v];
        size_t at = (size_t)vertex_hash(p) & mask;
        for (;;) {
            uint32_t held = slots[at];
            if (held == EMPTY_SLOT) {
                slots[at] = (uint32_t)v;
                weld[v] = (uint32_t)v;
                break;
            }
            if (same_point(mesh->vertices[held], p)) {
                weld[v] = held;
                break;
            }
            at = (at + 1) & mask;
        }
    }
}

static uint64_t edge_key(uint32_t a, uint32_t b)
{
    uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
    return (uint64_t)lo << 32 | hi;
}

static edge_entry *edge_slot(edge_entry *edges, size_t mask, uint64_t key)
{
    size_t at = (size_t)mix64(key) & mask;
    while (edges[at].key != 0 && edges[at].key != key)
        at = (at + 1) & mask;
    return &edges[at];
}

/* The triangle's welded corners; 0 when two of them are one vertex (left out). */
static int welded_corners(const mesh_data *mesh, const uint32_t *weld, size_t t, uint32_t c[3])
{
    for (int k = 0; k < 3; k++)
        c[k] = weld[mesh->indices[3 * t + (size_t)k]];
    return c[0] != c[1] && c[1] != c[2] && c[2] != c[0];
}

static void count_edges(const mesh_data *mesh, const uint32_t *weld, edge_entry *edges, size_t slot_count)
{
    memset(edges, 0, slot_count * sizeof *edges);
    size_t mask = slot_count - 1;
    for (size_t t = 0; t < mesh->triangle_count; t++) {
        uint32_t c[3];
        if (!welded_corners(mesh, weld, t, c))
            continue;
        for (int k = 0; k < 3; k++) {
            uint32_t a = c[k], b = c[(k + 1) % 3];
            uint64_t key = edge_key(a, b);
            edge_entry *e = edge_slot(edges, mask, key);
            e->key = key;
            if (a < b)
                e->up++;
            else
                e->down++;
        }
    }
}

/* The first triangle after `after` that runs a -> b (welded), or SIZE_MAX. */
static size_t next_running(const mesh_data *mesh, const uint32_t *weld, size_t after, uint32_t a, uint32_t b)
{
    for (size_t t = after + 1; t < mesh->triangle_count; t++) {
        uint32_t c[3];
        if (!welded_corners(mesh, weld, t, c))
            continue;
        for (int k = 0; k < 3; k++)
            if (c[k] == a && c[(k + 1) % 3] == b)
                return t;
    }
    return SIZE_MAX;
}

/* Scans the triangles in order for the first edge not used exactly once each way. */
static solid_check_status find_defect(const mesh_data *mesh, const uint32_t *weld, edge_entry *edges,
                                      size_t slot_count, solid_defect *defect)
{
    size_t mask = slot_count - 1;
    for (size_t t = 0; t < mesh->triangle_count; t++) {
        uint32_t c[3];
        if (!welded_corners(mesh, weld, t, c))
            continue;
        for (int k = 0; k < 3; k++) {
            uint32_t a = c[k], b = c[(k + 1) % 3];
            const edge_entry *e = edge_slot(edges, mask, edge_key(a, b));
            size_t uses = (size_t)e->up + e->down;
            solid_check_status why = uses == 1   ? SOLID_OPEN_EDGE
                                     : uses > 2  ? SOLID_OVERUSED_EDGE
                                     : e->up != e->down ? SOLID_MISORIENTED_EDGE
                                                        : SOLID_CLOSED;
            if (why == SOLID_CLOSED)
                continue;
            if (defect)
                *defect = (solid_defect){mesh->vertices[a], mesh->vertices[b], t,
                                         why == SOLID_MISORIENTED_EDGE ? next_running(mesh, weld, t, a, b) : SIZE_MAX,
                                         uses};
            return why;
        }
    }
    return SOLID_CLOSED;
}

solid_check_status solid_check(const mesh_data *mesh, size_t room, memory_account *account, solid_defect *defect)
{
    if (mesh->vertex_count >= UINT32_MAX)
        return SOLID_BAD_INDEX;
    for (size_t i = 0; i < 3 * mesh->triangle_count; i++)
        if (mesh->indices[i] >= mesh->vertex_count)
            return SOLID_BAD_INDEX;
    size_t bytes = solid_check_bytes(mesh->vertex_count, mesh->triangle_count);
    if (bytes > room || (account && memory_account_take(account, bytes) != 0))
        return SOLID_OVER_BUDGET;
    size_t vs = vertex_slots(mesh->vertex_count), es = edge_slots(mesh->triangle_count);
    uint32_t *weld = malloc((mesh->vertex_count ? mesh->vertex_count : 1) * sizeof *weld);
    uint32_t *slots = malloc(vs * sizeof *slots);
    edge_entry *edges = malloc(es * sizeof *edges);
    solid_check_status st = SOLID_NO_MEMORY;
    if (weld && slots && edges) {
        weld_vertices(mesh, weld, slots, vs);
        free(slots);
        slots = NULL;
        count_edges(mesh, weld, edges, es);
        st = find_defect(mesh, weld, edges, es, defect);
    }
    free(weld);
    free(slots);
    free(edges);
    if (account)
        memory_account_give(account, bytes);
    return st;
}

void solid_defect_text(solid_check_status status, const solid_defect *d, const char *label, const char *other_label,
                       char *buf, size_t len)
{
    char edge[192];
    snprintf(edge, sizeof edge, "edge (%.17g %.17g %.17g) -> (%.17g %.17g %.17g)", d->from.x, d->from.y, d->from.z,
             d->to.x, d->to.y, d->to.z);
    switch (status) {
    case SOLID_OPEN_EDGE:
        snprintf(buf, len, "%s is open: only %s uses it (a closed surface uses every edge twice)", edge, label);
        return;
    case SOLID_OVERUSED_EDGE:
        snprintf(buf, len, "%s is used by %zu triangles, %s first (a closed surface uses every edge twice)", edge,
                 d->uses, label);
        return;
    case SOLID_MISORIENTED_EDGE:
        snprintf(buf, len, "%s is run the same way by %s and %s: their orientations disagree (flip one)", edge,
                 label, other_label);
        return;
    case SOLID_BAD_INDEX:
        snprintf(buf, len, "a triangle refers to a vertex that does not exist");
        return;
    case SOLID_NO_MEMORY:
        snprintf(buf, len, "out of memory checking that the mesh is closed");
        return;
    case SOLID_OVER_BUDGET:
        snprintf(buf, len, "checking that the mesh is closed needs more memory than the budget leaves");
        return;
    case SOLID_CLOSED:
        break;
    }
    snprintf(buf, len, "closed and consistently oriented");
}
