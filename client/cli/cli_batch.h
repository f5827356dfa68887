/* What `rays` and `mesh` share when they cut a long batch into requests under the caps and
 * join the answers: growing the joined records, and noting which world versions answered. */
#ifndef TRIOCT_CLI_BATCH_H
#define TRIOCT_CLI_BATCH_H

#include <stddef.h>
#include <stdint.h>

#include "cli.h"

/* The replies of a batch's requests, in order. */
typedef struct cli_batch {
    trioct_reply reply; /* the last request's */
    size_t requests;
    int64_t first_version, last_version;
} cli_batch;

/* Notes one more request's reply. */
void cli_batch_note(cli_batch *b, const trioct_reply *reply);

/* Warns when the world was rebuilt between the batch's requests, so the answers come from
 * more than one version of it. */
void cli_batch_warn_rebuilt(cli_context *ctx, const cli_batch *b, const char *world);

#endif
