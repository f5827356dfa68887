/* The one rotation matrix of a quaternion, for the engine's poses and the client's alike,
 * so that a pose given as a quaternion is the same matrix wherever it is made. Header-only:
 * the engine links nothing of the client's and the client nothing of the engine's. */
#ifndef TRIOCT_QUATERNION_H
#define TRIOCT_QUATERNION_H

#include <math.h>

/* How far a quaternion's length may be from 1: past it, a caller's mistake (a degree for a
 * radian, a missing component), not rounding, and refused so that it cannot pass as a
 * rotation. */
#define TRIOCT_QUATERNION_TOLERANCE 1e-3

typedef enum trioct_quaternion_status {
    TRIOCT_QUATERNION_OK = 0,
    TRIOCT_QUATERNION_NONFINITE = -1, /* a NaN or infinite component */
    TRIOCT_QUATERNION_NOT_UNIT = -2,  /* length not 1 within TRIOCT_QUATERNION_TOLERANCE */
} trioct_quaternion_status;

/* r: the row-major rotation matrix of (qw, qx, qy, qz) normalised.
 *
 * Each product of two components is divided by the squared length rather than each
 * component by the length first. A quarter turn about an axis has two components of one
 * magnitude a and two zeros, so every entry is 0 or +-(2 a a) / (2 a a): exactly 0, 1 or -1,
 * as the same pose given in degrees is (cli_rotation_degrees), however a = sqrt(1/2) was
 * rounded when typed; half turns and the turns with components +-1/2 are exact as well.
 * Scaling by 1 / length first leaves entries such as -2.2e-16 and -1.0000000000000002,
 * enough to move a resting contact. */
static inline trioct_quaternion_status trioct_quaternion_matrix(double qw, double qx, double qy, double qz,
                                                                double r[9])
{
    if (!isfinite(qw) || !isfinite(qx) || !isfinite(qy) || !isfinite(qz))
        return TRIOCT_QUATERNION_NONFINITE;
    double n2 = qw * qw + qx * qx + qy * qy + qz * qz;
    double n = sqrt(n2);
    if (!(n >= 1.0 - TRIOCT_QUATERNION_TOLERANCE && n <= 1.0 + TRIOCT_QUATERNION_TOLERANCE))
        return TRIOCT_QUATERNION_NOT_UNIT;
    double w = qw, x = qx, y = qy, z = qz; /* not scaled: see above */
    r[0] = 1 - 2 * (y * y + z * z) / n2;
    r[1] = 2 * (x * y - w * z) / n2;
    r[2] = 2 * (x * z + w * y) / n2;
    r[3] = 2 * (x * y + w * z) / n2;
    r[4] = 1 - 2 * (x * x + z * z) / n2;
    r[5] = 2 * (y * z - w * x) / n2;
    r[6] = 2 * (x * z - w * y) / n2;
    r[7] = 2 * (y * z + w * x) / n2;
    r[8] = 1 - 2 * (x * x + y * y) / n2;
    for (int i = 0; i < 9; i++)
        r[i] += 0.0; /* no -0 entries (a half turn's zeros): a printed matrix says 0 */
    return TRIOCT_QUATERNION_OK;
}

#endif
