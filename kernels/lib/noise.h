/* noise.h — 3D gradient noise (Perlin 2002, "Improving Noise": quintic fade, gradients
 * (±1,±1,0), (±1,0,±1), (0,±1,±1)) with hashed lattice gradients instead of a permutation
 * table, and its interval extension: for a box of inputs, an interval that contains the
 * noise at every point of the box (Hanika §3.2-3.3: interval arithmetic on procedural noise
 * keeps every bounding box conservative). Shared by kernels and host. */
#ifndef TS_NOISE_H
#define TS_NOISE_H

#include "lib/shared_types.h"
#include "lib/rng.h"

#ifndef __OPENCL_C_VERSION__
#include <math.h>
#endif

/* |noise| <= NOISE_BOUND everywhere. The noise is a combination of the eight corner terms
 * g . (x - c) with the fade weights w_c >= 0 (sum 1), so |noise| <= B(x) = sum_c w_c
 * max_g |g . (x - c)| = sum_c w_c (sum of the two largest |x - c| components). B peaks at
 * 1.0363 over a 200^3 grid of the cell, and its gradient (at most about 8 per axis) adds at
 * most 0.035 between grid points: 1.1 is a proven bound (tools/noise_bound.c computes it). */
#define NOISE_BOUND 1.1f

typedef struct ts_interval {
    float lo, hi;
} ts_interval;

TS_INLINE float noise_fade(float t)
{
    return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f);
}

/* Gradient index 0..11 of lattice point (x, y, z). */
TS_INLINE ts_u32 noise_hash(ts_i32 x, ts_i32 y, ts_i32 z)
{
    ts_u32 h = rng_mix((ts_u32)x * 0x8da6b343u ^
                       rng_mix((ts_u32)y * 0xd8163841u ^ rng_mix((ts_u32)z * 0xcb1ab31fu)));
    return h % 12u;
}

/* Components of gradient h: two of them are ±1, one is 0. */
TS_INLINE void noise_gradient(ts_u32 h, float *gx, float *gy, float *gz)
{
    float a = (h & 1u) ? -1.0f : 1.0f, b = (h & 2u) ? -1.0f : 1.0f;
    ts_u32 axis = h >> 2; /* 0: (a,b,0), 1: (a,0,b), 2: (0,a,b) */
    *gx = axis == 2u ? 0.0f : a;
    *gy = axis == 0u ? b : axis == 2u ? a : 0.0f;
    *gz = axis == 0u ? 0.0f : b;
}

TS_INLINE float noise_lerp(float a, float b, float t)
{
    return a + t * (b - a);
}

/* Gradient noise at (x, y, z); |result| <= NOISE_BOUND. */
TS_INLINE float noise3(float x, float y, float z)
{
    float fx0 = floor(x), fy0 = floor(y), fz0 = floor(z);
    ts_i32 ix = (ts_i32)fx0, iy = (ts_i32)fy0, iz = (ts_i32)fz0;
    float fx = x - fx0, fy = y - fy0, fz = z - fz0;
    float c[8];
    for (int k = 0; k < 8; ++k) {
        ts_i32 dx = k & 1, dy = (k >> 1) & 1, dz = k >> 2;
        float gx, gy, gz;
        noise_gradient(noise_hash(ix + dx, iy + dy, iz + dz), &gx, &gy, &gz);
        c[k] = gx * (fx - (float)dx) + gy * (fy - (float)dy) + gz * (fz - (float)dz);
    }
    float u = noise_fade(fx), v = noise_fade(fy), w = noise_fade(fz);
    float x00 = noise_lerp(c[0], c[1], u), x10 = noise_lerp(c[2], c[3], u);
    float x01 = noise_lerp(c[4], c[5], u), x11 = noise_lerp(c[6], c[7], u);
    return noise_lerp(noise_lerp(x00, x10, v), noise_lerp(x01, x11, v), w);
}

/* lerp(a, b, t) over intervals, t in [t0, t1] within [0, 1]: the result is monotone in a
 * and b (weights are non-negative) and linear in t, so the ends are reached at t0 or t1. */
TS_INLINE ts_interval interval_lerp(ts_interval a, ts_interval b, float t0, float t1)
{
    float l0 = a.lo + t0 * (b.lo - a.lo), l1 = a.lo + t1 * (b.lo - a.lo);
    float h0 = a.hi + t0 * (b.hi - a.hi), h1 = a.hi + t1 * (b.hi - a.hi);
    ts_interval r = {fmin(l0, l1), fmax(h0, h1)};
    return r;
}

/* Noise over the box [lo, hi] lying within the single lattice cell (ix, iy, iz). */
TS_INLINE ts_interval noise3_cell_interval(ts_i32 ix, ts_i32 iy, ts_i32 iz, float lx, float ly,
                                           float lz, float hx, float hy, float hz)
{
    /* Local coordinates in [0, 1]. */
    float ax = lx - (float)ix, ay = ly - (float)iy, az = lz - (float)iz;
    float bx = hx - (float)ix, by = hy - (float)iy, bz = hz - (float)iz;
    ts_interval c[8];
    for (int k = 0; k < 8; ++k) {
        ts_i32 dx = k & 1, dy = (k >> 1) & 1, dz = k >> 2;
        float gx, gy, gz;
        noise_gradient(noise_hash(ix + dx, iy + dy, iz + dz), &gx, &gy, &gz);
        /* A linear function over a box: each term reaches its ends at the box's faces. */
        float px = gx * (ax - (float)dx), qx = gx * (bx - (float)dx);
        float py = gy * (ay - (float)dy), qy = gy * (by - (float)dy);
        float pz = gz * (az - (float)dz), qz = gz * (bz - (float)dz);
        c[k].lo = fmin(px, qx) + fmin(py, qy) + fmin(pz, qz);
        c[k].hi = fmax(px, qx) + fmax(py, qy) + fmax(pz, qz);
    }
    float u0 = noise_fade(ax), u1 = noise_fade(bx);
    float v0 = noise_fade(ay), v1 = noise_fade(by);
    float w0 = noise_fade(az), w1 = noise_fade(bz);
    ts_interval x00 = interval_lerp(c[0], c[1], u0, u1), x10 = interval_lerp(c[2], c[3], u0, u1);
    ts_interval x01 = interval_lerp(c[4], c[5], u0, u1), x11 = interval_lerp(c[6], c[7], u0, u1);
    return interval_lerp(interval_lerp(x00, x10, v0, v1), interval_lerp(x01, x11, v0, v1), w0, w1);
}

/* An interval holding noise3 over the box [lo, hi]: exact cell by cell where the box spans
 * at most two cells per axis (up to 8 sub-boxes), else [-NOISE_BOUND, NOISE_BOUND].
 * Widened by 1e-5 to cover the rounding of the point evaluation. */
TS_INLINE ts_interval noise3_interval(float lx, float ly, float lz, float hx, float hy, float hz)
{
    ts_interval full = {-NOISE_BOUND, NOISE_BOUND};
    float cx0 = floor(lx), cy0 = floor(ly), cz0 = floor(lz);
    float cx1 = floor(hx), cy1 = floor(hy), cz1 = floor(hz);
    if (!(cx1 - cx0 <= 1.0f && cy1 - cy0 <= 1.0f && cz1 - cz0 <= 1.0f)) return full;
    if (fabs(cx0) > 1e6f || fabs(cy0) > 1e6f || fabs(cz0) > 1e6f) return full;
    ts_interval r = {INFINITY, -INFINITY};
    for (int k = 0; k < 8; ++k) {
        float cx = cx0 + (float)(k & 1), cy = cy0 + (float)((k >> 1) & 1),
              cz = cz0 + (float)(k >> 2);
        if (cx > cx1 || cy > cy1 || cz > cz1) continue;
        /* The part of the box inside cell (cx, cy, cz). */
        ts_interval s = noise3_cell_interval((ts_i32)cx, (ts_i32)cy, (ts_i32)cz, fmax(lx, cx),
                                             fmax(ly, cy), fmax(lz, cz), fmin(hx, cx + 1.0f),
                                             fmin(hy, cy + 1.0f), fmin(hz, cz + 1.0f));
        r.lo = fmin(r.lo, s.lo);
        r.hi = fmax(r.hi, s.hi);
    }
    r.lo = fmax(r.lo - 1e-5f, -NOISE_BOUND);
    r.hi = fmin(r.hi + 1e-5f, NOISE_BOUND);
    return r;
}

#endif
