/* udiv.h — division by a divisor that many work-items share, by multiplication (Granlund
 * and Montgomery 1994, "Division by invariant integers using multiplication", Fig. 4.1): the
 * host makes the divisor ready once (udiv_make), the kernels divide with a multiply, two
 * shifts and a subtraction. A 32-bit divide takes 25 cycles or more on a CPU and a long
 * instruction sequence on a GPU; camera and shade find each sample's pixel and sample this
 * way (lib/sample_order.h). Shared by the kernels and the host (tests/test_units.c). */
#ifndef TS_UDIV_H
#define TS_UDIV_H

#include "lib/shared_types.h"

/* n / d with d made ready by udiv_make: the same quotient as n / d for every 32-bit n. */
TS_INLINE ts_u32 udiv(ts_u32 n, ts_udiv d)
{
#ifdef __OPENCL_C_VERSION__
    ts_u32 t = mul_hi(d.mul, n);
#else
    ts_u32 t = (ts_u32)(((unsigned long long)d.mul * n) >> 32);
#endif
    return (t + ((n - t) >> d.sh1)) >> d.sh2;
}

#ifdef __OPENCL_C_VERSION__
/* udiv of eight numerators in the lanes of a uint8, each by its lane's divisor (mul, sh1,
 * sh2 of udiv_make): the same quotients. */
inline uint8 udiv_lanes(uint8 n, uint8 mul, uint8 sh1, uint8 sh2)
{
    uint8 t = mul_hi(mul, n);
    return (t + ((n - t) >> sh1)) >> sh2;
}

/* udiv of eight numerators by one divisor. */
inline uint8 udiv_x8(uint8 n, ts_udiv d)
{
    return udiv_lanes(n, (uint8)(d.mul), (uint8)(d.sh1), (uint8)(d.sh2));
}
#endif

#ifndef __OPENCL_C_VERSION__
/* d (>= 1) made ready for udiv: l = ceil(log2 d), mul = floor(2^32 (2^l - d) / d) + 1, which
 * fits 32 bits since 2^l - d < d; sh1 = min(l, 1), sh2 = max(l - 1, 0) (Granlund and
 * Montgomery's branch-free form; d = 1 gives mul = 1, sh1 = sh2 = 0: t = 0, n). */
TS_INLINE ts_udiv udiv_make(ts_u32 d)
{
    ts_u32 l = 0;
    while (l < 32u && ((unsigned long long)1 << l) < d)
        ++l;
    unsigned long long x = ((unsigned long long)1 << l) - d; /* < d <= 2^32 */
    ts_udiv r = {(ts_u32)((x << 32) / d + 1u), l < 1u ? l : 1u, l > 1u ? l - 1u : 0u, d};
    return r;
}

#endif

#endif
