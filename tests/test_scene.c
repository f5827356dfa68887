/* Scene file tests: every key parsed into exact values (rotations exact at quarter turns),
 * the [daemon] section kept raw, every kind of error refused with its file and line, and
 * world_spec_equal. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "world/scene.h"

/* ---------- scratch scene files ---------- */

typedef struct scratch {
    char dir[64];
    char path[96];
} scratch;

static void scratch_write(scratch *s, const char *text, size_t len)
{
    snprintf(s->dir, sizeof s->dir, "/tmp/trioct_scene_XXXXXX");
    assert_non_null(mkdtemp(s->dir));
    snprintf(s->path, sizeof s->path, "%s/scene.ini", s->dir);
    FILE *f = fopen(s->path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(text, 1, len, f), len);
    assert_int_equal(fclose(f), 0);
}

static void scratch_remove(scratch *s)
{
    unlink(s->path);
    rmdir(s->dir);
}

typedef struct loaded {
    int status;
    scene sc;
    char err[1024];
    char path[96];
} loaded;

static loaded load_text(const char *text)
{
    scratch s;
    scratch_write(&s, text, strlen(text));
    loaded l;
    memset(&l, 0, sizeof l);
    l.status = scene_load(s.path, &l.sc, l.err, sizeof l.err);
    snprintf(l.path, sizeof l.path, "%s", s.path);
    scratch_remove(&s);
    return l;
}

/* The scene must be refused with "path:line: ..." containing what, and leave out empty. */
static void expect_error_at(const char *text, int line, const char *what)
{
    loaded l = load_text(text);
    char prefix[160];
    snprintf(prefix, sizeof prefix, "%s:%d: ", l.path, line);
    if (l.status != -1 || strncmp(l.err, prefix, strlen(prefix)) != 0 || !strstr(l.err, what))
        fail_msg("scene\n%s\nexpected -1 and \"%s...%s...\", got %d and \"%s\"", text, prefix, what,
                 l.status, l.err);
    assert_int_equal(l.sc.world_count, 0);
    assert_null(l.sc.worlds);
    assert_int_equal(l.sc.daemon_option_count, 0);
    assert_null(l.sc.daemon_options);
    scene_free(&l.sc);
}

static const world_spec *load_one_world(loaded *l, const char *text)
{
    *l = load_text(text);
    if (l->status != 0)
        fail_msg("scene refused: %s", l->err);
    assert_int_equal(l->sc.world_count, 1);
    return &l->sc.worlds[0];
}

static void assert_matrix_equal(const double *got, const double *want)
{
    for (int i = 0; i < 9; i++)
        if (!(got[i] == want[i]))
            fail_msg("entry %d: got %.17g, want %.17g", i, got[i], want[i]);
}

/* ---------- parsing a good scene ---------- */

static const char good_scene[] =
    "; a scene using every key\n"              /* 1 */
    "[daemon]\n"                               /* 2 */
    "prefix = ROBOTS\n"                        /* 3 */
    "world_dir = worlds/here\n"                /* 4 */
    "anything_at_all = not checked here\n"     /* 5 */
    "\n"                                       /* 6 */
    "[warehouse]\n"                            /* 7 */
    "mesh = shelves.obj\n"                     /* 8 */
    "mesh = sub/floor.stl\n"                   /* 9 */
    "scale = 0.5\n"                            /* 10 */
    "rotate = 0 0 90\n"                        /* 11 */
    "translate = 1, -2, 3.25\n"                /* 12 */
    "resolution = 0.125\n"                     /* 13 */
    "max_depth = 12\n"                         /* 14 */
    "accuracy = seed\n"                        /* 15 */
    "seed_epsilon = 1e-7\n"                    /* 16 */
    "effects = rays, meshes\n"                 /* 17 */
    "shape.gripper = gripper.stl\n"            /* 18 */
    "shape.box_2 = tools/box.obj\n"            /* 19 */
    "\n"                                       /* 20 */
    "# a comment of the other kind\n"          /* 21 */
    "[plain]\n"                                /* 22 */
    "    mesh = a.obj   ; indented, with a comment\n"  /* 23 */
    "    resolution = auto\n";                 /* 24 */

static void test_good_scene_every_key(void **state)
{
    (void)state;
    loaded l = load_text(good_scene);
    if (l.status != 0)
        fail_msg("%s", l.err);
    assert_string_equal(l.sc.path, l.path);

    assert_int_equal(l.sc.daemon_option_count, 3);
    const scene_option *o = l.sc.daemon_options;
    assert_string_equal(o[0].key, "prefix");
    assert_string_equal(o[0].value, "ROBOTS");
    assert_int_equal(o[0].line, 3);
    assert_string_equal(o[1].key, "world_dir");
    assert_string_equal(o[1].value, "worlds/here");
    assert_int_equal(o[1].line, 4);
    assert_string_equal(o[2].key, "anything_at_all");
    assert_string_equal(o[2].value, "not checked here");
    assert_int_equal(o[2].line, 5);

    assert_int_equal(l.sc.world_count, 2);
    const world_spec *w = &l.sc.worlds[0];
    assert_string_equal(w->name, "warehouse");
    char source[200];
    snprintf(source, sizeof source, "%s [warehouse]", l.path);
    assert_string_equal(w->source, source);
    assert_int_equal(w->mesh_count, 2);
    assert_string_equal(w->meshes[0], "shelves.obj");
    assert_string_equal(w->meshes[1], "sub/floor.stl");
    assert_true(w->transform.scale == 0.5);
    const double quarter_z[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
    assert_matrix_equal(w->transform.r, quarter_z);
    assert_true(w->transform.t.x == 1.0 && w->transform.t.y == -2.0 && w->transform.t.z == 3.25);
    assert_int_equal(w->transform.identity, 0);
    assert_true(w->def.resolution == 0.125);
    assert_int_equal(w->def.max_depth, 12);
    assert_int_equal(w->def.mode, ACCURACY_SEED);
    assert_true(w->def.seed_epsilon == 1e-7);
    assert_int_equal(w->effects, EFFECT_RAYS | EFFECT_MESHES);
    assert_int_equal(w->shape_count, 2);
    assert_string_equal(w->shapes[0].name, "gripper");
    assert_string_equal(w->shapes[0].path, "gripper.stl");
    assert_string_equal(w->shapes[1].name, "box_2");
    assert_string_equal(w->shapes[1].path, "tools/box.obj");

    /* Everything left out takes the defaults of world_spec_init. */
    const world_spec *p = &l.sc.worlds[1];
    world_spec expected;
    world_spec_init(&expected, "plain");
    snprintf(expected.meshes[0], sizeof expected.meshes[0], "a.obj");
    expected.mesh_count = 1;
    assert_true(world_spec_equal(p, &expected));
    assert_int_equal(p->transform.identity, 1);
    assert_true(p->def.resolution == 0.0);
    octree_def def = octree_default_def();
    assert_int_equal(p->def.max_depth, def.max_depth);
    assert_int_equal(p->def.mode, ACCURACY_EXACT);
    assert_int_equal(p->effects, EFFECT_ALL);
    assert_int_equal(p->shape_count, 0);
    snprintf(source, sizeof source, "%s [plain]", l.path);
    assert_string_equal(p->source, source);

    assert_ptr_equal(scene_find(&l.sc, "plain"), p);
    assert_ptr_equal(scene_find(&l.sc, "warehouse"), w);
    assert_null(scene_find(&l.sc, "daemon"));
    assert_null(scene_find(&l.sc, "Plain"));
    scene_free(&l.sc);
    assert_null(l.sc.worlds);
    assert_int_equal(l.sc.world_count, 0);
}

static void test_scene_without_daemon_section_and_with_bom_and_crlf(void **state)
{
    (void)state;
    loaded l = load_text("\xEF\xBB\xBF[w]\r\nmesh = m.obj\r\nmax_depth = 0\r\n");
    if (l.status != 0)
        fail_msg("%s", l.err);
    assert_int_equal(l.sc.daemon_option_count, 0);
    assert_int_equal(l.sc.world_count, 1);
    assert_string_equal(l.sc.worlds[0].meshes[0], "m.obj");
    assert_int_equal(l.sc.worlds[0].def.max_depth, 0);
    scene_free(&l.sc);

    l = load_text("[w]\nmesh = m.obj\nmax_depth = 21\nresolution = 1e-3\n");
    assert_int_equal(l.status, 0);
    assert_int_equal(l.sc.worlds[0].def.max_depth, OCTREE_MAX_DEPTH_CAP);
    assert_true(l.sc.worlds[0].def.resolution == 1e-3);
    scene_free(&l.sc);
}

/* ---------- rotations ---------- */

/* cos and sin of k quarter turns as integers, and R = Rz Ry Rx multiplied in integers:
 * an independent way to the exact matrix a scene with quarter-turn angles must give. */
static void quarter_cos_sin(int k, int *c, int *s)
{
    static const int cs[4][2] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
    k = ((k % 4) + 4) % 4;
    *c = cs[k][0];
    *s = cs[k][1];
}

static void int_mul(const int a[9], const int b[9], int out[9])
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            out[3 * i + j] = a[3 * i] * b[j] + a[3 * i + 1] * b[3 + j] + a[3 * i + 2] * b[6 + j];
}

static void quarter_turn_matrix(int kx, int ky, int kz, double out[9])
{
    int cx, sx, cy, sy, cz, sz;
    quarter_cos_sin(kx, &cx, &sx);
    quarter_cos_sin(ky, &cy, &sy);
    quarter_cos_sin(kz, &cz, &sz);
    const int rx[9] = {1, 0, 0, 0, cx, -sx, 0, sx, cx};
    const int ry[9] = {cy, 0, sy, 0, 1, 0, -sy, 0, cy};
    const int rz[9] = {cz, -sz, 0, sz, cz, 0, 0, 0, 1};
    int zy[9], zyx[9];
    int_mul(rz, ry, zy);
    int_mul(zy, rx, zyx);
    for (int i = 0; i < 9; i++)
        out[i] = zyx[i];
}

static void rotation_of(const char *angles, double r[9], int *identity)
{
    char text[160];
    snprintf(text, sizeof text, "[w]\nmesh = m.obj\nrotate = %s\n", angles);
    loaded l;
    const world_spec *w = load_one_world(&l, text);
    memcpy(r, w->transform.r, 9 * sizeof *r);
    *identity = w->transform.identity;
    scene_free(&l.sc);
}

static void test_rotations_at_quarter_turns_are_exact(void **state)
{
    (void)state;
    /* Every combination of quarter turns, written in degrees, some beyond a full turn or
     * negative: the matrix must be the integer one, entry for entry. */
    for (int kx = -1; kx <= 4; kx++) {
        for (int ky = -1; ky <= 4; ky++) {
            for (int kz = -1; kz <= 4; kz++) {
                char angles[64];
                snprintf(angles, sizeof angles, "%d %d %d", 90 * kx, 90 * ky, 90 * kz + (kz == 4 ? 720 : 0));
                double got[9], want[9];
                int identity;
                rotation_of(angles, got, &identity);
                quarter_turn_matrix(kx, ky, kz, want);
                for (int i = 0; i < 9; i++)
                    if (!(got[i] == want[i]))
                        fail_msg("rotate = %s: entry %d is %.17g, want %.17g", angles, i, got[i], want[i]);
                int want_identity = 1;
                for (int i = 0; i < 9; i++)
                    want_identity &= want[i] == (i % 4 == 0 ? 1.0 : 0.0);
                assert_int_equal(identity, want_identity);
            }
        }
    }
}

static void apply(const double r[9], const double p[3], double out[3])
{
    for (int i = 0; i < 3; i++)
        out[i] = r[3 * i] * p[0] + r[3 * i + 1] * p[1] + r[3 * i + 2] * p[2];
}

static void test_rotation_order_is_x_then_y_then_z_about_fixed_axes(void **state)
{
    (void)state;
    double r[9], q[3];
    int identity;
    /* 90 about x takes y to z; 90 about z then leaves z and takes x to y. Rotating about z
     * first would send x to y and then y to z instead. */
    rotation_of("90 0 90", r, &identity);
    apply(r, (double[3]){0, 1, 0}, q);
    assert_true(q[0] == 0 && q[1] == 0 && q[2] == 1);
    apply(r, (double[3]){1, 0, 0}, q);
    assert_true(q[0] == 0 && q[1] == 1 && q[2] == 0);
    /* Right-handed: 90 about z takes x to y; about y takes z to x; about x takes y to z. */
    rotation_of("0 90 0", r, &identity);
    apply(r, (double[3]){0, 0, 1}, q);
    assert_true(q[0] == 1 && q[1] == 0 && q[2] == 0);
}

static void test_rotation_at_other_angles_is_orthonormal(void **state)
{
    (void)state;
    double r[9];
    int identity;
    rotation_of("30 0 0", r, &identity);
    assert_int_equal(identity, 0);
    assert_true(r[0] == 1 && r[1] == 0 && r[2] == 0 && r[3] == 0 && r[6] == 0);
    assert_true(fabs(r[4] - sqrt(3.0) / 2) <= 1e-15 && fabs(r[7] - 0.5) <= 1e-15);
    assert_true(r[5] == -r[7] && r[8] == r[4]);

    rotation_of("17.5 -123 400.25", r, &identity);
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            double dot = r[i] * r[j] + r[3 + i] * r[3 + j] + r[6 + i] * r[6 + j];
            assert_true(fabs(dot - (i == j ? 1.0 : 0.0)) <= 1e-15);
        }
    }
    /* Whole turns more or less give the same rotation to the last bit: the angle is reduced
     * (exactly) before any trigonometry. */
    double again[9];
    rotation_of("377.5 -483 40.25", again, &identity);
    for (int i = 0; i < 9; i++)
        assert_true(again[i] == r[i]);
}

static void test_identity_flag(void **state)
{
    (void)state;
    static const struct {
        const char *keys;
        int identity;
    } cases[] = {
        {"", 1},
        {"scale = 1\nrotate = 0 0 360\ntranslate = 0 0 0\n", 1},
        {"rotate = -360 720 0\n", 1},
        {"translate = -0 0 -0\n", 1},
        {"scale = 1.0000000000000002\n", 0},
        {"translate = 0 0 1e-300\n", 0},
        {"rotate = 0 180 0\n", 0},
        {"rotate = 1e-9 0 0\n", 0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char text[256];
        snprintf(text, sizeof text, "[w]\nmesh = m.obj\n%s", cases[i].keys);
        loaded l;
        const world_spec *w = load_one_world(&l, text);
        if (w->transform.identity != cases[i].identity)
            fail_msg("%s: identity %d", cases[i].keys, w->transform.identity);
        scene_free(&l.sc);
    }
}

static void test_up_axis(void **state)
{
    (void)state;
    loaded l;
    const world_spec *w = load_one_world(&l, "[w]\nmesh = m.gltf\nup = y\n");
    assert_int_equal(w->up_y, 1);
    world_spec z_up = *w;
    z_up.up_y = 0;
    /* A reload that changes up rebuilds the world. */
    assert_false(world_spec_equal(w, &z_up));
    scene_free(&l.sc);
    w = load_one_world(&l, "[w]\nmesh = m.obj\nup = z\n");
    assert_int_equal(w->up_y, 0);
    scene_free(&l.sc);
    w = load_one_world(&l, "[w]\nmesh = m.obj\n");
    assert_int_equal(w->up_y, 0);
    scene_free(&l.sc);
    expect_error_at("[w]\nmesh = a.obj\nup = x\n", 3, "up must be z (the default) or y (for Y-up files), not 'x'");
    expect_error_at("[w]\nmesh = a.obj\nup = y\nup = y\n", 4, "up given twice");
}

/* ---------- errors ---------- */

static void test_unknown_key_and_syntax_errors(void **state)
{
    (void)state;
    expect_error_at("[w]\nmesh = a.obj\ncolour = red\n", 3, "unknown key 'colour' in world 'w'");
    expect_error_at("[w]\nmesh = a.obj\nMesh = b.obj\n", 3, "unknown key 'Mesh'");
    expect_error_at("[w]\nmesh = a.obj\njust some words\n", 3, "syntax error");
    expect_error_at("[w]\nmesh = a.obj\n[broken\nmesh = b.obj\n", 3, "syntax error");
    expect_error_at("mesh = a.obj\n[w]\nmesh = a.obj\n", 1, "'mesh' outside any section");
    expect_error_at("[w]\nmesh = a.obj\nscale = 2\nscale = 3\n", 4, "scale given twice");
    expect_error_at("[w]\nmesh = a.obj\neffects = rays\n  effects = meshes\n", 4, "effects given twice");
    /* The first error in the file wins, whoever finds it. */
    expect_error_at("[w]\nmesh = a.obj\nno equals here\nscale = -1\n", 3, "syntax error");
    expect_error_at("[w]\nmesh = a.obj\nscale = -1\nno equals here\n", 3, "scale must be a positive number");

    char long_line[400];
    snprintf(long_line, sizeof long_line, "[w]\nmesh = %0300d.obj\n", 7);
    expect_error_at(long_line, 2, "line longer than");

    const char with_nul[] = "[w]\nmesh = a.obj\nsca\0le = 2\n";
    scratch s;
    scratch_write(&s, with_nul, sizeof with_nul - 1);
    scene sc;
    char err[512];
    assert_int_equal(scene_load(s.path, &sc, err, sizeof err), -1);
    char prefix[160];
    snprintf(prefix, sizeof prefix, "%s:3: a NUL byte in the line", s.path);
    assert_string_equal(err, prefix);
    scratch_remove(&s);
}

static void test_bad_numbers(void **state)
{
    (void)state;
    const char *const scales[] = {"two", "0", "-1", "nan", "inf", "1e999", "2 3", ""};
    for (size_t i = 0; i < sizeof scales / sizeof scales[0]; i++) {
        char text[128];
        snprintf(text, sizeof text, "[w]\nmesh = a.obj\n\nscale = %s\n", scales[i]);
        expect_error_at(text, 4, "scale must be a positive number");
    }
    const char *const triples[] = {"1 2", "1 2 3 4", "1 2 x", "1 nan 3", "1 2 -inf", "", "1;2;3"};
    for (size_t i = 0; i < sizeof triples / sizeof triples[0]; i++) {
        char text[128];
        snprintf(text, sizeof text, "[w]\nmesh = a.obj\ntranslate = %s\n", triples[i]);
        expect_error_at(text, 3, "translate must be three numbers");
        snprintf(text, sizeof text, "[w]\nrotate = %s\nmesh = a.obj\n", triples[i]);
        expect_error_at(text, 2, "rotate must be three angles");
    }
    expect_error_at("[w]\nmesh = a.obj\nseed_epsilon = -1e-9\n", 3, "seed_epsilon must be a number >= 0");
    expect_error_at("[w]\nmesh = a.obj\nseed_epsilon = small\n", 3, "seed_epsilon must be a number >= 0");
}

static void test_bad_resolution_depth_accuracy_effects(void **state)
{
    (void)state;
    const char *const resolutions[] = {"0", "-0.5", "-0", "Auto", "fine", "nan"};
    for (size_t i = 0; i < sizeof resolutions / sizeof resolutions[0]; i++) {
        char text[128];
        snprintf(text, sizeof text, "[w]\nmesh = a.obj\nresolution = %s\n", resolutions[i]);
        expect_error_at(text, 3, "resolution must be 'auto' or a positive length");
    }
    const char *const depths[] = {"-1", "22", "3.5", "x", "", "99999999999999999999"};
    for (size_t i = 0; i < sizeof depths / sizeof depths[0]; i++) {
        char text[128];
        snprintf(text, sizeof text, "[w]\nmesh = a.obj\nmax_depth = %s\n", depths[i]);
        expect_error_at(text, 3, "max_depth must be an integer from 0 to 21");
    }
    expect_error_at("[w]\naccuracy = precise\nmesh = a.obj\n", 2, "accuracy must be exact, seed or fast, not 'precise'");
    expect_error_at("[w]\naccuracy = EXACT\nmesh = a.obj\n", 2, "accuracy must be exact, seed or fast");
    expect_error_at("[w]\nmesh = a.obj\neffects =\n", 3, "effects: no effect given");
    expect_error_at("[w]\nmesh = a.obj\neffects = , ,\n", 3, "effects: no effect given");
    expect_error_at("[w]\nmesh = a.obj\neffects = rays lasers\n", 3, "effects: unknown effect 'lasers'");
}

static void test_too_many_meshes_and_shapes(void **state)
{
    (void)state;
    char text[4096] = "[w]\n";
    for (int i = 0; i < SCENE_MAX_MESHES; i++)
        snprintf(text + strlen(text), sizeof text - strlen(text), "mesh = m%d.obj\n", i);
    loaded l = load_text(text);
    assert_int_equal(l.status, 0);
    assert_int_equal(l.sc.worlds[0].mesh_count, SCENE_MAX_MESHES);
    assert_string_equal(l.sc.worlds[0].meshes[SCENE_MAX_MESHES - 1], "m15.obj");
    scene_free(&l.sc);
    strcat(text, "mesh = one_too_many.obj\n");
    expect_error_at(text, SCENE_MAX_MESHES + 2, "more than 16 meshes in world 'w'");

    snprintf(text, sizeof text, "[w]\nmesh = a.obj\n");
    for (int i = 0; i < TRIOCT_MAX_SHAPES; i++)
        snprintf(text + strlen(text), sizeof text - strlen(text), "shape.s%d = s%d.stl\n", i, i);
    l = load_text(text);
    assert_int_equal(l.status, 0);
    assert_int_equal(l.sc.worlds[0].shape_count, TRIOCT_MAX_SHAPES);
    scene_free(&l.sc);
    strcat(text, "shape.extra = e.stl\n");
    expect_error_at(text, TRIOCT_MAX_SHAPES + 3, "more than 16 shapes in world 'w'");

    expect_error_at("[w]\nmesh = a.obj\nshape.g = g.stl\nshape.g = h.stl\n", 4, "shape 'g' given twice");
    expect_error_at("[w]\nmesh = a.obj\nmesh =\n", 3, "mesh needs a file path");
    expect_error_at("[w]\nmesh = a.obj\nshape.g =\n", 3, "shape.g needs a file path");
}

static void test_bad_names(void **state)
{
    (void)state;
    expect_error_at("[my-world]\nmesh = a.obj\n", 1, "invalid world name 'my-world'");
    expect_error_at("[w]\nmesh = a.obj\n[]\nmesh = a.obj\n", 3, "invalid world name ''");
    expect_error_at("[w]\nmesh = a.obj\n[ spaced ]\nmesh = a.obj\n", 3, "invalid world name ' spaced '");
    /* 32 characters are fine, 33 are not. */
    loaded l = load_text("[abcdefghijklmnopqrstuvwxyz_01234]\nmesh = a.obj\n");
    assert_int_equal(l.status, 0);
    scene_free(&l.sc);
    expect_error_at("[w]\nmesh = a.obj\n[abcdefghijklmnopqrstuvwxyz_012345]\n", 3,
                    "invalid world name 'abcdefghijklmnopqrstuvwxyz_012345'");
    expect_error_at("[w]\nmesh = a.obj\nshape.bad-name = s.stl\n", 3, "invalid shape name 'bad-name'");
    expect_error_at("[w]\nmesh = a.obj\nshape. = s.stl\n", 3, "invalid shape name ''");
    expect_error_at("[w]\nmesh = a.obj\nshape.abcdefghijklmnopqrstuvwxyz_012345 = s.stl\n", 3,
                    "invalid shape name");
}

static void test_duplicate_sections_and_worlds_without_mesh(void **state)
{
    (void)state;
    expect_error_at("[a]\nmesh = a.obj\n[b]\nmesh = b.obj\n\n[a]\nmesh = c.obj\n", 6,
                    "duplicate section [a] (first at line 1)");
    expect_error_at("[a]\nmesh = a.obj\n[a]\n", 3, "duplicate section [a] (first at line 1)");
    expect_error_at("[daemon]\nprefix = X\n[w]\nmesh = a.obj\n[daemon]\n", 5,
                    "duplicate section [daemon] (first at line 1)");
    expect_error_at("[a]\nscale = 2\n[b]\nmesh = b.obj\n", 1, "world 'a' has no mesh");
    expect_error_at("[a]\nmesh = a.obj\n\n[empty]\n", 4, "world 'empty' has no mesh");
}

/* ---------- objects ---------- */

/* Objects and their poses, in either order; objects of one file share its mesh; they are
 * kept in name order; an object without a pose stands at the identity. */
static void test_objects_and_poses(void **state)
{
    (void)state;
    loaded l;
    const world_spec *w = load_one_world(&l, "[bench]\n"
                                             "pose.zeta = 1 2 3 0 0 0 1\n"
                                             "object.zeta = parts/crate.obj\n"
                                             "object.alpha = parts/ball.obj\n"
                                             "object.mid = parts/crate.obj\n"
                                             "pose.mid = 0.5 0 -1 0.7071067811865476 0.7071067811865476 0 0\n"
                                             "object.shelf.left-2 = parts/crate.obj\n");
    /* Object names follow the one rule of object names: dots and dashes too. */
    assert_int_equal(w->object_count, 4);
    assert_string_equal(w->objects[3].name, "zeta");
    assert_string_equal(w->objects[2].name, "shelf.left-2");
    assert_int_equal(w->objects[2].mesh, w->objects[1].mesh);
    scene_free(&l.sc);
    w = load_one_world(&l, "[bench]\n"
                           "pose.zeta = 1 2 3 0 0 0 1\n"
                           "object.zeta = parts/crate.obj\n"
                           "object.alpha = parts/ball.obj\n"
                           "object.mid = parts/crate.obj\n"
                           "pose.mid = 0.5 0 -1 0.7071067811865476 0.7071067811865476 0 0\n");
    assert_int_equal(w->object_count, 3);
    assert_int_equal(w->mesh_count, 2); /* crate once, ball once */
    assert_string_equal(w->objects[0].name, "alpha");
    assert_string_equal(w->objects[1].name, "mid");
    assert_string_equal(w->objects[2].name, "zeta");
    assert_string_equal(w->meshes[w->objects[0].mesh], "parts/ball.obj");
    assert_int_equal(w->objects[1].mesh, w->objects[2].mesh);
    const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, half_turn_z[9] = {-1, 0, 0, 0, -1, 0, 0, 0, 1};
    assert_matrix_equal(w->objects[0].at.r, identity);
    assert_true(w->objects[0].at.t.x == 0 && w->objects[0].at.t.y == 0 && w->objects[0].at.t.z == 0);
    assert_matrix_equal(w->objects[2].at.r, half_turn_z);
    assert_true(w->objects[2].at.t.x == 1 && w->objects[2].at.t.y == 2 && w->objects[2].at.t.z == 3);
    /* A quarter turn about x, normalised from its rounded quaternion. */
    assert_int_equal(octree_pose_check(&w->objects[1].at), OCTREE_OK);
    assert_true(fabs(w->objects[1].at.r[5] + 1) < 1e-15 && fabs(w->objects[1].at.r[7] - 1) < 1e-15);

    /* The same objects with the pose lines elsewhere are the same world; a moved object is
     * not. */
    loaded m;
    const world_spec *v = load_one_world(&m, "[bench]\n"
                                             "object.zeta = parts/crate.obj\n"
                                             "pose.mid = 0.5 0 -1 0.7071067811865476 0.7071067811865476 0 0\n"
                                             "object.alpha = parts/ball.obj\n"
                                             "object.mid = parts/crate.obj\n"
                                             "pose.zeta = 1 2 3 0 0 0 1\n");
    assert_true(world_spec_equal(w, v));
    world_spec moved = *v;
    moved.objects[2].at.t.x = 1.5;
    assert_false(world_spec_equal(v, &moved));
    scene_free(&l.sc);
    scene_free(&m.sc);
}

static void test_object_errors(void **state)
{
    (void)state;
    expect_error_at("[w]\nobject.a = a.obj\npose.b = 0 0 0 1 0 0 0\n", 1, "pose.b names no object");
    expect_error_at("[w]\nobject.a = a.obj\nobject.a = b.obj\n", 3, "object 'a' given twice");
    expect_error_at("[w]\nobject.a = a.obj\npose.a = 0 0 0 1 0 0 0\npose.a = 1 0 0 1 0 0 0\n", 4,
                    "pose of object 'a' given twice");
    expect_error_at("[w]\nobject.a = a.obj\npose.a = 0 0 0 2 0 0 0\n", 3, "must have length 1");
    expect_error_at("[w]\nobject.a = a.obj\npose.a = 0 0 0 0 0 0 0\n", 3, "must have length 1");
    expect_error_at("[w]\nobject.a = a.obj\npose.a = 0 0 0 1 0 0\n", 3, "seven numbers");
    expect_error_at("[w]\nobject.a = a.obj\npose.a = 0 0 0 1 0 0 0 5\n", 3, "seven numbers");
    expect_error_at("[w]\nobject.a = a.obj\npose.a = 0 nan 0 1 0 0 0\n", 3, "not finite");
    expect_error_at("[w]\nobject.a/b = a.obj\n", 2, "invalid object name 'a/b'");
    expect_error_at("[w]\nobject.a =\n", 2, "object.a needs a file path");
    expect_error_at("[w]\nmesh = m.obj\nobject.a = a.obj\n", 1, "has objects and mesh");
    expect_error_at("[w]\nobject.a = a.obj\ntranslate = 1 2 3\n", 1, "has objects and mesh");
    char text[8192] = "[w]\n";
    for (int i = 0; i < SCENE_MAX_OBJECTS; i++)
        snprintf(text + strlen(text), sizeof text - strlen(text), "object.o%d = a.obj\n", i);
    loaded l = load_text(text);
    assert_int_equal(l.status, 0);
    assert_int_equal(l.sc.worlds[0].object_count, SCENE_MAX_OBJECTS);
    assert_int_equal(l.sc.worlds[0].mesh_count, 1);
    scene_free(&l.sc);
    strcat(text, "object.extra = a.obj\n");
    expect_error_at(text, SCENE_MAX_OBJECTS + 2, "more than 64 objects in world 'w'");
}

/* solid = yes|no for a section, solid.NAME for one object, which overrides it. */
static void test_solid_keys(void **state)
{
    (void)state;
    loaded l;
    const world_spec *w = load_one_world(&l, "[cell]\nmesh = box.obj\nsolid = yes\n");
    assert_int_equal(w->solid, 1);
    scene_free(&l.sc);
    w = load_one_world(&l, "[cell]\nmesh = box.obj\n");
    assert_int_equal(w->solid, 0);
    scene_free(&l.sc);
    w = load_one_world(&l, "[cell]\n"
                           "solid = yes\n"
                           "object.crate = crate.obj\n"
                           "solid.tray = no\n"
                           "object.tray = tray.obj\n"
                           "object.bin = crate.obj\n"
                           "solid.bin = yes\n");
    assert_int_equal(w->solid, 1);
    assert_int_equal(w->object_count, 3); /* bin, crate, tray */
    assert_string_equal(w->objects[0].name, "bin");
    assert_int_equal(w->objects[0].solid, 1);
    assert_string_equal(w->objects[1].name, "crate");
    assert_int_equal(w->objects[1].solid, -1); /* the section's */
    assert_string_equal(w->objects[2].name, "tray");
    assert_int_equal(w->objects[2].solid, 0);
    /* A change of solidity is a different world (a reload rebuilds it). */
    world_spec flipped = *w;
    flipped.objects[2].solid = 1;
    assert_false(world_spec_equal(w, &flipped));
    flipped = *w;
    flipped.solid = 0;
    assert_false(world_spec_equal(w, &flipped));
    assert_true(world_spec_equal(w, w));
    scene_free(&l.sc);

    expect_error_at("[w]\nmesh = a.obj\nsolid = true\n", 3, "solid must be yes or no, not 'true'");
    expect_error_at("[w]\nmesh = a.obj\nsolid = yes\nsolid = no\n", 4, "solid given twice");
    expect_error_at("[w]\nobject.a = a.obj\nsolid.a = 1\n", 3, "solid.a must be yes or no, not '1'");
    expect_error_at("[w]\nobject.a = a.obj\nsolid.a = yes\nsolid.a = no\n", 4, "solid of object 'a' given twice");
    expect_error_at("[w]\nobject.a = a.obj\nsolid.b = yes\n", 1, "solid.b names no object (no object.b line)");
    expect_error_at("[w]\nmesh = m.obj\nsolid.b = yes\n", 1, "solid.b names no object");
    expect_error_at("[w]\nobject.a = a.obj\nsolid.a/b = yes\n", 3, "invalid object name 'a/b'");
}

static void test_more_than_max_worlds(void **state)
{
    (void)state;
    size_t cap = (TRIOCT_MAX_WORLDS + 2) * 32;
    char *text = calloc(1, cap);
    assert_non_null(text);
    for (int i = 0; i < TRIOCT_MAX_WORLDS; i++)
        snprintf(text + strlen(text), cap - strlen(text), "[w%d]\nmesh = a.obj\n", i);
    loaded l = load_text(text);
    assert_int_equal(l.status, 0);
    assert_int_equal(l.sc.world_count, TRIOCT_MAX_WORLDS);
    assert_string_equal(l.sc.worlds[TRIOCT_MAX_WORLDS - 1].name, "w63");
    assert_non_null(scene_find(&l.sc, "w40"));
    scene_free(&l.sc);
    strcat(text, "[w64]\nmesh = a.obj\n");
    expect_error_at(text, 2 * TRIOCT_MAX_WORLDS + 1, "more than 64 worlds");
    free(text);
}

static void test_missing_scene_file(void **state)
{
    (void)state;
    scene sc;
    char err[256];
    assert_int_equal(scene_load("/tmp/trioct_no_such_dir/none.ini", &sc, err, sizeof err), -1);
    assert_string_equal(err, "/tmp/trioct_no_such_dir/none.ini: cannot open: No such file or directory");
    assert_int_equal(sc.world_count, 0);
    assert_int_equal(scene_load("/tmp", &sc, err, sizeof err), -1);
    assert_string_equal(err, "/tmp: cannot read: Is a directory");
    assert_int_equal(scene_load("", &sc, err, sizeof err), -1);
    assert_string_equal(err, "no scene file given");
}

/* ---------- words ---------- */

static void test_distance_effect_in_a_section_and_by_default(void **state)
{
    (void)state;
    loaded l = load_text("[near]\nmesh = a.obj\neffects = distance\n[both]\nmesh = a.obj\neffects = rays, distance\n"
                         "[plain]\nmesh = a.obj\n");
    if (l.status != 0)
        fail_msg("%s", l.err);
    assert_int_equal(l.sc.world_count, 3);
    assert_int_equal(l.sc.worlds[0].effects, EFFECT_DISTANCE);
    assert_int_equal(l.sc.worlds[1].effects, EFFECT_RAYS | EFFECT_DISTANCE);
    /* A section that names no effects serves them all, distance among them. */
    assert_true(l.sc.worlds[2].effects & EFFECT_DISTANCE);
    assert_int_equal(l.sc.worlds[2].effects, EFFECT_ALL);
    scene_free(&l.sc);
    expect_error_at("[w]\nmesh = a.obj\neffects = distances\n", 3, "effects: unknown effect 'distances'");
}

static void test_effects_and_accuracy_words(void **state)
{
    (void)state;
    unsigned e = 0;
    char err[128], buf[32];
    assert_int_equal(effects_parse("rays", &e, err, sizeof err), 0);
    assert_int_equal(e, EFFECT_RAYS);
    assert_int_equal(effects_parse(" meshes,triangles ", &e, err, sizeof err), 0);
    assert_int_equal(e, EFFECT_TRIANGLES | EFFECT_MESHES);
    assert_int_equal(effects_parse("rays rays", &e, err, sizeof err), 0);
    assert_int_equal(e, EFFECT_RAYS);
    e = 99;
    assert_int_equal(effects_parse("rays ray", &e, err, sizeof err), -1);
    assert_string_equal(err, "unknown effect 'ray' (rays, triangles, meshes or distance)");
    assert_int_equal(e, 99);
    assert_int_equal(effects_parse("", &e, err, sizeof err), -1);
    assert_string_equal(err, "no effect given (any of rays, triangles, meshes, distance)");
    assert_int_equal(effects_parse("distance", &e, err, sizeof err), 0);
    assert_int_equal(e, EFFECT_DISTANCE);
    assert_int_equal(EFFECT_DISTANCE, 8); /* world_info_t.EFFECT_DISTANCE on the wire */
    assert_int_equal(effects_parse("rays,distance", &e, err, sizeof err), 0);
    assert_int_equal(e, EFFECT_RAYS | EFFECT_DISTANCE);

    /* All effects, the default, take in distance: the longest text fits 32 bytes. */
    assert_string_equal(effects_text(EFFECT_ALL, buf, sizeof buf), "rays triangles meshes distance");
    assert_string_equal(effects_text(EFFECT_MESHES | EFFECT_DISTANCE, buf, sizeof buf), "meshes distance");
    assert_string_equal(effects_text(EFFECT_RAYS | EFFECT_MESHES, buf, sizeof buf), "rays meshes");
    assert_string_equal(effects_text(EFFECT_TRIANGLES, buf, sizeof buf), "triangles");
    assert_string_equal(effects_text(0, buf, sizeof buf), "none");
    for (unsigned mask = 1; mask <= EFFECT_ALL; mask++) {
        assert_int_equal(effects_parse(effects_text(mask, buf, sizeof buf), &e, err, sizeof err), 0);
        assert_int_equal(e, mask);
    }

    accuracy_mode m = ACCURACY_FAST;
    assert_int_equal(accuracy_parse("exact", &m), 0);
    assert_int_equal(m, ACCURACY_EXACT);
    assert_int_equal(accuracy_parse("seed", &m), 0);
    assert_int_equal(m, ACCURACY_SEED);
    assert_int_equal(accuracy_parse("fast", &m), 0);
    assert_int_equal(m, ACCURACY_FAST);
    assert_int_equal(accuracy_parse("fastest", &m), -1);
    assert_int_equal(accuracy_parse("", &m), -1);
    assert_int_equal(m, ACCURACY_FAST);
}

/* ---------- world_spec_equal ---------- */

static void test_world_spec_equal(void **state)
{
    (void)state;
    loaded l = load_text(good_scene);
    assert_int_equal(l.status, 0);
    const world_spec base = l.sc.worlds[0];
    scene_free(&l.sc);

    world_spec b = base;
    assert_true(world_spec_equal(&base, &b));
    snprintf(b.source, sizeof b.source, "elsewhere.ini [warehouse]");
    assert_true(world_spec_equal(&base, &b));
    /* -0 and +0 translate alike. */
    world_spec zero_a = base, zero_b = base;
    zero_a.transform.t.y = 0.0;
    zero_b.transform.t.y = -0.0;
    assert_true(world_spec_equal(&zero_a, &zero_b));

    /* Each field on its own makes a different world. */
    world_spec *changed = malloc(14 * sizeof *changed);
    assert_non_null(changed);
    for (int i = 0; i < 14; i++)
        changed[i] = base;
    snprintf(changed[0].name, sizeof changed[0].name, "other");
    snprintf(changed[1].meshes[1], sizeof changed[1].meshes[1], "sub/floor2.stl");
    snprintf(changed[2].meshes[0], sizeof changed[2].meshes[0], "sub/floor.stl"); /* order */
    snprintf(changed[2].meshes[1], sizeof changed[2].meshes[1], "shelves.obj");
    changed[3].mesh_count = 1;
    snprintf(changed[4].shapes[1].path, sizeof changed[4].shapes[1].path, "tools/box2.obj");
    snprintf(changed[5].shapes[0].name, sizeof changed[5].shapes[0].name, "hand");
    changed[6].shape_count = 1;
    changed[7].transform.scale = 0.25;
    changed[8].transform.r[1] = 1.0;
    changed[9].transform.t.z = 3.5;
    changed[10].def.resolution = 0.0;
    changed[11].def.max_depth = 11;
    changed[12].def.mode = ACCURACY_EXACT;
    changed[13].effects = EFFECT_ALL;
    for (int i = 0; i < 14; i++)
        if (world_spec_equal(&base, &changed[i]) || world_spec_equal(&changed[i], &base))
            fail_msg("change %d went unnoticed", i);
    free(changed);
    world_spec eps = base;
    eps.def.seed_epsilon = 2e-7;
    assert_false(world_spec_equal(&base, &eps));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_objects_and_poses),
        cmocka_unit_test(test_object_errors),
        cmocka_unit_test(test_solid_keys),
        cmocka_unit_test(test_good_scene_every_key),
        cmocka_unit_test(test_scene_without_daemon_section_and_with_bom_and_crlf),
        cmocka_unit_test(test_rotations_at_quarter_turns_are_exact),
        cmocka_unit_test(test_rotation_order_is_x_then_y_then_z_about_fixed_axes),
        cmocka_unit_test(test_rotation_at_other_angles_is_orthonormal),
        cmocka_unit_test(test_identity_flag),
        cmocka_unit_test(test_up_axis),
        cmocka_unit_test(test_unknown_key_and_syntax_errors),
        cmocka_unit_test(test_bad_numbers),
        cmocka_unit_test(test_bad_resolution_depth_accuracy_effects),
        cmocka_unit_test(test_too_many_meshes_and_shapes),
        cmocka_unit_test(test_bad_names),
        cmocka_unit_test(test_duplicate_sections_and_worlds_without_mesh),
        cmocka_unit_test(test_more_than_max_worlds),
        cmocka_unit_test(test_missing_scene_file),
        cmocka_unit_test(test_effects_and_accuracy_words),
        cmocka_unit_test(test_distance_effect_in_a_section_and_by_default),
        cmocka_unit_test(test_world_spec_equal),
    };
    return cmocka_run_group_tests_name("scene", tests, NULL, NULL);
}
