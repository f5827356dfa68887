/* trioctd's options: the command line and the scene's [daemon] section. The command line
 * wins; a value neither gives takes its default. Every error names where it came from:
 * "--queue-depth: 'x' is not an integer in 1..1000000" or
 * "scene.ini:12: unknown daemon option 'foo'"; trioctd exits 2 on any of them.
 *
 *   command line            [daemon] key       default
 *   -s, --scene FILE        -                  (required)
 *   -u, --url URL           url                $LCM_DEFAULT_URL, else LCM's udpm default
 *       --publish-url URL   publish_url        the input URL
 *   -p, --prefix P          prefix             TRIOCT
 *   -n, --name NAME         name               trioctd
 *   -t, --threads N         threads            the CPUs this process may run on
 *   -w, --world-dir DIR     world_dir          the scene file's directory
 *   -q, --queue-depth N     queue_depth        1024
 *   -l, --log-level L       log_level          info
 *       --status-interval MS status_interval   1000
 *       --exit-at-eof       -                  off
 *       --ordered           -                  off
 *       --no-inline         -                  off (small requests answered on the loop)
 *
 * A relative world_dir in the scene is relative to the scene file's directory; on the
 * command line, to the working directory. */
#ifndef TRIOCT_SERVICE_OPTIONS_H
#define TRIOCT_SERVICE_OPTIONS_H

#include <stddef.h>
#include <stdio.h>

#include "../../common/trioct_limits.h"
#include "../../common/trioct_version.h"
#include "../world/scene.h"
#include "log.h"


/* LCM's own default (lcm_create(NULL) without LCM_DEFAULT_URL), spelled out so the log
 * says which bus the daemon is on. */
#define OPTIONS_LCM_DEFAULT_URL "udpm://239.255.76.67:7667?ttl=0"
#define OPTIONS_URL_LEN 1024

#define OPTIONS_DEFAULT_QUEUE_DEPTH 1024
#define OPTIONS_MAX_QUEUE_DEPTH 1000000
#define OPTIONS_DEFAULT_STATUS_INTERVAL_MS 1000
#define OPTIONS_MIN_STATUS_INTERVAL_MS 10
#define OPTIONS_MAX_STATUS_INTERVAL_MS 86400000
#define OPTIONS_MAX_THREADS 1024 /* libuv's cap on UV_THREADPOOL_SIZE */
#define OPTIONS_MIN_MEMORY_BUDGET ((size_t)16 << 20)

/* Half the machine's physical memory: what memory_budget is when nothing sets it. */
size_t options_default_memory_budget(void);

/* The options a scene may also set, as bits of daemon_options.from_cli. */
enum {
    OPT_URL = 1u << 0,
    OPT_PUBLISH_URL = 1u << 1,
    OPT_PREFIX = 1u << 2,
    OPT_NAME = 1u << 3,
    OPT_THREADS = 1u << 4,
    OPT_WORLD_DIR = 1u << 5,
    OPT_QUEUE_DEPTH = 1u << 6,
    OPT_LOG_LEVEL = 1u << 7,
    OPT_STATUS_INTERVAL = 1u << 8,
    OPT_MEMORY_BUDGET = 1u << 9,
    OPT_LOADER = 1u << 10,
    OPT_ADMIN_KEY_FILE = 1u << 11,
    OPT_MESH_ROOT = 1u << 12, /* repeatable: each one adds a root */
};

typedef struct daemon_options {
    char scene_path[TRIOCT_MAX_PATH_LEN];
    char url[OPTIONS_URL_LEN];
    char publish_url[OPTIONS_URL_LEN];
    char prefix[TRIOCT_MAX_PREFIX_LEN + 1];
    char name[TRIOCT_MAX_NAME_LEN + 1];
    int threads;
    char world_dir[TRIOCT_MAX_PATH_LEN];
    int queue_depth;
    log_level log_level;
    int status_interval_ms;
    size_t memory_budget;      /* bytes every world's meshes and trees may hold together */
    char loader[TRIOCT_MAX_PATH_LEN];         /* "": the one mesh_loader_find finds */
    char admin_key_file[TRIOCT_MAX_PATH_LEN]; /* "": no key, no change over the bus */
    mesh_roots mesh_roots;     /* read-only mesh directories besides world_dir (scene.h) */
    int exit_at_eof;   /* file:// input: finish the work in hand and exit 0 at its end */
    int ordered;       /* replays: answers as one thread gives them, whatever threads (daemon.c) */
    int no_inline;     /* every request to the workers, the small ones too (daemon.c) */
    unsigned from_cli; /* OPT_* bits set on the command line: a reload keeps them */
} daemon_options;

typedef enum options_action {
    OPTIONS_RUN = 0,
    OPTIONS_HELP,    /* --help: print options_usage, exit 0 */
    OPTIONS_VERSION, /* --version: print TRIOCT_VERSION, exit 0 */
    OPTIONS_ERROR,   /* err says why: exit 2 */
} options_action;

/* Empty options: nothing set. */
void options_init(daemon_options *opt);

/* Parses argv (getopt_long; reentrant: each call starts afresh). Sets the fields given and
 * their from_cli bits; defaults come with options_apply_scene. */
options_action options_parse_args(daemon_options *opt, int argc, char **argv, char *err,
                                  size_t err_len);

/* Applies the scene's [daemon] section under the command line, then the defaults, then
 * checks what only the whole can tell (a file:// input needs its own publish URL). Every
 * field without its from_cli bit is recomputed, so a reload calls it again on the running
 * options with the new scene. 0, or -1 with err and opt unchanged. */
int options_apply_scene(daemon_options *opt, const scene *sc, char *err, size_t err_len);

/* What trioctd's main does before running: parses argv, loads the scene it names (into
 * sc, which the caller frees or hands to daemon_run) and applies it. OPTIONS_RUN with sc
 * loaded; OPTIONS_HELP or OPTIONS_VERSION with sc empty; OPTIONS_ERROR with err and sc
 * empty. */
options_action options_load(daemon_options *opt, int argc, char **argv, scene *sc, char *err,
                            size_t err_len);

/* Whether url reads an LCM log (file://): its end is the end of the input. */
int options_url_is_file(const char *url);

void options_usage(FILE *out, const char *argv0);

#endif
