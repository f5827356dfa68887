/* Small value-type vector helpers used by every geometry file. */
#ifndef TRIOCT_GEOM_VEC3_H
#define TRIOCT_GEOM_VEC3_H

#include <math.h>

#include "../engine.h"

static inline vec3 vec3_make(double x, double y, double z) { return (vec3){x, y, z}; }
static inline vec3 vec3_add(vec3 a, vec3 b) { return (vec3){a.x + b.x, a.y + b.y, a.z + b.z}; }
static inline vec3 vec3_sub(vec3 a, vec3 b) { return (vec3){a.x - b.x, a.y - b.y, a.z - b.z}; }
static inline vec3 vec3_scale(vec3 a, double s) { return (vec3){a.x * s, a.y * s, a.z * s}; }
static inline double vec3_dot(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline vec3 vec3_cross(vec3 a, vec3 b)
{
    return (vec3){a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
static inline double vec3_length(vec3 a) { return sqrt(vec3_dot(a, a)); }
static inline vec3 vec3_normalize(vec3 a)
{
    double len = vec3_length(a);
    return len > 0.0 ? vec3_scale(a, 1.0 / len) : (vec3){0.0, 0.0, 0.0};
}
static inline vec3 vec3_min(vec3 a, vec3 b)
{
    return (vec3){a.x < b.x ? a.x : b.x, a.y < b.y ? a.y : b.y, a.z < b.z ? a.z : b.z};
}
static inline vec3 vec3_max(vec3 a, vec3 b)
{
    return (vec3){a.x > b.x ? a.x : b.x, a.y > b.y ? a.y : b.y, a.z > b.z ? a.z : b.z};
}
static inline vec3 vec3_abs(vec3 a) { return (vec3){fabs(a.x), fabs(a.y), fabs(a.z)}; }
static inline int vec3_is_finite(vec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }
static inline int vec3_equal(vec3 a, vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }
/* Component by axis index 0, 1, 2. */
static inline double vec3_get(vec3 a, int axis) { return axis == 0 ? a.x : axis == 1 ? a.y : a.z; }
/* a with component `axis` replaced by value. */
static inline vec3 vec3_with(vec3 a, int axis, double value)
{
    if (axis == 0)
        a.x = value;
    else if (axis == 1)
        a.y = value;
    else
        a.z = value;
    return a;
}

/* box3, the closed axis-aligned box, is engine.h's. */

#endif
