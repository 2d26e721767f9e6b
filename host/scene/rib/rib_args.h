/* rib_args.h — what every request handler of the RIB reader uses (rib_args.c): messages
 * that name the file, line and column; the arguments of the current request, read from
 * the tokens into the parser's pools (RI Spec 3.2 Appendix C.2: numbers, strings and
 * [arrays] up to the next request name) and read back as numbers, integers, strings and
 * "name" value parameter lists (§5.1: inline declarations); file names relative to the
 * file being read, and the textures they name. It calls only the lexer and the scene,
 * never a handler.
 */
#ifndef TS_RIB_ARGS_H
#define TS_RIB_ARGS_H

#include "scene/rib/rib_parser.h"

#include <stddef.h>
#include <stdint.h>

/* ---- messages ---- */

/* Sets TS_E_SCENE "file:line:col: error: <fmt>" and returns TS_E_SCENE. */
int rib_error_at(rib_parser *p, int line, int col, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
/* Prints "file:line:col: warning: <what>" once per distinct text unless quiet. */
void rib_warn_once(rib_parser *p, int line, int col, const char *what);
/* A file the current request names (`what` "texture ", "" ..., then its name) that cannot
 * be read for reason `why`, at (line, col): strict, the error "REQ: cannot read WHAT\"name\":
 * why" (TS_E_SCENE); otherwise, as RenderMan does, one warning "...; FALLBACK (--strict makes
 * this an error)" and TS_OK: the caller goes on without the file. */
int rib_missing_file(rib_parser *p, int line, int col, const char *what, const char *name,
                     const char *why, const char *fallback);
/* s with control and non-ASCII bytes as '?', cut to RIB_PRINT_MAX - 1 bytes ("..."):
 * for echoing file strings in one-line messages. Returns buf. */
const char *rib_printable(const char *s, char buf[RIB_PRINT_MAX]);

/* ---- reading a request's arguments ---- */

/* Reads the arguments after a request name into p->args (and their values into p->nums,
 * p->strs, p->chars), up to the next name or the end of the file, which is left in *next.
 * The pools are reused by every request: what a handler keeps past the next request it
 * copies. */
int rib_read_args(rib_parser *p, rib_token *next);
/* Frees the argument pools. */
void rib_args_free(rib_parser *p);

/* A request with its arguments copied out of the pools: ObjectBegin records the requests of
 * an object's definition (rib_object.c) and ObjectInstance puts them back. One allocation
 * holds the four arrays. */
typedef struct rib_saved_request {
    char name[RIB_MAX_NAME + 1];
    int line, col;
    size_t nargs, nnums, nstrs, nchars;
    rib_arg *args;
    double *nums;
    size_t *strs;
    char *chars;
} rib_saved_request;

/* Copies the current request (p->req, its position and its arguments) into *out. */
int rib_args_save(rib_parser *p, rib_saved_request *out);
/* Makes *r the current request again, its arguments in the pools as rib_read_args left
 * them. */
int rib_args_restore(rib_parser *p, const rib_saved_request *r);
void rib_saved_request_free(rib_saved_request *r);
/* The requests of an object's definition or an inline archive, in order. */
typedef struct rib_saved_list {
    rib_saved_request *reqs;
    size_t count, cap;
} rib_saved_list;
/* Appends the current request (rib_args_save) to l. */
int rib_saved_list_push(rib_parser *p, rib_saved_list *l);
/* Frees l's requests and empties it. */
void rib_saved_list_free(rib_saved_list *l);

/* Appends an argument [v0 .. vn-1] (at line:col, for messages) after the current ones: a
 * handler that runs another request's handler on values it read (Option "Ri" runs Format,
 * CropWindow, Shutter) sets p->nargs to 0 first and puts the arguments back after. */
int rib_args_push_numbers(rib_parser *p, const double *v, size_t n, int line, int col);

/* ---- positional arguments ---- */

const char *rib_arg_str(const rib_parser *p, const rib_arg *a, size_t k);
const double *rib_arg_nums(const rib_parser *p, const rib_arg *a);
/* n numbers at args[*i], as n bare numbers or one [n] array; advances *i past them. */
int rib_numbers(rib_parser *p, size_t *i, size_t n, double *out);
/* Fails when arguments are left from index i on. */
int rib_no_more(rib_parser *p, size_t i);
/* An integer in [1, max] at args[*i]; advances *i. */
int rib_integer(rib_parser *p, size_t *i, const char *what, double max, int *out);
/* A string (or a one-string array) at args[i]. */
int rib_string_arg(rib_parser *p, size_t i, const char *what, const char **out);

/* ---- parameter lists ---- */

/* One "name" value pair of a parameter list; an inline declaration ("float fov",
 * "uniform color lightcolor") is reduced to its last word. */
typedef struct rib_param {
    const char *name;
    const rib_arg *key, *val;
} rib_param;

/* The pair at args[i], args[i + 1]. */
int rib_param_at(rib_parser *p, size_t i, rib_param *out);
/* The numbers of a parameter value: exactly n of them unless n == 0. */
int rib_param_numbers(rib_parser *p, const rib_param *prm, size_t n, const double **out,
                      size_t *count);
/* Whether name is one of list[0 .. n). */
int rib_in_list(const char *name, const char *const *list, size_t n);
/* The entries of a static array. */
#define RIB_COUNT(a) (sizeof(a) / sizeof((a)[0]))
/* A parameter at a value that changes nothing Tessera draws (RenderMan's default, or what
 * exporters write for "none"): its name and its n numbers (n <= 3). */
typedef struct rib_neutral {
    const char *name;
    size_t n;
    double v[3];
} rib_neutral;
/* Whether prm is one of table[0 .. count) at exactly its numbers (the ignored parameters that
 * need no warning). */
int rib_param_neutral(const rib_parser *p, const rib_param *prm, const rib_neutral *table,
                      size_t count);
/* Warns once that a parameter of the current request is ignored; silent for names beginning
 * "__", RenderMan's own bookkeeping (__instanceid). */
void rib_warn_param(rib_parser *p, const rib_param *prm);

/* ---- file names ---- */

/* `name` relative to the directory of the file being read (absolute names as they are);
 * a malloc'd path or NULL. */
char *rib_resolve(const rib_parser *p, const char *name);
/* As rib_resolve, but a relative name not found there is looked for in the working
 * directory (RenderMan's place for relative names: RenderMan for Maya writes archive paths
 * relative to the Maya project, where it renders from), then in each directory of Option
 * "searchpath" `which` (0: "archive", 1: "texture"; relative directories beside the file
 * being read); the first readable one is returned, else rib_resolve's path. */
char *rib_resolve_in(const rib_parser *p, const char *name, int which);
/* Reads the texture named by string argument args[i] (relative to the RIB file, or on the
 * "texture" search path) as kind TS_TEX_* into the scene. A missing file (none to open) is
 * rib_missing_file's: an error when strict, else a warning ending in `fallback` (what the
 * scene does without it), TS_OK and *index = TS_INVALID. A file that is there but cannot be
 * read as an image is an error at that argument naming it. An empty name is no texture
 * (TS_OK, *index = TS_INVALID, no warning), as RenderMan's shaders take "". */
int rib_texture_arg(rib_parser *p, size_t i, uint32_t kind, const char *fallback, uint32_t *index);
/* The name to read for texture `name` (malloc'd): name itself, except that a RenderMan .tex
 * (a format Tessera cannot read) gives the first of name.tx, .exr, .png, .tif, .tiff, .jpg
 * (its extension replaced) found beside the RIB file or on the "texture" search path; NULL
 * when there is none (why: RIB_TEX_NO_SIBLING) or out of memory. */
char *rib_texture_sibling(const rib_parser *p, const char *name);
#define RIB_TEX_NO_SIBLING                                                                         \
    "a RenderMan .tex, which Tessera cannot read, and no .tx, .exr, .png, .tif, .tiff or .jpg "    \
    "of the same name beside it"
/* As rib_texture_arg for a file name read earlier (a Pattern's), at (line, col). */
int rib_texture_named(rib_parser *p, const char *name, int line, int col, uint32_t kind,
                      const char *fallback, uint32_t *index);

#endif
