/* Tests for the daemon's reply cache (service/reply_cache.h): a retry finds its original in
 * work or answered, other bytes under the same ids do not, and the bounds hold: the oldest
 * answers leave first, answers in work never, and an answer past the byte bound is not
 * kept. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdlib.h>
#include <string.h>

#include "service/reply_cache.h"

/* A reply of chunks chunks of size bytes each, every byte tag. */
static dispatch_reply make_reply(size_t chunks, size_t size, uint8_t tag)
{
    dispatch_reply r;
    memset(&r, 0, sizeof r);
    strcpy(r.channel, "REPLIES");
    r.chunks = calloc(chunks, sizeof *r.chunks);
    assert_non_null(r.chunks);
    for (size_t i = 0; i < chunks; i++) {
        r.chunks[i].data = malloc(size);
        assert_non_null(r.chunks[i].data);
        memset(r.chunks[i].data, tag, size);
        r.chunks[i].size = size;
    }
    r.chunk_count = chunks;
    r.status = 0;
    return r;
}

static void test_a_retry_finds_its_original(void **state)
{
    (void)state;
    reply_cache *c = reply_cache_create(8, 1 << 20);
    assert_non_null(c);
    const char request[] = "the request's bytes";
    uint64_t digest = reply_cache_digest(request, sizeof request);
    assert_int_not_equal(digest, reply_cache_digest("other bytes", 12));
    assert_int_equal(reply_cache_find(c, 7, 1, digest, NULL), REPLY_CACHE_NEW);
    reply_cache_start(c, 7, 1, digest);
    assert_int_equal(reply_cache_find(c, 7, 1, digest, NULL), REPLY_CACHE_IN_WORK);
    /* Another client, another id, other bytes: not this request. */
    assert_int_equal(reply_cache_find(c, 8, 1, digest, NULL), REPLY_CACHE_NEW);
    assert_int_equal(reply_cache_find(c, 7, 2, digest, NULL), REPLY_CACHE_NEW);
    assert_int_equal(reply_cache_find(c, 7, 1, digest + 1, NULL), REPLY_CACHE_NEW);

    dispatch_reply r = make_reply(3, 100, 0xab);
    reply_cache_finish(c, 7, 1, digest, &r);
    assert_int_equal(r.chunk_count, 0); /* moved into the cache */
    assert_null(r.chunks);
    assert_string_equal(r.channel, "REPLIES"); /* the caller's copy keeps the rest */
    const dispatch_reply *got = NULL;
    assert_int_equal(reply_cache_find(c, 7, 1, digest, &got), REPLY_CACHE_DONE);
    assert_non_null(got);
    assert_int_equal(got->chunk_count, 3);
    assert_int_equal(got->chunks[2].size, 100);
    assert_int_equal(got->chunks[2].data[99], 0xab);
    assert_int_equal(reply_cache_bytes(c), 300);

    /* The same ids with other bytes start afresh: the old answer goes. */
    reply_cache_start(c, 7, 1, digest + 1);
    assert_int_equal(reply_cache_find(c, 7, 1, digest, NULL), REPLY_CACHE_NEW);
    assert_int_equal(reply_cache_find(c, 7, 1, digest + 1, NULL), REPLY_CACHE_IN_WORK);
    assert_int_equal(reply_cache_bytes(c), 0);
    /* Answered otherwise (out of memory): forgotten, so a retry is worked. */
    reply_cache_forget(c, 7, 1);
    assert_int_equal(reply_cache_find(c, 7, 1, digest + 1, NULL), REPLY_CACHE_NEW);
    assert_int_equal(reply_cache_entries(c), 0);
    reply_cache_free(c);
}

static void test_bounds_evict_the_oldest_answers_only(void **state)
{
    (void)state;
    reply_cache *c = reply_cache_create(4, 1000);
    assert_non_null(c);
    /* Two in work, two answered. */
    for (int64_t id = 1; id <= 4; id++)
        reply_cache_start(c, 1, id, 42);
    dispatch_reply r = make_reply(1, 100, 1);
    reply_cache_finish(c, 1, 3, 42, &r);
    r = make_reply(1, 100, 2);
    reply_cache_finish(c, 1, 4, 42, &r);
    /* A fifth request: the oldest answer (3) leaves; 1 and 2, in work, stay. */
    reply_cache_start(c, 1, 5, 42);
    assert_int_equal(reply_cache_find(c, 1, 3, 42, NULL), REPLY_CACHE_NEW);
    assert_int_equal(reply_cache_find(c, 1, 4, 42, NULL), REPLY_CACHE_DONE);
    assert_int_equal(reply_cache_find(c, 1, 1, 42, NULL), REPLY_CACHE_IN_WORK);
    assert_int_equal(reply_cache_find(c, 1, 2, 42, NULL), REPLY_CACHE_IN_WORK);
    assert_int_equal(reply_cache_entries(c), 4);
    /* Bytes: an answer of 950 pushes out the 100 held; one of 1001 is not kept at all. */
    r = make_reply(2, 475, 3);
    reply_cache_finish(c, 1, 5, 42, &r);
    assert_int_equal(reply_cache_find(c, 1, 4, 42, NULL), REPLY_CACHE_NEW);
    assert_int_equal(reply_cache_bytes(c), 950);
    r = make_reply(1, 1001, 4);
    reply_cache_finish(c, 1, 1, 42, &r);
    assert_int_equal(r.chunk_count, 1); /* still the caller's */
    dispatch_reply_free(&r);
    assert_int_equal(reply_cache_find(c, 1, 1, 42, NULL), REPLY_CACHE_NEW);
    assert_int_equal(reply_cache_bytes(c), 950);
    /* Every entry in work: a new request is simply not tracked. */
    reply_cache *full = reply_cache_create(2, 1000);
    reply_cache_start(full, 2, 1, 1);
    reply_cache_start(full, 2, 2, 1);
    reply_cache_start(full, 2, 3, 1);
    assert_int_equal(reply_cache_find(full, 2, 3, 1, NULL), REPLY_CACHE_NEW);
    assert_int_equal(reply_cache_entries(full), 2);
    reply_cache_free(full);
    reply_cache_free(c); /* frees the answers it holds: ASan sees no leak */
}

/* Many requests through a small cache: the counts stay within the bounds at every step. */
static void test_churn_stays_bounded(void **state)
{
    (void)state;
    reply_cache *c = reply_cache_create(64, 10000);
    for (int64_t id = 1; id <= 5000; id++) {
        reply_cache_start(c, id % 7, id, (uint64_t)id);
        dispatch_reply r = make_reply(1 + (size_t)(id % 3), 50 + (size_t)(id % 200), (uint8_t)id);
        reply_cache_finish(c, id % 7, id, (uint64_t)id, &r);
        dispatch_reply_free(&r);
        assert_true(reply_cache_entries(c) <= 64);
        assert_true(reply_cache_bytes(c) <= 10000);
        assert_int_equal(reply_cache_find(c, id % 7, id, (uint64_t)id, NULL), REPLY_CACHE_DONE);
    }
    reply_cache_free(c);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_a_retry_finds_its_original),
        cmocka_unit_test(test_bounds_evict_the_oldest_answers_only),
        cmocka_unit_test(test_churn_stays_bounded),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
