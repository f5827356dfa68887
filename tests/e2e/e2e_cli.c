/* End to end: the trioct command against a real trioctd over udpm, inside the private
 * network and pid namespace that tests/e2e/netns.sh makes.
 *
 *   e2e_cli TRIOCTD_BINARY TRIOCT_BINARY
 *
 * The daemon serves a box whose triangles this file writes one by one, so every answer is
 * known exactly: a ray straight down at (x, y) crosses the top face at t = 8 in triangle 1
 * when y > x (triangle 0 when y < x) with known barycentric weights, and the bottom face at
 * t = 10. Each subcommand runs as a subprocess with --json; its one line of output is parsed
 * by the small JSON reader below (which also rejects anything that is not strict JSON) and
 * checked field by field. Every documented exit code is provoked, 5 with a fake daemon
 * that answers with bytes no reply decoder accepts. */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <poll.h>
#include <pthread.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <cmocka.h>
#include <lcm/lcm.h>

#include "cli/cli_png.h"
#include "support/daemon_proc.h"
#include "trioct.h"
#include "trioct_version.h"

#define BUS_URL "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
#define DAEMON "dE"
#define RUN_LIMIT_MS 30000 /* a trioct run that takes longer than this has hung */

static const char *daemon_bin, *cli_bin;
static char dir[256];
static pid_t daemon_pid = -1;

/* ====================================================================================== */
/* A strict JSON reader, just enough for trioct's output                                    */
/* ====================================================================================== */

typedef enum { J_NULL, J_BOOL, J_NUM, J_STR, J_ARR, J_OBJ } jtype;

typedef struct jv {
    jtype type;
    double num; /* J_NUM; J_BOOL: 0 or 1 */
    char *str;  /* J_STR */
    size_t n;   /* J_ARR, J_OBJ: items */
    struct jv *items;
    char **keys; /* J_OBJ */
} jv;

typedef struct jreader {
    const char *p;
    char err[128];
} jreader;

static int jvalue(jreader *r, jv *out);

static void jfree_value(jv *v)
{
    for (size_t i = 0; i < v->n; i++) {
        jfree_value(&v->items[i]);
        if (v->keys)
            free(v->keys[i]);
    }
    free(v->items);
    free(v->keys);
    free(v->str);
}

static void jfree(jv *v)
{
    if (v) {
        jfree_value(v);
        free(v);
    }
}

static int jfail(jreader *r, const char *what)
{
    if (r->err[0] == '\0')
        snprintf(r->err, sizeof r->err, "%s at '%.20s'", what, r->p);
    return -1;
}

static void skip_ws(jreader *r)
{
    while (*r->p == ' ' || *r->p == '\t' || *r->p == '\n' || *r->p == '\r')
        r->p++;
}

static void put_utf8(char **o, unsigned cp)
{
    if (cp < 0x80) {
        *(*o)++ = (char)cp;
    } else if (cp < 0x800) {
        *(*o)++ = (char)(0xC0 | cp >> 6);
        *(*o)++ = (char)(0x80 | (cp & 0x3F));
    } else if (cp < 0x10000) {
        *(*o)++ = (char)(0xE0 | cp >> 12);
        *(*o)++ = (char)(0x80 | ((cp >> 6) & 0x3F));
        *(*o)++ = (char)(0x80 | (cp & 0x3F));
    } else {
        *(*o)++ = (char)(0xF0 | cp >> 18);
        *(*o)++ = (char)(0x80 | ((cp >> 12) & 0x3F));
        *(*o)++ = (char)(0x80 | ((cp >> 6) & 0x3F));
        *(*o)++ = (char)(0x80 | (cp & 0x3F));
    }
}

static int hex_digit(char c)
{
    if (c >= '0' && c <= '9')
        return c - '0';
    if (c >= 'a' && c <= 'f')
        return c - 'a' + 10;
    if (c >= 'A' && c <= 'F')
        return c - 'A' + 10;
    return -1;
}

static int hex4(const char *p, unsigned *out)
{
    unsigned v = 0;
    for (int i = 0; i < 4; i++) {
        int d = hex_digit(p[i]);
        if (d < 0)
            return -1;
        v = v * 16 + (unsigned)d;
    }
    *out = v;
    return 0;
}

static int jstring(jreader *r, char **out)
{
    if (*r->p != '"')
        return jfail(r, "expected a string");
    r->p++;
    char *buf = malloc(strlen(r->p) * 2 + 8), *o = buf;
    assert_non_null(buf);
    for (;;) {
        unsigned char c = (unsigned char)*r->p;
        if (c == '\0' || c < 0x20) {
            free(buf);
            return jfail(r, "unterminated string or raw control character");
        }
        r->p++;
        if (c == '"')
            break;
        if (c != '\\') {
            *o++ = (char)c;
            continue;
        }
        char e = *r->p++;
        const char *simple = strchr("\"\\/bfnrt", e);
        if (e != '\0' && simple != NULL) {
            *o++ = "\"\\/\b\f\n\r\t"[simple - "\"\\/bfnrt"];
            continue;
        }
        unsigned cp;
        if (e != 'u' || hex4(r->p, &cp) != 0) {
            free(buf);
            return jfail(r, "bad escape");
        }
        r->p += 4;
        if (cp >= 0xD800 && cp <= 0xDBFF) {
            unsigned lo;
            if (r->p[0] != '\\' || r->p[1] != 'u' || hex4(r->p + 2, &lo) != 0 || lo < 0xDC00 || lo > 0xDFFF) {
                free(buf);
                return jfail(r, "lone surrogate");
            }
            r->p += 6;
            cp = 0x10000 + ((cp - 0xD800) << 10) + (lo - 0xDC00);
        }
        put_utf8(&o, cp);
    }
    *o = '\0';
    *out = buf;
    return 0;
}

/* JSON's number grammar, exactly: no "inf", "nan", hex, leading '+' or leading zeros. */
static int jnumber(jreader *r, double *out)
{
    const char *p = r->p;
    if (*p == '-')
        p++;
    if (*p == '0')
        p++;
    else if (*p >= '1' && *p <= '9')
        while (*p >= '0' && *p <= '9')
            p++;
    else
        return jfail(r, "bad number");
    if (*p == '.') {
        p++;
        if (!(*p >= '0' && *p <= '9'))
            return jfail(r, "bad fraction");
        while (*p >= '0' && *p <= '9')
            p++;
    }
    if (*p == 'e' || *p == 'E') {
        p++;
        if (*p == '+' || *p == '-')
            p++;
        if (!(*p >= '0' && *p <= '9'))
            return jfail(r, "bad exponent");
        while (*p >= '0' && *p <= '9')
            p++;
    }
    *out = strtod(r->p, NULL);
    r->p = p;
    return 0;
}

static void jpush(jv *v, size_t *cap)
{
    if (v->n == *cap) {
        *cap = *cap ? *cap * 2 : 8;
        v->items = realloc(v->items, *cap * sizeof *v->items);
        assert_non_null(v->items);
        if (v->type == J_OBJ) {
            v->keys = realloc(v->keys, *cap * sizeof *v->keys);
            assert_non_null(v->keys);
        }
    }
    memset(&v->items[v->n], 0, sizeof v->items[v->n]);
}

static int jcontainer(jreader *r, jv *out, char close)
{
    out->type = close == '}' ? J_OBJ : J_ARR;
    size_t cap = 0;
    r->p++;
    skip_ws(r);
    if (*r->p == close) {
        r->p++;
        return 0;
    }
    for (;;) {
        skip_ws(r);
        jpush(out, &cap);
        if (out->type == J_OBJ) {
            char *key = NULL;
            if (jstring(r, &key) != 0)
                return -1;
            out->keys[out->n] = key;
            skip_ws(r);
            if (*r->p++ != ':') {
                out->n++; /* the key is freed with the object */
                return jfail(r, "expected ':'");
            }
        }
        int rc = jvalue(r, &out->items[out->n]);
        out->n++;
        if (rc != 0)
            return -1;
        skip_ws(r);
        if (*r->p == ',') {
            r->p++;
            continue;
        }
        if (*r->p == close) {
            r->p++;
            return 0;
        }
        return jfail(r, "expected ',' or the container's end");
    }
}

static int jvalue(jreader *r, jv *out)
{
    skip_ws(r);
    memset(out, 0, sizeof *out);
    switch (*r->p) {
    case '{':
        return jcontainer(r, out, '}');
    case '[':
        return jcontainer(r, out, ']');
    case '"':
        out->type = J_STR;
        return jstring(r, &out->str);
    case 't':
    case 'f':
    case 'n': {
        const char *word = *r->p == 't' ? "true" : *r->p == 'f' ? "false" : "null";
        if (strncmp(r->p, word, strlen(word)) != 0)
            return jfail(r, "bad literal");
        r->p += strlen(word);
        out->type = word[0] == 'n' ? J_NULL : J_BOOL;
        out->num = word[0] == 't';
        return 0;
    }
    default:
        out->type = J_NUM;
        return jnumber(r, &out->num);
    }
}

/* Parses exactly one JSON value followed by one newline. */
static jv *jparse_line(const char *text)
{
    jreader r = {.p = text};
    jv *v = calloc(1, sizeof *v);
    assert_non_null(v);
    if (jvalue(&r, v) != 0 || strcmp(r.p, "\n") != 0) {
        fprintf(stderr, "not one line of JSON (%s): %s\n", r.err[0] ? r.err : "trailing text", text);
        jfree(v);
        fail();
    }
    return v;
}

/* Follows a path like "hits.0.normal.2": object keys and array indices. NULL when absent. */
static const jv *jget(const jv *v, const char *path)
{
    char buf[256];
    snprintf(buf, sizeof buf, "%s", path);
    char *save = NULL;
    for (char *part = strtok_r(buf, ".", &save); part && v; part = strtok_r(NULL, ".", &save)) {
        const jv *next = NULL;
        if (v->type == J_OBJ) {
            for (size_t i = 0; i < v->n && !next; i++)
                if (strcmp(v->keys[i], part) == 0)
                    next = &v->items[i];
        } else if (v->type == J_ARR) {
            char *end;
            unsigned long i = strtoul(part, &end, 10);
            if (*end == '\0' && i < v->n)
                next = &v->items[i];
        }
        v = next;
    }
    return v;
}

static const jv *jneed(const jv *root, const char *path, jtype type)
{
    const jv *v = jget(root, path);
    if (v == NULL)
        fail_msg("JSON has no %s", path);
    if (v->type != type)
        fail_msg("JSON %s has type %d, not %d", path, v->type, type);
    return v;
}

static double jnum(const jv *root, const char *path)
{
    return jneed(root, path, J_NUM)->num;
}

static const char *jstr(const jv *root, const char *path)
{
    return jneed(root, path, J_STR)->str;
}

static int jbool(const jv *root, const char *path)
{
    return (int)jneed(root, path, J_BOOL)->num;
}

static size_t jlen(const jv *root, const char *path)
{
    const jv *v = jget(root, path);
    if (v == NULL || (v->type != J_ARR && v->type != J_OBJ))
        fail_msg("JSON %s is no array or object", path);
    return v->n;
}

/* ====================================================================================== */
/* Running trioct                                                                           */
/* ====================================================================================== */

typedef struct cli_run {
    int code;
    char *out, *err;
} cli_run;

static void run_free(cli_run *r)
{
    free(r->out);
    free(r->err);
}

static int64_t now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

typedef struct sink {
    int fd;
    char *buf;
    size_t len, cap;
} sink;

static int sink_read(sink *s)
{
    if (s->len + 4096 + 1 > s->cap) {
        s->cap = (s->cap + 4096) * 2;
        s->buf = realloc(s->buf, s->cap);
        assert_non_null(s->buf);
    }
    ssize_t n = read(s->fd, s->buf + s->len, s->cap - s->len - 1);
    if (n > 0)
        s->len += (size_t)n;
    s->buf[s->len] = '\0';
    return n > 0 || (n < 0 && errno == EINTR);
}

/* Runs trioct --url BUS_URL args... with stdin from stdin_path (or /dev/null). A later
 * --url in args wins. */
static cli_run run_cli(const char *stdin_path, const char *const *args)
{
    const char *argv[64];
    int n = 0;
    argv[n++] = cli_bin;
    argv[n++] = "--url";
    argv[n++] = BUS_URL;
    for (int i = 0; args[i] && n < 63; i++)
        argv[n++] = args[i];
    argv[n] = NULL;

    int out_pipe[2], err_pipe[2];
    assert_int_equal(pipe(out_pipe), 0);
    assert_int_equal(pipe(err_pipe), 0);
    fflush(NULL);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        int in = open(stdin_path ? stdin_path : "/dev/null", O_RDONLY);
        if (in >= 0)
            dup2(in, STDIN_FILENO);
        dup2(out_pipe[1], STDOUT_FILENO);
        dup2(err_pipe[1], STDERR_FILENO);
        close(out_pipe[0]);
        close(err_pipe[0]);
        execv(cli_bin, (char *const *)argv);
        fprintf(stderr, "exec %s: %s\n", cli_bin, strerror(errno));
        _exit(127);
    }
    close(out_pipe[1]);
    close(err_pipe[1]);
    sink out = {.fd = out_pipe[0], .buf = calloc(1, 1), .cap = 1};
    sink err = {.fd = err_pipe[0], .buf = calloc(1, 1), .cap = 1};
    assert_true(out.buf != NULL && err.buf != NULL);
    int64_t deadline = now_ms() + RUN_LIMIT_MS;
    int open_out = 1, open_err = 1;
    while ((open_out || open_err) && now_ms() < deadline) {
        struct pollfd pfd[2] = {{out.fd, open_out ? POLLIN : 0, 0}, {err.fd, open_err ? POLLIN : 0, 0}};
        if (poll(pfd, 2, 200) <= 0)
            continue;
        if (open_out && pfd[0].revents)
            open_out = sink_read(&out);
        if (open_err && pfd[1].revents)
            open_err = sink_read(&err);
    }
    if (open_out || open_err)
        kill(pid, SIGKILL);
    close(out.fd);
    close(err.fd);
    int wstatus = 0;
    waitpid(pid, &wstatus, 0);
    cli_run r = {.out = out.buf, .err = err.buf};
    r.code = WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : 128 + WTERMSIG(wstatus);
    return r;
}

#define CLI(...) run_cli(NULL, (const char *const[]){__VA_ARGS__, NULL})
#define CLI_STDIN(path, ...) run_cli(path, (const char *const[]){__VA_ARGS__, NULL})

/* Runs trioct, expects exit code `code` and one JSON line, returns it parsed. */
static jv *json_run(int code, const char *const *args)
{
    cli_run r = run_cli(NULL, args);
    if (r.code != code) {
        fprintf(stderr, "trioct exited %d, expected %d\nstdout: %s\nstderr: %s\n", r.code, code, r.out,
                r.err);
        run_free(&r);
        fail();
    }
    jv *v = jparse_line(r.out);
    run_free(&r);
    assert_int_equal((int)jnum(v, "exit_code"), code);
    assert_int_equal(jbool(v, "ok"), code == 0);
    return v;
}

#define JSON(code, ...) json_run(code, (const char *const[]){"--json", __VA_ARGS__, NULL})

static void expect_code(const cli_run *r, int code)
{
    if (r->code != code)
        fail_msg("trioct exited %d, expected %d\nstdout: %s\nstderr: %s", r->code, code, r->out, r->err);
}

static void expect_text(const char *text, const char *needle)
{
    if (strstr(text, needle) == NULL)
        fail_msg("expected \"%s\" in:\n%s", needle, text);
}

/* ====================================================================================== */
/* The scene                                                                                */
/* ====================================================================================== */

static char key_file[320]; /* the daemon's admin key; TRIOCT_KEY_FILE names it */
static char pkg_dir[320];  /* the daemon's --mesh-root */

static void path_in_dir(char *out, size_t len, const char *name)
{
    snprintf(out, len, "%s/%s", dir, name);
}

static void write_text(const char *name, const char *text)
{
    char path[320];
    path_in_dir(path, sizeof path, name);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    assert_int_equal(fclose(f), 0);
}

/* The whole of a file in dir (the daemon's log), NUL-terminated; free it. */
static char *read_text(const char *name)
{
    char path[320];
    path_in_dir(path, sizeof path, name);
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    char *text = NULL;
    size_t len = 0;
    FILE *mem = open_memstream(&text, &len);
    assert_non_null(mem);
    char buf[4096];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, f)) > 0)
        fwrite(buf, 1, n, mem);
    fclose(f);
    assert_int_equal(fclose(mem), 0);
    return text;
}

/* The box [0,4] x [0,4] x [0,2], outward normals. Triangle ids: 0, 1 the top (0 where
 * y < x), 2, 3 the bottom (2 where y < x), then the four sides. */
static const char box_obj[] = "v 0 0 0\nv 4 0 0\nv 4 4 0\nv 0 4 0\n"
                              "v 0 0 2\nv 4 0 2\nv 4 4 2\nv 0 4 2\n"
                              "f 5 6 7\nf 5 7 8\n"
                              "f 1 3 2\nf 1 4 3\n"
                              "f 1 2 6\nf 1 6 5\n"
                              "f 2 3 7\nf 2 7 6\n"
                              "f 3 4 8\nf 3 8 7\n"
                              "f 4 1 5\nf 4 5 8\n";

/* The query shape: the cube [-0.5, 0.5]^3. */
static const char cube_obj[] = "v -0.5 -0.5 -0.5\nv 0.5 -0.5 -0.5\nv 0.5 0.5 -0.5\nv -0.5 0.5 -0.5\n"
                               "v -0.5 -0.5 0.5\nv 0.5 -0.5 0.5\nv 0.5 0.5 0.5\nv -0.5 0.5 0.5\n"
                               "f 5 6 7\nf 5 7 8\nf 1 3 2\nf 1 4 3\nf 1 2 6\nf 1 6 5\n"
                               "f 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";

static int group_setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/trioct-e2e-cli-XXXXXX");
    if (mkdtemp(dir) == NULL)
        return -1;
    write_text("box.obj", box_obj);
    write_text("cube.obj", cube_obj);
    /* A read-only mesh directory outside the world directory (mesh_root), as a ROS package
     * would be. */
    snprintf(pkg_dir, sizeof pkg_dir, "%s-pkg", dir);
    if (mkdir(pkg_dir, 0755) != 0)
        return -1;
    char pkg_box[400];
    snprintf(pkg_box, sizeof pkg_box, "%s/box.obj", pkg_dir);
    FILE *pf = fopen(pkg_box, "w");
    if (pf == NULL)
        return -1;
    fputs(box_obj, pf);
    fclose(pf);
    write_text("scene.ini", "[box]\nmesh = box.obj\neffects = rays triangles meshes distance\n"
                            "shape.cube = cube.obj\n\n"
                            "[box_rays]\nmesh = box.obj\neffects = rays\n\n"
                            "[broken]\nmesh = missing.obj\n");
    char scene[320], log[320];
    path_in_dir(scene, sizeof scene, "scene.ini");
    path_in_dir(log, sizeof log, "daemon.log");
    path_in_dir(key_file, sizeof key_file, "admin.key");
    if (daemon_proc_write_key(key_file) != 0)
        return -1;
    const char *extra[] = {"--threads", "2", "--status-interval", "200", "--admin-key-file", key_file,
                           "--mesh-root", pkg_dir, NULL};
    daemon_pid = daemon_proc_start(daemon_bin, scene, BUS_URL, DAEMON, extra, log);
    if (daemon_pid < 0)
        return -1;
    trioct_connect_options opt = {.url = BUS_URL};
    trioct_client *c = trioct_connect(&opt, NULL, NULL, 0);
    if (c == NULL)
        return -1;
    int ready = daemon_proc_wait_ready(c, DAEMON, 20000) == 0;
    trioct_disconnect(c);
    if (!ready)
        fprintf(stderr, "e2e_cli: the daemon did not report READY; see %s\n", log);
    return ready ? 0 : -1;
}

static int group_teardown(void **state)
{
    (void)state;
    if (daemon_pid > 0)
        daemon_proc_stop(daemon_pid, SIGTERM, 5000);
    char cmd[700];
    snprintf(cmd, sizeof cmd, "rm -rf '%s' '%s'", dir, pkg_dir);
    return system(cmd) == 0 ? 0 : -1;
}

/* ====================================================================================== */
/* The tests                                                                                */
/* ====================================================================================== */

static void test_help_and_version(void **state)
{
    (void)state;
    cli_run r = CLI("--help");
    expect_code(&r, 0);
    expect_text(r.out, "Exit codes:");
    expect_text(r.out, "  3  no reply");
    expect_text(r.out, "  4  transport failure");
    run_free(&r);
    const char *commands[] = {"worlds", "info", "load", "unload", "ray", "rays", "tri", "mesh", "status"};
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++) {
        r = CLI(commands[i], "--help");
        expect_code(&r, 0);
        char usage[64];
        snprintf(usage, sizeof usage, "Usage: trioct %s", commands[i]);
        expect_text(r.out, usage);
        expect_text(r.out, "Examples:");
        run_free(&r);
    }
    r = CLI("help", "rays");
    expect_code(&r, 0);
    expect_text(r.out, "Usage: trioct rays");
    run_free(&r);
    r = CLI("--version");
    expect_code(&r, 0);
    assert_string_equal(r.out, "trioct " TRIOCT_VERSION "\n");
    run_free(&r);
}

static int has_world(const jv *v, const char *list, const char *name)
{
    char path[64];
    for (size_t i = 0; i < jlen(v, list); i++) {
        snprintf(path, sizeof path, "%s.%zu.name", list, i);
        if (strcmp(jstr(v, path), name) == 0)
            return (int)i;
    }
    return -1;
}

static void check_box_info(const jv *v, const char *at)
{
    char p[96];
#define AT(field) (snprintf(p, sizeof p, "%s.%s", at, field), p)
    assert_string_equal(jstr(v, AT("daemon")), DAEMON);
    assert_int_equal((int)jnum(v, AT("triangles")), 12);
    assert_int_equal((int)jnum(v, AT("degenerate")), 0);
    assert_true(jnum(v, AT("bbox_min.0")) == 0 && jnum(v, AT("bbox_min.2")) == 0);
    assert_true(jnum(v, AT("bbox_max.0")) == 4 && jnum(v, AT("bbox_max.1")) == 4);
    assert_true(jnum(v, AT("bbox_max.2")) == 2);
    assert_string_equal(jstr(v, AT("accuracy")), "exact");
    assert_true(jnum(v, AT("nodes")) >= 1);
    assert_true(jnum(v, AT("bytes.total")) > 0);
    assert_string_equal(jstr(v, AT("last_error")), "");
#undef AT
}

static void test_worlds(void **state)
{
    (void)state;
    jv *v = JSON(0, "worlds", "--expect", "1");
    assert_int_equal(jlen(v, "daemons"), 1);
    assert_string_equal(jstr(v, "daemons.0.daemon"), DAEMON);
    assert_string_equal(jstr(v, "daemons.0.status"), "OK");
    assert_int_equal(jlen(v, "worlds"), 3);
    int box = has_world(v, "worlds", "box"), rays = has_world(v, "worlds", "box_rays");
    int broken = has_world(v, "worlds", "broken");
    assert_true(box >= 0 && rays >= 0 && broken >= 0);
    char at[32];
    snprintf(at, sizeof at, "worlds.%d", box);
    check_box_info(v, at);
    char p[64];
    snprintf(p, sizeof p, "worlds.%d.effects", box);
    assert_int_equal(jlen(v, p), 4); /* all: rays, triangles, meshes, distance */
    snprintf(p, sizeof p, "worlds.%d.shapes.0", box);
    assert_string_equal(jstr(v, p), "cube");
    snprintf(p, sizeof p, "worlds.%d.effects", rays);
    assert_int_equal(jlen(v, p), 1);
    snprintf(p, sizeof p, "worlds.%d.effects.0", rays);
    assert_string_equal(jstr(v, p), "rays");
    /* The scene's world that could not load is listed: version 0 and why. */
    snprintf(p, sizeof p, "worlds.%d.version", broken);
    assert_int_equal((int)jnum(v, p), 0);
    snprintf(p, sizeof p, "worlds.%d.last_error", broken);
    expect_text(jstr(v, p), "missing.obj: No such file or directory");
    jfree(v);

    cli_run r = CLI("worlds");
    expect_code(&r, 0);
    expect_text(r.out, "3 worlds on 1 daemon (" BUS_URL "), 1 not loaded");
    expect_text(r.out, "WORLD");
    expect_text(r.out, "box_rays");
    expect_text(r.out, "rays triangles meshes distance");
    expect_text(r.out, "not loaded: world 'broken': missing.obj: No such file or directory");
    run_free(&r);

    /* Asking the failed world anything gets the reason at once, not silence. */
    r = CLI("info", "broken");
    expect_code(&r, 1);
    expect_text(r.err, "daemon " DAEMON " answered ERR_LOAD_FAILED");
    expect_text(r.err, "its build failed: world 'broken': missing.obj: No such file or directory");
    run_free(&r);
    r = CLI("ray", "broken", "0", "0", "5", "0", "0", "-1");
    expect_code(&r, 1);
    expect_text(r.err, "ERR_LOAD_FAILED");
    run_free(&r);
}

static void test_info(void **state)
{
    (void)state;
    jv *v = JSON(0, "info", "box");
    assert_string_equal(jstr(v, "world"), "box");
    assert_int_equal((int)jnum(v, "world_version"), 1);
    assert_int_equal(jlen(v, "worlds"), 1);
    assert_string_equal(jstr(v, "worlds.0.name"), "box");
    check_box_info(v, "worlds.0");
    jfree(v);
    cli_run r = CLI("info", "box");
    expect_code(&r, 0);
    expect_text(r.out, "triangles   12");
    expect_text(r.out, "shapes      cube");
    run_free(&r);
}

static void check_hit(const jv *v, int i, int ray, double t, int triangle, double u, double w)
{
    char p[64];
#define H(field) (snprintf(p, sizeof p, "hits.%d.%s", i, field), p)
    assert_int_equal((int)jnum(v, H("ray")), ray);
    assert_true(jnum(v, H("t")) == t);
    assert_int_equal((int)jnum(v, H("triangle")), triangle);
    assert_true(fabs(jnum(v, H("u")) - u) < 1e-12);
    assert_true(fabs(jnum(v, H("v")) - w) < 1e-12);
    /* Top and bottom faces: unit normals along z, outward. */
    assert_true(jnum(v, H("normal.0")) == 0 && jnum(v, H("normal.1")) == 0);
    assert_true(jnum(v, H("normal.2")) == (triangle <= 1 ? 1 : -1));
#undef H
}

static void test_ray(void **state)
{
    (void)state;
    /* Straight down at (1, 3): the top's triangle 1 (y > x) at t = 8, u = x/4, v = (y-x)/4. */
    jv *v = JSON(0, "ray", "box", "1", "3", "10", "0", "0", "-1");
    assert_string_equal(jstr(v, "status"), "OK");
    assert_string_equal(jstr(v, "daemon"), DAEMON);
    assert_string_equal(jstr(v, "world"), "box");
    assert_string_equal(jstr(v, "detail"), "closest");
    assert_int_equal((int)jnum(v, "rays"), 1);
    assert_int_equal((int)jnum(v, "requests"), 1);
    assert_true(jneed(v, "tmax", J_NULL) != NULL); /* infinity: no limit */
    assert_int_equal(jlen(v, "found"), 1);
    assert_int_equal((int)jnum(v, "found.0"), 1);
    assert_int_equal(jlen(v, "hits"), 1);
    check_hit(v, 0, 0, 8, 1, 0.25, 0.5);
    /* Where: origin + t * direction. */
    assert_true(jnum(v, "hits.0.point.0") == 1 && jnum(v, "hits.0.point.1") == 3 && jnum(v, "hits.0.point.2") == 2);
    jfree(v);

    /* At (3, 1): triangle 0, u = (x-y)/4, v = y/4. Negative numbers pass unquoted. */
    v = JSON(0, "ray", "box", "3", "1", "10", "-0", "-0", "-2");
    check_hit(v, 0, 0, 4, 0, 0.5, 0.25);
    assert_true(jnum(v, "hits.0.point.0") == 3 && jnum(v, "hits.0.point.2") == 2);
    jfree(v);
    /* Text never shows -0: the same ray's point is 3 1 2, and -0 inputs print as 0. */
    cli_run neg = CLI("ray", "box", "3", "1", "10", "-0", "-0", "-2");
    expect_code(&neg, 0);
    expect_text(neg.out, "  3 1 2  ");
    if (strstr(neg.out, "-0") != NULL)
        fail_msg("text output shows -0:\n%s", neg.out);
    run_free(&neg);

    /* Every crossing: the top at 8, the bottom's triangle 3 at 10. */
    v = JSON(0, "ray", "box", "1", "3", "10", "0", "0", "-1", "--all");
    assert_string_equal(jstr(v, "detail"), "all");
    assert_int_equal((int)jnum(v, "found.0"), 2);
    assert_int_equal(jlen(v, "hits"), 2);
    check_hit(v, 0, 0, 8, 1, 0.25, 0.5);
    assert_true(jnum(v, "hits.1.t") == 10);
    assert_int_equal((int)jnum(v, "hits.1.triangle"), 3);
    jfree(v);

    /* max_hits stores fewer; found still counts both crossings. */
    v = JSON(0, "ray", "box", "1", "3", "10", "0", "0", "-1", "--all", "--max-hits", "1");
    assert_int_equal((int)jnum(v, "found.0"), 2);
    assert_int_equal(jlen(v, "hits"), 1);
    assert_true(jnum(v, "hits.0.t") == 8);
    jfree(v);

    v = JSON(0, "ray", "box", "1", "3", "10", "0", "0", "-1", "--any");
    assert_string_equal(jstr(v, "detail"), "any");
    assert_int_equal((int)jnum(v, "found.0"), 1);
    double t = jnum(v, "hits.0.t");
    assert_true(t == 8 || t == 10);
    jfree(v);

    /* The interval: the top is past tmax 5; from tmin 9 the bottom is the closest; the
     * interval is closed, so [8, 8] still hits. */
    v = JSON(0, "ray", "box", "1", "3", "10", "0", "0", "-1", "--tmax", "5");
    assert_int_equal((int)jnum(v, "found.0"), 0);
    assert_int_equal(jlen(v, "hits"), 0);
    assert_true(jnum(v, "tmax") == 5);
    jfree(v);
    v = JSON(0, "ray", "box", "1", "3", "10", "0", "0", "-1", "--tmin", "9");
    assert_true(jnum(v, "hits.0.t") == 10);
    assert_int_equal((int)jnum(v, "hits.0.triangle"), 3);
    jfree(v);
    v = JSON(0, "ray", "box", "1", "3", "10", "0", "0", "-1", "--tmin=8", "--tmax=8", "--accuracy", "fast");
    assert_string_equal(jstr(v, "accuracy"), "fast");
    assert_int_equal((int)jnum(v, "found.0"), 1);
    jfree(v);

    /* Options before the command, and the human table. */
    cli_run r = CLI("--timeout", "3000", "ray", "box", "1", "3", "10", "0", "0", "-1", "--all");
    expect_code(&r, 0);
    expect_text(r.out, "world box (version 1, daemon " DAEMON "), all hit: 1 of 1 ray hit");
    expect_text(r.out, "RAY  FOUND   T  POINT  OBJECT  TRIANGLE     U     V  NORMAL\n"
                       "  0      2   8  1 3 2  box            1  0.25   0.5  0 0 1\n"
                       "  0      2  10  1 3 0  box            3   0.5  0.25  0 0 -1\n");
    run_free(&r);
}

/* A 5x5 depth picture of the box from (2, 2, 10) straight down, 60 degrees high: the centre
 * pixel's ray is the view itself and meets the top at t = 8 exactly (the nearest hit, white);
 * the inner 3x3 pixels land on the top (their lateral offset at the top is 1.85), the
 * border ring's rays (3.7 off) pass beside the box and leave their pixels transparent. */
static void test_render(void **state)
{
    (void)state;
    char png[320];
    path_in_dir(png, sizeof png, "box.png");
    jv *v = JSON(0, "render", "box", "--camera", "2", "2", "10", "--look-at", "2", "2", "0", "--up", "0", "1", "0",
                 "--size", "5x5", "-o", png);
    assert_string_equal(jstr(v, "status"), "OK");
    assert_string_equal(jstr(v, "world"), "box");
    assert_string_equal(jstr(v, "shade"), "depth");
    assert_int_equal((int)jnum(v, "rays"), 25);
    assert_int_equal((int)jnum(v, "requests"), 1);
    assert_int_equal((int)jnum(v, "hit_rays"), 9);
    assert_true(jnum(v, "depth_near") == 8.0);
    double far = jnum(v, "depth_far");
    assert_true(far > 8.4 && far < 8.5); /* 8 * sqrt(1 + 2 * (0.4 * tan 30)^2) = 8.42 */
    jfree(v);

    cli_png_image img;
    char err[512];
    assert_int_equal(cli_png_read(png, &img, err, sizeof err), 0);
    assert_int_equal(img.width, 5);
    assert_int_equal(img.height, 5);
    assert_int_equal(img.channels, 2);
    assert_int_equal(img.bit_depth, 16);
    for (int y = 0; y < 5; y++)
        for (int x = 0; x < 5; x++) {
            const uint16_t *px = img.samples + (y * 5 + x) * 2;
            int inner = x >= 1 && x <= 3 && y >= 1 && y <= 3;
            assert_int_equal(px[1], inner ? 65535 : 0);
            if (!inner)
                assert_int_equal(px[0], 0);
        }
    assert_int_equal(img.samples[(2 * 5 + 2) * 2], 65535); /* the centre: nearest */
    assert_true(img.samples[(1 * 5 + 1) * 2] <= 1);         /* an inner corner: farthest */
    uint16_t edge = img.samples[(1 * 5 + 2) * 2];
    assert_true(edge > 1000 && edge < 64535);
    assert_string_equal(cli_png_text_get(&img, "trioct.world"), "box");
    assert_string_equal(cli_png_text_get(&img, "trioct.depth_near"), "8");
    assert_string_equal(cli_png_text_get(&img, "trioct.camera"), "2 2 10");
    assert_string_equal(cli_png_text_get(&img, "trioct.shade"), "depth");
    cli_png_image_free(&img);

    /* Normals: the top's +z faces the camera, so its pixels are (128, 128, 255). */
    cli_run r = CLI("render", "box", "--camera", "2", "2", "10", "--look-at=2,2,0", "--up", "0", "1", "0",
                    "--size", "5x5", "--shade", "normal", "-o", png);
    expect_code(&r, 0);
    expect_text(r.out, "5x5 normal picture of world box (version 1, daemon " DAEMON "), 9 of 25 rays hit");
    run_free(&r);
    assert_int_equal(cli_png_read(png, &img, err, sizeof err), 0);
    assert_int_equal(img.channels, 4);
    const uint16_t *centre = img.samples + (2 * 5 + 2) * 4;
    assert_true(centre[0] == 128 && centre[1] == 128 && centre[2] == 255 && centre[3] == 255);
    assert_int_equal(img.samples[3], 0); /* a corner: transparent */
    cli_png_image_free(&img);

    /* What makes no picture is a usage error before anything is asked. */
    r = CLI("render", "box", "--look-at", "2", "2", "0", "-o", png);
    expect_code(&r, 2);
    expect_text(r.err, "render needs --camera x y z, --look-at x y z and -o FILE.png");
    run_free(&r);
    r = CLI("render", "box", "--camera", "2", "2", "10", "--look-at", "2", "2", "0", "-o", png);
    expect_code(&r, 2); /* the default up, 0 0 1, is parallel to this view */
    expect_text(r.err, "parallel to the view");
    run_free(&r);
    r = CLI("render", "box", "--camera", "2", "2", "10", "--look-at", "2", "2", "0", "--size", "0x5", "-o", png);
    expect_code(&r, 2);
    expect_text(r.err, "--size: '0x5' is not WIDTHxHEIGHT");
    run_free(&r);
    r = CLI("render", "box", "--camera", "2", "2", "--look-at", "2", "2", "0", "-o", png);
    expect_code(&r, 2);
    run_free(&r);
    /* A file that cannot be written: trioct's own failure, naming it. */
    r = CLI("render", "box", "--camera", "2", "-9", "1", "--look-at", "2", "2", "1", "--size", "4x3", "-o",
            "/nonexistent-dir/box.png");
    expect_code(&r, 5);
    expect_text(r.err, "/nonexistent-dir/box.png");
    run_free(&r);
    /* A world nobody serves: the daemon error, as for rays. */
    r = CLI("render", "no_such_world", "--camera", "2", "-9", "1", "--look-at", "2", "2", "1", "-o", png,
            "--timeout", "500");
    assert_true(r.code == 1 || r.code == 3);
    run_free(&r);
}

/* --touch on a ray sliding along the top z = 2 at y = 1, from x = -1: as crossings it
 * passes (the perturbed ray runs just above the top), as a touch it is blocked at t = 1
 * where it reaches the top's edge (0, 1, 2): the top's triangle 1 (u = 0, v = 1/4) and the
 * side x = 0's triangle 11 there, the top's triangle 0 from the diagonal x = y at t = 2,
 * and the side x = 4's triangle 7 at t = 5. */
static void test_ray_touch(void **state)
{
    (void)state;
    jv *v = JSON(0, "ray", "box", "-1", "1", "2", "1", "0", "0", "--any");
    assert_int_equal((int)jnum(v, "found.0"), 0);
    jfree(v);
    v = JSON(0, "ray", "box", "-1", "1", "2", "1", "0", "0", "--all");
    assert_int_equal((int)jnum(v, "found.0"), 0);
    jfree(v);
    v = JSON(0, "ray", "box", "-1", "1", "2", "1", "0", "0", "--any", "--touch");
    assert_string_equal(jstr(v, "detail"), "any");
    assert_int_equal((int)jnum(v, "found.0"), 1);
    jfree(v);
    v = JSON(0, "ray", "box", "-1", "1", "2", "1", "0", "0", "--touch");
    assert_int_equal((int)jnum(v, "found.0"), 1);
    check_hit(v, 0, 0, 1, 1, 0, 0.25);
    jfree(v);
    v = JSON(0, "ray", "box", "-1", "1", "2", "1", "0", "0", "--touch", "--all", "--accuracy", "world");
    assert_int_equal((int)jnum(v, "found.0"), 4);
    static const int ids[4] = {1, 11, 0, 7};
    static const double ts[4] = {1, 1, 2, 5};
    for (int k = 0; k < 4; k++) {
        char p[32];
        snprintf(p, sizeof p, "hits.%d.triangle", k);
        assert_int_equal((int)jnum(v, p), ids[k]);
        snprintf(p, sizeof p, "hits.%d.t", k);
        assert_true(jnum(v, p) == ts[k]);
    }
    jfree(v);
    /* A ray straight down crosses as it touches: the same answer either way. */
    v = JSON(0, "ray", "box", "1", "3", "10", "0", "0", "-1", "--touch");
    check_hit(v, 0, 0, 8, 1, 0.25, 0.5);
    jfree(v);

    /* rays: the same rule for every line of the file. */
    char path[320];
    path_in_dir(path, sizeof path, "touch.csv");
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fprintf(f, "-1, 1, 2, 1, 0, 0\n1, 3, 10, 0, 0, -1\n-1, 1, 2.5, 1, 0, 0\n");
    assert_int_equal(fclose(f), 0);
    cli_run r = CLI("rays", "box", path, "--any", "--touch", "--json");
    expect_code(&r, 0);
    v = jparse_line(r.out);
    assert_int_equal((int)jnum(v, "found.0"), 1);
    assert_int_equal((int)jnum(v, "found.1"), 1);
    assert_int_equal((int)jnum(v, "found.2"), 0); /* above the box */
    jfree(v);
    run_free(&r);
    r = CLI("rays", "box", path, "--any", "--json");
    expect_code(&r, 0);
    v = jparse_line(r.out);
    assert_int_equal((int)jnum(v, "found.0"), 0);
    assert_int_equal((int)jnum(v, "found.1"), 1);
    jfree(v);
    run_free(&r);

    /* The human table is the one without --touch. */
    r = CLI("ray", "box", "-1", "1", "2", "1", "0", "0", "--touch");
    expect_code(&r, 0);
    expect_text(r.out, "world box (version 1, daemon " DAEMON "), closest hit: 1 of 1 ray hit");
    expect_text(r.out, "RAY  FOUND  T  POINT  OBJECT  TRIANGLE  U     V  NORMAL\n"
                       "  0      1  1  0 1 2  box            1  0  0.25  0 0 1\n");
    run_free(&r);

    /* Touch is exact-only: seed or fast with it is a usage error. */
    const char *seed[] = {"ray", "box", "-1", "1", "2", "1", "0", "0", "--touch", "--accuracy", "seed", NULL};
    r = run_cli(NULL, seed);
    expect_code(&r, 2);
    expect_text(r.err, "--touch is decided exactly: use --accuracy exact or world");
    run_free(&r);
}

/* (x, y) of ray i of the batch: off the diagonal, so which top triangle is never a tie. */
static void batch_xy(int i, double *x, double *y)
{
    *x = 0.25 + 0.5 * (i % 7);
    *y = 0.375 + 0.5 * ((i / 7) % 7);
}

static void test_rays_batch(void **state)
{
    (void)state;
    enum { N = 3000 };
    char path[320];
    path_in_dir(path, sizeof path, "rays.csv");
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fprintf(f, "# ox,oy,oz,dx,dy,dz\n\n");
    for (int i = 0; i < N; i++) {
        double x, y;
        batch_xy(i, &x, &y);
        fprintf(f, "%.17g, %.17g, 10, 0, 0, -1\r\n", x, y);
        if (i % 1000 == 999)
            fprintf(f, "   # a thousand\n\n");
    }
    assert_int_equal(fclose(f), 0);

    /* From standard input: 3000 rays are three requests (1280 + 1280 + 440), numbered as one. */
    cli_run r = CLI_STDIN(path, "--json", "rays", "box", "-");
    expect_code(&r, 0);
    jv *v = jparse_line(r.out);
    run_free(&r);
    assert_int_equal((int)jnum(v, "rays"), N);
    assert_int_equal((int)jnum(v, "requests"), 3);
    assert_int_equal((int)jnum(v, "hit_rays"), N);
    assert_int_equal(jlen(v, "found"), N);
    assert_int_equal(jlen(v, "hits"), N);
    const jv *hits = jget(v, "hits");
    for (int i = 0; i < N; i++) {
        double x, y;
        batch_xy(i, &x, &y);
        const jv *h = &hits->items[i];
        assert_int_equal((int)jnum(h, "ray"), i);
        assert_true(jnum(h, "t") == 8);
        assert_int_equal((int)jnum(h, "triangle"), y > x ? 1 : 0);
        double u = y > x ? x / 4 : (x - y) / 4, w = y > x ? (y - x) / 4 : y / 4;
        assert_true(fabs(jnum(h, "u") - u) < 1e-12 && fabs(jnum(h, "v") - w) < 1e-12);
    }
    jfree(v);

    /* From the file, by name, with every crossing: two per ray, each ray's in t order. */
    r = CLI("rays", "box", path, "--all", "--json");
    expect_code(&r, 0);
    v = jparse_line(r.out);
    run_free(&r);
    assert_int_equal(jlen(v, "hits"), 2 * N);
    hits = jget(v, "hits");
    for (int i = 0; i < N; i++) {
        assert_int_equal((int)jnum(&hits->items[2 * i], "ray"), i);
        assert_int_equal((int)jnum(&hits->items[2 * i + 1], "ray"), i);
        assert_true(jnum(&hits->items[2 * i + 1], "t") == 10);
    }
    jfree(v);

    r = CLI("rays", "box", path);
    expect_code(&r, 0);
    expect_text(r.out, "closest hit: 3000 of 3000 rays hit");
    expect_text(r.out, "\n2999 ");
    run_free(&r);
}

static void test_tri(void **state)
{
    (void)state;
    /* Upright in the plane y = 1, poking through the top between x = 1.5 and 2.5, where
     * y < x: it touches triangle 0 along that segment and nothing else. */
    jv *v = JSON(0, "tri", "box", "1", "1", "1", "3", "1", "1", "2", "1", "3");
    assert_string_equal(jstr(v, "detail"), "yesno");
    assert_true(jbool(v, "touching"));
    assert_int_equal((int)jnum(v, "found.0"), 1);
    assert_int_equal(jlen(v, "contacts"), 0);
    jfree(v);

    v = JSON(0, "tri", "box", "1", "1", "1", "3", "1", "1", "2", "1", "3", "--ids");
    assert_int_equal((int)jnum(v, "found.0"), 1);
    assert_int_equal(jlen(v, "contacts"), 1);
    assert_int_equal((int)jnum(v, "contacts.0.query"), 0);
    assert_int_equal((int)jnum(v, "contacts.0.triangle"), 0);
    jfree(v);

    v = JSON(0, "tri", "box", "1", "1", "1", "3", "1", "1", "2", "1", "3", "--segments");
    assert_int_equal(jlen(v, "contacts"), 1);
    double px = jnum(v, "contacts.0.segment.p.0"), qx = jnum(v, "contacts.0.segment.q.0");
    assert_true((px == 1.5 && qx == 2.5) || (px == 2.5 && qx == 1.5));
    assert_true(jnum(v, "contacts.0.segment.p.1") == 1 && jnum(v, "contacts.0.segment.q.1") == 1);
    assert_true(jnum(v, "contacts.0.segment.p.2") == 2 && jnum(v, "contacts.0.segment.q.2") == 2);
    jfree(v);

    /* Inside the box, touching no face. */
    v = JSON(0, "tri", "box", "1", "1", "0.5", "3", "1", "0.5", "2", "3", "0.5", "--ids");
    assert_false(jbool(v, "touching"));
    assert_int_equal((int)jnum(v, "found.0"), 0);
    assert_int_equal(jlen(v, "contacts"), 0);
    jfree(v);

    cli_run r = CLI("tri", "box", "1", "1", "1", "3", "1", "1", "2", "1", "3", "--segments");
    expect_code(&r, 0);
    expect_text(r.out, "touching 1 world triangle\n");
    expect_text(r.out, "TRIANGLE  FROM");
    run_free(&r);
}

static void test_mesh(void **state)
{
    (void)state;
    /* The unit cube resting on the top (coplanar contact), lifted clear, turned 45 degrees
     * about z while resting, and turned 90 about x (exact) while resting. */
    jv *v = JSON(0, "mesh", "box", "cube", "--pose", "2 2 2.5", "--pose", "2,2,5", "--pose", "2 2 2.5 0 0 45",
                 "--pose", "2 2 2.5 90 0 0");
    assert_string_equal(jstr(v, "shape"), "cube");
    assert_string_equal(jstr(v, "detail"), "yesno");
    assert_int_equal((int)jnum(v, "poses"), 4);
    assert_int_equal(jlen(v, "found"), 4);
    assert_int_equal((int)jnum(v, "found.0"), 1);
    assert_int_equal((int)jnum(v, "found.1"), 0);
    assert_int_equal((int)jnum(v, "found.2"), 1);
    assert_int_equal((int)jnum(v, "found.3"), 1);
    assert_int_equal((int)jnum(v, "touching_poses"), 3);
    jfree(v);

    /* Lifted by 2.5 + 0.5 after a quarter turn about x: clear of the top by exactly 0.5. */
    v = JSON(0, "mesh", "box", "cube", "--pose", "2 2 3 90 0 0");
    assert_int_equal((int)jnum(v, "found.0"), 0);
    jfree(v);

    /* Without a pose the cube stays where it is, around the box's corner (0, 0, 0). */
    v = JSON(0, "mesh", "box", "cube");
    assert_int_equal((int)jnum(v, "poses"), 1);
    assert_int_equal((int)jnum(v, "found.0"), 1);
    jfree(v);

    /* Pairs: every one for pose 0, against the two top triangles only (the cube's footprint
     * [1.5, 2.5]^2 straddles their shared diagonal). */
    v = JSON(0, "mesh", "box", "cube", "--pose", "2 2 2.5", "--pose", "2 2 5", "--pairs");
    assert_string_equal(jstr(v, "detail"), "pairs");
    size_t n = jlen(v, "pairs");
    assert_true(n > 0);
    assert_int_equal((int)jnum(v, "found.0"), (int)n);
    assert_int_equal((int)jnum(v, "found.1"), 0);
    int seen[2] = {0, 0};
    const jv *pairs = jget(v, "pairs");
    for (size_t i = 0; i < n; i++) {
        assert_int_equal((int)jnum(&pairs->items[i], "pose"), 0);
        int w = (int)jnum(&pairs->items[i], "world_triangle");
        int s = (int)jnum(&pairs->items[i], "shape_triangle");
        assert_true(w == 0 || w == 1);
        assert_true(s >= 0 && s < 12);
        seen[w] = 1;
    }
    assert_true(seen[0] && seen[1]);
    jfree(v);

    /* 600 poses from a file: two requests (512 + 88), numbered as one list. */
    char path[320];
    path_in_dir(path, sizeof path, "poses.csv");
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fprintf(f, "# tx,ty,tz,rx,ry,rz\n");
    for (int i = 0; i < 600; i++)
        fprintf(f, i % 2 ? "2,2,5\n\n" : "2, 2, 2.5, 0, 0, %d\n", i % 360);
    assert_int_equal(fclose(f), 0);
    v = JSON(0, "mesh", "box", "cube", "--poses", path);
    assert_int_equal((int)jnum(v, "poses"), 600);
    assert_int_equal((int)jnum(v, "requests"), 2);
    assert_int_equal((int)jnum(v, "touching_poses"), 300);
    for (int i = 0; i < 600; i++) {
        char p[32];
        snprintf(p, sizeof p, "found.%d", i);
        assert_int_equal((int)jnum(v, p), i % 2 == 0);
    }
    jfree(v);

    cli_run r = CLI("mesh", "box", "cube", "--pose", "2 2 2.5", "--pose", "2 2 5");
    expect_code(&r, 0);
    expect_text(r.out, "shape cube: 1 of 2 poses touching");
    expect_text(r.out, "POSE  TOUCHING\n   0  yes\n   1  no\n");
    run_free(&r);
}

/* The corners and faces (1-based, as in cube_obj) of the query shape. */
static const double cube_corner[8][3] = {{-0.5, -0.5, -0.5}, {0.5, -0.5, -0.5}, {0.5, 0.5, -0.5}, {-0.5, 0.5, -0.5},
                                         {-0.5, -0.5, 0.5},  {0.5, -0.5, 0.5},  {0.5, 0.5, 0.5},  {-0.5, 0.5, 0.5}};
static const int cube_face[12][3] = {{5, 6, 7}, {5, 7, 8}, {1, 3, 2}, {1, 4, 3}, {1, 2, 6}, {1, 6, 5},
                                     {2, 3, 7}, {2, 7, 6}, {3, 4, 8}, {3, 8, 7}, {4, 1, 5}, {4, 5, 8}};

/* cube_obj's triangles, in its order, as an ASCII STL (another format than the scene's
 * cube.obj, and one without shared vertices), `copies` times over. Returns its path. */
static void write_cube_stl(const char *name, int copies, char *path, size_t len)
{
    path_in_dir(path, len, name);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fprintf(f, "solid cube\n");
    for (int c = 0; c < copies; c++)
        for (int t = 0; t < 12; t++) {
            fprintf(f, " facet normal 0 0 0\n  outer loop\n");
            for (int k = 0; k < 3; k++) {
                const double *p = cube_corner[cube_face[t][k] - 1];
                fprintf(f, "   vertex %g %g %g\n", p[0], p[1], p[2]);
            }
            fprintf(f, "  endloop\n endfacet\n");
        }
    fprintf(f, "endsolid cube\n");
    assert_int_equal(fclose(f), 0);
}

/* Pairs i and k of a and b: the same pose (after a pose offset), shape triangle, object
 * and world triangle. */
static int same_pair(const jv *a, size_t i, const jv *b, size_t k, int pose_offset)
{
    const jv *p = &jget(a, "pairs")->items[i], *q = &jget(b, "pairs")->items[k];
    return (int)jnum(p, "pose") + pose_offset == (int)jnum(q, "pose") &&
           (int)jnum(p, "shape_triangle") == (int)jnum(q, "shape_triangle") &&
           strcmp(jstr(p, "object"), jstr(q, "object")) == 0 &&
           (int)jnum(p, "world_triangle") == (int)jnum(q, "world_triangle");
}

/* The pairs of one pose in v: first index and count (pairs are sorted by pose). */
static void pose_pairs(const jv *v, int pose, size_t *first, size_t *count)
{
    size_t n = jlen(v, "pairs");
    *first = n;
    *count = 0;
    for (size_t i = 0; i < n; i++)
        if ((int)jnum(&jget(v, "pairs")->items[i], "pose") == pose) {
            if (*count == 0)
                *first = i;
            ++*count;
        }
}

/* --shape-file: the cube as a file of this test's, its triangles sent inline, answers as the
 * scene's cube does, touching and pairs alike, at poses given in degrees and as quaternions
 * (a quaternion pose of a quarter turn rests on the top exactly as its Euler twin does). */
static void test_mesh_shape_file(void **state)
{
    (void)state;
    char stl[320];
    write_cube_stl("cube_copy.stl", 1, stl, sizeof stl);
#define MESH_POSES                                                                                                \
    "--pose", "2 2 2.5", "--pose", "2,2,5", "--pose", "2 2 2.5 0 0 45", "--pose", "2 2 2.5 90 0 0", "--pose",         \
        "2 2 2.5 0.7071067811865476 0.7071067811865476 0 0", "--pose", "2 2 3 0.70710678 0.70710678 0 0", "--pose", \
        "2 2 2.5 0 0 0 1", "--pose", "0 0 0"
    static const int touching[8] = {1, 0, 1, 1, 1, 0, 1, 1};
    jv *named = JSON(0, "mesh", "box", "cube", MESH_POSES, "--pairs");
    jv *file = JSON(0, "mesh", "box", "--shape-file", stl, MESH_POSES, "--pairs");
    jv *yesno = JSON(0, "mesh", "box", "--shape-file", stl, MESH_POSES);
#undef MESH_POSES
    assert_string_equal(jstr(named, "shape"), "cube");
    assert_false(jbool(named, "shape_file"));
    assert_null(jget(named, "shape_triangles"));
    assert_string_equal(jstr(file, "shape"), stl);
    assert_true(jbool(file, "shape_file"));
    assert_int_equal((int)jnum(file, "shape_triangles"), 12);
    assert_int_equal((int)jnum(file, "requests"), 1);
    assert_int_equal((int)jnum(yesno, "touching_poses"), 6);
    for (int i = 0; i < 8; i++) {
        char p[32];
        snprintf(p, sizeof p, "found.%d", i);
        assert_int_equal((int)jnum(named, p) > 0, touching[i]);
        assert_int_equal((int)jnum(file, p), (int)jnum(named, p));
        assert_int_equal((int)jnum(yesno, p), touching[i]);
    }
    size_t n = jlen(named, "pairs");
    assert_true(n > 0);
    assert_int_equal(jlen(file, "pairs"), n);
    for (size_t i = 0; i < n; i++)
        if (!same_pair(named, i, file, i, 0))
            fail_msg("pair %zu differs between the scene's cube and %s", i, stl);
    /* Pose 4, a quaternion, is pose 3 in degrees: the very same pairs, for both shapes. */
    const jv *answers[2] = {named, file};
    for (int a = 0; a < 2; a++) {
        size_t first3, count3, first4, count4;
        pose_pairs(answers[a], 3, &first3, &count3);
        pose_pairs(answers[a], 4, &first4, &count4);
        assert_true(count3 > 0);
        assert_int_equal(count4, count3);
        for (size_t i = 0; i < count3; i++)
            if (!same_pair(answers[a], first3 + i, answers[a], first4 + i, 1))
                fail_msg("pair %zu of the quaternion pose differs from its Euler twin's", i);
    }
    jfree(named);
    jfree(file);
    jfree(yesno);

    cli_run r = CLI("mesh", "box", "--shape-file", stl, "--pose", "2 2 2.5", "--pose", "2 2 5");
    expect_code(&r, 0);
    char says[400];
    snprintf(says, sizeof says, "shape file %s (12 triangles): 1 of 2 poses touching", stl);
    expect_text(r.out, says);
    expect_text(r.out, "POSE  TOUCHING\n   0  yes\n   1  no\n");
    run_free(&r);

    /* 504 triangles (the cube 42 times over) leave room for fewer poses a request than
     * TRIOCT_MAX_POSES: 600 poses from a file, degrees, translations and quaternions mixed,
     * take 3 requests and come back numbered as one list. */
    char big[320], path[320];
    write_cube_stl("cubes.stl", 42, big, sizeof big);
    path_in_dir(path, sizeof path, "shape_poses.csv");
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    for (int i = 0; i < 600; i++)
        fprintf(f, i % 3 == 0 ? "2, 2, 2.5, 0, 0, %d\n" : i % 3 == 1 ? "2,2,5\n" : "2 2 2.5 0.7071 0 0 0.7071\n",
                i % 360);
    assert_int_equal(fclose(f), 0);
    jv *v = JSON(0, "mesh", "box", "--shape-file", big, "--poses", path);
    assert_int_equal((int)jnum(v, "shape_triangles"), 504);
    assert_int_equal((int)jnum(v, "poses"), 600);
    assert_int_equal((int)jnum(v, "requests"), 3);
    assert_int_equal((int)jnum(v, "touching_poses"), 400);
    for (int i = 0; i < 600; i++) {
        char p[32];
        snprintf(p, sizeof p, "found.%d", i);
        assert_int_equal((int)jnum(v, p), i % 3 != 1);
    }
    jfree(v);

    /* Usage errors, each naming what is wrong: nothing is sent. */
    char missing[320], over[320], lines[320], zero[320];
    path_in_dir(missing, sizeof missing, "missing.stl");
    write_cube_stl("too_many.stl", 43, over, sizeof over); /* 516 triangles */
    write_text("lines.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nl 2 3\n");
    path_in_dir(lines, sizeof lines, "lines.obj");
    write_text("zero_q.csv", "2 2 2.5\n\n2 2 2.5 0 0 0 0\n");
    path_in_dir(zero, sizeof zero, "zero_q.csv");
    char says_missing[400], says_lines[400], says_zero[400];
    snprintf(says_missing, sizeof says_missing, "--shape-file: cannot open %s: No such file or directory", missing);
    snprintf(says_lines, sizeof says_lines, "--shape-file: no triangles in %s", lines);
    snprintf(says_zero, sizeof says_zero, "%s:3: the quaternion (0 0 0 0) is not of length 1 within 1e-3", zero);
    struct {
        const char *args[8];
        const char *says;
    } cases[] = {
        {{"mesh", "box", "--shape-file", missing}, says_missing},
        {{"mesh", "box", "cube", "--shape-file", stl}, "SHAPE (cube) and --shape-file exclude each other"},
        {{"mesh", "box", "--shape-file", stl, "--shape-file", stl}, "--shape-file given twice"},
        {{"mesh", "box", "--shape-file", over}, "holds 516 triangles, over the cap of 512 a request carries inline "
                                                "(TRIOCT_MAX_INLINE_SHAPE_TRIANGLES)"},
        {{"mesh", "box", "--shape-file", lines}, says_lines},
        {{"mesh", "box", "--shape-file", stl, "--pose", "2 2 2.5 0 0 0 0"},
         "--pose '2 2 2.5 0 0 0 0': the quaternion (0 0 0 0) is not of length 1 within 1e-3"},
        {{"mesh", "box", "cube", "--poses", zero}, says_zero},
        {{"mesh", "box"}, "expected 2 arguments, WORLD and SHAPE (or WORLD and --shape-file FILE); got 1"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        r = run_cli(NULL, cases[i].args);
        expect_code(&r, 2);
        expect_text(r.err, cases[i].says);
        assert_string_equal(r.out, "");
        run_free(&r);
    }
    v = JSON(2, "mesh", "box", "--shape-file", missing);
    expect_text(jstr(v, "message"), says_missing);
    jfree(v);
}

/* Objects of box_rays: the section is one object named after it; the cube added as `lid`
 * above the box, moved (a quarter turn about z, which keeps its top at exactly z = 5.5),
 * and removed, with a ray straight down at (2, 2) naming what it meets at each step. */
static void test_objects(void **state)
{
    (void)state;
    jv *v = JSON(0, "objects", "box_rays");
    assert_int_equal((int)jnum(v, "objects"), 1);
    assert_int_equal(jlen(v, "list"), 1);
    assert_string_equal(jstr(v, "list.0.name"), "box_rays");
    assert_string_equal(jstr(v, "list.0.mesh"), "section:box_rays");
    assert_int_equal((int)jnum(v, "list.0.triangles"), 12);
    int version = (int)jnum(v, "world_version");
    jfree(v);

    v = JSON(0, "object", "add", "box_rays", "lid", "--mesh", "cube.obj", "--pose", "2", "2", "3", "1", "0", "0", "0");
    assert_string_equal(jstr(v, "action"), "added");
    assert_string_equal(jstr(v, "object"), "lid");
    assert_int_equal((int)jnum(v, "objects"), 2);
    assert_int_equal((int)jnum(v, "world_version"), version + 1);
    jfree(v);
    v = JSON(0, "ray", "box_rays", "2", "2", "10", "0", "0", "-1");
    assert_true(jnum(v, "hits.0.t") == 6.5); /* the lid's top, z = 3.5 */
    assert_string_equal(jstr(v, "hits.0.object"), "lid");
    jfree(v);

    v = JSON(0, "object", "move", "box_rays", "lid", "--pose", "2", "2", "5", "0.7071067811865476", "0", "0",
             "0.7071067811865476");
    assert_string_equal(jstr(v, "action"), "moved");
    jfree(v);
    v = JSON(0, "ray", "box_rays", "2", "2", "10", "0", "0", "-1", "--all");
    assert_true(jnum(v, "hits.0.t") == 4.5);
    assert_string_equal(jstr(v, "hits.0.object"), "lid");
    assert_true(jnum(v, "hits.2.t") == 8); /* then the box's top */
    assert_string_equal(jstr(v, "hits.2.object"), "box_rays");
    jfree(v);
    v = JSON(0, "objects", "box_rays");
    assert_string_equal(jstr(v, "list.1.name"), "lid");
    assert_true(jnum(v, "list.1.position.2") == 5);
    assert_true(fabs(jnum(v, "list.1.quaternion.3") - 0.7071067811865476) < 1e-12);
    jfree(v);
    cli_run r = CLI("objects", "box_rays");
    expect_code(&r, 0);
    expect_text(r.out, "2 objects");
    expect_text(r.out, "lid");
    run_free(&r);

    /* Errors: a name the world does not hold (the daemon's), a quaternion far from unit
     * length and an add without a mesh (trioct's own: nothing is sent). */
    v = JSON(1, "object", "move", "box_rays", "nothing", "--pose", "0", "0", "0", "1", "0", "0", "0");
    assert_string_equal(jstr(v, "status"), "ERR_UNKNOWN_OBJECT");
    expect_text(jstr(v, "message"), "nothing");
    jfree(v);
    r = CLI("object", "add", "box_rays", "lid2", "--mesh", "cube.obj", "--pose", "0", "0", "0", "2", "0", "0", "0");
    expect_code(&r, 2);
    run_free(&r);
    r = CLI("object", "add", "box_rays", "lid2");
    expect_code(&r, 2);
    run_free(&r);

    v = JSON(0, "object", "remove", "box_rays", "lid");
    assert_int_equal((int)jnum(v, "objects"), 1);
    jfree(v);
    v = JSON(0, "ray", "box_rays", "2", "2", "10", "0", "0", "-1");
    assert_true(jnum(v, "hits.0.t") == 8);
    assert_string_equal(jstr(v, "hits.0.object"), "box_rays");
    jfree(v);
}

/* A robot state of cube links over the box: resting on the top is a contact with the box
 * (coplanar faces), lifted it is clear; two overlapping links collide with --self unless
 * their pair is allowed; allowing the box leaves the resting link clear. */
static void test_state(void **state)
{
    (void)state;
    jv *v = JSON(0, "state", "box", "--link", "cube", "2", "2", "2.5", "1", "0", "0", "0", "--contacts");
    assert_false(jbool(v, "valid"));
    assert_true(jlen(v, "contacts") > 0);
    assert_string_equal(jstr(v, "contacts.0.link"), "cube");
    assert_string_equal(jstr(v, "contacts.0.other"), "box");
    assert_string_equal(jstr(v, "contacts.0.other_kind"), "object");
    int tri = (int)jnum(v, "contacts.0.other_triangle");
    assert_true(tri == 0 || tri == 1); /* the top */
    jfree(v);

    v = JSON(0, "state", "box", "--link", "cube", "2", "2", "2.5", "1", "0", "0", "0", "--allow", "box:cube");
    assert_true(jbool(v, "valid"));
    jfree(v);

    /* Two cubes overlapping in the air: clear of the world, not of each other. */
    v = JSON(0, "state", "box", "--link", "cube", "2", "2", "5", "1", "0", "0", "0", "--link", "cube", "2.5", "2", "5",
             "0.7071067811865476", "0", "0", "0.7071067811865476");
    assert_true(jbool(v, "valid"));
    jfree(v);
    v = JSON(0, "state", "box", "--link", "cube", "2", "2", "5", "1", "0", "0", "0", "--link", "cube", "2.5", "2", "5",
             "0.7071067811865476", "0", "0", "0.7071067811865476", "--self");
    assert_false(jbool(v, "valid"));
    assert_string_equal(jstr(v, "contacts.0.other"), "cube.2");
    assert_string_equal(jstr(v, "contacts.0.other_kind"), "link");
    jfree(v);
    v = JSON(0, "state", "box", "--link", "cube", "2", "2", "5", "1", "0", "0", "0", "--link", "cube", "2.5", "2", "5",
             "1", "0", "0", "0", "--self", "--allow", "cube.2:cube");
    assert_true(jbool(v, "valid"));
    jfree(v);

    cli_run r = CLI("state", "box", "--link", "cube", "2", "2", "2.5", "1", "0", "0", "0");
    expect_code(&r, 0);
    expect_text(r.out, "1 link: in collision");
    run_free(&r);
    v = JSON(1, "state", "box", "--link", "nosuch", "0", "0", "0", "1", "0", "0", "0");
    assert_string_equal(jstr(v, "status"), "ERR_UNKNOWN_SHAPE");
    jfree(v);
    v = JSON(1, "state", "box_rays", "--link", "cube", "0", "0", "0", "1", "0", "0", "0");
    assert_string_equal(jstr(v, "status"), "ERR_EFFECT");
    jfree(v);
    r = CLI("state", "box", "--link", "cube", "0", "0", "0");
    expect_code(&r, 2);
    run_free(&r);
}

/* trioct distance against the box [0,4] x [0,4] x [0,2]: distances known exactly, the
 * nearest feature a face, an edge or a vertex, --within, and the shape and clearance
 * forms printing the daemon's refusal. */
static void test_distance(void **state)
{
    (void)state;
    jv *v = JSON(0, "distance", "box", "--point", "6", "1", "1.5", "--point", "7", "-2", "1", "--point", "7", "7",
                 "5", "--point", "2", "1", "1.5");
    assert_string_equal(jstr(v, "command"), "distance");
    assert_int_equal((int)jnum(v, "points"), 4);
    assert_int_equal(jget(v, "within")->type, J_NULL);
    assert_int_equal(jlen(v, "results"), 4);
    /* (6, 1, 1.5) is 2 from the side x = 4, on its face. */
    assert_true(jbool(v, "results.0.found"));
    assert_true(fabs(jnum(v, "results.0.distance") - 2.0) <= jnum(v, "results.0.bound"));
    assert_true(jnum(v, "results.0.lower") <= 2.0 && 2.0 <= jnum(v, "results.0.upper"));
    assert_true(jnum(v, "results.0.point.0") == 4.0 && jnum(v, "results.0.point.1") == 1.0 &&
                jnum(v, "results.0.point.2") == 1.5);
    assert_true(jnum(v, "results.0.query.0") == 6.0);
    assert_string_equal(jstr(v, "results.0.object"), "box");
    int tri = (int)jnum(v, "results.0.triangle");
    assert_true(tri == 6 || tri == 7); /* the side x = 4 */
    assert_string_equal(jstr(v, "results.0.feature"), "face");
    assert_int_equal((int)jnum(v, "results.0.feature_index"), 0);
    assert_null(jget(v, "results.0.inside")); /* no solid objects: left out */
    /* (7, -2, 1): sqrt(13) from the edge x = 4, y = 0. */
    assert_string_equal(jstr(v, "results.1.feature"), "edge");
    assert_true(fabs(jnum(v, "results.1.distance") - sqrt(13.0)) <= jnum(v, "results.1.bound") + 1e-15);
    /* The nearest point is a rounded result: on the edge to within its rounding. */
    assert_true(fabs(jnum(v, "results.1.point.0") - 4.0) < 1e-14 && fabs(jnum(v, "results.1.point.1")) < 1e-14);
    /* (7, 7, 5): 3 sqrt(3) from the corner (4, 4, 2). */
    assert_string_equal(jstr(v, "results.2.feature"), "vertex");
    assert_true(fabs(jnum(v, "results.2.distance") - sqrt(27.0)) <= jnum(v, "results.2.bound") + 1e-15);
    assert_true(jnum(v, "results.2.point.0") == 4.0 && jnum(v, "results.2.point.1") == 4.0 &&
                jnum(v, "results.2.point.2") == 2.0);
    /* Inside the box, its surface distance: 0.5 to the top. */
    assert_true(fabs(jnum(v, "results.3.distance") - 0.5) <= jnum(v, "results.3.bound"));
    assert_true(jnum(v, "results.3.point.2") == 2.0);
    jfree(v);

    v = JSON(0, "distance", "box", "--point", "6", "1", "1.5", "--within", "1.5");
    assert_true(jnum(v, "within") == 1.5);
    assert_false(jbool(v, "results.0.found"));
    assert_null(jget(v, "results.0.distance"));
    jfree(v);

    cli_run r = CLI("distance", "box", "--point", "6", "1", "1.5", "--point", "7", "-2", "1");
    expect_code(&r, 0);
    expect_text(r.out, "2 points, 2 with a nearest point");
    expect_text(r.out, "DISTANCE");
    expect_text(r.out, "2 ± ");
    expect_text(r.out, "4 1 1.5");
    expect_text(r.out, "face");
    expect_text(r.out, "edge ");
    run_free(&r);
    r = CLI("distance", "box", "--point", "6", "1", "1.5", "--within", "1");
    expect_code(&r, 0);
    expect_text(r.out, "none within");
    run_free(&r);

    v = JSON(1, "distance", "box_rays", "--point", "6", "1", "1.5");
    assert_string_equal(jstr(v, "status"), "ERR_EFFECT");
    expect_text(jstr(v, "message"), "distance queries need effects = distance");
    jfree(v);

    /* Shape distance: the cube ([-0.5, 0.5]^3) at z = 5 is 2.5 above the box's top (z = 2),
     * at z = 2.6 it is fl(2.6 - 0.5) - 2 above it, and at z = 2.4 it touches: 0 exactly. */
    r = CLI("distance", "box", "--shape", "cube", "--pose", "2 2 5 1 0 0 0");
    expect_code(&r, 0);
    expect_text(r.out, "1 pose, 1 with a nearest point");
    expect_text(r.out, "2.5 ± ");
    expect_text(r.out, "SHAPE POINT (TRIANGLE)");
    run_free(&r);
    v = JSON(0, "distance", "box", "--shape", "cube", "--pose", "2 2 5 1 0 0 0", "--pose", "2 2 2.6", "--pose",
             "2 2 2.4");
    assert_int_equal(jlen(v, "results"), 3);
    assert_true(jnum(v, "results.0.lower") <= 2.5 && 2.5 <= jnum(v, "results.0.upper"));
    assert_true(jnum(v, "results.0.shape_point.2") == 4.5 && jnum(v, "results.0.point.2") == 2);
    double above = (2.6 - 0.5) - 2;
    assert_true(jnum(v, "results.1.lower") <= above && above <= jnum(v, "results.1.upper"));
    assert_true(jnum(v, "results.2.distance") == 0 && jnum(v, "results.2.upper") == 0);
    assert_string_equal(jstr(v, "results.2.object"), "box");
    assert_true(jget(v, "results.0.feature") == NULL); /* a shape's witness is a pair of triangles */
    jfree(v);
    /* Clearance: both poses clear of 0.05; at the second pose's own distance, not clear. */
    v = JSON(0, "clear", "box", "--shape", "cube", "--pose", "2 2 5 1 0 0 0", "--pose", "2 2 2.6", "--within", "0.05");
    assert_string_equal(jstr(v, "command"), "clear");
    assert_true(jbool(v, "results.0.clear") && jbool(v, "results.1.clear"));
    jfree(v);
    char at[32];
    snprintf(at, sizeof at, "%.17g", above);
    v = JSON(0, "clear", "box", "--shape", "cube", "--pose", "2 2 2.6", "--within", at);
    assert_false(jbool(v, "results.0.clear"));
    assert_string_equal(jstr(v, "results.0.object"), "box");
    jfree(v);
    r = CLI("clear", "box", "--shape", "cube", "--pose", "2 2 2.6", "--within", "0.2");
    expect_code(&r, 0);
    expect_text(r.out, "1 pose, 0 clear of everything within 0.20000000000000001");
    run_free(&r);

    /* Usage errors: nothing is asked. */
    const char *const bad[][9] = {
        {"distance", "box", NULL},
        {"distance", "box", "--point", "1", "2", NULL},
        {"distance", "box", "--point", "1", "2", "x", NULL},
        {"distance", "box", "--point", "1", "2", "3", "--within", "-1"},
        {"distance", "box", "--point", "1", "2", "3", "--shape", "cube", NULL},
        {"clear", "box", "--shape", "cube", NULL},
        {"clear", "box", "--within", "0.1", NULL},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        const char *args[10] = {0};
        for (int k = 0; k < 9 && bad[i][k]; k++)
            args[k] = bad[i][k];
        r = run_cli(NULL, args);
        expect_code(&r, 2);
        run_free(&r);
    }
}

static void test_load_and_unload(void **state)
{
    (void)state;
    jv *v = JSON(0, "load", "extra", "--mesh", "box.obj", "--effects", "rays", "--resolution", "0.5",
                 "--daemon", DAEMON);
    assert_string_equal(jstr(v, "worlds.0.name"), "extra");
    assert_string_equal(jstr(v, "worlds.0.daemon"), DAEMON);
    assert_int_equal((int)jnum(v, "worlds.0.version"), 1);
    assert_int_equal((int)jnum(v, "worlds.0.triangles"), 12);
    assert_true(jnum(v, "worlds.0.resolution") == 0.5);
    assert_int_equal(jlen(v, "worlds.0.effects"), 1);
    assert_string_equal(jstr(v, "worlds.0.effects.0"), "rays");
    jfree(v);

    v = JSON(0, "ray", "extra", "1", "3", "10", "0", "0", "-1");
    check_hit(v, 0, 0, 8, 1, 0.25, 0.5);
    jfree(v);

    /* Loading again rebuilds: version 2. Without --daemon the one daemon on the bus is
     * found with LIST. */
    v = JSON(0, "load", "extra", "--mesh", "box.obj", "--effects", "rays");
    assert_int_equal((int)jnum(v, "worlds.0.version"), 2);
    assert_string_equal(jstr(v, "worlds.0.daemon"), DAEMON);
    jfree(v);

    /* With a second daemon on the bus, which one should build is the user's to say: a
     * usage error naming both, before anything is loaded. */
    char scene2[320], log2[320];
    path_in_dir(scene2, sizeof scene2, "second.ini");
    path_in_dir(log2, sizeof log2, "second.log");
    write_text("second.ini", "[second_world]\nmesh = cube.obj\n");
    const char *extra2[] = {"--threads", "1", NULL};
    pid_t second = daemon_proc_start(daemon_bin, scene2, BUS_URL, "second", extra2, log2);
    assert_true(second > 0);
    trioct_connect_options opt = {.url = BUS_URL};
    trioct_client *c = trioct_connect(&opt, NULL, NULL, 0);
    assert_non_null(c);
    assert_int_equal(daemon_proc_wait_ready(c, "second", 20000), 0);
    trioct_disconnect(c);
    cli_run several = CLI("load", "extra", "--mesh", "box.obj");
    expect_code(&several, 2);
    expect_text(several.err, "several daemons answer on " BUS_URL);
    expect_text(several.err, "say which builds the world with --daemon NAME");
    if (strstr(several.err, DAEMON) == NULL || strstr(several.err, "second") == NULL)
        fail_msg("the error names both daemons: %s", several.err);
    run_free(&several);
    assert_int_equal(daemon_proc_stop(second, SIGTERM, 5000), 0);
    v = JSON(0, "info", "extra");
    assert_int_equal((int)jnum(v, "worlds.0.version"), 2); /* nothing was loaded */
    jfree(v);

    v = JSON(0, "unload", "extra");
    assert_string_equal(jstr(v, "status"), "OK");
    jfree(v);

    /* A load long enough to be seen (405,000 triangles) shows its progress with --progress:
     * the daemon's heartbeat (every 200 ms here) lists it with this client's LOAD. */
    char big[320];
    path_in_dir(big, sizeof big, "big.obj");
    FILE *bf = fopen(big, "w");
    assert_non_null(bf);
    enum { SIDE = 450 };
    for (int i = 0; i <= SIDE; i++)
        for (int k = 0; k <= SIDE; k++)
            fprintf(bf, "v %d %d %d\n", i, k, (i * 7 + k * 13) % 5);
    for (int i = 0; i < SIDE; i++)
        for (int k = 0; k < SIDE; k++) {
            int a = i * (SIDE + 1) + k + 1;
            fprintf(bf, "f %d %d %d\nf %d %d %d\n", a, a + 1, a + SIDE + 2, a, a + SIDE + 2, a + SIDE + 1);
        }
    assert_int_equal(fclose(bf), 0);
    cli_run shown = CLI("load", "big", "--mesh", "big.obj", "--effects", "rays", "--progress");
    expect_code(&shown, 0);
    expect_text(shown.out, "loaded big (version 1)");
    expect_text(shown.err, "trioct load: world big: ");
    expect_text(shown.err, " triangles, ");
    expect_text(shown.err, " (LOAD ");
    if (strstr(shown.err, "reading meshes") == NULL && strstr(shown.err, "building octrees") == NULL)
        fail_msg("no phase in the progress:\n%s", shown.err);
    run_free(&shown);
    v = JSON(0, "info", "big");
    assert_int_equal((int)jnum(v, "worlds.0.triangles"), 405000);
    assert_true(jnum(v, "worlds.0.load_seconds") > 0 && jnum(v, "worlds.0.build_seconds") > 0);
    jfree(v);
    v = JSON(0, "unload", "big");
    jfree(v);

    /* A mesh under a mesh_root loads by its absolute path; one outside every root does not. */
    char rooted[400];
    snprintf(rooted, sizeof rooted, "%s/box.obj", pkg_dir);
    v = JSON(0, "load", "rooted", "--mesh", rooted, "--effects", "rays");
    assert_int_equal((int)jnum(v, "worlds.0.triangles"), 12);
    jfree(v);
    v = JSON(0, "ray", "rooted", "1", "3", "10", "0", "0", "-1");
    check_hit(v, 0, 0, 8, 1, 0.25, 0.5);
    jfree(v);
    v = JSON(0, "unload", "rooted");
    jfree(v);
    char outside[400];
    path_in_dir(outside, sizeof outside, "box.obj"); /* the world directory's, but absolute */
    cli_run refused = CLI("load", "rooted", "--mesh", outside);
    expect_code(&refused, 1);
    expect_text(refused.err, "ERR_BAD_PATH");
    expect_text(refused.err, "lies outside every mesh_root");
    run_free(&refused);

    /* A change signed with another key is refused, and the refusal is logged too. */
    char other_key[320];
    path_in_dir(other_key, sizeof other_key, "other.key");
    write_text("other.key", "00112233445566778899aabbccddeeff00112233445566778899aabbccddeeff\n");
    assert_int_equal(chmod(other_key, 0600), 0);
    cli_run denied = CLI("--key-file", other_key, "unload", "box");
    expect_code(&denied, 1);
    expect_text(denied.err, "ERR_DENIED");
    run_free(&denied);

    /* The daemon's log says who changed what and how it went. */
    char *log = read_text("daemon.log");
    expect_text(log, "UNLOAD of world 'box' by client ");
    expect_text(log, "ERR_DENIED");
    expect_text(log, "LOAD of world 'extra' by client ");
    expect_text(log, "OK, version 1, 12 triangles; meshes read in ");
    expect_text(log, "OK, version 2, 12 triangles; meshes read in ");
    expect_text(log, "UNLOAD of world 'extra' by client ");
    free(log);
    cli_run r = CLI("info", "extra", "--timeout", "300");
    expect_code(&r, 3);
    run_free(&r);
}

static void test_exit_usage(void **state)
{
    (void)state;
    struct {
        const char *args[12]; /* NULL-terminated */
        const char *says;
    } cases[] = {
        {{NULL}, "no command given"},
        {{"fly"}, "unknown command 'fly'"},
        {{"ray", "box", "1", "2"}, "expected 7 arguments"},
        {{"ray", "box", "1", "2", "3", "0", "0", "x"}, "dz: 'x' is not a finite number"},
        {{"ray", "box", "1", "2", "3", "0", "0", "nan"}, "dz: 'nan' is not a finite number"},
        {{"ray", "a-b", "1", "2", "3", "0", "0", "1"}, "world name 'a-b' is not"},
        {{"worlds", "--timeout", "0"}, "--timeout: '0' is not a whole number"},
        {{"worlds", "--bogus"}, "unknown option '--bogus'"},
        {{"tri", "box", "1", "2", "3"}, "expected 10 arguments"},
        {{"mesh", "box", "cube", "--pose", "1 2"}, "expected 3, 6 or 7 numbers"},
        {{"load", "w", "--accuracy", "world"}, "is not exact, seed or fast"},
        {{"load", "w", "--effects", "sound"}, "unknown effect 'sound'"},
        {{"rays", "box", "/nonexistent/rays.csv"}, "cannot read /nonexistent/rays.csv"},
        {{"status", "--count", "-3"}, "--count: '-3'"},
    };
    /* Option combinations that exclude each other. */
    const char *any_all[] = {"ray", "box", "1", "2", "3", "0", "0", "1", "--any", "--all", NULL};
    const char *max_hits[] = {"ray", "box", "1", "2", "3", "0", "0", "1", "--max-hits", "3", NULL};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        cli_run r = run_cli(NULL, cases[i].args);
        expect_code(&r, 2);
        expect_text(r.err, cases[i].says);
        expect_text(r.err, "Try 'trioct");
        assert_string_equal(r.out, "");
        run_free(&r);
    }
    cli_run r = run_cli(NULL, any_all);
    expect_code(&r, 2);
    expect_text(r.err, "--any and --all exclude each other");
    run_free(&r);
    r = run_cli(NULL, max_hits);
    expect_code(&r, 2);
    expect_text(r.err, "--max-hits counts the hits of --all");
    run_free(&r);

    /* A bad line of a ray file is named by file and line. */
    char path[320];
    path_in_dir(path, sizeof path, "bad.csv");
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("0,0,10,0,0,-1\n# comment\n0,0,10,0,0\n", f);
    assert_int_equal(fclose(f), 0);
    r = CLI("rays", "box", path);
    expect_code(&r, 2);
    char where[400];
    snprintf(where, sizeof where, "%s:3: expected 6 numbers ox,oy,oz,dx,dy,dz: found 5", path);
    expect_text(r.err, where);
    run_free(&r);

    /* With --json, the usage error is one JSON object too. */
    jv *v = JSON(2, "ray", "box", "1");
    assert_true(jneed(v, "status", J_NULL) != NULL);
    expect_text(jstr(v, "message"), "expected 7 arguments");
    assert_string_equal(jstr(v, "command"), "ray");
    jfree(v);
}

static void test_exit_daemon_error(void **state)
{
    (void)state;
    jv *v = JSON(1, "ray", "box", "0", "0", "5", "0", "0", "0");
    assert_string_equal(jstr(v, "status"), "ERR_ZERO_DIRECTION");
    assert_int_equal((int)jnum(v, "status_code"), TRIOCT_ERR_ZERO_DIRECTION);
    assert_string_equal(jstr(v, "daemon"), DAEMON);
    expect_text(jstr(v, "message"), "direction[0]");
    jfree(v);

    v = JSON(1, "tri", "box_rays", "0", "0", "0", "1", "0", "0", "0", "1", "0");
    assert_string_equal(jstr(v, "status"), "ERR_EFFECT");
    jfree(v);

    /* The daemon's message quotes the shape: the quotes come back escaped and parse. */
    v = JSON(1, "mesh", "box", "nosuch", "--pose", "0 0 0");
    assert_string_equal(jstr(v, "status"), "ERR_UNKNOWN_SHAPE");
    expect_text(jstr(v, "message"), "\"nosuch\"");
    jfree(v);

    v = JSON(1, "load", "bad", "--mesh", "../etc/passwd", "--daemon", DAEMON);
    assert_string_equal(jstr(v, "status"), "ERR_BAD_PATH");
    jfree(v);

    cli_run r = CLI("ray", "box", "0", "0", "5", "0", "0", "0");
    expect_code(&r, 1);
    expect_text(r.err, "daemon " DAEMON " answered ERR_ZERO_DIRECTION (4, a ray direction has zero length)");
    run_free(&r);

    /* A batch that fails in its second request says which rays. */
    char path[320];
    path_in_dir(path, sizeof path, "zero.csv");
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    for (int i = 0; i < 1500; i++)
        fprintf(f, i == 1400 ? "1,1,5,0,0,0\n" : "1,1,5,0,0,-1\n");
    assert_int_equal(fclose(f), 0);
    r = CLI("rays", "box", path);
    expect_code(&r, 1);
    expect_text(r.err, "rays 1280..1499 of 1500: daemon " DAEMON " answered ERR_ZERO_DIRECTION");
    run_free(&r);
}

static void test_exit_no_reply(void **state)
{
    (void)state;
    cli_run r = CLI("ray", "nobody", "0", "0", "5", "0", "0", "-1", "--timeout", "300");
    expect_code(&r, 3);
    expect_text(r.err, "no reply from any daemon on " BUS_URL
                       " within 300 ms: is it running with this --prefix? is the multicast route set");
    expect_text(r.err, "no daemon serves world nobody");
    run_free(&r);

    /* The advice fits the transport: memq:// and file:// never reach a daemon elsewhere,
     * and say so instead of asking about multicast. */
    r = CLI("--url", "memq://", "ray", "nobody", "0", "0", "5", "0", "0", "-1", "--timeout", "300");
    expect_code(&r, 3);
    expect_text(r.err, "no reply from any daemon on memq:// within 300 ms: memq:// is a "
                       "queue inside this one process");
    if (strstr(r.err, "multicast") != NULL)
        fail_msg("memq:// advice talks of multicast: %s", r.err);
    run_free(&r);

    jv *v = JSON(3, "ray", "nobody", "0", "0", "5", "0", "0", "-1", "--timeout", "300");
    assert_string_equal(jstr(v, "status"), "ERR_NO_DAEMON");
    expect_text(jstr(v, "hint"), "is the multicast route set");
    expect_text(jstr(v, "message"), "no daemon serves world nobody");
    jfree(v);

    r = CLI("worlds", "--prefix", "NOBODY", "--timeout", "300");
    expect_code(&r, 3);
    expect_text(r.err, "no reply from any daemon on " BUS_URL " within 300 ms");
    run_free(&r);
    r = CLI("status", "--daemon", "nobody", "--timeout", "500");
    expect_code(&r, 3);
    expect_text(r.err, "no reply from any daemon");
    run_free(&r);
    r = CLI("load", "w", "--daemon", "nobody", "--timeout", "300");
    expect_code(&r, 3);
    expect_text(r.err, "no daemon named nobody");
    run_free(&r);
}

static void test_exit_transport(void **state)
{
    (void)state;
    jv *v = JSON(4, "worlds", "--url", "nosuchprovider://");
    assert_string_equal(jstr(v, "status"), "ERR_TRANSPORT");
    expect_text(jstr(v, "message"), "nosuchprovider://");
    jfree(v);
    cli_run r = CLI("--url", "nosuchprovider://", "ray", "box", "0", "0", "5", "0", "0", "-1");
    expect_code(&r, 4);
    expect_text(r.err, "ERR_TRANSPORT");
    run_free(&r);
}

/* A "daemon" for world `fake` that answers every ray request with bytes that carry the
 * right client and request ids but no valid reply. */
typedef struct fake_daemon {
    lcm_t *lcm;
    atomic_int stop;
    atomic_int answered;
} fake_daemon;

static void on_fake_request(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
    (void)channel;
    fake_daemon *f = user;
    const uint8_t *b = rbuf->data;
    /* fingerprint, client id, request id, then the reply channel (length with its NUL). */
    if (rbuf->data_size < 28)
        return;
    uint32_t len = (uint32_t)b[24] << 24 | (uint32_t)b[25] << 16 | (uint32_t)b[26] << 8 | b[27];
    if (len < 2 || len > 64 || 28 + len > rbuf->data_size)
        return;
    char reply_channel[64];
    memcpy(reply_channel, b + 28, len);
    reply_channel[len - 1] = '\0';
    uint8_t junk[48];
    memset(junk, 0xA5, sizeof junk);
    memset(junk, 0, 8);          /* a fingerprint of no type */
    memcpy(junk + 8, b + 8, 16); /* the ids, so the client takes it as its reply */
    lcm_publish(f->lcm, reply_channel, junk, sizeof junk);
    atomic_fetch_add(&f->answered, 1);
}

static void *fake_loop(void *arg)
{
    fake_daemon *f = arg;
    while (!atomic_load(&f->stop))
        lcm_handle_timeout(f->lcm, 50);
    return NULL;
}

static void test_exit_bad_reply(void **state)
{
    (void)state;
    fake_daemon f = {.lcm = lcm_create(BUS_URL)};
    assert_non_null(f.lcm);
    atomic_init(&f.stop, 0);
    atomic_init(&f.answered, 0);
    lcm_subscription_t *sub = lcm_subscribe(f.lcm, "TRIOCT_RAY_fake", on_fake_request, &f);
    assert_non_null(sub);
    pthread_t thread;
    assert_int_equal(pthread_create(&thread, NULL, fake_loop, &f), 0);

    jv *v = JSON(5, "ray", "fake", "0", "0", "5", "0", "0", "-1", "--timeout", "800");
    assert_string_equal(jstr(v, "status"), "ERR_BAD_REPLY");
    expect_text(jstr(v, "message"), "malformed");
    jfree(v);

    atomic_store(&f.stop, 1);
    pthread_join(thread, NULL);
    lcm_unsubscribe(f.lcm, sub);
    lcm_destroy(f.lcm);
    /* Junk is no answer: the command sent the request again (after 250 and 750 ms) within
     * its timeout, and every copy got junk back. */
    assert_true(atomic_load(&f.answered) >= 2);
}

/* Runs after the others: the heartbeat counts what they asked. */
static void test_status(void **state)
{
    (void)state;
    jv *v = JSON(0, "status");
    assert_string_equal(jstr(v, "command"), "status");
    assert_int_equal(jlen(v, "daemons"), 1);
    assert_string_equal(jstr(v, "daemons.0.daemon"), DAEMON);
    assert_string_equal(jstr(v, "daemons.0.state"), "ready");
    assert_int_equal((int)jnum(v, "daemons.0.threads"), 2);
    assert_true(jnum(v, "daemons.0.served.ray") >= 10);
    assert_true(jnum(v, "daemons.0.served.triangle") >= 5);
    assert_true(jnum(v, "daemons.0.served.mesh") >= 5);
    assert_true(jnum(v, "daemons.0.served.admin") >= 4);
    assert_true(jnum(v, "daemons.0.replies_by_status.ERR_ZERO_DIRECTION") >= 2);
    assert_true(jnum(v, "daemons.0.replies_by_status.ERR_EFFECT") >= 1);
    assert_true(jnum(v, "daemons.0.errors") >= 5);
    assert_true(jnum(v, "daemons.0.replies_by_status.OK") >= 20);
    assert_true(jnum(v, "daemons.0.latency_us.count") >= 0);
    assert_true(jnum(v, "daemons.0.uptime_s") > 0);
    int box = has_world(v, "daemons.0.worlds", "box");
    assert_true(box >= 0);
    char at[48];
    snprintf(at, sizeof at, "daemons.0.worlds.%d", box);
    check_box_info(v, at);
    assert_true(has_world(v, "daemons.0.worlds", "extra") < 0); /* unloaded */
    jfree(v);

    /* --count: that many heartbeats, one JSON line each. */
    cli_run r = CLI("status", "--count", "3", "--json");
    expect_code(&r, 0);
    int lines = 0;
    for (char *line = r.out, *nl; (nl = strchr(line, '\n')) != NULL; line = nl + 1, lines++) {
        char saved = nl[1];
        nl[1] = '\0';
        v = jparse_line(line);
        nl[1] = saved;
        assert_string_equal(jstr(v, "daemons.0.daemon"), DAEMON);
        jfree(v);
    }
    assert_int_equal(lines, 3);
    run_free(&r);

    r = CLI("status");
    expect_code(&r, 0);
    expect_text(r.out, "daemon " DAEMON ": ready");
    expect_text(r.out, "ERR_ZERO_DIRECTION");
    expect_text(r.out, "box_rays");
    run_free(&r);
}

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: %s TRIOCTD_BINARY TRIOCT_BINARY (inside tests/e2e/netns.sh)\n", argv[0]);
        return 2;
    }
    daemon_bin = argv[1];
    cli_bin = argv[2];
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_help_and_version),
        cmocka_unit_test(test_worlds),
        cmocka_unit_test(test_info),
        cmocka_unit_test(test_ray),
        cmocka_unit_test(test_ray_touch),
        cmocka_unit_test(test_render),
        cmocka_unit_test(test_rays_batch),
        cmocka_unit_test(test_tri),
        cmocka_unit_test(test_mesh),
        cmocka_unit_test(test_mesh_shape_file),
        cmocka_unit_test(test_load_and_unload),
        cmocka_unit_test(test_exit_usage),
        cmocka_unit_test(test_exit_daemon_error),
        cmocka_unit_test(test_exit_no_reply),
        cmocka_unit_test(test_exit_transport),
        cmocka_unit_test(test_exit_bad_reply),
        cmocka_unit_test(test_status),
        cmocka_unit_test(test_objects),
        cmocka_unit_test(test_state),
        cmocka_unit_test(test_distance),
    };
    return cmocka_run_group_tests(tests, group_setup, group_teardown);
}
