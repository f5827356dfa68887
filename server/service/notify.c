/* The sd_notify(3) datagram protocol, written from systemd's documentation of it. */
#include "notify.h"

#include <errno.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

/* Room for the longest message: RELOADING=1, MONOTONIC_USEC= and a full STATUS= line. */
#define NOTIFY_MESSAGE_MAX (NOTIFY_STATUS_MAX + 96)

/* A decimal number and nothing else, no sign, no spaces, no overflow: 0 or -1. */
static int parse_u64(const char *text, uint64_t *out)
{
    if (text == NULL || *text == '\0')
        return -1;
    uint64_t v = 0;
    for (const char *p = text; *p != '\0'; p++) {
        if (*p < '0' || *p > '9')
            return -1;
        unsigned digit = (unsigned)(*p - '0');
        if (v > (UINT64_MAX - digit) / 10)
            return -1;
        v = v * 10 + digit;
    }
    *out = v;
    return 0;
}

/* systemd sets WATCHDOG_PID when the watchdog is meant for one process only: a child that
 * inherited the environment must not ping for its parent. */
static uint64_t watchdog_from_env(void)
{
    uint64_t usec;
    if (parse_u64(getenv("WATCHDOG_USEC"), &usec) < 0 || usec == 0)
        return 0;
    const char *pid_text = getenv("WATCHDOG_PID");
    if (pid_text != NULL) {
        uint64_t pid;
        if (parse_u64(pid_text, &pid) < 0 || pid != (uint64_t)getpid())
            return 0;
    }
    return usec;
}

/* "/run/systemd/notify" or "@name" (an abstract socket: sun_path starts with a NUL and the
 * name's length, not a terminator, ends it). */
static int address_from_text(const char *text, struct sockaddr_un *addr, socklen_t *len)
{
    size_t n = strlen(text);
    memset(addr, 0, sizeof *addr);
    addr->sun_family = AF_UNIX;
    if (strncmp(text, "vsock:", 6) == 0)
        return -EAFNOSUPPORT; /* for services in VMs; trioctd runs on the host it serves */
    if ((text[0] != '/' && text[0] != '@') || n < 2 || n >= sizeof addr->sun_path)
        return -EINVAL;
    memcpy(addr->sun_path, text, n);
    if (text[0] == '@') {
        addr->sun_path[0] = '\0';
        *len = (socklen_t)(offsetof(struct sockaddr_un, sun_path) + n);
    } else {
        *len = (socklen_t)(offsetof(struct sockaddr_un, sun_path) + n + 1);
    }
    return 0;
}

int notify_open(notifier *n)
{
    memset(n, 0, sizeof *n);
    n->fd = -1;
    const char *where = getenv("NOTIFY_SOCKET");
    if (where == NULL || where[0] == '\0')
        return 0;
    int rc = address_from_text(where, &n->addr, &n->addr_len);
    if (rc < 0)
        return rc;
    /* Non-blocking: a manager that does not read must cost a dropped datagram, never a
     * stalled loop. Close-on-exec: nothing the daemon starts may talk for it. */
    n->fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    if (n->fd < 0) {
        rc = -errno;
        n->fd = -1;
        return rc;
    }
    n->watchdog_usec = watchdog_from_env();
    return 0;
}

void notify_close(notifier *n)
{
    if (n->fd >= 0)
        close(n->fd);
    n->fd = -1;
    n->watchdog_usec = 0;
}

int notify_enabled(const notifier *n)
{
    return n->fd >= 0;
}

uint64_t notify_watchdog_usec(const notifier *n)
{
    return n->fd >= 0 ? n->watchdog_usec : 0;
}

int notify_send(notifier *n, const char *text)
{
    if (n->fd < 0)
        return 0;
    size_t len = strlen(text);
    for (;;) {
        /* Unconnected: systemd may recreate its socket (daemon-reexec) between two sends. */
        ssize_t sent = sendto(n->fd, text, len, MSG_NOSIGNAL, (const struct sockaddr *)&n->addr,
                              n->addr_len);
        if (sent >= 0)
            return (size_t)sent == len ? 0 : -EMSGSIZE;
        if (errno != EINTR)
            return errno == EWOULDBLOCK ? -EAGAIN : -errno;
    }
}

/* The status line as systemd gets it: one line (a newline would start a new assignment),
 * at most NOTIFY_STATUS_MAX - 1 bytes. */
static void status_line(char out[NOTIFY_STATUS_MAX], const char *status)
{
    size_t i = 0;
    for (; status[i] != '\0' && i < NOTIFY_STATUS_MAX - 1; i++)
        out[i] = status[i] == '\n' || status[i] == '\r' ? ' ' : status[i];
    out[i] = '\0';
}

/* Sends head followed by STATUS=status, and remembers the line once it went out. */
static int send_with_status(notifier *n, const char *head, const char *status)
{
    if (n->fd < 0)
        return 0;
    char line[NOTIFY_STATUS_MAX];
    status_line(line, status);
    char msg[NOTIFY_MESSAGE_MAX];
    snprintf(msg, sizeof msg, "%s%sSTATUS=%s", head, head[0] != '\0' ? "\n" : "", line);
    int rc = notify_send(n, msg);
    if (rc == 0)
        memcpy(n->status, line, sizeof line);
    return rc;
}

int notify_ready(notifier *n, const char *status)
{
    return send_with_status(n, "READY=1", status);
}

int notify_reloading(notifier *n, const char *status)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    char head[64];
    snprintf(head, sizeof head, "RELOADING=1\nMONOTONIC_USEC=%llu",
             (unsigned long long)ts.tv_sec * 1000000ull + (unsigned long long)ts.tv_nsec / 1000);
    return send_with_status(n, head, status);
}

int notify_stopping(notifier *n, const char *status)
{
    return send_with_status(n, "STOPPING=1", status);
}

int notify_status(notifier *n, const char *status)
{
    if (n->fd < 0)
        return 0;
    char line[NOTIFY_STATUS_MAX];
    status_line(line, status);
    if (strcmp(line, n->status) == 0)
        return 0;
    return send_with_status(n, "", line);
}

int notify_watchdog(notifier *n)
{
    return notify_send(n, "WATCHDOG=1");
}
