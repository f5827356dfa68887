/* The daemon's half of loading in a child: start trioct-load, read its frame with a
 * deadline, check everything in it, and turn each way the child can end into a message. */
#define _GNU_SOURCE
#include "mesh_load_child.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "error_text.h"
#include "geom/vec3.h"
#include "mesh_load_frame.h"

extern char **environ;

#define LOADER_NAME "trioct-load"

size_t mesh_data_bytes_for(size_t vertex_count, size_t triangle_count)
{
    if (vertex_count > SIZE_MAX / sizeof(vec3) || triangle_count > SIZE_MAX / (3 * sizeof(uint32_t)))
        return SIZE_MAX;
    size_t v = vertex_count * sizeof(vec3), t = triangle_count * 3 * sizeof(uint32_t);
    return v > SIZE_MAX - t ? SIZE_MAX : v + t;
}

static int executable(const char *path) { return access(path, X_OK) == 0; }

int mesh_loader_find(char *out, size_t out_len, char *err, size_t err_len)
{
    char exe[4096];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n <= 0)
        return error_text(err, err_len, "cannot find the mesh loader: /proc/self/exe: %s", strerror(errno));
    exe[n] = '\0';
    char *slash = strrchr(exe, '/');
    if (slash)
        *slash = '\0';
    char beside[4096 + 32], libexec[4096 + 64];
    snprintf(beside, sizeof beside, "%s/" LOADER_NAME, exe);
    snprintf(libexec, sizeof libexec, "%s/../libexec/trioct/" LOADER_NAME, exe);
    const char *found = executable(beside) ? beside : executable(libexec) ? libexec : NULL;
    if (!found)
        return error_text(err, err_len, "cannot find the mesh loader: neither %s nor %s is an executable", beside,
                          libexec);
    if (strlen(found) >= out_len)
        return error_text(err, err_len, "the mesh loader's path %s is too long", found);
    strcpy(out, found);
    return 0;
}

static int64_t now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

typedef struct child {
    const mesh_loader *loader;
    const char *path;
    pid_t pid;
    int fd;            /* the read end of the child's stdout */
    int64_t deadline;  /* monotonic ms; INT64_MAX: none */
    int timed_out;     /* we killed it for taking too long */
    char *err;
    size_t err_len;
} child;

/* 0 when len bytes came, 1 at end of file (partial or none), -1 on a read error, -2 when
 * the deadline passed first. */
static int read_full(child *c, void *buf, size_t len)
{
    char *p = buf;
    while (len > 0) {
        int wait_ms = -1;
        if (c->deadline != INT64_MAX) {
            int64_t left = c->deadline - now_ms();
            if (left <= 0)
                return -2;
            wait_ms = left > INT_MAX ? INT_MAX : (int)left;
        }
        struct pollfd pfd = {.fd = c->fd, .events = POLLIN};
        int ready = poll(&pfd, 1, wait_ms);
        if (ready < 0 && errno == EINTR)
            continue;
        if (ready < 0)
            return -1;
        if (ready == 0)
            return -2;
        ssize_t n = read(c->fd, p, len);
        if (n < 0 && (errno == EINTR || errno == EAGAIN))
            continue;
        if (n < 0)
            return -1;
        if (n == 0)
            return 1;
        p += n;
        len -= (size_t)n;
    }
    return 0;
}

static const char *signal_name(int sig)
{
    switch (sig) {
    case SIGSEGV: return "SIGSEGV";
    case SIGBUS: return "SIGBUS";
    case SIGABRT: return "SIGABRT";
    case SIGILL: return "SIGILL";
    case SIGFPE: return "SIGFPE";
    case SIGKILL: return "SIGKILL";
    case SIGXCPU: return "SIGXCPU";
    case SIGXFSZ: return "SIGXFSZ";
    case SIGSYS: return "SIGSYS";
    default: return "a signal";
    }
}

/* Reaps the child, killing it once the deadline has passed; returns its wait status. */
static int reap(child *c)
{
    int status = 0;
    for (;;) {
        pid_t got = waitpid(c->pid, &status, WNOHANG);
        if (got == c->pid)
            return status;
        if (got < 0 && errno != EINTR)
            return 0;
        if (c->deadline != INT64_MAX && now_ms() >= c->deadline && !c->timed_out) {
            kill(c->pid, SIGKILL);
            c->timed_out = 1;
        }
        struct timespec pause = {0, 2 * 1000 * 1000};
        nanosleep(&pause, NULL);
    }
}

static void kill_and_reap(child *c, int timed_out)
{
    kill(c->pid, SIGKILL);
    c->timed_out |= timed_out;
    int status;
    while (waitpid(c->pid, &status, 0) < 0 && errno == EINTR) {
    }
}

/* Why a child that gave no usable frame ended as it did. */
static mesh_load_outcome explain_end(child *c, int status)
{
    const mesh_loader *ld = c->loader;
    if (c->timed_out)
        return error_text(c->err, c->err_len, "cannot load %s: the loader did not finish within %u s", c->path,
                          ld->wall_seconds);
    if (WIFSIGNALED(status)) {
        int sig = WTERMSIG(status);
        if (sig == SIGXCPU)
            return error_text(c->err, c->err_len, "cannot load %s: the loader used up its CPU limit of %u s",
                              c->path, ld->cpu_seconds);
        if (sig == SIGXFSZ || sig == SIGSYS)
            return error_text(c->err, c->err_len, "cannot load %s: the loader was stopped by %s for a call its "
                              "confinement forbids", c->path, signal_name(sig));
        if (sig == SIGKILL)
            return error_text(c->err, c->err_len, "cannot load %s: the loader was killed (SIGKILL)", c->path);
        return error_text(c->err, c->err_len,
                          "cannot load %s: the loader crashed (%s): the file is malformed or nested deeper than "
                          "the parser's stack holds",
                          c->path, signal_name(sig));
    }
    if (WIFEXITED(status) && WEXITSTATUS(status) != 0)
        return error_text(c->err, c->err_len, "cannot load %s: the loader exited with status %d", c->path,
                          WEXITSTATUS(status));
    return error_text(c->err, c->err_len, "cannot load %s: the loader sent no mesh", c->path);
}

static mesh_load_outcome read_error_frame(child *c, const mesh_load_frame_head *head)
{
    if (head->message_len == 0 || head->message_len > MESH_LOAD_FRAME_MAX_MESSAGE)
        return error_text(c->err, c->err_len, "cannot load %s: the loader sent a malformed reply", c->path);
    char message[MESH_LOAD_FRAME_MAX_MESSAGE + 1];
    if (read_full(c, message, (size_t)head->message_len) != 0)
        return error_text(c->err, c->err_len, "cannot load %s: the loader's error message was cut short", c->path);
    message[head->message_len] = '\0';
    for (size_t i = 0; i < head->message_len; i++)
        if ((unsigned char)message[i] < 0x20)
            message[i] = ' ';
    return error_text(c->err, c->err_len, "%s", message);
}

/* Everything a mesh from an untrusted process must satisfy before the engine sees it. */
static int mesh_is_sound(const mesh_data *mesh, const mesh_load_report *report)
{
    for (size_t i = 0; i < 3 * mesh->triangle_count; i++)
        if (mesh->indices[i] >= mesh->vertex_count)
            return 0;
    for (size_t v = 0; v < mesh->vertex_count; v++)
        if (!vec3_is_finite(mesh->vertices[v]))
            return 0;
    return report->triangles == mesh->triangle_count;
}

static mesh_load_outcome read_mesh_frame(child *c, const mesh_load_frame_head *head, size_t max_mesh_bytes,
                                         mesh_data *out)
{
    if (head->vertex_count == 0 || head->triangle_count == 0 || head->vertex_count > UINT32_MAX - 1 ||
        head->triangle_count > UINT32_MAX - 1 || head->vertex_count > 3 * head->triangle_count)
        return error_text(c->err, c->err_len, "cannot load %s: the loader sent a malformed reply", c->path);
    size_t bytes = mesh_data_bytes_for((size_t)head->vertex_count, (size_t)head->triangle_count);
    if (bytes > max_mesh_bytes) {
        error_text(c->err, c->err_len,
                   "%s: its mesh of %llu triangles needs %zu MiB, more than the %zu MiB the budget leaves", c->path,
                   (unsigned long long)head->triangle_count, (bytes + (1u << 20) - 1) >> 20, max_mesh_bytes >> 20);
        return MESH_LOAD_OVER_BUDGET;
    }
    mesh_data mesh = {0};
    mesh.vertex_count = (size_t)head->vertex_count;
    mesh.triangle_count = (size_t)head->triangle_count;
    mesh.vertices = malloc(mesh.vertex_count * sizeof *mesh.vertices);
    mesh.indices = malloc(3 * mesh.triangle_count * sizeof *mesh.indices);
    if (!mesh.vertices || !mesh.indices) {
        mesh_data_free(&mesh);
        error_text(c->err, c->err_len, "%s: no memory to receive its %zu triangles", c->path, mesh.triangle_count);
        return MESH_LOAD_NO_MEMORY;
    }
    char extra;
    if (read_full(c, mesh.vertices, mesh.vertex_count * sizeof *mesh.vertices) != 0 ||
        read_full(c, mesh.indices, 3 * mesh.triangle_count * sizeof *mesh.indices) != 0 ||
        read_full(c, &extra, 1) != 1 || !mesh_is_sound(&mesh, &head->report)) {
        mesh_data_free(&mesh);
        return error_text(c->err, c->err_len, "cannot load %s: the loader sent a malformed or incomplete mesh",
                          c->path);
    }
    *out = mesh;
    return MESH_LOAD_OK;
}

/* Whether a frame's head is one the loader writes: the magic and a kind there is. */
static int head_is_sound(const mesh_load_frame_head *head)
{
    return head->magic == MESH_LOAD_FRAME_MAGIC &&
           (head->kind == MESH_LOAD_FRAME_MESH || head->kind == MESH_LOAD_FRAME_ERROR);
}

/* What follows a sound head: the loader's error, or the mesh. */
static mesh_load_outcome read_frame_body(child *c, const mesh_load_frame_head *head, size_t max_mesh_bytes,
                                         mesh_data *out)
{
    return head->kind == MESH_LOAD_FRAME_ERROR ? read_error_frame(c, head)
                                                : read_mesh_frame(c, head, max_mesh_bytes, out);
}

mesh_load_outcome mesh_load_frame_read(int fd, const char *path, size_t max_mesh_bytes, mesh_data *out,
                                       mesh_load_report *report, char *err, size_t err_len)
{
    memset(out, 0, sizeof *out);
    if (report)
        memset(report, 0, sizeof *report);
    child c = {.path = path, .pid = -1, .fd = fd, .deadline = INT64_MAX, .err = err, .err_len = err_len};
    mesh_load_frame_head head;
    if (read_full(&c, &head, sizeof head) != 0 || !head_is_sound(&head))
        return error_text(err, err_len, "cannot load %s: the loader sent a malformed reply", path);
    mesh_load_outcome outcome = read_frame_body(&c, &head, max_mesh_bytes, out);
    if (outcome == MESH_LOAD_OK && report)
        *report = head.report;
    return outcome;
}

static int spawn(child *c)
{
    int pipe_fds[2];
    if (pipe2(pipe_fds, O_CLOEXEC) != 0)
        return error_text(c->err, c->err_len, "cannot load %s: no pipe for the loader: %s", c->path, strerror(errno));
    char memory[32], cpu[16], parent[16];
    snprintf(memory, sizeof memory, "%zu", c->loader->memory_bytes);
    snprintf(cpu, sizeof cpu, "%u", c->loader->cpu_seconds);
    snprintf(parent, sizeof parent, "%ld", (long)getpid());
    char *argv[] = {(char *)c->loader->program, "--memory", memory, "--cpu", cpu, "--parent", parent,
                    (char *)c->path, NULL};

    posix_spawn_file_actions_t actions;
    posix_spawnattr_t attr;
    posix_spawn_file_actions_init(&actions);
    posix_spawnattr_init(&attr);
    posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDOUT_FILENO);
    /* The daemon ignores SIGPIPE and blocks nothing the child should not see. */
    sigset_t none, defaults;
    sigemptyset(&none);
    sigemptyset(&defaults);
    sigaddset(&defaults, SIGPIPE);
    sigaddset(&defaults, SIGHUP);
    sigaddset(&defaults, SIGTERM);
    sigaddset(&defaults, SIGINT);
    posix_spawnattr_setsigmask(&attr, &none);
    posix_spawnattr_setsigdefault(&attr, &defaults);
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
    int rc = posix_spawn(&c->pid, c->loader->program, &actions, &attr, argv, environ);
    posix_spawn_file_actions_destroy(&actions);
    posix_spawnattr_destroy(&attr);
    close(pipe_fds[1]);
    if (rc != 0) {
        close(pipe_fds[0]);
        return error_text(c->err, c->err_len, "cannot load %s: cannot start the loader %s: %s", c->path,
                          c->loader->program, strerror(rc));
    }
    c->fd = pipe_fds[0];
    return 0;
}

mesh_load_outcome mesh_load_child(const mesh_loader *loader, const char *path, size_t max_mesh_bytes,
                                  mesh_data *out, mesh_load_report *report, char *err, size_t err_len)
{
    memset(out, 0, sizeof *out);
    if (report)
        memset(report, 0, sizeof *report);
    if (err && err_len)
        err[0] = '\0';
    child c = {.loader = loader, .path = path, .pid = -1, .fd = -1, .err = err, .err_len = err_len};
    c.deadline = loader->wall_seconds ? now_ms() + (int64_t)loader->wall_seconds * 1000 : INT64_MAX;
    if (spawn(&c) != 0)
        return MESH_LOAD_FAILED;

    mesh_load_frame_head head;
    int got = read_full(&c, &head, sizeof head);
    if (got != 0 || !head_is_sound(&head)) {
        int status = 0;
        if (got == 1)
            status = reap(&c);
        else
            kill_and_reap(&c, got == -2);
        close(c.fd);
        if (got == 0)
            return error_text(err, err_len, "cannot load %s: the loader sent a malformed reply", path);
        return explain_end(&c, status);
    }

    mesh_load_outcome outcome = read_frame_body(&c, &head, max_mesh_bytes, out);
    if (outcome != MESH_LOAD_OK) {
        kill_and_reap(&c, 0);
        close(c.fd);
        return outcome;
    }
    int status = reap(&c);
    close(c.fd);
    if (c.timed_out || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        mesh_data_free(out);
        return explain_end(&c, status);
    }
    if (report)
        *report = head.report;
    return MESH_LOAD_OK;
}
