/* Triangle against triangle: the exact test (every decision an exact predicate on input
 * points), the seed document's epsilon test, Moller's 1997 interval test, and the contact
 * segment reported for pairs that touch. */
#include "tri_tri.h"

#include <float.h>

#include "lanes4.h"
#include "predicates.h"

/* ------------------------------------------------------------------------------------
 * Shape of a possibly degenerate triangle, decided exactly.
 * ------------------------------------------------------------------------------------ */

typedef enum shape_kind {
    SHAPE_POINT = 0,
    SHAPE_SEGMENT = 1,
    SHAPE_TRIANGLE = 2,
} shape_kind;

typedef struct tri_shape {
    shape_kind kind;
    int axis;     /* triangle: an axis along which its normal is nonzero (exactly) */
    int end0;     /* segment: vertex indices of its two extreme points; point: end0 */
    int end1;
} tri_shape;

static int other_axis_u(int axis) { return axis == 2 ? 0 : axis + 1; }
static int other_axis_v(int axis) { return axis == 0 ? 2 : axis - 1; }

/* A zero-area triangle is the segment between its two extreme vertices, found along an
 * axis where the vertices differ: on a line not perpendicular to that axis, the
 * coordinate orders the points along the line. */
static tri_shape classify_triangle(const vec3 t[3])
{
    tri_shape shape = {SHAPE_POINT, 0, 0, 0};
    for (int axis = 0; axis < 3; axis++) {
        if (orient2d_axis(t[0], t[1], t[2], axis) != 0) {
            shape.kind = SHAPE_TRIANGLE;
            shape.axis = axis;
            return shape;
        }
    }
    for (int axis = 0; axis < 3; axis++) {
        double c0 = vec3_get(t[0], axis), c1 = vec3_get(t[1], axis), c2 = vec3_get(t[2], axis);
        if (c0 == c1 && c1 == c2)
            continue;
        int lo = 0, hi = 0;
        if (c1 < vec3_get(t[lo], axis)) lo = 1;
        if (c2 < vec3_get(t[lo], axis)) lo = 2;
        if (c1 > vec3_get(t[hi], axis)) hi = 1;
        if (c2 > vec3_get(t[hi], axis)) hi = 2;
        shape.kind = SHAPE_SEGMENT;
        shape.end0 = lo;
        shape.end1 = hi;
        return shape;
    }
    return shape;
}

/* ------------------------------------------------------------------------------------
 * Exact primitives. Every predicate argument is an input point.
 * ------------------------------------------------------------------------------------ */

/* x inside the closed box of p and q in the plane normal to axis (for points collinear in
 * that projection this is "x on segment pq"). */
static int in_box_2d(vec3 x, vec3 p, vec3 q, int axis)
{
    int u = other_axis_u(axis), v = other_axis_v(axis);
    double xu = vec3_get(x, u), pu = vec3_get(p, u), qu = vec3_get(q, u);
    double xv = vec3_get(x, v), pv = vec3_get(p, v), qv = vec3_get(q, v);
    return xu >= fmin(pu, qu) && xu <= fmax(pu, qu) && xv >= fmin(pv, qv) && xv <= fmax(pv, qv);
}

static int in_box_3d(vec3 x, vec3 p, vec3 q)
{
    vec3 lo = vec3_min(p, q), hi = vec3_max(p, q);
    return x.x >= lo.x && x.x <= hi.x && x.y >= lo.y && x.y <= hi.y && x.z >= lo.z &&
           x.z <= hi.z;
}

/* Closed segments pq and rs in the projection along axis (either may be a point). */
static int seg_seg_2d(vec3 p, vec3 q, vec3 r, vec3 s, int axis)
{
    int d1 = orient2d_axis(p, q, r, axis), d2 = orient2d_axis(p, q, s, axis);
    if (d1 != 0 && d1 == d2)
        return 0;
    int d3 = orient2d_axis(r, s, p, axis), d4 = orient2d_axis(r, s, q, axis);
    if (d3 != 0 && d3 == d4)
        return 0;
    if (d1 * d2 < 0 && d3 * d4 < 0)
        return 1;
    return (d1 == 0 && in_box_2d(r, p, q, axis)) || (d2 == 0 && in_box_2d(s, p, q, axis)) ||
           (d3 == 0 && in_box_2d(p, r, s, axis)) || (d4 == 0 && in_box_2d(q, r, s, axis));
}

/* x in the closed triangle t, all in the plane of t, seen along axis where t's normal
 * component has sign `turn` (nonzero). */
static int point_in_tri_2d(vec3 x, const vec3 t[3], int axis, int turn)
{
    return orient2d_axis(t[0], t[1], x, axis) != -turn &&
           orient2d_axis(t[1], t[2], x, axis) != -turn &&
           orient2d_axis(t[2], t[0], x, axis) != -turn;
}

/* Closed segment pq lying in the plane of the non-degenerate triangle t. The projection
 * along `axis` is one-to-one on that plane, so the 2D answer is the 3D answer. */
static int seg_tri_coplanar(vec3 p, vec3 q, const vec3 t[3], int axis)
{
    int turn = orient2d_axis(t[0], t[1], t[2], axis);
    return point_in_tri_2d(p, t, axis, turn) || point_in_tri_2d(q, t, axis, turn) ||
           seg_seg_2d(p, q, t[0], t[1], axis) || seg_seg_2d(p, q, t[1], t[2], axis) ||
           seg_seg_2d(p, q, t[2], t[0], axis);
}

/* Closed segment pq (p != q) against the closed non-degenerate triangle t; sp, sq are
 * orient3d(t, p) and orient3d(t, q). When the segment is not in the plane it meets the
 * plane in one point X, and orient3d(p, q, t_i, t_j) over the three edges is
 * ((q - p) . normal of t) times the barycentric weights of X, so X is in t iff those signs are not mixed. */
static int seg_tri_exact(vec3 p, vec3 q, int sp, int sq, const vec3 t[3], int axis)
{
    if (sp != 0 && sp == sq)
        return 0;
    if (sp == 0 && sq == 0)
        return seg_tri_coplanar(p, q, t, axis);
    int s0 = orient3d(p, q, t[0], t[1]);
    int s1 = orient3d(p, q, t[1], t[2]);
    if (s0 * s1 < 0)
        return 0;
    int s2 = orient3d(p, q, t[2], t[0]);
    return !((s0 > 0 || s1 > 0 || s2 > 0) && (s0 < 0 || s1 < 0 || s2 < 0));
}

static int collinear_3d(vec3 p, vec3 q, vec3 x)
{
    return orient2d_axis(p, q, x, 0) == 0 && orient2d_axis(p, q, x, 1) == 0 &&
           orient2d_axis(p, q, x, 2) == 0;
}

static int point_on_seg_3d(vec3 x, vec3 p, vec3 q)
{
    return in_box_3d(x, p, q) && collinear_3d(p, q, x);
}

/* An axis along which the plane through p, q, r (not collinear) projects one-to-one,
 * preferring the largest normal component for better-conditioned constructions; -1 when
 * the three points are collinear. */
static int plane_axis(vec3 p, vec3 q, vec3 r)
{
    vec3 n = vec3_abs(vec3_cross(vec3_sub(q, p), vec3_sub(r, p)));
    int order[3] = {0, 1, 2};
    for (int i = 0; i < 3; i++)
        for (int j = i + 1; j < 3; j++)
            if (vec3_get(n, order[j]) > vec3_get(n, order[i])) {
                int swap = order[i];
                order[i] = order[j];
                order[j] = swap;
            }
    for (int i = 0; i < 3; i++)
        if (orient2d_axis(p, q, r, order[i]) != 0)
            return order[i];
    return -1;
}

/* An axis where p and q differ (p != q). */
static int differing_axis(vec3 p, vec3 q)
{
    return p.x != q.x ? 0 : p.y != q.y ? 1 : 2;
}

/* Closed segments pq, rs in 3D (p != q, r != s). */
static int seg_seg_3d(vec3 p, vec3 q, vec3 r, vec3 s)
{
    if (orient3d(p, q, r, s) != 0)
        return 0;
    int axis = plane_axis(p, q, r);
    if (axis < 0)
        axis = plane_axis(p, q, s);
    if (axis >= 0)
        return seg_seg_2d(p, q, r, s, axis);
    /* All four on one line: intervals along an axis the line is not perpendicular to. */
    axis = differing_axis(p, q);
    double p0 = vec3_get(p, axis), p1 = vec3_get(q, axis);
    double r0 = vec3_get(r, axis), r1 = vec3_get(s, axis);
    return fmax(fmin(p0, p1), fmin(r0, r1)) <= fmin(fmax(p0, p1), fmax(r0, r1));
}

/* The vertex of a triangle alone on its closed side of the other triangle's plane, from
 * the exact signs s of its vertices there (neither all zero nor all one nonzero sign): the
 * one nonzero sign; the zero between two equal signs; the odd one out of three nonzero
 * signs; the positive one of +, -, 0. *others_positive is set when the other two lie on
 * the positive closed side (for two zeros: when the apex is negative). */
static int apex_of(const int s[3], int *others_positive)
{
    int pos = (s[0] > 0) + (s[1] > 0) + (s[2] > 0), neg = (s[0] < 0) + (s[1] < 0) + (s[2] < 0);
    int want = pos + neg == 1 ? (pos ? 1 : -1) : (pos == 0 || neg == 0) ? 0 : pos == 1 ? 1 : -1;
    int i = s[0] == want ? 0 : s[1] == want ? 1 : 2;
    int j = i == 2 ? 0 : i + 1, k = j == 2 ? 0 : j + 1;
    int other = s[j] != 0 ? s[j] : s[k] != 0 ? s[k] : -want;
    *others_positive = other > 0;
    return i;
}

/* Two non-degenerate triangles in distinct planes, each meeting the other's plane (sa, sb:
 * exact signs of a's vertices against b's plane and of b's against a's, each with a
 * nonzero and not all one sign). Each triangle cuts a segment from the planes' common line,
 * bounded by its two edges from its apex, and the triangles meet iff the segments overlap.
 * Guigue and Devillers (2003) put both in a canonical form: apex first, and the order of
 * the other triangle's last two vertices chosen so that each apex is on the non-negative
 * side of the other plane and its two companions on the non-positive side. Then each
 * segment end's order along the line is one orient3d of an edge from one apex against an
 * edge from the other, and the segments overlap iff orient3d(a0, a1, b0, b1) <= 0 and
 * orient3d(a0, a2, b2, b0) <= 0. Two exact predicates on input points replace up to six
 * edge-triangle tests; vertices and edges on the other plane are the zero signs the
 * canonical form was built to take. */
static int crossing_planes_meet(const vec3 a[3], const vec3 b[3], const int sa[3], const int sb[3])
{
    int a_others_positive, b_others_positive;
    int ia = apex_of(sa, &a_others_positive), ib = apex_of(sb, &b_others_positive);
    vec3 ca[3] = {a[ia], a[ia == 2 ? 0 : ia + 1], a[ia == 0 ? 2 : ia - 1]};
    vec3 cb[3] = {b[ib], b[ib == 2 ? 0 : ib + 1], b[ib == 0 ? 2 : ib - 1]};
    /* Swapping two vertices of a triangle negates the signs against its plane. */
    if (a_others_positive) {
        vec3 t = cb[1];
        cb[1] = cb[2];
        cb[2] = t;
    }
    if (b_others_positive) {
        vec3 t = ca[1];
        ca[1] = ca[2];
        ca[2] = t;
    }
    return orient3d(ca[0], ca[1], cb[0], cb[1]) <= 0 && orient3d(ca[0], ca[2], cb[2], cb[0]) <= 0;
}

/* Triangle t against the segment or point d; sd are orient3d(t, d_i). */
static int tri_meets_degenerate(const vec3 t[3], tri_shape kt, const vec3 d[3], tri_shape kd,
                                const int sd[3])
{
    if (kd.kind == SHAPE_SEGMENT)
        return seg_tri_exact(d[kd.end0], d[kd.end1], sd[kd.end0], sd[kd.end1], t, kt.axis);
    return sd[kd.end0] == 0 &&
           point_in_tri_2d(d[kd.end0], t, kt.axis, orient2d_axis(t[0], t[1], t[2], kt.axis));
}

static int all_same_decided(const int s[3])
{
    return s[0] != PREDICATES_UNDECIDED && s[0] == s[1] && s[1] == s[2];
}

#if defined(__x86_64__)
/* orient3d_plane_filter on the four points (wx, wy, wz) + p->a, one to a lane: its
 * operations in its order, so each lane decides what the scalar filter decides. Its
 * decided lanes, and among them the positive ones in *positive. A pair of triangles takes
 * two plane stages, whose six scalar filters were most of a pair's test; built for the
 * baseline's two-lane registers the same code cost more than the scalar calls, so it runs
 * only with AVX2. */
#define PLANE_LANES __attribute__((target("avx2"), always_inline)) static inline
PLANE_LANES unsigned plane_filter_lanes(const orient3d_plane *p, lanes4 wx, lanes4 wy, lanes4 wz,
                                        unsigned *positive)
{
    wx -= p->a.x;
    wy -= p->a.y;
    wz -= p->a.z;
    lanes4 det = wx * p->minor.x + wy * p->minor.y + wz * p->minor.z;
    lanes4 permanent = p->permanent.x * ABS4(wx) + p->permanent.y * ABS4(wy) + p->permanent.z * ABS4(wz);
    lanes4 bound = PREDICATES_ERRBOUND_ORIENT3D * permanent + PREDICATES_UNDERFLOW_ABSOLUTE;
    mask4 decided = (det != 0.0) & (ABS4(det) > bound);
    *positive = BITS4(decided & (det > 0.0));
    return BITS4(decided);
}

/* The three points in lanes 0-2 (lane 3 repeats the first). */
__attribute__((target("avx2"))) static void plane_signs_avx2(const orient3d_plane *p, const vec3 d[3], int s[3])
{
    unsigned positive, decided = plane_filter_lanes(p, (lanes4){d[0].x, d[1].x, d[2].x, d[0].x},
                                                    (lanes4){d[0].y, d[1].y, d[2].y, d[0].y},
                                                    (lanes4){d[0].z, d[1].z, d[2].z, d[0].z}, &positive);
    for (int i = 0; i < 3; i++)
        s[i] = decided >> i & 1 ? (positive >> i & 1 ? 1 : -1) : PREDICATES_UNDECIDED;
}

/* The eight corners, four at a time: x and y from the lane, z the same for all four. */
__attribute__((target("avx2"))) static int plane_box_side_avx2(const orient3d_plane *p, const double lo[3],
                                                                const double hi[3])
{
    lanes4 x = {lo[0], hi[0], lo[0], hi[0]}, y = {lo[1], lo[1], hi[1], hi[1]};
    unsigned positive_lo, positive_hi;
    unsigned decided = plane_filter_lanes(p, x, y, (lanes4){lo[2], lo[2], lo[2], lo[2]}, &positive_lo) |
                       plane_filter_lanes(p, x, y, (lanes4){hi[2], hi[2], hi[2], hi[2]}, &positive_hi) << 4;
    unsigned positive = positive_lo | positive_hi << 4;
    if (decided != 0xffu)
        return 0;
    return positive == 0xffu ? 1 : positive == 0 ? -1 : 0;
}
#endif

void tri_tri_plane_signs(const orient3d_plane *p, const vec3 d[3], int s[3])
{
#if defined(__x86_64__)
    if (__builtin_cpu_supports("avx2")) {
        plane_signs_avx2(p, d, s);
        return;
    }
#endif
    for (int i = 0; i < 3; i++)
        s[i] = orient3d_plane_filter(p, d[i]);
}

int tri_tri_plane_box_side(const orient3d_plane *p, const double lo[3], const double hi[3])
{
#if defined(__x86_64__)
    if (__builtin_cpu_supports("avx2"))
        return plane_box_side_avx2(p, lo, hi);
#endif
    int first = 0;
    for (int k = 0; k < 8; k++) {
        vec3 c = {k & 1 ? hi[0] : lo[0], k & 2 ? hi[1] : lo[1], k & 4 ? hi[2] : lo[2]};
        int s = orient3d_plane_filter(p, c);
        if (s == PREDICATES_UNDECIDED || (k > 0 && s != first))
            return 0;
        first = s;
    }
    return first;
}

static int any_undecided(const int s[3])
{
    return s[0] == PREDICATES_UNDECIDED || s[1] == PREDICATES_UNDECIDED || s[2] == PREDICATES_UNDECIDED;
}

/* 1 when the filter proves that the projections along axis of t (whose orientation there
 * the filter found to be turn, nonzero) and of the points x lie strictly on opposite sides
 * of an edge line of t. Projection maps a common point to a common point, so disjoint
 * projections prove disjoint triangles. Only decided signs count: an undecided one (a
 * point nearly on the edge line) leaves that edge unproven, never costs exact arithmetic. */
static int edge_separates_2d(const vec3 t[3], int turn, const vec3 x[3], int axis)
{
    for (int i = 0; i < 3; i++) {
        int j = i == 2 ? 0 : i + 1;
        if (orient2d_axis_filter(t[i], t[j], x[0], axis) == -turn &&
            orient2d_axis_filter(t[i], t[j], x[1], axis) == -turn &&
            orient2d_axis_filter(t[i], t[j], x[2], axis) == -turn)
            return 1;
    }
    return 0;
}

/* Nearly coplanar pairs leave the plane-side filters undecided; most of them (neighbours
 * in a flat region of a mesh) are apart in the plane, which 2D filters on the shared
 * projection show far more cheaply than exact orient3d signs. */
static int separated_in_projection(const tri_tri_query *q, const vec3 b[3])
{
    if (q->turn != PREDICATES_UNDECIDED && edge_separates_2d(q->v, q->turn, b, q->axis))
        return 1;
    int turn_b = orient2d_axis_filter(b[0], b[1], b[2], q->axis);
    return turn_b != PREDICATES_UNDECIDED && edge_separates_2d(b, turn_b, q->v, q->axis);
}

/* Closed triangles whose bounding boxes are strictly apart share no point; the bounds are
 * input coordinates, so the comparison is exact. */
static int bounds_apart(const tri_tri_query *q, const vec3 b[3])
{
    box3 bb = {vec3_min(vec3_min(b[0], b[1]), b[2]), vec3_max(vec3_max(b[0], b[1]), b[2])};
    return bb.lo.x > q->box.hi.x || bb.lo.y > q->box.hi.y || bb.lo.z > q->box.hi.z || bb.hi.x < q->box.lo.x ||
           bb.hi.y < q->box.lo.y || bb.hi.z < q->box.lo.z;
}

void tri_tri_query_prepare(tri_tri_query *q, const vec3 a[3])
{
    for (int i = 0; i < 3; i++)
        q->v[i] = a[i];
    q->box.lo = vec3_min(vec3_min(a[0], a[1]), a[2]);
    q->box.hi = vec3_max(vec3_max(a[0], a[1]), a[2]);
    q->plane = orient3d_plane_make(a[0], a[1], a[2]);
    /* Any axis makes the separation proof sound; the largest rounded normal component
     * makes the projected triangle the least thin, so the 2D filters decide most often. */
    vec3 n = vec3_abs(q->plane.minor);
    q->axis = n.x >= n.y ? (n.x >= n.z ? 0 : 2) : (n.y >= n.z ? 1 : 2);
    q->turn = orient2d_axis_filter(a[0], a[1], a[2], q->axis);
}

int tri_tri_overlap_exact(const vec3 a[3], const vec3 b[3])
{
    tri_tri_query q;
    tri_tri_query_prepare(&q, a);
    return tri_tri_overlap_exact_query(&q, b);
}

/* Why edges suffice: let X = A n B (closed, convex, compact) be nonempty and x an extreme
 * point of X. If x were in the 2D relative interior of both triangles, then near x the set
 * X would coincide with aff(A) n aff(B), a line or a plane, and x would not be extreme. So
 * x lies on the relative boundary of A or of B, i.e. on one of their edges (a degenerate
 * triangle has no 2D interior and is the union of its edges). That edge then meets the
 * other triangle. Conversely an edge meeting the other triangle is a common point. This
 * holds for crossing, coplanar and degenerate pairs alike.
 *
 * The tests run cheapest first, so the common candidate that does not touch leaves early:
 * exact bounds, plane sides from the float filters alone, then, for the pairs those leave
 * open, shared vertices, a 2D separation proof for nearly coplanar pairs, and only then
 * exact arithmetic for the signs the filters left open. Each rejection is a proof, so the answer is the same as
 * deciding every sign exactly first. */
int tri_tri_overlap_exact_query(const tri_tri_query *q, const vec3 b[3])
{
    const vec3 *a = q->v;
    if (bounds_apart(q, b))
        return 0;
    /* A nonzero orient3d proves the plane's triangle is non-degenerate, so these
     * rejections are sound without classifying first. */
    int sb[3], sa[3];
    tri_tri_plane_signs(&q->plane, b, sb);
    if (all_same_decided(sb))
        return 0;
    orient3d_plane plane_b = orient3d_plane_make(b[0], b[1], b[2]);
    tri_tri_plane_signs(&plane_b, a, sa);
    if (all_same_decided(sa))
        return 0;
    if (any_undecided(sb) || any_undecided(sa)) {
        /* A vertex common to both (equal doubles) is a common point. Neighbours in a mesh
         * share vertices, and without this they would take the full edge tests, often
         * through the exact stage, to find what nine comparisons say. A shared vertex lies
         * exactly on both planes, which the filters never decide, so the check waits
         * until a sign is left open; a pair the filters reject shares none. */
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                if (vec3_equal(a[i], b[j]))
                    return 1;
        if (separated_in_projection(q, b))
            return 0;
        for (int i = 0; i < 3; i++)
            if (sb[i] == PREDICATES_UNDECIDED)
                sb[i] = orient3d_plane_exact(&q->plane, b[i]);
        if (sb[0] != 0 && sb[0] == sb[1] && sb[1] == sb[2])
            return 0;
        for (int i = 0; i < 3; i++)
            if (sa[i] == PREDICATES_UNDECIDED)
                sa[i] = orient3d_plane_exact(&plane_b, a[i]);
        if (sa[0] != 0 && sa[0] == sa[1] && sa[1] == sa[2])
            return 0;
    }

    /* A nonzero sign against a plane proves that plane's triangle non-degenerate; nonzero
     * signs on both sides also rule out a common plane. */
    if ((sa[0] | sa[1] | sa[2]) != 0 && (sb[0] | sb[1] | sb[2]) != 0)
        return crossing_planes_meet(a, b, sa, sb);
    /* Left: a degenerate triangle, or two triangles in one plane (every sign zero). */
    tri_shape ka = classify_triangle(a), kb = classify_triangle(b);
    if (ka.kind == SHAPE_TRIANGLE && kb.kind == SHAPE_TRIANGLE) {
        for (int i = 0; i < 3; i++) {
            int j = i == 2 ? 0 : i + 1;
            if (seg_tri_exact(b[i], b[j], sb[i], sb[j], a, ka.axis))
                return 1;
        }
        for (int i = 0; i < 3; i++) {
            int j = i == 2 ? 0 : i + 1;
            if (seg_tri_exact(a[i], a[j], sa[i], sa[j], b, kb.axis))
                return 1;
        }
        return 0;
    }
    if (ka.kind == SHAPE_TRIANGLE)
        return tri_meets_degenerate(a, ka, b, kb, sb);
    if (kb.kind == SHAPE_TRIANGLE)
        return tri_meets_degenerate(b, kb, a, ka, sa);
    if (ka.kind == SHAPE_SEGMENT && kb.kind == SHAPE_SEGMENT)
        return seg_seg_3d(a[ka.end0], a[ka.end1], b[kb.end0], b[kb.end1]);
    if (ka.kind == SHAPE_SEGMENT)
        return point_on_seg_3d(b[kb.end0], a[ka.end0], a[ka.end1]);
    if (kb.kind == SHAPE_SEGMENT)
        return point_on_seg_3d(a[ka.end0], b[kb.end0], b[kb.end1]);
    return vec3_equal(a[ka.end0], b[kb.end0]);
}

/* ------------------------------------------------------------------------------------
 * The seed's test with epsilon.
 *
 * Reading of the seed: its triangle-box test is (1) vertex containment, (2) the other
 * object's edges against the triangle (edge-plane parameter s, then point-in-triangle
 * against the unit edge normals), and it calls (2) "the edge-triangle test carried out in
 * step 2 of the triangle-triangle collision test", so triangle-triangle is taken as the
 * same shape: (1) a vertex of either triangle within eps of the other's plane and inside
 * it, (2) every edge of each triangle against the other. Step (1) is needed: an exactly
 * coplanar edge has n.E = 0 and s = 0/eps = 0 tests its start vertex, but a vertex within
 * eps of the face whose edges leave at a shallow angle (n.E near +-eps) gets s outside
 * (-eps, 1 + eps) or a zero denominator, and only the vertex test sees it.
 * Degenerate triangles give zero normals (vec3_normalize returns 0, never NaN), and the
 * point-in-triangle test then accepts every point: the seed's behaviour, kept as written.
 * ------------------------------------------------------------------------------------ */

typedef struct seed_tri {
    vec3 v[3];
    vec3 n;         /* unit normal E2 x E0 */
    vec3 edge[3];   /* E_j = V_{j+1} - V_j */
    vec3 edge_n[3]; /* outward unit edge normals E_j/|E_j| x n */
} seed_tri;

static seed_tri seed_prepare(const vec3 t[3])
{
    seed_tri s;
    for (int j = 0; j < 3; j++) {
        s.v[j] = t[j];
        s.edge[j] = vec3_sub(t[j == 2 ? 0 : j + 1], t[j]);
    }
    s.n = vec3_normalize(vec3_cross(s.edge[2], s.edge[0]));
    for (int j = 0; j < 3; j++)
        s.edge_n[j] = vec3_cross(vec3_normalize(s.edge[j]), s.n);
    return s;
}

static int seed_point_in_tri(const seed_tri *t, vec3 p, double eps)
{
    for (int j = 0; j < 3; j++)
        if (!(vec3_dot(t->edge_n[j], vec3_sub(p, t->v[j])) < eps))
            return 0;
    return 1;
}

static int seed_vertex_in_tri(const seed_tri *t, vec3 p, double eps)
{
    return fabs(vec3_dot(t->n, vec3_sub(p, t->v[0]))) < eps && seed_point_in_tri(t, p, eps);
}

static int seed_edge_hits_tri(const seed_tri *t, vec3 start, vec3 edge, double eps)
{
    double den = vec3_dot(t->n, edge) + eps;
    if (den == 0.0) /* n.E == -eps exactly: the seed's formula has no answer; skip */
        return 0;
    double s = vec3_dot(t->n, vec3_sub(t->v[0], start)) / den;
    if (!(s > -eps && s < 1.0 + eps))
        return 0;
    return seed_point_in_tri(t, vec3_add(start, vec3_scale(edge, s)), eps);
}

int tri_tri_overlap_seed(const vec3 a[3], const vec3 b[3], double eps)
{
    seed_tri ta = seed_prepare(a), tb = seed_prepare(b);
    for (int j = 0; j < 3; j++)
        if (seed_vertex_in_tri(&tb, a[j], eps) || seed_vertex_in_tri(&ta, b[j], eps))
            return 1;
    for (int j = 0; j < 3; j++)
        if (seed_edge_hits_tri(&tb, ta.v[j], ta.edge[j], eps) ||
            seed_edge_hits_tri(&ta, tb.v[j], tb.edge[j], eps))
            return 1;
    return 0;
}

/* ------------------------------------------------------------------------------------
 * Moller 1997, plain double. Signs are compared as signs, not through products of
 * distances, so tiny distances cannot underflow into a wrong case and a division by zero.
 * No epsilon snaps distances to zero: any fixed epsilon is wrong at some scale.
 *
 * Nearly parallel planes are decided as coplanar, by a relative criterion: the normals
 * scaled to a max norm of 1 have a cross product of max norm at most
 * TRI_TRI_FAST_COPLANAR = 2^-15 (sin of the angle at most sqrt(3) 2^-15). The intervals on
 * the common line are off by about 7u M / sin(angle) each (u = 2^-53, M the coordinates'
 * magnitude: the rounding of the plane distances, divided by how fast they change along
 * an edge); below the cutoff that is rounding noise that accepted pairs at any distance
 * along the planes, above it (sin > 2^-15 / 3) it stays within 2^-32 M, the octree's
 * slack. Both triangles have passed the plane-side rejection, so each meets the other's
 * plane and lies within its size times sqrt(3) 2^-15 of it: the 2D test in the query's
 * projection then accepts only pairs that close (octree_modes.c has the bound).
 * ------------------------------------------------------------------------------------ */

static int sign_of(double v) { return (v > 0.0) - (v < 0.0); }

static int largest_axis(vec3 v)
{
    vec3 m = vec3_abs(v);
    return m.x >= m.y ? (m.x >= m.z ? 0 : 2) : (m.y >= m.z ? 1 : 2);
}

/* The interval where the triangle (projections p, plane distances d of its vertices,
 * not all on the other plane and not all on one side) meets the line of the two planes. */
static void moller_interval(const double p[3], const double d[3], double *lo, double *hi)
{
    int s0 = sign_of(d[0]), s1 = sign_of(d[1]), s2 = sign_of(d[2]);
    int k; /* the vertex alone on its side of the other plane */
    if (s0 * s1 > 0)
        k = 2;
    else if (s0 * s2 > 0)
        k = 1;
    else if (s1 * s2 > 0 || s0 != 0)
        k = 0;
    else if (s1 != 0)
        k = 1;
    else
        k = 2;
    int i = k == 0 ? 1 : 0, j = k == 2 ? 1 : 2;
    double t0 = p[k] + (p[i] - p[k]) * (d[k] / (d[k] - d[i]));
    double t1 = p[k] + (p[j] - p[k]) * (d[k] / (d[k] - d[j]));
    *lo = fmin(t0, t1);
    *hi = fmax(t0, t1);
}

static double cross_2d(double ax, double ay, double bx, double by, double cx, double cy)
{
    return (ax - cx) * (by - cy) - (ay - cy) * (bx - cx);
}

static int fast_in_box_2d(const double x[2], const double p[2], const double q[2])
{
    return x[0] >= fmin(p[0], q[0]) && x[0] <= fmax(p[0], q[0]) && x[1] >= fmin(p[1], q[1]) &&
           x[1] <= fmax(p[1], q[1]);
}

static int fast_seg_seg_2d(const double p[2], const double q[2], const double r[2],
                           const double s[2])
{
    int d1 = sign_of(cross_2d(p[0], p[1], q[0], q[1], r[0], r[1]));
    int d2 = sign_of(cross_2d(p[0], p[1], q[0], q[1], s[0], s[1]));
    int d3 = sign_of(cross_2d(r[0], r[1], s[0], s[1], p[0], p[1]));
    int d4 = sign_of(cross_2d(r[0], r[1], s[0], s[1], q[0], q[1]));
    if (d1 * d2 < 0 && d3 * d4 < 0)
        return 1;
    return (d1 == 0 && fast_in_box_2d(r, p, q)) || (d2 == 0 && fast_in_box_2d(s, p, q)) ||
           (d3 == 0 && fast_in_box_2d(p, r, s)) || (d4 == 0 && fast_in_box_2d(q, r, s));
}

/* Strictly inside: boundary contacts are found by the edge-edge tests. */
static int fast_point_in_tri_2d(const double x[2], const double t[3][2])
{
    int s0 = sign_of(cross_2d(t[0][0], t[0][1], t[1][0], t[1][1], x[0], x[1]));
    int s1 = sign_of(cross_2d(t[1][0], t[1][1], t[2][0], t[2][1], x[0], x[1]));
    int s2 = sign_of(cross_2d(t[2][0], t[2][1], t[0][0], t[0][1], x[0], x[1]));
    return s0 != 0 && s0 == s1 && s1 == s2;
}

/* Coplanar branch: project onto the axis plane where the triangle's area is largest, then
 * edge-edge tests and containment of one vertex each way. */
static int moller_coplanar(vec3 normal, const vec3 a[3], const vec3 b[3])
{
    int axis = largest_axis(normal);
    int u = other_axis_u(axis), v = other_axis_v(axis);
    double pa[3][2], pb[3][2];
    for (int i = 0; i < 3; i++) {
        pa[i][0] = vec3_get(a[i], u);
        pa[i][1] = vec3_get(a[i], v);
        pb[i][0] = vec3_get(b[i], u);
        pb[i][1] = vec3_get(b[i], v);
    }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            if (fast_seg_seg_2d(pa[i], pa[(i + 1) % 3], pb[j], pb[(j + 1) % 3]))
                return 1;
    return fast_point_in_tri_2d(pa[0], pb) || fast_point_in_tri_2d(pb[0], pa);
}

static double max_norm(vec3 v) { return fmax(fabs(v.x), fmax(fabs(v.y), fabs(v.z))); }

/* Like fast_point_in_tri_2d, boundary included: a point on an edge is in. */
static int fast_point_in_closed_tri_2d(const double x[2], const double t[3][2])
{
    int s0 = sign_of(cross_2d(t[0][0], t[0][1], t[1][0], t[1][1], x[0], x[1]));
    int s1 = sign_of(cross_2d(t[1][0], t[1][1], t[2][0], t[2][1], x[0], x[1]));
    int s2 = sign_of(cross_2d(t[2][0], t[2][1], t[0][0], t[0][1], x[0], x[1]));
    return s0 * s1 >= 0 && s1 * s2 >= 0 && s0 * s2 >= 0;
}

/* A triangle whose computed normal n = e1 x e2 (e1 = v1 - v0, e2 = v2 - v0) gives no
 * direction to trust: zero (no area), or a sliver's, at most TRI_TRI_FAST_FLAT times the
 * product of the edges' max norms, where the rounding of the cross product (a few u of that
 * product) turns it by more than 2^-21. Projected as coplanar with the other triangle, such
 * a triangle would be accepted wherever its projection meets the other's, however far off
 * the other's plane it runs. */
#define TRI_TRI_FAST_FLAT 0x1p-30
static int fast_flat(vec3 n, const vec3 t[3])
{
    return !(max_norm(n) > TRI_TRI_FAST_FLAT * (max_norm(vec3_sub(t[1], t[0])) * max_norm(vec3_sub(t[2], t[0]))));
}

/* A flat triangle a against a triangle b with a trusted normal nb, da the distances of a's
 * vertices to b's plane (times |nb|): a as the segments it is, each edge whose ends lie on
 * both sides of the plane crossing it where its distances interpolate to zero, a point that
 * must lie in b's projection; an edge in the plane, and a wholly in it, are tested in 2D.
 * An accepted pair then shares a point up to the rounding of the distances and of the 2D
 * test, which keeps the octree's slack for fast queries bounded. */
static int fast_flat_against(const vec3 a[3], const double da[3], vec3 nb, const vec3 b[3])
{
    if (da[0] == 0.0 && da[1] == 0.0 && da[2] == 0.0)
        return moller_coplanar(nb, a, b);
    int axis = largest_axis(nb);
    int u = other_axis_u(axis), v = other_axis_v(axis);
    double pb[3][2];
    for (int i = 0; i < 3; i++) {
        pb[i][0] = vec3_get(b[i], u);
        pb[i][1] = vec3_get(b[i], v);
    }
    for (int i = 0; i < 3; i++) {
        int j = i == 2 ? 0 : i + 1;
        double dp = da[i], dq = da[j];
        double p2[2] = {vec3_get(a[i], u), vec3_get(a[i], v)}, q2[2] = {vec3_get(a[j], u), vec3_get(a[j], v)};
        if (dp == 0.0 && dq == 0.0) {
            for (int k = 0; k < 3; k++)
                if (fast_seg_seg_2d(p2, q2, pb[k], pb[k == 2 ? 0 : k + 1]))
                    return 1;
            if (fast_point_in_closed_tri_2d(p2, pb))
                return 1;
            continue;
        }
        if (sign_of(dp) * sign_of(dq) > 0)
            continue;
        double r = dp / (dp - dq); /* in [0, 1]: the signs differ, or one is zero */
        double x[2] = {p2[0] + (q2[0] - p2[0]) * r, p2[1] + (q2[1] - p2[1]) * r};
        if (fast_point_in_closed_tri_2d(x, pb))
            return 1;
    }
    return 0;
}

int tri_tri_overlap_fast(const vec3 a[3], const vec3 b[3])
{
    vec3 na = vec3_cross(vec3_sub(a[1], a[0]), vec3_sub(a[2], a[0]));
    double offset_a = -vec3_dot(na, a[0]);
    double db[3];
    for (int i = 0; i < 3; i++)
        db[i] = vec3_dot(na, b[i]) + offset_a;
    int sb0 = sign_of(db[0]);
    if (sb0 != 0 && sb0 == sign_of(db[1]) && sb0 == sign_of(db[2]))
        return 0;

    vec3 nb = vec3_cross(vec3_sub(b[1], b[0]), vec3_sub(b[2], b[0]));
    double offset_b = -vec3_dot(nb, b[0]);
    double da[3];
    for (int i = 0; i < 3; i++)
        da[i] = vec3_dot(nb, a[i]) + offset_b;
    int sa0 = sign_of(da[0]);
    if (sa0 != 0 && sa0 == sign_of(da[1]) && sa0 == sign_of(da[2]))
        return 0;

    int flat_a = fast_flat(na, a), flat_b = fast_flat(nb, b);
    if (flat_a != flat_b)
        return flat_a ? fast_flat_against(a, da, nb, b) : fast_flat_against(b, db, na, a);

    /* The planes' common line from the normals scaled to a max norm of 1 (a positive
     * scaling changes neither the line nor the axis chosen, and keeps the products of
     * tiny or huge normals clear of underflow and overflow). */
    double ma = fmax(fabs(na.x), fmax(fabs(na.y), fabs(na.z)));
    double mb = fmax(fabs(nb.x), fmax(fabs(nb.y), fabs(nb.z)));
    vec3 line = vec3_make(0, 0, 0);
    if (ma > 0.0 && mb > 0.0)
        line = vec3_cross(vec3_scale(na, 1.0 / ma), vec3_scale(nb, 1.0 / mb));
    double ml = fmax(fabs(line.x), fmax(fabs(line.y), fabs(line.z)));
    if (ml <= TRI_TRI_FAST_COPLANAR || (da[0] == 0.0 && da[1] == 0.0 && da[2] == 0.0) ||
        (db[0] == 0.0 && db[1] == 0.0 && db[2] == 0.0))
        /* A zero-area first triangle has no normal to project along; use the other's. */
        return moller_coplanar(ma == 0.0 ? nb : na, a, b);

    int axis = largest_axis(line);
    double pa[3], pb[3];
    for (int i = 0; i < 3; i++) {
        pa[i] = vec3_get(a[i], axis);
        pb[i] = vec3_get(b[i], axis);
    }
    double a_lo, a_hi, b_lo, b_hi;
    moller_interval(pa, da, &a_lo, &a_hi);
    moller_interval(pb, db, &b_lo, &b_hi);
    return !(a_hi < b_lo || b_hi < a_lo);
}

/* ------------------------------------------------------------------------------------
 * Contact segment.
 *
 * The extreme points of A n B lie on edges (see tri_tri_overlap_exact), and an extreme
 * point of A n B on edge e is an extreme point of e n (other triangle). So the contact
 * set is the convex hull of the endpoints of the pieces e n other over the edges that
 * meet the other triangle (decided exactly); the reported pair is the farthest pair of
 * those endpoints: the two ends of the crossing segment, or two extreme points of the
 * overlap polygon along its longest extent when coplanar.
 *
 * Accuracy: which edges take part, which endpoints are input vertices, and which piece
 * ends are unclipped are exact decisions. An endpoint on a vertex is that vertex exactly.
 * A constructed endpoint is the point at parameter t on an edge PQ, t a ratio of two
 * plane (or edge-line) distances computed in double, clamped to [0, 1] so it never leaves its edge; its error
 * is a few units of roundoff times the triangles' extent (plus the coordinates' own ulp),
 * divided by the sine of the angle between the edge and the plane or line it crosses.
 * Crossings at grazing angles are therefore the least accurate, though still on the edge.
 * A point contact that is not a vertex may come out as two points a few ulps apart.
 * ------------------------------------------------------------------------------------ */

typedef struct contact_points {
    vec3 pt[12];
    int count;
} contact_points;

static void contact_add(contact_points *c, vec3 p)
{
    if (c->count < 12)
        c->pt[c->count++] = p;
}

/* The point at parameter t in [0, 1] on pq; a convex combination cannot overflow. */
static vec3 point_on_edge(vec3 p, vec3 q, double t)
{
    if (t <= 0.0)
        return p;
    if (t >= 1.0)
        return q;
    double s = 1.0 - t;
    return vec3_make(s * p.x + t * q.x, s * p.y + t * q.y, s * p.z + t * q.z);
}

/* Where a linear function with values fp at p and fq at q vanishes, kept in [0, 1] and
 * finite whatever rounding did to the values. */
static double zero_crossing(double fp, double fq)
{
    double den = fp - fq;
    if (den == 0.0 || !isfinite(den))
        return 0.5;
    double t = fp / den;
    if (!(t >= 0.0))
        return 0.0;
    return t > 1.0 ? 1.0 : t;
}

/* (a - x) x (b - x) along axis in double; orient2d_axis(a, b, x) is its exact sign. */
static double edge_value(vec3 a, vec3 b, vec3 x, int axis)
{
    int u = other_axis_u(axis), v = other_axis_v(axis);
    return cross_2d(vec3_get(a, u), vec3_get(a, v), vec3_get(b, u), vec3_get(b, v),
                    vec3_get(x, u), vec3_get(x, v));
}

/* Adds the ends of (segment pq) n (triangle t), for a segment known to meet t. */
static void contact_seg_tri(contact_points *c, vec3 p, vec3 q, int sp, int sq, const vec3 t[3],
                            int axis)
{
    if (sp != 0 || sq != 0) {
        if (sp == 0) {
            contact_add(c, p);
        } else if (sq == 0) {
            contact_add(c, q);
        } else {
            vec3 n = vec3_cross(vec3_sub(t[1], t[0]), vec3_sub(t[2], t[0]));
            double fp = vec3_dot(n, vec3_sub(p, t[0])), fq = vec3_dot(n, vec3_sub(q, t[0]));
            contact_add(c, point_on_edge(p, q, zero_crossing(fp, fq)));
        }
        return;
    }
    /* In the plane: clip the parameter range of pq by each edge's inner half-plane. */
    int turn = orient2d_axis(t[0], t[1], t[2], axis);
    double t_enter = 0.0, t_leave = 1.0;
    for (int i = 0; i < 3; i++) {
        vec3 e0 = t[i], e1 = t[i == 2 ? 0 : i + 1];
        int gp = orient2d_axis(e0, e1, p, axis) * turn;
        int gq = orient2d_axis(e0, e1, q, axis) * turn;
        if (gp >= 0 && gq >= 0)
            continue;
        if (gp < 0 && gq < 0) /* cannot happen for a segment meeting t */
            continue;
        double cross = gq == 0 ? 1.0 : gp == 0 ? 0.0
                       : zero_crossing(edge_value(e0, e1, p, axis), edge_value(e0, e1, q, axis));
        if (gp < 0)
            t_enter = fmax(t_enter, cross);
        else
            t_leave = fmin(t_leave, cross);
    }
    if (t_enter > t_leave)
        t_enter = t_leave = 0.5 * (t_enter + t_leave);
    contact_add(c, point_on_edge(p, q, t_enter));
    contact_add(c, point_on_edge(p, q, t_leave));
}

/* Adds (segment pq) n (segment rs) for segments known to meet (p != q, r != s). */
static void contact_seg_seg(contact_points *c, vec3 p, vec3 q, vec3 r, vec3 s)
{
    int axis = plane_axis(p, q, r);
    if (axis < 0)
        axis = plane_axis(p, q, s);
    if (axis < 0) {
        /* Collinear overlap: its ends are input points. */
        axis = differing_axis(p, q);
        vec3 lo_pq = vec3_get(p, axis) <= vec3_get(q, axis) ? p : q;
        vec3 hi_pq = vec3_get(p, axis) <= vec3_get(q, axis) ? q : p;
        vec3 lo_rs = vec3_get(r, axis) <= vec3_get(s, axis) ? r : s;
        vec3 hi_rs = vec3_get(r, axis) <= vec3_get(s, axis) ? s : r;
        contact_add(c, vec3_get(lo_pq, axis) >= vec3_get(lo_rs, axis) ? lo_pq : lo_rs);
        contact_add(c, vec3_get(hi_pq, axis) <= vec3_get(hi_rs, axis) ? hi_pq : hi_rs);
        return;
    }
    if (orient2d_axis(r, s, p, axis) == 0)
        contact_add(c, p);
    else if (orient2d_axis(r, s, q, axis) == 0)
        contact_add(c, q);
    else if (orient2d_axis(p, q, r, axis) == 0)
        contact_add(c, r);
    else if (orient2d_axis(p, q, s, axis) == 0)
        contact_add(c, s);
    else
        contact_add(c, point_on_edge(p, q, zero_crossing(edge_value(r, s, p, axis),
                                                          edge_value(r, s, q, axis))));
}

static double distance_squared(vec3 p, vec3 q)
{
    vec3 d = vec3_sub(p, q);
    return vec3_dot(d, d);
}

/* A triangle-shaped a against b of any shape; sb are orient3d(a, b_i). */
static void contact_tri_any(contact_points *c, const vec3 a[3], tri_shape ka, const vec3 b[3],
                            tri_shape kb, const int sa[3], const int sb[3])
{
    if (kb.kind == SHAPE_POINT) {
        if (sb[kb.end0] == 0 &&
            point_in_tri_2d(b[kb.end0], a, ka.axis, orient2d_axis(a[0], a[1], a[2], ka.axis)))
            contact_add(c, b[kb.end0]);
        return;
    }
    if (kb.kind == SHAPE_SEGMENT) {
        vec3 p = b[kb.end0], q = b[kb.end1];
        if (seg_tri_exact(p, q, sb[kb.end0], sb[kb.end1], a, ka.axis))
            contact_seg_tri(c, p, q, sb[kb.end0], sb[kb.end1], a, ka.axis);
        return;
    }
    for (int i = 0; i < 3; i++) {
        int j = i == 2 ? 0 : i + 1;
        if (seg_tri_exact(b[i], b[j], sb[i], sb[j], a, ka.axis))
            contact_seg_tri(c, b[i], b[j], sb[i], sb[j], a, ka.axis);
        if (seg_tri_exact(a[i], a[j], sa[i], sa[j], b, kb.axis))
            contact_seg_tri(c, a[i], a[j], sa[i], sa[j], b, kb.axis);
    }
}

/* The shape's own best projection axis for constructions (classification takes the
 * first exact one; the largest normal component conditions the 2D ratios best). */
static tri_shape with_best_axis(const vec3 t[3], tri_shape shape)
{
    if (shape.kind == SHAPE_TRIANGLE) {
        int axis = plane_axis(t[0], t[1], t[2]);
        if (axis >= 0)
            shape.axis = axis;
    }
    return shape;
}

void tri_tri_contact_segment(const vec3 a[3], const vec3 b[3], vec3 *p, vec3 *q)
{
    int sa[3], sb[3];
    for (int i = 0; i < 3; i++) {
        sb[i] = orient3d(a[0], a[1], a[2], b[i]);
        sa[i] = orient3d(b[0], b[1], b[2], a[i]);
    }
    tri_shape ka = with_best_axis(a, classify_triangle(a));
    tri_shape kb = with_best_axis(b, classify_triangle(b));
    contact_points c;
    c.count = 0;
    if (ka.kind == SHAPE_TRIANGLE) {
        contact_tri_any(&c, a, ka, b, kb, sa, sb);
    } else if (kb.kind == SHAPE_TRIANGLE) {
        contact_tri_any(&c, b, kb, a, ka, sb, sa);
    } else if (tri_tri_overlap_exact(a, b)) {
        /* Two degenerate shapes (rare): what touches is a point of one, or a piece of two
         * segments. */
        if (ka.kind == SHAPE_POINT)
            contact_add(&c, a[ka.end0]);
        else if (kb.kind == SHAPE_POINT)
            contact_add(&c, b[kb.end0]);
        else
            contact_seg_seg(&c, a[ka.end0], a[ka.end1], b[kb.end0], b[kb.end1]);
    }

    if (c.count == 0) {
        /* Not touching after all (outside the contract): the closest vertex pair. */
        double best = DBL_MAX;
        *p = a[0];
        *q = b[0];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                if (distance_squared(a[i], b[j]) < best) {
                    best = distance_squared(a[i], b[j]);
                    *p = a[i];
                    *q = b[j];
                }
        return;
    }
    int best_i = 0, best_j = 0;
    double best = -1.0;
    for (int i = 0; i < c.count; i++)
        for (int j = i; j < c.count; j++)
            if (distance_squared(c.pt[i], c.pt[j]) > best) {
                best = distance_squared(c.pt[i], c.pt[j]);
                best_i = i;
                best_j = j;
            }
    *p = c.pt[best_i];
    *q = c.pt[best_j];
}
