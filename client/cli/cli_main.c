/* trioct: the command line of trioctd. main finds the subcommand and hands it the rest of
 * the line; global options may come before the subcommand or anywhere after it. */
#include <stdlib.h>
#include <string.h>

#include "cli.h"

static const cli_command *const commands[] = {
    &cli_command_worlds, &cli_command_info, &cli_command_load, &cli_command_unload,
    &cli_command_ray,    &cli_command_rays, &cli_command_tri,  &cli_command_mesh,
    &cli_command_status, &cli_command_objects, &cli_command_object, &cli_command_state,
    &cli_command_render, &cli_command_distance, &cli_command_clear,
};
#define NUM_COMMANDS (sizeof commands / sizeof commands[0])

static const char global_help[] =
    "Global options (before or after the command):\n"
    "  --url URL        the LCM bus (default: $LCM_DEFAULT_URL, else LCM's default,\n"
    "                   udpm://239.255.76.67:7667?ttl=0)\n"
    "  --prefix P       the deployment's channel prefix (default TRIOCT)\n"
    "  --timeout MS     how long to wait for an answer (default 2000; load: 60000)\n"
    "  --key-file FILE  the daemon's admin key, which load, unload and object edits\n"
    "                   are signed with (default: $TRIOCT_KEY_FILE; a daemon refuses\n"
    "                   them unsigned)\n"
    "  --json           print one JSON object (one line) instead of text\n"
    "  --progress       show the progress of long batches even when stderr is not a\n"
    "                   terminal\n"
    "  -h, --help       this help, or a command's: trioct ray --help\n"
    "  -V, --version    the version\n"
    "\n"
    "Exit codes:\n"
    "  0  ok\n"
    "  1  a daemon answered with an error status (the message says which and why)\n"
    "  2  usage error: bad arguments or input; nothing was asked\n"
    "  3  no reply: no daemon answered in time (or part of the answer never came)\n"
    "  4  transport failure: the LCM bus could not be opened or used\n"
    "  5  a reply could not be decoded, or trioct itself failed (out of memory, output)\n";

static void print_main_help(FILE *out)
{
    fputs("Usage: trioct [global options] COMMAND [arguments] [options]\n"
          "\n"
          "Asks trioctd, the collision-query daemon, about its worlds over LCM.\n"
          "\n"
          "Commands:\n",
          out);
    for (size_t i = 0; i < NUM_COMMANDS; i++)
        fprintf(out, "  %-8s %s\n", commands[i]->name, commands[i]->summary);
    fputs("\n", out);
    fputs(global_help, out);
    fputs("\n"
          "Examples:\n"
          "  trioct worlds\n"
          "  trioct ray yard 0 0 50 0 0 -1\n"
          "  trioct rays yard scan.csv --json\n"
          "  trioct status --follow\n"
          "\n"
          "docs/cli.md describes every command and the --json fields.\n",
          out);
}

static const cli_command *find_command(const char *name)
{
    for (size_t i = 0; i < NUM_COMMANDS; i++)
        if (strcmp(commands[i]->name, name) == 0)
            return commands[i];
    return NULL;
}

/* --json anywhere on the line: a usage error found before its place is reached is still
 * reported as JSON. */
static int wants_json(int argc, char **argv)
{
    for (int i = 1; i < argc && strcmp(argv[i], "--") != 0; i++)
        if (strcmp(argv[i], "--json") == 0)
            return 1;
    return 0;
}

/* `trioct help [COMMAND]`. */
static int run_help(cli_context *ctx, int argc, char **argv)
{
    if (argc == 0) {
        print_main_help(ctx->out);
        return CLI_EXIT_OK;
    }
    const cli_command *cmd = find_command(argv[0]);
    if (cmd == NULL)
        return cli_usage_error(ctx, "unknown command '%s'", argv[0]);
    fputs(cmd->help, ctx->out);
    return CLI_EXIT_OK;
}

static int run(cli_context *ctx, int argc, char **argv)
{
    cli_option_set globals = {cli_global_options, cli_global_option, ctx};
    int consumed = 0;
    char err[512];
    int scan_rc = cli_scan(argc - 1, argv + 1, &globals, 1, 1, NULL, 0, NULL, &consumed, err, sizeof err);
    if (ctx->help) { /* what was asked for, whatever else is wrong on the line */
        print_main_help(ctx->out);
        return CLI_EXIT_OK;
    }
    if (ctx->version) {
        fprintf(ctx->out, "trioct %s\n", TRIOCT_VERSION);
        return CLI_EXIT_OK;
    }
    if (scan_rc != 0)
        return cli_usage_error(ctx, "%s", err);
    int at = 1 + consumed;
    if (at >= argc)
        return cli_usage_error(ctx, "no command given");
    if (strcmp(argv[at], "help") == 0)
        return run_help(ctx, argc - at - 1, argv + at + 1);
    const cli_command *cmd = find_command(argv[at]);
    if (cmd == NULL)
        return cli_usage_error(ctx, "unknown command '%s'", argv[at]);
    ctx->command = cmd->name;
    return cmd->run(ctx, argc - at - 1, argv + at + 1);
}

int main(int argc, char **argv)
{
    cli_context ctx = {
        .timeout_ms = -1,
        .json = wants_json(argc, argv),
        .out = stdout,
        .err = stderr,
    };
    int rc = run(&ctx, argc, argv);
    cli_disconnect(&ctx);
    /* Output that never reached its file is a failure, not a success. */
    if (fflush(stdout) != 0 || ferror(stdout)) {
        fprintf(stderr, "trioct: cannot write the output\n");
        if (rc == CLI_EXIT_OK)
            rc = CLI_EXIT_BAD_REPLY;
    }
    return rc;
}
