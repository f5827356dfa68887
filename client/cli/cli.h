/* The trioct command: what its files share. One trioct run makes one connection, asks one
 * thing (or one batch), prints the answer for people or, with --json, as one JSON object,
 * and exits with a code that says how it went. */
#ifndef TRIOCT_CLI_H
#define TRIOCT_CLI_H

#include <stdio.h>

#include "cli_args.h"
#include "cli_json.h"
#include "trioct.h"
#include "trioct_version.h"


/* The exit codes: `trioct --help` and docs/cli.md list them. */
enum {
    CLI_EXIT_OK = 0,
    CLI_EXIT_DAEMON_ERROR = 1, /* a daemon answered with an error status */
    CLI_EXIT_USAGE = 2,        /* bad arguments or input: nothing was asked */
    CLI_EXIT_NO_REPLY = 3,     /* no daemon answered (or not all of the answer came) in time */
    CLI_EXIT_TRANSPORT = 4,    /* the LCM bus could not be opened or used */
    CLI_EXIT_BAD_REPLY = 5,    /* a reply made no sense, or trioct itself failed */
};

#define CLI_DEFAULT_TIMEOUT_MS 2000
#define CLI_LOAD_TIMEOUT_MS 60000 /* a load answers when the octree is built */
#define CLI_MAX_POSITIONAL 16     /* tri takes the most: WORLD and nine numbers */

typedef struct cli_context {
    const char *command; /* the subcommand, for messages and "command" in JSON; NULL before */
    const char *url;     /* --url; NULL: $LCM_DEFAULT_URL, else LCM's default */
    const char *prefix;  /* --prefix; NULL: TRIOCT */
    int timeout_ms;      /* --timeout; -1: the command's default */
    const char *key_file; /* --key-file; NULL: $TRIOCT_KEY_FILE, else changes go unsigned */
    int json;            /* --json */
    int progress;        /* --progress: progress lines even when stderr is not a terminal */
    int help, version;   /* --help, --version seen */
    FILE *out, *err;
    trioct_client *client;
} cli_context;

typedef struct cli_command {
    const char *name;
    const char *summary; /* one line in `trioct --help` */
    const char *help;    /* `trioct NAME --help`: usage, options, examples */
    int (*run)(cli_context *ctx, int argc, char **argv); /* the arguments after NAME */
} cli_command;

extern const cli_command cli_command_worlds, cli_command_info, cli_command_load,
    cli_command_unload, cli_command_ray, cli_command_rays, cli_command_tri, cli_command_mesh,
    cli_command_status, cli_command_objects, cli_command_object, cli_command_state, cli_command_render,
    cli_command_distance, cli_command_clear;

/* ---- cli_session.c: arguments, connection -------------------------------------------- */

/* The options every subcommand takes (--url, --prefix, --timeout, --json, --progress,
 * --help, --version) and their handler (user: the cli_context). */
extern const cli_option cli_global_options[];
int cli_global_option(void *ctx, int id, const char *value, char *err, size_t err_len);

/* Scans a subcommand's arguments: its own options (may be NULL) and the global ones, the
 * rest into positional[CLI_MAX_POSITIONAL]. Returns -1 to go on; otherwise the run is over
 * and the return is its exit code (0 after --help or --version, 2 after a usage error,
 * already reported). */
int cli_command_args(cli_context *ctx, const cli_command *cmd, int argc, char **argv,
                     const cli_option *options, cli_option_fn handle, void *user,
                     char **positional, int *num_positional);

/* Reports a usage error (and, with --json, its JSON object); returns CLI_EXIT_USAGE. */
int cli_usage_error(cli_context *ctx, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Checks a world, daemon or shape name; a usage error naming `what` when it is invalid.
 * Returns -1 to go on, or CLI_EXIT_USAGE. */
int cli_check_name(cli_context *ctx, const char *what, const char *name);

/* Opens path for reading ("-": standard input). Returns -1 with *file and *name set, or
 * CLI_EXIT_USAGE (reported) when it cannot be opened. */
int cli_open_input(cli_context *ctx, const char *path, FILE **file, const char **name);
void cli_close_input(FILE *file);

/* Appends the poses of path ("-": standard input), one a line as cli_read_poses reads them,
 * to *poses. Returns -1 to go on, or CLI_EXIT_USAGE (reported). */
typedef struct cli_pose_list cli_pose_list;
int cli_read_pose_file(cli_context *ctx, const char *path, cli_pose_list *poses);

/* Connects to the bus. Returns -1 to go on, or the exit code (reported). */
int cli_connect(cli_context *ctx);
void cli_disconnect(cli_context *ctx);

/* --timeout, or the command's default. */
int cli_timeout(const cli_context *ctx, int default_ms);

/* The bus in words: the connection's URL, or what it would be. */
const char *cli_bus_url(const cli_context *ctx);

/* ---- cli_report.c: outcomes ---------------------------------------------------------- */

/* The exit code of a call's outcome. */
int cli_exit_code(const trioct_reply *r);

/* Reports a call that did not succeed: on stderr for people (with, when nothing answered,
 * "no reply from any daemon serving world W on <url> within <t> ms: ..."), and with --json as
 * the command's JSON object on stdout. part (may be NULL) says which part of a batch
 * failed. Returns the exit code. */
int cli_report_failure(cli_context *ctx, const trioct_reply *r, int timeout_ms, const char *part);

/* The sentence for a call nothing answered: who was asked (r's daemon or world, when it
 * names one), where, and what to check for that transport. */
void cli_no_reply_hint(const cli_context *ctx, const trioct_reply *r, int timeout_ms, char *buf, size_t len);

/* Begins the command's JSON object with the fields every one has: command, ok, exit_code,
 * status, status_code, message, and daemon, world, world_version when r names them. */
void cli_json_envelope(cli_json *j, const cli_context *ctx, int exit_code, const trioct_reply *r);

/* Ends a JSON line. */
void cli_json_finish(cli_json *j);

/* Reports what is not a call's outcome but trioct's own failure (out of memory, say):
 * exit code CLI_EXIT_BAD_REPLY. */
int cli_internal_error(cli_context *ctx, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* A heads-up on stderr that does not change the outcome ("world box was rebuilt during the
 * batch"). */
void cli_warn(cli_context *ctx, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

#endif
