/* Pairs the replies a daemon gave with the replies a golden log holds, by (client id,
 * request id), and counts:
 *   matched     the reply equals the expected one (replay_compare);
 *   mismatched  both came, and differ (each difference printed);
 *   missing     the golden log has a reply the daemon did not give;
 *   extra       the daemon answered where the golden log has no reply: a request left
 *               unanswered on purpose (malformed, a world nobody holds) must stay so;
 *   to nobody   of the extra ones, replies to a key no request of the log has.
 * A replay passes when nothing is mismatched, missing or extra. Lines come in log order of
 * the requests, the replies to nobody last. */
#ifndef TRIOCT_REPLAY_MATCH_H
#define TRIOCT_REPLAY_MATCH_H

#include <stddef.h>
#include <stdio.h>

#include "replay_book.h"
#include "replay_compare.h"

typedef struct replay_counts {
    size_t requests;   /* well-formed requests of the log */
    size_t malformed;  /* events on request channels the validator refused */
    size_t expected;   /* replies in the golden log */
    size_t got;        /* replies the daemon gave */
    size_t matched, mismatched, missing, extra, to_nobody;
    size_t statuses;   /* heartbeats seen in the daemon's output, not compared */
    size_t bad_replies;/* reply-typed messages the validator refused, in either log */
} replay_counts;

/* script: the requests (the log replayed); expected: the golden replies; got: the daemon's.
 * Prints the differences to out (NULL: silent), at most max_lines per reply, and with
 * verbose a line for every reply that matched too. 0, or -1 when out of memory. */
int replay_match(const replay_book *script, const replay_book *expected, const replay_book *got,
                 const replay_rules *rules, size_t max_lines, int verbose, FILE *out, replay_counts *counts);

/* Whether the counts say the replay passed. */
int replay_counts_pass(const replay_counts *c);

/* "requests 57 (2 malformed), replies 55: 55 matched, 0 mismatched, 0 missing, 0 extra
 * (0 to nobody)" */
void replay_counts_print(FILE *out, const replay_counts *c);

/* "request 17 (client 0x2a, ray_request_t on TRIOCT_RAY_yard)" */
void replay_describe(const replay_request *r, char *buf, size_t len);

#endif
