/* rib_text.h — the bytes of a RIB file as the lexer reads them, private to the RIB reader
 * (rib.c for the top-level file, rib_archive.c for archives): gzip data (found by its
 * content, the magic bytes 1f 8b of RFC 1952, whatever the file is called) is inflated, and
 * a UTF-8 byte order mark at the start is skipped. Everything else goes to the lexer as it
 * is: the lexer reads ASCII and binary RIB alike. */
#ifndef TS_RIB_TEXT_H
#define TS_RIB_TEXT_H

#include "base/error.h"

#include <stddef.h>

/* Largest inflated size of a gzip RIB file: 1 GiB, so that a small hostile file (deflate
 * reaches about 1000:1) cannot take all memory. */
#define RIB_MAX_INFLATED ((size_t)1 << 30)

typedef struct rib_text {
    const char *text; /* what the lexer reads: into the caller's bytes or into owned */
    size_t len;
    int gzip;    /* the bytes were gzip data */
    char *owned; /* the inflated bytes, NULL when the input was used as it is */
} rib_text;

/* Prepares len bytes of raw (a file's contents; name for messages) for the lexer. Fails
 * with TS_E_SCENE "name:1:1: error: gzip: ..." for damaged, truncated or oversized gzip
 * data, TS_E_MEMORY when out of memory; t is then empty. raw must outlive t. */
int rib_text_open(rib_text *t, const char *name, const char *raw, size_t len, ts_error *err);
void rib_text_free(rib_text *t);

#endif
