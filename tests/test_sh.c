/* test_sh.c — the real spherical harmonics of kernels/lib/sh.h (the convention of the bake's
 * files, docs/bake.md). Host only; never skips. Asserts:
 *   - sh_eval equals the textbook definition sqrt(2) K_l^|m| P_l^|m|(cos theta) trig(|m| phi),
 *     computed here independently (associated Legendre recurrence, factorials), without the
 *     Condon-Shortley phase, at random directions;
 *   - orthonormality over the sphere (product Gauss-Legendre x trapezoid quadrature, exact
 *     for these polynomials);
 *   - the index l^2 + l + m and the named values (Y_00 = 1 / (2 sqrt(pi)), Y_11 along +x);
 *   - sh_cosine_lobe: the projection of max(0, n . w) is lobe(l) Y_lm(n) for random n. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include <cmocka.h>

#include "lib/sh.h"

/* Associated Legendre P_l^m(x), m >= 0, without the Condon-Shortley phase. */
static double legendre(int l, int m, double x)
{
    double pmm = 1.0, s = sqrt(fmax(0.0, 1.0 - x * x));
    for (int i = 1; i <= m; ++i)
        pmm *= (2.0 * i - 1.0) * s;
    if (l == m) return pmm;
    double pm1 = x * (2.0 * m + 1.0) * pmm;
    if (l == m + 1) return pm1;
    double pll = 0.0;
    for (int ll = m + 2; ll <= l; ++ll) {
        pll = ((2.0 * ll - 1.0) * x * pm1 - (ll + m - 1.0) * pmm) / (ll - m);
        pmm = pm1;
        pm1 = pll;
    }
    return pll;
}

static double factorial(int n)
{
    double f = 1.0;
    for (int i = 2; i <= n; ++i)
        f *= i;
    return f;
}

/* The real SH Y_lm at (theta, phi) from the definition. */
static double sh_reference(int l, int m, double theta, double phi)
{
    int am = abs(m);
    double k = sqrt((2.0 * l + 1.0) / (4.0 * M_PI) * factorial(l - am) / factorial(l + am));
    double p = legendre(l, am, cos(theta));
    if (m == 0) return k * p;
    return sqrt(2.0) * k * p * (m > 0 ? cos(am * phi) : sin(am * phi));
}

static uint32_t rng = 12345u;
static double uniform(void)
{
    rng = rng * 1664525u + 1013904223u;
    return (rng >> 8) * (1.0 / 16777216.0);
}

static void test_matches_the_definition(void **state)
{
    for (int k = 0; k < 2000; ++k) {
        double theta = acos(1.0 - 2.0 * uniform()), phi = 2.0 * M_PI * uniform();
        float x = (float)(sin(theta) * cos(phi)), y = (float)(sin(theta) * sin(phi)),
              z = (float)cos(theta);
        float out[TS_SH_MAX_COEFFS];
        sh_eval(x, y, z, TS_SH_MAX_BANDS, out);
        for (int l = 0; l < 4; ++l)
            for (int m = -l; m <= l; ++m) {
                double want = sh_reference(l, m, theta, phi);
                if (fabs(out[TS_SH_INDEX(l, m)] - want) > 2e-6)
                    fail_msg("Y_%d,%d at (%g, %g): %.9g, definition %.9g", l, m, theta, phi,
                             out[TS_SH_INDEX(l, m)], want);
            }
    }
}

static void test_named_values(void **state)
{
    float out[TS_SH_MAX_COEFFS];
    sh_eval(1.0f, 0.0f, 0.0f, 4u, out);
    assert_float_equal(out[0], 1.0 / (2.0 * sqrt(M_PI)), 1e-7);
    assert_float_equal(out[TS_SH_INDEX(1, 1)], sqrt(3.0 / (4.0 * M_PI)), 1e-7); /* +x */
    assert_float_equal(out[TS_SH_INDEX(1, -1)], 0.0, 1e-7);
    assert_float_equal(out[TS_SH_INDEX(1, 0)], 0.0, 1e-7);
    sh_eval(0.0f, 0.0f, 1.0f, 4u, out);
    assert_float_equal(out[TS_SH_INDEX(1, 0)], sqrt(3.0 / (4.0 * M_PI)), 1e-7); /* +z */
    assert_float_equal(out[TS_SH_INDEX(2, 0)], sqrt(5.0 / (4.0 * M_PI)), 1e-6);
    assert_float_equal(out[TS_SH_INDEX(3, 0)], sqrt(7.0 / (4.0 * M_PI)), 1e-6);
    sh_eval(0.0f, 1.0f, 0.0f, 4u, out);
    assert_float_equal(out[TS_SH_INDEX(1, -1)], sqrt(3.0 / (4.0 * M_PI)), 1e-7); /* +y */
    /* Fewer bands write fewer values. */
    float few[TS_SH_MAX_COEFFS];
    for (int i = 0; i < 16; ++i)
        few[i] = -7.0f;
    sh_eval(0.0f, 0.0f, 1.0f, 3u, few);
    assert_true(few[8] != -7.0f && few[9] == -7.0f);
    for (int i = 0; i < 16; ++i)
        few[i] = -7.0f;
    sh_eval(0.0f, 0.0f, 1.0f, 1u, few);
    assert_true(few[0] > 0.28f && few[1] == -7.0f);
}

/* Gauss-Legendre nodes and weights on [-1, 1] (Newton on P_n). */
static void gauss_legendre(int n, double *x, double *w)
{
    for (int i = 0; i < n; ++i) {
        double z = cos(M_PI * (i + 0.75) / (n + 0.5)), dp = 0.0;
        for (int it = 0; it < 100; ++it) {
            double p0 = 1.0, p1 = z;
            for (int k = 2; k <= n; ++k) {
                double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
                p0 = p1;
                p1 = p2;
            }
            dp = n * (z * p1 - p0) / (z * z - 1.0);
            double dz = p1 / dp;
            z -= dz;
            if (fabs(dz) < 1e-15) break;
        }
        x[i] = z;
        w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
    }
}

static void test_orthonormal(void **state)
{
    enum { NZ = 12, NPHI = 24 }; /* exact for degree <= 6 in z and 23 in phi */
    double zx[NZ], zw[NZ], gram[16][16] = {{0}};
    gauss_legendre(NZ, zx, zw);
    for (int i = 0; i < NZ; ++i)
        for (int j = 0; j < NPHI; ++j) {
            double phi = 2.0 * M_PI * j / NPHI, s = sqrt(1.0 - zx[i] * zx[i]);
            float y[16];
            sh_eval((float)(s * cos(phi)), (float)(s * sin(phi)), (float)zx[i], 4u, y);
            double w = zw[i] * 2.0 * M_PI / NPHI;
            for (int a = 0; a < 16; ++a)
                for (int b = 0; b < 16; ++b)
                    gram[a][b] += w * y[a] * y[b];
        }
    for (int a = 0; a < 16; ++a)
        for (int b = 0; b < 16; ++b)
            if (fabs(gram[a][b] - (a == b)) > 2e-6)
                fail_msg("<Y%d, Y%d> = %.9g, want %d", a, b, gram[a][b], a == b);
}

static void test_cosine_lobe(void **state)
{
    /* max(0, n . w) is not a polynomial: a fine product rule, error ~1e-5. */
    enum { NZ = 400, NPHI = 800 };
    for (int trial = 0; trial < 4; ++trial) {
        double th = acos(1.0 - 2.0 * uniform()), ph = 2.0 * M_PI * uniform();
        double n[3] = {sin(th) * cos(ph), sin(th) * sin(ph), cos(th)}, proj[16] = {0};
        for (int i = 0; i < NZ; ++i)
            for (int j = 0; j < NPHI; ++j) {
                double z = -1.0 + 2.0 * (i + 0.5) / NZ, phi = 2.0 * M_PI * (j + 0.5) / NPHI;
                double s = sqrt(1.0 - z * z), w[3] = {s * cos(phi), s * sin(phi), z};
                double c = n[0] * w[0] + n[1] * w[1] + n[2] * w[2];
                if (c <= 0.0) continue;
                float y[16];
                sh_eval((float)w[0], (float)w[1], (float)w[2], 4u, y);
                for (int k = 0; k < 16; ++k)
                    proj[k] += c * y[k] * (2.0 / NZ) * (2.0 * M_PI / NPHI);
            }
        float yn[16];
        sh_eval((float)n[0], (float)n[1], (float)n[2], 4u, yn);
        for (int l = 0; l < 4; ++l)
            for (int m = -l; m <= l; ++m) {
                int k = TS_SH_INDEX(l, m);
                double want = sh_cosine_lobe((uint32_t)l) * yn[k];
                if (fabs(proj[k] - want) > 2e-4)
                    fail_msg("clamped cosine, coefficient %d: %.6g by quadrature, %.6g from the "
                             "lobe",
                             k, proj[k], want);
            }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_matches_the_definition),
        cmocka_unit_test(test_named_values),
        cmocka_unit_test(test_orthonormal),
        cmocka_unit_test(test_cosine_lobe),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
