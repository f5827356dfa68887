/* Channel names in common/channels.c: the protocol's channels formatted and parsed back,
 * the ordered daemon's mark channels, and every invalid prefix or name refused with an
 * empty string rather than a channel LCM would read as a different pattern. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "channels.h"

static void test_protocol_channels_round_trip(void **state)
{
    (void)state;
    static const struct {
        trioct_channel_kind kind;
        const char *name, *channel;
    } cases[] = {
        {TRIOCT_CHANNEL_RAY, "yard", "TRIOCT_RAY_yard"},       {TRIOCT_CHANNEL_TRI, "yard", "TRIOCT_TRI_yard"},
        {TRIOCT_CHANNEL_MESH, "yard", "TRIOCT_MESH_yard"},     {TRIOCT_CHANNEL_ADMIN, "w_2", "TRIOCT_ADMIN_w_2"},
        {TRIOCT_CHANNEL_LOAD, "trioctd", "TRIOCT_LOAD_trioctd"}, {TRIOCT_CHANNEL_LIST, NULL, "TRIOCT_LIST"},
        {TRIOCT_CHANNEL_STATUS, NULL, "TRIOCT_STATUS"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char out[TRIOCT_MAX_CHANNEL_LEN + 1];
        assert_int_equal(trioct_channel_name(out, "TRIOCT", cases[i].kind, cases[i].name), 0);
        assert_string_equal(out, cases[i].channel);
        trioct_channel_kind kind;
        char name[TRIOCT_MAX_NAME_LEN + 1];
        assert_int_equal(trioct_channel_parse(out, "TRIOCT", &kind, name), 0);
        assert_int_equal(kind, cases[i].kind);
        assert_string_equal(name, cases[i].name ? cases[i].name : "");
    }
}

static void test_mark_channels(void **state)
{
    (void)state;
    char out[TRIOCT_MAX_CHANNEL_LEN + 1];
    assert_int_equal(trioct_mark_channel_name(out, "TRIOCT", TRIOCT_MARK_RELOAD, "replayd"), 0);
    assert_string_equal(out, "TRIOCT_RELOAD_replayd");
    assert_int_equal(trioct_mark_channel_name(out, "LAB", TRIOCT_MARK_STOP, "d1"), 0);
    assert_string_equal(out, "LAB_STOP_d1");
    /* Not a protocol channel: a daemon that is not ordered must not take it for one. */
    trioct_channel_kind kind;
    char name[TRIOCT_MAX_NAME_LEN + 1];
    assert_int_equal(trioct_channel_parse(out, "LAB", &kind, name), -1);
}

static void test_invalid_names_make_no_channel(void **state)
{
    (void)state;
    char out[TRIOCT_MAX_CHANNEL_LEN + 1];
    char long_name[TRIOCT_MAX_NAME_LEN + 2];
    memset(long_name, 'a', sizeof long_name - 1);
    long_name[sizeof long_name - 1] = '\0';
    const char *bad[] = {"", "a.b", "x*", "two words", long_name};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        memcpy(out, "junk", 5);
        assert_int_equal(trioct_mark_channel_name(out, "TRIOCT", TRIOCT_MARK_STOP, bad[i]), -1);
        assert_string_equal(out, "");
        memcpy(out, "junk", 5);
        assert_int_equal(trioct_mark_channel_name(out, bad[i], TRIOCT_MARK_RELOAD, "d"), -1);
        assert_string_equal(out, "");
        memcpy(out, "junk", 5);
        assert_int_equal(trioct_channel_name(out, "TRIOCT", TRIOCT_CHANNEL_RAY, bad[i]), -1);
        assert_string_equal(out, "");
    }
    assert_int_equal(trioct_mark_channel_name(out, "TRIOCT", (trioct_mark_kind)7, "d"), -1);
    assert_int_equal(trioct_channel_name(out, "TRIOCT", TRIOCT_CHANNEL_KIND_COUNT, "d"), -1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_protocol_channels_round_trip),
        cmocka_unit_test(test_mark_channels),
        cmocka_unit_test(test_invalid_names_make_no_channel),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
