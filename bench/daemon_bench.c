/* trioctd over udpm against the engine in process: what the daemon costs a client.
 *
 *   daemon_bench TRIOCTD   (inside tests/e2e/netns.sh: udpm never touches the host network)
 *
 * One daemon with one worker thread serves a generated world; one client asks, one request
 * in flight at a time. Printed: round-trip latency p50/p99 of one-ray closest-hit queries,
 * and rays/s of 1,000-ray closest-hit batches beside the same rays answered in this process
 * by octree_ray_batch on the same world, on one core, as a ratio. Targets (issue 4): p50 below
 * 100 us; batched throughput at least 70% of in-process. */
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "engine.h"
#include "support/daemon_proc.h"
#include "support/meshgen.h"
#include "support/obj_write.h"
#include "trioct.h"
#include "world/scene.h"
#include "world/world.h"

#define BUS_URL "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
#define BATCH 1000

static double now_seconds(void)
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

static void make_rays(rng *r, trioct_vec3 *o, trioct_vec3 *d, ray_input *in, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        vec3 from = rng_point_in_box(r, (box3){{-60, -60, 20}, {60, 60, 40}});
        vec3 to = rng_point_in_box(r, (box3){{-50, -50, -1}, {50, 50, 1}});
        vec3 dir = vec3_sub(to, from);
        o[i] = (trioct_vec3){from.x, from.y, from.z};
        d[i] = (trioct_vec3){dir.x, dir.y, dir.z};
        in[i] = (ray_input){from, dir, 0, INFINITY, RAY_CROSSING};
    }
}

static int fail(const char *what)
{
    fprintf(stderr, "daemon_bench: %s\n", what);
    return 1;
}

int main(int argc, char **argv)
{
    if (argc != 2)
        return fail("usage: daemon_bench TRIOCTD (inside tests/e2e/netns.sh)");
    char dir[] = "/tmp/trioct-bench-XXXXXX";
    if (mkdtemp(dir) == NULL)
        return fail("mkdtemp failed");
    char path[256], scene_path[256], log_path[256];
    mesh_data terrain = meshgen_terrain(9, (box3){{-50, -50, -1}, {50, 50, 1}}, 224, 224);
    snprintf(path, sizeof path, "%s/terrain.obj", dir);
    if (obj_write(path, &terrain) != 0)
        return fail("cannot write the world mesh");
    size_t triangles = terrain.triangle_count;
    mesh_data_free(&terrain);
    snprintf(scene_path, sizeof scene_path, "%s/bench.ini", dir);
    FILE *f = fopen(scene_path, "w");
    if (f == NULL)
        return fail("cannot write the scene");
    fputs("[bench]\nmesh = terrain.obj\neffects = rays\n", f);
    fclose(f);
    snprintf(log_path, sizeof log_path, "%s/daemon.log", dir);

    const char *extra[] = {"--threads", "1", "--log-level", "warn", NULL};
    pid_t pid = daemon_proc_start(argv[1], scene_path, BUS_URL, "bench", extra, log_path);
    trioct_connect_options opt = {.url = BUS_URL};
    trioct_client *c = trioct_connect(&opt, NULL, NULL, 0);
    if (pid < 0 || c == NULL || daemon_proc_wait_ready(c, "bench", 30000) != 0)
        return fail("the daemon did not start");

    /* The same world in this process, built from the same scene section. */
    scene s;
    char err[512];
    if (scene_load(scene_path, &s, err, sizeof err) != 0)
        return fail(err);
    int status;
    world *w = world_build(&s.worlds[0], dir, &status, err, sizeof err);
    scene_free(&s);
    if (w == NULL)
        return fail(err);

    rng r = rng_seeded(2026);
    static trioct_vec3 o[BATCH], d[BATCH];
    static ray_input in[BATCH];
    static ray_output outs[BATCH];
    static ray_hit hits[BATCH];
    static octree_status statuses[BATCH];
    for (size_t i = 0; i < BATCH; i++)
        outs[i] = (ray_output){.hits = &hits[i], .max_hits = 1};

    /* One ray at a time: the round trip. */
    enum { SINGLES = 3000, WARMUP = 200 };
    static double rtt[SINGLES];
    trioct_ray_query q = trioct_ray_query_default("bench");
    q.origins = o;
    q.directions = d;
    q.count = 1;
    for (int i = 0; i < SINGLES + WARMUP; i++) {
        make_rays(&r, o, d, in, 1);
        trioct_ray_result res;
        double t0 = now_seconds();
        int rc = trioct_rays(c, &q, 2000, &res);
        double t1 = now_seconds();
        trioct_ray_result_free(&res);
        if (rc != TRIOCT_OK)
            return fail("a one-ray query failed");
        if (i >= WARMUP)
            rtt[i - WARMUP] = t1 - t0;
    }
    qsort(rtt, SINGLES, sizeof rtt[0], compare_double);
    double p50 = rtt[SINGLES / 2], p99 = rtt[SINGLES * 99 / 100];

    /* 1,000-ray batches: over the bus, then the same rays in process, alternating rounds so
     * that machine noise falls on both alike. */
    enum { ROUNDS = 40 };
    double bus_time = 0, local_time = 0;
    q.count = BATCH;
    for (int round = 0; round < ROUNDS; round++) {
        make_rays(&r, o, d, in, BATCH);
        trioct_ray_result res;
        double t0 = now_seconds();
        int rc = trioct_rays(c, &q, 5000, &res);
        double t1 = now_seconds();
        trioct_ray_result_free(&res);
        if (rc != TRIOCT_OK)
            return fail("a batch query failed");
        query_stats st = {0};
        double t2 = now_seconds();
        octree_ray_batch(w->tree, in, BATCH, RAY_CLOSEST, ACCURACY_EXACT, outs, statuses, &st);
        double t3 = now_seconds();
        bus_time += t1 - t0;
        local_time += t3 - t2;
    }
    double bus_rate = ROUNDS * BATCH / bus_time, local_rate = ROUNDS * BATCH / local_time;

    printf("daemon_bench: world of %zu triangles, daemon with 1 worker thread, udpm on loopback\n", triangles);
    printf("  one-ray round trip     p50 %7.1f us   p99 %7.1f us   [target: p50 < 100 us]\n", p50 * 1e6,
           p99 * 1e6);
    printf("  1,000-ray batches      %.3fM rays/s over the bus, %.3fM rays/s in process: %.0f%%   [target: >= 70%%]\n",
           bus_rate / 1e6, local_rate / 1e6, 100 * bus_rate / local_rate);

    trioct_disconnect(c);
    world_release(w);
    int rc = daemon_proc_stop(pid, SIGTERM, 10000);
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd) != 0)
        return fail("cannot remove the temporary directory");
    return rc == 0 ? 0 : fail("the daemon did not exit cleanly on SIGTERM");
}
