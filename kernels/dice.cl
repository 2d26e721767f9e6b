/* dice.cl — stage `dice` (Hanika §3.2): evaluates the (2^m+1)^2 vertices of each patch
 * segment of a batch into the segment's slot.
 * Reads:  segments[seg_first .. seg_first+seg_count) (patch, slot, lod = m), control points.
 * Writes: grid[slot * verts_per_slot + j * (2^m+1) + i] = P(i / 2^m, j / 2^m).
 * One work-item per (segment, vertex); items past a segment's (2^m+1)^2 return.
 * Parameters are i * 2^-m exactly (ldexp), so the host reference dices the same points. */
#include "lib/shared_types.h"
#include "lib/bezier.h"

__kernel void dice_grid(__global const ts_segment *segments, uint seg_first, uint seg_count,
                        uint verts_per_slot, __global const ts_vec4 *cp, __global ts_vec4 *grid)
{
    uint gid = get_global_id(0);
    uint s = gid / verts_per_slot, v = gid % verts_per_slot;
    if (s >= seg_count) return;
    ts_segment seg = segments[seg_first + s];
    uint n = (1u << seg.lod) + 1u;
    if (v >= n * n) return;
    float u = ldexp((float)(v % n), -(int)seg.lod);
    float w = ldexp((float)(v / n), -(int)seg.lod);
    grid[(size_t)seg.slot * verts_per_slot + v] = bezier_eval(cp + (size_t)seg.patch * 16u, u, w);
}
