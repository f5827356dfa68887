/* Scratch directories for the cmocka tests that write scenes, meshes and logs for a daemon:
 * one fresh directory a test under /tmp, removed afterwards unless TRIOCT_KEEP_SCRATCH=1
 * asks to keep it for a look. Failures are cmocka assertions, so only tests use these. */
#ifndef TRIOCT_TESTS_SCRATCH_H
#define TRIOCT_TESTS_SCRATCH_H

#include <stddef.h>

typedef struct scratch {
    char dir[64];
} scratch;

/* Makes /tmp/trioct_<tag>_XXXXXX (tag: a few characters naming the test program). */
void scratch_init(scratch *s, const char *tag);
void scratch_path(const scratch *s, const char *name, char *out, size_t len);
void scratch_write(const scratch *s, const char *name, const char *text);
/* Replaces scene.ini with text in one rename (through scene.tmp), so a daemon watching it
 * never reads half a file. */
void scratch_write_scene(const scratch *s, const char *text);
/* Removes the files of names (a NULL-terminated list: only the names the test writes, so
 * nothing else is ever deleted) and the directory; with TRIOCT_KEEP_SCRATCH=1 keeps all
 * and says where. */
void scratch_remove(const scratch *s, const char *const *names);

#endif
