/* Accuracy report (issue 3): what each accuracy mode costs in time and gets wrong, swept over
 * seed epsilon and octree resolution on real, generated and CAD-like scenes. Writes raw TSVs,
 * plot tables for scripts/accuracy_report.sh, and docs/accuracy.md. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "array_reserve.h"
#include "engine.h"
#include "support/hard_cases.h"
#include "support/meshgen.h"
#include "support/oracle.h"
#include "support/oracle_mesh.h"
#include "support/query_shapes.h"
#include "support/real_meshes.h"

/* ---------- the sweep ---------- */

/* Resolution factors applied to the seed's heuristic d. */
static const double RES_FACTORS[] = {0.25, 0.5, 1.0, 2.0, 4.0};
#define RES_COUNT (sizeof RES_FACTORS / sizeof RES_FACTORS[0])
#define RES_DEFAULT_INDEX 2

typedef struct mode_setting {
    accuracy_mode mode;
    double eps; /* seed only */
    const char *label;
} mode_setting;

static const mode_setting SETTINGS[] = {
    {ACCURACY_EXACT, 0, "exact"},          {ACCURACY_SEED, 1e-12, "seed 1e-12"},
    {ACCURACY_SEED, 1e-9, "seed 1e-9"},    {ACCURACY_SEED, 1e-6, "seed 1e-6"},
    {ACCURACY_SEED, 1e-3, "seed 1e-3"},    {ACCURACY_FAST, 0, "fast"},
};
#define SETTING_COUNT (sizeof SETTINGS / sizeof SETTINGS[0])
/* The seed setting the resolution plot follows: the engine's default epsilon. */
#define SETTING_SEED_DEFAULT 2
#define SETTING_EXACT 0
#define SETTING_FAST 5

/* Timed passes per point; the fastest counts (the others absorb page faults and noise). */
#define TIMED_PASSES 2
/* Contacts one triangle query may report before it counts as truncated. */
#define TRI_CAPACITY 65536

/* ---------- workloads ---------- */

enum ray_category { RC_RANDOM, RC_AT_VERTEX, RC_VERTEX_AXIS, RC_EDGE_MID, RC_FACE_PLANE, RC_COUNT };
static const char *const RAY_CATEGORY_NAMES[RC_COUNT] = {
    "ray: random toward the surface", "ray: aimed exactly at a vertex",
    "ray: axis-aligned through a vertex (along block edges in the CAD scene)", "ray: aimed at an edge midpoint",
    "ray: lying in a block face plane (CAD)"};
static const char *const RAY_CATEGORY_KEYS[RC_COUNT] = {"random", "at_vertex", "vertex_axis", "edge_mid",
                                                        "face_plane"};

enum tri_category { TC_NEAR, TC_AT_VERTEX, TC_SAME, TC_IN_FACE, TC_COUNT };
static const char *const TRI_CATEGORY_NAMES[TC_COUNT] = {
    "triangle: about d, near the surface", "triangle: one corner exactly on a mesh vertex",
    "triangle: identical to a mesh triangle", "triangle: lying in a block face (CAD)"};
static const char *const TRI_CATEGORY_KEYS[TC_COUNT] = {"near", "at_vertex", "same", "in_face"};

typedef struct workload {
    ray_input *rays;
    unsigned char *ray_cat;
    size_t ray_count;
    vec3 (*tris)[3];
    unsigned char *tri_cat;
    size_t tri_count;
} workload;

typedef struct scene {
    const char *name;  /* short key used in the TSVs */
    char title[256];   /* what it is, for the document */
    const char *kind;  /* real, real-subdivided, generated, cad */
    mesh_data mesh;
    int cad;
    double cad_cell;
    /* Every seed epsilon at every resolution; the large timing scenes run seed only at its
     * default epsilon and the heuristic resolution, because seed queries test every
     * zero-area and sliver triangle (the seed list) and the whole report must stay within
     * minutes. */
    int full_sweep;
} scene;

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* True when a - b rounds to nothing (Knuth's TwoSum error is zero), so o = a - b, d = b gives
 * a ray passing exactly through a. */
static int difference_is_exact(double a, double b)
{
    double s = a - b, nb = -b;
    double bb = s - a;
    double err = (a - (s - bb)) + (nb - bb);
    return err == 0.0;
}

/* An axis-aligned ray starting outside the bounds and passing exactly through p. */
static ray_input ray_axis_through(rng *r, vec3 p, box3 around)
{
    int axis = (int)(rng_next(r) % 3);
    int negative = (int)(rng_next(r) & 1);
    double c[3] = {p.x, p.y, p.z}, d[3] = {0, 0, 0};
    c[axis] = negative ? vec3_get(around.hi, axis) : vec3_get(around.lo, axis);
    d[axis] = negative ? -1.0 : 1.0;
    return (ray_input){{c[0], c[1], c[2]}, {d[0], d[1], d[2]}, 0.0, INFINITY, RAY_CROSSING};
}

/* A ray from near `around` that passes exactly through `target` at t = 1: each coordinate of
 * the offset is kept only where subtracting it is exact, otherwise that coordinate of the
 * origin equals the target's (still an exact passage, in an axis plane). */
static ray_input ray_through(rng *r, vec3 target, box3 around)
{
    vec3 o = rng_point_in_box(r, around);
    vec3 d = vec3_sub(target, o);
    double dc[3] = {d.x, d.y, d.z}, tc[3] = {target.x, target.y, target.z}, oc[3];
    for (int k = 0; k < 3; k++) {
        oc[k] = tc[k] - dc[k];
        if (!difference_is_exact(tc[k], dc[k])) {
            dc[k] = 0.0;
            oc[k] = tc[k];
        }
    }
    if (dc[0] == 0.0 && dc[1] == 0.0 && dc[2] == 0.0)
        return ray_axis_through(r, target, around);
    return (ray_input){{oc[0], oc[1], oc[2]}, {dc[0], dc[1], dc[2]}, 0.0, INFINITY, RAY_CROSSING};
}

/* The axis along which a block-face triangle is flat, or -1 for a tilted triangle. */
static int flat_axis(vec3 a, vec3 b, vec3 c)
{
    for (int k = 0; k < 3; k++)
        if (vec3_get(a, k) == vec3_get(b, k) && vec3_get(a, k) == vec3_get(c, k))
            return k;
    return -1;
}

static void make_ray(const scene *s, rng *r, box3 around, int cat, ray_input *out)
{
    const mesh_data *m = &s->mesh;
    size_t t = rng_next(r) % m->triangle_count;
    vec3 a = mesh_data_corner(m, t, 0), b = mesh_data_corner(m, t, 1), c = mesh_data_corner(m, t, 2);
    switch (cat) {
    case RC_RANDOM: {
        double u = rng_uniform(r, 0, 1), v = rng_uniform(r, 0, 1);
        if (u + v > 1) {
            u = 1 - u;
            v = 1 - v;
        }
        vec3 target = vec3_add(a, vec3_add(vec3_scale(vec3_sub(b, a), u), vec3_scale(vec3_sub(c, a), v)));
        vec3 o = rng_point_in_box(r, around);
        *out = (ray_input){o, vec3_sub(target, o), 0.0, INFINITY, RAY_CROSSING};
        return;
    }
    case RC_AT_VERTEX:
        *out = ray_through(r, a, around);
        return;
    case RC_VERTEX_AXIS:
        *out = ray_axis_through(r, a, around);
        return;
    case RC_EDGE_MID: {
        /* (a + b) / 2 is on the edge whenever the sums are exact (always in the CAD scene). */
        vec3 mid = vec3_scale(vec3_add(a, b), 0.5);
        *out = (rng_next(r) & 1) ? ray_through(r, mid, around) : ray_axis_through(r, mid, around);
        return;
    }
    default: {
        /* In the face's plane, half a cell in from the corner, running along an in-plane
         * axis across the whole scene: it grazes every coplanar face and crosses the
         * perpendicular faces of other blocks exactly on their edges. */
        int n = flat_axis(a, b, c);
        if (n < 0) {
            *out = ray_axis_through(r, a, around);
            return;
        }
        int u = (n + 1 + (int)(rng_next(r) & 1)) % 3, w = 3 - n - u;
        double half = 0.5 * s->cad_cell;
        double wmin = fmin(vec3_get(a, w), fmin(vec3_get(b, w), vec3_get(c, w)));
        vec3 p = vec3_with(a, w, wmin + half);
        int negative = (int)(rng_next(r) & 1);
        p = vec3_with(p, u, negative ? vec3_get(around.hi, u) : vec3_get(around.lo, u));
        vec3 d = vec3_with((vec3){0, 0, 0}, u, negative ? -1.0 : 1.0);
        *out = (ray_input){p, d, 0.0, INFINITY, RAY_CROSSING};
        return;
    }
    }
}

static void make_tri(const scene *s, rng *r, double leaf, int cat, vec3 out[3])
{
    const mesh_data *m = &s->mesh;
    /* The first three categories are the benchmarks' query shapes (query_shapes.h), in
     * the same order. */
    if (cat != TC_IN_FACE) {
        query_triangle_sample(m, r, leaf, (query_triangle_kind)cat, out);
        return;
    }
    /* Corners on the half-cell grid of the face's plane, reaching into the neighbouring
     * faces: coplanar area contacts, every coordinate exact. */
    size_t t = rng_next(r) % m->triangle_count;
    vec3 a = mesh_data_corner(m, t, 0), b = mesh_data_corner(m, t, 1), c = mesh_data_corner(m, t, 2);
    int n = flat_axis(a, b, c);
    if (n < 0) {
        out[0] = a, out[1] = b, out[2] = c;
        return;
    }
    int u = (n + 1) % 3, w = (n + 2) % 3;
    double half = 0.5 * s->cad_cell, cell = s->cad_cell;
    double su = (rng_next(r) & 1) ? half : -half, sw = (rng_next(r) & 1) ? half : -half;
    vec3 p0 = vec3_with(vec3_with(a, u, vec3_get(a, u) + su), w, vec3_get(a, w) + sw);
    out[0] = p0;
    out[1] = vec3_with(p0, u, vec3_get(p0, u) + ((rng_next(r) & 1) ? cell : -cell));
    out[2] = vec3_with(p0, w, vec3_get(p0, w) + ((rng_next(r) & 1) ? cell : -cell));
}

/* The fixed workload of a scene: every category gets an equal share. */
static workload make_workload(const scene *s, double leaf, size_t rays, size_t tris, uint64_t seed)
{
    rng r = rng_seeded(seed);
    box3 b = mesh_data_bounds(&s->mesh);
    vec3 ext = vec3_sub(b.hi, b.lo);
    box3 around = {vec3_sub(b.lo, vec3_scale(ext, 0.2)), vec3_add(b.hi, vec3_scale(ext, 0.2))};
    int ray_cats = s->cad ? RC_COUNT : RC_FACE_PLANE;
    int tri_cats = s->cad ? TC_COUNT : TC_IN_FACE;
    workload w = {malloc(rays * sizeof *w.rays), malloc(rays), rays, malloc(tris * sizeof *w.tris), malloc(tris), tris};
    if (!w.rays || !w.ray_cat || !w.tris || !w.tri_cat) {
        fprintf(stderr, "report_accuracy: out of memory\n");
        exit(1);
    }
    for (size_t i = 0; i < rays; i++) {
        w.ray_cat[i] = (unsigned char)(i % (size_t)ray_cats);
        make_ray(s, &r, around, w.ray_cat[i], &w.rays[i]);
    }
    for (size_t i = 0; i < tris; i++) {
        w.tri_cat[i] = (unsigned char)(i % (size_t)tri_cats);
        make_tri(s, &r, leaf, w.tri_cat[i], w.tris[i]);
    }
    return w;
}

static void workload_free(workload *w)
{
    free(w->rays);
    free(w->ray_cat);
    free(w->tris);
    free(w->tri_cat);
}

/* ---------- truth and comparison ---------- */

/* The exact answers at the default resolution. */
typedef struct truth {
    unsigned char *ray_hit;
    uint32_t *ray_tri;
    double *ray_t;
    size_t *tri_first; /* tri_count + 1 offsets into tri_ids */
    uint32_t *tri_ids;
} truth;

typedef struct point_result {
    int ran;   /* part of this scene's sweep */
    int built; /* the build succeeded */
    octree_info info;
    double ray_seconds, tri_seconds; /* fastest pass, whole workload */
    query_stats ray_stats, tri_stats;
    size_t ray_wrong, ray_fn, ray_fp;
    size_t ray_other_point; /* a hit, but at another point than the truth's: another surface */
    size_t ray_tie;   /* the truth's point on another triangle: a tie at an edge or vertex decided differently */
    size_t ray_t_off; /* reported t more than 1e-6 (relative) from its own triangle's plane */
    double ray_cat_seconds[RC_COUNT], tri_cat_seconds[TC_COUNT]; /* one pass, each query timed */
    uint64_t ray_fallbacks_by_cat[RC_COUNT], tri_fallbacks_by_cat[TC_COUNT];
    size_t tri_wrong, tri_fn_pairs, tri_fp_pairs, tri_truncated;
    size_t ray_wrong_by_cat[RC_COUNT], ray_tie_by_cat[RC_COUNT], ray_by_cat[RC_COUNT];
    size_t tri_wrong_by_cat[TC_COUNT], tri_by_cat[TC_COUNT];
    /* Against the oracle, on the scene's oracle sample (see oracle_sample). */
    size_t orc_ray_wrong_clean, orc_ray_wrong_boundary, orc_tri_wrong;
} point_result;

/* The independent truth of a sample of a scene's workload: its first `rays` rays and
 * first `tris` triangle queries (categories take turns, so every category is sampled
 * alike), answered by the GMP oracle over every triangle of the scene (oracle_mesh.h). */
typedef struct oracle_sample {
    size_t rays, tris;
    oracle_mesh om;
    oracle_ray_truth *ray_truth;
    uint32_t *tri_ids;
    size_t *tri_first; /* tris + 1 offsets into tri_ids */
    size_t clean, clean_hitting, boundary, touching_tris;
    size_t clean_by_cat[RC_COUNT], boundary_by_cat[RC_COUNT];
    double seconds;
} oracle_sample;

static double time_rays(const octree *t, const workload *w, accuracy_mode mode)
{
    ray_hit hit;
    query_stats st = {0};
    double start = now();
    for (size_t i = 0; i < w->ray_count; i++) {
        ray_output out = {.hits = &hit, .max_hits = 1};
        octree_ray(t, &w->rays[i], RAY_CLOSEST, mode, &out, &st);
    }
    return now() - start;
}

static double time_tris(const octree *t, const workload *w, accuracy_mode mode, tri_contact *buf)
{
    query_stats st = {0};
    double start = now();
    for (size_t i = 0; i < w->tri_count; i++) {
        tri_output out = {.contacts = buf, .capacity = TRI_CAPACITY};
        octree_triangle(t, w->tris[i], TRI_IDS, mode, &out, &st);
    }
    return now() - start;
}

/* How many of the sorted, unique ids in a are not in the sorted, unique ids in b. */
static size_t count_missing(const uint32_t *a, size_t na, const uint32_t *b, size_t nb)
{
    size_t i = 0, j = 0, missing = 0;
    while (i < na) {
        if (j >= nb || a[i] < b[j]) {
            missing++;
            i++;
        } else if (a[i] == b[j]) {
            i++;
            j++;
        } else {
            j++;
        }
    }
    return missing;
}

/* Where the ray meets the plane of mesh triangle `tri`, in plain doubles (accurate away from
 * grazing); `fallback` when the ray is parallel to the plane. */
static double plane_t(const mesh_data *m, const ray_input *ray, uint32_t tri, double fallback)
{
    vec3 a = mesh_data_corner(m, tri, 0), b = mesh_data_corner(m, tri, 1), c = mesh_data_corner(m, tri, 2);
    vec3 n = vec3_cross(vec3_sub(b, a), vec3_sub(c, a));
    double denom = vec3_dot(n, ray->direction);
    if (denom == 0.0 || !isfinite(denom))
        return fallback;
    double tp = vec3_dot(n, vec3_sub(a, ray->origin)) / denom;
    return isfinite(tp) ? tp : fallback;
}

/* One pass with every query timed on its own, summed by category: which queries cost. */
static void time_by_category(const octree *t, const workload *w, accuracy_mode mode, tri_contact *buf,
                             point_result *res)
{
    ray_hit hit;
    query_stats st = {0};
    for (size_t i = 0; i < w->ray_count; i++) {
        ray_output out = {.hits = &hit, .max_hits = 1};
        double start = now();
        octree_ray(t, &w->rays[i], RAY_CLOSEST, mode, &out, &st);
        res->ray_cat_seconds[w->ray_cat[i]] += now() - start;
    }
    for (size_t i = 0; i < w->tri_count; i++) {
        tri_output out = {.contacts = buf, .capacity = TRI_CAPACITY};
        double start = now();
        octree_triangle(t, w->tris[i], TRI_IDS, mode, &out, &st);
        res->tri_cat_seconds[w->tri_cat[i]] += now() - start;
    }
}

/* Runs the workload once collecting answers (into the truth when `record` is set, else
 * compared against it), then TIMED_PASSES timed passes. */
static void measure(const octree *t, const mesh_data *m, const workload *w, accuracy_mode mode, truth *tr,
                    int record, const oracle_sample *os, tri_contact *buf, uint32_t *ids, point_result *res)
{
    ray_hit hit;
    for (size_t i = 0; i < w->ray_count; i++) {
        ray_output out = {.hits = &hit, .max_hits = 1};
        uint64_t fallbacks_before = res->ray_stats.exact_fallbacks;
        octree_ray(t, &w->rays[i], RAY_CLOSEST, mode, &out, &res->ray_stats);
        int got = out.hit_count > 0;
        int cat = w->ray_cat[i];
        if (i < os->rays) {
            char why[256];
            const oracle_ray_truth *ot = &os->ray_truth[i];
            if (!oracle_ray_answer_ok(&os->om, &w->rays[i], ot, RAY_CLOSEST, &hit, out.hit_count, why, sizeof why)) {
                if (ot->boundary)
                    res->orc_ray_wrong_boundary++;
                else
                    res->orc_ray_wrong_clean++;
            }
        }
        res->ray_fallbacks_by_cat[cat] += res->ray_stats.exact_fallbacks - fallbacks_before;
        res->ray_by_cat[cat]++;
        if (record) {
            tr->ray_hit[i] = (unsigned char)got;
            tr->ray_tri[i] = got ? hit.triangle : 0;
            tr->ray_t[i] = got ? hit.t : 0.0;
            continue;
        }
        int want = tr->ray_hit[i];
        int wrong = 0;
        if (got) {
            /* The hit's own plane gives its point independently of the mode's arithmetic: a
             * mode whose t is off (seed's epsilon sits in its denominator) still hit there. */
            double tp = plane_t(m, &w->rays[i], hit.triangle, hit.t);
            if (fabs(hit.t - tp) > 1e-6 * fmax(1.0, fabs(tp)))
                res->ray_t_off++;
            if (want) {
                double tt = tr->ray_t[i];
                if (fabs(tp - tt) > 1e-9 * fmax(1.0, fabs(tt)))
                    res->ray_other_point++, wrong = 1;
                else if (hit.triangle != tr->ray_tri[i])
                    res->ray_tie++, res->ray_tie_by_cat[cat]++;
            }
        }
        if (want && !got)
            res->ray_fn++, wrong = 1;
        else if (!want && got)
            res->ray_fp++, wrong = 1;
        res->ray_wrong += (size_t)wrong;
        res->ray_wrong_by_cat[cat] += (size_t)wrong;
    }
    size_t ids_used = 0, ids_cap = 0;
    if (record) {
        tr->tri_ids = NULL;
        if (array_reserve((void **)&tr->tri_ids, &ids_cap, 1, sizeof *tr->tri_ids, 1024) != 0) {
            fprintf(stderr, "report_accuracy: out of memory\n");
            exit(1);
        }
        tr->tri_first[0] = 0;
    }
    for (size_t i = 0; i < w->tri_count; i++) {
        tri_output out = {.contacts = buf, .capacity = TRI_CAPACITY};
        uint64_t fallbacks_before = res->tri_stats.exact_fallbacks;
        octree_triangle(t, w->tris[i], TRI_IDS, mode, &out, &res->tri_stats);
        int cat = w->tri_cat[i];
        res->tri_fallbacks_by_cat[cat] += res->tri_stats.exact_fallbacks - fallbacks_before;
        res->tri_by_cat[cat]++;
        res->tri_truncated += (size_t)(out.truncated != 0);
        size_t n = out.count < TRI_CAPACITY ? out.count : TRI_CAPACITY;
        if (i < os->tris) {
            size_t nwant = os->tri_first[i + 1] - os->tri_first[i];
            int same = !out.truncated && n == nwant;
            for (size_t k = 0; same && k < n; k++)
                same = buf[k].triangle == os->tri_ids[os->tri_first[i] + k];
            res->orc_tri_wrong += (size_t)!same;
        }
        if (record) {
            if (array_reserve((void **)&tr->tri_ids, &ids_cap, ids_used + n, sizeof *tr->tri_ids, 1024) != 0) {
                fprintf(stderr, "report_accuracy: out of memory\n");
                exit(1);
            }
            for (size_t k = 0; k < n; k++)
                tr->tri_ids[ids_used++] = buf[k].triangle;
            tr->tri_first[i + 1] = ids_used;
            continue;
        }
        const uint32_t *want = tr->tri_ids + tr->tri_first[i];
        size_t nwant = tr->tri_first[i + 1] - tr->tri_first[i];
        for (size_t k = 0; k < n; k++)
            ids[k] = buf[k].triangle;
        size_t fn = count_missing(want, nwant, ids, n);
        size_t fp = count_missing(ids, n, want, nwant);
        res->tri_fn_pairs += fn;
        res->tri_fp_pairs += fp;
        int wrong = fn + fp > 0;
        res->tri_wrong += (size_t)wrong;
        res->tri_wrong_by_cat[cat] += (size_t)wrong;
    }
    res->ray_seconds = res->tri_seconds = INFINITY;
    for (int pass = 0; pass < TIMED_PASSES; pass++) {
        res->ray_seconds = fmin(res->ray_seconds, time_rays(t, w, mode));
        res->tri_seconds = fmin(res->tri_seconds, time_tris(t, w, mode, buf));
    }
    time_by_category(t, w, mode, buf, res);
}

/* ---------- output helpers ---------- */

static FILE *open_or_die(const char *dir, const char *name)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    if (!f) {
        fprintf(stderr, "report_accuracy: cannot write %s\n", path);
        exit(1);
    }
    return f;
}

static double per(double num, size_t den)
{
    return den ? num / (double)den : 0.0;
}

/* ---------- scenes ---------- */

#define MAX_SCENES 8

/* Real meshes as loaded and subdivided, a generated terrain, and the CAD-like blocks. quick
 * shrinks every scene for a smoke run. */
static size_t load_scenes(scene *out, int quick)
{
    size_t n = 0;
    const char *subkeys[REAL_MESH_COUNT] = {[REAL_WUSON] = "wuson-sub", [REAL_SPIDER] = "spider-sub"};
    /* Subdivided to the 250k-1M range: Wuson (3732) x3 = 239k, Spider (1368) x4 = 350k. */
    const size_t limits[REAL_MESH_COUNT] = {[REAL_WUSON] = 300000, [REAL_SPIDER] = 1000000};
    mesh_data subs[REAL_MESH_COUNT] = {{0}};
    int sub_times[REAL_MESH_COUNT] = {0};
    for (int i = 0; i < REAL_MESH_COUNT; i++) {
        mesh_data m;
        char err[256];
        if (real_mesh_load((real_mesh)i, quick ? 30000 : limits[i], &m, &subs[i], &sub_times[i], err, sizeof err) !=
            0) {
            printf("skipping %s: %s\n", real_mesh_path((real_mesh)i), err);
            continue;
        }
        out[n] = (scene){.name = real_mesh_key((real_mesh)i), .kind = "real", .mesh = m, .full_sweep = 1};
        snprintf(out[n].title, sizeof out[n].title, "%s, as loaded (real)", real_mesh_path((real_mesh)i));
        n++;
    }
    int blocks = quick ? 8 : 16;
    out[n] = (scene){.name = "blocks", .kind = "cad", .mesh = meshgen_blocks(3, blocks, blocks, blocks, 0.5),
                     .cad = 1, .cad_cell = 0.5, .full_sweep = 1};
    snprintf(out[n].title, sizeof out[n].title, "meshgen_blocks, %d^3 cells of 0.5, 3 in 4 present (CAD-like)",
             blocks);
    n++;
    for (int i = 0; i < REAL_MESH_COUNT; i++)
        if (subs[i].triangle_count) {
            out[n] = (scene){.name = subkeys[i], .kind = "real-subdivided", .mesh = subs[i]};
            snprintf(out[n].title, sizeof out[n].title, "%s subdivided %d times (meshgen_subdivide)",
                     real_mesh_path((real_mesh)i), sub_times[i]);
            n++;
        }
    int grid = quick ? 100 : 708;
    out[n] = (scene){.name = "terrain", .kind = "generated",
                     .mesh = meshgen_terrain(1, (box3){{0, 0, 0}, {100, 100, 10}}, grid, grid)};
    snprintf(out[n].title, sizeof out[n].title, "meshgen_terrain %dx%d over 100 x 100 x 10 (generated)", grid, grid);
    n++;
    return n;
}

/* ---------- the document ---------- */

static void machine_name(char *out, size_t len)
{
    snprintf(out, len, "unknown CPU");
    FILE *f = fopen("/proc/cpuinfo", "r");
    if (!f)
        return;
    char line[512];
    while (fgets(line, sizeof line, f)) {
        if (strncmp(line, "model name", 10) == 0) {
            char *colon = strchr(line, ':');
            if (colon) {
                colon++;
                while (*colon == ' ' || *colon == '\t')
                    colon++;
                colon[strcspn(colon, "\n")] = 0;
                snprintf(out, len, "%s", colon);
            }
            break;
        }
    }
    fclose(f);
}

/* Errors of one setting over one hard-case category. */
typedef struct hard_tally {
    size_t cases, wrong, missed, extra;
} hard_tally;

#define MAX_HARD_CATEGORIES 32

/* The target's measurement, apart from the sweep: exact and fast trees of one scene
 * timed in alternating rounds, so that whatever else the machine does in a stretch of
 * time lands on both modes alike. Each round gives a ratio; the median is the figure, the
 * spread shows how much one round can be trusted. */
#define TARGET_ROUNDS 9

typedef struct target_result {
    int ran;
    double ray_ratio[TARGET_ROUNDS], tri_ratio[TARGET_ROUNDS];
    double exact_ray_us, fast_ray_us, exact_tri_us, fast_tri_us; /* medians */
} target_result;

typedef struct sweep {
    scene *scenes;
    size_t scene_count;
    double heuristic[MAX_SCENES];
    point_result res[MAX_SCENES][SETTING_COUNT][RES_COUNT];
    target_result target[MAX_SCENES];
    size_t rays, tris;
    oracle_sample oracle[MAX_SCENES]; /* counts kept, arrays released after the scene */
    size_t oracle_rays, oracle_tris;  /* sample sizes asked for */
    size_t hard_category_count;
    const char *const *hard_categories;
    hard_tally hard[MAX_HARD_CATEGORIES + 1][SETTING_COUNT]; /* last row: cases of no known category */
} sweep;

/* Which points a scene runs (see scene.full_sweep). */
static int point_in_sweep(const scene *sc, size_t setting, size_t res)
{
    return sc->full_sweep || setting == SETTING_EXACT || setting == SETTING_FAST ||
           (setting == SETTING_SEED_DEFAULT && res == RES_DEFAULT_INDEX);
}

static double us_per_ray(const point_result *p, const sweep *s)
{
    return 1e6 * per(p->ray_seconds, s->rays);
}

static double us_per_tri(const point_result *p, const sweep *s)
{
    return 1e6 * per(p->tri_seconds, s->tris);
}

static const char *CONTRACTS =
    "## The three modes: what each promises\n"
    "\n"
    "The mode is chosen per tree (`octree_def.mode`, the default for its queries) and per query (the `mode` "
    "argument). Every mode builds the same tree, with exact closed-set membership; fast and seed queries widen "
    "their walk by what their own final test can accept, so through the octree they answer what that test "
    "answers over every triangle. Every figure here builds and queries in the same mode.\n\n"
    "| mode | promises | can get wrong |\n"
    "| --- | --- | --- |\n"
    "| `ACCURACY_EXACT` (default) | Every decision equals exact real arithmetic on the double inputs: "
    "closed-set node membership, closed triangle-triangle and triangle-box tests (touching at one point "
    "counts), watertight rays (a ray through an edge or vertex shared by triangles of a closed mesh crosses "
    "exactly one of them) or, with the `touch` contact rule, every ray that shares a point with a closed "
    "triangle, exact `t` ordering with ties to the smaller triangle id. The answers do not depend "
    "on the resolution. Details and the exponent ranges: [engine.md](engine.md). | "
    "Nothing inside the documented ranges. Reported numbers (`t`, `u`, `v`, normals, contact segments) are "
    "rounded results of exact decisions. |\n"
    "| `ACCURACY_SEED` | The seed document's epsilon tests as written, with the absolute epsilon "
    "`octree_def.seed_epsilon` (default 1e-9), as the final test of each query; hits lie in the closed "
    "`[tmin, tmax]`. | Anything "
    "decided within about epsilon of a boundary: touching contacts, grazing rays, rays through edges and "
    "vertices can be missed or found twice, and a large epsilon turns near misses into hits. The epsilon is "
    "absolute, so what it does depends on the scene's scale. |\n"
    "| `ACCURACY_FAST` | Plain double tests (Moller triangle-triangle, Moller-Trumbore) as the final test "
    "of each query. | Exact boundary cases: rays through shared "
    "edges and vertices (missed, or hitting the neighbour), touching and coplanar contacts. |\n\n";

/* The head of a table with a category, a count column and one column per setting. */
static void settings_table_header(FILE *f, const char *count_name)
{
    fprintf(f, "| category | %s |", count_name);
    for (size_t m = 0; m < SETTING_COUNT; m++)
        fprintf(f, " %s |", SETTINGS[m].label);
    fprintf(f, "\n| --- | ---: |");
    for (size_t m = 0; m < SETTING_COUNT; m++)
        fprintf(f, " ---: |");
    fprintf(f, "\n");
}

static void point_row(FILE *f, const sweep *s, const char *lead, const point_result *p, int with_fallbacks)
{
    if (!p->ran) {
        fprintf(f, "| %s | not run (time budget) |%s\n", lead, with_fallbacks ? " | | | | | | | | | | | |" : " | | | | | | | | | |");
        return;
    }
    if (!p->built) {
        fprintf(f, "| %s | build failed |%s\n", lead, with_fallbacks ? " | | | | | | | | | | | |" : " | | | | | | | | | |");
        return;
    }
    fprintf(f, "| %s | %.3f | %.1f | %zu | %.3f | %.3f | %.1f | %.1f |", lead, p->info.build_seconds,
            (double)p->info.bytes_total / 1e6, p->info.node_count, us_per_ray(p, s), us_per_tri(p, s),
            per((double)p->ray_stats.candidates_tested, s->rays), per((double)p->tri_stats.candidates_tested, s->tris));
    if (with_fallbacks)
        fprintf(f, " %.3f | %.3f |", per((double)p->ray_stats.exact_fallbacks, s->rays),
                per((double)p->tri_stats.exact_fallbacks, s->tris));
    fprintf(f, " %zu (%zu/%zu/%zu) | %zu | %zu | %zu (%zu/%zu) |\n", p->ray_wrong, p->ray_fn, p->ray_fp,
            p->ray_other_point, p->ray_tie, p->ray_t_off, p->tri_wrong, p->tri_fn_pairs, p->tri_fp_pairs);
}

/* Where exact mode's extra time goes: per-category time, exact over fast, on the subdivided real
 * scenes pooled (each query timed on its own, so the figures carry a little timer overhead). */
static void write_category_times(FILE *f, const sweep *s)
{
    fprintf(f, "Where the time goes, by query category (subdivided real scenes pooled, heuristic resolution; "
               "each query timed on its own, so a little timer overhead is included; exact-arithmetic "
               "fallbacks per query in exact mode):\n\n");
    fprintf(f, "| category | exact us/query | fast us/query | ratio | exact fallbacks/query |\n");
    fprintf(f, "| --- | ---: | ---: | ---: | ---: |\n");
    for (int c = 0; c < RC_COUNT + TC_COUNT; c++) {
        double te = 0, tf = 0;
        size_t n = 0;
        for (size_t i = 0; i < s->scene_count; i++) {
            if (strcmp(s->scenes[i].kind, "real-subdivided") != 0)
                continue;
            const point_result *e = &s->res[i][SETTING_EXACT][RES_DEFAULT_INDEX];
            const point_result *q = &s->res[i][SETTING_FAST][RES_DEFAULT_INDEX];
            if (!e->built || !q->built)
                continue;
            if (c < RC_COUNT) {
                te += e->ray_cat_seconds[c], tf += q->ray_cat_seconds[c], n += e->ray_by_cat[c];
            } else {
                te += e->tri_cat_seconds[c - RC_COUNT], tf += q->tri_cat_seconds[c - RC_COUNT];
                n += e->tri_by_cat[c - RC_COUNT];
            }
        }
        if (!n || tf <= 0)
            continue;
        double fallbacks = 0;
        for (size_t i = 0; i < s->scene_count; i++)
            if (strcmp(s->scenes[i].kind, "real-subdivided") == 0)
                fallbacks += c < RC_COUNT ? (double)s->res[i][SETTING_EXACT][RES_DEFAULT_INDEX].ray_fallbacks_by_cat[c]
                                          : (double)s->res[i][SETTING_EXACT][RES_DEFAULT_INDEX].tri_fallbacks_by_cat[c - RC_COUNT];
        fprintf(f, "| %s | %.3f | %.3f | %.2fx | %.2f |\n", c < RC_COUNT ? RAY_CATEGORY_NAMES[c] : TRI_CATEGORY_NAMES[c - RC_COUNT],
                1e6 * te / (double)n, 1e6 * tf / (double)n, te / tf, fallbacks / (double)n);
    }
    fprintf(f, "\n");
}

static int compare_doubles(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median_of(const double *v, size_t n)
{
    double sorted[TARGET_ROUNDS];
    memcpy(sorted, v, n * sizeof *v);
    qsort(sorted, n, sizeof *sorted, compare_doubles);
    return n % 2 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
}

static double min_of(const double *v, size_t n)
{
    double m = v[0];
    for (size_t i = 1; i < n; i++)
        m = v[i] < m ? v[i] : m;
    return m;
}

static double max_of(const double *v, size_t n)
{
    double m = v[0];
    for (size_t i = 1; i < n; i++)
        m = v[i] > m ? v[i] : m;
    return m;
}

/* Exact against fast at the heuristic resolution, each tree built in its own mode, in
 * TARGET_ROUNDS rounds; odd rounds run fast first so neither mode always follows the
 * other. One untimed pass each first brings both trees into the caches. */
static void measure_target(const scene *sc, const workload *w, tri_contact *buf, target_result *out)
{
    mesh_view v = mesh_data_view(&sc->mesh);
    octree_error err;
    octree_def de = octree_default_def(), df = octree_default_def();
    de.mode = ACCURACY_EXACT;
    df.mode = ACCURACY_FAST;
    octree *te = octree_build(&v, &de, &err), *tf = octree_build(&v, &df, &err);
    if (!te || !tf) {
        octree_free(te);
        octree_free(tf);
        return;
    }
    time_rays(te, w, ACCURACY_EXACT);
    time_rays(tf, w, ACCURACY_FAST);
    double er[TARGET_ROUNDS], fr[TARGET_ROUNDS], et[TARGET_ROUNDS], ft[TARGET_ROUNDS];
    for (int round = 0; round < TARGET_ROUNDS; round++) {
        for (int k = 0; k < 2; k++) {
            int exact = (k == 0) != (round % 2 == 1);
            if (exact) {
                er[round] = time_rays(te, w, ACCURACY_EXACT);
                et[round] = time_tris(te, w, ACCURACY_EXACT, buf);
            } else {
                fr[round] = time_rays(tf, w, ACCURACY_FAST);
                ft[round] = time_tris(tf, w, ACCURACY_FAST, buf);
            }
        }
        out->ray_ratio[round] = er[round] / fr[round];
        out->tri_ratio[round] = et[round] / ft[round];
    }
    out->exact_ray_us = 1e6 * median_of(er, TARGET_ROUNDS) / (double)w->ray_count;
    out->fast_ray_us = 1e6 * median_of(fr, TARGET_ROUNDS) / (double)w->ray_count;
    out->exact_tri_us = 1e6 * median_of(et, TARGET_ROUNDS) / (double)w->tri_count;
    out->fast_tri_us = 1e6 * median_of(ft, TARGET_ROUNDS) / (double)w->tri_count;
    out->ran = 1;
    octree_free(te);
    octree_free(tf);
}


/* One cell of the oracle table: a setting's disagreements with the oracle on a scene's
 * sample, or why there are none. */
static void oracle_cell(FILE *f, const point_result *p)
{
    if (!p->ran)
        fprintf(f, " not run |");
    else if (!p->built)
        fprintf(f, " build failed |");
    else
        fprintf(f, " %zu + %zu / %zu |", p->orc_ray_wrong_clean, p->orc_ray_wrong_boundary, p->orc_tri_wrong);
}

static void write_oracle_section(FILE *f, const sweep *s)
{
    fprintf(f, "## What the figures are checked against\n\n");
    fprintf(f, "Two references, one independent of the engine and one not.\n\n");
    fprintf(f, "**The oracle, on a sample.** For each scene, the first %zu rays and the first %zu triangle queries "
               "of its workload (the categories take turns, so each is sampled alike) are answered by "
               "`tests/support/oracle.c`: GMP rationals, two closed convex sets meet when an exact linear "
               "feasibility problem has a solution; no engine code is involved. It runs over every triangle of the "
               "scene (`tests/support/oracle_mesh.c`), after a bounding-box rejection that cannot drop a contact: "
               "plain comparisons of doubles for triangle queries (exact), slabs widened by 2^-40 relative for rays "
               "(far beyond their rounding error). Every setting at every resolution is then checked on that "
               "sample:\n\n",
            s->oracle_rays, s->oracle_tris);
    fprintf(f, "- a triangle query is right when its id set equals the oracle's (closed triangles: touching counts);\n"
               "- a ray whose every contact is a crossing of a triangle's interior (*no boundary contact*) is right "
               "when it hits exactly if the oracle's ray meets something, on the nearest triangle by the oracle's "
               "exact `t` (`oracle_compare_plane_t`), ties to the smaller id;\n"
               "- a ray *with a boundary contact* (it meets an edge or a vertex, lies in a triangle's plane, or meets "
               "a zero-area triangle) is excluded from that check, because there the engine's crossing rule decides "
               "and the oracle does not: exact mode's watertight rule counts a ray through an edge shared by two "
               "triangles once, by symbolic perturbation, while the oracle counts every contact. Such a ray is only "
               "checked for consistency: the reported triangle is one the oracle says the ray meets, it is not "
               "beyond (nor tied with, at a larger id) any interior crossing, and no miss is reported while the ray "
               "crosses a triangle's interior.\n\n");
    fprintf(f, "Cells: rays wrong without + with boundary contact / triangle queries wrong, out of the sample sizes "
               "in the first columns; all at the heuristic resolution, except the last column, which sums exact "
               "mode's trees at the other four resolutions.\n\n");
    fprintf(f, "| scene | rays sampled | no boundary contact (hitting) | with boundary contact | triangle queries "
               "sampled (touching) | oracle s |");
    for (size_t m = 0; m < SETTING_COUNT; m++)
        fprintf(f, " %s |", SETTINGS[m].label);
    fprintf(f, " exact, f != 1 |\n| --- | ---: | ---: | ---: | ---: | ---: |");
    for (size_t m = 0; m <= SETTING_COUNT; m++)
        fprintf(f, " ---: |");
    fprintf(f, "\n");
    size_t total_rays = 0, total_clean = 0, total_boundary = 0, total_tris = 0;
    size_t wrong[SETTING_COUNT + 1][3] = {{0}};
    for (size_t i = 0; i < s->scene_count; i++) {
        const oracle_sample *os = &s->oracle[i];
        fprintf(f, "| %s | %zu | %zu (%zu) | %zu | %zu (%zu) | %.1f |", s->scenes[i].name, os->rays, os->clean,
                os->clean_hitting, os->boundary, os->tris, os->touching_tris, os->seconds);
        total_rays += os->rays, total_clean += os->clean, total_boundary += os->boundary, total_tris += os->tris;
        for (size_t m = 0; m < SETTING_COUNT; m++) {
            const point_result *p = &s->res[i][m][RES_DEFAULT_INDEX];
            oracle_cell(f, p);
            wrong[m][0] += p->orc_ray_wrong_clean, wrong[m][1] += p->orc_ray_wrong_boundary;
            wrong[m][2] += p->orc_tri_wrong;
        }
        point_result other = {.ran = 1, .built = 1};
        for (size_t r = 0; r < RES_COUNT; r++) {
            const point_result *p = &s->res[i][SETTING_EXACT][r];
            if (r == RES_DEFAULT_INDEX || !p->built)
                continue;
            other.orc_ray_wrong_clean += p->orc_ray_wrong_clean;
            other.orc_ray_wrong_boundary += p->orc_ray_wrong_boundary;
            other.orc_tri_wrong += p->orc_tri_wrong;
        }
        oracle_cell(f, &other);
        wrong[SETTING_COUNT][0] += other.orc_ray_wrong_clean, wrong[SETTING_COUNT][1] += other.orc_ray_wrong_boundary;
        wrong[SETTING_COUNT][2] += other.orc_tri_wrong;
        fprintf(f, "\n");
    }
    fprintf(f, "| **all** | %zu | %zu | %zu | %zu | |", total_rays, total_clean, total_boundary, total_tris);
    for (size_t m = 0; m <= SETTING_COUNT; m++)
        fprintf(f, " %zu + %zu / %zu |", wrong[m][0], wrong[m][1], wrong[m][2]);
    fprintf(f, "\n\nSeed at epsilons other than 1e-9 runs on the fully swept scenes only, so its totals cover fewer "
               "scenes. Which sampled rays were excluded from the exact check, by category (scenes pooled):\n\n");
    fprintf(f, "| category | sampled | no boundary contact | with boundary contact |\n| --- | ---: | ---: | ---: |\n");
    for (int c = 0; c < RC_COUNT; c++) {
        size_t clean = 0, boundary = 0;
        for (size_t i = 0; i < s->scene_count; i++)
            clean += s->oracle[i].clean_by_cat[c], boundary += s->oracle[i].boundary_by_cat[c];
        if (clean + boundary)
            fprintf(f, "| %s | %zu | %zu | %zu |\n", RAY_CATEGORY_NAMES[c], clean + boundary, clean, boundary);
    }
    fprintf(f, "\n**Exact mode at the heuristic resolution, on the whole workload.** Every other error figure in "
               "this document (the sweep tables, the category table, the plots) counts disagreements with exact "
               "mode's answers at the heuristic resolution, on all %zu rays and %zu triangle queries of each "
               "scene. Exact mode is not independent of itself: its zero there says its answers agree across "
               "resolutions; that they are right is what the oracle columns above say, on their sample. The hard-"
               "case catalogue at the end has its own exact expected answers.\n\n",
            s->rays, s->tris);
}

static void write_markdown(const char *path, const sweep *s, const char *date, int hard_done)
{
    FILE *f = fopen(path, "w");
    if (!f) {
        fprintf(stderr, "report_accuracy: cannot write %s\n", path);
        exit(1);
    }
    char cpu[256];
    machine_name(cpu, sizeof cpu);
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    fprintf(f, "# Accuracy and what it costs\n\n");
    fprintf(f, "Generated by `make accuracy-report` (`bench/report_accuracy.c`, `scripts/accuracy_report.sh`); "
               "the raw results are in `build/accuracy/*.tsv`. Regenerate rather than edit.\n\n");
    fprintf(f, "Measured on %s, %ld cores (queries and builds on one thread), %s. Times move from run to "
               "run: each sweep time is the fastest of %d passes, and ratios taken from two sweep points can "
               "be off by 0.2 on this shared machine, which is why the target below is measured in paired "
               "rounds instead. Error counts do not move; every workload is seeded.\n\n",
            cpu, cores, date, TIMED_PASSES);
    fputs(CONTRACTS, f);
    write_oracle_section(f, s);

    fprintf(f, "## Target: exact costs at most 1.3x fast\n\n");
    fprintf(f, "Time per query at the heuristic resolution, exact over fast, each building and querying in its "
               "own mode, on the real scenes, the workload below. Measured apart from the sweep: the two trees "
               "are timed in %d alternating rounds (odd rounds fast first), and the ratio shown is the median "
               "of the rounds' ratios, with the lowest and highest round in brackets; times are medians.\n\n",
            TARGET_ROUNDS);
    fprintf(f, "| scene | triangles | closest ray, exact / fast (us) | ratio (range) | triangle ids, exact / fast (us) "
               "| ratio (range) |\n");
    fprintf(f, "| --- | ---: | ---: | ---: | ---: | ---: |\n");
    double worst_ray = 0, worst_tri = 0, worst_small = 0;
    for (size_t i = 0; i < s->scene_count; i++) {
        const target_result *t = &s->target[i];
        if (!t->ran)
            continue;
        double rr = median_of(t->ray_ratio, TARGET_ROUNDS), rt = median_of(t->tri_ratio, TARGET_ROUNDS);
        fprintf(f, "| %s | %zu | %.3f / %.3f | %.2fx (%.2f-%.2f) | %.3f / %.3f | %.2fx (%.2f-%.2f) |\n",
                s->scenes[i].name, s->scenes[i].mesh.triangle_count, t->exact_ray_us, t->fast_ray_us, rr,
                min_of(t->ray_ratio, TARGET_ROUNDS), max_of(t->ray_ratio, TARGET_ROUNDS), t->exact_tri_us,
                t->fast_tri_us, rt, min_of(t->tri_ratio, TARGET_ROUNDS), max_of(t->tri_ratio, TARGET_ROUNDS));
        if (strcmp(s->scenes[i].kind, "real-subdivided") == 0) {
            worst_ray = fmax(worst_ray, rr);
            worst_tri = fmax(worst_tri, rt);
        } else {
            worst_small = fmax(worst_small, fmax(rr, rt));
        }
    }
    double worst = fmax(worst_small, fmax(worst_ray, worst_tri));
    fprintf(f, "\nOn the subdivided real scenes (the 250k-1M-triangle sizes the engine targets) the worst median "
               "ratio is **%.2fx for closest-hit rays** and **%.2fx for triangle queries**; on the small as-loaded "
               "meshes it is **%.2fx**. Over every real scene the worst is %.2fx: the target is **%s**.\n\n",
            worst_ray, worst_tri, worst_small, worst, worst <= 1.3 ? "met" : "not met");
    write_category_times(f, s);

    fprintf(f, "## Scenes and workload\n\n");
    for (size_t i = 0; i < s->scene_count; i++) {
        const point_result *e = &s->res[i][SETTING_EXACT][RES_DEFAULT_INDEX];
        fprintf(f, "- `%s`: %s; %zu triangles, heuristic d = %.6g%s.\n", s->scenes[i].name, s->scenes[i].title,
                e->info.triangle_count, s->heuristic[i],
                s->scenes[i].full_sweep ? "; full sweep" : "; seed only at epsilon 1e-9 and f = 1");
    }
    fprintf(f, "\nPer scene: %zu closest-hit rays and %zu triangle-ids queries from a fixed seed, every "
               "category of the category table in an equal share (the CAD categories only in `blocks`). "
               "Query triangles are about d across. In the tables below the reference is exact mode at the "
               "heuristic resolution, so \"wrong\" there means *disagrees with exact mode* (see above for what "
               "was checked against the oracle). A ray is wrong when it misses a hit "
               "(FN), hits where there is nothing (FP) or hits another point (point: the reported triangle's "
               "plane meets the ray more than 1e-9 relative from the reference's `t`, so a farther or nearer "
               "surface). Not counted as wrong, but shown: \"ties\", the reference's point on another triangle "
               "(a tie at a shared edge or vertex decided the other way), and \"t off\", hits whose reported "
               "`t` is more than 1e-6 relative from their own triangle's plane (seed's epsilon sits in the "
               "denominator of its `t`). A triangle query is wrong when its id set differs "
               "(FN/FP count the missing/extra ids). Build time and memory are for the mode's own tree; "
               "cand is primitive tests per query; fallbacks are predicate evaluations per query that needed "
               "exact arithmetic. Every mode builds the same exact tree; seed queries also test every "
               "zero-area and sliver triangle of the scene (the seed test accepts points far from those), which "
               "makes them slow on meshes that have many, and is why the large scenes run seed only once.\n\n",
            s->rays, s->tris);

    fprintf(f, "## Every mode at the heuristic resolution\n\n");
    fprintf(f, "| scene | mode | build s | MB | nodes | us/ray | us/tri | cand/ray | cand/tri | fallbacks/ray | "
               "fallbacks/tri | rays wrong (FN/FP/point) | ray ties | ray t off | tris wrong (FN/FP ids) |\n");
    fprintf(f, "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n");
    for (size_t i = 0; i < s->scene_count; i++)
        for (size_t m = 0; m < SETTING_COUNT; m++) {
            char lead[96];
            snprintf(lead, sizeof lead, "%s | %s", s->scenes[i].name, SETTINGS[m].label);
            point_row(f, s, lead, &s->res[i][m][RES_DEFAULT_INDEX], 1);
        }

    fprintf(f, "\n## Disagreements with exact mode by query category (heuristic resolution, scenes pooled)\n\n");
    fprintf(f, "Queries answered otherwise than exact mode at the heuristic resolution; in brackets, ray ties "
               "(same point, other triangle). Seed at epsilons other than "
               "1e-9 covers only the fully swept scenes, so its column totals are not comparable with the "
               "others.\n\n");
    settings_table_header(f, "queries");
    for (int c = 0; c < RC_COUNT + TC_COUNT; c++) {
        size_t total = 0;
        for (size_t i = 0; i < s->scene_count; i++) {
            const point_result *e = &s->res[i][SETTING_EXACT][RES_DEFAULT_INDEX];
            total += c < RC_COUNT ? e->ray_by_cat[c] : e->tri_by_cat[c - RC_COUNT];
        }
        if (!total)
            continue;
        fprintf(f, "| %s | %zu |", c < RC_COUNT ? RAY_CATEGORY_NAMES[c] : TRI_CATEGORY_NAMES[c - RC_COUNT], total);
        for (size_t m = 0; m < SETTING_COUNT; m++) {
            size_t wrong = 0, ties = 0;
            for (size_t i = 0; i < s->scene_count; i++) {
                const point_result *p = &s->res[i][m][RES_DEFAULT_INDEX];
                if (c < RC_COUNT) {
                    wrong += p->ray_wrong_by_cat[c];
                    ties += p->ray_tie_by_cat[c];
                } else {
                    wrong += p->tri_wrong_by_cat[c - RC_COUNT];
                }
            }
            if (c < RC_COUNT)
                fprintf(f, " %zu (%zu) |", wrong, ties);
            else
                fprintf(f, " %zu |", wrong);
        }
        fprintf(f, "\n");
    }

    fprintf(f, "\n## Time against errors\n\n");
    fprintf(f, "![time per query against error rate](accuracy-time-vs-error.png)\n\n");
    fprintf(f, "Pooled over the fully swept scenes (");
    for (size_t i = 0, first = 1; i < s->scene_count; i++)
        if (s->scenes[i].full_sweep) {
            fprintf(f, "%s`%s`", first ? "" : ", ", s->scenes[i].name);
            first = 0;
        }
    fprintf(f, "): time per query is the geometric mean of the scenes' times (so the slow CAD scene does not "
               "set the curve alone), the error rate their disagreements with exact mode at f = 1 over their "
               "queries (so exact mode's own curve measures agreement across resolutions). Exact and fast are traced over the resolution factors f, seed over its epsilon "
               "at f = 1. An error rate of zero is drawn at the bottom of the axis (1e-6).\n\n");

    fprintf(f, "## Resolution\n\n");
    fprintf(f, "![time and memory against resolution](accuracy-resolution.png)\n\n");
    fprintf(f, "The leaf side is f times the heuristic d: a smaller f means more, smaller leaves and more memory. "
               "The plot takes the fully swept scenes as above (memory and build time per triangle over all "
               "their triangles); the three modes' memory curves coincide because their trees hold "
               "nearly the same nodes (see the nodes column). Exact mode's error columns below compare it with "
               "itself at f = 1: zeros there mean its answers agree across resolutions (the oracle section "
               "says whether they are right). The approximate modes' errors come mostly "
               "from their primitive tests rather than from the tree: compare a mode's error columns down the "
               "resolutions of one scene; where they move, the mode's box test put a triangle in other "
               "leaves.\n\n");
    fprintf(f, "| scene | f | mode | build s | MB | nodes | us/ray | us/tri | cand/ray | cand/tri | rays wrong (FN/FP/point) | ray ties | ray t off | tris wrong (FN/FP ids) |\n");
    fprintf(f, "| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n");
    const size_t shown[] = {SETTING_EXACT, SETTING_SEED_DEFAULT, SETTING_FAST};
    for (size_t i = 0; i < s->scene_count; i++)
        for (size_t r = 0; r < RES_COUNT; r++)
            for (size_t k = 0; k < 3; k++) {
                const point_result *p = &s->res[i][shown[k]][r];
                if (!p->ran)
                    continue;
                char lead[96];
                snprintf(lead, sizeof lead, "%s | %g | %s", s->scenes[i].name, RES_FACTORS[r], SETTINGS[shown[k]].label);
                point_row(f, s, lead, p, 0);
            }
    fprintf(f, "\nThe other seed epsilons at every resolution are in `build/accuracy/results.tsv`.\n\n");

    fprintf(f, "## Hard-case catalogue\n\n");
    if (hard_done) {
        fprintf(f, "Cases from `tests/support/hard_cases.c` (each with an exact expected answer, expanded by "
                   "exact-preserving transforms), answered by each mode's primitive test "
                   "(`hard_case_answer`); wrong answers as missed/extra.\n\n");
        settings_table_header(f, "cases");
        hard_tally total[SETTING_COUNT] = {{0}};
        for (size_t c = 0; c <= s->hard_category_count; c++) {
            if (!s->hard[c][0].cases)
                continue;
            fprintf(f, "| %s | %zu |", c < s->hard_category_count ? s->hard_categories[c] : "(other)",
                    s->hard[c][0].cases);
            for (size_t m = 0; m < SETTING_COUNT; m++) {
                const hard_tally *h = &s->hard[c][m];
                fprintf(f, " %zu (%zu/%zu) |", h->wrong, h->missed, h->extra);
                total[m].cases += h->cases, total[m].wrong += h->wrong;
                total[m].missed += h->missed, total[m].extra += h->extra;
            }
            fprintf(f, "\n");
        }
        fprintf(f, "| **all** | %zu |", total[0].cases);
        for (size_t m = 0; m < SETTING_COUNT; m++)
            fprintf(f, " %zu (%zu/%zu) |", total[m].wrong, total[m].missed, total[m].extra);
        fprintf(f, "\n\n");
    } else {
        fprintf(f, "The catalogue (`tests/support/hard_cases.c`) was not part of this run.\n\n");
    }

    size_t exact_wrong = 0, seed_wrong = 0, fast_wrong = 0, queries = 0, exact_points = 0;
    size_t orc_exact = 0, orc_seed = 0, orc_fast = 0, orc_queries = 0;
    double exact_time = 0, fast_time = 0;
    for (size_t i = 0; i < s->scene_count; i++) {
        for (size_t r = 0; r < RES_COUNT; r++) {
            const point_result *e = &s->res[i][SETTING_EXACT][r];
            exact_wrong += e->ray_wrong + e->tri_wrong + e->ray_tie;
            exact_points += e->built;
            orc_exact += e->orc_ray_wrong_clean + e->orc_ray_wrong_boundary + e->orc_tri_wrong;
        }
        const point_result *os = &s->res[i][SETTING_SEED_DEFAULT][RES_DEFAULT_INDEX];
        const point_result *of = &s->res[i][SETTING_FAST][RES_DEFAULT_INDEX];
        orc_seed += os->orc_ray_wrong_clean + os->orc_ray_wrong_boundary + os->orc_tri_wrong;
        orc_fast += of->orc_ray_wrong_clean + of->orc_ray_wrong_boundary + of->orc_tri_wrong;
        orc_queries += s->oracle[i].rays + s->oracle[i].tris;
        const point_result *e = &s->res[i][SETTING_EXACT][RES_DEFAULT_INDEX];
        const point_result *q = &s->res[i][SETTING_FAST][RES_DEFAULT_INDEX];
        const point_result *sd = &s->res[i][SETTING_SEED_DEFAULT][RES_DEFAULT_INDEX];
        seed_wrong += sd->ray_wrong + sd->tri_wrong;
        fast_wrong += q->ray_wrong + q->tri_wrong;
        queries += s->rays + s->tris;
        exact_time += e->ray_seconds + e->tri_seconds;
        fast_time += q->ray_seconds + q->tri_seconds;
    }
    fprintf(f, "## Which mode to pick\n\n");
    fprintf(f, "Against the oracle, on the %zu sampled queries of all scenes, exact mode gave %zu wrong answers "
               "summed over its %zu trees (all five resolutions), seed mode (epsilon 1e-9) %zu and fast mode %zu at the "
               "heuristic resolution. Over all %zu queries of all scenes, at the heuristic resolution, seed mode "
               "disagreed with exact mode %zu times and fast mode %zu times, while exact mode took %.2fx the time "
               "of fast mode (query times summed over the scenes). Exact mode's answers at the other resolutions "
               "disagreed with its own at the heuristic one %zu times (a tie decided differently counts "
               "here).\n\n",
            orc_queries, orc_exact, exact_points, orc_seed, orc_fast, queries, seed_wrong, fast_wrong,
            fast_time > 0 ? exact_time / fast_time : 0.0, exact_wrong);
    fprintf(f, "- Use **exact**, the default, unless a measurement of your own workload says you cannot afford "
               "it. Its answers do not depend on the resolution, the scene's scale or an epsilon; touching "
               "contacts count; a ray through a shared edge or vertex is counted once. The sweep's errors are "
               "exactly the queries where the other modes disagree with it, and they cluster where robots and "
               "CAD scenes live: vertices, edges, touching and coplanar faces.\n"
               "- Use **fast** when an occasional wrong answer at an edge, a vertex or a touching contact does "
               "no harm (picking, a broad phase followed by your own check) and the measured saving matters "
               "to you.\n"
               "- **Seed** reproduces the seed document. Its absolute epsilon suits one scale of scene only: "
               "small, it errs like fast mode; large, near misses become hits; a zero-area triangle touches everything, so on a mesh "
               "with many of them every query tests them all. Prefer exact.\n"
               "- The resolution trades memory against query time, never exact mode's answers: keep the "
               "heuristic unless the resolution table shows a better trade for your mesh and queries.\n");
    fclose(f);
}

/* Counts each setting's wrong answers on the hard-case catalogue, by category. */
static int run_hard_cases(sweep *s)
{
    hard_case *cases = NULL;
    size_t n = hard_cases_generate(&cases);
    if (n == 0 || !cases)
        return 0;
    s->hard_categories = hard_case_categories(&s->hard_category_count);
    if (s->hard_category_count > MAX_HARD_CATEGORIES)
        s->hard_category_count = MAX_HARD_CATEGORIES;
    for (size_t k = 0; k < n; k++) {
        const hard_case *c = &cases[k];
        size_t cat = s->hard_category_count;
        for (size_t j = 0; j < s->hard_category_count; j++)
            if (c->category && strcmp(c->category, s->hard_categories[j]) == 0)
                cat = j;
        for (size_t m = 0; m < SETTING_COUNT; m++) {
            int got = hard_case_answer(c, SETTINGS[m].mode, SETTINGS[m].eps) != 0;
            hard_tally *h = &s->hard[cat][m];
            h->cases++;
            if (got != (c->expected != 0)) {
                h->wrong++;
                if (c->expected)
                    h->missed++;
                else
                    h->extra++;
            }
        }
    }
    free(cases);
    return 1;
}

/* The plots' tables over the fully swept scenes: query times as the geometric mean of the
 * scenes' times (so no one slow scene sets the curve), error rates over all their queries,
 * memory and build time per triangle over all their triangles. */
static void write_plot_tables(const sweep *s, const char *outdir)
{
    FILE *trade = open_or_die(outdir, "plot_tradeoff.tsv");
    FILE *resol = open_or_die(outdir, "plot_resolution.tsv");
    const double floor_rate = 1e-6; /* where a zero error rate is drawn on the log axis */
    const size_t traced[] = {SETTING_EXACT, SETTING_FAST, SETTING_SEED_DEFAULT};
    /* Blocks are separated by two blank lines for gnuplot's `index`. */
    for (int block = 0; block < 3; block++) {
        size_t m = traced[block];
        int eps_sweep = block == 2;
        fprintf(trade, "# %s\n# label\tus_per_ray\tray_error_rate\tus_per_tri\ttri_error_rate\n",
                eps_sweep ? "seed, epsilon sweep at f = 1" : SETTINGS[m].label);
        size_t steps = eps_sweep ? 4 : RES_COUNT;
        for (size_t k = 0; k < steps; k++) {
            size_t mm = eps_sweep ? 1 + k : m, r = eps_sweep ? RES_DEFAULT_INDEX : k;
            double ray_log = 0, tri_log = 0;
            size_t ray_wrong = 0, tri_wrong = 0, nr = 0, nt = 0, scenes = 0;
            for (size_t i = 0; i < s->scene_count; i++) {
                const point_result *p = &s->res[i][mm][r];
                if (!s->scenes[i].full_sweep || !p->built)
                    continue;
                ray_log += log(us_per_ray(p, s)), tri_log += log(us_per_tri(p, s));
                ray_wrong += p->ray_wrong, tri_wrong += p->tri_wrong;
                nr += s->rays, nt += s->tris, scenes++;
            }
            char label[32];
            if (eps_sweep)
                snprintf(label, sizeof label, "%g", SETTINGS[mm].eps);
            else
                snprintf(label, sizeof label, "f=%g", RES_FACTORS[r]);
            fprintf(trade, "\"%s\"\t%.6f\t%.9g\t%.6f\t%.9g\n", label, exp(per(ray_log, scenes)),
                    fmax(per((double)ray_wrong, nr), floor_rate), exp(per(tri_log, scenes)),
                    fmax(per((double)tri_wrong, nt), floor_rate));
        }
        fprintf(trade, "\n\n");
    }
    for (int block = 0; block < 3; block++) {
        size_t m = traced[block];
        fprintf(resol, "# %s\n# factor\tus_per_ray\tus_per_tri\tbytes_per_triangle\tbuild_us_per_triangle\n",
                SETTINGS[m].label);
        for (size_t r = 0; r < RES_COUNT; r++) {
            double ray_log = 0, tri_log = 0, bytes = 0, build = 0;
            size_t scenes = 0, tris = 0;
            for (size_t i = 0; i < s->scene_count; i++) {
                const point_result *p = &s->res[i][m][r];
                if (!s->scenes[i].full_sweep || !p->built)
                    continue;
                ray_log += log(us_per_ray(p, s)), tri_log += log(us_per_tri(p, s));
                bytes += (double)p->info.bytes_total, build += p->info.build_seconds;
                tris += p->info.triangle_count, scenes++;
            }
            fprintf(resol, "%g\t%.6f\t%.6f\t%.3f\t%.6f\n", RES_FACTORS[r], exp(per(ray_log, scenes)),
                    exp(per(tri_log, scenes)), per(bytes, tris), 1e6 * per(build, tris));
        }
        fprintf(resol, "\n\n");
    }
    fclose(trade);
    fclose(resol);
}

static void write_point_tsv(FILE *tsv, FILE *cats, const scene *sc, size_t m, size_t r, const point_result *p,
                            const sweep *s)
{
    fprintf(tsv, "%s\t%zu\t%s\t%g\t%g\t%.9g\t%d\t%.6f\t%zu\t%zu\t%zu\t%zu\t%d\t%.6f\t%.6f\t%.4f\t%.4f\t%.4f\t"
                 "%.4f\t%.6f\t%.6f\t%zu\t%zu\t%zu\t%zu\t%zu\t%zu\t%zu\t%zu\t%zu\t%zu\t%zu\t%zu\t%zu\t%zu\t%zu\t%zu\t%zu\n",
            sc->name, sc->mesh.triangle_count, accuracy_mode_name(SETTINGS[m].mode), SETTINGS[m].eps,
            RES_FACTORS[r], p->info.resolution, p->built, p->info.build_seconds, p->info.bytes_total,
            p->info.node_count, p->info.leaf_count, p->info.leaf_refs, p->info.max_level, us_per_ray(p, s),
            us_per_tri(p, s), per((double)p->ray_stats.candidates_tested, s->rays),
            per((double)p->tri_stats.candidates_tested, s->tris), per((double)p->ray_stats.nodes_visited, s->rays),
            per((double)p->tri_stats.nodes_visited, s->tris), per((double)p->ray_stats.exact_fallbacks, s->rays),
            per((double)p->tri_stats.exact_fallbacks, s->tris), s->rays, p->ray_wrong, p->ray_fn, p->ray_fp,
            p->ray_other_point, p->ray_tie, p->ray_t_off, s->tris, p->tri_wrong, p->tri_fn_pairs, p->tri_fp_pairs, p->tri_truncated,
            s->oracle[sc - s->scenes].rays, p->orc_ray_wrong_clean, p->orc_ray_wrong_boundary,
            s->oracle[sc - s->scenes].tris, p->orc_tri_wrong);
    for (int c = 0; c < RC_COUNT; c++)
        if (p->ray_by_cat[c])
            fprintf(cats, "%s\t%s\t%g\t%g\tray_%s\t%zu\t%zu\t%zu\n", sc->name, accuracy_mode_name(SETTINGS[m].mode),
                    SETTINGS[m].eps, RES_FACTORS[r], RAY_CATEGORY_KEYS[c], p->ray_by_cat[c], p->ray_wrong_by_cat[c],
                    p->ray_tie_by_cat[c]);
    for (int c = 0; c < TC_COUNT; c++)
        if (p->tri_by_cat[c])
            fprintf(cats, "%s\t%s\t%g\t%g\ttri_%s\t%zu\t%zu\t0\n", sc->name, accuracy_mode_name(SETTINGS[m].mode),
                    SETTINGS[m].eps, RES_FACTORS[r], TRI_CATEGORY_KEYS[c], p->tri_by_cat[c], p->tri_wrong_by_cat[c]);
}

/* The oracle's answers to the sample (see oracle_sample); ids is scratch of TRI_CAPACITY. */
static void oracle_sample_compute(oracle_sample *os, const scene *sc, const workload *w, size_t rays, size_t tris,
                                  uint32_t *ids)
{
    double start = now();
    os->rays = rays < w->ray_count ? rays : w->ray_count;
    os->tris = tris < w->tri_count ? tris : w->tri_count;
    mesh_view v = mesh_data_view(&sc->mesh);
    os->ray_truth = calloc(os->rays ? os->rays : 1, sizeof *os->ray_truth);
    os->tri_first = calloc(os->tris + 1, sizeof *os->tri_first);
    size_t ids_cap = 0, used = 0;
    if (oracle_mesh_init(&os->om, &v) != 0 || !os->ray_truth || !os->tri_first ||
        array_reserve((void **)&os->tri_ids, &ids_cap, 1, sizeof *os->tri_ids, 1024) != 0) {
        fprintf(stderr, "report_accuracy: out of memory\n");
        exit(1);
    }
    for (size_t i = 0; i < os->rays; i++) {
        if (oracle_mesh_ray(&os->om, &w->rays[i], &os->ray_truth[i]) != 0) {
            fprintf(stderr, "report_accuracy: out of memory\n");
            exit(1);
        }
        const oracle_ray_truth *t = &os->ray_truth[i];
        if (t->boundary) {
            os->boundary++;
            os->boundary_by_cat[w->ray_cat[i]]++;
        } else {
            os->clean++;
            os->clean_hitting += t->count > 0;
            os->clean_by_cat[w->ray_cat[i]]++;
        }
    }
    for (size_t i = 0; i < os->tris; i++) {
        size_t n = oracle_mesh_triangle(&os->om, w->tris[i], ids, TRI_CAPACITY);
        n = n < TRI_CAPACITY ? n : TRI_CAPACITY;
        if (array_reserve((void **)&os->tri_ids, &ids_cap, used + n, sizeof *os->tri_ids, 1024) != 0) {
            fprintf(stderr, "report_accuracy: out of memory\n");
            exit(1);
        }
        memcpy(os->tri_ids + used, ids, n * sizeof *ids);
        used += n;
        os->tri_first[i + 1] = used;
        os->touching_tris += n > 0;
    }
    os->seconds = now() - start;
}

/* Frees the sample's answers, keeping its counts for the document. */
static void oracle_sample_release(oracle_sample *os)
{
    for (size_t i = 0; i < os->rays; i++)
        oracle_ray_truth_free(&os->ray_truth[i]);
    free(os->ray_truth);
    free(os->tri_ids);
    free(os->tri_first);
    oracle_mesh_free(&os->om);
    os->ray_truth = NULL;
    os->tri_ids = NULL;
    os->tri_first = NULL;
}

/* Runs every point of one scene: exact at the heuristic resolution first, as the reference
 * the whole workload is compared with; every point is also checked against the oracle on
 * the scene's sample. */
static void run_scene(sweep *s, size_t i, uint64_t seed, tri_contact *buf, uint32_t *ids, FILE *tsv, FILE *cats,
                      double started)
{
    scene *sc = &s->scenes[i];
    mesh_view v = mesh_data_view(&sc->mesh);
    octree_error err;
    octree *def_tree = octree_build(&v, NULL, &err);
    if (!def_tree) {
        printf("%s: default build failed: %s\n", sc->name, err.message);
        return;
    }
    octree_info def_info;
    octree_get_info(def_tree, &def_info);
    octree_free(def_tree);
    s->heuristic[i] = def_info.resolution;
    workload w = make_workload(sc, def_info.resolution, s->rays, s->tris, seed + i);
    truth tr = {calloc(w.ray_count, 1), calloc(w.ray_count, sizeof(uint32_t)), calloc(w.ray_count, sizeof(double)),
                calloc(w.tri_count + 1, sizeof(size_t)), NULL};
    if (!tr.ray_hit || !tr.ray_tri || !tr.ray_t || !tr.tri_first) {
        fprintf(stderr, "report_accuracy: out of memory\n");
        exit(1);
    }
    printf("\n## %s: %zu triangles, heuristic d %.6g\n", sc->name, sc->mesh.triangle_count, def_info.resolution);
    oracle_sample *os = &s->oracle[i];
    oracle_sample_compute(os, sc, &w, s->oracle_rays, s->oracle_tris, ids);
    printf("oracle     %zu rays (%zu without boundary contact, %zu of them hitting; %zu with), %zu triangle queries "
           "(%zu touching) in %.1f s  [%.0f s]\n",
           os->rays, os->clean, os->clean_hitting, os->boundary, os->tris, os->touching_tris, os->seconds,
           now() - started);
    fflush(stdout);
    size_t order[SETTING_COUNT * RES_COUNT][2], n = 0;
    order[n][0] = SETTING_EXACT, order[n][1] = RES_DEFAULT_INDEX, n++;
    for (size_t m = 0; m < SETTING_COUNT; m++)
        for (size_t r = 0; r < RES_COUNT; r++)
            if (!(m == SETTING_EXACT && r == RES_DEFAULT_INDEX) && point_in_sweep(sc, m, r))
                order[n][0] = m, order[n][1] = r, n++;
    for (size_t k = 0; k < n; k++) {
        size_t m = order[k][0], r = order[k][1];
        point_result *p = &s->res[i][m][r];
        p->ran = 1;
        octree_def def = octree_default_def();
        def.resolution = RES_FACTORS[r] * def_info.resolution;
        def.mode = SETTINGS[m].mode;
        if (SETTINGS[m].mode == ACCURACY_SEED)
            def.seed_epsilon = SETTINGS[m].eps;
        octree *t = octree_build(&v, &def, &err);
        if (!t) {
            printf("%-10s f=%-5g build failed: %s\n", SETTINGS[m].label, RES_FACTORS[r], err.message);
            write_point_tsv(tsv, cats, sc, m, r, p, s);
            continue;
        }
        p->built = 1;
        octree_get_info(t, &p->info);
        measure(t, &sc->mesh, &w, SETTINGS[m].mode, &tr, k == 0, os, buf, ids, p);
        octree_free(t);
        printf("%-10s f=%-5g build %7.3f s %8.1f MB  ray %7.3f us  tri %8.3f us  vs exact: rays %zu (ties %zu) tris %zu"
               "  vs oracle: rays %zu+%zu tris %zu  [%.0f s]\n",
               SETTINGS[m].label, RES_FACTORS[r], p->info.build_seconds, (double)p->info.bytes_total / 1e6,
               us_per_ray(p, s), us_per_tri(p, s), p->ray_wrong, p->ray_tie, p->tri_wrong, p->orc_ray_wrong_clean,
               p->orc_ray_wrong_boundary, p->orc_tri_wrong, now() - started);
        fflush(stdout);
        write_point_tsv(tsv, cats, sc, m, r, p, s);
    }
    if (strncmp(sc->kind, "real", 4) == 0) {
        measure_target(sc, &w, buf, &s->target[i]);
        const target_result *t = &s->target[i];
        if (t->ran)
            printf("target     exact/fast rays %.2fx, triangles %.2fx (medians of %d rounds)  [%.0f s]\n",
                   median_of(t->ray_ratio, TARGET_ROUNDS), median_of(t->tri_ratio, TARGET_ROUNDS), TARGET_ROUNDS,
                   now() - started);
    }
    oracle_sample_release(os);
    free(tr.ray_hit);
    free(tr.ray_tri);
    free(tr.ray_t);
    free(tr.tri_first);
    free(tr.tri_ids);
    workload_free(&w);
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: %s OUTDIR DOC.md [full|quick] [date]\n", argv[0]);
        return 2;
    }
    const char *outdir = argv[1], *doc = argv[2];
    int quick = argc > 3 && strcmp(argv[3], "quick") == 0;
    const char *date = argc > 4 ? argv[4] : "an unrecorded date";
    sweep *sw = calloc(1, sizeof *sw); /* large: kept off the stack */
    scene *scenes = calloc(MAX_SCENES, sizeof *scenes);
    if (!sw || !scenes) {
        fprintf(stderr, "report_accuracy: out of memory\n");
        return 1;
    }
    sw->scenes = scenes;
    sw->scene_count = load_scenes(scenes, quick);
    sw->rays = quick ? 2000 : 20000;
    sw->tris = quick ? 500 : 4000;
    const char *env = getenv("TRIOCT_ACC_QUERIES");
    if (env && atol(env) > 0) {
        sw->rays = (size_t)atol(env);
        sw->tris = sw->rays / 5 ? sw->rays / 5 : 1;
    }
    /* A fifth of each workload. The oracle costs 0.1-0.5 ms per candidate triangle and the
     * box rejection a few ns per triangle per query: a few minutes on the full scenes. */
    sw->oracle_rays = quick ? 400 : 4000;
    sw->oracle_tris = quick ? 100 : 800;
    const char *oenv = getenv("TRIOCT_ACC_ORACLE");
    if (oenv && atol(oenv) >= 0) {
        sw->oracle_rays = (size_t)atol(oenv);
        sw->oracle_tris = sw->oracle_rays / 5;
    }
    uint64_t seed = 20260303;
    if (getenv("TRIOCT_SEED"))
        seed = strtoull(getenv("TRIOCT_SEED"), NULL, 10);
    printf("# accuracy report: %zu scenes, %zu closest rays and %zu triangle-ids queries per scene (the first %zu "
           "and %zu also against the oracle), fastest of %d timed passes, seed %llu\n",
           sw->scene_count, sw->rays, sw->tris, sw->oracle_rays, sw->oracle_tris, TIMED_PASSES,
           (unsigned long long)seed);
    tri_contact *buf = malloc(TRI_CAPACITY * sizeof *buf);
    uint32_t *ids = malloc(TRI_CAPACITY * sizeof *ids);
    if (!buf || !ids) {
        fprintf(stderr, "report_accuracy: out of memory\n");
        return 1;
    }
    FILE *tsv = open_or_die(outdir, "results.tsv");
    FILE *cats = open_or_die(outdir, "categories.tsv");
    fprintf(tsv, "scene\ttriangles\tmode\tseed_eps\tres_factor\tresolution\tbuilt\tbuild_s\tbytes_total\tnodes\tleaves\t"
                 "leaf_refs\tmax_level\tray_us\ttri_us\tray_candidates\ttri_candidates\tray_nodes\ttri_nodes\t"
                 "ray_fallbacks\ttri_fallbacks\trays\tray_wrong\tray_fn\tray_fp\tray_other_point\tray_ties\tray_t_off\ttris\t"
                 "tri_wrong\ttri_fn_ids\ttri_fp_ids\ttri_truncated\toracle_rays\toracle_ray_wrong_clean\t"
                 "oracle_ray_wrong_boundary\toracle_tris\toracle_tri_wrong\n");
    fprintf(cats, "scene\tmode\tseed_eps\tres_factor\tcategory\tqueries\twrong\tties\n");
    double started = now();
    for (size_t i = 0; i < sw->scene_count; i++)
        run_scene(sw, i, seed, buf, ids, tsv, cats, started);
    fclose(tsv);
    fclose(cats);
    write_plot_tables(sw, outdir);

    int hard_done = run_hard_cases(sw);
    if (hard_done) {
        FILE *hard = open_or_die(outdir, "hard_cases.tsv");
        fprintf(hard, "category\tmode\tseed_eps\tcases\twrong\tmissed\textra\n");
        for (size_t c = 0; c <= sw->hard_category_count; c++)
            for (size_t m = 0; m < SETTING_COUNT; m++)
                if (sw->hard[c][m].cases)
                    fprintf(hard, "%s\t%s\t%g\t%zu\t%zu\t%zu\t%zu\n",
                            c < sw->hard_category_count ? sw->hard_categories[c] : "(other)",
                            accuracy_mode_name(SETTINGS[m].mode), SETTINGS[m].eps, sw->hard[c][m].cases,
                            sw->hard[c][m].wrong, sw->hard[c][m].missed, sw->hard[c][m].extra);
        fclose(hard);
    }
    printf("\nhard-case catalogue: %s\n", hard_done ? "counted" : "not available");

    write_markdown(doc, sw, date, hard_done);
    printf("wrote %s/results.tsv, categories.tsv, plot tables and %s in %.0f s\n", outdir, doc, now() - started);
    for (size_t i = 0; i < sw->scene_count; i++)
        mesh_data_free(&scenes[i].mesh);
    free(scenes);
    free(sw);
    free(buf);
    free(ids);
    return 0;
}
