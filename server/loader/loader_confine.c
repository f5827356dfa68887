/* How trioct-load confines itself before it opens the file it is given. */
#define _GNU_SOURCE
#include "loader_confine.h"

#include <errno.h>
#include <limits.h>
#include <sched.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <seccomp.h>

/* The main thread's stack, set rather than inherited so a deep file fails the same way
 * wherever the daemon runs. Assimp recurses once per nested node: 8 MiB holds a few
 * thousand levels. */
#define LOADER_STACK_BYTES (8u << 20)
/* The parser opens the file and, for some formats, the files it names (materials, buffers). */
#define LOADER_OPEN_FILES 64u

#if defined(__SANITIZE_ADDRESS__)
#define LOADER_UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define LOADER_UNDER_ASAN 1
#endif
#endif

static int set_limit(int resource, rlim_t soft, rlim_t hard, const char *what, char *err, size_t err_len)
{
    struct rlimit limit = {.rlim_cur = soft, .rlim_max = hard};
    if (setrlimit(resource, &limit) == 0)
        return 0;
    snprintf(err, err_len, "the loader cannot limit its %s: %s", what, strerror(errno));
    return -1;
}

/* Descriptors the daemon held (its LCM sockets among them) must not reach the parser. */
static void close_inherited(void)
{
#ifdef SYS_close_range
    if (syscall(SYS_close_range, 3u, UINT_MAX, 0u) == 0)
        return;
#endif
    long max = sysconf(_SC_OPEN_MAX);
    for (long fd = 3; fd < (max > 0 ? max : 1024); fd++)
        close((int)fd);
}

/* Sockets, new processes and exec are what a parser taken over would use to reach further;
 * the parser needs none. A clone that shares the address space (a thread, or the sanitizers'
 * leak-check tracer) stays allowed; one that does not is a fork. clone3 hides its flags
 * from the filter, so it fails with ENOSYS and the C library falls back to clone. */
static int deny_network_and_exec(char *err, size_t err_len)
{
    static const int denied[] = {
        SCMP_SYS(socket),   SCMP_SYS(socketpair), SCMP_SYS(connect), SCMP_SYS(bind),
        SCMP_SYS(listen),   SCMP_SYS(accept),     SCMP_SYS(accept4), SCMP_SYS(execve),
        SCMP_SYS(execveat), SCMP_SYS(fork),       SCMP_SYS(vfork),
    };
    scmp_filter_ctx ctx = seccomp_init(SCMP_ACT_ALLOW);
    if (!ctx) {
        snprintf(err, err_len, "the loader cannot set up its system-call filter");
        return -1;
    }
    int rc = 0;
    for (size_t i = 0; i < sizeof denied / sizeof denied[0] && rc == 0; i++)
        rc = seccomp_rule_add(ctx, SCMP_ACT_ERRNO(EACCES), denied[i], 0);
    if (rc == 0)
        rc = seccomp_rule_add(ctx, SCMP_ACT_ERRNO(EACCES), SCMP_SYS(clone), 1,
                              SCMP_A0(SCMP_CMP_MASKED_EQ, CLONE_VM, 0));
    if (rc == 0)
        rc = seccomp_rule_add(ctx, SCMP_ACT_ERRNO(ENOSYS), SCMP_SYS(clone3), 0);
    if (rc == 0)
        rc = seccomp_load(ctx);
    seccomp_release(ctx);
    if (rc != 0) {
        snprintf(err, err_len, "the loader cannot load its system-call filter: %s", strerror(-rc));
        return -1;
    }
    return 0;
}

int loader_confine(unsigned long long memory, unsigned cpu, long parent, char *err, size_t err_len)
{
    close_inherited();
    /* Dies with the daemon instead of parsing on for no one; the check after the call
     * catches a daemon that died before it. */
    if (parent > 0) {
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        if (getppid() != (pid_t)parent)
            _exit(1);
    }
    if (prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0) {
        snprintf(err, err_len, "the loader cannot drop privileges: %s", strerror(errno));
        return -1;
    }
    if (set_limit(RLIMIT_CORE, 0, 0, "core dumps", err, err_len) != 0 ||
        set_limit(RLIMIT_FSIZE, 0, 0, "file writes", err, err_len) != 0 ||
        set_limit(RLIMIT_NOFILE, LOADER_OPEN_FILES, LOADER_OPEN_FILES, "open files", err, err_len) != 0 ||
        set_limit(RLIMIT_STACK, LOADER_STACK_BYTES, LOADER_STACK_BYTES, "stack", err, err_len) != 0)
        return -1;
    /* SIGXCPU at the soft limit, SIGKILL a second later if it is caught. */
    if (cpu > 0 && set_limit(RLIMIT_CPU, cpu, (rlim_t)cpu + 1, "CPU time", err, err_len) != 0)
        return -1;
#ifndef LOADER_UNDER_ASAN
    /* AddressSanitizer reserves terabytes of shadow at start, which an address-space limit
     * forbids; the sanitizer build of the loader runs without one. */
    if (memory > 0 && set_limit(RLIMIT_AS, memory, memory, "address space", err, err_len) != 0)
        return -1;
#else
    (void)memory;
#endif
    return deny_network_and_exec(err, err_len);
}

