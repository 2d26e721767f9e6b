/* test_principled.c — TS_MAT_PRINCIPLED (kernels/lib/principled.h) on the host, the code the
 * shade kernel runs, and on the device through shade.cl's shade_bsdf_probe:
 * - the table: lib/principled_table.h's albedos E1, E2 against a quadrature written here at
 *   points between the table's, the raised interpolant above them (the energy bound rests on
 *   it), and its means against the interpolant integrated here;
 * - energy: over many parameter sets and view angles the albedo E[f cos_i / pdf] over
 *   bsdf_sample's directions is at most 1 per channel (white furnace), near 1 for a white
 *   dielectric, and for a metal (metallic 1) equals the quadrature's Cs E1 + (1 - Cs) E2;
 * - the estimator is unbiased: for rough lobes it equals the albedo integrated on a grid of
 *   directions from bsdf_eval's f alone;
 * - the pdf: over bins of the hemisphere the sampled fraction matches the integral of
 *   bsdf_eval's pdf, which integrates to at most 1; bsdf_sample's pdf and f are bsdf_eval's;
 * - reciprocity: f(wo, wi) = f(wi, wo);
 * - the kernel: bsdf_eval and bsdf_sample on the device agree with the host's.
 * Tolerances: 5 standard errors of the estimates; quadratures to 1e-3. */
#include "lib/bsdf.h"
#include "pipeline/pipeline.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

#define N_SAMPLES 40000
#define THETA_BINS 6
#define PHI_BINS 4

typedef struct pset {
    float metallic, specular, specular_tint, roughness, sheen, sheen_tint, clearcoat, gloss;
    float cs[3];
} pset;

/* The attribute of a principled material with roughness r (alpha r^2). */
static ts_patch_attr principled(const pset *p)
{
    ts_patch_attr a;
    memset(&a, 0, sizeof a);
    a.material = TS_MAT_PRINCIPLED;
    a.roughness = fmaxf(p->roughness * p->roughness, 0.01f);
    a.metallic = p->metallic, a.specular = p->specular, a.specular_tint = p->specular_tint;
    a.sheen = p->sheen, a.sheen_tint = p->sheen_tint;
    a.clearcoat = p->clearcoat, a.clearcoat_gloss = p->gloss;
    a.emitter = TS_INVALID;
    return a;
}

/* GGX albedo at cos_o = co, alpha, with Fresnel 1 (e[0]) and (1 - wo.h)^5 (e[1]): the
 * half-vector quadrature of test_support's test_ggx_albedo, in double. */
static void quad_albedo(double co, double alpha, double e[2])
{
    enum { NT = 1024, NP = 128 };
    const double so = sqrt(1.0 - co * co);
    e[0] = e[1] = 0.0;
    for (int i = 0; i < NT; i++) {
        double t = (i + 0.5) / NT, x = alpha * t / (1.0 - t);
        double th = atan(x), dth = alpha / ((1.0 - t) * (1.0 - t)) / (1.0 + x * x);
        double ch = cos(th), sh = sin(th), a2 = alpha * alpha, d = ch * ch * (a2 - 1.0) + 1.0;
        double D = a2 / (M_PI * d * d);
        for (int j = 0; j < NP; j++) {
            double ph = (j + 0.5) * M_PI / NP;
            double oh = so * sh * cos(ph) + co * ch, ci = 2.0 * oh * ch - co;
            if (oh <= 0.0 || ci <= 0.0) continue;
            double g1o = 2.0 / (1.0 + sqrt(1.0 + a2 * (1.0 - co * co) / (co * co)));
            double g1i = 2.0 / (1.0 + sqrt(1.0 + a2 * (1.0 - ci * ci) / (ci * ci)));
            double w = D * g1o * g1i * oh / co * sh * dth;
            e[0] += w, e[1] += w * pow(1.0 - oh, 5.0);
        }
    }
    e[0] *= (1.0 / NT) * (2.0 * M_PI / NP), e[1] *= (1.0 / NT) * (2.0 * M_PI / NP);
}

/* The table between its points: within 0.02 of the quadrature, and the raised interpolant
 * (1 - principled_unreflected) at least the albedo to 2e-3 (the bound); the means exact. */
static void test_table(void **state)
{
    (void)state;
    uint32_t seed = 7u;
    for (int k = 0; k < 30; k++) {
        float r = test_uniform(&seed, 0.1f, 1.0f), mu = test_uniform(&seed, 0.01f, 1.0f);
        double e[2];
        quad_albedo(mu, (double)r * r, e);
        for (int kind = 0; kind < 2; kind++) {
            double in = principled_table_e(kind, mu, r);
            if (fabs(in - e[kind]) > 0.02)
                fail_msg("E%d at mu %g r %g: table %g, quadrature %g", kind + 1, mu, r, in,
                         e[kind]);
        }
        for (float f0 = 0.0f; f0 <= 1.0f; f0 += 0.25f) {
            double want = f0 * e[0] + (1.0 - f0) * e[1];
            double raised = 1.0 - principled_unreflected(f0, mu, r);
            if (raised < want - 2e-3)
                fail_msg("F0 %g mu %g r %g: raised table %g below the albedo %g", f0, mu, r, raised,
                         want);
        }
    }
    for (float r = 0.1f; r <= 1.0f; r += 0.137f)
        for (int kind = 0; kind < 2; kind++) {
            double s = 0.0;
            const int M = 20000;
            for (int i = 0; i < M; i++) {
                double mu = (i + 0.5) / M;
                s += 2.0 * principled_table_e(kind, (float)mu, r) * mu / M;
            }
            assert_true(fabs(s - principled_table_avg(kind, r)) < 2e-4);
        }
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

/* The sampled albedo E[f cos / pdf] per channel at cos_o = co (mean[], its standard error
 * se[]), checking that bsdf_sample returns bsdf_eval's f and pdf, and the fraction of samples
 * per bin (freq[], may be NULL). */
static void sampled_albedo(const ts_patch_attr *a, const float cs[3], float co, double mean[3],
                           double se[3], double *freq)
{
    ts_v3 n = v3(0, 0, 1), wo = v3(sqrtf(1.0f - co * co), 0.0f, co);
    uint32_t seed = 12345u;
    double sum[3] = {0, 0, 0}, sq[3] = {0, 0, 0};
    for (int k = 0; k < N_SAMPLES; k++) {
        float u0 = test_uniform(&seed, 0, 1), u1 = test_uniform(&seed, 0, 1),
              u2 = test_uniform(&seed, 0, 1);
        ts_v3 wi;
        float f[3], fe[3];
        float pdf = bsdf_sample(a, cs, n, wo, u0, u1, u2, &wi, f);
        if (!(pdf > 0.0f)) continue;
        float pe = bsdf_eval(a, cs, n, wo, wi, fe);
        assert_true(pe == pdf && fe[0] == f[0] && fe[1] == f[1] && fe[2] == f[2]);
        for (int c = 0; c < 3; c++) {
            assert_true(f[c] >= 0.0f && isfinite(f[c]));
            double w = f[c] * v3_dot(n, wi) / pdf;
            sum[c] += w, sq[c] += w * w;
        }
        int b = bin_of(wi);
        if (freq && b >= 0) freq[b] += 1.0 / N_SAMPLES;
    }
    for (int c = 0; c < 3; c++) {
        mean[c] = sum[c] / N_SAMPLES;
        se[c] = sqrt(fmax(sq[c] / N_SAMPLES - mean[c] * mean[c], 0.0) / N_SAMPLES);
    }
}

static const float cos_o[] = {1.0f, 0.7f, 0.3f, 0.1f};
#define N_COS (sizeof cos_o / sizeof cos_o[0])

/* The white furnace over parameter sets drawn at random (and the corners of the cube): never
 * above 1 in any channel, for any base colour up to 1. */
static void test_furnace_bound(void **state)
{
    (void)state;
    uint32_t seed = 99u;
    for (int k = 0; k < 32; k++) {
        pset p;
        float *v = &p.metallic;
        for (int j = 0; j < 8; j++) /* corners for k < 16, random after */
            v[j] = k < 16 ? (float)((k >> (j % 4)) & 1) : test_uniform(&seed, 0.0f, 1.0f);
        if (k < 16) p.roughness = k & 8 ? 1.0f : 0.1f;
        if (k % 4 == 1) p.clearcoat *= 4.0f; /* PxrSurface's coats reach 4 */
        for (int c = 0; c < 3; c++)
            p.cs[c] = k % 3 == 0 ? 1.0f : test_uniform(&seed, 0.0f, 1.0f);
        ts_patch_attr a = principled(&p);
        for (size_t j = 0; j < N_COS; j++) {
            double mean[3], se[3];
            sampled_albedo(&a, p.cs, cos_o[j], mean, se, NULL);
            for (int c = 0; c < 3; c++)
                if (mean[c] > 1.0 + 5.0 * se[c] + 1e-3)
                    fail_msg(
                        "set %d (metallic %g specular %g rough %g sheen %g coat %g) at cos %g: "
                        "albedo %g in channel %d (se %g)",
                        k, p.metallic, p.specular, p.roughness, p.sheen, p.clearcoat, cos_o[j],
                        mean[c], c, se[c]);
        }
    }
}

/* A white dielectric without sheen or coat reflects nearly all it receives: its specular
 * lobe's albedo E plus the diffuse layer's (1 - m)(1 - E), E from the table; and a metal's
 * albedo is Cs E1 + (1 - Cs) E2 by the quadrature, channel by channel. */
static void test_furnace_values(void **state)
{
    (void)state;
    const float rough[] = {0.1f, 0.5f, 1.0f}, spec[] = {0.0f, 0.5f, 1.0f};
    for (int i = 0; i < 3; i++)
        for (int s = 0; s < 3; s++)
            for (size_t j = 0; j < N_COS; j++) {
                pset p = {.specular = spec[s], .roughness = rough[i], .cs = {1, 1, 1}};
                ts_patch_attr a = principled(&p);
                float co = cos_o[j], r = sqrtf(a.roughness), f0 = 0.08f * spec[s];
                double mean[3], se[3], e[2];
                sampled_albedo(&a, p.cs, co, mean, se, NULL);
                quad_albedo(co, a.roughness, e);
                double want = f0 * e[0] + (1.0 - f0) * e[1] + principled_unreflected(f0, co, r);
                if (fabs(mean[0] - want) > 5.0 * se[0] + 2e-3 || mean[0] < 0.97)
                    fail_msg("white dielectric rough %g specular %g cos %g: albedo %g, want %g",
                             rough[i], spec[s], co, mean[0], want);
                pset m = {.metallic = 1.0f, .roughness = rough[i], .cs = {0.95f, 0.6f, 0.2f}};
                a = principled(&m);
                sampled_albedo(&a, m.cs, co, mean, se, NULL);
                for (int c = 0; c < 3; c++) {
                    double w = m.cs[c] * e[0] + (1.0 - m.cs[c]) * e[1];
                    if (fabs(mean[c] - w) > 5.0 * se[c] + 1e-3)
                        fail_msg("metal rough %g cos %g channel %d: albedo %g, quadrature %g",
                                 rough[i], co, c, mean[c], w);
                }
            }
}

/* The parameter sets of the sampling checks: rough enough for a grid of directions. */
static const pset rough_sets[] = {
    {.specular = 0.5f, .roughness = 0.6f, .cs = {0.8f, 0.5f, 0.3f}},
    {.metallic = 0.5f,
     .specular = 1.0f,
     .specular_tint = 1.0f,
     .roughness = 0.5f,
     .cs = {0.9f, 0.7f, 0.2f}},
    {.specular = 0.5f,
     .roughness = 0.8f,
     .sheen = 1.0f,
     .sheen_tint = 0.5f,
     .cs = {0.2f, 0.6f, 0.9f}},
    {.specular = 0.5f,
     .roughness = 0.4f,
     .clearcoat = 1.0f,
     .gloss = 0.0f,
     .cs = {0.7f, 0.1f, 0.1f}},
    {.metallic = 1.0f, .roughness = 0.7f, .clearcoat = 1.0f, .gloss = 0.2f, .cs = {1, 0.8f, 0.6f}},
};

/* The estimator against the albedo integrated on a grid (cos_i, phi) of f cos_i, and the
 * sampled directions' bins against the pdf's integral over them (same grid); the pdf's whole
 * integral at most 1. */
static void test_sampling(void **state)
{
    (void)state;
    enum { NG = 256 };
    ts_v3 n = v3(0, 0, 1);
    for (size_t k = 0; k < sizeof rough_sets / sizeof rough_sets[0]; k++)
        for (size_t j = 0; j < N_COS; j++) {
            const pset *p = &rough_sets[k];
            ts_patch_attr a = principled(p);
            float co = cos_o[j];
            ts_v3 wo = v3(sqrtf(1.0f - co * co), 0.0f, co);
            double mean[3], se[3], freq[THETA_BINS * PHI_BINS] = {0};
            sampled_albedo(&a, p->cs, co, mean, se, freq);
            double grid[3] = {0, 0, 0}, mass[THETA_BINS * PHI_BINS] = {0}, total = 0.0;
            for (int i = 0; i < NG; i++)
                for (int g = 0; g < NG; g++) {
                    float z = (i + 0.5f) / NG, phi = (g + 0.5f) * 2.0f * TS_PI / NG;
                    float r = sqrtf(fmaxf(0.0f, 1.0f - z * z));
                    ts_v3 wi = v3(r * cosf(phi), r * sinf(phi), z);
                    float f[3];
                    double dw = 2.0 * M_PI / ((double)NG * NG); /* dz dphi */
                    double pdf = bsdf_eval(&a, p->cs, n, wo, wi, f);
                    for (int c = 0; c < 3; c++)
                        grid[c] += f[c] * z * dw;
                    mass[bin_of(wi)] += pdf * dw, total += pdf * dw;
                }
            for (int c = 0; c < 3; c++)
                if (fabs(mean[c] - grid[c]) > 5.0 * se[c] + 2e-3)
                    fail_msg("set %zu cos %g channel %d: sampled albedo %g, grid %g (se %g)", k, co,
                             c, mean[c], grid[c], se[c]);
            assert_true(total <= 1.0 + 2e-3);
            for (int b = 0; b < THETA_BINS * PHI_BINS; b++) {
                double tol = 5.0 * sqrt(freq[b] * (1 - freq[b]) / N_SAMPLES) + 2e-3;
                if (fabs(mass[b] - freq[b]) > tol)
                    fail_msg("set %zu cos %g bin %d: pdf integral %g, sampled fraction %g", k, co,
                             b, mass[b], freq[b]);
            }
        }
}

/* f(wo, wi) = f(wi, wo) for random directions and parameters (to float rounding). */
static void test_reciprocity(void **state)
{
    (void)state;
    uint32_t seed = 3u;
    ts_v3 n = v3(0, 0, 1);
    int nonzero = 0;
    for (int k = 0; k < 20000; k++) {
        pset p;
        float *v = &p.metallic;
        for (int j = 0; j < 8; j++)
            v[j] = test_uniform(&seed, 0.0f, 1.0f);
        for (int c = 0; c < 3; c++)
            p.cs[c] = test_uniform(&seed, 0.0f, 1.0f);
        ts_patch_attr a = principled(&p);
        ts_v3 w[2];
        for (int d = 0; d < 2; d++) {
            float z = test_uniform(&seed, 0.02f, 1.0f), phi = test_uniform(&seed, 0, 2.0f * TS_PI);
            float r = sqrtf(1.0f - z * z);
            w[d] = v3(r * cosf(phi), r * sinf(phi), z);
        }
        float f[3], g[3];
        bsdf_eval(&a, p.cs, n, w[0], w[1], f);
        bsdf_eval(&a, p.cs, n, w[1], w[0], g);
        for (int c = 0; c < 3; c++) {
            if (!(fabsf(f[c] - g[c]) <= 1e-5f * fmaxf(f[c], g[c]) + 1e-9f))
                fail_msg("f(wo, wi) %g, f(wi, wo) %g in channel %d", f[c], g[c], c);
            nonzero += f[c] > 0.0f;
        }
    }
    assert_true(nonzero > 50000);
}

/* bsdf_eval and bsdf_sample on the device (shade.cl shade_bsdf_probe) against the host's,
 * for random parameters and directions, a quarter of them translucent sheets: to float rounding
 * (the maths library's sqrt, cos and sin may round differently there). */
static void test_kernel_matches_host(void **state)
{
    (void)state;
    enum { N = 4096 };
    ts_device cl;
    test_open_device(&cl);
    ts_error err = {0};
    static ts_patch_attr attr[N];
    static float in[N * 12], out[N * 12], host[N * 12];
    uint32_t seed = 11u;
    for (int i = 0; i < N; i++) {
        pset p;
        float *v = &p.metallic;
        for (int j = 0; j < 8; j++)
            v[j] = test_uniform(&seed, 0.0f, 1.0f);
        for (int c = 0; c < 3; c++)
            p.cs[c] = test_uniform(&seed, 0.0f, 1.0f);
        attr[i] = principled(&p);
        if (i % 4 == 3) /* a translucent sheet (lib/bsdf.h translucent_eval), wi on both sides */
            attr[i].material = TS_MAT_TRANSLUCENT, attr[i].kd = 0.5f * v[0],
            attr[i].ks = 0.5f * v[1];
        float *x = in + 12 * i;
        memcpy(x, p.cs, sizeof p.cs);
        for (int d = 0; d < 2; d++) { /* wo, wi */
            float z = test_uniform(&seed, d ? -0.2f : 0.05f, 1.0f),
                  phi = test_uniform(&seed, 0, 6.28f);
            float r = sqrtf(1.0f - z * z);
            x[3 + 3 * d] = r * cosf(phi), x[4 + 3 * d] = r * sinf(phi), x[5 + 3 * d] = z;
        }
        for (int u = 0; u < 3; u++)
            x[9 + u] = test_uniform(&seed, 0.0f, 1.0f);
        /* the host: f, pdf of eval; wi, f, pdf of sample; out[12 i ...] likewise */
        float *h = host + 12 * i;
        ts_v3 n = v3(0, 0, 1), wo = v3(x[3], x[4], x[5]), wi = v3(x[6], x[7], x[8]), ws;
        h[3] = bsdf_eval(&attr[i], x, n, wo, wi, h);
        h[11] = bsdf_sample(&attr[i], x, n, wo, x[9], x[10], x[11], &ws, h + 8);
        h[4] = ws.x, h[5] = ws.y, h[6] = ws.z, h[7] = 0.0f;
    }
    cl_mem da =
        dev_buffer_create(&cl, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof attr, attr, &err);
    cl_mem di =
        dev_buffer_create(&cl, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof in, in, &err);
    cl_mem dout = dev_buffer_create(&cl, CL_MEM_WRITE_ONLY, sizeof out, NULL, &err);
    assert_true(da && di && dout);
    cl_kernel k = dev_kernel_create(&cl, "shade_bsdf_probe", &err);
    assert_non_null(k);
    cl_uint count = N;
    if (dev_set_args(k, &err, DEV_ARG(da), DEV_ARG(di), DEV_ARG(count), DEV_ARG(dout), (size_t)0) ||
        dev_launch(&cl, k, TS_STAGE_shade, N, TS_LOCAL_SIZE, &err) || dev_finish(&cl, NULL, &err))
        fail_msg("%s", err.msg);
    assert_int_equal(
        clEnqueueReadBuffer(cl.queue, dout, CL_TRUE, 0, sizeof out, out, 0, NULL, NULL),
        CL_SUCCESS);
    int sampled = 0;
    for (int i = 0; i < N; i++) {
        const float *d = out + 12 * i, *h = host + 12 * i;
        if (h[11] > 0.0f) sampled++;
        for (int j = 0; j < 12; j++) {
            /* a sample whose pdf is 0 on one side may land at 0 on the other: rounding */
            if ((j >= 8 || (j >= 4 && j < 7)) && (h[11] == 0.0f) != (d[11] == 0.0f)) continue;
            /* a sampled direction in a narrow lobe: f and pdf change fast with it */
            float tol = j >= 8 ? 2e-3f : 2e-4f;
            if (!(fabsf(d[j] - h[j]) <= tol * fmaxf(fabsf(h[j]), 1.0f)))
                fail_msg("item %d value %d: device %g, host %g", i, j, d[j], h[j]);
        }
    }
    assert_true(sampled > N / 2);
    clReleaseKernel(k);
    clReleaseMemObject(da), clReleaseMemObject(di), clReleaseMemObject(dout);
    dev_close(&cl);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_table),          cmocka_unit_test(test_furnace_bound),
        cmocka_unit_test(test_furnace_values), cmocka_unit_test(test_sampling),
        cmocka_unit_test(test_reciprocity),    cmocka_unit_test(test_kernel_matches_host),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
