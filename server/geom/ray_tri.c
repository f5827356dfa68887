/* Ray against triangle in three accuracy modes: the exact, watertight test (filtered edge
 * functions, symbolic tie-breaking, exact t range and t ordering), the seed's epsilon test,
 * and Moller-Trumbore. */
#include "ray_tri.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "expansion.h"
#include "predicates.h"

/* Error bounds of a triple product whose minors are products of rounded differences,
 * relative to its permanent (each minor's permanent padded by TRIPLE_PAD so that underflow
 * in a minor stays covered), plus TRIPLE_ABS. With the third row exact (the direction)
 * one rounding fewer enters; with it rounded too the bound is orient3d's. The derivation
 * is the one in predicates.c for ray_edge_sign and orient3d; the bounds also cover the
 * roundings made while computing the permanent and the bound. */
#define TRIPLE_ERR_EXACT_ROW ((6.0 + 64.0 * EXPANSION_EPS) * EXPANSION_EPS)
#define TRIPLE_ERR_ROUNDED_ROW ((7.0 + 80.0 * EXPANSION_EPS) * EXPANSION_EPS)
#define TRIPLE_PAD 0x1p-1020
#define TRIPLE_ABS 0x1p-1070
/* Combining two bounded quantities: BOUND_SLACK covers the handful of roundings made
 * while adding up the bound in double, and COMBINE_ABS the absolute error a product
 * picks up when it underflows. */
#define BOUND_SLACK (1.0 + 16.0 * EXPANSION_EPS)
#define COMBINE_ABS 0x1p-1068

/* Exact expansion sizes: a difference of doubles has at most 2 components, a 2 x 2 minor
 * of differences at most 16, the triple product n . (v0 - o) at most 3 * 2 * 16 * 2, and
 * n . d at most 3 * 2 * 16. */
#define DIFF_CAP 2
#define MINOR_CAP 16
#define PLANE_NUM_CAP 192
#define PLANE_DEN_CAP 96
/* Exact products that fit here stay on the stack; larger ones go to the heap. Compressed
 * plane expansions are a few components long, so in practice the heap is never used; the
 * worst case is 2 * PLANE_NUM_CAP * PLANE_DEN_CAP doubles. */
#define STACK_PRODUCT_CAP 256

static inline int sign_of(double x) { return (x > 0.0) - (x < 0.0); }

/* ---------------------------------------------------------------- exact test: filters */

/* The cross product u x v as its three rounded minors, and per component the padded sum of
 * the two products' magnitudes that a dot product with it weighs in its error bound. */
static inline void padded_cross(vec3 u, vec3 v, vec3 *cross, vec3 *mag)
{
    double p1 = u.y * v.z, p2 = u.z * v.y;
    double p3 = u.z * v.x, p4 = u.x * v.z;
    double p5 = u.x * v.y, p6 = u.y * v.x;
    *cross = (vec3){p1 - p2, p3 - p4, p5 - p6};
    *mag = (vec3){fabs(p1) + fabs(p2) + TRIPLE_PAD, fabs(p3) + fabs(p4) + TRIPLE_PAD,
                  fabs(p5) + fabs(p6) + TRIPLE_PAD};
}

/* The edge function ((vi - o) x (vj - o)) . d, evaluated as ((vi - o) x (vj - vi)) . d: the
 * same real number, but its error bound scales with the edge length instead of the
 * distance to the origin twice, so the filter fails less often for far-away origins. */
static inline double edge_function(vec3 a, vec3 e, vec3 d, double *err)
{
    /* padded_cross's products, with the magnitude sums left until w is known nonzero (a
     * ray's exact tests are frequent enough for them to count). */
    double p1 = a.y * e.z, p2 = a.z * e.y;
    double p3 = a.z * e.x, p4 = a.x * e.z;
    double p5 = a.x * e.y, p6 = a.y * e.x;
    double w = d.x * (p1 - p2) + d.y * (p3 - p4) + d.z * (p5 - p6);
    if (w == 0.0) {
        /* Undecided whatever the bound; skipping it keeps its arithmetic out of the
         * subnormal range (PREDICATES_ZERO_SKIPS_BOUND in predicates.h). */
        *err = INFINITY;
        return w;
    }
    double perm = fabs(d.x) * (fabs(p1) + fabs(p2) + TRIPLE_PAD) +
                  fabs(d.y) * (fabs(p3) + fabs(p4) + TRIPLE_PAD) +
                  fabs(d.z) * (fabs(p5) + fabs(p6) + TRIPLE_PAD);
    *err = TRIPLE_ERR_EXACT_ROW * perm + TRIPLE_ABS;
    return w;
}

/* The sign of an edge function when the filter is sure of it, else 0 ("ask exactly"). */
static inline int filtered_sign(double value, double err)
{
    if (value > err)
        return 1;
    if (-value > err)
        return -1;
    return 0;
}

/* t = num / den with num = n . (v0 - o), den = n . d and n = (v1 - v0) x (v2 - v0), all in
 * double with a bound on each error. This n-first form keeps the error relative to |n|
 * rather than to the cube of the distance from the origin, which keeps t accurate. */
typedef struct plane_param {
    double num, num_err;
    double den, den_err;
} plane_param;

static inline plane_param plane_param_of(vec3 o, vec3 d, const vec3 tri[3])
{
    vec3 e1 = vec3_sub(tri[1], tri[0]), e2 = vec3_sub(tri[2], tri[0]);
    vec3 a = vec3_sub(tri[0], o);
    vec3 n, m;
    padded_cross(e1, e2, &n, &m);
    plane_param pp;
    pp.num = n.x * a.x + n.y * a.y + n.z * a.z;
    pp.num_err =
        TRIPLE_ERR_ROUNDED_ROW * (m.x * fabs(a.x) + m.y * fabs(a.y) + m.z * fabs(a.z)) + TRIPLE_ABS;
    pp.den = n.x * d.x + n.y * d.y + n.z * d.z;
    pp.den_err =
        TRIPLE_ERR_EXACT_ROW * (m.x * fabs(d.x) + m.y * fabs(d.y) + m.z * fabs(d.z)) + TRIPLE_ABS;
    return pp;
}

/* Filtered sign of num - tau * den, or 0 when the filter cannot tell (or overflowed). */
static inline int filtered_sign_num_minus_t_den(const plane_param *pp, double tau)
{
    double m = tau * pp->den;
    double q = pp->num - m;
    double err = (pp->num_err + fabs(tau) * pp->den_err + EXPANSION_EPS * fabs(m) + COMBINE_ABS) *
                 BOUND_SLACK;
    if (!isfinite(q) || !isfinite(err))
        return 0;
    return filtered_sign(q, err);
}

/* An upper bound on the exact t = num / den of a hit whose den has the sign s. With
 * N = s num and D = s den (D > 0 exactly), the exact values are within num_err and den_err
 * of them, so the exact t is at most (N + num_err) / (D - den_err) when that numerator is
 * not negative and (N + num_err) / (D + den_err) when it is (rounding keeps its sign). The
 * bound's own three roundings are within 3.01 u of it, which 4 u of it covers, and 2^-1021
 * covers underflow. INFINITY when the denominator is not positive or a value overflowed. */
static double plane_t_upper(const plane_param *pp, int s)
{
    double n = s * pp->num + pp->num_err, dd = s * pp->den;
    double den = n >= 0.0 ? dd - pp->den_err : dd + pp->den_err;
    if (!(den > 0.0) || !isfinite(n) || !isfinite(den))
        return INFINITY;
    double q = n / den;
    return q + fabs(q) * (4 * EXPANSION_EPS) + 0x1p-1021;
}

/* ---------------------------------------------------------------- exact test: fallbacks */

/* Expansion helpers below never hand on an empty expansion: an empty result becomes a
 * single zero, so every later call sees at least one component. */
static size_t nonempty(size_t n, double *e)
{
    if (n == 0) {
        e[0] = 0.0;
        return 1;
    }
    return n;
}

/* a - b exactly, as an expansion of 1 or 2 components. */
static size_t diff_expansion(double a, double b, double out[DIFF_CAP])
{
    double hi, lo;
    two_diff(a, b, &hi, &lo);
    if (lo == 0.0) {
        out[0] = hi;
        return 1;
    }
    out[0] = lo;
    out[1] = hi;
    return 2;
}

/* a1 * b2 - a2 * b1 exactly, for expansions of at most DIFF_CAP components. */
static size_t minor_expansion(size_t a1n, const double *a1, size_t b2n, const double *b2,
                              size_t a2n, const double *a2, size_t b1n, const double *b1,
                              double out[MINOR_CAP])
{
    double left[2 * DIFF_CAP * DIFF_CAP], right[2 * DIFF_CAP * DIFF_CAP];
    size_t ln = nonempty(expansion_product(a1n, a1, b2n, b2, left), left);
    size_t rn = nonempty(expansion_product(a2n, a2, b1n, b1, right), right);
    expansion_negate(rn, right);
    return nonempty(expansion_sum(ln, left, rn, right, out), out);
}

/* The exact num and den of plane_param_of, compressed. */
typedef struct plane_exact {
    size_t num_len, den_len;
    double num[PLANE_NUM_CAP];
    double den[PLANE_DEN_CAP];
} plane_exact;

/* Scaling the ray's origin, its direction and the triangles' vertices by one power of two
 * scales num and den alike (both are of degree 3 in them), so t and every sign stay the
 * same while the expansions stay clear of overflow and underflow: differences of
 * coordinates near 1e308 would otherwise overflow their products, and an overflowed
 * expansion has no sign. One triangle's num and den are degree-3 products and take the
 * predicates' degree-3 range; comparing two triangles' t multiplies one's num by the
 * other's den, degree 6: factors below 2^161 keep such products below 2^966 and lowest
 * bits at 2^-175 keep their low parts at 2^-1050 or above. */
enum { DEGREE6_MAX_EXP = 160, DEGREE6_MIN_LSB = -175 };

static int plane_exact_scale(vec3 o, vec3 d, const vec3 *vertices, size_t vertex_count, int max_exp, int min_lsb)
{
    double v[3 * (2 + 6)];
    size_t n = 0;
    v[n++] = o.x, v[n++] = o.y, v[n++] = o.z;
    v[n++] = d.x, v[n++] = d.y, v[n++] = d.z;
    for (size_t i = 0; i < vertex_count; i++)
        v[n++] = vertices[i].x, v[n++] = vertices[i].y, v[n++] = vertices[i].z;
    return predicates_exact_scale_exponent(v, n, max_exp, min_lsb);
}

static vec3 vec3_scalbn(vec3 p, int k)
{
    return k == 0 ? p : (vec3){scalbn(p.x, k), scalbn(p.y, k), scalbn(p.z, k)};
}

/* The exact num and den of plane_param_of for the inputs scaled by 2^shift (the same t). */
static void plane_exact_of_scaled(vec3 o, vec3 d, const vec3 tri_in[3], int shift, plane_exact *pe)
{
    vec3 tri[3] = {vec3_scalbn(tri_in[0], shift), vec3_scalbn(tri_in[1], shift), vec3_scalbn(tri_in[2], shift)};
    o = vec3_scalbn(o, shift);
    d = vec3_scalbn(d, shift);
    double e1[3][DIFF_CAP], e2[3][DIFF_CAP], a[3][DIFF_CAP];
    size_t e1n[3], e2n[3], an[3];
    for (int k = 0; k < 3; k++) {
        double v0 = vec3_get(tri[0], k);
        e1n[k] = diff_expansion(vec3_get(tri[1], k), v0, e1[k]);
        e2n[k] = diff_expansion(vec3_get(tri[2], k), v0, e2[k]);
        an[k] = diff_expansion(v0, vec3_get(o, k), a[k]);
    }
    double num_terms[3][2 * MINOR_CAP * DIFF_CAP], den_terms[3][2 * MINOR_CAP];
    size_t num_n[3], den_n[3];
    for (int k = 0; k < 3; k++) {
        /* n_k = e1_i e2_j - e1_j e2_i with (i, j) the axes after k in cyclic order. */
        int i = (k + 1) % 3, j = (k + 2) % 3;
        double n[MINOR_CAP];
        size_t nn = minor_expansion(e1n[i], e1[i], e2n[j], e2[j], e1n[j], e1[j], e2n[i], e2[i], n);
        num_n[k] = nonempty(expansion_product(nn, n, an[k], a[k], num_terms[k]), num_terms[k]);
        den_n[k] = nonempty(expansion_scale(nn, n, vec3_get(d, k), den_terms[k]), den_terms[k]);
    }
    double num01[2 * 2 * MINOR_CAP * DIFF_CAP], den01[2 * 2 * MINOR_CAP];
    size_t n01 =
        nonempty(expansion_sum(num_n[0], num_terms[0], num_n[1], num_terms[1], num01), num01);
    pe->num_len = nonempty(expansion_sum(n01, num01, num_n[2], num_terms[2], pe->num), pe->num);
    size_t d01 =
        nonempty(expansion_sum(den_n[0], den_terms[0], den_n[1], den_terms[1], den01), den01);
    pe->den_len = nonempty(expansion_sum(d01, den01, den_n[2], den_terms[2], pe->den), pe->den);
    pe->num_len = expansion_compress(pe->num_len, pe->num);
    pe->den_len = expansion_compress(pe->den_len, pe->den);
}

/* Out of line: the exact stage is rare, and inlined its frame costs every candidate. */
#if defined(__GNUC__)
__attribute__((cold, noinline))
#endif
static void plane_exact_of(vec3 o, vec3 d, const vec3 tri[3], plane_exact *pe)
{
    int shift = plane_exact_scale(o, d, tri, 3, PREDICATES_DEGREE3_MAX_EXP, PREDICATES_DEGREE3_MIN_LSB);
    plane_exact_of_scaled(o, d, tri, shift, pe);
}

/* Exact sign of num - tau * den (den != 0) for a finite tau. */
static int exact_sign_num_minus_t_den(const plane_exact *pe, double tau)
{
    if (tau == 0.0)
        return expansion_sign(pe->num_len, pe->num);
    /* sign(num - tau den) = sign(t - tau) * sign(den). Compressed expansions estimate to
     * within a few ulps, so when t is clearly away from tau the estimate settles it; this
     * also keeps tau * den from overflowing for a huge finite tau (a caller's "no limit"). */
    int den_sign = expansion_sign(pe->den_len, pe->den);
    double t_est =
        expansion_estimate(pe->num_len, pe->num) / expansion_estimate(pe->den_len, pe->den);
    if (isinf(t_est) && fabs(tau) <= 0x1p1000)
        return sign_of(t_est) * den_sign;
    if (isfinite(t_est) && fabs(t_est - tau) > 0x1p-20 * fabs(t_est))
        return sign_of(t_est - tau) * den_sign;
    double scaled[2 * PLANE_DEN_CAP], diff[2 * PLANE_DEN_CAP + PLANE_NUM_CAP];
    size_t sn = nonempty(expansion_scale(pe->den_len, pe->den, -tau, scaled), scaled);
    size_t dn = nonempty(expansion_sum(pe->num_len, pe->num, sn, scaled, diff), diff);
    return expansion_sign(dn, diff);
}

/* The sign an edge function takes under the symbolic perturbation d + (e1, e2, e3),
 * e1 >> e2 >> e3 > 0, when it is exactly zero: the first nonzero component of
 * c = (p - o) x (q - o). When c vanishes (o on the edge's line) no direction can break the
 * tie, so a fixed rule on the edge decides; both rules flip sign when p and q swap, which
 * is what makes neighbouring triangles disagree about who owns the edge. */
static int edge_tie_sign(vec3 p, vec3 q, vec3 o)
{
    for (int axis = 0; axis < 3; axis++) {
        int s = orient2d_axis(p, q, o, axis);
        if (s != 0)
            return s;
    }
    for (int axis = 0; axis < 3; axis++) {
        double pa = vec3_get(p, axis), qa = vec3_get(q, axis);
        if (pa != qa)
            return pa < qa ? 1 : -1;
    }
    return -1; /* p == q: a degenerate triangle, which has den == 0 and never hits */
}

/* Exact, tie-broken sign of the edge function of p -> q; *exactly_zero tells whether the
 * unperturbed value was zero. */
static int edge_sign_exact(vec3 p, vec3 q, vec3 o, vec3 d, int *exactly_zero)
{
    int s = ray_edge_sign(p, q, o, d);
    *exactly_zero = s == 0;
    return s != 0 ? s : edge_tie_sign(p, q, o);
}

/* ---------------------------------------------------------------- reported t */

/* Error-free transforms for the hit parameter. They run on ill-conditioned hits, often
 * enough to be worth inlining, so they live here rather than behind expansion.c's calls.
 * Dekker's split needs |a| < 2^996, far beyond the coordinates anything here takes. */
static inline void dd_two_sum(double a, double b, double *sum, double *err)
{
    double s = a + b, bv = s - a, av = s - bv;
    *sum = s;
    *err = (a - av) + (b - bv);
}

static inline void dd_split(double a, double *hi, double *lo)
{
    double c = 134217729.0 * a; /* 2^27 + 1 */
    *hi = c - (c - a);
    *lo = a - *hi;
}

static inline void dd_two_product(double a, double b, double *prod, double *err)
{
    double p = a * b, ah, al, bh, bl;
    dd_split(a, &ah, &al);
    dd_split(b, &bh, &bl);
    *prod = p;
    *err = ((ah * bh - p) + ah * bl + al * bh) + al * bl;
}

/* t = num / den to within about an ulp when plain double loses digits to cancellation
 * (grazing rays, origins near the plane): every difference, product and sum carries its
 * rounding error along (double-double), dropping only second-order terms, which leaves
 * num and den with relative errors near 2^-100 times their condition numbers. */
static double hit_parameter_accurate(vec3 o, vec3 d, const vec3 tri[3])
{
    double e1h[3], e1l[3], e2h[3], e2l[3], ah[3], al[3];
    for (int k = 0; k < 3; k++) {
        double v0 = vec3_get(tri[0], k);
        dd_two_sum(vec3_get(tri[1], k), -v0, &e1h[k], &e1l[k]);
        dd_two_sum(vec3_get(tri[2], k), -v0, &e2h[k], &e2l[k]);
        dd_two_sum(v0, -vec3_get(o, k), &ah[k], &al[k]);
    }
    double num_hi = 0.0, num_lo = 0.0, den_hi = 0.0, den_lo = 0.0;
    for (int k = 0; k < 3; k++) {
        int i = (k + 1) % 3, j = (k + 2) % 3;
        double p1, p1e, p2, p2e, nh, nl;
        dd_two_product(e1h[i], e2h[j], &p1, &p1e);
        dd_two_product(e1h[j], e2h[i], &p2, &p2e);
        dd_two_sum(p1, -p2, &nh, &nl);
        nl +=
            (p1e - p2e) + (e1h[i] * e2l[j] + e1l[i] * e2h[j]) - (e1h[j] * e2l[i] + e1l[j] * e2h[i]);
        dd_two_sum(nh, nl, &nh, &nl);

        double dk = vec3_get(d, k), p, pe, s, se;
        dd_two_product(nh, dk, &p, &pe);
        dd_two_sum(den_hi, p, &den_hi, &se);
        den_lo += se + pe + nl * dk;
        dd_two_product(nh, ah[k], &p, &pe);
        dd_two_sum(num_hi, p, &s, &se);
        num_hi = s;
        num_lo += se + pe + nh * al[k] + nl * ah[k];
    }
    dd_two_sum(den_hi, den_lo, &den_hi, &den_lo);
    dd_two_sum(num_hi, num_lo, &num_hi, &num_lo);
    /* One Newton step on the quotient: t0 * den_hi is exact as a pair, and num_hi minus
     * its high part is exact because the two are within an ulp of each other. */
    double t0 = num_hi / den_hi, p, pe;
    dd_two_product(t0, den_hi, &p, &pe);
    double residual = ((num_hi - p) - pe) + num_lo - t0 * den_lo;
    return t0 + residual / den_hi;
}

/* Relative error bounds below which the plain double t is within a few ulps. */
#define T_FLOAT_REL_ERR 0x1p-49
/* ... and below which the double-double t is (its error is ~2^-100 times the condition
 * number, the plain bound ~2^-50 times it); beyond, t comes from the exact values. */
#define T_ACCURATE_REL_ERR 0x1p-8

/* ---------------------------------------------------------------- exact test */

/* Reported barycentrics: edge functions over their sum, with the signs already known to
 * agree; clamping the few that rounding pushed across zero keeps u, v in [0, 1]. */
static void report_barycentrics(int s, double w01, double w12, double w20, ray_tri_hit *hit)
{
    double b0 = fmax(0.0, s * w12), b1 = fmax(0.0, s * w20), b2 = fmax(0.0, s * w01);
    double sum = b0 + b1 + b2;
    if (sum > 0.0 && isfinite(sum)) {
        hit->u = b1 / sum;
        hit->v = b2 / sum;
    } else {
        hit->u = hit->v = 1.0 / 3.0;
    }
}

/* The exact tests' first test: a triangle with a repeated vertex is never crossed. Its
 * edge functions alone do not say so when all three vertices are one point (all three are
 * then zero), and such triangles come in hundreds where a mesh with one is subdivided. */
static inline int has_repeated_vertex(const vec3 tri[3])
{
    return vec3_equal(tri[0], tri[1]) || vec3_equal(tri[1], tri[2]) || vec3_equal(tri[2], tri[0]);
}

/* The exact test under either edge rule. closed = 0 is ray_tri_exact's watertight rule;
 * closed = 1 counts an exactly zero edge function as on the triangle (the closed triangle
 * of ray_tri_touch) and returns RAY_TRI_DEN_ZERO where den == 0 exactly, which that rule
 * decides elsewhere. Both are constants at the call sites, so each rule compiles to its
 * own code and the watertight one keeps exactly its arithmetic. */
static inline __attribute__((always_inline)) int ray_tri_exact_rule(vec3 o, vec3 d, double tmin, double tmax,
                                                                    const vec3 tri[3], int closed, ray_tri_hit *hit)
{
    if (!(tmin <= tmax) || tmin == INFINITY || tmax == -INFINITY)
        return 0;
    const vec3 v0 = tri[0], v1 = tri[1], v2 = tri[2];
    /* A triangle with a repeated vertex has den == 0 exactly and is never hit; saying so
     * here keeps its zero-length edge from sending every ray through the exact stage. */
    if (has_repeated_vertex(tri))
        return closed ? RAY_TRI_DEN_ZERO : 0;

    double err01, err12, err20;
    double w01 = edge_function(vec3_sub(v0, o), vec3_sub(v1, v0), d, &err01);
    double w12 = edge_function(vec3_sub(v1, o), vec3_sub(v2, v1), d, &err12);
    int s01 = filtered_sign(w01, err01), s12 = filtered_sign(w12, err12);
    if (s01 * s12 < 0)
        return 0;
    double w20 = edge_function(vec3_sub(v2, o), vec3_sub(v0, v2), d, &err20);
    int s20 = filtered_sign(w20, err20);
    if (s20 * s01 < 0 || s20 * s12 < 0)
        return 0;

    int s;
    if (closed) {
        /* Exact signs, zeros kept: a zero edge function puts the plane point on that edge's
         * line, which the closed triangle holds when the other signs agree. */
        if (s01 == 0)
            s01 = ray_edge_sign(v0, v1, o, d);
        if (s12 == 0)
            s12 = ray_edge_sign(v1, v2, o, d);
        if (s20 == 0)
            s20 = ray_edge_sign(v2, v0, o, d);
        if (s01 * s12 < 0 || s12 * s20 < 0 || s20 * s01 < 0)
            return 0;
        /* All three zero: den == 0 (the sum), in-plane ray or zero-area triangle. */
        s = s01 != 0 ? s01 : s12 != 0 ? s12 : s20;
        if (s == 0)
            return RAY_TRI_DEN_ZERO;
    } else {
        /* Only edges the filter could not settle go to the exact predicate. */
        int z01 = 0, z12 = 0, z20 = 0;
        if (s01 == 0)
            s01 = edge_sign_exact(v0, v1, o, d, &z01);
        if (s12 == 0)
            s12 = edge_sign_exact(v1, v2, o, d, &z12);
        if (s20 == 0)
            s20 = edge_sign_exact(v2, v0, o, d, &z20);
        if (s01 != s12 || s12 != s20)
            return 0;
        /* The three edge functions sum to den; all zero means den == 0 (parallel ray or
         * degenerate triangle). Otherwise den has the common sign s. */
        if (z01 && z12 && z20)
            return 0;
        s = s01;
    }

    /* tmin <= num / den <= tmax, i.e. s * (num - tmin den) >= 0 and s * (num - tmax den) <= 0. */
    plane_param pp = plane_param_of(o, d, tri);
    int lower = tmin == -INFINITY ? 1 : filtered_sign_num_minus_t_den(&pp, tmin) * s;
    int upper = tmax == INFINITY ? -1 : filtered_sign_num_minus_t_den(&pp, tmax) * s;
    if (lower < 0 || upper > 0)
        return 0;
    plane_exact pe;
    int have_exact = 0;
    if (lower == 0 || upper == 0) {
        predicates_note_fallback();
        plane_exact_of(o, d, tri, &pe);
        have_exact = 1;
        if (lower == 0 && exact_sign_num_minus_t_den(&pe, tmin) * s < 0)
            return 0;
        if (upper == 0 && exact_sign_num_minus_t_den(&pe, tmax) * s > 0)
            return 0;
    }

    if (hit) {
        double t;
        /* An overflowed num or den has an infinite bound, which "bound <= 2^-49 |value|"
         * would accept when the value is infinite too: such a t goes to the exact stage. */
        int in_range = isfinite(pp.num_err) && isfinite(pp.den_err);
        if (in_range && pp.num_err <= T_FLOAT_REL_ERR * fabs(pp.num) &&
            pp.den_err <= T_FLOAT_REL_ERR * fabs(pp.den)) {
            t = pp.num / pp.den;
        } else if (in_range && pp.num_err <= T_ACCURATE_REL_ERR * fabs(pp.num) &&
                   pp.den_err <= T_ACCURATE_REL_ERR * fabs(pp.den)) {
            t = hit_parameter_accurate(o, d, tri);
        } else {
            /* t near 0 or a nearly parallel ray: the exact values, compressed, round well. */
            if (!have_exact) {
                predicates_note_fallback();
                plane_exact_of(o, d, tri, &pe);
            }
            t = expansion_estimate(pe.num_len, pe.num) / expansion_estimate(pe.den_len, pe.den);
        }
        /* The exact t lies in [tmin, tmax]; keep the rounded one there too. */
        if (!(t >= tmin))
            t = tmin;
        if (!(t <= tmax))
            t = tmax;
        hit->t = t;
        hit->t_upper = plane_t_upper(&pp, s);
        report_barycentrics(s, w01, w12, w20, hit);
    }
    return 1;
}

/* ---------------------------------------------------------------- the filter, four at once */

/* The decided signs of the three edge functions of one triangle as ray_tri_exact_rule
 * computes them, and whether they already rule a hit out (two decided signs that differ). */
static unsigned scalar_edge_miss(vec3 o, vec3 d, const vec3 tri[3])
{
    if (has_repeated_vertex(tri))
        return 1;
    double e01, e12, e20;
    double w01 = edge_function(vec3_sub(tri[0], o), vec3_sub(tri[1], tri[0]), d, &e01);
    double w12 = edge_function(vec3_sub(tri[1], o), vec3_sub(tri[2], tri[1]), d, &e12);
    int s01 = filtered_sign(w01, e01), s12 = filtered_sign(w12, e12);
    if (s01 * s12 < 0)
        return 1;
    double w20 = edge_function(vec3_sub(tri[2], o), vec3_sub(tri[0], tri[2]), d, &e20);
    int s20 = filtered_sign(w20, e20);
    return s20 * s01 < 0 || s20 * s12 < 0;
}

#if defined(__x86_64__)
#include <immintrin.h>
#define RAY_TRI_AVX2 __attribute__((target("avx2")))

/* edge_function on four lanes: the same products, sums and bound, in the same order. The
 * sign masks say where the filter is sure the value is positive or negative. */
RAY_TRI_AVX2 static inline __attribute__((always_inline)) void edge_function4(const __m256d a[3], const __m256d e[3], const __m256d d[3],
                                               const __m256d dabs[3], __m256d *pos, __m256d *neg)
{
    __m256d mag = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffffll));
    __m256d p1 = _mm256_mul_pd(a[1], e[2]), p2 = _mm256_mul_pd(a[2], e[1]);
    __m256d p3 = _mm256_mul_pd(a[2], e[0]), p4 = _mm256_mul_pd(a[0], e[2]);
    __m256d p5 = _mm256_mul_pd(a[0], e[1]), p6 = _mm256_mul_pd(a[1], e[0]);
    __m256d w = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(d[0], _mm256_sub_pd(p1, p2)),
                                            _mm256_mul_pd(d[1], _mm256_sub_pd(p3, p4))),
                              _mm256_mul_pd(d[2], _mm256_sub_pd(p5, p6)));
    __m256d pad = _mm256_set1_pd(TRIPLE_PAD);
    __m256d m1 = _mm256_add_pd(_mm256_add_pd(_mm256_and_pd(p1, mag), _mm256_and_pd(p2, mag)), pad);
    __m256d m2 = _mm256_add_pd(_mm256_add_pd(_mm256_and_pd(p3, mag), _mm256_and_pd(p4, mag)), pad);
    __m256d m3 = _mm256_add_pd(_mm256_add_pd(_mm256_and_pd(p5, mag), _mm256_and_pd(p6, mag)), pad);
    __m256d perm = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(dabs[0], m1), _mm256_mul_pd(dabs[1], m2)),
                                 _mm256_mul_pd(dabs[2], m3));
    __m256d err = _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(TRIPLE_ERR_EXACT_ROW), perm), _mm256_set1_pd(TRIPLE_ABS));
    /* w == 0 is undecided whatever the bound (edge_function's err = INFINITY). */
    __m256d nonzero = _mm256_cmp_pd(w, _mm256_setzero_pd(), _CMP_NEQ_OQ);
    *pos = _mm256_and_pd(nonzero, _mm256_cmp_pd(w, err, _CMP_GT_OQ));
    *neg = _mm256_and_pd(nonzero, _mm256_cmp_pd(_mm256_xor_pd(w, _mm256_set1_pd(-0.0)), err, _CMP_GT_OQ));
}

/* Edge k -> k + 1 of four triangles: a = v_k - o, e = v_{k+1} - v_k, per axis. */
#define EDGE4(vk, vj, pos, neg)                                                                              \
    do {                                                                                                     \
        __m256d a_[3] = {_mm256_sub_pd(vk##x, ox), _mm256_sub_pd(vk##y, oy), _mm256_sub_pd(vk##z, oz)};       \
        __m256d e_[3] = {_mm256_sub_pd(vj##x, vk##x), _mm256_sub_pd(vj##y, vk##y), _mm256_sub_pd(vj##z, vk##z)}; \
        edge_function4(a_, e_, dv, da, &pos, &neg);                                                          \
    } while (0)

RAY_TRI_AVX2 static unsigned misses4_avx2(vec3 o, vec3 d, const vec3 *vertices, const uint32_t (*corners)[3],
                                          const uint32_t *ids, unsigned count)
{
    /* Unused lanes repeat the first triangle; their bits are dropped below. The vertices
     * are read where they are, not copied out first. */
    const uint32_t *c0 = corners[ids[0]], *c1 = count > 1 ? corners[ids[1]] : c0,
                   *c2 = count > 2 ? corners[ids[2]] : c0, *c3 = count > 3 ? corners[ids[3]] : c0;
#define COORD4(k, c)                                                                                         \
    _mm256_set_pd(vertices[c3[k]].c, vertices[c2[k]].c, vertices[c1[k]].c, vertices[c0[k]].c)
    __m256d v0x = COORD4(0, x), v0y = COORD4(0, y), v0z = COORD4(0, z);
    __m256d v1x = COORD4(1, x), v1y = COORD4(1, y), v1z = COORD4(1, z);
    __m256d v2x = COORD4(2, x), v2y = COORD4(2, y), v2z = COORD4(2, z);
#undef COORD4
    __m256d ox = _mm256_set1_pd(o.x), oy = _mm256_set1_pd(o.y), oz = _mm256_set1_pd(o.z);
    __m256d dv[3] = {_mm256_set1_pd(d.x), _mm256_set1_pd(d.y), _mm256_set1_pd(d.z)};
    __m256d da[3] = {_mm256_set1_pd(fabs(d.x)), _mm256_set1_pd(fabs(d.y)), _mm256_set1_pd(fabs(d.z))};
    __m256d pos01, neg01, pos12, neg12, pos20, neg20;
    EDGE4(v0, v1, pos01, neg01);
    EDGE4(v1, v2, pos12, neg12);
    EDGE4(v2, v0, pos20, neg20);
    /* Two decided signs that differ: (01, 12), then 20 against either. */
    __m256d miss = _mm256_or_pd(_mm256_and_pd(pos01, neg12), _mm256_and_pd(neg01, pos12));
    miss = _mm256_or_pd(miss, _mm256_and_pd(pos20, _mm256_or_pd(neg01, neg12)));
    miss = _mm256_or_pd(miss, _mm256_and_pd(neg20, _mm256_or_pd(pos01, pos12)));
    unsigned lanes = (1u << count) - 1, missed = (unsigned)_mm256_movemask_pd(miss) & lanes;
    if (missed == lanes)
        return missed;
    /* has_repeated_vertex, lane by lane, where some lane is left (on most meshes a
     * candidate in a few groups, a hit or a near miss). */
#define SAME4(a, b)                                                                                          \
    _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(a##x, b##x, _CMP_EQ_OQ), _mm256_cmp_pd(a##y, b##y, _CMP_EQ_OQ)),  \
                  _mm256_cmp_pd(a##z, b##z, _CMP_EQ_OQ))
    __m256d repeated = _mm256_or_pd(_mm256_or_pd(SAME4(v0, v1), SAME4(v1, v2)), SAME4(v2, v0));
#undef SAME4
    return missed | ((unsigned)_mm256_movemask_pd(repeated) & lanes);
}
#undef EDGE4
#endif

unsigned ray_tri_exact_misses4(vec3 o, vec3 d, const vec3 *vertices, const uint32_t (*corners)[3],
                               const uint32_t *ids, unsigned count, int avx2)
{
#if defined(__x86_64__)
    if (avx2 && count > 1)
        return misses4_avx2(o, d, vertices, corners, ids, count);
#else
    (void)avx2;
#endif
    unsigned miss = 0;
    for (unsigned i = 0; i < count; i++) {
        const uint32_t *c = corners[ids[i]];
        vec3 tri[3] = {vertices[c[0]], vertices[c[1]], vertices[c[2]]};
        miss |= scalar_edge_miss(o, d, tri) << i;
    }
    return miss;
}

/* ---------------------------------------------------------------- the filter, a fan of rays */

void ray_fan_init(ray_fan *fan, vec3 o, const vec3 *directions, unsigned count)
{
    fan->o = o;
    fan->count = count;
    for (unsigned i = 0; i < RAY_FAN_MAX; i++) {
        /* Unused lanes repeat the first ray; their bits are dropped. */
        vec3 d = directions[i < count ? i : 0];
        for (int a = 0; a < 3; a++) {
            fan->d[a][i] = vec3_get(d, a);
            fan->dabs[a][i] = fabs(vec3_get(d, a));
        }
    }
}

/* What edge_function computes before the direction comes in: a = v_k - o and e = v_j -
 * v_k, their six products, and per axis the difference and the padded magnitude sum that
 * the dot product with d and its bound weigh (the same operations, so the same values). */
typedef struct fan_edge {
    vec3 c, m;
} fan_edge;

static inline fan_edge fan_edge_of(vec3 vk, vec3 vj, vec3 o)
{
    fan_edge g;
    padded_cross(vec3_sub(vk, o), vec3_sub(vj, vk), &g.c, &g.m);
    return g;
}

/* filtered_sign of one ray's edge function from its shared part. */
static inline int fan_edge_sign(const fan_edge *g, const ray_fan *fan, unsigned i)
{
    double w = fan->d[0][i] * g->c.x + fan->d[1][i] * g->c.y + fan->d[2][i] * g->c.z;
    if (w == 0.0)
        return 0;
    double perm = fan->dabs[0][i] * g->m.x + fan->dabs[1][i] * g->m.y + fan->dabs[2][i] * g->m.z;
    return filtered_sign(w, TRIPLE_ERR_EXACT_ROW * perm + TRIPLE_ABS);
}

static unsigned fan_misses_scalar(const ray_fan *fan, const fan_edge g[3])
{
    unsigned miss = 0;
    for (unsigned i = 0; i < fan->count; i++) {
        int s01 = fan_edge_sign(&g[0], fan, i), s12 = fan_edge_sign(&g[1], fan, i),
            s20 = fan_edge_sign(&g[2], fan, i);
        miss |= (unsigned)(s01 * s12 < 0 || s20 * s01 < 0 || s20 * s12 < 0) << i;
    }
    return miss;
}

#if defined(__x86_64__)
/* fan_edge_sign on four rays: the decided-positive and decided-negative lanes. */
RAY_TRI_AVX2 static inline __attribute__((always_inline)) void fan_edge4(const fan_edge *g, const ray_fan *fan,
                                                                          unsigned half, __m256d *pos, __m256d *neg)
{
    __m256d dx = _mm256_loadu_pd(&fan->d[0][4 * half]), dy = _mm256_loadu_pd(&fan->d[1][4 * half]),
            dz = _mm256_loadu_pd(&fan->d[2][4 * half]);
    __m256d w = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(dx, _mm256_set1_pd(g->c.x)),
                                            _mm256_mul_pd(dy, _mm256_set1_pd(g->c.y))),
                              _mm256_mul_pd(dz, _mm256_set1_pd(g->c.z)));
    __m256d ax = _mm256_loadu_pd(&fan->dabs[0][4 * half]), ay = _mm256_loadu_pd(&fan->dabs[1][4 * half]),
            az = _mm256_loadu_pd(&fan->dabs[2][4 * half]);
    __m256d perm = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(ax, _mm256_set1_pd(g->m.x)),
                                               _mm256_mul_pd(ay, _mm256_set1_pd(g->m.y))),
                                 _mm256_mul_pd(az, _mm256_set1_pd(g->m.z)));
    __m256d err = _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(TRIPLE_ERR_EXACT_ROW), perm), _mm256_set1_pd(TRIPLE_ABS));
    __m256d nonzero = _mm256_cmp_pd(w, _mm256_setzero_pd(), _CMP_NEQ_OQ);
    *pos = _mm256_and_pd(nonzero, _mm256_cmp_pd(w, err, _CMP_GT_OQ));
    *neg = _mm256_and_pd(nonzero, _mm256_cmp_pd(_mm256_xor_pd(w, _mm256_set1_pd(-0.0)), err, _CMP_GT_OQ));
}

RAY_TRI_AVX2 static unsigned fan_misses_avx2(const ray_fan *fan, const fan_edge g[3])
{
    unsigned miss = 0;
    for (unsigned half = 0; 4 * half < fan->count; half++) {
        __m256d pos01, neg01, pos12, neg12, pos20, neg20;
        fan_edge4(&g[0], fan, half, &pos01, &neg01);
        fan_edge4(&g[1], fan, half, &pos12, &neg12);
        fan_edge4(&g[2], fan, half, &pos20, &neg20);
        __m256d m = _mm256_or_pd(_mm256_and_pd(pos01, neg12), _mm256_and_pd(neg01, pos12));
        m = _mm256_or_pd(m, _mm256_and_pd(pos20, _mm256_or_pd(neg01, neg12)));
        m = _mm256_or_pd(m, _mm256_and_pd(neg20, _mm256_or_pd(pos01, pos12)));
        miss |= (unsigned)_mm256_movemask_pd(m) << (4 * half);
    }
    return miss & ((1u << fan->count) - 1);
}
#endif

unsigned ray_fan_misses(const ray_fan *fan, const vec3 tri[3], int avx2)
{
    if (has_repeated_vertex(tri))
        return (1u << fan->count) - 1;
    fan_edge g[3] = {fan_edge_of(tri[0], tri[1], fan->o), fan_edge_of(tri[1], tri[2], fan->o),
                     fan_edge_of(tri[2], tri[0], fan->o)};
#if defined(__x86_64__)
    if (avx2)
        return fan_misses_avx2(fan, g);
#else
    (void)avx2;
#endif
    return fan_misses_scalar(fan, g);
}

int ray_tri_exact(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3], ray_tri_hit *hit)
{
    return ray_tri_exact_rule(o, d, tmin, tmax, tri, 0, hit);
}

int ray_tri_exact_closed(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3], ray_tri_hit *hit)
{
    return ray_tri_exact_rule(o, d, tmin, tmax, tri, 1, hit);
}

/* ---------------------------------------------------------------- exact ordering */

/* The exact product of two expansions, in caller stack space when it fits. Returns its
 * length; *heap is set when the result had to be allocated (the caller frees it). */
static size_t product_expansion(size_t an, const double *a, size_t bn, const double *b,
                                double *stack_buf, size_t stack_cap, double **out, double **heap)
{
    size_t need = 2 * an * bn;
    *heap = NULL;
    *out = stack_buf;
    if (need > stack_cap) {
        *heap = malloc(need * sizeof(double));
        if (*heap == NULL) {
            /* A few hundred kilobytes for one comparison: with none left the process
             * cannot do useful work, and a guessed order would break exactness silently. */
            fputs("ray_tri_compare_t: out of memory for an exact comparison\n", stderr);
            abort();
        }
        *out = *heap;
    }
    return nonempty(expansion_product(an, a, bn, b, *out), *out);
}

static int compare_t_exact(vec3 o, vec3 d, const vec3 a[3], const vec3 b[3])
{
    predicates_note_fallback();
    plane_exact pa, pb;
    vec3 both[6] = {a[0], a[1], a[2], b[0], b[1], b[2]};
    int k = plane_exact_scale(o, d, both, 6, DEGREE6_MAX_EXP, DEGREE6_MIN_LSB);
    plane_exact_of_scaled(o, d, a, k, &pa);
    plane_exact_of_scaled(o, d, b, k, &pb);
    int sa = expansion_sign(pa.den_len, pa.den), sb = expansion_sign(pb.den_len, pb.den);
    if (sa == 0 || sb == 0)
        return 0;

    /* t_a - t_b = (num_a den_b - num_b den_a) / (den_a den_b) */
    double buf1[STACK_PRODUCT_CAP], buf2[STACK_PRODUCT_CAP];
    double *p1, *p2, *heap1, *heap2;
    size_t n1 = product_expansion(pa.num_len, pa.num, pb.den_len, pb.den, buf1, STACK_PRODUCT_CAP,
                                  &p1, &heap1);
    size_t n2 = product_expansion(pb.num_len, pb.num, pa.den_len, pa.den, buf2, STACK_PRODUCT_CAP,
                                  &p2, &heap2);
    expansion_negate(n2, p2);
    double buf3[2 * STACK_PRODUCT_CAP];
    double *diff = buf3, *heap3 = NULL;
    if (n1 + n2 > 2 * STACK_PRODUCT_CAP) {
        heap3 = malloc((n1 + n2) * sizeof(double));
        if (heap3 == NULL) {
            fputs("ray_tri_compare_t: out of memory for an exact comparison\n", stderr);
            abort();
        }
        diff = heap3;
    }
    size_t dn = expansion_sum(n1, p1, n2, p2, diff);
    int s = dn == 0 ? 0 : expansion_sign(dn, diff);
    free(heap1);
    free(heap2);
    free(heap3);
    return s * sa * sb;
}

int ray_tri_compare_t(vec3 o, vec3 d, const vec3 a[3], const vec3 b[3])
{
    plane_param pa = plane_param_of(o, d, a), pb = plane_param_of(o, d, b);
    int sa = filtered_sign(pa.den, pa.den_err), sb = filtered_sign(pb.den, pb.den_err);
    if (sa != 0 && sb != 0) {
        /* num_a den_b - num_b den_a, each factor off by at most its bound. */
        double p1 = pa.num * pb.den, p2 = pb.num * pa.den;
        double x = p1 - p2;
        double err =
            (fabs(pa.num) * pb.den_err + fabs(pb.den) * pa.num_err + pa.num_err * pb.den_err +
             fabs(pb.num) * pa.den_err + fabs(pa.den) * pb.num_err + pb.num_err * pa.den_err +
             EXPANSION_EPS * (fabs(p1) + fabs(p2)) + COMBINE_ABS) *
            BOUND_SLACK;
        if (isfinite(x) && isfinite(err)) {
            int sx = filtered_sign(x, err);
            if (sx != 0)
                return sx * sa * sb;
        }
    }
    return compare_t_exact(o, d, a, b);
}

/* ---------------------------------------------------------------- seed test */

int ray_tri_seed(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3], double eps,
                 ray_tri_hit *hit)
{
    const vec3 v0 = tri[0], v1 = tri[1], v2 = tri[2];
    vec3 edges[3] = {vec3_sub(v1, v0), vec3_sub(v2, v1), vec3_sub(v0, v2)};
    vec3 n = vec3_cross(edges[0], edges[1]);
    double n2 = vec3_dot(n, n);
    if (!(n2 > 0.0) || !isfinite(n2))
        return 0; /* a zero-area triangle has no plane and no edge normals */
    vec3 unit_n = vec3_scale(n, 1.0 / sqrt(n2));

    /* Plane parameter with eps in the denominator, as the seed guards its 0/0 case. */
    double den = vec3_dot(unit_n, d) + eps;
    if (den == 0.0)
        return 0;
    double t = vec3_dot(unit_n, vec3_sub(v0, o)) / den;
    if (!(t > tmin - eps && t < tmax + eps))
        return 0;
    vec3 p = vec3_add(o, vec3_scale(d, t));

    /* Outside as soon as p is on the outward side of an edge by eps or more. */
    for (int j = 0; j < 3; j++) {
        vec3 edge_normal = vec3_cross(vec3_normalize(edges[j]), unit_n);
        if (!(vec3_dot(edge_normal, vec3_sub(p, tri[j])) < eps))
            return 0;
    }
    if (hit) {
        vec3 w = vec3_sub(p, v0), e02 = vec3_sub(v2, v0);
        /* The test's epsilon accepts t a little outside [tmin, tmax]; the hit is reported
         * at the nearest end of the closed interval the API promises (ray_tri.h). */
        hit->t = t < tmin ? tmin : t > tmax ? tmax : t;
        hit->t_upper = INFINITY;
        hit->u = vec3_dot(vec3_cross(w, e02), n) / n2;
        hit->v = vec3_dot(vec3_cross(edges[0], w), n) / n2;
    }
    return 1;
}

/* ---------------------------------------------------------------- Moller-Trumbore */

/* The paper rejects |det| < 1e-6 in absolute terms, which assumes unit-sized scenes; this
 * cutoff is relative to the edge and direction sizes so it means "parallel" at any scale.
 * It is the paper's value, 2^-20: the octree's walk must visit every node within the
 * distance by which a hit this test accepts can miss the triangle, and that distance
 * grows as 1 / cutoff (server/octree/octree_modes.c); at 1e-12 it was 3% of the scene. */
#define FAST_PARALLEL_CUTOFF 0x1p-20

static inline double max_abs(vec3 a) { return fmax(fabs(a.x), fmax(fabs(a.y), fabs(a.z))); }

int ray_tri_fast(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3], ray_tri_hit *hit)
{
    vec3 e1 = vec3_sub(tri[1], tri[0]), e2 = vec3_sub(tri[2], tri[0]);
    vec3 p = vec3_cross(d, e2);
    double det = vec3_dot(e1, p);
    if (!(fabs(det) > FAST_PARALLEL_CUTOFF * max_abs(e1) * max_abs(e2) * max_abs(d)))
        return 0;
    double inv_det = 1.0 / det;
    vec3 s = vec3_sub(o, tri[0]);
    double u = vec3_dot(s, p) * inv_det;
    if (u < 0.0 || u > 1.0)
        return 0;
    vec3 q = vec3_cross(s, e1);
    double v = vec3_dot(d, q) * inv_det;
    if (v < 0.0 || u + v > 1.0)
        return 0;
    double t = vec3_dot(e2, q) * inv_det;
    if (!(t >= tmin && t <= tmax))
        return 0;
    if (hit) {
        hit->t = t;
        hit->t_upper = INFINITY;
        hit->u = u;
        hit->v = v;
    }
    return 1;
}
