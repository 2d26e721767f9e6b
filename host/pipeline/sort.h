/* radix_sort.h — the `sort` stage (DESIGN.md §1; Hanika et al. 2010 Fig. 2): a stable LSD
 * radix sort of the (leaf, window) pairs written by top_level, by leaf, on the host, then
 * one segment [begin, end) per leaf for dice / build / bottom_level.
 *
 * The sorter owns a persistent thread pool, created once per render: worker threads sleep
 * on a condition variable between calls, so a call creates no thread. A call cuts the
 * input into contiguous chunks; per pass, the pool threads (the caller among them) take
 * count, prefix and scatter tasks of those chunks from a shared counter (see radix_sort.c).
 *
 * Work buffers (n = pairs passed in):
 *   pairs, scratch: caller's, n * 8 bytes each (sizeof(ts_pair) = 8); ping-ponged.
 *   histograms:     owned, RADIX_MAX_CHUNKS * RADIX_HIST_STRIDE * 4 = 69632 bytes, one row
 *                   per chunk, reused by every pass and call.
 *   on each thread's stack: bucket offsets 257 * 4 = 1028 bytes, destination indices of one
 *                   scatter block 512 * 4 = 2048 bytes, pass totals 1028 bytes.
 * Nothing is allocated per call.
 */
#ifndef TS_RADIX_SORT_H
#define TS_RADIX_SORT_H

#include "base/error.h"
#include "lib/shared_types.h"

#include <stdint.h>

/* Bits per digit and buckets per pass; bucket RADIX_BUCKETS collects TS_INVALID entries in
 * the first pass (they end up after the valid ones and are then ignored). */
#define RADIX_DIGIT_BITS 8
#define RADIX_BUCKETS 256
/* uint32 words per chunk histogram: 256 digits + 1 invalid bucket + 1 out-of-range flag,
 * padded to 1088 bytes (17 cache lines of 64 bytes) so two chunks never share a line. */
#define RADIX_HIST_STRIDE 272

/* Pairs per chunk at least (one chunk, run by the caller alone, for n < 2 * grain): waking a
 * sleeping worker costs tens of microseconds, about what one core sorts 32 Ki pairs in. */
#define RADIX_DEFAULT_GRAIN (32u * 1024u)
/* Chunks per call at most: 2^20 pairs make 32 chunks of 32 Ki. */
#define RADIX_MAX_CHUNKS 64u

typedef struct radix_sorter radix_sorter;

/* Creates a sorter with a pool of `threads` threads in all, counting the caller (threads <= 0:
 * the number of online CPUs). Returns NULL and sets err (TS_E_MEMORY, also when a thread cannot
 * be started) on failure. Not thread-safe: one call at a time per sorter. */
radix_sorter *radix_sorter_create(int threads, ts_error *err);
/* Joins the pool and frees the sorter. NULL is a no-op. */
void radix_sorter_destroy(radix_sorter *s);
/* Threads in the pool, counting the caller. */
int radix_sorter_threads(const radix_sorter *s);
/* Minimum pairs per chunk (default RADIX_DEFAULT_GRAIN; 0 is taken as 1): a call makes
 * min(RADIX_MAX_CHUNKS, max(1, n / grain)) chunks, whatever the pool size. Tests set 1 to cut
 * tiny inputs into many chunks. */
void radix_sorter_set_grain(radix_sorter *s, uint32_t pairs_per_chunk);

/* 8-bit passes needed for keys in [0, key_limit): 0 for key_limit <= 1, 1 up to 256,
 * 2 up to 65536, 3 up to 2^24, else 4. */
uint32_t radix_sort_pass_count(uint32_t key_limit);

/* Stably sorts the n pairs by leaf and drops those with leaf == TS_INVALID.
 * key_limit: every valid leaf is < key_limit (the number of leaves); only
 * radix_sort_pass_count(key_limit) passes run, the first of which also drops the invalid
 * pairs, so later passes touch only valid ones (with key_limit <= 1 the one pass just
 * compacts). pairs and scratch (n pairs each, not overlapping) are both overwritten;
 * *sorted is set to whichever holds the result: its first *valid_count entries are the
 * valid pairs, equal leaves in their input order; entries after that are unspecified.
 * A pass whose digit is the same for every pair is skipped, so *sorted may be `pairs`.
 * Returns TS_OK, or TS_E_INTERNAL (err set, *sorted = NULL, *valid_count = 0) when a valid
 * leaf is >= key_limit: the contract with top_level broke and the buffers hold garbage. */
int radix_sort_pairs(radix_sorter *s, ts_pair *pairs, ts_pair *scratch, uint32_t n,
                     uint32_t key_limit, const ts_pair **sorted, uint32_t *valid_count,
                     ts_error *err);

/* radix_sort_pairs for top_level's windows: window w (of `windows`) is pairs[w * width ..),
 * of which only the first counts[w] (<= width) are candidates, all valid; the rest of each
 * window is never read (top_level leaves it unwritten). The result is what radix_sort_pairs
 * gives for the same windows filled up with TS_INVALID pairs, at a cost in the valid pairs
 * (plus 4 bytes of count per window) instead of in width * windows: on the teapot demo ~8 %
 * of the window slots are used. pairs and scratch are width * windows pairs each. */
int radix_sort_windows(radix_sorter *s, ts_pair *pairs, ts_pair *scratch, const uint32_t *counts,
                       uint32_t windows, uint32_t width, uint32_t key_limit, const ts_pair **sorted,
                       uint32_t *valid_count, ts_error *err);

/* Fills out[] with one segment per distinct leaf of sorted[0, n) (which must be sorted by
 * leaf): patch = leaf, [begin, end) its pairs; the other fields are set to 0. Returns the
 * segment count (0 for n == 0). If there are more than `capacity` distinct leaves it returns
 * UINT32_MAX, having written only out[0, capacity): size out for the number of leaves (the
 * key_limit given to radix_sort_pairs) and that never happens. */
uint32_t sort_segments(const ts_pair *sorted, uint32_t n, ts_segment *out, uint32_t capacity);

#endif
