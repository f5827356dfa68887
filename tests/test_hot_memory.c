/* hot_memory.h: alignment as promised (a cache line for small arrays, a huge page for
 * large ones), contents kept by a move, and the nothing-to-do cases. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "octree/hot_memory.h"

static void test_alignment_follows_the_size(void **state)
{
    (void)state;
    const size_t sizes[] = {1, 63, 64, 4096, ((size_t)2 << 20) - 1, (size_t)2 << 20, ((size_t)5 << 20) + 7};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        unsigned char *p = hot_alloc(sizes[i]);
        assert_non_null(p);
        size_t align = sizes[i] >= ((size_t)2 << 20) ? (size_t)2 << 20 : 64;
        assert_int_equal((uintptr_t)p % align, 0);
        memset(p, 0xab, sizes[i]); /* every byte is ours */
        assert_int_equal(p[sizes[i] - 1], 0xab);
        free(p);
    }
    assert_null(hot_alloc(0));
}

static void test_move_keeps_the_contents(void **state)
{
    (void)state;
    size_t n = ((size_t)3 << 20) / sizeof(uint32_t);
    uint32_t *a = malloc(n * sizeof *a);
    assert_non_null(a);
    for (size_t i = 0; i < n; i++)
        a[i] = (uint32_t)(i * 2654435761u);
    void *p = a;
    hot_move(&p, n * sizeof *a);
    uint32_t *b = p;
    assert_int_equal((uintptr_t)b % ((size_t)2 << 20), 0);
    for (size_t i = 0; i < n; i++)
        if (b[i] != (uint32_t)(i * 2654435761u))
            fail_msg("word %zu changed in the move", i);
    free(b);

    void *none = NULL;
    hot_move(&none, 100); /* nothing there: stays NULL */
    assert_null(none);
    void *small = malloc(8);
    assert_non_null(small);
    void *before = small;
    hot_move(&small, 0); /* nothing to move: the block stays */
    assert_ptr_equal(small, before);
    free(small);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_alignment_follows_the_size),
        cmocka_unit_test(test_move_keeps_the_contents),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
