/* Exact point-to-triangle distances (oracle_distance.h). */
#include "oracle_distance.h"

#include <gmp.h>

typedef struct qvec {
    mpq_t c[3];
} qvec;

static void qvec_init(qvec *v)
{
    for (int k = 0; k < 3; k++)
        mpq_init(v->c[k]);
}

static void qvec_clear(qvec *v)
{
    for (int k = 0; k < 3; k++)
        mpq_clear(v->c[k]);
}

static void qvec_set(qvec *v, vec3 p)
{
    mpq_set_d(v->c[0], p.x);
    mpq_set_d(v->c[1], p.y);
    mpq_set_d(v->c[2], p.z);
}

static void qvec_sub(qvec *out, const qvec *a, const qvec *b)
{
    for (int k = 0; k < 3; k++)
        mpq_sub(out->c[k], a->c[k], b->c[k]);
}

static void qvec_dot(mpq_t out, const qvec *a, const qvec *b)
{
    mpq_t t;
    mpq_init(t);
    mpq_set_ui(out, 0, 1);
    for (int k = 0; k < 3; k++) {
        mpq_mul(t, a->c[k], b->c[k]);
        mpq_add(out, out, t);
    }
    mpq_clear(t);
}

/* |p - (a + s e1 + t e2)|^2 with w = p - a. */
static void residual2(mpq_t out, const qvec *w, const qvec *e1, const mpq_t s, const qvec *e2, const mpq_t t)
{
    qvec r;
    qvec_init(&r);
    mpq_t m;
    mpq_init(m);
    for (int k = 0; k < 3; k++) {
        mpq_set(r.c[k], w->c[k]);
        mpq_mul(m, s, e1->c[k]);
        mpq_sub(r.c[k], r.c[k], m);
        if (e2) {
            mpq_mul(m, t, e2->c[k]);
            mpq_sub(r.c[k], r.c[k], m);
        }
    }
    qvec_dot(out, &r, &r);
    mpq_clear(m);
    qvec_clear(&r);
}

static void take(mpq_t best, int *best_feature, const mpq_t value, int feature)
{
    int c = mpq_cmp(value, best);
    if (*best_feature < 0 || c < 0 || (c == 0 && feature < *best_feature)) {
        mpq_set(best, value);
        *best_feature = feature;
    }
}

static void exact_distance2(vec3 p, const vec3 v[3], mpq_t best, int *feature)
{
    qvec qp, qv[3], w, e, e2;
    qvec_init(&qp);
    qvec_init(&w);
    qvec_init(&e);
    qvec_init(&e2);
    qvec_set(&qp, p);
    for (int k = 0; k < 3; k++) {
        qvec_init(&qv[k]);
        qvec_set(&qv[k], v[k]);
    }
    mpq_t value, a, b, c, d, f, det, s, t, one;
    mpq_inits(value, a, b, c, d, f, det, s, t, one, NULL);
    mpq_set_ui(one, 1, 1);
    *feature = -1;
    for (int k = 0; k < 3; k++) {
        qvec_sub(&w, &qp, &qv[k]);
        qvec_dot(value, &w, &w);
        take(best, feature, value, 2);
    }
    for (int k = 0; k < 3; k++) {
        qvec_sub(&w, &qp, &qv[k]);
        qvec_sub(&e, &qv[(k + 1) % 3], &qv[k]);
        qvec_dot(a, &e, &e);
        if (mpq_sgn(a) == 0)
            continue;
        qvec_dot(b, &w, &e);
        mpq_div(t, b, a);
        if (mpq_sgn(t) > 0 && mpq_cmp(t, one) < 0) {
            residual2(value, &w, &e, t, NULL, t);
            take(best, feature, value, 1);
        }
    }
    /* The face: s e1 + t e2 nearest to w = p - v0 solves
     * [e1.e1 e1.e2; e1.e2 e2.e2] (s, t) = (w.e1, w.e2). */
    qvec_sub(&w, &qp, &qv[0]);
    qvec_sub(&e, &qv[1], &qv[0]);
    qvec_sub(&e2, &qv[2], &qv[0]);
    qvec_dot(a, &e, &e);
    qvec_dot(b, &e, &e2);
    qvec_dot(c, &e2, &e2);
    qvec_dot(d, &w, &e);
    qvec_dot(f, &w, &e2);
    mpq_mul(det, a, c);
    mpq_mul(value, b, b);
    mpq_sub(det, det, value);
    if (mpq_sgn(det) != 0) {
        mpq_mul(s, d, c); /* s = (d c - b f) / det, t = (a f - b d) / det */
        mpq_mul(value, b, f);
        mpq_sub(s, s, value);
        mpq_div(s, s, det);
        mpq_mul(t, a, f);
        mpq_mul(value, b, d);
        mpq_sub(t, t, value);
        mpq_div(t, t, det);
        mpq_add(value, s, t);
        if (mpq_sgn(s) >= 0 && mpq_sgn(t) >= 0 && mpq_cmp(value, one) <= 0) {
            residual2(value, &w, &e, s, &e2, t);
            take(best, feature, value, 0);
        }
    }
    mpq_clears(value, a, b, c, d, f, det, s, t, one, NULL);
    for (int k = 0; k < 3; k++)
        qvec_clear(&qv[k]);
    qvec_clear(&qp);
    qvec_clear(&w);
    qvec_clear(&e);
    qvec_clear(&e2);
}

int oracle_point_triangle_compare(vec3 p, const vec3 v[3], double dist)
{
    mpq_t best, d2;
    mpq_inits(best, d2, NULL);
    int feature;
    exact_distance2(p, v, best, &feature);
    mpq_set_d(d2, dist);
    mpq_mul(d2, d2, d2);
    int c = mpq_cmp(best, d2);
    mpq_clears(best, d2, NULL);
    return (c > 0) - (c < 0);
}

double oracle_point_triangle_distance2(vec3 p, const vec3 v[3], int *feature)
{
    mpq_t best;
    mpq_init(best);
    int f;
    exact_distance2(p, v, best, &f);
    double d = mpq_get_d(best);
    mpq_clear(best);
    if (feature)
        *feature = f;
    return d;
}

/* The interior critical point of two segments' squared distance, when both parameters are
 * strictly inside: |r + s d1 - t d2|^2 with (s, t) from the 2x2 normal equations. */
static void segment_interior(vec3 p1, vec3 q1, vec3 p2, vec3 q2, mpq_t best, int *have)
{
    qvec a1, b1, a2, b2, d1, d2, r, minus_d1;
    qvec *all[] = {&a1, &b1, &a2, &b2, &d1, &d2, &r, &minus_d1};
    for (int k = 0; k < 8; k++)
        qvec_init(all[k]);
    qvec_set(&a1, p1);
    qvec_set(&b1, q1);
    qvec_set(&a2, p2);
    qvec_set(&b2, q2);
    qvec_sub(&d1, &b1, &a1);
    qvec_sub(&d2, &b2, &a2);
    qvec_sub(&r, &a1, &a2);
    for (int k = 0; k < 3; k++)
        mpq_neg(minus_d1.c[k], d1.c[k]);
    mpq_t a, b, e, c, f, det, s, t, m, one, value;
    mpq_inits(a, b, e, c, f, det, s, t, m, one, value, NULL);
    mpq_set_ui(one, 1, 1);
    qvec_dot(a, &d1, &d1);
    qvec_dot(b, &d1, &d2);
    qvec_dot(e, &d2, &d2);
    qvec_dot(c, &d1, &r);
    qvec_dot(f, &d2, &r);
    mpq_mul(det, b, b);
    mpq_mul(m, a, e);
    mpq_sub(det, det, m); /* b^2 - a e */
    if (mpq_sgn(det) != 0) {
        mpq_mul(s, c, e);
        mpq_mul(m, b, f);
        mpq_sub(s, s, m);
        mpq_div(s, s, det); /* (c e - b f) / det */
        mpq_mul(t, b, c);
        mpq_mul(m, a, f);
        mpq_sub(t, t, m);
        mpq_div(t, t, det); /* (b c - a f) / det */
        if (mpq_sgn(s) > 0 && mpq_cmp(s, one) < 0 && mpq_sgn(t) > 0 && mpq_cmp(t, one) < 0) {
            residual2(value, &r, &minus_d1, s, &d2, t);
            if (!*have || mpq_cmp(value, best) < 0)
                mpq_set(best, value);
            *have = 1;
        }
    }
    mpq_clears(a, b, e, c, f, det, s, t, m, one, value, NULL);
    for (int k = 0; k < 8; k++)
        qvec_clear(all[k]);
}

static void exact_pair_distance2(const vec3 a[3], const vec3 b[3], mpq_t best)
{
    mpq_set_ui(best, 0, 1);
    if (oracle_tri_tri(a, b))
        return;
    int have = 0, feature;
    mpq_t value;
    mpq_init(value);
    for (int side = 0; side < 2; side++)
        for (int i = 0; i < 3; i++) {
            exact_distance2(side ? b[i] : a[i], side ? a : b, value, &feature);
            if (!have || mpq_cmp(value, best) < 0)
                mpq_set(best, value);
            have = 1;
        }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            segment_interior(a[i], a[(i + 1) % 3], b[j], b[(j + 1) % 3], best, &have);
    mpq_clear(value);
}

int oracle_triangle_pair_compare(const vec3 a[3], const vec3 b[3], double dist)
{
    mpq_t best, d2;
    mpq_inits(best, d2, NULL);
    exact_pair_distance2(a, b, best);
    mpq_set_d(d2, dist);
    mpq_mul(d2, d2, d2);
    int c = mpq_cmp(best, d2);
    mpq_clears(best, d2, NULL);
    return (c > 0) - (c < 0);
}

double oracle_triangle_pair_distance2(const vec3 a[3], const vec3 b[3])
{
    mpq_t best;
    mpq_init(best);
    exact_pair_distance2(a, b, best);
    double d = mpq_get_d(best);
    mpq_clear(best);
    return d;
}
