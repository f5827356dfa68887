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
    trioct_admin_key key = {{0}, 0};
    const char *hex = REPLAY_LOGS_KEY_HEX;
    for (size_t i = 0; hex[2 * i] && hex[2 * i + 1]; i++) {
        unsigned v = 0;
        for (int k = 0; k < 2; k++) {
            char c = hex[2 * i + (size_t)k];
            v = v << 4 | (unsigned)(c <= '9' ? c - '0' : c - 'a' + 10);
        }
        key.bytes[key.len++] = (unsigned char)v;
    }
    return key;
}

#endif
