/* What every subcommand does around its request: scanning its arguments together with the
 * global options, opening input files, and the connection to the bus. */
#include <errno.h>
#include <limits.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cli_pose.h"

enum { OPT_URL, OPT_PREFIX, OPT_TIMEOUT, OPT_KEY_FILE, OPT_JSON, OPT_PROGRESS, OPT_HELP, OPT_VERSION };

const cli_option cli_global_options[] = {
    {"url", 0, 1, OPT_URL},
    {"prefix", 0, 1, OPT_PREFIX},
    {"timeout", 0, 1, OPT_TIMEOUT},
    {"key-file", 0, 1, OPT_KEY_FILE},
    {"json", 0, 0, OPT_JSON},
    {"progress", 0, 0, OPT_PROGRESS},
    {"help", 'h', 0, OPT_HELP},
    {"version", 'V', 0, OPT_VERSION},
    {NULL, 0, 0, 0},
};

int cli_global_option(void *user, int id, const char *value, char *err, size_t err_len)
{
    cli_context *ctx = user;
    long long v;
    switch (id) {
    case OPT_URL:
        if (value[0] == '\0') {
            snprintf(err, err_len, "--url: the URL is empty");
            return -1;
        }
        ctx->url = value;
        return 0;
    case OPT_PREFIX:
        if (!cli_name_valid(value, TRIOCT_MAX_PREFIX_LEN)) {
            snprintf(err, err_len, "--prefix: '%.40s' is not 1..%d characters of [A-Za-z0-9_]",
                     value, TRIOCT_MAX_PREFIX_LEN);
            return -1;
        }
        ctx->prefix = value;
        return 0;
    case OPT_TIMEOUT:
        if (cli_parse_int(value, 1, INT_MAX, &v) != 0) {
            snprintf(err, err_len, "--timeout: '%.40s' is not a whole number of milliseconds >= 1",
                     value);
            return -1;
        }
        ctx->timeout_ms = (int)v;
        return 0;
    case OPT_KEY_FILE:
        if (value[0] == '\0') {
            snprintf(err, err_len, "--key-file: the path is empty");
            return -1;
        }
        ctx->key_file = value;
        return 0;
    case OPT_JSON:
        ctx->json = 1;
        return 0;
    case OPT_PROGRESS:
        ctx->progress = 1;
        return 0;
    case OPT_HELP:
        ctx->help = 1;
        return 0;
    case OPT_VERSION:
        ctx->version = 1;
        return 0;
    }
    snprintf(err, err_len, "unhandled option %d", id);
    return -1;
}

int cli_command_args(cli_context *ctx, const cli_command *cmd, int argc, char **argv,
                     const cli_option *options, cli_option_fn handle, void *user,
                     char **positional, int *num_positional)
{
    cli_option_set sets[2] = {
        {cli_global_options, cli_global_option, ctx},
        {options, handle, user},
    };
    char err[512];
    int rc = cli_scan(argc, argv, sets, options ? 2 : 1, 0, positional, CLI_MAX_POSITIONAL,
                      num_positional, NULL, err, sizeof err);
    /* --help wins over whatever else is wrong on the line: it is what the user asked for. */
    if (ctx->help) {
        fputs(cmd->help, ctx->out);
        return CLI_EXIT_OK;
    }
    if (ctx->version) {
        fprintf(ctx->out, "trioct %s\n", TRIOCT_VERSION);
        return CLI_EXIT_OK;
    }
    if (rc != 0)
        return cli_usage_error(ctx, "%s", err);
    return -1;
}

int cli_usage_error(cli_context *ctx, const char *fmt, ...)
{
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (ctx->command)
        fprintf(ctx->err, "trioct %s: %s\nTry 'trioct %s --help'.\n", ctx->command, msg,
                ctx->command);
    else
        fprintf(ctx->err, "trioct: %s\nTry 'trioct --help'.\n", msg);
    if (ctx->json) {
        cli_json j;
        cli_json_init(&j, ctx->out);
        cli_json_envelope(&j, ctx, CLI_EXIT_USAGE, NULL);
        cli_json_key_string(&j, "message", msg);
        cli_json_finish(&j);
    }
    return CLI_EXIT_USAGE;
}

int cli_check_name(cli_context *ctx, const char *what, const char *name)
{
    if (cli_name_valid(name, TRIOCT_MAX_NAME_LEN))
        return -1;
    return cli_usage_error(ctx, "%s name '%.40s' is not 1..%d characters of [A-Za-z0-9_]", what,
                           name, TRIOCT_MAX_NAME_LEN);
}

int cli_open_input(cli_context *ctx, const char *path, FILE **file, const char **name)
{
    if (strcmp(path, "-") == 0) {
        *file = stdin;
        *name = "<stdin>";
        return -1;
    }
    *file = fopen(path, "r");
    *name = path;
    if (*file == NULL)
        return cli_usage_error(ctx, "cannot read %s: %s", path, strerror(errno));
    return -1;
}

void cli_close_input(FILE *file)
{
    if (file != NULL && file != stdin)
        fclose(file);
}

int cli_read_pose_file(cli_context *ctx, const char *path, cli_pose_list *poses)
{
    FILE *file;
    const char *name;
    int rc = cli_open_input(ctx, path, &file, &name);
    if (rc >= 0)
        return rc;
    char err[512];
    int read_rc = cli_read_poses(file, name, poses, err, sizeof err);
    cli_close_input(file);
    return read_rc == 0 ? -1 : cli_usage_error(ctx, "%s", err);
}

int cli_connect(cli_context *ctx)
{
    trioct_connect_options opt = {.url = ctx->url, .prefix = ctx->prefix, .admin_key_file = ctx->key_file};
    int status = 0;
    char err[TRIOCT_MAX_MESSAGE_LEN + 1];
    ctx->client = trioct_connect(&opt, &status, err, sizeof err);
    if (ctx->client != NULL)
        return -1;
    trioct_reply r = {.status = status};
    snprintf(r.message, sizeof r.message, "%s", err);
    return cli_report_failure(ctx, &r, 0, NULL);
}

void cli_disconnect(cli_context *ctx)
{
    trioct_disconnect(ctx->client);
    ctx->client = NULL;
}

int cli_timeout(const cli_context *ctx, int default_ms)
{
    return ctx->timeout_ms > 0 ? ctx->timeout_ms : default_ms;
}

const char *cli_bus_url(const cli_context *ctx)
{
    if (ctx->client != NULL)
        return trioct_url(ctx->client);
    if (ctx->url != NULL)
        return ctx->url;
    const char *env = getenv("LCM_DEFAULT_URL");
    return env && env[0] ? env : "LCM's default URL";
}
