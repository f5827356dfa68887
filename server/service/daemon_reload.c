/* SIGHUP (or a reload mark): the scene is read again; new and changed worlds build while
 * the held versions answer, and worlds whose section left are unloaded at the end. */

#include "daemon_internal.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../world/registry.h"
#include "log.h"


/* Whether the held world w came from the scene s (its section there), rather than from an
 * admin LOAD of a mesh path: only those leave with their section. A LOAD of a section
 * copies the section's spec, source text included. */
static int world_from_scene(const world *w, const scene *s)
{
    const world_spec *section = scene_find(s, w->spec.name);
    if (section == NULL)
        return 0;
    return strcmp(section->source, w->spec.source) == 0 || world_spec_equal(section, &w->spec);
}

/* The workers read the roots while they resolve paths: a change waits for a restart. */
static int mesh_roots_equal(const mesh_roots *a, const mesh_roots *b)
{
    if (a->count != b->count)
        return 0;
    for (size_t i = 0; i < a->count; i++)
        if (strcmp(a->paths[i], b->paths[i]) != 0)
            return 0;
    return 1;
}

static int in_scene(const char *name, void *scene_)
{
    return scene_find(scene_, name) != NULL;
}

/* Options a reload can change without a restart take effect; the others are kept and the
 * log says so. */
static void apply_reloaded_options(daemon *d, const daemon_options *next)
{
    daemon_options *cur = &d->opt;
    if (next->log_level != cur->log_level) {
        cur->log_level = next->log_level;
        log_set_level(next->log_level);
        LOG(LOG_INFO, "reload: log level %s", log_level_name(next->log_level));
    }
    if (next->status_interval_ms != cur->status_interval_ms) {
        cur->status_interval_ms = next->status_interval_ms;
        uv_timer_set_repeat(&d->heartbeat, (uint64_t)next->status_interval_ms);
        uv_timer_again(&d->heartbeat);
        LOG(LOG_INFO, "reload: status every %d ms", next->status_interval_ms);
    }
    if (next->queue_depth != cur->queue_depth) {
        cur->queue_depth = next->queue_depth;
        daemon_resize_lcm_queues(d);
        LOG(LOG_INFO, "reload: queue depth %d", next->queue_depth);
    }
    struct {
        int changed;
        const char *key;
    } restart[] = {
        {strcmp(next->url, cur->url) != 0, "url"},
        {strcmp(next->publish_url, cur->publish_url) != 0, "publish_url"},
        {strcmp(next->prefix, cur->prefix) != 0, "prefix"},
        {strcmp(next->name, cur->name) != 0, "name"},
        {next->threads != cur->threads, "threads"},
        {strcmp(next->world_dir, cur->world_dir) != 0, "world_dir"},
        {!mesh_roots_equal(&next->mesh_roots, &cur->mesh_roots), "mesh_root"},
    };
    for (size_t i = 0; i < sizeof restart / sizeof restart[0]; i++)
        if (restart[i].changed)
            LOG(LOG_WARN, "reload: the scene changes %s, which takes effect at the next start",
                restart[i].key);
}

void daemon_start_reload(daemon *d)
{
    if (d->state == TRIOCT_STATUS_T_STOPPING)
        return;
    if (d->state != TRIOCT_STATUS_T_READY) {
        d->reload_pending = 1;
        LOG(LOG_INFO, "SIGHUP while %s: the reload follows", daemon_state_name(d->state));
        return;
    }

    char err[1024];
    scene *next = calloc(1, sizeof *next);
    if (next == NULL) {
        LOG(LOG_ERROR, "reload: out of memory; the running scene stays");
        return;
    }
    if (scene_load(d->opt.scene_path, next, err, sizeof err) < 0) {
        LOG(LOG_ERROR, "reload: %s; the running scene stays", err);
        free(next);
        return;
    }
    daemon_options opt = d->opt;
    if (options_apply_scene(&opt, next, err, sizeof err) < 0) {
        LOG(LOG_ERROR, "reload: %s; the running scene stays", err);
        scene_free(next);
        free(next);
        return;
    }
    d->state = TRIOCT_STATUS_T_RELOADING;
    daemon_tell_systemd(d, TELL_RELOADING);
    LOG(LOG_INFO, "reloading %s", d->opt.scene_path);
    apply_reloaded_options(d, &opt);
    d->reload_built = d->reload_failed = d->reload_unchanged = 0;

    /* Scene worlds whose section is gone leave at the end of the reload. */
    registry_entry entries[TRIOCT_MAX_WORLDS];
    size_t n = registry_entries(d->ctx.worlds, entries, TRIOCT_MAX_WORLDS);
    if (n > TRIOCT_MAX_WORLDS)
        n = TRIOCT_MAX_WORLDS;
    free(d->unload);
    d->unload = calloc(n ? n : 1, sizeof *d->unload);
    d->unload_count = 0;
    for (size_t i = 0; i < n && d->unload != NULL; i++) {
        const world *w = entries[i].w;
        if (scene_find(next, w->spec.name) == NULL && world_from_scene(w, d->scene))
            snprintf(d->unload[d->unload_count++], sizeof d->unload[0], "%s", w->spec.name);
    }
    registry_entries_free(entries, n);

    /* A failed world whose section left is no longer a failure of this scene. */
    failed_worlds_filter(d->ctx.failed, in_scene, next);

    /* New and changed sections are rebuilt while the held versions keep answering; a
     * world held but failed before (its error set) is retried only when its spec changed. */
    size_t *rebuild = calloc(next->world_count ? next->world_count : 1, sizeof *rebuild);
    size_t rebuilds = 0;
    for (size_t i = 0; i < next->world_count; i++) {
        const world_spec *spec = &next->worlds[i];
        world *held = registry_acquire(d->ctx.worlds, spec->name);
        int same = held != NULL && world_spec_equal(&held->spec, spec);
        if (held != NULL)
            world_release(held);
        if (same)
            d->reload_unchanged++;
        else if (rebuild != NULL)
            rebuild[rebuilds++] = i;
        else
            d->reload_failed++; /* out of memory: logged below */
    }
    if (rebuild == NULL)
        LOG(LOG_ERROR, "reload: out of memory; changed worlds are not rebuilt");

    /* Admin LOADs of a section read the new scene from now on. Workers copy the spec they
     * need under the lock, so once the pointer is swapped nobody reads the old scene. */
    pthread_mutex_lock(&d->ctx.scene_lock);
    scene *old = d->scene;
    d->scene = next;
    d->ctx.scene = next;
    pthread_mutex_unlock(&d->ctx.scene_lock);
    scene_free(old);
    free(old);

    daemon_queue_builds(d, rebuild, rebuilds, BUILD_RELOAD); /* takes rebuild */
}

void daemon_reload_done(daemon *d)
{
    int unloaded = 0;
    for (size_t i = 0; i < d->unload_count; i++) {
        const char *name = d->unload[i];
        /* Still absent from the scene, which cannot change during a reload; removed by an
         * admin UNLOAD meanwhile is fine too. */
        if (scene_find(d->scene, name) == NULL && registry_remove(d->ctx.worlds, name) == 0) {
            LOG(LOG_INFO, "world '%s' unloaded: its section left the scene", name);
            unloaded++;
        }
    }
    free(d->unload);
    d->unload = NULL;
    d->unload_count = 0;

    daemon_sync_subscriptions(d);
    d->state = TRIOCT_STATUS_T_READY;
    LOG(LOG_INFO, "reload done: %d built, %d failed, %d unloaded, %d unchanged", d->reload_built,
        d->reload_failed, unloaded, d->reload_unchanged);
    daemon_tell_systemd(d, TELL_READY);
    daemon_publish_status(d);
    if (d->reload_pending) {
        d->reload_pending = 0;
        daemon_start_reload(d);
    }
    if (d->reload_in_order && d->state != TRIOCT_STATUS_T_RELOADING) {
        d->reload_in_order = 0;
        daemon_ordered_run(d);
    }
}
