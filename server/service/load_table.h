/* The world builds under way, for the status message: each LOAD over the bus and each
 * start-up or reload build takes a slot for its world_progress while it runs. Builds run
 * on workers and status is made on the loop thread, so the table is locked and the
 * progress fields are atomic (world.h). */
#ifndef TRIOCT_SERVICE_LOAD_TABLE_H
#define TRIOCT_SERVICE_LOAD_TABLE_H

#include <pthread.h>
#include <stddef.h>
#include <stdint.h>

#include "../world/world.h"
#include "trioct_limits.h"

/* Builds reported at once: more than workers and start-up builds ever run together; one
 * past it just goes unreported. */
#define LOAD_TABLE_SLOTS TRIOCT_MAX_LOADS

typedef struct load_slot {
    int used;
    char world[TRIOCT_MAX_NAME_LEN + 1];
    int64_t client_id, request_id; /* 0, 0: a scene build */
    double started;                /* CLOCK_MONOTONIC seconds */
    world_progress progress;
} load_slot;

typedef struct load_table {
    pthread_mutex_t lock;
    load_slot slots[LOAD_TABLE_SLOTS];
} load_table;

/* What status says of one build. */
typedef struct load_entry {
    char world[TRIOCT_MAX_NAME_LEN + 1];
    int64_t client_id, request_id;
    int phase; /* world_phase */
    int files_done, files_total;
    long long triangles;
    double elapsed_seconds;
} load_entry;

void load_table_init(load_table *t);
void load_table_destroy(load_table *t);

/* A slot for a build of world: its progress, to give world_build through world_env, or
 * NULL when every slot is taken (the build runs all the same). */
world_progress *load_table_begin(load_table *t, const char *world, int64_t client_id, int64_t request_id);
/* Frees the slot of progress (NULL is fine). */
void load_table_end(load_table *t, world_progress *progress);

/* Copies up to cap builds under way into out; returns how many there are. */
size_t load_table_list(load_table *t, load_entry *out, size_t cap);

#endif
