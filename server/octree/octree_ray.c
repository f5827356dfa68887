/* Ray queries: front-to-back traversal with conservative slab tests, so no node that the
 * exact ray touches is ever skipped, and a closest-hit query stops at the first node that
 * cannot hold a nearer hit. Each traversal is a walk taken a step at a time: a lone ray runs
 * its walk to the end, a batch of scattered rays interleaves several walks to overlap their
 * memory waits, and a batch from one origin walks groups of rays through the tree together. */
#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "../geom/box_geometry.h"
#include "../geom/predicates.h"
#include "../geom/ray_tri.h"
#include "octree_internal.h"
#include "octree_modes.h"
#include "id_set.h"

#define EPS 0x1p-53
/* Absolute slack for results that may have underflowed (one ulp of the smallest normal). */
#define TINY 0x1p-1021

typedef struct ray_setup {
    vec3 o, d;
    double inv[3];
    /* Per axis: 0 = ordinary, 1 = direction exactly zero (the ray keeps that coordinate),
     * 2 = unconstrained (1/d is not a normal double, so the slab is not trusted at all),
     * 3 = far: ordinary, but a face of the world minus the origin overflows a double (an
     * origin near one end of the double range, the world near the other), so the crossings
     * take far_split_crossing. */
    int kind[3];
    double tmin, tmax;
    /* Every interval is widened by its rounding error, 4 eps |t| + TINY, and in fast and
     * seed mode by the mode's slack too: the walk then visits every node whose box, grown
     * by `grow` (a max-norm distance, octree_modes.c) in every direction, the ray meets,
     * which along axis a moves the box's faces by grow |1 / d_a| in t. */
    double grow;
    /* Every axis kind 0, as nearly every ray: its split crossings take the branch-free
     * path, widened by slack_rel |t| + slack_abs[a] (4 eps, and TINY + grow |1 / d_a|). */
    int ordinary;
    double slack_rel, slack_abs[3];
    int near_upper[3]; /* 1 when the ray meets the upper half along the axis first */
    /* Front-to-back visiting order of a node's children for this ray: the j-th child to
     * visit takes the upper half along axis a when bit a of upper[j] is set, and is seed
     * octant octant[j]. Along each axis the ray crosses the split plane at most once, so
     * the near half's segment precedes the far half's: lexicographic order of "far along
     * x, y, z" is front to back. */
    unsigned char upper[8];
    unsigned char octant[8];
    int touch; /* RAY_TOUCH: the closed rule (set by walk_begin; exact mode only) */
    /* A posed tree's walk (octree_ray_posed): o, d above are the local ray, which the walk
     * takes; the triangles are tested posed, against posed->world. NULL otherwise. */
    const posed_ray *posed;
} ray_setup;

/* One axis of setup_ray: its kind, 1/d, and its absolute slack. Inlined per axis, so the
 * axis is a constant (a coordinate looked up by index cost more than the arithmetic). */
static inline __attribute__((always_inline)) void setup_axis(ray_setup *r, const octree *tree, int a, double o,
                                                             double d, double world_lo, double world_hi)
{
    r->inv[a] = 0.0;
    r->slack_abs[a] = TINY;
    /* An infinite slack (octree_modes.c: inputs outside the range its bound covers) trusts
     * no slab at all: the walk visits every node, as brute force would test every
     * triangle. */
    if (!(r->grow < INFINITY)) {
        r->kind[a] = 2;
        return;
    }
    if (d == 0.0) {
        r->kind[a] = 1;
        return;
    }
    double inv = 1.0 / d;
    if (!isfinite(inv) || fabs(inv) < DBL_MIN) {
        r->kind[a] = 2;
        return;
    }
    /* Every face and split plane c of the tree lies between the world's faces, and a
     * rounded difference is monotone in c, so no c - o overflows unless one of theirs
     * does; none can when the world and the origin are within DBL_MAX / 2. */
    r->kind[a] = 0;
    if (!(tree->splits_in_range && fabs(o) <= DBL_MAX / 2) && (isinf(world_lo - o) || isinf(world_hi - o)))
        r->kind[a] = 3;
    r->inv[a] = inv;
    /* grow |1 / d_a| rounds once more: 2 eps covers it. A slack that overflows in t
     * leaves the axis unconstrained, like an unusable direction component. */
    if (r->grow > 0.0 && r->kind[a] == 0) {
        r->slack_abs[a] = TINY + r->grow * fabs(inv) * (1 + 2 * EPS);
        if (!(r->slack_abs[a] < INFINITY)) {
            r->kind[a] = 2;
            r->slack_abs[a] = TINY;
        }
    }
}

static void setup_ray(ray_setup *r, const octree *tree, const ray_input *in, accuracy_mode mode,
                      const posed_ray *posed)
{
    r->posed = posed;
    if (posed)
        in = &posed->local;
    r->o = in->origin;
    r->d = in->direction;
    r->tmin = in->tmin;
    r->tmax = in->tmax;
    r->grow = mode == ACCURACY_FAST   ? octree_fast_ray_slack(tree, in->origin, in->direction)
              : mode == ACCURACY_SEED ? octree_seed_ray_slack(tree, in->origin, in->direction)
              : posed                 ? posed->grow
                                      : 0.0;
    r->slack_rel = 4 * EPS;
    const box3 w = tree->world;
    setup_axis(r, tree, 0, in->origin.x, in->direction.x, w.lo.x, w.hi.x);
    setup_axis(r, tree, 1, in->origin.y, in->direction.y, w.lo.y, w.hi.y);
    setup_axis(r, tree, 2, in->origin.z, in->direction.z, w.lo.z, w.hi.z);
}

/* The rest of a ray's setup that only the double walk reads: its visiting order. */
static void setup_ray_order(ray_setup *r)
{
    for (int a = 0; a < 3; a++)
        r->near_upper[a] = (r->kind[a] == 0 || r->kind[a] == 3) && r->inv[a] < 0.0;
    r->ordinary = r->kind[0] == 0 && r->kind[1] == 0 && r->kind[2] == 0;
    for (int j = 0; j < 8; j++) {
        int hx = r->near_upper[0] ^ ((j >> 2) & 1), hy = r->near_upper[1] ^ ((j >> 1) & 1),
            hz = r->near_upper[2] ^ (j & 1);
        r->octant[j] = box_octant_of_upper_bits[hx | hy << 1 | hz << 2];
        r->upper[j] = (unsigned char)(hx | hy << 1 | hz << 2);
    }
}

/* Where the ray crosses a node's split plane along one axis, as the two bounds a child's
 * interval takes from it: the far half is entered no earlier than *far_enter and the near
 * half left no later than *near_exit. Everything else a child's interval needs is the
 * node's own interval, which its stack entry carries, so a node costs three planes, not
 * nine. The crossing is widened by its rounding error: (c - o) and the product each round
 * once and 1/d was a third rounding, so 4 eps |t| + TINY bounds the exact crossing (|t|
 * clamped to DBL_MAX so that an overflowed crossing widens to itself, not to NaN); fast
 * and seed mode add their slack, which moves the near half's far face and the far half's
 * near face (both the split plane) outward by grow. This is the crossing of an axis a of
 * kind 0. */
static inline void ordinary_split_crossing(const ray_setup *r, int a, double o, double inv, double c,
                                           double *far_enter, double *near_exit)
{
    double tc = (c - o) * inv;
    double size = fabs(tc) < DBL_MAX ? fabs(tc) : DBL_MAX;
    double slack = size * r->slack_rel + r->slack_abs[a];
    *far_enter = tc - slack;
    *near_exit = tc + slack;
}

/* (c - o) * inv, the crossing parameter of the plane x_a = c, for an axis of kind 0 or 3.
 * When c - o overflows (kind 3 only: an origin near one end of the double range and a
 * plane near the other), the parameter may still be finite, even small for a long
 * direction, and an infinite difference would put the plane beyond every node. Then it is
 * computed from the halves, (c/2 - o/2) * inv * 2: the halving is exact but for a subnormal
 * operand, whose error of at most 2^-1075 is nothing beside a difference of about 2^1024,
 * and the doubling is exact unless it overflows, so the result has the same three
 * relative roundings as (c - o) * inv and takes the same slack. */
static inline double plane_crossing(double o, double inv, double c)
{
    double diff = c - o;
    if (isinf(diff))
        return ((0.5 * c - 0.5 * o) * inv) * 2.0;
    return diff * inv;
}

/* ordinary_split_crossing for an axis of kind 3. Such rays are rare, and take the path
 * that branches on each axis's kind. */
static void far_split_crossing(const ray_setup *r, int a, double o, double inv, double c, double *far_enter,
                               double *near_exit)
{
    double tc = plane_crossing(o, inv, c);
    double size = fabs(tc) < DBL_MAX ? fabs(tc) : DBL_MAX;
    double slack = size * r->slack_rel + r->slack_abs[a];
    *far_enter = tc - slack;
    *near_exit = tc + slack;
}

/* The crossing along axis a, whatever its kind. */
static inline void axis_split_crossing(const ray_setup *r, int a, double c, double *far_enter, double *near_exit)
{
    double o = a == 0 ? r->o.x : a == 1 ? r->o.y : r->o.z;
    if (r->kind[a] == 0) {
        ordinary_split_crossing(r, a, o, r->inv[a], c, far_enter, near_exit);
    } else if (r->kind[a] == 3) {
        far_split_crossing(r, a, o, r->inv[a], c, far_enter, near_exit);
    } else if (r->kind[a] == 1) {
        /* The ray keeps this coordinate: a half either always holds it or never (grown by
         * the mode's slack: [lo, c + grow] and [c - grow, hi]; c -/+ grow rounds, but o is
         * compared with it, and grow carries a factor to spare). Such an axis has
         * near_upper 0, so near is the lower half. */
        *near_exit = o <= c + r->grow ? INFINITY : -INFINITY;
        *far_enter = o >= c - r->grow ? -INFINITY : INFINITY;
    } else {
        *far_enter = -INFINITY;
        *near_exit = INFINITY;
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
        if (r->kind[a] == 0 || r->kind[a] == 3) {
            double t0, t1;
            if (r->kind[a] == 0) {
                t0 = (lo[a] - o[a]) * r->inv[a];
                t1 = (hi[a] - o[a]) * r->inv[a];
            } else {
                t0 = plane_crossing(o[a], r->inv[a], lo[a]);
                t1 = plane_crossing(o[a], r->inv[a], hi[a]);
            }
            if (t0 > t1) {
                double s = t0;
                t0 = t1;
                t1 = s;
            }
            /* The mode's slack moves both faces outward (nothing in exact mode). */
            t0 -= r->slack_abs[a] - TINY;
            t1 += r->slack_abs[a] - TINY;
            tn = t0 > tn ? t0 : tn;
            tf = t1 < tf ? t1 : tf;
        } else if (r->kind[a] == 1 && (o[a] < lo[a] - r->grow || o[a] > hi[a] + r->grow)) {
            tn = INFINITY;
            tf = -INFINITY;
        }
    }
    tn = tn - fabs(tn) * (4 * EPS) - TINY;
    tf = tf + fabs(tf) * (4 * EPS) + TINY;
    *tnear = tn;
    *tfar = tf;
}

/* The smallest common t of a touch hit is within a few ulps of its reported t (ray_tri.h),
 * so this bounds it from above where the hit has no t_upper: a touch hit with den == 0 (in
 * the plane, a zero-area triangle) or one too close to parallel for the bound. */
static double touch_t_upper_bound(double t)
{
    return t + fabs(t) * 0x1p-40 + TINY;
}

/* Triangle id's vertices as the walk's final tests take them: posed where the tree is
 * placed (octree_ray_posed), the tree's own otherwise. */
static inline __attribute__((always_inline)) void walk_triangle(const octree *tree, const ray_setup *r, uint32_t id,
                                                                vec3 tri[3])
{
    octree_triangle_vertices(tree, id, tri);
    if (r->posed)
        for (int k = 0; k < 3; k++)
            tri[k] = octree_apply_pose(&r->posed->at, tri[k]);
}

/* The exact order of two hits' t under the contact rule (both hit by the ray). */
static int exact_hit_order(vec3 o, vec3 d, double tmin, double tmax, int touch, const vec3 a[3], const vec3 b[3])
{
    return touch ? ray_tri_touch_compare(o, d, tmin, tmax, a, b) : ray_tri_compare_t(o, d, a, b);
}

/* Forced inline: it runs once per candidate, and as a call it passes the ray by value a
 * second time (1.3% of an exact ray's instructions). */
static inline __attribute__((always_inline)) int test_triangle(const octree *tree, const ray_setup *r,
                                                              accuracy_mode mode, uint32_t id, ray_tri_hit *hit)
{
    vec3 tri[3];
    if (r->posed) { /* exact mode only (octree_ray_posed) */
        const posed_ray *p = r->posed;
        walk_triangle(tree, r, id, tri);
        if (r->touch)
            return ray_tri_touch(p->world.origin, p->world.direction, r->tmin, r->tmax, tri, hit);
        return ray_tri_exact(p->world.origin, p->world.direction, r->tmin, r->tmax, tri, hit);
    }
    octree_triangle_vertices(tree, id, tri);
    switch (mode) {
    case ACCURACY_SEED:
        return ray_tri_seed(r->o, r->d, r->tmin, r->tmax, tri, tree->seed_epsilon, hit);
    case ACCURACY_FAST:
        return ray_tri_fast(r->o, r->d, r->tmin, r->tmax, tri, hit);
    case ACCURACY_EXACT:
        break;
    }
    if (r->touch)
        return ray_tri_touch(r->o, r->d, r->tmin, r->tmax, tri, hit);
    return ray_tri_exact(r->o, r->d, r->tmin, r->tmax, tri, hit);
}

/* Order of two hits of the same ray: exact t in exact mode, then triangle id. */
static int hit_order(const octree *tree, const ray_setup *r, accuracy_mode mode, const ray_hit *a,
                     const ray_hit *b)
{
    int c;
    if (mode == ACCURACY_EXACT) {
        vec3 ta[3], tb[3];
        walk_triangle(tree, r, a->triangle, ta);
        walk_triangle(tree, r, b->triangle, tb);
        /* A placed tree's hits are on the world ray. */
        vec3 o = r->posed ? r->posed->world.origin : r->o, d = r->posed ? r->posed->world.direction : r->d;
        c = exact_hit_order(o, d, r->tmin, r->tmax, r->touch, ta, tb);
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
static ray_hit reported(const octree *tree, const ray_setup *r, ray_hit hit)
{
    vec3 tri[3];
    walk_triangle(tree, r, hit.triangle, tri);
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
    if (array_reserve((void **)&l->items, &l->capacity, l->count + 1, sizeof *l->items, 16) != 0)
        return -1;
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

/* A node waiting on the traversal stack: 24 bytes, no box. Its faces and split planes are
 * derived when it is expanded, from its parent's, which the walk keeps per level: the
 * stack is depth first, so when a node of level L is popped the last node expanded at
 * level L - 1 is its parent (any other node of that level still waits below it). The
 * entry carries the node's conservative parameter interval, which bounds its children's. */
typedef struct ray_entry {
    double tnear, tfar;
    uint32_t node;
    unsigned char level;
    unsigned char upper; /* bit a set: the upper half of the parent along axis a */
} ray_entry;

/* How many rays a batch keeps in flight. Enough walks that the memory one step asks for
 * arrives while the others take theirs, few enough that their hot state stays in L1: on
 * incoherent rays 4, 8 and 16 measured alike (about 1.4x over one ray at a time), 1 gave
 * only the gain of prefetching a leaf's triangles together (about 1.15x). */
#ifndef RAY_STREAM_WIDTH
#define RAY_STREAM_WIDTH 8
#endif

/* Marks a walk with no leaf waiting to be tested. */
#define NO_PENDING_LEAF UINT32_MAX

/* One ray's traversal in flight: everything a step needs, so that a single ray runs its
 * walk to completion and a batch advances several walks in turn, hiding one walk's memory
 * latency behind another's work. The tested set points into itself: a walk is never
 * copied once begun. */
typedef struct ray_walk {
    ray_setup r;
    ray_detail detail;
    accuracy_mode mode;
    octree_status st;
    int have_best;
    int done;
    /* A leaf already popped and counted whose candidates the next step tests: a pipelined
     * walk stops between the two so the candidates' triangles can arrive meanwhile. */
    uint32_t pending_leaf;
    double bound; /* nodes starting past this cannot hold a wanted hit */
    ray_hit best;
    query_stats local;
    id_set tested; /* each triangle is tested once */
    hit_list all;
    size_t top;
    ray_entry stack[OCTREE_STACK_MAX];
    /* The last node expanded at each level: per axis its lower face, split plane and upper
     * face, so that a child's faces are two adjacent entries picked by its half bit
     * (indexed loads: which half a child takes is unpredictable, and a branch on it
     * mispredicted half the time). */
    double level_planes[OCTREE_MAX_DEPTH_CAP + 1][3][3];
} ray_walk;

static octree_status check_query(const ray_input *ray, ray_detail detail, accuracy_mode mode)
{
    octree_status st = validate_ray(ray);
    if (st != OCTREE_OK)
        return st;
    if (detail != RAY_ANY && detail != RAY_CLOSEST && detail != RAY_ALL)
        return OCTREE_ERR_INVALID;
    if (mode != ACCURACY_EXACT && mode != ACCURACY_SEED && mode != ACCURACY_FAST)
        return OCTREE_ERR_INVALID;
    /* The touch rule promises every common point, which only the exact tests can keep. */
    if (ray->contact != RAY_CROSSING && (ray->contact != RAY_TOUCH || mode != ACCURACY_EXACT))
        return OCTREE_ERR_INVALID;
    return OCTREE_OK;
}

static inline __attribute__((always_inline)) int walk_test_candidate(ray_walk *w, const octree *tree, uint32_t id);

/* Makes the walk's tested set ready (clearing its inline slots costs about as much as a
 * node step, which walks that test no candidate twice need not pay). */
static void walk_need_set(ray_walk *w)
{
    if (!w->tested.slots)
        id_set_init(&w->tested);
}

/* Starts the walk of a ray that passed check_query. */
/* Starts the walk of a ray that passed check_query, short of its root: the compiled walk
 * goes on from here (compiled_begin), the double walk from walk_root. */
static void walk_init_posed(ray_walk *w, const octree *tree, const ray_input *ray, const posed_ray *posed,
                            ray_detail detail, accuracy_mode mode, ray_output *out)
{
    setup_ray(&w->r, tree, ray, mode, posed);
    w->r.touch = ray->contact == RAY_TOUCH;
    w->detail = detail;
    w->mode = mode;
    w->st = OCTREE_OK;
    w->have_best = 0;
    w->done = 0;
    w->pending_leaf = NO_PENDING_LEAF;
    w->bound = w->r.tmax;
    w->best = (ray_hit){0};
    w->local = (query_stats){0};
    /* The tested set is made ready by walk_need_set, for the walks that use it. */
    w->tested.slots = NULL;
    if (mode == ACCURACY_SEED)
        walk_need_set(w);
    w->all = (hit_list){0};
    w->top = 0;
    out->hit_count = 0;
    out->truncated = 0;
    /* Seed mode: the triangles whose seed test no slack bounds (octree_modes.c) first. */
    if (mode == ACCURACY_SEED)
        for (size_t i = 0; i < tree->sliver_list_count; i++)
            if (!walk_test_candidate(w, tree, octree_sliver_list(tree)[i]))
                return;
}

static void walk_init(ray_walk *w, const octree *tree, const ray_input *ray, ray_detail detail,
                      accuracy_mode mode, ray_output *out)
{
    walk_init_posed(w, tree, ray, NULL, detail, mode, out);
}

/* The double walk's start: its visiting order, and the root when the ray meets the world. */
static void walk_root(ray_walk *w, const octree *tree)
{
    setup_ray_order(&w->r);
    walk_need_set(w);
    if (w->done)
        return;
    double tn, tf;
    slab(&w->r, tree->world, &tn, &tf);
    if (tn <= tf && tn <= w->r.tmax && tf >= w->r.tmin && tn <= w->bound)
        w->stack[w->top++] = (ray_entry){tn, tf, 0, 0, 0};
}

/* Starts the double walk of a ray that passed check_query. */
static void walk_begin(ray_walk *w, const octree *tree, const ray_input *ray, ray_detail detail,
                       accuracy_mode mode, ray_output *out)
{
    walk_init(w, tree, ray, detail, mode, out);
    walk_root(w, tree);
}

/* Cache lines a prefetch of one leaf list or one leaf's triangles may ask for: leaves hold
 * a handful of triangles, and a pathological one is not worth flooding the memory system. */
#define PREFETCH_LINES_MAX 8
#define PREFETCH_TRIANGLES_MAX 32

/* The prefetch helpers are forced inline: GCC counts a prefetch as no side effect, so a
 * helper left out of line is found to be const and every call to it deleted as dead. */
#define PREFETCH_HELPER static inline __attribute__((always_inline))

PREFETCH_HELPER void prefetch_span(const void *first, size_t bytes)
{
    const char *p = first;
    size_t lines = (bytes + 63) / 64;
    lines = lines < PREFETCH_LINES_MAX ? lines : PREFETCH_LINES_MAX;
    for (size_t k = 0; k < lines; k++)
        __builtin_prefetch(p + 64 * k);
    __builtin_prefetch(p + bytes - 1); /* the last line when the span straddles one more */
}

/* Tests one candidate unless the walk tested it already. Returns 0 once the walk is done
 * (an answer for RAY_ANY, or out of memory). Forced inline: as a call per candidate it
 * cost exact rays 7% of their instructions. */
static inline __attribute__((always_inline)) int walk_test_unique(ray_walk *w, const octree *tree, uint32_t id);

static inline __attribute__((always_inline)) int walk_test_candidate(ray_walk *w, const octree *tree, uint32_t id)
{
    int fresh = id_set_insert(&w->tested, id);
    if (fresh == 0)
        return 1;
    if (fresh < 0) {
        w->st = OCTREE_ERR_NOMEM;
        w->done = 1;
        return 0;
    }
    return walk_test_unique(w, tree, id);
}

/* Tests one candidate, which the walk either has not tested yet or may test again (a
 * closest or any hit is the same however often a triangle is tested). */
static inline __attribute__((always_inline)) int walk_test_unique(ray_walk *w, const octree *tree, uint32_t id)
{
    const ray_setup *r = &w->r;
    /* The best hit so far met again in a neighbouring leaf: nothing to learn from it. */
    if (w->have_best && w->best.triangle == id)
        return 1;
    w->local.candidates_tested++;
    ray_tri_hit h;
    if (!test_triangle(tree, r, w->mode, id, &h))
        return 1;
    ray_hit hit = {h.t, id, h.u, h.v, {0, 0, 0}};
    if (w->detail == RAY_ANY) {
        w->best = hit;
        w->have_best = 1;
        w->done = 1;
        return 0;
    } else if (w->detail == RAY_CLOSEST) {
        if (!w->have_best || hit_order(tree, r, w->mode, &hit, &w->best) < 0) {
            w->best = hit;
            w->have_best = 1;
            if (w->mode == ACCURACY_EXACT) {
                double ub = h.t_upper;
                if (r->touch && ub == INFINITY)
                    ub = touch_t_upper_bound(hit.t);
                w->bound = ub < w->bound ? ub : w->bound;
            } else {
                /* A fast or seed hit reports the t at which the ray passes within the
                 * walk's slack of the triangle (octree_modes.c), so every node holding a
                 * triangle hit at a t up to this one meets the ray by then: the walk
                 * still visits it. */
                w->bound = hit.t < w->bound ? hit.t : w->bound;
            }
        }
    } else if (hit_list_push(&w->all, hit) != 0) {
        w->st = OCTREE_ERR_NOMEM;
        w->done = 1;
        return 0;
    }
    return 1;
}

static void walk_test_leaf(ray_walk *w, const octree *tree, octree_node node)
{
    for (uint32_t i = 0; i < node.count; i++)
        if (!walk_test_candidate(w, tree, tree->leaf_items[node.first + i]))
            return;
}

/* The faces and split planes of a popped interior node: the world's for the root, else
 * the half of its parent's (kept per level by the walk) that its entry names, split as
 * every query and the build split it. levels[L] holds, per axis, the lower face, split
 * plane and upper face of the last node expanded at level L. */
static inline void entry_planes(double (*levels)[3][3], const octree *tree, unsigned level, unsigned upper)
{
    double(*p)[3] = levels[level];
    double lo[3], hi[3];
    if (level == 0) {
        const box3 *world = &tree->world;
        lo[0] = world->lo.x, hi[0] = world->hi.x;
        lo[1] = world->lo.y, hi[1] = world->hi.y;
        lo[2] = world->lo.z, hi[2] = world->hi.z;
    } else {
        const double(*q)[3] = levels[level - 1];
        unsigned hx = upper & 1, hy = (upper >> 1) & 1, hz = (upper >> 2) & 1;
        lo[0] = q[0][hx], hi[0] = q[0][hx + 1];
        lo[1] = q[1][hy], hi[1] = q[1][hy + 1];
        lo[2] = q[2][hz], hi[2] = q[2][hz + 1];
    }
    /* Written from registers in one pass: storing the faces and reading them back for the
     * split stalled each expansion on store forwarding. */
    vec3 c = octree_split_point(tree, (box3){{lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]}});
    p[0][0] = lo[0], p[0][1] = c.x, p[0][2] = hi[0];
    p[1][0] = lo[1], p[1][1] = c.y, p[1][2] = hi[1];
    p[2][0] = lo[2], p[2][1] = c.z, p[2][2] = hi[2];
}

/* The children of a node (faces and split planes `planes`) that the walk's ray meets
 * within the node's interval [node_near, node_far] clipped to [tmin, bound], as a mask in
 * the ray's visiting order, with each child's interval in tnear[j], tfar[j]. Lone walks
 * and packets both expand nodes here, so a ray visits the same nodes either way. A
 * child's interval is the node's narrowed along each axis by the split plane: the near
 * half ends where the ray crosses it, the far half begins there. The bounds stay
 * conservative (every one is at or outside the exact value), so a child the exact ray
 * touches is never dropped; the exact per-axis entries of the node itself are implied by
 * its interval. */
static inline unsigned children_met(const ray_walk *w, double node_near, double node_far, const double (*planes)[3],
                                    double tnear[8], double tfar[8])
{
    const ray_setup *r = &w->r;
    double lo = node_near > r->tmin ? node_near : r->tmin;
    double hi = node_far < w->bound ? node_far : w->bound;
    double fx, nx, fy, ny, fz, nz;
    if (r->ordinary) {
        /* No axis's kind to branch on. */
        ordinary_split_crossing(r, 0, r->o.x, r->inv[0], planes[0][1], &fx, &nx);
        ordinary_split_crossing(r, 1, r->o.y, r->inv[1], planes[1][1], &fy, &ny);
        ordinary_split_crossing(r, 2, r->o.z, r->inv[2], planes[2][1], &fz, &nz);
    } else {
        axis_split_crossing(r, 0, planes[0][1], &fx, &nx);
        axis_split_crossing(r, 1, planes[1][1], &fy, &ny);
        axis_split_crossing(r, 2, planes[2][1], &fz, &nz);
    }
    /* Child j (in visiting order) takes the far half along x, y, z when bit 2, 1, 0 of j is
     * set. Its entry is the largest of lo and its far axes' crossings, its exit the
     * smallest of hi and its near axes' crossings; the x-y parts are shared by two
     * children each. Plain comparisons, not fmax/fmin: no operand is NaN. */
    double fx1 = lo > fx ? lo : fx, nx0 = hi < nx ? hi : nx;
    double fxy[4] = {lo, lo > fy ? lo : fy, fx1, fx1 > fy ? fx1 : fy};
    double nxy[4] = {nx0 < ny ? nx0 : ny, nx0, hi < ny ? hi : ny, hi};
    unsigned met = 0;
    /* Tested without branches: which children the ray meets is unpredictable. */
#define RAY_CHILD(j)                                                                                          \
    do {                                                                                                      \
        double t0 = (j) & 1 ? (fxy[(j) >> 1] > fz ? fxy[(j) >> 1] : fz) : fxy[(j) >> 1];                      \
        double t1 = (j) & 1 ? nxy[(j) >> 1] : (nxy[(j) >> 1] < nz ? nxy[(j) >> 1] : nz);                      \
        tnear[j] = t0;                                                                                        \
        tfar[j] = t1;                                                                                         \
        met |= (unsigned)(t0 <= t1) << (j);                                                                   \
    } while (0)
    RAY_CHILD(0);
    RAY_CHILD(1);
    RAY_CHILD(2);
    RAY_CHILD(3);
    RAY_CHILD(4);
    RAY_CHILD(5);
    RAY_CHILD(6);
    RAY_CHILD(7);
#undef RAY_CHILD
    return met;
}

/* A node's children that hold triangles, in the visiting order `octant` (empty leaves are
 * never pushed). */
static inline unsigned children_nonempty(const octree *tree, octree_node node, const unsigned char octant[8])
{
    const octree_node *kids = &tree->nodes[node.first];
#define NONEMPTY(j) ((unsigned)(kids[octant[j]].count != 0) << (j))
    return NONEMPTY(0) | NONEMPTY(1) | NONEMPTY(2) | NONEMPTY(3) | NONEMPTY(4) | NONEMPTY(5) | NONEMPTY(6) |
           NONEMPTY(7);
#undef NONEMPTY
}

/* What visiting a pushed child will read first: its children's block, or its leaf list.
 * Every child but the nearest waits for the nearer ones' subtrees, so its memory arrives
 * meanwhile instead of stalling the pop that reaches it. */
PREFETCH_HELPER void prefetch_child(const octree *tree, uint32_t child)
{
    octree_node kid = tree->nodes[child];
    __builtin_prefetch(kid.count == NODE_INTERIOR ? (const void *)&tree->nodes[kid.first]
                                                  : (const void *)&tree->leaf_items[kid.first]);
}

static inline void walk_expand(ray_walk *w, const octree *tree, ray_entry e, octree_node node, int pipelined)
{
    const ray_setup *r = &w->r;
    entry_planes(w->level_planes, tree, e.level, e.upper);
    double tnear[8], tfar[8];
    unsigned accepted = children_met(w, e.tnear, e.tfar, (const double(*)[3])w->level_planes[e.level], tnear, tfar) &
                        children_nonempty(tree, node, r->octant);
    /* Pushed far to near, so the nearest is popped first. */
    size_t top = w->top;
    unsigned char level = (unsigned char)(e.level + 1);
    while (accepted) {
        int j = 31 - __builtin_clz(accepted);
        accepted &= ~(1u << j);
        uint32_t child = node.first + r->octant[j];
        w->stack[top++] = (ray_entry){tnear[j], tfar[j], child, level, r->upper[j]};
        /* A pipelined walk asks for exactly the next node's memory instead (see
         * walk_prefetch_next); these extra requests gave it nothing measurable (0.85-1.13x
         * on random batches, this machine's noise). */
        if (!pipelined)
            prefetch_child(tree, child);
    }
    w->top = top;
}

/* Asks for the memory the walk's next step reads: the next node's block of children, or
 * the next leaf's list. Entries the bound already excludes are dropped first (the pop
 * would skip them anyway: the bound only shrinks), so the request is for the node the
 * next step really visits. The node record itself came in with its parent's block. */
PREFETCH_HELPER void walk_prefetch_next(ray_walk *w, const octree *tree)
{
    while (w->top > 0 && w->stack[w->top - 1].tnear > w->bound)
        w->top--;
    if (w->top == 0)
        return;
    octree_node next = tree->nodes[w->stack[w->top - 1].node];
    if (next.count == NODE_INTERIOR)
        prefetch_span(&tree->nodes[next.first], 8 * sizeof(octree_node));
    else if (next.count > 0)
        prefetch_span(&tree->leaf_items[next.first], next.count * sizeof(uint32_t));
}

/* A leaf's candidates' corner indices, asked for before their vertices are. */
PREFETCH_HELPER void prefetch_leaf_corners(const octree *tree, octree_node leaf)
{
    uint32_t n = leaf.count < PREFETCH_TRIANGLES_MAX ? leaf.count : PREFETCH_TRIANGLES_MAX;
    for (uint32_t i = 0; i < n; i++)
        __builtin_prefetch(tree->corners[tree->leaf_items[leaf.first + i]]);
}

/* A leaf's candidates' vertices, asked for one step before they are tested. */
PREFETCH_HELPER void prefetch_leaf_triangles(const octree *tree, octree_node leaf)
{
    uint32_t n = leaf.count < PREFETCH_TRIANGLES_MAX ? leaf.count : PREFETCH_TRIANGLES_MAX;
    for (uint32_t i = 0; i < n; i++)
    {
        /* The corners are read now (their line is likely in with the list's neighbours'),
         * so the three vertices can be asked for. */
        const uint32_t *c = tree->corners[tree->leaf_items[leaf.first + i]];
        __builtin_prefetch(&tree->vertices[c[0]]);
        __builtin_prefetch(&tree->vertices[c[1]]);
        __builtin_prefetch(&tree->vertices[c[2]]);
    }
}

/* Advances the walk by one node visit (or, pipelined, by one half of a leaf visit).
 * Returns 0 once the walk is over. `pipelined` is a constant at each call site: a lone
 * ray has nothing to overlap a prefetch with, so it neither prefetches nor splits leaves. */
static inline int walk_step(ray_walk *w, const octree *tree, int pipelined)
{
    if (pipelined && w->pending_leaf != NO_PENDING_LEAF) {
        walk_test_leaf(w, tree, tree->nodes[w->pending_leaf]);
        w->pending_leaf = NO_PENDING_LEAF;
    } else {
        ray_entry *e;
        do {
            if (w->top == 0)
                return 0;
            e = &w->stack[--w->top];
        } while (e->tnear > w->bound); /* a nearer hit was found after this node was pushed */
        w->local.nodes_visited++;
        octree_node node = tree->nodes[e->node];
        if (node.count != NODE_INTERIOR) {
            w->local.leaves_visited++;
            if (pipelined) {
                prefetch_leaf_triangles(tree, node);
                w->pending_leaf = e->node;
                return 1;
            }
            /* The leaf's triangles are asked for together, so their misses overlap
             * instead of coming one test at a time. */
            prefetch_leaf_triangles(tree, node);
            walk_test_leaf(w, tree, node);
        } else {
            /* The popped entry's slot is overwritten by the first child pushed: copy it. */
            walk_expand(w, tree, *e, node, pipelined);
        }
    }
    if (w->done)
        return 0;
    if (pipelined)
        walk_prefetch_next(w, tree);
    return w->top > 0;
}

/* Writes the walk's answer to out, releases what it holds and returns its status; the
 * caller adds w->local to its counters. */
/* Runs a walk begun by walk_init to its end by the double walk over the seed's nodes. */
static void walk_double(ray_walk *w, const octree *tree)
{
    walk_root(w, tree);
    while (walk_step(w, tree, 0))
        ;
}

static octree_status walk_finish(ray_walk *w, const octree *tree, ray_output *out)
{
    octree_status st = w->st;
    if (w->detail == RAY_ALL && st == OCTREE_OK) {
        sort_ctx c = {tree, &w->r, w->mode};
        ray_hit *tmp = malloc((w->all.count ? w->all.count : 1) * sizeof *tmp);
        if (!tmp) {
            st = OCTREE_ERR_NOMEM;
        } else {
            sort_hits(w->all.items, tmp, w->all.count, &c);
            free(tmp);
            out->hit_count = w->all.count;
            size_t keep = w->all.count < out->max_hits ? w->all.count : out->max_hits;
            out->truncated = keep < w->all.count;
            for (size_t i = 0; i < keep; i++)
                out->hits[i] = reported(tree, &w->r, w->all.items[i]);
        }
    } else if (w->have_best && st == OCTREE_OK) {
        out->hit_count = 1;
        if (out->max_hits > 0)
            out->hits[0] = reported(tree, &w->r, w->best);
        else
            out->truncated = 1;
    }
    free(w->all.items);
    id_set_release(&w->tested);
    return st;
}

/* ---------- the compiled walk (octree_traversal.h) ---------- */

/* A ray as the float walk takes it, relative to the world's lower corner. Along each axis
 * the near planes are measured from o_near and the far planes from o_far, floats on either
 * side of the exact origin (grown by the mode's slack): with d > 0 a larger origin gives a
 * smaller t, so (plane - o_near) / d is at or below the exact near crossing and
 * (plane - o_far) / d at or above the exact far one, and with d < 0 the roles swap. The
 * origin's rounding into float and the slack are paid here, once per ray; the walk's own
 * roundings are relative, three per crossing (the difference, the product, and 1/d taken
 * to float), and are paid once per child lane by widening the interval by 2^-21 of itself.
 * A direction component of zero takes 1/d = +inf: a plane beyond o_near gives +inf (the
 * box is not met), one before it -inf (no constraint), and a plane exactly at it NaN,
 * which the interval's max and min ignore (the axis then constrains nothing, which is
 * conservative). */
typedef struct float_ray {
    float o_near[3], o_far[3], inv[3];
    unsigned char near_row[3], far_row[3];
    unsigned near_upper; /* bit a: the ray meets the upper half along axis a first */
    int filtered;        /* leaves go through walk_test_leaf_filtered */
} float_ray;

/* Past these the float walk could overflow, or 1/d round to zero: such rays (an origin
 * 2^60 world sides away, a direction component below 2^-60 or above 2^60 of a unit) take
 * the double walk. */
#define FLOAT_WALK_RANGE 0x1p60

/* A float at or above x + g (g >= 0), from a float at or above x. */
static float float_grown_up(float f, double g)
{
    if (g == 0.0)
        return f;
    return float_at_or_above(nextafter((double)f + g, INFINITY));
}

static float float_grown_down(float f, double g)
{
    if (g == 0.0)
        return f;
    return float_at_or_below(nextafter((double)f - g, -INFINITY));
}

/* One axis of float_ray_setup: o and c the origin's and the world corner's coordinate,
 * d the direction's, inv its reciprocal as setup_ray took it. 0 when the ray must take the
 * double walk. Inlined per axis, so the axis is a constant and no coordinate is looked
 * up by index (which cost a ray's setup more than its arithmetic). */
static inline __attribute__((always_inline)) int float_axis_setup(float_ray *f, int a, int kind, double o, double c,
                                                                  double d, double inv, double grow)
{
    if (kind != 0 && kind != 1)
        return 0;
    float above, below;
    float_bounds_of_difference(o, c, &below, &above);
    if (grow != 0.0) {
        above = float_grown_up(above, grow);
        below = float_grown_down(below, grow);
    }
    if (!(fabsf(above) <= FLOAT_WALK_RANGE && fabsf(below) <= FLOAT_WALK_RANGE))
        return 0;
    int negative = 0;
    if (d == 0.0) {
        f->inv[a] = INFINITY;
    } else {
        if (!(fabs(inv) <= FLOAT_WALK_RANGE && fabs(inv) >= 1.0 / FLOAT_WALK_RANGE))
            return 0;
        f->inv[a] = (float)inv;
        negative = inv < 0;
    }
    f->o_near[a] = negative ? below : above;
    f->o_far[a] = negative ? above : below;
    f->near_row[a] = (unsigned char)(negative ? TRAVERSAL_HI_X + a : TRAVERSAL_LO_X + a);
    f->far_row[a] = (unsigned char)(negative ? TRAVERSAL_LO_X + a : TRAVERSAL_HI_X + a);
    f->near_upper |= (unsigned)negative << a;
    return 1;
}

/* Prepares r for the float walk; 0 when the ray must take the double walk instead. An
 * ordinary axis (kind 0) has setup_ray's 1/d, a normal double. */
static int float_ray_setup(float_ray *f, const octree *tree, const ray_setup *r)
{
    if (!tree->traversal.present || !(r->grow < INFINITY))
        return 0;
    f->near_upper = 0;
    const vec3 lo = tree->world.lo;
    return float_axis_setup(f, 0, r->kind[0], r->o.x, lo.x, r->d.x, r->inv[0], r->grow) &&
           float_axis_setup(f, 1, r->kind[1], r->o.y, lo.y, r->d.y, r->inv[1], r->grow) &&
           float_axis_setup(f, 2, r->kind[2], r->o.z, lo.z, r->d.z, r->inv[2], r->grow);
}

/* The children of n that the ray meets within [lo, hi], as a lane mask, with each lane's
 * widened entry parameter in tnear: eight lanes in two SSE2 halves (the x86-64 baseline),
 * or one AVX2 register where the processor has it. A child's bound is origin + q * scale,
 * exact in float (octree_traversal.h); each crossing (plane - o) * inv rounds three times
 * (with 1/d's rounding to float), which FLOAT_WALK_REL covers together with the rounding
 * of the widening itself, and FLOAT_WALK_ABS covers underflow. max and min take the
 * running value where a crossing is NaN (MAXPS and MINPS return their second operand
 * then), so a NaN constrains nothing. */
#define FLOAT_WALK_REL 0x1p-21f
#define FLOAT_WALK_ABS 0x1p-100f

#if defined(__x86_64__) || defined(__SSE2__)
#include <immintrin.h>
#define FLOAT_WALK_SIMD 1

/* Lanes 0-3 (half 0) or 4-7 (half 1) of a quantized row. */
static inline __m128 row_half_sse2(const uint8_t *row, int half, __m128 scale, __m128 origin)
{
    __m128i bytes = _mm_loadl_epi64((const __m128i *)row);
    __m128i words = _mm_unpacklo_epi8(bytes, _mm_setzero_si128());
    __m128i ints = half ? _mm_unpackhi_epi16(words, _mm_setzero_si128()) : _mm_unpacklo_epi16(words, _mm_setzero_si128());
    return _mm_add_ps(_mm_mul_ps(_mm_cvtepi32_ps(ints), scale), origin);
}

static inline unsigned node_children_met_sse2(const traversal_node *n, const float_ray *f, float lo, float hi,
                                              float tnear[8])
{
    __m128 scale = _mm_set1_ps(n->scale);
    __m128 rel = _mm_set1_ps(FLOAT_WALK_REL), absw = _mm_set1_ps(FLOAT_WALK_ABS);
    __m128 sign = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
    unsigned met = 0;
    for (int h = 0; h < 2; h++) {
        __m128 tn = _mm_set1_ps(lo), tf = _mm_set1_ps(hi);
        for (int a = 0; a < 3; a++) {
            __m128 origin = _mm_set1_ps(n->origin[a]), inv = _mm_set1_ps(f->inv[a]);
            __m128 t0 = _mm_mul_ps(_mm_sub_ps(row_half_sse2(n->q[f->near_row[a]], h, scale, origin),
                                              _mm_set1_ps(f->o_near[a])), inv);
            __m128 t1 = _mm_mul_ps(_mm_sub_ps(row_half_sse2(n->q[f->far_row[a]], h, scale, origin),
                                              _mm_set1_ps(f->o_far[a])), inv);
            tn = _mm_max_ps(t0, tn);
            tf = _mm_min_ps(t1, tf);
        }
        __m128 tn_w = _mm_sub_ps(_mm_sub_ps(tn, _mm_mul_ps(_mm_and_ps(tn, sign), rel)), absw);
        __m128 tf_w = _mm_add_ps(_mm_add_ps(tf, _mm_mul_ps(_mm_and_ps(tf, sign), rel)), absw);
        __m128i kids = _mm_loadu_si128((const __m128i *)&n->child[4 * h]);
        __m128i empty = _mm_cmpeq_epi32(kids, _mm_set1_epi32(-1));
        __m128 ok = _mm_andnot_ps(_mm_castsi128_ps(empty), _mm_cmple_ps(tn_w, tf_w));
        _mm_storeu_ps(&tnear[4 * h], tn_w);
        met |= (unsigned)_mm_movemask_ps(ok) << (4 * h);
    }
    return met;
}

/* All eight lanes in one AVX2 register: about half the instructions of the SSE2 form. */
#define FLOAT_WALK_AVX2 __attribute__((target("avx2")))

FLOAT_WALK_AVX2 static inline __m256 row_avx2(const uint8_t *row, __m256 scale, __m256 origin)
{
    __m256i ints = _mm256_cvtepu8_epi32(_mm_loadl_epi64((const __m128i *)row));
    return _mm256_add_ps(_mm256_mul_ps(_mm256_cvtepi32_ps(ints), scale), origin);
}

FLOAT_WALK_AVX2 static inline unsigned node_children_met_avx2(const traversal_node *n, const float_ray *f, float lo,
                                                              float hi, float tnear[8])
{
    __m256 scale = _mm256_set1_ps(n->scale);
    __m256 tn = _mm256_set1_ps(lo), tf = _mm256_set1_ps(hi);
    for (int a = 0; a < 3; a++) {
        __m256 origin = _mm256_set1_ps(n->origin[a]), inv = _mm256_set1_ps(f->inv[a]);
        __m256 t0 = _mm256_mul_ps(_mm256_sub_ps(row_avx2(n->q[f->near_row[a]], scale, origin), _mm256_set1_ps(f->o_near[a])), inv);
        __m256 t1 = _mm256_mul_ps(_mm256_sub_ps(row_avx2(n->q[f->far_row[a]], scale, origin), _mm256_set1_ps(f->o_far[a])), inv);
        tn = _mm256_max_ps(t0, tn);
        tf = _mm256_min_ps(t1, tf);
    }
    __m256 sign = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    __m256 rel = _mm256_set1_ps(FLOAT_WALK_REL), absw = _mm256_set1_ps(FLOAT_WALK_ABS);
    __m256 tn_w = _mm256_sub_ps(_mm256_sub_ps(tn, _mm256_mul_ps(_mm256_and_ps(tn, sign), rel)), absw);
    __m256 tf_w = _mm256_add_ps(_mm256_add_ps(tf, _mm256_mul_ps(_mm256_and_ps(tf, sign), rel)), absw);
    __m256i empty = _mm256_cmpeq_epi32(_mm256_loadu_si256((const __m256i *)n->child), _mm256_set1_epi32(-1));
    __m256 ok = _mm256_andnot_ps(_mm256_castsi256_ps(empty), _mm256_cmp_ps(tn_w, tf_w, _CMP_LE_OQ));
    _mm256_storeu_ps(tnear, tn_w);
    return (unsigned)_mm256_movemask_ps(ok);
}
#endif

/* The same test one lane at a time, for targets without SSE2; it computes exactly what the
 * lanes compute (plain comparisons keep the running value where a crossing is NaN). */
/* Unused where the lanes are compiled (clang says so; GCC does not for inline). */
static inline __attribute__((unused)) unsigned node_children_met_scalar(const traversal_node *n, const float_ray *f, float lo, float hi,
                                                float tnear[8])
{
    unsigned met = 0;
    for (int k = 0; k < 8; k++) {
        float tn = lo, tf = hi;
        for (int a = 0; a < 3; a++) {
            float bn = (float)n->q[f->near_row[a]][k] * n->scale + n->origin[a];
            float bf = (float)n->q[f->far_row[a]][k] * n->scale + n->origin[a];
            float t0 = (bn - f->o_near[a]) * f->inv[a], t1 = (bf - f->o_far[a]) * f->inv[a];
            tn = t0 > tn ? t0 : tn;
            tf = t1 < tf ? t1 : tf;
        }
        float tn_w = tn - fabsf(tn) * FLOAT_WALK_REL - FLOAT_WALK_ABS;
        float tf_w = tf + fabsf(tf) * FLOAT_WALK_REL + FLOAT_WALK_ABS;
        tnear[k] = tn_w;
        met |= (unsigned)(tn_w <= tf_w && n->child[k] != TRAVERSAL_EMPTY) << k;
    }
    return met;
}

/* Bit j of rank_of_lanes[s][m] is bit j ^ s of m: a lane mask in a ray's front-to-back
 * order, for the ray whose near-upper bits are s. */
#define RANK_BIT(s, m, j) ((((m) >> ((j) ^ (s))) & 1u) << (j))
#define RANK_MASK(s, m)                                                                                      \
    (RANK_BIT(s, m, 0) | RANK_BIT(s, m, 1) | RANK_BIT(s, m, 2) | RANK_BIT(s, m, 3) | RANK_BIT(s, m, 4) |       \
     RANK_BIT(s, m, 5) | RANK_BIT(s, m, 6) | RANK_BIT(s, m, 7))
#define RANK4(s, m) RANK_MASK(s, m), RANK_MASK(s, (m) + 1), RANK_MASK(s, (m) + 2), RANK_MASK(s, (m) + 3)
#define RANK16(s, m) RANK4(s, m), RANK4(s, (m) + 4), RANK4(s, (m) + 8), RANK4(s, (m) + 12)
#define RANK64(s, m) RANK16(s, m), RANK16(s, (m) + 16), RANK16(s, (m) + 32), RANK16(s, (m) + 48)
#define RANK256(s) {RANK64(s, 0), RANK64(s, 64), RANK64(s, 128), RANK64(s, 192)}
static const unsigned char rank_of_lanes[8][256] = {RANK256(0), RANK256(1), RANK256(2), RANK256(3),
                                                    RANK256(4), RANK256(5), RANK256(6), RANK256(7)};

typedef struct float_entry {
    float tnear;
    uint32_t ref;
} float_entry;

/* 7 siblings waiting per level plus the node. */
#define FLOAT_STACK_MAX (7 * (OCTREE_MAX_DEPTH_CAP + 1) + 2)

/* walk_test_leaf_filtered for a placed tree: four candidates at a time posed into a small
 * block, the filter run on them with the world ray, so that it rejects exactly what the
 * exact test on the posed triangles would. */
static __attribute__((noinline)) void walk_test_leaf_filtered_posed(ray_walk *w, const octree *tree, octree_node leaf)
{
    static const uint32_t corners[4][3] = {{0, 1, 2}, {3, 4, 5}, {6, 7, 8}, {9, 10, 11}};
    static const uint32_t slots[4] = {0, 1, 2, 3};
    const posed_ray *p = w->r.posed;
    const uint32_t *ids = &tree->leaf_items[leaf.first];
    for (uint32_t i = 0; i < leaf.count; i += 4) {
        unsigned k = leaf.count - i < 4 ? leaf.count - i : 4;
        vec3 posed[12];
        for (unsigned j = 0; j < k; j++)
            walk_triangle(tree, &w->r, ids[i + j], &posed[3 * j]);
        unsigned miss = ray_tri_exact_misses4(p->world.origin, p->world.direction, posed, corners, slots, k,
                                              tree->traversal.avx2);
        w->local.candidates_tested += bits_set8(miss);
        for (unsigned j = 0; j < k; j++)
            if (!((miss >> j) & 1) && !walk_test_unique(w, tree, ids[i + j]))
                return;
    }
}

/* A leaf's candidates for an exact crossing, closest or any hit: four at a time through
 * ray_tri_exact's own edge filter, and the full test only for those it cannot rule out.
 * Repeats are not skipped (walk_test_unique). */
static void walk_test_leaf_filtered(ray_walk *w, const octree *tree, octree_node leaf)
{
    if (w->r.posed) {
        walk_test_leaf_filtered_posed(w, tree, leaf);
        return;
    }
    const uint32_t *ids = &tree->leaf_items[leaf.first];
    for (uint32_t i = 0; i < leaf.count; i += 4) {
        unsigned k = leaf.count - i < 4 ? leaf.count - i : 4;
        unsigned miss = ray_tri_exact_misses4(w->r.o, w->r.d, tree->vertices, (const uint32_t(*)[3])tree->corners,
                                              &ids[i], k, tree->traversal.avx2);
        w->local.candidates_tested += bits_set8(miss);
        for (unsigned j = 0; j < k; j++)
            if (!((miss >> j) & 1) && !walk_test_unique(w, tree, ids[i + j]))
                return;
    }
}

/* What visiting a pushed child reads first: its record (two cache lines), or its leaf's
 * node. Every child but the nearest waits for the nearer ones' subtrees, so its memory
 * arrives meanwhile. */
PREFETCH_HELPER void prefetch_compiled_child(const octree *tree, uint32_t ref)
{
    if (ref & TRAVERSAL_SPAN) { /* the leaf's list: at most 32 ids, three lines */
        octree_node leaf = octree_leaf_of_ref(tree, ref);
        __builtin_prefetch(&tree->leaf_items[leaf.first]);
        __builtin_prefetch(&tree->leaf_items[leaf.first + leaf.count - 1]);
        return;
    }
    if (ref & TRAVERSAL_LEAF) {
        __builtin_prefetch(&tree->nodes[ref & ~TRAVERSAL_LEAF]);
        return;
    }
    const char *p = (const char *)&tree->traversal.nodes[ref];
    __builtin_prefetch(p);
    __builtin_prefetch(p + sizeof(traversal_node) - 1);
}

/* A walk over the compiled form: its ray in float, its stack, and its interval. */
typedef struct compiled_walk {
    float_ray f;
    float lo, bound; /* [tmin, bound] rounded outward */
    uint32_t pending_leaf; /* the reference of a leaf popped and counted, tested by a later step (pipelined) */
    int pending_stage;     /* what the next step does for it (compiled_step) */
    size_t top;
    float_entry stack[FLOAT_STACK_MAX];
} compiled_walk;

/* Prepares c for the walk w (begun by walk_begin); 0 when the ray must take the double walk. */
static int compiled_begin(compiled_walk *c, ray_walk *w, const octree *tree)
{
    if (w->done || !float_ray_setup(&c->f, tree, &w->r))
        return 0;
    /* Closest and any-hit exact crossings may test a triangle twice (a leaf's neighbours
     * share it), which costs less than a set that prevents it, and their leaves take four
     * candidates at once through the filter. */
    c->f.filtered = w->mode == ACCURACY_EXACT && !w->r.touch && w->detail != RAY_ALL;
    if (!c->f.filtered)
        walk_need_set(w);
    c->lo = float_at_or_below(w->r.tmin);
    c->bound = float_at_or_above(w->bound);
    c->pending_leaf = NO_PENDING_LEAF;
    c->top = 0;
    if (tree->traversal.root != TRAVERSAL_EMPTY)
        c->stack[c->top++] = (float_entry){-INFINITY, tree->traversal.root};
    return 1;
}

static inline __attribute__((always_inline)) void compiled_test_leaf(ray_walk *w, compiled_walk *c,
                                                                     const octree *tree, octree_node leaf)
{
    if (c->f.filtered)
        walk_test_leaf_filtered(w, tree, leaf);
    else
        walk_test_leaf(w, tree, leaf);
    c->bound = float_at_or_above(w->bound);
}

/* Asks for what the walk's next step reads: the next entry's record, or its leaf's list
 * and triangles. Entries the bound excludes are dropped first (the pop would skip them). */
PREFETCH_HELPER void compiled_prefetch_next(compiled_walk *c, const octree *tree)
{
    while (c->top > 0 && c->stack[c->top - 1].tnear > c->bound)
        c->top--;
    if (c->top > 0)
        prefetch_compiled_child(tree, c->stack[c->top - 1].ref);
}

/* One step of a compiled walk: a node expanded, or a leaf tested (pipelined: a leaf's
 * triangles asked for, and tested by the next step). Returns 0 once the walk is over. One
 * body for each instruction set, NODE_TEST its eight-lane child test, so that the whole
 * loop is compiled for it (a function for another target is not inlined into this one). */
#define DEFINE_COMPILED_STEP(SUFFIX, TARGET, NODE_TEST)                                                      \
    TARGET static inline __attribute__((always_inline)) int compiled_step_##SUFFIX(                          \
        ray_walk *w, compiled_walk *c, const octree *tree, int pipelined)                                    \
    {                                                                                                         \
        if (pipelined && c->pending_leaf != NO_PENDING_LEAF) {                                                \
            octree_node leaf_ = octree_leaf_of_ref(tree, c->pending_leaf);                                    \
            /* A leaf in three steps: its triangles' corners asked for (its list came with the */         \
            /* pop), then their vertices, then the tests, each arriving while other walks step. */        \
            if (c->pending_stage == 0) {                                                                      \
                prefetch_leaf_corners(tree, leaf_);                                                           \
                c->pending_stage = 1;                                                                         \
                return 1;                                                                                     \
            }                                                                                                 \
            if (c->pending_stage == 1) {                                                                      \
                prefetch_leaf_triangles(tree, leaf_);                                                         \
                c->pending_stage = 2;                                                                         \
                return 1;                                                                                     \
            }                                                                                                 \
            compiled_test_leaf(w, c, tree, leaf_);                                                            \
            c->pending_leaf = NO_PENDING_LEAF;                                                                \
            if (w->done)                                                                                      \
                return 0;                                                                                     \
            compiled_prefetch_next(c, tree);                                                                  \
            return c->top > 0;                                                                                \
        }                                                                                                     \
        float_entry e;                                                                                        \
        do {                                                                                                  \
            if (c->top == 0)                                                                                  \
                return 0;                                                                                     \
            e = c->stack[--c->top];                                                                           \
        } while (e.tnear > c->bound); /* a nearer hit was found after this node was pushed */                \
        w->local.nodes_visited++;                                                                             \
        if (e.ref & TRAVERSAL_LEAF) {                                                                         \
            octree_node leaf = octree_leaf_of_ref(tree, e.ref);                                               \
            w->local.leaves_visited++;                                                                        \
            if (pipelined) {                                                                                  \
                c->pending_leaf = e.ref;                                                                      \
                /* A short leaf's list was asked for when it reached the top of the stack: its  */         \
                /* corners can be asked for now. A long one's list is asked for first. */                    \
                if (e.ref & TRAVERSAL_SPAN) {                                                                 \
                    prefetch_leaf_corners(tree, leaf);                                                        \
                    c->pending_stage = 1;                                                                     \
                } else {                                                                                      \
                    prefetch_span(&tree->leaf_items[leaf.first], leaf.count * sizeof(uint32_t));              \
                    c->pending_stage = 0;                                                                     \
                }                                                                                             \
                return 1;                                                                                     \
            }                                                                                                 \
            /* Asked for together, so their misses overlap instead of coming one test at a time. */         \
            prefetch_leaf_triangles(tree, leaf);                                                              \
            compiled_test_leaf(w, c, tree, leaf);                                                             \
            return !w->done && c->top > 0;                                                                    \
        }                                                                                                     \
        const traversal_node *n = &tree->traversal.nodes[e.ref];                                              \
        float tnear[8];                                                                                       \
        unsigned met = rank_of_lanes[c->f.near_upper][NODE_TEST(n, &c->f, c->lo, c->bound, tnear)];           \
        /* Pushed far to near, so the nearest is popped first. */                                            \
        while (met) {                                                                                         \
            int j = 31 - __builtin_clz(met);                                                                  \
            met &= ~(1u << j);                                                                                \
            int lane = j ^ (int)c->f.near_upper;                                                              \
            uint32_t child = n->child[lane];                                                                  \
            c->stack[c->top++] = (float_entry){tnear[lane], child};                                           \
            if (!pipelined)                                                                                   \
                prefetch_compiled_child(tree, child);                                                         \
        }                                                                                                     \
        if (pipelined)                                                                                        \
            compiled_prefetch_next(c, tree);                                                                  \
        return c->top > 0;                                                                                    \
    }                                                                                                         \
                                                                                                              \
    TARGET static void compiled_run_##SUFFIX(ray_walk *w, compiled_walk *c, const octree *tree)              \
    {                                                                                                         \
        while (compiled_step_##SUFFIX(w, c, tree, 0))                                                         \
            ;                                                                                                 \
    }                                                                                                         \
                                                                                                              \
    /* Round robin over the slots, one step each: each step ends by asking for what that walk reads \
     * next, which arrives while the other walks take their steps. A finished slot takes the next ray. */  \
    TARGET static void compiled_stream_##SUFFIX(compiled_stream *s, const octree *tree)                      \
    {                                                                                                         \
        while (s->live > 0)                                                                                   \
            for (int k = 0; k < RAY_STREAM_WIDTH; k++) {                                                      \
                if (s->ray_of[k] == s->count)                                                                 \
                    continue;                                                                                 \
                if (compiled_step_##SUFFIX(&s->walks[k], &s->compiled[k], tree, 1))                           \
                    continue;                                                                                 \
                compiled_stream_next(s, tree, k);                                                             \
            }                                                                                                 \
    }

/* A batch of rays walking the compiled form side by side (octree_ray_stream). */
typedef struct compiled_stream {
    const ray_input *rays;
    size_t count, next;
    ray_detail detail;
    accuracy_mode mode;
    ray_output *outs;
    octree_status *statuses;
    octree_status batch;
    query_stats sum;
    int live;
    size_t ray_of[RAY_STREAM_WIDTH];
    ray_walk walks[RAY_STREAM_WIDTH];
    compiled_walk compiled[RAY_STREAM_WIDTH];
} compiled_stream;

static void add_walk_counts(query_stats *sum, const ray_walk *w);

/* Ends slot k's ray, if it has one, and starts the next ray that can take the compiled
 * walk in it; rays that cannot are answered on the spot by the double walk. */
static void compiled_stream_next(compiled_stream *s, const octree *tree, int k)
{
    if (s->ray_of[k] < s->count) {
        size_t i = s->ray_of[k];
        s->statuses[i] = walk_finish(&s->walks[k], tree, &s->outs[i]);
        if (s->statuses[i] == OCTREE_ERR_NOMEM)
            s->batch = OCTREE_ERR_NOMEM;
        add_walk_counts(&s->sum, &s->walks[k]);
        s->live--;
    }
    s->ray_of[k] = s->count;
    while (s->next < s->count) {
        size_t i = s->next++;
        octree_status st = check_query(&s->rays[i], s->detail, s->mode);
        if (st != OCTREE_OK) {
            s->statuses[i] = st;
            continue;
        }
        ray_walk *w = &s->walks[k];
        walk_init(w, tree, &s->rays[i], s->detail, s->mode, &s->outs[i]);
        if (compiled_begin(&s->compiled[k], w, tree)) {
            s->ray_of[k] = i;
            s->live++;
            return;
        }
        walk_double(w, tree);
        s->statuses[i] = walk_finish(w, tree, &s->outs[i]);
        if (s->statuses[i] == OCTREE_ERR_NOMEM)
            s->batch = OCTREE_ERR_NOMEM;
        add_walk_counts(&s->sum, w);
    }
}

#ifdef FLOAT_WALK_SIMD
DEFINE_COMPILED_STEP(sse2, , node_children_met_sse2)
DEFINE_COMPILED_STEP(avx2, FLOAT_WALK_AVX2, node_children_met_avx2)
#else
DEFINE_COMPILED_STEP(scalar, , node_children_met_scalar)
#endif

#ifdef FLOAT_WALK_SIMD
/* Lanes 0-7 of a node's quantized row at byte offset `at` of its record, as bounds. */
FLOAT_WALK_AVX2 static inline __m256 row_at_avx2(const traversal_node *n, size_t at, __m256 scale, __m256 origin)
{
    return row_avx2((const uint8_t *)n + at, scale, origin);
}

/* A lone exact crossing's walk, closest or any hit, over the compiled form with AVX2:
 * compiled_step's tests in compiled_step's order, with the ray's constants held in
 * registers for the whole walk. Through the generic step they were read back from the
 * walk at every node (its stores to the stack may alias them, as far as the compiler
 * knows), which cost a third of a node step. */
FLOAT_WALK_AVX2 static void compiled_run_filtered_avx2(ray_walk *w, compiled_walk *c, const octree *tree)
{
    const float_ray f = c->f;
    const size_t q0 = offsetof(traversal_node, q);
    const size_t near0 = q0 + 8 * (size_t)f.near_row[0], near1 = q0 + 8 * (size_t)f.near_row[1],
                 near2 = q0 + 8 * (size_t)f.near_row[2];
    const size_t far0 = q0 + 8 * (size_t)f.far_row[0], far1 = q0 + 8 * (size_t)f.far_row[1],
                 far2 = q0 + 8 * (size_t)f.far_row[2];
    const __m256 on0 = _mm256_set1_ps(f.o_near[0]), on1 = _mm256_set1_ps(f.o_near[1]),
                 on2 = _mm256_set1_ps(f.o_near[2]);
    const __m256 of0 = _mm256_set1_ps(f.o_far[0]), of1 = _mm256_set1_ps(f.o_far[1]),
                 of2 = _mm256_set1_ps(f.o_far[2]);
    const __m256 inv0 = _mm256_set1_ps(f.inv[0]), inv1 = _mm256_set1_ps(f.inv[1]), inv2 = _mm256_set1_ps(f.inv[2]);
    const __m256 sign = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    const __m256 rel = _mm256_set1_ps(FLOAT_WALK_REL), absw = _mm256_set1_ps(FLOAT_WALK_ABS);
    const __m256i none = _mm256_set1_epi32(-1);
    const unsigned char *rank = rank_of_lanes[f.near_upper];
    const unsigned flip = f.near_upper;
    const traversal_node *nodes = tree->traversal.nodes;
    float_entry *stack = c->stack;
    size_t top = c->top;
    const __m256 lo = _mm256_set1_ps(c->lo);
    float bound = c->bound;
    uint64_t visited = 0, leaves = 0;
    float_entry e;
    while (top > 0) {
        e = stack[--top];
        if (e.tnear > bound) /* a nearer hit was found after this entry was pushed */
            continue;
    next:
        visited++;
        if (e.ref & TRAVERSAL_LEAF) {
            octree_node leaf = octree_leaf_of_ref(tree, e.ref);
            leaves++;
            /* Asked for together, so their misses overlap instead of coming one test at a time. */
            prefetch_leaf_triangles(tree, leaf);
            walk_test_leaf_filtered(w, tree, leaf);
            if (w->done)
                break;
            bound = float_at_or_above(w->bound);
            continue;
        }
        const traversal_node *n = &nodes[e.ref];
        __m256 scale = _mm256_set1_ps(n->scale);
        __m256 x = _mm256_set1_ps(n->origin[0]), y = _mm256_set1_ps(n->origin[1]), z = _mm256_set1_ps(n->origin[2]);
        __m256 tn = _mm256_max_ps(_mm256_mul_ps(_mm256_sub_ps(row_at_avx2(n, near0, scale, x), on0), inv0), lo);
        __m256 tf = _mm256_min_ps(_mm256_mul_ps(_mm256_sub_ps(row_at_avx2(n, far0, scale, x), of0), inv0),
                                  _mm256_set1_ps(bound));
        tn = _mm256_max_ps(_mm256_mul_ps(_mm256_sub_ps(row_at_avx2(n, near1, scale, y), on1), inv1), tn);
        tf = _mm256_min_ps(_mm256_mul_ps(_mm256_sub_ps(row_at_avx2(n, far1, scale, y), of1), inv1), tf);
        tn = _mm256_max_ps(_mm256_mul_ps(_mm256_sub_ps(row_at_avx2(n, near2, scale, z), on2), inv2), tn);
        tf = _mm256_min_ps(_mm256_mul_ps(_mm256_sub_ps(row_at_avx2(n, far2, scale, z), of2), inv2), tf);
        __m256 tn_w = _mm256_sub_ps(_mm256_sub_ps(tn, _mm256_mul_ps(_mm256_and_ps(tn, sign), rel)), absw);
        __m256 tf_w = _mm256_add_ps(_mm256_add_ps(tf, _mm256_mul_ps(_mm256_and_ps(tf, sign), rel)), absw);
        __m256i empty = _mm256_cmpeq_epi32(_mm256_loadu_si256((const __m256i *)n->child), none);
        __m256 ok = _mm256_andnot_ps(_mm256_castsi256_ps(empty), _mm256_cmp_ps(tn_w, tf_w, _CMP_LE_OQ));
        float tnear[8];
        _mm256_storeu_ps(tnear, tn_w);
        unsigned met = rank[_mm256_movemask_ps(ok)];
        if (!met)
            continue;
        /* The others pushed far to near, so the nearest of them is popped first; the
         * nearest child is taken at once, as the pop would take it next. */
        unsigned nearest = (unsigned)__builtin_ctz(met);
        met &= met - 1;
        while (met) {
            int j = 31 - __builtin_clz(met);
            met &= ~(1u << j);
            unsigned lane = (unsigned)j ^ flip;
            uint32_t child = n->child[lane];
            stack[top++] = (float_entry){tnear[lane], child};
            prefetch_compiled_child(tree, child);
        }
        e = (float_entry){tnear[nearest ^ flip], n->child[nearest ^ flip]};
        /* The pop's own test: the widened entry parameter may pass the bound. */
        if (e.tnear > bound)
            continue;
        goto next;
    }
    w->local.nodes_visited += visited;
    w->local.leaves_visited += leaves;
    c->top = 0;
    c->bound = bound;
}
#endif

static void compiled_run(ray_walk *w, compiled_walk *c, const octree *tree)
{
#ifdef FLOAT_WALK_SIMD
    if (tree->traversal.avx2 && c->f.filtered)
        compiled_run_filtered_avx2(w, c, tree);
    else if (tree->traversal.avx2)
        compiled_run_avx2(w, c, tree);
    else
        compiled_run_sse2(w, c, tree);
#else
    compiled_run_scalar(w, c, tree);
#endif
}

/* Answers a batch over the compiled form, RAY_STREAM_WIDTH rays in flight, into *batch;
 * -1 (nothing answered) when the stream's own memory could not be had. */
static int compiled_stream_run(const octree *tree, const ray_input *rays, size_t count, ray_detail detail,
                               accuracy_mode mode, ray_output *outs, octree_status *statuses, query_stats *stats,
                               octree_status *batch)
{
    compiled_stream *s = malloc(sizeof *s);
    if (!s)
        return -1;
    uint64_t fallbacks_before = predicates_fallback_count();
    *s = (compiled_stream){.rays = rays, .count = count, .detail = detail, .mode = mode, .outs = outs,
                           .statuses = statuses, .batch = OCTREE_OK};
    for (int k = 0; k < RAY_STREAM_WIDTH; k++) {
        s->ray_of[k] = count;
        compiled_stream_next(s, tree, k);
    }
#ifdef FLOAT_WALK_SIMD
    if (tree->traversal.avx2)
        compiled_stream_avx2(s, tree);
    else
        compiled_stream_sse2(s, tree);
#else
    compiled_stream_scalar(s, tree);
#endif
    *batch = s->batch;
    /* Every ray runs the same predicates as alone, so the batch's fallbacks are the sum of
     * the rays' own. */
    query_stats_finish(stats, &s->sum, fallbacks_before, predicates_fallback_count());
    free(s);
    return 0;
}

/* Runs a walk begun by walk_init to its end, over the compiled form when the ray can take
 * it, else by the double walk. */
static void walk_alone(ray_walk *w, const octree *tree)
{
    compiled_walk c;
    if (compiled_begin(&c, w, tree)) {
        compiled_run(w, &c, tree);
        return;
    }
    walk_double(w, tree);
}

octree_status octree_ray(const octree *tree, const ray_input *ray, ray_detail detail, accuracy_mode mode,
                         ray_output *out, query_stats *stats)
{
    octree_status st = check_query(ray, detail, mode);
    if (st != OCTREE_OK)
        return st;
    uint64_t fallbacks_before = predicates_fallback_count();
    ray_walk w;
    walk_init(&w, tree, ray, detail, mode, out);
    walk_alone(&w, tree);
    st = walk_finish(&w, tree, out);
    query_stats_finish(stats, &w.local, fallbacks_before, predicates_fallback_count());
    return st;
}

octree_status octree_ray_posed(const octree *tree, const pose *at, const ray_input *ray, ray_detail detail,
                               accuracy_mode mode, ray_output *out, query_stats *stats)
{
    if (!tree || !at || !out)
        return OCTREE_ERR_INVALID;
    octree_status st = check_query(ray, detail, mode);
    if (st != OCTREE_OK)
        return st;
    if (mode != ACCURACY_EXACT)
        return OCTREE_ERR_INVALID;
    posed_ray posed;
    st = octree_posed_ray_setup(tree, at, ray, &posed);
    if (st != OCTREE_OK)
        return st;
    out->hit_count = 0;
    out->truncated = 0;
    if (posed.misses)
        return OCTREE_OK;
    uint64_t fallbacks_before = predicates_fallback_count();
    ray_walk w;
    walk_init_posed(&w, tree, ray, &posed, detail, mode, out);
    walk_alone(&w, tree);
    st = walk_finish(&w, tree, out);
    query_stats_finish(stats, &w.local, fallbacks_before, predicates_fallback_count());
    return st;
}

octree_status octree_ray_check(const ray_input *ray, ray_detail detail, accuracy_mode mode)
{
    return ray ? check_query(ray, detail, mode) : OCTREE_ERR_INVALID;
}

int octree_ray_hit_order(const ray_input *ray, const vec3 a[3], const vec3 b[3])
{
    return exact_hit_order(ray->origin, ray->direction, ray->tmin, ray->tmax, ray->contact == RAY_TOUCH, a, b);
}

/* Rays from one origin (a camera image, a lidar scan) in visiting-order groups of up to
 * PACKET_RAYS walk the tree together: a node is popped, its planes derived and its
 * children's records read once for the group, and each ray's own intervals are computed
 * side by side, which the processor overlaps, where one ray at a time waits on each step
 * of its walk in turn. Each ray visits exactly the nodes, in exactly the order, that it
 * would alone (the group shares the visiting order; a child is entered by the rays that
 * meet it; a ray leaves an entry once its bound passes it), so the answers and the counts
 * are the same. */
#define PACKET_RAYS 4

typedef struct packet_entry {
    double tnear[PACKET_RAYS], tfar[PACKET_RAYS]; /* set for the active rays only */
    uint32_t node;
    unsigned char level;
    unsigned char upper;
    unsigned char active; /* bit i: ray i of the packet meets the node */
} packet_entry;

typedef struct ray_packet {
    ray_walk *walk[PACKET_RAYS];
    int count;
    packet_entry stack[OCTREE_STACK_MAX];
    double level_planes[OCTREE_MAX_DEPTH_CAP + 1][3][3];
} ray_packet;

/* Runs the packet's walks, each begun by walk_begin and sharing one visiting order, to
 * their end. */
static void packet_run(ray_packet *p, const octree *tree)
{
    const ray_setup *order = &p->walk[0]->r;
    size_t top = 0;
    packet_entry root = {.node = 0, .level = 0, .upper = 0, .active = 0};
    for (int i = 0; i < p->count; i++) {
        ray_walk *w = p->walk[i];
        if (w->top == 0)
            continue;
        root.tnear[i] = w->stack[0].tnear;
        root.tfar[i] = w->stack[0].tfar;
        root.active |= (unsigned char)(1u << i);
        w->top = 0;
    }
    if (root.active)
        p->stack[top++] = root;
    while (top > 0) {
        /* Copied: the first child pushed overwrites the slot. */
        packet_entry e = p->stack[--top];
        unsigned active = 0;
        for (int i = 0; i < p->count; i++)
            if (((e.active >> i) & 1) && !p->walk[i]->done && e.tnear[i] <= p->walk[i]->bound)
                active |= 1u << i;
        if (!active)
            continue;
        octree_node node = tree->nodes[e.node];
        if (node.count != NODE_INTERIOR) {
            prefetch_leaf_triangles(tree, node);
            for (int i = 0; i < p->count; i++) {
                if (!((active >> i) & 1))
                    continue;
                p->walk[i]->local.nodes_visited++;
                p->walk[i]->local.leaves_visited++;
                walk_test_leaf(p->walk[i], tree, node);
            }
            continue;
        }
        entry_planes(p->level_planes, tree, e.level, e.upper);
        const double(*planes)[3] = (const double(*)[3])p->level_planes[e.level];
        unsigned nonempty = children_nonempty(tree, node, order->octant);
        double tnear[PACKET_RAYS][8], tfar[PACKET_RAYS][8];
        unsigned met[PACKET_RAYS] = {0}, any = 0;
        for (int i = 0; i < p->count; i++) {
            if (!((active >> i) & 1))
                continue;
            ray_walk *w = p->walk[i];
            w->local.nodes_visited++;
            met[i] = children_met(w, e.tnear[i], e.tfar[i], planes, tnear[i], tfar[i]) & nonempty;
            any |= met[i];
        }
        /* Pushed far to near, so the nearest is popped first. */
        unsigned char level = (unsigned char)(e.level + 1);
        while (any) {
            int j = 31 - __builtin_clz(any);
            any &= ~(1u << j);
            packet_entry child = {.node = node.first + order->octant[j], .level = level, .upper = order->upper[j]};
            for (int i = 0; i < p->count; i++) {
                if (!((met[i] >> j) & 1))
                    continue;
                child.active |= (unsigned char)(1u << i);
                child.tnear[i] = tnear[i][j];
                child.tfar[i] = tfar[i][j];
            }
            p->stack[top++] = child;
            prefetch_child(tree, child.node);
        }
    }
}

/* Starts the walk of the next valid ray from *next on, giving each invalid one its status
 * on the way. Returns the ray's index, or count when none is left. */
static size_t walk_start_next(ray_walk *w, const octree *tree, const ray_input *rays, size_t count,
                                size_t *next, ray_detail detail, accuracy_mode mode, ray_output *outs,
                                octree_status *statuses)
{
    while (*next < count) {
        size_t i = (*next)++;
        octree_status st = check_query(&rays[i], detail, mode);
        if (st != OCTREE_OK) {
            statuses[i] = st;
            continue;
        }
        walk_begin(w, tree, &rays[i], detail, mode, &outs[i]);
        return i;
    }
    return count;
}

/* Every ray answered by octree_ray, when a batch could not get its walks' memory. */
static octree_status rays_one_at_a_time(const octree *tree, const ray_input *rays, size_t count, ray_detail detail,
                                        accuracy_mode mode, ray_output *outs, octree_status *statuses,
                                        query_stats *stats)
{
    octree_status batch = OCTREE_OK;
    for (size_t i = 0; i < count; i++) {
        statuses[i] = octree_ray(tree, &rays[i], detail, mode, &outs[i], stats);
        if (statuses[i] == OCTREE_ERR_NOMEM)
            batch = OCTREE_ERR_NOMEM;
    }
    return batch;
}

/* A finished walk's counters, into a batch's sum (whose fallbacks query_stats_finish
 * counts once for the batch). */
static void add_walk_counts(query_stats *sum, const ray_walk *w)
{
    sum->nodes_visited += w->local.nodes_visited;
    sum->leaves_visited += w->local.leaves_visited;
    sum->candidates_tested += w->local.candidates_tested;
}

#ifdef FLOAT_WALK_SIMD
/* ---------- rays from one origin, side by side over the compiled form ---------- */

/* Rays from one origin that share a visiting order (a camera's, a lidar's), up to eight,
 * walk the compiled form together, one ray to a lane of an AVX2 register: a node's record
 * is read once for all of them and each child's planes are taken once, then multiplied by
 * each ray's own 1/d; a leaf's triangles are read once and their edges' cross products
 * shared (ray_fan_misses). Each ray meets its entries in the order it would alone, tests
 * each child with exactly its own walk's arithmetic and bound, and stops where it would
 * alone, so every answer is octree_ray's. */
/* At most this many rays left in a subtree walk it one by one: a fan's node test costs
 * about as much as a few lone ones (callgrind, a 256x256 camera on Wuson x4^3: 1, 2, 3, 4
 * gave 3.20k, 3.06k, 3.06k, 3.09k instructions a ray). */
#ifndef FAN_ALONE_MAX
#define FAN_ALONE_MAX 2
#endif

typedef struct fan_entry {
    float tnear[RAY_FAN_MAX];
    uint32_t ref;
    unsigned rays; /* bit i: ray i met the node */
} fan_entry;

typedef struct compiled_fan {
    unsigned count;
    ray_walk *walk[RAY_FAN_MAX];
    size_t ray_of[RAY_FAN_MAX];
    float_ray f; /* the first ray's: the origin's floats, the rows and the order are shared */
    float_ray own[RAY_FAN_MAX]; /* each ray's, for the subtrees it walks alone */
    compiled_walk alone;
    float inv[3][RAY_FAN_MAX];
    float lo[RAY_FAN_MAX], bound[RAY_FAN_MAX];
    unsigned done; /* rays whose walk is over (an any hit, or out of memory) */
    ray_fan fan;
    fan_entry stack[FLOAT_STACK_MAX]; /* as one walk's: 7 siblings a level plus the node */
} compiled_fan;

/* The children of n that each live ray meets (rays[k] for lane k, with its entry
 * parameters in tnear[k]), and the lanes some ray meets. Per ray and lane this is
 * node_children_met_avx2's arithmetic: (origin + q scale - o_near) * inv, max and min
 * against the ray's interval in the same operand order, the same widening. */
FLOAT_WALK_AVX2 static unsigned fan_children_met(const traversal_node *n, const compiled_fan *p, unsigned live,
                                                 unsigned rays[8], float tnear[8][RAY_FAN_MAX])
{
    const float_ray *f = &p->f;
    __m256 scale = _mm256_set1_ps(n->scale);
    float near_d[3][8], far_d[3][8];
    for (int a = 0; a < 3; a++) {
        __m256 origin = _mm256_set1_ps(n->origin[a]);
        _mm256_storeu_ps(near_d[a], _mm256_sub_ps(row_avx2(n->q[f->near_row[a]], scale, origin), _mm256_set1_ps(f->o_near[a])));
        _mm256_storeu_ps(far_d[a], _mm256_sub_ps(row_avx2(n->q[f->far_row[a]], scale, origin), _mm256_set1_ps(f->o_far[a])));
    }
    __m256i empty = _mm256_cmpeq_epi32(_mm256_loadu_si256((const __m256i *)n->child), _mm256_set1_epi32(-1));
    unsigned lanes = ~(unsigned)_mm256_movemask_ps(_mm256_castsi256_ps(empty)) & 0xffu;
    __m256 inv[3] = {_mm256_loadu_ps(p->inv[0]), _mm256_loadu_ps(p->inv[1]), _mm256_loadu_ps(p->inv[2])};
    __m256 lo = _mm256_loadu_ps(p->lo), hi = _mm256_loadu_ps(p->bound);
    __m256 sign = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    __m256 rel = _mm256_set1_ps(FLOAT_WALK_REL), absw = _mm256_set1_ps(FLOAT_WALK_ABS);
    unsigned met = 0;
    while (lanes) {
        int k = __builtin_ctz(lanes);
        lanes &= lanes - 1;
        __m256 tn = lo, tf = hi;
        for (int a = 0; a < 3; a++) {
            tn = _mm256_max_ps(_mm256_mul_ps(_mm256_set1_ps(near_d[a][k]), inv[a]), tn);
            tf = _mm256_min_ps(_mm256_mul_ps(_mm256_set1_ps(far_d[a][k]), inv[a]), tf);
        }
        __m256 tn_w = _mm256_sub_ps(_mm256_sub_ps(tn, _mm256_mul_ps(_mm256_and_ps(tn, sign), rel)), absw);
        __m256 tf_w = _mm256_add_ps(_mm256_add_ps(tf, _mm256_mul_ps(_mm256_and_ps(tf, sign), rel)), absw);
        unsigned r = (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(tn_w, tf_w, _CMP_LE_OQ)) & live;
        if (!r)
            continue;
        rays[k] = r;
        _mm256_storeu_ps(tnear[k], tn_w);
        met |= 1u << k;
    }
    return met;
}

/* A leaf's candidates against its live rays, in list order: each triangle's vertices read
 * once, the rays it surely misses ruled out together, the full test for each other ray
 * (walk_test_unique). Four at a time, counted as a ray's own filtered leaf counts them
 * (walk_test_leaf_filtered), so the counters are the lone ray's too. */
static void fan_test_leaf(compiled_fan *p, const octree *tree, octree_node leaf, unsigned live)
{
    const uint32_t *ids = &tree->leaf_items[leaf.first];
    unsigned tested = live;
    for (uint32_t i = 0; i < leaf.count && live; i += 4) {
        unsigned k = leaf.count - i < 4 ? leaf.count - i : 4;
        unsigned miss[4];
        for (unsigned j = 0; j < k; j++) {
            vec3 tri[3];
            octree_triangle_vertices(tree, ids[i + j], tri);
            miss[j] = ray_fan_misses(&p->fan, tri, 1) & live;
        }
        for (unsigned j = 0; j < k; j++)
            for (unsigned m = miss[j]; m; m &= m - 1)
                p->walk[__builtin_ctz(m)]->local.candidates_tested++;
        for (unsigned j = 0; j < k; j++)
            for (unsigned t = live & ~miss[j]; t; t &= t - 1) {
                unsigned r = (unsigned)__builtin_ctz(t);
                if (!walk_test_unique(p->walk[r], tree, ids[i + j])) {
                    p->done |= 1u << r;
                    live &= ~(1u << r);
                }
            }
    }
    for (unsigned t = tested; t; t &= t - 1) {
        unsigned r = (unsigned)__builtin_ctz(t);
        p->bound[r] = float_at_or_above(p->walk[r]->bound);
    }
}

FLOAT_WALK_AVX2 static void fan_run(compiled_fan *p, const octree *tree)
{
    size_t top = 0;
    p->done = 0;
    if (tree->traversal.root != TRAVERSAL_EMPTY) {
        fan_entry *root = &p->stack[top++];
        for (int i = 0; i < RAY_FAN_MAX; i++)
            root->tnear[i] = -INFINITY;
        root->ref = tree->traversal.root;
        root->rays = (1u << p->count) - 1;
    }
    while (top > 0) {
        fan_entry e = p->stack[--top]; /* copied: the first child pushed takes its slot */
        __m256 within = _mm256_cmp_ps(_mm256_loadu_ps(e.tnear), _mm256_loadu_ps(p->bound), _CMP_LE_OQ);
        unsigned live = e.rays & ~p->done & (unsigned)_mm256_movemask_ps(within);
        if (!live)
            continue;
        if (bits_set8(live) <= FAN_ALONE_MAX) {
            /* Few rays left in this subtree: each walks it on its own, one after the other
             * (each ray's walk would have taken the subtree next), with the single ray's
             * cheaper steps; rays are independent, so their order does not matter. */
            for (unsigned t = live; t; t &= t - 1) {
                unsigned r = (unsigned)__builtin_ctz(t);
                compiled_walk *c = &p->alone;
                c->f = p->own[r];
                c->lo = p->lo[r];
                c->bound = p->bound[r];
                c->pending_leaf = NO_PENDING_LEAF;
                c->top = 1;
                c->stack[0] = (float_entry){e.tnear[r], e.ref};
                compiled_run(p->walk[r], c, tree);
                p->bound[r] = float_at_or_above(p->walk[r]->bound);
                if (p->walk[r]->done)
                    p->done |= 1u << r;
            }
            continue;
        }
        for (unsigned t = live; t; t &= t - 1)
            p->walk[__builtin_ctz(t)]->local.nodes_visited++;
        if (e.ref & TRAVERSAL_LEAF) {
            octree_node leaf = octree_leaf_of_ref(tree, e.ref);
            for (unsigned t = live; t; t &= t - 1)
                p->walk[__builtin_ctz(t)]->local.leaves_visited++;
            prefetch_leaf_triangles(tree, leaf);
            fan_test_leaf(p, tree, leaf, live);
            continue;
        }
        const traversal_node *n = &tree->traversal.nodes[e.ref];
        unsigned rays[8];
        float tnear[8][RAY_FAN_MAX];
        unsigned met = rank_of_lanes[p->f.near_upper][fan_children_met(n, p, live, rays, tnear)];
        /* Pushed far to near, so the nearest is popped first. */
        while (met) {
            int j = 31 - __builtin_clz(met);
            met &= ~(1u << j);
            int lane = j ^ (int)p->f.near_upper;
            fan_entry *c = &p->stack[top++];
            memcpy(c->tnear, tnear[lane], sizeof c->tnear);
            c->ref = n->child[lane];
            c->rays = rays[lane];
            prefetch_compiled_child(tree, c->ref);
        }
    }
}

/* Takes ray i into the fan being formed, when it can walk the compiled form with the
 * fan's first ray's order and origin floats: 1 taken, 0 it begins the next fan. A ray that
 * cannot walk the compiled form at all (or an invalid one) is answered on the spot: -1. */
static int fan_take(compiled_fan *p, ray_walk *w, const octree *tree, const ray_input *ray, size_t i,
                    ray_detail detail, accuracy_mode mode, ray_output *out, octree_status *status,
                    query_stats *sum)
{
    octree_status st = check_query(ray, detail, mode);
    if (st != OCTREE_OK) {
        *status = st;
        return -1;
    }
    walk_init(w, tree, ray, detail, mode, out); /* exact mode: nothing held yet */
    float_ray f;
    if (w->done || w->r.touch || !float_ray_setup(&f, tree, &w->r)) {
        walk_alone(w, tree);
        *status = walk_finish(w, tree, out);
        add_walk_counts(sum, w);
        return -1;
    }
    if (p->count > 0 && (f.near_upper != p->f.near_upper || memcmp(f.o_near, p->f.o_near, sizeof f.o_near) ||
                         memcmp(f.o_far, p->f.o_far, sizeof f.o_far)))
        return 0;
    unsigned k = p->count++;
    if (k == 0)
        p->f = f;
    p->walk[k] = w;
    p->ray_of[k] = i;
    f.filtered = 1;
    p->own[k] = f;
    for (int a = 0; a < 3; a++)
        p->inv[a][k] = f.inv[a];
    p->lo[k] = float_at_or_below(w->r.tmin);
    p->bound[k] = float_at_or_above(w->bound);
    return 1;
}

/* octree_ray_batch for rays from one origin, exact crossings, closest or any hit, over a
 * compiled form on a processor with AVX2. */
octree_status octree_ray_fans(const octree *tree, const ray_input *rays, size_t count, ray_detail detail,
                              accuracy_mode mode, ray_output *outs, octree_status *statuses, query_stats *stats)
{
    compiled_fan *p = malloc(sizeof *p);
    ray_walk *walks = malloc(RAY_FAN_MAX * sizeof *walks);
    if (!p || !walks) {
        free(p);
        free(walks);
        return rays_one_at_a_time(tree, rays, count, detail, mode, outs, statuses, stats);
    }
    octree_status batch = OCTREE_OK;
    uint64_t fallbacks_before = predicates_fallback_count();
    query_stats sum = {0};
    size_t i = 0;
    while (i < count) {
        p->count = 0;
        while (p->count < RAY_FAN_MAX && i < count) {
            int taken = fan_take(p, &walks[p->count], tree, &rays[i], i, detail, mode, &outs[i], &statuses[i],
                                 &sum);
            if (taken == 0)
                break;
            if (taken < 0 && statuses[i] == OCTREE_ERR_NOMEM)
                batch = OCTREE_ERR_NOMEM;
            i++;
        }
        if (p->count == 0)
            continue;
        vec3 dirs[RAY_FAN_MAX];
        for (unsigned k = 0; k < p->count; k++)
            dirs[k] = p->walk[k]->r.d;
        for (unsigned k = p->count; k < RAY_FAN_MAX; k++) { /* unused lanes repeat the first ray */
            for (int a = 0; a < 3; a++)
                p->inv[a][k] = p->inv[a][0];
            p->lo[k] = p->lo[0];
            p->bound[k] = p->bound[0];
        }
        ray_fan_init(&p->fan, p->walk[0]->r.o, dirs, p->count);
        fan_run(p, tree);
        for (unsigned k = 0; k < p->count; k++) {
            size_t r = p->ray_of[k];
            statuses[r] = walk_finish(p->walk[k], tree, &outs[r]);
            if (statuses[r] == OCTREE_ERR_NOMEM)
                batch = OCTREE_ERR_NOMEM;
            add_walk_counts(&sum, p->walk[k]);
        }
    }
    free(p);
    free(walks);
    query_stats_finish(stats, &sum, fallbacks_before, predicates_fallback_count());
    return batch;
}
#endif

octree_status octree_ray_packets(const octree *tree, const ray_input *rays, size_t count, ray_detail detail,
                                 accuracy_mode mode, ray_output *outs, octree_status *statuses,
                                 query_stats *stats)
{
    octree_status batch = OCTREE_OK;
    ray_walk *walks = malloc(PACKET_RAYS * sizeof *walks);
    ray_packet *p = malloc(sizeof *p);
    if (!walks || !p) {
        free(walks);
        free(p);
        return rays_one_at_a_time(tree, rays, count, detail, mode, outs, statuses, stats);
    }
    uint64_t fallbacks_before = predicates_fallback_count();
    query_stats sum = {0};
    size_t ray_of[PACKET_RAYS];
    size_t i = 0;
    while (i < count) {
        /* The next run of valid rays sharing a visiting order, up to PACKET_RAYS. */
        p->count = 0;
        while (p->count < PACKET_RAYS) {
            ray_walk *w = &walks[p->count];
            size_t at = walk_start_next(w, tree, rays, count, &i, detail, mode, outs, statuses);
            if (at == count)
                break;
            if (p->count > 0 && memcmp(w->r.upper, walks[0].r.upper, sizeof w->r.upper) != 0) {
                id_set_release(&w->tested);
                i = at; /* begins the next packet */
                break;
            }
            p->walk[p->count] = w;
            ray_of[p->count++] = at;
        }
        packet_run(p, tree);
        for (int k = 0; k < p->count; k++) {
            size_t r = ray_of[k];
            statuses[r] = walk_finish(&walks[k], tree, &outs[r]);
            if (statuses[r] == OCTREE_ERR_NOMEM)
                batch = OCTREE_ERR_NOMEM;
            add_walk_counts(&sum, &walks[k]);
        }
    }
    free(walks);
    free(p);
    query_stats_finish(stats, &sum, fallbacks_before, predicates_fallback_count());
    return batch;
}

octree_status octree_ray_stream(const octree *tree, const ray_input *rays, size_t count, ray_detail detail,
                                accuracy_mode mode, ray_output *outs, octree_status *statuses,
                                query_stats *stats)
{
    if (tree->traversal.present) {
        octree_status batch;
        if (compiled_stream_run(tree, rays, count, detail, mode, outs, statuses, stats, &batch) == 0)
            return batch;
        /* Without the memory for the stream the rays still get their answers, one at a time. */
        return rays_one_at_a_time(tree, rays, count, detail, mode, outs, statuses, stats);
    }
    octree_status batch = OCTREE_OK;
    /* Walks are large (their stacks): on the heap, once per batch. Without the memory the
     * rays still get their answers, one at a time. */
    ray_walk *walks = malloc(RAY_STREAM_WIDTH * sizeof *walks);
    if (!walks)
        return rays_one_at_a_time(tree, rays, count, detail, mode, outs, statuses, stats);
    uint64_t fallbacks_before = predicates_fallback_count();
    query_stats sum = {0};
    size_t ray_of[RAY_STREAM_WIDTH];
    size_t next = 0;
    int live = 0;
    for (int s = 0; s < RAY_STREAM_WIDTH; s++) {
        ray_of[s] = walk_start_next(&walks[s], tree, rays, count, &next, detail, mode, outs, statuses);
        live += ray_of[s] < count;
    }
    /* Round robin, one step per walk: each step ends by prefetching what that walk reads
     * next, which then arrives while the other walks take their steps. A finished walk's
     * slot takes the next ray at once, so the stream stays full until the rays run out. */
    while (live > 0) {
        for (int s = 0; s < RAY_STREAM_WIDTH; s++) {
            if (ray_of[s] == count || walk_step(&walks[s], tree, 1))
                continue;
            size_t i = ray_of[s];
            statuses[i] = walk_finish(&walks[s], tree, &outs[i]);
            if (statuses[i] == OCTREE_ERR_NOMEM)
                batch = OCTREE_ERR_NOMEM;
            add_walk_counts(&sum, &walks[s]);
            ray_of[s] = walk_start_next(&walks[s], tree, rays, count, &next, detail, mode, outs, statuses);
            live -= ray_of[s] == count;
        }
    }
    free(walks);
    /* Every ray runs the same predicates as alone, so the batch's fallbacks are the sum of
     * the rays' own. */
    query_stats_finish(stats, &sum, fallbacks_before, predicates_fallback_count());
    return batch;
}
