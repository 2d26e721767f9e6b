/* top_level.cl — stage `top_level` (Hanika §3.1, Fig. 2): each active ray resumes its
 * ordered traversal of the top-level QBVH and appends up to n_per_ray candidate
 * (leaf, window) pairs, front to back.
 * Reads:  nodes, active[0..active_count), org, dir, hit.t (tmax: closest hit so far),
 *         entry (where the ray stopped last iteration).
 * Writes: pairs[i*n_per_ray .. +count[i]) and count[i] (the rest of the window is left
 *         as it was: sort reads only the first count[i], radix_sort_windows), entry
 *         (TS_INVALID once the traversal is finished).
 * Invariant: the child order of a node depends only on the signs of the ray direction on
 * the node's split axes, so (node, position) is enough to resume, and across all
 * iterations every leaf box the ray meets within tmax is emitted exactly once. */
#include "lib/shared_types.h"
#include "lib/intersect.h"
#include "lib/qbvh.h"

/* Which of node q's four children the ray enters within [0, tmax]: bit c for child c. The
 * slab test of box_enter (lib/intersect.h), lane by lane with the same operations, on all
 * four boxes at once; tmax is fixed for the launch, so testing a node's children when the
 * ray reaches the node decides exactly what testing each one in turn would. */
inline uint qbvh_children_hit(__global const ts_qbvh_node *q, float4 o, float4 inv, float tmax)
{
    float4 lx = vload4(0, q->lo_x), ly = vload4(0, q->lo_y), lz = vload4(0, q->lo_z);
    float4 hx = vload4(0, q->hi_x), hy = vload4(0, q->hi_y), hz = vload4(0, q->hi_z);
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

__kernel void top_level_collect(__global const ts_qbvh_node *nodes, __global const uint *active,
                                uint active_count, uint n_per_ray, __global const ts_vec4 *org,
                                __global const ts_vec4 *dir, __global const ts_hit *hit,
                                __global uint *entry, __global ts_pair *pairs, __global uint *count)
{
    uint i = get_global_id(0);
    if (i >= active_count) return;
    uint ray = active[i];
    ts_vec4 o = org[ray], d = dir[ray];
    float4 o4 = (float4)(o.x, o.y, o.z, 0.0f);
    float4 inv = (float4)(safe_reciprocal(d.x), safe_reciprocal(d.y), safe_reciprocal(d.z), 0.0f);
    float tmax = hit[ray].t;
    uint state = entry[ray];
    uint node = state >> 3, pos = state & 7u, n = 0, hits = 0u;
    uint order[4];
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
                node = (uint)child;
                pos = 0u;
                child_order(nodes[node].axes, d.x, d.y, d.z, order);
                hits = qbvh_children_hit(&nodes[node], o4, inv, tmax);
                continue;
            }
            pairs[i * n_per_ray + n] = (ts_pair){(uint)~child, i * n_per_ray + n};
            if (++n == n_per_ray) {
                state = (node << 3) | pos;
                break;
            }
        } else if (node == 0u) {
            state = TS_INVALID; /* back at the root with every child done */
        } else {
            qbvh_ascend(nodes, &node, &pos, order, d.x, d.y, d.z);
            hits = qbvh_children_hit(&nodes[node], o4, inv, tmax);
        }
    }
    count[i] = n;
    entry[ray] = state;
}
