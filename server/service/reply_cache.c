/* reply_cache.h: a fixed pool of entries, chained in hash buckets by (client, request), and
 * kept in one list in the order they were answered (in-work entries first, never evicted),
 * so the oldest answer is the first to go when room is needed. */
#include "reply_cache.h"

#include <stdlib.h>
#include <string.h>

typedef struct entry {
    int64_t client, request;
    uint64_t digest;
    reply_cache_state state; /* IN_WORK or DONE while in use */
    dispatch_reply reply;    /* DONE: the answer */
    size_t bytes;            /* its chunks' bytes */
    struct entry *bucket_next;
    struct entry *prev, *next; /* c->order, or the free list (next only) */
} entry;

struct reply_cache {
    entry *pool;
    size_t max_entries, max_bytes;
    entry **buckets;
    size_t bucket_mask;
    entry *free_list;
    entry *oldest, *newest; /* in-use entries: started or answered, oldest first */
    size_t used, bytes;
};

static size_t bucket_of(const reply_cache *c, int64_t client, int64_t request)
{
    uint64_t h = (uint64_t)client * 0x9e3779b97f4a7c15ull ^ (uint64_t)request * 0xc2b2ae3d27d4eb4full;
    h ^= h >> 29;
    return (size_t)(h & c->bucket_mask);
}

reply_cache *reply_cache_create(size_t max_entries, size_t max_bytes)
{
    if (max_entries == 0)
        return NULL;
    reply_cache *c = calloc(1, sizeof *c);
    if (!c)
        return NULL;
    size_t buckets = 1;
    while (buckets < 2 * max_entries)
        buckets <<= 1;
    c->pool = calloc(max_entries, sizeof *c->pool);
    c->buckets = calloc(buckets, sizeof *c->buckets);
    if (!c->pool || !c->buckets) {
        reply_cache_free(c);
        return NULL;
    }
    c->bucket_mask = buckets - 1;
    c->max_entries = max_entries;
    c->max_bytes = max_bytes;
    for (size_t i = max_entries; i-- > 0;) {
        c->pool[i].next = c->free_list;
        c->free_list = &c->pool[i];
    }
    return c;
}

void reply_cache_free(reply_cache *c)
{
    if (!c)
        return;
    for (entry *e = c->oldest; e; e = e->next)
        dispatch_reply_free(&e->reply);
    free(c->pool);
    free(c->buckets);
    free(c);
}

uint64_t reply_cache_digest(const void *bytes, size_t size)
{
    /* FNV-1a: a retry's bytes are identical, and telling two requests of one client apart
     * under the same ids needs no strength against an adversary (a peer that forges the
     * ids only gets back what it could read off the bus). */
    const uint8_t *p = bytes;
    uint64_t h = 0xcbf29ce484222325ull;
    for (size_t i = 0; i < size; i++)
        h = (h ^ p[i]) * 0x100000001b3ull;
    return h ^ (uint64_t)size;
}

static entry *lookup(const reply_cache *c, int64_t client, int64_t request)
{
    for (entry *e = c->buckets[bucket_of(c, client, request)]; e; e = e->bucket_next)
        if (e->client == client && e->request == request)
            return e;
    return NULL;
}

static void order_unlink(reply_cache *c, entry *e)
{
    if (e->prev)
        e->prev->next = e->next;
    else
        c->oldest = e->next;
    if (e->next)
        e->next->prev = e->prev;
    else
        c->newest = e->prev;
    e->prev = e->next = NULL;
}

static void order_append(reply_cache *c, entry *e)
{
    e->prev = c->newest;
    e->next = NULL;
    if (c->newest)
        c->newest->next = e;
    else
        c->oldest = e;
    c->newest = e;
}

static void forget(reply_cache *c, entry *e)
{
    entry **link = &c->buckets[bucket_of(c, e->client, e->request)];
    while (*link != e)
        link = &(*link)->bucket_next;
    *link = e->bucket_next;
    order_unlink(c, e);
    dispatch_reply_free(&e->reply);
    c->bytes -= e->bytes;
    c->used--;
    memset(e, 0, sizeof *e);
    e->next = c->free_list;
    c->free_list = e;
}

/* Frees the oldest answer; 0, or -1 when every entry is in work. */
static int evict_oldest_answer(reply_cache *c)
{
    for (entry *e = c->oldest; e; e = e->next)
        if (e->state == REPLY_CACHE_DONE) {
            forget(c, e);
            return 0;
        }
    return -1;
}

reply_cache_state reply_cache_find(const reply_cache *c, int64_t client, int64_t request, uint64_t digest,
                                   const dispatch_reply **reply)
{
    const entry *e = lookup(c, client, request);
    if (!e || e->digest != digest)
        return REPLY_CACHE_NEW;
    if (reply && e->state == REPLY_CACHE_DONE)
        *reply = &e->reply;
    return e->state;
}

void reply_cache_start(reply_cache *c, int64_t client, int64_t request, uint64_t digest)
{
    entry *e = lookup(c, client, request);
    if (e) /* the same ids with other bytes: the newer request is the one now meant */
        forget(c, e);
    if (!c->free_list && evict_oldest_answer(c) != 0)
        return;
    e = c->free_list;
    c->free_list = e->next;
    memset(e, 0, sizeof *e);
    e->client = client;
    e->request = request;
    e->digest = digest;
    e->state = REPLY_CACHE_IN_WORK;
    size_t b = bucket_of(c, client, request);
    e->bucket_next = c->buckets[b];
    c->buckets[b] = e;
    order_append(c, e);
    c->used++;
}

void reply_cache_finish(reply_cache *c, int64_t client, int64_t request, uint64_t digest, dispatch_reply *reply)
{
    entry *e = lookup(c, client, request);
    if (!e || e->digest != digest || e->state != REPLY_CACHE_IN_WORK)
        return;
    size_t bytes = 0;
    for (size_t i = 0; i < reply->chunk_count; i++)
        bytes += reply->chunks[i].size;
    if (bytes > c->max_bytes) {
        forget(c, e);
        return;
    }
    while (c->bytes + bytes > c->max_bytes && evict_oldest_answer(c) == 0) {
    }
    e->reply = *reply;
    reply->chunks = NULL; /* the cache owns them now; the rest stays for the caller */
    reply->chunk_count = 0;
    e->bytes = bytes;
    e->state = REPLY_CACHE_DONE;
    c->bytes += bytes;
    order_unlink(c, e);
    order_append(c, e);
}

void reply_cache_forget(reply_cache *c, int64_t client, int64_t request)
{
    entry *e = lookup(c, client, request);
    if (e && e->state == REPLY_CACHE_IN_WORK)
        forget(c, e);
}

size_t reply_cache_entries(const reply_cache *c) { return c->used; }
size_t reply_cache_bytes(const reply_cache *c) { return c->bytes; }
