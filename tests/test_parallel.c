/* test_parallel.c — ts_parallel_for (host/base/parallel.h; no device): every index of the
 * range is visited exactly once, in at most `threads` contiguous chunks of at least `grain`
 * items, and a range too small to split runs on the calling thread. */
#include "test_support.h"
#include "base/parallel.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <unistd.h>

typedef struct visits {
    unsigned char *seen;
    atomic_uint calls;
    atomic_size_t smallest;
    pthread_t caller;
    atomic_int off_caller; /* calls made on another thread than the caller's */
} visits;

static void visit(void *ctx, size_t begin, size_t end)
{
    visits *v = ctx;
    atomic_fetch_add(&v->calls, 1u);
    size_t size = end - begin, s = atomic_load(&v->smallest);
    while (size < s && !atomic_compare_exchange_weak(&v->smallest, &s, size)) {
    }
    if (!pthread_equal(pthread_self(), v->caller)) atomic_store(&v->off_caller, 1);
    for (size_t i = begin; i < end; ++i)
        v->seen[i]++;
}

static visits *run(size_t n, size_t grain, unsigned threads)
{
    visits *v = calloc(1, sizeof *v);
    assert_non_null(v);
    v->seen = calloc(n ? n : 1, 1);
    assert_non_null(v->seen);
    atomic_init(&v->calls, 0u);
    atomic_init(&v->smallest, (size_t)-1);
    atomic_init(&v->off_caller, 0);
    v->caller = pthread_self();
    ts_parallel_for(n, grain, threads, visit, v);
    for (size_t i = 0; i < n; ++i)
        if (v->seen[i] != 1) fail_msg("index %zu visited %d times", i, v->seen[i]);
    return v;
}

static void done(visits *v)
{
    free(v->seen);
    free(v);
}

static void test_every_index_once_on_threads(void **state)
{
    (void)state;
    visits *v = run(100003, 1000, 4);
    assert_int_equal(atomic_load(&v->calls), 4);
    assert_true(atomic_load(&v->smallest) >= 1000);
    assert_int_equal(atomic_load(&v->off_caller), 1);
    done(v);
    v = run(5000, 1000, 64); /* the grain caps the chunks: five */
    assert_int_equal(atomic_load(&v->calls), 5);
    assert_true(atomic_load(&v->smallest) >= 1000);
    done(v);
    v = run(100000, 1, 0); /* every online processor, at most 64 */
    long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    unsigned want = cpus < 1 ? 1u : cpus > 64 ? 64u : (unsigned)cpus;
    assert_int_equal(ts_parallel_threads(0), want);
    assert_int_equal(ts_parallel_threads(200), 64);
    assert_int_equal(atomic_load(&v->calls), want);
    done(v);
}

static void test_small_ranges_run_on_the_caller(void **state)
{
    (void)state;
    visits *v = run(1999, 1000, 8); /* one chunk of 1999: two of 999.5 would be below the grain */
    assert_int_equal(atomic_load(&v->calls), 1);
    assert_int_equal(atomic_load(&v->off_caller), 0);
    done(v);
    v = run(100000, 10, 1);
    assert_int_equal(atomic_load(&v->calls), 1);
    assert_int_equal(atomic_load(&v->off_caller), 0);
    done(v);
    v = run(0, 10, 4);
    assert_int_equal(atomic_load(&v->calls), 0);
    done(v);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_index_once_on_threads),
        cmocka_unit_test(test_small_ranges_run_on_the_caller),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
