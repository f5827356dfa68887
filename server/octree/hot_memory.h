/* Memory for a built tree's arrays that every query reads at random: cache-line aligned,
 * and large ones backed by huge pages where the kernel offers them.
 *
 * A ray or shape query over a large world touches a few dozen cache lines spread over tens
 * of megabytes; with 4 KiB pages nearly each of them also misses the TLB, and under
 * virtualisation a page walk costs several memory reads of its own. Measured on the peer
 * bench's worlds (one ray at a time, 20,000 random rays, alternating runs): 1.05-1.3x the
 * rays per second. Where transparent huge pages are off, or madvise is not there, the
 * arrays are ordinary aligned memory. */
#ifndef TRIOCT_HOT_MEMORY_H
#define TRIOCT_HOT_MEMORY_H

#include <stddef.h>

/* bytes (> 0) aligned on 64 bytes, or on a huge page when bytes fills at least one;
 * freed by free(). NULL when out of memory. */
void *hot_alloc(size_t bytes);

/* Moves the first `bytes` of *p (from malloc) into hot_alloc memory and frees the old
 * block. Without the memory *p stays where it is: the move only makes queries faster. */
void hot_move(void **p, size_t bytes);

#endif
