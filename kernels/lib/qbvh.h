/* qbvh.h — ordered traversal of the top-level 4-wide BVH (ts_qbvh_node), shared by
 * top_level.cl and lod.cl. */
#ifndef TS_QBVH_H
#define TS_QBVH_H

#include "lib/shared_types.h"

/* The ray's visiting order of a node's four children: the half nearer along the node's
 * split axis first, then within each half the nearer child along the half's axis. It
 * depends only on the signs of the direction, so (node, position) resumes a traversal. */
TS_INLINE void child_order(ts_u32 axes, float dx, float dy, float dz, ts_u32 order[4])
{
    float d[3] = {dx, dy, dz};
    ts_u32 a0 = axes & 3u, a1 = (axes >> 2) & 3u, a2 = (axes >> 4) & 3u;
    ts_u32 first = d[a0] >= 0.0f ? 0u : 2u;
    ts_u32 lo0 = d[a1] >= 0.0f ? 0u : 1u, lo1 = d[a2] >= 0.0f ? 2u : 3u;
    ts_u32 pair0[2] = {lo0, 1u - lo0}, pair1[2] = {lo1, 5u - lo1};
    order[0] = first == 0u ? pair0[0] : pair1[0];
    order[1] = first == 0u ? pair0[1] : pair1[1];
    order[2] = first == 0u ? pair1[0] : pair0[0];
    order[3] = first == 0u ? pair1[1] : pair0[1];
}

/* Climbs from *node (all four children done) to its parent, and sets *pos to the position
 * after it in the parent's child order (refreshed in order[]), so the ordered traversal
 * goes on with the next sibling. */
TS_INLINE void qbvh_ascend(TS_CONST_GLOBAL ts_qbvh_node *nodes, ts_u32 *node, ts_u32 *pos,
                           ts_u32 order[4], float dx, float dy, float dz)
{
    ts_u32 slot = nodes[*node].parent_slot;
    *node = (ts_u32)nodes[*node].parent;
    child_order(nodes[*node].axes, dx, dy, dz, order);
    ts_u32 p = 0u;
    while (order[p] != slot)
        ++p;
    *pos = p + 1u;
}

#endif
