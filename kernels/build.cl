/* build.cl — stage `build` (Hanika §3.2.1, §3.3): the implicit complete quad-tree of each tree
 * of a batch, linear in its micro-polygons, stored as SoA sibling groups (lib/quadtree.h).
 * build_leaves (one launch per LOD m in the batch): leaf k (Morton order) gets a box that
 *   holds the displaced surface over the micro-quad's whole parameter square, not only its
 *   four vertices, so coarse leaves span every finer tessellation and patches diced at
 *   different m stay hole-free when boxes are the geometry (§3.3):
 *     undisplaced part: box of the four undisplaced corners (the Bézier patch of the time
 *       sample at the corners, a corner per lane: lib/noise4.h bezier_eval_x4; on CPU devices
 *       the 2 x 2 leaves of a work-item from their 9 corners, block_base_boxes) grown by the
 *       flatness bound E0 * 4^-m (lib/patch.h patch_flatness),
 *     displacement part: [d] x [N] per axis, [d] by interval arithmetic on the noise over
 *       the time-0 undisplaced box (lib/displace.h; its cells eight at a time in float8
 *       lanes, on CPU devices the cells of a work-item's TS_BUILD_LEAF_RUN leaves sharing
 *       them, lib/noise4.h displace_interval_tasks), [N] the box of the displacement normal
 *       over the square (lib/displace.h displace_normal_box, with x, y, z in float4 lanes:
 *       lib/noise4.h displace_normal_box_x4; on CPU devices the 2 x 2 leaves of a work-item
 *       together, a leaf per lane, block_normal_boxes).
 *   On CPU devices the 2 x 2 leaves of a noise-displaced tree (not trimmed, stitched, rough or
 *   in triangle mode) are built together, a leaf per float4 lane from the corners to the
 *   group's store, their noise cells queued into the float8 lanes (block_leaves): forest-100's
 *   `build` took a third less than with one leaf at a time through the same functions.
 *   Every lane form runs the scalar operations in their order: the leaf boxes have the bits
 *   of the plain-C reference (host/ref/dice_build_ref.c; tests/test_bottom_level.c compares
 *   the trees, tests/test_dice_build.c the normal boxes through build_normal_box_probe).
 *   Each leaf also gets its tight box, the box of its four diced vertices (lib/quadtree.h
 *   tight_leaf_box), stored as 8-bit codes inside the leaf box in the arena `codes` beside
 *   `groups` (ts_tight4; in triangle mode the two are the same box).
 * build_level (one launch per level l, deepest first): node k of level l of every tree with
 *   m > l (a prefix of the batch's tree list, which is sorted by decreasing m) gets the union
 *   of its four children — the bottom-up min-max reduction — and the union of their decoded
 *   tight boxes as its codes. The root group's lanes 1-3 are left empty. On CPU devices a
 *   work-item of build_leaves makes the parents of its two sibling groups too (level m - 1,
 *   build_parents: the same union, read back from its own stores), and build_level runs only
 *   for the levels above: its launch over m - 1 was three quarters of its work.
 * Reads: trees, segments (the patch built is each segment's shape), control points, grid (only for
 * tight boxes: triangle mode, rough patches, stitched edges; dice need not have run otherwise),
 * corner normals,
 * attributes, transforms, flatness, patch boxes (every leaf box is clamped to its patch's top-level
 * box), textures (the min-max tiles under the leaves' st rectangles must be resident; a cut-out
 * patch's mask tiles at level 0), trim segments (a TS_SEG_TRIMMED segment's micro-quads whose
 * centres its trim, or its cutout mask, removes get empty boxes, lo > hi: lib/trim.h,
 * lib/texture.h tex_cutout_keeps). Writes:
 * groups[group_first + time * quadtree_group_count(m) ...] and codes[the same]. Invariants:
 * every vertex of a micro-quad kept lies in its leaf box and in its decoded tight box; every inner
 * box is the union of its children, every inner tight box holds its children's
 * (tests/test_dice_build.c, tests/test_bounds.c). */
#include "lib/shared_types.h"
#include "lib/displace.h"
#include "lib/noise4.h"
#include "lib/quadtree.h"
#include "lib/trim.h"

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

/* A leaf box clamped to the patch's top-level box (scene_patch_box: the control hull of
 * both time samples grown by the displacement bound and a few ulps). Both contain the
 * leaf's piece of surface, so their intersection does too; without it a coarse leaf (its
 * corners' box grown by the flatness bound e / 4^m) can stick out of the patch box, and a
 * ray could hit it nearer than the patch box the top level sorted it by (test_scene). */
inline ts_box leaf_clamp(ts_box b, ts_box p)
{
    b.lo_x = fmax(b.lo_x, p.lo_x), b.lo_y = fmax(b.lo_y, p.lo_y), b.lo_z = fmax(b.lo_z, p.lo_z);
    b.hi_x = fmin(b.hi_x, p.hi_x), b.hi_y = fmin(b.hi_y, p.hi_y), b.hi_z = fmin(b.hi_z, p.hi_z);
    return b;
}

/* [lo, hi] * [a, b] for intervals. */
inline float2 interval_mul(float lo, float hi, float a, float b)
{
    float p0 = lo * a, p1 = lo * b, p2 = hi * a, p3 = hi * b;
    return (float2)(fmin(fmin(p0, p1), fmin(p2, p3)), fmax(fmax(p0, p1), fmax(p2, p3)));
}

/* Lane q of a block's boxes (block_base_boxes, block_normal_boxes: lo_x, lo_y, lo_z, hi_x, hi_y,
 * hi_z of the four leaves, four floats each), from s = the boxes + q. Kept as floats written by
 * vector stores, so that each read is forwarded from one store. */
TS_INLINE_ALWAYS ts_box block_box(const float *s)
{
    ts_box b = {s[0], s[4], s[8], s[12], s[16], s[20]};
    return b;
}

/* Starts leaf k = (i, j) of a tree at m: a micro-quad trimmed or cut away gets a box no ray
 * enters, a leaf in triangle mode (tight) the box of its diced vertices, both stored (returns
 * 0); any other gets *b, the box of its undisplaced corners on cp (the tree's time sample)
 * grown by the flatness e * s and a few ulps for the corners' rounding, *mag their magnitude,
 * *b0 the same box at time 0 (cp0: where the noise is evaluated), *tb its tight box (0 unless
 * coded), and returns 1. The corners' boxes on cp and cp0 come from pre and pre0 where the caller
 * made them (block_base_boxes), else from base_box. */
TS_INLINE_ALWAYS int leaf_begin(__global const ts_patch_attr *a, __global const ts_vec4 *trim_seg,
                                ts_tex_ctx tex, __global const ts_vec4 *cp0,
                                __global const ts_vec4 *cp, ts_vec4 e, float s,
                                __global const ts_vec4 *g, uint n, uint i, uint j, uint m, float h,
                                uint seg_flags, uint tight, uint coded, ts_box pbox,
                                __global ts_box4 *groups, __global ts_tight4 *codes, uint k,
                                const float *pre, const float *pre0, ts_box *b, ts_box *b0,
                                ts_box *tb, float *mag)
{
    if ((seg_flags & TS_SEG_TRIMMED) != 0u &&
        !patch_keeps(a, trim_seg, tex, quadtree_centre(i, m), quadtree_centre(j, m))) {
        ts_box empty = {1e30f, 1e30f, 1e30f, -1e30f, -1e30f, -1e30f};
        quadtree_store(groups, codes, m, k, empty, empty, coded);
        return 0;
    }
    ts_box zero = {0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
    *tb = tight || coded ? leaf_clamp(tight_leaf_box(g, n, i, j), pbox) : zero;
    if (tight) {
        quadtree_store(groups, codes, m, k, *tb, *tb, 0u);
        return 0;
    }
    *b = pre ? block_box(pre) : base_box(cp, i, j, h);
    *mag = box_magnitude(*b);
    float ex = e.x * s + 4e-7f * *mag, ey = e.y * s + 4e-7f * *mag, ez = e.z * s + 4e-7f * *mag;
    b->lo_x -= ex, b->hi_x += ex, b->lo_y -= ey, b->hi_y += ey, b->lo_z -= ez, b->hi_z += ez;
    *b0 = *b;
    if (cp != cp0 && a->disp_kind != TS_DISP_NONE && a->disp_kind != TS_DISP_TEXTURE) {
        *b0 = pre0 ? block_box(pre0) : base_box(cp0, i, j, h);
        b0->lo_x -= ex, b0->hi_x += ex, b0->lo_y -= ey, b0->hi_y += ey, b0->lo_z -= ez,
            b0->hi_z += ez;
    }
    return 1;
}

/* Finishes leaf k = (i, j) of a tree at m from b, the box of its undisplaced corners grown by
 * the flatness (mag: their magnitude): where displaced, grown by the displacement interval d
 * times the box of the displacement normal over the micro-quad's whole parameter square;
 * with a stitched edge, by the box of its diced vertices; clamped to the patch box and
 * stored with its tight box tb. */
TS_INLINE_ALWAYS void leaf_finish(ts_box b, float mag, ts_interval d, uint displaced,
                                  __global const ts_vec4 *cn, __global const ts_vec4 *mn,
                                  __global const ts_vec4 *g, uint n, uint i, uint j, float h,
                                  uint seg_flags, ts_box pbox, __global ts_box4 *groups,
                                  __global ts_tight4 *codes, uint m, uint k, ts_box tb, uint coded,
                                  const float *pre_nb)
{
    if (displaced) {
        ts_box nb = pre_nb ? block_box(pre_nb)
                           : displace_normal_box_x4(cn, mn, (float)i * h, (float)j * h,
                                                    (float)(i + 1u) * h, (float)(j + 1u) * h);
        float2 ox = interval_mul(d.lo, d.hi, nb.lo_x, nb.hi_x);
        float2 oy = interval_mul(d.lo, d.hi, nb.lo_y, nb.hi_y);
        float2 oz = interval_mul(d.lo, d.hi, nb.lo_z, nb.hi_z);
        float slack = 4e-7f * (mag + fmax(fabs(d.lo), fabs(d.hi)));
        b.lo_x += ox.x - slack, b.hi_x += ox.y + slack;
        b.lo_y += oy.x - slack, b.hi_y += oy.y + slack;
        b.lo_z += oz.x - slack, b.hi_z += oz.y + slack;
    }
    /* Triangle mode with these boxes (TESSERA_TIGHT_LEAVES=0): a micro-quad on an edge
     * stitched to a coarser neighbour has vertices moved along the edge, outside its square. */
    if ((seg_flags >> TS_SEG_EDGE_SHIFT) != 0u) b = box_union(b, tight_leaf_box(g, n, i, j));
    b = leaf_clamp(b, pbox);
    quadtree_store(groups, codes, m, k, b, tb, coded);
}

#ifdef TS_CPU_LANES
/* The 2 x 2 leaves (i0 + (q & 1), j0 + (q >> 1)) of a noise-displaced tree at m >= 1 built
 * together, leaf q in lane q of each float4: leaf_begin, the noise intervals (the cells of
 * displace_interval_tasks, queued into the lanes of tasks, and displace_interval_sum) and
 * leaf_finish, each lane their operations in their order (the same bits), the four boxes
 * stored as their sibling group g with their codes in c (quadtree_store: 0, or where coded the
 * tight boxes of their vertices in grid, rows of n). Not for trimmed, stitched or
 * triangle-mode trees, which build_leaves finishes leaf by leaf. */
inline void block_leaves(__global const ts_patch_attr *a, __global const ts_xform *ax,
                         __global const ts_vec4 *cp0, __global const ts_vec4 *cp,
                         __global const ts_vec4 *cn, __global const ts_vec4 *mn, ts_vec4 e, float s,
                         float h, uint i0, uint j0, ts_box pbox, const float *freq,
                         const float *weight, uint octaves, noise_tasks *tasks, float *vlo,
                         float *vhi, __global const ts_vec4 *grid, uint n, uint coded,
                         __global ts_box4 *g, __global ts_tight4 *c)
{
    block_box4 b = block_base_boxes(cp, i0, j0, h);
    float4 mag = fmax(fmax(fabs(b.lx), fabs(b.hx)),
                      fmax(fmax(fabs(b.ly), fabs(b.hy)), fmax(fabs(b.lz), fabs(b.hz))));
    float4 ex = e.x * s + 4e-7f * mag, ey = e.y * s + 4e-7f * mag, ez = e.z * s + 4e-7f * mag;
    b.lx -= ex, b.hx += ex, b.ly -= ey, b.hy += ey, b.lz -= ez, b.hz += ez;
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
    b.lx = fmax(b.lx, pbox.lo_x), b.ly = fmax(b.ly, pbox.lo_y), b.lz = fmax(b.lz, pbox.lo_z);
    b.hx = fmin(b.hx, pbox.hi_x), b.hy = fmin(b.hy, pbox.hi_y), b.hz = fmin(b.hz, pbox.hi_z);
    vstore4(b.lx, 0, g->lo_x), vstore4(b.ly, 0, g->lo_y), vstore4(b.lz, 0, g->lo_z);
    vstore4(b.hx, 0, g->hi_x), vstore4(b.hy, 0, g->hi_y), vstore4(b.hz, 0, g->hi_z);
    if (!coded) {
        uchar4 zero = (uchar4)(0);
        vstore4(zero, 0, c->lo_x), vstore4(zero, 0, c->lo_y), vstore4(zero, 0, c->lo_z);
        vstore4(zero, 0, c->hi_x), vstore4(zero, 0, c->hi_y), vstore4(zero, 0, c->hi_z);
        return;
    }
    float fb[24]; /* a rough patch: each leaf's tight box, as codes inside its box */
    block_spill(b, fb);
    for (uint q = 0; q < 4u; ++q)
        tight_store_lane(c, q, block_box(fb + q),
                         leaf_clamp(tight_leaf_box(grid, n, i0 + (q & 1u), j0 + (q >> 1)), pbox));
}
#endif

/* Node k of level l of the tree at base (groups) and cbase (codes): the union of its four
 * children, group k of level l + 1, and (coded) the union of their tight boxes, decoded. */
inline void build_node(__global ts_box4 *base, __global ts_tight4 *cbase, uint l, uint k,
                       uint coded)
{
    __global const ts_box4 *c = base + quadtree_group_offset(l + 1u) + k;
    ts_box box;
    box.lo_x = fmin(fmin(c->lo_x[0], c->lo_x[1]), fmin(c->lo_x[2], c->lo_x[3]));
    box.lo_y = fmin(fmin(c->lo_y[0], c->lo_y[1]), fmin(c->lo_y[2], c->lo_y[3]));
    box.lo_z = fmin(fmin(c->lo_z[0], c->lo_z[1]), fmin(c->lo_z[2], c->lo_z[3]));
    box.hi_x = fmax(fmax(c->hi_x[0], c->hi_x[1]), fmax(c->hi_x[2], c->hi_x[3]));
    box.hi_y = fmax(fmax(c->hi_y[0], c->hi_y[1]), fmax(c->hi_y[2], c->hi_y[3]));
    box.hi_z = fmax(fmax(c->hi_z[0], c->hi_z[1]), fmax(c->hi_z[2], c->hi_z[3]));
    ts_box tb = coded ? quadtree_tight_union(base, cbase, l, k) : box;
    quadtree_store(base, cbase, l, k, box, tb, coded);
}

/* The parents of leaves k0 .. k0 + per - 1 (level m - 1, build_node) where they are whole
 * sibling groups (per >= 4: on CPU devices, BUILD_LEAF_RUN leaves a work-item), read back from
 * what the work-item stored; the host then starts build_level a level higher for the trees
 * (trace.c stage_build). Saves build_level's largest launch and its reads of the leaves. */
inline void build_parents(__global ts_box4 *base, __global ts_tight4 *cbase, uint m, uint k0,
                          uint per, uint coded)
{
    if (per < 4u) return;
    for (uint k = k0 >> 2; k < (k0 + per) >> 2; ++k)
        build_node(base, cbase, m - 1u, k, coded);
}

/* Leaves a work-item of build_leaves (TS_BUILD_LEAF_RUN on CPU devices, shared_types.h). */
#ifdef TS_CPU_LANES
#define BUILD_LEAF_RUN TS_BUILD_LEAF_RUN
#else
#define BUILD_LEAF_RUN 1u
#endif
/* ... taken in blocks of up to 2 x 2 leaves (consecutive in Morton order) */
#define BUILD_LEAF_BLOCK (BUILD_LEAF_RUN < 4u ? BUILD_LEAF_RUN : 4u)

__kernel void build_leaves(__global const uint *trees, uint tree_first, uint tree_count, uint m,
                           __global const ts_segment *segments, __global const ts_vec4 *cp,
                           __global const ts_vec4 *cp1, __global const ts_vec4 *grid,
                           __global const ts_vec4 *corner_n, __global const ts_vec4 *mid_n,
                           __global const ts_patch_attr *attr, __global const ts_xform *xform,
                           __global const ts_vec4 *flatness, __global const ts_box *patch_box,
                           __global const ts_texture *textures, __global const uint *tex_pages,
                           __global const ts_vec4 *tex_pool, __global const ts_vec4 *trim_seg,
                           uint tight, __global ts_box4 *groups, __global ts_tight4 *codes)
{
    /* A work-item builds `per` consecutive leaves k0 .. k0 + per - 1 of one tree. */
    uint nl = 1u << (2u * m), per = min(nl, (uint)BUILD_LEAF_RUN), gid = get_global_id(0);
    uint items = nl / per;
    uint t = gid / items, k0 = (gid % items) * per;
    if (t >= tree_count) return;
    uint tree = trees[tree_first + t];
    ts_segment seg = segments[TS_TREE_SEGMENT(tree)];
    uint time = TS_TREE_TIME(tree), n = (1u << m) + 1u, nv = n * n;
    float h = ldexp(1.0f, -(int)m);
    /* The segment's shape: the patch diced (itself, or the master an instance shares). */
    __global const ts_vec4 *cn = corner_n + (size_t)seg.shape * 4u;
    __global const ts_vec4 *mn = mid_n + (size_t)seg.shape * 5u;
    __global const ts_vec4 *g = grid + (size_t)seg.vert_first + time * nv;
    size_t at = (size_t)seg.group_first + time * quadtree_group_count(m);
    /* The box of the micro-quad's four diced vertices: triangle mode's leaf box, and for a
     * displaced patch in box mode the tight box its codes give (the origin-patch rule's
     * culling; elsewhere the codes are 0). */
    uint coded = !tight && (seg.flags & TS_PATCH_ROUGH) != 0u;
    __global const ts_patch_attr *a = attr + seg.shape;
    __global const ts_xform *ax = xform + a->xform;
    ts_tex_ctx tex = {textures, tex_pages, tex_pool};
    __global const ts_vec4 *cp0 = cp + (size_t)seg.shape * 16u;
    ts_vec4 e = flatness[seg.shape];
    ts_box pbox = patch_box[seg.shape];
    float s = ldexp(1.0f, -2 * (int)m);
    int noise = displace_is_noise(a);
    __global const ts_vec4 *cpt = time ? cp1 + (size_t)seg.shape * 16u : cp0;
    float freq[TS_DISP_MAX_OCTAVES], weight[TS_DISP_MAX_OCTAVES]; /* once for the leaves */
    uint octaves = noise ? displace_octaves(a) : 0u;
    if (noise) displace_octave_steps(a, octaves, octaves, freq, weight);
    /* leaf q of a block's octave o in slot o * BUILD_LEAF_BLOCK + q of vlo, vhi */
    float vlo[BUILD_LEAF_BLOCK * TS_DISP_MAX_OCTAVES], vhi[BUILD_LEAF_BLOCK * TS_DISP_MAX_OCTAVES];
    noise_tasks tasks;
    tasks.n = 0u;
    uint blk = min(per, (uint)BUILD_LEAF_BLOCK);
#ifdef TS_CPU_LANES
    if (noise && blk == 4u && !tight && (seg.flags & TS_SEG_TRIMMED) == 0u &&
        (seg.flags >> TS_SEG_EDGE_SHIFT) == 0u) { /* each block's leaves a leaf per lane */
        __global ts_box4 *gq = groups + at + quadtree_group_offset(m) + (k0 >> 2);
        __global ts_tight4 *cq = codes + at + quadtree_group_offset(m) + (k0 >> 2);
        for (uint b = 0; b < per / 4u; ++b)
            block_leaves(a, ax, cp0, cpt, cn, mn, e, s, h, morton_i(k0 + 4u * b),
                         morton_j(k0 + 4u * b), pbox, freq, weight, octaves, &tasks, vlo, vhi, g, n,
                         coded, gq + b, cq + b);
        build_parents(groups + at, codes + at, m, k0, per, coded);
        return;
    }
#endif
    for (uint k1 = k0; k1 < k0 + per; k1 += blk) { /* a block of leaves k1 .. k1 + blk - 1 */
        /* The corners' boxes of a 2 x 2 block of leaves at once (a third of the Bézier points'
         * work), on the tree's time sample and, where the noise is evaluated at time 0, on
         * cp0. */
        const float *pre = NULL, *pre0 = NULL, *pre_nb = NULL;
#ifdef TS_CPU_LANES
        float bb[24], bb0[24], nbs[24];
        if (blk == 4u && !tight) {
            uint i0 = morton_i(k1), j0 = morton_j(k1);
            block_spill(block_base_boxes(cpt, i0, j0, h), bb);
            pre = bb;
            if (cpt != cp0 && a->disp_kind != TS_DISP_NONE && a->disp_kind != TS_DISP_TEXTURE)
                block_spill(block_base_boxes(cp0, i0, j0, h), bb0), pre0 = bb0;
            if (a->disp_kind != TS_DISP_NONE)
                block_spill(block_normal_boxes(cn, mn, i0, j0, h), nbs), pre_nb = nbs;
        }
#endif
        if (!noise) { /* each leaf at once */
            for (uint q = 0; q < blk; ++q) {
                uint k = k1 + q, i = morton_i(k), j = morton_j(k);
                ts_box b, b0, tb;
                float mag;
                if (!leaf_begin(a, trim_seg, tex, cp0, cpt, e, s, g, n, i, j, m, h, seg.flags,
                                tight, coded, pbox, groups + at, codes + at, k,
                                pre ? pre + q : NULL, pre0 ? pre0 + q : NULL, &b, &b0, &tb, &mag))
                    continue;
                ts_interval d = {0.0f, 0.0f};
                if (a->disp_kind == TS_DISP_TEXTURE)
                    d = displace_texture_interval(a, tex, (float)i * h, (float)j * h,
                                                  (float)(i + 1u) * h, (float)(j + 1u) * h);
                else if (a->disp_kind != TS_DISP_NONE)
                    d = displace_interval(a, ax, b0.lo_x, b0.lo_y, b0.lo_z, b0.hi_x, b0.hi_y,
                                          b0.hi_z);
                leaf_finish(b, mag, d, a->disp_kind != TS_DISP_NONE, cn, mn, g, n, i, j, h,
                            seg.flags, pbox, groups + at, codes + at, m, k, tb, coded,
                            pre_nb ? pre_nb + q : NULL);
            }
            continue;
        }
        /* Noise: each leaf's interval queued as cell tasks (the block's cells share the lanes),
         * then the leaves finished once the tasks have run. */
        ts_box bq[BUILD_LEAF_BLOCK], tq[BUILD_LEAF_BLOCK];
        float magq[BUILD_LEAF_BLOCK];
        uint queued = 0u;
        for (uint q = 0; q < blk; ++q) {
            uint k = k1 + q, i = morton_i(k), j = morton_j(k);
            ts_box b, b0, tb;
            float mag;
            if (!leaf_begin(a, trim_seg, tex, cp0, cpt, e, s, g, n, i, j, m, h, seg.flags, tight,
                            coded, pbox, groups + at, codes + at, k, pre ? pre + q : NULL,
                            pre0 ? pre0 + q : NULL, &b, &b0, &tb, &mag))
                continue;
            displace_interval_tasks(a, ax, b0.lo_x, b0.lo_y, b0.lo_z, b0.hi_x, b0.hi_y, b0.hi_z,
                                    freq, q, BUILD_LEAF_BLOCK, &tasks, vlo, vhi);
            bq[q] = b, tq[q] = tb, magq[q] = mag, queued |= 1u << q;
        }
        if (queued == 0u) continue;
        noise_tasks_run(&tasks, vlo, vhi);
        for (uint q = 0; q < blk; ++q) {
            if ((queued >> q & 1u) == 0u) continue;
            uint k = k1 + q;
            ts_interval d = displace_interval_sum(a, weight, q, BUILD_LEAF_BLOCK, vlo, vhi);
            leaf_finish(bq[q], magq[q], d, 1u, cn, mn, g, n, morton_i(k), morton_j(k), h, seg.flags,
                        pbox, groups + at, codes + at, m, k, tq[q], coded,
                        pre_nb ? pre_nb + q : NULL);
        }
    }
    build_parents(groups + at, codes + at, m, k0, per, coded);
}

__kernel void build_level(__global const uint *trees, uint tree_first, uint tree_count, uint level,
                          uint tight, __global const ts_segment *segments, __global ts_box4 *groups,
                          __global ts_tight4 *codes)
{
    uint per_tree = 1u << (2u * level), gid = get_global_id(0);
    uint t = gid / per_tree, k = gid % per_tree;
    if (t >= tree_count) return;
    uint tree = trees[tree_first + t];
    ts_segment seg = segments[TS_TREE_SEGMENT(tree)];
    size_t at = (size_t)seg.group_first + TS_TREE_TIME(tree) * quadtree_group_count(seg.lod);
    /* The tight box: the union of the children's, decoded (build_leaves' coded). */
    build_node(groups + at, codes + at, level, k, !tight && (seg.flags & TS_PATCH_ROUGH) != 0u);
}

/* The four boxes of sibling group g as codes inside the patch box p (tight_store_lane; every
 * box lies in p: leaves are clamped to it), into *c. */
inline void cull_encode(__global const ts_box4 *g, ts_box p, __global ts_tight4 *c)
{
    for (uint q = 0; q < 4u; ++q) {
        ts_box b = {g->lo_x[q], g->lo_y[q], g->lo_z[q], g->hi_x[q], g->hi_y[q], g->hi_z[q]};
        tight_store_lane(c, q, p, b);
    }
}

/* build_cull (one launch per batch, after build_level): copies levels 1 and 2 of each static
 * tree of the batch, TS_CULL_GROUPS groups from its group 1, to its patch's entry of cull as
 * codes inside the patch's top-level box (cull_encode),
 * and sets cull_levels[patch] to how many of the two levels top_level may cull by
 * (quadtree_cull_levels; groups of levels it may not are left as they were and never read).
 * A moving patch keeps 0 (top_level then never culls it). The entry written is the
 * segment's shape's: an instance's segment dices its master, whose tree is in the master's
 * frame, so it serves the master's candidates and never the instance's (whose entry stays 0).
 * The host resets an entry whose patch's m or leaf size changed (trace.c cull_reset_stale).
 * One work-item per group. */
__kernel void build_cull(__global const uint *trees, uint tree_first, uint tree_count, uint leaf_b,
                         __global const ts_segment *segments, __global const ts_box4 *groups,
                         __global const ts_box *patch_box, __global ts_tight4 *cull,
                         __global uint *cull_levels)
{
    uint gid = get_global_id(0);
    uint t = gid / TS_CULL_GROUPS, g = gid % TS_CULL_GROUPS;
    if (t >= tree_count) return;
    uint tree = trees[tree_first + t];
    ts_segment seg = segments[TS_TREE_SEGMENT(tree)];
    if (TS_TREE_TIME(tree) != 0u || (seg.flags & TS_PATCH_MOVING) != 0u) return;
    uint levels = quadtree_cull_levels(seg.lod, leaf_b);
    if (g == 0u) cull_levels[seg.shape] = levels;
    if (g + 1u < quadtree_group_count(levels))
        cull_encode(groups + (size_t)seg.group_first + 1u + g, patch_box[seg.shape],
                    cull + (size_t)seg.shape * TS_CULL_GROUPS + g);
}

/* Not a stage: the probe of tests/test_dice_build.c. Item i: displace_normal_box_x4 of the
 * normals nodes[9i .. 9i + 3] (corners) and nodes[9i + 4 .. 9i + 8] (edge midpoints, centre)
 * over the rectangle rect[4i .. 4i + 3] = (u0, v0, u1, v1), which the test compares bit for bit
 * with the host's displace_normal_box (lib/displace.h). */
__kernel void build_normal_box_probe(__global const ts_vec4 *nodes, __global const float *rect,
                                     uint count, __global ts_box *out)
{
    uint i = get_global_id(0);
    if (i >= count) return;
    __global const float *r = rect + 4u * (size_t)i;
    out[i] = displace_normal_box_x4(nodes + 9u * (size_t)i, nodes + 9u * (size_t)i + 4u, r[0], r[1],
                                    r[2], r[3]);
}
