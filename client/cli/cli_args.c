/* Scanning arguments and parsing option values (see cli_args.h for the rules). */
#include "cli_args.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "trioct.h"

/* "-5", "-.5", "-": values, not options. */
static int is_positional(const char *arg)
{
    if (arg[0] != '-' || arg[1] == '\0')
        return 1;
    return isdigit((unsigned char)arg[1]) || arg[1] == '.';
}

static const cli_option *find_long(const cli_option_set *sets, size_t num_sets, const char *name,
                                   size_t name_len, const cli_option_set **set)
{
    for (size_t s = 0; s < num_sets; s++)
        for (const cli_option *o = sets[s].options; o && o->name; o++)
            if (strlen(o->name) == name_len && strncmp(o->name, name, name_len) == 0) {
                *set = &sets[s];
                return o;
            }
    return NULL;
}

static const cli_option *find_alias(const cli_option_set *sets, size_t num_sets, char alias,
                                    const cli_option_set **set)
{
    for (size_t s = 0; s < num_sets; s++)
        for (const cli_option *o = sets[s].options; o && o->name; o++)
            if (o->alias != 0 && o->alias == alias) {
                *set = &sets[s];
                return o;
            }
    return NULL;
}

/* Handles argv[*i], an option; advances *i past its value when it takes one. */
static int scan_option(int argc, char **argv, int *i, const cli_option_set *sets,
                       size_t num_sets, char *err, size_t err_len)
{
    const char *arg = argv[*i];
    const cli_option_set *set = NULL;
    const cli_option *opt;
    const char *inline_value = NULL;
    if (arg[1] == '-') {
        const char *name = arg + 2;
        const char *eq = strchr(name, '=');
        size_t len = eq ? (size_t)(eq - name) : strlen(name);
        inline_value = eq ? eq + 1 : NULL;
        opt = find_long(sets, num_sets, name, len, &set);
    } else {
        opt = arg[2] == '\0' ? find_alias(sets, num_sets, arg[1], &set) : NULL;
    }
    if (opt == NULL) {
        snprintf(err, err_len, "unknown option '%s'", arg);
        return -1;
    }
    const char *value = NULL;
    char joined[CLI_MAX_VALUE_LEN];
    if (opt->takes_value) {
        if (inline_value != NULL) {
            value = inline_value;
        } else if (*i + opt->takes_value < argc) {
            /* Several values ("--camera 0 -40 12") reach the handler as one, blank between. */
            size_t used = 0;
            joined[0] = '\0';
            for (int k = 1; k <= opt->takes_value; k++) {
                int w = snprintf(joined + used, sizeof joined - used, "%s%s", k > 1 ? " " : "", argv[*i + k]);
                if (w < 0 || (size_t)w >= sizeof joined - used) {
                    snprintf(err, err_len, "the values of --%s are too long", opt->name);
                    return -1;
                }
                used += (size_t)w;
            }
            *i += opt->takes_value;
            value = opt->takes_value == 1 ? argv[*i] : joined;
        } else if (opt->takes_value == 1) {
            snprintf(err, err_len, "option --%s needs a value", opt->name);
            return -1;
        } else {
            snprintf(err, err_len, "option --%s needs %d values", opt->name, opt->takes_value);
            return -1;
        }
    } else if (inline_value != NULL) {
        snprintf(err, err_len, "option --%s takes no value", opt->name);
        return -1;
    }
    return set->handle(set->user, opt->id, value, err, err_len);
}

int cli_scan(int argc, char **argv, const cli_option_set *sets, size_t num_sets,
             int stop_at_positional, char **positional, int positional_cap, int *num_positional,
             int *consumed, char *err, size_t err_len)
{
    int n = 0, i = 0, only_positional = 0;
    for (; i < argc; i++) {
        const char *arg = argv[i];
        if (!only_positional && strcmp(arg, "--") == 0) {
            only_positional = 1;
            continue;
        }
        if (only_positional || is_positional(arg)) {
            if (stop_at_positional)
                break;
            if (n == positional_cap) {
                snprintf(err, err_len, "too many arguments (from '%s' on)", arg);
                return -1;
            }
            positional[n++] = argv[i];
            continue;
        }
        if (scan_option(argc, argv, &i, sets, num_sets, err, err_len) != 0)
            return -1;
    }
    if (num_positional != NULL)
        *num_positional = n;
    if (consumed != NULL)
        *consumed = i;
    return 0;
}

int cli_parse_double(const char *text, int allow_infinite, double *out)
{
    if (text == NULL || text[0] == '\0' || isspace((unsigned char)text[0]))
        return -1;
    char *end;
    errno = 0;
    double v = strtod(text, &end);
    if (*end != '\0' || isnan(v))
        return -1;
    /* strtod gives HUGE_VAL for "1e999" with ERANGE: that is no finite number either. */
    if (isinf(v)) {
        const char *t = text[0] == '+' || text[0] == '-' ? text + 1 : text;
        if (!allow_infinite || errno == ERANGE || !isalpha((unsigned char)t[0]))
            return -1;
    }
    *out = v;
    return 0;
}

int cli_parse_vec3(const char *text, double out[3])
{
    char buf[CLI_MAX_VALUE_LEN];
    if (text == NULL || strlen(text) >= sizeof buf)
        return -1;
    snprintf(buf, sizeof buf, "%s", text);
    double v[3];
    int n = 0;
    for (char *save = NULL, *tok = strtok_r(buf, ", \t", &save); tok != NULL; tok = strtok_r(NULL, ", \t", &save)) {
        if (n == 3 || cli_parse_double(tok, 0, &v[n]) != 0)
            return -1;
        n++;
    }
    if (n != 3)
        return -1;
    memcpy(out, v, sizeof v);
    return 0;
}

int cli_parse_int(const char *text, long long min, long long max, long long *out)
{
    if (text == NULL || text[0] == '\0' || isspace((unsigned char)text[0]))
        return -1;
    char *end;
    errno = 0;
    long long v = strtoll(text, &end, 10);
    if (*end != '\0' || errno == ERANGE || v < min || v > max)
        return -1;
    *out = v;
    return 0;
}

static const struct {
    const char *name;
    int value;
} accuracy_names[] = {
    {"world", TRIOCT_ACCURACY_WORLD},
    {"exact", TRIOCT_ACCURACY_EXACT},
    {"seed", TRIOCT_ACCURACY_SEED},
    {"fast", TRIOCT_ACCURACY_FAST},
};

int cli_parse_accuracy(const char *text, int *out)
{
    for (size_t i = 0; i < sizeof accuracy_names / sizeof accuracy_names[0]; i++)
        if (strcmp(text, accuracy_names[i].name) == 0) {
            *out = accuracy_names[i].value;
            return 0;
        }
    return -1;
}

int cli_accuracy_option(const char *value, int *out, char *err, size_t err_len)
{
    if (cli_parse_accuracy(value, out) == 0)
        return 0;
    snprintf(err, err_len, "--accuracy: '%.40s' is not exact, seed, fast or world", value);
    return -1;
}

const char *cli_accuracy_name(int accuracy)
{
    for (size_t i = 0; i < sizeof accuracy_names / sizeof accuracy_names[0]; i++)
        if (accuracy_names[i].value == accuracy)
            return accuracy_names[i].name;
    return "unknown";
}

static int effect_bit(const char *word, size_t len)
{
    static const struct {
        const char *name;
        int bits;
    } words[] = {
        {"rays", TRIOCT_EFFECT_RAYS},
        {"triangles", TRIOCT_EFFECT_TRIANGLES},
        {"meshes", TRIOCT_EFFECT_MESHES},
        {"distance", TRIOCT_EFFECT_DISTANCE},
        {"all", TRIOCT_EFFECT_RAYS | TRIOCT_EFFECT_TRIANGLES | TRIOCT_EFFECT_MESHES | TRIOCT_EFFECT_DISTANCE},
    };
    for (size_t i = 0; i < sizeof words / sizeof words[0]; i++)
        if (strlen(words[i].name) == len && strncmp(words[i].name, word, len) == 0)
            return words[i].bits;
    return 0;
}

int cli_parse_effects(const char *text, int *out, char *err, size_t err_len)
{
    int bits = 0;
    const char *p = text;
    for (;;) {
        while (*p == ',' || isspace((unsigned char)*p))
            p++;
        if (*p == '\0')
            break;
        size_t len = strcspn(p, ", \t");
        int bit = effect_bit(p, len);
        if (bit == 0) {
            snprintf(err, err_len, "unknown effect '%.*s' (rays, triangles, meshes, distance or all)",
                     (int)(len > 40 ? 40 : len), p);
            return -1;
        }
        bits |= bit;
        p += len;
    }
    if (bits == 0) {
        snprintf(err, err_len, "no effect named (rays, triangles, meshes, distance or all)");
        return -1;
    }
    *out = bits;
    return 0;
}

int cli_name_valid(const char *s, size_t max_len)
{
    size_t n = 0;
    for (; s[n] != '\0'; n++)
        if (!(isalnum((unsigned char)s[n]) || s[n] == '_') || n >= max_len)
            return 0;
    return n > 0;
}
