/* bake.cl — stage `bake` (PantaRay §3 and §4.4, issue 18): spherical-harmonics directional
 * occlusion at points on every patch, the rays traced by the same two-level pipeline as a
 * render (top_level .. resolve, shadow rays: the first hit ends them). A wave of points:
 *   bake_points   one work-item per point: global point g lies on the patch p whose range
 *                 [point_first[p], point_first[p + 1]) holds it, at vertex (i, j) of p diced
 *                 at m = lod[p] ((2^m+1)^2 vertices, row by row: k = j (2^m+1) + i, (u, v) =
 *                 (i, j) / 2^m exactly; a vertex on the patch's boundary is taken a quarter
 *                 of a micro-quad inside, (u, v) clamped to [2^-m / 4, 1 - 2^-m / 4]).
 *                 Writes its position (patch_vertex at shutter open, displaced; w = the rays'
 *                 offset eps = l / 2^m as for secondary rays, Hanika §3.3), its normal
 *                 (patch_shading_normal at m, turned towards the camera unless
 *                 TS_BAKE_FRONT; w = 0) and its patch.
 *   bake_rays     one work-item per ray: ray r = i N + k is sample k of point i. Directions
 *                 from the sampler's bake set (lib/sampler.h, keyed by the global point g, so a
 *                 point's rays do not depend on the wave it falls in): uniform over the
 *                 hemisphere about n, cosine-weighted (TS_BAKE_COSINE), or uniform over the
 *                 sphere (TS_BAKE_SPHERE: a direction below the surface is left untraced,
 *                 entry = TS_INVALID). Each ray starts at P + eps n, flagged TS_RAY_SHADOW,
 *                 leaving patch p (ray_from = p + 1: bottom_level meets p as micro-triangles
 *                 and ignores hits on it nearer than eps, the origin-patch rule).
 *   bake_project  one work-item per point, after resolve: c_lm = sum over its N rays, in
 *                 order, of w V(d) Y_lm(d), V = 1 when the ray hit nothing and d . n > 0,
 *                 w = 2 pi / N (hemisphere), 4 pi / N (sphere), pi / N (cosine-weighted
 *                 directions: the estimator of the integral of V cos Y), 4 pi cos / N (sphere
 *                 with cosine). Writes B^2 floats per point.
 * Every value is a pure function of (point, ray, seed, the patch's m), and each work-item
 * writes only its own entries: the results do not depend on waves, thread counts or memory.
 * The convention of the coefficients (real SH, index l^2 + l + m) is lib/sh.h's. */
#include "lib/shared_types.h"
#include "lib/patch.h"
#include "lib/sampler.h"
#include "lib/sh.h"

/* The bake's directions: the sampler's set 0 with the global point index as its "pixel"
 * (bake rays never share a program run with eye rays). */
#define BAKE_SET 0u

/* The patch holding global point g: the last p with point_first[p] <= g. */
inline uint bake_patch_of(__global const uint *point_first, uint patch_count, uint g)
{
    uint lo = 0u, hi = patch_count;
    while (hi - lo > 1u) {
        uint mid = (lo + hi) / 2u;
        if (point_first[mid] <= g)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* Points [get_global_id(0), end) of the wave (the host launches ranges of it when textures
 * are paged, so that each range's tiles fit the pool). */
__kernel void bake_points(ts_bake_params bp, uint end, __global const uint *point_first,
                          __global const uint *lod, __global const ts_vec4 *cp,
                          __global const ts_vec4 *corner_n, __global const ts_vec4 *mid_n,
                          __global const ts_patch_attr *attr, __global const ts_xform *xform,
                          __global const ts_vec4 *flatness, __global const ts_texture *textures,
                          __global const uint *tex_pages, __global const ts_vec4 *tex_pool,
                          __global ts_vec4 *point_pos, __global ts_vec4 *point_n,
                          __global uint *point_patch)
{
    uint i = get_global_id(0);
    if (i >= end) return;
    uint g = bp.first_point + i;
    uint p = bake_patch_of(point_first, bp.patch_count, g);
    uint m = lod[p], n = (1u << m) + 1u, k = g - point_first[p];
    /* A vertex on the patch's boundary is shared with its neighbours, and where a neighbour
     * meets the patch at an angle (a concave junction: a wall on a floor) the vertex lies on
     * it, so whether a ray from there meets it is rounding: the point moves a quarter of a
     * micro-quad into the patch. */
    float q = ldexp(0.25f, -(int)m);
    float u = clamp(quadtree_vertex_param(k % n, m), q, 1.0f - q);
    float v = clamp(quadtree_vertex_param(k / n, m), q, 1.0f - q);
    __global const ts_vec4 *c = cp + (size_t)p * 16u;
    __global const ts_vec4 *cn = corner_n + (size_t)p * 4u, *mn = mid_n + (size_t)p * 5u;
    __global const ts_patch_attr *a = attr + p;
    ts_tex_ctx tex = {textures, tex_pages, tex_pool};
    ts_vec4 pos = patch_vertex(c, c, cn, mn, a, xform + a->xform, tex, u, v);
    ts_vec4 nn = patch_shading_normal(c, cn, mn, a, xform + a->xform, tex, u, v, m);
    if (!(nn.x * nn.x + nn.y * nn.y + nn.z * nn.z > 0.5f)) /* no normal: take +z */
        nn = (ts_vec4){0.0f, 0.0f, 1.0f, 0.0f};
    if (!(bp.flags & TS_BAKE_FRONT)) {
        /* faceforward towards the camera, as a RenderMan bake shader does: the side the
         * camera sees (and the relit render shades). */
        float tx = bp.orthographic ? -bp.eye[0] : bp.eye[0] - pos.x;
        float ty = bp.orthographic ? -bp.eye[1] : bp.eye[1] - pos.y;
        float tz = bp.orthographic ? -bp.eye[2] : bp.eye[2] - pos.z;
        if (nn.x * tx + nn.y * ty + nn.z * tz < 0.0f) nn.x = -nn.x, nn.y = -nn.y, nn.z = -nn.z;
    }
    /* eps: the longest side of the patch's box (flatness w) over 2^m, as shade offsets the
     * rays that leave a hit. */
    pos.w = flatness[p].w * ldexp(1.0f, -(int)m);
    nn.w = 0.0f;
    point_pos[i] = pos;
    point_n[i] = nn;
    point_patch[i] = p;
}

/* The direction of sample (u1, u2) about unit n: uniform over the hemisphere, cosine-
 * weighted, or uniform over the sphere (flags). */
inline ts_v3 bake_direction(uint flags, ts_v3 n, float u1, float u2)
{
    if (!(flags & TS_BAKE_SPHERE) && (flags & TS_BAKE_COSINE)) return sample_cosine(n, u1, u2);
    float z = flags & TS_BAKE_SPHERE ? 1.0f - 2.0f * u1 : 1.0f - u1; /* (0, 1] or (-1, 1] */
    float r = sqrt(fmax(0.0f, 1.0f - z * z)), phi = 2.0f * TS_PI * u2;
    return local_to_world(v3(r * cos(phi), r * sin(phi), z), n);
}

__kernel void bake_rays(ts_bake_params bp, __global const ts_vec4 *point_pos,
                        __global const ts_vec4 *point_n, __global const uint *point_patch,
                        __global ts_vec4 *org, __global ts_vec4 *dir, __global ts_hit *hit,
                        __global uint *entry, __global uint *flags, __global uint *from,
                        __global uint *active)
{
    uint r = get_global_id(0);
    if (r >= bp.point_count * bp.rays) return;
    uint i = r / bp.rays, k = r % bp.rays, g = bp.first_point + i;
    ts_vec4 pos = point_pos[i], n4 = point_n[i];
    ts_v3 n = v3(n4.x, n4.y, n4.z);
    uint mask = sampler_mask(bp.rays);
    float u1 = sampler_value(g, k, BAKE_SET, 0u, bp.seed, mask);
    float u2 = sampler_value(g, k, BAKE_SET, 1u, bp.seed, mask);
    ts_v3 d = bake_direction(bp.flags, n, u1, u2);
    float eps = pos.w;
    org[r] = (ts_vec4){pos.x + eps * n.x, pos.y + eps * n.y, pos.z + eps * n.z, eps};
    dir[r] = (ts_vec4){d.x, d.y, d.z, 0.0f}; /* time 0: the shape the points lie on */
    hit[r] = (ts_hit){TS_NO_HIT, 0.0f, 0.0f, TS_INVALID, TS_INVALID};
    entry[r] = v3_dot(d, n) > 0.0f ? TS_ENTRY_START : TS_INVALID; /* below: V = 0, untraced */
    flags[r] = TS_RAY_SHADOW;
    from[r] = point_patch[i] + 1u;
    active[r] = r;
}

__kernel void bake_project(ts_bake_params bp, __global const ts_vec4 *point_n,
                           __global const ts_vec4 *dir, __global const ts_hit *hit,
                           __global float *coeffs)
{
    uint i = get_global_id(0);
    if (i >= bp.point_count) return;
    uint nc = bp.bands * bp.bands, sphere = bp.flags & TS_BAKE_SPHERE;
    uint cosine = bp.flags & TS_BAKE_COSINE;
    ts_vec4 n = point_n[i];
    float w = (sphere ? 4.0f * TS_PI : cosine ? TS_PI : 2.0f * TS_PI) / (float)bp.rays;
    float acc[TS_SH_MAX_COEFFS], y[TS_SH_MAX_COEFFS];
    for (uint c = 0; c < nc; ++c)
        acc[c] = 0.0f;
    for (uint k = 0; k < bp.rays; ++k) {
        uint r = i * bp.rays + k;
        ts_vec4 d = dir[r];
        float cn = d.x * n.x + d.y * n.y + d.z * n.z;
        if (!(cn > 0.0f) || hit[r].patch != TS_INVALID) continue; /* V = 0 */
        float wk = sphere && cosine ? w * cn : w;
        sh_eval(d.x, d.y, d.z, bp.bands, y);
        for (uint c = 0; c < nc; ++c)
            acc[c] += wk * y[c];
    }
    for (uint c = 0; c < nc; ++c)
        coeffs[(size_t)i * nc + c] = acc[c];
}
