/* The one growth rule of the project's realloc'd arrays: the first allocation takes the
 * caller's starting size, later ones double, a request the array already holds changes
 * nothing, and a size that cannot be expressed in bytes fails with the array intact. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "array_reserve.h"

static void test_first_allocation_takes_first(void **state)
{
    (void)state;
    int *items = NULL;
    size_t cap = 0;
    assert_int_equal(array_reserve((void **)&items, &cap, 1, sizeof *items, 16), 0);
    assert_non_null(items);
    assert_int_equal(cap, 16);
    /* A need beyond first doubles from first until it fits. */
    int *more = NULL;
    size_t more_cap = 0;
    assert_int_equal(array_reserve((void **)&more, &more_cap, 100, sizeof *more, 16), 0);
    assert_int_equal(more_cap, 128);
    free(items);
    free(more);
}

static void test_growth_doubles_and_keeps_contents(void **state)
{
    (void)state;
    int *items = NULL;
    size_t cap = 0, count = 0;
    for (int i = 0; i < 1000; i++) {
        assert_int_equal(array_reserve((void **)&items, &cap, count + 1, sizeof *items, 4), 0);
        assert_true(cap >= count + 1);
        items[count++] = i;
    }
    assert_int_equal(cap, 1024); /* 4, 8, ..., 1024 */
    for (int i = 0; i < 1000; i++)
        assert_int_equal(items[i], i);
    free(items);
}

static void test_need_already_held_changes_nothing(void **state)
{
    (void)state;
    int *items = NULL;
    size_t cap = 0;
    assert_int_equal(array_reserve((void **)&items, &cap, 10, sizeof *items, 32), 0);
    int *before = items;
    assert_int_equal(array_reserve((void **)&items, &cap, 32, sizeof *items, 32), 0);
    assert_ptr_equal(items, before);
    assert_int_equal(cap, 32);
    free(items);
}

static void test_unrepresentable_size_fails_intact(void **state)
{
    (void)state;
    double *items = NULL;
    size_t cap = 0;
    assert_int_equal(array_reserve((void **)&items, &cap, 3, sizeof *items, 8), 0);
    items[0] = 1.5;
    double *before = items;
    /* need * elem overflows a size_t: refused before any arithmetic wraps. */
    assert_int_equal(array_reserve((void **)&items, &cap, SIZE_MAX / 4, sizeof *items, 8), -1);
    assert_ptr_equal(items, before);
    assert_int_equal(cap, 8);
    assert_true(items[0] == 1.5);
    free(items);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_first_allocation_takes_first),
        cmocka_unit_test(test_growth_doubles_and_keeps_contents),
        cmocka_unit_test(test_need_already_held_changes_nothing),
        cmocka_unit_test(test_unrepresentable_size_fails_intact),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
