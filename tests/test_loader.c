/* Tests for loading in a child process (world/mesh_load_child.h, server/loader/): the mesh
 * that comes back is the one an in-process load gives, and every way a hostile file or a
 * broken child can end (a crash on a deep file, a header that lies about its size, a
 * timeout, a CPU limit, garbage, out-of-range indices, NaN) is an error naming the file,
 * never a crash or an unbounded allocation here.
 *
 * The broken children are this test program itself, started with TRIOCT_FAKE_LOADER set. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "loader/loader_confine.h"
#include "support/daemon_proc.h"
#include "support/hostile_files.h"
#include "world/mesh_load.h"
#include "world/mesh_load_child.h"
#include "world/mesh_load_frame.h"

#define MODELS "/usr/share/assimp/models"

static char self_path[PATH_MAX];
static char loader_path[PATH_MAX];
static char tmp_dir[] = "/tmp/trioct-loader-XXXXXX";

/* ---------- the fake loaders ---------- */

static void write_all(const void *data, size_t len)
{
    const char *p = data;
    while (len > 0) {
        ssize_t n = write(STDOUT_FILENO, p, len);
        if (n <= 0)
            _exit(1);
        p += n;
        len -= (size_t)n;
    }
}

/* One triangle, with whatever the mode breaks in it. */
static void send_triangle(int bad_index, int nan)
{
    mesh_load_frame_head head;
    memset(&head, 0, sizeof head);
    head.magic = MESH_LOAD_FRAME_MAGIC;
    head.kind = MESH_LOAD_FRAME_MESH;
    head.vertex_count = 3;
    head.triangle_count = 1;
    head.report.triangles = 1;
    head.report.meshes = 1;
    vec3 v[3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    if (nan)
        v[1].y = NAN;
    uint32_t idx[3] = {0, 1, bad_index ? 3u : 2u};
    write_all(&head, sizeof head);
    write_all(v, sizeof v);
    write_all(idx, sizeof idx);
}

/* What the confinement refuses, each reported as an error frame naming what happened. */
static void probe_confinement(void)
{
    char report[512];
    signal(SIGXFSZ, SIG_IGN); /* a write past the limit then fails with EFBIG instead */
    int sock = socket(AF_INET, SOCK_DGRAM, 0);
    int sock_errno = errno;
    pid_t pid = fork();
    int fork_errno = errno;
    if (pid == 0)
        _exit(0);
    errno = 0;
    FILE *f = fopen("/tmp/trioct-loader-probe-write", "w");
    size_t wrote = 0;
    if (f) {
        wrote = fwrite("x", 1, 1, f);
        wrote = fflush(f) == 0 ? wrote : 0;
        fclose(f);
        unlink("/tmp/trioct-loader-probe-write");
    }
    struct rlimit cpu, core, nofile;
    getrlimit(RLIMIT_CPU, &cpu);
    getrlimit(RLIMIT_CORE, &core);
    getrlimit(RLIMIT_NOFILE, &nofile);
    snprintf(report, sizeof report, "/some/file.obj: socket %d errno %d, fork %d errno %d, wrote %zu, cpu %llu core %llu nofile %llu",
             sock, sock_errno, (int)pid, fork_errno, wrote, (unsigned long long)cpu.rlim_cur,
             (unsigned long long)core.rlim_cur, (unsigned long long)nofile.rlim_cur);
    mesh_load_frame_head head;
    memset(&head, 0, sizeof head);
    head.magic = MESH_LOAD_FRAME_MAGIC;
    head.kind = MESH_LOAD_FRAME_ERROR;
    head.message_len = strlen(report);
    write_all(&head, sizeof head);
    write_all(report, strlen(report));
}

/* Takes the real loader's command line and confines itself as the loader does. */
static int run_fake_loader(const char *mode, int argc, char **argv)
{
    unsigned long long memory = 0, cpu = 0, parent = 0;
    for (int i = 1; i + 1 < argc; i++) {
        if (strcmp(argv[i], "--memory") == 0)
            memory = strtoull(argv[i + 1], NULL, 10);
        else if (strcmp(argv[i], "--cpu") == 0)
            cpu = strtoull(argv[i + 1], NULL, 10);
        else if (strcmp(argv[i], "--parent") == 0)
            parent = strtoull(argv[i + 1], NULL, 10);
    }
    char err[256];
    if (loader_confine(memory, (unsigned)cpu, (long)parent, err, sizeof err) != 0) {
        fprintf(stderr, "fake loader: %s\n", err);
        return 1;
    }
    if (strcmp(mode, "probe") == 0) {
        probe_confinement();
    } else if (strcmp(mode, "sleep") == 0) {
        sleep(60);
    } else if (strcmp(mode, "spin") == 0) {
        for (volatile unsigned long i = 0;; i++) {
        }
    } else if (strcmp(mode, "garbage") == 0) {
        write_all("this is not a frame at all, not even close to one: 0123456789abcdef0123456789abcdef"
                  "0123456789abcdef0123456789abcdef0123456789abcdef", 130);
    } else if (strcmp(mode, "short") == 0) {
        write_all("TLD", 3);
    } else if (strcmp(mode, "bad-index") == 0) {
        send_triangle(1, 0);
    } else if (strcmp(mode, "nan") == 0) {
        send_triangle(0, 1);
    } else if (strcmp(mode, "good-then-exit-3") == 0) {
        send_triangle(0, 0);
        return 3;
    } else if (strcmp(mode, "huge") == 0) {
        /* Claims a mesh far past any budget and then sends nothing. */
        mesh_load_frame_head head;
        memset(&head, 0, sizeof head);
        head.magic = MESH_LOAD_FRAME_MAGIC;
        head.kind = MESH_LOAD_FRAME_MESH;
        head.vertex_count = 1000000000;
        head.triangle_count = 2000000000;
        head.report.triangles = head.triangle_count;
        write_all(&head, sizeof head);
        sleep(60);
    } else if (strcmp(mode, "crash") == 0) {
        abort();
    }
    return 0;
}

/* ---------- helpers ---------- */

typedef struct loaded {
    mesh_load_outcome outcome;
    mesh_data mesh;
    mesh_load_report report;
    char err[512];
} loaded;

static mesh_loader real_loader(void)
{
    mesh_loader ld = {.memory_bytes = (size_t)1 << 30, .cpu_seconds = 20, .wall_seconds = 60};
    strcpy(ld.program, loader_path);
    return ld;
}

static loaded load_with(const mesh_loader *ld, const char *path, size_t max_bytes)
{
    loaded l;
    memset(&l, 0, sizeof l);
    l.outcome = mesh_load_child(ld, path, max_bytes, &l.mesh, &l.report, l.err, sizeof l.err);
    return l;
}

static loaded load_fake(const char *mode, unsigned cpu, unsigned wall)
{
    mesh_loader ld = {.cpu_seconds = cpu, .wall_seconds = wall};
    strcpy(ld.program, self_path);
    setenv("TRIOCT_FAKE_LOADER", mode, 1);
    loaded l = load_with(&ld, "/some/file.obj", SIZE_MAX);
    unsetenv("TRIOCT_FAKE_LOADER");
    return l;
}

static void expect_failure(loaded *l, const char *path, const char *words)
{
    if (l->outcome != MESH_LOAD_FAILED || !strstr(l->err, path) || (words && !strstr(l->err, words)))
        print_error("outcome %d, message: %s\n", l->outcome, l->err);
    assert_int_equal(l->outcome, MESH_LOAD_FAILED);
    assert_non_null(strstr(l->err, path));
    if (words)
        assert_non_null(strstr(l->err, words));
    assert_null(l->mesh.vertices);
    assert_null(l->mesh.indices);
}

/* ---------- tests ---------- */

/* The child's mesh is the in-process load's, vertex for vertex and index for index. */
static void test_child_mesh_equals_in_process(void **state)
{
    (void)state;
    const char *files[] = {MODELS "/PLY/Wuson.ply", MODELS "/OBJ/box.obj", MODELS "/STL/Spider_ascii.stl"};
    mesh_loader ld = real_loader();
    for (size_t f = 0; f < sizeof files / sizeof files[0]; f++) {
        mesh_data direct;
        mesh_load_report direct_report;
        char err[512];
        assert_int_equal(mesh_load_file(files[f], &direct, &direct_report, err, sizeof err), 0);
        loaded l = load_with(&ld, files[f], SIZE_MAX);
        if (l.outcome != MESH_LOAD_OK)
            print_error("%s: %s\n", files[f], l.err);
        assert_int_equal(l.outcome, MESH_LOAD_OK);
        assert_int_equal(l.mesh.vertex_count, direct.vertex_count);
        assert_int_equal(l.mesh.triangle_count, direct.triangle_count);
        assert_memory_equal(l.mesh.vertices, direct.vertices, direct.vertex_count * sizeof *direct.vertices);
        assert_memory_equal(l.mesh.indices, direct.indices, 3 * direct.triangle_count * sizeof *direct.indices);
        assert_memory_equal(&l.report, &direct_report, sizeof direct_report);
        mesh_data_free(&l.mesh);
        mesh_data_free(&direct);
    }
}

/* The parser's own error comes back as it is. */
static void test_child_passes_parser_errors(void **state)
{
    (void)state;
    mesh_loader ld = real_loader();
    loaded l = load_with(&ld, "/nonexistent/mesh.obj", SIZE_MAX);
    expect_failure(&l, "/nonexistent/mesh.obj", "No such file");
    char fifo[PATH_MAX];
    snprintf(fifo, sizeof fifo, "%s/pipe.obj", tmp_dir);
    assert_int_equal(mkfifo(fifo, 0600), 0);
    l = load_with(&ld, fifo, SIZE_MAX);
    expect_failure(&l, fifo, "FIFO");
    unlink(fifo);
}

/* 100,000 nested COLLADA nodes overflow assimp's recursion: the child dies of it, not us. */
static void test_deep_collada_crashes_only_the_child(void **state)
{
    (void)state;
    char path[PATH_MAX];
    snprintf(path, sizeof path, "%s/deep.dae", tmp_dir);
    assert_int_equal(hostile_write_deep_collada(path, 100000), 0);
    mesh_loader ld = real_loader();
    loaded l = load_with(&ld, path, SIZE_MAX);
    expect_failure(&l, path, NULL);
    /* The sanitizer build reports the overflow itself and exits; the plain one is killed. */
    assert_true(strstr(l.err, "crashed (SIGSEGV)") || strstr(l.err, "exited with status"));
    /* And the next load works. */
    l = load_with(&ld, MODELS "/OBJ/box.obj", SIZE_MAX);
    assert_int_equal(l.outcome, MESH_LOAD_OK);
    mesh_data_free(&l.mesh);
    unlink(path);
}

/* A 177-byte PLY header claiming 268 million vertices: the child's address-space limit
 * stops the parser's allocation; nothing of it reaches this process. */
static void test_lying_ply_stays_in_its_limit(void **state)
{
    (void)state;
    char path[PATH_MAX];
    snprintf(path, sizeof path, "%s/lying.ply", tmp_dir);
    assert_int_equal(hostile_write_lying_ply(path), 0);
    mesh_loader ld = real_loader();
    ld.memory_bytes = (size_t)512 << 20;
    loaded l = load_with(&ld, path, SIZE_MAX);
    expect_failure(&l, path, NULL);
    unlink(path);
}

/* The budget is checked on the counts in the head, before anything is allocated. */
static void test_mesh_over_budget_is_refused_before_allocation(void **state)
{
    (void)state;
    mesh_loader ld = real_loader();
    loaded l = load_with(&ld, MODELS "/PLY/Wuson.ply", 10000);
    assert_int_equal(l.outcome, MESH_LOAD_OVER_BUDGET);
    assert_non_null(strstr(l.err, "Wuson.ply"));
    assert_non_null(strstr(l.err, "budget"));
    assert_null(l.mesh.vertices);

    /* A child claiming 2e9 triangles and sending none: refused on its head at once,
     * long before its wall-clock limit. */
    mesh_loader ld_fake = {.wall_seconds = 30};
    strcpy(ld_fake.program, self_path);
    setenv("TRIOCT_FAKE_LOADER", "huge", 1);
    time_t start = time(NULL);
    loaded huge = load_with(&ld_fake, "/some/file.obj", (size_t)1 << 30);
    unsetenv("TRIOCT_FAKE_LOADER");
    assert_int_equal(huge.outcome, MESH_LOAD_OVER_BUDGET);
    assert_non_null(strstr(huge.err, "2000000000 triangles"));
    assert_true(time(NULL) - start < 10);
}

static void test_broken_children(void **state)
{
    (void)state;
    loaded l = load_fake("garbage", 0, 30);
    expect_failure(&l, "/some/file.obj", "malformed");
    l = load_fake("short", 0, 30);
    expect_failure(&l, "/some/file.obj", "sent no mesh");
    l = load_fake("bad-index", 0, 30);
    expect_failure(&l, "/some/file.obj", "malformed or incomplete mesh");
    l = load_fake("nan", 0, 30);
    expect_failure(&l, "/some/file.obj", "malformed or incomplete mesh");
    l = load_fake("good-then-exit-3", 0, 30);
    expect_failure(&l, "/some/file.obj", "exited with status 3");
    l = load_fake("crash", 0, 30);
    expect_failure(&l, "/some/file.obj", "crashed (SIGABRT)");

    mesh_loader missing = {.wall_seconds = 5};
    snprintf(missing.program, sizeof missing.program, "%s/no-such-loader", tmp_dir);
    l = load_with(&missing, "/some/file.obj", SIZE_MAX);
    expect_failure(&l, "/some/file.obj", "cannot start the loader");
}

/* The confinement as a child sees it: no socket, no fork, no file written, the limits set. */
static void test_loader_confinement(void **state)
{
    (void)state;
    loaded l = load_fake("probe", 7, 30);
    assert_int_equal(l.outcome, MESH_LOAD_FAILED);
    print_message("%s\n", l.err);
    char expected[256];
    snprintf(expected, sizeof expected, "socket -1 errno %d, fork -1 errno %d, wrote 0, cpu 7 core 0 nofile 64", EACCES,
             EACCES);
    assert_non_null(strstr(l.err, expected));
}

static void test_hung_and_spinning_children_are_stopped(void **state)
{
    (void)state;
    loaded l = load_fake("sleep", 0, 1);
    expect_failure(&l, "/some/file.obj", "did not finish within 1 s");
    l = load_fake("spin", 1, 30);
    expect_failure(&l, "/some/file.obj", "CPU limit of 1 s");
}

/* This program lives in build/tests, where no loader is: the search names both places. */
static void test_loader_search_names_where_it_looked(void **state)
{
    (void)state;
    char found[PATH_MAX], err[1024], dir[PATH_MAX], beside[PATH_MAX + 32], libexec[PATH_MAX + 64];
    snprintf(dir, sizeof dir, "%s", self_path);
    *strrchr(dir, '/') = '\0';
    snprintf(beside, sizeof beside, "%s/trioct-load", dir);
    snprintf(libexec, sizeof libexec, "%s/../libexec/trioct/trioct-load", dir);
    assert_int_equal(mesh_loader_find(found, sizeof found, err, sizeof err), -1);
    assert_non_null(strstr(err, beside));
    assert_non_null(strstr(err, libexec));
}

int main(int argc, char **argv)
{
    const char *fake = getenv("TRIOCT_FAKE_LOADER");
    if (fake)
        return run_fake_loader(fake, argc, argv);
    ssize_t n = readlink("/proc/self/exe", self_path, sizeof self_path - 1);
    if (n <= 0)
        return 1;
    self_path[n] = '\0';
    snprintf(loader_path, sizeof loader_path, "%s", daemon_proc_loader());
    if (access(loader_path, X_OK) != 0) {
        fprintf(stderr, "%s: the loader %s is missing (make all builds it)\n", argv[0], loader_path);
        return 1;
    }
    if (!mkdtemp(tmp_dir))
        return 1;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_child_mesh_equals_in_process),
        cmocka_unit_test(test_child_passes_parser_errors),
        cmocka_unit_test(test_deep_collada_crashes_only_the_child),
        cmocka_unit_test(test_lying_ply_stays_in_its_limit),
        cmocka_unit_test(test_mesh_over_budget_is_refused_before_allocation),
        cmocka_unit_test(test_broken_children),
        cmocka_unit_test(test_loader_confinement),
        cmocka_unit_test(test_hung_and_spinning_children_are_stopped),
        cmocka_unit_test(test_loader_search_names_where_it_looked),
    };
    int failed = cmocka_run_group_tests(tests, NULL, NULL);
    rmdir(tmp_dir);
    return failed;
}
