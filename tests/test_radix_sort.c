/* test_radix_sort.c — the `sort` stage (host/pipeline/sort.c) against a reference: qsort of the
 * valid pairs on (leaf, input position), which is the unique stable order. Host-only; never
 * skips.
 *
 * Inputs: sizes 0, 1, 7, 1000, 2^20; key ranges 1 .. 0xFFFFFFFE (0..4 passes, with and
 * without a partial top digit); 0 %, 50 % and 100 % TS_INVALID; each sorted by pools of 1, 2
 * and 3 threads. Tiny inputs use grain 1, so they are cut into up to RADIX_MAX_CHUNKS chunks
 * (the 2^20 ones into 32 by the default grain). Every result is compared pair by pair with
 * the reference, stability is asserted on its own (equal leaves keep input order), and the
 * segments are checked against the sorted pairs. radix_sort_windows (windows read only up
 * to their counts) is checked against the same reference on the windows filled up with
 * TS_INVALID.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "pipeline/sort.h"

#define THREAD_CASES 3 /* pools of 1, 2 and 3 threads */

static const uint32_t key_ranges[] = {
    1, 2, 255, 256, 257, 65536, 70000, 1u << 24, 0xFFFFFFFEu,
};
static const unsigned invalid_percents[] = {0, 50, 100};

/* splitmix64: a fixed seed per case makes every failure reproducible. */
static uint64_t rng_next(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* n pairs with leaves uniform in [0, key_range), each TS_INVALID with probability
 * invalid_percent / 100; window = input position, or a bijective hash of it if scramble. */
static void make_pairs(ts_pair *p, uint32_t n, uint32_t key_range, unsigned invalid_percent,
                       int scramble, uint64_t seed)
{
    uint64_t st = seed;
    for (uint32_t i = 0; i < n; i++) {
        uint64_t r = rng_next(&st);
        int invalid = (unsigned)(r % 100u) < invalid_percent;
        p[i].leaf = invalid ? TS_INVALID : (uint32_t)((r >> 32) % key_range);
        p[i].window = scramble ? (i * 2654435761u) ^ 0x5bd1e995u : i;
    }
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Reference: the valid pairs of in[] ordered by (leaf, input position). Returns the count. */
static uint32_t reference_sort(const ts_pair *in, uint32_t n, ts_pair *out)
{
    uint64_t *keys = malloc(((size_t)n + 1) * sizeof *keys);
    assert_non_null(keys);
    uint32_t m = 0;
    for (uint32_t i = 0; i < n; i++)
        if (in[i].leaf != TS_INVALID) keys[m++] = ((uint64_t)in[i].leaf << 32) | i;
    qsort(keys, m, sizeof *keys, cmp_u64);
    for (uint32_t j = 0; j < m; j++)
        out[j] = in[(uint32_t)keys[j]];
    free(keys);
    return m;
}

/* Segments of sorted[0, m): contiguous from 0 to m, non-empty, one leaf each, strictly
 * increasing leaves (so one per distinct leaf), the other fields 0. Returns the count. */
static uint32_t check_segments(const ts_pair *sorted, uint32_t m)
{
    ts_segment *seg = malloc(((size_t)m + 1) * sizeof *seg);
    assert_non_null(seg);
    uint32_t count = sort_segments(sorted, m, seg, m);
    assert_int_not_equal(count, UINT32_MAX);
    uint32_t distinct = 0;
    for (uint32_t i = 0; i < m; i++)
        distinct += (i == 0 || sorted[i].leaf != sorted[i - 1].leaf);
    assert_int_equal(count, distinct);
    uint32_t pos = 0;
    for (uint32_t k = 0; k < count; k++) {
        assert_int_equal(seg[k].begin, pos);
        assert_true(seg[k].end > seg[k].begin);
        if (k > 0) assert_true(seg[k].patch > seg[k - 1].patch);
        assert_int_equal(seg[k].vert_first, 0);
        assert_int_equal(seg[k].lod, 0);
        for (uint32_t i = seg[k].begin; i < seg[k].end; i++)
            assert_int_equal(sorted[i].leaf, seg[k].patch);
        pos = seg[k].end;
    }
    assert_int_equal(pos, m);
    free(seg);
    return count;
}

/* Stability on its own terms, for inputs whose window is the input position: leaves
 * non-decreasing, and within a leaf the windows increase. */
static void check_sorted_stable(const ts_pair *sorted, uint32_t m)
{
    for (uint32_t i = 1; i < m; i++) {
        assert_true(sorted[i - 1].leaf <= sorted[i].leaf);
        if (sorted[i - 1].leaf == sorted[i].leaf)
            assert_true(sorted[i - 1].window < sorted[i].window);
    }
}

typedef struct fixture {
    radix_sorter *sorters[THREAD_CASES]; /* pools of 1, 2, 3 threads */
} fixture;

static int group_setup(void **state)
{
    static fixture fx;
    for (int t = 0; t < THREAD_CASES; t++) {
        ts_error err = {0};
        fx.sorters[t] = radix_sorter_create(t + 1, &err);
        if (!fx.sorters[t]) return -1;
    }
    *state = &fx;
    return 0;
}

static int group_teardown(void **state)
{
    fixture *fx = *state;
    for (int t = 0; t < THREAD_CASES; t++)
        radix_sorter_destroy(fx->sorters[t]);
    return 0;
}

/* Sorts a copy of in[0, n) with s and asserts it equals expect[0, m). */
static void sort_and_compare(radix_sorter *s, const ts_pair *in, uint32_t n, uint32_t key_limit,
                             const ts_pair *expect, uint32_t m, int window_is_position)
{
    ts_pair *pairs = malloc(((size_t)n + 1) * sizeof *pairs);
    ts_pair *scratch = malloc(((size_t)n + 1) * sizeof *scratch);
    assert_non_null(pairs);
    assert_non_null(scratch);
    memcpy(pairs, in, (size_t)n * sizeof *pairs);
    const ts_pair *sorted = NULL;
    uint32_t valid = UINT32_MAX;
    ts_error err = {0};
    assert_int_equal(radix_sort_pairs(s, pairs, scratch, n, key_limit, &sorted, &valid, &err),
                     TS_OK);
    assert_int_equal(err.code, TS_OK);
    assert_true(sorted == pairs || sorted == scratch);
    assert_int_equal(valid, m);
    if (m > 0) assert_memory_equal(sorted, expect, (size_t)m * sizeof *sorted);
    if (window_is_position) check_sorted_stable(sorted, m);
    check_segments(sorted, m);
    free(pairs);
    free(scratch);
}

/* Every key range and invalid fraction at size n, each on 1, 2 and 3 threads. */
static void run_size(void **state, uint32_t n, uint32_t grain)
{
    fixture *fx = *state;
    ts_pair *in = malloc(((size_t)n + 1) * sizeof *in);
    ts_pair *expect = malloc(((size_t)n + 1) * sizeof *expect);
    assert_non_null(in);
    assert_non_null(expect);
    for (size_t r = 0; r < sizeof key_ranges / sizeof key_ranges[0]; r++) {
        for (size_t v = 0; v < sizeof invalid_percents / sizeof invalid_percents[0]; v++) {
            uint64_t seed = ((uint64_t)n << 20) ^ (r << 8) ^ v;
            make_pairs(in, n, key_ranges[r], invalid_percents[v], 0, seed);
            uint32_t m = reference_sort(in, n, expect);
            if (invalid_percents[v] == 0) assert_int_equal(m, n);
            if (invalid_percents[v] == 100) assert_int_equal(m, 0);
            for (int t = 0; t < THREAD_CASES; t++) {
                radix_sorter_set_grain(fx->sorters[t], grain);
                sort_and_compare(fx->sorters[t], in, n, key_ranges[r], expect, m, 1);
            }
        }
    }
    free(in);
    free(expect);
}

static void test_size_0(void **state)
{
    run_size(state, 0, 1);
}
static void test_size_1(void **state)
{
    run_size(state, 1, 1);
}
static void test_size_7(void **state)
{
    run_size(state, 7, 1);
}
static void test_size_1000(void **state)
{
    run_size(state, 1000, 1);
}
/* Default grain: 2^20 pairs spread over every thread of the pool. */
static void test_size_1m(void **state)
{
    run_size(state, 1u << 20, RADIX_DEFAULT_GRAIN);
}

static void test_pass_count(void **state)
{
    (void)state;
    const uint32_t limits[] = {
        0,           1,          2, 255, 256, 257, 65536, 65537, 70000, 1u << 24, (1u << 24) + 1,
        0xFFFFFFFEu, 0xFFFFFFFFu};
    const uint32_t passes[] = {0, 0, 1, 1, 1, 2, 2, 3, 3, 3, 4, 4, 4};
    for (size_t i = 0; i < sizeof limits / sizeof limits[0]; i++)
        assert_int_equal(radix_sort_pass_count(limits[i]), passes[i]);
}

/* Windows that do not follow input order: stability is by input position, not by window. */
static void test_scrambled_windows(void **state)
{
    fixture *fx = *state;
    const uint32_t n = 50000;
    ts_pair *in = malloc(n * sizeof *in), *expect = malloc(n * sizeof *expect);
    assert_non_null(in);
    assert_non_null(expect);
    make_pairs(in, n, 300, 30, 1, 99);
    uint32_t m = reference_sort(in, n, expect);
    for (int t = 0; t < THREAD_CASES; t++) {
        radix_sorter_set_grain(fx->sorters[t], 1000);
        sort_and_compare(fx->sorters[t], in, n, 300, expect, m, 0);
    }
    free(in);
    free(expect);
}

/* The layout top_level writes: ray i owns [i * n_per_ray, (i + 1) * n_per_ray), filled from
 * the front, the rest TS_INVALID. Sorted, every leaf's pairs come in ray order. */
static void test_ray_windows(void **state)
{
    fixture *fx = *state;
    const uint32_t rays = 20000, n_per_ray = 13, n = rays * n_per_ray, leaves = 5000;
    ts_pair *in = malloc(n * sizeof *in), *expect = malloc(n * sizeof *expect);
    assert_non_null(in);
    assert_non_null(expect);
    uint64_t st = 7;
    for (uint32_t i = 0; i < rays; i++) {
        uint32_t used = (uint32_t)(rng_next(&st) % (n_per_ray + 1));
        for (uint32_t k = 0; k < n_per_ray; k++) {
            uint32_t w = i * n_per_ray + k;
            in[w].leaf = k < used ? (uint32_t)(rng_next(&st) % leaves) : TS_INVALID;
            in[w].window = w;
        }
    }
    uint32_t m = reference_sort(in, n, expect);
    for (int t = 0; t < THREAD_CASES; t++) {
        radix_sorter_set_grain(fx->sorters[t], RADIX_DEFAULT_GRAIN);
        sort_and_compare(fx->sorters[t], in, n, leaves, expect, m, 1);
    }
    free(in);
    free(expect);
}

/* radix_sort_windows against radix_sort_pairs' contract: windows of which only the first
 * counts[w] are read give the reference order of the same windows filled up with TS_INVALID.
 * The unused tail of every window holds garbage leaves (>= key_limit, or TS_INVALID) that
 * must never be read; key ranges of 0 to 3 passes, one chunk and many, 1 to 3 threads. */
static void test_sort_windows(void **state)
{
    fixture *fx = *state;
    const uint32_t windows = 30000, width = 11, n = windows * width;
    const uint32_t ranges[] = {1, 32, 256, 5000, 1u << 20};
    ts_pair *in = malloc(n * sizeof *in), *filled = malloc(n * sizeof *filled);
    ts_pair *expect = malloc(n * sizeof *expect), *pairs = malloc(n * sizeof *pairs);
    ts_pair *scratch = malloc(n * sizeof *scratch);
    uint32_t *counts = malloc(windows * sizeof *counts);
    assert_true(in && filled && expect && pairs && scratch && counts);
    for (size_t r = 0; r < sizeof ranges / sizeof *ranges; r++) {
        uint64_t st = 11 + r;
        for (uint32_t w = 0; w < windows; w++) {
            /* mostly short windows, as on the teapot demo; some empty, some full */
            uint64_t x = rng_next(&st);
            counts[w] = x % 4u == 0u ? 0u : x % 7u == 0u ? width : (uint32_t)(x >> 40) % 3u;
            for (uint32_t k = 0; k < width; k++) {
                uint32_t i = w * width + k, used = k < counts[w];
                uint32_t garbage = (k & 1u) ? TS_INVALID : ranges[r] + (uint32_t)(x >> 50);
                in[i] = (ts_pair){used ? (uint32_t)(rng_next(&st) % ranges[r]) : garbage, i};
                filled[i] = (ts_pair){used ? in[i].leaf : TS_INVALID, i};
            }
        }
        uint32_t m = reference_sort(filled, n, expect);
        for (int t = 0; t < THREAD_CASES; t++)
            for (int g = 0; g < 2; g++) { /* 60 chunks, then one */
                radix_sorter_set_grain(fx->sorters[t], g == 0 ? 500u : RADIX_DEFAULT_GRAIN);
                memcpy(pairs, in, n * sizeof *pairs);
                const ts_pair *sorted = NULL;
                uint32_t valid = UINT32_MAX;
                ts_error err = {0};
                assert_int_equal(radix_sort_windows(fx->sorters[t], pairs, scratch, counts, windows,
                                                    width, ranges[r], &sorted, &valid, &err),
                                 TS_OK);
                assert_true(sorted == pairs || sorted == scratch);
                assert_int_equal(valid, m);
                if (m > 0) assert_memory_equal(sorted, expect, (size_t)m * sizeof *sorted);
                check_segments(sorted, m);
            }
    }
    /* a counted leaf >= key_limit is reported by its pair index, as radix_sort_pairs does */
    memcpy(pairs, in, n * sizeof *pairs);
    uint32_t w = 0;
    while (counts[w] == 0)
        ++w;
    pairs[w * width].leaf = 1u << 20;
    const ts_pair *sorted = NULL;
    uint32_t valid = 0;
    ts_error err = {0};
    char want[64];
    snprintf(want, sizeof want, "pair %u has leaf %u", w * width, 1u << 20);
    assert_int_equal(radix_sort_windows(fx->sorters[1], pairs, scratch, counts, windows, width,
                                        1u << 20, &sorted, &valid, &err),
                     TS_E_INTERNAL);
    assert_non_null(strstr(err.msg, want));
    assert_null(sorted);
    free(in);
    free(filled);
    free(expect);
    free(pairs);
    free(scratch);
    free(counts);
}

/* A pass whose digit is equal for every pair is skipped; the result stays right, and with
 * nothing to move at all it stays in `pairs`. */
static void test_skipped_passes(void **state)
{
    fixture *fx = *state;
    const uint32_t n = 4096;
    ts_pair *in = malloc(n * sizeof *in), *expect = malloc(n * sizeof *expect);
    ts_pair *pairs = malloc(n * sizeof *pairs), *scratch = malloc(n * sizeof *scratch);
    assert_true(in && expect && pairs && scratch);
    /* keys < 256 under key_limit 2^24: passes 2 and 3 are skipped */
    make_pairs(in, n, 256, 50, 0, 5);
    uint32_t m = reference_sort(in, n, expect);
    for (int t = 0; t < THREAD_CASES; t++) {
        radix_sorter_set_grain(fx->sorters[t], 1);
        sort_and_compare(fx->sorters[t], in, n, 1u << 24, expect, m, 1);
    }
    /* one key, no invalid pair: nothing moves, result in pairs */
    for (uint32_t i = 0; i < n; i++)
        pairs[i] = (ts_pair){.leaf = 0x123456u, .window = i};
    for (int t = 0; t < THREAD_CASES; t++) {
        const ts_pair *sorted = NULL;
        uint32_t valid = 0;
        ts_error err = {0};
        assert_int_equal(
            radix_sort_pairs(fx->sorters[t], pairs, scratch, n, 1u << 24, &sorted, &valid, &err),
            TS_OK);
        assert_ptr_equal(sorted, pairs);
        assert_int_equal(valid, n);
        check_sorted_stable(sorted, valid);
    }
    free(in);
    free(expect);
    free(pairs);
    free(scratch);
}

/* A valid leaf >= key_limit breaks the contract: TS_E_INTERNAL naming the pair. */
static void test_leaf_out_of_range(void **state)
{
    fixture *fx = *state;
    ts_pair pairs[6] = {{3, 0}, {TS_INVALID, 1}, {9, 2}, {10, 3}, {1, 4}, {2, 5}};
    ts_pair scratch[6];
    for (int t = 0; t < THREAD_CASES; t++) {
        radix_sorter_set_grain(fx->sorters[t], 1);
        const ts_pair *sorted = pairs;
        uint32_t valid = 77;
        ts_error err = {0};
        assert_int_equal(
            radix_sort_pairs(fx->sorters[t], pairs, scratch, 6, 10, &sorted, &valid, &err),
            TS_E_INTERNAL);
        assert_int_equal(err.code, TS_E_INTERNAL);
        assert_non_null(strstr(err.msg, "pair 3 has leaf 10"));
        assert_null(sorted);
        assert_int_equal(valid, 0);
        ts_error_clear(&err);
    }
    /* key_limit 0 admits only TS_INVALID */
    ts_pair none[2] = {{TS_INVALID, 0}, {TS_INVALID, 1}};
    const ts_pair *sorted = NULL;
    uint32_t valid = 5;
    ts_error err = {0};
    assert_int_equal(radix_sort_pairs(fx->sorters[1], none, scratch, 2, 0, &sorted, &valid, &err),
                     TS_OK);
    assert_int_equal(valid, 0);
    none[1].leaf = 0;
    assert_int_equal(radix_sort_pairs(fx->sorters[1], none, scratch, 2, 0, &sorted, &valid, &err),
                     TS_E_INTERNAL);
    ts_error_clear(&err);
}

static void test_segments_capacity(void **state)
{
    (void)state;
    const ts_pair sorted[7] = {{0, 5}, {0, 9}, {4, 1}, {7, 2}, {7, 3}, {7, 4}, {300, 0}};
    ts_segment seg[5];
    memset(seg, 0xAB, sizeof seg);
    assert_int_equal(sort_segments(sorted, 7, seg, 4), 4);
    const uint32_t expect[4][3] = {{0, 0, 2}, {4, 2, 3}, {7, 3, 6}, {300, 6, 7}};
    for (int k = 0; k < 4; k++) {
        assert_int_equal(seg[k].patch, expect[k][0]);
        assert_int_equal(seg[k].begin, expect[k][1]);
        assert_int_equal(seg[k].end, expect[k][2]);
        assert_int_equal(seg[k].vert_first, 0);
        assert_int_equal(seg[k].lod, 0);
    }
    /* too small: UINT32_MAX, nothing written past capacity */
    memset(seg, 0xAB, sizeof seg);
    assert_int_equal(sort_segments(sorted, 7, seg, 3), UINT32_MAX);
    assert_int_equal(seg[3].patch, 0xABABABABu);
    assert_int_equal(sort_segments(sorted, 0, seg, 0), 0);
    assert_int_equal(sort_segments(sorted, 1, seg, 0), UINT32_MAX);
}

/* Many calls of changing size, key range and chunk count on one pool: workers sleep, wake
 * (some too late for a call, which must not disturb the next) and claim tasks correctly.
 * Run on the 3-thread pool and on an 8-thread one, more threads than this machine has. */
static void pool_reuse(radix_sorter *s, uint32_t calls)
{
    radix_sorter_set_grain(s, 64);
    const uint32_t max_n = 3000;
    ts_pair *in = malloc(max_n * sizeof *in), *expect = malloc(max_n * sizeof *expect);
    assert_true(in && expect);
    for (uint32_t call = 0; call < calls; call++) {
        uint32_t n = (call * 977u) % max_n;
        uint32_t key_limit = key_ranges[call % (sizeof key_ranges / sizeof key_ranges[0])];
        make_pairs(in, n, key_limit, (call * 37u) % 101u, 0, call);
        uint32_t m = reference_sort(in, n, expect);
        sort_and_compare(s, in, n, key_limit, expect, m, 1);
    }
    free(in);
    free(expect);
}

static void test_pool_reuse(void **state)
{
    fixture *fx = *state;
    pool_reuse(fx->sorters[2], 300);
    ts_error err = {0};
    radix_sorter *wide = radix_sorter_create(8, &err);
    assert_non_null(wide);
    pool_reuse(wide, 100);
    radix_sorter_destroy(wide);
}

static void test_create_threads(void **state)
{
    (void)state;
    ts_error err = {0};
    radix_sorter *s = radix_sorter_create(0, &err);
    assert_non_null(s);
    long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    assert_int_equal(radix_sorter_threads(s), cpus < 1 ? 1 : (cpus > 256 ? 256 : cpus));
    radix_sorter_destroy(s);
    s = radix_sorter_create(5, &err);
    assert_non_null(s);
    assert_int_equal(radix_sorter_threads(s), 5);
    radix_sorter_destroy(s);
    radix_sorter_destroy(NULL);
    assert_int_equal(err.code, TS_OK);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pass_count),
        cmocka_unit_test(test_segments_capacity),
        cmocka_unit_test(test_create_threads),
        cmocka_unit_test(test_size_0),
        cmocka_unit_test(test_size_1),
        cmocka_unit_test(test_size_7),
        cmocka_unit_test(test_size_1000),
        cmocka_unit_test(test_size_1m),
        cmocka_unit_test(test_scrambled_windows),
        cmocka_unit_test(test_ray_windows),
        cmocka_unit_test(test_sort_windows),
        cmocka_unit_test(test_skipped_passes),
        cmocka_unit_test(test_leaf_out_of_range),
        cmocka_unit_test(test_pool_reuse),
    };
    return cmocka_run_group_tests(tests, group_setup, group_teardown);
}
