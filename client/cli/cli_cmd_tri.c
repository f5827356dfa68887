/* The tri subcommand: does a triangle touch the world, which world triangles, and along
 * which segments. */
#include <inttypes.h>
#include <string.h>

#include "cli.h"
#include "cli_text.h"

enum { OPT_IDS, OPT_SEGMENTS, OPT_ACCURACY };

typedef struct tri_args {
    int ids, segments;
    int accuracy;
} tri_args;

static const cli_option tri_options[] = {
    {"ids", 0, 0, OPT_IDS},
    {"segments", 0, 0, OPT_SEGMENTS},
    {"accuracy", 0, 1, OPT_ACCURACY},
    {NULL, 0, 0, 0},
};

static int tri_option(void *user, int id, const char *value, char *err, size_t err_len)
{
    tri_args *a = user;
    switch (id) {
    case OPT_IDS:
        a->ids = 1;
        return 0;
    case OPT_SEGMENTS:
        a->segments = 1;
        return 0;
    case OPT_ACCURACY:
        return cli_accuracy_option(value, &a->accuracy, err, err_len);
    }
    return -1;
}

static const char *detail_name(int detail)
{
    return detail == TRIOCT_TRI_YESNO ? "yesno" : detail == TRIOCT_TRI_IDS ? "ids" : "segments";
}

static void tri_json(cli_context *ctx, const trioct_triangle_result *res, int accuracy)
{
    cli_json j;
    cli_json_init(&j, ctx->out);
    cli_json_envelope(&j, ctx, CLI_EXIT_OK, &res->reply);
    cli_json_key_string(&j, "detail", detail_name(res->detail));
    cli_json_key_string(&j, "accuracy", cli_accuracy_name(accuracy));
    cli_json_key_int(&j, "triangles", (int64_t)res->num_triangles);
    cli_json_key_bool(&j, "touching", res->num_triangles > 0 && res->found[0] > 0);
    cli_json_key(&j, "found");
    cli_json_array_begin(&j);
    for (size_t i = 0; i < res->num_triangles; i++)
        cli_json_int(&j, res->found[i]);
    cli_json_array_end(&j);
    cli_json_key(&j, "contacts");
    cli_json_array_begin(&j);
    for (size_t i = 0; i < res->num_contacts; i++) {
        cli_json_object_begin(&j);
        cli_json_key_int(&j, "query", res->contacts[i].query);
        cli_json_key_string(&j, "object", res->objects.names[res->contacts[i].object]);
        cli_json_key_int(&j, "triangle", res->contacts[i].triangle);
        if (res->segments != NULL) {
            cli_json_key(&j, "segment");
            cli_json_object_begin(&j);
            cli_json_key_vec3(&j, "p", res->segments[i].p);
            cli_json_key_vec3(&j, "q", res->segments[i].q);
            cli_json_object_end(&j);
        }
        cli_json_object_end(&j);
    }
    cli_json_array_end(&j);
    cli_json_finish(&j);
}

static void point_cell(cli_table *t, trioct_vec3 p)
{
    char x[CLI_NUMBER_LEN], y[CLI_NUMBER_LEN], z[CLI_NUMBER_LEN];
    cli_table_cell(t, "%s %s %s", cli_format_double(p.x, x), cli_format_double(p.y, y),
                   cli_format_double(p.z, z));
}

static int tri_print(cli_context *ctx, const trioct_triangle_result *res)
{
    int32_t found = res->num_triangles > 0 ? res->found[0] : 0;
    fprintf(ctx->out, "world %s (version %" PRId64 ", daemon %s): ", res->reply.world,
            res->reply.world_version, res->reply.daemon);
    if (res->detail == TRIOCT_TRI_YESNO) {
        fprintf(ctx->out, "%s\n", found ? "touching" : "not touching");
        return CLI_EXIT_OK;
    }
    fprintf(ctx->out, "touching %" PRId32 " world triangle%s\n", found, found == 1 ? "" : "s");
    if (res->num_contacts == 0)
        return CLI_EXIT_OK;
    int segments = res->segments != NULL;
    cli_table t;
    cli_table_init(&t, segments ? 4 : 2, 2u);
    cli_table_cell(&t, "OBJECT");
    cli_table_cell(&t, "TRIANGLE");
    if (segments) {
        cli_table_cell(&t, "FROM");
        cli_table_cell(&t, "TO");
    }
    for (size_t i = 0; i < res->num_contacts; i++) {
        cli_table_cell(&t, "%s", res->objects.names[res->contacts[i].object]);
        cli_table_cell(&t, "%" PRId32, res->contacts[i].triangle);
        if (segments) {
            point_cell(&t, res->segments[i].p);
            point_cell(&t, res->segments[i].q);
        }
    }
    int rc = cli_table_print(&t, ctx->out, "");
    cli_table_free(&t);
    return rc == 0 ? CLI_EXIT_OK
                   : cli_internal_error(ctx, "out of memory printing %zu contacts", res->num_contacts);
}

static int run_tri(cli_context *ctx, int argc, char **argv)
{
    tri_args a = {.accuracy = TRIOCT_ACCURACY_WORLD};
    char *pos[CLI_MAX_POSITIONAL];
    int npos;
    int rc = cli_command_args(ctx, &cli_command_tri, argc, argv, tri_options, tri_option, &a, pos,
                              &npos);
    if (rc >= 0)
        return rc;
    if (npos != 10)
        return cli_usage_error(ctx, "expected 10 arguments, WORLD x1 y1 z1 x2 y2 z2 x3 y3 z3; got %d",
                               npos);
    if ((rc = cli_check_name(ctx, "world", pos[0])) >= 0)
        return rc;
    if (a.ids && a.segments)
        return cli_usage_error(ctx, "--ids and --segments exclude each other (segments carry the ids)");
    double v[9];
    for (int i = 0; i < 9; i++)
        if (cli_parse_double(pos[1 + i], 0, &v[i]) != 0)
            return cli_usage_error(ctx, "coordinate %d: '%.40s' is not a finite number", i + 1,
                                   pos[1 + i]);
    if ((rc = cli_connect(ctx)) >= 0)
        return rc;
    trioct_triangle tri = {{v[0], v[1], v[2]}, {v[3], v[4], v[5]}, {v[6], v[7], v[8]}};
    trioct_triangle_query q = {
        .world = pos[0],
        .detail = a.segments ? TRIOCT_TRI_SEGMENTS : a.ids ? TRIOCT_TRI_IDS : TRIOCT_TRI_YESNO,
        .accuracy = a.accuracy,
        .count = 1,
        .triangles = &tri,
    };
    int timeout = cli_timeout(ctx, CLI_DEFAULT_TIMEOUT_MS);
    trioct_triangle_result res;
    int status = trioct_triangles(ctx->client, &q, timeout, &res);
    rc = CLI_EXIT_OK;
    if (status != TRIOCT_OK)
        rc = cli_report_failure(ctx, &res.reply, timeout, NULL);
    else if (ctx->json)
        tri_json(ctx, &res, a.accuracy);
    else
        rc = tri_print(ctx, &res);
    trioct_triangle_result_free(&res);
    return rc;
}

const cli_command cli_command_tri = {
    "tri",
    "test one triangle against the world: yes/no, triangle ids, contact segments",
    "Usage: trioct tri WORLD x1 y1 z1 x2 y2 z2 x3 y3 z3 [--ids | --segments]\n"
    "                  [--accuracy MODE] [global options]\n"
    "\n"
    "Tests the triangle with corners (x1 y1 z1), (x2 y2 z2), (x3 y3 z3) against WORLD.\n"
    "Touching includes contact at a single point and coplanar overlap; a zero-area\n"
    "triangle acts as the segment or point it is. Contact is with surfaces: a triangle\n"
    "wholly inside an object touches it only when the object is solid (solid = yes in\n"
    "the scene; exact mode), and is then reported with triangle id -1.\n"
    "\n"
    "Options:\n"
    "  --ids           the ids of every world triangle it touches (sorted)\n"
    "  --segments      the ids and, for each, the contact segment (from == to for a\n"
    "                  point contact)\n"
    "  --accuracy MODE exact, seed, fast, or world (the world's own mode; default)\n"
    "\n"
    "Examples:\n"
    "  trioct tri cell 0 0 0  1 0 0  0 1 0\n"
    "  trioct tri cell 0 0 0  1 0 0  0 1 0 --segments --json\n",
    run_tri,
};
