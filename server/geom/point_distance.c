/* Point to triangle distance bounds (point_distance.h).
 *
 * The nearest point of a closed triangle to p is the foot of the perpendicular on its plane
 * when that foot lies in the triangle, and otherwise the nearest point of one of its three
 * edges; an edge's nearest point is an end, or the foot on its line. Each case is an
 * algebraic formula in the differences v - p, computed here as intervals, and each case
 * choice is the sign of one such formula: where an interval decides the sign the case is
 * known, and where it does not, the bounds of both cases are joined. That stays tight:
 * an undecided sign means the two cases' distances agree to within the sign's own
 * uncertainty (at the boundary between two cases their formulas agree). */
#include "point_distance.h"

#include "closest_point.h"
#include "predicates.h"
#include "tri_distance.h"

/* The nearest point of the segment from va to vb, a = va - p and b = vb - p, e = vb - va,
 * |a|^2 and |b|^2 given. */
static void segment_part(interval3 a, interval3 b, interval3 e, interval ca, interval cb, vec3 va, vec3 vb,
                         point_triangle_distance *out)
{
    interval along_a = iv3_dot(a, e), along_b = iv3_dot(b, e);
    if (along_a.lo >= 0) { /* the foot is at or before a */
        *out = (point_triangle_distance){ca.lo, ca.hi, DISTANCE_VERTEX, 0, va};
        return;
    }
    if (along_b.hi <= 0) { /* at or past b */
        *out = (point_triangle_distance){cb.lo, cb.hi, DISTANCE_VERTEX, 1, vb};
        return;
    }
    /* The line's distance, |a x e|^2 / |e|^2, is a lower bound in every case, and the
     * distance itself when the foot is surely inside. Either end is an upper bound. */
    interval e2 = iv3_norm2(e);
    interval line = iv_sanitize_nonnegative(iv_div_nonnegative(iv3_norm2(iv3_cross(a, e)), e2));
    if (ca.hi <= cb.hi)
        *out = (point_triangle_distance){line.lo, ca.hi, DISTANCE_VERTEX, 0, va};
    else
        *out = (point_triangle_distance){line.lo, cb.hi, DISTANCE_VERTEX, 1, vb};
    if (along_a.hi < 0 && along_b.lo > 0 && line.hi < out->hi2) {
        double t = -(0.5 * along_a.lo + 0.5 * along_a.hi) / (0.5 * e2.lo + 0.5 * e2.hi);
        t = t > 0 ? (t < 1 ? t : 1.0) : 0.0;
        vec3 d = vec3_sub(vb, va);
        out->hi2 = line.hi;
        out->feature = DISTANCE_EDGE;
        out->index = 0;
        out->point = (vec3){va.x + t * d.x, va.y + t * d.y, va.z + t * d.z};
    }
}

void point_segment_distance_bounds(vec3 p, vec3 a, vec3 b, point_triangle_distance *out)
{
    interval3 ia = iv3_diff(a, p), ib = iv3_diff(b, p);
    segment_part(ia, ib, iv3_diff(b, a), iv_sanitize_nonnegative(iv3_norm2(ia)),
                 iv_sanitize_nonnegative(iv3_norm2(ib)), a, b, out);
    out->lo2 = iv_sanitize_nonnegative((interval){out->lo2, out->hi2}).lo;
}

/* 1 when the three points are collinear (the triangle has no area), exactly. */
static int triangle_is_flat(const vec3 v[3])
{
    return orient2d_axis(v[0], v[1], v[2], 0) == 0 && orient2d_axis(v[0], v[1], v[2], 1) == 0 &&
           orient2d_axis(v[0], v[1], v[2], 2) == 0;
}

static interval iv_intersect(interval a, interval b)
{
    return (interval){iv_max2(a.lo, b.lo), iv_min2(a.hi, b.hi)};
}

void point_triangle_distance_intervals(vec3 p, const vec3 v[3], point_triangle_distance *out)
{
    interval3 a[3], e[3];
    interval c[3];
    for (int k = 0; k < 3; k++) {
        a[k] = iv3_diff(v[k], p);
        e[k] = iv3_diff(v[(k + 1) % 3], v[k]);
        c[k] = iv_sanitize_nonnegative(iv3_norm2(a[k]));
    }

    /* The edges: their smallest upper bound and their smallest lower bound bound the
     * smallest of the three distances. */
    point_triangle_distance edges = {INFINITY, INFINITY, DISTANCE_VERTEX, 0, v[0]};
    for (int k = 0; k < 3; k++) {
        int j = (k + 1) % 3;
        point_triangle_distance s;
        segment_part(a[k], a[j], e[k], c[k], c[j], v[k], v[j], &s);
        s.index = s.feature == DISTANCE_VERTEX ? (s.index ? j : k) : k;
        double lo2 = iv_min2(edges.lo2, s.lo2);
        if (s.hi2 < edges.hi2)
            edges = s;
        edges.lo2 = lo2;
    }

    /* The face: n = (v1 - v0) x (v2 - v0); the foot lies in the closed triangle when the
     * three signed areas n . ((v_j - p) x (v_k - p)) it makes with the edges are >= 0
     * (they sum to |n|^2). Its squared distance is (n . (v - p))^2 / |n|^2 for any vertex
     * v; the three are one real number, so their intervals are intersected. */
    interval3 n = iv3_cross(e[2], e[0]); /* (v0 - v2) x (v1 - v0) */
    interval nn = iv3_norm2(n);
    if (!(nn.hi > 0) || (!(nn.lo > 0) && triangle_is_flat(v))) {
        *out = edges; /* no area: the triangle is its edges */
        return;
    }
    int inside = nn.lo > 0, outside = 0;
    for (int k = 0; k < 3; k++) {
        interval area = iv3_dot(n, iv3_cross(a[(k + 1) % 3], a[(k + 2) % 3]));
        inside &= area.lo >= 0;
        outside |= area.hi < 0;
    }
    if (outside) {
        *out = edges;
        return;
    }
    interval off = iv_intersect(iv_intersect(iv3_dot(n, a[0]), iv3_dot(n, a[1])), iv3_dot(n, a[2]));
    interval h = iv_sanitize_nonnegative(iv_div_nonnegative(iv_sqr(off), nn));
    if (!inside) { /* the foot is on the boundary, to rounding: either case */
        *out = edges;
        out->lo2 = iv_min2(edges.lo2, h.lo);
        return;
    }
    if (h.hi < edges.hi2) {
        double s = (0.5 * off.lo + 0.5 * off.hi) / (0.5 * nn.lo + 0.5 * nn.hi);
        vec3 m = iv3_mid(n);
        *out = (point_triangle_distance){h.lo, h.hi, DISTANCE_FACE, 0, {p.x + s * m.x, p.y + s * m.y, p.z + s * m.z}};
    } else {
        *out = edges;
        out->lo2 = h.lo;
    }
}

void point_triangle_distance_bounds(vec3 p, const vec3 v[3], point_triangle_distance *out)
{
    /* The nearest point in doubles, searched near the origin (coordinates relative to p,
     * so that 1e9 offsets do not round the search); then its proof. */
    const vec3 local[3] = {vec3_sub(v[0], p), vec3_sub(v[1], p), vec3_sub(v[2], p)};
    double s, t;
    closest_region region;
    closest_point_on_triangle((vec3){0, 0, 0}, local, &s, &t, &region);
    interval3 apart = triangle_point_minus(v, s, t, p);
    interval hi = iv_sanitize_nonnegative(iv3_norm2(apart));
    vec3 n = iv3_mid(apart);
    /* The triangle lies beyond the plane through the point found, normal to the line from
     * p to it, when that point is the nearest (its region's half-space): the gap along
     * that line is then the distance itself, and for any other direction still a lower
     * bound. */
    double lo2 = convex_gap_lower2(&p, 1, v, 3, n);
    if (region.feature == DISTANCE_FACE && lo2 < hi.hi * (1 - 0x1p-30)) {
        double along = convex_gap_lower2(&p, 1, v, 3, vec3_cross(vec3_sub(v[1], v[0]), vec3_sub(v[2], v[0])));
        lo2 = along > lo2 ? along : lo2;
    }
    if (!(lo2 >= hi.hi * (1 - 0x1p-30))) {
        /* Too near for the line's rounding (on the surface, or a sliver): the intervals
         * over every case, slower and tight everywhere. */
        point_triangle_distance_intervals(p, v, out);
        return;
    }
    /* The point reported: a vertex itself, else the weights' point on the triangle (in the
     * triangle's coordinates, so an edge along an axis keeps its exact coordinates). */
    vec3 at = v[region.index];
    if (region.feature != DISTANCE_VERTEX) {
        vec3 e1 = vec3_sub(v[1], v[0]), e2 = vec3_sub(v[2], v[0]);
        at = (vec3){v[0].x + s * e1.x + t * e2.x, v[0].y + s * e1.y + t * e2.y, v[0].z + s * e1.z + t * e2.z};
    }
    *out = (point_triangle_distance){lo2, hi.hi, region.feature, region.index, at};
}
