/* Robot state checks: a set of link shapes, each at its pose, against a world's objects
 * and, when asked, against each other, with allowed pairs left out (MoveIt's
 * allowed-collision matrix). Each link is a shape tree built once in the link's frame; a
 * link and an object are tested only when their posed boxes meet, and then by the two
 * trees descended together (octree_mesh_tree_posed), so a state costs what the parts of
 * the links near something cost. Answers are exact on the posed vertices of both sides. */
#ifndef TRIOCT_WORLD_OBJECT_STATE_H
#define TRIOCT_WORLD_OBJECT_STATE_H

#include <stddef.h>
#include <stdint.h>

#include "object_set.h"

/* Links one state may hold, and allowed pairs one check may name. */
#define STATE_MAX_LINKS 64
#define STATE_MAX_ALLOWED 1024

typedef struct state_link {
    const char *name;
    const octree *tree; /* the link's shape tree, in its frame */
    box3 bounds;        /* its mesh's bounds, in its frame */
    pose at;
} state_link;

/* A pair that may touch: a link's name and an object's or another link's name, either way
 * round. */
typedef struct state_allowed {
    const char *a, *b;
} state_allowed;

typedef struct state_contact {
    uint32_t link;          /* index into the links */
    int with_link;          /* 0: other is an object index in the set; 1: a link index */
    uint32_t other;
    uint32_t link_triangle; /* index in the link's mesh */
    uint32_t other_triangle;
} state_contact;

typedef struct state_output {
    int valid;    /* 1: no contact outside the allowed pairs */
    size_t count; /* contacts found (first contact only unless every contact was asked) */
    int truncated;
    state_contact *contacts; /* by link, objects before links, other, then triangles */
    size_t capacity;
} state_output;

/* What a check keeps between states: each link tree's shape scratch
 * (octree_shape_scratch), made on the link's first check. One thread at a time. */
typedef struct state_scratch state_scratch;
state_scratch *state_scratch_new(void);
void state_scratch_free(state_scratch *scratch);

/* Checks one state: every link against every object whose posed box its own meets, and
 * with self_collision every pair of links, pairs named in allowed left out. With
 * all_contacts 0 the check stops at its first contact (which it reports), else it reports
 * every colliding triangle pair. OCTREE_ERR_INVALID for more than STATE_MAX_LINKS links
 * or STATE_MAX_ALLOWED pairs, a link without a tree or name, or a pose
 * octree_pose_check refuses. scratch may be NULL (the check then makes and frees its
 * own). */
octree_status object_set_state(const object_set *s, const state_link *links, size_t link_count,
                               const state_allowed *allowed, size_t allowed_count, int self_collision,
                               int all_contacts, state_output *out, state_scratch *scratch, query_stats *stats);

/* object_set_state's checks of its links and allowed pairs: OCTREE_OK, or the status it
 * returns for them. */
octree_status state_links_check(const state_link *links, size_t link_count, const state_allowed *allowed,
                                size_t allowed_count);

/* For a link that touches no triangle of the solid objects it meets: the first solid
 * object (in object order, among those whose posed boxes meet the link's) holding a
 * connected part of it, as *object (-1: none), with a triangle of that part. What signs a
 * shape's distance and keeps a clearance from calling a shape inside a solid clear. */
octree_status object_set_link_inside(const object_set *s, const state_link *link, long *object, uint32_t *triangle,
                                     query_stats *stats);

/* 1 when the pair (x, y) is named in allowed (either way round). */
int state_pair_allowed(const state_allowed *allowed, size_t count, const char *x, const char *y);

/* The minimum distance between a state's links and the world's objects (not between links),
 * pairs named in allowed left out: octree_shape_distance's contract over every link and
 * object pair, with the link and object named. Ties: the smaller link, then object index;
 * touching: the first touching pair met (links in order, objects nearest box first).
 * found = 0 when every pair is proven farther than max_distance. The argument checks are
 * object_set_state's. */
typedef struct state_distance_output {
    int found;
    shape_distance_output distance; /* world_triangle: in the object's mesh; shape_triangle: the link's */
    uint32_t link, object;
} state_distance_output;

octree_status object_set_state_distance(const object_set *s, const state_link *links, size_t link_count,
                                        const state_allowed *allowed, size_t allowed_count, double max_distance,
                                        state_distance_output *out, query_stats *stats);

#endif
