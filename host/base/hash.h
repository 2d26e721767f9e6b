/* hash.h — 64-bit FNV-1a, for keys that identify content (the kernel binary cache, the
 * render job that --resume checks). Not for hash tables under attack. */
#ifndef TS_HASH_H
#define TS_HASH_H

#include <stddef.h>
#include <stdint.h>

#define TS_FNV1A_INIT 0xcbf29ce484222325ull

/* Folds n bytes of data into h (start from TS_FNV1A_INIT). */
static inline uint64_t ts_fnv1a(uint64_t h, const void *data, size_t n)
{
    const unsigned char *b = data;
    for (size_t i = 0; i < n; ++i)
        h = (h ^ b[i]) * 0x100000001b3ull;
    return h;
}

#endif
