/* Tests for the node-box geometry (against the seed's formulas evaluated literally) and the
 * three triangle-box tests (against an exact rational reference written here). */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <gmp.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geom/box_geometry.h"
#include "geom/predicates.h"
#include "geom/tri_box.h"
#include "support/oracle.h"

/* The seed's epsilon for the seed mode, and the margin that makes a random case "clearly"
 * overlapping or separate for the modes that are not exact (a thousand epsilons). */
#define SEED_EPS 1e-9
#define CLEAR_MARGIN 1e-6

/* ---------- randomness with a printed seed ---------- */

typedef struct test_config {
    uint64_t seed;
} test_config;

typedef struct rng {
    uint64_t state;
} rng;

static uint64_t rng_next(rng *r)
{
    uint64_t z = (r->state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}
static double rng_unit(rng *r) { return (double)(rng_next(r) >> 11) * 0x1p-53; }
static double rng_range(rng *r, double a, double b) { return a + (b - a) * rng_unit(r); }
static int rng_int(rng *r, int lo, int hi)
{
    return lo + (int)(rng_next(r) % (uint64_t)(hi - lo + 1));
}

/* Each test draws from its own stream so one can be rerun alone with the same seed. */
static rng test_rng(void **state, uint64_t stream)
{
    const test_config *config = *state;
    rng r = {config->seed ^ (stream * 0xd1342543de82ef95ull)};
    rng_next(&r);
    return r;
}

static double coord(vec3 v, int k) { return k == 0 ? v.x : k == 1 ? v.y : v.z; }
/* ---------- exact reference ---------- */

/* The closed triangle meets the closed box iff some convex combination of its vertices is
 * a convex combination of the box's corners, that is, lies in [lo, hi]. With weights
 * l1, l2 on v1, v2 (and 1 - l1 - l2 on v0) that is the 2D linear system
 *     l1 >= 0, l2 >= 0, l1 + l2 <= 1, lo <= v0 + l1 (v1 - v0) + l2 (v2 - v0) <= hi,
 * nine rows c1 l1 + c2 l2 <= d. Its solution set is bounded and, because the rows l1 >= 0
 * and l2 >= 0 have rank 2, when nonempty it has a vertex where two independent rows hold
 * with equality. So the system is feasible iff one of those pairwise solutions satisfies
 * all rows; each is checked in exact rationals (doubles convert exactly). Nothing here
 * depends on the triangle's area, so segments and points are decided the same way. */
static int reference_tri_box(const vec3 tri[3], box3 box)
{
    enum { ROWS = 9 };
    mpq_t c1[ROWS], c2[ROWS], d[ROWS];
    mpq_t v0, a, b, t, det, l1, l2, lhs;
    for (int r = 0; r < ROWS; r++)
        mpq_inits(c1[r], c2[r], d[r], NULL);
    mpq_inits(v0, a, b, t, det, l1, l2, lhs, NULL);

    mpq_set_si(c1[0], -1, 1); /* -l1 <= 0 */
    mpq_set_si(c2[1], -1, 1); /* -l2 <= 0 */
    mpq_set_si(c1[2], 1, 1);  /* l1 + l2 <= 1 */
    mpq_set_si(c2[2], 1, 1);
    mpq_set_si(d[2], 1, 1);
    for (int k = 0; k < 3; k++) {
        mpq_set_d(v0, coord(tri[0], k));
        mpq_set_d(a, coord(tri[1], k));
        mpq_sub(a, a, v0);
        mpq_set_d(b, coord(tri[2], k));
        mpq_sub(b, b, v0);
        int up = 3 + 2 * k, down = 4 + 2 * k;
        mpq_set(c1[up], a); /* v0 + l1 a + l2 b <= hi */
        mpq_set(c2[up], b);
        mpq_set_d(d[up], coord(box.hi, k));
        mpq_sub(d[up], d[up], v0);
        mpq_neg(c1[down], a); /* -(v0 + l1 a + l2 b) <= -lo */
        mpq_neg(c2[down], b);
        mpq_set_d(d[down], coord(box.lo, k));
        mpq_sub(d[down], v0, d[down]);
    }

    int feasible = 0;
    for (int r = 0; r < ROWS && !feasible; r++) {
        for (int s = r + 1; s < ROWS && !feasible; s++) {
            mpq_mul(det, c1[r], c2[s]);
            mpq_mul(t, c2[r], c1[s]);
            mpq_sub(det, det, t);
            int det_sign = mpq_sgn(det);
            if (det_sign == 0)
                continue;
            /* Cramer's rule without dividing: (l1, l2) = (L1, L2) / det. */
            mpq_mul(l1, d[r], c2[s]);
            mpq_mul(t, c2[r], d[s]);
            mpq_sub(l1, l1, t);
            mpq_mul(l2, c1[r], d[s]);
            mpq_mul(t, d[r], c1[s]);
            mpq_sub(l2, l2, t);
            int all_hold = 1;
            for (int q = 0; q < ROWS && all_hold; q++) {
                mpq_mul(lhs, c1[q], l1);
                mpq_mul(t, c2[q], l2);
                mpq_add(lhs, lhs, t);
                mpq_mul(t, d[q], det);
                mpq_sub(lhs, lhs, t);
                all_hold = mpq_sgn(lhs) * det_sign <= 0;
            }
            feasible = all_hold;
        }
    }

    for (int r = 0; r < ROWS; r++)
        mpq_clears(c1[r], c2[r], d[r], NULL);
    mpq_clears(v0, a, b, t, det, l1, l2, lhs, NULL);
    return feasible;
}

static box3 box_make(double lx, double ly, double lz, double hx, double hy, double hz)
{
    return (box3){{lx, ly, lz}, {hx, hy, hz}};
}

static const box3 unit_box = {{0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}};

static void print_case(const char *what, const vec3 tri[3], box3 box)
{
    printf("%s: tri (%a,%a,%a) (%a,%a,%a) (%a,%a,%a) box (%a,%a,%a)-(%a,%a,%a)\n", what, tri[0].x,
           tri[0].y, tri[0].z, tri[1].x, tri[1].y, tri[1].z, tri[2].x, tri[2].y, tri[2].z, box.lo.x,
           box.lo.y, box.lo.z, box.hi.x, box.hi.y, box.hi.z);
}

/* ---------- node box geometry ---------- */

/* The seed's table of face vertices, transcribed entry by entry. */
static void seed_face_vertices(box3 box, vec3 V[6][4])
{
    double xmin = box.lo.x, ymin = box.lo.y, zmin = box.lo.z;
    double xmax = box.hi.x, ymax = box.hi.y, zmax = box.hi.z;
    V[0][0] = box.lo;
    V[0][1] = vec3_make(xmax, ymin, zmin);
    V[0][2] = vec3_make(xmax, ymin, zmax);
    V[0][3] = vec3_make(xmin, ymin, zmax);
    V[1][0] = V[0][1];
    V[1][1] = vec3_make(xmax, ymax, zmin);
    V[1][2] = box.hi;
    V[1][3] = V[0][2];
    V[2][0] = V[1][1];
    V[2][1] = vec3_make(xmin, ymax, zmin);
    V[2][2] = vec3_make(xmin, ymax, zmax);
    V[2][3] = V[1][2];
    V[3][0] = V[2][1];
    V[3][1] = V[0][0];
    V[3][2] = V[0][3];
    V[3][3] = V[2][2];
    V[4][0] = V[0][3];
    V[4][1] = V[0][2];
    V[4][2] = V[1][2];
    V[4][3] = V[2][2];
    V[5][0] = V[0][0];
    V[5][1] = V[2][1];
    V[5][2] = V[1][1];
    V[5][3] = V[0][1];
}

/* v / |v| as the seed writes it: a division by the Euclidean length. */
static vec3 seed_divide_by_length(vec3 v)
{
    double len = sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    return vec3_make(v.x / len, v.y / len, v.z / len);
}

static box3 random_box(rng *r)
{
    box3 box;
    for (int k = 0; k < 3; k++) {
        double lo = rng_range(r, -1e6, 1e6);
        double extent = ldexp(rng_range(r, 1.0, 2.0), rng_int(r, -20, 20));
        box.lo = vec3_with(box.lo, k, lo);
        box.hi = vec3_with(box.hi, k, lo + extent);
    }
    return box;
}

static void test_box_face_geometry_equals_seed_formulas(void **state)
{
    rng r = test_rng(state, 1);
    for (int n = 0; n < 2000; n++) {
        box3 box = random_box(&r);
        vec3 V[6][4], E[6][4];
        seed_face_vertices(box, V);
        vec3 centre = vec3_scale(vec3_add(box.lo, box.hi), 0.5);
        for (int i = 0; i < 6; i++) {
            E[i][0] = vec3_sub(V[i][1], V[i][0]);
            E[i][1] = vec3_sub(V[i][2], V[i][1]);
            E[i][2] = vec3_sub(V[i][3], V[i][2]);
            E[i][3] = vec3_sub(V[i][0], V[i][3]);
            vec3 normal = seed_divide_by_length(vec3_cross(E[i][3], E[i][0]));
            assert_true(vec3_equal(box_face_normal(i), normal));
            /* An outward unit axis: the centre lies behind every face. */
            assert_true(vec3_dot(normal, vec3_sub(centre, V[i][0])) < 0.0);
            assert_true(fabs(normal.x) + fabs(normal.y) + fabs(normal.z) == 1.0);
            for (int j = 0; j < 4; j++) {
                assert_true(vec3_equal(box_face_vertex(box, i, j), V[i][j]));
                assert_true(vec3_equal(box_face_edge(box, i, j), E[i][j]));
                vec3 edge_normal = vec3_cross(seed_divide_by_length(E[i][j]), normal);
                assert_true(vec3_equal(box_face_edge_normal(box, i, j), edge_normal));
                /* It points away from the face's other vertices. */
                vec3 opposite = V[i][(j + 2) & 3];
                assert_true(vec3_dot(edge_normal, vec3_sub(opposite, V[i][j])) < 0.0);
            }
        }
    }
}

/* The seed's octant table, transcribed entry by entry (index k is octant k + 1). */
static box3 seed_octant(box3 parent, int k)
{
    vec3 pmin = parent.lo, pmax = parent.hi;
    vec3 c = vec3_scale(vec3_add(pmax, pmin), 0.5);
    switch (k) {
    case 0: return (box3){c, pmax};
    case 1: return (box3){{pmin.x, c.y, c.z}, {c.x, pmax.y, pmax.z}};
    case 2: return (box3){{pmin.x, pmin.y, c.z}, {c.x, c.y, pmax.z}};
    case 3: return (box3){{c.x, pmin.y, c.z}, {pmax.x, c.y, pmax.z}};
    case 4: return (box3){{c.x, c.y, pmin.z}, {pmax.x, pmax.y, c.z}};
    case 5: return (box3){{pmin.x, c.y, pmin.z}, {c.x, pmax.y, c.z}};
    case 6: return (box3){pmin, c};
    default: return (box3){{c.x, pmin.y, pmin.z}, {pmax.x, c.y, c.z}};
    }
}

static int box_equal(box3 a, box3 b) { return vec3_equal(a.lo, b.lo) && vec3_equal(a.hi, b.hi); }

/* Two octants that differ only in which half of axis k they take share that face. */
static void assert_octants_tile(box3 parent, const box3 child[8])
{
    for (int a = 0; a < 8; a++) {
        for (int k = 0; k < 3; k++) {
            assert_true(coord(child[a].lo, k) >= coord(parent.lo, k));
            assert_true(coord(child[a].hi, k) <= coord(parent.hi, k));
            assert_true(coord(child[a].lo, k) <= coord(child[a].hi, k));
        }
        for (int b = 0; b < 8; b++) {
            int differing = 0, axis = -1;
            for (int k = 0; k < 3; k++) {
                if (coord(child[a].lo, k) != coord(child[b].lo, k)) {
                    differing++;
                    axis = k;
                }
            }
            if (differing != 1 || coord(child[a].lo, axis) > coord(child[b].lo, axis))
                continue;
            assert_true(coord(child[a].hi, axis) == coord(child[b].lo, axis));
            assert_true(coord(child[a].lo, axis) == coord(parent.lo, axis));
            assert_true(coord(child[b].hi, axis) == coord(parent.hi, axis));
        }
    }
}

/* A coordinate along one axis of a box [l, h] split at m: a face, the split, a point
 * between, or a point beyond the box. */
static double box_landmark(rng *r, double l, double m, double h)
{
    double w = h - l;
    double pick[7] = {l, m, h, l + (m - l) * 0.5, m + (h - m) * 0.5, l - 0.25 * w, h + 0.25 * w};
    return pick[rng_int(r, 0, 6)];
}

/* The octree's descent and build classify a region against a box's split planes with
 * box_octants_reached; it must name exactly the children whose closed boxes the closed
 * region meets, including regions that only touch a split plane and regions reaching
 * past the box (callers pass a triangle's bounds unclipped). */
static void test_octants_reached_are_the_children_a_region_meets(void **state)
{
    rng r = test_rng(state, 9);
    int touching = 0, beyond = 0;
    for (int n = 0; n < 20000; n++) {
        box3 box = random_box(&r);
        vec3 c = box_split_point(box);
        double lo[3], hi[3];
        for (int a = 0; a < 3; a++) {
            double l = coord(box.lo, a), h = coord(box.hi, a), m = coord(c, a);
            /* A region is kept meeting the box. */
            double x = box_landmark(&r, l, m, h), y = box_landmark(&r, l, m, h);
            lo[a] = x < y ? x : y;
            hi[a] = x < y ? y : x;
            if (hi[a] < l)
                hi[a] = l;
            if (lo[a] > h)
                lo[a] = h;
            touching += lo[a] == m || hi[a] == m;
            beyond += lo[a] < l || hi[a] > h;
        }
        vec3 rlo = {lo[0], lo[1], lo[2]}, rhi = {hi[0], hi[1], hi[2]};
        unsigned want = 0;
        for (int k = 0; k < 8; k++) {
            box3 child = box_octant(box, k);
            int meets = 1;
            for (int a = 0; a < 3; a++)
                meets &= coord(rlo, a) <= coord(child.hi, a) && coord(rhi, a) >= coord(child.lo, a);
            want |= (unsigned)meets << k;
        }
        assert_int_equal(box_octants_reached(rlo, rhi, c), want);
    }
    assert_true(touching > 1000 && beyond > 1000);
}

/* box_octants_holding names exactly the children whose closed boxes hold one of the
 * points: points on split planes, faces and corners, inside and outside the box. */
static void test_octants_holding_are_the_children_holding_a_point(void **state)
{
    rng r = test_rng(state, 10);
    int on_split = 0, outside = 0;
    for (int n = 0; n < 20000; n++) {
        box3 box = random_box(&r);
        vec3 c = box_split_point(box);
        vec3 p[3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
        for (int t = 0; t < 3; t++)
            for (int a = 0; a < 3; a++) {
                double l = coord(box.lo, a), h = coord(box.hi, a), m = coord(c, a);
                double x = box_landmark(&r, l, m, h);
                p[t] = vec3_with(p[t], a, x);
                on_split += x == m;
                outside += x < l || x > h;
            }
        unsigned want = 0;
        for (int k = 0; k < 8; k++) {
            box3 child = box_octant(box, k);
            for (int t = 0; t < 3; t++) {
                int in = 1;
                for (int a = 0; a < 3; a++)
                    in &= coord(p[t], a) >= coord(child.lo, a) && coord(p[t], a) <= coord(child.hi, a);
                want |= (unsigned)in << k;
            }
        }
        assert_int_equal(box_octants_holding(p, box, c), want);
    }
    assert_true(on_split > 1000 && outside > 1000);
}

static void test_box_octants_equal_seed_table_and_share_faces(void **state)
{
    rng r = test_rng(state, 2);
    for (int n = 0; n < 2000; n++) {
        box3 parent = random_box(&r);
        /* Walk a few levels down so the shared faces are checked at every depth. */
        for (int level = 0; level < 6; level++) {
            box3 child[8];
            for (int k = 0; k < 8; k++) {
                child[k] = box_octant(parent, k);
                assert_true(box_equal(child[k], seed_octant(parent, k)));
            }
            assert_octants_tile(parent, child);
            parent = child[rng_int(&r, 0, 7)];
        }
    }
    /* Octant 1 (k = 0) is the upper half along every axis, 7 (k = 6) the lower. */
    box3 up = box_octant(unit_box, 0), down = box_octant(unit_box, 6);
    assert_true(box_equal(up, box_make(0.5, 0.5, 0.5, 1, 1, 1)));
    assert_true(box_equal(down, box_make(0, 0, 0, 0.5, 0.5, 0.5)));
    /* A box whose lo + hi overflows still splits inside itself. */
    box3 huge = box_make(1e308, 1e308, -1e308, 1.7e308, 1.7e308, 1.7e308);
    box3 child[8];
    for (int k = 0; k < 8; k++) {
        child[k] = box_octant(huge, k);
        assert_true(vec3_is_finite(child[k].lo) && vec3_is_finite(child[k].hi));
    }
    assert_octants_tile(huge, child);
    assert_true(child[6].hi.x > 1.3e308 && child[6].hi.x < 1.4e308);
}

/* ---------- hand-made cases ---------- */

/* Maps a case onto one of its 288 symmetric copies: vertex order (6), axis order (6) and
 * mirror per axis (8). Negating and permuting coordinates is exact, so the answer must not
 * change; this catches any branch that only works for one orientation. */
static void symmetric_copy(const vec3 tri[3], box3 box, int variant, vec3 out_tri[3], box3 *out_box)
{
    static const int orders[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
    const int *vertex_order = orders[variant % 6];
    const int *axis_order = orders[(variant / 6) % 6];
    int mirror = variant / 36;
    for (int t = 0; t < 3; t++) {
        vec3 src = tri[vertex_order[t]];
        for (int k = 0; k < 3; k++) {
            double value = coord(src, axis_order[k]);
            out_tri[t] = vec3_with(out_tri[t], k, (mirror >> k) & 1 ? -value : value);
        }
    }
    for (int k = 0; k < 3; k++) {
        double lo = coord(box.lo, axis_order[k]), hi = coord(box.hi, axis_order[k]);
        out_box->lo = vec3_with(out_box->lo, k, (mirror >> k) & 1 ? -hi : lo);
        out_box->hi = vec3_with(out_box->hi, k, (mirror >> k) & 1 ? -lo : hi);
    }
}

static void expect_exact(const char *name, vec3 a, vec3 b, vec3 c, box3 box, int expected)
{
    vec3 tri[3] = {a, b, c};
    int reference = reference_tri_box(tri, box);
    if (reference != expected)
        print_case(name, tri, box);
    assert_int_equal(reference, expected);
    for (int variant = 0; variant < 288; variant++) {
        vec3 copy[3];
        box3 copy_box;
        symmetric_copy(tri, box, variant, copy, &copy_box);
        int got = tri_box_overlap_exact(copy, copy_box);
        if (got != expected) {
            printf("variant %d of ", variant);
            print_case(name, copy, copy_box);
        }
        assert_int_equal(got, expected);
    }
}

/* For cases far from any boundary every mode must answer like the exact one. */
static void expect_all_modes(const char *name, vec3 a, vec3 b, vec3 c, box3 box, int expected)
{
    expect_exact(name, a, b, c, box, expected);
    vec3 tri[3] = {a, b, c};
    assert_int_equal(tri_box_overlap_seed(tri, box, SEED_EPS), expected);
    assert_int_equal(tri_box_overlap_fast(tri, box), expected);
}

static vec3 v3(double x, double y, double z) { return vec3_make(x, y, z); }
static double up(double x) { return nextafter(x, INFINITY); }
static double down(double x) { return nextafter(x, -INFINITY); }

static void test_exact_triangle_inside_box(void **state)
{
    (void)state;
    expect_all_modes("inside", v3(0.25, 0.25, 0.25), v3(0.75, 0.25, 0.5), v3(0.5, 0.75, 0.75),
                     unit_box, 1);
    expect_all_modes("far away", v3(3, 3, 3), v3(4, 3, 3), v3(3, 4, 3), unit_box, 0);
    /* Bounding boxes overlap, but the plane passes beyond the corner. */
    expect_all_modes("beyond corner", v3(3.5, 0, 0), v3(0, 3.5, 0), v3(0, 0, 3.5), unit_box, 0);
}

static void test_exact_large_triangle_cutting_through_box(void **state)
{
    (void)state;
    /* Centroid at the box centre, every vertex far outside. */
    expect_all_modes("through centre", v3(10.5, 2.5, -7.5), v3(-5.5, 9.5, 3.5),
                     v3(-3.5, -10.5, 5.5), unit_box, 1);
    /* The same triangle moved past the box along x; the bounding boxes still overlap. */
    expect_all_modes("parallel miss", v3(12.5, 2.5, -7.5), v3(-3.5, 9.5, 3.5),
                     v3(-1.5, -10.5, 5.5), unit_box, 0);
    /* A box much smaller than the triangle, in its plane's interior. */
    box3 small = box_make(0.5, 0.5, 0.5, 0.5 + 0x1p-30, 0.5 + 0x1p-30, 0.5 + 0x1p-30);
    expect_exact("small box in big triangle", v3(10.5, 2.5, -7.5), v3(-5.5, 9.5, 3.5),
                 v3(-3.5, -10.5, 5.5), small, 1);
}

static void test_exact_touching_face_edge_corner_from_outside(void **state)
{
    (void)state;
    /* An edge lying on the top face. */
    expect_exact("edge on face", v3(-1, 0.5, 1), v3(2, 0.5, 1), v3(0.5, 0.5, 3), unit_box, 1);
    /* A vertex on the top face. */
    expect_exact("vertex on face", v3(0.5, 0.5, 1), v3(0, 0, 2), v3(1, 0, 2), unit_box, 1);
    /* The plane x + z = 2 holds the box edge x = z = 1, the triangle covers all of it. */
    expect_exact("plane on box edge", v3(3, -1, -1), v3(3, 2, -1), v3(-1, 0.5, 3), unit_box, 1);
    /* A triangle edge crossing the box edge x = z = 1 skew, at (1, 0.5, 1). */
    expect_exact("edge across box edge", v3(0.5, 0.25, 1.5), v3(1.5, 0.75, 0.5), v3(2, 2, 2),
                 unit_box, 1);
    expect_exact("edge across box edge in axis plane", v3(0.5, 0.5, 1.5), v3(1.5, 0.5, 0.5),
                 v3(1.5, 0.5, 1.5), unit_box, 1);
    /* Plane x + y + z = 3 through the corner (1, 1, 1), the triangle's centroid. */
    expect_exact("plane on corner", v3(3, 0, 0), v3(0, 3, 0), v3(0, 0, 3), unit_box, 1);
    /* A triangle edge through the corner, in the plane of the top face. */
    expect_exact("edge through corner", v3(0, 2, 1), v3(2, 0, 1), v3(2, 2, 1), unit_box, 1);
    /* A skew edge through the corner; every other point has x + y > 2. */
    expect_exact("skew edge through corner", v3(0.5, 1.5, 1.25), v3(1.5, 0.5, 0.75),
                 v3(2, 2, 2), unit_box, 1);
    expect_exact("vertex on corner", v3(1, 1, 1), v3(2, 3, 4), v3(3, 2, 5), unit_box, 1);
}

static void test_exact_one_ulp_separation(void **state)
{
    (void)state;
    double d = 0x1p-50; /* a few ulps of the coordinates below, exactly representable */
    expect_exact("edge above face", v3(-1, 0.5, up(1)), v3(2, 0.5, up(1)), v3(0.5, 0.5, 3),
                 unit_box, 0);
    expect_exact("vertex above face", v3(0.5, 0.5, up(1)), v3(0, 0, 2), v3(1, 0, 2), unit_box, 0);
    expect_exact("plane past box edge", v3(3, -1, -1 + d), v3(3, 2, -1 + d), v3(-1, 0.5, 3 + d),
                 unit_box, 0);
    expect_exact("edge past box edge", v3(0.5 + d, 0.25, 1.5), v3(1.5 + d, 0.75, 0.5),
                 v3(2 + d, 2, 2), unit_box, 0);
    expect_exact("edge past box edge in axis plane", v3(0.5 + d, 0.5, 1.5),
                 v3(1.5 + d, 0.5, 0.5), v3(1.5 + d, 0.5, 1.5), unit_box, 0);
    expect_exact("plane past corner", v3(up(3), 0, 0), v3(0, up(3), 0), v3(0, 0, up(3)),
                 unit_box, 0);
    expect_exact("edge past corner", v3(0, up(2), 1), v3(up(2), 0, 1), v3(2, 2, 1), unit_box, 0);
    expect_exact("skew edge past corner", v3(0.5 + d, 1.5, 1.25), v3(1.5 + d, 0.5, 0.75),
                 v3(2, 2, 2), unit_box, 0);
    expect_exact("vertex past corner", v3(up(1), 1, 1), v3(2, 3, 4), v3(3, 2, 5), unit_box, 0);
    /* The other way: one ulp inside is an overlap. */
    expect_exact("plane one ulp into corner", v3(down(3), 0, 0), v3(0, 3, 0), v3(0, 0, 3),
                 unit_box, 1);
    expect_exact("edge one ulp into box edge", v3(0.5 - d, 0.25, 1.5), v3(1.5 - d, 0.75, 0.5),
                 v3(2, 2, 2), unit_box, 1);
}

static void test_exact_triangle_in_face_plane(void **state)
{
    (void)state;
    expect_exact("covers top face", v3(-1, -1, 1), v3(3, -1, 1), v3(-1, 3, 1), unit_box, 1);
    expect_exact("beside top face", v3(2, 2, 1), v3(3, 2, 1), v3(2, 3, 1), unit_box, 0);
    expect_exact("crosses top face", v3(-1, 0.5, 1), v3(2, 0.4, 1), v3(2, 0.6, 1), unit_box, 1);
    expect_exact("meets top face edge", v3(1, -1, 1), v3(1, 2, 1), v3(3, 0.5, 1), unit_box, 1);
    expect_exact("ulp beside top face edge", v3(up(1), -1, 1), v3(up(1), 2, 1), v3(3, 0.5, 1),
                 unit_box, 0);
    /* In the face plane but cutting only the face's corner off. */
    expect_exact("cuts face corner", v3(0.5, 1.25, 1), v3(1.25, 0.5, 1), v3(3, 3, 1), unit_box, 1);
    expect_exact("misses face corner", v3(1, 1.25, 1), v3(1.25, 1, 1), v3(3, 3, 1), unit_box, 0);
    /* In the face plane of the bottom face, inside it. */
    expect_exact("inside bottom face", v3(0.25, 0.25, 0), v3(0.75, 0.25, 0), v3(0.5, 0.75, 0),
                 unit_box, 1);
}

static void test_exact_zero_area_triangles(void **state)
{
    (void)state;
    double d = 0x1p-50;
    /* Collinear, the segment crossing the box with no vertex inside. */
    expect_exact("segment through box", v3(-1, 0.5, 0.5), v3(2, 0.5, 0.5), v3(3, 0.5, 0.5),
                 unit_box, 1);
    expect_exact("segment along diagonal", v3(-1, -1, -1), v3(2, 2, 2), v3(3, 3, 3), unit_box, 1);
    expect_exact("segment beside box", v3(-1, 0.5, up(1)), v3(2, 0.5, up(1)), v3(3, 0.5, up(1)),
                 unit_box, 0);
    /* Collinear in a plane z = 0.5, touching the box edge x = y = 1. */
    expect_exact("segment on box edge", v3(2, 0, 0.5), v3(0, 2, 0.5), v3(3, -1, 0.5), unit_box, 1);
    expect_exact("segment past box edge", v3(up(2), 0, 0.5), v3(0, up(2), 0.5),
                 v3(1 + 0x1p-52, 1 + 0x1p-52, 0.5), unit_box, 0);
    /* Skew segment through (1, 0.5, 1), on the box edge x = z = 1. */
    expect_exact("skew segment on box edge", v3(0.5, 0.25, 1.5), v3(1.5, 0.75, 0.5),
                 v3(2.5, 1.25, -0.5), unit_box, 1);
    expect_exact("skew segment past box edge", v3(0.5 + d, 0.25, 1.5), v3(1.5 + d, 0.75, 0.5),
                 v3(2.5 + d, 1.25, -0.5), unit_box, 0);
    expect_exact("skew segment into box edge", v3(0.5 - d, 0.25, 1.5), v3(1.5 - d, 0.75, 0.5),
                 v3(2.5 - d, 1.25, -0.5), unit_box, 1);
    /* Repeated vertices. */
    expect_exact("repeated vertex on box edge", v3(2, 0, 0.5), v3(2, 0, 0.5), v3(0, 2, 0.5),
                 unit_box, 1);
    expect_exact("repeated vertex through box", v3(-1, 0.5, 0.5), v3(2, 0.5, 0.5),
                 v3(2, 0.5, 0.5), unit_box, 1);
    expect_exact("repeated vertex past box edge", v3(up(2), 0, 0.5), v3(up(2), 0, 0.5),
                 v3(0, up(2), 0.5), unit_box, 0);
    /* All three equal: a point. */
    expect_exact("point on corner", v3(1, 1, 1), v3(1, 1, 1), v3(1, 1, 1), unit_box, 1);
    expect_exact("point inside", v3(0.5, 0.5, 0.5), v3(0.5, 0.5, 0.5), v3(0.5, 0.5, 0.5),
                 unit_box, 1);
    expect_exact("point past corner", v3(up(1), 1, 1), v3(up(1), 1, 1), v3(up(1), 1, 1),
                 unit_box, 0);
    expect_exact("point far", v3(5, 5, 5), v3(5, 5, 5), v3(5, 5, 5), unit_box, 0);
}

static void test_exact_triangle_crossing_only_a_box_edge(void **state)
{
    (void)state;
    /* The plane x + y = 1.5 cuts a prism off the box around the edge x = y = 1. */
    expect_all_modes("cuts box edge", v3(3, -1.5, -5), v3(-1.5, 3, -5), v3(0.75, 0.75, 10),
                     unit_box, 1);
    /* The plane x + y + z = 2.5 cuts the corner (1, 1, 1) off. */
    expect_all_modes("cuts box corner", v3(2.5, 0, 0), v3(0, 2.5, 0), v3(0, 0, 2.5), unit_box, 1);
    /* A needle through two opposite faces: no vertex inside and no box edge through it. */
    expect_all_modes("needle through box", v3(-1, 0.5, 0.5), v3(2, 0.4, 0.5), v3(2, 0.6, 0.5),
                     unit_box, 1);
    /* A thin triangle crossing the box edge x = z = 1 near y = 0.5, narrower than the box. */
    expect_all_modes("thin across box edge", v3(0.75, 0.5, 1.5), v3(1.25, 0.4, 0.25),
                     v3(1.25, 0.6, 0.25), unit_box, 1);
}

static void test_exact_huge_offsets(void **state)
{
    (void)state;
    const double offsets[] = {1e6, 1e9, -1e9};
    for (size_t n = 0; n < sizeof offsets / sizeof offsets[0]; n++) {
        double o = offsets[n];
        box3 box = box_make(o, o, o, o + 1, o + 1, o + 1);
        expect_exact("offset plane on corner", v3(o + 3, o, o), v3(o, o + 3, o), v3(o, o, o + 3),
                     box, 1);
        expect_exact("offset plane past corner", v3(up(o + 3), o, o), v3(o, up(o + 3), o),
                     v3(o, o, up(o + 3)), box, 0);
        expect_exact("offset edge across box edge", v3(o + 0.5, o + 0.25, o + 1.5),
                     v3(o + 1.5, o + 0.75, o + 0.5), v3(o + 2, o + 2, o + 2), box, 1);
        expect_exact("offset edge past box edge", v3(up(o + 0.5), o + 0.25, o + 1.5),
                     v3(up(o + 1.5), o + 0.75, o + 0.5), v3(o + 2, o + 2, o + 2), box, 0);
        expect_all_modes("offset inside", v3(o + 0.25, o + 0.25, o + 0.5),
                         v3(o + 0.75, o + 0.25, o + 0.5), v3(o + 0.5, o + 0.75, o + 0.5), box, 1);
        /* A box of one unit in the last place of the offset. */
        box3 tiny = box_make(o, o, o, up(o), up(o), up(o));
        expect_exact("ulp box on plane", v3(o - 4, o + 2, o + 2), v3(o + 2, o - 4, o + 2),
                     v3(o + 2, o + 2, o - 4), tiny, 1);
        expect_exact("ulp box beside plane", v3(o - 4, o + 2, o + 2), v3(o + 2, o - 4, o + 2),
                     v3(o + 2, o + 2, o - 4), box_make(up(o), up(o), up(o), up(up(o)),
                                                       up(up(o)), up(up(o))), 0);
    }
}

/* The unit-box configurations at the ends of the double range: x -> (x - 2) 2^1021 maps
 * the unit box to [-2^1022, -2^1021] on each axis and the triangles across zero to near
 * +-2^1023, exactly (the coordinates are small dyadics); the symmetric copies mirror them
 * onto the other end too. Differences across the range overflow, and one-ulp steps are
 * steps of 2^969 to 2^971. */
static double far_end(double x) { return ldexp(x - 2.0, 1021); }
static vec3 far3(double x, double y, double z) { return v3(far_end(x), far_end(y), far_end(z)); }

static void test_exact_at_the_ends_of_the_double_range(void **state)
{
    (void)state;
    box3 box = {far3(0, 0, 0), far3(1, 1, 1)};
    expect_exact("far edge on face", far3(-1, 0.5, 1), far3(2, 0.5, 1), far3(0.5, 0.5, 3), box, 1);
    expect_exact("far edge above face", v3(far_end(-1), far_end(0.5), up(far_end(1))),
                 v3(far_end(2), far_end(0.5), up(far_end(1))), far3(0.5, 0.5, 3), box, 0);
    expect_exact("far vertex on face", far3(0.5, 0.5, 1), far3(0, 0, 2), far3(1, 0, 2), box, 1);
    expect_exact("far plane on box edge", far3(3, -1, -1), far3(3, 2, -1), far3(-1, 0.5, 3), box, 1);
    expect_exact("far edge across box edge", far3(0.5, 0.25, 1.5), far3(1.5, 0.75, 0.5), far3(2, 2, 2), box, 1);
    expect_exact("far edge past box edge", v3(up(far_end(0.5)), far_end(0.25), far_end(1.5)),
                 v3(up(far_end(1.5)), far_end(0.75), far_end(0.5)), far3(2, 2, 2), box, 0);
    expect_exact("far plane on corner", far3(3, 0, 0), far3(0, 3, 0), far3(0, 0, 3), box, 1);
    expect_exact("far plane past corner", v3(up(far_end(3)), far_end(0), far_end(0)),
                 v3(far_end(0), up(far_end(3)), far_end(0)), v3(far_end(0), far_end(0), up(far_end(3))), box, 0);
    expect_exact("far edge through corner", far3(0, 2, 1), far3(2, 0, 1), far3(2, 2, 1), box, 1);
    expect_exact("far vertex on corner", far3(1, 1, 1), far3(2, 3, 4), far3(3, 2, 5), box, 1);
    /* A triangle spanning the range against a small box at its middle (2^400: inside the
     * exact span with DBL_MAX) and a box of one ulp at its end. */
    const double M = DBL_MAX;
    box3 small_box = box_make(0, 0, 0, 0x1p400, 0x1p400, 0x1p400);
    expect_exact("range-wide triangle through a small box", v3(-M, -M, 0), v3(M, -M, 0), v3(0, M, 0), small_box, 1);
    box3 lifted = box_make(0, 0, 0x1p400, 0x1p400, 0x1p400, 0x1p401);
    expect_exact("range-wide triangle below a small box", v3(-M, -M, 0), v3(M, -M, 0), v3(0, M, 0), lifted, 0);
    /* The plane z = y, from one end of the range to the other, touches that box along its
     * edge y = z = 2^400; one ulp higher the box is clear of it. */
    expect_exact("range-wide tilted triangle on a small box's edge", v3(-M, -M, -M), v3(M, -M, -M), v3(0, M, M),
                 lifted, 1);
    box3 higher = box_make(0, 0, up(0x1p400), 0x1p400, 0x1p400, 0x1p401);
    expect_exact("range-wide tilted triangle below a small box", v3(-M, -M, -M), v3(M, -M, -M), v3(0, M, M),
                 higher, 0);
    box3 top_ulp = box_make(nextafter(M, 0), nextafter(M, 0), 0, M, M, 0);
    expect_exact("range-wide triangle beside the top corner", v3(-M, -M, 0), v3(M, -M, 0), v3(0, M, 0), top_ulp, 0);
    expect_exact("range-wide triangle on the top corner", v3(-M, -M, 0), v3(M, -M, 0), v3(M, M, 0), top_ulp, 1);
}

static void test_exact_tiny_triangles(void **state)
{
    (void)state;
    double e = 0x1p-30; /* about 1e-9 */
    double u = 0x1p-52;
    expect_exact("tiny edge on box edge", v3(1 - e, 1 + e, 0.5), v3(1 + e, 1 - e, 0.5),
                 v3(1 + e, 1 + e, 0.5), unit_box, 1);
    expect_exact("tiny edge past box edge", v3(1 - e + u, 1 + e, 0.5), v3(1 + e + u, 1 - e, 0.5),
                 v3(1 + e + u, 1 + e, 0.5), unit_box, 0);
    expect_exact("tiny inside corner", v3(1 - e, 1 - e, 1 - e), v3(1 - 2 * e, 1 - e, 1 - e),
                 v3(1 - e, 1 - 2 * e, 1 - e), unit_box, 1);
    /* Tiny triangle around the corner with plane x + y + z = 3 - e: no vertex inside. */
    expect_exact("tiny across corner", v3(1 + e, 1 - e, 1 - e), v3(1 - e, 1 + e, 1 - e),
                 v3(1 - e, 1 - e, 1 + e), unit_box, 1);
    expect_exact("tiny past corner", v3(1 + 2 * e, 1, 1), v3(1, 1 + 2 * e, 1), v3(1, 1, 1 + 2 * e),
                 unit_box, 0);
    expect_exact("tiny touching corner", v3(1 + 2 * e, 1 - e, 1 - e), v3(1 - e, 1 + 2 * e, 1 - e),
                 v3(1 - e, 1 - e, 1 + 2 * e), unit_box, 1);
    expect_exact("1e-9 near face", v3(0.5, 0.5, 1 + 1e-9), v3(0.5 + 1e-9, 0.5, 1 + 1e-9),
                 v3(0.5, 0.5 + 1e-9, 1 + 2e-9), unit_box, 0);
}

/* ---------- randomised comparisons ---------- */

/* A random box and a triangle around it, in general position. */
static void uniform_case(rng *r, vec3 tri[3], box3 *box)
{
    for (int k = 0; k < 3; k++) {
        double lo = rng_range(r, -1, 1);
        box->lo = vec3_with(box->lo, k, lo);
        box->hi = vec3_with(box->hi, k, lo + rng_range(r, 0.1, 2));
    }
    for (int t = 0; t < 3; t++)
        for (int k = 0; k < 3; k++) {
            double lo = coord(box->lo, k), hi = coord(box->hi, k), size = hi - lo;
            tri[t] = vec3_with(tri[t], k, rng_range(r, lo - size, hi + size));
        }
}

static double grid_value(rng *r, double lo, double hi)
{
    switch (rng_int(r, 0, 5)) {
    case 0: return lo;
    case 1: return hi;
    default: return rng_int(r, (int)lo - 4, (int)hi + 4);
    }
}

/* Small integer coordinates make touching, collinear and coplanar configurations exact
 * (vertices on faces, edges through box edges and corners, zero-area triangles); a later
 * ulp nudge lands just beside them, and an exact power-of-two scale and an offset move
 * them around without rounding. */
static void near_degenerate_case(rng *r, vec3 tri[3], box3 *box)
{
    for (int k = 0; k < 3; k++) {
        int lo = rng_int(r, 0, 4);
        int extent = rng_int(r, 0, 9) == 0 ? 0 : rng_int(r, 1, 4); /* a few flat boxes */
        box->lo = vec3_with(box->lo, k, lo);
        box->hi = vec3_with(box->hi, k, lo + extent);
    }
    for (int t = 0; t < 3; t++)
        for (int k = 0; k < 3; k++)
            tri[t] = vec3_with(tri[t], k, grid_value(r, coord(box->lo, k), coord(box->hi, k)));

    vec3 anchor; /* a box corner or a lattice point on a box edge */
    for (int k = 0; k < 3; k++)
        anchor = vec3_with(anchor, k, rng_int(r, 0, 1) ? coord(box->lo, k) : coord(box->hi, k));
    int along = rng_int(r, 0, 2);
    anchor = vec3_with(anchor, along, grid_value(r, coord(box->lo, along), coord(box->hi, along)));
    vec3 step = v3(rng_int(r, -3, 3), rng_int(r, -3, 3), rng_int(r, -3, 3));

    switch (rng_int(r, 0, 7)) {
    case 0: /* collinear */
        tri[2] = vec3_add(tri[0], vec3_scale(vec3_sub(tri[1], tri[0]), rng_int(r, -2, 3)));
        break;
    case 1: /* a point */
        tri[1] = tri[2] = tri[0];
        break;
    case 2: /* an edge through the anchor */
        tri[0] = vec3_add(anchor, step);
        tri[1] = vec3_sub(anchor, vec3_scale(step, rng_int(r, 1, 2)));
        break;
    case 3: /* a zero-area triangle through the anchor */
        tri[0] = vec3_add(anchor, step);
        tri[1] = vec3_sub(anchor, step);
        tri[2] = vec3_add(anchor, vec3_scale(step, rng_int(r, -3, 3)));
        break;
    case 4: /* a vertex on the anchor */
        tri[rng_int(r, 0, 2)] = anchor;
        break;
    case 5: { /* random doubles with coordinates snapped onto the box's planes */
        for (int t = 0; t < 3; t++)
            for (int k = 0; k < 3; k++) {
                double lo = coord(box->lo, k), hi = coord(box->hi, k);
                int pick = rng_int(r, 0, 3);
                tri[t] = vec3_with(tri[t], k, pick == 0 ? lo : pick == 1 ? hi
                                                     : rng_range(r, lo - 2, hi + 2));
            }
        break;
    }
    default: /* as generated */
        break;
    }

    if (rng_int(r, 0, 1)) { /* nudge one coordinate by an ulp or two */
        int which = rng_int(r, 0, 4), k = rng_int(r, 0, 2);
        double dir = rng_int(r, 0, 1) ? INFINITY : -INFINITY;
        int times = rng_int(r, 1, 2);
        if (which < 3) {
            double value = coord(tri[which], k);
            for (int n = 0; n < times; n++)
                value = nextafter(value, dir);
            tri[which] = vec3_with(tri[which], k, value);
        } else {
            vec3 *side = which == 3 ? &box->lo : &box->hi;
            double value = coord(*side, k);
            for (int n = 0; n < times; n++)
                value = nextafter(value, dir);
            *side = vec3_with(*side, k, value);
            if (coord(box->lo, k) > coord(box->hi, k)) {
                vec3 *other = which == 3 ? &box->hi : &box->lo;
                *other = vec3_with(*other, k, value);
            }
        }
    }

    static const double offsets[] = {0.0, 1e6, -1e9, 0x1p30};
    double scale = ldexp(1.0, rng_int(r, -16, 16));
    double offset = offsets[rng_int(r, 0, 3)];
    for (int t = 0; t < 3; t++)
        tri[t] = vec3_add(vec3_scale(tri[t], scale), v3(offset, offset, offset));
    box->lo = vec3_add(vec3_scale(box->lo, scale), v3(offset, offset, offset));
    box->hi = vec3_add(vec3_scale(box->hi, scale), v3(offset, offset, offset));
}

static void test_exact_equals_reference_on_near_degenerate_cases(void **state)
{
    rng r = test_rng(state, 3);
    int cases = 40000, overlaps = 0, mismatches = 0, zero_area = 0;
    uint64_t fallbacks_before = predicates_fallback_count();
    for (int n = 0; n < cases; n++) {
        vec3 tri[3];
        box3 box;
        near_degenerate_case(&r, tri, &box);
        int expected = reference_tri_box(tri, box);
        int got = tri_box_overlap_exact(tri, box);
        overlaps += expected;
        vec3 normal = vec3_cross(vec3_sub(tri[1], tri[0]), vec3_sub(tri[2], tri[0]));
        zero_area += vec3_equal(normal, v3(0, 0, 0));
        if (got != expected && mismatches++ < 5) {
            printf("exact %d, reference %d: ", got, expected);
            print_case("mismatch", tri, box);
        }
    }
    printf("near-degenerate: %d cases, %d overlapping, %d of about zero area, %llu exact "
           "fallbacks, %d mismatches\n",
           cases, overlaps, zero_area,
           (unsigned long long)(predicates_fallback_count() - fallbacks_before), mismatches);
    assert_int_equal(mismatches, 0);
    /* Both answers must be well represented, or the comparison proves little. */
    assert_true(overlaps > cases / 5 && overlaps < cases * 4 / 5);
    assert_true(zero_area > cases / 10);
}

/* near_degenerate_case moved to the ends of the double range: centred on its box (the
 * centre is rounded, so a few degeneracies become near ones) and scaled by a power of two
 * that puts its largest coordinate in the top binade, so the triangle and the box reach
 * both ends and their differences overflow. */
static void test_exact_equals_reference_at_the_ends_of_the_double_range(void **state)
{
    rng r = test_rng(state, 11);
    int cases = 8000, overlaps = 0, mismatches = 0;
    for (int n = 0; n < cases; n++) {
        vec3 tri[3];
        box3 box;
        near_degenerate_case(&r, tri, &box);
        vec3 centre = n % 2 ? vec3_scale(vec3_add(box.lo, box.hi), 0.5) : v3(0, 0, 0);
        double top = 0.0;
        for (int t = 0; t < 3; t++)
            tri[t] = vec3_sub(tri[t], centre);
        box.lo = vec3_sub(box.lo, centre);
        box.hi = vec3_sub(box.hi, centre);
        for (int k = 0; k < 3; k++) {
            for (int t = 0; t < 3; t++)
                top = fmax(top, fabs(coord(tri[t], k)));
            top = fmax(top, fmax(fabs(coord(box.lo, k)), fabs(coord(box.hi, k))));
        }
        if (top == 0.0)
            continue;
        int shift = 1023 - ilogb(top);
        for (int t = 0; t < 3; t++)
            tri[t] = v3(ldexp(tri[t].x, shift), ldexp(tri[t].y, shift), ldexp(tri[t].z, shift));
        box.lo = v3(ldexp(box.lo.x, shift), ldexp(box.lo.y, shift), ldexp(box.lo.z, shift));
        box.hi = v3(ldexp(box.hi.x, shift), ldexp(box.hi.y, shift), ldexp(box.hi.z, shift));
        int expected = reference_tri_box(tri, box);
        int got = tri_box_overlap_exact(tri, box);
        overlaps += expected;
        if (got != expected && mismatches++ < 5) {
            printf("exact %d, reference %d: ", got, expected);
            print_case("mismatch at the ends of the range", tri, box);
        }
        if (n % 8 == 0)
            assert_int_equal(oracle_tri_box(tri, box), expected);
    }
    printf("ends of the range: %d cases, %d overlapping, %d mismatches\n", cases, overlaps, mismatches);
    assert_int_equal(mismatches, 0);
    assert_true(overlaps > cases / 5 && overlaps < cases * 4 / 5);
}

static void test_exact_equals_reference_on_uniform_cases(void **state)
{
    rng r = test_rng(state, 4);
    int cases = 20000, overlaps = 0, mismatches = 0;
    for (int n = 0; n < cases; n++) {
        vec3 tri[3];
        box3 box;
        uniform_case(&r, tri, &box);
        int expected = reference_tri_box(tri, box);
        int got = tri_box_overlap_exact(tri, box);
        overlaps += expected;
        if (got != expected && mismatches++ < 5) {
            printf("exact %d, reference %d: ", got, expected);
            print_case("mismatch", tri, box);
        }
    }
    printf("uniform: %d cases, %d overlapping, %d mismatches\n", cases, overlaps, mismatches);
    assert_int_equal(mismatches, 0);
    assert_true(overlaps > cases / 5 && overlaps < cases * 4 / 5);
}

/* One preparation serves every box a triangle meets on its way down a tree: the node
 * itself, its eight children (which share the split planes, where touching is decided by
 * an exact zero) and a box the triangle never reaches. Each answer must equal the
 * reference, so nothing the preparation computes may depend on the box tested first. */
static void test_prepared_triangle_against_a_node_and_its_children(void **state)
{
    rng r = test_rng(state, 5);
    int cases = 10000, answers = 0, overlaps = 0, mismatches = 0;
    for (int n = 0; n < cases; n++) {
        vec3 tri[3];
        box3 box;
        near_degenerate_case(&r, tri, &box);
        tri_box_triangle prepared;
        tri_box_prepare(&prepared, tri);
        box3 boxes[10];
        boxes[0] = box;
        for (int k = 0; k < 8; k++)
            boxes[1 + k] = box_octant(box, k);
        vec3 far = v3(4 * fabs(box.hi.x) + 1e3, 0, 0);
        boxes[9] = (box3){vec3_add(box.lo, far), vec3_add(box.hi, far)};
        for (int b = 0; b < 10; b++) {
            int expected = reference_tri_box(tri, boxes[b]);
            int got = tri_box_overlap_prepared(&prepared, boxes[b]);
            answers++;
            overlaps += expected;
            if (got != expected && mismatches++ < 5) {
                printf("box %d: prepared %d, reference %d: ", b, got, expected);
                print_case("mismatch", tri, boxes[b]);
            }
        }
    }
    printf("prepared: %d answers, %d overlapping, %d mismatches\n", answers, overlaps, mismatches);
    assert_int_equal(mismatches, 0);
    assert_true(overlaps > answers / 5 && overlaps < answers * 4 / 5);
}

/* The children test (four lanes of float filters, then the prepared test for what they
 * leave open) must answer as the reference for every child it is asked about, on both its
 * code paths: on near-degenerate cases (vertices and edges on the split planes and faces,
 * zero-area triangles, ulp nudges, offsets up to 1e9), uniform ones, ones scaled near
 * either end of the double range (where the filters' products overflow or underflow and
 * must decide nothing), and slivers. The masks asked vary, and a far box is asked too.
 * Both outcomes must occur often, and the exact stages must be reached often (counted
 * through the exact fallbacks), so that the cases are the ones the filters cannot settle. */
static void test_children_touched_equals_reference(void **state)
{
    rng r = test_rng(state, 8);
    int answers = 0, touched = 0, wrong = 0;
    uint64_t fallbacks_before = predicates_fallback_count();
    for (int n = 0; n < 30000; n++) {
        vec3 tri[3];
        box3 box;
        if (n % 3 == 0)
            uniform_case(&r, tri, &box);
        else
            near_degenerate_case(&r, tri, &box);
        if (n % 10 == 9 || n % 10 == 8) { /* exact power-of-two scalings */
            double s = n % 10 == 9 ? 0x1p950 : 0x1p-950;
            for (int t = 0; t < 3; t++)
                tri[t] = vec3_scale(tri[t], s);
            box = (box3){vec3_scale(box.lo, s), vec3_scale(box.hi, s)};
        }
        if (n % 17 == 5) { /* a sliver: the third vertex one ulp off the first edge's midpoint */
            vec3 mid = vec3_scale(vec3_add(tri[0], tri[1]), 0.5);
            tri[2] = vec3_with(mid, 2, nextafter(mid.z, INFINITY));
        }
        vec3 c = box_split_point(box);
        box3 child[8];
        for (int k = 0; k < 8; k++)
            child[k] = box_child(box, c, box_octant_upper_bits[k]);
        if (n % 5 == 4) { /* one child moved far away: the box axes decide it */
            vec3 far = v3(4 * fabs(box.hi.x) + 1e3, 0, 0);
            child[3] = (box3){vec3_add(child[3].lo, far), vec3_add(child[3].hi, far)};
        }
        unsigned open = n % 4 == 0 ? 0xffu : (unsigned)(rng_next(&r) & 0xff);
        unsigned expected = 0;
        for (int k = 0; k < 8; k++)
            if ((open >> k) & 1 && reference_tri_box(tri, child[k]))
                expected |= 1u << k;
        for (int path = 0; path < 2; path++) {
            tri_box_triangle prepared;
            tri_box_prepare(&prepared, tri);
            unsigned got = path == 0 ? tri_box_children_touched(&prepared, child, open)
                                     : tri_box_children_touched_portable(&prepared, child, open);
            answers += __builtin_popcount(open);
            touched += __builtin_popcount(expected);
            if (got != expected && wrong++ < 5) {
                printf("path %d, open %02x: got %02x, reference %02x: ", path, open, got, expected);
                print_case("children", tri, box);
            }
        }
    }
    uint64_t fallbacks = predicates_fallback_count() - fallbacks_before;
    printf("children touched: %d answers, %d touched, %d wrong, %llu exact fallbacks\n", answers, touched, wrong,
           (unsigned long long)fallbacks);
    assert_int_equal(wrong, 0);
    assert_true(touched > answers / 5 && touched < answers * 4 / 5);
    assert_true(fallbacks > 1000);
}

/* Each child tri_box_children_at_crossings names must be touched, on near-degenerate
 * cases (edges crossing split planes at lattice points, ulp nudges), uniform ones, and
 * ones scaled near the top of the double range, where the crossing arithmetic overflows
 * and must prove nothing. It must also name many: it exists to spare the full test. Its
 * AVX2 and portable paths must name the same children. */
static void test_children_at_crossings_are_touched(void **state)
{
    rng r = test_rng(state, 6);
    int named = 0, touched_open = 0, wrong = 0, paths_differ = 0, crossings_seen = 0;
    for (int n = 0; n < 30000; n++) {
        vec3 tri[3];
        box3 box;
        if (n % 3 == 0)
            near_degenerate_case(&r, tri, &box);
        else
            uniform_case(&r, tri, &box);
        if (n % 10 == 9) { /* exact power-of-two scaling: the same configuration near 1e300 */
            for (int t = 0; t < 3; t++)
                tri[t] = vec3_scale(tri[t], 0x1p950);
            box = (box3){vec3_scale(box.lo, 0x1p950), vec3_scale(box.hi, 0x1p950)};
        }
        vec3 c = box_split_point(box);
        unsigned crossing = tri_box_children_at_crossings(tri, box, c, 0xff);
        /* Both code paths name the same children when all are wanted; with fewer wanted,
         * each may stop early (the AVX2 path after whole edges), but names no child the
         * full search does not, and every wanted one the full search names. */
        unsigned portable = tri_box_children_at_crossings_portable(tri, box, c, 0xff);
        unsigned wanted = (unsigned)(rng_next(&r) & 0xff);
        unsigned some = tri_box_children_at_crossings(tri, box, c, wanted);
        unsigned some_portable = tri_box_children_at_crossings_portable(tri, box, c, wanted);
        int differ = crossing != portable || (some & ~crossing) != 0 || (some_portable & ~crossing) != 0 ||
                     (some & wanted) != (crossing & wanted) || (some_portable & wanted) != (crossing & wanted);
        if (differ && paths_differ++ < 5) {
            printf("paths differ: %02x and %02x named, %02x and %02x of %02x wanted: ", crossing, portable, some,
                   some_portable, wanted);
            print_case("crossing", tri, box);
        }
        crossings_seen += crossing != 0;
        for (int k = 0; k < 8; k++) {
            int touched = reference_tri_box(tri, box_octant(box, k));
            int claimed = (crossing >> k) & 1;
            named += claimed;
            touched_open += touched;
            if (claimed && !touched && wrong++ < 5) {
                printf("child %d claimed but not touched: ", k);
                print_case("crossing", tri, box_octant(box, k));
            }
        }
    }
    /* An edge whose x difference overflows: a naive t = (c - p) / (q - p) is 0 and puts the
     * crossing of x = 0 at p's y, -2^1022, in the lower y half; the true crossing is at
     * y = 2^1020. The triangle does not reach x >= 0 with y <= 0, so the children there
     * must not be named. */
    const double big = 0x1.8p1023;
    vec3 wide[3] = {{-big, -0x1p1022, 0.5}, {big, 0x1.8p1022, 0.5}, {big, 0x1.8p1022 + 0x1p1000, 0.5}};
    box3 whole = {{-DBL_MAX, -DBL_MAX, -1}, {DBL_MAX, DBL_MAX, 1}};
    unsigned wide_crossing = tri_box_children_at_crossings(wide, whole, box_split_point(whole), 0xff);
    for (int k = 0; k < 8; k++)
        if ((wide_crossing >> k) & 1) {
            named++;
            if (!tri_box_overlap_exact(wide, box_octant(whole, k)) && wrong++ < 5)
                printf("child %d of the overflowing case claimed but not touched\n", k);
        }
    printf("crossings: %d children named of %d touched, %d wrongly; %d cases named some, %d where the paths "
           "differ\n", named, touched_open, wrong, crossings_seen, paths_differ);
    assert_int_equal(wrong, 0);
    assert_int_equal(paths_differ, 0);
    assert_true(crossings_seen > 1000);
    assert_true(named > touched_open / 10);
}

static box3 grow_box(box3 box, double margin)
{
    return (box3){vec3_sub(box.lo, v3(margin, margin, margin)),
                  vec3_add(box.hi, v3(margin, margin, margin))};
}

/* The seed and fast modes are not exact, so they are held to the reference only where the
 * answer does not hinge on the boundary: the triangle meets the box shrunk by the margin,
 * or misses it grown by the margin. Their errors on borderline cases are counted. */
static void test_seed_and_fast_agree_with_reference_on_clear_cases(void **state)
{
    rng r = test_rng(state, 5);
    int cases = 8000, clear = 0, clear_overlaps = 0, seed_wrong = 0, fast_wrong = 0;
    for (int n = 0; n < cases; n++) {
        vec3 tri[3];
        box3 box;
        uniform_case(&r, tri, &box);
        int inner = reference_tri_box(tri, grow_box(box, -CLEAR_MARGIN));
        int outer = reference_tri_box(tri, grow_box(box, CLEAR_MARGIN));
        if (inner != outer)
            continue;
        clear++;
        clear_overlaps += inner;
        int seed = tri_box_overlap_seed(tri, box, SEED_EPS);
        int fast = tri_box_overlap_fast(tri, box);
        if ((seed != inner && seed_wrong++ < 5) || (fast != inner && fast_wrong++ < 5)) {
            printf("seed %d, fast %d, expected %d: ", seed, fast, inner);
            print_case("clear case", tri, box);
        }
    }
    printf("clear cases: %d of %d (%d overlapping); seed wrong %d, fast wrong %d\n", clear, cases,
           clear_overlaps, seed_wrong, fast_wrong);
    assert_int_equal(seed_wrong, 0);
    assert_int_equal(fast_wrong, 0);
    assert_true(clear > cases * 9 / 10);
    assert_true(clear_overlaps > clear / 5 && clear_overlaps < clear * 4 / 5);

    int borderline = 0, seed_errors = 0, fast_errors = 0, seed_false_hits = 0, fast_false_hits = 0;
    for (int n = 0; n < 20000; n++) {
        vec3 tri[3];
        box3 box;
        near_degenerate_case(&r, tri, &box);
        int expected = reference_tri_box(tri, box);
        borderline++;
        int seed = tri_box_overlap_seed(tri, box, SEED_EPS);
        int fast = tri_box_overlap_fast(tri, box);
        seed_errors += seed != expected;
        fast_errors += fast != expected;
        seed_false_hits += seed && !expected;
        fast_false_hits += fast && !expected;
    }
    printf("near-degenerate cases: %d; seed (eps %g) wrong on %d (%d false hits, %d misses), "
           "fast wrong on %d (%d false hits, %d misses)\n",
           borderline, SEED_EPS, seed_errors, seed_false_hits, seed_errors - seed_false_hits,
           fast_errors, fast_false_hits, fast_errors - fast_false_hits);
}

/* The seed mode must not turn a zero-area or repeated-vertex triangle into a hit on every
 * box (its unit normal would be 0/0) nor produce NaN from it. */
static void test_seed_mode_zero_area_triangles(void **state)
{
    (void)state;
    vec3 far_segment[3] = {v3(3, 3, 3), v3(4, 5, 6), v3(5, 7, 9)};
    vec3 far_point[3] = {v3(3, 3, 3), v3(3, 3, 3), v3(3, 3, 3)};
    vec3 through[3] = {v3(-1, 0.5, 0.5), v3(2, 0.5, 0.5), v3(3, 0.5, 0.5)};
    assert_int_equal(tri_box_overlap_seed(far_segment, unit_box, SEED_EPS), 0);
    assert_int_equal(tri_box_overlap_seed(far_point, unit_box, SEED_EPS), 0);
    assert_int_equal(tri_box_overlap_seed(through, unit_box, SEED_EPS), 1);
    assert_int_equal(tri_box_overlap_seed(far_segment, unit_box, 0.0), 0);
    assert_int_equal(tri_box_overlap_seed(through, unit_box, 0.0), 1);
    assert_int_equal(tri_box_overlap_fast(far_segment, unit_box), 0);
    assert_int_equal(tri_box_overlap_fast(through, unit_box), 1);
}

/* The seed mode answers with its epsilon: within eps of the box is a hit, and with eps = 0
 * the strict d_i < 0 of step 1 leaves a vertex on a face to the later steps. */
static void test_seed_mode_follows_its_epsilon(void **state)
{
    (void)state;
    double eps = 1e-6;
    vec3 just_above[3] = {v3(0.5, 0.5, 1 + eps / 2), v3(0.5, 0.5, 1 + eps / 2),
                          v3(0.5, 0.5, 1 + eps / 2)};
    vec3 above[3] = {v3(0.5, 0.5, 1 + 2 * eps), v3(0.5, 0.5, 1 + 2 * eps),
                     v3(0.5, 0.5, 1 + 2 * eps)};
    assert_int_equal(tri_box_overlap_seed(just_above, unit_box, eps), 1);
    assert_int_equal(tri_box_overlap_exact(just_above, unit_box), 0);
    assert_int_equal(tri_box_overlap_seed(above, unit_box, eps), 0);
    /* An edge passing eps/2 above the top face: step 3's point-in-quadrilateral. */
    vec3 edge_above[3] = {v3(-1, 0.5, 1 + eps / 2), v3(2, 0.5, 1 + eps / 2), v3(0.5, 0.5, 3)};
    assert_int_equal(tri_box_overlap_seed(edge_above, unit_box, eps), 1);
    assert_int_equal(tri_box_overlap_exact(edge_above, unit_box), 0);
    /* A plane eps/2 beyond the corner (1, 1, 1): step 2's point-in-triangle. */
    double o = 3 + 1.5 * eps; /* x + y + z = 3 + 1.5 eps: distance eps * sqrt(3) / 2 */
    vec3 plane_beyond[3] = {v3(o, 0, 0), v3(0, o, 0), v3(0, 0, o)};
    assert_int_equal(tri_box_overlap_seed(plane_beyond, unit_box, eps), 1);
    assert_int_equal(tri_box_overlap_exact(plane_beyond, unit_box), 0);
    /* eps = 0 makes every comparison strict (d_i < 0, s > 0, ... < 0): a triangle touching
     * the box with one vertex is then missed by all three steps. */
    vec3 on_face[3] = {v3(0.5, 0.5, 1), v3(0, 0, 2), v3(1, 0, 2)};
    assert_int_equal(tri_box_overlap_seed(on_face, unit_box, 0.0), 0);
    assert_int_equal(tri_box_overlap_seed(on_face, unit_box, eps), 1);
    assert_int_equal(tri_box_overlap_exact(on_face, unit_box), 1);
    /* With eps = 0 a crossing edge is still found by step 3. */
    vec3 crossing[3] = {v3(-1, 0.5, 0.5), v3(2, 0.4, 0.5), v3(2, 0.6, 0.5)};
    assert_int_equal(tri_box_overlap_seed(crossing, unit_box, 0.0), 1);
}

static int group_setup(void **state)
{
    test_config *config = malloc(sizeof *config);
    if (!config)
        return -1;
    config->seed = 20240611;
    const char *env = getenv("TRIOCT_SEED");
    if (env && *env)
        config->seed = strtoull(env, NULL, 0);
    printf("test_tri_box seed %llu (rerun with TRIOCT_SEED=%llu)\n",
           (unsigned long long)config->seed, (unsigned long long)config->seed);
    *state = config;
    return 0;
}

static int group_teardown(void **state)
{
    free(*state);
    return 0;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_box_face_geometry_equals_seed_formulas),
        cmocka_unit_test(test_box_octants_equal_seed_table_and_share_faces),
        cmocka_unit_test(test_octants_reached_are_the_children_a_region_meets),
        cmocka_unit_test(test_octants_holding_are_the_children_holding_a_point),
        cmocka_unit_test(test_exact_triangle_inside_box),
        cmocka_unit_test(test_exact_large_triangle_cutting_through_box),
        cmocka_unit_test(test_exact_touching_face_edge_corner_from_outside),
        cmocka_unit_test(test_exact_one_ulp_separation),
        cmocka_unit_test(test_exact_triangle_in_face_plane),
        cmocka_unit_test(test_exact_zero_area_triangles),
        cmocka_unit_test(test_exact_triangle_crossing_only_a_box_edge),
        cmocka_unit_test(test_exact_huge_offsets),
        cmocka_unit_test(test_exact_tiny_triangles),
        cmocka_unit_test(test_exact_at_the_ends_of_the_double_range),
        cmocka_unit_test(test_exact_equals_reference_at_the_ends_of_the_double_range),
        cmocka_unit_test(test_exact_equals_reference_on_near_degenerate_cases),
        cmocka_unit_test(test_exact_equals_reference_on_uniform_cases),
        cmocka_unit_test(test_prepared_triangle_against_a_node_and_its_children),
        cmocka_unit_test(test_children_at_crossings_are_touched),
        cmocka_unit_test(test_children_touched_equals_reference),
        cmocka_unit_test(test_seed_and_fast_agree_with_reference_on_clear_cases),
        cmocka_unit_test(test_seed_mode_zero_area_triangles),
        cmocka_unit_test(test_seed_mode_follows_its_epsilon),
    };
    return cmocka_run_group_tests_name("tri_box", tests, group_setup, group_teardown);
}
