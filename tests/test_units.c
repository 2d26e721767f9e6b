/* test_units.c — the units of a render on several devices (host/app/units.c, done.c) and
 * the frame's sample order (kernels/lib/sample_order.h), host only: the order visits every
 * (pixel, sample) once, in sample order per pixel, for bands of any size; merging units
 * gives the sums kernels/film.cl makes (a C copy of its loop, wave by wave) and a plain
 * per-pixel sum in sample order, bit for bit, whatever the unit size and the bands; the
 * board's units (one a band, none sharing a pixel) merged as threads finish them, in any
 * order, given back and taken again, from an empty film, a prefix or runs past a gap, give
 * the same bits and record the runs the film holds; take, give back, close, freeze;
 * backup units of a slow device's (merged once, whichever copy ends first; none of a device
 * no slower, or with TESSERA_BACKUP_UNITS=0); units made larger before any is handed out
 * (board_regather) and a gated board; units_plan's and sample_order_band's sizes. The
 * radiance values span 12 orders of magnitude, so any other order of the additions changes bits
 * (asserted too). */
#include "app/units.h"
#include "base/stats.h"
#include "lib/sample_order.h"

#include <math.h>
#include <pthread.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <cmocka.h>

#define W 37
#define H 11
#define P (W * H)
#define SPP 9
#define TOTAL ((uint64_t)P * SPP)

/* Sample s of pixel p: radiance[s * P + p] (and its AOVs), whatever the order. */
static ts_vec4 radiance[TOTAL], aov[TOTAL], albedo[TOTAL];

/* Bands the tests try: one (pass after pass), one row, three rows, rows that do not divide
 * the image, and a band of part of a row. */
static const uint32_t bands[] = {0, W, 3 * W, 4 * W, 5};

static ts_sample_order order_of(uint32_t band)
{
    return (ts_sample_order){P, SPP, band};
}

/* The index into radiance[] of the order's k-th sample. */
static uint64_t value_at(const ts_sample_order *o, uint64_t k)
{
    uint32_t p, s;
    sample_order_at((uint32_t)k, o->pixels, o->spp, o->band, &p, &s);
    return (uint64_t)s * P + p;
}

static uint64_t rng_next(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* A float in [0, 1) times 10^(0..11). */
static float wide(uint64_t *st)
{
    uint64_t r = rng_next(st);
    float f = (float)(r >> 40) / (float)(1u << 24);
    for (uint64_t e = (r & 0xff) % 12; e > 0; --e)
        f *= 10.0f;
    return f;
}

static int setup(void **state)
{
    (void)state;
    uint64_t st = 42;
    for (uint64_t g = 0; g < TOTAL; ++g) {
        radiance[g] = (ts_vec4){wide(&st), wide(&st), wide(&st), 7.0f};
        aov[g] = (ts_vec4){(float)g, 1.0f, 2.0f, 3.0f};
        albedo[g] = (ts_vec4){0.5f, (float)g, 0.25f, 0.0f};
    }
    return 0;
}

static void film_alloc(ts_film_state *f)
{
    ts_error err = {0};
    assert_int_equal(film_state_alloc(f, P, &err), TS_OK);
}

/* f and b: films and a board over the whole of TOTAL samples in order o, nothing held. */
static void board_open(ts_board *b, ts_film_state *f, const ts_sample_order *o)
{
    ts_error err = {0};
    film_alloc(f);
    assert_int_equal(board_init(b, f, o, TOTAL, 0, NULL, &err), TS_OK);
}

/* Each pixel's samples added in sample order, AOVs from sample 0: what every order, wave
 * size and unit size must give. */
static void film_plain(ts_film_state *f)
{
    for (uint32_t p = 0; p < P; ++p) {
        ts_vec4 acc = {0, 0, 0, 0};
        for (uint32_t s = 0; s < SPP; ++s) {
            ts_vec4 r = radiance[(uint64_t)s * P + p];
            acc.x += r.x;
            acc.y += r.y;
            acc.z += r.z;
            acc.w += 1.0f;
        }
        f->accum[p] = acc, f->aov[p] = aov[p], f->albedo[p] = albedo[p];
    }
}

/* kernels/film.cl's loop in C: waves of `wave` samples of the order o from `start` on, each
 * pixel of the wave's bands (sample_order_pixels, the pixels film.cl's launch covers) with
 * its samples in the wave added in order. */
static void film_reference(ts_film_state *f, const ts_sample_order *o, uint64_t start,
                           uint64_t wave)
{
    for (uint64_t first = start; first < TOTAL; first += wave) {
        uint64_t last = first + wave < TOTAL ? first + wave : TOTAL;
        uint32_t p0, p1;
        sample_order_pixels((uint32_t)first, (uint32_t)(last - first), P, SPP, o->band, &p0, &p1);
        for (uint32_t p = p0; p < p1; ++p) {
            uint32_t k0 = sample_order_index(p, 0, P, SPP, o->band);
            uint32_t n = sample_order_index(p, 1, P, SPP, o->band) - k0;
            uint32_t s = sample_order_count(p, (uint32_t)first, P, SPP, o->band);
            ts_vec4 acc = f->accum[p];
            for (uint64_t k = k0 + (uint64_t)s * n; s < SPP && k < last; ++s, k += n) {
                ts_vec4 r = radiance[value_at(o, k)];
                acc.x += r.x;
                acc.y += r.y;
                acc.z += r.z;
                acc.w += 1.0f;
                if (s == 0) f->aov[p] = aov[value_at(o, k)], f->albedo[p] = albedo[value_at(o, k)];
            }
            f->accum[p] = acc;
        }
    }
}

/* The order visits every (pixel, sample) once, each pixel's samples in increasing order;
 * sample_order_index inverts sample_order_at and sample_order_count counts a prefix; the
 * runs of samples 0 are exactly the samples 0; sample_order_pixels holds the pixel of every
 * sample of a window, and no more than the whole bands the window touches. */
static void test_sample_order_is_a_permutation(void **state)
{
    (void)state;
    static uint8_t seen[TOTAL];
    for (size_t b = 0; b < sizeof bands / sizeof *bands; ++b) {
        ts_sample_order o = order_of(bands[b]);
        memset(seen, 0, sizeof seen);
        uint32_t last[P];
        for (uint32_t p = 0; p < P; ++p)
            last[p] = UINT32_MAX;
        uint32_t counts[P] = {0};
        uint64_t zeros = 0;
        for (uint32_t k = 0; k < TOTAL; ++k) {
            uint32_t p, s;
            sample_order_at(k, P, SPP, o.band, &p, &s);
            assert_true(p < P && s < SPP);
            assert_int_equal(seen[(uint64_t)s * P + p]++, 0);
            assert_true(last[p] == UINT32_MAX ? s == 0 : s == last[p] + 1);
            last[p] = s;
            assert_int_equal(sample_order_index(p, s, P, SPP, o.band), k);
            counts[p]++;
            zeros += s == 0;
            assert_int_equal(sample_order_zero_count(&o, k, 1), s == 0);
            if (k % 13 == 0) /* the prefix [0, k + 1) */
                for (uint32_t q = 0; q < P; ++q)
                    assert_int_equal(sample_order_count(q, k + 1, P, SPP, o.band), counts[q]);
        }
        assert_int_equal(zeros, P);
        uint32_t band = o.band && o.band < P ? o.band : P;
        for (uint32_t k = 0; k < TOTAL; k += 7)
            for (uint32_t count = 1; k + count <= TOTAL; count = count * 3 + 1) {
                uint32_t p0, p1, p, s;
                sample_order_pixels(k, count, P, SPP, o.band, &p0, &p1);
                assert_true(p0 < p1 && p1 <= P);
                assert_int_equal(p0 % band, 0);
                assert_true(p1 == P || p1 % band == 0);
                for (uint32_t j = k; j < k + count; ++j) {
                    sample_order_at(j, P, SPP, o.band, &p, &s);
                    assert_true(p >= p0 && p < p1);
                }
                /* The first and last samples' bands, and every band between. */
                sample_order_at(k, P, SPP, o.band, &p, &s);
                assert_int_equal(p0, p / band * band);
                sample_order_at(k + count - 1, P, SPP, o.band, &p, &s);
                assert_int_equal(p1, p / band * band + band < P ? p / band * band + band : P);
            }
        assert_int_equal(sample_order_zero_count(&o, 0, TOTAL), P);
        assert_int_equal(sample_order_zero_count(&o, 17, TOTAL - 40),
                         sample_order_zero_count(&o, 0, TOTAL) -
                             sample_order_zero_count(&o, 0, 17) -
                             sample_order_zero_count(&o, TOTAL - 23, 23));
    }
    /* Bands from a sample budget: whole rows, one band when they would hold the image. */
    assert_int_equal(sample_order_band(W, H, SPP, (uint64_t)W * SPP * 3 + 5), 3 * W);
    assert_int_equal(sample_order_band(W, H, SPP, 1), W);
    assert_int_equal(sample_order_band(W, H, SPP, TOTAL), 0);
    assert_int_equal(sample_order_band(W, H, SPP, TOTAL - 1), (H - 1) * W);
}

/* udiv gives n / d for divisors of every size and numerators at and about their multiples,
 * the ends of the 32-bit range and at random; sample_order_at_ready, with the divisors
 * sample_order_divs makes, is sample_order_at for every sample of the test's orders and of
 * a 1280x720 frame's first and last bands. */
static void test_division_by_multiplication(void **state)
{
    (void)state;
    static const uint32_t ds[] = {1u,          2u,         3u,          5u,          7u,
                                  37u,         641u,       1280u,       4096u,       65537u,
                                  921600u,     14745600u,  0x7fffffffu, 0x80000000u, 0x80000001u,
                                  0xfffffffeu, 0xffffffffu};
    uint32_t x = 12345u;
    for (size_t i = 0; i < sizeof ds / sizeof *ds; ++i) {
        ts_udiv u = udiv_make(ds[i]);
        static const uint32_t ends[] = {0u, 1u, 2u, 0x7fffffffu, 0x80000000u, 0xffffffffu};
        for (size_t j = 0; j < sizeof ends / sizeof *ends; ++j)
            assert_int_equal(udiv(ends[j], u), ends[j] / ds[i]);
        for (uint64_t q = 1; q < 2000 && q * ds[i] <= UINT32_MAX; ++q)
            for (uint64_t n = q * ds[i] - 1; n <= q * ds[i] + 1 && n <= UINT32_MAX; ++n)
                assert_int_equal(udiv((uint32_t)n, u), (uint32_t)n / ds[i]);
        for (int j = 0; j < 20000; ++j) {
            x = x * 1664525u + 1013904223u;
            assert_int_equal(udiv(x, u), x / ds[i]);
        }
    }
    for (int j = 0; j < 20000; ++j) { /* random divisors */
        x = x * 1664525u + 1013904223u;
        uint32_t d = (x >> 7) | 1u, n = x * 2654435761u;
        assert_int_equal(udiv(n, udiv_make(d)), n / d);
    }
    for (size_t b = 0; b < sizeof bands / sizeof *bands; ++b) {
        ts_order_divs o = sample_order_divs(P, W, SPP, bands[b]);
        for (uint32_t k = 0; k < TOTAL; ++k) {
            uint32_t p, s, p2, s2;
            sample_order_at(k, P, SPP, bands[b], &p, &s);
            sample_order_at_ready(k, o, &p2, &s2);
            assert_int_equal(p2, p);
            assert_int_equal(s2, s);
            assert_int_equal(udiv(p, o.width), p / W);
        }
        assert_int_equal(o.mask, sampler_mask(SPP));
    }
    const uint32_t w = 1280, npix = 1280 * 720, spp = 16, band = 36 * 1280;
    ts_order_divs o = sample_order_divs(npix, w, spp, band);
    for (uint32_t k = 0; k < npix * spp;
         k += k < 2000000u || k > npix * spp - 2000000u ? 1u : 4099u) {
        uint32_t p, s, p2, s2;
        sample_order_at(k, npix, spp, band, &p, &s);
        sample_order_at_ready(k, o, &p2, &s2);
        assert_int_equal(p2, p);
        assert_int_equal(s2, s);
    }
}

static void assert_same_films(const ts_film_state *a, const ts_film_state *b)
{
    assert_memory_equal(a->accum, b->accum, P * sizeof(ts_vec4));
    assert_memory_equal(a->aov, b->aov, P * sizeof(ts_vec4));
    assert_memory_equal(a->albedo, b->albedo, P * sizeof(ts_vec4));
}

/* A unit's result as a device hands it back: its samples' radiance and the AOVs of the
 * samples 0 among them. */
static void trace(const ts_sample_order *o, const ts_unit *u, ts_unit_result *r)
{
    ts_error err = {0};
    assert_int_equal(unit_result_alloc(r, u, o, &err), TS_OK);
    uint64_t j = 0;
    for (uint64_t k = 0; k < u->count; ++k) {
        uint64_t v = value_at(o, u->first + k);
        r->radiance[k] = radiance[v];
        if (v < P) { /* sample 0 */
            assert_true(j < r->aov_count);
            r->aov[j] = aov[v], r->albedo[j] = albedo[v], ++j;
        }
    }
    assert_int_equal(j, r->aov_count);
    r->rays = u->count;
}

/* Units of every size, merged in order, give film.cl's sums for any wave size and any
 * bands, and those are the plain per-pixel sums. */
static void test_merge_in_order_is_the_film(void **state)
{
    (void)state;
    ts_film_state plain, ref, f;
    film_alloc(&plain);
    film_plain(&plain);
    for (size_t b = 0; b < sizeof bands / sizeof *bands; ++b) {
        ts_sample_order o = order_of(bands[b]);
        const uint64_t waves[] = {1, 64, 1000, TOTAL};
        for (size_t w = 0; w < sizeof waves / sizeof *waves; ++w) {
            film_alloc(&ref);
            film_reference(&ref, &o, 0, waves[w]);
            assert_same_films(&plain, &ref);
            film_state_free(&ref);
        }
        const uint64_t sizes[] = {1, 7, P - 1, P, P + 5, 3 * P, TOTAL};
        for (size_t k = 0; k < sizeof sizes / sizeof *sizes; ++k) {
            film_alloc(&f);
            for (uint64_t first = 0, i = 0; first < TOTAL; first += sizes[k], ++i) {
                ts_unit u = {.index = (uint32_t)i,
                             .first = first,
                             .count = TOTAL - first < sizes[k] ? TOTAL - first : sizes[k]};
                ts_unit_result r;
                trace(&o, &u, &r);
                units_merge(&f, &o, &u, &r);
                unit_result_free(&r);
            }
            assert_same_films(&plain, &f);
            film_state_free(&f);
        }
    }
    /* Another order of the same additions (odd passes summed apart, then added) differs:
     * the values are such that order shows. */
    size_t differ = 0;
    for (uint32_t p = 0; p < P; ++p) {
        float even = 0.0f, odd = 0.0f;
        for (uint32_t s = 0; s < SPP; ++s)
            *(s % 2 ? &odd : &even) += radiance[(uint64_t)s * P + p].x;
        differ += even + odd != plain.accum[p].x;
    }
    assert_true(differ > P / 10);
    film_state_free(&plain);
}

/* Threads that take units, finish them in random order and sometimes give them back. */
typedef struct taker {
    ts_board *b;
    const ts_sample_order *o;
    uint64_t seed;
    uint32_t units, given_back;
} taker;

static void *taker_main(void *arg)
{
    taker *t = arg;
    ts_unit u;
    while (board_take(t->b, &u)) {
        uint64_t r = rng_next(&t->seed);
        nanosleep(&(struct timespec){0, (long)(r % 200000)}, NULL);
        if (r % 7 == 0) {
            board_give_back(t->b, &u);
            t->given_back++;
            continue;
        }
        ts_unit_result res;
        trace(t->o, &u, &res);
        board_done(t->b, &u, &res);
        t->units++;
    }
    return NULL;
}

/* The film holding `held` (each run merged as a unit would be). */
static void film_holding(ts_film_state *f, const ts_sample_order *o, const ts_done *held)
{
    film_alloc(f);
    for (uint32_t i = 0; i < held->count; ++i) {
        ts_unit u = {.first = held->r[i].first, .count = held->r[i].end - held->r[i].first};
        ts_unit_result r;
        trace(o, &u, &r);
        units_merge(f, o, &u, &r);
        unit_result_free(&r);
    }
}

/* The units of what a film lacks: one a band, each inside its band (bands of one pixel,
 * one device's order: whole pixels gathered into units of 4096 samples or more, cut only by
 * what the film holds and the frame's end), no two with a pixel in common, together exactly
 * the samples not held. */
static void assert_units_partition(const ts_sample_order *o, const ts_done *held)
{
    ts_unit *u;
    uint32_t n;
    ts_error err = {0};
    assert_int_equal(units_list(o, TOTAL, held, 0, &u, &n, &err), TS_OK);
    static uint8_t covered[TOTAL], owner_set[P];
    static uint32_t owner[P];
    memset(covered, 0, sizeof covered);
    memset(owner_set, 0, sizeof owner_set);
    for (uint32_t i = 0; i < held->count; ++i)
        for (uint64_t k = held->r[i].first; k < held->r[i].end; ++k)
            covered[k] = 1;
    for (uint32_t i = 0; i < n; ++i) {
        assert_int_equal(u[i].index, i);
        for (uint64_t k = u[i].first; k < u[i].first + u[i].count; ++k) {
            assert_int_equal(covered[k]++, 0);
            uint32_t p, smp;
            sample_order_at((uint32_t)k, P, SPP, o->band, &p, &smp);
            if (owner_set[p]) assert_int_equal(owner[p], i); /* no pixel in two units */
            owner_set[p] = 1, owner[p] = i;
        }
    }
    for (uint64_t k = 0; k < TOTAL; ++k)
        assert_int_equal(covered[k], 1);
    for (uint32_t i = 0; o->band == 1u && i + 1u < n; ++i)
        if (u[i].first + u[i].count == u[i + 1].first) assert_true(u[i].count >= 4096u);
    if (o->band == 1u) assert_true(n < TOTAL / 4096u + 4u);
    free(u);
}

/* Bands of one pixel (one device's order) resumed on several devices: units_list gathers
 * the rest of the pixel the film holds a prefix of, and whole pixels after it, into units of
 * at least 4096 samples, which cover exactly what the film lacks. */
static void test_units_gather_one_pixel_bands(void **state)
{
    (void)state;
    const uint32_t pixels = 4000, spp = 3;
    ts_sample_order o = {pixels, spp, 1u};
    uint64_t total = (uint64_t)pixels * spp;
    ts_done held = {0};
    ts_error err = {0};
    assert_int_equal(done_add(&held, 0, 1001, &err), TS_OK); /* pixel 333's first two samples */
    ts_unit *u;
    uint32_t n;
    assert_int_equal(units_list(&o, total, &held, 0, &u, &n, &err), TS_OK);
    /* 1 + 1365 pixels = 4096, then 1366 pixels = 4098 (4096 rounded up to pixels), the rest */
    assert_int_equal(n, 3u);
    uint64_t at = 1001;
    for (uint32_t i = 0; i < n; ++i) {
        assert_int_equal(u[i].index, i);
        assert_int_equal(u[i].first, at); /* contiguous: together exactly [1001, total) */
        at += u[i].count;
        if (i > 0) assert_int_equal(u[i].first % spp, 0); /* whole pixels */
        if (i + 1 < n) assert_true(u[i].count >= 4096u && u[i].count < 4096u + spp);
    }
    assert_int_equal(u[0].count, 4096u);
    assert_int_equal(at, total);
    free(u);
    done_free(&held);
}

/* The last sixteenth of a frame's samples goes in units a quarter the size (no smaller than
 * 4096 samples), so that the devices' last units end closer together; the units still
 * cover the frame exactly, in whole pixels. */
static void test_units_smaller_at_the_frame_end(void **state)
{
    (void)state;
    const uint32_t pixels = 100000, spp = 4;
    const uint64_t gather = 16384, total = (uint64_t)pixels * spp, tail = total - total / 16;
    ts_sample_order o = {pixels, spp, 1u};
    ts_done none = {0};
    ts_error err = {0};
    ts_unit *u;
    uint32_t n, small = 0;
    assert_int_equal(units_list(&o, total, &none, gather, &u, &n, &err), TS_OK);
    uint64_t at = 0;
    for (uint32_t i = 0; i < n; ++i) {
        assert_int_equal(u[i].first, at);
        assert_int_equal(u[i].first % spp, 0);
        at += u[i].count;
        if (i + 1 == n) break; /* the frame's end cuts the last one */
        if (u[i].first < tail) {
            assert_int_equal(u[i].count, gather);
        } else {
            assert_int_equal(u[i].count, 4096u);
            ++small;
        }
    }
    assert_int_equal(at, total);
    assert_true(small >= (total - tail) / 4096u - 1u); /* not one large unit at the end */
    free(u);
}

/* Four threads sharing a board: units merged as they finish, in any order, give the plain
 * sums bit for bit, from a film that held nothing, a prefix ending inside a band, or a
 * prefix and two later bands (what an interrupted several-device render leaves); every
 * unit is merged once and the board records what the film holds. */
static void test_board_merges_in_any_order(void **state)
{
    (void)state;
    ts_film_state ref, f;
    film_alloc(&ref);
    film_plain(&ref);
    const uint32_t shapes[] = {0, 1, 3 * W}; /* one band, pixel after pixel, rows */
    for (int bi = 0; bi < 3; ++bi) {
        uint32_t band = shapes[bi];
        ts_sample_order o = order_of(band);
        uint64_t span = (band ? band : P) * (uint64_t)SPP;
        for (int start = 0; start < 3; ++start) {
            ts_done held = {0};
            ts_error err = {0};
            if (start >= 1) assert_int_equal(done_add(&held, 0, span / 2 + 13, &err), TS_OK);
            if (start == 2 && band) {
                assert_int_equal(done_add(&held, 2 * span, 3 * span, &err), TS_OK);
                assert_int_equal(done_add(&held, 3 * span, 3 * span + 40, &err), TS_OK);
            }
            assert_units_partition(&o, &held);
            film_holding(&f, &o, &held);
            ts_board b;
            assert_int_equal(board_init(&b, &f, &o, TOTAL, 0, &held, &err), TS_OK);
            assert_int_equal(b.start, done_samples(&held));
            taker t[4];
            pthread_t th[4];
            for (int i = 0; i < 4; ++i) {
                t[i] = (taker){&b, &o, 1000u + (uint64_t)i + band + (uint64_t)start, 0, 0};
                assert_int_equal(pthread_create(&th[i], NULL, taker_main, &t[i]), 0);
            }
            uint32_t units = 0;
            for (int i = 0; i < 4; ++i) {
                pthread_join(th[i], NULL);
                units += t[i].units;
            }
            assert_true(board_finished(&b));
            assert_int_equal(units, b.unit_count);
            assert_int_equal(board_samples_done(&b), TOTAL);
            ts_done all = {0};
            assert_int_equal(board_held(&b, &all, &err), TS_OK);
            assert_int_equal(all.count, 1);
            assert_true(all.r[0].first == 0 && all.r[0].end == TOTAL);
            done_free(&all);
            assert_same_films(&ref, &f);
            ts_unit u;
            assert_int_equal(board_try_take(&b, &u), -1);
            board_free(&b);
            film_state_free(&f);
            done_free(&held);
        }
    }
    film_state_free(&ref);
}

/* try_take hands units out in order, a given-back one first, 0 while units are out, -1 when
 * nothing can come; units merge as they finish, out of order, and the board records the
 * runs the films hold; a closed board hands out nothing but still merges, a frozen one
 * merges nothing more. */
static void test_board_take_give_back_close(void **state)
{
    (void)state;
    ts_film_state f;
    ts_board b;
    ts_error err = {0};
    ts_sample_order o = order_of(W); /* one row a band: 11 units of W * SPP samples */
    const uint64_t span = (uint64_t)W * SPP;
    board_open(&b, &f, &o);
    assert_int_equal(b.unit_count, H);
    ts_unit u[H + 1];
    for (int i = 0; i < H; ++i) {
        assert_int_equal(board_try_take(&b, &u[i]), 1);
        assert_int_equal(u[i].index, (uint32_t)i);
        assert_int_equal(u[i].first, span * (uint64_t)i);
        assert_int_equal(u[i].count, span);
    }
    assert_int_equal(board_try_take(&b, &u[H]), 0); /* all out */
    ts_unit_result r;
    trace(&o, &u[1], &r);
    board_done(&b, &u[1], &r); /* merged at once, before unit 0 */
    assert_int_equal(board_samples_done(&b), span);
    ts_done held = {0};
    assert_int_equal(board_held(&b, &held, &err), TS_OK);
    assert_true(held.count == 1 && held.r[0].first == span && held.r[0].end == 2 * span);
    done_free(&held);
    board_give_back(&b, &u[0]);
    assert_int_equal(board_try_take(&b, &u[H]), 1);
    assert_int_equal(u[H].index, 0); /* the given-back unit first */
    trace(&o, &u[H], &r);
    board_done(&b, &u[H], &r);
    assert_int_equal(board_samples_done(&b), 2 * span);
    board_close(&b);
    assert_int_equal(board_try_take(&b, &u[0]), -1);
    assert_int_equal(board_take(&b, &u[0]), 0);
    trace(&o, &u[5], &r);
    board_done(&b, &u[5], &r); /* a unit out when the board closed */
    assert_int_equal(board_samples_done(&b), 3 * span);
    assert_int_equal(board_held(&b, &held, &err), TS_OK);
    assert_int_equal(held.count, 2);
    assert_true(held.r[1].first == 5 * span && held.r[1].end == 6 * span);
    char text[128];
    assert_true(done_format(&held, text, sizeof text));
    ts_done back = {0};
    assert_int_equal(done_parse(text, &o, TOTAL, &back, &err), TS_OK);
    assert_int_equal(back.count, 2);
    assert_int_equal(done_samples(&back), 3 * span);
    /* A run starting inside a band is no such file's. */
    done_free(&back);
    assert_int_equal(done_parse("0-10 40-50", &o, TOTAL, &back, &err), TS_E_USAGE);
    ts_error_clear(&err);
    done_free(&held);
    board_freeze(&b);
    trace(&o, &u[7], &r);
    board_done(&b, &u[7], &r); /* dropped */
    assert_int_equal(board_samples_done(&b), 3 * span);
    assert_false(board_finished(&b));
    board_free(&b);
    film_state_free(&f);
}

static void sleep_ms(long ms)
{
    nanosleep(&(struct timespec){ms / 1000, ms % 1000 * 1000000L}, NULL);
}

/* A change between a look at the board (board_changes) and the wait is not slept through:
 * frame_wait once slept its whole 0.25 s when the last unit was merged while it wrote the
 * EXR's rows (a quarter of the displaced teapot's 1.5 s frame on two devices, one run in
 * three). */
static void test_board_wait_sees_a_change_it_missed(void **state)
{
    (void)state;
    ts_film_state f;
    ts_board b;
    ts_sample_order o = order_of(W);
    board_open(&b, &f, &o);
    uint64_t seen = board_changes(&b);
    ts_unit u;
    ts_unit_result r;
    assert_int_equal(board_try_take(&b, &u), 1);
    trace(&o, &u, &r);
    board_done(&b, &u, &r);
    assert_true(board_changes(&b) > seen);
    double t0 = stats_now();
    board_wait(&b, 30.0, seen);
    assert_true(stats_now() - t0 < 10.0);
    board_free(&b);
    film_state_free(&f);
}

/* A board of order o into film f (board_open) whose unit 0 device 2 holds (*slow) while device 1
 * takes and finishes every other unit, `ms` milliseconds each. */
static void board_with_slow_holder(ts_board *b, ts_film_state *f, const ts_sample_order *o,
                                   ts_unit *slow, long ms)
{
    board_open(b, f, o);
    assert_true(board_take_as(b, 2, slow));
    assert_true(slow->index == 0 && slow->taker == 2 && !slow->backup);
    for (uint32_t i = 1; i < b->unit_count; ++i) {
        ts_unit u;
        ts_unit_result r;
        assert_true(board_take_as(b, 1, &u));
        assert_true(u.index == i && u.taker == 1 && !u.backup);
        sleep_ms(ms);
        trace(o, &u, &r);
        assert_int_equal(board_done(b, &u, &r), 1);
    }
}

/* Backup units (units.h): a device that finished its units is handed a copy of the unit a
 * slow device still holds; whichever copy ends first is merged, the other dropped, and the
 * films are the one-device films either way. */
static void test_board_backs_up_a_slow_device(void **state)
{
    (void)state;
    ts_sample_order o = order_of(W); /* 11 units */
    ts_film_state ref;
    film_alloc(&ref);
    film_reference(&ref, &o, 0, TOTAL);
    for (int slow_wins = 0; slow_wins < 2; ++slow_wins) {
        ts_film_state f;
        ts_board b;
        ts_unit slow, u, copy;
        ts_unit_result r;
        board_with_slow_holder(&b, &f, &o, &slow, 2); /* the fast device: 2 ms a unit */
        /* Nothing new is left; the slow device's speed is unknown until it has held its
         * unit 4 times as long as the fast one needs: then the backup. */
        assert_true(board_take_as(&b, 1, &copy));
        assert_true(copy.index == 0 && copy.taker == 1 && copy.backup);
        assert_int_equal(b.backups_taken, 1);
        assert_false(board_dropped(&b, &slow));
        const ts_unit *first = slow_wins ? &slow : &copy, *second = slow_wins ? &copy : &slow;
        trace(&o, first, &r);
        assert_int_equal(board_done(&b, first, &r), 1);
        assert_true(board_dropped(&b, second)); /* told to stop */
        if (slow_wins) {
            trace(&o, second, &r);
            assert_int_equal(board_done(&b, second, &r), 0); /* finished, but dropped */
        } else {
            board_give_back(&b, second); /* stopped between two waves */
        }
        assert_true(board_finished(&b));
        assert_int_equal(board_samples_done(&b), TOTAL);
        assert_int_equal(board_take_as(&b, 1, &u), 0);
        assert_same_films(&ref, &f);
        board_free(&b);
        film_state_free(&f);
    }
    film_state_free(&ref);
}

typedef struct late_done {
    ts_board *b;
    const ts_sample_order *o;
    ts_unit u;
    long ms;
} late_done;

static void *finish_late(void *arg)
{
    late_done *l = arg;
    ts_unit_result r;
    sleep_ms(l->ms);
    trace(l->o, &l->u, &r);
    board_done(l->b, &l->u, &r);
    return NULL;
}

/* No backup of a device at least as fast as the taker (its speed known), nor of any with
 * TESSERA_BACKUP_UNITS=0: the taker waits for the last unit and gets none. A unit given back
 * while a backup of it is traced stays out; the backup is merged. */
static void test_board_backs_up_only_the_slow(void **state)
{
    (void)state;
    ts_sample_order o = order_of(W);
    for (int off = 0; off < 2; ++off) {
        if (off) setenv("TESSERA_BACKUP_UNITS", "0", 1);
        ts_film_state f;
        ts_board b;
        board_open(&b, &f, &o);
        unsetenv("TESSERA_BACKUP_UNITS");
        ts_unit u;
        ts_unit_result r;
        assert_true(board_take_as(&b, 2, &u)); /* device 2 traces a unit at 2 ms */
        sleep_ms(2);
        trace(&o, &u, &r);
        assert_int_equal(board_done(&b, &u, &r), 1);
        late_done late = {&b, &o, {0}, off ? 60 : 40};
        assert_true(board_take_as(&b, 2, &late.u)); /* and holds one for 40 or 60 ms */
        for (uint32_t i = 2; i < H; ++i) {          /* device 1 no faster (10 ms a unit) */
            assert_true(board_take_as(&b, 1, &u));
            sleep_ms(10);
            trace(&o, &u, &r);
            assert_int_equal(board_done(&b, &u, &r), 1);
        }
        pthread_t t;
        assert_int_equal(pthread_create(&t, NULL, finish_late, &late), 0);
        assert_int_equal(board_take_as(&b, 1, &u), 0); /* waits: no backup */
        pthread_join(t, NULL);
        assert_int_equal(b.backups_taken, 0);
        assert_true(board_finished(&b));
        board_free(&b);
        film_state_free(&f);
    }
    /* Given back by its first holder while the backup is out: the backup is merged. */
    ts_film_state f;
    ts_board b;
    ts_unit slow, u, copy;
    ts_unit_result r;
    board_with_slow_holder(&b, &f, &o, &slow, 1);
    assert_true(board_take_as(&b, 1, &copy) && copy.backup);
    board_give_back(&b, &slow);                  /* its device failed */
    assert_int_equal(board_try_take(&b, &u), 0); /* not handed out again: the copy is out */
    trace(&o, &copy, &r);
    assert_int_equal(board_done(&b, &copy, &r), 1);
    assert_true(board_finished(&b));
    board_free(&b);
    film_state_free(&f);
}

/* A frame whose patches do not fit takes larger units (app/workers.c worker_squeeze): before
 * any unit is handed out the board makes them again over the same samples, contiguous and in
 * whole pixels, fewer of them (the last sixteenth still in quarter units); not to a smaller
 * size, nor once one is out. A gated board (rank 0 of several MPI ranks) hands out nothing
 * until the first board_regather, which opens it whatever size it asks for. */
static void test_board_regathers_before_handing_out(void **state)
{
    (void)state;
    const uint32_t pixels = 40000, spp = 3;
    const uint64_t total = (uint64_t)pixels * spp, big = 30000;
    ts_sample_order o = {pixels, spp, 1u};
    ts_film_state f;
    ts_board b;
    ts_error err = {0};
    ts_unit u;
    assert_int_equal(film_state_alloc(&f, pixels, &err), TS_OK);
    assert_int_equal(board_init(&b, &f, &o, total, 4096, NULL, &err), TS_OK);
    uint32_t before = b.unit_count;
    assert_true(before >= 29);
    assert_int_equal(board_regather(&b, 1024), 0); /* smaller: as they were */
    assert_int_equal(b.unit_count, before);
    assert_int_equal(board_regather(&b, big), 1);
    assert_true(b.unit_count >= 4 && b.unit_count < before / 4);
    uint64_t at = 0;
    for (uint32_t i = 0; i < b.unit_count; ++i) {
        assert_int_equal(b.units[i].index, i);
        assert_int_equal(b.units[i].first, at);
        assert_int_equal(b.units[i].first % spp, 0);
        assert_true(b.units[i].count <= big + spp);
        at += b.units[i].count;
    }
    assert_int_equal(at, total);
    assert_int_equal(board_try_take(&b, &u), 1);
    assert_true(u.first == 0 && u.count >= big && u.count < big + spp);
    uint32_t now = b.unit_count;
    assert_int_equal(board_regather(&b, 2 * big), 0); /* one is out: as they are */
    assert_int_equal(b.unit_count, now);
    board_free(&b);
    assert_int_equal(board_init(&b, &f, &o, total, 4096, NULL, &err), TS_OK);
    board_gate(&b);
    assert_int_equal(board_try_take(&b, &u), 0); /* gated: wait */
    assert_int_equal(board_regather(&b, 0), 0);  /* opens it, sizes unchanged */
    assert_int_equal(b.unit_count, before);
    assert_int_equal(board_try_take(&b, &u), 1);
    board_free(&b);
    film_state_free(&f);
}

/* The progress line's credit for the units out: nothing before a unit is merged; then each
 * unit out is credited its time out at the seconds a unit of weight the merged ones took,
 * at most 90% of its weight; merged units are not counted twice. Samples weigh 1 here
 * (eta_init without costs), the times are set on the board as its takes would have. */
static void test_board_credits_units_in_flight(void **state)
{
    (void)state;
    ts_film_state f;
    ts_board b;
    ts_error err = {0};
    ts_sample_order o = order_of(W); /* one row a band: units of W * SPP samples */
    const double span = (double)W * SPP;
    ts_eta eta;
    assert_int_equal(eta_init(&eta, NULL, W * H, SPP, W, &err), TS_OK);
    board_open(&b, &f, &o);
    ts_unit u[3];
    for (int i = 0; i < 3; ++i)
        assert_int_equal(board_try_take(&b, &u[i]), 1);
    double now = stats_now();
    b.since[0] = now - 100.0, b.since[1] = now - 100.0;
    assert_true(board_work_in_flight(&b, &eta, now) == 0.0); /* no rate yet */
    ts_unit_result r;
    trace(&o, &u[0], &r);
    assert_int_equal(board_done(&b, &u[0], &r), 1); /* took about 100 s */
    double took = b.took[0];
    assert_true(took >= 100.0 && took < 101.0);
    b.since[1] = now - took / 4, b.since[2] = now - took / 2;
    double c = board_work_in_flight(&b, &eta, now);
    assert_true(c > 0.749 * span && c < 0.751 * span); /* a quarter and a half */
    b.since[1] = now - 10 * took;
    c = board_work_in_flight(&b, &eta, now);
    assert_true(c > 1.399 * span && c < 1.401 * span); /* 0.9 at most, and a half */
    trace(&o, &u[1], &r);
    assert_int_equal(board_done(&b, &u[1], &r), 1);
    c = board_work_in_flight(&b, &eta, now); /* rate: (took + 10 took) / 2 units */
    double expect = (took / 2) / ((took + (b.took[1])) / 2) * span;
    assert_true(c > 0.999 * expect && c < 1.001 * expect);
    assert_true(board_work_finished(&b, &eta) == 2 * span);
    eta_free(&eta);
    board_free(&b);
    film_state_free(&f);
}

/* Units that dice again (the frame's patches do not fit: each unit a wave): the board hands
 * eta_units_left each unit's weight, its seconds (merged: taken to merged; out: so far) and
 * what its result says it diced, and the estimate waits for a unit that evicted. */
static void test_board_units_left_when_units_dice_again(void **state)
{
    (void)state;
    ts_film_state f;
    ts_board b;
    ts_error err = {0};
    ts_sample_order o = order_of(W); /* one row a band: H units of W * SPP samples */
    const double span = (double)W * SPP;
    ts_eta eta;
    assert_int_equal(eta_init(&eta, NULL, W * H, SPP, W, &err), TS_OK);
    board_open(&b, &f, &o);
    assert_int_equal(b.unit_count, H);
    ts_unit u[3];
    for (int i = 0; i < 3; ++i)
        assert_int_equal(board_try_take(&b, &u[i]), 1);
    double now = stats_now();
    for (int i = 0; i < 3; ++i)
        b.since[i] = b.started[i] = now - 100.0;
    ts_unit_result r;
    trace(&o, &u[0], &r);
    r.dicing = 60.0, r.evicted = 0; /* fits: the weights' rate holds */
    assert_int_equal(board_done(&b, &u[0], &r), 1);
    assert_true(board_units_left(&b, &eta, now, 2, NULL) == -1.0);
    trace(&o, &u[1], &r);
    r.dicing = 60.0, r.evicted = 1;
    assert_int_equal(board_done(&b, &u[1], &r), 1);
    now = b.since[0] + b.took[1]; /* when unit 1 was merged: units 1 and 2 out as long */
    double took0 = b.took[0], took1 = b.took[1];
    /* a unit: its weight at (took0 + took1 - 60) / (2 span), plus 60 s of dicing */
    double unit = (took0 + took1 - 60.0) / 2.0 + 60.0, out = unit - took1;
    double k = H - 3; /* units not out */
    double credit = -1.0, one = board_units_left(&b, &eta, now, 1, NULL);
    double two = board_units_left(&b, &eta, now, 2, &credit);
    assert_true(fabs(one - (out + k * unit)) < 1e-6 * one);
    /* two devices: the one free takes the first, the other its next as unit 2 ends, ... */
    double even = (double)((int)k / 2), odd = k - even; /* units to the free one, to the other */
    double expect = fmax(odd * unit, out + even * unit);
    assert_true(fabs(two - expect) < 1e-6 * two);
    /* the line's credit: unit 2, out as long as unit 1 took, for that share of a unit */
    double w2 = eta_work(&eta, u[2].first + u[2].count) - eta_work(&eta, u[2].first);
    assert_true(fabs(credit - w2 * fmin(took1 / unit, 0.9)) < 1e-6 * w2);
    /* a unit out keeps its device's passes so far; one merged, its result's */
    ts_eta_passes p = {.end = {1, 2}, .count = 2, .started = 3};
    board_unit_passes(&b, &u[2], &p);
    assert_int_equal(b.passes[u[2].index].count, 2);
    board_unit_passes(&b, &u[1], &p); /* merged: kept as its result said */
    assert_int_equal(b.passes[u[1].index].count, 0);
    (void)span;
    eta_free(&eta);
    board_free(&b);
    film_state_free(&f);
}

/* An MPI rank takes its next unit while it traces one (board_try_take_for): that unit begins
 * when the one before is done with, merged or given back, and waits until then. */
static void test_board_owner_takes_ahead(void **state)
{
    (void)state;
    ts_film_state f;
    ts_board b;
    ts_sample_order o = order_of(W);
    board_open(&b, &f, &o);
    const uint32_t rank = TS_BOARD_TAKERS + 1;
    ts_unit u[4];
    assert_int_equal(board_try_take_for(&b, rank, &u[0]), 1);
    assert_int_equal(board_try_take_for(&b, rank, &u[1]), 1);
    assert_int_equal(board_try_take_for(&b, rank, &u[2]), 1);
    assert_int_equal(board_try_take_for(&b, rank + 1, &u[3]), 1); /* another rank's: begins */
    assert_true(b.started[u[0].index] == b.since[u[0].index]);
    assert_true(b.started[u[1].index] < 0.0 && b.started[u[2].index] < 0.0);
    assert_true(b.started[u[3].index] == b.since[u[3].index]);
    double before = stats_now();
    ts_unit_result r;
    trace(&o, &u[0], &r);
    assert_int_equal(board_done(&b, &u[0], &r), 1);
    assert_true(b.started[u[1].index] >= before); /* the next in order begins */
    assert_true(b.started[u[2].index] < 0.0);
    board_give_back(&b, &u[1]);
    assert_true(b.started[u[2].index] >= before);
    board_free(&b);
    film_state_free(&f);
}

static void test_units_plan(void **state)
{
    (void)state;
    uint64_t u;
    units_plan(640 * 360 * 16, 2, &u);
    assert_int_equal(u, 57600); /* 3686400 / 64, a multiple of 64 */
    units_plan(1000, 2, &u);
    assert_int_equal(u, 4096);
    units_plan((uint64_t)1 << 32, 1, &u);
    assert_int_equal(u, 1u << 20);
    units_plan(1 << 24, 3, &u);
    assert_int_equal(u % 64, 0);
    setenv("TESSERA_UNIT_SAMPLES", "77", 1);
    units_plan(1 << 24, 3, &u);
    unsetenv("TESSERA_UNIT_SAMPLES");
    assert_int_equal(u, 77);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sample_order_is_a_permutation),
        cmocka_unit_test(test_division_by_multiplication),
        cmocka_unit_test(test_merge_in_order_is_the_film),
        cmocka_unit_test(test_board_merges_in_any_order),
        cmocka_unit_test(test_units_gather_one_pixel_bands),
        cmocka_unit_test(test_units_smaller_at_the_frame_end),
        cmocka_unit_test(test_board_take_give_back_close),
        cmocka_unit_test(test_board_wait_sees_a_change_it_missed),
        cmocka_unit_test(test_board_backs_up_a_slow_device),
        cmocka_unit_test(test_board_backs_up_only_the_slow),
        cmocka_unit_test(test_board_regathers_before_handing_out),
        cmocka_unit_test(test_board_credits_units_in_flight),
        cmocka_unit_test(test_board_units_left_when_units_dice_again),
        cmocka_unit_test(test_board_owner_takes_ahead),
        cmocka_unit_test(test_units_plan),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
