/* rib_lex.c — RIB tokens (RI Spec 3.2, Appendix C.2). ASCII: request names, numbers,
 * "strings" with C escapes, [ and ], and # comments to the end of the line. Binary (a byte
 * 0200-0377 starts an encoded token, Table C.1), mixed freely with ASCII: integers and
 * fixed-point numbers (0200-0217), strings (0220-0243), IEEE floats and doubles (0244,
 * 0245), float arrays (0310-0313, handed out as '[' numbers ']' so that the parser sees the
 * same tokens as for ASCII), requests bound to one-byte codes (0314 defines, 0246 uses) and
 * strings bound to tokens (0315/0316 define, 0317/0320 use). Bounded: names and numbers to
 * 64 bytes, strings to 64 KiB, defined strings to 64 MiB in all, so a hostile file costs at
 * most that much; every binary token checks that its bytes are there before reading them. */
#include "scene/rib/rib_lex.h"

#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* What a binary stream has defined: request names by code (0314; "" where undefined) and
 * strings by token (0315 + w, w + 1 token bytes: tokens 0..65535), grown as tokens come. */
struct rib_lex_defs {
    char requests[256][RIB_MAX_NAME + 1];
    char **strings; /* NULL where undefined */
    size_t *lengths;
    size_t nstrings; /* entries allocated */
    size_t bytes;    /* of all defined strings, at most RIB_MAX_DEFINED_BYTES */
};

void rib_lex_init(rib_lexer *lx, const char *file, const char *text, size_t len, ts_error *err)
{
    memset(lx, 0, sizeof *lx);
    lx->file = file;
    lx->text = text;
    lx->len = text ? len : 0;
    lx->line = 1;
    lx->col = 1;
    lx->err = err;
}

void rib_lex_free(rib_lexer *lx)
{
    free(lx->buf);
    lx->buf = NULL;
    lx->buf_cap = 0;
    if (lx->defs) {
        for (size_t k = 0; k < lx->defs->nstrings; k++)
            free(lx->defs->strings[k]);
        free(lx->defs->strings);
        free(lx->defs->lengths);
        free(lx->defs);
        lx->defs = NULL;
    }
}

const char *rib_lex_where(const char *file, int line, int col, char *buf, size_t n)
{
    if (line == 0)
        snprintf(buf, n, "%s:byte %d", file, col);
    else
        snprintf(buf, n, "%s:%d:%d", file, line, col);
    return buf;
}

static int lex_errorf(rib_lexer *lx, int line, int col, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

static int lex_errorf(rib_lexer *lx, int line, int col, const char *fmt, ...)
{
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (line == 0)
        return ts_error_set(lx->err, TS_E_SCENE, "%s:byte %d: error: %s", lx->file, col, msg);
    return ts_error_set(lx->err, TS_E_SCENE, "%s:%d:%d: error: %s", lx->file, line, col, msg);
}

static int lex_error(rib_lexer *lx, int line, int col, const char *what, const char *arg)
{
    return lex_errorf(lx, line, col, "%s%s", what, arg ? arg : "");
}

static int lex_peek(const rib_lexer *lx)
{
    return lx->pos < lx->len ? (unsigned char)lx->text[lx->pos] : -1;
}

/* A line ends at LF, at CR LF and at a lone CR (classic Mac OS files): all three count as
 * one line end, so positions in messages are right whatever wrote the file. */
static void lex_advance(rib_lexer *lx)
{
    if (lx->pos >= lx->len) return;
    char c = lx->text[lx->pos++];
    if (c == '\n' || (c == '\r' && (lx->pos >= lx->len || lx->text[lx->pos] != '\n'))) {
        lx->line++;
        lx->col = 1;
    } else {
        lx->col++;
    }
}

static int lex_is_space(int c)
{
    return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v';
}

/* Bytes 0200-0377 start binary tokens, which delimit ASCII ones. */
static int lex_is_delim(int c)
{
    return c < 0 || c >= 0x80 || lex_is_space(c) || c == '[' || c == ']' || c == '"' || c == '#';
}

static int lex_is_digit(int c)
{
    return c >= '0' && c <= '9';
}

static int lex_is_name_char(int c)
{
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || lex_is_digit(c) || c == '_';
}

/* Appends one byte to the token buffer, growing it geometrically up to RIB_MAX_STRING. */
static int lex_put(rib_lexer *lx, size_t *n, char c, int line, int col)
{
    if (*n >= RIB_MAX_STRING)
        return lex_error(lx, line, col, "string longer than 65536 bytes", NULL);
    if (*n + 1 >= lx->buf_cap) {
        size_t cap = lx->buf_cap ? lx->buf_cap * 2 : 256;
        if (cap > RIB_MAX_STRING + 1) cap = RIB_MAX_STRING + 1;
        char *b = realloc(lx->buf, cap);
        if (!b) return ts_error_set(lx->err, TS_E_MEMORY, "%s: out of memory", lx->file);
        lx->buf = b;
        lx->buf_cap = cap;
    }
    lx->buf[(*n)++] = c;
    lx->buf[*n] = '\0';
    return TS_OK;
}

/* Whether the text at the current position is a "##RLF" nugget: "##RLF" then a blank or the
 * end of the line. */
static int lex_at_rlf(const rib_lexer *lx)
{
    static const char mark[] = "##RLF";
    size_t n = sizeof mark - 1;
    if (lx->len - lx->pos < n || memcmp(lx->text + lx->pos, mark, n) != 0) return 0;
    if (lx->pos + n == lx->len) return 1;
    char c = lx->text[lx->pos + n];
    return c == ' ' || c == '\t' || c == '\n' || c == '\r';
}

/* Skips blanks and comments, stopping before a "##RLF" nugget (a token). */
static void lex_skip_space_and_comments(rib_lexer *lx)
{
    for (;;) {
        int c = lex_peek(lx);
        if (lex_is_space(c)) {
            lex_advance(lx);
        } else if (c == '#' && lex_at_rlf(lx)) {
            return;
        } else if (c == '#') { /* to the end of the line: LF, CR LF or CR */
            while (lex_peek(lx) >= 0 && lex_peek(lx) != '\n' && lex_peek(lx) != '\r')
                lex_advance(lx);
        } else {
            return;
        }
    }
}

/* Counts a run of digits at pos + *k, advancing *k past it. */
static size_t lex_digits(const rib_lexer *lx, size_t *k)
{
    size_t n = 0;
    while (lx->pos + *k < lx->len && lex_is_digit((unsigned char)lx->text[lx->pos + *k])) {
        (*k)++;
        n++;
    }
    return n;
}

/* [+-] digits [. digits] [(e|E) [+-] digits], at least one mantissa digit, then a
 * delimiter. Scanned by hand so that strtod never sees "inf", "nan" or hex forms. */
static int lex_number(rib_lexer *lx, rib_token *tok)
{
    size_t k = 0;
    const char *s = lx->text + lx->pos;
    size_t avail = lx->len - lx->pos;
    if (k < avail && (s[k] == '+' || s[k] == '-')) k++;
    size_t mantissa = lex_digits(lx, &k);
    if (k < avail && s[k] == '.') {
        k++;
        mantissa += lex_digits(lx, &k);
    }
    int ok = mantissa > 0;
    if (ok && k < avail && (s[k] == 'e' || s[k] == 'E')) {
        k++;
        if (k < avail && (s[k] == '+' || s[k] == '-')) k++;
        ok = lex_digits(lx, &k) > 0;
    }
    if (ok) ok = lex_is_delim(k < avail ? (unsigned char)s[k] : -1);
    if (!ok) return lex_error(lx, tok->line, tok->col, "malformed number", NULL);
    if (k >= RIB_MAX_NUMBER) return lex_error(lx, tok->line, tok->col, "number too long", NULL);
    char tmp[RIB_MAX_NUMBER];
    memcpy(tmp, s, k);
    tmp[k] = '\0';
    tok->num = strtod(tmp, NULL);
    if (!isfinite(tok->num)) return lex_error(lx, tok->line, tok->col, "number out of range", NULL);
    for (size_t i = 0; i < k; i++)
        lex_advance(lx);
    tok->kind = RIB_TOK_NUMBER;
    return TS_OK;
}

/* Octal escape \o, \oo or \ooo (value at most 0377); the backslash is already consumed. */
static int lex_octal_escape(rib_lexer *lx, int *value)
{
    int v = 0;
    for (int d = 0; d < 3 && lex_peek(lx) >= '0' && lex_peek(lx) <= '7'; d++) {
        v = v * 8 + (lex_peek(lx) - '0');
        lex_advance(lx);
    }
    *value = v;
    return v <= 0377;
}

/* One escape after a backslash (consumed): the byte in *out, or -1 for a line
 * continuation, which adds nothing. */
static int lex_escape(rib_lexer *lx, int *out, int line, int col)
{
    static const char from[] = "ntrbf\\\"'";
    static const char to[] = "\n\t\r\b\f\\\"'";
    int c = lex_peek(lx);
    if (c < 0) return lex_error(lx, line, col, "unterminated string", NULL);
    const char *hit = c ? strchr(from, c) : NULL;
    if (hit) {
        *out = (unsigned char)to[hit - from];
        lex_advance(lx);
    } else if (c == '\n' || c == '\r') { /* line continuation, LF or CR LF */
        *out = -1;
        lex_advance(lx);
        if (c == '\r' && lex_peek(lx) == '\n') lex_advance(lx);
    } else if (c >= '0' && c <= '7') {
        if (!lex_octal_escape(lx, out))
            return lex_error(lx, lx->line, lx->col, "octal escape greater than \\377", NULL);
    } else {
        char what[8] = {'\\', (char)(c >= 0x20 && c < 0x7f ? c : '?'), '\'', '\0'};
        return lex_error(lx, lx->line, lx->col, "unknown escape sequence '", what);
    }
    return TS_OK;
}

static int lex_string(rib_lexer *lx, rib_token *tok)
{
    size_t n = 0;
    lex_advance(lx);                                     /* opening quote */
    int rc = lex_put(lx, &n, '\0', tok->line, tok->col); /* a buffer even for "" */
    if (rc != TS_OK) return rc;
    n = 0;
    for (;;) {
        int c = lex_peek(lx);
        if (c < 0) return lex_error(lx, tok->line, tok->col, "unterminated string", NULL);
        lex_advance(lx);
        if (c == '"') break;
        if (c == '\\') {
            rc = lex_escape(lx, &c, tok->line, tok->col);
            if (rc != TS_OK) return rc;
            if (c < 0) continue;
        }
        rc = lex_put(lx, &n, (char)c, tok->line, tok->col);
        if (rc != TS_OK) return rc;
    }
    tok->kind = RIB_TOK_STRING;
    tok->str = lx->buf;
    tok->len = n;
    return TS_OK;
}

static int lex_name(rib_lexer *lx, rib_token *tok)
{
    size_t n = 0;
    while (lex_is_name_char(lex_peek(lx))) {
        if (n >= RIB_MAX_NAME)
            return lex_error(lx, tok->line, tok->col, "request name too long", NULL);
        int rc = lex_put(lx, &n, (char)lex_peek(lx), tok->line, tok->col);
        if (rc != TS_OK) return rc;
        lex_advance(lx);
    }
    if (!lex_is_delim(lex_peek(lx)))
        return lex_error(lx, lx->line, lx->col, "unexpected character after request name", NULL);
    tok->kind = RIB_TOK_NAME;
    tok->str = lx->buf;
    tok->len = n;
    return TS_OK;
}

/* A byte that starts no ASCII token and no binary one. */
static int lex_bad_byte(rib_lexer *lx, const rib_token *tok, int c)
{
    char what[96];
    if (c >= 0x20 && c < 0x7f)
        snprintf(what, sizeof what, "character '%c'", c);
    else
        snprintf(what, sizeof what, "byte 0x%02x", c);
    return lex_error(lx, tok->line, tok->col, "unexpected ", what);
}

/* ---- binary RIB (RI Spec 3.2, Appendix C.2, Table C.1) -------------------------------- */

/* A byte offset as a token column (line 0); files past 2 GiB show INT_MAX. */
static int lex_offset(size_t pos)
{
    return pos > (size_t)INT_MAX ? INT_MAX : (int)pos;
}

/* Fails unless n bytes follow offset `at` + `head` (the token's first byte at `at`). */
static int lex_need(rib_lexer *lx, size_t at, size_t head, size_t n, const char *what)
{
    size_t left = lx->len - at;
    if (head <= left && n <= left - head) return TS_OK;
    return lex_errorf(lx, 0, lex_offset(at),
                      "binary RIB: %s (byte 0%03o) needs %zu more bytes, only %zu are left "
                      "(a truncated file)",
                      what, (unsigned char)lx->text[at], head + n - 1, left - 1);
}

/* Moves past n binary bytes: they count as columns, never as line ends. */
static void lex_skip(rib_lexer *lx, size_t n)
{
    lx->pos += n;
    lx->col = n > (size_t)(INT_MAX - lx->col) ? INT_MAX : lx->col + (int)n;
}

/* n (1..8) bytes at offset at, most significant first, as an unsigned number. */
static uint64_t lex_be(const rib_lexer *lx, size_t at, size_t n)
{
    uint64_t v = 0;
    for (size_t k = 0; k < n; k++)
        v = (v << 8) | (unsigned char)lx->text[at + k];
    return v;
}

static double lex_be_float(const rib_lexer *lx, size_t at)
{
    uint32_t u = (uint32_t)lex_be(lx, at, 4);
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

/* Makes room for n bytes and a NUL in the token buffer (n <= RIB_MAX_STRING). */
static int lex_reserve(rib_lexer *lx, size_t n)
{
    if (n + 1 <= lx->buf_cap) return TS_OK;
    char *b = realloc(lx->buf, n + 1);
    if (!b) return ts_error_set(lx->err, TS_E_MEMORY, "%s: out of memory", lx->file);
    lx->buf = b;
    lx->buf_cap = n + 1;
    return TS_OK;
}

static int lex_defs(rib_lexer *lx)
{
    if (lx->defs) return TS_OK;
    lx->defs = calloc(1, sizeof *lx->defs);
    return lx->defs ? TS_OK : ts_error_set(lx->err, TS_E_MEMORY, "%s: out of memory", lx->file);
}

/* Integers and fixed-point numbers, 0200 + 4d + w: w + 1 bytes of a signed integer, most
 * significant first, the last d bytes after the binary point; floats 0244 and doubles 0245,
 * IEEE, most significant byte first. Non-finite values are errors, as in ASCII. */
static int lex_bin_number(rib_lexer *lx, rib_token *tok, int c)
{
    size_t at = lx->pos, n;
    if (c <= 0217) {
        n = (size_t)((c - 0200) & 3) + 1;
        int d = (c - 0200) >> 2;
        int rc = lex_need(lx, at, 1, n, d ? "a fixed-point number" : "an integer");
        if (rc != TS_OK) return rc;
        uint64_t u = lex_be(lx, at + 1, n);
        int64_t v = (int64_t)u;
        if (u >> (8 * n - 1)) v -= (int64_t)1 << (8 * n); /* two's complement */
        tok->num = ldexp((double)v, -8 * d);
    } else if (c == 0244) {
        n = 4;
        int rc = lex_need(lx, at, 1, n, "a float");
        if (rc != TS_OK) return rc;
        tok->num = lex_be_float(lx, at + 1);
    } else {
        n = 8;
        int rc = lex_need(lx, at, 1, n, "a double");
        if (rc != TS_OK) return rc;
        uint64_t u = lex_be(lx, at + 1, 8);
        memcpy(&tok->num, &u, sizeof tok->num);
    }
    if (!isfinite(tok->num))
        return lex_errorf(lx, tok->line, tok->col, "binary RIB: a number that is not finite");
    lex_skip(lx, 1 + n);
    tok->kind = RIB_TOK_NUMBER;
    return TS_OK;
}

/* Strings: 0220 + w (w < 16 bytes follow), or 0240 + l, l + 1 bytes of unsigned length, the
 * bytes. No escapes; the bytes may hold NULs. Into the token buffer. */
static int lex_bin_string(rib_lexer *lx, rib_token *tok, int c)
{
    size_t at = lx->pos, head = 1, n;
    if (c <= 0237) {
        n = (size_t)(c - 0220);
    } else {
        size_t l = (size_t)(c - 0240) + 1;
        int rc = lex_need(lx, at, 1, l, "a string length");
        if (rc != TS_OK) return rc;
        n = (size_t)lex_be(lx, at + 1, l);
        head += l;
    }
    if (n > RIB_MAX_STRING)
        return lex_errorf(lx, tok->line, tok->col, "binary RIB: a string of %zu bytes (at most %d)",
                          n, RIB_MAX_STRING);
    int rc = lex_need(lx, at, head, n, "a string");
    if (rc == TS_OK) rc = lex_reserve(lx, n);
    if (rc != TS_OK) return rc;
    if (n) memcpy(lx->buf, lx->text + at + head, n);
    lx->buf[n] = '\0';
    lex_skip(lx, head + n);
    tok->kind = RIB_TOK_STRING;
    tok->str = lx->buf;
    tok->len = n;
    return TS_OK;
}

static int lex_string(rib_lexer *lx, rib_token *tok);

/* The string of a definition (0314, 0315, 0316): encoded (0220-0243) or quoted ASCII, right
 * after the token's bytes. */
static int lex_def_string(rib_lexer *lx, rib_token *tok, const char *what)
{
    memset(tok, 0, sizeof *tok);
    tok->line = 0;
    tok->col = lex_offset(lx->pos);
    int c = lex_peek(lx);
    if (c >= 0220 && c <= 0243) return lex_bin_string(lx, tok, c);
    if (c == '"') {
        tok->line = lx->line;
        tok->col = lx->col;
        return lex_string(lx, tok);
    }
    return lex_errorf(lx, tok->line, tok->col, "binary RIB: %s must be followed by a string", what);
}

/* 0314 | code | string: binds a request name to a one-byte code. */
static int lex_define_request(rib_lexer *lx)
{
    size_t at = lx->pos;
    int rc = lex_need(lx, at, 1, 1, "a request definition");
    if (rc == TS_OK) rc = lex_defs(lx);
    if (rc != TS_OK) return rc;
    unsigned code = (unsigned char)lx->text[at + 1];
    lex_skip(lx, 2);
    rib_token s;
    rc = lex_def_string(lx, &s, "a request definition (0314)");
    if (rc != TS_OK) return rc;
    int ok = s.len >= 1 && s.len <= RIB_MAX_NAME && !lex_is_digit((unsigned char)s.str[0]);
    for (size_t k = 0; ok && k < s.len; k++)
        ok = lex_is_name_char((unsigned char)s.str[k]);
    if (!ok)
        return lex_errorf(lx, 0, lex_offset(at),
                          "binary RIB: request code %u is defined as something that is not a "
                          "request name",
                          code);
    memcpy(lx->defs->requests[code], s.str, s.len + 1);
    return TS_OK;
}

/* 0246 | code: the request bound to code. */
static int lex_use_request(rib_lexer *lx, rib_token *tok)
{
    size_t at = lx->pos;
    int rc = lex_need(lx, at, 1, 1, "a request code");
    if (rc != TS_OK) return rc;
    unsigned code = (unsigned char)lx->text[at + 1];
    const char *name = lx->defs ? lx->defs->requests[code] : "";
    if (!name[0])
        return lex_errorf(lx, tok->line, tok->col,
                          "binary RIB: request code %u is used before it is defined (0314)", code);
    size_t n = strlen(name);
    rc = lex_reserve(lx, n);
    if (rc != TS_OK) return rc;
    memcpy(lx->buf, name, n + 1);
    lex_skip(lx, 2);
    tok->kind = RIB_TOK_NAME;
    tok->str = lx->buf;
    tok->len = n;
    return TS_OK;
}

/* 0315 + w | token | string: binds a string to a token of w + 1 bytes. */
static int lex_define_string(rib_lexer *lx, int c)
{
    size_t at = lx->pos, w = (size_t)(c - 0315) + 1;
    int rc = lex_need(lx, at, 1, w, "a string definition");
    if (rc == TS_OK) rc = lex_defs(lx);
    if (rc != TS_OK) return rc;
    size_t token = (size_t)lex_be(lx, at + 1, w);
    lex_skip(lx, 1 + w);
    rib_token s;
    rc = lex_def_string(lx, &s, "a string definition (0315, 0316)");
    if (rc != TS_OK) return rc;
    struct rib_lex_defs *d = lx->defs;
    if (token >= d->nstrings) {
        size_t cap = token + 1 > d->nstrings * 2 ? token + 1 : d->nstrings * 2;
        char **ss = realloc(d->strings, cap * sizeof *ss);
        if (ss) d->strings = ss;
        size_t *ls = ss ? realloc(d->lengths, cap * sizeof *ls) : NULL;
        if (!ls) return ts_error_set(lx->err, TS_E_MEMORY, "%s: out of memory", lx->file);
        d->lengths = ls;
        for (size_t k = d->nstrings; k < cap; k++)
            d->strings[k] = NULL, d->lengths[k] = 0;
        d->nstrings = cap;
    }
    size_t old = d->strings[token] ? d->lengths[token] + 1 : 0;
    if (d->bytes - old + s.len + 1 > RIB_MAX_DEFINED_BYTES)
        return lex_errorf(lx, 0, lex_offset(at),
                          "binary RIB: defined strings take more than %zu bytes",
                          RIB_MAX_DEFINED_BYTES);
    char *copy = malloc(s.len + 1);
    if (!copy) return ts_error_set(lx->err, TS_E_MEMORY, "%s: out of memory", lx->file);
    memcpy(copy, s.str, s.len + 1);
    free(d->strings[token]);
    d->strings[token] = copy;
    d->lengths[token] = s.len;
    d->bytes = d->bytes - old + s.len + 1;
    return TS_OK;
}

/* 0317 + w | token: the string bound to a token of w + 1 bytes. */
static int lex_use_string(rib_lexer *lx, rib_token *tok, int c)
{
    size_t at = lx->pos, w = (size_t)(c - 0317) + 1;
    int rc = lex_need(lx, at, 1, w, "a string reference");
    if (rc != TS_OK) return rc;
    size_t token = (size_t)lex_be(lx, at + 1, w);
    const struct rib_lex_defs *d = lx->defs;
    if (!d || token >= d->nstrings || !d->strings[token])
        return lex_errorf(lx, tok->line, tok->col,
                          "binary RIB: string token %zu is used before it is defined (0315)",
                          token);
    rc = lex_reserve(lx, d->lengths[token]);
    if (rc != TS_OK) return rc;
    memcpy(lx->buf, d->strings[token], d->lengths[token] + 1);
    lex_skip(lx, 1 + w);
    tok->kind = RIB_TOK_STRING;
    tok->str = lx->buf;
    tok->len = d->lengths[token];
    return TS_OK;
}

/* 0310 + l | length (l + 1 bytes) | length floats: '[' now, then its numbers and ']' from
 * rib_lex_next. The whole array must be in the file. */
static int lex_float_array(rib_lexer *lx, rib_token *tok, int c)
{
    size_t at = lx->pos, l = (size_t)(c - 0310) + 1;
    int rc = lex_need(lx, at, 1, l, "a float array length");
    if (rc != TS_OK) return rc;
    uint64_t count = lex_be(lx, at + 1, l);
    if (count > (lx->len - at - 1 - l) / 4)
        return lex_errorf(lx, tok->line, tok->col,
                          "binary RIB: a float array of %llu values runs past the end of the "
                          "file (a truncated file)",
                          (unsigned long long)count);
    lex_skip(lx, 1 + l);
    lx->in_array = 1;
    lx->array_left = (size_t)count;
    tok->kind = RIB_TOK_LBRACKET;
    return TS_OK;
}

/* The next element of a float array, or its ']'. */
static int lex_array_next(rib_lexer *lx, rib_token *tok)
{
    memset(tok, 0, sizeof *tok);
    tok->col = lex_offset(lx->pos);
    if (lx->array_left == 0) {
        lx->in_array = 0;
        tok->kind = RIB_TOK_RBRACKET;
        return TS_OK;
    }
    tok->num = lex_be_float(lx, lx->pos); /* present: lex_float_array checked */
    if (!isfinite(tok->num))
        return lex_errorf(lx, 0, tok->col, "binary RIB: a number that is not finite");
    lex_skip(lx, 4);
    lx->array_left--;
    tok->kind = RIB_TOK_NUMBER;
    return TS_OK;
}

/* One binary token starting with byte c (0200-0377); *made: whether it made a token (the
 * definitions make none). */
static int lex_binary(rib_lexer *lx, rib_token *tok, int c, int *made)
{
    tok->line = 0;
    tok->col = lex_offset(lx->pos);
    *made = 1;
    if (c <= 0217 || c == 0244 || c == 0245) return lex_bin_number(lx, tok, c);
    if (c <= 0243) return lex_bin_string(lx, tok, c);
    if (c == 0246) return lex_use_request(lx, tok);
    if (c >= 0310 && c <= 0313) return lex_float_array(lx, tok, c);
    if (c == 0317 || c == 0320) return lex_use_string(lx, tok, c);
    *made = 0;
    if (c == 0314) return lex_define_request(lx);
    if (c == 0315 || c == 0316) return lex_define_string(lx, c);
    return lex_errorf(lx, 0, tok->col, "binary RIB: reserved byte 0%03o (0x%02x)", (unsigned)c,
                      (unsigned)c);
}

/* A "##RLF" nugget (lex_at_rlf): the rest of its line, blanks after "##RLF" skipped. */
static int lex_rlf(rib_lexer *lx, rib_token *tok)
{
    for (int k = 0; k < 5; k++)
        lex_advance(lx);
    while (lex_peek(lx) == ' ' || lex_peek(lx) == '\t')
        lex_advance(lx);
    size_t n = 0;
    int rc = lex_put(lx, &n, '\0', tok->line, tok->col); /* the buffer exists when n is 0 */
    n = 0;
    while (rc == TS_OK && lex_peek(lx) >= 0 && lex_peek(lx) != '\n' && lex_peek(lx) != '\r') {
        rc = lex_put(lx, &n, (char)lex_peek(lx), tok->line, tok->col);
        lex_advance(lx);
    }
    if (rc != TS_OK) return rc;
    lx->buf[n] = '\0';
    tok->kind = RIB_TOK_RLF;
    tok->str = lx->buf;
    tok->len = n;
    return TS_OK;
}

int rib_lex_next(rib_lexer *lx, rib_token *tok)
{
    if (lx->in_array) return lex_array_next(lx, tok);
    for (;;) {
        lex_skip_space_and_comments(lx);
        memset(tok, 0, sizeof *tok);
        tok->line = lx->line;
        tok->col = lx->col;
        int c = lex_peek(lx);
        if (c < 0) {
            tok->kind = RIB_TOK_EOF;
            return TS_OK;
        }
        if (c >= 0x80) {
            int made, rc = lex_binary(lx, tok, c, &made);
            if (rc != TS_OK || made) return rc;
            continue; /* a definition: the token after it */
        }
        if (c == '[' || c == ']') {
            tok->kind = c == '[' ? RIB_TOK_LBRACKET : RIB_TOK_RBRACKET;
            lex_advance(lx);
            return TS_OK;
        }
        if (c == '"') return lex_string(lx, tok);
        if (c == '#') return lex_rlf(lx, tok); /* the only comment not skipped */
        if (lex_is_digit(c) || c == '+' || c == '-' || c == '.') return lex_number(lx, tok);
        if ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_') return lex_name(lx, tok);
        return lex_bad_byte(lx, tok, c);
    }
}
