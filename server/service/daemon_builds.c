/* World builds on the thread pool, at start-up and in a reload; the scene worlds whose
 * build failed; the end of start-up. */

#include "daemon_internal.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../world/registry.h"
#include "log.h"


static failed_world *failed_find(daemon *d, const char *name)
{
    for (size_t i = 0; i < d->failed_count; i++)
        if (strcmp(d->failed[i].name, name) == 0)
            return &d->failed[i];
    return NULL;
}

void daemon_failed_remove(daemon *d, const char *name)
{
    failed_world *f = failed_find(d, name);
    if (f != NULL)
        *f = d->failed[--d->failed_count];
}

void daemon_failed_set(daemon *d, const world_spec *spec, const char *error)
{
    failed_world *f = failed_find(d, spec->name);
    if (f == NULL) {
        if (d->failed_count == d->failed_alloc) {
            size_t want = d->failed_alloc ? d->failed_alloc * 2 : 8;
            failed_world *grown = realloc(d->failed, want * sizeof *grown);
            if (grown == NULL)
                return; /* the error is logged already; status just will not show it */
            d->failed = grown;
            d->failed_alloc = want;
        }
        f = &d->failed[d->failed_count++];
    }
    snprintf(f->name, sizeof f->name, "%s", spec->name);
    snprintf(f->source, sizeof f->source, "%s", spec->source);
    snprintf(f->error, sizeof f->error, "%s", error);
}

/* ---- Worlds: start-up and reload builds ------------------------------------------------- */

static void work_build(uv_work_t *work)
{
    build_job *job = work->data;
    uint64_t t0 = uv_hrtime();
    job->status = TRIOCT_OK;
    job->result = world_build(&job->spec, job->world_dir, &job->d->ctx.env, &job->status, job->err, sizeof job->err);
    job->seconds = (double)(uv_hrtime() - t0) / 1e9;
}


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
                "bounds (%g %g %g)-(%g %g %g), built in %.3f s",
                name, w->version, r->triangles, r->degenerate, r->duplicates, r->bbox_lo.x, r->bbox_lo.y,
                r->bbox_lo.z, r->bbox_hi.x, r->bbox_hi.y, r->bbox_hi.z, job->seconds);
            daemon_failed_remove(d, name);
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
    build_phase phase = job->phase;
    free(job);

    if (d->builds > 0)
        return;
    if (d->state == TRIOCT_STATUS_T_STOPPING)
        daemon_maybe_finish(d);
    else if (phase == BUILD_STARTUP)
        daemon_startup_done(d);
    else
        daemon_reload_done(d);
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
        "prefix %s, name %s, %d threads, queue depth %d", d->sub_count, d->failed_count,
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
