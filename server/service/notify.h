/* Telling systemd how trioctd is doing: the notify protocol of sd_notify(3), spoken without
 * libsystemd.
 *
 * systemd starts a Type=notify service with $NOTIFY_SOCKET naming an AF_UNIX datagram
 * socket: a path, or an abstract name written with a leading '@'. Each message is one
 * datagram of newline-separated KEY=VALUE lines; systemd learns the sender from the
 * credentials the kernel attaches. With $WATCHDOG_USEC set (and $WATCHDOG_PID, when set,
 * naming this process), systemd expects WATCHDOG=1 at least that often and restarts a
 * service that falls silent.
 *
 *   notifier nt;
 *   notify_open(&nt);                       at start: reads the environment
 *   notify_ready(&nt, "ready: 2 worlds");   READY=1 + STATUS=
 *   notify_reloading(&nt, "reloading");     RELOADING=1 + MONOTONIC_USEC= + STATUS=
 *   notify_stopping(&nt, "stopping");       STOPPING=1 + STATUS=
 *   notify_status(&nt, "...");              STATUS= alone, only when the line changed
 *   notify_watchdog(&nt);                   WATCHDOG=1, every notify_watchdog_usec()/2
 *   notify_close(&nt);
 *
 * Without $NOTIFY_SOCKET (run by hand, under another supervisor, in the tests) every call
 * is a no-op returning 0. Sends never block: a datagram systemd cannot take right now is
 * dropped and reported, so a stuck manager cannot stall the event loop. Not thread-safe:
 * one thread (the daemon's loop) owns a notifier. */
#ifndef TRIOCT_SERVICE_NOTIFY_H
#define TRIOCT_SERVICE_NOTIFY_H

#include <stddef.h>
#include <stdint.h>
#include <sys/socket.h>
#include <sys/un.h>

/* A STATUS= line longer than this is cut; systemctl status shows one line anyway. */
#define NOTIFY_STATUS_MAX 256

typedef struct notifier {
    int fd;                   /* -1: no $NOTIFY_SOCKET, every call is a no-op */
    struct sockaddr_un addr;  /* where datagrams go; abstract when sun_path[0] is 0 */
    socklen_t addr_len;
    uint64_t watchdog_usec;   /* 0: no watchdog asked of this process */
    char status[NOTIFY_STATUS_MAX]; /* the last STATUS= sent, so an unchanged one is not */
} notifier;

/* Reads $NOTIFY_SOCKET, $WATCHDOG_USEC and $WATCHDOG_PID. Returns 0 (also when there is no
 * socket to talk to: n is then a no-op), or a negative errno when $NOTIFY_SOCKET is set
 * but unusable (-EINVAL: not an absolute path nor '@name', or too long; -EAFNOSUPPORT: a
 * vsock address; else socket(2)'s error); n is a no-op then too. A $WATCHDOG_USEC that is
 * not a positive decimal, or a $WATCHDOG_PID naming another process, means no watchdog. */
int notify_open(notifier *n);

/* Closes the socket; n becomes a no-op. */
void notify_close(notifier *n);

/* 1 when messages go somewhere. */
int notify_enabled(const notifier *n);

/* The watchdog interval systemd asked for in microseconds, 0 for none. Ping at half of it. */
uint64_t notify_watchdog_usec(const notifier *n);

/* One datagram with exactly text (lines separated by '\n'). 0, or a negative errno
 * (-EAGAIN: systemd's queue is full and the message was dropped). */
int notify_send(notifier *n, const char *text);

/* READY=1 and the status line: start-up or a reload is complete. */
int notify_ready(notifier *n, const char *status);

/* RELOADING=1 with MONOTONIC_USEC= (CLOCK_MONOTONIC now: systemd 253's Type=notify-reload
 * wants it; older managers ignore it) and the status line. READY=1 ends the reload. */
int notify_reloading(notifier *n, const char *status);

/* STOPPING=1 and the status line: the service has begun to stop. */
int notify_stopping(notifier *n, const char *status);

/* STATUS= alone, when status differs from the last line sent; else nothing is sent. */
int notify_status(notifier *n, const char *status);

/* WATCHDOG=1: the loop is alive. */
int notify_watchdog(notifier *n);

#endif
