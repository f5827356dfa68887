#include "failed_worlds.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct failed_worlds {
    pthread_mutex_t lock;
    size_t count;
    failed_world entries[TRIOCT_MAX_WORLDS];
};

failed_worlds *failed_worlds_create(void)
{
    failed_worlds *f = calloc(1, sizeof *f);
    if (f != NULL)
        pthread_mutex_init(&f->lock, NULL);
    return f;
}

void failed_worlds_free(failed_worlds *f)
{
    if (f == NULL)
        return;
    pthread_mutex_destroy(&f->lock);
    free(f);
}

static failed_world *find_locked(failed_worlds *f, const char *name)
{
    for (size_t i = 0; i < f->count; i++)
        if (strcmp(f->entries[i].name, name) == 0)
            return &f->entries[i];
    return NULL;
}

int failed_worlds_set(failed_worlds *f, const char *name, const char *source, const char *error)
{
    pthread_mutex_lock(&f->lock);
    failed_world *e = find_locked(f, name);
    if (e == NULL && f->count < TRIOCT_MAX_WORLDS)
        e = &f->entries[f->count++];
    if (e != NULL) {
        snprintf(e->name, sizeof e->name, "%s", name);
        snprintf(e->source, sizeof e->source, "%s", source);
        snprintf(e->error, sizeof e->error, "%s", error);
    }
    pthread_mutex_unlock(&f->lock);
    return e != NULL ? 0 : -1;
}

void failed_worlds_remove(failed_worlds *f, const char *name)
{
    pthread_mutex_lock(&f->lock);
    failed_world *e = find_locked(f, name);
    if (e != NULL)
        *e = f->entries[--f->count];
    pthread_mutex_unlock(&f->lock);
}

void failed_worlds_filter(failed_worlds *f, int (*keep)(const char *name, void *user), void *user)
{
    pthread_mutex_lock(&f->lock);
    for (size_t i = 0; i < f->count;) {
        if (keep(f->entries[i].name, user))
            i++;
        else
            f->entries[i] = f->entries[--f->count];
    }
    pthread_mutex_unlock(&f->lock);
}

int failed_worlds_find(failed_worlds *f, const char *name, failed_world *out)
{
    pthread_mutex_lock(&f->lock);
    failed_world *e = find_locked(f, name);
    if (e != NULL && out != NULL)
        *out = *e;
    pthread_mutex_unlock(&f->lock);
    return e != NULL;
}

size_t failed_worlds_list(failed_worlds *f, failed_world *out, size_t cap)
{
    pthread_mutex_lock(&f->lock);
    size_t n = f->count;
    for (size_t i = 0; i < n && i < cap; i++)
        out[i] = f->entries[i];
    pthread_mutex_unlock(&f->lock);
    return n;
}
