/* World admin: LIST, INFO, LOAD and UNLOAD, and the one conversion of a held world into
 * world_info_t that their replies and the status message share. */
#include <inttypes.h>
#include <math.h>
#include <string.h>

#include "dispatch_internal.h"
#include "log.h"

static trioct_vec3_t vec_out(vec3 v)
{
    return (trioct_vec3_t){v.x, v.y, v.z};
}

void dispatch_world_info(const dispatch_ctx *ctx, const registry_entry *entry, trioct_world_info_t *info,
                         char *shape_names[TRIOCT_MAX_SHAPES])
{
    const world *w = entry->w;
    octree_info oi;
    world_tree_info(w, &oi);
    memset(info, 0, sizeof *info);
    /* The generated struct has char * fields; the encoder only reads them. */
    info->name = (char *)w->spec.name;
    info->daemon = (char *)ctx->daemon;
    info->version = (int64_t)w->version;
    info->source = (char *)w->spec.source;
    info->accuracy = (char *)accuracy_mode_name(w->spec.def.mode);
    info->seed_epsilon = w->spec.def.seed_epsilon;
    info->effects = (int32_t)w->spec.effects;

    info->triangles = (int64_t)oi.triangle_count;
    info->vertices = (int64_t)oi.vertex_count;
    info->degenerate = (int64_t)w->report.degenerate;
    info->duplicates = (int64_t)w->report.duplicates;
    info->bbox_min = vec_out(w->report.bbox_lo);
    info->bbox_max = vec_out(w->report.bbox_hi);

    info->nodes = (int64_t)oi.node_count;
    info->leaves = (int64_t)oi.leaf_count;
    info->max_level = oi.max_level;
    info->resolution = oi.resolution;
    info->world_size = oi.world_size;
    info->world_min = vec_out(oi.world_min);

    /* What the effects cost beyond the octree itself: query shapes (meshes) and, when the
     * engine keeps them, the triangles' bounding boxes (triangle and mesh queries). */
    int64_t effects_bytes = (int64_t)w->bytes_shapes;
#ifdef OCTREE_HAS_TRIANGLE_BOXES
    effects_bytes += (int64_t)oi.bytes_triangle_boxes;
#endif
    info->bytes_nodes = (int64_t)oi.bytes_nodes;
    info->bytes_leaf_lists = (int64_t)oi.bytes_leaf_lists;
    info->bytes_triangles = (int64_t)oi.bytes_triangles;
    info->bytes_effects = effects_bytes;
    info->bytes_total = (int64_t)oi.bytes_total + (int64_t)w->bytes_shapes;
    info->memory_bytes = (int64_t)world_memory_bytes(w);
    info->memory_budget = (int64_t)w->spec.memory_budget;
    /* The octrees' build after the meshes were read, as the log says it; a version made by
     * an object edit has only its trees' own times. */
    info->build_seconds = w->build_seconds > 0 ? w->build_seconds : oi.build_seconds;
    info->load_seconds = w->load_seconds;

    info->objects = (int64_t)w->objects->count;
    info->queries = (int64_t)atomic_load(&((world *)w)->queries);
    info->last_error = (char *)entry->last_error;
    size_t shapes = w->shape_count < TRIOCT_MAX_SHAPES ? w->shape_count : TRIOCT_MAX_SHAPES;
    for (size_t i = 0; i < shapes; i++)
        shape_names[i] = (char *)w->shapes[i].name;
    info->num_shapes = (int32_t)shapes;
    info->shapes = shape_names;
}

void dispatch_failed_world_info(const dispatch_ctx *ctx, const failed_world *f, trioct_world_info_t *info)
{
    static char empty[] = "";
    memset(info, 0, sizeof *info);
    info->name = (char *)f->name;
    info->daemon = (char *)ctx->daemon;
    info->version = 0;
    info->source = (char *)f->source;
    info->accuracy = empty;
    info->last_error = (char *)f->error;
}

/* Encodes the OK reply listing `count` entries, then `failed_count` failed worlds. */
static int reply_worlds(job *j, const registry_entry *entries, size_t count, const failed_world *failed,
                        size_t failed_count)
{
    size_t all = count + failed_count;
    trioct_world_info_t *infos = dispatch_calloc(all, sizeof *infos);
    char *(*names)[TRIOCT_MAX_SHAPES] = dispatch_calloc(count, sizeof *names);
    int status = TRIOCT_OK;
    if (!infos || !names) {
        status = job_fail(j, TRIOCT_ERR_NOMEM, "out of memory listing %zu worlds", all);
    } else {
        for (size_t i = 0; i < count; i++)
            dispatch_world_info(j->ctx, &entries[i], &infos[i], names[i]);
        for (size_t i = 0; i < failed_count; i++)
            dispatch_failed_world_info(j->ctx, &failed[i], &infos[count + i]);
        reply_head h = job_head(j, TRIOCT_OK, "ok");
        status = encode_admin_reply(j->out, &h, j->req.admin_op, infos, all);
        if (status == TRIOCT_ERR_NOMEM)
            job_fail(j, status, "out of memory encoding the reply");
        else if (status != TRIOCT_OK)
            job_fail(j, status, "a world's info does not fit TRIOCT_MAX_CHUNK_BYTES=%d", TRIOCT_MAX_CHUNK_BYTES);
    }
    free(infos);
    free(names);
    return status;
}

static int admin_list(job *j)
{
    registry_entry entries[TRIOCT_MAX_WORLDS];
    size_t count = registry_entries(j->ctx->worlds, entries, TRIOCT_MAX_WORLDS);
    if (count > TRIOCT_MAX_WORLDS)
        count = TRIOCT_MAX_WORLDS; /* the registry holds no more; only as many were filled */
    /* The scene worlds that failed follow, version 0 and why: a user listing the worlds
     * sees what is missing, not just what is there. */
    failed_world *failed = j->ctx->failed != NULL ? dispatch_calloc(TRIOCT_MAX_WORLDS, sizeof *failed) : NULL;
    size_t nf = failed != NULL ? failed_worlds_list(j->ctx->failed, failed, TRIOCT_MAX_WORLDS) : 0;
    if (nf > TRIOCT_MAX_WORLDS)
        nf = TRIOCT_MAX_WORLDS;
    int status = reply_worlds(j, entries, count, failed, nf);
    free(failed);
    registry_entries_free(entries, count);
    return status;
}

/* INFO's entry carries the world's last rebuild error, which only the registry's listing
 * has; the one held by this job is the same world or an older version of it. */
static int admin_info(job *j)
{
    registry_entry entries[TRIOCT_MAX_WORLDS];
    size_t count = registry_entries(j->ctx->worlds, entries, TRIOCT_MAX_WORLDS);
    if (count > TRIOCT_MAX_WORLDS)
        count = TRIOCT_MAX_WORLDS;
    const registry_entry *found = NULL;
    for (size_t i = 0; i < count && !found; i++)
        if (strcmp(entries[i].w->spec.name, j->req.channel_name) == 0)
            found = &entries[i];
    int status;
    if (found) {
        j->world_version = (int64_t)found->w->version;
        status = reply_worlds(j, found, 1, NULL, 0);
    } else {
        /* Unloaded between the check and here. */
        status = job_fail(j, TRIOCT_ERR_UNKNOWN_WORLD, "world %s is not held by daemon %s", j->req.channel_name,
                          j->ctx->daemon);
    }
    registry_entries_free(entries, count);
    return status;
}

static int admin_unload(job *j)
{
    if (registry_remove(j->ctx->worlds, j->req.channel_name) != 0)
        return job_fail(j, TRIOCT_ERR_UNKNOWN_WORLD, "world %s is not held by daemon %s", j->req.channel_name,
                        j->ctx->daemon);
    j->out->worlds_changed = 1;
    if (reply_worlds(j, NULL, 0, NULL, 0) != TRIOCT_OK)
        return job_fail(j, j->status, "world %s was unloaded, but the reply failed: %s", j->req.channel_name,
                        trioct_status_text(j->status));
    return TRIOCT_OK;
}

/* A LOAD's spec: the scene's section of that name when mesh_path is empty, else the path
 * with the request's options. */
static int load_spec(job *j, const trioct_admin_request_t *m, world_spec *spec)
{
    const char *name = j->req.world;
    if (m->mesh_path[0] == '\0') {
        /* A scene section carries its own options; taking the request's silently would
         * build something else than either says, ignoring them would drop the caller's
         * intent without a word. */
        if (m->resolution > 0 || m->accuracy != TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD || m->seed_epsilon > 0 ||
            m->effects != 0)
            return job_fail(j, TRIOCT_ERR_BAD_REQUEST,
                            "world %s comes from the scene's section [%s], which sets its own resolution, "
                            "accuracy and effects; send them only with mesh_path",
                            name, name);
        dispatch_ctx *ctx = j->ctx;
        int found = 0;
        pthread_mutex_lock(&ctx->scene_lock);
        const world_spec *s = ctx->scene ? scene_find(ctx->scene, name) : NULL;
        if (s) {
            *spec = *s;
            found = 1;
        }
        pthread_mutex_unlock(&ctx->scene_lock);
        if (!found)
            return job_fail(j, TRIOCT_ERR_BAD_REQUEST,
                            "scene has no section [%s]; send mesh_path to load a mesh file instead", name);
        return TRIOCT_OK;
    }
    size_t len = strlen(m->mesh_path);
    if (len >= TRIOCT_MAX_PATH_LEN)
        return job_fail(j, TRIOCT_ERR_BAD_PATH, "mesh_path is %zu characters, over TRIOCT_MAX_PATH_LEN=%d", len,
                        TRIOCT_MAX_PATH_LEN - 1);
    if (isnan(m->resolution) || isinf(m->resolution))
        return job_fail(j, TRIOCT_ERR_NONFINITE, "resolution is %g; send a length, or <= 0 for the heuristic",
                        m->resolution);
    if (isnan(m->seed_epsilon) || isinf(m->seed_epsilon))
        return job_fail(j, TRIOCT_ERR_NONFINITE, "seed_epsilon is %g; send a length, or <= 0 for the default",
                        m->seed_epsilon);
    if (m->accuracy < TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD || m->accuracy > TRIOCT_RAY_REQUEST_T_FAST)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST,
                        "accuracy %d is not ACCURACY_WORLD (-1, exact), EXACT (0), SEED (1) or FAST (2)",
                        m->accuracy);
    if (m->effects & ~(int32_t)EFFECT_ALL)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST,
                        "effects 0x%x has bits other than EFFECT_RAYS (1), EFFECT_TRIANGLES (2), "
                        "EFFECT_MESHES (4) and EFFECT_DISTANCE (8)",
                        (unsigned)m->effects);
    world_spec_init(spec, name);
    memcpy(spec->meshes[0], m->mesh_path, len + 1);
    spec->mesh_count = 1;
    memcpy(spec->source, m->mesh_path, len + 1);
    spec->def.resolution = m->resolution > 0 ? m->resolution : 0.0;
    spec->def.mode = m->accuracy == TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD ? ACCURACY_EXACT
                                                                        : (accuracy_mode)m->accuracy;
    if (m->seed_epsilon > 0)
        spec->def.seed_epsilon = m->seed_epsilon;
    spec->effects = m->effects ? (unsigned)m->effects : EFFECT_ALL;
    return TRIOCT_OK;
}

static int admin_load(job *j, const trioct_admin_request_t *m)
{
    world_spec *spec = dispatch_malloc(sizeof *spec); /* a spec is ~35 KB: not for a worker's stack */
    if (!spec)
        return job_fail(j, TRIOCT_ERR_NOMEM, "out of memory for the world's spec");
    int status = load_spec(j, m, spec);
    if (status != TRIOCT_OK) {
        free(spec);
        return status;
    }
    char err[TRIOCT_MAX_MESSAGE_LEN - 64];
    err[0] = '\0';
    int build_status = TRIOCT_ERR_LOAD_FAILED;
    world_env env = j->ctx->env; /* this build's own progress, which status shows */
    env.progress = j->ctx->loads ? load_table_begin(j->ctx->loads, j->req.world, j->req.client_id, j->req.request_id)
                                 : NULL;
    world *w = world_build(spec, j->ctx->world_dir, &env, &build_status, err, sizeof err);
    if (j->ctx->loads)
        load_table_end(j->ctx->loads, env.progress);
    free(spec);
    if (!w) {
        if (build_status == TRIOCT_OK)
            build_status = TRIOCT_ERR_LOAD_FAILED;
        /* A failed rebuild leaves the old version serving; status and INFO say why. */
        registry_set_error(j->ctx->worlds, j->req.world, err);
        /* world_build's message already names the world and the file. */
        if (err[0])
            return job_fail(j, build_status, "%s", err);
        return job_fail(j, build_status, "world %s was not loaded: %s", j->req.world,
                        trioct_status_text(build_status));
    }
    world_retain(w); /* install takes one reference; this one is the reply's */
    if (registry_install(j->ctx->worlds, w) != 0) {
        world_release(w);
        world_release(w);
        return job_fail(j, TRIOCT_ERR_OVER_CAP,
                        "daemon %s already holds TRIOCT_MAX_WORLDS=%d worlds; unload one first", j->ctx->daemon,
                        TRIOCT_MAX_WORLDS);
    }
    j->out->worlds_changed = 1;
    j->world_version = (int64_t)w->version;
    registry_entry entry = {.w = w, .last_error = ""};
    status = reply_worlds(j, &entry, 1, NULL, 0);
    if (status == TRIOCT_OK)
        LOG(LOG_INFO, "LOAD of world '%s' by client %" PRIx64 " (request %" PRId64 "): OK, version %" PRIu64
            ", %zu triangles; meshes read in %.3f s, octrees built in %.3f s", j->req.world,
            (uint64_t)j->req.client_id, j->req.request_id, w->version, w->report.triangles, w->load_seconds,
            w->build_seconds);
    world_release(w);
    if (status != TRIOCT_OK)
        return job_fail(j, status, "world %s was loaded as version %lld, but the reply failed: %s", j->req.world,
                        (long long)j->world_version, trioct_status_text(status));
    return TRIOCT_OK;
}

/* Every change over the bus is logged with who asked and how it went: what an operator
 * reads to learn why a world changed, or why it did not. A granted LOAD is logged by
 * admin_load, which holds the world it built. */
static void log_change(const job *j, const char *op, int status)
{
    if (status != TRIOCT_OK)
        LOG(LOG_WARN, "%s of world '%s' by client %" PRIx64 " (request %" PRId64 "): %s: %s", op, j->req.world,
            (uint64_t)j->req.client_id, j->req.request_id, trioct_status_name(status), j->message);
    else
        LOG(LOG_INFO, "%s of world '%s' by client %" PRIx64 " (request %" PRId64 "): OK", op, j->req.world,
            (uint64_t)j->req.client_id, j->req.request_id);
}

int dispatch_admin(job *j, const trioct_admin_request_t *m)
{
    int status;
    switch (m->op) {
    case TRIOCT_ADMIN_REQUEST_T_LIST:
        return admin_list(j);
    case TRIOCT_ADMIN_REQUEST_T_INFO:
        return admin_info(j);
    case TRIOCT_ADMIN_REQUEST_T_UNLOAD:
        status = dispatch_authorize(j) == TRIOCT_OK ? admin_unload(j) : j->status;
        log_change(j, "UNLOAD", status);
        return status;
    case TRIOCT_ADMIN_REQUEST_T_LOAD:
        status = dispatch_authorize(j) == TRIOCT_OK ? admin_load(j, m) : j->status;
        if (status != TRIOCT_OK)
            log_change(j, "LOAD", status);
        return status;
    default:
        /* check_header admits only the op its channel serves. */
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "admin op %d is not LIST, INFO, LOAD or UNLOAD", m->op);
    }
}
