#include "base/error.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

int ts_error_set(ts_error *err, int code, const char *fmt, ...)
{
    if (!err || err->code != 0) return code;
    err->code = code;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err->msg, sizeof err->msg, fmt, ap);
    va_end(ap);
    return code;
}

int ts_error_set_status(ts_error *err, int code, int status, const char *fmt, ...)
{
    if (!err || err->code != 0) return code;
    err->code = code;
    err->status = status;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err->msg, sizeof err->msg, fmt, ap);
    va_end(ap);
    return code;
}

void ts_error_set_detail(ts_error *err, char *detail)
{
    if (!err) {
        free(detail);
        return;
    }
    free(err->detail);
    err->detail = detail;
}

void ts_error_clear(ts_error *err)
{
    if (!err) return;
    free(err->detail);
    err->detail = NULL;
    err->code = 0;
    err->status = 0;
    err->msg[0] = '\0';
}

void ts_print_line(const char *fmt, ...)
{
    char text[4096];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    /* The escaped line is written with one call: stderr is unbuffered, so character by
     * character it would reach a terminal or mpirun's forwarding as one write each, and the
     * lines of several ranks or threads would interleave within a line. */
    char line[4 * sizeof text + 2];
    size_t n = 0;
    for (const unsigned char *c = (const unsigned char *)text; *c; ++c) {
        if (*c == '\n')
            line[n++] = '\\', line[n++] = 'n';
        else if (*c == '\t')
            line[n++] = '\\', line[n++] = 't';
        else if (*c == '\r')
            line[n++] = '\\', line[n++] = 'r';
        else if (*c < 0x20 || *c == 0x7f)
            n += (size_t)snprintf(line + n, sizeof line - n, "\\x%02x", *c);
        else
            line[n++] = (char)*c;
    }
    line[n++] = '\n';
    fwrite(line, 1, n, stderr);
}
