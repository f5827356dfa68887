/* The --json writer (see cli_json.h). */
#include "cli_json.h"

#include <inttypes.h>
#include <math.h>
#include <string.h>

void cli_json_init(cli_json *j, FILE *out)
{
    memset(j, 0, sizeof *j);
    j->out = out;
}

/* Before every value and key: a comma when the container already holds an item. */
static void separate(cli_json *j)
{
    if (j->after_key) {
        j->after_key = 0;
        return;
    }
    if (j->depth > 0) {
        if (j->has_items[j->depth - 1])
            fputc(',', j->out);
        j->has_items[j->depth - 1] = 1;
    }
}

static void open_container(cli_json *j, char c)
{
    separate(j);
    fputc(c, j->out);
    if (j->depth < CLI_JSON_MAX_DEPTH)
        j->has_items[j->depth] = 0;
    j->depth++;
}

static void close_container(cli_json *j, char c)
{
    if (j->depth > 0)
        j->depth--;
    fputc(c, j->out);
}

void cli_json_object_begin(cli_json *j)
{
    open_container(j, '{');
}

void cli_json_object_end(cli_json *j)
{
    close_container(j, '}');
}

void cli_json_array_begin(cli_json *j)
{
    open_container(j, '[');
}

void cli_json_array_end(cli_json *j)
{
    close_container(j, ']');
}

void cli_json_key(cli_json *j, const char *key)
{
    separate(j);
    cli_json_write_string(j->out, key);
    fputc(':', j->out);
    j->after_key = 1;
}

void cli_json_string(cli_json *j, const char *s)
{
    separate(j);
    cli_json_write_string(j->out, s ? s : "");
}

void cli_json_int(cli_json *j, int64_t v)
{
    separate(j);
    fprintf(j->out, "%" PRId64, v);
}

void cli_json_double(cli_json *j, double v)
{
    separate(j);
    if (isfinite(v))
        fprintf(j->out, "%.17g", v);
    else
        fputs("null", j->out);
}

void cli_json_bool(cli_json *j, int v)
{
    separate(j);
    fputs(v ? "true" : "false", j->out);
}

void cli_json_null(cli_json *j)
{
    separate(j);
    fputs("null", j->out);
}

void cli_json_vec3(cli_json *j, trioct_vec3 v)
{
    cli_json_array_begin(j);
    cli_json_double(j, v.x);
    cli_json_double(j, v.y);
    cli_json_double(j, v.z);
    cli_json_array_end(j);
}

void cli_json_key_string(cli_json *j, const char *key, const char *s)
{
    cli_json_key(j, key);
    cli_json_string(j, s);
}

void cli_json_key_int(cli_json *j, const char *key, int64_t v)
{
    cli_json_key(j, key);
    cli_json_int(j, v);
}

void cli_json_key_double(cli_json *j, const char *key, double v)
{
    cli_json_key(j, key);
    cli_json_double(j, v);
}

void cli_json_key_bool(cli_json *j, const char *key, int v)
{
    cli_json_key(j, key);
    cli_json_bool(j, v);
}

void cli_json_key_vec3(cli_json *j, const char *key, trioct_vec3 v)
{
    cli_json_key(j, key);
    cli_json_vec3(j, v);
}

/* Length of the well-formed UTF-8 sequence at s (1..4), or 0 when the bytes there are not
 * one: a stray continuation byte, a truncated sequence, an overlong form, a surrogate or a
 * code point past U+10FFFF. */
static size_t utf8_sequence(const unsigned char *s)
{
    unsigned char c = s[0];
    if (c < 0x80)
        return 1;
    size_t len;
    unsigned char lo = 0x80, hi = 0xBF; /* the range of the second byte */
    if (c >= 0xC2 && c <= 0xDF) {
        len = 2;
    } else if (c >= 0xE0 && c <= 0xEF) {
        len = 3;
        if (c == 0xE0)
            lo = 0xA0; /* overlong below U+0800 */
        if (c == 0xED)
            hi = 0x9F; /* surrogates U+D800..DFFF */
    } else if (c >= 0xF0 && c <= 0xF4) {
        len = 4;
        if (c == 0xF0)
            lo = 0x90; /* overlong below U+10000 */
        if (c == 0xF4)
            hi = 0x8F; /* past U+10FFFF */
    } else {
        return 0;
    }
    if (s[1] < lo || s[1] > hi)
        return 0;
    for (size_t i = 2; i < len; i++)
        if (s[i] < 0x80 || s[i] > 0xBF)
            return 0;
    return len;
}

void cli_json_write_string(FILE *out, const char *s)
{
    const unsigned char *p = (const unsigned char *)s;
    fputc('"', out);
    while (*p != '\0') {
        unsigned char c = *p;
        switch (c) {
        case '"': fputs("\\\"", out); p++; continue;
        case '\\': fputs("\\\\", out); p++; continue;
        case '\n': fputs("\\n", out); p++; continue;
        case '\r': fputs("\\r", out); p++; continue;
        case '\t': fputs("\\t", out); p++; continue;
        case '\b': fputs("\\b", out); p++; continue;
        case '\f': fputs("\\f", out); p++; continue;
        default: break;
        }
        if (c < 0x20) {
            fprintf(out, "\\u%04x", c);
            p++;
            continue;
        }
        size_t len = utf8_sequence(p);
        if (len == 0) {
            fputs("\\ufffd", out);
            p++;
            continue;
        }
        fwrite(p, 1, len, out);
        p += len;
    }
    fputc('"', out);
}
