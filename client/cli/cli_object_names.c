/* One table of object names across a batch's results (cli_object_names.h). */
#include "cli_object_names.h"

#include <stdlib.h>
#include <string.h>

int cli_names_map(cli_names *t, const trioct_object_names *from, int32_t *object)
{
    if (*object < 0 || (size_t)*object >= from->count)
        return -1;
    const char *name = from->names[*object];
    for (size_t i = 0; i < t->count; i++)
        if (strcmp(t->names[i], name) == 0) {
            *object = (int32_t)i;
            return 0;
        }
    if (t->count == t->cap) {
        size_t cap = t->cap ? 2 * t->cap : 8;
        void *grown = realloc(t->names, cap * sizeof *t->names);
        if (grown == NULL)
            return -1;
        t->names = grown;
        t->cap = cap;
    }
    memcpy(t->names[t->count], name, sizeof t->names[t->count]);
    *object = (int32_t)t->count++;
    return 0;
}

const char *cli_names_get(const cli_names *t, int32_t i)
{
    return i >= 0 && (size_t)i < t->count ? t->names[i] : "?";
}

void cli_names_free(cli_names *t)
{
    free(t->names);
    memset(t, 0, sizeof *t);
}
