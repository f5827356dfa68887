/* Geometry for the replay logs' requests, drawn from a seeded generator (tests/support's
 * splitmix64) and aimed at the replay scene (logs_world.h): rays that land on the yard,
 * rays through the ball, small triangles at the ground, triangles on the cell's block
 * faces, rigid poses. Same seed, same numbers, on every machine. */
#ifndef TRIOCT_LOGS_SHAPES_H
#define TRIOCT_LOGS_SHAPES_H

#include "support/meshgen.h"
#include "trioct_pose_t.h"
#include "trioct_triangle_t.h"
#include "trioct_vec3_t.h"

trioct_vec3_t ls_vec(double x, double y, double z);

/* From 12 above a random point of the yard, straight down with a small random tilt. */
void ls_rays_from_above(rng *r, int n, trioct_vec3_t *origin, trioct_vec3_t *direction);
/* From x = -9 at random heights and depths through the ball, along +x. */
void ls_rays_through_ball(rng *r, int n, trioct_vec3_t *origin, trioct_vec3_t *direction);
/* From random points of the box around the yard towards random directions. */
void ls_rays_random(rng *r, int n, trioct_vec3_t *origin, trioct_vec3_t *direction);
/* Straight down onto the terrain's grid vertices and edge midpoints: watertightness. */
void ls_rays_on_grid(int n, trioct_vec3_t *origin, trioct_vec3_t *direction);

/* Small triangles (about `size` across) whose centres lie at the terrain's height band. */
void ls_triangles_at_ground(rng *r, int n, double size, trioct_triangle_t *out);
/* Triangles lying in the planes of the cell's block faces (z = k * cell). */
void ls_triangles_on_cell(rng *r, int n, trioct_triangle_t *out);
/* Poses: a random rotation and a translation in [lo, hi]. */
void ls_poses(rng *r, int n, trioct_vec3_t lo, trioct_vec3_t hi, trioct_pose_t *out);
/* Poses turned by multiples of 90 degrees about z onto grid points: exact rotations. */
void ls_poses_on_grid(int n, double cell, trioct_vec3_t base, trioct_pose_t *out);
/* A tetrahedron of four triangles with its centre at the origin, edge about `size`. */
void ls_tetrahedron(double size, trioct_triangle_t out[4]);

#endif
