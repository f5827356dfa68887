/* Open-addressing id set with linear probing (see id_set.h). */
#include "id_set.h"

#include <stdlib.h>
#include <string.h>

#define EMPTY UINT32_MAX

void id_set_init(id_set *set)
{
    set->slots = set->inline_slots;
    set->capacity = ID_SET_INLINE;
    set->count = 0;
    memset(set->inline_slots, 0xff, sizeof set->inline_slots);
}

void id_set_release(id_set *set)
{
    if (set->slots != set->inline_slots)
        free(set->slots);
    set->slots = NULL;
}

static inline size_t slot_of(uint32_t id, size_t mask)
{
    /* Fibonacci hashing spreads consecutive ids (neighbouring triangles) apart. */
    return (size_t)(((uint64_t)id * 0x9E3779B97F4A7C15ull) >> 32) & mask;
}

static int grow(id_set *set)
{
    size_t cap = set->capacity * 2;
    uint32_t *slots = malloc(cap * sizeof *slots);
    if (!slots)
        return -1;
    memset(slots, 0xff, cap * sizeof *slots);
    for (size_t i = 0; i < set->capacity; i++) {
        uint32_t id = set->slots[i];
        if (id == EMPTY)
            continue;
        size_t s = slot_of(id, cap - 1);
        while (slots[s] != EMPTY)
            s = (s + 1) & (cap - 1);
        slots[s] = id;
    }
    if (set->slots != set->inline_slots)
        free(set->slots);
    set->slots = slots;
    set->capacity = cap;
    return 0;
}

int id_set_insert(id_set *set, uint32_t id)
{
    if (2 * (set->count + 1) > set->capacity && grow(set) != 0)
        return -1;
    size_t mask = set->capacity - 1;
    size_t s = slot_of(id, mask);
    while (set->slots[s] != EMPTY) {
        if (set->slots[s] == id)
            return 0;
        s = (s + 1) & mask;
    }
    set->slots[s] = id;
    set->count++;
    return 1;
}
