/* The registry: a small array sorted by name under one mutex. It holds at most
 * TRIOCT_MAX_WORLDS entries, so a binary search and a memmove on install are cheaper than
 * any cleverer structure, and the lock is held only for pointer moves and a retain: the
 * free of a replaced world (an octree of maybe gigabytes) happens after unlocking. */
#include "registry.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct registry_slot {
    world *w;
    char last_error[sizeof(((registry_entry *)0)->last_error)];
} registry_slot;

struct registry {
    pthread_mutex_t lock;
    registry_slot slots[TRIOCT_MAX_WORLDS]; /* sorted by w->spec.name */
    size_t count;
};

registry *registry_create(void)
{
    registry *r = calloc(1, sizeof *r);
    if (!r)
        return NULL;
    if (pthread_mutex_init(&r->lock, NULL) != 0) {
        free(r);
        return NULL;
    }
    return r;
}

void registry_free(registry *r)
{
    if (!r)
        return;
    for (size_t i = 0; i < r->count; i++)
        world_release(r->slots[i].w);
    pthread_mutex_destroy(&r->lock);
    free(r);
}

/* The slot of name, or where it would be inserted (*found tells which). Lock held. */
static size_t find_slot(const registry *r, const char *name, int *found)
{
    size_t lo = 0, hi = r->count;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        int order = strcmp(r->slots[mid].w->spec.name, name);
        if (order == 0) {
            *found = 1;
            return mid;
        }
        if (order < 0)
            lo = mid + 1;
        else
            hi = mid;
    }
    *found = 0;
    return lo;
}

world *registry_acquire(registry *r, const char *name)
{
    if (!r || !name)
        return NULL;
    world *w = NULL;
    int found;
    pthread_mutex_lock(&r->lock);
    size_t at = find_slot(r, name, &found);
    if (found) {
        w = r->slots[at].w;
        world_retain(w);
    }
    pthread_mutex_unlock(&r->lock);
    return w;
}

int registry_install(registry *r, world *w)
{
    if (!r || !w)
        return -1;
    world *old = NULL;
    int found, status = 0;
    pthread_mutex_lock(&r->lock);
    size_t at = find_slot(r, w->spec.name, &found);
    if (found) {
        old = r->slots[at].w;
        w->version = old->version + 1;
        r->slots[at].w = w;
        r->slots[at].last_error[0] = '\0';
    } else if (r->count >= TRIOCT_MAX_WORLDS) {
        status = -1;
    } else {
        memmove(&r->slots[at + 1], &r->slots[at], (r->count - at) * sizeof r->slots[0]);
        w->version = 1;
        r->slots[at].w = w;
        r->slots[at].last_error[0] = '\0';
        r->count++;
    }
    pthread_mutex_unlock(&r->lock);
    world_release(old);
    return status;
}

int registry_replace(registry *r, const world *expected, world *w)
{
    if (!r || !w || !expected)
        return -1;
    world *old = NULL;
    int found, status;
    pthread_mutex_lock(&r->lock);
    size_t at = find_slot(r, w->spec.name, &found);
    if (!found) {
        status = -1;
    } else if (r->slots[at].w != expected) {
        status = 1;
    } else {
        old = r->slots[at].w;
        w->version = old->version + 1;
        r->slots[at].w = w;
        status = 0;
    }
    pthread_mutex_unlock(&r->lock);
    world_release(old);
    return status;
}

int registry_remove(registry *r, const char *name)
{
    if (!r || !name)
        return -1;
    world *old = NULL;
    int found;
    pthread_mutex_lock(&r->lock);
    size_t at = find_slot(r, name, &found);
    if (found) {
        old = r->slots[at].w;
        memmove(&r->slots[at], &r->slots[at + 1], (r->count - at - 1) * sizeof r->slots[0]);
        r->count--;
    }
    pthread_mutex_unlock(&r->lock);
    world_release(old);
    return found ? 0 : -1;
}

void registry_set_error(registry *r, const char *name, const char *message)
{
    if (!r || !name)
        return;
    int found;
    pthread_mutex_lock(&r->lock);
    size_t at = find_slot(r, name, &found);
    if (found)
        snprintf(r->slots[at].last_error, sizeof r->slots[at].last_error, "%s", message ? message : "");
    pthread_mutex_unlock(&r->lock);
}

size_t registry_entries(registry *r, registry_entry *out, size_t cap)
{
    if (!r)
        return 0;
    pthread_mutex_lock(&r->lock);
    size_t count = r->count;
    for (size_t i = 0; i < count && i < cap && out; i++) {
        out[i].w = r->slots[i].w;
        world_retain(out[i].w);
        memcpy(out[i].last_error, r->slots[i].last_error, sizeof out[i].last_error);
    }
    pthread_mutex_unlock(&r->lock);
    return count;
}

void registry_entries_free(registry_entry *entries, size_t count)
{
    for (size_t i = 0; entries && i < count; i++) {
        world_release(entries[i].w);
        entries[i].w = NULL;
    }
}
