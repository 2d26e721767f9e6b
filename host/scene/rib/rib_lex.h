/* rib_lex.h — tokenizer for ASCII RIB (RenderMan Interface Spec 3.2, Appendix C.2), private
 * to the RIB parser. Works on a byte buffer of known length (no NUL terminator needed) and
 * never reads past it. Positions are 1-based lines and columns (columns count bytes). */
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
} rib_tok_kind;

typedef struct rib_token {
    rib_tok_kind kind;
    int line, col; /* of the token's first byte */
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
} rib_lexer;

void rib_lex_init(rib_lexer *lx, const char *file, const char *text, size_t len, ts_error *err);
void rib_lex_free(rib_lexer *lx);
/* Reads the next token. Returns TS_OK, or TS_E_SCENE / TS_E_MEMORY with err set to a
 * "file:line:col: error: ..." message. */
int rib_lex_next(rib_lexer *lx, rib_token *tok);

#endif
