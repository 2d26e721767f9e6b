/* test_units.c — the units of a render on several devices (host/app/units.c), host only:
 * merging units in order gives the sums kernels/film.cl makes (a C copy of its loop, wave by
 * wave) bit for bit, whatever the unit size and whatever order threads finish them in, with
 * units given back and taken again; the window bounds what waits for the merge; a closed
 * board hands out nothing; units_plan's sizes. The radiance values span 12 orders of
 * magnitude, so any other order of the additions changes bits (asserted too). */
#include "app/units.h"

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

static ts_vec4 radiance[TOTAL], aov[TOTAL], albedo[TOTAL];

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

/* kernels/film.cl's loop in C: waves of `wave` samples from `start` on, each pixel's
 * samples added in order. */
static void film_reference(ts_film_state *f, uint64_t start, uint64_t wave)
{
    for (uint64_t first = start; first < TOTAL; first += wave) {
        uint64_t last = first + wave < TOTAL ? first + wave : TOTAL;
        for (uint32_t p = 0; p < P; ++p) {
            uint64_t s = first / P;
            if (s * P + p < first) ++s;
            ts_vec4 acc = f->accum[p];
            for (uint64_t g = s * P + p; g < last; g += P) {
                ts_vec4 r = radiance[g];
                acc.x += r.x;
                acc.y += r.y;
                acc.z += r.z;
                acc.w += 1.0f;
                if (g < P) f->aov[p] = aov[g], f->albedo[p] = albedo[g];
            }
            f->accum[p] = acc;
        }
    }
}

static void assert_same_films(const ts_film_state *a, const ts_film_state *b)
{
    assert_memory_equal(a->accum, b->accum, P * sizeof(ts_vec4));
    assert_memory_equal(a->aov, b->aov, P * sizeof(ts_vec4));
    assert_memory_equal(a->albedo, b->albedo, P * sizeof(ts_vec4));
}

/* A unit's result as a device hands it back: its samples' radiance and pass-0 AOVs. */
static void trace(const ts_unit *u, ts_unit_result *r)
{
    ts_error err = {0};
    assert_int_equal(unit_result_alloc(r, u, P, &err), TS_OK);
    memcpy(r->radiance, &radiance[u->first], u->count * sizeof(ts_vec4));
    if (r->aov_count) {
        memcpy(r->aov, &aov[u->first], r->aov_count * sizeof(ts_vec4));
        memcpy(r->albedo, &albedo[u->first], r->aov_count * sizeof(ts_vec4));
    }
    r->rays = u->count;
}

/* Units of every size, merged in order, give film.cl's sums for any wave size. */
static void test_merge_in_order_is_the_film(void **state)
{
    (void)state;
    ts_film_state ref, f;
    film_alloc(&ref);
    film_reference(&ref, 0, 1000);
    const uint64_t sizes[] = {1, 7, P - 1, P, P + 5, 3 * P, TOTAL};
    for (size_t k = 0; k < sizeof sizes / sizeof *sizes; ++k) {
        film_alloc(&f);
        for (uint64_t first = 0, i = 0; first < TOTAL; first += sizes[k], ++i) {
            ts_unit u = {(uint32_t)i, 0, first,
                         TOTAL - first < sizes[k] ? TOTAL - first : sizes[k]};
            ts_unit_result r;
            trace(&u, &r);
            units_merge(&f, P, &u, &r);
            unit_result_free(&r);
        }
        assert_same_films(&ref, &f);
        film_state_free(&f);
    }
    /* Another order of the same additions (odd passes summed apart, then added) differs:
     * the values are such that order shows. */
    film_alloc(&f);
    size_t differ = 0;
    for (uint32_t p = 0; p < P; ++p) {
        float even = 0.0f, odd = 0.0f;
        for (uint32_t s = 0; s < SPP; ++s)
            *(s % 2 ? &odd : &even) += radiance[(uint64_t)s * P + p].x;
        differ += even + odd != ref.accum[p].x;
    }
    assert_true(differ > P / 10);
    film_state_free(&f);
    film_state_free(&ref);
}

/* Threads that take units, finish them in random order and sometimes give them back. */
typedef struct taker {
    ts_board *b;
    uint64_t seed;
    uint32_t units, given_back;
    uint32_t max_ahead; /* the most units out beyond the merged ones, as seen */
} taker;

static void *taker_main(void *arg)
{
    taker *t = arg;
    ts_unit u;
    while (board_take(t->b, &u)) {
        pthread_mutex_lock(&t->b->lock);
        uint32_t ahead = t->b->next - t->b->merged;
        pthread_mutex_unlock(&t->b->lock);
        if (ahead > t->max_ahead) t->max_ahead = ahead;
        uint64_t r = rng_next(&t->seed);
        nanosleep(&(struct timespec){0, (long)(r % 200000)}, NULL);
        if (r % 7 == 0) {
            board_give_back(t->b, &u);
            t->given_back++;
            continue;
        }
        ts_unit_result res;
        trace(&u, &res);
        board_done(t->b, &u, &res);
        t->units++;
    }
    return NULL;
}

/* Four threads sharing a board from a resumed start: the films are film.cl's, every unit is
 * merged once, the window holds. */
static void test_board_merges_out_of_order_finishes(void **state)
{
    (void)state;
    const uint64_t start = 2 * P + 13; /* a resumed render: the films hold [0, start) */
    ts_film_state ref, f;
    film_alloc(&ref);
    film_reference(&ref, 0, 500);
    film_alloc(&f);
    for (uint64_t g = 0; g < start; ++g) {
        ts_unit u = {0, 0, g, 1};
        ts_unit_result r;
        trace(&u, &r);
        units_merge(&f, P, &u, &r);
        unit_result_free(&r);
    }
    ts_board b;
    ts_error err = {0};
    assert_int_equal(board_init(&b, &f, P, start, TOTAL, 29, 5, &err), TS_OK);
    taker t[4];
    pthread_t th[4];
    for (int i = 0; i < 4; ++i) {
        t[i] = (taker){&b, 1000u + (uint64_t)i, 0, 0, 0};
        assert_int_equal(pthread_create(&th[i], NULL, taker_main, &t[i]), 0);
    }
    uint32_t units = 0, given_back = 0;
    for (int i = 0; i < 4; ++i) {
        pthread_join(th[i], NULL);
        units += t[i].units, given_back += t[i].given_back;
        assert_true(t[i].max_ahead <= 5);
    }
    assert_true(board_finished(&b));
    assert_int_equal(units, b.unit_count);
    assert_int_equal(b.unit_count, (TOTAL - start + 28) / 29);
    assert_true(given_back > 0);
    assert_int_equal(board_samples_done(&b), TOTAL);
    assert_int_equal(b.samples_finished, TOTAL - start);
    assert_same_films(&ref, &f);
    ts_unit u;
    assert_int_equal(board_try_take(&b, &u), -1);
    board_free(&b);
    film_state_free(&f);
    film_state_free(&ref);
}

/* try_take: 0 while the window is full or units are out, -1 when nothing can come; a
 * closed board hands out nothing, but still merges what finishes. */
static void test_board_window_and_close(void **state)
{
    (void)state;
    ts_film_state f;
    film_alloc(&f);
    ts_board b;
    ts_error err = {0};
    assert_int_equal(board_init(&b, &f, P, 0, 10 * 100, 100, 3, &err), TS_OK);
    ts_unit u[4];
    for (int i = 0; i < 3; ++i) {
        assert_int_equal(board_try_take(&b, &u[i]), 1);
        assert_int_equal(u[i].index, (uint32_t)i);
        assert_int_equal(u[i].first, 100u * (uint64_t)i);
    }
    assert_int_equal(board_try_take(&b, &u[3]), 0); /* the window of 3 is full */
    ts_unit_result r;
    trace(&u[1], &r);
    board_done(&b, &u[1], &r);                      /* waits for unit 0 */
    assert_int_equal(board_try_take(&b, &u[3]), 0); /* still full: 0 is not merged */
    assert_int_equal(board_samples_done(&b), 0);
    board_give_back(&b, &u[0]);
    assert_int_equal(board_try_take(&b, &u[3]), 1);
    assert_int_equal(u[3].index, 0); /* the given-back unit first */
    trace(&u[3], &r);
    board_done(&b, &u[3], &r);
    assert_int_equal(board_samples_done(&b), 200); /* units 0 and 1 merged */
    board_close(&b);
    assert_int_equal(board_try_take(&b, &u[0]), -1);
    assert_int_equal(board_take(&b, &u[0]), 0);
    trace(&u[2], &r);
    board_done(&b, &u[2], &r); /* a unit out when the board closed */
    assert_int_equal(board_samples_done(&b), 300);
    assert_false(board_finished(&b));
    board_free(&b);
    film_state_free(&f);
}

static void test_units_plan(void **state)
{
    (void)state;
    uint64_t u;
    uint32_t w;
    units_plan(640 * 360 * 16, 2, &u, &w);
    assert_int_equal(u, 230400); /* 3686400 / 16, a multiple of 64 */
    assert_int_equal(w, 8);
    units_plan(1000, 2, &u, &w);
    assert_int_equal(u, 4096);
    units_plan((uint64_t)1 << 32, 1, &u, &w);
    assert_int_equal(u, 1u << 20);
    assert_int_equal(w, 8);
    units_plan((uint64_t)1 << 32, 8, &u, &w);
    assert_int_equal(w, 16); /* 32 would hold 512 MB of results: 256 MB of them */
    units_plan(1 << 24, 3, &u, &w);
    assert_int_equal(u % 64, 0);
    assert_int_equal(w, 12);
    setenv("TESSERA_UNIT_SAMPLES", "77", 1);
    units_plan(1 << 24, 3, &u, &w);
    unsetenv("TESSERA_UNIT_SAMPLES");
    assert_int_equal(u, 77);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_merge_in_order_is_the_film),
        cmocka_unit_test(test_board_merges_out_of_order_finishes),
        cmocka_unit_test(test_board_window_and_close),
        cmocka_unit_test(test_units_plan),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
