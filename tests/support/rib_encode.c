/* rib_encode.c — ASCII RIB to binary RIB for the tests (rib_encode.h). Its tokenizer is its
 * own, kept simple: comments, "strings" with C escapes, [ ], numbers, request names. */
#include "rib_encode.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef enum { ENC_NAME, ENC_NUM, ENC_STR, ENC_OPEN, ENC_CLOSE } enc_kind;

typedef struct enc_tok {
    enc_kind kind;
    size_t start, end; /* the source text */
    double num;
    char *str; /* ENC_NAME, ENC_STR (decoded); len bytes */
    size_t len;
} enc_tok;

typedef struct enc_out {
    unsigned char *b;
    size_t n, cap;
} enc_out;

static void out_bytes(enc_out *o, const void *p, size_t n)
{
    if (o->n + n > o->cap) {
        while (o->n + n > o->cap)
            o->cap = o->cap ? o->cap * 2 : 4096;
        o->b = realloc(o->b, o->cap);
        if (!o->b) abort();
    }
    memcpy(o->b + o->n, p, n);
    o->n += n;
}

static void out_byte(enc_out *o, unsigned v)
{
    unsigned char c = (unsigned char)v;
    out_bytes(o, &c, 1);
}

/* v in n bytes, most significant first. */
static void out_be(enc_out *o, uint64_t v, int n)
{
    for (int k = n - 1; k >= 0; k--)
        out_byte(o, (unsigned)((v >> (8 * k)) & 0xff));
}

/* Bytes (1..4) an unsigned count needs. */
static int count_bytes(uint64_t v)
{
    return v < 0x100 ? 1 : v < 0x10000 ? 2 : v < 0x1000000 ? 3 : 4;
}

/* ---- tokenizer ------------------------------------------------------------------------ */

static int is_space(int c)
{
    return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v';
}

/* The next token from t[*i]; 0 at the end, -1 on text it does not know. */
static int next_tok(const char *t, size_t len, size_t *i, enc_tok *tok)
{
    for (;;) {
        while (*i < len && is_space((unsigned char)t[*i]))
            (*i)++;
        if (*i < len && t[*i] == '#') {
            while (*i < len && t[*i] != '\n' && t[*i] != '\r')
                (*i)++;
            continue;
        }
        break;
    }
    if (*i >= len) return 0;
    memset(tok, 0, sizeof *tok);
    tok->start = *i;
    char c = t[*i];
    if (c == '[' || c == ']') {
        tok->kind = c == '[' ? ENC_OPEN : ENC_CLOSE;
        tok->end = ++*i;
        return 1;
    }
    if (c == '"') {
        tok->kind = ENC_STR;
        tok->str = malloc(len - *i + 1);
        if (!tok->str) abort();
        (*i)++;
        while (*i < len && t[*i] != '"') {
            char ch = t[(*i)++];
            if (ch == '\\' && *i < len) {
                char e = t[(*i)++];
                const char *from = "ntrbf\\\"'", *to = "\n\t\r\b\f\\\"'";
                const char *hit = strchr(from, e);
                if (hit && e) {
                    ch = to[hit - from];
                } else if (e >= '0' && e <= '7') {
                    int v = e - '0';
                    for (int d = 1; d < 3 && *i < len && t[*i] >= '0' && t[*i] <= '7'; d++)
                        v = v * 8 + (t[(*i)++] - '0');
                    ch = (char)v;
                } else if (e == '\n' || e == '\r') {
                    if (e == '\r' && *i < len && t[*i] == '\n') (*i)++;
                    continue;
                } else {
                    return -1;
                }
            }
            tok->str[tok->len++] = ch;
        }
        if (*i >= len) return -1;
        tok->str[tok->len] = '\0';
        tok->end = ++*i;
        return 1;
    }
    size_t j = *i;
    while (j < len && !is_space((unsigned char)t[j]) && t[j] != '[' && t[j] != ']' && t[j] != '"' &&
           t[j] != '#')
        j++;
    tok->end = j;
    if ((c >= '0' && c <= '9') || c == '-' || c == '+' || c == '.') {
        char buf[128];
        if (j - *i >= sizeof buf) return -1;
        memcpy(buf, t + *i, j - *i);
        buf[j - *i] = '\0';
        char *endp;
        tok->kind = ENC_NUM;
        tok->num = strtod(buf, &endp);
        if (*endp) return -1;
    } else {
        tok->kind = ENC_NAME;
        tok->len = j - *i;
        tok->str = malloc(tok->len + 1);
        if (!tok->str) abort();
        memcpy(tok->str, t + *i, tok->len);
        tok->str[tok->len] = '\0';
    }
    *i = j;
    return 1;
}

/* ---- encoders ------------------------------------------------------------------------- */

static int float_exact(double v)
{
    return (double)(float)v == v;
}

static void out_float(enc_out *o, float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    out_be(o, u, 4);
}

/* The shortest exact encoding of v: integer (0200 + w), fixed point (0200 + 4d + w), float
 * (0244) or double (0245). */
static void out_number(enc_out *o, double v)
{
    if (!(v == 0 && signbit(v))) {
        for (int d = 0; d <= 3; d++) {
            double s = ldexp(v, 8 * d);
            if (s != floor(s) || fabs(s) >= 2147483648.0) continue;
            int64_t iv = (int64_t)s;
            for (int w = 0; w <= 3; w++) {
                int64_t lim = (int64_t)1 << (8 * (w + 1) - 1);
                if (iv >= -lim && iv < lim) {
                    out_byte(o, 0200u + 4u * (unsigned)d + (unsigned)w);
                    out_be(o, (uint64_t)iv & ((((uint64_t)1) << (8 * (w + 1))) - 1), w + 1);
                    return;
                }
            }
        }
    }
    if (float_exact(v)) {
        out_byte(o, 0244);
        out_float(o, (float)v);
    } else {
        uint64_t u;
        memcpy(&u, &v, sizeof u);
        out_byte(o, 0245);
        out_be(o, u, 8);
    }
}

static void out_string_bytes(enc_out *o, const char *s, size_t n)
{
    if (n < 16) {
        out_byte(o, 0220u + (unsigned)n);
    } else {
        int l = count_bytes(n);
        out_byte(o, 0240u + (unsigned)(l - 1));
        out_be(o, n, l);
    }
    out_bytes(o, s, n);
}

/* Strings defined so far (0315/0316) and request names (0314), by first appearance. */
typedef struct enc_dict {
    char **s;
    size_t *len, n, cap;
} enc_dict;

static long dict_find(const enc_dict *d, const char *s, size_t n)
{
    for (size_t k = 0; k < d->n; k++)
        if (d->len[k] == n && memcmp(d->s[k], s, n) == 0) return (long)k;
    return -1;
}

static size_t dict_add(enc_dict *d, const char *s, size_t n)
{
    if (d->n == d->cap) {
        d->cap = d->cap ? d->cap * 2 : 64;
        d->s = realloc(d->s, d->cap * sizeof *d->s);
        d->len = realloc(d->len, d->cap * sizeof *d->len);
        if (!d->s || !d->len) abort();
    }
    d->s[d->n] = malloc(n + 1);
    if (!d->s[d->n]) abort();
    memcpy(d->s[d->n], s, n);
    d->s[d->n][n] = '\0';
    d->len[d->n] = n;
    return d->n++;
}

static void dict_free(enc_dict *d)
{
    for (size_t k = 0; k < d->n; k++)
        free(d->s[k]);
    free(d->s);
    free(d->len);
}

typedef struct enc_state {
    enc_out out;
    enc_dict requests, strings, seen; /* seen: strings met once */
} enc_state;

/* A string: the second time it is seen it is defined (0315 one-byte token, 0316 two-byte),
 * then referenced (0317/0320) from then on; the first time it goes as it is. */
static void out_string(enc_state *e, const enc_tok *t)
{
    long k = dict_find(&e->strings, t->str, t->len);
    if (k < 0 && dict_find(&e->seen, t->str, t->len) >= 0 && e->strings.n < 65536) {
        k = (long)dict_add(&e->strings, t->str, t->len);
        out_byte(&e->out, k < 256 ? 0315 : 0316);
        out_be(&e->out, (uint64_t)k, k < 256 ? 1 : 2);
        out_string_bytes(&e->out, t->str, t->len);
    }
    if (k >= 0) {
        out_byte(&e->out, k < 256 ? 0317 : 0320);
        out_be(&e->out, (uint64_t)k, k < 256 ? 1 : 2);
        return;
    }
    dict_add(&e->seen, t->str, t->len);
    out_string_bytes(&e->out, t->str, t->len);
}

static void out_request(enc_state *e, const enc_tok *t)
{
    long k = dict_find(&e->requests, t->str, t->len);
    if (k < 0) {
        if (e->requests.n >= 256) abort(); /* more request names than codes */
        k = (long)dict_add(&e->requests, t->str, t->len);
        out_byte(&e->out, 0314);
        out_byte(&e->out, (unsigned)k);
        out_string_bytes(&e->out, t->str, t->len);
    }
    out_byte(&e->out, 0246);
    out_byte(&e->out, (unsigned)k);
}

/* An array from toks[0] ('[') to its ']' (count tokens in all): 0310 + l when every element
 * is a number exact as a float, else '[' elements ']'. */
static void out_array(enc_state *e, const enc_tok *toks, size_t count)
{
    size_t n = count - 2;
    int floats = 1;
    for (size_t k = 1; k + 1 < count; k++)
        floats = floats && toks[k].kind == ENC_NUM && float_exact(toks[k].num);
    if (floats) {
        int l = count_bytes(n);
        out_byte(&e->out, 0310u + (unsigned)(l - 1));
        out_be(&e->out, n, l);
        for (size_t k = 1; k + 1 < count; k++)
            out_float(&e->out, (float)toks[k].num);
        return;
    }
    out_byte(&e->out, '[');
    for (size_t k = 1; k + 1 < count; k++) {
        if (toks[k].kind == ENC_NUM)
            out_number(&e->out, toks[k].num);
        else
            out_string(e, &toks[k]);
    }
    out_byte(&e->out, ']');
}

/* One request, toks[0] its name, count tokens with its arguments. */
static void out_binary_request(enc_state *e, const enc_tok *toks, size_t count)
{
    out_request(e, &toks[0]);
    for (size_t k = 1; k < count; k++) {
        if (toks[k].kind == ENC_OPEN) {
            size_t j = k;
            while (j < count && toks[j].kind != ENC_CLOSE)
                j++;
            out_array(e, toks + k, j - k + 1);
            k = j;
        } else if (toks[k].kind == ENC_NUM) {
            out_number(&e->out, toks[k].num);
        } else {
            out_string(e, &toks[k]);
        }
    }
}

unsigned char *rib_encode(const char *text, size_t len, rib_encode_mode mode, size_t *out_len)
{
    enc_tok *toks = NULL;
    size_t n = 0, cap = 0, i = 0;
    int r;
    enc_tok t;
    while ((r = next_tok(text, len, &i, &t)) == 1) {
        if (n == cap) {
            cap = cap ? cap * 2 : 1024;
            toks = realloc(toks, cap * sizeof *toks);
            if (!toks) abort();
        }
        toks[n++] = t;
    }
    enc_state e;
    memset(&e, 0, sizeof e);
    if (r == 0) {
        out_bytes(&e.out, "##RenderMan RIB\n", 16); /* an ASCII comment first, as PRMan writes */
        size_t req = 0;
        for (size_t k = 0; k < n;) {
            size_t j = k + 1;
            while (j < n && toks[j].kind != ENC_NAME)
                j++;
            if (toks[k].kind != ENC_NAME) {
                r = -1;
                break;
            }
            if (mode == RIB_ENCODE_MIXED && req % 2 == 1) {
                out_bytes(&e.out, text + toks[k].start, toks[j - 1].end - toks[k].start);
                out_byte(&e.out, '\n');
            } else {
                out_binary_request(&e, toks + k, j - k);
            }
            req++;
            k = j;
        }
    }
    for (size_t k = 0; k < n; k++)
        free(toks[k].str);
    free(toks);
    dict_free(&e.requests);
    dict_free(&e.strings);
    dict_free(&e.seen);
    if (r != 0) {
        fprintf(stderr, "rib_encode: text it cannot tokenize near byte %zu\n", i);
        free(e.out.b);
        return NULL;
    }
    *out_len = e.out.n;
    return e.out.b;
}
