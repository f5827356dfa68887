/* Tests of triangle-triangle overlap: the exact test against an exact rational reference
 * (hand-made boundary cases under exact symmetries, random and snapped random pairs), the
 * contact segment, and the seed and fast modes on clear cases. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <float.h>
#include <gmp.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geom/predicates.h"
#include "geom/tri_tri.h"
#include "support/oracle.h"

/* ------------------------------------------------------------------------------------
 * Reference: closed triangles meet iff convex weights l (of a) and m (of b) exist with
 * sum l_i a_i = sum m_j b_j. The feasible set {x >= 0 : M x = e}, with columns (a_i, 1, 0)
 * and (-b_j, 0, 1) and e = (0, 0, 0, 1, 1), if nonempty has a basic solution: one whose
 * support columns are linearly independent. So enumerate column subsets, solve each
 * exactly, and look for a nonnegative solution. The coordinates are made integers by one
 * common power of two (rows 0-2 have a zero right-hand side, so scaling them keeps the
 * solutions), and elimination is fraction-free (Bareiss).
 * ------------------------------------------------------------------------------------ */

typedef struct reference_lp {
    mpz_t column[6][5];
    mpz_t work[5][7];
    mpz_t scratch;
    mpq_t x[5], term;
} reference_lp;

static void reference_init(reference_lp *lp, const vec3 a[3], const vec3 b[3])
{
    mpq_t coord[18];
    mpz_t common, factor;
    mpz_init_set_ui(common, 1);
    mpz_init(factor);
    for (int k = 0; k < 18; k++) {
        const vec3 *v = k < 9 ? &a[k / 3] : &b[(k - 9) / 3];
        mpq_init(coord[k]);
        mpq_set_d(coord[k], vec3_get(*v, k % 3));
        if (mpz_cmp(mpq_denref(coord[k]), common) > 0) /* denominators are powers of two */
            mpz_set(common, mpq_denref(coord[k]));
    }
    for (int c = 0; c < 6; c++) {
        for (int r = 0; r < 5; r++)
            mpz_init(lp->column[c][r]);
        for (int r = 0; r < 3; r++) {
            int k = c < 3 ? c * 3 + r : 9 + (c - 3) * 3 + r;
            mpz_divexact(factor, common, mpq_denref(coord[k]));
            mpz_mul(lp->column[c][r], mpq_numref(coord[k]), factor);
            if (c >= 3)
                mpz_neg(lp->column[c][r], lp->column[c][r]);
        }
        mpz_set_ui(lp->column[c][c < 3 ? 3 : 4], 1);
    }
    for (int r = 0; r < 5; r++)
        for (int c = 0; c < 7; c++)
            mpz_init(lp->work[r][c]);
    mpz_init(lp->scratch);
    for (int i = 0; i < 5; i++)
        mpq_init(lp->x[i]);
    mpq_init(lp->term);
    for (int k = 0; k < 18; k++)
        mpq_clear(coord[k]);
    mpz_clear(common);
    mpz_clear(factor);
}

static void reference_clear(reference_lp *lp)
{
    for (int c = 0; c < 6; c++)
        for (int r = 0; r < 5; r++)
            mpz_clear(lp->column[c][r]);
    for (int r = 0; r < 5; r++)
        for (int c = 0; c < 7; c++)
            mpz_clear(lp->work[r][c]);
    mpz_clear(lp->scratch);
    for (int i = 0; i < 5; i++)
        mpq_clear(lp->x[i]);
    mpq_clear(lp->term);
}

/* 1 when the columns in `cols` are independent and M_S x = e has a solution x >= 0. */
static int reference_subset_feasible(reference_lp *lp, const int *cols, int k)
{
    for (int r = 0; r < 5; r++) {
        for (int c = 0; c < k; c++)
            mpz_set(lp->work[r][c], lp->column[cols[c]][r]);
        mpz_set_ui(lp->work[r][k], r >= 3 ? 1 : 0);
    }
    mpz_t prev;
    mpz_init_set_ui(prev, 1);
    int independent = 1;
    for (int c = 0; c < k && independent; c++) {
        int pivot = c;
        while (pivot < 5 && mpz_sgn(lp->work[pivot][c]) == 0)
            pivot++;
        if (pivot == 5) {
            independent = 0;
            break;
        }
        if (pivot != c)
            for (int j = 0; j <= k; j++)
                mpz_swap(lp->work[pivot][j], lp->work[c][j]);
        for (int i = c + 1; i < 5; i++) {
            for (int j = c + 1; j <= k; j++) {
                mpz_mul(lp->scratch, lp->work[c][c], lp->work[i][j]);
                mpz_submul(lp->scratch, lp->work[i][c], lp->work[c][j]);
                mpz_divexact(lp->work[i][j], lp->scratch, prev);
            }
            mpz_set_ui(lp->work[i][c], 0);
        }
        mpz_set(prev, lp->work[c][c]);
    }
    mpz_clear(prev);
    if (!independent)
        return 0;
    for (int r = k; r < 5; r++)
        if (mpz_sgn(lp->work[r][k]) != 0)
            return 0; /* inconsistent */
    for (int c = k - 1; c >= 0; c--) {
        mpq_set_z(lp->x[c], lp->work[c][k]);
        for (int j = c + 1; j < k; j++) {
            mpq_set_z(lp->term, lp->work[c][j]);
            mpq_mul(lp->term, lp->term, lp->x[j]);
            mpq_sub(lp->x[c], lp->x[c], lp->term);
        }
        mpq_set_z(lp->term, lp->work[c][c]);
        mpq_div(lp->x[c], lp->x[c], lp->term);
        if (mpq_sgn(lp->x[c]) < 0)
            return 0;
    }
    return 1;
}

static int reference_tri_tri(const vec3 a[3], const vec3 b[3])
{
    reference_lp lp;
    reference_init(&lp, a, b);
    int found = 0;
    for (int mask = 1; mask < 64 && !found; mask++) {
        /* Both weight sums are 1, so a support needs a column of each triangle. */
        if ((mask & 7) == 0 || (mask & 56) == 0 || __builtin_popcount(mask) > 5)
            continue;
        int cols[6], k = 0;
        for (int c = 0; c < 6; c++)
            if (mask & (1 << c))
                cols[k++] = c;
        found = reference_subset_feasible(&lp, cols, k);
    }
    reference_clear(&lp);
    return found;
}

/* ------------------------------------------------------------------------------------
 * Random numbers (splitmix64) with a printed, overridable seed.
 * ------------------------------------------------------------------------------------ */

typedef struct rng {
    uint64_t state;
} rng;

static uint64_t rng_next(rng *r)
{
    uint64_t z = (r->state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

static double rng_unit(rng *r) { return (double)(rng_next(r) >> 11) * 0x1p-53; }
static double rng_range(rng *r, double lo, double hi) { return lo + (hi - lo) * rng_unit(r); }
static int rng_int(rng *r, int lo, int hi) { return lo + (int)(rng_next(r) % (uint64_t)(hi - lo + 1)); }

static rng rng_for_test(const char *test_name, uint64_t salt)
{
    const char *env = getenv("TRIOCT_SEED");
    uint64_t seed = env ? strtoull(env, NULL, 0) : 20150117ULL;
    printf("[ seed     ] %s: TRIOCT_SEED=%llu\n", test_name, (unsigned long long)seed);
    rng r = {seed * 0x2545f4914f6cdd1dULL + salt};
    return r;
}

/* ------------------------------------------------------------------------------------
 * Helpers.
 * ------------------------------------------------------------------------------------ */

static vec3 v3(double x, double y, double z) { return vec3_make(x, y, z); }

static void set_tri(vec3 t[3], vec3 p, vec3 q, vec3 r)
{
    t[0] = p;
    t[1] = q;
    t[2] = r;
}

/* a + b exactly representable (error-free sum has zero error term). */
static int sum_is_exact(double a, double b)
{
    double s = a + b;
    double bb = s - a;
    return isfinite(s) && (a - (s - bb)) + (b - bb) == 0.0;
}

static int scale_is_exact(double x, int exponent)
{
    double y = ldexp(x, exponent);
    return isfinite(y) && ldexp(y, -exponent) == x && (y == 0.0 || fabs(y) >= DBL_MIN);
}

static const int permutations3[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                         {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};

/* An exact affine map: axis permutation, reflections, power-of-two scale, offset. */
typedef struct exact_transform {
    int perm;        /* index into permutations3 */
    int reflect;     /* bit i: negate output axis i */
    int scale_exp;
    vec3 offset;
} exact_transform;

/* 0 when some coordinate would not be mapped exactly (then the case is skipped). */
static int transform_point(const exact_transform *tf, vec3 in, vec3 *out)
{
    double c[3];
    for (int i = 0; i < 3; i++) {
        double x = vec3_get(in, permutations3[tf->perm][i]);
        if (tf->reflect & (1 << i))
            x = -x;
        if (!scale_is_exact(x, tf->scale_exp))
            return 0;
        x = ldexp(x, tf->scale_exp);
        double o = vec3_get(tf->offset, i);
        if (!sum_is_exact(x, o))
            return 0;
        c[i] = x + o;
    }
    *out = v3(c[0], c[1], c[2]);
    return 1;
}

static int transform_tri(const exact_transform *tf, const vec3 in[3], vec3 out[3])
{
    for (int i = 0; i < 3; i++)
        if (!transform_point(tf, in[i], &out[i]))
            return 0;
    return 1;
}

static void permute_tri(const vec3 in[3], int perm, vec3 out[3])
{
    for (int i = 0; i < 3; i++)
        out[i] = in[permutations3[perm][i]];
}

static double max_abs_coord(const vec3 a[3], const vec3 b[3])
{
    double m = 0.0;
    for (int i = 0; i < 3; i++) {
        m = fmax(m, fmax(fabs(a[i].x), fmax(fabs(a[i].y), fabs(a[i].z))));
        m = fmax(m, fmax(fabs(b[i].x), fmax(fabs(b[i].y), fabs(b[i].z))));
    }
    return m;
}

/* ------------------------------------------------------------------------------------
 * Hand-made cases with exact answers.
 * ------------------------------------------------------------------------------------ */

typedef struct hand_case {
    const char *name;
    const char *variant;
    vec3 a[3], b[3];
    int expected;
} hand_case;

enum { MAX_HAND_CASES = 256 };

typedef struct hand_list {
    hand_case item[MAX_HAND_CASES];
    int count;
} hand_list;

static void hand_add(hand_list *list, const char *name, vec3 a0, vec3 a1, vec3 a2, vec3 b0,
                     vec3 b1, vec3 b2, int expected)
{
    assert_true(list->count < MAX_HAND_CASES);
    hand_case *c = &list->item[list->count++];
    c->name = name;
    c->variant = "as built";
    set_tri(c->a, a0, a1, a2);
    set_tri(c->b, b0, b1, b2);
    c->expected = expected;
}

static void build_base_cases(hand_list *list)
{
    const double up = nextafter(1.0, 2.0), down = nextafter(1.0, 0.0);
    const double tiny = 0x1p-40;
    /* The reference triangle a lies in z = 1 (or z = 0) with legs of length 4. */
    vec3 A0 = v3(0, 0, 1), A1 = v3(4, 0, 1), A2 = v3(0, 4, 1);

    hand_add(list, "crossing", v3(0, 0, 0), v3(4, 0, 0), v3(0, 4, 0), v3(1, 1, -1),
             v3(3, 1, 1), v3(1, 3, 1), 1);
    hand_add(list, "separated", A0, A1, A2, v3(10, 1, 0), v3(11, 1, 2), v3(10, 2, 2), 0);
    hand_add(list, "piercing outside footprint", A0, A1, A2, v3(3, 3, 0), v3(4, 3, 2),
             v3(3, 4, 2), 0);

    hand_add(list, "touching at a vertex", A0, A1, A2, v3(4, 0, 1), v3(5, 0, 2), v3(5, 1, 2), 1);
    hand_add(list, "vertex touch missed by one ulp", A0, A1, A2, v3(nextafter(4, 5), 0, 1),
             v3(5, 0, 2), v3(5, 1, 2), 0);

    hand_add(list, "touching along part of an edge", v3(0, 1, 1), v3(4, 1, 1), v3(0, 5, 1),
             v3(1, 1, 1), v3(3, 1, 1), v3(2, 0, 2), 1);
    hand_add(list, "edge touch missed by one ulp", v3(0, 1, 1), v3(4, 1, 1), v3(0, 5, 1),
             v3(1, down, 1), v3(3, down, 1), v3(2, 0, 2), 0);

    hand_add(list, "vertex on face", A0, A1, A2, v3(1, 1, 1), v3(2, 1, 2), v3(1, 2, 2), 1);
    hand_add(list, "vertex above face by one ulp", A0, A1, A2, v3(1, 1, up), v3(2, 1, 2),
             v3(1, 2, 2), 0);

    hand_add(list, "edge crossing edge exactly", A0, A1, A2, v3(1, -1, 2), v3(1, 1, 0),
             v3(1, -3, 0), 1);
    hand_add(list, "edge passing an edge one ulp outside", A0, A1, A2, v3(1, -1, 2),
             v3(1, down, 0), v3(1, -3, 0), 0);
    hand_add(list, "edge passing an edge one ulp inside", A0, A1, A2, v3(1, -1, 2),
             v3(1, up, 0), v3(1, -3, 0), 1);

    hand_add(list, "coplanar overlapping", A0, A1, A2, v3(1, 1, 1), v3(5, 1, 1), v3(1, 5, 1), 1);
    hand_add(list, "coplanar contained", A0, A1, A2, v3(1, 1, 1), v3(2, 1, 1), v3(1, 2, 1), 1);
    hand_add(list, "coplanar star (no vertex inside)", v3(0, 0, 1), v3(6, 0, 1), v3(3, 6, 1),
             v3(0, 4, 1), v3(6, 4, 1), v3(3, -2, 1), 1);
    hand_add(list, "coplanar touching along an edge", v3(0, 1, 1), v3(4, 1, 1), v3(0, 5, 1),
             v3(1, 1, 1), v3(3, 1, 1), v3(2, -1, 1), 1);
    hand_add(list, "coplanar separated by one ulp", v3(0, 1, 1), v3(4, 1, 1), v3(0, 5, 1),
             v3(1, down, 1), v3(3, down, 1), v3(2, -1, 1), 0);
    hand_add(list, "coplanar touching at a vertex", v3(0, 1, 1), v3(4, 1, 1), v3(0, 5, 1),
             v3(4, 1, 1), v3(6, 0, 1), v3(6, 2, 1), 1);
    hand_add(list, "coplanar vertex touch missed by one ulp", v3(0, 1, 1), v3(4, 1, 1),
             v3(0, 5, 1), v3(nextafter(4, 5), 1, 1), v3(6, 0, 1), v3(6, 2, 1), 0);
    hand_add(list, "coplanar vertex on edge", v3(0, 1, 1), v3(4, 1, 1), v3(0, 5, 1),
             v3(2, 1, 1), v3(3, 0, 1), v3(1, 0, 1), 1);

    hand_add(list, "shared edge, hinge", v3(0, 0, 0), v3(4, 0, 0), v3(0, 4, 0), v3(0, 0, 0),
             v3(4, 0, 0), v3(2, -1, 3), 1);
    hand_add(list, "shared edge, coplanar", v3(0, 0, 0), v3(4, 0, 0), v3(0, 4, 0), v3(4, 0, 0),
             v3(0, 0, 0), v3(2, -3, 0), 1);
    hand_add(list, "shared vertex", v3(0, 0, 0), v3(4, 0, 0), v3(0, 4, 0), v3(0, 0, 0),
             v3(-1, -2, 3), v3(-2, -1, 1), 1);

    hand_add(list, "identical", A0, A1, A2, A0, A1, A2, 1);
    hand_add(list, "parallel planes one ulp apart", A0, A1, A2, v3(0, 0, up), v3(4, 0, up),
             v3(0, 4, up), 0);

    hand_add(list, "nearly coplanar, crossing", A0, A1, A2, v3(1, 1, 1 + tiny),
             v3(3, 1, 1 - tiny), v3(1, 3, 1 + tiny), 1);
    hand_add(list, "nearly coplanar, above", A0, A1, A2, v3(1, 1, 1 + tiny),
             v3(3, 1, 1 + tiny / 2), v3(1, 3, 1 + tiny), 0);
    hand_add(list, "nearly coplanar, outside footprint", A0, A1, A2, v3(5, 5, 1 + tiny),
             v3(7, 5, 1 - tiny), v3(5, 7, 1), 0);

    hand_add(list, "sliver pierced by a needle", v3(0, 0, 1), v3(8, 0, 1), v3(4, 0x1p-40, 1),
             v3(4, 0x1p-42, 0), v3(4, 0x1p-42, 2), v3(4 + 0x1p-50, 0x1p-42, 2), 1);
    hand_add(list, "needle passing above a sliver's apex", v3(0, 0, 1), v3(8, 0, 1),
             v3(4, 0x1p-40, 1), v3(4, 0x1p-39, 0), v3(4, 0x1p-39, 2),
             v3(4 + 0x1p-50, 0x1p-39, 2), 0);

    /* Zero-area triangles against normal ones. */
    hand_add(list, "collinear segment with middle vertex on face", A0, A1, A2, v3(1, 1, 0),
             v3(1, 1, 2), v3(1, 1, 1), 1);
    hand_add(list, "collinear segment above face", A0, A1, A2, v3(1, 1, 2), v3(1, 1, 3),
             v3(1, 1, 2.5), 0);
    hand_add(list, "collinear segment in plane across face", A0, A1, A2, v3(-1, 1, 1),
             v3(5, 1, 1), v3(2, 1, 1), 1);
    hand_add(list, "collinear segment in plane beside face", A0, A1, A2, v3(-1, -1, 1),
             v3(5, -1, 1), v3(2, -1, 1), 0);
    hand_add(list, "repeated vertex segment crossing face", A0, A1, A2, v3(1, 1, 0),
             v3(1, 1, 0), v3(2, 2, 2), 1);
    hand_add(list, "repeated vertex segment missing face", A0, A1, A2, v3(3, 3, 0),
             v3(3, 3, 0), v3(4, 4, 2), 0);
    hand_add(list, "point inside face", A0, A1, A2, v3(1, 1, 1), v3(1, 1, 1), v3(1, 1, 1), 1);
    hand_add(list, "point one ulp above face", A0, A1, A2, v3(1, 1, up), v3(1, 1, up),
             v3(1, 1, up), 0);
    hand_add(list, "point on edge", A0, A1, A2, v3(2, 0, 1), v3(2, 0, 1), v3(2, 0, 1), 1);
    hand_add(list, "point at vertex", A0, A1, A2, v3(0, 4, 1), v3(0, 4, 1), v3(0, 4, 1), 1);
    hand_add(list, "point just off hypotenuse", A0, A1, A2, v3(2, nextafter(2, 3), 1),
             v3(2, nextafter(2, 3), 1), v3(2, nextafter(2, 3), 1), 0);

    /* Zero-area triangles against each other. */
    hand_add(list, "segments crossing", v3(0, 0, 0), v3(2, 2, 0), v3(1, 1, 0), v3(0, 2, 0),
             v3(2, 0, 0), v3(0, 2, 0), 1);
    hand_add(list, "segments skew", v3(0, 0, 0), v3(2, 2, 0), v3(1, 1, 0), v3(0, 2, 1),
             v3(2, 0, 1), v3(0, 2, 1), 0);
    hand_add(list, "coplanar segments missing", v3(0, 0, 0), v3(2, 2, 0), v3(1, 1, 0),
             v3(0, 2, 0), v3(0.5, 1.5, 0), v3(0, 2, 0), 0);
    hand_add(list, "collinear segments overlapping", v3(0, 0, 0), v3(2, 0, 0), v3(1, 0, 0),
             v3(1, 0, 0), v3(3, 0, 0), v3(3, 0, 0), 1);
    hand_add(list, "collinear segments touching at an end", v3(0, 0, 0), v3(2, 0, 0),
             v3(1, 0, 0), v3(2, 0, 0), v3(3, 0, 0), v3(3, 0, 0), 1);
    hand_add(list, "collinear segments one ulp apart", v3(0, 0, 0), v3(2, 0, 0), v3(1, 0, 0),
             v3(nextafter(2, 3), 0, 0), v3(3, 0, 0), v3(3, 0, 0), 0);
    hand_add(list, "point on segment", v3(0, 0, 0), v3(2, 2, 2), v3(2, 2, 2), v3(1, 1, 1),
             v3(1, 1, 1), v3(1, 1, 1), 1);
    hand_add(list, "point one ulp off segment", v3(0, 0, 0), v3(2, 2, 2), v3(2, 2, 2),
             v3(1, 1, up), v3(1, 1, up), v3(1, 1, up), 0);
    hand_add(list, "point beyond segment end", v3(0, 0, 0), v3(2, 2, 2), v3(2, 2, 2),
             v3(3, 3, 3), v3(3, 3, 3), v3(3, 3, 3), 0);
    hand_add(list, "equal points", v3(1, 2, 3), v3(1, 2, 3), v3(1, 2, 3), v3(1, 2, 3),
             v3(1, 2, 3), v3(1, 2, 3), 1);
    hand_add(list, "different points", v3(1, 2, 3), v3(1, 2, 3), v3(1, 2, 3), v3(1, 2, up * 3),
             v3(1, 2, up * 3), v3(1, 2, up * 3), 0);

    /* Large offsets with small triangles. */
    const double big = 1e9, mid = 1e6;
    hand_add(list, "crossing at 1e9", v3(big, big, big), v3(big + 1, big, big),
             v3(big, big + 1, big), v3(big + 0.25, big + 0.25, big - 0.5),
             v3(big + 0.75, big + 0.25, big + 0.5), v3(big + 0.25, big + 0.75, big + 0.5), 1);
    hand_add(list, "vertex touch at 1e9", v3(big, big, big), v3(big + 1, big, big),
             v3(big, big + 1, big), v3(big + 1, big, big), v3(big + 2, big, big + 1),
             v3(big + 2, big + 1, big + 1), 1);
    hand_add(list, "vertex touch at 1e9 missed by one ulp", v3(big, big, big),
             v3(big + 1, big, big), v3(big, big + 1, big),
             v3(nextafter(big + 1, 2 * big), big, big), v3(big + 2, big, big + 1),
             v3(big + 2, big + 1, big + 1), 0);
    hand_add(list, "parallel planes one ulp apart at 1e9", v3(big, big, big),
             v3(big + 1, big, big), v3(big, big + 1, big),
             v3(big, big, nextafter(big, 2 * big)), v3(big + 1, big, nextafter(big, 2 * big)),
             v3(big, big + 1, nextafter(big, 2 * big)), 0);
    hand_add(list, "edge crossing edge at 1e6", v3(mid, mid, mid), v3(mid + 4, mid, mid),
             v3(mid, mid + 4, mid), v3(mid + 1, mid - 1, mid + 1), v3(mid + 1, mid + 1, mid - 1),
             v3(mid + 1, mid - 3, mid - 1), 1);
    hand_add(list, "edge passing an edge one ulp outside at 1e6", v3(mid, mid, mid),
             v3(mid + 4, mid, mid), v3(mid, mid + 4, mid), v3(mid + 1, mid - 1, mid + 1),
             v3(mid + 1, nextafter(mid + 1, 0), mid - 1), v3(mid + 1, mid - 3, mid - 1), 0);
}

/* Every base case again at size ~1e-9 and, where exact, shrunk and moved to 1e9. */
static void build_hand_cases(hand_list *list)
{
    list->count = 0;
    build_base_cases(list);
    int base_count = list->count;
    exact_transform to_tiny = {0, 0, -30, {0, 0, 0}};
    exact_transform to_far = {0, 0, -4, {1e9, -1e9, 1e9}};
    for (int i = 0; i < base_count; i++) {
        const hand_case *base = &list->item[i];
        hand_case moved = *base;
        if (transform_tri(&to_tiny, base->a, moved.a) && transform_tri(&to_tiny, base->b, moved.b)) {
            moved.variant = "scaled by 2^-30";
            assert_true(list->count < MAX_HAND_CASES);
            list->item[list->count++] = moved;
        }
        moved = *base;
        if (transform_tri(&to_far, base->a, moved.a) && transform_tri(&to_far, base->b, moved.b)) {
            moved.variant = "scaled by 2^-4, offset to 1e9";
            assert_true(list->count < MAX_HAND_CASES);
            list->item[list->count++] = moved;
        }
    }
}

static void check_case(const hand_case *c, const vec3 a[3], const vec3 b[3], const char *how)
{
    int got = tri_tri_overlap_exact(a, b);
    if (got != c->expected)
        fail_msg("case '%s' (%s, %s): exact says %d, expected %d", c->name, c->variant, how, got,
                 c->expected);
}

static void test_hand_cases_match_expected_and_reference(void **state)
{
    (void)state;
    hand_list *list = malloc(sizeof *list);
    assert_non_null(list);
    build_hand_cases(list);
    assert_true(list->count > 100);
    for (int i = 0; i < list->count; i++) {
        const hand_case *c = &list->item[i];
        int ref = reference_tri_tri(c->a, c->b);
        if (ref != c->expected)
            fail_msg("reference disagrees with hand answer on '%s' (%s): %d", c->name, c->variant,
                     ref);
        check_case(c, c->a, c->b, "as given");
        check_case(c, c->b, c->a, "swapped");
    }
    printf("[ info     ] %d hand-made cases (with size and offset variants)\n", list->count);
    free(list);
}

static void test_hand_cases_invariant_under_exact_symmetries(void **state)
{
    (void)state;
    hand_list *list = malloc(sizeof *list);
    assert_non_null(list);
    build_hand_cases(list);
    long checked = 0, skipped = 0;
    for (int i = 0; i < list->count; i++) {
        const hand_case *c = &list->item[i];
        vec3 a[3], b[3], ta[3], tb[3];
        /* Every vertex order of both triangles, both argument orders. */
        for (int order = 0; order < 72; order++) {
            permute_tri(c->a, order % 6, a);
            permute_tri(c->b, (order / 6) % 6, b);
            if (order >= 36)
                check_case(c, b, a, "vertex orders permuted, swapped");
            else
                check_case(c, a, b, "vertex orders permuted");
            checked++;
        }
        /* Axis permutations and reflections, each with a few vertex orders. */
        for (int axes = 0; axes < 48; axes++) {
            exact_transform tf = {axes % 6, axes / 6, 0, {0, 0, 0}};
            for (int order = axes % 12; order < 72; order += 12) {
                permute_tri(c->a, order % 6, a);
                permute_tri(c->b, (order / 6) % 6, b);
                if (!transform_tri(&tf, a, ta) || !transform_tri(&tf, b, tb)) {
                    skipped++;
                    continue;
                }
                check_case(c, (order & 1) ? tb : ta, (order & 1) ? ta : tb,
                           "axes permuted and reflected");
                checked++;
            }
        }
        /* Power-of-two scales and exactly representable offsets. */
        static const int scales[] = {0, -3, 7, -50};
        const vec3 offsets[] = {v3(0, 0, 0), v3(1024, -2048, 512), v3(0.5, 0.25, -0.125),
                                v3(3 * 1048576.0, -1048576.0, 0), v3(-1e6, 1e6, 1e6)};
        for (int s = 0; s < 4; s++)
            for (int o = 0; o < 5; o++) {
                exact_transform tf = {(s + o) % 6, (s * 5 + o) % 8, scales[s], offsets[o]};
                if (!transform_tri(&tf, c->a, ta) || !transform_tri(&tf, c->b, tb)) {
                    skipped++;
                    continue;
                }
                check_case(c, ta, tb, "scaled and offset");
                check_case(c, tb, ta, "scaled and offset, swapped");
                checked++;
            }
    }
    printf("[ info     ] %ld transformed hand cases checked, %ld inexact transforms skipped\n",
           checked, skipped);
    assert_true(checked > 50000);
    free(list);
}

/* ------------------------------------------------------------------------------------
 * Random cases against the reference.
 * ------------------------------------------------------------------------------------ */

static vec3 random_point(rng *r, double lo, double hi)
{
    return v3(rng_range(r, lo, hi), rng_range(r, lo, hi), rng_range(r, lo, hi));
}

static vec3 random_grid_point(rng *r, int lo, int hi)
{
    return v3(rng_int(r, lo, hi), rng_int(r, lo, hi), rng_int(r, lo, hi));
}

/* A point related to triangle a by an exact construction: a vertex, an edge midpoint, a
 * point of its plane, a point of an edge's line, or a free grid point. a has even integer
 * coordinates, so halves stay integers. */
static vec3 snapped_point(rng *r, const vec3 a[3])
{
    int i = rng_int(r, 0, 2), j = (i + rng_int(r, 1, 2)) % 3;
    switch (rng_int(r, 0, 5)) {
    case 0:
        return a[i];
    case 1:
        return vec3_scale(vec3_add(a[i], a[j]), 0.5);
    case 2: {
        int k = 3 - i - j;
        double s = rng_int(r, -2, 4) * 0.5, t = rng_int(r, -2, 4) * 0.5;
        return vec3_add(a[k], vec3_add(vec3_scale(vec3_sub(a[i], a[k]), s),
                                       vec3_scale(vec3_sub(a[j], a[k]), t)));
    }
    case 3: {
        double s = rng_int(r, -2, 4) * 0.5;
        return vec3_add(a[i], vec3_scale(vec3_sub(a[j], a[i]), s));
    }
    default:
        return vec3_scale(random_grid_point(r, -3, 3), 2.0);
    }
}

static void random_snapped_pair(rng *r, vec3 a[3], vec3 b[3])
{
    for (int i = 0; i < 3; i++)
        a[i] = vec3_scale(random_grid_point(r, -3, 3), 2.0);
    for (int i = 0; i < 3; i++)
        b[i] = snapped_point(r, a);
    if (rng_int(r, 0, 2) == 0) {
        /* A small exact step away: parallel near misses and partial overlaps. */
        vec3 step = v3(rng_int(r, -1, 1), rng_int(r, -1, 1), rng_int(r, -1, 1));
        for (int i = 0; i < 3; i++)
            b[i] = vec3_add(b[i], step);
    }
    /* Move the whole pair somewhere else exactly, sometimes far away. */
    static const double offsets[] = {0.0, 1e6, -1e9, 0.375};
    exact_transform tf = {rng_int(r, 0, 5), rng_int(r, 0, 7), rng_int(r, -40, 10),
                          {offsets[rng_int(r, 0, 3)], offsets[rng_int(r, 0, 3)], 0.0}};
    vec3 ta[3], tb[3];
    if (transform_tri(&tf, a, ta) && transform_tri(&tf, b, tb)) {
        memcpy(a, ta, sizeof ta);
        memcpy(b, tb, sizeof tb);
    }
}

/* A triangle of zero area: collinear, with a repeated vertex, or a single point. */
static void random_degenerate_tri(rng *r, vec3 t[3])
{
    vec3 p = vec3_scale(random_grid_point(r, -3, 3), 2.0);
    vec3 q = vec3_scale(random_grid_point(r, -3, 3), 2.0);
    static const double along[] = {0.0, 0.5, 1.0, 2.0, -1.0};
    switch (rng_int(r, 0, 2)) {
    case 0:
        set_tri(t, p, q, vec3_add(p, vec3_scale(vec3_sub(q, p), along[rng_int(r, 0, 4)])));
        break;
    case 1:
        set_tri(t, p, p, q);
        break;
    default:
        set_tri(t, p, p, p);
        break;
    }
    vec3 shuffled[3];
    permute_tri(t, rng_int(r, 0, 5), shuffled);
    memcpy(t, shuffled, sizeof shuffled);
}

static void nudge_one_coordinate(rng *r, vec3 t[3])
{
    int v = rng_int(r, 0, 2), axis = rng_int(r, 0, 2), steps = rng_int(r, 1, 2);
    double c[3] = {t[v].x, t[v].y, t[v].z};
    double toward = rng_int(r, 0, 1) ? INFINITY : -INFINITY;
    for (int s = 0; s < steps; s++)
        c[axis] = nextafter(c[axis], toward);
    if (c[axis] != 0.0 && fabs(c[axis]) < DBL_MIN)
        c[axis] = 0.0; /* keep clear of subnormals, where predicates may underflow */
    t[v] = v3(c[0], c[1], c[2]);
}

typedef struct agreement {
    long cases, hits;
} agreement;

static void expect_exact_equals_reference(const vec3 a[3], const vec3 b[3], agreement *tally,
                                          const char *what, long index)
{
    int ref = reference_tri_tri(a, b);
    int got = tri_tri_overlap_exact(a, b);
    int swapped = tri_tri_overlap_exact(b, a);
    if (got != ref || swapped != ref)
        fail_msg("%s #%ld: exact %d (swapped %d), reference %d\n a = (%a %a %a) (%a %a %a) "
                 "(%a %a %a)\n b = (%a %a %a) (%a %a %a) (%a %a %a)",
                 what, index, got, swapped, ref, a[0].x, a[0].y, a[0].z, a[1].x, a[1].y, a[1].z,
                 a[2].x, a[2].y, a[2].z, b[0].x, b[0].y, b[0].z, b[1].x, b[1].y, b[1].z, b[2].x,
                 b[2].y, b[2].z);
    tally->cases++;
    tally->hits += ref;
}

/* The plane of a random triangle t at a random scale, a power of two from 2^-800 to 2^799
 * (inputs from about 1e-240 to 1e240). */
static orient3d_plane random_plane(rng *r, vec3 t[3], double *scale)
{
    *scale = ldexp(1.0, (int)(rng_next(r) % 1600) - 800);
    for (int k = 0; k < 3; k++)
        t[k] = random_point(r, -*scale, *scale);
    return orient3d_plane_make(t[0], t[1], t[2]);
}

/* The three-point plane filter decides what the scalar filter decides, point by point:
 * random points, points on the plane (exact zero), one ulp off it, and coordinates from
 * 1e-240 to 1e240, where the bound's underflow pad or its product's size decides. */
static void test_plane_signs_are_the_scalar_filter(void **state)
{
    (void)state;
    rng r = rng_for_test("plane_signs", 77);
    size_t decided = 0, undecided = 0;
    for (int i = 0; i < 100000; i++) {
        vec3 t[3], d[3];
        double scale;
        orient3d_plane p = random_plane(&r, t, &scale);
        for (int k = 0; k < 3; k++) {
            uint64_t kind = rng_next(&r) % 4;
            if (kind == 0) { /* on the plane: a vertex, or an edge's end */
                d[k] = t[rng_next(&r) % 3];
            } else if (kind == 1) { /* next to a vertex, one ulp along an axis */
                d[k] = t[rng_next(&r) % 3];
                d[k].x = nextafter(d[k].x, INFINITY);
            } else if (kind == 2) { /* near the plane: a barycentric point, rounded */
                double u = rng_range(&r, 0, 1), v = rng_range(&r, 0, 1 - u);
                d[k] = vec3_add(t[0], vec3_add(vec3_scale(vec3_sub(t[1], t[0]), u), vec3_scale(vec3_sub(t[2], t[0]), v)));
            } else {
                d[k] = random_point(&r, -scale, scale);
            }
        }
        int s[3];
        tri_tri_plane_signs(&p, d, s);
        for (int k = 0; k < 3; k++) {
            int want = orient3d_plane_filter(&p, d[k]);
            if (s[k] != want)
                fail_msg("point %d of case %d: %d, scalar filter %d", k, i, s[k], want);
            decided += want != PREDICATES_UNDECIDED;
            undecided += want == PREDICATES_UNDECIDED;
        }
    }
    assert_true(decided > 10000 && undecided > 10000);
}

/* The box side is the scalar filter's verdict on all eight corners, and sound: where it
 * says a side, random points of the box have that exact orientation. Boxes around,
 * beside and touching the plane (a corner on it), at scales from 1e-240 to 1e240. */
static void test_plane_box_side_is_the_corners_verdict(void **state)
{
    (void)state;
    rng r = rng_for_test("plane_box_side", 78);
    size_t sided = 0, open = 0;
    for (int i = 0; i < 50000; i++) {
        vec3 t[3];
        double scale;
        orient3d_plane p = random_plane(&r, t, &scale);
        double lo[3], hi[3], half = rng_range(&r, 0, 0.5) * scale;
        vec3 centre = rng_next(&r) % 4 == 0 ? t[rng_next(&r) % 3] : random_point(&r, -scale, scale);
        for (int a = 0; a < 3; a++) {
            lo[a] = vec3_get(centre, a) - half;
            hi[a] = vec3_get(centre, a) + half;
        }
        if (rng_next(&r) % 4 == 0) /* a corner exactly at a vertex: on the plane */
            for (int a = 0; a < 3; a++)
                lo[a] = vec3_get(t[0], a), hi[a] = lo[a] + half;
        int want = 0;
        for (int k = 0; k < 8; k++) {
            vec3 c = {k & 1 ? hi[0] : lo[0], k & 2 ? hi[1] : lo[1], k & 4 ? hi[2] : lo[2]};
            int sgn = orient3d_plane_filter(&p, c);
            if (sgn == PREDICATES_UNDECIDED || (k > 0 && sgn != want)) {
                want = 0;
                break;
            }
            want = sgn;
        }
        int got = tri_tri_plane_box_side(&p, lo, hi);
        if (got != want)
            fail_msg("case %d: %d, the corners' filter %d", i, got, want);
        sided += got != 0;
        open += got == 0;
        for (int j = 0; got != 0 && j < 4; j++) {
            vec3 x = {fmin(fmax(rng_range(&r, lo[0], hi[0]), lo[0]), hi[0]),
                      fmin(fmax(rng_range(&r, lo[1], hi[1]), lo[1]), hi[1]),
                      fmin(fmax(rng_range(&r, lo[2], hi[2]), lo[2]), hi[2])};
            assert_int_equal(orient3d(t[0], t[1], t[2], x), got);
        }
    }
    assert_true(sided > 5000 && open > 5000);
}

static void test_random_pairs_match_reference(void **state)
{
    (void)state;
    rng r = rng_for_test("random pairs", 1);
    agreement tally = {0, 0};
    for (long n = 0; n < 20000; n++) {
        vec3 a[3], b[3];
        double spread = n % 2 ? 1.0 : 0.25; /* small triangles: more near misses */
        vec3 shift = random_point(&r, -0.25 * spread, 0.25 * spread);
        for (int i = 0; i < 3; i++) {
            a[i] = random_point(&r, -spread, spread);
            b[i] = vec3_add(shift, random_point(&r, -spread, spread));
        }
        expect_exact_equals_reference(a, b, &tally, "random pair", n);
    }
    printf("[ info     ] random pairs: %ld cases, %ld touching\n", tally.cases, tally.hits);
    assert_true(tally.hits > tally.cases / 10 && tally.hits < tally.cases * 9 / 10);
}

static void test_snapped_pairs_match_reference(void **state)
{
    (void)state;
    rng r = rng_for_test("snapped pairs", 2);
    agreement tally = {0, 0};
    for (long n = 0; n < 20000; n++) {
        vec3 a[3], b[3];
        random_snapped_pair(&r, a, b);
        expect_exact_equals_reference(a, b, &tally, "snapped pair", n);
    }
    printf("[ info     ] snapped pairs: %ld cases, %ld touching\n", tally.cases, tally.hits);
    assert_true(tally.hits > tally.cases / 10 && tally.hits < tally.cases * 9 / 10);
}

static void test_ulp_nudged_pairs_match_reference(void **state)
{
    (void)state;
    rng r = rng_for_test("ulp-nudged snapped pairs", 3);
    agreement tally = {0, 0};
    for (long n = 0; n < 10000; n++) {
        vec3 a[3], b[3];
        random_snapped_pair(&r, a, b);
        nudge_one_coordinate(&r, rng_int(&r, 0, 1) ? a : b);
        expect_exact_equals_reference(a, b, &tally, "ulp-nudged pair", n);
    }
    printf("[ info     ] ulp-nudged pairs: %ld cases, %ld touching\n", tally.cases, tally.hits);
    assert_true(tally.hits > tally.cases / 20 && tally.hits < tally.cases * 19 / 20);
}

/* Pairs on a lattice of 3 or 5 points a side: vertices on the other plane, edges through
 * edges and vertices, shared vertices, and one triangle's edge lying in the other's plane
 * are common there. Pairs in distinct planes, each meeting the other's plane, take the
 * two-orientation test for crossing planes; those with a vertex exactly on the other
 * plane (the canonical form's zero cases) must be many for the comparison to prove much. */
static void test_lattice_pairs_match_reference(void **state)
{
    (void)state;
    rng r = rng_for_test("lattice pairs", 5);
    agreement tally = {0, 0};
    long crossing = 0, crossing_with_zero = 0;
    for (long n = 0; n < 20000; n++) {
        int side = n % 2 ? 1 : 2;
        vec3 a[3], b[3];
        for (int i = 0; i < 3; i++) {
            a[i] = random_grid_point(&r, -side, side);
            b[i] = random_grid_point(&r, -side, side);
        }
        int sa[3], sb[3], zero = 0;
        for (int i = 0; i < 3; i++) {
            sa[i] = orient3d(b[0], b[1], b[2], a[i]);
            sb[i] = orient3d(a[0], a[1], a[2], b[i]);
            zero |= sa[i] == 0 || sb[i] == 0;
        }
        /* Each meets the other's plane, and neither lies in it. */
        int a_meets = !(sa[0] != 0 && sa[0] == sa[1] && sa[1] == sa[2]) && (sa[0] | sa[1] | sa[2]) != 0;
        int b_meets = !(sb[0] != 0 && sb[0] == sb[1] && sb[1] == sb[2]) && (sb[0] | sb[1] | sb[2]) != 0;
        if (a_meets && b_meets) {
            crossing++;
            crossing_with_zero += zero;
        }
        expect_exact_equals_reference(a, b, &tally, "lattice pair", n);
    }
    printf("[ info     ] lattice pairs: %ld cases, %ld touching, %ld in crossing planes (%ld with a vertex on the "
           "other plane)\n",
           tally.cases, tally.hits, crossing, crossing_with_zero);
    assert_true(tally.hits > tally.cases / 10 && tally.hits < tally.cases * 9 / 10);
    assert_true(crossing > tally.cases / 5 && crossing_with_zero > crossing / 5);
}

static void test_degenerate_triangles_match_reference(void **state)
{
    (void)state;
    rng r = rng_for_test("degenerate triangles", 4);
    agreement tally = {0, 0};
    for (long n = 0; n < 10000; n++) {
        vec3 a[3], b[3];
        random_degenerate_tri(&r, b);
        if (n % 3 == 0) {
            random_degenerate_tri(&r, a);
        } else {
            /* A normal triangle through or near the degenerate one. */
            for (int i = 0; i < 3; i++)
                a[i] = rng_int(&r, 0, 2) ? b[rng_int(&r, 0, 2)]
                                         : vec3_scale(random_grid_point(&r, -3, 3), 2.0);
            if (n % 3 == 2)
                for (int i = 0; i < 3; i++)
                    a[i] = snapped_point(&r, b);
        }
        expect_exact_equals_reference(a, b, &tally, "degenerate pair", n);
    }
    printf("[ info     ] degenerate pairs: %ld cases, %ld touching\n", tally.cases, tally.hits);
    assert_true(tally.hits > tally.cases / 10 && tally.hits < tally.cases * 9 / 10);
}

/* Lattice, snapped and ulp-nudged pairs moved to the ends of the double range: scaled by
 * the power of two that puts their largest coordinate in the top binade (exact: only
 * exponents change), then nudged there by an ulp of up to 2^971. The lattices are centred
 * on zero, so the triangles reach from near -DBL_MAX to near DBL_MAX and every difference
 * across them overflows a double. */
static void test_pairs_at_the_ends_of_the_double_range_match_reference(void **state)
{
    (void)state;
    rng r = rng_for_test("ends of the double range", 6);
    agreement tally = {0, 0};
    for (long n = 0; n < 12000; n++) {
        vec3 a[3], b[3];
        if (n % 3 == 0) {
            for (int i = 0; i < 3; i++) {
                a[i] = random_grid_point(&r, -2, 2);
                b[i] = random_grid_point(&r, -2, 2);
            }
        } else {
            random_snapped_pair(&r, a, b);
        }
        double top = max_abs_coord(a, b);
        if (top == 0.0)
            continue;
        int shift = 1023 - ilogb(top);
        for (int i = 0; i < 3; i++) {
            a[i] = v3(ldexp(a[i].x, shift), ldexp(a[i].y, shift), ldexp(a[i].z, shift));
            b[i] = v3(ldexp(b[i].x, shift), ldexp(b[i].y, shift), ldexp(b[i].z, shift));
        }
        if (n % 3 == 2)
            nudge_one_coordinate(&r, rng_int(&r, 0, 1) ? a : b);
        assert_true(vec3_is_finite(a[0]) && vec3_is_finite(a[1]) && vec3_is_finite(a[2]));
        assert_true(vec3_is_finite(b[0]) && vec3_is_finite(b[1]) && vec3_is_finite(b[2]));
        expect_exact_equals_reference(a, b, &tally, "pair at the ends of the range", n);
        if (n % 16 == 0)
            assert_int_equal(oracle_tri_tri(a, b), reference_tri_tri(a, b));
    }
    printf("[ info     ] ends of the double range: %ld cases, %ld touching\n", tally.cases, tally.hits);
    assert_true(tally.hits > tally.cases / 10 && tally.hits < tally.cases * 9 / 10);
}

/* ------------------------------------------------------------------------------------
 * Contact segment.
 * ------------------------------------------------------------------------------------ */

static double point_segment_distance(vec3 x, vec3 p, vec3 q)
{
    vec3 d = vec3_sub(q, p);
    double len2 = vec3_dot(d, d);
    double t = len2 > 0.0 ? vec3_dot(vec3_sub(x, p), d) / len2 : 0.0;
    t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
    return vec3_length(vec3_sub(x, vec3_add(p, vec3_scale(d, t))));
}

static double point_triangle_distance(vec3 x, const vec3 t[3])
{
    vec3 n = vec3_cross(vec3_sub(t[1], t[0]), vec3_sub(t[2], t[0]));
    double n2 = vec3_dot(n, n);
    if (n2 > 0.0) {
        int inside = 1;
        for (int i = 0; i < 3; i++) {
            vec3 e = vec3_sub(t[(i + 1) % 3], t[i]);
            if (vec3_dot(vec3_cross(e, vec3_sub(x, t[i])), n) < 0.0)
                inside = 0;
        }
        if (inside)
            return fabs(vec3_dot(vec3_sub(x, t[0]), n)) / sqrt(n2);
    }
    double best = INFINITY;
    for (int i = 0; i < 3; i++)
        best = fmin(best, point_segment_distance(x, t[i], t[(i + 1) % 3]));
    return best;
}

static int same_point(vec3 p, vec3 q) { return vec3_equal(p, q); }

static void expect_contact_pair(const vec3 a[3], const vec3 b[3], vec3 want_p, vec3 want_q,
                                const char *what)
{
    vec3 p, q;
    tri_tri_contact_segment(a, b, &p, &q);
    int ok = (same_point(p, want_p) && same_point(q, want_q)) ||
             (same_point(p, want_q) && same_point(q, want_p));
    if (!ok)
        fail_msg("%s: contact (%g %g %g)-(%g %g %g), expected (%g %g %g)-(%g %g %g)", what, p.x,
                 p.y, p.z, q.x, q.y, q.z, want_p.x, want_p.y, want_p.z, want_q.x, want_q.y,
                 want_q.z);
}

static void test_contact_segment_hand_cases(void **state)
{
    (void)state;
    vec3 a[3], b[3];
    set_tri(a, v3(0, 0, 0), v3(4, 0, 0), v3(0, 4, 0));

    set_tri(b, v3(1, 1, -1), v3(3, 1, 1), v3(1, 3, 1));
    expect_contact_pair(a, b, v3(2, 1, 0), v3(1, 2, 0), "crossing");
    expect_contact_pair(b, a, v3(2, 1, 0), v3(1, 2, 0), "crossing, swapped");

    set_tri(b, v3(1, 1, 0), v3(2, 1, 1), v3(1, 2, 1));
    expect_contact_pair(a, b, v3(1, 1, 0), v3(1, 1, 0), "vertex on face gives that point");

    set_tri(b, v3(0, 0, 0), v3(4, 0, 0), v3(2, -1, 3));
    expect_contact_pair(a, b, v3(0, 0, 0), v3(4, 0, 0), "hinge gives the shared edge");

    set_tri(b, v3(0, 0, 0), v3(-1, -2, 3), v3(-2, -1, 1));
    expect_contact_pair(a, b, v3(0, 0, 0), v3(0, 0, 0), "shared vertex");

    /* Overlap polygon (1,1) (3,1) (1,3): its longest extent is the hypotenuse. */
    set_tri(b, v3(1, 1, 0), v3(5, 1, 0), v3(1, 5, 0));
    expect_contact_pair(a, b, v3(3, 1, 0), v3(1, 3, 0), "coplanar overlap");

    /* Star: the overlap hexagon's longest extent. */
    vec3 s[3], t[3];
    set_tri(s, v3(0, 0, 0), v3(6, 0, 0), v3(3, 6, 0));
    set_tri(t, v3(0, 4, 0), v3(6, 4, 0), v3(3, -2, 0));
    vec3 p, q;
    tri_tri_contact_segment(s, t, &p, &q);
    /* The overlap hexagon (2,0) (4,0) (5,2) (4,4) (2,4) (1,2) has two diagonals of the
     * greatest length sqrt(20): (2,0)-(4,4) and (4,0)-(2,4). */
    assert_true(fabs(vec3_length(vec3_sub(p, q)) - sqrt(20.0)) < 1e-12);
    assert_true(fabs(p.x + q.x - 6.0) < 1e-12 && fabs(p.y + q.y - 4.0) < 1e-12);
    assert_true(p.z == 0.0 && q.z == 0.0);

    set_tri(b, v3(1, 1, -1), v3(1, 1, 1), v3(1, 1, -1));
    expect_contact_pair(a, b, v3(1, 1, 0), v3(1, 1, 0), "segment through face");

    set_tri(b, v3(-1, 1, 0), v3(7, 1, 0), v3(3, 1, 0));
    expect_contact_pair(a, b, v3(0, 1, 0), v3(3, 1, 0), "segment clipped in plane");

    set_tri(b, v3(2, 0, 0), v3(2, 0, 0), v3(2, 0, 0));
    expect_contact_pair(a, b, v3(2, 0, 0), v3(2, 0, 0), "point on edge");

    set_tri(s, v3(0, 0, 0), v3(2, 0, 0), v3(1, 0, 0));
    set_tri(t, v3(3, 0, 0), v3(1, 0, 0), v3(3, 0, 0));
    expect_contact_pair(s, t, v3(1, 0, 0), v3(2, 0, 0), "collinear segments overlap");

    set_tri(s, v3(0, 0, 0), v3(2, 2, 0), v3(1, 1, 0));
    set_tri(t, v3(0, 2, 0), v3(2, 0, 0), v3(0, 2, 0));
    expect_contact_pair(s, t, v3(1, 1, 0), v3(1, 1, 0), "segments crossing");

    /* Edge meeting an edge at one point, not a vertex. */
    set_tri(a, v3(0, 0, 1), v3(4, 0, 1), v3(0, 4, 1));
    set_tri(b, v3(1, -1, 2), v3(1, 1, 0), v3(1, -3, 0));
    tri_tri_contact_segment(a, b, &p, &q);
    assert_true(vec3_length(vec3_sub(p, v3(1, 0, 1))) < 1e-15);
    assert_true(vec3_length(vec3_sub(q, v3(1, 0, 1))) < 1e-15);
}

static void expect_contact_near_both(const vec3 a[3], const vec3 b[3], double tolerance,
                                     const char *what, long index)
{
    vec3 ends[2];
    tri_tri_contact_segment(a, b, &ends[0], &ends[1]);
    for (int e = 0; e < 2; e++) {
        if (!vec3_is_finite(ends[e]))
            fail_msg("%s #%ld: contact endpoint not finite", what, index);
        double da = point_triangle_distance(ends[e], a), db = point_triangle_distance(ends[e], b);
        if (!(da <= tolerance && db <= tolerance))
            fail_msg("%s #%ld: endpoint %d is %g from a and %g from b (tolerance %g)", what,
                     index, e, da, db, tolerance);
    }
}

static void test_contact_segment_on_random_crossings(void **state)
{
    (void)state;
    rng r = rng_for_test("contact segment", 5);
    long crossing = 0, snapped = 0;
    for (long n = 0; n < 20000 && crossing < 3000; n++) {
        vec3 a[3], b[3];
        for (int i = 0; i < 3; i++) {
            a[i] = random_point(&r, -1, 1);
            b[i] = random_point(&r, -1, 1);
        }
        if (!tri_tri_overlap_exact(a, b))
            continue;
        expect_contact_near_both(a, b, 1e-9, "random crossing", n);
        crossing++;
    }
    /* Exact integer configurations (coplanar, shared features, degenerate) at unit scale:
     * every distance the construction uses is computed without cancellation error. */
    for (long n = 0; n < 4000; n++) {
        vec3 a[3], b[3];
        for (int i = 0; i < 3; i++)
            a[i] = vec3_scale(random_grid_point(&r, -3, 3), 2.0);
        for (int i = 0; i < 3; i++)
            b[i] = snapped_point(&r, a);
        if (n % 4 == 0)
            random_degenerate_tri(&r, b);
        if (!tri_tri_overlap_exact(a, b))
            continue;
        expect_contact_near_both(a, b, 1e-12, "snapped touching pair", n);
        snapped++;
    }
    printf("[ info     ] contact segment: %ld random crossings, %ld snapped touching pairs\n",
           crossing, snapped);
    assert_true(crossing >= 1000 && snapped >= 1000);
}

static void test_contact_segment_finite_on_any_input(void **state)
{
    (void)state;
    rng r = rng_for_test("contact segment finiteness", 6);
    for (long n = 0; n < 5000; n++) {
        vec3 a[3], b[3];
        random_snapped_pair(&r, a, b);
        if (n % 2)
            nudge_one_coordinate(&r, b);
        if (n % 5 == 0)
            random_degenerate_tri(&r, a);
        if (n % 7 == 0)
            random_degenerate_tri(&r, b);
        vec3 ends[2];
        tri_tri_contact_segment(a, b, &ends[0], &ends[1]); /* touching or not: never NaN */
        if (!vec3_is_finite(ends[0]) || !vec3_is_finite(ends[1]))
            fail_msg("case #%ld: contact endpoints not finite", n);
        if (!tri_tri_overlap_exact(a, b)) {
            /* Outside the contract: the closest vertex pair, a vertex of each. */
            int pa = 0, qb = 0;
            for (int i = 0; i < 3; i++) {
                pa |= vec3_equal(ends[0], a[i]);
                qb |= vec3_equal(ends[1], b[i]);
            }
            if (!pa || !qb)
                fail_msg("case #%ld: apart, but the ends are not a vertex of each", n);
            continue;
        }
        /* However ill-conditioned the crossing, each end stays on an edge of one of the
         * triangles (its parameter is clamped to the edge). */
        double tolerance = 16 * DBL_EPSILON * max_abs_coord(a, b);
        for (int e = 0; e < 2; e++) {
            double d = fmin(point_triangle_distance(ends[e], a),
                            point_triangle_distance(ends[e], b));
            if (!(d <= tolerance))
                fail_msg("case #%ld: contact end %d is %g from both triangles", n, e, d);
        }
    }
}

/* ------------------------------------------------------------------------------------
 * Seed and fast modes.
 * ------------------------------------------------------------------------------------ */

static const double cos_15_degrees = 0.96592582628906829;
static const double cos_30_degrees = 0.86602540378443865;

/* 1 when every angle of t is at least 15 degrees: the seed's epsilon band around a sharp
 * vertex reaches far beyond it, which would make a "clear" miss borderline. */
static int wellshaped(const vec3 t[3])
{
    for (int i = 0; i < 3; i++) {
        vec3 u = vec3_sub(t[(i + 1) % 3], t[i]), w = vec3_sub(t[(i + 2) % 3], t[i]);
        double c = vec3_dot(u, w) / (vec3_length(u) * vec3_length(w));
        if (!(c < cos_15_degrees))
            return 0;
    }
    return 1;
}

static void random_wellshaped_tri(rng *r, vec3 t[3])
{
    do {
        for (int i = 0; i < 3; i++)
            t[i] = random_point(r, -1, 1);
    } while (!wellshaped(t) || vec3_length(vec3_sub(t[1], t[0])) < 0.3);
}

static vec3 barycentric_point(const vec3 t[3], double u, double v)
{
    double w = 1.0 - u - v;
    return vec3_add(vec3_scale(t[0], w), vec3_add(vec3_scale(t[1], u), vec3_scale(t[2], v)));
}

/* b crosses a through a point deep inside both, at an angle of at least 30 degrees. */
static void random_clear_crossing(rng *r, vec3 a[3], vec3 b[3])
{
    random_wellshaped_tri(r, a);
    vec3 inside = barycentric_point(a, rng_range(r, 0.2, 0.5), rng_range(r, 0.2, 0.3));
    vec3 na = vec3_normalize(vec3_cross(vec3_sub(a[1], a[0]), vec3_sub(a[2], a[0])));
    for (;;) {
        random_wellshaped_tri(r, b);
        vec3 nb = vec3_normalize(vec3_cross(vec3_sub(b[1], b[0]), vec3_sub(b[2], b[0])));
        if (fabs(vec3_dot(na, nb)) < cos_30_degrees)
            break;
    }
    vec3 from = barycentric_point(b, rng_range(r, 0.2, 0.5), rng_range(r, 0.2, 0.3));
    vec3 shift = vec3_sub(inside, from);
    for (int i = 0; i < 3; i++)
        b[i] = vec3_add(b[i], shift);
}

/* a and b on opposite sides of a random plane, with a gap of 0.2 between them. */
static void random_clear_separation(rng *r, vec3 a[3], vec3 b[3])
{
    random_wellshaped_tri(r, a);
    random_wellshaped_tri(r, b);
    vec3 u = vec3_normalize(random_point(r, -1, 1));
    double a_max = -INFINITY, b_min = INFINITY;
    for (int i = 0; i < 3; i++) {
        a_max = fmax(a_max, vec3_dot(u, a[i]));
        b_min = fmin(b_min, vec3_dot(u, b[i]));
    }
    vec3 shift = vec3_scale(u, a_max - b_min + 0.2);
    for (int i = 0; i < 3; i++)
        b[i] = vec3_add(b[i], shift);
}

static void test_seed_and_fast_agree_on_clear_cases(void **state)
{
    (void)state;
    rng r = rng_for_test("seed and fast on clear cases", 7);
    const double eps = 1e-6;
    for (long n = 0; n < 3000; n++) {
        vec3 a[3], b[3];
        int crossing = n % 2 == 0;
        if (crossing)
            random_clear_crossing(&r, a, b);
        else
            random_clear_separation(&r, a, b);
        int exact = tri_tri_overlap_exact(a, b);
        int seed = tri_tri_overlap_seed(a, b, eps), seed_swapped = tri_tri_overlap_seed(b, a, eps);
        int fast = tri_tri_overlap_fast(a, b), fast_swapped = tri_tri_overlap_fast(b, a);
        if (exact != crossing || seed != crossing || seed_swapped != crossing ||
            fast != crossing || fast_swapped != crossing)
            fail_msg("clear case #%ld (%s): exact %d seed %d/%d fast %d/%d", n,
                     crossing ? "crossing" : "separated", exact, seed, seed_swapped, fast,
                     fast_swapped);
    }
}

static void test_seed_and_fast_error_counts_on_borderline_cases(void **state)
{
    (void)state;
    rng r = rng_for_test("seed and fast on borderline cases", 8);
    const double eps = 1e-9;
    long total = 0, seed_false_pos = 0, seed_false_neg = 0, fast_false_pos = 0,
         fast_false_neg = 0;
    for (long n = 0; n < 4000; n++) {
        vec3 a[3], b[3];
        random_snapped_pair(&r, a, b);
        if (n % 2)
            nudge_one_coordinate(&r, b);
        int truth = tri_tri_overlap_exact(a, b);
        int seed = tri_tri_overlap_seed(a, b, eps), fast = tri_tri_overlap_fast(a, b);
        seed_false_pos += seed && !truth;
        seed_false_neg += !seed && truth;
        fast_false_pos += fast && !truth;
        fast_false_neg += !fast && truth;
        total++;
    }
    printf("[ info     ] borderline set of %ld pairs (eps %g): seed %ld false hits, %ld missed; "
           "fast %ld false hits, %ld missed\n",
           total, eps, seed_false_pos, seed_false_neg, fast_false_pos, fast_false_neg);
    assert_int_equal(total, 4000);

    hand_list *list = malloc(sizeof *list);
    assert_non_null(list);
    build_hand_cases(list);
    long seed_wrong = 0, fast_wrong = 0;
    for (int i = 0; i < list->count; i++) {
        const hand_case *c = &list->item[i];
        seed_wrong += tri_tri_overlap_seed(c->a, c->b, eps) != c->expected;
        fast_wrong += tri_tri_overlap_fast(c->a, c->b) != c->expected;
    }
    printf("[ info     ] hand-made set of %d cases: seed wrong on %ld, fast wrong on %ld\n",
           list->count, seed_wrong, fast_wrong);
    free(list);
}

static void test_seed_behaviour_as_written(void **state)
{
    (void)state;
    vec3 a[3], b[3];
    const double eps = 1e-9;
    set_tri(a, v3(0, 0, 1), v3(4, 0, 1), v3(0, 4, 1));
    /* Coplanar containment. */
    set_tri(b, v3(1, 1, 1), v3(2, 1, 1), v3(1, 2, 1));
    assert_int_equal(tri_tri_overlap_seed(a, b, eps), 1);
    assert_int_equal(tri_tri_overlap_seed(b, a, eps), 1);
    /* A vertex eps/2 above the face whose edges rise too shallowly for the edge step
     * (s = -0.25 on one, a zero denominator on the other): only the vertex step reports the
     * contact the seed's tolerance intends. Exactly, they are apart. */
    set_tri(a, v3(0, 0, 0), v3(4, 0, 0), v3(0, 4, 0));
    set_tri(b, v3(1, 1, 5e-4), v3(3, 1, 1.5e-3), v3(1, 3, 1.5e-3));
    assert_int_equal(tri_tri_overlap_seed(a, b, 1e-3), 1);
    assert_int_equal(tri_tri_overlap_seed(b, a, 1e-3), 1);
    assert_int_equal(tri_tri_overlap_exact(a, b), 0);
    set_tri(a, v3(0, 0, 1), v3(4, 0, 1), v3(0, 4, 1));
    /* A plain crossing and a plain miss. */
    set_tri(b, v3(1, 1, 0), v3(3, 1, 2), v3(1, 3, 2));
    assert_int_equal(tri_tri_overlap_seed(a, b, eps), 1);
    set_tri(b, v3(10, 1, 0), v3(11, 1, 2), v3(10, 2, 2));
    assert_int_equal(tri_tri_overlap_seed(a, b, eps), 0);
    /* A coplanar crossing with no vertex inside: a coplanar edge gives s = 0/eps, so only
     * its start vertex is tested, and the seed's test misses this overlap. */
    set_tri(a, v3(0, 0, 1), v3(6, 0, 1), v3(3, 6, 1));
    set_tri(b, v3(0, 4, 1), v3(6, 4, 1), v3(3, -2, 1));
    assert_int_equal(tri_tri_overlap_seed(a, b, eps), 0);
    assert_int_equal(tri_tri_overlap_exact(a, b), 1);
    /* The fast test's coplanar branch finds it. */
    assert_int_equal(tri_tri_overlap_fast(a, b), 1);
}

/* Nearly coplanar pairs (the same plane up to rounding, or tilted by up to 2^-20 of the
 * triangles' size) with at least one triangle's size between them along the plane: Moller's
 * intervals come from rounding there, and the fast test must not accept them; the same
 * planes with the second triangle inside the first, crossing its plane, it must accept. */
static void plane_basis(rng *r, vec3 *origin, vec3 *n, vec3 *e1, vec3 *e2)
{
    vec3 v;
    do
        v = v3(rng_range(r, -1, 1), rng_range(r, -1, 1), rng_range(r, -1, 1));
    while (vec3_dot(v, v) > 1 || vec3_dot(v, v) < 0.01);
    *n = vec3_scale(v, 1 / vec3_length(v));
    vec3 w = vec3_cross(*n, fabs(n->x) < 0.5 ? v3(1, 0, 0) : v3(0, 1, 0));
    *e1 = vec3_scale(w, 1 / vec3_length(w));
    *e2 = vec3_cross(*n, *e1);
    *origin = v3(rng_range(r, -10, 10), rng_range(r, -10, 10), rng_range(r, -10, 10));
}

static vec3 plane_point(vec3 o, vec3 n, vec3 e1, vec3 e2, double s, double t, double h)
{
    return vec3_add(o, vec3_add(vec3_add(vec3_scale(e1, s), vec3_scale(e2, t)), vec3_scale(n, h)));
}

static void test_fast_rejects_nearly_coplanar_pairs_apart(void **state)
{
    (void)state;
    rng r = rng_for_test("fast on nearly coplanar pairs", 9);
    const double tilts[3] = {0.0, 0x1p-30, 0x1p-20};
    long pairs = 0, wrong = 0, contained = 0, missed = 0;
    for (int i = 0; i < 300000; i++) {
        vec3 o, n, e1, e2, a[3], b[3];
        plane_basis(&r, &o, &n, &e1, &e2);
        double tilt = tilts[rng_int(&r, 0, 2)];
        double shift = rng_range(&r, -1, 1);
        for (int k = 0; k < 3; k++) {
            a[k] = plane_point(o, n, e1, e2, rng_unit(&r), rng_unit(&r), 0.0);
            b[k] = plane_point(o, n, e1, e2, 2 + rng_unit(&r), shift + rng_unit(&r), tilt * rng_range(&r, -1, 1));
        }
        /* Along e1 (a unit vector) they lie at least `gap` apart, so at least that far. */
        double a_max = -INFINITY, b_min = INFINITY;
        for (int k = 0; k < 3; k++) {
            a_max = fmax(a_max, vec3_dot(vec3_sub(a[k], o), e1));
            b_min = fmin(b_min, vec3_dot(vec3_sub(b[k], o), e1));
        }
        if (!(b_min - a_max >= 0.5))
            continue;
        pairs++;
        assert_int_equal(tri_tri_overlap_exact(a, b), 0);
        if (tri_tri_overlap_fast(a, b) || tri_tri_overlap_fast(b, a)) {
            if (wrong++ < 3)
                printf("[ info     ] pair #%d %.2f apart, accepted: a (%.17g %.17g %.17g) (%.17g %.17g %.17g) "
                       "(%.17g %.17g %.17g) b (%.17g %.17g %.17g) (%.17g %.17g %.17g) (%.17g %.17g %.17g)\n",
                       i, b_min - a_max, a[0].x, a[0].y, a[0].z, a[1].x, a[1].y, a[1].z, a[2].x, a[2].y, a[2].z,
                       b[0].x, b[0].y, b[0].z, b[1].x, b[1].y, b[1].z, b[2].x, b[2].y, b[2].z);
        }
        /* The second triangle shrunk into the first and crossing its plane at 2^-24 of the size. */
        vec3 c = vec3_scale(vec3_add(a[0], vec3_add(a[1], a[2])), 1.0 / 3);
        const double lift[3] = {0x1p-24, -0x1p-24, 0x1p-25};
        for (int k = 0; k < 3; k++)
            b[k] = vec3_add(vec3_add(c, vec3_scale(vec3_sub(a[k], c), 0.5)), vec3_scale(n, lift[k]));
        if (!tri_tri_overlap_exact(a, b))
            continue;
        contained++;
        missed += !tri_tri_overlap_fast(a, b) || !tri_tri_overlap_fast(b, a);
    }
    printf("[ info     ] %ld nearly coplanar pairs apart: fast accepted %ld; %ld crossing inside: fast missed "
           "%ld\n",
           pairs, wrong, contained, missed);
    assert_true(pairs > 100000 && contained > 100000);
    assert_int_equal(wrong, 0);
    assert_int_equal(missed, 0);
}

static void test_fast_coplanar_branch(void **state)
{
    (void)state;
    vec3 a[3], b[3];
    set_tri(a, v3(0, 0, 1), v3(4, 0, 1), v3(0, 4, 1));
    set_tri(b, v3(1, 1, 1), v3(2, 1, 1), v3(1, 2, 1));
    assert_int_equal(tri_tri_overlap_fast(a, b), 1); /* contained: vertex test */
    assert_int_equal(tri_tri_overlap_fast(b, a), 1);
    set_tri(b, v3(3, 3, 1), v3(5, 3, 1), v3(3, 5, 1));
    assert_int_equal(tri_tri_overlap_fast(a, b), 0); /* coplanar, apart */
    set_tri(b, v3(1, -1, 1), v3(3, -1, 1), v3(2, 1, 1));
    assert_int_equal(tri_tri_overlap_fast(a, b), 1); /* coplanar, edges crossing */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hand_cases_match_expected_and_reference),
        cmocka_unit_test(test_hand_cases_invariant_under_exact_symmetries),
        cmocka_unit_test(test_plane_signs_are_the_scalar_filter),
        cmocka_unit_test(test_plane_box_side_is_the_corners_verdict),
        cmocka_unit_test(test_random_pairs_match_reference),
        cmocka_unit_test(test_snapped_pairs_match_reference),
        cmocka_unit_test(test_ulp_nudged_pairs_match_reference),
        cmocka_unit_test(test_degenerate_triangles_match_reference),
        cmocka_unit_test(test_lattice_pairs_match_reference),
        cmocka_unit_test(test_pairs_at_the_ends_of_the_double_range_match_reference),
        cmocka_unit_test(test_contact_segment_hand_cases),
        cmocka_unit_test(test_contact_segment_on_random_crossings),
        cmocka_unit_test(test_contact_segment_finite_on_any_input),
        cmocka_unit_test(test_seed_and_fast_agree_on_clear_cases),
        cmocka_unit_test(test_seed_and_fast_error_counts_on_borderline_cases),
        cmocka_unit_test(test_seed_behaviour_as_written),
        cmocka_unit_test(test_fast_coplanar_branch),
        cmocka_unit_test(test_fast_rejects_nearly_coplanar_pairs_apart),
    };
    return cmocka_run_group_tests_name("tri_tri", tests, NULL, NULL);
}
