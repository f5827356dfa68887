/* The hard-case catalogue against the GMP oracle, the exact primitives, the octree's own
 * answers, closed-mesh watertightness and bad input; seed and fast mode errors are printed. */
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
#include <gmp.h>

#include "engine.h"
#include "geom/box_geometry.h"
#include "octree/octree_internal.h"
#include "support/hard_cases.h"
#include "support/meshgen.h"
#include "support/oracle.h"

static uint64_t base_seed = 20261121;

/* The catalogue, generated once for the group. */
typedef struct catalogue {
    hard_case *cases;
    size_t count;
    const char *const *categories;
    size_t category_count;
} catalogue;

static int setup_catalogue(void **state)
{
    catalogue *cat = calloc(1, sizeof *cat);
    if (!cat)
        return -1;
    cat->count = hard_cases_generate(&cat->cases);
    if (!cat->count) {
        free(cat);
        return -1;
    }
    cat->categories = hard_case_categories(&cat->category_count);
    *state = cat;
    return 0;
}

static int teardown_catalogue(void **state)
{
    catalogue *cat = *state;
    free(cat->cases);
    free(cat);
    return 0;
}

static size_t category_index(const catalogue *cat, const char *name)
{
    for (size_t i = 0; i < cat->category_count; i++)
        if (strcmp(cat->categories[i], name) == 0)
            return i;
    fail_msg("case with unknown category '%s'", name);
    return 0;
}

static const char *kind_name(hard_kind kind)
{
    return kind == HARD_TRI_TRI ? "tri-tri" : kind == HARD_TRI_BOX ? "tri-box" : "ray-tri";
}

static void print_vec(const char *name, vec3 v) { printf("  %s (%a, %a, %a)\n", name, v.x, v.y, v.z); }

static void print_case(const hard_case *c)
{
    printf("[%s] %s transform %#x expected %d\n", c->category, kind_name(c->kind), c->transform, c->expected);
    for (int i = 0; i < 3; i++)
        print_vec("a", c->a[i]);
    if (c->kind == HARD_TRI_TRI)
        for (int i = 0; i < 3; i++)
            print_vec("b", c->b[i]);
    if (c->kind == HARD_TRI_BOX) {
        print_vec("box lo", c->box.lo);
        print_vec("box hi", c->box.hi);
    }
    if (c->kind == HARD_RAY_TRI) {
        print_vec("origin", c->origin);
        print_vec("direction", c->direction);
        printf("  t in [%a, %a]\n", c->tmin, c->tmax);
    }
}

/* ---------- the catalogue itself ---------- */

/* Generated the same every time, every category present with both kinds of answer where
 * it has any, and every base case followed by at least its 47 symmetric copies. */
static void test_catalogue_is_deterministic_and_complete(void **state)
{
    const catalogue *cat = *state;
    hard_case *again = NULL;
    size_t count = hard_cases_generate(&again);
    assert_int_equal(count, cat->count);
    assert_memory_equal(again, cat->cases, count * sizeof *again);
    free(again);

    size_t base_cases = 0, group = 0, smallest_group = SIZE_MAX;
    size_t(*answers)[2] = calloc(cat->category_count, sizeof *answers);
    assert_non_null(answers);
    for (size_t i = 0; i < cat->count; i++) {
        const hard_case *c = &cat->cases[i];
        if (c->transform == 0) {
            if (base_cases++)
                smallest_group = group < smallest_group ? group : smallest_group;
            group = 0;
        }
        group++;
        assert_true(c->expected == 0 || c->expected == 1);
        answers[category_index(cat, c->category)][c->expected]++;
    }
    smallest_group = group < smallest_group ? group : smallest_group;
    printf("catalogue: %zu cases from %zu base cases in %zu categories (smallest group %zu)\n", cat->count,
           base_cases, cat->category_count, smallest_group);
    assert_true(smallest_group >= 48);
    for (size_t k = 0; k < cat->category_count; k++) {
        assert_true(answers[k][0] + answers[k][1] > 0);
        /* Only the zero-area ray cases are all misses, by the engine's definition. */
        if (answers[k][1] == 0)
            printf("  '%s' has only separated / missing cases\n", cat->categories[k]);
    }
    free(answers);
}

/* ---------- (a) the expected answers against the GMP oracle ---------- */

/* The engine gives no hit where the closed-set oracle may: a zero-area triangle, or a ray
 * parallel to the triangle's plane (in it or not). Decided exactly: the normal
 * (v1 - v0) x (v2 - v0) and its dot product with the direction, in rationals. */
static int ray_case_outside_closed_semantics(const hard_case *c)
{
    mpq_t e1[3], e2[3], n[3], t, dot;
    for (int k = 0; k < 3; k++)
        mpq_inits(e1[k], e2[k], n[k], NULL);
    mpq_inits(t, dot, NULL);
    for (int k = 0; k < 3; k++) {
        mpq_set_d(e1[k], vec3_get(c->a[1], k));
        mpq_set_d(t, vec3_get(c->a[0], k));
        mpq_sub(e1[k], e1[k], t);
        mpq_set_d(e2[k], vec3_get(c->a[2], k));
        mpq_sub(e2[k], e2[k], t);
    }
    int zero_area = 1;
    for (int k = 0; k < 3; k++) {
        int i = (k + 1) % 3, j = (k + 2) % 3;
        mpq_mul(n[k], e1[i], e2[j]);
        mpq_mul(t, e1[j], e2[i]);
        mpq_sub(n[k], n[k], t);
        zero_area &= mpq_sgn(n[k]) == 0;
        mpq_set_d(t, vec3_get(c->direction, k));
        mpq_mul(t, t, n[k]);
        mpq_add(dot, dot, t);
    }
    int parallel = mpq_sgn(dot) == 0;
    for (int k = 0; k < 3; k++)
        mpq_clears(e1[k], e2[k], n[k], NULL);
    mpq_clears(t, dot, NULL);
    return zero_area || parallel;
}

/* oracle_tri_box hands the LP all eight corners, whose basic solutions are many. The same
 * question, still answered by the GMP hull oracle, costs far less asked of smaller hulls:
 * only the part of the box inside the triangle's bounding box can meet the triangle, and
 * that closed box is the union of the six simplices of its Kuhn triangulation (lo, then
 * the coordinates raised to hi one axis at a time, in each of the six orders). */
static int oracle_tri_box_by_simplices(const vec3 tri[3], box3 box)
{
    vec3 lo = vec3_max(box.lo, vec3_min(vec3_min(tri[0], tri[1]), tri[2]));
    vec3 hi = vec3_min(box.hi, vec3_max(vec3_max(tri[0], tri[1]), tri[2]));
    if (lo.x > hi.x || lo.y > hi.y || lo.z > hi.z)
        return 0; /* disjoint bounding boxes share no point */
    static const int orders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (int p = 0; p < 6; p++) {
        vec3 simplex[4];
        int n = 0;
        double corner[3] = {lo.x, lo.y, lo.z};
        const double top[3] = {hi.x, hi.y, hi.z};
        simplex[n++] = lo;
        for (int step = 0; step < 3; step++) {
            int axis = orders[p][step];
            if (corner[axis] == top[axis])
                continue; /* a flat box: the same point again */
            corner[axis] = top[axis];
            simplex[n++] = vec3_make(corner[0], corner[1], corner[2]);
        }
        if (oracle_hulls_intersect(tri, 3, simplex, n))
            return 1;
    }
    return 0;
}

static void test_expected_answers_equal_the_oracle(void **state)
{
    const catalogue *cat = *state;
    size_t checked = 0, engine_only = 0, wrong = 0;
    for (size_t i = 0; i < cat->count; i++) {
        const hard_case *c = &cat->cases[i];
        int oracle;
        if (c->kind == HARD_TRI_TRI)
            oracle = oracle_tri_tri(c->a, c->b);
        else if (c->kind == HARD_TRI_BOX) {
            oracle = oracle_tri_box_by_simplices(c->a, c->box);
            /* The reduction itself is checked against the plain oracle on every base case. */
            if (c->transform == 0 && oracle_tri_box(c->a, c->box) != oracle)
                fail_msg("the simplex reduction of oracle_tri_box disagrees on a [%s] case", c->category);
        } else if (ray_case_outside_closed_semantics(c)) {
            /* Only a miss belongs in the catalogue for these. */
            engine_only++;
            if (c->expected != 0 && wrong++ < 10) {
                printf("expected a hit where the engine promises none:\n");
                print_case(c);
            }
            continue;
        } else
            oracle = oracle_ray_tri(c->origin, c->direction, c->tmin, c->tmax, c->a);
        checked++;
        if (oracle != c->expected && wrong++ < 10) {
            printf("oracle says %d:\n", oracle);
            print_case(c);
        }
    }
    printf("oracle: %zu cases checked, %zu ray cases under the engine's own semantics\n", checked, engine_only);
    assert_int_equal(wrong, 0);
    assert_true(checked + engine_only == cat->count);
}

/* ---------- (b) exact mode answers every case ---------- */

static void test_exact_mode_has_no_wrong_answer_in_any_category(void **state)
{
    const catalogue *cat = *state;
    size_t wrong_total = 0;
    size_t *cases = calloc(cat->category_count, sizeof *cases);
    size_t *wrong = calloc(cat->category_count, sizeof *wrong);
    assert_non_null(cases);
    assert_non_null(wrong);
    for (size_t i = 0; i < cat->count; i++) {
        const hard_case *c = &cat->cases[i];
        size_t k = category_index(cat, c->category);
        cases[k]++;
        if (hard_case_answer(c, ACCURACY_EXACT, 0.0) != c->expected) {
            if (wrong_total++ < 10) {
                printf("exact mode wrong:\n");
                print_case(c);
            }
            wrong[k]++;
        }
    }
    for (size_t k = 0; k < cat->category_count; k++) {
        if (cases[k] == 0)
            fail_msg("category '%s' has no cases", cat->categories[k]);
        if (wrong[k])
            printf("exact mode: %zu of %zu wrong in '%s'\n", wrong[k], cases[k], cat->categories[k]);
    }
    free(cases);
    free(wrong);
    assert_int_equal(wrong_total, 0);
}

/* ---------- (c) the same cases through the octree ---------- */

static octree *build_world(const vec3 *vertices, size_t vertex_count, double resolution)
{
    uint32_t indices[3 * 8];
    assert_true(vertex_count <= 3 * 8 && vertex_count % 3 == 0);
    for (uint32_t i = 0; i < vertex_count; i++)
        indices[i] = i;
    mesh_view view = {vertices, vertex_count, indices, vertex_count / 3};
    octree_def def = octree_default_def();
    def.resolution = resolution;
    def.max_depth = OCTREE_MAX_DEPTH_CAP;
    octree_error err;
    octree *tree = octree_build(&view, &def, &err);
    if (!tree)
        fail_msg("world build failed: %s", err.message);
    return tree;
}

/* The case's triangle is world triangle 0; two small unrelated triangles beyond the upper
 * corner of everything the case touches give the tree its depth. Nothing goes below, so
 * the case's lower bounds are the world's (its boundary cases stay on the boundary). */
static octree *build_world_with_distant_triangles(const hard_case *c)
{
    vec3 lo = vec3_min(vec3_min(c->a[0], c->a[1]), c->a[2]), hi = vec3_max(vec3_max(c->a[0], c->a[1]), c->a[2]);
    if (c->kind == HARD_TRI_TRI)
        for (int i = 0; i < 3; i++) {
            lo = vec3_min(lo, c->b[i]);
            hi = vec3_max(hi, c->b[i]);
        }
    vec3 extent = vec3_sub(hi, lo);
    double size = fmax(extent.x, fmax(extent.y, extent.z));
    if (size == 0.0)
        size = fmax(fmax(fabs(hi.x), fabs(hi.y)), fmax(fabs(hi.z), 1.0)) * 0x1p-30;
    vec3 world[9] = {c->a[0], c->a[1], c->a[2]};
    for (int k = 0; k < 2; k++) {
        vec3 corner = vec3_add(hi, vec3_make((2 + 2 * k) * size, (2 + 2 * k) * size, (2 + 2 * k) * size));
        world[3 + 3 * k] = corner;
        world[4 + 3 * k] = vec3_add(corner, vec3_make(0.5 * size, 0, 0));
        world[5 + 3 * k] = vec3_add(corner, vec3_make(0, 0.5 * size, 0.25 * size));
    }
    return build_world(world, 9, 0.0);
}

static int octree_tri_tri_answer(const hard_case *c)
{
    octree *tree = build_world_with_distant_triangles(c);
    tri_contact contacts[3];
    tri_output out = {.contacts = contacts, .capacity = 3};
    assert_int_equal(octree_triangle(tree, c->b, TRI_IDS, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
    assert_false(out.truncated);
    int touches = 0;
    for (size_t i = 0; i < out.count; i++)
        touches |= contacts[i].triangle == 0;
    octree_free(tree);
    return touches;
}

static int octree_ray_tri_answer(const hard_case *c)
{
    octree *tree = build_world_with_distant_triangles(c);
    ray_hit hits[3];
    ray_output out = {.hits = hits, .max_hits = 3};
    /* octree_ray wants a finite tmin; -DBL_MAX excludes no finite t. */
    ray_input ray = {c->origin, c->direction, isinf(c->tmin) ? -DBL_MAX : c->tmin, c->tmax, RAY_CROSSING};
    assert_int_equal(octree_ray(tree, &ray, RAY_ALL, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
    assert_false(out.truncated);
    int hit = 0;
    for (size_t i = 0; i < out.hit_count; i++)
        hit |= hits[i].triangle == 0;
    octree_free(tree);
    return hit;
}

/* a - b when that is exact (TwoSum error zero), else NAN. */
static double exact_difference(double a, double b)
{
    double s = a - b, b_part = a - s, a_part = s + b_part;
    double error = (a - a_part) - (b - b_part);
    return isfinite(s) && error == 0.0 ? s : NAN;
}

/* For a tri-box case whose box is a cube of side 2^k with its lower corner a multiple of
 * 2^k: the world [W, W + 2^L s] with d = s makes the box a leaf-level node. W is the box's
 * lower corner where the triangle does not reach below it (so world boundary cases keep
 * the box on the world's boundary), else whole cells lower. Three small triangles, each
 * at the world's lower bound along one axis and near its upper bound along the others,
 * and one at the upper corner fix the world exactly without touching the box. Returns
 * NULL when the case's box cannot be a node. */
static octree *build_world_around_box(const hard_case *c, double *side)
{
    box3 b = c->box;
    double s = b.hi.x - b.lo.x;
    int exponent;
    if (!(s > 0) || frexp(s, &exponent) != 0.5 || b.hi.y - b.lo.y != s || b.hi.z - b.lo.z != s)
        return NULL;
    vec3 tri_lo = vec3_min(vec3_min(c->a[0], c->a[1]), c->a[2]);
    vec3 tri_hi = vec3_max(vec3_max(c->a[0], c->a[1]), c->a[2]);
    double world_lo[3], span = 0.0;
    for (int k = 0; k < 3; k++) {
        double lo = vec3_get(b.lo, k);
        if (fmod(lo, s) != 0.0)
            return NULL;
        double below = lo - vec3_get(tri_lo, k);
        double cells = below > 0 ? ceil(below / s) + 1 : 0;
        world_lo[k] = exact_difference(lo, cells * s);
        double top = fmax(vec3_get(tri_hi, k), vec3_get(b.hi, k));
        if (isnan(world_lo[k]) || !isfinite(top))
            return NULL;
        span = fmax(span, (top - world_lo[k]) / s + 1);
    }
    int levels = 1;
    while (ldexp(1.0, levels) < span)
        levels++;
    if (levels > 16)
        return NULL;
    double size = ldexp(s, levels);
    double world_hi[3];
    for (int k = 0; k < 3; k++) {
        world_hi[k] = world_lo[k] + size;
        if (exact_difference(world_hi[k], world_lo[k]) != size)
            return NULL;
    }
    const double q = 0.25 * s;
    vec3 v[15] = {c->a[0], c->a[1], c->a[2]};
    for (int k = 0; k < 3; k++) {
        double p[3] = {world_hi[0] - 2 * q, world_hi[1] - 2 * q, world_hi[2] - 2 * q};
        p[k] = world_lo[k];
        vec3 corner = vec3_make(p[0], p[1], p[2]);
        v[3 + 3 * k] = corner;
        v[4 + 3 * k] = vec3_add(corner, vec3_make(k == 0 ? 0 : q, k == 0 ? q : 0, 0));
        v[5 + 3 * k] = vec3_add(corner, vec3_make(0, k == 2 ? q : 0, k == 2 ? 0 : q));
    }
    vec3 top = vec3_make(world_hi[0], world_hi[1], world_hi[2]);
    v[12] = top;
    v[13] = vec3_sub(top, vec3_make(q, 0, 0));
    v[14] = vec3_sub(top, vec3_make(0, q, q));
    octree *tree = build_world(v, 15, s);
    if (tree->world.lo.x != world_lo[0] || tree->world.lo.y != world_lo[1] || tree->world.lo.z != world_lo[2] ||
        tree->world.hi.x != world_hi[0] || tree->info.max_level != levels)
        fail_msg("world [%a, %a] at level %d, wanted [%a, %a] at level %d", tree->world.lo.x, tree->world.hi.x,
                 tree->info.max_level, world_lo[0], world_hi[0], levels);
    *side = s;
    return tree;
}

static int box_contains_point(box3 b, vec3 p)
{
    return b.lo.x <= p.x && p.x <= b.hi.x && b.lo.y <= p.y && p.y <= b.hi.y && b.lo.z <= p.z && p.z <= b.hi.z;
}

/* Membership of world triangle 0 in the node that is the case's box, read from the tree:
 * the leaf holding the box's centre is the box itself, or an empty leaf above it. Returns
 * -1 when the case does not fit a world. */
static int octree_tri_box_answer(const hard_case *c)
{
    double s;
    octree *tree = build_world_around_box(c, &s);
    if (!tree)
        return -1;
    vec3 centre = vec3_add(c->box.lo, vec3_make(0.5 * s, 0.5 * s, 0.5 * s));
    uint32_t node = 0;
    box3 box = tree->world;
    while (tree->nodes[node].count == NODE_INTERIOR) {
        uint32_t first = tree->nodes[node].first;
        int k = 0;
        while (k < 8 && !box_contains_point(box_octant(box, k), centre))
            k++;
        assert_true(k < 8);
        box = box_octant(box, k);
        node = first + (uint32_t)k;
    }
    octree_node leaf = tree->nodes[node];
    int member = 0;
    for (uint32_t i = 0; i < leaf.count; i++)
        member |= tree->original_id[tree->leaf_items[leaf.first + i]] == 0;
    if (member && !(vec3_equal(box.lo, c->box.lo) && vec3_equal(box.hi, c->box.hi)))
        fail_msg("triangle 0 listed in a leaf larger than the case's box");
    octree_free(tree);
    return member;
}

static void test_octree_answers_every_case(void **state)
{
    const catalogue *cat = *state;
    size_t checked[3] = {0}, skipped = 0, wrong = 0;
    for (size_t i = 0; i < cat->count; i++) {
        const hard_case *c = &cat->cases[i];
        int answer = c->kind == HARD_TRI_TRI   ? octree_tri_tri_answer(c)
                     : c->kind == HARD_RAY_TRI ? octree_ray_tri_answer(c)
                                               : octree_tri_box_answer(c);
        if (answer < 0) {
            skipped++;
            continue;
        }
        checked[c->kind]++;
        if (answer != c->expected && wrong++ < 10) {
            printf("octree answers %d:\n", answer);
            print_case(c);
        }
    }
    printf("octree: %zu tri-tri, %zu tri-box (box = a node), %zu ray-tri cases; %zu tri-box boxes fit no world\n",
           checked[0], checked[1], checked[2], skipped);
    assert_int_equal(wrong, 0);
    assert_true(skipped * 20 < checked[1]); /* nearly every box is a node */
}

/* ---------- (d) symmetry and invariance ---------- */

/* Every variant of a base case (the cases up to the next transform 0) has the base's
 * expected answer; exact mode gives one answer for all of them, and for every vertex order
 * of each triangle and (tri-tri) both argument orders. */
static void test_answers_invariant_under_order_swap_and_transforms(void **state)
{
    const catalogue *cat = *state;
    size_t *violations = calloc(cat->category_count, sizeof *violations);
    size_t *groups = calloc(cat->category_count, sizeof *groups);
    assert_non_null(violations);
    assert_non_null(groups);
    size_t total = 0;
    const hard_case *base = NULL;
    for (size_t i = 0; i < cat->count; i++) {
        const hard_case *c = &cat->cases[i];
        size_t k = category_index(cat, c->category);
        if (c->transform == 0) {
            base = c;
            groups[k]++;
        }
        assert_non_null(base);
        int bad = c->expected != base->expected || c->kind != base->kind || strcmp(c->category, base->category);
        for (int order = 0; order < 6 && !bad; order++) {
            static const int orders[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}, {1, 0, 2}, {0, 2, 1}};
            hard_case v = *c;
            for (int j = 0; j < 3; j++)
                v.a[j] = c->a[orders[order][j]];
            bad |= hard_case_answer(&v, ACCURACY_EXACT, 0.0) != base->expected;
            if (c->kind == HARD_TRI_TRI) {
                for (int j = 0; j < 3; j++) {
                    v.a[j] = c->b[orders[order][j]];
                    v.b[j] = c->a[orders[(order + 1) % 6][j]];
                }
                bad |= hard_case_answer(&v, ACCURACY_EXACT, 0.0) != base->expected;
            }
        }
        if (bad) {
            violations[k]++;
            if (total++ < 10) {
                printf("variant answers differently from its base case:\n");
                print_case(c);
            }
        }
    }
    for (size_t k = 0; k < cat->category_count; k++) {
        if (violations[k])
            printf("invariance: %zu violations in '%s'\n", violations[k], cat->categories[k]);
        assert_true(groups[k] > 0);
        assert_int_equal(violations[k], 0);
    }
    free(violations);
    free(groups);
}

/* ---------- (e) watertightness through the octree ---------- */

/* Closed meshes with every vertex on the grid 2^-20 (rounded copies of the generators'),
 * so that points through which a ray must pass exactly (vertices, edge midpoints) and
 * the rays themselves are exact. Rounding by 2^-21 at most keeps the meshes closed (the
 * indices are shared) and, at these sizes, convex where they were. */
#define GRID_BITS 20

static double on_grid(double x) { return ldexp(nearbyint(ldexp(x, GRID_BITS)), -GRID_BITS); }
static vec3 vec3_on_grid(vec3 p) { return vec3_make(on_grid(p.x), on_grid(p.y), on_grid(p.z)); }

typedef struct closed_mesh {
    const char *name;
    mesh_data mesh;
    int convex;
    vec3 centre;
    double radius;      /* every vertex within this of the centre */
    double inner;       /* convex: a ball of this radius about the centre is inside */
    double torus_major; /* torus about the z axis through the centre: tube centres at this radius */
    double torus_minor;
} closed_mesh;

static closed_mesh closed_mesh_make(const char *name, mesh_data mesh, int convex, vec3 centre, double radius,
                                    double inner)
{
    for (size_t i = 0; i < mesh.vertex_count; i++)
        mesh.vertices[i] = vec3_on_grid(mesh.vertices[i]);
    return (closed_mesh){name, mesh, convex, centre, radius, inner, 0, 0};
}

static void closed_meshes(closed_mesh out[4])
{
    out[0] = closed_mesh_make("tetrahedron",
                              meshgen_tetrahedron(vec3_make(0, 0, 0), vec3_make(4, 0, 0), vec3_make(0, 4, 0),
                                                  vec3_make(1, 1, 4)),
                              1, vec3_make(1.25, 1.25, 1), 4, 0.3);
    out[1] = closed_mesh_make("cube", meshgen_box((box3){{-1, -1, -1}, {1, 1, 1}}), 1, vec3_make(0, 0, 0), 2, 0.9);
    out[2] = closed_mesh_make("icosphere", meshgen_icosphere(vec3_make(0, 0, 0), 2, 2), 1, vec3_make(0, 0, 0), 2.01,
                              1.5);
    out[3] = closed_mesh_make("torus", meshgen_torus(vec3_make(0, 0, 0), 4, 1, 24, 12), 0, vec3_make(0, 0, 0), 5.01,
                              0);
    out[3].torus_major = 4;
    out[3].torus_minor = 1;
}

/* A point deep inside: in the inner ball, or near the tube's core circle. */
static vec3 interior_point(const closed_mesh *m, rng *r)
{
    if (m->convex)
        return vec3_add(m->centre, vec3_scale(rng_unit_vector(r), rng_uniform(r, 0, 0.9) * m->inner));
    double u = rng_uniform(r, 0, 6.283185307179586), w = 0.4 * m->torus_minor;
    vec3 core = vec3_make(m->torus_major * cos(u), m->torus_major * sin(u), 0);
    return vec3_add(vec3_add(m->centre, core), vec3_make(rng_uniform(r, -w, w), rng_uniform(r, -w, w),
                                                         rng_uniform(r, -w, w)));
}

/* The inside point a ray through boundary point p aims at: the centre, or the tube's core
 * at p's angle (then the ray starts outside the tube, on the far side from its core). */
static vec3 inside_behind(const closed_mesh *m, vec3 p)
{
    if (m->convex)
        return vec3_on_grid(m->centre);
    vec3 rel = vec3_sub(p, m->centre);
    double len = sqrt(rel.x * rel.x + rel.y * rel.y);
    return vec3_on_grid(vec3_add(m->centre, vec3_make(m->torus_major * rel.x / len, m->torus_major * rel.y / len, 0)));
}

/* A frame the meshes and rays are also checked in: p -> p 2^scale + offset. */
typedef struct frame {
    int scale;
    vec3 offset;
} frame;

/* 1 when every coordinate maps exactly. */
static int frame_point(frame f, vec3 p, vec3 *out)
{
    double in[3] = {p.x, p.y, p.z}, o[3] = {f.offset.x, f.offset.y, f.offset.z}, res[3];
    for (int k = 0; k < 3; k++) {
        double scaled = ldexp(in[k], f.scale);
        if (ldexp(scaled, -f.scale) != in[k])
            return 0;
        res[k] = scaled + o[k];
        if (exact_difference(res[k], o[k]) != scaled)
            return 0;
    }
    *out = vec3_make(res[0], res[1], res[2]);
    return 1;
}

static int same_t(double a, double b) { return fabs(a - b) <= 0x1p-48 * fmax(fabs(a), fabs(b)); }

typedef struct crossing_tally {
    size_t rays, exact_rays_skipped, wrong;
    size_t seed_wrong, fast_wrong; /* the same check on the other modes: printed only */
} crossing_tally;

/* Whether the crossings of one ray are right: exactly 2 for a convex mesh it enters, 0 or
 * 2 for one it may only touch, an even count (>= 2 when it enters) for the torus. Entering
 * faces the outward normal against the ray, leaving with it, so the depth inside stays 0
 * or 1 after each group of crossings at one t and ends at 0. (Within a group the order is
 * by triangle id, not by the perturbed ray's order: a ray touching a corner may clip it
 * with an exit listed first; reported t are rounded, so "one t" is within a few ulps.)
 * Near-grazing crossings are not judged for direction. */
static int crossings_right(const closed_mesh *m, const ray_input *ray, const ray_output *out, int enters)
{
    size_t n = out->hit_count;
    if (out->truncated || n % 2 != 0 || (enters && n < 2) || (m->convex && n > 2))
        return 0;
    double dlen = vec3_length(ray->direction);
    int depth = 0, judged = 1;
    for (size_t i = 0; i < n;) {
        size_t j = i;
        for (; j < n && same_t(out->hits[j].t, out->hits[i].t); j++) {
            double facing = vec3_dot(out->hits[j].normal, ray->direction) / dlen;
            judged &= fabs(facing) > 1e-6;
            depth += facing < 0 ? 1 : -1;
        }
        if (judged && (depth < 0 || depth > 1))
            return 0;
        i = j;
    }
    return !judged || depth == 0;
}

/* Casts one ray (given in the mesh's own frame) through the framed tree in every mode;
 * exact mode must be right, the others are counted. */
static void check_crossings(const octree *tree, const closed_mesh *m, frame f, vec3 origin, vec3 direction,
                            int enters, crossing_tally *tally, const char *what, uint64_t seed)
{
    ray_input ray = {.tmin = 0, .tmax = INFINITY};
    if (!frame_point(f, origin, &ray.origin)) {
        tally->exact_rays_skipped++;
        return;
    }
    ray.direction = vec3_make(ldexp(direction.x, f.scale), ldexp(direction.y, f.scale), ldexp(direction.z, f.scale));
    ray_hit hits[16];
    ray_output out = {.hits = hits, .max_hits = 16};
    for (int mode = ACCURACY_SEED; mode <= ACCURACY_FAST; mode++) {
        assert_int_equal(octree_ray(tree, &ray, RAY_ALL, (accuracy_mode)mode, &out, NULL), OCTREE_OK);
        if (!crossings_right(m, &ray, &out, enters))
            *(mode == ACCURACY_SEED ? &tally->seed_wrong : &tally->fast_wrong) += 1;
    }
    assert_int_equal(octree_ray(tree, &ray, RAY_ALL, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
    tally->rays++;
    if (!crossings_right(m, &ray, &out, enters) && tally->wrong++ < 10) {
        size_t n = out.hit_count;
        printf("%s (frame 2^%d + (%a, %a, %a)), seed %llu: %zu crossings of the %s, expected %s\n", what, f.scale,
               f.offset.x, f.offset.y, f.offset.z, (unsigned long long)seed, n, m->name,
               m->convex ? (enters ? "2" : "0 or 2") : (enters ? "an even count >= 2" : "an even count"));
        print_vec("origin", ray.origin);
        print_vec("direction", ray.direction);
        for (size_t i = 0; i < n && i < 16; i++)
            printf("  t %a triangle %u n.d %g\n", hits[i].t, hits[i].triangle, vec3_dot(hits[i].normal, ray.direction));
    }
}

/* From outside through boundary point p into the inside point q: o = p - 2 (q - p), exact
 * on the grid, so the ray passes p at t = 2 exactly. */
static void ray_through_point(const octree *tree, const closed_mesh *m, frame f, vec3 p, crossing_tally *tally,
                              const char *what, uint64_t seed)
{
    vec3 q = inside_behind(m, p);
    vec3 d = vec3_make(exact_difference(q.x, p.x), exact_difference(q.y, p.y), exact_difference(q.z, p.z));
    vec3 o = vec3_make(exact_difference(p.x, 2 * d.x), exact_difference(p.y, 2 * d.y), exact_difference(p.z, 2 * d.z));
    if (!vec3_is_finite(o) || !vec3_is_finite(d)) {
        tally->exact_rays_skipped++;
        return;
    }
    check_crossings(tree, m, f, o, d, 1, tally, what, seed);
}

static vec3 random_outside_origin(const closed_mesh *m, rng *r)
{
    return vec3_on_grid(vec3_add(m->centre, vec3_scale(rng_unit_vector(r), rng_uniform(r, 2, 4) * m->radius)));
}

static void test_closed_meshes_are_crossed_watertight_through_the_octree(void **state)
{
    (void)state;
    const uint64_t seed = base_seed + 5;
    printf("watertightness seed %llu\n", (unsigned long long)seed);
    closed_mesh meshes[4];
    closed_meshes(meshes);
    const frame frames[] = {{0, {0, 0, 0}}, {-10, {0x1p20, -0x3p20, 0x1p21}}};
    crossing_tally tally = {0};
    for (int mi = 0; mi < 4; mi++) {
        const closed_mesh *m = &meshes[mi];
        assert_true(m->mesh.triangle_count > 0);
        for (size_t fi = 0; fi < sizeof frames / sizeof frames[0]; fi++) {
            frame f = frames[fi];
            mesh_data framed = {0};
            framed.vertices = malloc(m->mesh.vertex_count * sizeof *framed.vertices);
            assert_non_null(framed.vertices);
            framed.vertex_count = m->mesh.vertex_count;
            framed.indices = m->mesh.indices;
            framed.triangle_count = m->mesh.triangle_count;
            for (size_t i = 0; i < m->mesh.vertex_count; i++)
                assert_true(frame_point(f, m->mesh.vertices[i], &framed.vertices[i]));
            mesh_view view = mesh_data_view(&framed);
            octree_def def = octree_default_def();
            def.resolution = ldexp(m->radius, f.scale) / 8;
            octree *tree = octree_build(&view, &def, NULL);
            assert_non_null(tree);
            rng r = rng_seeded(seed + (uint64_t)(10 * mi) + fi);

            for (size_t v = 0; v < m->mesh.vertex_count; v++)
                ray_through_point(tree, m, f, m->mesh.vertices[v], &tally, "ray through a vertex", seed);
            for (size_t t = 0; t < m->mesh.triangle_count; t++)
                for (int e = 0; e < 3; e++) {
                    uint32_t i = m->mesh.indices[3 * t + (size_t)e], j = m->mesh.indices[3 * t + (size_t)(e + 1) % 3];
                    if (i > j)
                        continue; /* each shared edge once */
                    vec3 mid = vec3_scale(vec3_add(m->mesh.vertices[i], m->mesh.vertices[j]), 0.5);
                    ray_through_point(tree, m, f, mid, &tally, "ray through an edge midpoint", seed);
                }
            /* From random outside points exactly at vertices: they may only touch. */
            for (int k = 0; k < 100; k++) {
                vec3 o = random_outside_origin(m, &r);
                vec3 p = m->mesh.vertices[rng_next(&r) % m->mesh.vertex_count];
                vec3 d = vec3_make(exact_difference(p.x, o.x), exact_difference(p.y, o.y), exact_difference(p.z, o.z));
                if (!vec3_is_finite(d)) {
                    tally.exact_rays_skipped++;
                    continue;
                }
                check_crossings(tree, m, f, o, d, 0, &tally, "ray from outside at a vertex", seed);
            }
            for (int k = 0; k < 200; k++) {
                vec3 o = random_outside_origin(m, &r), q = interior_point(m, &r);
                check_crossings(tree, m, f, o, vec3_sub(q, o), 1, &tally, "random ray through the inside", seed);
            }
            printf("  %-11s frame %zu: %zu rays so far; seed mode wrong %zu, fast mode wrong %zu\n", m->name, fi,
                   tally.rays, tally.seed_wrong, tally.fast_wrong);
            octree_free(tree);
            free(framed.vertices);
        }
    }
    printf("watertightness: %zu rays, %zu skipped (a coordinate would round), %zu wrong in exact mode "
           "(seed mode %zu, fast mode %zu, not asserted)\n",
           tally.rays, tally.exact_rays_skipped, tally.wrong, tally.seed_wrong, tally.fast_wrong);
    for (int mi = 0; mi < 4; mi++)
        mesh_data_free(&meshes[mi].mesh);
    assert_int_equal(tally.wrong, 0);
    assert_true(tally.exact_rays_skipped * 100 < tally.rays);
}

/* ---------- (f) bad input ---------- */

static void test_bad_rays_and_triangles_are_rejected(void **state)
{
    (void)state;
    mesh_data cube = meshgen_box((box3){{0, 0, 0}, {1, 1, 1}});
    mesh_view view = mesh_data_view(&cube);
    octree_def def = octree_default_def();
    def.resolution = 0.25;
    octree *tree = octree_build(&view, &def, NULL);
    assert_non_null(tree);
    const double bad[] = {NAN, INFINITY, -INFINITY};
    ray_hit hits[4];
    for (int mode = ACCURACY_EXACT; mode <= ACCURACY_FAST; mode++)
        for (int detail = RAY_ANY; detail <= RAY_ALL; detail++) {
            for (int b = 0; b < 3; b++)
                for (int k = 0; k < 3; k++) {
                    ray_input ray = {{-1, 0.5, 0.5}, {1, 0, 0}, 0, INFINITY, RAY_CROSSING};
                    ray_output out = {.hits = hits, .max_hits = 4};
                    double *origin[3] = {&ray.origin.x, &ray.origin.y, &ray.origin.z};
                    *origin[k] = bad[b];
                    assert_int_equal(octree_ray(tree, &ray, (ray_detail)detail, (accuracy_mode)mode, &out, NULL),
                                     OCTREE_ERR_NONFINITE);
                    ray = (ray_input){{-1, 0.5, 0.5}, {1, 0, 0}, 0, INFINITY, RAY_CROSSING};
                    double *direction[3] = {&ray.direction.x, &ray.direction.y, &ray.direction.z};
                    *direction[k] = bad[b];
                    assert_int_equal(octree_ray(tree, &ray, (ray_detail)detail, (accuracy_mode)mode, &out, NULL),
                                     OCTREE_ERR_NONFINITE);
                }
            ray_output out = {.hits = hits, .max_hits = 4};
            ray_input zero = {{-1, 0.5, 0.5}, {0, 0, 0}, 0, INFINITY, RAY_CROSSING};
            ray_input negative_zero = {{-1, 0.5, 0.5}, {-0.0, 0.0, -0.0}, 0, INFINITY, RAY_CROSSING};
            ray_input nan_limit = {{-1, 0.5, 0.5}, {1, 0, 0}, 0, NAN, RAY_CROSSING};
            assert_int_equal(octree_ray(tree, &zero, (ray_detail)detail, (accuracy_mode)mode, &out, NULL),
                             OCTREE_ERR_INVALID);
            assert_int_equal(octree_ray(tree, &negative_zero, (ray_detail)detail, (accuracy_mode)mode, &out, NULL),
                             OCTREE_ERR_INVALID);
            assert_int_equal(octree_ray(tree, &nan_limit, (ray_detail)detail, (accuracy_mode)mode, &out, NULL),
                             OCTREE_ERR_INVALID);
            /* Extreme but valid directions are answered, and answered promptly. */
            ray_input tiny = {{-1, 0.5, 0.5}, {0x1p-1074, 0, 0}, 0, INFINITY, RAY_CROSSING};
            ray_input huge = {{-1, 0.5, 0.5}, {DBL_MAX, 0, 0}, 0, INFINITY, RAY_CROSSING};
            assert_int_equal(octree_ray(tree, &tiny, (ray_detail)detail, (accuracy_mode)mode, &out, NULL), OCTREE_OK);
            assert_true(out.hit_count <= 4);
            assert_int_equal(octree_ray(tree, &huge, (ray_detail)detail, (accuracy_mode)mode, &out, NULL), OCTREE_OK);
            assert_true(out.hit_count <= 4);

            for (int b = 0; b < 3; b++)
                for (int v = 0; v < 3; v++) {
                    vec3 q[3] = {{0.5, 0.5, -1}, {0.5, 0.5, 2}, {0.25, 0.75, 0.5}};
                    double *coords[3] = {&q[v].x, &q[v].y, &q[v].z};
                    *coords[(v + b) % 3] = bad[b];
                    tri_contact contacts[4];
                    tri_output tout = {.contacts = contacts, .capacity = 4};
                    assert_int_equal(octree_triangle(tree, q, (tri_detail)detail, (accuracy_mode)mode, &tout, NULL),
                                     OCTREE_ERR_NONFINITE);
                }
        }
    /* The same tree still answers a good ray: two crossings of the cube. */
    ray_input good = {{-1, 0.5, 0.5}, {1, 0, 0}, 0, INFINITY, RAY_CROSSING};
    ray_output out = {.hits = hits, .max_hits = 4};
    assert_int_equal(octree_ray(tree, &good, RAY_ALL, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
    assert_int_equal(out.hit_count, 2);
    octree_free(tree);
    mesh_data_free(&cube);
}

/* ---------- (g) seed and fast modes: counted, not asserted ---------- */

static void test_print_seed_and_fast_error_table(void **state)
{
    const catalogue *cat = *state;
    const double eps = octree_default_def().seed_epsilon;
    size_t n = cat->category_count;
    size_t(*counts)[3][4] = calloc(n, sizeof *counts); /* [kind][cases, seed wrong, fast wrong, exact wrong] */
    assert_non_null(counts);
    for (size_t i = 0; i < cat->count; i++) {
        const hard_case *c = &cat->cases[i];
        size_t k = category_index(cat, c->category);
        size_t *row = counts[k][c->kind];
        row[0]++;
        row[1] += hard_case_answer(c, ACCURACY_SEED, eps) != c->expected;
        row[2] += hard_case_answer(c, ACCURACY_FAST, 0.0) != c->expected;
        row[3] += hard_case_answer(c, ACCURACY_EXACT, 0.0) != c->expected;
    }
    printf("\nwrong answers per category (seed eps %g): cases / seed / fast / exact\n", eps);
    printf("%-40s %-22s %-22s %-22s\n", "category", "tri-tri", "tri-box", "ray-tri");
    size_t total[3][4] = {{0}};
    for (size_t k = 0; k < n; k++) {
        printf("%-40s", cat->categories[k]);
        for (int kind = 0; kind < 3; kind++) {
            const size_t *row = counts[k][kind];
            char cell[64];
            if (row[0])
                snprintf(cell, sizeof cell, "%zu/%zu/%zu/%zu", row[0], row[1], row[2], row[3]);
            else
                snprintf(cell, sizeof cell, "-");
            printf(" %-22s", cell);
            for (int j = 0; j < 4; j++)
                total[kind][j] += row[j];
        }
        printf("\n");
    }
    printf("%-40s", "total");
    for (int kind = 0; kind < 3; kind++) {
        char cell[64];
        snprintf(cell, sizeof cell, "%zu/%zu/%zu/%zu", total[kind][0], total[kind][1], total[kind][2],
                 total[kind][3]);
        printf(" %-22s", cell);
    }
    printf("\n\n");
    free(counts);
    assert_int_equal(total[0][3] + total[1][3] + total[2][3], 0);
}

int main(void)
{
    const char *env = getenv("TRIOCT_SEED");
    if (env && *env)
        base_seed = strtoull(env, NULL, 0);
    printf("test_hard_cases: seed %llu (set TRIOCT_SEED to rerun with another)\n", (unsigned long long)base_seed);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_catalogue_is_deterministic_and_complete),
        cmocka_unit_test(test_expected_answers_equal_the_oracle),
        cmocka_unit_test(test_exact_mode_has_no_wrong_answer_in_any_category),
        cmocka_unit_test(test_octree_answers_every_case),
        cmocka_unit_test(test_answers_invariant_under_order_swap_and_transforms),
        cmocka_unit_test(test_closed_meshes_are_crossed_watertight_through_the_octree),
        cmocka_unit_test(test_bad_rays_and_triangles_are_rejected),
        cmocka_unit_test(test_print_seed_and_fast_error_table),
    };
    return cmocka_run_group_tests_name("hard_cases", tests, setup_catalogue, teardown_catalogue);
}
