/* Exact reference answers for tests: every question becomes "does A x = b have a solution
 * with x >= 0?" over GMP rationals, decided by enumerating basic solutions. Slow on purpose. */
#include "oracle.h"

#include <assert.h>
#include <math.h>

#include <gmp.h>

/* Five rows cover the largest question (three coordinates and two weight sums); sixteen
 * columns are the weights of two eight-point sets. */
#define LP_MAX_ROWS 5
#define LP_MAX_COLS 16

/* The system A x = b, x >= 0. */
typedef struct exact_lp {
    int rows, cols;
    mpq_t coef[LP_MAX_ROWS][LP_MAX_COLS];
    mpq_t rhs[LP_MAX_ROWS];
} exact_lp;

static void lp_init(exact_lp *lp, int rows, int cols)
{
    assert(rows >= 1 && rows <= LP_MAX_ROWS);
    assert(cols >= 1 && cols <= LP_MAX_COLS);
    lp->rows = rows;
    lp->cols = cols;
    for (int r = 0; r < LP_MAX_ROWS; r++) {
        for (int c = 0; c < LP_MAX_COLS; c++)
            mpq_init(lp->coef[r][c]);
        mpq_init(lp->rhs[r]);
    }
}

static void lp_clear(exact_lp *lp)
{
    for (int r = 0; r < LP_MAX_ROWS; r++) {
        for (int c = 0; c < LP_MAX_COLS; c++)
            mpq_clear(lp->coef[r][c]);
        mpq_clear(lp->rhs[r]);
    }
}

static double coord(vec3 p, int axis) { return axis == 0 ? p.x : axis == 1 ? p.y : p.z; }

static void assert_finite_point(vec3 p)
{
    assert(isfinite(p.x) && isfinite(p.y) && isfinite(p.z));
    (void)p;
}

/* Gauss-Jordan on [A_S | b] for the columns S listed in support[0..k). Returns 1 when the
 * columns are independent, the restricted system is consistent and its (then unique)
 * solution is nonnegative. w, factor and product are scratch space. */
static int support_gives_nonnegative_solution(const exact_lp *lp, const int *support, int k,
                                               mpq_t w[LP_MAX_ROWS][LP_MAX_ROWS + 1],
                                               mpq_t factor, mpq_t product)
{
    const int m = lp->rows;
    for (int r = 0; r < m; r++) {
        for (int j = 0; j < k; j++)
            mpq_set(w[r][j], lp->coef[r][support[j]]);
        mpq_set(w[r][k], lp->rhs[r]);
    }
    for (int c = 0; c < k; c++) {
        int pivot = c;
        while (pivot < m && mpq_sgn(w[pivot][c]) == 0)
            pivot++;
        if (pivot == m)
            return 0; /* dependent columns: a smaller support covers any solution here */
        if (pivot != c)
            for (int j = 0; j <= k; j++)
                mpq_swap(w[pivot][j], w[c][j]);
        for (int j = c + 1; j <= k; j++)
            mpq_div(w[c][j], w[c][j], w[c][c]);
        mpq_set_ui(w[c][c], 1, 1);
        for (int r = 0; r < m; r++) {
            if (r == c || mpq_sgn(w[r][c]) == 0)
                continue;
            mpq_set(factor, w[r][c]);
            for (int j = c; j <= k; j++) {
                mpq_mul(product, factor, w[c][j]);
                mpq_sub(w[r][j], w[r][j], product);
            }
        }
    }
    for (int r = k; r < m; r++)
        if (mpq_sgn(w[r][k]) != 0)
            return 0; /* b is not in the span of these columns */
    for (int c = 0; c < k; c++)
        if (mpq_sgn(w[c][k]) < 0)
            return 0;
    return 1;
}

/* If A x = b has a solution x >= 0, one of minimal support has linearly independent
 * support columns (otherwise a null-space direction of those columns could be followed
 * until one more weight reaches zero). Restricted to independent columns the solution is
 * unique, so trying every independent column subset of size <= rows finds it. */
static int lp_has_nonnegative_solution(const exact_lp *lp)
{
    mpq_t w[LP_MAX_ROWS][LP_MAX_ROWS + 1];
    mpq_t factor, product;
    for (int r = 0; r < LP_MAX_ROWS; r++)
        for (int j = 0; j <= LP_MAX_ROWS; j++)
            mpq_init(w[r][j]);
    mpq_init(factor);
    mpq_init(product);

    int feasible = 0;
    const unsigned long subsets = 1ul << lp->cols;
    for (unsigned long mask = 0; mask < subsets && !feasible; mask++) {
        int support[LP_MAX_COLS];
        int k = 0;
        for (int c = 0; c < lp->cols; c++)
            if (mask & (1ul << c))
                support[k++] = c;
        if (k > lp->rows)
            continue; /* more columns than rows are always dependent */
        feasible = support_gives_nonnegative_solution(lp, support, k, w, factor, product);
    }

    mpq_clear(factor);
    mpq_clear(product);
    for (int r = 0; r < LP_MAX_ROWS; r++)
        for (int j = 0; j <= LP_MAX_ROWS; j++)
            mpq_clear(w[r][j]);
    return feasible;
}

int oracle_hulls_intersect(const vec3 *a, int na, const vec3 *b, int nb)
{
    assert(na >= 1 && na <= 8 && nb >= 1 && nb <= 8);
    exact_lp lp;
    lp_init(&lp, 5, na + nb);
    /* Rows 0-2: sum l_i a_i - sum m_j b_j = 0; row 3: sum l_i = 1; row 4: sum m_j = 1. */
    for (int i = 0; i < na; i++) {
        assert_finite_point(a[i]);
        for (int axis = 0; axis < 3; axis++)
            mpq_set_d(lp.coef[axis][i], coord(a[i], axis));
        mpq_set_ui(lp.coef[3][i], 1, 1);
    }
    for (int j = 0; j < nb; j++) {
        assert_finite_point(b[j]);
        for (int axis = 0; axis < 3; axis++) {
            mpq_set_d(lp.coef[axis][na + j], coord(b[j], axis));
            mpq_neg(lp.coef[axis][na + j], lp.coef[axis][na + j]);
        }
        mpq_set_ui(lp.coef[4][na + j], 1, 1);
    }
    mpq_set_ui(lp.rhs[3], 1, 1);
    mpq_set_ui(lp.rhs[4], 1, 1);
    int result = lp_has_nonnegative_solution(&lp);
    lp_clear(&lp);
    return result;
}

int oracle_tri_tri(const vec3 a[3], const vec3 b[3]) { return oracle_hulls_intersect(a, 3, b, 3); }

int oracle_tri_box(const vec3 tri[3], box3 box)
{
    assert(box.lo.x <= box.hi.x && box.lo.y <= box.hi.y && box.lo.z <= box.hi.z);
    vec3 corners[8];
    for (int i = 0; i < 8; i++) {
        corners[i].x = (i & 1) ? box.hi.x : box.lo.x;
        corners[i].y = (i & 2) ? box.hi.y : box.lo.y;
        corners[i].z = (i & 4) ? box.hi.z : box.lo.z;
    }
    return oracle_hulls_intersect(tri, 3, corners, 8);
}

/* Adds a nonnegative unknown s that moves the ray point by sign * s * d, i.e. contributes
 * -sign * d to the coordinate rows (the triangle point sits on the left-hand side). */
static void lp_set_ray_column(exact_lp *lp, int col, int sign, vec3 d)
{
    for (int axis = 0; axis < 3; axis++) {
        mpq_set_d(lp->coef[axis][col], coord(d, axis));
        if (sign > 0)
            mpq_neg(lp->coef[axis][col], lp->coef[axis][col]);
    }
}

/* The ray-triangle question as a system: columns 0-2 the triangle's weights, column 3 the
 * s that moves t away from the finite end (t = tmin + s when tmin is finite), column 4 the
 * slack of a bounded interval or, for a line, the second half of t = s_plus - s_minus. */
static void ray_lp_build(exact_lp *lp, vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3])
{
    assert_finite_point(o);
    assert_finite_point(d);
    assert(tri != NULL);
    assert(!isnan(tmin) && !isnan(tmax));
    assert(tmin < INFINITY && tmax > -INFINITY);

    /* t = anchor + s (or anchor - s) with s >= 0, anchored at whichever end is finite; a
     * finite other end adds s + slack = tmax - tmin; a line gets t = s_plus - s_minus. */
    const int lower_finite = isfinite(tmin), upper_finite = isfinite(tmax);
    const int bounded = lower_finite && upper_finite;
    const int line = !lower_finite && !upper_finite;
    const double anchor = lower_finite ? tmin : upper_finite ? tmax : 0.0;
    const int rows = bounded ? 5 : 4;
    const int cols = 3 + 1 + (bounded || line ? 1 : 0);

    lp_init(lp, rows, cols);
    for (int i = 0; i < 3; i++) {
        assert_finite_point(tri[i]);
        for (int axis = 0; axis < 3; axis++)
            mpq_set_d(lp->coef[axis][i], coord(tri[i], axis));
        mpq_set_ui(lp->coef[3][i], 1, 1);
    }
    mpq_set_ui(lp->rhs[3], 1, 1);

    if (line) {
        lp_set_ray_column(lp, 3, +1, d);
        lp_set_ray_column(lp, 4, -1, d);
    } else {
        lp_set_ray_column(lp, 3, lower_finite ? +1 : -1, d);
    }

    mpq_t q_anchor, q_term;
    mpq_init(q_anchor);
    mpq_init(q_term);
    mpq_set_d(q_anchor, anchor);
    for (int axis = 0; axis < 3; axis++) { /* rhs = o + anchor * d */
        mpq_set_d(q_term, coord(d, axis));
        mpq_mul(q_term, q_term, q_anchor);
        mpq_set_d(lp->rhs[axis], coord(o, axis));
        mpq_add(lp->rhs[axis], lp->rhs[axis], q_term);
    }
    if (bounded) { /* s + slack = tmax - tmin; negative when the interval is empty */
        mpq_set_ui(lp->coef[4][3], 1, 1);
        mpq_set_ui(lp->coef[4][4], 1, 1);
        mpq_set_d(q_term, tmin);
        mpq_set_d(lp->rhs[4], tmax);
        mpq_sub(lp->rhs[4], lp->rhs[4], q_term);
    }
    mpq_clear(q_term);
    mpq_clear(q_anchor);
}

int oracle_ray_tri(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3])
{
    exact_lp lp;
    ray_lp_build(&lp, o, d, tmin, tmax, tri);
    int result = lp_has_nonnegative_solution(&lp);
    lp_clear(&lp);
    return result;
}

/* The smallest x_col over the nonnegative solutions of A x = b: a linear function bounded
 * below on a polyhedron in x >= 0 takes its minimum at a vertex, and the vertices are the
 * nonnegative basic solutions, which the same enumeration as above visits. Returns 0 when
 * there is no solution. */
static int lp_min_of_column(const exact_lp *lp, int col, mpq_t best)
{
    mpq_t w[LP_MAX_ROWS][LP_MAX_ROWS + 1];
    mpq_t factor, product;
    for (int r = 0; r < LP_MAX_ROWS; r++)
        for (int j = 0; j <= LP_MAX_ROWS; j++)
            mpq_init(w[r][j]);
    mpq_init(factor);
    mpq_init(product);
    int found = 0;
    const unsigned long subsets = 1ul << lp->cols;
    for (unsigned long mask = 0; mask < subsets; mask++) {
        int support[LP_MAX_COLS];
        int k = 0, at = -1;
        for (int c = 0; c < lp->cols; c++) {
            if (mask & (1ul << c)) {
                if (c == col)
                    at = k;
                support[k++] = c;
            }
        }
        if (k > lp->rows || !support_gives_nonnegative_solution(lp, support, k, w, factor, product))
            continue;
        /* The solution of support column j is w[j][k]; a column left out is 0. */
        if (at < 0)
            mpq_set_ui(product, 0, 1);
        else
            mpq_set(product, w[at][k]);
        if (!found || mpq_cmp(product, best) < 0)
            mpq_set(best, product);
        found = 1;
    }
    mpq_clear(factor);
    mpq_clear(product);
    for (int r = 0; r < LP_MAX_ROWS; r++)
        for (int j = 0; j <= LP_MAX_ROWS; j++)
            mpq_clear(w[r][j]);
    return found;
}

/* The smallest common t, exactly: tmin + min s. */
static int first_t(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3], mpq_t t)
{
    assert(isfinite(tmin));
    exact_lp lp;
    ray_lp_build(&lp, o, d, tmin, tmax, tri);
    int found = lp_min_of_column(&lp, 3, t);
    lp_clear(&lp);
    if (found) {
        mpq_t q_tmin;
        mpq_init(q_tmin);
        mpq_set_d(q_tmin, tmin);
        mpq_add(t, t, q_tmin);
        mpq_clear(q_tmin);
    }
    return found;
}

int oracle_ray_tri_first_t_compare(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3], double t)
{
    mpq_t exact, q;
    mpq_init(exact);
    mpq_init(q);
    int result = ORACLE_NO_CONTACT;
    if (first_t(o, d, tmin, tmax, tri, exact)) {
        mpq_set_d(q, t);
        int c = mpq_cmp(exact, q);
        result = (c > 0) - (c < 0);
    }
    mpq_clear(exact);
    mpq_clear(q);
    return result;
}

double oracle_ray_tri_first_t(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3])
{
    mpq_t exact;
    mpq_init(exact);
    double t = NAN;
    if (first_t(o, d, tmin, tmax, tri, exact))
        t = mpq_get_d(exact);
    mpq_clear(exact);
    return t;
}

int oracle_ray_tri_first_t_order(vec3 o, vec3 d, double tmin, double tmax, const vec3 a[3], const vec3 b[3])
{
    mpq_t ta, tb;
    mpq_init(ta);
    mpq_init(tb);
    int ha = first_t(o, d, tmin, tmax, a, ta), hb = first_t(o, d, tmin, tmax, b, tb);
    assert(ha && hb && "both triangles must share a point with the ray");
    (void)ha;
    (void)hb;
    int c = mpq_cmp(ta, tb);
    mpq_clear(ta);
    mpq_clear(tb);
    return (c > 0) - (c < 0);
}

/* t = n.(v0 - o) / n.d with n = (v1 - v0) x (v2 - v0), all in rationals. */
static void exact_plane_t(mpq_t t, vec3 o, vec3 d, const vec3 tri[3])
{
    mpq_t v0[3], e1[3], e2[3], n[3], od[3], tmp, num, den;
    for (int i = 0; i < 3; i++) {
        mpq_inits(v0[i], e1[i], e2[i], n[i], od[i], (mpq_ptr)0);
        assert_finite_point(tri[i]);
    }
    mpq_inits(tmp, num, den, (mpq_ptr)0);
    for (int axis = 0; axis < 3; axis++) {
        mpq_set_d(v0[axis], coord(tri[0], axis));
        mpq_set_d(e1[axis], coord(tri[1], axis));
        mpq_sub(e1[axis], e1[axis], v0[axis]);
        mpq_set_d(e2[axis], coord(tri[2], axis));
        mpq_sub(e2[axis], e2[axis], v0[axis]);
    }
    for (int axis = 0; axis < 3; axis++) {
        const int p = (axis + 1) % 3, q = (axis + 2) % 3;
        mpq_mul(n[axis], e1[p], e2[q]);
        mpq_mul(tmp, e1[q], e2[p]);
        mpq_sub(n[axis], n[axis], tmp);
    }
    for (int axis = 0; axis < 3; axis++) {
        mpq_set_d(od[axis], coord(o, axis));
        mpq_sub(od[axis], v0[axis], od[axis]); /* v0 - o */
        mpq_mul(tmp, n[axis], od[axis]);
        mpq_add(num, num, tmp);
        mpq_set_d(tmp, coord(d, axis));
        mpq_mul(tmp, n[axis], tmp);
        mpq_add(den, den, tmp);
    }
    assert(mpq_sgn(den) != 0 && "ray parallel to the plane, or degenerate triangle");
    mpq_div(t, num, den);
    mpq_clears(tmp, num, den, (mpq_ptr)0);
    for (int i = 0; i < 3; i++)
        mpq_clears(v0[i], e1[i], e2[i], n[i], od[i], (mpq_ptr)0);
}

int oracle_compare_plane_t(vec3 o, vec3 d, const vec3 a[3], const vec3 b[3])
{
    assert_finite_point(o);
    assert_finite_point(d);
    mpq_t ta, tb;
    mpq_init(ta);
    mpq_init(tb);
    exact_plane_t(ta, o, d, a);
    exact_plane_t(tb, o, d, b);
    const int cmp = mpq_cmp(ta, tb);
    mpq_clear(ta);
    mpq_clear(tb);
    return (cmp > 0) - (cmp < 0);
}

/* The sign of n.d, n = (v1 - v0) x (v2 - v0), and whether n is zero, in rationals. */
static void exact_normal_and_dot(vec3 d, const vec3 tri[3], int *normal_zero, int *dot_sign)
{
    mpq_t e1[3], e2[3], n[3], tmp, dot;
    for (int i = 0; i < 3; i++)
        mpq_inits(e1[i], e2[i], n[i], (mpq_ptr)0);
    mpq_inits(tmp, dot, (mpq_ptr)0);
    for (int axis = 0; axis < 3; axis++) {
        mpq_set_d(e1[axis], coord(tri[1], axis));
        mpq_set_d(tmp, coord(tri[0], axis));
        mpq_sub(e1[axis], e1[axis], tmp);
        mpq_set_d(e2[axis], coord(tri[2], axis));
        mpq_sub(e2[axis], e2[axis], tmp);
    }
    *normal_zero = 1;
    for (int axis = 0; axis < 3; axis++) {
        const int p = (axis + 1) % 3, q = (axis + 2) % 3;
        mpq_mul(n[axis], e1[p], e2[q]);
        mpq_mul(tmp, e1[q], e2[p]);
        mpq_sub(n[axis], n[axis], tmp);
        *normal_zero &= mpq_sgn(n[axis]) == 0;
        mpq_set_d(tmp, coord(d, axis));
        mpq_mul(tmp, n[axis], tmp);
        mpq_add(dot, dot, tmp);
    }
    *dot_sign = mpq_sgn(dot);
    mpq_clears(tmp, dot, (mpq_ptr)0);
    for (int i = 0; i < 3; i++)
        mpq_clears(e1[i], e2[i], n[i], (mpq_ptr)0);
}

int oracle_ray_tri_contact(vec3 o, vec3 d, double tmin, double tmax, const vec3 tri[3])
{
    if (!oracle_ray_tri(o, d, tmin, tmax, tri))
        return ORACLE_RAY_MISS;
    int normal_zero, dot_sign;
    exact_normal_and_dot(d, tri, &normal_zero, &dot_sign);
    if (normal_zero)
        return ORACLE_RAY_ZERO_AREA;
    if (dot_sign == 0)
        return ORACLE_RAY_IN_PLANE;
    /* A triangle with a repeated corner is its edge: the same question for a segment. */
    for (int k = 0; k < 3; k++) {
        const vec3 edge[3] = {tri[k], tri[(k + 1) % 3], tri[(k + 1) % 3]};
        if (oracle_ray_tri(o, d, tmin, tmax, edge))
            return ORACLE_RAY_BOUNDARY;
    }
    return ORACLE_RAY_INTERIOR;
}

double oracle_plane_t(vec3 o, vec3 d, const vec3 tri[3])
{
    mpq_t t;
    mpq_init(t);
    exact_plane_t(t, o, d, tri);
    const double r = mpq_get_d(t);
    mpq_clear(t);
    return r;
}
