/* principled.h — TS_MAT_PRINCIPLED: Burley 2012's principled BRDF ("Physically-Based Shading at
 * Disney", §5.3 and its BRDF Explorer shader), reflection only, layered so that it never
 * reflects more than it receives. Included by lib/bsdf.h (bsdf_eval and bsdf_sample dispatch
 * here); the shade kernel and tests/test_principled.c run the same code. Parameters: the base
 * colour Cs (times its texture), ts_patch_attr's roughness (GGX alpha, the square of Burley's
 * roughness) and the metallic ... clearcoat_gloss fields, each in [0, 1] but clearcoat, in
 * [0, 4] (1 is Burley's full coat; 4 a coat of Schlick F0 0.04 to 1, as PxrSurface's).
 * Lobes, with tint = Cs / max(Cs) (Burley's hue, normalised by the largest channel rather than
 * the luminance so that it stays in [0, 1]):
 *   specular  Schlick's F(wo.h) from F0 = mix(0.08 specular mix(1, tint, specular_tint), Cs,
 *             metallic) (Burley's Cspec0) times the GGX lobe D G1(o) G1(i) / (4 cos_o cos_i)
 *             of alpha = roughness: Burley's metallic blend, exactly, since F is linear in F0;
 *   diffuse   (1 - metallic) Cs / pi under the dielectric specular layer: times
 *             (1 - E(cos_o)) (1 - E(cos_i)) / (1 - E_avg), E the dielectric lobe's directional
 *             albedo and E_avg its cosine-weighted mean (Kelemen and Szirmay-Kalos 2001; Kulla
 *             and Conty 2017), so that a white dielectric reflects all it receives: specular E
 *             plus diffuse 1 - E. Lambert, not Burley's retro-reflective Fd, whose albedo passes 1
 *             at grazing angles on rough surfaces;
 *   sheen     (1 - metallic) sheen mix(1, tint, sheen_tint) (1 - wi.h)^5 (Burley's Fsheen), in the
 *             diffuse layer, which gives up sheen K of its Lambert part to keep the bound
 *             (K = TS_PRINCIPLED_SHEEN / (1 - E_avg): the sheen lobe's albedo is at most
 *             TS_PRINCIPLED_SHEEN);
 *   clearcoat 0.25 clearcoat F(wo.h) D G1 G1 / (4 cos_o cos_i) with F0 = 0.04 (index 1.5) and a
 *             GGX lobe of alpha = mix(0.1, 0.01, clearcoat_gloss) (Burley: GTR1 down to 0.001;
 *             GGX keeps D and G consistent, so its albedo is at most 1, and 0.01 is Tessera's
 *             floor), over the rest, which it dims by (1 - Ec(cos_o)) (1 - Ec(cos_i)).
 * Every factor is symmetric in wo and wi (reciprocity), and each layer reflects at most what
 * the one above lets through (energy <= 1). E comes from lib/principled_table.h (E of Schlick
 * F0 = F0 E1 + (1 - F0) E2), raised by TS_PRINCIPLED_MARGIN towards 1 to stay above the true
 * albedo between its points (tools/principled_table.c measures how far; test_principled checks
 * it), so the bound holds and a white dielectric reflects a little under 1.
 * Sampling: a lobe chosen by its estimated albedo at wo (specular, clearcoat, or the cosine for
 * diffuse and sheen), then D(h) cos(theta_h) or the cosine; the pdf is the mixture of the three
 * (what MIS in shade weighs). */
#ifndef TS_PRINCIPLED_H
#define TS_PRINCIPLED_H

#include "lib/principled_table.h"

/* How far E is raised towards 1: E + m (1 - E). */
#define TS_PRINCIPLED_MARGIN 0.02f
/* The largest albedo of (1 - wi.h)^5 over wo, int (1 - wi.h)^5 cos_i dwi: 0.0885 at grazing. */
#define TS_PRINCIPLED_SHEEN 0.09f
#define TS_PRINCIPLED_COAT_F0 0.04f

/* E1 (k = 0) or E2 (k = 1) of lib/principled_table.h at cos(theta_o) = mu, roughness r =
 * sqrt(alpha), interpolated bilinearly in (sqrt(mu), r). */
TS_INLINE float principled_table_e(int k, float mu, float r)
{
    float x = sqrt(fmin(fmax(mu, 0.0f), 1.0f)) * (float)TS_PRINCIPLED_N;
    float y = fmin(fmax((r - 0.1f) / 0.9f, 0.0f), 1.0f) * (float)TS_PRINCIPLED_N;
    int i = (int)fmin(x, (float)(TS_PRINCIPLED_N - 1)),
        j = (int)fmin(y, (float)(TS_PRINCIPLED_N - 1));
    float fx = x - (float)i, fy = y - (float)j;
    float e0 = TS_PRINCIPLED_E[k][j][i] * (1.0f - fx) + TS_PRINCIPLED_E[k][j][i + 1] * fx;
    float e1 = TS_PRINCIPLED_E[k][j + 1][i] * (1.0f - fx) + TS_PRINCIPLED_E[k][j + 1][i + 1] * fx;
    return e0 * (1.0f - fy) + e1 * fy;
}

/* The cosine-weighted mean of principled_table_e over mu (exact for the interpolant). */
TS_INLINE float principled_table_avg(int k, float r)
{
    float y = fmin(fmax((r - 0.1f) / 0.9f, 0.0f), 1.0f) * (float)TS_PRINCIPLED_N;
    int j = (int)fmin(y, (float)(TS_PRINCIPLED_N - 1));
    float fy = y - (float)j;
    return TS_PRINCIPLED_EAVG[k][j] * (1.0f - fy) + TS_PRINCIPLED_EAVG[k][j + 1] * fy;
}

/* 1 - E for a GGX lobe of Schlick F0 f0 at cos mu and roughness r, E raised by the margin
 * (E <= the value this leaves out); mu < 0: the mean 1 - E_avg instead. */
TS_INLINE float principled_unreflected(float f0, float mu, float r)
{
    float e = mu < 0.0f
                  ? f0 * principled_table_avg(0, r) + (1.0f - f0) * principled_table_avg(1, r)
                  : f0 * principled_table_e(0, mu, r) + (1.0f - f0) * principled_table_e(1, mu, r);
    return (1.0f - TS_PRINCIPLED_MARGIN) * (1.0f - e);
}

/* A principled material at one point, its parameters worked out once. */
typedef struct ts_principled {
    float f0[3];       /* the specular lobe's Schlick F0 per channel */
    float f0d;         /* the dielectric's largest F0: what the diffuse layer lies under */
    float below;       /* 1 - E_avg of that dielectric lobe */
    float diffuse[3];  /* (1 - metallic) Cs (1 - sheen K) / pi / (1 - E_avg) */
    float sheen[3];    /* (1 - metallic) sheen Csheen / (1 - E_avg) */
    float r, alpha;    /* the specular lobe's roughness and GGX alpha */
    float coat;        /* 0.25 clearcoat */
    float rc, alpha_c; /* the clear coat's roughness and alpha */
} ts_principled;

TS_INLINE ts_principled principled_setup(TS_CONST_GLOBAL ts_patch_attr *a, const float cs[3])
{
    ts_principled p;
    float mx = fmax(cs[0], fmax(cs[1], cs[2])), met = a->metallic;
    p.alpha = fmin(fmax(a->roughness, 0.01f), 1.0f), p.r = sqrt(p.alpha);
    p.alpha_c = 0.1f + (0.01f - 0.1f) * a->clearcoat_gloss, p.rc = sqrt(p.alpha_c);
    p.coat = 0.25f * a->clearcoat;
    p.f0d = 0.0f;
    float f0d[3];
    for (int c = 0; c < 3; c++) {
        float tint = mx > 0.0f ? cs[c] / mx : 1.0f;
        f0d[c] = 0.08f * a->specular * (1.0f + (tint - 1.0f) * a->specular_tint);
        p.f0d = fmax(p.f0d, f0d[c]);
        p.f0[c] = f0d[c] + (cs[c] - f0d[c]) * met;
    }
    p.below = principled_unreflected(p.f0d, -1.0f, p.r);
    float k = TS_PRINCIPLED_SHEEN / p.below, w = (1.0f - met) / p.below;
    for (int c = 0; c < 3; c++) {
        float tint = mx > 0.0f ? cs[c] / mx : 1.0f;
        p.diffuse[c] = w * cs[c] * fmax(1.0f - a->sheen * k, 0.0f) / TS_PI;
        p.sheen[c] = w * a->sheen * (1.0f + (tint - 1.0f) * a->sheen_tint);
    }
    return p;
}

/* The probabilities of sampling the specular lobe (*ps) and the clear coat (*pc); the cosine
 * takes the rest. By the lobes' albedos at cos_o = co, averaged over the channels. */
TS_INLINE void principled_lobe_probs(const ts_principled *p, float co, float *ps, float *pc)
{
    float f0 = (p->f0[0] + p->f0[1] + p->f0[2]) / 3.0f;
    float ws = 1.0f - principled_unreflected(f0, co, p->r);
    float wc = p->coat * (1.0f - principled_unreflected(TS_PRINCIPLED_COAT_F0, co, p->rc));
    float below = principled_unreflected(p->f0d, co, p->r) * p->below;
    float wd = below *
               ((p->diffuse[0] + p->diffuse[1] + p->diffuse[2]) * TS_PI +
                (p->sheen[0] + p->sheen[1] + p->sheen[2]) * TS_PRINCIPLED_SHEEN) /
               3.0f;
    ws *= 1.0f - wc, wd *= 1.0f - wc;
    float sum = ws + wc + wd;
    *ps = sum > 0.0f ? ws / sum : 0.0f;
    *pc = sum > 0.0f ? wc / sum : 0.0f;
}

/* f(wo, wi) in f[] and the mixture pdf of principled_sample; co, ci > 0: the cosines. */
TS_INLINE float principled_eval(TS_CONST_GLOBAL ts_patch_attr *a, const float cs[3], ts_v3 n,
                                ts_v3 wo, ts_v3 wi, float co, float ci, float f[3])
{
    ts_principled p = principled_setup(a, cs);
    ts_v3 h = v3_normalize(v3_add(wo, wi));
    float ch = v3_dot(n, h), oh = fmax(v3_dot(wo, h), 0.0f), m = 1.0f - oh;
    float s5 = m * m * m * m * m; /* Schlick's (1 - wo.h)^5, = (1 - wi.h)^5 */
    float ds = ggx_d(ch, p.alpha), dc = ggx_d(ch, p.alpha_c);
    float spec = ds * ggx_g1(co, p.alpha) * ggx_g1(ci, p.alpha) / (4.0f * co * ci);
    float coat = p.coat * (TS_PRINCIPLED_COAT_F0 + (1.0f - TS_PRINCIPLED_COAT_F0) * s5) * dc *
                 ggx_g1(co, p.alpha_c) * ggx_g1(ci, p.alpha_c) / (4.0f * co * ci);
    float layer = principled_unreflected(p.f0d, co, p.r) * principled_unreflected(p.f0d, ci, p.r);
    float through =
        (1.0f - p.coat * (1.0f - principled_unreflected(TS_PRINCIPLED_COAT_F0, co, p.rc))) *
        (1.0f - p.coat * (1.0f - principled_unreflected(TS_PRINCIPLED_COAT_F0, ci, p.rc)));
    for (int c = 0; c < 3; c++) {
        float fs = (p.f0[c] + (1.0f - p.f0[c]) * s5) * spec;
        float fd = layer * (p.diffuse[c] + p.sheen[c] * s5);
        f[c] = through * (fs + fd) + coat;
    }
    float ps, pc;
    principled_lobe_probs(&p, co, &ps, &pc);
    float pdf = fmax(1.0f - ps - pc, 0.0f) * ci / TS_PI; /* (not below 0 by rounding) */
    if (oh > 0.0f) pdf += (ps * ds + pc * dc) * ch / (4.0f * oh);
    return pdf;
}

/* Samples wi from (u0, u1, u2): the lobe by u0, the direction by (u1, u2); returns the pdf
 * (0 below the surface) with f(wo, wi) in f[]. */
TS_INLINE float principled_sample(TS_CONST_GLOBAL ts_patch_attr *a, const float cs[3], ts_v3 n,
                                  ts_v3 wo, float u0, float u1, float u2, ts_v3 *wi, float f[3])
{
    f[0] = f[1] = f[2] = 0.0f;
    float co = v3_dot(n, wo);
    if (co <= 0.0f) return 0.0f;
    ts_principled p = principled_setup(a, cs);
    float ps, pc;
    principled_lobe_probs(&p, co, &ps, &pc);
    if (u0 < ps + pc)
        *wi = ggx_reflect_sample(n, wo, u0 < ps ? p.alpha : p.alpha_c, u1, u2);
    else
        *wi = sample_cosine(n, u1, u2);
    float ci = v3_dot(n, *wi);
    if (ci <= 0.0f) return 0.0f;
    return principled_eval(a, cs, n, wo, *wi, co, ci, f);
}

#endif
