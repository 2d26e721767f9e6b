/* test_sampler.c — the Owen-scrambled Sobol sampler (kernels/lib/sampler.h). Host only;
 * never skips. Asserts the properties the renderer relies on, for many pixels and sets:
 *   - the first 2^k samples of a pixel are stratified in each of the four dimensions of a
 *     set (one value per interval of width 2^-k), for spp = 2^k and for spp masks above;
 *   - dimensions 0 and 1 form a (0, k, 2)-net: every elementary box of area 2^-k holds
 *     exactly one point;
 *   - the sampler's 32-bit Sobol values match the direction numbers' definition computed
 *     another way (Gray-code recurrence);
 *   - values are in [0, 1), the same inputs give the same values, and different pixels,
 *     sets and seeds give independent-looking values (means and correlations within
 *     statistical tolerances derived from the count);
 *   - the star discrepancy of 256 points of one pixel is below that of independent random
 *     points by a wide margin. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "lib/sampler.h"

static void test_sobol_matches_gray_code(void **state)
{
    /* Antonov-Saleev: x_{i+1} = x_i ^ v[c], c = index of the lowest zero bit of i. */
    for (uint32_t d = 0; d < 4; ++d) {
        uint32_t x = 0;
        for (uint32_t i = 0; i < 4096; ++i) {
            uint32_t gray = i ^ (i >> 1);
            assert_int_equal(sampler_sobol(gray, d), x);
            uint32_t c = 0;
            while ((i >> c) & 1u)
                ++c;
            x ^= d == 0 ? 0x80000000u >> c : ts_sobol_dirs[d - 1][c];
        }
    }
}

static void test_owen_and_lk_are_permutations(void **state)
{
    /* On 12-bit values (an Owen scramble keeps the top bits' intervals): bijective. */
    for (uint32_t seed = 1; seed < 20; ++seed) {
        static uint8_t seen_lk[4096], seen_owen[4096];
        memset(seen_lk, 0, sizeof seen_lk), memset(seen_owen, 0, sizeof seen_owen);
        for (uint32_t i = 0; i < 4096; ++i) {
            uint32_t a = sampler_lk(i, seed * 0x9e3779b9u) & 4095u;
            uint32_t b = sampler_owen(i << 20, seed * 0x85ebca6bu) >> 20;
            assert_int_equal(seen_lk[a]++, 0);
            assert_int_equal(seen_owen[b]++, 0);
        }
    }
}

static void test_prefixes_are_stratified(void **state)
{
    uint8_t *seen = malloc(1u << 10);
    assert_non_null(seen);
    for (uint32_t pixel = 0; pixel < 300; pixel += 7)
        for (uint32_t set = 0; set < 8; ++set)
            for (uint32_t k = 0; k <= 10; ++k) {
                uint32_t n = 1u << k;
                /* spp = n, and spp = 3n / 2 + 1 (mask 2n - 1): the first n are stratified in
                 * both cases, since the shuffle permutes every power-of-two prefix. */
                for (int variant = 0; variant < 2; ++variant) {
                    uint32_t mask = sampler_mask(variant ? 3 * n / 2 + 1 : n);
                    for (uint32_t d = 0; d < 4; ++d) {
                        memset(seen, 0, n);
                        for (uint32_t s = 0; s < n; ++s) {
                            uint32_t bits = sampler_bits(pixel, s, set, d, 42u, mask);
                            uint32_t bin = k == 0 ? 0 : bits >> (32 - k);
                            if (seen[bin]++)
                                fail_msg("pixel %u set %u d %u: two of %u samples in bin %u", pixel,
                                         set, d, n, bin);
                        }
                    }
                    /* (0, k, 2)-net in dimensions 0 and 1. */
                    for (uint32_t a = 0; a <= k; ++a) {
                        memset(seen, 0, n);
                        for (uint32_t s = 0; s < n; ++s) {
                            uint32_t x = sampler_bits(pixel, s, set, 0, 42u, mask);
                            uint32_t y = sampler_bits(pixel, s, set, 1, 42u, mask);
                            uint32_t bx = a == 0 ? 0 : x >> (32 - a);
                            uint32_t by = k - a == 0 ? 0 : y >> (32 - (k - a));
                            if (seen[(bx << (k - a)) | by]++)
                                fail_msg("pixel %u set %u: box %ux%u of 2^%u points twice", pixel,
                                         set, a, k - a, k);
                        }
                    }
                }
            }
    free(seen);
}

static void test_values_and_independence(void **state)
{
    /* The first sample of 20000 pixels in set 3, dimensions 0..3, and of two seeds: each
     * mean within 5 sigma of 1/2 (sigma = sqrt(1/12 / n)), correlations between dimensions,
     * seeds and neighbouring pixels within 5 / sqrt(n). */
    enum { N = 20000 };
    double sum[6] = {0}, sq[6] = {0}, cross[5] = {0};
    for (uint32_t p = 0; p < N; ++p) {
        double v[6];
        for (uint32_t d = 0; d < 4; ++d)
            v[d] = sampler_value(p, 0, 3, d, 7u, 15u);
        v[4] = sampler_value(p, 0, 3, 0, 8u, 15u);     /* another seed */
        v[5] = sampler_value(p + 1, 0, 3, 0, 7u, 15u); /* the next pixel */
        for (int k = 0; k < 6; ++k) {
            assert_true(v[k] >= 0.0 && v[k] < 1.0);
            sum[k] += v[k], sq[k] += v[k] * v[k];
        }
        cross[0] += (v[0] - 0.5) * (v[1] - 0.5);
        cross[1] += (v[2] - 0.5) * (v[3] - 0.5);
        cross[2] += (v[0] - 0.5) * (v[4] - 0.5);
        cross[3] += (v[0] - 0.5) * (v[5] - 0.5);
        cross[4] += (v[1] - 0.5) * (v[2] - 0.5);
    }
    double sigma = sqrt(1.0 / 12.0 / N);
    for (int k = 0; k < 6; ++k)
        assert_true(fabs(sum[k] / N - 0.5) < 5 * sigma);
    for (int k = 0; k < 5; ++k) /* correlation coefficient: cov / (1/12) */
        assert_true(fabs(cross[k] / N * 12.0) < 5.0 / sqrt((double)N));
    /* Same inputs, same bits. */
    assert_int_equal(sampler_bits(123, 45, 6, 2, 9u, 63u), sampler_bits(123, 45, 6, 2, 9u, 63u));
}

/* Star discrepancy of n 2-D points, computed exactly over the grid of their coordinates. */
static double star_discrepancy(const double *x, const double *y, int n)
{
    double worst = 0;
    for (int i = 0; i <= n; ++i)
        for (int j = 0; j <= n; ++j) {
            double bx = i < n ? x[i] : 1.0, by = j < n ? y[j] : 1.0;
            int open = 0, closed = 0;
            for (int k = 0; k < n; ++k) {
                open += x[k] < bx && y[k] < by;
                closed += x[k] <= bx && y[k] <= by;
            }
            double area = bx * by;
            worst = fmax(worst, fmax(area - (double)open / n, (double)closed / n - area));
        }
    return worst;
}

static void test_discrepancy_below_random(void **state)
{
    enum { N = 256 };
    double x[N], y[N], rx[N], ry[N], sobol_worst = 0, random_best = 1;
    uint32_t h = 1;
    for (uint32_t pixel = 0; pixel < 4; ++pixel) {
        for (uint32_t s = 0; s < N; ++s) {
            x[s] = sampler_value(pixel, s, 5, 0, 1u, N - 1);
            y[s] = sampler_value(pixel, s, 5, 1, 1u, N - 1);
            h = rng_mix(h + s);
            rx[s] = (h >> 8) / 16777216.0;
            h = rng_mix(h + 77);
            ry[s] = (h >> 8) / 16777216.0;
        }
        sobol_worst = fmax(sobol_worst, star_discrepancy(x, y, N));
        random_best = fmin(random_best, star_discrepancy(rx, ry, N));
    }
    /* A (0, 8, 2)-net: D* < about (log n)^2 / n; random points: about 1 / sqrt(n). */
    assert_true(sobol_worst < 0.03);
    assert_true(random_best > 2 * sobol_worst);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sobol_matches_gray_code),
        cmocka_unit_test(test_owen_and_lk_are_permutations),
        cmocka_unit_test(test_prefixes_are_stratified),
        cmocka_unit_test(test_values_and_independence),
        cmocka_unit_test(test_discrepancy_below_random),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
