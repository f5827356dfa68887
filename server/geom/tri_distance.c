/* Triangle to triangle distance bounds (tri_distance.h).
 *
 * Two disjoint closed triangles are nearest at a vertex of one and a point of the other,
 * or at two edges' points: the search tries the six vertices against the other triangle
 * and the nine edge pairs, in doubles, by the usual region tests (the closest point of a
 * triangle to a point by its Voronoi regions; of two segments by the clamped solution of
 * their 2x2 normal equations). Nothing there needs to be exact: the proof that follows
 * holds for any pair of points and any direction, and a poor choice only loosens it. */
#include "tri_distance.h"

#include "closest_point.h"
#include "interval.h"
#include "tri_tri.h"

typedef enum pair_kind { PAIR_A_VERTEX, PAIR_B_VERTEX, PAIR_EDGES } pair_kind;

/* The best pair the double search found: which features, and where on them. */
typedef struct pair_choice {
    double d2;
    pair_kind kind;
    int i, j;    /* the vertex, or a's edge and b's edge (edge k joins k and k + 1) */
    double s, t; /* on the other triangle (v, w), or along a's and b's edges */
    int face;    /* a vertex's nearest point inside the other's face */
    vec3 a_point, b_point;
} pair_choice;

static vec3 on_segment(vec3 p, vec3 q, double s)
{
    return (vec3){p.x + s * (q.x - p.x), p.y + s * (q.y - p.y), p.z + s * (q.z - p.z)};
}

static double dist2(vec3 a, vec3 b)
{
    vec3 d = vec3_sub(a, b);
    return vec3_dot(d, d);
}

/* The search runs on the triangles moved by -a0 (each coordinate rounded once): points
 * near 1e9 would round its candidates' squared distances by their 1e-7 steps and pick the
 * wrong pair among near ties. The parameters it finds are the proof's; the points are
 * moved back for the caller. */
static void search_near_origin(const vec3 a[3], const vec3 b[3], pair_choice *best)
{
    best->d2 = INFINITY;
    for (int side = 0; side < 2; side++) {
        const vec3 *from = side ? b : a, *to = side ? a : b;
        for (int i = 0; i < 3; i++) {
            double v, w;
            closest_region region;
            vec3 x = closest_point_on_triangle(from[i], to, &v, &w, &region);
            int face = region.feature == DISTANCE_FACE;
            double d2 = dist2(from[i], x);
            if (d2 < best->d2)
                *best = (pair_choice){d2, side ? PAIR_B_VERTEX : PAIR_A_VERTEX, i, 0, v, w, face,
                                      side ? x : from[i], side ? from[i] : x};
        }
    }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double s, t;
            vec3 p1 = a[i], q1 = a[(i + 1) % 3], p2 = b[j], q2 = b[(j + 1) % 3];
            closest_points_on_segments(p1, q1, p2, q2, &s, &t);
            vec3 x = on_segment(p1, q1, s), y = on_segment(p2, q2, t);
            double d2 = dist2(x, y);
            if (d2 < best->d2)
                *best = (pair_choice){d2, PAIR_EDGES, i, j, s, t, 0, x, y};
        }
}

static void search(const vec3 a[3], const vec3 b[3], pair_choice *best)
{
    vec3 la[3], lb[3];
    for (int k = 0; k < 3; k++) {
        la[k] = vec3_sub(a[k], a[0]);
        lb[k] = vec3_sub(b[k], a[0]);
    }
    search_near_origin(la, lb, best);
    best->a_point = vec3_add(best->a_point, a[0]);
    best->b_point = vec3_add(best->b_point, a[0]);
}

double triangle_pair_distance_estimate(const vec3 a[3], const vec3 b[3], vec3 *a_point, vec3 *b_point)
{
    pair_choice best;
    search(a, b, &best);
    *a_point = best.a_point;
    *b_point = best.b_point;
    return best.d2;
}

/* A real point of a closed triangle, as its vertex t0 and bounds on the offset
 * v (t1 - t0) + w (t2 - t0), v and w made a point of the triangle first: in [0, 1], and w
 * at most the real 1 - v. The offset is kept apart from the vertex so that two points
 * far from the origin are subtracted as offsets (a difference of coordinates near 1e9
 * in doubles would carry their 1e-7 steps into the bound). */
typedef struct triangle_point {
    vec3 base;
    interval3 offset;
} triangle_point;

static triangle_point point_of_triangle(const vec3 t[3], double v, double w)
{
    v = clamp01(v);
    double room = iv_down(1 - v);
    w = clamp01(w < room ? w : room);
    interval3 e1 = iv3_diff(t[1], t[0]), e2 = iv3_diff(t[2], t[0]);
    interval iv = iv_point(v), iw = iv_point(w);
    return (triangle_point){t[0], {iv_add(iv_mul(iv, e1.x), iv_mul(iw, e2.x)), iv_add(iv_mul(iv, e1.y), iv_mul(iw, e2.y)),
                                   iv_add(iv_mul(iv, e1.z), iv_mul(iw, e2.z))}};
}

static triangle_point point_of_segment(vec3 p, vec3 q, double s)
{
    const vec3 t[3] = {p, q, p};
    return point_of_triangle(t, s, 0.0);
}

static triangle_point point_at(vec3 p)
{
    return (triangle_point){p, {{0, 0}, {0, 0}, {0, 0}}};
}

/* Bounds on x - y: (x.base - y.base) + x.offset - y.offset. */
static interval3 points_difference(triangle_point x, triangle_point y)
{
    interval3 d = iv3_diff(x.base, y.base);
    return (interval3){iv_sub(iv_add(d.x, x.offset.x), y.offset.x), iv_sub(iv_add(d.y, x.offset.y), y.offset.y),
                       iv_sub(iv_add(d.z, x.offset.z), y.offset.z)};
}

interval3 triangle_point_minus(const vec3 t[3], double v, double w, vec3 p)
{
    return points_difference(point_of_triangle(t, v, w), point_at(p));
}

static interval3 iv3_of(vec3 p)
{
    return (interval3){iv_point(p.x), iv_point(p.y), iv_point(p.z)};
}

/* A lower bound of the squared distance from the gap of the triangles along n: every x in
 * a and y in b have n . (x - y) >= min_i n . a_i - max_j n . b_j (a linear function's
 * extremes over a triangle are at vertices), so |x - y| >= gap / |n| when the gap is
 * positive. Measured from b0, so that far-off coordinates do not swamp it. */
static double gap_lower2(const vec3 a[3], const vec3 b[3], vec3 n)
{
    interval3 in = iv3_of(n);
    double min_a = INFINITY, max_b = 0.0;
    for (int i = 0; i < 3; i++) {
        double lo = iv3_dot(in, iv3_diff(a[i], b[0])).lo;
        min_a = lo < min_a ? lo : min_a;
        if (!(lo == lo))
            return 0.0;
    }
    for (int j = 1; j < 3; j++) {
        double hi = iv3_dot(in, iv3_diff(b[j], b[0])).hi;
        max_b = hi > max_b ? hi : max_b;
        if (!(hi == hi))
            return 0.0;
    }
    double gap = iv_down(min_a - max_b);
    if (!(gap > 0))
        return 0.0;
    interval nn = iv3_norm2(in);
    double lo2 = iv_down(iv_down(gap * gap) / nn.hi);
    return lo2 > 0 ? lo2 : 0.0;
}

double convex_gap_lower2(const vec3 *a, int na, const vec3 *b, int nb, vec3 n)
{
    /* In plain doubles with a forward error bound, this being a filter run per pair:
     * each d = n . (p - o) has the difference's rounding (u |p - o| a coordinate) and the
     * dot product's (gamma_3 of |n| . |p - o|), together within 5u |n|_1 M for M the
     * largest max-norm |p - o|; the gap, a difference of two of them, within 10u |n|_1 M
     * plus its own rounding. */
    if (!vec3_is_finite(n) || (n.x == 0 && n.y == 0 && n.z == 0))
        return 0.0;
    vec3 o = b[0];
    double min_a = INFINITY, max_a = -INFINITY, min_b = INFINITY, max_b = -INFINITY, reach = 0;
    for (int i = 0; i < na + nb; i++) {
        vec3 q = vec3_sub(i < na ? a[i] : b[i - na], o);
        double d = n.x * q.x + n.y * q.y + n.z * q.z;
        double ax = fabs(q.x), ay = fabs(q.y), az = fabs(q.z);
        double m = ax > ay ? (ax > az ? ax : az) : (ay > az ? ay : az);
        reach = m > reach ? m : reach;
        if (i < na) {
            min_a = d < min_a ? d : min_a;
            max_a = d > max_a ? d : max_a;
        } else {
            min_b = d < min_b ? d : min_b;
            max_b = d > max_b ? d : max_b;
        }
    }
    double up = min_a - max_b, down = min_b - max_a;
    double gap = up > down ? up : down;
    double slack = 0x1.4p-49 * (fabs(n.x) + fabs(n.y) + fabs(n.z)) * reach + 0x1p-52 * fabs(gap) + 0x1p-1020;
    gap -= slack;
    if (!(gap > 0) || !(gap < INFINITY))
        return 0.0;
    /* gap^2 / |n|^2, each of the five roundings within u: 2^-48 of it covers them. */
    double nn = vec3_dot(n, n);
    double lo2 = gap * gap / nn * (1 - 0x1p-48);
    return lo2 > 0 && lo2 < INFINITY ? lo2 : 0.0;
}

/* gap_lower2 along n turned to point along `between` (from b's point to a's); 0 when n
 * is no direction. */
static double oriented_gap_lower2(const vec3 a[3], const vec3 b[3], vec3 n, vec3 between)
{
    double side = vec3_dot(n, between);
    if (!(side != 0) || !vec3_is_finite(n))
        return 0.0;
    return gap_lower2(a, b, side < 0 ? vec3_scale(n, -1.0) : n);
}

static void certify(const vec3 a[3], const vec3 b[3], const pair_choice *found, triangle_pair_distance *out);

void triangle_pair_distance_bounds(const vec3 a[3], const vec3 b[3], triangle_pair_distance *out)
{
    pair_choice best;
    search(a, b, &best);
    certify(a, b, &best, out);
}

int triangle_pair_distance_within(const vec3 a[3], const vec3 b[3], double limit2, triangle_pair_distance *out)
{
    pair_choice best;
    search(a, b, &best);
    /* The gap along the line between the points found, in doubles with its error bound:
     * when that alone is past the limit, the interval proof is not needed. */
    double far2 = convex_gap_lower2(a, 3, b, 3, vec3_sub(best.a_point, best.b_point));
    if (far2 > limit2) {
        *out = (triangle_pair_distance){far2, INFINITY, best.a_point, best.b_point};
        return 0;
    }
    certify(a, b, &best, out);
    return out->lo2 <= limit2;
}

/* The bounds of the pair the search found (see the header). */
static void certify(const vec3 a[3], const vec3 b[3], const pair_choice *found, triangle_pair_distance *out)
{
    pair_choice best = *found;

    /* The upper bound: the two points found, as the real points of the triangles they
     * stand for. */
    triangle_point pa, pb;
    vec3 n;
    switch (best.kind) {
    case PAIR_A_VERTEX:
        pa = point_at(a[best.i]);
        pb = point_of_triangle(b, best.s, best.t);
        n = best.face ? vec3_cross(vec3_sub(b[1], b[0]), vec3_sub(b[2], b[0])) : (vec3){0, 0, 0};
        break;
    case PAIR_B_VERTEX:
        pb = point_at(b[best.i]);
        pa = point_of_triangle(a, best.s, best.t);
        n = best.face ? vec3_cross(vec3_sub(a[1], a[0]), vec3_sub(a[2], a[0])) : (vec3){0, 0, 0};
        break;
    default: {
        vec3 p1 = a[best.i], q1 = a[(best.i + 1) % 3], p2 = b[best.j], q2 = b[(best.j + 1) % 3];
        pa = point_of_segment(p1, q1, best.s);
        pb = point_of_segment(p2, q2, best.t);
        int interior = best.s > 0 && best.s < 1 && best.t > 0 && best.t < 1;
        n = interior ? vec3_cross(vec3_sub(q1, p1), vec3_sub(q2, p2)) : (vec3){0, 0, 0};
        break;
    }
    }
    interval3 apart = points_difference(pa, pb);
    interval hi = iv_sanitize_nonnegative(iv3_norm2(apart));
    out->hi2 = hi.hi;
    out->a_point = best.a_point;
    out->b_point = best.b_point;

    /* The lower bound: the gap along n, pointed from b towards a; and when that leaves
     * room (a direction from a sliver's normal or nearly parallel edges, whose rounding
     * tilts it), the gap along the line between the points as well. */
    vec3 between = iv3_mid(apart); /* as offsets: best.a_point - best.b_point would round */
    if (n.x == 0 && n.y == 0 && n.z == 0)
        n = between; /* a vertex or edge end: the line between the points */
    out->lo2 = oriented_gap_lower2(a, b, n, between);
    if (out->lo2 < out->hi2 * (1 - 0x1p-30))
        out->lo2 = fmax(out->lo2, oriented_gap_lower2(a, b, between, between));
    if (out->lo2 > 0)
        return;
    /* Not parted: touching, or too near for the direction's rounding. */
    if (tri_tri_overlap_exact(a, b)) {
        vec3 p, q;
        tri_tri_contact_segment(a, b, &p, &q);
        out->lo2 = out->hi2 = 0.0;
        out->a_point = out->b_point = p;
    }
}
