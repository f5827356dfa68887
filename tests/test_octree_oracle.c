/* The octree against the independent oracle (support/oracle.h: GMP rationals, no engine
 * code) over every triangle: exact-mode triangle queries (yes/no and ids) and rays (any,
 * closest, all) on small random and hard scenes at full-mantissa coordinates, at several
 * resolutions and depth caps. test_octree compares the tree with brute force over the
 * engine's own predicates, which checks the walk; this checks the answers. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "engine.h"
#include "geom/box_geometry.h"
#include "support/meshgen.h"
#include "support/oracle.h"
#include "support/oracle_mesh.h"

static uint64_t base_seed = 20260417;

/* ---------- building scenes ---------- */

typedef struct scene {
    const char *name;
    mesh_data mesh;
    size_t vertex_cap, triangle_cap;
    vec3 (*tris)[3];
    const char **tri_kind;
    size_t tri_count, tri_cap;
    ray_input *rays;
    const char **ray_kind;
    size_t ray_count, ray_cap;
} scene;

static void *grow(void *p, size_t *cap, size_t need, size_t size)
{
    if (need <= *cap)
        return p;
    size_t n = *cap ? *cap : 16;
    while (n < need)
        n *= 2;
    void *q = realloc(p, n * size);
    if (!q)
        fail_msg("out of memory");
    *cap = n;
    return q;
}

static void add_triangle(scene *s, vec3 a, vec3 b, vec3 c)
{
    mesh_data *m = &s->mesh;
    size_t vcap = s->vertex_cap, tcap = s->triangle_cap;
    m->vertices = grow(m->vertices, &vcap, m->vertex_count + 3, sizeof *m->vertices);
    m->indices = grow(m->indices, &tcap, 3 * (m->triangle_count + 1), sizeof *m->indices);
    s->vertex_cap = vcap, s->triangle_cap = tcap;
    const vec3 v[3] = {a, b, c};
    for (int k = 0; k < 3; k++) {
        m->indices[3 * m->triangle_count + (size_t)k] = (uint32_t)m->vertex_count;
        m->vertices[m->vertex_count++] = v[k];
    }
    m->triangle_count++;
}

static void add_query_triangle(scene *s, const char *kind, vec3 a, vec3 b, vec3 c)
{
    size_t cap = s->tri_cap;
    s->tris = grow(s->tris, &cap, s->tri_count + 1, sizeof *s->tris);
    cap = s->tri_cap;
    s->tri_kind = grow(s->tri_kind, &cap, s->tri_count + 1, sizeof *s->tri_kind);
    s->tri_cap = cap;
    s->tris[s->tri_count][0] = a, s->tris[s->tri_count][1] = b, s->tris[s->tri_count][2] = c;
    s->tri_kind[s->tri_count++] = kind;
}

static void add_ray(scene *s, const char *kind, vec3 o, vec3 d, double tmin, double tmax)
{
    if (d.x == 0 && d.y == 0 && d.z == 0)
        return;
    size_t cap = s->ray_cap;
    s->rays = grow(s->rays, &cap, s->ray_count + 1, sizeof *s->rays);
    cap = s->ray_cap;
    s->ray_kind = grow(s->ray_kind, &cap, s->ray_count + 1, sizeof *s->ray_kind);
    s->ray_cap = cap;
    s->rays[s->ray_count] = (ray_input){o, d, tmin, tmax, RAY_CROSSING};
    s->ray_kind[s->ray_count++] = kind;
}

static void scene_free(scene *s)
{
    mesh_data_free(&s->mesh);
    free(s->tris);
    free(s->tri_kind);
    free(s->rays);
    free(s->ray_kind);
    memset(s, 0, sizeof *s);
}

static vec3 corner(const scene *s, size_t t, int k)
{
    return s->mesh.vertices[s->mesh.indices[3 * t + (size_t)k]];
}

/* True when a - b is exact (TwoSum error zero). */
static int difference_is_exact(double a, double b)
{
    double s = a - b, nb = -b, bb = s - a;
    return (a - (s - bb)) + (nb - bb) == 0.0;
}

/* A ray from o that passes exactly through p at t = 1: d = p - o where each coordinate's
 * difference is exact, else that coordinate of o is moved onto p's (d 0 there). */
static void add_ray_through(scene *s, const char *kind, vec3 o, vec3 p)
{
    double oc[3] = {o.x, o.y, o.z}, pc[3] = {p.x, p.y, p.z}, dc[3];
    for (int a = 0; a < 3; a++) {
        if (!difference_is_exact(pc[a], oc[a]))
            oc[a] = pc[a];
        dc[a] = pc[a] - oc[a];
    }
    add_ray(s, kind, vec3_make(oc[0], oc[1], oc[2]), vec3_make(dc[0], dc[1], dc[2]), 0.0, INFINITY);
}

/* An axis-aligned ray through p from outside box b (exactly through p: only one
 * coordinate differs). */
static void add_axis_ray_through(scene *s, const char *kind, rng *r, vec3 p, box3 b)
{
    int axis = (int)(rng_next(r) % 3), neg = (int)(rng_next(r) & 1);
    vec3 o = vec3_with(p, axis, neg ? vec3_get(b.hi, axis) + 1.0 : vec3_get(b.lo, axis) - 1.0);
    add_ray(s, kind, o, vec3_with(vec3_make(0, 0, 0), axis, neg ? -1.0 : 1.0), 0.0, INFINITY);
}

static box3 grown(box3 b, double by)
{
    vec3 e = vec3_scale(vec3_sub(b.hi, b.lo), by);
    return (box3){vec3_sub(b.lo, e), vec3_add(b.hi, e)};
}

/* A point inside triangle t (barycentric weights in doubles: near the triangle, and the
 * oracle says exactly where). */
static vec3 point_on(const scene *s, rng *r, size_t t)
{
    double u = rng_uniform(r, 0.05, 0.9), v = rng_uniform(r, 0.05, 0.9);
    if (u + v > 0.95)
        u = 0.95 - u, v = 0.95 - v;
    u = fabs(u), v = fabs(v);
    vec3 a = corner(s, t, 0), b = corner(s, t, 1), c = corner(s, t, 2);
    return vec3_add(a, vec3_add(vec3_scale(vec3_sub(b, a), u), vec3_scale(vec3_sub(c, a), v)));
}

/* The queries every scene gets, drawn from its triangles: triangles near the surface,
 * mesh triangles themselves, triangles sharing a mesh vertex; rays toward triangle
 * interiors, exactly through vertices, along axes through vertices, and bounded ones. */
static void add_common_queries(scene *s, rng *r, int count, double size)
{
    box3 b = mesh_data_bounds(&s->mesh), around = grown(b, 0.3);
    size_t n = s->mesh.triangle_count;
    for (int i = 0; i < count; i++) {
        size_t t = rng_next(r) % n;
        vec3 p = point_on(s, r, t);
        vec3 v = corner(s, t, (int)(rng_next(r) % 3));
        vec3 q1 = vec3_add(p, vec3_scale(rng_unit_vector(r), size * rng_uniform(r, 0.2, 1)));
        vec3 q2 = vec3_add(p, vec3_scale(rng_unit_vector(r), size * rng_uniform(r, 0.2, 1)));
        switch (i % 3) {
        case 0: add_query_triangle(s, "near the surface", p, q1, q2); break;
        case 1: add_query_triangle(s, "a mesh triangle", corner(s, t, 0), corner(s, t, 1), corner(s, t, 2)); break;
        default: add_query_triangle(s, "sharing a mesh vertex", v, q1, q2); break;
        }
        vec3 o = rng_point_in_box(r, around);
        switch (i % 4) {
        case 0: add_ray(s, "toward an interior", o, vec3_sub(p, o), 0.0, INFINITY); break;
        case 1: add_ray_through(s, "exactly through a vertex", o, v); break;
        case 2: add_axis_ray_through(s, "along an axis through a vertex", r, v, b); break;
        default: add_ray(s, "bounded, toward an interior", o, vec3_sub(p, o), 0.0, rng_uniform(r, 0.5, 1.5)); break;
        }
    }
}

/* Random triangles at full-mantissa coordinates in a box straddling the origin. */
static void make_soup(scene *s, uint64_t seed)
{
    s->name = "soup";
    box3 region = {{-1.3724519, -0.7031, -0.9152}, {2.1135, 1.6877, 1.1049}};
    mesh_data m = meshgen_soup(seed, 180, region, 0.45);
    for (size_t t = 0; t < m.triangle_count; t++)
        add_triangle(s, mesh_data_corner(&m, t, 0), mesh_data_corner(&m, t, 1), mesh_data_corner(&m, t, 2));
    mesh_data_free(&m);
    rng r = rng_seeded(seed + 1);
    add_common_queries(s, &r, 120, 0.4);
}

/* Sorted random full-mantissa values, the lines of a grid. */
static void grid_lines(rng *r, double lo, double hi, int n, double *out)
{
    for (int i = 0; i < n; i++)
        out[i] = lo + (hi - lo) * ((i + rng_uniform(r, 0.15, 0.85)) / n);
}

/* Coplanar grids whose cells are split into two triangles (shared edges and vertices),
 * in the plane z = z0 and in the tilted plane x = y, a duplicated (coincident) triangle,
 * and random triangles around; queries that touch them exactly: coplanar along an edge,
 * a corner on a face, sharing a vertex, and the same one ulp away. */
static void make_touching(scene *s, uint64_t seed)
{
    s->name = "touching";
    rng r = rng_seeded(seed);
    enum { G = 6 };
    double xs[G], ys[G], us[G], ws[G];
    grid_lines(&r, -0.913, 1.077, G, xs);
    grid_lines(&r, -0.851, 1.013, G, ys);
    grid_lines(&r, -0.777, 0.981, G, us);
    grid_lines(&r, -0.933, 0.911, G, ws);
    const double z0 = 0.1234567890123457;
    for (int i = 0; i + 1 < G; i++)
        for (int j = 0; j + 1 < G; j++) {
            vec3 a = {xs[i], ys[j], z0}, b = {xs[i + 1], ys[j], z0}, c = {xs[i], ys[j + 1], z0},
                 d = {xs[i + 1], ys[j + 1], z0};
            add_triangle(s, a, b, c);
            add_triangle(s, b, d, c);
            vec3 e = {us[i], us[i], ws[j]}, f = {us[i + 1], us[i + 1], ws[j]}, g = {us[i], us[i], ws[j + 1]},
                 h = {us[i + 1], us[i + 1], ws[j + 1]};
            add_triangle(s, e, f, g);
            add_triangle(s, f, h, g);
        }
    size_t duplicated = 7;
    add_triangle(s, corner(s, duplicated, 0), corner(s, duplicated, 1), corner(s, duplicated, 2));
    mesh_data m = meshgen_soup(seed + 2, 60, (box3){{-0.95, -0.9, -0.8}, {1.1, 1.05, 1.0}}, 0.4);
    for (size_t t = 0; t < m.triangle_count; t++)
        add_triangle(s, mesh_data_corner(&m, t, 0), mesh_data_corner(&m, t, 1), mesh_data_corner(&m, t, 2));
    mesh_data_free(&m);

    box3 b = mesh_data_bounds(&s->mesh);
    for (int k = 0; k < 40; k++) {
        int i = 1 + (int)(rng_next(&r) % (G - 2)), j = (int)(rng_next(&r) % (G - 1));
        double y1 = rng_uniform(&r, ys[j], ys[j + 1]), y2 = rng_uniform(&r, ys[0], ys[G - 1]);
        double w = rng_uniform(&r, 0.05, 0.3);
        int gap = k % 4 == 3; /* one ulp off the plane or the edge: must miss there */
        double zq = gap ? nextafter(z0, INFINITY) : z0;
        /* In the plane, touching the grid's outer edge x = xs[0] from outside. */
        double x0 = gap ? nextafter(xs[0], -INFINITY) : xs[0];
        add_query_triangle(s, gap ? "coplanar, one ulp off the edge" : "coplanar, along an edge",
                           vec3_make(x0, y1, z0), vec3_make(x0, y2, z0), vec3_make(x0 - w, 0.5 * (y1 + y2), z0));
        /* A corner on a cell's face (or on the grid line x = xs[i], an interior edge), the
         * rest above. */
        double xf = (k & 1) ? xs[i] : rng_uniform(&r, xs[i], xs[i + 1]);
        vec3 on = {xf, y1, zq};
        add_query_triangle(s, gap ? "a corner one ulp above a face" : "a corner on a face or an edge", on,
                           vec3_make(xf + w, y1 - w, z0 + w), vec3_make(xf - w, y1 + 0.5 * w, z0 + 2 * w));
        /* Sharing a grid vertex of the tilted plane, from one side of it. */
        vec3 gv = {us[i], us[i], ws[j]};
        add_query_triangle(s, "sharing a vertex of the tilted grid", gv, vec3_make(us[i] + w, us[i] - w, ws[j]),
                           vec3_make(us[i] + w, us[i] - 2 * w, ws[j] + w));
        /* Rays: across a cell's interior (clean), exactly through a grid vertex or along a
         * grid edge's line (boundary), in the plane along a grid line, onto the duplicate. */
        double xc = rng_uniform(&r, xs[i], xs[i + 1]);
        add_ray(s, "perpendicular across a cell", vec3_make(xc, y1, 2.0), vec3_make(0, 0, -1), 0.0, INFINITY);
        add_ray(s, "perpendicular through a grid vertex", vec3_make(xs[i], ys[j], -2.0), vec3_make(0, 0, 1), 0.0,
                INFINITY);
        add_ray_through(s, "tilted, exactly through a grid vertex", rng_point_in_box(&r, grown(b, 0.3)),
                        vec3_make(xs[i], ys[j], z0));
        add_ray(s, "in the plane along a grid line", vec3_make(-3.0, ys[j], z0), vec3_make(1, 0, 0), 0.0, INFINITY);
        add_ray(s, "through the tilted grid's edge line", vec3_make(us[i], us[i], -3.0), vec3_make(0, 0, 1), 0.0,
                INFINITY);
        vec3 dup = point_on(s, &r, duplicated);
        add_ray(s, "onto a duplicated triangle", vec3_make(dup.x, dup.y, 1.5), vec3_make(0, 0, -1), 0.0, INFINITY);
    }
    add_common_queries(s, &r, 60, 0.3);
}

/* A world whose upper corner lo + (hi - lo) rounds below hi in doubles along x, the
 * longest axis, with a wall of triangles in the plane x = hi.x: contacts on the mesh's
 * largest coordinate, which the world cube must still enclose. */
static void make_upper_bounds(scene *s, uint64_t seed)
{
    s->name = "upper bounds";
    rng r = rng_seeded(seed);
    double lox = 0, hix = 0;
    for (int tries = 0;; tries++) {
        assert_true(tries < 10000);
        lox = rng_uniform(&r, -1.9, -1.1);
        hix = rng_uniform(&r, 1.1, 1.9);
        if (lox + (hix - lox) < hix)
            break;
    }
    const box3 inner = {{lox, -0.61, -0.57}, {hix, 0.63, 0.59}};
    /* Corners that fix the bounds, then the wall. */
    add_triangle(s, vec3_make(lox, -0.61, -0.57), vec3_make(lox, -0.5, -0.57), vec3_make(lox, -0.61, -0.45));
    enum { G = 4 };
    double ys[G], zs[G];
    grid_lines(&r, -0.61, 0.63, G, ys);
    grid_lines(&r, -0.57, 0.59, G, zs);
    ys[G - 1] = 0.63, zs[G - 1] = 0.59;
    for (int i = 0; i + 1 < G; i++)
        for (int j = 0; j + 1 < G; j++) {
            vec3 a = {hix, ys[i], zs[j]}, b = {hix, ys[i + 1], zs[j]}, c = {hix, ys[i], zs[j + 1]},
                 d = {hix, ys[i + 1], zs[j + 1]};
            add_triangle(s, a, b, c);
            add_triangle(s, b, d, c);
        }
    mesh_data m = meshgen_soup(seed + 3, 100, inner, 0.5);
    for (size_t t = 0; t < m.triangle_count; t++)
        add_triangle(s, mesh_data_corner(&m, t, 0), mesh_data_corner(&m, t, 1), mesh_data_corner(&m, t, 2));
    mesh_data_free(&m);
    box3 b = mesh_data_bounds(&s->mesh);
    assert_true(b.hi.x == hix && b.lo.x == lox);

    for (int k = 0; k < 40; k++) {
        double y = rng_uniform(&r, ys[0], ys[G - 1]), z = rng_uniform(&r, zs[0], zs[G - 1]);
        double w = rng_uniform(&r, 0.05, 0.3);
        int i = (int)(rng_next(&r) % G), j = (int)(rng_next(&r) % G);
        add_query_triangle(s, "a corner on the wall, the rest outside", vec3_make(hix, y, z),
                           vec3_make(hix + w, y + w, z), vec3_make(hix + w, y, z - w));
        add_query_triangle(s, "sharing a wall vertex from outside", vec3_make(hix, ys[i], zs[j]),
                           vec3_make(hix + w, ys[i] + w, zs[j]), vec3_make(hix + 2 * w, ys[i], zs[j] + w));
        add_query_triangle(s, "in the wall's plane, overlapping it", vec3_make(hix, y, z),
                           vec3_make(hix, y + w, z), vec3_make(hix, y, z + w));
        add_query_triangle(s, "one ulp outside the wall", vec3_make(nextafter(hix, INFINITY), y, z),
                           vec3_make(hix + w, y + w, z), vec3_make(hix + w, y, z - w));
        /* Rays across the wall from just outside it (a small t, so no widening covers a
         * world one ulp short) and from far away. */
        double near = nextafter(hix, INFINITY) + 0x1p-40;
        add_ray(s, "across the wall from just outside", vec3_make(near, y, z), vec3_make(-1, 0, 0), 0.0, INFINITY);
        add_ray(s, "across the wall from far", vec3_make(hix + 3.0, y, z), vec3_make(-1, 0, 0), 0.0, INFINITY);
        add_ray(s, "onto the wall, ending there", vec3_make(hix + 1.0, y, z), vec3_make(-1, 0, 0), 0.0, 1.0);
        add_ray(s, "through a wall vertex", vec3_make(hix + 1.0, ys[i], zs[j]), vec3_make(-1, 0, 0), 0.0, INFINITY);
    }
    add_common_queries(s, &r, 40, 0.4);
}

/* The planes of a world's node faces along one axis, to `levels` levels below the root:
 * split as the engine splits boxes (box_split_point), collected in out. */
static int node_planes(double lo, double hi, int levels, double *out, int n)
{
    out[n++] = box_split(lo, hi);
    if (levels > 1) {
        n = node_planes(lo, out[n - 1], levels - 1, out, n);
        n = node_planes(box_split(lo, hi), hi, levels - 1, out, n);
    }
    return n;
}

/* Triangles lying in node faces (split planes of the first three levels and the world's
 * own faces) of the world `w` at full-mantissa in-plane coordinates, a frame fixing the
 * bounds, and queries touching them: in the face, a corner on it, rays across it and
 * along it. */
static void make_node_faces(scene *s, uint64_t seed, box3 frame, box3 w)
{
    s->name = "node faces";
    rng r = rng_seeded(seed);
    add_triangle(s, frame.lo, vec3_make(frame.lo.x + 0.1, frame.lo.y, frame.lo.z),
                 vec3_make(frame.lo.x, frame.lo.y + 0.1, frame.lo.z));
    add_triangle(s, frame.hi, vec3_make(frame.hi.x - 0.1, frame.hi.y, frame.hi.z),
                 vec3_make(frame.hi.x, frame.hi.y - 0.1, frame.hi.z));
    double planes[3][16];
    int np[3];
    for (int a = 0; a < 3; a++) {
        double all[16];
        int n = node_planes(vec3_get(w.lo, a), vec3_get(w.hi, a), 3, all, 0);
        np[a] = 0;
        planes[a][np[a]++] = vec3_get(frame.lo, a); /* the world's lower face */
        for (int k = 0; k < n; k++) /* those inside the frame, which fixes the bounds */
            if (all[k] <= vec3_get(frame.hi, a) - 0.5)
                planes[a][np[a]++] = all[k];
    }
    for (int k = 0; k < 120; k++) {
        int a = k % 3, u = (a + 1) % 3, v = (a + 2) % 3;
        double c = planes[a][rng_next(&r) % (size_t)np[a]];
        /* Kept half a unit inside the frame's upper faces, so the bounds stay the frame's. */
        vec3 p = rng_point_in_box(&r, (box3){frame.lo, vec3_sub(frame.hi, vec3_make(0.5, 0.5, 0.5))});
        p = vec3_with(p, a, c);
        double w1 = rng_uniform(&r, 0.1, 0.5), w2 = rng_uniform(&r, 0.1, 0.5);
        vec3 q = vec3_with(p, u, vec3_get(p, u) + w1), t = vec3_with(p, v, vec3_get(p, v) + w2);
        if (k < 60) {
            add_triangle(s, p, q, t);
            continue;
        }
        /* A query in the same face, overlapping a face triangle's corner; one with a corner
         * on the plane and the rest off it; rays across and along the plane. */
        size_t ft = 2 + (rng_next(&r) % 60);
        vec3 fc = corner(s, ft, 0);
        int fa = (int)((ft - 2) % 3), fu = (fa + 1) % 3;
        add_query_triangle(s, "in a node face, overlapping a face triangle", fc,
                           vec3_with(fc, fu, vec3_get(fc, fu) - w1), vec3_with(fc, (fa + 2) % 3, vec3_get(fc, (fa + 2) % 3) - w2));
        vec3 off = vec3_with(q, a, c + w1), off2 = vec3_with(t, a, c + w2);
        add_query_triangle(s, "a corner on a node face", p, off, off2);
        vec3 inside = point_on(s, &r, ft);
        add_ray(s, "across a node face into a face triangle", vec3_with(inside, fa, vec3_get(inside, fa) + 2.0),
                vec3_with(vec3_make(0, 0, 0), fa, -1.0), 0.0, INFINITY);
        add_ray(s, "ending on a node face", vec3_with(inside, fa, vec3_get(inside, fa) - 1.0),
                vec3_with(vec3_make(0, 0, 0), fa, 1.0), 0.0, 1.0);
        add_ray(s, "along a node face", vec3_with(vec3_with(p, u, vec3_get(frame.lo, u) - 1.0), a, c),
                vec3_with(vec3_make(0, 0, 0), u, 1.0), 0.0, INFINITY);
    }
}

/* ---------- the truth and the comparison ---------- */

typedef struct truth {
    oracle_mesh om;
    uint32_t **ids; /* per triangle query */
    size_t *id_count;
    oracle_ray_truth *rays;
    size_t touching_queries, clean_rays, clean_hits, boundary_rays;
} truth;

static void truth_compute(truth *t, const scene *s)
{
    mesh_view v = mesh_data_view(&s->mesh);
    assert_int_equal(oracle_mesh_init(&t->om, &v), 0);
    t->ids = calloc(s->tri_count, sizeof *t->ids);
    t->id_count = calloc(s->tri_count, sizeof *t->id_count);
    t->rays = calloc(s->ray_count, sizeof *t->rays);
    assert_true(t->ids && t->id_count && t->rays);
    t->touching_queries = t->clean_rays = t->clean_hits = t->boundary_rays = 0;
    for (size_t i = 0; i < s->tri_count; i++) {
        t->ids[i] = malloc(s->mesh.triangle_count * sizeof **t->ids);
        assert_non_null(t->ids[i]);
        t->id_count[i] = oracle_mesh_triangle(&t->om, s->tris[i], t->ids[i], s->mesh.triangle_count);
        t->touching_queries += t->id_count[i] > 0;
    }
    for (size_t i = 0; i < s->ray_count; i++) {
        assert_int_equal(oracle_mesh_ray(&t->om, &s->rays[i], &t->rays[i]), 0);
        if (t->rays[i].boundary) {
            t->boundary_rays++;
        } else {
            t->clean_rays++;
            t->clean_hits += t->rays[i].count > 0;
        }
    }
}

static void truth_free(truth *t, const scene *s)
{
    for (size_t i = 0; i < s->tri_count; i++)
        free(t->ids[i]);
    for (size_t i = 0; i < s->ray_count; i++)
        oracle_ray_truth_free(&t->rays[i]);
    free(t->ids);
    free(t->id_count);
    free(t->rays);
    oracle_mesh_free(&t->om);
}

typedef struct config {
    char label[96];
    octree_def def;
} config;

/* Failures printed per configuration, at most this many triangle queries and rays each. */
#define MAX_PRINTED 6

static void print_triangle(const vec3 q[3])
{
    for (int k = 0; k < 3; k++)
        printf("%s(%a, %a, %a)", k ? ", " : "      query ", q[k].x, q[k].y, q[k].z);
    printf("\n");
}

static void print_ids(const char *who, const uint32_t *ids, size_t n)
{
    printf("      %s {", who);
    for (size_t k = 0; k < n && k < 12; k++)
        printf("%s%u", k ? ", " : "", ids[k]);
    printf("%s}\n", n > 12 ? ", ..." : "");
}

/* Builds the scene at the configuration and compares every query with the truth;
 * returns the number of wrong answers (each printed, up to MAX_PRINTED). */
static size_t check_config(const scene *s, const truth *tr, const config *c)
{
    mesh_view v = mesh_data_view(&s->mesh);
    octree_error err;
    octree *tree = octree_build(&v, &c->def, &err);
    if (!tree)
        fail_msg("%s, %s: build failed: %s", s->name, c->label, err.message);
    octree_info info;
    octree_get_info(tree, &info);
    size_t wrong = 0, tri_wrong = 0, ray_wrong = 0, n = s->mesh.triangle_count;
    tri_contact *got = malloc(n * sizeof *got);
    uint32_t *got_ids = malloc(n * sizeof *got_ids);
    ray_hit *hits = malloc((n + 1) * sizeof *hits);
    assert_true(got && got_ids && hits);
    for (size_t i = 0; i < s->tri_count; i++) {
        tri_output out = {.contacts = got, .capacity = n};
        assert_int_equal(octree_triangle(tree, s->tris[i], TRI_IDS, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
        tri_output yn = {0};
        assert_int_equal(octree_triangle(tree, s->tris[i], TRI_YESNO, ACCURACY_EXACT, &yn, NULL), OCTREE_OK);
        for (size_t k = 0; k < out.count && k < n; k++)
            got_ids[k] = got[k].triangle;
        int same = out.count == tr->id_count[i] && !out.truncated &&
                   memcmp(got_ids, tr->ids[i], out.count * sizeof *got_ids) == 0;
        int yes_right = yn.hit == (tr->id_count[i] > 0);
        if (same && yes_right)
            continue;
        if (wrong++, tri_wrong++ < MAX_PRINTED) {
            printf("    WRONG %s, %s: triangle query %zu (%s): yes/no %d, oracle %d\n", s->name, c->label, i,
                   s->tri_kind[i], yn.hit, tr->id_count[i] > 0);
            print_triangle(s->tris[i]);
            print_ids("oracle", tr->ids[i], tr->id_count[i]);
            print_ids("octree", got_ids, out.count < n ? out.count : n);
        }
    }
    for (size_t i = 0; i < s->ray_count; i++) {
        const ray_input *ray = &s->rays[i];
        for (int detail = RAY_ANY; detail <= RAY_ALL; detail++) {
            ray_output out = {.hits = hits, .max_hits = n + 1};
            assert_int_equal(octree_ray(tree, ray, (ray_detail)detail, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
            char why[256];
            int ok = oracle_ray_answer_ok(&tr->om, ray, &tr->rays[i], (ray_detail)detail, hits, out.hit_count, why,
                                          sizeof why);
            /* On a clean ray the reported t is the rounded exact one. */
            if (ok && detail == RAY_CLOSEST && out.hit_count && !tr->rays[i].boundary) {
                vec3 t3[3];
                oracle_mesh_triangle_at(&tr->om, hits[0].triangle, t3);
                double te = oracle_plane_t(ray->origin, ray->direction, t3);
                if (fabs(hits[0].t - te) > 0x1p-50 * fmax(fabs(te), 0x1p-1000)) {
                    ok = 0;
                    snprintf(why, sizeof why, "t %.17g, exact %.17g", hits[0].t, te);
                }
            }
            if (ok)
                continue;
            if (wrong++, ray_wrong++ < MAX_PRINTED)
                printf("    WRONG %s, %s: ray %zu (%s, %s contact) detail %d: %s\n"
                       "      o (%a, %a, %a) d (%a, %a, %a) t [%a, %a]\n",
                       s->name, c->label, i, s->ray_kind[i], tr->rays[i].boundary ? "boundary" : "no boundary",
                       detail, why, ray->origin.x, ray->origin.y, ray->origin.z, ray->direction.x, ray->direction.y,
                       ray->direction.z, ray->tmin, ray->tmax);
        }
    }
    if (wrong)
        printf("  %s, %s (d %a, L %d, world [%a, %a] in x, mesh max x %a): %zu triangle queries and %zu ray "
               "answers wrong\n",
               s->name, c->label, info.resolution, info.max_level, info.world_min.x,
               info.world_min.x + info.world_size, mesh_data_bounds(&s->mesh).hi.x, tri_wrong, ray_wrong);
    free(got);
    free(got_ids);
    free(hits);
    octree_free(tree);
    return wrong;
}

/* The configurations: the heuristic resolution times 1/64, 1/8, 1 and 4; the mesh's
 * extent over 2^3 and 2^5 (a world of exactly the extent); the heuristic under depth caps
 * of 1 and 3 levels (clamped, so again a world of exactly the extent). */
static size_t make_configs(const scene *s, config *out)
{
    mesh_view v = mesh_data_view(&s->mesh);
    octree *t = octree_build(&v, NULL, NULL);
    assert_non_null(t);
    octree_info info;
    octree_get_info(t, &info);
    octree_free(t);
    box3 b = mesh_data_bounds(&s->mesh);
    double extent = fmax(b.hi.x - b.lo.x, fmax(b.hi.y - b.lo.y, b.hi.z - b.lo.z));
    size_t n = 0;
    const double factors[] = {1.0 / 64, 1.0 / 8, 1.0, 4.0};
    out[n].def = octree_default_def();
    snprintf(out[n++].label, sizeof out[0].label, "heuristic resolution (default def)");
    for (size_t k = 0; k < 4; k++) {
        out[n].def = octree_default_def();
        out[n].def.resolution = factors[k] * info.resolution;
        snprintf(out[n++].label, sizeof out[0].label, "resolution %g x heuristic", factors[k]);
    }
    for (int k = 3; k <= 5; k += 2) {
        out[n].def = octree_default_def();
        out[n].def.resolution = ldexp(extent, -k);
        snprintf(out[n++].label, sizeof out[0].label, "resolution extent / 2^%d", k);
    }
    for (int cap = 1; cap <= 3; cap += 2) {
        out[n].def = octree_default_def();
        out[n].def.max_depth = cap;
        snprintf(out[n++].label, sizeof out[0].label, "heuristic resolution, max_depth %d", cap);
    }
    return n;
}

/* Adds "; label" (or label first) to a list of failed configurations, cut at cap. */
static void append_label(char *list, size_t cap, const char *label)
{
    size_t used = strlen(list);
    const char *parts[2] = {used ? "; " : "", label};
    for (int p = 0; p < 2; p++)
        for (const char *c = parts[p]; *c && used + 1 < cap; c++)
            list[used++] = *c;
    list[used] = '\0';
}

/* Every configuration of one scene; fills `failed` with the configurations that gave
 * wrong answers (empty when none did), for the caller to fail with once the scene is
 * freed. The scene must hold what it is for: touching queries and rays of both kinds. */
static void check_scene(scene *s, char *failed, size_t failed_len)
{
    truth tr;
    truth_compute(&tr, s);
    printf("  %s: %zu triangles; %zu triangle queries (%zu touching); %zu rays (%zu without boundary contact, %zu "
           "of them hitting; %zu with)\n",
           s->name, s->mesh.triangle_count, s->tri_count, tr.touching_queries, s->ray_count, tr.clean_rays,
           tr.clean_hits, tr.boundary_rays);
    assert_true(tr.touching_queries > 0 && tr.touching_queries < s->tri_count);
    assert_true(tr.clean_hits > 0 && tr.boundary_rays > 0);
    config configs[16];
    size_t nc = make_configs(s, configs);
    failed[0] = '\0';
    for (size_t k = 0; k < nc; k++)
        if (check_config(s, &tr, &configs[k]) > 0)
            append_label(failed, failed_len, configs[k].label);
    truth_free(&tr, s);
}

/* One scene's test: built by make, checked at every configuration, freed, then failed
 * naming the configurations with wrong answers. */
static void run_scene_test(void (*make)(scene *, uint64_t), uint64_t seed)
{
    scene s = {0};
    make(&s, seed);
    char failed[1024], name[64];
    check_scene(&s, failed, sizeof failed);
    snprintf(name, sizeof name, "%s", s.name);
    scene_free(&s);
    if (failed[0])
        fail_msg("%s: wrong answers at %s", name, failed);
}

/* ---------- tests ---------- */

static void test_random_soup_equals_oracle(void **state)
{
    (void)state;
    run_scene_test(make_soup, base_seed);
}

static void test_touching_contacts_equal_oracle(void **state)
{
    (void)state;
    run_scene_test(make_touching, base_seed + 10);
}

static void test_contacts_on_the_mesh_upper_bounds_equal_oracle(void **state)
{
    (void)state;
    run_scene_test(make_upper_bounds, base_seed + 20);
}

/* The node faces depend on the world, so each resolution gets its own scene: the frame
 * alone fixes the world (its bounds and the resolution), then triangles go in its faces. */
static void test_triangles_on_node_faces_equal_oracle(void **state)
{
    (void)state;
    const box3 frame = {{-1.0471975511965976, -0.8660254037844386, -0.7071067811865476},
                        {1.3247179572447460, 1.1892071150027210, 0.9775804501612746}};
    const double factors[] = {1.0 / 64, 1.0 / 8, 1.0, 4.0};
    const double reference = 0.3183098861837907; /* about a face triangle's size */
    char failed[512] = "";
    for (size_t k = 0; k < 4; k++) {
        octree_def def = octree_default_def();
        def.resolution = factors[k] * reference;
        scene probe = {0};
        add_triangle(&probe, frame.lo, vec3_make(frame.lo.x + 0.1, frame.lo.y, frame.lo.z),
                     vec3_make(frame.lo.x, frame.lo.y + 0.1, frame.lo.z));
        add_triangle(&probe, frame.hi, vec3_make(frame.hi.x - 0.1, frame.hi.y, frame.hi.z),
                     vec3_make(frame.hi.x, frame.hi.y - 0.1, frame.hi.z));
        mesh_view pv = mesh_data_view(&probe.mesh);
        octree *t = octree_build(&pv, &def, NULL);
        assert_non_null(t);
        octree_info info;
        octree_get_info(t, &info);
        octree_free(t);
        scene_free(&probe);
        box3 w = {info.world_min, vec3_make(info.world_min.x + info.world_size, info.world_min.y + info.world_size,
                                            info.world_min.z + info.world_size)};
        scene s = {0};
        make_node_faces(&s, base_seed + 30 + k, frame, w);
        rng r = rng_seeded(base_seed + 40 + k);
        add_common_queries(&s, &r, 30, 0.3);
        box3 got = mesh_data_bounds(&s.mesh);
        assert_true(vec3_equal(got.lo, frame.lo) && vec3_equal(got.hi, frame.hi));
        truth tr;
        truth_compute(&tr, &s);
        printf("  %s at %g x %g: %zu triangles; %zu triangle queries (%zu touching); %zu rays (%zu without boundary "
               "contact; %zu with)\n",
               s.name, factors[k], reference, s.mesh.triangle_count, s.tri_count, tr.touching_queries, s.ray_count,
               tr.clean_rays, tr.boundary_rays);
        assert_true(tr.touching_queries > 0 && tr.clean_hits > 0 && tr.boundary_rays > 0);
        config c = {.def = def};
        snprintf(c.label, sizeof c.label, "resolution %g x %g", factors[k], reference);
        if (check_config(&s, &tr, &c) > 0)
            append_label(failed, sizeof failed, c.label);
        truth_free(&tr, &s);
        scene_free(&s);
    }
    if (failed[0])
        fail_msg("node faces: wrong answers at %s", failed);
}

int main(void)
{
    const char *env = getenv("TRIOCT_SEED");
    if (env)
        base_seed = strtoull(env, NULL, 10);
    printf("test_octree_oracle: seed %llu (set TRIOCT_SEED to rerun with another)\n", (unsigned long long)base_seed);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_random_soup_equals_oracle),
        cmocka_unit_test(test_touching_contacts_equal_oracle),
        cmocka_unit_test(test_triangles_on_node_faces_equal_oracle),
        cmocka_unit_test(test_contacts_on_the_mesh_upper_bounds_equal_oracle),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
