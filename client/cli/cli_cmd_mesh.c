/* The mesh subcommand: one of the world's query shapes, or the triangles of a mesh file sent
 * inline, at one or many poses. Like rays, a pose list of any length is cut into requests
 * (of TRIOCT_MAX_POSES, or fewer beside inline triangles) and the answers joined, poses
 * numbered as given. */
#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

#include "array_reserve.h"
#include "cli.h"
#include "cli_object_names.h"
#include "cli_batch.h"
#include "cli_pose.h"
#include "cli_progress.h"
#include "cli_shape_file.h"
#include "cli_text.h"

enum { OPT_POSE, OPT_POSES, OPT_PAIRS, OPT_ACCURACY, OPT_SHAPE_FILE };

/* A request must fit one datagram (TRIOCT_MAX_REQUEST_BYTES), and inline triangles share it
 * with the poses: 512 of them leave room for fewer than TRIOCT_MAX_POSES. A pose is 96 bytes
 * on the wire (pose_t: 12 doubles), a triangle 72 (triangle_t: 9); everything else of a
 * mesh_request_t, the header's names at their longest included, is under 200 bytes, and
 * MESH_REQUEST_OTHER_BYTES leaves room to spare. */
#define MESH_POSE_BYTES 96
#define MESH_TRIANGLE_BYTES 72
#define MESH_REQUEST_OTHER_BYTES 512

typedef struct mesh_args {
    cli_pose_list poses; /* from --pose, in order */
    const char *poses_file;
    const char *shape_file;      /* --shape-file; NULL: SHAPE names a shape of the scene */
    trioct_triangle *triangles;  /* the shape file's, sent inline */
    size_t num_triangles;
    int pairs;
    int accuracy;
    int out_of_memory;
} mesh_args;

static const cli_option mesh_options[] = {
    {"pose", 0, 1, OPT_POSE},
    {"poses", 0, 1, OPT_POSES},
    {"pairs", 0, 0, OPT_PAIRS},
    {"accuracy", 0, 1, OPT_ACCURACY},
    {"shape-file", 0, 1, OPT_SHAPE_FILE},
    {NULL, 0, 0, 0},
};

static int mesh_option(void *user, int id, const char *value, char *err, size_t err_len)
{
    mesh_args *a = user;
    switch (id) {
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
        if (a->poses_file != NULL) {
            snprintf(err, err_len, "--poses given twice");
            return -1;
        }
        a->poses_file = value;
        return 0;
    case OPT_PAIRS:
        a->pairs = 1;
        return 0;
    case OPT_ACCURACY:
        return cli_accuracy_option(value, &a->accuracy, err, err_len);
    case OPT_SHAPE_FILE:
        if (a->shape_file != NULL) {
            snprintf(err, err_len, "--shape-file given twice");
            return -1;
        }
        a->shape_file = value;
        return 0;
    }
    return -1;
}

/* Poses per request: TRIOCT_MAX_POSES, or what fits beside num_triangles inline ones. */
static size_t poses_per_request(size_t num_triangles)
{
    size_t room = TRIOCT_MAX_REQUEST_BYTES - MESH_REQUEST_OTHER_BYTES - num_triangles * MESH_TRIANGLE_BYTES;
    size_t n = room / MESH_POSE_BYTES;
    return n < TRIOCT_MAX_POSES ? n : TRIOCT_MAX_POSES;
}
_Static_assert(TRIOCT_MAX_REQUEST_BYTES - MESH_REQUEST_OTHER_BYTES >
                   TRIOCT_MAX_INLINE_SHAPE_TRIANGLES * MESH_TRIANGLE_BYTES + MESH_POSE_BYTES,
               "a request of the most inline triangles still carries a pose");

/* The answers of every request, joined. */
typedef struct mesh_answer {
    cli_batch batch;
    int detail;
    size_t num_poses;
    int32_t *found;
    size_t num_pairs, cap_pairs;
    trioct_mesh_pair *pairs; /* object: an index into names */
    cli_names names;
} mesh_answer;

static void mesh_answer_free(mesh_answer *a)
{
    free(a->found);
    free(a->pairs);
    cli_names_free(&a->names);
    memset(a, 0, sizeof *a);
}

static int mesh_answer_add(mesh_answer *a, const trioct_mesh_result *res, size_t offset)
{
    if (array_reserve((void **)&a->pairs, &a->cap_pairs, a->num_pairs + res->num_pairs, sizeof *a->pairs, 1024) != 0)
        return -1;
    for (size_t i = 0; i < res->num_poses; i++)
        a->found[offset + i] = res->found[i];
    for (size_t i = 0; i < res->num_pairs; i++) {
        trioct_mesh_pair p = res->pairs[i];
        p.pose += (int32_t)offset;
        if (cli_names_map(&a->names, &res->objects, &p.object) != 0)
            return -1;
        a->pairs[a->num_pairs++] = p;
    }
    cli_batch_note(&a->batch, &res->reply);
    return 0;
}

/* shape: a query shape of the world's scene, or NULL for args' inline triangles. */
static int place_shape(cli_context *ctx, const char *world, const char *shape, const mesh_args *args,
                       mesh_answer *answer)
{
    size_t count = args->poses.count;
    trioct_mesh_query q = {
        .world = world,
        .detail = args->pairs ? TRIOCT_MESH_PAIRS : TRIOCT_MESH_YESNO,
        .accuracy = args->accuracy,
        .shape = shape,
        .num_shape_triangles = shape ? 0 : args->num_triangles,
        .shape_triangles = shape ? NULL : args->triangles,
    };
    size_t per_request = poses_per_request(q.num_shape_triangles);
    answer->detail = q.detail;
    answer->num_poses = count;
    answer->found = calloc(count, sizeof *answer->found);
    if (answer->found == NULL)
        return cli_internal_error(ctx, "out of memory for %zu poses", count);

    int timeout = cli_timeout(ctx, CLI_DEFAULT_TIMEOUT_MS);
    cli_progress progress;
    cli_progress_begin(&progress, ctx->err, cli_progress_mode_for(ctx->err, ctx->progress),
                       "poses", count, cli_now_ns());
    int rc = CLI_EXIT_OK;
    for (size_t done = 0; done < count && rc == CLI_EXIT_OK;) {
        size_t n = count - done < per_request ? count - done : per_request;
        q.num_poses = n;
        q.poses = args->poses.poses + done;
        trioct_mesh_result res;
        int status = trioct_mesh(ctx->client, &q, timeout, &res);
        if (status != TRIOCT_OK) {
            char part[96] = "";
            if (n < count)
                snprintf(part, sizeof part, "poses %zu..%zu of %zu", done, done + n - 1, count);
            rc = cli_report_failure(ctx, &res.reply, timeout, part[0] ? part : NULL);
        } else if (mesh_answer_add(answer, &res, done) != 0) {
            rc = cli_internal_error(ctx, "out of memory for the pairs of %zu poses", count);
        }
        trioct_mesh_result_free(&res);
        done += n;
        cli_progress_update(&progress, done, cli_now_ns());
    }
    cli_progress_end(&progress, count, cli_now_ns());
    if (rc == CLI_EXIT_OK)
        cli_batch_warn_rebuilt(ctx, &answer->batch, world);
    return rc;
}

/* shape: the scene's shape name, or the file's path when args->shape_file is set. */
static void mesh_json(cli_context *ctx, const mesh_answer *a, const char *shape, const mesh_args *args)
{
    /* The first request's version: a rebuild during the batch was warned about. */
    trioct_reply reply = a->batch.reply;
    reply.world_version = a->batch.first_version;
    size_t touching = 0;
    for (size_t i = 0; i < a->num_poses; i++)
        touching += a->found[i] > 0;
    cli_json j;
    cli_json_init(&j, ctx->out);
    cli_json_envelope(&j, ctx, CLI_EXIT_OK, &reply);
    cli_json_key_string(&j, "shape", shape);
    cli_json_key_bool(&j, "shape_file", args->shape_file != NULL);
    if (args->shape_file != NULL)
        cli_json_key_int(&j, "shape_triangles", (int64_t)args->num_triangles);
    cli_json_key_string(&j, "detail", a->detail == TRIOCT_MESH_PAIRS ? "pairs" : "yesno");
    cli_json_key_string(&j, "accuracy", cli_accuracy_name(args->accuracy));
    cli_json_key_int(&j, "poses", (int64_t)a->num_poses);
    cli_json_key_int(&j, "requests", (int64_t)a->batch.requests);
    cli_json_key_int(&j, "touching_poses", (int64_t)touching);
    cli_json_key(&j, "found");
    cli_json_array_begin(&j);
    for (size_t i = 0; i < a->num_poses; i++)
        cli_json_int(&j, a->found[i]);
    cli_json_array_end(&j);
    cli_json_key(&j, "pairs");
    cli_json_array_begin(&j);
    for (size_t i = 0; i < a->num_pairs; i++) {
        cli_json_object_begin(&j);
        cli_json_key_int(&j, "pose", a->pairs[i].pose);
        cli_json_key_int(&j, "shape_triangle", a->pairs[i].shape_triangle);
        cli_json_key_string(&j, "object", cli_names_get(&a->names, a->pairs[i].object));
        cli_json_key_int(&j, "world_triangle", a->pairs[i].world_triangle);
        cli_json_object_end(&j);
    }
    cli_json_array_end(&j);
    cli_json_finish(&j);
}

static int mesh_print(cli_context *ctx, const mesh_answer *a, const char *shape, const mesh_args *args)
{
    size_t touching = 0;
    for (size_t i = 0; i < a->num_poses; i++)
        touching += a->found[i] > 0;
    char what[TRIOCT_MAX_PATH_LEN + 64];
    if (args->shape_file != NULL)
        snprintf(what, sizeof what, "shape file %s (%zu triangle%s)", shape, args->num_triangles,
                 args->num_triangles == 1 ? "" : "s");
    else
        snprintf(what, sizeof what, "shape %s", shape);
    fprintf(ctx->out, "world %s (version %" PRId64 ", daemon %s), %s: %zu of %zu pose%s touching\n",
            a->batch.reply.world, a->batch.first_version, a->batch.reply.daemon, what, touching, a->num_poses,
            a->num_poses == 1 ? "" : "s");
    cli_table t;
    int pairs = a->detail == TRIOCT_MESH_PAIRS;
    if (pairs) {
        cli_table_init(&t, 4, 0xB);
        cli_table_cell(&t, "POSE");
        cli_table_cell(&t, "SHAPE TRIANGLE");
        cli_table_cell(&t, "OBJECT");
        cli_table_cell(&t, "WORLD TRIANGLE");
        for (size_t i = 0; i < a->num_pairs; i++) {
            cli_table_cell(&t, "%" PRId32, a->pairs[i].pose);
            cli_table_cell(&t, "%" PRId32, a->pairs[i].shape_triangle);
            cli_table_cell(&t, "%s", cli_names_get(&a->names, a->pairs[i].object));
            cli_table_cell(&t, "%" PRId32, a->pairs[i].world_triangle);
        }
    } else {
        cli_table_init(&t, 2, 0x1);
        cli_table_cell(&t, "POSE");
        cli_table_cell(&t, "TOUCHING");
        for (size_t i = 0; i < a->num_poses; i++) {
            cli_table_cell(&t, "%zu", i);
            cli_table_cell(&t, "%s", a->found[i] ? "yes" : "no");
        }
    }
    int rc = pairs && a->num_pairs == 0 ? 0 : cli_table_print(&t, ctx->out, "");
    cli_table_free(&t);
    return rc == 0 ? CLI_EXIT_OK : cli_internal_error(ctx, "out of memory printing the answer");
}

static int mesh_with_args(cli_context *ctx, int argc, char **argv, mesh_args *a)
{
    char *pos[CLI_MAX_POSITIONAL];
    int npos;
    int rc = cli_command_args(ctx, &cli_command_mesh, argc, argv, mesh_options, mesh_option, a,
                              pos, &npos);
    if (rc >= 0)
        return rc;
    if (a->shape_file != NULL && npos == 2)
        return cli_usage_error(ctx, "SHAPE (%.40s) and --shape-file exclude each other: give one", pos[1]);
    if (a->shape_file != NULL && npos != 1)
        return cli_usage_error(ctx, "expected 1 argument with --shape-file, WORLD; got %d", npos);
    if (a->shape_file == NULL && npos != 2)
        return cli_usage_error(ctx, "expected 2 arguments, WORLD and SHAPE (or WORLD and --shape-file FILE); got %d",
                               npos);
    if ((rc = cli_check_name(ctx, "world", pos[0])) >= 0 ||
        (a->shape_file == NULL && (rc = cli_check_name(ctx, "shape", pos[1])) >= 0))
        return rc;
    if (a->poses_file != NULL && (rc = cli_read_pose_file(ctx, a->poses_file, &a->poses)) >= 0)
        return rc;
    char err[1024];
    if (a->shape_file != NULL && cli_read_shape_file(a->shape_file, &a->triangles, &a->num_triangles, err,
                                                     sizeof err) != 0)
        return cli_usage_error(ctx, "%s", err);
    if (a->poses.count == 0 && a->poses_file != NULL)
        return cli_usage_error(ctx, "%s holds no poses", a->poses_file);
    trioct_pose identity = {.r = {1, 0, 0, 0, 1, 0, 0, 0, 1}};
    if (a->poses.count == 0 && cli_pose_list_add(&a->poses, &identity) != 0)
        a->out_of_memory = 1;
    if (a->out_of_memory)
        return cli_internal_error(ctx, "out of memory for the poses");
    if ((rc = cli_connect(ctx)) >= 0)
        return rc;
    mesh_answer answer = {0};
    const char *shape = a->shape_file != NULL ? a->shape_file : pos[1];
    rc = place_shape(ctx, pos[0], a->shape_file != NULL ? NULL : shape, a, &answer);
    if (rc == CLI_EXIT_OK && ctx->json)
        mesh_json(ctx, &answer, shape, a);
    else if (rc == CLI_EXIT_OK)
        rc = mesh_print(ctx, &answer, shape, a);
    mesh_answer_free(&answer);
    return rc;
}

static int run_mesh(cli_context *ctx, int argc, char **argv)
{
    mesh_args a = {.accuracy = TRIOCT_ACCURACY_WORLD};
    int rc = mesh_with_args(ctx, argc, argv, &a);
    cli_pose_list_free(&a.poses);
    free(a.triangles);
    return rc;
}

const cli_command cli_command_mesh = {
    "mesh",
    "place a query shape, the world's or a mesh file, at poses: touching, and which pairs",
    "Usage: trioct mesh WORLD SHAPE [--pose POSE]... [--poses FILE|-] [--pairs] [--accuracy MODE]\n"
    "       trioct mesh WORLD --shape-file FILE [--pose POSE]... [--poses FILE|-] [--pairs] ...\n"
    "                   [global options]\n"
    "\n"
    "Places SHAPE, a query shape WORLD's scene names (shape.<name> = file), at each pose\n"
    "and tells whether it touches the world there. Contact is surface contact unless the\n"
    "object is solid: a shape wholly inside a solid collides with it (world triangle -1\n"
    "with --pairs; docs/engine.md). With --shape-file, the\n"
    "shape is FILE instead (any format assimp reads, node transforms applied), read here\n"
    "and its\n"
    "triangles sent with each request: at most 512 (TRIOCT_MAX_INLINE_SHAPE_TRIANGLES).\n"
    "\n"
    "A pose is \"tx ty tz\", a translation; \"tx ty tz rx ry rz\", and rotation angles in\n"
    "degrees about the fixed x, then y, then z axes (the scene files' convention); or\n"
    "\"tx ty tz qw qx qy qz\", and a quaternion, normalised, refused when its length is off 1\n"
    "by more than 1e-3. Quarter turns are exact either way. Without any pose the shape is\n"
    "tested where it is. --pose repeats; --poses reads one pose a line (3, 6 or 7 numbers,\n"
    "commas or blanks; blank lines and # comments skipped) after the --pose ones. Lists\n"
    "longer than a request carries (512 poses, TRIOCT_MAX_POSES, or fewer beside a shape\n"
    "file's triangles) are sent as several requests, numbered as given all the same.\n"
    "\n"
    "Options:\n"
    "  --shape-file FILE             the shape from a mesh file, instead of SHAPE\n"
    "  --pose POSE                   one pose (repeatable): \"tx ty tz [rx ry rz | qw qx qy qz]\"\n"
    "  --poses FILE|-                poses from a file or standard input\n"
    "  --pairs                       every touching (pose, shape triangle, world triangle)\n"
    "  --accuracy MODE               exact, seed, fast, or world (default)\n"
    "\n"
    "Examples:\n"
    "  trioct mesh yard gripper --pose \"1 2 0.5\"\n"
    "  trioct mesh yard gripper --pose \"1 2 0.5 0 0 90\" --pose \"3 2 0.5\" --pairs\n"
    "  trioct mesh yard --shape-file gripper.stl --pose \"1 2 0.5 0.7071 0 0 0.7071\"\n"
    "  trioct mesh cell probe --poses path.csv --json\n",
    run_mesh,
};
