/* The admin key the request logs of tests/logs are signed with (their LOADs, UNLOADs, edits
 * and marks), and that trioct-replay gives the daemon it runs unless --key-file names
 * another. A test fixture, known to anyone who reads this: never a key to serve with. */
#ifndef TRIOCT_REPLAY_KEY_H
#define TRIOCT_REPLAY_KEY_H

#include "admin_key.h"

#define REPLAY_LOGS_KEY_HEX "7472696f63742d7265706c61792d6c6f67732d6b65792d6e6f742d7365637265"

/* The key's bytes from its hex. */
static inline trioct_admin_key replay_logs_key(void)
{
    trioct_admin_key key;
    trioct_admin_key_from_hex(REPLAY_LOGS_KEY_HEX, sizeof REPLAY_LOGS_KEY_HEX - 1, &key);
    return key;
}

#endif
