/* The channels the daemon hears: the fixed ones from the start, and each held world's
 * once it is held, so daemons sharing a bus never answer each other's worlds. */

#include "daemon_internal.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../world/registry.h"
#include "log.h"

/* The channels a held world is heard on, in this order. */
static const trioct_channel_kind world_kinds[] = {
    TRIOCT_CHANNEL_RAY,
    TRIOCT_CHANNEL_TRI,
    TRIOCT_CHANNEL_MESH,
    TRIOCT_CHANNEL_ADMIN,
    TRIOCT_CHANNEL_OBJECTS,
    TRIOCT_CHANNEL_STATE,
    TRIOCT_CHANNEL_DISTANCE,
};
_Static_assert(sizeof world_kinds / sizeof world_kinds[0] == DAEMON_WORLD_KINDS,
               "world_subs holds one subscription a kind");

/* LCM's queue in front of the daemon's, per subscription, in units of --queue-depth. */
#define DAEMON_LCM_QUEUE_FACTOR 4

/* LCM keeps about 30 messages a subscription between its receive thread and lcm_handle
 * and drops the rest without a word. A burst must reach the loop to be answered, if only
 * with BUSY, so LCM's queue holds several times the requests the daemon takes in hand: a
 * replay at full speed on two cores was seen to run the loop 1,500 messages behind its
 * receive thread. Bounded still, so a flood cannot take all memory. */
int daemon_lcm_queue_capacity(int queue_depth)
{
    return queue_depth > INT_MAX / DAEMON_LCM_QUEUE_FACTOR ? INT_MAX
                                                           : queue_depth * DAEMON_LCM_QUEUE_FACTOR;
}

lcm_subscription_t *daemon_subscribe_to(daemon *d, const char *channel, lcm_msg_handler_t handler)
{
    /* Channel names are [A-Za-z0-9_], so the regular expression LCM makes of them matches
     * exactly themselves. */
    lcm_subscription_t *sub = lcm_subscribe(d->lcm_in, channel, handler, d);
    if (sub == NULL) {
        LOG(LOG_ERROR, "could not subscribe to %s", channel);
        return NULL;
    }
    lcm_subscription_set_queue_capacity(sub, daemon_lcm_queue_capacity(d->opt.queue_depth));
    LOG(LOG_DEBUG, "subscribed to %s", channel);
    return sub;
}

static lcm_subscription_t *subscribe(daemon *d, const char *channel)
{
    return daemon_subscribe_to(d, channel, daemon_on_message);
}

int daemon_subscribe_fixed(daemon *d)
{
    char ch[TRIOCT_MAX_CHANNEL_LEN + 1];
    if (trioct_channel_name(ch, d->opt.prefix, TRIOCT_CHANNEL_LIST, NULL) < 0 ||
        (d->sub_list = subscribe(d, ch)) == NULL)
        return -1;
    if (trioct_channel_name(ch, d->opt.prefix, TRIOCT_CHANNEL_LOAD, d->opt.name) < 0 ||
        (d->sub_load = subscribe(d, ch)) == NULL)
        return -1;
    if (d->opt.ordered && daemon_ordered_subscribe(d) < 0)
        return -1;
    return 0;
}

static void unsubscribe_world(daemon *d, world_subs *ws)
{
    for (size_t k = 0; k < DAEMON_WORLD_KINDS; k++) {
        if (ws->sub[k] != NULL)
            lcm_unsubscribe(d->lcm_in, ws->sub[k]);
        ws->sub[k] = NULL;
    }
    LOG(LOG_DEBUG, "no longer listening for world '%s'", ws->name);
}

static int subscribe_world(daemon *d, world_subs *ws, const char *name)
{
    memset(ws, 0, sizeof *ws);
    snprintf(ws->name, sizeof ws->name, "%s", name);
    for (size_t k = 0; k < DAEMON_WORLD_KINDS; k++) {
        char ch[TRIOCT_MAX_CHANNEL_LEN + 1];
        if (trioct_channel_name(ch, d->opt.prefix, world_kinds[k], name) < 0) {
            LOG(LOG_ERROR, "world '%s' has no valid channel under prefix %s", name, d->opt.prefix);
            unsubscribe_world(d, ws);
            return -1;
        }
        if ((ws->sub[k] = subscribe(d, ch)) == NULL) {
            unsubscribe_world(d, ws);
            return -1;
        }
    }
    return 0;
}

/* Makes one world's subscriptions kept, subscribing when it has none yet. */
static void keep_world(daemon *d, const char *name)
{
    for (size_t i = 0; i < d->sub_count; i++)
        if (strcmp(d->subs[i].name, name) == 0) {
            d->subs[i].keep = 1;
            return;
        }
    if (d->sub_count == d->sub_alloc) {
        size_t want = d->sub_alloc ? d->sub_alloc * 2 : 16;
        world_subs *grown = realloc(d->subs, want * sizeof *grown);
        if (grown == NULL) {
            LOG(LOG_ERROR, "out of memory: world '%s' gets no subscriptions", name);
            return;
        }
        d->subs = grown;
        d->sub_alloc = want;
    }
    if (subscribe_world(d, &d->subs[d->sub_count], name) == 0) {
        d->subs[d->sub_count].keep = 1;
        d->sub_count++;
        LOG(LOG_DEBUG, "listening for world '%s'", name);
    }
}

/* Makes the per-world subscriptions those of the worlds the registry holds and of the
 * scene worlds that failed to build (whose requests are answered with why): a daemon hears
 * the requests of its own worlds only, so daemons sharing a bus never answer twice. Called
 * after start-up, after a reload and after a reply that loaded or unloaded a world; never
 * from inside lcm_handle. */
void daemon_sync_subscriptions(daemon *d)
{
    registry_entry entries[TRIOCT_MAX_WORLDS];
    size_t n = registry_entries(d->ctx.worlds, entries, TRIOCT_MAX_WORLDS);
    if (n > TRIOCT_MAX_WORLDS)
        n = TRIOCT_MAX_WORLDS;

    for (size_t i = 0; i < d->sub_count; i++)
        d->subs[i].keep = 0;
    for (size_t e = 0; e < n; e++) {
        const char *name = entries[e].w->spec.name;
        failed_worlds_remove(d->ctx.failed, name); /* held now, by a LOAD say */
        keep_world(d, name);
    }
    failed_world *failed = malloc(TRIOCT_MAX_WORLDS * sizeof *failed);
    size_t nf = failed != NULL ? failed_worlds_list(d->ctx.failed, failed, TRIOCT_MAX_WORLDS) : 0;
    for (size_t i = 0; i < nf && i < TRIOCT_MAX_WORLDS; i++)
        keep_world(d, failed[i].name);
    free(failed);
    for (size_t i = 0; i < d->sub_count;) {
        if (d->subs[i].keep) {
            i++;
            continue;
        }
        unsubscribe_world(d, &d->subs[i]);
        d->subs[i] = d->subs[--d->sub_count];
    }
    registry_entries_free(entries, n);
}

void daemon_unsubscribe_all(daemon *d)
{
    for (size_t i = 0; i < d->sub_count; i++)
        unsubscribe_world(d, &d->subs[i]);
    d->sub_count = 0;
    if (d->sub_list != NULL)
        lcm_unsubscribe(d->lcm_in, d->sub_list);
    if (d->sub_load != NULL)
        lcm_unsubscribe(d->lcm_in, d->sub_load);
    if (d->sub_reload != NULL)
        lcm_unsubscribe(d->lcm_in, d->sub_reload);
    if (d->sub_stop != NULL)
        lcm_unsubscribe(d->lcm_in, d->sub_stop);
    d->sub_list = d->sub_load = d->sub_reload = d->sub_stop = NULL;
}

void daemon_resize_lcm_queues(daemon *d)
{
    int capacity = daemon_lcm_queue_capacity(d->opt.queue_depth);
    lcm_subscription_t *fixed[] = {d->sub_list, d->sub_load, d->sub_reload, d->sub_stop};
    for (size_t i = 0; i < sizeof fixed / sizeof fixed[0]; i++)
        if (fixed[i] != NULL)
            lcm_subscription_set_queue_capacity(fixed[i], capacity);
    for (size_t i = 0; i < d->sub_count; i++)
        for (size_t k = 0; k < DAEMON_WORLD_KINDS; k++)
            if (d->subs[i].sub[k] != NULL)
                lcm_subscription_set_queue_capacity(d->subs[i].sub[k], capacity);
}
