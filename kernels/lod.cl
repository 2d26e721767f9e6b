/* lod.cl — stage `lod` (Hanika §3.3, level of detail): counts, for every patch, the eye rays
 * of the frame's first sample pass whose path meets the patch's box; the host then dices
 * patch p at the smallest m with 4^m >= that count (Hanika's R / spp: a pass has one ray per
 * pixel). The paper counts R per segment of an iteration; counting over the frame's first
 * pass instead makes m independent of how rays are split into waves and iterations, so an
 * image does not change with --memory. The default rule counts every crossing (no tmax); the
 * experimental rules (TESSERA_LOD_RULE=visible|seen, pipeline_lod) count a second time,
 * once the pass has been traced, only the crossings before each ray's closest hit (use_hit:
 * tmax = hit.t), to dice patches hidden behind others coarser.
 * Reads:  nodes, a wave of eye rays (org, dir; hit when use_hit).
 * Writes: counts[patch] += 1 per ray whose ordered traversal enters the patch's leaf box
 *         before tmax (integer atomics: the counts do not depend on order);
 *         crossings[i]: how many leaf boxes ray i entered (the host's cost of its pixel for
 *         the progress line's estimate, host/app/eta.h). */
#include "lib/shared_types.h"
#include "lib/intersect.h"
#include "lib/qbvh.h"

__kernel void lod_count(__global const ts_qbvh_node *nodes, uint ray_count,
                        __global const ts_vec4 *org, __global const ts_vec4 *dir,
                        __global const ts_hit *hit, uint use_hit, __global uint *counts,
                        __global uint *crossings)
{
    uint i = get_global_id(0);
    if (i >= ray_count) return;
    ts_vec4 o = org[i], d = dir[i];
    /* A crossing at the hit itself counts: the hit patch's box is entered no later. */
    float tmax = use_hit ? hit[i].t : INFINITY;
    float ix = safe_reciprocal(d.x), iy = safe_reciprocal(d.y), iz = safe_reciprocal(d.z);
    uint node = 0u, pos = 0u, order[4], crossed = 0u;
    child_order(nodes[0].axes, d.x, d.y, d.z, order);
    for (;;) {
        if (pos < 4u) {
            uint c = order[pos++];
            __global const ts_qbvh_node *q = &nodes[node];
            int child = q->child[c];
            if (child == TS_CHILD_EMPTY ||
                box_enter(o.x, o.y, o.z, ix, iy, iz, q->lo_x[c], q->lo_y[c], q->lo_z[c], q->hi_x[c],
                          q->hi_y[c], q->hi_z[c], 0.0f, tmax) < 0.0f)
                continue;
            if (child >= 0) {
                node = (uint)child;
                pos = 0u;
                child_order(nodes[node].axes, d.x, d.y, d.z, order);
            } else {
                atomic_inc(&counts[(uint)~child]);
                ++crossed;
            }
        } else if (node == 0u) {
            crossings[i] = crossed;
            return;
        } else {
            qbvh_ascend(nodes, &node, &pos, order, d.x, d.y, d.z);
        }
    }
}
