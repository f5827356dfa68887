/* Scene files: INI (parsed with inih) with a [daemon] section and one section per world.
 *
 *   [daemon]                 ; options of trioctd, applied by server/service/options.c
 *   prefix = TRIOCT
 *   world_dir = worlds
 *
 *   [warehouse]              ; a world; the section name is the world's name ([A-Za-z0-9_])
 *   mesh = shelves.obj       ; one or more (repeat the key), relative to the world directory
 *   mesh = floor.stl
 *   scale = 0.001            ; optional transform: p' = R(rotate) (scale p) + translate
 *   rotate = 0 0 90          ; degrees about x, then y, then z (fixed axes)
 *   translate = 0 0 1.5
 *   up = y                   ; the files are Y-up (glTF, COLLADA often): turned to z-up as read
 *   resolution = auto        ; or a length (the leaf side d)
 *   max_depth = 16
 *   accuracy = exact         ; exact | seed | fast
 *   seed_epsilon = 1e-9      ; seed only
 *   effects = rays triangles meshes distance  ; what the world serves, any of the four
 *   shape.gripper = gripper.stl      ; query shapes for mesh queries (meshes effect)
 *   solid = yes              ; yes | no (default): the mesh (or every object) is a closed
 *                            ; solid whose inside counts as contact; solid.NAME overrides
 *                            ; it for object NAME
 *
 * Keys may be indented; a value never continues on the next line, and a line holds at
 * most 197 characters (inih's fixed line buffer). mesh and shape.<name> repeat (at most
 * SCENE_MAX_MESHES and TRIOCT_MAX_SHAPES, shape names unique); every other world key is
 * given at most once. scale > 0; resolution "auto" or > 0; max_depth 0..21; seed_epsilon
 * >= 0. A rotation by a multiple of 90 degrees is exact (entries 0, 1, -1).
 */
#ifndef TRIOCT_WORLD_SCENE_H
#define TRIOCT_WORLD_SCENE_H

#include <stddef.h>

#include "../../common/trioct_limits.h"
#include "../engine.h"

#define SCENE_MAX_MESHES 16

/* What a world serves. Queries of an effect a world does not serve are refused, and the
 * world precomputes nothing for it. Bits equal world_info_t's EFFECT_* constants. */
enum {
    EFFECT_RAYS = 1,
    EFFECT_TRIANGLES = 2,
    EFFECT_MESHES = 4,
    EFFECT_DISTANCE = 8,
    EFFECT_ALL = 15,
};

/* The text of an effects mask ("rays triangles"); buf of at least 32 bytes. */
const char *effects_text(unsigned effects, char *buf, size_t len);
/* Parses "rays triangles meshes distance" (spaces or commas); 0, or -1 naming the bad word in err. */
int effects_parse(const char *text, unsigned *effects, char *err, size_t err_len);
/* "exact" | "seed" | "fast"; 0 or -1. */
int accuracy_parse(const char *text, accuracy_mode *mode);

typedef struct world_transform {
    double scale;  /* 1 when absent */
    double r[9];   /* row-major rotation; identity when absent */
    vec3 t;
    int identity;  /* 1 when the transform changes nothing */
} world_transform;

typedef struct world_shape_spec {
    char name[TRIOCT_MAX_NAME_LEN + 1];
    char path[TRIOCT_MAX_PATH_LEN];
} world_shape_spec;

/* Objects a scene section may place (object.NAME = mesh, pose.NAME = x y z qw qx qy qz). */
#define SCENE_MAX_OBJECTS 64

/* One placed object: a mesh of the world's list (objects of one file share it) at a pose,
 * p' = fl(R p + t) as octree_pose_point computes it; identity when no pose is given. */
typedef struct world_object_spec {
    char name[TRIOCT_MAX_NAME_LEN + 1];
    int mesh; /* index into world_spec.meshes */
    pose at;
    int solid; /* solid.NAME: 1 yes, 0 no, -1 not given (the section's solid applies) */
} world_object_spec;

/* One world, as a scene section or an admin LOAD request describes it. Plain data: copy by
 * assignment, compare with world_spec_equal. */
typedef struct world_spec {
    char name[TRIOCT_MAX_NAME_LEN + 1];
    char source[TRIOCT_MAX_PATH_LEN];        /* "scene.ini [name]" or the mesh path */
    char meshes[SCENE_MAX_MESHES][TRIOCT_MAX_PATH_LEN]; /* relative to the world directory */
    size_t mesh_count;
    world_shape_spec shapes[TRIOCT_MAX_SHAPES];
    size_t shape_count;
    /* With objects the world is their posed meshes, in name order; without, the meshes
     * under the transform, as one object. A section has one or the other. */
    world_object_spec objects[SCENE_MAX_OBJECTS];
    size_t object_count;
    world_transform transform;
    /* up = y: every file of the section (meshes, objects, shapes) is Y-up, and each vertex
     * is turned to trioct's z-up as it is read, (x, y, z) -> (x, -z, y): a quarter turn
     * about x, exact. Then the transform or the object's pose applies. 0: z-up as given. */
    int up_y;
    /* solid = yes: the section's mesh, or each of its objects without a solid.NAME of its
     * own, is a solid: checked closed and oriented at load (solid_check.h), and its inside
     * counts as contact (docs/engine.md, "Solid objects"). 0: surfaces only. */
    int solid;
    octree_def def;      /* resolution (<= 0: heuristic), max_depth, mode, seed_epsilon */
    unsigned effects;    /* EFFECT_* bits, never 0 */
    /* The most its meshes and trees may hold, in bytes (memory_budget); 0: only the
     * daemon's total bounds it. */
    size_t memory_budget;
} world_spec;

/* Read-only directories outside the world directory that mesh paths may lead into
 * (mesh_root in [daemon], repeatable): where a ROS package or /usr/share keeps its meshes.
 * A path relative to the world directory may reach them through a symlink, and an
 * absolute path may name a file inside one; either way the path resolved (symlinks
 * followed) must stay inside the world directory or one root, and '..' is refused. */
#define MESH_ROOTS_MAX 16
typedef struct mesh_roots {
    size_t count;
    char paths[MESH_ROOTS_MAX][TRIOCT_MAX_PATH_LEN];
} mesh_roots;

/* A spec with the defaults: no meshes, identity transform, octree_default_def(), all effects. */
void world_spec_init(world_spec *spec, const char *name);
/* 1 when building a and b would give the same world (the source text aside). */
int world_spec_equal(const world_spec *a, const world_spec *b);

/* A byte count as a scene or a command line writes it: digits with an optional unit, K, M,
 * G or T (also KiB, MiB, GiB, TiB; powers of 1024) and nothing else. 0, or -1 for text that
 * is not one or a count past SIZE_MAX. */
int scene_parse_bytes(const char *text, size_t *out);

typedef struct scene_option {
    char key[64];
    char value[TRIOCT_MAX_PATH_LEN];
    int line;
} scene_option;

typedef struct scene {
    char path[TRIOCT_MAX_PATH_LEN];
    scene_option *daemon_options; /* the [daemon] section, in file order, unchecked */
    size_t daemon_option_count;
    world_spec *worlds;
    size_t world_count;
} scene;

/* Reads a scene file. Returns 0, or -1 with err saying "file:line: what" for a syntax error,
 * an unknown key in a world section, a bad value, a duplicate or invalid world name, a world
 * without a mesh, or more than TRIOCT_MAX_WORLDS worlds. On error *out is left empty. */
int scene_load(const char *path, scene *out, char *err, size_t err_len);
void scene_free(scene *s);
/* The world of that name, or NULL. */
const world_spec *scene_find(const scene *s, const char *name);

#endif
