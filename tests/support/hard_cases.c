/* The catalogue of numerically hard cases: hand-built base cases with answers known by
 * construction, each expanded by transforms that provably change no answer. */
#include "support/hard_cases.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geom/ray_tri.h"
#include "geom/tri_box.h"
#include "geom/tri_tri.h"

/* ---------- categories ---------- */

#define CAT_COPLANAR_OVERLAP "coplanar overlapping"
#define CAT_COPLANAR_EDGE "coplanar touching at an edge"
#define CAT_COPLANAR_VERTEX "coplanar touching at a vertex"
#define CAT_COPLANAR_ULP "coplanar separated by one ulp"
#define CAT_SHARED_EDGE "shared edge"
#define CAT_SHARED_VERTEX "shared vertex"
#define CAT_VERTEX_ON_FACE "vertex exactly on a face"
#define CAT_EDGE_EDGE "edge crossing edge exactly"
#define CAT_NEARLY_COPLANAR "nearly coplanar"
#define CAT_PARALLEL_HAIR "parallel planes a hair apart"
#define CAT_SLIVER "slivers and needles"
#define CAT_COLLINEAR "zero-area: three collinear points"
#define CAT_REPEATED "zero-area: repeated vertex"
#define CAT_POINT "zero-area: all three equal"
#define CAT_NODE_FACE "triangle on a node face"
#define CAT_NODE_EDGE "triangle on a node edge"
#define CAT_NODE_CORNER "triangle on a node corner"
#define CAT_WORLD_BOUNDARY "on the world boundary"
#define CAT_OFFSET_1E6 "offset 1e6 with small triangles"
#define CAT_OFFSET_1E9 "offset 1e9 with small triangles"
#define CAT_SIZE_1E_9 "size 1e-9"
#define CAT_RAY_IN_PLANE "ray in the plane of a triangle"
#define CAT_RAY_AXIS "ray parallel to box faces"
#define CAT_RAY_ON_SURFACE "ray starting on a surface"
#define CAT_RAY_GRAZING "grazing ray"
#define CAT_RAY_LIMITS "ray with tmin/tmax exactly at the hit"

static const char *const category_names[] = {
    CAT_COPLANAR_OVERLAP, CAT_COPLANAR_EDGE, CAT_COPLANAR_VERTEX, CAT_COPLANAR_ULP, CAT_SHARED_EDGE,
    CAT_SHARED_VERTEX,    CAT_VERTEX_ON_FACE, CAT_EDGE_EDGE,     CAT_NEARLY_COPLANAR, CAT_PARALLEL_HAIR,
    CAT_SLIVER,           CAT_COLLINEAR,     CAT_REPEATED,      CAT_POINT,          CAT_NODE_FACE,
    CAT_NODE_EDGE,        CAT_NODE_CORNER,   CAT_WORLD_BOUNDARY, CAT_OFFSET_1E6,    CAT_OFFSET_1E9,
    CAT_SIZE_1E_9,        CAT_RAY_IN_PLANE,  CAT_RAY_AXIS,      CAT_RAY_ON_SURFACE, CAT_RAY_GRAZING,
    CAT_RAY_LIMITS,
};

const char *const *hard_case_categories(size_t *count)
{
    if (count)
        *count = sizeof category_names / sizeof category_names[0];
    return category_names;
}

/* ---------- a growable list ---------- */

typedef struct case_list {
    hard_case *items;
    size_t count, capacity;
    int out_of_memory;
} case_list;

static void push(case_list *list, const hard_case *c)
{
    if (list->out_of_memory)
        return;
    if (list->count == list->capacity) {
        size_t capacity = list->capacity ? 2 * list->capacity : 256;
        hard_case *grown = realloc(list->items, capacity * sizeof *grown);
        if (!grown) {
            list->out_of_memory = 1;
            return;
        }
        list->items = grown;
        list->capacity = capacity;
    }
    list->items[list->count++] = *c;
}

static vec3 V(double x, double y, double z) { return (vec3){x, y, z}; }
static double up(double x) { return nextafter(x, INFINITY); }
static double down(double x) { return nextafter(x, -INFINITY); }
static box3 cube(vec3 lo, double side) { return (box3){lo, {lo.x + side, lo.y + side, lo.z + side}}; }
static const box3 unit_box = {{0, 0, 0}, {1, 1, 1}};

static void tri_tri(case_list *l, const char *cat, vec3 a0, vec3 a1, vec3 a2, vec3 b0, vec3 b1, vec3 b2,
                    int expected)
{
    hard_case c = {.category = cat, .kind = HARD_TRI_TRI, .a = {a0, a1, a2}, .b = {b0, b1, b2}, .expected = expected};
    push(l, &c);
}

static void tri_box(case_list *l, const char *cat, vec3 a0, vec3 a1, vec3 a2, box3 box, int expected)
{
    hard_case c = {.category = cat, .kind = HARD_TRI_BOX, .a = {a0, a1, a2}, .box = box, .expected = expected};
    push(l, &c);
}

static void ray_tri(case_list *l, const char *cat, vec3 o, vec3 d, double tmin, double tmax, vec3 a0, vec3 a1,
                    vec3 a2, int expected)
{
    hard_case c = {.category = cat,
                   .kind = HARD_RAY_TRI,
                   .a = {a0, a1, a2},
                   .origin = o,
                   .direction = d,
                   .tmin = tmin,
                   .tmax = tmax,
                   .expected = expected};
    push(l, &c);
}

/* ---------- base cases, by category ---------- */

/* Most cases test against this right triangle in z = 0 (legs 2 or 4) or the unit box,
 * whose faces, edges and corners become node boundaries in the octree tests. */

static void add_coplanar(case_list *l)
{
    const vec3 a0 = V(0, 0, 0), a1 = V(4, 0, 0), a2 = V(0, 4, 0);
    tri_tri(l, CAT_COPLANAR_OVERLAP, a0, a1, a2, V(1, 1, 0), V(5, 1, 0), V(1, 5, 0), 1);
    tri_tri(l, CAT_COPLANAR_OVERLAP, a0, a1, a2, V(-1, -1, 0), V(10, -1, 0), V(-1, 10, 0), 1); /* b holds a */
    tri_tri(l, CAT_COPLANAR_OVERLAP, V(4, 0, 0), V(0, 4, 0), V(0, 0, 4), V(3, 1, 0), V(1, 1, 2), V(1, 3, 0), 1);
    tri_tri(l, CAT_COPLANAR_OVERLAP, a0, a1, a2, V(-1, 1, 0), V(5, 1, 0), V(2, 0.5, 0), 1); /* crossing edges */
    tri_box(l, CAT_COPLANAR_OVERLAP, V(0.25, 0.25, 1), V(2, 0.5, 1), V(0.5, 2, 1), unit_box, 1);
    tri_box(l, CAT_COPLANAR_OVERLAP, V(-1, -1, 0.5), V(3, -1, 0.5), V(-1, 3, 0.5), unit_box, 1);
    /* Across the common plane through the overlap, and along it (no hit by definition). */
    ray_tri(l, CAT_COPLANAR_OVERLAP, V(1.5, 1.5, -1), V(0, 0, 1), 0, INFINITY, a0, a1, a2, 1);
    ray_tri(l, CAT_COPLANAR_OVERLAP, V(-1, 1.5, 0), V(1, 0, 0), 0, INFINITY, a0, a1, a2, 0);

    const vec3 s0 = V(0, 0, 0), s1 = V(2, 0, 0), s2 = V(0, 2, 0);
    /* b's edge runs along a's hypotenuse x + y = 2 from (1, 1) past (2, 0). */
    tri_tri(l, CAT_COPLANAR_EDGE, s0, s1, s2, V(1, 1, 0), V(3, -1, 0), V(3, 3, 0), 1);
    tri_tri(l, CAT_COPLANAR_EDGE, s0, s1, s2, V(0.5, 0, 0), V(1.5, 0, 0), V(1, -3, 0), 1);
    tri_box(l, CAT_COPLANAR_EDGE, V(1, 0.25, 1), V(1, 0.75, 1), V(2, 0.5, 1), unit_box, 1);
    tri_box(l, CAT_COPLANAR_EDGE, V(1, 0.25, 0.5), V(1, 0.75, 0.5), V(2, 0.5, 0.5), unit_box, 1);

    tri_tri(l, CAT_COPLANAR_VERTEX, s0, s1, s2, V(1, 1, 0), V(3, 1, 0), V(1, 3, 0), 1);
    tri_tri(l, CAT_COPLANAR_VERTEX, s0, s1, s2, V(2, 0, 0), V(4, -1, 0), V(4, 1, 0), 1);
    tri_box(l, CAT_COPLANAR_VERTEX, V(1, 1, 1), V(2, 1.5, 1), V(1.5, 2, 1), unit_box, 1);
    tri_box(l, CAT_COPLANAR_VERTEX, V(1, 0.5, 1), V(2, 0.25, 1), V(2, 0.75, 1), unit_box, 1);

    /* One ulp past the hypotenuse x + y = 2: 1 + 2^-52 is the double after 1. */
    tri_tri(l, CAT_COPLANAR_ULP, s0, s1, s2, V(1, up(1), 0), V(3, 1, 0), V(1, 3, 0), 0);
    tri_tri(l, CAT_COPLANAR_ULP, s0, s1, s2, V(1.5, 0.5 + 0x1p-52, 0), V(0.5, 1.5 + 0x1p-52, 0), V(3, 3, 0), 0);
    tri_tri(l, CAT_COPLANAR_ULP, s0, s1, s2, V(2, 0, 0), V(up(2), 0, 0), V(3, 0, 0), 1); /* control */
    tri_tri(l, CAT_COPLANAR_ULP, s0, s1, s2, V(up(2), 0, 0), V(4, -1, 0), V(4, 1, 0), 0);
    tri_box(l, CAT_COPLANAR_ULP, V(up(1), 0.5, 1), V(2, 0, 1), V(2, 1, 1), unit_box, 0);
    tri_box(l, CAT_COPLANAR_ULP, V(0.5, up(1), 0.5), V(0, 2, 0.5), V(1, 2, 0.5), unit_box, 0);
    ray_tri(l, CAT_COPLANAR_ULP, V(1, up(1), 1), V(0, 0, -1), 0, INFINITY, s0, s1, s2, 0);
    ray_tri(l, CAT_COPLANAR_ULP, V(1, down(1), 1), V(0, 0, -1), 0, INFINITY, s0, s1, s2, 1);
}

static void add_shared(case_list *l)
{
    const vec3 a0 = V(0, 0, 0), a1 = V(2, 0, 0), a2 = V(0, 2, 0);
    tri_tri(l, CAT_SHARED_EDGE, a0, a1, a2, V(2, 0, 0), V(0, 2, 0), V(2, 2, 0), 1);
    tri_tri(l, CAT_SHARED_EDGE, a0, a1, a2, V(2, 0, 0), V(0, 2, 0), V(1, 1, 3), 1);
    tri_tri(l, CAT_SHARED_EDGE, a0, a1, a2, V(0, 0, 0), V(2, 0, 0), V(1, -1, 1), 1);
    tri_box(l, CAT_SHARED_EDGE, V(0, 0, 0), V(1, 0, 0), V(0.5, -1, -1), unit_box, 1);
    tri_box(l, CAT_SHARED_EDGE, V(0, 0, 1), V(1, 0, 1), V(0.5, 0, 2), unit_box, 1);
    /* Strictly inside one of two triangles sharing the hypotenuse, half an ulp of 1 away. */
    ray_tri(l, CAT_SHARED_EDGE, V(1, down(1), 1), V(0, 0, -1), 0, INFINITY, a0, a1, a2, 1);
    ray_tri(l, CAT_SHARED_EDGE, V(1, down(1), 1), V(0, 0, -1), 0, INFINITY, V(2, 0, 0), V(0, 2, 0), V(2, 2, 0), 0);
    ray_tri(l, CAT_SHARED_EDGE, V(1, up(1), 1), V(0, 0, -1), 0, INFINITY, V(2, 0, 0), V(0, 2, 0), V(2, 2, 0), 1);

    tri_tri(l, CAT_SHARED_VERTEX, a0, a1, a2, V(0, 0, 0), V(-2, 0, 1), V(0, -2, 1), 1);
    tri_tri(l, CAT_SHARED_VERTEX, a0, a1, a2, V(0, 0, 0), V(-2, 0, 0), V(0, -2, 0), 1);
    tri_tri(l, CAT_SHARED_VERTEX, a0, a1, a2, V(2, 0, 0), V(3, 1, 1), V(3, -1, 1), 1);
    tri_box(l, CAT_SHARED_VERTEX, V(1, 1, 1), V(2, 1, 3), V(1, 2, 3), unit_box, 1);
    tri_box(l, CAT_SHARED_VERTEX, V(0, 0, 0), V(-1, -2, 0), V(-2, -1, -1), unit_box, 1);
    ray_tri(l, CAT_SHARED_VERTEX, V(0x1p-40, 0x1p-40, 1), V(0, 0, -1), 0, INFINITY, a0, a1, a2, 1);
    ray_tri(l, CAT_SHARED_VERTEX, V(0x1p-40, 0x1p-40, 1), V(0, 0, -1), 0, INFINITY, V(0, 0, 0), V(-2, 0, 0),
            V(0, -2, 0), 0);
}

static void add_contacts(case_list *l)
{
    const vec3 a0 = V(0, 0, 0), a1 = V(4, 0, 0), a2 = V(0, 4, 0);
    tri_tri(l, CAT_VERTEX_ON_FACE, a0, a1, a2, V(1, 1, 0), V(1, 1, 2), V(2, 2, 3), 1);
    tri_tri(l, CAT_VERTEX_ON_FACE, a0, a1, a2, V(1, 1, 0x1p-60), V(1, 1, 2), V(2, 2, 3), 0);
    tri_tri(l, CAT_VERTEX_ON_FACE, a0, a1, a2, V(1, 1, -0x1p-60), V(1, 1, 2), V(2, 2, 3), 1);
    tri_box(l, CAT_VERTEX_ON_FACE, V(1, 0.5, 0.5), V(2, 0.25, 0.5), V(2, 0.75, 0.75), unit_box, 1);
    tri_box(l, CAT_VERTEX_ON_FACE, V(down(1), 0.5, 0.5), V(2, 0.25, 0.5), V(2, 0.75, 0.75), unit_box, 1);
    ray_tri(l, CAT_VERTEX_ON_FACE, V(1, 1, 5), V(0, 0, -1), 0, INFINITY, a0, a1, a2, 1);
    ray_tri(l, CAT_VERTEX_ON_FACE, V(1, 1, 5), V(0, 0, 1), 0, INFINITY, a0, a1, a2, 0);

    /* b in the plane x = 1, its edge along z crossing a's edge along x at (1, 0, 0). */
    const vec3 s0 = V(0, 0, 0), s1 = V(2, 0, 0), s2 = V(0, 2, 0);
    tri_tri(l, CAT_EDGE_EDGE, s0, s1, s2, V(1, 0, -1), V(1, 0, 1), V(1, -2, 0), 1);
    tri_tri(l, CAT_EDGE_EDGE, s0, s1, s2, V(1, -0x1p-60, -1), V(1, -0x1p-60, 1), V(1, -2, 0), 0);
    tri_tri(l, CAT_EDGE_EDGE, s0, s1, s2, V(1, 1, -1), V(1, 1, 1), V(3, 3, 0), 1); /* across the hypotenuse */
    tri_tri(l, CAT_EDGE_EDGE, s0, s1, s2, V(1, up(1), -1), V(1, up(1), 1), V(3, 3, 0), 0);
    tri_box(l, CAT_EDGE_EDGE, V(2, 0, 0.5), V(0, 2, 0.5), V(2, 2, 0.5), unit_box, 1);
    tri_box(l, CAT_EDGE_EDGE, V(2, 0x1p-50, 0.5), V(0x1p-50, 2, 0.5), V(2, 2, 0.5), unit_box, 0);
    tri_box(l, CAT_EDGE_EDGE, V(2, 0.5, 0), V(0.5, 2, 2), V(2, 2, 2), unit_box, 0);
}

static void add_near_parallel(case_list *l)
{
    const vec3 a0 = V(0, 0, 0), a1 = V(4, 0, 0), a2 = V(0, 4, 0);
    const double e = 0x1p-50;
    tri_tri(l, CAT_NEARLY_COPLANAR, a0, a1, a2, V(1, 1, -e), V(3, 1, e), V(1, 3, e), 1);
    tri_tri(l, CAT_NEARLY_COPLANAR, a0, a1, a2, V(1, 1, e), V(3, 1, 2 * e), V(1, 3, 2 * e), 0);
    tri_tri(l, CAT_NEARLY_COPLANAR, a0, a1, a2, V(5, -1, -e), V(7, 1, e), V(5, 1, e), 0);
    tri_box(l, CAT_NEARLY_COPLANAR, V(0.25, 0.25, up(1)), V(3, 0.25, 1 + 0x1p-51), V(0.25, 3, 1 + 0x1p-51), unit_box,
            0);
    tri_box(l, CAT_NEARLY_COPLANAR, V(0.25, 0.25, 1), V(3, 0.25, 1 + 0x1p-51), V(0.25, 3, 1 + 0x1p-51), unit_box, 1);
    ray_tri(l, CAT_NEARLY_COPLANAR, V(0, 1, 0x1p-52), V(1, 0, -0x1p-52), 0, INFINITY, a0, a1, a2, 1);
    ray_tri(l, CAT_NEARLY_COPLANAR, V(0, 1, 0x1p-52), V(1, 0, 0x1p-52), 0, INFINITY, a0, a1, a2, 0);

    tri_tri(l, CAT_PARALLEL_HAIR, a0, a1, a2, V(1, 1, 0x1p-60), V(3, 1, 0x1p-60), V(1, 3, 0x1p-60), 0);
    tri_tri(l, CAT_PARALLEL_HAIR, V(4, 0, 0), V(0, 4, 0), V(0, 0, 4), V(2, 1, 1 + e), V(1, 2, 1 + e), V(1, 1, 2 + e),
            0);
    tri_tri(l, CAT_PARALLEL_HAIR, V(4, 0, 0), V(0, 4, 0), V(0, 0, 4), V(2, 1, 1), V(1, 2, 1), V(1, 1, 2), 1);
    tri_box(l, CAT_PARALLEL_HAIR, V(0.25, 0.25, up(1)), V(0.75, 0.25, up(1)), V(0.5, 0.75, up(1)), unit_box, 0);
    tri_box(l, CAT_PARALLEL_HAIR, V(0.25, 0.25, -0x1p-60), V(0.75, 0.25, -0x1p-60), V(0.5, 0.75, -0x1p-60), unit_box,
            0);
    tri_box(l, CAT_PARALLEL_HAIR, V(0.25, 0.25, 1), V(0.75, 0.25, 1), V(0.5, 0.75, 1), unit_box, 1);
    ray_tri(l, CAT_PARALLEL_HAIR, V(-1, 1, 0x1p-60), V(1, 0, 0), 0, INFINITY, a0, a1, a2, 0);
}

static void add_thin(case_list *l)
{
    const vec3 t0 = V(0, 0, 0), t1 = V(4, 0, 0), t2 = V(2, 0x1p-40, 0); /* sliver */
    tri_tri(l, CAT_SLIVER, t0, t1, t2, V(2, 0x1p-41, -1), V(2, 0x1p-41, 1), V(2, -1, 0), 1);
    tri_tri(l, CAT_SLIVER, t0, t1, t2, V(2, 0x1p-39, -1), V(2, 0x1p-39, 1), V(2, 1, 0), 0);
    tri_tri(l, CAT_SLIVER, V(0, 0, 0), V(4, 0, 0), V(0, 4, 0), V(1, 1, -1), V(1, 1 + 0x1p-40, -1), V(1, 1, 5), 1);
    tri_tri(l, CAT_SLIVER, V(0, 0, 0), V(4, 0, 0), V(0, 4, 0), V(3, 1 + 0x1p-40, -1), V(3, 1 + 0x1p-39, -1),
            V(3, 1 + 0x1p-40, 5), 0);
    tri_box(l, CAT_SLIVER, V(1, 0.5, 0.5), V(8, 0.5, 0.5), V(8, 0.5 + 0x1p-40, 0.5), unit_box, 1);
    tri_box(l, CAT_SLIVER, V(up(1), 0.5, 0.5), V(8, 0.5, 0.5), V(8, 0.5 + 0x1p-40, 0.5), unit_box, 0);
    tri_box(l, CAT_SLIVER, V(-4, 1 + 0x1p-45, 0.5), V(4, 1 + 0x1p-45, 0.5), V(0, 1 + 0x1p-44, 0.5), unit_box, 0);
    ray_tri(l, CAT_SLIVER, V(2, 0x1p-42, 1), V(0, 0, -1), 0, INFINITY, t0, t1, t2, 1);
    ray_tri(l, CAT_SLIVER, V(2, 0x1p-39, 1), V(0, 0, -1), 0, INFINITY, t0, t1, t2, 0);
}

static void add_zero_area(case_list *l)
{
    const vec3 b0 = V(0, 0, 1), b1 = V(3, 0, 1), b2 = V(0, 3, 1);
    tri_tri(l, CAT_COLLINEAR, V(0, 0, 0), V(1, 1, 1), V(2, 2, 2), b0, b1, b2, 1);
    tri_tri(l, CAT_COLLINEAR, V(0, 0, -2), V(0.25, 0.25, -1.75), V(0.5, 0.5, -1.5), b0, b1, b2, 0);
    tri_tri(l, CAT_COLLINEAR, V(0, 0, 0), V(2, 2, 2), V(1, 1, 1), V(0, 2, 1), V(2, 0, 1), V(1, 1, 1), 1);
    tri_tri(l, CAT_COLLINEAR, V(0, 0, 0), V(2, 2, 2), V(1, 1, 1), V(0, 2, up(1)), V(2, 0, up(1)), V(1, 1, up(1)), 0);
    tri_box(l, CAT_COLLINEAR, V(-1, 0.5, 0.5), V(0.5, 0.5, 0.5), V(2, 0.5, 0.5), unit_box, 1);
    tri_box(l, CAT_COLLINEAR, V(-1, up(1), 0.5), V(0, up(1), 0.5), V(2, up(1), 0.5), unit_box, 0);
    tri_box(l, CAT_COLLINEAR, V(1, 1, 2), V(1, 1, 3), V(1, 1, 1), unit_box, 1);
    ray_tri(l, CAT_COLLINEAR, V(1, 1, 5), V(0, 0, -1), 0, INFINITY, V(0, 0, 0), V(1, 1, 1), V(2, 2, 2), 0);
    ray_tri(l, CAT_COLLINEAR, V(5, 1, 1), V(-1, 0, 0), 0, INFINITY, V(0, 0, 0), V(1, 1, 1), V(2, 2, 2), 0);

    tri_tri(l, CAT_REPEATED, V(0, 0, 0), V(2, 2, 2), V(0, 0, 0), b0, b1, b2, 1);
    tri_tri(l, CAT_REPEATED, V(1, 1, 1), V(1, 1, 1), V(5, 5, 5), b0, b1, b2, 1);
    tri_tri(l, CAT_REPEATED, V(0, 0, 0), V(0.5, 0.5, 0.5), V(0, 0, 0), b0, b1, b2, 0);
    tri_tri(l, CAT_REPEATED, V(1, 1, up(1)), V(1, 1, up(1)), V(5, 5, 5), b0, b1, b2, 0);
    tri_box(l, CAT_REPEATED, V(0.5, 0.5, 0.5), V(0.5, 0.5, 0.5), V(3, 3, 3), unit_box, 1);
    tri_box(l, CAT_REPEATED, V(1, 1, up(1)), V(1, 1, up(1)), V(2, 2, 2), unit_box, 0);
    tri_box(l, CAT_REPEATED, V(1, 1, 1), V(2, 2, 2), V(2, 2, 2), unit_box, 1);
    ray_tri(l, CAT_REPEATED, V(1, 1, 5), V(0, 0, -1), 0, INFINITY, V(0, 0, 1), V(2, 2, 1), V(0, 0, 1), 0);

    const vec3 a0 = V(0, 0, 0), a1 = V(4, 0, 0), a2 = V(0, 4, 0);
    const vec3 p = V(1, 1, 0), lifted = V(1, 1, 0x1p-60);
    tri_tri(l, CAT_POINT, p, p, p, a0, a1, a2, 1);
    tri_tri(l, CAT_POINT, lifted, lifted, lifted, a0, a1, a2, 0);
    tri_tri(l, CAT_POINT, V(2, 2, 0), V(2, 2, 0), V(2, 2, 0), a0, a1, a2, 1); /* on the hypotenuse */
    tri_tri(l, CAT_POINT, V(1, 1, 1), V(1, 1, 1), V(1, 1, 1), V(1, 1, 1), V(1, 1, 1), V(1, 1, 1), 1);
    tri_tri(l, CAT_POINT, V(1, 1, 1), V(1, 1, 1), V(1, 1, 1), V(1, 1, up(1)), V(1, 1, up(1)), V(1, 1, up(1)), 0);
    tri_box(l, CAT_POINT, V(1, 1, 1), V(1, 1, 1), V(1, 1, 1), unit_box, 1);
    tri_box(l, CAT_POINT, V(up(1), 1, 1), V(up(1), 1, 1), V(up(1), 1, 1), unit_box, 0);
    tri_box(l, CAT_POINT, V(0.5, 0.5, 0.5), V(0.5, 0.5, 0.5), V(0.5, 0.5, 0.5), unit_box, 1);
    ray_tri(l, CAT_POINT, V(1, 1, 5), V(0, 0, -1), 0, INFINITY, p, p, p, 0);
}

static void add_node_boundaries(case_list *l)
{
    const double u = up(1);
    /* Face x = 1 of the unit box: in it, touching it with a vertex or an edge, one ulp out. */
    tri_box(l, CAT_NODE_FACE, V(1, 0.25, 0.25), V(1, 0.75, 0.25), V(1, 0.5, 0.75), unit_box, 1);
    tri_box(l, CAT_NODE_FACE, V(1, 0.5, 0.5), V(2, 0.25, 0.25), V(2, 0.75, 0.75), unit_box, 1);
    tri_box(l, CAT_NODE_FACE, V(1, 0.25, 0.5), V(1, 0.75, 0.5), V(2, 0.5, 0.5), unit_box, 1);
    tri_box(l, CAT_NODE_FACE, V(u, 0.25, 0.25), V(u, 0.75, 0.25), V(u, 0.5, 0.75), unit_box, 0);
    tri_box(l, CAT_NODE_FACE, V(u, 0.5, 0.5), V(2, 0.25, 0.25), V(2, 0.75, 0.75), unit_box, 0);
    tri_box(l, CAT_NODE_FACE, V(u, 0.25, 0.5), V(u, 0.75, 0.5), V(2, 0.5, 0.5), unit_box, 0);
    tri_box(l, CAT_NODE_FACE, V(1, -1, -1), V(1, 3, -1), V(1, -1, 3), unit_box, 1); /* covers the face */
    tri_tri(l, CAT_NODE_FACE, V(1, 0, 0), V(1, 2, 0), V(1, 0, 2), V(1, 0.5, 0.5), V(2, 0.5, 0.5), V(2, 1, 0.5), 1);
    tri_tri(l, CAT_NODE_FACE, V(1, 0, 0), V(1, 2, 0), V(1, 0, 2), V(u, 0.5, 0.5), V(2, 0.5, 0.5), V(2, 1, 0.5), 0);
    ray_tri(l, CAT_NODE_FACE, V(0, 0.5, 0.5), V(1, 0, 0), 0, INFINITY, V(1, 0, 0), V(1, 2, 0), V(1, 0, 2), 1);

    /* Edge x = y = 1. */
    tri_box(l, CAT_NODE_EDGE, V(1.5, 0.5, 0.5), V(0.5, 1.5, 0.5), V(1, 1, 3), unit_box, 1);
    tri_box(l, CAT_NODE_EDGE, V(1.5 + 0x1p-52, 0.5 + 0x1p-52, 0.5), V(0.5 + 0x1p-52, 1.5 + 0x1p-52, 0.5), V(u, u, 3),
            unit_box, 0);
    tri_box(l, CAT_NODE_EDGE, V(1, 1, 0.25), V(1, 1, 0.75), V(3, 3, 0.5), unit_box, 1);
    tri_box(l, CAT_NODE_EDGE, V(u, u, 0.25), V(u, u, 0.75), V(3, 3, 0.5), unit_box, 0);
    tri_box(l, CAT_NODE_EDGE, V(1, 1, 0.25), V(1, 1, 0.75), V(1, 2, 0.5), unit_box, 1);
    tri_box(l, CAT_NODE_EDGE, V(1, u, 0.25), V(1, u, 0.75), V(1, 2, 0.5), unit_box, 0);
    tri_box(l, CAT_NODE_EDGE, V(1, 1, -1), V(1, 1, 2), V(1, 1, 0.5), unit_box, 1); /* segment along the edge */
    ray_tri(l, CAT_NODE_EDGE, V(1, 1, -1), V(0, 0, 1), 0, INFINITY, V(0, 0, 0.5), V(4, 0, 0.5), V(0, 4, 0.5), 1);
    ray_tri(l, CAT_NODE_EDGE, V(1, 1, -1), V(0, 0, 1), 0, 1, V(0, 0, 0.5), V(4, 0, 0.5), V(0, 4, 0.5), 0);

    /* Corner (1, 1, 1): inside a triangle of the plane x + y + z = 3, then that plane
     * moved out by 3 * 2^-50; a vertex on the corner, then one ulp out. */
    const double e = 0x1p-50;
    tri_box(l, CAT_NODE_CORNER, V(1.5, 1.5, 0), V(0, 1.5, 1.5), V(1.5, 0, 1.5), unit_box, 1);
    tri_box(l, CAT_NODE_CORNER, V(1.5 + e, 1.5 + e, e), V(e, 1.5 + e, 1.5 + e), V(1.5 + e, e, 1.5 + e), unit_box, 0);
    tri_box(l, CAT_NODE_CORNER, V(1, 1, 1), V(2, 1, 2), V(1, 2, 2), unit_box, 1);
    /* Along the box's diagonal through the corner, into that triangle at t = 1. */
    ray_tri(l, CAT_NODE_CORNER, V(0, 0, 0), V(1, 1, 1), 0, INFINITY, V(1.5, 1.5, 0), V(0, 1.5, 1.5), V(1.5, 0, 1.5), 1);
    ray_tri(l, CAT_NODE_CORNER, V(0, 0, 0), V(1, 1, 1), 0, down(1), V(1.5, 1.5, 0), V(0, 1.5, 1.5), V(1.5, 0, 1.5),
            0);
    tri_box(l, CAT_NODE_CORNER, V(u, u, u), V(2, 1, 2), V(1, 2, 2), unit_box, 0);
    tri_box(l, CAT_NODE_CORNER, V(1, 1, 1), V(1, 1, 1), V(1, 1, 1), unit_box, 1);
    tri_box(l, CAT_NODE_CORNER, V(2, 1, 1), V(1, 2, 1), V(1, 1, 2), (box3){{0, 0, 0}, {2, 2, 2}}, 1);
    tri_box(l, CAT_NODE_CORNER, V(2, 1, 1), V(1, 2, 1), V(1, 1, 2), (box3){{0, 0, 0}, {0.5, 0.5, 0.5}}, 0);

    /* The world cube [0, 8]^3 itself: on its faces, edges and corners, and just outside. */
    const box3 world = cube(V(0, 0, 0), 8);
    tri_box(l, CAT_WORLD_BOUNDARY, V(0, 1, 1), V(0, 3, 1), V(0, 1, 3), world, 1);
    tri_box(l, CAT_WORLD_BOUNDARY, V(-0x1p-60, 1, 1), V(-0x1p-60, 3, 1), V(-0x1p-60, 1, 3), world, 0);
    tri_box(l, CAT_WORLD_BOUNDARY, V(0, 0, 1), V(0, 0, 3), V(0, 0, 2), world, 1);
    tri_box(l, CAT_WORLD_BOUNDARY, V(8, 8, 8), V(8, 8, 8), V(8, 8, 8), world, 1);
    tri_box(l, CAT_WORLD_BOUNDARY, V(up(8), 8, 8), V(up(8), 8, 8), V(up(8), 8, 8), world, 0);
    tri_box(l, CAT_WORLD_BOUNDARY, V(8, 8, 8), V(9, 8, 10), V(8, 9, 10), world, 1);
    const vec3 w0 = V(0, 0, 0), w1 = V(8, 0, 0), w2 = V(0, 8, 0);
    tri_tri(l, CAT_WORLD_BOUNDARY, w0, w1, w2, V(1, 1, 0), V(3, 1, -2), V(1, 3, -2), 1);
    tri_tri(l, CAT_WORLD_BOUNDARY, w0, w1, w2, V(1, 1, -0x1p-60), V(3, 1, -2), V(1, 3, -2), 0);
    tri_tri(l, CAT_WORLD_BOUNDARY, w0, w1, w2, V(-1, -1, 0), V(0, -2, 0), V(0, 0, 0), 1);
    ray_tri(l, CAT_WORLD_BOUNDARY, V(1, 1, -3), V(0, 0, 1), 0, INFINITY, w0, w1, w2, 1);
    ray_tri(l, CAT_WORLD_BOUNDARY, V(1, 1, -3), V(0, 0, 1), 0, down(3), w0, w1, w2, 0);
    ray_tri(l, CAT_WORLD_BOUNDARY, V(1, 1, -3), V(0, 0, 1), 3, 3, w0, w1, w2, 1);
    ray_tri(l, CAT_WORLD_BOUNDARY, V(-1, 1, 0x1p-59), V(1, 0, -0x1p-60), 0, INFINITY, w0, w1, w2, 1);
}

/* The same few contacts at origin o with triangles of side s: o + k s / 4 must be exact,
 * and the one-ulp gaps are the ulp of the coordinate they sit at. */
static vec3 scaled_point(vec3 o, double s, double x, double y, double z)
{
    return V(o.x + x * s, o.y + y * s, o.z + z * s);
}

static void add_small_at(case_list *l, const char *cat, vec3 o, double s)
{
#define P(x, y, z) scaled_point(o, s, x, y, z)
    const vec3 a0 = P(0, 0, 0), a1 = P(1, 0, 0), a2 = P(0, 1, 0);
    const vec3 hyp = P(0.5, 0.5, 0);
    tri_tri(l, cat, a0, a1, a2, hyp, P(1, 1, 1), P(0.5, 1, 1), 1);
    tri_tri(l, cat, a0, a1, a2, V(hyp.x, hyp.y, up(o.z)), P(1, 1, 1), P(0.5, 1, 1), 0);
    tri_tri(l, cat, a0, a1, a2, P(0.25, 0.25, 0), P(1, 0.25, 0), P(0.25, 1, 0), 1);
    tri_tri(l, cat, a0, a1, a2, V(hyp.x, up(hyp.y), o.z), P(1, 1, 0), P(0.5, 1, 0), 0);
    tri_tri(l, cat, a0, a1, a2, a1, a2, P(1, 1, 1), 1);
    tri_tri(l, cat, a0, a1, a2, P(0.25, 0.25, -1), P(0.25, 0.25, 1), P(2, 2, 0), 1); /* edge through the face */

    const box3 box = {P(0, 0, 0), P(1, 1, 1)};
    const double hi_x = box.hi.x;
    tri_box(l, cat, V(hi_x, box.lo.y + 0.5 * s, box.lo.z + 0.5 * s), P(2, 0.25, 0.25), P(2, 0.75, 0.75), box, 1);
    tri_box(l, cat, V(up(hi_x), box.lo.y + 0.5 * s, box.lo.z + 0.5 * s), P(2, 0.25, 0.25), P(2, 0.75, 0.75), box, 0);
    tri_box(l, cat, P(1.5, 1.5, 0), P(0, 1.5, 1.5), P(1.5, 0, 1.5), box, 1);
    tri_box(l, cat, P(1, 1, 1), P(2, 1, 2), P(1, 2, 2), box, 1);
    tri_box(l, cat, V(up(box.hi.x), up(box.hi.y), up(box.hi.z)), P(2, 1, 2), P(1, 2, 2), box, 0);

    const vec3 down_z = V(0, 0, -1);
    ray_tri(l, cat, P(0.5, 0.25, 1), down_z, 0, INFINITY, a0, a1, a2, 1);
    ray_tri(l, cat, V(hyp.x, down(hyp.y), o.z + s), down_z, 0, INFINITY, a0, a1, a2, 1);
    ray_tri(l, cat, V(hyp.x, up(hyp.y), o.z + s), down_z, 0, INFINITY, a0, a1, a2, 0);
    /* t = s exactly: o.z + s - o.z. */
    ray_tri(l, cat, P(0.25, 0.25, 1), down_z, 0, s, a0, a1, a2, 1);
    ray_tri(l, cat, P(0.25, 0.25, 1), down_z, 0, down(s), a0, a1, a2, 0);
#undef P
}

static void add_rays(case_list *l)
{
    const vec3 a0 = V(0, 0, 0), a1 = V(4, 0, 0), a2 = V(0, 4, 0);
    ray_tri(l, CAT_RAY_IN_PLANE, V(-1, 1, 0), V(1, 0, 0), 0, INFINITY, a0, a1, a2, 0);
    ray_tri(l, CAT_RAY_IN_PLANE, V(1, 1, 0), V(1, 1, 0), 0, INFINITY, a0, a1, a2, 0);
    ray_tri(l, CAT_RAY_IN_PLANE, V(1, 1, 0), V(1, 1, 0), -INFINITY, INFINITY, a0, a1, a2, 0);
    ray_tri(l, CAT_RAY_IN_PLANE, V(-1, 2, 3), V(1, -1, 0), 0, INFINITY, V(4, 0, 0), V(0, 4, 0), V(0, 0, 4), 0);
    ray_tri(l, CAT_RAY_IN_PLANE, V(-1, 1, 0x1p-60), V(1, 0, 0), 0, INFINITY, a0, a1, a2, 0);
    ray_tri(l, CAT_RAY_IN_PLANE, V(0, 1, 0x1p-60), V(1, 0, -0x1p-60), 0, INFINITY, a0, a1, a2, 1);

    ray_tri(l, CAT_RAY_AXIS, V(1, 1, 5), V(0, 0, -1), 0, INFINITY, a0, a1, a2, 1);
    ray_tri(l, CAT_RAY_AXIS, V(5, 5, 5), V(0, 0, -1), 0, INFINITY, a0, a1, a2, 0);
    ray_tri(l, CAT_RAY_AXIS, V(1, -3, 1), V(0, 1, 0), 0, INFINITY, V(0, 2, 0), V(4, 2, 0), V(0, 2, 4), 1);
    ray_tri(l, CAT_RAY_AXIS, V(0, 0.5, 0.5), V(1, 0, 0), 0, INFINITY, V(2, 0, 0), V(2, 4, 0), V(2, 0, 4), 1);
    ray_tri(l, CAT_RAY_AXIS, V(0, 0.5, 4), V(1, 0, 0), 0, INFINITY, V(2, 0, 0), V(2, 4, 0), V(2, 0, 4), 0);
    /* Along the line y = z = 1, which is an edge of nodes in the octree tests. */
    ray_tri(l, CAT_RAY_AXIS, V(0, 1, 1), V(1, 0, 0), 0, INFINITY, V(2, 0, 0), V(2, 4, 0), V(2, 0, 4), 1);
    ray_tri(l, CAT_RAY_AXIS, V(0, 1, 1), V(0x1p-3, 0, 0), 0, INFINITY, V(2, 0, 0), V(2, 4, 0), V(2, 0, 4), 1);
    ray_tri(l, CAT_RAY_AXIS, V(3, 1, 1), V(1, 0, 0), 0, INFINITY, V(2, 0, 0), V(2, 4, 0), V(2, 0, 4), 0);

    ray_tri(l, CAT_RAY_ON_SURFACE, V(1, 1, 0), V(0, 0, 1), 0, INFINITY, a0, a1, a2, 1);
    ray_tri(l, CAT_RAY_ON_SURFACE, V(1, 1, 0), V(0, 0, -1), 0, INFINITY, a0, a1, a2, 1);
    ray_tri(l, CAT_RAY_ON_SURFACE, V(1, 1, 0), V(0, 0, 1), 0x1p-60, INFINITY, a0, a1, a2, 0);
    ray_tri(l, CAT_RAY_ON_SURFACE, V(1, 1, 0), V(1, 1, 1), -INFINITY, INFINITY, a0, a1, a2, 1);
    ray_tri(l, CAT_RAY_ON_SURFACE, V(1, 1, 0), V(1, 1, 1), -INFINITY, -0x1p-60, a0, a1, a2, 0);
    ray_tri(l, CAT_RAY_ON_SURFACE, V(1, 1, 0), V(1, 1, 1), 0, 0, a0, a1, a2, 1);
    ray_tri(l, CAT_RAY_ON_SURFACE, V(1, 1, 0x1p-60), V(0, 0, 1), 0, INFINITY, a0, a1, a2, 0);

    const vec3 g0 = V(0, 0, 0), g1 = V(1, 0, 0), g2 = V(0, 1, 0);
    const double below_half = 0.5 - 0x1p-54; /* x + y = 1 - 2^-54 < 1 */
    ray_tri(l, CAT_RAY_GRAZING, V(0.5, below_half, 1), V(0, 0, -1), 0, INFINITY, g0, g1, g2, 1);
    ray_tri(l, CAT_RAY_GRAZING, V(0.5, up(0.5), 1), V(0, 0, -1), 0, INFINITY, g0, g1, g2, 0);
    ray_tri(l, CAT_RAY_GRAZING, V(0.375, 0.375 - 0x1p-54, 1), V(0x1p-3, 0x1p-3, -1), 0, INFINITY, g0, g1, g2, 1);
    ray_tri(l, CAT_RAY_GRAZING, V(0.375, 0.375 + 0x1p-54, 1), V(0x1p-3, 0x1p-3, -1), 0, INFINITY, g0, g1, g2, 0);
    ray_tri(l, CAT_RAY_GRAZING, V(0x1p-50, 0x1p-50, 1), V(0, 0, -1), 0, INFINITY, g0, g1, g2, 1);
    ray_tri(l, CAT_RAY_GRAZING, V(-0x1p-50, 0x1p-50, 1), V(0, 0, -1), 0, INFINITY, g0, g1, g2, 0);
    /* Descending at 45 degrees across the edge y = 0: lands 2^-60 short of it, or past it. */
    ray_tri(l, CAT_RAY_GRAZING, V(0.5, -0x1p-59, 0x1p-60), V(0, 1, -1), 0, INFINITY, g0, g1, g2, 0);
    ray_tri(l, CAT_RAY_GRAZING, V(0.5, -0x1p-60, 0x1p-59), V(0, 1, -1), 0, INFINITY, g0, g1, g2, 1);

    const vec3 c = V(1, 1, 4);
    ray_tri(l, CAT_RAY_LIMITS, c, V(0, 0, -1), 0, 4, a0, a1, a2, 1);
    ray_tri(l, CAT_RAY_LIMITS, c, V(0, 0, -1), 0, down(4), a0, a1, a2, 0);
    ray_tri(l, CAT_RAY_LIMITS, c, V(0, 0, -1), 4, INFINITY, a0, a1, a2, 1);
    ray_tri(l, CAT_RAY_LIMITS, c, V(0, 0, -1), up(4), INFINITY, a0, a1, a2, 0);
    ray_tri(l, CAT_RAY_LIMITS, c, V(0, 0, -1), 4, 4, a0, a1, a2, 1);
    ray_tri(l, CAT_RAY_LIMITS, c, V(0, 0, -0x1p-3), 32, 32, a0, a1, a2, 1);
    ray_tri(l, CAT_RAY_LIMITS, c, V(0, 0, -0x1p-3), down(32), down(32), a0, a1, a2, 0);
    ray_tri(l, CAT_RAY_LIMITS, V(1, 1, 3), V(0, 0, -4), 0.75, 0.75, a0, a1, a2, 1);
    ray_tri(l, CAT_RAY_LIMITS, V(1, 1, 3), V(0, 0, -4), 0, down(0.75), a0, a1, a2, 0);
    ray_tri(l, CAT_RAY_LIMITS, V(1, 1, 3), V(0.25, 0.5, -4), up(0.75), 1, a0, a1, a2, 0);
    ray_tri(l, CAT_RAY_LIMITS, V(1, 1, 3), V(0.25, 0.5, -4), 0.75, 1, a0, a1, a2, 1);
}

/* ---------- exact-preserving transforms ---------- */

/* transform = symmetry | (extra << 6). symmetry = permutation * 8 + reflections: bit k of
 * the reflections negates axis k, and permutation 0..5 reorders the axes. extra is one of
 * the following, applied after the symmetry. */
enum extra_transform {
    EXTRA_NONE = 0,
    EXTRA_SCALE_DOWN = 1,   /* every coordinate and the direction times 2^-20 */
    EXTRA_SCALE_UP = 2,     /* times 2^20 */
    EXTRA_OFFSET_SMALL = 3, /* points plus (2^20, -2^20, 2^20) */
    EXTRA_OFFSET_LARGE = 4, /* points plus (3 * 2^30, -3 * 2^30, 3 * 2^30) */
    EXTRA_SWAP = 5,         /* tri-tri: a and b exchanged */
    EXTRA_ROTATE = 6,       /* vertex order rotated (a, and b for tri-tri) */
    EXTRA_REVERSE = 7,      /* vertex order reversed (a; b rotated for tri-tri) */
    EXTRA_SWAP_REVERSE = 8, /* tri-tri: swapped and both reversed */
    EXTRA_COUNT = 9,
};

static const int permutations[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};

typedef struct transform_state {
    int exact; /* cleared by any operation that rounded */
} transform_state;

static vec3 apply_symmetry(vec3 p, unsigned symmetry)
{
    const int *perm = permutations[symmetry >> 3];
    double in[3] = {p.x, p.y, p.z}, out[3];
    for (int k = 0; k < 3; k++) {
        double value = in[perm[k]];
        out[k] = (symmetry >> k) & 1u ? -value : value; /* negation is always exact */
    }
    return V(out[0], out[1], out[2]);
}

/* Box corners move with the symmetry, and a reflected axis swaps lo and hi. */
static box3 apply_symmetry_box(box3 b, unsigned symmetry)
{
    vec3 p = apply_symmetry(b.lo, symmetry), q = apply_symmetry(b.hi, symmetry);
    return (box3){vec3_min(p, q), vec3_max(p, q)};
}

/* x * 2^k is exact unless it overflows or loses bits to underflow: scaling back tells. */
static double scaled_exactly(double x, int k, transform_state *st)
{
    double y = ldexp(x, k);
    if (!isfinite(y) || ldexp(y, -k) != x)
        st->exact = 0;
    return y;
}

/* x + offset is exact iff the rounding error of the sum (TwoSum) is zero. */
static double offset_exactly(double x, double offset, transform_state *st)
{
    double s = x + offset;
    double offset_part = s - x;
    double x_part = s - offset_part;
    double error = (x - x_part) + (offset - offset_part);
    if (!isfinite(s) || error != 0.0)
        st->exact = 0;
    return s;
}

static vec3 scale_point(vec3 p, int k, transform_state *st)
{
    return V(scaled_exactly(p.x, k, st), scaled_exactly(p.y, k, st), scaled_exactly(p.z, k, st));
}

static vec3 offset_point(vec3 p, vec3 offset, transform_state *st)
{
    return V(offset_exactly(p.x, offset.x, st), offset_exactly(p.y, offset.y, st), offset_exactly(p.z, offset.z, st));
}

static void map_points(hard_case *c, int scale_k, const vec3 *offset, transform_state *st)
{
    vec3 *points[] = {&c->a[0], &c->a[1], &c->a[2], &c->b[0], &c->b[1], &c->b[2], &c->box.lo, &c->box.hi, &c->origin};
    for (size_t i = 0; i < sizeof points / sizeof points[0]; i++)
        *points[i] = offset ? offset_point(*points[i], *offset, st) : scale_point(*points[i], scale_k, st);
    /* Scaling the direction with the points keeps every t; offsets leave it alone. */
    if (!offset)
        c->direction = scale_point(c->direction, scale_k, st);
}

static void rotate3(vec3 t[3])
{
    vec3 first = t[0];
    t[0] = t[1];
    t[1] = t[2];
    t[2] = first;
}

static void reverse3(vec3 t[3])
{
    vec3 first = t[0];
    t[0] = t[2];
    t[2] = first;
}

static void swap_triangles(hard_case *c)
{
    for (int i = 0; i < 3; i++) {
        vec3 t = c->a[i];
        c->a[i] = c->b[i];
        c->b[i] = t;
    }
}

/* The variant, or 0 when the transform does not apply to the case's kind or would round. */
static int make_variant(const hard_case *base, unsigned symmetry, int extra, hard_case *out)
{
    hard_case c = *base;
    for (int i = 0; i < 3; i++) {
        c.a[i] = apply_symmetry(c.a[i], symmetry);
        c.b[i] = apply_symmetry(c.b[i], symmetry);
    }
    c.box = apply_symmetry_box(c.box, symmetry);
    c.origin = apply_symmetry(c.origin, symmetry);
    c.direction = apply_symmetry(c.direction, symmetry);

    transform_state st = {1};
    const vec3 offset_small = V(0x1p20, -0x1p20, 0x1p20), offset_large = V(0x3p30, -0x3p30, 0x3p30);
    const int tri_tri = c.kind == HARD_TRI_TRI;
    switch (extra) {
    case EXTRA_NONE:
        break;
    case EXTRA_SCALE_DOWN:
        map_points(&c, -20, NULL, &st);
        break;
    case EXTRA_SCALE_UP:
        map_points(&c, 20, NULL, &st);
        break;
    case EXTRA_OFFSET_SMALL:
        map_points(&c, 0, &offset_small, &st);
        break;
    case EXTRA_OFFSET_LARGE:
        map_points(&c, 0, &offset_large, &st);
        break;
    case EXTRA_SWAP:
        if (!tri_tri)
            return 0;
        swap_triangles(&c);
        break;
    case EXTRA_ROTATE:
        rotate3(c.a);
        if (tri_tri)
            rotate3(c.b);
        break;
    case EXTRA_REVERSE:
        reverse3(c.a);
        if (tri_tri) {
            rotate3(c.b);
            rotate3(c.b);
        }
        break;
    case EXTRA_SWAP_REVERSE:
        if (!tri_tri)
            return 0;
        swap_triangles(&c);
        reverse3(c.a);
        reverse3(c.b);
        break;
    default:
        return 0;
    }
    if (!st.exact)
        return 0;
    c.transform = symmetry | (unsigned)extra << 6;
    *out = c;
    return 1;
}

/* The base case first (transform 0), then every variant of it; a group ends where the next
 * transform-0 case begins. */
static void expand(case_list *out, const hard_case *base)
{
    static const unsigned extra_symmetries[] = {0, 47, 21};
    for (unsigned symmetry = 0; symmetry < 48; symmetry++) {
        hard_case v;
        if (make_variant(base, symmetry, EXTRA_NONE, &v))
            push(out, &v);
    }
    for (size_t s = 0; s < sizeof extra_symmetries / sizeof extra_symmetries[0]; s++)
        for (int extra = 1; extra < EXTRA_COUNT; extra++) {
            hard_case v;
            if (make_variant(base, extra_symmetries[s], extra, &v))
                push(out, &v);
        }
}

size_t hard_cases_generate(hard_case **out)
{
    case_list base = {0}, all = {0};
    add_coplanar(&base);
    add_shared(&base);
    add_contacts(&base);
    add_near_parallel(&base);
    add_thin(&base);
    add_zero_area(&base);
    add_node_boundaries(&base);
    add_small_at(&base, CAT_OFFSET_1E6, V(1e6, 1e6, 1e6), 0x1p-20);
    add_small_at(&base, CAT_OFFSET_1E6, V(-1e6, 1e6, 3e6), 0x1p-12);
    add_small_at(&base, CAT_OFFSET_1E9, V(1e9, 1e9, 1e9), 0x1p-16);
    add_small_at(&base, CAT_OFFSET_1E9, V(1e9, -2e9, 5e8), 0x1p-14);
    add_small_at(&base, CAT_SIZE_1E_9, V(0.5, 0.25, 0.125), 0x1p-30);
    add_small_at(&base, CAT_SIZE_1E_9, V(1, 0.5, -0.25), 0x1p-30);
    add_rays(&base);
    for (size_t i = 0; i < base.count && !base.out_of_memory; i++)
        expand(&all, &base.items[i]);
    int failed = base.out_of_memory || all.out_of_memory;
    free(base.items);
    if (failed) {
        free(all.items);
        *out = NULL;
        return 0;
    }
    *out = all.items;
    return all.count;
}

int hard_case_answer(const hard_case *c, int accuracy_mode, double seed_eps)
{
    switch (c->kind) {
    case HARD_TRI_TRI:
        return accuracy_mode == ACCURACY_SEED   ? tri_tri_overlap_seed(c->a, c->b, seed_eps)
               : accuracy_mode == ACCURACY_FAST ? tri_tri_overlap_fast(c->a, c->b)
                                                : tri_tri_overlap_exact(c->a, c->b);
    case HARD_TRI_BOX:
        return accuracy_mode == ACCURACY_SEED   ? tri_box_overlap_seed(c->a, c->box, seed_eps)
               : accuracy_mode == ACCURACY_FAST ? tri_box_overlap_fast(c->a, c->box)
                                                : tri_box_overlap_exact(c->a, c->box);
    case HARD_RAY_TRI:
        return accuracy_mode == ACCURACY_SEED
                   ? ray_tri_seed(c->origin, c->direction, c->tmin, c->tmax, c->a, seed_eps, NULL)
               : accuracy_mode == ACCURACY_FAST ? ray_tri_fast(c->origin, c->direction, c->tmin, c->tmax, c->a, NULL)
                                                : ray_tri_exact(c->origin, c->direction, c->tmin, c->tmax, c->a, NULL);
    }
    return 0;
}
