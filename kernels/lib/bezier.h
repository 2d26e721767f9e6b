/* bezier.h — bicubic Bézier patch evaluation, shared by the dice/shade kernels and the host
 * (the brute-force reference tracer dices with it so both sides produce the same vertices
 * bit for bit; tests/test_dice.c checks it against an independent de Casteljau in double).
 * Control points: 16 ts_vec4, row by row with u fastest (cp[j * 4 + i]). */
#ifndef TS_BEZIER_H
#define TS_BEZIER_H

#include "lib/shared_types.h"

#ifndef __OPENCL_C_VERSION__
#include <math.h>
#endif

/* Cubic Bernstein basis at t: (1-t)^3, 3t(1-t)^2, 3t^2(1-t), t^3, rounded so that the basis
 * at 1 - t is exactly this one reversed wherever 1 - (1 - t) == t (the grid's parameters
 * k / 2^m): b[1] and b[2] share the product t (1-t). */
TS_INLINE void bezier_basis(float t, float b[4])
{
    float s = 1.0f - t, ts = 3.0f * (t * s);
    b[0] = s * s * s;
    b[1] = ts * s;
    b[2] = ts * t;
    b[3] = t * t * t;
}

/* Derivative of the basis: 3 * (-(1-t)^2, (1-t)^2 - 2t(1-t), 2t(1-t) - t^2, t^2). */
TS_INLINE void bezier_basis_deriv(float t, float d[4])
{
    float s = 1.0f - t;
    d[0] = -3.0f * s * s;
    d[1] = 3.0f * (s * s - 2.0f * t * s);
    d[2] = 3.0f * (2.0f * t * s - t * t);
    d[3] = 3.0f * t * t;
}

/* (b0 x0 + b3 x3) + (b1 x1 + b2 x2): the same bits for the sequence read backwards with the
 * basis reversed (IEEE addition commutes), so a curve evaluated from either end agrees. */
TS_INLINE float bezier_sum4(const float b[4], float x0, float x1, float x2, float x3)
{
    return (b[0] * x0 + b[3] * x3) + (b[1] * x1 + b[2] * x2);
}

/* Sum over the grid with weights bu[i] * bv[j]; fixed operation order (no FMA, see
 * FP_CONTRACT) so host and device agree. Rows first, then the rows' sums along v, each with
 * bezier_sum4: on an edge of the patch (bu or bv = (1, 0, 0, 0) or its reverse) the result
 * is exactly that boundary curve's sum, the same for both patches sharing the curve,
 * whichever way each of them runs along it, so neighbours' vertices on their common edge
 * are bitwise equal (tests/test_scene.c). */
TS_INLINE ts_vec4 bezier_combine(TS_CONST_GLOBAL ts_vec4 *cp, const float bu[4], const float bv[4])
{
#if defined(__OPENCL_C_VERSION__) && defined(TS_CPU_LANES)
    /* CPU devices (-DTS_CPU_LANES, host/device/device.c dev_build_options): the same sums
     * with x, y, z (and w, unused) in the lanes of a float4, each lane the scalar operations
     * in their order: the same bits. The scalar form below is compiled into gathers of the
     * control points' columns by PoCL (a quarter of shade's time before the displaced normal
     * went to lib/noise4.h's lanes; most of dice's). Not on GPUs, where a work-item's float4
     * is no SIMD register: there NVIDIA's OpenCL compiler (driver 580.159) built shade_path
     * with this form into a kernel that fails at every path past the eye hit
     * (CL_INVALID_COMMAND_QUEUE, "Unknown error executing clFlush"; docs/benchmarks.md). */
    __global const float *f = (__global const float *)cp;
    float4 r[4];
    for (int j = 0; j < 4; ++j)
        r[j] = (bu[0] * vload4(4 * j, f) + bu[3] * vload4(4 * j + 3, f)) +
               (bu[1] * vload4(4 * j + 1, f) + bu[2] * vload4(4 * j + 2, f));
    float4 q = (bv[0] * r[0] + bv[3] * r[3]) + (bv[1] * r[1] + bv[2] * r[2]);
    ts_vec4 o = {q.x, q.y, q.z, 0.0f};
    return o;
#else
    float rx[4], ry[4], rz[4];
    for (int j = 0; j < 4; ++j) {
        TS_CONST_GLOBAL ts_vec4 *c = cp + j * 4;
        rx[j] = bezier_sum4(bu, c[0].x, c[1].x, c[2].x, c[3].x);
        ry[j] = bezier_sum4(bu, c[0].y, c[1].y, c[2].y, c[3].y);
        rz[j] = bezier_sum4(bu, c[0].z, c[1].z, c[2].z, c[3].z);
    }
    ts_vec4 r = {bezier_sum4(bv, rx[0], rx[1], rx[2], rx[3]),
                 bezier_sum4(bv, ry[0], ry[1], ry[2], ry[3]),
                 bezier_sum4(bv, rz[0], rz[1], rz[2], rz[3]), 0.0f};
    return r;
#endif
}

/* Position at (u, v) in [0,1]^2; w = 1. */
TS_INLINE ts_vec4 bezier_eval(TS_CONST_GLOBAL ts_vec4 *cp, float u, float v)
{
    float bu[4], bv[4];
    bezier_basis(u, bu);
    bezier_basis(v, bv);
    ts_vec4 p = bezier_combine(cp, bu, bv);
    p.w = 1.0f;
    return p;
}

/* Unnormalised surface normal dP/du x dP/dv at (u, v). Zero where a derivative vanishes
 * (the teapot's lid apex and bottom centre): see bezier_normal. */
TS_INLINE ts_vec4 bezier_cross_derivs(TS_CONST_GLOBAL ts_vec4 *cp, float u, float v)
{
    float bu[4], bv[4], du[4], dv[4];
    bezier_basis(u, bu);
    bezier_basis(v, bv);
    bezier_basis_deriv(u, du);
    bezier_basis_deriv(v, dv);
    ts_vec4 pu = bezier_combine(cp, du, bv);
    ts_vec4 pv = bezier_combine(cp, bu, dv);
    ts_vec4 n = {pu.y * pv.z - pu.z * pv.y, pu.z * pv.x - pu.x * pv.z, pu.x * pv.y - pu.y * pv.x,
                 0.0f};
    return n;
}

/* Unit normal at (u, v). At a degenerate point (a collapsed edge, dP/du = 0) the normal is
 * the limit from inside the patch: it is evaluated a little towards the centre. */
TS_INLINE ts_vec4 bezier_normal(TS_CONST_GLOBAL ts_vec4 *cp, float u, float v)
{
    ts_vec4 n = bezier_cross_derivs(cp, u, v);
    float len2 = n.x * n.x + n.y * n.y + n.z * n.z;
    for (int k = 0; k < 8 && !(len2 > 1e-20f); ++k) {
        u = 0.5f + 0.999f * (u - 0.5f) + (u < 0.5f ? 1e-3f : -1e-3f);
        v = 0.5f + 0.999f * (v - 0.5f) + (v < 0.5f ? 1e-3f : -1e-3f);
        n = bezier_cross_derivs(cp, u, v);
        len2 = n.x * n.x + n.y * n.y + n.z * n.z;
    }
    float inv = len2 > 0.0f ? 1.0f / sqrt(len2) : 0.0f;
    n.x *= inv;
    n.y *= inv;
    n.z *= inv;
    return n;
}

#endif
