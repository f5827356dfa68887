/* The daemon's counters and latency percentiles: nearest-rank percentiles exact on known
 * inputs (shuffled, duplicated, tiny and large), an interval that starts empty after each
 * summary while the counters run on, the reservoir past the sample cap, and every counter
 * refusing what its table has no slot for. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "service/stats.h"

/* A fixed permutation, so the inputs arrive in no helpful order. */
static void shuffle(int64_t *v, size_t n, uint64_t seed)
{
    for (size_t i = n; i > 1; i--) {
        seed = seed * 6364136223846793005ull + 1442695040888963407ull;
        size_t j = (size_t)((seed >> 33) % i);
        int64_t t = v[i - 1];
        v[i - 1] = v[j];
        v[j] = t;
    }
}

static void test_percentile_known_inputs(void **state)
{
    (void)state;
    int64_t v[1000];

    /* 1..100: the 50th percentile is 50, the 99th is 99, the 100th is 100. */
    for (int i = 0; i < 100; i++)
        v[i] = i + 1;
    shuffle(v, 100, 1);
    assert_int_equal(stats_percentile(v, 100, 50), 50);
    shuffle(v, 100, 2);
    assert_int_equal(stats_percentile(v, 100, 99), 99);
    shuffle(v, 100, 3);
    assert_int_equal(stats_percentile(v, 100, 100), 100);
    shuffle(v, 100, 4);
    assert_int_equal(stats_percentile(v, 100, 1), 1);

    /* 1..1000: ranks 500 and 990. */
    for (int i = 0; i < 1000; i++)
        v[i] = (i + 1) * 10;
    shuffle(v, 1000, 5);
    assert_int_equal(stats_percentile(v, 1000, 50), 5000);
    shuffle(v, 1000, 6);
    assert_int_equal(stats_percentile(v, 1000, 99), 9900);

    /* Ranks round up: of 3 values the median is the 2nd, of 4 the 2nd, and p99 of 10 is
     * the 10th (ceil(9.9)). */
    int64_t three[] = {30, 10, 20};
    assert_int_equal(stats_percentile(three, 3, 50), 20);
    int64_t four[] = {40, 10, 30, 20};
    assert_int_equal(stats_percentile(four, 4, 50), 20);
    int64_t ten[] = {5, 9, 1, 7, 3, 10, 2, 8, 4, 6};
    assert_int_equal(stats_percentile(ten, 10, 99), 10);
    assert_int_equal(stats_percentile(ten, 10, 90), 9);

    /* One value is every percentile; none gives 0. */
    int64_t one[] = {77};
    assert_int_equal(stats_percentile(one, 1, 50), 77);
    assert_int_equal(stats_percentile(one, 1, 99), 77);
    assert_int_equal(stats_percentile(NULL, 0, 50), 0);
}

static void test_percentile_duplicates(void **state)
{
    (void)state;
    /* 900 values of 5 and 100 of 1000: p50 is 5, p90 still 5 (rank 900), p91 is 1000. */
    int64_t v[1000];
    for (int i = 0; i < 1000; i++)
        v[i] = i < 900 ? 5 : 1000;
    shuffle(v, 1000, 7);
    assert_int_equal(stats_percentile(v, 1000, 50), 5);
    shuffle(v, 1000, 8);
    assert_int_equal(stats_percentile(v, 1000, 90), 5);
    shuffle(v, 1000, 9);
    assert_int_equal(stats_percentile(v, 1000, 91), 1000);
    /* All equal. */
    for (int i = 0; i < 1000; i++)
        v[i] = 42;
    assert_int_equal(stats_percentile(v, 1000, 99), 42);
    /* Already sorted and reverse sorted: the pivot choice must not matter. */
    for (int i = 0; i < 1000; i++)
        v[i] = i;
    assert_int_equal(stats_percentile(v, 1000, 50), 499);
    for (int i = 0; i < 1000; i++)
        v[i] = 1000 - i;
    assert_int_equal(stats_percentile(v, 1000, 99), 990);
}

static void test_interval_summary_and_reset(void **state)
{
    (void)state;
    stats s;
    stats_init(&s, 0);
    latency_summary sum;

    /* An empty interval: all zero. */
    stats_take_interval(&s, &sum);
    assert_int_equal(sum.count, 0);
    assert_int_equal(sum.p50_us, 0);
    assert_int_equal(sum.p99_us, 0);
    assert_int_equal(sum.max_us, 0);

    /* 200 latencies 1..200 in a scrambled order: p50 100, p99 198, max 200. */
    int64_t v[200];
    for (int i = 0; i < 200; i++)
        v[i] = i + 1;
    shuffle(v, 200, 10);
    for (int i = 0; i < 200; i++)
        stats_add_latency(&s, v[i]);
    stats_take_interval(&s, &sum);
    assert_int_equal(sum.count, 200);
    assert_int_equal(sum.p50_us, 100);
    assert_int_equal(sum.p99_us, 198);
    assert_int_equal(sum.max_us, 200);

    /* The next interval knows nothing of the last one. */
    stats_add_latency(&s, 7);
    stats_add_latency(&s, 3);
    stats_add_latency(&s, -5); /* a clock step backwards counts as 0 */
    stats_take_interval(&s, &sum);
    assert_int_equal(sum.count, 3);
    assert_int_equal(sum.p50_us, 3);
    assert_int_equal(sum.p99_us, 7);
    assert_int_equal(sum.max_us, 7);

    stats_take_interval(&s, &sum);
    assert_int_equal(sum.count, 0);
    assert_int_equal(sum.p50_us, 0);
    stats_free(&s);
}

static void test_large_interval_is_exact(void **state)
{
    (void)state;
    /* 300,000 latencies grow the buffer several times; every one is kept. */
    enum { N = 300000 };
    stats s;
    stats_init(&s, 0);
    int64_t *v = malloc(N * sizeof *v);
    assert_non_null(v);
    for (int i = 0; i < N; i++)
        v[i] = i + 1;
    shuffle(v, N, 11);
    for (int i = 0; i < N; i++)
        stats_add_latency(&s, v[i]);
    latency_summary sum;
    stats_take_interval(&s, &sum);
    assert_int_equal(sum.count, N);
    assert_int_equal(sum.p50_us, N / 2);
    assert_int_equal(sum.p99_us, N / 100 * 99);
    assert_int_equal(sum.max_us, N);
    assert_int_equal(s.sample_count, 0);
    /* A busy interval keeps its buffer for the next one; a quiet interval after it gives
     * the memory back. */
    assert_true(s.sample_alloc >= N);
    stats_add_latency(&s, 5);
    stats_take_interval(&s, &sum);
    assert_int_equal(sum.count, 1);
    assert_int_equal(sum.p50_us, 5);
    assert_int_equal(sum.p99_us, 5);
    assert_int_equal(s.sample_alloc, 0);
    free(v);
    stats_free(&s);
}

static void test_reservoir_past_the_cap(void **state)
{
    (void)state;
    /* Cap 1000 over 100,000 latencies: count stays exact, memory stays at the cap, and the
     * sample is uniform enough that the percentiles land near the truth. 1..100000 in a
     * shuffled order: p50 50000, p99 99000; a uniform sample of 1000 puts them within a
     * few percent (the standard error of p50's rank is 1.6%; 5% is three of them). */
    enum { N = 100000, CAP = 1000 };
    stats s;
    stats_init(&s, CAP);
    int64_t *v = malloc(N * sizeof *v);
    assert_non_null(v);
    for (int i = 0; i < N; i++)
        v[i] = i + 1;
    shuffle(v, N, 12);
    for (int i = 0; i < N; i++)
        stats_add_latency(&s, v[i]);
    assert_int_equal(s.sample_count, CAP);
    assert_true(s.sample_alloc <= CAP);
    latency_summary sum;
    stats_take_interval(&s, &sum);
    assert_int_equal(sum.count, N);
    assert_in_range(sum.p50_us, 45000, 55000);
    assert_in_range(sum.p99_us, 97000, 100000);
    assert_in_range(sum.max_us, sum.p99_us, N);
    free(v);
    stats_free(&s);
}

static void test_counters(void **state)
{
    (void)state;
    stats s;
    stats_init(&s, 0);
    assert_int_equal(stats_count_reply(&s, 0, TRIOCT_OK), 0);
    assert_int_equal(stats_count_reply(&s, 0, TRIOCT_OK), 0);
    assert_int_equal(stats_count_reply(&s, 1, TRIOCT_ERR_NONFINITE), 0);
    assert_int_equal(stats_count_reply(&s, 3, TRIOCT_ERR_BUSY), 0);
    assert_int_equal(stats_count_reply(&s, 2, TRIOCT_ERR_NOMEM), 0);
    stats_count_malformed(&s);
    stats_count_malformed(&s);
    stats_count_malformed(&s);

    /* Outside the tables: refused, nothing counted. The client-side codes (100 and up)
     * never travel on the wire. */
    assert_int_equal(stats_count_reply(&s, -1, TRIOCT_OK), -1);
    assert_int_equal(stats_count_reply(&s, STATS_REQUEST_TYPES, TRIOCT_OK), -1);
    assert_int_equal(stats_count_reply(&s, 0, -1), -1);
    assert_int_equal(stats_count_reply(&s, 0, TRIOCT_WIRE_STATUS_COUNT), -1);
    assert_int_equal(stats_count_reply(&s, 0, TRIOCT_ERR_TIMEOUT), -1);

    assert_int_equal(s.served[0], 2);
    assert_int_equal(s.served[1], 1);
    assert_int_equal(s.served[2], 1);
    assert_int_equal(s.served[3], 1);
    assert_int_equal(s.malformed, 3);
    int64_t total = 0;
    for (int i = 0; i < TRIOCT_WIRE_STATUS_COUNT; i++)
        total += s.replies_by_status[i];
    assert_int_equal(total, 5);
    assert_int_equal(s.replies_by_status[TRIOCT_OK], 2);
    assert_int_equal(s.replies_by_status[TRIOCT_ERR_NONFINITE], 1);
    assert_int_equal(s.replies_by_status[TRIOCT_ERR_BUSY], 1);
    assert_int_equal(s.replies_by_status[TRIOCT_ERR_NOMEM], 1);

    /* Counters run on across intervals. */
    latency_summary sum;
    stats_add_latency(&s, 10);
    stats_take_interval(&s, &sum);
    assert_int_equal(s.served[0], 2);
    assert_int_equal(s.malformed, 3);
    assert_int_equal(s.replies_by_status[TRIOCT_OK], 2);
    stats_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_percentile_known_inputs),
        cmocka_unit_test(test_percentile_duplicates),
        cmocka_unit_test(test_interval_summary_and_reset),
        cmocka_unit_test(test_large_interval_is_exact),
        cmocka_unit_test(test_reservoir_past_the_cap),
        cmocka_unit_test(test_counters),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
