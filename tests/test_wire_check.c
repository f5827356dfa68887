/* Tests of the wire validator against the generated LCM code: every message the generated
 * encoder writes is accepted, every damaged one (cut short, extended, foreign fingerprint,
 * bad count, bad string) is rejected at the right byte, and under random mutation whatever
 * the validator accepts the generated decoder reads back to the very same bytes. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <lcm/eventlog.h>

#include "support/meshgen.h"
#include "wire_check.h"

#include "trioct_admin_reply_t.h"
#include "trioct_admin_request_t.h"
#include "trioct_distance_reply_t.h"
#include "trioct_distance_request_t.h"
#include "trioct_mesh_reply_t.h"
#include "trioct_mesh_request_t.h"
#include "trioct_object_edit_request_t.h"
#include "trioct_object_reply_t.h"
#include "trioct_state_reply_t.h"
#include "trioct_state_request_t.h"
#include "trioct_ray_reply_t.h"
#include "trioct_ray_request_t.h"
#include "trioct_ray_request_v1_t.h"
#include "trioct_status_t.h"
#include "trioct_triangle_reply_t.h"
#include "trioct_triangle_request_t.h"

/* The seed of the randomised tests: fixed, or TRIOCT_SEED to rerun another. */
static uint64_t test_seed(void)
{
    const char *env = getenv("TRIOCT_SEED");
    return env ? strtoull(env, NULL, 0) : 0x5eed2024ull;
}

/* ---------- random messages built with the generated types ---------- */

/* EMPTY: every count 0, every string "". SMALLEST: counts above 0 but every string "", so
 * each array element is as short as it can be. RANDOM: anything, including 0 and "". */
typedef enum variant { VARIANT_EMPTY, VARIANT_SMALLEST, VARIANT_RANDOM } variant;

static int32_t pick_count(rng *r, variant v)
{
    if (v == VARIANT_EMPTY)
        return 0;
    if (v == VARIANT_SMALLEST)
        return 1 + (int32_t)(rng_next(r) % 4);
    return (int32_t)(rng_next(r) % 6);
}

/* Any bytes but NUL; now and then long enough that the length needs two bytes. */
static char *random_text(rng *r, variant v)
{
    size_t length = 0;
    if (v == VARIANT_RANDOM) {
        uint64_t roll = rng_next(r) % 8;
        length = roll < 2 ? 0 : roll == 7 ? 200 + rng_next(r) % 201 : 1 + rng_next(r) % 12;
    }
    char *s = malloc(length + 1);
    assert_non_null(s);
    for (size_t i = 0; i < length; i++)
        s[i] = (char)(1 + rng_next(r) % 255);
    s[length] = '\0';
    return s;
}

/* NaN, infinities and arbitrary bit patterns are structurally as good as any double. */
static double random_double(rng *r)
{
    switch (rng_next(r) % 8) {
    case 0:
        return NAN;
    case 1:
        return INFINITY;
    case 2:
        return -INFINITY;
    case 3: {
        uint64_t bits = rng_next(r);
        double d;
        memcpy(&d, &bits, sizeof d);
        return d;
    }
    default:
        return rng_uniform(r, -1e3, 1e3);
    }
}

static trioct_vec3_t random_vec3(rng *r)
{
    return (trioct_vec3_t){random_double(r), random_double(r), random_double(r)};
}

static int32_t random_i32(rng *r) { return (int32_t)(uint32_t)rng_next(r); }
static int64_t random_i64(rng *r) { return (int64_t)(rng_next(r) >> 1) * ((rng_next(r) & 1) ? 1 : -1); }

static void *array_of(int32_t count, size_t element_size)
{
    if (count <= 0)
        return NULL;
    void *p = calloc((size_t)count, element_size);
    assert_non_null(p);
    return p;
}

static void fill_request_header(rng *r, variant v, trioct_request_header_t *h)
{
    h->client_id = random_i64(r);
    h->request_id = random_i64(r);
    h->reply_channel = random_text(r, v);
    h->world = random_text(r, v);
    h->deadline_utime = random_i64(r);
}

static void fill_reply_header(rng *r, variant v, trioct_reply_header_t *h)
{
    h->client_id = random_i64(r);
    h->request_id = random_i64(r);
    h->daemon = random_text(r, v);
    h->world = random_text(r, v);
    h->world_version = random_i64(r);
    h->status = (int16_t)random_i32(r);
    h->message = random_text(r, v);
    h->chunk_index = random_i32(r);
    h->chunk_count = random_i32(r);
}

static void fill_triangles(rng *r, trioct_triangle_t *t, int32_t count)
{
    for (int32_t i = 0; i < count; i++)
        t[i] = (trioct_triangle_t){random_vec3(r), random_vec3(r), random_vec3(r)};
}

/* version stays below 2^31: the bad-count test relies on its high four bytes being zero
 * (see test_bad_counts_are_rejected). */
static void fill_world_info(rng *r, variant v, trioct_world_info_t *w)
{
    w->name = random_text(r, v);
    w->daemon = random_text(r, v);
    w->version = (int64_t)(rng_next(r) % ((uint64_t)1 << 31));
    w->source = random_text(r, v);
    w->accuracy = random_text(r, v);
    w->seed_epsilon = random_double(r);
    w->effects = random_i32(r);
    w->triangles = random_i64(r);
    w->vertices = random_i64(r);
    w->degenerate = random_i64(r);
    w->duplicates = random_i64(r);
    w->bbox_min = random_vec3(r);
    w->bbox_max = random_vec3(r);
    w->nodes = random_i64(r);
    w->leaves = random_i64(r);
    w->max_level = random_i32(r);
    w->resolution = random_double(r);
    w->world_size = random_double(r);
    w->world_min = random_vec3(r);
    w->bytes_nodes = random_i64(r);
    w->bytes_leaf_lists = random_i64(r);
    w->bytes_triangles = random_i64(r);
    w->bytes_effects = random_i64(r);
    w->bytes_total = random_i64(r);
    w->build_seconds = random_double(r);
    w->load_seconds = random_double(r);
    w->queries = random_i64(r);
    w->last_error = random_text(r, v);
    w->num_shapes = pick_count(r, v);
    w->shapes = array_of(w->num_shapes, sizeof(char *));
    for (int32_t i = 0; i < w->num_shapes; i++)
        w->shapes[i] = random_text(r, v);
}

static trioct_world_info_t *random_worlds(rng *r, variant v, int32_t count)
{
    trioct_world_info_t *worlds = array_of(count, sizeof *worlds);
    for (int32_t i = 0; i < count; i++)
        fill_world_info(r, v, &worlds[i]);
    return worlds;
}

static void make_ray_request(rng *r, variant v, trioct_ray_request_t *m)
{
    fill_request_header(r, v, &m->header);
    m->detail = (int8_t)random_i32(r);
    m->accuracy = (int8_t)random_i32(r);
    m->tmin = random_double(r);
    m->tmax = random_double(r);
    m->max_hits = random_i32(r);
    m->num_rays = pick_count(r, v);
    m->origin = array_of(m->num_rays, sizeof *m->origin);
    m->direction = array_of(m->num_rays, sizeof *m->direction);
    for (int32_t i = 0; i < m->num_rays; i++) {
        m->origin[i] = random_vec3(r);
        m->direction[i] = random_vec3(r);
    }
    m->contact = (int8_t)random_i32(r);
}

static void make_ray_request_v1(rng *r, variant v, trioct_ray_request_v1_t *m)
{
    fill_request_header(r, v, &m->header);
    m->detail = (int8_t)random_i32(r);
    m->accuracy = (int8_t)random_i32(r);
    m->tmin = random_double(r);
    m->tmax = random_double(r);
    m->max_hits = random_i32(r);
    m->num_rays = pick_count(r, v);
    m->origin = array_of(m->num_rays, sizeof *m->origin);
    m->direction = array_of(m->num_rays, sizeof *m->direction);
    for (int32_t i = 0; i < m->num_rays; i++) {
        m->origin[i] = random_vec3(r);
        m->direction[i] = random_vec3(r);
    }
}

static void make_triangle_request(rng *r, variant v, trioct_triangle_request_t *m)
{
    fill_request_header(r, v, &m->header);
    m->detail = (int8_t)random_i32(r);
    m->accuracy = (int8_t)random_i32(r);
    m->num_triangles = pick_count(r, v);
    m->triangles = array_of(m->num_triangles, sizeof *m->triangles);
    fill_triangles(r, m->triangles, m->num_triangles);
}

static void make_mesh_request(rng *r, variant v, trioct_mesh_request_t *m)
{
    fill_request_header(r, v, &m->header);
    m->detail = (int8_t)random_i32(r);
    m->accuracy = (int8_t)random_i32(r);
    m->shape = random_text(r, v);
    m->num_shape_triangles = pick_count(r, v);
    m->shape_triangles = array_of(m->num_shape_triangles, sizeof *m->shape_triangles);
    fill_triangles(r, m->shape_triangles, m->num_shape_triangles);
    m->num_poses = pick_count(r, v);
    m->poses = array_of(m->num_poses, sizeof *m->poses);
    for (int32_t i = 0; i < m->num_poses; i++) {
        for (int k = 0; k < 9; k++)
            m->poses[i].r[k] = random_double(r);
        m->poses[i].t = random_vec3(r);
    }
}

static void make_admin_request(rng *r, variant v, trioct_admin_request_t *m)
{
    fill_request_header(r, v, &m->header);
    m->op = (int8_t)random_i32(r);
    m->mesh_path = random_text(r, v);
    m->resolution = random_double(r);
    m->accuracy = (int8_t)random_i32(r);
    m->seed_epsilon = random_double(r);
    m->effects = random_i32(r);
}

static int32_t *random_found(rng *r, int32_t count)
{
    int32_t *found = array_of(count, sizeof *found);
    for (int32_t i = 0; i < count; i++)
        found[i] = random_i32(r);
    return found;
}

static char **random_names(rng *r, variant v, int32_t count)
{
    char **names = array_of(count, sizeof *names);
    for (int32_t i = 0; i < count; i++)
        names[i] = random_text(r, v);
    return names;
}

static void make_ray_reply(rng *r, variant v, trioct_ray_reply_t *m)
{
    fill_reply_header(r, v, &m->header);
    m->detail = (int8_t)random_i32(r);
    m->num_rays = pick_count(r, v);
    m->found = random_found(r, m->num_rays);
    m->num_objects = pick_count(r, v);
    m->objects = random_names(r, v, m->num_objects);
    m->num_hits = pick_count(r, v);
    m->hits = array_of(m->num_hits, sizeof *m->hits);
    for (int32_t i = 0; i < m->num_hits; i++)
        m->hits[i] = (trioct_ray_hit_t){random_i32(r), random_double(r), random_i32(r), random_i32(r), random_double(r),
                                        random_double(r), random_vec3(r)};
}

static void make_triangle_reply(rng *r, variant v, trioct_triangle_reply_t *m)
{
    fill_reply_header(r, v, &m->header);
    m->detail = (int8_t)random_i32(r);
    m->num_triangles = pick_count(r, v);
    m->found = random_found(r, m->num_triangles);
    m->num_objects = pick_count(r, v);
    m->objects = random_names(r, v, m->num_objects);
    m->num_contacts = pick_count(r, v);
    m->contacts = array_of(m->num_contacts, sizeof *m->contacts);
    for (int32_t i = 0; i < m->num_contacts; i++)
        m->contacts[i] = (trioct_contact_t){random_i32(r), random_i32(r), random_i32(r)};
    m->num_segments = pick_count(r, v);
    m->segments = array_of(m->num_segments, sizeof *m->segments);
    for (int32_t i = 0; i < m->num_segments; i++)
        m->segments[i] = (trioct_segment_t){random_vec3(r), random_vec3(r)};
}

static void make_mesh_reply(rng *r, variant v, trioct_mesh_reply_t *m)
{
    fill_reply_header(r, v, &m->header);
    m->detail = (int8_t)random_i32(r);
    m->num_poses = pick_count(r, v);
    m->found = random_found(r, m->num_poses);
    m->num_objects = pick_count(r, v);
    m->objects = random_names(r, v, m->num_objects);
    m->num_pairs = pick_count(r, v);
    m->pairs = array_of(m->num_pairs, sizeof *m->pairs);
    for (int32_t i = 0; i < m->num_pairs; i++)
        m->pairs[i] = (trioct_mesh_pair_t){random_i32(r), random_i32(r), random_i32(r), random_i32(r)};
}

static void make_admin_reply(rng *r, variant v, trioct_admin_reply_t *m)
{
    fill_reply_header(r, v, &m->header);
    m->op = (int8_t)random_i32(r);
    m->num_worlds = pick_count(r, v);
    m->worlds = random_worlds(r, v, m->num_worlds);
}

static void random_pose(rng *r, trioct_pose_t *p)
{
    for (int k = 0; k < 9; k++)
        p->r[k] = random_double(r);
    p->t = random_vec3(r);
}

static void make_object_edit_request(rng *r, variant v, trioct_object_edit_request_t *m)
{
    fill_request_header(r, v, &m->header);
    m->list = (int8_t)random_i32(r);
    m->num_edits = pick_count(r, v);
    m->edits = array_of(m->num_edits, sizeof *m->edits);
    for (int32_t i = 0; i < m->num_edits; i++) {
        trioct_object_edit_t *e = &m->edits[i];
        e->op = (int8_t)random_i32(r);
        e->name = random_text(r, v);
        e->mesh = random_text(r, v);
        random_pose(r, &e->pose);
        e->rotation = (int8_t)random_i32(r);
        for (int k = 0; k < 4; k++)
            e->quaternion[k] = random_double(r);
        e->num_triangles = pick_count(r, v);
        e->triangles = array_of(e->num_triangles, sizeof *e->triangles);
        fill_triangles(r, e->triangles, e->num_triangles);
    }
}

static void make_object_reply(rng *r, variant v, trioct_object_reply_t *m)
{
    fill_reply_header(r, v, &m->header);
    m->failed_edit = random_i32(r);
    m->objects = random_i32(r);
    m->triangles = random_i32(r);
    m->num_objects = pick_count(r, v);
    m->list = array_of(m->num_objects, sizeof *m->list);
    for (int32_t i = 0; i < m->num_objects; i++) {
        trioct_object_info_t *o = &m->list[i];
        o->name = random_text(r, v);
        o->mesh = random_text(r, v);
        o->triangles = random_i32(r);
        random_pose(r, &o->pose);
        o->bbox_min = random_vec3(r);
        o->bbox_max = random_vec3(r);
        o->bytes = random_i32(r);
        o->shared = random_i32(r);
    }
}

static void make_state_request(rng *r, variant v, trioct_state_request_t *m)
{
    fill_request_header(r, v, &m->header);
    m->detail = (int8_t)random_i32(r);
    m->self_collision = (int8_t)random_i32(r);
    m->num_links = pick_count(r, v);
    m->links = array_of(m->num_links, sizeof *m->links);
    for (int32_t i = 0; i < m->num_links; i++) {
        trioct_state_link_t *l = &m->links[i];
        l->name = random_text(r, v);
        l->shape = random_text(r, v);
        l->num_triangles = pick_count(r, v);
        l->triangles = array_of(l->num_triangles, sizeof *l->triangles);
        fill_triangles(r, l->triangles, l->num_triangles);
    }
    m->num_allowed = pick_count(r, v);
    m->allowed_a = random_names(r, v, m->num_allowed);
    m->allowed_b = random_names(r, v, m->num_allowed);
    m->num_poses = pick_count(r, v);
    m->poses = array_of(m->num_poses, sizeof *m->poses);
    for (int32_t i = 0; i < m->num_poses; i++)
        random_pose(r, &m->poses[i]);
    m->rotation = (int8_t)random_i32(r);
    m->num_quaternions = pick_count(r, v);
    m->quaternions = array_of(m->num_quaternions, sizeof *m->quaternions);
    for (int32_t i = 0; i < m->num_quaternions; i++)
        m->quaternions[i] = random_double(r);
}

static void make_state_reply(rng *r, variant v, trioct_state_reply_t *m)
{
    fill_reply_header(r, v, &m->header);
    m->detail = (int8_t)random_i32(r);
    m->num_states = pick_count(r, v);
    m->found = random_found(r, m->num_states);
    m->num_objects = pick_count(r, v);
    m->objects = random_names(r, v, m->num_objects);
    m->num_contacts = pick_count(r, v);
    m->contacts = array_of(m->num_contacts, sizeof *m->contacts);
    for (int32_t i = 0; i < m->num_contacts; i++)
        m->contacts[i] = (trioct_state_contact_t){random_i32(r), random_i32(r), (int8_t)random_i32(r),
                                                  random_i32(r), random_i32(r), random_i32(r)};
}

static void make_distance_request(rng *r, variant v, trioct_distance_request_t *m)
{
    fill_request_header(r, v, &m->header);
    m->kind = (int8_t)random_i32(r);
    m->within = random_double(r);
    m->num_points = pick_count(r, v);
    m->points = array_of(m->num_points, sizeof *m->points);
    for (int32_t i = 0; i < m->num_points; i++)
        m->points[i] = random_vec3(r);
    m->shape = random_text(r, v);
    m->num_shape_triangles = pick_count(r, v);
    m->shape_triangles = array_of(m->num_shape_triangles, sizeof *m->shape_triangles);
    fill_triangles(r, m->shape_triangles, m->num_shape_triangles);
    m->num_poses = pick_count(r, v);
    m->poses = array_of(m->num_poses, sizeof *m->poses);
    for (int32_t i = 0; i < m->num_poses; i++)
        random_pose(r, &m->poses[i]);
    m->rotation = (int8_t)random_i32(r);
    m->num_quaternions = pick_count(r, v);
    m->quaternions = array_of(m->num_quaternions, sizeof *m->quaternions);
    for (int32_t i = 0; i < m->num_quaternions; i++)
        m->quaternions[i] = random_double(r);
}

static void make_distance_reply(rng *r, variant v, trioct_distance_reply_t *m)
{
    fill_reply_header(r, v, &m->header);
    m->kind = (int8_t)random_i32(r);
    m->num_objects = pick_count(r, v);
    m->objects = random_names(r, v, m->num_objects);
    m->num_results = pick_count(r, v);
    m->results = array_of(m->num_results, sizeof *m->results);
    for (int32_t i = 0; i < m->num_results; i++)
        m->results[i] = (trioct_distance_result_t){
            random_i32(r),      (int8_t)random_i32(r), (int8_t)random_i32(r), random_double(r),
            random_double(r),   random_double(r),      random_double(r),      random_vec3(r),
            random_vec3(r),     random_i32(r),         random_i32(r),         random_i32(r),
            (int8_t)random_i32(r), (int8_t)random_i32(r), (int8_t)random_i32(r)};
}

static void make_status(rng *r, variant v, trioct_status_t *m)
{
    m->utime = random_i64(r);
    m->daemon = random_text(r, v);
    m->version = random_text(r, v);
    m->uptime_us = random_i64(r);
    m->state = (int8_t)random_i32(r);
    m->threads = random_i32(r);
    m->queue_depth = random_i32(r);
    m->queue_capacity = random_i32(r);
    for (int k = 0; k < 7; k++)
        m->served[k] = random_i64(r);
    m->malformed = random_i64(r);
    m->num_status_codes = pick_count(r, v);
    m->replies_by_status = array_of(m->num_status_codes, sizeof *m->replies_by_status);
    for (int32_t i = 0; i < m->num_status_codes; i++)
        m->replies_by_status[i] = random_i64(r);
    m->latency_p50_us = random_i64(r);
    m->latency_p99_us = random_i64(r);
    m->latency_count = random_i64(r);
    m->num_worlds = pick_count(r, v);
    m->worlds = random_worlds(r, v, m->num_worlds);
    m->num_loads = pick_count(r, v);
    m->loads = array_of(m->num_loads, sizeof *m->loads);
    for (int32_t i = 0; i < m->num_loads; i++) {
        trioct_load_progress_t *p = &m->loads[i];
        p->world = random_text(r, v);
        p->client_id = random_i64(r);
        p->request_id = random_i64(r);
        p->phase = random_text(r, v);
        p->files_done = random_i32(r);
        p->files_total = random_i32(r);
        p->triangles = random_i64(r);
        p->elapsed_seconds = random_double(r);
    }
}

/* ---------- where the counts and strings lie in an encoded message ---------- */

/* Offsets come from the message's own values and the generated encoded sizes; each mark is
 * checked against the encoded bytes, and the total against the generated size, so a wrong
 * layout fails loudly instead of testing the wrong bytes. */
enum { MAX_MARKS = 160 };

typedef enum mark_kind { MARK_COUNT, MARK_STRING } mark_kind;

typedef struct mark {
    mark_kind kind;
    size_t offset;  /* of the count, or of the string's length */
    int32_t value;  /* the count, or the string's length with its NUL */
    char name[48];  /* as the validator names the field */
} mark;

typedef struct layout {
    size_t pos;
    char scope[24];
    int count;
    mark marks[MAX_MARKS];
} layout;

static void lay_mark(layout *l, mark_kind kind, const char *name, int index, int32_t value)
{
    assert_true(l->count < MAX_MARKS);
    mark *m = &l->marks[l->count++];
    m->kind = kind;
    m->offset = l->pos;
    m->value = value;
    if (index >= 0)
        snprintf(m->name, sizeof m->name, "%s%s[%d]", l->scope, name, index);
    else
        snprintf(m->name, sizeof m->name, "%s%s", l->scope, name);
}

static void lay_bytes(layout *l, int n)
{
    assert_true(n >= 0);
    l->pos += (size_t)n;
}

static void lay_string_element(layout *l, const char *name, int index, char *const *s)
{
    lay_mark(l, MARK_STRING, name, index, (int32_t)strlen(*s) + 1);
    lay_bytes(l, __string_encoded_array_size(s, 1));
}

static void lay_string(layout *l, const char *name, char *const *s)
{
    lay_string_element(l, name, -1, s);
}

static void lay_count(layout *l, const char *name, int32_t count)
{
    lay_mark(l, MARK_COUNT, name, -1, count);
    lay_bytes(l, __int32_t_encoded_array_size(&count, 1));
}

static void lay_request_header(layout *l, const trioct_request_header_t *h)
{
    size_t start = l->pos;
    lay_bytes(l, __int64_t_encoded_array_size(&h->client_id, 2));
    lay_string(l, "header.reply_channel", &h->reply_channel);
    lay_string(l, "header.world", &h->world);
    lay_bytes(l, __int64_t_encoded_array_size(&h->deadline_utime, 1));
    assert_int_equal(l->pos - start, __trioct_request_header_t_encoded_array_size(h, 1));
}

static void lay_reply_header(layout *l, const trioct_reply_header_t *h)
{
    size_t start = l->pos;
    lay_bytes(l, __int64_t_encoded_array_size(&h->client_id, 2));
    lay_string(l, "header.daemon", &h->daemon);
    lay_string(l, "header.world", &h->world);
    lay_bytes(l, __int64_t_encoded_array_size(&h->world_version, 1) +
                     __int16_t_encoded_array_size(&h->status, 1));
    lay_string(l, "header.message", &h->message);
    lay_bytes(l, __int32_t_encoded_array_size(&h->chunk_index, 2));
    assert_int_equal(l->pos - start, __trioct_reply_header_t_encoded_array_size(h, 1));
}

/* The fixed-width fields of world_info_t between accuracy and last_error. */
static int world_info_middle_bytes(const trioct_world_info_t *w)
{
    return __double_encoded_array_size(&w->seed_epsilon, 1) + __int32_t_encoded_array_size(&w->effects, 1) +
           __int64_t_encoded_array_size(&w->triangles, 4) + __trioct_vec3_t_encoded_array_size(&w->bbox_min, 1) +
           __trioct_vec3_t_encoded_array_size(&w->bbox_max, 1) +
           __int64_t_encoded_array_size(&w->nodes, 2) + __int32_t_encoded_array_size(&w->max_level, 1) +
           __double_encoded_array_size(&w->resolution, 2) + __trioct_vec3_t_encoded_array_size(&w->world_min, 1) +
           __int64_t_encoded_array_size(&w->bytes_nodes, 7) + __double_encoded_array_size(&w->build_seconds, 2) +
           __int64_t_encoded_array_size(&w->objects, 1) + __int64_t_encoded_array_size(&w->queries, 1);
}

static void lay_worlds(layout *l, int32_t count, const trioct_world_info_t *worlds)
{
    lay_count(l, "num_worlds", count);
    for (int32_t i = 0; i < count; i++) {
        const trioct_world_info_t *w = &worlds[i];
        size_t start = l->pos;
        snprintf(l->scope, sizeof l->scope, "worlds[%d].", (int)i);
        lay_string(l, "name", &w->name);
        lay_string(l, "daemon", &w->daemon);
        lay_bytes(l, __int64_t_encoded_array_size(&w->version, 1));
        lay_string(l, "source", &w->source);
        lay_string(l, "accuracy", &w->accuracy);
        lay_bytes(l, world_info_middle_bytes(w));
        lay_string(l, "last_error", &w->last_error);
        lay_count(l, "num_shapes", w->num_shapes);
        for (int32_t k = 0; k < w->num_shapes; k++)
            lay_string_element(l, "shapes", (int)k, &w->shapes[k]);
        l->scope[0] = '\0';
        assert_int_equal(l->pos - start, __trioct_world_info_t_encoded_array_size(w, 1));
    }
}

static void lay_ray_request(layout *l, const trioct_ray_request_t *m)
{
    lay_request_header(l, &m->header);
    lay_bytes(l, 1 + 1 + 8 + 8 + 4);
    lay_count(l, "num_rays", m->num_rays);
    lay_bytes(l, 2 * __trioct_vec3_t_encoded_array_size(m->origin, m->num_rays));
    lay_bytes(l, 1); /* contact */
}

static void lay_ray_request_v1(layout *l, const trioct_ray_request_v1_t *m)
{
    lay_request_header(l, &m->header);
    lay_bytes(l, 1 + 1 + 8 + 8 + 4);
    lay_count(l, "num_rays", m->num_rays);
    lay_bytes(l, 2 * __trioct_vec3_t_encoded_array_size(m->origin, m->num_rays));
}

static void lay_triangle_request(layout *l, const trioct_triangle_request_t *m)
{
    lay_request_header(l, &m->header);
    lay_bytes(l, 1 + 1);
    lay_count(l, "num_triangles", m->num_triangles);
    lay_bytes(l, __trioct_triangle_t_encoded_array_size(m->triangles, m->num_triangles));
}

static void lay_mesh_request(layout *l, const trioct_mesh_request_t *m)
{
    lay_request_header(l, &m->header);
    lay_bytes(l, 1 + 1);
    lay_string(l, "shape", &m->shape);
    lay_count(l, "num_shape_triangles", m->num_shape_triangles);
    lay_bytes(l, __trioct_triangle_t_encoded_array_size(m->shape_triangles, m->num_shape_triangles));
    lay_count(l, "num_poses", m->num_poses);
    lay_bytes(l, __trioct_pose_t_encoded_array_size(m->poses, m->num_poses));
}

static void lay_admin_request(layout *l, const trioct_admin_request_t *m)
{
    lay_request_header(l, &m->header);
    lay_bytes(l, 1);
    lay_string(l, "mesh_path", &m->mesh_path);
    lay_bytes(l, 8 + 1 + 8 + 4);
    lay_bytes(l, 8 + 16 + 32); /* auth */
}

static void lay_ray_reply(layout *l, const trioct_ray_reply_t *m)
{
    lay_reply_header(l, &m->header);
    lay_bytes(l, 1);
    lay_count(l, "num_rays", m->num_rays);
    lay_bytes(l, __int32_t_encoded_array_size(m->found, m->num_rays));
    lay_count(l, "num_objects", m->num_objects);
    for (int32_t k = 0; k < m->num_objects; k++)
        lay_string_element(l, "objects", (int)k, &m->objects[k]);
    lay_count(l, "num_hits", m->num_hits);
    lay_bytes(l, __trioct_ray_hit_t_encoded_array_size(m->hits, m->num_hits));
}

static void lay_triangle_reply(layout *l, const trioct_triangle_reply_t *m)
{
    lay_reply_header(l, &m->header);
    lay_bytes(l, 1);
    lay_count(l, "num_triangles", m->num_triangles);
    lay_bytes(l, __int32_t_encoded_array_size(m->found, m->num_triangles));
    lay_count(l, "num_objects", m->num_objects);
    for (int32_t k = 0; k < m->num_objects; k++)
        lay_string_element(l, "objects", (int)k, &m->objects[k]);
    lay_count(l, "num_contacts", m->num_contacts);
    lay_bytes(l, __trioct_contact_t_encoded_array_size(m->contacts, m->num_contacts));
    lay_count(l, "num_segments", m->num_segments);
    lay_bytes(l, __trioct_segment_t_encoded_array_size(m->segments, m->num_segments));
}

static void lay_mesh_reply(layout *l, const trioct_mesh_reply_t *m)
{
    lay_reply_header(l, &m->header);
    lay_bytes(l, 1);
    lay_count(l, "num_poses", m->num_poses);
    lay_bytes(l, __int32_t_encoded_array_size(m->found, m->num_poses));
    lay_count(l, "num_objects", m->num_objects);
    for (int32_t k = 0; k < m->num_objects; k++)
        lay_string_element(l, "objects", (int)k, &m->objects[k]);
    lay_count(l, "num_pairs", m->num_pairs);
    lay_bytes(l, __trioct_mesh_pair_t_encoded_array_size(m->pairs, m->num_pairs));
}

static void lay_admin_reply(layout *l, const trioct_admin_reply_t *m)
{
    lay_reply_header(l, &m->header);
    lay_bytes(l, 1);
    lay_worlds(l, m->num_worlds, m->worlds);
}

static void lay_object_edit_request(layout *l, const trioct_object_edit_request_t *m)
{
    lay_request_header(l, &m->header);
    lay_bytes(l, 1);
    lay_count(l, "num_edits", m->num_edits);
    for (int32_t i = 0; i < m->num_edits; i++) {
        const trioct_object_edit_t *e = &m->edits[i];
        snprintf(l->scope, sizeof l->scope, "edits[%d].", (int)i);
        lay_bytes(l, 1);
        lay_string(l, "name", &e->name);
        lay_string(l, "mesh", &e->mesh);
        lay_bytes(l, __trioct_pose_t_encoded_array_size(&e->pose, 1) + 1 + 4 * 8);
        lay_count(l, "num_triangles", e->num_triangles);
        lay_bytes(l, __trioct_triangle_t_encoded_array_size(e->triangles, e->num_triangles));
        l->scope[0] = '\0';
    }
    lay_bytes(l, 8 + 16 + 32); /* auth */
}

static void lay_object_reply(layout *l, const trioct_object_reply_t *m)
{
    lay_reply_header(l, &m->header);
    lay_bytes(l, 4 + 8 + 8);
    lay_count(l, "num_objects", m->num_objects);
    for (int32_t i = 0; i < m->num_objects; i++) {
        const trioct_object_info_t *o = &m->list[i];
        snprintf(l->scope, sizeof l->scope, "list[%d].", (int)i);
        lay_string(l, "name", &o->name);
        lay_string(l, "mesh", &o->mesh);
        lay_bytes(l, 8 + __trioct_pose_t_encoded_array_size(&o->pose, 1) + 2 * __trioct_vec3_t_encoded_array_size(&o->bbox_min, 1) + 8 + 4);
        l->scope[0] = '\0';
    }
}

static void lay_state_request(layout *l, const trioct_state_request_t *m)
{
    lay_request_header(l, &m->header);
    lay_bytes(l, 1 + 1);
    lay_count(l, "num_links", m->num_links);
    for (int32_t i = 0; i < m->num_links; i++) {
        const trioct_state_link_t *k = &m->links[i];
        snprintf(l->scope, sizeof l->scope, "links[%d].", (int)i);
        lay_string(l, "name", &k->name);
        lay_string(l, "shape", &k->shape);
        lay_count(l, "num_triangles", k->num_triangles);
        lay_bytes(l, __trioct_triangle_t_encoded_array_size(k->triangles, k->num_triangles));
        l->scope[0] = '\0';
    }
    lay_count(l, "num_allowed", m->num_allowed);
    for (int32_t i = 0; i < m->num_allowed; i++)
        lay_string_element(l, "allowed_a", (int)i, &m->allowed_a[i]);
    for (int32_t i = 0; i < m->num_allowed; i++)
        lay_string_element(l, "allowed_b", (int)i, &m->allowed_b[i]);
    lay_count(l, "num_poses", m->num_poses);
    lay_bytes(l, __trioct_pose_t_encoded_array_size(m->poses, m->num_poses));
    lay_bytes(l, 1);
    lay_count(l, "num_quaternions", m->num_quaternions);
    lay_bytes(l, __double_encoded_array_size(m->quaternions, m->num_quaternions));
}

static void lay_state_reply(layout *l, const trioct_state_reply_t *m)
{
    lay_reply_header(l, &m->header);
    lay_bytes(l, 1);
    lay_count(l, "num_states", m->num_states);
    lay_bytes(l, __int32_t_encoded_array_size(m->found, m->num_states));
    lay_count(l, "num_objects", m->num_objects);
    for (int32_t k = 0; k < m->num_objects; k++)
        lay_string_element(l, "objects", (int)k, &m->objects[k]);
    lay_count(l, "num_contacts", m->num_contacts);
    lay_bytes(l, __trioct_state_contact_t_encoded_array_size(m->contacts, m->num_contacts));
}

static void lay_distance_request(layout *l, const trioct_distance_request_t *m)
{
    lay_request_header(l, &m->header);
    lay_bytes(l, 1 + 8);
    lay_count(l, "num_points", m->num_points);
    lay_bytes(l, __trioct_vec3_t_encoded_array_size(m->points, m->num_points));
    lay_string(l, "shape", &m->shape);
    lay_count(l, "num_shape_triangles", m->num_shape_triangles);
    lay_bytes(l, __trioct_triangle_t_encoded_array_size(m->shape_triangles, m->num_shape_triangles));
    lay_count(l, "num_poses", m->num_poses);
    lay_bytes(l, __trioct_pose_t_encoded_array_size(m->poses, m->num_poses));
    lay_bytes(l, 1);
    lay_count(l, "num_quaternions", m->num_quaternions);
    lay_bytes(l, __double_encoded_array_size(m->quaternions, m->num_quaternions));
}

static void lay_distance_reply(layout *l, const trioct_distance_reply_t *m)
{
    lay_reply_header(l, &m->header);
    lay_bytes(l, 1);
    lay_count(l, "num_objects", m->num_objects);
    for (int32_t k = 0; k < m->num_objects; k++)
        lay_string_element(l, "objects", (int)k, &m->objects[k]);
    lay_count(l, "num_results", m->num_results);
    lay_bytes(l, __trioct_distance_result_t_encoded_array_size(m->results, m->num_results));
}

static void lay_status(layout *l, const trioct_status_t *m)
{
    lay_bytes(l, 8);
    lay_string(l, "daemon", &m->daemon);
    lay_string(l, "version", &m->version);
    lay_bytes(l, 8 + 1 + 3 * 4 + 2 * 8 + 7 * 8 + 3 * 8);
    lay_count(l, "num_status_codes", m->num_status_codes);
    lay_bytes(l, __int64_t_encoded_array_size(m->replies_by_status, m->num_status_codes));
    lay_bytes(l, 3 * 8);
    lay_worlds(l, m->num_worlds, m->worlds);
    lay_count(l, "num_loads", m->num_loads);
    for (int32_t i = 0; i < m->num_loads; i++) {
        const trioct_load_progress_t *p = &m->loads[i];
        size_t start = l->pos;
        snprintf(l->scope, sizeof l->scope, "loads[%d].", (int)i);
        lay_string(l, "world", &p->world);
        lay_bytes(l, 2 * 8);
        lay_string(l, "phase", &p->phase);
        lay_bytes(l, 2 * 4 + 8 + 8);
        l->scope[0] = '\0';
        assert_int_equal(l->pos - start, __trioct_load_progress_t_encoded_array_size(p, 1));
    }
}

/* ---------- one table over the ten types ---------- */

typedef union any_message {
    trioct_ray_request_t ray_request;
    trioct_triangle_request_t triangle_request;
    trioct_mesh_request_t mesh_request;
    trioct_admin_request_t admin_request;
    trioct_ray_reply_t ray_reply;
    trioct_triangle_reply_t triangle_reply;
    trioct_mesh_reply_t mesh_reply;
    trioct_admin_reply_t admin_reply;
    trioct_status_t status;
    trioct_ray_request_v1_t ray_request_v1;
    trioct_object_edit_request_t object_edit_request;
    trioct_object_reply_t object_reply;
    trioct_state_request_t state_request;
    trioct_state_reply_t state_reply;
    trioct_distance_request_t distance_request;
    trioct_distance_reply_t distance_reply;
} any_message;

typedef struct codec {
    wire_type type;
    const char *name;
    void (*make)(rng *r, variant v, any_message *m);
    void (*lay_out)(layout *l, const any_message *m);
    int (*encode)(void *buf, int maxlen, const any_message *m);
    int (*decode)(const void *buf, int maxlen, any_message *m);
    int (*encoded_size)(const any_message *m);
    /* Frees what decode allocated; make allocates with malloc too, so it frees those. */
    void (*cleanup)(any_message *m);
    int64_t (*get_hash)(void);
} codec;

#define CODEC_FUNCTIONS(member)                                                                         \
    static void codec_make_##member(rng *r, variant v, any_message *m) { make_##member(r, v, &m->member); } \
    static void codec_lay_##member(layout *l, const any_message *m) { lay_##member(l, &m->member); }       \
    static int codec_encode_##member(void *buf, int maxlen, const any_message *m)                      \
    {                                                                                                   \
        return trioct_##member##_t_encode(buf, 0, maxlen, &m->member);                                  \
    }                                                                                                   \
    static int codec_decode_##member(const void *buf, int maxlen, any_message *m)                      \
    {                                                                                                   \
        return trioct_##member##_t_decode(buf, 0, maxlen, &m->member);                                  \
    }                                                                                                   \
    static int codec_size_##member(const any_message *m) { return trioct_##member##_t_encoded_size(&m->member); } \
    static void codec_cleanup_##member(any_message *m) { trioct_##member##_t_decode_cleanup(&m->member); }

CODEC_FUNCTIONS(ray_request)
CODEC_FUNCTIONS(triangle_request)
CODEC_FUNCTIONS(mesh_request)
CODEC_FUNCTIONS(admin_request)
CODEC_FUNCTIONS(ray_reply)
CODEC_FUNCTIONS(triangle_reply)
CODEC_FUNCTIONS(mesh_reply)
CODEC_FUNCTIONS(admin_reply)
CODEC_FUNCTIONS(status)
CODEC_FUNCTIONS(ray_request_v1)
CODEC_FUNCTIONS(object_edit_request)
CODEC_FUNCTIONS(object_reply)
CODEC_FUNCTIONS(state_request)
CODEC_FUNCTIONS(state_reply)
CODEC_FUNCTIONS(distance_request)
CODEC_FUNCTIONS(distance_reply)

#define CODEC_ENTRY(type, member)                                                                     \
    {type, #member "_t", codec_make_##member, codec_lay_##member, codec_encode_##member,              \
     codec_decode_##member, codec_size_##member, codec_cleanup_##member, __trioct_##member##_t_get_hash}

static const codec codecs[WIRE_TYPE_COUNT] = {
    CODEC_ENTRY(WIRE_RAY_REQUEST, ray_request),     CODEC_ENTRY(WIRE_TRIANGLE_REQUEST, triangle_request),
    CODEC_ENTRY(WIRE_MESH_REQUEST, mesh_request),   CODEC_ENTRY(WIRE_ADMIN_REQUEST, admin_request),
    CODEC_ENTRY(WIRE_RAY_REPLY, ray_reply),         CODEC_ENTRY(WIRE_TRIANGLE_REPLY, triangle_reply),
    CODEC_ENTRY(WIRE_MESH_REPLY, mesh_reply),       CODEC_ENTRY(WIRE_ADMIN_REPLY, admin_reply),
    CODEC_ENTRY(WIRE_STATUS, status),               CODEC_ENTRY(WIRE_RAY_REQUEST_V1, ray_request_v1),
    CODEC_ENTRY(WIRE_OBJECT_EDIT_REQUEST, object_edit_request), CODEC_ENTRY(WIRE_OBJECT_REPLY, object_reply),
    CODEC_ENTRY(WIRE_STATE_REQUEST, state_request), CODEC_ENTRY(WIRE_STATE_REPLY, state_reply),
    CODEC_ENTRY(WIRE_DISTANCE_REQUEST, distance_request), CODEC_ENTRY(WIRE_DISTANCE_REPLY, distance_reply),
};

/* ---------- samples: encoded messages with their layout ---------- */

typedef struct sample {
    const codec *codec;
    uint8_t *bytes;
    size_t size;
    layout layout;
} sample;

static int32_t load_i32(const uint8_t *p)
{
    uint32_t u = (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
    int32_t v;
    memcpy(&v, &u, sizeof v);
    return v;
}

static void store_i32(uint8_t *p, int32_t v)
{
    uint32_t u;
    memcpy(&u, &v, sizeof u);
    p[0] = (uint8_t)(u >> 24);
    p[1] = (uint8_t)(u >> 16);
    p[2] = (uint8_t)(u >> 8);
    p[3] = (uint8_t)u;
}

static void store_i64(uint8_t *p, int64_t v)
{
    uint64_t u;
    memcpy(&u, &v, sizeof u);
    for (int i = 0; i < 8; i++)
        p[i] = (uint8_t)(u >> (56 - 8 * i));
}

static sample sample_make(const codec *k, rng *r, variant v)
{
    any_message m;
    memset(&m, 0, sizeof m);
    k->make(r, v, &m);
    int size = k->encoded_size(&m);
    sample s = {.codec = k, .size = (size_t)size};
    s.bytes = malloc(s.size);
    assert_non_null(s.bytes);
    assert_int_equal(k->encode(s.bytes, size, &m), size);

    s.layout.pos = 8; /* the fingerprint */
    k->lay_out(&s.layout, &m);
    assert_int_equal(s.layout.pos, s.size);
    for (int i = 0; i < s.layout.count; i++)
        assert_int_equal(load_i32(s.bytes + s.layout.marks[i].offset), s.layout.marks[i].value);
    k->cleanup(&m);
    return s;
}

static void sample_free(sample *s)
{
    free(s->bytes);
    s->bytes = NULL;
}

enum { SAMPLES_PER_TYPE = 6 };

/* Per type: one EMPTY, one SMALLEST and the rest RANDOM. */
static void samples_make(const codec *k, uint64_t seed, sample out[SAMPLES_PER_TYPE])
{
    rng r = rng_seeded(seed ^ ((uint64_t)k->type * 0x9e3779b97f4a7c15ull));
    for (int i = 0; i < SAMPLES_PER_TYPE; i++)
        out[i] = sample_make(k, &r, i == 0 ? VARIANT_EMPTY : i == 1 ? VARIANT_SMALLEST : VARIANT_RANDOM);
}

static void samples_free(sample s[SAMPLES_PER_TYPE])
{
    for (int i = 0; i < SAMPLES_PER_TYPE; i++)
        sample_free(&s[i]);
}

static int check(const sample *s, const uint8_t *bytes, size_t size, wire_error *err)
{
    return wire_check(s->codec->type, bytes, size, err);
}

/* The validator accepted: the generated decoder must read exactly these bytes, and encoding
 * what it read must give them back. */
static void assert_decodes_to_same_bytes(const codec *k, const uint8_t *bytes, size_t size)
{
    any_message m;
    memset(&m, 0, sizeof m);
    assert_int_equal(k->decode(bytes, (int)size, &m), size);
    assert_int_equal(k->encoded_size(&m), size);
    uint8_t *again = malloc(size);
    assert_non_null(again);
    assert_int_equal(k->encode(again, (int)size, &m), size);
    assert_memory_equal(again, bytes, size);
    free(again);
    k->cleanup(&m);
}

/* A copy of the sample's bytes with room to grow, for one mutation. */
static uint8_t *copy_bytes(const sample *s, size_t extra)
{
    uint8_t *copy = malloc(s->size + extra);
    assert_non_null(copy);
    memcpy(copy, s->bytes, s->size);
    return copy;
}

/* ---------- names and fingerprints ---------- */

static void test_type_names_and_fingerprints_match_generated_code(void **state)
{
    (void)state;
    for (int t = 0; t < WIRE_TYPE_COUNT; t++) {
        assert_int_equal(codecs[t].type, t);
        assert_string_equal(wire_type_name((wire_type)t), codecs[t].name);
        assert_true(wire_fingerprint((wire_type)t) == codecs[t].get_hash());
        for (int u = 0; u < t; u++)
            assert_true(wire_fingerprint((wire_type)t) != wire_fingerprint((wire_type)u));
    }
    assert_string_equal(wire_type_name(WIRE_TYPE_COUNT), "unknown");
    assert_string_equal(wire_type_name((wire_type)-1), "unknown");
    assert_true(wire_fingerprint(WIRE_TYPE_COUNT) == 0);
    assert_true(wire_fingerprint((wire_type)-1) == 0);
}

/* The first eight bytes of an encoded message are the fingerprint wire_fingerprint names. */
static void test_encoded_messages_start_with_the_fingerprint(void **state)
{
    (void)state;
    for (int t = 0; t < WIRE_TYPE_COUNT; t++) {
        sample s[SAMPLES_PER_TYPE];
        samples_make(&codecs[t], test_seed(), s);
        uint8_t expected[8];
        store_i64(expected, wire_fingerprint((wire_type)t));
        assert_memory_equal(s[0].bytes, expected, 8);
        samples_free(s);
    }
}

/* ---------- what the encoder writes is accepted ---------- */

static void test_encoded_messages_are_accepted(void **state)
{
    (void)state;
    for (int t = 0; t < WIRE_TYPE_COUNT; t++) {
        sample s[SAMPLES_PER_TYPE];
        samples_make(&codecs[t], test_seed() + 1, s);
        for (int i = 0; i < SAMPLES_PER_TYPE; i++) {
            wire_error err = {.offset = 99, .what = "stale"};
            assert_int_equal(check(&s[i], s[i].bytes, s[i].size, &err), 0);
            assert_string_equal(err.what, "");
            assert_int_equal(check(&s[i], s[i].bytes, s[i].size, NULL), 0);
            assert_decodes_to_same_bytes(s[i].codec, s[i].bytes, s[i].size);
        }
        samples_free(s);
    }
}

/* A count bound that overestimated the smallest element would refuse these: every world
 * and every shape as short as the encoder can make it, the worlds array last in the message,
 * so the count meets its bound exactly. */
static void test_smallest_elements_fill_the_message_exactly(void **state)
{
    (void)state;
    rng r = rng_seeded(test_seed() + 2);
    trioct_admin_reply_t reply;
    memset(&reply, 0, sizeof reply);
    make_admin_reply(&r, VARIANT_SMALLEST, &reply);
    for (int32_t i = 0; i < reply.num_worlds; i++) {
        for (int32_t k = 0; k < reply.worlds[i].num_shapes; k++)
            free(reply.worlds[i].shapes[k]);
        free(reply.worlds[i].shapes);
        reply.worlds[i].shapes = NULL;
        reply.worlds[i].num_shapes = 0;
    }
    int size = trioct_admin_reply_t_encoded_size(&reply);
    int worlds_bytes = __trioct_world_info_t_encoded_array_size(reply.worlds, reply.num_worlds);
    assert_int_equal(worlds_bytes, 277 * reply.num_worlds);
    uint8_t *bytes = malloc((size_t)size);
    assert_non_null(bytes);
    assert_int_equal(trioct_admin_reply_t_encode(bytes, 0, size, &reply), size);
    assert_int_equal(wire_check(WIRE_ADMIN_REPLY, bytes, (size_t)size, NULL), 0);
    /* One more world than the bytes hold is refused at the count itself. */
    size_t count_at = (size_t)(size - worlds_bytes - 4);
    assert_int_equal(load_i32(bytes + count_at), reply.num_worlds);
    store_i32(bytes + count_at, reply.num_worlds + 1);
    wire_error err;
    assert_int_equal(wire_check(WIRE_ADMIN_REPLY, bytes, (size_t)size, &err), -1);
    assert_int_equal(err.offset, count_at);
    free(bytes);
    trioct_admin_reply_t_decode_cleanup(&reply);
}

/* ---------- damaged messages are rejected ---------- */

static void test_every_truncation_is_rejected(void **state)
{
    (void)state;
    for (int t = 0; t < WIRE_TYPE_COUNT; t++) {
        sample s[SAMPLES_PER_TYPE];
        samples_make(&codecs[t], test_seed() + 3, s);
        for (int i = 0; i < SAMPLES_PER_TYPE; i++) {
            for (size_t len = 0; len < s[i].size; len++) {
                /* A copy of exactly len bytes, so ASan sees any read past the cut. */
                uint8_t *cut = malloc(len ? len : 1);
                assert_non_null(cut);
                memcpy(cut, s[i].bytes, len);
                wire_error err;
                assert_int_equal(check(&s[i], cut, len, &err), -1);
                assert_true(err.offset <= len);
                assert_true(strncmp(err.what, codecs[t].name, strlen(codecs[t].name)) == 0);
                free(cut);
            }
        }
        samples_free(s);
    }
}

static void test_appended_bytes_are_rejected(void **state)
{
    (void)state;
    for (int t = 0; t < WIRE_TYPE_COUNT; t++) {
        sample s[SAMPLES_PER_TYPE];
        samples_make(&codecs[t], test_seed() + 4, s);
        for (int i = 0; i < SAMPLES_PER_TYPE; i++) {
            for (size_t extra = 1; extra <= 3; extra++) {
                uint8_t *longer = copy_bytes(&s[i], extra);
                memset(longer + s[i].size, 0, extra);
                wire_error err;
                assert_int_equal(check(&s[i], longer, s[i].size + extra, &err), -1);
                assert_int_equal(err.offset, s[i].size);
                char expected[160];
                snprintf(expected, sizeof expected, "%s: %zu byte%s left over after the message at byte %zu",
                         codecs[t].name, extra, extra == 1 ? "" : "s", s[i].size);
                assert_string_equal(err.what, expected);
                free(longer);
            }
        }
        samples_free(s);
    }
}

static void test_foreign_fingerprints_are_rejected(void **state)
{
    (void)state;
    for (int t = 0; t < WIRE_TYPE_COUNT; t++) {
        sample s[SAMPLES_PER_TYPE];
        samples_make(&codecs[t], test_seed() + 5, s);
        uint8_t *bytes = copy_bytes(&s[2], 0);
        wire_error err;
        for (int other = 0; other < WIRE_TYPE_COUNT; other++) {
            if (other == t)
                continue;
            store_i64(bytes, wire_fingerprint((wire_type)other));
            assert_int_equal(check(&s[2], bytes, s[2].size, &err), -1);
            assert_int_equal(err.offset, 0);
            char expected[160];
            snprintf(expected, sizeof expected, "%s: the fingerprint is that of %s", codecs[t].name,
                     codecs[other].name);
            assert_string_equal(err.what, expected);
            /* And the message passes as the type it really is. */
            assert_int_equal(wire_check((wire_type)t, s[2].bytes, s[2].size, NULL), 0);
        }
        for (int bit = 0; bit < 64; bit++) {
            memcpy(bytes, s[2].bytes, 8);
            bytes[bit / 8] ^= (uint8_t)(1u << (bit % 8));
            assert_int_equal(check(&s[2], bytes, s[2].size, &err), -1);
            assert_int_equal(err.offset, 0);
            assert_non_null(strstr(err.what, "fingerprint"));
        }
        free(bytes);
        samples_free(s);
    }
}

/* Negative and huge counts fail at the count itself. count + 1 fails further on, but for
 * every message these tests build:
 * - a count whose array ends the message (num_rays of a request, num_triangles, num_poses,
 *   num_hits, num_segments, num_pairs, num_worlds) runs out of bytes;
 * - otherwise the extra element swallows the next count and what follows no longer comes out
 *   whole: ray_reply leaves 56h - 4 bytes for 56-byte hits, mesh_reply 12m - 4 for 12-byte
 *   pairs, mesh_request 96p - 72 for 96-byte poses, triangle_reply 48s - 8 for segments
 *   after contacts, or 8c + 48s for 8c' + 4 + 48s' after found[] (4 apart modulo 8);
 * - one more shape swallows the next world's name, so that world is read from its daemon on
 *   and its daemon's length from its version, whose high half is zero (fill_world_info);
 * - one more status code swallows latency_p50_us, so num_worlds is read from the first
 *   world's name text: 0 when the name is empty (and bytes are left over), else at least
 *   0x01000000 or negative. */
static void test_bad_counts_are_rejected(void **state)
{
    (void)state;
    const int32_t refused_at_count[] = {-1, -5, INT32_MIN, INT32_MAX};
    int counts_seen = 0;
    for (int t = 0; t < WIRE_TYPE_COUNT; t++) {
        sample s[SAMPLES_PER_TYPE];
        samples_make(&codecs[t], test_seed() + 6, s);
        for (int i = 0; i < SAMPLES_PER_TYPE; i++) {
            for (int n = 0; n < s[i].layout.count; n++) {
                const mark *mk = &s[i].layout.marks[n];
                if (mk->kind != MARK_COUNT)
                    continue;
                counts_seen++;
                uint8_t *bytes = copy_bytes(&s[i], 0);
                wire_error err;
                for (size_t v = 0; v < sizeof refused_at_count / sizeof refused_at_count[0]; v++) {
                    store_i32(bytes + mk->offset, refused_at_count[v]);
                    assert_int_equal(check(&s[i], bytes, s[i].size, &err), -1);
                    assert_int_equal(err.offset, mk->offset);
                    if (refused_at_count[v] == -5) {
                        char expected[160];
                        snprintf(expected, sizeof expected, "%s: %s -5 is negative at byte %zu", codecs[t].name,
                                 mk->name, mk->offset);
                        assert_string_equal(err.what, expected);
                    }
                }
                store_i32(bytes + mk->offset, mk->value + 1);
                assert_int_equal(check(&s[i], bytes, s[i].size, &err), -1);
                assert_true(err.offset >= mk->offset);
                free(bytes);
            }
        }
        samples_free(s);
    }
    assert_true(counts_seen >= 9 * SAMPLES_PER_TYPE);
}

static void assert_string_rejected(const sample *s, const uint8_t *bytes, size_t size, const mark *mk,
                                   size_t expected_offset, const char *problem)
{
    wire_error err;
    assert_int_equal(check(s, bytes, size, &err), -1);
    assert_int_equal(err.offset, expected_offset);
    char expected[160];
    snprintf(expected, sizeof expected, "%s: %s %s at byte %zu", s->codec->name, mk->name, problem,
             expected_offset);
    assert_string_equal(err.what, expected);
}

static void damage_string(const sample *s, const mark *mk)
{
    size_t length_at = mk->offset;
    size_t text_at = mk->offset + 4;
    size_t last = text_at + (size_t)mk->value - 1;
    char problem[96];
    uint8_t *bytes = copy_bytes(s, 0);

    bytes[last] = 'x'; /* the NUL replaced */
    assert_string_rejected(s, bytes, s->size, mk, last, "does not end in NUL");
    bytes[last] = '\0';

    const int32_t too_short[] = {0, -1, INT32_MIN};
    for (size_t v = 0; v < sizeof too_short / sizeof too_short[0]; v++) {
        store_i32(bytes + length_at, too_short[v]);
        snprintf(problem, sizeof problem, "length %ld is below 1", (long)too_short[v]);
        assert_string_rejected(s, bytes, s->size, mk, length_at, problem);
    }

    size_t remain = s->size - text_at;
    const int32_t too_long[] = {INT32_MAX, (int32_t)remain + 1};
    for (size_t v = 0; v < sizeof too_long / sizeof too_long[0]; v++) {
        store_i32(bytes + length_at, too_long[v]);
        snprintf(problem, sizeof problem, "length %ld runs past the end (%zu bytes remain)", (long)too_long[v],
                 remain);
        assert_string_rejected(s, bytes, s->size, mk, length_at, problem);
    }
    store_i32(bytes + length_at, mk->value);

    if (mk->value >= 2) {
        /* A length one short leaves the NUL outside the string. */
        store_i32(bytes + length_at, mk->value - 1);
        assert_string_rejected(s, bytes, s->size, mk, last - 1, "does not end in NUL");
        store_i32(bytes + length_at, mk->value);
        /* A NUL inside would decode as a shorter string. */
        bytes[text_at] = '\0';
        assert_string_rejected(s, bytes, s->size, mk, text_at, "has a NUL before its end");
    }
    free(bytes);
}

static void test_bad_strings_are_rejected(void **state)
{
    (void)state;
    int strings_seen = 0, nonempty_seen = 0;
    for (int t = 0; t < WIRE_TYPE_COUNT; t++) {
        sample s[SAMPLES_PER_TYPE];
        samples_make(&codecs[t], test_seed() + 7, s);
        for (int i = 0; i < SAMPLES_PER_TYPE; i++) {
            for (int n = 0; n < s[i].layout.count; n++) {
                const mark *mk = &s[i].layout.marks[n];
                if (mk->kind != MARK_STRING)
                    continue;
                strings_seen++;
                nonempty_seen += mk->value >= 2;
                damage_string(&s[i], mk);
            }
        }
        samples_free(s);
    }
    assert_true(strings_seen >= 9 * SAMPLES_PER_TYPE);
    assert_true(nonempty_seen > 0);
}

/* A message laid out by hand, so the offsets do not come from the same reasoning as the
 * layout helpers: fingerprint 8, ids 16, "R" 4 + 2, "W" 4 + 2, deadline 8, detail and
 * accuracy 2, tmin and tmax 16, max_hits 4: num_rays at 8 + 16 + 6 + 6 + 8 + 2 + 16 + 4 = 66. */
static void test_ray_request_errors_name_field_and_byte(void **state)
{
    (void)state;
    char channel[] = "R", world[] = "W";
    trioct_vec3_t origin = {0, 0, 0}, direction = {1, 0, 0};
    trioct_ray_request_v1_t m = {
        .header = {.client_id = 1, .request_id = 2, .reply_channel = channel, .world = world},
        .detail = TRIOCT_RAY_REQUEST_T_ALL,
        .tmax = INFINITY,
        .max_hits = 4,
        .num_rays = 1,
        .origin = &origin,
        .direction = &direction,
    };
    uint8_t bytes[256];
    int size = trioct_ray_request_v1_t_encode(bytes, 0, sizeof bytes, &m);
    assert_int_equal(size, 66 + 4 + 48);
    assert_int_equal(wire_check(WIRE_RAY_REQUEST_V1, bytes, (size_t)size, NULL), 0);
    wire_error err;

    store_i32(bytes + 66, -5);
    assert_int_equal(wire_check(WIRE_RAY_REQUEST_V1, bytes, (size_t)size, &err), -1);
    assert_string_equal(err.what, "ray_request_v1_t: num_rays -5 is negative at byte 66");
    assert_int_equal(err.offset, 66);

    store_i32(bytes + 66, 2);
    assert_int_equal(wire_check(WIRE_RAY_REQUEST_V1, bytes, (size_t)size, &err), -1);
    assert_string_equal(err.what, "ray_request_v1_t: num_rays 2 needs at least 48 bytes per element, 48 remain at byte 66");
    store_i32(bytes + 66, 1);

    bytes[35] = 'x'; /* world's NUL: 8 + 16 + 6 + 4 + 1 */
    assert_int_equal(wire_check(WIRE_RAY_REQUEST_V1, bytes, (size_t)size, &err), -1);
    assert_string_equal(err.what, "ray_request_v1_t: header.world does not end in NUL at byte 35");
    bytes[35] = '\0';

    assert_int_equal(wire_check(WIRE_RAY_REQUEST_V1, bytes, 50, &err), -1);
    assert_string_equal(err.what, "ray_request_v1_t: tmin needs 8 bytes, 4 remain at byte 46");
    assert_int_equal(wire_check(WIRE_RAY_REQUEST_V1, bytes, (size_t)size - 1, &err), -1);
    /* Both arrays are counted before either is walked. */
    assert_string_equal(err.what, "ray_request_v1_t: num_rays 1 needs at least 48 bytes per element, 47 remain at byte 66");
    assert_int_equal(wire_check(WIRE_RAY_REQUEST_V1, bytes, (size_t)size, &err), 0);
}

/* ray_request_t is ray_request_v1_t and one more byte, contact: the same offsets, one byte
 * longer; each type's bytes are refused as the other, naming it, and the RAY channel's
 * type follows the fingerprint. */
static void test_ray_request_contact_byte_and_the_old_type(void **state)
{
    (void)state;
    char channel[] = "R", world[] = "W";
    trioct_vec3_t origin = {0, 0, 0}, direction = {1, 0, 0};
    trioct_ray_request_t m = {
        .header = {.client_id = 1, .request_id = 2, .reply_channel = channel, .world = world},
        .detail = TRIOCT_RAY_REQUEST_T_ANY,
        .tmax = INFINITY,
        .num_rays = 1,
        .origin = &origin,
        .direction = &direction,
        .contact = TRIOCT_RAY_REQUEST_T_TOUCH,
    };
    trioct_ray_request_v1_t old = {
        .header = m.header,
        .detail = m.detail,
        .tmax = m.tmax,
        .num_rays = 1,
        .origin = &origin,
        .direction = &direction,
    };
    uint8_t bytes[256], old_bytes[256];
    int size = trioct_ray_request_t_encode(bytes, 0, sizeof bytes, &m);
    int old_size = trioct_ray_request_v1_t_encode(old_bytes, 0, sizeof old_bytes, &old);
    assert_int_equal(size, 66 + 4 + 48 + 1);
    assert_int_equal(old_size, size - 1);
    assert_memory_equal(bytes + 8, old_bytes + 8, (size_t)old_size - 8); /* all but fingerprint and contact */
    assert_int_equal(bytes[size - 1], TRIOCT_RAY_REQUEST_T_TOUCH);
    assert_int_equal(wire_check(WIRE_RAY_REQUEST, bytes, (size_t)size, NULL), 0);
    assert_int_equal(wire_check(WIRE_RAY_REQUEST_V1, old_bytes, (size_t)old_size, NULL), 0);
    wire_error err;
    assert_int_equal(wire_check(WIRE_RAY_REQUEST, bytes, (size_t)size - 1, &err), -1);
    assert_string_equal(err.what, "ray_request_t: contact needs 1 bytes, 0 remain at byte 118");
    assert_int_equal(wire_check(WIRE_RAY_REQUEST, old_bytes, (size_t)old_size, &err), -1);
    assert_string_equal(err.what, "ray_request_t: the fingerprint is that of ray_request_v1_t");
    assert_int_equal(wire_check(WIRE_RAY_REQUEST_V1, bytes, (size_t)size, &err), -1);
    assert_string_equal(err.what, "ray_request_v1_t: the fingerprint is that of ray_request_t");

    assert_int_equal(wire_ray_request_type(old_bytes, (size_t)old_size), WIRE_RAY_REQUEST_V1);
    assert_int_equal(wire_ray_request_type(bytes, (size_t)size), WIRE_RAY_REQUEST);
    assert_int_equal(wire_ray_request_type(old_bytes, 7), WIRE_RAY_REQUEST); /* too short to tell */
    assert_int_equal(wire_ray_request_type(NULL, 100), WIRE_RAY_REQUEST);
    assert_int_equal(wire_ray_request_type("garbage!", 8), WIRE_RAY_REQUEST);
    /* The old fingerprint is the one the checked-in logs carry (LCM hashes the members,
     * not the type's name, so ray_request_v1_t kept it): the first ray request of a log
     * recorded before contact existed starts with it. */
    lcm_eventlog_t *log = lcm_eventlog_create("tests/logs/queries.lcmlog", "r");
    assert_non_null(log);
    int rays_seen = 0;
    for (lcm_eventlog_event_t *ev; (ev = lcm_eventlog_read_next_event(log)) != NULL;) {
        if (strncmp(ev->channel, "TRIOCT_RAY_", 11) == 0 && ev->datalen >= 8) {
            assert_int_equal(wire_ray_request_type(ev->data, (size_t)ev->datalen), WIRE_RAY_REQUEST_V1);
            assert_int_equal(wire_check(WIRE_RAY_REQUEST_V1, ev->data, (size_t)ev->datalen, NULL), 0);
            rays_seen++;
        }
        lcm_eventlog_free_event(ev);
    }
    lcm_eventlog_destroy(log);
    assert_true(rays_seen >= 10);
}

/* Errors inside a world and a shape name the element they are in. */
static void test_world_errors_name_the_element(void **state)
{
    (void)state;
    rng r = rng_seeded(test_seed() + 8);
    int found_shape = 0;
    for (int attempt = 0; attempt < 50 && !found_shape; attempt++) {
        sample s = sample_make(&codecs[WIRE_STATUS], &r, VARIANT_SMALLEST);
        for (int n = 0; n < s.layout.count; n++) {
            const mark *mk = &s.layout.marks[n];
            if (strncmp(mk->name, "worlds[1].shapes[", 17) != 0)
                continue;
            found_shape = 1;
            uint8_t *bytes = copy_bytes(&s, 0);
            bytes[mk->offset + 4] = 'x'; /* the empty shape's NUL */
            wire_error err;
            assert_int_equal(wire_check(WIRE_STATUS, bytes, s.size, &err), -1);
            char expected[160];
            snprintf(expected, sizeof expected, "status_t: %s does not end in NUL at byte %zu", mk->name,
                     mk->offset + 4);
            assert_string_equal(err.what, expected);
            free(bytes);
            break;
        }
        sample_free(&s);
    }
    assert_true(found_shape);
}

static void test_short_absent_and_oversized_input_is_rejected(void **state)
{
    (void)state;
    wire_error err;
    uint8_t fingerprint[8];
    for (int t = 0; t < WIRE_TYPE_COUNT; t++) {
        store_i64(fingerprint, wire_fingerprint((wire_type)t));
        for (size_t len = 0; len < 8; len++) {
            assert_int_equal(wire_check((wire_type)t, fingerprint, len, &err), -1);
            assert_int_equal(err.offset, 0);
            char expected[160];
            snprintf(expected, sizeof expected, "%s: fingerprint needs 8 bytes, %zu remain at byte 0",
                     codecs[t].name, len);
            assert_string_equal(err.what, expected);
        }
        /* The fingerprint alone is a message cut short. */
        assert_int_equal(wire_check((wire_type)t, fingerprint, 8, &err), -1);
        assert_int_equal(err.offset, 8);
        assert_int_equal(wire_check((wire_type)t, NULL, 0, &err), -1);
        assert_int_equal(wire_check((wire_type)t, NULL, 100, NULL), -1);
        /* Refused on the size alone: not one byte is read. */
        assert_int_equal(wire_check((wire_type)t, fingerprint, (size_t)INT32_MAX + 1, &err), -1);
        assert_non_null(strstr(err.what, "more than LCM can encode"));
    }
    assert_int_equal(wire_check(WIRE_TYPE_COUNT, fingerprint, 8, &err), -1);
    assert_string_equal(err.what, "wire type 16 is unknown");
    assert_int_equal(wire_check((wire_type)-3, fingerprint, 8, NULL), -1);
}

/* ---------- random mutation: validator and generated decoder agree ---------- */

enum { FUZZ_ITERATIONS_PER_TYPE = 20000, FUZZ_MAX_GROWTH = 16 };

typedef struct fuzz_tally {
    int accepted, rejected, reshaped_accepted;
} fuzz_tally;

static int32_t interesting_i32(rng *r, const sample *s)
{
    switch (rng_next(r) % 5) {
    case 0:
        return (int32_t)(rng_next(r) % 8) - 2;
    case 1:
        return (int32_t)(rng_next(r) % (s->size + 8));
    case 2:
        return INT32_MIN + (int32_t)(rng_next(r) % 4);
    case 3:
        return INT32_MAX - (int32_t)(rng_next(r) % 4);
    default:
        return random_i32(r);
    }
}

static const mark *random_mark(rng *r, const sample *s, mark_kind kind)
{
    int matching = 0;
    for (int i = 0; i < s->layout.count; i++)
        matching += s->layout.marks[i].kind == kind;
    if (matching == 0)
        return NULL;
    int pick = (int)(rng_next(r) % (uint64_t)matching);
    for (int i = 0; i < s->layout.count; i++)
        if (s->layout.marks[i].kind == kind && pick-- == 0)
            return &s->layout.marks[i];
    return NULL;
}

/* Lengthens or shortens one string and moves the rest of the message with it: mostly a
 * valid message of another shape, sometimes (an inserted NUL) not. Returns the new size. */
static size_t reshape_string(rng *r, const sample *s, uint8_t *bytes)
{
    const mark *mk = random_mark(r, s, MARK_STRING);
    size_t text_at = mk->offset + 4;
    size_t size = s->size;
    if (mk->value >= 2 && rng_next(r) % 2) {
        size_t cut = 1 + rng_next(r) % (size_t)(mk->value - 1);
        memmove(bytes + text_at, bytes + text_at + cut, size - text_at - cut);
        store_i32(bytes + mk->offset, mk->value - (int32_t)cut);
        return size - cut;
    }
    size_t grow = 1 + rng_next(r) % FUZZ_MAX_GROWTH;
    memmove(bytes + text_at + grow, bytes + text_at, size - text_at);
    for (size_t i = 0; i < grow; i++)
        bytes[text_at + i] = rng_next(r) % 16 ? (uint8_t)(1 + rng_next(r) % 255) : 0;
    store_i32(bytes + mk->offset, mk->value + (int32_t)grow);
    return size + grow;
}

/* One random mutation of the sample into bytes (capacity size + FUZZ_MAX_GROWTH); returns
 * the new size and whether it reshaped a string. */
static size_t mutate(rng *r, const sample *s, uint8_t *bytes, int *reshaped)
{
    memcpy(bytes, s->bytes, s->size);
    *reshaped = 0;
    switch (rng_next(r) % 6) {
    case 0: {
        int flips = 1 + (int)(rng_next(r) % 4);
        for (int i = 0; i < flips; i++)
            bytes[rng_next(r) % s->size] ^= (uint8_t)(1u << (rng_next(r) % 8));
        return s->size;
    }
    case 1:
        store_i32(bytes + rng_next(r) % (s->size - 3), interesting_i32(r, s));
        return s->size;
    case 2: {
        const mark *mk = &s->layout.marks[rng_next(r) % (uint64_t)s->layout.count];
        int32_t value = rng_next(r) % 2 ? mk->value + (int32_t)(rng_next(r) % 7) - 3 : interesting_i32(r, s);
        store_i32(bytes + mk->offset, value);
        return s->size;
    }
    case 3:
    case 4:
        *reshaped = 1;
        return reshape_string(r, s, bytes);
    default: {
        if (rng_next(r) % 2)
            return rng_next(r) % s->size;
        size_t extra = 1 + rng_next(r) % FUZZ_MAX_GROWTH;
        for (size_t i = 0; i < extra; i++)
            bytes[s->size + i] = (uint8_t)rng_next(r);
        return s->size + extra;
    }
    }
}

static void test_mutations_agree_with_generated_decoder(void **state)
{
    (void)state;
    for (int t = 0; t < WIRE_TYPE_COUNT; t++) {
        const codec *k = &codecs[t];
        sample s[SAMPLES_PER_TYPE];
        samples_make(k, test_seed() + 9, s);
        rng r = rng_seeded(test_seed() ^ (0xf00dull + (uint64_t)t));
        fuzz_tally tally = {0};
        for (int it = 0; it < FUZZ_ITERATIONS_PER_TYPE; it++) {
            const sample *base = &s[rng_next(&r) % SAMPLES_PER_TYPE];
            size_t capacity = base->size + FUZZ_MAX_GROWTH;
            uint8_t *bytes = malloc(capacity);
            assert_non_null(bytes);
            int reshaped;
            size_t size = mutate(&r, base, bytes, &reshaped);
            /* Exactly size bytes, so ASan catches a read past the end. */
            uint8_t *exact = malloc(size ? size : 1);
            assert_non_null(exact);
            memcpy(exact, bytes, size);
            wire_error err;
            if (wire_check(k->type, exact, size, &err) == 0) {
                assert_decodes_to_same_bytes(k, exact, size);
                tally.accepted++;
                tally.reshaped_accepted += reshaped;
            } else {
                assert_true(err.offset <= size);
                assert_true(err.what[0] != '\0');
                tally.rejected++;
            }
            free(exact);
            free(bytes);
        }
        print_message("%s: %d accepted (%d with a string resized), %d rejected\n", k->name, tally.accepted,
                      tally.reshaped_accepted, tally.rejected);
        assert_true(tally.accepted > FUZZ_ITERATIONS_PER_TYPE / 10);
        assert_true(tally.rejected > FUZZ_ITERATIONS_PER_TYPE / 10);
        assert_true(tally.reshaped_accepted > FUZZ_ITERATIONS_PER_TYPE / 20);
        samples_free(s);
    }
}

int main(void)
{
    printf("test_wire_check: seed %llu (set TRIOCT_SEED to rerun with another)\n",
           (unsigned long long)test_seed());
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_type_names_and_fingerprints_match_generated_code),
        cmocka_unit_test(test_encoded_messages_start_with_the_fingerprint),
        cmocka_unit_test(test_encoded_messages_are_accepted),
        cmocka_unit_test(test_smallest_elements_fill_the_message_exactly),
        cmocka_unit_test(test_every_truncation_is_rejected),
        cmocka_unit_test(test_appended_bytes_are_rejected),
        cmocka_unit_test(test_foreign_fingerprints_are_rejected),
        cmocka_unit_test(test_bad_counts_are_rejected),
        cmocka_unit_test(test_bad_strings_are_rejected),
        cmocka_unit_test(test_ray_request_errors_name_field_and_byte),
        cmocka_unit_test(test_ray_request_contact_byte_and_the_old_type),
        cmocka_unit_test(test_world_errors_name_the_element),
        cmocka_unit_test(test_short_absent_and_oversized_input_is_rejected),
        cmocka_unit_test(test_mutations_agree_with_generated_decoder),
    };
    return cmocka_run_group_tests_name("wire_check", tests, NULL, NULL);
}
