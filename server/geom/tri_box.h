/* Triangle against closed axis-aligned box, in the three accuracy modes. A degenerate
 * triangle (zero area) is tested as the segment or point it is. */
#ifndef TRIOCT_GEOM_TRI_BOX_H
#define TRIOCT_GEOM_TRI_BOX_H

#include "vec3.h"

/* 1 when the closed triangle touches the closed box, decided exactly on the double inputs
 * (separating-axis test whose every comparison is an exact predicate). */
int tri_box_overlap_exact(const vec3 tri[3], box3 box);

/* The seed document's three-step test with its epsilon, as written: vertex in box; box
 * edges (faces 0-3 x edges 0-2) against the triangle; triangle edges against the six
 * faces with the point-in-quadrilateral test. */
int tri_box_overlap_seed(const vec3 tri[3], box3 box, double eps);

/* Plain double separating-axis test (Akenine-Moller 2001), what a typical library does. */
int tri_box_overlap_fast(const vec3 tri[3], box3 box);

#endif
