/* A streaming JSON writer for --json output: compact, one object on one line, commas
 * placed by the writer. Strings are escaped (quote, backslash, control characters) and
 * bytes that are not UTF-8 become U+FFFD, so the output is valid JSON whatever a daemon's
 * message holds. Doubles are written with %.17g, enough to read back the same double;
 * NaN and infinities, which no answer carries, become null rather than invalid JSON. */
#ifndef TRIOCT_CLI_JSON_H
#define TRIOCT_CLI_JSON_H

#include <stdint.h>
#include <stdio.h>

#include "trioct.h"

#define CLI_JSON_MAX_DEPTH 16

typedef struct cli_json {
    FILE *out;
    int depth;
    int has_items[CLI_JSON_MAX_DEPTH]; /* per open container: a comma before the next item */
    int after_key;                     /* a key was written: the value needs no comma */
} cli_json;

void cli_json_init(cli_json *j, FILE *out);

void cli_json_object_begin(cli_json *j);
void cli_json_object_end(cli_json *j);
void cli_json_array_begin(cli_json *j);
void cli_json_array_end(cli_json *j);

void cli_json_key(cli_json *j, const char *key);
void cli_json_string(cli_json *j, const char *s);
void cli_json_int(cli_json *j, int64_t v);
void cli_json_double(cli_json *j, double v);
void cli_json_bool(cli_json *j, int v);
void cli_json_null(cli_json *j);
void cli_json_vec3(cli_json *j, trioct_vec3 v); /* [x, y, z] */

/* A key and its value in one call. */
void cli_json_key_string(cli_json *j, const char *key, const char *s);
void cli_json_key_int(cli_json *j, const char *key, int64_t v);
void cli_json_key_double(cli_json *j, const char *key, double v);
void cli_json_key_bool(cli_json *j, const char *key, int v);
void cli_json_key_vec3(cli_json *j, const char *key, trioct_vec3 v);

/* Writes s as a quoted, escaped JSON string. */
void cli_json_write_string(FILE *out, const char *s);

#endif
