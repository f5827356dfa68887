/* Scanning `trioct distance` and `trioct clear`: each --point's three numbers are one
 * option value (the scanner reads "-1" there as a number, not an option), each --pose the
 * text `trioct mesh` takes. */
#include "cli_distance_args.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { OPT_POINT, OPT_WITHIN, OPT_SHAPE, OPT_SHAPE_FILE, OPT_POSE, OPT_POSES };

const cli_option cli_distance_options[] = {
    {"point", 0, 3, OPT_POINT},
    {"within", 0, 1, OPT_WITHIN},
    {"shape", 0, 1, OPT_SHAPE},
    {"shape-file", 0, 1, OPT_SHAPE_FILE},
    {"pose", 0, 1, OPT_POSE},
    {"poses", 0, 1, OPT_POSES},
    {NULL, 0, 0, 0},
};

static int add_point(cli_distance_args *a, const double v[3])
{
    if (a->num_points == a->cap_points) {
        size_t cap = a->cap_points ? 2 * a->cap_points : 16;
        trioct_vec3 *grown = realloc(a->points, cap * sizeof *grown);
        if (grown == NULL)
            return -1;
        a->points = grown;
        a->cap_points = cap;
    }
    a->points[a->num_points++] = (trioct_vec3){v[0], v[1], v[2]};
    return 0;
}

/* An option that names one thing and may be given once. */
static int once(const char **slot, const char *value, const char *name, char *err, size_t err_len)
{
    if (*slot != NULL) {
        snprintf(err, err_len, "--%s given twice", name);
        return -1;
    }
    *slot = value;
    return 0;
}

int cli_distance_option(void *user, int id, const char *value, char *err, size_t err_len)
{
    cli_distance_args *a = user;
    switch (id) {
    case OPT_POINT: {
        double v[3];
        if (cli_parse_vec3(value, v) != 0) {
            snprintf(err, err_len, "--point '%.60s': expected three finite numbers x y z", value);
            return -1;
        }
        if (add_point(a, v) != 0)
            a->out_of_memory = 1;
        return 0;
    }
    case OPT_WITHIN: {
        double r;
        if (a->has_within) {
            snprintf(err, err_len, "--within given twice");
            return -1;
        }
        if (cli_parse_double(value, 1, &r) != 0 || !(r >= 0)) {
            snprintf(err, err_len, "--within '%.40s': expected a distance >= 0", value);
            return -1;
        }
        a->within = r;
        a->has_within = 1;
        return 0;
    }
    case OPT_SHAPE:
        if (!cli_name_valid(value, TRIOCT_MAX_NAME_LEN)) {
            snprintf(err, err_len, "--shape '%.40s' is not a shape name (1..%d of [A-Za-z0-9_])", value,
                     TRIOCT_MAX_NAME_LEN);
            return -1;
        }
        return once(&a->shape, value, "shape", err, err_len);
    case OPT_SHAPE_FILE:
        return once(&a->shape_file, value, "shape-file", err, err_len);
    case OPT_POSE: {
        trioct_pose pose;
        char why[256];
        if (cli_parse_pose(value, &pose, why, sizeof why) != 0) {
            snprintf(err, err_len, "--pose '%.60s': %s", value, why);
            return -1;
        }
        if (cli_pose_list_add(&a->poses, &pose) != 0)
            a->out_of_memory = 1;
        return 0;
    }
    case OPT_POSES:
        return once(&a->poses_file, value, "poses", err, err_len);
    }
    return -1;
}

int cli_distance_check(const cli_distance_args *a, int clear, char *err, size_t err_len)
{
    int shaped = a->shape != NULL || a->shape_file != NULL;
    int posed = a->poses.count > 0 || a->poses_file != NULL;
    if (a->shape != NULL && a->shape_file != NULL) {
        snprintf(err, err_len, "--shape and --shape-file exclude each other: give one");
        return -1;
    }
    if (shaped && a->num_points > 0) {
        snprintf(err, err_len, "--point and a shape exclude each other: ask points, or a shape at poses");
        return -1;
    }
    if (clear) {
        if (!shaped) {
            snprintf(err, err_len, "clear needs a shape: --shape NAME or --shape-file FILE, at --pose POSE");
            return -1;
        }
        if (!a->has_within) {
            snprintf(err, err_len, "clear needs --within R, the clearance radius");
            return -1;
        }
        return 0;
    }
    if (!shaped && a->num_points == 0) {
        snprintf(err, err_len, "nothing to ask: give --point x y z (repeatable), or --shape NAME with --pose POSE");
        return -1;
    }
    if (!shaped && posed) {
        snprintf(err, err_len, "--pose places a shape: give --shape NAME or --shape-file FILE with it");
        return -1;
    }
    return 0;
}

void cli_distance_args_free(cli_distance_args *a)
{
    free(a->points);
    cli_pose_list_free(&a->poses);
    memset(a, 0, sizeof *a);
}

const char *cli_feature_name(int feature)
{
    switch (feature) {
    case TRIOCT_FEATURE_FACE:
        return "face";
    case TRIOCT_FEATURE_EDGE:
        return "edge";
    case TRIOCT_FEATURE_VERTEX:
        return "vertex";
    default:
        return "unknown";
    }
}
