/* trioct-replay: replays an LCM log of trioct requests against a fresh trioctd and compares
 * its replies with recorded ones. docs/replay.md says how to use it.
 *
 *   trioct-replay check  --scene S [--world-dir D] LOG [--golden GOLDEN]
 *   trioct-replay record --scene S [--world-dir D] LOG -o GOLDEN
 *   trioct-replay live   --scene S [--world-dir D] LOG [--golden GOLDEN]
 *
 * Exit status: 0 when every reply matched (record: when the golden log was written), 1
 * when replies differ, are missing or extra, 2 when the replay could not run. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "replay_compare.h"
#include "replay_session.h"

#define DEFAULT_MAX_LINES 20
#define DEFAULT_TIMEOUT_S 120
#define DEFAULT_LIVE_URL "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"

static void usage(FILE *f)
{
    fprintf(f,
            "usage: trioct-replay check  --scene S [options] LOG [--golden GOLDEN]\n"
            "       trioct-replay record --scene S [options] LOG -o GOLDEN\n"
            "       trioct-replay live   --scene S [options] LOG [--golden GOLDEN]\n"
            "\n"
            "Feeds the requests of an LCM log to a fresh trioctd and compares its replies, paired\n"
            "by (client id, request id), with the replies of the golden log (or of LOG itself).\n"
            "check runs the daemon on file:// logs, live over udpm with lcm-logplayer and\n"
            "lcm-logger (inside a private network namespace: tests/e2e/netns.sh); record writes\n"
            "the golden log.\n"
            "\n"
            "  -s, --scene FILE       the daemon's scene\n"
            "  -w, --world-dir DIR    where its meshes are (default: the scene's directory)\n"
            "  -g, --golden FILE      the replies to expect (default: those in LOG)\n"
            "  -o, --output FILE      record: the golden log to write\n"
            "  -t, --threads N        the daemon's worker threads (default: its own default)\n"
            "  -d, --daemon PATH      the trioctd to run (default: the one beside this program)\n"
            "      --key-file FILE    the daemon's admin key (default: the key tests/logs are\n"
            "                         signed with)\n"
            "  -i, --ignore FIELD     do not compare FIELD: queries, version or message (repeat)\n"
            "  -m, --max-lines N      difference lines printed per reply (default %d)\n"
            "      --timeout S        seconds the daemon has to answer everything (default %d)\n"
            "  -k, --keep             keep the scratch directory (input, output, daemon log)\n"
            "  -q, --quiet            print the counts only\n"
            "  -v, --verbose          print every reply that matched too\n"
            "  -u, --url URL          live: the bus (default " DEFAULT_LIVE_URL ")\n"
            "      --speed X          live: lcm-logplayer's speed (default 1: the log's timing)\n"
            "      --host-network     live: run even outside a private network namespace\n"
            "  -h, --help\n",
            DEFAULT_MAX_LINES, DEFAULT_TIMEOUT_S);
}

enum { OPT_TIMEOUT = 256, OPT_SPEED, OPT_HOST_NETWORK, OPT_KEY_FILE };

static int parse_count(const char *text, long lo, long hi, long *out)
{
    char *end;
    long v = strtol(text, &end, 10);
    if (text[0] == '\0' || *end != '\0' || v < lo || v > hi)
        return -1;
    *out = v;
    return 0;
}

static int parse(int argc, char **argv, replay_options *o)
{
    static const struct option longs[] = {
        {"scene", required_argument, NULL, 's'},     {"world-dir", required_argument, NULL, 'w'},
        {"golden", required_argument, NULL, 'g'},    {"output", required_argument, NULL, 'o'},
        {"threads", required_argument, NULL, 't'},   {"daemon", required_argument, NULL, 'd'},
        {"ignore", required_argument, NULL, 'i'},    {"max-lines", required_argument, NULL, 'm'},
        {"timeout", required_argument, NULL, OPT_TIMEOUT},
        {"keep", no_argument, NULL, 'k'},            {"quiet", no_argument, NULL, 'q'},
        {"verbose", no_argument, NULL, 'v'},
        {"url", required_argument, NULL, 'u'},       {"speed", required_argument, NULL, OPT_SPEED},
        {"host-network", no_argument, NULL, OPT_HOST_NETWORK},
        {"key-file", required_argument, NULL, OPT_KEY_FILE},
        {"help", no_argument, NULL, 'h'},            {NULL, 0, NULL, 0},
    };
    memset(o, 0, sizeof *o);
    o->max_lines = DEFAULT_MAX_LINES;
    o->timeout_s = DEFAULT_TIMEOUT_S;
    o->url = DEFAULT_LIVE_URL;
    o->speed = "1";
    if (argc < 2 || strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "--help") == 0) {
        usage(argc < 2 ? stderr : stdout);
        return argc < 2 ? -1 : 1;
    }
    o->mode = argv[1];
    if (strcmp(o->mode, "check") != 0 && strcmp(o->mode, "record") != 0 && strcmp(o->mode, "live") != 0) {
        fprintf(stderr, "trioct-replay: unknown mode '%s' (check, record or live)\n", o->mode);
        return -1;
    }
    optind = 2;
    int c;
    long v;
    while ((c = getopt_long(argc, argv, "s:w:g:o:t:d:i:m:kqvu:h", longs, NULL)) != -1) {
        switch (c) {
        case 's': o->scene = optarg; break;
        case 'w': o->world_dir = optarg; break;
        case 'g': o->golden = optarg; break;
        case 'o': o->output = optarg; break;
        case 'd': o->daemon = optarg; break;
        case 'k': o->keep = 1; break;
        case 'q': o->quiet = 1; break;
        case 'v': o->verbose = 1; break;
        case 'u': o->url = optarg; break;
        case OPT_SPEED: o->speed = optarg; break;
        case OPT_HOST_NETWORK: o->host_network = 1; break;
        case OPT_KEY_FILE: o->key_file = optarg; break;
        case 't':
            if (parse_count(optarg, 1, 1024, &v) < 0) {
                fprintf(stderr, "trioct-replay: --threads: '%s' is not in 1..1024\n", optarg);
                return -1;
            }
            o->threads = (int)v;
            break;
        case 'm':
            if (parse_count(optarg, 0, 1000000, &v) < 0) {
                fprintf(stderr, "trioct-replay: --max-lines: '%s' is not in 0..1000000\n", optarg);
                return -1;
            }
            o->max_lines = (size_t)v;
            break;
        case OPT_TIMEOUT:
            if (parse_count(optarg, 1, 86400, &v) < 0) {
                fprintf(stderr, "trioct-replay: --timeout: '%s' is not in 1..86400 seconds\n", optarg);
                return -1;
            }
            o->timeout_s = (int)v;
            break;
        case 'i':
            if (replay_ignore_parse(optarg, &o->ignore) < 0) {
                fprintf(stderr, "trioct-replay: --ignore: '%s' is not queries, version or message\n", optarg);
                return -1;
            }
            break;
        case 'h':
            usage(stdout);
            return 1;
        default:
            usage(stderr);
            return -1;
        }
    }
    if (optind != argc - 1) {
        fprintf(stderr, "trioct-replay: %s needs exactly one LOG\n", o->mode);
        return -1;
    }
    o->log = argv[optind];
    if (o->scene == NULL) {
        fprintf(stderr, "trioct-replay: --scene FILE is needed: the daemon's scene\n");
        return -1;
    }
    if (strcmp(o->mode, "record") == 0 && (o->output == NULL || o->golden != NULL)) {
        fprintf(stderr, "trioct-replay: record writes -o GOLDEN from LOG, and takes no --golden\n");
        return -1;
    }
    if (strcmp(o->mode, "record") != 0 && o->output != NULL) {
        fprintf(stderr, "trioct-replay: -o is for record\n");
        return -1;
    }
    return 0;
}

int main(int argc, char **argv)
{
    replay_options o;
    int p = parse(argc, argv, &o);
    if (p != 0)
        return p > 0 ? 0 : 2;
    FILE *out = stdout;
    replay_session s;
    int rc = 2;
    if (replay_session_open(&s, &o) < 0)
        goto done;
    int live = strcmp(o.mode, "live") == 0;
    if (!o.quiet) {
        char threads[32] = "";
        if (o.threads > 0)
            snprintf(threads, sizeof threads, " at %d thread%s", o.threads, o.threads == 1 ? "" : "s");
        fprintf(out, "trioct-replay %s: %s (%zu messages in)%s, daemon %s%s\n", o.mode, o.log, s.inputs,
                live ? " over udpm" : "", s.daemon_bin, threads);
        if (strcmp(o.mode, "record") != 0)
            fprintf(out, "expecting the replies of %s\n", o.golden ? o.golden : o.log);
    }
    if ((live ? replay_live_run(&s) : replay_session_run_offline(&s)) < 0)
        goto done;
    if (strcmp(o.mode, "record") == 0) {
        rc = replay_record_golden(&s, o.output, out) < 0 ? 2 : 0;
        goto done;
    }
    int r = replay_session_compare(&s, o.quiet ? NULL : out, out);
    rc = r < 0 ? 2 : r;
    if (!o.quiet && r >= 0)
        fprintf(out, "%s\n", r == 0 ? "PASS" : "FAIL");
done:
    replay_session_close(&s);
    return rc;
}
