/* The worlds a daemon holds, by name. Thread-safe: workers acquire a reference to answer a
 * query while the loop thread installs a rebuilt version; the old version lives until its
 * last query releases it. */
#ifndef TRIOCT_WORLD_REGISTRY_H
#define TRIOCT_WORLD_REGISTRY_H

#include <stddef.h>

#include "world.h"

typedef struct registry registry;

typedef struct registry_entry {
    world *w;               /* one reference, released by registry_entries_free */
    char last_error[256];   /* why the last rebuild of this world failed, or "" */
} registry_entry;

registry *registry_create(void);
/* Frees the registry and releases its worlds (those still acquired live on). */
void registry_free(registry *r);

/* The world of that name with a reference the caller releases, or NULL. */
world *registry_acquire(registry *r, const char *name);

/* Installs w (taking the caller's reference) under w->spec.name, replacing and releasing
 * the version held before; sets w->version to 1 or the old version + 1 and clears the
 * entry's last error. Returns 0, or -1 when the registry already holds TRIOCT_MAX_WORLDS
 * other worlds (w is then not taken). */
int registry_install(registry *r, world *w);

/* Installs w (taking the caller's reference) in place of expected, the version it was
 * made from, as one step: 0 with w->version = expected's + 1; 1 when another version has
 * replaced expected meanwhile (w is not taken: the caller makes it again from the new
 * one); -1 when the world is no longer held (w is not taken). The entry's last error, about
 * the last rebuild, stays. */
int registry_replace(registry *r, const world *expected, world *w);

/* Removes the world; 0, or -1 when there is none of that name. */
int registry_remove(registry *r, const char *name);

/* Records why rebuilding name failed; the old version keeps serving. No-op for an unknown name. */
void registry_set_error(registry *r, const char *name, const char *message);

/* Every world, sorted by name, each with a reference: fills at most cap entries and returns
 * how many there are (possibly more than cap: free only the min(returned, cap) filled). */
size_t registry_entries(registry *r, registry_entry *out, size_t cap);
void registry_entries_free(registry_entry *entries, size_t count);

#endif
