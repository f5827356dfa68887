/* Tests of ray against triangle: the exact test against a GMP rational reference,
 * watertightness on closed meshes, range and boundary cases, exact t ordering, and how the
 * seed and fast modes fare on the same rays. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <float.h>
#include <gmp.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "geom/predicates.h"
#include "geom/ray_tri.h"
#include "geom/vec3.h"

/* ------------------------------------------------------------------ seeded RNG */

static uint64_t base_seed = 0x5eed0ea7a11ce5ULL;

typedef struct rng {
    uint64_t state;
} rng;

/* splitmix64: the same sequence on every machine. */
static uint64_t rng_u64(rng *r)
{
    uint64_t z = (r->state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/* Each test draws from its own stream so adding draws to one leaves the others alone. */
static rng rng_for(uint64_t test_salt)
{
    rng r = {base_seed ^ (test_salt * 0xd1b54a32d192ed03ULL)};
    return r;
}

static double rng_unit(rng *r) { return (double)(rng_u64(r) >> 11) * 0x1p-53; }
static double rng_range(rng *r, double lo, double hi) { return lo + (hi - lo) * rng_unit(r); }
static int rng_int(rng *r, int lo, int hi)
{
    return lo + (int)(rng_u64(r) % (uint64_t)(hi - lo + 1));
}
static vec3 rng_vec(rng *r, double lo, double hi)
{
    return vec3_make(rng_range(r, lo, hi), rng_range(r, lo, hi), rng_range(r, lo, hi));
}
/* A point on the grid of multiples of 1/step, so sums and midpoints stay exact. */
static vec3 rng_grid_vec(rng *r, int lo, int hi, int step)
{
    return vec3_make((double)rng_int(r, lo, hi) / step, (double)rng_int(r, lo, hi) / step,
                     (double)rng_int(r, lo, hi) / step);
}

/* ------------------------------------------------------------------ GMP reference */

typedef struct qvec {
    mpq_t c[3];
} qvec;

/* Every rational the reference needs, initialised once per test: GMP allocates on init, and
 * the reference runs hundreds of thousands of times. */
typedef struct ref_scratch {
    qvec o, d, tri[3], e1, e2, nd, r;
    mpq_t det, t, u, v, w, x, y, eps, bound;
} ref_scratch;

static void qv_init(qvec *q)
{
    for (int k = 0; k < 3; k++)
        mpq_init(q->c[k]);
}
static void qv_clear(qvec *q)
{
    for (int k = 0; k < 3; k++)
        mpq_clear(q->c[k]);
}
static void qv_set(qvec *q, vec3 v)
{
    mpq_set_d(q->c[0], v.x);
    mpq_set_d(q->c[1], v.y);
    mpq_set_d(q->c[2], v.z);
}
static void qv_sub(qvec *r, const qvec *a, const qvec *b)
{
    for (int k = 0; k < 3; k++)
        mpq_sub(r->c[k], a->c[k], b->c[k]);
}

static void ref_scratch_init(ref_scratch *rs)
{
    qvec *all[] = {&rs->o,  &rs->d,  &rs->tri[0], &rs->tri[1], &rs->tri[2],
                   &rs->e1, &rs->e2, &rs->nd,     &rs->r};
    for (size_t i = 0; i < sizeof all / sizeof all[0]; i++)
        qv_init(all[i]);
    mpq_inits(rs->det, rs->t, rs->u, rs->v, rs->w, rs->x, rs->y, rs->eps, rs->bound, NULL);
}

static void ref_scratch_clear(ref_scratch *rs)
{
    qvec *all[] = {&rs->o,  &rs->d,  &rs->tri[0], &rs->tri[1], &rs->tri[2],
                   &rs->e1, &rs->e2, &rs->nd,     &rs->r};
    for (size_t i = 0; i < sizeof all / sizeof all[0]; i++)
        qv_clear(all[i]);
    mpq_clears(rs->det, rs->t, rs->u, rs->v, rs->w, rs->x, rs->y, rs->eps, rs->bound, NULL);
}

/* out = det[a b c] = a . (b x c); out must not be rs->x or rs->y. */
static void q_triple(ref_scratch *rs, mpq_t out, const qvec *a, const qvec *b, const qvec *c)
{
    mpq_set_ui(out, 0, 1);
    for (int k = 0; k < 3; k++) {
        int i = (k + 1) % 3, j = (k + 2) % 3;
        mpq_mul(rs->x, b->c[i], c->c[j]);
        mpq_mul(rs->y, b->c[j], c->c[i]);
        mpq_sub(rs->x, rs->x, rs->y);
        mpq_mul(rs->x, rs->x, a->c[k]);
        mpq_add(out, out, rs->x);
    }
}

/* Solves rs->o + t rs->d = v0 + u e1 + v e2 (triangle rs->tri) by Cramer's rule on the
 * columns e1, e2, -d, into rs->t, rs->u, rs->v. Returns 0 when the determinant vanishes
 * (ray parallel to the plane or degenerate triangle). */
static int q_solve(ref_scratch *rs)
{
    qv_sub(&rs->e1, &rs->tri[1], &rs->tri[0]);
    qv_sub(&rs->e2, &rs->tri[2], &rs->tri[0]);
    for (int k = 0; k < 3; k++)
        mpq_neg(rs->nd.c[k], rs->d.c[k]);
    qv_sub(&rs->r, &rs->o, &rs->tri[0]);
    q_triple(rs, rs->det, &rs->e1, &rs->e2, &rs->nd);
    if (mpq_sgn(rs->det) == 0)
        return 0;
    q_triple(rs, rs->u, &rs->r, &rs->e2, &rs->nd);
    q_triple(rs, rs->v, &rs->e1, &rs->r, &rs->nd);
    q_triple(rs, rs->t, &rs->e1, &rs->e2, &rs->r);
    mpq_div(rs->u, rs->u, rs->det);
    mpq_div(rs->v, rs->v, rs->det);
    mpq_div(rs->t, rs->t, rs->det);
    return 1;
}

/* For rs->u, rs->v: +1 when all three barycentric weights are positive, -1 when one is
 * negative, else 0. */
static int q_classify(ref_scratch *rs)
{
    mpq_set_ui(rs->w, 1, 1);
    mpq_sub(rs->w, rs->w, rs->u);
    mpq_sub(rs->w, rs->w, rs->v);
    int su = mpq_sgn(rs->u), sv = mpq_sgn(rs->v), sw = mpq_sgn(rs->w);
    if (su < 0 || sv < 0 || sw < 0)
        return -1;
    return su > 0 && sv > 0 && sw > 0 ? 1 : 0;
}

/* The double nearest to q (q must not be rs->x or rs->y). */
static double q_nearest(ref_scratch *rs, const mpq_t q)
{
    double lo = mpq_get_d(q); /* truncated towards zero */
    double hi = nextafter(lo, mpq_sgn(q) >= 0 ? INFINITY : -INFINITY);
    if (!isfinite(hi))
        return lo;
    mpq_set_d(rs->x, lo);
    mpq_sub(rs->x, q, rs->x);
    mpq_abs(rs->x, rs->x);
    mpq_set_d(rs->y, hi);
    mpq_sub(rs->y, rs->y, q);
    mpq_abs(rs->y, rs->y);
    return mpq_cmp(rs->y, rs->x) < 0 ? hi : lo;
}

static int q_cmp_d(const mpq_t q, mpq_t scratch, double x)
{
    mpq_set_d(scratch, x);
    int c = mpq_cmp(q, scratch);
    return (c > 0) - (c < 0);
}

/* The reference answer for one ray and one closed triangle. `perturbed` classifies the
 * hit point of the direction d + (e, e^2, e^3) with e = 2^-300, which for these inputs is
 * far smaller than any nonzero quantity involved: the symbolic perturbation the exact test
 * simulates, computed here by plain rational arithmetic instead. */
typedef struct ref_answer {
    int parallel;  /* den == 0: never a hit */
    int strict;    /* +1 strictly inside, -1 strictly outside, 0 on the boundary */
    int perturbed; /* the same for the perturbed direction (0: o on an edge's line) */
    int lower;     /* sign(t - tmin), +1 for tmin = -inf */
    int upper;     /* sign(t - tmax), -1 for tmax = +inf */
    double t, u, v;
} ref_answer;

static void ref_ray_tri(ref_scratch *rs, vec3 o, vec3 d, double tmin, double tmax,
                        const vec3 tri[3], ref_answer *ans)
{
    memset(ans, 0, sizeof *ans);
    qv_set(&rs->o, o);
    qv_set(&rs->d, d);
    for (int k = 0; k < 3; k++)
        qv_set(&rs->tri[k], tri[k]);
    if (!q_solve(rs)) {
        ans->parallel = 1;
        return;
    }
    ans->strict = q_classify(rs);
    ans->t = q_nearest(rs, rs->t);
    ans->u = q_nearest(rs, rs->u);
    ans->v = q_nearest(rs, rs->v);
    ans->lower = tmin == -INFINITY ? 1 : q_cmp_d(rs->t, rs->bound, tmin);
    ans->upper = tmax == INFINITY ? -1 : q_cmp_d(rs->t, rs->bound, tmax);
    /* Off the boundary the perturbation changes nothing; on it, solve again. */
    ans->perturbed = ans->strict;
    if (ans->strict == 0) {
        mpq_set_ui(rs->eps, 1, 1);
        for (int k = 0; k < 3; k++) {
            mpq_div_2exp(rs->eps, rs->eps, 300);
            mpq_add(rs->d.c[k], rs->d.c[k], rs->eps);
        }
        int solved = q_solve(rs);
        assert_true(solved);
        ans->perturbed = q_classify(rs);
    }
}

/* What the exact test must answer: 1, 0, or -1 when the rule for an origin on an edge's
 * line decides (the perturbation cannot). */
static int ref_expect(const ref_answer *a)
{
    if (a->parallel || a->lower < 0 || a->upper > 0 || a->perturbed < 0)
        return 0;
    return a->perturbed > 0 ? 1 : -1;
}

/* Exact sign of t_a - t_b for the planes of a and b (both not parallel to the ray). */
static int ref_compare_t(ref_scratch *rs, vec3 o, vec3 d, const vec3 a[3], const vec3 b[3])
{
    qv_set(&rs->o, o);
    qv_set(&rs->d, d);
    for (int k = 0; k < 3; k++)
        qv_set(&rs->tri[k], a[k]);
    int ok_a = q_solve(rs);
    mpq_set(rs->bound, rs->t);
    for (int k = 0; k < 3; k++)
        qv_set(&rs->tri[k], b[k]);
    int ok_b = q_solve(rs);
    assert_true(ok_a && ok_b);
    int c = mpq_cmp(rs->bound, rs->t);
    return (c > 0) - (c < 0);
}

/* Distance in units in the last place of `want`. */
static double ulps_between(double got, double want)
{
    double ulp = nextafter(fabs(want), INFINITY) - fabs(want);
    return fabs(got - want) / ulp;
}

/* ------------------------------------------------------------------ random rays (a), (d) */

typedef struct random_ray_case {
    vec3 tri[3];
    vec3 o, d;
    double tmin, tmax;
} random_ray_case;

/* A random triangle and a ray aimed near it (target barycentrics in [-0.3, 1.3]), all
 * coordinates offset + scale * (uniform in [-1, 1] or [-3, 3]), rounded to double. */
static random_ray_case random_case(rng *r, double offset, double scale)
{
    random_ray_case c;
    vec3 off = vec3_make(offset, offset * 0.5, -offset);
    for (int k = 0; k < 3; k++)
        c.tri[k] = vec3_add(off, vec3_scale(rng_vec(r, -1, 1), scale));
    c.o = vec3_add(off, vec3_scale(rng_vec(r, -3, 3), scale));
    double b1 = rng_range(r, -0.3, 1.3), b2 = rng_range(r, -0.3, 1.3);
    vec3 target = vec3_add(c.tri[0], vec3_add(vec3_scale(vec3_sub(c.tri[1], c.tri[0]), b1),
                                              vec3_scale(vec3_sub(c.tri[2], c.tri[0]), b2)));
    c.d = vec3_scale(vec3_sub(target, c.o), rng_range(r, 0.25, 4));
    int kind = rng_int(r, 0, 9);
    c.tmin = 0.0;
    c.tmax = INFINITY;
    if (kind == 0) {
        c.tmin = rng_range(r, 0, 0.5);
        c.tmax = rng_range(r, 0.1, 0.6);
    } else if (kind == 1) {
        c.tmin = -INFINITY;
        c.tmax = rng_range(r, -0.5, 0.5);
    } else if (kind == 2) {
        c.d = vec3_scale(c.d, -1.0); /* the triangle lies behind the origin */
        c.tmin = rng_range(r, -1, 0);
    }
    if (c.tmin > c.tmax) {
        double s = c.tmin;
        c.tmin = c.tmax;
        c.tmax = s;
    }
    return c;
}

typedef struct agreement {
    int inside, outside, out_of_range, boundary;
    int bounded; /* inside hits with a finite t_upper */
    double max_t_ulps, max_uv_err, max_upper_ulps;
} agreement;

/* Checks one random case against the reference and tallies it. */
static void check_random_case(ref_scratch *rs, const random_ray_case *c, agreement *tally)
{
    ray_tri_hit hit = {NAN, NAN, NAN, NAN};
    int got = ray_tri_exact(c->o, c->d, c->tmin, c->tmax, c->tri, &hit);
    ref_answer ref;
    ref_ray_tri(rs, c->o, c->d, c->tmin, c->tmax, c->tri, &ref);
    int want = ref_expect(&ref);
    if (want >= 0 && got != want) {
        fail_msg("exact test says %d, reference %d: o (%a %a %a) d (%a %a %a) tri (%a %a %a) "
                 "(%a %a %a) (%a %a %a) t in [%a, %a]",
                 got, want, c->o.x, c->o.y, c->o.z, c->d.x, c->d.y, c->d.z, c->tri[0].x,
                 c->tri[0].y, c->tri[0].z, c->tri[1].x, c->tri[1].y, c->tri[1].z, c->tri[2].x,
                 c->tri[2].y, c->tri[2].z, c->tmin, c->tmax);
    }
    if (ref.parallel || ref.strict == 0) {
        tally->boundary++;
        return;
    }
    if (ref.lower < 0 || ref.upper > 0) {
        tally->out_of_range++;
        assert_int_equal(got, 0);
        return;
    }
    if (ref.strict < 0) {
        tally->outside++;
        assert_int_equal(got, 0);
        return;
    }
    tally->inside++;
    assert_int_equal(got, 1);
    assert_true(hit.t >= c->tmin && hit.t <= c->tmax);
    double ulps = ulps_between(hit.t, ref.t);
    if (ulps > tally->max_t_ulps)
        tally->max_t_ulps = ulps;
    /* t_upper, which a closest-hit walk cuts its interval with, is at or above the exact t
     * (rs->t: a strictly inside hit is solved once, unperturbed). */
    if (hit.t_upper != INFINITY) {
        if (q_cmp_d(rs->t, rs->bound, hit.t_upper) > 0)
            fail_msg("t_upper %a below the exact t (about %a)", hit.t_upper, ref.t);
        tally->bounded++;
        double upper_ulps = ulps_between(hit.t_upper, ref.t);
        if (upper_ulps > tally->max_upper_ulps)
            tally->max_upper_ulps = upper_ulps;
    }
    double uv_err = fmax(fabs(hit.u - ref.u), fabs(hit.v - ref.v));
    if (uv_err > tally->max_uv_err)
        tally->max_uv_err = uv_err;
}

/* Few ulps for t, grazing rays included: the exact test falls back to a more accurate
 * evaluation when plain double could lose more. */
#define T_ULPS_ALLOWED 8.0
#define UV_ERR_ALLOWED 1e-9

static void run_random_agreement(uint64_t salt, double offset, double scale, int count)
{
    rng r = rng_for(salt);
    agreement tally = {0};
    int grazing = 0;
    ref_scratch rs;
    ref_scratch_init(&rs);
    for (int i = 0; i < count; i++) {
        random_ray_case c = random_case(&r, offset, scale);
        vec3 n = vec3_cross(vec3_sub(c.tri[1], c.tri[0]), vec3_sub(c.tri[2], c.tri[0]));
        grazing += fabs(vec3_dot(n, c.d)) < 1e-3 * vec3_length(n) * vec3_length(c.d);
        check_random_case(&rs, &c, &tally);
    }
    ref_scratch_clear(&rs);
    printf("  offset %g scale %g: %d inside, %d outside, %d out of range, %d boundary, %d grazing; "
           "max t error %.1f ulps, max u/v error %.2e; t_upper for %d, at most %.3g ulps above\n",
           offset, scale, tally.inside, tally.outside, tally.out_of_range, tally.boundary, grazing,
           tally.max_t_ulps, tally.max_uv_err, tally.bounded, tally.max_upper_ulps);
    assert_true(tally.inside > count / 10);
    assert_true(tally.outside > count / 10);
    assert_true(tally.out_of_range > count / 50);
    assert_true(tally.max_t_ulps <= T_ULPS_ALLOWED);
    assert_true(tally.max_uv_err <= UV_ERR_ALLOWED);
    /* Nearly every hit gets a bound (only near-parallel rays may go without). */
    assert_true(tally.bounded >= tally.inside * 9 / 10);
}

static void test_random_rays_match_rational_reference(void **state)
{
    (void)state;
    run_random_agreement(1, 0.0, 1.0, 20000);
}

static void test_random_rays_with_huge_offsets_and_tiny_sizes(void **state)
{
    (void)state;
    run_random_agreement(2, 1e6, 1.0, 4000);
    run_random_agreement(3, 1e9, 1.0, 4000);
    run_random_agreement(4, 0.0, 1e-9, 4000);
    run_random_agreement(5, 1e6, 1e-3, 4000);
    run_random_agreement(6, 1e9, 1e3, 4000);
}

/* Rays aimed at a rounded point of an edge, or at a vertex, of a triangle with arbitrary
 * double coordinates: the edge functions are then below their rounding errors, so only a
 * correct filter bound plus the exact stage gets them right. Range limits at the nearest
 * double to the exact t (and one ulp either side) do the same for the t range test. */
static void test_near_boundary_rays_match_reference(void **state)
{
    (void)state;
    rng r = rng_for(7);
    ref_scratch rs;
    ref_scratch_init(&rs);
    uint64_t before = predicates_fallback_count();
    int checked = 0, hits = 0, range_checked = 0;
    for (int i = 0; i < 12000; i++) {
        double off = (i % 2) ? 1e6 : 0.0;
        vec3 shift = vec3_make(off, -off, 0.5 * off);
        vec3 tri[3];
        for (int k = 0; k < 3; k++)
            tri[k] = vec3_add(shift, rng_vec(&r, -1, 1));
        vec3 o = vec3_add(shift, rng_vec(&r, -3, 3));
        int k = rng_int(&r, 0, 2);
        vec3 target = tri[k];
        if (rng_int(&r, 0, 3) != 0)
            target = vec3_add(tri[k], vec3_scale(vec3_sub(tri[(k + 1) % 3], tri[k]), rng_unit(&r)));
        vec3 d = vec3_sub(target, o);
        ray_tri_hit hit;
        ref_answer ref;
        int got = ray_tri_exact(o, d, 0, INFINITY, tri, &hit);
        ref_ray_tri(&rs, o, d, 0, INFINITY, tri, &ref);
        int want = ref_expect(&ref);
        if (want < 0)
            continue;
        assert_int_equal(got, want);
        checked++;
        hits += got;
        if (ref.parallel || ref.perturbed <= 0)
            continue;
        double near[3] = {nextafter(ref.t, -INFINITY), ref.t, nextafter(ref.t, INFINITY)};
        for (int j = 0; j < 3; j++) {
            double lims[2][2] = {{-INFINITY, near[j]}, {near[j], INFINITY}};
            for (int l = 0; l < 2; l++) {
                ref_ray_tri(&rs, o, d, lims[l][0], lims[l][1], tri, &ref);
                assert_int_equal(ray_tri_exact(o, d, lims[l][0], lims[l][1], tri, &hit),
                                 ref_expect(&ref));
                range_checked++;
            }
        }
    }
    ref_scratch_clear(&rs);
    uint64_t fallbacks = predicates_fallback_count() - before;
    printf(
        "  %d near-boundary rays (%d hits), %d range limits at the exact t; %llu exact fallbacks\n",
        checked, hits, range_checked, (unsigned long long)fallbacks);
    assert_true(checked > 10000);
    assert_true(hits > 2000);
    assert_true(fallbacks > (uint64_t)checked / 10); /* the exact stage really was exercised */
}

/* ------------------------------------------------------------------ closed meshes (b) */

#define MESH_MAX_VERTS 16
#define MESH_MAX_TRIS 24
#define MESH_MAX_POINTS 160

typedef struct test_mesh {
    const char *name;
    int convex;
    int nv, nt;
    vec3 v[MESH_MAX_VERTS];
    int t[MESH_MAX_TRIS][3];
    int n_interior;
    vec3 interior[12]; /* strictly interior points, on a coarse dyadic grid */
} test_mesh;

static void mesh_tri(const test_mesh *m, int i, vec3 out[3])
{
    for (int k = 0; k < 3; k++)
        out[k] = m->v[m->t[i][k]];
}

/* Sign of det[v1 - v0, v2 - v0, p - v0]: +1 when p is on the side the normal points to.
 * Plain double is exact here: mesh coordinates and test points are small multiples of
 * 1/32, so every product and sum fits in far fewer than 53 bits. */
static int side_of(const vec3 tri[3], vec3 p)
{
    double det = vec3_dot(vec3_sub(p, tri[0]),
                          vec3_cross(vec3_sub(tri[1], tri[0]), vec3_sub(tri[2], tri[0])));
    return (det > 0) - (det < 0);
}

static vec3 mesh_vertex_mean(const test_mesh *m)
{
    vec3 s = {0, 0, 0};
    for (int i = 0; i < m->nv; i++)
        s = vec3_add(s, m->v[i]);
    return vec3_scale(s, 1.0 / m->nv);
}

/* Convex meshes: flip every face whose normal points at the vertex mean, and take interior
 * points between the mean and each vertex. */
static void finish_convex(test_mesh *m)
{
    vec3 c = mesh_vertex_mean(m);
    for (int i = 0; i < m->nt; i++) {
        vec3 tri[3];
        mesh_tri(m, i, tri);
        int s = side_of(tri, c);
        assert_int_not_equal(s, 0);
        if (s > 0) {
            int k = m->t[i][1];
            m->t[i][1] = m->t[i][2];
            m->t[i][2] = k;
        }
    }
    m->convex = 1;
    m->n_interior = 0;
    m->interior[m->n_interior++] = c;
    for (int i = 0; i < m->nv && m->n_interior < 12; i++)
        m->interior[m->n_interior++] = vec3_scale(vec3_add(vec3_scale(c, 3), m->v[i]), 0.25);
}

static test_mesh make_tetrahedron(void)
{
    test_mesh m = {.name = "tetrahedron", .nv = 4, .nt = 4};
    m.v[0] = vec3_make(0, 0, 0);
    m.v[1] = vec3_make(8, 1, 0);
    m.v[2] = vec3_make(2, 7, 1);
    m.v[3] = vec3_make(3, 2, 9);
    int faces[4][3] = {{0, 1, 2}, {0, 1, 3}, {0, 2, 3}, {1, 2, 3}};
    memcpy(m.t, faces, sizeof faces);
    finish_convex(&m);
    return m;
}

/* The cube [0, 4]^3; vertex i has coordinate 4 * bit k of i on axis k. Faces alternate
 * their diagonal so both diagonal directions are exercised. */
static test_mesh make_cube(void)
{
    test_mesh m = {.name = "cube", .nv = 8, .nt = 12};
    for (int i = 0; i < 8; i++)
        m.v[i] = vec3_make(4.0 * (i & 1), 4.0 * ((i >> 1) & 1), 4.0 * ((i >> 2) & 1));
    int n = 0;
    for (int axis = 0; axis < 3; axis++) {
        int b = 1 << ((axis + 1) % 3), c = 1 << ((axis + 2) % 3);
        for (int side = 0; side < 2; side++) {
            int base = side ? 1 << axis : 0;
            int q[4] = {base, base | b, base | b | c, base | c};
            if ((axis + side) % 2 == 0) {
                int tris[2][3] = {{q[0], q[1], q[2]}, {q[0], q[2], q[3]}};
                memcpy(m.t[n], tris, sizeof tris);
            } else {
                int tris[2][3] = {{q[0], q[1], q[3]}, {q[1], q[2], q[3]}};
                memcpy(m.t[n], tris, sizeof tris);
            }
            n += 2;
        }
    }
    finish_convex(&m);
    return m;
}

static test_mesh make_octahedron(void)
{
    test_mesh m = {.name = "octahedron", .nv = 6, .nt = 8};
    for (int axis = 0; axis < 3; axis++) {
        vec3 p = {0, 0, 0};
        if (axis == 0)
            p.x = 4;
        if (axis == 1)
            p.y = 4;
        if (axis == 2)
            p.z = 4;
        m.v[2 * axis] = p;
        m.v[2 * axis + 1] = vec3_scale(p, -1);
    }
    int n = 0;
    for (int sx = 0; sx < 2; sx++)
        for (int sy = 0; sy < 2; sy++)
            for (int sz = 0; sz < 2; sz++) {
                m.t[n][0] = sx;
                m.t[n][1] = 2 + sy;
                m.t[n][2] = 4 + sz;
                n++;
            }
    finish_convex(&m);
    return m;
}

/* An L-shaped prism: the polygon (0,0) (8,0) (8,4) (4,4) (4,8) (0,8) extruded over z in
 * [0, 4], caps split into four triangles, oriented outward by hand. */
static test_mesh make_l_prism(void)
{
    test_mesh m = {.name = "L prism", .nv = 12, .nt = 20, .convex = 0};
    const double poly[6][2] = {{0, 0}, {8, 0}, {8, 4}, {4, 4}, {4, 8}, {0, 8}};
    for (int i = 0; i < 6; i++) {
        m.v[i] = vec3_make(poly[i][0], poly[i][1], 0);
        m.v[6 + i] = vec3_make(poly[i][0], poly[i][1], 4);
    }
    const int cap[4][3] = {{0, 1, 2}, {0, 2, 3}, {0, 3, 5}, {3, 4, 5}};
    int n = 0;
    for (int i = 0; i < 4; i++) {
        /* bottom faces -z: clockwise seen from above; top faces +z: counter-clockwise */
        m.t[n][0] = cap[i][0];
        m.t[n][1] = cap[i][2];
        m.t[n][2] = cap[i][1];
        n++;
        m.t[n][0] = 6 + cap[i][0];
        m.t[n][1] = 6 + cap[i][1];
        m.t[n][2] = 6 + cap[i][2];
        n++;
    }
    for (int i = 0; i < 6; i++) {
        int j = (i + 1) % 6;
        int side[2][3] = {{i, j, 6 + j}, {i, 6 + j, 6 + i}};
        memcpy(m.t[n], side, sizeof side);
        n += 2;
    }
    const double inner[7][3] = {{2, 2, 2}, {6, 2, 1}, {2, 6, 3},      {1, 1, 1},
                                {3, 7, 2}, {7, 3, 3}, {3.5, 3.5, 0.5}};
    m.n_interior = 7;
    for (int i = 0; i < 7; i++)
        m.interior[i] = vec3_make(inner[i][0], inner[i][1], inner[i][2]);
    return m;
}

/* +1 strictly inside, -1 strictly outside, 0 on the surface. */
static int mesh_point_status(const test_mesh *m, vec3 p)
{
    if (m->convex) {
        int worst = -1;
        for (int i = 0; i < m->nt; i++) {
            vec3 tri[3];
            mesh_tri(m, i, tri);
            int s = side_of(tri, p);
            if (s > worst)
                worst = s;
        }
        return -worst;
    }
    /* The L prism, in its own coordinates (dyadic, so these comparisons are exact). */
    int in_open =
        p.z > 0 && p.z < 4 &&
        ((p.x > 0 && p.x < 8 && p.y > 0 && p.y < 4) || (p.x > 0 && p.x < 4 && p.y > 0 && p.y < 8));
    if (in_open)
        return 1;
    int in_closed = p.z >= 0 && p.z <= 4 &&
                    ((p.x >= 0 && p.x <= 8 && p.y >= 0 && p.y <= 4) ||
                     (p.x >= 0 && p.x <= 4 && p.y >= 0 && p.y <= 8));
    return in_closed ? 0 : -1;
}

/* Every directed edge appears once and its reverse once, and the signed volume is
 * positive: closed and consistently oriented outward. */
static void assert_closed_and_outward(const test_mesh *m)
{
    for (int i = 0; i < m->nt; i++)
        for (int k = 0; k < 3; k++) {
            int a = m->t[i][k], b = m->t[i][(k + 1) % 3];
            int same = 0, reverse = 0;
            for (int j = 0; j < m->nt; j++)
                for (int l = 0; l < 3; l++) {
                    int c = m->t[j][l], d = m->t[j][(l + 1) % 3];
                    same += c == a && d == b;
                    reverse += c == b && d == a;
                }
            assert_int_equal(same, 1);
            assert_int_equal(reverse, 1);
        }
    double volume6 = 0; /* small integers: exact */
    for (int i = 0; i < m->nt; i++) {
        vec3 tri[3];
        mesh_tri(m, i, tri);
        volume6 += vec3_dot(tri[0], vec3_cross(tri[1], tri[2]));
    }
    assert_true(volume6 > 0);
}

/* Points of the surface where neighbours meet: vertices, edge midpoints and quarter
 * points, plus one point inside each face. */
typedef struct feature_set {
    int n_vertex, n_edge, n_face;
    vec3 vertex[MESH_MAX_VERTS];
    vec3 edge[MESH_MAX_POINTS];
    vec3 face[MESH_MAX_TRIS];
    int edge_ends[MESH_MAX_POINTS / 2][2];
    int n_edges;
} feature_set;

static void mesh_features(const test_mesh *m, feature_set *f)
{
    memset(f, 0, sizeof *f);
    for (int i = 0; i < m->nv; i++)
        f->vertex[f->n_vertex++] = m->v[i];
    for (int i = 0; i < m->nt; i++) {
        for (int k = 0; k < 3; k++) {
            int a = m->t[i][k], b = m->t[i][(k + 1) % 3];
            if (a > b)
                continue; /* each undirected edge once */
            f->edge_ends[f->n_edges][0] = a;
            f->edge_ends[f->n_edges][1] = b;
            f->n_edges++;
            vec3 va = m->v[a], vb = m->v[b];
            f->edge[f->n_edge++] = vec3_scale(vec3_add(va, vb), 0.5);
            f->edge[f->n_edge++] = vec3_scale(vec3_add(vec3_scale(va, 3), vb), 0.25);
        }
        vec3 tri[3];
        mesh_tri(m, i, tri);
        f->face[f->n_face++] =
            vec3_scale(vec3_add(vec3_add(tri[0], tri[1]), vec3_scale(tri[2], 2)), 0.25);
    }
}

/* An exact affine map p -> scale p + offset (scale a power of two); checked exact. */
typedef struct frame {
    double scale, offset;
} frame;

static double frame_coord(frame fr, double x)
{
    double y = x * fr.scale + fr.offset;
    mpq_t want, got, s;
    mpq_inits(want, got, s, NULL);
    mpq_set_d(want, x);
    mpq_set_d(s, fr.scale);
    mpq_mul(want, want, s);
    mpq_set_d(s, fr.offset);
    mpq_add(want, want, s);
    mpq_set_d(got, y);
    int exact = mpq_equal(want, got);
    mpq_clears(want, got, s, NULL);
    assert_true(exact);
    return y;
}

static vec3 frame_point(frame fr, vec3 p)
{
    return vec3_make(frame_coord(fr, p.x), frame_coord(fr, p.y), frame_coord(fr, p.z));
}

static vec3 frame_direction(frame fr, vec3 d) { return vec3_scale(d, fr.scale); }

typedef struct mesh_ray_stats {
    int rays, checked_triangles;
    int special_rays, seed_double, seed_missed, fast_double, fast_missed;
} mesh_ray_stats;

#define SEED_EPS 1e-9

/* Shoots one ray (given in mesh coordinates) through the mesh mapped by `fr` (`placed`
 * holds its triangles so mapped) and checks every triangle against the reference, and the
 * crossing count against parity (and against `want_count` when that is >= 0). Special rays
 * also tally the seed and fast modes. */
static void check_mesh_ray(ref_scratch *rs, const test_mesh *m, frame fr, const vec3 (*placed)[3],
                           vec3 o_mesh, vec3 d_mesh, int want_count, int special,
                           mesh_ray_stats *st)
{
    if (d_mesh.x == 0 && d_mesh.y == 0 && d_mesh.z == 0)
        return;
    int status = mesh_point_status(m, o_mesh);
    if (status == 0)
        return; /* an origin on the surface has no parity */
    vec3 o = frame_point(fr, o_mesh), d = frame_direction(fr, d_mesh);
    int count = 0, seed_count = 0, fast_count = 0, ref_count = 0, determined = 1;
    for (int i = 0; i < m->nt; i++) {
        const vec3 *tri = placed[i];
        ray_tri_hit hit = {NAN, NAN, NAN, NAN};
        int got = ray_tri_exact(o, d, 0.0, INFINITY, tri, &hit);
        count += got;
        if (got) {
            assert_true(hit.t >= 0.0 && isfinite(hit.t));
            assert_true(hit.u >= 0.0 && hit.v >= 0.0 && hit.u + hit.v <= 1.0 + 1e-12);
        }
        ref_answer ref;
        ref_ray_tri(rs, o, d, 0.0, INFINITY, tri, &ref);
        int want = ref_expect(&ref);
        if (want < 0) {
            determined = 0; /* the origin is on this edge's line: the fixed rule decides */
        } else {
            st->checked_triangles++;
            ref_count += want;
            if (got != want)
                fail_msg("%s (scale %g offset %g) triangle %d: exact %d, reference %d; "
                         "o (%g %g %g) d (%g %g %g)",
                         m->name, fr.scale, fr.offset, i, got, want, o_mesh.x, o_mesh.y, o_mesh.z,
                         d_mesh.x, d_mesh.y, d_mesh.z);
        }
        if (special) {
            ray_tri_hit h2;
            seed_count += ray_tri_seed(o, d, 0.0, INFINITY, tri, SEED_EPS * fr.scale, &h2);
            fast_count += ray_tri_fast(o, d, 0.0, INFINITY, tri, &h2);
        }
    }
    st->rays++;
    if (determined)
        assert_int_equal(count, ref_count);
    if ((count % 2) != (status > 0 ? 1 : 0) || (m->convex && count > 2) ||
        (want_count >= 0 && count != want_count))
        fail_msg(
            "%s (scale %g offset %g): %d crossings (want %d, origin %s); o (%g %g %g) d (%g %g %g)",
            m->name, fr.scale, fr.offset, count, want_count, status > 0 ? "inside" : "outside",
            o_mesh.x, o_mesh.y, o_mesh.z, d_mesh.x, d_mesh.y, d_mesh.z);
    if (special) {
        st->special_rays++;
        st->seed_double += seed_count > count;
        st->seed_missed += seed_count < count;
        st->fast_double += fast_count > count;
        st->fast_missed += fast_count < count;
    }
}

static const vec3 axis_dirs[6] = {{1, 0, 0},  {-1, 0, 0}, {0, 1, 0},
                                  {0, -1, 0}, {0, 0, 1},  {0, 0, -1}};
static const vec3 diagonal_dirs[6] = {{1, 1, 1},  {-1, 1, -1}, {1, -2, 3},
                                      {-3, 1, 2}, {0, 1, 1},   {1, 0, -1}};

/* All ray families for one mesh in one frame. */
static void watertight_mesh(ref_scratch *rs, const test_mesh *m, frame fr, rng *r, int random_rays,
                            int thorough, mesh_ray_stats *st)
{
    feature_set f;
    mesh_features(m, &f);
    int n_points = f.n_vertex + f.n_edge;
    vec3 *points = malloc(sizeof(vec3) * (size_t)n_points);
    assert_non_null(points);
    memcpy(points, f.vertex, sizeof(vec3) * (size_t)f.n_vertex);
    memcpy(points + f.n_vertex, f.edge, sizeof(vec3) * (size_t)f.n_edge);
    vec3 placed[MESH_MAX_TRIS][3];
    for (int i = 0; i < m->nt; i++)
        for (int k = 0; k < 3; k++)
            placed[i][k] = frame_point(fr, m->v[m->t[i][k]]);

    /* Other frames repeat the same families on a sample, to keep the run short. */
    int point_step = thorough ? 1 : 2, n_inner = thorough ? m->n_interior : 3;

    /* Through a vertex or an edge point into the interior: from just outside (o = 2F - C),
     * a convex mesh is crossed exactly twice. From the interior point outward: once. */
    for (int i = 0; i < n_points; i += point_step)
        for (int c = 0; c < n_inner; c++) {
            vec3 feat = points[i], inner = m->interior[c];
            vec3 d = vec3_sub(inner, feat);
            vec3 o = vec3_sub(feat, d);
            check_mesh_ray(rs, m, fr, placed, o, d, m->convex ? 2 : -1, 1, st);
            check_mesh_ray(rs, m, fr, placed, vec3_sub(feat, vec3_scale(d, 4)), vec3_scale(d, 0.5),
                           m->convex ? 2 : -1, 1, st);
            check_mesh_ray(rs, m, fr, placed, inner, vec3_scale(d, -1), m->convex ? 1 : -1, 1, st);
        }
    /* Axis-aligned and diagonal rays through every vertex and edge point, including
     * rays that run along faces and edges. */
    for (int i = 0; i < n_points; i += point_step) {
        for (int a = 0; a < 6; a++)
            check_mesh_ray(rs, m, fr, placed, vec3_sub(points[i], vec3_scale(axis_dirs[a], 32)),
                           axis_dirs[a], -1, 1, st);
        for (int a = 0; a < 6; a++)
            check_mesh_ray(rs, m, fr, placed, vec3_sub(points[i], vec3_scale(diagonal_dirs[a], 16)),
                           diagonal_dirs[a], -1, 1, st);
    }
    /* Origins on an edge's line beyond either end, aimed at interior points and at the
     * other features. */
    for (int e = 0; e < f.n_edges; e++)
        for (int end = 0; end < 2; end++) {
            vec3 a = m->v[f.edge_ends[e][end]], b = m->v[f.edge_ends[e][1 - end]];
            vec3 o = vec3_sub(vec3_scale(b, 2), a); /* beyond b on the line a -> b */
            for (int c = 0; c < n_inner; c++)
                check_mesh_ray(rs, m, fr, placed, o, vec3_sub(m->interior[c], o),
                               m->convex ? 2 : -1, 1, st);
            for (int i = 0; i < n_points; i += 3 * point_step)
                check_mesh_ray(rs, m, fr, placed, o, vec3_sub(points[i], o), -1, 0, st);
            check_mesh_ray(rs, m, fr, placed, o, vec3_sub(a, b), -1, 0,
                           st); /* along the edge itself */
        }
    /* Random origins on a 1/8 grid around the mesh, aimed at features, at face points, at
     * grid points, or along small integer directions (often with zero components). */
    vec3 lo = m->v[0], hi = m->v[0];
    for (int i = 1; i < m->nv; i++) {
        lo = vec3_min(lo, m->v[i]);
        hi = vec3_max(hi, m->v[i]);
    }
    for (int i = 0; i < random_rays; i++) {
        vec3 g = rng_grid_vec(r, 0, 8 * 16, 8);
        vec3 o = vec3_make(lo.x - 4 + g.x * (hi.x - lo.x + 8) / 16,
                           lo.y - 4 + g.y * (hi.y - lo.y + 8) / 16,
                           lo.z - 4 + g.z * (hi.z - lo.z + 8) / 16);
        if (i % 4 == 0)
            o = vec3_add(m->interior[rng_int(r, 0, m->n_interior - 1)],
                         vec3_scale(rng_grid_vec(r, -4, 4, 8), 0.5));
        vec3 d;
        switch (rng_int(r, 0, 3)) {
        case 0: d = vec3_sub(points[rng_int(r, 0, n_points - 1)], o); break;
        case 1: d = vec3_sub(f.face[rng_int(r, 0, f.n_face - 1)], o); break;
        case 2: d = vec3_sub(vec3_add(lo, rng_grid_vec(r, 0, 8 * 8, 8)), o); break;
        default: d = rng_grid_vec(r, -3, 3, 1); break;
        }
        check_mesh_ray(rs, m, fr, placed, o, d, -1, 0, st);
    }
    free(points);
}

static void run_watertight(uint64_t salt, frame fr, int random_rays, int thorough, int print_modes)
{
    test_mesh meshes[4] = {make_tetrahedron(), make_cube(), make_octahedron(), make_l_prism()};
    rng r = rng_for(salt);
    ref_scratch rs;
    ref_scratch_init(&rs);
    for (int i = 0; i < 4; i++) {
        assert_closed_and_outward(&meshes[i]);
        mesh_ray_stats st = {0};
        watertight_mesh(&rs, &meshes[i], fr, &r, random_rays, thorough, &st);
        printf("  %-11s scale %-9g offset %-6g: %d rays, %d triangle answers checked\n",
               meshes[i].name, fr.scale, fr.offset, st.rays, st.checked_triangles);
        if (print_modes)
            printf("    on %d rays through shared edges/vertices: seed mode double-counts %d, "
                   "misses %d; "
                   "fast mode double-counts %d, misses %d\n",
                   st.special_rays, st.seed_double, st.seed_missed, st.fast_double, st.fast_missed);
        assert_true(st.checked_triangles > 1000);
    }
    ref_scratch_clear(&rs);
}

static void test_closed_meshes_are_crossed_with_correct_parity(void **state)
{
    (void)state;
    run_watertight(10, (frame){1.0, 0.0}, 400, 1, 1);
}

static void test_closed_meshes_watertight_at_huge_offsets_and_tiny_scale(void **state)
{
    (void)state;
    run_watertight(11, (frame){1.0, 1e6}, 100, 0, 1);
    run_watertight(12, (frame){1.0, 1e9}, 100, 0, 1);
    run_watertight(13, (frame){0x1p-30, 0.0}, 100, 0, 1);
    run_watertight(14, (frame){0x1p20, 1e9}, 100, 0, 0);
}

/* Two coplanar triangles sharing a diagonal, and a fan of six around one vertex: rays
 * through the shared edge and the shared vertex hit exactly one triangle, whatever the
 * direction's zero components. */
static void test_shared_edge_and_fan_vertex_claimed_once(void **state)
{
    (void)state;
    const vec3 square[2][3] = {{{0, 0, 0}, {4, 0, 0}, {4, 4, 0}},
                               {{0, 0, 0}, {4, 4, 0}, {0, 4, 0}}};
    const vec3 dirs[5] = {{0, 0, -1}, {0, 0, 1}, {1, 1, -1}, {-1, 1, 1}, {0, 3, -1}};
    for (int k = 0; k < 5; k++) {
        vec3 through = {1, 1, 0}; /* on the diagonal */
        vec3 o = vec3_sub(through, vec3_scale(dirs[k], 2));
        int hits = 0;
        for (int i = 0; i < 2; i++)
            hits += ray_tri_exact(o, dirs[k], 0, INFINITY, square[i], NULL);
        assert_int_equal(hits, 1);
    }
    vec3 hub = {0, 0, 0},
         ring[6] = {{4, 0, 0}, {2, 4, 0}, {-2, 4, 0}, {-4, 0, 0}, {-2, -4, 0}, {2, -4, 0}};
    for (int k = 0; k < 5; k++) {
        vec3 o = vec3_sub(hub, vec3_scale(dirs[k], 2));
        int hits = 0;
        for (int i = 0; i < 6; i++) {
            vec3 tri[3] = {hub, ring[i], ring[(i + 1) % 6]};
            hits += ray_tri_exact(o, dirs[k], 0, INFINITY, tri, NULL);
        }
        assert_int_equal(hits, 1);
    }
    /* A ray starting on the middle of a cube edge and heading inside: the t = 0 crossing
     * is claimed by exactly one of the two faces, the way out by exactly one more. */
    test_mesh cube = make_cube();
    feature_set f;
    mesh_features(&cube, &f);
    for (int e = 0; e < f.n_edges; e++) {
        vec3 mid = vec3_scale(vec3_add(cube.v[f.edge_ends[e][0]], cube.v[f.edge_ends[e][1]]), 0.5);
        for (int c = 0; c < cube.n_interior; c++) {
            vec3 d = vec3_sub(cube.interior[c], mid);
            int at_zero = 0, later = 0;
            for (int i = 0; i < cube.nt; i++) {
                vec3 tri[3];
                mesh_tri(&cube, i, tri);
                ray_tri_hit h;
                if (ray_tri_exact(mid, d, 0, INFINITY, tri, &h)) {
                    at_zero += h.t == 0.0;
                    later += h.t > 0.0;
                }
            }
            assert_int_equal(at_zero, 1);
            assert_int_equal(later, 1);
        }
    }
}

/* ------------------------------------------------------------------ boundary cases (c) */

/* The plane z = x/4 + y/2 through (0,0,0), (4,0,1), (0,4,2). */
static const vec3 slope[3] = {{0, 0, 0}, {4, 0, 1}, {0, 4, 2}};

static void test_ray_in_triangle_plane_never_hits(void **state)
{
    (void)state;
    rng r = rng_for(20);
    int cases = 0;
    for (int i = 0; i < 2000; i++) {
        vec3 tri[3];
        for (int k = 0; k < 3; k++)
            tri[k] = rng_grid_vec(&r, -16, 16, 1);
        vec3 e1 = vec3_sub(tri[1], tri[0]), e2 = vec3_sub(tri[2], tri[0]);
        if (vec3_dot(vec3_cross(e1, e2), vec3_cross(e1, e2)) == 0)
            continue;
        /* Origins inside, on the boundary of and outside the triangle, all in its plane. */
        double a = rng_int(&r, -4, 8) / 4.0, b = rng_int(&r, -4, 8) / 4.0;
        vec3 o = vec3_add(tri[0], vec3_add(vec3_scale(e1, a), vec3_scale(e2, b)));
        vec3 d = vec3_add(vec3_scale(e1, rng_int(&r, -3, 3)), vec3_scale(e2, rng_int(&r, -3, 3)));
        ray_tri_hit hit;
        assert_int_equal(ray_tri_exact(o, d, -INFINITY, INFINITY, tri, &hit), 0);
        assert_int_equal(ray_tri_exact(o, d, 0, INFINITY, tri, &hit), 0);
        cases++;
    }
    assert_true(cases > 1500);
    /* Along an edge, and through a vertex, in the plane. */
    assert_int_equal(
        ray_tri_exact(vec3_make(-4, 0, -1), vec3_make(4, 0, 1), -INFINITY, INFINITY, slope, NULL),
        0);
    assert_int_equal(
        ray_tri_exact(vec3_make(1, 1, 0.75), vec3_make(-4, -4, -3), 0, INFINITY, slope, NULL), 0);
}

static void test_zero_direction_components(void **state)
{
    (void)state;
    ray_tri_hit hit;
    /* Straight up the z axis at (1, 1): plane height 0.75. */
    assert_int_equal(
        ray_tri_exact(vec3_make(1, 1, -5), vec3_make(0, 0, 1), 0, INFINITY, slope, &hit), 1);
    assert_true(hit.t == 5.75);
    assert_true(fabs(hit.u - 0.25) < 1e-15 && fabs(hit.v - 0.25) < 1e-15);
    assert_int_equal(
        ray_tri_exact(vec3_make(1, 1, 10), vec3_make(0, 0, -2), 0, INFINITY, slope, &hit), 1);
    assert_true(hit.t == 4.625);
    /* Along x at y = 1, z = 1: meets the plane at x = 2. */
    assert_int_equal(
        ray_tri_exact(vec3_make(-3, 1, 1), vec3_make(1, 0, 0), 0, INFINITY, slope, &hit), 1);
    assert_true(hit.t == 5.0);
    assert_true(fabs(hit.u - 0.5) < 1e-15 && fabs(hit.v - 0.25) < 1e-15);
    /* Along y: the plane at x = 1, z = 1 is y = 1.5, inside the triangle. */
    assert_int_equal(
        ray_tri_exact(vec3_make(1, -2, 1), vec3_make(0, 0.5, 0), 0, INFINITY, slope, &hit), 1);
    assert_true(hit.t == 7.0);
    /* Axis rays that pass beside the triangle. */
    assert_int_equal(
        ray_tri_exact(vec3_make(3, 3, -5), vec3_make(0, 0, 1), 0, INFINITY, slope, &hit), 0);
    assert_int_equal(
        ray_tri_exact(vec3_make(-0.25, 1, -5), vec3_make(0, 0, 1), 0, INFINITY, slope, &hit), 0);
    /* The zero direction never hits, not even from a point of the triangle. */
    assert_int_equal(
        ray_tri_exact(vec3_make(1, 1, 0.75), vec3_make(0, 0, 0), -INFINITY, INFINITY, slope, &hit),
        0);
    assert_int_equal(ray_tri_exact(vec3_make(1, 1, 0.75), vec3_make(-0.0, 0, 0), 0, 0, slope, &hit),
                     0);
}

static void test_ray_starting_on_surface_hits_at_zero_iff_tmin_le_zero(void **state)
{
    (void)state;
    ray_tri_hit hit;
    vec3 on = {1, 1, 0.75};
    vec3 dirs[2] = {{0.5, -0.25, 1}, {-0.5, 0.25, -1}};
    for (int k = 0; k < 2; k++) {
        vec3 d = dirs[k];
        assert_int_equal(ray_tri_exact(on, d, 0.0, INFINITY, slope, &hit), 1);
        assert_true(hit.t == 0.0);
        assert_int_equal(ray_tri_exact(on, d, -0.0, INFINITY, slope, &hit), 1);
        assert_int_equal(ray_tri_exact(on, d, -1.0, INFINITY, slope, &hit), 1);
        assert_int_equal(ray_tri_exact(on, d, -1.0, 0.0, slope, &hit), 1);
        assert_int_equal(ray_tri_exact(on, d, 0x1p-1074, INFINITY, slope, &hit), 0);
        assert_int_equal(ray_tri_exact(on, d, 1e-300, INFINITY, slope, &hit), 0);
        assert_int_equal(ray_tri_exact(on, d, -1.0, -0x1p-1074, slope, &hit), 0);
    }
    /* Starting on vertex 1, both edges through it lie on lines through the origin, so the
     * fixed rule decides: edge 0->1 runs lexicographically upward (+1), edge 1->2 downward
     * (-1), and the signs disagree, so a lone triangle does not claim its vertex. Starting
     * on vertex 0, edges 2->0 (-1) and 0->1 (+1) disagree as well. */
    assert_int_equal(ray_tri_exact(slope[1], vec3_make(0, 0, 1), 0, INFINITY, slope, &hit), 0);
    assert_int_equal(ray_tri_exact(slope[0], vec3_make(0.5, 0.5, 1), 0, INFINITY, slope, &hit), 0);
    /* Starting on the middle of edge 0->1 (+1): claimed with t = 0 when the ray leaves on
     * the side where den > 0 and the other edge functions are positive too. */
    vec3 mid01 = vec3_scale(vec3_add(slope[0], slope[1]), 0.5);
    int up = ray_tri_exact(mid01, vec3_make(0, 0, 1), 0, INFINITY, slope, &hit);
    int down = ray_tri_exact(mid01, vec3_make(0, 0, -1), 0, INFINITY, slope, &hit);
    assert_int_equal(up + down, 1);
    assert_int_equal(ray_tri_exact(mid01, vec3_make(0, 0, up ? 1 : -1), 0, INFINITY, slope, &hit),
                     1);
    assert_true(hit.t == 0.0);
}

static void test_range_is_closed_and_exact(void **state)
{
    (void)state;
    ray_tri_hit hit;
    vec3 o = {1, 1, -5}, d = {0, 0, 1}; /* t = 5.75 exactly */
    double t = 5.75;
    assert_int_equal(ray_tri_exact(o, d, 0, t, slope, &hit), 1);
    assert_true(hit.t == t);
    assert_int_equal(ray_tri_exact(o, d, 0, nextafter(t, 0), slope, &hit), 0);
    assert_int_equal(ray_tri_exact(o, d, t, INFINITY, slope, &hit), 1);
    assert_int_equal(ray_tri_exact(o, d, nextafter(t, INFINITY), INFINITY, slope, &hit), 0);
    assert_int_equal(ray_tri_exact(o, d, t, t, slope, &hit), 1);
    assert_true(hit.t == t);
    assert_int_equal(ray_tri_exact(o, d, t, nextafter(t, 0), slope, &hit), 0); /* empty */
    assert_int_equal(ray_tri_exact(o, d, NAN, INFINITY, slope, &hit), 0);
    assert_int_equal(ray_tri_exact(o, d, 0, NAN, slope, &hit), 0);
    assert_int_equal(ray_tri_exact(o, d, INFINITY, INFINITY, slope, &hit), 0);
    assert_int_equal(ray_tri_exact(o, d, -INFINITY, -INFINITY, slope, &hit), 0);
    /* Huge finite limits act as limits, not as overflow. */
    assert_int_equal(ray_tri_exact(o, d, -DBL_MAX, DBL_MAX, slope, &hit), 1);
    assert_int_equal(ray_tri_exact(o, d, DBL_MAX, INFINITY, slope, &hit), 0);
    assert_int_equal(ray_tri_exact(o, d, -DBL_MAX, -0x1p1000, slope, &hit), 0);

    /* t = 1/3, not a double: the nearest doubles below and above bracket it exactly. */
    vec3 o3 = {1, 1, -0.25}, d3 = {0, 0, 3};
    double below = 1.0 / 3.0, above = nextafter(below, 1);
    mpq_t third, q;
    mpq_inits(third, q, NULL);
    mpq_set_ui(third, 1, 3);
    mpq_set_d(q, below);
    assert_true(mpq_cmp(q, third) < 0);
    mpq_set_d(q, above);
    assert_true(mpq_cmp(q, third) > 0);
    mpq_clears(third, q, NULL);
    uint64_t before = predicates_fallback_count();
    assert_int_equal(ray_tri_exact(o3, d3, 0, below, slope, &hit), 0);
    assert_int_equal(ray_tri_exact(o3, d3, 0, above, slope, &hit), 1);
    assert_true(hit.t == below || hit.t == above);
    assert_int_equal(ray_tri_exact(o3, d3, below, INFINITY, slope, &hit), 1);
    assert_int_equal(ray_tri_exact(o3, d3, above, INFINITY, slope, &hit), 0);
    assert_int_equal(ray_tri_exact(o3, d3, below, above, slope, &hit), 1);
    /* Those ties are beyond the filter: the exact stage ran and was counted. */
    assert_true(predicates_fallback_count() > before);
}

static void test_range_behind_origin_and_infinite(void **state)
{
    (void)state;
    ray_tri_hit hit;
    vec3 o = {1, 1, 5}, d = {0, 0, 1}; /* the plane is behind: t = -4.25 */
    assert_int_equal(ray_tri_exact(o, d, 0, INFINITY, slope, &hit), 0);
    assert_int_equal(ray_tri_exact(o, d, -INFINITY, 0, slope, &hit), 1);
    assert_true(hit.t == -4.25);
    assert_int_equal(ray_tri_exact(o, d, -INFINITY, INFINITY, slope, &hit), 1);
    assert_int_equal(ray_tri_exact(o, d, -4.25, -4.25, slope, &hit), 1);
    assert_int_equal(ray_tri_exact(o, d, nextafter(-4.25, 0), 0, slope, &hit), 0);
    assert_int_equal(ray_tri_exact(o, d, -INFINITY, nextafter(-4.25, -5), slope, &hit), 0);
}

static void test_degenerate_triangles_never_hit(void **state)
{
    (void)state;
    const vec3 degenerate[4][3] = {
        {{0, 0, 0}, {2, 2, 2}, {4, 4, 4}}, /* collinear */
        {{0, 0, 0}, {0, 0, 0}, {4, 0, 0}}, /* repeated vertex */
        {{1, 1, 1}, {1, 1, 1}, {1, 1, 1}}, /* a point */
        {{0, 0, 0}, {4, 4, 4}, {2, 2, 2}}, /* collinear, other order */
    };
    const vec3 dirs[4] = {{1, 0, 0}, {0, 1, -1}, {1, 1, 1}, {-1, 2, 0}};
    for (int i = 0; i < 4; i++)
        for (int k = 0; k < 4; k++)
            for (int p = 0; p < 3; p++) {
                /* Rays through every vertex and the middle of the degenerate triangle. */
                vec3 through = p < 2
                                   ? degenerate[i][p]
                                   : vec3_scale(vec3_add(degenerate[i][0], degenerate[i][2]), 0.5);
                vec3 o = vec3_sub(through, dirs[k]);
                assert_int_equal(
                    ray_tri_exact(o, dirs[k], -INFINITY, INFINITY, degenerate[i], NULL), 0);
                assert_int_equal(
                    ray_tri_exact(through, dirs[k], -INFINITY, INFINITY, degenerate[i], NULL), 0);
            }
}

static void test_boundary_hits_report_valid_barycentrics(void **state)
{
    (void)state;
    ray_tri_hit hit;
    /* Through each vertex and edge middle of a lone triangle. Whichever way the tie rule
     * decides, a reported hit carries t = 3 and barycentrics in range; at a vertex they
     * are exactly that vertex's. */
    vec3 targets[6] = {slope[0],
                       slope[1],
                       slope[2],
                       vec3_scale(vec3_add(slope[0], slope[1]), 0.5),
                       vec3_scale(vec3_add(slope[1], slope[2]), 0.5),
                       vec3_scale(vec3_add(slope[2], slope[0]), 0.5)};
    vec3 dirs[4] = {{0, 0, -1}, {0, 0, 1}, {1, 1, -1}, {-1, -1, 1}};
    int hits = 0;
    for (int i = 0; i < 6; i++)
        for (int k = 0; k < 4; k++) {
            vec3 o = vec3_sub(targets[i], vec3_scale(dirs[k], 3));
            if (ray_tri_exact(o, dirs[k], 0, INFINITY, slope, &hit)) {
                hits++;
                assert_true(hit.t == 3.0);
                assert_true(isfinite(hit.u) && isfinite(hit.v));
                assert_true(hit.u >= 0 && hit.v >= 0 && hit.u + hit.v <= 1.0 + 1e-15);
                if (i == 0)
                    assert_true(hit.u == 0.0 && hit.v == 0.0);
                if (i == 1)
                    assert_true(hit.u == 1.0 && hit.v == 0.0);
                if (i == 2)
                    assert_true(hit.u == 0.0 && hit.v == 1.0);
            }
        }
    /* Straight down, the perturbation shifts the hit point towards +x, then +y: into the
     * triangle at vertex 0 and at the middles of edges 0-1 and 2-0, out of it elsewhere. */
    assert_int_equal(ray_tri_exact(vec3_sub(slope[0], vec3_make(0, 0, -3)), vec3_make(0, 0, -1), 0,
                                   INFINITY, slope, &hit),
                     1);
    assert_int_equal(ray_tri_exact(vec3_sub(slope[1], vec3_make(0, 0, -3)), vec3_make(0, 0, -1), 0,
                                   INFINITY, slope, &hit),
                     0);
    assert_int_equal(ray_tri_exact(vec3_sub(targets[3], vec3_make(0, 0, -3)), vec3_make(0, 0, -1),
                                   0, INFINITY, slope, &hit),
                     1);
    assert_int_equal(ray_tri_exact(vec3_sub(targets[4], vec3_make(0, 0, -3)), vec3_make(0, 0, -1),
                                   0, INFINITY, slope, &hit),
                     0);
    assert_int_equal(ray_tri_exact(vec3_sub(targets[5], vec3_make(0, 0, -3)), vec3_make(0, 0, -1),
                                   0, INFINITY, slope, &hit),
                     1);
    assert_true(hits > 0);
}

/* ------------------------------------------------------------------ ordering (e) */

static int compare_checked(vec3 o, vec3 d, const vec3 a[3], const vec3 b[3])
{
    int c = ray_tri_compare_t(o, d, a, b);
    assert_int_equal(ray_tri_compare_t(o, d, b, a), -c);
    return c;
}

static int plane_not_parallel(ref_scratch *rs, vec3 d, const vec3 tri[3])
{
    ref_answer ref;
    ref_ray_tri(rs, vec3_make(0, 0, 0), d, 0, INFINITY, tri, &ref);
    return !ref.parallel;
}

static void test_compare_t_random_against_reference(void **state)
{
    (void)state;
    ref_scratch rs;
    ref_scratch_init(&rs);
    rng r = rng_for(30);
    const double offsets[3] = {0.0, 1e6, 1e9};
    int counts[3] = {0, 0, 0};
    uint64_t before = predicates_fallback_count();
    int total = 0;
    for (int i = 0; i < 9000; i++) {
        double off = offsets[i % 3];
        vec3 shift = vec3_make(off, -off, off * 0.5);
        vec3 a[3], b[3];
        for (int k = 0; k < 3; k++) {
            a[k] = vec3_add(shift, rng_vec(&r, -1, 1));
            b[k] = vec3_add(shift, rng_vec(&r, -1, 1));
        }
        vec3 o = vec3_add(shift, rng_vec(&r, -3, 3)), d = rng_vec(&r, -1, 1);
        if (!plane_not_parallel(&rs, d, a) || !plane_not_parallel(&rs, d, b))
            continue;
        int want = ref_compare_t(&rs, o, d, a, b);
        assert_int_equal(compare_checked(o, d, a, b), want);
        assert_int_equal(compare_checked(o, d, a, a), 0);
        counts[want + 1]++;
        total++;
    }
    ref_scratch_clear(&rs);
    uint64_t fallbacks = predicates_fallback_count() - before;
    printf("  %d random pairs: %d before, %d after; %llu exact fallbacks\n", total, counts[0],
           counts[2], (unsigned long long)fallbacks);
    assert_true(counts[0] > 1000 && counts[2] > 1000);
}

/* Ties: b in the same plane as a, and two planes that cross where the ray meets them;
 * then one-ulp nudges of those ties, which only exact arithmetic can order. */
static void test_compare_t_ties_and_near_ties(void **state)
{
    (void)state;
    ref_scratch rs;
    ref_scratch_init(&rs);
    rng r = rng_for(31);
    int ties = 0, nudged = 0;
    uint64_t before = predicates_fallback_count();
    for (int i = 0; i < 3000; i++) {
        double off = (i % 3 == 0) ? 0.0 : (i % 3 == 1) ? 1e6 : 1e9;
        vec3 shift = vec3_make(off, off, -off);
        vec3 o = vec3_add(shift, rng_grid_vec(&r, -16, 16, 4)), d = rng_grid_vec(&r, -8, 8, 2);
        vec3 a[3], b[3];
        if (i % 2 == 0) {
            /* Same plane: b's vertices are dyadic combinations of a's. */
            for (int k = 0; k < 3; k++)
                a[k] = vec3_add(shift, rng_grid_vec(&r, -16, 16, 1));
            vec3 e1 = vec3_sub(a[1], a[0]), e2 = vec3_sub(a[2], a[0]);
            for (int k = 0; k < 3; k++)
                b[k] = vec3_add(a[0], vec3_add(vec3_scale(e1, rng_int(&r, -8, 8) / 4.0),
                                               vec3_scale(e2, rng_int(&r, -8, 8) / 4.0)));
        } else {
            /* Planes through the same point of the ray, p = o + t d with dyadic t. */
            vec3 p = vec3_add(o, vec3_scale(d, rng_int(&r, -8, 8) / 2.0));
            vec3 ra = rng_grid_vec(&r, -8, 8, 1), sa = rng_grid_vec(&r, -8, 8, 1);
            vec3 rb = rng_grid_vec(&r, -8, 8, 1), sb = rng_grid_vec(&r, -8, 8, 1);
            a[0] = vec3_add(p, ra);
            a[1] = vec3_add(p, sa);
            a[2] = vec3_sub(vec3_sub(p, ra), sa); /* p is a's centroid */
            b[0] = vec3_sub(p, rb);
            b[1] = vec3_add(p, vec3_scale(rb, 2));
            b[2] = vec3_add(p, sb); /* p = (2 b0 + b1) / 3 lies on b's plane */
        }
        if (!plane_not_parallel(&rs, d, a) || !plane_not_parallel(&rs, d, b))
            continue;
        int want = ref_compare_t(&rs, o, d, a, b);
        assert_int_equal(want, 0);
        assert_int_equal(compare_checked(o, d, a, b), 0);
        ties++;
        /* Nudge one coordinate of b by one ulp: the order becomes whatever the exact
         * reference says (usually +-1). */
        vec3 bn[3] = {b[0], b[1], b[2]};
        int which = rng_int(&r, 0, 2);
        double up = rng_int(&r, 0, 1) ? INFINITY : -INFINITY;
        /* A zero coordinate would become a subnormal, outside the range where the exact
         * stage is exact (see ray_tri.h); nudge a nonzero one. */
        if (bn[which].x != 0)
            bn[which].x = nextafter(bn[which].x, up);
        else if (bn[which].y != 0)
            bn[which].y = nextafter(bn[which].y, up);
        else
            bn[which].z = nextafter(bn[which].z, up);
        if (!plane_not_parallel(&rs, d, bn))
            continue;
        want = ref_compare_t(&rs, o, d, a, bn);
        assert_int_equal(compare_checked(o, d, a, bn), want);
        nudged += want != 0;
    }
    ref_scratch_clear(&rs);
    uint64_t fallbacks = predicates_fallback_count() - before;
    printf("  %d exact ties, %d one-ulp nudges ordered; %llu exact fallbacks\n", ties, nudged,
           (unsigned long long)fallbacks);
    assert_true(ties > 1000);
    assert_true(nudged > 500);
    assert_true(fallbacks >= (uint64_t)ties);
}

/* The ordering agrees with the reported t whenever the reported t values differ by more
 * than their rounding, and with the reference always: a closest-hit sweep over a stack of
 * parallel triangles finds the nearest one. */
static void test_compare_t_orders_a_stack_of_hits(void **state)
{
    (void)state;
    vec3 o = {0.25, 0.25, -1}, d = {0, 0, 1};
    vec3 layers[5][3];
    const double heights[5] = {3, 0.5, 2, 0.5 + 0x1p-50, 1};
    for (int i = 0; i < 5; i++) {
        layers[i][0] = vec3_make(0, 0, heights[i]);
        layers[i][1] = vec3_make(1, 0, heights[i]);
        layers[i][2] = vec3_make(0, 1, heights[i]);
    }
    int best = 0;
    for (int i = 1; i < 5; i++)
        if (ray_tri_compare_t(o, d, layers[i], layers[best]) < 0)
            best = i;
    assert_int_equal(best, 1);
    assert_int_equal(ray_tri_compare_t(o, d, layers[1], layers[3]), -1);
    /* A tilted triangle through the same hit point ties with the flat one. */
    vec3 tilted[3] = {{0.25, 0.25, 0.5}, {1, 0, 1.5}, {0, 1, -0.25}};
    assert_int_equal(ray_tri_compare_t(o, d, tilted, layers[1]), 0);
    /* Seen from the other side the order flips. */
    vec3 o2 = {0.25, 0.25, 5}, d2 = {0, 0, -2};
    assert_int_equal(ray_tri_compare_t(o2, d2, layers[1], layers[3]), 1);
}

/* ------------------------------------------------------------------ seed and fast modes */

/* On rays that clearly hit (all barycentrics >= 1e-3, not grazing, t well inside the
 * range) or clearly miss (a barycentric <= -1e-3), the seed and fast tests agree with the
 * exact one. */
/* Coordinates near 1e308 with features of 2^1000: every product of coordinate differences
 * overflows a double, so the range check and the ordering of hits take the exact stage,
 * which must still answer exactly. Before the exact stage scaled its inputs, a triangle
 * behind the origin was reported hit at t = 0. */
static void test_rays_near_the_top_of_the_double_range(void **state)
{
    (void)state;
    const double f = 0x1p1000;
    vec3 o = {0x1.2p1023, -0x1.2p1023, 0x1.2p1023}, d = {1, 0, 0};
    vec3 ahead[3], behind[3], further[3];
    double xs[3] = {o.x + f, o.x - f, o.x + 2 * f};
    vec3 *tris[3] = {ahead, behind, further};
    for (int i = 0; i < 3; i++) {
        tris[i][0] = (vec3){xs[i], o.y - f, o.z - f};
        tris[i][1] = (vec3){xs[i], o.y + f, o.z - f};
        tris[i][2] = (vec3){xs[i], o.y, o.z + f};
    }
    ray_tri_hit hit;
    assert_int_equal(ray_tri_exact(o, d, 0, INFINITY, ahead, &hit), 1);
    assert_true(hit.t == f);
    assert_true(hit.u >= 0 && hit.v >= 0 && hit.u + hit.v <= 1);
    assert_int_equal(ray_tri_exact(o, d, 0, INFINITY, further, &hit), 1);
    assert_true(hit.t == 2 * f);
    assert_int_equal(ray_tri_exact(o, d, 0, INFINITY, behind, NULL), 0);
    assert_int_equal(ray_tri_exact(o, d, -INFINITY, INFINITY, behind, &hit), 1);
    assert_true(hit.t == -f);
    /* The range ends are exact too: t = f is inside [f, f] and outside (f, 2f]. */
    assert_int_equal(ray_tri_exact(o, d, f, f, ahead, NULL), 1);
    assert_int_equal(ray_tri_exact(o, d, nextafter(f, INFINITY), 2 * f, ahead, NULL), 0);
    assert_int_equal(ray_tri_compare_t(o, d, ahead, further), -1);
    assert_int_equal(ray_tri_compare_t(o, d, further, ahead), 1);
    assert_int_equal(ray_tri_compare_t(o, d, ahead, ahead), 0);
}

/* A coordinate at the ends of the double range: anywhere in [-DBL_MAX, DBL_MAX] (nearly
 * always within a few binades of the top), a top-binade value, DBL_MAX itself, 2^1000 and
 * up, or zero. Any mix of these spans at most 24 binary exponents, well inside the exact
 * stages' span, and differences of opposite ends overflow a double. */
static double range_end_coordinate(rng *r)
{
    double sign = rng_u64(r) & 1 ? -1.0 : 1.0;
    switch (rng_int(r, 0, 5)) {
    case 0: return DBL_MAX * (2.0 * rng_unit(r) - 1.0);
    case 1: return sign * DBL_MAX * (0.5 + 0.5 * rng_unit(r));
    case 2: return sign * DBL_MAX;
    case 3: return sign * ldexp(1.0 + rng_unit(r), rng_int(r, 1000, 1022));
    case 4: return 0.0;
    default: return DBL_MAX * (2.0 * rng_unit(r) - 1.0);
    }
}

static vec3 range_end_point(rng *r)
{
    return vec3_make(range_end_coordinate(r), range_end_coordinate(r), range_end_coordinate(r));
}

/* The largest minus the smallest binary exponent of the nonzero components. */
static int exponent_span(const vec3 *p, int n)
{
    int lo = INT_MAX, hi = INT_MIN;
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            double x = vec3_get(p[i], k);
            if (x != 0.0) {
                lo = ilogb(x) < lo ? ilogb(x) : lo;
                hi = ilogb(x) > hi ? ilogb(x) : hi;
            }
        }
    return hi - lo;
}

/* Random rays and triangles at the ends of the double range (triangles spanning
 * -DBL_MAX..DBL_MAX, rays from one end to the other, shared coordinates and exact zeros
 * that put rays through edges and vertices), against the rational reference. Every edge
 * function, num and den overflows in double here, so every answer comes from the exact
 * stage's scaling. Hits are ordered against a second triangle the same way. */
static void test_random_rays_at_the_ends_of_the_double_range_match_reference(void **state)
{
    (void)state;
    ref_scratch rs;
    ref_scratch_init(&rs);
    rng r = rng_for(50);
    int hits = 0, misses = 0, boundary = 0, ordered = 0;
    for (int i = 0; i < 6000; i++) {
        vec3 tri[3] = {range_end_point(&r), range_end_point(&r), range_end_point(&r)};
        vec3 o = range_end_point(&r);
        /* Aim at a point of the triangle's plane (barycentrics in [-0.3, 1.3]) or a vertex,
         * a quarter of the way, so that nothing overflows. */
        double b1 = rng_range(&r, -0.3, 1.3), b2 = rng_range(&r, -0.3, 1.3), b0 = 1.0 - b1 - b2;
        vec3 target = vec3_add(vec3_scale(tri[0], 0.25 * b0),
                               vec3_add(vec3_scale(tri[1], 0.25 * b1), vec3_scale(tri[2], 0.25 * b2)));
        if (i % 4 == 0)
            target = vec3_scale(tri[i % 3], 0.25);
        vec3 d = vec3_sub(target, vec3_scale(o, 0.25));
        if (!vec3_is_finite(d) || (d.x == 0.0 && d.y == 0.0 && d.z == 0.0))
            continue;
        double tmin = i % 3 == 0 ? -INFINITY : 0.0, tmax = i % 5 == 0 ? rng_range(&r, 1.0, 8.0) : INFINITY;
        vec3 all[5] = {tri[0], tri[1], tri[2], o, d};
        assert_true(exponent_span(all, 5) <= 633);
        ray_tri_hit hit = {NAN, NAN, NAN, NAN};
        int got = ray_tri_exact(o, d, tmin, tmax, tri, &hit);
        ref_answer ref;
        ref_ray_tri(&rs, o, d, tmin, tmax, tri, &ref);
        int want = ref_expect(&ref);
        if (want >= 0 && got != want)
            fail_msg("case %d: exact test says %d, reference %d: o (%a %a %a) d (%a %a %a) tri (%a %a %a) "
                     "(%a %a %a) (%a %a %a) t in [%a, %a]",
                     i, got, want, o.x, o.y, o.z, d.x, d.y, d.z, tri[0].x, tri[0].y, tri[0].z, tri[1].x,
                     tri[1].y, tri[1].z, tri[2].x, tri[2].y, tri[2].z, tmin, tmax);
        boundary += !ref.parallel && ref.strict == 0;
        if (got) {
            hits++;
            assert_true(hit.t >= tmin && hit.t <= tmax);
            /* t within a few ulps of the exact value, unless that is beyond DBL_MAX. */
            if (fabs(ref.t) < DBL_MAX)
                assert_true(ulps_between(hit.t, ref.t) <= T_ULPS_ALLOWED);
            assert_true(hit.u >= 0 && hit.v >= 0 && hit.u + hit.v <= 1 + 1e-12);
        } else {
            misses++;
        }
        /* Ordering two planes takes degree-6 products: its span of 283 holds here too. */
        vec3 other[3] = {range_end_point(&r), range_end_point(&r), range_end_point(&r)};
        if (!ref.parallel && plane_not_parallel(&rs, d, other)) {
            assert_int_equal(compare_checked(o, d, tri, other), ref_compare_t(&rs, o, d, tri, other));
            ordered++;
        }
    }
    ref_scratch_clear(&rs);
    printf("  ends of the range: %d hits, %d misses, %d on a boundary, %d pairs ordered\n", hits, misses, boundary,
           ordered);
    assert_true(hits > 500 && misses > 500 && boundary > 50 && ordered > 3000);
}

/* Hand-made rays across the whole double range. */
static void test_rays_across_the_whole_double_range(void **state)
{
    (void)state;
    const double M = DBL_MAX;
    /* A triangle spanning the range in the plane z = 0, containing the origin. */
    vec3 span[3] = {{-M, -M, 0}, {M, -M, 0}, {0, M, 0}};
    ray_tri_hit hit;
    /* From the top of the range straight down: t = DBL_MAX exactly, closed range. */
    vec3 top = {0, 0, M}, down = {0, 0, -1};
    assert_int_equal(ray_tri_exact(top, down, 0, INFINITY, span, &hit), 1);
    assert_true(hit.t == M);
    assert_int_equal(ray_tri_exact(top, down, 0, M, span, NULL), 1);
    assert_int_equal(ray_tri_exact(top, down, 0, nextafter(M, 0), span, NULL), 0);
    assert_int_equal(ray_tri_exact(top, (vec3){0, 0, 1}, 0, INFINITY, span, NULL), 0);
    /* From one corner of the range to the other: through (0, 0, 0) at t = 1. */
    vec3 corner = {-M, -M, -M}, across = {M, M, M};
    assert_int_equal(ray_tri_exact(corner, across, 0, INFINITY, span, &hit), 1);
    assert_true(hit.t == 1.0);
    assert_int_equal(ray_tri_exact(corner, across, nextafter(1.0, 2.0), INFINITY, span, NULL), 0);
    assert_int_equal(ray_tri_exact(corner, across, 0, nextafter(1.0, 0.0), span, NULL), 0);
    /* The same ray against the same triangle shifted one unit of 2^971 (an ulp of
     * DBL_MAX) up or down: the hit moves off t = 1 by exactly that much of the way. */
    vec3 up[3] = {{-M, -M, 0x1p971}, {M, -M, 0x1p971}, {0, M, 0x1p971}};
    assert_int_equal(ray_tri_compare_t(corner, across, span, up), -1);
    assert_int_equal(ray_tri_compare_t(corner, across, up, span), 1);
    /* Through the middle of the edge from (M, -M) to (0, M), shared with the neighbour on
     * its other side (wound the same way): exactly one of the two claims the crossing. */
    vec3 neighbour[3] = {{0, M, 0}, {M, -M, 0}, {M, M, 0}};
    vec3 above = {0.5 * M, 0, M};
    int first = ray_tri_exact(above, down, 0, INFINITY, span, NULL);
    int second = ray_tri_exact(above, down, 0, INFINITY, neighbour, NULL);
    assert_int_equal(first + second, 1);
    first = ray_tri_exact(above, (vec3){0, 0, -0x1p400}, 0, INFINITY, span, NULL);
    second = ray_tri_exact(above, (vec3){0, 0, -0x1p400}, 0, INFINITY, neighbour, NULL);
    assert_int_equal(first + second, 1);
    /* A ray in the triangle's plane, from one end of the range to the other, never hits. */
    assert_int_equal(ray_tri_exact((vec3){-M, 0, 0}, (vec3){M, 0, 0}, -INFINITY, INFINITY, span, NULL), 0);
    /* Parallel to the plane just above it: no hit either. */
    assert_int_equal(ray_tri_exact((vec3){-M, 0, 0x1p-1074}, (vec3){1, 0, 0}, -INFINITY, INFINITY, span, NULL), 0);
}

static void test_seed_and_fast_agree_on_clear_cases(void **state)
{
    (void)state;
    ref_scratch rs;
    ref_scratch_init(&rs);
    rng r = rng_for(40);
    int clear_hits = 0, clear_misses = 0;
    for (int i = 0; i < 20000; i++) {
        random_ray_case c = random_case(&r, 0.0, 1.0);
        c.tmin = 0;
        c.tmax = INFINITY;
        vec3 n = vec3_cross(vec3_sub(c.tri[1], c.tri[0]), vec3_sub(c.tri[2], c.tri[0]));
        double area2 = vec3_length(n);
        double cosine = fabs(vec3_dot(n, c.d)) / (area2 * vec3_length(c.d));
        if (cosine < 1e-2 || area2 < 1e-2)
            continue;
        ref_answer ref;
        ref_ray_tri(&rs, c.o, c.d, c.tmin, c.tmax, c.tri, &ref);
        if (ref.parallel)
            continue;
        double w = 1.0 - ref.u - ref.v;
        double min_bary = fmin(w, fmin(ref.u, ref.v));
        int expected;
        if (min_bary >= 1e-3 && ref.t > 1e-3)
            expected = 1;
        else if (min_bary <= -1e-3 || ref.t < -1e-3)
            expected = 0;
        else
            continue;
        ray_tri_hit hs, hf, he;
        assert_int_equal(ray_tri_exact(c.o, c.d, c.tmin, c.tmax, c.tri, &he), expected);
        assert_int_equal(ray_tri_seed(c.o, c.d, c.tmin, c.tmax, c.tri, SEED_EPS, &hs), expected);
        assert_int_equal(ray_tri_fast(c.o, c.d, c.tmin, c.tmax, c.tri, &hf), expected);
        if (expected) {
            assert_true(fabs(hs.t - ref.t) <= 1e-5 * fabs(ref.t));
            assert_true(fabs(hf.t - ref.t) <= 1e-9 * fabs(ref.t));
            assert_true(fabs(hs.u - ref.u) < 1e-4 && fabs(hs.v - ref.v) < 1e-4);
            assert_true(fabs(hf.u - ref.u) < 1e-9 && fabs(hf.v - ref.v) < 1e-9);
            clear_hits++;
        } else {
            clear_misses++;
        }
    }
    ref_scratch_clear(&rs);
    printf("  %d clear hits, %d clear misses agree in all three modes\n", clear_hits, clear_misses);
    assert_true(clear_hits > 2000 && clear_misses > 2000);
}

static void test_seed_and_fast_reject_parallel_and_degenerate(void **state)
{
    (void)state;
    ray_tri_hit h;
    const vec3 line[3] = {{0, 0, 0}, {2, 2, 2}, {4, 4, 4}};
    assert_int_equal(
        ray_tri_seed(vec3_make(2, 2, 0), vec3_make(0, 0, 1), 0, INFINITY, line, SEED_EPS, &h), 0);
    assert_int_equal(ray_tri_fast(vec3_make(2, 2, 0), vec3_make(0, 0, 1), 0, INFINITY, line, &h),
                     0);
    assert_int_equal(
        ray_tri_fast(vec3_make(-4, 1, 0.5), vec3_make(4, 0, 1), 0, INFINITY, slope, &h), 0);
    assert_int_equal(
        ray_tri_fast(vec3_make(1, 1, 0.75), vec3_make(0, 0, 0), 0, INFINITY, slope, &h), 0);
    assert_int_equal(
        ray_tri_seed(vec3_make(1, 1, 5), vec3_make(0, 0, 0), 0, INFINITY, slope, SEED_EPS, &h), 0);
    /* A plain hit in both modes, with its t. */
    assert_int_equal(
        ray_tri_seed(vec3_make(1, 1, -5), vec3_make(0, 0, 1), 0, INFINITY, slope, SEED_EPS, &h), 1);
    assert_true(fabs(h.t - 5.75) < 1e-6);
    assert_int_equal(ray_tri_fast(vec3_make(1, 1, -5), vec3_make(0, 0, 1), 0, INFINITY, slope, &h),
                     1);
    assert_true(fabs(h.t - 5.75) < 1e-12);
    assert_true(fabs(h.u - 0.25) < 1e-12 && fabs(h.v - 0.25) < 1e-12);
}

/* ------------------------------------------------------------------ filter efficiency */

/* The float filter settles nearly every generic case (the fast path the octree relies on);
 * prints the time per call for the record. */
static void test_filter_decides_generic_cases(void **state)
{
    (void)state;
    rng r = rng_for(50);
    enum { N = 4096 };
    random_ray_case *cases = malloc(sizeof(random_ray_case) * N);
    assert_non_null(cases);
    for (int i = 0; i < N; i++) {
        cases[i] = random_case(&r, 0.0, 1.0);
        cases[i].tmin = 0;
        cases[i].tmax = INFINITY;
    }
    uint64_t before = predicates_fallback_count();
    int hits = 0;
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    const int rounds = 50;
    for (int round = 0; round < rounds; round++)
        for (int i = 0; i < N; i++) {
            ray_tri_hit h;
            hits += ray_tri_exact(cases[i].o, cases[i].d, cases[i].tmin, cases[i].tmax,
                                  cases[i].tri, &h);
        }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    uint64_t fallbacks = predicates_fallback_count() - before;
    double ns = ((double)(t1.tv_sec - t0.tv_sec) * 1e9 + (double)(t1.tv_nsec - t0.tv_nsec)) /
                ((double)rounds * N);
    printf("  exact test: %.1f ns per call (%d%% hits), %llu exact fallbacks in %d calls\n", ns,
           100 * hits / (rounds * N), (unsigned long long)fallbacks, rounds * N);
    assert_true(fallbacks * 1000 < (uint64_t)rounds * N);
    free(cases);
}

/* Whether the filters' AVX2 forms can run here (the tests compare them with the scalar). */
static int have_avx2(void)
{
#if defined(__x86_64__)
    return __builtin_cpu_supports("avx2");
#else
    return 0;
#endif
}

/* The fan filter (one triangle against up to eight rays from one origin) decides each ray
 * exactly as the four-triangle filter decides it alone, with and without AVX2, and a ray
 * it rejects is one the exact test misses. Rays aim at grid points, so many pass exactly
 * through a vertex or along an edge line, where the filter must leave the sign open. */
static void test_fan_filter_decides_as_each_ray_alone(void **state)
{
    (void)state;
    rng r = rng_for(51);
    int avx2 = have_avx2();
    size_t rays = 0, rejected = 0, hits = 0;
    for (int c = 0; c < 3000; c++) {
        double offset = c % 3 == 0 ? 0.0 : c % 3 == 1 ? 1e6 : -3e9;
        vec3 shift = {offset, -offset, offset};
        vec3 tri[3];
        for (int k = 0; k < 3; k++)
            tri[k] = vec3_add(rng_grid_vec(&r, -4, 4, 1), shift);
        if (c % 17 == 0)
            tri[2] = tri[1]; /* zero area */
        if (c % 23 == 0)
            tri[1] = tri[2] = tri[0]; /* one point: every edge function zero */
        if (c % 19 == 0)
            tri[2] = vec3_add(tri[0], vec3_scale(vec3_sub(tri[1], tri[0]), 0.5)); /* collinear */
        vec3 o = vec3_add(rng_grid_vec(&r, -8, 8, 1), shift);
        unsigned count = 1 + (unsigned)(rng_u64(&r) % RAY_FAN_MAX);
        vec3 d[RAY_FAN_MAX];
        for (unsigned i = 0; i < count; i++) {
            /* Toward a vertex, an edge's midpoint, or a grid point near the triangle. */
            unsigned pick = (unsigned)(rng_u64(&r) % 3);
            vec3 target = pick == 0   ? tri[rng_u64(&r) % 3]
                          : pick == 1 ? vec3_scale(vec3_add(tri[0], tri[1]), 0.5)
                                      : vec3_add(rng_grid_vec(&r, -4, 4, 1), shift);
            d[i] = vec3_sub(target, o);
            if (d[i].x == 0 && d[i].y == 0 && d[i].z == 0)
                d[i] = (vec3){1, 0, 0};
        }
        ray_fan fan;
        ray_fan_init(&fan, o, d, count);
        unsigned plain = ray_fan_misses(&fan, tri, 0);
        assert_int_equal(ray_fan_misses(&fan, tri, avx2), plain);
        assert_int_equal(plain >> count, 0);
        for (unsigned i = 0; i < count; i++) {
            static const uint32_t corners[1][3] = {{0, 1, 2}}, first = 0;
            unsigned alone = ray_tri_exact_misses4(o, d[i], tri, corners, &first, 1, 0);
            assert_int_equal((plain >> i) & 1, alone);
            ray_tri_hit h;
            int hit = ray_tri_exact(o, d[i], 0.0, INFINITY, tri, &h);
            if ((plain >> i) & 1)
                assert_int_equal(hit, 0);
            rays++;
            rejected += (plain >> i) & 1;
            hits += hit != 0;
        }
    }
    printf("  fan filter: %zu rays, %zu rejected by the filter, %zu hits\n", rays, rejected, hits);
    /* Not vacuous: the filter rejects most misses, and hits were there to keep. */
    assert_true(rejected * 4 > rays);
    assert_true(hits * 10 > rays);
}

/* The four-triangle filter (an indexed mesh's leaf candidates) decides each candidate the
 * same with and without AVX2, whatever the group's size, and rejects only triangles the
 * exact test misses. Among the candidates are triangles with a repeated vertex, among
 * them whole triangles at one point (all three edge functions zero, which leaves the edge
 * filter undecided): the exact test never crosses them, and the filter must say so. */
static void test_four_filter_rejects_only_misses(void **state)
{
    (void)state;
    rng r = rng_for(52);
    int avx2 = have_avx2();
    enum { TRIS = 4 };
    size_t candidates = 0, rejected = 0, hits = 0, repeated = 0;
    for (int c = 0; c < 4000; c++) {
        double offset = c % 3 == 0 ? 0.0 : c % 3 == 1 ? 1e6 : -3e9;
        vec3 shift = {offset, -offset, offset};
        vec3 vertices[3 * TRIS];
        uint32_t corners[TRIS][3], ids[TRIS];
        for (int t = 0; t < TRIS; t++) {
            for (int k = 0; k < 3; k++) {
                vertices[3 * t + k] = vec3_add(rng_grid_vec(&r, -4, 4, 1), shift);
                corners[t][k] = (uint32_t)(3 * t + k);
            }
            unsigned kind = (unsigned)(rng_u64(&r) % 6);
            if (kind == 0) /* one point, under three vertex numbers */
                vertices[3 * t + 1] = vertices[3 * t + 2] = vertices[3 * t];
            else if (kind == 1) /* two corners at one point */
                vertices[3 * t + 2] = vertices[3 * t + 1];
            else if (kind == 2) /* one vertex number twice */
                corners[t][1] = corners[t][0];
            ids[t] = (uint32_t)(TRIS - 1 - t);
        }
        /* Rays toward a vertex (often a repeated one), an edge's midpoint, or a grid point. */
        vec3 o = vec3_add(rng_grid_vec(&r, -8, 8, 1), shift);
        unsigned pick = (unsigned)(rng_u64(&r) % 3);
        const vec3 *aim = &vertices[3 * (rng_u64(&r) % TRIS)];
        vec3 target = pick == 0   ? aim[0]
                      : pick == 1 ? vec3_scale(vec3_add(aim[0], aim[1]), 0.5)
                                  : vec3_add(rng_grid_vec(&r, -4, 4, 1), shift);
        vec3 d = vec3_sub(target, o);
        if (d.x == 0 && d.y == 0 && d.z == 0)
            d = (vec3){0, 1, 0};
        unsigned count = 1 + (unsigned)(rng_u64(&r) % TRIS);
        unsigned plain = ray_tri_exact_misses4(o, d, vertices, (const uint32_t(*)[3])corners, ids, count, 0);
        assert_int_equal(ray_tri_exact_misses4(o, d, vertices, (const uint32_t(*)[3])corners, ids, count, avx2),
                         plain);
        assert_int_equal(plain >> count, 0);
        for (unsigned i = 0; i < count; i++) {
            const uint32_t *cn = corners[ids[i]];
            vec3 tri[3] = {vertices[cn[0]], vertices[cn[1]], vertices[cn[2]]};
            int hit = ray_tri_exact(o, d, 0.0, INFINITY, tri, NULL);
            int rep = vec3_equal(tri[0], tri[1]) || vec3_equal(tri[1], tri[2]) || vec3_equal(tri[2], tri[0]);
            if ((plain >> i) & 1)
                assert_int_equal(hit, 0);
            if (rep)
                assert_true((plain >> i) & 1);
            candidates++;
            rejected += (plain >> i) & 1;
            hits += hit != 0;
            repeated += (size_t)rep;
        }
    }
    printf("  four filter: %zu candidates, %zu rejected (%zu with a repeated vertex), %zu hits\n", candidates,
           rejected, repeated, hits);
    assert_true(repeated * 4 > candidates);
    assert_true(hits * 20 > candidates);
}

int main(void)
{
    const char *env = getenv("TRIOCT_SEED");
    if (env && *env)
        base_seed = strtoull(env, NULL, 0);
    printf("test_ray_tri: seed %#llx (set TRIOCT_SEED to rerun with another)\n",
           (unsigned long long)base_seed);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_random_rays_match_rational_reference),
        cmocka_unit_test(test_fan_filter_decides_as_each_ray_alone),
        cmocka_unit_test(test_four_filter_rejects_only_misses),
        cmocka_unit_test(test_random_rays_with_huge_offsets_and_tiny_sizes),
        cmocka_unit_test(test_near_boundary_rays_match_reference),
        cmocka_unit_test(test_closed_meshes_are_crossed_with_correct_parity),
        cmocka_unit_test(test_closed_meshes_watertight_at_huge_offsets_and_tiny_scale),
        cmocka_unit_test(test_shared_edge_and_fan_vertex_claimed_once),
        cmocka_unit_test(test_ray_in_triangle_plane_never_hits),
        cmocka_unit_test(test_zero_direction_components),
        cmocka_unit_test(test_ray_starting_on_surface_hits_at_zero_iff_tmin_le_zero),
        cmocka_unit_test(test_range_is_closed_and_exact),
        cmocka_unit_test(test_range_behind_origin_and_infinite),
        cmocka_unit_test(test_degenerate_triangles_never_hit),
        cmocka_unit_test(test_boundary_hits_report_valid_barycentrics),
        cmocka_unit_test(test_compare_t_random_against_reference),
        cmocka_unit_test(test_compare_t_ties_and_near_ties),
        cmocka_unit_test(test_compare_t_orders_a_stack_of_hits),
        cmocka_unit_test(test_rays_near_the_top_of_the_double_range),
        cmocka_unit_test(test_random_rays_at_the_ends_of_the_double_range_match_reference),
        cmocka_unit_test(test_rays_across_the_whole_double_range),
        cmocka_unit_test(test_seed_and_fast_agree_on_clear_cases),
        cmocka_unit_test(test_seed_and_fast_reject_parallel_and_degenerate),
        cmocka_unit_test(test_filter_decides_generic_cases),
    };
    return cmocka_run_group_tests_name("ray_tri", tests, NULL, NULL);
}
