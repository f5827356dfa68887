#include "cli_batch.h"

#include <inttypes.h>
#include <stdlib.h>

void cli_batch_note(cli_batch *b, const trioct_reply *reply)
{
    if (b->requests == 0)
        b->first_version = reply->world_version;
    b->last_version = reply->world_version;
    b->reply = *reply;
    b->requests++;
}

void cli_batch_warn_rebuilt(cli_context *ctx, const cli_batch *b, const char *world)
{
    if (b->first_version != b->last_version)
        cli_warn(ctx, "world %s was rebuilt during the batch: the answers come from versions %" PRId64 " to %" PRId64,
                 world, b->first_version, b->last_version);
}
