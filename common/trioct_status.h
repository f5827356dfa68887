/* The status codes of every trioct reply: one table shared by the daemon, libtrioct and the
 * trioct command. Codes below 100 travel on the wire; 100 and up are raised by the client
 * side only (nothing came back, or came back wrong). Never renumber a code: old clients
 * and recorded logs carry them. */
#ifndef TRIOCT_STATUS_H
#define TRIOCT_STATUS_H

#define TRIOCT_STATUS_MAP(X)                                                                   \
    X(TRIOCT_OK, 0, "ok")                                                                      \
    X(TRIOCT_ERR_BAD_REQUEST, 1, "malformed or inconsistent request")                          \
    X(TRIOCT_ERR_UNKNOWN_WORLD, 2, "this daemon does not hold the world")                      \
    X(TRIOCT_ERR_NONFINITE, 3, "a coordinate is NaN or infinite")                              \
    X(TRIOCT_ERR_ZERO_DIRECTION, 4, "a ray direction has zero length")                         \
    X(TRIOCT_ERR_OVER_CAP, 5, "the request is over a documented cap")                          \
    X(TRIOCT_ERR_EFFECT, 6, "the world does not serve this effect")                            \
    X(TRIOCT_ERR_BAD_PATH, 7, "the path is outside the world directory or unreadable")         \
    X(TRIOCT_ERR_DEADLINE, 8, "the deadline passed before the work started")                   \
    X(TRIOCT_ERR_BUSY, 9, "the daemon's queue is full; try again")                             \
    X(TRIOCT_ERR_LOAD_FAILED, 10, "the world could not be built")                              \
    X(TRIOCT_ERR_STOPPING, 11, "the daemon is stopping and takes no new requests")             \
    X(TRIOCT_ERR_UNKNOWN_SHAPE, 12, "the world has no query shape of that name")               \
    X(TRIOCT_ERR_NOMEM, 13, "the daemon ran out of memory for this request")                   \
    X(TRIOCT_ERR_UNKNOWN_OBJECT, 14, "the world has no object of that name")                   \
    X(TRIOCT_ERR_OBJECT_EXISTS, 15, "the world already has an object of that name")            \
    X(TRIOCT_ERR_BAD_POSE, 16, "a pose is not a rotation, or places a vertex out of range")    \
    X(TRIOCT_ERR_BUDGET, 17, "the change needs more memory than a budget leaves")             \
    X(TRIOCT_ERR_DENIED, 18, "the change is not authenticated, or its nonce was seen before")  \
    X(TRIOCT_ERR_TIMEOUT, 100, "no reply within the timeout")                                  \
    X(TRIOCT_ERR_NO_DAEMON, 101, "no daemon serves the world")                                 \
    X(TRIOCT_ERR_TRANSPORT, 102, "the LCM bus could not be used")                              \
    X(TRIOCT_ERR_BAD_REPLY, 103, "a reply could not be decoded")

typedef enum trioct_status {
#define TRIOCT_STATUS_ENUM(name, code, text) name = code,
    TRIOCT_STATUS_MAP(TRIOCT_STATUS_ENUM)
#undef TRIOCT_STATUS_ENUM
} trioct_status;

/* Codes that travel on the wire are below this; arrays indexed by status use it as size. */
#define TRIOCT_WIRE_STATUS_COUNT 19

/* The table's text for a code, or "unknown status" for a code not in it. */
static inline const char *trioct_status_text(int status)
{
    switch (status) {
#define TRIOCT_STATUS_CASE(name, code, text) \
    case code:                               \
        return text;
        TRIOCT_STATUS_MAP(TRIOCT_STATUS_CASE)
#undef TRIOCT_STATUS_CASE
    }
    return "unknown status";
}

/* The code's name without the TRIOCT_ prefix ("OK", "ERR_BUSY"), for logs and --json. */
static inline const char *trioct_status_name(int status)
{
    switch (status) {
#define TRIOCT_STATUS_NAME(name, code, text) \
    case code:                               \
        return &#name[7];
        TRIOCT_STATUS_MAP(TRIOCT_STATUS_NAME)
#undef TRIOCT_STATUS_NAME
    }
    return "UNKNOWN";
}

#endif
