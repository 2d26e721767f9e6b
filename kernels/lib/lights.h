/* lights.h — sampling the scene's lights for next-event estimation and their pdfs for
 * multiple importance sampling (DESIGN.md §3). One light is chosen uniformly among
 * light_count; the pdfs below include that choice. Solid-angle pdfs throughout.
 *   distant (sun): a cone of half angle acos(cos_max) around dir, uniform in solid angle,
 *     radiance = E / solid angle; a delta light when cos_max = 1 (irradiance E).
 *   dome: uniform radiance L, sampled uniformly over the sphere (pdf 1 / 4 pi).
 *   area: an emissive patch chosen by area (the emitter table), (u, v) uniform on its
 *     undisplaced surface; pdf = prob * dist^2 / (|dP/du x dP/dv| |cos_light|). */
#ifndef TS_LIGHTS_H
#define TS_LIGHTS_H

#include "lib/bezier.h"
#include "lib/bsdf.h"
#include "lib/shared_types.h"

typedef struct ts_light_sample {
    ts_v3 dir;      /* towards the light, unit */
    float dist;     /* to the sampled point; TS_NO_HIT for lights at infinity */
    float le[3];    /* radiance arriving (or irradiance, for a delta light) */
    float pdf;      /* solid angle, with the light choice; 0 = failed sample */
    int delta;      /* a delta light: no BSDF sample can find it */
    ts_u32 patch;   /* area: the sampled patch (its own boxes must not shadow the ray) */
} ts_light_sample;

/* Direction in a cone around unit axis d with cos(half angle) = cos_max. */
TS_INLINE ts_v3 sample_cone(ts_v3 d, float cos_max, float u1, float u2)
{
    float c = 1.0f - u1 * (1.0f - cos_max), s = sqrt(fmax(0.0f, 1.0f - c * c));
    float phi = 2.0f * TS_PI * u2;
    return local_to_world(v3(s * cos(phi), s * sin(phi), c), d);
}

/* The emitter whose cdf range holds u (binary search). */
TS_INLINE ts_u32 emitter_pick(TS_CONST_GLOBAL ts_emitter *e, ts_u32 n, float u)
{
    ts_u32 lo = 0, hi = n - 1u;
    while (lo < hi) {
        ts_u32 mid = (lo + hi) / 2u;
        if (u < e[mid].cdf) hi = mid;
        else lo = mid + 1u;
    }
    return lo;
}

/* Samples light `li` as seen from point p. */
TS_INLINE ts_light_sample light_sample(TS_CONST_GLOBAL ts_light *lights, ts_u32 light_count,
                                       ts_u32 li, TS_CONST_GLOBAL ts_emitter *emitters,
                                       TS_CONST_GLOBAL ts_vec4 *cp,
                                       TS_CONST_GLOBAL ts_patch_attr *attr, ts_v3 p, float u1,
                                       float u2, float u3)
{
    ts_light_sample s;
    TS_CONST_GLOBAL ts_light *l = &lights[li];
    float choose = 1.0f / (float)light_count;
    s.dist = TS_NO_HIT, s.delta = 0, s.patch = TS_INVALID, s.pdf = 0.0f;
    s.le[0] = l->radiance[0], s.le[1] = l->radiance[1], s.le[2] = l->radiance[2];
    if (l->type == TS_LIGHT_DISTANT) {
        ts_v3 d = v3(l->dir[0], l->dir[1], l->dir[2]);
        if (l->cos_max >= 1.0f) {
            s.dir = d, s.delta = 1, s.pdf = choose;
        } else {
            s.dir = sample_cone(d, l->cos_max, u1, u2), s.pdf = choose / l->solid_angle;
        }
    } else if (l->type == TS_LIGHT_DOME) {
        float z = 1.0f - 2.0f * u1, r = sqrt(fmax(0.0f, 1.0f - z * z)), phi = 2.0f * TS_PI * u2;
        s.dir = v3(r * cos(phi), r * sin(phi), z), s.pdf = choose / (4.0f * TS_PI);
    } else {
        ts_u32 k = emitter_pick(emitters, l->emitter_count, u1);
        TS_CONST_GLOBAL ts_emitter *e = &emitters[k];
        /* Reuse u1 within the chosen entry's cdf range as the u coordinate. */
        float lo = k > 0u ? emitters[k - 1u].cdf : 0.0f;
        float u = e->prob > 0.0f ? fmin(fmax((u1 - lo) / e->prob, 0.0f), 1.0f) : u3;
        TS_CONST_GLOBAL ts_vec4 *c = cp + (size_t)e->patch * 16u;
        ts_vec4 x = bezier_eval(c, u, u2), nn = bezier_cross_derivs(c, u, u2);
        ts_v3 to = v3(x.x - p.x, x.y - p.y, x.z - p.z);
        float d2 = v3_dot(to, to), jac = sqrt(nn.x * nn.x + nn.y * nn.y + nn.z * nn.z);
        if (!(d2 > 0.0f) || !(jac > 0.0f)) return s;
        s.dist = sqrt(d2);
        s.dir = v3_scale(to, 1.0f / s.dist);
        float cl = fabs(nn.x * s.dir.x + nn.y * s.dir.y + nn.z * s.dir.z) / jac;
        if (!(cl > 1e-6f)) return s;
        TS_CONST_GLOBAL ts_patch_attr *a = &attr[e->patch];
        s.le[0] = a->le_r, s.le[1] = a->le_g, s.le[2] = a->le_b;
        s.patch = e->patch;
        s.pdf = choose * e->prob * d2 / (jac * cl);
    }
    return s;
}

/* Radiance arriving along dir from the lights at infinity (a ray that hit nothing), with
 * the pdf with which light sampling would have chosen that direction. */
TS_INLINE void light_escape(TS_CONST_GLOBAL ts_light *lights, ts_u32 light_count, ts_v3 dir,
                            float le[3], float *pdf)
{
    le[0] = le[1] = le[2] = 0.0f;
    *pdf = 0.0f;
    float choose = 1.0f / (float)(light_count ? light_count : 1u);
    for (ts_u32 i = 0; i < light_count; ++i) {
        TS_CONST_GLOBAL ts_light *l = &lights[i];
        if (l->type == TS_LIGHT_DOME) {
            le[0] += l->radiance[0], le[1] += l->radiance[1], le[2] += l->radiance[2];
            *pdf += choose / (4.0f * TS_PI);
        } else if (l->type == TS_LIGHT_DISTANT && l->cos_max < 1.0f &&
                   dir.x * l->dir[0] + dir.y * l->dir[1] + dir.z * l->dir[2] >= l->cos_max) {
            le[0] += l->radiance[0], le[1] += l->radiance[1], le[2] += l->radiance[2];
            *pdf += choose / l->solid_angle;
        }
    }
}

/* The pdf with which light sampling picks point (u, v) of emissive patch `patch` seen along
 * unit dir at distance t (for the MIS weight of emission found by a BSDF sample). */
TS_INLINE float light_pdf_area(TS_CONST_GLOBAL ts_light *lights, ts_u32 light_count,
                               TS_CONST_GLOBAL ts_emitter *emitters, TS_CONST_GLOBAL ts_vec4 *cp,
                               ts_u32 emitter, ts_u32 patch, float u, float v, ts_v3 dir, float t)
{
    if (emitter == TS_INVALID || light_count == 0u) return 0.0f;
    ts_vec4 nn = bezier_cross_derivs(cp + (size_t)patch * 16u, u, v);
    float jac = sqrt(nn.x * nn.x + nn.y * nn.y + nn.z * nn.z);
    float cl = fabs(nn.x * dir.x + nn.y * dir.y + nn.z * dir.z) / (jac > 0.0f ? jac : 1.0f);
    if (!(jac > 0.0f) || !(cl > 1e-6f)) return 0.0f;
    return emitters[emitter].prob * t * t / (jac * cl) / (float)light_count;
}

#endif
