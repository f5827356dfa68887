#include "channels.h"

#include <stdio.h>
#include <string.h>

static const char *const kind_tag[TRIOCT_CHANNEL_KIND_COUNT] = {
    [TRIOCT_CHANNEL_RAY] = "RAY",     [TRIOCT_CHANNEL_TRI] = "TRI",
    [TRIOCT_CHANNEL_MESH] = "MESH",   [TRIOCT_CHANNEL_ADMIN] = "ADMIN",
    [TRIOCT_CHANNEL_LOAD] = "LOAD",   [TRIOCT_CHANNEL_LIST] = "LIST",
    [TRIOCT_CHANNEL_STATUS] = "STATUS", [TRIOCT_CHANNEL_OBJECTS] = "OBJECTS",
    [TRIOCT_CHANNEL_STATE] = "STATE", [TRIOCT_CHANNEL_DISTANCE] = "DISTANCE",
};

static int kind_has_name(trioct_channel_kind kind)
{
    return kind != TRIOCT_CHANNEL_LIST && kind != TRIOCT_CHANNEL_STATUS;
}

int trioct_name_valid(const char *s, size_t max_len)
{
    if (s == NULL || s[0] == '\0')
        return 0;
    size_t n = 0;
    for (; s[n] != '\0'; n++) {
        char c = s[n];
        int ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
        if (!ok || n >= max_len)
            return 0;
    }
    return 1;
}

int trioct_channel_name(char *out, const char *prefix, trioct_channel_kind kind, const char *name)
{
    out[0] = '\0';
    if ((unsigned)kind >= TRIOCT_CHANNEL_KIND_COUNT || !trioct_name_valid(prefix, TRIOCT_MAX_PREFIX_LEN))
        return -1;
    int n;
    if (kind_has_name(kind)) {
        if (!trioct_name_valid(name, TRIOCT_MAX_NAME_LEN))
            return -1;
        n = snprintf(out, TRIOCT_MAX_CHANNEL_LEN + 1, "%s_%s_%s", prefix, kind_tag[kind], name);
    } else {
        n = snprintf(out, TRIOCT_MAX_CHANNEL_LEN + 1, "%s_%s", prefix, kind_tag[kind]);
    }
    if (n < 0 || n > TRIOCT_MAX_CHANNEL_LEN) {
        out[0] = '\0';
        return -1;
    }
    return 0;
}

int trioct_mark_channel_name(char *out, const char *prefix, trioct_mark_kind kind, const char *daemon)
{
    out[0] = '\0';
    if ((kind != TRIOCT_MARK_RELOAD && kind != TRIOCT_MARK_STOP) || !trioct_name_valid(prefix, TRIOCT_MAX_PREFIX_LEN) ||
        !trioct_name_valid(daemon, TRIOCT_MAX_NAME_LEN))
        return -1;
    int n = snprintf(out, TRIOCT_MAX_CHANNEL_LEN + 1, "%s_%s_%s", prefix, kind == TRIOCT_MARK_RELOAD ? "RELOAD" : "STOP",
                     daemon);
    if (n < 0 || n > TRIOCT_MAX_CHANNEL_LEN) {
        out[0] = '\0';
        return -1;
    }
    return 0;
}

int trioct_channel_parse(const char *channel, const char *prefix, trioct_channel_kind *kind,
                         char name[TRIOCT_MAX_NAME_LEN + 1])
{
    size_t plen = strlen(prefix);
    name[0] = '\0';
    if (strncmp(channel, prefix, plen) != 0 || channel[plen] != '_')
        return -1;
    const char *rest = channel + plen + 1;
    for (int k = 0; k < TRIOCT_CHANNEL_KIND_COUNT; k++) {
        size_t tlen = strlen(kind_tag[k]);
        if (strncmp(rest, kind_tag[k], tlen) != 0)
            continue;
        const char *tail = rest + tlen;
        if (!kind_has_name((trioct_channel_kind)k)) {
            if (*tail != '\0')
                continue;
        } else {
            if (*tail != '_' || !trioct_name_valid(tail + 1, TRIOCT_MAX_NAME_LEN))
                continue;
            strcpy(name, tail + 1);
        }
        *kind = (trioct_channel_kind)k;
        return 0;
    }
    return -1;
}
