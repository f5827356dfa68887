/* `trioct render`: a picture of a world as a camera sees it. One ray through every pixel,
 * cast in requests of TRIOCT_MAX_RAYS (the closest hit each), and the answers written as a
 * depth or normal PNG (cli_render.h says how each is encoded). The file's text chunks keep
 * the camera, so the rays of any pixel can be made again (cli_camera.h) and checked. */
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cli_batch.h"
#include "cli_camera.h"
#include "cli_png.h"
#include "cli_progress.h"
#include "cli_render.h"
#include "cli_text.h"

enum { OPT_CAMERA, OPT_LOOK_AT, OPT_UP, OPT_FOV, OPT_SIZE, OPT_OUTPUT, OPT_SHADE, OPT_ACCURACY };

typedef struct render_args {
    double camera[3], look_at[3], up[3];
    int have_camera, have_look_at;
    double fov;
    int width, height;
    const char *output;
    cli_shade shade;
    int accuracy;
} render_args;

static const cli_option render_options[] = {
    {"camera", 0, 3, OPT_CAMERA},
    {"look-at", 0, 3, OPT_LOOK_AT},
    {"up", 0, 3, OPT_UP},
    {"fov", 0, 1, OPT_FOV},
    {"size", 0, 1, OPT_SIZE},
    {"output", 'o', 1, OPT_OUTPUT},
    {"shade", 0, 1, OPT_SHADE},
    {"accuracy", 0, 1, OPT_ACCURACY},
    {NULL, 0, 0, 0},
};

static int render_option(void *user, int id, const char *value, char *err, size_t err_len)
{
    render_args *a = user;
    switch (id) {
    case OPT_CAMERA:
    case OPT_LOOK_AT:
    case OPT_UP: {
        static const char *const names[] = {"--camera", "--look-at", "--up"};
        double *to = id == OPT_CAMERA ? a->camera : id == OPT_LOOK_AT ? a->look_at : a->up;
        if (cli_parse_vec3(value, to) != 0) {
            snprintf(err, err_len, "%s: '%.60s' is not three finite numbers x y z", names[id - OPT_CAMERA], value);
            return -1;
        }
        a->have_camera |= id == OPT_CAMERA;
        a->have_look_at |= id == OPT_LOOK_AT;
        return 0;
    }
    case OPT_FOV:
        if (cli_parse_double(value, 0, &a->fov) != 0 || !(a->fov > 0.0 && a->fov < 180.0)) {
            snprintf(err, err_len, "--fov: '%.40s' is not an angle in degrees between 0 and 180", value);
            return -1;
        }
        return 0;
    case OPT_SIZE:
        if (cli_parse_size(value, &a->width, &a->height) != 0) {
            snprintf(err, err_len, "--size: '%.40s' is not WIDTHxHEIGHT, 1..%d pixels each", value,
                     CLI_CAMERA_MAX_SIDE);
            return -1;
        }
        return 0;
    case OPT_OUTPUT:
        if (value[0] == '\0') {
            snprintf(err, err_len, "-o: the file name is empty");
            return -1;
        }
        a->output = value;
        return 0;
    case OPT_SHADE:
        if (cli_parse_shade(value, &a->shade) != 0) {
            snprintf(err, err_len, "--shade: '%.40s' is not depth or normal", value);
            return -1;
        }
        return 0;
    case OPT_ACCURACY:
        return cli_accuracy_option(value, &a->accuracy, err, err_len);
    }
    return -1;
}

/* The answers of the sweep, pixel by pixel. */
typedef struct sweep {
    double *t;           /* NaN: the pixel's ray hit nothing */
    trioct_vec3 *normal;
    size_t hits;
    cli_batch batch;
} sweep;

static int cast_sweep(cli_context *ctx, const char *world, const render_args *a, const cli_camera *cam, sweep *s)
{
    size_t pixels = (size_t)cam->width * (size_t)cam->height;
    s->t = malloc(pixels * sizeof *s->t);
    s->normal = calloc(pixels, sizeof *s->normal);
    trioct_vec3 *origins = malloc(TRIOCT_MAX_RAYS * sizeof *origins);
    trioct_vec3 *directions = malloc(TRIOCT_MAX_RAYS * sizeof *directions);
    if (s->t == NULL || s->normal == NULL || origins == NULL || directions == NULL) {
        free(origins);
        free(directions);
        return cli_internal_error(ctx, "out of memory for %zu rays", pixels);
    }
    for (size_t i = 0; i < TRIOCT_MAX_RAYS; i++)
        origins[i] = cam->eye;

    trioct_ray_query q = trioct_ray_query_default(world);
    q.accuracy = a->accuracy;
    q.origins = origins;
    q.directions = directions;
    int timeout = cli_timeout(ctx, CLI_DEFAULT_TIMEOUT_MS);
    cli_progress progress;
    cli_progress_begin(&progress, ctx->err, cli_progress_mode_for(ctx->err, ctx->progress), "rays", pixels,
                       cli_now_ns());
    int rc = CLI_EXIT_OK;
    for (size_t done = 0; done < pixels && rc == CLI_EXIT_OK;) {
        size_t n = pixels - done < TRIOCT_MAX_RAYS ? pixels - done : TRIOCT_MAX_RAYS;
        for (size_t k = 0; k < n; k++) {
            size_t p = done + k;
            directions[k] = cli_camera_ray(cam, (int)(p % (size_t)cam->width), (int)(p / (size_t)cam->width));
            s->t[p] = NAN;
        }
        q.count = n;
        trioct_ray_result res;
        int status = trioct_rays(ctx->client, &q, timeout, &res);
        if (status != TRIOCT_OK) {
            char part[96];
            snprintf(part, sizeof part, "rays %zu..%zu of %zu", done, done + n - 1, pixels);
            rc = cli_report_failure(ctx, &res.reply, timeout, pixels > n ? part : NULL);
        } else {
            for (size_t h = 0; h < res.num_hits; h++) {
                const trioct_ray_hit *hit = &res.hits[h];
                if (hit->ray < 0 || (size_t)hit->ray >= n)
                    continue; /* the library checked the reply; this cannot be */
                s->t[done + (size_t)hit->ray] = hit->t;
                s->normal[done + (size_t)hit->ray] = hit->normal;
                s->hits++;
            }
            cli_batch_note(&s->batch, &res.reply);
        }
        trioct_ray_result_free(&res);
        done += n;
        cli_progress_update(&progress, done, cli_now_ns());
    }
    cli_progress_end(&progress, pixels, cli_now_ns());
    free(origins);
    free(directions);
    if (rc == CLI_EXIT_OK)
        cli_batch_warn_rebuilt(ctx, &s->batch, world);
    return rc;
}

static void add_text(cli_png_image *img, const char *key, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void add_text(cli_png_image *img, const char *key, const char *fmt, ...)
{
    if (img->num_text == CLI_PNG_MAX_TEXT)
        return;
    cli_png_text *t = &img->text[img->num_text++];
    snprintf(t->key, sizeof t->key, "%s", key);
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(t->value, sizeof t->value, fmt, ap);
    va_end(ap);
}

/* Every parameter of the picture, exactly (%.17g reads back to the same double). */
static void describe(cli_png_image *img, const char *world, const render_args *a, const sweep *s, double near,
                     double far)
{
    add_text(img, "Software", "trioct %s", TRIOCT_VERSION);
    add_text(img, "trioct.world", "%s", world);
    add_text(img, "trioct.world_version", "%" PRId64, s->batch.first_version);
    add_text(img, "trioct.camera", "%.17g %.17g %.17g", a->camera[0], a->camera[1], a->camera[2]);
    add_text(img, "trioct.look_at", "%.17g %.17g %.17g", a->look_at[0], a->look_at[1], a->look_at[2]);
    add_text(img, "trioct.up", "%.17g %.17g %.17g", a->up[0], a->up[1], a->up[2]);
    add_text(img, "trioct.fov", "%.17g", a->fov);
    add_text(img, "trioct.shade", "%s", cli_shade_name(a->shade));
    add_text(img, "trioct.accuracy", "%s", cli_accuracy_name(a->accuracy));
    if (a->shade == CLI_SHADE_DEPTH && !isnan(near)) {
        add_text(img, "trioct.depth_near", "%.17g", near);
        add_text(img, "trioct.depth_far", "%.17g", far);
    }
}

static void render_json(cli_context *ctx, const char *world, const render_args *a, const sweep *s, double near,
                        double far)
{
    trioct_reply reply = s->batch.reply;
    reply.world_version = s->batch.first_version;
    snprintf(reply.world, sizeof reply.world, "%s", world);
    cli_json j;
    cli_json_init(&j, ctx->out);
    cli_json_envelope(&j, ctx, CLI_EXIT_OK, &reply);
    cli_json_key_string(&j, "output", a->output);
    cli_json_key_string(&j, "shade", cli_shade_name(a->shade));
    cli_json_key_int(&j, "width", a->width);
    cli_json_key_int(&j, "height", a->height);
    cli_json_key_int(&j, "rays", (int64_t)a->width * a->height);
    cli_json_key_int(&j, "requests", (int64_t)s->batch.requests);
    cli_json_key_int(&j, "hit_rays", (int64_t)s->hits);
    cli_json_key_double(&j, "depth_near", near); /* null when nothing was hit */
    cli_json_key_double(&j, "depth_far", far);
    cli_json_finish(&j);
}

static int run_render(cli_context *ctx, int argc, char **argv)
{
    render_args a = {.up = {0, 0, 1}, .fov = 60.0, .width = 640, .height = 480, .accuracy = TRIOCT_ACCURACY_WORLD};
    char *pos[CLI_MAX_POSITIONAL];
    int npos;
    int rc = cli_command_args(ctx, &cli_command_render, argc, argv, render_options, render_option, &a, pos, &npos);
    if (rc >= 0)
        return rc;
    if (npos != 1)
        return cli_usage_error(ctx, "expected 1 argument, WORLD; got %d", npos);
    if ((rc = cli_check_name(ctx, "world", pos[0])) >= 0)
        return rc;
    if (!a.have_camera || !a.have_look_at || a.output == NULL)
        return cli_usage_error(ctx, "render needs --camera x y z, --look-at x y z and -o FILE.png");
    cli_camera cam;
    char err[256];
    trioct_vec3 eye = {a.camera[0], a.camera[1], a.camera[2]};
    trioct_vec3 at = {a.look_at[0], a.look_at[1], a.look_at[2]};
    trioct_vec3 up = {a.up[0], a.up[1], a.up[2]};
    if (cli_camera_init(&cam, eye, at, up, a.fov, a.width, a.height, err, sizeof err) != 0)
        return cli_usage_error(ctx, "%s", err);
    if ((rc = cli_connect(ctx)) >= 0)
        return rc;

    sweep s = {0};
    rc = cast_sweep(ctx, pos[0], &a, &cam, &s);
    if (rc == CLI_EXIT_OK) {
        cli_png_image img = {0};
        double near, far;
        if (cli_render_image(&cam, s.t, s.normal, a.shade, &img, &near, &far) != 0) {
            rc = cli_internal_error(ctx, "out of memory for a %dx%d picture", a.width, a.height);
        } else {
            describe(&img, pos[0], &a, &s, near, far);
            if (cli_png_write(a.output, &img, err, sizeof err) != 0) {
                rc = cli_internal_error(ctx, "%s", err);
            } else if (ctx->json) {
                render_json(ctx, pos[0], &a, &s, near, far);
            } else {
                size_t rays = (size_t)a.width * (size_t)a.height;
                fprintf(ctx->out, "wrote %s: %dx%d %s picture of world %s (version %" PRId64 ", daemon %s), "
                        "%zu of %zu rays hit", a.output, a.width, a.height, cli_shade_name(a.shade), pos[0],
                        s.batch.first_version, s.batch.reply.daemon, s.hits, rays);
                if (a.shade == CLI_SHADE_DEPTH && s.hits > 0) {
                    char n[CLI_NUMBER_LEN], f[CLI_NUMBER_LEN];
                    fprintf(ctx->out, ", depth %s (white) to %s (black)", cli_format_double(near, n),
                            cli_format_double(far, f));
                }
                fputc('\n', ctx->out);
            }
        }
        cli_png_image_free(&img);
    }
    free(s.t);
    free(s.normal);
    return rc;
}

const cli_command cli_command_render = {
    "render",
    "a picture of a world from a camera: depth or normals, as PNG",
    "Usage: trioct render WORLD --camera x y z --look-at x y z -o FILE.png [--up x y z]\n"
    "                     [--fov DEG] [--size WxH] [--shade depth|normal] [--accuracy MODE]\n"
    "                     [global options]\n"
    "\n"
    "Casts one ray through the centre of every pixel of a pinhole camera at --camera looking\n"
    "at --look-at, and writes what they hit as a PNG. Rays that hit nothing leave their\n"
    "pixel transparent. A sweep of more than 1280 rays (TRIOCT_MAX_RAYS) goes as several\n"
    "requests; one that takes more than a second shows its progress on stderr.\n"
    "\n"
    "  --shade depth   (default) 16-bit grey: the distance from the camera, white at the\n"
    "                  nearest hit, black at the farthest, linear between; the two\n"
    "                  distances are in the file's text chunks trioct.depth_near and\n"
    "                  trioct.depth_far\n"
    "  --shade normal  8-bit colour: the hit triangle's normal, turned to face the camera,\n"
    "                  x y z as red green blue ((n + 1) / 2)\n"
    "\n"
    "Options:\n"
    "  --camera x y z  where the camera is\n"
    "  --look-at x y z the point at the centre of the picture\n"
    "  --up x y z      the direction that is up in the picture (default 0 0 1)\n"
    "  --fov DEG       the vertical field of view in degrees (default 60)\n"
    "  --size WxH      the picture's size in pixels (default 640x480)\n"
    "  -o, --output F  the PNG file to write\n"
    "  --accuracy MODE exact, seed, fast, or world (the world's own mode; default)\n"
    "\n"
    "The text chunks also keep the world, its version, the camera, look-at, up and field of\n"
    "view, each number exactly, so the ray of any pixel can be cast again.\n"
    "\n"
    "Examples:\n"
    "  trioct render yard --camera 60 -60 40 --look-at 0 0 0 -o yard.png\n"
    "  trioct render yard --camera 0 0 80 --look-at 0 0 0 --up 0 1 0 --shade normal \\\n"
    "      --size 1024x768 -o yard-top.png\n",
    run_render,
};
