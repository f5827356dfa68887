/* Engine benchmark: build cost, memory, ray and triangle query throughput on generated and
 * real meshes, single thread and all cores, and the speed-up over brute force. Prints
 * figures beside the targets; asserts nothing (machines are noisy). */
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "engine.h"
#include "support/brute_force.h"
#include "support/meshgen.h"
#include "support/query_shapes.h"
#include "support/real_meshes.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

typedef struct workload {
    ray_input *rays;
    size_t ray_count;
    ray_input *sensor_rays; /* ray_count of them too */
    vec3 (*tris)[3];
    size_t tri_count;
} workload;

/* Rays from random points around the mesh toward random points on random triangles (the
 * hit-heavy case a robot's sensor sees), and query triangles of about the leaf size placed
 * on the surface (a contact check). */
static workload make_workload(const mesh_data *m, double leaf, size_t rays, size_t tris, uint64_t seed)
{
    rng r = rng_seeded(seed);
    box3 b = mesh_data_bounds(m);
    vec3 ext = vec3_sub(b.hi, b.lo);
    box3 around = {vec3_sub(b.lo, vec3_scale(ext, 0.2)), vec3_add(b.hi, vec3_scale(ext, 0.2))};
    workload w = {.rays = malloc(rays * sizeof *w.rays), .ray_count = rays, .tris = malloc(tris * sizeof *w.tris), .tri_count = tris};
    for (size_t i = 0; i < rays; i++) {
        size_t t = rng_next(&r) % m->triangle_count;
        double u = rng_uniform(&r, 0, 1), v = rng_uniform(&r, 0, 1);
        if (u + v > 1) {
            u = 1 - u;
            v = 1 - v;
        }
        vec3 a = m->vertices[m->indices[3 * t]], bb = m->vertices[m->indices[3 * t + 1]],
             c = m->vertices[m->indices[3 * t + 2]];
        vec3 target = vec3_add(a, vec3_add(vec3_scale(vec3_sub(bb, a), u), vec3_scale(vec3_sub(c, a), v)));
        vec3 o = rng_point_in_box(&r, around);
        w.rays[i] = (ray_input){o, vec3_sub(target, o), 0, INFINITY, RAY_CROSSING};
    }
    for (size_t i = 0; i < tris; i++)
        query_triangle_sample(m, &r, leaf, QUERY_TRI_NEAR, w.tris[i]);
    return w;
}

/* Camera-like rays: one sensor outside the mesh's bounding sphere sweeping a grid of
 * directions across it, row by row, as a depth camera or a lidar scan sends them. */
static ray_input *make_sensor_rays(const mesh_data *m, size_t count)
{
    box3 b = mesh_data_bounds(m);
    vec3 centre = vec3_scale(vec3_add(b.lo, b.hi), 0.5);
    double radius = 0.5 * vec3_length(vec3_sub(b.hi, b.lo));
    /* The field of view frames the vertices' RMS radius, so most rays hit, as a sensor
     * pointed at an object sees mostly the object. */
    double rms = 0;
    for (size_t i = 0; i < m->vertex_count; i++) {
        vec3 dv = vec3_sub(m->vertices[i], centre);
        rms += vec3_dot(dv, dv);
    }
    rms = sqrt(rms / (double)m->vertex_count);
    vec3 eye = vec3_add(centre, vec3_scale(vec3_normalize((vec3){0.6, -0.7, 0.45}), 2.2 * radius));
    vec3 forward = vec3_normalize(vec3_sub(centre, eye));
    vec3 right = vec3_normalize(vec3_cross(forward, (vec3){0, 0, 1}));
    vec3 up = vec3_cross(right, forward);
    size_t width = (size_t)sqrt((double)count), height = count / width;
    double half = 0.8 * rms / (2.2 * radius); /* tan of the half field of view */
    ray_input *rays = malloc(width * height * sizeof *rays);
    for (size_t y = 0; y < height; y++)
        for (size_t x = 0; x < width; x++) {
            double u = (2.0 * ((double)x + 0.5) / (double)width - 1.0) * half;
            double v = (2.0 * ((double)y + 0.5) / (double)height - 1.0) * half;
            vec3 d = vec3_add(forward, vec3_add(vec3_scale(right, u), vec3_scale(up, v)));
            rays[y * width + x] = (ray_input){eye, d, 0, INFINITY, RAY_CROSSING};
        }
    return rays;
}

typedef struct job {
    const octree *tree;
    const workload *w;
    /* 0 closest, 1 any, 2 tri yes/no, 3 tri ids, 4 closest sensor, 5 any sensor; 6..9 are
     * 0, 1, 4, 5 asked through octree_ray_batch */
    int kind;
    size_t first, count;
    query_stats stats;
    size_t hits;
} job;

/* Rays per octree_ray_batch call: what a sensor frame or a planner's sweep hands over. */
#define BATCH_RAYS 256

static int is_batch(int kind)
{
    return kind >= 6;
}

/* The per-ray kind a batch kind asks the same queries as. */
static int single_kind(int kind)
{
    static const int single[] = {0, 1, 2, 3, 4, 5, 0, 1, 4, 5};
    return single[kind];
}

static void run_batches(job *j)
{
    int kind = single_kind(j->kind);
    const ray_input *rays = kind >= 4 ? j->w->sensor_rays : j->w->rays;
    ray_hit hits[BATCH_RAYS];
    ray_output outs[BATCH_RAYS];
    octree_status statuses[BATCH_RAYS];
    size_t end = j->first + j->count;
    for (size_t i = j->first; i < end;) {
        size_t start = i % j->w->ray_count, n = end - i;
        n = n < BATCH_RAYS ? n : BATCH_RAYS;
        n = n < j->w->ray_count - start ? n : j->w->ray_count - start;
        for (size_t k = 0; k < n; k++)
            outs[k] = (ray_output){.hits = &hits[k], .max_hits = 1};
        octree_ray_batch(j->tree, &rays[start], n, kind % 2 == 0 ? RAY_CLOSEST : RAY_ANY, ACCURACY_EXACT, outs,
                         statuses, &j->stats);
        for (size_t k = 0; k < n; k++)
            j->hits += outs[k].hit_count > 0;
        i += n;
    }
}

static void *run(void *arg)
{
    job *j = arg;
    ray_hit hit;
    tri_contact contacts[256];
    if (is_batch(j->kind)) {
        run_batches(j);
        return NULL;
    }
    for (size_t i = j->first; i < j->first + j->count; i++) {
        if (j->kind <= 1 || j->kind >= 4) {
            ray_output out = {.hits = &hit, .max_hits = 1};
            const ray_input *rays = j->kind >= 4 ? j->w->sensor_rays : j->w->rays;
            octree_ray(j->tree, &rays[i % j->w->ray_count], j->kind % 2 == 0 ? RAY_CLOSEST : RAY_ANY,
                       ACCURACY_EXACT, &out, &j->stats);
            j->hits += out.hit_count > 0;
        } else {
            tri_output out = {.contacts = contacts, .capacity = 256};
            octree_triangle(j->tree, j->w->tris[i % j->w->tri_count], j->kind == 2 ? TRI_YESNO : TRI_IDS,
                            ACCURACY_EXACT, &out, &j->stats);
            j->hits += out.hit;
        }
    }
    return NULL;
}

/* Queries per second over `count` queries on `threads` threads. */
static double throughput(const octree *t, const workload *w, int kind, size_t count, int threads, query_stats *stats,
                         double *hit_rate)
{
    job jobs[64];
    pthread_t th[64];
    double start = now();
    for (int i = 0; i < threads; i++) {
        jobs[i] = (job){t, w, kind, (size_t)i * (count / (size_t)threads), count / (size_t)threads, {0}, 0};
        if (threads == 1)
            run(&jobs[i]);
        else
            pthread_create(&th[i], NULL, run, &jobs[i]);
    }
    size_t hits = 0;
    *stats = (query_stats){0};
    for (int i = 0; i < threads; i++) {
        if (threads > 1)
            pthread_join(th[i], NULL);
        hits += jobs[i].hits;
        stats->nodes_visited += jobs[i].stats.nodes_visited;
        stats->candidates_tested += jobs[i].stats.candidates_tested;
        stats->exact_fallbacks += jobs[i].stats.exact_fallbacks;
    }
    double secs = now() - start;
    size_t done = (count / (size_t)threads) * (size_t)threads;
    *hit_rate = (double)hits / (double)done;
    return (double)done / secs;
}

/* Brute force per query, measured on a few queries (it is slow by design). */
static double brute_rate(const mesh_data *m, const workload *w, int kind, size_t count)
{
    mesh_view v = mesh_data_view(m);
    ray_hit h;
    uint32_t ids[256];
    double start = now();
    for (size_t i = 0; i < count; i++) {
        if (kind <= 1 || kind >= 4)
            brute_ray(&v, kind >= 4 ? &w->sensor_rays[i] : &w->rays[i], kind % 2 == 0 ? RAY_CLOSEST : RAY_ANY,
                      ACCURACY_EXACT, 0, &h, 1);
        else
            brute_triangle(&v, w->tris[i], ACCURACY_EXACT, 0, ids, 256);
    }
    return (double)count / (now() - start);
}

/* Triangle queries with and without the per-triangle box prefilter, on two trees built
 * from the same mesh. The two trees alternate, round after round, so that whatever else
 * the machine does lands on both; each keeps its best round. */
#define BOX_ROUNDS 5

/* Mesh queries (every pair) per second: a small sphere of about two leaves posed at the
 * query triangles' first vertices, one thread. */
static double mesh_rate(const octree *t, const mesh_data *shape, const workload *w, size_t count, query_stats *stats,
                        double *hit_rate)
{
    mesh_view sv = mesh_data_view(shape);
    mesh_pair pairs[1024];
    size_t hits = 0;
    *stats = (query_stats){0};
    double start = now();
    for (size_t i = 0; i < count; i++) {
        pose p = {{1, 0, 0, 0, 1, 0, 0, 0, 1}, w->tris[i % w->tri_count][0]};
        mesh_output out = {.pairs = pairs, .capacity = 1024};
        octree_mesh(t, &sv, &p, 1, ACCURACY_EXACT, &out, stats);
        hits += out.hit;
    }
    double secs = now() - start;
    *hit_rate = (double)hits / (double)count;
    return (double)count / secs;
}

static void bench_triangle_boxes(const octree *plain, const octree *boxed, const workload *w)
{
    octree_info pi, bi;
    octree_get_info(plain, &pi);
    octree_get_info(boxed, &bi);
    double n = (double)bi.triangle_count;
    printf("triangle boxes: %.1f bytes per triangle (%.1f -> %.1f total per triangle), build %.3f -> %.3f s\n",
           (double)bi.bytes_triangle_boxes / n, (double)pi.bytes_total / n, (double)bi.bytes_total / n,
           pi.build_seconds, bi.build_seconds);
    printf("%-22s %12s %12s %9s %10s %10s %10s\n", "query, 1 thread", "no boxes/s", "boxes/s", "ratio", "hit rate",
           "cand/q no", "cand/q box");
    mesh_data shape = meshgen_icosphere((vec3){0, 0, 0}, 2.0 * pi.resolution, 1);
    size_t mesh_count = w->tri_count / 20;
    /* kind 2: triangle yes/no, 3: triangle ids, 4: mesh pairs */
    for (int kind = 2; kind <= 4; kind++) {
        size_t count = kind == 4 ? mesh_count : w->tri_count;
        double best[2] = {0, 0}, hit_rate[2] = {0, 0};
        query_stats stats[2] = {{0}, {0}};
        for (int round = 0; round < BOX_ROUNDS; round++)
            for (int b = 0; b < 2; b++) {
                query_stats s;
                double hr;
                /* Odd rounds run the boxed tree first, so neither always follows the other. */
                int which = round % 2 ? 1 - b : b;
                const octree *t = which ? boxed : plain;
                double rate = kind == 4 ? mesh_rate(t, &shape, w, count, &s, &hr)
                                        : throughput(t, w, kind, count, 1, &s, &hr);
                if (rate > best[which]) {
                    best[which] = rate;
                    stats[which] = s;
                }
                hit_rate[which] = hr;
            }
        if (hit_rate[0] != hit_rate[1])
            printf("hit rates differ: %.6f without boxes, %.6f with\n", hit_rate[0], hit_rate[1]);
        static const char *names[] = {"triangle yes/no", "triangle ids", "mesh pairs (80 tris)"};
        printf("%-22s %11.3fM %11.3fM %8.2fx %10.3f %10.2f %10.2f\n", names[kind - 2], best[0] / 1e6, best[1] / 1e6,
               best[1] / best[0], hit_rate[1], (double)stats[0].candidates_tested / (double)count,
               (double)stats[1].candidates_tested / (double)count);
    }
    mesh_data_free(&shape);
}

/* Sensor rays one at a time against the same rays as batches (which walk the tree in
 * groups), alternating round after round as the triangle-box table does, each keeping its
 * best round: the single rows above run minutes apart, too far for a ratio on this
 * machine. */
static void bench_sensor_batches(const octree *t, const workload *w)
{
    printf("%-22s %12s %12s %9s\n", "sensor rays, 1 thread", "per ray/s", "batches/s", "ratio");
    static const int pairs[2][2] = {{4, 8}, {5, 9}};
    static const char *names[] = {"closest", "any-hit"};
    for (int p = 0; p < 2; p++) {
        double best[2] = {0, 0};
        for (int round = 0; round < BOX_ROUNDS; round++)
            for (int b = 0; b < 2; b++) {
                int which = round % 2 ? 1 - b : b;
                query_stats s;
                double hr, rate = throughput(t, w, pairs[p][which], w->ray_count, 1, &s, &hr);
                best[which] = rate > best[which] ? rate : best[which];
            }
        printf("%-22s %11.3fM %11.3fM %8.2fx\n", names[p], best[0] / 1e6, best[1] / 1e6, best[1] / best[0]);
    }
}

static void bench_scene(const char *name, mesh_data *m, int threads, size_t queries, int boxes_only)
{
    mesh_view v = mesh_data_view(m);
    octree_error err;
    octree *t = octree_build(&v, NULL, &err);
    if (!t) {
        printf("%s: build failed: %s\n", name, err.message);
        return;
    }
    octree_info info;
    octree_get_info(t, &info);
    double per_tri = (double)info.bytes_total / (double)info.triangle_count;
    double build_per_m = info.build_seconds / ((double)info.triangle_count / 1e6);
    printf("\n## %s: %zu triangles, %zu vertices\n", name, info.triangle_count, info.vertex_count);
    printf("build %.3f s (%.3f s per million triangles; target <= 1.0)\n", info.build_seconds, build_per_m);
    printf("d = %.6g, L_max = %d, D = %.6g, nodes %zu, leaves %zu (%zu non-empty), refs per triangle %.2f\n",
           info.resolution, info.max_level, info.world_size, info.node_count, info.leaf_count,
           info.nonempty_leaf_count, (double)info.leaf_refs / (double)info.triangle_count);
    printf("memory %.1f bytes per triangle (target <= 120): nodes %zu, leaf lists %zu, triangles %zu\n", per_tri,
           info.bytes_nodes, info.bytes_leaf_lists, info.bytes_triangles);

    workload w = make_workload(m, info.resolution, queries, queries / 2, 7);
    w.sensor_rays = make_sensor_rays(m, queries);
    w.ray_count = (size_t)sqrt((double)queries) * (queries / (size_t)sqrt((double)queries));
    const char *names[] = {"closest, random", "any-hit, random", "triangle yes/no", "triangle ids",
                           "closest, sensor", "any-hit, sensor", "closest, random, batch", "any-hit, random, batch",
                           "closest, sensor, batch", "any-hit, sensor, batch"};
    const double targets[] = {1.2e6, 1.5e6, 5e5, 0, 1.2e6, 1.5e6, 1.2e6, 1.5e6, 1.2e6, 1.5e6};
    /* Each batch row right under its per-ray row; "vs 1 ray" is the batch's gain. */
    const int order[] = {0, 6, 1, 7, 2, 3, 4, 8, 5, 9};
    if (!boxes_only)
        printf("%-22s %12s %12s %9s %10s %10s %10s %12s %9s\n", "query", "1 thread/s", "target", "all/s", "hit rate",
               "cand/q", "nodes/q", "vs brute", "vs 1 ray");
    double single_rate[6] = {0};
    for (size_t row = 0; row < sizeof order / sizeof order[0] && !boxes_only; row++) {
        int kind = order[row], base = single_kind(kind);
        size_t count = (base <= 1 || base >= 4) ? w.ray_count : w.tri_count;
        query_stats s1, sn;
        double hr, hr2;
        double one = throughput(t, &w, kind, count, 1, &s1, &hr);
        double all = throughput(t, &w, kind, count, threads, &sn, &hr2);
        size_t brute_n = info.triangle_count > 200000 ? 5 : 50;
        double brute = brute_rate(m, &w, base, brute_n);
        char target[32] = "-", gain[32] = "-";
        if (targets[kind] > 0)
            snprintf(target, sizeof target, "%.2fM", targets[kind] / 1e6);
        if (is_batch(kind))
            snprintf(gain, sizeof gain, "%.2fx", one / single_rate[base]);
        else
            single_rate[kind] = one;
        printf("%-22s %11.3fM %12s %8.3fM %10.3f %10.2f %10.1f %11.0fx %9s\n", names[kind], one / 1e6, target,
               all / 1e6, hr, (double)s1.candidates_tested / (double)count, (double)s1.nodes_visited / (double)count,
               one / brute, gain);
        if (s1.exact_fallbacks)
            printf("%-18s exact fallbacks per query: %.5f\n", "", (double)s1.exact_fallbacks / (double)count);
    }
    if (!boxes_only)
        bench_sensor_batches(t, &w);
    octree_def def = octree_default_def();
    def.triangle_boxes = 1;
    octree *boxed = octree_build(&v, &def, &err);
    if (boxed)
        bench_triangle_boxes(t, boxed, &w);
    else
        printf("build with triangle boxes failed: %s\n", err.message);
    octree_free(boxed);
    free(w.rays);
    free(w.sensor_rays);
    free(w.tris);
    octree_free(t);
}

int main(int argc, char **argv)
{
    int threads = (int)sysconf(_SC_NPROCESSORS_ONLN);
    if (threads < 1)
        threads = 1;
    if (threads > 64)
        threads = 64;
    size_t queries = argc > 1 ? strtoull(argv[1], NULL, 10) : 200000;
    /* "boxes" as the second argument runs only the triangle box rows. */
    int boxes_only = argc > 2 && strcmp(argv[2], "boxes") == 0;
    printf("# trioct engine benchmark: %d cores, %zu ray queries per figure, exact mode\n", threads, queries);
    printf("# random: rays from random points around the mesh to random surface points (incoherent);\n"
           "# sensor: one camera sweeping a grid of directions across the mesh (coherent)\n");

    mesh_data terrain = meshgen_terrain(1, (box3){{0, 0, 0}, {100, 100, 10}}, 708, 708);
    bench_scene("terrain (generated)", &terrain, threads, queries, boxes_only);
    mesh_data_free(&terrain);

    mesh_data sphere = meshgen_icosphere((vec3){0, 0, 0}, 1.0, 7);
    bench_scene("icosphere (generated)", &sphere, threads, queries, boxes_only);
    mesh_data_free(&sphere);

    for (int i = 0; i < REAL_MESH_COUNT; i++) {
        mesh_data m, big;
        int times;
        char err[256];
        /* Subdivided so the real shape reaches the 250k-1M range the targets speak of. */
        if (real_mesh_load((real_mesh)i, 1000000, &m, &big, &times, err, sizeof err) != 0) {
            printf("%s\n", err);
            continue;
        }
        char name[320];
        snprintf(name, sizeof name, "%s (real, %zu triangles, subdivided x%d)", real_mesh_path((real_mesh)i),
                 m.triangle_count, times);
        bench_scene(name, &big, threads, queries, boxes_only);
        mesh_data_free(&big);
        mesh_data_free(&m);
    }
    return 0;
}
