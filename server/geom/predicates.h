/* Exact geometric predicates on double inputs: a floating-point filter decides the sign
 * when it can, and exact expansion arithmetic decides when it cannot. Every function
 * returns the sign (-1, 0, +1) of an exact real-number expression of its inputs, which
 * must be finite (the engine refuses NaN and infinities at its boundary; the exact stages
 * assert it). Differences of inputs may overflow: the filters then leave the sign to the
 * exact stage, which scales the inputs themselves, never a rounded difference. */
#ifndef TRIOCT_GEOM_PREDICATES_H
#define TRIOCT_GEOM_PREDICATES_H

#include <stdint.h>

#include "vec3.h"

/* Each predicate below is a float filter, inline because it sits in the innermost loops
 * of every query and of the build, followed by an exact stage out of line (the
 * *_undecided functions, which only the filters should call). The filters' error bounds
 * are derived at the top of predicates.c; u = 2^-53. The underflow terms keep the filter
 * from deciding once products fall toward 2^-1020 and determinants toward 2^-1070.
 *
 * PREDICATES_ZERO_SKIPS_BOUND: a determinant that rounds to exactly zero is never decided
 * by a filter (every bound is at least PREDICATES_UNDERFLOW_ABSOLUTE), so each filter
 * hands it on before forming its bound. Besides the saved work, this keeps the bound's
 * arithmetic out of the subnormal range: the exactly degenerate inputs (a ray through a
 * vertex, a point on an axis plane) have all-zero minors, whose padded permanent times the
 * error constant is subnormal, and a subnormal product costs a microcode assist of about
 * a hundred cycles on x86. */
#define PREDICATES_ERRBOUND_DIFF_PRODUCTS ((3.0 + 16.0 * 0x1p-53) * 0x1p-53)
#define PREDICATES_ERRBOUND_ORIENT3D ((7.0 + 80.0 * 0x1p-53) * 0x1p-53)
#define PREDICATES_ERRBOUND_RAY_EDGE ((6.0 + 64.0 * 0x1p-53) * 0x1p-53)
#define PREDICATES_UNDERFLOW_ABSOLUTE 0x1p-1070
#define PREDICATES_UNDERFLOW_MINOR_PAD 0x1p-1020

int sign_diff_products_undecided(double a, double b, double c, double d, double e, double f, double g,
                                 double h);
int orient3d_undecided(vec3 a, vec3 b, vec3 c, vec3 d);
int ray_edge_sign_undecided(vec3 p, vec3 q, vec3 o, vec3 dir);

/* Filter-only forms return the sign when the float filter decides it and
 * PREDICATES_UNDECIDED when it cannot (the caller then either proves its answer another
 * way or asks the exact stage through the full predicate). They let a test try a cheap
 * proof before paying for exact arithmetic on nearly degenerate inputs. */
#define PREDICATES_UNDECIDED 2

/* The filter of sign(left - right) for left = fl((a - b)(c - d)) and right =
 * fl((e - f)(g - h)), however the factors were obtained, provided each is the rounded
 * difference of two doubles (a caller may compute a factor once for many evaluations: the
 * rounding is the same). */
static inline int products_difference_filter(double left, double right)
{
    double det = left - right;
    if (det == 0.0) /* see PREDICATES_ZERO_SKIPS_BOUND */
        return PREDICATES_UNDECIDED;
    double bound = PREDICATES_ERRBOUND_DIFF_PRODUCTS * (fabs(left) + fabs(right)) + PREDICATES_UNDERFLOW_ABSOLUTE;
    if (fabs(det) > bound)
        return (det > 0.0) - (det < 0.0);
    return PREDICATES_UNDECIDED;
}

/* sign_diff_products' filter alone. */
static inline int sign_diff_products_filter(double a, double b, double c, double d, double e, double f, double g,
                                            double h)
{
    return products_difference_filter((a - b) * (c - d), (e - f) * (g - h));
}

/* sign of (a - b)(c - d) - (e - f)(g - h): the shape of every 2D separating-axis test. */
static inline int sign_diff_products(double a, double b, double c, double d, double e, double f, double g,
                                     double h)
{
    int sign = sign_diff_products_filter(a, b, c, d, e, f, g, h);
    return sign != PREDICATES_UNDECIDED ? sign : sign_diff_products_undecided(a, b, c, d, e, f, g, h);
}

/* sign of (a - c) x (b - c) = (ax-cx)(by-cy) - (ay-cy)(bx-cx): +1 when a, b, c turn
 * counter-clockwise. */
static inline int orient2d(double ax, double ay, double bx, double by, double cx, double cy)
{
    return sign_diff_products(ax, cx, by, cy, ay, cy, bx, cx);
}

/* The coordinates of p in the plane normal to `axis` (0 = x, 1 = y, 2 = z), in cyclic
 * order (y,z), (z,x), (x,y), which keeps each projection's orientation equal to the sign
 * of component `axis` of (a - c) x (b - c). */
static inline void predicates_project(vec3 p, int axis, double *u, double *v)
{
    *u = axis == 0 ? p.y : axis == 1 ? p.z : p.x;
    *v = axis == 0 ? p.z : axis == 1 ? p.x : p.y;
}

/* The orient2d of a, b, c projected onto the plane normal to `axis`. */
static inline int orient2d_axis(vec3 a, vec3 b, vec3 c, int axis)
{
    double au, av, bu, bv, cu, cv;
    predicates_project(a, axis, &au, &av);
    predicates_project(b, axis, &bu, &bv);
    predicates_project(c, axis, &cu, &cv);
    return sign_diff_products(au, cu, bv, cv, av, cv, bu, cu);
}

/* sign of det[b - a, c - a, d - a] = ((b-a) x (c-a)) . (d-a): +1 when d lies on the side
 * the normal of the counter-clockwise triangle a, b, c points to. Evaluated as
 * det[d-a; d-b; d-c], which is equal, expanded along z. */
static inline int orient3d(vec3 a, vec3 b, vec3 c, vec3 d)
{
    vec3 da = vec3_sub(d, a), db = vec3_sub(d, b), dc = vec3_sub(d, c);
    double bc_1 = db.x * dc.y, bc_2 = dc.x * db.y;
    double ca_1 = dc.x * da.y, ca_2 = da.x * dc.y;
    double ab_1 = da.x * db.y, ab_2 = db.x * da.y;
    double det = da.z * (bc_1 - bc_2) + db.z * (ca_1 - ca_2) + dc.z * (ab_1 - ab_2);
    if (det == 0.0)
        return orient3d_undecided(a, b, c, d);
    double permanent = (fabs(bc_1) + fabs(bc_2) + PREDICATES_UNDERFLOW_MINOR_PAD) * fabs(da.z) +
                       (fabs(ca_1) + fabs(ca_2) + PREDICATES_UNDERFLOW_MINOR_PAD) * fabs(db.z) +
                       (fabs(ab_1) + fabs(ab_2) + PREDICATES_UNDERFLOW_MINOR_PAD) * fabs(dc.z);
    double bound = PREDICATES_ERRBOUND_ORIENT3D * permanent + PREDICATES_UNDERFLOW_ABSOLUTE;
    if (fabs(det) > bound)
        return (det > 0.0) - (det < 0.0);
    return orient3d_undecided(a, b, c, d);
}

/* sign of ((p - o) x (q - o)) . dir: which side of the directed line through o along dir
 * the edge p->q passes (the ray-triangle edge function). */
static inline int ray_edge_sign(vec3 p, vec3 q, vec3 o, vec3 dir)
{
    vec3 op = vec3_sub(p, o), oq = vec3_sub(q, o);
    double x_1 = op.y * oq.z, x_2 = op.z * oq.y;
    double y_1 = op.z * oq.x, y_2 = op.x * oq.z;
    double z_1 = op.x * oq.y, z_2 = op.y * oq.x;
    double det = dir.x * (x_1 - x_2) + dir.y * (y_1 - y_2) + dir.z * (z_1 - z_2);
    if (det == 0.0)
        return ray_edge_sign_undecided(p, q, o, dir);
    double permanent = (fabs(x_1) + fabs(x_2) + PREDICATES_UNDERFLOW_MINOR_PAD) * fabs(dir.x) +
                       (fabs(y_1) + fabs(y_2) + PREDICATES_UNDERFLOW_MINOR_PAD) * fabs(dir.y) +
                       (fabs(z_1) + fabs(z_2) + PREDICATES_UNDERFLOW_MINOR_PAD) * fabs(dir.z);
    double bound = PREDICATES_ERRBOUND_RAY_EDGE * permanent + PREDICATES_UNDERFLOW_ABSOLUTE;
    if (fabs(det) > bound)
        return (det > 0.0) - (det < 0.0);
    return ray_edge_sign_undecided(p, q, o, dir);
}

/* orient2d_axis' filter alone. */
static inline int orient2d_axis_filter(vec3 a, vec3 b, vec3 c, int axis)
{
    double au, av, bu, bv, cu, cv;
    predicates_project(a, axis, &au, &av);
    predicates_project(b, axis, &bu, &bv);
    predicates_project(c, axis, &cu, &cv);
    return sign_diff_products_filter(au, cu, bv, cv, av, cv, bu, cu);
}

/* orient3d(a, b, c, d) for one plane a, b, c and many points d: the plane's part of the
 * filter is computed once. The value is the same determinant, expanded along the other
 * operand: det[d - a; b - a; c - a] = (d - a) . ((b - a) x (c - a)), a cyclic permutation
 * of the rows of det[b - a; c - a; d - a], so its sign is orient3d's.
 *
 * Error bound: the evaluation has exactly the shape the orient3d bound at the top of
 * predicates.c was derived for: three terms, each a rounded difference (here d - a) times
 * a minor fl(fl(x1 y2) - fl(x2 y1)) of rounded differences (here b - a and c - a), summed
 * left to right in two additions; and the permanent is formed by the same five roundings,
 * fl(fl(fl(|m1| + |m2|) + PAD) |z|) per term, then two additions, then the same two for
 * the bound. Where an operation happens (once per plane or once per point) does not change
 * its rounding, so PREDICATES_ERRBOUND_ORIENT3D, PREDICATES_UNDERFLOW_MINOR_PAD and
 * PREDICATES_UNDERFLOW_ABSOLUTE hold unchanged. Overflow gives an inf or NaN permanent or
 * determinant, the comparison fails, and the point is left undecided. */
typedef struct orient3d_plane {
    vec3 a, b, c;
    vec3 minor;     /* fl(m1 - m2) for the x, y, z components of (b - a) x (c - a) */
    vec3 permanent; /* fl(fl(|m1| + |m2|) + PAD) for the same components */
} orient3d_plane;

static inline orient3d_plane orient3d_plane_make(vec3 a, vec3 b, vec3 c)
{
    vec3 e = vec3_sub(b, a), f = vec3_sub(c, a);
    double x_1 = e.y * f.z, x_2 = e.z * f.y;
    double y_1 = e.z * f.x, y_2 = e.x * f.z;
    double z_1 = e.x * f.y, z_2 = e.y * f.x;
    orient3d_plane p = {a, b, c, {x_1 - x_2, y_1 - y_2, z_1 - z_2},
                        {fabs(x_1) + fabs(x_2) + PREDICATES_UNDERFLOW_MINOR_PAD,
                         fabs(y_1) + fabs(y_2) + PREDICATES_UNDERFLOW_MINOR_PAD,
                         fabs(z_1) + fabs(z_2) + PREDICATES_UNDERFLOW_MINOR_PAD}};
    return p;
}

/* The sign of orient3d(p->a, p->b, p->c, d) when the filter decides, else PREDICATES_UNDECIDED. */
static inline int orient3d_plane_filter(const orient3d_plane *p, vec3 d)
{
    vec3 w = vec3_sub(d, p->a);
    double det = w.x * p->minor.x + w.y * p->minor.y + w.z * p->minor.z;
    if (det == 0.0)
        return PREDICATES_UNDECIDED;
    double permanent = p->permanent.x * fabs(w.x) + p->permanent.y * fabs(w.y) + p->permanent.z * fabs(w.z);
    double bound = PREDICATES_ERRBOUND_ORIENT3D * permanent + PREDICATES_UNDERFLOW_ABSOLUTE;
    if (fabs(det) > bound)
        return (det > 0.0) - (det < 0.0);
    return PREDICATES_UNDECIDED;
}

/* The exact stage for a point orient3d_plane_filter left undecided: orient3d(p->a, p->b,
 * p->c, d), exactly. Kept apart so a caller can try cheaper proofs first. */
static inline int orient3d_plane_exact(const orient3d_plane *p, vec3 d)
{
    return orient3d_undecided(p->a, p->b, p->c, d);
}

/* How many evaluations on this thread needed the exact fallback since the thread began.
 * Thread-local, so concurrent queries never share it; callers report differences. */
uint64_t predicates_fallback_count(void);
/* Called by exact fallbacks outside predicates.c so the count stays complete. */
void predicates_note_fallback(void);

/* The exact stage's range for products of two and of three scaled factors: every nonzero
 * input below 2^(MAX_EXP + 1), its lowest set bit at or above 2^MIN_LSB (derivation in
 * predicates.c, "Exact stage"). */
enum {
    PREDICATES_DEGREE2_MAX_EXP = 500,
    PREDICATES_DEGREE2_MIN_LSB = -530,
    PREDICATES_DEGREE3_MAX_EXP = 330,
    PREDICATES_DEGREE3_MIN_LSB = -355,
};

/* The power of two that brings every nonzero v[i] below 2^(max_exp + 1) while keeping its
 * lowest set bit at or above 2^min_lsb (0 when they already are), as the exact stage scales
 * a homogeneous group of inputs; when the values span too wide for both, the largest
 * shift that cannot overflow. Defined for any doubles: infinities and NaNs, which have no
 * bits to keep, are passed over like zeros (0 when no value is finite and nonzero). For
 * exact fallbacks outside predicates.c. */
int predicates_exact_scale_exponent(const double *v, size_t n, int max_exp, int min_lsb);

#endif
