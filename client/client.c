/* The connection: bus, client id and reply channel, the table of requests waiting for
 * replies, chunk reassembly, and the poll-guarded drain every wait runs on. */
#include "client_internal.h"

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <limits.h>
#include <poll.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <time.h>
#include <unistd.h>

/* What lcm_create(NULL) uses when $LCM_DEFAULT_URL is unset, for messages only. */
#define LCM_BUILTIN_URL "udpm://239.255.76.67:7667?ttl=0"

/* ---- small helpers ------------------------------------------------------------------- */

/* Waiting runs on nanoseconds so that "returned at the deadline" means not a moment early. */
int64_t client_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

int64_t client_deadline(int timeout_ms)
{
    if (timeout_ms < 0)
        return INT64_MAX;
    return client_now_ns() + (int64_t)timeout_ms * 1000000;
}

void client_copy(char *dst, size_t dst_len, const char *src)
{
    if (dst_len == 0)
        return;
    if (src == NULL)
        src = "";
    size_t n = strnlen(src, dst_len - 1);
    memcpy(dst, src, n);
    dst[n] = '\0';
}

int client_fail(trioct_reply *r, int status, const char *fmt, ...)
{
    r->status = status;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(r->message, sizeof r->message, fmt, ap);
    va_end(ap);
    return status;
}

void client_no_daemon_world(const trioct_client *c, const char *world, int timeout_ms, char *buf,
                            size_t len)
{
    snprintf(buf, len, "no daemon serves world %s on %s (no reply within %d ms)", world, c->url,
             timeout_ms);
}

int client_object_names(trioct_reply *r, int32_t count, char *const *names, trioct_object_names *out)
{
    out->count = 0;
    out->names = NULL;
    if (count < 0)
        return client_fail(r, TRIOCT_ERR_BAD_REPLY, "the reply names %d objects", count);
    out->names = calloc(count ? (size_t)count : 1, sizeof *out->names);
    if (!out->names)
        return client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for %d object names", count);
    for (int32_t i = 0; i < count; i++) {
        if (strlen(names[i]) > TRIOCT_MAX_NAME_LEN)
            return client_fail(r, TRIOCT_ERR_BAD_REPLY, "object name %d is longer than %d characters", i,
                               TRIOCT_MAX_NAME_LEN);
        client_copy(out->names[i], sizeof out->names[i], names[i]);
    }
    out->count = (size_t)count;
    return TRIOCT_OK;
}

int client_check_object(trioct_reply *r, int32_t object, const trioct_object_names *names, const char *what,
                        size_t record)
{
    if (object < 0 || (size_t)object >= names->count)
        return client_fail(r, TRIOCT_ERR_BAD_REPLY, "%s %zu names object %d of %zu", what, record, object,
                           names->count);
    return TRIOCT_OK;
}

void client_object_names_free(trioct_object_names *names)
{
    free(names->names);
    names->names = NULL;
    names->count = 0;
}

void client_reply_from_header(trioct_reply *r, const trioct_reply_header_t *h, int chunks)
{
    r->status = h->status;
    client_copy(r->message, sizeof r->message, h->message);
    client_copy(r->daemon, sizeof r->daemon, h->daemon);
    client_copy(r->world, sizeof r->world, h->world);
    r->world_version = h->world_version;
    r->request_id = h->request_id;
    r->chunks = chunks;
}

/* The wire is big-endian; the ids sit at fixed offsets after the fingerprint in every
 * reply, which lets a reply be matched before it is validated against its type. */
static int64_t read_be64(const uint8_t *b)
{
    uint64_t v = 0;
    for (int i = 0; i < 8; i++)
        v = (v << 8) | b[i];
    return (int64_t)v;
}

#define REPLY_IDS_END 24 /* fingerprint, client_id, request_id */

/* A nonzero random id; 0 when the system has no randomness to give. */
static uint64_t random_id(void)
{
    for (int attempt = 0; attempt < 4; attempt++) {
        uint64_t id = 0;
        ssize_t n = getrandom(&id, sizeof id, 0);
        if (n != (ssize_t)sizeof id) {
            /* Old kernels lack getrandom; the device says the same thing. */
            int fd = open("/dev/urandom", O_RDONLY | O_CLOEXEC);
            if (fd < 0)
                return 0;
            n = read(fd, &id, sizeof id);
            close(fd);
            if (n != (ssize_t)sizeof id)
                return 0;
        }
        if (id != 0)
            return id;
    }
    return 0;
}

/* ---- the pending table and reassembly ------------------------------------------------ */

static pending *find_pending(trioct_client *c, int64_t request_id)
{
    for (pending *p = c->waiting; p != NULL; p = p->next)
        if (p->request_id == request_id)
            return p;
    return NULL;
}

static void free_chunks(const reply_ops *ops, assembly *a)
{
    if (a->chunks == NULL)
        return;
    for (int32_t i = 0; i < a->chunk_count; i++) {
        if (a->chunks[i] != NULL) {
            ops->cleanup(a->chunks[i]);
            free(a->chunks[i]);
        }
    }
    free(a->chunks);
    a->chunks = NULL;
}

static assembly *find_assembly(pending *p, const char *daemon)
{
    for (size_t i = 0; i < p->num_assemblies; i++)
        if (strcmp(p->assemblies[i].daemon, daemon) == 0)
            return &p->assemblies[i];
    if (p->num_assemblies == p->cap_assemblies) {
        size_t cap = p->cap_assemblies ? 2 * p->cap_assemblies : 2;
        assembly *grown = realloc(p->assemblies, cap * sizeof *grown);
        if (grown == NULL)
            return NULL;
        p->assemblies = grown;
        p->cap_assemblies = cap;
    }
    char *name = strdup(daemon);
    if (name == NULL)
        return NULL;
    assembly *a = &p->assemblies[p->num_assemblies++];
    memset(a, 0, sizeof *a);
    a->daemon = name;
    a->state = ASSEMBLY_OPEN;
    return a;
}

static void assembly_finished(trioct_client *c, pending *p, assembly *a)
{
    a->order = ++c->finish_counter;
    p->finished++;
    if (!p->gather || (p->expect > 0 && p->finished >= (size_t)p->expect)) {
        p->done = 1;
        client_pending_ready(c, p);
    }
}

static void assembly_bad(trioct_client *c, pending *p, assembly *a, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

static void assembly_bad(trioct_client *c, pending *p, assembly *a, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(a->why, sizeof a->why, fmt, ap);
    va_end(ap);
    free_chunks(p->ops, a);
    a->state = ASSEMBLY_BAD;
    assembly_finished(c, p, a);
}

/* Takes ownership of msg, a decoded chunk for p. */
static void accept_chunk(trioct_client *c, pending *p, void *msg)
{
    const trioct_reply_header_t *h = msg;
    assembly *a = NULL;
    if (p->done) {
        /* Another daemon's answer to a request already answered (two daemons holding the
         * same world), or a LIST answer past the expected count or the window, arriving
         * before the completion ran: the answers that finished it stand. */
        c->stats.unmatched++;
        goto drop;
    }
    a = find_assembly(p, h->daemon);
    if (a == NULL)
        goto drop; /* out of memory: as if the chunk was lost */
    if (a->state != ASSEMBLY_OPEN) {
        c->stats.duplicate_chunks++;
        goto drop;
    }
    if (h->chunk_count < 1 || h->chunk_count > CLIENT_MAX_CHUNKS) {
        assembly_bad(c, p, a, "chunk_count %" PRId32 " is outside 1..%d", h->chunk_count,
                     CLIENT_MAX_CHUNKS);
        goto drop;
    }
    if (a->chunk_count == 0) {
        a->chunks = calloc((size_t)h->chunk_count, sizeof *a->chunks);
        if (a->chunks == NULL)
            goto drop;
        a->chunk_count = h->chunk_count;
    } else if (h->chunk_count != a->chunk_count) {
        assembly_bad(c, p, a, "chunk %" PRId32 " says %" PRId32 " chunks, an earlier one said %" PRId32,
                     h->chunk_index, h->chunk_count, a->chunk_count);
        goto drop;
    }
    if (h->chunk_index < 0 || h->chunk_index >= a->chunk_count) {
        assembly_bad(c, p, a, "chunk_index %" PRId32 " is outside 0..%" PRId32, h->chunk_index,
                     a->chunk_count - 1);
        goto drop;
    }
    if (a->chunks[h->chunk_index] != NULL) {
        c->stats.duplicate_chunks++;
        goto drop;
    }
    a->chunks[h->chunk_index] = msg;
    a->received++;
    c->stats.chunks_accepted++;
    if (a->received == a->chunk_count) {
        a->state = ASSEMBLY_COMPLETE;
        assembly_finished(c, p, a);
    }
    return;
drop:
    p->ops->cleanup(msg);
    free(msg);
}

/* Every reply to this connection arrives here: matched by ids, checked, then decoded. */
static void on_reply(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
    (void)channel;
    trioct_client *c = user;
    const uint8_t *bytes = rbuf->data;
    size_t size = rbuf->data_size;
    if (size < REPLY_IDS_END) {
        c->stats.malformed++;
        return;
    }
    if ((uint64_t)read_be64(bytes + 8) != c->client_id) {
        c->stats.foreign_client++;
        return;
    }
    pending *p = find_pending(c, read_be64(bytes + 16));
    if (p == NULL) {
        c->stats.unmatched++;
        return;
    }
    if (wire_check(p->ops->wire, bytes, size, NULL) != 0) {
        c->stats.malformed++;
        p->malformed++;
        return;
    }
    void *msg = calloc(1, p->ops->msg_size);
    if (msg == NULL)
        return;
    if (p->ops->decode(bytes, size, msg) != 0) {
        free(msg); /* the checked bytes decode; this is a guard, not a path */
        c->stats.malformed++;
        p->malformed++;
        return;
    }
    accept_chunk(c, p, msg);
}

pending *client_pending_new(trioct_client *c, const reply_ops *ops, int timeout_ms,
                            trioct_reply *r)
{
    if (c->closing) {
        client_fail(r, TRIOCT_ERR_TRANSPORT, "the connection to %s is closing", c->url);
        return NULL;
    }
    pending *p = calloc(1, sizeof *p);
    if (p == NULL) {
        client_fail(r, TRIOCT_ERR_NOMEM, "out of memory for a request");
        return NULL;
    }
    p->request_id = ++c->next_request_id;
    p->ops = ops;
    p->timeout_ms = timeout_ms;
    p->deadline = client_deadline(timeout_ms);
    return p;
}

void client_pending_unlink(trioct_client *c, pending *p)
{
    for (pending **link = &c->waiting; *link != NULL; link = &(*link)->next) {
        if (*link == p) {
            *link = p->next;
            break;
        }
    }
    if (p->ready) {
        pending *prev = NULL;
        for (pending *q = c->ready_head; q != NULL; prev = q, q = q->next_ready) {
            if (q != p)
                continue;
            if (prev == NULL)
                c->ready_head = p->next_ready;
            else
                prev->next_ready = p->next_ready;
            if (c->ready_tail == p)
                c->ready_tail = prev;
            break;
        }
        p->ready = 0;
    }
    p->next = NULL;
    p->next_ready = NULL;
}

void client_pending_free(pending *p)
{
    if (p == NULL)
        return;
    for (size_t i = 0; i < p->num_assemblies; i++) {
        free_chunks(p->ops, &p->assemblies[i]);
        free(p->assemblies[i].daemon);
    }
    free(p->assemblies);
    free(p->sent);
    free(p);
}

/* ---- retries ------------------------------------------------------------------------- */

#define RETRY_FIRST_NS ((int64_t)250 * 1000000)
#define RETRY_MAX_GAP_NS ((int64_t)4000 * 1000000)

void client_retry_due(trioct_client *c, int64_t now)
{
    for (pending *p = c->waiting; p != NULL; p = p->next) {
        if (p->sent == NULL || p->done || p->next_retry > now)
            continue;
        /* A retry past the deadline would only be answered for nobody. */
        if (p->deadline != INT64_MAX && now + p->retry_gap / 4 >= p->deadline) {
            p->next_retry = INT64_MAX;
            continue;
        }
        if (lcm_publish(c->lcm, p->sent_channel, p->sent, (unsigned)p->sent_size) == 0)
            c->stats.retries++;
        p->next_retry = now + p->retry_gap;
        p->retry_gap = p->retry_gap * 2 > RETRY_MAX_GAP_NS ? RETRY_MAX_GAP_NS : p->retry_gap * 2;
    }
}

int64_t client_next_retry(const trioct_client *c)
{
    int64_t next = INT64_MAX;
    for (const pending *p = c->waiting; p != NULL; p = p->next)
        if (p->sent != NULL && !p->done && p->next_retry < next)
            next = p->next_retry;
    return next;
}

/* ---- the drain ----------------------------------------------------------------------- */

/* The deadline is checked now and then, so that a flood cannot hold a call past it. memq
 * crashes in lcm_handle on an empty queue and udpm may block, so every lcm_handle is guarded
 * by a zero-timeout poll. */
int client_drain(trioct_client *c, const int *flag, int64_t deadline)
{
    int fd = lcm_get_fileno(c->lcm);
    int handled = 0;
    for (;;) {
        if (flag != NULL && *flag)
            break;
        if ((handled & 255) == 255 && client_now_ns() >= deadline)
            break;
        struct pollfd pfd = {.fd = fd, .events = POLLIN};
        int r = poll(&pfd, 1, 0);
        if (r < 0) {
            if (errno == EINTR)
                continue;
            return -1;
        }
        if (r == 0)
            break;
        if (!(pfd.revents & POLLIN))
            return -1; /* error or hang-up on the notify fd */
        if (lcm_handle(c->lcm) != 0)
            return -1; /* also a file:// log at its end: readable forever, never more */
        handled++;
    }
    return handled;
}

int client_wait_flag(trioct_client *c, const int *flag, int64_t deadline)
{
    int fd = lcm_get_fileno(c->lcm);
    for (;;) {
        if (client_drain(c, flag, deadline) < 0)
            return -1;
        if (*flag)
            return 0;
        int64_t now = client_now_ns();
        if (now >= deadline)
            return 0;
        client_retry_due(c, now);
        int64_t wake = client_next_retry(c);
        if (deadline < wake)
            wake = deadline;
        int timeout = -1;
        if (wake != INT64_MAX) {
            int64_t ms = wake <= now ? 0 : (wake - now + 999999) / 1000000; /* round up: never wake early */
            timeout = ms > INT_MAX ? INT_MAX : (int)ms;
        }
        struct pollfd pfd = {.fd = fd, .events = POLLIN};
        if (poll(&pfd, 1, timeout) < 0 && errno != EINTR)
            return -1;
    }
}

/* ---- sending ------------------------------------------------------------------------- */

int client_channel(trioct_client *c, trioct_channel_kind kind, const char *name,
                   char out[TRIOCT_MAX_CHANNEL_LEN + 1], trioct_reply *r, const char *what)
{
    if (trioct_channel_name(out, c->prefix, kind, name) != 0)
        return client_fail(r, TRIOCT_ERR_BAD_REQUEST,
                           "invalid %s name \"%.40s\": 1..%d characters of [A-Za-z0-9_]", what,
                           name ? name : "(null)", TRIOCT_MAX_NAME_LEN);
    return TRIOCT_OK;
}

/* Microseconds since the Unix epoch: the daemon's clock for deadlines. */
static int64_t realtime_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (int64_t)ts.tv_sec * 1000000 + ts.tv_nsec / 1000;
}

void client_request_header(trioct_client *c, trioct_request_header_t *h, const pending *p,
                           const char *world)
{
    h->client_id = (int64_t)c->client_id;
    h->request_id = p->request_id;
    h->reply_channel = c->reply_channel;
    h->world = (char *)(world ? world : ""); /* the encoder only reads it */
    /* Past this the daemon answers ERR_DEADLINE instead of working for a caller that has
     * given up; without a timeout there is nothing to send. */
    h->deadline_utime = c->send_deadlines && p->timeout_ms >= 0
                            ? realtime_us() + (int64_t)p->timeout_ms * 1000
                            : 0;
}

int client_pending_send(trioct_client *c, pending *p, const char *channel,
                        const request_codec *codec, const void *msg, trioct_reply *r)
{
    int size = codec->encoded_size(msg);
    int rc;
    uint8_t *buf = NULL;
    if (size < 0 || size > TRIOCT_MAX_REQUEST_BYTES) {
        rc = client_fail(r, TRIOCT_ERR_OVER_CAP,
                         "the request encodes to %d bytes, over the cap of %d bytes per "
                         "request (TRIOCT_MAX_REQUEST_BYTES)",
                         size, TRIOCT_MAX_REQUEST_BYTES);
    } else if ((buf = malloc((size_t)size)) == NULL) {
        rc = client_fail(r, TRIOCT_ERR_NOMEM, "out of memory encoding a request of %d bytes",
                         size);
    } else if (codec->encode(buf, size, msg) != size) {
        rc = client_fail(r, TRIOCT_ERR_BAD_REQUEST, "the request could not be encoded");
    } else {
        /* A change is signed over the bytes just encoded (a daemon refuses it unsigned). */
        if (codec->is_change && codec->is_change(msg) && c->admin_key.len > 0)
            trioct_admin_sign(&c->admin_key, channel, buf, (size_t)size, realtime_us());
        if (lcm_publish(c->lcm, channel, buf, (unsigned)size) != 0) {
            rc = client_fail(r, TRIOCT_ERR_TRANSPORT, "cannot publish on %s over %s", channel, c->url);
        } else {
            c->stats.requests_sent++;
            rc = TRIOCT_OK;
        }
    }
    /* Kept to send again while no answer comes; LIST gathers every daemon's answer and is
     * not retried (a retry would only ask the ones that answered again). */
    if (rc == TRIOCT_OK && c->retries && !p->gather && p->timeout_ms != 0) {
        p->sent = buf;
        p->sent_size = (size_t)size;
        snprintf(p->sent_channel, sizeof p->sent_channel, "%s", channel);
        p->retry_gap = RETRY_FIRST_NS;
        p->next_retry = client_now_ns() + RETRY_FIRST_NS;
        p->retry_gap *= 2;
        buf = NULL;
    }
    free(buf);
    if (rc != TRIOCT_OK) {
        client_pending_free(p);
        return rc;
    }
    /* Replies are only handled by a later lcm_handle, so linking p after publishing cannot
     * miss one. */
    p->next = c->waiting;
    c->waiting = p;
    r->request_id = p->request_id;
    return TRIOCT_OK;
}

int client_ended_early(const trioct_client *c, const pending *p, trioct_reply *r)
{
    r->request_id = p->request_id;
    if (p->closed) {
        client_fail(r, TRIOCT_ERR_TRANSPORT,
                    "the connection to %s was closed before the answer came", c->url);
        return 1;
    }
    if (p->bus_failed) {
        client_fail(r, TRIOCT_ERR_TRANSPORT, "the LCM bus %s failed while waiting for a reply",
                    c->url);
        return 1;
    }
    return 0;
}

const assembly *client_answer(trioct_client *c, const pending *p, trioct_reply *r)
{
    if (client_ended_early(c, p, r))
        return NULL;
    const assembly *first = NULL;
    for (size_t i = 0; i < p->num_assemblies; i++) {
        const assembly *a = &p->assemblies[i];
        if (a->state != ASSEMBLY_OPEN && (first == NULL || a->order < first->order))
            first = a;
    }
    if (first != NULL) {
        if (first->state == ASSEMBLY_COMPLETE) {
            client_reply_from_header(r, first->chunks[0], first->chunk_count);
            return first;
        }
        client_copy(r->daemon, sizeof r->daemon, first->daemon);
        client_fail(r, TRIOCT_ERR_BAD_REPLY, "bad reply from daemon %.40s: %s", first->daemon,
                    first->why);
        return NULL;
    }
    const assembly *partial = NULL;
    for (size_t i = 0; i < p->num_assemblies; i++)
        if (partial == NULL || p->assemblies[i].received > partial->received)
            partial = &p->assemblies[i];
    if (partial != NULL && partial->received > 0) {
        client_copy(r->daemon, sizeof r->daemon, partial->daemon);
        r->chunks = partial->received;
        client_fail(r, TRIOCT_ERR_TIMEOUT,
                    "reply from daemon %.40s incomplete: %" PRId32 " of %" PRId32
                    " chunks within %d ms",
                    partial->daemon, partial->received, partial->chunk_count, p->timeout_ms);
        return NULL;
    }
    if (p->malformed > 0) {
        client_fail(r, TRIOCT_ERR_BAD_REPLY,
                    "%" PRIu64 " malformed replies and no good one within %d ms", p->malformed,
                    p->timeout_ms);
        return NULL;
    }
    client_fail(r, TRIOCT_ERR_NO_DAEMON, "%s", p->no_daemon);
    return NULL;
}

/* ---- connection ---------------------------------------------------------------------- */

static trioct_client *connect_fail(trioct_client *c, int *status, char *err, size_t err_len,
                                   int code, const char *fmt, ...)
    __attribute__((format(printf, 6, 7)));

static trioct_client *connect_fail(trioct_client *c, int *status, char *err, size_t err_len,
                                   int code, const char *fmt, ...)
{
    if (status != NULL)
        *status = code;
    if (err != NULL && err_len > 0) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, err_len, fmt, ap);
        va_end(ap);
    }
    trioct_disconnect(c);
    return NULL;
}

trioct_client *trioct_connect(const trioct_connect_options *opt, int *status, char *err,
                              size_t err_len)
{
    trioct_connect_options o = {0};
    if (opt != NULL)
        o = *opt;
    const char *prefix = o.prefix ? o.prefix : TRIOCT_DEFAULT_PREFIX;
    if (!trioct_name_valid(prefix, TRIOCT_MAX_PREFIX_LEN))
        return connect_fail(NULL, status, err, err_len, TRIOCT_ERR_BAD_REQUEST,
                            "invalid channel prefix \"%.40s\": 1..%d characters of [A-Za-z0-9_]",
                            prefix, TRIOCT_MAX_PREFIX_LEN);
    if (o.queue_capacity < 0)
        return connect_fail(NULL, status, err, err_len, TRIOCT_ERR_BAD_REQUEST,
                            "queue_capacity %d is negative", o.queue_capacity);

    trioct_client *c = calloc(1, sizeof *c);
    if (c == NULL)
        return connect_fail(NULL, status, err, err_len, TRIOCT_ERR_NOMEM, "out of memory");
    client_copy(c->prefix, sizeof c->prefix, prefix);
    c->send_deadlines = o.send_deadlines != 0;
    c->retries = o.no_retries == 0;
    const char *key_file = o.admin_key_file ? o.admin_key_file : getenv("TRIOCT_KEY_FILE");
    if (key_file && key_file[0] != '\0') {
        char why[TRIOCT_MAX_MESSAGE_LEN];
        if (trioct_admin_key_load(key_file, &c->admin_key, why, sizeof why) != 0)
            return connect_fail(c, status, err, err_len, TRIOCT_ERR_BAD_REQUEST, "%s", why);
    }
    const char *env = getenv("LCM_DEFAULT_URL");
    const char *url = o.url               ? o.url
                      : o.lcm != NULL     ? "the caller's LCM instance"
                      : env && env[0]     ? env
                                          : LCM_BUILTIN_URL;
    client_copy(c->url, sizeof c->url, url);

    c->client_id = random_id();
    if (c->client_id == 0)
        return connect_fail(c, status, err, err_len, TRIOCT_ERR_TRANSPORT,
                            "no randomness for a client id (getrandom and /dev/urandom failed)");
    snprintf(c->reply_channel, sizeof c->reply_channel, "%s_R_%016" PRIx64, c->prefix,
             c->client_id);

    if (o.lcm != NULL) {
        c->lcm = (lcm_t *)o.lcm;
    } else {
        c->lcm = lcm_create(o.url);
        if (c->lcm == NULL)
            return connect_fail(c, status, err, err_len, TRIOCT_ERR_TRANSPORT,
                                "cannot open LCM on %s", c->url);
        c->own_lcm = 1;
    }
    c->reply_sub = lcm_subscribe(c->lcm, c->reply_channel, on_reply, c);
    if (c->reply_sub == NULL)
        return connect_fail(c, status, err, err_len, TRIOCT_ERR_TRANSPORT,
                            "cannot subscribe to %s on %s", c->reply_channel, c->url);
    int capacity = o.queue_capacity ? o.queue_capacity : CLIENT_DEFAULT_QUEUE_CAPACITY;
    lcm_subscription_set_queue_capacity(c->reply_sub, capacity);
    if (status != NULL)
        *status = TRIOCT_OK;
    if (err != NULL && err_len > 0)
        err[0] = '\0';
    return c;
}

void trioct_disconnect(trioct_client *c)
{
    if (c == NULL || c->closing)
        return;
    c->closing = 1;
    if (c->dispatching)
        return; /* a callback's: the pump or poll that runs it closes when it is done */
    client_destroy(c);
}

void client_destroy(trioct_client *c)
{
    client_close_requests(c);
    if (c->reply_sub != NULL)
        lcm_unsubscribe(c->lcm, c->reply_sub);
    if (c->own_lcm)
        lcm_destroy(c->lcm);
    free(c);
}

int trioct_fileno(const trioct_client *c)
{
    return lcm_get_fileno(c->lcm);
}

uint64_t trioct_client_id(const trioct_client *c)
{
    return c->client_id;
}

const char *trioct_reply_channel(const trioct_client *c)
{
    return c->reply_channel;
}

const char *trioct_url(const trioct_client *c)
{
    return c->url;
}

const char *trioct_prefix(const trioct_client *c)
{
    return c->prefix;
}

void trioct_client_get_stats(const trioct_client *c, trioct_client_stats *out)
{
    *out = c->stats;
}
