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

__kernel void top_level_collect(__global const ts_qbvh_node *nodes, __global const uint *active,
                                uint active_count, uint n_per_ray, __global const ts_vec4 *org,
                                __global const ts_vec4 *dir, __global const ts_hit *hit,
                                __global uint *entry, __global ts_pair *pairs, __global uint *count)
{
    uint i = get_global_id(0);
    if (i >= active_count) return;
    uint ray = active[i];
    ts_vec4 o = org[ray], d = dir[ray];
    float ix = safe_reciprocal(d.x), iy = safe_reciprocal(d.y), iz = safe_reciprocal(d.z);
    float tmax = hit[ray].t;
    uint state = entry[ray];
    uint node = state >> 3, pos = state & 7u, n = 0;
    uint order[4];
    if (state != TS_INVALID) child_order(nodes[node].axes, d.x, d.y, d.z, order);
    while (state != TS_INVALID) {
        if (pos < 4u) {
            uint c = order[pos++];
            __global const ts_qbvh_node *q = &nodes[node];
            float te = box_enter(o.x, o.y, o.z, ix, iy, iz, q->lo_x[c], q->lo_y[c], q->lo_z[c],
                                 q->hi_x[c], q->hi_y[c], q->hi_z[c], 0.0f, tmax);
            int child = q->child[c];
            if (te < 0.0f || child == TS_CHILD_EMPTY) continue;
            if (child >= 0) {
                node = (uint)child;
                pos = 0u;
                child_order(nodes[node].axes, d.x, d.y, d.z, order);
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
        }
    }
    count[i] = n;
    entry[ray] = state;
}
