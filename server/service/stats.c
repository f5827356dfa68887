#include "stats.h"

#include <stdlib.h>
#include <string.h>

#define STATS_FIRST_ALLOC 256
#define STATS_KEEP_ALLOC 65536 /* 512 KB of samples stay between intervals whatever the load */
#define STATS_RNG_SEED 0x9E3779B97F4A7C15ull

void stats_init(stats *s, size_t max_samples)
{
    memset(s, 0, sizeof *s);
    s->max_samples = max_samples ? max_samples : STATS_DEFAULT_MAX_SAMPLES;
    s->rng = STATS_RNG_SEED;
}

void stats_free(stats *s)
{
    free(s->samples);
    s->samples = NULL;
    s->sample_count = s->sample_alloc = 0;
}

void stats_count_malformed(stats *s)
{
    s->malformed++;
}

int stats_count_reply(stats *s, int type, int status)
{
    if (type < 0 || type >= STATS_REQUEST_TYPES || status < 0 || status >= TRIOCT_WIRE_STATUS_COUNT)
        return -1;
    s->served[type]++;
    s->replies_by_status[status]++;
    return 0;
}

/* xorshift64*: the reservoir only needs indices that do not favour any position. */
static uint64_t next_random(stats *s)
{
    uint64_t x = s->rng;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    s->rng = x;
    return x * 0x2545F4914F6CDD1Dull;
}

void stats_add_latency(stats *s, int64_t us)
{
    if (us < 0)
        us = 0;
    s->interval_count++;

    if (s->sample_count == s->sample_alloc && s->sample_alloc < s->max_samples) {
        size_t want = s->sample_alloc ? s->sample_alloc * 2 : STATS_FIRST_ALLOC;
        if (want > s->max_samples)
            want = s->max_samples;
        int64_t *grown = realloc(s->samples, want * sizeof *grown);
        /* Out of memory, the interval samples within what it has (below). */
        if (grown != NULL) {
            s->samples = grown;
            s->sample_alloc = want;
        }
    }
    if (s->sample_count < s->sample_alloc) {
        s->samples[s->sample_count++] = us;
        return;
    }
    if (s->sample_alloc == 0)
        return;
    /* Reservoir sampling (Vitter's algorithm R): the n-th latency replaces a random stored
     * one with probability max/n, which keeps every latency of the interval equally likely
     * to be in the sample. */
    uint64_t j = next_random(s) % (uint64_t)s->interval_count;
    if (j < s->sample_count)
        s->samples[j] = us;
}

static void swap64(int64_t *a, int64_t *b)
{
    int64_t t = *a;
    *a = *b;
    *b = t;
}

static int64_t median3(int64_t a, int64_t b, int64_t c)
{
    if (a > b)
        swap64(&a, &b);
    if (b > c)
        swap64(&b, &c);
    if (a > b)
        swap64(&a, &b);
    return b;
}

/* The k-th smallest (0-based) of v[lo..hi), rearranging v so that v[lo..k) <= v[k] <=
 * v[k+1..hi). Quickselect with a three-way partition: runs of equal latencies, which are
 * common at microsecond resolution, shrink the range instead of stalling it. */
static int64_t select_kth(int64_t *v, size_t lo, size_t hi, size_t k)
{
    while (hi - lo > 1) {
        int64_t pivot = median3(v[lo], v[lo + (hi - lo) / 2], v[hi - 1]);
        size_t lt = lo, i = lo, gt = hi;
        while (i < gt) {
            if (v[i] < pivot)
                swap64(&v[lt++], &v[i++]);
            else if (v[i] > pivot)
                swap64(&v[i], &v[--gt]);
            else
                i++;
        }
        /* The pivot is one of the range's values, so [lt, gt) is never empty. */
        if (k < lt)
            hi = lt;
        else if (k >= gt)
            lo = gt;
        else
            return pivot;
    }
    return v[k];
}

static size_t nearest_rank(size_t n, unsigned percent)
{
    /* ceil(percent * n / 100), at least 1: the 1-based rank. */
    size_t rank = (size_t)(((unsigned long long)percent * n + 99) / 100);
    if (rank < 1)
        rank = 1;
    if (rank > n)
        rank = n;
    return rank;
}

int64_t stats_percentile(int64_t *v, size_t n, unsigned percent)
{
    if (n == 0)
        return 0;
    if (percent > 100)
        percent = 100;
    return select_kth(v, 0, n, nearest_rank(n, percent) - 1);
}

void stats_take_interval(stats *s, latency_summary *out)
{
    memset(out, 0, sizeof *out);
    out->count = s->interval_count;
    size_t n = s->sample_count;
    if (n > 0) {
        size_t k50 = nearest_rank(n, 50) - 1;
        size_t k99 = nearest_rank(n, 99) - 1;
        out->p50_us = select_kth(s->samples, 0, n, k50);
        /* Everything above k50 is now >= p50, and k99 >= k50: search only there. */
        out->p99_us = select_kth(s->samples, k50, n, k99);
        int64_t max = out->p99_us;
        for (size_t i = k99; i < n; i++)
            if (s->samples[i] > max)
                max = s->samples[i];
        out->max_us = max;
    }
    s->sample_count = 0;
    s->interval_count = 0;
    /* A burst must not pin its memory for the daemon's life: a large buffer goes back
     * after an interval that used under an eighth of it; busy intervals keep it. */
    if (s->sample_alloc > STATS_KEEP_ALLOC && n < s->sample_alloc / 8) {
        free(s->samples);
        s->samples = NULL;
        s->sample_alloc = 0;
    }
}
