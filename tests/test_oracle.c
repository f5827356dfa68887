/* Tests for the exact test oracle: cases whose answers are known by construction, most of
 * them decided by one ulp or one denormal, plus seeded consistency checks between its forms. */
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include <cmocka.h>

#include "support/oracle.h"

static vec3 pt(double x, double y, double z) { return (vec3){x, y, z}; }
static double up(double x) { return nextafter(x, INFINITY); }
static double down(double x) { return nextafter(x, -INFINITY); }
/* The smallest positive double: a gap no rounded computation could see. */
static double tiny(void) { return nextafter(0.0, 1.0); }

static void cube_corners(vec3 lo, double side, vec3 out[8])
{
    for (int i = 0; i < 8; i++)
        out[i] = pt(lo.x + ((i & 1) ? side : 0.0), lo.y + ((i & 2) ? side : 0.0),
                    lo.z + ((i & 4) ? side : 0.0));
}

static int cube_meets_cube(vec3 lo_a, vec3 lo_b)
{
    vec3 a[8], b[8];
    cube_corners(lo_a, 1.0, a);
    cube_corners(lo_b, 1.0, b);
    return oracle_hulls_intersect(a, 8, b, 8);
}

static int point_in_unit_cube(vec3 p)
{
    vec3 corners[8];
    cube_corners(pt(0, 0, 0), 1.0, corners);
    return oracle_hulls_intersect(&p, 1, corners, 8);
}

static int segments_meet(vec3 p0, vec3 p1, vec3 q0, vec3 q1)
{
    const vec3 p[2] = {p0, p1}, q[2] = {q0, q1};
    return oracle_hulls_intersect(p, 2, q, 2);
}

static const box3 unit_box = {{0, 0, 0}, {1, 1, 1}};

/* ---------- hulls of point sets ---------- */

static void test_unit_cubes_apart_do_not_meet(void **state)
{
    (void)state;
    assert_int_equal(cube_meets_cube(pt(0, 0, 0), pt(2, 0, 0)), 0);
    assert_int_equal(cube_meets_cube(pt(0, 0, 0), pt(-1.5, 3, 0.5)), 0);
}

static void test_unit_cubes_overlapping_meet(void **state)
{
    (void)state;
    assert_int_equal(cube_meets_cube(pt(0, 0, 0), pt(0.5, 0.5, 0.5)), 1);
    assert_int_equal(cube_meets_cube(pt(0, 0, 0), pt(0, 0, 0)), 1);
    assert_int_equal(cube_meets_cube(pt(0, 0, 0), pt(-0.75, 0.25, -0.5)), 1);
}

static void test_unit_cubes_sharing_a_face_meet_and_one_ulp_apart_do_not(void **state)
{
    (void)state;
    assert_int_equal(cube_meets_cube(pt(0, 0, 0), pt(1, 0.5, -0.25)), 1);
    assert_int_equal(cube_meets_cube(pt(0, 0, 0), pt(up(1), 0.5, -0.25)), 0);
    assert_int_equal(cube_meets_cube(pt(0, 0, 0), pt(0.5, -1, 0)), 1);
    assert_int_equal(cube_meets_cube(pt(0, 0, 0), pt(0.5, down(-1), 0)), 0);
}

static void test_unit_cubes_sharing_only_a_corner_meet_and_one_ulp_apart_do_not(void **state)
{
    (void)state;
    assert_int_equal(cube_meets_cube(pt(0, 0, 0), pt(1, 1, 1)), 1);
    assert_int_equal(cube_meets_cube(pt(0, 0, 0), pt(1, 1, up(1))), 0);
    assert_int_equal(cube_meets_cube(pt(0, 0, 0), pt(-1, -1, -1)), 1);
    assert_int_equal(cube_meets_cube(pt(0, 0, 0), pt(down(-1), -1, -1)), 0);
}

static void test_point_inside_on_boundary_and_outside_unit_cube(void **state)
{
    (void)state;
    assert_int_equal(point_in_unit_cube(pt(0.5, 0.5, 0.5)), 1);
    assert_int_equal(point_in_unit_cube(pt(1, 0.5, 0.25)), 1);     /* face */
    assert_int_equal(point_in_unit_cube(pt(1, 1, 0.25)), 1);       /* edge */
    assert_int_equal(point_in_unit_cube(pt(0, 1, 1)), 1);         /* corner */
    assert_int_equal(point_in_unit_cube(pt(up(1), 0.5, 0.25)), 0);
    assert_int_equal(point_in_unit_cube(pt(0.5, -tiny(), 0.5)), 0);
    assert_int_equal(point_in_unit_cube(pt(0.5, tiny(), 0.5)), 1);
    assert_int_equal(point_in_unit_cube(pt(0, 1, up(1))), 0);
    assert_int_equal(point_in_unit_cube(pt(2, 2, 2)), 0);
}

static void test_point_on_slanted_face_of_tetrahedron_counts_and_one_ulp_out_does_not(void **state)
{
    (void)state;
    const vec3 tet[4] = {pt(0, 0, 0), pt(1, 0, 0), pt(0, 1, 0), pt(0, 0, 1)};
    vec3 p = pt(0.25, 0.25, 0.5); /* on x + y + z = 1 exactly */
    assert_int_equal(oracle_hulls_intersect(&p, 1, tet, 4), 1);
    p = pt(0.25, 0.25, up(0.5));
    assert_int_equal(oracle_hulls_intersect(&p, 1, tet, 4), 0);
    p = pt(0.25, 0.25, down(0.5));
    assert_int_equal(oracle_hulls_intersect(&p, 1, tet, 4), 1);
    p = pt(0.125, 0.125, 0.125);
    assert_int_equal(oracle_hulls_intersect(&p, 1, tet, 4), 1);
    assert_int_equal(oracle_hulls_intersect(tet, 4, &p, 1), 1); /* argument order is free */
}

static void test_single_points_meet_only_when_equal(void **state)
{
    (void)state;
    vec3 p = pt(1e300, -3.5, 1e-300), q = p;
    assert_int_equal(oracle_hulls_intersect(&p, 1, &q, 1), 1);
    q.z = up(q.z);
    assert_int_equal(oracle_hulls_intersect(&p, 1, &q, 1), 0);
}

static void test_repeated_points_make_dependent_columns_without_changing_the_answer(void **state)
{
    (void)state;
    const vec3 same[3] = {pt(2, 3, 4), pt(2, 3, 4), pt(2, 3, 4)};
    vec3 p = pt(2, 3, 4);
    assert_int_equal(oracle_hulls_intersect(same, 3, &p, 1), 1);
    p.y = down(3);
    assert_int_equal(oracle_hulls_intersect(same, 3, &p, 1), 0);
    /* A degenerate (collinear) triangle acts as its segment. */
    const vec3 sliver[3] = {pt(0, 0, 0), pt(1, 1, 1), pt(4, 4, 4)};
    const vec3 crossing[2] = {pt(3, 3, 0), pt(3, 3, 8)};
    const vec3 beside[2] = {pt(3, up(3), 0), pt(3, up(3), 8)};
    assert_int_equal(oracle_hulls_intersect(sliver, 3, crossing, 2), 1);
    assert_int_equal(oracle_hulls_intersect(sliver, 3, beside, 2), 0);
}

/* ---------- segments ---------- */

static void test_crossing_segments_meet_even_at_an_unrepresentable_point(void **state)
{
    (void)state;
    assert_int_equal(segments_meet(pt(0, 0, 0), pt(2, 2, 0), pt(0, 2, 0), pt(2, 0, 0)), 1);
    /* y = x/3 against y = 3 - 3x: they cross at x = 9/10, which no double holds. */
    assert_int_equal(segments_meet(pt(0, 0, 0), pt(3, 1, 0), pt(1, 0, 0), pt(0, 3, 0)), 1);
}

static void test_segment_touching_at_an_endpoint_meets_and_one_ulp_off_does_not(void **state)
{
    (void)state;
    assert_int_equal(segments_meet(pt(0, 0, 0), pt(2, 2, 0), pt(1, 1, 0), pt(1, 5, 0)), 1);
    assert_int_equal(segments_meet(pt(0, 0, 0), pt(2, 2, 0), pt(1, up(1), 0), pt(1, 5, 0)), 0);
}

static void test_skew_segments_do_not_meet(void **state)
{
    (void)state;
    assert_int_equal(segments_meet(pt(0, 0, 0), pt(2, 2, 0), pt(0, 2, 1), pt(2, 0, 1)), 0);
    assert_int_equal(segments_meet(pt(0, 0, 0), pt(2, 2, 0), pt(0, 2, tiny()), pt(2, 0, tiny())),
                     0);
}

static void test_collinear_segments_overlapping_touching_and_disjoint(void **state)
{
    (void)state;
    assert_int_equal(segments_meet(pt(0, 0, 0), pt(2, 0, 0), pt(1, 0, 0), pt(3, 0, 0)), 1);
    assert_int_equal(segments_meet(pt(0, 0, 0), pt(2, 0, 0), pt(3, 0, 0), pt(2, 0, 0)), 1);
    assert_int_equal(segments_meet(pt(0, 0, 0), pt(2, 0, 0), pt(up(2), 0, 0), pt(3, 0, 0)), 0);
    /* Collinear along a slanted line, one segment inside the other. */
    assert_int_equal(segments_meet(pt(0, 0, 0), pt(4, 2, 8), pt(1, 0.5, 2), pt(2, 1, 4)), 1);
    assert_int_equal(segments_meet(pt(0, 0, 0), pt(4, 2, 8), pt(5, 2.5, 10), pt(6, 3, 12)), 0);
}

/* ---------- triangle against triangle ---------- */

static void test_triangles_touching_at_one_vertex_meet_and_a_denormal_apart_do_not(void **state)
{
    (void)state;
    const vec3 a[3] = {pt(0, 0, 0), pt(1, 0, 0), pt(0, 1, 0)};
    const vec3 b[3] = {pt(0, 0, 0), pt(-1, 0, 1), pt(0, -1, 1)};
    const vec3 b_lifted[3] = {pt(0, 0, tiny()), pt(-1, 0, 1), pt(0, -1, 1)};
    assert_int_equal(oracle_tri_tri(a, b), 1);
    assert_int_equal(oracle_tri_tri(b, a), 1);
    assert_int_equal(oracle_tri_tri(a, b_lifted), 0);
    assert_int_equal(oracle_tri_tri(b_lifted, a), 0);
}

static void test_triangle_vertex_on_other_face_meets_and_one_ulp_above_does_not(void **state)
{
    (void)state;
    const vec3 a[3] = {pt(0, 0, 1), pt(4, 0, 1), pt(0, 4, 1)};
    const vec3 b[3] = {pt(1, 1, 1), pt(1, 1, 5), pt(3, -2, 6)};
    const vec3 b_lifted[3] = {pt(1, 1, up(1)), pt(1, 1, 5), pt(3, -2, 6)};
    assert_int_equal(oracle_tri_tri(a, b), 1);
    assert_int_equal(oracle_tri_tri(a, b_lifted), 0);
}

static void test_piercing_triangles_meet(void **state)
{
    (void)state;
    const vec3 a[3] = {pt(0, 0, 0), pt(4, 0, 0), pt(0, 4, 0)};
    const vec3 b[3] = {pt(1, 1, -1), pt(1, 1, 1), pt(3, 0.5, 0)};
    assert_int_equal(oracle_tri_tri(a, b), 1);
}

static void test_coplanar_triangles_overlapping_touching_and_one_ulp_apart(void **state)
{
    (void)state;
    const vec3 a[3] = {pt(0, 0, 0), pt(2, 0, 0), pt(0, 2, 0)};
    const vec3 overlapping[3] = {pt(0.5, 0.5, 0), pt(3, 0.5, 0), pt(0.5, 3, 0)};
    /* touches the hypotenuse x + y = 2 at (1, 1) only */
    const vec3 touching[3] = {pt(1, 1, 0), pt(3, 1, 0), pt(1, 3, 0)};
    const vec3 apart[3] = {pt(up(1), 1, 0), pt(3, 1, 0), pt(up(1), 3, 0)};
    assert_int_equal(oracle_tri_tri(a, overlapping), 1);
    assert_int_equal(oracle_tri_tri(a, touching), 1);
    assert_int_equal(oracle_tri_tri(a, apart), 0);
}

static void test_triangles_in_parallel_planes_one_ulp_apart_do_not_meet(void **state)
{
    (void)state;
    const vec3 a[3] = {pt(0, 0, 1), pt(2, 0, 1), pt(0, 2, 1)};
    const vec3 same_plane[3] = {pt(0, 0, 1), pt(-2, 0, 1), pt(0, -2, 1)};
    const vec3 next_plane[3] = {pt(0, 0, up(1)), pt(2, 0, up(1)), pt(0, 2, up(1))};
    assert_int_equal(oracle_tri_tri(a, same_plane), 1);
    assert_int_equal(oracle_tri_tri(a, next_plane), 0);
}

/* ---------- triangle against box ---------- */

static void test_triangle_touching_box_exactly_at_a_corner_and_one_ulp_away(void **state)
{
    (void)state;
    /* x + y + z = 3 meets [0,1]^3 at (1,1,1) only. */
    const vec3 slant[3] = {pt(3, 0, 0), pt(0, 3, 0), pt(0, 0, 3)};
    const vec3 slant_out[3] = {pt(up(3), 0, 0), pt(0, up(3), 0), pt(0, 0, up(3))};
    assert_int_equal(oracle_tri_box(slant, unit_box), 1);
    assert_int_equal(oracle_tri_box(slant_out, unit_box), 0);
    /* A triangle vertex on the corner. */
    const vec3 on_corner[3] = {pt(1, 1, 1), pt(2, 2, 1), pt(2, 1, 2)};
    const vec3 off_corner[3] = {pt(up(1), 1, 1), pt(2, 2, 1), pt(2, 1, 2)};
    assert_int_equal(oracle_tri_box(on_corner, unit_box), 1);
    assert_int_equal(oracle_tri_box(off_corner, unit_box), 0);
}

static void test_triangle_touching_box_along_an_edge_and_one_ulp_away(void **state)
{
    (void)state;
    /* In the plane x + y = 2, which holds the box edge x = y = 1. */
    const vec3 on_edge[3] = {pt(2, 0, -1), pt(0, 2, -1), pt(2, 0, 5)};
    const vec3 off_edge[3] = {pt(up(2), 0, -1), pt(0, up(2), -1), pt(up(2), 0, 5)};
    assert_int_equal(oracle_tri_box(on_edge, unit_box), 1);
    assert_int_equal(oracle_tri_box(off_edge, unit_box), 0);
}

static void test_triangle_on_box_face_plane_and_one_ulp_above(void **state)
{
    (void)state;
    const vec3 on_face[3] = {pt(0.5, 0.5, 1), pt(3, 0.5, 1), pt(0.5, 3, 1)};
    const vec3 above[3] = {pt(0.5, 0.5, up(1)), pt(3, 0.5, up(1)), pt(0.5, 3, up(1))};
    assert_int_equal(oracle_tri_box(on_face, unit_box), 1);
    assert_int_equal(oracle_tri_box(above, unit_box), 0);
}

static void test_triangle_through_box_with_every_vertex_outside_meets(void **state)
{
    (void)state;
    const vec3 slicing[3] = {pt(-1, 0.5, -1), pt(2, 0.5, -1), pt(0.5, 0.5, 3)};
    const vec3 covering[3] = {pt(-10, -10, 0.5), pt(10, -10, 0.5), pt(0, 10, 0.5)};
    const vec3 inside[3] = {pt(0.25, 0.25, 0.25), pt(0.75, 0.25, 0.5), pt(0.5, 0.75, 0.75)};
    const vec3 beside[3] = {pt(-1, 2, -1), pt(2, 2, -1), pt(0.5, 2, 3)};
    assert_int_equal(oracle_tri_box(slicing, unit_box), 1);
    assert_int_equal(oracle_tri_box(covering, unit_box), 1);
    assert_int_equal(oracle_tri_box(inside, unit_box), 1);
    assert_int_equal(oracle_tri_box(beside, unit_box), 0);
}

static void test_triangle_against_flat_box(void **state)
{
    (void)state;
    const box3 flat = {{0, 0, 0.5}, {1, 1, 0.5}}; /* a square, zero thickness */
    const vec3 through[3] = {pt(0.5, 0.5, 0), pt(0.5, 0.5, 1), pt(3, 3, 3)};
    const vec3 below[3] = {pt(0.5, 0.5, 0), pt(0.5, 0.5, down(0.5)), pt(3, 3, down(0.5))};
    assert_int_equal(oracle_tri_box(through, flat), 1);
    assert_int_equal(oracle_tri_box(below, flat), 0);
}

/* ---------- ray against triangle ---------- */

static const vec3 floor_tri[3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};

static void test_ray_through_triangle_vertex_hits_and_one_ulp_beside_misses(void **state)
{
    (void)state;
    const vec3 down_z = pt(0, 0, -1);
    assert_int_equal(oracle_ray_tri(pt(1, 0, 1), down_z, 0, INFINITY, floor_tri), 1);
    assert_int_equal(oracle_ray_tri(pt(up(1), 0, 1), down_z, 0, INFINITY, floor_tri), 0);
    assert_int_equal(oracle_ray_tri(pt(1, -tiny(), 1), down_z, 0, INFINITY, floor_tri), 0);
    assert_int_equal(oracle_ray_tri(pt(0, 0, 1), down_z, 0, INFINITY, floor_tri), 1);
    assert_int_equal(oracle_ray_tri(pt(-tiny(), 0, 1), down_z, 0, INFINITY, floor_tri), 0);
    /* Slanted onto the vertex (1, 0, 0); a direction one ulp steeper in x passes it. */
    assert_int_equal(oracle_ray_tri(pt(0, 0, 1), pt(1, 0, -1), 0, INFINITY, floor_tri), 1);
    assert_int_equal(oracle_ray_tri(pt(0, 0, 1), pt(up(1), 0, -1), 0, INFINITY, floor_tri), 0);
}

static void test_ray_through_triangle_edge_hits_and_one_ulp_outside_misses(void **state)
{
    (void)state;
    const vec3 down_z = pt(0, 0, -1);
    assert_int_equal(oracle_ray_tri(pt(0.5, 0.5, 1), down_z, 0, INFINITY, floor_tri), 1);
    assert_int_equal(oracle_ray_tri(pt(0.5, up(0.5), 1), down_z, 0, INFINITY, floor_tri), 0);
    assert_int_equal(oracle_ray_tri(pt(0.25, 0.5, 1), down_z, 0, INFINITY, floor_tri), 1);
}

/* The contact kind: the interior one ulp in from a vertex or an edge, the boundary on them,
 * a ray in the plane, a zero-area triangle, and a miss one ulp outside. */
static void test_ray_contact_kind_tells_interior_from_boundary(void **state)
{
    (void)state;
    const vec3 down_z = pt(0, 0, -1);
    const vec3 sliver[3] = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
    assert_int_equal(oracle_ray_tri_contact(pt(0.25, 0.25, 1), down_z, 0, INFINITY, floor_tri), ORACLE_RAY_INTERIOR);
    assert_int_equal(oracle_ray_tri_contact(pt(tiny(), tiny(), 1), down_z, 0, INFINITY, floor_tri), ORACLE_RAY_INTERIOR);
    assert_int_equal(oracle_ray_tri_contact(pt(0, 0, 1), down_z, 0, INFINITY, floor_tri), ORACLE_RAY_BOUNDARY);
    assert_int_equal(oracle_ray_tri_contact(pt(1, 0, 1), down_z, 0, INFINITY, floor_tri), ORACLE_RAY_BOUNDARY);
    assert_int_equal(oracle_ray_tri_contact(pt(0.5, 0.5, 1), down_z, 0, INFINITY, floor_tri), ORACLE_RAY_BOUNDARY);
    assert_int_equal(oracle_ray_tri_contact(pt(0.5, down(0.5), 1), down_z, 0, INFINITY, floor_tri),
                     ORACLE_RAY_INTERIOR);
    assert_int_equal(oracle_ray_tri_contact(pt(0.25, 0, 1), down_z, 0, INFINITY, floor_tri), ORACLE_RAY_BOUNDARY);
    assert_int_equal(oracle_ray_tri_contact(pt(0.5, up(0.5), 1), down_z, 0, INFINITY, floor_tri), ORACLE_RAY_MISS);
    /* In the plane, through the interior: not an interior crossing, whatever a rule says. */
    assert_int_equal(oracle_ray_tri_contact(pt(-1, 0.25, 0), pt(1, 0, 0), 0, INFINITY, floor_tri), ORACLE_RAY_IN_PLANE);
    assert_int_equal(oracle_ray_tri_contact(pt(-1, 0.25, tiny()), pt(1, 0, 0), 0, INFINITY, floor_tri), ORACLE_RAY_MISS);
    assert_int_equal(oracle_ray_tri_contact(pt(0.5, 1, 1), pt(0, 0, -1), 0, INFINITY, sliver), ORACLE_RAY_MISS);
    assert_int_equal(oracle_ray_tri_contact(pt(0.5, 0, 1), pt(0, 0, -1), 0, INFINITY, sliver), ORACLE_RAY_ZERO_AREA);
    /* An interior crossing at exactly t = tmax, and the interval one ulp short of it. */
    assert_int_equal(oracle_ray_tri_contact(pt(0.25, 0.25, 1), down_z, 0, 1, floor_tri), ORACLE_RAY_INTERIOR);
    assert_int_equal(oracle_ray_tri_contact(pt(0.25, 0.25, 1), down_z, 0, down(1), floor_tri), ORACLE_RAY_MISS);
}

static void test_ray_interval_excluding_exact_t_by_one_ulp_misses(void **state)
{
    (void)state;
    const vec3 o = pt(0.25, 0.25, 1), d = pt(0, 0, -1); /* meets at t = 1 */
    assert_int_equal(oracle_ray_tri(o, d, 0, 1, floor_tri), 1);
    assert_int_equal(oracle_ray_tri(o, d, 1, 1, floor_tri), 1);
    assert_int_equal(oracle_ray_tri(o, d, 1, INFINITY, floor_tri), 1);
    assert_int_equal(oracle_ray_tri(o, d, 0, down(1), floor_tri), 0);
    assert_int_equal(oracle_ray_tri(o, d, up(1), INFINITY, floor_tri), 0);
    assert_int_equal(oracle_ray_tri(o, d, up(1), 5, floor_tri), 0);
    assert_int_equal(oracle_ray_tri(o, d, 2, 1, floor_tri), 0); /* empty interval */
}

static void test_ray_interval_bounds_against_unrepresentable_t(void **state)
{
    (void)state;
    /* Meets z = 0 at t = 1/3; the double 1.0/3 lies below it. */
    const vec3 o = pt(0.25, 0.25, 1), d = pt(0, 0, -3);
    const double third = 1.0 / 3.0;
    assert_int_equal(oracle_ray_tri(o, d, 0, third, floor_tri), 0);
    assert_int_equal(oracle_ray_tri(o, d, 0, up(third), floor_tri), 1);
    assert_int_equal(oracle_ray_tri(o, d, third, INFINITY, floor_tri), 1);
    assert_int_equal(oracle_ray_tri(o, d, up(third), INFINITY, floor_tri), 0);
    assert_int_equal(oracle_ray_tri(o, d, third, up(third), floor_tri), 1);
}

static void test_ray_with_infinite_lower_bound(void **state)
{
    (void)state;
    const vec3 o = pt(0.25, 0.25, 1), d = pt(0, 0, 1); /* points away: t = -1 */
    assert_int_equal(oracle_ray_tri(o, d, 0, INFINITY, floor_tri), 0);
    assert_int_equal(oracle_ray_tri(o, d, -INFINITY, 0, floor_tri), 1);
    assert_int_equal(oracle_ray_tri(o, d, -INFINITY, -1, floor_tri), 1);
    assert_int_equal(oracle_ray_tri(o, d, -INFINITY, down(-1), floor_tri), 0);
    assert_int_equal(oracle_ray_tri(o, d, -INFINITY, INFINITY, floor_tri), 1);
    assert_int_equal(oracle_ray_tri(pt(2, 2, 1), d, -INFINITY, INFINITY, floor_tri), 0);
}

static void test_ray_in_triangle_plane_counts_boundary_contact(void **state)
{
    (void)state;
    const vec3 along_x = pt(1, 0, 0);
    assert_int_equal(oracle_ray_tri(pt(-1, 0.25, 0), along_x, 0, INFINITY, floor_tri), 1);
    assert_int_equal(oracle_ray_tri(pt(-1, 0.25, 0), along_x, 0, down(1), floor_tri), 0);
    assert_int_equal(oracle_ray_tri(pt(-1, 1, 0), along_x, 0, INFINITY, floor_tri), 1);
    assert_int_equal(oracle_ray_tri(pt(-1, up(1), 0), along_x, 0, INFINITY, floor_tri), 0);
    assert_int_equal(oracle_ray_tri(pt(-1, 0.25, tiny()), along_x, 0, INFINITY, floor_tri), 0);
}

static void test_ray_with_zero_direction_is_its_origin(void **state)
{
    (void)state;
    const vec3 still = pt(0, 0, 0);
    assert_int_equal(oracle_ray_tri(pt(0.25, 0.25, 0), still, 0, INFINITY, floor_tri), 1);
    assert_int_equal(oracle_ray_tri(pt(0.25, 0.25, tiny()), still, 0, INFINITY, floor_tri), 0);
    assert_int_equal(oracle_ray_tri(pt(0.25, 0.25, 0), still, 1, 0, floor_tri), 0);
}

/* ---------- plane parameter comparison ---------- */

static void tri_in_plane_z(double z, vec3 out[3])
{
    out[0] = pt(0, 0, z);
    out[1] = pt(1, 0, z);
    out[2] = pt(0, 1, z);
}

static void test_compare_plane_t_on_parallel_planes(void **state)
{
    (void)state;
    vec3 a[3], b[3];
    const vec3 o = pt(0.25, -7, 0), up_z = pt(0, 0, 1), down_z = pt(0, 0, -1);
    tri_in_plane_z(1, a);
    tri_in_plane_z(2, b);
    assert_int_equal(oracle_compare_plane_t(o, up_z, a, b), -1);
    assert_int_equal(oracle_compare_plane_t(o, up_z, b, a), 1);
    assert_int_equal(oracle_compare_plane_t(o, down_z, a, b), 1); /* t = -1 vs -2 */
    tri_in_plane_z(up(1), b);
    assert_int_equal(oracle_compare_plane_t(o, up_z, a, b), -1);
    tri_in_plane_z(0.5, a);
    tri_in_plane_z(-2, b);
    assert_int_equal(oracle_compare_plane_t(o, up_z, a, b), 1);
    tri_in_plane_z(1e-300, a);
    tri_in_plane_z(tiny(), b);
    assert_int_equal(oracle_compare_plane_t(o, up_z, a, b), 1);
    /* t = (1 - ulp)/3 against 1/3 along a non-unit direction */
    tri_in_plane_z(1, a);
    tri_in_plane_z(down(1), b);
    assert_int_equal(oracle_compare_plane_t(o, pt(0, 0, 3), a, b), 1);
}

static void test_compare_plane_t_ties_for_one_plane_whatever_the_triangle(void **state)
{
    (void)state;
    const vec3 a[3] = {pt(3, 0, 0), pt(0, 3, 0), pt(0, 0, 3)};   /* x + y + z = 3 */
    const vec3 flip[3] = {pt(0, 3, 0), pt(3, 0, 0), pt(1, 1, 1)}; /* same plane, wound back */
    const vec3 z1[3] = {pt(0, 0, 1), pt(1, 0, 1), pt(0, 1, 1)};   /* z = 1 */
    const vec3 o = pt(0, 0, 0), d = pt(1, 1, 1);                  /* meets both at t = 1 */
    assert_int_equal(oracle_compare_plane_t(o, d, a, flip), 0);
    assert_int_equal(oracle_compare_plane_t(o, d, a, z1), 0);
    assert_int_equal(oracle_compare_plane_t(o, pt(1, 1, up(1)), a, z1), 1);
}

/* ---------- seeded consistency checks ---------- */

/* splitmix64, kept local so the oracle's tests depend on nothing else under test. */
static uint64_t next_random(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static uint64_t test_seed(void)
{
    const char *env = getenv("TRIOCT_SEED");
    const uint64_t seed = env ? strtoull(env, NULL, 0) : 0x0AC1Eull;
    printf("test_oracle seed: %llu (set TRIOCT_SEED to rerun)\n", (unsigned long long)seed);
    return seed;
}

/* Small integers make touching cases common and keep differences exact. */
static vec3 random_grid_point(uint64_t *state)
{
    return pt((double)(next_random(state) % 5) - 2.0, (double)(next_random(state) % 5) - 2.0,
              (double)(next_random(state) % 5) - 2.0);
}

static void test_point_in_box_agrees_with_coordinate_comparison(void **state)
{
    (void)state;
    uint64_t rng = test_seed();
    const double values[] = {-tiny(), 0.0, tiny(), 0.5, down(1), 1.0, up(1), 2.0};
    const int nvalues = (int)(sizeof values / sizeof values[0]);
    int inside_seen = 0, outside_seen = 0;
    for (int i = 0; i < 200; i++) {
        const vec3 p = pt(values[next_random(&rng) % nvalues], values[next_random(&rng) % nvalues],
                          values[next_random(&rng) % nvalues]);
        const int expected = p.x >= 0 && p.x <= 1 && p.y >= 0 && p.y <= 1 && p.z >= 0 && p.z <= 1;
        inside_seen += expected;
        outside_seen += !expected;
        assert_int_equal(point_in_unit_cube(p), expected);
    }
    assert_true(inside_seen > 0 && outside_seen > 0);
}

static void test_segment_hull_agrees_with_ray_segment(void **state)
{
    (void)state;
    uint64_t rng = test_seed() + 1;
    int hits = 0, misses = 0;
    for (int i = 0; i < 400; i++) {
        vec3 tri[3], seg[2];
        for (int k = 0; k < 3; k++)
            tri[k] = random_grid_point(&rng);
        seg[0] = random_grid_point(&rng);
        seg[1] = random_grid_point(&rng);
        const vec3 d = pt(seg[1].x - seg[0].x, seg[1].y - seg[0].y, seg[1].z - seg[0].z);
        const int by_hull = oracle_hulls_intersect(seg, 2, tri, 3);
        assert_int_equal(oracle_ray_tri(seg[0], d, 0, 1, tri), by_hull);
        /* The same segment from its other end, with t running over [-1, 0]. */
        assert_int_equal(oracle_ray_tri(seg[1], d, -1, 0, tri), by_hull);
        hits += by_hull;
        misses += !by_hull;
    }
    assert_true(hits > 20 && misses > 20);
}

static void test_triangle_pairs_symmetric_and_invariant_under_relabelling(void **state)
{
    (void)state;
    uint64_t rng = test_seed() + 2;
    int hits = 0, misses = 0;
    for (int i = 0; i < 300; i++) {
        vec3 a[3], b[3];
        for (int k = 0; k < 3; k++) {
            a[k] = random_grid_point(&rng);
            b[k] = random_grid_point(&rng);
        }
        const int answer = oracle_tri_tri(a, b);
        const vec3 b_rotated[3] = {b[1], b[2], b[0]};
        const vec3 a_flipped[3] = {a[0], a[2], a[1]};
        /* Scaling by a power of two and shifting by an integer are exact. */
        vec3 a_moved[3], b_moved[3];
        for (int k = 0; k < 3; k++) {
            a_moved[k] = pt(a[k].x * 0.125 + 3, a[k].y * 0.125 - 5, a[k].z * 0.125 + 1);
            b_moved[k] = pt(b[k].x * 0.125 + 3, b[k].y * 0.125 - 5, b[k].z * 0.125 + 1);
        }
        assert_int_equal(oracle_tri_tri(b, a), answer);
        assert_int_equal(oracle_tri_tri(a_flipped, b_rotated), answer);
        assert_int_equal(oracle_tri_tri(a_moved, b_moved), answer);
        hits += answer;
        misses += !answer;
    }
    assert_true(hits > 20 && misses > 20);
}

/* The smallest common t, on cases whose value is known by construction: a crossing, an
 * in-plane entry through an edge, the far end of an interval behind the origin, tmin
 * inside, a single vertex, and no contact. */
static void test_first_t_known_by_construction(void **state)
{
    (void)state;
    const vec3 tri[3] = {pt(0, 0, 0), pt(3, 0, 0), pt(0, 3, 0)};
    /* Down onto (1, 1, 0) from z = 2.5: t = 2.5; one ulp either side compares so. */
    assert_int_equal(oracle_ray_tri_first_t_compare(pt(1, 1, 2.5), pt(0, 0, -1), 0, INFINITY, tri, 2.5), 0);
    assert_int_equal(oracle_ray_tri_first_t_compare(pt(1, 1, 2.5), pt(0, 0, -1), 0, INFINITY, tri, up(2.5)), -1);
    assert_int_equal(oracle_ray_tri_first_t_compare(pt(1, 1, 2.5), pt(0, 0, -1), 0, INFINITY, tri, down(2.5)), 1);
    /* In the plane along +x at y = 1 from x = -0.75: enters at x = 0, t = 0.75 / 0.5. */
    assert_true(oracle_ray_tri_first_t(pt(-0.75, 1, 0), pt(0.5, 0, 0), 0, INFINITY, tri) == 1.5);
    /* Backwards with tmin = -20: the interval x in [0, 2] is t in [-2.75, -0.75] * 2. */
    assert_true(oracle_ray_tri_first_t(pt(-0.75, 1, 0), pt(-0.5, 0, 0), -20, INFINITY, tri) == -5.5);
    /* tmin inside the interval: tmin itself. */
    assert_true(oracle_ray_tri_first_t(pt(-0.75, 1, 0), pt(0.5, 0, 0), 2, 3, tri) == 2);
    /* Only the vertex (0, 3, 0), along y = 3. */
    assert_true(oracle_ray_tri_first_t(pt(-1, 3, 0), pt(1, 0, 0), 0, INFINITY, tri) == 1);
    /* Above the hypotenuse: nothing. */
    assert_true(isnan(oracle_ray_tri_first_t(pt(-1, up(3), 0), pt(1, 0, 0), 0, INFINITY, tri)));
    assert_int_equal(oracle_ray_tri_first_t_compare(pt(-1, up(3), 0), pt(1, 0, 0), 0, INFINITY, tri, 1),
                     ORACLE_NO_CONTACT);
    /* Two triangles along one in-plane ray: the nearer entry first. */
    const vec3 far_tri[3] = {pt(5, 0, 0), pt(8, 0, 0), pt(5, 3, 0)};
    assert_int_equal(oracle_ray_tri_first_t_order(pt(-0.75, 1, 0), pt(0.5, 0, 0), 0, INFINITY, tri, far_tri), -1);
    assert_int_equal(oracle_ray_tri_first_t_order(pt(-0.75, 1, 0), pt(0.5, 0, 0), 0, INFINITY, far_tri, tri), 1);
    assert_int_equal(oracle_ray_tri_first_t_order(pt(-0.75, 1, 0), pt(0.5, 0, 0), 0, INFINITY, tri, tri), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_unit_cubes_apart_do_not_meet),
        cmocka_unit_test(test_unit_cubes_overlapping_meet),
        cmocka_unit_test(test_unit_cubes_sharing_a_face_meet_and_one_ulp_apart_do_not),
        cmocka_unit_test(test_unit_cubes_sharing_only_a_corner_meet_and_one_ulp_apart_do_not),
        cmocka_unit_test(test_point_inside_on_boundary_and_outside_unit_cube),
        cmocka_unit_test(test_point_on_slanted_face_of_tetrahedron_counts_and_one_ulp_out_does_not),
        cmocka_unit_test(test_single_points_meet_only_when_equal),
        cmocka_unit_test(test_repeated_points_make_dependent_columns_without_changing_the_answer),
        cmocka_unit_test(test_crossing_segments_meet_even_at_an_unrepresentable_point),
        cmocka_unit_test(test_segment_touching_at_an_endpoint_meets_and_one_ulp_off_does_not),
        cmocka_unit_test(test_skew_segments_do_not_meet),
        cmocka_unit_test(test_collinear_segments_overlapping_touching_and_disjoint),
        cmocka_unit_test(test_triangles_touching_at_one_vertex_meet_and_a_denormal_apart_do_not),
        cmocka_unit_test(test_triangle_vertex_on_other_face_meets_and_one_ulp_above_does_not),
        cmocka_unit_test(test_piercing_triangles_meet),
        cmocka_unit_test(test_coplanar_triangles_overlapping_touching_and_one_ulp_apart),
        cmocka_unit_test(test_triangles_in_parallel_planes_one_ulp_apart_do_not_meet),
        cmocka_unit_test(test_triangle_touching_box_exactly_at_a_corner_and_one_ulp_away),
        cmocka_unit_test(test_triangle_touching_box_along_an_edge_and_one_ulp_away),
        cmocka_unit_test(test_triangle_on_box_face_plane_and_one_ulp_above),
        cmocka_unit_test(test_triangle_through_box_with_every_vertex_outside_meets),
        cmocka_unit_test(test_triangle_against_flat_box),
        cmocka_unit_test(test_ray_through_triangle_vertex_hits_and_one_ulp_beside_misses),
        cmocka_unit_test(test_ray_through_triangle_edge_hits_and_one_ulp_outside_misses),
        cmocka_unit_test(test_ray_contact_kind_tells_interior_from_boundary),
        cmocka_unit_test(test_ray_interval_excluding_exact_t_by_one_ulp_misses),
        cmocka_unit_test(test_ray_interval_bounds_against_unrepresentable_t),
        cmocka_unit_test(test_ray_with_infinite_lower_bound),
        cmocka_unit_test(test_ray_in_triangle_plane_counts_boundary_contact),
        cmocka_unit_test(test_ray_with_zero_direction_is_its_origin),
        cmocka_unit_test(test_compare_plane_t_on_parallel_planes),
        cmocka_unit_test(test_compare_plane_t_ties_for_one_plane_whatever_the_triangle),
        cmocka_unit_test(test_point_in_box_agrees_with_coordinate_comparison),
        cmocka_unit_test(test_segment_hull_agrees_with_ray_segment),
        cmocka_unit_test(test_triangle_pairs_symmetric_and_invariant_under_relabelling),
        cmocka_unit_test(test_first_t_known_by_construction),
    };
    return cmocka_run_group_tests_name("oracle", tests, NULL, NULL);
}
