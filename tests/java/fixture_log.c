/* The C half of tests/java/java_test.sh: writes an LCM log of two messages encoded by the
 * generated C code, with values chosen to catch a decoder that gets a type's width, sign,
 * byte order or string encoding wrong: a status_t on FIXTURE_STATUS (extreme integers of
 * every width, doubles that print exactly, a UTF-8 string, worlds with and without shapes)
 * and a LIST reply, admin_reply_t, on FIXTURE_LIST_REPLY. The Java half decodes them with
 * the classes lcm-gen -j made and the test compares the fields with those below.
 *   fixture_log OUT.lcmlog */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <lcm/eventlog.h>

#include "trioct_admin_reply_t.h"
#include "trioct_admin_request_t.h"
#include "trioct_status_t.h"

/* Every string of a world_info_t set (the encoder needs them), the rest as the caller sets. */
static trioct_world_info_t world(char *name, char *daemon)
{
    trioct_world_info_t w;
    memset(&w, 0, sizeof w);
    w.name = name;
    w.daemon = daemon;
    w.source = (char *)"";
    w.accuracy = (char *)"exact";
    w.last_error = (char *)"";
    return w;
}

static int write_event(lcm_eventlog_t *log, int64_t n, const char *channel, void *data, int size)
{
    lcm_eventlog_event_t e;
    memset(&e, 0, sizeof e);
    e.eventnum = n;
    e.timestamp = INT64_C(1700000000000000) + n;
    e.channellen = (int32_t)strlen(channel);
    e.channel = (char *)channel;
    e.datalen = size;
    e.data = data;
    return lcm_eventlog_write_event(log, &e);
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: fixture_log OUT.lcmlog\n");
        return 2;
    }
    char *shapes[] = {(char *)"probe", (char *)"ring"};
    trioct_world_info_t worlds[2];
    worlds[0] = world((char *)"alpha", (char *)"fixtured");
    worlds[0].version = 3;
    worlds[0].source = (char *)"scene [alpha]";
    worlds[0].seed_epsilon = 1e-9;
    worlds[0].effects = TRIOCT_WORLD_INFO_T_EFFECT_RAYS | TRIOCT_WORLD_INFO_T_EFFECT_MESHES;
    worlds[0].triangles = INT64_C(1) << 40;
    worlds[0].bbox_min = (trioct_vec3_t){-0.0, -2.5, -1e300};
    worlds[0].bbox_max = (trioct_vec3_t){0.1, 4.9e-324, 1.7976931348623157e308};
    worlds[0].max_level = 21;
    worlds[0].resolution = 0.125;
    worlds[0].build_seconds = 1.5;
    worlds[0].num_shapes = 2;
    worlds[0].shapes = shapes;
    worlds[1] = world((char *)"beta", (char *)"fixtured");
    worlds[1].accuracy = (char *)"fast";
    worlds[1].last_error = (char *)"line 1\nline \"2\"";

    int64_t replies[3] = {INT64_C(10), 0, INT64_C(-10)};
    trioct_status_t st;
    memset(&st, 0, sizeof st);
    st.utime = INT64_C(1700000000123456);
    st.daemon = (char *)"fixtured";
    st.version = (char *)"9.8.7-\xc3\xa9\xe2\x82\xac"; /* e acute, euro sign */
    st.uptime_us = INT64_MAX;
    st.state = TRIOCT_STATUS_T_STOPPING;
    st.threads = -7;
    st.queue_depth = INT32_MIN;
    st.queue_capacity = INT32_MAX;
    st.memory_used = INT64_MIN;
    st.memory_budget = INT64_C(0x0123456789abcdef);
    for (int i = 0; i < 7; i++)
        st.served[i] = i + 1;
    st.malformed = -1;
    st.num_status_codes = 3;
    st.replies_by_status = replies;
    st.latency_p99_us = 4096;
    st.num_worlds = 2;
    st.worlds = worlds;

    trioct_admin_reply_t list;
    memset(&list, 0, sizeof list);
    list.header.client_id = (int64_t)UINT64_C(0xfedcba9876543210);
    list.header.request_id = 42;
    list.header.daemon = (char *)"fixtured";
    list.header.world = (char *)"";
    list.header.status = -32768;
    list.header.message = (char *)"";
    list.header.chunk_count = 1;
    list.op = TRIOCT_ADMIN_REQUEST_T_LIST;
    list.num_worlds = 2;
    list.worlds = worlds;

    int st_size = trioct_status_t_encoded_size(&st);
    int list_size = trioct_admin_reply_t_encoded_size(&list);
    void *st_buf = malloc((size_t)st_size);
    void *list_buf = malloc((size_t)list_size);
    lcm_eventlog_t *log = lcm_eventlog_create(argv[1], "w");
    int ok = st_buf && list_buf && log && trioct_status_t_encode(st_buf, 0, st_size, &st) == st_size &&
             trioct_admin_reply_t_encode(list_buf, 0, list_size, &list) == list_size &&
             write_event(log, 0, "FIXTURE_STATUS", st_buf, st_size) == 0 &&
             write_event(log, 1, "FIXTURE_LIST_REPLY", list_buf, list_size) == 0;
    if (log)
        lcm_eventlog_destroy(log);
    free(st_buf);
    free(list_buf);
    if (!ok) {
        fprintf(stderr, "fixture_log: could not encode or write %s\n", argv[1]);
        return 1;
    }
    return 0;
}
