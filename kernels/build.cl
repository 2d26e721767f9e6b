/* build.cl — stage `build` (Hanika §3.2.1): the implicit complete quad-tree over a diced
 * patch, in time linear in its micro-polygons, stored as SoA sibling groups
 * (lib/quadtree.h).
 * build_leaves: leaf k (Morton order) of level m gets the box of its micro-quad's four
 *   vertices, which holds both of its micro-triangles.
 * build_level:  node k of level l gets the union of its children, the four lanes of group
 *   quadtree_group_offset(l + 1) + k; launched for l = max_lod-1 down to 0 (bottom-up
 *   min-max reduction); segments with m <= l skip. The root's group gets empty lanes 1-3.
 * Reads: segments, grid. Writes: the slot's groups.
 * Invariant after the last launch: every inner box equals the union of its children. */
#include "lib/shared_types.h"
#include "lib/quadtree.h"

/* Stores box b as node k of level l. */
inline void node_store(__global ts_box4 *groups, uint l, uint k, ts_box b)
{
    __global ts_box4 *g = groups + (l == 0u ? 0u : quadtree_group_offset(l) + (k >> 2));
    uint q = l == 0u ? 0u : (k & 3u);
    g->lo_x[q] = b.lo_x;
    g->lo_y[q] = b.lo_y;
    g->lo_z[q] = b.lo_z;
    g->hi_x[q] = b.hi_x;
    g->hi_y[q] = b.hi_y;
    g->hi_z[q] = b.hi_z;
    if (l == 0u) {
        for (uint e = 1u; e < 4u; ++e) { /* empty lanes: lo > hi, never hit */
            g->lo_x[e] = g->lo_y[e] = g->lo_z[e] = 1e30f;
            g->hi_x[e] = g->hi_y[e] = g->hi_z[e] = -1e30f;
        }
    }
}

__kernel void build_leaves(__global const ts_segment *segments, uint seg_first, uint seg_count,
                           uint leaves_per_slot, uint verts_per_slot, uint groups_per_slot,
                           __global const ts_vec4 *grid, __global ts_box4 *groups)
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
    node_store(groups + (size_t)seg.slot * groups_per_slot, m, k, box);
}

__kernel void build_level(__global const ts_segment *segments, uint seg_first, uint seg_count,
                          uint level, uint groups_per_slot, __global ts_box4 *groups)
{
    uint gid = get_global_id(0);
    uint per_seg = 1u << (2u * level);
    uint s = gid / per_seg, k = gid % per_seg;
    if (s >= seg_count) return;
    ts_segment seg = segments[seg_first + s];
    if (seg.lod <= level) return;
    __global ts_box4 *t = groups + (size_t)seg.slot * groups_per_slot;
    __global const ts_box4 *c = t + quadtree_group_offset(level + 1u) + k;
    ts_box box;
    box.lo_x = fmin(fmin(c->lo_x[0], c->lo_x[1]), fmin(c->lo_x[2], c->lo_x[3]));
    box.lo_y = fmin(fmin(c->lo_y[0], c->lo_y[1]), fmin(c->lo_y[2], c->lo_y[3]));
    box.lo_z = fmin(fmin(c->lo_z[0], c->lo_z[1]), fmin(c->lo_z[2], c->lo_z[3]));
    box.hi_x = fmax(fmax(c->hi_x[0], c->hi_x[1]), fmax(c->hi_x[2], c->hi_x[3]));
    box.hi_y = fmax(fmax(c->hi_y[0], c->hi_y[1]), fmax(c->hi_y[2], c->hi_y[3]));
    box.hi_z = fmax(fmax(c->hi_z[0], c->hi_z[1]), fmax(c->hi_z[2], c->hi_z[3]));
    node_store(t, level, k, box);
}
