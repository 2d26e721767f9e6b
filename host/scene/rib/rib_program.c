/* rib_program.c — Procedural "RunProgram" ["program args" "datablock"] [bound] (RI Spec 3.2
 * §5.7): a helper program that writes RIB on request. Each program (its command line) is
 * started once, on the first request that names it, with a socket as its standard input and
 * output (its standard error is Tessera's): for each request it reads one line,
 * "detail datablock\n" (detail: the bound's area in raster pixels), and answers with RIB
 * ended by the byte \377, staying up for the next request. At the end of the parse its
 * input is closed, which tells it to exit. The answer is read in place of the request inside
 * an attribute block of its own (rib_archive.c runs it), so what it sets does not leak.
 * docs/rib.md "Archives and procedurals" has the rules; which program may run is the caller's
 * choice (RIB_PROGRAMS: `--no-programs` and the fuzzer leave it off). */
#include "scene/rib/rib_internal.h"
#include "base/mat4.h"

#include <errno.h>
#include <math.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

extern char **environ;

#define RIB_PROGRAM_REPLY_MAX ((size_t)1 << 30) /* the largest answer read */
#define RIB_PROGRAM_ARGS 64                     /* words of a command line */
#define RIB_PROGRAM_END 0xffu                   /* the byte that ends an answer */
#define RIB_PROGRAM_INFINITY 1e38               /* RI_INFINITY: a bound across the eye plane */

/* A program started by this parse. */
struct rib_program {
    char *command; /* the request's command line, as written: programs are told apart by it */
    pid_t pid;
    int fd;     /* the socket: the program's standard input and output */
    char *rest; /* bytes read after an answer's \377 (the start of the next), rest_len */
    size_t rest_len;
    unsigned answered; /* requests answered so far */
    struct rib_program *next;
};

/* Waits up to about `ms` milliseconds for pid to exit; 1 when it did (reaped). */
static int reap_within(pid_t pid, int ms, int *status)
{
    for (int t = 0;; t += 10) {
        pid_t r = waitpid(pid, status, WNOHANG);
        if (r == pid || (r < 0 && errno != EINTR)) return 1;
        if (t >= ms) return 0;
        struct timespec d = {0, 10 * 1000 * 1000};
        nanosleep(&d, NULL);
    }
}

/* Closes the program's socket (its end of input: it should exit), then reaps it, killing it
 * after a second if it has not exited. */
static void program_stop(struct rib_program *g)
{
    int status;
    if (g->fd >= 0) close(g->fd);
    g->fd = -1;
    if (g->pid > 0 && !reap_within(g->pid, 1000, &status)) {
        kill(g->pid, SIGKILL);
        waitpid(g->pid, &status, 0);
    }
    g->pid = 0;
}

void rib_program_free(rib_parser *p)
{
    while (p->programs) {
        struct rib_program *g = p->programs;
        p->programs = g->next;
        program_stop(g);
        free(g->command);
        free(g->rest);
        free(g);
    }
}

/* Where `name` (a command line's first word) is run from: where rib_resolve_in finds it
 * (beside the RIB file, in the working directory, along Option "searchpath" "procedural"); a
 * bare name found nowhere as a file is left to PATH (NULL: posix_spawnp looks). Returns the
 * malloc'd path, or NULL with *oom set on a failed allocation. */
static char *program_path(const rib_parser *p, const char *name, int *oom)
{
    char *path = rib_resolve_in(p, name, 2);
    struct stat st;
    *oom = path == NULL;
    if (path && !strchr(name, '/') && (stat(path, &st) != 0 || !S_ISREG(st.st_mode))) {
        free(path);
        path = NULL;
    }
    return path;
}

/* The interpreter a script's "#!" line names (its first word), into out; 0 when path does
 * not start with "#!". */
static int script_interpreter(const char *path, char *out, size_t cap)
{
    char line[256] = {0};
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    size_t n = fread(line, 1, sizeof line - 1, f);
    fclose(f);
    line[n] = '\0';
    if (n < 3 || line[0] != '#' || line[1] != '!') return 0;
    const char *s = line + 2 + strspn(line + 2, " \t");
    snprintf(out, cap, "%.*s", (int)strcspn(s, " \t\r\n"), s);
    return out[0] != '\0';
}

/* Starts `command` (words split at blanks) with a socket as its standard input and output.
 * TS_OK with *out; a program that cannot be started is rib_missing_file's case (a warning and
 * *out NULL, or the error when strict). */
static int program_start(rib_parser *p, const char *command, const rib_arg *at,
                         struct rib_program **out)
{
    *out = NULL;
    char *words = strdup(command);
    char *argv[RIB_PROGRAM_ARGS + 1];
    int argc = 0;
    if (!words) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    for (char *save = NULL, *w = strtok_r(words, " \t\n", &save); w;
         w = strtok_r(NULL, " \t\n", &save)) {
        if (argc == RIB_PROGRAM_ARGS) {
            free(words);
            return rib_error_at(p, at->line, at->col,
                                "Procedural \"RunProgram\": more than %d words in the command "
                                "line",
                                RIB_PROGRAM_ARGS);
        }
        argv[argc++] = w;
    }
    argv[argc] = NULL;
    if (argc == 0) {
        free(words);
        return rib_error_at(p, at->line, at->col, "Procedural \"RunProgram\": no program named");
    }
    int oom;
    char *path = program_path(p, argv[0], &oom);
    int sv[2] = {-1, -1};
    struct rib_program *g = calloc(1, sizeof *g);
    char *copy = strdup(command);
    if (oom || !g || !copy || socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0) {
        int rc = oom || !g || !copy
                     ? ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file)
                     : rib_error_at(p, at->line, at->col,
                                    "Procedural \"RunProgram\": cannot make a socket: %s",
                                    strerror(errno));
        free(path), free(words), free(g), free(copy);
        return rc;
    }
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, sv[1], 0);
    posix_spawn_file_actions_adddup2(&fa, sv[1], 1);
    pid_t pid;
    int err = path ? posix_spawn(&pid, path, &fa, NULL, argv, environ)
                   : posix_spawnp(&pid, argv[0], &fa, NULL, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    close(sv[1]);
    int rc = TS_OK;
    if (err != 0) {
        close(sv[0]);
        char why[320];
        char interp[128];
        if (err == EACCES)
            snprintf(why, sizeof why,
                     "%s (not executable: chmod +x it, or name its interpreter, e.g. "
                     "\"python3 %s\")",
                     strerror(err), argv[0]);
        else if (err == ENOENT && path && script_interpreter(path, interp, sizeof interp))
            snprintf(why, sizeof why, "its interpreter \"%s\" (its #! line) is not there", interp);
        else
            snprintf(why, sizeof why, "%s", strerror(err));
        rc = rib_missing_file(p, at->line, at->col, "the program ", path ? path : argv[0], why,
                              "skipped");
        free(copy), free(g);
    } else {
        g->command = copy, g->pid = pid, g->fd = sv[0];
        g->next = p->programs;
        p->programs = g;
        *out = g;
    }
    free(path);
    free(words);
    return rc;
}

/* The raster area of the object-space box bound (xmin xmax ymin ymax zmin zmax) under the
 * CTM and the camera: RI Spec 3.2's detail, at the file's Format (RenderMan's 640x480 without
 * one) and screen window; RI_INFINITY when a corner is not in front of the eye. */
static double program_detail(const rib_parser *p, const double *bound)
{
    const ts_camera *c = &p->scene->camera;
    double w = c->has_format ? c->width : 640, h = c->has_format ? c->height : 480;
    double a = w / h, win[4] = {-a, a, -1, 1};
    if (a < 1) win[0] = -1, win[1] = 1, win[2] = -1 / a, win[3] = 1 / a;
    if (c->has_screen) memcpy(win, c->screen, sizeof win);
    double t = tan(c->fov_deg * M_PI / 360.0), m[16];
    memcpy(m, c->world_to_camera, sizeof m);
    mat4_concat(m, p->ctm); /* object to camera */
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int k = 0; k < 8; k++) {
        const double o[3] = {bound[k & 1], bound[2 + (k >> 1 & 1)], bound[4 + (k >> 2)]};
        double cp[4];
        for (int r = 0; r < 4; r++)
            cp[r] = m[r * 4] * o[0] + m[r * 4 + 1] * o[1] + m[r * 4 + 2] * o[2] + m[r * 4 + 3];
        if (!(cp[3] > 0)) return RIB_PROGRAM_INFINITY;
        double x = cp[0] / cp[3], y = cp[1] / cp[3], z = cp[2] / cp[3], s[2];
        if (c->projection == TS_PROJECTION_ORTHOGRAPHIC) {
            s[0] = x, s[1] = y;
        } else {
            if (!(z > 1e-12)) return RIB_PROGRAM_INFINITY;
            s[0] = x / (z * t), s[1] = y / (z * t);
        }
        double r[2] = {(s[0] - win[0]) / (win[1] - win[0]) * w,
                       (win[3] - s[1]) / (win[3] - win[2]) * h};
        for (int d = 0; d < 2; d++)
            lo[d] = fmin(lo[d], r[d]), hi[d] = fmax(hi[d], r[d]);
    }
    double area = (hi[0] - lo[0]) * (hi[1] - lo[1]);
    return isfinite(area) ? area : RIB_PROGRAM_INFINITY;
}

/* Where the answer in buf[0, have) ends: the index of its end mark, *mark its length, or -1
 * when it has not ended yet (scan from *pos on next time, in *mode). The mark is the byte
 * \377 anywhere, or outside strings and comments its UTF-8 encoding, C3 BF (what Python 3's
 * sys.stdout.write("\377") writes: RenderMan's Python helpers are written that way; no RIB
 * token outside a string holds a byte above 0x7f). mode: 0 between tokens, 1 in a string, 2
 * after a backslash in it, 3 in a comment. */
static long answer_end(const char *buf, size_t *pos, size_t have, int *mode, size_t *mark)
{
    for (size_t i = *pos; i < have; i++) {
        unsigned char c = (unsigned char)buf[i];
        if (c == RIB_PROGRAM_END) {
            *mark = 1;
            return (long)i;
        }
        if (*mode == 0) {
            if (c == '"')
                *mode = 1;
            else if (c == '#')
                *mode = 3;
            else if (c == 0xc3) {
                if (i + 1 == have) { /* its second byte is still to come */
                    *pos = i;
                    return -1;
                }
                if ((unsigned char)buf[i + 1] == 0xbf) {
                    *mark = 2;
                    return (long)i;
                }
            }
        } else if (*mode == 1) {
            *mode = c == '\\' ? 2 : c == '"' ? 0 : 1;
        } else if (*mode == 2) {
            *mode = 1;
        } else if (c == '\n' || c == '\r') {
            *mode = 0;
        }
    }
    *pos = have;
    return -1;
}

/* Writes all n bytes of buf to the program; 0, or errno. */
static int program_write(struct rib_program *g, const char *buf, size_t n)
{
    while (n > 0) {
        ssize_t k = send(g->fd, buf, n, MSG_NOSIGNAL);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) return k < 0 ? errno : EPIPE;
        buf += k, n -= (size_t)k;
    }
    return 0;
}

/* Why the program's answer ended early: its exit status once it has exited (reaped), else
 * that it closed its output. */
static void program_gone(struct rib_program *g, char *why, size_t cap)
{
    int status;
    if (g->pid > 0 && reap_within(g->pid, 200, &status)) {
        g->pid = 0;
        if (WIFEXITED(status))
            snprintf(why, cap, "it exited with status %d", WEXITSTATUS(status));
        else if (WIFSIGNALED(status))
            snprintf(why, cap, "it was killed by signal %d", WTERMSIG(status));
        else
            snprintf(why, cap, "it ended");
    } else {
        snprintf(why, cap, "it closed its output");
    }
}

/* Sends g the request for `data` over the object-space bound: "detail data\n". */
static int program_ask(rib_parser *p, struct rib_program *g, const char *command, const char *data,
                       const double *bound, const rib_arg *at)
{
    char shown[RIB_PRINT_MAX], why[256];
    size_t n = strlen(data) + 64;
    char *line = malloc(n);
    if (!line) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    snprintf(line, n, "%g %s\n", program_detail(p, bound), data);
    int err = program_write(g, line, strlen(line));
    free(line);
    if (!err) return TS_OK;
    program_gone(g, why, sizeof why);
    program_stop(g);
    return rib_error_at(p, at->line, at->col,
                        "Procedural \"RunProgram\": cannot send \"%s\" its request: %s (%s)",
                        rib_printable(command, shown), strerror(err), why);
}

/* Reads g's answer up to its end mark (answer_end) into *text (malloc'd, NUL-ended, *len
 * bytes), after what the last read left over; what follows the mark is kept for the next. */
static int program_answer(rib_parser *p, struct rib_program *g, const char *command,
                          const rib_arg *at, char **text, size_t *len)
{
    char shown[RIB_PRINT_MAX], why[256];
    size_t cap = g->rest_len + 65536, have = g->rest_len, scanned = 0, mark = 0;
    char *buf = malloc(cap + 1);
    if (!buf) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    if (have) memcpy(buf, g->rest, have);
    free(g->rest);
    g->rest = NULL, g->rest_len = 0;
    int mode = 0;
    long end;
    while ((end = answer_end(buf, &scanned, have, &mode, &mark)) < 0) {
        if (have == cap) {
            if (cap >= RIB_PROGRAM_REPLY_MAX) {
                free(buf);
                program_stop(g);
                return rib_error_at(p, at->line, at->col,
                                    "Procedural \"RunProgram\": \"%s\" answered more than %zu MB "
                                    "without the \\377 that ends an answer",
                                    rib_printable(command, shown), RIB_PROGRAM_REPLY_MAX >> 20);
            }
            char *more = realloc(buf, cap * 2 + 1);
            if (!more) {
                free(buf);
                return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
            }
            buf = more, cap *= 2;
        }
        ssize_t k = recv(g->fd, buf + have, cap - have, 0);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) {
            int e = k < 0 && errno != ECONNRESET ? errno : 0; /* reset: it exited unread */
            free(buf);
            if (e)
                snprintf(why, sizeof why, "%s", strerror(e));
            else
                program_gone(g, why, sizeof why);
            program_stop(g);
            return rib_error_at(p, at->line, at->col,
                                "Procedural \"RunProgram\": \"%s\" did not finish its answer "
                                "with \\377: %s",
                                rib_printable(command, shown), why);
        }
        have += (size_t)k;
    }
    size_t used = (size_t)end;
    if (have > used + mark) { /* kept for the next answer */
        g->rest_len = have - used - mark;
        g->rest = malloc(g->rest_len);
        if (!g->rest) {
            free(buf);
            return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
        }
        memcpy(g->rest, buf + used + mark, g->rest_len);
    }
    buf[used] = '\0';
    *text = buf, *len = used;
    return TS_OK;
}

int rib_program_run(rib_parser *p, const char *command, const char *data, const double *bound,
                    const rib_arg *at, char **text, size_t *len, char **name)
{
    *text = *name = NULL;
    *len = 0;
    if (!p->run_programs) {
        char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
        snprintf(what, sizeof what,
                 "Procedural \"RunProgram\": \"%s\" is not run (programs are off: "
                 "--no-programs); skipped",
                 rib_printable(command, shown));
        rib_warn_once(p, at->line, at->col, what);
        return TS_OK;
    }
    struct rib_program *g = p->programs;
    while (g && strcmp(g->command, command) != 0)
        g = g->next;
    int rc = g ? TS_OK : program_start(p, command, at, &g);
    if (rc != TS_OK || !g) return rc; /* an error, or not started (a warning) */
    rc = program_ask(p, g, command, data, bound, at);
    if (rc == TS_OK) rc = program_answer(p, g, command, at, text, len);
    if (rc != TS_OK) return rc;
    /* Messages name the answer "program[k]": its k-th answer, from 1. */
    size_t nn = strlen(command) + 24;
    if (!(*name = malloc(nn))) {
        free(*text);
        *text = NULL;
        return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    }
    snprintf(*name, nn, "%s[%u]", command, ++g->answered);
    return TS_OK;
}
