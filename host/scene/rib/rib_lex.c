/* rib_lex.c — ASCII RIB tokens: request names, numbers, "strings" with C escapes, [ and ],
 * and # comments to the end of the line (RI Spec 3.2, Appendix C.2). Binary RIB (bytes
 * 0x80-0xff as encoded tokens) is rejected. Bounded: names and numbers to 64 bytes,
 * strings to 64 KiB, so a hostile file costs at most that much per token. */
#include "scene/rib/rib_lex.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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
}

static int lex_error(rib_lexer *lx, int line, int col, const char *what, const char *arg)
{
    return ts_error_set(lx->err, TS_E_SCENE, "%s:%d:%d: error: %s%s", lx->file, line, col, what,
                        arg ? arg : "");
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

static int lex_is_delim(int c)
{
    return c < 0 || lex_is_space(c) || c == '[' || c == ']' || c == '"' || c == '#';
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

static void lex_skip_space_and_comments(rib_lexer *lx)
{
    for (;;) {
        int c = lex_peek(lx);
        if (lex_is_space(c)) {
            lex_advance(lx);
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

/* A byte that starts no token. Bytes 0x80-0xff are how binary RIB (RI Spec 3.2 Appendix
 * C.3) encodes its tokens, so such a byte names binary RIB; gzip data never gets here
 * (rib_text.c inflates it first) and a UTF-8 byte order mark at the start is skipped. */
static int lex_bad_byte(rib_lexer *lx, const rib_token *tok, int c)
{
    char what[96];
    if (c >= 0x80) {
        snprintf(what, sizeof what,
                 "(byte 0x%02x starts a binary token; convert the file to ASCII RIB)", c);
        return lex_error(lx, tok->line, tok->col, "binary RIB is not supported ", what);
    }
    if (c >= 0x20 && c < 0x7f)
        snprintf(what, sizeof what, "character '%c'", c);
    else
        snprintf(what, sizeof what, "byte 0x%02x", c);
    return lex_error(lx, tok->line, tok->col, "unexpected ", what);
}

int rib_lex_next(rib_lexer *lx, rib_token *tok)
{
    lex_skip_space_and_comments(lx);
    memset(tok, 0, sizeof *tok);
    tok->line = lx->line;
    tok->col = lx->col;
    int c = lex_peek(lx);
    if (c < 0) {
        tok->kind = RIB_TOK_EOF;
        return TS_OK;
    }
    if (c == '[' || c == ']') {
        tok->kind = c == '[' ? RIB_TOK_LBRACKET : RIB_TOK_RBRACKET;
        lex_advance(lx);
        return TS_OK;
    }
    if (c == '"') return lex_string(lx, tok);
    if (lex_is_digit(c) || c == '+' || c == '-' || c == '.') return lex_number(lx, tok);
    if ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_') return lex_name(lx, tok);
    return lex_bad_byte(lx, tok, c);
}
