/* top_level.cl — stage `top_level` (Hanika §3.1, Fig. 2): each active ray resumes its
 * ordered traversal of the top-level QBVH and appends up to n_per_ray candidate
 * (leaf, window) pairs, front to back.
 * Reads:  nodes, cull and cull_levels (the upper levels of built patches' quad-trees as codes
 *         inside patch_box: candidates that cannot reach a leaf are left out, cull_enter),
 *         attr[].flags and the ray's flags and from (a shadow ray gets no candidate of a patch
 *         that casts no shadow, TS_PATCH_NO_SHADOW, an eye ray none of a patch the camera
 *         does not see, TS_PATCH_NO_CAMERA, a bounce's BSDF ray none that indirect rays do not
 *         see, TS_PATCH_NO_INDIRECT; read only where unseen_flags says the scene has such
 *         patches),
 *         active[0..active_count),
 *         org, dir, hit.t (tmax: closest hit so far),
 *         entry (where the ray stopped last iteration).
 * Writes: pairs[i*n_per_ray .. +count[i]) and count[i] (the rest of the window is left
 *         as it was: sort reads only the first count[i], radix_sort_windows), entry
 *         (TS_INVALID once the traversal is finished); with stamp != 0 (trace.c, when the
 *         frame's patches do not fit) leaving[leaf] = stamp for a candidate of a ray that
 *         leaves that patch (from == leaf + 1): the patches whose diced vertices bottom_level
 *         reads this iteration (the origin-patch rule), the others' trees being enough in box
 *         mode.
 * Water-filled windows (n_per_ray 0; trace.c, when the frame's patches do not fit): ray i's
 *         window is [window_first[i], window_first[i + 1]), sized from a counting launch
 *         before (count_only 1: count[i] = the candidates it would emit, up to n_per_ray,
 *         and nothing else written), so the pair buffer holds every candidate of the rays
 *         that have few and the iteration's patches are diced once for all of them. Such a
 *         window is filled to its end (TS_INVALID leaves where the ray had fewer, which sort
 *         drops), and a ray whose window is full stops at its next candidate, so one whose
 *         candidates all fit ends its traversal in this iteration. The counting launch also
 *         writes ray i's first stash_n candidates to stash[i * stash_n ..] (trace.c
 *         water_fill: pairs_scratch, unused until sort; stash_n < its cap), and the
 *         collecting launch copies them for a ray with count[i] <= stash_n, whose traversal
 *         ended in the counting launch, instead of traversing again: the same pairs.
 * Invariant: the child order of a node depends only on the signs of the ray direction on
 * the node's split axes, so (node, position) is enough to resume, and across all
 * iterations every leaf box the ray meets within tmax is emitted exactly once. */
#include "lib/shared_types.h"
#include "lib/intersect.h"
#include "lib/prefetch.h"
#include "lib/qbvh.h"
#include "lib/quadtree.h"

/* Which of four boxes, their planes in float4 lanes, the ray enters within [0, tmax]: bit c
 * for box c. The slab test of box_enter (lib/intersect.h), lane by lane with the same
 * operations, on all four boxes at once; tmax is fixed for the launch, so testing a node's
 * children when the ray reaches the node decides exactly what testing each one in turn
 * would. */
TS_INLINE_ALWAYS uint lanes_hits(float4 lx, float4 ly, float4 lz, float4 hx, float4 hy, float4 hz,
                                 float4 o, float4 inv, float tmax)
{
    float4 tx0 = (lx - o.x) * inv.x, tx1 = (hx - o.x) * inv.x;
    float4 ty0 = (ly - o.y) * inv.y, ty1 = (hy - o.y) * inv.y;
    float4 tz0 = (lz - o.z) * inv.z, tz1 = (hz - o.z) * inv.z;
    float4 tn = TS_MAX(TS_MAX(TS_MIN(tx0, tx1), TS_MIN(ty0, ty1)),
                       TS_MAX(TS_MIN(tz0, tz1), (float4)(0.0f)));
    float4 tf = TS_MIN(TS_MIN(TS_MAX(tx0, tx1), TS_MAX(ty0, ty1)),
                       TS_MIN(TS_MAX(tz0, tz1), (float4)(tmax)));
    tf *= 1.0000003576f;
    int4 hit = lx <= hx && tn <= tf;
    return (uint)(hit.x & 1) | (uint)(hit.y & 2) | (uint)(hit.z & 4) | (uint)(hit.w & 8);
}

/* lanes_hits on four boxes stored SoA (lo_x[4] .. hi_z[4], as ts_qbvh_node and ts_box4
 * begin). */
inline uint box4_hits(__global const float *b, float4 o, float4 inv, float tmax)
{
    return lanes_hits(vload4(0, b), vload4(1, b), vload4(2, b), vload4(3, b), vload4(4, b),
                      vload4(5, b), o, inv, tmax);
}

inline uint qbvh_children_hit(__global const ts_qbvh_node *q, float4 o, float4 inv, float tmax)
{
    return box4_hits(q->lo_x, o, inv, tmax);
}

/* lanes_hits on the four boxes of a culling copy's group c, decoded inside the patch's box p
 * (build.cl cull_encode; the tight codes' decoding, each box holding the tree's): the same
 * slab operations on boxes that hold the tree's, so a ray that enters a tree box within
 * [0, tmax] enters its decoded box too (the slab test is monotone in the planes). */
inline uint cull4_hits(__global const ts_tight4 *c, ts_box p, float4 o, float4 inv, float tmax)
{
    float4 lx, ly, lz, hx, hy, hz;
    tight4_decode(c, (float4)(p.lo_x), (float4)(p.lo_y), (float4)(p.lo_z), (float4)(p.hi_x),
                  (float4)(p.hi_y), (float4)(p.hi_z), (float4)(tight_step(p.lo_x, p.hi_x)),
                  (float4)(tight_step(p.lo_y, p.hi_y)), (float4)(tight_step(p.lo_z, p.hi_z)), &lx,
                  &ly, &lz, &hx, &hy, &hz);
    return lanes_hits(lx, ly, lz, hx, hy, hz, o, inv, tmax);
}

/* Whether the ray, within [0, tmax], enters a box of level 2 of a built patch's quad-tree
 * under a level-1 box it enters (levels 2; levels 1: a level-1 box; 0: the patch is not
 * built yet, always). bottom_level reaches a leaf only through boxes of both levels that it
 * enters within [tmin, tmax'] (tmin >= 0, tmax' <= tmax; group_enter: the same slab
 * operations), so a candidate that fails here finds no hit there and is left out: the hits
 * and their order do not change, only the pairs (TS_CULL_GROUPS). */
TS_INLINE_ALWAYS int cull_enter(__global const ts_tight4 *c, uint levels,
                                __global const ts_box *patch_box, float4 o, float4 inv, float tmax)
{
    if (levels == 0u) return 1;
    ts_box p = *patch_box;
    uint h = cull4_hits(c, p, o, inv, tmax);
    if (levels == 1u || h == 0u) return h != 0u;
    for (uint q = 0; q < 4u; ++q)
        if (((h >> q) & 1u) && cull4_hits(c + 1u + q, p, o, inv, tmax) != 0u) return 1;
    return 0;
}

/* The hit masks top_level_collect keeps on its way down: the nibbles of a uint. */
#define TL_HELD 8u

__kernel void top_level_collect(
    __global const ts_qbvh_node *nodes, __global const ts_tight4 *cull,
    __global const uint *cull_levels, __global const ts_box *patch_box, __global const uint *active,
    uint active_count, uint n_per_ray, __global const uint *window_first, uint count_only,
    __global const ts_vec4 *org, __global const ts_vec4 *dir, __global const ts_hit *hit,
    __global uint *entry, __global const uint *ray_flags, __global const uint *ray_from,
    __global const ts_patch_attr *attr, uint unseen_flags, __global ts_pair *pairs,
    __global uint *count, __global uint *leaving, uint stamp, __global uint *stash, uint stash_n)
{
    uint i = get_global_id(0);
    if (i >= active_count) return;
    /* The window: uniform, or water-filled (n_per_ray 0); counting, a cap of n_per_ray. */
    uint filled = n_per_ray == 0u && !count_only;
    uint base = filled ? window_first[i] : i * n_per_ray;
    uint limit = filled ? window_first[i + 1u] - base : n_per_ray;
#ifdef TS_PREFETCH_AT /* the rays ahead (lib/prefetch.h) */
    if (i + TS_PREFETCH_AHEAD < active_count) {
        uint ahead = active[i + TS_PREFETCH_AHEAD];
        TS_PREFETCH_AT(org + ahead), TS_PREFETCH_AT(dir + ahead);
        TS_PREFETCH_AT(hit + ahead), TS_PREFETCH_AT(entry + ahead);
    }
#endif
    uint ray = active[i];
    ts_vec4 o = org[ray], d = dir[ray];
    /* the patch this ray leaves + 1 where leaving is marked (0: none, or not marked) */
    uint leaves = stamp != 0u && !count_only ? ray_from[ray] : 0u;
    /* A ray whose every candidate the counting launch found and stashed (count[i] <=
     * stash_n, fewer than its cap: its traversal ended there): its window takes them all,
     * copied in the order the traversal emitted them. */
    if (filled && stash_n != 0u && count[i] <= stash_n && count[i] <= limit) {
        uint c = count[i];
        __global const uint *st = stash + (size_t)i * stash_n;
        for (uint k = 0; k < c; ++k) {
            uint leaf = st[k];
            pairs[base + k] = (ts_pair){leaf, base + k};
            if (leaves == leaf + 1u) atomic_xchg(leaving + leaf, stamp); /* rays alike */
        }
        for (uint k = c; k < limit; ++k)
            pairs[base + k] = (ts_pair){TS_INVALID, base + k};
        entry[ray] = TS_INVALID;
        return; /* count[i] stays c */
    }
    float4 o4 = (float4)(o.x, o.y, o.z, 0.0f);
    float4 inv = (float4)(safe_reciprocal(d.x), safe_reciprocal(d.y), safe_reciprocal(d.z), 0.0f);
    float tmax = hit[ray].t;
    /* The patches this ray passes through: a shadow ray those that cast no shadow, an eye ray
     * those the camera does not see, a bounce's BSDF ray those indirect rays do not see
     * (unseen_flags: the flags some patch of the scene has, so
     * that a scene without them reads no attributes here). */
    uint unseen = !unseen_flags                      ? 0u
                  : (ray_flags[ray] & TS_RAY_SHADOW) ? TS_PATCH_NO_SHADOW & unseen_flags
                  : ray_from[ray] == 0u              ? TS_PATCH_NO_CAMERA & unseen_flags
                                                     : TS_PATCH_NO_INDIRECT & unseen_flags;
    uint state = entry[ray];
    uint node = state >> 3, pos = state & 7u, n = 0, hits = 0u;
    uint order[4];
    /* The hit masks of the nodes above, a nibble each (the last TL_HELD), pushed as the
     * traversal descends, so that climbing back needs no second test of the parent's
     * children: the same mask, tmax being fixed for the launch. Above what this launch pushed
     * (a traversal resumed below the root, or more than TL_HELD levels up) the children are
     * tested again. */
    uint above = 0u, held = 0u;
    if (state != TS_INVALID) {
        child_order(nodes[node].axes, d.x, d.y, d.z, order);
        hits = qbvh_children_hit(&nodes[node], o4, inv, tmax);
    }
    while (state != TS_INVALID) {
        if (pos < 4u) {
            uint c = order[pos++];
            int child = nodes[node].child[c];
            if (!((hits >> c) & 1u) || child == TS_CHILD_EMPTY) continue;
            if (child >= 0) {
                above = (above << 4) | hits;
                held = held < TL_HELD ? held + 1u : TL_HELD;
                node = (uint)child;
                pos = 0u;
                child_order(nodes[node].axes, d.x, d.y, d.z, order);
                hits = qbvh_children_hit(&nodes[node], o4, inv, tmax);
                continue;
            }
            uint leaf = (uint)~child;
            if (unseen && (attr[leaf].flags & unseen)) continue;
            if (!cull_enter(cull + (size_t)leaf * TS_CULL_GROUPS, cull_levels[leaf],
                            patch_box + leaf, o4, inv, tmax))
                continue;
            if (filled && n == limit) { /* full: resume at this candidate */
                state = (node << 3) | (pos - 1u);
                break;
            }
            if (!count_only)
                pairs[base + n] = (ts_pair){leaf, base + n};
            else if (n < stash_n)
                stash[(size_t)i * stash_n + n] = leaf;
            if (leaves == leaf + 1u) atomic_xchg(leaving + leaf, stamp); /* rays alike */
            if (++n == limit && !filled) {
                state = (node << 3) | pos;
                break;
            }
        } else if (node == 0u) {
            state = TS_INVALID; /* back at the root with every child done */
        } else {
            qbvh_ascend(nodes, &node, &pos, order, d.x, d.y, d.z);
            if (held != 0u) {
                hits = above & 15u, above >>= 4, --held;
            } else {
                hits = qbvh_children_hit(&nodes[node], o4, inv, tmax);
            }
        }
    }
    count[i] = n;
    if (count_only) return;
    for (uint k = n; filled && k < limit; ++k)
        pairs[base + k] = (ts_pair){TS_INVALID, base + k};
    entry[ray] = state;
}
