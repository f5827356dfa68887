/* Triangle against closed axis-aligned box, in the three accuracy modes. A degenerate
 * triangle (zero area) is tested as the segment or point it is. */
#ifndef TRIOCT_GEOM_TRI_BOX_H
#define TRIOCT_GEOM_TRI_BOX_H

#include "box_geometry.h"
#include "predicates.h"
#include "vec3.h"

/* 1 when the closed triangle touches the closed box, decided exactly on the double inputs
 * (separating-axis test whose every comparison is an exact predicate). */
int tri_box_overlap_exact(const vec3 tri[3], box3 box);

/* The exact test split in two, for a triangle tested against many boxes (a query triangle
 * against every node it descends into; a triangle straddling a node's split planes against
 * the children it reaches): the triangle's part is computed once, and each box costs only
 * its own part. tri_box_overlap_exact is one preparation and one prepared test, so the
 * answers are the same. Parts are computed on first need (most boxes are settled by a
 * vertex inside them), so the test writes to the struct: a prepared triangle is never
 * shared between threads. */
typedef struct tri_box_triangle {
    double v[3][3];            /* vertices, by coordinate */
    double lo[3], hi[3];       /* exact bounds */
    double edge_delta[3][3];   /* fl(q - p) for edge e = v[e] -> v[e + 1], per coordinate */
    int normal_sign[3];        /* exact signs of the normal's components (all 0: zero area) */
    orient3d_plane plane;
    /* The nine edge x axis tests as tri_box_children_touched runs them: for edge e, lane k
     * holds axis k's, lane 3 nothing (all zero). dj, di are edge_delta's components j, i
     * (edge_axis_separates' naming), above and below the triangle points its two tests
     * measure from (each chosen by the sign of the normal's component k), and active is
     * 0 where the edge gives no axis (parallel to axis k, or of zero length). */
    struct {
        double dj[3][4], di[3][4];
        double above_i[3][4], above_j[3][4], below_i[3][4], below_j[3][4];
        long long active[3][4]; /* -1 (all bits set) or 0 */
    } lanes;
    int ready;                 /* edge_delta, normal_sign and plane set (on first need) */
    int lanes_ready;           /* lanes set (tri_box_children_touched, on first need) */
} tri_box_triangle;

void tri_box_prepare(tri_box_triangle *t, const vec3 tri[3]);
int tri_box_overlap_prepared(tri_box_triangle *t, box3 box);

/* Of the boxes child[k] named in `open`, those the prepared triangle touches, exactly:
 * the same answers as tri_box_overlap_prepared, for any boxes. Each box first takes the
 * axes' float filters, the nine edge axes four lanes at a time and without branches; only
 * a box they leave open (an undecided filter, and no axis decided separating) takes the
 * prepared test, whose exact stages then decide. The build's children are mostly not
 * touched and mostly decided by the filters, so the branches and index arithmetic of
 * the one-axis-at-a-time test were most of its cost. */
unsigned tri_box_children_touched(tri_box_triangle *t, const box3 child[8], unsigned open);
/* The same without the AVX2 code path, which tri_box_children_touched takes where the
 * processor has it: for tests, which check both. */
unsigned tri_box_children_touched_portable(tri_box_triangle *t, const box3 child[8], unsigned open);

/* The children of a box with split point c that the triangle certainly touches at a
 * point where one of its edges crosses a split plane strictly between the edge's ends: the
 * point, computed in double, lies inside the box and off the other split planes by more
 * than its rounding error. A proof only: a child not named may still be touched. The
 * search stops once every child in the mask `wanted` is named. */
unsigned tri_box_children_at_crossings(const vec3 tri[3], box3 box, vec3 c, unsigned wanted);
/* The same without the AVX2 code path, which tri_box_children_at_crossings takes where the
 * processor has it: for tests, which check both. With wanted 0xff both name the same
 * children; with fewer, each may stop at a different point once the wanted are named (the
 * AVX2 path only after a whole edge). */
unsigned tri_box_children_at_crossings_portable(const vec3 tri[3], box3 box, vec3 c, unsigned wanted);

/* Of the children `reach` of a box with split point c, those a triangle touching the box
 * certainly touches, shown without the full test: reach must be box_octants_reached of the
 * triangle's bounds. One child reached is touched (the touching point lies in the bounds,
 * clipped to the box); of several, those holding a vertex (box_octants_holding) or an edge's
 * crossing of a split plane (tri_box_children_at_crossings). The build and the triangle
 * descent both decide children this way, then test the rest in full. Inline: both call
 * it once per node and item, and most calls end at the first test. */
static inline unsigned tri_box_children_proven(const vec3 tri[3], box3 box, vec3 c, unsigned reach)
{
    if ((reach & (reach - 1)) == 0)
        return reach;
    unsigned proven = reach & box_octants_holding(tri, box, c);
    if (reach & ~proven)
        proven |= reach & tri_box_children_at_crossings(tri, box, c, reach & ~proven);
    return proven;
}

/* The seed document's three-step test with its epsilon, as written: vertex in box; box
 * edges (faces 0-3 x edges 0-2) against the triangle; triangle edges against the six
 * faces with the point-in-quadrilateral test. */
int tri_box_overlap_seed(const vec3 tri[3], box3 box, double eps);

/* Plain double separating-axis test (Akenine-Moller 2001), what a typical library does. */
int tri_box_overlap_fast(const vec3 tri[3], box3 box);

#endif
