/* bsdf.h — the materials of DESIGN.md §3, their sampling and pdfs, shared by the shade
 * kernel and the host tests (tests/test_bsdf.c). Directions are unit vectors in world
 * space; n is the unit shading normal on the side of wo (the direction back along the
 * incoming ray).
 *   matte:   f = Kd Cs / pi, sampled by cosine.
 *   plastic: f = Kd Cs / pi + Ks D(h) G(wo, wi) / (4 cos_o cos_i), GGX D with alpha =
 *            roughness and the separable Smith G (Walter et al. 2007). Energy-conserving for
 *            Kd + Ks <= 1 (the parser enforces it): the GGX lobe without Fresnel reflects at
 *            most Ks. Sampled by choosing the lobe with probability Ks / (Kd + Ks), then the
 *            cosine or D(h) cos(theta_h).
 *   metal:   f = Ks Cs D(h) G(wo, wi) / (4 cos_o cos_i): the plastic's GGX lobe tinted by the
 *            surface colour, no diffuse part (RenderMan's metal: Cs Ks specular()); albedo at
 *            most Ks Cs. Always sampled by D(h) cos(theta_h).
 *   glass:   a smooth dielectric of index ior inside, 1 outside (which side the path is on is
 *            its TS_PATH_INSIDE bit): two delta lobes, specular reflection with the exact
 *            dielectric Fresnel F (unpolarised; 1 past the critical angle) and refraction by
 *            Snell's law with 1 - F, the transmitted radiance tinted by Cs and scaled by
 *            (eta_o / eta_i)^2 (radiance, not importance: Veach 1997 §5.2). bsdf_eval is 0
 *            (no light sample can hit a delta lobe); glass_sample picks a lobe with
 *            probability F, so the weight is 1 (reflection) or Cs (eta_o / eta_i)^2.
 *            Rough glass (roughness = GGX alpha above TS_GLASS_SMOOTH): Walter et al. 2007's
 *            GGX dielectric, sampled as there (§5.3), still without light samples (its
 *            emission found counts whole, as behind smooth glass).
 *   principled: Burley 2012's principled BRDF, layered (lib/principled.h). */
#ifndef TS_BSDF_H
#define TS_BSDF_H

#include "lib/shared_types.h"

#ifndef __OPENCL_C_VERSION__
#include <math.h>
#endif

#define TS_PI 3.14159265358979f

typedef struct ts_v3 {
    float x, y, z;
} ts_v3;

TS_INLINE ts_v3 v3(float x, float y, float z)
{
    ts_v3 r = {x, y, z};
    return r;
}
TS_INLINE float v3_dot(ts_v3 a, ts_v3 b)
{
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
TS_INLINE ts_v3 v3_scale(ts_v3 a, float s)
{
    return v3(a.x * s, a.y * s, a.z * s);
}
TS_INLINE ts_v3 v3_add(ts_v3 a, ts_v3 b)
{
    return v3(a.x + b.x, a.y + b.y, a.z + b.z);
}
TS_INLINE ts_v3 v3_sub(ts_v3 a, ts_v3 b)
{
    return v3(a.x - b.x, a.y - b.y, a.z - b.z);
}
TS_INLINE ts_v3 v3_cross(ts_v3 a, ts_v3 b)
{
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
TS_INLINE ts_v3 v3_normalize(ts_v3 a)
{
    float l = sqrt(v3_dot(a, a));
    return l > 0.0f ? v3_scale(a, 1.0f / l) : a;
}

/* An orthonormal basis (t, b, n) around unit n (Duff et al. 2017). */
TS_INLINE void onb(ts_v3 n, ts_v3 *t, ts_v3 *b)
{
    float s = n.z >= 0.0f ? 1.0f : -1.0f;
    float a = -1.0f / (s + n.z), c = n.x * n.y * a;
    *t = v3(1.0f + s * n.x * n.x * a, s * c, -s * n.x);
    *b = v3(c, s + n.y * n.y * a, -n.y);
}

TS_INLINE ts_v3 local_to_world(ts_v3 l, ts_v3 n)
{
    ts_v3 t, b;
    onb(n, &t, &b);
    return v3_add(v3_add(v3_scale(t, l.x), v3_scale(b, l.y)), v3_scale(n, l.z));
}

/* Cosine-weighted direction around n from (u1, u2); pdf cos / pi. */
TS_INLINE ts_v3 sample_cosine(ts_v3 n, float u1, float u2)
{
    float r = sqrt(u1), phi = 2.0f * TS_PI * u2;
    return local_to_world(v3(r * cos(phi), r * sin(phi), sqrt(fmax(0.0f, 1.0f - u1))), n);
}

/* GGX normal distribution D(h) for cos(theta_h) = c. */
TS_INLINE float ggx_d(float c, float alpha)
{
    if (c <= 0.0f) return 0.0f;
    float a2 = alpha * alpha, d = c * c * (a2 - 1.0f) + 1.0f;
    return a2 / (TS_PI * d * d);
}

/* Smith G1 for GGX at cos(theta) = c. */
TS_INLINE float ggx_g1(float c, float alpha)
{
    if (c <= 0.0f) return 0.0f;
    float t2 = (1.0f - c * c) / (c * c);
    return 2.0f / (1.0f + sqrt(1.0f + alpha * alpha * t2));
}

/* wo mirrored about a microfacet normal h drawn from D(h) cos(theta_h) by (u1, u2):
 * tan^2(theta_h) = alpha^2 u1 / (1 - u1). */
TS_INLINE ts_v3 ggx_reflect_sample(ts_v3 n, ts_v3 wo, float alpha, float u1, float u2)
{
    float t2 = alpha * alpha * u1 / fmax(1.0f - u1, 1e-7f);
    float ch = 1.0f / sqrt(1.0f + t2), sh = sqrt(fmax(0.0f, 1.0f - ch * ch));
    float phi = 2.0f * TS_PI * u2;
    ts_v3 h = local_to_world(v3(sh * cos(phi), sh * sin(phi), ch), n);
    return v3_sub(v3_scale(h, 2.0f * v3_dot(wo, h)), wo);
}

#include "lib/principled.h"

TS_INLINE float plastic_spec_prob(TS_CONST_GLOBAL ts_patch_attr *a)
{
    float s = a->kd + a->ks;
    return a->material == TS_MAT_PLASTIC && s > 0.0f ? a->ks / s : 0.0f;
}

/* Probability that bsdf_sample takes the GGX lobe: plastic as above, metal 1, matte 0. */
TS_INLINE float bsdf_spec_prob(TS_CONST_GLOBAL ts_patch_attr *a)
{
    return a->material == TS_MAT_METAL ? 1.0f : plastic_spec_prob(a);
}

/* Probability that bsdf_sample reflects a translucent material's sample (TS_MAT_TRANSLUCENT):
 * its reflected share Kd / (Kd + Ks), 0 when it scatters nothing. */
TS_INLINE float translucent_front_prob(TS_CONST_GLOBAL ts_patch_attr *a)
{
    float s = a->kd + a->ks;
    return s > 0.0f ? a->kd / s : 0.0f;
}

/* TS_MAT_TRANSLUCENT: f = Kd Cs / pi for wi on wo's side of n (ci > 0), Ks Cs / pi on the far
 * side (ci < 0: diffuse transmission through a thin sheet, which is reciprocal: the same
 * either way through); the pdf of bsdf_sample's choice of side times |ci| / pi. */
TS_INLINE float translucent_eval(TS_CONST_GLOBAL ts_patch_attr *a, const float cs[3], float co,
                                 float ci, float f[3])
{
    f[0] = f[1] = f[2] = 0.0f;
    if (co <= 0.0f || ci == 0.0f || !(a->kd + a->ks > 0.0f)) return 0.0f;
    float pr = translucent_front_prob(a), k = (ci > 0.0f ? a->kd : a->ks) / TS_PI;
    f[0] = k * cs[0], f[1] = k * cs[1], f[2] = k * cs[2];
    return (ci > 0.0f ? pr : 1.0f - pr) * fabs(ci) / TS_PI;
}

/* f(wo, wi) (rgb in r[]) and the pdf of sampling wi with bsdf_sample; cs: the surface
 * colour at the point (Cs, times the colour texture if any; lib/texture.h
 * tex_surface_colour). */
TS_INLINE float bsdf_eval(TS_CONST_GLOBAL ts_patch_attr *a, const float cs[3], ts_v3 n, ts_v3 wo,
                          ts_v3 wi, float f[3])
{
    float ci = v3_dot(n, wi), co = v3_dot(n, wo);
    f[0] = f[1] = f[2] = 0.0f;
    if (a->material == TS_MAT_TRANSLUCENT) return translucent_eval(a, cs, co, ci, f);
    if (ci <= 0.0f || co <= 0.0f || a->material == TS_MAT_GLASS) return 0.0f;
    if (a->material == TS_MAT_PRINCIPLED) return principled_eval(a, cs, n, wo, wi, co, ci, f);
    int metal = a->material == TS_MAT_METAL;
    float kd = metal ? 0.0f : a->kd / TS_PI;
    f[0] = kd * cs[0], f[1] = kd * cs[1], f[2] = kd * cs[2];
    float ps = bsdf_spec_prob(a);
    float pdf = (1.0f - ps) * ci / TS_PI;
    if (a->material == TS_MAT_PLASTIC || metal) {
        ts_v3 h = v3_normalize(v3_add(wo, wi));
        float ch = v3_dot(n, h), d = ggx_d(ch, a->roughness);
        float spec =
            a->ks * d * ggx_g1(co, a->roughness) * ggx_g1(ci, a->roughness) / (4.0f * co * ci);
        if (metal)
            f[0] += spec * cs[0], f[1] += spec * cs[1], f[2] += spec * cs[2];
        else
            f[0] += spec, f[1] += spec, f[2] += spec;
        float oh = v3_dot(wo, h);
        if (oh > 0.0f) pdf += ps * d * ch / (4.0f * oh);
    }
    return pdf;
}

/* Samples wi from (u0, u1, u2); returns its pdf (0 when the sample is below the surface; a
 * translucent material's may lie on the far side of n), with f(wo, wi) in f[]. */
TS_INLINE float bsdf_sample(TS_CONST_GLOBAL ts_patch_attr *a, const float cs[3], ts_v3 n, ts_v3 wo,
                            float u0, float u1, float u2, ts_v3 *wi, float f[3])
{
    if (a->material == TS_MAT_PRINCIPLED) return principled_sample(a, cs, n, wo, u0, u1, u2, wi, f);
    if (a->material == TS_MAT_TRANSLUCENT) { /* a side by its share, then cosine about it */
        *wi = sample_cosine(u0 < translucent_front_prob(a) ? n : v3_scale(n, -1.0f), u1, u2);
        return bsdf_eval(a, cs, n, wo, *wi, f);
    }
    float ps = bsdf_spec_prob(a);
    if (u0 < ps) {
        *wi = ggx_reflect_sample(n, wo, a->roughness, u1, u2);
    } else {
        *wi = sample_cosine(n, u1, u2);
    }
    return bsdf_eval(a, cs, n, wo, *wi, f);
}

/* Unpolarised Fresnel reflectance of a smooth dielectric interface, light arriving at cosine
 * ci > 0 from the side of index ratio eta = eta_i / eta_t (Born and Wolf; Walter et al. 2007
 * eq. 22 in its exact form); *ct the cosine of the refracted direction, 0 with F = 1 past the
 * critical angle (total internal reflection). */
TS_INLINE float fresnel_dielectric(float ci, float eta, float *ct)
{
    float st2 = eta * eta * fmax(0.0f, 1.0f - ci * ci);
    if (st2 >= 1.0f) {
        *ct = 0.0f;
        return 1.0f;
    }
    float c = sqrt(1.0f - st2);
    *ct = c;
    float rs = (eta * ci - c) / (eta * ci + c), rp = (ci - eta * c) / (ci + eta * c);
    return 0.5f * (rs * rs + rp * rp);
}

/* Glass up to this GGX alpha is smooth (two delta lobes): the parser's floor of 0.01 for
 * roughness 0, and Surface "glass". */
#define TS_GLASS_SMOOTH 0.0101f

/* Smith's G1 for GGX of direction v about microfacet normal m on a surface of normal n: 0
 * when v sees m's back while seeing n's front or the other way (Walter et al. 2007 eq. 34). */
TS_INLINE float ggx_g1_m(ts_v3 v, ts_v3 m, ts_v3 n, float alpha)
{
    float vn = v3_dot(v, n), vm = v3_dot(v, m);
    return vm * vn > 0.0f ? ggx_g1(fabs(vn), alpha) : 0.0f;
}

/* Rough glass (glass_sample with roughness alpha > TS_GLASS_SMOOTH), Walter et al. 2007
 * §5.3: the microfacet normal m from D(m) |m.n| (u1, u2), then the mirror direction about m
 * with probability F(wo.m), else the refraction through m; the weight f |cos| / pdf is
 * |wo.m| G(wo, wi) / (|wo.n| |m.n|) (eq. 41), times Cs (eta_o / eta_i)^2 refracted. A
 * direction on the wrong side of n (reflected below it, refracted above) has weight 0. */
TS_INLINE int rough_glass_sample(float alpha, float eta, const float cs[3], ts_v3 n, ts_v3 wo,
                                 float u0, float u1, float u2, ts_v3 *wi, float w[3])
{
    float t2 = alpha * alpha * u1 / fmax(1.0f - u1, 1e-7f);
    float cm = 1.0f / sqrt(1.0f + t2), sm = sqrt(fmax(0.0f, 1.0f - cm * cm));
    float phi = 2.0f * TS_PI * u2;
    ts_v3 m = local_to_world(v3(sm * cos(phi), sm * sin(phi), cm), n);
    float co = v3_dot(n, wo), om = v3_dot(wo, m), ct;
    w[0] = w[1] = w[2] = 0.0f;
    *wi = v3_sub(v3_scale(n, 2.0f * fmax(co, 0.0f)), wo); /* (for weight 0) */
    if (co <= 0.0f || om <= 0.0f) return 0;
    float F = fresnel_dielectric(om, eta, &ct);
    int through = u0 >= F;
    if (through)
        *wi = v3_normalize(v3_add(v3_scale(wo, -eta), v3_scale(m, eta * om - ct)));
    else
        *wi = v3_sub(v3_scale(m, 2.0f * om), wo);
    float ci = v3_dot(n, *wi);
    if (through ? ci >= 0.0f : ci <= 0.0f) return through;
    float g = om * ggx_g1_m(wo, m, n, alpha) * ggx_g1_m(*wi, m, n, alpha) / (co * cm);
    float k = through ? g * eta * eta : g;
    w[0] = through ? k * cs[0] : k, w[1] = through ? k * cs[1] : k, w[2] = through ? k * cs[2] : k;
    return through;
}

/* Samples glass (TS_MAT_GLASS) from u0: with probability F the mirror direction, else the
 * refracted one; inside: wo's side is the glass (the path's TS_PATH_INSIDE bit). Writes wi
 * and the weight f cos / pdf in w[] (1 reflected, Cs (eta_o / eta_i)^2 refracted) and
 * returns 1 when wi goes through the surface (to the other side of n), 0 when reflected.
 * Rough glass (roughness above TS_GLASS_SMOOTH) also takes u1 and u2 (rough_glass_sample). */
TS_INLINE int glass_sample(TS_CONST_GLOBAL ts_patch_attr *a, const float cs[3], ts_v3 n, ts_v3 wo,
                           int inside, float u0, float u1, float u2, ts_v3 *wi, float w[3])
{
    float ior = a->ior > 0.0f ? a->ior : 1.5f;
    float eta = inside ? ior : 1.0f / ior; /* eta_o / eta_i: wo's side over the other */
    if (a->roughness > TS_GLASS_SMOOTH)
        return rough_glass_sample(a->roughness, eta, cs, n, wo, u0, u1, u2, wi, w);
    float co = fmax(v3_dot(n, wo), 0.0f), ct;
    float F = fresnel_dielectric(co, eta, &ct);
    if (u0 < F) {
        *wi = v3_sub(v3_scale(n, 2.0f * co), wo);
        w[0] = w[1] = w[2] = 1.0f;
        return 0;
    }
    /* t = -eta wo + (eta co - ct) n: unit, on the far side of n, Snell's sin_t = eta sin_o */
    *wi = v3_normalize(v3_add(v3_scale(wo, -eta), v3_scale(n, eta * co - ct)));
    float e2 = eta * eta;
    w[0] = cs[0] * e2, w[1] = cs[1] * e2, w[2] = cs[2] * e2;
    return 1;
}

#endif
