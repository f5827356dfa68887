/* Command-line scanning and value parsing for the trioct command: pure functions, no I/O.
 *
 * The scanner is written here rather than taken from getopt_long because coordinates are
 * arguments: `trioct ray w 0 0 5 0 0 -1` must read "-1" as a number, not as an option. An
 * argument is an option when it starts with "--" (or is one of the few short aliases such as
 * "-h"); "-" alone and anything that starts with "-" and a digit or "." is positional, and
 * "--" ends the options. */
#ifndef TRIOCT_CLI_ARGS_H
#define TRIOCT_CLI_ARGS_H

#include <stddef.h>

/* The longest option value, several values joined included. */
#define CLI_MAX_VALUE_LEN 512

typedef struct cli_option {
    const char *name; /* the long name without "--"; NULL ends a table */
    char alias;       /* a one-letter short form ("-h"), or 0 */
    int takes_value;  /* 1: "--name VALUE" or "--name=VALUE"; n > 1: "--name V1 .. Vn"
                         (handed over as one value, blank between) or "--name=V1,..,Vn" */
    int id;           /* handed to the set's handler */
} cli_option;

/* Called for each option found. Returns 0, or -1 with err saying what is wrong with it. */
typedef int (*cli_option_fn)(void *user, int id, const char *value, char *err, size_t err_len);

/* One table of options and who handles them (a subcommand scans its own and the global
 * ones in one pass, so global options may stand anywhere on the line). */
typedef struct cli_option_set {
    const cli_option *options;
    cli_option_fn handle;
    void *user;
} cli_option_set;

/* Scans argv[0..argc): options go to their set's handler, the other arguments are stored
 * in order into positional (more than positional_cap of them is an error). With
 * stop_at_positional the scan ends at the first positional argument, which is not stored
 * (the subcommand's name, found by the caller at argv[*consumed]). Returns 0, or -1 with
 * err (an unknown option, a missing value, or the handler's complaint). */
int cli_scan(int argc, char **argv, const cli_option_set *sets, size_t num_sets,
             int stop_at_positional, char **positional, int positional_cap, int *num_positional,
             int *consumed, char *err, size_t err_len);

/* A finite double, the whole text (strtod's syntax). With allow_infinite, also "inf",
 * "+inf" and "infinity". 0, or -1. */
int cli_parse_double(const char *text, int allow_infinite, double *out);

/* Three finite doubles separated by blanks or commas ("1 2 3", "1,2,3"). 0, or -1. */
int cli_parse_vec3(const char *text, double out[3]);

/* A decimal integer in [min, max], the whole text. 0, or -1. */
int cli_parse_int(const char *text, long long min, long long max, long long *out);

/* "exact", "seed", "fast" or "world" to TRIOCT_ACCURACY_*. 0, or -1. */
int cli_parse_accuracy(const char *text, int *out);
/* --accuracy's value as an option handler takes it: 0, or -1 with the usage message. */
int cli_accuracy_option(const char *value, int *out, char *err, size_t err_len);
/* The name of a TRIOCT_ACCURACY_* value ("world" for the world's own mode). */
const char *cli_accuracy_name(int accuracy);

/* "rays,triangles,meshes" (commas or blanks; "all" for the three) to TRIOCT_EFFECT_* bits.
 * 0, or -1 with err naming the word it does not know. */
int cli_parse_effects(const char *text, int *out, char *err, size_t err_len);

/* 1 when s is 1..max_len characters of [A-Za-z0-9_] (world, daemon, shape names and the
 * channel prefix), else 0. */
int cli_name_valid(const char *s, size_t max_len);

#endif
