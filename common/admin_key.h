/* The shared key that authenticates changes over the bus (LOAD, UNLOAD, object edits,
 * ordered-mode marks), and the code that proves a request was made with it: HMAC-SHA256
 * (libsodium) over the channel name, a zero byte, and every byte of the encoded request up
 * to its code. The daemon and trusted clients read the same key file; see
 * docs/protocol.md, "Authenticated changes", for what it protects and what it does not. */
#ifndef TRIOCT_ADMIN_KEY_H
#define TRIOCT_ADMIN_KEY_H

#include <stddef.h>
#include <stdint.h>

#define TRIOCT_ADMIN_KEY_MIN_BYTES 32
#define TRIOCT_ADMIN_KEY_MAX_BYTES 128
#define TRIOCT_ADMIN_MAC_BYTES 32
#define TRIOCT_ADMIN_NONCE_BYTES 16
/* A change is accepted within this many microseconds of its timestamp, either way; its
 * nonce is remembered as long, so the same bytes are never accepted twice. */
#define TRIOCT_ADMIN_WINDOW_US ((int64_t)30 * 1000 * 1000)
/* The bytes auth_t takes at the end of an encoded request: utime, nonce, mac. */
#define TRIOCT_ADMIN_AUTH_BYTES (8 + TRIOCT_ADMIN_NONCE_BYTES + TRIOCT_ADMIN_MAC_BYTES)

typedef struct trioct_admin_key {
    unsigned char bytes[TRIOCT_ADMIN_KEY_MAX_BYTES];
    size_t len;
} trioct_admin_key;

/* Reads a key file: hex text of at least 32 bytes of key (64 digits), at most 128, one
 * trailing newline allowed, nothing else. Refused: a file that is not regular, or that
 * others (not its owner, not its group) may read or write. 0, or -1 with err naming the
 * file and what is wrong with it. */
int trioct_admin_key_load(const char *path, trioct_admin_key *key, char *err, size_t err_len);

/* A key from len hex digits (64 to 256, nothing else): 0, or -1 with *key empty. */
int trioct_admin_key_from_hex(const char *hex, size_t len, trioct_admin_key *key);

/* The code of a request: HMAC-SHA256 under key of channel, a zero byte, and len bytes. */
void trioct_admin_mac(const trioct_admin_key *key, const char *channel, const void *bytes, size_t len,
                      unsigned char mac[TRIOCT_ADMIN_MAC_BYTES]);

/* Signs an encoded request whose last TRIOCT_ADMIN_AUTH_BYTES are its auth_t: writes utime
 * and a fresh random nonce there, then the code over everything before the code. */
void trioct_admin_sign(const trioct_admin_key *key, const char *channel, void *bytes, size_t len, int64_t utime);

/* The same with the nonce given: for tools that must write the same bytes every time
 * (the replay logs). A nonce must still never be used twice under one key. */
void trioct_admin_sign_nonce(const trioct_admin_key *key, const char *channel, void *bytes, size_t len,
                             int64_t utime, const unsigned char nonce[TRIOCT_ADMIN_NONCE_BYTES]);

/* 1 when the last TRIOCT_ADMIN_MAC_BYTES of the request are its code under key (compared
 * in constant time), else 0; also 0 for a request too short to hold an auth_t. */
int trioct_admin_verify(const trioct_admin_key *key, const char *channel, const void *bytes, size_t len);

/* The auth_t fields of an encoded request (LCM's big-endian utime; the nonce's bytes). */
int64_t trioct_admin_utime(const void *bytes, size_t len);
const unsigned char *trioct_admin_nonce(const void *bytes, size_t len);

#endif
