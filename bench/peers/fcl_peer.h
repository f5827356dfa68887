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

#ifdef __cplusplus
}
#endif

#endif
