/* test_eta.c — the progress line's estimate (host/app/eta.c). Host only; never skips.
 * Asserts: the weight of the samples [0, k) equals the sum over the frame's sample order
 * (kernels/lib/sample_order.h, sample_order_at) of each sample's pixel weight, for one band,
 * bands of one pixel and of rows, and a last band shorter than the others; pixels not counted
 * weigh the mean of those counted. On a frame whose top quarter is sky (no box crossed) and
 * the rest forest (30 crossings a pixel), timed as forest-100 was on PoCL (0.07 us a sky
 * sample, 26 us a forest one), the estimate once the sky is traced is within 2x of the time
 * left, where the samples-only estimate the progress line used before (time per sample so
 * far times the samples left) is off by more than 10x. Waves of a frame whose patches do not
 * fit (ts_eta_waves), as forest-100 at --memory 512 took them: after the first, the time
 * left within 1.5x (the weight rate alone: 2.5x), after the second within 1.25x; waves that
 * fit give the weight rate's estimate. A frame's first wave, before any wave finished, is
 * projected from its own passes and batches (as forest-100 at 960x384 with --memory 192 took
 * them: within 10% of its time from a third of the eye rays' pass), and the waves after it
 * from that projection. A frame that fits counts its first dicing apart from the weights'
 * rate and adds what it has not diced yet (forest-100 1920x768 x 8: within 10%). Units of
 * several devices or ranks: projected from their own passes where the merged ones are unlike
 * them, a band's first bounce longer than the frame's (its share of the weight). */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include <cmocka.h>

#include "app/eta.h"
#include "lib/sample_order.h"

static void check_order(const uint32_t *cost, uint32_t npix, uint32_t spp, uint32_t band)
{
    ts_eta e;
    ts_error err = {0};
    assert_int_equal(eta_init(&e, cost, npix, spp, band, &err), TS_OK);
    double sum = 0.0;
    for (uint32_t k = 0; k <= npix * spp; ++k) {
        assert_true(eta_work(&e, k) == sum); /* integers below 2^53: exact */
        if (k == npix * spp) break;
        uint32_t pixel, sample;
        sample_order_at(k, npix, spp, band, &pixel, &sample);
        sum += (double)eta_weight(cost[pixel]);
    }
    eta_free(&e);
}

static void test_work_follows_the_sample_order(void **state)
{
    (void)state;
    uint32_t cost[60];
    for (uint32_t p = 0; p < 60; ++p)
        cost[p] = 1 + (p * 7919u) % 13u;
    check_order(cost, 60, 4, 0);  /* one band: pass after pass */
    check_order(cost, 60, 4, 1);  /* pixel after pixel */
    check_order(cost, 60, 3, 12); /* bands of rows */
    check_order(cost, 60, 5, 25); /* the last band shorter */
    check_order(cost, 60, 1, 60);
}

static void test_uncounted_pixels_weigh_the_mean(void **state)
{
    (void)state;
    uint32_t cost[4] = {1, 0, 4, 0}; /* weights 1 and 28: the uncounted weigh 15 */
    ts_eta e;
    ts_error err = {0};
    assert_int_equal(eta_init(&e, cost, 4, 1, 0, &err), TS_OK);
    assert_int_equal(eta_weight(1), 1); /* sky */
    assert_int_equal(eta_weight(2), 1 + (TS_ETA_GEOMETRY_WEIGHT - 1) / TS_ETA_CROSSINGS_SEEN);
    assert_int_equal(eta_weight(1 + TS_ETA_CROSSINGS_SEEN), TS_ETA_GEOMETRY_WEIGHT);
    assert_int_equal(eta_weight(31), TS_ETA_GEOMETRY_WEIGHT); /* however many more */
    assert_true(eta_work(&e, 4) == 1 + 15 + 28 + 15);
    eta_free(&e);
    assert_int_equal(eta_init(&e, NULL, 4, 2, 1, &err), TS_OK); /* no counts: samples */
    assert_true(eta_work(&e, 5) == 5.0);
    eta_free(&e);
}

static void test_sky_above_forest_below(void **state)
{
    (void)state;
    enum { W = 64, H = 32, SPP = 8 };
    uint32_t *cost = malloc(W * H * sizeof *cost);
    assert_non_null(cost);
    for (uint32_t p = 0; p < W * H; ++p)
        cost[p] = 1 + (p < W * H / 4 ? 0u : 30u); /* 1 + crossings, pipeline.h pixel_cost */
    ts_eta e;
    ts_error err = {0};
    assert_int_equal(eta_init(&e, cost, W * H, SPP, 1, &err), TS_OK);
    uint64_t total = (uint64_t)W * H * SPP, quarter = total / 4;
    /* Time a sample as forest-100 1920x768 x 8 took on PoCL (eta.h TS_ETA_GEOMETRY_WEIGHT):
     * 0.06 us a sky sample, 2.3 us one of the forest, with 10% noise. */
    double spent = 0.0, all = 0.0;
    for (uint64_t k = 0; k < total; ++k) {
        uint32_t pixel, sample;
        sample_order_at((uint32_t)k, W * H, SPP, 1, &pixel, &sample);
        double t = (cost[pixel] > 1 ? 2.3 : 0.06) *
                   (1.0 + 0.1 * (double)((k * 2654435761u) % 100u) / 100.0);
        all += t;
        if (k < quarter) spent += t;
    }
    double truth = all - spent;
    double estimate = eta_seconds_left(&e, eta_work(&e, quarter), spent, 0, total);
    double samples_only = spent * (double)(total - quarter) / (double)quarter;
    assert_true(estimate > truth / 2 && estimate < truth * 2);
    assert_true(samples_only < truth / 10);
    assert_true(eta_seconds_left(&e, 0.0, 1.0, 0, total) < 0); /* nothing done: no estimate */
    eta_free(&e);
    free(cost);
}

/* A frame whose patches do not fit: forest-100 1920x768 x 2 at --memory 512 on PoCL, its
 * three waves as measured (2026-11-30): shares of the weight 0.085, 0.536 and 0.380 (the
 * first band is sky and treetops), 11.4, 26.9 and 22.3 s, of which 10.3, 19.9 and 16.5 s
 * dicing and building, the patch cache evicting in each. */
static void test_waves_that_dice_again(void **state)
{
    (void)state;
    const double work[3] = {0.0847, 0.5358, 0.3795}, secs[3] = {11.4, 26.9, 22.3},
                 dicing[3] = {10.34, 19.94, 16.46};
    ts_eta_waves w = {0};
    assert_true(eta_waves_left(&w, 0.0, 0.0, 1.0, work, 3) < 0.0); /* nothing finished yet */
    eta_waves_done(&w, work[0], secs[0], dicing[0], 1, NULL);
    double truth = secs[1] + secs[2];
    double left = eta_waves_left(&w, 0.0, 0.0, 1.0 - work[0], work + 1, 2);
    double by_weight = secs[0] / work[0] * (1.0 - work[0]); /* the weight rate alone: 123 s */
    /* a wave's dicing as the first's, whatever its weight: 32 s */
    double flat = (secs[0] - dicing[0]) / work[0] * (1.0 - work[0]) + 2.0 * dicing[0];
    assert_true(left > 0.9 * truth && left < 1.1 * truth); /* 45.6 s of 49.2 */
    assert_true(by_weight > 2.0 * truth && flat < 0.7 * truth);
    /* the second wave's dicing, from the first's at the power 0.3: 18.0 s of 19.9 */
    assert_true(fabs(eta_waves_dicing(&w, work[1]) - dicing[0] * pow(work[1] / work[0], 0.3)) <
                1e-9);
    /* In the second wave: what is left of it, less the time it has run. */
    double in_wave = eta_waves_left(&w, work[1], 5.0, work[2], work + 2, 1);
    assert_true(fabs(in_wave - (left - 5.0)) < 1e-9);
    assert_true(eta_waves_left(&w, work[1], 1e3, work[2], work + 2, 1) ==
                eta_waves_left(&w, 0.0, 0.0, work[2], work + 2, 1)); /* overrun: the rest */
    eta_waves_done(&w, work[1], secs[1], dicing[1], 1, NULL);
    /* two waves fit the power: log(19.94 / 10.34) / log(0.5358 / 0.0847) = 0.356 */
    assert_true(fabs(eta_waves_exponent(&w) - log(dicing[1] / dicing[0]) / log(work[1] / work[0])) <
                1e-9);
    left = eta_waves_left(&w, 0.0, 0.0, work[2], work + 2, 1);
    assert_true(left > 0.9 * secs[2] && left < 1.1 * secs[2]);      /* 22.6 s of 22.3 */
    assert_true(eta_waves_left(&w, 0.0, 0.0, 0.0, NULL, 0) == 0.0); /* nothing after: done */
}

/* The power of the dicing fit (eta.h ts_eta_waves): 0.3 until two waves of different weights
 * evicted, then their slope of log d on log w, kept within [0, 0.5]: the displaced teapot's
 * bands (weights 9, 22, 33 a sample, 1.1, 1.8, 1.3 s) about 0.2, dicing that falls as the
 * weight grows 0, a steep one 0.5. */
static void test_waves_fit_exponent(void **state)
{
    (void)state;
    ts_eta_waves w = {0};
    assert_true(eta_waves_exponent(&w) == 0.3);
    eta_waves_done(&w, 9.0, 3.0, 1.1, 1, NULL);
    eta_waves_done(&w, 9.0, 3.0, 1.5, 1, NULL);
    assert_true(eta_waves_exponent(&w) == 0.3); /* the weights alike */
    ts_eta_waves t = {0};
    eta_waves_done(&t, 9.0, 3.0, 1.1, 1, NULL);
    eta_waves_done(&t, 22.0, 3.0, 1.8, 1, NULL);
    eta_waves_done(&t, 33.0, 3.0, 1.3, 1, NULL);
    assert_true(eta_waves_exponent(&t) > 0.15 && eta_waves_exponent(&t) < 0.25);
    /* the fit's dicing at the weights' geometric mean: the dicing's */
    double g = cbrt(9.0 * 22.0 * 33.0);
    assert_true(fabs(eta_waves_dicing(&t, g) - cbrt(1.1 * 1.8 * 1.3)) < 1e-9);
    ts_eta_waves f = {0}, s = {0};
    eta_waves_done(&f, 1.0, 9.0, 8.0, 1, NULL);
    eta_waves_done(&f, 4.0, 9.0, 4.0, 1, NULL);
    assert_true(eta_waves_exponent(&f) == 0.0);
    eta_waves_done(&s, 1.0, 90.0, 1.0, 1, NULL);
    eta_waves_done(&s, 4.0, 90.0, 16.0, 1, NULL);
    assert_true(eta_waves_exponent(&s) == 0.5);
    eta_waves_done(&s, 4.0, 90.0, 16.0, 0, NULL); /* the last did not evict: no dicing after */
    assert_true(eta_waves_dicing(&s, 4.0) == 0.0);
}

/* The same frame's waves pass by pass (2026-11-30, stop 56: the rays each pass traced, the
 * eye rays' first, and as they ended the seconds from the wave's start and the dicing seconds
 * by then). The first wave's eye pass took 8% of it, the second's 23%: after the eye pass a
 * wave's bounces follow the last wave's, scaled by their first bounce's rays (10x the rays,
 * 2x the time: they reach most of the forest whatever their number), and after two passes the
 * last wave's share of its time by pass. Inside the second wave the weights' estimate stays
 * at the third wave's 15 s once the second overruns its expected 17 s (it takes 27 s). */
static void test_waves_by_passes(void **state)
{
    (void)state;
    const double work[3] = {0.0847, 0.5358, 0.3795};
    const double rays[3][4] = {{1057279, 157594, 44001, 5782},
                               {1057279, 1633716, 327276, 46388},
                               {834562, 1535541, 286660, 43871}};
    const double end[3][4] = {
        {0.96, 6.54, 9.83, 11.42}, {6.25, 15.93, 22.54, 27.41}, {4.25, 12.18, 17.43, 21.65}};
    const double dice[3][4] = {
        {0.58, 5.76, 8.87, 10.40}, {3.72, 9.86, 15.55, 20.23}, {2.34, 7.51, 12.16, 16.22}};
    ts_eta_passes p[3];
    memset(p, 0, sizeof p);
    for (int v = 0; v < 3; ++v)
        for (int i = 0; i < 4; ++i)
            eta_passes_start(&p[v], rays[v][i]), eta_passes_add(&p[v], end[v][i], dice[v][i]);
    ts_eta_waves w = {0};
    eta_waves_done(&w, work[0], end[0][3], dice[0][3], 1, &p[0]);
    /* The second wave in its eye pass: nothing to project from yet. */
    ts_eta_passes now;
    memset(&now, 0, sizeof now);
    double d;
    eta_passes_start(&now, rays[1][0]);
    assert_true(eta_waves_project(&w, &now, &d) < 0.0);
    eta_passes_add(&now, end[1][0], dice[1][0]);
    assert_true(eta_waves_project(&w, &now, &d) < 0.0); /* the first bounce's rays unknown */
    assert_true(eta_waves_left_passes(&w, work[1], 7.0, work[2], work + 2, 1, &now, NULL) ==
                eta_waves_left(&w, work[1], 7.0, work[2], work + 2, 1));
    /* In its first bounce, then after its second pass and later in its third: the time left
     * from the passes, where the weights' estimate is 0.5-0.7 of it. */
    eta_passes_start(&now, rays[1][1]);
    double seconds = eta_waves_project(&w, &now, &d);
    assert_true(fabs(seconds - (end[1][0] + (end[0][3] - end[0][0]) *
                                                pow(rays[1][1] / rays[0][1], 0.3))) < 1e-9);
    double at[3] = {10.0, end[1][1], 20.0};
    for (int k = 0; k < 3; ++k) {
        if (k == 1) eta_passes_add(&now, end[1][1], dice[1][1]), eta_passes_start(&now, rays[1][2]);
        double truth = end[1][3] - at[k] + end[2][3];
        double by_weight = eta_waves_left(&w, work[1], at[k], work[2], work + 2, 1);
        double by_passes =
            eta_waves_left_passes(&w, work[1], at[k], work[2], work + 2, 1, &now, NULL);
        assert_true(by_weight > 0.85 * truth && by_weight < truth); /* 0.87-0.91 */
        assert_true(by_passes > 0.9 * truth && by_passes < 1.1 * truth);
    }
    seconds = eta_waves_project(&w, &now, &d);
    assert_true(fabs(seconds - end[1][1] * end[0][3] / end[0][1]) < 1e-9);
    assert_true(fabs(d - dice[1][1] * seconds / end[1][1]) < 1e-9);
    /* The third wave from the second's passes: after its eye pass, and after its second. */
    eta_waves_done(&w, work[1], end[1][3], dice[1][3], 1, &p[1]);
    ts_eta_passes third;
    memset(&third, 0, sizeof third);
    eta_passes_start(&third, rays[2][0]), eta_passes_add(&third, end[2][0], dice[2][0]);
    eta_passes_start(&third, rays[2][1]);
    double left = eta_waves_left_passes(&w, work[2], end[2][0], 0.0, NULL, 0, &third, NULL);
    double truth = end[2][3] - end[2][0];
    assert_true(left > 0.9 * truth && left < 1.25 * truth);
    eta_passes_add(&third, end[2][1], dice[2][1]);
    left = eta_waves_left_passes(&w, work[2], end[2][1], 0.0, NULL, 0, &third, NULL);
    truth = end[2][3] - end[2][1];
    assert_true(left > 0.9 * truth && left < 1.1 * truth);
    /* A wave that did not evict leaves nothing to project from. */
    eta_waves_done(&w, 0.0, 1.0, 0.0, 0, &p[2]);
    assert_true(eta_waves_project(&w, &third, &d) < 0.0);
}

/* A wave with no finished wave before it, projected from its own passes (eta_wave_alone), as
 * forest-100 at 960x384 x 1 with --memory 192 traced its one wave (pass ends 2.56, 4.79,
 * 6.28, 7.25 s): nothing before a quarter of the eye rays' work has run; then within 10% of
 * its 7.25 s from the eye rays' batches, within 20% from the pass before the first bounce,
 * within 5% once the first bounce's batches are planned (at the eye rays' seconds a unit of
 * work) and from the rays of the second; a pass runs at least what it has run; --depth 0 is
 * one pass. */
static void test_wave_alone(void **state)
{
    (void)state;
    const double end[4] = {2.557, 4.794, 6.276, 7.250};
    const double rays[4] = {368640, 414682, 84567, 12465};
    const double truth = end[3];
    const double later = 1.0 + TS_ETA_FIRST_BOUNCE + TS_ETA_FIRST_BOUNCE * TS_ETA_NEXT_BOUNCE +
                         TS_ETA_FIRST_BOUNCE * TS_ETA_NEXT_BOUNCE * TS_ETA_NEXT_BOUNCE;
    ts_eta_passes p = {.depth = 3};
    assert_true(eta_wave_alone(&p, 0.5) < 0.0); /* no pass begun */
    eta_passes_start(&p, rays[0]);
    assert_true(eta_wave_alone(&p, 0.5) < 0.0);
    p.flight = (ts_eta_flight){.work = 9.3e6, .done = 2.0e6, .t0 = 0.20};
    assert_true(eta_wave_alone(&p, 0.8) < 0.0); /* under a quarter of the work run */
    p.flight.done = 4.12e6;                     /* 1.01 s into the wave */
    double d0 = 0.20 + (1.01 - 0.20) * 9.3e6 / 4.12e6;
    double s = eta_wave_alone(&p, 1.01);
    assert_true(fabs(s - d0 * later) < 1e-9);
    assert_true(s > 0.9 * truth && s < 1.1 * truth);
    /* the first bounce begun, its batches not yet seen (the flight is the eye rays' pass's) */
    eta_passes_add(&p, end[0], 1.96), eta_passes_start(&p, rays[1]);
    s = eta_wave_alone(&p, 2.7);
    double d1 = end[0] * TS_ETA_FIRST_BOUNCE;
    assert_true(fabs(s - (end[0] + d1 * (1.0 + TS_ETA_NEXT_BOUNCE +
                                         TS_ETA_NEXT_BOUNCE * TS_ETA_NEXT_BOUNCE))) < 1e-9);
    assert_true(s > 0.9 * truth && s < 1.2 * truth);
    /* its batches planned: at the eye rays' batches' seconds a unit of work (their work,
     * 1.2e7, from 0.20 s to the pass's end), within 5% */
    eta_passes_batches(&p, 1.2e7, 0.20);
    p.flight = (ts_eta_flight){.work = 8.86e6, .done = 1.0e6, .t0 = 3.09};
    double d1w = 3.09 - end[0] + 8.86e6 * (end[0] - 0.20) / 1.2e7;
    s = eta_wave_alone(&p, 3.2);
    assert_true(fabs(s - (end[0] + d1w * (1.0 + TS_ETA_NEXT_BOUNCE +
                                          TS_ETA_NEXT_BOUNCE * TS_ETA_NEXT_BOUNCE))) < 1e-9);
    assert_true(s > 0.95 * truth && s < 1.05 * truth);
    p.flight = (ts_eta_flight){0};
    eta_passes_batches(&p, 0.0, 0.0);
    /* a pass that runs past its projection is given what it has run */
    assert_true(fabs(eta_wave_alone(&p, end[0] + 20.0) -
                     (end[0] + 20.0 * (1.0 + TS_ETA_NEXT_BOUNCE +
                                       TS_ETA_NEXT_BOUNCE * TS_ETA_NEXT_BOUNCE))) < 1e-9);
    /* the second bounce, from the first's time and the rays' ratio */
    eta_passes_add(&p, end[1], 3.42), eta_passes_start(&p, rays[2]);
    s = eta_wave_alone(&p, 5.0);
    double d2 = (end[1] - end[0]) * pow(rays[2] / rays[1], TS_ETA_REACH_EXPONENT);
    assert_true(fabs(s - (end[1] + d2 * (1.0 + TS_ETA_NEXT_BOUNCE))) < 1e-9);
    assert_true(s > 0.95 * truth && s < 1.05 * truth);
    /* --depth 0: the eye rays' pass is the wave */
    ts_eta_passes one = {.depth = 0};
    eta_passes_start(&one, rays[0]);
    one.flight = (ts_eta_flight){.work = 9.3e6, .done = 4.12e6, .t0 = 0.20};
    assert_true(fabs(eta_wave_alone(&one, 1.01) - d0) < 1e-9);
}

/* The first wave of forest-100 at 1920x768 x 2 with --memory 512 (sky and treetops, 0.085 of
 * the weight, its passes ending at 0.96, 6.54, 9.83 and 11.42 s; the frame 60.5 s) in its
 * first bounce, half of that pass's work run: the waves after it estimated as if it had
 * finished as projected, its dicing those of the eye rays' pass and TS_ETA_BOUNCE_DICING of
 * the rest (the stages' dicing seconds lag: the line saw 0.55 s until 5 s into the wave).
 * Within 25% of the 57.3 s left (45.5 s), where the wave's dicing share so far (0.55 of
 * 3.17 s) puts it at over 1.5 times that; with no wave after it, its own time left. */
static void test_first_wave_and_after(void **state)
{
    (void)state;
    const double work[3] = {0.0847, 0.5358, 0.3795};
    ts_eta_passes p = {.depth = 3};
    eta_passes_start(&p, 1057279), eta_passes_add(&p, 0.96, 0.58), eta_passes_start(&p, 157594);
    p.flight =
        (ts_eta_flight){.work = 2.16e7, .done = 1.09e7, .t0 = 1.14, .dicing = 0.55, .evicted = 1};
    ts_eta_waves w = {0};
    double projected;
    double left =
        eta_waves_left_passes(&w, work[0], 3.17, work[1] + work[2], work + 1, 2, &p, &projected);
    double truth = 60.5 - 3.17;
    assert_true(fabs(projected - eta_wave_alone(&p, 3.17)) < 1e-9);
    assert_true(left > 0.75 * truth && left < 1.25 * truth); /* 0.79 */
    /* with the wave's dicing share so far instead */
    ts_eta_waves then = {0};
    eta_waves_done(&then, work[0], projected, 0.55 * projected / 3.17, 1, NULL);
    double share =
        projected - 3.17 + eta_waves_left(&then, 0.0, 0.0, work[1] + work[2], work + 1, 2);
    assert_true(share > 1.5 * truth);
    left = eta_waves_left_passes(&w, work[0], 3.17, 0.0, NULL, 0, &p, NULL);
    assert_true(fabs(left - (projected - 3.17)) < 1e-9);
    /* before the eye rays' batches are seen: no estimate */
    ts_eta_passes eye = {.depth = 3};
    eta_passes_start(&eye, 1057279);
    assert_true(eta_waves_left_passes(&w, work[0], 0.5, 0.9153, work + 1, 2, &eye, NULL) < 0.0);
}

/* The progress line stays under 80 columns (a longer one wraps on a terminal, and every
 * update then scrolls), with a frame of 47 M samples (1920x768 x 32): done and left, and the
 * pass of the first wave in flight at the deepest --depth. */
static void test_line_fits_80_columns(void **state)
{
    (void)state;
    char path[] = "/tmp/test_eta_line_XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    fflush(stderr);
    int saved = dup(2);
    dup2(fd, 2);
    ts_eta e = {0};
    eta_print_left(&e, 0, 0, 47185920, 0.0, 1e8, 1.0, -1.0, "wave");
    eta_print_tail(&e, 0, 0, 47185920, 0.0, 1e8, 1.0, "wave 1: bounce 63/64");
    eta_print_left(&e, 47185920, 0, 47185920, 47185920.0, 1e8, 1.0, 99999.0, "wave");
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    char text[1024] = "";
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    size_t got = fread(text, 1, sizeof text - 1, f);
    text[got] = 0;
    fclose(f), close(fd), unlink(path);
    int lines = 0;
    for (char *line = strtok(text, "\r"); line; line = strtok(NULL, "\r"), ++lines) {
        size_t n = strlen(line);
        while (n > 0 && line[n - 1] == ' ')
            --n; /* the spaces after it in a log (a terminal's line is erased instead) */
        assert_true(strncmp(line, "tessera: ", 9) == 0);
        if (n >= 80) fail_msg("%zu columns: %.*s", n, (int)n, line);
    }
    assert_int_equal(lines, 3);
}

/* Waves that do not evict count whole: the time left is the weight left at the weight per
 * second so far, what eta_seconds_left gives. */
static void test_waves_that_fit(void **state)
{
    (void)state;
    ts_eta_waves w = {0};
    eta_waves_done(&w, 0.2, 4.0, 3.0, 0, NULL); /* its dicing is new to the frame: counted whole */
    eta_waves_done(&w, 0.3, 5.0, 0.5, 0, NULL);
    double rate = 9.0 / 0.5;
    const double halves[2] = {0.25, 0.25};
    assert_true(fabs(eta_waves_left(&w, 0.0, 0.0, 0.5, halves, 2) - rate * 0.5) < 1e-9);
    assert_true(fabs(eta_waves_expect(&w, 0.25) - rate * 0.25) < 1e-9);
}

/* A frame that fits, as forest-100 1920x768 x 8 took its waves at the default budget (weights
 * in millions, 37 a sample whose eye ray crosses a box; seconds; dicing seconds; micro-
 * polygons created): two sky waves, then the first to meet the forest, whose dicing is the
 * frame's first of those patches. After its fourth wave the time left is within 10% of the
 * 17.9 s its other eight took, counting the first dicing apart and the frame's 5.6 M
 * micro-polygons not diced yet at its seconds a micro-polygon, in the share of the weight
 * left; counted whole, over 4 times. */
static void test_waves_that_fit_first_dicing(void **state)
{
    (void)state;
    const double work[4] = {1.048576, 1.048576, 1.490368, 15.099808};
    const double secs[4] = {0.077, 0.065, 1.363, 5.003}, dice[4] = {0.0, 0.0, 1.267, 3.961};
    const double mp[4] = {0.0, 0.0, 5.23e6, 20.57e6}, after = 278.56 - 18.687328;
    const double truth = 17.94, need = 31.36e6;
    ts_eta_waves first = {0}, whole = {0};
    for (int i = 0; i < 4; ++i) {
        eta_waves_done_diced(&first, work[i], secs[i], dice[i], 0, NULL, mp[i]);
        eta_waves_done(&whole, work[i], secs[i], dice[i], 0, NULL);
    }
    first.mp_left = whole.mp_left = need - 25.8e6;
    double left = eta_waves_left(&first, 0.0, 0.0, after, NULL, 0);
    double rate = (0.077 + 0.065 + 0.096 + 1.042) / 18.687328;
    double share = after / (18.687328 + after); /* of the weight, what is left to trace */
    assert_true(fabs(left - (rate * after + 5.228 / 25.8e6 * first.mp_left * share)) < 1e-6);
    assert_true(left > 0.9 * truth && left < 1.1 * truth);
    assert_true(eta_waves_left(&whole, 0.0, 0.0, after, NULL, 0) > 4.0 * truth);
}

/* Waves of background dice nothing: of the waves left, only those holding a pixel whose eye
 * ray crosses a patch box add a wave's dicing (a wave whose eye rays cross none has no hit to
 * bounce from). Without the pixels' costs every wave counts. */
static void test_waves_of_background(void **state)
{
    (void)state;
    enum { N = 64 };
    uint32_t cost[N];
    for (int p = 0; p < N; ++p)
        cost[p] = p < N / 2 ? 3 : 1; /* the top half crosses patch boxes, the bottom is sky */
    ts_eta e, plain;
    ts_error err = {0};
    assert_int_equal(eta_init(&e, cost, N, 1, N, &err), TS_OK);
    assert_int_equal(eta_init(&plain, NULL, N, 1, N, &err), TS_OK);
    assert_int_equal(eta_waves_with_geometry(&e, 0, N, 16), 2);
    assert_int_equal(eta_waves_with_geometry(&e, 24, N, 16), 1); /* [24, 40) holds 24..31 */
    assert_int_equal(eta_waves_with_geometry(&e, 32, N, 16), 0);
    assert_int_equal(eta_waves_with_geometry(&plain, 32, N, 16), 2);
    ts_eta_waves w = {0};
    eta_waves_done(&w, 1.0, 12.0, 10.0, 1, NULL); /* 2 s of weight, 10 s of dicing */
    double sky = eta_work(&e, N) - eta_work(&e, N / 2);
    /* the waves that dice, by weight: none of the sky's, both of the unweighted frame's */
    double works[4];
    assert_int_equal(eta_waves_works(&e, 32, N, 16, works), 0);
    assert_int_equal(eta_waves_works(&plain, 32, N, 16, works), 2);
    assert_true(works[0] == 16.0 && works[1] == 16.0);
    assert_int_equal(eta_waves_works(&e, 0, N, 16, works), 2);
    assert_true(works[0] == eta_work(&e, 16) && works[1] == eta_work(&e, 32) - eta_work(&e, 16));
    assert_true(fabs(eta_waves_left(&w, 0.0, 0.0, sky, works, 0) - 2.0 * sky) < 1e-9);
    const double ones[2] = {1.0, 1.0}; /* two waves of the first's weight: its 10 s each */
    assert_true(fabs(eta_waves_left(&w, 0.0, 0.0, sky, ones, 2) - (2.0 * sky + 20.0)) < 1e-9);
    eta_free(&e);
    eta_free(&plain);
}

/* eta_units_left: the units out longest run, one a device, the others wait in line (an MPI
 * rank's next unit while it traces one); a unit of background adds no dicing; -1 until a
 * merged unit evicted. The frame measured: forest-100 1920x768 x 2 at --memory 512 on two
 * devices, whose first unit (sky and treetops, 2% of the weight) took 10 s, and whose line
 * said 784 s with 67 s left by the weights' rate. */
static void test_units_that_dice_again(void **state)
{
    (void)state;
    /* weights 1 and 1024 (1024^0.3 = 8): unit 0 took 8 s of dicing and 1/64 s for its
     * weight of 1, so a unit of weight 1024 is expected to take 16 + 8 * 8 = 80 s */
    ts_eta_unit u[5] = {
        {.work = 1.0,
         .seconds = 8.015625,
         .dicing = 8.0,
         .state = TS_ETA_UNIT_MERGED,
         .evicted = 0,
         .geometry = 1},
        {.work = 1024.0, .seconds = 4.0, .state = TS_ETA_UNIT_OUT, .geometry = 1},
        {.work = 1024.0, .seconds = 10.0, .state = TS_ETA_UNIT_OUT, .geometry = 1},
        {.work = 1.0, .state = TS_ETA_UNIT_WAITING, .geometry = 1},
        {.work = 1024.0, .state = TS_ETA_UNIT_WAITING, .geometry = 0},
    };
    assert_true(eta_units_left(u, 5, 2, NULL) == -1.0); /* nothing evicted: the weights hold */
    u[0].evicted = 1;
    /* two devices: units 2 and 1 end in 70 s and 76 s, unit 3 (8.015625) follows unit 2,
     * unit 4 (sky: 16, no dicing) unit 1 (92 s) */
    assert_true(fabs(eta_units_left(u, 5, 2, NULL) - 92.0) < 1e-9);
    /* the line's credit: units 2 and 1, each expected to take 80 s, 10 s and 4 s in */
    double credit = -1.0;
    assert_true(fabs(eta_units_left(u, 5, 2, &credit) - 92.0) < 1e-9);
    assert_true(fabs(credit - 1024.0 * (10.0 + 4.0) / 80.0) < 1e-9);
    /* at most 0.9 of a unit's weight, however long it has run */
    u[2].seconds = 400.0;
    assert_true(eta_units_left(u, 5, 2, &credit) > 0.0);
    assert_true(fabs(credit - 1024.0 * (0.9 + 4.0 / 80.0)) < 1e-9);
    u[2].seconds = 10.0;
    /* one device (an MPI rank that took unit 1 ahead): unit 2, out longer, runs, unit 1 waits */
    assert_true(fabs(eta_units_left(u, 5, 1, NULL) - (70.0 + 80.0 + 8.015625 + 16.0)) < 1e-9);
    /* four: every unit at once, the last to end the one out least long */
    assert_true(fabs(eta_units_left(u, 5, 4, NULL) - 76.0) < 1e-9);
    assert_true(eta_units_left(u, 5, 0, NULL) == -1.0);
    /* unit 2 waits behind unit 1 on its device (queued: an MPI rank's next): unit 1 runs (76 s
     * left), unit 2 (80) goes first in line to the free device, then unit 3 after unit 1 and
     * unit 4 after unit 2 (96 s) */
    u[2].queued = 1, u[2].seconds = 0.0;
    assert_true(fabs(eta_units_left(u, 5, 2, NULL) - 96.0) < 1e-9);
    /* a unit out longer than expected has a quarter of its time so far left, not nothing */
    u[2].queued = 0, u[2].seconds = 400.0;
    assert_true(fabs(eta_units_left(u, 5, 1, NULL) - (100.0 + 80.0 + 8.015625 + 16.0)) < 1e-9);
}

/* A unit a device traces is projected from its wave's passes: as the last merged unit spent
 * its own (eta_waves_project) where that one is alike (weights within 2x), else from its own
 * passes (eta_wave_alone, with its share of the weight), and the units after it are expected
 * as if it had ended so. In its eye rays' pass, before its batches say anything, with only
 * lighter units merged, there is no estimate (TS_ETA_UNITS_EYE_RAYS). */
static void test_units_by_passes(void **state)
{
    (void)state;
    ts_eta_passes then = {.end = {4, 12, 17, 20},
                          .dicing = {2, 7, 10, 12},
                          .rays = {100, 50, 10, 2},
                          .count = 4,
                          .started = 4,
                          .depth = 3};
    ts_eta_passes now = {.end = {5, 9},
                         .dicing = {3, 6},
                         .rays = {100, 50, 20},
                         .count = 2,
                         .started = 3,
                         .depth = 3};
    ts_eta_unit u[3] = {
        {.work = 512.0,
         .seconds = 20.0,
         .dicing = 12.0,
         .state = TS_ETA_UNIT_MERGED,
         .evicted = 1,
         .geometry = 1,
         .passes = &then},
        {.work = 1024.0, .seconds = 10.0, .state = TS_ETA_UNIT_OUT, .geometry = 1, .passes = &now},
        {.work = 1024.0, .state = TS_ETA_UNIT_WAITING, .geometry = 1},
    };
    /* unit 1: 9 s through the two passes that took unit 0 12 of its 20 s: 15 s (5 left), 10 of
     * them dicing; unit 2 then at (8 + 5) s for 1536 of weight, and the dicing of units 0 and 1
     * (12 s at weight 512, 10 s at 1024: no growth, their geometric mean) */
    double unit2 = 13.0 / 1536.0 * 1024.0 + sqrt(12.0 * 10.0);
    assert_true(fabs(eta_units_left(u, 3, 2, NULL) - unit2) < 1e-9);
    assert_true(fabs(eta_units_left(u, 3, 1, NULL) - (5.0 + unit2)) < 1e-9);
    /* without its passes unit 1 is its weight at 8/512 s a unit of weight and 12 x 2^0.3 s of
     * dicing (one unit: the exponent TS_ETA_REACH_EXPONENT) */
    u[1].passes = NULL;
    double alone = 16.0 + 12.0 * pow(2.0, TS_ETA_REACH_EXPONENT);
    assert_true(fabs(eta_units_left(u, 3, 1, NULL) - (alone - 10.0 + alone)) < 1e-9);
    /* unit 0 unlike it (of sky, 1/64 of its weight): unit 1 from its own passes, its second
     * bounce at the first's 4 s times the rays' ratio to 0.3, the third 0.6 of that; its
     * dicing those by its last pass (6 s) and 0.9 of the rest */
    u[0].work = 16.0, u[1].passes = &now;
    double b2 = 4.0 * pow(20.0 / 50.0, TS_ETA_REACH_EXPONENT);
    double s1 = 9.0 + b2 * (1.0 + TS_ETA_NEXT_BOUNCE), d1 = 6.0 + (s1 - 9.0) * 0.9;
    ts_eta_passes own = now;
    own.share = 1024.0 / 2064.0;
    assert_true(fabs(eta_wave_alone(&own, 10.0) - s1) < 1e-9);
    double after = (8.0 + s1 - d1) / 1040.0 * 1024.0 + sqrt(12.0 * d1);
    assert_true(fabs(eta_units_left(u, 3, 1, NULL) - (s1 - 10.0 + after)) < 1e-9);
    /* in its eye rays' pass, its batches not a quarter run: no estimate */
    ts_eta_passes eye = {.rays = {100}, .started = 1, .depth = 3};
    eye.flight = (ts_eta_flight){.work = 1e6, .done = 1e5, .t0 = 0.5};
    u[1].passes = &eye;
    assert_true(eta_units_left(u, 3, 1, NULL) == TS_ETA_UNITS_EYE_RAYS);
    /* ... unless the units merged weigh as much: then they are its rate, even once its eye
     * rays' batches could project it (a band's first bounce may take 3 times that pass) */
    u[0].work = 1024.0;
    double left = eta_units_left(u, 3, 1, NULL);
    assert_true(left > 0.0);
    eye.flight.done = 5e5;
    assert_true(eta_wave_alone(&eye, 10.0) > 0.0);
    assert_true(eta_units_left(u, 3, 1, NULL) == left);
    u[1].passes = NULL;
    assert_true(eta_units_left(u, 3, 1, NULL) == left);
    u[1].passes = &eye;
    eye.flight.done = 1e5;
    /* Nothing merged yet (two MPI ranks with a unit each): units out whose patch caches evict
     * are projected from their own passes; while their caches have not evicted, the weights'
     * rate holds (-1) */
    ts_eta_unit two[2] = {
        {.work = 1024.0, .seconds = 10.0, .state = TS_ETA_UNIT_OUT, .geometry = 1, .passes = &now},
        {.work = 1024.0, .seconds = 10.0, .state = TS_ETA_UNIT_OUT, .geometry = 1, .passes = &now},
    };
    now.share = 0.5;
    assert_true(eta_units_left(two, 2, 2, NULL) == -1.0);
    now.flight.evicted = 1;
    own = now;
    assert_true(fabs(eta_units_left(two, 2, 2, NULL) - (eta_wave_alone(&own, 10.0) - 10.0)) < 1e-9);
    two[1].passes = &eye; /* one in its eye rays' pass */
    assert_true(eta_units_left(two, 2, 2, NULL) == TS_ETA_UNITS_EYE_RAYS);
}

/* The first bounce of a wave that is a band of the image, from its eye rays' pass:
 * TS_ETA_FIRST_BOUNCE times its share of the weight to the power -TS_ETA_BAND_EXPONENT (a unit
 * of forest-100 1920x768 x 2 at --memory 512 on two MPI ranks, 0.45 of the weight: its eye rays'
 * pass 11.4 s, its first bounce 21.2 s, where 1.2 alone says 13.7 s); a frame in one wave
 * keeps 1.2. Projected in the eye rays' pass, the passes after it take that factor. */
static void test_unit_first_bounce(void **state)
{
    (void)state;
    assert_true(eta_first_bounce(0.0) == TS_ETA_FIRST_BOUNCE);
    assert_true(eta_first_bounce(1.0) == TS_ETA_FIRST_BOUNCE);
    double f = eta_first_bounce(0.45);
    assert_true(fabs(f - TS_ETA_FIRST_BOUNCE * pow(0.45, -TS_ETA_BAND_EXPONENT)) < 1e-12);
    assert_true(f > TS_ETA_FIRST_BOUNCE && 11.4 * f < 21.2);
    assert_true(eta_first_bounce(0.001) == eta_first_bounce(0.01));
    /* in its eye rays' pass, half its batches' work run in 5 s from 1.1 s */
    ts_eta_passes p = {.rays = {873676}, .started = 1, .depth = 3, .share = 0.45};
    p.flight = (ts_eta_flight){.work = 2.77e7, .done = 1.385e7, .t0 = 1.1};
    double eye = 1.1 + (6.1 - 1.1) * 2.0;
    double later = 1.0 + f + f * TS_ETA_NEXT_BOUNCE + f * TS_ETA_NEXT_BOUNCE * TS_ETA_NEXT_BOUNCE;
    assert_true(fabs(eta_wave_alone(&p, 6.1) - eye * later) < 1e-9);
    p.share = 1.0;
    double one = 1.0 + TS_ETA_FIRST_BOUNCE + TS_ETA_FIRST_BOUNCE * TS_ETA_NEXT_BOUNCE +
                 TS_ETA_FIRST_BOUNCE * TS_ETA_NEXT_BOUNCE * TS_ETA_NEXT_BOUNCE;
    assert_true(fabs(eta_wave_alone(&p, 6.1) - eye * one) < 1e-9);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_work_follows_the_sample_order),
        cmocka_unit_test(test_uncounted_pixels_weigh_the_mean),
        cmocka_unit_test(test_sky_above_forest_below),
        cmocka_unit_test(test_waves_that_dice_again),
        cmocka_unit_test(test_waves_by_passes),
        cmocka_unit_test(test_waves_fit_exponent),
        cmocka_unit_test(test_waves_that_fit),
        cmocka_unit_test(test_waves_that_fit_first_dicing),
        cmocka_unit_test(test_waves_of_background),
        cmocka_unit_test(test_units_that_dice_again),
        cmocka_unit_test(test_units_by_passes),
        cmocka_unit_test(test_unit_first_bounce),
        cmocka_unit_test(test_wave_alone),
        cmocka_unit_test(test_first_wave_and_after),
        cmocka_unit_test(test_line_fits_80_columns),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
