/* rng.h — counter-based random numbers: a pure function of (pixel, sample, bounce,
 * dimension, seed), so an image does not depend on thread count, batch sizes or memory
 * budget (DESIGN.md §3). Hash: the "lowbias32" integer mix (Wellons 2018) chained over the
 * key words. */
#ifndef TS_RNG_H
#define TS_RNG_H

#include "lib/shared_types.h"

/* The lowbias32 steps on the lvalue x: a ts_u32, or in kernels a vector of them
 * (lib/noise4.h). */
#define TS_LOWBIAS32(x)                                                                            \
    ((x) ^= (x) >> 16, (x) *= 0x7feb352du, (x) ^= (x) >> 15, (x) *= 0x846ca68bu, (x) ^= (x) >> 16)

TS_INLINE ts_u32 rng_mix(ts_u32 x)
{
    TS_LOWBIAS32(x);
    return x;
}

/* Uniform float in [0, 1) with 24 random bits. */
TS_INLINE float rng_uniform(ts_u32 pixel, ts_u32 sample, ts_u32 bounce, ts_u32 dim, ts_u32 seed)
{
    ts_u32 h = rng_mix(seed ^ 0x9e3779b9u);
    h = rng_mix(h ^ pixel);
    h = rng_mix(h ^ sample);
    h = rng_mix(h ^ (bounce * 0x10000u + dim));
    return (float)(h >> 8) * (1.0f / 16777216.0f);
}

#endif
