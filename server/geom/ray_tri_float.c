/* The float prefilter (ray_tri_float.h) and the bound it rests on.
 *
 * Notation: u = 2^-24 (float's unit roundoff); p, q the exact vertex and origin in the
 * frame, P, Q their floats; a = p_k - q, e = p_j - p_k exact, A = fl(P_k - Q) and
 * Ef = fl(P_j - P_k) in float; |.| the max norm over the three coordinates.
 * - Inputs. A vertex lies in [0, 1]: |P - p| <= dv = 2^-22 (the double subtraction and the
 *   float rounding, 2^-53 + 2^-24 relative, with room). The origin: |Q - q| <= dq =
 *   2^-22 |Q| + 2^-126. The direction is scaled by a power of two (the signs of w do not
 *   change) and rounded: |D_i - d_i| <= u |D_i| + 2^-149 for each component.
 * - Differences. |A_i - a_i| <= alpha = dv + dq + 2^-23 |A|, and |Ef_i - e_i| <= eps =
 *   2 dv + 2^-23 |Ef| (each subtraction's rounding is u of its result, with room).
 * - Cross product c = a x e against C = fl(A x Ef), per component:
 *   |A_y Ef_z - a_y e_z| <= alpha |Ef| + (|A| + alpha) eps, two such terms make
 *   gamma = 2 (alpha |Ef| + (|A| + alpha) eps); the two products and the difference
 *   round by at most 4.01 u |A| |Ef|, so |C_i - c_i| <= eta = gamma + 2^-21.9 |A| |Ef|.
 * - The dot product W = fl(D . C) against w = d . c: the direction's rounding adds at most
 *   (u |D|_1 + 3 * 2^-149)(|C| + eta), the components' error |D|_1 eta, and the three
 *   roundings of the sum 3.01 u |D|_1 |C|; in all below
 *   |D|_1 (eta + 2^-21.5 (|C| + eta)) + 2^-120 (|C| + eta <= 2^23 here).
 * - E is that bound computed in float: every term is positive and takes at most a dozen
 *   roundings, which the factor 1 + 2^-10 covers; 2^-100 covers underflow in any of the
 *   products (an absolute error of 2^-149 each). With |Q| <= 16, |A| <= 17, |Ef| <= 2,
 *   |C| <= 2^7 and |D| <= 2: nothing overflows.
 * A sign counts where |W| > E: then w has W's sign. */
#include "ray_tri_float.h"

#include <float.h>
#include <math.h>

/* Past 16 world sides the origin's own rounding, 2^-22 of its distance, leaves too few
 * signs decided for the filter to pay: such rays take the double filter. */
#define FRAME_ORIGIN_LIMIT 16.0f

int float_frame_for(float_frame *f, vec3 lo, double side)
{
    if (!(side > 0 && side <= DBL_MAX))
        return -1;
    int e;
    frexp(side, &e); /* side < 2^e */
    f->lo = lo;
    f->exp = e;
    return 0;
}

void float_frame_point(const float_frame *f, vec3 p, float out[3])
{
    out[0] = (float)ldexp(p.x - f->lo.x, -f->exp);
    out[1] = (float)ldexp(p.y - f->lo.y, -f->exp);
    out[2] = (float)ldexp(p.z - f->lo.z, -f->exp);
}

int ray_float_init(ray_float *r, const float_frame *f, vec3 o, vec3 d)
{
    float q[3];
    float_frame_point(f, o, q);
    double big = fmax(fabs(d.x), fmax(fabs(d.y), fabs(d.z)));
    if (!(big > 0 && big <= DBL_MAX) || !isfinite(o.x) || !isfinite(o.y) || !isfinite(o.z))
        return 0;
    float qmax = fmaxf(fabsf(q[0]), fmaxf(fabsf(q[1]), fabsf(q[2])));
    if (!(qmax <= FRAME_ORIGIN_LIMIT))
        return 0;
    int t;
    frexp(big, &t); /* big in [2^(t-1), 2^t): scaled, in [1, 2) */
    double dd[3] = {ldexp(d.x, 1 - t), ldexp(d.y, 1 - t), ldexp(d.z, 1 - t)};
    for (int i = 0; i < 3; i++) {
        r->q[i] = q[i];
        r->d[i] = (float)dd[i];
    }
    r->d_sum = (fabsf(r->d[0]) + fabsf(r->d[1]) + fabsf(r->d[2])) * (1 + 0x1p-20f);
    const float dv = 0x1p-22f, dq = 0x1p-22f * qmax + 0x1p-126f;
    r->delta_a = (dv + dq) * (1 + 0x1p-20f);
    r->delta_e = 2 * dv;
    return 1;
}

/* One edge in one lane: the sign of W when |W| exceeds E, else 0. The vector form below
 * computes exactly these operations in this order. */
static int edge_sign(const ray_float *r, const float vk[3], const float vj[3])
{
    float A[3], F[3];
    for (int i = 0; i < 3; i++) {
        A[i] = vk[i] - r->q[i];
        F[i] = vj[i] - vk[i];
    }
    float amax = fmaxf(fmaxf(fabsf(A[0]), fabsf(A[1])), fabsf(A[2]));
    float fmx = fmaxf(fmaxf(fabsf(F[0]), fabsf(F[1])), fabsf(F[2]));
    float cx = A[1] * F[2] - A[2] * F[1];
    float cy = A[2] * F[0] - A[0] * F[2];
    float cz = A[0] * F[1] - A[1] * F[0];
    float cmax = fmaxf(fmaxf(fabsf(cx), fabsf(cy)), fabsf(cz));
    float w = (r->d[0] * cx + r->d[1] * cy) + r->d[2] * cz;
    float alpha = r->delta_a + 0x1p-23f * amax;
    float eps = r->delta_e + 0x1p-23f * fmx;
    float eta = 2 * (alpha * fmx + (amax + alpha) * eps) + 0x1.12p-22f * (amax * fmx);
    float bound = (r->d_sum * (eta + 0x1.6ap-22f * (cmax + eta)) + 0x1p-120f) * (1 + 0x1p-10f) + 0x1p-100f;
    return w > bound ? 1 : -w > bound ? -1 : 0;
}

static unsigned misses_scalar(const ray_float *r, const float *vertices, const uint32_t (*corners)[3],
                              const uint32_t *ids, unsigned count)
{
    unsigned miss = 0;
    for (unsigned i = 0; i < count; i++) {
        const uint32_t *c = corners[ids[i]];
        const float *v0 = &vertices[3 * (size_t)c[0]], *v1 = &vertices[3 * (size_t)c[1]],
                    *v2 = &vertices[3 * (size_t)c[2]];
        int s01 = edge_sign(r, v0, v1), s12 = edge_sign(r, v1, v2), s20 = edge_sign(r, v2, v0);
        miss |= (unsigned)(s01 * s12 < 0 || s12 * s20 < 0 || s20 * s01 < 0) << i;
    }
    return miss;
}

#if defined(__x86_64__)
#include <immintrin.h>
#define FLOAT_FILTER_AVX2 __attribute__((target("avx2")))

typedef struct lanes3 {
    __m256 x, y, z;
} lanes3;

FLOAT_FILTER_AVX2 static inline __attribute__((always_inline)) __m256 abs8(__m256 v)
{
    return _mm256_and_ps(v, _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff)));
}

/* edge_sign on eight lanes: the lanes whose sign is surely positive, and surely negative. */
FLOAT_FILTER_AVX2 static inline __attribute__((always_inline)) void edge8(const ray_float *r, lanes3 vk, lanes3 vj,
                                                                           __m256 *pos, __m256 *neg)
{
    __m256 ax = _mm256_sub_ps(vk.x, _mm256_set1_ps(r->q[0])), ay = _mm256_sub_ps(vk.y, _mm256_set1_ps(r->q[1])),
           az = _mm256_sub_ps(vk.z, _mm256_set1_ps(r->q[2]));
    __m256 fx = _mm256_sub_ps(vj.x, vk.x), fy = _mm256_sub_ps(vj.y, vk.y), fz = _mm256_sub_ps(vj.z, vk.z);
    __m256 amax = _mm256_max_ps(_mm256_max_ps(abs8(ax), abs8(ay)), abs8(az));
    __m256 fmx = _mm256_max_ps(_mm256_max_ps(abs8(fx), abs8(fy)), abs8(fz));
    __m256 cx = _mm256_sub_ps(_mm256_mul_ps(ay, fz), _mm256_mul_ps(az, fy));
    __m256 cy = _mm256_sub_ps(_mm256_mul_ps(az, fx), _mm256_mul_ps(ax, fz));
    __m256 cz = _mm256_sub_ps(_mm256_mul_ps(ax, fy), _mm256_mul_ps(ay, fx));
    __m256 cmax = _mm256_max_ps(_mm256_max_ps(abs8(cx), abs8(cy)), abs8(cz));
    __m256 w = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(r->d[0]), cx),
                                           _mm256_mul_ps(_mm256_set1_ps(r->d[1]), cy)),
                             _mm256_mul_ps(_mm256_set1_ps(r->d[2]), cz));
    __m256 alpha = _mm256_add_ps(_mm256_set1_ps(r->delta_a), _mm256_mul_ps(_mm256_set1_ps(0x1p-23f), amax));
    __m256 eps = _mm256_add_ps(_mm256_set1_ps(r->delta_e), _mm256_mul_ps(_mm256_set1_ps(0x1p-23f), fmx));
    __m256 eta = _mm256_add_ps(
        _mm256_mul_ps(_mm256_set1_ps(2.0f), _mm256_add_ps(_mm256_mul_ps(alpha, fmx), _mm256_mul_ps(_mm256_add_ps(amax, alpha), eps))),
        _mm256_mul_ps(_mm256_set1_ps(0x1.12p-22f), _mm256_mul_ps(amax, fmx)));
    __m256 inner = _mm256_add_ps(eta, _mm256_mul_ps(_mm256_set1_ps(0x1.6ap-22f), _mm256_add_ps(cmax, eta)));
    __m256 bound = _mm256_add_ps(
        _mm256_mul_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(r->d_sum), inner), _mm256_set1_ps(0x1p-120f)),
                      _mm256_set1_ps(1 + 0x1p-10f)),
        _mm256_set1_ps(0x1p-100f));
    *pos = _mm256_cmp_ps(w, bound, _CMP_GT_OQ);
    *neg = _mm256_cmp_ps(_mm256_xor_ps(w, _mm256_set1_ps(-0.0f)), bound, _CMP_GT_OQ);
}

FLOAT_FILTER_AVX2 static unsigned misses_avx2(const ray_float *r, const float *vertices, const uint32_t (*corners)[3],
                                              const uint32_t *ids, unsigned count)
{
    /* Unused lanes repeat the first triangle; their bits are dropped below. */
    uint32_t lane_ids[8];
    for (unsigned i = 0; i < 8; i++)
        lane_ids[i] = ids[i < count ? i : 0];
    __m256i id3 = _mm256_mullo_epi32(_mm256_loadu_si256((const __m256i *)lane_ids), _mm256_set1_epi32(3));
    const int *cs = (const int *)corners;
    lanes3 v[3];
    for (int k = 0; k < 3; k++) {
        __m256i at = _mm256_mullo_epi32(_mm256_i32gather_epi32(cs, _mm256_add_epi32(id3, _mm256_set1_epi32(k)), 4),
                                        _mm256_set1_epi32(3));
        v[k].x = _mm256_i32gather_ps(vertices, at, 4);
        v[k].y = _mm256_i32gather_ps(vertices, _mm256_add_epi32(at, _mm256_set1_epi32(1)), 4);
        v[k].z = _mm256_i32gather_ps(vertices, _mm256_add_epi32(at, _mm256_set1_epi32(2)), 4);
    }
    __m256 p01, n01, p12, n12, p20, n20;
    edge8(r, v[0], v[1], &p01, &n01);
    edge8(r, v[1], v[2], &p12, &n12);
    edge8(r, v[2], v[0], &p20, &n20);
    __m256 miss = _mm256_or_ps(_mm256_and_ps(p01, n12), _mm256_and_ps(n01, p12));
    miss = _mm256_or_ps(miss, _mm256_or_ps(_mm256_and_ps(p12, n20), _mm256_and_ps(n12, p20)));
    miss = _mm256_or_ps(miss, _mm256_or_ps(_mm256_and_ps(p20, n01), _mm256_and_ps(n20, p01)));
    return (unsigned)_mm256_movemask_ps(miss) & ((1u << count) - 1);
}
#endif

unsigned ray_float_misses8(const ray_float *r, const float *vertices, const uint32_t (*corners)[3],
                           const uint32_t *ids, unsigned count, int avx2)
{
#if defined(__x86_64__)
    if (avx2)
        return misses_avx2(r, vertices, corners, ids, count);
#else
    (void)avx2;
#endif
    return misses_scalar(r, vertices, corners, ids, count);
}
