/* Exact geometric predicates on double inputs: a floating-point filter decides the sign
 * when it can, and exact expansion arithmetic decides when it cannot. Every function
 * returns the sign (-1, 0, +1) of an exact real-number expression of its inputs. */
#ifndef TRIOCT_GEOM_PREDICATES_H
#define TRIOCT_GEOM_PREDICATES_H

#include <stdint.h>

#include "vec3.h"

/* sign of (a - c) x (b - c) = (ax-cx)(by-cy) - (ay-cy)(bx-cx): +1 when a, b, c turn
 * counter-clockwise. */
int orient2d(double ax, double ay, double bx, double by, double cx, double cy);

/* sign of det[b - a, c - a, d - a] = ((b-a) x (c-a)) . (d-a): +1 when d lies on the side
 * the normal of the counter-clockwise triangle a, b, c points to. */
int orient3d(vec3 a, vec3 b, vec3 c, vec3 d);

/* sign of (a - b)(c - d) - (e - f)(g - h): the shape of every 2D separating-axis test. */
int sign_diff_products(double a, double b, double c, double d,
                       double e, double f, double g, double h);

/* sign of ((p - o) x (q - o)) . dir: which side of the directed line through o along dir
 * the edge p->q passes (the ray-triangle edge function). */
int ray_edge_sign(vec3 p, vec3 q, vec3 o, vec3 dir);

/* The orient2d of a, b, c projected onto the plane normal to `axis` (0 = x, 1 = y, 2 = z),
 * with the projected coordinates taken in cyclic order (y,z), (z,x), (x,y). This is the
 * exact sign of component `axis` of (a - c) x (b - c). */
int orient2d_axis(vec3 a, vec3 b, vec3 c, int axis);

/* How many evaluations on this thread needed the exact fallback since the thread began.
 * Thread-local, so concurrent queries never share it; callers report differences. */
uint64_t predicates_fallback_count(void);
/* Called by exact fallbacks outside predicates.c so the count stays complete. */
void predicates_note_fallback(void);

#endif
