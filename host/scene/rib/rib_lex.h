/* rib_lex.h — tokenizer for RIB (RenderMan Interface Spec 3.2, Appendix C.2), ASCII and
 * binary encoded tokens freely mixed in one stream, private to the RIB parser. Works on a
 * byte buffer of known length (no NUL terminator needed) and never reads past it.
 * Positions: an ASCII token has a 1-based line and column (columns count bytes); a binary
 * token has line 0 and col its 0-based byte offset in the (inflated) file, since lines mean
 * nothing in binary data. rib_lex_where formats either. */
#ifndef TS_RIB_LEX_H
#define TS_RIB_LEX_H

#include "base/error.h"

#include <stddef.h>

/* Longest request name and number literal accepted, in bytes. */
#define RIB_MAX_NAME 64
#define RIB_MAX_NUMBER 64
/* Longest string literal after escapes, in bytes. */
#define RIB_MAX_STRING 65536

typedef enum rib_tok_kind {
    RIB_TOK_EOF,
    RIB_TOK_NAME,   /* a request name: letters, digits, '_' */
    RIB_TOK_NUMBER, /* tok.num */
    RIB_TOK_STRING, /* tok.str, NUL-terminated, tok.len bytes (may hold NULs) */
    RIB_TOK_LBRACKET,
    RIB_TOK_RBRACKET,
    /* A comment that starts "##RLF" (RenderMan for Maya's look-file nuggets, rib_rlf.c): tok.str
     * is the rest of its line after "##RLF" and the blanks that follow, tok.len bytes. Every
     * other comment is skipped. */
    RIB_TOK_RLF,
} rib_tok_kind;

/* Binary RIB: request names bound to codes (0314), strings bound to tokens (0315, 0316),
 * and at most RIB_MAX_DEFINED_BYTES of defined strings at a time. */
#define RIB_MAX_DEFINED_BYTES ((size_t)1 << 26)

typedef struct rib_token {
    rib_tok_kind kind;
    int line, col; /* of the token's first byte; line 0: col is a byte offset (binary) */
    double num;
    const char *str; /* names and strings; valid until the next rib_lex_next */
    size_t len;
} rib_token;

typedef struct rib_lexer {
    const char *file; /* for messages */
    const char *text;
    size_t len, pos;
    int line, col;
    char *buf; /* decoded names and strings */
    size_t buf_cap;
    ts_error *err;
    /* Binary RIB (rib_lex.c): a float array (0310-0313) being handed out one number a
     * token, array_left numbers then its ']'; the definitions of this stream, NULL before
     * the first. */
    int in_array;
    size_t array_left;
    struct rib_lex_defs *defs;
} rib_lexer;

void rib_lex_init(rib_lexer *lx, const char *file, const char *text, size_t len, ts_error *err);
void rib_lex_free(rib_lexer *lx);
/* "file:line:col" for an ASCII position, "file:byte N" for a binary one (line 0), into buf
 * (n bytes). Returns buf. */
const char *rib_lex_where(const char *file, int line, int col, char *buf, size_t n);
/* Reads the next token. Returns TS_OK, or TS_E_SCENE / TS_E_MEMORY with err set to a
 * "file:line:col: error: ..." (ASCII) or "file:byte N: error: ..." (binary) message. Binary
 * definitions (0314, 0315, 0316) make no token: the token after them is returned. */
int rib_lex_next(rib_lexer *lx, rib_token *tok);

#endif
