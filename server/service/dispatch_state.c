/* Robot state checks (state_request_t): links, each a registered shape's tree or inline
 * triangles given a tree here, posed state after state and checked against the world's
 * objects and, when asked, each other, with the allowed pairs left out (object_state.h).
 * Every link, pair name and pose is checked before any work. */
#include <math.h>
#include <string.h>

#include "../../common/array_reserve.h"
#include "../world/object_state.h"
#include "dispatch_internal.h"

static int finite3(const trioct_vec3_t *v)
{
    return isfinite(v->x) && isfinite(v->y) && isfinite(v->z);
}

/* Pose k of the request (dispatch_wire_pose). */
static octree_status state_pose(const trioct_state_request_t *m, int k, pose *out)
{
    return dispatch_wire_pose(&m->poses[k],
                              m->rotation == TRIOCT_STATE_REQUEST_T_QUATERNION ? &m->quaternions[4 * k] : NULL, out);
}

static int check_state(job *j, const trioct_state_request_t *m)
{
    char q[48];
    if (m->detail != TRIOCT_STATE_REQUEST_T_VALID && m->detail != TRIOCT_STATE_REQUEST_T_CONTACTS)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "detail %d is not VALID (0) or CONTACTS (1)", m->detail);
    if (m->self_collision != 0 && m->self_collision != 1)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "self_collision %d is not 0 or 1", m->self_collision);
    if (m->num_links < 1 || m->num_links > STATE_MAX_LINKS)
        return job_fail(j, m->num_links < 1 ? TRIOCT_ERR_BAD_REQUEST : TRIOCT_ERR_OVER_CAP,
                        "num_links %d: a state has 1..%d links", m->num_links, STATE_MAX_LINKS);
    if (m->num_allowed > STATE_MAX_ALLOWED)
        return job_fail(j, TRIOCT_ERR_OVER_CAP, "num_allowed %d is over %d", m->num_allowed, STATE_MAX_ALLOWED);
    if (m->num_poses > TRIOCT_MAX_POSES)
        return job_fail(j, TRIOCT_ERR_OVER_CAP, "num_poses %d is over TRIOCT_MAX_POSES=%d; send fewer states",
                        m->num_poses, TRIOCT_MAX_POSES);
    if (m->rotation != TRIOCT_STATE_REQUEST_T_MATRIX && m->rotation != TRIOCT_STATE_REQUEST_T_QUATERNION)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "rotation %d is not MATRIX (0) or QUATERNION (1)", m->rotation);
    int quaternions = m->rotation == TRIOCT_STATE_REQUEST_T_QUATERNION;
    if (m->num_quaternions != (quaternions ? 4 * m->num_poses : 0))
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "num_quaternions %d: %s", m->num_quaternions,
                        quaternions ? "QUATERNION rotations are 4 numbers a pose" : "MATRIX rotations send none");
    if (m->num_poses % m->num_links != 0)
        return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "num_poses %d is not a whole number of states of %d links",
                        m->num_poses, m->num_links);
    int inline_total = 0;
    for (int i = 0; i < m->num_links; i++) {
        const trioct_state_link_t *l = &m->links[i];
        if (!object_name_valid(l->name))
            return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "links[%d].name \"%s\" is not 1..%d of [A-Za-z0-9_.-]", i,
                            dispatch_quote(l->name, q, sizeof q), TRIOCT_MAX_NAME_LEN);
        for (int k = 0; k < i; k++)
            if (strcmp(m->links[k].name, l->name) == 0)
                return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "links[%d] and links[%d] are both named %s", k, i,
                                l->name);
        int named = l->shape[0] != '\0';
        if (named && l->num_triangles != 0)
            return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "links[%d] (%s): both a shape and inline triangles", i,
                            l->name);
        if (named && !world_find_shape(j->w, l->shape))
            return job_fail(j, TRIOCT_ERR_UNKNOWN_SHAPE, "links[%d] (%s): world %s has no query shape \"%s\"", i,
                            l->name, j->w->spec.name, dispatch_quote(l->shape, q, sizeof q));
        if (!named && l->num_triangles < 1)
            return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "links[%d] (%s): no shape and no triangles", i, l->name);
        inline_total += l->num_triangles;
        if (inline_total > TRIOCT_MAX_INLINE_SHAPE_TRIANGLES)
            return job_fail(j, TRIOCT_ERR_OVER_CAP,
                            "the links' inline triangles are over TRIOCT_MAX_INLINE_SHAPE_TRIANGLES=%d; register "
                            "the shapes in the world's scene",
                            TRIOCT_MAX_INLINE_SHAPE_TRIANGLES);
        for (int t = 0; t < l->num_triangles; t++)
            if (!finite3(&l->triangles[t].a) || !finite3(&l->triangles[t].b) || !finite3(&l->triangles[t].c))
                return job_fail(j, TRIOCT_ERR_NONFINITE, "links[%d] (%s): triangle %d has a NaN or infinite coordinate",
                                i, l->name, t);
    }
    for (int i = 0; i < m->num_allowed; i++)
        if (!object_name_valid(m->allowed_a[i]) || !object_name_valid(m->allowed_b[i]))
            return job_fail(j, TRIOCT_ERR_BAD_REQUEST, "allowed pair %d names no link or object", i);
    for (int k = 0; k < m->num_poses; k++) {
        int state = k / m->num_links, link = k % m->num_links;
        pose at;
        int st = state_pose(m, k, &at);
        if (st == OCTREE_ERR_NONFINITE)
            return job_fail(j, TRIOCT_ERR_NONFINITE, "poses[%d] (state %d, link %s) has a NaN or infinite entry", k,
                            state, m->links[link].name);
        if (st != OCTREE_OK && quaternions)
            return job_fail(j, TRIOCT_ERR_BAD_POSE,
                            "poses[%d] (state %d, link %s): its quaternion's length is not 1 within 1e-3", k, state,
                            m->links[link].name);
        if (st != OCTREE_OK)
            return job_fail(j, TRIOCT_ERR_BAD_POSE,
                            "poses[%d] (state %d, link %s) is not a rotation: R^T R must be I within %g in every "
                            "entry and det(R) +1",
                            k, state, m->links[link].name, OCTREE_ROTATION_TOLERANCE);
    }
    return TRIOCT_OK;
}

/* A tree for an inline link, in the link's frame. */
static int inline_link(job *j, const trioct_state_link_t *l, int index, octree **tree, box3 *bounds)
{
    size_t n = (size_t)l->num_triangles;
    vec3 *v;
    uint32_t *ix;
    mesh_view view;
    if (dispatch_triangle_mesh(l->triangles, n, &v, &ix, &view) != 0)
        return job_fail(j, TRIOCT_ERR_NOMEM, "out of memory for links[%d]", index);
    *bounds = (box3){v[0], v[0]};
    for (size_t k = 1; k < 3 * n; k++) {
        bounds->lo = (vec3){fmin(bounds->lo.x, v[k].x), fmin(bounds->lo.y, v[k].y), fmin(bounds->lo.z, v[k].z)};
        bounds->hi = (vec3){fmax(bounds->hi.x, v[k].x), fmax(bounds->hi.y, v[k].y), fmax(bounds->hi.z, v[k].z)};
    }
    octree_def def = octree_default_def();
    def.node_bounds = 1;
    octree_error e;
    *tree = octree_build(&view, &def, &e);
    free(v);
    free(ix);
    if (*tree)
        return TRIOCT_OK;
    return e.status == OCTREE_ERR_NOMEM ? job_fail(j, TRIOCT_ERR_NOMEM, "out of memory for links[%d]'s tree", index)
                                        : job_fail(j, TRIOCT_ERR_BAD_REQUEST, "links[%d] (%s): %s", index, l->name,
                                                   e.message);
}

/* The reply's contacts and per-state arrays, in wire form. */
typedef struct state_answer {
    int32_t states;
    int32_t *found;
    size_t count, capacity;
    trioct_state_contact_t *contacts;
    int32_t object_count;
    char **objects;
} state_answer;

static void state_answer_free(state_answer *a)
{
    free(a->found);
    free(a->contacts);
    free(a->objects);
}

/* A state contact's object, or NULL when its other is a link. */
static int32_t *contact_object(void *records, size_t i)
{
    trioct_state_contact_t *c = &((trioct_state_contact_t *)records)[i];
    return c->with_link ? NULL : &c->other;
}

static int run_states(job *j, const trioct_state_request_t *m, state_link *links, const state_allowed *allowed,
                      state_answer *a)
{
    size_t n = (size_t)m->num_links;
    int all = m->detail == TRIOCT_STATE_REQUEST_T_CONTACTS;
    a->states = m->num_poses / m->num_links;
    a->found = dispatch_malloc((size_t)a->states * sizeof *a->found);
    state_contact *buf = dispatch_malloc((all ? TRIOCT_MAX_RESULTS : 1) * sizeof *buf);
    state_scratch *scratch = state_scratch_new();
    int status = TRIOCT_OK;
    if (!a->found || !buf || !scratch)
        status = job_fail(j, TRIOCT_ERR_NOMEM, "out of memory for the states");
    for (int32_t s = 0; s < a->states && status == TRIOCT_OK; s++) {
        for (size_t i = 0; i < n; i++)
            (void)state_pose(m, (int)((size_t)s * n + i), &links[i].at); /* checked before any work */
        size_t room = all ? TRIOCT_MAX_RESULTS - a->count : 1;
        state_output out = {.contacts = buf, .capacity = room};
        octree_status st = object_set_state(j->w->objects, links, n, allowed, (size_t)m->num_allowed, m->self_collision,
                                            all, &out, scratch, NULL);
        if (st != OCTREE_OK) {
            status = job_engine_error(j, st, "state", (size_t)s);
            break;
        }
        if (all && out.truncated) {
            status = job_fail(j, TRIOCT_ERR_OVER_CAP,
                              "the states have more than TRIOCT_MAX_RESULTS=%d contacts; send fewer states or ask "
                              "VALID",
                              TRIOCT_MAX_RESULTS);
            break;
        }
        size_t keep = out.count < room ? out.count : room;
        a->found[s] = (int32_t)keep;
        if (keep && array_reserve((void **)&a->contacts, &a->capacity, a->count + keep, sizeof *a->contacts, 64) != 0) {
            status = job_fail(j, TRIOCT_ERR_NOMEM, "out of memory for the contacts");
            break;
        }
        for (size_t k = 0; k < keep; k++)
            a->contacts[a->count++] = (trioct_state_contact_t){s,
                                                               (int32_t)buf[k].link,
                                                               (int8_t)buf[k].with_link,
                                                               (int32_t)buf[k].other,
                                                               (int32_t)buf[k].link_triangle,
                                                               (int32_t)buf[k].other_triangle};
    }
    free(buf);
    state_scratch_free(scratch);
    return status == TRIOCT_OK
               ? dispatch_name_objects(j, a->contacts, a->count, contact_object, &a->object_count, &a->objects)
               : status;
}

int dispatch_state(job *j, const trioct_state_request_t *m)
{
    if (check_state(j, m) != TRIOCT_OK)
        return j->status;
    size_t n = (size_t)m->num_links;
    state_link links[STATE_MAX_LINKS];
    octree *own[STATE_MAX_LINKS] = {0};
    int status = TRIOCT_OK;
    for (size_t i = 0; i < n && status == TRIOCT_OK; i++) {
        const trioct_state_link_t *l = &m->links[i];
        links[i] = (state_link){.name = l->name};
        if (l->shape[0] != '\0') {
            const world_shape *shape = world_find_shape(j->w, l->shape);
            links[i].tree = shape->model->tree;
            links[i].bounds = shape->model->bounds;
        } else {
            status = inline_link(j, l, (int)i, &own[i], &links[i].bounds);
            links[i].tree = own[i];
        }
    }
    state_allowed *allowed = dispatch_malloc((size_t)m->num_allowed * sizeof *allowed);
    if (status == TRIOCT_OK && !allowed)
        status = job_fail(j, TRIOCT_ERR_NOMEM, "out of memory for the allowed pairs");
    for (int i = 0; status == TRIOCT_OK && i < m->num_allowed; i++)
        allowed[i] = (state_allowed){m->allowed_a[i], m->allowed_b[i]};
    state_answer a = {0};
    if (status == TRIOCT_OK)
        status = run_states(j, m, links, allowed, &a);
    if (status == TRIOCT_OK) {
        reply_head h = job_head(j, TRIOCT_OK, "ok");
        status = encode_state_reply(j->out, &h, m->detail, a.states, a.found, a.object_count, a.objects,
                                    a.contacts, a.count);
        if (status == TRIOCT_ERR_NOMEM)
            job_fail(j, status, "out of memory encoding the reply");
        else if (status != TRIOCT_OK)
            job_fail(j, status, "the reply does not fit chunks of TRIOCT_MAX_CHUNK_BYTES=%d", TRIOCT_MAX_CHUNK_BYTES);
        else
            j->counted = 1;
    }
    state_answer_free(&a);
    free(allowed);
    for (size_t i = 0; i < n; i++)
        octree_free(own[i]);
    return status;
}
