#include "replay_compare.h"

#include <inttypes.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#include "trioct_admin_reply_t.h"
#include "trioct_contact_t.h"
#include "trioct_mesh_pair_t.h"
#include "trioct_object_reply_t.h"
#include "trioct_distance_reply_t.h"
#include "trioct_state_reply_t.h"
#include "trioct_ray_hit_t.h"
#include "trioct_ray_request_t.h"
#include "trioct_status.h"
#include "trioct_world_info_t.h"

int replay_ignore_parse(const char *word, unsigned *bits)
{
    if (strcmp(word, "queries") == 0)
        *bits |= REPLAY_IGNORE_QUERIES;
    else if (strcmp(word, "version") == 0)
        *bits |= REPLAY_IGNORE_VERSION;
    else if (strcmp(word, "message") == 0)
        *bits |= REPLAY_IGNORE_MESSAGE;
    else
        return -1;
    return 0;
}

void replay_format_double(double v, char *buf, size_t len)
{
    for (int digits = 15; digits <= 17; digits++) {
        snprintf(buf, len, "%.*g", digits, v);
        if (strtod(buf, NULL) == v || v != v)
            return;
    }
}

void replay_canon_text(int status, const char *text, const char *world_dir, char *out, size_t len)
{
    /* dispatch.c: "deadline_utime D passed E us before the work could start". A text
     * already canonical says "passed N us". */
    static const char mark[] = " passed ";
    size_t used = 0, dir_len = world_dir != NULL && strcmp(world_dir, "/") != 0 ? strlen(world_dir) : 0;
    const char *at = status == TRIOCT_ERR_DEADLINE ? strstr(text, mark) : NULL;
    const char *skip_from = NULL, *skip_to = NULL;
    if (at != NULL) {
        skip_from = at + sizeof mark - 1;
        skip_to = skip_from;
        while (*skip_to >= '0' && *skip_to <= '9')
            skip_to++;
        if (skip_to == skip_from && *skip_to == 'N')
            skip_to++;
    }
    if (len == 0)
        return;
    for (const char *p = text; *p != '\0' && used + 1 < len;) {
        if (p == skip_from) {
            out[used++] = 'N';
            p = skip_to;
        } else if (dir_len > 0 && strncmp(p, world_dir, dir_len) == 0 && (p[dir_len] == '/' || p[dir_len] == '\0')) {
            out[used++] = '.';
            p += dir_len;
        } else {
            out[used++] = *p++;
        }
    }
    out[used] = '\0';
}

/* ---------- the differences, as lines ---------- */

typedef struct diff {
    FILE *out;
    const char *what;
    size_t max, count;
} diff;

static void say(diff *d, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void say(diff *d, const char *fmt, ...)
{
    if (d->count++ >= d->max || d->out == NULL)
        return;
    fprintf(d->out, "%s: ", d->what);
    va_list ap;
    va_start(ap, fmt);
    vfprintf(d->out, fmt, ap);
    va_end(ap);
    fputc('\n', d->out);
}

/* where: "ray 3: " or "" */
static void cmp_i64(diff *d, const char *where, const char *field, int64_t a, int64_t b)
{
    if (a != b)
        say(d, "%s%s expected %" PRId64 " got %" PRId64, where, field, a, b);
}

static int same_bits(double a, double b)
{
    uint64_t x, y;
    memcpy(&x, &a, sizeof x);
    memcpy(&y, &b, sizeof y);
    return x == y;
}

static void cmp_f64(diff *d, const char *where, const char *field, double a, double b)
{
    if (same_bits(a, b))
        return;
    char sa[40], sb[40];
    replay_format_double(a, sa, sizeof sa);
    replay_format_double(b, sb, sizeof sb);
    say(d, "%s%s expected %s got %s", where, field, sa, sb);
}

static void cmp_vec(diff *d, const char *where, const char *field, const trioct_vec3_t *a,
                    const trioct_vec3_t *b)
{
    char name[48];
    snprintf(name, sizeof name, "%s.x", field);
    cmp_f64(d, where, name, a->x, b->x);
    snprintf(name, sizeof name, "%s.y", field);
    cmp_f64(d, where, name, a->y, b->y);
    snprintf(name, sizeof name, "%s.z", field);
    cmp_f64(d, where, name, a->z, b->z);
}

static void cmp_str(diff *d, const char *where, const char *field, const char *a, const char *b)
{
    if (strcmp(a, b) != 0)
        say(d, "%s%s expected \"%s\" got \"%s\"", where, field, a, b);
}

/* ---------- records grouped by the item they belong to ---------- */

/* The records of each item (ray, query triangle, pose), in record order: start[i] ..
 * start[i + 1] index into order[]. Records naming no item of the reply go to the end. */
typedef struct groups {
    size_t *start; /* items + 2 entries */
    size_t *order;
    size_t stray;  /* records naming an item out of range */
} groups;

typedef int32_t (*item_of_fn)(const void *record);

static int32_t hit_ray(const void *r) { return ((const trioct_ray_hit_t *)r)->ray; }
static int32_t contact_query(const void *r) { return ((const trioct_contact_t *)r)->query; }
static int32_t pair_pose(const void *r) { return ((const trioct_mesh_pair_t *)r)->pose; }
static int32_t state_of(const void *r) { return ((const trioct_state_contact_t *)r)->state; }

static int group(groups *g, const replay_reply *r, int32_t items, item_of_fn item_of)
{
    size_t n = items > 0 ? (size_t)items : 0;
    g->start = calloc(n + 2, sizeof *g->start);
    g->order = calloc(r->num_records ? r->num_records : 1, sizeof *g->order);
    g->stray = 0;
    if (g->start == NULL || g->order == NULL)
        return -1;
    for (size_t k = 0; k < r->num_records; k++) {
        int32_t i = item_of(r->records[k]);
        size_t slot = i >= 0 && (size_t)i < n ? (size_t)i : n;
        g->start[slot + 1]++;
    }
    for (size_t i = 1; i <= n + 1; i++)
        g->start[i] += g->start[i - 1];
    size_t *fill = calloc(n + 1, sizeof *fill);
    if (fill == NULL)
        return -1;
    for (size_t k = 0; k < r->num_records; k++) {
        int32_t i = item_of(r->records[k]);
        size_t slot = i >= 0 && (size_t)i < n ? (size_t)i : n;
        g->order[g->start[slot] + fill[slot]++] = k;
    }
    free(fill);
    g->stray = g->start[n + 1] - g->start[n];
    return 0;
}

static void groups_free(groups *g)
{
    free(g->start);
    free(g->order);
}

/* ---------- per reply type ---------- */

typedef void (*record_cmp_fn)(diff *d, const char *where, const replay_reply *e, size_t ke,
                              const replay_reply *g, size_t kg);

/* The name a record's object index gives in its reply's table; "(index N: none)" when the
 * index names no entry. Answers are compared by name: indexes are the reply's own. */
static const char *object_name(const replay_reply *r, int32_t object, char *buf, size_t len)
{
    if (object >= 0 && object < r->num_names)
        return r->names[object];
    snprintf(buf, len, "(index %d: none)", object);
    return buf;
}

static void cmp_object(diff *d, const char *where, const replay_reply *e, int32_t a, const replay_reply *g, int32_t b)
{
    char na[40], nb[40];
    cmp_str(d, where, "object", object_name(e, a, na, sizeof na), object_name(g, b, nb, sizeof nb));
}

static void hit_cmp(diff *d, const char *where, const replay_reply *e, size_t ke, const replay_reply *g,
                    size_t kg)
{
    const trioct_ray_hit_t *a = e->records[ke], *b = g->records[kg];
    /* An any-hit answer promises a hit when there is one, not which: which of a ray's hits
     * the walk meets first is the traversal's business. Whether it hit is compared (the
     * ray's found flag and its count of hits). */
    if (e->detail == TRIOCT_RAY_REQUEST_T_ANY)
        return;
    cmp_f64(d, where, "t", a->t, b->t);
    cmp_object(d, where, e, a->object, g, b->object);
    cmp_i64(d, where, "triangle", a->triangle, b->triangle);
    cmp_f64(d, where, "u", a->u, b->u);
    cmp_f64(d, where, "v", a->v, b->v);
    cmp_vec(d, where, "normal", &a->normal, &b->normal);
}

static void contact_cmp(diff *d, const char *where, const replay_reply *e, size_t ke, const replay_reply *g,
                        size_t kg)
{
    const trioct_contact_t *a = e->records[ke], *b = g->records[kg];
    cmp_object(d, where, e, a->object, g, b->object);
    cmp_i64(d, where, "world triangle", a->triangle, b->triangle);
    /* SEGMENTS: the segment of contact k is segment k. */
    if (ke < e->num_segments && kg < g->num_segments) {
        cmp_vec(d, where, "segment p", &e->segments[ke]->p, &g->segments[kg]->p);
        cmp_vec(d, where, "segment q", &e->segments[ke]->q, &g->segments[kg]->q);
    }
}

static void pair_cmp(diff *d, const char *where, const replay_reply *e, size_t ke, const replay_reply *g,
                     size_t kg)
{
    const trioct_mesh_pair_t *a = e->records[ke], *b = g->records[kg];
    cmp_i64(d, where, "shape triangle", a->shape_triangle, b->shape_triangle);
    cmp_object(d, where, e, a->object, g, b->object);
    cmp_i64(d, where, "world triangle", a->world_triangle, b->world_triangle);
}

static void state_cmp(diff *d, const char *where, const replay_reply *e, size_t ke, const replay_reply *g, size_t kg)
{
    const trioct_state_contact_t *a = e->records[ke], *b = g->records[kg];
    cmp_i64(d, where, "link", a->link, b->link);
    cmp_i64(d, where, "with_link", a->with_link, b->with_link);
    if (a->with_link && b->with_link)
        cmp_i64(d, where, "other link", a->other, b->other);
    else if (!a->with_link && !b->with_link)
        cmp_object(d, where, e, a->other, g, b->other);
    cmp_i64(d, where, "link triangle", a->link_triangle, b->link_triangle);
    cmp_i64(d, where, "other triangle", a->other_triangle, b->other_triangle);
}

typedef struct item_kind {
    const char *item;   /* "ray" */
    const char *record; /* "hit" */
    item_of_fn item_of;
    record_cmp_fn cmp;
} item_kind;

static const item_kind ray_kind = {"ray", "hit", hit_ray, hit_cmp};
static const item_kind tri_kind = {"triangle", "contact", contact_query, contact_cmp};
static const item_kind mesh_kind = {"pose", "pair", pair_pose, pair_cmp};
static const item_kind state_kind = {"state", "contact", state_of, state_cmp};

static void cmp_items(diff *d, const replay_reply *e, const replay_reply *g, const item_kind *k)
{
    if (e->num_items != g->num_items) {
        say(d, "%ss expected %d got %d", k->item, e->num_items, g->num_items);
        return;
    }
    groups ge, gg;
    if (group(&ge, e, e->num_items, k->item_of) < 0 || group(&gg, g, g->num_items, k->item_of) < 0) {
        say(d, "out of memory comparing");
        groups_free(&ge);
        groups_free(&gg);
        return;
    }
    if (e->num_segments != g->num_segments)
        say(d, "segments expected %zu got %zu", e->num_segments, g->num_segments);
    for (int32_t i = 0; i <= e->num_items; i++) {
        char where[96];
        size_t ne = ge.start[i + 1] - ge.start[i], ng = gg.start[i + 1] - gg.start[i];
        if (i == e->num_items) {
            if (ne != ng)
                say(d, "%ss naming no %s of the request: expected %zu got %zu", k->record, k->item, ne, ng);
            break;
        }
        snprintf(where, sizeof where, "%s %d: ", k->item, i);
        if (e->found[i] != g->found[i])
            say(d, "%sfound expected %d got %d", where, e->found[i], g->found[i]);
        if (ne != ng) {
            say(d, "%s%zu %ss expected, got %zu", where, ne, k->record, ng);
            continue;
        }
        for (size_t j = 0; j < ne; j++) {
            if (ne > 1)
                snprintf(where, sizeof where, "%s %d %s %zu: ", k->item, i, k->record, j);
            k->cmp(d, where, e, ge.order[ge.start[i] + j], g, gg.order[gg.start[i] + j]);
        }
    }
    groups_free(&ge);
    groups_free(&gg);
}

static void cmp_world(diff *d, const char *where, const trioct_world_info_t *a, const trioct_world_info_t *b,
                      const replay_rules *rules)
{
    unsigned ignore = rules->ignore;
    cmp_str(d, where, "daemon", a->daemon, b->daemon);
    if (!(ignore & REPLAY_IGNORE_VERSION))
        cmp_i64(d, where, "version", a->version, b->version);
    cmp_str(d, where, "source", a->source, b->source);
    cmp_str(d, where, "accuracy", a->accuracy, b->accuracy);
    cmp_f64(d, where, "seed_epsilon", a->seed_epsilon, b->seed_epsilon);
    cmp_i64(d, where, "effects", a->effects, b->effects);
    cmp_i64(d, where, "triangles", a->triangles, b->triangles);
    cmp_i64(d, where, "vertices", a->vertices, b->vertices);
    cmp_i64(d, where, "degenerate", a->degenerate, b->degenerate);
    cmp_i64(d, where, "duplicates", a->duplicates, b->duplicates);
    cmp_vec(d, where, "bbox_min", &a->bbox_min, &b->bbox_min);
    cmp_vec(d, where, "bbox_max", &a->bbox_max, &b->bbox_max);
    cmp_i64(d, where, "nodes", a->nodes, b->nodes);
    cmp_i64(d, where, "leaves", a->leaves, b->leaves);
    cmp_i64(d, where, "max_level", a->max_level, b->max_level);
    cmp_f64(d, where, "resolution", a->resolution, b->resolution);
    cmp_f64(d, where, "world_size", a->world_size, b->world_size);
    cmp_vec(d, where, "world_min", &a->world_min, &b->world_min);
    cmp_i64(d, where, "bytes_nodes", a->bytes_nodes, b->bytes_nodes);
    cmp_i64(d, where, "bytes_leaf_lists", a->bytes_leaf_lists, b->bytes_leaf_lists);
    cmp_i64(d, where, "bytes_triangles", a->bytes_triangles, b->bytes_triangles);
    cmp_i64(d, where, "bytes_effects", a->bytes_effects, b->bytes_effects);
    cmp_i64(d, where, "bytes_total", a->bytes_total, b->bytes_total);
    /* build_seconds, load_seconds: wall clock, never compared. */
    if (!(ignore & REPLAY_IGNORE_QUERIES))
        cmp_i64(d, where, "queries", a->queries, b->queries);
    char ea[TRIOCT_MAX_MESSAGE_LEN + 8], eb[TRIOCT_MAX_MESSAGE_LEN + 8];
    replay_canon_text(0, a->last_error, rules->world_dir, ea, sizeof ea);
    replay_canon_text(0, b->last_error, rules->world_dir, eb, sizeof eb);
    cmp_str(d, where, "last_error", ea, eb);
    if (a->num_shapes != b->num_shapes) {
        say(d, "%sshapes expected %d got %d", where, a->num_shapes, b->num_shapes);
        return;
    }
    for (int32_t s = 0; s < a->num_shapes; s++) {
        char field[32];
        snprintf(field, sizeof field, "shape %d", s);
        cmp_str(d, where, field, a->shapes[s], b->shapes[s]);
    }
}

/* "[yard cell]" */
static void world_names(const replay_reply *r, char *buf, size_t len)
{
    size_t used = 0;
    buf[0] = '\0';
    used += (size_t)snprintf(buf, len, "[");
    for (size_t k = 0; k < r->num_records && used < len; k++) {
        const trioct_world_info_t *w = r->records[k];
        used += (size_t)snprintf(buf + used, len - used, "%s%s", k ? " " : "", w->name);
    }
    if (used < len)
        snprintf(buf + used, len - used, "]");
}

static void cmp_worlds(diff *d, const replay_reply *e, const replay_reply *g, const replay_rules *rules)
{
    if (e->num_records != g->num_records) {
        char a[256], b[256];
        world_names(e, a, sizeof a);
        world_names(g, b, sizeof b);
        say(d, "worlds expected %s got %s", a, b);
        return;
    }
    for (size_t k = 0; k < e->num_records; k++) {
        const trioct_world_info_t *a = e->records[k], *b = g->records[k];
        char where[96];
        if (strcmp(a->name, b->name) != 0) {
            say(d, "world %zu: name expected \"%s\" got \"%s\"", k, a->name, b->name);
            continue;
        }
        snprintf(where, sizeof where, "world %zu (%s): ", k, a->name);
        cmp_world(d, where, a, b, rules);
    }
}

/* Object replies: the edit that failed, the version's counts and the listing, in order. */
/* Distance results, one an item in item order: every field, bit for bit (the bounds are
 * the engine's deterministic arithmetic), the object by name. */
static void cmp_distances(diff *d, const replay_reply *e, const replay_reply *g)
{
    if (e->num_records != g->num_records) {
        say(d, "distance results expected %zu got %zu", e->num_records, g->num_records);
        return;
    }
    for (size_t k = 0; k < e->num_records; k++) {
        const trioct_distance_result_t *a = e->records[k], *b = g->records[k];
        char where[64];
        snprintf(where, sizeof where, "result %zu: ", k);
        cmp_i64(d, where, "item", a->item, b->item);
        cmp_i64(d, where, "found", a->found, b->found);
        cmp_i64(d, where, "clear", a->clear, b->clear);
        cmp_f64(d, where, "distance", a->distance, b->distance);
        cmp_f64(d, where, "bound", a->bound, b->bound);
        cmp_f64(d, where, "lower", a->lower, b->lower);
        cmp_f64(d, where, "upper", a->upper, b->upper);
        cmp_vec(d, where, "point", &a->point, &b->point);
        cmp_vec(d, where, "shape_point", &a->shape_point, &b->shape_point);
        if (a->found && b->found)
            cmp_object(d, where, e, a->object, g, b->object);
        else
            cmp_i64(d, where, "object", a->object, b->object);
        cmp_i64(d, where, "triangle", a->triangle, b->triangle);
        cmp_i64(d, where, "shape_triangle", a->shape_triangle, b->shape_triangle);
        cmp_i64(d, where, "feature", a->feature, b->feature);
        cmp_i64(d, where, "feature_index", a->feature_index, b->feature_index);
        cmp_i64(d, where, "inside", a->inside, b->inside);
    }
}

static void cmp_objects(diff *d, const replay_reply *e, const replay_reply *g)
{
    const trioct_object_reply_t *a = e->chunk[0], *b = g->chunk[0];
    if (a != NULL && b != NULL) {
        cmp_i64(d, "", "failed_edit", a->failed_edit, b->failed_edit);
        cmp_i64(d, "", "objects", a->objects, b->objects);
        cmp_i64(d, "", "triangles", a->triangles, b->triangles);
    }
    if (e->num_records != g->num_records) {
        say(d, "objects listed expected %zu got %zu", e->num_records, g->num_records);
        return;
    }
    for (size_t k = 0; k < e->num_records; k++) {
        const trioct_object_info_t *x = e->records[k], *y = g->records[k];
        char where[96];
        snprintf(where, sizeof where, "object %zu (%s): ", k, x->name);
        cmp_str(d, where, "name", x->name, y->name);
        cmp_str(d, where, "mesh", x->mesh, y->mesh);
        cmp_i64(d, where, "triangles", x->triangles, y->triangles);
        for (int i = 0; i < 9; i++) {
            char field[24];
            snprintf(field, sizeof field, "pose.r[%d]", i);
            cmp_f64(d, where, field, x->pose.r[i], y->pose.r[i]);
        }
        cmp_vec(d, where, "pose.t", &x->pose.t, &y->pose.t);
        cmp_vec(d, where, "bbox_min", &x->bbox_min, &y->bbox_min);
        cmp_vec(d, where, "bbox_max", &x->bbox_max, &y->bbox_max);
        cmp_i64(d, where, "bytes", x->bytes, y->bytes);
        cmp_i64(d, where, "shared", x->shared, y->shared);
    }
}

size_t replay_compare(const replay_reply *expected, const replay_reply *got, const replay_rules *rules,
                      const char *what, FILE *out, size_t max_lines)
{
    unsigned ignore = rules->ignore;
    diff d = {out, what, max_lines, 0};
    const replay_reply *e = expected, *g = got;
    if (e->problem[0])
        say(&d, "the expected reply is damaged: %s", e->problem);
    if (g->problem[0])
        say(&d, "the reply is damaged: %s", g->problem);
    if (e->type != g->type) {
        say(&d, "a %s expected, got a %s", wire_type_name(e->type), wire_type_name(g->type));
        goto done;
    }
    if (strcmp(e->channel, g->channel) != 0)
        say(&d, "reply channel expected %s got %s", e->channel, g->channel);
    if (e->header == NULL || g->header == NULL)
        goto done; /* no chunk decoded: the problem says why */

    const trioct_reply_header_t *he = e->header, *hg = g->header;
    cmp_str(&d, "", "daemon", he->daemon, hg->daemon);
    cmp_str(&d, "", "world", he->world, hg->world);
    if (!(ignore & REPLAY_IGNORE_VERSION))
        cmp_i64(&d, "", "world_version", he->world_version, hg->world_version);
    if (he->status != hg->status)
        say(&d, "status expected %s got %s", trioct_status_name(he->status), trioct_status_name(hg->status));
    if (!(ignore & REPLAY_IGNORE_MESSAGE)) {
        char ce[TRIOCT_MAX_MESSAGE_LEN + 8], cg[TRIOCT_MAX_MESSAGE_LEN + 8];
        replay_canon_text(he->status, he->message, rules->world_dir, ce, sizeof ce);
        replay_canon_text(hg->status, hg->message, rules->world_dir, cg, sizeof cg);
        cmp_str(&d, "", "message", ce, cg);
    }
    /* Another status: the rest of the reply is another kind of answer altogether. */
    if (he->status != hg->status)
        goto done;
    if (e->detail != g->detail)
        say(&d, "%s expected %d got %d", e->type == WIRE_ADMIN_REPLY ? "op" : "detail", e->detail, g->detail);

    switch (e->type) {
    case WIRE_RAY_REPLY:
        cmp_items(&d, e, g, &ray_kind);
        break;
    case WIRE_TRIANGLE_REPLY:
        cmp_items(&d, e, g, &tri_kind);
        break;
    case WIRE_MESH_REPLY:
        cmp_items(&d, e, g, &mesh_kind);
        break;
    case WIRE_OBJECT_REPLY:
        cmp_objects(&d, e, g);
        break;
    case WIRE_STATE_REPLY:
        cmp_items(&d, e, g, &state_kind);
        break;
    case WIRE_DISTANCE_REPLY:
        cmp_distances(&d, e, g);
        break;
    default:
        cmp_worlds(&d, e, g, rules);
        break;
    }
done:
    if (d.count > d.max && out != NULL)
        fprintf(out, "%s: ... and %zu more differences\n", what, d.count - d.max);
    return d.count;
}
