/* The change guard: code, window, then nonce (admin_auth.h). Nonces live in a ring in the
 * order they were accepted, with an open-addressing index over it; the ring's oldest entry
 * leaves once its timestamp is out of the window of the newest change heard. */
#include "admin_auth.h"

#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <sodium.h>

#define INDEX_SLOTS (2 * ADMIN_AUTH_MAX_NONCES) /* a power of two, at most half full */
#define EMPTY_SLOT UINT32_MAX

typedef struct nonce_entry {
    unsigned char nonce[TRIOCT_ADMIN_NONCE_BYTES];
    int64_t utime;
} nonce_entry;

struct admin_auth {
    trioct_admin_key key;
    int has_key;
    int check_window;
    int64_t newest;    /* the latest timestamp accepted: the clock nonces age by in a log */
    pthread_mutex_t lock;
    nonce_entry *ring; /* ADMIN_AUTH_MAX_NONCES */
    size_t oldest, count;
    uint32_t *index;   /* INDEX_SLOTS ring positions, EMPTY_SLOT when free */
};

admin_auth *admin_auth_create(const trioct_admin_key *key, int check_window)
{
    if (sodium_init() < 0)
        return NULL;
    admin_auth *a = calloc(1, sizeof *a);
    if (!a)
        return NULL;
    a->ring = calloc(ADMIN_AUTH_MAX_NONCES, sizeof *a->ring);
    a->index = malloc(INDEX_SLOTS * sizeof *a->index);
    if (!a->ring || !a->index) {
        free(a->ring);
        free(a->index);
        free(a);
        return NULL;
    }
    memset(a->index, 0xff, INDEX_SLOTS * sizeof *a->index);
    if (key && key->len > 0) {
        a->key = *key;
        a->has_key = 1;
    }
    a->check_window = check_window != 0;
    a->newest = INT64_MIN;
    pthread_mutex_init(&a->lock, NULL);
    return a;
}

void admin_auth_free(admin_auth *a)
{
    if (!a)
        return;
    sodium_memzero(&a->key, sizeof a->key);
    pthread_mutex_destroy(&a->lock);
    free(a->ring);
    free(a->index);
    free(a);
}

int admin_auth_has_key(const admin_auth *a) { return a && a->has_key; }

/* Nonces are random: their first bytes are as good a hash as any. */
static size_t slot_of(const unsigned char *nonce)
{
    uint64_t h;
    memcpy(&h, nonce, sizeof h);
    return (size_t)(h & (INDEX_SLOTS - 1));
}

static size_t find_slot(const admin_auth *a, const unsigned char *nonce, int *found)
{
    size_t s = slot_of(nonce);
    while (a->index[s] != EMPTY_SLOT) {
        if (memcmp(a->ring[a->index[s]].nonce, nonce, TRIOCT_ADMIN_NONCE_BYTES) == 0) {
            *found = 1;
            return s;
        }
        s = (s + 1) & (INDEX_SLOTS - 1);
    }
    *found = 0;
    return s;
}

/* Backward-shift deletion keeps every probe chain unbroken without tombstones. */
static void index_remove(admin_auth *a, size_t hole)
{
    size_t s = hole;
    for (;;) {
        s = (s + 1) & (INDEX_SLOTS - 1);
        if (a->index[s] == EMPTY_SLOT)
            break;
        size_t home = slot_of(a->ring[a->index[s]].nonce);
        /* The entry at s may move to the hole when its home is not in (hole, s]. */
        int stays = hole <= s ? (home > hole && home <= s) : (home > hole || home <= s);
        if (!stays) {
            a->index[hole] = a->index[s];
            hole = s;
        }
    }
    a->index[hole] = EMPTY_SLOT;
}

static void forget_oldest(admin_auth *a)
{
    int found;
    size_t s = find_slot(a, a->ring[a->oldest].nonce, &found);
    if (found)
        index_remove(a, s);
    a->oldest = (a->oldest + 1) % ADMIN_AUTH_MAX_NONCES;
    a->count--;
}

static int refuse(char *why, size_t why_len, const char *format, ...) __attribute__((format(printf, 3, 4)));
static int refuse(char *why, size_t why_len, const char *format, ...)
{
    if (why && why_len) {
        va_list args;
        va_start(args, format);
        vsnprintf(why, why_len, format, args);
        va_end(args);
    }
    return -1;
}

int admin_auth_check(admin_auth *a, const char *channel, const void *bytes, size_t len, int64_t heard_utime,
                     char *why, size_t why_len)
{
    if (!a || !a->has_key)
        return refuse(why, why_len,
                      "changes over the bus are refused: the daemon has no admin key (admin_key_file in [daemon]); "
                      "the scene file and SIGHUP change its worlds");
    if (!trioct_admin_verify(&a->key, channel, bytes, len))
        return refuse(why, why_len, "the request's code does not match the daemon's admin key");
    int64_t utime = trioct_admin_utime(bytes, len), off;
    if (a->check_window && (__builtin_sub_overflow(heard_utime, utime, &off) || off > TRIOCT_ADMIN_WINDOW_US ||
                            off < -TRIOCT_ADMIN_WINDOW_US))
        return refuse(why, why_len, "the request's timestamp is %lld s from the daemon's clock, outside its window of 30 s",
                      (long long)(utime == 0 ? 0 : (heard_utime - utime) / 1000000));
    const unsigned char *nonce = trioct_admin_nonce(bytes, len);

    pthread_mutex_lock(&a->lock);
    /* What has aged out of the window can no longer pass the timestamp test: let it go. A
     * log has no clock but its own timestamps. */
    int64_t clock = a->check_window ? heard_utime : (utime > a->newest ? utime : a->newest);
    while (a->count > 0 && clock - a->ring[a->oldest].utime > 2 * TRIOCT_ADMIN_WINDOW_US)
        forget_oldest(a);
    int found;
    size_t slot = find_slot(a, nonce, &found);
    int rc = 0;
    if (found) {
        rc = refuse(why, why_len, "the request's nonce was seen before: a replayed change is refused");
    } else if (a->count == ADMIN_AUTH_MAX_NONCES) {
        rc = refuse(why, why_len, "more than %d changes within one window; wait and send it again",
                    ADMIN_AUTH_MAX_NONCES);
    } else {
        size_t at = (a->oldest + a->count) % ADMIN_AUTH_MAX_NONCES;
        memcpy(a->ring[at].nonce, nonce, TRIOCT_ADMIN_NONCE_BYTES);
        a->ring[at].utime = utime;
        a->index[slot] = (uint32_t)at;
        a->count++;
        a->newest = clock;
    }
    pthread_mutex_unlock(&a->lock);
    return rc;
}
