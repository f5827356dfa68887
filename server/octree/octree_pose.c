/* Rigid poses: the one way a local vertex is placed in the world, the check that a pose is a
 * rotation, and what a walk in a posed tree's local frame must be widened by so that it
 * still reaches every triangle the world-space ray meets (octree_ray_posed).
 *
 * The bounds below use u = 2^-53 (a double's unit roundoff) and tau, a bound on the
 * spectral norm of R^T R - I (how far R is from orthonormal), which pose_defect
 * computes from R itself. Each is derived where it is used, and each is taken about twice
 * as large as the derivation needs, so that the rounding of the bound's own arithmetic
 * cannot make it too small. */
#include <float.h>
#include <math.h>

#include "../../common/quaternion.h"
#include "octree_internal.h"

#define U 0x1p-53

vec3 octree_pose_point(const pose *at, vec3 p)
{
    return octree_apply_pose(at, p);
}

pose octree_pose_identity(void)
{
    return (pose){{1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0}};
}

int octree_pose_is_identity(const pose *at)
{
    static const double eye[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    for (int k = 0; k < 9; k++)
        if (at->r[k] != eye[k])
            return 0;
    return at->t.x == 0 && at->t.y == 0 && at->t.z == 0;
}

octree_status octree_pose_from_quaternion(vec3 t, double qw, double qx, double qy, double qz, pose *out)
{
    if (!vec3_is_finite(t))
        return OCTREE_ERR_NONFINITE;
    trioct_quaternion_status st = trioct_quaternion_matrix(qw, qx, qy, qz, out->r);
    if (st == TRIOCT_QUATERNION_NONFINITE)
        return OCTREE_ERR_NONFINITE;
    if (st != TRIOCT_QUATERNION_OK)
        return OCTREE_ERR_INVALID;
    out->t = t;
    return OCTREE_OK;
}

/* 0 with *tau a bound on the spectral norm of R^T R - I, or -1 when an entry of it is
 * NaN or above 1. */
static int pose_defect(const pose *at, double *tau)
{
    const double *r = at->r;
    double worst = 0.0;
    for (int i = 0; i < 3; i++)
        for (int j = i; j < 3; j++) {
            /* Entry (i, j) of R^T R: columns i and j of R. */
            double g = r[i] * r[j] + r[3 + i] * r[3 + j] + r[6 + i] * r[6 + j];
            double e = fabs(g - (i == j ? 1.0 : 0.0));
            if (!(e <= 1.0)) /* NaN, or nowhere near a rotation */
                return -1;
            worst = e > worst ? e : worst;
        }
    /* The spectral norm of the symmetric defect is at most its Frobenius norm, at most 3
     * times its largest entry. Each computed entry is within 4u (|columns|^2 <= 2 here)
     * of the real one, 8u more covers that and the sum. */
    *tau = 3.0 * (worst + 8 * U) * (1 + 4 * U);
    return 0;
}

/* octree_pose_check, with the defect bound the widenings below are made of. */
static octree_status rotation_check(const pose *at, double *tau)
{
    for (int k = 0; k < 9; k++)
        if (!isfinite(at->r[k]))
            return OCTREE_ERR_NONFINITE;
    if (!vec3_is_finite(at->t))
        return OCTREE_ERR_NONFINITE;
    if (pose_defect(at, tau) != 0 || *tau > 3.0 * OCTREE_ROTATION_TOLERANCE + 64 * U)
        return OCTREE_ERR_INVALID;
    const double *r = at->r;
    double det = r[0] * (r[4] * r[8] - r[5] * r[7]) - r[1] * (r[3] * r[8] - r[5] * r[6]) +
                 r[2] * (r[3] * r[7] - r[4] * r[6]);
    /* Orthonormal within the tolerance, the determinant is within a few of it of +1 or -1:
     * the sign tells a rotation from a reflection. */
    return det > 0.5 ? OCTREE_OK : OCTREE_ERR_INVALID;
}

octree_status octree_pose_check(const pose *at)
{
    double tau;
    return rotation_check(at, &tau);
}

static double max_abs3(vec3 v)
{
    double a = fabs(v.x), b = fabs(v.y), c = fabs(v.z);
    double m = a > b ? a : b;
    return m > c ? m : c;
}

/* How far a posed point fl(R p + t) may be from the real R p + t, per coordinate, for p in
 * the box `local`. Each coordinate is a sum of four terms rounded in six operations,
 * within 4.1u of the sum of |terms|; a row of R has |r|_1 <= sqrt(3) |r|_2 <= 1.8 (tau
 * <= 1/16 by the check), so the sum is at most 1.8 P + |t| with P the largest |coordinate|
 * in the box. */
static double pose_point_error(const pose *at, box3 local)
{
    double P = max_abs3(local.lo) > max_abs3(local.hi) ? max_abs3(local.lo) : max_abs3(local.hi);
    return 8 * U * (2 * P + max_abs3(at->t));
}

box3 octree_pose_box(const pose *at, box3 local)
{
    /* Each posed coordinate, ((r0 p.x + r1 p.y) + r2 p.z) + t.x, is a monotone function of
     * each of p.x, p.y, p.z on its own: every operation is, with the others held, and
     * rounding to nearest is monotone. So over a box it is largest and smallest at
     * corners, and the box of the eight posed corners holds every posed point. */
    box3 wb = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    for (int q = 0; q < 8; q++) {
        vec3 corner = {q & 1 ? local.hi.x : local.lo.x, q & 2 ? local.hi.y : local.lo.y,
                       q & 4 ? local.hi.z : local.lo.z};
        vec3 w = octree_apply_pose(at, corner);
        wb.lo = vec3_min(wb.lo, w);
        wb.hi = vec3_max(wb.hi, w);
    }
    return wb;
}

int octree_ray_box_interval(vec3 o, vec3 d, box3 b, double *t0, double *t1)
{
    /* Each crossing (c - o) / d rounds twice, so widening it by 4u of itself and the
     * smallest normal covers it. */
    double lo = -INFINITY, hi = INFINITY;
    const double os[3] = {o.x, o.y, o.z}, ds[3] = {d.x, d.y, d.z};
    const double bl[3] = {b.lo.x, b.lo.y, b.lo.z}, bh[3] = {b.hi.x, b.hi.y, b.hi.z};
    for (int a = 0; a < 3; a++) {
        if (ds[a] == 0.0) {
            if (os[a] < bl[a] || os[a] > bh[a])
                return 0;
            continue;
        }
        double ta = (bl[a] - os[a]) / ds[a], tb = (bh[a] - os[a]) / ds[a];
        double n = ta < tb ? ta : tb, f = ta < tb ? tb : ta;
        n -= fabs(n) * 4 * U + DBL_MIN;
        f += fabs(f) * 4 * U + DBL_MIN;
        lo = n > lo ? n : lo;
        hi = f < hi ? f : hi;
    }
    *t0 = lo;
    *t1 = hi;
    return lo <= hi;
}

/* R^T c: a world offset taken into the pose's frame, R^T standing for R^-1 (the bounds
 * below count what that and the rounding cost). */
static vec3 unrotate(const double *r, vec3 c)
{
    return (vec3){r[0] * c.x + r[3] * c.y + r[6] * c.z, r[1] * c.x + r[4] * c.y + r[7] * c.z,
                  r[2] * c.x + r[5] * c.y + r[8] * c.z};
}

octree_status octree_posed_ray_setup(const octree *tree, const pose *at, const ray_input *ray, posed_ray *out)
{
    double tau;
    octree_status st = rotation_check(at, &tau);
    if (st != OCTREE_OK)
        return st;
    const double *r = at->r;
    const vec3 o = ray->origin, d = ray->direction, t = at->t;
    /* The local ray: R^T (o - t) and R^T d, R^T standing for R^-1. */
    vec3 lo = unrotate(r, vec3_sub(o, t)), ld = unrotate(r, d);
    if (!vec3_is_finite(lo) || !vec3_is_finite(ld))
        return OCTREE_ERR_NONFINITE;
    if (ld.x == 0.0 && ld.y == 0.0 && ld.z == 0.0) /* a direction below 2^-1000 or so */
        return OCTREE_ERR_INVALID;
    out->at = *at;
    out->world = *ray;
    out->local = *ray;
    out->local.origin = lo;
    out->local.direction = ld;
    out->misses = 0;

    double T = max_abs3(t);
    double e = pose_point_error(at, tree->world);
    /* The posed triangle's real preimage A^-1(T_w), A(p) = R p + t, has its vertices within
     * |R^-1| e of the tree's own: |R^-1|_2 <= 1 / sqrt(1 - tau) <= 1.04, and a max-norm
     * error e is at most sqrt(3) e in the 2-norm, so 2e in the max norm covers every point
     * of it, by convexity. */
    double delta = 2 * e;
    /* The computed local ray against the real preimage of the world ray,
     * R^-1 (o - t) + s R^-1 d: |R^-1 - R^T|_2 <= tau / (1 - tau) |R|_2 <= 1.1 tau, and the
     * roundings of o - t and of the two products add 7.4u; with |o - t| <= |o| + |t| in
     * the max norm (sqrt(3) of it in the 2-norm) that is within (16u + 4 tau)(|o| + |t|)
     * at s = 0, and (16u + 4 tau) |d| more per unit of s. */
    double k = 16 * U + 4 * tau;
    double g_origin = k * (max_abs3(o) + T), g_direction = k * max_abs3(d);
    /* Hits are where the world ray is within the posed tree's reach: its world cube
     * posed. */
    box3 wb = octree_pose_box(at, tree->world);
    if (!vec3_is_finite(wb.lo) || !vec3_is_finite(wb.hi))
        return OCTREE_ERR_NONFINITE;
    double t0, t1;
    int reaches = octree_ray_box_interval(o, d, wb, &t0, &t1);
    if (reaches) {
        t0 = t0 > ray->tmin ? t0 : ray->tmin;
        t1 = t1 < ray->tmax ? t1 : ray->tmax;
        reaches = t0 <= t1;
    }
    if (!reaches) {
        out->misses = 1;
        out->grow = out->vertex_reach = out->origin_reach = out->direction_reach = out->s_bound = 0.0;
        return OCTREE_OK;
    }
    double S = fabs(t0) > fabs(t1) ? fabs(t0) : fabs(t1);
    /* Every hit at s in [t0, t1] is a point of a posed triangle whose preimage is within
     * delta of a tree triangle, and the computed local ray at s is within
     * g_origin + S g_direction of that preimage: the walk, widened by their sum (rounded
     * up), visits a leaf listing the triangle. */
    out->grow = (delta + g_origin + S * g_direction) * (1 + 16 * U) + DBL_MIN;
    out->vertex_reach = delta;
    out->origin_reach = g_origin;
    out->direction_reach = g_direction;
    out->s_bound = S;
    if (!(out->grow < INFINITY))
        return OCTREE_ERR_NONFINITE;
    return OCTREE_OK;
}

/* The local triangle's vertices against the real preimages of the world triangle's: each
 * as the local ray's origin (16u + 4 tau)(|q_k| + |t|); by convexity every point of the
 * real preimage of q is within the largest of them of the local triangle. A posed tree
 * triangle's real preimage is within 2e of the tree's (octree_posed_ray_setup), so a
 * posed triangle touching q has its tree triangle within the sum of the local q: the
 * descent, widened by it, reaches a leaf listing it. */
octree_status octree_posed_triangle_setup(const octree *tree, const pose *at, const vec3 tri[3], vec3 local[3],
                                          double *grow)
{
    double tau;
    octree_status st = rotation_check(at, &tau);
    if (st != OCTREE_OK)
        return st;
    const double *r = at->r;
    double T = max_abs3(at->t), worst = 0.0;
    for (int k = 0; k < 3; k++) {
        local[k] = unrotate(r, vec3_sub(tri[k], at->t));
        if (!vec3_is_finite(local[k]))
            return OCTREE_ERR_NONFINITE;
        double m = max_abs3(tri[k]);
        worst = m > worst ? m : worst;
    }
    double g = (16 * U + 4 * tau) * (worst + T);
    double delta = 2 * pose_point_error(at, tree->world);
    *grow = (delta + g) * (1 + 16 * U) + DBL_MIN;
    return *grow < INFINITY ? OCTREE_OK : OCTREE_ERR_NONFINITE;
}

/* The shape's pose relative to the world tree's frame, R_rel = R_w^T R_s and
 * t_rel = R_w^T (t_s - t_w), with what the descent must widen the world's boxes by: a
 * contact x of a shape triangle posed at shape_at and a world triangle posed at world_at
 * has its real preimage A_w^-1(x) within 2 e_w of a tree triangle (as for rays) and
 * within G_s of the shape triangle posed at the relative pose, where G_s bounds, per
 * shape vertex v, |fl(P_rel v) - A_w^-1(fl(P_s v))|: 2 e_s (the shape vertex's own
 * rounding, taken back by |R_w^-1| <= 1.04 and sqrt(3)), e_rel (posing at P_rel), the
 * computed R_rel against R_w^-1 R_s ((32u + 8 tau_w) in each entry, three entries a row)
 * and t_rel against R_w^-1 (t_s - t_w) ((16u + 4 tau_w)(|t_s| + |t_w|), as the local ray's
 * origin). So a point of the relatively posed shape triangle comes within 2 e_w + G_s of
 * a point of the tree triangle, and the descent, widened by that, reaches their leaves. */
octree_status octree_posed_pair_setup(const octree *world, const pose *world_at, const octree *shape,
                                      const pose *shape_at, pose *relative, double *grow)
{
    double tau, shape_tau;
    octree_status st = rotation_check(world_at, &tau);
    if (st == OCTREE_OK)
        st = rotation_check(shape_at, &shape_tau);
    if (st != OCTREE_OK)
        return st;
    const double *a = world_at->r, *b = shape_at->r;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            relative->r[3 * i + j] = a[i] * b[j] + a[3 + i] * b[3 + j] + a[6 + i] * b[6 + j];
    relative->t = unrotate(a, vec3_sub(shape_at->t, world_at->t));
    for (int k = 0; k < 9; k++)
        if (!isfinite(relative->r[k]))
            return OCTREE_ERR_NONFINITE;
    if (!vec3_is_finite(relative->t))
        return OCTREE_ERR_NONFINITE;
    double ps = max_abs3(shape->world.lo) > max_abs3(shape->world.hi) ? max_abs3(shape->world.lo)
                                                                     : max_abs3(shape->world.hi);
    double ts = max_abs3(shape_at->t), tw = max_abs3(world_at->t);
    double e_s = pose_point_error(shape_at, shape->world), e_rel = pose_point_error(relative, shape->world);
    double g_s = 2 * e_s + e_rel + 3 * (32 * U + 8 * tau) * ps + (16 * U + 4 * tau) * (ts + tw);
    double delta = 2 * pose_point_error(world_at, world->world);
    *grow = (delta + g_s) * (1 + 16 * U) + DBL_MIN;
    return *grow < INFINITY ? OCTREE_OK : OCTREE_ERR_NONFINITE;
}

/* A world point taken into a posed tree's frame, for distances: every posed tree triangle
 * has its real preimage within 2e (max norm) of the tree's triangle (as for rays), and
 * the computed local point is within (16u + 4 tau)(|p| + |t|) of p's real preimage (as a
 * ray's origin). A posed triangle at world distance r from p thus has a point of its tree
 * triangle within r / sqrt(1 - tau) of the local point, in the 2-norm, after the two
 * reaches in the max norm: a node box grown by *grow on every side whose distance from
 * the local point, squared and times *shrink2, exceeds r^2, holds no such triangle. */
octree_status octree_posed_point_setup(const octree *tree, const pose *at, vec3 p, vec3 *local, double *grow,
                                       double *shrink2)
{
    double tau;
    octree_status st = rotation_check(at, &tau);
    if (st != OCTREE_OK)
        return st;
    *local = unrotate(at->r, vec3_sub(p, at->t));
    if (!vec3_is_finite(*local))
        return OCTREE_ERR_NONFINITE;
    double g = (16 * U + 4 * tau) * (max_abs3(p) + max_abs3(at->t));
    *grow = (2 * pose_point_error(at, tree->world) + g) * (1 + 16 * U) + DBL_MIN;
    /* 1 - tau >= sigma_min(R)^2, less 16u for the rounding of the products it scales. */
    *shrink2 = (1 - tau) * (1 - 16 * U);
    return *grow < INFINITY ? OCTREE_OK : OCTREE_ERR_NONFINITE;
}

double octree_pose_reach(const octree *tree, const pose *at)
{
    /* Each posed vertex within e of the real image of the tree's (max norm), so by
     * convexity every point of a posed triangle within e of the real image of a point of
     * the tree's triangle, and that image within e of the posed box of any box holding
     * the point (octree_pose_box poses the corners alike): 2e covers both. */
    return 2 * pose_point_error(at, tree->world) * (1 + 16 * U) + DBL_MIN;
}

double octree_pose_defect(const pose *at)
{
    double tau;
    return rotation_check(at, &tau) == OCTREE_OK ? tau : INFINITY;
}

double octree_pose_vertex_error(const octree *tree, const pose *at)
{
    return pose_point_error(at, tree->world);
}
