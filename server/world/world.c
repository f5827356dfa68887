/* Building a world from its spec: resolve every file inside the world directory, load and
 * merge the meshes, apply the scene's transform, build the octree; and the reference
 * count that lets a rebuilt version replace a world while queries finish on the old one. */
/* realpath is an XSI function: POSIX 2008 alone does not declare it. */
#define _XOPEN_SOURCE 700

#include "world.h"

#include <errno.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "../../common/channels.h"
#include "../../common/trioct_status.h"
#include "../geom/vec3.h"
#include "error_text.h"
#include "solid_check.h"


/* ---------- paths ---------- */

/* 1 when some '/'-separated component of rel is exactly "..". */
static int has_parent_component(const char *rel)
{
    const char *at = rel;
    for (;;) {
        const char *slash = strchr(at, '/');
        size_t n = slash ? (size_t)(slash - at) : strlen(at);
        if (n == 2 && at[0] == '.' && at[1] == '.')
            return 1;
        if (!slash)
            return 0;
        at = slash + 1;
    }
}

/* 1 when path is dir itself or below it; both are canonical (realpath) paths. */
static int is_inside(const char *dir, const char *path)
{
    size_t n = strlen(dir);
    if (n == 1 && dir[0] == '/')
        return path[0] == '/';
    return strncmp(dir, path, n) == 0 && (path[n] == '/' || path[n] == '\0');
}

/* The root of roots that holds resolved, or NULL. A root that does not resolve holds
 * nothing (the daemon checked them all at start). */
static const char *root_holding(const mesh_roots *roots, const char *resolved)
{
    for (size_t i = 0; roots && i < roots->count; i++) {
        char *root = realpath(roots->paths[i], NULL);
        int inside = root != NULL && is_inside(root, resolved);
        free(root);
        if (inside)
            return roots->paths[i];
    }
    return NULL;
}

int world_resolve_path(const char *world_dir, const char *rel, char *out, size_t out_len,
                       char *err, size_t err_len)
{
    return world_resolve_path_in(world_dir, NULL, rel, out, out_len, err, err_len);
}

int world_resolve_path_in(const char *world_dir, const mesh_roots *roots, const char *rel, char *out,
                          size_t out_len, char *err, size_t err_len)
{
    if (out && out_len)
        out[0] = '\0';
    int have_roots = roots != NULL && roots->count > 0;
    int absolute = rel && rel[0] == '/';
    if (!world_dir || !world_dir[0])
        return error_text(err, err_len, "no world directory is set");
    if (!rel || !rel[0])
        return error_text(err, err_len, "empty file path");
    if (absolute && !have_roots)
        return error_text(err, err_len, "%s: absolute paths are refused; give a path relative to the world directory "
                          "(or name its directory as a mesh_root)", rel);
    if (has_parent_component(rel))
        return error_text(err, err_len, "%s: '..' is refused in paths", rel);

    char *dir = realpath(world_dir, NULL);
    if (!dir)
        return error_text(err, err_len, "world directory %s: %s", world_dir, strerror(errno));
    char *joined = NULL; /* a relative path, joined to the world directory */
    if (!absolute) {
        size_t joined_len = strlen(dir) + 1 + strlen(rel) + 1;
        if (!(joined = malloc(joined_len))) {
            free(dir);
            return error_text(err, err_len, "%s: out of memory", rel);
        }
        snprintf(joined, joined_len, "%s/%s", dir, rel);
    }
    char *resolved = realpath(absolute ? rel : joined, NULL);
    int why = errno;
    free(joined);
    int status = 0;
    /* An absolute path may lead into a root only; a relative one into the world directory
     * or a root. */
    int allowed = resolved && ((!absolute && is_inside(dir, resolved)) || root_holding(roots, resolved) != NULL);
    if (!resolved && absolute)
        status = error_text(err, err_len, "%s: %s", rel, strerror(why));
    else if (!resolved)
        status = error_text(err, err_len, "%s: %s (in world directory %s)", rel, strerror(why), world_dir);
    else if (!allowed && absolute)
        status = error_text(err, err_len, "%s: lies outside every mesh_root (it resolves to %s)", rel, resolved);
    else if (!allowed)
        status = error_text(err, err_len, "%s: leads outside the world directory %s%s (to %s)", rel, world_dir,
                            have_roots ? " and every mesh_root" : "", resolved);
    else if (!out || strlen(resolved) >= out_len)
        status = error_text(err, err_len, "%s: resolved path longer than %zu characters", rel,
                           out_len ? out_len - 1 : 0);
    else
        memcpy(out, resolved, strlen(resolved) + 1);
    free(resolved);
    free(dir);
    return status;
}

/* ---------- building ---------- */

static atomic_size_t live_worlds;

size_t world_live_count(void) { return atomic_load(&live_worlds); }

/* What one build is doing, so the failure paths name the file at hand. */
typedef struct world_builder {
    const world_spec *spec;
    const char *world_dir;
    int status;
    char *err;
    size_t err_len;
    mesh_data merged;
    size_t triangle_start[SCENE_MAX_MESHES]; /* first merged triangle of each mesh file */
    mesh_load_report merged_report;
    int merging; /* building a section's merged meshes: a triangle index names a file */
    world *w;
    const world_env *env;
    size_t budget;      /* the world's memory budget; SIZE_MAX: none */
    size_t world_bytes; /* what the world holds, and this build has added, so far */
    size_t mesh_held;   /* mesh bytes taken from the account and not yet handed to a model */
    double load_seconds; /* spent reading mesh files so far */
} world_builder;

const char *world_phase_name(int phase)
{
    return phase == WORLD_PHASE_READING ? "reading meshes" : phase == WORLD_PHASE_BUILDING ? "building octrees" : "queued";
}

static void note_building(world_builder *b)
{
    if (b->env && b->env->progress)
        atomic_store(&b->env->progress->phase, WORLD_PHASE_BUILDING);
}

static double monotonic_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec / 1e9;
}

static int build_fail(world_builder *b, int status, const char *format, ...)
    __attribute__((format(printf, 3, 4)));
static int build_fail(world_builder *b, int status, const char *format, ...)
{
    b->status = status;
    va_list args;
    va_start(args, format);
    error_vtext(b->err, b->err_len, format, args);
    va_end(args);
    return -1;
}

static memory_account *builder_account(const world_builder *b) { return b->env ? b->env->account : NULL; }

/* What the world's budget and the daemon's account both still allow. */
static size_t builder_room(const world_builder *b)
{
    size_t room = b->budget > b->world_bytes ? b->budget - b->world_bytes : 0;
    memory_account *account = builder_account(b);
    if (account && memory_account_left(account) < room)
        room = memory_account_left(account);
    return room;
}

/* Bytes for a person: "740 bytes", "64 KiB", "12.5 MiB", "2 GiB". */
static const char *bytes_text(size_t bytes, char buf[32])
{
    static const char *const units[] = {"bytes", "KiB", "MiB", "GiB", "TiB"};
    double v = (double)bytes;
    size_t u = 0;
    while (v >= 1024.0 && u + 1 < sizeof units / sizeof units[0]) {
        v /= 1024.0;
        u++;
    }
    if (u == 0 || v == (double)(size_t)v)
        snprintf(buf, 32, "%zu %s", (size_t)v, units[u]);
    else
        snprintf(buf, 32, "%.1f %s", v, units[u]);
    return buf;
}

/* A refusal for memory, saying both budgets and what they hold, after why (the need). */
static int budget_fail(world_builder *b, const char *why)
{
    char world_part[96] = "no budget of its own", daemon_part[128] = "the daemon has no budget";
    char a[32], c[32];
    if (b->budget != SIZE_MAX)
        snprintf(world_part, sizeof world_part, "a memory_budget of %s, %s of it in use", bytes_text(b->budget, a),
                 bytes_text(b->world_bytes, c));
    memory_account *account = builder_account(b);
    if (account && account->limit != SIZE_MAX)
        snprintf(daemon_part, sizeof daemon_part, "the daemon's memory_budget is %s, %s of it in use",
                 bytes_text(account->limit, a), bytes_text(memory_account_used(account), c));
    return build_fail(b, TRIOCT_ERR_BUDGET, "world '%s': %s (the world has %s; %s)", b->spec->name, why, world_part,
                      daemon_part);
}

/* Resolves and loads one file, in the env's loader child when it has one, and takes the
 * mesh's bytes from the account; the loader's message already names the file (and the
 * triangle of a NaN/Inf coordinate). */
static int read_file(world_builder *b, const char *rel, const char *path, size_t room, mesh_data *mesh,
                     mesh_load_report *report, char *why, size_t why_len);

/* up = y: a Y-up file's vertices in trioct's z-up frame. A quarter turn about x moves
 * coordinates and flips one sign, so no vertex moves off its double and the triangles keep
 * their winding. */
static void turn_to_z_up(mesh_data *mesh, mesh_load_report *report)
{
    for (size_t i = 0; i < mesh->vertex_count; i++) {
        vec3 v = mesh->vertices[i];
        mesh->vertices[i] = (vec3){v.x, -v.z, v.y};
    }
    if (report) {
        vec3 lo = report->bbox_lo, hi = report->bbox_hi;
        report->bbox_lo = (vec3){lo.x, -hi.z, lo.y};
        report->bbox_hi = (vec3){hi.x, -lo.z, hi.y};
    }
}

static int load_file(world_builder *b, const char *rel, mesh_data *mesh, mesh_load_report *report)
{
    char path[TRIOCT_MAX_PATH_LEN];
    char why[TRIOCT_MAX_MESSAGE_LEN];
    if (world_resolve_path_in(b->world_dir, b->env ? b->env->roots : NULL, rel, path, sizeof path, why, sizeof why) != 0)
        return build_fail(b, TRIOCT_ERR_BAD_PATH, "world '%s': %s", b->spec->name, why);
    size_t room = builder_room(b);
    world_progress *progress = b->env ? b->env->progress : NULL;
    if (progress)
        atomic_store(&progress->phase, WORLD_PHASE_READING);
    double started = monotonic_seconds();
    int rc = read_file(b, rel, path, room, mesh, report, why, sizeof why);
    b->load_seconds += monotonic_seconds() - started;
    if (progress && rc == 0) {
        atomic_fetch_add(&progress->files_done, 1);
        atomic_fetch_add(&progress->triangles, (long long)mesh->triangle_count);
    }
    if (rc == 0 && b->spec->up_y)
        turn_to_z_up(mesh, report);
    return rc;
}

/* load_file's work: the file parsed by the loader child (or, without one, in this process)
 * and its mesh's memory taken from the budget. */
static int read_file(world_builder *b, const char *rel, const char *path, size_t room, mesh_data *mesh,
                     mesh_load_report *report, char *why, size_t why_len)
{
    if (b->env && b->env->loader) {
        mesh_load_outcome outcome = mesh_load_child(b->env->loader, path, room, mesh, report, why, why_len);
        if (outcome == MESH_LOAD_OVER_BUDGET)
            return budget_fail(b, why);
        if (outcome == MESH_LOAD_NO_MEMORY)
            return build_fail(b, TRIOCT_ERR_NOMEM, "world '%s': %s", b->spec->name, why);
        if (outcome != MESH_LOAD_OK)
            return build_fail(b, TRIOCT_ERR_LOAD_FAILED, "world '%s': %s", b->spec->name, why);
    } else if (mesh_load_file(path, mesh, report, why, why_len) != 0) {
        return build_fail(b, TRIOCT_ERR_LOAD_FAILED, "world '%s': %s", b->spec->name, why);
    }
    size_t bytes = mesh_data_bytes_for(mesh->vertex_count, mesh->triangle_count);
    memory_account *account = builder_account(b);
    if (bytes > room || (account && memory_account_take(account, bytes) != 0)) {
        char need[32];
        snprintf(why, why_len, "%s: its mesh of %zu triangles needs %s, more than the budget leaves", rel,
                 mesh->triangle_count, bytes_text(bytes, need));
        mesh_data_free(mesh);
        return budget_fail(b, why);
    }
    b->world_bytes += bytes;
    b->mesh_held += account ? bytes : 0;
    return 0;
}

/* A model takes over the account's share of its mesh from the builder. */
static void hand_mesh_to_model(world_builder *b, object_model *m)
{
    memory_account *account = builder_account(b);
    if (!account)
        return;
    size_t bytes = mesh_data_bytes_for(m->mesh.vertex_count, m->mesh.triangle_count);
    if (bytes > b->mesh_held) { /* a mesh made here, not loaded: counted now */
        memory_account_charge(account, bytes - b->mesh_held);
        b->mesh_held = bytes;
    }
    b->mesh_held -= bytes;
    m->account = account;
    m->mesh_accounted = bytes;
}

/* The tree budget of a mesh of n triangles: the engine's own, within what is left. */
static void budget_tree(world_builder *b, octree_def *def, size_t n)
{
    size_t engine = def->budget_bytes ? def->budget_bytes : octree_default_budget(n);
    size_t world_left = b->budget > b->world_bytes ? b->budget - b->world_bytes : 0;
    def->budget_bytes = engine < world_left ? engine : world_left;
    if (def->budget_bytes == 0)
        def->budget_bytes = 1; /* 0 would mean the default */
    def->account = builder_account(b);
}

/* p' = R (s p) + t, in the order the scene documents. */
static vec3 transform_point(const world_transform *tf, vec3 p)
{
    vec3 s = vec3_scale(p, tf->scale);
    const double *r = tf->r;
    return vec3_make(r[0] * s.x + r[1] * s.y + r[2] * s.z + tf->t.x,
                     r[3] * s.x + r[4] * s.y + r[5] * s.z + tf->t.y,
                     r[6] * s.x + r[7] * s.y + r[8] * s.z + tf->t.z);
}

/* The first triangle using a vertex that is not finite, or SIZE_MAX. */
static size_t first_nonfinite_triangle(const mesh_data *mesh)
{
    for (size_t t = 0; t < mesh->triangle_count; t++)
        for (int k = 0; k < 3; k++)
            if (!vec3_is_finite(mesh_data_corner(mesh, t, k)))
                return t;
    return SIZE_MAX;
}

/* A finite file can still overflow under a large scale or translation. */
static int apply_transform(world_builder *b, const char *rel, mesh_data *mesh, mesh_load_report *report)
{
    const world_transform *tf = &b->spec->transform;
    if (tf->identity)
        return 0;
    for (size_t v = 0; v < mesh->vertex_count; v++)
        mesh->vertices[v] = transform_point(tf, mesh->vertices[v]);
    size_t bad = first_nonfinite_triangle(mesh);
    if (bad != SIZE_MAX)
        return build_fail(b, TRIOCT_ERR_LOAD_FAILED,
                          "world '%s': %s: triangle %zu has a coordinate that is not finite after the transform",
                          b->spec->name, rel, bad);
    box3 bounds = mesh_data_bounds(mesh);
    report->bbox_lo = bounds.lo;
    report->bbox_hi = bounds.hi;
    return 0;
}

/* Counts add up; duplicates are those within each file, since files are loaded apart. */
static void add_report(mesh_load_report *sum, const mesh_load_report *one, int first)
{
    sum->meshes += one->meshes;
    sum->triangles += one->triangles;
    sum->skipped_primitives += one->skipped_primitives;
    sum->degenerate += one->degenerate;
    sum->duplicates += one->duplicates;
    sum->bbox_lo = first ? one->bbox_lo : vec3_min(sum->bbox_lo, one->bbox_lo);
    sum->bbox_hi = first ? one->bbox_hi : vec3_max(sum->bbox_hi, one->bbox_hi);
}

static int merge_mesh(world_builder *b, const char *rel, mesh_data *mesh)
{
    if (b->merged.triangle_count == 0) {
        b->merged = *mesh; /* the first file is taken over, not copied */
        memset(mesh, 0, sizeof *mesh);
        return 0;
    }
    if (mesh->vertex_count > UINT32_MAX - 1 - b->merged.vertex_count)
        return build_fail(b, TRIOCT_ERR_LOAD_FAILED, "world '%s': %s: more vertices than the engine addresses",
                          b->spec->name, rel);
    if (mesh_data_append(&b->merged, mesh) != 0)
        return build_fail(b, TRIOCT_ERR_NOMEM, "world '%s': out of memory merging %s", b->spec->name, rel);
    mesh_data_free(mesh);
    return 0;
}

/* The merged triangle index back to its file, for a message a user can act on. */
static size_t mesh_of_triangle(const world_builder *b, size_t triangle)
{
    size_t file = 0;
    while (file + 1 < b->spec->mesh_count && b->triangle_start[file + 1] <= triangle)
        file++;
    return file;
}

/* The build error of a tree, naming the file and the triangle in it. */
static int tree_fail(world_builder *b, const octree_error *oerr, const char *rel, size_t first_triangle)
{
    if (oerr->status == OCTREE_ERR_BUDGET) {
        char why[TRIOCT_MAX_MESSAGE_LEN];
        snprintf(why, sizeof why, "%s: %s", rel, oerr->message);
        return budget_fail(b, why);
    }
    if (oerr->status == OCTREE_ERR_NOMEM)
        return build_fail(b, TRIOCT_ERR_NOMEM, "world '%s': %s: out of memory building the octree", b->spec->name,
                          rel);
    if (oerr->triangle != SIZE_MAX)
        return build_fail(b, TRIOCT_ERR_LOAD_FAILED, "world '%s': %s: triangle %zu: %s: %s", b->spec->name, rel,
                          oerr->triangle - first_triangle, octree_status_text(oerr->status), oerr->message);
    return build_fail(b, TRIOCT_ERR_LOAD_FAILED, "world '%s': %s: %s: %s", b->spec->name, rel,
                      octree_status_text(oerr->status), oerr->message);
}

/* The tree of a world's (or an object's) mesh, with what the effects need. */
static octree_def world_tree_def(const world_spec *spec)
{
    octree_def def = spec->def;
#ifdef OCTREE_HAS_TRIANGLE_BOXES
    def.triangle_boxes = (spec->effects & (EFFECT_TRIANGLES | EFFECT_MESHES | EFFECT_DISTANCE)) != 0;
#endif
    /* Distance walks bound nodes by their triangles' bounds and slabs (docs/engine.md,
     * "Distances"): 88 bytes a node more, which only worlds serving distance pay. */
    if (spec->effects & EFFECT_DISTANCE) {
        def.node_bounds = 1;
        def.node_slabs = 1;
    }
    return def;
}

/* Builds mesh's tree and makes the model (taking the mesh); NULL after build_fail. */
static object_model *make_model(world_builder *b, const char *key, mesh_data *mesh, const mesh_load_report *report,
                                const char *rel)
{
    octree_def def = world_tree_def(b->spec);
    budget_tree(b, &def, mesh->triangle_count);
    mesh_view view = mesh_data_view(mesh);
    octree_error oerr;
    note_building(b);
    octree *tree = octree_build(&view, &def, &oerr);
    if (!tree) {
        if (b->merging && oerr.triangle != SIZE_MAX) {
            size_t file = mesh_of_triangle(b, oerr.triangle);
            tree_fail(b, &oerr, b->spec->meshes[file], b->triangle_start[file]);
        } else {
            tree_fail(b, &oerr, rel, 0);
        }
        return NULL;
    }
    object_model *m = object_model_adopt(key, mesh, tree);
    if (!m) {
        octree_free(tree);
        build_fail(b, TRIOCT_ERR_NOMEM, "world '%s': out of memory for %s", b->spec->name, rel);
        return NULL;
    }
    octree_info info;
    octree_get_info(tree, &info);
    b->world_bytes += info.bytes_total;
    hand_mesh_to_model(b, m);
    if (report)
        m->report = *report;
    snprintf(m->source, sizeof m->source, "%s", rel);
    return m;
}

/* A triangle of the mesh named for a person: in its own file for a section's merged meshes. */
static void triangle_label(const world_builder *b, const char *rel, size_t triangle, char *buf, size_t len)
{
    if (triangle == SIZE_MAX) {
        snprintf(buf, len, "no other triangle");
    } else if (b->merging) {
        size_t file = mesh_of_triangle(b, triangle);
        snprintf(buf, len, "%s triangle %zu", b->spec->meshes[file], triangle - b->triangle_start[file]);
    } else {
        snprintf(buf, len, "%s triangle %zu", rel, triangle);
    }
}

/* A solid's model must be closed and consistently oriented (solid_check.h); checked once
 * a model, however many solid objects share it. The check's scratch counts against the
 * budgets like the rest of a load. */
static int check_solid(world_builder *b, object_model *m, const char *rel)
{
    if (atomic_load(&m->closed))
        return 0;
    solid_defect defect;
    solid_check_status st = solid_check(&m->mesh, builder_room(b), builder_account(b), &defect);
    if (st == SOLID_CLOSED) {
        atomic_store(&m->closed, 1);
        return 0;
    }
    char why[TRIOCT_MAX_MESSAGE_LEN], label[TRIOCT_MAX_PATH_LEN + 32], other[TRIOCT_MAX_PATH_LEN + 32];
    triangle_label(b, rel, defect.triangle, label, sizeof label);
    triangle_label(b, rel, defect.other, other, sizeof other);
    solid_defect_text(st, &defect, label, other, why, sizeof why);
    if (st == SOLID_OVER_BUDGET) {
        char need[TRIOCT_MAX_MESSAGE_LEN + TRIOCT_MAX_PATH_LEN + 32];
        snprintf(need, sizeof need, "%s: %s (%zu bytes)", rel, why,
                 solid_check_bytes(m->mesh.vertex_count, m->mesh.triangle_count));
        return budget_fail(b, need);
    }
    if (st == SOLID_NO_MEMORY)
        return build_fail(b, TRIOCT_ERR_NOMEM, "world '%s': %s: %s", b->spec->name, rel, why);
    return build_fail(b, TRIOCT_ERR_LOAD_FAILED, "world '%s': %s: declared solid but not a closed surface: %s",
                      b->spec->name, rel, why);
}

/* An object's solid = its own solid.NAME, or the section's. */
static int object_is_solid(const world_spec *spec, const world_object_spec *o)
{
    return o->solid >= 0 ? o->solid : spec->solid;
}

/* The trioct status of an edit list that did not apply. */
static int edit_status(object_edit_status st)
{
    switch (st) {
    case OBJECT_EDIT_OK:
        return TRIOCT_OK;
    case OBJECT_EDIT_EXISTS:
        return TRIOCT_ERR_OBJECT_EXISTS;
    case OBJECT_EDIT_UNKNOWN:
        return TRIOCT_ERR_UNKNOWN_OBJECT;
    case OBJECT_EDIT_BAD_POSE:
        return TRIOCT_ERR_BAD_POSE;
    case OBJECT_EDIT_TOO_MANY:
        return TRIOCT_ERR_OVER_CAP;
    case OBJECT_EDIT_NOMEM:
        return TRIOCT_ERR_NOMEM;
    case OBJECT_EDIT_BAD_NAME:
    case OBJECT_EDIT_BAD_EDIT:
        break;
    }
    return TRIOCT_ERR_BAD_REQUEST;
}

/* A first version of the objects: the adds applied to an empty set. */
static object_edit_status first_set(const object_edit *adds, size_t count, object_set **out, size_t *failed,
                                    char *why, size_t why_len)
{
    object_set *empty = object_set_create();
    if (!empty) {
        error_text(why, why_len, "out of memory");
        return OBJECT_EDIT_NOMEM;
    }
    object_edit_status st = object_set_apply(empty, adds, count, out, failed, why, why_len);
    object_set_release(empty);
    return st;
}

/* A world of objects: each file loaded once into a model (its tree built once, in the
 * file's frame), each object that model at its pose. */
static int load_objects(world_builder *b)
{
    const world_spec *spec = b->spec;
    object_model *models[SCENE_MAX_MESHES] = {0};
    object_edit edits[SCENE_MAX_OBJECTS];
    int status = 0;
    for (size_t i = 0; i < spec->mesh_count && status == 0; i++) {
        mesh_data mesh = {0};
        mesh_load_report report;
        char path[TRIOCT_MAX_PATH_LEN];
        char why[TRIOCT_MAX_MESSAGE_LEN];
        if (world_resolve_path_in(b->world_dir, b->env ? b->env->roots : NULL, spec->meshes[i], path, sizeof path, why,
                                  sizeof why) != 0) {
            status = build_fail(b, TRIOCT_ERR_BAD_PATH, "world '%s': %s", spec->name, why);
            break;
        }
        if (load_file(b, spec->meshes[i], &mesh, &report) != 0) {
            status = -1;
            break;
        }
        models[i] = make_model(b, path, &mesh, &report, spec->meshes[i]);
        mesh_data_free(&mesh);
        if (!models[i])
            status = -1;
        for (size_t k = 0; k < spec->object_count && status == 0; k++)
            if ((size_t)spec->objects[k].mesh == i && object_is_solid(spec, &spec->objects[k]))
                status = check_solid(b, models[i], spec->meshes[i]);
    }
    for (size_t k = 0; k < spec->object_count && status == 0; k++)
        edits[k] = (object_edit){OBJECT_EDIT_ADD, spec->objects[k].name, models[spec->objects[k].mesh],
                                 spec->objects[k].at, object_is_solid(spec, &spec->objects[k])};
    if (status == 0) {
        char why[TRIOCT_MAX_MESSAGE_LEN];
        size_t failed = 0;
        object_edit_status st = first_set(edits, spec->object_count, &b->w->objects, &failed, why, sizeof why);
        /* A pose the scene parser accepted can still throw a vertex past the doubles. */
        if (st != OBJECT_EDIT_OK)
            status = build_fail(b, st == OBJECT_EDIT_BAD_POSE ? TRIOCT_ERR_LOAD_FAILED : edit_status(st),
                                "world '%s': object %s (%s): %s", spec->name, spec->objects[failed].name,
                                spec->meshes[spec->objects[failed].mesh], why);
    }
    for (size_t i = 0; i < spec->mesh_count; i++)
        object_model_release(models[i]); /* the set holds its own references */
    return status;
}

/* A section without objects: its meshes under the transform, merged, as one object named
 * after the world at the identity. */
static int load_merged(world_builder *b)
{
    b->merging = 1;
    for (size_t i = 0; i < b->spec->mesh_count; i++) {
        const char *rel = b->spec->meshes[i];
        mesh_data mesh;
        mesh_load_report report;
        if (load_file(b, rel, &mesh, &report) != 0)
            return -1;
        b->triangle_start[i] = b->merged.triangle_count;
        if (apply_transform(b, rel, &mesh, &report) != 0 || merge_mesh(b, rel, &mesh) != 0) {
            mesh_data_free(&mesh);
            return -1;
        }
        add_report(&b->merged_report, &report, i == 0);
    }
    char key[TRIOCT_MAX_PATH_LEN];
    snprintf(key, sizeof key, "section:%s", b->spec->name);
    object_model *model = make_model(b, key, &b->merged, &b->merged_report, b->spec->meshes[0]);
    if (!model)
        return -1;
    snprintf(model->source, sizeof model->source, "%s", key);
    if (b->spec->solid && check_solid(b, model, "the section's meshes") != 0) {
        object_model_release(model);
        return -1;
    }
    object_edit add = {OBJECT_EDIT_ADD, b->spec->name, model, octree_pose_identity(), b->spec->solid};
    char why[TRIOCT_MAX_MESSAGE_LEN];
    object_edit_status st = first_set(&add, 1, &b->w->objects, NULL, why, sizeof why);
    object_model_release(model);
    if (st != OBJECT_EDIT_OK)
        return build_fail(b, edit_status(st), "world '%s': %s", b->spec->name, why);
    return 0;
}

static int load_meshes(world_builder *b)
{
    return b->spec->object_count > 0 ? load_objects(b) : load_merged(b);
}

/* A shape's tree, in the shape's frame, at the heuristic resolution: built once here so
 * that no mesh query pays for it. */
static int load_shape(world_builder *b, const world_shape_spec *spec, world_shape *shape)
{
    mesh_data mesh = {0};
    if (load_file(b, spec->path, &mesh, NULL) != 0)
        return -1;
    octree_def def = octree_default_def();
    def.node_bounds = 1;
    def.node_slabs = (b->spec->effects & EFFECT_DISTANCE) != 0; /* for shape distance walks */
    budget_tree(b, &def, mesh.triangle_count);
    mesh_view view = mesh_data_view(&mesh);
    octree_error oerr;
    note_building(b);
    octree *tree = octree_build(&view, &def, &oerr);
    if (!tree) {
        mesh_data_free(&mesh);
        if (oerr.status == OCTREE_ERR_BUDGET) {
            char why[TRIOCT_MAX_MESSAGE_LEN];
            snprintf(why, sizeof why, "shape '%s' (%s): %s", spec->name, spec->path, oerr.message);
            return budget_fail(b, why);
        }
        if (oerr.status == OCTREE_ERR_NOMEM)
            return build_fail(b, TRIOCT_ERR_NOMEM, "world '%s': shape '%s' (%s): out of memory building its octree",
                              b->spec->name, spec->name, spec->path);
        return build_fail(b, TRIOCT_ERR_LOAD_FAILED, "world '%s': shape '%s' (%s): building its octree: %s: %s",
                          b->spec->name, spec->name, spec->path, octree_status_text(oerr.status), oerr.message);
    }
    char key[TRIOCT_MAX_PATH_LEN];
    snprintf(key, sizeof key, "shape:%s", spec->name);
    shape->model = object_model_adopt(key, &mesh, tree);
    if (!shape->model) {
        octree_free(tree);
        mesh_data_free(&mesh);
        return build_fail(b, TRIOCT_ERR_NOMEM, "world '%s': out of memory for shape '%s'", b->spec->name, spec->name);
    }
    octree_info info;
    octree_get_info(tree, &info);
    b->world_bytes += info.bytes_total;
    hand_mesh_to_model(b, shape->model);
    memcpy(shape->name, spec->name, sizeof shape->name);
    return 0;
}

/* Query shapes stay in their own frame: a mesh query places them with its pose. */
static int load_shapes(world_builder *b)
{
    world *w = b->w;
    if (!(b->spec->effects & (EFFECT_MESHES | EFFECT_DISTANCE)) || b->spec->shape_count == 0)
        return 0;
    w->shapes = calloc(b->spec->shape_count, sizeof *w->shapes);
    if (!w->shapes)
        return build_fail(b, TRIOCT_ERR_NOMEM, "world '%s': out of memory for shapes", b->spec->name);
    for (size_t i = 0; i < b->spec->shape_count; i++) {
        if (load_shape(b, &b->spec->shapes[i], &w->shapes[w->shape_count]) != 0)
            return -1;
        w->bytes_shapes += w->shapes[w->shape_count].model->bytes;
        w->shape_count++;
    }
    return 0;
}

/* What a version's answers and info come from: the single tree when there is one, and
 * the report summed over the objects (each instance counts its triangles; the box is the
 * union of the objects' posed boxes, exact at the identity). */
static void derive_from_objects(world *w)
{
    const object_set *s = w->objects;
    w->tree = NULL;
    if (s->count == 1 && octree_pose_is_identity(&s->objects[0].at))
        w->tree = s->objects[0].model->tree;
    memset(&w->report, 0, sizeof w->report);
    for (size_t i = 0; i < s->count; i++) {
        mesh_load_report one = s->objects[i].model->report;
        one.triangles = s->objects[i].model->mesh.triangle_count;
        one.bbox_lo = s->objects[i].bounds.lo;
        one.bbox_hi = s->objects[i].bounds.hi;
        add_report(&w->report, &one, i == 0);
    }
}

/* A spec from an admin request has not been through the scene parser. */
static int check_spec(world_builder *b)
{
    const world_spec *spec = b->spec;
    if (!trioct_name_valid(spec->name, TRIOCT_MAX_NAME_LEN))
        return build_fail(b, TRIOCT_ERR_BAD_REQUEST, "invalid world name '%.*s'", TRIOCT_MAX_NAME_LEN,
                          spec->name);
    if (spec->mesh_count == 0 || spec->mesh_count > SCENE_MAX_MESHES)
        return build_fail(b, TRIOCT_ERR_BAD_REQUEST, "world '%s' has %zu meshes (1 to %d)", spec->name,
                          spec->mesh_count, SCENE_MAX_MESHES);
    if (spec->object_count > SCENE_MAX_OBJECTS)
        return build_fail(b, TRIOCT_ERR_BAD_REQUEST, "world '%s' has %zu objects (at most %d)", spec->name,
                          spec->object_count, SCENE_MAX_OBJECTS);
    for (size_t k = 0; k < spec->object_count; k++)
        if (spec->objects[k].mesh < 0 || (size_t)spec->objects[k].mesh >= spec->mesh_count ||
            octree_pose_check(&spec->objects[k].at) != OCTREE_OK)
            return build_fail(b, TRIOCT_ERR_BAD_REQUEST, "world '%s': object %.*s has no mesh or no rotation", spec->name,
                              TRIOCT_MAX_NAME_LEN, spec->objects[k].name);
    if (spec->shape_count > TRIOCT_MAX_SHAPES)
        return build_fail(b, TRIOCT_ERR_BAD_REQUEST, "world '%s' has %zu shapes (at most %d)", spec->name,
                          spec->shape_count, TRIOCT_MAX_SHAPES);
    if (spec->effects == 0 || (spec->effects & ~(unsigned)EFFECT_ALL))
        return build_fail(b, TRIOCT_ERR_BAD_REQUEST, "world '%s': effects mask %u is not a set of rays, triangles, meshes",
                          spec->name, spec->effects);
    return 0;
}

static void world_destroy(world *w)
{
    atomic_fetch_sub(&live_worlds, 1);
    object_set_release(w->objects);
    for (size_t i = 0; i < w->shape_count; i++)
        object_model_release(w->shapes[i].model);
    free(w->shapes);
    free(w);
}

/* What the build took for meshes that never reached a model goes back. */
static void builder_give_back(world_builder *b)
{
    memory_account *account = builder_account(b);
    if (account && b->mesh_held)
        memory_account_give(account, b->mesh_held);
    b->mesh_held = 0;
}

static size_t spec_budget(const world_spec *spec) { return spec->memory_budget ? spec->memory_budget : SIZE_MAX; }

world *world_build(const world_spec *spec, const char *world_dir, const world_env *env, int *status, char *err,
                   size_t err_len)
{
    world_builder b;
    memset(&b, 0, sizeof b);
    b.spec = spec;
    b.world_dir = world_dir;
    b.env = env;
    b.budget = spec ? spec_budget(spec) : SIZE_MAX;
    b.status = TRIOCT_OK;
    b.err = err;
    b.err_len = err_len;
    if (err && err_len)
        err[0] = '\0';

    double started = monotonic_seconds();
    if (spec && env && env->progress) {
        size_t shapes = (spec->effects & (EFFECT_MESHES | EFFECT_DISTANCE)) ? spec->shape_count : 0;
        atomic_store(&env->progress->files_total, (int)(spec->mesh_count + shapes));
    }
    int failed = !spec ? build_fail(&b, TRIOCT_ERR_BAD_REQUEST, "no world spec given") : check_spec(&b);
    if (!failed) {
        b.w = calloc(1, sizeof *b.w);
        if (!b.w)
            failed = build_fail(&b, TRIOCT_ERR_NOMEM, "world '%s': out of memory", spec->name);
        else
            atomic_fetch_add(&live_worlds, 1);
    }
    if (!failed) {
        b.w->spec = *spec;
        atomic_init(&b.w->queries, 0);
        atomic_init(&b.w->refs, 1);
        failed = load_meshes(&b) || load_shapes(&b);
        if (!failed) {
            derive_from_objects(b.w);
            b.w->load_seconds = b.load_seconds;
            b.w->build_seconds = monotonic_seconds() - started - b.load_seconds;
        }
    }
    mesh_data_free(&b.merged); /* moved into the model unless a step failed */
    builder_give_back(&b);
    if (failed && b.w) {
        world_destroy(b.w);
        b.w = NULL;
    }
    if (status)
        *status = b.status;
    return b.w;
}

world *world_edit(const world *from, const object_edit *edits, size_t count, int *status, size_t *failed,
                  char *err, size_t err_len)
{
    if (failed)
        *failed = 0;
    if (from->spec.def.mode != ACCURACY_EXACT) {
        if (failed)
            *failed = SIZE_MAX;
        *status = TRIOCT_ERR_BAD_REQUEST;
        error_text(err, err_len,
                   "world %s serves %s accuracy; objects are edited only in exact worlds (a posed object is "
                   "answered exactly)",
                   from->spec.name, accuracy_mode_name(from->spec.def.mode));
        return NULL;
    }
    world *w = calloc(1, sizeof *w);
    world_shape *shapes = from->shape_count ? calloc(from->shape_count, sizeof *shapes) : NULL;
    if (!w || (from->shape_count && !shapes)) {
        free(w);
        free(shapes);
        if (failed)
            *failed = SIZE_MAX;
        *status = TRIOCT_ERR_NOMEM;
        error_text(err, err_len, "out of memory");
        return NULL;
    }
    object_edit_status st = object_set_apply(from->objects, edits, count, &w->objects, failed, err, err_len);
    if (st != OBJECT_EDIT_OK) {
        free(w);
        free(shapes);
        *status = edit_status(st);
        return NULL;
    }
    w->spec = from->spec;
    w->shapes = shapes;
    w->shape_count = from->shape_count;
    for (size_t i = 0; i < from->shape_count; i++) {
        shapes[i] = from->shapes[i];
        object_model_retain(shapes[i].model);
    }
    w->bytes_shapes = from->bytes_shapes;
    atomic_init(&w->queries, 0);
    atomic_init(&w->refs, 1);
    atomic_fetch_add(&live_worlds, 1);
    derive_from_objects(w);
    *status = TRIOCT_OK;
    return w;
}

object_model *world_model_from_file(const world *w, const char *world_dir, const world_env *env, const char *rel,
                                    int *status, char *err, size_t err_len)
{
    world_builder b = {.spec = &w->spec, .world_dir = world_dir, .status = TRIOCT_OK, .err = err, .err_len = err_len,
                       .env = env, .budget = spec_budget(&w->spec), .world_bytes = world_memory_bytes(w)};
    char path[TRIOCT_MAX_PATH_LEN];
    char why[TRIOCT_MAX_MESSAGE_LEN];
    if (world_resolve_path_in(world_dir, env ? env->roots : NULL, rel, path, sizeof path, why, sizeof why) != 0) {
        build_fail(&b, TRIOCT_ERR_BAD_PATH, "%s", why);
        *status = b.status;
        return NULL;
    }
    for (size_t i = 0; i < w->objects->count; i++) {
        object_model *m = w->objects->objects[i].model;
        if (strcmp(m->key, path) == 0) {
            object_model_retain(m);
            *status = TRIOCT_OK;
            return m;
        }
    }
    mesh_data mesh = {0};
    mesh_load_report report;
    object_model *m = NULL;
    if (load_file(&b, rel, &mesh, &report) == 0)
        m = make_model(&b, path, &mesh, &report, rel);
    mesh_data_free(&mesh);
    builder_give_back(&b);
    *status = m ? TRIOCT_OK : b.status;
    return m;
}

object_model *world_model_from_triangles(const world *w, const world_env *env, const char *name,
                                         const vec3 (*tris)[3], size_t count, int *status, char *err,
                                         size_t err_len)
{
    world_builder b = {.spec = &w->spec, .status = TRIOCT_OK, .err = err, .err_len = err_len, .env = env,
                       .budget = spec_budget(&w->spec), .world_bytes = world_memory_bytes(w)};
    mesh_data mesh = {0};
    size_t corners = count > 0 ? 3 * count : 1;
    size_t bytes = mesh_data_bytes_for(corners, count);
    memory_account *account = builder_account(&b);
    if (bytes > builder_room(&b) || (account && memory_account_take(account, bytes) != 0)) {
        char why[TRIOCT_MAX_MESSAGE_LEN];
        snprintf(why, sizeof why, "object %s: its %zu inline triangles need %zu bytes, more than the budget leaves",
                 name, count, bytes);
        budget_fail(&b, why);
        *status = b.status;
        return NULL;
    }
    b.world_bytes += bytes;
    b.mesh_held = account ? bytes : 0;
    mesh.vertices = malloc(corners * sizeof *mesh.vertices);
    mesh.indices = malloc(corners * sizeof *mesh.indices);
    if (!mesh.vertices || !mesh.indices) {
        mesh_data_free(&mesh);
        builder_give_back(&b);
        *status = TRIOCT_ERR_NOMEM;
        error_text(err, err_len, "object %s: out of memory", name);
        return NULL;
    }
    for (size_t t = 0; t < count; t++)
        for (uint32_t k = 0; k < 3; k++) {
            mesh.vertices[3 * t + k] = tris[t][k];
            mesh.indices[3 * t + k] = (uint32_t)(3 * t + k);
        }
    mesh.vertex_count = 3 * count;
    mesh.triangle_count = count;
    mesh_load_report report = {.meshes = 1, .triangles = count};
    char key[TRIOCT_MAX_PATH_LEN];
    snprintf(key, sizeof key, "inline:%s", name);
    object_model *m = make_model(&b, key, &mesh, &report, "inline");
    mesh_data_free(&mesh);
    builder_give_back(&b);
    *status = m ? TRIOCT_OK : b.status;
    return m;
}

int world_model_check_solid(const world *w, const world_env *env, object_model *m, const char *label, int *status,
                            char *err, size_t err_len)
{
    world_builder b = {.spec = &w->spec, .status = TRIOCT_OK, .err = err, .err_len = err_len, .env = env,
                       .budget = spec_budget(&w->spec), .world_bytes = world_memory_bytes(w)};
    int rc = check_solid(&b, m, label);
    *status = b.status;
    return rc;
}

void world_retain(world *w)
{
    if (w)
        atomic_fetch_add_explicit(&w->refs, 1, memory_order_relaxed);
}

/* acq_rel: every use of the world by other holders happens before the free. */
void world_release(world *w)
{
    if (w && atomic_fetch_sub_explicit(&w->refs, 1, memory_order_acq_rel) == 1)
        world_destroy(w);
}

void world_tree_info(const world *w, octree_info *out)
{
    memset(out, 0, sizeof *out);
    const object_set *s = w->objects;
    for (size_t i = 0; i < s->count; i++) {
        const object_model *m = s->objects[i].model;
        octree_info one;
        octree_get_info(m->tree, &one);
        if (i == 0) {
            *out = one;
            continue;
        }
        out->triangle_count += one.triangle_count;
        out->vertex_count += one.vertex_count;
        int seen = 0;
        for (size_t k = 0; k < i && !seen; k++)
            seen = s->objects[k].model == m;
        if (seen)
            continue;
        out->node_count += one.node_count;
        out->leaf_count += one.leaf_count;
        out->nonempty_leaf_count += one.nonempty_leaf_count;
        out->leaf_refs += one.leaf_refs;
        out->depth_clamped |= one.depth_clamped;
        out->bytes_nodes += one.bytes_nodes;
        out->bytes_leaf_lists += one.bytes_leaf_lists;
        out->bytes_triangles += one.bytes_triangles;
        out->bytes_total += one.bytes_total;
        out->bytes_triangle_boxes += one.bytes_triangle_boxes;
        out->bytes_traversal += one.bytes_traversal;
        out->bytes_node_bounds += one.bytes_node_bounds;
        out->build_seconds += one.build_seconds;
    }
}

size_t world_memory_bytes(const world *w)
{
    size_t bytes = w->bytes_shapes;
    const object_set *s = w->objects;
    for (size_t i = 0; s && i < s->count; i++) {
        const object_model *m = s->objects[i].model;
        int seen = 0;
        for (size_t k = 0; k < i && !seen; k++)
            seen = s->objects[k].model == m;
        if (!seen)
            bytes += m->bytes;
    }
    return bytes;
}

const world_shape *world_find_shape(const world *w, const char *name)
{
    for (size_t i = 0; w && name && i < w->shape_count; i++)
        if (strcmp(w->shapes[i].name, name) == 0)
            return &w->shapes[i];
    return NULL;
}
