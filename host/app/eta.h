/* eta.h — the progress line's estimate of the time left (issue 38 item 6, issue 41 item 4).
 *
 * Samples do not cost the same: a sky pixel's path ends at once, a forest pixel's crosses
 * dozens of patch boxes and bounces. The lod stage traces every pixel's first eye ray
 * through the top level before any wave (kernels/lod.cl) and counts the leaf boxes it
 * crosses; a sample of pixel p is then weighed 1 + TS_ETA_PER_CROSSING x crossings(p)
 * (pipeline.h pixel_cost holds 1 + crossings), and
 * the frame's progress is the weight of the samples finished over the weight of all of them,
 * in the frame's sample order (kernels/lib/sample_order.h). The time left is the weight left
 * at the rate measured so far (weight finished per second). Without the lod stage (a fixed
 * --lod) every pixel weighs 1: samples finished over samples, as before. */
#ifndef TS_ETA_H
#define TS_ETA_H

#include "base/error.h"

#include <stdint.h>
#include <stdio.h>

/* A crossing's weight against a sample's own: a sample whose eye ray crosses no patch box
 * (sky) ends at once, one that crosses some is traced, shaded and bounced. forest-100 at
 * 640x256 x 16 on PoCL: the sky's samples took 0.07 us, the forest's 26 us at 20-50
 * crossings, so a crossing weighs 16 samples' own work (with 1, the estimate at a quarter of
 * that frame, all sky, said 2 s of 55). */
#define TS_ETA_PER_CROSSING 16u

typedef struct ts_eta {
    uint64_t *prefix; /* prefix[p]: the weight of pixels [0, p), npix + 1 entries */
    uint32_t npix, spp, band;
} ts_eta;

/* The weight of a sample of a pixel whose pixel_cost is cost (>= 1). */
uint64_t eta_weight(uint32_t cost);
/* The weights of npix pixels from cost[] (0: not counted, weighs the mean of those counted;
 * NULL: all 1), spp samples a pixel, bands of band pixels (0: one band). */
int eta_init(ts_eta *e, const uint32_t *cost, uint32_t npix, uint32_t spp, uint32_t band,
             ts_error *err);
void eta_free(ts_eta *e);
/* The weight of the frame's samples [0, k) in its sample order. */
double eta_work(const ts_eta *e, uint64_t k);
/* The seconds left when the samples of weight `done` took `seconds` and [start, total) is the
 * frame's part to trace; -1 while nothing is done. */
double eta_seconds_left(const ts_eta *e, double done, double seconds, uint64_t start,
                        uint64_t total);

/* Prints the progress line on stderr (\r, no newline): samples finished of total, the
 * share `done` of the weight of [start, total), rays per second over `seconds`, and the time
 * left, or "ETA after the first <what>" while nothing is done. */
void eta_print(const ts_eta *e, uint64_t samples, uint64_t start, uint64_t total, double done,
               double rays, double seconds, const char *what);

#endif
