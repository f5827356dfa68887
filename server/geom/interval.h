/* Interval arithmetic on doubles, rounded outward: each operation returns an interval that
 * holds every real result of its operands' intervals. Distances are computed this way so
 * that their error bound is proven by construction, operation by operation, instead of by
 * a hand derivation per formula (docs/engine.md, "Distances").
 *
 * Outward rounding without changing the rounding mode: a result r rounded to nearest is
 * within half a step of the real one, and r - |r| 2^-52 is at least one step below r
 * whatever r's binade, so the real result lies in [iv_down(r), iv_up(r)]; 2^-1074 covers
 * the absolute error of an underflowed product or quotient. Rounding is monotone, which
 * is what keeps each widening on its side once it is itself rounded. An overflow to an
 * infinity keeps its far side infinite and its near side at DBL_MAX; a NaN (inf - inf,
 * 0 * inf) stays NaN, and the users of an interval read a NaN bound as unknown: a lower
 * bound of a distance as 0, an upper one as infinity (iv_sanitize_nonnegative). */
#ifndef TRIOCT_GEOM_INTERVAL_H
#define TRIOCT_GEOM_INTERVAL_H

#include <float.h>
#include <math.h>

#include "vec3.h"

typedef struct interval {
    double lo, hi;
} interval;

typedef struct interval3 {
    interval x, y, z;
} interval3;

/* A double at or below the real result whose nearest double is r. */
static inline double iv_down(double r)
{
    if (r == INFINITY)
        return DBL_MAX;
    return r - (fabs(r) * 0x1p-52 + 0x1p-1074);
}

static inline double iv_up(double r)
{
    if (r == -INFINITY)
        return -DBL_MAX;
    return r + (fabs(r) * 0x1p-52 + 0x1p-1074);
}

static inline double iv_min2(double a, double b) { return a < b ? a : b; }
static inline double iv_max2(double a, double b) { return a > b ? a : b; }

static inline interval iv_point(double x) { return (interval){x, x}; }

/* The real difference a - b of two doubles. */
static inline interval iv_diff(double a, double b)
{
    double d = a - b;
    return (interval){iv_down(d), iv_up(d)};
}

static inline interval iv_add(interval a, interval b)
{
    return (interval){iv_down(a.lo + b.lo), iv_up(a.hi + b.hi)};
}

static inline interval iv_sub(interval a, interval b)
{
    return (interval){iv_down(a.lo - b.hi), iv_up(a.hi - b.lo)};
}

static inline interval iv_neg(interval a) { return (interval){-a.hi, -a.lo}; }

static inline interval iv_mul(interval a, interval b)
{
    double p0 = a.lo * b.lo, p1 = a.lo * b.hi, p2 = a.hi * b.lo, p3 = a.hi * b.hi;
    double lo = iv_min2(iv_min2(p0, p1), iv_min2(p2, p3));
    double hi = iv_max2(iv_max2(p0, p1), iv_max2(p2, p3));
    /* A NaN product (0 * inf) makes the comparisons drop it: the bound is then unknown. */
    if (p0 != p0 || p1 != p1 || p2 != p2 || p3 != p3)
        return (interval){NAN, NAN};
    return (interval){iv_down(lo), iv_up(hi)};
}

/* a * a, which is never negative (iv_mul(a, a) would be for an interval around 0). */
static inline interval iv_sqr(interval a)
{
    if (a.lo >= 0)
        return (interval){iv_down(a.lo * a.lo), iv_up(a.hi * a.hi)};
    if (a.hi <= 0)
        return (interval){iv_down(a.hi * a.hi), iv_up(a.lo * a.lo)};
    double m = iv_max2(-a.lo, a.hi);
    return (interval){0.0, iv_up(m * m)};
}

/* a / b for b >= 0 and a >= 0 (squared lengths): an interval around a zero divisor is
 * [a.lo / b.hi, inf]. */
static inline interval iv_div_nonnegative(interval a, interval b)
{
    double lo = b.hi > 0 ? a.lo / b.hi : (a.lo > 0 ? INFINITY : 0.0);
    double hi = b.lo > 0 ? a.hi / b.lo : INFINITY;
    return (interval){lo == INFINITY ? DBL_MAX : iv_down(lo), hi == INFINITY ? INFINITY : iv_up(hi)};
}

/* Both bounds of a nonnegative quantity made usable: a lower bound that is NaN or below 0
 * is 0, an upper one that is NaN is infinity. */
static inline interval iv_sanitize_nonnegative(interval a)
{
    if (!(a.lo >= 0))
        a.lo = 0.0;
    if (!(a.hi >= a.lo))
        a.hi = INFINITY;
    return a;
}

/* The square root of a nonnegative interval. */
static inline interval iv_sqrt_nonnegative(interval a)
{
    a = iv_sanitize_nonnegative(a);
    /* sqrt(0) is exact: a distance proven 0 stays 0. */
    double lo = a.lo > 0 ? iv_down(sqrt(a.lo)) : 0.0;
    double hi = a.hi == INFINITY ? INFINITY : a.hi > 0 ? iv_up(sqrt(a.hi)) : 0.0;
    return (interval){lo > 0 ? lo : 0.0, hi};
}

/* A distance enclosed in [lower, upper] as reported: est (the plain double distance between
 * the points found, what a caller would compute from them) clamped into the enclosure, and
 * the bound |distance - real| <= bound that the enclosure proves. */
static inline void iv_distance_report(double est, double lower, double upper, double *distance, double *bound)
{
    double d = est >= lower ? (est <= upper ? est : upper) : lower; /* a NaN takes lower */
    double below = d > lower ? iv_up(d - lower) : 0.0, above = upper > d ? iv_up(upper - d) : 0.0;
    *distance = d;
    *bound = below > above ? below : above;
}

/* The real difference a - b of two points of doubles. */
static inline interval3 iv3_diff(vec3 a, vec3 b)
{
    return (interval3){iv_diff(a.x, b.x), iv_diff(a.y, b.y), iv_diff(a.z, b.z)};
}

static inline interval iv3_dot(interval3 a, interval3 b)
{
    return iv_add(iv_add(iv_mul(a.x, b.x), iv_mul(a.y, b.y)), iv_mul(a.z, b.z));
}

static inline interval iv3_norm2(interval3 a)
{
    return iv_add(iv_add(iv_sqr(a.x), iv_sqr(a.y)), iv_sqr(a.z));
}

static inline interval3 iv3_cross(interval3 a, interval3 b)
{
    return (interval3){iv_sub(iv_mul(a.y, b.z), iv_mul(a.z, b.y)), iv_sub(iv_mul(a.z, b.x), iv_mul(a.x, b.z)),
                       iv_sub(iv_mul(a.x, b.y), iv_mul(a.y, b.x))};
}

/* The midpoint of each component: the double estimate of a computed vector. */
static inline vec3 iv3_mid(interval3 a)
{
    return (vec3){0.5 * a.x.lo + 0.5 * a.x.hi, 0.5 * a.y.lo + 0.5 * a.y.hi, 0.5 * a.z.lo + 0.5 * a.z.hi};
}

#endif
