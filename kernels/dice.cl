/* dice.cl — stage `dice` (Hanika §3.2): evaluates the (2^m+1)^2 displaced vertices of each
 * tree of a batch into the vertex arena.
 * Reads:  trees[tree_first .. tree_first + tree_count) — all of LOD m (the host launches once
 *         per m present), segments (shape, vert_first), control points at both times, corner
 *         normals, attributes, transforms, textures (descriptors, page table, tile pool:
 *         the level-0 tiles under the batch's st rectangles must be resident).
 * Writes: grid[vert_first + time * (2^m+1)^2 + j * (2^m+1) + i] = patch_vertex(i 2^-m, j 2^-m):
 *         xyz the displaced position, w the displacement d (build recovers the undisplaced
 *         point from it).
 * Parameters are i * 2^-m exactly (ldexp), so the host references dice the same points. In
 * triangle mode the vertices of an edge shared with a patch diced coarser are that patch's
 * (quadtree_stitch), so no crack opens between them. */
#include "lib/shared_types.h"
#include "lib/noise4.h"
#include "lib/patch.h"
#include "lib/quadtree.h"

__kernel void dice_grid(__global const uint *trees, uint tree_first, uint tree_count, uint m,
                        __global const ts_segment *segments, __global const ts_vec4 *cp0,
                        __global const ts_vec4 *cp1, __global const ts_vec4 *corner_n,
                        __global const ts_vec4 *mid_n, __global const ts_patch_attr *attr,
                        __global const ts_xform *xform, __global const ts_texture *textures,
                        __global const uint *tex_pages, __global const ts_vec4 *tex_pool,
                        __global ts_vec4 *grid)
{
    uint nv = quadtree_vertex_count(m);
    uint gid = get_global_id(0);
    uint t = gid / nv, v = gid % nv;
    if (t >= tree_count) return;
    uint tree = trees[tree_first + t];
    ts_segment seg = segments[TS_TREE_SEGMENT(tree)];
    uint time = TS_TREE_TIME(tree), n = (1u << m) + 1u;
    ts_tex_ctx tex = {textures, tex_pages, tex_pool};
    /* The patch diced is the segment's shape: itself, or the master it shares (instances). */
    __global const ts_vec4 *c0 = cp0 + (size_t)seg.shape * 16u;
    __global const ts_vec4 *c = time ? cp1 + (size_t)seg.shape * 16u : c0;
    __global const ts_patch_attr *a = attr + seg.shape;
    /* Triangle mode moves the vertices of an edge towards a coarser neighbour onto its grid
     * (lib/quadtree.h quadtree_stitch: the edges' level differences in seg.flags). */
    uint i = v % n, j = v / n;
    quadtree_stitch(seg.flags >> TS_SEG_EDGE_SHIFT, m, &i, &j);
    float u = quadtree_vertex_param(i, m);
    float w = quadtree_vertex_param(j, m);
    grid[(size_t)seg.vert_first + time * nv + v] =
        patch_vertex_x8(c, c0, corner_n + (size_t)seg.shape * 4u, mid_n + (size_t)seg.shape * 5u, a,
                        xform + a->xform, tex, u, w);
}
