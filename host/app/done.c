/* done.c — which of a frame's samples a film holds (done.h). */
#include "app/done.h"
#include "lib/sample_order.h"

#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

ts_sample_order sample_order_of(const ts_camera_params *cam)
{
    return (ts_sample_order){cam->width * cam->height, cam->spp ? cam->spp : 1u, cam->band};
}

int done_add(ts_done *d, uint64_t first, uint64_t end, ts_error *err)
{
    if (first >= end) return TS_OK;
    uint32_t i = 0;
    while (i < d->count && d->r[i].end < first)
        ++i;
    /* Ranges i .. j - 1 touch or overlap [first, end): they become one. */
    uint32_t j = i;
    while (j < d->count && d->r[j].first <= end) {
        if (d->r[j].first < first) first = d->r[j].first;
        if (d->r[j].end > end) end = d->r[j].end;
        ++j;
    }
    if (j == i) { /* a new range at i */
        if (d->count == d->capacity) {
            uint32_t cap = d->capacity ? 2 * d->capacity : 8;
            ts_sample_range *r = realloc(d->r, cap * sizeof *r);
            if (!r) return ts_error_set(err, TS_E_MEMORY, "out of memory");
            d->r = r, d->capacity = cap;
        }
        memmove(&d->r[i + 1], &d->r[i], (d->count - i) * sizeof *d->r);
        d->count++;
    } else if (j > i + 1) {
        memmove(&d->r[i + 1], &d->r[j], (d->count - j) * sizeof *d->r);
        d->count -= j - i - 1;
    }
    d->r[i] = (ts_sample_range){first, end};
    return TS_OK;
}

uint64_t done_samples(const ts_done *d)
{
    uint64_t n = 0;
    for (uint32_t i = 0; i < d->count; ++i)
        n += d->r[i].end - d->r[i].first;
    return n;
}

int done_is_prefix(const ts_done *d)
{
    return d->count == 0 || (d->count == 1 && d->r[0].first == 0);
}

uint32_t done_pixel_count(const ts_done *d, const ts_sample_order *o, uint32_t pixel)
{
    uint32_t n = 0;
    for (uint32_t i = 0; i < d->count; ++i)
        n += sample_order_count(pixel, (uint32_t)d->r[i].end, o->pixels, o->spp, o->band) -
             sample_order_count(pixel, (uint32_t)d->r[i].first, o->pixels, o->spp, o->band);
    return n;
}

int done_format(const ts_done *d, char *buf, size_t size)
{
    size_t used = 0;
    if (size) buf[0] = '\0';
    for (uint32_t i = 0; i < d->count; ++i) {
        int k = snprintf(buf + used, size - used, "%s%" PRIu64 "-%" PRIu64, i ? " " : "",
                         d->r[i].first, d->r[i].end);
        if (k < 0 || (size_t)k >= size - used) return 0;
        used += (size_t)k;
    }
    return 1;
}

uint32_t sample_order_band(uint32_t width, uint32_t height, uint32_t spp, uint64_t band_samples)
{
    uint64_t row = (uint64_t)width * (spp ? spp : 1u), rows = band_samples / row;
    const char *env = getenv("TESSERA_SAMPLE_BAND_ROWS");
    if (env && *env) {
        char *end;
        errno = 0;
        unsigned long long v = strtoull(env, &end, 10);
        if (!errno && !*end) rows = v ? v : height;
    }
    if (rows < 1) rows = 1;
    return rows >= height ? 0u : (uint32_t)rows * width;
}

uint32_t sample_order_band_pixel(uint32_t width, uint32_t height, uint32_t spp)
{
    const char *env = getenv("TESSERA_SAMPLE_BAND_ROWS");
    if (env && *env) return sample_order_band(width, height, spp, 0);
    return (uint64_t)width * height > 1u ? 1u : 0u;
}

int sample_order_band_runs(const ts_sample_order *o, uint64_t b, uint64_t *first, uint64_t *end,
                           uint64_t *zero_end)
{
    uint64_t band = sample_order_band_pixels(o);
    uint64_t base = b * band;
    if (base >= o->pixels) return 0;
    uint64_t n = o->pixels - base < band ? o->pixels - base : band;
    *first = base * o->spp, *end = (base + n) * o->spp, *zero_end = *first + n;
    return 1;
}

int sample_order_zero_run(const ts_sample_order *o, uint64_t first, uint64_t count, uint64_t *k0,
                          uint64_t *k1)
{
    uint64_t band = sample_order_band_pixels(o);
    uint64_t end = first + count, z0, z1, band_end;
    for (uint64_t b = first / (band * o->spp); sample_order_band_runs(o, b, &z0, &band_end, &z1);
         ++b) {
        if (z0 >= end) return 0;
        if (z1 > first) {
            *k0 = z0 > first ? z0 : first;
            *k1 = z1 < end ? z1 : end;
            return 1;
        }
    }
    return 0;
}

uint64_t sample_order_zero_count(const ts_sample_order *o, uint64_t first, uint64_t count)
{
    uint64_t n = 0, k0, k1, end = first + count;
    for (uint64_t k = first; k < end && sample_order_zero_run(o, k, end - k, &k0, &k1); k = k1)
        n += k1 - k0;
    return n;
}

int done_parse(const char *text, const ts_sample_order *o, uint64_t total, ts_done *d,
               ts_error *err)
{
    const char *s = text;
    uint64_t last = 0;
    while (*s) {
        char *e1, *e2;
        errno = 0;
        unsigned long long a = strtoull(s, &e1, 10);
        if (e1 == s || *e1 != '-') goto bad;
        unsigned long long b = strtoull(e1 + 1, &e2, 10);
        if (errno || e2 == e1 + 1 || (*e2 && *e2 != ' ') || a >= b || b > total ||
            (d->count && a <= last))
            goto bad;
        /* The band rule: every run starts where a band starts; then each band holds a
         * prefix of its samples (a run ending inside a band is followed by none before the
         * next band). */
        uint64_t band = sample_order_band_pixels(o), bf, be, bz;
        if (!sample_order_band_runs(o, a / (band * o->spp), &bf, &be, &bz) || a != bf) goto bad;
        if (done_add(d, a, b, err)) return err->code;
        last = b;
        s = *e2 ? e2 + 1 : e2;
    }
    return TS_OK;
bad:
    done_free(d);
    return ts_error_set(err, TS_E_USAGE, "not a list of runs of whole or leading band samples");
}

void done_free(ts_done *d)
{
    free(d->r);
    memset(d, 0, sizeof *d);
}
