/* Exact floating-point expansion arithmetic after Shewchuk (1997): error-free transforms,
 * zero-eliminating sums, scalings and products of nonoverlapping expansions. */
#include "expansion.h"

#include <math.h>
#include <string.h>

/* Every routine here is exact as long as nothing overflows and no product's rounding error
 * falls below the subnormal range (the low part of a*b is exact when the lowest set bits
 * of a and b sit at exponents summing to -1074 or more). The predicates scale their inputs
 * by a power of two before calling in, which guarantees both. */

/* Merge step of the sum: takes the not yet consumed component of smaller magnitude. */
static inline double take_smaller(const double *e, size_t en, size_t *ei,
                                  const double *f, size_t fn, size_t *fi)
{
    if (*fi >= fn || (*ei < en && fabs(e[*ei]) <= fabs(f[*fi])))
        return e[(*ei)++];
    return f[(*fi)++];
}

/* Linear-expansion-sum (Shewchuk's Theorem 12) with zero elimination. It is chosen over
 * fast-expansion-sum because its correctness needs only nonoverlapping inputs, which is
 * exactly what scale-expansion guarantees; every two_sum is exact, so the value is exact
 * even where a fast_two_sum would have sufficed.
 *
 * Each output component is written only after at least three more inputs than outputs
 * have been read. expansion_product relies on that: it passes h = e - fn inside one
 * array, and the writes never reach a component of e that is still unread. */
static size_t merge_sum(size_t en, const double *e, size_t fn, const double *f, double *h)
{
    size_t ei = 0, fi = 0, hn = 0;
    size_t total = en + fn;
    if (total == 0)
        return 0;
    double g1 = take_smaller(e, en, &ei, f, fn, &fi);
    if (total == 1) {
        if (g1 != 0.0)
            h[hn++] = g1;
        return hn;
    }
    double g2 = take_smaller(e, en, &ei, f, fn, &fi);
    double big, small; /* the running sum is big + small, big carrying the high bits */
    two_sum(g2, g1, &big, &small);
    for (size_t consumed = 2; consumed < total; consumed++) {
        double g = take_smaller(e, en, &ei, f, fn, &fi);
        double r_hi, r_lo;
        two_sum(g, small, &r_hi, &r_lo);
        if (r_lo != 0.0)
            h[hn++] = r_lo;
        two_sum(big, r_hi, &big, &small);
    }
    if (small != 0.0)
        h[hn++] = small;
    if (big != 0.0)
        h[hn++] = big;
    return hn;
}

size_t expansion_sum(size_t en, const double *e, size_t fn, const double *f, double *h)
{
    return merge_sum(en, e, fn, f, h);
}

size_t expansion_scale(size_t en, const double *e, double b, double *h)
{
    size_t hn = 0;
    if (en == 0 || b == 0.0)
        return 0;
    double carry, lo;
    two_product(e[0], b, &carry, &lo);
    if (lo != 0.0)
        h[hn++] = lo;
    for (size_t i = 1; i < en; i++) {
        double p_hi, p_lo, sum, sum_lo;
        two_product(e[i], b, &p_hi, &p_lo);
        two_sum(carry, p_lo, &sum, &sum_lo);
        if (sum_lo != 0.0)
            h[hn++] = sum_lo;
        /* Shewchuk's Theorem 19 shows |p_hi| >= |sum| here, so a fast_two_sum would do;
         * two_sum gives the same pair and needs no such argument. */
        two_sum(p_hi, sum, &carry, &sum_lo);
        if (sum_lo != 0.0)
            h[hn++] = sum_lo;
    }
    if (carry != 0.0)
        h[hn++] = carry;
    return hn;
}

/* Components of e scaled in one go: bounds the stack scratch, so a product of any size
 * needs no heap and cannot overflow the stack. */
#define PRODUCT_CHUNK 64

size_t expansion_product(size_t en, const double *e, size_t fn, const double *f, double *h)
{
    if (en == 0 || fn == 0)
        return 0;
    /* The running sum lives at the back of h, in [start, start + len). Each scaled chunk
     * (at most 2 * chunk components) is merged into it with the output starting that many
     * slots lower; merge_sum's writes trail its reads, and the scaled lengths add up to at
     * most 2 * en * fn, so start never drops below 0. */
    size_t capacity = 2 * en * fn;
    size_t start = capacity, len = 0;
    double scaled[2 * PRODUCT_CHUNK];
    for (size_t j = 0; j < fn; j++) {
        for (size_t first = 0; first < en; first += PRODUCT_CHUNK) {
            size_t chunk = en - first < PRODUCT_CHUNK ? en - first : PRODUCT_CHUNK;
            size_t sn = expansion_scale(chunk, e + first, f[j], scaled);
            if (sn == 0)
                continue;
            len = merge_sum(len, h + start, sn, scaled, h + start - sn);
            start -= sn;
        }
    }
    if (start != 0 && len != 0)
        memmove(h, h + start, len * sizeof *h);
    return len;
}

void expansion_negate(size_t en, double *e)
{
    for (size_t i = 0; i < en; i++)
        e[i] = -e[i];
}

int expansion_sign(size_t en, const double *e)
{
    /* Nonoverlapping and increasing: the largest nonzero component outweighs the rest. */
    for (size_t i = en; i-- > 0;) {
        if (e[i] > 0.0)
            return 1;
        if (e[i] < 0.0)
            return -1;
    }
    return 0;
}

double expansion_estimate(size_t en, const double *e)
{
    double sum = 0.0;
    for (size_t i = 0; i < en; i++)
        sum += e[i];
    return sum;
}

/* Shewchuk's Compress: the same value in as few non-adjacent components as it takes, so
 * products of it (ray_tri_compare_t's degree-6 ones) stay small and the largest component
 * is within an ulp of the value (which makes estimates trustworthy). In place. */
size_t expansion_compress(size_t n, double *e)
{
    double q = e[n - 1], lo;
    size_t bottom = n - 1;
    for (size_t i = n - 1; i-- > 0;) {
        two_sum(q, e[i], &q, &lo);
        if (lo != 0.0) {
            e[bottom--] = q;
            q = lo;
        }
    }
    e[bottom] = q;
    size_t top = 0;
    for (size_t i = bottom + 1; i < n; i++) {
        two_sum(e[i], q, &q, &lo);
        if (lo != 0.0)
            e[top++] = lo;
    }
    e[top++] = q;
    return top;
}
