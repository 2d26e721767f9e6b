/* file.c — regular-file checks for inputs, and where outputs may go (base/file.h). */
#include "base/file.h"

#include <dirent.h>
#include <errno.h>
#include <limits.h>
#include <signal.h>
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

/* NAME_MAX of the directory dir (255 on the usual file systems). */
static size_t file_name_max(const char *dir)
{
    long n = pathconf(dir, _PC_NAME_MAX);
    return n > 0 ? (size_t)n : NAME_MAX;
}

/* The length BASE keeps in ".BASE" + suffix under name_max: all of it, or what fits. */
static size_t temp_stem_len(size_t base_len, size_t suffix_len, size_t name_max)
{
    size_t room = name_max > suffix_len + 1 ? name_max - suffix_len - 1 : 0;
    return base_len < room ? base_len : room;
}

int ts_file_temp_name(const char *path, long pid, unsigned n, char *out, size_t cap)
{
    char dir[PATH_MAX], suffix[64];
    const char *base = file_split(path, dir, sizeof dir);
    int slen = snprintf(suffix, sizeof suffix, ".tmp-%ld-%u", pid, n);
    size_t keep = temp_stem_len(strlen(base), (size_t)slen, file_name_max(dir));
    size_t dlen = (size_t)(base - path); /* path's directory part, with its slash */
    int len = snprintf(out, cap, "%.*s.%.*s%s", (int)dlen, path, (int)keep, base, suffix);
    return len < 0 || (size_t)len >= cap ? -1 : 0;
}

/* The process id of a temporary name's ".tmp-PID-N" ending whose stem (what precedes it,
 * after the leading dot) is base or, in a name exactly name_max long, a cut of it; else 0. */
static long temp_owner(const char *name, const char *base, size_t name_max)
{
    const char *tmp = NULL;
    for (const char *p = strstr(name, ".tmp-"); p; p = strstr(p + 1, ".tmp-"))
        tmp = p; /* the last one: BASE may hold ".tmp-" itself */
    if (name[0] != '.' || !tmp) return 0;
    char *end;
    long pid = strtol(tmp + 5, &end, 10);
    if (pid <= 0 || *end != '-' || !end[1]) return 0;
    for (const char *d = end + 1; *d; ++d)
        if (*d < '0' || *d > '9') return 0;
    size_t stem = (size_t)(tmp - name - 1), base_len = strlen(base);
    if (strncmp(name + 1, base, stem) != 0) return 0;
    return stem == base_len || (stem < base_len && strlen(name) == name_max) ? pid : 0;
}

int ts_file_remove_stale_temps(const char *path)
{
    char dir[PATH_MAX], file[PATH_MAX + 512];
    const char *base = file_split(path, dir, sizeof dir);
    size_t name_max = file_name_max(dir);
    DIR *d = opendir(dir);
    if (!d) return 0;
    int removed = 0;
    for (struct dirent *e; (e = readdir(d));) {
        long pid = temp_owner(e->d_name, base, name_max);
        if (pid <= 0 || pid == (long)getpid()) continue;
        if (kill((pid_t)pid, 0) == 0 || errno != ESRCH) continue; /* alive (or not ours) */
        if ((size_t)snprintf(file, sizeof file, "%s/%s", dir, e->d_name) >= sizeof file) continue;
        removed += unlink(file) == 0;
    }
    closedir(d);
    return removed;
}

int ts_file_temp_create(const char *path, char *tmp, size_t cap, ts_error *err)
{
    static _Atomic unsigned counter;  /* distinct names for the threads of one process */
    ts_file_remove_stale_temps(path); /* left by a process killed while it wrote */
    int last_errno = 0;
    for (int attempt = 0; attempt < 100; attempt++) {
        if (ts_file_temp_name(path, (long)getpid(), counter++, tmp, cap) != 0)
            return ts_error_set(err, TS_E_IO, "%s: the path is too long", path);
        int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0) {
            close(fd); /* the writer reopens it by name */
            return TS_OK;
        }
        last_errno = errno;
        if (errno != EEXIST) break; /* a temporary of a live process: try the next */
    }
    tmp[0] = '\0';
    return ts_error_set(err, TS_E_IO, "%s: cannot create a temporary file beside it: %s", path,
                        strerror(last_errno));
}

int ts_file_temp_commit(const char *tmp, const char *path, ts_error *err)
{
    int fd = open(tmp, O_RDONLY | O_CLOEXEC);
    if (fd < 0 || fsync(fd) != 0) {
        int e = errno;
        if (fd >= 0) close(fd);
        unlink(tmp);
        return ts_error_set(err, TS_E_IO, "%s: cannot sync temporary file: %s", path, strerror(e));
    }
    close(fd);
    if (rename(tmp, path) != 0) {
        int e = errno;
        unlink(tmp);
        return ts_error_set(err, TS_E_IO, "%s: cannot rename temporary file over it: %s", path,
                            strerror(e));
    }
    return TS_OK;
}
