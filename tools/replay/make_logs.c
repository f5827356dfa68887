/* trioct-make-logs DIR: writes the replay scene, its meshes and the request logs of
 * tests/logs into DIR. Everything comes from fixed seeds and a fixed clock, so the same
 * code writes the same bytes; `make logs` runs it and then records the golden logs with
 * trioct-replay (tools/replay/make_logs.sh), and tests/test_replay.c checks that doing so
 * again reproduces the checked-in files byte for byte. */
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "logs_cases.h"
#include "logs_world.h"

static const char readme[] =
    "# Replay logs\n"
    "\n"
    "Generated: `make logs` rewrites every file here but `recorded/`\n"
    "(tools/replay/make_logs.sh), and tests/test_replay.c checks that doing so gives these\n"
    "very bytes. Do not edit them. `recorded/` holds a real recording of a live daemon\n"
    "instead; its README says how it was made.\n"
    "\n"
    "- `NAME.lcmlog`: a request log, written by trioct-make-logs (tools/replay/logs_*.c).\n"
    "- `NAME.golden.lcmlog`: the same requests, each followed by the reply trioctd gave,\n"
    "  recorded by `trioct-replay record`.\n"
    "- `scene.ini`, `busy.ini` and the meshes: the daemon they run against; NAME.lcmlog\n"
    "  uses NAME.ini when there is one, else scene.ini.\n"
    "\n"
    "Replay one: `build/trioct-replay check --scene tests/logs/scene.ini\n"
    "tests/logs/queries.lcmlog --golden tests/logs/queries.golden.lcmlog`. docs/replay.md\n"
    "says what each log covers and how to make one from a live system.\n";

static int write_readme(const char *dir)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/README.md", dir);
    FILE *f = fopen(path, "w");
    int rc = f != NULL && fputs(readme, f) >= 0 ? 0 : -1;
    if (f != NULL && fclose(f) != 0)
        rc = -1;
    if (rc != 0)
        fprintf(stderr, "trioct-make-logs: cannot write %s: %s\n", path, strerror(errno));
    return rc;
}

int main(int argc, char **argv)
{
    if (argc != 2 || argv[1][0] == '-') {
        fprintf(stderr, "usage: trioct-make-logs DIR\n");
        return 2;
    }
    const char *dir = argv[1];
    if (mkdir(dir, 0755) != 0 && errno != EEXIST) {
        fprintf(stderr, "trioct-make-logs: cannot create %s: %s\n", dir, strerror(errno));
        return 1;
    }
    int (*const logs[])(const char *) = {
        write_readme,      logs_write_world,  logs_write_queries, logs_write_chunked, logs_write_burst,
        logs_write_admin,  logs_write_reload,  logs_write_busy,    logs_write_errors,
        logs_write_overcap, logs_write_hostile, logs_write_stopping, logs_write_touch,
        logs_write_objects, logs_write_distance,
    };
    int rc = 0;
    for (size_t i = 0; i < sizeof logs / sizeof logs[0]; i++)
        rc |= logs[i](dir) != 0;
    return rc;
}
