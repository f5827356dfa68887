/* Human-readable numbers and aligned tables (see cli_text.h). */
#include "cli_text.h"

#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

const char *cli_format_double(double v, char buf[CLI_NUMBER_LEN])
{
    if (isnan(v))
        return strcpy(buf, "nan");
    if (isinf(v))
        return strcpy(buf, v > 0 ? "inf" : "-inf");
    if (v == 0.0)
        return strcpy(buf, "0"); /* -0 too: a sign on nothing only puzzles a reader */
    for (int precision = 15; precision < 17; precision++) {
        snprintf(buf, CLI_NUMBER_LEN, "%.*g", precision, v);
        if (strtod(buf, NULL) == v)
            return buf;
    }
    snprintf(buf, CLI_NUMBER_LEN, "%.17g", v);
    return buf;
}

const char *cli_format_bytes(int64_t bytes, char buf[CLI_NUMBER_LEN])
{
    static const char *const units[] = {"KiB", "MiB", "GiB", "TiB"};
    if (bytes < 1024) {
        snprintf(buf, CLI_NUMBER_LEN, "%" PRId64 " B", bytes);
        return buf;
    }
    double v = (double)bytes / 1024.0;
    size_t u = 0;
    while (v >= 1024.0 && u + 1 < sizeof units / sizeof units[0]) {
        v /= 1024.0;
        u++;
    }
    snprintf(buf, CLI_NUMBER_LEN, "%.1f %s", v, units[u]);
    return buf;
}

int cli_table_init(cli_table *t, size_t columns, unsigned numeric_columns)
{
    memset(t, 0, sizeof *t);
    t->columns = columns;
    t->numeric = numeric_columns;
    t->widths = calloc(columns, sizeof *t->widths);
    t->failed = t->widths == NULL;
    return t->failed ? -1 : 0;
}

static int reserve_cell(cli_table *t)
{
    if (t->num_cells < t->cap_cells)
        return 0;
    size_t cap = t->cap_cells ? t->cap_cells * 2 : 64;
    char **cells = realloc(t->cells, cap * sizeof *cells);
    if (cells == NULL)
        return -1;
    t->cells = cells;
    t->cap_cells = cap;
    return 0;
}

void cli_table_cell(cli_table *t, const char *fmt, ...)
{
    if (t->failed)
        return;
    va_list ap;
    va_start(ap, fmt);
    int len = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    char *cell = len >= 0 ? malloc((size_t)len + 1) : NULL;
    if (cell == NULL || reserve_cell(t) != 0) {
        free(cell);
        t->failed = 1;
        return;
    }
    va_start(ap, fmt);
    vsnprintf(cell, (size_t)len + 1, fmt, ap);
    va_end(ap);
    size_t column = t->num_cells % t->columns;
    if ((size_t)len > t->widths[column])
        t->widths[column] = (size_t)len;
    t->cells[t->num_cells++] = cell;
}

int cli_table_print(const cli_table *t, FILE *out, const char *indent)
{
    if (t->failed)
        return -1;
    for (size_t i = 0; i < t->num_cells; i++) {
        size_t column = i % t->columns;
        int last = column + 1 == t->columns || i + 1 == t->num_cells;
        int width = (int)t->widths[column];
        if (column == 0)
            fputs(indent, out);
        else
            fputs("  ", out);
        if (t->numeric & (1u << column))
            fprintf(out, "%*s", width, t->cells[i]);
        else if (last)
            fputs(t->cells[i], out);
        else
            fprintf(out, "%-*s", width, t->cells[i]);
        if (last)
            fputc('\n', out);
    }
    return 0;
}

void cli_table_free(cli_table *t)
{
    for (size_t i = 0; i < t->num_cells; i++)
        free(t->cells[i]);
    free(t->cells);
    free(t->widths);
    memset(t, 0, sizeof *t);
}
