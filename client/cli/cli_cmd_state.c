/* The state subcommand: one robot state, its links each a registered shape at a pose,
 * checked against the world's objects and, with --self, against each other. */
#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cli_pose.h"
#include "cli_text.h"

enum { STATE_MAX_CLI_LINKS = 64, STATE_MAX_CLI_ALLOWED = 256 };

typedef struct state_args {
    trioct_state_link links[STATE_MAX_CLI_LINKS];
    char names[STATE_MAX_CLI_LINKS][TRIOCT_MAX_NAME_LEN + 1];
    trioct_pose poses[STATE_MAX_CLI_LINKS];
    double quaternions[STATE_MAX_CLI_LINKS][4]; /* as typed: what is sent */
    size_t num_links;
    trioct_allowed_pair allowed[STATE_MAX_CLI_ALLOWED];
    char allowed_text[STATE_MAX_CLI_ALLOWED][2 * TRIOCT_MAX_NAME_LEN + 2];
    size_t num_allowed;
    int self, contacts;
} state_args;

/* Takes every "--link SHAPE x y z qw qx qy qz" out of argv (so that the numbers are not read
 * as options), compacting the rest. A link is named after its shape; the second link of a
 * shape is SHAPE.2, and so on. 0, or -1 with err. */
static int take_links(int *argc, char **argv, state_args *a, char *err, size_t err_len)
{
    for (int i = 0; i < *argc; i++) {
        if (strcmp(argv[i], "--") == 0)
            break;
        if (strcmp(argv[i], "--link") != 0)
            continue;
        if (i + 8 >= *argc) {
            snprintf(err, err_len, "--link takes a shape and seven numbers: SHAPE x y z qw qx qy qz");
            return -1;
        }
        if (a->num_links == STATE_MAX_CLI_LINKS) {
            snprintf(err, err_len, "at most %d links", STATE_MAX_CLI_LINKS);
            return -1;
        }
        const char *shape = argv[i + 1];
        if (!cli_name_valid(shape, TRIOCT_MAX_NAME_LEN)) {
            snprintf(err, err_len, "--link: '%.40s' is not a shape name (1..%d of [A-Za-z0-9_])", shape,
                     TRIOCT_MAX_NAME_LEN);
            return -1;
        }
        size_t k = a->num_links;
        if (cli_parse_quaternion_pose(&argv[i + 2], "--link", &a->poses[k], a->quaternions[k], err, err_len) != 0)
            return -1;
        int same = 0;
        for (size_t j = 0; j < k; j++)
            same += strcmp(a->links[j].shape, shape) == 0;
        if (same == 0)
            snprintf(a->names[k], sizeof a->names[k], "%s", shape);
        else
            snprintf(a->names[k], sizeof a->names[k], "%.28s.%u", shape, (unsigned)(same + 1) % 100u);
        a->links[k] = (trioct_state_link){a->names[k], shape, 0, NULL};
        a->num_links++;
        memmove(&argv[i], &argv[i + 9], (size_t)(*argc - i - 9) * sizeof *argv);
        *argc -= 9;
        i--;
    }
    return 0;
}

enum { OPT_ALLOW, OPT_SELF, OPT_CONTACTS };

static const cli_option state_options[] = {
    {"allow", 0, 1, OPT_ALLOW},
    {"self", 0, 0, OPT_SELF},
    {"contacts", 0, 0, OPT_CONTACTS},
    {NULL, 0, 0, 0},
};

static int state_option(void *user, int id, const char *value, char *err, size_t err_len)
{
    state_args *a = user;
    if (id == OPT_SELF) {
        a->self = 1;
        return 0;
    }
    if (id == OPT_CONTACTS) {
        a->contacts = 1;
        return 0;
    }
    const char *colon = strchr(value, ':');
    if (colon == NULL || colon == value || colon[1] == '\0' || strlen(value) >= sizeof a->allowed_text[0]) {
        snprintf(err, err_len, "--allow: '%.40s' is not A:B (a link and an object, or two links)", value);
        return -1;
    }
    if (a->num_allowed == STATE_MAX_CLI_ALLOWED) {
        snprintf(err, err_len, "at most %d --allow pairs", STATE_MAX_CLI_ALLOWED);
        return -1;
    }
    char *text = a->allowed_text[a->num_allowed];
    snprintf(text, sizeof a->allowed_text[0], "%s", value);
    text[colon - value] = '\0';
    a->allowed[a->num_allowed] = (trioct_allowed_pair){text, text + (colon - value) + 1};
    a->num_allowed++;
    return 0;
}

static const char *other_name(const state_args *a, const trioct_state_result *res, const trioct_state_contact *c)
{
    if (c->with_link)
        return c->other >= 0 && (size_t)c->other < a->num_links ? a->names[c->other] : "?";
    return c->other >= 0 && (size_t)c->other < res->objects.count ? res->objects.names[c->other] : "?";
}

static void state_json(cli_context *ctx, const state_args *a, const trioct_state_result *res)
{
    cli_json j;
    cli_json_init(&j, ctx->out);
    cli_json_envelope(&j, ctx, CLI_EXIT_OK, &res->reply);
    cli_json_key_string(&j, "detail", a->contacts ? "contacts" : "valid");
    cli_json_key_bool(&j, "self", a->self);
    cli_json_key_int(&j, "links", (int64_t)a->num_links);
    cli_json_key_bool(&j, "valid", res->num_states > 0 && res->valid[0]);
    cli_json_key_int(&j, "found", res->num_states > 0 ? res->found[0] : 0);
    cli_json_key(&j, "contacts");
    cli_json_array_begin(&j);
    for (size_t i = 0; i < res->num_contacts; i++) {
        const trioct_state_contact *c = &res->contacts[i];
        cli_json_object_begin(&j);
        cli_json_key_string(&j, "link", a->names[c->link]);
        cli_json_key_string(&j, "other", other_name(a, res, c));
        cli_json_key_string(&j, "other_kind", c->with_link ? "link" : "object");
        cli_json_key_int(&j, "link_triangle", c->link_triangle);
        cli_json_key_int(&j, "other_triangle", c->other_triangle);
        cli_json_object_end(&j);
    }
    cli_json_array_end(&j);
    cli_json_finish(&j);
}

static int state_print(cli_context *ctx, const state_args *a, const trioct_state_result *res)
{
    int valid = res->num_states > 0 && res->valid[0];
    fprintf(ctx->out, "world %s (version %" PRId64 ", daemon %s), %zu link%s: %s\n", res->reply.world,
            res->reply.world_version, res->reply.daemon, a->num_links, a->num_links == 1 ? "" : "s",
            valid ? "valid" : "in collision");
    if (res->num_contacts == 0)
        return CLI_EXIT_OK;
    cli_table t;
    cli_table_init(&t, 4, 0xC);
    cli_table_cell(&t, "LINK");
    cli_table_cell(&t, "TOUCHES");
    cli_table_cell(&t, "LINK TRIANGLE");
    cli_table_cell(&t, "ITS TRIANGLE");
    for (size_t i = 0; i < res->num_contacts; i++) {
        const trioct_state_contact *c = &res->contacts[i];
        cli_table_cell(&t, "%s", a->names[c->link]);
        cli_table_cell(&t, "%s %s", c->with_link ? "link" : "object", other_name(a, res, c));
        cli_table_cell(&t, "%" PRId32, c->link_triangle);
        cli_table_cell(&t, "%" PRId32, c->other_triangle);
    }
    int rc = cli_table_print(&t, ctx->out, "");
    cli_table_free(&t);
    return rc == 0 ? CLI_EXIT_OK : cli_internal_error(ctx, "out of memory printing the contacts");
}

static int run_state(cli_context *ctx, int argc, char **argv)
{
    state_args *a = calloc(1, sizeof *a);
    char **args = calloc((size_t)argc + 1, sizeof *args);
    if (a == NULL || args == NULL) {
        free(a);
        free(args);
        return cli_internal_error(ctx, "out of memory");
    }
    memcpy(args, argv, (size_t)argc * sizeof *args);
    int n = argc;
    char err[256];
    int rc = -1;
    if (take_links(&n, args, a, err, sizeof err) != 0)
        rc = cli_usage_error(ctx, "%s", err);
    char *pos[CLI_MAX_POSITIONAL];
    int npos = 0;
    if (rc < 0)
        rc = cli_command_args(ctx, &cli_command_state, n, args, state_options, state_option, a, pos, &npos);
    if (rc < 0 && npos != 1)
        rc = cli_usage_error(ctx, "expected one argument, WORLD; got %d", npos);
    if (rc < 0 && a->num_links == 0)
        rc = cli_usage_error(ctx, "no link: give --link SHAPE x y z qw qx qy qz at least once");
    if (rc < 0)
        rc = cli_check_name(ctx, "world", pos[0]);
    if (rc < 0)
        rc = cli_connect(ctx);
    if (rc < 0) {
        int timeout = cli_timeout(ctx, CLI_DEFAULT_TIMEOUT_MS);
        trioct_state_query q = {pos[0],      a->contacts ? TRIOCT_STATE_CONTACTS : TRIOCT_STATE_VALID,
                                a->self,     a->num_links,
                                a->links,    a->num_allowed,
                                a->allowed,  1,
                                a->poses,    &a->quaternions[0][0]};
        trioct_state_result res;
        int status = trioct_states(ctx->client, &q, timeout, &res);
        if (status != TRIOCT_OK) {
            rc = cli_report_failure(ctx, &res.reply, timeout, NULL);
        } else if (ctx->json) {
            state_json(ctx, a, &res);
            rc = CLI_EXIT_OK;
        } else {
            rc = state_print(ctx, a, &res);
        }
        trioct_state_result_free(&res);
    }
    free(args);
    free(a);
    return rc;
}

const cli_command cli_command_state = {
    "state",
    "check a robot state: links at poses against the world and each other",
    "Usage: trioct state WORLD --link SHAPE x y z qw qx qy qz [--link ...] [--allow A:B]...\n"
    "                    [--self] [--contacts] [global options]\n"
    "\n"
    "Places each link, a query shape the world's scene registers, at its pose (a position\n"
    "and a unit quaternion w x y z) and checks them all against the world's objects in one\n"
    "request; with --self also against each other. A link is named after its shape (a\n"
    "second link of one shape is SHAPE.2). --allow A:B leaves out the pair of a link and an\n"
    "object, or of two links, either way round (an allowed-collision matrix entry). The\n"
    "answer is valid or in collision with the first contact found; --contacts lists every\n"
    "colliding (link, object or link, triangle pair). The world must serve meshes.\n"
    "Contact is surface contact unless the object is solid: a link wholly inside a solid\n"
    "collides with it through triangle -1 (docs/engine.md, \"Solid objects\").\n"
    "\n"
    "Options:\n"
    "  --link SHAPE x y z qw qx qy qz   a link at its pose (repeat, up to 64)\n"
    "  --allow A:B                      a pair that may touch (repeat)\n"
    "  --self                           check the links against each other too\n"
    "  --contacts                       every contact, not the first\n"
    "\n"
    "Examples:\n"
    "  trioct state cell --link probe 1 0 0.5 1 0 0 0 --link probe 1.2 0 0.5 1 0 0 0 --self\n"
    "  trioct state cell --link probe 0 0 0 1 0 0 0 --allow probe:floor --contacts --json\n",
    run_state,
};
