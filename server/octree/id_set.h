/* A small open-addressing set of triangle ids, so a query tests each candidate once without
 * sorting its candidate list. Starts on the caller's stack and grows on the heap.
 *
 * Insertion is inline: a grazing ray over a large terrain meets about 135 ids (95 distinct)
 * and a call per id measured as much as the probing itself. 256 inline slots keep a set up
 * to 128 ids, half full, off the heap; with 64 such a ray grew the set twice, about 9% of
 * its time. */
#ifndef TRIOCT_OCTREE_ID_SET_H
#define TRIOCT_OCTREE_ID_SET_H

#include <stddef.h>
#include <stdint.h>

#define ID_SET_INLINE 256 /* slots kept inline */
#define ID_SET_EMPTY UINT32_MAX

typedef struct id_set {
    uint32_t *slots; /* ID_SET_EMPTY marks an empty slot */
    size_t mask;     /* capacity - 1, the capacity a power of two */
    size_t count;
    uint32_t inline_slots[ID_SET_INLINE];
} id_set;

void id_set_init(id_set *set);
void id_set_release(id_set *set);
/* Doubles the capacity; 0, or -1 when memory ran out (the set is unchanged). */
int id_set_grow(id_set *set);

static inline size_t id_set_slot(uint32_t id, size_t mask)
{
    /* Fibonacci hashing spreads consecutive ids (neighbouring triangles) apart. */
    return (size_t)(((uint64_t)id * 0x9E3779B97F4A7C15ull) >> 32) & mask;
}

/* 1 when id was added, 0 when it was there already, -1 when memory ran out. */
static inline int id_set_insert(id_set *set, uint32_t id)
{
    size_t mask = set->mask;
    size_t k = id_set_slot(id, mask);
    for (;;) {
        uint32_t x = set->slots[k];
        if (x == id)
            return 0;
        if (x == ID_SET_EMPTY)
            break;
        k = (k + 1) & mask;
    }
    /* Kept at most half full, so probes stay short and an empty slot always exists. */
    if (2 * (set->count + 1) > mask + 1) {
        if (id_set_grow(set) != 0)
            return -1;
        mask = set->mask;
        k = id_set_slot(id, mask);
        while (set->slots[k] != ID_SET_EMPTY)
            k = (k + 1) & mask;
    }
    set->slots[k] = id;
    set->count++;
    return 1;
}

#endif
