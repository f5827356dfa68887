/* Open-addressing set of triangle pairs with linear probing (see pair_set.h). */
#include "pair_set.h"

#include <stdlib.h>
#include <string.h>

void pair_set_init(pair_set *set)
{
    set->slots = set->inline_slots;
    set->mask = PAIR_SET_INLINE - 1;
    set->count = 0;
    memset(set->inline_slots, 0xff, sizeof set->inline_slots);
}

void pair_set_release(pair_set *set)
{
    if (set->slots != set->inline_slots)
        free(set->slots);
    set->slots = NULL;
}

int pair_set_grow(pair_set *set)
{
    size_t cap = 2 * (set->mask + 1);
    uint64_t *slots = malloc(cap * sizeof *slots);
    if (!slots)
        return -1;
    memset(slots, 0xff, cap * sizeof *slots);
    for (size_t i = 0; i <= set->mask; i++) {
        uint64_t key = set->slots[i];
        if (key == PAIR_SET_EMPTY)
            continue;
        size_t k = pair_set_slot(key, cap - 1);
        while (slots[k] != PAIR_SET_EMPTY)
            k = (k + 1) & (cap - 1);
        slots[k] = key;
    }
    if (set->slots != set->inline_slots)
        free(set->slots);
    set->slots = slots;
    set->mask = cap - 1;
    return 0;
}
