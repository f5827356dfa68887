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

int cli_reserve(void **items, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap)
        return 0;
    size_t grown = *cap ? *cap : 1024;
    while (grown < need)
        grown *= 2;
    void *p = realloc(*items, grown * elem);
    if (p == NULL)
        return -1;
    *items = p;
    *cap = grown;
    return 0;
}
