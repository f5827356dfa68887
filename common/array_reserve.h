/* One growth rule for every realloc'd array of the project: the engine's build lists and
 * hit and id lists, the client command's gathered answers, the loaders' stacks. */
#ifndef TRIOCT_ARRAY_RESERVE_H
#define TRIOCT_ARRAY_RESERVE_H

#include <stdint.h>
#include <stdlib.h>

/* Grows a realloc'd array (*items, *capacity elements of elem bytes) to hold at least need,
 * doubling from first (or from the present capacity). 0, or -1 when the memory is not
 * there or need * elem does not fit a size_t; the array is then left as it was, so the
 * caller still owns and frees it. */
/* The capacity array_reserve grows to for need (elem > 0, need * elem fitting a size_t):
 * what a caller that budgets its memory must count before it asks. */
static inline size_t array_grown_capacity(size_t capacity, size_t need, size_t elem, size_t first)
{
    if (need <= capacity)
        return capacity;
    size_t cap = capacity ? capacity : (first ? first : 1);
    while (cap < need)
        cap = cap <= SIZE_MAX / elem / 2 ? cap * 2 : need;
    return cap;
}

static inline int array_reserve(void **items, size_t *capacity, size_t need, size_t elem, size_t first)
{
    if (need <= *capacity)
        return 0;
    if (elem == 0 || need > SIZE_MAX / elem)
        return -1;
    size_t cap = array_grown_capacity(*capacity, need, elem, first);
    void *grown = realloc(*items, cap * elem);
    if (grown == NULL)
        return -1;
    *items = grown;
    *capacity = cap;
    return 0;
}

#endif
