/* Closed triangle against closed axis-aligned box: the exact separating-axis test used to
 * build and descend the octree, the seed document's epsilon test, and the plain double test. */
#include "tri_box.h"

#include "box_geometry.h"
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

/* Coordinates as arrays so the axis tests can be written once for all three axes. */
typedef struct exact_input {
    double v[3][3]; /* triangle vertices */
    double lo[3], hi[3];
} exact_input;

static int cmp_sign(double a, double b) { return (a > b) - (a < b); }

/* The separating test along u_k x (q - p), with the values projected relative to p:
 * f(x) = ((x - p) x (q - p))_k, which is 0 at p and q and w = f(r) at the third vertex, so
 * the triangle covers [min(0, w), max(0, w)]. f depends only on the two coordinates i, j
 * other than k, so the box covers [f(m), f(M)] with m, M the corners of its projected
 * rectangle picked by the signs of (q - p)_i and (q - p)_j. Every comparison is the sign
 * of an expression (a - b)(c - d) - (e - f)(g - h), decided exactly. */
static int edge_axis_separates(const exact_input *in, int p_index, int q_index, int r_index, int k)
{
    const double *p = in->v[p_index], *q = in->v[q_index], *r = in->v[r_index];
    int i = k == 2 ? 0 : k + 1;
    int j = k == 0 ? 2 : k - 1;
    int ei = cmp_sign(q[i], p[i]);
    int ej = cmp_sign(q[j], p[j]);
    if (ei == 0 && ej == 0)
        return 0; /* the edge is parallel to axis k or has zero length: no axis */

    /* f grows with x_i when (q - p)_j > 0 and falls with x_j when (q - p)_i > 0. */
    double m_i = ej > 0 ? in->lo[i] : in->hi[i];
    double m_j = ei > 0 ? in->hi[j] : in->lo[j];
    double big_i = ej > 0 ? in->hi[i] : in->lo[i];
    double big_j = ei > 0 ? in->lo[j] : in->hi[j];

    /* Box wholly above the triangle: f(m) > 0 and f(m) > f(r). */
    if (sign_diff_products(m_i, p[i], q[j], p[j], m_j, p[j], q[i], p[i]) > 0 &&
        sign_diff_products(m_i, r[i], q[j], p[j], m_j, r[j], q[i], p[i]) > 0)
        return 1;
    /* Box wholly below: f(M) < 0 and f(M) < f(r). */
    if (sign_diff_products(big_i, p[i], q[j], p[j], big_j, p[j], q[i], p[i]) < 0 &&
        sign_diff_products(big_i, r[i], q[j], p[j], big_j, r[j], q[i], p[i]) < 0)
        return 1;
    return 0;
}

/* The plane of the triangle separates iff the box corner lowest along the normal is
 * strictly above it or the highest is strictly below; the exact sign of each normal
 * component picks those corners, orient3d places them. */
static int normal_axis_separates(const vec3 tri[3], box3 box)
{
    int nx = orient2d_axis(tri[1], tri[2], tri[0], 0);
    int ny = orient2d_axis(tri[1], tri[2], tri[0], 1);
    int nz = orient2d_axis(tri[1], tri[2], tri[0], 2);
    if (nx == 0 && ny == 0 && nz == 0)
        return 0; /* zero area: no plane */
    vec3 lowest = vec3_make(nx > 0 ? box.lo.x : box.hi.x, ny > 0 ? box.lo.y : box.hi.y,
                            nz > 0 ? box.lo.z : box.hi.z);
    if (orient3d(tri[0], tri[1], tri[2], lowest) > 0)
        return 1;
    vec3 highest = vec3_make(nx > 0 ? box.hi.x : box.lo.x, ny > 0 ? box.hi.y : box.lo.y,
                             nz > 0 ? box.hi.z : box.lo.z);
    return orient3d(tri[0], tri[1], tri[2], highest) < 0;
}

/* 1 when a point of the triangle is certainly inside the box: an edge midpoint or the
 * centroid, computed in double, lying inside by more than its rounding error, so the exact
 * point lies inside too. Most triangles straddling a node's split plane do touch the child
 * tested, and this settles them without the thirteen axis tests. */
static int interior_point_inside(const vec3 tri[3], box3 box)
{
    /* 0.5 * (a + b) is off by at most one rounding of the sum, (a + b + c) / 3 by three;
     * 4 u (|a| + |b| + |c|) bounds both with room to spare. */
    const double u4 = 4 * 0x1p-53;
    double lo[3] = {box.lo.x, box.lo.y, box.lo.z}, hi[3] = {box.hi.x, box.hi.y, box.hi.z};
    double v[3][3] = {{tri[0].x, tri[0].y, tri[0].z}, {tri[1].x, tri[1].y, tri[1].z}, {tri[2].x, tri[2].y, tri[2].z}};
    for (int p = 0; p < 4; p++) {
        int inside = 1;
        for (int k = 0; k < 3 && inside; k++) {
            double a = v[0][k], b = v[1][k], c = v[2][k], x, tol;
            if (p < 3) {
                double e0 = v[p][k], e1 = v[(p + 1) % 3][k];
                x = 0.5 * (e0 + e1);
                tol = u4 * (fabs(e0) + fabs(e1)) + 0x1p-1070;
            } else {
                x = (a + b + c) / 3.0;
                tol = u4 * (fabs(a) + fabs(b) + fabs(c)) + 0x1p-1070;
            }
            inside = x - tol > lo[k] && x + tol < hi[k];
        }
        if (inside)
            return 1;
    }
    return 0;
}

int tri_box_overlap_exact(const vec3 tri[3], box3 box)
{
    exact_input in;
    for (int t = 0; t < 3; t++) {
        in.v[t][0] = tri[t].x;
        in.v[t][1] = tri[t].y;
        in.v[t][2] = tri[t].z;
    }
    in.lo[0] = box.lo.x, in.lo[1] = box.lo.y, in.lo[2] = box.lo.z;
    in.hi[0] = box.hi.x, in.hi[1] = box.hi.y, in.hi[2] = box.hi.z;

    /* The box axes: plain comparisons are exact. */
    for (int k = 0; k < 3; k++) {
        double a = in.v[0][k], b = in.v[1][k], c = in.v[2][k];
        double tri_min = a < b ? (a < c ? a : c) : (b < c ? b : c);
        double tri_max = a > b ? (a > c ? a : c) : (b > c ? b : c);
        if (tri_min > in.hi[k] || tri_max < in.lo[k])
            return 0;
    }
    for (int t = 0; t < 3; t++) {
        if (in.v[t][0] >= in.lo[0] && in.v[t][0] <= in.hi[0] && in.v[t][1] >= in.lo[1] &&
            in.v[t][1] <= in.hi[1] && in.v[t][2] >= in.lo[2] && in.v[t][2] <= in.hi[2])
            return 1;
    }

    if (interior_point_inside(tri, box))
        return 1;
    if (normal_axis_separates(tri, box))
        return 0;
    for (int k = 0; k < 3; k++) {
        if (edge_axis_separates(&in, 0, 1, 2, k) || edge_axis_separates(&in, 1, 2, 0, k) ||
            edge_axis_separates(&in, 2, 0, 1, k))
            return 0;
    }
    return 1;
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
