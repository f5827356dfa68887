/* The status message, on every heartbeat and at each change of state. */

#include "daemon_internal.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

#include "../../common/wire_check.h"
#include "../world/registry.h"
#include "log.h"
#include "trioct_world_info_t.h"


typedef struct world_info_space {
    char *shapes[TRIOCT_MAX_SHAPES];
} world_info_space;

void daemon_publish_status(daemon *d)
{
    latency_summary lat;
    stats_take_interval(&d->st, &lat);

    registry_entry entries[TRIOCT_MAX_WORLDS];
    size_t held = registry_entries(d->ctx.worlds, entries, TRIOCT_MAX_WORLDS);
    if (held > TRIOCT_MAX_WORLDS)
        held = TRIOCT_MAX_WORLDS;
    failed_world *failed = malloc(TRIOCT_MAX_WORLDS * sizeof *failed);
    size_t nf = failed != NULL ? failed_worlds_list(d->ctx.failed, failed, TRIOCT_MAX_WORLDS) : 0;
    if (nf > TRIOCT_MAX_WORLDS)
        nf = TRIOCT_MAX_WORLDS;
    size_t total = held + nf;
    trioct_world_info_t *infos = calloc(total ? total : 1, sizeof *infos);
    world_info_space *space = calloc(held ? held : 1, sizeof *space);

    trioct_status_t msg;
    memset(&msg, 0, sizeof msg);
    msg.utime = daemon_wall_utime();
    msg.daemon = d->opt.name;
    msg.version = TRIOCT_VERSION;
    msg.uptime_us = (int64_t)((uv_hrtime() - d->start_hr) / 1000);
    msg.state = (int8_t)d->state;
    msg.threads = d->opt.threads;
    msg.queue_depth = d->in_flight;
    msg.queue_capacity = d->opt.queue_depth;
    msg.memory_used = (int64_t)memory_account_used(&d->ctx.memory);
    msg.memory_budget = (int64_t)d->ctx.memory.limit;
    memcpy(msg.served, d->st.served, sizeof msg.served);
    msg.malformed = d->st.malformed;
    msg.duplicates_answered = d->st.duplicates_answered;
    msg.duplicates_joined = d->st.duplicates_joined;
    msg.num_status_codes = TRIOCT_WIRE_STATUS_COUNT;
    msg.replies_by_status = d->st.replies_by_status;
    msg.latency_p50_us = lat.p50_us;
    msg.latency_p99_us = lat.p99_us;
    msg.latency_count = lat.count;
    msg.num_worlds = 0;
    msg.worlds = infos;
    /* The builds under way, so a long LOAD is seen to move (trioct load --progress). */
    load_entry *loads = malloc(LOAD_TABLE_SLOTS * sizeof *loads);
    trioct_load_progress_t *progress = calloc(LOAD_TABLE_SLOTS, sizeof *progress);
    size_t nl = loads != NULL && progress != NULL ? load_table_list(&d->loads, loads, LOAD_TABLE_SLOTS) : 0;
    if (nl > LOAD_TABLE_SLOTS)
        nl = LOAD_TABLE_SLOTS;
    for (size_t i = 0; i < nl; i++) {
        progress[i].world = loads[i].world;
        progress[i].client_id = loads[i].client_id;
        progress[i].request_id = loads[i].request_id;
        progress[i].phase = (char *)world_phase_name(loads[i].phase);
        progress[i].files_done = loads[i].files_done;
        progress[i].files_total = loads[i].files_total;
        progress[i].triangles = loads[i].triangles;
        progress[i].elapsed_seconds = loads[i].elapsed_seconds;
    }
    msg.num_loads = (int32_t)nl;
    msg.loads = progress;
    if (infos != NULL && space != NULL) {
        for (size_t i = 0; i < held; i++)
            dispatch_world_info(&d->ctx, &entries[i], &infos[msg.num_worlds++], space[i].shapes);
        for (size_t i = 0; i < nf; i++)
            dispatch_failed_world_info(&d->ctx, &failed[i], &infos[msg.num_worlds++]);
    }

    /* One datagram or nothing: a status that LCM had to fragment could be lost whole. With
     * long sources and errors 64 worlds may not fit; the ones left out are logged. */
    int size = trioct_status_t_encoded_size(&msg);
    size_t all = (size_t)msg.num_worlds;
    while (size > TRIOCT_MAX_CHUNK_BYTES && msg.num_worlds > 0) {
        msg.num_worlds--;
        size = trioct_status_t_encoded_size(&msg);
    }
    size_t left_out = all - (size_t)msg.num_worlds;
    if (left_out != d->status_worlds_left_out) {
        if (left_out > 0)
            LOG(LOG_WARN, "status: %zu of %zu worlds left out to fit one datagram", left_out, all);
        d->status_worlds_left_out = left_out;
    }

    void *buf = malloc((size_t)size);
    if (buf != NULL && trioct_status_t_encode(buf, 0, size, &msg) == size) {
        if (lcm_publish(d->lcm_out, d->status_channel, buf, (unsigned)size) < 0)
            LOG(LOG_WARN, "could not publish the status on %s", d->status_channel);
    } else {
        LOG(LOG_ERROR, "could not encode the status message (%d bytes)", size);
    }
    free(buf);

    LOG(LOG_DEBUG, "status: %s, %zu worlds (%zu failed), queue %d/%d, served ray %" PRId64
        " triangle %" PRId64 " mesh %" PRId64 " admin %" PRId64 ", malformed %" PRId64
        ", latency p50 %" PRId64 " us p99 %" PRId64 " us over %" PRId64,
        daemon_state_name(d->state), held, nf, d->in_flight, d->opt.queue_depth,
        d->st.served[0], d->st.served[1], d->st.served[2], d->st.served[3], d->st.malformed,
        lat.p50_us, lat.p99_us, lat.count);

    free(space);
    free(infos);
    free(failed);
    free(loads);
    free(progress);
    registry_entries_free(entries, held);
    daemon_tell_systemd(d, TELL_STATUS);
}

void daemon_on_heartbeat(uv_timer_t *timer)
{
    daemon_publish_status(timer->data);
}
