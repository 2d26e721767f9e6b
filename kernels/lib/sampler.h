/* sampler.h — the sample values of a path (DESIGN.md §3, issue 14): Owen-scrambled Sobol
 * points after Burley 2020 ("Practical Hash-based Owen Scrambling", JCGT 9(4)), the scheme
 * Cycles calls Sobol-Burley. Shared by the kernels and the host tests.
 *
 * Dimensions come in sets of four: a set is one 4-D Sobol sequence (Joe-Kuo direction
 * numbers for dimensions 2-4 after van der Corput), so the four values one decision uses
 * are stratified together. For pixel p, sample s and set k:
 *   seed_k   = hash(seed, p, k): per pixel and set, so pixels and sets are decorrelated;
 *   index    = Owen(s, seed_k) & mask: a nested uniform scramble of the sample index (most
 *              significant bit first, so the bits above 2^j stay fixed for s < 2^j while
 *              the bits below are permuted), masked to the next power of two >= spp: the
 *              first 2^j samples of a pixel are an aligned block of 2^j Sobol points, so
 *              every power-of-two prefix keeps their stratification, in an order of its own
 *              per pixel and set;
 *   value_d  = Owen(sobol_d(index), hash(seed_k, d)): each dimension Owen-scrambled (the
 *              same permutation on the reversed value bits), which keeps the points a
 *              (0, m, 2)-net in dimensions 0-1 and stratified in each dimension alone.
 * Everything is a pure function of (pixel, sample, set, seed, spp): the image does not
 * depend on thread counts, --memory, resume, devices or ranks.
 * Sets (docs/rendering.md "Samples"): 0 camera (pixel x, y, time), then per path vertex b
 * (b = 0 at the eye ray's hit): 1 + 2b light (choice, two for the point, one spare),
 * 2 + 2b BSDF (lobe, two for the direction, Russian roulette). */
#ifndef TS_SAMPLER_H
#define TS_SAMPLER_H

#include "lib/rng.h"
#include "lib/shared_types.h"

#define TS_SET_CAMERA 0u
#define TS_SET_LIGHT(b) (1u + 2u * (b))
#define TS_SET_BSDF(b) (2u + 2u * (b))
/* The lens of a camera with depth of field (kernels/camera.cl): dimensions 0 and 1, the point
 * on the lens. Above every vertex's sets (the path depth is at most 64). */
#define TS_SET_LENS 0xffffu

/* Direction numbers of Sobol dimensions 1-3 (dimension 0 is the bit reversal), 32 bits:
 * primitive polynomials x + 1, x^2 + x + 1, x^3 + x + 1 with initial m = (1), (1, 3),
 * (1, 3, 1) (Joe and Kuo 2008). */
#ifdef __OPENCL_C_VERSION__
__constant
#else
static const
#endif
    ts_u32 ts_sobol_dirs[3][32] = {
        {0x80000000u, 0xc0000000u, 0xa0000000u, 0xf0000000u, 0x88000000u, 0xcc000000u, 0xaa000000u,
         0xff000000u, 0x80800000u, 0xc0c00000u, 0xa0a00000u, 0xf0f00000u, 0x88880000u, 0xcccc0000u,
         0xaaaa0000u, 0xffff0000u, 0x80008000u, 0xc000c000u, 0xa000a000u, 0xf000f000u, 0x88008800u,
         0xcc00cc00u, 0xaa00aa00u, 0xff00ff00u, 0x80808080u, 0xc0c0c0c0u, 0xa0a0a0a0u, 0xf0f0f0f0u,
         0x88888888u, 0xccccccccu, 0xaaaaaaaau, 0xffffffffu},
        {0x80000000u, 0xc0000000u, 0x60000000u, 0x90000000u, 0xe8000000u, 0x5c000000u, 0x8e000000u,
         0xc5000000u, 0x68800000u, 0x9cc00000u, 0xee600000u, 0x55900000u, 0x80680000u, 0xc09c0000u,
         0x60ee0000u, 0x90550000u, 0xe8808000u, 0x5cc0c000u, 0x8e606000u, 0xc5909000u, 0x6868e800u,
         0x9c9c5c00u, 0xeeee8e00u, 0x5555c500u, 0x8000e880u, 0xc0005cc0u, 0x60008e60u, 0x9000c590u,
         0xe8006868u, 0x5c009c9cu, 0x8e00eeeeu, 0xc5005555u},
        {0x80000000u, 0xc0000000u, 0x20000000u, 0x50000000u, 0xf8000000u, 0x74000000u, 0xa2000000u,
         0x93000000u, 0xd8800000u, 0x25400000u, 0x59e00000u, 0xe6d00000u, 0x78080000u, 0xb40c0000u,
         0x82020000u, 0xc3050000u, 0x208f8000u, 0x51474000u, 0xfbea2000u, 0x75d93000u, 0xa0858800u,
         0x914e5400u, 0xdbe79e00u, 0x25db6d00u, 0x58800080u, 0xe54000c0u, 0x79e00020u, 0xb6d00050u,
         0x800800f8u, 0xc00c0074u, 0x200200a2u, 0x50050093u},
};

/* The bit reversal and the Laine-Karras steps on the lvalue x: a ts_u32, or in kernels a
 * vector of them (the _x8 forms below), as rng.h's TS_LOWBIAS32. */
#define TS_REVERSE_BITS(x)                                                                         \
    ((x) = (((x) >> 1) & 0x55555555u) | (((x)&0x55555555u) << 1),                                  \
     (x) = (((x) >> 2) & 0x33333333u) | (((x)&0x33333333u) << 2),                                  \
     (x) = (((x) >> 4) & 0x0f0f0f0fu) | (((x)&0x0f0f0f0fu) << 4),                                  \
     (x) = (((x) >> 8) & 0x00ff00ffu) | (((x)&0x00ff00ffu) << 8), (x) = ((x) >> 16) | ((x) << 16))
#define TS_LK_STEPS(x, seed)                                                                       \
    ((x) += (seed), (x) ^= (x)*0x6c50b47cu, (x) ^= (x)*0xb82f1e52u, (x) ^= (x)*0xc7afe638u,        \
     (x) ^= (x)*0x8d22f6e6u)

TS_INLINE ts_u32 sampler_reverse_bits(ts_u32 x)
{
    TS_REVERSE_BITS(x);
    return x;
}

/* Laine-Karras permutation with Burley's constants: bit q of the result depends only on
 * bits 0..q of x (an add and xor-multiplies by even constants), so on reversed bits it is
 * a nested uniform (Owen) scramble. */
TS_INLINE ts_u32 sampler_lk(ts_u32 x, ts_u32 seed)
{
    TS_LK_STEPS(x, seed);
    return x;
}

/* Owen scramble of a 32-bit value, most significant bit first: bit q of the result is bit
 * q of v flipped by a hash of the bits above it, so every dyadic interval maps onto one of
 * the same size. */
TS_INLINE ts_u32 sampler_owen(ts_u32 v, ts_u32 seed)
{
    return sampler_reverse_bits(sampler_lk(sampler_reverse_bits(v), seed));
}

/* Sobol dimension d (0..3) of point index. */
TS_INLINE ts_u32 sampler_sobol(ts_u32 index, ts_u32 d)
{
    if (d == 0u) return sampler_reverse_bits(index);
    /* A fixed trip count and no branch, so the compiler can run work-items in SIMD lanes. */
    ts_u32 x = 0u;
    for (ts_u32 k = 0u; k < 32u; ++k)
        x ^= ts_sobol_dirs[d - 1u][k] & (0u - ((index >> k) & 1u));
    return x;
}

/* mask for spp samples per pixel: the next power of two >= spp, minus one. */
TS_INLINE ts_u32 sampler_mask(ts_u32 spp)
{
    ts_u32 m = 1u;
    while (m < spp && m < 0x80000000u)
        m <<= 1;
    return m - 1u;
}

/* One set of one (pixel, sample): its scramble seed and its shuffled Sobol index, computed
 * once for the set's four values. */
typedef struct ts_sampler_set {
    ts_u32 k, index;
} ts_sampler_set;

TS_INLINE ts_sampler_set sampler_set(ts_u32 pixel, ts_u32 sample, ts_u32 set, ts_u32 seed,
                                     ts_u32 mask)
{
    ts_sampler_set s;
    s.k = rng_mix(rng_mix(rng_mix(seed ^ 0x2545f491u) ^ pixel) ^ (set * 0x9e3779b9u));
    s.index = sampler_owen(sample, s.k) & mask;
    return s;
}

/* Value d (0..3) of a set as 32 bits, and in [0, 1) (the top 24 bits). */
TS_INLINE ts_u32 sampler_set_bits(ts_sampler_set s, ts_u32 d)
{
    return sampler_owen(sampler_sobol(s.index, d), rng_mix(s.k ^ (d + 1u) * 0x68e31da4u));
}

TS_INLINE float sampler_set_value(ts_sampler_set s, ts_u32 d)
{
    return (float)(sampler_set_bits(s, d) >> 8) * (1.0f / 16777216.0f);
}

/* Value d (0..3) of set `set` for (pixel, sample) as 32 bits; the same in [0, 1). */
TS_INLINE ts_u32 sampler_bits(ts_u32 pixel, ts_u32 sample, ts_u32 set, ts_u32 d, ts_u32 seed,
                              ts_u32 mask)
{
    return sampler_set_bits(sampler_set(pixel, sample, set, seed, mask), d);
}

TS_INLINE float sampler_value(ts_u32 pixel, ts_u32 sample, ts_u32 set, ts_u32 d, ts_u32 seed,
                              ts_u32 mask)
{
    return sampler_set_value(sampler_set(pixel, sample, set, seed, mask), d);
}

#ifdef __OPENCL_C_VERSION__
/* Kernels only: the functions above for eight (pixel, sample) keys in the lanes of a uint8,
 * each lane the scalar operations in their order, so the same bits (camera.cl on CPU
 * devices, -DTS_CPU_LANES; the set, its seed and d are the same for all lanes). */
inline uint8 sampler_reverse_bits_x8(uint8 x)
{
    TS_REVERSE_BITS(x);
    return x;
}

inline uint8 sampler_owen_x8(uint8 v, uint8 seed)
{
    uint8 x = sampler_reverse_bits_x8(v);
    TS_LK_STEPS(x, seed);
    return sampler_reverse_bits_x8(x);
}

inline uint8 sampler_sobol_x8(uint8 index, ts_u32 d)
{
    if (d == 0u) return sampler_reverse_bits_x8(index);
    uint8 x = (uint8)(0u);
    for (ts_u32 k = 0u; k < 32u; ++k)
        x ^= (uint8)(ts_sobol_dirs[d - 1u][k]) & ((uint8)(0u) - ((index >> k) & 1u));
    return x;
}

typedef struct ts_sampler_set_x8 {
    uint8 k, index;
} ts_sampler_set_x8;

inline ts_sampler_set_x8 sampler_set_x8(uint8 pixel, uint8 sample, ts_u32 set, ts_u32 seed,
                                        ts_u32 mask)
{
    ts_sampler_set_x8 s;
    uint8 k = (uint8)(rng_mix(seed ^ 0x2545f491u)) ^ pixel;
    TS_LOWBIAS32(k);
    k ^= set * 0x9e3779b9u;
    TS_LOWBIAS32(k);
    s.k = k;
    s.index = sampler_owen_x8(sample, k) & mask;
    return s;
}

inline float8 sampler_set_value_x8(ts_sampler_set_x8 s, ts_u32 d)
{
    uint8 m = s.k ^ ((d + 1u) * 0x68e31da4u);
    TS_LOWBIAS32(m);
    uint8 bits = sampler_owen_x8(sampler_sobol_x8(s.index, d), m);
    return convert_float8(bits >> 8) * (1.0f / 16777216.0f);
}
#endif

#endif
