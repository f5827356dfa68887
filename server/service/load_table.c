#include "load_table.h"

#include <stdio.h>
#include <string.h>
#include <time.h>

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec / 1e9;
}

void load_table_init(load_table *t)
{
    memset(t, 0, sizeof *t);
    pthread_mutex_init(&t->lock, NULL);
}

void load_table_destroy(load_table *t)
{
    pthread_mutex_destroy(&t->lock);
}

world_progress *load_table_begin(load_table *t, const char *world, int64_t client_id, int64_t request_id)
{
    world_progress *p = NULL;
    pthread_mutex_lock(&t->lock);
    for (size_t i = 0; i < LOAD_TABLE_SLOTS && p == NULL; i++) {
        load_slot *s = &t->slots[i];
        if (s->used)
            continue;
        s->used = 1;
        snprintf(s->world, sizeof s->world, "%s", world);
        s->client_id = client_id;
        s->request_id = request_id;
        s->started = now_seconds();
        atomic_init(&s->progress.phase, WORLD_PHASE_QUEUED);
        atomic_init(&s->progress.files_done, 0);
        atomic_init(&s->progress.files_total, 0);
        atomic_init(&s->progress.triangles, 0);
        p = &s->progress;
    }
    pthread_mutex_unlock(&t->lock);
    return p;
}

void load_table_end(load_table *t, world_progress *progress)
{
    if (progress == NULL)
        return;
    pthread_mutex_lock(&t->lock);
    for (size_t i = 0; i < LOAD_TABLE_SLOTS; i++)
        if (&t->slots[i].progress == progress)
            t->slots[i].used = 0;
    pthread_mutex_unlock(&t->lock);
}

size_t load_table_list(load_table *t, load_entry *out, size_t cap)
{
    size_t n = 0;
    double now = now_seconds();
    pthread_mutex_lock(&t->lock);
    for (size_t i = 0; i < LOAD_TABLE_SLOTS; i++) {
        const load_slot *s = &t->slots[i];
        if (!s->used)
            continue;
        if (n < cap) {
            load_entry *e = &out[n];
            memcpy(e->world, s->world, sizeof e->world);
            e->client_id = s->client_id;
            e->request_id = s->request_id;
            e->phase = atomic_load(&s->progress.phase);
            e->files_done = atomic_load(&s->progress.files_done);
            e->files_total = atomic_load(&s->progress.files_total);
            e->triangles = atomic_load(&s->progress.triangles);
            e->elapsed_seconds = now - s->started;
        }
        n++;
    }
    pthread_mutex_unlock(&t->lock);
    return n;
}
