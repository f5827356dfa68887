/* The world module's one way of filling a caller's error buffer: every loader, parser and
 * builder here reports failure as -1 plus a message in (err, err_len), either of which the
 * caller may leave NULL/0. */
#ifndef TRIOCT_WORLD_ERROR_TEXT_H
#define TRIOCT_WORLD_ERROR_TEXT_H

#include <stdarg.h>
#include <stddef.h>

/* Formats into err when there is room to; always returns -1, so `return error_text(...)`
 * reads as the failure it is. */
int error_text(char *err, size_t err_len, const char *format, ...) __attribute__((format(printf, 3, 4)));
int error_vtext(char *err, size_t err_len, const char *format, va_list args);

#endif
