#include "options.h"

#include <errno.h>
#include <getopt.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <uv.h>

#include "../../common/channels.h"

/* One row per option the scene may also set: the command line and the [daemon] section go
 * through the same setter, so both accept and refuse exactly the same values. */
typedef struct option_row {
    unsigned bit;
    const char *flag;      /* "--queue-depth" */
    const char *scene_key; /* "queue_depth" */
} option_row;

static const option_row rows[] = {
    {OPT_URL, "--url", "url"},
    {OPT_PUBLISH_URL, "--publish-url", "publish_url"},
    {OPT_PREFIX, "--prefix", "prefix"},
    {OPT_NAME, "--name", "name"},
    {OPT_THREADS, "--threads", "threads"},
    {OPT_WORLD_DIR, "--world-dir", "world_dir"},
    {OPT_QUEUE_DEPTH, "--queue-depth", "queue_depth"},
    {OPT_LOG_LEVEL, "--log-level", "log_level"},
    {OPT_STATUS_INTERVAL, "--status-interval", "status_interval"},
    {OPT_MEMORY_BUDGET, "--memory-budget", "memory_budget"},
    {OPT_LOADER, "--loader", "loader"},
    {OPT_ADMIN_KEY_FILE, "--admin-key-file", "admin_key_file"},
    {OPT_MESH_ROOT, "--mesh-root", "mesh_root"},
};
#define ROW_COUNT (sizeof rows / sizeof rows[0])

/* Long options without a row: command line only. */
enum {
    LONGOPT_PUBLISH_URL = 256,
    LONGOPT_STATUS_INTERVAL,
    LONGOPT_EXIT_AT_EOF,
    LONGOPT_ORDERED,
    LONGOPT_NO_INLINE,
    LONGOPT_MEMORY_BUDGET,
    LONGOPT_LOADER,
    LONGOPT_ADMIN_KEY_FILE,
    LONGOPT_MESH_ROOT,
};

static const struct option long_options[] = {
    {"scene", required_argument, NULL, 's'},
    {"url", required_argument, NULL, 'u'},
    {"publish-url", required_argument, NULL, LONGOPT_PUBLISH_URL},
    {"prefix", required_argument, NULL, 'p'},
    {"name", required_argument, NULL, 'n'},
    {"threads", required_argument, NULL, 't'},
    {"world-dir", required_argument, NULL, 'w'},
    {"queue-depth", required_argument, NULL, 'q'},
    {"log-level", required_argument, NULL, 'l'},
    {"status-interval", required_argument, NULL, LONGOPT_STATUS_INTERVAL},
    {"exit-at-eof", no_argument, NULL, LONGOPT_EXIT_AT_EOF},
    {"ordered", no_argument, NULL, LONGOPT_ORDERED},
    {"no-inline", no_argument, NULL, LONGOPT_NO_INLINE},
    {"memory-budget", required_argument, NULL, LONGOPT_MEMORY_BUDGET},
    {"loader", required_argument, NULL, LONGOPT_LOADER},
    {"admin-key-file", required_argument, NULL, LONGOPT_ADMIN_KEY_FILE},
    {"mesh-root", required_argument, NULL, LONGOPT_MESH_ROOT},
    {"help", no_argument, NULL, 'h'},
    {"version", no_argument, NULL, 'V'},
    {NULL, 0, NULL, 0},
};
/* The leading ':' makes a missing value come back as ':' rather than '?'. */
static const char short_options[] = ":s:u:p:n:t:w:q:l:hV";

void options_init(daemon_options *opt)
{
    memset(opt, 0, sizeof *opt);
    opt->log_level = LOG_INFO;
}

int options_url_is_file(const char *url)
{
    return strncmp(url, "file://", 7) == 0;
}

/* Copies src into dst[cap]; -1 when it does not fit. */
static int copy_text(char *dst, size_t cap, const char *src)
{
    size_t n = strlen(src);
    if (n >= cap)
        return -1;
    memcpy(dst, src, n + 1);
    return 0;
}

/* A decimal integer in lo..hi, the whole text and nothing else (no sign games, no spaces). */
static int parse_int(const char *text, long lo, long hi, int *out)
{
    if (text[0] == '\0' || text[0] == ' ' || text[0] == '\t' || text[0] == '+')
        return -1;
    char *end = NULL;
    errno = 0;
    long v = strtol(text, &end, 10);
    if (errno != 0 || *end != '\0' || v < lo || v > hi)
        return -1;
    *out = (int)v;
    return 0;
}

/* The directory part of a path: "." for a bare name, "/" for a file at the root. */
static void dir_of(const char *path, char *out, size_t cap)
{
    const char *slash = strrchr(path, '/');
    if (slash == NULL) {
        snprintf(out, cap, ".");
        return;
    }
    size_t n = (size_t)(slash - path);
    if (n == 0)
        n = 1;
    snprintf(out, cap, "%.*s", (int)n, path);
}

size_t options_default_memory_budget(void)
{
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (pages <= 0 || page <= 0)
        return (size_t)1 << 30;
    size_t half = (size_t)pages / 2 * (size_t)page;
    return half < OPTIONS_MIN_MEMORY_BUDGET ? OPTIONS_MIN_MEMORY_BUDGET : half;
}

/* A path option: relative ones in a scene are relative to the scene's directory. */
static int set_path(char *dst, const char *text, const char *base_dir, char *why, size_t why_len)
{
    if (text[0] == '\0') {
        snprintf(why, why_len, "a path is needed");
        return -1;
    }
    int n;
    if (text[0] == '/' || base_dir == NULL || strcmp(base_dir, ".") == 0)
        n = snprintf(dst, TRIOCT_MAX_PATH_LEN, "%s", text);
    else
        n = snprintf(dst, TRIOCT_MAX_PATH_LEN, "%s/%s", base_dir, text);
    if (n < 0 || (size_t)n >= TRIOCT_MAX_PATH_LEN) {
        snprintf(why, why_len, "the path is longer than %d characters", TRIOCT_MAX_PATH_LEN - 1);
        return -1;
    }
    return 0;
}

/* Sets the field of bit from text. base_dir resolves a relative world_dir (NULL: leave it
 * relative to the working directory). 0, or -1 with why ("'x' is not ..."). */
static int set_field(daemon_options *opt, unsigned bit, const char *text, const char *base_dir,
                     char *why, size_t why_len)
{
    int v;
    switch (bit) {
    case OPT_URL:
    case OPT_PUBLISH_URL: {
        char *dst = bit == OPT_URL ? opt->url : opt->publish_url;
        if (text[0] == '\0') {
            snprintf(why, why_len, "an LCM URL is needed, e.g. udpm://239.255.76.67:7667?ttl=0");
            return -1;
        }
        if (strstr(text, "://") == NULL) {
            snprintf(why, why_len, "'%s' is not an LCM URL (provider://address?options)", text);
            return -1;
        }
        if (copy_text(dst, OPTIONS_URL_LEN, text) < 0) {
            snprintf(why, why_len, "the URL is longer than %d characters", OPTIONS_URL_LEN - 1);
            return -1;
        }
        return 0;
    }
    case OPT_PREFIX:
        if (!trioct_name_valid(text, TRIOCT_MAX_PREFIX_LEN)) {
            snprintf(why, why_len, "'%s' is not a channel prefix: 1..%d characters of [A-Za-z0-9_]",
                     text, TRIOCT_MAX_PREFIX_LEN);
            return -1;
        }
        return copy_text(opt->prefix, sizeof opt->prefix, text);
    case OPT_NAME:
        if (!trioct_name_valid(text, TRIOCT_MAX_NAME_LEN)) {
            snprintf(why, why_len, "'%s' is not a daemon name: 1..%d characters of [A-Za-z0-9_]",
                     text, TRIOCT_MAX_NAME_LEN);
            return -1;
        }
        return copy_text(opt->name, sizeof opt->name, text);
    case OPT_THREADS:
        if (parse_int(text, 1, OPTIONS_MAX_THREADS, &v) < 0) {
            snprintf(why, why_len, "'%s' is not an integer in 1..%d", text, OPTIONS_MAX_THREADS);
            return -1;
        }
        opt->threads = v;
        return 0;
    case OPT_WORLD_DIR: {
        if (text[0] == '\0') {
            snprintf(why, why_len, "a directory is needed");
            return -1;
        }
        int n;
        if (text[0] == '/' || base_dir == NULL || strcmp(base_dir, ".") == 0)
            n = snprintf(opt->world_dir, sizeof opt->world_dir, "%s", text);
        else
            n = snprintf(opt->world_dir, sizeof opt->world_dir, "%s/%s", base_dir, text);
        if (n < 0 || (size_t)n >= sizeof opt->world_dir) {
            snprintf(why, why_len, "the path is longer than %d characters", TRIOCT_MAX_PATH_LEN - 1);
            return -1;
        }
        return 0;
    }
    case OPT_QUEUE_DEPTH:
        if (parse_int(text, 1, OPTIONS_MAX_QUEUE_DEPTH, &v) < 0) {
            snprintf(why, why_len, "'%s' is not an integer in 1..%d", text, OPTIONS_MAX_QUEUE_DEPTH);
            return -1;
        }
        opt->queue_depth = v;
        return 0;
    case OPT_LOG_LEVEL: {
        log_level level;
        if (log_level_parse(text, &level) < 0) {
            snprintf(why, why_len, "'%s' is not a log level: error, warn, info or debug", text);
            return -1;
        }
        opt->log_level = level;
        return 0;
    }
    case OPT_STATUS_INTERVAL:
        if (parse_int(text, OPTIONS_MIN_STATUS_INTERVAL_MS, OPTIONS_MAX_STATUS_INTERVAL_MS, &v) < 0) {
            snprintf(why, why_len, "'%s' is not a number of milliseconds in %d..%d", text,
                     OPTIONS_MIN_STATUS_INTERVAL_MS, OPTIONS_MAX_STATUS_INTERVAL_MS);
            return -1;
        }
        opt->status_interval_ms = v;
        return 0;
    case OPT_MEMORY_BUDGET: {
        size_t bytes;
        if (scene_parse_bytes(text, &bytes) != 0 || bytes < OPTIONS_MIN_MEMORY_BUDGET) {
            snprintf(why, why_len, "'%s' is not a size of at least 16M (digits and K, M, G or T)", text);
            return -1;
        }
        opt->memory_budget = bytes;
        return 0;
    }
    case OPT_LOADER:
        return set_path(opt->loader, text, base_dir, why, why_len);
    case OPT_ADMIN_KEY_FILE:
        return set_path(opt->admin_key_file, text, base_dir, why, why_len);
    case OPT_MESH_ROOT: {
        mesh_roots *r = &opt->mesh_roots;
        if (r->count == MESH_ROOTS_MAX) {
            snprintf(why, why_len, "more than %d mesh roots", MESH_ROOTS_MAX);
            return -1;
        }
        if (set_path(r->paths[r->count], text, base_dir, why, why_len) != 0)
            return -1;
        r->count++;
        return 0;
    }
    }
    snprintf(why, why_len, "internal: no such option");
    return -1;
}

static const option_row *row_of(unsigned bit)
{
    for (size_t i = 0; i < ROW_COUNT; i++)
        if (rows[i].bit == bit)
            return &rows[i];
    return NULL;
}

static unsigned bit_of_flag(int c)
{
    switch (c) {
    case 'u': return OPT_URL;
    case LONGOPT_PUBLISH_URL: return OPT_PUBLISH_URL;
    case 'p': return OPT_PREFIX;
    case 'n': return OPT_NAME;
    case 't': return OPT_THREADS;
    case 'w': return OPT_WORLD_DIR;
    case 'q': return OPT_QUEUE_DEPTH;
    case 'l': return OPT_LOG_LEVEL;
    case LONGOPT_STATUS_INTERVAL: return OPT_STATUS_INTERVAL;
    case LONGOPT_MEMORY_BUDGET: return OPT_MEMORY_BUDGET;
    case LONGOPT_LOADER: return OPT_LOADER;
    case LONGOPT_ADMIN_KEY_FILE: return OPT_ADMIN_KEY_FILE;
    case LONGOPT_MESH_ROOT: return OPT_MESH_ROOT;
    }
    return 0;
}

options_action options_parse_args(daemon_options *opt, int argc, char **argv, char *err,
                                  size_t err_len)
{
    char why[OPTIONS_URL_LEN + 128];
    err[0] = '\0';
    /* optind = 0 makes glibc's getopt start afresh, so tests can parse many command lines
     * in one process; opterr = 0 because the daemon words its own errors. */
    optind = 0;
    opterr = 0;
    for (;;) {
        int c = getopt_long(argc, argv, short_options, long_options, NULL);
        if (c == -1)
            break;
        switch (c) {
        case 'h':
            return OPTIONS_HELP;
        case 'V':
            return OPTIONS_VERSION;
        case 's':
            if (optarg[0] == '\0' || copy_text(opt->scene_path, sizeof opt->scene_path, optarg) < 0) {
                snprintf(err, err_len, "--scene: '%s' is not a usable path", optarg);
                return OPTIONS_ERROR;
            }
            break;
        case LONGOPT_EXIT_AT_EOF:
            opt->exit_at_eof = 1;
            break;
        case LONGOPT_ORDERED:
            opt->ordered = 1;
            break;
        case LONGOPT_NO_INLINE:
            opt->no_inline = 1;
            break;
        case ':':
            snprintf(err, err_len, "option '%s' needs a value", argv[optind - 1]);
            return OPTIONS_ERROR;
        case '?': {
            /* A long option comes back whole in argv; a short one only as optopt, since
             * it may sit in a cluster ("-tx"). glibc also lands here for a value given to
             * a long option that takes none ("--exit-at-eof=1"). */
            const char *arg = argv[optind - 1];
            if (strncmp(arg, "--", 2) != 0) {
                snprintf(err, err_len, "unknown option '-%c'", optopt);
                return OPTIONS_ERROR;
            }
            const char *eq = strchr(arg, '=');
            size_t name_len = eq != NULL ? (size_t)(eq - arg - 2) : strlen(arg + 2);
            for (const struct option *o = long_options; eq != NULL && o->name != NULL; o++) {
                if (o->has_arg == no_argument && strlen(o->name) == name_len &&
                    strncmp(o->name, arg + 2, name_len) == 0) {
                    snprintf(err, err_len, "option '--%s' takes no value", o->name);
                    return OPTIONS_ERROR;
                }
            }
            snprintf(err, err_len, "unknown option '%s'", arg);
            return OPTIONS_ERROR;
        }
        default: {
            unsigned bit = bit_of_flag(c);
            const option_row *row = row_of(bit);
            if (row == NULL) {
                snprintf(err, err_len, "unknown option '%s'", argv[optind - 1]);
                return OPTIONS_ERROR;
            }
            if (set_field(opt, bit, optarg, NULL, why, sizeof why) < 0) {
                snprintf(err, err_len, "%s: %s", row->flag, why);
                return OPTIONS_ERROR;
            }
            opt->from_cli |= bit;
        }
        }
    }
    if (optind < argc) {
        snprintf(err, err_len, "unexpected argument '%s' (options only; the scene is --scene FILE)",
                 argv[optind]);
        return OPTIONS_ERROR;
    }
    if (opt->scene_path[0] == '\0') {
        snprintf(err, err_len, "missing --scene FILE");
        return OPTIONS_ERROR;
    }
    return OPTIONS_RUN;
}

static void set_defaults(daemon_options *opt, unsigned bits, const char *scene_dir)
{
    if (bits & OPT_URL) {
        const char *env = getenv("LCM_DEFAULT_URL");
        snprintf(opt->url, sizeof opt->url, "%s",
                 env != NULL && env[0] != '\0' ? env : OPTIONS_LCM_DEFAULT_URL);
    }
    if (bits & OPT_PUBLISH_URL)
        opt->publish_url[0] = '\0'; /* follows url once url is known */
    if (bits & OPT_PREFIX)
        snprintf(opt->prefix, sizeof opt->prefix, "%s", TRIOCT_DEFAULT_PREFIX);
    if (bits & OPT_NAME)
        snprintf(opt->name, sizeof opt->name, "%s", TRIOCT_DEFAULT_DAEMON);
    if (bits & OPT_THREADS) {
        unsigned n = uv_available_parallelism();
        opt->threads = n < 1 ? 1 : n > OPTIONS_MAX_THREADS ? OPTIONS_MAX_THREADS : (int)n;
    }
    if (bits & OPT_WORLD_DIR)
        snprintf(opt->world_dir, sizeof opt->world_dir, "%s", scene_dir);
    if (bits & OPT_QUEUE_DEPTH)
        opt->queue_depth = OPTIONS_DEFAULT_QUEUE_DEPTH;
    if (bits & OPT_LOG_LEVEL)
        opt->log_level = LOG_INFO;
    if (bits & OPT_STATUS_INTERVAL)
        opt->status_interval_ms = OPTIONS_DEFAULT_STATUS_INTERVAL_MS;
    if (bits & OPT_MEMORY_BUDGET)
        opt->memory_budget = options_default_memory_budget();
    if (bits & OPT_LOADER)
        opt->loader[0] = '\0';
    if (bits & OPT_ADMIN_KEY_FILE)
        opt->admin_key_file[0] = '\0';
    if (bits & OPT_MESH_ROOT)
        opt->mesh_roots.count = 0;
}

int options_apply_scene(daemon_options *opt, const scene *sc, char *err, size_t err_len)
{
    char why[OPTIONS_URL_LEN + 128];
    char scene_dir[TRIOCT_MAX_PATH_LEN];
    const char *where = sc != NULL && sc->path[0] != '\0' ? sc->path : opt->scene_path;
    dir_of(opt->scene_path, scene_dir, sizeof scene_dir);

    /* Work on a copy: a bad scene must leave the running options as they were. */
    daemon_options next = *opt;
    unsigned from_scene = ~opt->from_cli;
    set_defaults(&next, from_scene, scene_dir);

    unsigned seen = 0;
    int seen_line[ROW_COUNT] = {0};
    size_t count = sc != NULL ? sc->daemon_option_count : 0;
    for (size_t i = 0; i < count; i++) {
        const scene_option *o = &sc->daemon_options[i];
        size_t r = 0;
        while (r < ROW_COUNT && strcmp(rows[r].scene_key, o->key) != 0)
            r++;
        if (r == ROW_COUNT) {
            snprintf(err, err_len, "%s:%d: unknown daemon option '%s'", where, o->line, o->key);
            return -1;
        }
        if ((seen & rows[r].bit) && rows[r].bit != OPT_MESH_ROOT) {
            snprintf(err, err_len, "%s:%d: daemon option '%s' given twice (first at line %d)",
                     where, o->line, o->key, seen_line[r]);
            return -1;
        }
        seen |= rows[r].bit;
        seen_line[r] = o->line;
        /* Checked even when the command line overrides it: a scene that is wrong stays
         * wrong, and the error should not wait for the day the flag is dropped. */
        daemon_options scratch = next;
        if (set_field(&scratch, rows[r].bit, o->value, scene_dir, why, sizeof why) < 0) {
            snprintf(err, err_len, "%s:%d: %s: %s", where, o->line, o->key, why);
            return -1;
        }
        if (from_scene & rows[r].bit)
            next = scratch;
    }

    if (next.publish_url[0] == '\0')
        snprintf(next.publish_url, sizeof next.publish_url, "%s", next.url);
    if (options_url_is_file(next.url) && strcmp(next.url, next.publish_url) == 0) {
        snprintf(err, err_len,
                 "the input '%s' is an LCM log, which cannot publish: give --publish-url "
                 "(e.g. file:///tmp/replies.log?mode=w)",
                 next.url);
        return -1;
    }
    *opt = next;
    return 0;
}

options_action options_load(daemon_options *opt, int argc, char **argv, scene *sc, char *err,
                            size_t err_len)
{
    memset(sc, 0, sizeof *sc);
    options_init(opt);
    options_action action = options_parse_args(opt, argc, argv, err, err_len);
    if (action != OPTIONS_RUN)
        return action;
    if (scene_load(opt->scene_path, sc, err, err_len) < 0)
        return OPTIONS_ERROR;
    if (options_apply_scene(opt, sc, err, err_len) < 0) {
        scene_free(sc);
        memset(sc, 0, sizeof *sc);
        return OPTIONS_ERROR;
    }
    return OPTIONS_RUN;
}

void options_usage(FILE *out, const char *argv0)
{
    fprintf(out,
            "usage: %s --scene FILE [options]\n"
            "Answers ray, triangle and mesh queries over LCM against the worlds of a scene.\n"
            "\n"
            "  -s, --scene FILE          the scene: a [daemon] section and one section per world\n"
            "  -u, --url URL             LCM URL to listen on (default: $LCM_DEFAULT_URL, else\n"
            "                            " OPTIONS_LCM_DEFAULT_URL ")\n"
            "      --publish-url URL     LCM URL to publish on (default: the --url; a file://\n"
            "                            input log needs its own, e.g. file:///out.log?mode=w)\n"
            "  -p, --prefix P            channel prefix (default " TRIOCT_DEFAULT_PREFIX ")\n"
            "  -n, --name NAME           this daemon's name, for LOAD (default " TRIOCT_DEFAULT_DAEMON ")\n"
            "  -t, --threads N           worker threads (default: the CPUs available)\n"
            "  -w, --world-dir DIR       where meshes are read (default: the scene's directory)\n"
            "  -q, --queue-depth N       requests in hand before new ones get BUSY (default %d)\n"
            "  -l, --log-level L         error, warn, info or debug (default info)\n"
            "      --status-interval MS  heartbeat period on <prefix>_STATUS (default %d)\n"
            "      --exit-at-eof         with a file:// input: answer it all, then exit 0\n"
            "      --ordered             for replays: answer as one thread would, whatever\n"
            "                            --threads; <prefix>_RELOAD_<name> reloads the scene\n"
            "                            and <prefix>_STOP_<name> stops, at that point\n"
            "      --no-inline           hand every request to the workers, even those small\n"
            "                            enough to answer on the loop thread as they come\n"
            "      --memory-budget SIZE  what all worlds' meshes and trees may hold (default:\n"
            "                            half the machine's memory; 512M, 2G, ...)\n"
            "      --loader PROGRAM      the mesh loader (default: trioct-load beside trioctd)\n"
            "      --admin-key-file FILE the key changes over the bus are authenticated with\n"
            "                            (default: none, and LOAD, UNLOAD and edits are refused)\n"
            "      --mesh-root DIR       a read-only directory meshes may also be read from (a ROS\n"
            "                            package, /usr/share/...); repeat for more\n"
            "  -h, --help                this text\n"
            "  -V, --version             the version\n"
            "\n"
            "The scene's [daemon] section takes the same options as url, publish_url, prefix,\n"
            "name, threads, world_dir, queue_depth, log_level, status_interval, memory_budget,\n"
            "loader, admin_key_file and mesh_root (repeatable); the command line wins. SIGHUP reloads the scene; SIGTERM\n"
            "and SIGINT finish the work in hand and exit.\n",
            argv0, OPTIONS_DEFAULT_QUEUE_DEPTH, OPTIONS_DEFAULT_STATUS_INTERVAL_MS);
}
