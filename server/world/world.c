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

#include "../../common/channels.h"
#include "../../common/trioct_status.h"
#include "../geom/vec3.h"
#include "error_text.h"


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

int world_resolve_path(const char *world_dir, const char *rel, char *out, size_t out_len,
                       char *err, size_t err_len)
{
    if (out && out_len)
        out[0] = '\0';
    if (!world_dir || !world_dir[0])
        return error_text(err, err_len, "no world directory is set");
    if (!rel || !rel[0])
        return error_text(err, err_len, "empty file path");
    if (rel[0] == '/')
        return error_text(err, err_len, "%s: absolute paths are refused; give a path relative to the world directory", rel);
    if (has_parent_component(rel))
        return error_text(err, err_len, "%s: '..' is refused in paths", rel);

    char *dir = realpath(world_dir, NULL);
    if (!dir)
        return error_text(err, err_len, "world directory %s: %s", world_dir, strerror(errno));
    size_t joined_len = strlen(dir) + 1 + strlen(rel) + 1;
    char *joined = malloc(joined_len);
    if (!joined) {
        free(dir);
        return error_text(err, err_len, "%s: out of memory", rel);
    }
    snprintf(joined, joined_len, "%s/%s", dir, rel);
    char *resolved = realpath(joined, NULL);
    int why = errno;
    free(joined);
    int status = 0;
    if (!resolved)
        status = error_text(err, err_len, "%s: %s (in world directory %s)", rel, strerror(why), world_dir);
    else if (!is_inside(dir, resolved))
        status = error_text(err, err_len, "%s: leads outside the world directory %s (to %s)", rel,
                           world_dir, resolved);
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
    size_t object_start[SCENE_MAX_OBJECTS];  /* with objects: first merged triangle of each */
    world *w;
} world_builder;

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

/* Resolves and loads one file; the loader's message already names the file (and the
 * triangle of a NaN/Inf coordinate). */
static int load_file(world_builder *b, const char *rel, mesh_data *mesh, mesh_load_report *report)
{
    char path[TRIOCT_MAX_PATH_LEN];
    char why[TRIOCT_MAX_MESSAGE_LEN];
    if (world_resolve_path(b->world_dir, rel, path, sizeof path, why, sizeof why) != 0)
        return build_fail(b, TRIOCT_ERR_BAD_PATH, "world '%s': %s", b->spec->name, why);
    if (mesh_load_file(path, mesh, report, why, sizeof why) != 0)
        return build_fail(b, TRIOCT_ERR_LOAD_FAILED, "world '%s': %s", b->spec->name, why);
    return 0;
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

/* A world of objects: each file loaded once, each object a copy of its file's mesh with
 * every vertex posed (octree_pose_point, the one posing expression), merged in the
 * objects' (name) order. */
static int load_objects(world_builder *b)
{
    const world_spec *spec = b->spec;
    mesh_data files[SCENE_MAX_MESHES];
    mesh_load_report reports[SCENE_MAX_MESHES];
    memset(files, 0, sizeof files);
    int status = 0;
    for (size_t i = 0; i < spec->mesh_count && status == 0; i++)
        status = load_file(b, spec->meshes[i], &files[i], &reports[i]);
    for (size_t k = 0; k < spec->object_count && status == 0; k++) {
        const world_object_spec *o = &spec->objects[k];
        const mesh_data *src = &files[o->mesh];
        mesh_data posed = {0};
        if (mesh_data_append(&posed, src) != 0) {
            status = build_fail(b, TRIOCT_ERR_NOMEM, "world '%s': out of memory placing object %s", spec->name, o->name);
            break;
        }
        for (size_t v = 0; v < posed.vertex_count; v++)
            posed.vertices[v] = octree_pose_point(&o->at, posed.vertices[v]);
        size_t bad = first_nonfinite_triangle(&posed);
        if (bad != SIZE_MAX) {
            mesh_data_free(&posed);
            status = build_fail(b, TRIOCT_ERR_LOAD_FAILED,
                                "world '%s': object %s (%s): triangle %zu has a coordinate that is not finite at its pose",
                                spec->name, o->name, spec->meshes[o->mesh], bad);
            break;
        }
        mesh_load_report report = reports[o->mesh];
        box3 bounds = mesh_data_bounds(&posed);
        report.bbox_lo = bounds.lo;
        report.bbox_hi = bounds.hi;
        b->object_start[k] = b->merged.triangle_count;
        if (merge_mesh(b, spec->meshes[o->mesh], &posed) != 0) {
            mesh_data_free(&posed);
            status = -1;
            break;
        }
        add_report(&b->w->report, &report, k == 0);
    }
    for (size_t i = 0; i < spec->mesh_count; i++)
        mesh_data_free(&files[i]);
    return status;
}

static int load_meshes(world_builder *b)
{
    if (b->spec->object_count > 0)
        return load_objects(b);
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
        add_report(&b->w->report, &report, i == 0);
    }
    return 0;
}

/* A shape's tree, in the shape's frame, at the heuristic resolution: built once here so
 * that no mesh query pays for it. */
static int build_shape_tree(world_builder *b, const world_shape_spec *spec, world_shape *shape)
{
    octree_def def = octree_default_def();
    def.node_bounds = 1;
    mesh_view view = mesh_data_view(&shape->mesh);
    octree_error oerr;
    shape->tree = octree_build(&view, &def, &oerr);
    if (shape->tree)
        return 0;
    if (oerr.status == OCTREE_ERR_NOMEM)
        return build_fail(b, TRIOCT_ERR_NOMEM, "world '%s': shape '%s' (%s): out of memory building its octree",
                          b->spec->name, spec->name, spec->path);
    return build_fail(b, TRIOCT_ERR_LOAD_FAILED, "world '%s': shape '%s' (%s): building its octree: %s: %s",
                      b->spec->name, spec->name, spec->path, octree_status_text(oerr.status), oerr.message);
}

/* Query shapes stay in their own frame: a mesh query places them with its pose. */
static int load_shapes(world_builder *b)
{
    world *w = b->w;
    if (!(b->spec->effects & EFFECT_MESHES) || b->spec->shape_count == 0)
        return 0;
    w->shapes = calloc(b->spec->shape_count, sizeof *w->shapes);
    if (!w->shapes)
        return build_fail(b, TRIOCT_ERR_NOMEM, "world '%s': out of memory for shapes", b->spec->name);
    for (size_t i = 0; i < b->spec->shape_count; i++) {
        const world_shape_spec *shape = &b->spec->shapes[i];
        world_shape *loaded = &w->shapes[w->shape_count];
        if (load_file(b, shape->path, &loaded->mesh, NULL) != 0)
            return -1;
        memcpy(loaded->name, shape->name, sizeof loaded->name);
        w->shape_count++;
        if (build_shape_tree(b, shape, loaded) != 0)
            return -1;
        octree_info info;
        octree_get_info(loaded->tree, &info);
        w->bytes_shapes += loaded->mesh.vertex_count * sizeof(vec3) +
                           3 * loaded->mesh.triangle_count * sizeof(uint32_t) + info.bytes_total;
    }
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

static int build_tree(world_builder *b)
{
    octree_def def = b->spec->def;
#ifdef OCTREE_HAS_TRIANGLE_BOXES
    def.triangle_boxes = (b->spec->effects & (EFFECT_TRIANGLES | EFFECT_MESHES)) != 0;
#endif
    mesh_view view = mesh_data_view(&b->merged);
    octree_error oerr;
    b->w->tree = octree_build(&view, &def, &oerr);
    if (b->w->tree)
        return 0;
    if (oerr.status == OCTREE_ERR_NOMEM)
        return build_fail(b, TRIOCT_ERR_NOMEM, "world '%s': out of memory building the octree",
                          b->spec->name);
    if (oerr.triangle != SIZE_MAX && b->spec->object_count > 0) {
        size_t k = 0;
        while (k + 1 < b->spec->object_count && b->object_start[k + 1] <= oerr.triangle)
            k++;
        const world_object_spec *o = &b->spec->objects[k];
        return build_fail(b, TRIOCT_ERR_LOAD_FAILED, "world '%s': object %s (%s): triangle %zu: %s: %s", b->spec->name,
                          o->name, b->spec->meshes[o->mesh], oerr.triangle - b->object_start[k],
                          octree_status_text(oerr.status), oerr.message);
    }
    if (oerr.triangle != SIZE_MAX) {
        size_t file = mesh_of_triangle(b, oerr.triangle);
        return build_fail(b, TRIOCT_ERR_LOAD_FAILED, "world '%s': %s: triangle %zu: %s: %s", b->spec->name,
                          b->spec->meshes[file], oerr.triangle - b->triangle_start[file],
                          octree_status_text(oerr.status), oerr.message);
    }
    return build_fail(b, TRIOCT_ERR_LOAD_FAILED, "world '%s': %s: %s", b->spec->name,
                      octree_status_text(oerr.status), oerr.message);
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
    octree_free(w->tree);
    for (size_t i = 0; i < w->shape_count; i++) {
        mesh_data_free(&w->shapes[i].mesh);
        octree_free(w->shapes[i].tree);
    }
    free(w->shapes);
    free(w);
}

world *world_build(const world_spec *spec, const char *world_dir, int *status, char *err,
                   size_t err_len)
{
    world_builder b;
    memset(&b, 0, sizeof b);
    b.spec = spec;
    b.world_dir = world_dir;
    b.status = TRIOCT_OK;
    b.err = err;
    b.err_len = err_len;
    if (err && err_len)
        err[0] = '\0';

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
        failed = load_meshes(&b) || load_shapes(&b) || build_tree(&b);
    }
    /* The octree holds its own copy of the triangles. */
    mesh_data_free(&b.merged);
    if (failed && b.w) {
        world_destroy(b.w);
        b.w = NULL;
    }
    if (status)
        *status = b.status;
    return b.w;
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

const world_shape *world_find_shape(const world *w, const char *name)
{
    for (size_t i = 0; w && name && i < w->shape_count; i++)
        if (strcmp(w->shapes[i].name, name) == 0)
            return &w->shapes[i];
    return NULL;
}
