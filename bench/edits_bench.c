/* Object edits over udpm: what a move costs a client, and what a stream of moves costs the
 * queries served meanwhile.
 *
 *   edits_bench TRIOCTD   (inside tests/e2e/netns.sh: udpm never touches the host network)
 *
 * The world: 100 objects of about 10,000 triangles each (four meshes, 25 objects each,
 * instanced), about a million triangles in all, on a 10 x 10 grid. The daemon has two
 * worker threads.
 *
 *   - Edit round trip: one MOVE of one object of the 100, from the call to the answer in
 *     hand, one at a time. Per round p50/p99. Target: p50 <= 1 ms.
 *   - Queries during edits: one client asks 64-ray closest-hit batches down onto the
 *     objects, one at a time; in alternate rounds a second client streams moves, 200 a
 *     second (a planning scene's updates), and then as fast as they are answered. Per round
 *     the queries' p50 and p99, and the median over the round pairs of the p99 ratio (with
 *     edits / without). Target, at 200 a second: the p99 kept, ratio <= 1.25x.
 *
 * Rounds alternate so that the noise of a shared machine falls on both sides alike. Figures
 * are printed beside their targets; nothing here asserts a time. */
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "support/daemon_proc.h"
#include "support/meshgen.h"
#include "support/obj_write.h"
#include "trioct.h"

#define BUS_URL "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
#define WORLD "edits"
#define DAEMON "editsd"
#define OBJECTS 100
#define SCENE_OBJECTS 64
#define MESHES 4
#define GRID_STEP 12.0
#define RAYS 64
#define STREAM_PERIOD_US 5000 /* 200 moves a second */

enum { ROUNDS = 7, EDITS_PER_ROUND = 300, QUERIES_PER_ROUND = 1000, WARMUP = 20 };

#define TARGET_EDIT_P50_US 1000.0
#define TARGET_P99_RATIO 1.25

static int fail(const char *what)
{
    fprintf(stderr, "edits_bench: %s\n", what);
    return 1;
}

static double now_seconds(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int compare_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Sorts v; the q-quantile (nearest rank). */
static double quantile(double *v, size_t n, double q)
{
    qsort(v, n, sizeof *v, compare_double);
    size_t k = (size_t)ceil(q * (double)n);
    return v[k > 0 ? k - 1 : 0];
}

static double median(double *v, size_t n)
{
    return quantile(v, n, 0.5);
}

static void object_name(int k, char out[16])
{
    snprintf(out, 16, "obj%03d", k);
}

/* Object k's place on the grid, turned by angle about z. */
static trioct_pose grid_pose(int k, double angle, double lift)
{
    double c = cos(angle), s = sin(angle);
    return (trioct_pose){{c, -s, 0, s, c, 0, 0, 0, 1},
                         {(k % 10) * GRID_STEP - 54, (k / 10) * GRID_STEP - 54, lift}};
}

/* One move of one object, timed from the call to the answer; -1 when it failed. */
static double timed_move(trioct_client *c, uint64_t *state)
{
    *state = *state * 6364136223846793005ull + 1442695040888963407ull;
    int k = (int)((*state >> 33) % OBJECTS);
    char name[16];
    object_name(k, name);
    trioct_object_edit e = {.op = TRIOCT_OBJECT_MOVE, .name = name,
                            .pose = grid_pose(k, (double)(*state >> 40) * 1e-6, 0.0)};
    trioct_object_result res;
    double t0 = now_seconds();
    int st = trioct_objects_edit(c, WORLD, &e, 1, 0, 2000, &res);
    double t = now_seconds() - t0;
    trioct_object_result_free(&res);
    return st == TRIOCT_OK ? t : -1;
}

/* The second client: moves until told to stop, one every period_us (0: back to back). */
typedef struct streamer {
    atomic_int run;
    atomic_long done, failed;
    long period_us;
} streamer;

static void *stream_edits(void *arg)
{
    streamer *s = arg;
    trioct_connect_options opt = {.url = BUS_URL};
    trioct_client *c = trioct_connect(&opt, NULL, NULL, 0);
    if (c == NULL) {
        atomic_fetch_add(&s->failed, 1);
        return NULL;
    }
    uint64_t state = 99;
    double next = now_seconds();
    while (atomic_load(&s->run)) {
        if (timed_move(c, &state) < 0)
            atomic_fetch_add(&s->failed, 1);
        else
            atomic_fetch_add(&s->done, 1);
        next += (double)s->period_us * 1e-6;
        double wait = next - now_seconds();
        if (wait > 0) {
            struct timespec ts = {(time_t)wait, (long)((wait - (double)(time_t)wait) * 1e9)};
            nanosleep(&ts, NULL);
        }
    }
    trioct_disconnect(c);
    return NULL;
}

/* One round of ray batches: the round trips into t (QUERIES_PER_ROUND), 0 or -1. */
static int query_round(trioct_client *c, trioct_ray_query *q, trioct_vec3 *o, trioct_vec3 *d, uint64_t *state,
                       double *t)
{
    for (int i = 0; i < WARMUP + QUERIES_PER_ROUND; i++) {
        for (int k = 0; k < RAYS; k++) {
            *state = *state * 6364136223846793005ull + 1442695040888963407ull;
            double x = (double)((*state >> 11) % 120000) / 1000.0 - 60.0;
            double y = (double)((*state >> 31) % 120000) / 1000.0 - 60.0;
            o[k] = (trioct_vec3){x, y, 50};
            d[k] = (trioct_vec3){0.01, -0.02, -1};
        }
        trioct_ray_result res;
        double t0 = now_seconds();
        int st = trioct_rays(c, q, 2000, &res);
        double dt = now_seconds() - t0;
        trioct_ray_result_free(&res);
        if (st != TRIOCT_OK)
            return -1;
        if (i >= WARMUP)
            t[i - WARMUP] = dt;
    }
    return 0;
}

/* Alternate rounds of ray batches alone and while a second client moves objects, one
 * every period_us (0: back to back); prints the rounds and the median p99 ratio. */
static int queries_during_edits(trioct_client *c, trioct_ray_query *q, trioct_vec3 *o, trioct_vec3 *d, double *t,
                                double *t2, long period_us)
{
    double ratio[ROUNDS];
    if (period_us > 0)
        printf("  %d-ray closest-hit batches, %d a round, alone and while a second client moves an object every "
               "%ld us:\n",
               RAYS, QUERIES_PER_ROUND, period_us);
    else
        printf("  the same, the second client moving objects back to back (as fast as they are answered):\n");
    for (int round = 0; round < ROUNDS; round++) {
        uint64_t qs = 1000 + (uint64_t)round;
        if (query_round(c, q, o, d, &qs, t) != 0)
            return -1;
        streamer s;
        atomic_init(&s.run, 1);
        atomic_init(&s.done, 0);
        atomic_init(&s.failed, 0);
        s.period_us = period_us;
        pthread_t th;
        if (pthread_create(&th, NULL, stream_edits, &s) != 0)
            return -1;
        qs = 1000 + (uint64_t)round; /* the same rays */
        int rc = query_round(c, q, o, d, &qs, t2);
        atomic_store(&s.run, 0);
        pthread_join(th, NULL);
        if (rc != 0 || atomic_load(&s.failed) != 0)
            return -1;
        double a50 = quantile(t, QUERIES_PER_ROUND, 0.5), a99 = quantile(t, QUERIES_PER_ROUND, 0.99);
        double b50 = quantile(t2, QUERIES_PER_ROUND, 0.5), b99 = quantile(t2, QUERIES_PER_ROUND, 0.99);
        ratio[round] = b99 / a99;
        printf("    round %d: alone p50 %7.1f us p99 %7.1f | with %ld moves p50 %7.1f us p99 %7.1f | p99 ratio "
               "%.2fx\n",
               round + 1, a50 * 1e6, a99 * 1e6, atomic_load(&s.done), b50 * 1e6, b99 * 1e6, ratio[round]);
    }
    if (period_us > 0)
        printf("  query p99 with edits / alone: median %.2fx over the rounds   [target: <= %.2fx]\n",
               median(ratio, ROUNDS), TARGET_P99_RATIO);
    else
        printf("  query p99 with edits back to back / alone: median %.2fx over the rounds (no target)\n",
               median(ratio, ROUNDS));
    return 0;
}

int main(int argc, char **argv)
{
    if (argc != 2)
        return fail("usage: edits_bench TRIOCTD (inside tests/e2e/netns.sh)");
    char dir[] = "/tmp/trioct-edits-XXXXXX";
    if (mkdtemp(dir) == NULL)
        return fail("mkdtemp failed");
    char path[256];
    size_t triangles = 0, per_mesh[MESHES];
    for (int m = 0; m < MESHES; m++) {
        /* 71 x 71 cells of two triangles: 10,082 triangles in a 10 x 10 patch. */
        mesh_data mesh = meshgen_terrain(100 + (uint64_t)m, (box3){{-5, -5, 0}, {5, 5, 3}}, 71, 71);
        snprintf(path, sizeof path, "%s/part%d.obj", dir, m);
        if (obj_write(path, &mesh) != 0)
            return fail("cannot write a mesh");
        per_mesh[m] = mesh.triangle_count;
        mesh_data_free(&mesh);
    }
    snprintf(path, sizeof path, "%s/edits.ini", dir);
    FILE *f = fopen(path, "w");
    if (f == NULL)
        return fail("cannot write the scene");
    fprintf(f, "[" WORLD "]\neffects = rays\n");
    /* A scene section places at most 64 objects; the rest come as one edit list of adds,
     * which share the meshes the scene's objects loaded. */
    for (int k = 0; k < SCENE_OBJECTS; k++) {
        char name[16];
        object_name(k, name);
        trioct_pose p = grid_pose(k, 0, 0);
        fprintf(f, "object.%s = part%d.obj\npose.%s = %.17g %.17g 0 1 0 0 0\n", name, k % MESHES, name, p.t.x,
                p.t.y);
    }
    for (int k = 0; k < OBJECTS; k++)
        triangles += per_mesh[k % MESHES];
    fclose(f);
    char log_path[256];
    snprintf(log_path, sizeof log_path, "%s/daemon.log", dir);
    const char *extra[] = {"--threads", "2", "--log-level", "warn", NULL};
    pid_t pid = daemon_proc_start(argv[1], path, BUS_URL, DAEMON, extra, log_path);
    trioct_connect_options opt = {.url = BUS_URL};
    trioct_client *c = trioct_connect(&opt, NULL, NULL, 0);
    if (pid < 0 || c == NULL || daemon_proc_wait_ready(c, DAEMON, 60000) != 0)
        return fail("the daemon did not start");

    static char names[OBJECTS][16], meshes[MESHES][16];
    trioct_object_edit adds[OBJECTS - SCENE_OBJECTS];
    for (int m = 0; m < MESHES; m++)
        snprintf(meshes[m], sizeof meshes[m], "part%d.obj", m);
    for (int k = SCENE_OBJECTS; k < OBJECTS; k++) {
        object_name(k, names[k]);
        adds[k - SCENE_OBJECTS] = (trioct_object_edit){.op = TRIOCT_OBJECT_ADD, .name = names[k],
                                                       .mesh = meshes[k % MESHES], .pose = grid_pose(k, 0, 0)};
    }
    trioct_object_result added;
    int st = trioct_objects_edit(c, WORLD, adds, OBJECTS - SCENE_OBJECTS, 0, 60000, &added);
    if (st != TRIOCT_OK || added.objects != OBJECTS) {
        fprintf(stderr, "edits_bench: adding the objects: %s\n", added.reply.message);
        return 1;
    }
    trioct_object_result_free(&added);

    printf("edits_bench: %d objects (%d meshes of about %zu triangles, instanced), %zu triangles in all, "
           "daemon with 2 worker threads, udpm on loopback\n",
           OBJECTS, MESHES, per_mesh[0], triangles);

    /* Edit round trips, one at a time. */
    uint64_t state = 7;
    double p50s[ROUNDS];
    double *t = malloc(sizeof *t * (EDITS_PER_ROUND > QUERIES_PER_ROUND ? EDITS_PER_ROUND : QUERIES_PER_ROUND));
    double *t2 = malloc(sizeof *t2 * QUERIES_PER_ROUND);
    if (t == NULL || t2 == NULL)
        return fail("out of memory");
    printf("  one MOVE of one object of %d, round trip through libtrioct, %d rounds of %d:\n", OBJECTS, ROUNDS,
           EDITS_PER_ROUND);
    for (int round = 0; round < ROUNDS; round++) {
        for (int i = 0; i < WARMUP + EDITS_PER_ROUND; i++) {
            double dt = timed_move(c, &state);
            if (dt < 0)
                return fail("a move failed");
            if (i >= WARMUP)
                t[i - WARMUP] = dt;
        }
        double p99 = quantile(t, EDITS_PER_ROUND, 0.99);
        p50s[round] = quantile(t, EDITS_PER_ROUND, 0.5);
        printf("    round %d: p50 %7.1f us  p99 %7.1f us\n", round + 1, p50s[round] * 1e6, p99 * 1e6);
    }
    double edit_p50 = median(p50s, ROUNDS);
    printf("  edit round trip p50: median %.1f us over the rounds   [target: <= %.0f us]\n", edit_p50 * 1e6,
           TARGET_EDIT_P50_US);

    /* Queries alone, and queries while a second client streams moves: a planning scene's
     * pace (a move every 5 ms), the target's case, then moves back to back. */
    trioct_vec3 o[RAYS], d[RAYS];
    trioct_ray_query q = trioct_ray_query_default(WORLD);
    q.count = RAYS;
    q.origins = o;
    q.directions = d;
    static const long periods[2] = {STREAM_PERIOD_US, 0};
    for (int pace = 0; pace < 2; pace++)
        if (queries_during_edits(c, &q, o, d, t, t2, periods[pace]) != 0)
            return fail("a query or a move failed during the stream");
    free(t);
    free(t2);
    trioct_disconnect(c);
    daemon_proc_stop(pid, 15, 5000);
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : 1;
}
