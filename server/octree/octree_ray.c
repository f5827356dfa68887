/* Ray queries: front-to-back traversal with conservative slab tests, so no node that the
 * exact ray touches is ever skipped, and a closest-hit query stops at the first node that
 * cannot hold a nearer hit. */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "../geom/box_geometry.h"
#include "../geom/predicates.h"
#include "../geom/ray_tri.h"
#include "id_set.h"
#include "octree_internal.h"

#define EPS 0x1p-53
/* Absolute slack for results that may have underflowed (one ulp of the smallest normal). */
#define TINY 0x1p-1021

typedef struct ray_setup {
    vec3 o, d;
    double inv[3];
    /* Per axis: 0 = ordinary, 1 = direction exactly zero (the ray keeps that coordinate),
     * 2 = unconstrained (1/d is not a normal double, so the slab is not trusted at all). */
    int kind[3];
    double tmin, tmax;
    int widen; /* exact mode: widen every interval by its rounding error */
    int near_upper[3]; /* 1 when the ray meets the upper half along the axis first */
    /* Front-to-back visiting order of a node's children for this ray: the j-th child to
     * visit takes the upper half along axis a when half[a][j], and is seed octant
     * octant[j]. Along each axis the ray crosses the split plane at most once, so the near
     * half's segment precedes the far half's: lexicographic order of "far along x, y, z"
     * is front to back. */
    unsigned char half[3][8];
    unsigned char octant[8];
} ray_setup;

static void setup_ray(ray_setup *r, const ray_input *in, accuracy_mode mode)
{
    r->o = in->origin;
    r->d = in->direction;
    r->tmin = in->tmin;
    r->tmax = in->tmax;
    r->widen = mode == ACCURACY_EXACT;
    for (int a = 0; a < 3; a++) {
        double d = vec3_get(in->direction, a);
        r->inv[a] = 0.0;
        if (d == 0.0) {
            r->kind[a] = 1;
            continue;
        }
        double inv = 1.0 / d;
        if (!isfinite(inv) || fabs(inv) < DBL_MIN) {
            r->kind[a] = 2;
            continue;
        }
        r->kind[a] = 0;
        r->inv[a] = inv;
    }
    for (int a = 0; a < 3; a++)
        r->near_upper[a] = r->kind[a] == 0 && r->inv[a] < 0.0;
    for (int j = 0; j < 8; j++) {
        int hx = r->near_upper[0] ^ ((j >> 2) & 1), hy = r->near_upper[1] ^ ((j >> 1) & 1),
            hz = r->near_upper[2] ^ (j & 1);
        r->half[0][j] = (unsigned char)hx;
        r->half[1][j] = (unsigned char)hy;
        r->half[2][j] = (unsigned char)hz;
        r->octant[j] = box_octant_of_upper_bits[hx | hy << 1 | hz << 2];
    }
}

/* Plain comparisons: fmax/fmin are library calls that also order NaNs, which cannot occur
 * here (every operand is a product of finite numbers or an infinity). */
static inline double max3(double a, double b, double c)
{
    double m = a > b ? a : b;
    return m > c ? m : c;
}

static inline double min3(double a, double b, double c)
{
    double m = a < b ? a : b;
    return m < c ? m : c;
}

/* The parameter intervals of the lower half [lo, c] (index 0) and the upper half [c, hi]
 * (index 1) of a node along one axis: three planes serve all eight children. */
static inline void axis_halves(const ray_setup *r, int a, double lo, double c, double hi, double enter[2],
                               double leave[2])
{
    double o = a == 0 ? r->o.x : a == 1 ? r->o.y : r->o.z;
    if (r->kind[a] == 0) {
        double inv = r->inv[a];
        double tl = (lo - o) * inv, tc = (c - o) * inv, th = (hi - o) * inv;
        if (inv > 0.0) {
            enter[0] = tl, leave[0] = tc, enter[1] = tc, leave[1] = th;
        } else {
            enter[0] = tc, leave[0] = tl, enter[1] = th, leave[1] = tc;
        }
    } else if (r->kind[a] == 1) {
        /* The ray keeps this coordinate: a half either always holds it or never. */
        int in_lower = o >= lo && o <= c, in_upper = o >= c && o <= hi;
        enter[0] = in_lower ? -INFINITY : INFINITY, leave[0] = in_lower ? INFINITY : -INFINITY;
        enter[1] = in_upper ? -INFINITY : INFINITY, leave[1] = in_upper ? INFINITY : -INFINITY;
    } else {
        enter[0] = enter[1] = -INFINITY;
        leave[0] = leave[1] = INFINITY;
    }
}

/* The parameter interval over which the ray is inside the closed box, widened outward by
 * the rounding error of (plane - o) * (1/d): each of the three roundings is relative, so
 * 4 eps |t| covers them, plus TINY for underflow. Empty boxes give tnear > tfar (or NaN,
 * which fails every comparison the same way). */
static inline void slab(const ray_setup *r, box3 b, double *tnear, double *tfar)
{
    double lo[3] = {b.lo.x, b.lo.y, b.lo.z}, hi[3] = {b.hi.x, b.hi.y, b.hi.z};
    double o[3] = {r->o.x, r->o.y, r->o.z};
    double tn = -INFINITY, tf = INFINITY;
    for (int a = 0; a < 3; a++) {
        if (r->kind[a] == 0) {
            double t0 = (lo[a] - o[a]) * r->inv[a], t1 = (hi[a] - o[a]) * r->inv[a];
            if (t0 > t1) {
                double s = t0;
                t0 = t1;
                t1 = s;
            }
            tn = t0 > tn ? t0 : tn;
            tf = t1 < tf ? t1 : tf;
        } else if (r->kind[a] == 1 && (o[a] < lo[a] || o[a] > hi[a])) {
            tn = INFINITY;
            tf = -INFINITY;
        }
    }
    if (r->widen) {
        tn = tn - fabs(tn) * (4 * EPS) - TINY;
        tf = tf + fabs(tf) * (4 * EPS) + TINY;
    }
    *tnear = tn;
    *tfar = tf;
}

/* An upper bound on the exact t = N / D of a hit, N = det[v0-o, v1-o, v2-o] and
 * D = ((v1-v0) x (v2-v0)) . d. Each is a sum of products of rounded differences, whose
 * error is below 8 eps times its permanent (the orient3d bound is 7 eps + 56 eps^2). */
static double exact_t_upper_bound(const ray_setup *r, const vec3 tri[3])
{
    vec3 a = vec3_sub(tri[0], r->o), b = vec3_sub(tri[1], r->o), c = vec3_sub(tri[2], r->o);
    vec3 bc = vec3_cross(b, c);
    double n = vec3_dot(a, bc);
    vec3 ab = vec3_abs(a), bb = vec3_abs(b), cb = vec3_abs(c);
    double perm_n = ab.x * (bb.y * cb.z + bb.z * cb.y) + ab.y * (bb.z * cb.x + bb.x * cb.z) +
                    ab.z * (bb.x * cb.y + bb.y * cb.x);
    vec3 e1 = vec3_sub(tri[1], tri[0]), e2 = vec3_sub(tri[2], tri[0]);
    vec3 nn = vec3_cross(e1, e2);
    double den = vec3_dot(nn, r->d);
    vec3 e1b = vec3_abs(e1), e2b = vec3_abs(e2), db = vec3_abs(r->d);
    double perm_d = db.x * (e1b.y * e2b.z + e1b.z * e2b.y) + db.y * (e1b.z * e2b.x + e1b.x * e2b.z) +
                    db.z * (e1b.x * e2b.y + e1b.y * e2b.x);
    double err_n = 8 * EPS * perm_n + TINY, err_d = 8 * EPS * perm_d + TINY;
    if (den < 0) {
        den = -den;
        n = -n;
    }
    if (!(den - err_d > 0) || !isfinite(n) || !isfinite(den))
        return INFINITY;
    double q = (n + err_n) / (den - err_d);
    return q + fabs(q) * (4 * EPS) + TINY;
}

static int test_triangle(const octree *tree, const ray_setup *r, accuracy_mode mode, uint32_t id,
                         ray_tri_hit *hit)
{
    const vec3 *tri = octree_triangle_at(tree, id);
    switch (mode) {
    case ACCURACY_SEED:
        return ray_tri_seed(r->o, r->d, r->tmin, r->tmax, tri, tree->seed_epsilon, hit);
    case ACCURACY_FAST:
        return ray_tri_fast(r->o, r->d, r->tmin, r->tmax, tri, hit);
    case ACCURACY_EXACT:
        break;
    }
    return ray_tri_exact(r->o, r->d, r->tmin, r->tmax, tri, hit);
}

/* Order of two hits of the same ray: exact t in exact mode, then triangle id. */
static int hit_order(const octree *tree, const ray_setup *r, accuracy_mode mode, const ray_hit *a,
                     const ray_hit *b)
{
    int c;
    if (mode == ACCURACY_EXACT) {
        c = ray_tri_compare_t(r->o, r->d, octree_triangle_at(tree, a->triangle), octree_triangle_at(tree, b->triangle));
    } else {
        c = (a->t > b->t) - (a->t < b->t);
    }
    if (c == 0) {
        uint32_t ia = tree->original_id[a->triangle], ib = tree->original_id[b->triangle];
        c = (ia > ib) - (ia < ib);
    }
    return c;
}

/* A hit as reported: the caller's triangle id, and the unit normal, which only reported
 * hits pay for. */
static ray_hit reported(const octree *tree, ray_hit hit)
{
    const vec3 *tri = octree_triangle_at(tree, hit.triangle);
    hit.normal = vec3_normalize(vec3_cross(vec3_sub(tri[1], tri[0]), vec3_sub(tri[2], tri[0])));
    hit.triangle = tree->original_id[hit.triangle];
    return hit;
}

/* A growable list of hits for RAY_ALL. */
typedef struct hit_list {
    ray_hit *items;
    size_t count, capacity;
} hit_list;

static int hit_list_push(hit_list *l, ray_hit h)
{
    if (l->count == l->capacity) {
        size_t cap = l->capacity ? 2 * l->capacity : 16;
        ray_hit *items = realloc(l->items, cap * sizeof *items);
        if (!items)
            return -1;
        l->items = items;
        l->capacity = cap;
    }
    l->items[l->count++] = h;
    return 0;
}

typedef struct sort_ctx {
    const octree *tree;
    const ray_setup *r;
    accuracy_mode mode;
} sort_ctx;

/* Merge sort with a context (qsort has none in C11); hits per ray are few. */
static void sort_hits(ray_hit *items, ray_hit *tmp, size_t n, const sort_ctx *c)
{
    if (n < 2)
        return;
    size_t half = n / 2;
    sort_hits(items, tmp, half, c);
    sort_hits(items + half, tmp, n - half, c);
    size_t i = 0, j = half, k = 0;
    while (i < half && j < n)
        tmp[k++] = hit_order(c->tree, c->r, c->mode, &items[j], &items[i]) < 0 ? items[j++] : items[i++];
    while (i < half)
        tmp[k++] = items[i++];
    while (j < n)
        tmp[k++] = items[j++];
    memcpy(items, tmp, n * sizeof *items);
}

static octree_status validate_ray(const ray_input *ray)
{
    if (!vec3_is_finite(ray->origin) || !vec3_is_finite(ray->direction))
        return OCTREE_ERR_NONFINITE;
    if (ray->direction.x == 0.0 && ray->direction.y == 0.0 && ray->direction.z == 0.0)
        return OCTREE_ERR_INVALID;
    if (!isfinite(ray->tmin) || isnan(ray->tmax) || ray->tmin > ray->tmax)
        return OCTREE_ERR_INVALID;
    return OCTREE_OK;
}

typedef struct ray_entry {
    uint32_t node;
    double tnear;
    box3 box;
} ray_entry;

octree_status octree_ray(const octree *tree, const ray_input *ray, ray_detail detail, accuracy_mode mode,
                         ray_output *out, query_stats *stats)
{
    octree_status st = validate_ray(ray);
    if (st != OCTREE_OK)
        return st;
    if (detail != RAY_ANY && detail != RAY_CLOSEST && detail != RAY_ALL)
        return OCTREE_ERR_INVALID;
    if (mode != ACCURACY_EXACT && mode != ACCURACY_SEED && mode != ACCURACY_FAST)
        return OCTREE_ERR_INVALID;
    uint64_t fallbacks_before = predicates_fallback_count();
    query_stats local = {0};

    ray_setup r;
    setup_ray(&r, ray, mode);
    out->hit_count = 0;
    out->truncated = 0;

    id_set tested;
    id_set_init(&tested);
    hit_list all = {0};
    ray_hit best = {0};
    int have_best = 0;
    double bound = r.tmax; /* nodes starting past this cannot hold a wanted hit */
    int done = 0;

    ray_entry stack[OCTREE_STACK_MAX];
    size_t top = 0;
    double tn, tf;
    slab(&r, tree->world, &tn, &tf);
    if (tn <= tf && tn <= r.tmax && tf >= r.tmin)
        stack[top++] = (ray_entry){0, tn, tree->world};

    while (top > 0 && !done) {
        ray_entry e = stack[--top];
        if (e.tnear > bound)
            continue; /* a nearer hit was found after this node was pushed */
        local.nodes_visited++;
        octree_node node = tree->nodes[e.node];
        if (node.count != NODE_INTERIOR) {
            local.leaves_visited++;
            for (uint32_t i = 0; i < node.count && !done; i++) {
                uint32_t id = tree->leaf_items[node.first + i];
                int fresh = id_set_insert(&tested, id);
                if (fresh == 0)
                    continue;
                if (fresh < 0) {
                    st = OCTREE_ERR_NOMEM;
                    done = 1;
                    break;
                }
                local.candidates_tested++;
                ray_tri_hit h;
                if (!test_triangle(tree, &r, mode, id, &h))
                    continue;
                ray_hit hit = {h.t, id, h.u, h.v, {0, 0, 0}};
                if (detail == RAY_ANY) {
                    best = hit;
                    have_best = 1;
                    done = 1;
                } else if (detail == RAY_CLOSEST) {
                    if (!have_best || hit_order(tree, &r, mode, &hit, &best) < 0) {
                        best = hit;
                        have_best = 1;
                        if (mode == ACCURACY_EXACT) {
                            double ub = exact_t_upper_bound(&r, octree_triangle_at(tree, id));
                            bound = ub < bound ? ub : bound;
                        } else {
                            bound = hit.t < bound ? hit.t : bound;
                        }
                    }
                } else if (hit_list_push(&all, hit) != 0) {
                    st = OCTREE_ERR_NOMEM;
                    done = 1;
                }
            }
            continue;
        }
        /* Children the ray meets within [tmin, bound], tested without branches (which
         * child the ray meets is unpredictable), then pushed far to near so the nearest
         * is popped first. Empty leaves never enter the stack. */
        box3 b = e.box;
        double c[3] = {box_split(b.lo.x, b.hi.x), box_split(b.lo.y, b.hi.y), box_split(b.lo.z, b.hi.z)};
        double lo[3] = {b.lo.x, b.lo.y, b.lo.z}, hi[3] = {b.hi.x, b.hi.y, b.hi.z};
        double enter[3][2], leave[3][2];
        for (int a = 0; a < 3; a++)
            axis_halves(&r, a, lo[a], c[a], hi[a], enter[a], leave[a]);
        const octree_node *kids = &tree->nodes[node.first];
        double widen = r.widen ? 4 * EPS : 0.0, tiny = r.widen ? TINY : 0.0;
        double tnear[8];
        unsigned accepted = 0;
        for (int j = 0; j < 8; j++) {
            double t0 = max3(enter[0][r.half[0][j]], enter[1][r.half[1][j]], enter[2][r.half[2][j]]);
            double t1 = min3(leave[0][r.half[0][j]], leave[1][r.half[1][j]], leave[2][r.half[2][j]]);
            t0 = t0 - fabs(t0) * widen - tiny;
            t1 = t1 + fabs(t1) * widen + tiny;
            tnear[j] = t0;
            int ok = (t0 <= t1) & (t0 <= bound) & (t1 >= r.tmin) & (kids[r.octant[j]].count != 0);
            accepted |= (unsigned)ok << j;
        }
        while (accepted) {
            int j = 31 - __builtin_clz(accepted);
            accepted &= ~(1u << j);
            int hx = r.half[0][j], hy = r.half[1][j], hz = r.half[2][j];
            box3 cb = {{hx ? c[0] : lo[0], hy ? c[1] : lo[1], hz ? c[2] : lo[2]},
                       {hx ? hi[0] : c[0], hy ? hi[1] : c[1], hz ? hi[2] : c[2]}};
            stack[top++] = (ray_entry){node.first + r.octant[j], tnear[j], cb};
        }
    }

    if (detail == RAY_ALL && st == OCTREE_OK) {
        sort_ctx c = {tree, &r, mode};
        ray_hit *tmp = malloc((all.count ? all.count : 1) * sizeof *tmp);
        if (!tmp) {
            st = OCTREE_ERR_NOMEM;
        } else {
            sort_hits(all.items, tmp, all.count, &c);
            free(tmp);
            out->hit_count = all.count;
            size_t keep = all.count < out->max_hits ? all.count : out->max_hits;
            out->truncated = keep < all.count;
            for (size_t i = 0; i < keep; i++)
                out->hits[i] = reported(tree, all.items[i]);
        }
    } else if (have_best && st == OCTREE_OK) {
        out->hit_count = 1;
        if (out->max_hits > 0)
            out->hits[0] = reported(tree, best);
        else
            out->truncated = 1;
    }
    free(all.items);
    id_set_release(&tested);
    query_stats_finish(stats, &local, fallbacks_before, predicates_fallback_count());
    return st;
}
