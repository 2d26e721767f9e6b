/* parallel.h — a loop over [0, n) split into contiguous chunks on the host's cores, for the
 * per-patch passes on the render's critical path (the pipeline's patch boxes and flatness
 * bounds: 0.4 s of forest-1000's set-up on one core). Each index is visited once, by one
 * thread, so a body that writes only its own entries needs no lock. */
#ifndef TS_PARALLEL_H
#define TS_PARALLEL_H

#include <stddef.h>

/* The threads ts_parallel_for starts at most for `threads` (0: every online processor), at
 * most 64. */
unsigned ts_parallel_threads(unsigned threads);

/* fn(ctx, begin, end) over consecutive chunks of [0, n): one chunk a thread, on up to
 * `threads` threads (0: every online processor), none smaller than `grain` items; the
 * calling thread takes the first chunk, and a chunk whose thread cannot be started too.
 * Returns once every chunk is done. */
void ts_parallel_for(size_t n, size_t grain, unsigned threads,
                     void (*fn)(void *ctx, size_t begin, size_t end), void *ctx);

#endif
