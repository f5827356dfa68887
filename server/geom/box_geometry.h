/* The seed's node-box geometry (face vertices V_ij, edges E_ij, face normals n_i, edge
 * normals n_Eij, octant corners), derived from a box's two corners on demand. Nodes do not
 * store any of it. */
#ifndef TRIOCT_GEOM_BOX_GEOMETRY_H
#define TRIOCT_GEOM_BOX_GEOMETRY_H

#include "vec3.h"

/* The midpoint as the seed writes it, (lo + hi) / 2. Halving is exact, and rounding the sum
 * is monotone, so the result never leaves [lo, hi]; only a sum that overflows needs the
 * halves added instead. Every split of a node, at build and in every query, goes through
 * this one function, so two neighbours' shared face is the same double everywhere.
 * box_split_in_range is the same value for boxes whose lo + hi cannot overflow (every box
 * of a world whose coordinates are within DBL_MAX / 2), without the check. */
static inline double box_split_in_range(double lo, double hi)
{
    return 0.5 * (lo + hi);
}

static inline double box_split(double lo, double hi)
{
    double c = box_split_in_range(lo, hi);
    if (isinf(c) && isfinite(lo) && isfinite(hi))
        c = 0.5 * lo + 0.5 * hi;
    return c;
}

/* The split point C of a box: box_split on each axis. */
static inline vec3 box_split_point(box3 box)
{
    return (vec3){box_split(box.lo.x, box.hi.x), box_split(box.lo.y, box.hi.y), box_split(box.lo.z, box.hi.z)};
}

/* The child of a box with split point c that takes the upper half [C, hi] along each axis
 * whose bit is set in upper (bit 0 x, bit 1 y, bit 2 z) and the lower half [lo, C] along
 * the others. Builds and queries derive every child box here, from the same C. */
static inline box3 box_child(box3 box, vec3 c, unsigned upper)
{
    return (box3){{upper & 1 ? c.x : box.lo.x, upper & 2 ? c.y : box.lo.y, upper & 4 ? c.z : box.lo.z},
                  {upper & 1 ? box.hi.x : c.x, upper & 2 ? box.hi.y : c.y, upper & 4 ? box.hi.z : c.z}};
}

/* Which half the seed's octant k (0..7 for 1..8) takes along each axis: bit 0 for x, bit 1
 * for y, bit 2 for z, set for the upper half [C, hi]. And the inverse: the octant holding
 * a given set of upper halves. */
extern const unsigned char box_octant_upper_bits[8];
extern const unsigned char box_octant_of_upper_bits[8];

/* The octants a region reaches, as a bit mask over the seed's octants, when along each
 * axis a it reaches the lower half (h = 1), the upper half (h = 2) or both (h = 3):
 * box_octants_by_half[0][hx] & box_octants_by_half[1][hy] & box_octants_by_half[2][hz]. */
extern const unsigned char box_octants_by_half[3][4];

/* 1 when the closed boxes a and b are strictly apart along some axis, so they share no
 * point; boxes that touch are not apart. */
static inline int boxes_apart(box3 a, box3 b)
{
    return a.lo.x > b.hi.x || a.lo.y > b.hi.y || a.lo.z > b.hi.z || a.hi.x < b.lo.x || a.hi.y < b.lo.y ||
           a.hi.z < b.lo.z;
}

/* Which children of a box with split point c the closed region [lo, hi], meeting the
 * box, reaches (meets once clipped to the box). The clipping changes nothing (the box's
 * lo <= c <= its hi on every axis, so max(lo, box lo) <= c iff lo <= c, and likewise
 * above), so callers pass the region's own bounds. */
static inline unsigned box_octants_reached(vec3 lo, vec3 hi, vec3 c)
{
    return box_octants_by_half[0][(lo.x <= c.x) | (hi.x >= c.x) << 1] &
           box_octants_by_half[1][(lo.y <= c.y) | (hi.y >= c.y) << 1] &
           box_octants_by_half[2][(lo.z <= c.z) | (hi.z >= c.z) << 1];
}

/* The children of a box with split point c whose closed boxes hold one of the three
 * points (a point on a split plane is in the children on both sides). A triangle with a
 * vertex in a child touches it: this settles most children a straddling triangle reaches
 * with comparisons only. */
static inline unsigned box_octants_holding(const vec3 p[3], box3 box, vec3 c)
{
    unsigned held = 0;
    for (int n = 0; n < 3; n++)
        if (p[n].x >= box.lo.x && p[n].x <= box.hi.x && p[n].y >= box.lo.y && p[n].y <= box.hi.y &&
            p[n].z >= box.lo.z && p[n].z <= box.hi.z)
            held |= box_octants_reached(p[n], p[n], c);
    return held;
}

/* V_ij: vertex j (0..3) of face i (0..5), in the seed's anti-clockwise order. */
vec3 box_face_vertex(box3 box, int face, int j);
/* E_ij = V_i(j+1) - V_ij. */
vec3 box_face_edge(box3 box, int face, int j);
/* n_i: outward unit normal of face i (an axis direction). */
vec3 box_face_normal(int face);
/* n_Eij = E_ij/|E_ij| x n_i: unit normal of edge j in the plane of face i, pointing out of
 * the face. */
vec3 box_face_edge_normal(box3 box, int face, int j);
/* The seed's octant k (0..7 for the seed's 1..8) of box: child corners from the parent's
 * corners and centre C = (lo + hi) / 2, computed so that neighbouring children share their
 * faces to the bit. */
box3 box_octant(box3 box, int k);

#endif
