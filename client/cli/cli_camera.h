/* The pinhole camera of `trioct render`: one ray through the centre of every pixel, from
 * the eye, row 0 at the top of the image. Pure arithmetic, so a test (or a user checking a
 * picture) can make the very rays a render cast from the parameters it records. */
#ifndef TRIOCT_CLI_CAMERA_H
#define TRIOCT_CLI_CAMERA_H

#include <stddef.h>

#include "trioct.h"

#define CLI_CAMERA_MAX_SIDE 16384 /* pixels a side: 268 million rays at most */

typedef struct cli_camera {
    trioct_vec3 eye;
    trioct_vec3 forward, right, up; /* unit vectors: view direction, image x and image -y */
    double half_height;             /* tan(fov / 2): half the image plane at distance 1 */
    double half_width;              /* half_height * width / height */
    int width, height;
} cli_camera;

/* Sets up a camera at eye looking at look_at, with up the direction that points to the
 * top of the image (it need not be perpendicular to the view, only not parallel to it),
 * fov_deg the vertical field of view (0 < fov < 180) and the image size. Returns 0, or -1
 * with why in err when the parameters make no camera. */
int cli_camera_init(cli_camera *c, trioct_vec3 eye, trioct_vec3 look_at, trioct_vec3 up,
                    double fov_deg, int width, int height, char *err, size_t err_len);

/* The unit direction of the ray through the centre of pixel (x, y); t along it is the
 * distance from the eye. */
trioct_vec3 cli_camera_ray(const cli_camera *c, int x, int y);

/* Parses "WxH" (1..CLI_CAMERA_MAX_SIDE each). 0, or -1. */
int cli_parse_size(const char *s, int *width, int *height);

#endif
