/* The pure parts of the trioct command: argument scanning, numbers, CSV ray files, poses,
 * the JSON writer's escaping and numbers, human number formatting, tables and the progress
 * line. Output is captured with open_memstream and compared byte for byte. */
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

#include "cli/cli_args.h"
#include "cli/cli_camera.h"
#include "cli/cli_png.h"
#include "cli/cli_render.h"
#include "cli/cli_csv.h"
#include "cli/cli_distance_args.h"
#include "cli/cli_json.h"
#include "cli/cli_pose.h"
#include "cli/cli_progress.h"
#include "cli/cli_text.h"

/* ---------- capturing a FILE ---------- */

typedef struct capture {
    FILE *f;
    char *text;
    size_t len;
} capture;

static void capture_open(capture *c)
{
    c->text = NULL;
    c->len = 0;
    c->f = open_memstream(&c->text, &c->len);
    assert_non_null(c->f);
}

/* Closes the stream; the text stays in c->text until capture_free. */
static const char *capture_close(capture *c)
{
    assert_int_equal(fclose(c->f), 0);
    c->f = NULL;
    return c->text;
}

static void capture_free(capture *c)
{
    free(c->text);
    c->text = NULL;
}

static FILE *file_of(const char *text)
{
    FILE *f = fmemopen((void *)text, strlen(text), "r");
    assert_non_null(f);
    return f;
}

/* ---------- argument scanning ---------- */

typedef struct seen {
    int flag;
    char value[64];
    int calls;
} seen;

enum { ID_FLAG, ID_VALUE, ID_REFUSE, ID_TRIPLE };

static int record(void *user, int id, const char *value, char *err, size_t err_len)
{
    seen *s = user;
    s->calls++;
    if (id == ID_FLAG)
        s->flag++;
    if (id == ID_VALUE || id == ID_TRIPLE)
        snprintf(s->value, sizeof s->value, "%s", value);
    if (id == ID_REFUSE) {
        snprintf(err, err_len, "refused '%s'", value);
        return -1;
    }
    return 0;
}

static const cli_option test_options[] = {
    {"flag", 'f', 0, ID_FLAG},
    {"value", 0, 1, ID_VALUE},
    {"refuse", 0, 1, ID_REFUSE},
    {"triple", 0, 3, ID_TRIPLE},
    {NULL, 0, 0, 0},
};

static int scan(char **argv, int argc, seen *s, char **pos, int cap, int *npos, char *err)
{
    cli_option_set set = {test_options, record, s};
    memset(s, 0, sizeof *s);
    return cli_scan(argc, argv, &set, 1, 0, pos, cap, npos, NULL, err, 256);
}

static void test_scan_negative_numbers_are_positional(void **state)
{
    (void)state;
    char *argv[] = {"w", "0", "-1", "--flag", "-.5", "-", "-2e3", "--value=a=b"};
    seen s;
    char *pos[8], err[256];
    int n;
    assert_int_equal(scan(argv, 8, &s, pos, 8, &n, err), 0);
    assert_int_equal(n, 6);
    assert_string_equal(pos[0], "w");
    assert_string_equal(pos[1], "0");
    assert_string_equal(pos[2], "-1");
    assert_string_equal(pos[3], "-.5");
    assert_string_equal(pos[4], "-");
    assert_string_equal(pos[5], "-2e3");
    /* --value=a=b keeps everything after the first '='. */
    assert_int_equal(s.flag, 1);
    assert_string_equal(s.value, "a=b");
}

static void test_scan_values_aliases_and_terminator(void **state)
{
    (void)state;
    char *argv[] = {"-f", "--value", "--flag", "x", "--", "--flag", "-f"};
    seen s;
    char *pos[8], err[256];
    int n;
    assert_int_equal(scan(argv, 7, &s, pos, 8, &n, err), 0);
    /* "--value --flag": the next word is the value, whatever it looks like. */
    assert_string_equal(s.value, "--flag");
    assert_int_equal(s.flag, 1);
    assert_int_equal(n, 3);
    assert_string_equal(pos[0], "x");
    assert_string_equal(pos[1], "--flag");
    assert_string_equal(pos[2], "-f");
}

/* Scans argv as `trioct distance` or `clear` would (their options only); 0, or -1 with err. */
static int scan_distance(char **argv, int argc, cli_distance_args *a, char **pos, int *n, char *err, size_t len)
{
    memset(a, 0, sizeof *a);
    cli_option_set set = {cli_distance_options, cli_distance_option, a};
    return cli_scan(argc, argv, &set, 1, 0, pos, 8, n, NULL, err, len);
}

static void test_distance_points_and_within(void **state)
{
    (void)state;
    char *argv[] = {"w", "--point", "3", "-0.5", "-1e-3", "--point=1,2,3", "--within", "2.5"};
    cli_distance_args a;
    char *pos[8], err[256];
    int n;
    assert_int_equal(scan_distance(argv, 8, &a, pos, &n, err, sizeof err), 0);
    assert_int_equal(n, 1);
    assert_string_equal(pos[0], "w");
    assert_int_equal(a.num_points, 2);
    /* Negative numbers after --point are its values, not options. */
    assert_true(a.points[0].x == 3 && a.points[0].y == -0.5 && a.points[0].z == -1e-3);
    assert_true(a.points[1].x == 1 && a.points[1].y == 2 && a.points[1].z == 3);
    assert_int_equal(a.has_within, 1);
    assert_true(a.within == 2.5);
    assert_int_equal(cli_distance_check(&a, 0, err, sizeof err), 0);
    /* clear needs a shape. */
    assert_int_equal(cli_distance_check(&a, 1, err, sizeof err), -1);
    assert_string_equal(err, "clear needs a shape: --shape NAME or --shape-file FILE, at --pose POSE");
    cli_distance_args_free(&a);

    char *no_points[] = {"w"};
    assert_int_equal(scan_distance(no_points, 1, &a, pos, &n, err, sizeof err), 0);
    assert_int_equal(cli_distance_check(&a, 0, err, sizeof err), -1);
    assert_non_null(strstr(err, "nothing to ask: give --point x y z"));
    cli_distance_args_free(&a);

    assert_string_equal(cli_feature_name(TRIOCT_FEATURE_FACE), "face");
    assert_string_equal(cli_feature_name(TRIOCT_FEATURE_EDGE), "edge");
    assert_string_equal(cli_feature_name(TRIOCT_FEATURE_VERTEX), "vertex");
    assert_string_equal(cli_feature_name(7), "unknown");
}

static void test_distance_shapes_and_clear(void **state)
{
    (void)state;
    char *argv[] = {"w", "--shape", "gripper", "--pose", "1 2 0.5 1 0 0 0", "--pose", "0 0 1 0 0 90", "--within", "0.05"};
    cli_distance_args a;
    char *pos[8], err[256];
    int n;
    assert_int_equal(scan_distance(argv, 9, &a, pos, &n, err, sizeof err), 0);
    assert_string_equal(a.shape, "gripper");
    assert_int_equal(a.poses.count, 2);
    /* The seven-number pose: a translation and the identity quaternion. */
    assert_true(a.poses.poses[0].t.x == 1 && a.poses.poses[0].t.y == 2 && a.poses.poses[0].t.z == 0.5);
    assert_true(a.poses.poses[0].r[0] == 1 && a.poses.poses[0].r[4] == 1 && a.poses.poses[0].r[8] == 1);
    /* Degrees about z: a quarter turn, exact. */
    assert_true(a.poses.poses[1].r[0] == 0 && a.poses.poses[1].r[1] == -1 && a.poses.poses[1].r[3] == 1);
    assert_int_equal(cli_distance_check(&a, 0, err, sizeof err), 0);
    assert_int_equal(cli_distance_check(&a, 1, err, sizeof err), 0);
    cli_distance_args_free(&a);

    struct {
        char *argv[6];
        int argc;
        const char *says;
    } bad[] = {
        {{"w", "--point", "1", "2"}, 4, "--point"},
        {{"w", "--point", "1", "2", "x"}, 5, "--point '1 2 x': expected three finite numbers x y z"},
        {{"w", "--point", "1", "2", "nan"}, 5, "expected three finite numbers"},
        {{"w", "--within", "-1"}, 3, "--within '-1': expected a distance >= 0"},
        {{"w", "--within", "1", "--within", "2"}, 5, "--within given twice"},
        {{"w", "--shape", "no-such!"}, 3, "is not a shape name"},
        {{"w", "--pose", "1 2"}, 3, "--pose '1 2'"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        if (scan_distance(bad[i].argv, bad[i].argc, &a, pos, &n, err, sizeof err) != -1 || !strstr(err, bad[i].says))
            fail_msg("case %zu: expected an error saying \"%s\", got \"%s\"", i, bad[i].says, err);
        cli_distance_args_free(&a);
    }

    /* Scanned fine, refused as a whole: the checks name what is missing or mixed up. */
    struct {
        char *argv[6];
        int argc, clear;
        const char *says;
    } mixed[] = {
        {{"w", "--point=1,2,3", "--shape", "s"}, 4, 0, "--point and a shape exclude each other"},
        {{"w", "--shape", "s", "--shape-file", "f.stl"}, 5, 0, "--shape and --shape-file exclude each other"},
        {{"w", "--point=1,2,3", "--pose", "0 0 1"}, 4, 0, "--pose places a shape"},
        {{"w", "--shape", "s"}, 3, 1, "clear needs --within R"},
    };
    for (size_t i = 0; i < sizeof mixed / sizeof mixed[0]; i++) {
        assert_int_equal(scan_distance(mixed[i].argv, mixed[i].argc, &a, pos, &n, err, sizeof err), 0);
        if (cli_distance_check(&a, mixed[i].clear, err, sizeof err) != -1 || !strstr(err, mixed[i].says))
            fail_msg("case %zu: expected \"%s\", got \"%s\"", i, mixed[i].says, err);
        cli_distance_args_free(&a);
    }
}

static void test_scan_errors(void **state)
{
    (void)state;
    seen s;
    char *pos[2], err[256];
    int n;
    char *unknown[] = {"--nope"};
    assert_int_equal(scan(unknown, 1, &s, pos, 2, &n, err), -1);
    assert_string_equal(err, "unknown option '--nope'");
    char *short_unknown[] = {"-x"};
    assert_int_equal(scan(short_unknown, 1, &s, pos, 2, &n, err), -1);
    assert_string_equal(err, "unknown option '-x'");
    char *missing[] = {"a", "--value"};
    assert_int_equal(scan(missing, 2, &s, pos, 2, &n, err), -1);
    assert_string_equal(err, "option --value needs a value");
    char *flag_value[] = {"--flag=1"};
    assert_int_equal(scan(flag_value, 1, &s, pos, 2, &n, err), -1);
    assert_string_equal(err, "option --flag takes no value");
    char *refused[] = {"--refuse", "zz"};
    assert_int_equal(scan(refused, 2, &s, pos, 2, &n, err), -1);
    assert_string_equal(err, "refused 'zz'");
    char *too_many[] = {"a", "b", "c"};
    assert_int_equal(scan(too_many, 3, &s, pos, 2, &n, err), -1);
    assert_string_equal(err, "too many arguments (from 'c' on)");
}

static void test_scan_stops_at_the_command(void **state)
{
    (void)state;
    char *argv[] = {"--flag", "--value", "v", "ray", "--flag"};
    seen s;
    memset(&s, 0, sizeof s);
    cli_option_set set = {test_options, record, &s};
    int consumed = -1;
    char err[256];
    assert_int_equal(cli_scan(5, argv, &set, 1, 1, NULL, 0, NULL, &consumed, err, sizeof err), 0);
    assert_int_equal(consumed, 3);
    assert_int_equal(s.flag, 1);
}

/* ---------- numbers and names ---------- */

static void test_parse_double(void **state)
{
    (void)state;
    double v = 0;
    assert_int_equal(cli_parse_double("1.5", 0, &v), 0);
    assert_true(v == 1.5);
    assert_int_equal(cli_parse_double("-0.25", 0, &v), 0);
    assert_true(v == -0.25);
    assert_int_equal(cli_parse_double("0x1p-3", 0, &v), 0);
    assert_true(v == 0.125);
    assert_int_equal(cli_parse_double("1e3", 0, &v), 0);
    assert_true(v == 1000);
    const char *bad[] = {"", " 1", "1 ", "1x", "abc", "nan", "NaN", "inf", "-inf", "1e999", "--1"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        assert_int_equal(cli_parse_double(bad[i], 0, &v), -1);
    assert_int_equal(cli_parse_double("inf", 1, &v), 0);
    assert_true(isinf(v) && v > 0);
    assert_int_equal(cli_parse_double("Infinity", 1, &v), 0);
    assert_true(isinf(v));
    /* An overflow is no way to say infinity, and NaN never is a number. */
    assert_int_equal(cli_parse_double("1e999", 1, &v), -1);
    assert_int_equal(cli_parse_double("nan", 1, &v), -1);
}

static void test_parse_int(void **state)
{
    (void)state;
    long long v = 0;
    assert_int_equal(cli_parse_int("42", 1, 100, &v), 0);
    assert_int_equal(v, 42);
    assert_int_equal(cli_parse_int("0", 1, 100, &v), -1);
    assert_int_equal(cli_parse_int("101", 1, 100, &v), -1);
    assert_int_equal(cli_parse_int("4.5", 1, 100, &v), -1);
    assert_int_equal(cli_parse_int("99999999999999999999", 1, 100, &v), -1);
    assert_int_equal(cli_parse_int("", 1, 100, &v), -1);
}

static void test_accuracy_effects_names(void **state)
{
    (void)state;
    int a = 99;
    assert_int_equal(cli_parse_accuracy("exact", &a), 0);
    assert_int_equal(a, TRIOCT_ACCURACY_EXACT);
    assert_int_equal(cli_parse_accuracy("seed", &a), 0);
    assert_int_equal(a, TRIOCT_ACCURACY_SEED);
    assert_int_equal(cli_parse_accuracy("fast", &a), 0);
    assert_int_equal(a, TRIOCT_ACCURACY_FAST);
    assert_int_equal(cli_parse_accuracy("world", &a), 0);
    assert_int_equal(a, TRIOCT_ACCURACY_WORLD);
    assert_int_equal(cli_parse_accuracy("Exact", &a), -1);
    assert_string_equal(cli_accuracy_name(TRIOCT_ACCURACY_SEED), "seed");

    int e = 0;
    char err[128];
    assert_int_equal(cli_parse_effects("rays,meshes", &e, err, sizeof err), 0);
    assert_int_equal(e, TRIOCT_EFFECT_RAYS | TRIOCT_EFFECT_MESHES);
    assert_int_equal(cli_parse_effects(" triangles  rays ", &e, err, sizeof err), 0);
    assert_int_equal(e, TRIOCT_EFFECT_RAYS | TRIOCT_EFFECT_TRIANGLES);
    assert_int_equal(cli_parse_effects("all", &e, err, sizeof err), 0);
    assert_int_equal(e, 15); /* rays, triangles, meshes and distance */
    assert_int_equal(cli_parse_effects("distance", &e, err, sizeof err), 0);
    assert_int_equal(e, TRIOCT_EFFECT_DISTANCE);
    assert_int_equal(cli_parse_effects("rays,lasers", &e, err, sizeof err), -1);
    assert_string_equal(err, "unknown effect 'lasers' (rays, triangles, meshes, distance or all)");
    assert_int_equal(cli_parse_effects(" , ", &e, err, sizeof err), -1);

    assert_true(cli_name_valid("yard_2", 32));
    assert_false(cli_name_valid("", 32));
    assert_false(cli_name_valid("a-b", 32));
    assert_false(cli_name_valid("a b", 32));
    assert_true(cli_name_valid("abcd", 4));
    assert_false(cli_name_valid("abcde", 4));
}

/* ---------- CSV ---------- */

static void test_parse_numbers(void **state)
{
    (void)state;
    double v[6];
    char err[160];
    assert_int_equal(cli_parse_numbers("1,2,3", v, 6, err, sizeof err), 3);
    assert_true(v[0] == 1 && v[1] == 2 && v[2] == 3);
    assert_int_equal(cli_parse_numbers("  1 , -2 ,3\t4 5e-1\r", v, 6, err, sizeof err), 5);
    assert_true(v[1] == -2 && v[3] == 4 && v[4] == 0.5);
    assert_int_equal(cli_parse_numbers("   ", v, 6, err, sizeof err), 0);
    assert_int_equal(cli_parse_numbers("1,,2", v, 6, err, sizeof err), -1);
    assert_string_equal(err, "field 2 is empty");
    assert_int_equal(cli_parse_numbers("1,2,", v, 6, err, sizeof err), -1);
    assert_string_equal(err, "field 3 is empty");
    assert_int_equal(cli_parse_numbers(",1", v, 6, err, sizeof err), -1);
    assert_string_equal(err, "field 1 is empty");
    assert_int_equal(cli_parse_numbers("1,2,x3", v, 6, err, sizeof err), -1);
    assert_string_equal(err, "field 3 'x3' is not a finite number");
    assert_int_equal(cli_parse_numbers("1,nan", v, 6, err, sizeof err), -1);
    assert_string_equal(err, "field 2 'nan' is not a finite number");
    assert_int_equal(cli_parse_numbers("1 2 3 4 5 6 7", v, 6, err, sizeof err), -1);
    assert_string_equal(err, "more than 6 fields");
}

static void test_read_rays(void **state)
{
    (void)state;
    FILE *f = file_of("# origin, direction\n"
                      "0,0,10,0,0,-1\n"
                      "\n"
                      "   # indented comment\n"
                      "1.5, 2.5, 3, 0, 1, 0\r\n"
                      "\t\n"
                      "-1 -2 -3 4 5 6");
    cli_ray_list rays;
    char err[256];
    assert_int_equal(cli_read_rays(f, "r.csv", &rays, err, sizeof err), 0);
    fclose(f);
    assert_int_equal(rays.count, 3);
    assert_true(rays.origins[0].z == 10 && rays.directions[0].z == -1);
    assert_true(rays.origins[1].x == 1.5 && rays.origins[1].y == 2.5 && rays.directions[1].y == 1);
    assert_true(rays.origins[2].x == -1 && rays.directions[2].z == 6);
    cli_ray_list_free(&rays);
    assert_null(rays.origins);

    f = file_of("0,0,10,0,0,-1\n# fine\n\n1,2,3,4,5\n");
    assert_int_equal(cli_read_rays(f, "bad.csv", &rays, err, sizeof err), -1);
    fclose(f);
    assert_string_equal(err, "bad.csv:4: expected 6 numbers ox,oy,oz,dx,dy,dz: found 5");
    assert_int_equal(rays.count, 0);

    f = file_of("0,0,10,0,0,-1\nox,oy,oz,dx,dy,dz\n");
    assert_int_equal(cli_read_rays(f, "<stdin>", &rays, err, sizeof err), -1);
    fclose(f);
    assert_string_equal(err, "<stdin>:2: expected 6 numbers ox,oy,oz,dx,dy,dz: "
                             "field 1 'ox' is not a finite number");

    f = file_of("# nothing but comments\n\n");
    assert_int_equal(cli_read_rays(f, "empty.csv", &rays, err, sizeof err), 0);
    fclose(f);
    assert_int_equal(rays.count, 0);
    cli_ray_list_free(&rays);
}

/* Many rays: the arrays grow past their first allocation and keep every value. */
static void test_read_many_rays(void **state)
{
    (void)state;
    capture c;
    capture_open(&c);
    for (int i = 0; i < 5000; i++)
        fprintf(c.f, "%d,0,0,0,0,%d\n", i, -1 - i);
    const char *text = capture_close(&c);
    FILE *f = file_of(text);
    cli_ray_list rays;
    char err[256];
    assert_int_equal(cli_read_rays(f, "many.csv", &rays, err, sizeof err), 0);
    fclose(f);
    assert_int_equal(rays.count, 5000);
    for (int i = 0; i < 5000; i++) {
        assert_true(rays.origins[i].x == i);
        assert_true(rays.directions[i].z == -1 - i);
    }
    cli_ray_list_free(&rays);
    capture_free(&c);
}

/* ---------- poses ---------- */

static void assert_matrix(const double r[9], const double want[9])
{
    /* Exact entries, and no -0 (a printed matrix would show it). */
    for (int i = 0; i < 9; i++)
        if (r[i] != want[i] || (want[i] == 0 && signbit(r[i])))
            fail_msg("entry %d: %.17g, want %.17g", i, r[i], want[i]);
}

static void test_rotation_exact_quarter_turns(void **state)
{
    (void)state;
    double r[9];
    cli_rotation_degrees(0, 0, 0, r);
    assert_matrix(r, (double[9]){1, 0, 0, 0, 1, 0, 0, 0, 1});
    /* About z by 90: x goes to y, exactly (cos 90 in double is not 0; here it must be). */
    cli_rotation_degrees(0, 0, 90, r);
    assert_matrix(r, (double[9]){0, -1, 0, 1, 0, 0, 0, 0, 1});
    cli_rotation_degrees(90, 0, 0, r);
    assert_matrix(r, (double[9]){1, 0, 0, 0, 0, -1, 0, 1, 0});
    cli_rotation_degrees(0, 90, 0, r);
    assert_matrix(r, (double[9]){0, 0, 1, 0, 1, 0, -1, 0, 0});
    cli_rotation_degrees(0, 0, 180, r);
    assert_matrix(r, (double[9]){-1, 0, 0, 0, -1, 0, 0, 0, 1});
    cli_rotation_degrees(0, 0, -90, r);
    assert_matrix(r, (double[9]){0, 1, 0, -1, 0, 0, 0, 0, 1});
    cli_rotation_degrees(0, 0, 450, r); /* 450 = 360 + 90 */
    assert_matrix(r, (double[9]){0, -1, 0, 1, 0, 0, 0, 0, 1});
    /* x first, then z (fixed axes): R = Rz(90) Rx(90). Column j is where axis j goes:
     * x -> y, y -> z, z -> x. */
    cli_rotation_degrees(90, 0, 90, r);
    assert_matrix(r, (double[9]){0, 0, 1, 1, 0, 0, 0, 1, 0});
}

static void test_rotation_general_angle(void **state)
{
    (void)state;
    double r[9];
    cli_rotation_degrees(0, 0, 30, r);
    assert_true(fabs(r[0] - sqrt(3.0) / 2) < 1e-15);
    assert_true(fabs(r[1] + 0.5) < 1e-15);
    assert_true(fabs(r[3] - 0.5) < 1e-15);
    assert_true(r[8] == 1);
    /* 135 = 90 + 45: the rest angle goes through cos and sin, the quarter turn exactly. */
    cli_rotation_degrees(0, 0, 135, r);
    assert_true(fabs(r[0] + sqrt(0.5)) < 1e-15);
    assert_true(fabs(r[3] - sqrt(0.5)) < 1e-15);
    /* Orthonormal rows for an odd rotation. */
    cli_rotation_degrees(17, -33, 251, r);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double dot = r[3 * i] * r[3 * j] + r[3 * i + 1] * r[3 * j + 1] + r[3 * i + 2] * r[3 * j + 2];
            assert_true(fabs(dot - (i == j)) < 1e-14);
        }
}

static void test_parse_pose(void **state)
{
    (void)state;
    trioct_pose p;
    char err[256];
    assert_int_equal(cli_parse_pose("1 2 3", &p, err, sizeof err), 0);
    assert_true(p.t.x == 1 && p.t.y == 2 && p.t.z == 3);
    assert_matrix(p.r, (double[9]){1, 0, 0, 0, 1, 0, 0, 0, 1});
    assert_int_equal(cli_parse_pose("1,2,3,0,0,90", &p, err, sizeof err), 0);
    assert_matrix(p.r, (double[9]){0, -1, 0, 1, 0, 0, 0, 0, 1});
    /* Seven numbers: a position and a quaternion w x y z, normalised. */
    assert_int_equal(cli_parse_pose("1 2 3 0 0 0 1.0005", &p, err, sizeof err), 0);
    assert_true(p.t.x == 1 && p.t.y == 2 && p.t.z == 3);
    assert_matrix(p.r, (double[9]){-1, 0, 0, 0, -1, 0, 0, 0, 1});
    assert_int_equal(cli_parse_pose("1 2 3 4", &p, err, sizeof err), -1);
    assert_string_equal(err, "expected 3, 6 or 7 numbers \"tx ty tz [rx ry rz | qw qx qy qz]\" "
                             "(degrees or a quaternion): found 4");
    assert_int_equal(cli_parse_pose("1 2 3 4 5 6 7 8", &p, err, sizeof err), -1);
    assert_string_equal(err, "expected 3, 6 or 7 numbers \"tx ty tz [rx ry rz | qw qx qy qz]\" "
                             "(degrees or a quaternion): more than 7 fields");
    assert_int_equal(cli_parse_pose("1 2 z", &p, err, sizeof err), -1);
    assert_string_equal(err, "expected 3, 6 or 7 numbers \"tx ty tz [rx ry rz | qw qx qy qz]\" "
                             "(degrees or a quaternion): field 3 'z' is not a finite number");
    /* A zero quaternion is no rotation, nor is one far from unit length. */
    assert_int_equal(cli_parse_pose("1 2 3 0 0 0 0", &p, err, sizeof err), -1);
    assert_string_equal(err, "the quaternion (0 0 0 0) is not of length 1 within 1e-3");
    assert_int_equal(cli_parse_pose("1,2,3,1,0,0,1", &p, err, sizeof err), -1);
    assert_string_equal(err, "the quaternion (1 0 0 1) is not of length 1 within 1e-3");
}

/* The nearest of 0, +-1/2, +-sqrt(1/2), +-1: the components of a turn of a cube, as a
 * person would type them. */
static double cube_component(double v)
{
    static const double exact[] = {0, 0.5, 0.7071067811865476, 1};
    double best = 0;
    for (size_t i = 0; i < sizeof exact / sizeof exact[0]; i++)
        if (fabs(fabs(v) - exact[i]) < fabs(fabs(v) - best))
            best = exact[i];
    return v < 0 ? -best : best;
}

/* (w, x, y, z) of a turn by m quarter turns about one axis (0 x, 1 y, 2 z). */
static void quarter_turns(int axis, int m, double q[4])
{
    static const double half_cos[4] = {1, 0.7071067811865476, 0, -0.7071067811865476};
    static const double half_sin[4] = {0, 0.7071067811865476, 1, 0.7071067811865476};
    q[0] = half_cos[m];
    q[1] = q[2] = q[3] = 0;
    q[1 + axis] = half_sin[m];
}

static void quaternion_product(const double a[4], const double b[4], double out[4])
{
    double r[4] = {
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    };
    memcpy(out, r, sizeof r);
}

/* A pose of seven numbers is the very matrix of the same turn in degrees, for every
 * combination of quarter turns about x, y and z (all the turns of a cube): what rests on
 * a face in degrees rests on it as a quaternion. Also with sqrt(1/2) typed short and with
 * the quaternion negated (the same rotation). */
static void test_quaternion_pose_equals_degrees(void **state)
{
    (void)state;
    char err[256], text[256];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            for (int k = 0; k < 4; k++) {
                trioct_pose euler, quat;
                snprintf(text, sizeof text, "1 2 3 %d %d %d", 90 * i, 90 * j, 90 * k);
                assert_int_equal(cli_parse_pose(text, &euler, err, sizeof err), 0);
                /* R = Rz Ry Rx: the quaternion qz qy qx. */
                double qx[4], qy[4], qz[4], zy[4], q[4];
                quarter_turns(0, i, qx);
                quarter_turns(1, j, qy);
                quarter_turns(2, k, qz);
                quaternion_product(qz, qy, zy);
                quaternion_product(zy, qx, q);
                for (int c = 0; c < 4; c++)
                    q[c] = cube_component(q[c]);
                snprintf(text, sizeof text, "1 2 3 %.17g %.17g %.17g %.17g", q[0], q[1], q[2], q[3]);
                assert_int_equal(cli_parse_pose(text, &quat, err, sizeof err), 0);
                assert_matrix(quat.r, euler.r);
                assert_true(quat.t.x == 1 && quat.t.y == 2 && quat.t.z == 3);
            }
    trioct_pose euler, quat;
    assert_int_equal(cli_parse_pose("0 0 0 0 0 90", &euler, err, sizeof err), 0);
    assert_int_equal(cli_parse_pose("0 0 0 0.70710678 0 0 0.70710678", &quat, err, sizeof err), 0);
    assert_matrix(quat.r, euler.r);
    assert_int_equal(cli_parse_pose("0 0 0 -0.7071 0 0 -0.7071", &quat, err, sizeof err), 0);
    assert_matrix(quat.r, euler.r);
    assert_int_equal(cli_parse_pose("0 0 0 -90 0 0", &euler, err, sizeof err), 0);
    assert_int_equal(cli_parse_pose("0,0,0,0.7071067811865476,-0.7071067811865476,0,0", &quat, err, sizeof err), 0);
    assert_matrix(quat.r, euler.r);
}

/* x y z qw qx qy qz: a quarter turn about z is exact in the rows that do not involve it,
 * a quaternion off unit length by more than 1e-3 is refused, as is a word. */
static void test_parse_quaternion_pose(void **state)
{
    (void)state;
    trioct_pose p;
    double q[4];
    char err[160];
    char *quarter[7] = {"1", "2", "3", "0.7071067811865476", "0", "0", "0.7071067811865476"};
    assert_int_equal(cli_parse_quaternion_pose(quarter, "--pose", &p, q, err, sizeof err), 0);
    assert_true(p.t.x == 1 && p.t.y == 2 && p.t.z == 3);
    assert_true(fabs(p.r[0]) < 1e-15 && fabs(p.r[1] + 1) < 1e-15 && fabs(p.r[3] - 1) < 1e-15);
    assert_true(p.r[8] == 1 && p.r[2] == 0 && p.r[6] == 0);
    assert_true(q[0] == 0.7071067811865476 && q[1] == 0 && q[3] == 0.7071067811865476); /* as typed */
    char *unnormalised[7] = {"0", "0", "0", "1.0005", "0", "0", "0"};
    assert_int_equal(cli_parse_quaternion_pose(unnormalised, "--pose", &p, NULL, err, sizeof err), 0);
    assert_true(p.r[0] == 1 && p.r[4] == 1);
    char *long_one[7] = {"0", "0", "0", "2", "0", "0", "0"};
    assert_int_equal(cli_parse_quaternion_pose(long_one, "--pose", &p, NULL, err, sizeof err), -1);
    assert_non_null(strstr(err, "not of length 1"));
    char *word[7] = {"0", "zero", "0", "1", "0", "0", "0"};
    assert_int_equal(cli_parse_quaternion_pose(word, "--link", &p, NULL, err, sizeof err), -1);
    assert_non_null(strstr(err, "--link: 'zero'"));
}

static void test_read_poses(void **state)
{
    (void)state;
    cli_pose_list list = {0};
    trioct_pose first;
    char err[256];
    assert_int_equal(cli_parse_pose("9 9 9", &first, err, sizeof err), 0);
    assert_int_equal(cli_pose_list_add(&list, &first), 0);
    FILE *f = file_of("# poses\n0,0,1\n\n2,0,0,0,0,90\n");
    assert_int_equal(cli_read_poses(f, "p.csv", &list, err, sizeof err), 0);
    fclose(f);
    assert_int_equal(list.count, 3);
    assert_true(list.poses[0].t.x == 9);
    assert_true(list.poses[1].t.z == 1);
    assert_true(list.poses[2].t.x == 2 && list.poses[2].r[1] == -1);
    /* Lines of 7: a quaternion, here half a turn about z and a quarter turn about x. */
    f = file_of("3 0 0 0 0 0 1\n# x\n4,0,0,0.7071067811865476,0.7071067811865476,0,0\n");
    assert_int_equal(cli_read_poses(f, "p.csv", &list, err, sizeof err), 0);
    fclose(f);
    assert_int_equal(list.count, 5);
    assert_true(list.poses[3].t.x == 3);
    assert_matrix(list.poses[3].r, (double[9]){-1, 0, 0, 0, -1, 0, 0, 0, 1});
    assert_true(list.poses[4].t.x == 4);
    assert_matrix(list.poses[4].r, (double[9]){1, 0, 0, 0, 0, -1, 0, 1, 0});
    f = file_of("0,0,1\n0,0\n");
    assert_int_equal(cli_read_poses(f, "p.csv", &list, err, sizeof err), -1);
    fclose(f);
    assert_string_equal(err, "p.csv:2: expected 3, 6 or 7 numbers \"tx ty tz [rx ry rz | qw qx qy qz]\" "
                             "(degrees or a quaternion): found 2");
    /* A zero quaternion is named by its line. */
    f = file_of("0 0 1 1 0 0 0\n\n# next\n0 0 1 0 0 0 0\n");
    assert_int_equal(cli_read_poses(f, "p.csv", &list, err, sizeof err), -1);
    fclose(f);
    assert_string_equal(err, "p.csv:4: the quaternion (0 0 0 0) is not of length 1 within 1e-3");
    cli_pose_list_free(&list);
}

/* ---------- several values, cameras and pictures (trioct render) ---------- */

static void test_scan_option_with_three_values(void **state)
{
    (void)state;
    seen s;
    char *pos[4], err[256];
    int n;
    /* Negative numbers among the values are values, not options or positionals. */
    char *argv[] = {"w", "--triple", "0", "-40", "12.5", "x"};
    assert_int_equal(scan(argv, 6, &s, pos, 4, &n, err), 0);
    assert_string_equal(s.value, "0 -40 12.5");
    assert_int_equal(n, 2);
    assert_string_equal(pos[1], "x");
    char *inline_form[] = {"--triple=1,2,3"};
    assert_int_equal(scan(inline_form, 1, &s, pos, 4, &n, err), 0);
    assert_string_equal(s.value, "1,2,3");
    char *short_of_values[] = {"--triple", "1", "2"};
    assert_int_equal(scan(short_of_values, 3, &s, pos, 4, &n, err), -1);
    assert_string_equal(err, "option --triple needs 3 values");

    double v[3];
    assert_int_equal(cli_parse_vec3("0 -40 12.5", v), 0);
    assert_true(v[0] == 0.0 && v[1] == -40.0 && v[2] == 12.5);
    assert_int_equal(cli_parse_vec3("1,2,3", v), 0);
    assert_true(v[0] == 1.0 && v[1] == 2.0 && v[2] == 3.0);
    assert_int_equal(cli_parse_vec3("1 2", v), -1);
    assert_int_equal(cli_parse_vec3("1 2 3 4", v), -1);
    assert_int_equal(cli_parse_vec3("1 nan 3", v), -1);
    assert_int_equal(cli_parse_vec3("1 inf 3", v), -1);
    assert_int_equal(cli_parse_vec3("", v), -1);
}

static void test_parse_size_and_shade(void **state)
{
    (void)state;
    int w = 0, h = 0;
    assert_int_equal(cli_parse_size("640x480", &w, &h), 0);
    assert_true(w == 640 && h == 480);
    assert_int_equal(cli_parse_size("1X1", &w, &h), 0);
    assert_true(w == 1 && h == 1);
    const char *bad[] = {"640", "x480", "640x", "0x10", "10x0", "-5x5", "5x-5", "+5x5", "5x5x", "20000x10", "5 x5"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        assert_int_equal(cli_parse_size(bad[i], &w, &h), -1);
    cli_shade shade;
    assert_int_equal(cli_parse_shade("normal", &shade), 0);
    assert_int_equal(shade, CLI_SHADE_NORMAL);
    assert_int_equal(cli_parse_shade("depth", &shade), 0);
    assert_int_equal(shade, CLI_SHADE_DEPTH);
    assert_int_equal(cli_parse_shade("colour", &shade), -1);
}

static double dot3(trioct_vec3 a, trioct_vec3 b)
{
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

static void test_camera_rays(void **state)
{
    (void)state;
    cli_camera cam;
    char err[256];
    /* Looking down -y from (0, 10, 0), z up, 90 degrees high, 3x3 pixels: the centre pixel's
     * ray is the view itself and the top-left corner's leans left (-x... seen from +y looking
     * to -y, right is -x) and up by tan(45) * 2/3 of the half plane. */
    assert_int_equal(cli_camera_init(&cam, (trioct_vec3){0, 10, 0}, (trioct_vec3){0, 0, 0}, (trioct_vec3){0, 0, 1},
                                     90.0, 3, 3, err, sizeof err), 0);
    trioct_vec3 c = cli_camera_ray(&cam, 1, 1);
    assert_true(c.x == 0.0 && c.y == -1.0 && c.z == 0.0);
    trioct_vec3 tl = cli_camera_ray(&cam, 0, 0);
    double s = 2.0 / 3.0, len = sqrt(1.0 + 2.0 * s * s);
    assert_true(fabs(tl.x - (s / len)) <= 1e-15);
    assert_true(fabs(tl.y - (-1.0 / len)) <= 1e-15);
    assert_true(fabs(tl.z - (s / len)) <= 1e-15);
    /* Every ray is a unit vector, so t is the distance from the eye. */
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 3; x++)
            assert_true(fabs(dot3(cli_camera_ray(&cam, x, y), cli_camera_ray(&cam, x, y)) - (1.0)) <= 1e-15);
    /* A wide picture is wider, not taller: 60 degrees high, 200x100. */
    assert_int_equal(cli_camera_init(&cam, (trioct_vec3){0, 0, 5}, (trioct_vec3){0, 0, 0}, (trioct_vec3){0, 1, 0},
                                     60.0, 200, 100, err, sizeof err), 0);
    assert_true(fabs(cam.half_width - (2.0 * tan(3.14159265358979323846 / 6.0))) <= 1e-15);
    /* An up that leans toward the view only says which way is up. */
    cli_camera leaning;
    assert_int_equal(cli_camera_init(&leaning, (trioct_vec3){0, 0, 5}, (trioct_vec3){0, 0, 0},
                                     (trioct_vec3){0, 3, -1}, 60.0, 200, 100, err, sizeof err), 0);
    assert_true(fabs(leaning.up.y - (1.0)) <= 1e-15);
    assert_true(fabs(dot3(leaning.up, leaning.forward) - (0.0)) <= 1e-15);

    assert_int_equal(cli_camera_init(&cam, (trioct_vec3){1, 1, 1}, (trioct_vec3){1, 1, 1}, (trioct_vec3){0, 0, 1},
                                     60.0, 4, 4, err, sizeof err), -1);
    assert_non_null(strstr(err, "must differ"));
    assert_int_equal(cli_camera_init(&cam, (trioct_vec3){0, 0, 9}, (trioct_vec3){0, 0, 0}, (trioct_vec3){0, 0, 1},
                                     60.0, 4, 4, err, sizeof err), -1);
    assert_non_null(strstr(err, "parallel to the view"));
    assert_int_equal(cli_camera_init(&cam, (trioct_vec3){0, 9, 0}, (trioct_vec3){0, 0, 0}, (trioct_vec3){0, 0, 1},
                                     180.0, 4, 4, err, sizeof err), -1);
    assert_int_equal(cli_camera_init(&cam, (trioct_vec3){0, 9, 0}, (trioct_vec3){0, 0, 0}, (trioct_vec3){0, 0, 1},
                                     60.0, 0, 4, err, sizeof err), -1);
}

static void test_depth_encoding(void **state)
{
    (void)state;
    assert_int_equal(cli_depth_sample(10.0, 10.0, 20.0), 65535);
    assert_int_equal(cli_depth_sample(20.0, 10.0, 20.0), 0);
    assert_int_equal(cli_depth_sample(15.0, 10.0, 20.0), 32768); /* 32767.5 rounds up */
    assert_int_equal(cli_depth_sample(7.0, 7.0, 7.0), 65535);      /* one depth only */
    /* One step of grey is (far - near) / 65535 of distance. */
    double step = 10.0 / 65535.0;
    assert_int_equal(cli_depth_sample(10.0 + 100.0 * step, 10.0, 20.0), 65435);
}

static void test_render_image(void **state)
{
    (void)state;
    cli_camera cam;
    char err[256];
    assert_int_equal(cli_camera_init(&cam, (trioct_vec3){0, 0, 10}, (trioct_vec3){0, 0, 0}, (trioct_vec3){0, 1, 0},
                                     60.0, 2, 2, err, sizeof err), 0);
    /* Pixels: a near hit, a miss, a far hit, a middle one; the first normal points away
     * from the camera (a back face), the others toward it. */
    double t[4] = {4.0, NAN, 8.0, 6.0};
    trioct_vec3 n[4] = {{0, 0, -1}, {0, 0, 0}, {0, 0, 1}, {-1, 0, 0}};
    cli_png_image img = {0};
    double near, far;
    assert_int_equal(cli_render_image(&cam, t, n, CLI_SHADE_DEPTH, &img, &near, &far), 0);
    assert_true(near == 4.0 && far == 8.0);
    assert_int_equal(img.channels, 2);
    assert_int_equal(img.bit_depth, 16);
    const uint16_t want_depth[8] = {65535, 65535, 0, 0, 0, 65535, 32768, 65535};
    assert_memory_equal(img.samples, want_depth, sizeof want_depth);
    cli_png_image_free(&img);

    assert_int_equal(cli_render_image(&cam, t, n, CLI_SHADE_NORMAL, &img, &near, &far), 0);
    assert_int_equal(img.channels, 4);
    assert_int_equal(img.bit_depth, 8);
    /* Pixel 0's back face shows as facing the camera (+z): (128, 128, 255). The miss is
     * transparent black. Pixel 3's ray leans to +x (the camera's right), so its -x normal
     * faces the camera and is kept: (0, 128, 128). */
    const uint16_t want_normal[16] = {128, 128, 255, 255, 0, 0, 0, 0, 128, 128, 255, 255, 0, 128, 128, 255};
    assert_memory_equal(img.samples, want_normal, sizeof want_normal);
    cli_png_image_free(&img);

    double none[4] = {NAN, NAN, NAN, NAN};
    assert_int_equal(cli_render_image(&cam, none, n, CLI_SHADE_DEPTH, &img, &near, &far), 0);
    assert_true(isnan(near) && isnan(far));
    for (int i = 0; i < 8; i++)
        assert_int_equal(img.samples[i], 0);
    cli_png_image_free(&img);
}

static void test_png_round_trip(void **state)
{
    (void)state;
    char path[] = "/tmp/trioct-png-XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    close(fd);
    char err[512];
    for (int depth = 8; depth <= 16; depth += 8) {
        cli_png_image img = {.width = 3, .height = 2, .channels = depth == 16 ? 2 : 4, .bit_depth = depth};
        size_t n = (size_t)img.width * (size_t)img.height * (size_t)img.channels;
        img.samples = malloc(n * sizeof *img.samples);
        assert_non_null(img.samples);
        for (size_t i = 0; i < n; i++)
            img.samples[i] = (uint16_t)(depth == 16 ? i * 9973u + 1u : i * 17u) & (depth == 16 ? 0xffff : 0xff);
        img.num_text = 2;
        snprintf(img.text[0].key, sizeof img.text[0].key, "trioct.camera");
        snprintf(img.text[0].value, sizeof img.text[0].value, "%.17g 0 -1e-300", 0.1);
        snprintf(img.text[1].key, sizeof img.text[1].key, "trioct.world");
        snprintf(img.text[1].value, sizeof img.text[1].value, "yard");
        assert_int_equal(cli_png_write(path, &img, err, sizeof err), 0);
        cli_png_image back;
        assert_int_equal(cli_png_read(path, &back, err, sizeof err), 0);
        assert_int_equal(back.width, 3);
        assert_int_equal(back.height, 2);
        assert_int_equal(back.channels, img.channels);
        assert_int_equal(back.bit_depth, depth);
        assert_memory_equal(back.samples, img.samples, n * sizeof *img.samples);
        assert_string_equal(cli_png_text_get(&back, "trioct.camera"), "0.10000000000000001 0 -1e-300");
        assert_string_equal(cli_png_text_get(&back, "trioct.world"), "yard");
        assert_null(cli_png_text_get(&back, "trioct.fov"));
        cli_png_image_free(&back);
        free(img.samples);
    }
    /* Not a PNG: an error naming the file, no crash. */
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("not a picture", f);
    fclose(f);
    cli_png_image back;
    assert_int_equal(cli_png_read(path, &back, err, sizeof err), -1);
    assert_non_null(strstr(err, path));
    unlink(path);
    /* A directory that does not exist: the error says so, and nothing is left behind. */
    cli_png_image img = {.width = 1, .height = 1, .channels = 2, .bit_depth = 16};
    uint16_t px[2] = {1, 2};
    img.samples = px;
    assert_int_equal(cli_png_write("/nonexistent-dir/x.png", &img, err, sizeof err), -1);
    assert_non_null(strstr(err, "/nonexistent-dir/x.png"));
}

/* ---------- JSON ---------- */

static void assert_escaped(const char *in, const char *want)
{
    capture c;
    capture_open(&c);
    cli_json_write_string(c.f, in);
    assert_string_equal(capture_close(&c), want);
    capture_free(&c);
}

static void test_json_escaping(void **state)
{
    (void)state;
    assert_escaped("plain", "\"plain\"");
    assert_escaped("world box has no query shape \"x\"", "\"world box has no query shape \\\"x\\\"\"");
    assert_escaped("a\\b", "\"a\\\\b\"");
    assert_escaped("l1\nl2\r\t\b\f", "\"l1\\nl2\\r\\t\\b\\f\"");
    assert_escaped("\x01\x1f", "\"\\u0001\\u001f\"");
    assert_escaped("/", "\"/\"");
    /* Well-formed UTF-8 passes unchanged: e acute, euro sign, a 4-byte emoji. */
    assert_escaped("caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80",
                   "\"caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80\"");
    /* Not UTF-8: a Latin-1 byte, a stray continuation byte, an overlong '/', a truncated
     * sequence, a surrogate, past U+10FFFF: each bad byte becomes U+FFFD. */
    assert_escaped("caf\xe9", "\"caf\\ufffd\"");
    assert_escaped("\x80x", "\"\\ufffdx\"");
    assert_escaped("\xc0\xaf", "\"\\ufffd\\ufffd\"");
    assert_escaped("\xe2\x82", "\"\\ufffd\\ufffd\"");
    assert_escaped("\xed\xa0\x80", "\"\\ufffd\\ufffd\\ufffd\"");
    assert_escaped("\xf4\x90\x80\x80", "\"\\ufffd\\ufffd\\ufffd\\ufffd\"");
    assert_escaped("\xff", "\"\\ufffd\"");
}

static void test_json_writer(void **state)
{
    (void)state;
    capture c;
    capture_open(&c);
    cli_json j;
    cli_json_init(&j, c.f);
    cli_json_object_begin(&j);
    cli_json_key_string(&j, "s", "x");
    cli_json_key_int(&j, "i", -42);
    cli_json_key_double(&j, "tenth", 0.1);
    cli_json_key_double(&j, "eight", 8.0);
    cli_json_key_double(&j, "negzero", -0.0);
    cli_json_key_double(&j, "big", 1e300);
    cli_json_key_double(&j, "inf", INFINITY);
    cli_json_key_double(&j, "nan", NAN);
    cli_json_key_bool(&j, "yes", 1);
    cli_json_key(&j, "empty");
    cli_json_array_begin(&j);
    cli_json_array_end(&j);
    cli_json_key(&j, "list");
    cli_json_array_begin(&j);
    cli_json_vec3(&j, (trioct_vec3){1, -2.5, 3});
    cli_json_object_begin(&j);
    cli_json_key(&j, "n");
    cli_json_null(&j);
    cli_json_object_end(&j);
    cli_json_int(&j, 7);
    cli_json_array_end(&j);
    cli_json_object_end(&j);
    assert_string_equal(capture_close(&c),
                        "{\"s\":\"x\",\"i\":-42,\"tenth\":0.10000000000000001,\"eight\":8,"
                        "\"negzero\":-0,\"big\":1.0000000000000001e+300,\"inf\":null,\"nan\":null,"
                        "\"yes\":true,\"empty\":[],\"list\":[[1,-2.5,3],{\"n\":null},7]}");
    capture_free(&c);
}

/* %.17g reads back as the same double, for any double. */
static void test_json_doubles_round_trip(void **state)
{
    (void)state;
    double values[] = {1.0 / 3, 2.0 / 3, 1e-300, 4.9406564584124654e-324, 1.7976931348623157e308,
                       0.1 + 0.2, -123456.789, 8.000000000000002};
    for (size_t i = 0; i < sizeof values / sizeof values[0]; i++) {
        capture c;
        capture_open(&c);
        cli_json j;
        cli_json_init(&j, c.f);
        cli_json_double(&j, values[i]);
        const char *text = capture_close(&c);
        assert_true(strtod(text, NULL) == values[i]);
        capture_free(&c);
    }
}

/* ---------- text ---------- */

static void test_format_double(void **state)
{
    (void)state;
    char buf[CLI_NUMBER_LEN];
    assert_string_equal(cli_format_double(0.1, buf), "0.1");
    assert_string_equal(cli_format_double(8, buf), "8");
    assert_string_equal(cli_format_double(-0.25, buf), "-0.25");
    assert_string_equal(cli_format_double(0.1 + 0.2, buf), "0.30000000000000004");
    assert_string_equal(cli_format_double(-0.0, buf), "0"); /* no sign on nothing */
    assert_string_equal(cli_format_double(0.0, buf), "0");
    assert_string_equal(cli_format_double(1.0 / 3, buf), "0.3333333333333333");
    assert_string_equal(cli_format_double(1e21, buf), "1e+21");
    assert_string_equal(cli_format_double(INFINITY, buf), "inf");
    assert_string_equal(cli_format_double(-INFINITY, buf), "-inf");
    assert_string_equal(cli_format_double(NAN, buf), "nan");
    double x = 8.000000000000002;
    assert_true(strtod(cli_format_double(x, buf), NULL) == x);

    assert_string_equal(cli_format_bytes(812, buf), "812 B");
    assert_string_equal(cli_format_bytes(1024, buf), "1.0 KiB");
    assert_string_equal(cli_format_bytes(12595, buf), "12.3 KiB");
    assert_string_equal(cli_format_bytes(4 * 1024 * 1024, buf), "4.0 MiB");
    assert_string_equal(cli_format_bytes(3LL << 40, buf), "3.0 TiB");
}

static void test_table(void **state)
{
    (void)state;
    cli_table t;
    assert_int_equal(cli_table_init(&t, 3, 1u << 1), 0);
    cli_table_cell(&t, "NAME");
    cli_table_cell(&t, "N");
    cli_table_cell(&t, "NOTE");
    cli_table_cell(&t, "a");
    cli_table_cell(&t, "%d", 12345);
    cli_table_cell(&t, "first");
    cli_table_cell(&t, "longer");
    cli_table_cell(&t, "%d", 7);
    cli_table_cell(&t, "x");
    capture c;
    capture_open(&c);
    assert_int_equal(cli_table_print(&t, c.f, "> "), 0);
    assert_string_equal(capture_close(&c), "> NAME        N  NOTE\n"
                                           "> a       12345  first\n"
                                           "> longer      7  x\n");
    capture_free(&c);
    cli_table_free(&t);
}

/* ---------- progress ---------- */

#define MS 1000000LL

static void test_progress_lines(void **state)
{
    (void)state;
    capture c;
    capture_open(&c);
    cli_progress p;
    cli_progress_begin(&p, c.f, CLI_PROGRESS_LINES, "rays", 4000, 0);
    cli_progress_update(&p, 1280, 400 * MS);  /* under a second: nothing */
    cli_progress_update(&p, 2560, 1200 * MS); /* shown */
    cli_progress_update(&p, 3000, 1700 * MS); /* within a second of the last: nothing */
    cli_progress_update(&p, 3840, 2300 * MS); /* shown */
    cli_progress_end(&p, 4000, 2500 * MS);
    assert_string_equal(capture_close(&c), "rays: 2560 of 4000 (64%), 1.2 s\n"
                                           "rays: 3840 of 4000 (96%), 2.3 s\n"
                                           "rays: 4000 of 4000 (100%), 2.5 s\n");
    capture_free(&c);
}

static void test_progress_terminal(void **state)
{
    (void)state;
    capture c;
    capture_open(&c);
    cli_progress p;
    cli_progress_begin(&p, c.f, CLI_PROGRESS_TERMINAL, "poses", 10, 0);
    cli_progress_update(&p, 5, 1000 * MS);
    cli_progress_update(&p, 6, 1050 * MS); /* within a tenth of a second: nothing */
    cli_progress_end(&p, 10, 1300 * MS);
    assert_string_equal(capture_close(&c), "\rposes: 5 of 10 (50%), 1.0 s   "
                                           "\rposes: 10 of 10 (100%), 1.3 s   \n");
    capture_free(&c);
}

static void test_progress_quiet_cases(void **state)
{
    (void)state;
    capture c;
    capture_open(&c);
    cli_progress p;
    /* A batch done within a second shows nothing at all. */
    cli_progress_begin(&p, c.f, CLI_PROGRESS_TERMINAL, "rays", 10, 0);
    cli_progress_update(&p, 5, 500 * MS);
    cli_progress_end(&p, 10, 900 * MS);
    /* Off shows nothing however long it takes. */
    cli_progress_begin(&p, c.f, CLI_PROGRESS_OFF, "rays", 10, 0);
    cli_progress_update(&p, 5, 5000 * MS);
    cli_progress_end(&p, 10, 9000 * MS);
    /* A long batch whose only update came early still ends with its count. */
    cli_progress_begin(&p, c.f, CLI_PROGRESS_LINES, "rays", 2, 0);
    cli_progress_update(&p, 1, 600 * MS);
    cli_progress_end(&p, 2, 1500 * MS);
    assert_string_equal(capture_close(&c), "rays: 2 of 2 (100%), 1.5 s\n");
    capture_free(&c);
    /* A memory stream is no terminal: only --progress turns lines on. */
    capture_open(&c);
    assert_int_equal(cli_progress_mode_for(c.f, 0), CLI_PROGRESS_OFF);
    assert_int_equal(cli_progress_mode_for(c.f, 1), CLI_PROGRESS_LINES);
    capture_close(&c);
    capture_free(&c);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_scan_negative_numbers_are_positional),
        cmocka_unit_test(test_scan_values_aliases_and_terminator),
        cmocka_unit_test(test_scan_errors),
        cmocka_unit_test(test_distance_points_and_within),
        cmocka_unit_test(test_distance_shapes_and_clear),
        cmocka_unit_test(test_scan_option_with_three_values),
        cmocka_unit_test(test_parse_size_and_shade),
        cmocka_unit_test(test_camera_rays),
        cmocka_unit_test(test_depth_encoding),
        cmocka_unit_test(test_render_image),
        cmocka_unit_test(test_png_round_trip),
        cmocka_unit_test(test_parse_quaternion_pose),
        cmocka_unit_test(test_scan_stops_at_the_command),
        cmocka_unit_test(test_parse_double),
        cmocka_unit_test(test_parse_int),
        cmocka_unit_test(test_accuracy_effects_names),
        cmocka_unit_test(test_parse_numbers),
        cmocka_unit_test(test_read_rays),
        cmocka_unit_test(test_read_many_rays),
        cmocka_unit_test(test_rotation_exact_quarter_turns),
        cmocka_unit_test(test_rotation_general_angle),
        cmocka_unit_test(test_parse_pose),
        cmocka_unit_test(test_quaternion_pose_equals_degrees),
        cmocka_unit_test(test_read_poses),
        cmocka_unit_test(test_json_escaping),
        cmocka_unit_test(test_json_writer),
        cmocka_unit_test(test_json_doubles_round_trip),
        cmocka_unit_test(test_format_double),
        cmocka_unit_test(test_table),
        cmocka_unit_test(test_progress_lines),
        cmocka_unit_test(test_progress_terminal),
        cmocka_unit_test(test_progress_quiet_cases),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
