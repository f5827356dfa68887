/* The objects and object subcommands: a world's named objects listed, and one added, moved
 * or removed. Each change is one edit list of one edit, so it applies whole or not at all
 * and makes the next version of the world. */
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cli_pose.h"
#include "cli_text.h"

/* ---- --pose x y z qw qx qy qz --------------------------------------------------------- */

/* Takes --pose and its seven numbers out of argv (so that the numbers, negative ones too,
 * are not read as options), compacting the rest. 0 with *found and *out, or -1 with err. */
static int take_pose(int *argc, char **argv, int *found, trioct_pose *out, double q[4], char *err, size_t err_len)
{
    *found = 0;
    for (int i = 0; i < *argc; i++) {
        if (strcmp(argv[i], "--") == 0)
            break;
        if (strcmp(argv[i], "--pose") != 0)
            continue;
        if (*found) {
            snprintf(err, err_len, "--pose given twice");
            return -1;
        }
        if (i + 7 >= *argc) {
            snprintf(err, err_len, "--pose takes seven numbers: x y z qw qx qy qz");
            return -1;
        }
        if (cli_parse_quaternion_pose(&argv[i + 1], "--pose", out, q, err, err_len) != 0)
            return -1;
        memmove(&argv[i], &argv[i + 8], (size_t)(*argc - i - 8) * sizeof *argv);
        *argc -= 8;
        *found = 1;
        i--;
    }
    return 0;
}

/* ---- output -------------------------------------------------------------------------- */

/* The rotation of a pose as the quaternion (w, x, y, z) with w >= 0, for people. */
static void pose_quaternion(const trioct_pose *p, double q[4])
{
    const double *r = p->r;
    double tr = r[0] + r[4] + r[8];
    if (tr > 0) {
        double s = 0.5 / sqrt(tr + 1.0);
        q[0] = 0.25 / s;
        q[1] = (r[7] - r[5]) * s;
        q[2] = (r[2] - r[6]) * s;
        q[3] = (r[3] - r[1]) * s;
    } else if (r[0] > r[4] && r[0] > r[8]) {
        double s = 2.0 * sqrt(1.0 + r[0] - r[4] - r[8]);
        q[0] = (r[7] - r[5]) / s;
        q[1] = 0.25 * s;
        q[2] = (r[1] + r[3]) / s;
        q[3] = (r[2] + r[6]) / s;
    } else if (r[4] > r[8]) {
        double s = 2.0 * sqrt(1.0 + r[4] - r[0] - r[8]);
        q[0] = (r[2] - r[6]) / s;
        q[1] = (r[1] + r[3]) / s;
        q[2] = 0.25 * s;
        q[3] = (r[5] + r[7]) / s;
    } else {
        double s = 2.0 * sqrt(1.0 + r[8] - r[0] - r[4]);
        q[0] = (r[3] - r[1]) / s;
        q[1] = (r[2] + r[6]) / s;
        q[2] = (r[5] + r[7]) / s;
        q[3] = 0.25 * s;
    }
    if (q[0] < 0)
        for (int k = 0; k < 4; k++)
            q[k] = -q[k];
}

static void objects_json(cli_context *ctx, const trioct_object_result *res, const char *action, const char *name)
{
    cli_json j;
    cli_json_init(&j, ctx->out);
    cli_json_envelope(&j, ctx, CLI_EXIT_OK, &res->reply);
    if (action != NULL) {
        cli_json_key_string(&j, "action", action);
        cli_json_key_string(&j, "object", name);
    }
    cli_json_key_int(&j, "objects", res->objects);
    cli_json_key_int(&j, "triangles", res->triangles);
    if (action == NULL) {
        cli_json_key(&j, "list");
        cli_json_array_begin(&j);
        for (size_t i = 0; i < res->num_objects; i++) {
            const trioct_object_info *o = &res->list[i];
            double q[4];
            pose_quaternion(&o->pose, q);
            cli_json_object_begin(&j);
            cli_json_key_string(&j, "name", o->name);
            cli_json_key_string(&j, "mesh", o->mesh);
            cli_json_key_int(&j, "triangles", o->triangles);
            cli_json_key_vec3(&j, "position", o->pose.t);
            cli_json_key(&j, "quaternion");
            cli_json_array_begin(&j);
            for (int k = 0; k < 4; k++)
                cli_json_double(&j, q[k]);
            cli_json_array_end(&j);
            cli_json_key(&j, "r");
            cli_json_array_begin(&j);
            for (int k = 0; k < 9; k++)
                cli_json_double(&j, o->pose.r[k]);
            cli_json_array_end(&j);
            cli_json_key_vec3(&j, "bbox_min", o->bbox_min);
            cli_json_key_vec3(&j, "bbox_max", o->bbox_max);
            cli_json_key_int(&j, "bytes", o->bytes);
            cli_json_key_int(&j, "shared", o->shared);
            cli_json_object_end(&j);
        }
        cli_json_array_end(&j);
    }
    cli_json_finish(&j);
}

static int objects_print(cli_context *ctx, const trioct_object_result *res)
{
    fprintf(ctx->out, "world %s (version %" PRId64 ", daemon %s): %" PRId64 " object%s, %" PRId64 " triangles\n",
            res->reply.world, res->reply.world_version, res->reply.daemon, res->objects, res->objects == 1 ? "" : "s",
            res->triangles);
    if (res->num_objects == 0)
        return 0;
    cli_table t;
    cli_table_init(&t, 7, 0x64); /* TRIANGLES, SHARED and MEMORY right-aligned */
    const char *head[] = {"NAME", "MESH", "TRIANGLES", "POSITION", "QUATERNION (W X Y Z)", "SHARED", "MEMORY"};
    for (int c = 0; c < 7; c++)
        cli_table_cell(&t, "%s", head[c]);
    for (size_t i = 0; i < res->num_objects; i++) {
        const trioct_object_info *o = &res->list[i];
        char x[CLI_NUMBER_LEN], y[CLI_NUMBER_LEN], z[CLI_NUMBER_LEN];
        char q0[CLI_NUMBER_LEN], q1[CLI_NUMBER_LEN], q2[CLI_NUMBER_LEN], q3[CLI_NUMBER_LEN];
        double q[4];
        pose_quaternion(&o->pose, q);
        cli_table_cell(&t, "%s", o->name);
        cli_table_cell(&t, "%s", o->mesh);
        cli_table_cell(&t, "%" PRId64, o->triangles);
        cli_table_cell(&t, "%s %s %s", cli_format_double(o->pose.t.x, x), cli_format_double(o->pose.t.y, y),
                       cli_format_double(o->pose.t.z, z));
        cli_table_cell(&t, "%s %s %s %s", cli_format_double(q[0], q0), cli_format_double(q[1], q1),
                       cli_format_double(q[2], q2), cli_format_double(q[3], q3));
        cli_table_cell(&t, "%d", o->shared);
        char bytes[CLI_NUMBER_LEN];
        cli_table_cell(&t, "%s", cli_format_bytes(o->bytes, bytes));
    }
    int rc = cli_table_print(&t, ctx->out, "");
    cli_table_free(&t);
    return rc;
}

/* An edit that failed: the daemon's message names the edit and why. */
static int edit_answer(cli_context *ctx, int status, const trioct_object_result *res, int timeout,
                       const char *action, const char *name)
{
    if (status != TRIOCT_OK)
        return cli_report_failure(ctx, &res->reply, timeout, NULL);
    if (ctx->json) {
        objects_json(ctx, res, action, name);
        return CLI_EXIT_OK;
    }
    if (action == NULL)
        return objects_print(ctx, res) == 0 ? CLI_EXIT_OK : CLI_EXIT_BAD_REPLY;
    fprintf(ctx->out, "%s %s: world %s is now version %" PRId64 " (%" PRId64 " object%s, %" PRId64 " triangles)\n",
            action, name, res->reply.world, res->reply.world_version, res->objects, res->objects == 1 ? "" : "s",
            res->triangles);
    return CLI_EXIT_OK;
}

/* ---- trioct objects WORLD ------------------------------------------------------------- */

static int run_objects(cli_context *ctx, int argc, char **argv)
{
    char *pos[CLI_MAX_POSITIONAL];
    int npos;
    int rc = cli_command_args(ctx, &cli_command_objects, argc, argv, NULL, NULL, NULL, pos, &npos);
    if (rc >= 0)
        return rc;
    if (npos != 1)
        return cli_usage_error(ctx, "expected one argument, WORLD; got %d", npos);
    if ((rc = cli_check_name(ctx, "world", pos[0])) >= 0)
        return rc;
    if ((rc = cli_connect(ctx)) >= 0)
        return rc;
    int timeout = cli_timeout(ctx, CLI_DEFAULT_TIMEOUT_MS);
    trioct_object_result res;
    int status = trioct_objects_edit(ctx->client, pos[0], NULL, 0, 1, timeout, &res);
    rc = edit_answer(ctx, status, &res, timeout, NULL, NULL);
    trioct_object_result_free(&res);
    return rc;
}

/* ---- trioct object add|move|remove WORLD NAME ----------------------------------------- */

enum { OPT_MESH };

static const cli_option object_options[] = {
    {"mesh", 0, 1, OPT_MESH},
    {NULL, 0, 0, 0},
};

static int object_option(void *user, int id, const char *value, char *err, size_t err_len)
{
    (void)err;
    (void)err_len;
    if (id == OPT_MESH)
        *(const char **)user = value;
    return 0;
}

static int run_object(cli_context *ctx, int argc, char **argv)
{
    int has_pose = 0;
    trioct_pose at = {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0}};
    char err[256];
    /* argv belongs to main: the pose is taken out of a copy. */
    char **args = calloc((size_t)argc + 1, sizeof *args);
    if (args == NULL)
        return cli_internal_error(ctx, "out of memory");
    memcpy(args, argv, (size_t)argc * sizeof *args);
    int n = argc;
    double q[4];
    if (take_pose(&n, args, &has_pose, &at, q, err, sizeof err) != 0) {
        free(args);
        return cli_usage_error(ctx, "%s", err);
    }
    const char *mesh = NULL;
    char *pos[CLI_MAX_POSITIONAL];
    int npos;
    int rc = cli_command_args(ctx, &cli_command_object, n, args, object_options, object_option, &mesh, pos, &npos);
    if (rc < 0 && npos != 3)
        rc = cli_usage_error(ctx, "expected add|move|remove WORLD NAME; got %d argument%s", npos, npos == 1 ? "" : "s");
    /* The quaternion goes as it was typed; the daemon makes the matrix. */
    trioct_object_edit e = {.name = npos > 2 ? pos[2] : NULL, .mesh = mesh, .pose = at, .quaternion = has_pose ? q : NULL};
    const char *action = npos > 0 ? pos[0] : "";
    if (rc < 0) {
        if (strcmp(action, "add") == 0)
            e.op = TRIOCT_OBJECT_ADD;
        else if (strcmp(action, "move") == 0)
            e.op = TRIOCT_OBJECT_MOVE;
        else if (strcmp(action, "remove") == 0)
            e.op = TRIOCT_OBJECT_REMOVE;
        else
            rc = cli_usage_error(ctx, "unknown action '%s': add, move or remove", action);
    }
    if (rc < 0 && e.op == TRIOCT_OBJECT_ADD && mesh == NULL)
        rc = cli_usage_error(ctx, "add needs --mesh FILE (a mesh file in the daemon's world directory)");
    if (rc < 0 && e.op != TRIOCT_OBJECT_ADD && mesh != NULL)
        rc = cli_usage_error(ctx, "--mesh is for add only");
    if (rc < 0 && e.op == TRIOCT_OBJECT_MOVE && !has_pose)
        rc = cli_usage_error(ctx, "move needs --pose x y z qw qx qy qz");
    if (rc < 0 && e.op == TRIOCT_OBJECT_REMOVE && has_pose)
        rc = cli_usage_error(ctx, "remove takes no --pose");
    if (rc < 0)
        rc = cli_check_name(ctx, "world", pos[1]);
    if (rc < 0)
        rc = cli_connect(ctx);
    if (rc < 0) {
        int timeout = cli_timeout(ctx, e.op == TRIOCT_OBJECT_ADD ? CLI_LOAD_TIMEOUT_MS : CLI_DEFAULT_TIMEOUT_MS);
        trioct_object_result res;
        int status = trioct_objects_edit(ctx->client, pos[1], &e, 1, 0, timeout, &res);
        static const char *const done[] = {"added", "moved", "removed"};
        rc = edit_answer(ctx, status, &res, timeout, done[e.op], e.name);
        trioct_object_result_free(&res);
    }
    free(args);
    return rc;
}

const cli_command cli_command_objects = {
    "objects",
    "list a world's objects: meshes, triangles, poses, memory",
    "Usage: trioct objects WORLD [global options]\n"
    "\n"
    "Lists the named objects of WORLD, in name order: each object's mesh (its file, \"inline\",\n"
    "or section:WORLD for a scene section's merged meshes), triangles, position and rotation\n"
    "(as the quaternion w x y z), how many objects share its mesh and tree, and their memory.\n"
    "A scene section without objects is one object named after the world.\n"
    "\n"
    "Examples:\n"
    "  trioct objects cell\n"
    "  trioct objects cell --json\n",
    run_objects,
};

const cli_command cli_command_object = {
    "object",
    "add, move or remove one of a world's objects",
    "Usage: trioct object add WORLD NAME --mesh FILE [--pose x y z qw qx qy qz]\n"
    "       trioct object move WORLD NAME --pose x y z qw qx qy qz\n"
    "       trioct object remove WORLD NAME [global options]\n"
    "\n"
    "Changes one object of WORLD and makes the world's next version; queries already\n"
    "running finish on the version they started on. add loads FILE from the daemon's world\n"
    "directory (objects of one file share its mesh and tree) and places it at --pose (the\n"
    "identity without it); move sets an object's pose; remove takes it out. NAME is 1 to 32\n"
    "characters of [A-Za-z0-9_.-]. The pose is a position and a unit quaternion (w x y z),\n"
    "normalised; one whose length is off by more than 1e-3 is refused. Objects are edited in\n"
    "exact worlds only.\n"
    "\n"
    "Options:\n"
    "  --mesh FILE                  add: the mesh file, relative to the world directory\n"
    "  --pose x y z qw qx qy qz     where the object stands\n"
    "\n"
    "Examples:\n"
    "  trioct object add cell box2 --mesh crate.obj --pose 1 0 0 1 0 0 0\n"
    "  trioct object move cell box2 --pose 1.5 0.2 0 0.7071 0 0 0.7071\n"
    "  trioct object remove cell box2\n",
    run_object,
};
