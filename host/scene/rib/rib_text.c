/* rib_text.c — a RIB file's bytes made ready for the lexer (rib_text.h): gzip data inflated
 * with zlib (RFC 1952; members one after another, as `cat a.gz b.gz` makes, are read in
 * turn), at most RIB_MAX_INFLATED bytes; a UTF-8 byte order mark skipped. Producers of
 * compressed RIB (PRMan's "-binary -gzip", Houdini, catrib) write plain gzip. */
#include "scene/rib/rib_text.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

/* First inflate buffer: 64 KiB, doubled as needed. */
#define RIB_INFLATE_FIRST ((size_t)1 << 16)

static int rib_is_gzip(const char *raw, size_t len)
{
    return len >= 2 && (unsigned char)raw[0] == 0x1f && (unsigned char)raw[1] == 0x8b;
}

static int rib_gzip_error(const char *name, ts_error *err, const char *what, const char *why)
{
    return ts_error_set(err, TS_E_SCENE, "%s:1:1: error: gzip: %s%s%s%s", name, what,
                        why ? " (zlib: " : "", why ? why : "", why ? ")" : "");
}

/* Doubles *cap (up to RIB_MAX_INFLATED) and regrows *buf; 0 with err set when it cannot. */
static int rib_inflate_grow(char **buf, size_t *cap, const char *name, ts_error *err)
{
    if (*cap >= RIB_MAX_INFLATED) {
        rib_gzip_error(name, err, "the file inflates to more than 1024 MiB", NULL);
        return 0;
    }
    size_t c = *cap ? *cap * 2 : RIB_INFLATE_FIRST;
    if (c > RIB_MAX_INFLATED) c = RIB_MAX_INFLATED;
    char *b = realloc(*buf, c + 1); /* + 1: a NUL after the text, as files have */
    if (!b) {
        ts_error_set(err, TS_E_MEMORY, "%s: out of memory inflating gzip data", name);
        return 0;
    }
    *buf = b;
    *cap = c;
    return 1;
}

/* Inflates every gzip member of raw into a malloc'd buffer. */
static int rib_inflate(const char *name, const char *raw, size_t len, char **out, size_t *out_len,
                       ts_error *err)
{
    z_stream zs;
    memset(&zs, 0, sizeof zs);
    if (inflateInit2(&zs, 16 + MAX_WBITS) != Z_OK) /* 16: gzip header and trailer */
        return rib_gzip_error(name, err, "cannot start zlib", zs.msg);
    char *buf = NULL;
    size_t cap = 0, n = 0, in = 0;
    int rc = TS_OK;
    while (rc == TS_OK) {
        if (n == cap && !rib_inflate_grow(&buf, &cap, name, err)) {
            rc = err->code;
            break;
        }
        size_t chunk_in = len - in > UINT32_MAX ? UINT32_MAX : len - in;
        zs.next_in = (Bytef *)(uintptr_t)(raw + in);
        zs.avail_in = (uInt)chunk_in;
        zs.next_out = (Bytef *)(buf + n);
        zs.avail_out = (uInt)(cap - n);
        int z = inflate(&zs, Z_NO_FLUSH);
        in += chunk_in - zs.avail_in;
        n = cap - zs.avail_out;
        if (z == Z_STREAM_END) {
            if (in == len) break;
            if (!rib_is_gzip(raw + in, len - in)) {
                rc = rib_gzip_error(name, err, "data that is not gzip follows the compressed data",
                                    NULL);
                break;
            }
            inflateReset(&zs); /* the next member */
        } else if (z == Z_BUF_ERROR && in == len && zs.avail_out > 0) {
            rc = rib_gzip_error(name, err, "the compressed data ends early (a truncated file)",
                                NULL);
        } else if (z != Z_OK && z != Z_BUF_ERROR) {
            rc = rib_gzip_error(name, err, "the compressed data is damaged", zs.msg);
        }
    }
    inflateEnd(&zs);
    if (rc != TS_OK) {
        free(buf);
        return rc;
    }
    buf[n] = '\0';
    *out = buf;
    *out_len = n;
    return TS_OK;
}

int rib_text_open(rib_text *t, const char *name, const char *raw, size_t len, ts_error *err)
{
    memset(t, 0, sizeof *t);
    t->text = raw;
    t->len = raw ? len : 0;
    if (rib_is_gzip(t->text, t->len)) {
        int rc = rib_inflate(name, raw, len, &t->owned, &t->len, err);
        if (rc != TS_OK) {
            memset(t, 0, sizeof *t);
            return rc;
        }
        t->text = t->owned;
        t->gzip = 1;
    }
    /* A UTF-8 byte order mark (EF BB BF), which some editors write: not part of the RIB. */
    if (t->len >= 3 && (unsigned char)t->text[0] == 0xef && (unsigned char)t->text[1] == 0xbb &&
        (unsigned char)t->text[2] == 0xbf)
        t->text += 3, t->len -= 3;
    return TS_OK;
}

void rib_text_free(rib_text *t)
{
    free(t->owned);
    memset(t, 0, sizeof *t);
}
