/* The world subcommands: worlds (every daemon's list, gathered), info, load and unload. */
#include <inttypes.h>
#include <string.h>

#include "cli.h"
#include "cli_progress.h"
#include "cli_text.h"
#include "cli_world_info.h"

/* Without --gather, worlds listens this long for answers (or the timeout, when shorter):
 * every daemon on the bus answers a LIST, and nothing says which answer is the last. */
#define WORLDS_DEFAULT_GATHER_MS 1000

/* ---- worlds ---------------------------------------------------------------------------- */

enum { OPT_GATHER, OPT_EXPECT };

typedef struct worlds_args {
    int gather_ms; /* 0: the default */
    int expect;
} worlds_args;

static const cli_option worlds_options[] = {
    {"gather", 0, 1, OPT_GATHER},
    {"expect", 0, 1, OPT_EXPECT},
    {NULL, 0, 0, 0},
};

static int worlds_option(void *user, int id, const char *value, char *err, size_t err_len)
{
    worlds_args *a = user;
    long long v;
    if (cli_parse_int(value, 1, 1000000000, &v) != 0) {
        snprintf(err, err_len, "--%s: '%.40s' is not a whole number >= 1",
                 id == OPT_GATHER ? "gather" : "expect", value);
        return -1;
    }
    if (id == OPT_GATHER)
        a->gather_ms = (int)v;
    else
        a->expect = (int)v;
    return 0;
}

static void worlds_json(cli_context *ctx, const trioct_list_result *res, int code)
{
    cli_json j;
    cli_json_init(&j, ctx->out);
    cli_json_envelope(&j, ctx, code, &res->reply);
    cli_json_key(&j, "daemons");
    cli_json_array_begin(&j);
    for (size_t i = 0; i < res->num_daemons; i++) {
        const trioct_reply *d = &res->daemons[i];
        cli_json_object_begin(&j);
        cli_json_key_string(&j, "daemon", d->daemon);
        cli_json_key_string(&j, "status", trioct_status_name(d->status));
        cli_json_key_int(&j, "status_code", d->status);
        cli_json_key_string(&j, "message", d->message);
        cli_json_object_end(&j);
    }
    cli_json_array_end(&j);
    cli_json_key(&j, "worlds");
    cli_json_array_begin(&j);
    for (size_t i = 0; i < res->num_worlds; i++)
        cli_world_info_json(&j, &res->worlds[i]);
    cli_json_array_end(&j);
    cli_json_finish(&j);
}

static int worlds_print(cli_context *ctx, const trioct_list_result *res)
{
    size_t failed = 0;
    for (size_t i = 0; i < res->num_worlds; i++)
        failed += res->worlds[i].version == 0;
    fprintf(ctx->out, "%zu world%s on %zu daemon%s (%s)", res->num_worlds, res->num_worlds == 1 ? "" : "s",
            res->num_daemons, res->num_daemons == 1 ? "" : "s", cli_bus_url(ctx));
    if (failed > 0)
        fprintf(ctx->out, ", %zu not loaded", failed);
    fputc('\n', ctx->out);
    if (res->num_worlds > 0 && cli_world_table_print(ctx->out, res->worlds, res->num_worlds, "") != 0)
        return -1;
    for (size_t i = 0; i < res->num_daemons; i++) {
        const trioct_reply *d = &res->daemons[i];
        if (d->status != TRIOCT_OK)
            fprintf(ctx->err, "trioct worlds: daemon %s: %s: %s\n", d->daemon,
                    trioct_status_name(d->status), d->message);
    }
    return 0;
}

static int run_worlds(cli_context *ctx, int argc, char **argv)
{
    worlds_args a = {0};
    char *pos[CLI_MAX_POSITIONAL];
    int npos;
    int rc = cli_command_args(ctx, &cli_command_worlds, argc, argv, worlds_options, worlds_option,
                              &a, pos, &npos);
    if (rc >= 0)
        return rc;
    if (npos != 0)
        return cli_usage_error(ctx, "takes no arguments, got '%s'", pos[0]);
    if ((rc = cli_connect(ctx)) >= 0)
        return rc;
    int timeout = cli_timeout(ctx, CLI_DEFAULT_TIMEOUT_MS);
    int gather = a.gather_ms > 0 ? a.gather_ms : WORLDS_DEFAULT_GATHER_MS;
    if (gather > timeout)
        gather = timeout;
    trioct_list_options opt = {.gather_ms = gather, .expect_daemons = a.expect};
    trioct_list_result res;
    int status = trioct_list(ctx->client, &opt, timeout, &res);
    /* A gathering with some answers missing or bad still shows the good ones. */
    if (status != TRIOCT_OK && res.num_daemons == 0) {
        rc = cli_report_failure(ctx, &res.reply, gather, NULL);
    } else {
        rc = cli_exit_code(&res.reply);
        if (ctx->json)
            worlds_json(ctx, &res, rc);
        else if (worlds_print(ctx, &res) != 0)
            rc = cli_internal_error(ctx, "out of memory printing %zu worlds", res.num_worlds);
        if (status != TRIOCT_OK)
            fprintf(ctx->err, "trioct worlds: %s: %s\n", trioct_status_name(status),
                    res.reply.message);
    }
    trioct_list_result_free(&res);
    return rc;
}

const cli_command cli_command_worlds = {
    "worlds",
    "list the worlds of every daemon on the bus",
    "Usage: trioct worlds [--gather MS] [--expect N] [global options]\n"
    "\n"
    "Asks every daemon on the bus for the worlds it holds and prints them, one a line:\n"
    "name, daemon, version, triangles, memory, accuracy and the effects served. A world of\n"
    "a daemon's scene that failed to load is listed too, with version 0 and why.\n"
    "\n"
    "Options:\n"
    "  --gather MS   listen this long for the daemons' answers (default 1000, at most\n"
    "                the --timeout): every daemon answers, so only time ends the list\n"
    "  --expect N    stop as soon as N daemons have answered\n"
    "\n"
    "Exit code 3 when no daemon answered within the gather window.\n"
    "\n"
    "Examples:\n"
    "  trioct worlds\n"
    "  trioct worlds --expect 2 --json\n"
    "  trioct worlds --url 'udpm://239.255.76.67:7667?ttl=0' --prefix FLEET\n",
    run_worlds,
};

/* ---- info and unload: one world by name ------------------------------------------------ */

typedef int (*world_call)(trioct_client *c, const char *world, int timeout_ms,
                          trioct_admin_result *out);

static void admin_json(cli_context *ctx, const trioct_admin_result *res, int code)
{
    cli_json j;
    cli_json_init(&j, ctx->out);
    cli_json_envelope(&j, ctx, code, &res->reply);
    cli_json_key(&j, "worlds");
    cli_json_array_begin(&j);
    for (size_t i = 0; i < res->num_worlds; i++)
        cli_world_info_json(&j, &res->worlds[i]);
    cli_json_array_end(&j);
    cli_json_finish(&j);
}

/* Prints an admin answer; what says what happened ("loaded", "unloaded", NULL for info). */
static int admin_answer(cli_context *ctx, int status, const trioct_admin_result *res,
                        int timeout, const char *what)
{
    if (status != TRIOCT_OK)
        return cli_report_failure(ctx, &res->reply, timeout, NULL);
    if (ctx->json) {
        admin_json(ctx, res, CLI_EXIT_OK);
        return CLI_EXIT_OK;
    }
    if (what != NULL && res->num_worlds == 0)
        fprintf(ctx->out, "%s %s on daemon %s\n", what, res->reply.world, res->reply.daemon);
    for (size_t i = 0; i < res->num_worlds; i++) {
        const trioct_world_info *w = &res->worlds[i];
        if (what != NULL)
            fprintf(ctx->out, "%s %s (version %" PRId64 ") on daemon %s\n", what, w->name,
                    w->version, w->daemon);
        cli_world_info_print(ctx->out, w, what ? "  " : "");
    }
    return CLI_EXIT_OK;
}

static int run_world_call(cli_context *ctx, const cli_command *cmd, int argc, char **argv,
                          world_call call, const char *what)
{
    char *pos[CLI_MAX_POSITIONAL];
    int npos;
    int rc = cli_command_args(ctx, cmd, argc, argv, NULL, NULL, NULL, pos, &npos);
    if (rc >= 0)
        return rc;
    if (npos != 1)
        return cli_usage_error(ctx, "expected one argument, WORLD; got %d", npos);
    if ((rc = cli_check_name(ctx, "world", pos[0])) >= 0)
        return rc;
    if ((rc = cli_connect(ctx)) >= 0)
        return rc;
    int timeout = cli_timeout(ctx, CLI_DEFAULT_TIMEOUT_MS);
    trioct_admin_result res;
    int status = call(ctx->client, pos[0], timeout, &res);
    rc = admin_answer(ctx, status, &res, timeout, what);
    trioct_admin_result_free(&res);
    return rc;
}

static int run_info(cli_context *ctx, int argc, char **argv)
{
    return run_world_call(ctx, &cli_command_info, argc, argv, trioct_info, NULL);
}

static int run_unload(cli_context *ctx, int argc, char **argv)
{
    return run_world_call(ctx, &cli_command_unload, argc, argv, trioct_unload, "unloaded");
}

const cli_command cli_command_info = {
    "info",
    "show one world: source, triangles, octree, memory, shapes",
    "Usage: trioct info WORLD [global options]\n"
    "\n"
    "Asks the daemon holding WORLD about it: where it was built from, its effects and\n"
    "accuracy, triangles, bounds, the octree (nodes, leaves, L_max, d, D), memory by\n"
    "part, build time, queries answered, query shapes, and why its last reload failed.\n"
    "\n"
    "Examples:\n"
    "  trioct info yard\n"
    "  trioct info yard --json\n",
    run_info,
};

const cli_command cli_command_unload = {
    "unload",
    "drop a world from the daemon holding it",
    "Usage: trioct unload WORLD [global options]\n"
    "\n"
    "Asks the daemon holding WORLD to drop it. Queries already running finish; later ones\n"
    "get no answer (nobody holds the world any more).\n"
    "\n"
    "Examples:\n"
    "  trioct unload yard_lidar\n",
    run_unload,
};

/* ---- load ------------------------------------------------------------------------------ */

enum { OPT_MESH, OPT_RESOLUTION, OPT_ACCURACY, OPT_SEED_EPSILON, OPT_EFFECTS, OPT_DAEMON };

typedef struct load_args {
    trioct_load_options load;
} load_args;

static const cli_option load_options[] = {
    {"mesh", 0, 1, OPT_MESH},
    {"resolution", 0, 1, OPT_RESOLUTION},
    {"accuracy", 0, 1, OPT_ACCURACY},
    {"seed-epsilon", 0, 1, OPT_SEED_EPSILON},
    {"effects", 0, 1, OPT_EFFECTS},
    {"daemon", 0, 1, OPT_DAEMON},
    {NULL, 0, 0, 0},
};

static int positive_number(const char *option, const char *value, double *out, char *err,
                           size_t err_len)
{
    if (cli_parse_double(value, 0, out) != 0 || *out <= 0) {
        snprintf(err, err_len, "--%s: '%.40s' is not a positive finite number", option, value);
        return -1;
    }
    return 0;
}

static int load_option(void *user, int id, const char *value, char *err, size_t err_len)
{
    trioct_load_options *o = &((load_args *)user)->load;
    switch (id) {
    case OPT_MESH:
        if (value[0] == '\0' || strlen(value) > TRIOCT_MAX_PATH_LEN) {
            snprintf(err, err_len, "--mesh: the path must have 1..%d characters",
                     TRIOCT_MAX_PATH_LEN);
            return -1;
        }
        o->mesh_path = value;
        return 0;
    case OPT_RESOLUTION:
        return positive_number("resolution", value, &o->resolution, err, err_len);
    case OPT_SEED_EPSILON:
        return positive_number("seed-epsilon", value, &o->seed_epsilon, err, err_len);
    case OPT_ACCURACY:
        if (cli_parse_accuracy(value, &o->accuracy) != 0 || o->accuracy == TRIOCT_ACCURACY_WORLD) {
            snprintf(err, err_len, "--accuracy: '%.40s' is not exact, seed or fast", value);
            return -1;
        }
        return 0;
    case OPT_EFFECTS: {
        char why[128];
        if (cli_parse_effects(value, &o->effects, why, sizeof why) != 0) {
            snprintf(err, err_len, "--effects: %s", why);
            return -1;
        }
        return 0;
    }
    case OPT_DAEMON:
        if (!cli_name_valid(value, TRIOCT_MAX_NAME_LEN)) {
            snprintf(err, err_len, "--daemon: '%.40s' is not 1..%d characters of [A-Za-z0-9_]",
                     value, TRIOCT_MAX_NAME_LEN);
            return -1;
        }
        o->daemon = value;
        return 0;
    }
    return -1;
}

/* Without --daemon, a load goes to the one daemon on the bus: LIST finds it, and a second
 * answer ends the search at once, since which daemon should build the world is then the
 * user's choice. -1 with name set, or the exit code (reported). */
static int find_the_daemon(cli_context *ctx, char name[TRIOCT_MAX_NAME_LEN + 1])
{
    int gather = cli_timeout(ctx, CLI_LOAD_TIMEOUT_MS);
    if (gather > WORLDS_DEFAULT_GATHER_MS)
        gather = WORLDS_DEFAULT_GATHER_MS;
    trioct_list_options opt = {.gather_ms = gather, .expect_daemons = 2};
    trioct_list_result res;
    int status = trioct_list(ctx->client, &opt, gather, &res);
    int rc = -1;
    if (res.num_daemons == 0) {
        rc = cli_report_failure(ctx, &res.reply, gather, "finding the daemon to load with (no --daemon)");
    } else if (res.num_daemons > 1) {
        rc = cli_usage_error(ctx, "several daemons answer on %s (%s, %s%s): say which builds the world with "
                             "--daemon NAME", cli_bus_url(ctx), res.daemons[0].daemon, res.daemons[1].daemon,
                             status == TRIOCT_OK && res.num_daemons == 2 ? "" : ", ...");
    } else {
        snprintf(name, TRIOCT_MAX_NAME_LEN + 1, "%s", res.daemons[0].daemon);
    }
    trioct_list_result_free(&res);
    return rc;
}

/* ---- load with its progress ---------------------------------------------------------- */

typedef struct load_wait {
    int done;
    trioct_admin_result res;
} load_wait;

static void on_loaded(trioct_client *c, trioct_admin_result *res, void *user)
{
    (void)c;
    load_wait *w = user;
    w->res = *res;
    memset(res, 0, sizeof *res); /* kept: the library frees nothing of it now */
    w->done = 1;
}

/* The LOAD sent without waiting, and the daemon's heartbeat listened to meanwhile: each
 * one lists the builds under way, and this LOAD's (this client, this request) is shown on
 * stderr, redrawn on a terminal, a line a heartbeat otherwise. Returns the LOAD's status,
 * its answer in *res as trioct_load gives it. */
static int load_showing_progress(cli_context *ctx, const trioct_load_options *opt, int timeout, cli_progress_mode mode,
                                 trioct_admin_result *res)
{
    load_wait w;
    memset(&w, 0, sizeof w);
    int64_t request_id = 0;
    int status = trioct_load_async(ctx->client, opt, timeout, on_loaded, &w, &request_id);
    if (status != TRIOCT_OK) {
        memset(res, 0, sizeof *res);
        res->reply.status = status;
        snprintf(res->reply.message, sizeof res->reply.message, "%s", trioct_last_error(ctx->client));
        return status;
    }
    int64_t me = (int64_t)trioct_client_id(ctx->client);
    int shown = 0;
    while (!w.done) {
        trioct_daemon_status st;
        /* A heartbeat comes every second or so; waiting a little longer than one keeps the
         * LOAD's answer from waiting for the next. */
        if (trioct_next_status(ctx->client, opt->daemon, 1100, &st) == TRIOCT_OK) {
            for (size_t i = 0; i < st.num_loads; i++) {
                const trioct_load_progress *p = &st.loads[i];
                if (p->client_id != me || p->request_id != request_id)
                    continue;
                char line[256];
                cli_load_progress_text(p, line, sizeof line);
                if (mode == CLI_PROGRESS_TERMINAL)
                    fprintf(ctx->err, "\r%s\033[K", line);
                else
                    fprintf(ctx->err, "trioct load: %s\n", line);
                fflush(ctx->err);
                shown = 1;
            }
            trioct_daemon_status_free(&st);
        }
        if (trioct_poll(ctx->client, 0) < 0)
            break; /* the bus failed: the request completes as failed below */
    }
    if (shown && mode == CLI_PROGRESS_TERMINAL)
        fputc('\n', ctx->err);
    if (!w.done) {
        memset(res, 0, sizeof *res);
        res->reply.status = TRIOCT_ERR_TRANSPORT;
        snprintf(res->reply.message, sizeof res->reply.message, "%s", trioct_last_error(ctx->client));
        return TRIOCT_ERR_TRANSPORT;
    }
    *res = w.res;
    return res->reply.status;
}

static int run_load(cli_context *ctx, int argc, char **argv)
{
    load_args a = {.load = {.accuracy = TRIOCT_ACCURACY_WORLD}};
    char *pos[CLI_MAX_POSITIONAL];
    int npos;
    int rc = cli_command_args(ctx, &cli_command_load, argc, argv, load_options, load_option, &a,
                              pos, &npos);
    if (rc >= 0)
        return rc;
    if (npos != 1)
        return cli_usage_error(ctx, "expected one argument, WORLD; got %d", npos);
    if ((rc = cli_check_name(ctx, "world", pos[0])) >= 0)
        return rc;
    if ((rc = cli_connect(ctx)) >= 0)
        return rc;
    a.load.world = pos[0];
    char found[TRIOCT_MAX_NAME_LEN + 1];
    if (a.load.daemon == NULL) {
        if ((rc = find_the_daemon(ctx, found)) >= 0)
            return rc;
        a.load.daemon = found;
    }
    int timeout = cli_timeout(ctx, CLI_LOAD_TIMEOUT_MS);
    trioct_admin_result res;
    cli_progress_mode mode = cli_progress_mode_for(ctx->err, ctx->progress);
    int status = mode == CLI_PROGRESS_OFF ? trioct_load(ctx->client, &a.load, timeout, &res)
                                          : load_showing_progress(ctx, &a.load, timeout, mode, &res);
    rc = admin_answer(ctx, status, &res, timeout, "loaded");
    trioct_admin_result_free(&res);
    return rc;
}

const cli_command cli_command_load = {
    "load",
    "build (or rebuild) a world on a daemon",
    "Usage: trioct load WORLD [--mesh PATH] [--resolution D] [--accuracy exact|seed|fast]\n"
    "                   [--seed-epsilon E] [--effects LIST] [--daemon NAME] [global options]\n"
    "\n"
    "Asks a daemon to build WORLD and waits until it is built (the default --timeout is\n"
    "60000 ms here). Without --mesh the daemon builds its scene's section named WORLD;\n"
    "with it, the mesh file PATH inside the daemon's world directory. Loading a world the\n"
    "daemon holds rebuilds it; queries keep being answered by the old version until the\n"
    "new one is swapped in. While it builds, the daemon's heartbeat says how far it is\n"
    "(reading meshes, files and triangles read, building octrees, seconds): shown on stderr\n"
    "when stderr is a terminal or with --progress (a line a heartbeat).\n"
    "\n"
    "Options:\n"
    "  --mesh PATH          a mesh file relative to the daemon's world directory, or an\n"
    "                       absolute path inside one of its mesh_root directories\n"
    "  --resolution D       the leaf side d (default: the seed heuristic)\n"
    "  --accuracy MODE      exact (default), seed or fast\n"
    "  --seed-epsilon E     the epsilon of seed mode\n"
    "  --effects LIST       what the world serves: rays,triangles,meshes,distance (default all)\n"
    "  --daemon NAME        the daemon that builds it (default: the one daemon on the\n"
    "                       bus, found with LIST; with several, --daemon is needed)\n"
    "\n"
    "Examples:\n"
    "  trioct load yard\n"
    "  trioct load bunny --mesh bunny.ply --effects rays --daemon lidar_host\n"
    "  trioct load cell --mesh cell.stl --resolution 0.01 --accuracy fast --json\n"
    "  trioct load terrain --progress\n",
    run_load,
};
