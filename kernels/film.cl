/* film.cl — stage `film`: adds a wave's samples into the image.
 * Reads:  radiance and aov of the wave's rays (ray r is the frame's sample first_sample + r
 *         in the sample order, lib/sample_order.h; see camera.cl).
 * Writes: accum[pixel] += radiance of each of its samples in this wave, in sample order (a
 *         fixed summation order: the image does not depend on how samples were split into
 *         waves, nor on the order's bands); aov_film[pixel] and albedo_film[pixel] = the aov
 *         and albedo of sample 0.
 * One work-item per pixel of [pixel_first, pixel_end), the bands the wave's samples fall in
 * (sample_order_pixels; no other pixel has a sample in it), so no two items write the same
 * pixel. */
#include "lib/shared_types.h"
#include "lib/sample_order.h"

__kernel void film_accumulate(uint first_sample, uint ray_count, uint pixel_count, uint spp,
                              uint band, uint pixel_first, uint pixel_end,
                              __global const ts_vec4 *radiance, __global const ts_vec4 *aov,
                              __global const ts_vec4 *albedo, __global ts_vec4 *accum,
                              __global ts_vec4 *aov_film, __global ts_vec4 *albedo_film)
{
    uint p = pixel_first + get_global_id(0);
    if (p >= pixel_end) return;
    uint first = first_sample, last = first_sample + ray_count; /* [first, last) */
    /* The pixel's samples s < spp are k = k0 + s * n (lib/sample_order.h). */
    uint k0 = sample_order_index(p, 0u, pixel_count, spp, band);
    uint n = spp > 1u ? sample_order_index(p, 1u, pixel_count, spp, band) - k0 : 1u;
    uint s = sample_order_count(p, first, pixel_count, spp, band);
    if (s >= spp) return;
    ts_vec4 acc = accum[p];
    int changed = 0;
    for (uint k = k0 + s * n; s < spp && k < last; ++s, k += n) {
        ts_vec4 r = radiance[k - first];
        acc.x += r.x;
        acc.y += r.y;
        acc.z += r.z;
        acc.w += 1.0f;
        changed = 1;
        if (s == 0u) aov_film[p] = aov[k - first], albedo_film[p] = albedo[k - first];
    }
    if (changed) accum[p] = acc;
}
