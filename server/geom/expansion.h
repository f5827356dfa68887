/* Exact floating-point expansion arithmetic (Shewchuk 1997, "Adaptive Precision
 * Floating-Point Arithmetic and Fast Robust Geometric Predicates"). An expansion is an
 * array of doubles, ordered by increasing magnitude and non-overlapping, whose exact sum
 * is the value. Used only by the exact fallbacks of the predicates. */
#ifndef TRIOCT_GEOM_EXPANSION_H
#define TRIOCT_GEOM_EXPANSION_H

#include <math.h>
#include <stddef.h>

/* The relative rounding unit of double (2^-53), the epsilon of every error bound. */
#define EXPANSION_EPS 0x1p-53

/* Error-free transforms: a op b = hi + lo exactly. Inline: every exact stage is made of
 * them, and as calls they cost more than the arithmetic they do. */
static inline void two_sum(double a, double b, double *hi, double *lo)
{
    double sum = a + b;
    double b_virtual = sum - a;
    double a_virtual = sum - b_virtual;
    double b_roundoff = b - b_virtual;
    double a_roundoff = a - a_virtual;
    *hi = sum;
    *lo = a_roundoff + b_roundoff;
}

static inline void two_diff(double a, double b, double *hi, double *lo)
{
    double diff = a - b;
    double b_virtual = a - diff;
    double a_virtual = diff + b_virtual;
    double b_roundoff = b_virtual - b;
    double a_roundoff = a - a_virtual;
    *hi = diff;
    *lo = a_roundoff + b_roundoff;
}

static inline void two_product(double a, double b, double *hi, double *lo)
{
    double product = a * b;
    *hi = product;
    /* fma rounds once, and a*b - product is representable, so this is its exact value. */
    *lo = fma(a, b, -product);
}

/* h = e + f (lengths en, fn); returns length of h, which must hold en + fn doubles. */
size_t expansion_sum(size_t en, const double *e, size_t fn, const double *f, double *h);
/* h = e * b; h must hold 2 * en doubles. */
size_t expansion_scale(size_t en, const double *e, double b, double *h);
/* h = e * f; h must hold 2 * en * fn doubles (at least 1). */
size_t expansion_product(size_t en, const double *e, size_t fn, const double *f, double *h);
/* -e, in place. */
void expansion_negate(size_t en, double *e);
/* Sign of the exact value: -1, 0 or +1. */
int expansion_sign(size_t en, const double *e);
/* Shewchuk's Compress, in place: the same value in as few non-adjacent components as it
 * takes, the largest within an ulp of the value; returns the new length (n >= 1). */
size_t expansion_compress(size_t n, double *e);
/* The value rounded roughly to double (for reporting, not for decisions). */
double expansion_estimate(size_t en, const double *e);

#endif
