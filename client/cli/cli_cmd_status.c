/* The status subcommand: the daemons' heartbeats (state, load, latency, errors, worlds).
 * Without --follow it listens until every daemon that publishes has been heard once (one
 * of them is heard a second time, so a whole heartbeat interval has passed) or the
 * timeout ends; with --follow it prints every heartbeat as it comes. */
#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cli_progress.h"
#include "cli_text.h"
#include "cli_world_info.h"

/* Daemons one report lists: more than one bus sensibly carries, and a bound on the array. */
#define STATUS_MAX_DAEMONS 256

enum { OPT_FOLLOW, OPT_COUNT, OPT_DAEMON };

typedef struct status_args {
    int follow;
    long long count; /* 0: no limit */
    const char *daemon;
} status_args;

static const cli_option status_options[] = {
    {"follow", 'f', 0, OPT_FOLLOW},
    {"count", 0, 1, OPT_COUNT},
    {"daemon", 0, 1, OPT_DAEMON},
    {NULL, 0, 0, 0},
};

static int status_option(void *user, int id, const char *value, char *err, size_t err_len)
{
    status_args *a = user;
    switch (id) {
    case OPT_FOLLOW:
        a->follow = 1;
        return 0;
    case OPT_COUNT:
        if (cli_parse_int(value, 1, 1000000000, &a->count) != 0) {
            snprintf(err, err_len, "--count: '%.40s' is not a whole number >= 1", value);
            return -1;
        }
        return 0;
    case OPT_DAEMON:
        if (!cli_name_valid(value, TRIOCT_MAX_NAME_LEN)) {
            snprintf(err, err_len, "--daemon: '%.40s' is not 1..%d characters of [A-Za-z0-9_]",
                     value, TRIOCT_MAX_NAME_LEN);
            return -1;
        }
        a->daemon = value;
        return 0;
    }
    return -1;
}

static int64_t error_replies(const trioct_daemon_status *s)
{
    int64_t n = 0;
    for (size_t code = 1; code < s->num_status_codes; code++)
        n += s->replies_by_status[code];
    return n;
}

static void daemon_json(cli_json *j, const trioct_daemon_status *s)
{
    cli_json_object_begin(j);
    cli_json_key_string(j, "daemon", s->reply.daemon);
    cli_json_key_string(j, "version", s->version);
    cli_json_key_string(j, "state", cli_daemon_state_name(s->state));
    cli_json_key_double(j, "uptime_s", (double)s->uptime_us / 1e6);
    cli_json_key_int(j, "threads", s->threads);
    cli_json_key_int(j, "queue_depth", s->queue_depth);
    cli_json_key_int(j, "queue_capacity", s->queue_capacity);
    cli_json_key_int(j, "memory_used", s->memory_used);
    cli_json_key_int(j, "memory_budget", s->memory_budget);
    cli_json_key_int(j, "duplicates_answered", s->duplicates_answered);
    cli_json_key_int(j, "duplicates_joined", s->duplicates_joined);
    cli_json_key(j, "served");
    cli_json_object_begin(j);
    cli_json_key_int(j, "ray", s->served[0]);
    cli_json_key_int(j, "triangle", s->served[1]);
    cli_json_key_int(j, "mesh", s->served[2]);
    cli_json_key_int(j, "admin", s->served[3]);
    cli_json_key_int(j, "objects", s->served[4]);
    cli_json_key_int(j, "state", s->served[5]);
    cli_json_key_int(j, "distance", s->served[6]);
    cli_json_object_end(j);
    cli_json_key_int(j, "errors", error_replies(s));
    cli_json_key(j, "replies_by_status");
    cli_json_object_begin(j);
    for (size_t code = 0; code < s->num_status_codes; code++)
        if (s->replies_by_status[code] != 0)
            cli_json_key_int(j, trioct_status_name((int)code), s->replies_by_status[code]);
    cli_json_object_end(j);
    cli_json_key_int(j, "malformed", s->malformed);
    cli_json_key(j, "latency_us");
    cli_json_object_begin(j);
    cli_json_key_int(j, "p50", s->latency_p50_us);
    cli_json_key_int(j, "p99", s->latency_p99_us);
    cli_json_key_int(j, "count", s->latency_count);
    cli_json_object_end(j);
    cli_json_key(j, "worlds");
    cli_json_array_begin(j);
    for (size_t i = 0; i < s->num_worlds; i++)
        cli_world_info_json(j, &s->worlds[i]);
    cli_json_array_end(j);
    cli_json_key(j, "loads");
    cli_json_array_begin(j);
    for (size_t i = 0; i < s->num_loads; i++)
        cli_load_progress_json(j, &s->loads[i]);
    cli_json_array_end(j);
    cli_json_object_end(j);
}

static void status_json(cli_context *ctx, const trioct_daemon_status *s, size_t n)
{
    cli_json j;
    cli_json_init(&j, ctx->out);
    trioct_reply ok = {.status = TRIOCT_OK};
    snprintf(ok.message, sizeof ok.message, "%zu daemon%s heard", n, n == 1 ? "" : "s");
    cli_json_envelope(&j, ctx, CLI_EXIT_OK, &ok);
    cli_json_key(&j, "daemons");
    cli_json_array_begin(&j);
    for (size_t i = 0; i < n; i++)
        daemon_json(&j, &s[i]);
    cli_json_array_end(&j);
    cli_json_finish(&j);
}

static void print_errors(FILE *out, const trioct_daemon_status *s)
{
    fprintf(out, "  errors    %" PRId64, error_replies(s));
    const char *sep = " (";
    for (size_t code = 1; code < s->num_status_codes; code++)
        if (s->replies_by_status[code] != 0) {
            fprintf(out, "%s%s %" PRId64, sep, trioct_status_name((int)code),
                    s->replies_by_status[code]);
            sep = ", ";
        }
    fprintf(out, "%s, %" PRId64 " malformed messages dropped\n", sep[0] == ',' ? ")" : "",
            s->malformed);
}

static int daemon_print(cli_context *ctx, const trioct_daemon_status *s)
{
    FILE *out = ctx->out;
    fprintf(out, "daemon %s: %s, trioctd %s, up %.1f s, %d threads\n", s->reply.daemon,
            cli_daemon_state_name(s->state), s->version, (double)s->uptime_us / 1e6, s->threads);
    fprintf(out, "  queue     %d of %d\n", s->queue_depth, s->queue_capacity);
    char used[32], budget[32];
    fprintf(out, "  memory    %s of %s\n", cli_format_bytes(s->memory_used, used),
            cli_format_bytes(s->memory_budget, budget));
    fprintf(out, "  retries   %" PRId64 " answered again from the reply cache, %" PRId64 " joined to one in work\n",
            s->duplicates_answered, s->duplicates_joined);
    fprintf(out,
            "  served    ray %" PRId64 ", triangle %" PRId64 ", mesh %" PRId64 ", admin %" PRId64
            ", objects %" PRId64 ", state %" PRId64 ", distance %" PRId64 "\n",
            s->served[0], s->served[1], s->served[2], s->served[3], s->served[4], s->served[5], s->served[6]);
    if (s->latency_count > 0)
        fprintf(out,
                "  latency   p50 %" PRId64 " us, p99 %" PRId64 " us (%" PRId64
                " requests in the last interval)\n",
                s->latency_p50_us, s->latency_p99_us, s->latency_count);
    else
        fprintf(out, "  latency   - (no requests in the last interval)\n");
    print_errors(out, s);
    fprintf(out, "  worlds    %zu\n", s->num_worlds);
    if (s->num_worlds > 0 && cli_world_table_print(out, s->worlds, s->num_worlds, "    ") != 0)
        return cli_internal_error(ctx, "out of memory printing %zu worlds", s->num_worlds);
    if (s->num_loads > 0)
        fprintf(out, "  building  %zu world%s\n", s->num_loads, s->num_loads == 1 ? "" : "s");
    for (size_t i = 0; i < s->num_loads; i++) {
        char line[256];
        cli_load_progress_text(&s->loads[i], line, sizeof line);
        fprintf(out, "    %s\n", line);
    }
    return CLI_EXIT_OK;
}

static int status_output(cli_context *ctx, const trioct_daemon_status *s, size_t n)
{
    if (ctx->json) {
        status_json(ctx, s, n);
        return CLI_EXIT_OK;
    }
    for (size_t i = 0; i < n; i++) {
        int rc = daemon_print(ctx, &s[i]);
        if (rc != CLI_EXIT_OK)
            return rc;
    }
    fflush(ctx->out);
    return CLI_EXIT_OK;
}

/* The no-heartbeat failure, said for the bus and, with --daemon, for that daemon. */
static int no_status(cli_context *ctx, const trioct_daemon_status *s, int timeout)
{
    return cli_report_failure(ctx, &s->reply, timeout, NULL);
}

/* --follow (or --count): every heartbeat as it comes. */
static int follow(cli_context *ctx, const status_args *a, int timeout)
{
    for (long long printed = 0; a->count == 0 || printed < a->count; printed++) {
        trioct_daemon_status s;
        int status = trioct_next_status(ctx->client, a->daemon, timeout, &s);
        int rc = status == TRIOCT_OK ? status_output(ctx, &s, 1) : no_status(ctx, &s, timeout);
        trioct_daemon_status_free(&s);
        if (rc != CLI_EXIT_OK)
            return rc;
    }
    return CLI_EXIT_OK;
}

static int heard(const trioct_daemon_status *s, size_t n, const char *daemon)
{
    for (size_t i = 0; i < n; i++)
        if (strcmp(s[i].reply.daemon, daemon) == 0)
            return 1;
    return 0;
}

/* Once: the first heartbeat, then the others of the same interval. */
static int once(cli_context *ctx, const status_args *a, int timeout)
{
    trioct_daemon_status *all = calloc(STATUS_MAX_DAEMONS, sizeof *all);
    if (all == NULL)
        return cli_internal_error(ctx, "out of memory for daemon statuses");
    size_t n = 0;
    int64_t deadline = cli_now_ns() + (int64_t)timeout * 1000000;
    int rc = CLI_EXIT_OK;
    int status = trioct_next_status(ctx->client, a->daemon, timeout, &all[0]);
    if (status != TRIOCT_OK)
        rc = no_status(ctx, &all[0], timeout);
    else
        n = 1;
    while (rc == CLI_EXIT_OK && a->daemon == NULL && n < STATUS_MAX_DAEMONS) {
        int64_t left_ms = (deadline - cli_now_ns()) / 1000000;
        if (left_ms <= 0)
            break;
        trioct_daemon_status s;
        if (trioct_next_status(ctx->client, NULL, (int)left_ms, &s) != TRIOCT_OK) {
            trioct_daemon_status_free(&s);
            break;
        }
        if (heard(all, n, s.reply.daemon)) {
            trioct_daemon_status_free(&s);
            break;
        }
        all[n++] = s;
    }
    if (rc == CLI_EXIT_OK)
        rc = status_output(ctx, all, n);
    for (size_t i = 0; i < n; i++)
        trioct_daemon_status_free(&all[i]);
    free(all);
    return rc;
}

static int run_status(cli_context *ctx, int argc, char **argv)
{
    status_args a = {0};
    char *pos[CLI_MAX_POSITIONAL];
    int npos;
    int rc = cli_command_args(ctx, &cli_command_status, argc, argv, status_options, status_option,
                              &a, pos, &npos);
    if (rc >= 0)
        return rc;
    if (npos != 0)
        return cli_usage_error(ctx, "takes no arguments, got '%s'", pos[0]);
    if ((rc = cli_connect(ctx)) >= 0)
        return rc;
    int timeout = cli_timeout(ctx, CLI_DEFAULT_TIMEOUT_MS);
    return a.follow || a.count > 0 ? follow(ctx, &a, timeout) : once(ctx, &a, timeout);
}

const cli_command cli_command_status = {
    "status",
    "the daemons' heartbeats: state, load, latency, errors, worlds",
    "Usage: trioct status [--follow] [--count N] [--daemon NAME] [global options]\n"
    "\n"
    "Listens to the heartbeat every daemon publishes (once a second by default) and prints,\n"
    "per daemon: its state, version and uptime, queue depth, requests served by type,\n"
    "latency p50/p99 over the last interval, error replies by status, malformed messages\n"
    "dropped, and its worlds. Without --follow it prints each daemon heard within one\n"
    "heartbeat interval (or the timeout) and exits.\n"
    "\n"
    "Options:\n"
    "  -f, --follow    keep printing every heartbeat as it arrives, until interrupted\n"
    "                  (Ctrl-C); exit code 3 when none comes within --timeout\n"
    "  --count N       print N heartbeats, then exit (implies --follow)\n"
    "  --daemon NAME   only the daemon NAME\n"
    "\n"
    "With --json every printed report is one JSON object on its own line.\n"
    "\n"
    "Examples:\n"
    "  trioct status\n"
    "  trioct status --daemon trioctd --json\n"
    "  trioct status --follow --json | jq .daemons[0].latency_us\n",
    run_status,
};
