/* rib_args.c — the arguments of one RIB request and the messages about them: reads the
 * tokens after a request name into the parser's pools (numbers, strings and one-level
 * [arrays], bounded by RIB_MAX_*), and gives the handlers typed access to them: n numbers
 * bare or as one array, integers, strings, "name" value parameter lists with inline
 * declarations (RI Spec 3.2 §5.1), and file names relative to the file being read with the
 * textures they name (Displacement, Surface, domelight and the archives share those). Every
 * message names file:line:col of the token at fault. The handlers call this file; it calls
 * none of them (rib_internal.h has the map). */
#include "scene/rib/rib_args.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* ---- messages ---------------------------------------------------------------------- */

int rib_error_at(rib_parser *p, int line, int col, const char *fmt, ...)
{
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    char where[1200];
    rib_lex_where(p->lx.file, line, col, where, sizeof where);
    return ts_error_set(p->err, TS_E_SCENE, "%s: error: %s", where, msg);
}

/* Prints "file:line:col: warning: <what>" once per distinct `what` unless quiet. */
void rib_warn_once(rib_parser *p, int line, int col, const char *what)
{
    if (p->quiet) return;
    for (int i = 0; i < p->nwarned; i++)
        if (strncmp(p->warned[i], what, RIB_WARN_KEY - 1) == 0) return;
    if (p->nwarned < RIB_MAX_WARNED) { /* the key: what's first RIB_WARN_KEY - 1 bytes */
        size_t n = strnlen(what, RIB_WARN_KEY - 1);
        memcpy(p->warned[p->nwarned], what, n);
        p->warned[p->nwarned++][n] = '\0';
    }
    char where[1200];
    ts_print_line("%s: warning: %s", rib_lex_where(p->lx.file, line, col, where, sizeof where),
                  what);
}

int rib_missing_file(rib_parser *p, int line, int col, const char *what, const char *name,
                     const char *why, const char *fallback)
{
    char shown[RIB_PRINT_MAX];
    if (p->strict)
        return rib_error_at(p, line, col, "%s: cannot read %s\"%s\": %s", p->req, what,
                            rib_printable(name, shown), why);
    char text[1024];
    snprintf(text, sizeof text, "%s: cannot read %s\"%s\": %s; %s (--strict makes this an error)",
             p->req, what, rib_printable(name, shown), why, fallback);
    rib_warn_once(p, line, col, text);
    return TS_OK;
}

const char *rib_printable(const char *s, char buf[RIB_PRINT_MAX])
{
    size_t n = 0;
    for (; s[n] && n < RIB_PRINT_MAX - 4; n++) {
        unsigned char c = (unsigned char)s[n];
        buf[n] = (c >= 0x20 && c < 0x7f) ? (char)c : '?';
    }
    if (s[n]) buf[n++] = '.', buf[n++] = '.', buf[n++] = '.';
    buf[n] = '\0';
    return buf;
}

/* ---- reading a request's arguments ------------------------------------------------ */

/* Grows buf to hold `need` elements (doubling); NULL with err set when out of memory, buf
 * then still owned by the caller. */
static void *rib_reserve(rib_parser *p, void *buf, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap) return buf;
    size_t c = *cap ? *cap : 64;
    while (c < need)
        c *= 2;
    void *b = realloc(buf, c * elem);
    if (!b) {
        ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
        return NULL;
    }
    *cap = c;
    return b;
}

static int rib_push_number(rib_parser *p, const rib_token *t)
{
    if (p->nnums >= RIB_MAX_VALUES)
        return rib_error_at(p, t->line, t->col, "more than %u numbers in one request",
                            RIB_MAX_VALUES);
    double *n = rib_reserve(p, p->nums, &p->nums_cap, p->nnums + 1, sizeof *n);
    if (!n) return TS_E_MEMORY;
    p->nums = n;
    p->nums[p->nnums++] = t->num;
    return TS_OK;
}

static int rib_push_string(rib_parser *p, const rib_token *t)
{
    if (p->nstrs >= RIB_MAX_VALUES || p->nchars + t->len + 1 > RIB_MAX_CHARS)
        return rib_error_at(p, t->line, t->col, "too many strings in one request");
    size_t *s = rib_reserve(p, p->strs, &p->strs_cap, p->nstrs + 1, sizeof *s);
    if (!s) return TS_E_MEMORY;
    p->strs = s;
    char *c = rib_reserve(p, p->chars, &p->chars_cap, p->nchars + t->len + 1, 1);
    if (!c) return TS_E_MEMORY;
    p->chars = c;
    memcpy(c + p->nchars, t->str, t->len);
    c[p->nchars + t->len] = '\0';
    p->strs[p->nstrs++] = p->nchars;
    p->nchars += t->len + 1;
    return TS_OK;
}

static int rib_push_arg(rib_parser *p, const rib_arg *a)
{
    if (p->nargs >= RIB_MAX_ARGS)
        return rib_error_at(p, a->line, a->col, "more than %u arguments to %s", RIB_MAX_ARGS,
                            p->req);
    rib_arg *args = rib_reserve(p, p->args, &p->args_cap, p->nargs + 1, sizeof *args);
    if (!args) return TS_E_MEMORY;
    p->args = args;
    p->args[p->nargs++] = *a;
    return TS_OK;
}

/* Reads the elements of an array after its '[': all numbers or all strings, no nesting. */
static int rib_read_array(rib_parser *p, const rib_token *open)
{
    rib_arg a = {RIB_ARG_NUMBERS, open->line, open->col, p->nnums, 0};
    for (;;) {
        rib_token t;
        int rc = rib_lex_next(&p->lx, &t);
        if (rc != TS_OK) return rc;
        if (t.kind == RIB_TOK_RLF) continue; /* a look-file nugget inside an array: a comment */
        if (t.kind == RIB_TOK_RBRACKET) return rib_push_arg(p, &a);
        if (t.kind == RIB_TOK_LBRACKET)
            return rib_error_at(p, t.line, t.col, "nested arrays are not allowed");
        if (t.kind == RIB_TOK_EOF)
            return rib_error_at(p, open->line, open->col,
                                "unterminated array ('[' without ']' before the end of file)");
        if (t.kind == RIB_TOK_NAME) {
            char at[64];
            rib_lex_where("", t.line, t.col, at, sizeof at);
            return rib_error_at(p, open->line, open->col,
                                "unterminated array ('[' without ']' before %s at %s)", t.str,
                                at + 1);
        }
        int is_num = t.kind == RIB_TOK_NUMBER;
        if (a.count == 0) {
            a.kind = is_num ? RIB_ARG_NUMBERS : RIB_ARG_STRINGS;
            a.first = is_num ? p->nnums : p->nstrs;
        } else if ((a.kind == RIB_ARG_NUMBERS) != is_num) {
            return rib_error_at(p, t.line, t.col, "array mixes numbers and strings");
        }
        rc = is_num ? rib_push_number(p, &t) : rib_push_string(p, &t);
        if (rc != TS_OK) return rc;
        a.count++;
    }
}

/* Reads the arguments after a request name, up to the next name or the end of the file,
 * which is left in *next. */
int rib_read_args(rib_parser *p, rib_token *next)
{
    p->nargs = p->nnums = p->nstrs = p->nchars = 0;
    for (;;) {
        int rc = rib_lex_next(&p->lx, next);
        if (rc != TS_OK) return rc;
        rib_arg a = {RIB_ARG_NUMBER, next->line, next->col, 0, 1};
        if (next->kind == RIB_TOK_NUMBER) {
            a.first = p->nnums;
            rc = rib_push_number(p, next);
        } else if (next->kind == RIB_TOK_STRING) {
            a.kind = RIB_ARG_STRING;
            a.first = p->nstrs;
            rc = rib_push_string(p, next);
        } else if (next->kind == RIB_TOK_LBRACKET) {
            rc = rib_read_array(p, next);
            if (rc != TS_OK) return rc;
            continue;
        } else if (next->kind == RIB_TOK_RBRACKET) {
            return rib_error_at(p, next->line, next->col, "']' without '['");
        } else {
            return TS_OK; /* a name, a "##RLF" nugget or the end */
        }
        if (rc == TS_OK) rc = rib_push_arg(p, &a);
        if (rc != TS_OK) return rc;
    }
}

void rib_args_free(rib_parser *p)
{
    free(p->args);
    free(p->nums);
    free(p->strs);
    free(p->chars);
    free(p->st_join);
    p->st_join = NULL, p->st_join_cap = 0;
    p->args = NULL, p->nums = NULL, p->strs = NULL, p->chars = NULL;
    p->nargs = p->args_cap = p->nnums = p->nums_cap = 0;
    p->nstrs = p->strs_cap = p->nchars = p->chars_cap = 0;
}

/* ---- saved requests ---------------------------------------------------------------- */

int rib_args_save(rib_parser *p, rib_saved_request *out)
{
    memset(out, 0, sizeof *out);
    /* nums, strs and args are 8-byte aligned at 8-byte multiples; chars last. */
    size_t b_nums = p->nnums * sizeof(double), b_strs = p->nstrs * sizeof(size_t),
           b_args = p->nargs * sizeof(rib_arg);
    char *block = malloc(b_nums + b_strs + b_args + p->nchars + 1);
    if (!block) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    out->nums = (double *)block;
    out->strs = (size_t *)(block + b_nums);
    out->args = (rib_arg *)(block + b_nums + b_strs);
    out->chars = block + b_nums + b_strs + b_args;
    if (p->nnums) memcpy(out->nums, p->nums, b_nums);
    if (p->nstrs) memcpy(out->strs, p->strs, b_strs);
    if (p->nargs) memcpy(out->args, p->args, b_args);
    if (p->nchars) memcpy(out->chars, p->chars, p->nchars);
    memcpy(out->name, p->req, sizeof out->name);
    out->line = p->req_line, out->col = p->req_col;
    out->nargs = p->nargs, out->nnums = p->nnums, out->nstrs = p->nstrs, out->nchars = p->nchars;
    return TS_OK;
}

int rib_args_restore(rib_parser *p, const rib_saved_request *r)
{
    /* At least one element each: rib_reserve hands back the pool as it is when it is big
     * enough, which is NULL for a pool never used. */
    rib_arg *a = rib_reserve(p, p->args, &p->args_cap, r->nargs + 1, sizeof *a);
    if (a) p->args = a;
    double *n = a ? rib_reserve(p, p->nums, &p->nums_cap, r->nnums + 1, sizeof *n) : NULL;
    if (n) p->nums = n;
    size_t *s = n ? rib_reserve(p, p->strs, &p->strs_cap, r->nstrs + 1, sizeof *s) : NULL;
    if (s) p->strs = s;
    char *c = s ? rib_reserve(p, p->chars, &p->chars_cap, r->nchars + 1, 1) : NULL;
    if (!c) return TS_E_MEMORY; /* err set by rib_reserve */
    p->chars = c;
    if (r->nargs) memcpy(p->args, r->args, r->nargs * sizeof *a);
    if (r->nnums) memcpy(p->nums, r->nums, r->nnums * sizeof *n);
    if (r->nstrs) memcpy(p->strs, r->strs, r->nstrs * sizeof *s);
    if (r->nchars) memcpy(p->chars, r->chars, r->nchars);
    p->nargs = r->nargs, p->nnums = r->nnums, p->nstrs = r->nstrs, p->nchars = r->nchars;
    memcpy(p->req, r->name, sizeof p->req);
    p->req_line = r->line, p->req_col = r->col;
    return TS_OK;
}

void rib_saved_request_free(rib_saved_request *r)
{
    free(r->nums); /* the block */
    memset(r, 0, sizeof *r);
}

int rib_saved_list_push(rib_parser *p, rib_saved_list *l)
{
    if (l->count == l->cap) {
        size_t cap = l->cap ? l->cap * 2 : 16;
        rib_saved_request *r = realloc(l->reqs, cap * sizeof *r);
        if (!r) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
        l->reqs = r, l->cap = cap;
    }
    int rc = rib_args_save(p, &l->reqs[l->count]);
    if (rc == TS_OK) l->count++;
    return rc;
}

void rib_saved_list_free(rib_saved_list *l)
{
    for (size_t k = 0; k < l->count; k++)
        rib_saved_request_free(&l->reqs[k]);
    free(l->reqs);
    memset(l, 0, sizeof *l);
}

/* ---- positional arguments ---------------------------------------------------------- */

const char *rib_arg_str(const rib_parser *p, const rib_arg *a, size_t k)
{
    return p->chars + p->strs[a->first + k];
}

const double *rib_arg_nums(const rib_parser *p, const rib_arg *a)
{
    return p->nums + a->first;
}

static int arg_is_numeric(const rib_arg *a)
{
    return a->kind == RIB_ARG_NUMBER || a->kind == RIB_ARG_NUMBERS;
}

/* Reads n numbers starting at args[*i], given either as n bare numbers or as one [n]
 * array; advances *i past them. */
int rib_numbers(rib_parser *p, size_t *i, size_t n, double *out)
{
    if (*i < p->nargs && p->args[*i].kind == RIB_ARG_NUMBERS) {
        const rib_arg *a = &p->args[*i];
        if (a->count != n)
            return rib_error_at(p, a->line, a->col, "%s expects %zu numbers, got an array of %zu",
                                p->req, n, a->count);
        memcpy(out, rib_arg_nums(p, a), n * sizeof *out);
        (*i)++;
        return TS_OK;
    }
    for (size_t k = 0; k < n; k++, (*i)++) {
        if (*i >= p->nargs)
            return rib_error_at(p, p->req_line, p->req_col, "%s expects %zu numbers, got %zu",
                                p->req, n, k);
        const rib_arg *a = &p->args[*i];
        if (a->kind != RIB_ARG_NUMBER)
            return rib_error_at(p, a->line, a->col, "%s expects %zu numbers", p->req, n);
        out[k] = p->nums[a->first];
    }
    return TS_OK;
}

/* Fails on arguments left after the positional ones of a request without parameters. */
int rib_no_more(rib_parser *p, size_t i)
{
    if (i >= p->nargs) return TS_OK;
    return rib_error_at(p, p->args[i].line, p->args[i].col, "too many arguments to %s", p->req);
}

/* Reads a positive integer (a count, a step, a resolution) at args[*i]. */
int rib_integer(rib_parser *p, size_t *i, const char *what, double max, int *out)
{
    double v;
    int rc = rib_numbers(p, i, 1, &v);
    if (rc != TS_OK) return rc;
    const rib_arg *a = &p->args[*i - 1];
    if (!(v >= 1.0 && v <= max && v == floor(v)))
        return rib_error_at(p, a->line, a->col, "%s: %s must be an integer in [1, %.0f], got %g",
                            p->req, what, max, v);
    *out = (int)v;
    return TS_OK;
}

int rib_string_arg(rib_parser *p, size_t i, const char *what, const char **out)
{
    if (i >= p->nargs)
        return rib_error_at(p, p->req_line, p->req_col, "%s: missing %s (a string)", p->req, what);
    const rib_arg *a = &p->args[i];
    if (a->kind != RIB_ARG_STRING && !(a->kind == RIB_ARG_STRINGS && a->count == 1))
        return rib_error_at(p, a->line, a->col, "%s: expected %s (a string)", p->req, what);
    *out = rib_arg_str(p, a, 0);
    return TS_OK;
}
/* ---- parameter lists ------------------------------------------------------------- */

int rib_param_at(rib_parser *p, size_t i, rib_param *out)
{
    const rib_arg *key = &p->args[i];
    if (key->kind != RIB_ARG_STRING)
        return rib_error_at(p, key->line, key->col, "%s: expected a parameter name (a string)",
                            p->req);
    const char *name = rib_arg_str(p, key, 0);
    char shown[RIB_PRINT_MAX];
    if (i + 1 >= p->nargs)
        return rib_error_at(p, key->line, key->col, "%s: parameter \"%s\" has no value", p->req,
                            rib_printable(name, shown));
    const char *sp = strrchr(name, ' ');
    out->name = sp ? sp + 1 : name;
    out->key = key;
    out->val = &p->args[i + 1];
    return TS_OK;
}

/* The numbers of a parameter value; exactly n of them unless n == 0. */
int rib_param_numbers(rib_parser *p, const rib_param *prm, size_t n, const double **out,
                      size_t *count)
{
    const rib_arg *v = prm->val;
    char shown[RIB_PRINT_MAX];
    if (!arg_is_numeric(v))
        return rib_error_at(p, v->line, v->col, "%s: parameter \"%s\" needs numbers", p->req,
                            rib_printable(prm->name, shown));
    if (n != 0 && v->count != n)
        return rib_error_at(p, v->line, v->col, "%s: parameter \"%s\" needs %zu values, got %zu",
                            p->req, rib_printable(prm->name, shown), n, v->count);
    *out = rib_arg_nums(p, v);
    if (count) *count = v->count;
    return TS_OK;
}

int rib_in_list(const char *name, const char *const *list, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (strcmp(name, list[i]) == 0) return 1;
    return 0;
}

int rib_param_neutral(const rib_parser *p, const rib_param *prm, const rib_neutral *table,
                      size_t count)
{
    const rib_arg *v = prm->val;
    if (v->kind != RIB_ARG_NUMBER && v->kind != RIB_ARG_NUMBERS) return 0;
    for (size_t k = 0; k < count; k++) {
        if (strcmp(prm->name, table[k].name) != 0) continue;
        if (v->count != table[k].n) return 0;
        const double *x = rib_arg_nums(p, v);
        for (size_t c = 0; c < table[k].n; c++)
            if (x[c] != table[k].v[c]) return 0;
        return 1;
    }
    return 0;
}

void rib_warn_param(rib_parser *p, const rib_param *prm)
{
    char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
    /* Names beginning "__" are RenderMan's own bookkeeping (__instanceid, __faceindex, ...),
     * which RenderMan for Maya writes on every request: nothing to draw, nothing to say. */
    if (strncmp(prm->name, "__", 2) == 0) return;
    snprintf(what, sizeof what, "%s parameter \"%s\" is ignored", p->req,
             rib_printable(prm->name, shown));
    rib_warn_once(p, prm->key->line, prm->key->col, what);
}

/* ---- file names ------------------------------------------------------------------ */

char *rib_resolve(const rib_parser *p, const char *name)
{
    const char *file = p->lx.file, *slash = strrchr(file, '/');
    size_t dir = (name[0] == '/' || !slash) ? 0 : (size_t)(slash - file) + 1;
    size_t n = strlen(name);
    char *out = malloc(dir + n + 1);
    if (!out) return NULL;
    memcpy(out, file, dir);
    memcpy(out + dir, name, n + 1);
    return out;
}

char *rib_resolve_in(const rib_parser *p, const char *name, int which)
{
    char *here = rib_resolve(p, name);
    const char *dirs = p->searchpath[which];
    if (!here || name[0] == '/' || access(here, R_OK) == 0) return here;
    if (access(name, R_OK) == 0) { /* the working directory, where RenderMan looks */
        free(here);
        return strdup(name);
    }
    if (!dirs) return here;
    for (const char *d = dirs; *d;) {
        size_t n = strcspn(d, ":");
        if (n > 0 && !(n == 1 && (d[0] == '@' || d[0] == '&'))) {
            char *dir = malloc(n + 1), *full = NULL;
            if (dir) {
                memcpy(dir, d, n), dir[n] = '\0';
                size_t fl = n + strlen(name) + 2;
                char *joined = malloc(fl);
                if (joined) {
                    snprintf(joined, fl, "%s/%s", dir, name);
                    full = rib_resolve(p, joined); /* a relative directory: beside the file */
                    free(joined);
                }
                free(dir);
            }
            if (full && access(full, R_OK) == 0) {
                free(here);
                return full;
            }
            free(full);
        }
        d += n + (d[n] == ':');
    }
    return here;
}

int rib_texture_arg(rib_parser *p, size_t i, uint32_t kind, const char *fallback, uint32_t *index)
{
    const char *name = NULL;
    int rc = rib_string_arg(p, i, "a texture file name", &name);
    if (rc != TS_OK) return rc;
    if (!name[0]) { /* "": no map, as RenderMan's shaders take it */
        *index = TS_INVALID;
        return TS_OK;
    }
    return rib_texture_named(p, name, p->args[i].line, p->args[i].col, kind, fallback, index);
}

char *rib_texture_sibling(const rib_parser *p, const char *name)
{
    const char *dot = strrchr(name, '.');
    if (!dot || strcmp(dot, ".tex") != 0) return strdup(name);
    static const char *const exts[] = {".tx", ".exr", ".png", ".tif", ".tiff", ".jpg"};
    size_t stem = (size_t)(dot - name);
    for (size_t k = 0; k < sizeof exts / sizeof exts[0]; k++) {
        size_t n = strlen(exts[k]);
        char *cand = malloc(stem + n + 1);
        if (!cand) return NULL;
        memcpy(cand, name, stem), memcpy(cand + stem, exts[k], n + 1);
        char *path = rib_resolve_in(p, cand, 1);
        int found = path && access(path, R_OK) == 0;
        free(path);
        if (found) return cand;
        free(cand);
    }
    return NULL;
}

int rib_texture_named(rib_parser *p, const char *name, int line, int col, uint32_t kind,
                      const char *fallback, uint32_t *index)
{
    int rc;
    char *path = rib_resolve_in(p, name, 1);
    if (!path) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    ts_error e = {0};
    rc = scene_add_texture(p->scene, path, kind, index, &e);
    /* Missing (no file to open): RenderMan's warning and fallback unless strict. A file that
     * is there but is no image Tessera can read (or has no image module) stays an error. */
    int missing = rc != TS_OK && access(path, R_OK) != 0;
    free(path);
    if (rc == TS_E_MEMORY) return ts_error_set(p->err, rc, "%s", e.msg);
    if (rc != TS_OK && missing) {
        *index = TS_INVALID;
        rc = rib_missing_file(p, line, col, "texture ", name, e.msg, fallback);
    } else if (rc != TS_OK) {
        char shown[RIB_PRINT_MAX];
        rc = rib_error_at(p, line, col, "%s: cannot read texture \"%s\": %s", p->req,
                          rib_printable(name, shown), e.msg);
    }
    ts_error_clear(&e);
    return rc;
}

/* ---- arguments made by a handler ------------------------------------------------------ */

int rib_args_push_numbers(rib_parser *p, const double *v, size_t n, int line, int col)
{
    rib_arg a = {RIB_ARG_NUMBERS, line, col, p->nnums, n};
    for (size_t k = 0; k < n; k++) {
        rib_token t = {RIB_TOK_NUMBER, line, col, v[k], NULL, 0};
        int rc = rib_push_number(p, &t);
        if (rc != TS_OK) return rc;
    }
    return rib_push_arg(p, &a);
}
