/* Exact-sign geometric predicates: a floating-point filter with a proven error bound
 * decides the easy cases, and exact expansion arithmetic decides the rest. */
#include "predicates.h"

#include <assert.h>
#include <limits.h>
#include <math.h>
#include <stddef.h>

#include "expansion.h"

/* ---------------------------------------------------------------------------------------
 * Filter error bounds
 *
 * Notation: u = 2^-53 (EXPANSION_EPS), eta = 2^-1075 (half the smallest subnormal), fl()
 * one rounded operation, ^ a computed value. Round to nearest gives, for doubles:
 *   sums and differences:  |fl(x+y) - (x+y)| <= u |fl(x+y)|   (exact when subnormal);
 *   products:              |fl(xy) - xy|     <= u |fl(xy)| + eta;
 *   and with no underflow  fl(s) >= (1-u) s  for s >= 0.
 * The filter returns sign(det^) when |det^| > bound^, which is right whenever
 * |det - det^| < |det^|. Each constant below makes bound^ exceed the error even after
 * the roundings made while computing bound^ itself; the u^2 coefficients were checked
 * with exact rational arithmetic and then rounded up.
 *
 * Two products, (a-b)(c-d) - (e-f)(g-h):
 *   x^ = fl(a-b) has |x - x^| <= u|x^|, so for l^ = fl(x^ y^):
 *     |xy - l^| <= (2u+u^2)|x^y^| + u|l^| + eta <= A|l^| + (1+u)^2 eta,
 *     A = 3u + 3u^2 + u^3.
 *   With P = |l^| + |r^|:  |det - det^| <= A P + 2(1+u)^2 eta + u|det^|.
 *   The filter computes p^ = fl(|l^| + |r^|) >= (1-u) P and
 *   bound^ = fl(fl(E p^) + ABS) >= (1-u)^3 E P + (1-u)(ABS - eta). It suffices that
 *     E >= A / (1-u)^4 = 3u + 15u^2 + O(u^3)   -> E = (3 + 16u) u  (Shewchuk's ccwerrboundA)
 *     ABS >= eta + 2 eta (1+u)^2/(1-u)^2 ~ 3 eta  -> ABS = 2^-1070.
 *
 * orient3d, det = Az (Bx Cy - Cx By) + Bz (Cx Ay - Ax Cy) + Cz (Ax By - Bx Ay), with
 * A = d-a, B = d-b, C = d-c rounded:
 *   minor M^ = fl(m1^ - m2^), Pm = |m1^| + |m2^|:  |M - M^| <= (4u+4u^2+u^3) Pm + 2(1+u)^2 eta.
 *   term T^ = fl(z^ M^) with rounded z^:
 *     |T - T^| <= (6u + 11u^2 + 6u^3 + u^4) |z^| Pm + 2(1+u)^3 eta |z^| + (1+u) eta.
 *   The two additions add u|S| + u|det^| with u|S| <= u(1+u)^3 (Q1 + Q2) + 2u(1+u) eta,
 *   Qi = |zi^| Pmi. Altogether
 *     |det - det^| <= G sum Qi + 2(1+u)^3 eta sum|zi^| + 4 eta + u |det^|,
 *     G = 7u + 14u^2 + 9u^3 + 2u^4.
 *   The eta |z| terms come from minors whose products underflow; no bound on sum Qi
 *   covers them (a huge z times an underflowed minor), so every minor's permanent is
 *   padded: Pmi' = Pmi + PAD. The computed permanent takes 5 roundings, bound^ 2 more:
 *     bound^ >= (1-u)^7 E sum Qi' - 3 E eta + (1-u)(ABS - eta).
 *   It suffices that
 *     E >= G / (1-u)^8 = 7u + 70u^2 + O(u^3)         -> E = (7 + 80u) u
 *     PAD >= 2(1+u)^3 eta / ((1-u)^8 E) ~ 2^-1023.8    -> PAD = 2^-1020
 *     ABS >= eta + 3 E eta + 4 eta/(1-u)^2 ~ 2^-1072.4 -> ABS = 2^-1070.
 *   (Shewchuk's o3derrboundA is (7 + 56u) u; this accounting is a little looser and
 *   includes the padding's rounding, so the constant is larger. A larger constant only
 *   sends a few more nearly degenerate inputs to the exact stage.)
 *
 * ray_edge_sign, det = Dx (Py Qz - Pz Qy) + Dy (...) + Dz (...), P = p-o, Q = q-o rounded,
 * D = dir exact: the same as orient3d except that the multiplier carries no rounding:
 *     |T - T^| <= (5u + 6u^2 + 2u^3) |D| Pm + 2(1+u)^2 eta |D| + (1+u) eta,
 *     G = 6u + 9u^2 + 5u^3 + u^4,  E >= G/(1-u)^8 = 6u + 57u^2 + O(u^3) -> E = (6 + 64u) u,
 *     with PAD = 2^-1020 (needs ~2^-1023.6) and ABS = 2^-1070 as for orient3d.
 *
 * Range: the bounds above hold for every finite input. Underflow is covered by PAD and
 * ABS, which stop the filter from deciding once a minor's products fall toward 2^-1020
 * or a determinant toward 2^-1070 (coordinates near 1e-300 always go to the exact stage).
 * Overflow makes the computed permanent inf or NaN, so the comparison fails and the
 * exact stage decides.
 * ------------------------------------------------------------------------------------- */
/* The constants derived above are PREDICATES_ERRBOUND_* and PREDICATES_UNDERFLOW_* in
 * predicates.h, where the inline filters that use them live. */

/* ---------------------------------------------------------------------------------------
 * Exact stage
 *
 * Expansion arithmetic is exact unless something overflows or a product's low part falls
 * below 2^-1074. Each predicate is homogeneous in groups of its inputs (all coordinates
 * for orient3d; positions and direction separately for ray_edge_sign; the two factors'
 * operands for sign_diff_products), so scaling a group by a power of two leaves the sign
 * alone. The exact stage picks that power so that, per group, every nonzero input stays
 * below 2^(MAX_EXP+1) and keeps its lowest set bit at or above 2^MIN_LSB:
 *   degree 2 (two factor groups): MAX_EXP 500, MIN_LSB -530 -> products below 2^1005,
 *     low parts at 2^-1060 or above;
 *   degree 3 (three factors): MAX_EXP 330, MIN_LSB -355 -> triple products below 2^996,
 *     low parts at 2^-1065 or above;
 * the lowest set bit of x is taken to be ilogb(x) - 52, or -1074 for a subnormal. So the
 * answer is exact whenever, within each group, the binary exponents of the nonzero inputs
 * (ilogb) differ by at most 978 (degree 2) or 633 (degree 3): anything from subnormal-only
 * to near-DBL_MAX-only inputs, and 1e9 offsets with 1e-9 features. A group spanning more
 * (say 1e-300 beside 1e10 in one orient3d) is scaled to avoid overflow, the smallest
 * values lose low bits, and the sign is then that of a nearby input, not guaranteed.
 * ------------------------------------------------------------------------------------- */
/* The constants are PREDICATES_DEGREE*_MAX_EXP / _MIN_LSB in predicates.h, which the
 * ray-triangle exact stage scales by too. */
#if defined(__GNUC__)
#define PREDICATES_COLD __attribute__((cold, noinline))
#else
#define PREDICATES_COLD
#endif

static _Thread_local uint64_t fallback_count;

uint64_t predicates_fallback_count(void) { return fallback_count; }

void predicates_note_fallback(void) { fallback_count++; }

/* Power of two putting v[0..n) into the exact range; 0 when already inside. Zeros and
 * non-finite values are passed over: neither has bits to keep, and ilogb gives INT_MAX
 * for an infinity and FP_ILOGBNAN (INT_MIN on glibc) for a NaN, on which the exponent
 * arithmetic below would overflow an int. */
int predicates_exact_scale_exponent(const double *v, size_t n, int max_exp, int min_lsb)
{
    int top = INT_MIN, lowest_bit = INT_MAX;
    for (size_t i = 0; i < n; i++) {
        if (v[i] == 0.0 || !isfinite(v[i]))
            continue;
        int exponent = ilogb(v[i]);
        int low = exponent - 52 < -1074 ? -1074 : exponent - 52;
        top = exponent > top ? exponent : top;
        lowest_bit = low < lowest_bit ? low : lowest_bit;
    }
    if (top == INT_MIN)
        return 0;
    int k_max = max_exp - top;        /* largest shift that cannot overflow */
    int k_min = min_lsb - lowest_bit; /* smallest shift that keeps every low part */
    if (k_min > k_max)
        return k_max; /* span too wide: never overflow, lose the lowest bits */
    if (k_min > 0)
        return k_min;
    return k_max < 0 ? k_max : 0;
}

/* The exact stages' inputs are finite doubles: a rounded difference that overflowed must
 * never stand in for one (the exact stage takes the operands of every difference). */
static inline int all_finite(const double *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

static void scale_into_exact_range(double *v, size_t n, int max_exp, int min_lsb)
{
    int k = predicates_exact_scale_exponent(v, n, max_exp, min_lsb);
    if (k == 0)
        return;
    for (size_t i = 0; i < n; i++)
        v[i] = scalbn(v[i], k);
}

/* a - b as a zero-eliminated expansion of at most two components. */
typedef struct exact_diff {
    double c[2];
    size_t n;
} exact_diff;

static exact_diff exact_difference(double a, double b)
{
    exact_diff d = {{0.0, 0.0}, 0};
    double hi, lo;
    two_diff(a, b, &hi, &lo);
    if (lo != 0.0)
        d.c[d.n++] = lo;
    if (hi != 0.0)
        d.c[d.n++] = hi;
    return d;
}

/* x*y - z*w exactly; out holds 16. */
static size_t exact_products_difference(const exact_diff *x, const exact_diff *y,
                                        const exact_diff *z, const exact_diff *w,
                                        double out[16])
{
    double left[8], right[8];
    size_t left_n = expansion_product(x->n, x->c, y->n, y->c, left);
    size_t right_n = expansion_product(z->n, z->c, w->n, w->c, right);
    expansion_negate(right_n, right);
    return expansion_sum(left_n, left, right_n, right, out);
}

/* p*q - r*s is zero whatever the values when each product has a zero factor. A rounded
 * difference is zero only when it is exactly zero, so this needs no exact arithmetic;
 * it keeps axis-aligned and coincident inputs, common in real meshes, off the slow path. */
static inline int products_difference_is_zero(double p, double q, double r, double s)
{
    return (p == 0.0 || q == 0.0) && (r == 0.0 || s == 0.0);
}

/* ---------- exact stage for exact differences ----------
 * Undecided inputs are mostly points close together (shared or nearly shared vertices,
 * nearly coplanar neighbours), whose coordinate differences are computed without rounding.
 * Then the determinant is a sum of products of doubles, which two_product makes exact
 * with short expansions, at a fraction of the general exact stage's cost (this is the idea
 * of the paper's adaptive "stage B"). It applies when every difference is exact and every
 * nonzero one lies in [2^-SAFE, 2^SAFE], so that no product overflows or loses bits below
 * 2^-1074; otherwise the general stage runs. */
static inline int difference_is_safe(double hi, double lo)
{
    double m = fabs(hi);
    return lo == 0.0 && (m == 0.0 || (m >= 0x1p-300 && m <= 0x1p300));
}

/* The exact p*q - r*s as an expansion of at most 4 components; returns its length. */
static size_t products_difference_exact(double p, double q, double r, double s, double out[4])
{
    double x[2], y[2], hi, lo;
    size_t xn = 0, yn = 0;
    two_product(p, q, &hi, &lo);
    if (lo != 0.0)
        x[xn++] = lo;
    if (hi != 0.0)
        x[xn++] = hi;
    two_product(r, s, &hi, &lo);
    if (lo != 0.0)
        y[yn++] = -lo;
    if (hi != 0.0)
        y[yn++] = -hi;
    return expansion_sum(xn, x, yn, y, out);
}

/* The exact sign of w . (u x v) for doubles whose nonzero values all lie in
 * [2^-300, 2^300]: three minors from two_product, each scaled by a component of w. */
static int triple_product_sign_exact(const double u[3], const double v[3], const double w[3])
{
    double minor[4], term_x[8], term_y[8], term_z[8], partial[16], det[24];
    size_t m = products_difference_exact(u[1], v[2], u[2], v[1], minor);
    size_t nx = expansion_scale(m, minor, w[0], term_x);
    m = products_difference_exact(u[2], v[0], u[0], v[2], minor);
    size_t ny = expansion_scale(m, minor, w[1], term_y);
    m = products_difference_exact(u[0], v[1], u[1], v[0], minor);
    size_t nz = expansion_scale(m, minor, w[2], term_z);
    size_t np = expansion_sum(nx, term_x, ny, term_y, partial);
    size_t nd = expansion_sum(np, partial, nz, term_z, det);
    return expansion_sign(nd, det);
}

/* 1 when u x v is exactly the zero vector: parallel (or zero) vectors of doubles in the
 * safe range, where two_product's pair is the exact product, so equal products have
 * equal pairs. */
static int vectors_parallel_exact(const double u[3], const double v[3])
{
    for (int k = 0; k < 3; k++) {
        int i = (k + 1) % 3, j = (k + 2) % 3;
        double h1, l1, h2, l2;
        two_product(u[i], v[j], &h1, &l1);
        two_product(u[j], v[i], &h2, &l2);
        if (h1 != h2 || l1 != l2)
            return 0;
    }
    return 1;
}

/* out = a - b component by component; 1 when every difference is exact and safe. */
static int safe_exact_differences(const double *a, const double *b, size_t n, double *out)
{
    int safe = 1;
    for (size_t i = 0; i < n; i++) {
        double lo;
        two_diff(a[i], b[i], &out[i], &lo);
        safe &= difference_is_safe(out[i], lo);
    }
    return safe;
}

/* ---------- (a - b)(c - d) - (e - f)(g - h) ---------- */

PREDICATES_COLD int sign_diff_products_undecided(double a, double b, double c, double d,
                                                   double e, double f, double g, double h)
{
    if (products_difference_is_zero(a - b, c - d, e - f, g - h))
        return 0;
    /* The same two factors on both sides: orient2d with a == b. */
    if ((a == e && b == f && c == g && d == h) || (a == g && b == h && c == e && d == f))
        return 0;
    predicates_note_fallback();
    {
        double ab, cd, ef, gh, t0, t1, t2, t3;
        two_diff(a, b, &ab, &t0);
        two_diff(c, d, &cd, &t1);
        two_diff(e, f, &ef, &t2);
        two_diff(g, h, &gh, &t3);
        if (difference_is_safe(ab, t0) && difference_is_safe(cd, t1) && difference_is_safe(ef, t2) &&
            difference_is_safe(gh, t3)) {
            double det[4];
            size_t n = products_difference_exact(ab, cd, ef, gh, det);
            return expansion_sign(n, det);
        }
    }
    double first[4] = {a, b, e, f}, second[4] = {c, d, g, h};
    assert(all_finite(first, 4) && all_finite(second, 4));
    scale_into_exact_range(first, 4, PREDICATES_DEGREE2_MAX_EXP, PREDICATES_DEGREE2_MIN_LSB);
    scale_into_exact_range(second, 4, PREDICATES_DEGREE2_MAX_EXP, PREDICATES_DEGREE2_MIN_LSB);
    exact_diff ab = exact_difference(first[0], first[1]);
    exact_diff ef = exact_difference(first[2], first[3]);
    exact_diff cd = exact_difference(second[0], second[1]);
    exact_diff gh = exact_difference(second[2], second[3]);
    double det[16];
    size_t n = exact_products_difference(&ab, &cd, &ef, &gh, det);
    return expansion_sign(n, det);
}





/* ---------- orient3d ---------- */

PREDICATES_COLD int orient3d_undecided(vec3 a, vec3 b, vec3 c, vec3 d)
{
    /* Triangles sharing vertices test each other's corners all the time. */
    if (vec3_equal(a, b) || vec3_equal(a, c) || vec3_equal(a, d) || vec3_equal(b, c) ||
        vec3_equal(b, d) || vec3_equal(c, d))
        return 0;
    vec3 da = vec3_sub(d, a), db = vec3_sub(d, b), dc = vec3_sub(d, c);
    if ((da.z == 0.0 || products_difference_is_zero(db.x, dc.y, dc.x, db.y)) &&
        (db.z == 0.0 || products_difference_is_zero(dc.x, da.y, da.x, dc.y)) &&
        (dc.z == 0.0 || products_difference_is_zero(da.x, db.y, db.x, da.y)))
        return 0;
    predicates_note_fallback();
    {
        /* The differences d - a, d - b, d - c, as the filter formed them; the determinant
         * expanded along z is z . (x x y) over the columns x, y, z of those rows. */
        double dd[9] = {d.x, d.x, d.x, d.y, d.y, d.y, d.z, d.z, d.z};
        double abc[9] = {a.x, b.x, c.x, a.y, b.y, c.y, a.z, b.z, c.z};
        double cols[9];
        if (safe_exact_differences(dd, abc, 9, cols))
            return triple_product_sign_exact(cols, cols + 3, cols + 6);
    }
    double v[12] = {a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z, d.x, d.y, d.z};
    assert(all_finite(v, 12));
    scale_into_exact_range(v, 12, PREDICATES_DEGREE3_MAX_EXP, PREDICATES_DEGREE3_MIN_LSB);
    exact_diff ax = exact_difference(v[9], v[0]), ay = exact_difference(v[10], v[1]),
               az = exact_difference(v[11], v[2]);
    exact_diff bx = exact_difference(v[9], v[3]), by = exact_difference(v[10], v[4]),
               bz = exact_difference(v[11], v[5]);
    exact_diff cx = exact_difference(v[9], v[6]), cy = exact_difference(v[10], v[7]),
               cz = exact_difference(v[11], v[8]);

    double minor[16], term_a[64], term_b[64], term_c[64], partial[128], det[192];
    size_t minor_n = exact_products_difference(&bx, &cy, &cx, &by, minor);
    size_t a_n = expansion_product(minor_n, minor, az.n, az.c, term_a);
    minor_n = exact_products_difference(&cx, &ay, &ax, &cy, minor);
    size_t b_n = expansion_product(minor_n, minor, bz.n, bz.c, term_b);
    minor_n = exact_products_difference(&ax, &by, &bx, &ay, minor);
    size_t c_n = expansion_product(minor_n, minor, cz.n, cz.c, term_c);
    size_t partial_n = expansion_sum(a_n, term_a, b_n, term_b, partial);
    size_t det_n = expansion_sum(partial_n, partial, c_n, term_c, det);
    return expansion_sign(det_n, det);
}


/* ---------- ((p - o) x (q - o)) . dir ---------- */

PREDICATES_COLD int ray_edge_sign_undecided(vec3 p, vec3 q, vec3 o, vec3 dir)
{
    if (vec3_equal(p, q))
        return 0;
    vec3 op = vec3_sub(p, o), oq = vec3_sub(q, o);
    if ((dir.x == 0.0 || products_difference_is_zero(op.y, oq.z, op.z, oq.y)) &&
        (dir.y == 0.0 || products_difference_is_zero(op.z, oq.x, op.x, oq.z)) &&
        (dir.z == 0.0 || products_difference_is_zero(op.x, oq.y, op.y, oq.x)))
        return 0;
    predicates_note_fallback();
    {
        double pq[6] = {p.x, p.y, p.z, q.x, q.y, q.z}, oo[6] = {o.x, o.y, o.z, o.x, o.y, o.z};
        double rows[6], w[3] = {dir.x, dir.y, dir.z};
        if (safe_exact_differences(pq, oo, 6, rows) && difference_is_safe(w[0], 0.0) &&
            difference_is_safe(w[1], 0.0) && difference_is_safe(w[2], 0.0)) {
            /* A ray aimed exactly at p or q (d = p - o), or starting on the edge's line:
             * two of the three rows are parallel and the determinant is zero. These are
             * the undecided cases real queries make most, and the test costs a third of
             * the expansion arithmetic. */
            if (vectors_parallel_exact(rows, w) || vectors_parallel_exact(rows + 3, w) ||
                vectors_parallel_exact(rows, rows + 3))
                return 0;
            return triple_product_sign_exact(rows, rows + 3, w);
        }
    }
    double points[9] = {p.x, p.y, p.z, q.x, q.y, q.z, o.x, o.y, o.z};
    double direction[3] = {dir.x, dir.y, dir.z};
    assert(all_finite(points, 9) && all_finite(direction, 3));
    scale_into_exact_range(points, 9, PREDICATES_DEGREE3_MAX_EXP, PREDICATES_DEGREE3_MIN_LSB);
    scale_into_exact_range(direction, 3, PREDICATES_DEGREE3_MAX_EXP, PREDICATES_DEGREE3_MIN_LSB);
    exact_diff px = exact_difference(points[0], points[6]),
               py = exact_difference(points[1], points[7]),
               pz = exact_difference(points[2], points[8]);
    exact_diff qx = exact_difference(points[3], points[6]),
               qy = exact_difference(points[4], points[7]),
               qz = exact_difference(points[5], points[8]);

    double minor[16], term_x[32], term_y[32], term_z[32], partial[64], det[96];
    size_t minor_n = exact_products_difference(&py, &qz, &pz, &qy, minor);
    size_t x_n = expansion_scale(minor_n, minor, direction[0], term_x);
    minor_n = exact_products_difference(&pz, &qx, &px, &qz, minor);
    size_t y_n = expansion_scale(minor_n, minor, direction[1], term_y);
    minor_n = exact_products_difference(&px, &qy, &py, &qx, minor);
    size_t z_n = expansion_scale(minor_n, minor, direction[2], term_z);
    size_t partial_n = expansion_sum(x_n, term_x, y_n, term_y, partial);
    size_t det_n = expansion_sum(partial_n, partial, z_n, term_z, det);
    return expansion_sign(det_n, det);
}

