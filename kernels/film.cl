/* film.cl — stage `film`: adds a wave's samples into the image.
 * Reads:  radiance and aov of the wave's rays (ray r is global sample first_sample + r:
 *         pixel g % pixel_count, sample g / pixel_count, see camera.cl).
 * Writes: accum[pixel] += radiance of each of its samples in this wave, in sample order (a
 *         fixed summation order: the image does not depend on how samples were split into
 *         waves); aov_film[pixel] and albedo_film[pixel] = the aov and albedo of sample 0.
 * One work-item per pixel, so no two items write the same pixel. */
#include "lib/shared_types.h"

__kernel void film_accumulate(uint first_sample, uint ray_count, uint pixel_count,
                              __global const ts_vec4 *radiance, __global const ts_vec4 *aov,
                              __global const ts_vec4 *albedo, __global ts_vec4 *accum,
                              __global ts_vec4 *aov_film, __global ts_vec4 *albedo_film)
{
    uint p = get_global_id(0);
    if (p >= pixel_count) return;
    uint first = first_sample, last = first_sample + ray_count; /* [first, last) */
    uint s = first / pixel_count;
    if (s * pixel_count + p < first) ++s;
    ts_vec4 acc = accum[p];
    for (uint g = s * pixel_count + p; g < last; g += pixel_count) {
        ts_vec4 r = radiance[g - first];
        acc.x += r.x;
        acc.y += r.y;
        acc.z += r.z;
        acc.w += 1.0f;
        if (g < pixel_count) aov_film[p] = aov[g - first], albedo_film[p] = albedo[g - first];
    }
    accum[p] = acc;
}
