/* shade.cl — stage `shade` (Hanika §3.5, §4): one path-tracing step for every path that
 * traced a ray in this wave. Path i owns two ray slots: i for its BSDF ray and
 * wave_size + i for its shadow ray; path state mis.z says which of the two it traced.
 * Reads:  the wave's paths (paths[0..path_count)), their rays (dir, hit, flags), path state
 *         (throughput, mis, pending), patch data, lights, emitters, textures (colour at the
 *         hit's st, displacement for the normal; every tile resident).
 * Writes: radiance (accumulated per path: one work-item per path, so no races), aov
 *         (normal, Z) and albedo at the eye hit, the path's next rays into its two slots,
 *         path state, alive[k]: bit 0 a BSDF ray is next, bit 1 a shadow ray.
 * A shadow ray that reached its light unoccluded adds its light sample. A camera or BSDF
 * ray adds what it found (sky or sun on a miss, emission on a hit), weighted for MIS.
 * Then, below the depth: next-event estimation (a light sample and its shadow ray) and a
 * BSDF sample to continue, combined by the balance heuristic (Veach 1995): the light
 * sample weighs p_l / (p_l + p_b), emission found by the BSDF ray p_b / (p_b + p_l).
 * From the second bounce on, Russian roulette ends paths with probability
 * 1 - min(1, max(throughput)). --sampling light or bsdf keeps one strategy at weight 1.
 * Random numbers: rng_uniform(pixel, sample, bounce + 1, dimension). */
#include "lib/shared_types.h"
#include "lib/bsdf.h"
#include "lib/lights.h"
#include "lib/patch.h"
#include "lib/rng.h"

inline void add_rgb(__global ts_vec4 *acc, const float t[3], const float l[3], float w)
{
    ts_vec4 a = *acc;
    a.x += t[0] * l[0] * w, a.y += t[1] * l[1] * w, a.z += t[2] * l[2] * w;
    *acc = a;
}

/* Writes the path's next ray: from p, offset by eps along n, towards dir, up to tmax. */
inline void emit_ray(uint i, ts_v3 p, ts_v3 n, float eps, ts_v3 dir, float time, float tmax,
                     uint flags, __global ts_vec4 *org, __global ts_vec4 *dirs,
                     __global ts_hit *hit, __global uint *entry, __global uint *ray_flags)
{
    org[i] = (ts_vec4){p.x + eps * n.x, p.y + eps * n.y, p.z + eps * n.z, 0.0f};
    dirs[i] = (ts_vec4){dir.x, dir.y, dir.z, time};
    hit[i] = (ts_hit){tmax, 0.0f, 0.0f, TS_INVALID, TS_INVALID};
    entry[i] = TS_ENTRY_START;
    ray_flags[i] = flags;
}

/* MIS weight of emission found by a BSDF ray (mis = (p_b, mode)): mode 0 = weight 1 (eye
 * rays, --sampling bsdf), 1 = balance heuristic against light pdf pl, 2 = 0 (--sampling
 * light: light sampling alone accounts for it). */
inline float emission_weight(ts_vec4 mis, float pl)
{
    return mis.y == 0.0f ? 1.0f : mis.y == 2.0f ? 0.0f : mis.x / (mis.x + pl);
}

__kernel void shade_path(ts_shade_params sp, uint first_sample, uint pixel_count, uint wave_size,
                         __global const uint *paths, uint path_count, __global ts_vec4 *org,
                         __global ts_vec4 *dir, __global ts_hit *hit, __global uint *entry,
                         __global uint *ray_flags, __global const uint *pixel,
                         __global ts_vec4 *throughput, __global ts_vec4 *mis,
                         __global ts_vec4 *pending, __global ts_vec4 *radiance,
                         __global ts_vec4 *aov, __global ts_vec4 *albedo,
                         __global const ts_vec4 *cp, __global const ts_vec4 *corner_n,
                         __global const ts_patch_attr *attr, __global const ts_xform *xform,
                         __global const ts_light *lights, __global const ts_emitter *emitters,
                         __global const ts_vec4 *env_texels, __global const float *env_marginal,
                         __global const float *env_conditional, __global const ts_vec4 *flatness,
                         __global const ts_texture *textures, __global const uint *tex_pages,
                         __global const ts_vec4 *tex_pool, __global uint *alive)
{
    uint k = get_global_id(0);
    if (k >= path_count) return;
    uint i = paths[k], traced = (uint)mis[i].z;
    ts_env env = {env_texels, env_marginal, env_conditional};
    ts_tex_ctx tex = {textures, tex_pages, tex_pool};
    alive[k] = 0u;
    if ((traced & 2u) && hit[wave_size + i].patch == TS_INVALID) { /* the light was visible */
        ts_vec4 pe = pending[i], r = radiance[i];
        radiance[i] = (ts_vec4){r.x + pe.x, r.y + pe.y, r.z + pe.z, r.w};
    }
    if (!(traced & 1u)) return;
    ts_hit h = hit[i];
    ts_vec4 d4 = dir[i], o4 = org[i], t4 = throughput[i], m4 = mis[i];
    ts_v3 d = v3(d4.x, d4.y, d4.z);
    float tp[3] = {t4.x, t4.y, t4.z}, le[3];
    uint pix = pixel[i], sample = (first_sample + i) / pixel_count, b = sp.bounce;
    if (h.patch == TS_INVALID) { /* sky and sun */
        float pl;
        light_escape(lights, sp.light_count, env, d, le, &pl);
        add_rgb(&radiance[i], tp, le, emission_weight(m4, pl));
        if (b == 0u)
            aov[i] = (ts_vec4){0.0f, 0.0f, 0.0f, INFINITY}, albedo[i] = (ts_vec4){0, 0, 0, 0};
        return;
    }
    __global const ts_patch_attr *a = attr + h.patch;
    __global const ts_vec4 *c = cp + (size_t)h.patch * 16u;
    ts_vec4 n4 = patch_shading_normal(c, corner_n + (size_t)h.patch * 4u, a, xform + a->xform, tex,
                                      h.u, h.v, TS_PRIM_LOD(h.prim));
    float cs[3];
    tex_surface_colour(a, tex, h.u, h.v, cs);
    ts_v3 n = v3(n4.x, n4.y, n4.z), wo = v3_scale(d, -1.0f);
    if (v3_dot(n, wo) < 0.0f) n = v3_scale(n, -1.0f);
    ts_v3 p = v3(o4.x + h.t * d.x, o4.y + h.t * d.y, o4.z + h.t * d.z);
    if (b == 0u) {
        aov[i] = (ts_vec4){n.x, n.y, n.z, h.t};
        albedo[i] = (ts_vec4){a->kd * cs[0], a->kd * cs[1], a->kd * cs[2], 0.0f};
    }
    if (a->le_r > 0.0f || a->le_g > 0.0f || a->le_b > 0.0f) {
        float e[3] = {a->le_r, a->le_g, a->le_b};
        float pl = light_pdf_area(lights, sp.light_count, emitters, cp, a->emitter, h.patch, h.u,
                                  h.v, d, h.t);
        add_rgb(&radiance[i], tp, e, emission_weight(m4, pl));
    }
    if (b >= sp.depth) return;
    /* Offset for the next rays: epsilon = l / 2^m, l the longest side of the patch's box
     * (Hanika §3.3); the flatness record's w holds l. */
    float eps = flatness[h.patch].w * ldexp(1.0f, -(int)TS_PRIM_LOD(h.prim)), f[3];
    uint out = 0u;
    if (sp.light_count > 0u && sp.sampling != TS_SAMPLING_BSDF) { /* next-event estimation */
        uint li = min((uint)(rng_uniform(pix, sample, b + 1u, 1u, sp.seed) * (float)sp.light_count),
                      sp.light_count - 1u);
        ts_light_sample ls = light_sample(lights, sp.light_count, li, env, emitters, cp, attr, p,
                                          rng_uniform(pix, sample, b + 1u, 2u, sp.seed),
                                          rng_uniform(pix, sample, b + 1u, 3u, sp.seed),
                                          rng_uniform(pix, sample, b + 1u, 4u, sp.seed));
        float pb = ls.pdf > 0.0f ? bsdf_eval(a, cs, n, wo, ls.dir, f) : 0.0f;
        float cosl = ls.pdf > 0.0f ? v3_dot(n, ls.dir) : 0.0f;
        if (cosl > 0.0f && (f[0] > 0.0f || f[1] > 0.0f || f[2] > 0.0f)) {
            float denom = ls.delta || sp.sampling == TS_SAMPLING_LIGHT ? ls.pdf : ls.pdf + pb;
            float s = cosl / denom;
            pending[i] = (ts_vec4){tp[0] * f[0] * ls.le[0] * s, tp[1] * f[1] * ls.le[1] * s,
                                   tp[2] * f[2] * ls.le[2] * s, 0.0f};
            /* A shadow ray stops short of an area light's point and ignores that patch. */
            float tmax = ls.dist < TS_NO_HIT ? ls.dist * (1.0f - 1e-4f) : TS_NO_HIT;
            uint target = ls.patch == TS_INVALID ? 0u : (ls.patch + 1u) << 1;
            emit_ray(wave_size + i, p, n, eps, ls.dir, d4.w, tmax, TS_RAY_SHADOW | target, org, dir,
                     hit, entry, ray_flags);
            out |= 2u;
        }
    }
    ts_v3 wi;
    float pb = bsdf_sample(a, cs, n, wo, rng_uniform(pix, sample, b + 1u, 5u, sp.seed),
                           rng_uniform(pix, sample, b + 1u, 6u, sp.seed),
                           rng_uniform(pix, sample, b + 1u, 7u, sp.seed), &wi, f);
    float cosi = v3_dot(n, wi);
    if (pb > 0.0f && cosi > 0.0f) {
        float s = cosi / pb;
        float nt[3] = {tp[0] * f[0] * s, tp[1] * f[1] * s, tp[2] * f[2] * s};
        float survive = b >= 1u ? fmin(1.0f, fmax(nt[0], fmax(nt[1], nt[2]))) : 1.0f;
        if (rng_uniform(pix, sample, b + 1u, 0u, sp.seed) < survive) {
            throughput[i] = (ts_vec4){nt[0] / survive, nt[1] / survive, nt[2] / survive, 0.0f};
            float mode = sp.light_count == 0u || sp.sampling == TS_SAMPLING_BSDF ? 0.0f
                         : sp.sampling == TS_SAMPLING_LIGHT                      ? 2.0f
                                                                                 : 1.0f;
            emit_ray(i, p, n, eps, wi, d4.w, TS_NO_HIT, 0u, org, dir, hit, entry, ray_flags);
            mis[i] = (ts_vec4){pb, mode, 0.0f, 0.0f};
            out |= 1u;
        }
    }
    ts_vec4 m = mis[i];
    mis[i] = (ts_vec4){m.x, m.y, (float)out, 0.0f};
    alive[k] = out;
}
