/* Object edits and listings (object_edit_request_t): every edit is checked before any
 * work, the meshes the adds name are loaded (or shared with objects already using the
 * file), then the list is applied to the version being served and the new version
 * installed in its place in one step. A LOAD or another edit list that installed a
 * version meanwhile makes the list apply again to that one, so no applied edit is lost
 * and each list is all or none on the version it lands on. */
#include <math.h>
#include <string.h>

#include "dispatch_internal.h"

/* Edit lists in one request, and how often a list is applied again when other versions
 * keep landing first (each landing is a whole request's work elsewhere: a livelock this
 * long means a daemon flooded with edits, which BUSY already answers). */
#define DISPATCH_EDIT_RETRIES 64

static int edit_fail(job *j, int index, int status, const char *fmt, const char *name, const char *why)
{
    j->failed_edit = index;
    char q[48];
    return job_fail(j, status, fmt, index, dispatch_quote(name, q, sizeof q), why);
}

/* What the edit list asks, checked; the models of the adds are loaded later. */
static int check_edits(job *j, const trioct_object_edit_request_t *m, object_edit *edits)
{
    if (m->num_edits > TRIOCT_MAX_EDITS)
        return job_fail(j, TRIOCT_ERR_OVER_CAP, "num_edits %d is over TRIOCT_MAX_EDITS=%d; split the list",
                        m->num_edits, TRIOCT_MAX_EDITS);
    for (int i = 0; i < m->num_edits; i++) {
        const trioct_object_edit_t *e = &m->edits[i];
        object_edit *out = &edits[i];
        memset(out, 0, sizeof *out);
        out->name = e->name;
        switch (e->op) {
        case TRIOCT_OBJECT_EDIT_T_ADD:
            out->kind = OBJECT_EDIT_ADD;
            break;
        case TRIOCT_OBJECT_EDIT_T_ADD_SOLID:
            out->kind = OBJECT_EDIT_ADD;
            out->solid = 1;
            break;
        case TRIOCT_OBJECT_EDIT_T_MOVE:
            out->kind = OBJECT_EDIT_MOVE;
            break;
        case TRIOCT_OBJECT_EDIT_T_REMOVE:
            out->kind = OBJECT_EDIT_REMOVE;
            break;
        default:
            j->failed_edit = i;
            return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "edits[%d].op %d is not ADD (0), MOVE (1), REMOVE (2) or ADD_SOLID (3)", i,
                            e->op);
        }
        if (e->rotation != TRIOCT_OBJECT_EDIT_T_MATRIX && e->rotation != TRIOCT_OBJECT_EDIT_T_QUATERNION) {
            j->failed_edit = i;
            return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "edits[%d].rotation %d is not MATRIX (0) or QUATERNION (1)",
                            i, e->rotation);
        }
        if (out->kind != OBJECT_EDIT_REMOVE) {
            int ps = dispatch_wire_pose(&e->pose, e->rotation == TRIOCT_OBJECT_EDIT_T_QUATERNION ? e->quaternion : NULL,
                                        &out->at);
            if (ps == OCTREE_ERR_NONFINITE)
                return edit_fail(j, i, TRIOCT_ERR_NONFINITE, "edits[%d] (%s): the pose %s", e->name,
                                 "has a NaN or infinite entry");
            if (ps != OCTREE_OK && e->rotation == TRIOCT_OBJECT_EDIT_T_QUATERNION)
                return edit_fail(j, i, TRIOCT_ERR_BAD_POSE, "edits[%d] (%s): the pose %s", e->name,
                                 "has a quaternion whose length is not 1 within 1e-3");
            if (ps != OCTREE_OK)
                return edit_fail(j, i, TRIOCT_ERR_BAD_POSE, "edits[%d] (%s): the pose %s", e->name,
                                 "is not a rotation: R^T R must be I within 1e-6 in every entry and det(R) +1 "
                                 "(a scale, shear or mirror is refused)");
        }
        int inline_mesh = out->kind == OBJECT_EDIT_ADD && e->mesh[0] == '\0';
        if (out->kind != OBJECT_EDIT_ADD && (e->mesh[0] != '\0' || e->num_triangles != 0))
            return edit_fail(j, i, TRIOCT_ERR_BAD_REQUEST, "edits[%d] (%s): %s", e->name,
                             "only ADD takes a mesh or triangles");
        if (out->kind == OBJECT_EDIT_ADD && !inline_mesh && e->num_triangles != 0)
            return edit_fail(j, i, TRIOCT_ERR_BAD_REQUEST, "edits[%d] (%s): %s", e->name,
                             "both a mesh file and inline triangles: send one");
        if (inline_mesh && (e->num_triangles < 1 || e->num_triangles > TRIOCT_MAX_INLINE_SHAPE_TRIANGLES))
            return edit_fail(j, i, e->num_triangles < 1 ? TRIOCT_ERR_BAD_REQUEST : TRIOCT_ERR_OVER_CAP,
                             "edits[%d] (%s): %s", e->name,
                             "ADD needs a mesh file or 1..TRIOCT_MAX_INLINE_SHAPE_TRIANGLES=512 triangles");
        for (int t = 0; inline_mesh && t < e->num_triangles; t++) {
            const trioct_triangle_t *tri = &e->triangles[t];
            const trioct_vec3_t *v[3] = {&tri->a, &tri->b, &tri->c};
            for (int k = 0; k < 3; k++)
                if (!isfinite(v[k]->x) || !isfinite(v[k]->y) || !isfinite(v[k]->z))
                    return edit_fail(j, i, TRIOCT_ERR_NONFINITE, "edits[%d] (%s): %s", e->name,
                                     "an inline triangle has a NaN or infinite coordinate");
        }
    }
    return TRIOCT_OK;
}

/* The adds' models, from files (shared with the objects already using a file, and between
 * adds of one file in this list) or inline triangles. */
static int load_models(job *j, const trioct_object_edit_request_t *m, object_edit *edits)
{
    for (int i = 0; i < m->num_edits; i++) {
        const trioct_object_edit_t *e = &m->edits[i];
        if (edits[i].kind != OBJECT_EDIT_ADD)
            continue;
        for (int k = 0; k < i && e->mesh[0] != '\0'; k++)
            if (edits[k].model && strcmp(m->edits[k].mesh, e->mesh) == 0) {
                edits[i].model = edits[k].model;
                object_model_retain(edits[i].model);
                break;
            }
        if (edits[i].model)
            continue;
        int status = TRIOCT_OK;
        char why[TRIOCT_MAX_MESSAGE_LEN];
        if (e->mesh[0] != '\0') {
            edits[i].model = world_model_from_file(j->w, j->ctx->world_dir, &j->ctx->env, e->mesh, &status, why, sizeof why);
        } else {
            size_t n = (size_t)e->num_triangles;
            vec3(*tris)[3] = dispatch_malloc(n * sizeof *tris);
            if (!tris)
                return edit_fail(j, i, TRIOCT_ERR_NOMEM, "edits[%d] (%s): %s", e->name, "out of memory");
            for (size_t t = 0; t < n; t++) {
                const trioct_triangle_t *tri = &e->triangles[t];
                tris[t][0] = (vec3){tri->a.x, tri->a.y, tri->a.z};
                tris[t][1] = (vec3){tri->b.x, tri->b.y, tri->b.z};
                tris[t][2] = (vec3){tri->c.x, tri->c.y, tri->c.z};
            }
            edits[i].model = world_model_from_triangles(j->w, &j->ctx->env, e->name, (const vec3(*)[3])tris, n, &status, why,
                                                        sizeof why);
            free(tris);
        }
        if (!edits[i].model)
            return edit_fail(j, i, status, "edits[%d] (%s): %s", e->name, why);
    }
    /* A solid's mesh must be closed; a model shared by several adds is checked once. */
    for (int i = 0; i < m->num_edits; i++) {
        int status = TRIOCT_OK;
        char why[TRIOCT_MAX_MESSAGE_LEN];
        const char *label = m->edits[i].mesh[0] != '\0' ? m->edits[i].mesh : "inline";
        if (edits[i].solid && world_model_check_solid(j->w, &j->ctx->env, edits[i].model, label, &status, why,
                                                      sizeof why) != 0)
            return edit_fail(j, i, status, "edits[%d] (%s): %s", m->edits[i].name, why);
    }
    return TRIOCT_OK;
}

/* Applies the list to the version served and installs the result in its place; on a lost
 * race, again on the version that won. */
static int apply_edits(job *j, const object_edit *edits, size_t count)
{
    for (int attempt = 0; attempt < DISPATCH_EDIT_RETRIES; attempt++) {
        int status = TRIOCT_OK;
        size_t failed = 0;
        char why[TRIOCT_MAX_MESSAGE_LEN];
        world *next = world_edit(j->w, edits, count, &status, &failed, why, sizeof why);
        if (!next) {
            j->failed_edit = failed == SIZE_MAX ? -1 : (int32_t)failed;
            return job_fail(j, status, "%s", why);
        }
        int rc = registry_replace(j->ctx->worlds, j->w, next);
        if (rc == 0) {
            world_release(j->w);
            j->w = next; /* the reply describes the version the edits made */
            world_retain(j->w);
            j->world_version = (int64_t)j->w->version;
            return TRIOCT_OK;
        }
        world_release(next);
        if (rc < 0)
            return job_fail(j, TRIOCT_ERR_UNKNOWN_WORLD, "world %s was unloaded while the edits were made",
                            j->w->spec.name);
        world *now = registry_acquire(j->ctx->worlds, j->w->spec.name);
        if (!now)
            return job_fail(j, TRIOCT_ERR_UNKNOWN_WORLD, "world %s was unloaded while the edits were made",
                            j->w->spec.name);
        world_release(j->w);
        j->w = now;
    }
    return job_fail(j, TRIOCT_ERR_BUSY, "world %s changed %d times while these edits were applied; try again",
                    j->w->spec.name, DISPATCH_EDIT_RETRIES);
}

/* The listing of a version's objects, in name order. */
static int list_objects(job *j, trioct_object_info_t **out, size_t *count)
{
    const object_set *s = j->w->objects;
    *out = NULL;
    *count = s->count;
    if (s->count == 0)
        return TRIOCT_OK;
    trioct_object_info_t *infos = dispatch_calloc(s->count, sizeof *infos);
    if (!infos)
        return job_fail(j, TRIOCT_ERR_NOMEM, "out of memory listing %zu objects", s->count);
    for (size_t i = 0; i < s->count; i++) {
        const world_object *o = &s->objects[i];
        int32_t shared = 0;
        for (size_t k = 0; k < s->count; k++)
            shared += s->objects[k].model == o->model;
        trioct_object_info_t *info = &infos[i];
        info->name = (char *)o->name;
        info->mesh = (char *)o->model->source;
        info->triangles = (int64_t)o->model->mesh.triangle_count;
        memcpy(info->pose.r, o->at.r, sizeof info->pose.r);
        info->pose.t = (trioct_vec3_t){o->at.t.x, o->at.t.y, o->at.t.z};
        info->bbox_min = (trioct_vec3_t){o->bounds.lo.x, o->bounds.lo.y, o->bounds.lo.z};
        info->bbox_max = (trioct_vec3_t){o->bounds.hi.x, o->bounds.hi.y, o->bounds.hi.z};
        info->bytes = (int64_t)o->model->bytes;
        info->shared = shared;
    }
    *out = infos;
    return TRIOCT_OK;
}

int dispatch_objects(job *j, const trioct_object_edit_request_t *m)
{
    j->failed_edit = -1;
    if (m->num_edits < 0 || m->num_edits > TRIOCT_MAX_EDITS)
        return job_fail(j, TRIOCT_ERR_OVER_CAP, "num_edits %d is over TRIOCT_MAX_EDITS=%d; split the list",
                        m->num_edits, TRIOCT_MAX_EDITS);
    size_t n = (size_t)m->num_edits;
    if (n > 0 && dispatch_authorize(j) != TRIOCT_OK)
        return j->status;
    object_edit *edits = dispatch_calloc(n, sizeof *edits);
    if (!edits)
        return job_fail(j, TRIOCT_ERR_NOMEM, "out of memory for %zu edits", n);
    int status = check_edits(j, m, edits);
    if (status == TRIOCT_OK)
        status = load_models(j, m, edits);
    if (status == TRIOCT_OK && n > 0)
        status = apply_edits(j, edits, n);
    for (size_t i = 0; i < n; i++)
        object_model_release(edits[i].model); /* the new version holds its own */
    free(edits);
    if (status != TRIOCT_OK)
        return status;

    trioct_object_info_t *infos = NULL;
    size_t count = 0;
    if (m->list && list_objects(j, &infos, &count) != TRIOCT_OK)
        return j->status;
    reply_head h = job_head(j, TRIOCT_OK, "ok");
    status = encode_object_reply(j->out, &h, -1, (int64_t)j->w->objects->count, (int64_t)j->w->objects->triangles,
                                 m->list ? infos : NULL, m->list ? count : 0);
    free(infos);
    if (status == TRIOCT_ERR_NOMEM)
        return job_fail(j, status, "out of memory encoding the reply");
    if (status != TRIOCT_OK)
        return job_fail(j, status, "the reply does not fit chunks of TRIOCT_MAX_CHUNK_BYTES=%d",
                        TRIOCT_MAX_CHUNK_BYTES);
    j->counted = 1;
    return TRIOCT_OK;
}
