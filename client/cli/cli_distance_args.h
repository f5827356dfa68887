/* The options of `trioct distance` and `trioct clear`: points (--point x y z, repeatable),
 * or a shape (--shape NAME, --shape-file FILE) at poses (--pose, --poses as `trioct mesh`
 * reads them), and --within. Pure: scanned here, checked and sent by cli_cmd_distance.c. */
#ifndef TRIOCT_CLI_DISTANCE_ARGS_H
#define TRIOCT_CLI_DISTANCE_ARGS_H

#include <stddef.h>

#include "cli_args.h"
#include "cli_pose.h"
#include "trioct.h"

typedef struct cli_distance_args {
    trioct_vec3 *points; /* from --point, in order */
    size_t num_points, cap_points;
    double within;       /* --within; meaningful when has_within */
    int has_within;
    const char *shape;      /* --shape NAME: a query shape of the world's scene */
    const char *shape_file; /* --shape-file FILE: a mesh file's triangles, sent inline */
    cli_pose_list poses;    /* from --pose, in order */
    const char *poses_file; /* --poses FILE|- */
    int out_of_memory;
} cli_distance_args;

/* The option table and its handler (user: a cli_distance_args, zeroed to begin). */
extern const cli_option cli_distance_options[];
int cli_distance_option(void *user, int id, const char *value, char *err, size_t err_len);

/* What was asked for, once scanned: points or a shape, for `distance` (clear = 0) or
 * `clear` (clear = 1), which needs a shape and --within. 0, or -1 with the usage error. */
int cli_distance_check(const cli_distance_args *a, int clear, char *err, size_t err_len);

void cli_distance_args_free(cli_distance_args *a);

/* "face", "edge" or "vertex" for a TRIOCT_FEATURE_*; "unknown" for anything else. */
const char *cli_feature_name(int feature);

#endif
