#include "replay_proc.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

pid_t replay_spawn(const char *const *argv, const char *cwd, const char *log_path, char *err,
                   size_t err_len)
{
    int fd = open(log_path, O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (fd < 0) {
        snprintf(err, err_len, "%s: %s", log_path, strerror(errno));
        return -1;
    }
    /* The child reports a failed chdir or exec through this pipe, closed on a good exec. */
    int report[2];
    if (pipe(report) != 0) {
        snprintf(err, err_len, "pipe: %s", strerror(errno));
        close(fd);
        return -1;
    }
    fcntl(report[1], F_SETFD, FD_CLOEXEC);
    fflush(NULL);
    pid_t pid = fork();
    if (pid < 0) {
        snprintf(err, err_len, "fork: %s", strerror(errno));
        close(fd);
        close(report[0]);
        close(report[1]);
        return -1;
    }
    if (pid == 0) {
        close(report[0]);
        dup2(fd, STDOUT_FILENO);
        dup2(fd, STDERR_FILENO);
        close(fd);
        int why = 0;
        if (cwd != NULL && chdir(cwd) != 0)
            why = errno;
        else if (strchr(argv[0], '/') != NULL)
            execv(argv[0], (char *const *)argv);
        else
            execvp(argv[0], (char *const *)argv);
        if (why == 0)
            why = errno;
        ssize_t w = write(report[1], &why, sizeof why);
        (void)w;
        _exit(127);
    }
    close(fd);
    close(report[1]);
    int why = 0;
    ssize_t n;
    while ((n = read(report[0], &why, sizeof why)) < 0 && errno == EINTR)
        ;
    close(report[0]);
    if (n == (ssize_t)sizeof why) {
        snprintf(err, err_len, "cannot run %s%s%s: %s", argv[0], cwd ? " in " : "", cwd ? cwd : "",
                 strerror(why));
        waitpid(pid, NULL, 0);
        return -1;
    }
    return pid;
}

static int exit_code(int status)
{
    if (WIFEXITED(status))
        return WEXITSTATUS(status);
    if (WIFSIGNALED(status))
        return 128 + WTERMSIG(status);
    return -1;
}

int replay_wait(pid_t pid, int timeout_ms)
{
    struct timespec start, now, nap = {0, 5 * 1000 * 1000};
    clock_gettime(CLOCK_MONOTONIC, &start);
    for (;;) {
        int status;
        pid_t r = waitpid(pid, &status, WNOHANG);
        if (r == pid)
            return exit_code(status);
        if (r < 0 && errno != EINTR)
            return -1;
        clock_gettime(CLOCK_MONOTONIC, &now);
        long ms = (now.tv_sec - start.tv_sec) * 1000 + (now.tv_nsec - start.tv_nsec) / 1000000;
        if (ms >= timeout_ms)
            return -1;
        nanosleep(&nap, NULL);
    }
}

int replay_stop(pid_t pid, int sig, int timeout_ms)
{
    kill(pid, sig);
    int rc = replay_wait(pid, timeout_ms);
    if (rc == -1) {
        kill(pid, SIGKILL);
        rc = replay_wait(pid, 5000);
    }
    return rc;
}

void replay_print_tail(const char *path, int lines)
{
    FILE *f = fopen(path, "r");
    if (f == NULL)
        return;
    /* Keep the last `lines` lines in a ring. */
    enum { MAX_LINES = 64, LINE = 512 };
    static char ring[MAX_LINES][LINE];
    if (lines > MAX_LINES)
        lines = MAX_LINES;
    int n = 0;
    while (fgets(ring[n % lines], LINE, f) != NULL)
        n++;
    fclose(f);
    for (int i = n > lines ? n - lines : 0; i < n; i++) {
        const char *l = ring[i % lines];
        fprintf(stderr, "    %s%s", l, l[0] && l[strlen(l) - 1] == '\n' ? "" : "\n");
    }
}

int replay_own_dir(char *out, size_t len)
{
    ssize_t n = readlink("/proc/self/exe", out, len - 1);
    if (n <= 0)
        return -1;
    out[n] = '\0';
    char *slash = strrchr(out, '/');
    if (slash == NULL)
        return -1;
    *slash = '\0';
    return 0;
}
