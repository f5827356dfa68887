#include "cli_render.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

int cli_parse_shade(const char *text, cli_shade *out)
{
    if (strcmp(text, "depth") == 0)
        *out = CLI_SHADE_DEPTH;
    else if (strcmp(text, "normal") == 0)
        *out = CLI_SHADE_NORMAL;
    else
        return -1;
    return 0;
}

const char *cli_shade_name(cli_shade shade)
{
    return shade == CLI_SHADE_NORMAL ? "normal" : "depth";
}

uint16_t cli_depth_sample(double t, double near, double far)
{
    if (!(far > near))
        return 65535;
    double s = 65535.0 * (far - t) / (far - near);
    if (!(s > 0.0))
        return 0;
    if (s >= 65535.0)
        return 65535;
    return (uint16_t)lround(s);
}

static uint16_t colour_of(double component)
{
    double c = (component + 1.0) * 0.5 * 255.0;
    if (!(c > 0.0))
        return 0;
    return c >= 255.0 ? 255 : (uint16_t)lround(c);
}

int cli_render_image(const cli_camera *cam, const double *t, const trioct_vec3 *normal, cli_shade shade,
                     cli_png_image *img, double *near, double *far)
{
    size_t pixels = (size_t)cam->width * (size_t)cam->height;
    img->width = cam->width;
    img->height = cam->height;
    img->channels = shade == CLI_SHADE_DEPTH ? 2 : 4;
    img->bit_depth = shade == CLI_SHADE_DEPTH ? 16 : 8;
    img->samples = calloc(pixels * (size_t)img->channels, sizeof *img->samples);
    if (img->samples == NULL)
        return -1;

    double lo = NAN, hi = NAN;
    for (size_t i = 0; i < pixels; i++) {
        if (isnan(t[i]))
            continue;
        if (isnan(lo) || t[i] < lo)
            lo = t[i];
        if (isnan(hi) || t[i] > hi)
            hi = t[i];
    }
    *near = lo;
    *far = hi;

    for (int y = 0; y < cam->height; y++)
        for (int x = 0; x < cam->width; x++) {
            size_t i = (size_t)y * (size_t)cam->width + (size_t)x;
            uint16_t *px = img->samples + i * (size_t)img->channels; /* calloc: a miss is clear */
            if (isnan(t[i]))
                continue;
            if (shade == CLI_SHADE_DEPTH) {
                px[0] = cli_depth_sample(t[i], lo, hi);
                px[1] = 65535;
                continue;
            }
            /* A triangle seen from its back shows its front's colour: the picture is of
             * the surface, whichever way its vertices were wound. */
            trioct_vec3 n = normal[i];
            trioct_vec3 d = cli_camera_ray(cam, x, y);
            if (n.x * d.x + n.y * d.y + n.z * d.z > 0.0)
                n = (trioct_vec3){-n.x, -n.y, -n.z};
            px[0] = colour_of(n.x);
            px[1] = colour_of(n.y);
            px[2] = colour_of(n.z);
            px[3] = 255;
        }
    return 0;
}
