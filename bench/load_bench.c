/* The daemon under sustained load, over udpm: does every request get its answer?
 *
 *   load_bench TRIOCTD [SECONDS]   (inside tests/e2e/netns.sh; `make bench-load`)
 *
 * 8 clients, each its own connection and thread, each asking one 4-ray closest-hit request
 * every millisecond (8,000 requests a second in all) of a 20,000-triangle terrain, with a
 * 2 s timeout and libtrioct's retries, for SECONDS (default 60) in each of three phases:
 *   steady   nothing else happens;
 *   reload   the scene is rewritten (the terrain at another resolution: the same answers)
 *            and the daemon sent SIGHUP every 2 s;
 *   restart  after a third of the phase the daemon is killed with SIGKILL and started
 *            again at once.
 * Each phase prints requests, answers, lost (no answer within the timeout, retries
 * included), BUSY, other errors, wrong answers (against the engine in this process), the
 * clients' retries, latency p50/p99, and the daemon's RSS at the phase's start, middle and
 * end. Targets: 0 lost and 0 wrong in every phase, RSS flat. Figures are printed beside
 * the targets; nothing here asserts a time. */
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "engine.h"
#include "support/daemon_proc.h"
#include "support/meshgen.h"
#include "support/obj_write.h"
#include "trioct.h"
#include "world/scene.h"
#include "world/world.h"

#define BUS_URL "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608"
#define DAEMON "loadd"
#define CLIENTS 8
#define RAYS 4
#define PERIOD_NS 1000000 /* a request a millisecond, per client */
#define TIMEOUT_MS 2000
#define RAY_SETS 256

static char dir[64] = "/tmp/trioct-load-bench-XXXXXX";
static char scene_path[128], log_path[128];
static const char *daemon_bin;
static pid_t daemon_pid;
static const world *truth;
static trioct_vec3 origins[RAY_SETS][RAYS], directions[RAY_SETS][RAYS];
static double expected_t[RAY_SETS][RAYS]; /* INFINITY: no hit */

static int64_t now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (int64_t)t.tv_sec * 1000000000 + t.tv_nsec;
}

static void sleep_until(int64_t when)
{
    struct timespec t = {(time_t)(when / 1000000000), (long)(when % 1000000000)};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, NULL) != 0) {
    }
}

static long rss_kib(pid_t pid)
{
    char path[64], line[256];
    snprintf(path, sizeof path, "/proc/%d/status", (int)pid);
    FILE *f = fopen(path, "r");
    long kib = -1;
    while (f && fgets(line, sizeof line, f))
        if (sscanf(line, "VmRSS: %ld kB", &kib) == 1)
            break;
    if (f)
        fclose(f);
    return kib;
}

static void write_scene(int variant)
{
    FILE *f = fopen(scene_path, "w");
    fprintf(f, "[daemon]\nname = %s\nqueue_depth = 4096\nlog_level = warn\n\n[ground]\nmesh = terrain.obj\n"
               "effects = rays\nresolution = %s\n",
            DAEMON, variant ? "0.5" : "auto");
    fclose(f);
}

static int start_daemon(void)
{
    const char *extra[] = {"--threads", "2", "--status-interval", "500", NULL};
    daemon_pid = daemon_proc_start(daemon_bin, scene_path, BUS_URL, DAEMON, extra, log_path);
    if (daemon_pid < 0)
        return -1;
    trioct_connect_options opt = {.url = BUS_URL};
    trioct_client *c = trioct_connect(&opt, NULL, NULL, 0);
    int ready = c && daemon_proc_wait_ready(c, DAEMON, 30000) == 0;
    trioct_disconnect(c);
    return ready ? 0 : -1;
}

/* ---------- the clients ---------- */

typedef struct counts {
    atomic_long requests, answered, lost, busy, other, wrong;
} counts;

typedef struct client_job {
    int index;
    atomic_int *run;
    counts *n;
    double *latency_us; /* one per request, up to cap */
    size_t count, cap;
    uint64_t retries;
} client_job;

static int answer_right(const trioct_ray_result *res, int set)
{
    if (res->num_rays != RAYS)
        return 0;
    size_t h = 0;
    for (int i = 0; i < RAYS; i++) {
        int hit = res->found[i] > 0;
        if (hit != (expected_t[set][i] != INFINITY))
            return 0;
        if (hit) {
            if (h >= res->num_hits || res->hits[h].ray != i || res->hits[h].t != expected_t[set][i])
                return 0;
            h++;
        }
    }
    return 1;
}

static void *client_loop(void *arg)
{
    client_job *j = arg;
    trioct_connect_options opt = {.url = BUS_URL};
    trioct_client *c = trioct_connect(&opt, NULL, NULL, 0);
    if (!c)
        return NULL;
    int64_t next = now_ns() + j->index * (PERIOD_NS / CLIENTS);
    unsigned set = (unsigned)j->index * 31u;
    while (atomic_load(j->run)) {
        sleep_until(next);
        next += PERIOD_NS;
        set = (set + 1) % RAY_SETS;
        trioct_ray_query q = trioct_ray_query_default("ground");
        q.detail = TRIOCT_RAY_CLOSEST;
        q.count = RAYS;
        q.origins = origins[set];
        q.directions = directions[set];
        trioct_ray_result res;
        int64_t t0 = now_ns();
        int st = trioct_rays(c, &q, TIMEOUT_MS, &res);
        double us = (double)(now_ns() - t0) / 1e3;
        atomic_fetch_add(&j->n->requests, 1);
        if (st == TRIOCT_OK) {
            atomic_fetch_add(&j->n->answered, 1);
            if (!answer_right(&res, (int)set))
                atomic_fetch_add(&j->n->wrong, 1);
            if (j->count < j->cap)
                j->latency_us[j->count++] = us;
        } else if (st == TRIOCT_ERR_BUSY) {
            atomic_fetch_add(&j->n->busy, 1);
        } else if (st == TRIOCT_ERR_TIMEOUT || st == TRIOCT_ERR_NO_DAEMON) {
            atomic_fetch_add(&j->n->lost, 1);
        } else {
            atomic_fetch_add(&j->n->other, 1);
        }
        trioct_ray_result_free(&res);
        /* Behind by more than a second (a long stall): start afresh rather than burst. */
        if (now_ns() - next > 1000000000)
            next = now_ns();
    }
    trioct_client_stats st;
    trioct_client_get_stats(c, &st);
    j->retries = st.retries;
    trioct_disconnect(c);
    return NULL;
}

static int compare_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* ---------- a phase ---------- */

typedef enum { STEADY, RELOAD, RESTART } phase_kind;

static int run_phase(phase_kind kind, int seconds)
{
    static const char *names[] = {"steady", "reload every 2 s", "kill -9 and restart"};
    counts n;
    memset(&n, 0, sizeof n);
    atomic_int run;
    atomic_init(&run, 1);
    client_job jobs[CLIENTS];
    pthread_t threads[CLIENTS];
    size_t cap = (size_t)seconds * 1100 + 1000;
    for (int k = 0; k < CLIENTS; k++) {
        jobs[k] = (client_job){.index = k, .run = &run, .n = &n, .cap = cap};
        jobs[k].latency_us = malloc(cap * sizeof *jobs[k].latency_us);
        pthread_create(&threads[k], NULL, client_loop, &jobs[k]);
    }
    long rss[3] = {rss_kib(daemon_pid), 0, 0};
    int64_t start = now_ns(), end = start + (int64_t)seconds * 1000000000;
    int64_t next_event = start + (kind == RESTART ? (end - start) / 3 : 2000000000);
    int variant = 0, reloads = 0, restarts = 0, mid_taken = 0;
    while (now_ns() < end) {
        sleep_until(now_ns() + 20000000);
        if (!mid_taken && now_ns() >= start + (end - start) / 2) {
            rss[1] = rss_kib(daemon_pid);
            mid_taken = 1;
        }
        if (kind == STEADY || now_ns() < next_event)
            continue;
        if (kind == RELOAD) {
            variant = !variant;
            write_scene(variant);
            kill(daemon_pid, SIGHUP);
            reloads++;
            next_event += 2000000000;
        } else if (restarts == 0) {
            kill(daemon_pid, SIGKILL);
            daemon_proc_wait_exit(daemon_pid, 5000);
            int64_t t0 = now_ns();
            if (start_daemon() != 0) {
                fprintf(stderr, "load_bench: the daemon did not come back\n");
                break;
            }
            printf("  restarted in %.2f s (READY heard)\n", (double)(now_ns() - t0) / 1e9);
            restarts++;
        }
    }
    rss[2] = rss_kib(daemon_pid);
    atomic_store(&run, 0);
    uint64_t retries = 0;
    size_t total = 0;
    for (int k = 0; k < CLIENTS; k++) {
        pthread_join(threads[k], NULL);
        retries += jobs[k].retries;
        total += jobs[k].count;
    }
    double *all = malloc((total ? total : 1) * sizeof *all);
    size_t m = 0;
    for (int k = 0; k < CLIENTS; k++) {
        memcpy(all + m, jobs[k].latency_us, jobs[k].count * sizeof *all);
        m += jobs[k].count;
        free(jobs[k].latency_us);
    }
    qsort(all, m, sizeof *all, compare_double);
    double p50 = m ? all[(size_t)(0.50 * (double)(m - 1))] : 0, p99 = m ? all[(size_t)(0.99 * (double)(m - 1))] : 0;
    free(all);
    long lost = atomic_load(&n.lost), wrong = atomic_load(&n.wrong);
    printf("%-20s %8ld requests, %8ld answered, lost %ld (target 0), BUSY %ld, other errors %ld, wrong %ld "
           "(target 0), retries %llu; p50 %.0f us, p99 %.0f us; daemon RSS %ld / %ld / %ld KiB (start / middle / "
           "end); %d reloads, %d restarts\n",
           names[kind], atomic_load(&n.requests), atomic_load(&n.answered), lost, atomic_load(&n.busy),
           atomic_load(&n.other), wrong, (unsigned long long)retries, p50, p99, rss[0], rss[1], rss[2],
           reloads, restarts);
    return lost == 0 && wrong == 0 ? 0 : 1;
}

/* ---------- set-up ---------- */

static int make_world(void)
{
    if (!mkdtemp(dir))
        return -1;
    snprintf(scene_path, sizeof scene_path, "%s/scene.ini", dir);
    snprintf(log_path, sizeof log_path, "%s/daemon.log", dir);
    mesh_data terrain = meshgen_terrain(5, (box3){{-50, -50, -2}, {50, 50, 2}}, 100, 100);
    char path[160];
    snprintf(path, sizeof path, "%s/terrain.obj", dir);
    if (obj_write(path, &terrain) != 0)
        return -1;
    mesh_data_free(&terrain);
    write_scene(0);
    scene sc;
    char err[512];
    if (scene_load(scene_path, &sc, err, sizeof err) != 0)
        return -1;
    int status;
    truth = world_build(&sc.worlds[0], dir, NULL, &status, err, sizeof err);
    scene_free(&sc);
    if (!truth)
        return -1;
    uint64_t s = 12345;
    for (int k = 0; k < RAY_SETS; k++)
        for (int i = 0; i < RAYS; i++) {
            s = s * 6364136223846793005ull + 1442695040888963407ull;
            double x = (double)(s >> 11) / 9007199254740992.0 * 96 - 48;
            s = s * 6364136223846793005ull + 1442695040888963407ull;
            double y = (double)(s >> 11) / 9007199254740992.0 * 96 - 48;
            origins[k][i] = (trioct_vec3){x, y, 10};
            directions[k][i] = (trioct_vec3){0.01 * i, -0.02, -1};
            ray_input in = {.origin = {x, y, 10}, .direction = {0.01 * i, -0.02, -1}, .tmin = 0, .tmax = INFINITY};
            ray_hit hit;
            ray_output out = {.hits = &hit, .max_hits = 1};
            octree_ray(truth->tree, &in, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL);
            expected_t[k][i] = out.hit_count ? hit.t : INFINITY;
        }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: load_bench TRIOCTD [SECONDS] (inside tests/e2e/netns.sh)\n");
        return 2;
    }
    daemon_bin = argv[1];
    int seconds = argc > 2 ? atoi(argv[2]) : 60;
    if (seconds < 2)
        seconds = 2;
    if (make_world() != 0 || start_daemon() != 0) {
        fprintf(stderr, "load_bench: could not set up the world or the daemon (log %s)\n", log_path);
        return 1;
    }
    printf("load_bench: %d clients x %d requests/s of %d rays, %d s a phase, timeout %d ms, retries on\n", CLIENTS,
           (int)(1000000000 / PERIOD_NS), RAYS, seconds, TIMEOUT_MS);
    int failed = 0;
    failed |= run_phase(STEADY, seconds);
    failed |= run_phase(RELOAD, seconds);
    write_scene(0);
    failed |= run_phase(RESTART, seconds);
    daemon_proc_stop(daemon_pid, SIGTERM, 5000);
    world_release((world *)truth);
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "load_bench: could not remove %s\n", dir);
    printf("load_bench: %s\n", failed ? "targets missed (see lost and wrong above)" : "every target met");
    return 0;
}
