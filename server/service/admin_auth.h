/* The daemon's guard on changes over the bus: a request that would change what is served
 * (LOAD, UNLOAD, object edits, ordered-mode marks) is accepted only with a code made with
 * the daemon's key (common/admin_key.h), a timestamp within TRIOCT_ADMIN_WINDOW_US of when
 * it was heard, and a nonce not seen before. Without a key every change is refused. */
#ifndef TRIOCT_SERVICE_ADMIN_AUTH_H
#define TRIOCT_SERVICE_ADMIN_AUTH_H

#include <stddef.h>
#include <stdint.h>

#include "../../common/admin_key.h"

/* Nonces remembered at once: a change more within one window is refused until the oldest
 * has aged out (bounded memory; about 2,000 changes a second would be needed). */
#define ADMIN_AUTH_MAX_NONCES 65536

typedef struct admin_auth admin_auth;

/* A guard with key (copied), or, with key NULL, one that refuses every change. NULL when
 * out of memory. check_window 0 is for a daemon reading a log (file://): its changes were
 * signed when they were recorded, which no clock can judge, and a log on the daemon's own
 * disk is not a bus a peer could replay into; code and nonce are still checked. */
admin_auth *admin_auth_create(const trioct_admin_key *key, int check_window);
void admin_auth_free(admin_auth *a);
/* 1 when the guard has a key. */
int admin_auth_has_key(const admin_auth *a);

/* Checks the encoded request (its auth_t last) heard on channel at heard_utime (the bus's
 * receive time; a log's timestamp on replay): 0 when accepted, its nonce now remembered;
 * -1 with why when refused. Thread-safe. */
int admin_auth_check(admin_auth *a, const char *channel, const void *bytes, size_t len, int64_t heard_utime,
                     char *why, size_t why_len);

#endif
