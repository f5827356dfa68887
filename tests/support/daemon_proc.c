#include "daemon_proc.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

pid_t daemon_proc_start(const char *daemon_bin, const char *scene, const char *url, const char *name,
                        const char *const *extra_args, const char *log_path)
{
    const char *argv[64];
    int n = 0;
    argv[n++] = daemon_bin;
    argv[n++] = "--scene";
    argv[n++] = scene;
    argv[n++] = "--url";
    argv[n++] = url;
    argv[n++] = "--name";
    argv[n++] = name;
    for (int i = 0; extra_args != NULL && extra_args[i] != NULL && n < 62; i++)
        argv[n++] = extra_args[i];
    argv[n] = NULL;

    fflush(NULL);
    pid_t pid = fork();
    if (pid < 0)
        return -1;
    if (pid == 0) {
        int fd = open(log_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd >= 0) {
            dup2(fd, STDOUT_FILENO);
            dup2(fd, STDERR_FILENO);
            close(fd);
        }
        execv(daemon_bin, (char *const *)argv);
        fprintf(stderr, "exec %s: %s\n", daemon_bin, strerror(errno));
        _exit(127);
    }
    return pid;
}

int daemon_proc_wait_ready(trioct_client *c, const char *name, int timeout_ms)
{
    struct timespec start, now;
    clock_gettime(CLOCK_MONOTONIC, &start);
    for (;;) {
        clock_gettime(CLOCK_MONOTONIC, &now);
        long elapsed = (now.tv_sec - start.tv_sec) * 1000 + (now.tv_nsec - start.tv_nsec) / 1000000;
        if (elapsed >= timeout_ms)
            return -1;
        trioct_daemon_status st;
        int rc = trioct_next_status(c, name, (int)(timeout_ms - elapsed), &st);
        int ready = rc == TRIOCT_OK && st.state == TRIOCT_DAEMON_READY;
        trioct_daemon_status_free(&st);
        if (ready)
            return 0;
    }
}

static int exit_code(int wstatus)
{
    if (WIFEXITED(wstatus))
        return WEXITSTATUS(wstatus);
    if (WIFSIGNALED(wstatus))
        return 128 + WTERMSIG(wstatus);
    return -1;
}

int daemon_proc_wait_exit(pid_t pid, int timeout_ms)
{
    for (int waited = 0; waited <= timeout_ms; waited += 10) {
        int wstatus;
        pid_t r = waitpid(pid, &wstatus, WNOHANG);
        if (r == pid)
            return exit_code(wstatus);
        if (r < 0)
            return -1;
        struct timespec ten_ms = {0, 10 * 1000 * 1000};
        nanosleep(&ten_ms, NULL);
    }
    kill(pid, SIGKILL);
    int wstatus;
    waitpid(pid, &wstatus, 0);
    return -1;
}

int daemon_proc_stop(pid_t pid, int sig, int timeout_ms)
{
    if (kill(pid, sig) != 0)
        return -1;
    return daemon_proc_wait_exit(pid, timeout_ms);
}

const char *daemon_proc_loader(void)
{
    static char path[4096];
    ssize_t n = readlink("/proc/self/exe", path, sizeof path - 32);
    if (n <= 0)
        return "trioct-load";
    path[n] = '\0';
    for (int up = 0; up < 2; up++) {
        char *slash = strrchr(path, '/');
        if (slash)
            *slash = '\0';
    }
    strcat(path, "/trioct-load");
    return path;
}

int daemon_proc_write_key(const char *path)
{
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (fd < 0)
        return -1;
    static const char text[] = DAEMON_PROC_KEY_HEX "\n";
    ssize_t n = write(fd, text, sizeof text - 1);
    close(fd);
    if (n != (ssize_t)(sizeof text - 1))
        return -1;
    return setenv("TRIOCT_KEY_FILE", path, 1);
}
