/* bench_cache.h — what tools/bench_cache.c and its cache tracer (tools/cache_tracer.c)
 * share: the rays Tessera traced, the LRU caches and the benchmark's results. */
#ifndef TS_BENCH_CACHE_H
#define TS_BENCH_CACHE_H

#include "base/error.h"
#include "device/device.h"
#include "lib/shared_types.h"
#include "scene/scene.h"

#include <stdint.h>

#define BENCH_CACHES 3

/* One LRU cache of diced patches: a doubly linked list over `cap` slots, most recent first. */
typedef struct lru {
    uint32_t cap, size, head, tail;
    int32_t *slot_of;   /* per patch: its slot, or -1 */
    uint32_t *patch_of; /* per slot */
    uint32_t *prev, *next;
    uint64_t dicings, micropolygons;
} lru;

/* bench_cache --lazy (tools/lazy_sim.c): over every iteration traced, the patches diced (the
 * misses), and how many of them a trace that dices a patch only when one of its rays still
 * needs it would dice, in Tessera's batch order and near first; in patches and micro-quads. */
typedef struct lazy_counts {
    uint64_t misses, batch_order, near_first;
    /* the same in micro-quads (4^m a dicing): what the dicing costs */
    uint64_t misses_mp, batch_order_mp, near_first_mp;
} lazy_counts;
typedef struct bench_result {
    const char *scene;
    uint32_t patches, max_lod, waves, band_rows;
    uint64_t arena_bytes; /* the patch arenas after the lod stage (grown, without --memory) */
    uint64_t rays, reorder_dicings, reorder_micropolygons, reorder_iterations, reorder_pairs;
    uint64_t eye_rays, bsdf_rays, shadow_rays; /* with --paths: the rays of every bounce */
    uint64_t lookups, hits_reorder, hits_cache, hit_t_equal, host_dicings;
    uint64_t answers_equal; /* rays both tracers hit, or both miss */
    uint64_t hits_compared; /* hits of both, not of shadow rays: their distances compared */
    /* Patches the exact tracer reaches at least once: an unbounded cache's dicings, the floor
     * of any method that dices only what the rays reach before their closest hits. */
    uint64_t reached;
    uint8_t *seen; /* per patch, during cache_trace */
    /* With --order wave (the rays pass by pass): the patches each pass (a bounce of a wave)
     * reaches, counted once a pass and summed: what a method that dices each patch a pass
     * needs exactly once would dice, and pass_reached_mp their micro-quads (4^m each: what
     * those dicings cost); pass_seen holds per patch the last pass (+ 1) that did. */
    int by_pass;
    uint64_t pass_reached, pass_reached_mp, pass_now, *pass_seen;
    uint64_t t_reorder_nearer, t_cache_nearer; /* both hit, at different distances */
    int check_reorder_le_cache10, check_caches_monotone, check_same_hits;
    lru cache[BENCH_CACHES];
    int lazy; /* --lazy: the replay ran (lazy_counts) */
    lazy_counts lazy_dicings;
    double reorder_seconds, cache_seconds;
} bench_result;

/* One ray Tessera traced, kept for the caches: its key orders the rays as a tracer without
 * reordering meets them (scanline order of pixels, or pass by pass; then each path's rays by
 * bounce, a shadow ray before the BSDF ray made at the same vertex). */
typedef struct bench_ray {
    uint64_t key;
    ts_vec4 org, dir;
    float tmax; /* hit.t before the trace: a shadow ray's distance to its light */
    uint32_t flags, from;
    uint64_t pass; /* the pass it was traced in: its wave's first sample << 5 | its bounce */
    ts_hit hit;    /* Tessera's */
} bench_ray;

/* The cache baseline: rays[0..count) traced one at a time in that order (their keys' order)
 * through the patch QBVH, each patch reached looked up in the caches of 10, 100 and 1000 diced
 * patches (a miss dices it at lod[patch]) and intersected by the plain-C references; fills
 * res's cache counts, patches reached, lookups and how the answers compare with Tessera's
 * (rays[k].hit). memo_mb bounds the host's memo of really diced patches. */
int cache_trace(const ts_scene *s, const uint8_t *lod, const bench_ray *rays, uint64_t count,
                uint64_t memo_mb, bench_result *res, ts_error *err);
void lru_free(lru *c);

struct ts_pipeline;
/* ts_pipeline's iteration_watch; ctx a lazy_counts. */
int lazy_watch(void *ctx, struct ts_pipeline *p, uint32_t active, uint32_t n_per_ray, cl_mem pairs,
               uint32_t valid, uint32_t segs, ts_error *err);

#endif
