/* What `trioct render` makes of a camera sweep's answers: a depth or a normal picture.
 * Pure, so its encoding is tested without a daemon.
 *
 * depth: 16-bit grey and alpha. Grey is the distance from the camera, linear between the
 *   nearest hit (65535, white) and the farthest (0, black); the two distances are stored in
 *   the file's text chunks (trioct.depth_near, trioct.depth_far), so a depth can be read
 *   back to within (far - near) / 65535.
 * normal: 8-bit RGBA. The hit triangle's unit normal n, turned to face the camera, as
 *   colour ((n + 1) / 2 * 255 each axis: x red, y green, z blue).
 * A ray that hit nothing leaves its pixel transparent (alpha 0) in both. */
#ifndef TRIOCT_CLI_RENDER_H
#define TRIOCT_CLI_RENDER_H

#include <stddef.h>
#include <stdint.h>

#include "cli_camera.h"
#include "cli_png.h"

typedef enum cli_shade {
    CLI_SHADE_DEPTH,
    CLI_SHADE_NORMAL,
} cli_shade;

/* "depth" or "normal". 0, or -1. */
int cli_parse_shade(const char *text, cli_shade *out);
const char *cli_shade_name(cli_shade shade);

/* The grey of a hit at distance t when the nearest hit is at near and the farthest at far:
 * round(65535 * (far - t) / (far - near)), 65535 when far == near. */
uint16_t cli_depth_sample(double t, double near, double far);

/* Makes the picture of a sweep of cam: per pixel (row by row from the top) t, NaN for a
 * miss, and the normal of the triangle hit. Sets img's size and samples (allocated; the
 * caller frees them with cli_png_image_free) and *near and *far (NaN when nothing was hit).
 * Returns 0, or -1 out of memory. */
int cli_render_image(const cli_camera *cam, const double *t, const trioct_vec3 *normal, cli_shade shade,
                     cli_png_image *img, double *near, double *far);

#endif
