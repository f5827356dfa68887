/* A small open-addressing set of triangle ids, so a query tests each candidate once without
 * sorting its candidate list. Starts on the caller's stack and grows on the heap. */
#ifndef TRIOCT_OCTREE_ID_SET_H
#define TRIOCT_OCTREE_ID_SET_H

#include <stddef.h>
#include <stdint.h>

#define ID_SET_INLINE 64 /* slots kept inline: enough for most queries' candidates */

typedef struct id_set {
    uint32_t *slots; /* UINT32_MAX marks an empty slot */
    size_t capacity; /* a power of two */
    size_t count;
    uint32_t inline_slots[ID_SET_INLINE];
} id_set;

void id_set_init(id_set *set);
void id_set_release(id_set *set);
/* 1 when id was added, 0 when it was there already, -1 when memory ran out. */
int id_set_insert(id_set *set, uint32_t id);

#endif
