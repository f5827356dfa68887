/* A world: the octree over a scene section's meshes plus what its effects precompute.
 * Immutable once built and shared by reference count, so a reload can swap in a new
 * version while queries finish on the old one. */
#ifndef TRIOCT_WORLD_WORLD_H
#define TRIOCT_WORLD_WORLD_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#include "mesh_data.h"
#include "mesh_load.h"
#include "scene.h"

typedef struct world_shape {
    char name[TRIOCT_MAX_NAME_LEN + 1];
    mesh_data mesh;
    /* The shape's own octree in its local frame (with node bounds), built at load:
     * mesh queries descend it with the world's (octree_mesh_tree). */
    octree *tree;
} world_shape;

typedef struct world {
    world_spec spec;          /* what it was built from (name, effects, mode, ...) */
    uint64_t version;         /* set by registry_install: 1, then +1 per rebuild */
    octree *tree;
    mesh_load_report report;  /* summed over the meshes, after the transform */
    world_shape *shapes;      /* loaded only when the world serves EFFECT_MESHES */
    size_t shape_count;
    size_t bytes_shapes;      /* the shapes' meshes and their trees */
    atomic_uint_fast64_t queries; /* requests answered on this version */
    atomic_int refs;
} world;

/* Resolves rel inside world_dir: refuses an absolute path, a ".." component and, after
 * symlinks are followed, anything outside world_dir. 0 with the full path in out, or -1
 * with err. */
int world_resolve_path(const char *world_dir, const char *rel, char *out, size_t out_len,
                       char *err, size_t err_len);

/* Loads the spec's meshes (and shapes, for EFFECT_MESHES) from world_dir, applies the
 * transform and builds the octree with what the effects need. Returns the world with one
 * reference, or NULL with *status (a trioct_status: TRIOCT_ERR_BAD_PATH,
 * TRIOCT_ERR_LOAD_FAILED, TRIOCT_ERR_NOMEM, or TRIOCT_ERR_BAD_REQUEST for a spec that is
 * itself invalid: bad name, no mesh, too many meshes or shapes, empty effects) and err
 * naming the file and, for NaN/Inf, the triangle. Runs on any thread. */
world *world_build(const world_spec *spec, const char *world_dir, int *status, char *err,
                   size_t err_len);

void world_retain(world *w);
/* Drops one reference; the last frees the world. */
void world_release(world *w);

const world_shape *world_find_shape(const world *w, const char *name);

/* Worlds built and not yet freed, in the whole process: lets tests (and a leak check at
 * shutdown) see that the last release of a replaced version really freed it. */
size_t world_live_count(void);

#endif
