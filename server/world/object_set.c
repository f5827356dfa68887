/* A world's objects: shared models, versioned tables of posed objects, and rays over them
 * (object_set.h). */
#include "object_set.h"

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../../common/array_reserve.h"
#include "../geom/box_geometry.h"
#include "../geom/vec3.h"
#include "error_text.h"

/* ---------- models ---------- */

object_model *object_model_create(const char *key, mesh_data *mesh, const octree_def *def, char *err,
                                  size_t err_len)
{
    if (!key || strlen(key) >= TRIOCT_MAX_PATH_LEN) {
        error_text(err, err_len, "model key missing or too long");
        return NULL;
    }
    if (mesh->triangle_count == 0) {
        error_text(err, err_len, "%s: the mesh has no triangles", key);
        return NULL;
    }
    mesh_view view = mesh_data_view(mesh);
    octree_error e;
    octree *tree = octree_build(&view, def, &e);
    if (!tree) {
        error_text(err, err_len, "%s: %s", key, e.message);
        return NULL;
    }
    object_model *m = object_model_adopt(key, mesh, tree);
    if (!m) {
        octree_free(tree);
        error_text(err, err_len, "%s: out of memory", key);
    }
    return m;
}

object_model *object_model_adopt(const char *key, mesh_data *mesh, octree *tree)
{
    object_model *m = key && strlen(key) < TRIOCT_MAX_PATH_LEN ? calloc(1, sizeof *m) : NULL;
    if (!m)
        return NULL;
    m->tree = tree;
    snprintf(m->key, sizeof m->key, "%s", key);
    snprintf(m->source, sizeof m->source, "%s", key);
    m->mesh = *mesh;
    *mesh = (mesh_data){0};
    m->bounds = mesh_data_bounds(&m->mesh);
    octree_info info;
    octree_get_info(m->tree, &info);
    m->bytes = info.bytes_total + m->mesh.vertex_count * sizeof(vec3) + 3 * m->mesh.triangle_count * sizeof(uint32_t);
    atomic_init(&m->closed, 0);
    atomic_init(&m->refs, 1);
    return m;
}

void object_model_retain(object_model *m)
{
    atomic_fetch_add(&m->refs, 1);
}

void object_model_release(object_model *m)
{
    if (!m || atomic_fetch_sub(&m->refs, 1) != 1)
        return;
    octree_free(m->tree);
    mesh_data_free(&m->mesh);
    if (m->account)
        memory_account_give(m->account, m->mesh_accounted);
    free(m);
}

/* ---------- sets ---------- */

object_set *object_set_create(void)
{
    object_set *s = calloc(1, sizeof *s);
    if (s)
        atomic_init(&s->refs, 1);
    return s;
}

void object_set_retain(object_set *s)
{
    atomic_fetch_add(&s->refs, 1);
}

void object_set_release(object_set *s)
{
    if (!s || atomic_fetch_sub(&s->refs, 1) != 1)
        return;
    for (size_t i = 0; i < s->count; i++)
        object_model_release(s->objects[i].model);
    free(s->objects);
    free(s->top);
    free(s->top_order);
    free(s);
}

/* The index of name in the sorted table, or where it would go (*found 0). */
static size_t find_slot(const world_object *objects, size_t count, const char *name, int *found)
{
    size_t lo = 0, hi = count;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        int c = strcmp(objects[mid].name, name);
        if (c == 0) {
            *found = 1;
            return mid;
        }
        if (c < 0)
            lo = mid + 1;
        else
            hi = mid;
    }
    *found = 0;
    return lo;
}

long object_set_find(const object_set *s, const char *name)
{
    int found;
    size_t i = find_slot(s->objects, s->count, name, &found);
    return found ? (long)i : -1;
}

int object_name_valid(const char *name)
{
    size_t n = name ? strlen(name) : 0;
    if (n == 0 || n > TRIOCT_MAX_NAME_LEN)
        return 0;
    for (size_t i = 0; i < n; i++) {
        char c = name[i];
        if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' ||
              c == '.'))
            return 0;
    }
    return 1;
}

static const char *edit_kind_text(object_edit_kind k)
{
    switch (k) {
    case OBJECT_EDIT_ADD:
        return "add";
    case OBJECT_EDIT_MOVE:
        return "move";
    case OBJECT_EDIT_REMOVE:
        return "remove";
    }
    return "edit";
}

/* A working copy's table: the edits change it in place; models are referenced only once
 * the whole list has applied. */
typedef struct table {
    world_object *items;
    size_t count, capacity;
} table;

static object_edit_status apply_one(table *t, const object_edit *e, char *err, size_t err_len, size_t index)
{
    const char *what = edit_kind_text(e->kind);
    if (!object_name_valid(e->name)) {
        error_text(err, err_len, "edits[%zu] (%s): object name '%s' is not 1-%d of [A-Za-z0-9_.-]", index, what,
                   e->name ? e->name : "", TRIOCT_MAX_NAME_LEN);
        return OBJECT_EDIT_BAD_NAME;
    }
    int found;
    size_t slot = find_slot(t->items, t->count, e->name, &found);
    if (e->kind == OBJECT_EDIT_ADD || e->kind == OBJECT_EDIT_MOVE) {
        octree_status ps = octree_pose_check(&e->at);
        if (ps != OCTREE_OK) {
            error_text(err, err_len, "edits[%zu] (%s %s): the pose %s", index, what, e->name,
                       ps == OCTREE_ERR_NONFINITE ? "has a NaN or infinite entry"
                                                  : "is not a rotation (orthonormal with det +1 within 1e-6)");
            return OBJECT_EDIT_BAD_POSE;
        }
    }
    /* Posing is monotone in each coordinate, so the posed corners of the model's box bound
     * every posed vertex and every partial sum: finite corners mean finite vertices. */
    const object_model *model = e->kind == OBJECT_EDIT_ADD ? e->model : found ? t->items[slot].model : NULL;
    if (model && e->kind != OBJECT_EDIT_REMOVE) {
        box3 posed = octree_pose_box(&e->at, model->bounds);
        if (!vec3_is_finite(posed.lo) || !vec3_is_finite(posed.hi)) {
            error_text(err, err_len, "edits[%zu] (%s %s): the pose places a vertex at a coordinate that is not finite",
                       index, what, e->name);
            return OBJECT_EDIT_BAD_POSE;
        }
    }
    switch (e->kind) {
    case OBJECT_EDIT_ADD:
        if (!e->model) {
            error_text(err, err_len, "edits[%zu] (add %s): no model", index, e->name);
            return OBJECT_EDIT_BAD_EDIT;
        }
        if (e->solid && !atomic_load(&e->model->closed)) {
            error_text(err, err_len, "edits[%zu] (add %s): a solid object needs a mesh checked closed", index, e->name);
            return OBJECT_EDIT_BAD_EDIT;
        }
        if (found) {
            error_text(err, err_len, "edits[%zu] (add %s): the world already has an object of that name", index, e->name);
            return OBJECT_EDIT_EXISTS;
        }
        if (t->count >= OBJECT_SET_MAX_OBJECTS) {
            error_text(err, err_len, "edits[%zu] (add %s): a world holds at most %d objects", index, e->name,
                       OBJECT_SET_MAX_OBJECTS);
            return OBJECT_EDIT_TOO_MANY;
        }
        if (array_reserve((void **)&t->items, &t->capacity, t->count + 1, sizeof *t->items, 8) != 0) {
            error_text(err, err_len, "edits[%zu] (add %s): out of memory", index, e->name);
            return OBJECT_EDIT_NOMEM;
        }
        memmove(&t->items[slot + 1], &t->items[slot], (t->count - slot) * sizeof *t->items);
        t->count++;
        world_object *o = &t->items[slot];
        memset(o, 0, sizeof *o);
        snprintf(o->name, sizeof o->name, "%s", e->name);
        o->model = e->model;
        o->at = e->at;
        o->bounds = octree_pose_box(&e->at, e->model->bounds);
        o->solid = e->solid != 0;
        return OBJECT_EDIT_OK;
    case OBJECT_EDIT_MOVE:
        if (!found) {
            error_text(err, err_len, "edits[%zu] (move %s): the world has no object of that name", index, e->name);
            return OBJECT_EDIT_UNKNOWN;
        }
        t->items[slot].at = e->at;
        t->items[slot].bounds = octree_pose_box(&e->at, t->items[slot].model->bounds);
        return OBJECT_EDIT_OK;
    case OBJECT_EDIT_REMOVE:
        if (!found) {
            error_text(err, err_len, "edits[%zu] (remove %s): the world has no object of that name", index, e->name);
            return OBJECT_EDIT_UNKNOWN;
        }
        memmove(&t->items[slot], &t->items[slot + 1], (t->count - slot - 1) * sizeof *t->items);
        t->count--;
        return OBJECT_EDIT_OK;
    }
    error_text(err, err_len, "edits[%zu]: unknown kind %d", index, (int)e->kind);
    return OBJECT_EDIT_BAD_EDIT;
}

/* ---------- the hierarchy over the objects' boxes ---------- */

/* Objects a leaf holds at most: a leaf's boxes are tested one by one. */
#define TOP_LEAF_OBJECTS 2

static box3 box_union(box3 a, box3 b)
{
    return (box3){vec3_min(a.lo, b.lo), vec3_max(a.hi, b.hi)};
}

static double centre_on(const world_object *o, int axis)
{
    const double *lo = &o->bounds.lo.x, *hi = &o->bounds.hi.x;
    return 0.5 * lo[axis] + 0.5 * hi[axis];
}

typedef struct centre_key {
    double c;
    uint32_t i;
} centre_key;

static int key_less(centre_key x, centre_key y)
{
    return x.c < y.c || (x.c == y.c && x.i < y.i);
}

/* Puts the k-th smallest key (by centre, then object index: a total order, so the split
 * does not depend on the order the objects came in) at keys[k], smaller ones before it and
 * larger after: quickselect with a median-of-three pivot, O(n) expected. */
static void select_kth(centre_key *keys, size_t n, size_t k)
{
    size_t lo = 0, hi = n - 1;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (key_less(keys[mid], keys[lo])) {
            centre_key t = keys[mid]; keys[mid] = keys[lo]; keys[lo] = t;
        }
        if (key_less(keys[hi], keys[lo])) {
            centre_key t = keys[hi]; keys[hi] = keys[lo]; keys[lo] = t;
        }
        if (key_less(keys[hi], keys[mid])) {
            centre_key t = keys[hi]; keys[hi] = keys[mid]; keys[mid] = t;
        }
        centre_key pivot = keys[mid];
        size_t i = lo, j = hi;
        while (i <= j) {
            while (key_less(keys[i], pivot))
                i++;
            while (key_less(pivot, keys[j]))
                j--;
            if (i <= j) {
                centre_key t = keys[i]; keys[i] = keys[j]; keys[j] = t;
                i++;
                if (j == 0)
                    break;
                j--;
            }
        }
        if (k <= j)
            hi = j;
        else if (k >= i)
            lo = i;
        else
            return;
    }
}

/* Splits order[0, n) at its middle by box centre on axis: the n/2 smallest first. keys has
 * room for n. */
static void split_on_axis(const world_object *objects, uint32_t *order, size_t n, int axis, centre_key *keys)
{
    for (size_t k = 0; k < n; k++)
        keys[k] = (centre_key){centre_on(&objects[order[k]], axis), order[k]};
    select_kth(keys, n, n / 2);
    for (size_t k = 0; k < n; k++)
        order[k] = keys[k].i;
}

/* Builds the subtree of order[lo, hi) at node `at`; next is the next free node. */
static void build_top(object_set *s, uint32_t at, uint32_t lo, uint32_t hi, uint32_t *next, centre_key *keys)
{
    object_top_node *node = &s->top[at];
    box3 b = s->objects[s->top_order[lo]].bounds;
    for (uint32_t i = lo + 1; i < hi; i++)
        b = box_union(b, s->objects[s->top_order[i]].bounds);
    node->box = b;
    if (hi - lo <= TOP_LEAF_OBJECTS) {
        node->first = lo;
        node->count = hi - lo;
        return;
    }
    vec3 extent = vec3_sub(b.hi, b.lo);
    int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : extent.y >= extent.z ? 1 : 2;
    split_on_axis(s->objects, &s->top_order[lo], hi - lo, axis, keys);
    uint32_t mid = lo + (hi - lo) / 2;
    uint32_t left = *next;
    *next += 2;
    node->first = left;
    node->count = 0;
    build_top(s, left, lo, mid, next, keys);
    build_top(s, left + 1, mid, hi, next, keys);
}

/* 0, or -1 when out of memory (the set then has no hierarchy and must not be used). */
static int make_top(object_set *s)
{
    s->top = NULL;
    s->top_order = NULL;
    if (s->count == 0)
        return 0;
    s->top = malloc((2 * s->count) * sizeof *s->top);
    s->top_order = malloc(s->count * sizeof *s->top_order);
    centre_key *keys = malloc(s->count * sizeof *keys);
    if (!s->top || !s->top_order || !keys) {
        free(keys);
        return -1;
    }
    for (size_t i = 0; i < s->count; i++)
        s->top_order[i] = (uint32_t)i;
    uint32_t next = 1;
    build_top(s, 0, 0, (uint32_t)s->count, &next, keys);
    free(keys);
    return 0;
}

static int by_index(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

size_t object_set_near(const object_set *s, box3 b, uint32_t *out)
{
    if (s->count == 0)
        return 0;
    uint32_t stack[64];
    size_t depth = 0, n = 0;
    stack[depth++] = 0;
    while (depth > 0) {
        const object_top_node *node = &s->top[stack[--depth]];
        if (boxes_apart(b, node->box)) /* closed boxes apart: nothing below meets b */
            continue;
        if (node->count == 0) {
            stack[depth++] = node->first;
            stack[depth++] = node->first + 1;
            continue;
        }
        for (uint32_t k = 0; k < node->count; k++) {
            uint32_t i = s->top_order[node->first + k];
            if (!boxes_apart(b, s->objects[i].bounds))
                out[n++] = i;
        }
    }
    qsort(out, n, sizeof *out, by_index);
    return n;
}

object_edit_status object_set_apply(const object_set *from, const object_edit *edits, size_t count,
                                    object_set **out, size_t *failed, char *err, size_t err_len)
{
    *out = NULL;
    if (failed)
        *failed = 0;
    table t = {0};
    if (from->count &&
        array_reserve((void **)&t.items, &t.capacity, from->count, sizeof *t.items, 8) != 0) {
        error_text(err, err_len, "out of memory");
        return OBJECT_EDIT_NOMEM;
    }
    if (from->count)
        memcpy(t.items, from->objects, from->count * sizeof *t.items);
    t.count = from->count;
    for (size_t i = 0; i < count; i++) {
        object_edit_status st = apply_one(&t, &edits[i], err, err_len, i);
        if (st != OBJECT_EDIT_OK) {
            free(t.items);
            if (failed)
                *failed = i;
            return st;
        }
    }
    object_set *s = calloc(1, sizeof *s);
    if (!s) {
        free(t.items);
        error_text(err, err_len, "out of memory");
        return OBJECT_EDIT_NOMEM;
    }
    s->objects = t.items;
    s->count = t.count;
    s->version = from->version + 1;
    if (make_top(s) != 0) {
        free(s->top);
        free(s->top_order);
        free(s->objects);
        free(s);
        error_text(err, err_len, "out of memory");
        return OBJECT_EDIT_NOMEM;
    }
    for (size_t i = 0; i < s->count; i++) {
        object_model_retain(s->objects[i].model);
        s->triangles += s->objects[i].model->mesh.triangle_count;
        s->solids += s->objects[i].solid != 0;
    }
    atomic_init(&s->refs, 1);
    *out = s;
    return OBJECT_EDIT_OK;
}

/* ---------- rays ---------- */

/* An object the ray may reach, with the least t at which it can. */
typedef struct ray_candidate {
    double t0;
    uint32_t object;
} ray_candidate;

static int by_entry(const void *a, const void *b)
{
    const ray_candidate *x = a, *y = b;
    if (x->t0 != y->t0)
        return x->t0 < y->t0 ? -1 : 1;
    return (x->object > y->object) - (x->object < y->object);
}

static void posed_triangle(const world_object *o, uint32_t triangle, vec3 out[3])
{
    for (int k = 0; k < 3; k++)
        out[k] = octree_pose_point(&o->at, mesh_data_corner(&o->model->mesh, triangle, k));
}

/* The objects whose posed boxes the ray meets within [tmin, tmax], each with the least t
 * at which it can: through the hierarchy, whose node boxes hold their objects' boxes, so
 * a node the ray misses holds no object it meets (the slab interval only widens as a box
 * grows: every step of it is monotone in the box's bounds). */
static size_t ray_candidates(const object_set *s, const ray_input *ray, ray_candidate *cand, size_t cap)
{
    uint32_t stack[64];
    size_t depth = 0, n = 0;
    stack[depth++] = 0;
    while (depth > 0) {
        const object_top_node *node = &s->top[stack[--depth]];
        double t0, t1;
        if (!octree_ray_box_interval(ray->origin, ray->direction, node->box, &t0, &t1) || t1 < ray->tmin ||
            t0 > ray->tmax)
            continue;
        if (node->count == 0) {
            stack[depth++] = node->first;
            stack[depth++] = node->first + 1;
            continue;
        }
        for (uint32_t k = 0; k < node->count; k++) {
            uint32_t i = s->top_order[node->first + k];
            if (!octree_ray_box_interval(ray->origin, ray->direction, s->objects[i].bounds, &t0, &t1))
                continue;
            if (t1 < ray->tmin || t0 > ray->tmax)
                continue;
            if (n == cap)
                return SIZE_MAX; /* more than the caller's room: it asks again with more */
            cand[n++] = (ray_candidate){t0 > ray->tmin ? t0 : ray->tmin, i};
        }
    }
    return n;
}

/* Order of two hits of one ray: exact t, then object, then triangle. */
static int object_hit_order(const object_set *s, const ray_input *ray, const object_hit *a, const object_hit *b)
{
    if (a->object != b->object || a->hit.triangle != b->hit.triangle) {
        vec3 ta[3], tb[3];
        posed_triangle(&s->objects[a->object], a->hit.triangle, ta);
        posed_triangle(&s->objects[b->object], b->hit.triangle, tb);
        int c = octree_ray_hit_order(ray, ta, tb);
        if (c != 0)
            return c;
    }
    if (a->object != b->object)
        return a->object < b->object ? -1 : 1;
    return (a->hit.triangle > b->hit.triangle) - (a->hit.triangle < b->hit.triangle);
}

/* A t at or above the exact t of a hit reported at t (reported within a few ulps). */
static double t_upper(double t)
{
    return t + fabs(t) * 0x1p-40 + DBL_MIN;
}

static void sort_object_hits(const object_set *s, const ray_input *ray, object_hit *h, object_hit *tmp, size_t n)
{
    if (n < 2)
        return;
    size_t half = n / 2;
    sort_object_hits(s, ray, h, tmp, half);
    sort_object_hits(s, ray, h + half, tmp, n - half);
    size_t i = 0, j = half, k = 0;
    while (i < half && j < n)
        tmp[k++] = object_hit_order(s, ray, &h[j], &h[i]) < 0 ? h[j++] : h[i++];
    while (i < half)
        tmp[k++] = h[i++];
    while (j < n)
        tmp[k++] = h[j++];
    memcpy(h, tmp, n * sizeof *h);
}

octree_status object_set_ray(const object_set *s, const ray_input *ray, ray_detail detail,
                             object_ray_output *out, query_stats *stats)
{
    if (!s || !ray || !out)
        return OCTREE_ERR_INVALID;
    out->hit_count = 0;
    out->truncated = 0;
    /* The engine's own checks, so that a world with no object refuses what one with
     * objects would. */
    octree_status checked = octree_ray_check(ray, detail, ACCURACY_EXACT);
    if (checked != OCTREE_OK)
        return checked;
    if (s->count == 0)
        return OCTREE_OK;

    /* A ray meets a few objects' boxes: room for 64 on the stack, and when it meets more,
     * room for them all on the heap. */
    ray_candidate local[64];
    ray_candidate *cand = local;
    size_t n = ray_candidates(s, ray, cand, sizeof local / sizeof local[0]);
    if (n == SIZE_MAX) {
        cand = malloc(s->count * sizeof *cand);
        if (!cand)
            return OCTREE_ERR_NOMEM;
        n = ray_candidates(s, ray, cand, s->count);
    }
    qsort(cand, n, sizeof *cand, by_entry);

    octree_status st = OCTREE_OK;
    if (detail != RAY_ALL) {
        int have = 0;
        object_hit best = {0};
        for (size_t k = 0; k < n; k++) {
            /* Objects come in order of where the ray can first reach them: once that is
             * past the best hit, no later one holds a nearer hit. */
            if (have && cand[k].t0 > t_upper(best.hit.t))
                break;
            const world_object *o = &s->objects[cand[k].object];
            ray_hit h;
            ray_output one = {.hits = &h, .max_hits = 1};
            st = octree_ray_posed(o->model->tree, &o->at, ray, detail, ACCURACY_EXACT, &one, stats);
            if (st != OCTREE_OK)
                break;
            if (one.hit_count == 0)
                continue;
            object_hit found = {h, cand[k].object};
            if (!have || object_hit_order(s, ray, &found, &best) < 0) {
                best = found;
                have = 1;
            }
            if (detail == RAY_ANY)
                break;
        }
        if (st == OCTREE_OK && have) {
            out->hit_count = 1;
            if (out->max_hits > 0)
                out->hits[0] = best;
            else
                out->truncated = 1;
        }
        if (cand != local)
            free(cand);
        return st;
    }

    /* Every hit: each object's own first max_hits (the first max_hits of the union are
     * among them), merged in order. */
    size_t cap = out->max_hits, held = 0, total = 0, room = 0;
    object_hit *all = NULL;
    ray_hit *buf = malloc((cap ? cap : 1) * sizeof *buf);
    if (!buf) {
        if (cand != local)
            free(cand);
        return OCTREE_ERR_NOMEM;
    }
    for (size_t k = 0; k < n && st == OCTREE_OK; k++) {
        const world_object *o = &s->objects[cand[k].object];
        ray_output part = {.hits = buf, .max_hits = cap};
        st = octree_ray_posed(o->model->tree, &o->at, ray, RAY_ALL, ACCURACY_EXACT, &part, stats);
        if (st != OCTREE_OK)
            break;
        total += part.hit_count;
        size_t keep = part.hit_count < cap ? part.hit_count : cap;
        if (keep && array_reserve((void **)&all, &room, held + keep, sizeof *all, 16) != 0) {
            st = OCTREE_ERR_NOMEM;
            break;
        }
        for (size_t i = 0; i < keep; i++)
            all[held++] = (object_hit){buf[i], cand[k].object};
    }
    if (st == OCTREE_OK && held > 1) {
        object_hit *tmp = malloc(held * sizeof *tmp);
        if (!tmp)
            st = OCTREE_ERR_NOMEM;
        else
            sort_object_hits(s, ray, all, tmp, held);
        free(tmp);
    }
    if (st == OCTREE_OK) {
        out->hit_count = total;
        size_t keep = held < cap ? held : cap;
        out->truncated = keep < total;
        if (keep)
            memcpy(out->hits, all, keep * sizeof *all);
    }
    free(all);
    free(buf);
    if (cand != local)
        free(cand);
    return st;
}

/* ---------- triangles ---------- */

octree_status object_set_triangle(const object_set *s, const vec3 tri[3], tri_detail detail,
                                  object_tri_output *out, query_stats *stats)
{
    if (!s || !tri || !out || (detail != TRI_YESNO && detail != TRI_IDS && detail != TRI_SEGMENTS))
        return OCTREE_ERR_INVALID;
    out->hit = 0;
    out->count = 0;
    out->truncated = 0;
    for (int k = 0; k < 3; k++)
        if (!vec3_is_finite(tri[k]))
            return OCTREE_ERR_NONFINITE;
    box3 qb = {vec3_min(vec3_min(tri[0], tri[1]), tri[2]), vec3_max(vec3_max(tri[0], tri[1]), tri[2])};
    size_t stored = 0;
    tri_contact *buf = NULL;
    size_t buf_cap = 0;
    octree_status st = OCTREE_OK;
    /* In object order, each object's contacts sorted by triangle: the union's order. Only
     * objects whose closed boxes meet the triangle's can share a point with it. */
    uint32_t *near = s->count ? malloc(s->count * sizeof *near) : NULL;
    if (s->count && !near)
        return OCTREE_ERR_NOMEM;
    size_t near_count = object_set_near(s, qb, near);
    for (size_t ni = 0; ni < near_count; ni++) {
        size_t i = near[ni];
        const world_object *o = &s->objects[i];
        size_t room = detail == TRI_YESNO ? 0 : (out->capacity > stored ? out->capacity - stored : 0);
        if (room > buf_cap) {
            free(buf);
            buf = malloc(room * sizeof *buf);
            buf_cap = buf ? room : 0;
            if (!buf) {
                st = OCTREE_ERR_NOMEM;
                break;
            }
        }
        tri_output part = {.contacts = buf, .capacity = room};
        st = octree_triangle_posed(o->model->tree, &o->at, tri, detail, ACCURACY_EXACT, &part, stats);
        if (st != OCTREE_OK)
            break;
        if (!part.hit && o->solid) {
            /* Off the surface the triangle is wholly on one side of it. */
            point_side side;
            st = octree_point_side_posed(o->model->tree, &o->at, tri[0], &side, stats);
            if (st != OCTREE_OK)
                break;
            if (side == POINT_INSIDE) {
                part.hit = 1;
                part.count = 1;
                if (room > 0)
                    buf[0] = (tri_contact){OBJECT_INTERIOR, tri[0], tri[0]};
            }
        }
        if (!part.hit)
            continue;
        out->hit = 1;
        if (detail == TRI_YESNO)
            break;
        size_t keep = part.count < room ? part.count : room;
        for (size_t j = 0; j < keep; j++)
            out->contacts[stored++] = (object_contact){buf[j], (uint32_t)i};
        out->count += part.count;
    }
    out->truncated = out->count > stored;
    free(buf);
    free(near);
    return st;
}
