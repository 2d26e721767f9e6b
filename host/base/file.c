/* file.c — regular-file checks for inputs (base/file.h). */
#include "base/file.h"

#include <errno.h>
#include <stdlib.h>
#include <fcntl.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* What a non-regular file is, for the message. */
static const char *file_kind(mode_t mode)
{
    return S_ISDIR(mode)    ? "a directory"
           : S_ISFIFO(mode) ? "a FIFO"
           : S_ISCHR(mode)  ? "a character device"
           : S_ISBLK(mode)  ? "a block device"
           : S_ISSOCK(mode) ? "a socket"
                            : "not a file";
}

static int check_mode(const char *path, const struct stat *st, ts_error *err)
{
    if (S_ISREG(st->st_mode)) return TS_OK;
    return ts_error_set(err, TS_E_IO, "%s: not a regular file (%s)", path, file_kind(st->st_mode));
}

int ts_file_check_regular(const char *path, ts_error *err)
{
    struct stat st;
    if (stat(path, &st) != 0) return ts_error_set(err, TS_E_IO, "%s: %s", path, strerror(errno));
    return check_mode(path, &st, err);
}

FILE *ts_file_open_regular(const char *path, ts_error *err)
{
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        ts_error_set(err, TS_E_IO, "%s: %s", path, strerror(errno));
        return NULL;
    }
    struct stat st;
    int flags = fcntl(fd, F_GETFL);
    if (fstat(fd, &st) != 0 || check_mode(path, &st, err) != TS_OK || flags < 0 ||
        fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) != 0) {
        ts_error_set(err, TS_E_IO, "%s: %s", path, strerror(errno)); /* unless set above */
        close(fd);
        return NULL;
    }
    FILE *f = fdopen(fd, "rb");
    if (!f) {
        ts_error_set(err, TS_E_IO, "%s: %s", path, strerror(errno));
        close(fd);
    }
    return f;
}

int ts_file_read_all(const char *path, char **text, size_t *len, char *why, size_t why_cap)
{
    *text = NULL, *len = 0;
    ts_error e = {0};
    FILE *f = ts_file_open_regular(path, &e);
    if (!f) {
        /* e.msg is "PATH: reason": keep the reason. */
        size_t plen = strlen(path);
        const char *reason =
            strncmp(e.msg, path, plen) == 0 && e.msg[plen] == ':' ? e.msg + plen + 2 : e.msg;
        snprintf(why, why_cap, "%s", reason);
        ts_error_clear(&e);
        return TS_E_IO;
    }
    char *buf = NULL;
    size_t n = 0, cap = 0;
    int rc = TS_OK;
    for (;;) {
        if (n + 1 >= cap) {
            size_t c = cap ? cap * 2 : 65536;
            char *b = realloc(buf, c);
            if (!b) {
                snprintf(why, why_cap, "out of memory");
                rc = TS_E_MEMORY;
                break;
            }
            buf = b, cap = c;
        }
        size_t got = fread(buf + n, 1, cap - n - 1, f);
        n += got;
        if (got == 0) break;
    }
    if (rc == TS_OK && ferror(f)) {
        snprintf(why, why_cap, "%s", strerror(errno));
        rc = TS_E_IO;
    }
    fclose(f);
    if (rc != TS_OK) {
        free(buf);
        return rc;
    }
    buf[n] = '\0';
    *text = buf, *len = n;
    return TS_OK;
}
