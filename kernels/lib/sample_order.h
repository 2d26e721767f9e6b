/* sample_order.h — the order in which a frame's samples are traced (docs/rendering.md
 * "Sample order"). Shared by the kernels (camera, shade, film) and the host (units, resume).
 *
 * A frame has P pixels and S samples a pixel: P * S samples, numbered k = 0 .. P * S - 1 in
 * the order they are traced (waves, units and --resume count in k). The image is cut into
 * bands of B consecutive pixels (whole rows; B >= P, or 0: one band, the whole image). Band
 * b holds pixels [b B, b B + n_b), n_b = min(B, P - b B), and the samples
 * [b B S, (b B + n_b) S), sample after sample:
 *
 *     k = b B S + s n_b + (p - b B)      for pixel p of band b and sample s < S.
 *
 * With one band this is pass after pass (k = s P + p). Smaller bands finish every sample of
 * a few rows before the next rows start, so that consecutive waves need the same patches
 * and the patch cache keeps them (Hanika §3.6's argument for coherent batches, PantaRay's
 * batches in screen order): when the frame's patches do not fit the cache, pass-major order
 * dices every visible patch again in every pass.
 *
 * A pixel's samples come in sample order whatever B is, and the film adds them in that
 * order, so the image does not depend on B bit for bit. */
#ifndef TS_SAMPLE_ORDER_H
#define TS_SAMPLE_ORDER_H

#include "lib/sampler.h"
#include "lib/shared_types.h"
#include "lib/udiv.h"

/* The pixel (*pixel) and its sample (*sample) of the frame's k-th sample: npix pixels, spp
 * samples a pixel, bands of band pixels (0: one band). */
TS_INLINE void sample_order_at(ts_u32 k, ts_u32 npix, ts_u32 spp, ts_u32 band, ts_u32 *pixel,
                               ts_u32 *sample)
{
    if (band == 0u || band > npix) band = npix;
    ts_u32 b = k / band / spp; /* band * spp <= npix * spp fits: the frame's sample count */
    ts_u32 base = b * band, n = npix - base < band ? npix - base : band;
    ts_u32 r = k - base * spp;
    *sample = r / n;
    *pixel = base + r % n;
}

#ifndef __OPENCL_C_VERSION__
/* The order of a frame of npix pixels (width a row), spp samples a pixel and bands of band
 * pixels (0: one band) with its divisions made ready, for the kernels' sample_order_at_ready. */
TS_INLINE ts_order_divs sample_order_divs(ts_u32 npix, ts_u32 width, ts_u32 spp, ts_u32 band)
{
    if (band == 0u || band > npix) band = npix;
    ts_u32 last_first = (npix - 1u) / band * band;
    ts_order_divs o = {udiv_make(band * spp),
                       udiv_make(band),
                       udiv_make(npix - last_first),
                       udiv_make(width),
                       sampler_mask(spp),
                       npix,
                       {0u, 0u}};
    return o;
}
#endif

/* sample_order_at with the order's divisions made ready (sample_order_divs): the same
 * pixel and sample for every k of the frame. */
TS_INLINE void sample_order_at_ready(ts_u32 k, ts_order_divs o, ts_u32 *pixel, ts_u32 *sample)
{
    ts_u32 b = udiv(k, o.band_samples);
    ts_u32 base = b * o.band.d, r = k - b * o.band_samples.d;
    ts_udiv n = o.npix - base < o.band.d ? o.last : o.band;
    ts_u32 s = udiv(r, n);
    *sample = s;
    *pixel = base + (r - s * n.d);
}

#ifdef __OPENCL_C_VERSION__
/* sample_order_at_ready for eight samples k in the lanes of a uint8 (camera.cl on CPU
 * devices), each lane the scalar operations: the same pixels and samples. */
inline void sample_order_at_ready_x8(uint8 k, ts_order_divs o, uint8 *pixel, uint8 *sample)
{
    uint8 b = udiv_x8(k, o.band_samples);
    uint8 base = b * o.band.d, r = k - b * o.band_samples.d;
    int8 last = convert_int8((uint8)(o.npix) - base < (uint8)(o.band.d));
    uint8 mul = select((uint8)(o.band.mul), (uint8)(o.last.mul), last);
    uint8 sh1 = select((uint8)(o.band.sh1), (uint8)(o.last.sh1), last);
    uint8 sh2 = select((uint8)(o.band.sh2), (uint8)(o.last.sh2), last);
    uint8 d = select((uint8)(o.band.d), (uint8)(o.last.d), last);
    uint8 s = udiv_lanes(r, mul, sh1, sh2);
    *sample = s;
    *pixel = base + (r - s * d);
}
#endif

/* Pixels [*first, *end) hold every pixel with a sample among the frame's samples
 * [k, k + count), count >= 1: the bands those samples fall in (the whole image with one
 * band). */
TS_INLINE void sample_order_pixels(ts_u32 k, ts_u32 count, ts_u32 npix, ts_u32 spp, ts_u32 band,
                                   ts_u32 *first, ts_u32 *end)
{
    if (band == 0u || band > npix) band = npix;
    ts_u32 b0 = k / band / spp, b1 = (k + count - 1u) / band / spp;
    *first = b0 * band;
    *end = npix - b1 * band <= band ? npix : (b1 + 1u) * band;
}

/* The inverse: the index k of sample `sample` of pixel `pixel`. */
TS_INLINE ts_u32 sample_order_index(ts_u32 pixel, ts_u32 sample, ts_u32 npix, ts_u32 spp,
                                    ts_u32 band)
{
    if (band == 0u || band > npix) band = npix;
    ts_u32 base = pixel / band * band, n = npix - base < band ? npix - base : band;
    return base * spp + sample * n + (pixel - base);
}

/* How many of pixel's samples are among the first `done` of the frame (done <= npix * spp). */
TS_INLINE ts_u32 sample_order_count(ts_u32 pixel, ts_u32 done, ts_u32 npix, ts_u32 spp, ts_u32 band)
{
    if (band == 0u || band > npix) band = npix;
    ts_u32 base = pixel / band * band, n = npix - base < band ? npix - base : band;
    ts_u32 first = base * spp + (pixel - base); /* its sample 0 */
    if (done <= first) return 0u;
    ts_u32 c = (done - first - 1u) / n + 1u;
    return c < spp ? c : spp;
}

#endif
