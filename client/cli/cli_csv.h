/* Reading numbers from text: one line of comma- (or blank-) separated numbers, and the ray
 * files of `trioct rays`. Pure: a FILE in, arrays out, every error naming file and line. */
#ifndef TRIOCT_CLI_CSV_H
#define TRIOCT_CLI_CSV_H

#include <stddef.h>
#include <stdio.h>

#include "trioct.h"

/* Reads up to max finite numbers separated by a comma (blanks around it allowed) or by
 * blanks alone. Returns how many were read, or -1 with err ("field 2 'x' is not a finite
 * number", "more than 6 fields", "field 3 is empty"). A trailing "\r" is ignored. */
int cli_parse_numbers(const char *text, double *out, int max, char *err, size_t err_len);

/* A file read line by line, with the line number for messages; blank lines and lines whose
 * first non-blank character is '#' are skipped. */
typedef struct cli_line_reader {
    FILE *file;
    const char *name; /* for messages: the path, or "<stdin>" */
    long line_no;     /* of the line last returned */
    char *buf;
    size_t cap;
} cli_line_reader;

void cli_line_reader_init(cli_line_reader *r, FILE *file, const char *name);
/* 1 with *line set (valid until the next call), 0 at the end, -1 on a read error (err). */
int cli_line_reader_next(cli_line_reader *r, const char **line, char *err, size_t err_len);
void cli_line_reader_free(cli_line_reader *r);

/* Rays in structure-of-arrays form, as trioct_ray_query wants them. */
typedef struct cli_ray_list {
    size_t count, cap;
    trioct_vec3 *origins;
    trioct_vec3 *directions;
} cli_ray_list;

/* Reads "ox,oy,oz,dx,dy,dz" lines. 0, or -1 with err naming the line
 * ("rays.csv:4: expected 6 numbers ox,oy,oz,dx,dy,dz, found 5"). */
int cli_read_rays(FILE *file, const char *name, cli_ray_list *out, char *err, size_t err_len);
void cli_ray_list_free(cli_ray_list *list);

#endif
