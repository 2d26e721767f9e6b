/* error.h — how the host reports failure: a code plus a one-line message, filled once at
 * the place that failed and passed up unchanged. Only main() prints and exits. */
#ifndef TS_ERROR_H
#define TS_ERROR_H

#include <stddef.h>

typedef struct ts_error {
    int code;       /* 0 = no error; else a TS_E* value */
    char msg[2048]; /* one line, no trailing newline; scene errors start with file:line:col */
    char *detail;   /* optional multi-line detail (a kernel build log); owned, may be NULL */
    int status;     /* TS_E_DEVICE: the failed call's status (an OpenCL cl_int), else 0 */
} ts_error;

enum {
    TS_OK = 0,
    TS_E_USAGE = 1,    /* bad command line */
    TS_E_IO = 2,       /* a file could not be read or written */
    TS_E_SCENE = 3,    /* the scene file is malformed */
    TS_E_DEVICE = 4,   /* an OpenCL call failed */
    TS_E_MEMORY = 5,   /* host allocation failed */
    TS_E_INTERNAL = 6, /* an invariant broke: a bug */
};

/* Sets err (if non-NULL and not already set) and returns code. The first error wins, so a
 * caller may add nothing that hides the root cause. */
int ts_error_set(ts_error *err, int code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
/* As ts_error_set, and records `status` (the failed call's own code) when this call is the
 * one that sets err: callers decide by the status, never by matching message text. */
int ts_error_set_status(ts_error *err, int code, int status, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
/* Takes ownership of a malloc'd detail text (for example a build log). */
void ts_error_set_detail(ts_error *err, char *detail);
void ts_error_clear(ts_error *err);

/* Writes the formatted text to stderr as one line: control characters (a newline in a file
 * name would split the line a script reads) become \n, \t, \r or \xNN, then one newline.
 * Every message Tessera prints (errors, warnings, notes) goes through it. */
void ts_print_line(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

#endif
