/* leaf4.h — the leaf boxes of `build` that `bottom_level` makes too (kernels only): the box of
 * a micro-quad's undisplaced corners (base_box), and on CPU devices the boxes of a 2 x 2 block
 * of leaves a leaf per float4 lane (block_leaf_boxes). build.cl stores them as the tree's
 * leaves; bottom_level.cl makes the leaves of the blocks a ray enters where a patch is traced
 * through its skeleton (the same functions, so the same bits). */
#ifndef TS_LEAF4_H
#define TS_LEAF4_H

#include "lib/shared_types.h"
#include "lib/displace.h"
#include "lib/noise4.h"
#include "lib/quadtree.h"

/* The box of four corners (x, y, z, 0), folded in base_box's order. */
TS_INLINE_ALWAYS ts_box corner_fold(float4 q0, float4 q1, float4 q2, float4 q3)
{
    float4 lo = fmin(fmin(fmin(fmin((float4)(INFINITY), q0), q1), q2), q3);
    float4 hi = fmax(fmax(fmax(fmax((float4)(-INFINITY), q0), q1), q2), q3);
    ts_box b = {lo.x, lo.y, lo.z, hi.x, hi.y, hi.z};
    return b;
}

/* Box of the undisplaced corners of micro-quad (i, j), h = 2^-m: the Bézier patch cp at the
 * four corners, a corner per lane (bezier_eval_x4: bezier_eval's bits), folded corner by
 * corner with x, y, z in lanes as the host's base_box (host/ref/dice_build_ref.c) adds them:
 * the same bits, and no read of the diced grid. */
inline ts_box base_box(__global const ts_vec4 *cp, uint i, uint j, float h)
{
    float4 cu = (float4)((float)i * h, (float)(i + 1u) * h, (float)i * h, (float)(i + 1u) * h);
    float4 cv = (float4)((float)j * h, (float)j * h, (float)(j + 1u) * h, (float)(j + 1u) * h);
    float4 x, y, z;
    bezier_eval_x4(cp, cu, cv, &x, &y, &z);
    float4 q0 = (float4)(x.s0, y.s0, z.s0, 0.0f), q1 = (float4)(x.s1, y.s1, z.s1, 0.0f),
           q2 = (float4)(x.s2, y.s2, z.s2, 0.0f), q3 = (float4)(x.s3, y.s3, z.s3, 0.0f);
    return corner_fold(q0, q1, q2, q3);
}

#ifdef TS_CPU_LANES
/* Boxes of a work-item's 2 x 2 leaves (i0 + (q & 1), j0 + (q >> 1)), leaf q in lane q. */
typedef struct block_box4 {
    float4 lx, ly, lz, hx, hy, hz;
} block_box4;

/* b as block_box's layout (lo_x, lo_y, lo_z, hi_x, hi_y, hi_z of the four leaves, four floats
 * each), written by vector stores so that each float read later is forwarded from one store. */
TS_INLINE_ALWAYS void block_spill(block_box4 b, float s[24])
{
    vstore4(b.lx, 0, s), vstore4(b.ly, 1, s), vstore4(b.lz, 2, s);
    vstore4(b.hx, 3, s), vstore4(b.hy, 4, s), vstore4(b.hz, 5, s);
}
#endif

/* Lane q of a block's boxes in block_spill's layout (lo_x, lo_y, lo_z, hi_x, hi_y, hi_z of the
 * four leaves, four floats each), from s = the boxes + q. Kept as floats written by vector
 * stores, so that each read is forwarded from one store. */
TS_INLINE_ALWAYS ts_box block_box(const float *s)
{
    ts_box b = {s[0], s[4], s[8], s[12], s[16], s[20]};
    return b;
}

#ifdef TS_CPU_LANES

/* base_box of the 2 x 2 leaves (i0 + (q & 1), j0 + (q >> 1)), q = 0..3: their 9 corners,
 * bezier_eval_x4's operations per point in their order (the same bits), with the u-rows shared: the
 * 12 row sums of bezier_eval at the three u in lanes, then the sums over v at each of the three v.
 * A third of the operations of four base_box calls. */
TS_INLINE_ALWAYS block_box4 block_base_boxes(__global const ts_vec4 *cp, uint i0, uint j0, float h)
{
    float4 cu =
        (float4)((float)i0 * h, (float)(i0 + 1u) * h, (float)(i0 + 2u) * h, (float)(i0 + 2u) * h);
    float4 cv =
        (float4)((float)j0 * h, (float)(j0 + 1u) * h, (float)(j0 + 2u) * h, (float)(j0 + 2u) * h);
    float4 bu[4], bv[4], rx[4], ry[4], rz[4];
    bezier_basis_x4(cu, bu);
    bezier_basis_x4(cv, bv);
    bezier_rows_x4(cp, bu, rx, ry, rz);
    float4 x[3], y[3], z[3]; /* the corners at v = cv[v], u = cu[lane] */
#define BLOCK_ROW(v, sv)                                                                           \
    {                                                                                              \
        float4 w[4] = {(float4)(bv[0].sv), (float4)(bv[1].sv), (float4)(bv[2].sv),                 \
                       (float4)(bv[3].sv)};                                                        \
        x[v] = bezier_sum4_v4(w, rx[0], rx[1], rx[2], rx[3]);                                      \
        y[v] = bezier_sum4_v4(w, ry[0], ry[1], ry[2], ry[3]);                                      \
        z[v] = bezier_sum4_v4(w, rz[0], rz[1], rz[2], rz[3]);                                      \
    }
    BLOCK_ROW(0, s0)
    BLOCK_ROW(1, s1)
    BLOCK_ROW(2, s2)
#undef BLOCK_ROW
    /* corner_fold's order per leaf: (i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1) */
    block_box4 b;
#define BLOCK_FOLD(r, lo, hi)                                                                      \
    {                                                                                              \
        /* element by element: Oclgrind 21.10's --uninitialized crashes on (float4)(a.s01, b.s01)  \
         */                                                                                        \
        float4 c00 = (float4)(r[0].s0, r[0].s1, r[1].s0, r[1].s1);                                 \
        float4 c10 = (float4)(r[0].s1, r[0].s2, r[1].s1, r[1].s2);                                 \
        float4 c01 = (float4)(r[1].s0, r[1].s1, r[2].s0, r[2].s1);                                 \
        float4 c11 = (float4)(r[1].s1, r[1].s2, r[2].s1, r[2].s2);                                 \
        lo = fmin(fmin(fmin(fmin((float4)(INFINITY), c00), c10), c01), c11);                       \
        hi = fmax(fmax(fmax(fmax((float4)(-INFINITY), c00), c10), c01), c11);                      \
    }
    BLOCK_FOLD(x, b.lx, b.hx)
    BLOCK_FOLD(y, b.ly, b.hy)
    BLOCK_FOLD(z, b.lz, b.hz)
#undef BLOCK_FOLD
    return b;
}

/* displace_normal_box_x4 of the 2 x 2 leaves (i0 + (q & 1), j0 + (q >> 1)), q = 0..3, the same
 * bits: the rows restricted to the block's two u-intervals (x, y, z
 * in lanes, displace_quad_restrict_x4), then the columns, the box and its normalisation with the
 * four leaves in the lanes of a float4 per component, each lane displace_normal_box's operations in
 * their order. */
TS_INLINE_ALWAYS block_box4 block_normal_boxes(__global const ts_vec4 *n,
                                               __global const ts_vec4 *mid, uint i0, uint j0,
                                               float h)
{
    float u0 = (float)i0 * h, u1 = (float)(i0 + 1u) * h, u2 = (float)(i0 + 2u) * h;
    float4 ra[3][3], rb[3][3]; /* rows restricted to [u0, u1] (leaves 0, 2), [u1, u2] (1, 3) */
    displace_normal_rows_x4(n, mid, u0, u1, ra);
    displace_normal_rows_x4(n, mid, u1, u2, rb);
    /* displace_quad_restrict's weights in v, a leaf per lane */
    float va = (float)j0 * h, vb = (float)(j0 + 1u) * h, vc = (float)(j0 + 2u) * h;
    float4 t0 = (float4)(va, va, vb, vb), t1 = (float4)(vb, vb, vc, vc);
    float4 s0 = 1.0f - t0, s1 = 1.0f - t1;
    float4 w[3][3] = {{s0 * s0, 2.0f * t0 * s0, t0 * t0},
                      {s0 * s1, s0 * t1 + t0 * s1, t0 * t1},
                      {s1 * s1, 2.0f * t1 * s1, t1 * t1}};
    float4 lx = (float4)(INFINITY), ly = lx, lz = lx, hx = (float4)(-INFINITY), hy = hx, hz = hx;
    for (int k = 0; k < 3; ++k) {
#define BLOCK_COLUMN(comp, lo, hi)                                                                 \
    {                                                                                              \
        float4 a = (float4)(ra[0][k].comp, rb[0][k].comp, ra[0][k].comp, rb[0][k].comp);           \
        float4 m = (float4)(ra[1][k].comp, rb[1][k].comp, ra[1][k].comp, rb[1][k].comp);           \
        float4 e = (float4)(ra[2][k].comp, rb[2][k].comp, ra[2][k].comp, rb[2][k].comp);           \
        float4 c = 2.0f * m - 0.5f * (a + e);                                                      \
        for (int j = 0; j < 3; ++j) {                                                              \
            float4 o = w[j][0] * a + w[j][1] * c + w[j][2] * e;                                    \
            lo = fmin(lo, o), hi = fmax(hi, o);                                                    \
        }                                                                                          \
    }
        BLOCK_COLUMN(x, lx, hx)
        BLOCK_COLUMN(y, ly, hy)
        BLOCK_COLUMN(z, lz, hz)
#undef BLOCK_COLUMN
    }
    const float e = 4e-6f; /* displace_normal_box's rounding allowances */
    lx -= e, ly -= e, lz -= e, hx += e, hy += e, hz += e;
    float4 dx = fmax(fmax(lx, -hx), 0.0f), dy = fmax(fmax(ly, -hy), 0.0f),
           dz = fmax(fmax(lz, -hz), 0.0f);
    float4 rmin = sqrt(dx * dx + dy * dy + dz * dz);
    float4 fx = fmax(-lx, hx), fy = fmax(-ly, hy), fz = fmax(-lz, hz);
    float4 rmax = sqrt(fx * fx + fy * fy + fz * fz);
    int4 all = !(rmin > 1e-6f); /* displace_normal_box's [-1, 1]^3 */
    float4 ax = fmax(select(lx / rmin, lx / rmax, lx >= 0.0f), -1.0f) - e;
    float4 ay = fmax(select(ly / rmin, ly / rmax, ly >= 0.0f), -1.0f) - e;
    float4 az = fmax(select(lz / rmin, lz / rmax, lz >= 0.0f), -1.0f) - e;
    float4 bx = fmin(select(hx / rmin, hx / rmax, hx <= 0.0f), 1.0f) + e;
    float4 by = fmin(select(hy / rmin, hy / rmax, hy <= 0.0f), 1.0f) + e;
    float4 bz = fmin(select(hz / rmin, hz / rmax, hz <= 0.0f), 1.0f) + e;
    ax = select(ax, (float4)(-1.0f), all), ay = select(ay, (float4)(-1.0f), all);
    az = select(az, (float4)(-1.0f), all), bx = select(bx, (float4)(1.0f), all);
    by = select(by, (float4)(1.0f), all), bz = select(bz, (float4)(1.0f), all);
    block_box4 b = {ax, ay, az, bx, by, bz};
    return b;
}
#endif

#ifdef TS_CPU_LANES
/* build.cl leaf_clamp of the four boxes: each clamped to the patch box p. */
TS_INLINE_ALWAYS block_box4 block_clamp(block_box4 b, ts_box p)
{
    b.lx = fmax(b.lx, p.lo_x), b.ly = fmax(b.ly, p.lo_y), b.lz = fmax(b.lz, p.lo_z);
    b.hx = fmin(b.hx, p.hi_x), b.hy = fmin(b.hy, p.hi_y), b.hz = fmin(b.hz, p.hi_z);
    return b;
}

/* The boxes of the 2 x 2 leaves (i0 + (q & 1), j0 + (q >> 1)) of a noise-displaced or an
 * undisplaced tree at m >= 1, made together, leaf q in lane q of each float4: leaf_begin, the
 * noise intervals (the cells of displace_interval_tasks, queued into the lanes of tasks, and
 * displace_interval_sum) and leaf_finish up to the clamp to the patch box, each lane their
 * operations in their order (the same bits; undisplaced, leaf_begin and the clamp). build.cl
 * block_leaves stores a noise-displaced tree's (build_leaves makes an undisplaced tree's leaf by
 * leaf from block_base_boxes, the same bits); bottom_level.cl bl_skeleton tests them. Not for
 * trimmed, stitched or triangle-mode trees, which build_leaves finishes leaf by leaf. */
TS_INLINE_ALWAYS block_box4 block_leaf_boxes(
    __global const ts_patch_attr *a, __global const ts_xform *ax, __global const ts_vec4 *cp0,
    __global const ts_vec4 *cp, __global const ts_vec4 *cn, __global const ts_vec4 *mn, ts_vec4 e,
    float s, float h, uint i0, uint j0, ts_box pbox, const float *freq, const float *weight,
    uint octaves, noise_tasks *tasks, float *vlo, float *vhi)
{
    block_box4 b = block_base_boxes(cp, i0, j0, h);
    float4 mag = fmax(fmax(fabs(b.lx), fabs(b.hx)),
                      fmax(fmax(fabs(b.ly), fabs(b.hy)), fmax(fabs(b.lz), fabs(b.hz))));
    float4 ex = e.x * s + 4e-7f * mag, ey = e.y * s + 4e-7f * mag, ez = e.z * s + 4e-7f * mag;
    b.lx -= ex, b.hx += ex, b.ly -= ey, b.hy += ey, b.lz -= ez, b.hz += ez;
    if (a->disp_kind == TS_DISP_NONE) return block_clamp(b, pbox); /* leaf_finish: the clamp */
    block_box4 b0 = b; /* where the noise is evaluated: time 0 */
    if (cp != cp0) {
        b0 = block_base_boxes(cp0, i0, j0, h);
        b0.lx -= ex, b0.hx += ex, b0.ly -= ey, b0.hy += ey, b0.lz -= ez, b0.hz += ez;
    }
    /* displace_interval_tasks in the lanes: displace_object_box (lib/displace.h) a leaf per
     * lane, then per octave the cells' range, and the cells queued leaf by leaf (each slot's
     * cells in their order) */
    float4 ol[3], oh[3];
    __global const float *rows[3] = {ax->r0, ax->r1, ax->r2};
    for (int r = 0; r < 3; ++r) {
        float4 l = (float4)(rows[r][3]), hh = l;
        float4 e0 = rows[r][0] * b0.lx, e1 = rows[r][0] * b0.hx;
        l += fmin(e0, e1), hh += fmax(e0, e1);
        e0 = rows[r][1] * b0.ly, e1 = rows[r][1] * b0.hy;
        l += fmin(e0, e1), hh += fmax(e0, e1);
        e0 = rows[r][2] * b0.lz, e1 = rows[r][2] * b0.hz;
        l += fmin(e0, e1), hh += fmax(e0, e1);
        float4 slack = 1e-6f * (fabs(l) + fabs(hh));
        ol[r] = l - slack, oh[r] = hh + slack;
    }
    for (uint o = 0; o < octaves; ++o) {
        float f = freq[o];
        float4 bl[3], bh[3], c0[3];
        int4 ok = (int4)(-1), ext = (int4)(0);
        for (int r = 0; r < 3; ++r) {
            bl[r] = fmin(ol[r] * f, oh[r] * f), bh[r] = fmax(ol[r] * f, oh[r] * f);
            c0[r] = floor(bl[r]);
            float4 c1 = floor(bh[r]);
            ok &= c1 - c0[r] <= 1.0f;
            ok &= !(fabs(c0[r]) > 1e6f);
            ext |= (c1 > c0[r]) & (int4)(1 << r); /* the axes spanning two cells */
        }
        /* every slot the global bound, or empty for its cells' folds */
        vstore4(select((float4)(-NOISE_BOUND), (float4)(INFINITY), ok), o, vlo);
        vstore4(select((float4)(NOISE_BOUND), (float4)(-INFINITY), ok), o, vhi);
        float sp[3 * 12];
        int spi[8];
        for (int r = 0; r < 3; ++r)
            vstore4(bl[r], r, sp), vstore4(bh[r], 3 + r, sp), vstore4(c0[r], 6 + r, sp);
        vstore4(ok, 0, spi), vstore4(ext, 1, spi);
        for (uint q = 0; q < 4u; ++q) {
            if (!spi[q]) continue;
            float4 l = (float4)(sp[q], sp[4u + q], sp[8u + q], sp[8u + q]);
            float4 hq = (float4)(sp[12u + q], sp[16u + q], sp[20u + q], sp[20u + q]);
            float4 c = (float4)(sp[24u + q], sp[28u + q], sp[32u + q], 0.0f);
            int x2 = spi[4u + q];
            int nx = x2 & 1 ? 2 : 1, ny = x2 & 2 ? 2 : 1, nz = x2 & 4 ? 2 : 1;
            for (int dz = 0; dz < nz; ++dz)
                for (int dy = 0; dy < ny; ++dy)
                    for (int dx = 0; dx < nx; ++dx) {
                        float4 cc = c + (float4)((float)dx, (float)dy, (float)dz, 0.0f);
                        noise_task_add(tasks, cc, fmax(l, cc), fmin(hq, cc + 1.0f), o * 4u + q);
                        if (tasks->n == 8u) noise_tasks_run(tasks, vlo, vhi);
                    }
        }
    }
    noise_tasks_run(tasks, vlo, vhi);
    /* displace_interval_sum, displace_interval_add and displace_interval_end in the lanes */
    float4 slo = (float4)(0.0f), shi = (float4)(0.0f);
    int ridged = a->disp_kind == TS_DISP_RIDGED;
    for (uint o = 0; o < octaves; ++o) {
        float4 lo = fmax(vload4(o, vlo) - 1e-5f, -NOISE_BOUND);
        float4 hi = fmin(vload4(o, vhi) + 1e-5f, NOISE_BOUND);
        if (ridged) { /* 1 - 2|v| */
            float4 alo = select(select((float4)(0.0f), -hi, hi <= 0.0f), lo, lo >= 0.0f);
            float4 ahi = fmax(fabs(lo), fabs(hi));
            lo = 1.0f - 2.0f * ahi;
            hi = 1.0f - 2.0f * alo;
        }
        float4 p0 = weight[o] * lo, p1 = weight[o] * hi;
        slo += fmin(p0, p1);
        shi += fmax(p0, p1);
    }
    float4 d0 = a->disp_amplitude * slo, d1 = a->disp_amplitude * shi;
    float slack = 1e-5f * fabs(a->disp_amplitude) * (float)octaves;
    float4 dlo = fmin(d0, d1) - slack, dhi = fmax(d0, d1) + slack;
    /* leaf_finish: grown by the interval times the normal box, clamped, stored */
    block_box4 nb = block_normal_boxes(cn, mn, i0, j0, h);
    float4 grow = 4e-7f * (mag + fmax(fabs(dlo), fabs(dhi)));
#define BLOCK_GROW(l, hh, nl, nh)                                                                  \
    {                                                                                              \
        float4 p0 = dlo * nl, p1 = dlo * nh, p2 = dhi * nl, p3 = dhi * nh;                         \
        l += fmin(fmin(p0, p1), fmin(p2, p3)) - grow;                                              \
        hh += fmax(fmax(p0, p1), fmax(p2, p3)) + grow;                                             \
    }
    BLOCK_GROW(b.lx, b.hx, nb.lx, nb.hx)
    BLOCK_GROW(b.ly, b.hy, nb.ly, nb.hy)
    BLOCK_GROW(b.lz, b.hz, nb.lz, nb.hz)
#undef BLOCK_GROW
    return block_clamp(b, pbox);
}
#endif

#endif
