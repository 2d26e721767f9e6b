/* shade.cl — stage `shade` (Hanika §3.5, §4): one path-tracing step for every path that
 * traced a ray in this wave, split as Cycles' shade_surface.h is:
 *   shade_shadow_result  a shadow ray that reached its light unoccluded adds its light sample;
 *   shade_escape         a camera or BSDF ray that hit nothing adds sky and sun;
 *   shade_emission       one that hit an emissive patch adds its emission;
 *   shade_direct_light   below the depth: next-event estimation, a light sample and its
 *                        shadow ray;
 *   shade_bsdf_bounce    below the depth: a BSDF sample continues the path, ended from the
 *                        second bounce on by Russian roulette with probability
 *                        1 - min(1, max(throughput)).
 * Path i owns two ray slots: i for its BSDF ray and wave_size + i for its shadow ray; its
 * state's TS_PATH_TRACED_* bits say which of the two it traced.
 * Reads:  the wave's paths (paths[0..path_count)), their rays (org, dir, hit), path state
 *         (throughput, mis, state, pending), patch data, lights, emitters, the dome's map,
 *         textures (colour at the hit's st, displacement for the normal; every tile the
 *         chunk needs resident, host/pipeline/shade.c); with --occlusion the baked points
 *         (relight_patch, relight_coeffs, relight_normal) and the domes' tables
 *         (relight_light, host/pipeline/relight.c); the diced grids of resident patches
 *         (grid, grid_at: vert_first and m per patch, TS_INVALID where none, and the
 *         patch's stitched edges in triangle mode; host/pipeline/pipeline.h
 *         pipeline_grid_publish) for the shading normals.
 * Writes: radiance (accumulated per path), aov (normal, Z) and albedo at the eye hit, the
 *         path's next rays into its two slots (org, dir, hit, entry, flags), path state,
 *         alive[k] (per list slot k): the TS_PATH_TRACED_* bits of the rays it traces next.
 * Invariants: one work-item per path, which writes only its own slots (and alive[k]), so
 *         no races and the result does not depend on the order of the list; a path whose
 *         state traces nothing, or that ends here, keeps its state and gets alive[k] = 0.
 * MIS (Veach 1995, balance heuristic): the light sample weighs p_l / (p_l + p_b), emission
 * found by a BSDF ray p_b / (p_b + p_l), with p_b the pdf of the sample that made the ray
 * (path field mis) and the weighting chosen when it was made (state's TS_MIS_* mode):
 * --sampling light or bsdf keeps one strategy at weight 1.
 * Lights: one chosen per vertex by weight (lib/lights.h light_select); a uniform dome is
 * left to BSDF rays unless --sampling light. A point sampled on an area light that a trim
 * removes (TrimCurve, lib/trim.h) gives nothing.
 * Relighting (render --occlusion, rp.bands > 0; lib/relight.h, docs/bake.md): at the eye
 * ray's hit (bounce 0) the domes' light comes from the baked occlusion instead of rays:
 * shade_relit adds Kd Cs / pi times the irradiance E(n) of the domes through the baked
 * visibility; that vertex's light sample and the domes its BSDF ray finds leave the domes out
 * (TS_LIGHTS_NO_DOMES; the ray carries TS_PATH_RELIT). Other lights, and every later vertex,
 * are path traced as without it.
 * Sample values: Owen-scrambled Sobol sets (lib/sampler.h), keyed by (pixel, sample): at
 * vertex b, set TS_SET_LIGHT(b) = the light's choice and the point on it, TS_SET_BSDF(b) =
 * the lobe, the direction and Russian roulette. */
#include "lib/shared_types.h"
#include "lib/bsdf.h"
#include "lib/lights.h"
#include "lib/noise4.h"
#include "lib/patch.h"
#include "lib/quadtree.h"
#include "lib/relight.h"
#include "lib/sample_order.h"
#include "lib/sampler.h"
#include "lib/trim.h"

/* One path's step: its slots, the keys of its sample values and its weight so far. */
typedef struct shade_step {
    uint i, wave_size;        /* ray slot i, shadow-ray slot wave_size + i */
    uint pix, sample, bounce; /* sampler keys; bounce 0: the eye rays' hits */
    uint seed, mask;          /* mask: lib/sampler.h sampler_mask(spp) */
    float tp[3];              /* throughput up to this vertex */
} shade_step;

/* This vertex's light set (the choice, then the point on the light) or BSDF set (lobe, two
 * for the direction, Russian roulette): lib/sampler.h. */
inline ts_sampler_set step_light_set(const shade_step *s)
{
    return sampler_set(s->pix, s->sample, TS_SET_LIGHT(s->bounce), s->seed, s->mask);
}

inline ts_sampler_set step_bsdf_set(const shade_step *s)
{
    return sampler_set(s->pix, s->sample, TS_SET_BSDF(s->bounce), s->seed, s->mask);
}

/* The scene's lights as shade samples them (lib/lights.h). */
typedef struct shade_lights {
    __global const ts_light *lights;
    uint count, sampling;
    ts_env env;
    __global const ts_emitter *emitters;
    __global const ts_vec4 *cp;
    __global const ts_patch_attr *attr;
    __global const ts_vec4 *trim_seg; /* trimmed emitters' segments (lib/trim.h) */
} shade_lights;

/* A path vertex on a patch. */
typedef struct shade_vertex {
    ts_v3 p;     /* the hit point */
    ts_v3 n;     /* shading normal, on wo's side */
    ts_v3 wo;    /* towards the previous vertex */
    float cs[3]; /* surface colour at the hit (lib/texture.h tex_surface_colour) */
    __global const ts_patch_attr *a;
    float eps;  /* next rays' offset along n: l / 2^m (Hanika §3.3) */
    float self; /* next rays ignore hits on this patch nearer than this (bottom_level) */
    uint patch; /* the patch hit */
    float time; /* the ray's time, kept by the next rays (Hanika §3.4) */
} shade_vertex;

/* The ray buffers (TS_RAY_FIELDS) the next rays go to. */
typedef struct shade_rays {
    __global ts_vec4 *org;
    __global ts_vec4 *dir;
    __global ts_hit *hit;
    __global uint *entry;
    __global uint *flags;
    __global uint *from;
} shade_rays;

inline void add_rgb(__global ts_vec4 *acc, const float t[3], const float l[3], float w)
{
    ts_vec4 a = *acc;
    a.x += t[0] * l[0] * w, a.y += t[1] * l[1] * w, a.z += t[2] * l[2] * w;
    *acc = a;
}

/* Writes ray slot i: from the vertex, offset by eps along n on the side dir goes to (the far
 * side for a ray through a translucent sheet), towards dir, up to tmax. */
inline void emit_ray(shade_rays r, uint i, const shade_vertex *v, ts_v3 dir, float tmax, uint flags)
{
    ts_v3 p = v->p, n = v3_dot(v->n, dir) < 0.0f ? v3_scale(v->n, -1.0f) : v->n;
    float eps = v->eps;
    r.org[i] = (ts_vec4){p.x + eps * n.x, p.y + eps * n.y, p.z + eps * n.z, v->self};
    r.dir[i] = (ts_vec4){dir.x, dir.y, dir.z, v->time};
    r.hit[i] = (ts_hit){tmax, 0.0f, 0.0f, TS_INVALID, TS_INVALID};
    r.entry[i] = TS_ENTRY_START;
    r.flags[i] = flags;
    r.from[i] = v->patch + 1u;
}

/* MIS weight of emission found by a BSDF ray made with pdf pb under `mode`, against light
 * sampling's pdf pl of the same direction. */
inline float emission_weight(float pb, uint mode, float pl)
{
    return mode == TS_MIS_ONE ? 1.0f : mode == TS_MIS_ZERO ? 0.0f : pb / (pb + pl);
}

/* The light sample waiting in pending is added when its shadow ray hit nothing. */
inline void shade_shadow_result(ts_hit shadow, ts_vec4 pe, __global ts_vec4 *radiance)
{
    if (shadow.patch != TS_INVALID) return;
    ts_vec4 r = *radiance;
    *radiance = (ts_vec4){r.x + pe.x, r.y + pe.y, r.z + pe.z, r.w};
}

/* A ray that hit nothing: sky and sun in direction d, MIS-weighted. */
inline void shade_escape(const shade_lights *L, ts_v3 d, const shade_step *s, float pb, uint mode,
                         __global ts_vec4 *radiance)
{
    float le[3], pl;
    light_escape(L->lights, L->count, L->sampling, L->env, d, s->bounce == 0u, le, &pl);
    add_rgb(radiance, s->tp, le, emission_weight(pb, mode, pl));
}

/* The vertex where ray d (from o, at time) hit patch h.patch: position, shading normal
 * towards the ray's origin, colour. */
inline shade_vertex shade_vertex_at(ts_hit h, ts_vec4 o4, ts_v3 d, float time,
                                    __global const ts_vec4 *cp, __global const ts_vec4 *corner_n,
                                    __global const ts_vec4 *mid_n,
                                    __global const ts_patch_attr *attr,
                                    __global const ts_xform *xform, ts_tex_ctx tex,
                                    __global const ts_vec4 *grid, __global const uint *grid_at)
{
    shade_vertex v;
    v.a = attr + h.patch;
    __global const ts_vec4 *c = cp + (size_t)h.patch * 16u;
    uint m = TS_PRIM_LOD(h.prim), q = TS_PRIM_INDEX(h.prim) >> 1;
    uint qi = q & ((1u << m) - 1u), qj = q >> m;
    uint gf = grid_at[3u * h.patch], gm = grid_at[3u * h.patch + 1u];
    uint edges = grid_at[3u * h.patch + 2u]; /* triangle mode's stitching (dice.cl) */
    ts_vec4 n4;
    /* The hit micro-quad's normal from its four vertices: read from the diced grid where the
     * patch is still resident at this m (pipeline_grid_publish), else evaluated (the same
     * function of (i, j, m), so the same bits). */
    if (v.a->disp_kind != TS_DISP_NONE && gf != TS_INVALID && gm == m) {
        uint n = (1u << m) + 1u;
        __global const ts_vec4 *g = grid + gf + qj * n + qi;
        n4 = patch_quad_normal(c, h.u, h.v, g[0], g[1], g[n], g[n + 1u]);
    } else {
        n4 = patch_quad_shading_normal_x4(c, corner_n + (size_t)h.patch * 4u,
                                          mid_n + (size_t)h.patch * 5u, v.a, xform + v.a->xform,
                                          tex, h.u, h.v, qi, qj, m, edges);
    }
    tex_surface_colour(v.a, tex, h.u, h.v, v.cs);
    v.n = v3(n4.x, n4.y, n4.z), v.wo = v3_scale(d, -1.0f);
    if (v3_dot(v.n, v.wo) < 0.0f) v.n = v3_scale(v.n, -1.0f);
    v.p = v3(o4.x + h.t * d.x, o4.y + h.t * d.y, o4.z + h.t * d.z);
    v.eps = 0.0f;
    v.self = 0.0f;
    v.patch = h.patch;
    v.time = time;
    return v;
}

/* The hit patch's emission (both sides), MIS-weighted against sampling it as an area
 * light from the previous vertex. */
inline void shade_emission(const shade_lights *L, const shade_vertex *v, ts_hit h, ts_v3 d,
                           const shade_step *s, float pb, uint mode, __global ts_vec4 *radiance)
{
    __global const ts_patch_attr *a = v->a;
    if (!(a->le_r > 0.0f || a->le_g > 0.0f || a->le_b > 0.0f)) return;
    float e[3] = {a->le_r, a->le_g, a->le_b};
    float pl = light_pdf_area(L->lights, L->count, L->sampling, L->emitters, L->cp, a->emitter,
                              h.patch, h.u, h.v, d, h.t);
    add_rgb(radiance, s->tp, e, emission_weight(pb, mode, pl));
}

/* The baked occlusion (render --occlusion) as shade reads it: lib/relight.h. */
typedef struct shade_relight {
    ts_relight_params rp;
    __global const ts_u32 *patch; /* 2 words a patch: first point, m */
    __global const float *coeffs; /* B^2 a point */
    __global const float *normal; /* 3 a point: the N its hemisphere is about */
    __global const ts_vec4 *light;
} shade_relight;

/* The domes' light at the relit vertex: the diffuse lobe Kd Cs / pi times the irradiance
 * the baked occlusion gives at the hit's (u, v) for the shading normal (glossy lobes get no
 * dome light there: the file holds visibility, not a view-dependent transfer). */
inline void shade_relit(const shade_relight *R, const shade_vertex *v, ts_hit h,
                        const shade_step *s, __global ts_vec4 *radiance)
{
    __global const ts_patch_attr *a = v->a;
    float kd = a->material == TS_MAT_METAL ? 0.0f : a->kd / TS_PI;
    if (!(kd > 0.0f) || h.patch >= R->rp.patch_count) return;
    float c[TS_SH_MAX_COEFFS], e[3];
    relight_coeffs(R->patch, R->coeffs, R->normal, R->rp.bands * R->rp.bands, h.patch, h.u, h.v,
                   v->n, c);
    relight_irradiance(R->rp, R->light, c, v->n, e);
    float le[3] = {kd * v->cs[0] * e[0], kd * v->cs[1] * e[1], kd * v->cs[2] * e[2]};
    add_rgb(radiance, s->tp, le, 1.0f);
}

/* Next-event estimation: samples a light (chosen uniformly) and, when it lights the
 * vertex, stores its contribution in *pending and writes the shadow ray into slot
 * wave_size + i, stopping short of an area light's point and ignoring that patch. Returns
 * TS_PATH_TRACED_SHADOW when it wrote one. */
inline uint shade_direct_light(ts_shade_params sp, const shade_lights *L, const shade_vertex *v,
                               const shade_step *s, __global ts_vec4 *pending, shade_rays r)
{
    if (L->count == 0u || sp.sampling == TS_SAMPLING_BSDF) return 0u;
    float choose;
    ts_sampler_set u = step_light_set(s);
    uint li = light_select(L->lights, L->count, L->sampling, sampler_set_value(u, 0u), &choose);
    if (li >= L->count) return 0u; /* no light takes part (a uniform dome only, say) */
    /* A uniform dome is sampled about the normal (cosine-weighted); a translucent vertex takes
     * its side by the share each side scatters, with u3, which the dome does not use. */
    ts_v3 ln = v->n;
    float side = 1.0f;
    if (v->a->material == TS_MAT_TRANSLUCENT && L->lights[li].type == TS_LIGHT_DOME &&
        !L->lights[li].map_width) {
        side = translucent_front_prob(v->a);
        if (!(sampler_set_value(u, 3u) < side)) ln = v3_scale(v->n, -1.0f), side = 1.0f - side;
    }
    ts_light_sample ls =
        light_sample(L->lights, li, choose, L->env, L->emitters, L->cp, L->attr, v->p, ln,
                     sampler_set_value(u, 1u), sampler_set_value(u, 2u), sampler_set_value(u, 3u));
    ls.pdf *= side;
    /* A point a trim removes from an emitter gives nothing: the sample's pdf is the whole
     * piece's, so the estimate is of the light of the part that is there. */
    if (ls.patch != TS_INVALID && L->attr[ls.patch].trim_count != 0u &&
        !trim_keeps(L->trim_seg + L->attr[ls.patch].trim_first, L->attr[ls.patch].trim_count, ls.u,
                    ls.v))
        return 0u;
    float f[3] = {0.0f, 0.0f, 0.0f};
    float pb = ls.pdf > 0.0f ? bsdf_eval(v->a, v->cs, v->n, v->wo, ls.dir, f) : 0.0f;
    /* |cos|: only a translucent material's f is not 0 below the surface */
    float cosl = ls.pdf > 0.0f ? fabs(v3_dot(v->n, ls.dir)) : 0.0f;
    if (!(cosl > 0.0f && (f[0] > 0.0f || f[1] > 0.0f || f[2] > 0.0f))) return 0u;
    /* Light sampling alone where no BSDF sample can find the light: a delta light, --sampling
     * light, or an emitter indirect rays do not see (TS_PATCH_NO_INDIRECT, top_level). */
    int alone = ls.delta || sp.sampling == TS_SAMPLING_LIGHT ||
                (ls.patch != TS_INVALID && (L->attr[ls.patch].flags & TS_PATCH_NO_INDIRECT));
    float denom = alone ? ls.pdf : ls.pdf + pb;
    float w = cosl / denom;
    const float *tp = s->tp;
    *pending = (ts_vec4){tp[0] * f[0] * ls.le[0] * w, tp[1] * f[1] * ls.le[1] * w,
                         tp[2] * f[2] * ls.le[2] * w, 0.0f};
    float tmax = ls.dist < TS_NO_HIT ? ls.dist * (1.0f - 1e-4f) : TS_NO_HIT;
    uint target = ls.patch == TS_INVALID ? 0u : (ls.patch + 1u) << 1;
    emit_ray(r, s->wave_size + s->i, v, ls.dir, tmax, TS_RAY_SHADOW | target);
    return TS_PATH_TRACED_SHADOW;
}

/* The path's new throughput tp f w; from the second bounce on the path survives Russian
 * roulette with probability min(1, max of it) and is reweighted by it. 1 when it goes on,
 * with the throughput written. */
inline int shade_survive(const shade_step *s, ts_sampler_set u, const float f[3], float w,
                         __global ts_vec4 *throughput)
{
    const float *tp = s->tp;
    float nt[3] = {tp[0] * f[0] * w, tp[1] * f[1] * w, tp[2] * f[2] * w};
    float survive = s->bounce >= 1u ? fmin(1.0f, fmax(nt[0], fmax(nt[1], nt[2]))) : 1.0f;
    if (!(sampler_set_value(u, 3u) < survive)) return 0;
    *throughput = (ts_vec4){nt[0] / survive, nt[1] / survive, nt[2] / survive, 0.0f};
    return 1;
}

/* Samples the BSDF for the path's next ray; from the second bounce on the path survives
 * Russian roulette with probability min(1, max(new throughput)) and is reweighted by it.
 * When it goes on: writes its throughput, the sample's pdf (mis) and *mode for the
 * emission the ray finds, the ray into slot i, and returns TS_PATH_TRACED_BSDF. */
inline uint shade_bsdf_bounce(ts_shade_params sp, const shade_vertex *v, const shade_step *s,
                              __global ts_vec4 *throughput, __global float *mis, uint *mode,
                              shade_rays r)
{
    ts_v3 wi;
    float f[3];
    ts_sampler_set u = step_bsdf_set(s);
    float pb = bsdf_sample(v->a, v->cs, v->n, v->wo, sampler_set_value(u, 0u),
                           sampler_set_value(u, 1u), sampler_set_value(u, 2u), &wi, f);
    float cosi = v3_dot(v->n, wi); /* below 0 only through a translucent sheet */
    if (!(pb > 0.0f && cosi != 0.0f)) return 0u;
    if (!shade_survive(s, u, f, fabs(cosi) / pb, throughput)) return 0u;
    *mode = sp.light_count == 0u || sp.sampling == TS_SAMPLING_BSDF ? TS_MIS_ONE
            : sp.sampling == TS_SAMPLING_LIGHT                      ? TS_MIS_ZERO
                                                                    : TS_MIS_BALANCE;
    emit_ray(r, s->i, v, wi, TS_NO_HIT, 0u);
    *mis = pb;
    return TS_PATH_TRACED_BSDF;
}

/* Glass (TS_MAT_GLASS): a delta lobe sampled (lib/bsdf.h glass_sample), so the emission the
 * ray finds counts whole (TS_MIS_ONE: no light sample could have found it; rough glass takes
 * no light sample either, so the same holds for it); Russian roulette
 * by shade_survive. A refracted ray leaves from the far side of the surface and flips
 * the path's TS_PATH_INSIDE bit in *inside. */
inline uint shade_glass_bounce(const shade_vertex *v, const shade_step *s,
                               __global ts_vec4 *throughput, __global float *mis, uint *mode,
                               uint *inside, shade_rays r)
{
    ts_v3 wi;
    float w[3];
    ts_sampler_set u = step_bsdf_set(s);
    int through = glass_sample(v->a, v->cs, v->n, v->wo, (*inside & TS_PATH_INSIDE) != 0u,
                               sampler_set_value(u, 0u), sampler_set_value(u, 1u),
                               sampler_set_value(u, 2u), &wi, w);
    if (!(w[0] > 0.0f || w[1] > 0.0f || w[2] > 0.0f)) return 0u; /* rough glass's weight 0 */
    if (!shade_survive(s, u, w, 1.0f, throughput)) return 0u;
    *mode = TS_MIS_ONE;
    *mis = 1.0f;
    shade_vertex out = *v;
    if (through) {
        out.n = v3_scale(v->n, -1.0f);
        *inside ^= TS_PATH_INSIDE;
    }
    emit_ray(r, s->i, &out, wi, TS_NO_HIT, 0u);
    return TS_PATH_TRACED_BSDF;
}

/* The sample (of its pixel) that the frame's k-th sample is. */
static uint shade_sample(uint k, ts_order_divs ord)
{
    uint pixel, sample;
    sample_order_at_ready(k, ord, &pixel, &sample);
    return sample;
}

__kernel void shade_path(ts_shade_params sp, ts_order_divs ord, uint first_sample, uint wave_size,
                         __global const uint *paths, uint path_count, __global ts_vec4 *org,
                         __global ts_vec4 *dir, __global ts_hit *hit, __global uint *entry,
                         __global uint *ray_flags, __global uint *ray_from,
                         __global const uint *pixel, __global ts_vec4 *throughput,
                         __global float *mis, __global uint *state, __global ts_vec4 *pending,
                         __global ts_vec4 *radiance, __global ts_vec4 *aov,
                         __global ts_vec4 *albedo, __global const ts_vec4 *cp,
                         __global const ts_vec4 *corner_n, __global const ts_vec4 *mid_n,
                         __global const ts_patch_attr *attr, __global const ts_xform *xform,
                         __global const ts_light *lights, __global const ts_emitter *emitters,
                         __global const ts_vec4 *env_texels, __global const float *env_marginal,
                         __global const float *env_conditional, __global const ts_vec4 *flatness,
                         __global const ts_texture *textures, __global const uint *tex_pages,
                         __global const ts_vec4 *tex_pool, __global uint *alive,
                         ts_relight_params rp, __global const uint *relight_patch,
                         __global const float *relight_coeffs, __global const float *relight_normal,
                         __global const ts_vec4 *relight_light, __global const ts_vec4 *grid,
                         __global const uint *grid_at, __global const ts_vec4 *trim_seg)
{
    uint k = get_global_id(0);
    if (k >= path_count) return;
    uint i = paths[k], st = state[i];
    alive[k] = 0u;
    if (st & TS_PATH_TRACED_SHADOW)
        shade_shadow_result(hit[wave_size + i], pending[i], &radiance[i]);
    if (!(st & TS_PATH_TRACED_BSDF)) return;
    /* A ray from the relit vertex finds no dome: its light was counted there. */
    uint no_domes = st & TS_PATH_RELIT ? TS_LIGHTS_NO_DOMES : 0u;
    shade_lights L = {.lights = lights,
                      .count = sp.light_count,
                      .sampling = sp.sampling | no_domes,
                      .env = {env_texels, env_marginal, env_conditional},
                      .emitters = emitters,
                      .cp = cp,
                      .attr = attr,
                      .trim_seg = trim_seg};
    ts_tex_ctx tex = {textures, tex_pages, tex_pool};
    shade_rays rays = {org, dir, hit, entry, ray_flags, ray_from};
    ts_hit h = hit[i];
    ts_vec4 d4 = dir[i], o4 = org[i], t4 = throughput[i];
    ts_v3 d = v3(d4.x, d4.y, d4.z);
    float pb = mis[i];
    uint mode = TS_PATH_MIS(st);
    shade_step s = {.i = i,
                    .wave_size = wave_size,
                    .pix = pixel[i],
                    .sample = shade_sample(first_sample + i, ord),
                    .bounce = sp.bounce,
                    .seed = sp.seed,
                    .mask = ord.mask,
                    .tp = {t4.x, t4.y, t4.z}};
    if (h.patch == TS_INVALID) {
        shade_escape(&L, d, &s, pb, mode, &radiance[i]);
        if (s.bounce == 0u)
            aov[i] = (ts_vec4){0.0f, 0.0f, 0.0f, INFINITY}, albedo[i] = (ts_vec4){0, 0, 0, 0};
        return;
    }
    shade_vertex v =
        shade_vertex_at(h, o4, d, d4.w, cp, corner_n, mid_n, attr, xform, tex, grid, grid_at);
    if (s.bounce == 0u) {
        __global const ts_patch_attr *a = v.a;
        aov[i] = (ts_vec4){v.n.x, v.n.y, v.n.z, h.t + o4.w}; /* o4.w: a clipped eye ray's start */
        albedo[i] = (ts_vec4){a->kd * v.cs[0], a->kd * v.cs[1], a->kd * v.cs[2], 0.0f};
    }
    shade_emission(&L, &v, h, d, &s, pb, mode, &radiance[i]);
    if (s.bounce >= sp.depth) return;
    /* l: the longest side of the patch's box, in the flatness record's w. */
    v.eps = flatness[h.patch].w * ldexp(1.0f, -(int)TS_PRIM_LOD(h.prim));
    /* Hits on this patch nearer than one micro-quad (eps) are below the level of detail's
     * resolution (bottom_level.cl's origin-patch rule intersects it as micro-triangles). */
    v.self = v.eps;
    uint relit = rp.bands > 0u && s.bounce == 0u ? TS_PATH_RELIT : 0u;
    if (relit) {
        shade_relight R = {rp, relight_patch, relight_coeffs, relight_normal, relight_light};
        shade_relit(&R, &v, h, &s, &radiance[i]);
    }
    L.sampling = sp.sampling | (relit ? TS_LIGHTS_NO_DOMES : 0u);
    uint inside = st & TS_PATH_INSIDE, out;
    if (v.a->material == TS_MAT_GLASS) {
        out = shade_glass_bounce(&v, &s, &throughput[i], &mis[i], &mode, &inside, rays);
    } else {
        out = shade_direct_light(sp, &L, &v, &s, &pending[i], rays);
        out |= shade_bsdf_bounce(sp, &v, &s, &throughput[i], &mis[i], &mode, rays);
    }
    state[i] = TS_PATH_STATE(out, mode) | relit | inside;
    alive[k] = out;
}

/* Not a stage: the probe of tests/test_shading_normal.c. Item i: the shading normal
 * shade_vertex_at evaluates (patch_quad_shading_normal_x4) for a hit at (u, v) = (uv[2i],
 * uv[2i + 1]) in micro-quad (pm[4i + 2], pm[4i + 3]) of patch pm[4i] diced at m = pm[4i + 1],
 * which the test compares bit for bit with the host's patch_quad_shading_normal (lib/patch.h). */
__kernel void shade_normal_probe(__global const float *uv, __global const uint *pm, uint count,
                                 __global const ts_vec4 *cp, __global const ts_vec4 *corner_n,
                                 __global const ts_vec4 *mid_n, __global const ts_patch_attr *attr,
                                 __global const ts_xform *xform,
                                 __global const ts_texture *textures,
                                 __global const uint *tex_pages, __global const ts_vec4 *tex_pool,
                                 __global ts_vec4 *out)
{
    uint i = get_global_id(0);
    if (i >= count) return;
    uint q = pm[4u * i], m = pm[4u * i + 1u];
    __global const ts_patch_attr *a = attr + q;
    ts_tex_ctx tex = {textures, tex_pages, tex_pool};
    out[i] =
        patch_quad_shading_normal_x4(cp + (size_t)q * 16u, corner_n + (size_t)q * 4u,
                                     mid_n + (size_t)q * 5u, a, xform + a->xform, tex, uv[2u * i],
                                     uv[2u * i + 1u], pm[4u * i + 2u], pm[4u * i + 3u], m, 0u);
}

/* Not a stage: the probe of tests/test_principled.c. Item i reads in[12i ...]: the colour
 * cs[3], wo[3], wi[3] (the normal is +z) and (u0, u1, u2); writes out[12i ...]: bsdf_eval's
 * f[3] and pdf, bsdf_sample's wi[3], 0, f[3] and pdf, for patch attribute attr[i]. */
__kernel void shade_bsdf_probe(__global const ts_patch_attr *attr, __global const float *in,
                               uint count, __global float *out)
{
    uint i = get_global_id(0);
    if (i >= count) return;
    __global const float *x = in + 12u * i;
    float cs[3] = {x[0], x[1], x[2]}, f[3], fs[3];
    ts_v3 n = v3(0.0f, 0.0f, 1.0f), wo = v3(x[3], x[4], x[5]), wi = v3(x[6], x[7], x[8]), ws;
    float pdf = bsdf_eval(attr + i, cs, n, wo, wi, f);
    float pdfs = bsdf_sample(attr + i, cs, n, wo, x[9], x[10], x[11], &ws, fs);
    __global float *o = out + 12u * i;
    o[0] = f[0], o[1] = f[1], o[2] = f[2], o[3] = pdf;
    o[4] = ws.x, o[5] = ws.y, o[6] = ws.z, o[7] = 0.0f;
    o[8] = fs[0], o[9] = fs[1], o[10] = fs[2], o[11] = pdfs;
}
