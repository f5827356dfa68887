/* Rays and triangles against a tree placed in the world by a pose (octree_ray_posed,
 * octree_triangle_posed), and the pose contract they rest on: a posed tree answers
 * exactly as a tree built from the posed vertices (octree_pose_point of each) would, to
 * the bit: rays for closest hits, every hit and yes/no under the crossing and touch rules;
 * triangles for yes/no, ids and contact segments, coincident and coplanar with the posed
 * triangles or sharing their vertices; on closed meshes (shared edges and vertices), on
 * blocks whose faces lie on node faces, at huge offsets and at exact quarter turns. The
 * walk's widening is checked against the errors it covers, measured in extended
 * precision, and the pose checks against the matrices they must refuse. */
#include <float.h>
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
#include "octree/octree_internal.h"
#include "support/meshgen.h"

static uint64_t seed = 20261202;

/* The mesh with every vertex posed. */
static mesh_data posed_mesh(const mesh_data *m, const pose *at)
{
    mesh_data w = {0};
    w.vertex_count = m->vertex_count;
    w.triangle_count = m->triangle_count;
    w.vertices = malloc(w.vertex_count * sizeof *w.vertices);
    w.indices = malloc(3 * w.triangle_count * sizeof *w.indices);
    assert_non_null(w.vertices);
    assert_non_null(w.indices);
    for (size_t i = 0; i < m->vertex_count; i++)
        w.vertices[i] = octree_pose_point(at, m->vertices[i]);
    memcpy(w.indices, m->indices, 3 * w.triangle_count * sizeof *w.indices);
    return w;
}

static octree *build(const mesh_data *m)
{
    mesh_view v = mesh_data_view(m);
    octree_def def = octree_default_def();
    octree_error e;
    octree *t = octree_build(&v, &def, &e);
    assert_non_null(t);
    return t;
}

static int same_hit(const ray_hit *a, const ray_hit *b)
{
    return a->t == b->t && a->triangle == b->triangle && a->u == b->u && a->v == b->v &&
           a->normal.x == b->normal.x && a->normal.y == b->normal.y && a->normal.z == b->normal.z;
}

#define MAX_HITS 64

/* One ray, every detail, against the posed tree and the tree of the posed mesh. */
static void check_ray(const octree *local, const pose *at, const octree *world, const ray_input *ray,
                      size_t *hits_seen)
{
    for (int detail = RAY_ANY; detail <= RAY_ALL; detail++) {
        ray_hit hp[MAX_HITS], hw[MAX_HITS];
        ray_output op = {.hits = hp, .max_hits = MAX_HITS}, ow = {.hits = hw, .max_hits = MAX_HITS};
        assert_int_equal(octree_ray_posed(local, at, ray, (ray_detail)detail, ACCURACY_EXACT, &op, NULL), OCTREE_OK);
        assert_int_equal(octree_ray(world, ray, (ray_detail)detail, ACCURACY_EXACT, &ow, NULL), OCTREE_OK);
        assert_int_equal(op.hit_count, ow.hit_count);
        assert_int_equal(op.truncated, ow.truncated);
        *hits_seen += ow.hit_count > 0;
        /* Which hit an any-hit query stops at depends on the visiting order, which differs
         * between the two frames; that there is one does not. */
        if (detail == RAY_ANY)
            continue;
        size_t n = op.hit_count < MAX_HITS ? op.hit_count : MAX_HITS;
        for (size_t i = 0; i < n; i++)
            if (!same_hit(&hp[i], &hw[i]))
                fail_msg("hit %zu of %zu differs: posed t %.17g id %u, built t %.17g id %u", i, n, hp[i].t,
                         hp[i].triangle, hw[i].t, hw[i].triangle);
    }
}

#define MAX_CONTACTS 256

static int same_contact(const tri_contact *a, const tri_contact *b)
{
    return a->triangle == b->triangle && a->p.x == b->p.x && a->p.y == b->p.y && a->p.z == b->p.z &&
           a->q.x == b->q.x && a->q.y == b->q.y && a->q.z == b->q.z;
}

/* One triangle, every detail, against the posed tree and the tree of the posed mesh. */
static void check_triangle(const octree *local, const pose *at, const octree *world, const vec3 q[3],
                           size_t *hits_seen)
{
    for (int detail = TRI_YESNO; detail <= TRI_SEGMENTS; detail++) {
        tri_contact cp[MAX_CONTACTS], cw[MAX_CONTACTS];
        tri_output op = {.contacts = cp, .capacity = MAX_CONTACTS}, ow = {.contacts = cw, .capacity = MAX_CONTACTS};
        assert_int_equal(octree_triangle_posed(local, at, q, (tri_detail)detail, ACCURACY_EXACT, &op, NULL),
                         OCTREE_OK);
        assert_int_equal(octree_triangle(world, q, (tri_detail)detail, ACCURACY_EXACT, &ow, NULL), OCTREE_OK);
        assert_int_equal(op.hit, ow.hit);
        assert_int_equal(op.count, ow.count);
        assert_int_equal(op.truncated, ow.truncated);
        if (detail == TRI_YESNO)
            *hits_seen += ow.hit;
        size_t n = ow.count < MAX_CONTACTS ? ow.count : MAX_CONTACTS;
        for (size_t i = 0; i < n; i++)
            if (!same_contact(&cp[i], &cw[i]))
                fail_msg("detail %d contact %zu of %zu differs: posed id %u, built id %u", detail, i, n,
                         cp[i].triangle, cw[i].triangle);
    }
}

/* Query triangles at the posed mesh: small ones around surface points, ones sharing a
 * posed vertex, the posed triangle itself (coincident), one coplanar with it inside it,
 * and large ones across the mesh. */
static size_t check_triangles_at_pose(const mesh_data *w, const octree *local, const pose *at, const octree *world,
                                      int count, rng *r)
{
    box3 b = mesh_data_bounds(w);
    size_t hits = 0;
    for (int i = 0; i < count; i++) {
        size_t t = rng_next(r) % w->triangle_count;
        vec3 a = mesh_data_corner(w, t, 0), c1 = mesh_data_corner(w, t, 1), c2 = mesh_data_corner(w, t, 2);
        vec3 centre = vec3_scale(vec3_add(vec3_add(a, c1), c2), 1.0 / 3);
        double size = vec3_length(vec3_sub(c1, a)) * rng_uniform(r, 0.2, 2);
        vec3 q[3];
        switch (i % 5) {
        case 0:
            for (int k = 0; k < 3; k++)
                q[k] = vec3_add(centre, vec3_scale(rng_unit_vector(r), size));
            break;
        case 1:
            q[0] = a;
            q[1] = vec3_add(a, vec3_scale(rng_unit_vector(r), size));
            q[2] = vec3_add(a, vec3_scale(rng_unit_vector(r), size));
            break;
        case 2:
            q[0] = a;
            q[1] = c1;
            q[2] = c2;
            break;
        case 3:
            q[0] = a;
            q[1] = c1;
            q[2] = centre; /* coplanar up to the rounding of the centre */
            break;
        default:
            for (int k = 0; k < 3; k++)
                q[k] = rng_point_in_box(r, b);
            break;
        }
        check_triangle(local, at, world, q, &hits);
    }
    return hits;
}

/* Rays toward the posed mesh's triangles from around it: at random interior points, at
 * vertices (shared by several triangles) and at edge midpoints, half of them with the
 * touch rule; then random rays from inside its box. */
static size_t check_mesh_at_pose(const mesh_data *m, const pose *at, int rays)
{
    mesh_data w = posed_mesh(m, at);
    octree *local = build(m), *world = build(&w);
    box3 b = mesh_data_bounds(&w);
    vec3 ext = vec3_sub(b.hi, b.lo);
    box3 around = {vec3_sub(b.lo, vec3_scale(ext, 0.3)), vec3_add(b.hi, vec3_scale(ext, 0.3))};
    rng r = rng_seeded(seed++);
    size_t hits = 0;
    for (int i = 0; i < rays; i++) {
        size_t t = rng_next(&r) % w.triangle_count;
        vec3 a = mesh_data_corner(&w, t, 0), c1 = mesh_data_corner(&w, t, 1), c2 = mesh_data_corner(&w, t, 2);
        vec3 target;
        switch (i % 3) {
        case 0: {
            double u = rng_uniform(&r, 0, 1), v = rng_uniform(&r, 0, 1);
            if (u + v > 1) {
                u = 1 - u;
                v = 1 - v;
            }
            target = vec3_add(a, vec3_add(vec3_scale(vec3_sub(c1, a), u), vec3_scale(vec3_sub(c2, a), v)));
            break;
        }
        case 1:
            target = a;
            break;
        default:
            target = vec3_scale(vec3_add(a, c1), 0.5);
            break;
        }
        vec3 o = rng_point_in_box(&r, around);
        ray_input ray = {o, vec3_sub(target, o), 0, INFINITY, (i / 3) % 2 ? RAY_TOUCH : RAY_CROSSING};
        check_ray(local, at, world, &ray, &hits);
        ray_input inside = {rng_point_in_box(&r, b), rng_unit_vector(&r), 0, INFINITY, RAY_CROSSING};
        check_ray(local, at, world, &inside, &hits);
    }
    /* Three query triangles in five are on the mesh by construction. */
    size_t touched = check_triangles_at_pose(&w, local, at, world, rays / 2, &r);
    assert_true(touched >= (size_t)rays / 2 * 3 / 5);
    octree_free(local);
    octree_free(world);
    mesh_data_free(&w);
    return hits;
}

static pose quaternion_pose(vec3 t, double qw, double qx, double qy, double qz)
{
    pose p;
    assert_int_equal(octree_pose_from_quaternion(t, qw, qx, qy, qz, &p), OCTREE_OK);
    return p;
}

static pose random_pose(rng *r, double offset)
{
    vec3 q = rng_unit_vector(r);
    double angle = rng_uniform(r, 0, 6.283185307179586);
    vec3 t = {rng_uniform(r, -offset, offset), rng_uniform(r, -offset, offset), rng_uniform(r, -offset, offset)};
    return quaternion_pose(t, cos(angle / 2), sin(angle / 2) * q.x, sin(angle / 2) * q.y, sin(angle / 2) * q.z);
}

/* The poses every mesh is checked at: none, a quarter turn (entries exactly 0 and +-1), a
 * random rotation near the origin, one at a huge offset, and a tiny rotation. */
static void check_mesh(const mesh_data *m, int rays)
{
    rng r = rng_seeded(seed++);
    pose poses[5] = {
        {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0}},
        {{0, -1, 0, 1, 0, 0, 0, 0, 1}, {0.1, -3.25, 7}},
        random_pose(&r, 10),
        random_pose(&r, 0),
        quaternion_pose((vec3){0.5, 0.25, -0.125}, 1, 1e-9, -2e-9, 3e-9),
    };
    poses[3].t = (vec3){5e6 + 0.3, -2.5e7 - 0.7, 4e5 + 0.1}; /* a georeferenced site */
    for (int k = 0; k < 5; k++) {
        size_t hits = check_mesh_at_pose(m, &poses[k], rays);
        /* Most rays aim at the mesh: a test whose rays all missed would check nothing. */
        assert_true(hits > (size_t)rays);
    }
}

static void test_icosphere_at_poses(void **state)
{
    (void)state;
    mesh_data m = meshgen_icosphere((vec3){0.25, -0.5, 1}, 1.0, 3);
    check_mesh(&m, 300);
    mesh_data_free(&m);
}

/* Unit blocks on a dyadic grid: coplanar neighbours, faces on node faces. */
static void test_blocks_at_poses(void **state)
{
    (void)state;
    mesh_data m = meshgen_blocks(7, 4, 4, 2, 1.0);
    check_mesh(&m, 300);
    mesh_data_free(&m);
}

static void test_terrain_at_poses(void **state)
{
    (void)state;
    mesh_data m = meshgen_terrain(3, (box3){{0, 0, 0}, {20, 20, 3}}, 24, 24);
    check_mesh(&m, 300);
    mesh_data_free(&m);
}

/* ---------- a shape tree against a placed world tree ---------- */

/* A small closed shape at poses about the posed mesh's surface, half of them touching it:
 * every pair octree_mesh_tree_posed finds against the placed tree is one octree_mesh finds
 * against the tree of the posed mesh, and no other; yes/no alike. */
static void check_shapes_at_pose(const mesh_data *m, const pose *at, int poses)
{
    mesh_data w = posed_mesh(m, at);
    octree *local = build(m), *world = build(&w);
    box3 b = mesh_data_bounds(&w);
    double side = vec3_length(vec3_sub(b.hi, b.lo));
    mesh_data shape_mesh = meshgen_torus((vec3){0, 0, 0}, 0.06 * side, 0.02 * side, 16, 8);
    mesh_view sv = mesh_data_view(&shape_mesh);
    octree *shape = octree_shape_tree_for(&sv, 1000);
    assert_non_null(shape);
    rng r = rng_seeded(seed++);
    size_t touched = 0;
    for (int i = 0; i < poses; i++) {
        size_t t = rng_next(&r) % w.triangle_count;
        vec3 c = vec3_scale(vec3_add(vec3_add(mesh_data_corner(&w, t, 0), mesh_data_corner(&w, t, 1)),
                                     mesh_data_corner(&w, t, 2)),
                            1.0 / 3);
        pose sp = random_pose(&r, 0);
        sp.t = vec3_add(c, vec3_scale(rng_unit_vector(&r), rng_uniform(&r, 0, 0.1 * side)));
        mesh_pair pp[512], pw[512];
        mesh_output op = {.pairs = pp, .capacity = 512}, ow = {.pairs = pw, .capacity = 512};
        assert_int_equal(octree_mesh_tree_posed(local, at, shape, &sp, 1, ACCURACY_EXACT, &op, NULL), OCTREE_OK);
        assert_int_equal(octree_mesh(world, &sv, &sp, 1, ACCURACY_EXACT, &ow, NULL), OCTREE_OK);
        assert_int_equal(op.hit, ow.hit);
        assert_int_equal(op.count, ow.count);
        assert_int_equal(op.truncated, ow.truncated);
        size_t n = ow.count < 512 ? ow.count : 512;
        for (size_t k = 0; k < n; k++)
            if (pp[k].query_triangle != pw[k].query_triangle || pp[k].world_triangle != pw[k].world_triangle)
                fail_msg("pose %d pair %zu: placed (%u, %u), built (%u, %u)", i, k, pp[k].query_triangle,
                         pp[k].world_triangle, pw[k].query_triangle, pw[k].world_triangle);
        /* Yes/no: the same answer, and the pair it names is one of them. */
        mesh_pair first;
        mesh_output yes = {.pairs = &first, .capacity = 1};
        assert_int_equal(octree_mesh_tree_posed(local, at, shape, &sp, 0, ACCURACY_EXACT, &yes, NULL), OCTREE_OK);
        assert_int_equal(yes.hit, ow.hit);
        assert_int_equal(yes.count, ow.hit ? 1 : 0);
        int named = 0;
        for (size_t k = 0; yes.hit && k < n; k++)
            named |= first.query_triangle == pw[k].query_triangle && first.world_triangle == pw[k].world_triangle;
        assert_true(named == yes.hit);
        touched += ow.hit;
    }
    /* Poses within a tenth of the scene of the surface: some touch, some do not. */
    assert_true(touched > 0 && touched < (size_t)poses);
    octree_free(shape);
    mesh_data_free(&shape_mesh);
    octree_free(local);
    octree_free(world);
    mesh_data_free(&w);
}

/* A shape touching a placed world at exactly one point: its local origin, posed at the
 * world's posed corner (fl(R 0 + t) is t), pointing away from the world. The world's
 * matrix is typed with six decimals, so at the relative pose the shape stands about 1e-3
 * off the corner: only the widened descent, testing the triangles where they stand,
 * finds the contact. */
static void test_shape_touching_a_placed_corner(void **state)
{
    (void)state;
    mesh_data wm = meshgen_box((box3){{-2, -2, -2}, {2, 2, 2}});
    mesh_data sm = meshgen_tetrahedron((vec3){0, 0, 0}, (vec3){1, 0.5, 0.5}, (vec3){0.5, 1, 0.5},
                                       (vec3){0.5, 0.5, 1});
    octree_def def = octree_default_def();
    def.node_bounds = 1;
    /* With triangle boxes, as a world serving meshes has them: their filters hold for the
     * posed triangles only, which a placed world must not trust at the relative pose. */
    def.triangle_boxes = 1;
    octree_error e;
    mesh_view sv = mesh_data_view(&sm), wv = mesh_data_view(&wm);
    octree *shape = octree_build(&sv, &def, &e), *world = octree_build(&wv, &def, &e);
    assert_non_null(shape);
    assert_non_null(world);
    pose wp = {{0.707107, -0.707107, 0, 0.707107, 0.707107, 0, 0, 0, 1}, {1e3 + 0.5, -3, 2}};
    pose sp = wp;
    sp.t = octree_pose_point(&wp, (vec3){2, 2, 2});
    mesh_pair pairs[64];
    for (int all = 0; all <= 1; all++) {
        mesh_output out = {.pairs = pairs, .capacity = 64};
        assert_int_equal(octree_mesh_tree_posed(world, &wp, shape, &sp, all, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
        assert_true(out.hit);
        /* The reference: the world's posed mesh, the shape posed as octree_mesh poses it. */
        mesh_data posed = posed_mesh(&wm, &wp);
        octree *built = build(&posed);
        mesh_pair ref[64];
        mesh_output ro = {.pairs = ref, .capacity = 64};
        assert_int_equal(octree_mesh(built, &sv, &sp, all, ACCURACY_EXACT, &ro, NULL), OCTREE_OK);
        assert_true(ro.hit);
        assert_int_equal(out.count, all ? ro.count : 1); /* yes/no names its first pair */
        for (size_t k = 0; all && k < ro.count && k < 64; k++)
            assert_true(pairs[k].query_triangle == ref[k].query_triangle && pairs[k].world_triangle == ref[k].world_triangle);
        octree_free(built);
        mesh_data_free(&posed);
    }
    octree_free(shape);
    octree_free(world);
    mesh_data_free(&wm);
    mesh_data_free(&sm);
}

static void test_shapes_against_placed_trees(void **state)
{
    (void)state;
    rng r = rng_seeded(seed++);
    mesh_data meshes[2] = {meshgen_icosphere((vec3){0.25, -0.5, 1}, 1.0, 3),
                           meshgen_terrain(3, (box3){{0, 0, 0}, {20, 20, 3}}, 24, 24)};
    for (int k = 0; k < 2; k++) {
        pose poses[3] = {
            {{0, -1, 0, 1, 0, 0, 0, 0, 1}, {0.1, -3.25, 7}},
            random_pose(&r, 10),
            random_pose(&r, 0),
        };
        poses[2].t = (vec3){5e6 + 0.3, -2.5e7 - 0.7, 4e5 + 0.1};
        for (int p = 0; p < 3; p++)
            check_shapes_at_pose(&meshes[k], &poses[p], 60);
        mesh_data_free(&meshes[k]);
    }
}

/* ---------- the widening against the errors it covers ---------- */

typedef long double ld;

/* R^-1 in extended precision, from the adjugate. */
static void inverse_ld(const double *r, ld inv[9])
{
    ld a = r[0], b = r[1], c = r[2], d = r[3], e = r[4], f = r[5], g = r[6], h = r[7], i = r[8];
    ld det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
    ld adj[9] = {e * i - f * h, c * h - b * i, b * f - c * e, f * g - d * i, a * i - c * g,
                 c * d - a * f, d * h - e * g, b * g - a * h, a * e - b * d};
    for (int k = 0; k < 9; k++)
        inv[k] = adj[k] / det;
}

/* |A^-1(x) - y| in the max norm, x in the world, y in the local frame. */
static ld preimage_distance(const ld inv[9], const pose *at, ld x[3], ld y[3])
{
    ld c[3] = {x[0] - (ld)at->t.x, x[1] - (ld)at->t.y, x[2] - (ld)at->t.z};
    ld worst = 0;
    for (int i = 0; i < 3; i++) {
        ld p = inv[3 * i] * c[0] + inv[3 * i + 1] * c[1] + inv[3 * i + 2] * c[2];
        ld e = fabsl(p - y[i]);
        worst = e > worst ? e : worst;
    }
    return worst;
}

/* For rays from around a posed mesh through its posed vertices: the computed local ray at
 * s = 1 against the real preimage of o + d, and each posed vertex's real preimage against
 * the vertex; both within the walk's widening, which stays a few ulps of the scene. */
static void test_widening_covers_the_pose_rounding(void **state)
{
    (void)state;
    mesh_data m = meshgen_icosphere((vec3){3, -1, 2}, 2.0, 2);
    octree *local = build(&m);
    rng r = rng_seeded(seed++);
    /* A matrix typed with six decimals: a rotation within the tolerance, not exactly. */
    pose typed = {{0.707107, -0.707107, 0, 0.707107, 0.707107, 0, 0, 0, 1}, {1e6 + 0.5, -3, 2}};
    ld worst_ratio = 0;
    for (int k = 0; k < 40; k++) {
        pose at = k == 0 ? typed : random_pose(&r, k % 2 ? 1e7 : 5);
        ld inv[9];
        inverse_ld(at.r, inv);
        for (size_t i = 0; i < m.vertex_count; i += 7) {
            vec3 p = m.vertices[i], w = octree_pose_point(&at, p);
            vec3 o = vec3_add(w, vec3_scale(rng_unit_vector(&r), rng_uniform(&r, 1, 50)));
            ray_input ray = {o, vec3_sub(w, o), 0, INFINITY, RAY_CROSSING};
            posed_ray pr;
            assert_int_equal(octree_posed_ray_setup(local, &at, &ray, &pr), OCTREE_OK);
            assert_false(pr.misses);
            ld wx[3] = {w.x, w.y, w.z}, px[3] = {p.x, p.y, p.z};
            ld vertex_error = preimage_distance(inv, &at, wx, px);
            ld end[3] = {(ld)o.x + (ld)ray.direction.x, (ld)o.y + (ld)ray.direction.y,
                         (ld)o.z + (ld)ray.direction.z};
            ld at_one[3] = {(ld)pr.local.origin.x + (ld)pr.local.direction.x,
                            (ld)pr.local.origin.y + (ld)pr.local.direction.y,
                            (ld)pr.local.origin.z + (ld)pr.local.direction.z};
            ld ray_error = preimage_distance(inv, &at, end, at_one);
            ld both = vertex_error + ray_error;
            if (!(vertex_error <= (ld)pr.vertex_reach))
                fail_msg("pose %d vertex %zu: a posed vertex's preimage %Lg from it, above %g", k, i, vertex_error,
                         pr.vertex_reach);
            if (!(ray_error <= (ld)pr.origin_reach + (ld)pr.direction_reach))
                fail_msg("pose %d vertex %zu: the local ray %Lg from the preimage at s = 1, above %g + %g", k, i,
                         ray_error, pr.origin_reach, pr.direction_reach);
            /* The walk's widening holds all three at every s up to the hit's (s = 1 here). */
            assert_true(pr.s_bound >= 1.0);
            assert_true(pr.grow >= pr.vertex_reach + pr.origin_reach + pr.direction_reach);
            if (!(both <= (ld)pr.grow))
                fail_msg("pose %d vertex %zu: errors %Lg + %Lg above the widening %g", k, i, vertex_error, ray_error,
                         pr.grow);
            ld ratio = both / (ld)pr.grow;
            worst_ratio = ratio > worst_ratio ? ratio : worst_ratio;
            /* Small against the scene: the walk stays a walk, not a visit of every node. */
            double scale = fabs(o.x) + fabs(o.y) + fabs(o.z) + fabs(at.t.x) + fabs(at.t.y) + fabs(at.t.z) + 10;
            assert_true(pr.grow < scale * (k == 0 ? 1e-4 : 1e-12));
        }
    }
    print_message("largest measured error / widening: %.3Lg\n", worst_ratio);
    octree_free(local);
    mesh_data_free(&m);
}

/* A shape placed against a placed world: the shape's vertices at the relative pose
 * against the real preimages of its vertices at its own pose, measured in extended
 * precision, within the descent's widening, with the world's matrix typed with six
 * decimals (far from exactly orthonormal) or a rotation from a quaternion. */
static void test_pair_widening_covers_the_relative_pose(void **state)
{
    (void)state;
    mesh_data wm = meshgen_box((box3){{-2, -2, -2}, {2, 2, 2}});
    mesh_data sm = meshgen_icosphere((vec3){0.5, 0.25, 0}, 0.5, 2);
    octree *world = build(&wm), *shape = build(&sm);
    rng r = rng_seeded(seed++);
    pose typed = {{0.707107, -0.707107, 0, 0.707107, 0.707107, 0, 0, 0, 1}, {1e3 + 0.5, -3, 2}};
    for (int k = 0; k < 20; k++) {
        pose wp = k % 2 ? typed : random_pose(&r, k % 4 ? 5 : 1e6);
        pose sp = random_pose(&r, 3);
        sp.t = vec3_add(sp.t, wp.t);
        pose rel;
        double grow;
        assert_int_equal(octree_posed_pair_setup(world, &wp, shape, &sp, &rel, &grow), OCTREE_OK);
        ld inv[9];
        inverse_ld(wp.r, inv);
        for (size_t i = 0; i < sm.vertex_count; i++) {
            vec3 v = sm.vertices[i], placed = octree_pose_point(&sp, v), relative = octree_pose_point(&rel, v);
            ld x[3] = {placed.x, placed.y, placed.z}, y[3] = {relative.x, relative.y, relative.z};
            ld e = preimage_distance(inv, &wp, x, y);
            if (!(e <= (ld)grow))
                fail_msg("pose %d vertex %zu: %Lg from the preimage, above the widening %g", k, i, e, grow);
        }
    }
    octree_free(world);
    octree_free(shape);
    mesh_data_free(&wm);
    mesh_data_free(&sm);
}

/* A ray that cannot reach the posed tree is answered with no hit before any walk. */
static void test_ray_far_from_the_object_misses(void **state)
{
    (void)state;
    mesh_data m = meshgen_box((box3){{0, 0, 0}, {1, 1, 1}});
    octree *local = build(&m);
    pose at = quaternion_pose((vec3){100, 0, 0}, 1, 0, 0, 0);
    ray_input away = {{0, 0, 0}, {0, 1, 0}, 0, INFINITY, RAY_CROSSING};
    ray_input toward = {{0, 0.5, 0.5}, {1, 0, 0}, 0, INFINITY, RAY_CROSSING};
    ray_input too_short = {{0, 0.5, 0.5}, {1, 0, 0}, 0, 50, RAY_CROSSING};
    ray_hit h;
    ray_output out = {.hits = &h, .max_hits = 1};
    assert_int_equal(octree_ray_posed(local, &at, &away, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
    assert_int_equal(out.hit_count, 0);
    assert_int_equal(octree_ray_posed(local, &at, &too_short, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
    assert_int_equal(out.hit_count, 0);
    assert_int_equal(octree_ray_posed(local, &at, &toward, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
    assert_int_equal(out.hit_count, 1);
    assert_true(h.t == 100.0);
    assert_true(h.normal.x == -1.0);
    octree_free(local);
    mesh_data_free(&m);
}

/* Every posed point of a box lies in octree_pose_box's box, and its corners reach the
 * box's faces: at quarter turns, random rotations and a huge offset, with points a few
 * ulps of the scene inside the corners, where rounding could carry a posed point past
 * the posed corners if it were not monotone. */
static void test_pose_box_holds_every_posed_point(void **state)
{
    (void)state;
    rng r = rng_seeded(seed++);
    box3 local = {{-1.5, 0.25, -3}, {2, 4, 1e-3}};
    for (int k = 0; k < 30; k++) {
        pose at = k == 0 ? (pose){{0, 0, 1, 1, 0, 0, 0, 1, 0}, {7, 8, 9}} : random_pose(&r, k % 3 ? 10 : 3e7);
        box3 b = octree_pose_box(&at, local);
        box3 hull = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
        for (int i = 0; i < 2000; i++) {
            /* Corners, edge points and interior points alike. */
            vec3 p = rng_point_in_box(&r, local);
            if (i < 1000) {
                /* A corner, or a point a few ulps of the scene inside it, where rounding
                 * alone can carry a posed point past the posed corners. */
                int q = i % 8;
                double in = i < 8 ? 0.0 : rng_uniform(&r, 0, 1e-9);
                p = (vec3){q & 1 ? local.hi.x - in : local.lo.x + in, q & 2 ? local.hi.y - in : local.lo.y + in,
                           q & 4 ? local.hi.z - in : local.lo.z + in};
            }
            vec3 w = octree_pose_point(&at, p);
            assert_true(w.x >= b.lo.x && w.y >= b.lo.y && w.z >= b.lo.z);
            assert_true(w.x <= b.hi.x && w.y <= b.hi.y && w.z <= b.hi.z);
            hull.lo = vec3_min(hull.lo, w);
            hull.hi = vec3_max(hull.hi, w);
        }
        assert_true(hull.lo.x == b.lo.x && hull.lo.y == b.lo.y && hull.lo.z == b.lo.z);
        assert_true(hull.hi.x == b.hi.x && hull.hi.y == b.hi.y && hull.hi.z == b.hi.z);
    }
}

/* ---------- pose checks ---------- */

static void test_pose_checks(void **state)
{
    (void)state;
    pose ok = {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {1, 2, 3}};
    assert_int_equal(octree_pose_check(&ok), OCTREE_OK);
    pose typed = {{0.707107, -0.707107, 0, 0.707107, 0.707107, 0, 0, 0, 1}, {0, 0, 0}};
    assert_int_equal(octree_pose_check(&typed), OCTREE_OK);
    pose coarse = {{0.7071, -0.7071, 0, 0.7071, 0.7071, 0, 0, 0, 1}, {0, 0, 0}}; /* 2e-5 off */
    assert_int_equal(octree_pose_check(&coarse), OCTREE_ERR_INVALID);
    pose scaled = {{2, 0, 0, 0, 2, 0, 0, 0, 2}, {0, 0, 0}};
    assert_int_equal(octree_pose_check(&scaled), OCTREE_ERR_INVALID);
    pose sheared = {{1, 0.1, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0}};
    assert_int_equal(octree_pose_check(&sheared), OCTREE_ERR_INVALID);
    pose mirrored = {{-1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0}};
    assert_int_equal(octree_pose_check(&mirrored), OCTREE_ERR_INVALID);
    pose zero = {{0}, {0, 0, 0}};
    assert_int_equal(octree_pose_check(&zero), OCTREE_ERR_INVALID);
    pose nan = ok;
    nan.r[4] = NAN;
    assert_int_equal(octree_pose_check(&nan), OCTREE_ERR_NONFINITE);
    pose inf = ok;
    inf.t.y = INFINITY;
    assert_int_equal(octree_pose_check(&inf), OCTREE_ERR_NONFINITE);

    /* A quaternion is normalised: half a turn about z given at twice unit length is
     * refused, at unit length within the tolerance it is the exact matrix. */
    pose q;
    assert_int_equal(octree_pose_from_quaternion((vec3){0, 0, 0}, 0, 0, 0, 2, &q), OCTREE_ERR_INVALID);
    assert_int_equal(octree_pose_from_quaternion((vec3){0, 0, 0}, 0, 0, 0, 1.0005, &q), OCTREE_OK);
    const double half_turn[9] = {-1, 0, 0, 0, -1, 0, 0, 0, 1};
    for (int k = 0; k < 9; k++)
        assert_true(q.r[k] == half_turn[k]);
    assert_int_equal(octree_pose_from_quaternion((vec3){0, 0, 0}, 0, 0, 0, 0, &q), OCTREE_ERR_INVALID);
    assert_int_equal(octree_pose_from_quaternion((vec3){0, 0, 0}, NAN, 0, 0, 1, &q), OCTREE_ERR_NONFINITE);
    /* A quarter turn about x: y goes to z, exactly, as a pose in degrees would (sqrt(0.5)
     * is not 1/sqrt(2), yet the matrix's entries are 0 and 1 all the same). */
    assert_int_equal(octree_pose_from_quaternion((vec3){0, 0, 0}, sqrt(0.5), sqrt(0.5), 0, 0, &q), OCTREE_OK);
    assert_int_equal(octree_pose_check(&q), OCTREE_OK);
    const double quarter_x[9] = {1, 0, 0, 0, 0, -1, 0, 1, 0};
    for (int k = 0; k < 9; k++)
        assert_true(q.r[k] == quarter_x[k]);
    vec3 y = octree_pose_point(&q, (vec3){0, 1, 0});
    assert_true(y.x == 0 && y.y == 0 && y.z == 1);

    /* The posed ray refuses what the check refuses, and modes other than exact. */
    mesh_data m = meshgen_box((box3){{0, 0, 0}, {1, 1, 1}});
    octree *t = build(&m);
    ray_input ray = {{-1, 0.5, 0.5}, {1, 0, 0}, 0, INFINITY, RAY_CROSSING};
    ray_hit h;
    ray_output out = {.hits = &h, .max_hits = 1};
    assert_int_equal(octree_ray_posed(t, &scaled, &ray, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL), OCTREE_ERR_INVALID);
    assert_int_equal(octree_ray_posed(t, &mirrored, &ray, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL), OCTREE_ERR_INVALID);
    assert_int_equal(octree_ray_posed(t, &nan, &ray, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL), OCTREE_ERR_NONFINITE);
    assert_int_equal(octree_ray_posed(t, &ok, &ray, RAY_CLOSEST, ACCURACY_FAST, &out, NULL), OCTREE_ERR_INVALID);
    /* ok moves the box to [1, 2] x [2, 3] x [3, 4]. */
    ray.origin = (vec3){-1, 2.5, 3.5};
    assert_int_equal(octree_ray_posed(t, &ok, &ray, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
    assert_int_equal(out.hit_count, 1);
    assert_true(h.t == 2.0);
    octree_free(t);
    mesh_data_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_icosphere_at_poses),
        cmocka_unit_test(test_blocks_at_poses),
        cmocka_unit_test(test_terrain_at_poses),
        cmocka_unit_test(test_shapes_against_placed_trees),
        cmocka_unit_test(test_shape_touching_a_placed_corner),
        cmocka_unit_test(test_widening_covers_the_pose_rounding),
        cmocka_unit_test(test_pair_widening_covers_the_relative_pose),
        cmocka_unit_test(test_ray_far_from_the_object_misses),
        cmocka_unit_test(test_pose_box_holds_every_posed_point),
        cmocka_unit_test(test_pose_checks),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
