/* Lower bounds of distances between closed boxes, for the distance walks: every one a
 * proven lower bound of the real distance of the doubles it is given (a point is a box of
 * no size). Plain doubles with a relative margin, as these run once a node and once a
 * candidate: each gap is one rounded subtraction (within u of the real one), squared and
 * summed in four more roundings, which 2^-50 of the sum covers; 2^-1060 covers an
 * underflow. */
#ifndef TRIOCT_GEOM_BOX_DISTANCE_H
#define TRIOCT_GEOM_BOX_DISTANCE_H

#include "interval.h"

/* The larger of two gaps, or 0 (fmax is a call at -O2). */
static inline double box_gap_of(double x, double y)
{
    double g = x > y ? x : y;
    return g > 0 ? g : 0.0;
}

/* A lower bound of the squared distance between the closed boxes a and b; INFINITY when
 * either holds nothing (inverted bounds, an empty node's). */
static inline double boxes_distance2_below(box3 a, box3 b)
{
    if (!(b.lo.x <= b.hi.x) || !(a.lo.x <= a.hi.x))
        return INFINITY;
    double gx = box_gap_of(a.lo.x - b.hi.x, b.lo.x - a.hi.x), gy = box_gap_of(a.lo.y - b.hi.y, b.lo.y - a.hi.y),
           gz = box_gap_of(a.lo.z - b.hi.z, b.lo.z - a.hi.z);
    double s = (gx * gx + gy * gy + gz * gz) * (1 - 0x1p-50) - 0x1p-1060;
    return s > 0 ? s : 0.0;
}

/* b grown by g >= 0 on every side, rounded outward. */
static inline box3 box_grown(box3 b, double g)
{
    if (g > 0)
        b = (box3){{iv_down(b.lo.x - g), iv_down(b.lo.y - g), iv_down(b.lo.z - g)},
                   {iv_up(b.hi.x + g), iv_up(b.hi.y + g), iv_up(b.hi.z + g)}};
    return b;
}

static inline box3 point_box(vec3 p)
{
    return (box3){p, p};
}

/* The bounds of a triangle's three vertices. */
static inline box3 triangle_bounds(const vec3 v[3])
{
    return (box3){vec3_min(vec3_min(v[0], v[1]), v[2]), vec3_max(vec3_max(v[0], v[1]), v[2])};
}

#endif
