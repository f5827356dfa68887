/* Nearest points in plain doubles (closest_point.h): the region tests of a point against
 * a triangle's vertex, edge and face regions in turn (each from dot products with the
 * edges), and two segments' clamped normal equations. */
#include "closest_point.h"

#include "vec3.h"

vec3 closest_point_on_triangle(vec3 p, const vec3 t[3], double *v_out, double *w_out, closest_region *region)
{
    vec3 ab = vec3_sub(t[1], t[0]), ac = vec3_sub(t[2], t[0]), ap = vec3_sub(p, t[0]);
    double d1 = vec3_dot(ab, ap), d2 = vec3_dot(ac, ap);
    double v = 0, w = 0;
    *region = (closest_region){DISTANCE_VERTEX, 0};
    if (d1 <= 0 && d2 <= 0)
        goto done;
    vec3 bp = vec3_sub(p, t[1]);
    double d3 = vec3_dot(ab, bp), d4 = vec3_dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) {
        v = 1;
        *region = (closest_region){DISTANCE_VERTEX, 1};
        goto done;
    }
    double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) {
        v = d1 / (d1 - d3);
        *region = (closest_region){DISTANCE_EDGE, 0};
        goto done;
    }
    vec3 cp = vec3_sub(p, t[2]);
    double d5 = vec3_dot(ab, cp), d6 = vec3_dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) {
        w = 1;
        *region = (closest_region){DISTANCE_VERTEX, 2};
        goto done;
    }
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) {
        w = d2 / (d2 - d6);
        *region = (closest_region){DISTANCE_EDGE, 2};
        goto done;
    }
    double va = d3 * d6 - d5 * d4;
    if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        v = 1 - w;
        *region = (closest_region){DISTANCE_EDGE, 1};
        goto done;
    }
    double sum = va + vb + vc;
    v = vb / sum;
    w = vc / sum;
    *region = (closest_region){DISTANCE_FACE, 0};
    if (!(v >= 0 && w >= 0 && v + w <= 1)) { /* no area, or rounding: take the vertex */
        v = w = 0;
        *region = (closest_region){DISTANCE_VERTEX, 0};
    }
done:
    *v_out = clamp01(v);
    *w_out = clamp01(w);
    return (vec3){t[0].x + *v_out * ab.x + *w_out * ac.x, t[0].y + *v_out * ab.y + *w_out * ac.y,
                  t[0].z + *v_out * ab.z + *w_out * ac.z};
}

void closest_points_on_segments(vec3 p1, vec3 q1, vec3 p2, vec3 q2, double *s_out, double *t_out)
{
    vec3 d1 = vec3_sub(q1, p1), d2 = vec3_sub(q2, p2), r = vec3_sub(p1, p2);
    double a = vec3_dot(d1, d1), e = vec3_dot(d2, d2), f = vec3_dot(d2, r);
    double s = 0, t = 0;
    if (a == 0 && e == 0) {
        /* two points */
    } else if (a == 0) {
        t = clamp01(f / e);
    } else {
        double c = vec3_dot(d1, r);
        if (e == 0) {
            s = clamp01(-c / a);
        } else {
            double b = vec3_dot(d1, d2), denom = a * e - b * b;
            s = denom > 0 ? clamp01((b * f - c * e) / denom) : 0.0;
            t = (b * s + f) / e;
            if (t < 0) {
                t = 0;
                s = clamp01(-c / a);
            } else if (t > 1) {
                t = 1;
                s = clamp01((b - c) / a);
            }
            t = clamp01(t);
        }
    }
    *s_out = s;
    *t_out = t;
}

