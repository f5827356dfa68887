/* Closed triangle against closed axis-aligned box: the exact separating-axis test used to
 * build and descend the octree, the seed document's epsilon test, and the plain double test. */
#include "tri_box.h"

#include <float.h>
#include <string.h>

#include "box_geometry.h"
#include "lanes4.h"
#include "predicates.h"

/* ---------- exact ---------- */

/* Why these axes decide every input, including zero-area triangles.
 *
 * The triangle T and box B are disjoint iff the origin lies outside the Minkowski
 * difference B - T, a convex polytope, iff some facet normal of B - T separates them. The
 * facet normals of a Minkowski sum are facet normals of either part and cross products of
 * an edge direction of one with an edge direction of the other. For a triangle of nonzero
 * area that gives the 13 classic axes: the 3 box axes, the triangle normal, and the 9
 * products edge x box axis. An edge parallel to a box axis yields no facet (the two edges
 * only lengthen one another), so skipping its zero product loses nothing.
 *
 * A zero-area triangle is the segment between its two extreme vertices, or a point. A
 * segment has no facet of its own, so B - T has only the box axes and d x box axis (d the
 * segment's direction) as facet normals. Every edge of a collinear triangle is either zero
 * or parallel to d, so the edge x axis tests below include every d x box axis, and they
 * project all three vertices, so the triangle's interval on each is the segment's. The
 * normal test is vacuous for it (the normal is zero and is skipped). A point is decided by
 * the box axes alone, which the bounding-box rejection and the vertex-inside acceptance
 * cover. So the same code is exact for triangles, segments and points. */

/* The separating test along u_k x (q - p) for edge p -> q (third vertex r), with the
 * values projected relative to p: f(x) = ((x - p) x (q - p))_k, which is 0 at p and q and
 * w = f(r) at the third vertex, so the triangle covers [min(0, w), max(0, w)]. w is minus
 * component k of the triangle's normal, so its sign is known exactly from the
 * preparation, and each side of the interval is one comparison. f depends only on the two
 * coordinates i, j other than k, so the box covers [f(m), f(M)] with m, M the corners of
 * its projected rectangle picked by the signs of (q - p)_i and (q - p)_j.
 * Every comparison is the sign of an expression (a - b)(c - d) - (e - f)(g - h): f(x)
 * itself, or f(x) - w = ((x - r) x (q - p))_k. The filter is sign_diff_products' with the
 * box-independent factors c - d and g - h taken from the preparation (the same roundings,
 * done once); an undecided sign goes to the same exact stage with the original operands. */
static inline int prepared_sign(double a, double b, double c_minus_d, double e, double f, double g_minus_h,
                                double c, double d, double g, double h)
{
    int sign = products_difference_filter((a - b) * c_minus_d, (e - f) * g_minus_h);
    return sign != PREDICATES_UNDECIDED ? sign : sign_diff_products_undecided(a, b, c, d, e, f, g, h);
}

static int edge_axis_separates(const tri_box_triangle *t, int edge, int k, const double lo[3], const double hi[3])
{
    int i = k == 2 ? 0 : k + 1;
    int j = k == 0 ? 2 : k - 1;
    /* A rounded difference has the exact difference's sign, so these decide exactly. */
    double dj = t->edge_delta[edge][j], di = t->edge_delta[edge][i];
    if (di == 0.0 && dj == 0.0)
        return 0; /* the edge is parallel to axis k or has zero length: no axis */
    const double *p = t->v[edge], *q = t->v[edge == 2 ? 0 : edge + 1], *r = t->v[edge == 0 ? 2 : edge - 1];
    int w_sign = -t->normal_sign[k];

    /* f grows with x_i when (q - p)_j > 0 and falls with x_j when (q - p)_i > 0. */
    double m_i = dj > 0 ? lo[i] : hi[i];
    double m_j = di > 0 ? hi[j] : lo[j];
    double big_i = dj > 0 ? hi[i] : lo[i];
    double big_j = di > 0 ? lo[j] : hi[j];

    /* Box wholly above the triangle: f(m) > max(0, w). */
    const double *top = w_sign > 0 ? r : p;
    if (prepared_sign(m_i, top[i], dj, m_j, top[j], di, q[j], p[j], q[i], p[i]) > 0)
        return 1;
    /* Box wholly below: f(M) < min(0, w). */
    const double *bottom = w_sign < 0 ? r : p;
    return prepared_sign(big_i, bottom[i], dj, big_j, bottom[j], di, q[j], p[j], q[i], p[i]) < 0;
}

/* The plane of the triangle separates iff the box corner lowest along the normal is
 * strictly above it or the highest is strictly below; the exact sign of each normal
 * component picks those corners, orient3d places them. */
static int normal_axis_separates(const tri_box_triangle *t, const double lo[3], const double hi[3])
{
    const int *n = t->normal_sign;
    if (n[0] == 0 && n[1] == 0 && n[2] == 0)
        return 0; /* zero area: no plane */
    vec3 lowest = vec3_make(n[0] > 0 ? lo[0] : hi[0], n[1] > 0 ? lo[1] : hi[1], n[2] > 0 ? lo[2] : hi[2]);
    int below = orient3d_plane_filter(&t->plane, lowest);
    if (below == PREDICATES_UNDECIDED)
        below = orient3d_plane_exact(&t->plane, lowest);
    if (below > 0)
        return 1;
    vec3 highest = vec3_make(n[0] > 0 ? hi[0] : lo[0], n[1] > 0 ? hi[1] : lo[1], n[2] > 0 ? hi[2] : lo[2]);
    int above = orient3d_plane_filter(&t->plane, highest);
    if (above == PREDICATES_UNDECIDED)
        above = orient3d_plane_exact(&t->plane, highest);
    return above < 0;
}

void tri_box_prepare(tri_box_triangle *t, const vec3 tri[3])
{
    for (int n = 0; n < 3; n++) {
        t->v[n][0] = tri[n].x;
        t->v[n][1] = tri[n].y;
        t->v[n][2] = tri[n].z;
    }
    for (int k = 0; k < 3; k++) {
        double a = t->v[0][k], b = t->v[1][k], c = t->v[2][k];
        t->lo[k] = a < b ? (a < c ? a : c) : (b < c ? b : c);
        t->hi[k] = a > b ? (a > c ? a : c) : (b > c ? b : c);
    }
    t->ready = 0;
    t->lanes_ready = 0;
}

static void prepare_axes(tri_box_triangle *t)
{
    vec3 tri[3];
    for (int n = 0; n < 3; n++)
        tri[n] = vec3_make(t->v[n][0], t->v[n][1], t->v[n][2]);
    t->plane = orient3d_plane_make(tri[0], tri[1], tri[2]);
    /* Component k of the normal is orient2d_axis(tri[1], tri[2], tri[0], k), whose filter
     * computes the same two products the plane's minor k is the difference of, with the
     * same roundings; the plane's permanent (their magnitudes plus a pad) only enlarges
     * the filter's bound. So the minor decides the sign where it is clear, and only the
     * rest take the full predicate. */
    const double minor[3] = {t->plane.minor.x, t->plane.minor.y, t->plane.minor.z};
    const double permanent[3] = {t->plane.permanent.x, t->plane.permanent.y, t->plane.permanent.z};
    for (int k = 0; k < 3; k++) {
        double bound = PREDICATES_ERRBOUND_DIFF_PRODUCTS * permanent[k] + PREDICATES_UNDERFLOW_ABSOLUTE;
        t->normal_sign[k] = minor[k] != 0.0 && fabs(minor[k]) > bound ? (minor[k] > 0.0) - (minor[k] < 0.0)
                                                                       : orient2d_axis(tri[1], tri[2], tri[0], k);
    }
    for (int e = 0; e < 3; e++) {
        const double *p = t->v[e], *q = t->v[e == 2 ? 0 : e + 1];
        for (int k = 0; k < 3; k++)
            t->edge_delta[e][k] = q[k] - p[k];
    }
    t->ready = 1;
}

int tri_box_overlap_prepared(tri_box_triangle *t, box3 box)
{
    const double lo[3] = {box.lo.x, box.lo.y, box.lo.z}, hi[3] = {box.hi.x, box.hi.y, box.hi.z};

    /* The box axes: plain comparisons are exact. */
    for (int k = 0; k < 3; k++)
        if (t->lo[k] > hi[k] || t->hi[k] < lo[k])
            return 0;
    for (int n = 0; n < 3; n++) {
        const double *v = t->v[n];
        if (v[0] >= lo[0] && v[0] <= hi[0] && v[1] >= lo[1] && v[1] <= hi[1] && v[2] >= lo[2] && v[2] <= hi[2])
            return 1;
    }
    /* The build and the triangle descent call this only for children that no vertex and no
     * edge's crossing of a split plane has shown touched (tri_box_children_proven), and
     * nine in ten of those are not: so no other point of the triangle is tried first, and
     * the axes come next (an edge midpoint or the centroid inside the box settled 3-9% of
     * these calls and cost more than it saved). */
    if (!t->ready)
        prepare_axes(t);
    if (normal_axis_separates(t, lo, hi))
        return 0;
    for (int k = 0; k < 3; k++)
        for (int e = 0; e < 3; e++)
            if (edge_axis_separates(t, e, k, lo, hi))
                return 0;
    return 1;
}

/* ---------- the filters of the exact test, for many children ---------- */

/* What the float filters alone make of a box's axes. */
enum { FILTERED_APART, FILTERED_TOUCHING, FILTERED_UNDECIDED };

/* tri_box_triangle.lanes, from a triangle whose axes are prepared. */
static inline __attribute__((always_inline)) void fill_lanes(tri_box_triangle *t)
{
    /* edge_axis_separates' operands, per edge and axis (see tri_box_triangle.lanes):
     * lane
     * k reads coordinates i = k + 1 and j = k + 2 (mod 3). Built as lanes, the same
     * differences as edge_delta's. */
    lanes4 vi[3], vj[3];
    for (int n = 0; n < 3; n++) {
        vi[n] = (lanes4){t->v[n][1], t->v[n][2], t->v[n][0], 0};
        vj[n] = (lanes4){t->v[n][2], t->v[n][0], t->v[n][1], 0};
    }
    /* The test above the triangle measures from the third vertex r when the normal's
     * component k is negative (w > 0 there), the one below when it is positive, else
     * both from the edge's start p. */
    const int *ns = t->normal_sign;
    mask4 negative = {-(long long)(ns[0] < 0), -(long long)(ns[1] < 0), -(long long)(ns[2] < 0), 0};
    mask4 positive = {-(long long)(ns[0] > 0), -(long long)(ns[1] > 0), -(long long)(ns[2] > 0), 0};
    const lanes4 zero = {0, 0, 0, 0};
    for (int e = 0; e < 3; e++) {
        int p = e, q = e == 2 ? 0 : e + 1, r = e == 0 ? 2 : e - 1;
        lanes4 di = vi[q] - vi[p], dj = vj[q] - vj[p];
        lanes4 above_i = PICK4(negative, vi[r], vi[p]), above_j = PICK4(negative, vj[r], vj[p]);
        lanes4 below_i = PICK4(positive, vi[r], vi[p]), below_j = PICK4(positive, vj[r], vj[p]);
        mask4 active = (di != zero) | (dj != zero);
        memcpy(t->lanes.di[e], &di, sizeof di);
        memcpy(t->lanes.dj[e], &dj, sizeof dj);
        memcpy(t->lanes.above_i[e], &above_i, sizeof above_i);
        memcpy(t->lanes.above_j[e], &above_j, sizeof above_j);
        memcpy(t->lanes.below_i[e], &below_i, sizeof below_i);
        memcpy(t->lanes.below_j[e], &below_j, sizeof below_j);
        memcpy(t->lanes.active[e], &active, sizeof active);
    }
    t->lanes_ready = 1;
}

/* tri_box_overlap_prepared's separating axes, the vertex test left out (the build asks
 * only about children no vertex lies in), the others by their float filters alone: the same expressions with the same
 * roundings as normal_axis_separates' orient3d_plane_filter and edge_axis_separates'
 * prepared_sign, the corner choices made by bits, so a decided sign is the exact sign.
 * Apart when some axis is decided separating, touching when every axis is decided not
 * separating, else undecided. */
static inline __attribute__((always_inline)) int filtered_axes(const tri_box_triangle *t, const box3 *box)
{
    /* The box axes, exactly (the build's children always pass them). */
    if ((t->lo[0] > box->hi.x) | (t->hi[0] < box->lo.x) | (t->lo[1] > box->hi.y) | (t->hi[1] < box->lo.y) |
        (t->lo[2] > box->hi.z) | (t->hi[2] < box->lo.z))
        return FILTERED_APART;
    const int *n = t->normal_sign;
    int undecided = 0;
    if (n[0] != 0 || n[1] != 0 || n[2] != 0) {
        vec3 lowest = vec3_make(n[0] > 0 ? box->lo.x : box->hi.x, n[1] > 0 ? box->lo.y : box->hi.y,
                                n[2] > 0 ? box->lo.z : box->hi.z);
        int below = orient3d_plane_filter(&t->plane, lowest);
        if (below == 1)
            return FILTERED_APART;
        vec3 highest = vec3_make(n[0] > 0 ? box->hi.x : box->lo.x, n[1] > 0 ? box->hi.y : box->lo.y,
                                 n[2] > 0 ? box->hi.z : box->lo.z);
        int above = orient3d_plane_filter(&t->plane, highest);
        if (above == -1)
            return FILTERED_APART;
        undecided = below == PREDICATES_UNDECIDED || above == PREDICATES_UNDECIDED;
    }
    /* Lane k reads coordinates i, j = k + 1, k + 2 (mod 3) of the box; lane 3, which is
     * never active, repeats lane 0. */
    const lanes4 lo_i = {box->lo.y, box->lo.z, box->lo.x, box->lo.y};
    const lanes4 hi_i = {box->hi.y, box->hi.z, box->hi.x, box->hi.y};
    const lanes4 lo_j = {box->lo.z, box->lo.x, box->lo.y, box->lo.z};
    const lanes4 hi_j = {box->hi.z, box->hi.x, box->hi.y, box->hi.z};
    const lanes4 zero = {0, 0, 0, 0};
    const lanes4 err = {PREDICATES_ERRBOUND_DIFF_PRODUCTS, PREDICATES_ERRBOUND_DIFF_PRODUCTS,
                        PREDICATES_ERRBOUND_DIFF_PRODUCTS, PREDICATES_ERRBOUND_DIFF_PRODUCTS};
    const lanes4 tiny = {PREDICATES_UNDERFLOW_ABSOLUTE, PREDICATES_UNDERFLOW_ABSOLUTE, PREDICATES_UNDERFLOW_ABSOLUTE,
                         PREDICATES_UNDERFLOW_ABSOLUTE};
    mask4 apart = {0, 0, 0, 0}, open = {0, 0, 0, 0};
    for (int e = 0; e < 3; e++) {
        lanes4 dj = LOAD4(t->lanes.dj[e]), di = LOAD4(t->lanes.di[e]);
        mask4 active;
        memcpy(&active, t->lanes.active[e], sizeof active);
        mask4 dj_up = dj > zero, di_up = di > zero;
        /* edge_axis_separates' m (the box corner lowest in f) and M (highest). */
        lanes4 m_i = PICK4(dj_up, lo_i, hi_i), m_j = PICK4(di_up, hi_j, lo_j);
        lanes4 big_i = PICK4(dj_up, hi_i, lo_i), big_j = PICK4(di_up, lo_j, hi_j);
        /* products_difference_filter of prepared_sign's two products, for each test. */
        lanes4 left = (m_i - LOAD4(t->lanes.above_i[e])) * dj, right = (m_j - LOAD4(t->lanes.above_j[e])) * di;
        lanes4 det = left - right, bound = err * (ABS4(left) + ABS4(right)) + tiny;
        lanes4 left2 = (big_i - LOAD4(t->lanes.below_i[e])) * dj, right2 = (big_j - LOAD4(t->lanes.below_j[e])) * di;
        lanes4 det2 = left2 - right2, bound2 = err * (ABS4(left2) + ABS4(right2)) + tiny;
        /* Separating: the box wholly above (sign > 0) or wholly below (sign < 0). */
        apart |= active & ((det > bound) | (det2 < -bound2));
        open |= active & ~((det < -bound) & (det2 > bound2));
    }
    if (apart[0] | apart[1] | apart[2] | apart[3])
        return FILTERED_APART;
    return undecided || (open[0] | open[1] | open[2] | open[3]) ? FILTERED_UNDECIDED : FILTERED_TOUCHING;
}

/* tri_box_children_touched for a prepared triangle. Inline so that each target below
 * compiles its own copy of the lanes. */
static inline __attribute__((always_inline)) unsigned children_touched(tri_box_triangle *t, const box3 child[8],
                                                                      unsigned open)
{
    if (!t->lanes_ready)
        fill_lanes(t);
    unsigned touched = 0;
    for (int k = 0; k < 8; k++) {
        if (!((open >> k) & 1))
            continue;
        int filtered = filtered_axes(t, &child[k]);
        if (filtered == FILTERED_TOUCHING || (filtered == FILTERED_UNDECIDED && tri_box_overlap_prepared(t, child[k])))
            touched |= 1u << k;
    }
    return touched;
}

unsigned tri_box_children_touched_portable(tri_box_triangle *t, const box3 child[8], unsigned open)
{
    if (!t->ready)
        prepare_axes(t);
    return children_touched(t, child, open);
}

#if defined(__x86_64__) || defined(__i386__)
/* The same code with each lane group in one register instead of two. */
__attribute__((target("avx2"))) static unsigned children_touched_avx2(tri_box_triangle *t, const box3 child[8],
                                                                     unsigned open)
{
    return children_touched(t, child, open);
}
#endif

unsigned tri_box_children_touched(tri_box_triangle *t, const box3 child[8], unsigned open)
{
#if defined(__x86_64__) || defined(__i386__)
    static int avx2 = -1; /* a benign race: every thread stores the same answer */
    if (avx2 < 0)
        avx2 = __builtin_cpu_supports("avx2") ? 1 : 0;
    if (avx2) {
        if (!t->ready)
            prepare_axes(t);
        return children_touched_avx2(t, child, open);
    }
#endif
    return tri_box_children_touched_portable(t, child, open);
}

/* Where edge p -> q crosses the split plane x_k = c_k strictly between its ends, the
 * crossing point X has X_k = c_k exactly and X_i = p_i + t (q_i - p_i), t = (c_k - p_k) /
 * (q_k - p_k), off by at most about 6u |t (q_i - p_i)| + u |p_i| in double (three
 * roundings in t, |t| < 1, two more in the product and one in the sum); the tolerance
 * 8u (|p_i| + |product|) covers that and the rounding of X_i -/+ tolerance itself, plus an
 * absolute term for subnormal results. An overflowed q_k - p_k is skipped; any other
 * overflow gives an inf or NaN that fails every comparison, and the point proves nothing. */
#define CROSSING_ROUNDING (8 * 0x1p-53)

unsigned tri_box_children_at_crossings_portable(const vec3 tri[3], box3 box, vec3 c, unsigned wanted)
{
    const double v[3][3] = {{tri[0].x, tri[0].y, tri[0].z}, {tri[1].x, tri[1].y, tri[1].z},
                            {tri[2].x, tri[2].y, tri[2].z}};
    const double lo[3] = {box.lo.x, box.lo.y, box.lo.z}, hi[3] = {box.hi.x, box.hi.y, box.hi.z};
    const double split[3] = {c.x, c.y, c.z};
    unsigned touched = 0;
    for (int e = 0; e < 3; e++) {
        const double *p = v[e], *q = v[e == 2 ? 0 : e + 1];
        for (int k = 0; k < 3; k++) {
            if (!((p[k] < split[k] && split[k] < q[k]) || (q[k] < split[k] && split[k] < p[k])))
                continue;
            /* An overflowed q_k - p_k would give t = 0, a wrong finite point; the
             * numerator is no larger, so a finite denominator keeps t right. */
            double den = q[k] - p[k];
            if (!isfinite(den))
                continue;
            double t = (split[k] - p[k]) / den;
            /* Along k the point is on the split plane: both halves. The other two axes
             * name one half each, when the point is certainly inside the box there and
             * certainly off the split plane. */
            unsigned halves[3] = {3, 3, 3};
            int certain = 1;
            for (int i = 0; i < 3 && certain; i++) {
                if (i == k)
                    continue;
                double product = t * (q[i] - p[i]);
                double x = p[i] + product;
                double tol = CROSSING_ROUNDING * (fabs(p[i]) + fabs(product)) + 0x1p-1070;
                double below = x - tol, above = x + tol;
                if (below >= lo[i] && above <= split[i])
                    halves[i] = 1;
                else if (below >= split[i] && above <= hi[i])
                    halves[i] = 2;
                else
                    certain = 0;
            }
            if (certain) {
                touched |= box_octants_by_half[0][halves[0]] & box_octants_by_half[1][halves[1]] &
                           box_octants_by_half[2][halves[2]];
                if ((wanted & ~touched) == 0)
                    return touched;
            }
        }
    }
    return touched;
}

#if defined(__x86_64__) || defined(__i386__)
/* crossing_children[k][upper]: the children two halves name at a crossing of the split
 * plane of coordinate k (both halves along k), with bit 0 of upper set for the upper half
 * along coordinate i = k + 1 and bit 1 for j = k + 2 (mod 3): the product of
 * box_octants_by_half that the portable loop takes. Octant bits as box_octant_upper_bits. */
static unsigned char crossing_children[3][4];

static void crossing_children_fill(void)
{
    for (int k = 0; k < 3; k++)
        for (unsigned upper = 0; upper < 4; upper++) {
            int i = k == 2 ? 0 : k + 1, j = k == 0 ? 2 : k - 1;
            unsigned halves[3] = {3, 3, 3};
            halves[i] = upper & 1 ? 2 : 1;
            halves[j] = upper & 2 ? 2 : 1;
            crossing_children[k][upper] = (unsigned char)(box_octants_by_half[0][halves[0]] &
                                                          box_octants_by_half[1][halves[1]] &
                                                          box_octants_by_half[2][halves[2]]);
        }
}

/* tri_box_children_at_crossings_portable with an edge's three split planes as the lanes
 * of one register: the same operations on the same operands, so each lane proves what
 * the portable loop proves for that edge and plane; only the search stops after whole
 * edges, so more children may be named (each one proven). */
__attribute__((target("avx2"))) static unsigned children_at_crossings_avx2(const vec3 tri[3], box3 box, vec3 c,
                                                                          unsigned wanted)
{
    /* Lane k holds coordinate k, and the lanes of the two other coordinates i = k + 1
     * and j = k + 2 (mod 3) hold them in the same rotation. */
    const lanes4 split_k = {c.x, c.y, c.z, 0}, split_i = {c.y, c.z, c.x, 0}, split_j = {c.z, c.x, c.y, 0};
    const lanes4 lo_i = {box.lo.y, box.lo.z, box.lo.x, 0}, lo_j = {box.lo.z, box.lo.x, box.lo.y, 0};
    const lanes4 hi_i = {box.hi.y, box.hi.z, box.hi.x, 0}, hi_j = {box.hi.z, box.hi.x, box.hi.y, 0};
    const lanes4 one = {1, 1, 1, 1}, largest = {DBL_MAX, DBL_MAX, DBL_MAX, DBL_MAX};
    const lanes4 rounding = {CROSSING_ROUNDING, CROSSING_ROUNDING, CROSSING_ROUNDING, CROSSING_ROUNDING};
    const lanes4 tiny = {0x1p-1070, 0x1p-1070, 0x1p-1070, 0x1p-1070};
    lanes4 vk[3], vi[3], vj[3];
    for (int n = 0; n < 3; n++) {
        vk[n] = (lanes4){tri[n].x, tri[n].y, tri[n].z, 0};
        vi[n] = (lanes4){tri[n].y, tri[n].z, tri[n].x, 0};
        vj[n] = (lanes4){tri[n].z, tri[n].x, tri[n].y, 0};
    }
    unsigned touched = 0;
    for (int e = 0; e < 3; e++) {
        int q = e == 2 ? 0 : e + 1;
        lanes4 pk = vk[e], qk = vk[q];
        /* Lane 3 compares 0 < 0 and never crosses. */
        mask4 crossing = ((pk < split_k) & (split_k < qk)) | ((qk < split_k) & (split_k < pk));
        lanes4 den = qk - pk;
        crossing &= ABS4(den) <= largest; /* an overflowed difference proves nothing */
        /* A lane that does not cross divides by one instead of by a zero. */
        lanes4 t = (split_k - pk) / PICK4(crossing, den, one);
        lanes4 product_i = t * (vi[q] - vi[e]), product_j = t * (vj[q] - vj[e]);
        lanes4 x_i = vi[e] + product_i, x_j = vj[e] + product_j;
        lanes4 tol_i = rounding * (ABS4(vi[e]) + ABS4(product_i)) + tiny;
        lanes4 tol_j = rounding * (ABS4(vj[e]) + ABS4(product_j)) + tiny;
        lanes4 below_i = x_i - tol_i, above_i = x_i + tol_i, below_j = x_j - tol_j, above_j = x_j + tol_j;
        mask4 lower_i = (below_i >= lo_i) & (above_i <= split_i), upper_i = (below_i >= split_i) & (above_i <= hi_i);
        mask4 lower_j = (below_j >= lo_j) & (above_j <= split_j), upper_j = (below_j >= split_j) & (above_j <= hi_j);
        mask4 certain = crossing & (lower_i | upper_i) & (lower_j | upper_j);
        unsigned lanes = (unsigned)__builtin_ia32_movmskpd256((lanes4)certain);
        /* The portable loop tries the lower half first. */
        unsigned up_i = (unsigned)__builtin_ia32_movmskpd256((lanes4)(upper_i & ~lower_i));
        unsigned up_j = (unsigned)__builtin_ia32_movmskpd256((lanes4)(upper_j & ~lower_j));
        for (; lanes; lanes &= lanes - 1) {
            int k = __builtin_ctz(lanes);
            touched |= crossing_children[k][(up_i >> k & 1) | (up_j >> k & 1) << 1];
        }
        if ((wanted & ~touched) == 0)
            return touched;
    }
    return touched;
}
#endif

unsigned tri_box_children_at_crossings(const vec3 tri[3], box3 box, vec3 c, unsigned wanted)
{
#if defined(__x86_64__) || defined(__i386__)
    /* A benign race: every thread stores the same table and the same answer, the table
     * before the flag that says it is there. */
    static int avx2 = -1;
    if (__atomic_load_n(&avx2, __ATOMIC_ACQUIRE) < 0) {
        crossing_children_fill();
        __atomic_store_n(&avx2, __builtin_cpu_supports("avx2") ? 1 : 0, __ATOMIC_RELEASE);
    }
    if (avx2)
        return children_at_crossings_avx2(tri, box, c, wanted);
#endif
    return tri_box_children_at_crossings_portable(tri, box, c, wanted);
}

int tri_box_overlap_exact(const vec3 tri[3], box3 box)
{
    tri_box_triangle t;
    tri_box_prepare(&t, tri);
    return tri_box_overlap_prepared(&t, box);
}

/* ---------- seed ---------- */

/* Unit vector v/|v|, or zero for a zero vector. Scaling by the largest component first
 * keeps |v| from overflowing or underflowing, so no input makes 0/0. */
static vec3 seed_unit(vec3 v)
{
    double m = fmax(fabs(v.x), fmax(fabs(v.y), fabs(v.z)));
    if (!(m > 0.0) || !isfinite(m))
        return vec3_make(0.0, 0.0, 0.0);
    v = vec3_scale(v, 1.0 / m);
    double len = vec3_length(v);
    return vec3_make(v.x / len, v.y / len, v.z / len);
}

/* The seed's edge parameter s = num / den "with eps added to the denominator". The text
 * leaves open whether eps is added always or only when den is zero, and a literal den + eps
 * flips the sign of a den in (-eps, 0) and divides by zero at den = -eps. We add it always,
 * with den's sign, which is what keeps s finite. With eps = 0 a parallel edge (den = 0)
 * still has no parameter; it returns 0 and the edge is skipped. */
static int seed_edge_parameter(double num, double den, double eps, double *s)
{
    double padded = den < 0.0 ? den - eps : den + eps;
    if (padded == 0.0)
        return 0;
    *s = num / padded;
    return 1;
}

int tri_box_overlap_seed(const vec3 tri[3], box3 box, double eps)
{
    vec3 face_normal[6], face_vertex[6][4];
    for (int i = 0; i < 6; i++) {
        face_normal[i] = box_face_normal(i);
        face_vertex[i][0] = box_face_vertex(box, i, 0);
    }

    /* Step 1: a vertex with every signed face distance d_i < eps is in the box. The prose
     * says "negative (including zero)", the formula d_i < eps; the formula is used, so
     * eps = 0 leaves a vertex on a face to the later steps. */
    for (int t = 0; t < 3; t++) {
        int inside = 1;
        for (int i = 0; i < 6 && inside; i++)
            inside = vec3_dot(face_normal[i], vec3_sub(tri[t], face_vertex[i][0])) < eps;
        if (inside)
            return 1;
    }

    vec3 face_edge[6][4], face_edge_normal[6][4];
    for (int i = 0; i < 6; i++) {
        for (int j = 1; j < 4; j++)
            face_vertex[i][j] = box_face_vertex(box, i, j);
        for (int j = 0; j < 4; j++) {
            face_edge[i][j] = box_face_edge(box, i, j);
            face_edge_normal[i][j] = box_face_edge_normal(box, i, j);
        }
    }

    /* The triangle's frame, by analogy with the box's: E_Tj = V_T(j+1) - V_Tj and
     * n_T = E_T2 x E_T0 / |.| (the seed's resolution formula uses the same product), so
     * n_ETj = E_Tj/|E_Tj| x n_T points out of the triangle for either winding. */
    vec3 tri_edge[3], tri_edge_normal[3];
    for (int j = 0; j < 3; j++)
        tri_edge[j] = vec3_sub(tri[(j + 1) % 3], tri[j]);
    vec3 tri_normal = seed_unit(vec3_cross(tri_edge[2], tri_edge[0]));
    for (int j = 0; j < 3; j++)
        tri_edge_normal[j] = vec3_cross(seed_unit(tri_edge[j]), tri_normal);

    /* Step 2: the box's 12 edges (faces 0-3, edges 0-2) against the triangle. A zero-area
     * triangle has no plane (the seed does not consider one); its unit normal would be 0/0,
     * and with a zero normal every box edge would pass, so step 2 is skipped for it and
     * step 3 tests it as the segment it is. */
    int has_plane = tri_normal.x != 0.0 || tri_normal.y != 0.0 || tri_normal.z != 0.0;
    for (int i = 0; i < 4 && has_plane; i++) {
        for (int j = 0; j < 3; j++) {
            /* The seed writes this for edge 0 (P = V_i0 + s E_i0); edge j starts at V_ij. */
            vec3 start = face_vertex[i][j];
            vec3 edge = face_edge[i][j];
            double s;
            if (!seed_edge_parameter(vec3_dot(tri_normal, vec3_sub(tri[0], start)),
                                     vec3_dot(tri_normal, edge), eps, &s))
                continue;
            if (!(s > -eps && s < 1.0 + eps))
                continue;
            vec3 p = vec3_add(start, vec3_scale(edge, s));
            int inside = 1;
            for (int e = 0; e < 3 && inside; e++)
                inside = vec3_dot(tri_edge_normal[e], vec3_sub(p, tri[e])) < eps;
            if (inside)
                return 1;
        }
    }

    /* Step 3: the triangle's edges against the six faces. */
    for (int j = 0; j < 3; j++) {
        for (int i = 0; i < 6; i++) {
            double s;
            if (!seed_edge_parameter(vec3_dot(face_normal[i], vec3_sub(face_vertex[i][0], tri[j])),
                                     vec3_dot(face_normal[i], tri_edge[j]), eps, &s))
                continue;
            if (!(s > -eps && s < 1.0 + eps))
                continue;
            vec3 p = vec3_add(tri[j], vec3_scale(tri_edge[j], s));
            /* The seed writes n_Eij . (P - V_i0) for all four edges, but V_i0 lies on edges
             * 0 and 3 only; read literally, edges 1 and 2 would accept only points near
             * V_i0. Measured from the edge's own start V_ij, as the triangle test does
             * with V_Tj, it is the point-in-quadrilateral test the text describes. */
            int inside = 1;
            for (int e = 0; e < 4 && inside; e++)
                inside = vec3_dot(face_edge_normal[i][e], vec3_sub(p, face_vertex[i][e])) < eps;
            if (inside)
                return 1;
        }
    }
    return 0;
}

/* ---------- fast ---------- */

/* One of the nine edge x axis tests of Akenine-Moller's method, box centred at the origin:
 * the axis is u_k x f, on which a point x projects to f_i x_j - f_j x_i and the box
 * reaches r = h_i |f_j| + h_j |f_i| (i, j the other two axes). The edge's two ends project
 * to the same value, so two vertices suffice. Closed box: touching is overlap. */
static int fast_edge_axis_separates(const double f[3], const double on_edge[3],
                                    const double other[3], const double h[3], int k)
{
    int i = k == 2 ? 0 : k + 1;
    int j = k == 0 ? 2 : k - 1;
    double a = f[i] * on_edge[j] - f[j] * on_edge[i];
    double b = f[i] * other[j] - f[j] * other[i];
    double r = h[i] * fabs(f[j]) + h[j] * fabs(f[i]);
    double lo = a < b ? a : b, hi = a < b ? b : a;
    return lo > r || hi < -r;
}

int tri_box_overlap_fast(const vec3 tri[3], box3 box)
{
    double c[3] = {0.5 * (box.lo.x + box.hi.x), 0.5 * (box.lo.y + box.hi.y),
                   0.5 * (box.lo.z + box.hi.z)};
    double h[3] = {0.5 * (box.hi.x - box.lo.x), 0.5 * (box.hi.y - box.lo.y),
                   0.5 * (box.hi.z - box.lo.z)};
    double v[3][3], f[3][3];
    for (int t = 0; t < 3; t++) {
        v[t][0] = tri[t].x - c[0];
        v[t][1] = tri[t].y - c[1];
        v[t][2] = tri[t].z - c[2];
    }
    for (int t = 0; t < 3; t++)
        for (int k = 0; k < 3; k++)
            f[t][k] = v[(t + 1) % 3][k] - v[t][k];

    /* The nine edge x axis tests; edge t runs from v[t] to v[t + 1]. */
    for (int t = 0; t < 3; t++)
        for (int k = 0; k < 3; k++)
            if (fast_edge_axis_separates(f[t], v[t], v[(t + 2) % 3], h, k))
                return 0;

    /* The box's own axes: the triangle's bounding box against the box. */
    for (int k = 0; k < 3; k++) {
        double mn = fmin(v[0][k], fmin(v[1][k], v[2][k]));
        double mx = fmax(v[0][k], fmax(v[1][k], v[2][k]));
        if (mn > h[k] || mx < -h[k])
            return 0;
    }

    /* The triangle's plane against the box: the corners nearest and farthest along n. */
    double n[3] = {f[0][1] * f[1][2] - f[0][2] * f[1][1], f[0][2] * f[1][0] - f[0][0] * f[1][2],
                   f[0][0] * f[1][1] - f[0][1] * f[1][0]};
    double d = -(n[0] * v[0][0] + n[1] * v[0][1] + n[2] * v[0][2]);
    double near_dot = d, far_dot = d;
    for (int k = 0; k < 3; k++) {
        near_dot += n[k] > 0.0 ? -n[k] * h[k] : n[k] * h[k];
        far_dot += n[k] > 0.0 ? n[k] * h[k] : -n[k] * h[k];
    }
    if (near_dot > 0.0)
        return 0;
    return far_dot >= 0.0;
}
