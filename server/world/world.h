/* A world: a version of a scene section's named objects (object_set.h), each a mesh with
 * its octree at a pose, plus what its effects precompute. Immutable once built and shared
 * by reference count, so a reload or an edit can swap in a new version while queries
 * finish on the old one. */
#ifndef TRIOCT_WORLD_WORLD_H
#define TRIOCT_WORLD_WORLD_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#include "mesh_data.h"
#include "mesh_load.h"
#include "mesh_load_child.h"
#include "object_set.h"
#include "scene.h"

typedef struct world_shape {
    char name[TRIOCT_MAX_NAME_LEN + 1];
    /* The shape's mesh and its own octree in its local frame (with node bounds), built at
     * load and shared by the world's edited versions: mesh queries descend it with the
     * world's (octree_mesh_tree). */
    object_model *model;
} world_shape;

typedef struct world {
    world_spec spec;          /* what it was built from (name, effects, mode, ...) */
    uint64_t version;         /* set by registry_install: 1, then +1 per rebuild or edit */
    /* This version's objects, one reference. A section without objects is one object
     * named after the world, at the identity. */
    object_set *objects;
    /* When the world is one object at the identity pose, that object's tree: queries use
     * it directly, in every accuracy mode, with every batch path. Else NULL, and queries
     * go through the objects (exact mode). */
    const octree *tree;
    mesh_load_report report;  /* summed over the objects; bbox: their posed boxes */
    world_shape *shapes;      /* loaded only when the world serves EFFECT_MESHES or EFFECT_DISTANCE */
    size_t shape_count;
    size_t bytes_shapes;      /* the shapes' meshes and their trees */
    atomic_uint_fast64_t queries; /* requests answered on this version */
    /* How long world_build took: reading the mesh files (in the loader child), and the
     * rest, building the octrees (the world's and its shapes'). 0 for a version made by
     * an edit. */
    double load_seconds, build_seconds;
    atomic_int refs;
} world;

/* What a build in progress has done, for the daemon's status: written by the building
 * thread, read by the loop thread, so every field is atomic. */
typedef enum world_phase {
    WORLD_PHASE_QUEUED = 0,
    WORLD_PHASE_READING,  /* a mesh or shape file in the loader child */
    WORLD_PHASE_BUILDING, /* an octree */
} world_phase;

typedef struct world_progress {
    atomic_int phase;          /* world_phase */
    atomic_int files_done, files_total;
    atomic_llong triangles;    /* read so far */
} world_progress;

/* "queued", "reading meshes" or "building octrees". */
const char *world_phase_name(int phase);

/* Where a daemon's worlds get their meshes and their memory. */
typedef struct world_env {
    /* Files are parsed in this child program (mesh_load_child.h); NULL: in this process
     * (tests and tools, which trust their files). */
    const mesh_loader *loader;
    /* The daemon's memory budget: every mesh and tree of every world takes from it before
     * it is allocated and gives back when freed. NULL: none. */
    memory_account *account;
    /* Where mesh paths may lead besides the world directory (scene.h); NULL: nowhere. */
    const mesh_roots *roots;
    /* Where world_build reports how far it is (each caller its own); NULL: nowhere. */
    world_progress *progress;
} world_env;

/* Resolves rel inside world_dir: refuses an absolute path, a ".." component and, after
 * symlinks are followed, anything outside world_dir. 0 with the full path in out, or -1
 * with err. */
int world_resolve_path(const char *world_dir, const char *rel, char *out, size_t out_len,
                       char *err, size_t err_len);
/* The same, with roots (may be NULL) as further places a path may lead into: rel may be
 * absolute when it names a file inside a root, and a relative one may reach a root
 * through a symlink; what it resolves to must lie inside the world directory or a root. */
int world_resolve_path_in(const char *world_dir, const mesh_roots *roots, const char *rel, char *out,
                          size_t out_len, char *err, size_t err_len);

/* Loads the spec's meshes (and shapes, for EFFECT_MESHES and EFFECT_DISTANCE) from world_dir, applies the
 * transform and builds the octree with what the effects need, within the spec's memory
 * budget and env's account (env may be NULL). Returns the world with one reference, or
 * NULL with *status (a trioct_status: TRIOCT_ERR_BAD_PATH, TRIOCT_ERR_LOAD_FAILED,
 * TRIOCT_ERR_NOMEM, TRIOCT_ERR_BUDGET naming the budget and the need, or
 * TRIOCT_ERR_BAD_REQUEST for a spec that is itself invalid: bad name, no mesh, too many
 * meshes or shapes, empty effects) and err naming the file and, for NaN/Inf, the triangle.
 * Runs on any thread. */
world *world_build(const world_spec *spec, const char *world_dir, const world_env *env, int *status, char *err,
                   size_t err_len);

/* A new world of from's spec and shapes whose objects are from's with the edits applied,
 * all or none (object_set_apply), or NULL with *status (TRIOCT_ERR_UNKNOWN_OBJECT,
 * _OBJECT_EXISTS, _BAD_POSE, _BAD_REQUEST, _OVER_CAP, _NOMEM), *failed the index of the
 * failing edit (SIZE_MAX when the list as a whole was refused: a world not in exact
 * mode, no memory) and err naming it. Costs a copy of the object table, nothing per triangle.
 * The caller installs it (registry_replace). */
world *world_edit(const world *from, const object_edit *edits, size_t count, int *status, size_t *failed,
                  char *err, size_t err_len);

/* A model for an object added to w: the mesh file rel (inside world_dir, resolved as
 * world_build does) loaded and its tree built as the world's own are, within what w's
 * budget and env's account leave, or the model w's objects already use for that file
 * (instances share it). One reference, or NULL with *status (TRIOCT_ERR_BAD_PATH,
 * _LOAD_FAILED, _NOMEM, _BUDGET) and err. Any thread. */
object_model *world_model_from_file(const world *w, const char *world_dir, const world_env *env, const char *rel,
                                    int *status, char *err, size_t err_len);
/* The same for count inline triangles (finite, checked by the caller), keyed by the
 * object's name: never shared. */
object_model *world_model_from_triangles(const world *w, const world_env *env, const char *name,
                                         const vec3 (*tris)[3], size_t count, int *status, char *err,
                                         size_t err_len);

/* Makes m fit for a solid object added to w: its mesh checked closed and consistently
 * oriented (solid_check.h), once a model, within what w's budget and env's account leave.
 * 0, or -1 with *status TRIOCT_ERR_LOAD_FAILED and err naming the defective edge by its
 * two vertices and a triangle (label names the mesh: its file, "inline"), or
 * TRIOCT_ERR_BUDGET / _NOMEM. */
int world_model_check_solid(const world *w, const world_env *env, object_model *m, const char *label, int *status,
                            char *err, size_t err_len);

void world_retain(world *w);
/* Drops one reference; the last frees the world. */
void world_release(world *w);

const world_shape *world_find_shape(const world *w, const char *name);

/* The trees' figures for a world's info: counts and bytes summed over the objects' models,
 * each shared tree once (triangle and vertex counts: per object, as the answers see them);
 * the level, resolution and cube of the first object's tree (the world's only tree when
 * it has one); zeros for a world with no objects. */
void world_tree_info(const world *w, octree_info *out);

/* What w's meshes and trees hold, each shared model once, shapes included: what its
 * memory budget bounds. */
size_t world_memory_bytes(const world *w);

/* Worlds built and not yet freed, in the whole process: lets tests (and a leak check at
 * shutdown) see that the last release of a replaced version really freed it. */
size_t world_live_count(void);

#endif
