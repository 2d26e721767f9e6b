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

/* World point (px, py, pz) in the noise's object space (x: world to object), o[0..2]: the
 * point transform every evaluation of the noise takes, in one operation order. */
TS_INLINE void displace_object_point(TS_CONST_GLOBAL ts_xform *x, float px, float py, float pz,
                                     float o[3])
{
    o[0] = x->r0[0] * px + x->r0[1] * py + x->r0[2] * pz + x->r0[3];
    o[1] = x->r1[0] * px + x->r1[1] * py + x->r1[2] * pz + x->r1[3];
    o[2] = x->r2[0] * px + x->r2[1] * py + x->r2[2] * pz + x->r2[3];
}

/* d(P) at world point (px, py, pz). 0 unless a noise function. */
TS_INLINE float displace_value(TS_CONST_GLOBAL ts_patch_attr *a, TS_CONST_GLOBAL ts_xform *x,
                               float px, float py, float pz)
{
    if (!displace_is_noise(a)) return 0.0f;
    float op[3];
    displace_object_point(x, px, py, pz, op);
    float ox = op[0], oy = op[1], oz = op[2];
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

/* The box in object space holding the world box [l, h] moved by x: an affine map's range over
 * a box, row by row, widened by the rounding of the point transform. */
TS_INLINE void displace_object_box(TS_CONST_GLOBAL ts_xform *x, float lx, float ly, float lz,
                                   float hx, float hy, float hz, float olo[3], float ohi[3])
{
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
}

/* Adds octave interval v at weight w to *sum (ridged octaves as 1 - 2|v|); w >= 0 while
 * gain >= 0, a negative gain flips the ends. */
TS_INLINE void displace_interval_add(TS_CONST_GLOBAL ts_patch_attr *a, ts_interval v, float w,
                                     ts_interval *sum)
{
    if (a->disp_kind == TS_DISP_RIDGED) { /* 1 - 2|v| */
        float alo = v.lo >= 0.0f ? v.lo : v.hi <= 0.0f ? -v.hi : 0.0f;
        float ahi = fmax(fabs(v.lo), fabs(v.hi));
        v.lo = 1.0f - 2.0f * ahi;
        v.hi = 1.0f - 2.0f * alo;
    }
    float p0 = w * v.lo, p1 = w * v.hi;
    sum->lo += fmin(p0, p1);
    sum->hi += fmax(p0, p1);
}

/* The displacement interval of the octave sum `sum` of n octaves: times the amplitude,
 * widened by the summation's rounding. */
TS_INLINE ts_interval displace_interval_end(TS_CONST_GLOBAL ts_patch_attr *a, ts_interval sum,
                                            ts_u32 n)
{
    float d0 = a->disp_amplitude * sum.lo, d1 = a->disp_amplitude * sum.hi;
    float slack = 1e-5f * fabs(a->disp_amplitude) * (float)n; /* summation rounding */
    ts_interval r = {fmin(d0, d1) - slack, fmax(d0, d1) + slack};
    return r;
}

/* An interval holding d(P) for every P in the world box [lo, hi]. */
TS_INLINE ts_interval displace_interval(TS_CONST_GLOBAL ts_patch_attr *a,
                                        TS_CONST_GLOBAL ts_xform *x, float lx, float ly, float lz,
                                        float hx, float hy, float hz)
{
    ts_interval zero = {0.0f, 0.0f};
    if (!displace_is_noise(a)) return zero;
    float olo[3], ohi[3];
    displace_object_box(x, lx, ly, lz, hx, hy, hz, olo, ohi);
    float f = a->disp_frequency, w = 1.0f;
    ts_interval sum = zero;
    ts_u32 n = displace_octaves(a);
    for (ts_u32 o = 0; o < n; ++o) {
        float f0 = fmin(olo[0] * f, ohi[0] * f), f1 = fmax(olo[0] * f, ohi[0] * f);
        float g0 = fmin(olo[1] * f, ohi[1] * f), g1 = fmax(olo[1] * f, ohi[1] * f);
        float h0 = fmin(olo[2] * f, ohi[2] * f), h1 = fmax(olo[2] * f, ohi[2] * f);
        displace_interval_add(a, noise3_interval(f0, g0, h0, f1, g1, h1), w, &sum);
        f *= a->disp_lacunarity;
        w *= a->disp_gain;
    }
    return displace_interval_end(a, sum, n);
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

/* The displacement direction (DESIGN.md §2, issue 13): a unit vector interpolated between
 * nine normals of the patch, its corners n[0..3] at (0,0), (1,0), (0,1), (1,1) and mid[0..4]
 * at the edge midpoints (1/2,0), (0,1/2), (1,1/2), (1/2,1) and the centre, by the
 * biquadratic through those nodes, then normalised. Four corners alone (a bilinear blend)
 * vanish in the middle of a patch that spans half a tube, where its corner normals point in
 * opposite directions: the handle and spout of the teapot came out nearly undisplaced.
 * Along an edge the direction depends only on that edge's two corner normals and its
 * midpoint normal, which neighbours share (scene.h), and it is evaluated so that either
 * side, in either direction, rounds the same at the grid's parameters: the two end terms
 * first (a commutative sum), then the middle one. So displaced neighbours meet without a
 * crack. A sum that vanishes (never for nodes within 90 degrees of their neighbours) gives
 * +z; displace_normal_box bounds every case. */

/* Weights of the quadratic through t = 0, 1/2, 1: q(t) = w[0] a + w[1] m + w[2] b. */
TS_INLINE void displace_quad_weights(float t, float w[3])
{
    w[0] = (1.0f - t) * (1.0f - 2.0f * t);
    w[1] = 4.0f * t * (1.0f - t);
    w[2] = t * (2.0f * t - 1.0f);
}

/* (w0 a + w2 b) + w1 m, componentwise. */
TS_INLINE ts_vec4 displace_quad(const float w[3], ts_vec4 a, ts_vec4 m, ts_vec4 b)
{
    ts_vec4 r = {(w[0] * a.x + w[2] * b.x) + w[1] * m.x, (w[0] * a.y + w[2] * b.y) + w[1] * m.y,
                 (w[0] * a.z + w[2] * b.z) + w[1] * m.z, 0.0f};
    return r;
}

TS_INLINE ts_vec4 displace_normal(TS_CONST_GLOBAL ts_vec4 *n, TS_CONST_GLOBAL ts_vec4 *mid, float u,
                                  float v)
{
    float wu[3], wv[3];
    displace_quad_weights(u, wu);
    displace_quad_weights(v, wv);
    ts_vec4 r0 = displace_quad(wu, n[0], mid[0], n[1]);     /* the v = 0 edge */
    ts_vec4 r1 = displace_quad(wu, mid[1], mid[4], mid[2]); /* v = 1/2 */
    ts_vec4 r2 = displace_quad(wu, n[2], mid[3], n[3]);     /* the v = 1 edge */
    ts_vec4 s = displace_quad(wv, r0, r1, r2);
    float len = sqrt(s.x * s.x + s.y * s.y + s.z * s.z);
    ts_vec4 up = {0.0f, 0.0f, 1.0f, 0.0f};
    if (!(len > 1e-12f)) return up;
    ts_vec4 r = {s.x / len, s.y / len, s.z / len, 0.0f};
    return r;
}

/* The three Bernstein control points, over [t0, t1], of the quadratic through a, m, b at
 * t = 0, 1/2, 1 (its Bernstein form over [0, 1] is a, 2m - (a + b) / 2, b; over [t0, t1]
 * the points are q(t0), the blossom at (t0, t1), q(t1)). */
TS_INLINE void displace_quad_restrict(ts_vec4 a, ts_vec4 m, ts_vec4 b, float t0, float t1,
                                      ts_vec4 out[3])
{
    ts_vec4 c = {2.0f * m.x - 0.5f * (a.x + b.x), 2.0f * m.y - 0.5f * (a.y + b.y),
                 2.0f * m.z - 0.5f * (a.z + b.z), 0.0f};
    float s0 = 1.0f - t0, s1 = 1.0f - t1;
    float w[3][3] = {{s0 * s0, 2.0f * t0 * s0, t0 * t0},
                     {s0 * s1, s0 * t1 + t0 * s1, t0 * t1},
                     {s1 * s1, 2.0f * t1 * s1, t1 * t1}};
    for (int k = 0; k < 3; ++k) {
        out[k].x = w[k][0] * a.x + w[k][1] * c.x + w[k][2] * b.x;
        out[k].y = w[k][0] * a.y + w[k][1] * c.y + w[k][2] * b.y;
        out[k].z = w[k][0] * a.z + w[k][1] * c.z + w[k][2] * b.z;
        out[k].w = 0.0f;
    }
}

/* [lo, hi] / r for r in [rmin, rmax], 0 < rmin: the range of one component of v / |v|. */
TS_INLINE void displace_div_range(float lo, float hi, float rmin, float rmax, float *a, float *b)
{
    *a = lo >= 0.0f ? lo / rmax : lo / rmin;
    *b = hi <= 0.0f ? hi / rmax : hi / rmin;
    *a = fmax(*a, -1.0f), *b = fmin(*b, 1.0f);
}

/* A box holding displace_normal(n, mid, u, v) for every (u, v) in [u0, u1] x [v0, v1]: the
 * unnormalised biquadratic over the rectangle lies in the hull of its 9 Bernstein points
 * there (rows restricted in u, then the columns in v); normalising divides by a length in
 * [distance of that box from 0, its farthest corner]; a box around 0 gives [-1, 1]^3. */
TS_INLINE ts_box displace_normal_box(TS_CONST_GLOBAL ts_vec4 *n, TS_CONST_GLOBAL ts_vec4 *mid,
                                     float u0, float v0, float u1, float v1)
{
    ts_vec4 rows[3][3], col[3];
    displace_quad_restrict(n[0], mid[0], n[1], u0, u1, rows[0]);
    displace_quad_restrict(mid[1], mid[4], mid[2], u0, u1, rows[1]);
    displace_quad_restrict(n[2], mid[3], n[3], u0, u1, rows[2]);
    ts_box b = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    for (int k = 0; k < 3; ++k) {
        displace_quad_restrict(rows[0][k], rows[1][k], rows[2][k], v0, v1, col);
        for (int j = 0; j < 3; ++j) {
            b.lo_x = fmin(b.lo_x, col[j].x), b.hi_x = fmax(b.hi_x, col[j].x);
            b.lo_y = fmin(b.lo_y, col[j].y), b.hi_y = fmax(b.hi_y, col[j].y);
            b.lo_z = fmin(b.lo_z, col[j].z), b.hi_z = fmax(b.hi_z, col[j].z);
        }
    }
    /* Rounding of the conversions (a few ulps of components at most ~3 in size). */
    const float e = 4e-6f;
    b.lo_x -= e, b.lo_y -= e, b.lo_z -= e, b.hi_x += e, b.hi_y += e, b.hi_z += e;
    float dx = fmax(fmax(b.lo_x, -b.hi_x), 0.0f), dy = fmax(fmax(b.lo_y, -b.hi_y), 0.0f),
          dz = fmax(fmax(b.lo_z, -b.hi_z), 0.0f);
    float rmin = sqrt(dx * dx + dy * dy + dz * dz);
    ts_box all = {-1.0f, -1.0f, -1.0f, 1.0f, 1.0f, 1.0f};
    if (!(rmin > 1e-6f)) return all;
    float fx = fmax(-b.lo_x, b.hi_x), fy = fmax(-b.lo_y, b.hi_y), fz = fmax(-b.lo_z, b.hi_z);
    float rmax = sqrt(fx * fx + fy * fy + fz * fz);
    ts_box r;
    displace_div_range(b.lo_x, b.hi_x, rmin, rmax, &r.lo_x, &r.hi_x);
    displace_div_range(b.lo_y, b.hi_y, rmin, rmax, &r.lo_y, &r.hi_y);
    displace_div_range(b.lo_z, b.hi_z, rmin, rmax, &r.lo_z, &r.hi_z);
    /* The division and the float normalisation of displace_normal: a few ulps. */
    r.lo_x -= e, r.lo_y -= e, r.lo_z -= e, r.hi_x += e, r.hi_y += e, r.hi_z += e;
    return r;
}

#endif
