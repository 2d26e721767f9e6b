/* file.c — regular-file checks for inputs, and where outputs may go (base/file.h). */
#include "base/file.h"

#include <errno.h>
#include <limits.h>
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

/* The directory part of path ("." when it has none) into dir[0..cap), and its last
 * component. */
static const char *file_split(const char *path, char *dir, size_t cap)
{
    const char *slash = strrchr(path, '/');
    if (!slash) {
        snprintf(dir, cap, ".");
        return path;
    }
    snprintf(dir, cap, "%.*s", slash == path ? 1 : (int)(slash - path), path);
    return slash + 1;
}

int ts_file_same(const char *a, const char *b)
{
    struct stat sa, sb;
    int ea = stat(a, &sa) == 0, eb = stat(b, &sb) == 0;
    if (ea && eb) return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    if (ea != eb) return 0; /* one exists, the other does not */
    char da[PATH_MAX], db[PATH_MAX], ra[PATH_MAX], rb[PATH_MAX];
    const char *na = file_split(a, da, sizeof da), *nb = file_split(b, db, sizeof db);
    if (!realpath(da, ra) || !realpath(db, rb)) return 0;
    return strcmp(ra, rb) == 0 && strcmp(na, nb) == 0;
}

int ts_file_check_writable(const char *path, ts_error *err)
{
    char dir[PATH_MAX];
    file_split(path, dir, sizeof dir);
    struct stat st;
    if (stat(dir, &st) != 0)
        return ts_error_set(err, TS_E_IO, "%s: cannot write there: %s: %s", path, dir,
                            strerror(errno));
    if (!S_ISDIR(st.st_mode))
        return ts_error_set(err, TS_E_IO, "%s: cannot write there: %s is not a directory", path,
                            dir);
    if (access(dir, W_OK | X_OK) != 0)
        return ts_error_set(err, TS_E_IO, "%s: cannot write there: %s: %s", path, dir,
                            strerror(errno));
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode))
        return ts_error_set(err, TS_E_IO, "%s: cannot write there: it is a directory", path);
    return TS_OK;
}
