/* dice.cl — stage `dice` (Hanika §3.2): evaluates the (2^m+1)^2 displaced vertices of each
 * tree of a batch into the vertex arena.
 * Reads:  trees[tree_first .. tree_first + tree_count) — all of LOD m (the host launches once
 *         per m present), segments (shape, vert_first), control points at both times, corner
 *         normals, attributes, transforms, textures (descriptors, page table, tile pool:
 *         the level-0 tiles under the batch's st rectangles must be resident).
 * Writes: grid[vert_first + time * (2^m+1)^2 + j * (2^m+1) + i] = patch_vertex(i 2^-m, j 2^-m):
 *         xyz the displaced position, w the displacement d (build recovers the undisplaced
 *         point from it); TS_DICE_VERTICES (two) vertices a work-item.
 * Parameters are i * 2^-m exactly (ldexp), so the host references dice the same points. In
 * triangle mode the vertices of an edge shared with a patch diced coarser are that patch's
 * (quadtree_stitch), so no crack opens between them. */
#include "lib/shared_types.h"
#include "lib/noise4.h"
#include "lib/patch.h"
#include "lib/quadtree.h"

/* The parameters (u, v) of vertex v of a grid of n x n at level m, stitched in triangle mode
 * (lib/quadtree.h quadtree_stitch: the edges' level differences in flags). */
inline void dice_param(uint flags, uint m, uint n, uint v, float *u, float *w)
{
    uint i = v % n, j = v / n;
    quadtree_stitch(flags >> TS_SEG_EDGE_SHIFT, m, &i, &j);
    *u = quadtree_vertex_param(i, m), *w = quadtree_vertex_param(j, m);
}

/* Two vertices a work-item (v0 = 2 k and v0 + 1, the last one alone when the count is odd):
 * a noise of at most four octaves evaluates both vertices' octaves in one float8
 * (lib/noise4.h displace_value_pair), else each vertex is patch_vertex_x8. The same bits
 * either way (tests/test_dice_build.c, tests/test_bottom_level.c). */
__kernel void dice_grid(__global const uint *trees, uint tree_first, uint tree_count, uint m,
                        __global const ts_segment *segments, __global const ts_vec4 *cp0,
                        __global const ts_vec4 *cp1, __global const ts_vec4 *corner_n,
                        __global const ts_vec4 *mid_n, __global const ts_patch_attr *attr,
                        __global const ts_xform *xform, __global const ts_texture *textures,
                        __global const uint *tex_pages, __global const ts_vec4 *tex_pool,
                        __global ts_vec4 *grid)
{
    uint nv = quadtree_vertex_count(m), pairs = (nv + TS_DICE_VERTICES - 1u) / TS_DICE_VERTICES;
    uint gid = get_global_id(0);
    uint t = gid / pairs, v0 = TS_DICE_VERTICES * (gid % pairs);
    if (t >= tree_count) return;
    uint tree = trees[tree_first + t];
    ts_segment seg = segments[TS_TREE_SEGMENT(tree)];
    uint time = TS_TREE_TIME(tree), n = (1u << m) + 1u;
    ts_tex_ctx tex = {textures, tex_pages, tex_pool};
    /* The patch diced is the segment's shape: itself, or the master it shares (instances). */
    __global const ts_vec4 *c0 = cp0 + (size_t)seg.shape * 16u;
    __global const ts_vec4 *c = time ? cp1 + (size_t)seg.shape * 16u : c0;
    __global const ts_patch_attr *a = attr + seg.shape;
    __global const ts_vec4 *cn = corner_n + (size_t)seg.shape * 4u;
    __global const ts_vec4 *mn = mid_n + (size_t)seg.shape * 5u;
    __global const ts_xform *x = xform + a->xform;
    __global ts_vec4 *out = grid + (size_t)seg.vert_first + time * nv + v0;
    uint count = v0 + 1u < nv ? 2u : 1u;
    if (count == 2u && displace_is_noise(a) && displace_octaves(a) <= 4u) {
        float ua, va, ub, vb;
        dice_param(seg.flags, m, n, v0, &ua, &va);
        dice_param(seg.flags, m, n, v0 + 1u, &ub, &vb);
        ts_vec4 qa = bezier_eval(c, ua, va), qb = bezier_eval(c, ub, vb);
        ts_vec4 ra = c == c0 ? qa : bezier_eval(c0, ua, va);
        ts_vec4 rb = c == c0 ? qb : bezier_eval(c0, ub, vb);
        float2 d = displace_value_pair(a, x, (float4)(ra.x, ra.y, ra.z, 0.0f),
                                       (float4)(rb.x, rb.y, rb.z, 0.0f));
        ts_vec4 na = displace_normal(cn, mn, ua, va), nb = displace_normal(cn, mn, ub, vb);
        ts_vec4 oa = {qa.x + d.x * na.x, qa.y + d.x * na.y, qa.z + d.x * na.z, d.x};
        ts_vec4 ob = {qb.x + d.y * nb.x, qb.y + d.y * nb.y, qb.z + d.y * nb.z, d.y};
        out[0] = oa, out[1] = ob;
        return;
    }
    for (uint k = 0; k < count; ++k) {
        float u, v;
        dice_param(seg.flags, m, n, v0 + k, &u, &v);
        out[k] = patch_vertex_x8(c, c0, cn, mn, a, x, tex, u, v);
    }
}
