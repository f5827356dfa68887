/* The ray subcommands: `ray` casts one ray, `rays` a batch read from a CSV file. A batch of
 * any length is cut into requests of TRIOCT_MAX_RAYS and the answers joined with the rays
 * numbered as in the file, so the user never meets the per-request cap. */
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "array_reserve.h"
#include "cli.h"
#include "cli_object_names.h"
#include "cli_batch.h"
#include "cli_csv.h"
#include "cli_progress.h"
#include "cli_text.h"

enum { OPT_ANY, OPT_ALL, OPT_MAX_HITS, OPT_TMIN, OPT_TMAX, OPT_ACCURACY, OPT_TOUCH };

typedef struct ray_args {
    int any, all;
    int touch; /* --touch: TRIOCT_CONTACT_TOUCH */
    int max_hits; /* 0: not given */
    int accuracy;
    double tmin, tmax;
} ray_args;

static const cli_option ray_options[] = {
    {"any", 0, 0, OPT_ANY},
    {"all", 0, 0, OPT_ALL},
    {"max-hits", 0, 1, OPT_MAX_HITS},
    {"tmin", 0, 1, OPT_TMIN},
    {"tmax", 0, 1, OPT_TMAX},
    {"accuracy", 0, 1, OPT_ACCURACY},
    {"touch", 0, 0, OPT_TOUCH},
    {NULL, 0, 0, 0},
};

static int ray_option(void *user, int id, const char *value, char *err, size_t err_len)
{
    ray_args *a = user;
    long long v;
    switch (id) {
    case OPT_ANY:
        a->any = 1;
        return 0;
    case OPT_ALL:
        a->all = 1;
        return 0;
    case OPT_TOUCH:
        a->touch = 1;
        return 0;
    case OPT_MAX_HITS:
        if (cli_parse_int(value, 1, TRIOCT_MAX_HITS_PER_RAY, &v) != 0) {
            snprintf(err, err_len, "--max-hits: '%.40s' is not a whole number in 1..%d", value,
                     TRIOCT_MAX_HITS_PER_RAY);
            return -1;
        }
        a->max_hits = (int)v;
        return 0;
    case OPT_TMIN:
        if (cli_parse_double(value, 0, &a->tmin) != 0) {
            snprintf(err, err_len, "--tmin: '%.40s' is not a finite number", value);
            return -1;
        }
        return 0;
    case OPT_TMAX:
        if (cli_parse_double(value, 1, &a->tmax) != 0) {
            snprintf(err, err_len, "--tmax: '%.40s' is not a number (or inf)", value);
            return -1;
        }
        return 0;
    case OPT_ACCURACY:
        return cli_accuracy_option(value, &a->accuracy, err, err_len);
    }
    return -1;
}

/* Checks what the options say together. -1 to go on, or the usage error's exit code. */
static int ray_args_check(cli_context *ctx, const ray_args *a)
{
    if (a->any && a->all)
        return cli_usage_error(ctx, "--any and --all exclude each other");
    if (a->max_hits > 0 && !a->all)
        return cli_usage_error(ctx, "--max-hits counts the hits of --all; add --all");
    if (a->tmin > a->tmax)
        return cli_usage_error(ctx, "--tmin is greater than --tmax");
    if (a->touch && (a->accuracy == TRIOCT_ACCURACY_SEED || a->accuracy == TRIOCT_ACCURACY_FAST))
        return cli_usage_error(ctx, "--touch is decided exactly: use --accuracy exact or world");
    return -1;
}

static const char *detail_name(int detail)
{
    return detail == TRIOCT_RAY_ANY ? "any" : detail == TRIOCT_RAY_ALL ? "all" : "closest";
}

/* ---- the batch ------------------------------------------------------------------------- */

/* The answers of every request of a batch, joined. */
typedef struct ray_answer {
    cli_batch batch;
    int detail;
    size_t num_rays;
    int32_t *found;
    size_t num_hits, cap_hits;
    trioct_ray_hit *hits; /* object: an index into names */
    cli_names names;
    const trioct_vec3 *origins, *directions; /* the rays cast, for the hit points */
} ray_answer;

/* Where a hit is: origin + t * direction, as the daemon's t means it. */
static trioct_vec3 hit_point(const ray_answer *a, const trioct_ray_hit *h)
{
    trioct_vec3 o = a->origins[h->ray], d = a->directions[h->ray];
    return (trioct_vec3){o.x + h->t * d.x, o.y + h->t * d.y, o.z + h->t * d.z};
}

static void ray_answer_free(ray_answer *a)
{
    free(a->found);
    free(a->hits);
    cli_names_free(&a->names);
    memset(a, 0, sizeof *a);
}

/* Appends one request's result, its rays numbered from offset. 0, or -1 out of memory. */
static int ray_answer_add(ray_answer *a, const trioct_ray_result *res, size_t offset)
{
    if (array_reserve((void **)&a->hits, &a->cap_hits, a->num_hits + res->num_hits, sizeof *a->hits, 1024) != 0)
        return -1;
    for (size_t i = 0; i < res->num_rays; i++)
        a->found[offset + i] = res->found[i];
    for (size_t i = 0; i < res->num_hits; i++) {
        trioct_ray_hit h = res->hits[i];
        h.ray += (int32_t)offset;
        if (cli_names_map(&a->names, &res->objects, &h.object) != 0)
            return -1;
        a->hits[a->num_hits++] = h;
    }
    cli_batch_note(&a->batch, &res->reply);
    return 0;
}

static int cast_rays(cli_context *ctx, const char *world, const ray_args *args,
                     const trioct_vec3 *origins, const trioct_vec3 *directions, size_t count,
                     ray_answer *answer)
{
    trioct_ray_query q = trioct_ray_query_default(world);
    q.detail = args->any ? TRIOCT_RAY_ANY : args->all ? TRIOCT_RAY_ALL : TRIOCT_RAY_CLOSEST;
    q.accuracy = args->accuracy;
    q.tmin = args->tmin;
    q.tmax = args->tmax;
    if (args->max_hits > 0)
        q.max_hits = args->max_hits;
    answer->detail = q.detail;
    answer->num_rays = count;
    answer->origins = origins;
    answer->directions = directions;
    answer->found = calloc(count ? count : 1, sizeof *answer->found);
    if (answer->found == NULL)
        return cli_internal_error(ctx, "out of memory for %zu rays", count);

    int timeout = cli_timeout(ctx, CLI_DEFAULT_TIMEOUT_MS);
    cli_progress progress;
    cli_progress_begin(&progress, ctx->err, cli_progress_mode_for(ctx->err, ctx->progress),
                       "rays", count, cli_now_ns());
    int rc = CLI_EXIT_OK;
    for (size_t done = 0; done < count && rc == CLI_EXIT_OK;) {
        size_t n = count - done < TRIOCT_MAX_RAYS ? count - done : TRIOCT_MAX_RAYS;
        q.count = n;
        q.origins = origins + done;
        q.directions = directions + done;
        trioct_ray_result res;
        int contact = args->touch ? TRIOCT_CONTACT_TOUCH : TRIOCT_CONTACT_CROSSING;
        int status = trioct_rays_contact(ctx->client, &q, contact, timeout, &res);
        if (status != TRIOCT_OK) {
            char part[96] = "";
            if (n < count)
                snprintf(part, sizeof part, "rays %zu..%zu of %zu", done, done + n - 1, count);
            rc = cli_report_failure(ctx, &res.reply, timeout, part[0] ? part : NULL);
        } else if (ray_answer_add(answer, &res, done) != 0) {
            rc = cli_internal_error(ctx, "out of memory for the hits of %zu rays", count);
        }
        trioct_ray_result_free(&res);
        done += n;
        cli_progress_update(&progress, done, cli_now_ns());
    }
    cli_progress_end(&progress, count, cli_now_ns());
    if (rc == CLI_EXIT_OK)
        cli_batch_warn_rebuilt(ctx, &answer->batch, world);
    return rc;
}

/* ---- output ---------------------------------------------------------------------------- */

static void ray_json(cli_context *ctx, const ray_answer *a, const ray_args *args)
{
    /* The first request's version: a rebuild during the batch was warned about. */
    trioct_reply reply = a->batch.reply;
    reply.world_version = a->batch.first_version;
    size_t hit_rays = 0;
    for (size_t i = 0; i < a->num_rays; i++)
        hit_rays += a->found[i] > 0;
    cli_json j;
    cli_json_init(&j, ctx->out);
    cli_json_envelope(&j, ctx, CLI_EXIT_OK, &reply);
    cli_json_key_string(&j, "detail", detail_name(a->detail));
    cli_json_key_string(&j, "accuracy", cli_accuracy_name(args->accuracy));
    cli_json_key_double(&j, "tmin", args->tmin);
    cli_json_key_double(&j, "tmax", args->tmax); /* null: no limit */
    cli_json_key_int(&j, "rays", (int64_t)a->num_rays);
    cli_json_key_int(&j, "requests", (int64_t)a->batch.requests);
    cli_json_key_int(&j, "hit_rays", (int64_t)hit_rays);
    cli_json_key(&j, "found");
    cli_json_array_begin(&j);
    for (size_t i = 0; i < a->num_rays; i++)
        cli_json_int(&j, a->found[i]);
    cli_json_array_end(&j);
    cli_json_key(&j, "hits");
    cli_json_array_begin(&j);
    for (size_t i = 0; i < a->num_hits; i++) {
        const trioct_ray_hit *h = &a->hits[i];
        cli_json_object_begin(&j);
        cli_json_key_int(&j, "ray", h->ray);
        cli_json_key_double(&j, "t", h->t);
        cli_json_key_vec3(&j, "point", hit_point(a, h));
        cli_json_key_string(&j, "object", cli_names_get(&a->names, h->object));
        cli_json_key_int(&j, "triangle", h->triangle);
        cli_json_key_double(&j, "u", h->u);
        cli_json_key_double(&j, "v", h->v);
        cli_json_key_vec3(&j, "normal", h->normal);
        cli_json_object_end(&j);
    }
    cli_json_array_end(&j);
    cli_json_finish(&j);
}

/* One row per stored hit, and one with dashes for a ray without any. */
static int ray_table(cli_context *ctx, const ray_answer *a)
{
    cli_table t;
    cli_table_init(&t, 9, 0xe7); /* all but the point, the object and the normal right-aligned */
    const char *head[] = {"RAY", "FOUND", "T", "POINT", "OBJECT", "TRIANGLE", "U", "V", "NORMAL"};
    for (size_t i = 0; i < 9; i++)
        cli_table_cell(&t, "%s", head[i]);
    size_t h = 0;
    for (size_t ray = 0; ray < a->num_rays; ray++) {
        int rows = 0;
        for (; h < a->num_hits && (size_t)a->hits[h].ray == ray; h++, rows++) {
            const trioct_ray_hit *hit = &a->hits[h];
            char tt[CLI_NUMBER_LEN], u[CLI_NUMBER_LEN], v[CLI_NUMBER_LEN];
            char nx[CLI_NUMBER_LEN], ny[CLI_NUMBER_LEN], nz[CLI_NUMBER_LEN];
            char px[CLI_NUMBER_LEN], py[CLI_NUMBER_LEN], pz[CLI_NUMBER_LEN];
            trioct_vec3 p = hit_point(a, hit);
            cli_table_cell(&t, "%zu", ray);
            cli_table_cell(&t, "%" PRId32, a->found[ray]);
            cli_table_cell(&t, "%s", cli_format_double(hit->t, tt));
            cli_table_cell(&t, "%s %s %s", cli_format_double(p.x, px), cli_format_double(p.y, py),
                           cli_format_double(p.z, pz));
            cli_table_cell(&t, "%s", cli_names_get(&a->names, hit->object));
            cli_table_cell(&t, "%" PRId32, hit->triangle);
            cli_table_cell(&t, "%s", cli_format_double(hit->u, u));
            cli_table_cell(&t, "%s", cli_format_double(hit->v, v));
            cli_table_cell(&t, "%s %s %s", cli_format_double(hit->normal.x, nx),
                           cli_format_double(hit->normal.y, ny),
                           cli_format_double(hit->normal.z, nz));
        }
        if (rows == 0) {
            cli_table_cell(&t, "%zu", ray);
            cli_table_cell(&t, "%" PRId32, a->found[ray]);
            for (int c = 0; c < 7; c++)
                cli_table_cell(&t, "-");
        }
    }
    int rc = cli_table_print(&t, ctx->out, "");
    cli_table_free(&t);
    return rc;
}

static int ray_print(cli_context *ctx, const ray_answer *a)
{
    size_t hit_rays = 0;
    for (size_t i = 0; i < a->num_rays; i++)
        hit_rays += a->found[i] > 0;
    fprintf(ctx->out, "world %s (version %" PRId64 ", daemon %s), %s hit: %zu of %zu ray%s hit\n",
            a->batch.reply.world, a->batch.first_version, a->batch.reply.daemon, detail_name(a->detail), hit_rays,
            a->num_rays, a->num_rays == 1 ? "" : "s");
    if (ray_table(ctx, a) != 0)
        return cli_internal_error(ctx, "out of memory printing %zu hits", a->num_hits);
    return CLI_EXIT_OK;
}

static int ray_run_and_print(cli_context *ctx, const char *world, const ray_args *args,
                             const trioct_vec3 *origins, const trioct_vec3 *directions, size_t count)
{
    int rc = cli_connect(ctx);
    if (rc >= 0)
        return rc;
    ray_answer answer = {0};
    rc = cast_rays(ctx, world, args, origins, directions, count, &answer);
    if (rc == CLI_EXIT_OK) {
        if (ctx->json)
            ray_json(ctx, &answer, args);
        else
            rc = ray_print(ctx, &answer);
    }
    ray_answer_free(&answer);
    return rc;
}

/* ---- ray ------------------------------------------------------------------------------- */

static int run_ray(cli_context *ctx, int argc, char **argv)
{
    ray_args a = {.accuracy = TRIOCT_ACCURACY_WORLD, .tmin = 0.0, .tmax = INFINITY};
    char *pos[CLI_MAX_POSITIONAL];
    int npos;
    int rc = cli_command_args(ctx, &cli_command_ray, argc, argv, ray_options, ray_option, &a, pos,
                              &npos);
    if (rc >= 0)
        return rc;
    if (npos != 7)
        return cli_usage_error(ctx, "expected 7 arguments, WORLD ox oy oz dx dy dz; got %d", npos);
    if ((rc = cli_check_name(ctx, "world", pos[0])) >= 0 || (rc = ray_args_check(ctx, &a)) >= 0)
        return rc;
    double v[6];
    static const char *const names[] = {"ox", "oy", "oz", "dx", "dy", "dz"};
    for (int i = 0; i < 6; i++)
        if (cli_parse_double(pos[1 + i], 0, &v[i]) != 0)
            return cli_usage_error(ctx, "%s: '%.40s' is not a finite number", names[i], pos[1 + i]);
    trioct_vec3 origin = {v[0], v[1], v[2]}, direction = {v[3], v[4], v[5]};
    return ray_run_and_print(ctx, pos[0], &a, &origin, &direction, 1);
}

const cli_command cli_command_ray = {
    "ray",
    "cast one ray: the closest hit, any hit or all hits",
    "Usage: trioct ray WORLD ox oy oz dx dy dz [--any | --all [--max-hits N]]\n"
    "                  [--tmin T] [--tmax T] [--accuracy MODE] [--touch] [global options]\n"
    "\n"
    "Casts the ray origin + t * direction, t in [tmin, tmax], into WORLD and prints what it\n"
    "hits: t, the world triangle, the barycentric weights u and v of the triangle's second\n"
    "and third vertices, and the triangle's normal. Negative numbers need no quoting.\n"
    "\n"
    "Options:\n"
    "  --any           stop at the first hit found (not necessarily the closest)\n"
    "  --all           every crossing, by increasing t\n"
    "  --max-hits N    with --all: store at most N hits (1..1000, default 1000); the\n"
    "                  found count still says how many crossings there are\n"
    "  --tmin T        start of the interval (default 0)\n"
    "  --tmax T        end of the interval (default inf)\n"
    "  --accuracy MODE exact, seed, fast, or world (the world's own mode; default)\n"
    "  --touch         count every triangle the segment touches (edges, vertices, faces\n"
    "                  it slides along), not only crossings: --any is then a safe\n"
    "                  line-of-sight test; decided exactly (not with seed or fast)\n"
    "\n"
    "Examples:\n"
    "  trioct ray yard 0 0 50 0 0 -1\n"
    "  trioct ray yard 0 0 50 0 0 -1 --all --json\n"
    "  trioct ray yard -5 2 1 1 0 0 --any --tmax 10\n"
    "  trioct ray yard -5 2 1 1 0 0 --any --tmax 10 --touch\n",
    run_ray,
};

/* ---- rays ------------------------------------------------------------------------------ */

static int run_rays(cli_context *ctx, int argc, char **argv)
{
    ray_args a = {.accuracy = TRIOCT_ACCURACY_WORLD, .tmin = 0.0, .tmax = INFINITY};
    char *pos[CLI_MAX_POSITIONAL];
    int npos;
    int rc = cli_command_args(ctx, &cli_command_rays, argc, argv, ray_options, ray_option, &a,
                              pos, &npos);
    if (rc >= 0)
        return rc;
    if (npos != 2)
        return cli_usage_error(ctx, "expected 2 arguments, WORLD and FILE (or - for stdin); got %d",
                               npos);
    if ((rc = cli_check_name(ctx, "world", pos[0])) >= 0 || (rc = ray_args_check(ctx, &a)) >= 0)
        return rc;
    FILE *file;
    const char *name;
    if ((rc = cli_open_input(ctx, pos[1], &file, &name)) >= 0)
        return rc;
    cli_ray_list rays;
    char err[512];
    int read_rc = cli_read_rays(file, name, &rays, err, sizeof err);
    cli_close_input(file);
    if (read_rc != 0)
        return cli_usage_error(ctx, "%s", err);
    if (rays.count == 0) {
        cli_ray_list_free(&rays);
        return cli_usage_error(ctx, "%s holds no rays", name);
    }
    rc = ray_run_and_print(ctx, pos[0], &a, rays.origins, rays.directions, rays.count);
    cli_ray_list_free(&rays);
    return rc;
}

const cli_command cli_command_rays = {
    "rays",
    "cast a batch of rays read from a CSV file",
    "Usage: trioct rays WORLD FILE|- [--any | --all [--max-hits N]] [--tmin T] [--tmax T]\n"
    "                   [--accuracy MODE] [--touch] [global options]\n"
    "\n"
    "Reads one ray a line, \"ox,oy,oz,dx,dy,dz\" (commas or blanks between the numbers),\n"
    "from FILE or, with -, from standard input; blank lines and lines starting with # are\n"
    "skipped, and any other line that is not six finite numbers is a usage error naming\n"
    "the file and line. Batches longer than 1280 rays (TRIOCT_MAX_RAYS) are sent as\n"
    "several requests; the answer numbers the rays 0, 1, ... in file order all the same.\n"
    "A batch that takes more than a second shows its progress on stderr when stderr is a\n"
    "terminal (or always, with --progress). The options are those of `trioct ray`.\n"
    "\n"
    "Examples:\n"
    "  trioct rays yard scan.csv\n"
    "  trioct rays yard scan.csv --any --json > hits.json\n"
    "  generate_rays | trioct rays yard - --all --max-hits 4 --progress\n",
    run_rays,
};
