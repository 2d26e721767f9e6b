/* stats.h — what a render measured: seconds per stage (OpenCL profiling events for kernels,
 * a monotonic clock for host stages), counters, and the per-iteration log that reproduces
 * Hanika Table 3. Written as JSON by --stats (schema in DESIGN.md §4). */
#ifndef TS_STATS_H
#define TS_STATS_H

#include "base/error.h"
#include "base/stages.h"
#include "lib/shared_types.h"

#include <stdint.h>

/* clang-format off */
#define TS_COUNTERS(X)                                                                      \
    X(rays, "rays traced (all waves)")                                                      \
    X(shadow_rays, "shadow rays traced")                                                    \
    X(pairs, "(leaf, ray) candidates produced by top_level")                                \
    X(patches_diced, "patch segments diced (patch cache misses)")                           \
    X(micropolygons_created, "micro-quads diced, summed over all dicings")                  \
    X(micropolygons_potential, "micro-quads of every patch at max LOD")                     \
    X(iterations, "top_level/sort/dice/bottom_level iterations")                            \
    X(pair_overflow, "candidates dropped because the pair buffer was full (always 0)")      \
    X(leaf_tests, "micro-quad tests in bottom_level's leaves")                              \
    X(leaf_slots, "work-item slots those tests occupied (utilisation = tests / slots)")     \
    X(texture_tiles_uploaded, "texture tiles (32 x 32 texels) copied to the device pool")   \
    X(texture_bytes_uploaded, "bytes of those tiles")                                      \
    X(texture_pool_tiles, "tiles the device pool holds (every tile unless --memory pages)") \
    X(texture_tiles, "tiles of every texture level in the scene")                           \
    X(patch_cache_hits, "segments whose patch was already diced and resident")              \
    X(patch_cache_misses, "segments placed into the cache (= patches_diced + patches_shared)") \
    X(patch_cache_evictions, "resident patches evicted to make room")                      \
    X(batches, "batches of segments whose patches were resident together (launch groups)")  \
    X(patch_cache_examined, "cache entries looked at: one a hit or miss, one a victim")    \
    X(patch_cache_bytes, "bytes of the vertex and tree arenas the cache manages")        \
    X(patch_cache_need_bytes, "arena bytes the frame's patches need to be resident at once") \
    X(patch_cache_peak_bytes, "most arena bytes resident patches held at once")          \
    X(patches_shared, "misses filled from another device's dicing (patch_share.h)")       \
    X(grids_skipped, "of patches_diced, built without their vertices: no ray left them")   \
    X(skeleton_segments, "segments traced through their tree's kept skeleton, the leaves "  \
                         "their rays enter made in bottom_level (not diced)")                \
    X(skeleton_bytes, "most bytes of kept skeletons (within the budget) at once")          \
    X(device_bytes_peak, "most bytes of device buffers the pipeline held at once")        \
    X(device_bytes_fixed, "bytes of those buffers outside the memory budget (scene, films)") \
    X(device_bytes_in_place, "of those, read in place from host arrays (CL_MEM_USE_HOST_PTR)") \
    X(bake_points, "points baked (tessera bake; their rays are counted in rays)")
/* clang-format on */

typedef enum ts_counter {
#define TS_COUNTER_ENUM(name, what) TS_COUNTER_##name,
    TS_COUNTERS(TS_COUNTER_ENUM)
#undef TS_COUNTER_ENUM
        TS_COUNTER_COUNT
} ts_counter;

/* One iteration of the two-level loop (Hanika Table 3: R and N). */
typedef struct ts_iteration {
    uint32_t wave, iteration;
    uint64_t active_rays;
    uint32_t n_per_ray;
    uint64_t pairs;
    uint32_t segments;
    uint32_t lod; /* 1: traced by the lod stage (pipeline_lod), not by a wave of paths */
} ts_iteration;

/* One device of a render on several (app/workers.c), for --stats "devices". Plain bytes
 * and fixed sizes: the ranks of an MPI render send theirs to rank 0 as they are. */
typedef struct ts_device_stats {
    char name[256];
    int32_t index;                 /* in `tessera devices` of its machine */
    int32_t rank;                  /* MPI rank; 0 without MPI */
    uint64_t units, samples, rays; /* units, samples: merged into the image from it; rays: all
                                      it traced, with the shadow rays */
    /* Backups it traced of a slower device's units (app/units.h), and units it stopped or
     * dropped because another device's copy was merged first. */
    uint64_t backup_units, dropped_units;
    uint64_t memory_budget_bytes; /* of the pipeline that finished */
    uint64_t device_bytes_peak;   /* its buffers' bytes at their most (counters) */
    double stage_seconds[TS_STAGE_COUNT];
    double kernel_seconds; /* while its kernels ran (the union of its busy spans) */
    double setup_seconds;  /* making the pipeline (the scene copied to the device), counting
                              its part of the lod pass and waiting for the frame's levels of
                              detail */
    double busy_seconds;   /* tracing units and reading their results back */
    double frame_seconds;  /* from the start of the device's thread to the frame's end */
    /* Built patches shared with the other devices (pipeline/patch_share.h): misses diced
     * here, misses taken from the store, seconds spent waiting for another device's claims. */
    uint64_t patches_diced, patches_shared;
    double share_wait_seconds;
    int32_t failed;         /* 1: it stopped early with an error: */
    uint32_t compute_units; /* it rendered with (fewer than the device's on a sub-device) */
    char error[512];        /* why it stopped ("" when it did not) */
} ts_device_stats;

/* One process of an MPI render, for rank 0's --stats "ranks". */
typedef struct ts_rank_stats {
    char host[256];
    int32_t rank;
    uint32_t devices; /* devices that rendered */
    uint64_t units, samples;
    double seconds;             /* the rank's render, from the scene to its last unit */
    double scene_seconds;       /* getting the scene: loading the files, or receiving rank 0's */
    double kernel_seconds;      /* while a kernel ran on any of its devices */
    double host_serial_seconds; /* of `seconds`, while none did */
    char error[512];            /* why it rendered nothing ("" when it rendered) */
} ts_rank_stats;
/* What `tessera bake` adds (the "bake" object of --stats, written when points were baked):
 * the waves' wall time and the shape of each point's projection. */
typedef struct ts_bake_summary {
    double seconds; /* from the first wave's start to the last wave's end */
    uint32_t bands, rays_per_point;
} ts_bake_summary;

/* A span of host time (stats_now's clock) during which a device ran kernels. */
typedef struct ts_busy_span {
    double start, end;
} ts_busy_span;

typedef struct ts_stats {
    double stage_seconds[TS_STAGE_COUNT];
    uint64_t counters[TS_COUNTER_COUNT];
    ts_iteration *iterations;
    uint32_t iteration_count, iteration_capacity;
    uint64_t lod_histogram[TS_LOD_LIMIT + 1]; /* dicings per LOD m */
    /* The frame's levels of detail, as the waves trace them (pipeline_cache_plan): patches
     * diced at each m, each once (an instance diced as its master counts none); the lod
     * stage's own trace (TESSERA_LOD_RULE=visible|seen) is not in it, as it is in
     * lod_histogram. */
    uint64_t frame_lod_histogram[TS_LOD_LIMIT + 1];
    char device[256];
    double wall_seconds;
    double kernel_build_seconds;
    int kernel_cache_hit;
    /* The memory budget of the attempt that finished the render: the chosen one (--memory
     * or the default, app/budget.h), halved per out-of-memory retry. */
    uint64_t memory_budget_bytes;
    /* A render on several devices or ranks: each device, each rank, and the unit size
     * (app/units.h); none (0) on one device. */
    ts_device_stats *devices;
    uint32_t device_count;
    uint32_t rank_count;
    ts_rank_stats *ranks;
    uint64_t unit_samples;
    ts_bake_summary bake;
    /* When the devices ran kernels (dev_finish: each launch's profiling times on the host's
     * clock), in the order found, each device's spans merged where they touch: the union is
     * --stats "kernel_seconds", the wall's rest "host_serial_seconds". */
    ts_busy_span *busy;
    uint32_t busy_count, busy_capacity;
} ts_stats;

extern const char *const ts_counter_names[TS_COUNTER_COUNT];

/* Seconds on CLOCK_MONOTONIC. */
double stats_now(void);
int stats_add_iteration(ts_stats *s, const ts_iteration *it, ts_error *err);
/* Adds the span [start, end] of host time during which a device ran a kernel; a span that
 * starts before the last one ends extends it. */
int stats_add_busy(ts_stats *s, double start, double end, ts_error *err);
/* Seconds during which at least one device ran a kernel: the union of s->busy. */
double stats_kernel_seconds(const ts_stats *s);
/* The seconds of the stages that make a patch (dice and build): what a patch diced again costs
 * (the progress line's estimate of a frame whose patches do not fit, app/eta.h). */
double stats_dicing_seconds(const ts_stats *s);
/* --stats "host_serial_seconds": of `wall` seconds, those no kernel ran (`kernel`). */
double stats_host_serial(double wall, double kernel);
/* Appends a copy of *d (of *r) to s->devices (s->ranks). */
int stats_add_device(ts_stats *s, const ts_device_stats *d, ts_error *err);
int stats_add_rank(ts_stats *s, const ts_rank_stats *r, ts_error *err);
/* Adds what one device measured (its stages, counters, lod histogram, iterations and
 * kernel build time) into the frame's stats s. */
int stats_merge(ts_stats *s, const ts_stats *device, ts_error *err);
/* Peak resident set size of this process in bytes (getrusage). */
uint64_t stats_peak_rss_bytes(void);
/* Writes the JSON document atomically (temporary file, then rename). */
int stats_write_json(const ts_stats *s, const char *path, ts_error *err);
/* Prints the per-stage table (seconds, share) and counters to `f`. */
void stats_print_table(const ts_stats *s, void *file);
void stats_free(ts_stats *s);

#endif
