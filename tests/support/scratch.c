/* Scratch directories for the daemon tests: see scratch.h. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include <cmocka.h>

#include "scratch.h"

void scratch_init(scratch *s, const char *tag)
{
    int n = snprintf(s->dir, sizeof s->dir, "/tmp/trioct_%s_XXXXXX", tag);
    assert_true(n > 0 && (size_t)n < sizeof s->dir);
    assert_non_null(mkdtemp(s->dir));
}

void scratch_path(const scratch *s, const char *name, char *out, size_t len)
{
    snprintf(out, len, "%s/%s", s->dir, name);
}

void scratch_write(const scratch *s, const char *name, const char *text)
{
    char path[256];
    scratch_path(s, name, path, sizeof path);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    assert_int_equal(fclose(f), 0);
}

void scratch_write_scene(const scratch *s, const char *text)
{
    char tmp[256], path[256];
    scratch_write(s, "scene.tmp", text);
    scratch_path(s, "scene.tmp", tmp, sizeof tmp);
    scratch_path(s, "scene.ini", path, sizeof path);
    assert_int_equal(rename(tmp, path), 0);
}

void scratch_remove(const scratch *s, const char *const *names)
{
    const char *keep = getenv("TRIOCT_KEEP_SCRATCH");
    if (keep != NULL && keep[0] == '1') {
        fprintf(stderr, "kept %s\n", s->dir);
        return;
    }
    for (size_t i = 0; names[i] != NULL; i++) {
        char path[256];
        scratch_path(s, names[i], path, sizeof path);
        unlink(path);
    }
    rmdir(s->dir);
}
