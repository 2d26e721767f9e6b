/* bottom_level.cl — stage `bottom_level` (Hanika §3.2.1): each sorted (ray, patch) pair of a
 * batch traverses its patch's quad-tree front to back and intersects the micro-triangles of
 * the leaves it reaches (each micro-quad (i, j) is split along its (i,j)-(i+1,j+1) diagonal;
 * the watertight test of lib/intersect.h, so no ray slips between micro-triangles).
 * Reads:  pairs[pair_first ..), the batch's segments (to find the pair's slot), ray org/dir,
 *         hit.t as tmax, grid and quad-tree nodes of the slot.
 * Writes: pair_hit[pair.window]: the closest hit in this patch below tmax, or t = TS_NO_HIT.
 * Stack: at most 3 entries per level plus the root, 3 * TS_LOD_LIMIT + 1. */
#include "lib/shared_types.h"
#include "lib/intersect.h"
#include "lib/quadtree.h"

#define BL_STACK (3 * TS_LOD_LIMIT + 2)

/* Index (within the batch) of the segment holding sorted pair p: the last with begin <= p. */
inline uint segment_of(__global const ts_segment *seg, uint count, uint p)
{
    uint lo = 0, hi = count;
    while (hi - lo > 1u) {
        uint mid = (lo + hi) / 2u;
        if (seg[mid].begin <= p) lo = mid;
        else hi = mid;
    }
    return lo;
}

/* Tests micro-quad k of a patch diced at m; updates *best on a closer hit. */
inline void leaf_intersect(__global const ts_vec4 *g, uint m, uint k, ts_vec4 o,
                           const ts_ray_shear *sh, ts_hit *best, uint patch)
{
    uint i = morton_i(k), j = morton_j(k), n = (1u << m) + 1u;
    ts_vec4 v00 = g[j * n + i], v10 = g[j * n + i + 1u];
    ts_vec4 v01 = g[(j + 1u) * n + i], v11 = g[(j + 1u) * n + i + 1u];
    float b1, b2, scale = ldexp(1.0f, -(int)m);
    float t = triangle_hit(sh, o.x, o.y, o.z, v00, v10, v11, o.w, best->t, &b1, &b2);
    if (t >= 0.0f) {
        *best = (ts_hit){t, ((float)i + b1 + b2) * scale, ((float)j + b2) * scale, patch,
                         2u * (j * (n - 1u) + i)};
    }
    t = triangle_hit(sh, o.x, o.y, o.z, v00, v11, v01, o.w, best->t, &b1, &b2);
    if (t >= 0.0f) {
        *best = (ts_hit){t, ((float)i + b1) * scale, ((float)j + b1 + b2) * scale, patch,
                         2u * (j * (n - 1u) + i) + 1u};
    }
}

__kernel void bottom_level_trace(__global const ts_pair *pairs, uint pair_first, uint pair_count,
                                 __global const ts_segment *segments, uint seg_first,
                                 uint seg_count, uint verts_per_slot, uint nodes_per_slot,
                                 uint n_per_ray, __global const uint *active,
                                 __global const ts_vec4 *org, __global const ts_vec4 *dir,
                                 __global const ts_hit *hit, __global const ts_vec4 *grid,
                                 __global const ts_box *nodes, __global ts_hit *pair_hit)
{
    uint gid = get_global_id(0);
    if (gid >= pair_count) return;
    ts_pair pr = pairs[pair_first + gid];
    __global const ts_segment *batch = segments + seg_first;
    ts_segment seg = batch[segment_of(batch, seg_count, pair_first + gid)];
    uint ray = active[pr.window / n_per_ray];
    ts_vec4 o = org[ray], d = dir[ray];
    float ix = safe_reciprocal(d.x), iy = safe_reciprocal(d.y), iz = safe_reciprocal(d.z);
    ts_ray_shear sh = ray_shear(d.x, d.y, d.z);
    ts_hit best = {hit[ray].t, 0.0f, 0.0f, TS_INVALID, TS_INVALID};
    __global const ts_vec4 *g = grid + (size_t)seg.slot * verts_per_slot;
    __global const ts_box *t = nodes + (size_t)seg.slot * nodes_per_slot;
    uint m = seg.lod;
    /* Stack entries: (level << 24) | index within the level, with the entry distance. */
    uint stack[BL_STACK];
    float stack_t[BL_STACK];
    int sp = 0;
    float te = box_enter(o.x, o.y, o.z, ix, iy, iz, t[0].lo_x, t[0].lo_y, t[0].lo_z, t[0].hi_x,
                         t[0].hi_y, t[0].hi_z, o.w, best.t);
    if (te >= 0.0f) {
        stack[0] = 0u;
        stack_t[0] = te;
        sp = 1;
    }
    while (sp > 0) {
        --sp;
        if (stack_t[sp] > best.t) continue;
        uint level = stack[sp] >> 24, k = stack[sp] & 0xffffffu;
        if (level == m) {
            leaf_intersect(g, m, k, o, &sh, &best, seg.patch);
            continue;
        }
        __global const ts_box *c = t + quadtree_level_offset(level + 1u) + 4u * k;
        float tc[4];
        uint id[4];
        uint nc = 0;
        for (uint q = 0; q < 4u; ++q) {
            float e = box_enter(o.x, o.y, o.z, ix, iy, iz, c[q].lo_x, c[q].lo_y, c[q].lo_z,
                                c[q].hi_x, c[q].hi_y, c[q].hi_z, o.w, best.t);
            if (e < 0.0f) continue;
            /* Insertion by entry distance, nearest last so it is popped first. */
            uint at = nc++;
            while (at > 0u && tc[at - 1u] < e) {
                tc[at] = tc[at - 1u];
                id[at] = id[at - 1u];
                --at;
            }
            tc[at] = e;
            id[at] = ((level + 1u) << 24) | (4u * k + q);
        }
        for (uint q = 0; q < nc; ++q) {
            stack[sp] = id[q];
            stack_t[sp] = tc[q];
            ++sp;
        }
    }
    if (best.patch == TS_INVALID) best.t = TS_NO_HIT;
    pair_hit[pr.window] = best;
}
