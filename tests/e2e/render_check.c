/* Checks a depth picture of `trioct render` against the daemon: it makes the rays of
 * sampled pixels again from the camera the file records (cli_camera), asks the daemon for
 * them, and requires every sampled pixel to be what its ray's answer encodes to
 * (cli_depth_sample): transparent for a miss, the grey of t for a hit. Run where the daemon
 * is heard (LCM_DEFAULT_URL), e.g. through scripts/demo-shell.
 *   render_check FILE.png [STRIDE]   every STRIDE-th pixel (default 7) is checked */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cli_args.h"
#include "cli/cli_camera.h"
#include "cli/cli_png.h"
#include "cli/cli_render.h"
#include "trioct.h"

static int text_vec3(const cli_png_image *img, const char *key, trioct_vec3 *out)
{
    const char *v = cli_png_text_get(img, key);
    double d[3];
    if (v == NULL || cli_parse_vec3(v, d) != 0) {
        fprintf(stderr, "render_check: the picture has no usable %s\n", key);
        return -1;
    }
    *out = (trioct_vec3){d[0], d[1], d[2]};
    return 0;
}

static int text_double(const cli_png_image *img, const char *key, double *out)
{
    const char *v = cli_png_text_get(img, key);
    if (v == NULL || cli_parse_double(v, 0, out) != 0) {
        fprintf(stderr, "render_check: the picture has no usable %s\n", key);
        return -1;
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc < 2 || argc > 3) {
        fprintf(stderr, "usage: render_check FILE.png [STRIDE]\n");
        return 2;
    }
    size_t stride = argc == 3 ? (size_t)strtoul(argv[2], NULL, 10) : 7;
    if (stride == 0)
        stride = 1;
    char err[512];
    cli_png_image img;
    if (cli_png_read(argv[1], &img, err, sizeof err) != 0) {
        fprintf(stderr, "render_check: %s\n", err);
        return 1;
    }
    const char *world = cli_png_text_get(&img, "trioct.world");
    const char *shade = cli_png_text_get(&img, "trioct.shade");
    trioct_vec3 eye, at, up;
    double fov, near, far;
    if (world == NULL || shade == NULL || strcmp(shade, "depth") != 0 || img.channels != 2 || img.bit_depth != 16 ||
        text_vec3(&img, "trioct.camera", &eye) || text_vec3(&img, "trioct.look_at", &at) ||
        text_vec3(&img, "trioct.up", &up) || text_double(&img, "trioct.fov", &fov) ||
        text_double(&img, "trioct.depth_near", &near) || text_double(&img, "trioct.depth_far", &far)) {
        fprintf(stderr, "render_check: %s is not a depth picture of trioct render with its camera\n", argv[1]);
        cli_png_image_free(&img);
        return 1;
    }
    cli_camera cam;
    if (cli_camera_init(&cam, eye, at, up, fov, img.width, img.height, err, sizeof err) != 0) {
        fprintf(stderr, "render_check: %s\n", err);
        cli_png_image_free(&img);
        return 1;
    }

    int status;
    trioct_client *c = trioct_connect(NULL, &status, err, sizeof err);
    if (c == NULL) {
        fprintf(stderr, "render_check: %s\n", err);
        cli_png_image_free(&img);
        return 1;
    }
    size_t pixels = (size_t)img.width * (size_t)img.height;
    size_t checked = 0, hits = 0, misses = 0, wrong = 0;
    trioct_vec3 origins[TRIOCT_MAX_RAYS], dirs[TRIOCT_MAX_RAYS];
    size_t which[TRIOCT_MAX_RAYS];
    for (size_t first = 0; first < pixels && wrong == 0;) {
        size_t n = 0;
        for (; first < pixels && n < TRIOCT_MAX_RAYS; first += stride, n++) {
            which[n] = first;
            origins[n] = eye;
            dirs[n] = cli_camera_ray(&cam, (int)(first % (size_t)img.width), (int)(first / (size_t)img.width));
        }
        trioct_ray_query q = trioct_ray_query_default(world);
        q.count = n;
        q.origins = origins;
        q.directions = dirs;
        trioct_ray_result res;
        if (trioct_rays(c, &q, 5000, &res) != TRIOCT_OK) {
            fprintf(stderr, "render_check: the daemon did not answer: %s\n", res.reply.message);
            trioct_ray_result_free(&res);
            wrong++;
            break;
        }
        double t[TRIOCT_MAX_RAYS];
        for (size_t k = 0; k < n; k++)
            t[k] = NAN;
        for (size_t h = 0; h < res.num_hits; h++)
            t[res.hits[h].ray] = res.hits[h].t;
        for (size_t k = 0; k < n; k++) {
            const uint16_t *px = img.samples + which[k] * 2;
            checked++;
            if (isnan(t[k])) {
                misses++;
                if (px[1] != 0) {
                    fprintf(stderr, "render_check: pixel %zu: the ray misses, the picture has grey %u alpha %u\n",
                            which[k], px[0], px[1]);
                    wrong++;
                }
                continue;
            }
            hits++;
            uint16_t want = cli_depth_sample(t[k], near, far);
            if (px[1] != 65535 || px[0] != want) {
                fprintf(stderr, "render_check: pixel %zu: the ray hits at t = %.17g (grey %u), the picture has "
                        "grey %u alpha %u\n", which[k], t[k], want, px[0], px[1]);
                wrong++;
            }
        }
        trioct_ray_result_free(&res);
    }
    trioct_disconnect(c);
    cli_png_image_free(&img);
    if (wrong > 0 || hits == 0 || misses == 0) {
        fprintf(stderr, "render_check: %zu of %zu sampled pixels differ (%zu hits, %zu misses; both must occur)\n",
                wrong, checked, hits, misses);
        return 1;
    }
    printf("render_check: %zu sampled pixels of %s (%zu hits, %zu misses) equal the daemon's answers\n", checked,
           argv[1], hits, misses);
    return 0;
}
