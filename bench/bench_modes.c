/* Fast against exact: build time and query rates of each mode on its own tree, timed in
 * alternating rounds (odd rounds fast first) so that the machine's drift hits both alike;
 * prints the median of the rounds' ratios. `bench_modes one MESH MODE PART` runs a single
 * build or query pass, for instruction counts under callgrind (MESH wuson, spider, blocks;
 * MODE exact, fast, seed; PART build, rays, tris). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "engine.h"
#include "support/meshgen.h"
#include "support/query_shapes.h"
#include "support/real_meshes.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

enum { RAYS = 20000, TRIS = 4000, ROUNDS = 7 };

typedef struct queries {
    ray_input rays[RAYS];
    vec3 tris[TRIS][3];
} queries;

/* Closest-hit rays from around the mesh toward points on it, and triangle queries of about
 * a leaf across near the surface (the benchmarks' and the accuracy report's shapes). */
static void make_queries(const mesh_data *m, double leaf, queries *q)
{
    rng r = rng_seeded(77);
    box3 b = mesh_data_bounds(m);
    vec3 ext = vec3_sub(b.hi, b.lo);
    box3 around = {vec3_sub(b.lo, vec3_scale(ext, 0.2)), vec3_add(b.hi, vec3_scale(ext, 0.2))};
    for (size_t i = 0; i < RAYS; i++) {
        size_t t = rng_next(&r) % m->triangle_count;
        double u = rng_uniform(&r, 0, 1), v = rng_uniform(&r, 0, 1);
        if (u + v > 1) {
            u = 1 - u;
            v = 1 - v;
        }
        vec3 a = mesh_data_corner(m, t, 0), bb = mesh_data_corner(m, t, 1), c = mesh_data_corner(m, t, 2);
        vec3 target = vec3_add(a, vec3_add(vec3_scale(vec3_sub(bb, a), u), vec3_scale(vec3_sub(c, a), v)));
        vec3 o = rng_point_in_box(&r, around);
        q->rays[i] = (ray_input){o, vec3_sub(target, o), 0, INFINITY, RAY_CROSSING};
    }
    for (size_t i = 0; i < TRIS; i++)
        query_triangle_sample(m, &r, leaf, QUERY_TRI_NEAR, q->tris[i]);
}

static octree *build(const mesh_data *m, accuracy_mode mode, double *seconds)
{
    octree_def def = octree_default_def();
    def.mode = mode;
    mesh_view v = mesh_data_view(m);
    double t0 = now();
    octree *t = octree_build(&v, &def, NULL);
    *seconds = now() - t0;
    if (!t) {
        fprintf(stderr, "bench_modes: build failed\n");
        exit(1);
    }
    return t;
}

static double ray_pass(const octree *t, const queries *q, accuracy_mode mode, size_t *hits)
{
    ray_hit h;
    *hits = 0;
    double t0 = now();
    for (size_t i = 0; i < RAYS; i++) {
        ray_output out = {.hits = &h, .max_hits = 1};
        octree_ray(t, &q->rays[i], RAY_CLOSEST, mode, &out, NULL);
        *hits += out.hit_count;
    }
    return (now() - t0) / RAYS;
}

static double tri_pass(const octree *t, const queries *q, accuracy_mode mode, size_t *hits)
{
    tri_contact c[256];
    *hits = 0;
    double t0 = now();
    for (size_t i = 0; i < TRIS; i++) {
        tri_output out = {.contacts = c, .capacity = 256};
        octree_triangle(t, q->tris[i], TRI_IDS, mode, &out, NULL);
        *hits += out.count;
    }
    return (now() - t0) / TRIS;
}

static int compare_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, compare_double);
    return v[n / 2];
}

static int load(const char *name, mesh_data *m)
{
    char err[256];
    if (strcmp(name, "blocks") == 0) {
        *m = meshgen_blocks(5, 12, 12, 12, 0.5);
        return 0;
    }
    real_mesh which = strcmp(name, "spider") == 0 ? REAL_SPIDER : REAL_WUSON;
    mesh_data base, sub;
    int times;
    if (real_mesh_load(which, 250000, &base, &sub, &times, err, sizeof err) != 0) {
        fprintf(stderr, "bench_modes: %s\n", err);
        return -1;
    }
    mesh_data_free(&base);
    *m = sub;
    return 0;
}

static accuracy_mode mode_named(const char *s)
{
    return strcmp(s, "fast") == 0 ? ACCURACY_FAST : strcmp(s, "seed") == 0 ? ACCURACY_SEED : ACCURACY_EXACT;
}

/* One pass of one part, for callgrind. */
static int run_one(const char *mesh, const char *mode_name, const char *part)
{
    mesh_data m;
    if (load(mesh, &m) != 0)
        return 1;
    accuracy_mode mode = mode_named(mode_name);
    double s;
    octree *t = build(&m, mode, &s);
    size_t hits = 0;
    if (strcmp(part, "build") != 0) {
        queries *q = malloc(sizeof *q);
        octree_info info;
        octree_get_info(t, &info);
        make_queries(&m, info.resolution, q);
        if (strcmp(part, "rays") == 0)
            ray_pass(t, q, mode, &hits);
        else
            tri_pass(t, q, mode, &hits);
        free(q);
    }
    printf("%s %s %s: %zu hits\n", mesh, mode_name, part, hits);
    octree_free(t);
    mesh_data_free(&m);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc == 5 && strcmp(argv[1], "one") == 0)
        return run_one(argv[2], argv[3], argv[4]);
    const char *meshes[] = {"wuson", "spider", "blocks"};
    printf("fast vs exact, each mode on its own tree; medians of %d alternating rounds, ratio fast/exact "
           "(below 1: fast is faster)\n",
           ROUNDS);
    printf("%-8s %9s | %12s %12s %6s | %12s %12s %6s | %12s %12s %6s\n", "mesh", "triangles", "build exact", "fast",
           "ratio", "ray exact us", "fast us", "ratio", "tri exact us", "fast us", "ratio");
    queries *q = malloc(sizeof *q);
    for (size_t k = 0; k < sizeof meshes / sizeof meshes[0]; k++) {
        mesh_data m;
        if (load(meshes[k], &m) != 0)
            continue;
        double build_e[ROUNDS], build_f[ROUNDS], ray_e[ROUNDS], ray_f[ROUNDS], tri_e[ROUNDS], tri_f[ROUNDS];
        double r_build[ROUNDS], r_ray[ROUNDS], r_tri[ROUNDS];
        int made = 0;
        for (int round = 0; round < ROUNDS; round++) {
            size_t he = 0, hf = 0, te = 0, tf = 0;
            octree *e = NULL, *f = NULL;
            for (int side = 0; side < 2; side++) {
                int fast = (side == 0) == (round % 2 == 1);
                if (fast)
                    f = build(&m, ACCURACY_FAST, &build_f[round]);
                else
                    e = build(&m, ACCURACY_EXACT, &build_e[round]);
            }
            if (!made) {
                octree_info info;
                octree_get_info(e, &info);
                make_queries(&m, info.resolution, q);
                made = 1;
            }
            for (int side = 0; side < 2; side++) {
                int fast = (side == 0) == (round % 2 == 1);
                if (fast) {
                    ray_f[round] = ray_pass(f, q, ACCURACY_FAST, &hf);
                    tri_f[round] = tri_pass(f, q, ACCURACY_FAST, &tf);
                } else {
                    ray_e[round] = ray_pass(e, q, ACCURACY_EXACT, &he);
                    tri_e[round] = tri_pass(e, q, ACCURACY_EXACT, &te);
                }
            }
            r_build[round] = build_f[round] / build_e[round];
            r_ray[round] = ray_f[round] / ray_e[round];
            r_tri[round] = tri_f[round] / tri_e[round];
            if (round == 0)
                printf("  (%s: closest hits exact %zu fast %zu; triangle ids exact %zu fast %zu)\n", meshes[k], he, hf,
                       te, tf);
            octree_free(e);
            octree_free(f);
        }
        printf("%-8s %9zu | %10.4fs %10.4fs %5.2fx | %12.3f %12.3f %5.2fx | %12.3f %12.3f %5.2fx\n", meshes[k],
               m.triangle_count, median(build_e, ROUNDS), median(build_f, ROUNDS), median(r_build, ROUNDS),
               1e6 * median(ray_e, ROUNDS), 1e6 * median(ray_f, ROUNDS), median(r_ray, ROUNDS),
               1e6 * median(tri_e, ROUNDS), 1e6 * median(tri_f, ROUNDS), median(r_tri, ROUNDS));
        mesh_data_free(&m);
    }
    free(q);
    return 0;
}
