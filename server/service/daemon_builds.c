/* World builds on the thread pool, at start-up and in a reload; the scene worlds whose
 * build failed; the end of start-up. */

#include "daemon_internal.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../world/registry.h"
#include "log.h"


void daemon_failed_set(daemon *d, const world_spec *spec, const char *error)
{
    if (failed_worlds_set(d->ctx.failed, spec->name, spec->source, error) != 0)
        LOG(LOG_WARN, "world '%s': %d failed worlds are recorded already; this one is only logged", spec->name,
            TRIOCT_MAX_WORLDS);
}

/* ---- Worlds: start-up and reload builds ------------------------------------------------- */

static void work_build(uv_work_t *work)
{
    build_job *job = work->data;
    job->status = TRIOCT_OK;
    dispatch_ctx *ctx = &job->d->ctx;
    world_env env = ctx->env; /* with this build's progress, which status shows */
    env.progress = load_table_begin(ctx->loads, job->spec.name, 0, 0);
    job->result = world_build(&job->spec, job->world_dir, &env, &job->status, job->err, sizeof job->err);
    load_table_end(ctx->loads, env.progress);
}


static void queue_pending(daemon *d);

static void after_build(uv_work_t *work, int status)
{
    build_job *job = work->data;
    daemon *d = job->d;
    d->builds--;
    const char *name = job->spec.name;

    if (status != 0 && job->result == NULL)
        snprintf(job->err, sizeof job->err, "the build did not run: %s", uv_strerror(status));

    if (d->state == TRIOCT_STATUS_T_STOPPING) {
        if (job->result != NULL)
            world_release(job->result);
    } else if (job->result != NULL) {
        world *w = job->result;
        /* Our own reference for the log line: once installed, an UNLOAD on a worker may
         * drop the registry's at any moment. */
        world_retain(w);
        if (registry_install(d->ctx.worlds, w) < 0) {
            char err[128];
            snprintf(err, sizeof err, "the daemon already holds %d worlds", TRIOCT_MAX_WORLDS);
            LOG(LOG_ERROR, "world '%s' was built but not installed: %s", name, err);
            world_release(w);
            daemon_failed_set(d, &job->spec, err);
            d->reload_failed++;
        } else {
            /* The registry holds w now; its version was set by the install. */
            const mesh_load_report *r = &w->report;
            LOG(LOG_INFO,
                "world '%s' version %" PRIu64 " ready: %zu triangles (%zu degenerate, %zu duplicate), "
                "bounds (%g %g %g)-(%g %g %g); meshes read in %.3f s, octrees built in %.3f s",
                name, w->version, r->triangles, r->degenerate, r->duplicates, r->bbox_lo.x, r->bbox_lo.y,
                r->bbox_lo.z, r->bbox_hi.x, r->bbox_hi.y, r->bbox_hi.z, w->load_seconds, w->build_seconds);
            failed_worlds_remove(d->ctx.failed, name);
            d->reload_built++;
        }
        world_release(w);
    } else {
        world *old = registry_acquire(d->ctx.worlds, name);
        if (old != NULL) {
            registry_set_error(d->ctx.worlds, name, job->err);
            LOG(LOG_ERROR, "world '%s' could not be rebuilt (%s), version %" PRIu64
                " keeps serving: %s", name, trioct_status_name(job->status), old->version, job->err);
            world_release(old);
        } else {
            daemon_failed_set(d, &job->spec, job->err);
            LOG(LOG_ERROR, "world '%s' could not be loaded (%s): %s", name,
                trioct_status_name(job->status), job->err);
        }
        d->reload_failed++;
    }
    free(job);

    if (d->state == TRIOCT_STATUS_T_STOPPING) {
        if (d->builds == 0)
            daemon_maybe_finish(d);
        return;
    }
    queue_pending(d); /* the next world with --ordered; the end of the phase once all are back */
}

/* Queues what is pending: everything, or with --ordered the next one. Ends the phase when
 * nothing is left running. */
static void queue_pending(daemon *d)
{
    while (d->pending_next < d->pending_count) {
        const world_spec *spec = &d->scene->worlds[d->pending[d->pending_next++]];
        LOG(LOG_INFO, "building world '%s' from %s", spec->name, spec->source);
        if (daemon_queue_build(d, spec, d->pending_phase) == 0) {
            if (d->opt.ordered)
                return; /* after_build queues the next */
        } else if (d->pending_phase == BUILD_STARTUP) {
            daemon_failed_set(d, spec, "the build could not be queued");
        } else {
            d->reload_failed++;
        }
    }
    if (d->builds > 0)
        return;
    if (d->pending_phase == BUILD_STARTUP)
        daemon_startup_done(d);
    else
        daemon_reload_done(d);
}

void daemon_queue_builds(daemon *d, size_t *indices, size_t count, build_phase phase)
{
    free(d->pending);
    d->pending = indices;
    d->pending_count = indices != NULL ? count : 0;
    d->pending_next = 0;
    d->pending_phase = phase;
    queue_pending(d);
}

int daemon_queue_build(daemon *d, const world_spec *spec, build_phase phase)
{
    build_job *job = calloc(1, sizeof *job);
    if (job == NULL) {
        LOG(LOG_ERROR, "out of memory: world '%s' is not built", spec->name);
        return -1;
    }
    job->work.data = job;
    job->d = d;
    job->phase = phase;
    job->spec = *spec;
    snprintf(job->world_dir, sizeof job->world_dir, "%s", d->ctx.world_dir);
    int rc = uv_queue_work(&d->loop, &job->work, work_build, after_build);
    if (rc != 0) {
        LOG(LOG_ERROR, "world '%s' is not built: %s", spec->name, uv_strerror(rc));
        free(job);
        return -1;
    }
    d->builds++;
    return 0;
}

void daemon_startup_done(daemon *d)
{
    daemon_sync_subscriptions(d);
    d->state = TRIOCT_STATUS_T_READY;
    LOG(LOG_INFO, "ready: %zu world(s) held, %zu failed; listening on %s, publishing on %s, "
        "prefix %s, name %s, %d threads, queue depth %d", registry_entries(d->ctx.worlds, NULL, 0),
        failed_worlds_list(d->ctx.failed, NULL, 0),
        d->opt.url, d->opt.publish_url, d->opt.prefix, d->opt.name, d->opt.threads,
        d->opt.queue_depth);
    /* Only now: a replayed log must not reach a world that is still being built. */
    daemon_start_polling(d);
    daemon_start_selftest(d);
    daemon_tell_systemd(d, TELL_READY); /* at once for a file:// input, else once the bus is heard */
    daemon_publish_status(d);
    if (d->reload_pending) {
        d->reload_pending = 0;
        daemon_start_reload(d);
    }
}
