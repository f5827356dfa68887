/* The replay tool and the checked-in logs of tests/logs (docs/replay.md).
 *
 *   compare:     mismatches printed as decoded fields, chunks compared after reassembly,
 *                the wall-clock parts of a reply written the same way on both sides;
 *   reproducible: tools/replay/make_logs.sh run again gives tests/logs byte for byte (the
 *                generator's request logs, and golden logs recorded at 4 threads);
 *   replay:      every log replayed offline at 1 and at 4 threads matches its golden log,
 *                with exact counts, and the golden logs hold exactly the statuses each log
 *                is meant to provoke; so do the logs kept in tests/logs/recorded/;
 *   detects:     a world that moved a millimetre, a golden log with one answer changed by
 *                one ulp, a reply dropped, or a reply to nobody added makes the replay fail,
 *                saying which field;
 *   hostile:     logs that are no logs, cut short, or carry damaged replies fail cleanly;
 *   live:        one log over udpm with lcm-logplayer and lcm-logger, inside netns.sh.
 *
 * Run from the repository root (make test does); the tools come from this program's build
 * directory. */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmocka.h>

#include "../tools/replay/replay_book.h"
#include "../tools/replay/replay_classify.h"
#include "../tools/replay/replay_compare.h"
#include "../tools/replay/replay_log.h"
#include "../tools/replay/replay_match.h"
#include "trioct_object_reply_t.h"
#include "trioct_state_reply_t.h"
#include "trioct_ray_reply_t.h"
#include "trioct_ray_request_t.h"
#include "trioct_status.h"
#include "trioct_status_t.h"

#define LOGS "tests/logs"

static char build_dir[512];

/* ---------- running the tools ---------- */

typedef struct run_result {
    int status; /* exit status, or -1 */
    char *out;  /* stdout and stderr */
} run_result;

static run_result run(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static run_result run(const char *fmt, ...)
{
    char cmd[4096];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(cmd, sizeof cmd, fmt, ap);
    va_end(ap);
    strncat(cmd, " 2>&1", sizeof cmd - strlen(cmd) - 1);
    run_result r = {-1, NULL};
    size_t len = 0;
    FILE *out = open_memstream(&r.out, &len);
    FILE *p = popen(cmd, "r");
    assert_non_null(out);
    assert_non_null(p);
    char buf[4096];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, p)) > 0)
        fwrite(buf, 1, n, out);
    int st = pclose(p);
    fclose(out);
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    return r;
}

static void expect_line(const run_result *r, const char *line)
{
    size_t n = strlen(line);
    for (const char *p = r->out; (p = strstr(p, line)) != NULL; p++)
        if ((p == r->out || p[-1] == '\n') && (p[n] == '\n' || p[n] == '\0'))
            return;
    fail_msg("no line \"%s\" in:\n%s", line, r->out);
}

static void expect_status(const run_result *r, int status)
{
    if (r->status != status)
        fail_msg("exit status %d, expected %d; output:\n%s", r->status, status, r->out);
}

/* ---------- scratch ---------- */

static void scratch_make(char *dir, size_t len)
{
    snprintf(dir, len, "/tmp/trioct_test_replay_XXXXXX");
    assert_non_null(mkdtemp(dir));
}

static void scratch_remove(const char *dir)
{
    run_result r = run("rm -rf '%s'", dir);
    free(r.out);
}

static void copy_file(const char *from, const char *to)
{
    run_result r = run("cp '%s' '%s'", from, to);
    expect_status(&r, 0);
    free(r.out);
}

/* ---------- building logs in memory ---------- */

typedef struct mem_log {
    replay_event ev[16];
    size_t n;
} mem_log;

static void add(mem_log *m, const char *channel, const void *data, size_t size)
{
    assert_true(m->n < 16);
    replay_event *e = &m->ev[m->n++];
    e->timestamp = (int64_t)m->n;
    e->channel = strdup(channel);
    e->data = malloc(size + 1);
    memcpy(e->data, data, size);
    e->size = size;
}

static void mem_free(mem_log *m)
{
    for (size_t i = 0; i < m->n; i++) {
        free(m->ev[i].channel);
        free(m->ev[i].data);
    }
    m->n = 0;
}

static void add_ray_request(mem_log *m, int64_t client, int64_t id, int n)
{
    trioct_vec3_t o[8], d[8];
    for (int i = 0; i < n; i++) {
        o[i] = (trioct_vec3_t){i, 0, 10};
        d[i] = (trioct_vec3_t){0, 0, -1};
    }
    trioct_ray_request_t q;
    memset(&q, 0, sizeof q);
    q.header.client_id = client;
    q.header.request_id = id;
    q.header.reply_channel = "ME";
    q.header.world = "yard";
    q.detail = TRIOCT_RAY_REQUEST_T_CLOSEST;
    q.tmax = INFINITY;
    q.max_hits = 1;
    q.num_rays = n;
    q.origin = o;
    q.direction = d;
    uint8_t buf[2048];
    int len = trioct_ray_request_t_encode(buf, 0, sizeof buf, &q);
    assert_true(len > 0);
    add(m, "TRIOCT_RAY_yard", buf, (size_t)len);
}

/* A reply to a request of n rays, each hitting at t = ray + 0.5 except `odd`, hitting at
 * odd_t; hits [from, to) in chunk `chunk` of `chunks`. */
/* The detail the next replies echo, and a ray that they report as missed (-1: none). */
static int8_t reply_detail = TRIOCT_RAY_REQUEST_T_CLOSEST;
static int reply_miss = -1;

static void add_ray_reply(mem_log *m, int64_t client, int64_t id, int n, int odd, double odd_t, int from,
                          int to, int chunk, int chunks)
{
    int32_t found[8];
    trioct_ray_hit_t hits[8];
    int k = 0; /* the missed ray has no hit record: the hits after it move up one */
    for (int i = 0; i < n; i++) {
        found[i] = i != reply_miss;
        if (i == reply_miss)
            continue;
        memset(&hits[k], 0, sizeof hits[k]);
        hits[k].ray = i;
        hits[k].t = i == odd ? odd_t : i + 0.5;
        hits[k].triangle = 100 + i;
        hits[k].normal = (trioct_vec3_t){0, 0, 1};
        k++;
    }
    trioct_ray_reply_t r;
    memset(&r, 0, sizeof r);
    r.header.client_id = client;
    r.header.request_id = id;
    r.header.daemon = "replayd";
    r.header.world = "yard";
    r.header.world_version = 1;
    r.header.message = "ok";
    r.header.chunk_index = chunk;
    r.header.chunk_count = chunks;
    r.detail = reply_detail;
    r.num_rays = chunk == 0 ? n : 0;
    r.found = found;
    r.num_hits = to - from;
    r.hits = hits + from;
    uint8_t buf[4096];
    int len = trioct_ray_reply_t_encode(buf, 0, sizeof buf, &r);
    assert_true(len > 0);
    add(m, "ME", buf, (size_t)len);
}

static void book_of(replay_book *b, mem_log *m, replay_log *view)
{
    replay_proto p;
    assert_int_equal(replay_proto_init(&p, "TRIOCT", "replayd"), 0);
    view->events = m->ev;
    view->count = m->n;
    view->truncated = 0;
    char err[128];
    assert_int_equal(replay_book_build(b, view, &p, err, sizeof err), 0);
}

/* ---------- compare ---------- */

static void test_format_and_canon(void **state)
{
    (void)state;
    char buf[64];
    replay_format_double(2.5, buf, sizeof buf);
    assert_string_equal(buf, "2.5");
    replay_format_double(nextafter(2.5, 3), buf, sizeof buf);
    assert_string_equal(buf, "2.5000000000000004");
    replay_format_double(0.1, buf, sizeof buf);
    assert_string_equal(buf, "0.1");
    replay_format_double(1.0 / 3, buf, sizeof buf);
    assert_string_equal(buf, "0.3333333333333333");
    replay_format_double(-0.0, buf, sizeof buf);
    assert_string_equal(buf, "-0");

    char out[256];
    replay_canon_text(TRIOCT_ERR_DEADLINE, "deadline_utime 1 passed 1795301386904461 us before the work could start",
                      NULL, out, sizeof out);
    assert_string_equal(out, "deadline_utime 1 passed N us before the work could start");
    replay_canon_text(TRIOCT_ERR_DEADLINE, out, NULL, out, sizeof out); /* already canonical */
    assert_string_equal(out, "deadline_utime 1 passed N us before the work could start");
    replay_canon_text(TRIOCT_OK, "passed 12 us", NULL, out, sizeof out); /* only DEADLINE's */
    assert_string_equal(out, "passed 12 us");
    replay_canon_text(TRIOCT_ERR_LOAD_FAILED, "world 'x': cannot load /srv/w/a.obj: bad; /srv/wx/b.obj", "/srv/w",
                      out, sizeof out);
    assert_string_equal(out, "world 'x': cannot load ./a.obj: bad; /srv/wx/b.obj");
}

static void test_compare_names_the_field(void **state)
{
    (void)state;
    mem_log script = {0}, golden = {0}, got = {0};
    add_ray_request(&script, 0x2a, 17, 5);
    add_ray_reply(&golden, 0x2a, 17, 5, 3, 2.5, 0, 5, 0, 1);
    add_ray_reply(&got, 0x2a, 17, 5, 3, nextafter(2.5, 3), 0, 5, 0, 1);
    replay_log vs, vg, vo;
    replay_book bs, bg, bo;
    book_of(&bs, &script, &vs);
    book_of(&bg, &golden, &vg);
    book_of(&bo, &got, &vo);

    char *text = NULL;
    size_t len = 0;
    FILE *out = open_memstream(&text, &len);
    replay_counts c;
    replay_rules rules = {0, NULL};
    assert_int_equal(replay_match(&bs, &bg, &bo, &rules, 20, 0, out, &c), 0);
    fclose(out);
    assert_string_equal(text, "request 17 (client 0x2a, ray_request_t on TRIOCT_RAY_yard): ray 3: t expected 2.5 "
                              "got 2.5000000000000004\n");
    assert_int_equal(c.requests, 1);
    assert_int_equal(c.matched, 0);
    assert_int_equal(c.mismatched, 1);
    assert_false(replay_counts_pass(&c));
    free(text);
    replay_book_free(&bo);
    replay_book_free(&bg);
    replay_book_free(&bs);
    mem_free(&script);
    mem_free(&golden);
    mem_free(&got);
}

/* Replays a one-request script against golden and got; returns the mismatch count and
 * the differences printed in *text (the caller frees it). */
static size_t mismatches_between(mem_log *script, mem_log *golden, mem_log *got, char **text)
{
    replay_log vs, vg, vo;
    replay_book bs, bg, bo;
    book_of(&bs, script, &vs);
    book_of(&bg, golden, &vg);
    book_of(&bo, got, &vo);
    size_t len = 0;
    FILE *out = open_memstream(text, &len);
    replay_counts c;
    replay_rules rules = {0, NULL};
    replay_match(&bs, &bg, &bo, &rules, 20, 0, out, &c);
    fclose(out);
    replay_book_free(&bo);
    replay_book_free(&bg);
    replay_book_free(&bs);
    return c.mismatched;
}

/* An any-hit answer promises a hit when there is one, not which: another hit of the same
 * ray matches, a miss does not; a closest answer is compared field by field. */
static void test_any_hit_compared_by_whether_it_hit(void **state)
{
    (void)state;
    mem_log script = {0}, golden = {0}, other_hit = {0}, missed = {0}, closest_golden = {0}, closest_other = {0};
    add_ray_request(&script, 0x2a, 17, 5);
    reply_detail = TRIOCT_RAY_REQUEST_T_ANY;
    add_ray_reply(&golden, 0x2a, 17, 5, -1, 0, 0, 5, 0, 1);
    add_ray_reply(&other_hit, 0x2a, 17, 5, 3, 7.25, 0, 5, 0, 1);
    reply_miss = 3;
    add_ray_reply(&missed, 0x2a, 17, 5, 3, 7.25, 0, 4, 0, 1);
    reply_miss = -1;
    reply_detail = TRIOCT_RAY_REQUEST_T_CLOSEST;
    add_ray_reply(&closest_golden, 0x2a, 17, 5, -1, 0, 0, 5, 0, 1);
    add_ray_reply(&closest_other, 0x2a, 17, 5, 3, 7.25, 0, 5, 0, 1);
    char *text = NULL;
    assert_int_equal(mismatches_between(&script, &golden, &other_hit, &text), 0);
    assert_string_equal(text, "");
    free(text);
    assert_int_equal(mismatches_between(&script, &golden, &missed, &text), 1);
    assert_non_null(strstr(text, "ray 3: found expected 1 got 0"));
    free(text);
    assert_int_equal(mismatches_between(&script, &closest_golden, &closest_other, &text), 1);
    assert_non_null(strstr(text, "ray 3: t expected 3.5 got 7.25"));
    free(text);
    mem_free(&script);
    mem_free(&golden);
    mem_free(&other_hit);
    mem_free(&missed);
    mem_free(&closest_golden);
    mem_free(&closest_other);
}

static void test_chunks_compared_after_reassembly(void **state)
{
    (void)state;
    mem_log script = {0}, golden = {0}, got = {0};
    add_ray_request(&script, 7, 1, 5);
    add_ray_request(&script, 8, 1, 5); /* another client, the same request id */
    add_ray_request(&script, 7, 2, 5);
    /* Golden: whole replies. Got: the same cut in two chunks, arriving last chunk first,
     * the two clients' replies interleaved; and request 2 cut in two with chunk 1 lost. */
    add_ray_reply(&golden, 7, 1, 5, -1, 0, 0, 5, 0, 1);
    add_ray_reply(&golden, 8, 1, 5, 2, 9.25, 0, 5, 0, 1);
    add_ray_reply(&golden, 7, 2, 5, -1, 0, 0, 5, 0, 1);
    add_ray_reply(&got, 8, 1, 5, 2, 9.25, 3, 5, 1, 2);
    add_ray_reply(&got, 7, 1, 5, -1, 0, 2, 5, 1, 2);
    add_ray_reply(&got, 8, 1, 5, 2, 9.25, 0, 3, 0, 2);
    add_ray_reply(&got, 7, 1, 5, -1, 0, 0, 2, 0, 2);
    add_ray_reply(&got, 7, 2, 5, -1, 0, 0, 2, 0, 2);
    /* And a reply nobody asked for. */
    add_ray_reply(&got, 7, 99, 5, -1, 0, 0, 5, 0, 1);
    replay_log vs, vg, vo;
    replay_book bs, bg, bo;
    book_of(&bs, &script, &vs);
    book_of(&bg, &golden, &vg);
    book_of(&bo, &got, &vo);
    assert_int_equal(bo.reply_count, 4);

    char *text = NULL;
    size_t len = 0;
    FILE *out = open_memstream(&text, &len);
    replay_counts c;
    replay_rules rules = {0, NULL};
    assert_int_equal(replay_match(&bs, &bg, &bo, &rules, 20, 0, out, &c), 0);
    fclose(out);
    assert_string_equal(text,
                        "request 2 (client 0x7, ray_request_t on TRIOCT_RAY_yard): the reply is damaged: 1 of 2 "
                        "chunks never came (chunk 1)\n"
                        "request 2 (client 0x7, ray_request_t on TRIOCT_RAY_yard): ray 2: 1 hits expected, got 0\n"
                        "request 2 (client 0x7, ray_request_t on TRIOCT_RAY_yard): ray 3: 1 hits expected, got 0\n"
                        "request 2 (client 0x7, ray_request_t on TRIOCT_RAY_yard): ray 4: 1 hits expected, got 0\n"
                        "reply to request 99 (client 0x7), which no request of the log asked: OK, 5 items, 5 "
                        "records in 1 chunk, on ME\n");
    assert_int_equal(c.matched, 2);
    assert_int_equal(c.mismatched, 1);
    assert_int_equal(c.missing, 0);
    assert_int_equal(c.extra, 1);
    assert_int_equal(c.to_nobody, 1);
    free(text);
    replay_book_free(&bo);
    replay_book_free(&bg);
    replay_book_free(&bs);
    mem_free(&script);
    mem_free(&golden);
    mem_free(&got);
}

/* ---------- the checked-in logs ---------- */

typedef struct log_case {
    const char *name;
    const char *scene;
    const char *counts; /* the summary line of a passing replay */
    /* Replies in the golden log by status code, 0..TRIOCT_WIRE_STATUS_COUNT-1. */
    int by_status[TRIOCT_WIRE_STATUS_COUNT];
} log_case;

/* OK, BAD_REQUEST, UNKNOWN_WORLD, NONFINITE, ZERO_DIRECTION, OVER_CAP, EFFECT, BAD_PATH,
 * DEADLINE, BUSY, LOAD_FAILED, STOPPING, UNKNOWN_SHAPE, NOMEM, UNKNOWN_OBJECT,
 * OBJECT_EXISTS, BAD_POSE, BUDGET, DENIED */
static const log_case cases[] = {
    {"queries", "scene.ini", "requests 29 (0 malformed), replies 29: 29 matched, 0 mismatched, 0 missing, 0 extra (0 to nobody)",
     {29}},
    {"chunked", "scene.ini", "requests 3 (0 malformed), replies 3: 3 matched, 0 mismatched, 0 missing, 0 extra (0 to nobody)",
     {3}},
    {"burst", "scene.ini", "requests 144 (0 malformed), replies 144: 144 matched, 0 mismatched, 0 missing, 0 extra (0 to nobody)",
     {126, 0, 0, 0, 0, 0, 18}},
    {"admin", "scene.ini", "requests 40 (0 malformed), replies 38: 38 matched, 0 mismatched, 0 missing, 0 extra (0 to nobody)",
     {17, 7, 3, 1, 0, 0, 1, 3, 1, 0, 2, 0, 0, 0, 0, 0, 0, 1, 2}},
    {"reload", "scene.ini", "requests 12 (0 malformed), replies 12: 12 matched, 0 mismatched, 0 missing, 0 extra (0 to nobody)",
     {11, 0, 1}},
    {"busy", "busy.ini", "requests 30 (0 malformed), replies 30: 30 matched, 0 mismatched, 0 missing, 0 extra (0 to nobody)",
     {8, 0, 0, 0, 0, 0, 0, 0, 0, 22}},
    {"errors", "scene.ini", "requests 29 (0 malformed), replies 29: 29 matched, 0 mismatched, 0 missing, 0 extra (0 to nobody)",
     {1, 10, 0, 6, 2, 2, 3, 0, 3, 0, 0, 0, 2}},
    {"overcap", "scene.ini", "requests 3 (0 malformed), replies 3: 3 matched, 0 mismatched, 0 missing, 0 extra (0 to nobody)",
     {0, 0, 0, 0, 0, 3}},
    {"hostile", "scene.ini", "requests 52 (29 malformed), replies 18: 18 matched, 0 mismatched, 0 missing, 0 extra (0 to nobody)",
     {18}},
    {"stopping", "scene.ini", "requests 21 (1 malformed), replies 19: 19 matched, 0 mismatched, 0 missing, 0 extra (0 to nobody)",
     {7, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 12}},
    {"touch", "scene.ini", "requests 10 (0 malformed), replies 10: 10 matched, 0 mismatched, 0 missing, 0 extra (0 to nobody)",
     {8, 2}},
    {"objects", "scene.ini", "requests 48 (0 malformed), replies 48: 48 matched, 0 mismatched, 0 missing, 0 extra (0 to nobody)",
     {33, 4, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 1, 0, 2, 1, 3}},
    {"distance", "scene.ini", "requests 20 (0 malformed), replies 20: 20 matched, 0 mismatched, 0 missing, 0 extra (0 to nobody)",
     {16, 1, 0, 2, 0, 0, 1}},
};
#define CASES (sizeof cases / sizeof cases[0])

static void golden_path(char *out, size_t len, const log_case *c)
{
    snprintf(out, len, LOGS "/%s.golden.lcmlog", c->name);
}

static run_result check(const log_case *c, const char *golden, int threads, const char *extra)
{
    return run("%s/trioct-replay check --threads %d --daemon %s/trioctd --scene " LOGS "/%s --golden %s %s "
               LOGS "/%s.lcmlog",
               build_dir, threads, build_dir, c->scene, golden, extra, c->name);
}

static void test_logs_reproducible(void **state)
{
    (void)state;
    char dir[64];
    scratch_make(dir, sizeof dir);
    run_result r = run("sh tools/replay/make_logs.sh %s %s", build_dir, dir);
    expect_status(&r, 0);
    free(r.out);
    /* The same names, the same bytes: nothing stale, nothing edited by hand. */
    r = run("diff -r -x recorded " LOGS " %s && echo identical", dir);
    expect_status(&r, 0);
    expect_line(&r, "identical");
    free(r.out);
    scratch_remove(dir);
}

static void test_replay_every_log_at_1_and_4_threads(void **state)
{
    (void)state;
    for (size_t i = 0; i < CASES; i++) {
        char golden[256];
        golden_path(golden, sizeof golden, &cases[i]);
        for (int threads = 1; threads <= 4; threads += 3) {
            run_result r = check(&cases[i], golden, threads, "");
            expect_status(&r, 0);
            expect_line(&r, cases[i].counts);
            free(r.out);
        }
    }
}

static void test_goldens_hold_the_statuses_meant(void **state)
{
    (void)state;
    int seen[TRIOCT_WIRE_STATUS_COUNT] = {0};
    for (size_t i = 0; i < CASES; i++) {
        const log_case *c = &cases[i];
        char golden[256], scene[256], err[512];
        golden_path(golden, sizeof golden, c);
        snprintf(scene, sizeof scene, LOGS "/%s", c->scene);
        replay_proto p;
        replay_log log;
        replay_book b;
        assert_int_equal(replay_proto_from_scene(&p, scene, err, sizeof err), 0);
        assert_int_equal(replay_log_read(golden, &log, err, sizeof err), 0);
        assert_int_equal(replay_book_build(&b, &log, &p, err, sizeof err), 0);
        int by_status[TRIOCT_WIRE_STATUS_COUNT] = {0};
        for (size_t k = 0; k < b.reply_count; k++) {
            assert_string_equal(b.replies[k].problem, "");
            int st = b.replies[k].header->status;
            assert_true(st >= 0 && st < TRIOCT_WIRE_STATUS_COUNT);
            by_status[st]++;
            seen[st]++;
        }
        for (int st = 0; st < TRIOCT_WIRE_STATUS_COUNT; st++)
            if (by_status[st] != c->by_status[st])
                fail_msg("%s: %d replies %s, expected %d", c->name, by_status[st], trioct_status_name(st),
                         c->by_status[st]);
        replay_book_free(&b);
        replay_log_free(&log);
    }
    /* Every status a request can get without timing (STOPPING through the stop mark); NOMEM
     * needs an exhausted machine. */
    for (int st = 0; st < TRIOCT_WIRE_STATUS_COUNT; st++)
        if (st != TRIOCT_ERR_NOMEM && seen[st] == 0)
            fail_msg("no log provokes %s", trioct_status_name(st));
}

/* The touch log's golden answers say what the contact rule promises (tools/replay/
 * logs_touch.c): rays 0-2 graze a crate (slide along its top, a corner, an edge) and ray 3
 * goes straight through two. As crossings (requests 1-3; 1 in ray_request_v1_t) the first
 * two are clear; as touches (4-6) all four are blocked, at t = 3, 0.5, 1 and 2, and ALL
 * lists at least the crossings; ray 4 misses either way. */
static void test_touch_golden_blocks_grazing_rays(void **state)
{
    (void)state;
    char err[512];
    replay_proto p;
    replay_log log;
    replay_book b;
    assert_int_equal(replay_proto_from_scene(&p, LOGS "/scene.ini", err, sizeof err), 0);
    assert_int_equal(replay_log_read(LOGS "/touch.golden.lcmlog", &log, err, sizeof err), 0);
    assert_int_equal(replay_book_build(&b, &log, &p, err, sizeof err), 0);
    const replay_reply *r[8];
    for (int id = 1; id <= 7; id++) {
        size_t n;
        r[id] = replay_book_replies(&b, 0x70, id, &n);
        assert_non_null(r[id]);
        assert_int_equal(n, 1);
        assert_int_equal(r[id]->header->status, TRIOCT_OK);
        assert_int_equal(r[id]->num_items, 5);
    }
    assert_int_equal(replay_book_request(&b, 0x70, 1)->type, WIRE_RAY_REQUEST_V1);
    assert_int_equal(replay_book_request(&b, 0x70, 2)->type, WIRE_RAY_REQUEST);
    for (int ray = 0; ray < 5; ray++) {
        assert_int_equal(r[1]->found[ray], r[2]->found[ray]); /* the old type is CROSSING */
        assert_int_equal(r[4]->found[ray], ray < 4);           /* touch ANY: blocked */
        assert_true(r[6]->found[ray] >= r[2]->found[ray]);     /* touch ALL covers crossings */
    }
    assert_int_equal(r[3]->found[0], 0);
    assert_int_equal(r[3]->found[1], 0);
    static const double first_t[4] = {3, 0.5, 1, 2};
    for (size_t k = 0; k < r[5]->num_records; k++) {
        const trioct_ray_hit_t *h = r[5]->records[k];
        assert_true(h->t == first_t[h->ray]);
    }
    assert_int_equal(r[5]->num_records, 4);
    assert_int_equal(r[7]->found[0], 0); /* tmax one ulp before the first contact */
    replay_book_free(&b);
    replay_log_free(&log);
}


/* The object names a query reply's records give, each once: what the records name. */
static int names_object(const replay_reply *r, const char *name)
{
    for (int32_t k = 0; k < r->num_names; k++)
        if (strcmp(r->names[k], name) == 0)
            return 1;
    return 0;
}

static const trioct_object_info_t *listed(const replay_reply *r, const char *name)
{
    for (size_t k = 0; k < r->num_records; k++) {
        const trioct_object_info_t *o = r->records[k];
        if (strcmp(o->name, name) == 0)
            return o;
    }
    return NULL;
}

/* The objects log's golden answers follow its edits (tools/replay/logs_objects.c): each
 * applied list makes the next version, every query answers on the version the edits before
 * it made, the adds share the crates' tree, a removed object is never named again, and
 * every failed list, the one whose second edit fails included, leaves the world as it was. */
static void test_objects_golden_follows_the_edits(void **state)
{
    (void)state;
    char err[512];
    replay_proto p;
    replay_log log;
    replay_book b;
    assert_int_equal(replay_proto_from_scene(&p, LOGS "/scene.ini", err, sizeof err), 0);
    assert_int_equal(replay_log_read(LOGS "/objects.golden.lcmlog", &log, err, sizeof err), 0);
    assert_int_equal(replay_book_build(&b, &log, &p, err, sizeof err), 0);
    const replay_reply *r[49] = {0};
    for (int id = 1; id <= 48; id++) {
        size_t n;
        r[id] = replay_book_replies(&b, 0x80, id, &n);
        assert_non_null(r[id]);
        assert_int_equal(n, 1);
    }
    /* The scene's three objects, the crates twice over one tree. */
    assert_int_equal(r[1]->header->status, TRIOCT_OK);
    assert_int_equal(r[1]->num_records, 3);
    assert_int_equal(listed(r[1], "crate_a")->shared, 2);
    assert_int_equal(listed(r[1], "floor")->shared, 1);
    assert_true(listed(r[1], "crate_b")->pose.t.z == 4);
    /* Versions: 1, then one per applied list; the queries between on the version before. */
    static const int version_after[] = {1, 2, 3, 4};
    for (int step = 0; step < 4; step++) {
        int edit = 1 + 5 * step; /* the edit (or listing) before each block of four queries */
        assert_int_equal(r[edit]->header->status, TRIOCT_OK);
        assert_int_equal(r[edit]->header->world_version, version_after[step]);
        for (int k = 1; k <= 4; k++) {
            assert_int_equal(r[edit + k]->header->status, TRIOCT_OK);
            assert_int_equal(r[edit + k]->header->world_version, version_after[step]);
        }
    }
    /* The move changed the answers; the adds are listed, sharing the crates' tree. */
    int moved = 0;
    for (size_t k = 0; k < r[2]->num_records && k < r[7]->num_records; k++) {
        const trioct_ray_hit_t *a = r[2]->records[k], *c = r[7]->records[k];
        moved += a->t != c->t;
    }
    assert_true(moved > 0);
    assert_int_equal(r[11]->num_records, 5);
    assert_int_equal(listed(r[11], "crate_c")->shared, 3);
    assert_string_equal(listed(r[11], "box.1")->mesh, "inline");
    assert_int_equal(listed(r[11], "box.1")->triangles, 12);
    /* Removed: crate_a is named by no query answered after it. */
    for (int id = 17; id <= 34; id++)
        if (r[id]->type != WIRE_OBJECT_REPLY)
            assert_false(names_object(r[id], "crate_a"));
    assert_true(names_object(r[2], "crate_a"));
    /* Every error names its edit and leaves version 4 serving. */
    static const int errors[9] = {TRIOCT_ERR_UNKNOWN_OBJECT, TRIOCT_ERR_OBJECT_EXISTS, TRIOCT_ERR_BAD_POSE,
                                  TRIOCT_ERR_BAD_PATH,       TRIOCT_ERR_LOAD_FAILED,   TRIOCT_ERR_BAD_REQUEST,
                                  TRIOCT_ERR_NONFINITE,      TRIOCT_ERR_BAD_REQUEST,   TRIOCT_ERR_UNKNOWN_OBJECT};
    for (int i = 0; i < 9; i++) {
        const replay_reply *e = r[21 + i];
        const trioct_object_reply_t *m = e->chunk[0];
        assert_int_equal(e->header->status, errors[i]);
        assert_int_equal(e->header->world_version, 4);
        assert_int_equal(m->failed_edit, i == 8 ? 1 : 0);
        assert_int_equal(m->objects, 4);
    }
    /* All or none: crate_b is where the move before the failing list put it. */
    const trioct_object_info_t *b30 = listed(r[30], "crate_b");
    assert_non_null(b30);
    assert_true(b30->pose.t.x == 1 && b30->pose.t.y == 1 && b30->pose.t.z == 0.25);
    assert_null(listed(r[30], "crate_a"));
    /* The moved world refuses seed mode; the fast world refuses edits; a plain section moves
     * as the one object named after it. */
    assert_int_equal(r[35]->header->status, TRIOCT_ERR_BAD_REQUEST);
    assert_int_equal(r[36]->header->status, TRIOCT_ERR_BAD_REQUEST);
    assert_int_equal(((const trioct_object_reply_t *)r[36]->chunk[0])->failed_edit, -1);
    assert_int_equal(r[37]->header->status, TRIOCT_OK);
    assert_string_equal(((const trioct_object_info_t *)r[37]->records[0])->name, "yard");
    assert_int_equal(r[38]->num_names, 1);
    assert_string_equal(r[38]->names[0], "yard");

    /* States: the verdicts agree with the contact lists; allowed pairs never appear; with
     * self-collision the finger inside the hand is a link-link contact. */
    int invalid = 0;
    for (int s = 0; s < 12; s++) {
        assert_true(r[39]->found[s] <= 1);
        assert_int_equal(r[39]->found[s] == 0, r[40]->found[s] == 0);
        invalid += r[39]->found[s] != 0;
    }
    assert_true(invalid > 0 && invalid < 12);
    int self = 0;
    for (size_t k = 0; k < r[41]->num_records; k++) {
        const trioct_state_contact_t *c = r[41]->records[k];
        if (c->with_link) {
            self++;
            continue;
        }
        const char *other = r[41]->names[c->other];
        assert_false(c->link == 0 && strcmp(other, "floor") == 0);   /* hand:floor allowed */
        assert_false(c->link == 1 && strcmp(other, "crate_b") == 0); /* crate_b:finger allowed */
    }
    assert_true(self > 0);
    assert_int_equal(r[42]->header->status, TRIOCT_ERR_UNKNOWN_SHAPE);
    assert_int_equal(r[43]->header->status, TRIOCT_ERR_BAD_POSE);
    assert_int_equal(r[44]->header->status, TRIOCT_ERR_EFFECT);

    /* A quaternion on the wire: the daemon's matrix of a quarter turn about z, the version
     * after it; one of length 2 refused; states turned by quaternions answered. */
    assert_int_equal(r[45]->header->status, TRIOCT_OK);
    assert_int_equal(r[45]->header->world_version, 5);
    const trioct_object_info_t *turned = listed(r[45], "crate_b");
    assert_true(fabs(turned->pose.r[0]) < 1e-15 && fabs(turned->pose.r[1] + 1) < 1e-15 &&
                fabs(turned->pose.r[3] - 1) < 1e-15 && turned->pose.r[8] == 1);
    assert_int_equal(r[46]->header->status, TRIOCT_ERR_BAD_POSE);
    assert_non_null(strstr(r[46]->header->message, "quaternion"));
    assert_int_equal(r[47]->header->status, TRIOCT_OK);
    assert_int_equal(r[47]->num_items, 2);
    assert_int_equal(r[48]->header->world_version, 5);
    replay_book_free(&b);
    replay_log_free(&log);
}

/* Under CI (CI=true) or as root nothing this program needs is missing, so what would be a
 * skip elsewhere is a failure there. */
static int skips_are_failures(void)
{
    const char *ci = getenv("CI");
    return (ci != NULL && strcmp(ci, "true") == 0) || geteuid() == 0;
}

/* Skips the test, saying why, or fails it where skips are failures. */
#define SKIP_OR_FAIL(...)                                                                          \
    do {                                                                                           \
        if (skips_are_failures())                                                                  \
            fail_msg(__VA_ARGS__);                                                                 \
        print_message(__VA_ARGS__);                                                                \
        print_message("\n");                                                                       \
        skip();                                                                                    \
    } while (0)

/* Logs recorded from a live system and kept as regression tests (docs/replay.md): every
 * tests/logs/recorded/NAME.lcmlog, against NAME.golden.lcmlog when there is one, and
 * always against the replies the live daemon gave, which the log holds; with NAME.ini or
 * scene.ini and the meshes there. live.lcmlog is one, made by tools/replay/record_live.sh. */
static void test_recorded_logs(void **state)
{
    (void)state;
    run_result r = run("cd " LOGS "/recorded 2>/dev/null && ls *.lcmlog | grep -v '[.]golden[.]lcmlog$'");
    if (r.status != 0) {
        free(r.out);
        SKIP_OR_FAIL("no recorded logs in " LOGS "/recorded/ (tools/replay/record_live.sh makes one)");
    }
    int replayed = 0;
    char *save = NULL;
    for (char *name = strtok_r(r.out, "\n", &save); name != NULL; name = strtok_r(NULL, "\n", &save)) {
        char base[256], golden[512], scene[512];
        snprintf(base, sizeof base, "%.*s", (int)(strlen(name) - strlen(".lcmlog")), name);
        snprintf(golden, sizeof golden, LOGS "/recorded/%s.golden.lcmlog", base);
        snprintf(scene, sizeof scene, LOGS "/recorded/%s.ini", base);
        if (access(scene, R_OK) != 0)
            snprintf(scene, sizeof scene, LOGS "/recorded/scene.ini");
        const int has_golden = access(golden, R_OK) == 0;
        for (int threads = 1; threads <= 4; threads += 3)
            for (int against_golden = has_golden; against_golden >= 0; against_golden--) {
                run_result c = run("%s/trioct-replay check --threads %d --daemon %s/trioctd --scene %s %s%s " LOGS
                                   "/recorded/%s",
                                   build_dir, threads, build_dir, scene, against_golden ? "--golden " : "",
                                   against_golden ? golden : "", name);
                if (c.status != 0)
                    fail_msg("%s at %d threads, against %s:\n%s", name, threads,
                             against_golden ? "its golden log" : "its live replies", c.out);
                free(c.out);
                replayed++;
            }
    }
    free(r.out);
    printf("recorded logs: %d replays matched\n", replayed);
    assert_true(replayed > 0);
}

/* ---------- a changed golden log must fail ---------- */

/* Copies queries.golden.lcmlog to path, with the hit of ray 3 in the reply to request 1
 * one ulp further; *was and *now get the two t values. */
static void write_nudged_golden(const char *path, double *was, double *now)
{
    replay_log log;
    char err[512];
    assert_int_equal(replay_log_read(LOGS "/queries.golden.lcmlog", &log, err, sizeof err), 0);
    replay_proto p;
    assert_int_equal(replay_proto_init(&p, "TRIOCT", "replayd"), 0);
    int done = 0;
    for (size_t i = 0; i < log.count && !done; i++) {
        replay_class c;
        replay_classify(&p, &log.events[i], &c);
        if (c.kind != KIND_REPLY || c.request_id != 1)
            continue;
        trioct_ray_reply_t m;
        assert_int_equal(trioct_ray_reply_t_decode(log.events[i].data, 0, (int)log.events[i].size, &m),
                         (int)log.events[i].size);
        for (int h = 0; h < m.num_hits && !done; h++) {
            if (m.hits[h].ray != 3)
                continue;
            *was = m.hits[h].t;
            m.hits[h].t = nextafter(m.hits[h].t, INFINITY);
            *now = m.hits[h].t;
            done = 1;
        }
        assert_int_equal(trioct_ray_reply_t_encode(log.events[i].data, 0, (int)log.events[i].size, &m),
                         (int)log.events[i].size);
        trioct_ray_reply_t_decode_cleanup(&m);
    }
    assert_true(done);
    assert_int_equal(replay_log_write(path, log.events, log.count, err, sizeof err), 0);
    replay_log_free(&log);
}

static void test_changed_answer_fails(void **state)
{
    (void)state;
    char dir[64], path[128];
    scratch_make(dir, sizeof dir);
    snprintf(path, sizeof path, "%s/nudged.lcmlog", dir);
    double was = 0, now = 0;
    write_nudged_golden(path, &was, &now);
    char a[40], b[40], line[256];
    replay_format_double(now, a, sizeof a);
    replay_format_double(was, b, sizeof b);
    snprintf(line, sizeof line,
             "request 1 (client 0x51, ray_request_v1_t on TRIOCT_RAY_yard): ray 3: t expected %s got %s", a, b);
    for (int threads = 1; threads <= 4; threads += 3) {
        run_result r = check(&cases[0], path, threads, "--max-lines 5");
        expect_status(&r, 1);
        expect_line(&r, line);
        expect_line(&r, "requests 29 (0 malformed), replies 29: 28 matched, 1 mismatched, 0 missing, 0 extra (0 to "
                        "nobody)");
        free(r.out);
    }
    scratch_remove(dir);
}

static void test_changed_world_fails(void **state)
{
    (void)state;
    /* The regression a replay exists for: the daemon answers differently. Here the yard has
     * moved up a millimetre; every answer that touches it changes. */
    char dir[64];
    scratch_make(dir, sizeof dir);
    run_result r = run("cp " LOGS "/*.ini " LOGS "/*.obj " LOGS "/queries*.lcmlog %s/ && sed -i 's/^mesh = ball.obj$/mesh = ball.obj\\ntranslate = 0 0 0.001/' %s/scene.ini "
                       "&& grep -c translate %s/scene.ini", dir, dir, dir);
    expect_status(&r, 0);
    expect_line(&r, "2"); /* the yard's, and the cell's own */
    free(r.out);
    r = run("%s/trioct-replay check --threads 4 --max-lines 20 --daemon %s/trioctd --scene %s/scene.ini --golden "
            "%s/queries.golden.lcmlog %s/queries.lcmlog", build_dir, build_dir, dir, dir, dir);
    expect_status(&r, 1);
    /* Straight down from z = 12 onto a crate's top at z = 1, now 1.001. */
    expect_line(&r, "request 3 (client 0x51, ray_request_v1_t on TRIOCT_RAY_yard): ray 8: t expected 11 got 10.999");
    /* The any-hit request still hits on every ray (which hit is not compared): it matches. */
    expect_line(&r, "requests 29 (0 malformed), replies 29: 17 matched, 12 mismatched, 0 missing, 0 extra (0 to nobody)");
    expect_line(&r, "FAIL");
    free(r.out);
    scratch_remove(dir);
}

static void test_dropped_and_invented_replies_fail(void **state)
{
    (void)state;
    replay_log log;
    char err[512];
    assert_int_equal(replay_log_read(LOGS "/queries.golden.lcmlog", &log, err, sizeof err), 0);
    replay_proto p;
    assert_int_equal(replay_proto_init(&p, "TRIOCT", "replayd"), 0);
    /* Drop the reply to request 2; add a copy of the reply to request 12 claiming to answer
     * request 99, which nobody sent; add a heartbeat, which is never compared. */
    replay_event *ev = calloc(log.count + 2, sizeof *ev);
    assert_non_null(ev);
    size_t n = 0;
    for (size_t i = 0; i < log.count; i++) {
        replay_class c;
        replay_classify(&p, &log.events[i], &c);
        if (c.kind == KIND_REPLY && c.request_id == 2)
            continue;
        ev[n++] = log.events[i];
        if (c.kind == KIND_REPLY && c.request_id == 12) {
            trioct_ray_reply_t m;
            assert_true(trioct_ray_reply_t_decode(log.events[i].data, 0, (int)log.events[i].size, &m) > 0);
            m.header.request_id = 99;
            static uint8_t forged[1024];
            int len = trioct_ray_reply_t_encode(forged, 0, sizeof forged, &m);
            assert_true(len > 0);
            trioct_ray_reply_t_decode_cleanup(&m);
            ev[n++] = (replay_event){0, log.events[i].channel, forged, (size_t)len};
        }
    }
    trioct_status_t st;
    memset(&st, 0, sizeof st);
    st.daemon = "replayd";
    st.version = "0";
    st.state = TRIOCT_STATUS_T_READY;
    static uint8_t beat[512];
    int len = trioct_status_t_encode(beat, 0, sizeof beat, &st);
    assert_true(len > 0);
    ev[n++] = (replay_event){0, "TRIOCT_STATUS", beat, (size_t)len};

    char dir[64], path[128];
    scratch_make(dir, sizeof dir);
    snprintf(path, sizeof path, "%s/edited.lcmlog", dir);
    assert_int_equal(replay_log_write(path, ev, n, err, sizeof err), 0);
    free(ev);
    replay_log_free(&log);

    run_result r = check(&cases[0], path, 4, "");
    expect_status(&r, 1);
    expect_line(&r, "request 2 (client 0x51, ray_request_v1_t on TRIOCT_RAY_yard): a reply (OK, 32 items, 32 records "
                    "in 1 chunk, on REPLAY_QUERIES) where the golden log has none");
    expect_line(&r, "reply to request 99 (client 0x51), which no request of the log asked: no reply; expected OK, "
                    "0 items, 0 records in 1 chunk, on REPLAY_QUERIES");
    expect_line(&r, "requests 29 (0 malformed), replies 29: 28 matched, 0 mismatched, 1 missing, 1 extra (0 to "
                    "nobody)");
    free(r.out);
    scratch_remove(dir);
}

/* ---------- bad input to the tool ---------- */

/* Where the last event of a log starts: its size less the last event's. */
static long long last_event_at(const char *path)
{
    replay_log log;
    char err[512];
    assert_int_equal(replay_log_read(path, &log, err, sizeof err), 0);
    struct stat sb;
    assert_int_equal(stat(path, &sb), 0);
    const replay_event *e = &log.events[log.count - 1];
    long long at = (long long)sb.st_size - 28 - (long long)strlen(e->channel) - (long long)e->size;
    replay_log_free(&log);
    return at;
}

static void test_bad_logs_fail_cleanly(void **state)
{
    (void)state;
    char dir[64], path[128];
    scratch_make(dir, sizeof dir);

    /* Not a log at all. */
    snprintf(path, sizeof path, "%s/text.lcmlog", dir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("this is not an LCM log\n", f);
    fclose(f);
    run_result r = check(&cases[0], path, 1, "");
    expect_status(&r, 2);
    char line[256];
    snprintf(line, sizeof line, "trioct-replay: %s: byte 0: no LCM event starts here (not a log, or damaged)", path);
    expect_line(&r, line);
    free(r.out);

    /* A golden log cut inside its last event (the reply to request 36): left out, so that
     * reply is one the golden log lacks. */
    snprintf(path, sizeof path, "%s/cut.lcmlog", dir);
    copy_file(LOGS "/queries.golden.lcmlog", path);
    struct stat sb;
    assert_int_equal(stat(path, &sb), 0);
    assert_int_equal(truncate(path, sb.st_size - 10), 0);
    r = check(&cases[0], path, 1, "");
    expect_status(&r, 1);
    snprintf(line, sizeof line, "trioct-replay: %s: the event at byte %lld runs past the end of the file: left out",
             path, (long long)last_event_at(LOGS "/queries.golden.lcmlog"));
    expect_line(&r, line);
    expect_line(&r, "requests 29 (0 malformed), replies 28: 28 matched, 0 mismatched, 0 missing, 1 extra (0 to nobody)");
    free(r.out);

    /* A length that runs past the end of the file in the middle of it. */
    snprintf(path, sizeof path, "%s/lying.lcmlog", dir);
    copy_file(LOGS "/hostile.lcmlog", path);
    f = fopen(path, "r+b");
    assert_non_null(f);
    assert_int_equal(fseek(f, 24, SEEK_SET), 0); /* the first event's data length */
    fputc(0x7f, f);
    fclose(f);
    r = run("%s/trioct-replay check --daemon %s/trioctd --scene " LOGS "/scene.ini %s", build_dir, build_dir, path);
    expect_status(&r, 2);
    snprintf(line, sizeof line, "trioct-replay: %s: the event at byte 0 runs past the end of the file: left out", path);
    expect_line(&r, line);
    snprintf(line, sizeof line, "trioct-replay: %s holds nothing to replay (no requests for prefix TRIOCT)", path);
    expect_line(&r, line);
    free(r.out);

    /* No scene, a missing log, an unknown mode: usage errors. */
    r = run("%s/trioct-replay check " LOGS "/queries.lcmlog", build_dir);
    expect_status(&r, 2);
    expect_line(&r, "trioct-replay: --scene FILE is needed: the daemon's scene");
    free(r.out);
    r = run("%s/trioct-replay check --scene " LOGS "/scene.ini %s/missing.lcmlog", build_dir, dir);
    expect_status(&r, 2);
    free(r.out);
    r = run("%s/trioct-replay replay", build_dir);
    expect_status(&r, 2);
    expect_line(&r, "trioct-replay: unknown mode 'replay' (check, record or live)");
    free(r.out);
    scratch_remove(dir);
}

/* ---------- live ---------- */

static void test_live_replay_in_netns(void **state)
{
    (void)state;
    run_result r = run("tests/e2e/netns.sh %s/trioct-replay live --quiet --threads 4 --daemon %s/trioctd --scene "
                       LOGS "/scene.ini --golden " LOGS "/burst.golden.lcmlog " LOGS "/burst.lcmlog",
                       build_dir, build_dir);
    if (r.status == 77) {
        free(r.out);
        SKIP_OR_FAIL("live replay skipped: tests/e2e/netns.sh needs root and unshare(1)");
    }
    expect_status(&r, 0);
    expect_line(&r, cases[2].counts);
    free(r.out);
}

int main(int argc, char **argv)
{
    (void)argc;
    /* BUILD/tests/test_replay: the tools are in BUILD. */
    snprintf(build_dir, sizeof build_dir, "%s", argv[0]);
    for (int up = 0; up < 2; up++) {
        char *slash = strrchr(build_dir, '/');
        if (slash == NULL) {
            fprintf(stderr, "test_replay: run me as BUILD/tests/test_replay\n");
            return 1;
        }
        *slash = '\0';
    }
    if (access(LOGS "/scene.ini", R_OK) != 0) {
        fprintf(stderr, "test_replay: run me from the repository root (no " LOGS "/scene.ini here)\n");
        return 1;
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_format_and_canon),
        cmocka_unit_test(test_compare_names_the_field),
        cmocka_unit_test(test_any_hit_compared_by_whether_it_hit),
        cmocka_unit_test(test_chunks_compared_after_reassembly),
        cmocka_unit_test(test_logs_reproducible),
        cmocka_unit_test(test_replay_every_log_at_1_and_4_threads),
        cmocka_unit_test(test_goldens_hold_the_statuses_meant),
        cmocka_unit_test(test_touch_golden_blocks_grazing_rays),
        cmocka_unit_test(test_objects_golden_follows_the_edits),
        cmocka_unit_test(test_recorded_logs),
        cmocka_unit_test(test_changed_answer_fails),
        cmocka_unit_test(test_changed_world_fails),
        cmocka_unit_test(test_dropped_and_invented_replies_fail),
        cmocka_unit_test(test_bad_logs_fail_cleanly),
        cmocka_unit_test(test_live_replay_in_netns),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
