/* The seed's node-box geometry derived from a box's two corners: face vertices, edges,
 * face and edge normals, and the eight octants a node splits into. */
#include "box_geometry.h"

#include <assert.h>

/* Box corners are named by three bits, x in bit 0, y in bit 1, z in bit 2; a set bit takes
 * the coordinate from hi, a clear bit from lo. */
static vec3 box_corner(box3 box, int bits)
{
    return vec3_make(bits & 1 ? box.hi.x : box.lo.x, bits & 2 ? box.hi.y : box.lo.y,
                     bits & 4 ? box.hi.z : box.lo.z);
}

/* The seed's vertex table V_ij as corner bits: face 0 is y = ymin, 1 is x = xmax,
 * 2 is y = ymax, 3 is x = xmin, 4 is z = zmax, 5 is z = zmin, each wound so that
 * E_i3 x E_i0 points out of the box. */
static const unsigned char face_vertex_bits[6][4] = {
    {0, 1, 5, 4}, {1, 3, 7, 5}, {3, 2, 6, 7}, {2, 0, 4, 6}, {4, 5, 7, 6}, {0, 2, 3, 1},
};

/* The outward axis of each face: the axis index and the sign along it. */
static const signed char face_axis[6] = {1, 0, 1, 0, 2, 2};
static const signed char face_sign[6] = {-1, 1, 1, -1, 1, -1};

static vec3 axis_vector(int axis, int sign)
{
    return vec3_with((vec3){0.0, 0.0, 0.0}, axis, sign > 0 ? 1.0 : -1.0);
}

vec3 box_face_vertex(box3 box, int face, int j)
{
    assert(face >= 0 && face < 6 && j >= 0 && j < 4);
    return box_corner(box, face_vertex_bits[face][j]);
}

vec3 box_face_edge(box3 box, int face, int j)
{
    assert(face >= 0 && face < 6 && j >= 0 && j < 4);
    return vec3_sub(box_face_vertex(box, face, (j + 1) & 3), box_face_vertex(box, face, j));
}

vec3 box_face_normal(int face)
{
    assert(face >= 0 && face < 6);
    return axis_vector(face_axis[face], face_sign[face]);
}

/* An edge of an axis-aligned face runs along one axis; its two ends agree on the other two
 * corner bits, one of which is the face's own axis. The edge normal lies along the
 * remaining agreeing axis, towards the side the edge sits on. Deriving it from corner bits
 * rather than from lengths keeps it a unit axis even for a box of zero extent. */
vec3 box_face_edge_normal(box3 box, int face, int j)
{
    assert(face >= 0 && face < 6 && j >= 0 && j < 4);
    (void)box;
    int a = face_vertex_bits[face][j];
    int b = face_vertex_bits[face][(j + 1) & 3];
    int agreeing = ~(a ^ b) & 7 & ~(1 << face_axis[face]);
    int axis = agreeing == 1 ? 0 : agreeing == 2 ? 1 : 2;
    return axis_vector(axis, (a & agreeing) ? 1 : -1);
}

const unsigned char box_octant_upper_bits[8] = {
    7, /* 1: +x +y +z */
    6, /* 2: -x +y +z */
    4, /* 3: -x -y +z */
    5, /* 4: +x -y +z */
    3, /* 5: +x +y -z */
    2, /* 6: -x +y -z */
    0, /* 7: -x -y -z */
    1, /* 8: +x -y -z */
};

const unsigned char box_octant_of_upper_bits[8] = {6, 7, 5, 4, 2, 3, 1, 0};

const unsigned char box_octants_by_half[3][4] = {
    {0x00, 0x66, 0x99, 0xff}, /* x: octants 2,3,6,7 lie low; 1,4,5,8 high */
    {0x00, 0xcc, 0x33, 0xff}, /* y: octants 3,4,7,8 lie low; 1,2,5,6 high */
    {0x00, 0xf0, 0x0f, 0xff}, /* z: octants 5..8 lie low; 1..4 high */
};

box3 box_octant(box3 box, int k)
{
    assert(k >= 0 && k < 8);
    return box_child(box, box_split_point(box), box_octant_upper_bits[k]);
}
