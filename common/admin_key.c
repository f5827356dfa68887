/* Key files and request codes for authenticated changes (admin_key.h). */
#include "admin_key.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <sodium.h>

/* Hex of the largest key, a CR LF, and one byte more to see a file that is longer. */
#define KEY_FILE_MAX (2 * TRIOCT_ADMIN_KEY_MAX_BYTES + 3)

static int key_fail(char *err, size_t err_len, const char *path, const char *what)
{
    if (err && err_len)
        snprintf(err, err_len, "key file %s: %s", path, what);
    return -1;
}

static int hex_value(char c)
{
    if (c >= '0' && c <= '9')
        return c - '0';
    if (c >= 'a' && c <= 'f')
        return c - 'a' + 10;
    if (c >= 'A' && c <= 'F')
        return c - 'A' + 10;
    return -1;
}

int trioct_admin_key_from_hex(const char *hex, size_t len, trioct_admin_key *key)
{
    memset(key, 0, sizeof *key);
    if (len % 2 != 0 || len < 2 * TRIOCT_ADMIN_KEY_MIN_BYTES || len > 2 * TRIOCT_ADMIN_KEY_MAX_BYTES)
        return -1;
    for (size_t i = 0; i < len; i += 2) {
        int hi = hex_value(hex[i]), lo = hex_value(hex[i + 1]);
        if (hi < 0 || lo < 0) {
            sodium_memzero(key, sizeof *key);
            return -1;
        }
        key->bytes[i / 2] = (unsigned char)(hi << 4 | lo);
    }
    key->len = len / 2;
    return 0;
}

int trioct_admin_key_load(const char *path, trioct_admin_key *key, char *err, size_t err_len)
{
    memset(key, 0, sizeof *key);
    if (!path || !*path)
        return key_fail(err, err_len, "(none)", "no path given");
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        return key_fail(err, err_len, path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        return key_fail(err, err_len, path, "not a regular file");
    }
    if (st.st_mode & (S_IROTH | S_IWOTH)) {
        close(fd);
        char what[96];
        snprintf(what, sizeof what, "others may read or write it (mode %04o); chmod o-rw it",
                 (unsigned)(st.st_mode & 07777));
        return key_fail(err, err_len, path, what);
    }
    char text[KEY_FILE_MAX + 1];
    size_t len = 0;
    for (;;) {
        ssize_t n = read(fd, text + len, sizeof text - 1 - len);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0) {
            int why = errno;
            close(fd);
            return key_fail(err, err_len, path, strerror(why));
        }
        if (n == 0 || (len += (size_t)n) == sizeof text - 1)
            break;
    }
    close(fd);
    if (len >= KEY_FILE_MAX)
        return key_fail(err, err_len, path, "longer than a key of 128 bytes in hex");
    if (len > 0 && text[len - 1] == '\n')
        len--;
    if (len > 0 && text[len - 1] == '\r')
        len--;
    int sized = len % 2 == 0 && len >= 2 * TRIOCT_ADMIN_KEY_MIN_BYTES && len <= 2 * TRIOCT_ADMIN_KEY_MAX_BYTES;
    int rc = trioct_admin_key_from_hex(text, len, key);
    sodium_memzero(text, sizeof text);
    if (!sized)
        return key_fail(err, err_len, path, "the key must be 64 to 256 hex digits (32 to 128 bytes), and nothing else");
    if (rc != 0)
        return key_fail(err, err_len, path, "the key must be hex digits only (a trailing newline is allowed)");
    return 0;
}

void trioct_admin_mac(const trioct_admin_key *key, const char *channel, const void *bytes, size_t len,
                      unsigned char mac[TRIOCT_ADMIN_MAC_BYTES])
{
    crypto_auth_hmacsha256_state state;
    crypto_auth_hmacsha256_init(&state, key->bytes, key->len);
    crypto_auth_hmacsha256_update(&state, (const unsigned char *)channel, strlen(channel) + 1);
    crypto_auth_hmacsha256_update(&state, bytes, len);
    crypto_auth_hmacsha256_final(&state, mac);
    sodium_memzero(&state, sizeof state);
}

void trioct_admin_sign_nonce(const trioct_admin_key *key, const char *channel, void *bytes, size_t len,
                             int64_t utime, const unsigned char nonce[TRIOCT_ADMIN_NONCE_BYTES])
{
    if (len < TRIOCT_ADMIN_AUTH_BYTES)
        return;
    unsigned char *auth = (unsigned char *)bytes + len - TRIOCT_ADMIN_AUTH_BYTES;
    uint64_t u = (uint64_t)utime;
    for (int i = 0; i < 8; i++)
        auth[i] = (unsigned char)(u >> (56 - 8 * i));
    memcpy(auth + 8, nonce, TRIOCT_ADMIN_NONCE_BYTES);
    trioct_admin_mac(key, channel, bytes, len - TRIOCT_ADMIN_MAC_BYTES, auth + 8 + TRIOCT_ADMIN_NONCE_BYTES);
}

void trioct_admin_sign(const trioct_admin_key *key, const char *channel, void *bytes, size_t len, int64_t utime)
{
    unsigned char nonce[TRIOCT_ADMIN_NONCE_BYTES];
    if (sodium_init() < 0)
        return;
    randombytes_buf(nonce, sizeof nonce);
    trioct_admin_sign_nonce(key, channel, bytes, len, utime, nonce);
}

int trioct_admin_verify(const trioct_admin_key *key, const char *channel, const void *bytes, size_t len)
{
    if (len < TRIOCT_ADMIN_AUTH_BYTES || key->len == 0)
        return 0;
    unsigned char mac[TRIOCT_ADMIN_MAC_BYTES];
    trioct_admin_mac(key, channel, bytes, len - TRIOCT_ADMIN_MAC_BYTES, mac);
    return sodium_memcmp(mac, (const unsigned char *)bytes + len - TRIOCT_ADMIN_MAC_BYTES, sizeof mac) == 0;
}

int64_t trioct_admin_utime(const void *bytes, size_t len)
{
    if (len < TRIOCT_ADMIN_AUTH_BYTES)
        return 0;
    const unsigned char *auth = (const unsigned char *)bytes + len - TRIOCT_ADMIN_AUTH_BYTES;
    uint64_t u = 0;
    for (int i = 0; i < 8; i++)
        u = u << 8 | auth[i];
    return (int64_t)u;
}

const unsigned char *trioct_admin_nonce(const void *bytes, size_t len)
{
    if (len < TRIOCT_ADMIN_AUTH_BYTES)
        return NULL;
    return (const unsigned char *)bytes + len - TRIOCT_ADMIN_AUTH_BYTES + 8;
}
