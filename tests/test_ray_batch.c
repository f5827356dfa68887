/* Batched rays on the cases where the walk's bound comparisons decide: hits exactly at
 * tmax, at tmin, on a zero-length interval, where the ray enters or leaves the world,
 * ties between triangles at equal t (coincident duplicates, shared edges and vertices
 * seen from one origin), rays ending on a node face. Each ray is answered alone
 * (octree_ray), in a batch from one origin (the packet walk of octree_batch.c), and in a
 * batch of scattered origins (the stream walk): the three must agree to the bit, and in
 * exact mode every answer must agree with the GMP oracle over every triangle (fast mode
 * on rays with no boundary contact, where its plain arithmetic on these dyadic inputs is
 * exact too; seed mode's epsilon moves the interval's ends, so it is only compared with
 * itself). */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "engine.h"
#include "support/brute_force.h"
#include "support/meshgen.h"
#include "support/oracle.h"
#include "support/oracle_mesh.h"

static uint64_t base_seed = 20260418;

/* ---------- the scene ---------- */

/* Layers of a 4 x 4 grid of unit cells, two triangles each, at dyadic coordinates in the
 * cube [0, 4]^3: its top face z = 4 and bottom face z = 0 (where rays enter and leave the
 * world), the root's split plane z = 2, the plane z = 3, and the walls x = 0 and x = 4. At
 * resolution 1 the world is exactly the cube and z = 2, 3, x = 1, 2, 3 are node faces. One
 * triangle of z = 3 is duplicated with a smaller id (first in the mesh) and one with a
 * larger id (last). */
typedef struct grid_scene {
    mesh_data mesh;
    size_t cap_v, cap_t;
} grid_scene;

static void add_tri(grid_scene *g, vec3 a, vec3 b, vec3 c)
{
    mesh_data *m = &g->mesh;
    if (m->vertex_count + 3 > g->cap_v) {
        g->cap_v = g->cap_v ? 2 * g->cap_v : 64;
        m->vertices = realloc(m->vertices, g->cap_v * sizeof *m->vertices);
    }
    if (3 * (m->triangle_count + 1) > g->cap_t) {
        g->cap_t = g->cap_t ? 2 * g->cap_t : 64;
        m->indices = realloc(m->indices, g->cap_t * sizeof *m->indices);
    }
    assert_true(m->vertices && m->indices);
    const vec3 v[3] = {a, b, c};
    for (int k = 0; k < 3; k++) {
        m->indices[3 * m->triangle_count + (size_t)k] = (uint32_t)m->vertex_count;
        m->vertices[m->vertex_count++] = v[k];
    }
    m->triangle_count++;
}

/* A point of the layer `axis` = c at in-plane coordinates (u, w). */
static vec3 layer_point(int axis, double c, double u, double w)
{
    return axis == 2 ? vec3_make(u, w, c) : vec3_make(c, u, w);
}

static void add_layer(grid_scene *g, int axis, double c)
{
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            vec3 a = layer_point(axis, c, i, j), b = layer_point(axis, c, i + 1, j),
                 d = layer_point(axis, c, i, j + 1), e = layer_point(axis, c, i + 1, j + 1);
            add_tri(g, a, b, d);
            add_tri(g, b, e, d);
        }
}

static grid_scene make_grid(void)
{
    grid_scene g = {0};
    /* The duplicate with the smaller id: the cell (1, 2) of z = 3, first half. */
    add_tri(&g, vec3_make(1, 2, 3), vec3_make(2, 2, 3), vec3_make(1, 3, 3));
    add_layer(&g, 2, 4.0);
    add_layer(&g, 2, 3.0);
    add_layer(&g, 2, 2.0);
    add_layer(&g, 2, 0.0);
    add_layer(&g, 0, 0.0);
    add_layer(&g, 0, 4.0);
    /* ... and the one with the larger id: the cell (2, 1) of z = 3, second half. */
    add_tri(&g, vec3_make(3, 1, 3), vec3_make(3, 2, 3), vec3_make(2, 2, 3));
    return g;
}

/* ---------- the rays ---------- */

enum ray_case {
    AT_TMAX_ENTERING,  /* t = tmax = 1 on the top face, where the ray enters the world */
    AT_TMIN_LEAVING,   /* t = tmin = 1 on the bottom face, where it leaves the world */
    ZERO_LENGTH,       /* tmin = tmax = t on an inner node face (z = 2) */
    ENDING_ON_FACE,    /* tmax = t on the node face z = 2, after two layers */
    STARTING_ON_FACE,  /* tmin = t on the node face z = 2, before the bottom */
    WALL_AT_TMAX,      /* along -x onto the wall x = 4 with tmax = t */
    WALL_AT_TMIN,      /* along -x leaving through the wall x = 0 with tmin = t */
    ONTO_DUPLICATES,   /* through a duplicated triangle: a tie at equal t */
    IN_WORLD_FACE,     /* lying in the world's bottom face (z = 0, no z motion) */
    GRAZING_WORLD,     /* touching the world's box only along its top edge y = 4 */
    CASE_COUNT
};
static const char *const CASE_NAMES[CASE_COUNT] = {
    "hit at tmax where the ray enters the world", "hit at tmin where the ray leaves the world",
    "zero-length interval on a node face",        "ending on a node face",
    "starting on a node face",                    "onto a wall with tmax at the hit",
    "leaving through a wall with tmin at the hit", "through coincident duplicates",
    "lying in the world's bottom face",           "touching the world's box only at its edge"};

typedef struct ray_set {
    ray_input rays[1024];
    unsigned char kind[1024];
    size_t count;
} ray_set;

static void push(ray_set *s, int kind, vec3 o, vec3 d, double tmin, double tmax)
{
    assert_true(s->count < sizeof s->rays / sizeof s->rays[0]);
    s->rays[s->count] = (ray_input){o, d, tmin, tmax, RAY_CROSSING};
    s->kind[s->count++] = (unsigned char)kind;
}

/* A dyadic in-plane coordinate: a cell interior, a grid line or a grid vertex. */
static double dyadic(rng *r)
{
    static const double steps[] = {0.0, 0.25, 0.5, 0.75, 1.0};
    return (double)(rng_next(r) % 4) + steps[rng_next(r) % 5];
}

/* The rays of every case from origin o above the top (for the z cases) or beside the wall
 * x = 4 (for the x cases): every direction is target - o, exact, so each case's t is 1 on
 * its target layer exactly. */
static void add_cases(ray_set *s, rng *r, vec3 above, vec3 beside, int per_case)
{
    for (int k = 0; k < per_case; k++) {
        double u = dyadic(r), w = dyadic(r);
        vec3 top = {u, w, 4}, mid = {u, w, 2}, bottom = {u, w, 0};
        push(s, AT_TMAX_ENTERING, above, vec3_sub(top, above), 0.0, 1.0);
        push(s, AT_TMIN_LEAVING, above, vec3_sub(bottom, above), 1.0, INFINITY);
        push(s, ZERO_LENGTH, above, vec3_sub(mid, above), 1.0, 1.0);
        push(s, ENDING_ON_FACE, above, vec3_sub(mid, above), 0.0, 1.0);
        push(s, STARTING_ON_FACE, above, vec3_sub(mid, above), 1.0, INFINITY);
        vec3 wall = {4, u, w}, far_wall = {0, u, w};
        push(s, WALL_AT_TMAX, beside, vec3_sub(wall, beside), 0.0, 1.0);
        push(s, WALL_AT_TMIN, beside, vec3_sub(far_wall, beside), 1.0, INFINITY);
        /* Inside the duplicated triangles (their cells' lower-left halves, off the
         * diagonal and the grid lines). */
        double du = 0.125 + 0.25 * (double)(rng_next(r) % 2), dw = 0.125 + 0.25 * (double)(rng_next(r) % 2);
        vec3 dup = (k & 1) ? vec3_make(1 + du, 2 + dw, 3) : vec3_make(3 - du, 1 + dw, 3);
        push(s, ONTO_DUPLICATES, above, vec3_sub(dup, above), 0.0, (k & 2) ? 1.0 : INFINITY);
        /* Boundary contacts on the world's own faces, which only the engine's crossing rule
         * decides: compared with brute force over the same predicates (the walk must not
         * lose them) rather than with the oracle. */
        vec3 floor_o = {beside.x, u, 0.0};
        push(s, IN_WORLD_FACE, floor_o, vec3_make(-1.0, 0.25 * (double)(k % 3), 0.0), 0.0, INFINITY);
        vec3 edge_o = {u, 3.0, 5.0};
        push(s, GRAZING_WORLD, edge_o, vec3_make(0.0, 1.0, -1.0), 0.0, INFINITY);
    }
}

/* ---------- answering three ways ---------- */

enum { HIT_CAP = 16 };

typedef struct answers {
    octree_status st[1024];
    ray_output out[1024];
    ray_hit hits[1024][HIT_CAP];
} answers;

static void reset(answers *a, size_t n)
{
    memset(a->hits, 0x5a, n * sizeof a->hits[0]);
    for (size_t i = 0; i < n; i++) {
        a->out[i] = (ray_output){.hits = a->hits[i], .max_hits = HIT_CAP};
        a->st[i] = (octree_status)99;
    }
}

static uint64_t bits_of(double x)
{
    uint64_t b;
    memcpy(&b, &x, sizeof b);
    return b;
}

static int same_hits(const ray_output *a, const ray_output *b)
{
    if (a->hit_count != b->hit_count || a->truncated != b->truncated)
        return 0;
    size_t n = a->hit_count < HIT_CAP ? a->hit_count : HIT_CAP;
    for (size_t k = 0; k < n; k++)
        if (a->hits[k].triangle != b->hits[k].triangle || bits_of(a->hits[k].t) != bits_of(b->hits[k].t) ||
            bits_of(a->hits[k].u) != bits_of(b->hits[k].u) || bits_of(a->hits[k].v) != bits_of(b->hits[k].v))
            return 0;
    return 1;
}

typedef struct tally {
    size_t rays, clean, hits_at_tmax, hits_at_tmin, zero_length_hits, duplicate_ties, boundary;
} tally;

static void describe(const ray_input *r, const char *kind)
{
    printf("      ray (%s): o (%a, %a, %a) d (%a, %a, %a) t [%a, %a]\n", kind, r->origin.x, r->origin.y, r->origin.z,
           r->direction.x, r->direction.y, r->direction.z, r->tmin, r->tmax);
}

/* Answers the set alone, as one batch (packets when the set shares its origin) and as
 * a batch interleaved with `mix` (scattered origins: the stream), then compares. Returns
 * the number of wrong answers, each printed. */
static size_t check_set(const octree *t, const oracle_mesh *om, const ray_set *s, const ray_set *mix,
                        ray_detail detail, accuracy_mode mode, tally *ty)
{
    static answers single, packet, stream;
    static ray_input mixed[2048];
    reset(&single, s->count);
    reset(&packet, s->count);
    size_t nm = 0;
    for (size_t i = 0; i < s->count; i++) {
        mixed[nm++] = s->rays[i];
        mixed[nm++] = mix->rays[i % mix->count];
    }
    reset(&stream, nm);
    for (size_t i = 0; i < s->count; i++)
        single.st[i] = octree_ray(t, &s->rays[i], detail, mode, &single.out[i], NULL);
    /* One batch per origin: octree_ray_batch walks packets only when every ray of the
     * batch shares its origin. */
    static ray_input group[1024];
    static ray_output group_out[1024];
    static octree_status group_st[1024];
    static size_t group_of[1024];
    static unsigned char batched[1024];
    memset(batched, 0, s->count);
    for (size_t first = 0; first < s->count; first++) {
        if (batched[first])
            continue;
        size_t n = 0;
        for (size_t i = first; i < s->count; i++)
            if (!batched[i] && vec3_equal(s->rays[i].origin, s->rays[first].origin)) {
                group[n] = s->rays[i];
                group_out[n] = packet.out[i];
                group_of[n++] = i;
                batched[i] = 1;
            }
        assert_int_equal(octree_ray_batch(t, group, n, detail, mode, group_out, group_st, NULL), OCTREE_OK);
        for (size_t k = 0; k < n; k++) {
            packet.out[group_of[k]] = group_out[k];
            packet.st[group_of[k]] = group_st[k];
        }
    }
    assert_int_equal(octree_ray_batch(t, mixed, nm, detail, mode, stream.out, stream.st, NULL), OCTREE_OK);
    size_t wrong = 0;
    for (size_t i = 0; i < s->count; i++) {
        const ray_input *ray = &s->rays[i];
        const char *kind = CASE_NAMES[s->kind[i]];
        assert_int_equal(single.st[i], OCTREE_OK);
        const char *differs = packet.st[i] != OCTREE_OK || !same_hits(&packet.out[i], &single.out[i]) ? "one-origin batch"
                              : stream.st[2 * i] != OCTREE_OK || !same_hits(&stream.out[2 * i], &single.out[i])
                                  ? "scattered batch"
                                  : NULL;
        if (differs) {
            if (wrong++ < 8) {
                printf("    WRONG mode %d detail %d: ray %zu, %s answers %zu hits, alone %zu\n", mode, detail, i,
                       differs, differs[0] == 'o' ? packet.out[i].hit_count : stream.out[2 * i].hit_count,
                       single.out[i].hit_count);
                describe(ray, kind);
            }
            continue;
        }
        oracle_ray_truth truth;
        assert_int_equal(oracle_mesh_ray(om, ray, &truth), 0);
        const ray_output *o = &single.out[i];
        ty->rays++;
        ty->clean += truth.boundary == 0;
        ty->boundary += truth.boundary > 0;
        /* Seed mode's epsilon moves the interval's ends, so only its batches are compared. */
        if (mode == ACCURACY_EXACT || (mode == ACCURACY_FAST && truth.boundary == 0)) {
            char why[256];
            if (!oracle_ray_answer_ok(om, ray, &truth, detail, o->hits, o->hit_count, why, sizeof why)) {
                if (wrong++ < 8) {
                    printf("    WRONG mode %d detail %d: ray %zu against the oracle: %s\n", mode, detail, i, why);
                    describe(ray, kind);
                }
            }
        }
        /* The walk loses nothing the same predicate finds over every triangle. */
        if (mode != ACCURACY_SEED) {
            ray_hit want[HIT_CAP];
            size_t nw = brute_ray(&om->mesh, ray, detail, mode, 0.0, want, HIT_CAP);
            int same = detail == RAY_ANY ? (nw > 0) == (o->hit_count > 0) : nw == o->hit_count;
            for (size_t k = 0; same && detail != RAY_ANY && k < nw && k < HIT_CAP; k++)
                same = want[k].triangle == o->hits[k].triangle && bits_of(want[k].t) == bits_of(o->hits[k].t);
            if (!same && wrong++ < 8) {
                printf("    WRONG mode %d detail %d: ray %zu: %zu hits (first on %d), brute force %zu (first on %d)\n",
                       mode, detail, i, o->hit_count, o->hit_count ? (int)o->hits[0].triangle : -1, nw,
                       nw ? (int)want[0].triangle : -1);
                describe(ray, kind);
            }
        }
        /* What each case is for happened: the hit at exactly the interval's end. */
        if (o->hit_count > 0 && detail == RAY_CLOSEST) {
            double th = o->hits[0].t;
            ty->hits_at_tmax += th == ray->tmax;
            ty->hits_at_tmin += th == ray->tmin && ray->tmin > 0;
            ty->zero_length_hits += s->kind[i] == ZERO_LENGTH;
            ty->duplicate_ties += s->kind[i] == ONTO_DUPLICATES && truth.count >= 2 && truth.boundary == 0;
        }
        oracle_ray_truth_free(&truth);
    }
    return wrong;
}

static void run_all(double resolution, const char *label)
{
    grid_scene g = make_grid();
    mesh_view v = mesh_data_view(&g.mesh);
    octree_def def = octree_default_def();
    def.resolution = resolution;
    octree_error err;
    oracle_mesh om;
    assert_int_equal(oracle_mesh_init(&om, &v), 0);
    rng r = rng_seeded(base_seed + (uint64_t)(resolution * 1024));
    static ray_set one, other;
    one.count = other.count = 0;
    add_cases(&one, &r, vec3_make(1.25, 1.75, 5.0), vec3_make(5.0, 1.75, 2.25), 40);
    add_cases(&other, &r, vec3_make(2.5, 0.75, 5.0), vec3_make(5.0, 2.5, 0.75), 40);
    const accuracy_mode modes[] = {ACCURACY_EXACT, ACCURACY_FAST, ACCURACY_SEED};
    size_t wrong = 0;
    for (size_t m = 0; m < 3; m++) {
        def.mode = modes[m];
        octree *t = octree_build(&v, &def, &err);
        if (!t)
            fail_msg("%s: build failed: %s", label, err.message);
        tally ty = {0};
        for (int detail = RAY_ANY; detail <= RAY_ALL; detail++)
            wrong += check_set(t, &om, &one, &other, (ray_detail)detail, modes[m], &ty);
        printf("  %s, %s: %zu ray answers (%zu without boundary contact, %zu with); closest hits at tmax %zu, at tmin "
               "%zu, on zero-length intervals %zu, duplicate ties %zu\n",
               label, accuracy_mode_name(modes[m]), ty.rays, ty.clean, ty.boundary, ty.hits_at_tmax, ty.hits_at_tmin,
               ty.zero_length_hits, ty.duplicate_ties);
        /* Exact and fast alike find the hits the cases aim at (counted where all three ways
         * agreed); every mode runs before the test fails, so each one's failures show. */
        if (modes[m] != ACCURACY_SEED && !(ty.hits_at_tmax > 0 && ty.hits_at_tmin > 0 && ty.zero_length_hits > 0 &&
                                          ty.duplicate_ties > 0 && ty.clean > 0 && ty.boundary > 0)) {
            printf("    WRONG %s: a case that should hit found nothing where all three ways agreed\n",
                   accuracy_mode_name(modes[m]));
            wrong++;
        }
        octree_free(t);
    }
    oracle_mesh_free(&om);
    mesh_data_free(&g.mesh);
    if (wrong)
        fail_msg("%s: %zu wrong ray answers", label, wrong);
}

/* At resolution 1 the world is exactly [0, 4]^3, its faces are the top and bottom layers
 * and the walls, and the inner layers lie on node faces. */
static void test_batched_rays_at_interval_ends_on_node_faces(void **state)
{
    (void)state;
    run_all(1.0, "resolution 1");
}

/* Finer: the inner layers at z = 2 and z = 3 are still node faces, and z = 2 is one of
 * several levels. */
static void test_batched_rays_at_interval_ends_finer(void **state)
{
    (void)state;
    run_all(0.25, "resolution 1/4");
}

/* Coarser than the grid: one level, leaves of side 2 hold many triangles. */
static void test_batched_rays_at_interval_ends_coarse(void **state)
{
    (void)state;
    run_all(2.0, "resolution 2");
}

/* Rays from one origin through the grid's shared edges and vertices, and through
 * coincident duplicates: every tie at equal t, decided alike alone and in either batch,
 * and (exact) crossing each closed layer exactly once where it is crossed at all. */
static void test_batched_ties_from_one_origin(void **state)
{
    (void)state;
    grid_scene g = make_grid();
    mesh_view v = mesh_data_view(&g.mesh);
    oracle_mesh om;
    assert_int_equal(oracle_mesh_init(&om, &v), 0);
    octree_def def = octree_default_def();
    def.resolution = 1.0;
    octree *t = octree_build(&v, &def, NULL);
    assert_non_null(t);
    static ray_set ties, other;
    ties.count = other.count = 0;
    vec3 eye = {1.0, 2.0, 12.0};
    for (int i = 1; i <= 7; i++)
        for (int j = 1; j <= 7; j++) {
            /* Every grid vertex and edge midpoint of the top layer, and beyond to the bottom. */
            vec3 target = {0.5 * i, 0.5 * j, 4.0};
            push(&ties, ONTO_DUPLICATES, eye, vec3_sub(target, eye), 0.0, INFINITY);
        }
    rng r = rng_seeded(base_seed + 99);
    add_cases(&other, &r, vec3_make(2.5, 0.75, 5.0), vec3_make(5.0, 2.5, 0.75), 4);
    tally ty = {0};
    size_t wrong = 0;
    for (int detail = RAY_ANY; detail <= RAY_ALL; detail++)
        wrong += check_set(t, &om, &ties, &other, (ray_detail)detail, ACCURACY_EXACT, &ty);
    /* Each layer crossed once: a ray through a shared edge or vertex of the top layer that
     * stays inside the walls crosses the four horizontal layers (the duplicates, identical
     * to their layer's triangles, are crossed with them and not counted). */
    ray_hit hits[HIT_CAP];
    size_t through = 0;
    const uint32_t last = (uint32_t)g.mesh.triangle_count - 1;
    for (size_t i = 0; i < ties.count; i++) {
        ray_output out = {.hits = hits, .max_hits = HIT_CAP};
        assert_int_equal(octree_ray(t, &ties.rays[i], RAY_ALL, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
        vec3 end = vec3_add(ties.rays[i].origin, vec3_scale(ties.rays[i].direction, 1.5)); /* z = 0 at t = 1.5 */
        if (!(end.x > 0 && end.x < 4 && end.y > 0 && end.y < 4))
            continue;
        through++;
        size_t layers = 0;
        for (size_t k = 0; k < out.hit_count && k < HIT_CAP; k++)
            layers += hits[k].triangle != 0 && hits[k].triangle != last;
        if (layers != 4 || out.truncated)
            fail_msg("ray %zu toward (%g, %g, 4) crosses %zu layers, not 4", i, ties.rays[i].direction.x + eye.x,
                     ties.rays[i].direction.y + eye.y, layers);
    }
    printf("  ties from one origin: %zu ray answers, %zu with boundary contacts; %zu rays through all four layers\n",
           ty.rays, ty.boundary, through);
    assert_true(ty.boundary > 0 && through > 0);
    octree_free(t);
    oracle_mesh_free(&om);
    mesh_data_free(&g.mesh);
    if (wrong)
        fail_msg("%zu wrong ray answers", wrong);
}

int main(void)
{
    const char *env = getenv("TRIOCT_SEED");
    if (env)
        base_seed = strtoull(env, NULL, 10);
    printf("test_ray_batch: seed %llu (set TRIOCT_SEED to rerun with another)\n", (unsigned long long)base_seed);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_batched_rays_at_interval_ends_on_node_faces),
        cmocka_unit_test(test_batched_rays_at_interval_ends_finer),
        cmocka_unit_test(test_batched_rays_at_interval_ends_coarse),
        cmocka_unit_test(test_batched_ties_from_one_origin),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
