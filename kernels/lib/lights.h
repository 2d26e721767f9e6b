/* lights.h — sampling the scene's lights for next-event estimation and their pdfs for
 * multiple importance sampling (DESIGN.md §3). Solid-angle pdfs throughout; every pdf
 * includes the light's selection probability.
 *   selection: one light per light sample, with probability weight / (the sum of the
 *     weights of the lights that take part); host/pipeline/lights.c sets the weights. A
 *     uniform dome takes part only under --sampling light (light_sampled): with BSDF
 *     sampling in play a BSDF sample finds it as well as a light sample would, so its
 *     radiance comes from BSDF rays alone (weight 1) and the light samples go to the
 *     lights that need them (the sun).
 *   distant (sun): a cone of half angle acos(cos_max) around dir, uniform in solid angle,
 *     radiance = E / solid angle; a delta light when cos_max = 1 (irradiance E).
 *   dome: radiance L, uniform or times a lat-long map (z up: row 0 looks along +z, column
 *     x spans phi in [2 pi x / W, 2 pi (x + 1) / W) from +x towards +y); a uniform dome is
 *     sampled cosine-weighted about the shading normal (pdf cos / pi: no sample goes below
 *     the surface), a mapped one by texel luminance times sin(theta) through a marginal CDF
 *     over rows and a conditional CDF within each row (pdf = p(texel) W H / (2 pi^2 sin theta)).
 *   area: an emissive patch chosen by power (the emitter table), (u, v) uniform on its
 *     undisplaced surface; pdf = prob * dist^2 / (|dP/du x dP/dv| |cos_light|).
 *   point, spot (RenderMan's pointlight and spotlight): delta lights like the delta sun (no
 *     BSDF sample finds them; pdf = the choice), irradiance I falloff(d) on a surface facing
 *     them, times the spot's cone and beam (light_point_atten, shared_types.h ts_light). */
#ifndef TS_LIGHTS_H
#define TS_LIGHTS_H

#include "lib/bezier.h"
#include "lib/bsdf.h"
#include "lib/shared_types.h"

typedef struct ts_light_sample {
    ts_v3 dir;    /* towards the light, unit */
    float dist;   /* to the sampled point; TS_NO_HIT for lights at infinity */
    float le[3];  /* radiance arriving (or irradiance, for a delta light) */
    float pdf;    /* solid angle, with the light choice; 0 = failed sample */
    int delta;    /* a delta light: no BSDF sample can find it */
    ts_u32 patch; /* area: the sampled patch (its own boxes must not shadow the ray) */
    float u, v;   /* area: the sampled point's (u, v) on it (shade.cl: a trim may remove it) */
} ts_light_sample;

/* The environment map of a dome light: texels (rgb), the marginal CDF over rows (H) and the
 * conditional CDF within each row (W x H), cumulative, each ending at 1. */
typedef struct ts_env {
    TS_CONST_GLOBAL ts_vec4 *texels;
    TS_CONST_GLOBAL float *marginal;
    TS_CONST_GLOBAL float *conditional;
} ts_env;

/* First index i in cdf[0..n) with u < cdf[i]. */
TS_INLINE ts_u32 cdf_find(TS_CONST_GLOBAL float *cdf, ts_u32 n, float u)
{
    ts_u32 lo = 0, hi = n - 1u;
    while (lo < hi) {
        ts_u32 mid = (lo + hi) / 2u;
        if (u < cdf[mid])
            hi = mid;
        else
            lo = mid + 1u;
    }
    return lo;
}

/* Texel of direction d, and the density of sampling d by the map (solid angle). */
TS_INLINE ts_u32 env_lookup(TS_CONST_GLOBAL ts_light *l, ts_env env, ts_v3 d, float *pdf)
{
    ts_u32 w = l->map_width, h = l->map_height;
    float z = fmin(fmax(d.z, -1.0f), 1.0f), theta = acos(z), phi = atan2(d.y, d.x);
    if (phi < 0.0f) phi += 2.0f * TS_PI;
    ts_u32 x = (ts_u32)(phi / (2.0f * TS_PI) * (float)w), y = (ts_u32)(theta / TS_PI * (float)h);
    x = x < w ? x : w - 1u;
    y = y < h ? y : h - 1u;
    float pr = env.marginal[y] - (y ? env.marginal[y - 1u] : 0.0f);
    TS_CONST_GLOBAL float *row = env.conditional + (size_t)y * w;
    float pc = row[x] - (x ? row[x - 1u] : 0.0f);
    float s = sin(theta);
    *pdf = s > 0.0f ? pr * pc * (float)(w * h) / (2.0f * TS_PI * TS_PI * s) : 0.0f;
    return y * w + x;
}

/* Samples a direction of the map from (u1, u2): a row, then a column, then a point inside
 * the texel. */
TS_INLINE ts_v3 env_sample(TS_CONST_GLOBAL ts_light *l, ts_env env, float u1, float u2)
{
    ts_u32 w = l->map_width, h = l->map_height;
    ts_u32 y = cdf_find(env.marginal, h, u1);
    float r0 = y ? env.marginal[y - 1u] : 0.0f, r1 = env.marginal[y];
    float fy = r1 > r0 ? (u1 - r0) / (r1 - r0) : 0.5f;
    TS_CONST_GLOBAL float *row = env.conditional + (size_t)y * w;
    ts_u32 x = cdf_find(row, w, u2);
    float c0 = x ? row[x - 1u] : 0.0f, c1 = row[x];
    float fx = c1 > c0 ? (u2 - c0) / (c1 - c0) : 0.5f;
    float phi = 2.0f * TS_PI * ((float)x + fmin(fmax(fx, 0.0f), 1.0f)) / (float)w;
    float theta = TS_PI * ((float)y + fmin(fmax(fy, 0.0f), 1.0f)) / (float)h;
    return v3(sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta));
}

/* Direction in a cone around unit axis d with cos(half angle) = cos_max. */
TS_INLINE ts_v3 sample_cone(ts_v3 d, float cos_max, float u1, float u2)
{
    float c = 1.0f - u1 * (1.0f - cos_max), s = sqrt(fmax(0.0f, 1.0f - c * c));
    float phi = 2.0f * TS_PI * u2;
    return local_to_world(v3(s * cos(phi), s * sin(phi), c), d);
}

/* RenderMan's smoothstep(a, b, x) (RI Spec 3.2 §15.2): 0 below a, 1 from b on, the cubic
 * 3t^2 - 2t^3 of t = (x - a) / (b - a) between; a step at a when b <= a. */
TS_INLINE float light_smoothstep(float a, float b, float x)
{
    if (x < a) return 0.0f;
    if (!(b > a) || x >= b) return 1.0f;
    float t = (x - a) / (b - a);
    return t * t * (3.0f - 2.0f * t);
}

/* What a point or spot light l gives at distance d along unit direction w from the light,
 * as a factor of its radiance field (I): the distance falloff, and for a spot
 * cos^beam(a) smoothstep(cos_max, cos_inner, cos(a)), 0 outside the cone (cos(a) < cos_max),
 * cos(a) = w . axis (spotlight.sl; the beam factor takes cos(a) below 0 as 0). */
TS_INLINE float light_point_atten(TS_CONST_GLOBAL ts_light *l, float d, ts_v3 w)
{
    float r = l->falloff_dist / fmax(d, l->falloff_min);
    float a = l->falloff == 2.0f ? r * r : l->falloff == 0.0f ? 1.0f : pow(r, l->falloff);
    if (l->type != TS_LIGHT_SPOT) return a;
    float c = w.x * l->dir[0] + w.y * l->dir[1] + w.z * l->dir[2];
    if (c < l->cos_max) return 0.0f;
    float beam = l->beam == 0.0f ? 1.0f : pow(fmax(c, 0.0f), l->beam);
    return a * beam * light_smoothstep(l->cos_max, l->cos_inner, c);
}

/* The emitter whose cdf range holds u (binary search). */
TS_INLINE ts_u32 emitter_pick(TS_CONST_GLOBAL ts_emitter *e, ts_u32 n, float u)
{
    ts_u32 lo = 0, hi = n - 1u;
    while (lo < hi) {
        ts_u32 mid = (lo + hi) / 2u;
        if (u < e[mid].cdf)
            hi = mid;
        else
            lo = mid + 1u;
    }
    return lo;
}

/* 1 when light l takes part in light sampling under `sampling` (TS_SAMPLING_*, with
 * TS_LIGHTS_NO_DOMES: no dome does). */
TS_INLINE int light_sampled(TS_CONST_GLOBAL ts_light *l, ts_u32 sampling)
{
    int uniform_dome = l->type == TS_LIGHT_DOME && l->map_width == 0u;
    if (l->type == TS_LIGHT_DOME && (sampling & TS_LIGHTS_NO_DOMES)) return 0;
    return l->weight > 0.0f && !(uniform_dome && TS_SAMPLING_MODE(sampling) != TS_SAMPLING_LIGHT);
}

/* The sum of the weights of the lights that take part. */
TS_INLINE float light_total(TS_CONST_GLOBAL ts_light *lights, ts_u32 count, ts_u32 sampling)
{
    float total = 0.0f;
    for (ts_u32 i = 0; i < count; ++i)
        if (light_sampled(&lights[i], sampling)) total += lights[i].weight;
    return total;
}

/* The probability that light li is chosen. */
TS_INLINE float light_select_prob(TS_CONST_GLOBAL ts_light *lights, ts_u32 count, ts_u32 sampling,
                                  ts_u32 li)
{
    float total = light_total(lights, count, sampling);
    return li < count && total > 0.0f && light_sampled(&lights[li], sampling)
               ? lights[li].weight / total
               : 0.0f;
}

/* Chooses a light with probability weight / total from u in [0, 1): the first whose
 * cumulative weight exceeds u * total (the last taking part when rounding leaves none).
 * *prob gets its probability; returns count when no light takes part. */
TS_INLINE ts_u32 light_select(TS_CONST_GLOBAL ts_light *lights, ts_u32 count, ts_u32 sampling,
                              float u, float *prob)
{
    float total = light_total(lights, count, sampling), target = u * total, acc = 0.0f;
    ts_u32 chosen = count;
    *prob = 0.0f;
    for (ts_u32 i = 0; i < count; ++i) {
        if (!light_sampled(&lights[i], sampling)) continue;
        chosen = i;
        acc += lights[i].weight;
        if (target < acc) break;
    }
    if (chosen < count) *prob = lights[chosen].weight / total;
    return chosen;
}

/* Samples light `li`, chosen with probability `choose`, as seen from point p with shading
 * normal n. */
TS_INLINE ts_light_sample light_sample(TS_CONST_GLOBAL ts_light *lights, ts_u32 li, float choose,
                                       ts_env env, TS_CONST_GLOBAL ts_emitter *emitters,
                                       TS_CONST_GLOBAL ts_vec4 *cp,
                                       TS_CONST_GLOBAL ts_patch_attr *attr, ts_v3 p, ts_v3 n,
                                       float u1, float u2, float u3)
{
    ts_light_sample s;
    TS_CONST_GLOBAL ts_light *l = &lights[li];
    s.dist = TS_NO_HIT, s.delta = 0, s.patch = TS_INVALID, s.pdf = 0.0f, s.u = s.v = 0.0f;
    s.le[0] = l->radiance[0], s.le[1] = l->radiance[1], s.le[2] = l->radiance[2];
    if (l->type == TS_LIGHT_DISTANT) {
        ts_v3 d = v3(l->dir[0], l->dir[1], l->dir[2]);
        if (l->cos_max >= 1.0f) {
            s.dir = d, s.delta = 1, s.pdf = choose;
        } else {
            s.dir = sample_cone(d, l->cos_max, u1, u2), s.pdf = choose / l->solid_angle;
        }
    } else if (l->type == TS_LIGHT_POINT || l->type == TS_LIGHT_SPOT) {
        ts_v3 to = v3(l->pos[0] - p.x, l->pos[1] - p.y, l->pos[2] - p.z);
        float d2 = v3_dot(to, to);
        if (!(d2 > 0.0f)) return s;
        s.dist = sqrt(d2);
        s.dir = v3_scale(to, 1.0f / s.dist);
        float a = light_point_atten(l, s.dist, v3_scale(s.dir, -1.0f));
        if (!(a > 0.0f)) return s; /* outside a spot's cone */
        s.le[0] *= a, s.le[1] *= a, s.le[2] *= a;
        s.delta = 1, s.pdf = choose;
    } else if (l->type == TS_LIGHT_DOME && l->map_width) {
        float pdf;
        s.dir = env_sample(l, env, u1, u2);
        ts_vec4 t = env.texels[env_lookup(l, env, s.dir, &pdf)];
        s.le[0] *= t.x, s.le[1] *= t.y, s.le[2] *= t.z;
        s.pdf = choose * pdf;
    } else if (l->type == TS_LIGHT_DOME) { /* uniform: cosine-weighted about n */
        s.dir = sample_cosine(n, u1, u2);
        float c = v3_dot(n, s.dir);
        s.pdf = c > 0.0f ? choose * c / TS_PI : 0.0f;
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
        s.patch = e->patch, s.u = u, s.v = u2;
        s.pdf = choose * e->prob * d2 / (jac * cl);
    }
    return s;
}

/* Radiance arriving along dir from the lights at infinity (a ray that hit nothing), with
 * the pdf with which light sampling (under `sampling`) would have chosen that direction. A
 * uniform dome adds no pdf: it is light-sampled only under --sampling light, where emission
 * found by BSDF rays has weight 0 anyway. eye: the ray is an eye ray, which does not see
 * domes flagged TS_LIGHT_NOT_SEEN (RIB ambientlight lights surfaces, not the background).
 * With TS_LIGHTS_NO_DOMES in sampling no dome adds anything (the ray left a relit vertex). */
TS_INLINE void light_escape(TS_CONST_GLOBAL ts_light *lights, ts_u32 light_count, ts_u32 sampling,
                            ts_env env, ts_v3 dir, int eye, float le[3], float *pdf)
{
    le[0] = le[1] = le[2] = 0.0f;
    *pdf = 0.0f;
    float total = light_total(lights, light_count, sampling);
    for (ts_u32 i = 0; i < light_count; ++i) {
        TS_CONST_GLOBAL ts_light *l = &lights[i];
        float choose = total > 0.0f && light_sampled(l, sampling) ? l->weight / total : 0.0f;
        if (l->type == TS_LIGHT_DOME && (sampling & TS_LIGHTS_NO_DOMES)) continue;
        if (l->type == TS_LIGHT_DOME && l->map_width) {
            float p;
            ts_vec4 t = env.texels[env_lookup(l, env, dir, &p)];
            le[0] += l->radiance[0] * t.x, le[1] += l->radiance[1] * t.y,
                le[2] += l->radiance[2] * t.z;
            *pdf += choose * p;
        } else if (l->type == TS_LIGHT_DOME && !(eye && (l->flags & TS_LIGHT_NOT_SEEN))) {
            le[0] += l->radiance[0], le[1] += l->radiance[1], le[2] += l->radiance[2];
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
                               ts_u32 sampling, TS_CONST_GLOBAL ts_emitter *emitters,
                               TS_CONST_GLOBAL ts_vec4 *cp, ts_u32 emitter, ts_u32 patch, float u,
                               float v, ts_v3 dir, float t)
{
    if (emitter == TS_INVALID || light_count == 0u) return 0.0f;
    ts_u32 area = 0u; /* the area light: the list's last entry */
    while (area < light_count && lights[area].type != TS_LIGHT_AREA)
        ++area;
    float choose = light_select_prob(lights, light_count, sampling, area);
    ts_vec4 nn = bezier_cross_derivs(cp + (size_t)patch * 16u, u, v);
    float jac = sqrt(nn.x * nn.x + nn.y * nn.y + nn.z * nn.z);
    float cl = fabs(nn.x * dir.x + nn.y * dir.y + nn.z * dir.z) / (jac > 0.0f ? jac : 1.0f);
    if (!(jac > 0.0f) || !(cl > 1e-6f)) return 0.0f;
    return choose * emitters[emitter].prob * t * t / (jac * cl);
}

#endif
