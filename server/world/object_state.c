/* Robot state checks over a world's objects (object_state.h). */
#include "object_state.h"

#include <stdlib.h>
#include <string.h>

#include "../../common/array_reserve.h"
#include "../geom/box_geometry.h"

/* Link trees a scratch keeps a shape scratch for; past this the oldest is replaced. */
#define STATE_SCRATCH_TREES 64

struct state_scratch {
    const octree *tree[STATE_SCRATCH_TREES];
    octree_shape_scratch *shape[STATE_SCRATCH_TREES];
    size_t count, next;
};

state_scratch *state_scratch_new(void)
{
    return calloc(1, sizeof(state_scratch));
}

void state_scratch_free(state_scratch *x)
{
    if (!x)
        return;
    for (size_t i = 0; i < x->count; i++)
        octree_shape_scratch_free(x->shape[i]);
    free(x);
}

/* The shape scratch for tree, made on first need; NULL when out of memory. */
static octree_shape_scratch *scratch_for(state_scratch *x, const octree *tree)
{
    for (size_t i = 0; i < x->count; i++)
        if (x->tree[i] == tree)
            return x->shape[i];
    octree_shape_scratch *made = octree_shape_scratch_new(tree);
    if (!made)
        return NULL;
    size_t slot = x->count < STATE_SCRATCH_TREES ? x->count++ : x->next++ % STATE_SCRATCH_TREES;
    if (x->tree[slot])
        octree_shape_scratch_free(x->shape[slot]);
    x->tree[slot] = tree;
    x->shape[slot] = made;
    return made;
}

static int names_pair(const state_allowed *p, const char *x, const char *y)
{
    return (strcmp(p->a, x) == 0 && strcmp(p->b, y) == 0) || (strcmp(p->a, y) == 0 && strcmp(p->b, x) == 0);
}

octree_status state_links_check(const state_link *links, size_t link_count, const state_allowed *allowed,
                                size_t allowed_count)
{
    if ((link_count && !links) || (allowed_count && !allowed) || link_count > STATE_MAX_LINKS ||
        allowed_count > STATE_MAX_ALLOWED)
        return OCTREE_ERR_INVALID;
    for (size_t i = 0; i < link_count; i++) {
        if (!links[i].tree || !links[i].name)
            return OCTREE_ERR_INVALID;
        octree_status ps = octree_pose_check(&links[i].at);
        if (ps != OCTREE_OK)
            return ps;
    }
    for (size_t i = 0; i < allowed_count; i++)
        if (!allowed[i].a || !allowed[i].b)
            return OCTREE_ERR_INVALID;
    return OCTREE_OK;
}

int state_pair_allowed(const state_allowed *allowed, size_t count, const char *x, const char *y)
{
    for (size_t i = 0; i < count; i++)
        if (names_pair(&allowed[i], x, y))
            return 1;
    return 0;
}

/* The pairs one tree pair found, appended in their order (by link triangle, then the
 * other's); 1 when the check is over (first contact, or out of memory in *st). */
typedef struct state_run {
    state_scratch *scratch;
    state_output *out;
    int all;
    mesh_pair *pairs;
    size_t pairs_cap;
    octree_status st;
    query_stats *stats;
} state_run;

/* For a link touching no triangle of a solid object: whether a part of it lies inside, by
 * one vertex of each connected part (octree_component_points) placed by the link's pose;
 * 1 with *triangle a triangle of that part. */
static int link_inside(state_run *run, const octree *other, const pose *other_at, const state_link *link,
                       uint32_t *triangle);

octree_status object_set_link_inside(const object_set *s, const state_link *link, long *object, uint32_t *triangle,
                                     query_stats *stats)
{
    *object = -1;
    if (s->solids == 0 || s->count == 0)
        return OCTREE_OK;
    uint32_t *near = malloc(s->count * sizeof *near);
    if (!near)
        return OCTREE_ERR_NOMEM;
    state_run run = {NULL, NULL, 0, NULL, 0, OCTREE_OK, stats};
    size_t n = object_set_near(s, octree_pose_box(&link->at, link->bounds), near);
    for (size_t k = 0; k < n && *object < 0 && run.st == OCTREE_OK; k++) {
        const world_object *o = &s->objects[near[k]];
        if (o->solid && link_inside(&run, o->model->tree, &o->at, link, triangle))
            *object = near[k];
    }
    free(near);
    return run.st;
}

static int link_inside(state_run *run, const octree *other, const pose *other_at, const state_link *link,
                       uint32_t *triangle)
{
    enum { ROOM = 16 };
    vec3 local_points[ROOM];
    uint32_t local_ids[ROOM];
    vec3 *points = local_points;
    uint32_t *ids = local_ids;
    size_t n = octree_component_points(link->tree, points, ids, ROOM);
    if (n != SIZE_MAX && n > ROOM) {
        points = malloc(n * sizeof *points);
        ids = malloc(n * sizeof *ids);
        if (points && ids)
            n = octree_component_points(link->tree, points, ids, n);
        else
            n = SIZE_MAX;
    }
    int inside = 0;
    if (n == SIZE_MAX)
        run->st = OCTREE_ERR_NOMEM;
    for (size_t k = 0; k < n && n != SIZE_MAX && !inside && run->st == OCTREE_OK; k++) {
        point_side side;
        run->st = octree_point_side_posed(other, other_at, octree_pose_point(&link->at, points[k]), &side, run->stats);
        if (run->st == OCTREE_OK && side == POINT_INSIDE) {
            inside = 1;
            *triangle = ids[k];
        }
    }
    if (points != local_points)
        free(points);
    if (ids != local_ids)
        free(ids);
    return inside;
}

/* solid: the other is a solid object, whose inside counts as contact. */
static int test_pair(state_run *run, const octree *other, const pose *other_at, const state_link *link,
                     uint32_t link_index, int with_link, uint32_t other_index, int solid)
{
    mesh_pair first[1];
    mesh_output m = run->all ? (mesh_output){.pairs = run->pairs, .capacity = run->pairs_cap}
                             : (mesh_output){.pairs = first, .capacity = 1};
    /* The link is the shape side: pairs come as (link triangle, other triangle). */
    octree_shape_scratch *x = scratch_for(run->scratch, link->tree);
    if (!x) {
        run->st = OCTREE_ERR_NOMEM;
        return 1;
    }
    run->st = octree_mesh_tree_posed_with(x, other, other_at, &link->at, run->all, &m, run->stats);
    if (run->st == OCTREE_OK && run->all && m.truncated) {
        mesh_pair *more = realloc(run->pairs, m.count * sizeof *more);
        if (!more) {
            run->st = OCTREE_ERR_NOMEM;
            return 1;
        }
        run->pairs = more;
        run->pairs_cap = m.count;
        m = (mesh_output){.pairs = run->pairs, .capacity = run->pairs_cap};
        run->st = octree_mesh_tree_posed_with(x, other, other_at, &link->at, 1, &m, run->stats);
    }
    if (run->st != OCTREE_OK)
        return 1;
    if (!m.hit && solid) {
        uint32_t triangle;
        int inside = link_inside(run, other, other_at, link, &triangle);
        if (run->st != OCTREE_OK)
            return 1;
        if (inside) {
            /* One contact through no triangle of the object: the link is inside it. */
            state_output *out = run->out;
            out->valid = 0;
            if (out->count < out->capacity)
                out->contacts[out->count] = (state_contact){link_index, 0, other_index, triangle, OBJECT_INTERIOR};
            out->count++;
            if (!run->all) {
                out->truncated = out->capacity == 0;
                return 1;
            }
        }
        return 0;
    }
    if (!m.hit)
        return 0;
    state_output *out = run->out;
    out->valid = 0;
    if (!run->all) { /* yes/no gave the first pair the descent met */
        if (out->capacity > 0 && m.count > 0)
            out->contacts[0] = (state_contact){link_index, with_link, other_index, first[0].query_triangle,
                                               first[0].world_triangle};
        out->count = 1;
        out->truncated = out->capacity == 0;
        return 1;
    }
    for (size_t k = 0; k < m.count; k++) {
        if (out->count < out->capacity)
            out->contacts[out->count] = (state_contact){link_index, with_link, other_index, run->pairs[k].query_triangle,
                                                        run->pairs[k].world_triangle};
        out->count++;
    }
    return 0;
}

octree_status object_set_state(const object_set *s, const state_link *links, size_t link_count,
                               const state_allowed *allowed, size_t allowed_count, int self_collision,
                               int all_contacts, state_output *out, state_scratch *scratch, query_stats *stats)
{
    if (!s || !out)
        return OCTREE_ERR_INVALID;
    out->valid = 1;
    out->count = 0;
    out->truncated = 0;
    octree_status checked = state_links_check(links, link_count, allowed, allowed_count);
    if (checked != OCTREE_OK)
        return checked;
    box3 link_boxes[STATE_MAX_LINKS];
    for (size_t i = 0; i < link_count; i++)
        link_boxes[i] = octree_pose_box(&links[i].at, links[i].bounds);
    state_scratch *own = NULL;
    if (!scratch && !(scratch = own = state_scratch_new()))
        return OCTREE_ERR_NOMEM;
    state_run run = {scratch, out, all_contacts, NULL, 0, OCTREE_OK, stats};
    if (all_contacts) {
        run.pairs_cap = 64;
        run.pairs = malloc(run.pairs_cap * sizeof *run.pairs);
        if (!run.pairs) {
            state_scratch_free(own);
            return OCTREE_ERR_NOMEM;
        }
    }
    uint32_t *near = s->count ? malloc(s->count * sizeof *near) : NULL;
    if (s->count && !near) {
        free(run.pairs);
        state_scratch_free(own);
        return OCTREE_ERR_NOMEM;
    }
    int over = 0;
    for (size_t i = 0; i < link_count && !over; i++) {
        const state_link *l = &links[i];
        /* The objects whose boxes meet the link's, in object order, from the hierarchy. */
        size_t near_count = object_set_near(s, link_boxes[i], near);
        for (size_t nj = 0; nj < near_count && !over; nj++) {
            size_t j = near[nj];
            const world_object *o = &s->objects[j];
            if (state_pair_allowed(allowed, allowed_count, l->name, o->name))
                continue;
            over = test_pair(&run, o->model->tree, &o->at, l, (uint32_t)i, 0, (uint32_t)j, o->solid);
        }
        for (size_t j = i + 1; self_collision && j < link_count && !over; j++) {
            if (boxes_apart(link_boxes[i], link_boxes[j]) || state_pair_allowed(allowed, allowed_count, l->name, links[j].name))
                continue;
            over = test_pair(&run, links[j].tree, &links[j].at, l, (uint32_t)i, 1, (uint32_t)j, 0);
        }
    }
    if (all_contacts)
        out->truncated = out->count > out->capacity;
    free(near);
    free(run.pairs);
    state_scratch_free(own);
    return run.st;
}
