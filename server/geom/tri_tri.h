/* Triangle against triangle (closed sets), in the three accuracy modes. Degenerate
 * triangles act as the segment or point they are. */
#ifndef TRIOCT_GEOM_TRI_TRI_H
#define TRIOCT_GEOM_TRI_TRI_H

#include "predicates.h"
#include "vec3.h"

/* 1 when the closed triangles share a point, decided exactly on the double inputs. */
int tri_tri_overlap_exact(const vec3 a[3], const vec3 b[3]);

/* One triangle tested exactly against many (a triangle query against its candidates):
 * what depends on it alone is computed once. Fill with tri_tri_query_prepare. */
typedef struct tri_tri_query {
    vec3 v[3];
    box3 box;             /* the vertices' exact bounds */
    orient3d_plane plane; /* orient3d(v[0], v[1], v[2], x) for the candidates' vertices */
    int axis;             /* projection for the 2D separation proof: largest normal component */
    int turn;             /* orient2d_axis_filter(v[0], v[1], v[2], axis): +-1 or PREDICATES_UNDECIDED */
} tri_tri_query;

void tri_tri_query_prepare(tri_tri_query *q, const vec3 a[3]);

/* orient3d_plane_filter(p, d[i]) in s[i] for three points at once: the same signs (the
 * exact test's first two stages; public for its test). */
void tri_tri_plane_signs(const orient3d_plane *p, const vec3 d[3], int s[3]);

/* +1 or -1 when orient3d_plane_filter decides that sign for all eight corners of the box
 * [lo, hi] (so every point of the box lies strictly on that side of p's plane, which is
 * linear in the point: no triangle within the box can meet one in the plane), else 0. */
int tri_tri_plane_box_side(const orient3d_plane *p, const double lo[3], const double hi[3]);

/* tri_tri_overlap_exact(q->v, b): the same answer, for the price of one prepared side. */
int tri_tri_overlap_exact_query(const tri_tri_query *q, const vec3 b[3]);

/* The seed's edge-plane + point-in-triangle tests with epsilon. */
int tri_tri_overlap_seed(const vec3 a[3], const vec3 b[3], double eps);

/* Plain double test (Moller 1997 interval overlap), no exactness guarantee. Planes whose
 * unit-max-norm normals have a cross product of max norm at most TRI_TRI_FAST_COPLANAR are
 * decided as coplanar (2D overlap in projection). A triangle of no area, or a sliver whose
 * computed normal is mostly rounding, is tested as its edges against the other triangle
 * (each edge crossing the other's plane must cross it inside the triangle). */
#define TRI_TRI_FAST_COPLANAR 0x1p-15
int tri_tri_overlap_fast(const vec3 a[3], const vec3 b[3]);

/* For triangles known to touch: an intersection segment p..q (p == q for a point).
 * Coplanar overlaps give two extreme points of the overlap region along its longest
 * extent. The points are constructed in double: the decision was made exactly before. */
void tri_tri_contact_segment(const vec3 a[3], const vec3 b[3], vec3 *p, vec3 *q);

#endif
