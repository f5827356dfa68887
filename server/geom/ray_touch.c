/* The touch rule: does the closed ray segment share a point with the closed triangle, and
 * at which smallest t. The common case, a line crossing the triangle's plane, is
 * ray_tri_exact with zero edge functions counted as on the triangle; what is left, den == 0
 * exactly (a ray in the triangle's plane, a zero-area triangle), is decided here with
 * exact predicates and exact expansions on inputs scaled by one power of two. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "expansion.h"
#include "predicates.h"
#include "ray_tri.h"

/* ---------------------------------------------------------------- exact values */

/* An exact value as an expansion. The largest one built here is a plane numerator,
 * n . (v0 - o): three minors of at most 16 components times differences of 2, summed. */
#define XP_CAP 192
typedef struct xp {
    size_t n;
    double c[XP_CAP];
} xp;

static void xp_set(xp *x, double a)
{
    x->n = 1;
    x->c[0] = a;
}

static void xp_diff(xp *x, double a, double b)
{
    double hi, lo;
    two_diff(a, b, &hi, &lo);
    x->n = 0;
    if (lo != 0.0)
        x->c[x->n++] = lo;
    x->c[x->n++] = hi; /* hi may be 0: every xp keeps at least one component */
}

static void xp_nonempty(xp *x)
{
    if (x->n == 0)
        x->c[x->n++] = 0.0;
}

/* out = a * b; the caller keeps 2 * a.n * b.n <= XP_CAP (the fixed shapes below do). */
static void xp_mul(const xp *a, const xp *b, xp *out)
{
    out->n = expansion_product(a->n, a->c, b->n, b->c, out->c);
    xp_nonempty(out);
}

static void xp_add(const xp *a, const xp *b, xp *out)
{
    out->n = expansion_sum(a->n, a->c, b->n, b->c, out->c);
    xp_nonempty(out);
}

static void xp_neg(xp *x) { expansion_negate(x->n, x->c); }

static int xp_sign(const xp *x) { return expansion_sign(x->n, x->c); }

/* a1 * b1 - a2 * b2 for expansions of at most 2 components each (16 at most). */
static void xp_minor(const xp *a1, const xp *b1, const xp *a2, const xp *b2, xp *out)
{
    xp left, right;
    xp_mul(a1, b1, &left);
    xp_mul(a2, b2, &right);
    xp_neg(&right);
    xp_add(&left, &right, out);
}

/* ---------------------------------------------------------------- t values */

/* Every smallest common t the rule reports is one of these, each a ratio of exact
 * polynomials in the inputs (den made positive when evaluated):
 *   TV_TMIN   tmin itself (num = tmin, den = 1);
 *   TV_PLANE  the plane parameter n . (v0 - o) / n . d of triangle tri;
 *   TV_EDGE   where the line meets the line of edge p -> q within a coordinate plane (axis
 *             dropped): cross(q - p, p - o) / cross(q - p, d);
 *   TV_POINT  the parameter of point p on the line, (p - o)_axis / d_axis.
 * The TV_PLANE, TV_EDGE and TV_POINT ratios are homogeneous of equal degree in o, d and
 * the vertices, so scaling all of those by one power of two leaves every t unchanged. */
typedef enum { TV_TMIN, TV_PLANE, TV_EDGE, TV_POINT } tv_kind;

typedef struct touch_value {
    tv_kind kind;
    int axis;
    vec3 p, q;
    const vec3 *tri;
} touch_value;

/* The ray and the power of two its exact values are evaluated at. */
typedef struct touch_ctx {
    vec3 o, d;
    double tmin, tmax;
    int shift;
} touch_ctx;

/* Products of two t values' parts reach degree 5 (a plane's 3 times an edge's 2): the
 * bounds ray_tri_compare_t takes for degree 6 keep them exact (factors below 2^161,
 * lowest bits at 2^-175 or above). */
enum { TOUCH_MAX_EXP = 160, TOUCH_MIN_LSB = -175 };

static touch_ctx touch_ctx_make(vec3 o, vec3 d, double tmin, double tmax, const vec3 *vertices, size_t count)
{
    double v[6 + 3 * 6];
    size_t n = 0;
    v[n++] = o.x, v[n++] = o.y, v[n++] = o.z;
    v[n++] = d.x, v[n++] = d.y, v[n++] = d.z;
    for (size_t i = 0; i < count; i++)
        v[n++] = vertices[i].x, v[n++] = vertices[i].y, v[n++] = vertices[i].z;
    touch_ctx c = {o, d, tmin, tmax, predicates_exact_scale_exponent(v, n, TOUCH_MAX_EXP, TOUCH_MIN_LSB)};
    return c;
}

static double scaled(const touch_ctx *c, double x) { return c->shift == 0 ? x : scalbn(x, c->shift); }

static double coord(vec3 p, int axis) { return vec3_get(p, axis); }

/* The two coordinates of p that remain when `axis` is dropped, in predicates_project's
 * cyclic order (so 2D orientations are the sign of the normal's component `axis`). */
static void project(vec3 p, int axis, double *u, double *v) { predicates_project(p, axis, u, v); }

/* The exact num and den of a value (den > 0), compressed. */
static void value_exact(const touch_ctx *c, const touch_value *tv, xp *num, xp *den)
{
    switch (tv->kind) {
    case TV_TMIN:
        xp_set(num, c->tmin);
        xp_set(den, 1.0);
        return;
    case TV_POINT:
        xp_diff(num, scaled(c, coord(tv->p, tv->axis)), scaled(c, coord(c->o, tv->axis)));
        xp_set(den, scaled(c, coord(c->d, tv->axis)));
        break;
    case TV_EDGE: {
        double pu, pv, qu, qv, ou, ov, du, dv;
        project(tv->p, tv->axis, &pu, &pv);
        project(tv->q, tv->axis, &qu, &qv);
        project(c->o, tv->axis, &ou, &ov);
        project(c->d, tv->axis, &du, &dv);
        xp eu, ev, au, av, xu, xv;
        xp_diff(&eu, scaled(c, qu), scaled(c, pu));
        xp_diff(&ev, scaled(c, qv), scaled(c, pv));
        xp_diff(&au, scaled(c, pu), scaled(c, ou));
        xp_diff(&av, scaled(c, pv), scaled(c, ov));
        xp_set(&xu, scaled(c, du));
        xp_set(&xv, scaled(c, dv));
        xp_minor(&eu, &av, &ev, &au, num); /* cross(q - p, p - o) */
        xp_minor(&eu, &xv, &ev, &xu, den); /* cross(q - p, d) */
        break;
    }
    case TV_PLANE: {
        xp e1[3], e2[3], a[3];
        for (int k = 0; k < 3; k++) {
            double v0 = scaled(c, coord(tv->tri[0], k));
            xp_diff(&e1[k], scaled(c, coord(tv->tri[1], k)), v0);
            xp_diff(&e2[k], scaled(c, coord(tv->tri[2], k)), v0);
            xp_diff(&a[k], v0, scaled(c, coord(c->o, k)));
        }
        /* n_k = e1_i e2_j - e1_j e2_i with (i, j) the axes after k in cyclic order; the
         * sums start from the first term, so they stay within 3 x 64 and 3 x 32. */
        for (int k = 0; k < 3; k++) {
            int i = (k + 1) % 3, j = (k + 2) % 3;
            xp n, term, dk, sum;
            xp_minor(&e1[i], &e2[j], &e1[j], &e2[i], &n);
            xp_set(&dk, scaled(c, coord(c->d, k)));
            if (k == 0) {
                xp_mul(&n, &a[k], num);
                xp_mul(&n, &dk, den);
                continue;
            }
            xp_mul(&n, &a[k], &term);
            xp_add(num, &term, &sum);
            *num = sum;
            xp_mul(&n, &dk, &term);
            xp_add(den, &term, &sum);
            *den = sum;
        }
        break;
    }
    }
    if (xp_sign(den) < 0) {
        xp_neg(num);
        xp_neg(den);
    }
    num->n = expansion_compress(num->n, num->c);
    den->n = expansion_compress(den->n, den->c);
}

static double xp_estimate(const xp *x) { return expansion_estimate(x->n, x->c); }

/* A compressed expansion's estimate is within a few ulps of its value, so two values whose
 * estimated ratios differ by more than this relative margin are ordered by the estimates. */
#define ESTIMATE_MARGIN 0x1p-20

static int estimates_decide(double a, double b, int *order)
{
    if (!isfinite(a) || !isfinite(b) || a == b)
        return 0;
    double scale = fmax(fabs(a), fabs(b));
    if (!(scale >= 0x1p-900) || !(fabs(a - b) > ESTIMATE_MARGIN * scale))
        return 0;
    *order = a < b ? -1 : 1;
    return 1;
}

static void fatal_oom(void)
{
    /* As in ray_tri_compare_t: a guessed order would break exactness silently. */
    fputs("ray_tri_touch: out of memory for an exact comparison\n", stderr);
    abort();
}

/* sign(a * b - c * d), exactly, for compressed expansions of any length. */
static int sign_products_difference(const xp *a, const xp *b, const xp *c, const xp *d)
{
    size_t n1 = 2 * a->n * b->n, n2 = 2 * c->n * d->n;
    double stack[1024];
    double *buf = stack, *heap = NULL;
    if (2 * (n1 + n2) > sizeof stack / sizeof stack[0]) {
        heap = malloc(2 * (n1 + n2) * sizeof *heap);
        if (heap == NULL)
            fatal_oom();
        buf = heap;
    }
    double *p1 = buf, *p2 = buf + n1, *sum = buf + n1 + n2;
    size_t l1 = expansion_product(a->n, a->c, b->n, b->c, p1);
    size_t l2 = expansion_product(c->n, c->c, d->n, d->c, p2);
    expansion_negate(l2, p2);
    size_t ls = expansion_sum(l1, p1, l2, p2, sum);
    int s = ls == 0 ? 0 : expansion_sign(ls, sum);
    free(heap);
    return s;
}

/* sign(t_a - t_b), exactly. */
static int value_compare(const touch_ctx *c, const touch_value *a, const touch_value *b)
{
    if (a->kind == TV_TMIN && b->kind == TV_TMIN)
        return 0;
    predicates_note_fallback();
    xp na, da, nb, db;
    value_exact(c, a, &na, &da);
    value_exact(c, b, &nb, &db);
    int order;
    if (estimates_decide(xp_estimate(&na) / xp_estimate(&da), xp_estimate(&nb) / xp_estimate(&db), &order))
        return order;
    return sign_products_difference(&na, &db, &nb, &da);
}

/* sign(t_a - tau), exactly, for a finite or infinite tau. */
static int value_compare_double(const touch_ctx *c, const touch_value *a, double tau)
{
    if (tau == INFINITY)
        return -1;
    if (tau == -INFINITY)
        return 1;
    xp num, den;
    value_exact(c, a, &num, &den);
    double t = xp_estimate(&num) / xp_estimate(&den);
    if (isinf(t))
        return t > 0 ? 1 : -1; /* beyond every finite tau */
    int order;
    if (estimates_decide(t, tau, &order))
        return order;
    /* t is near tau here, so tau * den is near num and cannot overflow. */
    xp x_tau, one;
    xp_set(&x_tau, tau);
    xp_set(&one, 1.0);
    return sign_products_difference(&num, &one, &den, &x_tau);
}

/* The value rounded to double (a few ulps: the compressed parts each within one). */
static double value_double(const touch_ctx *c, const touch_value *tv)
{
    if (tv->kind == TV_TMIN)
        return c->tmin;
    xp num, den;
    value_exact(c, tv, &num, &den);
    return xp_estimate(&num) / xp_estimate(&den);
}

/* ---------------------------------------------------------------- the den == 0 cases */

/* sign of component `axis` of (a - b) x w for a difference a - b and a vector w. */
static int cross_component_sign(vec3 a, vec3 b, vec3 w, int axis)
{
    int i = (axis + 1) % 3, j = (axis + 2) % 3;
    return sign_diff_products(coord(a, i), coord(b, i), coord(w, j), 0.0, coord(a, j), coord(b, j), coord(w, i), 0.0);
}

/* 1 when a - b is parallel to w (their cross product is zero), exactly. */
static int parallel_to(vec3 a, vec3 b, vec3 w)
{
    for (int axis = 0; axis < 3; axis++)
        if (cross_component_sign(a, b, w, axis) != 0)
            return 0;
    return 1;
}

/* The axis of the largest direction component: t of a point on the line is read there. */
static int main_axis(vec3 d)
{
    double ax = fabs(d.x), ay = fabs(d.y), az = fabs(d.z);
    return ax >= ay && ax >= az ? 0 : ay >= az ? 1 : 2;
}

/* Where the parameter interval [lo, hi] of the line's common points meets [tmin, tmax]:
 * 1 with *entry its smallest t (lo, or tmin when lo is below it), else 0. */
static int clip_interval(const touch_ctx *c, const touch_value *lo, const touch_value *hi, touch_value *entry)
{
    if (value_compare_double(c, lo, c->tmax) > 0 || value_compare_double(c, hi, c->tmin) < 0)
        return 0;
    if (value_compare_double(c, lo, c->tmin) > 0)
        *entry = *lo;
    else
        *entry = (touch_value){.kind = TV_TMIN};
    return 1;
}

/* A line in the plane of the nonzero-area triangle, in the coordinate plane with `axis`
 * dropped, where the triangle has orientation s != 0. Each edge v_i -> v_j keeps the
 * points with s * cross(v_j - v_i, P - v_i) >= 0; along P = o + t d that is
 * A + t B >= 0, A = s cross(v_j - v_i, o - v_i), B = s cross(v_j - v_i, d): a lower bound on
 * t where B > 0, an upper one where B < 0, and all or nothing where B == 0. The direction
 * is not parallel to every edge, so both kinds of bound occur. */
static int in_plane_touch(const touch_ctx *c, const vec3 tri[3], int axis, int s, touch_value *entry)
{
    touch_value lo = {.kind = TV_TMIN}, hi = {.kind = TV_TMIN};
    int have_lo = 0, have_hi = 0;
    for (int e = 0; e < 3; e++) {
        vec3 p = tri[e], q = tri[(e + 1) % 3];
        double pu, pv, qu, qv, du, dv;
        project(p, axis, &pu, &pv);
        project(q, axis, &qu, &qv);
        project(c->d, axis, &du, &dv);
        int b = s * sign_diff_products(qu, pu, dv, 0.0, qv, pv, du, 0.0);
        if (b == 0) {
            if (s * orient2d_axis(p, q, c->o, axis) < 0)
                return 0; /* the line runs outside this edge */
            continue;
        }
        touch_value bound = {.kind = TV_EDGE, .axis = axis, .p = p, .q = q};
        if (b > 0 && (!have_lo || value_compare(c, &bound, &lo) > 0)) {
            lo = bound;
            have_lo = 1;
        } else if (b < 0 && (!have_hi || value_compare(c, &bound, &hi) < 0)) {
            hi = bound;
            have_hi = 1;
        }
    }
    if (!have_lo || !have_hi || value_compare(c, &lo, &hi) > 0)
        return 0;
    return clip_interval(c, &lo, &hi, entry);
}

/* A zero-area triangle reduced to the segment p -> q (p != q) or to the point p. */
static int segment_touch(const touch_ctx *c, vec3 p, vec3 q, touch_value *entry)
{
    vec3 o = c->o, d = c->d;
    if (ray_edge_sign(p, q, o, d) != 0)
        return 0; /* the two lines are skew */
    for (int axis = 0; axis < 3; axis++) {
        int n = cross_component_sign(q, p, d, axis);
        if (n == 0)
            continue;
        /* Coplanar and not parallel: one common point of the lines, which must lie
         * between p and q, i.e. p and q on opposite sides of the ray's line (or on it). In
         * this coordinate plane the two lines stay apart from parallel. */
        int sp = cross_component_sign(o, p, d, axis), sq = cross_component_sign(o, q, d, axis);
        if (sp * n < 0 || sq * n > 0)
            return 0;
        touch_value at = {.kind = TV_EDGE, .axis = axis, .p = p, .q = q};
        if (value_compare_double(c, &at, c->tmin) < 0 || value_compare_double(c, &at, c->tmax) > 0)
            return 0;
        *entry = at;
        return 1;
    }
    /* Parallel: common points only when the segment lies on the ray's line. */
    if (!parallel_to(p, o, d))
        return 0;
    int k = main_axis(d);
    touch_value tp = {.kind = TV_POINT, .axis = k, .p = p}, tq = {.kind = TV_POINT, .axis = k, .p = q};
    /* q - p = lambda d with lambda != 0: its sign orders the two along the ray. */
    int forward = (coord(q, k) > coord(p, k)) == (coord(d, k) > 0.0);
    return forward ? clip_interval(c, &tp, &tq, entry) : clip_interval(c, &tq, &tp, entry);
}

static int point_touch(const touch_ctx *c, vec3 p, touch_value *entry)
{
    if (!parallel_to(p, c->o, c->d))
        return 0;
    touch_value at = {.kind = TV_POINT, .axis = main_axis(c->d), .p = p};
    if (value_compare_double(c, &at, c->tmin) < 0 || value_compare_double(c, &at, c->tmax) > 0)
        return 0;
    *entry = at;
    return 1;
}

/* 1 when a before b lexicographically (x, then y, then z): on a line, the order along it. */
static int lex_less(vec3 a, vec3 b)
{
    if (a.x != b.x)
        return a.x < b.x;
    if (a.y != b.y)
        return a.y < b.y;
    return a.z < b.z;
}

/* The den == 0 cases. Returns 1 with *entry the smallest common t, and *u, *v as the
 * header states. */
static int den_zero_touch(const touch_ctx *c, const vec3 tri[3], touch_value *entry, double *u, double *v)
{
    for (int axis = 0; axis < 3; axis++) {
        int s = orient2d_axis(tri[0], tri[1], tri[2], axis);
        if (s == 0)
            continue;
        /* Nonzero area, so den == 0 means d is parallel to the plane: in it, or off it. */
        if (orient3d(tri[0], tri[1], tri[2], c->o) != 0)
            return 0;
        if (!in_plane_touch(c, tri, axis, s, entry))
            return 0;
        if (u != NULL) {
            /* Barycentrics of the rounded point, in the same coordinate plane. */
            double t = value_double(c, entry);
            vec3 pt = vec3_add(c->o, vec3_scale(c->d, t));
            double au, av, bu, bv, cu, cv, pu, pv;
            project(tri[0], axis, &au, &av);
            project(tri[1], axis, &bu, &bv);
            project(tri[2], axis, &cu, &cv);
            project(pt, axis, &pu, &pv);
            double area = (bu - au) * (cv - av) - (bv - av) * (cu - au);
            double b1 = ((pu - au) * (cv - av) - (pv - av) * (cu - au)) / area;
            double b2 = ((bu - au) * (pv - av) - (bv - av) * (pu - au)) / area;
            b1 = isfinite(b1) ? fmin(fmax(b1, 0.0), 1.0) : 0.0;
            b2 = isfinite(b2) ? fmin(fmax(b2, 0.0), 1.0) : 0.0;
            if (b1 + b2 > 1.0) {
                double sum = b1 + b2;
                b1 /= sum;
                b2 /= sum;
            }
            *u = b1;
            *v = b2;
        }
        return 1;
    }
    /* Zero area: the vertices are collinear; the extreme two (in lexicographic order,
     * which on a line is the order along it) bound the segment it is. */
    int lo = 0, hi = 0;
    for (int i = 1; i < 3; i++) {
        if (lex_less(tri[i], tri[lo]))
            lo = i;
        if (lex_less(tri[hi], tri[i]))
            hi = i;
    }
    int hit = lo == hi || vec3_equal(tri[lo], tri[hi]) ? point_touch(c, tri[lo], entry)
                                                       : segment_touch(c, tri[lo], tri[hi], entry);
    if (hit && u != NULL) {
        double w[3] = {0.0, 0.0, 0.0};
        if (vec3_equal(tri[lo], tri[hi])) {
            w[0] = 1.0;
        } else {
            /* The touch point's position from tri[lo] to tri[hi], read on the axis where the
             * segment is longest. */
            double t = value_double(c, entry);
            vec3 pt = vec3_add(c->o, vec3_scale(c->d, t));
            vec3 e = vec3_sub(tri[hi], tri[lo]);
            int k = main_axis(e);
            double s = (coord(pt, k) - coord(tri[lo], k)) / coord(e, k);
            s = isfinite(s) ? fmin(fmax(s, 0.0), 1.0) : 0.0;
            w[lo] += 1.0 - s;
            w[hi] += s;
        }
        *u = w[1];
        *v = w[2];
    }
    return hit;
}

/* ---------------------------------------------------------------- the rule */

static int limits_ok(double tmin, double tmax)
{
    return isfinite(tmin) && tmin <= tmax; /* NaN fails both */
}

int ray_tri_touch(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3], ray_tri_hit *hit)
{
    if (!limits_ok(tmin, tmax))
        return 0;
    int r = ray_tri_exact_closed(o, d, tmin, tmax, tri, hit);
    if (r != RAY_TRI_DEN_ZERO)
        return r;
    touch_ctx c = touch_ctx_make(o, d, tmin, tmax, tri, 3);
    touch_value entry;
    double u = 0.0, v = 0.0;
    if (!den_zero_touch(&c, tri, &entry, &u, &v))
        return 0;
    if (hit != NULL) {
        double t = value_double(&c, &entry);
        /* The exact t lies in [tmin, tmax]; keep the rounded one there too. */
        if (!(t >= tmin))
            t = tmin;
        if (!(t <= tmax))
            t = tmax;
        hit->t = t;
        hit->u = u;
        hit->v = v;
        hit->t_upper = INFINITY;
    }
    return 1;
}

/* The smallest common t of a triangle the rule hits, as a value. A triangle it does not
 * hit has none; it is given tmin's place, which no caller relies on. */
static touch_value entry_of(const touch_ctx *c, const vec3 tri[3], int den_sign)
{
    touch_value tv = {.kind = TV_PLANE, .tri = tri};
    if (den_sign != 0)
        return tv;
    if (den_zero_touch(c, tri, &tv, NULL, NULL))
        return tv;
    return (touch_value){.kind = TV_TMIN};
}

int ray_tri_touch_compare(vec3 o, vec3 d, double tmin, double tmax, const vec3 a[3], const vec3 b[3])
{
    /* den = ((v1 - v0) x (v2 - v0)) . d, exactly. */
    int da = ray_edge_sign(a[1], a[2], a[0], d), db = ray_edge_sign(b[1], b[2], b[0], d);
    if (da != 0 && db != 0)
        return ray_tri_compare_t(o, d, a, b);
    vec3 both[6] = {a[0], a[1], a[2], b[0], b[1], b[2]};
    touch_ctx c = touch_ctx_make(o, d, tmin, tmax, both, 6);
    touch_value ta = entry_of(&c, a, da), tb = entry_of(&c, b, db);
    return value_compare(&c, &ta, &tb);
}
