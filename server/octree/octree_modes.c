/* What fast and seed queries add to the octree's exact membership so that they find every
 * triangle their own final test accepts: the slack by which their walks and descents grow
 * node boxes, and the seed triangles that no slack covers, listed once per tree.
 *
 * Every mode builds the same tree, with exact membership: a triangle touching a node's
 * closed box is in the node. A query in exact mode visits the nodes its ray or triangle
 * touches, exactly or more. A fast or seed final test can accept a triangle the query does
 * not touch (rounding; the seed's epsilon), so such a query visits every node whose box,
 * grown by a slack delta in every direction, the query touches: if the test accepts T, a
 * point of T lies within delta (max norm) of the query, the leaf holding that point holds
 * T, and that leaf's grown box meets the query. The slacks below bound that distance.
 * u = 2^-53 is the unit roundoff throughout; |x| of a vector is its max norm. */
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "octree_modes.h"

#define U 0x1p-53

/* ---------- fast rays: Moller-Trumbore ----------
 *
 * ray_tri_fast computes e1 = v1 - v0, e2 = v2 - v0, s = o - v0, p = d x e2, q = s x e1,
 * det = e1.p, and u = (s.p)/det, v = (d.q)/det, t = (e2.q)/det, and accepts when
 * |det| > c |e1||e2||d| (c = FAST_PARALLEL_CUTOFF = 2^-20), u, v >= 0, u + v <= 1 and
 * tmin <= t <= tmax. Let P = v0 + u e1 + v e2 (a point of T, the computed u, v taken
 * exactly; fl(u + v) <= 1 lets u + v exceed 1 by 2u, which moves P by 2u D at most) and
 * Q = o + t d, the ray's point at the computed t. Then P - Q = A (x - x*) with
 * A = [e1 e2 -d], x = (u, v, t) computed and x* the exact solution, so
 *   |P - Q| <= |e1||du| + |e2||dv| + |d||dt|.
 * Each of s.p, d.q, e2.q, det is a triple product of the inputs' differences, whose
 * computed value is off by at most 8u times its permanent (orient3d's bound is
 * (7 + 56u)u), a permanent being at most 6 times the product of the three max norms. With
 * n = N + a, det = Det + b and one rounding each in 1/det and the product,
 *   |dx_i| <= (8u perm_i + |x*_i| 8u perm_det) / |det| + 2u |x*_i| (1 + small),
 * and |det| > c |e1||e2||d| turns every perm / |det| into 6 / c times the one norm the
 * numerator has that det lacks:
 *   |e1||du| <= (48u / c)(|s| + |u*||e1|) + 2u |u*||e1|, likewise for v with e2, and
 *   |d||dt| <= (48u / c)(|s| + |t*||d|) + 2u |t*||d|.
 * Every vertex lies in the world cube W of side D, so |s| <= S, the largest max-norm
 * distance from o to a corner of W, and |e1|, |e2| <= D. |u*| <= 1 + |du| and
 * |t*||d| <= |Q - o| + |d||dt| <= S + |P - Q| + |d||dt| keep the bound linear in itself;
 * with k = 48u / c + 2u = 2^-27.4 (c = 2^-20) it solves to
 *   |P - Q| <= 1.01 k (4 S + 2 D) <= 2^-25.4 (S + D).
 * The slack used is 2^-23 (S + D), five times that, which also covers the roundings in the
 * cutoff's own product and in S. The derivation needs the triple products free of
 * overflow and underflow: S, D and |d| at most 2^300, and |e1||e2||d| at least 2^-960 for
 * every triangle (the tree keeps the smallest nonzero |e1||e2|; a zero edge gives det = 0,
 * which the test rejects). Outside that, the slack is infinite: the walk visits every
 * node, which is brute force.
 *
 * With the old cutoff c = 1e-12 the same bound is 0.03 (S + D): a walk that wide is brute
 * force in all but name, which is why the cutoff is 2^-20 (Moller and Trumbore's 1e-6, made
 * relative to the sizes). */
#define FAST_RAY_SLACK 0x1p-23
#define RANGE_MAX 0x1p300
#define EDGE_PRODUCT_MIN 0x1p-960

double octree_fast_ray_slack(const struct octree *tree, vec3 o, vec3 d)
{
    box3 w = tree->world;
    double s = fmax(fmax(fmax(fabs(o.x - w.lo.x), fabs(o.x - w.hi.x)), fmax(fabs(o.y - w.lo.y), fabs(o.y - w.hi.y))),
                    fmax(fabs(o.z - w.lo.z), fabs(o.z - w.hi.z)));
    double size = w.hi.x - w.lo.x;
    double dm = fmax(fabs(d.x), fmax(fabs(d.y), fabs(d.z)));
    if (!(s + size <= RANGE_MAX) || !(dm <= RANGE_MAX))
        return INFINITY;
    if (tree->fast_edge_product_log2 != INT_MAX && !(ldexp(dm, tree->fast_edge_product_log2) >= EDGE_PRODUCT_MIN))
        return INFINITY;
    return FAST_RAY_SLACK * (s + size);
}

/* ---------- seed: the epsilon tests ----------
 *
 * ray_tri_seed accepts when the point p = o + t d, t = n.(v0 - o) / (n.d + eps) (n the
 * unit normal), lies on the inner side of each edge's line by less than eps along the
 * edge's unit outward normal, with tmin - eps < t < tmax + eps. In exact arithmetic
 * n.(p - v0) = -t eps: p lies |t| eps off the plane. Within the plane, the region where
 * all three edge distances are below eps is T offset outward by eps, whose corners lie
 * eps / sin(a / 2) <= 2 eps / sin a from T's (a the angle there). So p is within
 *   r_T = 2 eps' / sin(a_min) + |t| eps' of T,
 * eps' being eps plus the rounding of the computed distances. A triangle whose smallest
 * angle has a sine below SEED_SLIVER (or none: zero area, overflow) has a normal the
 * rounding may point anywhere and a reach without a useful bound: such triangles go on the
 * tree's sliver list, which every seed query tests, and the others set the tree's reach
 * factor K = max 2 / sin(a_min). Their normals and edge normals are accurate to
 * 4u / SEED_SLIVER, so a distance measured over at most 2 D (a point near T to a vertex)
 * is off by (8u / SEED_SLIVER) D, plus 4u of the coordinates' magnitude M for the rounded
 * p and differences: eps' = eps + (8u / SEED_SLIVER) D + 4u M.
 *
 * tri_tri_overlap_seed accepts when (1) a vertex of one triangle lies within eps of the
 * other's plane and its edge distances are below eps, or (2) an edge start + s E, with
 * s = n.(v0 - start) / (n.E + eps) in (-eps, 1 + eps), meets the other triangle so: the
 * point lies (1 + eps) eps off the plane (as for rays, with |s| <= 1 + eps) and up to
 * eps |E| past the edge's ends. Both ways round, q and T then lie within
 *   eps (|E| + 2) + K_both eps'
 * of each other, |E| the longest edge (at most D for the world's), K_both the larger of the
 * tree's K and the query's own 2 / sin(a_min). A zero-area query has a zero normal and
 * touches every triangle (the seed's own behaviour, tri_tri.c); a sliver query has no
 * useful bound either: both are tested against every triangle. */
#define SEED_SLIVER 0x1p-10

/* The square of the sine of the triangle's smallest angle, or -1 when the sine is below
 * SEED_SLIVER or not a finite number (zero area, overflow). The smallest angle is opposite
 * the shortest edge, between the two longest: sin^2 = |cross|^2 / (l1^2 l2^2). Squares, so
 * a tree's build takes no square root per triangle (octree_modes_prepare). */
static double seed_sine_squared(const vec3 t[3])
{
    vec3 e0 = vec3_sub(t[1], t[0]), e1 = vec3_sub(t[2], t[1]), e2 = vec3_sub(t[0], t[2]);
    double q0 = vec3_dot(e0, e0), q1 = vec3_dot(e1, e1), q2 = vec3_dot(e2, e2);
    vec3 c = vec3_cross(e2, e0);
    double area2 = vec3_dot(c, c);
    double product = q0 <= q1 && q0 <= q2 ? q1 * q2 : q1 <= q2 ? q0 * q2 : q0 * q1;
    double sine2 = area2 / product;
    if (!(sine2 >= SEED_SLIVER * SEED_SLIVER) || !isfinite(area2) || !isfinite(product))
        return -1.0;
    return sine2 < 1.0 ? sine2 : 1.0;
}

/* 2 / sin of the triangle's smallest angle, or INFINITY when the sine is below SEED_SLIVER
 * or not a finite number. */
static double seed_reach_factor(const vec3 t[3])
{
    double sine2 = seed_sine_squared(t);
    return sine2 < 0.0 ? INFINITY : 2.0 / sqrt(sine2);
}

static double seed_epsilon_rounded(const struct octree *tree, double magnitude)
{
    double size = tree->world.hi.x - tree->world.lo.x;
    return tree->seed_epsilon + (8 * U / SEED_SLIVER) * size + 4 * U * magnitude;
}

static double world_magnitude(const struct octree *tree)
{
    box3 w = tree->world;
    return fmax(fmax(fmax(fabs(w.lo.x), fabs(w.hi.x)), fmax(fabs(w.lo.y), fabs(w.hi.y))),
                fmax(fabs(w.lo.z), fabs(w.hi.z)));
}

/* What a query triangle's slack scales with: the largest coordinate magnitude of the
 * world and q, and q's longest edge in max norm. */
static void query_reach(const struct octree *tree, const vec3 q[3], double *magnitude, double *longest)
{
    *magnitude = world_magnitude(tree);
    *longest = 0.0;
    for (int i = 0; i < 3; i++) {
        *magnitude = fmax(*magnitude, fmax(fabs(q[i].x), fmax(fabs(q[i].y), fabs(q[i].z))));
        vec3 e = vec3_sub(q[i == 2 ? 0 : i + 1], q[i]);
        *longest = fmax(*longest, fmax(fabs(e.x), fmax(fabs(e.y), fabs(e.z))));
    }
}

/* Seed rays. With the constant part A = K eps' + eps |d| (tmin - eps and tmax + eps move
 * the point by eps |d|) and B = eps' per unit |t|, a hit at t puts p within A + B |t| of
 * T, so inside W grown by that; along the axis of the largest direction component this
 * bounds |t| |d| <= S + A + B |t|, |t| <= (S + A) / (|d| - B) = T_far, and the slack is
 * A + B T_far. A direction no longer than B (eps is absolute, d need not be unit) leaves
 * t unbounded: infinite slack. */
double octree_seed_ray_slack(const struct octree *tree, vec3 o, vec3 d)
{
    box3 w = tree->world;
    double s = fmax(fmax(fmax(fabs(o.x - w.lo.x), fabs(o.x - w.hi.x)), fmax(fabs(o.y - w.lo.y), fabs(o.y - w.hi.y))),
                    fmax(fabs(o.z - w.lo.z), fabs(o.z - w.hi.z)));
    double dm = fmax(fabs(d.x), fmax(fabs(d.y), fabs(d.z)));
    double magnitude = fmax(world_magnitude(tree), fmax(fabs(o.x), fmax(fabs(o.y), fabs(o.z))));
    double eps = seed_epsilon_rounded(tree, magnitude);
    /* p = o + t d rounds by u (|o| + |t d|) per coordinate: 4u per unit |t| |d|. */
    double a = tree->seed_reach_factor * eps + tree->seed_epsilon * dm + 4 * U * magnitude;
    double b = eps + 4 * U * dm;
    if (!(dm > 2 * b) || !isfinite(a))
        return INFINITY;
    double t_far = (s + a) / (dm - b);
    double slack = 2 * (a + b * t_far);
    return isfinite(slack) ? slack : INFINITY;
}

double octree_seed_triangle_slack(const struct octree *tree, const vec3 q[3])
{
    double k = seed_reach_factor(q);
    if (!isfinite(k))
        return INFINITY;
    double magnitude, longest;
    query_reach(tree, q, &magnitude, &longest);
    longest = fmax(longest, tree->world.hi.x - tree->world.lo.x);
    double eps = seed_epsilon_rounded(tree, magnitude);
    double slack = 2 * (tree->seed_epsilon * (longest + 2) + fmax(k, tree->seed_reach_factor) * eps);
    return isfinite(slack) ? slack : INFINITY;
}

/* ---------- fast triangles: Moller's interval test ----------
 *
 * tri_tri_overlap_fast measures each vertex's distance to the other triangle's plane as
 * n.x + offset on the absolute coordinates, off by about 7u M |n| for coordinates of
 * magnitude M, so a triangle it places on a plane lies within 7u M of it.
 *
 * Crossing planes. The test takes planes as crossing when the normals, scaled to a max
 * norm of 1, have a cross product of max norm above c = TRI_TRI_FAST_COPLANAR = 2^-15;
 * with |x|_max <= |x|_2 <= sqrt(3) |x|_max that puts the sine of the angle b between the
 * planes above c / 3 (less the cross product's own rounding, a few u). Each end of a
 * triangle's interval on the common line is where an edge crosses the other plane; the
 * distances' error 7u M moves it along the line by 7u M / sin b, and the two ends
 * compared by about twice that, 14u M / sin b < 42u M / c = 2^-32.6 M. Triangles the
 * test accepts there lie within that of each other: the slack 2^-32 (M + D) covers it.
 *
 * Nearly parallel planes (max norm of the scaled cross product at most c, so sin b at
 * most sqrt(3) c + a few u) are decided in the coplanar branch: both triangles projected
 * along the axis of the query's largest normal component, then plain double 2D overlap
 * (edges crossing, or a vertex inside). The plane-side rejection came first, so T has a
 * vertex on each closed side of q's plane (up to 7u M): every point of T lies within
 * diam(T) sin b + 7u M <= sqrt(3) L_T sqrt(3) c + 7u M = 3c L_T + 7u M of it, L_T the
 * longest edge of T in max norm; the points of q lie within their own rounding (7u M,
 * plus diam(q) times the angle by which q's rounded normal misses its plane, a few u for a
 * triangle that is not a sliver) of it. Two points x of T and y of q with the same
 * projection differ only along the projection axis, whose angle with q's normal has a
 * cosine of at least 1 / sqrt(3), so |x - y| <= sqrt(3) (3c L_T + 14u M + ...). The 2D
 * test's own rounding works on coordinate differences: it accepts projections apart by a
 * few u times the coordinates' extent, which the 2^-32 (M + D) term covers. So accepted
 * pairs lie within 5.2c L_T = 2^-12.6 L_T plus rounding; the slack adds
 * FAST_COPLANAR_SLACK (L_T + L_q) = 2^-11 (L_T + L_q), L_T the tree's longest edge
 * (rounded up to a power of two) and L_q the query's, which covers it with room for the normals' rounding and for the same
 * bound with the roles swapped (a zero-area query is projected along T's normal).
 *
 * What this does not bound: a triangle whose rounded normal misses its plane by more than
 * about 2^-14 (a sliver whose area is near the rounding of its edges' cross product, or
 * zero area: its normal is zero and any plane goes), which may meet the other's plane at
 * a steep angle while the test projects it as coplanar. So the test takes such a triangle
 * (tri_tri.c's fast_flat: a normal at most 2^-30 times its edges' product, whose direction
 * the cross product's rounding, a few u of that product, turns by less than 2^-21
 * otherwise, which the 2^-11 term covers many times) as the segments it is: an accepted
 * edge crosses the other's plane at a point whose distances were interpolated to zero,
 * within a few u M of the plane, and that point lies in the other's projection up to the
 * 2D test's rounding, so the pair lies within the first term. Two flat triangles are not
 * bounded; but a flat triangle is a sliver (a normal that small means a smallest angle's
 * sine far below SEED_SLIVER), so every flat world triangle is on the tree's sliver list,
 * and a sliver query tests that list besides the nodes its slack reaches. */
#define FAST_TRIANGLE_SLACK 0x1p-32
#define FAST_COPLANAR_SLACK 0x1p-11
/* 2^-1100 is 0 and 2^2000 is infinite in double: no edge, and an edge that overflowed. */
#define FAST_NO_EDGE_LOG2 (-1100)
#define FAST_HUGE_EDGE_LOG2 2000

int octree_is_sliver(const vec3 t[3]) { return !isfinite(seed_reach_factor(t)); }

double octree_fast_triangle_slack(const struct octree *tree, const vec3 q[3])
{
    double magnitude, longest;
    query_reach(tree, q, &magnitude, &longest);
    double slack = FAST_TRIANGLE_SLACK * (magnitude + (tree->world.hi.x - tree->world.lo.x)) +
                   FAST_COPLANAR_SLACK * (ldexp(1.0, tree->fast_longest_edge_log2) + longest);
    return isfinite(slack) ? slack : INFINITY;
}

/* ---------- per tree ---------- */

static inline double larger(double a, double b) { return a > b ? a : b; }

static inline double max_norm(vec3 v) { return larger(fabs(v.x), larger(fabs(v.y), fabs(v.z))); }

octree_status octree_modes_prepare(struct octree *tree)
{
    size_t n = tree->triangle_count, listed = 0, capacity = 0;
    /* The largest reach factor is that of the smallest sine: 2 / sqrt is monotone, so one
     * square root at the end gives what one per triangle would. */
    double product_min = INFINITY, sine2_min = 1.0, longest = 0.0;
    uint32_t *list = NULL;
    for (size_t i = 0; i < n; i++) {
        vec3 t[3];
        octree_triangle_vertices(tree, (uint32_t)i, t);
        vec3 e1 = vec3_sub(t[1], t[0]), e2 = vec3_sub(t[2], t[0]), e3 = vec3_sub(t[2], t[1]);
        /* Max norms by comparisons: a libm fmax call per pair cost the build more than the
         * arithmetic (every value here is a magnitude, never NaN). */
        double m1 = max_norm(e1), m2 = max_norm(e2), m3 = max_norm(e3);
        double product = m1 * m2;
        if (product > 0.0 && product < product_min)
            product_min = product;
        longest = larger(longest, larger(m1, larger(m2, m3)));
        double sine2 = seed_sine_squared(t);
        if (sine2 >= 0.0) {
            sine2_min = sine2 < sine2_min ? sine2 : sine2_min;
            continue;
        }
        if (array_reserve((void **)&list, &capacity, listed + 1, sizeof *list, 16) != 0) {
            free(list);
            return OCTREE_ERR_NOMEM;
        }
        list[listed++] = (uint32_t)i;
    }
    /* product_min = f 2^e with f in [0.5, 1), so 2^(e - 1) is at or below it. */
    int e = INT_MAX;
    if (product_min < INFINITY) {
        frexp(product_min, &e);
        e -= 1;
    }
    tree->fast_edge_product_log2 = e;
    /* longest = f 2^e with f in [0.5, 1), so 2^e is at or above it. */
    int le = FAST_NO_EDGE_LOG2;
    if (!(longest < INFINITY))
        le = FAST_HUGE_EDGE_LOG2;
    else if (longest > 0.0)
        frexp(longest, &le);
    tree->fast_longest_edge_log2 = (short)le;
    /* Rounded up to a float: the factor only ever grows a slack. */
    double reach = 2.0 / sqrt(sine2_min);
    float f = (float)reach;
    tree->seed_reach_factor = (double)f < reach ? nextafterf(f, INFINITY) : f;
    tree->sliver_list_count = (uint32_t)listed;
    if (listed) {
        size_t refs = tree->info.leaf_refs;
        uint32_t *items = realloc(tree->leaf_items, (refs + listed) * sizeof *items);
        if (!items) {
            free(list);
            return OCTREE_ERR_NOMEM;
        }
        memcpy(items + refs, list, listed * sizeof *items);
        tree->leaf_items = items;
    }
    free(list);
    return OCTREE_OK;
}
