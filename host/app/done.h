/* done.h — which of a frame's samples a film holds (docs/rendering.md "Interrupting and
 * resuming"): the frame's sample order and sets of runs of it, for the units that several
 * devices and ranks trace (units.h) and the partial images --resume continues (resume.h). */
#ifndef TS_DONE_H
#define TS_DONE_H

#include "base/error.h"
#include "lib/shared_types.h"

#include <stddef.h>
#include <stdint.h>

/* The frame's sample order (kernels/lib/sample_order.h): its pixels, samples a pixel and
 * pixels a band (0: one band). */
typedef struct ts_sample_order {
    uint32_t pixels, spp, band;
} ts_sample_order;

/* The order of the frame a camera's parameters describe. */
ts_sample_order sample_order_of(const ts_camera_params *cam);

/* The bands for an image of width x height pixels at spp samples a pixel, about
 * `band_samples` samples each: whole rows, at least one; 0 (one band) when a band would
 * hold the whole image. TESSERA_SAMPLE_BAND_ROWS=N sets the rows (a testing aid: the image
 * does not depend on it; 0 gives one band, pass after pass). */
uint32_t sample_order_band(uint32_t width, uint32_t height, uint32_t spp, uint64_t band_samples);
/* One device's order: pixel after pixel, each pixel's samples one after another (a band of
 * one pixel: k = p S + s), so the rays of a wave that meet the same micro-quads are traced
 * together (docs/rendering.md "The sample order"); TESSERA_SAMPLE_BAND_ROWS still sets
 * bands of rows (sample_order_band). 0 (one band) for a one-pixel image. */
uint32_t sample_order_band_pixel(uint32_t width, uint32_t height, uint32_t spp);

/* The samples 0 of their pixels among the samples [first, first + count) of the order o:
 * the next run of them at or after `first`, [*k0, *k1) clipped to the range. 0 when there is
 * none. */
int sample_order_zero_run(const ts_sample_order *o, uint64_t first, uint64_t count, uint64_t *k0,
                          uint64_t *k1);
/* How many samples 0 of their pixels [first, first + count) holds. */
uint64_t sample_order_zero_count(const ts_sample_order *o, uint64_t first, uint64_t count);

/* The pixels of a whole band of o (its band, or every pixel for one band). */
static inline uint64_t sample_order_band_pixels(const ts_sample_order *o)
{
    return o->band && o->band < o->pixels ? o->band : o->pixels;
}

/* Band b of the order o: its samples [*first, *end) and its samples 0 [*first, *zero_end)
 * (the band's pixels are the n = *zero_end - *first from pixel *first / spp). 0 when the
 * frame has no band b. */
int sample_order_band_runs(const ts_sample_order *o, uint64_t b, uint64_t *first, uint64_t *end,
                           uint64_t *zero_end);

/* A run of the frame's samples [first, end) in its order. */
typedef struct ts_sample_range {
    uint64_t first, end;
} ts_sample_range;

/* The samples a film holds: sorted, disjoint, not adjacent ranges of the order. Within
 * every band of the order they are a prefix of the band's samples (what any mix of
 * interrupted one-device runs, which trace a prefix, and several-device runs, which trace
 * whole bands, leaves), so what is left of a band is one run and the bands' runs have no
 * pixel in common: they can be traced and merged in any order, bit for bit. */
typedef struct ts_done {
    ts_sample_range *r;
    uint32_t count, capacity;
} ts_done;

/* Adds [first, end) (merging it with its neighbours). TS_E_MEMORY when it cannot. */
int done_add(ts_done *d, uint64_t first, uint64_t end, ts_error *err);
/* The samples d holds. */
uint64_t done_samples(const ts_done *d);
/* 1 when d is [0, n) for some n (or empty). */
int done_is_prefix(const ts_done *d);
/* How many samples of pixel `pixel` d holds in the order o. */
uint32_t done_pixel_count(const ts_done *d, const ts_sample_order *o, uint32_t pixel);
/* d as text ("first-end first-end ...", half-open, decimal) into buf; 0 when it does not fit. */
int done_format(const ts_done *d, char *buf, size_t size);
/* Parses done_format's text of a frame of `total` samples in the order o into *d (empty
 * before); TS_E_USAGE when it is not such text or breaks the band rule above. */
int done_parse(const char *text, const ts_sample_order *o, uint64_t total, ts_done *d,
               ts_error *err);
void done_free(ts_done *d);

#endif
