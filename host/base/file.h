/* file.h — opening input files safely: only regular files are read. A FIFO would block the
 * open forever, /dev/zero would grow a buffer until memory runs out, a directory cannot be
 * parsed (issue 15, item 7); each is refused at once with a message naming the path and
 * what it is. And the checks of output paths made before any work (item 4): whether two
 * paths name one file, whether a file can be written at a path. */
#ifndef TS_FILE_H
#define TS_FILE_H

#include "base/error.h"

#include <stdio.h>

/* TS_OK when path names a regular file (following symbolic links); else TS_E_IO with
 * "PATH: <strerror>" or "PATH: not a regular file (a FIFO)" (directory, character device,
 * block device, socket). */
int ts_file_check_regular(const char *path, ts_error *err);

/* Opens a regular file for reading ("rb") without ever blocking on a FIFO (the file is
 * opened non-blocking, checked with fstat, then made blocking). NULL with err set as
 * ts_file_check_regular says. */
FILE *ts_file_open_regular(const char *path, ts_error *err);

/* Reads a whole regular file into a malloc'd buffer (*text, *len; a NUL follows the last
 * byte, not counted). On failure returns TS_E_IO or TS_E_MEMORY and writes the reason
 * (strerror's text, "not a regular file (a FIFO)", "out of memory") to why[0..why_cap). */
int ts_file_read_all(const char *path, char **text, size_t *len, char *why, size_t why_cap);

/* 1 when paths a and b name the same file: the same device and inode when both exist,
 * else the same canonical directory (realpath) and the same last component. 0 otherwise,
 * and when either directory cannot be resolved. */
int ts_file_same(const char *a, const char *b);

/* TS_OK when a file can be written at path the way outputs are (a temporary created
 * beside it, then renamed over it): its directory exists and is writable, and path is not
 * itself a directory. Else TS_E_IO "PATH: cannot write there: <reason>". */
int ts_file_check_writable(const char *path, ts_error *err);

/* The temporary an output is written to before it is renamed over path (image.h, stats.h):
 * ".BASE.tmp-PID-N" in path's directory, BASE being path's last component, cut short when
 * the whole name would pass the directory's NAME_MAX (a 249-character output name is legal,
 * its temporary must be too). Fails (-1) only when out[0..cap) is too small. */
int ts_file_temp_name(const char *path, long pid, unsigned n, char *out, size_t cap);

/* Removes the temporaries of path (ts_file_temp_name's names, any N) whose process no
 * longer runs: what a SIGKILL, a crash or a power cut during a write left behind. Files of
 * a live process, of other outputs and of other programs are never touched. Returns how
 * many were removed. */
int ts_file_remove_stale_temps(const char *path);

/* Creates (O_EXCL, the caller's umask) an empty temporary for path (ts_file_temp_name, the
 * first free N), after removing stale ones; its name goes to tmp[0..cap) for a writer that
 * opens files by name. TS_E_IO "PATH: cannot create a temporary file beside it: <reason>"
 * (or "PATH: the path is too long"). */
int ts_file_temp_create(const char *path, char *tmp, size_t cap, ts_error *err);

/* Makes a finished temporary the file at path: fsync, then rename over path, so that a
 * crash cannot leave a truncated file under the target's name. On failure the temporary is
 * removed, path is left as it was and err is TS_E_IO "PATH: cannot ...". */
int ts_file_temp_commit(const char *tmp, const char *path, ts_error *err);

#endif
