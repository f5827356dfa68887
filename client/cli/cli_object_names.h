/* The object names of a batch's answers: each request's result names its objects in its own
 * table, so the records of a batch are mapped into one table as they are appended. */
#ifndef TRIOCT_CLI_OBJECT_NAMES_H
#define TRIOCT_CLI_OBJECT_NAMES_H

#include <stddef.h>
#include <stdint.h>

#include "trioct.h"

typedef struct cli_names {
    size_t count, cap;
    char (*names)[TRIOCT_MAX_NAME_LEN + 1];
} cli_names;

/* *object indexes from's names; on return it indexes t's (the name added when new). 0, or
 * -1 when out of memory or *object names nothing in from. */
int cli_names_map(cli_names *t, const trioct_object_names *from, int32_t *object);
/* The name at index i, or "?" for none. */
const char *cli_names_get(const cli_names *t, int32_t i);
void cli_names_free(cli_names *t);

#endif
