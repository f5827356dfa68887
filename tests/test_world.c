/* World and registry tests: path safety inside the world directory, world_build on OBJ
 * files written here and on an assimp test model (transform, merged meshes, NaN refusal,
 * engine errors, effects), reference counts, and the registry's versions, errors, order,
 * cap and thread safety. */
#define _XOPEN_SOURCE 700 /* nftw, symlink, realpath */

#include <math.h>
#include <pthread.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <ftw.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmocka.h>

#include "trioct_status.h"
#include "world/registry.h"
#include "world/world.h"

#define MODELS "/usr/share/assimp/models"

/* ---------- scratch world directories ---------- */

typedef struct scratch {
    char dir[64];
} scratch;

static void scratch_make(scratch *s)
{
    snprintf(s->dir, sizeof s->dir, "/tmp/trioct_world_XXXXXX");
    assert_non_null(mkdtemp(s->dir));
}

/* Writes dir/rel, making the directories on the way. */
static void scratch_write(const scratch *s, const char *rel, const char *text)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", s->dir, rel);
    for (char *slash = strchr(path + strlen(s->dir) + 1, '/'); slash; slash = strchr(slash + 1, '/')) {
        *slash = '\0';
        mkdir(path, 0755);
        *slash = '/';
    }
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    assert_true(fputs(text, f) >= 0);
    assert_int_equal(fclose(f), 0);
}

static int remove_entry(const char *path, const struct stat *sb, int flag, struct FTW *ftw)
{
    (void)sb;
    (void)flag;
    (void)ftw;
    return remove(path);
}

static void scratch_remove(scratch *s)
{
    assert_int_equal(nftw(s->dir, remove_entry, 16, FTW_DEPTH | FTW_PHYS), 0);
}

/* A unit cube [o, o+1]^3 as six quads, outward. */
static void cube_obj(char *buf, size_t len, double o)
{
    snprintf(buf, len,
             "v %g %g %g\nv %g %g %g\nv %g %g %g\nv %g %g %g\n"
             "v %g %g %g\nv %g %g %g\nv %g %g %g\nv %g %g %g\n"
             "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n",
             o, o, o, o + 1, o, o, o + 1, o + 1, o, o, o + 1, o,
             o, o, o + 1, o + 1, o, o + 1, o + 1, o + 1, o + 1, o, o + 1, o + 1);
}

static const char tetra_obj[] =
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

static void write_cube(const scratch *s, const char *rel, double origin)
{
    char obj[512];
    cube_obj(obj, sizeof obj, origin);
    scratch_write(s, rel, obj);
}

static world_spec cube_spec(const char *name)
{
    world_spec spec;
    world_spec_init(&spec, name);
    snprintf(spec.meshes[0], sizeof spec.meshes[0], "cube.obj");
    spec.mesh_count = 1;
    return spec;
}

static world *build_ok(const world_spec *spec, const char *dir)
{
    int status = -1;
    char err[512];
    world *w = world_build(spec, dir, NULL, &status, err, sizeof err);
    if (!w)
        fail_msg("world_build failed (%d): %s", status, err);
    assert_int_equal(status, TRIOCT_OK);
    assert_string_equal(err, "");
    return w;
}

static void build_fails(const world_spec *spec, const char *dir, int want_status, char *err, size_t err_len)
{
    int status = -1;
    world *w = world_build(spec, dir, NULL, &status, err, err_len);
    if (w)
        fail_msg("world_build of '%s' should have failed", spec->name);
    assert_int_equal(status, want_status);
}

static void assert_vec_equal(vec3 got, double x, double y, double z)
{
    if (!(got.x == x && got.y == y && got.z == z))
        fail_msg("got (%.17g, %.17g, %.17g), want (%.17g, %.17g, %.17g)", got.x, got.y, got.z, x, y, z);
}

/* Closest hit t of a ray, or -1. */
static double closest_t(const octree *tree, vec3 origin, vec3 direction)
{
    ray_input ray = {origin, direction, 0.0, INFINITY, RAY_CROSSING};
    ray_hit hit;
    ray_output out = {0, 0, &hit, 1};
    assert_int_equal(octree_ray(tree, &ray, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
    return out.hit_count ? hit.t : -1.0;
}

/* ---------- paths ---------- */

static void expect_refused(const char *dir, const char *rel, const char *what)
{
    char out[1024] = "unchanged", err[512] = "";
    if (world_resolve_path(dir, rel, out, sizeof out, err, sizeof err) != -1 || !strstr(err, what))
        fail_msg("'%s' should be refused with \"%s\", got \"%s\"", rel, what, err);
    assert_string_equal(out, "");
}

static void test_resolve_refuses_absolute_parent_and_missing(void **state)
{
    (void)state;
    scratch s;
    scratch_make(&s);
    write_cube(&s, "cube.obj", 0);
    write_cube(&s, "sub/cube.obj", 0);
    expect_refused(s.dir, "/etc/passwd", "absolute paths are refused");
    char absolute_inside[256];
    snprintf(absolute_inside, sizeof absolute_inside, "%s/cube.obj", s.dir);
    expect_refused(s.dir, absolute_inside, "absolute paths are refused");
    expect_refused(s.dir, "../cube.obj", "'..' is refused");
    expect_refused(s.dir, "sub/../cube.obj", "'..' is refused"); /* even when it stays inside */
    expect_refused(s.dir, "sub/..", "'..' is refused");
    expect_refused(s.dir, "..", "'..' is refused");
    expect_refused(s.dir, "", "empty file path");
    expect_refused(s.dir, "nope.obj", "nope.obj: No such file or directory");
    expect_refused(s.dir, "sub/nope/cube.obj", "sub/nope/cube.obj: No such file or directory");
    expect_refused("/tmp/trioct_no_such_world_dir", "cube.obj", "world directory /tmp/trioct_no_such_world_dir");
    scratch_remove(&s);
}

static void test_resolve_follows_symlinks_but_stays_inside(void **state)
{
    (void)state;
    scratch s, outside;
    scratch_make(&s);
    scratch_make(&outside);
    write_cube(&s, "real/cube.obj", 0);
    write_cube(&outside, "secret.obj", 0);
    char target[256], link[256];
    snprintf(target, sizeof target, "%s/secret.obj", outside.dir);
    snprintf(link, sizeof link, "%s/escape.obj", s.dir);
    assert_int_equal(symlink(target, link), 0);
    snprintf(link, sizeof link, "%s/escape_dir", s.dir);
    assert_int_equal(symlink(outside.dir, link), 0);
    snprintf(link, sizeof link, "%s/alias.obj", s.dir);
    assert_int_equal(symlink("real/cube.obj", link), 0);

    expect_refused(s.dir, "escape.obj", "leads outside the world directory");
    expect_refused(s.dir, "escape_dir/secret.obj", "leads outside the world directory");

    char *real_dir = realpath(s.dir, NULL);
    assert_non_null(real_dir);
    char out[1024], err[512], want[512];
    assert_int_equal(world_resolve_path(s.dir, "alias.obj", out, sizeof out, err, sizeof err), 0);
    snprintf(want, sizeof want, "%s/real/cube.obj", real_dir);
    assert_string_equal(out, want);
    assert_int_equal(world_resolve_path(s.dir, "./real//cube.obj", out, sizeof out, err, sizeof err), 0);
    assert_string_equal(out, want);

    /* The world directory itself may be reached through a symlink. */
    char dir_link[256];
    snprintf(dir_link, sizeof dir_link, "%s/worlds", outside.dir);
    assert_int_equal(symlink(s.dir, dir_link), 0);
    assert_int_equal(world_resolve_path(dir_link, "real/cube.obj", out, sizeof out, err, sizeof err), 0);
    assert_string_equal(out, want);
    /* A too-small output buffer is an error, not a cut path. */
    assert_int_equal(world_resolve_path(s.dir, "real/cube.obj", out, 8, err, sizeof err), -1);
    assert_non_null(strstr(err, "resolved path longer than 7 characters"));

    free(real_dir);
    scratch_remove(&s);
    scratch_remove(&outside);
}

/* A mesh root opens one more place: a symlink from the world directory into it, or an
 * absolute path inside it. Inside a root the same rules hold: '..' is refused, and a
 * symlink that leads out of the root is refused. */
static void test_resolve_into_mesh_roots(void **state)
{
    (void)state;
    scratch s, pkg, other;
    scratch_make(&s);
    scratch_make(&pkg);
    scratch_make(&other);
    write_cube(&pkg, "meshes/base.stl.obj", 0);
    write_cube(&other, "private.obj", 0);
    char link[256], target[256], out[1024], err[512], want[1024];
    snprintf(target, sizeof target, "%s/meshes/base.stl.obj", pkg.dir);
    snprintf(link, sizeof link, "%s/base.obj", s.dir);
    assert_int_equal(symlink(target, link), 0);
    snprintf(target, sizeof target, "%s/private.obj", other.dir);
    snprintf(link, sizeof link, "%s/meshes/leak.obj", pkg.dir);
    assert_int_equal(symlink(target, link), 0);

    /* Without roots the symlink is refused, as before; so is an absolute path. */
    expect_refused(s.dir, "base.obj", "leads outside the world directory");
    char absolute[512];
    snprintf(absolute, sizeof absolute, "%s/meshes/base.stl.obj", pkg.dir);
    expect_refused(s.dir, absolute, "absolute paths are refused");

    mesh_roots roots = {.count = 1};
    snprintf(roots.paths[0], sizeof roots.paths[0], "%s", pkg.dir);
    char *real_pkg = realpath(pkg.dir, NULL);
    assert_non_null(real_pkg);
    snprintf(want, sizeof want, "%s/meshes/base.stl.obj", real_pkg);
    assert_int_equal(world_resolve_path_in(s.dir, &roots, "base.obj", out, sizeof out, err, sizeof err), 0);
    assert_string_equal(out, want);
    assert_int_equal(world_resolve_path_in(s.dir, &roots, absolute, out, sizeof out, err, sizeof err), 0);
    assert_string_equal(out, want);

    /* Out of the root through its own symlink, '..', or a file of no root: refused. */
    snprintf(absolute, sizeof absolute, "%s/meshes/leak.obj", pkg.dir);
    assert_int_equal(world_resolve_path_in(s.dir, &roots, absolute, out, sizeof out, err, sizeof err), -1);
    assert_non_null(strstr(err, "lies outside every mesh_root"));
    snprintf(absolute, sizeof absolute, "%s/meshes/../meshes/base.stl.obj", pkg.dir);
    assert_int_equal(world_resolve_path_in(s.dir, &roots, absolute, out, sizeof out, err, sizeof err), -1);
    assert_non_null(strstr(err, "'..' is refused"));
    snprintf(absolute, sizeof absolute, "%s/private.obj", other.dir);
    assert_int_equal(world_resolve_path_in(s.dir, &roots, absolute, out, sizeof out, err, sizeof err), -1);
    assert_non_null(strstr(err, "lies outside every mesh_root"));
    snprintf(link, sizeof link, "%s/private.obj", s.dir);
    assert_int_equal(symlink(absolute, link), 0);
    assert_int_equal(world_resolve_path_in(s.dir, &roots, "private.obj", out, sizeof out, err, sizeof err), -1);
    assert_non_null(strstr(err, "leads outside the world directory"));
    assert_non_null(strstr(err, "and every mesh_root"));

    /* A world built from the root through the symlink, with the roots in its env. */
    world_spec spec;
    world_spec_init(&spec, "rooted");
    snprintf(spec.meshes[0], sizeof spec.meshes[0], "base.obj");
    spec.mesh_count = 1;
    world_env env = {.roots = &roots};
    int status;
    world *w = world_build(&spec, s.dir, &env, &status, err, sizeof err);
    assert_non_null(w);
    assert_int_equal(w->report.triangles, 12);
    world_release(w);
    free(real_pkg);
    scratch_remove(&s);
    scratch_remove(&pkg);
    scratch_remove(&other);
}

static void test_good_nested_path(void **state)
{
    (void)state;
    scratch s;
    scratch_make(&s);
    write_cube(&s, "a/b/c/deep cube.obj", 0);
    char *real_dir = realpath(s.dir, NULL);
    char out[1024], err[512], want[512];
    assert_int_equal(world_resolve_path(s.dir, "a/b/c/deep cube.obj", out, sizeof out, err, sizeof err), 0);
    snprintf(want, sizeof want, "%s/a/b/c/deep cube.obj", real_dir);
    assert_string_equal(out, want);
    /* Dots inside a name are not a parent component. */
    write_cube(&s, "v1..2/x..obj", 0);
    assert_int_equal(world_resolve_path(s.dir, "v1..2/x..obj", out, sizeof out, err, sizeof err), 0);
    free(real_dir);
    scratch_remove(&s);
}

/* ---------- world_build ---------- */

static void test_build_unit_cube(void **state)
{
    (void)state;
    scratch s;
    scratch_make(&s);
    write_cube(&s, "cube.obj", 0);
    size_t live = world_live_count();
    world_spec spec = cube_spec("cube");
    world *w = build_ok(&spec, s.dir);
    assert_int_equal(world_live_count(), live + 1);
    assert_true(world_spec_equal(&w->spec, &spec));
    assert_int_equal(w->version, 0);
    assert_int_equal(atomic_load(&w->refs), 1);
    assert_int_equal(atomic_load(&w->queries), 0);
    assert_int_equal(w->report.meshes, 1);
    assert_int_equal(w->report.triangles, 12);
    assert_int_equal(w->report.degenerate, 0);
    assert_int_equal(w->report.duplicates, 0);
    assert_vec_equal(w->report.bbox_lo, 0, 0, 0);
    assert_vec_equal(w->report.bbox_hi, 1, 1, 1);
    octree_info info;
    octree_get_info(w->tree, &info);
    assert_int_equal(info.triangle_count, 12);
    assert_int_equal(info.vertex_count, 8);
    assert_true(closest_t(w->tree, vec3_make(0.5, 0.5, -2), vec3_make(0, 0, 1)) == 2.0);
    /* EFFECT_ALL but no shapes in the spec. */
    assert_int_equal(w->shape_count, 0);
    assert_null(w->shapes);
    assert_int_equal(w->bytes_shapes, 0);

    world_retain(w);
    assert_int_equal(atomic_load(&w->refs), 2);
    world_release(w);
    assert_int_equal(world_live_count(), live + 1);
    world_release(w);
    assert_int_equal(world_live_count(), live);
    world_release(NULL);
    scratch_remove(&s);
}

static void test_build_uses_the_spec_octree_def(void **state)
{
    (void)state;
    scratch s;
    scratch_make(&s);
    write_cube(&s, "cube.obj", 0);
    world_spec spec = cube_spec("fine");
    spec.def.resolution = 0.25;
    spec.def.mode = ACCURACY_SEED;
    spec.def.seed_epsilon = 1e-6;
    world *w = build_ok(&spec, s.dir);
    octree_info info;
    octree_get_info(w->tree, &info);
    assert_true(info.resolution == 0.25);
    assert_int_equal(info.max_level, 2); /* ceil(log2(1 / 0.25)) */
    assert_int_equal(info.mode, ACCURACY_SEED);
    world_release(w);

    /* A resolution needing more levels than max_depth is the engine's error, passed on. */
    spec.def.resolution = 1e-9;
    spec.def.max_depth = 4;
    char err[512];
    build_fails(&spec, s.dir, TRIOCT_ERR_LOAD_FAILED, err, sizeof err);
    assert_non_null(strstr(err, "world 'fine': "));
    assert_non_null(strstr(err, octree_status_text(OCTREE_ERR_DEPTH)));
    scratch_remove(&s);
}

static void test_build_merges_meshes(void **state)
{
    (void)state;
    scratch s;
    scratch_make(&s);
    write_cube(&s, "cube.obj", 0);
    write_cube(&s, "far/cube5.obj", 5);
    world_spec spec = cube_spec("two");
    snprintf(spec.meshes[1], sizeof spec.meshes[1], "far/cube5.obj");
    spec.mesh_count = 2;
    world *w = build_ok(&spec, s.dir);
    assert_int_equal(w->report.meshes, 2);
    assert_int_equal(w->report.triangles, 24);
    assert_vec_equal(w->report.bbox_lo, 0, 0, 0);
    assert_vec_equal(w->report.bbox_hi, 6, 6, 6);
    octree_info info;
    octree_get_info(w->tree, &info);
    assert_int_equal(info.triangle_count, 24);
    assert_int_equal(info.vertex_count, 16);
    /* The second file's indices were shifted onto its own vertices. */
    assert_true(closest_t(w->tree, vec3_make(5.5, 5.5, -1), vec3_make(0, 0, 1)) == 6.0);
    assert_true(closest_t(w->tree, vec3_make(0.5, 0.5, -1), vec3_make(0, 0, 1)) == 1.0);
    assert_true(closest_t(w->tree, vec3_make(3, 3, -1), vec3_make(0, 0, 1)) == -1.0);
    world_release(w);
    scratch_remove(&s);
}

/* The closest hit's t over a world's objects (-1 for a miss) and the object it names. */
static double closest_object_t(const world *w, vec3 origin, vec3 direction, uint32_t *object)
{
    ray_input ray = {origin, direction, 0, INFINITY, RAY_CROSSING};
    object_hit hit;
    object_ray_output out = {.hits = &hit, .max_hits = 1};
    assert_int_equal(object_set_ray(w->objects, &ray, RAY_CLOSEST, &out, NULL), OCTREE_OK);
    if (out.hit_count == 0)
        return -1.0;
    *object = hit.object;
    return hit.hit.t;
}

/* A world of objects: one file placed twice (loaded once into one model), each object that
 * model at its pose; answers name the object. */
static void test_build_places_objects(void **state)
{
    (void)state;
    scratch s;
    scratch_make(&s);
    write_cube(&s, "cube.obj", 0);
    world_spec spec;
    world_spec_init(&spec, "yard");
    snprintf(spec.meshes[0], sizeof spec.meshes[0], "cube.obj");
    spec.mesh_count = 1;
    /* "b" at the identity; "a" half a turn about z about the origin and 10 up: its cube
     * spans [-1, 0] x [-1, 0] x [10, 11]. */
    spec.object_count = 2;
    spec.objects[0] = (world_object_spec){"a", 0, {{-1, 0, 0, 0, -1, 0, 0, 0, 1}, {0, 0, 10}}, -1};
    spec.objects[1] = (world_object_spec){"b", 0, {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0}}, -1};
    world *w = build_ok(&spec, s.dir);
    assert_int_equal(w->report.triangles, 24);
    assert_vec_equal(w->report.bbox_lo, -1, -1, 0);
    assert_vec_equal(w->report.bbox_hi, 1, 1, 11);
    /* Two objects of one model: one tree, built once, shared; no single tree to ask. */
    assert_null(w->tree);
    assert_int_equal(w->objects->count, 2);
    assert_ptr_equal(w->objects->objects[0].model, w->objects->objects[1].model);
    assert_int_equal(w->objects->objects[0].model->mesh.triangle_count, 12);
    octree_info info;
    world_tree_info(w, &info);
    assert_int_equal(info.triangle_count, 24);
    octree_info one;
    octree_get_info(w->objects->objects[0].model->tree, &one);
    assert_int_equal(info.node_count, one.node_count);
    assert_int_equal(info.bytes_total, one.bytes_total);
    /* Rays name the object they meet: "a" from above at z = 11, "b" at z = 1. */
    uint32_t object = 99;
    assert_true(closest_object_t(w, vec3_make(-0.5, -0.5, 20), vec3_make(0, 0, -1), &object) == 9.0);
    assert_int_equal(object, 0);
    assert_true(closest_object_t(w, vec3_make(0.5, 0.5, 20), vec3_make(0, 0, -1), &object) == 19.0);
    assert_int_equal(object, 1);
    assert_true(closest_object_t(w, vec3_make(0.5, -0.5, 20), vec3_make(0, 0, -1), &object) == -1.0);
    world_release(w);

    /* One object at the identity is queried as its own tree. */
    spec.object_count = 1;
    spec.objects[0] = spec.objects[1];
    w = build_ok(&spec, s.dir);
    assert_non_null(w->tree);
    assert_true(closest_t(w->tree, vec3_make(0.5, 0.5, 20), vec3_make(0, 0, -1)) == 19.0);
    world_release(w);
    spec.object_count = 2;
    spec.objects[0] = (world_object_spec){"a", 0, {{-1, 0, 0, 0, -1, 0, 0, 0, 1}, {0, 0, 10}}, -1};

    /* An object naming no mesh, or a pose that is not a rotation, is refused. */
    char err[512];
    spec.objects[1].mesh = 3;
    build_fails(&spec, s.dir, TRIOCT_ERR_BAD_REQUEST, err, sizeof err);
    assert_non_null(strstr(err, "object b"));
    spec.objects[1].mesh = 0;
    spec.objects[1].at.r[0] = 2;
    build_fails(&spec, s.dir, TRIOCT_ERR_BAD_REQUEST, err, sizeof err);
    assert_non_null(strstr(err, "object b"));
    scratch_remove(&s);
}

static void test_build_applies_the_transform(void **state)
{
    (void)state;
    scratch s;
    scratch_make(&s);
    write_cube(&s, "cube.obj", 0);
    world_spec spec = cube_spec("moved");
    /* p' = R (2 p) + t with R the quarter turn about z, (x, y, z) -> (-y, x, z): the unit
     * cube goes to [-2, 0] x [0, 2] x [0, 2], then to [8, 10] x [20, 22] x [30, 32]. */
    spec.transform.scale = 2.0;
    const double quarter_z[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
    memcpy(spec.transform.r, quarter_z, sizeof quarter_z);
    spec.transform.t = vec3_make(10, 20, 30);
    spec.transform.identity = 0;
    world *w = build_ok(&spec, s.dir);
    assert_vec_equal(w->report.bbox_lo, 8, 20, 30);
    assert_vec_equal(w->report.bbox_hi, 10, 22, 32);
    assert_int_equal(w->report.triangles, 12);
    /* The octree holds the moved cube: a ray up through its middle meets z = 30. */
    assert_true(closest_t(w->tree, vec3_make(9, 21, 0), vec3_make(0, 0, 1)) == 30.0);
    assert_true(closest_t(w->tree, vec3_make(0.5, 0.5, -1), vec3_make(0, 0, 1)) == -1.0);
    octree_info info;
    octree_get_info(w->tree, &info);
    assert_true(info.world_min.x <= 8 && info.world_min.y <= 20 && info.world_min.z <= 30);
    world_release(w);

    /* A transform that overflows a finite file is refused, naming file and triangle. */
    spec.transform.scale = 1e308;
    memcpy(spec.transform.r, (double[9]){1, 0, 0, 0, 1, 0, 0, 0, 1}, 9 * sizeof(double));
    spec.transform.t = vec3_make(1e308, 0, 0);
    char err[512];
    build_fails(&spec, s.dir, TRIOCT_ERR_LOAD_FAILED, err, sizeof err);
    assert_string_equal(err, "world 'moved': cube.obj: triangle 0 has a coordinate that is not finite after the transform");
    scratch_remove(&s);
}

/* up = y: what stands along y in a Y-up file stands along trioct's z: (x, y, z) ->
 * (x, -z, y), before the transform. */
static void test_build_turns_y_up_files_to_z_up(void **state)
{
    (void)state;
    scratch s;
    scratch_make(&s);
    /* A box [0, 1] x [0, 3] x [0, 1] in its Y-up file: 3 high along y. */
    scratch_write(&s, "tall.obj",
                  "v 0 0 0\nv 1 0 0\nv 1 3 0\nv 0 3 0\nv 0 0 1\nv 1 0 1\nv 1 3 1\nv 0 3 1\n"
                  "f 1 2 3\nf 1 3 4\nf 5 7 6\nf 5 8 7\nf 1 5 6\nf 1 6 2\nf 2 6 7\nf 2 7 3\n"
                  "f 3 7 8\nf 3 8 4\nf 4 8 5\nf 4 5 1\n");
    world_spec spec;
    world_spec_init(&spec, "tall");
    snprintf(spec.meshes[0], sizeof spec.meshes[0], "tall.obj");
    spec.mesh_count = 1;
    spec.up_y = 1;
    world *w = build_ok(&spec, s.dir);
    /* 3 high along z now, and its old +z face at y = -1. */
    assert_vec_equal(w->report.bbox_lo, 0, -1, 0);
    assert_vec_equal(w->report.bbox_hi, 1, 0, 3);
    assert_true(closest_t(w->tree, vec3_make(0.5, -0.5, 10), vec3_make(0, 0, -1)) == 7.0);
    world_release(w);

    /* The turn comes first, then the transform: up 10 along z. */
    spec.transform.t = vec3_make(0, 0, 10);
    spec.transform.identity = 0;
    w = build_ok(&spec, s.dir);
    assert_vec_equal(w->report.bbox_lo, 0, -1, 10);
    assert_vec_equal(w->report.bbox_hi, 1, 0, 13);
    world_release(w);

    /* Without up = y the same file lies as written. */
    spec.up_y = 0;
    spec.transform.identity = 1;
    spec.transform.t = vec3_make(0, 0, 0);
    w = build_ok(&spec, s.dir);
    assert_vec_equal(w->report.bbox_hi, 1, 3, 1);
    world_release(w);
    scratch_remove(&s);
}

static void test_build_assimp_model_with_transform(void **state)
{
    (void)state;
    const char *rel = "PLY/Wuson.ply";
    mesh_data direct;
    mesh_load_report report;
    char err[512];
    if (mesh_load_file(MODELS "/PLY/Wuson.ply", &direct, &report, err, sizeof err) != 0)
        fail_msg("%s", err);

    world_spec spec;
    world_spec_init(&spec, "wuson");
    snprintf(spec.meshes[0], sizeof spec.meshes[0], "%s", rel);
    spec.mesh_count = 1;
    world *w = build_ok(&spec, MODELS);
    assert_int_equal(w->report.triangles, report.triangles);
    assert_int_equal(w->report.degenerate, report.degenerate);
    assert_int_equal(w->report.duplicates, report.duplicates);
    assert_vec_equal(w->report.bbox_lo, report.bbox_lo.x, report.bbox_lo.y, report.bbox_lo.z);
    assert_vec_equal(w->report.bbox_hi, report.bbox_hi.x, report.bbox_hi.y, report.bbox_hi.z);
    octree_info info;
    octree_get_info(w->tree, &info);
    assert_int_equal(info.triangle_count, direct.triangle_count);
    assert_int_equal(info.vertex_count, direct.vertex_count);
    world_release(w);

    /* Scale 2 and a quarter turn about z are exact; adding t rounds every coordinate
     * monotonically, so the bounds move exactly as the loader's bounds do. */
    spec.transform.scale = 2.0;
    memcpy(spec.transform.r, (double[9]){0, -1, 0, 1, 0, 0, 0, 0, 1}, 9 * sizeof(double));
    spec.transform.t = vec3_make(0.5, -0.25, 3);
    spec.transform.identity = 0;
    w = build_ok(&spec, MODELS);
    vec3 lo = report.bbox_lo, hi = report.bbox_hi;
    assert_vec_equal(w->report.bbox_lo, -2 * hi.y + 0.5, 2 * lo.x - 0.25, 2 * lo.z + 3);
    assert_vec_equal(w->report.bbox_hi, -2 * lo.y + 0.5, 2 * hi.x - 0.25, 2 * hi.z + 3);
    assert_int_equal(w->report.triangles, report.triangles);
    world_release(w);
    mesh_data_free(&direct);
}

static void test_build_refuses_nan_naming_file_and_triangle(void **state)
{
    (void)state;
    scratch s;
    scratch_make(&s);
    write_cube(&s, "cube.obj", 0);
    scratch_write(&s, "bad/nan.obj",
                  "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 1 nan 1\n"
                  "f 1 2 3\nf 1 3 4\nf 2 5 3\nf 1 2 4\n");
    world_spec spec = cube_spec("nan");
    snprintf(spec.meshes[1], sizeof spec.meshes[1], "bad/nan.obj");
    spec.mesh_count = 2;
    size_t live = world_live_count();
    char err[1024];
    build_fails(&spec, s.dir, TRIOCT_ERR_LOAD_FAILED, err, sizeof err);
    assert_non_null(strstr(err, "world 'nan': "));
    assert_non_null(strstr(err, "bad/nan.obj: triangle 2 has a NaN or infinite coordinate"));
    assert_int_equal(world_live_count(), live);

    /* Not a mesh at all. */
    scratch_write(&s, "junk.obj", "this is not a mesh\n");
    spec = cube_spec("junk");
    snprintf(spec.meshes[0], sizeof spec.meshes[0], "junk.obj");
    build_fails(&spec, s.dir, TRIOCT_ERR_LOAD_FAILED, err, sizeof err);
    assert_non_null(strstr(err, "junk.obj"));
    scratch_remove(&s);
}

static void test_build_refuses_bad_paths_and_bad_specs(void **state)
{
    (void)state;
    scratch s;
    scratch_make(&s);
    write_cube(&s, "cube.obj", 0);
    char err[1024];
    world_spec spec = cube_spec("paths");
    snprintf(spec.meshes[0], sizeof spec.meshes[0], "missing.obj");
    build_fails(&spec, s.dir, TRIOCT_ERR_BAD_PATH, err, sizeof err);
    assert_non_null(strstr(err, "world 'paths': missing.obj: No such file or directory"));
    snprintf(spec.meshes[0], sizeof spec.meshes[0], "../cube.obj");
    build_fails(&spec, s.dir, TRIOCT_ERR_BAD_PATH, err, sizeof err);
    assert_non_null(strstr(err, "'..' is refused"));
    snprintf(spec.meshes[0], sizeof spec.meshes[0], "/etc/hostname");
    build_fails(&spec, s.dir, TRIOCT_ERR_BAD_PATH, err, sizeof err);
    assert_non_null(strstr(err, "absolute paths are refused"));

    spec = cube_spec("none");
    spec.mesh_count = 0;
    build_fails(&spec, s.dir, TRIOCT_ERR_BAD_REQUEST, err, sizeof err);
    assert_string_equal(err, "world 'none' has 0 meshes (1 to 16)");
    spec = cube_spec("bad-name");
    build_fails(&spec, s.dir, TRIOCT_ERR_BAD_REQUEST, err, sizeof err);
    assert_string_equal(err, "invalid world name 'bad-name'");
    spec = cube_spec("noeffects");
    spec.effects = 0;
    build_fails(&spec, s.dir, TRIOCT_ERR_BAD_REQUEST, err, sizeof err);
    spec.effects = 16; /* 8 is EFFECT_DISTANCE */
    build_fails(&spec, s.dir, TRIOCT_ERR_BAD_REQUEST, err, sizeof err);
    int status = 0;
    assert_null(world_build(NULL, s.dir, NULL, &status, err, sizeof err));
    assert_int_equal(status, TRIOCT_ERR_BAD_REQUEST);
    scratch_remove(&s);
}

static void test_shapes_load_only_for_mesh_effect(void **state)
{
    (void)state;
    scratch s;
    scratch_make(&s);
    write_cube(&s, "cube.obj", 0);
    scratch_write(&s, "tools/tetra.obj", tetra_obj);
    world_spec spec = cube_spec("shaped");
    spec.transform.scale = 2.0; /* applies to the world, never to its query shapes */
    spec.transform.identity = 0;
    snprintf(spec.shapes[0].name, sizeof spec.shapes[0].name, "tetra");
    snprintf(spec.shapes[0].path, sizeof spec.shapes[0].path, "tools/tetra.obj");
    snprintf(spec.shapes[1].name, sizeof spec.shapes[1].name, "box");
    snprintf(spec.shapes[1].path, sizeof spec.shapes[1].path, "cube.obj");
    spec.shape_count = 2;

    spec.effects = EFFECT_RAYS | EFFECT_TRIANGLES;
    world *w = build_ok(&spec, s.dir);
    assert_int_equal(w->shape_count, 0);
    assert_null(w->shapes);
    assert_int_equal(w->bytes_shapes, 0);
    assert_null(world_find_shape(w, "tetra"));
    world_release(w);

    spec.effects = EFFECT_MESHES;
    w = build_ok(&spec, s.dir);
    assert_int_equal(w->shape_count, 2);
    const world_shape *tetra = world_find_shape(w, "tetra");
    const world_shape *box = world_find_shape(w, "box");
    assert_non_null(tetra);
    assert_non_null(box);
    assert_null(world_find_shape(w, "Tetra"));
    assert_null(world_find_shape(NULL, "tetra"));
    assert_int_equal(tetra->model->mesh.vertex_count, 4);
    assert_int_equal(tetra->model->mesh.triangle_count, 4);
    assert_int_equal(box->model->mesh.vertex_count, 8);
    assert_int_equal(box->model->mesh.triangle_count, 12);
    box3 b = mesh_data_bounds(&box->model->mesh);
    assert_vec_equal(b.lo, 0, 0, 0);
    assert_vec_equal(b.hi, 1, 1, 1); /* not scaled */
    assert_vec_equal(w->report.bbox_hi, 2, 2, 2);
    /* Each shape has its own tree in its own frame, with node bounds, counted in the
     * shapes' bytes. */
    assert_non_null(tetra->model->tree);
    assert_non_null(box->model->tree);
    octree_info ti, bi;
    octree_get_info(tetra->model->tree, &ti);
    octree_get_info(box->model->tree, &bi);
    assert_int_equal(ti.triangle_count, 4);
    assert_int_equal(bi.triangle_count, 12);
    assert_true(bi.bytes_node_bounds > 0);
    assert_vec_equal(bi.world_min, 0, 0, 0); /* its own frame, not scaled */
    assert_int_equal(w->bytes_shapes,
                     (4 + 8) * sizeof(vec3) + 3 * (4 + 12) * sizeof(uint32_t) + ti.bytes_total + bi.bytes_total);
    world_release(w);

    /* A missing shape only matters to a world that would load it. */
    snprintf(spec.shapes[1].path, sizeof spec.shapes[1].path, "tools/missing.obj");
    spec.effects = EFFECT_RAYS;
    w = build_ok(&spec, s.dir);
    world_release(w);
    spec.effects = EFFECT_ALL;
    char err[512];
    size_t live = world_live_count();
    build_fails(&spec, s.dir, TRIOCT_ERR_BAD_PATH, err, sizeof err);
    assert_non_null(strstr(err, "tools/missing.obj: No such file or directory"));
    assert_int_equal(world_live_count(), live);
    scratch_remove(&s);
}

#ifdef OCTREE_HAS_TRIANGLE_BOXES
static void test_triangle_boxes_follow_effects(void **state)
{
    (void)state;
    scratch s;
    scratch_make(&s);
    write_cube(&s, "cube.obj", 0);
    const struct {
        unsigned effects;
        int boxes;
    } cases[] = {
        {EFFECT_RAYS, 0},
        {EFFECT_TRIANGLES, 1},
        {EFFECT_MESHES, 1},
        {EFFECT_RAYS | EFFECT_MESHES, 1},
        {EFFECT_DISTANCE, 1}, /* the nearest-first walk prunes triangles by their boxes */
        {EFFECT_RAYS | EFFECT_DISTANCE, 1},
        {EFFECT_ALL, 1},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        world_spec spec = cube_spec("boxes");
        spec.effects = cases[i].effects;
        world *w = build_ok(&spec, s.dir);
        octree_info info;
        octree_get_info(w->tree, &info);
        assert_int_equal(info.bytes_triangle_boxes, cases[i].boxes ? 24 * 12 : 0);
        world_release(w);
    }
    scratch_remove(&s);
}
#endif

/* ---------- registry ---------- */

typedef struct world_factory {
    scratch s;
} world_factory;

static void factory_make(world_factory *f)
{
    scratch_make(&f->s);
    write_cube(&f->s, "cube.obj", 0);
}

static world *factory_build(world_factory *f, const char *name)
{
    world_spec spec = cube_spec(name);
    return build_ok(&spec, f->s.dir);
}

static void test_registry_versions_and_old_versions_live_on(void **state)
{
    (void)state;
    world_factory f;
    factory_make(&f);
    size_t live = world_live_count();
    registry *r = registry_create();
    assert_non_null(r);
    assert_null(registry_acquire(r, "a"));

    world *v1 = factory_build(&f, "a");
    assert_int_equal(registry_install(r, v1), 0);
    assert_int_equal(v1->version, 1);
    world *got = registry_acquire(r, "a");
    assert_ptr_equal(got, v1);
    assert_int_equal(atomic_load(&v1->refs), 2);

    /* A swap while v1 is held: v1 stays whole until its holder lets go. */
    world *v2 = factory_build(&f, "a");
    assert_int_equal(registry_install(r, v2), 0);
    assert_int_equal(v2->version, 2);
    assert_int_equal(atomic_load(&v1->refs), 1);
    assert_int_equal(world_live_count(), live + 2);
    assert_true(closest_t(got->tree, vec3_make(0.5, 0.5, -1), vec3_make(0, 0, 1)) == 1.0);
    assert_string_equal(got->spec.name, "a");
    world_release(got);
    assert_int_equal(world_live_count(), live + 1);

    got = registry_acquire(r, "a");
    assert_ptr_equal(got, v2);
    world_release(got);
    world *v3 = factory_build(&f, "a");
    assert_int_equal(registry_install(r, v3), 0);
    assert_int_equal(v3->version, 3);
    assert_int_equal(world_live_count(), live + 1);

    /* Removing and installing again starts over at version 1. */
    assert_int_equal(registry_remove(r, "a"), 0);
    assert_int_equal(registry_remove(r, "a"), -1);
    assert_null(registry_acquire(r, "a"));
    assert_int_equal(world_live_count(), live);
    world *again = factory_build(&f, "a");
    assert_int_equal(registry_install(r, again), 0);
    assert_int_equal(again->version, 1);

    /* Freeing the registry leaves an acquired world to its holder. */
    got = registry_acquire(r, "a");
    registry_free(r);
    assert_int_equal(world_live_count(), live + 1);
    assert_int_equal(atomic_load(&got->refs), 1);
    world_release(got);
    assert_int_equal(world_live_count(), live);
    scratch_remove(&f.s);
}

static void test_registry_errors_and_sorted_entries(void **state)
{
    (void)state;
    world_factory f;
    factory_make(&f);
    registry *r = registry_create();
    const char *names[] = {"m", "b", "z", "a", "b2"};
    for (size_t i = 0; i < 5; i++)
        assert_int_equal(registry_install(r, factory_build(&f, names[i])), 0);

    registry_set_error(r, "m", "m.obj: triangle 3 has a NaN or infinite coordinate");
    registry_set_error(r, "unknown", "ignored");
    registry_entry entries[8];
    size_t n = registry_entries(r, entries, 8);
    assert_int_equal(n, 5);
    const char *sorted[] = {"a", "b", "b2", "m", "z"};
    for (size_t i = 0; i < n; i++) {
        assert_string_equal(entries[i].w->spec.name, sorted[i]);
        assert_int_equal(atomic_load(&entries[i].w->refs), 2);
        assert_string_equal(entries[i].last_error, i == 3 ? "m.obj: triangle 3 has a NaN or infinite coordinate" : "");
    }
    registry_entries_free(entries, n);
    assert_null(entries[0].w);

    /* A short array gets the first entries; the count says how many there are. */
    assert_int_equal(registry_entries(r, entries, 2), 5);
    assert_string_equal(entries[1].w->spec.name, "b");
    registry_entries_free(entries, 2);
    assert_int_equal(registry_entries(r, NULL, 0), 5);

    /* A new version clears the error; the error survives acquire and a failed install. */
    world *m = registry_acquire(r, "m");
    assert_int_equal(atomic_load(&m->refs), 2);
    world_release(m);
    assert_int_equal(registry_install(r, factory_build(&f, "m")), 0);
    n = registry_entries(r, entries, 8);
    assert_string_equal(entries[3].last_error, "");
    assert_int_equal(entries[3].w->version, 2);
    registry_entries_free(entries, n);
    assert_int_equal(registry_remove(r, "b"), 0);
    n = registry_entries(r, entries, 8);
    assert_int_equal(n, 4);
    assert_string_equal(entries[1].w->spec.name, "b2");
    registry_entries_free(entries, n);
    registry_free(r);
    scratch_remove(&f.s);
}

static void test_registry_cap(void **state)
{
    (void)state;
    world_factory f;
    factory_make(&f);
    size_t live = world_live_count();
    registry *r = registry_create();
    char name[16];
    for (int i = 0; i < TRIOCT_MAX_WORLDS; i++) {
        snprintf(name, sizeof name, "w%02d", i);
        assert_int_equal(registry_install(r, factory_build(&f, name)), 0);
    }
    world *extra = factory_build(&f, "one_more");
    assert_int_equal(registry_install(r, extra), -1);
    assert_int_equal(atomic_load(&extra->refs), 1); /* not taken */
    assert_null(registry_acquire(r, "one_more"));
    world_release(extra);
    /* Replacing a world at the cap is no new entry. */
    assert_int_equal(registry_install(r, factory_build(&f, "w17")), 0);
    world *w17 = registry_acquire(r, "w17");
    assert_int_equal(w17->version, 2);
    world_release(w17);
    registry_entry *entries = calloc(TRIOCT_MAX_WORLDS, sizeof *entries);
    assert_int_equal(registry_entries(r, entries, TRIOCT_MAX_WORLDS), TRIOCT_MAX_WORLDS);
    for (int i = 0; i < TRIOCT_MAX_WORLDS; i++) {
        snprintf(name, sizeof name, "w%02d", i);
        assert_string_equal(entries[i].w->spec.name, name);
    }
    registry_entries_free(entries, TRIOCT_MAX_WORLDS);
    free(entries);
    assert_int_equal(registry_remove(r, "w00"), 0);
    extra = factory_build(&f, "one_more");
    assert_int_equal(registry_install(r, extra), 0);
    registry_free(r);
    assert_int_equal(world_live_count(), live);
    scratch_remove(&f.s);
}

/* ---------- registry under threads ---------- */

#define STRESS_INSTALLS 150
#define STRESS_READERS 3

typedef struct stress {
    registry *r;
    world_factory *f;
    atomic_int done;
    atomic_int failures;
    uint64_t acquired[STRESS_READERS];
} stress;

typedef struct reader_arg {
    stress *st;
    int index;
} reader_arg;

static void *stress_reader(void *p)
{
    reader_arg *arg = p;
    stress *st = arg->st;
    uint64_t last_version = 0, count = 0;
    while (!atomic_load(&st->done)) {
        world *w = registry_acquire(st->r, "stress");
        if (!w || w->version < last_version || strcmp(w->spec.name, "stress") != 0 ||
            atomic_load(&w->refs) < 1) {
            atomic_fetch_add(&st->failures, 1);
        } else {
            last_version = w->version;
            /* Use the world while the installer may be replacing it. */
            ray_input ray = {vec3_make(0.5, 0.5, -1), vec3_make(0, 0, 1), 0.0, INFINITY, RAY_CROSSING};
            ray_hit hit;
            ray_output out = {0, 0, &hit, 1};
            if (octree_ray(w->tree, &ray, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL) != OCTREE_OK ||
                out.hit_count != 1 || hit.t != 1.0)
                atomic_fetch_add(&st->failures, 1);
            atomic_fetch_add(&w->queries, 1);
            count++;
        }
        if (w)
            world_release(w);
    }
    st->acquired[arg->index] = count;
    return NULL;
}

static void test_registry_stress(void **state)
{
    (void)state;
    world_factory f;
    factory_make(&f);
    size_t live = world_live_count();
    stress st = {.r = registry_create(), .f = &f};
    atomic_init(&st.done, 0);
    atomic_init(&st.failures, 0);
    assert_int_equal(registry_install(st.r, factory_build(&f, "stress")), 0);

    pthread_t readers[STRESS_READERS];
    reader_arg args[STRESS_READERS];
    for (int i = 0; i < STRESS_READERS; i++) {
        args[i] = (reader_arg){&st, i};
        assert_int_equal(pthread_create(&readers[i], NULL, stress_reader, &args[i]), 0);
    }
    /* The fourth thread, this one, installs new versions as fast as it builds them. */
    for (int i = 0; i < STRESS_INSTALLS; i++)
        assert_int_equal(registry_install(st.r, factory_build(&f, "stress")), 0);
    atomic_store(&st.done, 1);
    for (int i = 0; i < STRESS_READERS; i++)
        assert_int_equal(pthread_join(readers[i], NULL), 0);

    assert_int_equal(atomic_load(&st.failures), 0);
    uint64_t total = 0;
    for (int i = 0; i < STRESS_READERS; i++)
        total += st.acquired[i];
    assert_true(total > 0);
    world *w = registry_acquire(st.r, "stress");
    assert_int_equal(w->version, STRESS_INSTALLS + 1);
    world_release(w);
    assert_int_equal(world_live_count(), live + 1); /* every replaced version was freed */
    registry_free(st.r);
    assert_int_equal(world_live_count(), live);
    printf("registry stress: %d installs, %llu acquisitions by %d readers\n", STRESS_INSTALLS,
           (unsigned long long)total, STRESS_READERS);
    scratch_remove(&f.s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_resolve_refuses_absolute_parent_and_missing),
        cmocka_unit_test(test_resolve_follows_symlinks_but_stays_inside),
        cmocka_unit_test(test_good_nested_path),
        cmocka_unit_test(test_resolve_into_mesh_roots),
        cmocka_unit_test(test_build_turns_y_up_files_to_z_up),
        cmocka_unit_test(test_build_unit_cube),
        cmocka_unit_test(test_build_uses_the_spec_octree_def),
        cmocka_unit_test(test_build_merges_meshes),
        cmocka_unit_test(test_build_places_objects),
        cmocka_unit_test(test_build_applies_the_transform),
        cmocka_unit_test(test_build_assimp_model_with_transform),
        cmocka_unit_test(test_build_refuses_nan_naming_file_and_triangle),
        cmocka_unit_test(test_build_refuses_bad_paths_and_bad_specs),
        cmocka_unit_test(test_shapes_load_only_for_mesh_effect),
#ifdef OCTREE_HAS_TRIANGLE_BOXES
        cmocka_unit_test(test_triangle_boxes_follow_effects),
#endif
        cmocka_unit_test(test_registry_versions_and_old_versions_live_on),
        cmocka_unit_test(test_registry_errors_and_sorted_entries),
        cmocka_unit_test(test_registry_cap),
        cmocka_unit_test(test_registry_stress),
    };
    return cmocka_run_group_tests_name("world", tests, NULL, NULL);
}
