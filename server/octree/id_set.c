/* Open-addressing id set with linear probing (see id_set.h). */
#include "id_set.h"

#include <stdlib.h>
#include <string.h>

void id_set_init(id_set *set)
{
    set->slots = set->inline_slots;
    set->mask = ID_SET_INLINE - 1;
    set->count = 0;
    memset(set->inline_slots, 0xff, sizeof set->inline_slots);
}

void id_set_release(id_set *set)
{
    if (set->slots != set->inline_slots)
        free(set->slots);
    set->slots = NULL;
}

int id_set_grow(id_set *set)
{
    size_t cap = 2 * (set->mask + 1);
    uint32_t *slots = malloc(cap * sizeof *slots);
    if (!slots)
        return -1;
    memset(slots, 0xff, cap * sizeof *slots);
    for (size_t i = 0; i <= set->mask; i++) {
        uint32_t id = set->slots[i];
        if (id == ID_SET_EMPTY)
            continue;
        size_t k = id_set_slot(id, cap - 1);
        while (slots[k] != ID_SET_EMPTY)
            k = (k + 1) & (cap - 1);
        slots[k] = id;
    }
    if (set->slots != set->inline_slots)
        free(set->slots);
    set->slots = slots;
    set->mask = cap - 1;
    return 0;
}
