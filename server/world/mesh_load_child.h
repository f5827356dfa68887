/* Loading a mesh file in a short-lived child process (the trioct-load program), so that a
 * hostile file can crash, exhaust or hang only the child. The daemon loads every file of a
 * bus request or a scene this way; tests and tools may still call mesh_load_file. */
#ifndef TRIOCT_WORLD_MESH_LOAD_CHILD_H
#define TRIOCT_WORLD_MESH_LOAD_CHILD_H

#include <stddef.h>

#include "mesh_data.h"
#include "mesh_load.h"

typedef struct mesh_loader {
    char program[4096];     /* the trioct-load executable */
    size_t memory_bytes;    /* the child's address space; 0: no limit */
    unsigned cpu_seconds;   /* the child's CPU time; 0: no limit */
    unsigned wall_seconds;  /* killed after this long, whatever it does; 0: no limit */
} mesh_loader;

typedef enum mesh_load_outcome {
    MESH_LOAD_OK = 0,
    MESH_LOAD_FAILED = -1,      /* the file, or the child, failed: err says which and why */
    MESH_LOAD_OVER_BUDGET = -2, /* the mesh is larger than max_mesh_bytes: err gives both */
    MESH_LOAD_NO_MEMORY = -3,   /* the daemon had no memory to receive it */
} mesh_load_outcome;

/* The limits a daemon gives its loader by default. */
#define MESH_LOADER_CPU_SECONDS 120u
#define MESH_LOADER_WALL_SECONDS 300u
#define MESH_LOADER_MAX_MEMORY ((size_t)4 << 30)
#define MESH_LOADER_MIN_MEMORY ((size_t)256 << 20)

/* The loader next to the running executable, or in ../libexec/trioct/ from it (an installed
 * tree): 0 with its path in out, or -1 with err naming both places looked in. */
int mesh_loader_find(char *out, size_t out_len, char *err, size_t err_len);

/* Runs loader->program on path and receives its mesh. The mesh the child sends may hold at
 * most max_mesh_bytes (vertex and index arrays; SIZE_MAX: any); the daemon allocates nothing
 * before that is known. A crash, a limit, a timeout or a malformed reply of the child is
 * MESH_LOAD_FAILED with err naming the file. Any thread. */
mesh_load_outcome mesh_load_child(const mesh_loader *loader, const char *path, size_t max_mesh_bytes,
                                  mesh_data *out, mesh_load_report *report, char *err, size_t err_len);

/* Reads one frame from fd as mesh_load_child reads its child's, with every check: the way
 * in for a fuzz target, which has the bytes but no child. MESH_LOAD_OK with the mesh (and
 * nothing after it), or an outcome with err. */
mesh_load_outcome mesh_load_frame_read(int fd, const char *path, size_t max_mesh_bytes, mesh_data *out,
                                       mesh_load_report *report, char *err, size_t err_len);

/* The bytes a mesh of these counts holds in a mesh_data (what max_mesh_bytes bounds), or
 * SIZE_MAX when that overflows. */
size_t mesh_data_bytes_for(size_t vertex_count, size_t triangle_count);

#endif
