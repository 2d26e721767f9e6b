/* build.cl — stage `build` (Hanika §3.2.1): the implicit complete quad-tree over a diced
 * patch, in time linear in its micro-polygons.
 * build_leaves: leaf k (Morton order) of level m gets the box of its micro-quad's four
 *   vertices, which holds both of its micro-triangles.
 * build_level:  node k of level l gets the union of children 4k..4k+3 of level l+1; launched
 *   for l = max_lod-1 down to 0 (bottom-up min-max reduction); segments with m <= l skip.
 * Reads: segments, grid. Writes: nodes[slot * nodes_per_slot + quadtree_level_offset(l) + k].
 * Invariant after the last launch: every inner box equals the union of its children. */
#include "lib/shared_types.h"
#include "lib/quadtree.h"

__kernel void build_leaves(__global const ts_segment *segments, uint seg_first, uint seg_count,
                           uint leaves_per_slot, uint verts_per_slot, uint nodes_per_slot,
                           __global const ts_vec4 *grid, __global ts_box *nodes)
{
    uint gid = get_global_id(0);
    uint s = gid / leaves_per_slot, k = gid % leaves_per_slot;
    if (s >= seg_count) return;
    ts_segment seg = segments[seg_first + s];
    uint m = seg.lod, side = 1u << m;
    if (k >= side * side) return;
    uint i = morton_i(k), j = morton_j(k), n = side + 1u;
    __global const ts_vec4 *g = grid + (size_t)seg.slot * verts_per_slot;
    ts_vec4 a = g[j * n + i], b = g[j * n + i + 1u];
    ts_vec4 c = g[(j + 1u) * n + i], d = g[(j + 1u) * n + i + 1u];
    ts_box box;
    box.lo_x = fmin(fmin(a.x, b.x), fmin(c.x, d.x));
    box.lo_y = fmin(fmin(a.y, b.y), fmin(c.y, d.y));
    box.lo_z = fmin(fmin(a.z, b.z), fmin(c.z, d.z));
    box.hi_x = fmax(fmax(a.x, b.x), fmax(c.x, d.x));
    box.hi_y = fmax(fmax(a.y, b.y), fmax(c.y, d.y));
    box.hi_z = fmax(fmax(a.z, b.z), fmax(c.z, d.z));
    nodes[(size_t)seg.slot * nodes_per_slot + quadtree_level_offset(m) + k] = box;
}

__kernel void build_level(__global const ts_segment *segments, uint seg_first, uint seg_count,
                          uint level, uint nodes_per_slot, __global ts_box *nodes)
{
    uint gid = get_global_id(0);
    uint per_seg = 1u << (2u * level);
    uint s = gid / per_seg, k = gid % per_seg;
    if (s >= seg_count) return;
    ts_segment seg = segments[seg_first + s];
    if (seg.lod <= level) return;
    __global ts_box *t = nodes + (size_t)seg.slot * nodes_per_slot;
    __global const ts_box *c = t + quadtree_level_offset(level + 1u) + 4u * k;
    ts_box box = c[0];
    for (int q = 1; q < 4; ++q) {
        box.lo_x = fmin(box.lo_x, c[q].lo_x);
        box.lo_y = fmin(box.lo_y, c[q].lo_y);
        box.lo_z = fmin(box.lo_z, c[q].lo_z);
        box.hi_x = fmax(box.hi_x, c[q].hi_x);
        box.hi_y = fmax(box.hi_y, c[q].hi_y);
        box.hi_z = fmax(box.hi_z, c[q].hi_z);
    }
    t[quadtree_level_offset(level) + k] = box;
}
