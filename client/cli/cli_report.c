/* How a run ends: the exit code of an outcome, and the words (and JSON) that report it. */
#include <stdarg.h>
#include <string.h>

#include "cli.h"

int cli_exit_code(const trioct_reply *r)
{
    switch (r->status) {
    case TRIOCT_OK:
        return CLI_EXIT_OK;
    case TRIOCT_ERR_TIMEOUT:
    case TRIOCT_ERR_NO_DAEMON:
        return CLI_EXIT_NO_REPLY;
    case TRIOCT_ERR_TRANSPORT:
        return CLI_EXIT_TRANSPORT;
    case TRIOCT_ERR_BAD_REPLY:
        return CLI_EXIT_BAD_REPLY;
    }
    /* Nothing was sent: the library refused the request itself (a cap, a malformed field)
     * or ran out of memory preparing it. */
    if (r->request_id == 0)
        return r->status == TRIOCT_ERR_NOMEM ? CLI_EXIT_BAD_REPLY : CLI_EXIT_USAGE;
    /* A daemon's code, including ones newer than this table. */
    return r->status < 100 ? CLI_EXIT_DAEMON_ERROR : CLI_EXIT_BAD_REPLY;
}

/* What to check when nothing answered depends on the transport: only udpm needs a
 * multicast route, and memq:// and file:// can never reach a daemon in another process. */
static const char *transport_advice(const char *url)
{
    if (strncmp(url, "memq://", 7) == 0)
        return "memq:// is a queue inside this one process, which no daemon shares: give the daemon's "
               "--url (udpm://...)";
    if (strncmp(url, "file://", 7) == 0)
        return "file:// is a log file, not a bus, and nothing answers on it: give the daemon's --url";
    if (strncmp(url, "udpm://", 7) == 0 || strstr(url, "://") == NULL)
        return "is it running with this --prefix? is the multicast route set (ip route show 224.0.0.0/4)?";
    return "is it running on this bus, with this --prefix?";
}

void cli_no_reply_hint(const cli_context *ctx, const trioct_reply *r, int timeout_ms, char *buf, size_t len)
{
    const char *url = cli_bus_url(ctx);
    char who[TRIOCT_MAX_NAME_LEN + 48];
    if (r != NULL && r->daemon[0] != '\0')
        snprintf(who, sizeof who, "daemon %s", r->daemon);
    else if (r != NULL && r->world[0] != '\0')
        snprintf(who, sizeof who, "any daemon serving world %s", r->world);
    else
        snprintf(who, sizeof who, "any daemon");
    snprintf(buf, len, "no reply from %s on %s within %d ms: %s", who, url, timeout_ms, transport_advice(url));
}

static const char *command_name(const cli_context *ctx)
{
    return ctx->command ? ctx->command : "";
}

int cli_report_failure(cli_context *ctx, const trioct_reply *r, int timeout_ms, const char *part)
{
    int code = cli_exit_code(r);
    char hint[TRIOCT_MAX_MESSAGE_LEN + 128] = "";
    if (r->status == TRIOCT_ERR_NO_DAEMON)
        cli_no_reply_hint(ctx, r, timeout_ms, hint, sizeof hint);

    const char *sep = ctx->command ? " " : "";
    FILE *e = ctx->err;
    if (hint[0] != '\0')
        fprintf(e, "trioct%s%s: %s\n", sep, command_name(ctx), hint);
    fprintf(e, "trioct%s%s: %s%s", sep, command_name(ctx), part ? part : "", part ? ": " : "");
    /* A daemon's code gets the table's words too; the client-side ones (no reply, bus,
     * bad reply) are said in full by the message. */
    if (code == CLI_EXIT_DAEMON_ERROR)
        fprintf(e, "daemon %s answered %s (%d, %s): %s\n", r->daemon[0] ? r->daemon : "?",
                trioct_status_name(r->status), r->status, trioct_status_text(r->status),
                r->message);
    else if (code == CLI_EXIT_USAGE)
        fprintf(e, "refused before sending: %s (%d, %s): %s\n", trioct_status_name(r->status),
                r->status, trioct_status_text(r->status), r->message);
    else
        fprintf(e, "%s: %s\n", trioct_status_name(r->status), r->message);

    if (ctx->json) {
        cli_json j;
        cli_json_init(&j, ctx->out);
        cli_json_envelope(&j, ctx, code, r);
        if (part != NULL)
            cli_json_key_string(&j, "part", part);
        if (hint[0] != '\0')
            cli_json_key_string(&j, "hint", hint);
        cli_json_finish(&j);
    }
    return code;
}

void cli_json_envelope(cli_json *j, const cli_context *ctx, int exit_code, const trioct_reply *r)
{
    cli_json_object_begin(j);
    cli_json_key_string(j, "command", command_name(ctx));
    cli_json_key_bool(j, "ok", exit_code == CLI_EXIT_OK);
    cli_json_key_int(j, "exit_code", exit_code);
    if (r == NULL) {
        cli_json_key(j, "status");
        cli_json_null(j);
        cli_json_key(j, "status_code");
        cli_json_null(j);
        return;
    }
    cli_json_key_string(j, "status", trioct_status_name(r->status));
    cli_json_key_int(j, "status_code", r->status);
    cli_json_key_string(j, "message", r->message);
    if (r->daemon[0] != '\0')
        cli_json_key_string(j, "daemon", r->daemon);
    if (r->world[0] != '\0') {
        cli_json_key_string(j, "world", r->world);
        cli_json_key_int(j, "world_version", r->world_version);
    }
}

void cli_json_finish(cli_json *j)
{
    cli_json_object_end(j);
    fputc('\n', j->out);
    fflush(j->out);
}

int cli_internal_error(cli_context *ctx, const char *fmt, ...)
{
    trioct_reply r = {.status = TRIOCT_ERR_NOMEM};
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(r.message, sizeof r.message, fmt, ap);
    va_end(ap);
    fprintf(ctx->err, "trioct %s: %s\n", command_name(ctx), r.message);
    if (ctx->json) {
        cli_json j;
        cli_json_init(&j, ctx->out);
        cli_json_envelope(&j, ctx, CLI_EXIT_BAD_REPLY, &r);
        cli_json_finish(&j);
    }
    return CLI_EXIT_BAD_REPLY;
}

void cli_warn(cli_context *ctx, const char *fmt, ...)
{
    fprintf(ctx->err, "trioct %s: warning: ", command_name(ctx));
    va_list ap;
    va_start(ap, fmt);
    vfprintf(ctx->err, fmt, ap);
    va_end(ap);
    fputc('\n', ctx->err);
}

