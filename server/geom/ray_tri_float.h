/* A single-precision prefilter for the exact ray-triangle test: eight triangles of an
 * indexed mesh against one ray, rejecting only those the ray surely misses.
 *
 * The exact test (ray_tri.h) decides a crossing from the signs of the three edge
 * functions w_k = d . ((v_k - o) x (v_{k+1} - v_k)); two known signs that differ prove a
 * miss. Here the same functions are evaluated in float, from float copies of the vertices
 * and the origin in a scaled frame (coordinates relative to the world's lower corner,
 * times 2^-s with 2^s at or above the world's side, so every vertex lies in [0, 1]), with
 * a bound on the difference from the exact real value that covers the rounding of the
 * inputs into float and of every operation (derivation in ray_tri_float.c). A sign counts
 * only where |W| exceeds that bound, so a rejected triangle is one for which the exact edge
 * functions have two signs that differ: ray_tri_exact returns 0 for it. The others still
 * need the exact test.
 *
 * Floats halve the vertex data a candidate reads and eight triangles fit a register, so
 * a candidate costs a fraction of the double filter's work. */
#ifndef TRIOCT_RAY_TRI_FLOAT_H
#define TRIOCT_RAY_TRI_FLOAT_H

#include <stdint.h>

#include "vec3.h"

/* Coordinates of the scaled frame: (x - lo) * 2^-exp. */
typedef struct float_frame {
    vec3 lo;
    int exp;
} float_frame;

/* A frame for a world cube [lo, lo + side]; 0, or -1 when the side is not a positive
 * finite number. */
int float_frame_for(float_frame *f, vec3 lo, double side);

/* A vertex in the frame, rounded to nearest. */
void float_frame_point(const float_frame *f, vec3 p, float out[3]);

/* One ray, prepared for ray_float_misses8. */
typedef struct ray_float {
    float q[3];      /* the origin in the frame */
    float d[3];      /* the direction times a power of two, largest component in [1, 2) */
    float d_sum;     /* |d|_1 of that */
    float delta_a;   /* bound on the input error of v_k - o per coordinate */
    float delta_e;   /* bound on the input error of v_j - v_k per coordinate */
} ray_float;

/* Prepares the ray; 0 when the filter would not pay or cannot bound it (an origin more
 * than 16 world sides away, a non-finite input): the caller then keeps the double filter. */
int ray_float_init(ray_float *r, const float_frame *f, vec3 o, vec3 d);

/* The candidates among triangles ids[0 .. count) (count <= 8; triangle t's vertices are
 * vertices[3 * corners[t][0..2] + 0..2], floats in the frame) that the ray surely misses,
 * as a bit mask. With `avx2` (the caller checked the processor) in one AVX2 register,
 * otherwise one lane at a time with the same operations, so both give the same mask. */
unsigned ray_float_misses8(const ray_float *r, const float *vertices, const uint32_t (*corners)[3],
                           const uint32_t *ids, unsigned count, int avx2);

#endif
