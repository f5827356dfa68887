/* The octree's compiled traversal form: the same tree, after the seed's build, laid out for
 * ray walks that take a node step in a few dozen instructions.
 *
 * Each interior node of the octree becomes one 96-byte record holding, for each of its
 * eight children, the bounds of what the child holds: the union of its triangles' boxes,
 * each clipped to the child's cube. The bounds are floats relative to the world's lower
 * corner, rounded outward, and quantized to 8 bits within the node's own frame, so a ray
 * tests all eight children at once in single precision, with SIMD, and skips the empty
 * space inside a cube that the octree's cubes alone cannot.
 *
 * Exactness needs only that the walk is conservative. Every point of a triangle inside the
 * world lies in the cube of a leaf that lists the triangle (membership is exact), so it
 * lies in that leaf's bounds and in every ancestor's: a walk that never drops a child whose
 * bounds the exact ray meets within [tmin, bound] reaches every hit. The float test is
 * widened once per ray and once per child lane (octree_ray.c), and the final triangle tests
 * stay exact. */
#ifndef TRIOCT_OCTREE_TRAVERSAL_H
#define TRIOCT_OCTREE_TRAVERSAL_H

#include <stddef.h>
#include <stdint.h>

#include "../geom/vec3.h"

struct octree;

/* A child reference: a compiled node's index, or with TRAVERSAL_LEAF set the octree node
 * index of a leaf (whose first/count name its list). TRAVERSAL_EMPTY marks a lane with no
 * child that holds anything. */
#define TRAVERSAL_LEAF 0x80000000u
#define TRAVERSAL_EMPTY 0xFFFFFFFFu
/* A leaf reference names the leaf's list itself where it can, so that a walk reaching the
 * leaf reads its candidates without reading its node first (one dependent memory access
 * fewer a leaf, and the list can be asked for as soon as the leaf is pushed): with
 * TRAVERSAL_SPAN set, bits 0-24 are the list's first index in leaf_items and bits 25-29
 * its length less one. A longer leaf, or one further in, takes its octree node index in
 * bits 0-29 (octree_leaf_of_ref reads either). */
#define TRAVERSAL_SPAN 0x40000000u
#define TRAVERSAL_SPAN_COUNT_SHIFT 25
#define TRAVERSAL_SPAN_FIRST_LIMIT ((1u << TRAVERSAL_SPAN_COUNT_SHIFT) - 1) /* first below: never EMPTY */
#define TRAVERSAL_SPAN_COUNT_MAX 32u

/* Rows of traversal_node.q: the lower bounds along x, y, z, then the upper bounds. */
enum { TRAVERSAL_LO_X, TRAVERSAL_LO_Y, TRAVERSAL_LO_Z, TRAVERSAL_HI_X, TRAVERSAL_HI_Y, TRAVERSAL_HI_Z };

/* Lane k holds the child taking the upper half along x, y, z where bit 0, 1, 2 of k is set
 * (box_child's convention), so a ray's front-to-back order is lane ^ (its near-upper bits).
 * A child's bound along axis a is origin[a] + q[row][k] * scale: every such value is a
 * float computed exactly (origin is a multiple of scale, a power of two, below 2^22 of
 * them), and encloses the child's contents relative to the world's lower corner. */
typedef struct traversal_node {
    float origin[3];
    float scale;
    uint8_t q[6][8];
    uint32_t child[8];
} traversal_node;
_Static_assert(sizeof(traversal_node) == 96, "two nodes in three cache lines");

typedef struct traversal_form {
    traversal_node *nodes; /* preorder: a node's first compiled child follows it */
    size_t node_count;
    uint32_t root;  /* a compiled node, a leaf reference, or TRAVERSAL_EMPTY */
    int present;    /* 0: no form, every ray takes the double-precision walk */
    int avx2;       /* the processor has AVX2: the walk tests eight lanes in one register */
    size_t bytes;
} traversal_form;

/* Compiles tree's nodes into form; triangle_bounds[i] is internal triangle i's exact box.
 * Returns 0; 1 when the world is outside the range the float walk covers (a side beyond
 * 2^-60 .. 2^60) or a leaf's node index does not fit a reference (2^30 nodes), and -1 when
 * memory ran out: form is then not present and every ray takes the double-precision walk. */
int traversal_form_build(const struct octree *tree, const box3 *triangle_bounds, traversal_form *form);
void traversal_form_free(traversal_form *form);

#endif
