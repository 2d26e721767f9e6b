/* noise4.h — kernels only: the fBm of lib/displace.h with several noise evaluations in the
 * lanes of a float8 (noise3_x8). shade.cl's displaced shading normal, where the patch's grid
 * is not resident, evaluates the micro-quad's four corners together, a point per lane and two
 * octaves in the two halves (their Bézier points and displacement normals in float4 lanes);
 * dice.cl evaluates a vertex's octaves together, one per lane, or two vertices' octaves in
 * the two halves where there are at most four (displace_value_pair). The scalar fBm was 15% (shade)
 * and 4% (dice) of a teapot_displaced render. build.cl takes a micro-quad's four corner normals in
 * float4 lanes (displace_normal_x4) and its displacement-normal box with x, y, z in lanes
 * (displace_normal_box_x4): with base_box, 11% of that render as scalar code. Every lane runs
 * the operations of the scalar noise3 / displace_value / patch_vertex / displace_normal_box in
 * their order, and the octaves are added in octave order (kernels are built with FP_CONTRACT
 * OFF), so the results have the same bits as the host's references, which stay scalar:
 * test_dice_build and test_bottom_level compare the diced grids and built trees bit for bit,
 * test_dice_build the normal boxes (probe kernel build_normal_box_probe); test_shading_normal
 * compares the shading normal (through the probe kernel shade_normal_probe). */
#ifndef TS_NOISE4_H
#define TS_NOISE4_H

#include "lib/patch.h"

inline uint8 noise_mix8(uint8 x)
{
    TS_LOWBIAS32(x); /* lib/rng.h's rng_mix, lane by lane */
    return x;
}

/* The lattice and cell helpers below are always inlined: PoCL 3.1 left them as calls, their
 * float8 arrays passed through memory; inlined, forest-100's squeezed 960x384 frame spends 4%
 * less in `build` and 8% less in `dice`, the same bits (stop 62, 77a43ad). Inlining
 * displace_interval_x8 (now displace_interval_tasks) and displace_normal_box_x4 into
 * build_leaves as well was slower (forced for displace_interval_tasks: no faster). */

/* noise_gradient at the eight corners k (x bit 1, y bit 2, z bit 4) of the lattice cells at
 * (ix, iy, iz), lane by lane: two components are +-1, one is 0. The lattice hash of
 * noise_hash, its inner words shared by the corners with equal z (and y): the same values,
 * fewer mixes. */
TS_INLINE_ALWAYS void noise_gradients_x8(int8 ix, int8 iy, int8 iz, float8 gx[8], float8 gy[8],
                                         float8 gz[8])
{
    uint8 hz[2], hy[4];
    for (int dz = 0; dz < 2; ++dz)
        hz[dz] = noise_mix8(as_uint8(iz + dz) * 0xcb1ab31fu);
    for (int k = 0; k < 4; ++k)
        hy[k] = noise_mix8(as_uint8(iy + (k & 1)) * 0xd8163841u ^ hz[k >> 1]);
#pragma unroll
    for (int k = 0; k < 8; ++k) {
        int dx = k & 1, dy = (k >> 1) & 1, dz = k >> 2;
        uint8 h = noise_mix8(as_uint8(ix + dx) * 0x8da6b343u ^ hy[(dz << 1) | dy]) % 12u;
        int8 neg_a = as_int8(h & 1u) != 0, neg_b = as_int8(h & 2u) != 0;
        float8 a = select((float8)(1.0f), (float8)(-1.0f), neg_a);
        float8 b = select((float8)(1.0f), (float8)(-1.0f), neg_b);
        uint8 axis = h >> 2;
        int8 ax0 = as_int8(axis) == 0, ax2 = as_int8(axis) == 2;
        gx[k] = select(a, (float8)(0.0f), ax2);
        gy[k] = select(select((float8)(0.0f), a, ax2), b, ax0);
        gz[k] = select(b, (float8)(0.0f), ax0);
    }
}

/* noise3 at eight points (x.s0, y.s0, z.s0) .. (x.s7, y.s7, z.s7). */
inline float8 noise3_x8(float8 x, float8 y, float8 z)
{
    float8 fx0 = floor(x), fy0 = floor(y), fz0 = floor(z);
    int8 ix = convert_int8(fx0), iy = convert_int8(fy0), iz = convert_int8(fz0);
    float8 fx = x - fx0, fy = y - fy0, fz = z - fz0;
    float8 gx[8], gy[8], gz[8], c[8];
    noise_gradients_x8(ix, iy, iz, gx, gy, gz);
#pragma unroll
    for (int k = 0; k < 8; ++k) {
        int dx = k & 1, dy = (k >> 1) & 1, dz = k >> 2;
        c[k] = gx[k] * (fx - (float)dx) + gy[k] * (fy - (float)dy) + gz[k] * (fz - (float)dz);
    }
    float8 u = fx * fx * fx * (fx * (fx * 6.0f - 15.0f) + 10.0f);
    float8 v = fy * fy * fy * (fy * (fy * 6.0f - 15.0f) + 10.0f);
    float8 w = fz * fz * fz * (fz * (fz * 6.0f - 15.0f) + 10.0f);
    float8 x00 = c[0] + u * (c[1] - c[0]), x10 = c[2] + u * (c[3] - c[2]);
    float8 x01 = c[4] + u * (c[5] - c[4]), x11 = c[6] + u * (c[7] - c[6]);
    float8 y0 = x00 + v * (x10 - x00), y1 = x01 + v * (x11 - x01);
    return y0 + w * (y1 - y0);
}

/* The n octaves' frequencies f[o] and weights w[o], displace_value's running products, and f
 * of the last octave again up to `lanes` (the spare lanes of a vector evaluation). */
inline void displace_octave_steps(__global const ts_patch_attr *a, uint n, uint lanes, float *f,
                                  float *w)
{
    f[0] = a->disp_frequency, w[0] = 1.0f;
    for (uint o = 0; o + 1u < n; ++o)
        f[o + 1] = f[o] * a->disp_lacunarity, w[o + 1] = w[o] * a->disp_gain;
    for (uint o = n; o < lanes; ++o)
        f[o] = f[n - 1u];
}

/* displace_value at four world points (a noise function: the caller checked); two octaves
 * at a time, one in each half of a float8, added in octave order. */
inline float4 displace_value_x4(__global const ts_patch_attr *a, __global const ts_xform *x,
                                float4 px, float4 py, float4 pz)
{
    float4 ox = x->r0[0] * px + x->r0[1] * py + x->r0[2] * pz + x->r0[3];
    float4 oy = x->r1[0] * px + x->r1[1] * py + x->r1[2] * pz + x->r1[3];
    float4 oz = x->r2[0] * px + x->r2[1] * py + x->r2[2] * pz + x->r2[3];
    float f[TS_DISP_MAX_OCTAVES], w[TS_DISP_MAX_OCTAVES];
    uint n = displace_octaves(a);
    displace_octave_steps(a, n, n, f, w);
    float4 sum = (float4)(0.0f);
    int ridged = a->disp_kind == TS_DISP_RIDGED;
    for (uint o = 0; o < n; o += 2) {
        float f1 = o + 1u < n ? f[o + 1] : f[o]; /* n odd: the last octave twice, added once */
        float8 v = noise3_x8((float8)(ox * f[o], ox * f1), (float8)(oy * f[o], oy * f1),
                             (float8)(oz * f[o], oz * f1));
        sum += ridged ? w[o] * (1.0f - 2.0f * fabs(v.lo)) : w[o] * v.lo;
        if (o + 1u < n) sum += ridged ? w[o + 1] * (1.0f - 2.0f * fabs(v.hi)) : w[o + 1] * v.hi;
    }
    return a->disp_amplitude * sum;
}

/* displace_value at one world point, eight octaves at a time in the lanes of a float8 and
 * added in octave order (dice.cl). */
inline float displace_value_octaves(__global const ts_patch_attr *a, __global const ts_xform *x,
                                    float px, float py, float pz)
{
    float op[3];
    displace_object_point(x, px, py, pz, op);
    float ox = op[0], oy = op[1], oz = op[2];
    uint n = displace_octaves(a);
    float f[TS_DISP_MAX_OCTAVES + 8], w[TS_DISP_MAX_OCTAVES + 8];
    displace_octave_steps(a, n, (n + 7u) & ~7u, f, w);
    float sum = 0.0f, v[8];
    int ridged = a->disp_kind == TS_DISP_RIDGED;
    for (uint o = 0; o < n; o += 8u) {
        float8 fo = vload8(0, f + o);
        vstore8(noise3_x8(ox * fo, oy * fo, oz * fo), 0, v);
        for (uint l = 0; l < 8u && o + l < n; ++l)
            sum += ridged ? w[o + l] * (1.0f - 2.0f * fabs(v[l])) : w[o + l] * v[l];
    }
    return a->disp_amplitude * sum;
}

/* displace_value at two world points (a noise function of at most four octaves: the caller
 * checked), their octaves in the two halves of one float8 (point a in lanes 0-3, b in 4-7;
 * spare lanes repeat the last octave) and added in octave order: the bits of
 * displace_value_octaves at each point, one noise evaluation instead of two. */
inline float2 displace_value_pair(__global const ts_patch_attr *a, __global const ts_xform *x,
                                  float4 pa, float4 pb)
{
    float oa[3], ob[3];
    displace_object_point(x, pa.x, pa.y, pa.z, oa);
    displace_object_point(x, pb.x, pb.y, pb.z, ob);
    uint n = displace_octaves(a);
    float f[4], w[4];
    displace_octave_steps(a, n, 4u, f, w);
    /* Lanes 0-3: a's octaves, 4-7: b's (built by select: Oclgrind 21.10's uninitialized-value
     * check crashes on a float8 made of two float4) */
    float8 fo = (float8)(f[0], f[1], f[2], f[3], f[0], f[1], f[2], f[3]);
    int8 at_b = (int8)(0, 0, 0, 0, -1, -1, -1, -1);
    float8 v = noise3_x8(select((float8)(oa[0]), (float8)(ob[0]), at_b) * fo,
                         select((float8)(oa[1]), (float8)(ob[1]), at_b) * fo,
                         select((float8)(oa[2]), (float8)(ob[2]), at_b) * fo);
    float vv[8];
    vstore8(v, 0, vv);
    const float *va = vv, *vb = vv + 4;
    float sa = 0.0f, sb = 0.0f;
    int ridged = a->disp_kind == TS_DISP_RIDGED;
    for (uint o = 0; o < n; ++o) {
        sa += ridged ? w[o] * (1.0f - 2.0f * fabs(va[o])) : w[o] * va[o];
        sb += ridged ? w[o] * (1.0f - 2.0f * fabs(vb[o])) : w[o] * vb[o];
    }
    return (float2)(a->disp_amplitude * sa, a->disp_amplitude * sb);
}

/* patch_vertex (lib/patch.h), the same bits, with displace_value_octaves (dice.cl). */
inline ts_vec4 patch_vertex_x8(__global const ts_vec4 *cp, __global const ts_vec4 *cp0,
                               __global const ts_vec4 *n, __global const ts_vec4 *mid,
                               __global const ts_patch_attr *a, __global const ts_xform *x,
                               ts_tex_ctx tex, float u, float v)
{
    if (!displace_is_noise(a)) return patch_vertex(cp, cp0, n, mid, a, x, tex, u, v);
    ts_vec4 p = bezier_eval(cp, u, v);
    ts_vec4 p0 = cp0 == cp ? p : bezier_eval(cp0, u, v);
    float d = displace_value_octaves(a, x, p0.x, p0.y, p0.z);
    ts_vec4 dn = displace_normal(n, mid, u, v);
    ts_vec4 r = {p.x + d * dn.x, p.y + d * dn.y, p.z + d * dn.z, d};
    return r;
}

/* bezier_basis (lib/bezier.h) at four parameters, one per lane. */
inline void bezier_basis_x4(float4 t, float4 b[4])
{
    float4 s = 1.0f - t, ts = 3.0f * (t * s);
    b[0] = s * s * s;
    b[1] = ts * s;
    b[2] = ts * t;
    b[3] = t * t * t;
}

/* bezier_sum4 with the basis in lanes and the values shared by them. */
inline float4 bezier_sum4_x4(const float4 b[4], float x0, float x1, float x2, float x3)
{
    return (b[0] * x0 + b[3] * x3) + (b[1] * x1 + b[2] * x2);
}

/* bezier_sum4 with the basis in lanes and a value per lane. */
inline float4 bezier_sum4_v4(const float4 b[4], float4 x0, float4 x1, float4 x2, float4 x3)
{
    return (b[0] * x0 + b[3] * x3) + (b[1] * x1 + b[2] * x2);
}

/* bezier_eval's row sums: row j of the control points cp combined by the u basis bu (a
 * parameter per lane), x, y, z into rx[j], ry[j], rz[j]. */
TS_INLINE_ALWAYS void bezier_rows_x4(__global const ts_vec4 *cp, const float4 bu[4], float4 rx[4],
                                     float4 ry[4], float4 rz[4])
{
    for (int j = 0; j < 4; ++j) {
        __global const ts_vec4 *c = cp + j * 4;
        rx[j] = bezier_sum4_x4(bu, c[0].x, c[1].x, c[2].x, c[3].x);
        ry[j] = bezier_sum4_x4(bu, c[0].y, c[1].y, c[2].y, c[3].y);
        rz[j] = bezier_sum4_x4(bu, c[0].z, c[1].z, c[2].z, c[3].z);
    }
}

/* bezier_eval at four points (u.sk, v.sk), a point per lane, each lane bezier_combine's
 * operations in their order: the same bits. */
inline void bezier_eval_x4(__global const ts_vec4 *cp, float4 u, float4 v, float4 *px, float4 *py,
                           float4 *pz)
{
    float4 bu[4], bv[4], rx[4], ry[4], rz[4];
    bezier_basis_x4(u, bu);
    bezier_basis_x4(v, bv);
    bezier_rows_x4(cp, bu, rx, ry, rz);
    *px = bezier_sum4_v4(bv, rx[0], rx[1], rx[2], rx[3]);
    *py = bezier_sum4_v4(bv, ry[0], ry[1], ry[2], ry[3]);
    *pz = bezier_sum4_v4(bv, rz[0], rz[1], rz[2], rz[3]);
}

/* displace_quad_weights (lib/displace.h) in four lanes. */
inline void displace_quad_weights_x4(float4 t, float4 w[3])
{
    w[0] = (1.0f - t) * (1.0f - 2.0f * t);
    w[1] = 4.0f * t * (1.0f - t);
    w[2] = t * (2.0f * t - 1.0f);
}

/* displace_normal (lib/displace.h) at four points (u.sk, v.sk), the same bits per lane. */
inline void displace_normal_x4(__global const ts_vec4 *n, __global const ts_vec4 *mid, float4 u,
                               float4 v, float4 *nx, float4 *ny, float4 *nz)
{
    float4 wu[3], wv[3];
    displace_quad_weights_x4(u, wu);
    displace_quad_weights_x4(v, wv);
    /* displace_quad's rows: the v = 0 edge, v = 1/2, the v = 1 edge */
    ts_vec4 a[3] = {n[0], mid[1], n[2]}, m[3] = {mid[0], mid[4], mid[3]},
            b[3] = {n[1], mid[2], n[3]};
    float4 rx[3], ry[3], rz[3];
    for (int k = 0; k < 3; ++k) {
        rx[k] = (wu[0] * a[k].x + wu[2] * b[k].x) + wu[1] * m[k].x;
        ry[k] = (wu[0] * a[k].y + wu[2] * b[k].y) + wu[1] * m[k].y;
        rz[k] = (wu[0] * a[k].z + wu[2] * b[k].z) + wu[1] * m[k].z;
    }
    float4 sx = (wv[0] * rx[0] + wv[2] * rx[2]) + wv[1] * rx[1];
    float4 sy = (wv[0] * ry[0] + wv[2] * ry[2]) + wv[1] * ry[1];
    float4 sz = (wv[0] * rz[0] + wv[2] * rz[2]) + wv[1] * rz[1];
    float4 len = sqrt(sx * sx + sy * sy + sz * sz);
    int4 ok = len > 1e-12f;
    *nx = select((float4)(0.0f), sx / len, ok);
    *ny = select((float4)(0.0f), sy / len, ok);
    *nz = select((float4)(1.0f), sz / len, ok);
}

/* A ts_vec4's x, y, z in lanes 0-2 of a float4 (lane 3: w, never read). */
inline float4 vec4_lanes(__global const ts_vec4 *p)
{
    return vload4(0, (__global const float *)p);
}

/* displace_quad_restrict (lib/displace.h) with x, y, z in lanes: the same operations per
 * component in their order. */
TS_INLINE_ALWAYS void displace_quad_restrict_x4(float4 a, float4 m, float4 b, float t0, float t1,
                                                float4 out[3])
{
    float4 c = 2.0f * m - 0.5f * (a + b);
    float s0 = 1.0f - t0, s1 = 1.0f - t1;
    out[0] = (s0 * s0) * a + (2.0f * t0 * s0) * c + (t0 * t0) * b;
    out[1] = (s0 * s1) * a + (s0 * t1 + t0 * s1) * c + (t0 * t1) * b;
    out[2] = (s1 * s1) * a + (2.0f * t1 * s1) * c + (t1 * t1) * b;
}

/* displace_div_range (lib/displace.h) with x, y, z in lanes. */
inline void displace_div_range_x4(float4 lo, float4 hi, float rmin, float rmax, float4 *a,
                                  float4 *b)
{
    *a = fmax(select(lo / rmin, lo / rmax, lo >= 0.0f), -1.0f);
    *b = fmin(select(hi / rmin, hi / rmax, hi <= 0.0f), 1.0f);
}

/* displace_normal_box's first step: the normals' three rows (the v = 0 edge, v = 1/2, the v = 1
 * edge) restricted to [u0, u1], x, y, z in lanes. */
TS_INLINE_ALWAYS void displace_normal_rows_x4(__global const ts_vec4 *n,
                                              __global const ts_vec4 *mid, float u0, float u1,
                                              float4 rows[3][3])
{
    displace_quad_restrict_x4(vec4_lanes(n + 0), vec4_lanes(mid + 0), vec4_lanes(n + 1), u0, u1,
                              rows[0]);
    displace_quad_restrict_x4(vec4_lanes(mid + 1), vec4_lanes(mid + 4), vec4_lanes(mid + 2), u0, u1,
                              rows[1]);
    displace_quad_restrict_x4(vec4_lanes(n + 2), vec4_lanes(mid + 3), vec4_lanes(n + 3), u0, u1,
                              rows[2]);
}

/* displace_normal_box (lib/displace.h), the same bits, with x, y, z in the lanes of a float4
 * (build.cl): every lane runs the scalar operations of its component in their order; the
 * lengths rmin, rmax add their squares in the scalar order. displace_normal_box stays the
 * host's reference: test_dice_build compares the two through build_normal_box_probe. */
inline ts_box displace_normal_box_x4(__global const ts_vec4 *n, __global const ts_vec4 *mid,
                                     float u0, float v0, float u1, float v1)
{
    float4 rows[3][3], col[3];
    displace_normal_rows_x4(n, mid, u0, u1, rows);
    float4 lo = (float4)(INFINITY), hi = (float4)(-INFINITY);
    for (int k = 0; k < 3; ++k) {
        displace_quad_restrict_x4(rows[0][k], rows[1][k], rows[2][k], v0, v1, col);
        for (int j = 0; j < 3; ++j)
            lo = fmin(lo, col[j]), hi = fmax(hi, col[j]);
    }
    const float e = 4e-6f; /* displace_normal_box's rounding allowances */
    lo -= e, hi += e;
    float4 dd = fmax(fmax(lo, -hi), 0.0f);
    float rmin = sqrt(dd.x * dd.x + dd.y * dd.y + dd.z * dd.z);
    ts_box all = {-1.0f, -1.0f, -1.0f, 1.0f, 1.0f, 1.0f};
    if (!(rmin > 1e-6f)) return all;
    float4 ff = fmax(-lo, hi);
    float rmax = sqrt(ff.x * ff.x + ff.y * ff.y + ff.z * ff.z);
    float4 rlo, rhi;
    displace_div_range_x4(lo, hi, rmin, rmax, &rlo, &rhi);
    rlo -= e, rhi += e;
    ts_box r = {rlo.x, rlo.y, rlo.z, rhi.x, rhi.y, rhi.z};
    return r;
}

/* patch_quad_shading_normal (lib/patch.h), the same bits: the micro-quad's four corners
 * evaluated together where the displacement is noise, a corner per lane (the Bézier points,
 * their displacement normals, and the noise in displace_value_x4). shade takes the corners
 * from the diced grid where the patch is resident; this is the same function of (i, j, m). */
inline ts_vec4 patch_quad_shading_normal_x4(__global const ts_vec4 *cp, __global const ts_vec4 *n,
                                            __global const ts_vec4 *mid,
                                            __global const ts_patch_attr *a,
                                            __global const ts_xform *x, ts_tex_ctx tex, float u,
                                            float v, uint i, uint j, uint m, uint edges)
{
    if (!displace_is_noise(a))
        return patch_quad_shading_normal(cp, n, mid, a, x, tex, u, v, i, j, m, edges);
    float cu[4], cv[4]; /* the corners where dice put them */
    quadtree_quad_corners(edges, m, i, j, cu, cv);
    float4 pu = vload4(0, cu), pv = vload4(0, cv);
    float4 px, py, pz, nx, ny, nz;
    bezier_eval_x4(cp, pu, pv, &px, &py, &pz);
    float4 d = displace_value_x4(a, x, px, py, pz);
    displace_normal_x4(n, mid, pu, pv, &nx, &ny, &nz);
    /* patch_vertex's displaced points */
    float4 qx = px + d * nx, qy = py + d * ny, qz = pz + d * nz;
    ts_vec4 q[4] = {{qx.s0, qy.s0, qz.s0, d.s0},
                    {qx.s1, qy.s1, qz.s1, d.s1},
                    {qx.s2, qy.s2, qz.s2, d.s2},
                    {qx.s3, qy.s3, qz.s3, d.s3}};
    return patch_quad_normal(cp, u, v, q[0], q[1], q[2], q[3]);
}

/* interval_lerp (lib/noise.h) in eight lanes. */
TS_INLINE_ALWAYS void interval_lerp_x8(float8 alo, float8 ahi, float8 blo, float8 bhi, float8 t0,
                                       float8 t1, float8 *rlo, float8 *rhi)
{
    float8 l0 = alo + t0 * (blo - alo), l1 = alo + t1 * (blo - alo);
    float8 h0 = ahi + t0 * (bhi - ahi), h1 = ahi + t1 * (bhi - ahi);
    *rlo = fmin(l0, l1), *rhi = fmax(h0, h1);
}

/* noise3_cell_interval (lib/noise.h) in eight lanes: lane l bounds the noise over the box
 * [l, h] inside the lattice cell with corner c (floats holding integers, as noise3_interval
 * passes them), with the scalar operations in their order, so each lane has its bits. */
TS_INLINE_ALWAYS void noise3_cell_interval_x8(float8 cx, float8 cy, float8 cz, float8 lx, float8 ly,
                                              float8 lz, float8 hx, float8 hy, float8 hz,
                                              float8 *rlo, float8 *rhi)
{
    int8 ix = convert_int8(cx), iy = convert_int8(cy), iz = convert_int8(cz);
    float8 ax = lx - cx, ay = ly - cy, az = lz - cz;
    float8 bx = hx - cx, by = hy - cy, bz = hz - cz;
    float8 gx[8], gy[8], gz[8], clo[8], chi[8];
    noise_gradients_x8(ix, iy, iz, gx, gy, gz);
#pragma unroll
    for (int k = 0; k < 8; ++k) {
        int dx = k & 1, dy = (k >> 1) & 1, dz = k >> 2;
        float8 px = gx[k] * (ax - (float)dx), qx = gx[k] * (bx - (float)dx);
        float8 py = gy[k] * (ay - (float)dy), qy = gy[k] * (by - (float)dy);
        float8 pz = gz[k] * (az - (float)dz), qz = gz[k] * (bz - (float)dz);
        clo[k] = fmin(px, qx) + fmin(py, qy) + fmin(pz, qz);
        chi[k] = fmax(px, qx) + fmax(py, qy) + fmax(pz, qz);
    }
    float8 u0 = ax * ax * ax * (ax * (ax * 6.0f - 15.0f) + 10.0f);
    float8 u1 = bx * bx * bx * (bx * (bx * 6.0f - 15.0f) + 10.0f);
    float8 v0 = ay * ay * ay * (ay * (ay * 6.0f - 15.0f) + 10.0f);
    float8 v1 = by * by * by * (by * (by * 6.0f - 15.0f) + 10.0f);
    float8 w0 = az * az * az * (az * (az * 6.0f - 15.0f) + 10.0f);
    float8 w1 = bz * bz * bz * (bz * (bz * 6.0f - 15.0f) + 10.0f);
    float8 x00l, x00h, x10l, x10h, x01l, x01h, x11l, x11h, y0l, y0h, y1l, y1h;
    interval_lerp_x8(clo[0], chi[0], clo[1], chi[1], u0, u1, &x00l, &x00h);
    interval_lerp_x8(clo[2], chi[2], clo[3], chi[3], u0, u1, &x10l, &x10h);
    interval_lerp_x8(clo[4], chi[4], clo[5], chi[5], u0, u1, &x01l, &x01h);
    interval_lerp_x8(clo[6], chi[6], clo[7], chi[7], u0, u1, &x11l, &x11h);
    interval_lerp_x8(x00l, x00h, x10l, x10h, v0, v1, &y0l, &y0h);
    interval_lerp_x8(x01l, x01h, x11l, x11h, v0, v1, &y1l, &y1h);
    interval_lerp_x8(y0l, y0h, y1l, y1h, w0, w1, rlo, rhi);
}

/* The (octave, cell) tasks of displace_interval's cells waiting for a float8 evaluation, a
 * task a lane: the cell's corner, the part of the octave's box inside it, and the slot of
 * the octave's interval it folds into (leaf q's octave o: o * 4 + q in a 2 x 2 block, so
 * that the tasks of several leaves share the lanes). Lanes are filled by select
 * (noise_task_add), not by scalar stores read back as vectors: a vector load of eight
 * just-stored floats waits for the stores to retire. */
typedef struct noise_tasks {
    float8 cx, cy, cz, lx, ly, lz, hx, hy, hz;
    uint slot[8], n;
} noise_tasks;

/* Task n of the lanes: lane n gets (c, l, h); with n = 0 every lane does, so that spare lanes
 * repeat task 0 (evaluated, not read). */
TS_INLINE_ALWAYS void noise_task_add(noise_tasks *t, float4 c, float4 l, float4 h, uint slot)
{
    if (t->n == 0u) {
        t->cx = (float8)(c.x), t->cy = (float8)(c.y), t->cz = (float8)(c.z);
        t->lx = (float8)(l.x), t->ly = (float8)(l.y), t->lz = (float8)(l.z);
        t->hx = (float8)(h.x), t->hy = (float8)(h.y), t->hz = (float8)(h.z);
    } else {
        int8 at = (int8)(0, 1, 2, 3, 4, 5, 6, 7) == (int8)((int)t->n);
        t->cx = select(t->cx, (float8)(c.x), at), t->cy = select(t->cy, (float8)(c.y), at);
        t->cz = select(t->cz, (float8)(c.z), at), t->lx = select(t->lx, (float8)(l.x), at);
        t->ly = select(t->ly, (float8)(l.y), at), t->lz = select(t->lz, (float8)(l.z), at);
        t->hx = select(t->hx, (float8)(h.x), at), t->hy = select(t->hy, (float8)(h.y), at);
        t->hz = select(t->hz, (float8)(h.z), at);
    }
    t->slot[t->n++] = slot;
}

/* Evaluates the waiting tasks and folds each into its slot's interval in task order: the
 * scalar loop's fmin / fmax sequence. */
TS_INLINE_ALWAYS void noise_tasks_run(noise_tasks *t, float *lo, float *hi)
{
    if (t->n == 0u) return;
    float8 rlo, rhi;
    noise3_cell_interval_x8(t->cx, t->cy, t->cz, t->lx, t->ly, t->lz, t->hx, t->hy, t->hz, &rlo,
                            &rhi);
    float rl[8], rh[8];
    vstore8(rlo, 0, rl);
    vstore8(rhi, 0, rh);
    for (uint k = 0; k < t->n; ++k) {
        uint s = t->slot[k];
        lo[s] = fmin(lo[s], rl[k]), hi[s] = fmax(hi[s], rh[k]);
    }
    t->n = 0u;
}

/* displace_interval (lib/displace.h) in two halves, the same bits, for the noise functions
 * (the caller checked); build.cl's leaves, whose work-item takes the octaves' frequencies f
 * and weights w from displace_octave_steps once for all its leaves (the scalar loop's running
 * products). This first half, over the world box [l, h]:
 * noise3_interval's cells of every octave queued as tasks into slots base + o * stride of lo,
 * hi (evaluated whenever eight wait; the caller runs the rest), or the global bound
 * [-NOISE_BOUND, NOISE_BOUND] where the octave's box spans too many cells (noise3_interval's
 * `full`, which the widening in displace_interval_sum leaves as it is). A leaf's octaves cover 4-6
 * cells on forest-100's bark, so one leaf alone left a third to a half of the lanes spare;
 * build_leaves on CPU devices queues the cells of a 2 x 2 block of leaves into the same lanes
 * (this function for trimmed and stitched trees, and a leaf alone on GPUs; leaf4.h
 * block_leaf_boxes, the same queue from the four leaves' boxes in float4 lanes, for the others),
 * the same bits.
 * displace_interval stays the host's reference: test_dice_build and test_bottom_level compare the
 * built trees bit for bit. */
inline void displace_interval_tasks(__global const ts_patch_attr *a, __global const ts_xform *x,
                                    float lx, float ly, float lz, float hx, float hy, float hz,
                                    const float *f, uint base, uint stride, noise_tasks *t,
                                    float *lo, float *hi)
{
    float olo[3], ohi[3];
    displace_object_box(x, lx, ly, lz, hx, hy, hz, olo, ohi);
    uint n = displace_octaves(a);
    /* x, y, z in lanes 0-2; lane 3 repeats z, so all() and any() test exactly x, y, z */
    float4 ol = (float4)(olo[0], olo[1], olo[2], olo[2]),
           oh = (float4)(ohi[0], ohi[1], ohi[2], ohi[2]);
    for (uint o = 0; o < n; ++o) { /* noise3_interval's cells, as tasks */
        float4 bl = fmin(ol * f[o], oh * f[o]), bh = fmax(ol * f[o], oh * f[o]);
        float4 c0 = floor(bl), c1 = floor(bh);
        uint slot = base + o * stride;
        lo[slot] = -NOISE_BOUND, hi[slot] = NOISE_BOUND; /* the global bound, which the sum keeps */
        if (!all(c1 - c0 <= 1.0f)) continue;
        if (any(fabs(c0) > 1e6f)) continue;
        lo[slot] = INFINITY, hi[slot] = -INFINITY;
        /* The cells c0 + (dx, dy, dz) <= c1 (integers, c1 - c0 in {0, 1}), x fastest. */
        int nx = c1.x > c0.x ? 2 : 1, ny = c1.y > c0.y ? 2 : 1, nz = c1.z > c0.z ? 2 : 1;
        for (int dz = 0; dz < nz; ++dz)
            for (int dy = 0; dy < ny; ++dy)
                for (int dx = 0; dx < nx; ++dx) {
                    float4 c = c0 + (float4)((float)dx, (float)dy, (float)dz, 0.0f);
                    noise_task_add(t, c, fmax(bl, c), fmin(bh, c + 1.0f), slot);
                    if (t->n == 8u) noise_tasks_run(t, lo, hi);
                }
    }
}

/* The second half: the octaves' intervals in slots base + o * stride, widened and summed in the
 * scalar order. */
inline ts_interval displace_interval_sum(__global const ts_patch_attr *a, const float *w, uint base,
                                         uint stride, const float *lo, const float *hi)
{
    uint n = displace_octaves(a);
    ts_interval sum = {0.0f, 0.0f};
    for (uint o = 0; o < n; ++o) {
        uint slot = base + o * stride;
        /* noise3_interval's widening for the point evaluation's rounding (the global bound stays
         * itself: -NOISE_BOUND - 1e-5 rounds to at most -NOISE_BOUND) */
        ts_interval v = {fmax(lo[slot] - 1e-5f, -NOISE_BOUND), fmin(hi[slot] + 1e-5f, NOISE_BOUND)};
        displace_interval_add(a, v, w[o], &sum);
    }
    return displace_interval_end(a, sum, n);
}

#endif
