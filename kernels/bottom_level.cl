/* bottom_level.cl — stage `bottom_level` (Hanika §3.2.1-3.4): each sorted (ray, patch) pair
 * of a batch traverses its patch's quad-tree front to back.
 * Reads:  pairs[pair_first ..), the batch's segments (found by binary search on begin), ray
 *         org/dir (dir.w = time), hit.t as tmax, the grid(s) and tree(s) of the segment.
 * Writes: pair_hit[pair.window]: the closest hit in this patch below tmax, or t = TS_NO_HIT.
 * Geometry, by `exact`:
 *   0 (default): the leaf boxes themselves (§3.3): conservative over each micro-quad's
 *     parameter square, so patches diced at different m leave no holes; the hit is the
 *     ray's entry into the box, (u, v) the square's centre.
 *   1: the two micro-triangles of each micro-quad (split along (i,j)-(i+1,j+1)), with the
 *     watertight test of lib/intersect.h; for cross-checks at a fixed m.
 * Motion (§3.4): a moving segment has a tree and a grid per time sample; boxes and vertices
 * are interpolated linearly at the ray's time.
 * Sibling boxes are tested four at a time (SoA groups, lib/quadtree.h). Stack: at most 3
 * entries per level plus one. */
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

/* Vertex v of the grid at the ray's time (g1 == 0 for a static patch). */
inline float4 vertex_at(__global const float4 *g0, __global const float4 *g1, uint v, float time)
{
    float4 p = g0[v];
    if (g1) p = p + time * (g1[v] - p);
    return p;
}

/* Tests the micro-triangles of micro-quad k of a patch diced at m; updates *best. The
 * vertices are made relative to the origin and permuted to the shear's axes with one
 * shuffle each (the host reference, triangle_hit, does the same arithmetic). */
inline void leaf_triangles(__global const float4 *g0, __global const float4 *g1, float time,
                           uint m, uint k, float4 o4, float tmin, uint4 perm,
                           const ts_ray_shear *sh, ts_hit *best, uint patch)
{
    uint i = morton_i(k), j = morton_j(k), n = (1u << m) + 1u;
    float4 v00 = shuffle(vertex_at(g0, g1, j * n + i, time) - o4, perm);
    float4 v10 = shuffle(vertex_at(g0, g1, j * n + i + 1u, time) - o4, perm);
    float4 v01 = shuffle(vertex_at(g0, g1, (j + 1u) * n + i, time) - o4, perm);
    float4 v11 = shuffle(vertex_at(g0, g1, (j + 1u) * n + i + 1u, time) - o4, perm);
    float b1, b2, scale = ldexp(1.0f, -(int)m);
    uint quad = j * (n - 1u) + i;
    float t = triangle_hit_permuted(sh, v00.x, v00.y, v00.z, v10.x, v10.y, v10.z, v11.x, v11.y,
                                    v11.z, tmin, best->t, &b1, &b2);
    if (t >= 0.0f) {
        *best = (ts_hit){t, ((float)i + b1 + b2) * scale, ((float)j + b2) * scale, patch,
                         TS_PRIM(m, 2u * quad)};
    }
    t = triangle_hit_permuted(sh, v00.x, v00.y, v00.z, v11.x, v11.y, v11.z, v01.x, v01.y, v01.z,
                              tmin, best->t, &b1, &b2);
    if (t >= 0.0f) {
        *best = (ts_hit){t, ((float)i + b1) * scale, ((float)j + b1 + b2) * scale, patch,
                         TS_PRIM(m, 2u * quad + 1u)};
    }
}

/* A leaf box hit at entry distance e (box mode). */
inline void leaf_box(uint m, uint k, float e, ts_hit *best, uint patch)
{
    if (!(e < best->t)) return;
    uint i = morton_i(k), j = morton_j(k);
    float scale = ldexp(1.0f, -(int)m);
    *best = (ts_hit){e, ((float)i + 0.5f) * scale, ((float)j + 0.5f) * scale, patch,
                     TS_PRIM(m, 2u * (j * (1u << m) + i))};
}

/* Slab test of the four boxes of sibling group g (and of its time-1 twin g1, interpolated
 * at `time`, when g1 != 0). Returns the entry distances, -1 in lanes that miss; *raw gets
 * the entries before clamping to tmin (below tmin when the ray starts inside the box). */
inline float4 group_enter(__global const ts_box4 *g, __global const ts_box4 *g1, float time,
                          float4 o, float4 inv, float tmin, float tmax, float4 *raw)
{
    float4 lx = vload4(0, g->lo_x), ly = vload4(0, g->lo_y), lz = vload4(0, g->lo_z);
    float4 hx = vload4(0, g->hi_x), hy = vload4(0, g->hi_y), hz = vload4(0, g->hi_z);
    if (g1) {
        lx += time * (vload4(0, g1->lo_x) - lx), ly += time * (vload4(0, g1->lo_y) - ly);
        lz += time * (vload4(0, g1->lo_z) - lz), hx += time * (vload4(0, g1->hi_x) - hx);
        hy += time * (vload4(0, g1->hi_y) - hy), hz += time * (vload4(0, g1->hi_z) - hz);
    }
    float4 tx0 = (lx - o.x) * inv.x, tx1 = (hx - o.x) * inv.x;
    float4 ty0 = (ly - o.y) * inv.y, ty1 = (hy - o.y) * inv.y;
    float4 tz0 = (lz - o.z) * inv.z, tz1 = (hz - o.z) * inv.z;
    float4 in = TS_MAX(TS_MAX(TS_MIN(tx0, tx1), TS_MIN(ty0, ty1)), TS_MIN(tz0, tz1));
    float4 tn = TS_MAX(in, (float4)(tmin));
    float4 tf = TS_MIN(TS_MIN(TS_MAX(tx0, tx1), TS_MAX(ty0, ty1)), TS_MIN(TS_MAX(tz0, tz1), (float4)(tmax)));
    tf *= 1.0000003576f;
    *raw = in;
    return select((float4)(-1.0f), tn, tn <= tf && lx <= hx);
}

__kernel void bottom_level_trace(__global const ts_pair *pairs, uint pair_first, uint pair_count,
                                 __global const ts_segment *segments, uint seg_first,
                                 uint seg_count, uint n_per_ray, uint exact,
                                 __global const uint *active, __global const ts_vec4 *org,
                                 __global const ts_vec4 *dir, __global const ts_hit *hit,
                                 __global const uint *ray_flags,
                                 __global const ts_vec4 *grid, __global const ts_box4 *groups,
                                 __global ts_hit *pair_hit)
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
    uint m = seg.lod, flags = ray_flags[ray];
    /* A shadow ray towards a point of an area light is not stopped by that light's own
     * (conservative) boxes. */
    if ((flags & TS_RAY_SHADOW) && (flags >> 1) == seg.patch + 1u) {
        best.t = TS_NO_HIT;
        pair_hit[pr.window] = best;
        return;
    }
    int moving = (seg.flags & TS_PATCH_MOVING) != 0u;
    float time = d.w;
    __global const float4 *g0 = (__global const float4 *)(grid + seg.vert_first);
    __global const float4 *g1 = moving ? g0 + quadtree_vertex_count(m) : 0;
    __global const ts_box4 *t0 = groups + seg.group_first;
    __global const ts_box4 *t1 = moving ? t0 + quadtree_group_count(m) : 0;
    /* Stack of inner nodes still to visit: (level << 24) | index in the level, with the
     * entry distance. Leaves are intersected as soon as their group is tested. */
    uint stack[BL_STACK];
    float stack_t[BL_STACK];
    int sp = 0;
    float4 raw4;
    float te = group_enter(t0, t1, time, o4, inv, o.w, best.t, &raw4).x; /* the root, lane 0 */
    if (te >= 0.0f && m == 0u) {
        if (exact) leaf_triangles(g0, g1, time, 0u, 0u, o4, o.w, perm, &sh, &best, seg.patch);
        else if (raw4.x >= o.w) leaf_box(0u, 0u, te, &best, seg.patch);
    } else if (te >= 0.0f) {
        stack[0] = 0u;
        stack_t[0] = te;
        sp = 1;
    }
    while (sp > 0) {
        --sp;
        if (stack_t[sp] > best.t) continue;
        uint level = stack[sp] >> 24, k = stack[sp] & 0xffffffu;
        uint grp = quadtree_group_offset(level + 1u) + k;
        float4 e4 = group_enter(t0 + grp, t1 ? t1 + grp : 0, time, o4, inv, o.w, best.t, &raw4);
        float e[4] = {e4.x, e4.y, e4.z, e4.w};
        /* A leaf box the ray starts inside is not geometry for it: the ray is leaving the
         * surface there (secondary rays, offset by epsilon, Hanika §3.3). */
        if (level + 1u == m && !exact)
            e4 = select(e4, (float4)(-1.0f), raw4 < (float4)(o.w)), e[0] = e4.x, e[1] = e4.y,
            e[2] = e4.z, e[3] = e4.w;
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
            for (uint q = nc; q-- > 0u;) {
                if (!(tc[q] <= best.t)) continue;
                if (exact) leaf_triangles(g0, g1, time, m, id[q], o4, o.w, perm, &sh, &best, seg.patch);
                else leaf_box(m, id[q], tc[q], &best, seg.patch);
            }
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
