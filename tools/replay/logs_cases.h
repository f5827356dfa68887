/* The replay logs, one function each, writing dir/<name>.lcmlog. Each returns 0, or -1
 * with the reason printed. The golden logs are not written here: `trioct-replay record`
 * makes them from these (tools/replay/make_logs.sh).
 *
 *   queries   every request type and detail level, accuracy modes, tmin/tmax, deadlines
 *   chunked   replies larger than one chunk (rays ALL, triangle SEGMENTS)
 *   burst     24 clients interleaved, reusing each other's request ids and reply channels
 *   admin     LIST, INFO, LOAD (section, path, options), UNLOAD, and every admin error;
 *             a query and an INFO read after an UNLOAD in its wake-up: UNKNOWN_WORLD
 *   reload    a reload of the scene in the middle (the ordered daemon's reload mark)
 *   busy      bursts against a queue of four (busy.ini): the rest get BUSY
 *   errors    every error status a query can provoke without timing
 *   overcap   requests over the count caps
 *   hostile   bytes that are no request, interleaved with requests that must be answered
 *   stopping  the ordered daemon's stop mark in the middle: STOPPING for what follows it
 *   touch     the contact rule: grazing rays as CROSSING (old and new request types) and
 *             as TOUCH, and the touch requests refused
 *   objects   object edits interleaved with queries: moves, adds (a file shared, inline
 *             triangles), removes, every edit error, and lists all or none
 *   distance  point distances on one tree and on posed objects, limits, chunks, and what
 *             is refused (no effect, NaN, SHAPE and CLEAR not served yet) */
#ifndef TRIOCT_LOGS_CASES_H
#define TRIOCT_LOGS_CASES_H

int logs_write_queries(const char *dir);
int logs_write_chunked(const char *dir);
int logs_write_burst(const char *dir);
int logs_write_admin(const char *dir);
int logs_write_reload(const char *dir);
int logs_write_busy(const char *dir);
int logs_write_errors(const char *dir);
int logs_write_overcap(const char *dir);
int logs_write_hostile(const char *dir);
int logs_write_stopping(const char *dir);
int logs_write_touch(const char *dir);
int logs_write_objects(const char *dir);
int logs_write_distance(const char *dir);

/* The seed every log draws its geometry from. */
#define LOGS_SEED UINT64_C(0x7472696f63740006)

#endif
