/* trioct against its peers: Embree 3 for rays and builds, FCL 0.7 for triangles and a
 * shape at poses. One core (the process pinned to one CPU, Embree's device on one thread),
 * each figure the median over alternating rounds (even rounds trioct first, odd rounds the
 * peer first, the same queries on both sides), printed as trioct_rate / peer_rate with its
 * range over the rounds beside the target. Prints figures; asserts nothing about time.
 * trioct is reached through server/engine.h alone, so engine rewrites show up here as
 * they land. Only this benchmark links Embree and FCL; the product never does.
 * `bench_peers [terrain,icosphere,wuson,spider]` runs the named worlds only. */
#define _GNU_SOURCE
#include <math.h>
#include <sched.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <time.h>

#if defined(__x86_64__) || defined(__i386__)
#include <pmmintrin.h>
#include <xmmintrin.h>
#define HAVE_MXCSR 1
#endif

#include <embree3/rtcore.h>

#include "engine.h"
#include "fcl_peer.h"
#include "support/meshgen.h"
#include "support/query_shapes.h"
#include "support/real_meshes.h"

/* Counts, chosen so that the whole run (about 100 s of CPU) stays under three minutes on
 * this project's 2-core machine while other work shares it; all are printed. */
enum {
    ROUNDS = 5,               /* alternating rounds per figure (odd, for a plain median) */
    RANDOM_RAYS = 20000,      /* per random ray set */
    CAMERA_SIDE = 256,        /* pinhole camera, CAMERA_SIDE^2 rays */
    LIDAR_AZIMUTHS = 1024,    /* lidar sweep: azimuth steps x beams */
    LIDAR_BEAMS = 64,
    RAY_BATCH = 256,          /* rays per octree_ray_batch call (as bench_engine) */
    TRI_QUERIES = 10000,      /* single query triangles */
    POSES = 1000,             /* shape poses per world */
    POSE_CHUNK = 16,          /* poses per octree_mesh_tree_batch call */
    PAIR_CAP = 1 << 16,       /* pairs stored per pose (counts are exact beyond it) */
    TRI_CAP = 4096,           /* contacts stored per triangle query */
};
#define FCL_ALL_CONTACTS ((size_t)1 << 24) /* num_max_contacts for "every pair" */
/* The shape's bounding radius as a fraction of the world's bounding half-diagonal, and
 * its centre's offset from the surface along the normal in shape radii. */
#define SHAPE_FRACTION 0.02
#define OFFSET_LO (-0.05)
#define OFFSET_HI 1.3

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int compare_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median_of(const double *v, int n)
{
    double s[64];
    memcpy(s, v, (size_t)n * sizeof *s);
    qsort(s, (size_t)n, sizeof *s, compare_double);
    return n % 2 ? s[n / 2] : 0.5 * (s[n / 2 - 1] + s[n / 2]);
}

static void *xcalloc(size_t n, size_t size)
{
    void *p = calloc(n ? n : 1, size);
    if (!p) {
        fprintf(stderr, "bench_peers: out of memory\n");
        exit(1);
    }
    return p;
}

/* ---------- results: rows kept per section, printed as tables at the end ---------- */

typedef enum section { SEC_BUILD, SEC_RAYS, SEC_TRIS, SEC_SHAPE, SEC_COUNT } section;
static const char *const SECTION_TITLE[SEC_COUNT] = {
    "build and memory vs Embree: ratio trioct/Embree, lower is better",
    "rays vs Embree rtcIntersect1/rtcOccluded1: rays/s, trioct per ray / batch",
    "single triangles vs FCL: queries/s",
    "shape at poses vs FCL: poses/s",
};
static const char *const SECTION_EXTRA[SEC_COUNT] = {
    "Embree's part",
    "agree % hit/miss, id  trioct nodes, cands/ray",
    "answers; trioct nodes, cands/query",
    "answers; trioct nodes, cands/pose",
};
static const char *const SECTION_KEY[SEC_COUNT] = {"build", "rays", "triangles", "shape"};

typedef enum unit { U_RATE, U_SECONDS, U_BYTES } unit;

/* One measured figure: each side's median over the rounds, the median of the rounds'
 * ratios trioct/peer and their range. */
typedef struct figure {
    double trioct, peer, ratio, lo, hi;
} figure;

typedef struct row {
    section sec;
    char mesh[16];
    char query[32];
    unit u;
    int variants;   /* 2: per ray and batch side by side, against the same peer figure */
    figure f[2];
    double target;  /* 0: for information */
    int at_most;    /* 1: the ratio should be <= target, else >= */
    char extra[96]; /* answers compared, work per query */
} row;

static row rows[256];
static size_t row_count;

/* Lines printed under a section's table. */
static char notes[SEC_COUNT][4096];

static void note(section s, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void note(section s, const char *fmt, ...)
{
    size_t used = strlen(notes[s]);
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(notes[s] + used, sizeof notes[s] - used, fmt, ap);
    va_end(ap);
}

static figure figure_of(const double *t, const double *p, const double *ratio, int n)
{
    figure f = {median_of(t, n), median_of(p, n), median_of(ratio, n), ratio[0], ratio[0]};
    for (int i = 1; i < n; i++) {
        f.lo = ratio[i] < f.lo ? ratio[i] : f.lo;
        f.hi = ratio[i] > f.hi ? ratio[i] : f.hi;
    }
    return f;
}

/* Rates from per-round seconds for `count` queries; each round's ratio is trioct/peer. */
static figure rate_figure(size_t count, const double *t_sec, const double *p_sec)
{
    double tr[ROUNDS], pr[ROUNDS], ratio[ROUNDS];
    for (int k = 0; k < ROUNDS; k++) {
        tr[k] = (double)count / t_sec[k];
        pr[k] = (double)count / p_sec[k];
        ratio[k] = tr[k] / pr[k];
    }
    return figure_of(tr, pr, ratio, ROUNDS);
}

static row *add_row(section s, const char *mesh, const char *query, unit u, double target, int at_most)
{
    static row spare;
    if (row_count == sizeof rows / sizeof rows[0])
        return &spare;
    row *r = &rows[row_count++];
    *r = (row){.sec = s, .u = u, .variants = 1, .target = target, .at_most = at_most};
    snprintf(r->mesh, sizeof r->mesh, "%s", mesh);
    snprintf(r->query, sizeof r->query, "%s", query);
    return r;
}

static int met(const row *r, int v)
{
    return r->at_most ? r->f[v].ratio <= r->target : r->f[v].ratio >= r->target;
}

static void format_value(char *buf, size_t len, unit u, double v)
{
    if (u == U_SECONDS)
        snprintf(buf, len, "%.3f s", v);
    else if (u == U_BYTES)
        snprintf(buf, len, "%.1f B", v);
    else if (v >= 1e6)
        snprintf(buf, len, "%.3fM", v / 1e6);
    else if (v >= 1e4)
        snprintf(buf, len, "%.1fk", v / 1e3);
    else
        snprintf(buf, len, "%.0f", v);
}

/* "a / b" for a two-variant row, else "a". */
static void cell(char *buf, size_t len, const row *r, const char *a, const char *b)
{
    if (r->variants == 2)
        snprintf(buf, len, "%s / %s", a, b);
    else
        snprintf(buf, len, "%s", a);
}

static void print_tables(void)
{
    for (int s = 0; s < SEC_COUNT; s++) {
        printf("\n## %s\n", SECTION_TITLE[s]);
        printf("%-11s %-26s %15s %8s %13s %21s %6s %8s  %s\n", "mesh", "query", "trioct", "peer", "ratio", "range",
               "target", "met", SECTION_EXTRA[s]);
        for (size_t i = 0; i < row_count; i++) {
            const row *r = &rows[i];
            if ((int)r->sec != s)
                continue;
            char v[2][4][32], t[80], ratio[80], range[80], target[16], yes[80], peer[32];
            for (int k = 0; k < r->variants; k++) {
                format_value(v[k][0], sizeof v[k][0], r->u, r->f[k].trioct);
                snprintf(v[k][1], sizeof v[k][1], "%.2fx", r->f[k].ratio);
                snprintf(v[k][2], sizeof v[k][2], "%.2f-%.2f", r->f[k].lo, r->f[k].hi);
                snprintf(v[k][3], sizeof v[k][3], "%s", r->target > 0 ? (met(r, k) ? "yes" : "no") : "-");
            }
            int b = r->variants - 1;
            cell(t, sizeof t, r, v[0][0], v[b][0]);
            cell(ratio, sizeof ratio, r, v[0][1], v[b][1]);
            cell(range, sizeof range, r, v[0][2], v[b][2]);
            cell(yes, sizeof yes, r, v[0][3], v[b][3]);
            format_value(peer, sizeof peer, r->u, r->f[0].peer);
            if (r->target > 0)
                snprintf(target, sizeof target, "%s%.1f", r->at_most ? "<=" : ">=", r->target);
            else
                snprintf(target, sizeof target, "info");
            printf("%-11s %-26s %15s %8s %13s %21s %6s %8s  %s\n", r->mesh, r->query, t, peer, ratio, range, target,
                   yes, r->extra);
        }
        if (notes[s][0])
            printf("%s", notes[s]);
    }
}

/* Per section: targets met, the spread of the medians, the row furthest from its target. */
static void print_summary(void)
{
    size_t met_all = 0, total_all = 0;
    const row *worst_all = NULL;
    int worst_all_v = 0;
    double worst_all_share = INFINITY;
    printf("\n## summary of targets (per ray and batch counted apart)\n");
    for (int s = 0; s < SEC_COUNT; s++) {
        size_t n_met = 0, total = 0;
        double lo = INFINITY, hi = -INFINITY, worst_share = INFINITY;
        const row *worst = NULL;
        int worst_v = 0;
        for (size_t i = 0; i < row_count; i++) {
            const row *r = &rows[i];
            if ((int)r->sec != s || r->target <= 0)
                continue;
            for (int v = 0; v < r->variants; v++) {
                total++;
                n_met += (size_t)met(r, v);
                lo = r->f[v].ratio < lo ? r->f[v].ratio : lo;
                hi = r->f[v].ratio > hi ? r->f[v].ratio : hi;
                /* The share of its target a figure reaches: 1 is just met. */
                double share = r->at_most ? r->target / r->f[v].ratio : r->f[v].ratio / r->target;
                if (share < worst_share) {
                    worst_share = share;
                    worst = r;
                    worst_v = v;
                }
            }
        }
        if (!worst)
            continue;
        met_all += n_met;
        total_all += total;
        if (worst_share < worst_all_share) {
            worst_all_share = worst_share;
            worst_all = worst;
            worst_all_v = worst_v;
        }
        printf("%-10s met %2zu of %2zu, medians %.2fx-%.2fx; furthest: %s, %s%s, %.2fx (%s%.1f)\n", SECTION_KEY[s],
               n_met, total, lo, hi, worst->mesh, worst->query,
               worst->variants == 2 ? (worst_v ? ", batch" : ", per ray") : "", worst->f[worst_v].ratio,
               worst->at_most ? "<=" : ">=", worst->target);
    }
    printf("all        met %zu of %zu", met_all, total_all);
    if (worst_all)
        printf("; furthest: %s, %s, %s%s at %.0f%% of its target\n", SECTION_KEY[worst_all->sec], worst_all->mesh,
               worst_all->query, worst_all->variants == 2 ? (worst_all_v ? ", batch" : ", per ray") : "",
               100.0 * worst_all_share);
    else
        printf("\n");
}

/* ---------- one core ---------- */

static int pin_to_one_cpu(void)
{
    cpu_set_t set;
    int cpu = sched_getcpu();
    if (cpu < 0)
        cpu = 0;
    CPU_ZERO(&set);
    CPU_SET(cpu, &set);
    if (sched_setaffinity(0, sizeof set, &set) != 0) {
        perror("bench_peers: sched_setaffinity");
        return -1;
    }
    return cpu;
}

/* ---------- Embree ---------- */

typedef struct embree_memory {
    atomic_llong now, peak;
} embree_memory;

static bool embree_monitor(void *user, ssize_t bytes, bool post)
{
    (void)post; /* never cancelled, so every call is an allocation or a free that happens */
    embree_memory *m = user;
    long long cur = atomic_fetch_add(&m->now, (long long)bytes) + (long long)bytes;
    long long peak = atomic_load(&m->peak);
    while (cur > peak && !atomic_compare_exchange_weak(&m->peak, &peak, cur)) {
    }
    return true;
}

static void embree_error(void *user, enum RTCError code, const char *str)
{
    (void)user;
    fprintf(stderr, "bench_peers: Embree error %d: %s\n", (int)code, str);
}

/* Embree asks for flush-to-zero and denormals-are-zero on the threads that trace; trioct's
 * exact arithmetic must not run under them, so they are on only around Embree's work. */
static unsigned embree_enter(void)
{
#ifdef HAVE_MXCSR
    unsigned saved = _mm_getcsr();
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
    return saved;
#else
    return 0;
#endif
}

static void embree_leave(unsigned saved)
{
#ifdef HAVE_MXCSR
    _mm_setcsr(saved);
#else
    (void)saved;
#endif
}

typedef struct embree_build {
    RTCScene scene;
    double seconds;        /* rtcNewScene .. rtcCommitScene, buffers filled from the doubles */
    double commit_seconds; /* rtcCommitScene alone */
    long long buffer_bytes; /* the monitor's count after the buffers were made */
    long long held_bytes;  /* the monitor's count after the commit */
    long long peak_bytes;  /* the most the monitor counted during the build */
} embree_build;

/* A user's build: default scene flags and build quality (RTC_BUILD_QUALITY_MEDIUM, no
 * RTC_SCENE_FLAG_ROBUST or COMPACT), one triangle geometry over Embree-managed float3
 * vertex (12 bytes each, Embree pads the buffer for its 16-byte loads) and uint3 index
 * buffers. */
static embree_build embree_build_scene(RTCDevice dev, embree_memory *mem, const mesh_data *m)
{
    embree_build b = {0};
    unsigned csr = embree_enter();
    long long base = atomic_load(&mem->now);
    atomic_store(&mem->peak, base);
    double t0 = now();
    b.scene = rtcNewScene(dev);
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                       m->vertex_count);
    unsigned *idx = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                            m->triangle_count);
    for (size_t i = 0; i < m->vertex_count; i++) {
        v[3 * i] = (float)m->vertices[i].x;
        v[3 * i + 1] = (float)m->vertices[i].y;
        v[3 * i + 2] = (float)m->vertices[i].z;
    }
    memcpy(idx, m->indices, 3 * m->triangle_count * sizeof *idx);
    b.buffer_bytes = atomic_load(&mem->now) - base;
    rtcCommitGeometry(g);
    rtcAttachGeometry(b.scene, g);
    rtcReleaseGeometry(g);
    double t1 = now();
    rtcCommitScene(b.scene);
    double t2 = now();
    b.seconds = t2 - t0;
    b.commit_seconds = t2 - t1;
    b.held_bytes = atomic_load(&mem->now) - base;
    b.peak_bytes = atomic_load(&mem->peak) - base;
    embree_leave(csr);
    return b;
}

/* ---------- ray sets ---------- */

typedef struct ray_set {
    const char *name;
    int coherent;
    size_t count;
    ray_input *rays;
    float (*org)[3], (*dir)[3]; /* the same rays rounded to float for Embree */
} ray_set;

static void ray_set_alloc(ray_set *s, const char *name, int coherent, size_t count)
{
    *s = (ray_set){name, coherent, count, xcalloc(count, sizeof(ray_input)), xcalloc(count, sizeof *s->org),
                   xcalloc(count, sizeof *s->dir)};
}

static void ray_set_finish(ray_set *s)
{
    for (size_t i = 0; i < s->count; i++) {
        const ray_input *r = &s->rays[i];
        s->org[i][0] = (float)r->origin.x;
        s->org[i][1] = (float)r->origin.y;
        s->org[i][2] = (float)r->origin.z;
        s->dir[i][0] = (float)r->direction.x;
        s->dir[i][1] = (float)r->direction.y;
        s->dir[i][2] = (float)r->direction.z;
    }
}

static void ray_set_free(ray_set *s)
{
    free(s->rays);
    free(s->org);
    free(s->dir);
}

static vec3 random_surface_point(const mesh_data *m, rng *r, size_t *tri)
{
    size_t t = rng_next(r) % m->triangle_count;
    double u = rng_uniform(r, 0, 1), v = rng_uniform(r, 0, 1);
    if (u + v > 1) {
        u = 1 - u;
        v = 1 - v;
    }
    vec3 a = mesh_data_corner(m, t, 0), b = mesh_data_corner(m, t, 1), c = mesh_data_corner(m, t, 2);
    if (tri)
        *tri = t;
    return vec3_add(a, vec3_add(vec3_scale(vec3_sub(b, a), u), vec3_scale(vec3_sub(c, a), v)));
}

/* From random points in the box grown by a fifth on each side toward random surface
 * points: rays that mostly hit, as a sensor's do. */
static void rays_toward_surface(ray_set *s, const mesh_data *m, rng *r)
{
    box3 b = mesh_data_bounds(m);
    vec3 ext = vec3_sub(b.hi, b.lo);
    box3 around = {vec3_sub(b.lo, vec3_scale(ext, 0.2)), vec3_add(b.hi, vec3_scale(ext, 0.2))};
    ray_set_alloc(s, "random to surface", 0, RANDOM_RAYS);
    for (size_t i = 0; i < s->count; i++) {
        vec3 target = random_surface_point(m, r, NULL);
        vec3 o = rng_point_in_box(r, around);
        s->rays[i] = (ray_input){o, vec3_sub(target, o), 0, INFINITY, RAY_CROSSING};
    }
    ray_set_finish(s);
}

/* From random points inside the box in random directions. */
static void rays_inside(ray_set *s, const mesh_data *m, rng *r)
{
    box3 b = mesh_data_bounds(m);
    ray_set_alloc(s, "random in box", 0, RANDOM_RAYS);
    for (size_t i = 0; i < s->count; i++)
        s->rays[i] = (ray_input){rng_point_in_box(r, b), rng_unit_vector(r), 0, INFINITY, RAY_CROSSING};
    ray_set_finish(s);
}

/* A pinhole camera outside the bounding sphere, its field of view framing the vertices'
 * RMS radius, rows swept in order. */
static void rays_camera(ray_set *s, const mesh_data *m)
{
    box3 b = mesh_data_bounds(m);
    vec3 centre = vec3_scale(vec3_add(b.lo, b.hi), 0.5);
    double radius = 0.5 * vec3_length(vec3_sub(b.hi, b.lo)), rms = 0;
    for (size_t i = 0; i < m->vertex_count; i++) {
        vec3 dv = vec3_sub(m->vertices[i], centre);
        rms += vec3_dot(dv, dv);
    }
    rms = sqrt(rms / (double)m->vertex_count);
    vec3 eye = vec3_add(centre, vec3_scale(vec3_normalize((vec3){0.6, -0.7, 0.45}), 2.2 * radius));
    vec3 forward = vec3_normalize(vec3_sub(centre, eye));
    vec3 right = vec3_normalize(vec3_cross(forward, (vec3){0, 0, 1}));
    vec3 up = vec3_cross(right, forward);
    double half = 0.8 * rms / (2.2 * radius);
    ray_set_alloc(s, "camera", 1, (size_t)CAMERA_SIDE * CAMERA_SIDE);
    for (size_t y = 0; y < CAMERA_SIDE; y++)
        for (size_t x = 0; x < CAMERA_SIDE; x++) {
            double u = (2.0 * ((double)x + 0.5) / CAMERA_SIDE - 1.0) * half;
            double v = (2.0 * ((double)y + 0.5) / CAMERA_SIDE - 1.0) * half;
            vec3 d = vec3_add(forward, vec3_add(vec3_scale(right, u), vec3_scale(up, v)));
            s->rays[y * CAMERA_SIDE + x] = (ray_input){eye, d, 0, INFINITY, RAY_CROSSING};
        }
    ray_set_finish(s);
}

/* A spinning lidar at the middle of the box (inside a closed world, as in a room; among
 * the hills of the terrain): each column of beams from 45 degrees below the horizon to 45
 * above, columns swept round the full circle. */
static void rays_lidar(ray_set *s, const mesh_data *m)
{
    box3 b = mesh_data_bounds(m);
    vec3 o = vec3_scale(vec3_add(b.lo, b.hi), 0.5);
    ray_set_alloc(s, "lidar", 1, (size_t)LIDAR_AZIMUTHS * LIDAR_BEAMS);
    const double pi = 3.14159265358979323846;
    for (size_t a = 0; a < LIDAR_AZIMUTHS; a++)
        for (size_t e = 0; e < LIDAR_BEAMS; e++) {
            double az = 2 * pi * (double)a / LIDAR_AZIMUTHS;
            double el = (-45.0 + 90.0 * (double)e / (LIDAR_BEAMS - 1)) * pi / 180;
            vec3 d = {cos(el) * cos(az), cos(el) * sin(az), sin(el)};
            s->rays[a * LIDAR_BEAMS + e] = (ray_input){o, d, 0, INFINITY, RAY_CROSSING};
        }
    ray_set_finish(s);
}

/* ---------- ray passes: seconds for the whole set; ids[i] the hit triangle or -1 ---------- */

static double trioct_rays(const octree *t, const ray_set *s, ray_detail d, int64_t *ids, query_stats *st)
{
    ray_hit h;
    double t0 = now();
    for (size_t i = 0; i < s->count; i++) {
        ray_output out = {.hits = &h, .max_hits = 1};
        octree_ray(t, &s->rays[i], d, ACCURACY_EXACT, &out, st);
        ids[i] = out.hit_count ? (int64_t)h.triangle : -1;
    }
    return now() - t0;
}

static double trioct_ray_batches(const octree *t, const ray_set *s, ray_detail d, int64_t *ids)
{
    ray_hit hits[RAY_BATCH];
    ray_output outs[RAY_BATCH];
    octree_status statuses[RAY_BATCH];
    double t0 = now();
    for (size_t i = 0; i < s->count; i += RAY_BATCH) {
        size_t n = s->count - i < RAY_BATCH ? s->count - i : RAY_BATCH;
        for (size_t k = 0; k < n; k++)
            outs[k] = (ray_output){.hits = &hits[k], .max_hits = 1};
        octree_ray_batch(t, &s->rays[i], n, d, ACCURACY_EXACT, outs, statuses, NULL);
        for (size_t k = 0; k < n; k++)
            ids[i + k] = outs[k].hit_count ? (int64_t)hits[k].triangle : -1;
    }
    return now() - t0;
}

static void embree_ray_init(struct RTCRay *r, const ray_set *s, size_t i)
{
    r->org_x = s->org[i][0];
    r->org_y = s->org[i][1];
    r->org_z = s->org[i][2];
    r->dir_x = s->dir[i][0];
    r->dir_y = s->dir[i][1];
    r->dir_z = s->dir[i][2];
    r->tnear = 0.0f;
    r->tfar = INFINITY;
    r->time = 0.0f;
    r->mask = 0xFFFFFFFFu;
    r->id = (unsigned)i;
    r->flags = 0;
}

/* rtcIntersect1 / rtcOccluded1, a fresh RTCIntersectContext per ray. Any-hit ids are 0. */
static double embree_rays(RTCScene scene, const ray_set *s, int closest, int64_t *ids)
{
    unsigned csr = embree_enter();
    double t0 = now();
    for (size_t i = 0; i < s->count; i++) {
        struct RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        if (closest) {
            struct RTCRayHit rh;
            embree_ray_init(&rh.ray, s, i);
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(scene, &ctx, &rh);
            ids[i] = rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? -1 : (int64_t)rh.hit.primID;
        } else {
            struct RTCRay r;
            embree_ray_init(&r, s, i);
            rtcOccluded1(scene, &ctx, &r);
            ids[i] = r.tfar < 0 ? 0 : -1;
        }
    }
    double secs = now() - t0;
    embree_leave(csr);
    return secs;
}

/* rtcIntersect8 / rtcOccluded8 over eight consecutive rays of the sweep. */
static double embree_rays8(RTCScene scene, const ray_set *s, int closest, int64_t *ids)
{
    unsigned csr = embree_enter();
    double t0 = now();
    for (size_t i = 0; i < s->count; i += 8) {
        _Alignas(32) int valid[8]; /* Embree reads the mask with aligned loads */
        struct RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        struct RTCRayHit8 rh;
        struct RTCRay8 *r = &rh.ray;
        for (int k = 0; k < 8; k++) {
            size_t j = i + (size_t)k < s->count ? i + (size_t)k : s->count - 1;
            valid[k] = i + (size_t)k < s->count ? -1 : 0;
            r->org_x[k] = s->org[j][0];
            r->org_y[k] = s->org[j][1];
            r->org_z[k] = s->org[j][2];
            r->dir_x[k] = s->dir[j][0];
            r->dir_y[k] = s->dir[j][1];
            r->dir_z[k] = s->dir[j][2];
            r->tnear[k] = 0.0f;
            r->tfar[k] = INFINITY;
            r->time[k] = 0.0f;
            r->mask[k] = 0xFFFFFFFFu;
            r->id[k] = (unsigned)j;
            r->flags[k] = 0;
            rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
        }
        if (closest)
            rtcIntersect8(valid, scene, &ctx, &rh);
        else
            rtcOccluded8(valid, scene, &ctx, r);
        for (int k = 0; k < 8 && i + (size_t)k < s->count; k++)
            ids[i + (size_t)k] = closest ? (rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID ? -1 : (int64_t)rh.hit.primID[k])
                                         : (r->tfar[k] < 0 ? 0 : -1);
    }
    double secs = now() - t0;
    embree_leave(csr);
    return secs;
}

/* Closest and any-hit over one ray set; the Embree x8 figures of coherent sets are added
 * to x8 for the section's notes. */
static void bench_rays(const char *mesh, const octree *tree, RTCScene scene, const ray_set *s, char *x8,
                       size_t x8_len)
{
    int64_t *ti = xcalloc(s->count, sizeof *ti), *tb = xcalloc(s->count, sizeof *tb),
            *ei = xcalloc(s->count, sizeof *ei), *e8 = xcalloc(s->count, sizeof *e8);
    for (int closest = 1; closest >= 0; closest--) {
        ray_detail d = closest ? RAY_CLOSEST : RAY_ANY;
        double t_one[ROUNDS], t_batch[ROUNDS], e_one[ROUNDS], e_eight[ROUNDS];
        query_stats st = {0};
        size_t hit_agree = 0, id_agree = 0, t_hits = 0, batch_same = 1;
        for (int k = 0; k < ROUNDS; k++) {
            for (int side = 0; side < 2; side++) {
                if ((side == 0) == (k % 2 == 0)) {
                    t_one[k] = trioct_rays(tree, s, d, ti, k == 0 ? &st : NULL);
                    t_batch[k] = trioct_ray_batches(tree, s, d, tb);
                } else {
                    e_one[k] = embree_rays(scene, s, closest, ei);
                    e_eight[k] = s->coherent ? embree_rays8(scene, s, closest, e8) : 1;
                }
            }
            if (k > 0)
                continue;
            for (size_t i = 0; i < s->count; i++) {
                int th = ti[i] >= 0, eh = ei[i] >= 0;
                t_hits += (size_t)th;
                hit_agree += (size_t)(th == eh);
                id_agree += (size_t)(ti[i] == ei[i] || (!closest && th == eh));
                batch_same &= (size_t)((tb[i] >= 0) == th && (!closest || tb[i] == ti[i]));
            }
        }
        const char *dn = closest ? "closest" : "any-hit";
        char q[48];
        snprintf(q, sizeof q, "%s, %s", dn, s->name);
        row *r = add_row(SEC_RAYS, mesh, q, U_RATE, s->coherent ? 1.0 : 0.6, 0);
        r->variants = 2;
        r->f[0] = rate_figure(s->count, t_one, e_one);
        r->f[1] = rate_figure(s->count, t_batch, e_one);
        double n = (double)s->count;
        char ids[16] = "";
        if (closest)
            snprintf(ids, sizeof ids, " / %.2f", 100 * (double)id_agree / n);
        snprintf(r->extra, sizeof r->extra, "hits %5.1f%%, agree %6.2f%s; %.1f, %.1f%s", 100 * (double)t_hits / n,
                 100 * (double)hit_agree / n, ids, (double)st.nodes_visited / n, (double)st.candidates_tested / n,
                 batch_same ? "" : " (batch answers differ)");
        if (s->coherent) {
            figure f8 = rate_figure(s->count, t_batch, e_eight);
            size_t used = strlen(x8);
            snprintf(x8 + used, x8_len - used, "%s%s %s %.3fM %.2fx", used ? ", " : "", s->name, dn, f8.peer / 1e6,
                     f8.ratio);
        }
    }
    free(ti);
    free(tb);
    free(ei);
    free(e8);
}

/* ---------- shapes and poses ---------- */

static pose random_pose(rng *r, vec3 shape_centre, vec3 at)
{
    const double pi = 3.14159265358979323846;
    double u1 = rng_uniform(r, 0, 1), u2 = rng_uniform(r, 0, 1), u3 = rng_uniform(r, 0, 1);
    double a = sqrt(1 - u1), b = sqrt(u1);
    double x = a * sin(2 * pi * u2), y = a * cos(2 * pi * u2), z = b * sin(2 * pi * u3), w = b * cos(2 * pi * u3);
    pose p = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w), 2 * (x * y + z * w),
               1 - 2 * (x * x + z * z), 2 * (y * z - x * w), 2 * (x * z - y * w), 2 * (y * z + x * w),
               1 - 2 * (x * x + y * y)},
              {0, 0, 0}};
    vec3 rc = {p.r[0] * shape_centre.x + p.r[1] * shape_centre.y + p.r[2] * shape_centre.z,
               p.r[3] * shape_centre.x + p.r[4] * shape_centre.y + p.r[5] * shape_centre.z,
               p.r[6] * shape_centre.x + p.r[7] * shape_centre.y + p.r[8] * shape_centre.z};
    p.t = vec3_sub(at, rc);
    return p;
}

/* Poses whose shape centre sits off a random surface point along its triangle's normal,
 * by OFFSET_LO..OFFSET_HI shape radii: about half of them touch the world. */
static void make_poses(const mesh_data *world, vec3 shape_centre, double shape_radius, rng *r, pose *out, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        size_t t;
        vec3 p = random_surface_point(world, r, &t);
        vec3 a = mesh_data_corner(world, t, 0), b = mesh_data_corner(world, t, 1), c = mesh_data_corner(world, t, 2);
        vec3 nrm = vec3_normalize(vec3_cross(vec3_sub(b, a), vec3_sub(c, a)));
        double s = rng_uniform(r, OFFSET_LO, OFFSET_HI);
        out[i] = random_pose(r, shape_centre, vec3_add(p, vec3_scale(nrm, s * shape_radius)));
    }
}

/* The trioct side of one shape at many poses: the one place to switch when a shape-tree
 * API arrives. counts[i] is 0/1 (yes/no) or the pairs of pose i; seconds for all. */
/* The shape's own octree is built once, outside the timing, as the daemon builds a
 * registered shape's at load (and as FCL's models are built here). */
static double trioct_shape_at_poses(const octree *tree, const octree *shape, const pose *poses, size_t n,
                                    int all_pairs, size_t *counts, query_stats *stats)
{
    static mesh_pair *pairs;
    if (!pairs)
        pairs = xcalloc((size_t)POSE_CHUNK * PAIR_CAP, sizeof *pairs);
    mesh_output outs[POSE_CHUNK];
    octree_status statuses[POSE_CHUNK];
    double t0 = now();
    for (size_t i = 0; i < n; i += POSE_CHUNK) {
        size_t k = n - i < POSE_CHUNK ? n - i : POSE_CHUNK;
        for (size_t j = 0; j < k; j++)
            outs[j] = (mesh_output){.pairs = &pairs[j * PAIR_CAP], .capacity = PAIR_CAP};
        octree_mesh_tree_batch(tree, shape, &poses[i], k, all_pairs, ACCURACY_EXACT, outs, statuses, stats);
        for (size_t j = 0; j < k; j++)
            counts[i + j] = all_pairs ? outs[j].count : (size_t)outs[j].hit;
    }
    return now() - t0;
}

static double fcl_shape_at_poses(fcl_peer_model *shape, const fcl_peer_model *world, const pose *poses, size_t n,
                                 int all_pairs, size_t *counts)
{
    double t0 = now();
    for (size_t i = 0; i < n; i++) {
        double t[3] = {poses[i].t.x, poses[i].t.y, poses[i].t.z};
        size_t c = fcl_peer_collide(shape, poses[i].r, t, world, all_pairs ? FCL_ALL_CONTACTS : 1, NULL, 0);
        counts[i] = all_pairs ? c : (size_t)(c > 0);
    }
    return now() - t0;
}

static fcl_peer_model *fcl_model_of(const mesh_data *m)
{
    return fcl_peer_model_new(&m->vertices[0].x, m->vertex_count, m->indices, m->triangle_count);
}

typedef struct shape_case {
    const char *name;
    const pose *poses;
    size_t count;
    int all_pairs;
} shape_case;

static void bench_shape(const char *mesh, const octree *tree, const fcl_peer_model *world_fcl, const mesh_data *world,
                        const mesh_data *shape0)
{
    box3 wb = mesh_data_bounds(world), sb0 = mesh_data_bounds(shape0);
    double world_radius = 0.5 * vec3_length(vec3_sub(wb.hi, wb.lo));
    double radius0 = 0.5 * vec3_length(vec3_sub(sb0.hi, sb0.lo));
    double scale = SHAPE_FRACTION * world_radius / radius0;
    vec3 c0 = vec3_scale(vec3_add(sb0.lo, sb0.hi), 0.5);
    /* Scaled about the origin and moved so its box centre is the origin. */
    mesh_data shape = meshgen_transformed(shape0, scale, vec3_scale(c0, -scale));
    double radius = radius0 * scale;
    fcl_peer_model *shape_fcl = fcl_model_of(&shape);
    mesh_view shape_view = mesh_data_view(&shape);
    octree_error shape_err;
    /* As the daemon builds a registered shape's (server/world/world.c): with each node's
     * triangle bounds. */
    octree_def shape_def = octree_default_def();
    shape_def.node_bounds = 1;
    octree *shape_tree = octree_build(&shape_view, &shape_def, &shape_err);
    if (!shape_tree) {
        fprintf(stderr, "shape tree: %s\n", shape_err.message);
        exit(1);
    }
    pose *poses = xcalloc(POSES, sizeof *poses), *free_poses = xcalloc(POSES, sizeof *free_poses);
    size_t *tc = xcalloc(POSES, sizeof *tc), *fc = xcalloc(POSES, sizeof *fc);
    rng r = rng_seeded(4242);
    make_poses(world, (vec3){0, 0, 0}, radius, &r, poses, POSES);
    size_t free_count = 0;
    shape_case cases[3] = {{"yes/no, mixed poses", poses, POSES, 0},
                           {"yes/no, collision-free poses", free_poses, 0, 0},
                           {"all pairs, mixed poses", poses, POSES, 1}};
    /* The collision-free poses are those of the mixed set trioct's exact answer calls free. */
    for (int c = 0; c < 3; c++) {
        shape_case *sc = &cases[c];
        if (c == 1)
            sc->count = free_count;
        if (sc->count == 0) {
            note(SEC_SHAPE, "  %s: %s: no poses\n", mesh, sc->name);
            continue;
        }
        double ts[ROUNDS], fs[ROUNDS];
        query_stats st = {0};
        char extra[96] = "";
        for (int k = 0; k < ROUNDS; k++) {
            for (int side = 0; side < 2; side++) {
                if ((side == 0) == (k % 2 == 0))
                    ts[k] = trioct_shape_at_poses(tree, shape_tree, sc->poses, sc->count, sc->all_pairs, tc,
                                                  k == 0 ? &st : NULL);
                else
                    fs[k] = fcl_shape_at_poses(shape_fcl, world_fcl, sc->poses, sc->count, sc->all_pairs, fc);
            }
            if (k > 0)
                continue;
            size_t differ = 0, t_yes = 0, f_yes = 0, t_sum = 0, f_sum = 0;
            for (size_t i = 0; i < sc->count; i++) {
                differ += (size_t)(tc[i] != fc[i]);
                t_yes += (size_t)(tc[i] > 0);
                f_yes += (size_t)(fc[i] > 0);
                t_sum += tc[i];
                f_sum += fc[i];
                if (c == 0 && tc[i] == 0)
                    free_poses[free_count++] = sc->poses[i];
            }
            double n = (double)sc->count;
            if (sc->all_pairs)
                snprintf(extra, sizeof extra, "pairs %zu/%zu, poses differ %zu; %.0f, %.0f", t_sum, f_sum, differ,
                         (double)st.nodes_visited / n, (double)st.candidates_tested / n);
            else
                snprintf(extra, sizeof extra, "yes %zu/%zu of %zu, differ %zu; %.0f, %.0f", t_yes, f_yes, sc->count,
                         differ, (double)st.nodes_visited / n, (double)st.candidates_tested / n);
        }
        row *rw = add_row(SEC_SHAPE, mesh, sc->name, U_RATE, 1.0, 0);
        rw->f[0] = rate_figure(sc->count, ts, fs);
        snprintf(rw->extra, sizeof rw->extra, "%s", extra);
    }
    fcl_peer_model_free(shape_fcl);
    octree_free(shape_tree);
    mesh_data_free(&shape);
    free(poses);
    free(free_poses);
    free(tc);
    free(fc);
}

/* ---------- single triangles ---------- */

static double trioct_triangles(const octree *tree, const vec3 (*tris)[3], size_t n, tri_detail d, size_t *counts,
                               query_stats *stats)
{
    static tri_contact contacts[TRI_CAP];
    double t0 = now();
    for (size_t i = 0; i < n; i++) {
        tri_output out = {.contacts = contacts, .capacity = TRI_CAP};
        octree_triangle(tree, tris[i], d, ACCURACY_EXACT, &out, stats);
        counts[i] = d == TRI_YESNO ? (size_t)out.hit : out.count;
    }
    return now() - t0;
}

static double fcl_triangles(fcl_peer_model **models, const fcl_peer_model *world, size_t n, int ids, size_t *counts)
{
    double t0 = now();
    for (size_t i = 0; i < n; i++) {
        size_t c = fcl_peer_collide(models[i], NULL, NULL, world, ids ? FCL_ALL_CONTACTS : 1, NULL, 0);
        counts[i] = ids ? c : (size_t)(c > 0);
    }
    return now() - t0;
}

static void bench_triangles(const char *mesh, const octree *tree, const fcl_peer_model *world_fcl, const mesh_data *m,
                            double leaf)
{
    vec3(*tris)[3] = xcalloc(TRI_QUERIES, sizeof *tris);
    fcl_peer_model **models = xcalloc(TRI_QUERIES, sizeof *models);
    size_t *tc = xcalloc(TRI_QUERIES, sizeof *tc), *fc = xcalloc(TRI_QUERIES, sizeof *fc);
    rng r = rng_seeded(99);
    /* FCL's one-triangle models are built here, outside the timing, which favours FCL:
     * trioct takes the query triangle as it is. */
    static const uint32_t one[3] = {0, 1, 2};
    for (size_t i = 0; i < TRI_QUERIES; i++) {
        query_triangle_sample(m, &r, leaf, QUERY_TRI_NEAR, tris[i]);
        models[i] = fcl_peer_model_new(&tris[i][0].x, 3, one, 1);
    }
    for (int ids = 0; ids <= 1; ids++) {
        double ts[ROUNDS], fs[ROUNDS];
        query_stats st = {0};
        char extra[96] = "";
        for (int k = 0; k < ROUNDS; k++) {
            for (int side = 0; side < 2; side++) {
                if ((side == 0) == (k % 2 == 0))
                    ts[k] = trioct_triangles(tree, (const vec3(*)[3])tris, TRI_QUERIES, ids ? TRI_IDS : TRI_YESNO,
                                             tc, k == 0 ? &st : NULL);
                else
                    fs[k] = fcl_triangles(models, world_fcl, TRI_QUERIES, ids, fc);
            }
            if (k > 0)
                continue;
            size_t differ = 0, t_yes = 0, t_sum = 0, f_sum = 0;
            for (size_t i = 0; i < TRI_QUERIES; i++) {
                differ += (size_t)(tc[i] != fc[i]);
                t_yes += (size_t)(tc[i] > 0);
                t_sum += tc[i];
                f_sum += fc[i];
            }
            if (ids)
                snprintf(extra, sizeof extra, "ids %zu/%zu, queries differ %zu; %.1f, %.1f", t_sum, f_sum, differ,
                         (double)st.nodes_visited / TRI_QUERIES, (double)st.candidates_tested / TRI_QUERIES);
            else
                snprintf(extra, sizeof extra, "yes %zu of %d, differ %zu; %.1f, %.1f", t_yes, TRI_QUERIES, differ,
                         (double)st.nodes_visited / TRI_QUERIES, (double)st.candidates_tested / TRI_QUERIES);
        }
        row *rw = add_row(SEC_TRIS, mesh, ids ? "triangle ids" : "triangle yes/no", U_RATE, 1.5, 0);
        rw->f[0] = rate_figure(TRI_QUERIES, ts, fs);
        snprintf(rw->extra, sizeof rw->extra, "%s", extra);
    }
    for (size_t i = 0; i < TRI_QUERIES; i++)
        fcl_peer_model_free(models[i]);
    free(models);
    free(tris);
    free(tc);
    free(fc);
}

/* ---------- one world ---------- */

static char fcl_builds[256]; /* FCL's world model build times, for the shape section's notes */

static void bench_world(const char *mesh, const mesh_data *m, RTCDevice dev, embree_memory *mem,
                        const mesh_data *shape)
{
    double t_start = now();
    mesh_view v = mesh_data_view(m);
    octree_def def = octree_default_def();
    double tb[ROUNDS], eb[ROUNDS], ratio[ROUNDS], tbytes[ROUNDS], ebytes[ROUNDS], rbytes[ROUNDS];
    octree *tree = NULL;
    embree_build eb_last = {0};
    double commit[ROUNDS];
    size_t n = m->triangle_count;
    for (int k = 0; k < ROUNDS; k++) {
        for (int side = 0; side < 2; side++) {
            if ((side == 0) == (k % 2 == 0)) {
                octree_free(tree);
                octree_error err;
                double t0 = now();
                tree = octree_build(&v, &def, &err);
                tb[k] = now() - t0;
                if (!tree) {
                    printf("%s: trioct build failed: %s\n", mesh, err.message);
                    return;
                }
            } else {
                if (eb_last.scene) {
                    unsigned csr = embree_enter();
                    rtcReleaseScene(eb_last.scene);
                    embree_leave(csr);
                }
                eb_last = embree_build_scene(dev, mem, m);
                eb[k] = eb_last.seconds;
                commit[k] = eb_last.commit_seconds;
            }
        }
        octree_info info;
        octree_get_info(tree, &info);
        /* The monitor counts the buffers Embree allocates for rtcSetNewGeometryBuffer when
         * it sees them; when it does not, their size is added here. */
        long long buffers = (long long)(12 * m->vertex_count + 16 + 12 * n);
        long long held = eb_last.held_bytes + (eb_last.buffer_bytes > 0 ? 0 : buffers);
        tbytes[k] = (double)info.bytes_total / (double)n;
        ebytes[k] = (double)held / (double)n;
        rbytes[k] = tbytes[k] / ebytes[k];
        ratio[k] = tb[k] / eb[k];
    }
    row *rw = add_row(SEC_BUILD, mesh, "build seconds", U_SECONDS, 1.5, 1);
    rw->f[0] = figure_of(tb, eb, ratio, ROUNDS);
    snprintf(rw->extra, sizeof rw->extra, "rtcCommitScene alone %.3f s", median_of(commit, ROUNDS));
    rw = add_row(SEC_BUILD, mesh, "bytes per triangle", U_BYTES, 1.2, 1);
    rw->f[0] = figure_of(tbytes, ebytes, rbytes, ROUNDS);
    snprintf(rw->extra, sizeof rw->extra, "buffers %.1f B, peak during the build %.1f B",
             (double)eb_last.buffer_bytes / (double)n, (double)eb_last.peak_bytes / (double)n);
    octree_info info;
    octree_get_info(tree, &info);
    char about[160];
    snprintf(about, sizeof about, "%zu triangles, %zu vertices; trioct d %.4g, L_max %d, %zu nodes", n,
             m->vertex_count, info.resolution, info.max_level, info.node_count);

    rng r = rng_seeded(2024);
    ray_set sets[4];
    char x8[512] = "";
    rays_toward_surface(&sets[0], m, &r);
    rays_inside(&sets[1], m, &r);
    rays_camera(&sets[2], m);
    rays_lidar(&sets[3], m);
    for (int s = 0; s < 4; s++) {
        bench_rays(mesh, tree, eb_last.scene, &sets[s], x8, sizeof x8);
        ray_set_free(&sets[s]);
    }
    note(SEC_RAYS, "  %s: Embree x8 rays/s and trioct batch / x8: %s\n", mesh, x8);
    double t_rays = now();
    {
        unsigned csr = embree_enter();
        rtcReleaseScene(eb_last.scene);
        embree_leave(csr);
    }
    octree_free(tree);

    /* Triangle and shape queries on the tree a world serving them gets (per-triangle boxes). */
    def.triangle_boxes = 1;
    octree_error err;
    octree *boxed = octree_build(&v, &def, &err);
    if (!boxed) {
        printf("%s: trioct build with triangle boxes failed: %s\n", mesh, err.message);
        return;
    }
    double t0 = now();
    fcl_peer_model *world_fcl = fcl_model_of(m);
    double fcl_build = now() - t0;
    if (!world_fcl) {
        octree_free(boxed);
        return;
    }
    octree_get_info(boxed, &info);
    bench_triangles(mesh, boxed, world_fcl, m, info.resolution);
    double t_tris = now();
    if (shape)
        bench_shape(mesh, boxed, world_fcl, m, shape);
    size_t used = strlen(fcl_builds);
    snprintf(fcl_builds + used, sizeof fcl_builds - used, "%s%s %.2f s", used ? ", " : "", mesh, fcl_build);
    fcl_peer_model_free(world_fcl);
    octree_free(boxed);
    printf("# %s: %s; %.1f s (builds and rays %.1f, triangles %.1f, shape %.1f)\n", mesh, about, now() - t_start,
           t_rays - t_start, t_tris - t0, now() - t_tris);
    fflush(stdout);
}

static int wanted(const char *list, const char *key)
{
    if (!list)
        return 1;
    size_t k = strlen(key);
    for (const char *p = list; (p = strstr(p, key)) != NULL; p += k)
        if ((p == list || p[-1] == ',') && (p[k] == 0 || p[k] == ','))
            return 1;
    return 0;
}

int main(int argc, char **argv)
{
    const char *only = argc > 1 ? argv[1] : NULL;
    double t_start = now();
    int cpu = pin_to_one_cpu();
    embree_memory mem;
    atomic_init(&mem.now, 0);
    atomic_init(&mem.peak, 0);
    RTCDevice dev = rtcNewDevice("threads=1");
    if (!dev) {
        fprintf(stderr, "bench_peers: rtcNewDevice failed\n");
        return 1;
    }
    rtcSetDeviceErrorFunction(dev, embree_error, NULL);
    rtcSetDeviceMemoryMonitorFunction(dev, embree_monitor, &mem);
    long ev = (long)rtcGetDeviceProperty(dev, RTC_DEVICE_PROPERTY_VERSION);

    /* The shape: the real Wuson as loaded when the test models are installed, else a torus
     * of about as many triangles. */
    mesh_data shape = {0};
    char shape_name[320], err[256];
    if (real_mesh_load(REAL_WUSON, 0, &shape, NULL, NULL, err, sizeof err) == 0) {
        snprintf(shape_name, sizeof shape_name, "%s", real_mesh_path(REAL_WUSON));
    } else {
        printf("# %s; the shape is a generated torus\n", err);
        shape = meshgen_torus((vec3){0, 0, 0}, 1.0, 0.35, 64, 29);
        snprintf(shape_name, sizeof shape_name, "generated torus");
    }

    printf("# trioct vs Embree %ld.%ld.%ld and FCL %s on one core (pinned to CPU %d, Embree device \"threads=1\"); "
           "medians of %d alternating rounds\n",
           ev / 10000, ev / 100 % 100, ev % 100, fcl_peer_version(), cpu, ROUNDS);
    printf("# rays: %d a random set, camera %dx%d, lidar %dx%d; trioct exact, per ray and in batches of %d; "
           "Embree gets float copies of the same rays\n",
           RANDOM_RAYS, CAMERA_SIDE, CAMERA_SIDE, LIDAR_AZIMUTHS, LIDAR_BEAMS, RAY_BATCH);
    printf("# build: octree_build (default def) vs rtcNewScene..rtcCommitScene, geometry and buffers filled from "
           "the doubles included\n");
    printf("# bytes: octree_info.bytes_total vs the final count of Embree's memory monitor after the commit, which "
           "includes its float3 vertex (12 B, padded by Embree) and index buffers\n");
    printf("# triangles: %d near-surface, about a leaf across; shape: %s, %zu triangles, radius %.0f%% of the "
           "world's, %d poses a world; FCL models built outside the timing\n",
           TRI_QUERIES, shape_name, shape.triangle_count, 100 * SHAPE_FRACTION, POSES);
    fflush(stdout);

    if (wanted(only, "terrain")) {
        mesh_data terrain = meshgen_terrain(1, (box3){{0, 0, 0}, {100, 100, 10}}, 708, 708);
        bench_world("terrain", &terrain, dev, &mem, &shape);
        mesh_data_free(&terrain);
    }
    if (wanted(only, "icosphere")) {
        mesh_data sphere = meshgen_icosphere((vec3){0, 0, 0}, 1.0, 8);
        bench_world("icosphere", &sphere, dev, &mem, &shape);
        mesh_data_free(&sphere);
    }
    for (int i = 0; i < REAL_MESH_COUNT; i++) {
        if (!wanted(only, real_mesh_key((real_mesh)i)))
            continue;
        mesh_data base, sub;
        int times;
        if (real_mesh_load((real_mesh)i, 400000, &base, &sub, &times, err, sizeof err) != 0) {
            printf("# %s skipped: %s (Debian's assimp-testmodels holds it)\n", real_mesh_key((real_mesh)i), err);
            continue;
        }
        char name[40];
        snprintf(name, sizeof name, "%s x4^%d", real_mesh_key((real_mesh)i), times);
        bench_world(name, &sub, dev, &mem, &shape);
        mesh_data_free(&sub);
        mesh_data_free(&base);
    }
    mesh_data_free(&shape);
    rtcReleaseDevice(dev);
    note(SEC_SHAPE, "  FCL world models (BVHModel<OBBRSS>) built in: %s\n", fcl_builds);
    print_tables();
    print_summary();
    printf("# whole run %.1f s\n", now() - t_start);
    return 0;
}
