/* A world as a set of named objects that move: each object a model (a mesh and its
 * octree, built once in the model's local frame and shared by every object that uses the
 * same mesh) placed by a rigid pose. A set is one version of the world's object table,
 * immutable and shared by reference count: an edit list makes a new version that shares
 * the models, so a move costs a box per object and nothing per triangle, and queries in
 * flight finish on the version they started on.
 *
 * Answers are exact on the posed vertices, fl(R p + t) in the order octree_pose_point
 * gives (engine.h): the same answers a single octree built from every object's posed
 * triangles would give, with each triangle named by its object and its index in the
 * object's mesh. */
#ifndef TRIOCT_WORLD_OBJECT_SET_H
#define TRIOCT_WORLD_OBJECT_SET_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#include "../../common/trioct_limits.h"
#include "../engine.h"
#include "mesh_data.h"
#include "mesh_load.h"

/* Objects a world may hold. A query reaches them through a hierarchy of their posed boxes
 * (object_top), rebuilt with every version: O(n log n) an edit list, nothing per triangle. */
#define OBJECT_SET_MAX_OBJECTS 1024

/* A mesh and its tree in the mesh's own frame, shared by reference count. */
typedef struct object_model {
    char key[TRIOCT_MAX_PATH_LEN]; /* what makes two objects share it: a file path, or "inline:NAME" */
    char source[TRIOCT_MAX_PATH_LEN]; /* what a person is shown: the path as given, "inline", ... */
    mesh_data mesh;                /* the vertices answers are posed from */
    octree *tree;
    box3 bounds;                   /* of the mesh's vertices, in its frame */
    size_t bytes;                  /* the mesh and the tree */
    /* The account the mesh's bytes were taken from (the tree gives back its own): given
     * back when the model is freed. NULL: none. */
    memory_account *account;
    size_t mesh_accounted;
    mesh_load_report report;       /* what loading its file found (zero for inline meshes) */
    /* 1 once its mesh passed solid_check (closed, consistently oriented): objects of it
     * may then be solid. Set once, before any solid object uses it. */
    atomic_int closed;
    atomic_int refs;
} object_model;

/* Takes the mesh (moved into the model; *mesh is zeroed) and builds its tree with def.
 * NULL when the mesh is empty or the tree cannot be built, with err saying why. */
object_model *object_model_create(const char *key, mesh_data *mesh, const octree_def *def, char *err,
                                  size_t err_len);
/* A model of a tree already built from *mesh (the world builder builds its own, for
 * messages that name the file and triangle); takes both. NULL when out of memory, with
 * neither taken. */
object_model *object_model_adopt(const char *key, mesh_data *mesh, octree *tree);
void object_model_retain(object_model *m);
void object_model_release(object_model *m);

typedef struct world_object {
    char name[TRIOCT_MAX_NAME_LEN + 1];
    object_model *model; /* one reference */
    pose at;
    box3 bounds; /* every posed vertex inside (octree_pose_box of the model's bounds) */
    /* 1: a solid (its model is closed): its inside counts as contact for triangle, shape
     * and state queries, and object_set_point says whether a point is inside it. */
    int solid;
} world_object;

/* A node of the hierarchy over the objects' boxes: a leaf holds objects
 * top_order[first .. first + count), an interior node (count 0) its two children at first
 * and first + 1. */
typedef struct object_top_node {
    box3 box;
    uint32_t first;
    uint32_t count;
} object_top_node;

typedef struct object_set {
    uint64_t version;        /* 1 for the first set, + 1 for every applied edit list */
    world_object *objects;   /* sorted by name, so answers do not depend on edit order */
    size_t count;
    size_t triangles;
    size_t solids;           /* objects with solid set */
    object_top_node *top;    /* the hierarchy, root first; NULL without objects */
    uint32_t *top_order;     /* object indexes, leaf by leaf */
    atomic_int refs;
} object_set;

/* The indexes of the objects whose posed boxes meet the closed box b, ascending, into out
 * (room for s->count); returns how many. */
size_t object_set_near(const object_set *s, box3 b, uint32_t *out);

/* A set with no objects at version 0, or NULL when out of memory. */
object_set *object_set_create(void);
void object_set_retain(object_set *s);
void object_set_release(object_set *s);

/* 1 when name is 1..TRIOCT_MAX_NAME_LEN characters of [A-Za-z0-9_.-], the rule of object
 * (and robot link) names, else 0. */
int object_name_valid(const char *name);

/* The index of the object of that name, or -1. */
long object_set_find(const object_set *s, const char *name);

typedef enum object_edit_kind {
    OBJECT_EDIT_ADD,    /* name, model, at */
    OBJECT_EDIT_MOVE,   /* name, at */
    OBJECT_EDIT_REMOVE, /* name */
} object_edit_kind;

typedef struct object_edit {
    object_edit_kind kind;
    const char *name;
    object_model *model; /* ADD: the set takes its own reference */
    pose at;
    int solid; /* ADD: 1 for a solid object, whose model must be closed (object_model.closed) */
} object_edit;

typedef enum object_edit_status {
    OBJECT_EDIT_OK = 0,
    OBJECT_EDIT_BAD_NAME,  /* empty, too long, or not [A-Za-z0-9_.-] */
    OBJECT_EDIT_EXISTS,    /* ADD of a name the set holds */
    OBJECT_EDIT_UNKNOWN,   /* MOVE or REMOVE of a name it does not */
    OBJECT_EDIT_BAD_POSE,  /* not a rotation (octree_pose_check), not finite, or placing
                              a vertex at a coordinate that is not */
    OBJECT_EDIT_TOO_MANY,  /* past OBJECT_SET_MAX_OBJECTS */
    OBJECT_EDIT_BAD_EDIT,  /* an unknown kind, ADD without a model, or a solid ADD of a
                              model not checked closed */
    OBJECT_EDIT_NOMEM,
} object_edit_status;

/* Applies the edits in order to a copy of from, all or none: *out is the new version
 * (from's version + 1) with one reference, or NULL with the first failing edit's status,
 * its index in *failed and err naming the edit and the object. from is not changed. */
object_edit_status object_set_apply(const object_set *from, const object_edit *edits, size_t count,
                                    object_set **out, size_t *failed, char *err, size_t err_len);

/* A ray hit on an object: the engine's hit (triangle: the index in the object's mesh,
 * t, barycentrics and normal in world space) and the object's index in the set. */
typedef struct object_hit {
    ray_hit hit;
    uint32_t object;
} object_hit;

typedef struct object_ray_output {
    size_t hit_count; /* for RAY_ALL every hit found, possibly more than max_hits */
    int truncated;
    object_hit *hits;
    size_t max_hits;
} object_ray_output;

/* One ray against every object it can reach: octree_ray's contract over the union of the
 * posed triangles. Closest hits and RAY_ALL's order are by exact t, then object index,
 * then triangle index (what a tree of the union in object order breaks ties by); RAY_ANY
 * stops at the first hit found. Exact mode only. */
octree_status object_set_ray(const object_set *s, const ray_input *ray, ray_detail detail,
                             object_ray_output *out, query_stats *stats);

/* A triangle contact on an object: the engine's (triangle: the index in the object's
 * mesh, segment in world space) and the object's index in the set. */
typedef struct object_contact {
    tri_contact contact;
    uint32_t object;
} object_contact;

typedef struct object_tri_output {
    int hit;
    size_t count; /* every contact found, possibly more than capacity */
    int truncated;
    object_contact *contacts; /* sorted by object index, then triangle */
    size_t capacity;
} object_tri_output;

/* The triangle a contact names when the query lies inside a solid object without touching
 * its surface: the object is hit, through no triangle of it. */
#define OBJECT_INTERIOR UINT32_MAX

/* One triangle against every object whose posed box it reaches: octree_triangle's
 * contract over the union of the posed triangles, and for a solid object, its inside too:
 * a triangle touching no triangle of a solid lies wholly inside or wholly outside it, so
 * its first vertex decides, and one inside gives a single contact with the object, its
 * triangle OBJECT_INTERIOR and its segment that vertex (p == q). Exact mode only. */
octree_status object_set_triangle(const object_set *s, const vec3 tri[3], tri_detail detail,
                                  object_tri_output *out, query_stats *stats);

/* The nearest point of any object to p: octree_point_distance's contract over the union
 * of the posed triangles, found = 0 when every object is proven farther than
 * max_distance. The answer is the smallest upper bound's (ties: the smaller object
 * index, then triangle), its lower bound the smallest of every object that found one. */
typedef struct object_distance_output {
    int found;
    distance_output distance; /* triangle: the index in the object's mesh */
    uint32_t object;
    /* 1 when p lies inside a solid object (object_set_point): the distance is then signed,
     * negative, its magnitude the distance to the nearest surface (distance, lower and
     * upper negated, lower and upper swapped), the penetration depth. inside_object names
     * the solid; UINT32_MAX otherwise. A point on a solid's surface is at distance 0. */
    int inside;
    uint32_t inside_object;
} object_distance_output;

octree_status object_set_point_distance(const object_set *s, vec3 p, double max_distance, object_distance_output *out,
                                        query_stats *stats);

/* A shape tree placed at `at` against every object: octree_shape_distance's contract over
 * the union of the posed triangles (ties: the smaller object index; touching: the first
 * touching pair met, objects nearest box first). */
typedef struct object_shape_distance_output {
    int found;
    shape_distance_output distance; /* world_triangle: the index in the object's mesh */
    uint32_t object;
    /* 1 when a part of the shape lies inside a solid object without touching it: the
     * distance is then negative, minus its distance to the surface (lower and upper
     * negated and swapped); inside_object names the solid, else UINT32_MAX. */
    int inside;
    uint32_t inside_object;
} object_shape_distance_output;

octree_status object_set_shape_distance(const object_set *s, const octree *shape, const pose *at,
                                        double max_distance, object_shape_distance_output *out, query_stats *stats);

/* Clearance over every object: *clear = 1 when every object is proven farther than radius
 * from the placed shape and no part of it lies inside a solid; else 0, with *object (may
 * be NULL) the first object that could not be proven so (or the solid holding a part). */
octree_status object_set_shape_clearance(const object_set *s, const octree *shape, const pose *at, double radius,
                                         int *clear, long *object, query_stats *stats);

/* ---------- solid objects: where a point lies ---------- */

typedef struct object_point_output {
    point_side side; /* POINT_OUTSIDE when no solid object holds the point */
    uint32_t object; /* the object that holds it, or UINT32_MAX */
} object_point_output;

/* Whether p is inside a solid object, on its surface, or outside every one: the first
 * solid object in object (name) order whose closed volume (inside and surface) holds p,
 * and which of the two, by octree_point_side_posed on its posed triangles. Objects that
 * are not solid have no inside and are not asked. Exact; OCTREE_ERR_NONFINITE for a
 * non-finite p. */
octree_status object_set_point(const object_set *s, vec3 p, object_point_output *out, query_stats *stats);

#endif
