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

/* r: the row-major rotation matrix of (qw, qx, qy, qz) normalised. */
static inline trioct_quaternion_status trioct_quaternion_matrix(double qw, double qx, double qy, double qz,
                                                                double r[9])
{
    if (!isfinite(qw) || !isfinite(qx) || !isfinite(qy) || !isfinite(qz))
        return TRIOCT_QUATERNION_NONFINITE;
    double n = sqrt(qw * qw + qx * qx + qy * qy + qz * qz);
    if (!(n >= 1.0 - TRIOCT_QUATERNION_TOLERANCE && n <= 1.0 + TRIOCT_QUATERNION_TOLERANCE))
        return TRIOCT_QUATERNION_NOT_UNIT;
    double w = qw / n, x = qx / n, y = qy / n, z = qz / n;
    r[0] = 1 - 2 * (y * y + z * z);
    r[1] = 2 * (x * y - w * z);
    r[2] = 2 * (x * z + w * y);
    r[3] = 2 * (x * y + w * z);
    r[4] = 1 - 2 * (x * x + z * z);
    r[5] = 2 * (y * z - w * x);
    r[6] = 2 * (x * z - w * y);
    r[7] = 2 * (y * z + w * x);
    r[8] = 1 - 2 * (x * x + y * y);
    return TRIOCT_QUATERNION_OK;
}

#endif
