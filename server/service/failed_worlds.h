/* The scene worlds a daemon does not hold because their build failed, with why: what LIST,
 * status and every request to such a world report (version 0, TRIOCT_ERR_LOAD_FAILED with
 * the reason), until the world loads or its section leaves the scene. A held world that
 * fails to rebuild is not here: it keeps serving, its error set in the registry.
 *
 * The loop thread changes the table and workers read it, so every call takes its lock and
 * readers get copies. At most TRIOCT_MAX_WORLDS entries: a scene holds no more worlds. */
#ifndef TRIOCT_SERVICE_FAILED_WORLDS_H
#define TRIOCT_SERVICE_FAILED_WORLDS_H

#include <stddef.h>

#include "trioct_limits.h"

typedef struct failed_world {
    char name[TRIOCT_MAX_NAME_LEN + 1];
    char source[TRIOCT_MAX_PATH_LEN];
    char error[256];
} failed_world;

typedef struct failed_worlds failed_worlds;

failed_worlds *failed_worlds_create(void);
void failed_worlds_free(failed_worlds *f);

/* Records (or updates) the failure of world name. -1 when the table is full. */
int failed_worlds_set(failed_worlds *f, const char *name, const char *source, const char *error);
void failed_worlds_remove(failed_worlds *f, const char *name);
/* Removes every entry keep says no to. */
void failed_worlds_filter(failed_worlds *f, int (*keep)(const char *name, void *user), void *user);

/* 1 and a copy in *out when name failed, else 0. out may be NULL. */
int failed_worlds_find(failed_worlds *f, const char *name, failed_world *out);
/* Copies up to cap entries into out (may be NULL with cap 0); returns how many there are. */
size_t failed_worlds_list(failed_worlds *f, failed_world *out, size_t cap);

#endif
