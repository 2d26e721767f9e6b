/* test_patch_share.c — the store of built patches shared between devices
 * (host/pipeline/patch_share.c). Host only; never skips. Asserts: the sizes of a patch's
 * blocks; the first device to take a patch claims it, the others wait, and after publishing
 * every device reads the same bytes; a waiter in another thread is woken by the publish, or
 * by an abandon (then it dices itself, and the patch can be claimed again); the bound refuses
 * claims beyond it (TS_TAKE_LOCAL, counted), an abandon frees its room, patch_share_allow
 * never lowers it; a patch held at another m, or taken again by its own claimant, is diced
 * locally. In place (patch_share_in_place: the blocks lie in arenas the devices share) a claim
 * needs no room and stores nothing: the first device claims whatever the bound, the others
 * wait, and the published patch is READY with no data; an abandon lets another claim it. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <cmocka.h>

#include "lib/shared_types.h"
#include "pipeline/patch_cache.h"
#include "pipeline/patch_share.h"

static void test_bytes(void **state)
{
    (void)state;
    /* m = 3: 81 vertices of 16 bytes; 1 + 1 + 4 + 16 sibling groups of ts_box4 (96 bytes) and
     * of their ts_tight4 codes (24 bytes). */
    assert_int_equal(patch_cache_group_count(3, 1), 22);
    assert_int_equal(patch_share_bytes(3, 1), 81 * 16 + 22 * (96 + 24));
    assert_int_equal(patch_share_bytes(3, 2), 2 * patch_share_bytes(3, 1));
    assert_int_equal(patch_share_bytes(0, 1), 4 * 16 + 96 + 24);
}

/* Claim, wait, publish, read: one copy for every device. */
static void test_claim_publish_read(void **state)
{
    (void)state;
    ts_patch_share s;
    ts_error err = {0};
    assert_int_equal(patch_share_create(&s, 4, 2, &err), TS_OK);
    assert_int_equal(s.devices, 2);
    uint64_t bytes = patch_share_bytes(2, 1);
    void *d0 = NULL, *d1 = NULL;
    /* Bound 0: nothing is stored yet. */
    assert_int_equal(patch_share_take(&s, 1, 2, 1, bytes, 0, &d0), TS_TAKE_LOCAL);
    assert_int_equal(s.refused, 1);
    patch_share_allow(&s, 10 * bytes);
    assert_int_equal(patch_share_take(&s, 1, 2, 1, bytes, 0, &d0), TS_TAKE_MINE);
    assert_non_null(d0);
    assert_int_equal(s.used, bytes);
    assert_int_equal(patch_share_take(&s, 1, 2, 1, bytes, 1, &d1), TS_TAKE_WAIT);
    assert_null(d1);
    assert_int_equal(patch_share_take(&s, 1, 2, 1, bytes, 0, &d1), TS_TAKE_LOCAL); /* its own */
    const void *got = d0;
    assert_int_equal(patch_share_poll(&s, 1, &got), -1); /* claimed: still being built */
    assert_null(got);
    assert_int_equal(patch_share_poll(&s, 2, &got), 0); /* absent */
    memset(d0, 0xab, bytes);
    patch_share_publish(&s, 1);
    assert_int_equal(patch_share_poll(&s, 1, &got), 1);
    assert_ptr_equal(got, d0);
    got = NULL;
    assert_int_equal(patch_share_wait(&s, 1, &got), 1);
    assert_ptr_equal(got, d0);
    assert_int_equal(patch_share_take(&s, 1, 2, 1, bytes, 1, &d1), TS_TAKE_READY);
    assert_ptr_equal(d1, d0);
    assert_int_equal(((unsigned char *)d1)[bytes - 1], 0xab);
    /* Another m or another time count: diced locally, the copy kept. */
    assert_int_equal(patch_share_take(&s, 1, 3, 1, patch_share_bytes(3, 1), 1, &d1), TS_TAKE_LOCAL);
    assert_int_equal(patch_share_take(&s, 1, 2, 2, 2 * bytes, 1, &d1), TS_TAKE_LOCAL);
    assert_int_equal(s.published, 1);
    assert_int_equal(s.used, bytes);
    patch_share_free(&s);
    assert_null(s.entry);
}

/* In place: claims with bound 0, no data, the same claim and wait as the copying store. */
static void test_in_place(void **state)
{
    (void)state;
    ts_patch_share s;
    ts_error err = {0};
    assert_int_equal(patch_share_create(&s, 3, 2, &err), TS_OK);
    patch_share_in_place(&s);
    uint64_t bytes = patch_share_bytes(4, 1);
    void *d = (void *)&s;
    assert_int_equal(patch_share_take(&s, 0, 4, 1, bytes, 0, &d), TS_TAKE_MINE);
    assert_null(d);
    assert_int_equal(s.used, 0);
    assert_int_equal(patch_share_take(&s, 0, 4, 1, bytes, 1, &d), TS_TAKE_WAIT);
    const void *got = &s;
    assert_int_equal(patch_share_poll(&s, 0, &got), -1);
    patch_share_publish(&s, 0);
    assert_int_equal(patch_share_wait(&s, 0, &got), 1);
    assert_null(got);
    d = (void *)&s;
    assert_int_equal(patch_share_take(&s, 0, 4, 1, bytes, 1, &d), TS_TAKE_READY);
    assert_null(d);
    assert_int_equal(patch_share_take(&s, 2, 4, 1, bytes, 1, &d), TS_TAKE_MINE);
    patch_share_abandon(&s, 2); /* its device failed: anyone may claim it again */
    assert_int_equal(patch_share_poll(&s, 2, &got), 0);
    assert_int_equal(patch_share_take(&s, 2, 4, 1, bytes, 0, &d), TS_TAKE_MINE);
    assert_int_equal(s.refused, 0);
    assert_int_equal(s.abandoned, 1);
    patch_share_free(&s);
}

/* The bound: claims beyond it are refused; an abandon frees its room; allow never lowers. */
static void test_bound(void **state)
{
    (void)state;
    ts_patch_share s;
    ts_error err = {0};
    assert_int_equal(patch_share_create(&s, 8, 2, &err), TS_OK);
    uint64_t bytes = patch_share_bytes(4, 1);
    patch_share_allow(&s, 3 * bytes);
    patch_share_allow(&s, bytes); /* lower: ignored */
    assert_int_equal(s.bound, 3 * bytes);
    void *d;
    for (uint32_t p = 0; p < 3; ++p)
        assert_int_equal(patch_share_take(&s, p, 4, 1, bytes, 0, &d), TS_TAKE_MINE);
    assert_int_equal(patch_share_take(&s, 3, 4, 1, bytes, 0, &d), TS_TAKE_LOCAL);
    assert_int_equal(s.refused, 1);
    patch_share_publish(&s, 0);
    patch_share_abandon(&s, 1);
    assert_int_equal(s.abandoned, 1);
    assert_int_equal(s.used, 2 * bytes);
    const void *got;
    assert_int_equal(patch_share_wait(&s, 1, &got), 0); /* abandoned: dice it yourself */
    assert_null(got);
    assert_int_equal(patch_share_take(&s, 3, 4, 1, bytes, 1, &d), TS_TAKE_MINE);
    assert_int_equal(patch_share_take(&s, 1, 4, 1, bytes, 1, &d), TS_TAKE_LOCAL); /* full */
    patch_share_allow(&s, 4 * bytes);
    assert_int_equal(patch_share_take(&s, 1, 4, 1, bytes, 1, &d), TS_TAKE_MINE);
    assert_int_equal(s.used, 4 * bytes);
    patch_share_free(&s);
}

/* A waiter in another thread: woken by a publish (1) or an abandon (0). */
typedef struct waiter {
    ts_patch_share *s;
    uint32_t p;
    int ready;
    const void *got;
} waiter;

static void *wait_main(void *arg)
{
    waiter *w = arg;
    w->ready = patch_share_wait(w->s, w->p, &w->got);
    return NULL;
}

static void test_waiters_wake(void **state)
{
    (void)state;
    ts_patch_share s;
    ts_error err = {0};
    assert_int_equal(patch_share_create(&s, 2, 2, &err), TS_OK);
    uint64_t bytes = patch_share_bytes(3, 2);
    patch_share_allow(&s, 4 * bytes);
    void *d0, *d1;
    assert_int_equal(patch_share_take(&s, 0, 3, 2, bytes, 0, &d0), TS_TAKE_MINE);
    assert_int_equal(patch_share_take(&s, 1, 3, 2, bytes, 0, &d1), TS_TAKE_MINE);
    waiter w[2] = {{&s, 0, -1, NULL}, {&s, 1, -1, NULL}};
    pthread_t t[2];
    for (int i = 0; i < 2; ++i)
        assert_int_equal(pthread_create(&t[i], NULL, wait_main, &w[i]), 0);
    nanosleep(&(struct timespec){0, 20000000}, NULL); /* let them wait (either order works) */
    memset(d0, 7, bytes);
    patch_share_publish(&s, 0);
    patch_share_abandon(&s, 1);
    for (int i = 0; i < 2; ++i)
        pthread_join(t[i], NULL);
    assert_int_equal(w[0].ready, 1);
    assert_ptr_equal(w[0].got, d0);
    assert_int_equal(w[1].ready, 0);
    assert_null(w[1].got);
    /* The abandoned patch is open again: another device claims it. */
    assert_int_equal(patch_share_take(&s, 1, 3, 2, bytes, 1, &d1), TS_TAKE_MINE);
    assert_int_equal(s.used, 2 * bytes);
    patch_share_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bytes),        cmocka_unit_test(test_claim_publish_read),
        cmocka_unit_test(test_bound),        cmocka_unit_test(test_in_place),
        cmocka_unit_test(test_waiters_wake),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
