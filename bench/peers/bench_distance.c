/* Distances, trioct against FCL's distance (BVHModel<OBBRSS>, fcl::distance with nearest
 * points), on the same worlds, points, shapes and poses, one core: point distance (FCL: a
 * sphere of radius 0), shape distance (a sphere-like shape of 320 triangles at poses near
 * the surface) and clearance at a radius of 1% of the world (FCL has no early exit: its
 * distance, compared with the radius, as a caller of FCL would). Each figure is the median
 * over alternating rounds (each side first in turn) of trioct's rate over FCL's, with its
 * range, beside the target. Answers are compared: FCL's distance must lie in trioct's
 * proven [lower, upper] up to FCL's own rounding (1e-9 of the world's size), and the
 * clearance answers must agree except where trioct's bound straddles the radius. Prints
 * figures; asserts nothing about time. */
#define _GNU_SOURCE
#include <math.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "engine.h"
#include "fcl_peer.h"
#include "support/meshgen.h"
#include "support/real_meshes.h"

enum {
    ROUNDS = 5,
    POINTS = 4000,
    POSES = 400,
};
#define TARGET 1.0

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int pin_to_one_cpu(void)
{
    cpu_set_t set;
    CPU_ZERO(&set);
    if (sched_getaffinity(0, sizeof set, &set) != 0)
        return -1;
    for (int c = 0; c < CPU_SETSIZE; c++)
        if (CPU_ISSET(c, &set)) {
            CPU_ZERO(&set);
            CPU_SET(c, &set);
            sched_setaffinity(0, sizeof set, &set);
            return c;
        }
    return -1;
}

static int compare_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median_of(const double *v, int n)
{
    double s[ROUNDS];
    memcpy(s, v, (size_t)n * sizeof *s);
    qsort(s, (size_t)n, sizeof *s, compare_double);
    return s[n / 2];
}

static fcl_peer_model *fcl_of(const mesh_data *m)
{
    uint32_t *idx = malloc(3 * m->triangle_count * sizeof *idx);
    for (size_t i = 0; i < 3 * m->triangle_count; i++)
        idx[i] = (uint32_t)m->indices[i];
    fcl_peer_model *f = fcl_peer_model_new(&m->vertices[0].x, m->vertex_count, idx, m->triangle_count);
    free(idx);
    return f;
}

static vec3 surface_point(const mesh_data *m, rng *r)
{
    size_t t = rng_next(r) % m->triangle_count;
    double u = rng_uniform(r, 0, 1), v = rng_uniform(r, 0, 1);
    if (u + v > 1) {
        u = 1 - u;
        v = 1 - v;
    }
    vec3 a = m->vertices[m->indices[3 * t]], b = m->vertices[m->indices[3 * t + 1]],
         c = m->vertices[m->indices[3 * t + 2]];
    return vec3_add(a, vec3_add(vec3_scale(vec3_sub(b, a), u), vec3_scale(vec3_sub(c, a), v)));
}

static void print_row(const char *mesh, const char *measure, const double *ours, const double *theirs, int n,
                      const char *notes)
{
    double ratio[ROUNDS], lo = INFINITY, hi = 0;
    for (int k = 0; k < n; k++) {
        ratio[k] = ours[k] / theirs[k];
        lo = fmin(lo, ratio[k]);
        hi = fmax(hi, ratio[k]);
    }
    double med = median_of(ratio, n);
    char name[64], range[32];
    snprintf(name, sizeof name, "%s: %s", mesh, measure);
    snprintf(range, sizeof range, "%.2f-%.2f", lo, hi);
    printf("%-40s %10.0f %10.0f %8.2f %12s %8.2f %5s  %s\n", name, median_of(ours, n), median_of(theirs, n), med,
           range, TARGET, med >= TARGET ? "yes" : "no", notes);
    fflush(stdout);
}

static pose random_pose(rng *r, vec3 t)
{
    vec3 axis = rng_unit_vector(r);
    double a = rng_uniform(r, -3.1, 3.1);
    pose p;
    if (octree_pose_from_quaternion(t, cos(a / 2), sin(a / 2) * axis.x, sin(a / 2) * axis.y, sin(a / 2) * axis.z,
                                    &p) != OCTREE_OK)
        exit(1);
    return p;
}

/* FCL's answer against trioct's enclosure, up to FCL's rounding. */
static int outside(double fcl, double lower, double upper, double tol)
{
    fcl = fcl > 0 ? fcl : 0.0;
    return fcl < lower - tol || fcl > upper + tol;
}

static void bench_world(const char *mesh, const mesh_data *m)
{
    mesh_view view = mesh_data_view(m);
    octree_def def = octree_default_def();
    /* What a world serving distance builds: triangle boxes, node bounds and node slabs. */
    def.triangle_boxes = 1;
    def.node_bounds = 1;
    def.node_slabs = 1;
    octree_error err;
    octree *tree = octree_build(&view, &def, &err);
    fcl_peer_model *world_fcl = fcl_of(m);
    if (!tree || !world_fcl) {
        printf("%s: build failed\n", mesh);
        return;
    }
    box3 b = mesh_data_bounds(m);
    vec3 ext = vec3_sub(b.hi, b.lo);
    double size = fmax(ext.x, fmax(ext.y, ext.z));
    double tol = 1e-9 * size;
    rng r = rng_seeded(7);

    /* Points: half anywhere in the bounds grown by a fifth, half within 1% of the surface. */
    vec3 *points = malloc(POINTS * sizeof *points);
    box3 around = {vec3_sub(b.lo, vec3_scale(ext, 0.2)), vec3_add(b.hi, vec3_scale(ext, 0.2))};
    for (int i = 0; i < POINTS; i++)
        points[i] = i % 2 ? rng_point_in_box(&r, around)
                          : vec3_add(surface_point(m, &r), vec3_scale(rng_unit_vector(&r), rng_uniform(&r, 0, 0.01) * size));
    distance_output *ours = malloc(POINTS * sizeof *ours);
    double *theirs = malloc(POINTS * sizeof *theirs);
    double t_ours[ROUNDS], t_theirs[ROUNDS];
    for (int k = 0; k < ROUNDS; k++)
        for (int side = 0; side < 2; side++) {
            double t0 = now();
            if ((side == 0) == (k % 2 == 0)) {
                for (int i = 0; i < POINTS; i++)
                    octree_point_distance(tree, points[i], INFINITY, &ours[i], NULL);
                t_ours[k] = POINTS / (now() - t0);
            } else {
                double nearest[3];
                for (int i = 0; i < POINTS; i++) {
                    const double p[3] = {points[i].x, points[i].y, points[i].z};
                    theirs[i] = fcl_peer_point_distance(world_fcl, p, nearest);
                }
                t_theirs[k] = POINTS / (now() - t0);
            }
        }
    int differ = 0;
    double worst = 0, widest = 0;
    for (int i = 0; i < POINTS; i++) {
        differ += outside(theirs[i], ours[i].lower, ours[i].upper, tol);
        worst = fmax(worst, fabs(fmax(theirs[i], 0) - ours[i].distance));
        widest = fmax(widest, ours[i].bound);
    }
    char notes[256];
    snprintf(notes, sizeof notes, "FCL outside the bounds %d of %d; largest |difference| %.2g, bound %.2g", differ,
             POINTS, worst, widest);
    print_row(mesh, "point distance /s", t_ours, t_theirs, ROUNDS, notes);

    /* A shape of 320 triangles, 3% of the world's size, at poses within 5% of the surface. */
    mesh_data shape = meshgen_icosphere((vec3){0, 0, 0}, 0.03 * size, 2);
    mesh_view sview = mesh_data_view(&shape);
    octree_def sdef = octree_default_def();
    sdef.node_bounds = 1;
    sdef.node_slabs = 1; /* what a registered shape of such a world gets */
    octree *shape_tree = octree_build(&sview, &sdef, &err);
    fcl_peer_model *shape_fcl = fcl_of(&shape);
    pose *poses = malloc(POSES * sizeof *poses);
    for (int i = 0; i < POSES; i++)
        poses[i] = random_pose(&r, vec3_add(surface_point(m, &r),
                                            vec3_scale(rng_unit_vector(&r), (0.03 + rng_uniform(&r, 0, 0.05)) * size)));
    shape_distance_output *sours = malloc(POSES * sizeof *sours);
    double *stheirs = malloc(POSES * sizeof *stheirs);
    for (int k = 0; k < ROUNDS; k++)
        for (int side = 0; side < 2; side++) {
            double t0 = now();
            if ((side == 0) == (k % 2 == 0)) {
                for (int i = 0; i < POSES; i++)
                    octree_shape_distance(tree, NULL, shape_tree, &poses[i], INFINITY, &sours[i], NULL);
                t_ours[k] = POSES / (now() - t0);
            } else {
                double wp[3], sp[3];
                for (int i = 0; i < POSES; i++) {
                    const double t[3] = {poses[i].t.x, poses[i].t.y, poses[i].t.z};
                    stheirs[i] = fcl_peer_distance(shape_fcl, poses[i].r, t, world_fcl, wp, sp);
                }
                t_theirs[k] = POSES / (now() - t0);
            }
        }
    query_stats sst = {0};
    for (int i = 0; i < POSES; i++)
        octree_shape_distance(tree, NULL, shape_tree, &poses[i], INFINITY, &sours[i], &sst);
    differ = 0;
    worst = widest = 0;
    int touching = 0;
    for (int i = 0; i < POSES; i++) {
        differ += outside(stheirs[i], sours[i].lower, sours[i].upper, tol);
        worst = fmax(worst, fabs(fmax(stheirs[i], 0) - sours[i].distance));
        widest = fmax(widest, sours[i].bound);
        touching += sours[i].upper == 0;
    }
    snprintf(notes, sizeof notes,
             "FCL outside the bounds %d of %d (%d touching); |difference| %.2g, bound %.2g; %.0f node pairs, %.0f "
             "triangle pairs a pose",
             differ, POSES, touching, worst, widest, (double)sst.nodes_visited / POSES,
             (double)sst.candidates_tested / POSES);
    print_row(mesh, "shape distance /s", t_ours, t_theirs, ROUNDS, notes);

    /* Clearance at 1% of the world's size, the same poses. */
    double radius = 0.01 * size;
    int *clear = malloc(POSES * sizeof *clear);
    for (int k = 0; k < ROUNDS; k++)
        for (int side = 0; side < 2; side++) {
            double t0 = now();
            if ((side == 0) == (k % 2 == 0)) {
                for (int i = 0; i < POSES; i++)
                    octree_shape_clearance(tree, NULL, shape_tree, &poses[i], radius, &clear[i], NULL);
                t_ours[k] = POSES / (now() - t0);
            } else {
                for (int i = 0; i < POSES; i++) {
                    const double t[3] = {poses[i].t.x, poses[i].t.y, poses[i].t.z};
                    stheirs[i] = fcl_peer_distance(shape_fcl, poses[i].r, t, world_fcl, NULL, NULL);
                }
                t_theirs[k] = POSES / (now() - t0);
            }
        }
    int unsafe = 0, cautious = 0, clears = 0;
    for (int i = 0; i < POSES; i++) {
        clears += clear[i];
        unsafe += clear[i] && stheirs[i] <= radius - tol;
        cautious += !clear[i] && stheirs[i] > radius + tol;
    }
    snprintf(notes, sizeof notes, "clear %d of %d; clear where FCL is within %d; within where FCL is clear %d",
             clears, POSES, unsafe, cautious);
    print_row(mesh, "clearance /s", t_ours, t_theirs, ROUNDS, notes);

    free(clear);
    free(sours);
    free(stheirs);
    free(poses);
    fcl_peer_model_free(shape_fcl);
    octree_free(shape_tree);
    mesh_data_free(&shape);
    free(points);
    free(ours);
    free(theirs);
    fcl_peer_model_free(world_fcl);
    octree_free(tree);
}

int main(int argc, char **argv)
{
    const char *only = argc > 1 ? argv[1] : NULL;
    int cpu = pin_to_one_cpu();
    printf("# distances: trioct vs FCL %s (BVHModel<OBBRSS>, fcl::distance with nearest points) on one core (CPU "
           "%d); %d points, %d shape poses; medians of %d alternating rounds\n",
           fcl_peer_version(), cpu, POINTS, POSES, ROUNDS);
    printf("%-40s %10s %10s %8s %12s %8s %5s  %s\n", "measure", "trioct", "FCL", "ratio", "range", "target", "met",
           "notes");
    if (!only || strstr(only, "terrain")) {
        mesh_data terrain = meshgen_terrain(1, (box3){{0, 0, 0}, {100, 100, 10}}, 300, 300);
        bench_world("terrain 180k", &terrain);
        mesh_data_free(&terrain);
    }
    if (!only || strstr(only, "icosphere")) {
        mesh_data sphere = meshgen_icosphere((vec3){0, 0, 0}, 1.0, 6);
        bench_world("icosphere 82k", &sphere);
        mesh_data_free(&sphere);
    }
    if (!only || strstr(only, "wuson")) {
        mesh_data base, sub;
        int times;
        char err[256];
        if (real_mesh_load(REAL_WUSON, 100000, &base, &sub, &times, err, sizeof err) == 0) {
            char name[40];
            snprintf(name, sizeof name, "wuson x4^%d", times);
            bench_world(name, &sub);
            mesh_data_free(&sub);
            mesh_data_free(&base);
        } else {
            printf("# wuson skipped: %s\n", err);
        }
    }
    return 0;
}
