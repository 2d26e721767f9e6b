/* shade.cl — stage `shade` for primary rays: Lambert under one distant light plus a constant
 * ambient term, no shadows (path tracing replaces this in its own issue).
 * Reads:  dir, hit (patch, u, v, t, prim's LOD), patch data (control points at time 0,
 *         corner normals, attributes, transforms), patch colours.
 * Writes: radiance[ray] (rgb, w = 1 on a hit), aov[ray] = (N.x, N.y, N.z, Z): the unit normal
 *         facing the ray and the hit distance along the unit direction (+inf on a miss).
 * Normal: the Bézier normal at (u, v); on a displaced patch, the normal of the displaced
 * surface by central differences of patch_vertex over one micro-quad (the LOD the patch was
 * diced at), the paper's "normal by vertex differences" (§3.2). Moving patches are shaded
 * with their time-0 shape. */
#include "lib/shared_types.h"
#include "lib/bezier.h"
#include "lib/patch.h"

inline ts_vec4 surface_normal(__global const ts_vec4 *cp, __global const ts_vec4 *n,
                              __global const ts_patch_attr *a, __global const ts_xform *x,
                              float u, float v, uint m)
{
    if (a->disp_kind == TS_DISP_NONE) return bezier_normal(cp, u, v);
    float h = 0.5f * ldexp(1.0f, -(int)m);
    float u0 = fmax(u - h, 0.0f), u1 = fmin(u + h, 1.0f);
    float v0 = fmax(v - h, 0.0f), v1 = fmin(v + h, 1.0f);
    ts_vec4 pu0 = patch_vertex(cp, cp, n, a, x, u0, v), pu1 = patch_vertex(cp, cp, n, a, x, u1, v);
    ts_vec4 pv0 = patch_vertex(cp, cp, n, a, x, u, v0), pv1 = patch_vertex(cp, cp, n, a, x, u, v1);
    float ax = pu1.x - pu0.x, ay = pu1.y - pu0.y, az = pu1.z - pu0.z;
    float bx = pv1.x - pv0.x, by = pv1.y - pv0.y, bz = pv1.z - pv0.z;
    float nx = ay * bz - az * by, ny = az * bx - ax * bz, nz = ax * by - ay * bx;
    float len = sqrt(nx * nx + ny * ny + nz * nz);
    if (!(len > 0.0f)) return bezier_normal(cp, u, v); /* degenerate corner */
    ts_vec4 r = {nx / len, ny / len, nz / len, 0.0f};
    return r;
}

__kernel void shade_lambert(ts_shade_params p, uint ray_count, __global const ts_vec4 *dir,
                            __global const ts_hit *hit, __global const ts_vec4 *cp,
                            __global const ts_vec4 *corner_n, __global const ts_patch_attr *attr,
                            __global const ts_xform *xform, __global ts_vec4 *radiance,
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
    __global const ts_patch_attr *a = attr + h.patch;
    ts_vec4 n = surface_normal(cp + (size_t)h.patch * 16u, corner_n + (size_t)h.patch * 4u, a,
                               xform + a->xform, h.u, h.v, TS_PRIM_LOD(h.prim));
    if (n.x * d.x + n.y * d.y + n.z * d.z > 0.0f) {
        n.x = -n.x;
        n.y = -n.y;
        n.z = -n.z;
    }
    float cosl = fmax(0.0f, n.x * p.light_dir[0] + n.y * p.light_dir[1] + n.z * p.light_dir[2]);
    radiance[i] = (ts_vec4){a->cs_r * (p.ambient[0] + p.light_color[0] * cosl),
                            a->cs_g * (p.ambient[1] + p.light_color[1] * cosl),
                            a->cs_b * (p.ambient[2] + p.light_color[2] * cosl), 1.0f};
    aov[i] = (ts_vec4){n.x, n.y, n.z, h.t};
}
