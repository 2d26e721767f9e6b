/* test_patch_cache.c — the resident set of diced patches (host/pipeline/patch_cache.c).
 * Host only; never skips. Asserts: a working set that fits is placed once and then only hit;
 * eviction is least recently used among unpinned patches and never touches a pinned one;
 * a patch at another m is placed again; under a random workload every resident patch's
 * blocks lie inside the arenas and overlap no other, the free lists and the used counts
 * account for every entry, TS_CACHE_FULL only happens when the patch's size class has no
 * unpinned patch nor free slot, and the same patch fits once the batch ends. The entries
 * examined per acquire stay below a constant from 100 to 20,000 resident patches (a scan
 * would grow with them), and a frame 5% over the room, its classes planned, keeps over 90%
 * of the arenas in use while evicting one patch a miss. A cache with fixed places
 * (patch_cache_create_placed) puts each patch at its own place on a miss, hits it there after,
 * never evicts, refuses another m, and a second cache over the same places puts every patch at the
 * same place whatever the order. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "pipeline/patch_cache.h"

static uint64_t rng_next(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static void test_sizes(void **state)
{
    assert_int_equal(patch_cache_vert_count(0, 1), 4);
    assert_int_equal(patch_cache_vert_count(3, 1), 81);
    assert_int_equal(patch_cache_vert_count(3, 2), 162);
    assert_int_equal(patch_cache_group_count(0, 1), 1);
    assert_int_equal(patch_cache_group_count(2, 1), 1 + 1 + 4);
    assert_int_equal(patch_cache_group_count(2, 2), 12);
}

/* Everything fits: one miss per patch, then hits at the same places, no eviction. */
static void test_working_set_fits(void **state)
{
    ts_patch_cache c;
    ts_error err = {0};
    uint32_t n = 20, m = 3;
    assert_int_equal(patch_cache_create(&c, n, n * patch_cache_vert_count(m, 2),
                                        n * patch_cache_group_count(m, 2), &err),
                     TS_OK);
    uint32_t vf[20], gf[20];
    for (int pass = 0; pass < 5; ++pass) {
        for (uint32_t p = 0; p < n; ++p) {
            uint32_t v, g, times = 1 + (p & 1);
            ts_cache_result r = patch_cache_acquire(&c, p, m, times, &v, &g);
            assert_int_equal(r, pass == 0 ? TS_CACHE_MISS : TS_CACHE_HIT);
            if (pass == 0) vf[p] = v, gf[p] = g;
            assert_int_equal(v, vf[p]);
            assert_int_equal(g, gf[p]);
        }
        patch_cache_end_batch(&c);
    }
    assert_int_equal(c.misses, n);
    assert_int_equal(c.hits, 4 * n);
    assert_int_equal(c.evictions, 0);
    patch_cache_clear(&c);
    assert_int_equal(c.verts.used, 0);
    assert_int_equal(c.resident_count, 0);
    uint32_t v, g;
    assert_int_equal(patch_cache_acquire(&c, 0, m, 1, &v, &g), TS_CACHE_MISS);
    patch_cache_free(&c);
}

/* Room for three patches: the fourth evicts the least recently used unpinned one. */
/* Fixed places: the arrays' places on a miss, hits there, none evicted, another m refused; two
 * caches over one set of places (two devices' views of one arena) agree in any order. */
static void test_placed(void **state)
{
    (void)state;
    enum { N = 6 };
    const uint8_t lod[N] = {2, 3, 0, 3, 1, 2};
    const uint32_t times[N] = {1, 2, 1, 1, 1, 2};
    uint32_t vf[N], gf[N], v = 0, g = 0;
    for (uint32_t p = 0; p < N; ++p) {
        vf[p] = p == 4 ? UINT32_MAX : v, gf[p] = p == 4 ? UINT32_MAX : g; /* 4: an instance */
        if (p == 4) continue;
        v += patch_cache_vert_count(lod[p], times[p]),
            g += patch_cache_group_count(lod[p], times[p]);
    }
    ts_patch_cache a, b;
    ts_error err = {0};
    assert_int_equal(patch_cache_create_placed(&a, N, vf, gf, lod, &err), TS_OK);
    assert_int_equal(patch_cache_create_placed(&b, N, vf, gf, lod, &err), TS_OK);
    for (int pass = 0; pass < 3; ++pass) {
        for (uint32_t k = 0; k < N; ++k) {
            if (k == 4) continue;
            uint32_t pa = k, pb = N - 1 - k == 4 ? 4 : N - 1 - k, va, ga;
            assert_int_equal(patch_cache_acquire(&a, pa, lod[pa], times[pa], &va, &ga),
                             pass == 0 ? TS_CACHE_MISS : TS_CACHE_HIT);
            assert_int_equal(va, vf[pa]);
            assert_int_equal(ga, gf[pa]);
            if (pb == 4) continue;
            assert_int_equal(patch_cache_acquire(&b, pb, lod[pb], times[pb], &va, &ga),
                             pass == 0 ? TS_CACHE_MISS : TS_CACHE_HIT);
            assert_int_equal(va, vf[pb]);
            assert_int_equal(ga, gf[pb]);
        }
        patch_cache_end_batch(&a);
        patch_cache_end_batch(&b);
    }
    uint32_t vx, gx;
    assert_int_equal(patch_cache_acquire(&a, 0, 3, 1, &vx, &gx), TS_CACHE_FULL); /* another m */
    assert_int_equal(patch_cache_acquire(&a, 4, lod[4], 1, &vx, &gx), TS_CACHE_FULL);
    assert_int_equal(a.evictions, 0);
    assert_int_equal(a.misses, N - 1);
    assert_int_equal(a.peak_bytes, (uint64_t)v * 16u + (uint64_t)g * TS_GROUP_BYTES);
    patch_cache_clear(&a); /* new levels: every patch placed again */
    assert_int_equal(patch_cache_acquire(&a, 3, lod[3], times[3], &vx, &gx), TS_CACHE_MISS);
    assert_int_equal(vx, vf[3]);
    patch_cache_free(&a);
    patch_cache_free(&b);
}

static void test_lru_and_pinning(void **state)
{
    ts_patch_cache c;
    ts_error err = {0};
    uint32_t m = 2, v, g;
    assert_int_equal(patch_cache_create(&c, 10, 3 * patch_cache_vert_count(m, 1),
                                        3 * patch_cache_group_count(m, 1), &err),
                     TS_OK);
    for (uint32_t p = 0; p < 3; ++p) { /* 0, 1, 2 in separate batches: 0 is the oldest */
        assert_int_equal(patch_cache_acquire(&c, p, m, 1, &v, &g), TS_CACHE_MISS);
        patch_cache_end_batch(&c);
    }
    assert_int_equal(patch_cache_acquire(&c, 0, m, 1, &v, &g), TS_CACHE_HIT); /* 1 is oldest now */
    patch_cache_end_batch(&c);
    assert_int_equal(patch_cache_acquire(&c, 3, m, 1, &v, &g), TS_CACHE_MISS);
    assert_int_equal(c.evictions, 1);
    assert_false(c.entry[1].resident);
    assert_true(c.entry[0].resident && c.entry[2].resident && c.entry[3].resident);
    /* In one batch: 3 is pinned; 0 and 2 are pinned by acquiring them; a fifth does not fit. */
    assert_int_equal(patch_cache_acquire(&c, 0, m, 1, &v, &g), TS_CACHE_HIT);
    assert_int_equal(patch_cache_acquire(&c, 2, m, 1, &v, &g), TS_CACHE_HIT);
    assert_int_equal(patch_cache_acquire(&c, 4, m, 1, &v, &g), TS_CACHE_FULL);
    assert_true(c.entry[0].resident && c.entry[2].resident && c.entry[3].resident);
    patch_cache_end_batch(&c);
    assert_int_equal(patch_cache_acquire(&c, 4, m, 1, &v, &g), TS_CACHE_MISS);
    /* Another m for a resident patch: placed again. */
    assert_int_equal(patch_cache_acquire(&c, 4, m - 1, 1, &v, &g), TS_CACHE_MISS);
    assert_int_equal(c.entry[4].lod, m - 1);
    /* Larger than an arena: never fits. */
    assert_int_equal(patch_cache_acquire(&c, 5, m + 2, 1, &v, &g), TS_CACHE_FULL);
    patch_cache_free(&c);
}

/* Every resident block inside its arena, no two overlapping, free + used = capacity. */
static void check_invariants(const ts_patch_cache *c)
{
    uint8_t *vmap = calloc(c->verts.capacity + 1, 1), *gmap = calloc(c->groups.capacity + 1, 1);
    assert_non_null(vmap);
    assert_non_null(gmap);
    uint64_t vused = 0, gused = 0;
    for (uint32_t k = 0; k < c->resident_count; ++k) {
        const ts_cache_entry *e = &c->entry[c->resident_list[k]];
        assert_true(e->resident);
        assert_true((uint64_t)e->vert_first + e->vert_count <= c->verts.capacity);
        assert_true((uint64_t)e->group_first + e->group_count <= c->groups.capacity);
        for (uint32_t i = 0; i < e->vert_count; ++i)
            assert_int_equal(vmap[e->vert_first + i]++, 0);
        for (uint32_t i = 0; i < e->group_count; ++i)
            assert_int_equal(gmap[e->group_first + i]++, 0);
        vused += e->vert_count, gused += e->group_count;
    }
    assert_int_equal(vused, c->verts.used);
    assert_int_equal(gused, c->groups.used);
    /* Each class's free slots: inside the handed-out part, on no resident block nor another
     * free slot; every slot of the top is a class's, resident or free. */
    uint64_t vslots = 0, gslots = 0, resident_in[TS_CACHE_CLASSES] = {0};
    for (uint32_t k = 0; k < c->resident_count; ++k) {
        const ts_cache_entry *e = &c->entry[c->resident_list[k]];
        resident_in[TS_CACHE_CLASS(e->lod, e->times)]++;
    }
    for (uint32_t k = 0; k < TS_CACHE_CLASSES; ++k) {
        const ts_cache_class *cl = &c->cls[k];
        assert_int_equal(cl->free_count + resident_in[k], cl->slots);
        for (uint32_t f = 0; f < cl->free_count; ++f) {
            assert_true((uint64_t)cl->free_vert[f] + cl->nv <= c->verts.top);
            assert_true((uint64_t)cl->free_group[f] + cl->ng <= c->groups.top);
            for (uint32_t i = 0; i < cl->nv; ++i)
                assert_int_equal(vmap[cl->free_vert[f] + i]++, 0);
            for (uint32_t i = 0; i < cl->ng; ++i)
                assert_int_equal(gmap[cl->free_group[f] + i]++, 0);
        }
        vslots += (uint64_t)cl->slots * cl->nv, gslots += (uint64_t)cl->slots * cl->ng;
    }
    assert_int_equal(vslots, c->verts.top);
    assert_int_equal(gslots, c->groups.top);
    assert_true(c->verts.top <= c->verts.capacity && c->groups.top <= c->groups.capacity);
    free(vmap), free(gmap);
}

static void test_random_workload(void **state)
{
    uint64_t seed = 12345, fulls = 0, evictions = 0;
    for (int trial = 0; trial < 20; ++trial) {
        ts_patch_cache c;
        ts_error err = {0};
        uint32_t n = 50 + (uint32_t)(rng_next(&seed) % 200);
        uint32_t vcap = 200 + (uint32_t)(rng_next(&seed) % 20000);
        uint32_t gcap = 50 + (uint32_t)(rng_next(&seed) % 8000);
        assert_int_equal(patch_cache_create(&c, n, vcap, gcap, &err), TS_OK);
        uint8_t *lod = malloc(n);
        uint64_t need[TS_CACHE_CLASSES] = {0};
        for (uint32_t p = 0; p < n; ++p) {
            lod[p] = (uint8_t)(rng_next(&seed) % 6);
            need[TS_CACHE_CLASS(lod[p], 1u + (p % 3 == 0))]++;
        }
        if (trial % 2) patch_cache_plan(&c, need); /* quotas, as a frame has; else none */
        uint64_t misses = 0, hits = 0;
        for (int batch = 0; batch < 300; ++batch) {
            uint32_t want = 1 + (uint32_t)(rng_next(&seed) % 12);
            for (uint32_t k = 0; k < want; ++k) {
                uint32_t p = (uint32_t)(rng_next(&seed) % n), v, g;
                if (rng_next(&seed) % 50 == 0) lod[p] = (uint8_t)(rng_next(&seed) % 6);
                uint32_t times = 1 + (p % 3 == 0);
                int was =
                    c.entry[p].resident && c.entry[p].lod == lod[p] && c.entry[p].times == times;
                ts_cache_result r = patch_cache_acquire(&c, p, lod[p], times, &v, &g);
                int too_big = patch_cache_vert_count(lod[p], times) > vcap ||
                              patch_cache_group_count(lod[p], times) > gcap;
                if (too_big) {
                    assert_int_equal(r, TS_CACHE_FULL); /* can never fit */
                    continue;
                }
                if (r == TS_CACHE_FULL) { /* its class has no slot to give: all pinned */
                    const ts_cache_class *cl = &c.cls[TS_CACHE_CLASS(lod[p], times)];
                    assert_int_equal(cl->free_count, 0);
                    assert_int_equal(cl->lru_head, TS_CACHE_NONE);
                    assert_true(c.pinned_now > 0);
                    ++fulls;
                    patch_cache_end_batch(&c); /* the caller ends the batch here, then the */
                    r = patch_cache_acquire(&c, p, lod[p], times, &v, &g); /* patch fits */
                    assert_int_equal(r, TS_CACHE_MISS);
                    ++misses;
                    check_invariants(&c);
                    break;
                }
                assert_int_equal(r, was ? TS_CACHE_HIT : TS_CACHE_MISS);
                r == TS_CACHE_HIT ? ++hits : ++misses;
                assert_true(c.entry[p].pinned);
                assert_int_equal(c.entry[p].vert_first, v);
                assert_int_equal(c.entry[p].group_first, g);
                check_invariants(&c);
            }
            patch_cache_end_batch(&c);
        }
        assert_int_equal(c.hits, hits);
        assert_int_equal(c.misses, misses);
        evictions += c.evictions;
        free(lod);
        patch_cache_free(&c);
    }
    assert_true(fulls > 0);     /* the workload reached full batches */
    assert_true(evictions > 0); /* and evicted */
}

/* Sweeps patches 0..4R-1 of mixed sizes (m 1-4, some moving) through a cache planned for R
 * of their 4R, in batches of 8 as the sort would: the entries examined per acquire, and the
 * arenas' use at the end. */
static void sweep(uint32_t resident, double *examined_per_acquire, double *use)
{
    uint32_t n = 4 * resident;
    uint64_t need[TS_CACHE_CLASSES] = {0}, vneed = 0, gneed = 0;
    for (uint32_t p = 0; p < n; ++p) {
        uint32_t m = 1 + p % 4, t = 1 + (p % 7 == 0);
        need[TS_CACHE_CLASS(m, t)]++;
        vneed += patch_cache_vert_count(m, t), gneed += patch_cache_group_count(m, t);
    }
    ts_patch_cache c;
    ts_error err = {0};
    assert_int_equal(patch_cache_create(&c, n, (uint32_t)(vneed / 4), (uint32_t)(gneed / 4), &err),
                     TS_OK);
    patch_cache_plan(&c, need);
    uint64_t acquires = 0;
    for (int pass = 0; pass < 3; ++pass)
        for (uint32_t p = 0; p < n; ++p) {
            uint32_t v, g;
            assert_int_not_equal(patch_cache_acquire(&c, p, 1 + p % 4, 1 + (p % 7 == 0), &v, &g),
                                 TS_CACHE_FULL);
            ++acquires;
            if (p % 8 == 7) patch_cache_end_batch(&c);
        }
    *examined_per_acquire = (double)c.examined / (double)acquires;
    *use = (double)c.verts.used / c.verts.capacity;
    patch_cache_free(&c);
}

static void test_constant_cost(void **state)
{
    double small, large, use_small, use_large;
    sweep(100, &small, &use_small);
    sweep(20000, &large, &use_large);
    assert_true(small <= 2.0 && large <= 2.0); /* one entry a hit, two a miss that evicts */
    assert_true(use_small > 0.9 && use_large > 0.9);
}

/* 5% over the room: quotas leave no class without slots, the cache fills over 90% of both
 * arenas, and a miss evicts exactly one patch. */
static void test_slightly_over(void **state)
{
    const uint32_t n = 2000;
    uint64_t need[TS_CACHE_CLASSES] = {0}, vneed = 0, gneed = 0;
    for (uint32_t p = 0; p < n; ++p) {
        uint32_t m = p % 3 ? 3 : 6;
        need[TS_CACHE_CLASS(m, 1)]++;
        vneed += patch_cache_vert_count(m, 1), gneed += patch_cache_group_count(m, 1);
    }
    ts_patch_cache c;
    ts_error err = {0};
    assert_int_equal(
        patch_cache_create(&c, n, (uint32_t)(vneed / 1.05), (uint32_t)(gneed / 1.05), &err), TS_OK);
    assert_int_equal(patch_cache_plan(&c, need), 1);
    assert_int_equal(patch_cache_plan(&c, need), 0); /* the same quotas: kept */
    for (int pass = 0; pass < 2; ++pass)
        for (uint32_t p = 0; p < n; ++p) {
            uint32_t v, g;
            uint64_t before = c.evictions;
            ts_cache_result r = patch_cache_acquire(&c, p, p % 3 ? 3 : 6, 1, &v, &g);
            assert_int_not_equal(r, TS_CACHE_FULL);
            assert_true(c.evictions - before <= 1);
            patch_cache_end_batch(&c);
        }
    assert_true(c.verts.used > 0.9 * c.verts.capacity);
    assert_true(c.groups.used > 0.9 * c.groups.capacity);
    assert_true(c.evictions > 0);
    patch_cache_free(&c);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sizes),           cmocka_unit_test(test_working_set_fits),
        cmocka_unit_test(test_lru_and_pinning), cmocka_unit_test(test_placed),
        cmocka_unit_test(test_random_workload), cmocka_unit_test(test_constant_cost),
        cmocka_unit_test(test_slightly_over),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
