/* The distance and clear subcommands. `distance` asks each --point's nearest point of the
 * world, with the daemon's proven bound, or a shape's distance at poses; `clear` asks
 * whether anything lies within --within of a shape at poses. Points beyond one request's
 * cap are sent as several requests and their answers joined, numbered as given. */
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cli_batch.h"
#include "cli_distance_args.h"
#include "cli_object_names.h"
#include "cli_shape_file.h"
#include "cli_text.h"

/* The answers of every request, joined; object indexes cli_names. */
typedef struct distance_answer {
    cli_batch batch;
    size_t count;
    trioct_distance *results;
    cli_names names;
} distance_answer;

static void distance_answer_free(distance_answer *a)
{
    free(a->results);
    cli_names_free(&a->names);
    memset(a, 0, sizeof *a);
}

static int distance_answer_add(distance_answer *a, const trioct_distance_result *res, size_t offset)
{
    for (size_t i = 0; i < res->num_results; i++) {
        trioct_distance d = res->results[i];
        d.item += (int32_t)offset;
        if (d.object >= 0 && cli_names_map(&a->names, &res->objects, &d.object) != 0)
            return -1;
        a->results[offset + i] = d;
    }
    cli_batch_note(&a->batch, &res->reply);
    return 0;
}

static int ask_points(cli_context *ctx, const char *world, const cli_distance_args *args, distance_answer *answer)
{
    size_t count = args->num_points;
    answer->count = count;
    answer->results = calloc(count ? count : 1, sizeof *answer->results);
    if (answer->results == NULL)
        return cli_internal_error(ctx, "out of memory for %zu points", count);
    trioct_point_distance_query q = trioct_point_distance_query_default(world);
    q.within = args->has_within ? args->within : -1.0;
    int timeout = cli_timeout(ctx, CLI_DEFAULT_TIMEOUT_MS);
    int rc = CLI_EXIT_OK;
    for (size_t done = 0; done < count && rc == CLI_EXIT_OK;) {
        size_t n = count - done < TRIOCT_MAX_POINTS ? count - done : TRIOCT_MAX_POINTS;
        q.count = n;
        q.points = args->points + done;
        trioct_distance_result res;
        int status = trioct_point_distance(ctx->client, &q, timeout, &res);
        if (status != TRIOCT_OK) {
            char part[96] = "";
            if (n < count)
                snprintf(part, sizeof part, "points %zu..%zu of %zu", done, done + n - 1, count);
            rc = cli_report_failure(ctx, &res.reply, timeout, part[0] ? part : NULL);
        } else if (distance_answer_add(answer, &res, done) != 0) {
            rc = cli_internal_error(ctx, "out of memory for the answers of %zu points", count);
        }
        trioct_distance_result_free(&res);
        done += n;
    }
    if (rc == CLI_EXIT_OK)
        cli_batch_warn_rebuilt(ctx, &answer->batch, world);
    return rc;
}

/* A shape at poses, one request: shape distance (clear = 0) or clearance. */
static int ask_shape(cli_context *ctx, const char *world, const cli_distance_args *args, const trioct_triangle *tris,
                     size_t num_tris, int clear, distance_answer *answer)
{
    size_t count = args->poses.count;
    if (count > TRIOCT_MAX_POSES)
        return cli_usage_error(ctx, "%zu poses is over the %d a request carries (TRIOCT_MAX_POSES)", count,
                               TRIOCT_MAX_POSES);
    answer->count = count;
    answer->results = calloc(count ? count : 1, sizeof *answer->results);
    if (answer->results == NULL)
        return cli_internal_error(ctx, "out of memory for %zu poses", count);
    trioct_shape_distance_query q = {
        .world = world,
        .within = args->has_within ? args->within : -1.0,
        .shape = args->shape,
        .num_shape_triangles = num_tris,
        .shape_triangles = tris,
        .num_poses = count,
        .poses = args->poses.poses,
    };
    int timeout = cli_timeout(ctx, CLI_DEFAULT_TIMEOUT_MS);
    trioct_distance_result res;
    int status = clear ? trioct_clearance(ctx->client, &q, timeout, &res)
                       : trioct_shape_distance(ctx->client, &q, timeout, &res);
    int rc = CLI_EXIT_OK;
    if (status != TRIOCT_OK)
        rc = cli_report_failure(ctx, &res.reply, timeout, NULL);
    else if (distance_answer_add(answer, &res, 0) != 0)
        rc = cli_internal_error(ctx, "out of memory for the answers of %zu poses", count);
    trioct_distance_result_free(&res);
    return rc;
}

/* One result as JSON: a point's or a shape's distance with its bounds and witnesses, or a
 * clearance answer (clear, and the object it could not be proven clear of). inside
 * appears only for a point inside a solid object, whose distance is then negative. */
static void result_json(cli_json *j, const distance_answer *a, const trioct_distance *d, const char *item,
                        trioct_vec3 asked, int shaped, int clear)
{
    cli_json_object_begin(j);
    cli_json_key_int(j, item, d->item);
    if (!shaped)
        cli_json_key_vec3(j, "query", asked);
    if (clear) {
        cli_json_key_bool(j, "clear", d->clear);
        if (!d->clear && d->object >= 0)
            cli_json_key_string(j, "object", cli_names_get(&a->names, d->object));
        cli_json_object_end(j);
        return;
    }
    cli_json_key_bool(j, "found", d->found);
    if (d->found) {
        cli_json_key_double(j, "distance", d->distance);
        cli_json_key_double(j, "bound", d->bound);
        cli_json_key_double(j, "lower", d->lower);
        cli_json_key_double(j, "upper", d->upper);
        cli_json_key_vec3(j, "point", d->point);
        if (shaped) {
            cli_json_key_vec3(j, "shape_point", d->shape_point);
            cli_json_key_int(j, "shape_triangle", d->shape_triangle);
        }
        cli_json_key_string(j, "object", cli_names_get(&a->names, d->object));
        cli_json_key_int(j, "triangle", d->triangle);
        if (!shaped) {
            cli_json_key_string(j, "feature", cli_feature_name(d->feature));
            cli_json_key_int(j, "feature_index", d->feature_index);
        }
        if (d->inside)
            cli_json_key_bool(j, "inside", 1);
    }
    cli_json_object_end(j);
}

static void distance_json(cli_context *ctx, const distance_answer *a, const cli_distance_args *args, int clear)
{
    trioct_reply reply = a->batch.reply;
    reply.world_version = a->batch.first_version;
    int shaped = args->num_points == 0;
    cli_json j;
    cli_json_init(&j, ctx->out);
    cli_json_envelope(&j, ctx, CLI_EXIT_OK, &reply);
    cli_json_key(&j, "within");
    if (args->has_within)
        cli_json_double(&j, args->within);
    else
        cli_json_null(&j);
    if (shaped) {
        cli_json_key_string(&j, "shape", args->shape_file ? args->shape_file : args->shape);
        cli_json_key_int(&j, "poses", (int64_t)a->count);
    } else {
        cli_json_key_int(&j, "points", (int64_t)a->count);
        cli_json_key_int(&j, "requests", (int64_t)a->batch.requests);
    }
    cli_json_key(&j, "results");
    cli_json_array_begin(&j);
    for (size_t i = 0; i < a->count; i++)
        result_json(&j, a, &a->results[i], shaped ? "pose" : "index", shaped ? (trioct_vec3){0} : args->points[i],
                    shaped, clear);
    cli_json_array_end(&j);
    cli_json_finish(&j);
}

/* A clearance answer: one line a pose. */
static int clear_print(cli_context *ctx, const distance_answer *a, const cli_distance_args *args)
{
    size_t clear = 0;
    for (size_t i = 0; i < a->count; i++)
        clear += a->results[i].clear;
    fprintf(ctx->out, "world %s (version %" PRId64 ", daemon %s): %zu pose%s, %zu clear of everything within %.17g\n",
            a->batch.reply.world, a->batch.first_version, a->batch.reply.daemon, a->count, a->count == 1 ? "" : "s",
            clear, args->within);
    cli_table t;
    cli_table_init(&t, 3, 0x1);
    cli_table_cell(&t, "POSE");
    cli_table_cell(&t, "CLEAR");
    cli_table_cell(&t, "WITHIN R");
    for (size_t i = 0; i < a->count; i++) {
        const trioct_distance *d = &a->results[i];
        cli_table_cell(&t, "%zu", i);
        cli_table_cell(&t, "%s", d->clear ? "yes" : "no");
        cli_table_cell(&t, "%s", d->clear ? "-" : d->object >= 0 ? cli_names_get(&a->names, d->object) : "?");
    }
    int rc = cli_table_print(&t, ctx->out, "");
    cli_table_free(&t);
    return rc == 0 ? CLI_EXIT_OK : cli_internal_error(ctx, "out of memory printing the answer");
}

static int distance_print(cli_context *ctx, const distance_answer *a, const cli_distance_args *args, int clear)
{
    if (clear)
        return clear_print(ctx, a, args);
    int shaped = args->num_points == 0;
    size_t found = 0;
    for (size_t i = 0; i < a->count; i++)
        found += a->results[i].found;
    fprintf(ctx->out, "world %s (version %" PRId64 ", daemon %s): %zu %s%s, %zu with a nearest point", a->batch.reply.world,
            a->batch.first_version, a->batch.reply.daemon, a->count, shaped ? "pose" : "point",
            a->count == 1 ? "" : "s", found);
    if (args->has_within)
        fprintf(ctx->out, " within %.17g", args->within);
    fprintf(ctx->out, "\n");
    cli_table t;
    cli_table_init(&t, 6, 0x1);
    cli_table_cell(&t, shaped ? "POSE" : "POINT");
    cli_table_cell(&t, "DISTANCE");
    cli_table_cell(&t, "NEAREST");
    cli_table_cell(&t, "OBJECT");
    cli_table_cell(&t, "TRIANGLE");
    cli_table_cell(&t, shaped ? "SHAPE POINT (TRIANGLE)" : "FEATURE");
    for (size_t i = 0; i < a->count; i++) {
        const trioct_distance *d = &a->results[i];
        if (shaped)
            cli_table_cell(&t, "%zu", i);
        else
            cli_table_cell(&t, "%.17g %.17g %.17g", args->points[i].x, args->points[i].y, args->points[i].z);
        if (!d->found) {
            cli_table_cell(&t, "none within");
            for (int k = 0; k < 4; k++)
                cli_table_cell(&t, "-");
            continue;
        }
        cli_table_cell(&t, "%.17g ± %.3g%s", d->distance, d->bound, d->inside ? " (inside)" : "");
        cli_table_cell(&t, "%.17g %.17g %.17g", d->point.x, d->point.y, d->point.z);
        cli_table_cell(&t, "%s", cli_names_get(&a->names, d->object));
        cli_table_cell(&t, "%" PRId32, d->triangle);
        if (shaped)
            cli_table_cell(&t, "%.17g %.17g %.17g (%" PRId32 ")", d->shape_point.x, d->shape_point.y, d->shape_point.z,
                           d->shape_triangle);
        else if (d->feature == TRIOCT_FEATURE_FACE)
            cli_table_cell(&t, "face");
        else
            cli_table_cell(&t, "%s %d", cli_feature_name(d->feature), d->feature_index);
    }
    int rc = cli_table_print(&t, ctx->out, "");
    cli_table_free(&t);
    return rc == 0 ? CLI_EXIT_OK : cli_internal_error(ctx, "out of memory printing the answer");
}

static int distance_with_args(cli_context *ctx, const cli_command *cmd, int clear, int argc, char **argv,
                              cli_distance_args *a, trioct_triangle **tris, size_t *num_tris)
{
    char *pos[CLI_MAX_POSITIONAL];
    int npos;
    int rc = cli_command_args(ctx, cmd, argc, argv, cli_distance_options, cli_distance_option, a, pos, &npos);
    if (rc >= 0)
        return rc;
    if (npos != 1)
        return cli_usage_error(ctx, "expected 1 argument, WORLD; got %d", npos);
    if ((rc = cli_check_name(ctx, "world", pos[0])) >= 0)
        return rc;
    char err[1024];
    if (cli_distance_check(a, clear, err, sizeof err) != 0)
        return cli_usage_error(ctx, "%s", err);
    if (a->poses_file != NULL && (rc = cli_read_pose_file(ctx, a->poses_file, &a->poses)) >= 0)
        return rc;
    if (a->shape_file != NULL && cli_read_shape_file(a->shape_file, tris, num_tris, err, sizeof err) != 0)
        return cli_usage_error(ctx, "%s", err);
    int shaped = a->shape != NULL || a->shape_file != NULL;
    trioct_pose identity = {.r = {1, 0, 0, 0, 1, 0, 0, 0, 1}};
    if (shaped && a->poses.count == 0 && cli_pose_list_add(&a->poses, &identity) != 0)
        a->out_of_memory = 1;
    if (a->out_of_memory)
        return cli_internal_error(ctx, "out of memory for the points and poses");
    if ((rc = cli_connect(ctx)) >= 0)
        return rc;
    distance_answer answer = {0};
    rc = shaped ? ask_shape(ctx, pos[0], a, *tris, *num_tris, clear, &answer) : ask_points(ctx, pos[0], a, &answer);
    if (rc == CLI_EXIT_OK && ctx->json)
        distance_json(ctx, &answer, a, clear);
    else if (rc == CLI_EXIT_OK)
        rc = distance_print(ctx, &answer, a, clear);
    distance_answer_free(&answer);
    return rc;
}

static int run(cli_context *ctx, const cli_command *cmd, int clear, int argc, char **argv)
{
    cli_distance_args a = {0};
    trioct_triangle *tris = NULL;
    size_t num_tris = 0;
    int rc = distance_with_args(ctx, cmd, clear, argc, argv, &a, &tris, &num_tris);
    cli_distance_args_free(&a);
    free(tris);
    return rc;
}

static int run_distance(cli_context *ctx, int argc, char **argv)
{
    return run(ctx, &cli_command_distance, 0, argc, argv);
}

static int run_clear(cli_context *ctx, int argc, char **argv)
{
    return run(ctx, &cli_command_clear, 1, argc, argv);
}

const cli_command cli_command_distance = {
    "distance",
    "nearest point of the world to points, or a shape's distance at poses, with a proven bound",
    "Usage: trioct distance WORLD --point X Y Z [--point X Y Z]... [--within R] [global options]\n"
    "       trioct distance WORLD (--shape NAME | --shape-file FILE) [--pose POSE]... [--poses FILE|-]\n"
    "                       [--within R] [global options]\n"
    "\n"
    "For each point, the nearest point of WORLD's surface: its distance with the bound the\n"
    "daemon proves (the exact distance lies in [lower, upper]), the object and triangle it\n"
    "lies on and the feature there: the triangle's face, an edge (vertex k to k + 1 mod 3)\n"
    "or a vertex. With --within R, a point with nothing within R says so instead. The world\n"
    "must serve distance (effects = ... distance). Contact is surface contact unless the\n"
    "object is solid: a point inside a solid gets a negative distance (its depth below the\n"
    "surface, marked inside); inside any other closed mesh, its distance to the surface.\n"
    "\n"
    "With --shape (a query shape of WORLD's scene) or --shape-file (a mesh file's triangles,\n"
    "sent inline), the shape's minimum distance to the world at each pose, poses as trioct\n"
    "mesh takes them: the bound, the world's nearest point and triangle and the shape's;\n"
    "0 exactly when they touch.\n"
    "\n"
    "Options:\n"
    "  --point X Y Z      a query point (repeatable)\n"
    "  --within R         look no farther than R (>= 0; default: no limit)\n"
    "  --shape NAME       a query shape of the world's scene, instead of points\n"
    "  --shape-file FILE  the shape from a mesh file\n"
    "  --pose POSE        one pose of the shape (repeatable): \"tx ty tz [rx ry rz | qw qx qy qz]\"\n"
    "  --poses FILE|-     poses from a file or standard input, one a line\n"
    "\n"
    "With --json, results[i] carries index, query, found and, when found, distance, bound,\n"
    "lower, upper, point, object, triangle, feature (\"face\", \"edge\" or \"vertex\") and\n"
    "feature_index (a shape's: pose, shape_point and shape_triangle instead of query and\n"
    "feature); inside (true) appears only for a point inside a solid object.\n"
    "\n"
    "Examples:\n"
    "  trioct distance yard --point 3 0.5 0.5\n"
    "  trioct distance yard --point 3 0.5 0.5 --point -1 2 0 --within 5 --json\n"
    "  trioct distance yard --shape gripper --pose \"1 2 0.5 1 0 0 0\"\n",
    run_distance,
};

const cli_command cli_command_clear = {
    "clear",
    "is anything of the world within R of a shape at poses (conservative: never clear at R)",
    "Usage: trioct clear WORLD (--shape NAME | --shape-file FILE) [--pose POSE]... [--poses FILE|-]\n"
    "                    --within R [global options]\n"
    "\n"
    "For each pose, whether the shape is clear of WORLD by more than R: never \"clear\" when\n"
    "the exact distance is R or less. Poses as trioct mesh takes them; without any pose the\n"
    "shape is tested where it is. A pose whose proven bound straddles R answers not clear,\n"
    "naming the object; the walk stops at the first pair it cannot prove beyond R. With\n"
    "--json, results[i] carries pose, clear and, when not clear, object.\n"
    "\n"
    "Options:\n"
    "  --shape NAME       a query shape of the world's scene\n"
    "  --shape-file FILE  the shape from a mesh file, sent inline\n"
    "  --pose POSE        one pose (repeatable): \"tx ty tz [rx ry rz | qw qx qy qz]\"\n"
    "  --poses FILE|-     poses from a file or standard input, one a line\n"
    "  --within R         the clearance radius (>= 0), required\n"
    "\n"
    "Examples:\n"
    "  trioct clear yard --shape gripper --pose \"1 2 0.5 1 0 0 0\" --within 0.05\n",
    run_clear,
};
