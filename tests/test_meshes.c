/* Tests for the mesh generators (closedness, orientation, counts, determinism) and for the
 * assimp loader (real test models, broken files, NaN refusal, degenerate/duplicate counts). */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <dirent.h>
#include <pthread.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <sys/stat.h>
#include <unistd.h>

#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include "geom/vec3.h"
#include "support/meshgen.h"
#include "world/mesh_data.h"
#include "world/mesh_load.h"

#define MODELS "/usr/share/assimp/models"

/* A sanitizer's operator new aborts on a failed allocation instead of throwing, so a file
 * that makes assimp ask for gigabytes cannot be shown to fail cleanly under one. */
#if defined(__SANITIZE_ADDRESS__)
#define UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define UNDER_ASAN 1
#endif
#endif
#ifndef UNDER_ASAN
#define UNDER_ASAN 0
#endif

static const double pi = 3.14159265358979323846;

/* ---------- helpers ---------- */

/* The seed of the randomised tests: fixed, or TRIOCT_SEED to rerun another. */
static uint64_t test_seed(void)
{
    const char *env = getenv("TRIOCT_SEED");
    return env ? strtoull(env, NULL, 0) : 0x5eed2024ull;
}

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Sum of a . (b x c) / 6: the enclosed volume, positive when the normals point out. */
static double signed_volume(const mesh_data *m)
{
    double sum = 0.0;
    for (size_t t = 0; t < m->triangle_count; t++)
        sum += vec3_dot(mesh_data_corner(m, t, 0), vec3_cross(mesh_data_corner(m, t, 1), mesh_data_corner(m, t, 2)));
    return sum / 6.0;
}

static double surface_area(const mesh_data *m)
{
    double sum = 0.0;
    for (size_t t = 0; t < m->triangle_count; t++) {
        vec3 a = mesh_data_corner(m, t, 0);
        sum += 0.5 * vec3_length(vec3_cross(vec3_sub(mesh_data_corner(m, t, 1), a), vec3_sub(mesh_data_corner(m, t, 2), a)));
    }
    return sum;
}

static int compare_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Directed edges a->b as (a << 32 | b), sorted. */
static uint64_t *sorted_directed_edges(const mesh_data *m)
{
    size_t n = 3 * m->triangle_count;
    uint64_t *edges = malloc((n ? n : 1) * sizeof *edges);
    assert_non_null(edges);
    for (size_t t = 0; t < m->triangle_count; t++)
        for (int k = 0; k < 3; k++) {
            uint64_t a = m->indices[3 * t + (size_t)k], b = m->indices[3 * t + (size_t)(k + 1) % 3];
            edges[3 * t + (size_t)k] = a << 32 | b;
        }
    qsort(edges, n, sizeof *edges, compare_u64);
    return edges;
}

static size_t count_edge(const uint64_t *edges, size_t n, uint64_t edge)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (edges[mid] < edge)
            lo = mid + 1;
        else
            hi = mid;
    }
    size_t count = 0;
    while (lo + count < n && edges[lo + count] == edge)
        count++;
    return count;
}

/* Every directed edge appears exactly once and its reverse exactly once: the surface is
 * closed, two-manifold at edges, and consistently oriented. */
static void assert_closed_and_oriented(const mesh_data *m)
{
    size_t n = 3 * m->triangle_count;
    uint64_t *edges = sorted_directed_edges(m);
    for (size_t i = 0; i < n; i++) {
        uint64_t a = edges[i] >> 32, b = edges[i] & 0xffffffffu;
        assert_int_not_equal(a, b);
        if (i + 1 < n)
            assert_true(edges[i + 1] != edges[i]); /* once in this direction */
        assert_int_equal(count_edge(edges, n, b << 32 | a), 1); /* once in the other */
    }
    free(edges);
}

/* Every directed edge is matched by as many reverse uses (closed, consistently oriented,
 * but edges may be shared by more than two triangles, as between touching blocks). */
static void assert_balanced_edges(const mesh_data *m)
{
    size_t n = 3 * m->triangle_count;
    uint64_t *edges = sorted_directed_edges(m);
    for (size_t i = 0; i < n;) {
        size_t run = count_edge(edges, n, edges[i]);
        uint64_t a = edges[i] >> 32, b = edges[i] & 0xffffffffu;
        assert_int_equal(count_edge(edges, n, b << 32 | a), run);
        i += run;
    }
    free(edges);
}

static void assert_indices_valid(const mesh_data *m)
{
    for (size_t i = 0; i < 3 * m->triangle_count; i++)
        assert_true(m->indices[i] < m->vertex_count);
}

static void assert_same_bytes(const mesh_data *a, const mesh_data *b)
{
    assert_int_equal(a->vertex_count, b->vertex_count);
    assert_int_equal(a->triangle_count, b->triangle_count);
    assert_memory_equal(a->vertices, b->vertices, a->vertex_count * sizeof *a->vertices);
    assert_memory_equal(a->indices, b->indices, 3 * a->triangle_count * sizeof *a->indices);
}

static int same_bytes(const mesh_data *a, const mesh_data *b)
{
    return a->vertex_count == b->vertex_count && a->triangle_count == b->triangle_count &&
           memcmp(a->vertices, b->vertices, a->vertex_count * sizeof *a->vertices) == 0 &&
           memcmp(a->indices, b->indices, 3 * a->triangle_count * sizeof *a->indices) == 0;
}

static void assert_in_box(vec3 p, box3 box)
{
    assert_true(p.x >= box.lo.x && p.x <= box.hi.x);
    assert_true(p.y >= box.lo.y && p.y <= box.hi.y);
    assert_true(p.z >= box.lo.z && p.z <= box.hi.z);
}

/* ---------- RNG ---------- */

static void test_rng_matches_splitmix64_reference(void **state)
{
    (void)state;
    /* The published splitmix64 sequence for seed 0. */
    rng r = rng_seeded(0);
    assert_true(rng_next(&r) == 0xe220a8397b1dcdafull);
    assert_true(rng_next(&r) == 0x6e789e6aa1b965f4ull);
    assert_true(rng_next(&r) == 0x06c45d188009454full);

    r = rng_seeded(test_seed());
    box3 box = {{-1, 2, 3}, {1, 2.5, 7}};
    for (int i = 0; i < 10000; i++) {
        double u = rng_uniform(&r, -3.0, 5.0);
        assert_true(u >= -3.0 && u < 5.0);
        vec3 p = rng_point_in_box(&r, box);
        assert_true(p.x >= -1 && p.x < 1 && p.y >= 2 && p.y < 2.5 && p.z >= 3 && p.z < 7);
        double len = vec3_length(rng_unit_vector(&r));
        assert_true(fabs(len - 1.0) < 1e-14);
    }
    assert_true(rng_uniform(&r, 4.0, 4.0) == 4.0);
}

/* ---------- closed generators ---------- */

static void test_tetrahedron_outward_whatever_the_order(void **state)
{
    (void)state;
    vec3 a = {0, 0, 0}, b = {1, 0, 0}, c = {0, 1, 0}, d = {0, 0, 1};
    mesh_data m1 = meshgen_tetrahedron(a, b, c, d);
    mesh_data m2 = meshgen_tetrahedron(a, c, b, d);
    assert_int_equal(m1.triangle_count, 4);
    assert_int_equal(m2.triangle_count, 4);
    assert_closed_and_oriented(&m1);
    assert_closed_and_oriented(&m2);
    assert_true(signed_volume(&m1) == 1.0 / 6.0);
    assert_true(signed_volume(&m2) == 1.0 / 6.0);
    mesh_data_free(&m1);
    mesh_data_free(&m2);
}

static void test_box_has_twelve_outward_triangles_and_exact_volume(void **state)
{
    (void)state;
    box3 box = {{1, -2, 0.25}, {3, 0.5, 4}};
    mesh_data m = meshgen_box(box);
    assert_int_equal(m.triangle_count, 12);
    assert_int_equal(m.vertex_count, 8);
    assert_indices_valid(&m);
    assert_closed_and_oriented(&m);
    /* Dyadic coordinates: every product and sum is exact. */
    assert_true(signed_volume(&m) == 2.0 * 2.5 * 3.75);
    vec3 centre = vec3_scale(vec3_add(box.lo, box.hi), 0.5);
    for (size_t t = 0; t < 12; t++) {
        vec3 a = mesh_data_corner(&m, t, 0);
        vec3 n = vec3_cross(vec3_sub(mesh_data_corner(&m, t, 1), a), vec3_sub(mesh_data_corner(&m, t, 2), a));
        /* Axis-aligned and pointing away from the centre. */
        int nonzero = (n.x != 0) + (n.y != 0) + (n.z != 0);
        assert_int_equal(nonzero, 1);
        assert_true(vec3_dot(n, vec3_sub(a, centre)) > 0.0);
    }
    mesh_data_free(&m);
}

static void test_icosphere_counts_closed_and_volume(void **state)
{
    (void)state;
    vec3 centre = {1.5, -2, 0.5};
    double radius = 3.0;
    double sphere_volume = 4.0 / 3.0 * pi * radius * radius * radius;
    double previous_error = INFINITY;
    for (int s = 0; s <= 4; s++) {
        mesh_data m = meshgen_icosphere(centre, radius, s);
        size_t faces = (size_t)20 << (2 * s);
        assert_int_equal(m.triangle_count, faces);
        assert_int_equal(m.vertex_count, faces / 2 + 2); /* Euler: V = F/2 + 2, so shared */
        assert_indices_valid(&m);
        assert_closed_and_oriented(&m);
        for (size_t v = 0; v < m.vertex_count; v++)
            assert_true(fabs(vec3_length(vec3_sub(m.vertices[v], centre)) - radius) < 1e-13 * radius);
        /* Inscribed, so below the sphere's volume, positive only when the normals point out,
         * and converging about fourfold per level. */
        double volume = signed_volume(&m);
        assert_true(volume > 0.0 && volume < sphere_volume);
        double error = (sphere_volume - volume) / sphere_volume;
        assert_true(error < previous_error / 3.0);
        previous_error = error;
        mesh_data_free(&m);
    }
    assert_true(previous_error < 0.005);
}

static void test_icosphere_six_subdivisions_is_fast(void **state)
{
    (void)state;
    double start = now_seconds();
    mesh_data m = meshgen_icosphere((vec3){0, 0, 0}, 1.0, 6);
    double seconds = now_seconds() - start;
    printf("test_meshes: icosphere(6) %zu triangles in %.3f s\n", m.triangle_count, seconds);
    assert_int_equal(m.triangle_count, 81920);
    assert_int_equal(m.vertex_count, 40962);
    assert_closed_and_oriented(&m);
    assert_true(seconds < 1.0);
    mesh_data_free(&m);
}

static void test_torus_counts_closed_and_volume(void **state)
{
    (void)state;
    double major = 3.0, minor = 1.0;
    mesh_data m = meshgen_torus((vec3){5, 6, 7}, major, minor, 96, 48);
    assert_int_equal(m.triangle_count, 2 * 96 * 48);
    assert_int_equal(m.vertex_count, 96 * 48); /* seams shared: genus 1, V - E + F = 0 */
    assert_indices_valid(&m);
    assert_closed_and_oriented(&m);
    double expected = 2.0 * pi * pi * major * minor * minor;
    double volume = signed_volume(&m);
    assert_true(volume > 0.0);
    assert_true(fabs(volume - expected) < 0.01 * expected);
    mesh_data_free(&m);
}

/* ---------- open surfaces and scenes ---------- */

static void test_terrain_grid_faces_up_and_is_deterministic(void **state)
{
    (void)state;
    uint64_t seed = test_seed();
    box3 region = {{-10, 0, -1}, {30, 20, 4}};
    int nx = 40, ny = 25;
    mesh_data m = meshgen_terrain(seed, region, nx, ny);
    assert_int_equal(m.triangle_count, 2 * nx * ny);
    assert_int_equal(m.vertex_count, (nx + 1) * (ny + 1));
    assert_indices_valid(&m);
    double z_min = INFINITY, z_max = -INFINITY;
    for (size_t v = 0; v < m.vertex_count; v++) {
        assert_in_box(m.vertices[v], region);
        z_min = fmin(z_min, m.vertices[v].z);
        z_max = fmax(z_max, m.vertices[v].z);
    }
    assert_true(z_max - z_min > 0.1); /* the bumps are there */
    for (size_t t = 0; t < m.triangle_count; t++) {
        vec3 a = mesh_data_corner(&m, t, 0);
        vec3 n = vec3_cross(vec3_sub(mesh_data_corner(&m, t, 1), a), vec3_sub(mesh_data_corner(&m, t, 2), a));
        assert_true(n.z > 0.0);
    }
    /* Interior edges used once each way, boundary edges once: an oriented open sheet. */
    size_t n = 3 * m.triangle_count, boundary = 0;
    uint64_t *edges = sorted_directed_edges(&m);
    for (size_t i = 0; i < n; i++) {
        if (i + 1 < n)
            assert_true(edges[i + 1] != edges[i]);
        uint64_t a = edges[i] >> 32, b = edges[i] & 0xffffffffu;
        boundary += count_edge(edges, n, b << 32 | a) == 0;
    }
    free(edges);
    assert_int_equal(boundary, 2 * (nx + ny));
    /* Grid ends land exactly on the region. */
    assert_true(m.vertices[0].x == -10 && m.vertices[0].y == 0);
    assert_true(m.vertices[m.vertex_count - 1].x == 30 && m.vertices[m.vertex_count - 1].y == 20);

    mesh_data again = meshgen_terrain(seed, region, nx, ny);
    mesh_data other = meshgen_terrain(seed + 1, region, nx, ny);
    assert_same_bytes(&m, &again);
    assert_false(same_bytes(&m, &other));
    mesh_data_free(&m);
    mesh_data_free(&again);
    mesh_data_free(&other);
}

static void test_soup_triangles_sized_inside_region_and_deterministic(void **state)
{
    (void)state;
    uint64_t seed = test_seed();
    box3 region = {{0, 0, 0}, {100, 50, 25}};
    double size = 2.0;
    size_t n = 5000;
    mesh_data m = meshgen_soup(seed, n, region, size);
    assert_int_equal(m.triangle_count, n);
    assert_int_equal(m.vertex_count, 3 * n);
    assert_indices_valid(&m);
    vec3 normal_sum = {0, 0, 0};
    for (size_t t = 0; t < n; t++) {
        for (int k = 0; k < 3; k++) {
            assert_int_equal(m.indices[3 * t + (size_t)k], 3 * t + (size_t)k); /* independent */
            assert_in_box(mesh_data_corner(&m, t, k), region);
            double edge = vec3_length(vec3_sub(mesh_data_corner(&m, t, k), mesh_data_corner(&m, t, (k + 1) % 3)));
            assert_true(edge <= size * (1 + 1e-12));
        }
        vec3 a = mesh_data_corner(&m, t, 0);
        vec3 nrm = vec3_cross(vec3_sub(mesh_data_corner(&m, t, 1), a), vec3_sub(mesh_data_corner(&m, t, 2), a));
        normal_sum = vec3_add(normal_sum, vec3_normalize(nrm));
    }
    /* Random orientation: unit normals nearly cancel (a fixed winding would sum to ~n). */
    assert_true(vec3_length(normal_sum) < 0.1 * (double)n);
    mesh_data again = meshgen_soup(seed, n, region, size);
    mesh_data other = meshgen_soup(seed ^ 0x1234, n, region, size);
    assert_same_bytes(&m, &again);
    assert_false(same_bytes(&m, &other));
    mesh_data_free(&m);
    mesh_data_free(&again);
    mesh_data_free(&other);
}

static void test_blocks_on_grid_touching_and_deterministic(void **state)
{
    (void)state;
    uint64_t seed = test_seed();
    int nx = 4, ny = 3, nz = 5;
    double cell = 0.25;
    mesh_data m = meshgen_blocks(seed, nx, ny, nz, cell);
    size_t blocks = m.triangle_count / 12;
    assert_int_equal(m.triangle_count, 12 * blocks);
    assert_int_equal(m.vertex_count, 8 * blocks);
    assert_true(blocks > 0 && blocks < (size_t)(nx * ny * nz)); /* some omitted */
    assert_indices_valid(&m);
    assert_balanced_edges(&m);
    assert_true(signed_volume(&m) == (double)blocks * cell * cell * cell);

    box3 *boxes = malloc(blocks * sizeof *boxes);
    assert_non_null(boxes);
    for (size_t b = 0; b < blocks; b++) {
        box3 box = {m.vertices[8 * b], m.vertices[8 * b]};
        for (int k = 1; k < 8; k++) {
            box.lo = vec3_min(box.lo, m.vertices[8 * b + (size_t)k]);
            box.hi = vec3_max(box.hi, m.vertices[8 * b + (size_t)k]);
        }
        assert_true(box.hi.x - box.lo.x == cell && box.hi.y - box.lo.y == cell &&
                    box.hi.z - box.lo.z == cell);
        for (int axis = 0; axis < 3; axis++) {
            double q = vec3_get(box.lo, axis) / cell;
            assert_true(q == floor(q) && q >= 0);
        }
        for (size_t t = 12 * b; t < 12 * b + 12; t++) /* each box owns its triangles */
            for (int k = 0; k < 3; k++)
                assert_true(m.indices[3 * t + (size_t)k] / 8 == b);
        boxes[b] = box;
    }
    /* Coplanar contacts: neighbouring blocks share a face plane bit for bit. */
    size_t contacts = 0;
    for (size_t i = 0; i < blocks; i++)
        for (size_t j = 0; j < blocks; j++)
            for (int axis = 0; axis < 3; axis++) {
                int other1 = (axis + 1) % 3, other2 = (axis + 2) % 3;
                contacts += vec3_get(boxes[i].hi, axis) == vec3_get(boxes[j].lo, axis) &&
                            vec3_get(boxes[i].lo, other1) == vec3_get(boxes[j].lo, other1) &&
                            vec3_get(boxes[i].lo, other2) == vec3_get(boxes[j].lo, other2);
            }
    printf("test_meshes: blocks %zu of %d, %zu face contacts\n", blocks, nx * ny * nz, contacts);
    assert_true(contacts > 0);
    free(boxes);

    mesh_data again = meshgen_blocks(seed, nx, ny, nz, cell);
    mesh_data other = meshgen_blocks(seed + 7, nx, ny, nz, cell);
    assert_same_bytes(&m, &again);
    assert_false(same_bytes(&m, &other));
    mesh_data_free(&m);
    mesh_data_free(&again);
    mesh_data_free(&other);
}

/* ---------- derived meshes ---------- */

static void test_subdivide_keeps_closedness_area_and_volume(void **state)
{
    (void)state;
    mesh_data box = meshgen_box((box3){{-1, 0, 2}, {3, 1, 2.5}});
    mesh_data fine = meshgen_subdivide(&box, 2);
    assert_int_equal(fine.triangle_count, 12 * 16);
    assert_indices_valid(&fine);
    assert_closed_and_oriented(&fine);
    /* Euler characteristic 2 again: shared midpoints, no cracks. */
    assert_int_equal(fine.vertex_count, fine.triangle_count / 2 + 2);
    assert_true(fabs(surface_area(&fine) - surface_area(&box)) < 1e-12 * surface_area(&box));
    assert_true(signed_volume(&fine) == signed_volume(&box)); /* dyadic midpoints are exact */
    /* Old vertices keep their place, new ones are edge midpoints of the face planes. */
    assert_memory_equal(fine.vertices, box.vertices, 8 * sizeof *box.vertices);

    mesh_data torus = meshgen_torus((vec3){0, 0, 0}, 2.0, 0.5, 12, 8);
    mesh_data torus_fine = meshgen_subdivide(&torus, 1);
    assert_int_equal(torus_fine.triangle_count, 4 * torus.triangle_count);
    assert_closed_and_oriented(&torus_fine);
    assert_true(fabs(surface_area(&torus_fine) - surface_area(&torus)) < 1e-12 * surface_area(&torus));

    mesh_data same = meshgen_subdivide(&box, 0);
    assert_same_bytes(&same, &box);
    mesh_data_free(&box);
    mesh_data_free(&fine);
    mesh_data_free(&torus);
    mesh_data_free(&torus_fine);
    mesh_data_free(&same);
}

static void test_subdivide_quarter_million_triangles_is_fast(void **state)
{
    (void)state;
    mesh_data torus = meshgen_torus((vec3){0, 0, 0}, 10.0, 3.0, 500, 250);
    assert_int_equal(torus.triangle_count, 250000);
    double start = now_seconds();
    mesh_data fine = meshgen_subdivide(&torus, 1);
    double seconds = now_seconds() - start;
    printf("test_meshes: subdivide 250000 -> %zu triangles in %.3f s\n", fine.triangle_count, seconds);
    assert_int_equal(fine.triangle_count, 1000000);
    assert_int_equal(fine.vertex_count, torus.vertex_count + 3 * torus.triangle_count / 2);
    assert_true(seconds < 1.0);
    mesh_data_free(&torus);
    mesh_data_free(&fine);
}

static void test_transformed_scales_and_offsets_every_vertex(void **state)
{
    (void)state;
    mesh_data sphere = meshgen_icosphere((vec3){0, 0, 0}, 1.0, 2);
    vec3 offset = {10, -20, 0.5};
    mesh_data moved = meshgen_transformed(&sphere, 2.0, offset);
    assert_int_equal(moved.vertex_count, sphere.vertex_count);
    assert_memory_equal(moved.indices, sphere.indices, 3 * sphere.triangle_count * sizeof *sphere.indices);
    for (size_t v = 0; v < sphere.vertex_count; v++)
        assert_true(vec3_equal(moved.vertices[v], vec3_add(vec3_scale(sphere.vertices[v], 2.0), offset)));
    assert_closed_and_oriented(&moved);
    double expected = 8.0 * signed_volume(&sphere);
    assert_true(fabs(signed_volume(&moved) - expected) < 1e-9 * expected);
    mesh_data_free(&sphere);
    mesh_data_free(&moved);
}

/* ---------- loader ---------- */

typedef struct loaded {
    int status;
    mesh_data mesh;
    mesh_load_report report;
    char err[512];
} loaded;

static loaded load(const char *path)
{
    loaded l;
    memset(&l, 0, sizeof l);
    l.status = mesh_load_file(path, &l.mesh, &l.report, l.err, sizeof l.err);
    return l;
}

static void assert_bbox_of_vertices(const loaded *l)
{
    vec3 lo = l->mesh.vertices[0], hi = lo;
    for (size_t v = 0; v < l->mesh.vertex_count; v++) {
        lo = vec3_min(lo, l->mesh.vertices[v]);
        hi = vec3_max(hi, l->mesh.vertices[v]);
    }
    assert_true(vec3_equal(lo, l->report.bbox_lo) && vec3_equal(hi, l->report.bbox_hi));
}

static void test_load_obj_box_triangulates_quads(void **state)
{
    (void)state;
    loaded l = load(MODELS "/OBJ/box.obj");
    assert_int_equal(l.status, 0);
    assert_string_equal(l.err, "");
    /* Six quads, eight shared corners. */
    assert_int_equal(l.mesh.triangle_count, 12);
    assert_int_equal(l.report.triangles, 12);
    assert_int_equal(l.mesh.vertex_count, 8);
    assert_int_equal(l.report.meshes, 1);
    assert_int_equal(l.report.degenerate, 0);
    assert_int_equal(l.report.duplicates, 0);
    assert_int_equal(l.report.skipped_primitives, 0);
    assert_true(vec3_equal(l.report.bbox_lo, (vec3){-0.5, -0.5, -0.5}));
    assert_true(vec3_equal(l.report.bbox_hi, (vec3){0.5, 0.5, 0.5}));
    assert_indices_valid(&l.mesh);
    assert_closed_and_oriented(&l.mesh);
    assert_true(fabs(signed_volume(&l.mesh)) == 1.0);
    mesh_data_free(&l.mesh);
}

static void test_load_ply_wuson(void **state)
{
    (void)state;
    loaded l = load(MODELS "/PLY/Wuson.ply");
    assert_int_equal(l.status, 0);
    assert_int_equal(l.mesh.triangle_count, 3732); /* the header's face count */
    /* 11184 file vertices split by normals and UVs weld to 2117 positions. */
    assert_int_equal(l.mesh.vertex_count, 2117);
    assert_int_equal(l.report.degenerate, 0);
    assert_int_equal(l.report.duplicates, 0);
    assert_indices_valid(&l.mesh);
    assert_bbox_of_vertices(&l);
    assert_true(l.report.bbox_lo.x == (double)-0.459975988f);
    assert_true(l.report.bbox_hi.y == (double)1.51525092f);
    mesh_data_free(&l.mesh);
}

static void test_load_stl_binary_and_ascii_agree(void **state)
{
    (void)state;
    loaded bin = load(MODELS "/STL/Spider_binary.stl");
    loaded txt = load(MODELS "/STL/Spider_ascii.stl");
    assert_int_equal(bin.status, 0);
    assert_int_equal(txt.status, 0);
    assert_int_equal(bin.mesh.triangle_count, 1368);
    assert_int_equal(txt.mesh.triangle_count, 1368);
    assert_int_equal(bin.mesh.vertex_count, txt.mesh.vertex_count);
    /* The spider really has zero-area and repeated facets; both encodings agree. */
    assert_int_equal(bin.report.degenerate, 56);
    assert_int_equal(txt.report.degenerate, 56);
    assert_int_equal(bin.report.duplicates, 36);
    assert_int_equal(txt.report.duplicates, 36);
    assert_bbox_of_vertices(&bin);
    assert_bbox_of_vertices(&txt);
    /* The ASCII file's six decimals round to float one ulp away from the binary's floats. */
    for (int axis = 0; axis < 3; axis++) {
        assert_true(fabs(vec3_get(bin.report.bbox_lo, axis) - vec3_get(txt.report.bbox_lo, axis)) < 1e-6);
        assert_true(fabs(vec3_get(bin.report.bbox_hi, axis) - vec3_get(txt.report.bbox_hi, axis)) < 1e-6);
    }
    assert_true(bin.report.bbox_lo.y == -4.0 && bin.report.bbox_hi.y == 4.0);
    mesh_data_free(&bin.mesh);
    mesh_data_free(&txt.mesh);
}

static void test_load_counts_skipped_points_and_lines(void **state)
{
    (void)state;
    /* 24 points and 6 four-point polylines (18 segments) beside a triangulated box. */
    loaded l = load(MODELS "/OBJ/testmixed.obj");
    assert_int_equal(l.status, 0);
    assert_int_equal(l.mesh.triangle_count, 12);
    assert_int_equal(l.report.skipped_primitives, 42);
    mesh_data_free(&l.mesh);

    loaded lines = load(MODELS "/OBJ/testline.obj");
    assert_int_equal(lines.status, -1);
    assert_string_equal(lines.err, "no triangles in " MODELS "/OBJ/testline.obj");
    assert_null(lines.mesh.vertices);
}

static void test_load_missing_file_and_directory(void **state)
{
    (void)state;
    loaded l = load("/nonexistent/trioct/nothing.obj");
    assert_int_equal(l.status, -1);
    assert_string_equal(l.err, "cannot open /nonexistent/trioct/nothing.obj: No such file or directory");
    assert_null(l.mesh.vertices);
    assert_int_equal(l.mesh.triangle_count, 0);

    loaded dir = load(MODELS "/OBJ");
    assert_int_equal(dir.status, -1);
    assert_non_null(strstr(dir.err, "is a directory"));

    /* A tiny buffer truncates the message but never overflows it. */
    mesh_data m;
    char tiny[8];
    memset(tiny, 'x', sizeof tiny);
    assert_int_equal(mesh_load_file("/nonexistent.obj", &m, NULL, tiny, sizeof tiny), -1);
    assert_string_equal(tiny, "cannot ");
}

/* Bytes of address space this process holds now. */
static size_t address_space_bytes(void)
{
    FILE *f = fopen("/proc/self/statm", "r");
    assert_non_null(f);
    unsigned long pages = 0;
    assert_int_equal(fscanf(f, "%lu", &pages), 1);
    fclose(f);
    return (size_t)pages * (size_t)sysconf(_SC_PAGESIZE);
}

/* Loads path in a child whose address space may grow by only 1 GiB: a file that makes
 * assimp reserve many gigabytes (OutOfMemory.off claims 353535235358 vertices) must then
 * fail fast with a message, as it would on a server with a memory limit. Returns the
 * child's exit code: 0 refused with a message naming the file, 1 loaded, 2 bad message,
 * anything else (or a signal) a crash. */
static int load_under_memory_cap(const char *path)
{
    fflush(stdout);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        rlim_t cap = (rlim_t)address_space_bytes() + ((rlim_t)1 << 30);
        struct rlimit limit = {cap, cap};
        if (setrlimit(RLIMIT_AS, &limit) != 0)
            _exit(3);
        mesh_data m;
        char err[512];
        if (mesh_load_file(path, &m, NULL, err, sizeof err) == 0)
            _exit(1);
        _exit(strstr(err, path) ? 0 : 2);
    }
    int status = 0;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

static void test_load_invalid_models_fail_cleanly(void **state)
{
    (void)state;
    DIR *dir = opendir(MODELS "/invalid");
    assert_non_null(dir);
    size_t tried = 0, refused = 0;
    struct dirent *entry;
    while ((entry = readdir(dir)) != NULL) {
        if (entry->d_name[0] == '.')
            continue;
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", MODELS "/invalid", entry->d_name);
        tried++;
        if (strcmp(entry->d_name, "OutOfMemory.off") == 0) {
            if (UNDER_ASAN) {
                printf("test_meshes: %s not loaded under AddressSanitizer\n", path);
            } else {
                assert_int_equal(load_under_memory_cap(path), 0);
            }
            refused++;
            continue;
        }
        loaded l = load(path);
        if (strcmp(entry->d_name, "malformed2.obj") == 0) {
            /* Only its material is missing; the one empty face line is dropped. */
            assert_int_equal(l.status, 0);
            assert_int_equal(l.mesh.triangle_count, 10);
            mesh_data_free(&l.mesh);
            continue;
        }
        assert_int_equal(l.status, -1);
        assert_non_null(strstr(l.err, path)); /* every message names the file */
        assert_null(l.mesh.vertices);
        assert_null(l.mesh.indices);
        refused++;
    }
    closedir(dir);
    assert_int_equal(tried, 15);
    assert_int_equal(refused, 14);

    /* A node cycle and all-out-of-range indices, in glTF. */
    loaded cycle = load(MODELS "/glTF2/RecursiveNodes/RecursiveNodes.gltf");
    assert_int_equal(cycle.status, -1);
    assert_non_null(strstr(cycle.err, "RecursiveNodes.gltf"));
    loaded all_bad = load(MODELS "/glTF2/IndexOutOfRange/AllIndicesOutOfRange.gltf");
    assert_int_equal(all_bad.status, -1);
    assert_non_null(strstr(all_bad.err, "AllIndicesOutOfRange.gltf"));
}

static void test_load_refuses_infinite_coordinates_in_glb(void **state)
{
    (void)state;
    loaded l = load(MODELS "/glTF2/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb");
    assert_int_equal(l.status, -1);
    assert_string_equal(l.err, MODELS "/glTF2/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb: "
                               "triangle 0 has a NaN or infinite coordinate");
    assert_null(l.mesh.vertices);
}

/* Files the loader tests write, in a private directory (assimp picks the reader by the
 * file's extension, so each needs its real name). */
typedef struct scratch {
    char dir[64];
    char path[128];
} scratch;

static void scratch_write(scratch *s, const char *name, const char *text)
{
    if (s->dir[0] == '\0') {
        strcpy(s->dir, "/tmp/trioct-meshes-XXXXXX");
        assert_non_null(mkdtemp(s->dir));
    }
    snprintf(s->path, sizeof s->path, "%s/%s", s->dir, name);
    FILE *f = fopen(s->path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

static void scratch_remove(scratch *s)
{
    unlink(s->path);
    rmdir(s->dir);
}

/* Only regular files reach the importer: a FIFO named like a mesh is refused at once (an
 * open for reading would block until a writer came), and so is a device (issue 20). */
static void test_load_refuses_fifos_and_devices(void **state)
{
    (void)state;
    char dir[] = "/tmp/trioct-fifo-XXXXXX";
    assert_non_null(mkdtemp(dir));
    char path[96];
    snprintf(path, sizeof path, "%s/pipe.obj", dir);
    assert_int_equal(mkfifo(path, 0600), 0);
    loaded l = load(path);
    assert_int_equal(l.status, -1);
    assert_non_null(strstr(l.err, "it is a FIFO, not a regular file"));
    assert_null(l.mesh.vertices);
    unlink(path);
    rmdir(dir);

    loaded dev = load("/dev/zero");
    assert_int_equal(dev.status, -1);
    assert_non_null(strstr(dev.err, "it is a device, not a regular file"));
}

static void test_load_refuses_nan_naming_the_triangle(void **state)
{
    (void)state;
    /* The NaN vertex is first used by triangle 2; triangles 0 and 1 are fine. The NaN goes
     * in each coordinate in turn: assimp's float join of identical vertices merges
     * (1, nan, 1) into a finite vertex, and with it the file would load without a word. */
    static const char *const nan_vertex[3] = {"nan 1 1", "1 nan 1", "1 1 nan"};
    for (int axis = 0; axis < 3; axis++) {
        char obj[256];
        snprintf(obj, sizeof obj,
                 "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv %s\n"
                 "f 1 2 3\nf 1 3 4\nf 2 5 3\nf 1 2 4\n",
                 nan_vertex[axis]);
        scratch s = {{0}, {0}};
        scratch_write(&s, "nan.obj", obj);
        loaded l = load(s.path);
        char expected[256];
        snprintf(expected, sizeof expected, "%s: triangle 2 has a NaN or infinite coordinate", s.path);
        assert_int_equal(l.status, -1);
        assert_string_equal(l.err, expected);
        assert_null(l.mesh.vertices);
        assert_int_equal(l.report.triangles, 0);
        scratch_remove(&s);
    }

    /* An infinity from overflow, after a quad: the quad's two triangles count first. */
    scratch s = {{0}, {0}};
    scratch_write(&s, "inf.obj",
                  "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 1e999\n"
                  "f 1 2 3 4\nf 1 2 5\n");
    loaded l = load(s.path);
    char expected[256];
    snprintf(expected, sizeof expected, "%s: triangle 2 has a NaN or infinite coordinate", s.path);
    assert_int_equal(l.status, -1);
    assert_string_equal(l.err, expected);
    scratch_remove(&s);
}

static void test_load_reports_degenerate_and_duplicate_triangles(void **state)
{
    (void)state;
    scratch s = {{0}, {0}};
    /* Vertex 6 repeats vertex 2's position. Triangles: 0 good; 1 collinear; 2 the same
     * positions as 0 through vertex 6, reversed; 3 a repeated corner; 4 a rotation of 0.
     * The line is a primitive with no triangle. */
    scratch_write(&s, "degenerate.obj",
                  "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 2 0\nv 3 3 0\nv 1 0 0\n"
                  "l 1 2\n"
                  "f 1 2 3\nf 1 4 5\nf 6 3 1\nf 2 2 3\nf 3 1 2\n");
    loaded l = load(s.path);
    assert_int_equal(l.status, 0);
    assert_int_equal(l.mesh.triangle_count, 5); /* kept, all of them */
    assert_int_equal(l.report.triangles, 5);
    assert_int_equal(l.report.degenerate, 2);
    assert_int_equal(l.report.duplicates, 2);
    assert_int_equal(l.report.skipped_primitives, 1);
    assert_int_equal(l.mesh.vertex_count, 5); /* the repeated position is welded */
    assert_true(vec3_equal(l.report.bbox_lo, (vec3){0, 0, 0}));
    assert_true(vec3_equal(l.report.bbox_hi, (vec3){3, 3, 0}));
    mesh_data_free(&l.mesh);
    scratch_remove(&s);
}

static void test_load_applies_nested_node_transforms(void **state)
{
    (void)state;
    /* One triangle instanced under two nodes: translate then scale, and translate twice. */
    static const char dae[] =
        "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n"
        "<COLLADA xmlns=\"http://www.collada.org/2005/11/COLLADASchema\" version=\"1.4.1\">\n"
        "<asset><unit meter=\"1\"/><up_axis>Y_UP</up_axis></asset>\n"
        "<library_geometries><geometry id=\"tri\"><mesh>\n"
        "<source id=\"pos\"><float_array id=\"pos-array\" count=\"9\">0 0 0 1 0 0 0 1 0.5</float_array>\n"
        "<technique_common><accessor source=\"#pos-array\" count=\"3\" stride=\"3\">\n"
        "<param name=\"X\" type=\"float\"/><param name=\"Y\" type=\"float\"/><param name=\"Z\" type=\"float\"/>\n"
        "</accessor></technique_common></source>\n"
        "<vertices id=\"vtx\"><input semantic=\"POSITION\" source=\"#pos\"/></vertices>\n"
        "<triangles count=\"1\"><input semantic=\"VERTEX\" source=\"#vtx\" offset=\"0\"/><p>0 1 2</p></triangles>\n"
        "</mesh></geometry></library_geometries>\n"
        "<library_visual_scenes><visual_scene id=\"scene\">\n"
        "<node id=\"outer\"><translate>10 20 30</translate>\n"
        "  <node id=\"scaled\"><scale>2 4 8</scale><instance_geometry url=\"#tri\"/></node>\n"
        "  <node id=\"moved\"><translate>0 0 -1</translate><instance_geometry url=\"#tri\"/></node>\n"
        "</node></visual_scene></library_visual_scenes>\n"
        "<scene><instance_visual_scene url=\"#scene\"/></scene>\n"
        "</COLLADA>\n";
    scratch s = {{0}, {0}};
    scratch_write(&s, "nodes.dae", dae);
    loaded l = load(s.path);
    assert_int_equal(l.status, 0);
    assert_int_equal(l.report.meshes, 2);
    assert_int_equal(l.mesh.triangle_count, 2);
    assert_int_equal(l.mesh.vertex_count, 6);
    static const vec3 expected[2][3] = {
        {{10, 20, 30}, {12, 20, 30}, {10, 24, 34}},
        {{10, 20, 29}, {11, 20, 29}, {10, 21, 29.5}},
    };
    /* Assimp may list the two instances in either order; match each triangle as a set. */
    int matched[2] = {0, 0};
    for (size_t t = 0; t < 2; t++)
        for (int e = 0; e < 2; e++) {
            int all = 1;
            for (int k = 0; k < 3; k++)
                all &= vec3_equal(mesh_data_corner(&l.mesh, t, k), expected[e][k]);
            matched[e] += all;
        }
    assert_int_equal(matched[0], 1);
    assert_int_equal(matched[1], 1);
    assert_true(vec3_equal(l.report.bbox_lo, (vec3){10, 20, 29}));
    assert_true(vec3_equal(l.report.bbox_hi, (vec3){12, 24, 34}));
    mesh_data_free(&l.mesh);
    scratch_remove(&s);
}

static void test_load_gltf_matches_assimp_pretransform(void **state)
{
    (void)state;
    /* An independent reference: assimp's own float pre-transform of the node hierarchy. */
    const char *path = MODELS "/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
    loaded l = load(path);
    assert_int_equal(l.status, 0);
    const struct aiScene *scene =
        aiImportFile(path, aiProcess_Triangulate | aiProcess_PreTransformVertices | aiProcess_SortByPType);
    assert_non_null(scene);
    size_t triangles = 0;
    vec3 lo = {INFINITY, INFINITY, INFINITY}, hi = {-INFINITY, -INFINITY, -INFINITY};
    for (unsigned m = 0; m < scene->mNumMeshes; m++) {
        const struct aiMesh *mesh = scene->mMeshes[m];
        for (unsigned f = 0; f < mesh->mNumFaces; f++) {
            if (mesh->mFaces[f].mNumIndices != 3)
                continue;
            triangles++;
            for (int k = 0; k < 3; k++) {
                const struct aiVector3D *p = &mesh->mVertices[mesh->mFaces[f].mIndices[k]];
                lo = vec3_min(lo, (vec3){p->x, p->y, p->z});
                hi = vec3_max(hi, (vec3){p->x, p->y, p->z});
            }
        }
    }
    aiReleaseImport(scene);
    printf("test_meshes: 2CylinderEngine %zu triangles, %zu vertices\n", l.mesh.triangle_count,
           l.mesh.vertex_count);
    assert_int_equal(l.mesh.triangle_count, triangles);
    double extent = vec3_length(vec3_sub(hi, lo));
    assert_true(extent > 0.0);
    for (int axis = 0; axis < 3; axis++) {
        assert_true(fabs(vec3_get(l.report.bbox_lo, axis) - vec3_get(lo, axis)) < 1e-5 * extent);
        assert_true(fabs(vec3_get(l.report.bbox_hi, axis) - vec3_get(hi, axis)) < 1e-5 * extent);
    }
    assert_bbox_of_vertices(&l);
    mesh_data_free(&l.mesh);
}

/* Concurrent loads each report their own error: assimp keeps one last-error string for
 * the whole process, so without the loader's lock a thread could read another's. */
enum { ERROR_FILES = 4, ERROR_ROUNDS = 200 };
static const char *const error_files[ERROR_FILES] = {
    "/usr/share/assimp/models/invalid/empty.obj", "/usr/share/assimp/models/invalid/empty.ply",
    "/usr/share/assimp/models/invalid/malformed.obj", "/usr/share/assimp/models/invalid/empty.x"};

typedef struct error_job {
    int file;
    char expected[512];
    int mismatches;
} error_job;

static void *load_repeatedly(void *arg)
{
    error_job *job = arg;
    for (int i = 0; i < ERROR_ROUNDS; i++) {
        mesh_data m = {0};
        char err[512];
        if (mesh_load_file(error_files[job->file], &m, NULL, err, sizeof err) == 0) {
            job->mismatches++;
            mesh_data_free(&m);
        } else if (strcmp(err, job->expected) != 0) {
            job->mismatches++;
        }
    }
    return NULL;
}

static void test_concurrent_loads_report_their_own_errors(void **state)
{
    (void)state;
    error_job jobs[ERROR_FILES];
    int distinct = 0;
    for (int f = 0; f < ERROR_FILES; f++) {
        mesh_data m = {0};
        jobs[f] = (error_job){f, "", 0};
        assert_int_equal(mesh_load_file(error_files[f], &m, NULL, jobs[f].expected, sizeof jobs[f].expected), -1);
        assert_non_null(strstr(jobs[f].expected, error_files[f]));
    }
    /* assimp's reasons (after the path) differ from file to file, so a swapped one shows. */
    for (int f = 0; f < ERROR_FILES; f++) {
        const char *why_f = strstr(jobs[f].expected, error_files[f]) + strlen(error_files[f]);
        int unique = 1;
        for (int g = 0; g < ERROR_FILES; g++) {
            const char *why_g = strstr(jobs[g].expected, error_files[g]) + strlen(error_files[g]);
            unique &= g == f || strcmp(why_f, why_g) != 0;
        }
        distinct += unique;
    }
    assert_int_equal(distinct, ERROR_FILES);
    pthread_t threads[ERROR_FILES];
    for (int f = 0; f < ERROR_FILES; f++)
        assert_int_equal(pthread_create(&threads[f], NULL, load_repeatedly, &jobs[f]), 0);
    for (int f = 0; f < ERROR_FILES; f++) {
        pthread_join(threads[f], NULL);
        assert_int_equal(jobs[f].mismatches, 0);
    }
}

int main(void)
{
    printf("test_meshes: seed %llu (set TRIOCT_SEED to rerun with another)\n",
           (unsigned long long)test_seed());
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rng_matches_splitmix64_reference),
        cmocka_unit_test(test_tetrahedron_outward_whatever_the_order),
        cmocka_unit_test(test_box_has_twelve_outward_triangles_and_exact_volume),
        cmocka_unit_test(test_icosphere_counts_closed_and_volume),
        cmocka_unit_test(test_icosphere_six_subdivisions_is_fast),
        cmocka_unit_test(test_torus_counts_closed_and_volume),
        cmocka_unit_test(test_terrain_grid_faces_up_and_is_deterministic),
        cmocka_unit_test(test_soup_triangles_sized_inside_region_and_deterministic),
        cmocka_unit_test(test_blocks_on_grid_touching_and_deterministic),
        cmocka_unit_test(test_subdivide_keeps_closedness_area_and_volume),
        cmocka_unit_test(test_subdivide_quarter_million_triangles_is_fast),
        cmocka_unit_test(test_transformed_scales_and_offsets_every_vertex),
        cmocka_unit_test(test_load_obj_box_triangulates_quads),
        cmocka_unit_test(test_load_ply_wuson),
        cmocka_unit_test(test_load_stl_binary_and_ascii_agree),
        cmocka_unit_test(test_load_counts_skipped_points_and_lines),
        cmocka_unit_test(test_load_missing_file_and_directory),
        cmocka_unit_test(test_load_refuses_fifos_and_devices),
        cmocka_unit_test(test_load_invalid_models_fail_cleanly),
        cmocka_unit_test(test_load_refuses_infinite_coordinates_in_glb),
        cmocka_unit_test(test_load_refuses_nan_naming_the_triangle),
        cmocka_unit_test(test_load_reports_degenerate_and_duplicate_triangles),
        cmocka_unit_test(test_load_applies_nested_node_transforms),
        cmocka_unit_test(test_load_gltf_matches_assimp_pretransform),
        cmocka_unit_test(test_concurrent_loads_report_their_own_errors),
    };
    return cmocka_run_group_tests_name("meshes", tests, NULL, NULL);
}
