/* shade.cl — stage `shade` for primary rays: Lambert under one distant light plus a constant
 * ambient term, no shadows (path tracing replaces this in its own issue).
 * Reads:  dir, hit (patch, u, v, t), control points (for the smooth Bézier normal at (u, v)),
 *         patch colours.
 * Writes: radiance[ray] (rgb, w = 1 on a hit), aov[ray] = (N.x, N.y, N.z, Z): the unit normal
 *         facing the ray and the hit distance along the unit direction (+inf on a miss). */
#include "lib/shared_types.h"
#include "lib/bezier.h"

__kernel void shade_lambert(ts_shade_params p, uint ray_count, __global const ts_vec4 *dir,
                            __global const ts_hit *hit, __global const ts_vec4 *cp,
                            __global const ts_patch_attr *attr, __global ts_vec4 *radiance,
                            __global ts_vec4 *aov)
{
    uint i = get_global_id(0);
    if (i >= ray_count) return;
    ts_hit h = hit[i];
    if (h.patch == TS_INVALID) {
        radiance[i] = (ts_vec4){0.0f, 0.0f, 0.0f, 0.0f};
        aov[i] = (ts_vec4){0.0f, 0.0f, 0.0f, INFINITY};
        return;
    }
    ts_vec4 d = dir[i];
    ts_vec4 n = bezier_normal(cp + (size_t)h.patch * 16u, h.u, h.v);
    if (n.x * d.x + n.y * d.y + n.z * d.z > 0.0f) {
        n.x = -n.x;
        n.y = -n.y;
        n.z = -n.z;
    }
    float cosl = fmax(0.0f, n.x * p.light_dir[0] + n.y * p.light_dir[1] + n.z * p.light_dir[2]);
    ts_patch_attr a = attr[h.patch];
    radiance[i] = (ts_vec4){a.cs_r * (p.ambient[0] + p.light_color[0] * cosl),
                            a.cs_g * (p.ambient[1] + p.light_color[1] * cosl),
                            a.cs_b * (p.ambient[2] + p.light_color[2] * cosl), 1.0f};
    aov[i] = (ts_vec4){n.x, n.y, n.z, h.t};
}
