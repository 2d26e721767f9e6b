/* resolve.cl — stage `resolve` (Hanika §3.1): folds each active ray's candidate hits of this
 * iteration into its closest hit and says whether the ray goes on.
 * Reads:  count[i], pair_hit[i*n_per_ray .. +count[i]) (in front-to-back emission order;
 *         from window_first[i] when n_per_ray is 0: top_level's water-filled windows),
 *         entry (TS_INVALID = no further top-level candidates).
 * Writes: hit[ray] (closest so far; later iterations cull against it), alive[i]; a shadow
 *         ray (TS_RAY_SHADOW) retires at its first hit: it only asks whether anything is
 *         in the way.
 * Ties keep the earlier hit (earlier iteration, then earlier candidate), so the result is
 * independent of how pairs were batched. */
#include "lib/shared_types.h"

__kernel void resolve_closest(__global const uint *active, uint active_count, uint n_per_ray,
                              __global const uint *window_first, __global const uint *count,
                              __global const ts_hit *pair_hit, __global ts_hit *hit,
                              __global const uint *entry, __global const uint *flags,
                              __global uint *alive)
{
    uint i = get_global_id(0);
    if (i >= active_count) return;
    uint ray = active[i];
    ts_hit best = hit[ray];
    uint n = count[i], base = n_per_ray ? i * n_per_ray : window_first[i];
    for (uint k = 0; k < n; ++k) {
        ts_hit h = pair_hit[base + k];
        if (h.t < best.t) best = h;
    }
    hit[ray] = best;
    int occluded = (flags[ray] & TS_RAY_SHADOW) && best.patch != TS_INVALID;
    alive[i] = entry[ray] != TS_INVALID && !occluded ? 1u : 0u;
}
