/* Triangle-query cost of exact mode against fast mode on the subdivided real scenes of the
 * accuracy report (Wuson x3, Spider x4), per query category: exact on a tree without
 * triangle boxes (the same tree shape fast uses), exact with triangle boxes (what the daemon
 * builds for triangle worlds), and fast. The modes run in alternation, several rounds, so a
 * machine shared with other work slows them alike; the best round of each is reported. It
 * also prints a hash of every mode's answers, so a change to the exact test that alters an
 * answer shows up as a changed exact hash.
 *
 * Usage: bench_tri_exact [QUERIES_PER_CATEGORY [ROUNDS [only-exact|only-exactbox|only-fast]]]
 * The only-* forms run one mode once (for callgrind --toggle-collect=octree_triangle). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "engine.h"
#include "support/meshgen.h"
#include "support/query_shapes.h"
#include "support/real_meshes.h"

/* The accuracy report's triangle categories (query_shapes.h), in its order. */
enum { CAT_COUNT = QUERY_TRI_SAME + 1 };
static const char *cat_names[CAT_COUNT] = {"about d, near the surface", "one corner on a mesh vertex",
                                           "identical to a mesh triangle"};
enum { RUN_FAST, RUN_EXACT, RUN_EXACT_BOXES, RUN_COUNT };

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Seconds for the queries of one category, and an order-sensitive hash of the answers. */
static double run_queries(const octree *tree, accuracy_mode mode, vec3 (*q)[3], size_t n, tri_output *out,
                          uint64_t *hash, uint64_t *fallbacks)
{
    query_stats st = {0};
    uint64_t h = 1469598103934665603ull;
    double t0 = now();
    for (size_t i = 0; i < n; i++) {
        octree_triangle(tree, q[i], TRI_IDS, mode, out, &st);
        h = (h ^ out->count) * 1099511628211ull;
        size_t keep = out->count < out->capacity ? out->count : out->capacity;
        for (size_t k = 0; k < keep; k++)
            h = (h ^ out->contacts[k].triangle) * 1099511628211ull;
    }
    double dt = now() - t0;
    *hash = h;
    *fallbacks = st.exact_fallbacks;
    return dt;
}

int main(int argc, char **argv)
{
    size_t per_cat = argc > 1 ? strtoul(argv[1], NULL, 10) : 1500;
    int rounds = argc > 2 ? atoi(argv[2]) : 3;
    int only = -1;
    if (argc > 3)
        only = strcmp(argv[3], "only-fast") == 0 ? RUN_FAST : strcmp(argv[3], "only-exact") == 0 ? RUN_EXACT
                                                                                                  : RUN_EXACT_BOXES;
    if (only >= 0)
        rounds = 1;
    /* The accuracy report's subdivided scenes: Wuson x3 (239k), Spider x4 (350k). */
    const char *names[REAL_MESH_COUNT] = {[REAL_WUSON] = "wuson-sub", [REAL_SPIDER] = "spider-sub"};
    const size_t limits[REAL_MESH_COUNT] = {[REAL_WUSON] = 300000, [REAL_SPIDER] = 1000000};
    tri_output out = {0};
    out.capacity = 4096;
    out.contacts = malloc(out.capacity * sizeof *out.contacts);
    printf("triangle ids queries, exact over fast (best of %d alternated rounds, %zu queries a category)\n", rounds,
           per_cat);
    for (int s = 0; s < REAL_MESH_COUNT; s++) {
        mesh_data base, m;
        int times;
        char err[256];
        if (real_mesh_load((real_mesh)s, limits[s], &base, &m, &times, err, sizeof err) != 0) {
            printf("skipping %s: %s\n", real_mesh_path((real_mesh)s), err);
            continue;
        }
        mesh_data_free(&base);
        mesh_view view = {m.vertices, m.vertex_count, m.indices, m.triangle_count};
        octree *trees[RUN_COUNT];
        for (int k = 0; k < RUN_COUNT; k++) {
            octree_def def = octree_default_def();
            def.mode = k == RUN_FAST ? ACCURACY_FAST : ACCURACY_EXACT;
            def.triangle_boxes = k == RUN_EXACT_BOXES;
            trees[k] = octree_build(&view, &def, NULL);
            if (!trees[k]) {
                printf("build failed\n");
                return 1;
            }
        }
        octree_info info;
        octree_get_info(trees[RUN_EXACT], &info);
        rng r = rng_seeded(20261121u + (uint64_t)s);
        vec3(*q)[CAT_COUNT][3] = malloc(per_cat * sizeof *q);
        vec3(*by_cat)[3] = malloc(per_cat * sizeof *by_cat);
        for (size_t i = 0; i < per_cat; i++)
            for (int c = 0; c < CAT_COUNT; c++)
                query_triangle_sample(&m, &r, info.resolution, (query_triangle_kind)c, q[i][c]);
        printf("%s: %zu triangles, d = %g\n", names[s], m.triangle_count, info.resolution);
        double best[CAT_COUNT][RUN_COUNT];
        uint64_t hash[CAT_COUNT][RUN_COUNT], fb[CAT_COUNT][RUN_COUNT];
        for (int c = 0; c < CAT_COUNT; c++) {
            for (size_t i = 0; i < per_cat; i++)
                memcpy(by_cat[i], q[i][c], sizeof by_cat[i]);
            for (int k = 0; k < RUN_COUNT; k++)
                best[c][k] = INFINITY;
            for (int round = 0; round < rounds; round++)
                for (int k = 0; k < RUN_COUNT; k++) {
                    if (only >= 0 && k != only)
                        continue;
                    accuracy_mode mode = k == RUN_FAST ? ACCURACY_FAST : ACCURACY_EXACT;
                    double dt = run_queries(trees[k], mode, by_cat, per_cat, &out, &hash[c][k], &fb[c][k]);
                    best[c][k] = fmin(best[c][k], dt);
                }
        }
        if (only >= 0)
            continue;
        printf("  %-30s %9s %9s %9s %7s %7s %10s  answer hashes fast/exact/exact+boxes\n", "category", "fast us",
               "exact us", "+boxes us", "ratio", "+boxes", "fallbacks");
        double sum[RUN_COUNT] = {0};
        for (int c = 0; c < CAT_COUNT; c++) {
            double us[RUN_COUNT];
            for (int k = 0; k < RUN_COUNT; k++) {
                us[k] = 1e6 * best[c][k] / (double)per_cat;
                sum[k] += us[k];
            }
            printf("  %-30s %9.3f %9.3f %9.3f %6.2fx %6.2fx %10.2f  %016llx %016llx %016llx\n", cat_names[c],
                   us[RUN_FAST], us[RUN_EXACT], us[RUN_EXACT_BOXES], us[RUN_EXACT] / us[RUN_FAST],
                   us[RUN_EXACT_BOXES] / us[RUN_FAST], (double)fb[c][RUN_EXACT] / (double)per_cat,
                   (unsigned long long)hash[c][RUN_FAST], (unsigned long long)hash[c][RUN_EXACT],
                   (unsigned long long)hash[c][RUN_EXACT_BOXES]);
        }
        printf("  %-30s %9.3f %9.3f %9.3f %6.2fx %6.2fx\n", "all categories (mean)", sum[RUN_FAST] / CAT_COUNT,
               sum[RUN_EXACT] / CAT_COUNT, sum[RUN_EXACT_BOXES] / CAT_COUNT, sum[RUN_EXACT] / sum[RUN_FAST],
               sum[RUN_EXACT_BOXES] / sum[RUN_FAST]);
        free(q);
        free(by_cat);
        for (int k = 0; k < RUN_COUNT; k++)
            octree_free(trees[k]);
        mesh_data_free(&m);
    }
    free(out.contacts);
    return 0;
}
