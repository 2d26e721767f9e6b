/* test_bsdf.c — the materials of kernels/lib/bsdf.h (matte, plastic, metal) on the host, the
 * same code the shade kernel runs. For each material and several view angles:
 * - energy: the albedo E[f cos_i / pdf] over bsdf_sample's directions is at most 1 for a
 *   white surface (Kd Cs for matte exactly), metal's is tinted by Cs channel for channel,
 *   and every material's equals a Cook-Torrance quadrature written in the test;
 * - the pdf integrates to what the sampler delivers: over bins of the hemisphere, the
 *   fraction of bsdf_sample's directions in a bin matches the integral of bsdf_eval's pdf
 *   over it (estimated by uniform directions), and at normal incidence the whole integral
 *   is 1 for the cosine and the smooth GGX lobes (rough ones lose samples below the
 *   horizon, which the bins count);
 * - bsdf_sample's pdf and f are bsdf_eval's for the direction it returns.
 * Glass, a pair of delta lobes, is checked against Fresnel's and Snell's closed forms; the
 * translucent sheet (diffuse transmission) by its two albedos, its share of samples sent
 * through and its reciprocity.
 * Tolerances are 5 standard errors of the estimates. Host only: never skips. */
#include "lib/bsdf.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

#define N_SAMPLES 200000
#define N_UNIFORM 400000
#define THETA_BINS 6
#define PHI_BINS 4

static ts_patch_attr material(uint32_t kind, float kd, float ks, float roughness)
{
    ts_patch_attr a;
    memset(&a, 0, sizeof a);
    a.material = kind;
    a.kd = kd;
    a.ks = ks;
    a.roughness = roughness;
    a.emitter = TS_INVALID;
    return a;
}

/* The bin of direction w (local frame, z = the normal); -1 below the horizon. */
static int bin_of(ts_v3 w)
{
    if (w.z <= 0.0f) return -1;
    int t = (int)(acosf(fminf(w.z, 1.0f)) / (0.5f * TS_PI) * THETA_BINS);
    float phi = atan2f(w.y, w.x) + TS_PI;
    int p = (int)(phi / (2.0f * TS_PI) * PHI_BINS);
    t = t < THETA_BINS ? t : THETA_BINS - 1;
    p = p < PHI_BINS ? p : PHI_BINS - 1;
    return t * PHI_BINS + p;
}

typedef struct check {
    const char *name;
    ts_patch_attr a;
    float cs[3];
} check;

/* Energy and sampling for one material seen at cos(theta_o) = co. */
static void check_material(const check *c, float co)
{
    ts_v3 n = v3(0, 0, 1), wo = v3(sqrtf(1.0f - co * co), 0.0f, co);
    uint32_t seed = 12345u;
    double albedo[3] = {0, 0, 0}, sq[3] = {0, 0, 0}, freq[THETA_BINS * PHI_BINS] = {0};
    for (int k = 0; k < N_SAMPLES; k++) {
        float u0 = test_uniform(&seed, 0, 1), u1 = test_uniform(&seed, 0, 1),
              u2 = test_uniform(&seed, 0, 1);
        ts_v3 wi;
        float f[3], fe[3];
        float pdf = bsdf_sample(&c->a, c->cs, n, wo, u0, u1, u2, &wi, f);
        if (!(pdf > 0.0f)) continue;
        float pe = bsdf_eval(&c->a, c->cs, n, wo, wi, fe);
        assert_true(pe == pdf && fe[0] == f[0] && fe[1] == f[1] && fe[2] == f[2]);
        for (int ch = 0; ch < 3; ch++) {
            double w = f[ch] * v3_dot(n, wi) / pdf;
            albedo[ch] += w, sq[ch] += w * w;
        }
        int b = bin_of(wi);
        if (b >= 0) freq[b] += 1.0;
    }
    /* The albedo the model gives, by quadrature in the test: matte Kd Cs; plastic
     * Kd Cs + Ks A (its lobe is untinted); metal Ks Cs A, with A the GGX lobe's albedo. */
    double lobe = c->a.material == TS_MAT_MATTE ? 0.0 : test_ggx_albedo(co, c->a.roughness);
    for (int ch = 0; ch < 3; ch++) {
        double mean = albedo[ch] / N_SAMPLES, var = sq[ch] / N_SAMPLES - mean * mean;
        double tol = 5.0 * sqrt(fmax(var, 0.0) / N_SAMPLES) + 1e-6;
        double want = c->a.material == TS_MAT_METAL     ? c->a.ks * c->cs[ch] * lobe
                      : c->a.material == TS_MAT_PLASTIC ? c->a.kd * c->cs[ch] + c->a.ks * lobe
                                                        : c->a.kd * c->cs[ch];
        if (fabs(mean - want) > tol + 1e-3)
            fail_msg("%s at cos %g: albedo %g in channel %d, Cook-Torrance quadrature %g (tol %g)",
                     c->name, co, mean, ch, want, tol + 1e-3);
        if (mean > c->cs[ch] + tol)
            fail_msg("%s at cos %g: albedo %g in channel %d exceeds Cs %g (tol %g)", c->name, co,
                     mean, ch, c->cs[ch], tol);
        if (c->a.material == TS_MAT_MATTE && fabs(mean - c->a.kd * c->cs[ch]) > tol)
            fail_msg("%s: albedo %g, want Kd Cs = %g", c->name, mean, c->a.kd * c->cs[ch]);
        if (c->a.material == TS_MAT_METAL && ch > 0 &&
            fabs(albedo[ch] / albedo[0] - c->cs[ch] / c->cs[0]) > 1e-4)
            fail_msg("%s: channel %d / channel 0 = %g, want Cs ratio %g", c->name, ch,
                     albedo[ch] / albedo[0], c->cs[ch] / c->cs[0]);
    }
    /* The pdf's integral over each bin, by uniform directions on the hemisphere (density
     * 1 / 2 pi), against the fraction of samples that fell there. */
    double mass[THETA_BINS * PHI_BINS] = {0}, msq[THETA_BINS * PHI_BINS] = {0}, total = 0,
                             total_sq = 0;
    for (int k = 0; k < N_UNIFORM; k++) {
        float z = test_uniform(&seed, 0, 1), phi = test_uniform(&seed, 0, 2.0f * TS_PI);
        float r = sqrtf(fmaxf(0.0f, 1.0f - z * z));
        ts_v3 wi = v3(r * cosf(phi), r * sinf(phi), z);
        float f[3];
        double v = 2.0 * TS_PI * bsdf_eval(&c->a, c->cs, n, wo, wi, f);
        int b = bin_of(wi);
        if (b < 0) continue;
        mass[b] += v, msq[b] += v * v, total += v, total_sq += v * v;
    }
    for (int b = 0; b < THETA_BINS * PHI_BINS; b++) {
        double m = mass[b] / N_UNIFORM, vm = msq[b] / N_UNIFORM - m * m;
        double fq = freq[b] / N_SAMPLES;
        double tol =
            5.0 * (sqrt(fmax(vm, 0.0) / N_UNIFORM) + sqrt(fq * (1 - fq) / N_SAMPLES)) + 2e-4;
        if (fabs(m - fq) > tol)
            fail_msg("%s at cos %g, bin %d: pdf integral %g, sampled fraction %g (tol %g)", c->name,
                     co, b, m, fq, tol);
    }
    /* Rough GGX lobes send part of their samples below the horizon (pdf 0 there, counted
     * by the bins above); a smooth one, and the cosine lobe, stay above at normal
     * incidence, so their pdf integrates to 1 over the hemisphere. */
    double mean = total / N_UNIFORM;
    double tol = 5.0 * sqrt(fmax(total_sq / N_UNIFORM - mean * mean, 0.0) / N_UNIFORM) + 0.01;
    if (co == 1.0f && c->a.roughness <= 0.1f && fabs(mean - 1.0) > tol)
        fail_msg("%s: the pdf integrates to %g over the hemisphere at normal incidence (tol %g)",
                 c->name, mean, tol);
}

static void test_materials(void **state)
{
    (void)state;
    const check checks[] = {
        {"matte", material(TS_MAT_MATTE, 0.8f, 0.0f, 0.1f), {1, 0.5f, 0.25f}},
        {"plastic", material(TS_MAT_PLASTIC, 0.5f, 0.5f, 0.1f), {1, 1, 1}},
        {"rough plastic", material(TS_MAT_PLASTIC, 0.3f, 0.7f, 0.6f), {1, 1, 1}},
        {"metal", material(TS_MAT_METAL, 0.0f, 1.0f, 0.1f), {1, 0.5f, 0.25f}},
        {"rough metal", material(TS_MAT_METAL, 0.0f, 1.0f, 0.7f), {1, 1, 1}},
        {"smooth metal", material(TS_MAT_METAL, 0.0f, 0.9f, 0.02f), {0.9f, 0.8f, 0.3f}},
        /* Metal ignores Kd: a stray one must not add a diffuse part. */
        {"metal with Kd", material(TS_MAT_METAL, 0.7f, 1.0f, 0.3f), {1, 1, 1}},
    };
    const float cos_o[] = {1.0f, 0.7f, 0.3f, 0.1f};
    for (size_t k = 0; k < sizeof checks / sizeof checks[0]; k++)
        for (size_t j = 0; j < sizeof cos_o / sizeof cos_o[0]; j++)
            check_material(&checks[k], cos_o[j]);
}

/* Metal without Kd has no diffuse part: below the specular lobe (wi far from the mirror
 * direction) f vanishes with D, unlike plastic's Kd Cs / pi. */
static void test_metal_has_no_diffuse(void **state)
{
    (void)state;
    ts_patch_attr m = material(TS_MAT_METAL, 0.7f, 1.0f, 0.05f);
    ts_patch_attr p = material(TS_MAT_PLASTIC, 0.5f, 0.5f, 0.05f);
    const float cs[3] = {1, 1, 1};
    ts_v3 n = v3(0, 0, 1), wo = v3(0, 0, 1), wi = v3_normalize(v3(1, 0, 0.2f));
    float f[3];
    float pdf = bsdf_eval(&m, cs, n, wo, wi, f);
    assert_true(f[0] < 0.01f && pdf < 0.05f);
    bsdf_eval(&p, cs, n, wo, wi, f);
    assert_true(fabsf(f[0] - 0.5f / TS_PI) < 0.01f);
}

/* Glass (TS_MAT_GLASS): fresnel_dielectric against the closed forms, glass_sample's two
 * lobes against the reflection law and Snell's, the lobe chosen with probability F, the
 * weights 1 and Cs (eta_o / eta_i)^2, and bsdf_eval 0 (delta lobes). */
static void test_glass(void **state)
{
    (void)state;
    float ct;
    /* normal incidence: ((n - 1) / (n + 1))^2 from either side */
    assert_true(fabsf(fresnel_dielectric(1.0f, 1.0f / 1.5f, &ct) - 0.04f) < 1e-6f && ct == 1.0f);
    assert_true(fabsf(fresnel_dielectric(1.0f, 1.5f, &ct) - 0.04f) < 1e-6f);
    /* Brewster's angle from air, tan = 1.5: the p part vanishes, F = rs^2 / 2 */
    double tb = atan(1.5), ci = cos(tb), st = sin(tb) / 1.5, c2 = sqrt(1 - st * st);
    double rs = (ci / 1.5 - c2) / (ci / 1.5 + c2);
    assert_true(fabs(fresnel_dielectric((float)ci, 1.0f / 1.5f, &ct) - 0.5 * rs * rs) < 1e-6);
    assert_true(fabs(ct - c2) < 1e-6);
    /* past the critical angle from inside (sin > 1 / 1.5): total internal reflection */
    assert_true(fresnel_dielectric(cosf(asinf(0.7f)), 1.5f, &ct) == 1.0f && ct == 0.0f);
    /* the same interface seen from the other side: F(o -> t) = F(t -> o) */
    for (double c = 0.05; c < 1.0; c += 0.1) {
        float F1 = fresnel_dielectric((float)c, 1.0f / 1.5f, &ct), ct2;
        float F2 = fresnel_dielectric(ct, 1.5f, &ct2);
        assert_true(fabsf(F1 - F2) < 1e-5f && fabsf(ct2 - (float)c) < 1e-5f);
    }
    ts_patch_attr a = material(TS_MAT_GLASS, 0.0f, 0.0f, 0.01f); /* smooth: TS_GLASS_SMOOTH */
    a.ior = 1.5f;
    const float cs[3] = {0.9f, 0.8f, 0.7f};
    ts_v3 n = v3(0, 0, 1), wi, got;
    float f[3], w[3];
    assert_true(bsdf_eval(&a, cs, n, v3(0, 0.6f, 0.8f), v3(0, -0.6f, 0.8f), f) == 0.0f);
    assert_true(f[0] == 0.0f && f[1] == 0.0f && f[2] == 0.0f);
    for (int inside = 0; inside < 2; ++inside)
        for (double th = 0.1; th < 1.5; th += 0.35) {
            ts_v3 wo = v3((float)sin(th), 0, (float)cos(th));
            float eta = inside ? 1.5f : 1.0f / 1.5f;
            float F = fresnel_dielectric(wo.z, eta, &ct);
            int reflected = 0, total = 1000;
            for (int k = 0; k < total; ++k) {
                int through =
                    glass_sample(&a, cs, n, wo, inside, (k + 0.5f) / total, 0.3f, 0.7f, &got, w);
                if (!through) {
                    ++reflected; /* the mirror direction, weight 1 */
                    assert_true(fabsf(got.x + wo.x) < 1e-6f && fabsf(got.z - wo.z) < 1e-6f);
                    assert_true(w[0] == 1.0f && w[1] == 1.0f && w[2] == 1.0f);
                    continue;
                }
                /* Snell: eta sin_o = sin_t, on the far side, in the plane of incidence */
                assert_true(got.z < 0.0f && fabsf(got.y) < 1e-6f);
                assert_true(fabsf(eta * wo.x + got.x) < 1e-5f);
                assert_true(fabsf(v3_dot(got, got) - 1.0f) < 1e-5f);
                for (int c = 0; c < 3; ++c)
                    assert_true(fabsf(w[c] - cs[c] * eta * eta) < 1e-6f);
            }
            /* the lobe chosen with probability F (stratified u0: to 1 / total) */
            assert_true(fabs((double)reflected / total - F) <= 1.0 / total + 1e-6);
            wi = got;
        }
    (void)wi;
}

/* Rough glass (Walter et al. 2007): every sampled weight equals f |cos| / pdf from the paper's
 * BSDF and pdf evaluated here for the direction drawn (eqs. 20-21, 24, 38-40; h from wo and
 * wi), the lobe's probability F or 1 - F included; reflections stay above the surface,
 * refractions go below; the mean weight (importance, without the (eta_o / eta_i)^2 of
 * radiance) is at most 1 and near 1 when smooth; and at the smallest rough alpha the
 * directions and weights are the smooth glass's. */
static double walter_weight(double alpha, double eta, ts_v3 n, ts_v3 wo, ts_v3 wi, int through)
{
    double on = v3_dot(wo, n), in = v3_dot(wi, n);
    ts_v3 h = through ? v3_normalize(v3_scale(v3_add(v3_scale(wo, (float)eta), wi), -1.0f))
                      : v3_normalize(v3_add(wo, wi));
    if (v3_dot(h, n) < 0.0f) h = v3_scale(h, -1.0f);
    double hn = v3_dot(h, n), oh = v3_dot(wo, h), ih = v3_dot(wi, h), ct;
    double a2 = alpha * alpha, d = hn * hn * (a2 - 1.0) + 1.0, D = a2 / (M_PI * d * d);
    double g1o = 2.0 / (1.0 + sqrt(1.0 + a2 * (1.0 - on * on) / (on * on)));
    double g1i = 2.0 / (1.0 + sqrt(1.0 + a2 * (1.0 - in * in) / (in * in)));
    float ctf;
    double F = fresnel_dielectric((float)oh, (float)eta, &ctf);
    (void)ct;
    if (!through) { /* f_r = F D G / (4 |o.n| |i.n|), pdf = F D |h.n| / (4 |i.h|) */
        double f = F * D * g1o * g1i / (4.0 * fabs(on) * fabs(in));
        double pdf = F * D * hn / (4.0 * fabs(ih));
        return f * fabs(in) / pdf;
    }
    /* eta_o / eta_i = eta: indices 1 and 1 / eta up to a common factor */
    double ni = 1.0, nt = 1.0 / eta, den = ni * oh + nt * ih;
    double f = fabs(oh) * fabs(ih) / (fabs(on) * fabs(in)) * nt * nt * (1.0 - F) * D * g1o * g1i /
               (den * den);
    double pdf = (1.0 - F) * D * hn * fabs(ih) * nt * nt / (den * den);
    return f * fabs(in) / pdf;
}

static void test_rough_glass(void **state)
{
    (void)state;
    const float cs[3] = {1, 1, 1};
    ts_v3 n = v3(0, 0, 1);
    const float alphas[3] = {0.02f, 0.1f, 0.5f};
    const double floor_mean[3] = {0.99, 0.94, 0.6};
    int checked = 0;
    for (int ai = 0; ai < 3; ++ai)
        for (int inside = 0; inside < 2; ++inside)
            for (double th = 0.1; th < 1.2; th += 0.35) {
                float eta = inside ? 1.5f : 1.0f / 1.5f;
                ts_v3 wo = v3((float)sin(th), 0, (float)cos(th)), wi;
                double sum = 0.0;
                const int N = 24;
                for (int i = 0; i < N; ++i)
                    for (int j = 0; j < N; ++j)
                        for (int k = 0; k < N; ++k) {
                            float w[3];
                            int t = rough_glass_sample(alphas[ai], eta, cs, n, wo, (i + 0.5f) / N,
                                                       (j + 0.5f) / N, (k + 0.5f) / N, &wi, w);
                            double imp = t ? w[0] / (eta * eta) : w[0];
                            assert_true(imp >= 0.0 &&
                                        imp <=
                                            10.0); /* finite; above 1 at grazing wo (Walter §5.3) */
                            sum += imp;
                            if (w[0] == 0.0f) continue;
                            assert_true(t ? wi.z < 0.0f : wi.z > 0.0f);
                            double want = walter_weight(alphas[ai], eta, n, wo, wi, t);
                            if (!(fabs(imp - want) <= 2e-3 * want + 1e-6))
                                fail_msg("alpha %g inside %d th %g: weight %g, Walter's %g",
                                         alphas[ai], inside, th, imp, want);
                            ++checked;
                        }
                double mean = sum / (N * N * N);
                if (!(mean <= 1.001 && mean >= floor_mean[ai]))
                    fail_msg("alpha %g inside %d th %g: mean weight %g", alphas[ai], inside, th,
                             mean);
            }
    assert_true(checked > 50000);
    /* The smallest rough alpha: within a degree of smooth glass's directions and weights. */
    ts_patch_attr smooth = material(TS_MAT_GLASS, 0.0f, 0.0f, 0.01f);
    ts_patch_attr rough = material(TS_MAT_GLASS, 0.0f, 0.0f, 0.0102f);
    smooth.ior = rough.ior = 1.5f;
    ts_v3 wo = v3_normalize(v3(0.5f, 0.2f, 0.8f)), a, b;
    float wa[3], wb[3];
    for (int k = 0; k < 100; ++k) {
        float u0 = (k + 0.5f) / 100;
        int ta = glass_sample(&smooth, cs, n, wo, 0, u0, 0.5f, 0.25f, &a, wa);
        int tb = glass_sample(&rough, cs, n, wo, 0, u0, 0.5f, 0.25f, &b, wb);
        if (ta != tb) continue; /* F moved across u0 */
        assert_true(v3_dot(a, b) > cosf(1.0f * TS_PI / 180.0f));
        assert_true(fabsf(wa[0] - wb[0]) < 0.02f * wa[0]);
    }
}

/* TS_MAT_TRANSLUCENT, a thin Lambertian sheet: for several Kd, Ks and view angles, bsdf_sample's
 * pdf and f are bsdf_eval's; the reflected albedo (samples on wo's side) is Kd Cs and the
 * transmitted one (the far side) Ks Cs, so a white sheet of Kd + Ks = 1 loses nothing (the
 * white furnace); the share of samples sent through is Ks / (Kd + Ks); the pdf integrates to 1
 * over the sphere; f is reciprocal (the same through the sheet either way); a sheet that
 * scatters nothing has pdf 0. */
static void test_translucent(void **state)
{
    (void)state;
    const float kds[][2] = {{0.5f, 0.5f}, {0.8f, 0.2f}, {0.0f, 0.7f}, {0.3f, 0.0f}};
    const float cs[3] = {1.0f, 0.5f, 0.25f}, cos_o[] = {1.0f, 0.5f, 0.1f};
    ts_v3 n = v3(0, 0, 1);
    uint32_t seed = 777u;
    for (size_t k = 0; k < sizeof kds / sizeof kds[0]; k++) {
        ts_patch_attr a = material(TS_MAT_TRANSLUCENT, kds[k][0], kds[k][1], 0.1f);
        for (size_t j = 0; j < sizeof cos_o / sizeof cos_o[0]; j++) {
            float co = cos_o[j];
            ts_v3 wo = v3(sqrtf(1.0f - co * co), 0.0f, co);
            double sum[2][3] = {{0}}, sq[2][3] = {{0}}, through = 0;
            for (int i = 0; i < N_SAMPLES; i++) {
                float u0 = test_uniform(&seed, 0, 1), u1 = test_uniform(&seed, 0, 1),
                      u2 = test_uniform(&seed, 0, 1), f[3], fe[3];
                ts_v3 wi;
                float pdf = bsdf_sample(&a, cs, n, wo, u0, u1, u2, &wi, f);
                assert_true(pdf > 0.0f);
                float pe = bsdf_eval(&a, cs, n, wo, wi, fe);
                assert_true(pe == pdf && fe[0] == f[0] && fe[1] == f[1] && fe[2] == f[2]);
                int side = wi.z < 0.0f;
                through += side;
                for (int ch = 0; ch < 3; ch++) {
                    double w = f[ch] * fabsf(wi.z) / pdf;
                    sum[side][ch] += w, sq[side][ch] += w * w;
                }
                /* reciprocity: wi -> wo through the sheet, seen from wi's side */
                float fr[3];
                bsdf_eval(&a, cs, side ? v3(0, 0, -1) : n, wi, wo, fr);
                assert_true(fr[0] == f[0] && fr[1] == f[1] && fr[2] == f[2]);
            }
            for (int side = 0; side < 2; side++)
                for (int ch = 0; ch < 3; ch++) {
                    double mean = sum[side][ch] / N_SAMPLES,
                           var = sq[side][ch] / N_SAMPLES - mean * mean;
                    double want = (side ? a.ks : a.kd) * cs[ch];
                    double tol = 5.0 * sqrt(fmax(var, 0.0) / N_SAMPLES) + 1e-6;
                    if (fabs(mean - want) > tol)
                        fail_msg("Kd %g Ks %g at cos %g: %s albedo %g in channel %d, want %g", a.kd,
                                 a.ks, co, side ? "transmitted" : "reflected", mean, ch, want);
                }
            double share = through / N_SAMPLES, want = a.ks / (a.kd + a.ks);
            if (fabs(share - want) > 5.0 * sqrt(want * (1 - want) / N_SAMPLES) + 1e-9)
                fail_msg("Kd %g Ks %g: %g of the samples go through, want %g", a.kd, a.ks, share,
                         want);
            /* the pdf over the sphere, by uniform directions (density 1 / 4 pi) */
            double total = 0;
            for (int i = 0; i < N_UNIFORM; i++) {
                float z = test_uniform(&seed, -1, 1), phi = test_uniform(&seed, 0, 2.0f * TS_PI);
                float r = sqrtf(fmaxf(0.0f, 1.0f - z * z)), f[3];
                total +=
                    4.0 * TS_PI * bsdf_eval(&a, cs, n, wo, v3(r * cosf(phi), r * sinf(phi), z), f);
            }
            if (fabs(total / N_UNIFORM - 1.0) > 0.01)
                fail_msg("Kd %g Ks %g: the pdf integrates to %g over the sphere", a.kd, a.ks,
                         total / N_UNIFORM);
        }
    }
    ts_patch_attr none = material(TS_MAT_TRANSLUCENT, 0.0f, 0.0f, 0.1f);
    ts_v3 wi;
    float f[3];
    assert_true(bsdf_sample(&none, cs, n, n, 0.5f, 0.5f, 0.5f, &wi, f) == 0.0f);
    assert_true(f[0] == 0.0f && f[1] == 0.0f && f[2] == 0.0f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_materials),   cmocka_unit_test(test_metal_has_no_diffuse),
        cmocka_unit_test(test_glass),       cmocka_unit_test(test_rough_glass),
        cmocka_unit_test(test_translucent),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
