#include "cli_camera.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

/* M_PI is XSI, not C11 or plain POSIX. */
static const double PI = 3.14159265358979323846;

static trioct_vec3 sub(trioct_vec3 a, trioct_vec3 b)
{
    return (trioct_vec3){a.x - b.x, a.y - b.y, a.z - b.z};
}

static trioct_vec3 cross(trioct_vec3 a, trioct_vec3 b)
{
    return (trioct_vec3){a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

static double length(trioct_vec3 a)
{
    return sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
}

static trioct_vec3 scale(trioct_vec3 a, double s)
{
    return (trioct_vec3){a.x * s, a.y * s, a.z * s};
}

int cli_camera_init(cli_camera *c, trioct_vec3 eye, trioct_vec3 look_at, trioct_vec3 up,
                    double fov_deg, int width, int height, char *err, size_t err_len)
{
    if (!(fov_deg > 0.0 && fov_deg < 180.0)) {
        snprintf(err, err_len, "the field of view must be between 0 and 180 degrees, not %g", fov_deg);
        return -1;
    }
    if (width < 1 || height < 1 || width > CLI_CAMERA_MAX_SIDE || height > CLI_CAMERA_MAX_SIDE) {
        snprintf(err, err_len, "the image must be 1..%d pixels a side, not %dx%d", CLI_CAMERA_MAX_SIDE,
                 width, height);
        return -1;
    }
    trioct_vec3 view = sub(look_at, eye);
    double view_len = length(view);
    if (!(view_len > 0.0) || !isfinite(view_len)) {
        snprintf(err, err_len, "the camera and the point it looks at must differ (and be finite)");
        return -1;
    }
    trioct_vec3 forward = scale(view, 1.0 / view_len);
    /* The up vector only says which way is up: what of it is perpendicular to the view. */
    trioct_vec3 right = cross(forward, up);
    double right_len = length(right);
    double up_len = length(up);
    if (!(up_len > 0.0) || !isfinite(up_len) || !(right_len > 1e-9 * up_len)) {
        snprintf(err, err_len, "the up direction must not be zero or parallel to the view (give --up)");
        return -1;
    }
    c->eye = eye;
    c->forward = forward;
    c->right = scale(right, 1.0 / right_len);
    c->up = cross(c->right, forward); /* unit: right and forward are perpendicular units */
    c->half_height = tan(fov_deg * (PI / 360.0));
    c->half_width = c->half_height * (double)width / (double)height;
    c->width = width;
    c->height = height;
    return 0;
}

trioct_vec3 cli_camera_ray(const cli_camera *c, int x, int y)
{
    /* The pixel's centre on the image plane at distance 1, in [-1, 1] each way. */
    double sx = (2.0 * ((double)x + 0.5) / (double)c->width - 1.0) * c->half_width;
    double sy = (1.0 - 2.0 * ((double)y + 0.5) / (double)c->height) * c->half_height;
    trioct_vec3 d = {
        c->forward.x + sx * c->right.x + sy * c->up.x,
        c->forward.y + sx * c->right.y + sy * c->up.y,
        c->forward.z + sx * c->right.z + sy * c->up.z,
    };
    return scale(d, 1.0 / length(d));
}

int cli_parse_size(const char *s, int *width, int *height)
{
    char *end;
    errno = 0;
    long w = strtol(s, &end, 10);
    if (end == s || (*end != 'x' && *end != 'X') || errno != 0 || s[0] == '-' || s[0] == '+')
        return -1;
    const char *h_at = end + 1;
    if (*h_at < '0' || *h_at > '9')
        return -1;
    long h = strtol(h_at, &end, 10);
    if (*end != '\0' || errno != 0 || w < 1 || h < 1 || w > CLI_CAMERA_MAX_SIDE || h > CLI_CAMERA_MAX_SIDE)
        return -1;
    *width = (int)w;
    *height = (int)h;
    return 0;
}
