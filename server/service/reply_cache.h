/* The replies of recent requests, keyed by (client id, request id) and the request's bytes,
 * so that a client's retry (the same bytes again: its reply or its request was lost on
 * the bus) gets the answer already given, without the work done twice, and a retry that
 * arrives while the original is in work waits for the original's reply instead of
 * starting a second one. Bounded in entries and in bytes: the oldest answers go first, and
 * an answer larger than the bound is not kept (a retry of it is worked again). Used on the
 * daemon's loop thread only: no locks. */
#ifndef TRIOCT_SERVICE_REPLY_CACHE_H
#define TRIOCT_SERVICE_REPLY_CACHE_H

#include <stddef.h>
#include <stdint.h>

#include "dispatch.h"

#define REPLY_CACHE_ENTRIES 4096
#define REPLY_CACHE_BYTES ((size_t)32 << 20)

typedef enum reply_cache_state {
    REPLY_CACHE_NEW = 0, /* not seen (or seen with other bytes): work it */
    REPLY_CACHE_IN_WORK, /* the same request is being worked: its reply will come */
    REPLY_CACHE_DONE,    /* answered: *reply is the answer given */
} reply_cache_state;

typedef struct reply_cache reply_cache;

/* NULL when out of memory. max_bytes bounds the chunks kept, in all. */
reply_cache *reply_cache_create(size_t max_entries, size_t max_bytes);
void reply_cache_free(reply_cache *c);

/* A digest of a request's bytes: a retry has the same; another request under the same ids
 * (a client that reused its id) has another. */
uint64_t reply_cache_digest(const void *bytes, size_t size);

/* What is known of the request. For DONE, *reply points at the stored answer, valid until
 * the next call that changes the cache. */
reply_cache_state reply_cache_find(const reply_cache *c, int64_t client, int64_t request, uint64_t digest,
                                   const dispatch_reply **reply);

/* The request goes into work: a retry of it now finds IN_WORK. Nothing is recorded (and the
 * request is simply worked) when every entry is in work. */
void reply_cache_start(reply_cache *c, int64_t client, int64_t request, uint64_t digest);

/* The answer to a request started: kept (moved out of *reply, which is left empty) when it
 * fits the byte bound, older answers leaving to make room (reply keeps its channel and
 * status, its chunks now the cache's); else the entry is forgotten and *reply left as it
 * was. */
void reply_cache_finish(reply_cache *c, int64_t client, int64_t request, uint64_t digest, dispatch_reply *reply);

/* A request started and answered otherwise (out of memory, could not be queued): its entry
 * goes, so that a retry is worked. */
void reply_cache_forget(reply_cache *c, int64_t client, int64_t request);

/* Entries and bytes held, for tests and the status. */
size_t reply_cache_entries(const reply_cache *c);
size_t reply_cache_bytes(const reply_cache *c);

#endif
