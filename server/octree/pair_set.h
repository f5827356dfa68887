/* An open-addressing set of triangle pairs (a world id and a shape id), so a walk over two
 * trees tests each pair once. A triangle is listed in every leaf its box meets, on both
 * sides, so one pair turns up in many leaf pairs: a sphere over a terrain met its pairs
 * seven times each, on average, and a table of 64 recent pairs kept few of them. Starts
 * inline and grows on the heap, kept at most half full. */
#ifndef TRIOCT_OCTREE_PAIR_SET_H
#define TRIOCT_OCTREE_PAIR_SET_H

#include <stddef.h>
#include <stdint.h>

#define PAIR_SET_INLINE 256 /* slots kept inline */
#define PAIR_SET_EMPTY UINT64_MAX

typedef struct pair_set {
    uint64_t *slots; /* PAIR_SET_EMPTY marks an empty slot */
    size_t mask;     /* capacity - 1, the capacity a power of two */
    size_t count;
    uint64_t inline_slots[PAIR_SET_INLINE];
} pair_set;

void pair_set_init(pair_set *set);
void pair_set_release(pair_set *set);
/* Doubles the capacity; 0, or -1 when memory ran out (the set is unchanged). */
int pair_set_grow(pair_set *set);

static inline uint64_t pair_set_key(uint32_t a, uint32_t b)
{
    return (uint64_t)a << 32 | b; /* never PAIR_SET_EMPTY: ids are below UINT32_MAX */
}

static inline size_t pair_set_slot(uint64_t key, size_t mask)
{
    uint64_t h = (key ^ key >> 29) * 0x9E3779B97F4A7C15ull;
    return (size_t)(h >> 32) & mask;
}

/* 1 when the pair was added, 0 when it was there already, -1 when memory ran out. */
static inline int pair_set_insert(pair_set *set, uint64_t key)
{
    size_t mask = set->mask;
    size_t k = pair_set_slot(key, mask);
    for (;;) {
        uint64_t x = set->slots[k];
        if (x == key)
            return 0;
        if (x == PAIR_SET_EMPTY)
            break;
        k = (k + 1) & mask;
    }
    if (2 * (set->count + 1) > mask + 1) {
        if (pair_set_grow(set) != 0)
            return -1;
        mask = set->mask;
        k = pair_set_slot(key, mask);
        while (set->slots[k] != PAIR_SET_EMPTY)
            k = (k + 1) & mask;
    }
    set->slots[k] = key;
    set->count++;
    return 1;
}

#endif
