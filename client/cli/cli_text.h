/* Human output: numbers as short as they can be without lying, byte counts, and tables
 * whose columns line up. Pure. */
#ifndef TRIOCT_CLI_TEXT_H
#define TRIOCT_CLI_TEXT_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#define CLI_NUMBER_LEN 32

/* The shortest of %.15g, %.16g and %.17g that reads back as v: 0.1 prints "0.1", yet two
 * different doubles never print the same. NaN and infinities print "nan", "inf", "-inf". */
const char *cli_format_double(double v, char buf[CLI_NUMBER_LEN]);

/* "812 B", "12.3 KiB", "4.0 MiB", "1.2 GiB". */
const char *cli_format_bytes(int64_t bytes, char buf[CLI_NUMBER_LEN]);

/* Rows of cells printed with every column as wide as its widest cell; the first row is the
 * header. Columns marked numeric are right-aligned. Allocation failures are remembered and
 * reported by cli_table_print, so callers fill a table without checking every cell. */
typedef struct cli_table {
    size_t columns;
    unsigned numeric;  /* bit i: column i right-aligned */
    size_t num_cells, cap_cells;
    char **cells;      /* row-major */
    size_t *widths;
    int failed;
} cli_table;

int cli_table_init(cli_table *t, size_t columns, unsigned numeric_columns);
/* Appends one cell to the current row (rows wrap every `columns` cells). */
void cli_table_cell(cli_table *t, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Prints every row after indent, two spaces between columns, no trailing blanks. 0, or -1
 * when a cell could not be stored. */
int cli_table_print(const cli_table *t, FILE *out, const char *indent);
void cli_table_free(cli_table *t);

#endif
