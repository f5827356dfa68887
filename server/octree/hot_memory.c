/* madvise and MADV_HUGEPAGE are Linux's, outside POSIX. */
#define _DEFAULT_SOURCE
#include "hot_memory.h"

#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

#define HUGE_PAGE ((size_t)2 << 20)

void *hot_alloc(size_t bytes)
{
    size_t align = bytes >= HUGE_PAGE ? HUGE_PAGE : 64;
    void *p = NULL;
    if (bytes == 0 || posix_memalign(&p, align, bytes) != 0)
        return NULL;
#ifdef MADV_HUGEPAGE
    /* Advice only: nothing is touched yet, so the pages faulted in are huge ones when the
     * kernel has them; a refusal leaves ordinary pages. */
    if (align == HUGE_PAGE)
        (void)madvise(p, bytes & ~(HUGE_PAGE - 1), MADV_HUGEPAGE);
#endif
    return p;
}

void hot_move(void **p, size_t bytes)
{
    if (!*p || bytes == 0)
        return;
    void *q = hot_alloc(bytes);
    if (!q)
        return;
    memcpy(q, *p, bytes);
    free(*p);
    *p = q;
}
