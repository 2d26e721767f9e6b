/* bake_ref.c — bake_points, bake_rays and bake_project in scalar C (bake_ref.h). */
#include "ref/bake_ref.h"
#include "ref/dice_build_ref.h"
#include "lib/bsdf.h"
#include "lib/patch.h"
#include "lib/sampler.h"
#include "lib/sh.h"

#include <math.h>

void bake_ref_point(const ts_scene *s, const ts_bake_params *bp, const uint32_t *lod,
                    const uint32_t *point_first, uint32_t g, ts_vec4 *pos, ts_vec4 *normal,
                    uint32_t *patch)
{
    uint32_t p = 0; /* the last patch whose first point is <= g, by a linear scan */
    while (p + 1 < bp->patch_count && point_first[p + 1] <= g)
        ++p;
    uint32_t m = lod[p], n = (1u << m) + 1u, k = g - point_first[p];
    /* A boundary vertex moves a quarter of a micro-quad inside (docs/bake.md "Points"). */
    float q = ldexpf(0.25f, -(int)m);
    float u = fminf(fmaxf(quadtree_vertex_param(k % n, m), q), 1.0f - q);
    float v = fminf(fmaxf(quadtree_vertex_param(k / n, m), q), 1.0f - q);
    dice_build_ref_patch q_ = dice_build_ref_patch_of(s, p);
    ts_vec4 P = patch_vertex(q_.cp0, q_.cp0, q_.cn, q_.mn, q_.a, q_.x, q_.tex, u, v);
    ts_vec4 N = patch_shading_normal(q_.cp0, q_.cn, q_.mn, q_.a, q_.x, q_.tex, u, v, m);
    if (!(N.x * N.x + N.y * N.y + N.z * N.z > 0.5f)) N = (ts_vec4){0.0f, 0.0f, 1.0f, 0.0f};
    if (!(bp->flags & TS_BAKE_FRONT)) {
        float t[3];
        for (int c = 0; c < 3; ++c) {
            float pc = c == 0 ? P.x : c == 1 ? P.y : P.z;
            t[c] = bp->orthographic ? -bp->eye[c] : bp->eye[c] - pc;
        }
        if (N.x * t[0] + N.y * t[1] + N.z * t[2] < 0.0f) N.x = -N.x, N.y = -N.y, N.z = -N.z;
    }
    /* eps: the longest side of the patch's box over 2^m, as pipeline.c's flatness w */
    ts_box b = q_.pb;
    float l = fmaxf(b.hi_x - b.lo_x, fmaxf(b.hi_y - b.lo_y, b.hi_z - b.lo_z));
    P.w = l * ldexpf(1.0f, -(int)m);
    N.w = 0.0f;
    *pos = P, *normal = N, *patch = p;
}

void bake_ref_ray(const ts_bake_params *bp, ts_vec4 pos, ts_vec4 normal, uint32_t g, uint32_t k,
                  ts_vec4 *org, ts_vec4 *dir, int *traced)
{
    ts_v3 n = v3(normal.x, normal.y, normal.z);
    uint32_t mask = sampler_mask(bp->rays);
    float u1 = sampler_value(g, k, 0u, 0u, bp->seed, mask);
    float u2 = sampler_value(g, k, 0u, 1u, bp->seed, mask);
    ts_v3 d;
    if (!(bp->flags & TS_BAKE_SPHERE) && (bp->flags & TS_BAKE_COSINE)) {
        d = sample_cosine(n, u1, u2);
    } else { /* uniform in z over (0, 1] (hemisphere) or (-1, 1] (sphere), uniform in phi */
        float z = (bp->flags & TS_BAKE_SPHERE) ? 1.0f - 2.0f * u1 : 1.0f - u1;
        float r = sqrtf(fmaxf(0.0f, 1.0f - z * z)), phi = 2.0f * TS_PI * u2;
        d = local_to_world(v3(r * cosf(phi), r * sinf(phi), z), n);
    }
    float eps = pos.w;
    *org = (ts_vec4){pos.x + eps * n.x, pos.y + eps * n.y, pos.z + eps * n.z, eps};
    *dir = (ts_vec4){d.x, d.y, d.z, 0.0f};
    *traced = d.x * n.x + d.y * n.y + d.z * n.z > 0.0f;
}

void bake_ref_project(const ts_bake_params *bp, ts_vec4 n, const ts_vec4 *dir,
                      const uint8_t *escaped, float *coeffs)
{
    uint32_t nc = bp->bands * bp->bands;
    int sphere = (bp->flags & TS_BAKE_SPHERE) != 0, cosine = (bp->flags & TS_BAKE_COSINE) != 0;
    /* The estimator's weight: the sampling density's inverse over N (docs/bake.md "Rays"). */
    float w = (sphere ? 4.0f * TS_PI : cosine ? TS_PI : 2.0f * TS_PI) / (float)bp->rays;
    for (uint32_t c = 0; c < nc; ++c)
        coeffs[c] = 0.0f;
    for (uint32_t k = 0; k < bp->rays; ++k) {
        ts_vec4 d = dir[k];
        float cn = d.x * n.x + d.y * n.y + d.z * n.z;
        if (!(cn > 0.0f) || !escaped[k]) continue;
        float y[TS_SH_MAX_COEFFS];
        sh_eval(d.x, d.y, d.z, bp->bands, y);
        for (uint32_t c = 0; c < nc; ++c)
            coeffs[c] += (sphere && cosine ? w * cn : w) * y[c];
    }
}
