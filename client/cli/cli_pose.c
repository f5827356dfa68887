/* Poses from text (see cli_pose.h). */
#include "cli_pose.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cli_args.h"
#include "quaternion.h"
#include "cli_csv.h"

/* M_PI is XSI, not C11 or plain POSIX. */
static const double PI = 3.14159265358979323846;

/* cos and sin of an angle in degrees. cos(pi/2) in double is 6.1e-17, not 0, so a pose
 * "turned by 90" would move every vertex off the grid it was on. The angle is taken as whole
 * quarter turns, applied exactly by swapping and negating, plus a rest in [-45, 45] that
 * alone goes through cos and sin (and is 0 for multiples of 90). */
static void cos_sin_degrees(double degrees, double *c, double *s)
{
    double quarters = nearbyint(degrees / 90.0);
    double rest = (degrees - 90.0 * quarters) * (PI / 180.0);
    double cr = cos(rest), sr = sin(rest);
    long q = (long)fmod(quarters, 4.0);
    if (q < 0)
        q += 4;
    for (long i = 0; i < q; i++) { /* (c, s) of angle + 90 degrees */
        double t = cr;
        cr = -sr;
        sr = t;
    }
    *c = cr;
    *s = sr;
}

void cli_rotation_degrees(double rx, double ry, double rz, double r[9])
{
    double cx, sx, cy, sy, cz, sz;
    cos_sin_degrees(rx, &cx, &sx);
    cos_sin_degrees(ry, &cy, &sy);
    cos_sin_degrees(rz, &cz, &sz);
    /* Rz Ry Rx multiplied out. */
    r[0] = cz * cy;
    r[1] = cz * sy * sx - sz * cx;
    r[2] = cz * sy * cx + sz * sx;
    r[3] = sz * cy;
    r[4] = sz * sy * sx + cz * cx;
    r[5] = sz * sy * cx - cz * sx;
    r[6] = -sy;
    r[7] = cy * sx;
    r[8] = cy * cx;
    for (int i = 0; i < 9; i++)
        r[i] += 0.0; /* no -0 entries: a printed matrix says 0 */
}

/* The pose of v = x y z qw qx qy qz. The library's trioct_pose_from_quaternion makes the same
 * matrix; the header-only form keeps this file free of the library, as the parser's tests
 * link it alone. 0, or -1 with err. */
static int quaternion_pose(const double v[7], trioct_pose *out, char *err, size_t err_len)
{
    if (trioct_quaternion_matrix(v[3], v[4], v[5], v[6], out->r) != TRIOCT_QUATERNION_OK) {
        snprintf(err, err_len, "the quaternion (%g %g %g %g) is not of length 1 within 1e-3", v[3], v[4], v[5],
                 v[6]);
        return -1;
    }
    out->t = (trioct_vec3){v[0], v[1], v[2]};
    return 0;
}

int cli_parse_pose(const char *text, trioct_pose *out, char *err, size_t err_len)
{
    double v[7];
    char why[160];
    int n = cli_parse_numbers(text, v, 7, why, sizeof why);
    if (n != 3 && n != 6 && n != 7) {
        if (n >= 0)
            snprintf(why, sizeof why, "found %d", n);
        snprintf(err, err_len, "expected 3, 6 or 7 numbers \"tx ty tz [rx ry rz | qw qx qy qz]\" "
                 "(degrees or a quaternion): %s", why);
        return -1;
    }
    if (n == 7)
        return quaternion_pose(v, out, err, err_len);
    if (n == 3)
        v[3] = v[4] = v[5] = 0.0;
    cli_rotation_degrees(v[3], v[4], v[5], out->r);
    out->t = (trioct_vec3){v[0], v[1], v[2]};
    return 0;
}

int cli_pose_list_add(cli_pose_list *list, const trioct_pose *pose)
{
    if (list->count == list->cap) {
        size_t cap = list->cap ? list->cap * 2 : 64;
        trioct_pose *p = realloc(list->poses, cap * sizeof *p);
        if (p == NULL)
            return -1;
        list->poses = p;
        list->cap = cap;
    }
    list->poses[list->count++] = *pose;
    return 0;
}

int cli_read_poses(FILE *file, const char *name, cli_pose_list *list, char *err, size_t err_len)
{
    cli_line_reader reader;
    cli_line_reader_init(&reader, file, name);
    const char *line;
    int rc;
    while ((rc = cli_line_reader_next(&reader, &line, err, err_len)) == 1) {
        trioct_pose pose;
        char why[256];
        if (cli_parse_pose(line, &pose, why, sizeof why) != 0) {
            snprintf(err, err_len, "%s:%ld: %s", name, reader.line_no, why);
            rc = -1;
            break;
        }
        if (cli_pose_list_add(list, &pose) != 0) {
            snprintf(err, err_len, "%s:%ld: out of memory for %zu poses", name, reader.line_no,
                     list->count + 1);
            rc = -1;
            break;
        }
    }
    cli_line_reader_free(&reader);
    return rc < 0 ? -1 : 0;
}

void cli_pose_list_free(cli_pose_list *list)
{
    free(list->poses);
    memset(list, 0, sizeof *list);
}

int cli_parse_quaternion_pose(char *const text[7], const char *what, trioct_pose *out, double q[4], char *err,
                              size_t err_len)
{
    double v[7];
    for (int k = 0; k < 7; k++)
        if (cli_parse_double(text[k], 0, &v[k]) != 0) {
            snprintf(err, err_len, "%s: '%.40s' is not a finite number (x y z qw qx qy qz)", what, text[k]);
            return -1;
        }
    char why[160];
    if (quaternion_pose(v, out, why, sizeof why) != 0) {
        snprintf(err, err_len, "%s: %s", what, why);
        return -1;
    }
    if (q != NULL)
        memcpy(q, &v[3], 4 * sizeof *q);
    return 0;
}
