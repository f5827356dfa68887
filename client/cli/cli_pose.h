/* Poses for `trioct mesh`: "tx ty tz [rx ry rz]" (a translation and rotation angles in
 * degrees) or "tx ty tz qw qx qy qz" (a translation and a quaternion) on the command line or
 * one per line of a file. Pure. */
#ifndef TRIOCT_CLI_POSE_H
#define TRIOCT_CLI_POSE_H

#include <stddef.h>
#include <stdio.h>

#include "trioct.h"

/* R = Rz Ry Rx, row-major: rotate about the fixed x axis first, then y, then z (the scene
 * files' `rotate` convention). Exact at every multiple of 90 degrees: entries 0, 1, -1. */
void cli_rotation_degrees(double rx, double ry, double rz, double r[9]);

/* Parses "tx ty tz", "tx ty tz rx ry rz" or "tx ty tz qw qx qy qz" (blanks or commas); the
 * quaternion is normalised and refused off unit length as cli_parse_quaternion_pose does.
 * 0, or -1 with err. */
int cli_parse_pose(const char *text, trioct_pose *out, char *err, size_t err_len);

/* Seven arguments "x y z qw qx qy qz": a position and a quaternion, normalised as the
 * daemon would (trioct_pose_from_quaternion) into *out, and the quaternion as given into q
 * (may be NULL), which is what is sent. 0, or -1 with err (what names the option). */
int cli_parse_quaternion_pose(char *const text[7], const char *what, trioct_pose *out, double q[4], char *err,
                              size_t err_len);

typedef struct cli_pose_list {
    size_t count, cap;
    trioct_pose *poses;
} cli_pose_list;

/* Appends a pose. 0, or -1 when out of memory. */
int cli_pose_list_add(cli_pose_list *list, const trioct_pose *pose);

/* Appends the poses of a file, one a line as cli_parse_pose reads them (blank lines and #
 * comments skipped). 0, or -1 with err naming the line ("poses.csv:3: expected 3, 6 or 7
 * numbers ...: found 4"). */
int cli_read_poses(FILE *file, const char *name, cli_pose_list *list, char *err, size_t err_len);
void cli_pose_list_free(cli_pose_list *list);

#endif
