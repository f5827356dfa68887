/* trioctd's service loop: start-up, the loop's handles, signals, stopping and tear-down.
 * The loop's other concerns each have a file; daemon_internal.h lists them. */

#include "daemon_internal.h"

#include <errno.h>
#include <inttypes.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "../../common/wire_check.h"
#include "../world/registry.h"
#include "admin_auth.h"
#include "log.h"

_Static_assert(STATS_REQUEST_TYPES == REQUEST_TYPE_COUNT, "status_t.served has one slot a type");

static const char *const state_names[] = {
    [TRIOCT_STATUS_T_STARTING] = "starting",
    [TRIOCT_STATUS_T_READY] = "ready",
    [TRIOCT_STATUS_T_RELOADING] = "reloading",
    [TRIOCT_STATUS_T_STOPPING] = "stopping",
};

const char *daemon_state_name(int state)
{
    int known = state >= 0 && state < (int)(sizeof state_names / sizeof state_names[0]);
    return known && state_names[state] != NULL ? state_names[state] : "unknown";
}


static void close_handles(daemon *d)
{
    if (!d->handles_ready)
        return;
    d->polling = 0;
    uv_close((uv_handle_t *)&d->poll, NULL);
    uv_close((uv_handle_t *)&d->heartbeat, NULL);
    uv_close((uv_handle_t *)&d->sig_term, NULL);
    uv_close((uv_handle_t *)&d->sig_int, NULL);
    uv_close((uv_handle_t *)&d->sig_hup, NULL);
    uv_close((uv_handle_t *)&d->watchdog, NULL);
    lcm_selftest_close(&d->selftest);
    d->handles_ready = 0;
}

/* Stops once nothing is left in hand: every reply published, every build back. */
void daemon_maybe_finish(daemon *d)
{
    if (d->state != TRIOCT_STATUS_T_STOPPING || d->closing || d->in_flight > 0 || d->builds > 0 ||
        daemon_ordered_stop_waits(d))
        return;
    daemon_publish_status(d);
    LOG(LOG_INFO, "stopped: served ray %" PRId64 " triangle %" PRId64 " mesh %" PRId64
        " admin %" PRId64 ", malformed %" PRId64, d->st.served[0], d->st.served[1],
        d->st.served[2], d->st.served[3], d->st.malformed);
    d->closing = 1;
    close_handles(d);
}

static void on_signal(uv_signal_t *handle, int signum)
{
    daemon *d = handle->data;
    if (signum == SIGHUP) {
        LOG(LOG_INFO, "SIGHUP: reloading the scene");
        daemon_start_reload(d);
        return;
    }
    if (d->state == TRIOCT_STATUS_T_STOPPING) {
        LOG(LOG_INFO, "%s: already stopping, %d requests and %d builds in hand",
            signum == SIGINT ? "SIGINT" : "SIGTERM", d->in_flight, d->builds);
        return;
    }
    LOG(LOG_INFO, "%s: stopping; new requests get STOPPING, %d requests in hand finish first",
        signum == SIGINT ? "SIGINT" : "SIGTERM", d->in_flight);
    d->state = TRIOCT_STATUS_T_STOPPING;
    daemon_tell_systemd(d, TELL_STOPPING);
    daemon_maybe_finish(d);
}

/* ---- Running ---------------------------------------------------------------------------- */

static int init_handles(daemon *d)
{
    int rc;
    if ((rc = uv_poll_init(&d->loop, &d->poll, d->lcm_fd)) != 0) {
        LOG(LOG_ERROR, "cannot watch the LCM descriptor: %s", uv_strerror(rc));
        return -1;
    }
    uv_timer_init(&d->loop, &d->heartbeat);
    uv_signal_init(&d->loop, &d->sig_term);
    uv_signal_init(&d->loop, &d->sig_int);
    uv_signal_init(&d->loop, &d->sig_hup);
    d->poll.data = d->heartbeat.data = d->sig_term.data = d->sig_int.data = d->sig_hup.data = d;
    uv_timer_init(&d->loop, &d->watchdog);
    lcm_selftest_init(&d->selftest, &d->loop);
    d->watchdog.data = d->selftest.data = d;
    d->handles_ready = 1;
    uv_signal_start(&d->sig_term, on_signal, SIGTERM);
    uv_signal_start(&d->sig_int, on_signal, SIGINT);
    uv_signal_start(&d->sig_hup, on_signal, SIGHUP);
    uint64_t every = (uint64_t)d->opt.status_interval_ms;
    uv_timer_start(&d->heartbeat, daemon_on_heartbeat, every, every);
    daemon_start_watchdog(d);
    return 0;
}

static void destroy(daemon *d)
{
    notify_close(&d->nt);
    daemon_unsubscribe_all(d);
    if (d->lcm_out != NULL && d->lcm_out != d->lcm_in)
        lcm_destroy(d->lcm_out);
    if (d->lcm_in != NULL)
        lcm_destroy(d->lcm_in);
    if (d->ctx.worlds != NULL)
        registry_free(d->ctx.worlds);
    if (d->scene != NULL) {
        scene_free(d->scene);
        free(d->scene);
    }
    pthread_mutex_destroy(&d->ctx.scene_lock);
    admin_auth_free(d->ctx.auth);
    reply_cache_free(d->replies);
    stats_free(&d->st);
    while (d->held != NULL) {
        request_job *job = d->held;
        d->held = job->next;
        free(job);
    }
    free(d->subs);
    failed_worlds_free(d->ctx.failed);
    if (d->ctx.loads != NULL)
        load_table_destroy(&d->loads);
    free(d->unload);
    free(d->pending);
    free(d);
}

/* Changes over the bus need the key of admin_key_file; without one they are all refused,
 * and a key file that cannot be used stops the start (a configuration error). */
static int setup_admin_auth(daemon *d)
{
    const char *path = d->opt.admin_key_file;
    trioct_admin_key key;
    char err[TRIOCT_MAX_PATH_LEN + 256];
    if (path[0] != '\0' && trioct_admin_key_load(path, &key, err, sizeof err) != 0) {
        LOG(LOG_ERROR, "%s", err);
        return -1;
    }
    d->ctx.auth = admin_auth_create(path[0] != '\0' ? &key : NULL, !d->input_is_file);
    memset(&key, 0, sizeof key);
    if (!d->ctx.auth) {
        LOG(LOG_ERROR, "out of memory for the change guard");
        return -1;
    }
    if (path[0] != '\0')
        LOG(LOG_INFO, "changes over the bus are accepted when signed with the key of %s", path);
    else
        LOG(LOG_INFO, "no admin_key_file: LOAD, UNLOAD and object edits over the bus are refused");
    return 0;
}

/* Every mesh file is parsed in the loader child, within limits drawn from the budget;
 * a daemon that cannot find its loader does not start (a configuration error, exit 2). */
static int setup_world_env(daemon *d)
{
    const daemon_options *opt = &d->opt;
    char err[TRIOCT_MAX_PATH_LEN * 2 + 128];
    mesh_loader *ld = &d->ctx.loader;
    if (opt->loader[0] != '\0') {
        if (access(opt->loader, X_OK) != 0) {
            LOG(LOG_ERROR, "the mesh loader %s is not an executable: %s", opt->loader, strerror(errno));
            return -1;
        }
        snprintf(ld->program, sizeof ld->program, "%s", opt->loader);
    } else if (mesh_loader_find(ld->program, sizeof ld->program, err, sizeof err) != 0) {
        LOG(LOG_ERROR, "%s (give --loader or loader in [daemon])", err);
        return -1;
    }
    /* What the parser may take while it reads a file: never more than the budget, never
     * less than a parser needs for the libraries and a middling mesh. */
    size_t memory = opt->memory_budget < MESH_LOADER_MAX_MEMORY ? opt->memory_budget : MESH_LOADER_MAX_MEMORY;
    ld->memory_bytes = memory < MESH_LOADER_MIN_MEMORY ? MESH_LOADER_MIN_MEMORY : memory;
    ld->cpu_seconds = MESH_LOADER_CPU_SECONDS;
    ld->wall_seconds = MESH_LOADER_WALL_SECONDS;
    memory_account_init(&d->ctx.memory, opt->memory_budget);
    if (setup_admin_auth(d) != 0)
        return -1;
    /* A mesh root must be a directory now: a typo would otherwise show only as a refused
     * path, later, on some LOAD. */
    for (size_t i = 0; i < opt->mesh_roots.count; i++) {
        const char *root = opt->mesh_roots.paths[i];
        struct stat st;
        errno = 0;
        if (stat(root, &st) != 0 || !S_ISDIR(st.st_mode)) {
            LOG(LOG_ERROR, "mesh_root %s: %s", root, errno ? strerror(errno) : "not a directory");
            return -1;
        }
        LOG(LOG_INFO, "meshes may also be read from %s (mesh_root)", root);
    }
    d->ctx.env.loader = ld;
    d->ctx.env.account = &d->ctx.memory;
    d->ctx.env.roots = &d->opt.mesh_roots;
    LOG(LOG_INFO, "memory budget %zu MiB; meshes parsed by %s (at most %zu MiB, %u s of CPU each)",
        opt->memory_budget >> 20, ld->program, ld->memory_bytes >> 20, ld->cpu_seconds);
    return 0;
}

int daemon_run(const daemon_options *opt, scene *sc)
{
    log_set_level(opt->log_level);

    /* libuv sizes its pool from the environment at the first queued work, once a process. */
    char threads[16];
    snprintf(threads, sizeof threads, "%d", opt->threads);
    setenv("UV_THREADPOOL_SIZE", threads, 1);
    /* A peer closing a socket must cost a failed write, not the daemon. */
    signal(SIGPIPE, SIG_IGN);
    /* lcm-gen's code computes each type's fingerprint on first use into an unlocked static;
     * computing them all here, before any worker exists, keeps the workers from racing. */
    for (int t = 0; t < WIRE_TYPE_COUNT; t++)
        (void)wire_fingerprint((wire_type)t);

    daemon *d = calloc(1, sizeof *d);
    scene *owned = calloc(1, sizeof *owned);
    if (d == NULL || owned == NULL) {
        LOG(LOG_ERROR, "out of memory");
        free(d);
        free(owned);
        scene_free(sc);
        memset(sc, 0, sizeof *sc);
        return 1;
    }
    *owned = *sc;
    memset(sc, 0, sizeof *sc);
    d->opt = *opt;
    d->scene = owned;
    daemon_open_notify(d); /* first: destroy() closes its socket */
    d->state = TRIOCT_STATUS_T_STARTING;
    d->start_hr = uv_hrtime();
    d->input_is_file = options_url_is_file(opt->url);
    stats_init(&d->st, 0);
    pthread_mutex_init(&d->ctx.scene_lock, NULL);
    d->ctx.scene = owned;
    snprintf(d->ctx.prefix, sizeof d->ctx.prefix, "%s", opt->prefix);
    snprintf(d->ctx.daemon, sizeof d->ctx.daemon, "%s", opt->name);
    snprintf(d->ctx.world_dir, sizeof d->ctx.world_dir, "%s", opt->world_dir);
    if (setup_world_env(d) != 0) {
        destroy(d);
        return 2;
    }
    d->ctx.worlds = registry_create();
    d->ctx.failed = failed_worlds_create();
    load_table_init(&d->loads);
    d->ctx.loads = &d->loads;
    d->replies = reply_cache_create(REPLY_CACHE_ENTRIES, REPLY_CACHE_BYTES);
    if (d->ctx.worlds == NULL || d->ctx.failed == NULL || d->replies == NULL) {
        LOG(LOG_ERROR, "out of memory");
        destroy(d);
        return 1;
    }

    LOG(LOG_INFO, "trioctd %s starting: scene %s, world directory %s", TRIOCT_VERSION,
        opt->scene_path, opt->world_dir);
    d->lcm_in = lcm_create(opt->url);
    if (d->lcm_in == NULL) {
        LOG(LOG_ERROR, "cannot open LCM on %s%s", opt->url,
            d->input_is_file ? " (a log must exist and hold at least one event)" : "");
        destroy(d);
        return 1;
    }
    if (strcmp(opt->publish_url, opt->url) == 0) {
        d->lcm_out = d->lcm_in;
    } else if ((d->lcm_out = lcm_create(opt->publish_url)) == NULL) {
        LOG(LOG_ERROR, "cannot open LCM on %s to publish", opt->publish_url);
        destroy(d);
        return 1;
    }
    d->lcm_fd = lcm_get_fileno(d->lcm_in);
    if (trioct_channel_name(d->status_channel, opt->prefix, TRIOCT_CHANNEL_STATUS, NULL) < 0 ||
        daemon_subscribe_fixed(d) < 0) {
        LOG(LOG_ERROR, "cannot subscribe with prefix %s and name %s", opt->prefix, opt->name);
        destroy(d);
        return 1;
    }

    int rc = uv_loop_init(&d->loop);
    if (rc != 0) {
        LOG(LOG_ERROR, "cannot start the event loop: %s", uv_strerror(rc));
        destroy(d);
        return 1;
    }
    if (init_handles(d) < 0) {
        uv_loop_close(&d->loop);
        destroy(d);
        return 1;
    }
    daemon_publish_status(d);

    /* Every world of the scene builds on the pool at once (with --ordered one after another,
     * daemon_queue_builds); the loop reads no message until the last one is back
     * (daemon_startup_done). */
    size_t *all = calloc(owned->world_count ? owned->world_count : 1, sizeof *all);
    for (size_t i = 0; all != NULL && i < owned->world_count; i++)
        all[i] = i;
    if (all == NULL) {
        LOG(LOG_ERROR, "out of memory");
        destroy(d);
        return 1;
    }
    daemon_queue_builds(d, all, owned->world_count, BUILD_STARTUP);

    uv_run(&d->loop, UV_RUN_DEFAULT);
    /* Run again until every closed handle has had its close callback. */
    while (uv_loop_close(&d->loop) == UV_EBUSY)
        uv_run(&d->loop, UV_RUN_NOWAIT);

    int code = d->exit_code;
    destroy(d);
    return code;
}

