#define _XOPEN_SOURCE 700
/* libFuzzer target: the bytes of one request of one type (FUZZ_TYPE, fixed at compile
 * time: one binary per type) through the daemon's bytes-to-reply path, dispatch_peek then
 * dispatch_handle, against the replay scene's worlds (tests/logs). Every reply must pass
 * the wire validator; any crash, leak or undefined behaviour is the sanitizers' to report.
 *
 * Input: one byte choosing, for admin requests, LIST, LOAD or a world's ADMIN channel, then
 * the message; the world of the channel is the one its header names. Changes (LOAD, UNLOAD, edits) are
 * signed here with the logs' key, so that mutated changes reach the code behind the guard.
 * The registry is made afresh from the pristine worlds for each input: a LOAD or an edit
 * of one input does not change what the next one meets. Seed corpora: fuzz/make_corpus. */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "admin_key.h"
#include "channels.h"
#include "replay_key.h"
#include "service/dispatch.h"
#include "wire_check.h"
#include "world/registry.h"
#include "world/scene.h"
#include "world/world.h"

#ifndef FUZZ_TYPE
#error "FUZZ_TYPE names the request type: REQUEST_RAY, REQUEST_TRIANGLE, ..."
#endif

#define NOW_US INT64_C(1700000000000000)

static struct {
    int ready;
    scene sc;
    world *pristine[TRIOCT_MAX_WORLDS];
    size_t count;
    dispatch_ctx ctx;
    trioct_admin_key key;
    int64_t clock; /* advances two windows an input: the nonces of one never meet the next */
} F;

static const wire_type reply_wire[] = {
    [REQUEST_RAY] = WIRE_RAY_REPLY,       [REQUEST_TRIANGLE] = WIRE_TRIANGLE_REPLY,
    [REQUEST_MESH] = WIRE_MESH_REPLY,     [REQUEST_ADMIN] = WIRE_ADMIN_REPLY,
    [REQUEST_OBJECTS] = WIRE_OBJECT_REPLY, [REQUEST_STATE] = WIRE_STATE_REPLY,
    [REQUEST_DISTANCE] = WIRE_DISTANCE_REPLY,
};

static const trioct_channel_kind kind_of[] = {
    [REQUEST_RAY] = TRIOCT_CHANNEL_RAY,         [REQUEST_TRIANGLE] = TRIOCT_CHANNEL_TRI,
    [REQUEST_MESH] = TRIOCT_CHANNEL_MESH,       [REQUEST_ADMIN] = TRIOCT_CHANNEL_ADMIN,
    [REQUEST_OBJECTS] = TRIOCT_CHANNEL_OBJECTS, [REQUEST_STATE] = TRIOCT_CHANNEL_STATE,
    [REQUEST_DISTANCE] = TRIOCT_CHANNEL_DISTANCE,
};

/* The scene and its worlds, built once: the replay scene beside the sources. */
static void set_up(void)
{
    char dir[4096], path[4200], err[1024];
    const char *root = getenv("TRIOCT_FUZZ_LOGS");
    snprintf(dir, sizeof dir, "%s", root ? root : "tests/logs");
    char *absolute = realpath(dir, NULL);
    if (!absolute) {
        fprintf(stderr, "fuzz: no %s (run from the source tree, or set TRIOCT_FUZZ_LOGS)\n", dir);
        abort();
    }
    snprintf(path, sizeof path, "%s/scene.ini", absolute);
    if (scene_load(path, &F.sc, err, sizeof err) != 0) {
        fprintf(stderr, "fuzz: %s\n", err);
        abort();
    }
    for (size_t i = 0; i < F.sc.world_count; i++) {
        int status;
        world *w = world_build(&F.sc.worlds[i], absolute, NULL, &status, err, sizeof err);
        if (w)
            F.pristine[F.count++] = w; /* tight never builds: that is its point */
    }
    snprintf(F.ctx.prefix, sizeof F.ctx.prefix, "TRIOCT");
    snprintf(F.ctx.daemon, sizeof F.ctx.daemon, "replayd");
    snprintf(F.ctx.world_dir, sizeof F.ctx.world_dir, "%s", absolute);
    free(absolute);
    pthread_mutex_init(&F.ctx.scene_lock, NULL);
    F.ctx.scene = &F.sc;
    /* A budget small enough that a fuzzed resolution cannot take the machine. */
    memory_account_init(&F.ctx.memory, (size_t)64 << 20);
    F.ctx.env.account = &F.ctx.memory;
    F.key = replay_logs_key();
    F.ctx.auth = admin_auth_create(&F.key, 0);
    F.clock = NOW_US;
    F.ready = 1;
}

static registry *fresh_registry(void)
{
    registry *r = registry_create();
    for (size_t i = 0; r && i < F.count; i++) {
        world_retain(F.pristine[i]);
        if (registry_install(r, F.pristine[i]) != 0)
            world_release(F.pristine[i]);
    }
    return r;
}

/* The channel: the one the header's world names (what a client sends on), and for admin
 * requests the first byte's choice of LIST, LOAD or that world's ADMIN channel. */
static int channel_for(uint8_t pick, const uint8_t *bytes, size_t n, char out[TRIOCT_MAX_CHANNEL_LEN + 1])
{
    char world[TRIOCT_MAX_NAME_LEN + 1] = "yard";
    /* The header's strings by hand, bounds checked: fingerprint, two ids, reply channel. */
    size_t at = 8 + 16;
    for (int field = 0; field < 2 && at + 4 <= n; field++) {
        uint32_t len = (uint32_t)bytes[at] << 24 | (uint32_t)bytes[at + 1] << 16 | (uint32_t)bytes[at + 2] << 8 |
                       bytes[at + 3];
        at += 4;
        if (len == 0 || len > n - at)
            break;
        if (field == 1 && len - 1 <= TRIOCT_MAX_NAME_LEN) {
            memcpy(world, bytes + at, len - 1);
            world[len - 1] = '\0';
            if (!trioct_name_valid(world, TRIOCT_MAX_NAME_LEN))
                snprintf(world, sizeof world, "yard");
        }
        at += len;
    }
    if (FUZZ_TYPE == REQUEST_ADMIN) {
        if (pick % 3 == 0)
            return trioct_channel_name(out, "TRIOCT", TRIOCT_CHANNEL_LIST, NULL);
        if (pick % 3 == 1)
            return trioct_channel_name(out, "TRIOCT", TRIOCT_CHANNEL_LOAD, "replayd");
    }
    return trioct_channel_name(out, "TRIOCT", kind_of[FUZZ_TYPE], world);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (!F.ready)
        set_up();
    if (size < 1 || size > TRIOCT_MAX_REQUEST_BYTES + 1)
        return 0;
    char channel[TRIOCT_MAX_CHANNEL_LEN + 1];
    size_t n = size - 1;
    if (channel_for(data[0], data + 1, n, channel) != 0)
        return 0;
    uint8_t *bytes = malloc(n ? n : 1);
    if (!bytes)
        return 0;
    memcpy(bytes, data + 1, n);
    F.clock += 2 * TRIOCT_ADMIN_WINDOW_US + 1;
    if ((FUZZ_TYPE == REQUEST_ADMIN || FUZZ_TYPE == REQUEST_OBJECTS) && n >= TRIOCT_ADMIN_AUTH_BYTES)
        trioct_admin_sign(&F.key, channel, bytes, n, F.clock);

    F.ctx.worlds = fresh_registry();
    if (!F.ctx.worlds) {
        free(bytes);
        return 0;
    }
    dispatch_request req;
    if (dispatch_peek(&F.ctx, channel, bytes, n, &req) == PEEK_REQUEST) {
        dispatch_reply rep;
        if (dispatch_handle_heard(&F.ctx, channel, bytes, n, NOW_US, F.clock, &rep) == 0) {
            for (size_t i = 0; i < rep.chunk_count; i++) {
                wire_error err;
                if (wire_check(reply_wire[req.type], rep.chunks[i].data, rep.chunks[i].size, &err) != 0) {
                    fprintf(stderr, "fuzz: chunk %zu of a reply fails the validator: %s\n", i, err.what);
                    abort();
                }
            }
            dispatch_reply_free(&rep);
        }
    }
    registry_free(F.ctx.worlds);
    F.ctx.worlds = NULL;
    free(bytes);
    return 0;
}
