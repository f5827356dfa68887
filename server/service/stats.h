/* What the daemon counts for its status message: requests answered by type, replies by
 * status code, malformed messages, and the latency of the requests answered since the last
 * heartbeat. Owned and updated by the loop thread only (replies are published there), so
 * nothing here is atomic or locked.
 *
 * Latency percentiles are exact, by nearest rank over every latency of the interval, as
 * long as an interval answers at most max_samples requests (2^20 by default: 8 MB, and a
 * one-second interval reaches it only above a million answers a second). Past that the
 * interval keeps a uniform random sample of max_samples latencies (reservoir sampling), so
 * memory stays bounded and a percentile's rank has a standard error of
 * sqrt(p (1 - p) / max_samples) of n (under 0.05% of n by default); count stays the exact
 * number answered. */
#ifndef TRIOCT_SERVICE_STATS_H
#define TRIOCT_SERVICE_STATS_H

#include <stddef.h>
#include <stdint.h>

#include "../../common/trioct_status.h"

#define STATS_REQUEST_TYPES 7 /* ray, triangle, mesh, admin, objects, state, distance: status_t.served */
#define STATS_DEFAULT_MAX_SAMPLES ((size_t)1 << 20)

typedef struct stats {
    int64_t served[STATS_REQUEST_TYPES];          /* replies published, by request type */
    int64_t replies_by_status[TRIOCT_WIRE_STATUS_COUNT];
    int64_t malformed;                            /* messages dropped before decoding */
    int64_t duplicates_answered; /* retries answered from the reply cache, not worked again */
    int64_t duplicates_joined;   /* retries that came while the original was in work */

    /* The current interval's latencies, in microseconds. */
    int64_t *samples;
    size_t sample_count;   /* stored */
    size_t sample_alloc;
    size_t max_samples;
    int64_t interval_count; /* answered this interval, stored or not */
    uint64_t rng;          /* reservoir sampling only */
} stats;

typedef struct latency_summary {
    int64_t p50_us; /* 0 when count is 0 */
    int64_t p99_us;
    int64_t max_us;
    int64_t count;  /* requests whose latency the interval measured */
} latency_summary;

/* max_samples 0 means STATS_DEFAULT_MAX_SAMPLES. Allocates nothing until the first latency. */
void stats_init(stats *s, size_t max_samples);
void stats_free(stats *s);

void stats_count_malformed(stats *s);
/* One reply published for a request of type (0..STATS_REQUEST_TYPES-1) with status.
 * Returns 0, or -1 (nothing counted) for a type or status outside the tables. */
int stats_count_reply(stats *s, int type, int status);
/* A latency of the current interval; negative values count as 0. */
void stats_add_latency(stats *s, int64_t us);

/* Summarises the current interval and starts the next one; counters run on. */
void stats_take_interval(stats *s, latency_summary *out);

/* The nearest-rank percentile (1..100) of v[0..n): the smallest value with at least
 * percent% of the values at or below it, i.e. the ceil(percent * n / 100)-th smallest.
 * Reorders v. 0 when n is 0. */
int64_t stats_percentile(int64_t *v, size_t n, unsigned percent);

#endif
