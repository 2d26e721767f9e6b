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
 * build_skeleton (where the frame's patches do not fit): a copy of the upper levels of each
 *   static noise-displaced or undisplaced tree as codes, which bottom_level traces without the
 *   tree.
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
#include "lib/leaf4.h"
#include "lib/quadtree.h"
#include "lib/trim.h"

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
/* block_leaf_boxes' four boxes stored as their sibling group g with their codes in c
 * (quadtree_store: 0, or where coded the tight boxes of their vertices in grid, rows of n). */
inline void block_leaves(__global const ts_patch_attr *a, __global const ts_xform *ax,
                         __global const ts_vec4 *cp0, __global const ts_vec4 *cp,
                         __global const ts_vec4 *cn, __global const ts_vec4 *mn, ts_vec4 e, float s,
                         float h, uint i0, uint j0, ts_box pbox, const float *freq,
                         const float *weight, uint octaves, noise_tasks *tasks, float *vlo,
                         float *vhi, __global const ts_vec4 *grid, uint n, uint coded,
                         __global ts_box4 *g, __global ts_tight4 *c)
{
    block_box4 b = block_leaf_boxes(a, ax, cp0, cp, cn, mn, e, s, h, i0, j0, pbox, freq, weight,
                                    octaves, tasks, vlo, vhi);
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

/* Box t as codes inside box b (tight_store_lane's for one box), decoded again as
 * bottom_level.cl decodes a skeleton's groups (tight4_decode): a box that holds t. */
inline ts_box skeleton_code_box(ts_box b, ts_box t)
{
    float sx = tight_step(b.lo_x, b.hi_x), sy = tight_step(b.lo_y, b.hi_y),
          sz = tight_step(b.lo_z, b.hi_z);
    float rx = tight_scale(sx), ry = tight_scale(sy), rz = tight_scale(sz);
    ts_box d = {b.lo_x + (float)tight_code_lo(b.lo_x, sx, rx, t.lo_x) * sx,
                b.lo_y + (float)tight_code_lo(b.lo_y, sy, ry, t.lo_y) * sy,
                b.lo_z + (float)tight_code_lo(b.lo_z, sz, rz, t.lo_z) * sz,
                b.hi_x - (float)tight_code_hi(b.hi_x, sx, rx, t.hi_x) * sx,
                b.hi_y - (float)tight_code_hi(b.hi_y, sy, ry, t.hi_y) * sy,
                b.hi_z - (float)tight_code_hi(b.hi_z, sz, rz, t.hi_z) * sz};
    return d;
}

/* build_skeleton (after build_level, one launch per m of the batch's list of trees to keep,
 * trace.c skeleton_lists: static, their patch given a place in skel): the sibling
 * groups of levels 1 .. m - TS_SKELETON_DROP of each tree, group g of the tree at entry g - 1
 * from skel_first[shape], as codes inside the parent's box
 * decoded from the skeleton (the root's: the patch box). Each decoded box holds the tree's
 * (tight_store_lane rounds outwards), so a ray that enters a tree box enters its skeleton box
 * too, and bottom_level can trace the patch down to its 4 x 4 blocks of leaves without the
 * tree (bl_skeleton). A work-item decodes its ancestors' codes itself, from the tree's boxes,
 * and writes one group. */
__kernel void build_skeleton(__global const uint *trees, uint tree_first, uint tree_count, uint m,
                             __global const ts_segment *segments, __global const ts_box4 *groups,
                             __global const ts_box *patch_box, __global ts_tight4 *skel,
                             __global const uint *skel_first)
{
    uint per = TS_SKELETON_GROUPS(m), gid = get_global_id(0);
    uint t = gid / per, g = gid % per + 1u; /* the tree's group g, of level l */
    if (t >= tree_count) return;
    uint tree = trees[tree_first + t];
    ts_segment seg = segments[TS_TREE_SEGMENT(tree)];
    __global const ts_box4 *base = groups + seg.group_first;
    uint l = 1u;
    while (quadtree_group_offset(l + 1u) <= g)
        ++l;
    uint kp = g - quadtree_group_offset(l); /* the parent, node kp of level l - 1 */
    ts_box d = patch_box[seg.shape];
    for (uint a = 1u; a < l; ++a)
        d = skeleton_code_box(d, quadtree_box(base, a, kp >> (2u * (l - 1u - a))));
    __global ts_tight4 *out = skel + skel_first[seg.shape] + g - 1u;
    for (uint q = 0; q < 4u; ++q) /* group g holds the children 4 kp .. 4 kp + 3 of level l */
        tight_store_lane(out, q, d, quadtree_box(base, l, 4u * kp + q));
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
