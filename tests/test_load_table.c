/* The table of builds under way (server/service/load_table.c): what status reports while a
 * LOAD or a scene build runs. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <time.h>

#include <cmocka.h>

#include "service/load_table.h"

static void test_a_build_is_listed_while_it_runs(void **state)
{
    (void)state;
    load_table t;
    load_table_init(&t);
    load_entry e[4];
    assert_int_equal(load_table_list(&t, e, 4), 0);

    world_progress *p = load_table_begin(&t, "yard", 0x1234, 7);
    assert_non_null(p);
    world_progress *scene = load_table_begin(&t, "cell", 0, 0);
    assert_non_null(scene);
    atomic_store(&p->phase, WORLD_PHASE_BUILDING);
    atomic_store(&p->files_total, 2);
    atomic_store(&p->files_done, 1);
    atomic_store(&p->triangles, 23624);
    struct timespec pause = {0, 20 * 1000 * 1000};
    nanosleep(&pause, NULL);

    assert_int_equal(load_table_list(&t, e, 4), 2);
    const load_entry *yard = strcmp(e[0].world, "yard") == 0 ? &e[0] : &e[1];
    const load_entry *cell = yard == &e[0] ? &e[1] : &e[0];
    assert_string_equal(yard->world, "yard");
    assert_int_equal(yard->client_id, 0x1234);
    assert_int_equal(yard->request_id, 7);
    assert_int_equal(yard->phase, WORLD_PHASE_BUILDING);
    assert_string_equal(world_phase_name(yard->phase), "building octrees");
    assert_int_equal(yard->files_done, 1);
    assert_int_equal(yard->files_total, 2);
    assert_int_equal(yard->triangles, 23624);
    assert_true(yard->elapsed_seconds >= 0.015 && yard->elapsed_seconds < 10);
    assert_string_equal(cell->world, "cell");
    assert_int_equal(cell->client_id, 0);
    assert_string_equal(world_phase_name(cell->phase), "queued");

    /* Only as many as asked are copied; the count says how many there are. */
    assert_int_equal(load_table_list(&t, e, 1), 2);

    load_table_end(&t, p);
    assert_int_equal(load_table_list(&t, e, 4), 1);
    assert_string_equal(e[0].world, "cell");
    load_table_end(&t, scene);
    load_table_end(&t, NULL); /* a build that got no slot */
    assert_int_equal(load_table_list(&t, e, 4), 0);
    load_table_destroy(&t);
}

/* More builds than slots: the one past them runs unreported, and a slot freed is used again. */
static void test_a_full_table_reports_no_more(void **state)
{
    (void)state;
    load_table t;
    load_table_init(&t);
    world_progress *p[LOAD_TABLE_SLOTS];
    for (int i = 0; i < LOAD_TABLE_SLOTS; i++)
        assert_non_null(p[i] = load_table_begin(&t, "w", 1, i));
    assert_null(load_table_begin(&t, "w", 1, 999));
    atomic_store(&p[5]->files_done, 3);
    load_table_end(&t, p[5]);
    world_progress *again = load_table_begin(&t, "again", 1, 1000);
    assert_ptr_equal(again, p[5]);
    assert_int_equal(atomic_load(&again->files_done), 0); /* begun afresh */
    for (int i = 0; i < LOAD_TABLE_SLOTS; i++)
        load_table_end(&t, p[i]);
    load_entry e[1];
    assert_int_equal(load_table_list(&t, e, 1), 0);
    load_table_destroy(&t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_a_build_is_listed_while_it_runs),
        cmocka_unit_test(test_a_full_table_reports_no_more),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
