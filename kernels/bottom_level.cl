/* bottom_level.cl — stage `bottom_level` (Hanika §3.2.1): each sorted (ray, patch) pair of a
 * batch traverses its patch's quad-tree front to back and intersects the micro-triangles of
 * the leaves it reaches (each micro-quad (i, j) is split along its (i,j)-(i+1,j+1) diagonal;
 * the watertight test of lib/intersect.h, so no ray slips between micro-triangles).
 * Reads:  pairs[pair_first ..), the batch's segments (to find the pair's slot), ray org/dir,
 *         hit.t as tmax, grid and quad-tree nodes of the slot.
 * Writes: pair_hit[pair.window]: the closest hit in this patch below tmax, or t = TS_NO_HIT.
 * Sibling boxes are tested four at a time (SoA groups, lib/quadtree.h), the paper's use of
 * the implicit tree's memory layout (§3.2.1). Stack: at most 3 entries per level plus one. */
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

/* Tests micro-quad k of a patch diced at m; updates *best on a closer hit. The four
 * vertices are made relative to the origin and permuted to the shear's axes with one
 * shuffle each (the host reference, triangle_hit, does the same arithmetic per component). */
inline void leaf_intersect(__global const ts_vec4 *g, uint m, uint k, float4 o4, float tmin,
                           uint4 perm, const ts_ray_shear *sh, ts_hit *best, uint patch)
{
    __global const float4 *gv = (__global const float4 *)g;
    uint i = morton_i(k), j = morton_j(k), n = (1u << m) + 1u;
    float4 v00 = shuffle(gv[j * n + i] - o4, perm), v10 = shuffle(gv[j * n + i + 1u] - o4, perm);
    float4 v01 = shuffle(gv[(j + 1u) * n + i] - o4, perm);
    float4 v11 = shuffle(gv[(j + 1u) * n + i + 1u] - o4, perm);
    float b1, b2, scale = ldexp(1.0f, -(int)m);
    float t = triangle_hit_permuted(sh, v00.x, v00.y, v00.z, v10.x, v10.y, v10.z, v11.x, v11.y,
                                    v11.z, tmin, best->t, &b1, &b2);
    if (t >= 0.0f) {
        *best = (ts_hit){t, ((float)i + b1 + b2) * scale, ((float)j + b2) * scale, patch,
                         2u * (j * (n - 1u) + i)};
    }
    t = triangle_hit_permuted(sh, v00.x, v00.y, v00.z, v11.x, v11.y, v11.z, v01.x, v01.y, v01.z,
                              tmin, best->t, &b1, &b2);
    if (t >= 0.0f) {
        *best = (ts_hit){t, ((float)i + b1) * scale, ((float)j + b1 + b2) * scale, patch,
                         2u * (j * (n - 1u) + i) + 1u};
    }
}

/* Slab test of the four boxes of a sibling group at once (lib/intersect.h box_enter,
 * lane by lane). Returns the entry distances, -1 in lanes that miss. */
inline float4 group_enter(__global const ts_box4 *g, float4 o, float4 inv, float tmin, float tmax)
{
    float4 tx0 = (vload4(0, g->lo_x) - o.x) * inv.x, tx1 = (vload4(0, g->hi_x) - o.x) * inv.x;
    float4 ty0 = (vload4(0, g->lo_y) - o.y) * inv.y, ty1 = (vload4(0, g->hi_y) - o.y) * inv.y;
    float4 tz0 = (vload4(0, g->lo_z) - o.z) * inv.z, tz1 = (vload4(0, g->hi_z) - o.z) * inv.z;
    float4 tn = TS_MAX(TS_MAX(TS_MIN(tx0, tx1), TS_MIN(ty0, ty1)), TS_MAX(TS_MIN(tz0, tz1), (float4)(tmin)));
    float4 tf = TS_MIN(TS_MIN(TS_MAX(tx0, tx1), TS_MAX(ty0, ty1)), TS_MIN(TS_MAX(tz0, tz1), (float4)(tmax)));
    tf *= 1.0000003576f;
    return select((float4)(-1.0f), tn, tn <= tf && vload4(0, g->lo_x) <= vload4(0, g->hi_x));
}

__kernel void bottom_level_trace(__global const ts_pair *pairs, uint pair_first, uint pair_count,
                                 __global const ts_segment *segments, uint seg_first,
                                 uint seg_count, uint verts_per_slot, uint groups_per_slot,
                                 uint n_per_ray, __global const uint *active,
                                 __global const ts_vec4 *org, __global const ts_vec4 *dir,
                                 __global const ts_hit *hit, __global const ts_vec4 *grid,
                                 __global const ts_box4 *groups, __global ts_hit *pair_hit)
{
    uint gid = get_global_id(0);
    if (gid >= pair_count) return;
    ts_pair pr = pairs[pair_first + gid];
    __global const ts_segment *batch = segments + seg_first;
    ts_segment seg = batch[segment_of(batch, seg_count, pair_first + gid)];
    uint ray = active[pr.window / n_per_ray];
    ts_vec4 o = org[ray], d = dir[ray];
    float4 o4 = (float4)(o.x, o.y, o.z, 0.0f);
    float4 inv = (float4)(safe_reciprocal(d.x), safe_reciprocal(d.y), safe_reciprocal(d.z), 0.0f);
    ts_ray_shear sh = ray_shear(d.x, d.y, d.z);
    uint4 perm = (uint4)((uint)sh.kx, (uint)sh.ky, (uint)sh.kz, 3u);
    ts_hit best = {hit[ray].t, 0.0f, 0.0f, TS_INVALID, TS_INVALID};
    __global const ts_vec4 *g = grid + (size_t)seg.slot * verts_per_slot;
    __global const ts_box4 *t = groups + (size_t)seg.slot * groups_per_slot;
    uint m = seg.lod;
    /* Stack of inner nodes still to visit: (level << 24) | index in the level, with the
     * entry distance. Leaves are intersected as soon as their group is tested. */
    uint stack[BL_STACK];
    float stack_t[BL_STACK];
    int sp = 0;
    ts_box root = quadtree_box(t, 0u, 0u);
    float te = box_enter(o.x, o.y, o.z, inv.x, inv.y, inv.z, root.lo_x, root.lo_y, root.lo_z,
                         root.hi_x, root.hi_y, root.hi_z, o.w, best.t);
    if (te >= 0.0f && m == 0u) leaf_intersect(g, 0u, 0u, o4, o.w, perm, &sh, &best, seg.patch);
    else if (te >= 0.0f) {
        stack[0] = 0u;
        stack_t[0] = te;
        sp = 1;
    }
    while (sp > 0) {
        --sp;
        if (stack_t[sp] > best.t) continue;
        uint level = stack[sp] >> 24, k = stack[sp] & 0xffffffu;
        float4 e4 = group_enter(t + quadtree_group_offset(level + 1u) + k, o4, inv, o.w, best.t);
        float e[4] = {e4.x, e4.y, e4.z, e4.w};
        /* Children that are hit, sorted by entry distance, farthest first. */
        float tc[4];
        uint id[4];
        uint nc = 0;
        for (uint q = 0; q < 4u; ++q) {
            if (e[q] < 0.0f) continue;
            uint at = nc++;
            while (at > 0u && tc[at - 1u] < e[q]) {
                tc[at] = tc[at - 1u];
                id[at] = id[at - 1u];
                --at;
            }
            tc[at] = e[q];
            id[at] = 4u * k + q;
        }
        if (level + 1u == m) { /* the children are leaves: nearest first */
            for (uint q = nc; q-- > 0u;)
                if (tc[q] <= best.t) leaf_intersect(g, m, id[q], o4, o.w, perm, &sh, &best, seg.patch);
            continue;
        }
        for (uint q = 0; q < nc; ++q) {
            stack[sp] = ((level + 1u) << 24) | id[q];
            stack_t[sp] = tc[q];
            ++sp;
        }
    }
    if (best.patch == TS_INVALID) best.t = TS_NO_HIT;
    pair_hit[pr.window] = best;
}
