/* Deterministic test and benchmark geometry: splitmix64 and the mesh generators of meshgen.h.
 * A generator that runs out of memory returns a zeroed mesh (triangle_count 0). */
#include "meshgen.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---------- RNG ---------- */

rng rng_seeded(uint64_t seed) { return (rng){seed}; }

uint64_t rng_next(rng *r)
{
    uint64_t z = (r->state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

double rng_uniform(rng *r, double lo, double hi)
{
    double unit = (double)(rng_next(r) >> 11) * 0x1p-53; /* [0, 1), every value exact */
    double x = lo + (hi - lo) * unit;
    /* Rounding can land exactly on hi; the contract is half-open. */
    return x < hi ? x : lo;
}

vec3 rng_point_in_box(rng *r, box3 box)
{
    double x = rng_uniform(r, box.lo.x, box.hi.x);
    double y = rng_uniform(r, box.lo.y, box.hi.y);
    double z = rng_uniform(r, box.lo.z, box.hi.z);
    return vec3_make(x, y, z);
}

vec3 rng_unit_vector(rng *r)
{
    /* Rejection from the cube keeps the direction uniform; the lower bound keeps the
     * normalisation away from tiny vectors. */
    for (;;) {
        double x = rng_uniform(r, -1.0, 1.0);
        double y = rng_uniform(r, -1.0, 1.0);
        double z = rng_uniform(r, -1.0, 1.0);
        double len2 = x * x + y * y + z * z;
        if (len2 > 1e-6 && len2 <= 1.0)
            return vec3_scale(vec3_make(x, y, z), 1.0 / sqrt(len2));
    }
}

/* ---------- mesh building helpers ---------- */

static int mesh_alloc(mesh_data *m, size_t vertex_count, size_t triangle_count)
{
    memset(m, 0, sizeof *m);
    if (vertex_count > UINT32_MAX || triangle_count > SIZE_MAX / (3 * sizeof(uint32_t)))
        return -1;
    m->vertices = malloc((vertex_count ? vertex_count : 1) * sizeof *m->vertices);
    m->indices = malloc((triangle_count ? 3 * triangle_count : 1) * sizeof *m->indices);
    if (!m->vertices || !m->indices) {
        mesh_data_free(m);
        return -1;
    }
    m->vertex_count = vertex_count;
    m->triangle_count = triangle_count;
    return 0;
}

/* memcpy wrappers that accept the NULL arrays of an empty mesh. */
static void copy_vertices(vec3 *dst, const vec3 *src, size_t count)
{
    if (count)
        memcpy(dst, src, count * sizeof *dst);
}

static void copy_indices(uint32_t *dst, const uint32_t *src, size_t triangles)
{
    if (triangles)
        memcpy(dst, src, 3 * triangles * sizeof *dst);
}

static void set_triangle(mesh_data *m, size_t t, uint32_t a, uint32_t b, uint32_t c)
{
    m->indices[3 * t + 0] = a;
    m->indices[3 * t + 1] = b;
    m->indices[3 * t + 2] = c;
}

/* The 12 outward triangles of a box, vertices written at v[base .. base+8), triangles at
 * t[tbase .. tbase+12). Corner k has x = hi when bit 0 is set, y bit 1, z bit 2. */
static void write_box(mesh_data *m, size_t base, size_t tbase, box3 box)
{
    for (int k = 0; k < 8; k++)
        m->vertices[base + (size_t)k] = vec3_make(k & 1 ? box.hi.x : box.lo.x,
                                                  k & 2 ? box.hi.y : box.lo.y,
                                                  k & 4 ? box.hi.z : box.lo.z);
    size_t t = tbase;
    for (int axis = 0; axis < 3; axis++) {
        int u = 1 << ((axis + 1) % 3), v = 1 << ((axis + 2) % 3), a = 1 << axis;
        for (int side = 0; side < 2; side++) {
            int s = side ? a : 0;
            /* Counter-clockwise in (u, v) has normal e_u x e_v = +e_axis; the low side
             * takes the reverse order so both normals point out. */
            uint32_t q[4] = {(uint32_t)(base + (size_t)s), (uint32_t)(base + (size_t)(s | u)),
                             (uint32_t)(base + (size_t)(s | u | v)),
                             (uint32_t)(base + (size_t)(s | v))};
            if (side) {
                set_triangle(m, t++, q[0], q[1], q[2]);
                set_triangle(m, t++, q[0], q[2], q[3]);
            } else {
                set_triangle(m, t++, q[0], q[2], q[1]);
                set_triangle(m, t++, q[0], q[3], q[2]);
            }
        }
    }
}

/* ---------- closed meshes ---------- */

mesh_data meshgen_triangle(vec3 a, vec3 b, vec3 c)
{
    mesh_data m;
    if (mesh_alloc(&m, 3, 1) != 0)
        return m;
    m.vertices[0] = a;
    m.vertices[1] = b;
    m.vertices[2] = c;
    set_triangle(&m, 0, 0, 1, 2);
    return m;
}

mesh_data meshgen_tetrahedron(vec3 a, vec3 b, vec3 c, vec3 d)
{
    mesh_data m;
    if (mesh_alloc(&m, 4, 4) != 0)
        return m;
    double orientation = vec3_dot(vec3_cross(vec3_sub(b, a), vec3_sub(c, a)), vec3_sub(d, a));
    if (orientation < 0.0) {
        vec3 swap = b;
        b = c;
        c = swap;
    }
    m.vertices[0] = a;
    m.vertices[1] = b;
    m.vertices[2] = c;
    m.vertices[3] = d;
    /* With det[b-a, c-a, d-a] > 0, these four windings all face away from the fourth point. */
    set_triangle(&m, 0, 0, 2, 1);
    set_triangle(&m, 1, 0, 1, 3);
    set_triangle(&m, 2, 0, 3, 2);
    set_triangle(&m, 3, 1, 2, 3);
    return m;
}

mesh_data meshgen_box(box3 box)
{
    mesh_data m;
    if (mesh_alloc(&m, 8, 12) != 0)
        return m;
    write_box(&m, 0, 0, box);
    return m;
}

/* ---------- midpoint subdivision ---------- */

/* Open-addressing map from an undirected edge (lo << 32 | hi) to its midpoint vertex:
 * each edge is met twice, and the second visit must find the first one's vertex. */
typedef struct edge_map {
    uint64_t *keys;
    uint32_t *values;
    size_t mask;
} edge_map;

#define EDGE_MAP_EMPTY UINT64_MAX

static int edge_map_init(edge_map *map, size_t edges)
{
    size_t cap = 16;
    while (cap < 2 * edges)
        cap *= 2;
    map->keys = malloc(cap * sizeof *map->keys);
    map->values = malloc(cap * sizeof *map->values);
    if (!map->keys || !map->values) {
        free(map->keys);
        free(map->values);
        return -1;
    }
    memset(map->keys, 0xff, cap * sizeof *map->keys);
    map->mask = cap - 1;
    return 0;
}

static void edge_map_free(edge_map *map)
{
    free(map->keys);
    free(map->values);
}

/* Returns the slot for the edge; *found says whether it was already there. */
static size_t edge_map_slot(const edge_map *map, uint32_t a, uint32_t b, int *found)
{
    uint64_t key = a < b ? ((uint64_t)a << 32 | b) : ((uint64_t)b << 32 | a);
    uint64_t mixed = (key ^ (key >> 31)) * 0xbf58476d1ce4e5b9ull;
    size_t slot = (size_t)(mixed ^ (mixed >> 29)) & map->mask;
    while (map->keys[slot] != EDGE_MAP_EMPTY && map->keys[slot] != key)
        slot = (slot + 1) & map->mask;
    *found = map->keys[slot] == key;
    map->keys[slot] = key;
    return slot;
}

/* One 1 -> 4 split. New vertices are edge midpoints, pushed onto the unit sphere when
 * to_unit_sphere is set (the icosphere's vertices stay on the sphere at every level). */
static int subdivide_once(const mesh_data *in, mesh_data *out, int to_unit_sphere)
{
    memset(out, 0, sizeof *out);
    size_t nt = in->triangle_count;
    if (nt > SIZE_MAX / 12)
        return -1;
    /* At most 3 * nt distinct edges; the exact count is known once the map is filled. */
    edge_map map;
    if (edge_map_init(&map, 3 * nt) != 0)
        return -1;
    size_t max_vertices = in->vertex_count + 3 * nt;
    if (mesh_alloc(out, max_vertices, 4 * nt) != 0) {
        edge_map_free(&map);
        return -1;
    }
    copy_vertices(out->vertices, in->vertices, in->vertex_count);
    size_t next_vertex = in->vertex_count;
    for (size_t t = 0; t < nt; t++) {
        const uint32_t *tri = in->indices + 3 * t;
        uint32_t mid[3];
        for (int e = 0; e < 3; e++) {
            uint32_t a = tri[e], b = tri[(e + 1) % 3];
            int found;
            size_t slot = edge_map_slot(&map, a, b, &found);
            if (!found) {
                /* The sum of the two endpoints is symmetric, so the midpoint is the same
                 * bits whichever triangle reaches the edge first. */
                vec3 p = vec3_scale(vec3_add(in->vertices[a], in->vertices[b]), 0.5);
                if (to_unit_sphere)
                    p = vec3_normalize(p);
                out->vertices[next_vertex] = p;
                map.values[slot] = (uint32_t)next_vertex++;
            }
            mid[e] = map.values[slot];
        }
        set_triangle(out, 4 * t + 0, tri[0], mid[0], mid[2]);
        set_triangle(out, 4 * t + 1, mid[0], tri[1], mid[1]);
        set_triangle(out, 4 * t + 2, mid[2], mid[1], tri[2]);
        set_triangle(out, 4 * t + 3, mid[0], mid[1], mid[2]);
    }
    edge_map_free(&map);
    out->vertex_count = next_vertex;
    vec3 *shrunk = realloc(out->vertices, (next_vertex ? next_vertex : 1) * sizeof *shrunk);
    if (shrunk)
        out->vertices = shrunk;
    return 0;
}

static mesh_data subdivide_times(const mesh_data *mesh, int times, int to_unit_sphere)
{
    mesh_data current;
    if (mesh_alloc(&current, mesh->vertex_count, mesh->triangle_count) != 0)
        return current;
    copy_vertices(current.vertices, mesh->vertices, mesh->vertex_count);
    copy_indices(current.indices, mesh->indices, mesh->triangle_count);
    for (int i = 0; i < times; i++) {
        mesh_data next;
        int status = subdivide_once(&current, &next, to_unit_sphere);
        mesh_data_free(&current);
        if (status != 0)
            return current; /* zeroed by mesh_data_free */
        current = next;
    }
    return current;
}

mesh_data meshgen_subdivide(const mesh_data *mesh, int times)
{
    return subdivide_times(mesh, times < 0 ? 0 : times, 0);
}

mesh_data meshgen_icosphere(vec3 centre, double radius, int subdivisions)
{
    static const double phi = 1.6180339887498948482;
    static const double corners[12][3] = {
        {-1, phi, 0}, {1, phi, 0}, {-1, -phi, 0}, {1, -phi, 0},
        {0, -1, phi}, {0, 1, phi}, {0, -1, -phi}, {0, 1, -phi},
        {phi, 0, -1}, {phi, 0, 1}, {-phi, 0, -1}, {-phi, 0, 1},
    };
    static const uint32_t faces[20][3] = {
        {0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
        {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
        {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
        {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1},
    };
    mesh_data base;
    if (mesh_alloc(&base, 12, 20) != 0)
        return base;
    for (int i = 0; i < 12; i++)
        base.vertices[i] = vec3_normalize(vec3_make(corners[i][0], corners[i][1], corners[i][2]));
    for (int f = 0; f < 20; f++) {
        uint32_t a = faces[f][0], b = faces[f][1], c = faces[f][2];
        vec3 pa = base.vertices[a], pb = base.vertices[b], pc = base.vertices[c];
        /* The solid is convex around the origin: a face is outward when its normal points
         * the same way as its own vertices. */
        vec3 normal = vec3_cross(vec3_sub(pb, pa), vec3_sub(pc, pa));
        if (vec3_dot(normal, pa) < 0.0)
            set_triangle(&base, (size_t)f, a, c, b);
        else
            set_triangle(&base, (size_t)f, a, b, c);
    }
    mesh_data sphere = subdivide_times(&base, subdivisions < 0 ? 0 : subdivisions, 1);
    mesh_data_free(&base);
    for (size_t i = 0; i < sphere.vertex_count; i++)
        sphere.vertices[i] = vec3_add(centre, vec3_scale(sphere.vertices[i], radius));
    return sphere;
}

mesh_data meshgen_torus(vec3 centre, double major, double minor, int nu, int nv)
{
    mesh_data m;
    if (nu < 3)
        nu = 3;
    if (nv < 3)
        nv = 3;
    size_t count = (size_t)nu * (size_t)nv;
    if (mesh_alloc(&m, count, 2 * count) != 0)
        return m;
    const double two_pi = 6.283185307179586476925;
    for (int i = 0; i < nu; i++) {
        double u = two_pi * i / nu;
        for (int j = 0; j < nv; j++) {
            double v = two_pi * j / nv;
            double ring = major + minor * cos(v);
            m.vertices[(size_t)i * (size_t)nv + (size_t)j] =
                vec3_add(centre, vec3_make(ring * cos(u), ring * sin(u), minor * sin(v)));
        }
    }
    /* dP/du x dP/dv points away from the tube's core, so (i,j) -> (i+1,j) -> (i+1,j+1)
     * winds outward. */
    size_t t = 0;
    for (int i = 0; i < nu; i++) {
        int i1 = (i + 1) % nu;
        for (int j = 0; j < nv; j++) {
            int j1 = (j + 1) % nv;
            uint32_t a = (uint32_t)(i * nv + j), b = (uint32_t)(i1 * nv + j);
            uint32_t c = (uint32_t)(i1 * nv + j1), d = (uint32_t)(i * nv + j1);
            set_triangle(&m, t++, a, b, c);
            set_triangle(&m, t++, a, c, d);
        }
    }
    return m;
}

/* ---------- open surfaces and scenes ---------- */

/* Grid coordinate k of n between lo and hi, with both ends exact. */
static double grid_coordinate(double lo, double hi, int k, int n)
{
    if (k == n)
        return hi;
    return lo + (hi - lo) * ((double)k / n);
}

mesh_data meshgen_terrain(uint64_t seed, box3 region, int nx, int ny)
{
    mesh_data m;
    if (nx < 1)
        nx = 1;
    if (ny < 1)
        ny = 1;
    size_t cols = (size_t)nx + 1, rows = (size_t)ny + 1;
    if (mesh_alloc(&m, cols * rows, 2 * (size_t)nx * (size_t)ny) != 0)
        return m;

    enum { MAX_BUMPS = 6 };
    rng r = rng_seeded(seed);
    int bump_count = 3 + (int)(rng_next(&r) % (MAX_BUMPS - 2));
    vec3 bump_centre[MAX_BUMPS];
    double bump_radius[MAX_BUMPS], bump_height[MAX_BUMPS];
    double span = fmax(region.hi.x - region.lo.x, region.hi.y - region.lo.y);
    double depth = region.hi.z - region.lo.z;
    for (int b = 0; b < bump_count; b++) {
        bump_centre[b] = rng_point_in_box(&r, region);
        bump_radius[b] = rng_uniform(&r, 0.1, 0.4) * span;
        /* Mostly hills, sometimes a hollow. */
        bump_height[b] = rng_uniform(&r, -0.3, 0.7) * depth;
    }
    double ground = region.lo.z + 0.3 * depth;

    for (size_t j = 0; j < rows; j++) {
        double y = grid_coordinate(region.lo.y, region.hi.y, (int)j, ny);
        for (size_t i = 0; i < cols; i++) {
            double x = grid_coordinate(region.lo.x, region.hi.x, (int)i, nx);
            double z = ground;
            for (int b = 0; b < bump_count; b++) {
                double dx = x - bump_centre[b].x, dy = y - bump_centre[b].y;
                double rr = bump_radius[b] > 0.0 ? bump_radius[b] : 1.0;
                z += bump_height[b] * exp(-(dx * dx + dy * dy) / (rr * rr));
            }
            z = fmin(fmax(z, region.lo.z), region.hi.z);
            m.vertices[j * cols + i] = vec3_make(x, y, z);
        }
    }
    /* Counter-clockwise seen from +z: the surface faces up. */
    size_t t = 0;
    for (size_t j = 0; j < (size_t)ny; j++)
        for (size_t i = 0; i < (size_t)nx; i++) {
            uint32_t a = (uint32_t)(j * cols + i), b = a + 1;
            uint32_t d = (uint32_t)((j + 1) * cols + i), c = d + 1;
            set_triangle(&m, t++, a, b, c);
            set_triangle(&m, t++, a, c, d);
        }
    return m;
}

static double clamp(double x, double lo, double hi) { return x < lo ? lo : x > hi ? hi : x; }

mesh_data meshgen_soup(uint64_t seed, size_t n, box3 region, double size)
{
    mesh_data m;
    if (n > SIZE_MAX / 3 || mesh_alloc(&m, 3 * n, n) != 0) {
        memset(&m, 0, sizeof m);
        return m;
    }
    rng r = rng_seeded(seed);
    /* Centres keep half a size from the walls so clamping (which flattens triangles
     * against the box) only happens in regions too small for the triangles. */
    double half = 0.5 * size;
    box3 centres = region;
    double *lo[3] = {&centres.lo.x, &centres.lo.y, &centres.lo.z};
    double *hi[3] = {&centres.hi.x, &centres.hi.y, &centres.hi.z};
    for (int axis = 0; axis < 3; axis++) {
        if (*hi[axis] - *lo[axis] > size) {
            *lo[axis] += half;
            *hi[axis] -= half;
        } else {
            double mid = 0.5 * (*lo[axis] + *hi[axis]);
            *lo[axis] = *hi[axis] = mid;
        }
    }
    for (size_t t = 0; t < n; t++) {
        vec3 c = rng_point_in_box(&r, centres);
        for (int k = 0; k < 3; k++) {
            vec3 p = vec3_add(c, vec3_scale(rng_unit_vector(&r), half * rng_uniform(&r, 0.5, 1.0)));
            p = vec3_make(clamp(p.x, region.lo.x, region.hi.x), clamp(p.y, region.lo.y, region.hi.y),
                          clamp(p.z, region.lo.z, region.hi.z));
            m.vertices[3 * t + (size_t)k] = p;
        }
        set_triangle(&m, t, (uint32_t)(3 * t), (uint32_t)(3 * t + 1), (uint32_t)(3 * t + 2));
    }
    return m;
}

mesh_data meshgen_blocks(uint64_t seed, int nx, int ny, int nz, double cell)
{
    mesh_data m;
    memset(&m, 0, sizeof m);
    if (nx < 1 || ny < 1 || nz < 1)
        return m;
    size_t cells = (size_t)nx * (size_t)ny * (size_t)nz;
    unsigned char *present = malloc(cells);
    if (!present)
        return m;
    rng r = rng_seeded(seed);
    size_t kept = 0;
    for (size_t k = 0; k < cells; k++) {
        present[k] = (rng_next(&r) >> 62) != 0; /* three in four blocks stay */
        kept += present[k];
    }
    if (kept == 0) {
        present[0] = 1;
        kept = 1;
    }
    if (kept > SIZE_MAX / 12 || mesh_alloc(&m, 8 * kept, 12 * kept) != 0) {
        free(present);
        memset(&m, 0, sizeof m);
        return m;
    }
    size_t block = 0, k = 0;
    for (int z = 0; z < nz; z++)
        for (int y = 0; y < ny; y++)
            for (int x = 0; x < nx; x++, k++) {
                if (!present[k])
                    continue;
                /* Integer times a power of two: every coordinate is exact, so touching
                 * blocks share their face planes bit for bit. */
                box3 box = {vec3_make(x * cell, y * cell, z * cell),
                            vec3_make((x + 1) * cell, (y + 1) * cell, (z + 1) * cell)};
                write_box(&m, 8 * block, 12 * block, box);
                block++;
            }
    free(present);
    return m;
}

mesh_data meshgen_transformed(const mesh_data *mesh, double scale, vec3 offset)
{
    mesh_data m;
    if (mesh_alloc(&m, mesh->vertex_count, mesh->triangle_count) != 0)
        return m;
    for (size_t i = 0; i < mesh->vertex_count; i++)
        m.vertices[i] = vec3_add(vec3_scale(mesh->vertices[i], scale), offset);
    copy_indices(m.indices, mesh->indices, mesh->triangle_count);
    return m;
}
