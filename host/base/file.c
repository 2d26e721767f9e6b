/* file.c — regular-file checks for inputs (base/file.h). */
#include "base/file.h"

#include <errno.h>
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
