/* prefetch.h — software prefetches of the ray fields a kernel will read a few work-items on
 * (bottom_level, top_level). Only where the host builds with -DTS_PREFETCH (PoCL's CPU
 * devices, host/device/device.c dev_build_options): there a work-group's work-items run one
 * after another on one core, so item k + 8's rays, fetched while item k traverses, are in the
 * cache when their turn comes (bottom_level's pairs reach their rays in no order the hardware
 * prefetcher follows: 0.87 of its time on teapot_displaced, docs/benchmarks.md). OpenCL C's
 * prefetch() is a no-op in PoCL 3.1; __builtin_prefetch is Clang's. Elsewhere nothing: a
 * GPU hides the latency with other warps. Reads nothing, writes nothing, changes no result. */
#ifndef TS_PREFETCH_H
#define TS_PREFETCH_H

/* Defined only where prefetches are made: the kernels leave out the loads that find the
 * addresses (#ifdef TS_PREFETCH_AT) everywhere else. */
#if defined(TS_PREFETCH) && defined(__clang__)
#define TS_PREFETCH_AT(p) __builtin_prefetch(p)
#endif

/* How many work-items ahead the ray fields are fetched; the index list, twice as far. */
#define TS_PREFETCH_AHEAD 8u

#endif
