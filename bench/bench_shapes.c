/* Mesh queries of a robot-sized shape (a subdivided torus, 3,600 triangles) at 2,000 rigid
 * poses near a world's surface, half of them colliding: the per-triangle path (each posed
 * triangle searched from the world's root) against the shape's own octree descended with
 * the world's. Yes/no over the mixed poses, yes/no over the collision-free ones alone, and
 * every pair over the mixed poses; poses per second and work per pose, in alternating
 * rounds (old, new, old, new, ...), median and range. Also what building the shape's tree
 * costs (octree_mesh_batch on an inline shape, 512 poses a batch; octree_mesh one pose at a
 * time) and how the shape tree's resolution changes the rate. Asserts nothing; checks that
 * both paths give the same answers.
 *
 * bench_shapes [ROUNDS]                  everything, on the subdivided Spider and a terrain
 * bench_shapes one WORLD PATH PART [F]   one pass for callgrind: WORLD spider or terrain,
 *                                        PATH old, new or batch, PART mixed, free or pairs; F
 *                                        scales the shape tree's resolution (1)
 * bench_shapes peer WORLD PART           one batch pass of the peer bench's shape
 *                                        (bench/peers: Wuson at 2% of the world's radius) on
 *                                        WORLD spider, wuson (x4^3) or icosphere, for callgrind */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "engine.h"
#include "octree/octree_internal.h"
#include "support/meshgen.h"
#include "support/real_meshes.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

enum { POSES = 2000, DEFAULT_ROUNDS = 5, MAX_ROUNDS = 15, PAIR_ROOM = 1 << 16, INLINE_BATCH = 512 };

typedef struct workload {
    const char *name;
    mesh_data world_mesh;
    octree *world;
    mesh_data shape_mesh;
    octree *shape;
    pose mixed[POSES];      /* colliding and free alternate */
    pose free[POSES / 2];   /* the free ones of mixed */
} workload;

static void fail(const char *what)
{
    fprintf(stderr, "bench_shapes: %s\n", what);
    exit(1);
}

/* A world with triangle boxes (as the daemon builds worlds serving meshes), a shape with
 * node bounds (as it builds query shapes). */
static octree *build(const mesh_data *m, double resolution, int boxes)
{
    octree_def def = octree_default_def();
    def.resolution = resolution;
    def.triangle_boxes = boxes;
    def.node_bounds = !boxes;
    mesh_view v = mesh_data_view(m);
    octree_error err;
    octree *t = octree_build(&v, &def, &err);
    if (!t)
        fail(err.message);
    return t;
}

static void random_rotation(rng *r, double m[9])
{
    double q[4], n = 0;
    for (int i = 0; i < 4; i++) {
        q[i] = rng_uniform(r, -1, 1);
        n += q[i] * q[i];
    }
    n = sqrt(n);
    double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
    double v[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
                   2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                   2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
    memcpy(m, v, sizeof v);
}

/* The shape: a torus (a link with a hole), subdivided once to 3,600 triangles, its
 * extent `size`, centred on its local origin. */
static mesh_data make_shape(double size)
{
    mesh_data coarse = meshgen_torus((vec3){0, 0, 0}, 1.0, 0.35, 30, 15);
    mesh_data fine = meshgen_subdivide(&coarse, 1);
    mesh_data_free(&coarse);
    box3 b = mesh_data_bounds(&fine);
    double extent = fmax(b.hi.x - b.lo.x, fmax(b.hi.y - b.lo.y, b.hi.z - b.lo.z));
    mesh_data m = meshgen_transformed(&fine, size / extent, (vec3){0, 0, 0});
    mesh_data_free(&fine);
    return m;
}

/* Poses whose centre lies at -0.4 to 1.2 shape radii off a random surface point along the
 * surface's normal, rotated at random; kept until there are POSES / 2 of each answer,
 * which the per-triangle path decides. */
static void make_poses(workload *w, uint64_t seed)
{
    rng r = rng_seeded(seed);
    box3 sb = mesh_data_bounds(&w->shape_mesh);
    double radius = 0.5 * vec3_length(vec3_sub(sb.hi, sb.lo));
    mesh_view sv = mesh_data_view(&w->shape_mesh);
    size_t hits = 0, misses = 0;
    while (hits < POSES / 2 || misses < POSES / 2) {
        size_t t = rng_next(&r) % w->world_mesh.triangle_count;
        vec3 a = mesh_data_corner(&w->world_mesh, t, 0), b = mesh_data_corner(&w->world_mesh, t, 1),
             c = mesh_data_corner(&w->world_mesh, t, 2);
        vec3 n = vec3_normalize(vec3_cross(vec3_sub(b, a), vec3_sub(c, a)));
        if (!(vec3_length(n) > 0.5))
            continue;
        vec3 p = vec3_scale(vec3_add(vec3_add(a, b), c), 1.0 / 3.0);
        pose at;
        random_rotation(&r, at.r);
        at.t = vec3_add(p, vec3_scale(n, radius * rng_uniform(&r, -0.4, 1.2)));
        mesh_output out = {0};
        if (octree_mesh_as_triangles(w->world, &sv, &at, 0, ACCURACY_EXACT, &out, NULL) != OCTREE_OK)
            fail("a pose query failed");
        if (out.hit && hits < POSES / 2)
            w->mixed[2 * hits++] = at;
        else if (!out.hit && misses < POSES / 2) {
            w->free[misses] = at;
            w->mixed[2 * misses++ + 1] = at;
        }
    }
}

typedef enum part { PART_MIXED, PART_FREE, PART_PAIRS, PART_COUNT } part;
static const char *const PART_NAMES[PART_COUNT] = {"yes/no, mixed", "yes/no, collision-free", "all pairs, mixed"};
static const char *const PART_KEYS[PART_COUNT] = {"mixed", "free", "pairs"};

typedef struct pass {
    double seconds;
    size_t poses;
    query_stats stats;
    size_t hits;  /* poses in contact */
    size_t pairs; /* pairs reported */
    uint64_t digest; /* of every answer, to compare the paths */
} pass;

static uint64_t mix(uint64_t h, uint64_t v) { return (h ^ v) * 0x100000001b3ull; }

static mesh_pair pair_room[PAIR_ROOM];

/* One pass of a part by one path: old (the per-triangle path, as octree_mesh answered
 * before shape trees) or new (the registered shape's tree, octree_mesh_tree). */
static pass run_pass(const workload *w, const octree *shape, int new_path, part which, accuracy_mode mode)
{
    const pose *poses = which == PART_FREE ? w->free : w->mixed;
    size_t count = which == PART_FREE ? POSES / 2 : POSES;
    int all = which == PART_PAIRS;
    mesh_view sv = mesh_data_view(&w->shape_mesh);
    pass p = {0};
    p.poses = count;
    p.digest = 0xcbf29ce484222325ull;
    double t0 = now();
    if (new_path == 2) {
        /* One call for every pose, as the daemon asks for a registered shape's poses. */
        static mesh_output outs[POSES];
        static octree_status sts[POSES];
        size_t room = all ? PAIR_ROOM / count : 0;
        for (size_t i = 0; i < count; i++)
            outs[i] = (mesh_output){.pairs = all ? pair_room + i * room : NULL, .capacity = room};
        if (octree_mesh_tree_batch(w->world, shape, poses, count, all, mode, outs, sts, &p.stats) != OCTREE_OK)
            fail("a batch failed");
        for (size_t i = 0; i < count; i++) {
            if (sts[i] != OCTREE_OK)
                fail("a pose query failed");
            p.hits += outs[i].hit != 0;
            p.pairs += outs[i].count;
        }
        p.seconds = now() - t0;
        return p;
    }
    for (size_t i = 0; i < count; i++) {
        mesh_output out = {.pairs = pair_room, .capacity = PAIR_ROOM};
        octree_status st = new_path ? octree_mesh_tree(w->world, shape, &poses[i], all, mode, &out, &p.stats)
                                    : octree_mesh_as_triangles(w->world, &sv, &poses[i], all, mode, &out, &p.stats);
        if (st != OCTREE_OK)
            fail("a pose query failed");
        p.hits += out.hit != 0;
        p.pairs += out.count;
        p.digest = mix(p.digest, (uint64_t)out.hit << 40 | out.count);
        size_t n = out.count < PAIR_ROOM ? out.count : PAIR_ROOM;
        for (size_t k = 0; k < n; k++)
            p.digest = mix(p.digest, (uint64_t)out.pairs[k].query_triangle << 32 | out.pairs[k].world_triangle);
    }
    p.seconds = now() - t0;
    return p;
}

static int compare_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n)
{
    double s[MAX_ROUNDS];
    memcpy(s, v, (size_t)n * sizeof *v);
    qsort(s, (size_t)n, sizeof *s, compare_double);
    return n % 2 ? s[n / 2] : 0.5 * (s[n / 2 - 1] + s[n / 2]);
}

static double min_of(const double *v, int n)
{
    double m = v[0];
    for (int i = 1; i < n; i++)
        m = fmin(m, v[i]);
    return m;
}

static double max_of(const double *v, int n)
{
    double m = v[0];
    for (int i = 1; i < n; i++)
        m = fmax(m, v[i]);
    return m;
}

/* Old and new in alternating rounds for each part, exact mode. */
static void bench_parts(const workload *w, int rounds)
{
    printf("%-24s %-4s %12s %19s %13s %13s %11s %9s\n", "part", "path", "poses/s", "range", "nodes/pose",
           "leaves/pose", "tests/pose", "new/old");
    for (int k = 0; k < PART_COUNT; k++) {
        double rate[2][MAX_ROUNDS], ratio[MAX_ROUNDS];
        pass last[2];
        for (int r = 0; r < rounds; r++) {
            for (int path = 0; path < 2; path++) {
                last[path] = run_pass(w, w->shape, path, (part)k, ACCURACY_EXACT);
                rate[path][r] = (double)last[path].poses / last[path].seconds;
            }
            ratio[r] = rate[1][r] / rate[0][r];
        }
        if (last[0].digest != last[1].digest || last[0].hits != last[1].hits || last[0].pairs != last[1].pairs)
            fail("the two paths answered differently");
        for (int path = 0; path < 2; path++) {
            double n = (double)last[path].poses;
            printf("%-24s %-4s %12.0f %9.0f-%-9.0f %13.1f %13.1f %11.1f", path ? "" : PART_NAMES[k],
                   path ? "new" : "old", median(rate[path], rounds), min_of(rate[path], rounds),
                   max_of(rate[path], rounds), (double)last[path].stats.nodes_visited / n,
                   (double)last[path].stats.leaves_visited / n, (double)last[path].stats.candidates_tested / n);
            if (path)
                printf(" %8.1fx (%.1f-%.1f)", median(ratio, rounds), min_of(ratio, rounds), max_of(ratio, rounds));
            printf("\n");
        }
        printf("%-24s      %zu of %zu poses in contact, %zu pairs\n", "", last[0].hits, last[0].poses, last[0].pairs);
    }
}

/* Fast and seed mode, one alternating pair of passes each (their tests differ; the work
 * the trees save is the same). */
static void bench_modes(const workload *w)
{
    const accuracy_mode modes[] = {ACCURACY_FAST, ACCURACY_SEED};
    for (int m = 0; m < 2; m++)
        for (int k = 0; k < PART_COUNT; k += 2) {
            pass old = run_pass(w, w->shape, 0, (part)k, modes[m]);
            pass fresh = run_pass(w, w->shape, 1, (part)k, modes[m]);
            if (old.digest != fresh.digest)
                fail("the two paths answered differently");
            printf("%-5s %-24s old %9.0f poses/s, new %9.0f poses/s: %.1fx\n", accuracy_mode_name(modes[m]),
                   PART_NAMES[k], (double)old.poses / old.seconds, (double)fresh.poses / fresh.seconds,
                   old.seconds / fresh.seconds);
        }
}

/* The shape tree's resolution: the heuristic's times 1/4 .. 4, yes/no over the mixed and
 * the free poses, alternating with the heuristic's own tree. */
static void bench_shape_resolution(const workload *w, int rounds)
{
    const double factors[] = {0.25, 0.5, 2, 4, 8};
    double d = w->shape->info.resolution;
    printf("shape tree resolution (heuristic d = %.4g, %zu nodes), yes/no, exact; rate vs the heuristic's tree:\n", d,
           w->shape->info.node_count);
    for (size_t f = 0; f < sizeof factors / sizeof factors[0]; f++) {
        octree *alt = build(&w->shape_mesh, d * factors[f], 0);
        for (int k = 0; k < 2; k++) {
            double ratio[MAX_ROUNDS];
            for (int r = 0; r < rounds; r++) {
                pass base = run_pass(w, w->shape, 1, (part)k, ACCURACY_EXACT);
                pass other = run_pass(w, alt, 1, (part)k, ACCURACY_EXACT);
                ratio[r] = base.seconds / other.seconds;
            }
            printf("  d x %-5g (%6zu nodes) %-24s %.2fx (%.2f-%.2f)\n", factors[f], alt->info.node_count,
                   PART_NAMES[k], median(ratio, rounds), min_of(ratio, rounds), max_of(ratio, rounds));
        }
        octree_free(alt);
    }
}

/* Inline shapes: octree_mesh_batch builds the tree once a batch of 512 poses, octree_mesh
 * once a pose; against the per-triangle path on the same poses. */
static void bench_inline(const workload *w)
{
    mesh_view sv = mesh_data_view(&w->shape_mesh);
    static mesh_output outs[INLINE_BATCH];
    static octree_status sts[INLINE_BATCH];
    double t0 = now();
    octree *t = build(&w->shape_mesh, 0, 0);
    double build_s = now() - t0;
    octree_free(t);
    t0 = now();
    for (size_t i = 0; i < INLINE_BATCH; i++)
        outs[i] = (mesh_output){0};
    octree_mesh_batch(w->world, &sv, w->mixed, INLINE_BATCH, 0, ACCURACY_EXACT, outs, sts, NULL);
    double batch_s = now() - t0;
    t0 = now();
    size_t single = 200;
    for (size_t i = 0; i < single; i++) {
        mesh_output out = {0};
        octree_mesh(w->world, &sv, &w->mixed[i], 0, ACCURACY_EXACT, &out, NULL);
    }
    double one_s = (now() - t0) / (double)single;
    t0 = now();
    for (size_t i = 0; i < single; i++) {
        mesh_output out = {0};
        octree_mesh_as_triangles(w->world, &sv, &w->mixed[i], 0, ACCURACY_EXACT, &out, NULL);
    }
    double old_s = (now() - t0) / (double)single;
    printf("inline shape: tree build %.2f ms; octree_mesh_batch of %d poses %.0f poses/s; octree_mesh one pose "
           "%.0f poses/s (per-triangle path %.0f poses/s)\n",
           1e3 * build_s, INLINE_BATCH, INLINE_BATCH / batch_s, 1.0 / one_s, 1.0 / old_s);
}

/* The peer bench's shape: the real Wuson, centred, scaled to 2% of the world's radius. */
static mesh_data peer_shape(const mesh_data *world)
{
    mesh_data base;
    char err[256];
    if (real_mesh_load(REAL_WUSON, 0, &base, NULL, NULL, err, sizeof err) != 0)
        fail(err);
    box3 wb = mesh_data_bounds(world), sb = mesh_data_bounds(&base);
    double scale = 0.02 * vec3_length(vec3_sub(wb.hi, wb.lo)) / vec3_length(vec3_sub(sb.hi, sb.lo));
    vec3 c = vec3_scale(vec3_add(sb.lo, sb.hi), 0.5);
    mesh_data m = meshgen_transformed(&base, scale, vec3_scale(c, -scale));
    mesh_data_free(&base);
    return m;
}

/* A real mesh subdivided up to 400,000 triangles, as the peer bench loads its worlds. */
static mesh_data subdivided(real_mesh which)
{
    mesh_data base, sub;
    int times;
    char err[256];
    if (real_mesh_load(which, 400000, &base, &sub, &times, err, sizeof err) != 0)
        fail(err);
    mesh_data_free(&base);
    return sub;
}

/* peer: the peer bench's worlds and shape instead of the link. */
static void make_world_for(workload *w, const char *which, int peer)
{
    memset(w, 0, sizeof *w);
    if (peer && strcmp(which, "wuson") == 0) {
        w->world_mesh = subdivided(REAL_WUSON);
        w->name = "Wuson.ply, subdivided";
    } else if (peer && strcmp(which, "icosphere") == 0) {
        w->world_mesh = meshgen_icosphere((vec3){0, 0, 0}, 1.0, 8);
        w->name = "icosphere (generated)";
    } else if (strcmp(which, "spider") == 0) {
        w->world_mesh = subdivided(REAL_SPIDER);
        w->name = "Spider_binary.stl, subdivided";
    } else if (strcmp(which, "terrain") == 0) {
        w->world_mesh = meshgen_terrain(11, (box3){{0, 0, 0}, {100, 100, 12}}, 256, 256);
        w->name = "terrain (generated)";
    } else {
        fail(peer ? "WORLD is spider, wuson or icosphere" : "WORLD is spider or terrain");
    }
    w->world = build(&w->world_mesh, 0, 1);
    box3 b = mesh_data_bounds(&w->world_mesh);
    vec3 e = vec3_sub(b.hi, b.lo);
    /* A link a tenth of the world across (an arm's link over a workcell). */
    w->shape_mesh = peer ? peer_shape(&w->world_mesh) : make_shape(0.1 * fmax(e.x, fmax(e.y, e.z)));
    w->shape = build(&w->shape_mesh, 0, 0);
    make_poses(w, 2026);
}

static void make_world(workload *w, const char *which) { make_world_for(w, which, 0); }

static void free_world(workload *w)
{
    octree_free(w->world);
    octree_free(w->shape);
    mesh_data_free(&w->world_mesh);
    mesh_data_free(&w->shape_mesh);
}

static int run_one(const char *world, const char *path, const char *which, double shape_resolution_factor,
                   int peer)
{
    static workload w;
    make_world_for(&w, world, peer);
    if (shape_resolution_factor != 1.0) {
        double d = w.shape->info.resolution * shape_resolution_factor;
        octree_free(w.shape);
        w.shape = build(&w.shape_mesh, d, 0);
    }
    int k = 0;
    while (k < PART_COUNT && strcmp(PART_KEYS[k], which) != 0)
        k++;
    int path_id = strcmp(path, "old") == 0 ? 0 : strcmp(path, "new") == 0 ? 1 : strcmp(path, "batch") == 0 ? 2 : -1;
    if (k == PART_COUNT || path_id < 0)
        fail("usage: bench_shapes one spider|terrain old|new|batch mixed|free|pairs [F]");
    pass p = run_pass(&w, w.shape, path_id, (part)k, ACCURACY_EXACT);
    double n = (double)p.poses;
    printf("%s %s %s: %.0f poses/s, %zu in contact, %.1f nodes, %.1f leaves, %.1f tests a pose\n", world, path,
           which, n / p.seconds, p.hits, (double)p.stats.nodes_visited / n, (double)p.stats.leaves_visited / n,
           (double)p.stats.candidates_tested / n);
    free_world(&w);
    return 0;
}

int main(int argc, char **argv)
{
    if ((argc == 5 || argc == 6) && strcmp(argv[1], "one") == 0)
        return run_one(argv[2], argv[3], argv[4], argc == 6 ? atof(argv[5]) : 1.0, 0);
    if (argc == 4 && strcmp(argv[1], "peer") == 0)
        return run_one(argv[2], "batch", argv[3], 1.0, 1);
    int rounds = argc > 1 ? atoi(argv[1]) : DEFAULT_ROUNDS;
    if (rounds < 1 || rounds > MAX_ROUNDS)
        fail("ROUNDS is 1 to 15");
    const char *worlds[] = {"spider", "terrain"};
    static workload w;
    for (size_t i = 0; i < 2; i++) {
        make_world(&w, worlds[i]);
        octree_info wi, si;
        octree_get_info(w.world, &wi);
        octree_get_info(w.shape, &si);
        printf("== world %s: %zu triangles, %zu nodes; shape %zu triangles, %zu nodes (%zu bytes); %d rounds, "
               "one thread\n",
               w.name, wi.triangle_count, wi.node_count, si.triangle_count, si.node_count, si.bytes_total, rounds);
        bench_parts(&w, rounds);
        bench_modes(&w);
        bench_shape_resolution(&w, rounds < 3 ? rounds : 3);
        bench_inline(&w);
        free_world(&w);
    }
    return 0;
}
