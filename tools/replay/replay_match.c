#include "replay_match.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

#include "replay_compare.h"
#include "trioct_status.h"

void replay_describe(const replay_request *r, char *buf, size_t len)
{
    snprintf(buf, len, "request %" PRId64 " (client 0x%" PRIx64 ", %s on %s)", r->request_id,
             (uint64_t)r->client_id, wire_type_name(r->type), r->channel);
}

/* One key's replies on both sides, placed in the output by its request's position. */
typedef struct key_group {
    int64_t client_id, request_id;
    size_t order; /* the request's log index, or SIZE_MAX for a reply to nobody */
} key_group;

static int group_cmp(const void *a, const void *b)
{
    const key_group *x = a, *y = b;
    if (x->order != y->order)
        return x->order < y->order ? -1 : 1;
    if (x->client_id != y->client_id)
        return x->client_id < y->client_id ? -1 : 1;
    return x->request_id < y->request_id ? -1 : x->request_id > y->request_id;
}

/* What a reply says in brief: 'OK, 12 items and 30 records on CH' or 'ERR_BUSY "..." on CH'. */
static void summary(const replay_reply *r, char *buf, size_t len)
{
    if (r->header == NULL) {
        snprintf(buf, len, "a damaged %s on %s", wire_type_name(r->type), r->channel);
        return;
    }
    if (r->header->status != 0)
        snprintf(buf, len, "%s \"%s\" on %s", trioct_status_name(r->header->status), r->header->message,
                 r->channel);
    else if (r->type == WIRE_ADMIN_REPLY)
        snprintf(buf, len, "OK, %zu world%s, on %s", r->num_records, r->num_records == 1 ? "" : "s", r->channel);
    else if (r->type == WIRE_OBJECT_REPLY)
        snprintf(buf, len, "OK, %zu object%s listed, on %s", r->num_records, r->num_records == 1 ? "" : "s",
                 r->channel);
    else
        snprintf(buf, len, "OK, %d items, %zu records in %d chunk%s, on %s", r->num_items, r->num_records,
                 r->chunk_count, r->chunk_count == 1 ? "" : "s", r->channel);
}

static void match_key(const replay_book *script, const key_group *k, const replay_book *expected,
                      const replay_book *got, const replay_rules *rules, size_t max_lines, FILE *out,
                      replay_counts *c, char *used, int verbose)
{
    size_t ne, ng;
    const replay_reply *e = replay_book_replies(expected, k->client_id, k->request_id, &ne);
    const replay_reply *g = replay_book_replies(got, k->client_id, k->request_id, &ng);
    const replay_request *req = replay_book_request(script, k->client_id, k->request_id);
    char what[256], s[TRIOCT_MAX_MESSAGE_LEN + 128];
    if (req != NULL)
        replay_describe(req, what, sizeof what);
    else
        snprintf(what, sizeof what, "reply to request %" PRId64 " (client 0x%" PRIx64 "), which no request of the log asked",
                 k->request_id, (uint64_t)k->client_id);

    /* A key used twice has several replies a side: pair each expected one with an equal
     * reply first, then the rest in order. */
    size_t base = g != NULL ? (size_t)(g - got->replies) : 0;
    for (size_t i = 0; i < ne; i++) {
        for (size_t j = 0; j < ng; j++) {
            if (!used[base + j] && replay_compare(&e[i], &g[j], rules, what, NULL, 0) == 0) {
                used[base + j] = 1;
                c->matched++;
                if (verbose && out != NULL) {
                    summary(&g[j], s, sizeof s);
                    fprintf(out, "%s: %s\n", what, s);
                }
                goto next_expected;
            }
        }
        for (size_t j = 0; j < ng; j++) {
            if (!used[base + j]) {
                used[base + j] = 1;
                c->mismatched++;
                replay_compare(&e[i], &g[j], rules, what, out, max_lines);
                goto next_expected;
            }
        }
        c->missing++;
        if (out != NULL) {
            summary(&e[i], s, sizeof s);
            fprintf(out, "%s: no reply; expected %s\n", what, s);
        }
    next_expected:;
    }
    for (size_t j = 0; j < ng; j++) {
        if (used[base + j])
            continue;
        used[base + j] = 1;
        c->extra++;
        if (req == NULL)
            c->to_nobody++;
        if (out != NULL) {
            summary(&g[j], s, sizeof s);
            if (req != NULL)
                fprintf(out, "%s: a reply (%s) where the golden log has none\n", what, s);
            else
                fprintf(out, "%s: %s\n", what, s);
        }
    }
}

int replay_match(const replay_book *script, const replay_book *expected, const replay_book *got,
                 const replay_rules *rules, size_t max_lines, int verbose, FILE *out, replay_counts *c)
{
    memset(c, 0, sizeof *c);
    c->requests = script->request_count;
    c->malformed = script->malformed;
    c->expected = expected->reply_count;
    c->got = got->reply_count;
    c->statuses = got->statuses;
    c->bad_replies = expected->bad_replies + got->bad_replies;

    size_t cap = expected->reply_count + got->reply_count;
    key_group *keys = calloc(cap ? cap : 1, sizeof *keys);
    char *used = calloc(got->reply_count ? got->reply_count : 1, 1);
    if (keys == NULL || used == NULL) {
        free(keys);
        free(used);
        return -1;
    }
    /* Both sides are sorted by key: merge them into the distinct keys. */
    size_t nk = 0, i = 0, j = 0;
    while (i < expected->reply_count || j < got->reply_count) {
        const replay_reply *r;
        if (j >= got->reply_count ||
            (i < expected->reply_count &&
             (expected->replies[i].client_id < got->replies[j].client_id ||
              (expected->replies[i].client_id == got->replies[j].client_id &&
               expected->replies[i].request_id <= got->replies[j].request_id))))
            r = &expected->replies[i++];
        else
            r = &got->replies[j++];
        if (nk > 0 && keys[nk - 1].client_id == r->client_id && keys[nk - 1].request_id == r->request_id)
            continue;
        const replay_request *req = replay_book_request(script, r->client_id, r->request_id);
        keys[nk].client_id = r->client_id;
        keys[nk].request_id = r->request_id;
        keys[nk].order = req != NULL ? req->event : SIZE_MAX;
        nk++;
    }
    qsort(keys, nk, sizeof *keys, group_cmp);
    for (size_t k = 0; k < nk; k++)
        match_key(script, &keys[k], expected, got, rules, max_lines, out, c, used, verbose);
    free(keys);
    free(used);
    return 0;
}

int replay_counts_pass(const replay_counts *c)
{
    return c->mismatched == 0 && c->missing == 0 && c->extra == 0;
}

void replay_counts_print(FILE *out, const replay_counts *c)
{
    fprintf(out,
            "requests %zu (%zu malformed), replies %zu: %zu matched, %zu mismatched, %zu missing, "
            "%zu extra (%zu to nobody)\n",
            c->requests + c->malformed, c->malformed, c->expected, c->matched, c->mismatched, c->missing,
            c->extra, c->to_nobody);
}
