/* trioctd's options: every command-line option (long and short) and every [daemon] key
 * parsed to exact values, the defaults, the command line winning over the scene key by
 * key, a reload recomputing what the command line did not set, and every error with its
 * exact wording. The udpm:// URLs here are only parsed as text: no LCM instance is made,
 * so nothing needs the private network namespace (tests/e2e/netns.sh) the bus tests use. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>
#include <uv.h>

#include "service/options.h"

/* ---------- helpers ---------- */

#define ARGC(a) ((int)(sizeof(a) / sizeof((a)[0])) - 1)

/* Parses a NULL-terminated argv literal (copied: getopt_long may permute it). */
static options_action parse(daemon_options *opt, char *err, size_t err_len, const char *const *args)
{
    char *argv[32];
    int argc = 0;
    while (args[argc] != NULL) {
        argv[argc] = (char *)args[argc];
        argc++;
    }
    argv[argc] = NULL;
    options_init(opt);
    return options_parse_args(opt, argc, argv, err, err_len);
}

/* A scene with only a [daemon] section, as scene_load keeps it. */
typedef struct fake_scene {
    scene sc;
    scene_option opts[24];
} fake_scene;

static void fake_init(fake_scene *f, const char *path)
{
    memset(f, 0, sizeof *f);
    snprintf(f->sc.path, sizeof f->sc.path, "%s", path);
    f->sc.daemon_options = f->opts;
}

static void fake_add(fake_scene *f, int line, const char *key, const char *value)
{
    scene_option *o = &f->opts[f->sc.daemon_option_count++];
    snprintf(o->key, sizeof o->key, "%s", key);
    snprintf(o->value, sizeof o->value, "%s", value);
    o->line = line;
}

static int expected_threads(void)
{
    unsigned n = uv_available_parallelism();
    return n > OPTIONS_MAX_THREADS ? OPTIONS_MAX_THREADS : (int)n;
}

/* Command line args, then a scene's options, must fail with exactly want. */
static void expect_cli_error(const char *const *args, const char *want)
{
    daemon_options opt;
    char err[2048];
    assert_int_equal(parse(&opt, err, sizeof err, args), OPTIONS_ERROR);
    assert_string_equal(err, want);
}

/* ---------- defaults and the command line ---------- */

static void test_defaults(void **state)
{
    (void)state;
    daemon_options opt;
    char err[2048];
    const char *args[] = {"trioctd", "--scene", "conf/scenes/demo.ini", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, args), OPTIONS_RUN);
    assert_string_equal(opt.scene_path, "conf/scenes/demo.ini");
    assert_int_equal(opt.from_cli, 0);

    fake_scene f;
    fake_init(&f, "conf/scenes/demo.ini");
    setenv("LCM_DEFAULT_URL", "memq://", 1);
    assert_int_equal(options_apply_scene(&opt, &f.sc, err, sizeof err), 0);
    assert_string_equal(opt.url, "memq://");
    assert_string_equal(opt.publish_url, "memq://");
    assert_string_equal(opt.prefix, "TRIOCT");
    assert_string_equal(opt.name, "trioctd");
    assert_int_equal(opt.threads, expected_threads());
    assert_string_equal(opt.world_dir, "conf/scenes");
    assert_int_equal(opt.queue_depth, 1024);
    assert_int_equal(opt.log_level, LOG_INFO);
    assert_int_equal(opt.status_interval_ms, 1000);
    assert_int_equal(opt.exit_at_eof, 0);
    assert_int_equal(opt.no_inline, 0);

    /* Without LCM_DEFAULT_URL: LCM's own default, spelled out (nothing is opened here). */
    unsetenv("LCM_DEFAULT_URL");
    options_init(&opt);
    assert_int_equal(parse(&opt, err, sizeof err, args), OPTIONS_RUN);
    assert_int_equal(options_apply_scene(&opt, &f.sc, err, sizeof err), 0);
    assert_string_equal(opt.url, "udpm://239.255.76.67:7667?ttl=0");
    assert_string_equal(opt.publish_url, opt.url);

    /* A scene file in the working directory reads its meshes from there; one at the root
     * from the root. */
    const char *bare[] = {"trioctd", "-s", "demo.ini", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, bare), OPTIONS_RUN);
    assert_int_equal(options_apply_scene(&opt, NULL, err, sizeof err), 0);
    assert_string_equal(opt.world_dir, ".");
    const char *root[] = {"trioctd", "-s", "/demo.ini", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, root), OPTIONS_RUN);
    assert_int_equal(options_apply_scene(&opt, NULL, err, sizeof err), 0);
    assert_string_equal(opt.world_dir, "/");
}

static void test_every_long_option(void **state)
{
    (void)state;
    daemon_options opt;
    char err[2048];
    const char *args[] = {"trioctd",
                          "--scene", "/etc/trioct/scene.ini",
                          "--url", "udpm://239.255.76.99:7669?ttl=1",
                          "--publish-url", "file:///tmp/out.log?mode=w",
                          "--prefix", "FLEET_A",
                          "--name", "host7",
                          "--threads", "3",
                          "--world-dir", "meshes",
                          "--queue-depth", "17",
                          "--log-level", "debug",
                          "--status-interval", "250",
                          "--exit-at-eof",
                          "--no-inline",
                          NULL};
    assert_int_equal(parse(&opt, err, sizeof err, args), OPTIONS_RUN);
    assert_int_equal(opt.from_cli, OPT_URL | OPT_PUBLISH_URL | OPT_PREFIX | OPT_NAME | OPT_THREADS |
                                       OPT_WORLD_DIR | OPT_QUEUE_DEPTH | OPT_LOG_LEVEL |
                                       OPT_STATUS_INTERVAL);
    assert_int_equal(options_apply_scene(&opt, NULL, err, sizeof err), 0);
    assert_string_equal(opt.scene_path, "/etc/trioct/scene.ini");
    assert_string_equal(opt.url, "udpm://239.255.76.99:7669?ttl=1");
    assert_string_equal(opt.publish_url, "file:///tmp/out.log?mode=w");
    assert_string_equal(opt.prefix, "FLEET_A");
    assert_string_equal(opt.name, "host7");
    assert_int_equal(opt.threads, 3);
    assert_string_equal(opt.world_dir, "meshes"); /* relative to the working directory */
    assert_int_equal(opt.queue_depth, 17);
    assert_int_equal(opt.log_level, LOG_DEBUG);
    assert_int_equal(opt.status_interval_ms, 250);
    assert_int_equal(opt.exit_at_eof, 1);
    assert_int_equal(opt.no_inline, 1);

    /* --opt=value works as well as --opt value. */
    const char *eq[] = {"trioctd", "--scene=s.ini", "--threads=2", "--log-level=warn", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, eq), OPTIONS_RUN);
    assert_string_equal(opt.scene_path, "s.ini");
    assert_int_equal(opt.threads, 2);
    assert_int_equal(opt.log_level, LOG_WARN);
}

static void test_every_short_option(void **state)
{
    (void)state;
    daemon_options opt;
    char err[2048];
    const char *args[] = {"trioctd", "-s", "a/b.ini", "-u", "memq://", "-p", "P1", "-n", "n_2",
                          "-t", "1024", "-w", "/srv/worlds", "-q", "1000000", "-l", "error", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, args), OPTIONS_RUN);
    assert_int_equal(options_apply_scene(&opt, NULL, err, sizeof err), 0);
    assert_string_equal(opt.scene_path, "a/b.ini");
    assert_string_equal(opt.url, "memq://");
    assert_string_equal(opt.publish_url, "memq://");
    assert_string_equal(opt.prefix, "P1");
    assert_string_equal(opt.name, "n_2");
    assert_int_equal(opt.threads, 1024);
    assert_string_equal(opt.world_dir, "/srv/worlds");
    assert_int_equal(opt.queue_depth, 1000000);
    assert_int_equal(opt.log_level, LOG_ERROR);
    assert_int_equal(opt.status_interval_ms, 1000);

    /* Glued short values. */
    const char *glued[] = {"trioctd", "-sx.ini", "-t4", "-lwarn", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, glued), OPTIONS_RUN);
    assert_string_equal(opt.scene_path, "x.ini");
    assert_int_equal(opt.threads, 4);
    assert_int_equal(opt.log_level, LOG_WARN);
}

static void test_help_and_version(void **state)
{
    (void)state;
    daemon_options opt;
    char err[2048];
    const char *help[] = {"trioctd", "--help", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, help), OPTIONS_HELP);
    const char *h[] = {"trioctd", "-h", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, h), OPTIONS_HELP);
    const char *version[] = {"trioctd", "--version", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, version), OPTIONS_VERSION);
    const char *v[] = {"trioctd", "-V", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, v), OPTIONS_VERSION);
    /* Neither needs a scene; an error before them still wins, being read first. */
    const char *bad_first[] = {"trioctd", "--threads", "0", "--help", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, bad_first), OPTIONS_ERROR);

    /* The usage text names every option. */
    char *text = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&text, &len);
    assert_non_null(f);
    options_usage(f, "trioctd");
    fclose(f);
    const char *names[] = {"--scene", "--url", "--publish-url", "--prefix", "--name", "--threads",
                           "--world-dir", "--queue-depth", "--log-level", "--status-interval",
                           "--exit-at-eof", "--ordered", "--no-inline", "--help", "--version"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        assert_non_null(strstr(text, names[i]));
    free(text);
}

static void test_command_line_errors(void **state)
{
    (void)state;
    expect_cli_error((const char *[]){"trioctd", NULL}, "missing --scene FILE");
    expect_cli_error((const char *[]){"trioctd", "--threads", "2", NULL}, "missing --scene FILE");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "--bogus", NULL},
                     "unknown option '--bogus'");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "--bogus=1", NULL},
                     "unknown option '--bogus=1'");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "-z", NULL}, "unknown option '-z'");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "--threads", NULL},
                     "option '--threads' needs a value");
    expect_cli_error((const char *[]){"trioctd", "-s", NULL}, "option '-s' needs a value");
    expect_cli_error((const char *[]){"trioctd", "--scene", "", NULL},
                     "--scene: '' is not a usable path");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "extra", NULL},
                     "unexpected argument 'extra' (options only; the scene is --scene FILE)");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "--exit-at-eof=1", NULL},
                     "option '--exit-at-eof' takes no value");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "--help=yes", NULL},
                     "option '--help' takes no value");

    /* Values: integers are whole decimal numbers in range, nothing else. */
    const char *bad_threads[] = {"0", "1025", "-1", "x", "", "3x", " 3", "+3", "99999999999999999999"};
    for (size_t i = 0; i < sizeof bad_threads / sizeof bad_threads[0]; i++) {
        char want[128];
        snprintf(want, sizeof want, "--threads: '%s' is not an integer in 1..1024", bad_threads[i]);
        expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "--threads", bad_threads[i], NULL},
                         want);
    }
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "-q", "0", NULL},
                     "--queue-depth: '0' is not an integer in 1..1000000");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "-q", "1000001", NULL},
                     "--queue-depth: '1000001' is not an integer in 1..1000000");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "--status-interval", "9", NULL},
                     "--status-interval: '9' is not a number of milliseconds in 10..86400000");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "--status-interval", "86400001", NULL},
                     "--status-interval: '86400001' is not a number of milliseconds in 10..86400000");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "-l", "verbose", NULL},
                     "--log-level: 'verbose' is not a log level: error, warn, info or debug");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "-l", "INFO", NULL},
                     "--log-level: 'INFO' is not a log level: error, warn, info or debug");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "-p", "A-B", NULL},
                     "--prefix: 'A-B' is not a channel prefix: 1..16 characters of [A-Za-z0-9_]");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "-p", "ABCDEFGHIJKLMNOPQ", NULL},
                     "--prefix: 'ABCDEFGHIJKLMNOPQ' is not a channel prefix: 1..16 characters of "
                     "[A-Za-z0-9_]");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "-p", "", NULL},
                     "--prefix: '' is not a channel prefix: 1..16 characters of [A-Za-z0-9_]");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "-n", "a.b", NULL},
                     "--name: 'a.b' is not a daemon name: 1..32 characters of [A-Za-z0-9_]");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "-n", "abcdefghijklmnopqrstuvwxyz0123456", NULL},
                     "--name: 'abcdefghijklmnopqrstuvwxyz0123456' is not a daemon name: 1..32 "
                     "characters of [A-Za-z0-9_]");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "-u", "localhost:7667", NULL},
                     "--url: 'localhost:7667' is not an LCM URL (provider://address?options)");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "-u", "", NULL},
                     "--url: an LCM URL is needed, e.g. udpm://239.255.76.67:7667?ttl=0");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "--publish-url", "out.log", NULL},
                     "--publish-url: 'out.log' is not an LCM URL (provider://address?options)");
    expect_cli_error((const char *[]){"trioctd", "-s", "x.ini", "-w", "", NULL},
                     "--world-dir: a directory is needed");

    /* Longest accepted names pass. */
    daemon_options opt;
    char err[2048];
    const char *longest[] = {"trioctd", "-s", "x.ini", "-p", "ABCDEFGHIJKLMNOP", "-n",
                             "abcdefghijklmnopqrstuvwxyz012345", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, longest), OPTIONS_RUN);
    assert_string_equal(opt.prefix, "ABCDEFGHIJKLMNOP");
    assert_string_equal(opt.name, "abcdefghijklmnopqrstuvwxyz012345");
}

/* ---------- the [daemon] section ---------- */

static void test_scene_values(void **state)
{
    (void)state;
    daemon_options opt;
    char err[2048];
    const char *args[] = {"trioctd", "--scene", "/srv/trioct/scene.ini", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, args), OPTIONS_RUN);
    fake_scene f;
    fake_init(&f, "/srv/trioct/scene.ini");
    fake_add(&f, 2, "url", "memq://");
    fake_add(&f, 3, "publish_url", "file:///var/log/trioct.log?mode=w");
    fake_add(&f, 4, "prefix", "LAB");
    fake_add(&f, 5, "name", "bench_1");
    fake_add(&f, 6, "threads", "6");
    fake_add(&f, 7, "world_dir", "worlds");
    fake_add(&f, 8, "queue_depth", "64");
    fake_add(&f, 9, "log_level", "warn");
    fake_add(&f, 10, "status_interval", "100");
    assert_int_equal(options_apply_scene(&opt, &f.sc, err, sizeof err), 0);
    assert_string_equal(opt.url, "memq://");
    assert_string_equal(opt.publish_url, "file:///var/log/trioct.log?mode=w");
    assert_string_equal(opt.prefix, "LAB");
    assert_string_equal(opt.name, "bench_1");
    assert_int_equal(opt.threads, 6);
    assert_string_equal(opt.world_dir, "/srv/trioct/worlds"); /* relative to the scene */
    assert_int_equal(opt.queue_depth, 64);
    assert_int_equal(opt.log_level, LOG_WARN);
    assert_int_equal(opt.status_interval_ms, 100);

    /* An absolute world_dir stays as written; a relative one under a relative scene path
     * joins the two. */
    fake_init(&f, "/srv/trioct/scene.ini");
    fake_add(&f, 2, "world_dir", "/data/meshes");
    assert_int_equal(options_apply_scene(&opt, &f.sc, err, sizeof err), 0);
    assert_string_equal(opt.world_dir, "/data/meshes");
    const char *rel[] = {"trioctd", "--scene", "conf/s.ini", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, rel), OPTIONS_RUN);
    fake_init(&f, "conf/s.ini");
    fake_add(&f, 2, "world_dir", "../meshes");
    assert_int_equal(options_apply_scene(&opt, &f.sc, err, sizeof err), 0);
    assert_string_equal(opt.world_dir, "conf/../meshes");
}

/* mesh_root repeats: each line adds a root, relative ones under the scene's directory; on
 * the command line --mesh-root repeats too, and replaces the scene's roots wholesale. */
static void test_mesh_roots(void **state)
{
    (void)state;
    daemon_options opt;
    char err[2048];
    const char *args[] = {"trioctd", "--scene", "/srv/trioct/scene.ini", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, args), OPTIONS_RUN);
    fake_scene f;
    fake_init(&f, "/srv/trioct/scene.ini");
    fake_add(&f, 2, "mesh_root", "/opt/ros/humble/share");
    fake_add(&f, 3, "mesh_root", "robot_meshes");
    assert_int_equal(options_apply_scene(&opt, &f.sc, err, sizeof err), 0);
    assert_int_equal(opt.mesh_roots.count, 2);
    assert_string_equal(opt.mesh_roots.paths[0], "/opt/ros/humble/share");
    assert_string_equal(opt.mesh_roots.paths[1], "/srv/trioct/robot_meshes");
    /* Applying the scene again (a reload) starts the list afresh, not on top. */
    assert_int_equal(options_apply_scene(&opt, &f.sc, err, sizeof err), 0);
    assert_int_equal(opt.mesh_roots.count, 2);

    const char *cli[] = {"trioctd", "--scene", "/srv/trioct/scene.ini", "--mesh-root", "/usr/share/a",
                         "--mesh-root", "/usr/share/b", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, cli), OPTIONS_RUN);
    assert_int_equal(options_apply_scene(&opt, &f.sc, err, sizeof err), 0);
    assert_int_equal(opt.mesh_roots.count, 2);
    assert_string_equal(opt.mesh_roots.paths[0], "/usr/share/a");
    assert_string_equal(opt.mesh_roots.paths[1], "/usr/share/b");

    fake_init(&f, "/srv/trioct/scene.ini");
    for (int i = 0; i <= MESH_ROOTS_MAX; i++)
        fake_add(&f, 2 + i, "mesh_root", "/r");
    assert_int_equal(parse(&opt, err, sizeof err, args), OPTIONS_RUN);
    assert_int_equal(options_apply_scene(&opt, &f.sc, err, sizeof err), -1);
    assert_non_null(strstr(err, "more than 16 mesh roots"));
}

static void test_command_line_wins(void **state)
{
    (void)state;
    daemon_options opt;
    char err[2048];
    const char *args[] = {"trioctd", "-s", "/s/scene.ini", "--prefix", "CLI", "--threads", "2",
                          "--world-dir", "cli_worlds", "--log-level", "error", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, args), OPTIONS_RUN);
    fake_scene f;
    fake_init(&f, "/s/scene.ini");
    fake_add(&f, 2, "prefix", "SCENE");
    fake_add(&f, 3, "threads", "8");
    fake_add(&f, 4, "world_dir", "scene_worlds");
    fake_add(&f, 5, "log_level", "debug");
    fake_add(&f, 6, "queue_depth", "5");
    fake_add(&f, 7, "name", "from_scene");
    assert_int_equal(options_apply_scene(&opt, &f.sc, err, sizeof err), 0);
    /* The command line's keys... */
    assert_string_equal(opt.prefix, "CLI");
    assert_int_equal(opt.threads, 2);
    assert_string_equal(opt.world_dir, "cli_worlds");
    assert_int_equal(opt.log_level, LOG_ERROR);
    /* ...and the scene's for the rest. */
    assert_int_equal(opt.queue_depth, 5);
    assert_string_equal(opt.name, "from_scene");
    assert_int_equal(opt.status_interval_ms, 1000);

    /* A reload with a scene that drops its keys: what the scene set returns to the
     * defaults, what the command line set stays. */
    fake_init(&f, "/s/scene.ini");
    fake_add(&f, 2, "status_interval", "20");
    assert_int_equal(options_apply_scene(&opt, &f.sc, err, sizeof err), 0);
    assert_string_equal(opt.prefix, "CLI");
    assert_int_equal(opt.threads, 2);
    assert_string_equal(opt.world_dir, "cli_worlds");
    assert_int_equal(opt.log_level, LOG_ERROR);
    assert_int_equal(opt.queue_depth, 1024);
    assert_string_equal(opt.name, "trioctd");
    assert_int_equal(opt.status_interval_ms, 20);

    /* --url given, --publish-url not: the publish URL follows the command line's url, not
     * the scene's url. */
    const char *url_only[] = {"trioctd", "-s", "s.ini", "--url", "memq://", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, url_only), OPTIONS_RUN);
    fake_init(&f, "s.ini");
    fake_add(&f, 1, "url", "udpm://239.255.1.1:7667?ttl=0");
    assert_int_equal(options_apply_scene(&opt, &f.sc, err, sizeof err), 0);
    assert_string_equal(opt.url, "memq://");
    assert_string_equal(opt.publish_url, "memq://");
}

static void expect_scene_error(const char *key, const char *value, const char *want)
{
    daemon_options opt;
    char err[2048];
    const char *args[] = {"trioctd", "-s", "scene.ini", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, args), OPTIONS_RUN);
    fake_scene f;
    fake_init(&f, "scene.ini");
    /* A good key before the bad one: the error must name the bad one's line. */
    if (strcmp(key, "prefix") != 0)
        fake_add(&f, 3, "prefix", "OK");
    else
        fake_add(&f, 3, "name", "ok");
    /* A prefix given twice: the second at line 12. */
    if (strcmp(value, "TWICE") == 0)
        fake_add(&f, 7, "prefix", "FIRST");
    fake_add(&f, 12, key, value);
    assert_int_equal(options_apply_scene(&opt, &f.sc, err, sizeof err), -1);
    assert_string_equal(err, want);
}

static void test_scene_errors(void **state)
{
    (void)state;
    expect_scene_error("foo", "1", "scene.ini:12: unknown daemon option 'foo'");
    expect_scene_error("scene", "other.ini", "scene.ini:12: unknown daemon option 'scene'");
    expect_scene_error("exit_at_eof", "1", "scene.ini:12: unknown daemon option 'exit_at_eof'");
    expect_scene_error("no_inline", "1", "scene.ini:12: unknown daemon option 'no_inline'");
    expect_scene_error("queue-depth", "5", "scene.ini:12: unknown daemon option 'queue-depth'");
    expect_scene_error("threads", "0", "scene.ini:12: threads: '0' is not an integer in 1..1024");
    expect_scene_error("threads", "two", "scene.ini:12: threads: 'two' is not an integer in 1..1024");
    expect_scene_error("queue_depth", "-4",
                       "scene.ini:12: queue_depth: '-4' is not an integer in 1..1000000");
    expect_scene_error("status_interval", "1s",
                       "scene.ini:12: status_interval: '1s' is not a number of milliseconds in "
                       "10..86400000");
    expect_scene_error("log_level", "loud",
                       "scene.ini:12: log_level: 'loud' is not a log level: error, warn, info or debug");
    expect_scene_error("prefix", "A B",
                       "scene.ini:12: prefix: 'A B' is not a channel prefix: 1..16 characters of "
                       "[A-Za-z0-9_]");
    expect_scene_error("name", "",
                       "scene.ini:12: name: '' is not a daemon name: 1..32 characters of [A-Za-z0-9_]");
    expect_scene_error("url", "nowhere",
                       "scene.ini:12: url: 'nowhere' is not an LCM URL (provider://address?options)");
    expect_scene_error("publish_url", "",
                       "scene.ini:12: publish_url: an LCM URL is needed, e.g. "
                       "udpm://239.255.76.67:7667?ttl=0");
    expect_scene_error("world_dir", "", "scene.ini:12: world_dir: a directory is needed");
    expect_scene_error("prefix", "TWICE", "scene.ini:12: daemon option 'prefix' given twice (first at line 7)");
}

static void test_scene_error_even_under_the_command_line(void **state)
{
    (void)state;
    /* The command line overrides threads, but the scene's bad value is still an error:
     * it would bite the day the flag is dropped. */
    daemon_options opt;
    char err[2048];
    const char *args[] = {"trioctd", "-s", "scene.ini", "--threads", "2", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, args), OPTIONS_RUN);
    fake_scene f;
    fake_init(&f, "scene.ini");
    fake_add(&f, 4, "threads", "lots");
    assert_int_equal(options_apply_scene(&opt, &f.sc, err, sizeof err), -1);
    assert_string_equal(err, "scene.ini:4: threads: 'lots' is not an integer in 1..1024");
}

static void test_failed_apply_changes_nothing(void **state)
{
    (void)state;
    daemon_options opt;
    char err[2048];
    const char *args[] = {"trioctd", "-s", "/s/scene.ini", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, args), OPTIONS_RUN);
    fake_scene f;
    fake_init(&f, "/s/scene.ini");
    fake_add(&f, 2, "url", "memq://");
    fake_add(&f, 3, "queue_depth", "7");
    assert_int_equal(options_apply_scene(&opt, &f.sc, err, sizeof err), 0);
    daemon_options before = opt;

    /* A reload whose scene is wrong in its last key keeps every running value. */
    fake_init(&f, "/s/scene.ini");
    fake_add(&f, 2, "url", "memq://");
    fake_add(&f, 3, "queue_depth", "9");
    fake_add(&f, 4, "name", "other");
    fake_add(&f, 5, "log_level", "chatty");
    assert_int_equal(options_apply_scene(&opt, &f.sc, err, sizeof err), -1);
    assert_string_equal(err, "/s/scene.ini:5: log_level: 'chatty' is not a log level: error, warn, "
                             "info or debug");
    assert_memory_equal(&opt, &before, sizeof opt);
}

static void test_file_input_needs_its_own_output(void **state)
{
    (void)state;
    daemon_options opt;
    char err[2048];
    const char *in_only[] = {"trioctd", "-s", "s.ini", "--url", "file:///tmp/in.log?speed=0", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, in_only), OPTIONS_RUN);
    assert_int_equal(options_apply_scene(&opt, NULL, err, sizeof err), -1);
    assert_string_equal(err, "the input 'file:///tmp/in.log?speed=0' is an LCM log, which cannot "
                             "publish: give --publish-url (e.g. file:///tmp/replies.log?mode=w)");

    const char *both[] = {"trioctd", "-s", "s.ini", "--url", "file:///tmp/in.log?speed=0",
                          "--publish-url", "file:///tmp/out.log?mode=w", "--exit-at-eof", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, both), OPTIONS_RUN);
    assert_int_equal(options_apply_scene(&opt, NULL, err, sizeof err), 0);
    assert_true(options_url_is_file(opt.url));
    assert_string_equal(opt.publish_url, "file:///tmp/out.log?mode=w");
    assert_int_equal(opt.exit_at_eof, 1);

    /* The scene may give both too. */
    const char *plain[] = {"trioctd", "-s", "s.ini", NULL};
    assert_int_equal(parse(&opt, err, sizeof err, plain), OPTIONS_RUN);
    fake_scene f;
    fake_init(&f, "s.ini");
    fake_add(&f, 2, "url", "file:///tmp/in.log");
    fake_add(&f, 3, "publish_url", "memq://");
    assert_int_equal(options_apply_scene(&opt, &f.sc, err, sizeof err), 0);
    assert_string_equal(opt.publish_url, "memq://");
    assert_false(options_url_is_file("udpm://239.255.76.67:7667"));
    assert_false(options_url_is_file("memq://"));
}

/* ---------- options_load over real scene files ---------- */

typedef struct scratch {
    char dir[64];
    char path[128];
} scratch;

static void scratch_write(scratch *s, const char *text)
{
    snprintf(s->dir, sizeof s->dir, "/tmp/trioct_options_XXXXXX");
    assert_non_null(mkdtemp(s->dir));
    snprintf(s->path, sizeof s->path, "%s/scene.ini", s->dir);
    FILE *f = fopen(s->path, "w");
    assert_non_null(f);
    fputs(text, f);
    assert_int_equal(fclose(f), 0);
}

static void scratch_remove(scratch *s)
{
    unlink(s->path);
    rmdir(s->dir);
}

static void test_load_real_scene(void **state)
{
    (void)state;
    scratch s;
    scratch_write(&s, "; a comment\n"
                      "[daemon]\n"
                      "prefix = REAL\n"
                      "queue_depth = 33\n"
                      "world_dir = meshes\n"
                      "\n"
                      "[box]\n"
                      "mesh = box.obj\n");
    daemon_options opt;
    scene sc;
    char err[2048];
    char *argv[] = {"trioctd", "--scene", s.path, "--name", "d9", NULL};
    assert_int_equal(options_load(&opt, ARGC(argv), argv, &sc, err, sizeof err), OPTIONS_RUN);
    assert_string_equal(opt.prefix, "REAL");
    assert_int_equal(opt.queue_depth, 33);
    assert_string_equal(opt.name, "d9");
    char want_dir[256];
    snprintf(want_dir, sizeof want_dir, "%s/meshes", s.dir);
    assert_string_equal(opt.world_dir, want_dir);
    assert_int_equal(sc.world_count, 1);
    assert_string_equal(sc.worlds[0].name, "box");
    scene_free(&sc);
    scratch_remove(&s);

    /* The line numbers are the file's. */
    scratch_write(&s, "[daemon]\n"
                      "prefix = REAL\n"
                      "\n"
                      "foo = 1\n");
    char *argv2[] = {"trioctd", "-s", s.path, NULL};
    assert_int_equal(options_load(&opt, ARGC(argv2), argv2, &sc, err, sizeof err), OPTIONS_ERROR);
    char want[256];
    snprintf(want, sizeof want, "%s:4: unknown daemon option 'foo'", s.path);
    assert_string_equal(err, want);
    assert_int_equal(sc.world_count, 0);
    assert_null(sc.daemon_options);
    scratch_remove(&s);

    /* A scene that does not load is an error with scene_load's words. */
    char *argv3[] = {"trioctd", "-s", "/nonexistent/trioct/scene.ini", NULL};
    assert_int_equal(options_load(&opt, ARGC(argv3), argv3, &sc, err, sizeof err), OPTIONS_ERROR);
    assert_non_null(strstr(err, "/nonexistent/trioct/scene.ini"));
    assert_int_equal(sc.world_count, 0);

    /* --help needs no scene at all. */
    char *argv4[] = {"trioctd", "--help", NULL};
    assert_int_equal(options_load(&opt, ARGC(argv4), argv4, &sc, err, sizeof err), OPTIONS_HELP);
}

/* ---------- log levels ---------- */

static void test_log_levels(void **state)
{
    (void)state;
    log_level l;
    const char *names[] = {"error", "warn", "info", "debug"};
    for (int i = 0; i < 4; i++) {
        assert_int_equal(log_level_parse(names[i], &l), 0);
        assert_int_equal(l, i);
        assert_string_equal(log_level_name(l), names[i]);
    }
    assert_int_equal(log_level_parse("warning", &l), -1);
    assert_int_equal(log_level_parse("", &l), -1);
    assert_int_equal(log_level_parse(NULL, &l), -1);
    log_set_level(LOG_DEBUG);
    assert_int_equal(log_get_level(), LOG_DEBUG);
    log_set_level(LOG_ERROR);
    assert_int_equal(log_get_level(), LOG_ERROR);
    log_set_level(LOG_INFO);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_defaults),
        cmocka_unit_test(test_every_long_option),
        cmocka_unit_test(test_every_short_option),
        cmocka_unit_test(test_help_and_version),
        cmocka_unit_test(test_command_line_errors),
        cmocka_unit_test(test_scene_values),
        cmocka_unit_test(test_mesh_roots),
        cmocka_unit_test(test_command_line_wins),
        cmocka_unit_test(test_scene_errors),
        cmocka_unit_test(test_scene_error_even_under_the_command_line),
        cmocka_unit_test(test_failed_apply_changes_nothing),
        cmocka_unit_test(test_file_input_needs_its_own_output),
        cmocka_unit_test(test_load_real_scene),
        cmocka_unit_test(test_log_levels),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
