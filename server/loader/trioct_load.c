/* trioct-load: parses one mesh file in a process of its own and writes the welded mesh to
 * stdout (mesh_load_frame.h). trioctd starts one per file it loads, so a file that crashes,
 * exhausts or hangs the parser (assimp, fed files a bus request names) takes down this
 * short-lived process and never the daemon.
 *
 *   trioct-load [--memory BYTES] [--cpu SECONDS] [--parent PID] FILE
 *
 * Before the file is opened the process confines itself: every inherited descriptor past
 * stdout and stderr closed, limits on address space, CPU time, stack, open files and file
 * size, no core dumps, no new privileges, and a system-call filter that refuses sockets
 * and exec. Exit 0 when a frame was written (a mesh or an error message), 1 when not even
 * that was possible, 2 for a bad command line. */
#define _GNU_SOURCE
#include <errno.h>
#include <limits.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "loader/loader_confine.h"
#include "world/mesh_load.h"
#include "world/mesh_load_frame.h"

static int write_all(const void *data, size_t len)
{
    const char *p = data;
    while (len > 0) {
        ssize_t n = write(STDOUT_FILENO, p, len);
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0)
            return -1;
        p += n;
        len -= (size_t)n;
    }
    return 0;
}

static int send_error(const char *message)
{
    mesh_load_frame_head head;
    memset(&head, 0, sizeof head);
    head.magic = MESH_LOAD_FRAME_MAGIC;
    head.kind = MESH_LOAD_FRAME_ERROR;
    size_t len = strlen(message);
    if (len > MESH_LOAD_FRAME_MAX_MESSAGE)
        len = MESH_LOAD_FRAME_MAX_MESSAGE;
    head.message_len = len;
    return write_all(&head, sizeof head) == 0 && write_all(message, len) == 0 ? 0 : -1;
}

static int send_mesh(const mesh_data *mesh, const mesh_load_report *report)
{
    mesh_load_frame_head head;
    memset(&head, 0, sizeof head);
    head.magic = MESH_LOAD_FRAME_MAGIC;
    head.kind = MESH_LOAD_FRAME_MESH;
    head.vertex_count = mesh->vertex_count;
    head.triangle_count = mesh->triangle_count;
    head.report = *report;
    if (write_all(&head, sizeof head) != 0)
        return -1;
    if (write_all(mesh->vertices, mesh->vertex_count * sizeof *mesh->vertices) != 0)
        return -1;
    return write_all(mesh->indices, 3 * mesh->triangle_count * sizeof *mesh->indices);
}

static int parse_number(const char *text, unsigned long long *out)
{
    if (!text || !*text || *text == '-')
        return -1;
    char *end = NULL;
    errno = 0;
    unsigned long long v = strtoull(text, &end, 10);
    if (errno != 0 || *end != '\0')
        return -1;
    *out = v;
    return 0;
}

static int usage(void)
{
    fprintf(stderr, "usage: trioct-load [--memory BYTES] [--cpu SECONDS] [--parent PID] FILE\n");
    return 2;
}

/* The parser reports running out of memory as an exception's text; say which limit it hit. */
static void explain_out_of_memory(char *err, size_t err_len, const char *path, unsigned long long memory)
{
    if (memory == 0 || (!strstr(err, "bad_alloc") && !strstr(err, "out of memory")))
        return;
    snprintf(err, err_len, "cannot load %s: parsing it needs more than the loader's memory limit of %llu MiB",
             path, memory >> 20);
}

int main(int argc, char **argv)
{
    unsigned long long memory = 0, cpu = 0, parent = 0;
    const char *path = NULL;
    for (int i = 1; i < argc; i++) {
        unsigned long long *value = NULL;
        if (strcmp(argv[i], "--memory") == 0)
            value = &memory;
        else if (strcmp(argv[i], "--cpu") == 0)
            value = &cpu;
        else if (strcmp(argv[i], "--parent") == 0)
            value = &parent;
        else if (argv[i][0] == '-' || path)
            return usage();
        else {
            path = argv[i];
            continue;
        }
        if (i + 1 >= argc || parse_number(argv[++i], value) != 0 || (value == &cpu && cpu > UINT_MAX) ||
            (value == &parent && parent > INT_MAX))
            return usage();
    }
    if (!path)
        return usage();

    char err[MESH_LOAD_FRAME_MAX_MESSAGE];
    if (loader_confine(memory, (unsigned)cpu, (long)parent, err, sizeof err) != 0)
        return send_error(err) == 0 ? 0 : 1;

    mesh_data mesh;
    mesh_load_report report;
    if (mesh_load_file(path, &mesh, &report, err, sizeof err) != 0) {
        explain_out_of_memory(err, sizeof err, path, memory);
        return send_error(err) == 0 ? 0 : 1;
    }
    int rc = send_mesh(&mesh, &report) == 0 ? 0 : 1;
    mesh_data_free(&mesh);
    return rc;
}
