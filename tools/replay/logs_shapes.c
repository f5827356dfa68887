#include "logs_shapes.h"

#include <math.h>
#include <string.h>

#include "logs_world.h"

trioct_vec3_t ls_vec(double x, double y, double z)
{
    return (trioct_vec3_t){x, y, z};
}

static trioct_vec3_t out_vec(vec3 v)
{
    return ls_vec(v.x, v.y, v.z);
}

void ls_rays_from_above(rng *r, int n, trioct_vec3_t *origin, trioct_vec3_t *direction)
{
    double h = LOGS_TERRAIN_HALF - 0.5;
    for (int i = 0; i < n; i++) {
        origin[i] = ls_vec(rng_uniform(r, -h, h), rng_uniform(r, -h, h), 12);
        direction[i] = ls_vec(rng_uniform(r, -0.05, 0.05), rng_uniform(r, -0.05, 0.05), -1);
    }
}

void ls_rays_through_ball(rng *r, int n, trioct_vec3_t *origin, trioct_vec3_t *direction)
{
    double k = 0.95 * LOGS_BALL_R;
    for (int i = 0; i < n; i++) {
        origin[i] = ls_vec(-9, LOGS_BALL_Y + rng_uniform(r, -k, k), LOGS_BALL_Z + rng_uniform(r, -k, k));
        direction[i] = ls_vec(1, 0, 0);
    }
}

void ls_rays_random(rng *r, int n, trioct_vec3_t *origin, trioct_vec3_t *direction)
{
    box3 around = {{-10, -10, -2}, {10, 10, 6}};
    for (int i = 0; i < n; i++) {
        origin[i] = out_vec(rng_point_in_box(r, around));
        direction[i] = out_vec(rng_unit_vector(r));
    }
}

void ls_rays_on_grid(int n, trioct_vec3_t *origin, trioct_vec3_t *direction)
{
    /* Vertices at integer coordinates, edge midpoints half-way: 16 cells over 16 units. */
    for (int i = 0; i < n; i++) {
        double x = -6 + 0.5 * (i % 24), y = -3 + 0.5 * (i / 24);
        origin[i] = ls_vec(x, y, 5);
        direction[i] = ls_vec(0, 0, -1);
    }
}

void ls_triangles_at_ground(rng *r, int n, double size, trioct_triangle_t *out)
{
    double h = LOGS_TERRAIN_HALF - 1;
    for (int i = 0; i < n; i++) {
        vec3 c = vec3_make(rng_uniform(r, -h, h), rng_uniform(r, -h, h), rng_uniform(r, -0.6, 0.6));
        vec3 p[3];
        for (int k = 0; k < 3; k++)
            p[k] = vec3_add(c, vec3_scale(rng_unit_vector(r), size));
        out[i] = (trioct_triangle_t){out_vec(p[0]), out_vec(p[1]), out_vec(p[2])};
    }
}

void ls_triangles_on_cell(rng *r, int n, trioct_triangle_t *out)
{
    for (int i = 0; i < n; i++) {
        /* A face plane of the grid, and three grid points on it: exact coordinates. */
        double z = LOGS_CELL_SIZE * (double)(rng_next(r) % 3);
        trioct_vec3_t p[3];
        for (int k = 0; k < 3; k++) {
            double x = LOGS_CELL_LO_X + 0.25 * (double)(rng_next(r) % 7);
            double y = LOGS_CELL_LO_Y + 0.25 * (double)(rng_next(r) % 7);
            p[k] = ls_vec(x, y, z);
        }
        out[i] = (trioct_triangle_t){p[0], p[1], p[2]};
    }
}

/* The rotation of a random unit quaternion, row-major. */
static void random_rotation(rng *r, double m[9])
{
    double q[4], len = 0;
    do {
        len = 0;
        for (int k = 0; k < 4; k++) {
            q[k] = rng_uniform(r, -1, 1);
            len += q[k] * q[k];
        }
    } while (len < 0.01 || len > 1);
    len = sqrt(len);
    double w = q[0] / len, x = q[1] / len, y = q[2] / len, z = q[3] / len;
    double v[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - z * w),     2 * (x * z + y * w),
                   2 * (x * y + z * w),     1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
                   2 * (x * z - y * w),     2 * (y * z + x * w),     1 - 2 * (x * x + y * y)};
    memcpy(m, v, sizeof v);
}

void ls_poses(rng *r, int n, trioct_vec3_t lo, trioct_vec3_t hi, trioct_pose_t *out)
{
    for (int i = 0; i < n; i++) {
        random_rotation(r, out[i].r);
        out[i].t = ls_vec(rng_uniform(r, lo.x, hi.x), rng_uniform(r, lo.y, hi.y), rng_uniform(r, lo.z, hi.z));
    }
}

void ls_poses_on_grid(int n, double cell, trioct_vec3_t base, trioct_pose_t *out)
{
    static const double turn[4][4] = {{1, 0, 0, 1}, {0, -1, 1, 0}, {-1, 0, 0, -1}, {0, 1, -1, 0}};
    for (int i = 0; i < n; i++) {
        const double *c = turn[i % 4];
        double m[9] = {c[0], c[1], 0, c[2], c[3], 0, 0, 0, 1};
        memcpy(out[i].r, m, sizeof m);
        out[i].t = ls_vec(base.x + cell * (i % 3), base.y + cell * ((i / 3) % 3), base.z + cell * (i / 9));
    }
}

void ls_tetrahedron(double size, trioct_triangle_t out[4])
{
    double s = size / 2;
    trioct_vec3_t a = ls_vec(s, s, s), b = ls_vec(s, -s, -s), c = ls_vec(-s, s, -s), d = ls_vec(-s, -s, s);
    out[0] = (trioct_triangle_t){a, b, c};
    out[1] = (trioct_triangle_t){a, d, b};
    out[2] = (trioct_triangle_t){a, c, d};
    out[3] = (trioct_triangle_t){b, d, c};
}
