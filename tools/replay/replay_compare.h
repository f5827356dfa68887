/* Field-by-field comparison of two reassembled replies, printed as decoded fields:
 *
 *   request 17 (client 0x2a, ray_request_t on TRIOCT_RAY_yard): ray 3: t expected 2.5 got 2.5000000001
 *
 * Every field is compared exactly (doubles bit for bit, so -0 differs from 0), except:
 *   - world_info_t.build_seconds and load_seconds: wall-clock times of a build, never compared;
 *   - the message of an ERR_DEADLINE reply says how many microseconds ago the deadline
 *     passed (wall clock): that number is compared as "N"; and messages and last_error
 *     name the world directory (resolved, in a failed LOAD) as "." (replay_canon_text);
 *   - the chunking: replies are compared after reassembly, so where one chunk ends is not
 *     part of the answer;
 *   - with --ignore, world_info_t.queries (a counter that a log recorded from a live system
 *     cannot reproduce), world versions, or messages.
 * Heartbeats (status_t) are not replies and are never compared. */
#ifndef TRIOCT_REPLAY_COMPARE_H
#define TRIOCT_REPLAY_COMPARE_H

#include <stddef.h>
#include <stdio.h>

#include "replay_book.h"

enum {
    REPLAY_IGNORE_QUERIES = 1u << 0, /* world_info_t.queries */
    REPLAY_IGNORE_VERSION = 1u << 1, /* reply_header_t.world_version, world_info_t.version */
    REPLAY_IGNORE_MESSAGE = 1u << 2, /* reply_header_t.message */
};

/* "queries", "version" or "message" into *bits. 0, or -1 for another word. */
int replay_ignore_parse(const char *word, unsigned *bits);

typedef struct replay_rules {
    unsigned ignore;       /* REPLAY_IGNORE_* */
    const char *world_dir; /* absolute, or NULL: written "." in texts (replay_canon_text) */
} replay_rules;

/* Prints a line per difference, each starting "what: ", at most max_lines of them and then
 * how many more there were. Returns the number of differences (0: the replies match). */
size_t replay_compare(const replay_reply *expected, const replay_reply *got, const replay_rules *rules,
                      const char *what, FILE *out, size_t max_lines);

/* The shortest text that reads back as exactly v ("2.5", "0.10000000000000001"). */
void replay_format_double(double v, char *buf, size_t len);

/* A message or last_error as compared: the elapsed microseconds of an ERR_DEADLINE message
 * written "N" (wall clock), and the daemon's world directory, which a failed LOAD names
 * resolved, written "." (it depends on where the logs are checked out). */
void replay_canon_text(int status, const char *text, const char *world_dir, char *out, size_t len);

#endif
