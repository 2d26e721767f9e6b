/* displace.h — the built-in displacement functions (DESIGN.md §2, Hanika §3.2-3.3), shared
 * by the dice/build kernels and the host (patch boxes, references):
 *   fbm:    d(P) = amplitude * sum_o gain^o * noise(f_o * W P)
 *   ridged: d(P) = amplitude * sum_o gain^o * (1 - 2 |noise(f_o * W P)|)
 * with f_o = frequency * lacunarity^o and W the patch's world-to-object transform, so the
 * pattern sticks to the object. Each has a point form and an interval form over a box of
 * world positions, used to keep every leaf and patch box conservative.
 *   texture: d(u, v) = amplitude * (texel(s, t) - offset), (s, t) the patch's texture
 * coordinates at (u, v) (lib/texture.h); its interval form is over a parameter rectangle
 * (displace_texture_interval), through the texture's min-max pyramid. The noise functions
 * below answer 0 for it. */
#ifndef TS_DISPLACE_H
#define TS_DISPLACE_H

#include "lib/noise.h"
#include "lib/shared_types.h"
#include "lib/texture.h"

#define TS_DISP_MAX_OCTAVES 16u

TS_INLINE ts_u32 displace_octaves(TS_CONST_GLOBAL ts_patch_attr *a)
{
    return a->disp_octaves < 1u                    ? 1u
           : a->disp_octaves > TS_DISP_MAX_OCTAVES ? TS_DISP_MAX_OCTAVES
                                                   : a->disp_octaves;
}

/* 1 for the noise functions (fbm, ridged). */
TS_INLINE int displace_is_noise(TS_CONST_GLOBAL ts_patch_attr *a)
{
    return a->disp_kind == TS_DISP_FBM || a->disp_kind == TS_DISP_RIDGED;
}

/* d(P) at world point (px, py, pz). 0 unless a noise function. */
TS_INLINE float displace_value(TS_CONST_GLOBAL ts_patch_attr *a, TS_CONST_GLOBAL ts_xform *x,
                               float px, float py, float pz)
{
    if (!displace_is_noise(a)) return 0.0f;
    float ox = x->r0[0] * px + x->r0[1] * py + x->r0[2] * pz + x->r0[3];
    float oy = x->r1[0] * px + x->r1[1] * py + x->r1[2] * pz + x->r1[3];
    float oz = x->r2[0] * px + x->r2[1] * py + x->r2[2] * pz + x->r2[3];
    float f = a->disp_frequency, w = 1.0f, sum = 0.0f;
    ts_u32 n = displace_octaves(a);
    for (ts_u32 o = 0; o < n; ++o) {
        float v = noise3(ox * f, oy * f, oz * f);
        sum += a->disp_kind == TS_DISP_RIDGED ? w * (1.0f - 2.0f * fabs(v)) : w * v;
        f *= a->disp_lacunarity;
        w *= a->disp_gain;
    }
    return a->disp_amplitude * sum;
}

/* An interval holding d(P) for every P in the world box [lo, hi]. */
TS_INLINE ts_interval displace_interval(TS_CONST_GLOBAL ts_patch_attr *a,
                                        TS_CONST_GLOBAL ts_xform *x, float lx, float ly, float lz,
                                        float hx, float hy, float hz)
{
    ts_interval zero = {0.0f, 0.0f};
    if (!displace_is_noise(a)) return zero;
    /* The box in object space: an affine map's range over a box, row by row. */
    float olo[3], ohi[3];
    TS_CONST_GLOBAL float *rows[3] = {x->r0, x->r1, x->r2};
    for (int r = 0; r < 3; ++r) {
        float l = rows[r][3], h = rows[r][3];
        float e0 = rows[r][0] * lx, e1 = rows[r][0] * hx;
        l += fmin(e0, e1), h += fmax(e0, e1);
        e0 = rows[r][1] * ly, e1 = rows[r][1] * hy;
        l += fmin(e0, e1), h += fmax(e0, e1);
        e0 = rows[r][2] * lz, e1 = rows[r][2] * hz;
        l += fmin(e0, e1), h += fmax(e0, e1);
        float slack = 1e-6f * (fabs(l) + fabs(h)); /* rounding of the point transform */
        olo[r] = l - slack, ohi[r] = h + slack;
    }
    float f = a->disp_frequency, w = 1.0f;
    ts_interval sum = zero;
    ts_u32 n = displace_octaves(a);
    for (ts_u32 o = 0; o < n; ++o) {
        float f0 = fmin(olo[0] * f, ohi[0] * f), f1 = fmax(olo[0] * f, ohi[0] * f);
        float g0 = fmin(olo[1] * f, ohi[1] * f), g1 = fmax(olo[1] * f, ohi[1] * f);
        float h0 = fmin(olo[2] * f, ohi[2] * f), h1 = fmax(olo[2] * f, ohi[2] * f);
        ts_interval v = noise3_interval(f0, g0, h0, f1, g1, h1);
        if (a->disp_kind == TS_DISP_RIDGED) { /* 1 - 2|v| */
            float alo = v.lo >= 0.0f ? v.lo : v.hi <= 0.0f ? -v.hi : 0.0f;
            float ahi = fmax(fabs(v.lo), fabs(v.hi));
            v.lo = 1.0f - 2.0f * ahi;
            v.hi = 1.0f - 2.0f * alo;
        }
        /* w >= 0 while gain >= 0; a negative gain flips the ends. */
        float p0 = w * v.lo, p1 = w * v.hi;
        sum.lo += fmin(p0, p1);
        sum.hi += fmax(p0, p1);
        f *= a->disp_lacunarity;
        w *= a->disp_gain;
    }
    float d0 = a->disp_amplitude * sum.lo, d1 = a->disp_amplitude * sum.hi;
    float slack = 1e-5f * fabs(a->disp_amplitude) * (float)n; /* summation rounding */
    ts_interval r = {fmin(d0, d1) - slack, fmax(d0, d1) + slack};
    return r;
}

/* max |d(P)| over all P: the global noise bound through the octave sum (0 unless a noise
 * function; textures: displace_texture_interval over the patch's st rectangle). */
TS_INLINE float displace_bound(TS_CONST_GLOBAL ts_patch_attr *a)
{
    if (!displace_is_noise(a)) return 0.0f;
    /* ridged: 1 - 2|n| lies in [1 - 2 NOISE_BOUND, 1]. */
    float per =
        a->disp_kind == TS_DISP_RIDGED ? fmax(1.0f, 2.0f * NOISE_BOUND - 1.0f) : NOISE_BOUND;
    float w = 1.0f, sum = 0.0f;
    ts_u32 n = displace_octaves(a);
    for (ts_u32 o = 0; o < n; ++o) {
        sum += fabs(w) * per;
        w *= a->disp_gain;
    }
    return fabs(a->disp_amplitude) * sum * 1.0001f;
}

/* TS_DISP_TEXTURE: d at (u, v), bilinear at level 0 of the texture (what dice evaluates). */
TS_INLINE float displace_texture_value(TS_CONST_GLOBAL ts_patch_attr *a, ts_tex_ctx tex, float u,
                                       float v)
{
    float s, t;
    tex_patch_st(a, u, v, &s, &t);
    return a->disp_amplitude * (tex_bilinear(tex, a->disp_tex, s, t).x - a->disp_offset);
}

/* TS_DISP_TEXTURE: an interval holding d(u, v) for every (u, v) in [u0, u1] x [v0, v1].
 * The bilinear st of a rectangle stays in the box of its four corners' st. */
TS_INLINE ts_interval displace_texture_interval(TS_CONST_GLOBAL ts_patch_attr *a, ts_tex_ctx tex,
                                                float u0, float v0, float u1, float v1)
{
    float s[4], t[4];
    tex_patch_st(a, u0, v0, &s[0], &t[0]);
    tex_patch_st(a, u1, v0, &s[1], &t[1]);
    tex_patch_st(a, u0, v1, &s[2], &t[2]);
    tex_patch_st(a, u1, v1, &s[3], &t[3]);
    float s0 = fmin(fmin(s[0], s[1]), fmin(s[2], s[3])),
          s1 = fmax(fmax(s[0], s[1]), fmax(s[2], s[3]));
    float t0 = fmin(fmin(t[0], t[1]), fmin(t[2], t[3])),
          t1 = fmax(fmax(t[0], t[1]), fmax(t[2], t[3]));
    ts_interval r = tex_range(tex, a->disp_tex, s0, t0, s1, t1);
    float d0 = a->disp_amplitude * (r.lo - a->disp_offset),
          d1 = a->disp_amplitude * (r.hi - a->disp_offset);
    /* Rounding of texel - offset and of the product: a few ulps of the operands. */
    float slack =
        4e-7f * fabs(a->disp_amplitude) * (fmax(fabs(r.lo), fabs(r.hi)) + fabs(a->disp_offset));
    ts_interval d = {fmin(d0, d1) - slack, fmax(d0, d1) + slack};
    return d;
}

/* The displacement normal at (u, v): the bilinear interpolation of the four corner normals
 * n[0..3] at (0,0), (1,0), (0,1), (1,1). Not renormalised (so its range over a parameter
 * rectangle is the box of its values at the rectangle's corners); adjacent patches sharing
 * an edge share its two corner normals and so displace the edge identically. */
TS_INLINE ts_vec4 displace_normal(TS_CONST_GLOBAL ts_vec4 *n, float u, float v)
{
    float w00 = (1.0f - u) * (1.0f - v), w10 = u * (1.0f - v), w01 = (1.0f - u) * v, w11 = u * v;
    ts_vec4 r = {w00 * n[0].x + w10 * n[1].x + w01 * n[2].x + w11 * n[3].x,
                 w00 * n[0].y + w10 * n[1].y + w01 * n[2].y + w11 * n[3].y,
                 w00 * n[0].z + w10 * n[1].z + w01 * n[2].z + w11 * n[3].z, 0.0f};
    return r;
}

#endif
