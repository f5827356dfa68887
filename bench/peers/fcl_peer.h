/* The FCL side of the peer benchmark, behind a small C API so that bench_peers.c stays C.
 * A model is a BVHModel<OBBRSS> over a triangle soup with its CollisionObject, set up as
 * MoveIt sets FCL up for meshes (beginModel / addSubModel / endModel, default splitter).
 * Only the peer benchmark links this; the product never does. */
#ifndef TRIOCT_BENCH_FCL_PEER_H
#define TRIOCT_BENCH_FCL_PEER_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct fcl_peer_model fcl_peer_model;

const char *fcl_peer_version(void); /* FCL_VERSION of the headers compiled against */

/* xyz: 3 doubles a vertex; indices: 3 a triangle. Triangle ids in contacts are positions
 * in `indices`. NULL when FCL throws (the reason goes to stderr). */
fcl_peer_model *fcl_peer_model_new(const double *xyz, size_t vertex_count, const uint32_t *indices,
                                   size_t triangle_count);
void fcl_peer_model_free(fcl_peer_model *model);

/* Collides `shape` posed by p' = R p + t (r row-major; NULL r and t: identity) with `world`
 * at the identity, through fcl::collide with num_max_contacts = max_contacts and contacts
 * off (pairs only). max_contacts 1 is a yes/no query. Returns the contacts FCL reported;
 * with world_ids not NULL, the first id_cap of them give their world triangle there. */
size_t fcl_peer_collide(fcl_peer_model *shape, const double r[9], const double t[3], const fcl_peer_model *world,
                        size_t max_contacts, uint32_t *world_ids, size_t id_cap);

/* A world of objects as a MoveIt planning scene hands them to FCL: each object a
 * CollisionObject sharing its model's BVH, placed by its transform, all in one
 * DynamicAABBTreeCollisionManager (the broadphase). */
typedef struct fcl_peer_scene fcl_peer_scene;

fcl_peer_scene *fcl_peer_scene_new(void);
/* Places one object of `model` (which must outlive the scene) at p' = R p + t. */
void fcl_peer_scene_add(fcl_peer_scene *scene, const fcl_peer_model *model, const double r[9], const double t[3]);
/* Builds the broadphase over the objects added. */
void fcl_peer_scene_setup(fcl_peer_scene *scene);
/* Moves `link` to p' = R p + t (transform and AABB, as a planning scene updates a link)
 * and asks the broadphase for the objects whose boxes meet it, each pair by fcl::collide
 * with one contact, stopping at the first contact. skip: the index (in the order added)
 * of an object the link may touch, or -1. 1 when the link touches an object. */
int fcl_peer_scene_collide(fcl_peer_scene *scene, fcl_peer_model *link, const double r[9], const double t[3],
                           long skip);
void fcl_peer_scene_free(fcl_peer_scene *scene);

/* Two links where the last fcl_peer_scene_collide (or fcl_peer_move) put them: their AABBs
 * first, as a broadphase over the robot's links would, then fcl::collide with one
 * contact. 1 when they touch. */
int fcl_peer_links_collide(const fcl_peer_model *a, const fcl_peer_model *b);
/* Puts a link at p' = R p + t (transform and AABB) without asking anything. */
void fcl_peer_move(fcl_peer_model *link, const double r[9], const double t[3]);

/* The distance from p to the world's triangles, as FCL answers it for a point (a sphere
 * of radius 0 placed at p, fcl::distance); the nearest world point when nearest is not
 * NULL (witnesses asked for). */
double fcl_peer_point_distance(const fcl_peer_model *world, const double p[3], double nearest[3]);

/* fcl::distance of `shape` placed by p' = R p + t and `world` at the identity: the
 * minimum distance (0 or less when they touch), with both witness points when asked. */
double fcl_peer_distance(fcl_peer_model *shape, const double r[9], const double t[3], const fcl_peer_model *world,
                         double world_point[3], double shape_point[3]);

#ifdef __cplusplus
}
#endif

#endif
