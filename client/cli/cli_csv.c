/* Number lines and ray files (see cli_csv.h). */
#include "cli_csv.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "cli_args.h"

static int is_blank(char c)
{
    return c == ' ' || c == '\t' || c == '\r';
}

/* One field of len characters at start: a finite double, and nothing else. */
static int parse_field(const char *start, size_t len, double *out)
{
    char field[64];
    if (len >= sizeof field)
        return -1;
    memcpy(field, start, len);
    field[len] = '\0';
    return cli_parse_double(field, 0, out);
}

int cli_parse_numbers(const char *text, double *out, int max, char *err, size_t err_len)
{
    const char *p = text;
    int n = 0;
    while (is_blank(*p))
        p++;
    if (*p == '\0')
        return 0;
    for (;;) {
        const char *start = p;
        while (*p != '\0' && *p != ',' && !is_blank(*p))
            p++;
        size_t len = (size_t)(p - start);
        if (len == 0) {
            snprintf(err, err_len, "field %d is empty", n + 1);
            return -1;
        }
        if (n == max) {
            snprintf(err, err_len, "more than %d fields", max);
            return -1;
        }
        if (parse_field(start, len, &out[n]) != 0) {
            snprintf(err, err_len, "field %d '%.*s' is not a finite number", n + 1,
                     (int)(len > 40 ? 40 : len), start);
            return -1;
        }
        n++;
        /* A separator: blanks, or blanks around one comma. */
        while (is_blank(*p))
            p++;
        if (*p == ',') {
            p++;
            while (is_blank(*p))
                p++;
            if (*p == '\0') {
                snprintf(err, err_len, "field %d is empty", n + 1);
                return -1;
            }
        }
        if (*p == '\0')
            return n;
    }
}

void cli_line_reader_init(cli_line_reader *r, FILE *file, const char *name)
{
    memset(r, 0, sizeof *r);
    r->file = file;
    r->name = name;
}

static int skipped(const char *line)
{
    while (is_blank(*line))
        line++;
    return *line == '\0' || *line == '\n' || *line == '#';
}

int cli_line_reader_next(cli_line_reader *r, const char **line, char *err, size_t err_len)
{
    for (;;) {
        errno = 0;
        ssize_t n = getline(&r->buf, &r->cap, r->file);
        if (n < 0) {
            if (ferror(r->file)) {
                snprintf(err, err_len, "%s: read error after line %ld: %s", r->name, r->line_no,
                         strerror(errno ? errno : EIO));
                return -1;
            }
            return 0;
        }
        r->line_no++;
        if (n > 0 && r->buf[n - 1] == '\n')
            r->buf[--n] = '\0';
        if (n > 0 && r->buf[n - 1] == '\r')
            r->buf[--n] = '\0';
        if ((size_t)n != strlen(r->buf)) {
            snprintf(err, err_len, "%s:%ld: the line holds a NUL byte", r->name, r->line_no);
            return -1;
        }
        if (!skipped(r->buf)) {
            *line = r->buf;
            return 1;
        }
    }
}

void cli_line_reader_free(cli_line_reader *r)
{
    free(r->buf);
    r->buf = NULL;
    r->cap = 0;
}

static int ray_list_grow(cli_ray_list *list)
{
    size_t cap = list->cap ? list->cap * 2 : 1024;
    trioct_vec3 *o = realloc(list->origins, cap * sizeof *o);
    if (o == NULL)
        return -1;
    list->origins = o;
    trioct_vec3 *d = realloc(list->directions, cap * sizeof *d);
    if (d == NULL)
        return -1;
    list->directions = d;
    list->cap = cap;
    return 0;
}

int cli_read_rays(FILE *file, const char *name, cli_ray_list *out, char *err, size_t err_len)
{
    memset(out, 0, sizeof *out);
    cli_line_reader reader;
    cli_line_reader_init(&reader, file, name);
    const char *line;
    int rc;
    while ((rc = cli_line_reader_next(&reader, &line, err, err_len)) == 1) {
        double v[6];
        char why[160];
        int n = cli_parse_numbers(line, v, 6, why, sizeof why);
        if (n != 6) {
            if (n >= 0)
                snprintf(why, sizeof why, "found %d", n);
            snprintf(err, err_len, "%s:%ld: expected 6 numbers ox,oy,oz,dx,dy,dz: %s", name,
                     reader.line_no, why);
            rc = -1;
            break;
        }
        if (out->count == out->cap && ray_list_grow(out) != 0) {
            snprintf(err, err_len, "%s:%ld: out of memory for %zu rays", name, reader.line_no,
                     out->count + 1);
            rc = -1;
            break;
        }
        out->origins[out->count] = (trioct_vec3){v[0], v[1], v[2]};
        out->directions[out->count] = (trioct_vec3){v[3], v[4], v[5]};
        out->count++;
    }
    cli_line_reader_free(&reader);
    if (rc < 0)
        cli_ray_list_free(out);
    return rc < 0 ? -1 : 0;
}

void cli_ray_list_free(cli_ray_list *list)
{
    free(list->origins);
    free(list->directions);
    memset(list, 0, sizeof *list);
}
