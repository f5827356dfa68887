/* fuzz-make-corpus OUT LOG...: the seed corpora of the request targets, from the request
 * logs of tests/logs: every request of a log, by type, as OUT/TYPE/NNNNN (a channel byte,
 * then the message, the input fuzz_request.c reads). */
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "channels.h"
#include "replay_log.h"

static const char *type_dir(trioct_channel_kind kind)
{
    switch (kind) {
    case TRIOCT_CHANNEL_RAY: return "ray";
    case TRIOCT_CHANNEL_TRI: return "triangle";
    case TRIOCT_CHANNEL_MESH: return "mesh";
    case TRIOCT_CHANNEL_LIST:
    case TRIOCT_CHANNEL_LOAD:
    case TRIOCT_CHANNEL_ADMIN: return "admin";
    case TRIOCT_CHANNEL_OBJECTS: return "objects";
    case TRIOCT_CHANNEL_STATE: return "state";
    case TRIOCT_CHANNEL_DISTANCE: return "distance";
    default: return NULL;
    }
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: fuzz-make-corpus OUT LOG...\n");
        return 2;
    }
    /* Every directory type_dir names: a request type without one failed its first write. */
    const char *types[] = {"ray", "triangle", "mesh", "admin", "objects", "state", "distance"};
    mkdir(argv[1], 0755);
    for (size_t t = 0; t < sizeof types / sizeof types[0]; t++) {
        char dir[4200];
        snprintf(dir, sizeof dir, "%s/%s", argv[1], types[t]);
        if (mkdir(dir, 0755) != 0 && errno != EEXIST) {
            perror(dir);
            return 1;
        }
    }
    size_t written = 0;
    for (int a = 2; a < argc; a++) {
        replay_log log;
        char err[512];
        if (replay_log_read(argv[a], &log, err, sizeof err) != 0) {
            fprintf(stderr, "fuzz-make-corpus: %s\n", err);
            return 1;
        }
        for (size_t i = 0; i < log.count; i++) {
            const replay_event *e = &log.events[i];
            trioct_channel_kind kind;
            char name[TRIOCT_MAX_NAME_LEN + 1];
            if (trioct_channel_parse(e->channel, "TRIOCT", &kind, name) != 0 || !type_dir(kind))
                continue;
            /* The admin target's channel byte: 0 LIST, 1 LOAD, 2 a world's ADMIN channel. */
            unsigned char pick = kind == TRIOCT_CHANNEL_LIST ? 0 : kind == TRIOCT_CHANNEL_LOAD ? 1 : 2;
            char path[4300];
            snprintf(path, sizeof path, "%s/%s/%05zu", argv[1], type_dir(kind), written++);
            FILE *f = fopen(path, "wb");
            if (!f) {
                perror(path);
                replay_log_free(&log);
                return 1;
            }
            fputc(pick, f);
            fwrite(e->data, 1, e->size, f);
            fclose(f);
        }
        replay_log_free(&log);
    }
    printf("fuzz-make-corpus: %zu requests into %s\n", written, argv[1]);
    return 0;
}
