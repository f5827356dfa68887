/* The catalogue of numerically hard cases: named categories, each case with an exact
 * expected answer computed independently of the engine (by construction with exactly
 * representable coordinates, or by the GMP oracle), expanded by exact-preserving
 * transforms. Used by tests/test_hard_cases.c (which asserts zero errors in exact mode)
 * and by the accuracy report (which counts the seed and fast modes' errors). */
#ifndef TRIOCT_TESTS_HARD_CASES_H
#define TRIOCT_TESTS_HARD_CASES_H

#include <stddef.h>

#include "geom/vec3.h"

typedef enum hard_kind {
    HARD_TRI_TRI = 0, /* a vs b: do the closed triangles touch? */
    HARD_TRI_BOX = 1, /* a vs box: does the closed triangle touch the closed box? */
    HARD_RAY_TRI = 2, /* ray vs a: does the ray hit, with the engine's documented semantics
                         (closed interval; no hit for rays in the plane or zero-area
                         triangles; boundary hits only where the answer does not depend on
                         tie-breaking) */
} hard_kind;

typedef struct hard_case {
    const char *category; /* one of hard_case_categories() */
    hard_kind kind;
    vec3 a[3];
    vec3 b[3];
    box3 box;
    vec3 origin, direction;
    double tmin, tmax;
    int expected; /* 1 touch / hit, 0 not */
    unsigned transform; /* which exact-preserving transform produced it (0 = the base case):
                           bits 0-2 negate x, y, z; bits 3-5 the axis permutation (0..5);
                           bits 6 and up one extra step: 1, 2 scale points and direction by
                           2^-20, 2^20; 3, 4 offset points by (2^20, -2^20, 2^20),
                           (3, -3, 3) * 2^30; 5 swap a and b; 6 rotate vertex orders;
                           7 reverse a's order; 8 swap and reverse both. A variant that
                           would round any coordinate is left out. */
} hard_case;

/* Every case of every category, base cases and their transforms (axis permutations,
 * reflections, power-of-two scalings, exactly representable offsets). Each base case
 * (transform 0) is followed by its variants, all with its expected answer. Deterministic;
 * takes milliseconds. Returns the count and sets *out (free() it), or 0 with *out NULL
 * when memory runs out. */
size_t hard_cases_generate(hard_case **out);

/* The category names, in a fixed order. */
const char *const *hard_case_categories(size_t *count);

/* The answer of the given mode's primitive test for the case (seed_eps for ACCURACY_SEED). */
int hard_case_answer(const hard_case *c, int accuracy_mode, double seed_eps);

#endif
