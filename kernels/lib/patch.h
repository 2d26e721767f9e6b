/* patch.h — one diced vertex of a patch (Hanika §3.2): the Bézier surface point, moved along
 * the displacement normal by the patch's displacement function. The one definition used by
 * the dice kernel and by every host reference (brute force, Embree), so they dice the same
 * micro-polygons bit for bit. */
#ifndef TS_PATCH_H
#define TS_PATCH_H

#include "lib/bezier.h"
#include "lib/bsdf.h"
#include "lib/displace.h"
#include "lib/quadtree.h"
#include "lib/shared_types.h"

/* The vertex at (u, v) of patch cp (16 control points of the time sample being diced),
 * with displacement normals n (4 corners) and mid (5, scene.h mid_n) and attributes a, transform x,
 * textures tex. xyz = displaced position, w = the displacement d. The noise is evaluated at the
 * undisplaced point of time 0 (cp0), so the pattern moves with a moving patch; a texture at the st
 * of (u, v). */
TS_INLINE ts_vec4 patch_vertex(TS_CONST_GLOBAL ts_vec4 *cp, TS_CONST_GLOBAL ts_vec4 *cp0,
                               TS_CONST_GLOBAL ts_vec4 *n, TS_CONST_GLOBAL ts_vec4 *mid,
                               TS_CONST_GLOBAL ts_patch_attr *a, TS_CONST_GLOBAL ts_xform *x,
                               ts_tex_ctx tex, float u, float v)
{
    ts_vec4 p = bezier_eval(cp, u, v);
    if (a->disp_kind == TS_DISP_NONE) {
        p.w = 0.0f;
        return p;
    }
    float d;
    if (a->disp_kind == TS_DISP_TEXTURE) {
        d = displace_texture_value(a, tex, u, v);
    } else {
        ts_vec4 p0 = cp0 == cp ? p : bezier_eval(cp0, u, v);
        d = displace_value(a, x, p0.x, p0.y, p0.z);
    }
    ts_vec4 dn = displace_normal(n, mid, u, v);
    ts_vec4 r = {p.x + d * dn.x, p.y + d * dn.y, p.z + d * dn.z, d};
    return r;
}

/* Upper bound, per axis, of how far the undisplaced surface strays from the bilinear
 * interpolation of its four corner points over any parameter square of side h = 2^-m:
 * f - L = (f - L_u f) + L_u (f - L_v f) gives |f - L| <= h^2/8 (max|P_uu| + max|P_vv|),
 * and for a cubic Bézier |P_uu| <= 6 max |second difference of the control points along u|
 * (a convex combination of them), likewise along v. Covers both time samples when
 * cp1 != cp. Returns (ex, ey, ez). */
TS_INLINE ts_vec4 patch_flatness(TS_CONST_GLOBAL ts_vec4 *cp, TS_CONST_GLOBAL ts_vec4 *cp1,
                                 ts_u32 m)
{
    float h = ldexp(1.0f, -(int)m), e[3] = {0.0f, 0.0f, 0.0f};
    for (int t = 0; t < 2; ++t) {
        TS_CONST_GLOBAL ts_vec4 *c = t == 0 ? cp : cp1;
        float uu[3] = {0, 0, 0}, vv[3] = {0, 0, 0};
        for (int j = 0; j < 4; ++j)
            for (int i = 0; i < 4; ++i) {
                ts_vec4 p = c[j * 4 + i];
                if (i < 2) {
                    ts_vec4 q = c[j * 4 + i + 1], r = c[j * 4 + i + 2];
                    uu[0] = fmax(uu[0], fabs(p.x - 2.0f * q.x + r.x));
                    uu[1] = fmax(uu[1], fabs(p.y - 2.0f * q.y + r.y));
                    uu[2] = fmax(uu[2], fabs(p.z - 2.0f * q.z + r.z));
                }
                if (j < 2) {
                    ts_vec4 q = c[(j + 1) * 4 + i], r = c[(j + 2) * 4 + i];
                    vv[0] = fmax(vv[0], fabs(p.x - 2.0f * q.x + r.x));
                    vv[1] = fmax(vv[1], fabs(p.y - 2.0f * q.y + r.y));
                    vv[2] = fmax(vv[2], fabs(p.z - 2.0f * q.z + r.z));
                }
            }
        for (int k = 0; k < 3; ++k)
            e[k] = fmax(e[k], h * h * 0.75f * (uu[k] + vv[k]));
        if (cp1 == cp) break;
    }
    /* Slack for the rounding of the float evaluation of the corners. */
    ts_vec4 r = {e[0] * 1.001f, e[1] * 1.001f, e[2] * 1.001f, 0.0f};
    return r;
}

/* The unit normal of the surface whose points pu0, pu1 (along u) and pv0, pv1 (along v)
 * were evaluated about (u, v): the cross product of the differences, or the Bézier normal
 * where it vanishes. */
TS_INLINE ts_vec4 patch_normal_of_differences(TS_CONST_GLOBAL ts_vec4 *cp, float u, float v,
                                              ts_vec4 pu0, ts_vec4 pu1, ts_vec4 pv0, ts_vec4 pv1)
{
    ts_v3 du = v3(pu1.x - pu0.x, pu1.y - pu0.y, pu1.z - pu0.z);
    ts_v3 dv = v3(pv1.x - pv0.x, pv1.y - pv0.y, pv1.z - pv0.z);
    ts_v3 c = v3_cross(du, dv);
    float len = sqrt(v3_dot(c, c));
    if (!(len > 0.0f)) return bezier_normal(cp, u, v);
    ts_vec4 r = {c.x / len, c.y / len, c.z / len, 0.0f};
    return r;
}

/* The normal at (u, v) of patch cp diced at LOD m by central differences over one micro-quad
 * (Hanika §3.2; the bake's points, bake.cl): the Bézier normal without displacement, else the
 * displaced surface's, falling back to the Bézier normal at a degenerate corner. */
TS_INLINE ts_vec4 patch_shading_normal(TS_CONST_GLOBAL ts_vec4 *cp, TS_CONST_GLOBAL ts_vec4 *n,
                                       TS_CONST_GLOBAL ts_vec4 *mid,
                                       TS_CONST_GLOBAL ts_patch_attr *a,
                                       TS_CONST_GLOBAL ts_xform *x, ts_tex_ctx tex, float u,
                                       float v, ts_u32 m)
{
    if (a->disp_kind == TS_DISP_NONE) return bezier_normal(cp, u, v);
    float h = 0.5f * ldexp(1.0f, -(int)m);
    float u0 = fmax(u - h, 0.0f), u1 = fmin(u + h, 1.0f);
    float v0 = fmax(v - h, 0.0f), v1 = fmin(v + h, 1.0f);
    ts_vec4 pu0 = patch_vertex(cp, cp, n, mid, a, x, tex, u0, v),
            pu1 = patch_vertex(cp, cp, n, mid, a, x, tex, u1, v);
    ts_vec4 pv0 = patch_vertex(cp, cp, n, mid, a, x, tex, u, v0),
            pv1 = patch_vertex(cp, cp, n, mid, a, x, tex, u, v1);
    return patch_normal_of_differences(cp, u, v, pu0, pu1, pv0, pv1);
}

/* The unit normal at its centre of the bilinear micro-quad with corners p00, p10, p01, p11
 * (grid vertices (i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)): the cross product of its
 * diagonals, (p11 - p00) x (p01 - p10), or the Bézier normal at (u, v) where it vanishes. */
TS_INLINE ts_vec4 patch_quad_normal(TS_CONST_GLOBAL ts_vec4 *cp, float u, float v, ts_vec4 p00,
                                    ts_vec4 p10, ts_vec4 p01, ts_vec4 p11)
{
    return patch_normal_of_differences(cp, u, v, p00, p11, p10, p01);
}

/* The shading normal of a hit at (u, v) in micro-quad (i, j) of patch cp diced at LOD m
 * (shade.cl; the Embree benchmark's bounce rays on the host): the Bézier normal at (u, v)
 * without displacement, else the normal of the displaced micro-quad itself, patch_quad_normal
 * of the four vertices dice makes there (parameters i 2^-m exactly, as dice.cl), so that shade
 * can read them from the diced grid instead (issue 13). */
TS_INLINE ts_vec4 patch_quad_shading_normal(TS_CONST_GLOBAL ts_vec4 *cp, TS_CONST_GLOBAL ts_vec4 *n,
                                            TS_CONST_GLOBAL ts_vec4 *mid,
                                            TS_CONST_GLOBAL ts_patch_attr *a,
                                            TS_CONST_GLOBAL ts_xform *x, ts_tex_ctx tex, float u,
                                            float v, ts_u32 i, ts_u32 j, ts_u32 m, ts_u32 edges)
{
    if (a->disp_kind == TS_DISP_NONE) return bezier_normal(cp, u, v);
    /* the corners where dice put them (edges: triangle mode's stitching, quadtree_stitch) */
    float pu[4], pv[4];
    quadtree_quad_corners(edges, m, i, j, pu, pv);
    ts_vec4 q[4];
    for (int c = 0; c < 4; ++c)
        q[c] = patch_vertex(cp, cp, n, mid, a, x, tex, pu[c], pv[c]);
    return patch_quad_normal(cp, u, v, q[0], q[1], q[2], q[3]);
}

#endif
