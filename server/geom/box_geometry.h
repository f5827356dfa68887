/* The seed's node-box geometry (face vertices V_ij, edges E_ij, face normals n_i, edge
 * normals n_Eij, octant corners), derived from a box's two corners on demand. Nodes do not
 * store any of it. */
#ifndef TRIOCT_GEOM_BOX_GEOMETRY_H
#define TRIOCT_GEOM_BOX_GEOMETRY_H

#include "vec3.h"

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
