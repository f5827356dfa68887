#include "error_text.h"

#include <stdio.h>

int error_vtext(char *err, size_t err_len, const char *format, va_list args)
{
    if (err != NULL && err_len > 0)
        vsnprintf(err, err_len, format, args);
    return -1;
}

int error_text(char *err, size_t err_len, const char *format, ...)
{
    va_list args;
    va_start(args, format);
    error_vtext(err, err_len, format, args);
    va_end(args);
    return -1;
}
