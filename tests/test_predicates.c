/* Tests for the expansion arithmetic and the exact predicates, checked against an
 * independent GMP reference on random, nearly degenerate, exactly degenerate and extreme
 * inputs. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <float.h>
#include <gmp.h>
#include <limits.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geom/expansion.h"
#include "geom/predicates.h"

/* Set once in main from TRIOCT_SEED (or the default) before any test runs. */
static uint64_t base_seed = 20240611u;

/* ---------- random numbers ---------- */

typedef struct rng {
    uint64_t state;
} rng;

static uint64_t rng_next(rng *r)
{
    /* splitmix64 */
    uint64_t z = (r->state += 0x9e3779b97f4a7c15u);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9u;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebu;
    return z ^ (z >> 31);
}

/* Each test draws from its own stream so tests do not depend on their order. */
static rng rng_for(uint64_t test_salt)
{
    rng r = {base_seed ^ (test_salt * 0x2545f4914f6cdd1du)};
    rng_next(&r);
    return r;
}

static double rng_unit(rng *r) { return (double)(rng_next(r) >> 11) * 0x1p-53; }
static double rng_sym(rng *r) { return 2.0 * rng_unit(r) - 1.0; }
static int rng_int(rng *r, int lo, int hi)
{
    return lo + (int)(rng_next(r) % (uint64_t)(hi - lo + 1));
}

/* A double with a random 53-bit mantissa, random sign and binary exponent in [lo, hi]. */
static double rng_wide(rng *r, int lo_exp, int hi_exp)
{
    double m = 1.0 + rng_unit(r);
    double x = ldexp(m, rng_int(r, lo_exp, hi_exp));
    return (rng_next(r) & 1) ? -x : x;
}

static double nudge_ulps(double x, int ulps)
{
    for (; ulps > 0; ulps--)
        x = nextafter(x, INFINITY);
    for (; ulps < 0; ulps++)
        x = nextafter(x, -INFINITY);
    return x;
}

/* ---------- GMP reference ---------- */

/* Exact integer images of n doubles, all multiplied by one common power of two (which
 * leaves the sign of any homogeneous polynomial unchanged). */
static void ref_load(mpz_t *out, const double *x, int n)
{
    mpq_t q;
    mpq_init(q);
    unsigned long shift[16], max_shift = 0;
    for (int i = 0; i < n; i++) {
        mpq_set_d(q, x[i]);
        assert_int_equal(mpz_popcount(mpq_denref(q)), 1);
        shift[i] = mpz_scan1(mpq_denref(q), 0);
        mpz_set(out[i], mpq_numref(q));
        if (shift[i] > max_shift)
            max_shift = shift[i];
    }
    for (int i = 0; i < n; i++)
        mpz_mul_2exp(out[i], out[i], max_shift - shift[i]);
    mpq_clear(q);
}

typedef struct ref_ctx {
    mpz_t v[12];
    mpz_t t[12];
} ref_ctx;

static void ref_init(ref_ctx *c)
{
    for (int i = 0; i < 12; i++) {
        mpz_init(c->v[i]);
        mpz_init(c->t[i]);
    }
}

static void ref_clear(ref_ctx *c)
{
    for (int i = 0; i < 12; i++) {
        mpz_clear(c->v[i]);
        mpz_clear(c->t[i]);
    }
}

/* out = x*y - z*w */
static void ref_cross_term(mpz_t out, const mpz_t x, const mpz_t y, const mpz_t z,
                           const mpz_t w, mpz_t scratch)
{
    mpz_mul(out, x, y);
    mpz_mul(scratch, z, w);
    mpz_sub(out, out, scratch);
}

/* sign of (u x w) . s for integer 3-vectors u = t[0..2], w = t[3..5], s = t[6..8]. */
static int ref_triple(ref_ctx *c)
{
    mpz_t *t = c->t;
    ref_cross_term(t[9], t[1], t[5], t[2], t[4], t[11]);
    ref_cross_term(t[10], t[2], t[3], t[0], t[5], t[11]);
    mpz_mul(t[9], t[9], t[6]);
    mpz_addmul(t[9], t[10], t[7]);
    ref_cross_term(t[10], t[0], t[4], t[1], t[3], t[11]);
    mpz_addmul(t[9], t[10], t[8]);
    return mpz_sgn(t[9]);
}

static int ref_orient2d(ref_ctx *c, const double v[6])
{
    /* (ax-cx)(by-cy) - (ay-cy)(bx-cx), straight from the header. */
    ref_load(c->v, v, 6);
    mpz_sub(c->t[0], c->v[0], c->v[4]);
    mpz_sub(c->t[1], c->v[3], c->v[5]);
    mpz_sub(c->t[2], c->v[1], c->v[5]);
    mpz_sub(c->t[3], c->v[2], c->v[4]);
    ref_cross_term(c->t[4], c->t[0], c->t[1], c->t[2], c->t[3], c->t[5]);
    return mpz_sgn(c->t[4]);
}

static int ref_orient3d(ref_ctx *c, const double v[12])
{
    /* ((b-a) x (c-a)) . (d-a) */
    ref_load(c->v, v, 12);
    for (int k = 0; k < 3; k++) {
        mpz_sub(c->t[k], c->v[3 + k], c->v[k]);
        mpz_sub(c->t[3 + k], c->v[6 + k], c->v[k]);
        mpz_sub(c->t[6 + k], c->v[9 + k], c->v[k]);
    }
    return ref_triple(c);
}

static int ref_diff_products(ref_ctx *c, const double v[8])
{
    ref_load(c->v, v, 8);
    mpz_sub(c->t[0], c->v[0], c->v[1]);
    mpz_sub(c->t[1], c->v[2], c->v[3]);
    mpz_sub(c->t[2], c->v[4], c->v[5]);
    mpz_sub(c->t[3], c->v[6], c->v[7]);
    ref_cross_term(c->t[4], c->t[0], c->t[1], c->t[2], c->t[3], c->t[5]);
    return mpz_sgn(c->t[4]);
}

static int ref_ray_edge(ref_ctx *c, const double v[12])
{
    /* ((p-o) x (q-o)) . dir */
    ref_load(c->v, v, 12);
    for (int k = 0; k < 3; k++) {
        mpz_sub(c->t[k], c->v[k], c->v[6 + k]);
        mpz_sub(c->t[3 + k], c->v[3 + k], c->v[6 + k]);
        mpz_set(c->t[6 + k], c->v[9 + k]);
    }
    return ref_triple(c);
}

static int ref_orient2d_axis(ref_ctx *c, const double v[9], int axis)
{
    /* component `axis` of (a-c) x (b-c): dot with the unit vector of that axis */
    ref_load(c->v, v, 9);
    for (int k = 0; k < 3; k++) {
        mpz_sub(c->t[k], c->v[k], c->v[6 + k]);
        mpz_sub(c->t[3 + k], c->v[3 + k], c->v[6 + k]);
        mpz_set_si(c->t[6 + k], k == axis ? 1 : 0);
    }
    return ref_triple(c);
}

/* ---------- predicate cases ---------- */

typedef enum pred_kind {
    PRED_ORIENT2D,
    PRED_ORIENT3D,
    PRED_DIFF_PRODUCTS,
    PRED_RAY_EDGE,
    PRED_ORIENT2D_AXIS,
    PRED_KIND_COUNT,
} pred_kind;

static const char *const pred_names[PRED_KIND_COUNT] = {
    "orient2d", "orient3d", "sign_diff_products", "ray_edge_sign", "orient2d_axis",
};

/* Input layouts: orient2d a,b,c (2 each); orient3d a,b,c,d; sign_diff_products a..h;
 * ray_edge_sign p,q,o,dir; orient2d_axis a,b,c (3 each) plus axis. */
static const int pred_arity[PRED_KIND_COUNT] = {6, 12, 8, 12, 9};

typedef struct pred_case {
    pred_kind kind;
    int axis;
    double v[12];
} pred_case;

static vec3 vec_at(const double *v, int i) { return vec3_make(v[3 * i], v[3 * i + 1], v[3 * i + 2]); }

static int eval_impl(const pred_case *pc)
{
    const double *v = pc->v;
    switch (pc->kind) {
    case PRED_ORIENT2D:
        return orient2d(v[0], v[1], v[2], v[3], v[4], v[5]);
    case PRED_ORIENT3D:
        return orient3d(vec_at(v, 0), vec_at(v, 1), vec_at(v, 2), vec_at(v, 3));
    case PRED_DIFF_PRODUCTS:
        return sign_diff_products(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]);
    case PRED_RAY_EDGE:
        return ray_edge_sign(vec_at(v, 0), vec_at(v, 1), vec_at(v, 2), vec_at(v, 3));
    case PRED_ORIENT2D_AXIS:
        return orient2d_axis(vec_at(v, 0), vec_at(v, 1), vec_at(v, 2), pc->axis);
    default:
        fail();
        return 2;
    }
}

static int eval_ref(ref_ctx *c, const pred_case *pc)
{
    switch (pc->kind) {
    case PRED_ORIENT2D:
        return ref_orient2d(c, pc->v);
    case PRED_ORIENT3D:
        return ref_orient3d(c, pc->v);
    case PRED_DIFF_PRODUCTS:
        return ref_diff_products(c, pc->v);
    case PRED_RAY_EDGE:
        return ref_ray_edge(c, pc->v);
    case PRED_ORIENT2D_AXIS:
        return ref_orient2d_axis(c, pc->v, pc->axis);
    default:
        fail();
        return 2;
    }
}

/* Tallies of one batch: a mismatch is reported with its exact inputs. */
typedef struct tally {
    long cases, zeros, positives, negatives, mismatches;
} tally;

static void report_mismatch(const pred_case *pc, int got, int want, const char *what)
{
    fprintf(stderr, "MISMATCH %s (%s): got %d, exact %d, axis %d, inputs:", pred_names[pc->kind],
            what, got, want, pc->axis);
    for (int i = 0; i < pred_arity[pc->kind]; i++)
        fprintf(stderr, " %a", pc->v[i]);
    fprintf(stderr, "\n");
}

static void check_case(ref_ctx *c, const pred_case *pc, tally *t, const char *what)
{
    int want = eval_ref(c, pc);
    int got = eval_impl(pc);
    t->cases++;
    t->zeros += want == 0;
    t->positives += want > 0;
    t->negatives += want < 0;
    if (got != want) {
        if (t->mismatches < 5)
            report_mismatch(pc, got, want, what);
        t->mismatches++;
    }
}

static void finish_tally(const tally *t, const char *what, pred_kind kind)
{
    printf("  %-20s %-26s %6ld cases: %6ld +, %6ld -, %6ld zero\n", pred_names[kind], what,
           t->cases, t->positives, t->negatives, t->zeros);
    assert_int_equal(t->mismatches, 0);
}

/* ---------- case generators ---------- */

/* A point near offset*(1, -1/2, 1/4) within +-size on each axis. */
static vec3 rand_point(rng *r, double offset, double size)
{
    return vec3_make(offset + size * rng_sym(r), -0.5 * offset + size * rng_sym(r),
                     0.25 * offset + size * rng_sym(r));
}

static void put_point(double *v, int i, vec3 p)
{
    v[3 * i] = p.x;
    v[3 * i + 1] = p.y;
    v[3 * i + 2] = p.z;
}

static vec3 nudge_point(rng *r, vec3 p, int max_ulps)
{
    return vec3_make(nudge_ulps(p.x, rng_int(r, -max_ulps, max_ulps)),
                     nudge_ulps(p.y, rng_int(r, -max_ulps, max_ulps)),
                     nudge_ulps(p.z, rng_int(r, -max_ulps, max_ulps)));
}

/* Point on the line through a and b (rounded), at parameter t. */
static vec3 lerp_point(vec3 a, vec3 b, double t)
{
    return vec3_add(a, vec3_scale(vec3_sub(b, a), t));
}

static void gen_random(rng *r, pred_kind kind, double offset, double size, pred_case *pc)
{
    memset(pc, 0, sizeof *pc);
    pc->kind = kind;
    pc->axis = rng_int(r, 0, 2);
    for (int i = 0; i < 4; i++)
        put_point(pc->v, i, rand_point(r, offset, size));
    if (kind == PRED_ORIENT2D)
        for (int i = 0; i < 3; i++) {
            pc->v[2 * i] = pc->v[3 * i];
            pc->v[2 * i + 1] = pc->v[3 * i + 1];
        }
    if (kind == PRED_RAY_EDGE)
        put_point(pc->v, 3, rand_point(r, 0.0, 1.0));
}

/* Inputs on the degenerate set up to rounding, then moved a few ulps (or not at all). */
static void gen_near_degenerate(rng *r, pred_kind kind, double offset, double size,
                                pred_case *pc)
{
    int ulps = rng_int(r, 0, 3);
    memset(pc, 0, sizeof *pc);
    pc->kind = kind;
    pc->axis = rng_int(r, 0, 2);
    vec3 a = rand_point(r, offset, size), b = rand_point(r, offset, size);
    switch (kind) {
    case PRED_ORIENT2D: {
        vec3 pts[3] = {a, b, nudge_point(r, lerp_point(a, b, 2.0 * rng_sym(r)), ulps)};
        int where = rng_int(r, 0, 2); /* put the nudged point in any role */
        vec3 t = pts[where];
        pts[where] = pts[2];
        pts[2] = t;
        for (int i = 0; i < 3; i++) {
            pc->v[2 * i] = pts[i].x;
            pc->v[2 * i + 1] = pts[i].y;
        }
        break;
    }
    case PRED_ORIENT3D: {
        vec3 c = rand_point(r, offset, size), d;
        if (rng_int(r, 0, 3) == 0) {
            /* Mesh-like: a, c, d on an axis-aligned plane and nearly collinear in it, b
             * off the plane, so only some terms of the determinant are nonzero. */
            d = nudge_point(r, lerp_point(a, c, 2.0 * rng_sym(r)), ulps);
            double shared = rng_sym(r) * size + offset;
            int axis = rng_int(r, 0, 2);
            a = vec3_with(a, axis, shared);
            c = vec3_with(c, axis, shared);
            d = vec3_with(d, axis, shared);
        } else {
            d = vec3_add(a, vec3_add(vec3_scale(vec3_sub(b, a), 2.0 * rng_sym(r)),
                                     vec3_scale(vec3_sub(c, a), 2.0 * rng_sym(r))));
            d = nudge_point(r, d, ulps);
        }
        vec3 pts[4] = {a, b, c, d};
        for (int i = 3; i > 0; i--) { /* every point in every role */
            int j = rng_int(r, 0, i);
            vec3 t = pts[i];
            pts[i] = pts[j];
            pts[j] = t;
        }
        for (int i = 0; i < 4; i++)
            put_point(pc->v, i, pts[i]);
        break;
    }
    case PRED_DIFF_PRODUCTS: {
        /* (a-b)(c-d) - (c'-d')(a'-b') with primes a few ulps away: exactly equal
         * products before the nudge. */
        double v[8] = {a.x, a.y, b.x, b.y, b.x, b.y, a.x, a.y};
        for (int i = 4; i < 8; i++)
            v[i] = nudge_ulps(v[i], rng_int(r, -ulps, ulps));
        memcpy(pc->v, v, sizeof v);
        break;
    }
    case PRED_RAY_EDGE: {
        vec3 dir = rand_point(r, 0.0, 1.0);
        /* Axis-aligned and plane-aligned rays are common; zero out one or two components. */
        int zeros = rng_int(r, 0, 3);
        if (zeros == 1 || zeros == 2) {
            int axis = rng_int(r, 0, 2);
            dir = vec3_with(dir, axis, 0.0);
            if (zeros == 2)
                dir = vec3_with(dir, (axis + 1) % 3, 0.0);
        }
        vec3 on_edge = lerp_point(a, b, rng_unit(r));
        vec3 o = nudge_point(r, vec3_sub(on_edge, vec3_scale(dir, size * rng_sym(r))), ulps);
        put_point(pc->v, 0, a);
        put_point(pc->v, 1, b);
        put_point(pc->v, 2, o);
        put_point(pc->v, 3, dir);
        break;
    }
    case PRED_ORIENT2D_AXIS: {
        vec3 c = nudge_point(r, lerp_point(a, b, 2.0 * rng_sym(r)), ulps);
        vec3 pts[3] = {a, b, c};
        int where = rng_int(r, 0, 2);
        vec3 t = pts[where];
        pts[where] = pts[2];
        pts[2] = t;
        for (int i = 0; i < 3; i++)
            put_point(pc->v, i, pts[i]);
        break;
    }
    default:
        fail();
    }
}

/* A small-integer vector, optionally zero. */
static vec3 rand_int_vec(rng *r, int range)
{
    return vec3_make(rng_int(r, -range, range), rng_int(r, -range, range),
                     rng_int(r, -range, range));
}

/* Exactly degenerate inputs: small integers times a power of two, plus an offset that
 * keeps everything exactly representable. */
static void gen_exactly_degenerate(rng *r, pred_kind kind, pred_case *pc)
{
    static const double units[] = {1.0, 0x1p-20, 0x1p-40, 0x1p10, 0.5};
    /* in units: every coordinate is an integer below 2^42 times the unit */
    static const double offsets[] = {0.0, 0x1p20, -0x1p40, 0x1.8p39};
    double unit = units[rng_int(r, 0, 4)];
    double offset = offsets[rng_int(r, 0, 3)] * unit;
    vec3 shift = vec3_make(offset, -offset, offset);
    memset(pc, 0, sizeof *pc);
    pc->kind = kind;
    pc->axis = rng_int(r, 0, 2);
    vec3 base = rand_int_vec(r, 64), u = rand_int_vec(r, 16), w = rand_int_vec(r, 16);
#define EXACT_POINT(i, j) \
    vec3_add(shift, vec3_scale(vec3_add(base, vec3_add(vec3_scale(u, (i)), vec3_scale(w, (j)))), unit))
    switch (kind) {
    case PRED_ORIENT2D:
    case PRED_ORIENT2D_AXIS: {
        vec3 p[3];
        for (int i = 0; i < 3; i++)
            p[i] = EXACT_POINT(rng_int(r, -8, 8), 0);
        if (kind == PRED_ORIENT2D) {
            double v[6] = {p[0].x, p[0].y, p[1].x, p[1].y, p[2].x, p[2].y};
            memcpy(pc->v, v, sizeof v);
        } else {
            for (int i = 0; i < 3; i++)
                put_point(pc->v, i, p[i]);
        }
        break;
    }
    case PRED_ORIENT3D:
        for (int i = 0; i < 4; i++)
            put_point(pc->v, i, EXACT_POINT(rng_int(r, -8, 8), rng_int(r, -8, 8)));
        break;
    case PRED_DIFF_PRODUCTS: {
        /* (a-b)(c-d) = x*y = (e-f)(g-h) with e-f = y, g-h = x. */
        double x = rng_int(r, -64, 64) * unit, y = rng_int(r, -64, 64) * unit;
        double b = offset + rng_int(r, -64, 64) * unit, d = offset + rng_int(r, -64, 64) * unit;
        double f = offset + rng_int(r, -64, 64) * unit, h = offset + rng_int(r, -64, 64) * unit;
        double v[8] = {b + x, b, d + y, d, f + y, f, h + x, h};
        memcpy(pc->v, v, sizeof v);
        break;
    }
    case PRED_RAY_EDGE: {
        /* dir in the plane spanned by p-o and q-o. */
        vec3 o = EXACT_POINT(0, 0);
        vec3 p = EXACT_POINT(rng_int(r, -8, 8), rng_int(r, -8, 8));
        vec3 q = EXACT_POINT(rng_int(r, -8, 8), rng_int(r, -8, 8));
        vec3 dir = vec3_add(vec3_scale(u, rng_int(r, -4, 4)), vec3_scale(w, rng_int(r, -4, 4)));
        put_point(pc->v, 0, p);
        put_point(pc->v, 1, q);
        put_point(pc->v, 2, o);
        put_point(pc->v, 3, dir);
        break;
    }
    default:
        fail();
    }
#undef EXACT_POINT
}

/* ---------- permutations ---------- */

/* Writes permutation number `which` of pc into out and returns the sign factor it should
 * apply (+1 or -1), or 0 when there are no more. */
static int permute_case(const pred_case *pc, int which, pred_case *out)
{
    *out = *pc;
    const double *v = pc->v;
    double *w = out->v;
    switch (pc->kind) {
    case PRED_ORIENT2D:
    case PRED_ORIENT2D_AXIS: {
        static const int perms[][3] = {{1, 0, 2}, {0, 2, 1}, {2, 1, 0}, {1, 2, 0}, {2, 0, 1}};
        static const int signs[] = {-1, -1, -1, 1, 1};
        if (which >= 5)
            return 0;
        int dim = pc->kind == PRED_ORIENT2D ? 2 : 3;
        for (int i = 0; i < 3; i++)
            for (int k = 0; k < dim; k++)
                w[dim * i + k] = v[dim * perms[which][i] + k];
        return signs[which];
    }
    case PRED_ORIENT3D: {
        static const int perms[][4] = {
            {1, 0, 2, 3}, {0, 1, 3, 2}, {3, 1, 2, 0}, {1, 2, 0, 3}, {1, 0, 3, 2}, {3, 2, 1, 0}};
        static const int signs[] = {-1, -1, -1, 1, 1, 1};
        if (which >= 6)
            return 0;
        for (int i = 0; i < 4; i++)
            for (int k = 0; k < 3; k++)
                w[3 * i + k] = v[3 * perms[which][i] + k];
        return signs[which];
    }
    case PRED_DIFF_PRODUCTS: {
        /* Negating both first factors, both second factors, or swapping the products
         * flips the sign; negating both factors of one product, or commuting them, not. */
        static const int perms[][8] = {{1, 0, 2, 3, 5, 4, 6, 7}, {0, 1, 3, 2, 4, 5, 7, 6},
                                       {4, 5, 6, 7, 0, 1, 2, 3}, {2, 3, 0, 1, 6, 7, 4, 5},
                                       {1, 0, 3, 2, 4, 5, 6, 7}, {0, 1, 2, 3, 5, 4, 7, 6}};
        static const int signs[] = {-1, -1, -1, 1, 1, 1};
        if (which >= 6)
            return 0;
        for (int i = 0; i < 8; i++)
            w[i] = v[perms[which][i]];
        return signs[which];
    }
    case PRED_RAY_EDGE: {
        if (which >= 3)
            return 0;
        if (which != 1) { /* swap p and q */
            for (int k = 0; k < 3; k++) {
                w[k] = v[3 + k];
                w[3 + k] = v[k];
            }
        }
        if (which != 0) /* reverse the direction */
            for (int k = 9; k < 12; k++)
                w[k] = -v[k];
        return which == 2 ? 1 : -1;
    }
    default:
        fail();
        return 0;
    }
}

/* ---------- expansion helpers ---------- */

static int lowest_bit_exponent(double x)
{
    int exponent;
    double mantissa = frexp(fabs(x), &exponent);
    uint64_t bits = (uint64_t)ldexp(mantissa, 53);
    return __builtin_ctzll(bits) + exponent - 53;
}

/* Zero-eliminated, finite, increasing and nonoverlapping: every component lies wholly
 * below the lowest set bit of the next. */
static int is_valid_expansion(size_t n, const double *e)
{
    for (size_t i = 0; i < n; i++)
        if (e[i] == 0.0 || !isfinite(e[i]))
            return 0;
    for (size_t i = 0; i + 1 < n; i++)
        if (!(fabs(e[i]) < ldexp(1.0, lowest_bit_exponent(e[i + 1]))))
            return 0;
    return 1;
}

static void expansion_to_mpq(mpq_t out, size_t n, const double *e)
{
    mpq_t q;
    mpq_init(q);
    mpq_set_ui(out, 0, 1);
    for (size_t i = 0; i < n; i++) {
        mpq_set_d(q, e[i]);
        mpq_add(out, out, q);
    }
    mpq_clear(q);
}

/* A random expansion built from `terms` random doubles with exponents in [lo, hi]; the
 * exact sum of the doubles goes to value. Returns the length; e holds `terms`. */
static size_t random_expansion(rng *r, int terms, int lo_exp, int hi_exp, double *e, mpq_t value)
{
    double scratch[256];
    size_t n = 0;
    mpq_t q;
    mpq_init(q);
    mpq_set_ui(value, 0, 1);
    assert_true(terms <= 256);
    for (int i = 0; i < terms; i++) {
        double x = rng_wide(r, lo_exp, hi_exp);
        mpq_set_d(q, x);
        mpq_add(value, value, q);
        n = expansion_sum(n, e, 1, &x, scratch);
        memcpy(e, scratch, n * sizeof *e);
    }
    mpq_clear(q);
    return n;
}

/* ---------- expansion tests ---------- */

static void test_error_free_transforms_are_exact(void **state)
{
    (void)state;
    rng r = rng_for(1);
    mpq_t exact, got, part;
    mpq_inits(exact, got, part, NULL);
    for (int i = 0; i < 20000; i++) {
        /* exponents keep every product's low part above 2^-1074 */
        double a = rng_wide(&r, -480, 480), b = rng_wide(&r, -480, 480);
        if (i % 4 == 0)
            b = nudge_ulps(-a, rng_int(&r, -3, 3)); /* heavy cancellation */
        double hi, lo;
        mpq_t qa, qb;
        mpq_inits(qa, qb, NULL);
        mpq_set_d(qa, a);
        mpq_set_d(qb, b);

        two_sum(a, b, &hi, &lo);
        assert_true(hi == a + b);
        mpq_add(exact, qa, qb);
        mpq_set_d(got, hi);
        mpq_set_d(part, lo);
        mpq_add(got, got, part);
        assert_true(mpq_equal(exact, got));

        two_diff(a, b, &hi, &lo);
        assert_true(hi == a - b);
        mpq_sub(exact, qa, qb);
        mpq_set_d(got, hi);
        mpq_set_d(part, lo);
        mpq_add(got, got, part);
        assert_true(mpq_equal(exact, got));

        two_product(a, b, &hi, &lo);
        assert_true(hi == a * b);
        mpq_mul(exact, qa, qb);
        mpq_set_d(got, hi);
        mpq_set_d(part, lo);
        mpq_add(got, got, part);
        assert_true(mpq_equal(exact, got));
        assert_true(fabs(lo) <= 0.5 * (nextafter(fabs(hi), INFINITY) - fabs(hi)));
        mpq_clears(qa, qb, NULL);
    }
    mpq_clears(exact, got, part, NULL);
}

static void test_expansion_sum_matches_gmp(void **state)
{
    (void)state;
    rng r = rng_for(2);
    double e[64], f[64], h[128];
    mpq_t ev, fv, hv, want;
    mpq_inits(ev, fv, hv, want, NULL);
    for (int i = 0; i < 3000; i++) {
        int spread = rng_int(&r, 0, 300);
        size_t en = random_expansion(&r, rng_int(&r, 0, 64), -spread, spread, e, ev);
        size_t fn = random_expansion(&r, rng_int(&r, 0, 64), -spread, spread, f, fv);
        assert_true(is_valid_expansion(en, e));
        assert_true(is_valid_expansion(fn, f));
        if (i % 3 == 0) { /* f = -e: everything cancels */
            memcpy(f, e, en * sizeof *e);
            expansion_negate(en, f);
            fn = en;
            mpq_neg(fv, ev);
        }
        size_t hn = expansion_sum(en, e, fn, f, h);
        assert_true(hn <= en + fn);
        assert_true(is_valid_expansion(hn, h));
        expansion_to_mpq(hv, hn, h);
        mpq_add(want, ev, fv);
        assert_true(mpq_equal(hv, want));
        assert_int_equal(expansion_sign(hn, h), mpq_sgn(want));
    }
    mpq_clears(ev, fv, hv, want, NULL);
}

static void test_expansion_sum_of_opposites_is_empty(void **state)
{
    (void)state;
    rng r = rng_for(3);
    double e[40], f[40], h[80];
    mpq_t v;
    mpq_init(v);
    size_t en = random_expansion(&r, 40, -200, 200, e, v);
    memcpy(f, e, en * sizeof *e);
    expansion_negate(en, f);
    assert_int_equal(expansion_sum(en, e, en, f, h), 0);
    assert_int_equal(expansion_sign(0, h), 0);
    assert_true(expansion_estimate(0, h) == 0.0);
    mpq_clear(v);
}

static void test_expansion_scale_matches_gmp(void **state)
{
    (void)state;
    rng r = rng_for(4);
    double e[48], h[96];
    mpq_t ev, bv, hv;
    mpq_inits(ev, bv, hv, NULL);
    for (int i = 0; i < 3000; i++) {
        size_t en = random_expansion(&r, rng_int(&r, 0, 48), -250, 250, e, ev);
        double b = i % 17 == 0 ? 0.0 : rng_wide(&r, -200, 200);
        size_t hn = expansion_scale(en, e, b, h);
        assert_true(hn <= 2 * en);
        assert_true(is_valid_expansion(hn, h));
        expansion_to_mpq(hv, hn, h);
        mpq_set_d(bv, b);
        mpq_mul(ev, ev, bv);
        assert_true(mpq_equal(hv, ev));
    }
    mpq_clears(ev, bv, hv, NULL);
}

/* Checks h = e * f with an output buffer of exactly 2 * en * fn doubles, so the address
 * sanitizer catches any write past the documented size. */
static void check_product(size_t en, const double *e, size_t fn, const double *f)
{
    size_t capacity = 2 * en * fn > 0 ? 2 * en * fn : 1;
    double *h = malloc(capacity * sizeof *h);
    assert_non_null(h);
    mpq_t ev, fv, hv;
    mpq_inits(ev, fv, hv, NULL);
    expansion_to_mpq(ev, en, e);
    expansion_to_mpq(fv, fn, f);
    mpq_mul(ev, ev, fv);
    size_t hn = expansion_product(en, e, fn, f, h);
    assert_true(hn <= capacity);
    assert_true(is_valid_expansion(hn, h));
    expansion_to_mpq(hv, hn, h);
    assert_true(mpq_equal(hv, ev));
    assert_int_equal(expansion_sign(hn, h), mpq_sgn(ev));
    mpq_clears(ev, fv, hv, NULL);
    free(h);
}

static void test_expansion_product_matches_gmp(void **state)
{
    (void)state;
    rng r = rng_for(5);
    double e[40], f[40];
    mpq_t v;
    mpq_init(v);
    for (int i = 0; i < 2000; i++) {
        size_t en = random_expansion(&r, rng_int(&r, 0, 40), -150, 150, e, v);
        size_t fn = random_expansion(&r, rng_int(&r, 0, 40), -150, 150, f, v);
        check_product(en, e, fn, f);
    }
    mpq_clear(v);
}

/* Long expansions (more components than one scaling chunk): small odd mantissas four bits
 * apart, so they are nonoverlapping by construction. */
static size_t long_expansion(rng *r, size_t n, int first_exp, double *e)
{
    for (size_t i = 0; i < n; i++) {
        double m = 2 * rng_int(r, 0, 3) + 1;
        double x = ldexp(m, first_exp + 4 * (int)i);
        e[i] = (rng_next(r) & 1) ? -x : x;
    }
    return n;
}

static void test_expansion_product_of_long_expansions(void **state)
{
    (void)state;
    rng r = rng_for(6);
    static double e[200], f[200];
    static const size_t sizes[][2] = {{150, 3}, {3, 150}, {70, 70}, {130, 1}, {1, 1}, {65, 64}};
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        size_t en = long_expansion(&r, sizes[k][0], -400, e);
        size_t fn = long_expansion(&r, sizes[k][1], -300, f);
        assert_true(is_valid_expansion(en, e));
        check_product(en, e, fn, f);
    }
}

static void test_expansion_product_with_empty_factor_is_zero(void **state)
{
    (void)state;
    double e[2] = {0x1p-60, 3.0}, h[4] = {7.0, 7.0, 7.0, 7.0};
    assert_int_equal(expansion_product(0, e, 2, e, h), 0);
    assert_int_equal(expansion_product(2, e, 0, e, h), 0);
    assert_int_equal(expansion_scale(0, e, 2.0, h), 0);
    assert_int_equal(expansion_scale(2, e, 0.0, h), 0);
}

static void test_expansion_sign_estimate_negate(void **state)
{
    (void)state;
    rng r = rng_for(7);
    double e[64];
    mpq_t v;
    mpq_init(v);
    for (int i = 0; i < 2000; i++) {
        size_t en = random_expansion(&r, rng_int(&r, 1, 64), -100, 100, e, v);
        assert_int_equal(expansion_sign(en, e), mpq_sgn(v));
        /* recursive summation of at most 64 terms: within 64 u of the absolute sum */
        double estimate = expansion_estimate(en, e), exact = mpq_get_d(v), magnitude = 0.0;
        for (size_t k = 0; k < en; k++)
            magnitude += fabs(e[k]);
        assert_true(fabs(estimate - exact) <= 0x1p-46 * magnitude);
        expansion_negate(en, e);
        assert_int_equal(expansion_sign(en, e), -mpq_sgn(v));
    }
    mpq_clear(v);
}

/* ---------- predicate tests ---------- */

static void test_predicates_random_inputs_match_gmp(void **state)
{
    (void)state;
    rng r = rng_for(10);
    ref_ctx c;
    ref_init(&c);
    for (int kind = 0; kind < PRED_KIND_COUNT; kind++) {
        tally t = {0};
        pred_case pc;
        for (int i = 0; i < 20000; i++) {
            /* plain unit-box inputs, then coordinates of very different sizes */
            gen_random(&r, (pred_kind)kind, 0.0, 1.0, &pc);
            if (i % 2)
                for (int k = 0; k < pred_arity[kind]; k++)
                    pc.v[k] = rng_wide(&r, -40, 40);
            check_case(&c, &pc, &t, "random");
        }
        finish_tally(&t, "random", (pred_kind)kind);
    }
    ref_clear(&c);
}

static void test_predicates_near_degenerate_inputs_match_gmp(void **state)
{
    (void)state;
    rng r = rng_for(11);
    static const double offsets[] = {0.0, 1e6, 1e9};
    static const double sizes[] = {1.0, 1e-3, 1e-9};
    ref_ctx c;
    ref_init(&c);
    for (int kind = 0; kind < PRED_KIND_COUNT; kind++) {
        tally t = {0};
        pred_case pc;
        uint64_t fallbacks_before = predicates_fallback_count();
        for (int o = 0; o < 3; o++)
            for (int s = 0; s < 3; s++)
                for (int i = 0; i < 3000; i++) {
                    gen_near_degenerate(&r, (pred_kind)kind, offsets[o], sizes[s], &pc);
                    check_case(&c, &pc, &t, "near degenerate");
                }
        finish_tally(&t, "near degenerate", (pred_kind)kind);
        /* The batch is only a test of the exact stage if the filter gave up often. */
        uint64_t fallbacks = predicates_fallback_count() - fallbacks_before;
        printf("  %-20s %-26s %6llu exact fallbacks\n", pred_names[kind], "",
               (unsigned long long)fallbacks);
        assert_true(fallbacks >= (uint64_t)t.cases / 10);
        assert_true(t.positives > 0 && t.negatives > 0);
    }
    ref_clear(&c);
}

static void test_predicates_exactly_degenerate_inputs_are_zero(void **state)
{
    (void)state;
    rng r = rng_for(12);
    ref_ctx c;
    ref_init(&c);
    for (int kind = 0; kind < PRED_KIND_COUNT; kind++) {
        tally t = {0};
        pred_case pc;
        for (int i = 0; i < 4000; i++) {
            gen_exactly_degenerate(&r, (pred_kind)kind, &pc);
            assert_int_equal(eval_ref(&c, &pc), 0); /* the generator is right */
            check_case(&c, &pc, &t, "exactly degenerate");
        }
        finish_tally(&t, "exactly degenerate", (pred_kind)kind);
        assert_int_equal(t.zeros, t.cases);
    }
    ref_clear(&c);
}

/* Kettner et al., "Classroom examples of robustness problems in geometric computations":
 * p on a 256 x 256 grid of doubles next to (0.5, 0.5), q = (12, 12), r = (24, 24). Plain
 * double evaluation gets a jumble of signs here; the exact signs form clean regions. */
static void test_orient2d_kettner_grid_matches_gmp(void **state)
{
    (void)state;
    ref_ctx c;
    ref_init(&c);
    tally t2 = {0}, t_axis = {0};
    long naive_wrong = 0;
    for (int i = 0; i < 256; i++)
        for (int j = 0; j < 256; j++) {
            double px = 0.5 + i * 0x1p-53, py = 0.5 + j * 0x1p-53;
            pred_case pc = {.kind = PRED_ORIENT2D, .v = {px, py, 12.0, 12.0, 24.0, 24.0}};
            check_case(&c, &pc, &t2, "kettner grid");
            double naive = (px - 24.0) * (12.0 - 24.0) - (py - 24.0) * (12.0 - 24.0);
            naive_wrong += (naive > 0) - (naive < 0) != eval_ref(&c, &pc);
            /* the same points lifted to z = 7, seen along z */
            pred_case lifted = {.kind = PRED_ORIENT2D_AXIS, .axis = 2,
                                .v = {px, py, 7.0, 12.0, 12.0, 7.0, 24.0, 24.0, 7.0}};
            check_case(&c, &lifted, &t_axis, "kettner grid");
        }
    finish_tally(&t2, "kettner grid", PRED_ORIENT2D);
    finish_tally(&t_axis, "kettner grid", PRED_ORIENT2D_AXIS);
    /* The line y = x passes through the grid: all three answers occur, and plain double
     * evaluation gets many of them wrong. */
    assert_true(t2.zeros > 0 && t2.positives > 0 && t2.negatives > 0);
    printf("  plain double evaluation is wrong on %ld of the grid's points\n", naive_wrong);
    assert_true(naive_wrong > 1000);
    ref_clear(&c);
}

static void check_permutations(ref_ctx *c, const pred_case *pc, tally *t)
{
    int want = eval_ref(c, pc);
    pred_case permuted;
    int factor;
    for (int which = 0; (factor = permute_case(pc, which, &permuted)) != 0; which++) {
        int got = eval_impl(&permuted);
        t->cases++;
        t->zeros += want == 0;
        t->positives += factor * want > 0;
        t->negatives += factor * want < 0;
        if (got != factor * want) {
            if (t->mismatches < 5)
                report_mismatch(&permuted, got, factor * want, "permutation");
            t->mismatches++;
        }
    }
}

static void test_predicates_permutations_flip_sign(void **state)
{
    (void)state;
    rng r = rng_for(13);
    ref_ctx c;
    ref_init(&c);
    for (int kind = 0; kind < PRED_KIND_COUNT; kind++) {
        tally t = {0};
        pred_case pc;
        for (int i = 0; i < 6000; i++) {
            int style = i % 3;
            if (style == 0)
                gen_near_degenerate(&r, (pred_kind)kind, i % 2 ? 1e6 : 0.0, 1e-3, &pc);
            else if (style == 1)
                gen_exactly_degenerate(&r, (pred_kind)kind, &pc);
            else
                gen_random(&r, (pred_kind)kind, 0.0, 1.0, &pc);
            check_permutations(&c, &pc, &t);
        }
        finish_tally(&t, "permutations", (pred_kind)kind);
    }
    ref_clear(&c);
}

/* Configurations scaled from subnormal to near-overflow: the filter's underflow terms and
 * the exact stage's power-of-two scaling both get exercised. */
static void test_predicates_extreme_magnitudes_match_gmp(void **state)
{
    (void)state;
    rng r = rng_for(14);
    /* Unit-sized configurations (coordinates below 9) scaled by these powers of two, so
     * nearly degenerate ones stay nearly degenerate until they reach the subnormals. */
    static const int scales[] = {
        -1064, /* subnormal coordinates */
        -997,  /* about 1e-300: products underflow entirely */
        -531,  /* about 1e-160: two-factor products land among the subnormals */
        -355,  /* three-factor products near 2^-1065 */
        -340,  /* three-factor products at the bottom of the normal range */
        498,   /* about 1e150: three-factor products overflow */
        997,   /* about 1e300: two-factor products overflow */
        1019,  /* coordinates near 1e307: differences overflow */
        1020,  /* up to 9 * 2^1020, in the top binade: the range's two ends at once */
    };
    const size_t scale_count = sizeof scales / sizeof scales[0];
    ref_ctx c;
    ref_init(&c);
    for (int kind = 0; kind < PRED_KIND_COUNT; kind++) {
        tally t = {0};
        pred_case pc;
        for (size_t s = 0; s < scale_count; s++)
            for (int i = 0; i < 2000; i++) {
                if (i % 2)
                    gen_near_degenerate(&r, (pred_kind)kind, 0.0, 1.0, &pc);
                else
                    gen_random(&r, (pred_kind)kind, 0.0, 1.0, &pc);
                int positions = kind == PRED_RAY_EDGE ? 9 : pred_arity[kind];
                for (int k = 0; k < positions; k++)
                    pc.v[k] = ldexp(pc.v[k], scales[s]);
                if (kind == PRED_RAY_EDGE) /* the direction at its own, varying scale */
                    for (int k = 9; k < 12; k++)
                        pc.v[k] = ldexp(pc.v[k], scales[(s + (size_t)i) % scale_count]);
                for (int k = 0; k < pred_arity[kind]; k++)
                    assert_true(isfinite(pc.v[k]));
                check_case(&c, &pc, &t, "extreme magnitudes");
            }
        finish_tally(&t, "extreme magnitudes", (pred_kind)kind);
    }
    ref_clear(&c);
}

/* ---------- worst roundings found ---------- */

/* The filters' own expressions in plain doubles, in the filters' operation order, so the
 * test can show that its inputs fool them. *permanent is the sum the bound multiplies. */
static double plain_determinant(const pred_case *pc, double *permanent)
{
    const double *v = pc->v;
    switch (pc->kind) {
    case PRED_ORIENT2D:
    case PRED_DIFF_PRODUCTS: {
        /* orient2d is (ax-cx)(by-cy) - (ay-cy)(bx-cx) */
        static const int orient2d_operands[8] = {0, 4, 3, 5, 1, 5, 2, 4};
        double x[8];
        for (int i = 0; i < 8; i++)
            x[i] = pc->kind == PRED_ORIENT2D ? v[orient2d_operands[i]] : v[i];
        double left = (x[0] - x[1]) * (x[2] - x[3]), right = (x[4] - x[5]) * (x[6] - x[7]);
        *permanent = fabs(left) + fabs(right);
        return left - right;
    }
    case PRED_ORIENT3D: {
        vec3 da = vec3_sub(vec_at(v, 3), vec_at(v, 0)), db = vec3_sub(vec_at(v, 3), vec_at(v, 1)),
             dc = vec3_sub(vec_at(v, 3), vec_at(v, 2));
        double bc_1 = db.x * dc.y, bc_2 = dc.x * db.y, ca_1 = dc.x * da.y, ca_2 = da.x * dc.y,
               ab_1 = da.x * db.y, ab_2 = db.x * da.y;
        *permanent = (fabs(bc_1) + fabs(bc_2)) * fabs(da.z) + (fabs(ca_1) + fabs(ca_2)) * fabs(db.z) +
                     (fabs(ab_1) + fabs(ab_2)) * fabs(dc.z);
        return da.z * (bc_1 - bc_2) + db.z * (ca_1 - ca_2) + dc.z * (ab_1 - ab_2);
    }
    case PRED_RAY_EDGE: {
        vec3 op = vec3_sub(vec_at(v, 0), vec_at(v, 2)), oq = vec3_sub(vec_at(v, 1), vec_at(v, 2)),
             dir = vec_at(v, 3);
        double x_1 = op.y * oq.z, x_2 = op.z * oq.y, y_1 = op.z * oq.x, y_2 = op.x * oq.z,
               z_1 = op.x * oq.y, z_2 = op.y * oq.x;
        *permanent = (fabs(x_1) + fabs(x_2)) * fabs(dir.x) + (fabs(y_1) + fabs(y_2)) * fabs(dir.y) +
                     (fabs(z_1) + fabs(z_2)) * fabs(dir.z);
        return dir.x * (x_1 - x_2) + dir.y * (y_1 - y_2) + dir.z * (z_1 - z_2);
    }
    default:
        fail();
        *permanent = 0.0;
        return 0.0;
    }
}

/* Found by a randomized ulp-by-ulp search for the largest |det^| / permanent among inputs
 * whose plain double determinant det^ has the wrong sign. A filter constant below the
 * margin (in units of 2^-53) would accept that wrong sign; the constants in use are
 * 3 (two products), 7 (orient3d) and 6 (ray_edge_sign), from the worst-case analysis. */
static const struct {
    pred_case pc;
    double margin;
} worst_rounding_cases[] = {
    {{PRED_ORIENT2D, 0,
          {0x1.85d8097f79789p-1, -0x1.ed483d9868c4dp-1, -0x1.b8c851e785718p-5,
           0x1.64d6395a277f1p-1, -0x1.792915e5e703ep-1, 0x1.0b39d0aa0e27ep+1}},
     1.9},
    {{PRED_DIFF_PRODUCTS, 0,
          {0x1.39da863594410p-1, -0x1.6494b779b5b67p-1, 0x1.cdc1fd5883a20p-5,
           -0x1.ee810b4313df1p-1, 0x1.cdc1fd58839aep-5, -0x1.ee810b4313e00p-1,
           0x1.39da8635943dep-1, -0x1.6494b779b5b8fp-1}},
     2.2},
    {{PRED_ORIENT3D, 0,
          {0x1.24619b04c5ba7p-3, 0x1.c4d1cf01e4a35p-1, 0x1.e7bba1c7cd0abp-2,
           0x1.1fb3afe35dd6cp-5, -0x1.69600e2a6378dp-3, 0x1.212dd767cba66p-4,
           0x1.67b846e1bdb58p-2, -0x1.e69e5f35ce9e7p-5, -0x1.8989dd6122434p-2,
           -0x1.054a622973837p-2, -0x1.1b817501a53c3p-2, 0x1.f7f68cf270d01p-2}},
     3.0},
    {{PRED_RAY_EDGE, 0,
          {0x1.93cb15dbb705ep-2, 0x1.5a2b0e1eabee5p-3, -0x1.736431c48af4cp-2,
           0x1.41d6530f881e4p-1, 0x1.a924412b0d902p-2, 0x1.5dcb5faec680ap-1,
           -0x1.875baf4b72372p-4, 0x1.08606e32c0f51p-1, 0x1.d45a647341483p-5,
           0x1.0eb996d9c6143p-1, -0x1.3bb3c1adf66d4p-2, -0x1.01d34b8286650p-2}},
     2.15},
};

static void test_filters_reject_worst_roundings_found(void **state)
{
    (void)state;
    ref_ctx c;
    ref_init(&c);
    for (size_t i = 0; i < sizeof worst_rounding_cases / sizeof worst_rounding_cases[0]; i++) {
        const pred_case *pc = &worst_rounding_cases[i].pc;
        int want = eval_ref(&c, pc);
        double permanent, plain = plain_determinant(pc, &permanent);
        int plain_sign = (plain > 0) - (plain < 0);
        printf("  %-20s plain sign %+d, exact %+d, |det^| = %.3f u * permanent\n",
               pred_names[pc->kind], plain_sign, want, fabs(plain) / permanent / EXPANSION_EPS);
        assert_int_not_equal(plain_sign, want);
        assert_true(fabs(plain) >= worst_rounding_cases[i].margin * EXPANSION_EPS * permanent);
        assert_int_equal(eval_impl(pc), want);
    }
    ref_clear(&c);
}

/* ---------- fallback counter ---------- */

static const pred_case degenerate_inputs[] = {
    /* collinear, with no zero difference and no factor repeated */
    {PRED_ORIENT2D, 0, {0, 0, 1, 2, 3, 6}},
    /* d = b + c - a: coplanar */
    {PRED_ORIENT3D, 0, {0, 0, 0, 1, 1, 1, 1, 2, 3, 2, 3, 4}},
    /* (6-2)(5-2) - (7-1)(4-2) = 12 - 12 */
    {PRED_DIFF_PRODUCTS, 0, {6, 2, 5, 2, 7, 1, 4, 2}},
    /* dir = p + q lies in the plane of o, p, q */
    {PRED_RAY_EDGE, 0, {1, 2, 3, 4, 5, 6, 0, 0, 0, 5, 7, 9}},
    /* collinear in 3D, so collinear on every projection */
    {PRED_ORIENT2D_AXIS, 1, {0, 0, 0, 1, 2, 3, 2, 4, 6}},
};

static const pred_case easy_inputs[] = {
    {PRED_ORIENT2D, 0, {0, 0, 1, 0, 0, 1}},
    {PRED_ORIENT3D, 0, {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1}},
    {PRED_DIFF_PRODUCTS, 0, {6, 2, 5, 2, 7, 1, 4, 3}},
    {PRED_RAY_EDGE, 0, {1, 0, 0, 0, 1, 0, 0, 0, -1, 0, 0, 1}},
    {PRED_ORIENT2D_AXIS, 2, {0, 0, 0, 1, 0, 5, 0, 1, -5}},
};

static void test_fallback_counter_counts_only_undecided_inputs(void **state)
{
    (void)state;
    ref_ctx c;
    ref_init(&c);
    for (size_t i = 0; i < sizeof degenerate_inputs / sizeof degenerate_inputs[0]; i++) {
        uint64_t before = predicates_fallback_count();
        assert_int_equal(eval_impl(&degenerate_inputs[i]), 0);
        assert_int_equal(eval_ref(&c, &degenerate_inputs[i]), 0);
        assert_int_equal(predicates_fallback_count(), before + 1);

        before = predicates_fallback_count();
        int sign = eval_impl(&easy_inputs[i]);
        assert_int_not_equal(sign, 0);
        assert_int_equal(sign, eval_ref(&c, &easy_inputs[i]));
        assert_int_equal(predicates_fallback_count(), before);
    }
    uint64_t before = predicates_fallback_count();
    predicates_note_fallback();
    assert_int_equal(predicates_fallback_count(), before + 1);
    ref_clear(&c);
}

/* Coincident points and points on an axis-aligned plane are common in meshes; their zero
 * is visible without exact arithmetic. */
static void test_axis_aligned_degeneracies_need_no_fallback(void **state)
{
    (void)state;
    vec3 a = vec3_make(1, 2, 5), b = vec3_make(4, -1, 5), c = vec3_make(0.25, 7, 5),
         d = vec3_make(-3, 0.5, 5);
    vec3 p = vec3_make(0.1, 0.7, -0.3), q = vec3_make(-1.3, 0.2, 0.9),
         r = vec3_make(0.6, -0.4, 0.35), dir = vec3_make(0.3, -0.9, 0.2);
    uint64_t before = predicates_fallback_count();
    assert_int_equal(orient3d(a, b, c, d), 0); /* plane z = 5 */
    for (int i = 0; i < 4; i++) {              /* a repeated point, in every pair of roles */
        vec3 pts[4] = {p, q, r, dir};
        pts[i] = pts[(i + 1) % 4];
        assert_int_equal(orient3d(pts[0], pts[1], pts[2], pts[3]), 0);
        pts[i] = pts[(i + 2) % 4];
        assert_int_equal(orient3d(pts[0], pts[1], pts[2], pts[3]), 0);
    }
    assert_int_equal(orient2d(0.1, 0.7, 0.1, 0.7, 0.3, 0.9), 0); /* a == b */
    assert_int_equal(orient2d(0.1, 0.7, 0.3, 0.9, 0.1, 0.7), 0); /* a == c */
    assert_int_equal(orient2d(0.3, 0.9, 0.1, 0.7, 0.1, 0.7), 0); /* b == c */
    assert_int_equal(orient2d_axis(p, p, q, 1), 0);
    assert_int_equal(orient2d_axis(a, b, c, 0), 0); /* projects to a segment */
    assert_int_equal(ray_edge_sign(p, q, p, dir), 0); /* o == p */
    assert_int_equal(ray_edge_sign(p, q, q, dir), 0); /* o == q */
    assert_int_equal(ray_edge_sign(p, p, q, dir), 0); /* p == q */
    assert_int_equal(sign_diff_products(1, 1, 2, 3, 4, 5, 6, 6), 0);
    assert_int_equal(sign_diff_products(0.1, 0.3, 0.7, 0.9, 0.7, 0.9, 0.1, 0.3), 0);
    assert_int_equal(predicates_fallback_count(), before);
}

/* 1 when v scaled by 2^k and back is v again: no bit was lost and nothing overflowed. */
static int scaling_keeps_every_bit(const double *v, size_t n, int k)
{
    for (size_t i = 0; i < n; i++) {
        double scaled = scalbn(v[i], k);
        if (!isfinite(scaled) || scalbn(scaled, -k) != v[i])
            return 0;
    }
    return 1;
}

/* The largest binary exponent of the nonzero finite v[i], and the lowest bit any of them
 * may have set as the exact stage counts it (ilogb(x) - 52, at least -1074). */
static void exponent_range(const double *v, size_t n, int *top, int *low)
{
    *top = INT_MIN;
    *low = INT_MAX;
    for (size_t i = 0; i < n; i++) {
        if (v[i] == 0.0 || !isfinite(v[i]))
            continue;
        int e = ilogb(v[i]), bit = e - 52 < -1074 ? -1074 : e - 52;
        *top = e > *top ? e : *top;
        *low = bit < *low ? bit : *low;
    }
}

/* The exact stage's scaling at the ends of the double range: near DBL_MAX, among the
 * subnormals, both at once, and with infinities or NaNs among the values (which a
 * rounded difference of coordinates near DBL_MAX gives). The shift must be defined for
 * every input, keep every finite value finite, and lose no bit when the nonzero values'
 * exponents fit the range; a non-finite value has no bits to keep and is passed over.
 * ilogb(inf) is INT_MAX and ilogb(NaN) INT_MIN on glibc, so arithmetic on them overflows
 * an int unless they are kept out. */
static void test_exact_scale_exponent_is_defined_at_the_ends_of_the_range(void **state)
{
    (void)state;
    const int max2 = PREDICATES_DEGREE2_MAX_EXP, lsb2 = PREDICATES_DEGREE2_MIN_LSB;
    const int max3 = PREDICATES_DEGREE3_MAX_EXP, lsb3 = PREDICATES_DEGREE3_MIN_LSB;
    const double top_only[] = {DBL_MAX, -0x1p1023};
    assert_int_equal(predicates_exact_scale_exponent(top_only, 2, max2, lsb2), max2 - 1023);
    assert_int_equal(predicates_exact_scale_exponent(top_only, 2, max3, lsb3), max3 - 1023);
    const double bottom_only[] = {0x1p-1074, -0x1p-1070};
    assert_int_equal(predicates_exact_scale_exponent(bottom_only, 2, max2, lsb2), lsb2 + 1074);
    const double zeros[] = {0.0, -0.0};
    assert_int_equal(predicates_exact_scale_exponent(zeros, 2, max2, lsb2), 0);
    /* Both ends at once: too wide for both, so the shift that cannot overflow. */
    const double both[] = {-DBL_MAX, 0x1p-1074};
    assert_int_equal(predicates_exact_scale_exponent(both, 2, max3, lsb3), max3 - 1023);

    /* Non-finite values are passed over: the shift is the finite values' own. */
    const double inf_and_one[] = {INFINITY, 1.0}, one[] = {1.0};
    assert_int_equal(predicates_exact_scale_exponent(inf_and_one, 2, max2, lsb2),
                     predicates_exact_scale_exponent(one, 1, max2, lsb2));
    const double nan_and_big[] = {NAN, 0x1p1000, -INFINITY}, big[] = {0x1p1000};
    assert_int_equal(predicates_exact_scale_exponent(nan_and_big, 3, max3, lsb3),
                     predicates_exact_scale_exponent(big, 1, max3, lsb3));
    assert_int_equal(predicates_exact_scale_exponent(big, 1, max3, lsb3), max3 - 1000);
    const double nothing_finite[] = {INFINITY, -INFINITY, NAN};
    assert_int_equal(predicates_exact_scale_exponent(nothing_finite, 3, max2, lsb2), 0);

    /* Random groups drawn from the whole range, its ends included. */
    rng r = rng_for(41);
    int exact_groups = 0, wide_groups = 0;
    for (int i = 0; i < 20000; i++) {
        double v[12];
        size_t n = (size_t)rng_int(&r, 1, 12);
        int lo_exp = rng_int(&r, -1074, 1023), hi_exp = rng_int(&r, lo_exp, 1023);
        for (size_t k = 0; k < n; k++) {
            switch (rng_int(&r, 0, 9)) {
            case 0: v[k] = rng_next(&r) & 1 ? DBL_MAX : -DBL_MAX; break;
            case 1: v[k] = rng_next(&r) & 1 ? 0x1p-1074 : -0x1p-1074; break;
            case 2: v[k] = 0.0; break;
            case 3: v[k] = i % 4 == 0 ? (rng_next(&r) & 1 ? INFINITY : NAN) : rng_wide(&r, lo_exp, hi_exp); break;
            default: v[k] = rng_wide(&r, lo_exp, hi_exp); break;
            }
        }
        int degree3 = i & 1, max_exp = degree3 ? max3 : max2, min_lsb = degree3 ? lsb3 : lsb2;
        int k = predicates_exact_scale_exponent(v, n, max_exp, min_lsb);
        double finite[12];
        size_t m = 0;
        for (size_t j = 0; j < n; j++)
            if (isfinite(v[j]))
                finite[m++] = v[j];
        int top, low;
        exponent_range(finite, m, &top, &low);
        if (top == INT_MIN) {
            assert_int_equal(k, 0);
            continue;
        }
        /* Never an overflow, and the largest value lands at or below 2^max_exp. */
        assert_true(top + k <= max_exp);
        for (size_t j = 0; j < m; j++)
            assert_true(isfinite(scalbn(finite[j], k)));
        if (top - low <= max_exp - min_lsb) {
            /* Fits: every bit is kept, and the lowest lands at or above 2^min_lsb. */
            assert_true(scaling_keeps_every_bit(finite, m, k));
            assert_true(low + k >= min_lsb);
            exact_groups++;
        } else {
            assert_int_equal(k, max_exp - top);
            wide_groups++;
        }
    }
    printf("  scale exponent: %d groups kept exactly, %d too wide\n", exact_groups, wide_groups);
    assert_true(exact_groups > 2000 && wide_groups > 2000);
}

static void *count_one_fallback(void *arg)
{
    uint64_t *seen = arg;
    seen[0] = predicates_fallback_count();
    (void)orient2d(0, 0, 1, 2, 3, 6);
    seen[1] = predicates_fallback_count();
    return NULL;
}

/* The exact stage's parallel-rows shortcut: a ray aimed exactly at p or q (dir = p - o
 * computed without rounding) or starting on the edge's line gives zero; one ulp off in
 * any component of dir or o gives the sign GMP gives, so the shortcut never answers zero
 * for a determinant that is not. Coordinates on a 2^-20 grid near 1, 1e6 and 1e9 keep every
 * difference exact. */
static void test_ray_edge_aimed_at_endpoint_is_exact(void **state)
{
    (void)state;
    rng r = rng_for(31);
    static const double offsets[] = {1.0, 1e6, 1e9};
    ref_ctx c;
    ref_init(&c);
    tally t = {0};
    for (int o_i = 0; o_i < 3; o_i++)
        for (int i = 0; i < 400; i++) {
            double grid[9];
            for (int k = 0; k < 9; k++)
                grid[k] = offsets[o_i] + ldexp((double)(int64_t)(rng_next(&r) % 2048) - 1024.0, -20);
            vec3 p = vec3_make(grid[0], grid[1], grid[2]), q = vec3_make(grid[3], grid[4], grid[5]);
            vec3 o = vec3_make(grid[6], grid[7], grid[8]);
            if (i % 3 == 2) /* o on the line through p and q, beyond q */
                o = vec3_add(q, vec3_sub(q, p));
            vec3 aims[2] = {vec3_sub(p, o), vec3_sub(q, o)};
            for (int a = 0; a < 2; a++)
                for (int nudge = 0; nudge < 13; nudge++) {
                    /* nudge 0: exact aim; 1-6: one component of dir one ulp up or down;
                     * 7-12: one component of o one ulp up or down. */
                    vec3 dir = aims[a], oo = o;
                    int comp = (nudge - 1) % 6 / 2, up = (nudge - 1) % 2;
                    if (nudge >= 1 && nudge <= 6) {
                        double x = vec3_get(dir, comp);
                        dir = vec3_with(dir, comp, nextafter(x, up ? INFINITY : -INFINITY));
                    } else if (nudge >= 7) {
                        double x = vec3_get(oo, comp);
                        oo = vec3_with(oo, comp, nextafter(x, up ? INFINITY : -INFINITY));
                    }
                    if (dir.x == 0.0 && dir.y == 0.0 && dir.z == 0.0)
                        continue;
                    pred_case pc = {.kind = PRED_RAY_EDGE};
                    double vals[12] = {p.x, p.y, p.z, q.x, q.y, q.z, oo.x, oo.y, oo.z, dir.x, dir.y, dir.z};
                    memcpy(pc.v, vals, sizeof vals);
                    check_case(&c, &pc, &t, "aimed at an endpoint");
                }
        }
    /* Rows whose cross product rounds to zero but is not: (1 + 2^-30)^2 - (1 + 2^-29) is
     * 2^-60, lost in the high parts of the products, so only their exact low parts show
     * that the ray misses p's line. The determinant is -2^-60. */
    {
        double e30 = 1.0 + 0x1p-30, e29 = 1.0 + 0x1p-29;
        pred_case pc = {.kind = PRED_RAY_EDGE, .v = {0, e30, e29, 1, 0, 0, 0, 0, 0, 0, 1, e30}};
        check_case(&c, &pc, &t, "products equal when rounded");
        assert_int_equal(eval_impl(&pc), -1);
    }
    finish_tally(&t, "aimed at an endpoint", PRED_RAY_EDGE);
    /* Both kinds of answer were asked for: exact zeros and ulp-sized nonzero signs. */
    assert_true(t.zeros > 1000);
    assert_true(t.positives > 1000 && t.negatives > 1000);
    ref_clear(&c);
}

static void test_fallback_counter_is_per_thread(void **state)
{
    (void)state;
    (void)orient2d(0, 0, 1, 2, 3, 6); /* this thread's count is now at least 1 */
    uint64_t mine = predicates_fallback_count();
    uint64_t seen[2] = {99, 99};
    pthread_t thread;
    assert_int_equal(pthread_create(&thread, NULL, count_one_fallback, seen), 0);
    assert_int_equal(pthread_join(thread, NULL), 0);
    assert_int_equal(seen[0], 0);
    assert_int_equal(seen[1], 1);
    assert_int_equal(predicates_fallback_count(), mine);
}

int main(void)
{
    const char *env = getenv("TRIOCT_SEED");
    if (env != NULL && *env != '\0')
        base_seed = strtoull(env, NULL, 0);
    printf("test_predicates: seed %llu (rerun with TRIOCT_SEED=%llu)\n",
           (unsigned long long)base_seed, (unsigned long long)base_seed);

    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_error_free_transforms_are_exact),
        cmocka_unit_test(test_expansion_sum_matches_gmp),
        cmocka_unit_test(test_expansion_sum_of_opposites_is_empty),
        cmocka_unit_test(test_expansion_scale_matches_gmp),
        cmocka_unit_test(test_expansion_product_matches_gmp),
        cmocka_unit_test(test_expansion_product_of_long_expansions),
        cmocka_unit_test(test_expansion_product_with_empty_factor_is_zero),
        cmocka_unit_test(test_expansion_sign_estimate_negate),
        cmocka_unit_test(test_predicates_random_inputs_match_gmp),
        cmocka_unit_test(test_predicates_near_degenerate_inputs_match_gmp),
        cmocka_unit_test(test_predicates_exactly_degenerate_inputs_are_zero),
        cmocka_unit_test(test_orient2d_kettner_grid_matches_gmp),
        cmocka_unit_test(test_predicates_permutations_flip_sign),
        cmocka_unit_test(test_predicates_extreme_magnitudes_match_gmp),
        cmocka_unit_test(test_filters_reject_worst_roundings_found),
        cmocka_unit_test(test_fallback_counter_counts_only_undecided_inputs),
        cmocka_unit_test(test_axis_aligned_degeneracies_need_no_fallback),
        cmocka_unit_test(test_ray_edge_aimed_at_endpoint_is_exact),
        cmocka_unit_test(test_fallback_counter_is_per_thread),
        cmocka_unit_test(test_exact_scale_exponent_is_defined_at_the_ends_of_the_range),
    };
    return cmocka_run_group_tests_name("predicates", tests, NULL, NULL);
}
