/* radix_sort.c — the `sort` stage: stable LSD radix sort of (leaf, window) pairs by leaf.
 *
 * Reads:  the pair array top_level wrote (mapped, zero copy on CPU devices): n pairs, 8 bytes
 *         each, leaf < key_limit or TS_INVALID; or (radix_sort_windows) n windows of `width`
 *         pairs of which the first counts[w] are used, the rest never read.
 * Writes: the valid pairs, stably sorted by leaf, into pairs or scratch; then segments.
 * Invariants: equal leaves keep their input order (each pass is stable: the input is cut
 *         into contiguous chunks, and chunk c's bucket d starts after bucket d of every
 *         earlier chunk); TS_INVALID pairs are dropped by the first pass, so later passes
 *         touch only valid pairs; no allocation and no thread creation per call.
 * Paper:  Hanika, Keller, Lensch 2010, §3.1 and Fig. 2 (sort the (leaf, ray) pairs so every
 *         patch is diced once per iteration for all its rays).
 *
 * One call runs up to 4 passes of 8 bits (radix_sort_pass_count), each in three phases:
 *   count   one task per chunk: the chunk's digit histogram (257 buckets: 256 digits plus
 *           TS_INVALID in the first pass) into its own row;
 *   prefix  one task: totals, whether the pass can be skipped (one bucket holds every pair,
 *           so nothing would move), and each row turned in place into that chunk's first
 *           output position per bucket (a prefix over (digit, chunk): 2 * 257 * chunks adds);
 *   scatter one task per chunk: the chunk's pairs to the other buffer.
 * Tasks are numbered in that order and claimed one at a time from an atomic counter by
 * whichever pool thread is free (the caller included); a task first waits until the phase
 * before it is complete. So a thread descheduled by another process (this runs on shared
 * 2-core machines) delays only the one chunk it holds: the others take the rest, where a
 * static split with barriers would wait for its whole share, and for its arrival.
 */
#include "pipeline/sort.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Histogram row layout (uint32 words): [0, 256) digit counts, [256] TS_INVALID pairs (first
 * pass), [257] nonzero if a valid leaf is >= key_limit. The prefix task overwrites [0, 257)
 * with the chunk's first output position per bucket. */
#define RADIX_INVALID_BUCKET RADIX_BUCKETS
#define RADIX_BAD_SLOT (RADIX_BUCKETS + 1)
#define RADIX_ROW_USED (RADIX_BAD_SLOT + 1)
#define RADIX_OFF_SLOTS (RADIX_BUCKETS + 1)
/* Pairs per scatter block: destination indices of one block, 2 KiB, stay in L1. */
#define RADIX_BLOCK 512
#define RADIX_MAX_PASSES 4
#define RADIX_PHASES (3 * RADIX_MAX_PASSES) /* count, prefix, scatter per pass */
#define RADIX_MAX_THREADS 256
/* A waiting thread spins this many pause instructions (~10-100 us) before sleeping: phases
 * of a 2^20-pair sort are ~1 ms apart, and on a busy machine a spinning waiter steals the
 * core from the thread it waits for. */
#define RADIX_SPIN_LIMIT 4096

_Static_assert(RADIX_HIST_STRIDE >= RADIX_ROW_USED, "histogram row too short");
_Static_assert((RADIX_HIST_STRIDE * sizeof(uint32_t)) % 64 == 0, "rows must fill cache lines");
_Static_assert(sizeof(ts_pair) == 8, "ts_pair is 8 bytes");

/* What pass p reads: written by the prefix task of pass p - 1 (by the caller for p = 0). */
typedef struct radix_pass_input {
    uint32_t buf; /* index into radix_job.buf */
    uint32_t m;   /* entries: n for the first pass, the valid count after it */
} radix_pass_input;

/* One call's work. The caller writes the parameters under the pool lock before it publishes
 * the generation; tasks write the per-pass fields, ordered by the phase counters. */
typedef struct radix_job {
    ts_pair *buf[2];        /* [0] = pairs, [1] = scratch */
    uint32_t n;             /* input pairs (windowed: windows) */
    const uint32_t *counts; /* windowed input: valid pairs per window, NULL for flat input */
    uint32_t width;         /* windowed input: pairs per window */
    uint32_t key_limit;     /* valid leaves are < key_limit */
    uint32_t passes;        /* max(1, radix_sort_pass_count(key_limit)) */
    uint32_t mask;          /* first-pass digit mask: 0xff, or 0 when the pass only compacts */
    uint32_t chunks;        /* chunks per pass, 1 .. RADIX_MAX_CHUNKS */
    uint32_t tasks;         /* passes * (2 * chunks + 1) */
    radix_pass_input in[RADIX_MAX_PASSES + 1]; /* in[passes]: where the result is */
    bool skip[RADIX_MAX_PASSES];               /* the pass would move nothing */
    bool bad;                                  /* a leaf >= key_limit: nothing was moved */
} radix_job;

struct radix_sorter {
    int threads;    /* pool size counting the caller */
    uint32_t grain; /* minimum pairs per chunk */
    pthread_t *tids;
    int started;           /* workers running: threads - 1 once created */
    pthread_mutex_t lock;  /* guards generation, quit and the job parameters */
    pthread_cond_t wake;   /* workers wait here for a new generation */
    pthread_cond_t phased; /* threads wait here for a phase to complete */
    uint32_t generation;   /* one per call */
    bool quit;
    radix_job job;
    _Atomic uint64_t next;          /* (generation << 32) | next task to claim */
    atomic_uint done[RADIX_PHASES]; /* tasks completed per phase */
    uint32_t *rows;                 /* [RADIX_MAX_CHUNKS][RADIX_HIST_STRIDE], 64-byte aligned */
};

static inline void radix_cpu_relax(void)
{
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
}

uint32_t radix_sort_pass_count(uint32_t key_limit)
{
    uint32_t passes = 0;
    for (uint32_t max_key = key_limit > 0 ? key_limit - 1 : 0; max_key != 0; max_key >>= 8)
        passes++;
    return passes;
}

/* Chunk c of m entries cut in `chunks`: [*begin, *end), contiguous and in chunk order. */
static void radix_chunk(uint32_t m, uint32_t c, uint32_t chunks, uint32_t *begin, uint32_t *end)
{
    *begin = (uint32_t)((uint64_t)m * c / chunks);
    *end = (uint32_t)((uint64_t)m * (c + 1) / chunks);
}

/* First pass: counts digit (leaf & mask) of src[begin, end) into row[0..255], TS_INVALID
 * pairs into row[256], and sets row[RADIX_BAD_SLOT] if a valid leaf is >= key_limit.
 * Branch-free, as invalid pairs come in no useful order: `sel` is all ones for an invalid
 * pair (gcc 12 compiles `inv ? 256 : digit` here to a branch that mispredicts half the time
 * on random input, 2x slower), and the range check keeps a running maximum. */
static void radix_count_first(const ts_pair *src, uint32_t begin, uint32_t end, uint32_t mask,
                              uint32_t key_limit, uint32_t *row)
{
    memset(row, 0, RADIX_ROW_USED * sizeof *row);
    uint32_t max_key = 0, any_valid = 0;
    for (uint32_t i = begin; i < end; i++) {
        uint32_t k = src[i].leaf;
        uint32_t inv = (k == TS_INVALID);
        uint32_t sel = 0u - inv;
        uint32_t kv = k & ~sel; /* 0 for an invalid pair */
        max_key = kv > max_key ? kv : max_key;
        any_valid |= inv ^ 1u;
        row[((k & mask) & ~sel) | (RADIX_INVALID_BUCKET & sel)]++;
    }
    row[RADIX_BAD_SLOT] = any_valid && max_key >= key_limit;
}

/* Later passes: counts digit ((leaf >> shift) & 0xff) of src[begin, end); all are valid. */
static void radix_count(const ts_pair *src, uint32_t begin, uint32_t end, unsigned shift,
                        uint32_t *row)
{
    memset(row, 0, RADIX_ROW_USED * sizeof *row);
    for (uint32_t i = begin; i < end; i++)
        row[(src[i].leaf >> shift) & 0xffu]++;
}

/* Scatter, both passes, one block of RADIX_BLOCK pairs at a time in two steps: first every
 * destination index (the off[d]++ chain: loads and stores of off[] only), then the copies.
 * Fused into one loop, each store's address waits on a load of off[] and each later load
 * of off[] waits on that store: 2x slower (8 -> 4 ms per 2^20-pair pass on this machine).
 *
 * First pass: valid pairs go to their bucket; invalid ones all go to one trash slot, the
 * chunk's first position in the invalid range [valid, m) of dst (off[256], never advanced),
 * which no one reads and no other chunk writes: no branch, and no memory traffic for
 * dropped pairs. */
static void radix_scatter_first(const ts_pair *src, ts_pair *dst, uint32_t begin, uint32_t end,
                                uint32_t mask, uint32_t off[RADIX_OFF_SLOTS])
{
    uint32_t idx[RADIX_BLOCK]; /* destination of each pair of the block: 2 KiB */
    for (uint32_t b = begin; b < end; b += RADIX_BLOCK) {
        const ts_pair *blk = src + b;
        uint32_t len = end - b < RADIX_BLOCK ? end - b : RADIX_BLOCK;
        for (uint32_t j = 0; j < len; j++) {
            uint32_t k = blk[j].leaf;
            uint32_t inv = (k == TS_INVALID);
            uint32_t sel = 0u - inv;
            uint32_t d = ((k & mask) & ~sel) | (RADIX_INVALID_BUCKET & sel);
            idx[j] = off[d];
            off[d] += inv ^ 1u;
        }
        for (uint32_t j = 0; j < len; j++)
            dst[idx[j]] = blk[j];
    }
}

static void radix_scatter(const ts_pair *src, ts_pair *dst, uint32_t begin, uint32_t end,
                          unsigned shift, uint32_t off[RADIX_OFF_SLOTS])
{
    uint32_t idx[RADIX_BLOCK]; /* 2 KiB */
    for (uint32_t b = begin; b < end; b += RADIX_BLOCK) {
        const ts_pair *blk = src + b;
        uint32_t len = end - b < RADIX_BLOCK ? end - b : RADIX_BLOCK;
        for (uint32_t j = 0; j < len; j++)
            idx[j] = off[(blk[j].leaf >> shift) & 0xffu]++;
        for (uint32_t j = 0; j < len; j++)
            dst[idx[j]] = blk[j];
    }
}

/* First pass over windows (radix_sort_windows): window w holds counts[w] valid pairs at
 * src[w * width ..]; the rest of it is never read, so top_level need not fill it. Counts
 * digits as radix_count_first does (no pair is invalid here). */
static void radix_count_windows(const ts_pair *src, const uint32_t *counts, uint32_t width,
                                uint32_t begin, uint32_t end, uint32_t mask, uint32_t key_limit,
                                uint32_t *row)
{
    memset(row, 0, RADIX_ROW_USED * sizeof *row);
    uint32_t max_key = 0, any_valid = 0;
    for (uint32_t w = begin; w < end; w++) {
        const ts_pair *win = src + (size_t)w * width;
        for (uint32_t k = 0, c = counts[w]; k < c; k++) {
            uint32_t key = win[k].leaf;
            max_key = key > max_key ? key : max_key;
            row[key & mask]++;
        }
        any_valid |= counts[w];
    }
    row[RADIX_BAD_SLOT] = any_valid && max_key >= key_limit;
}

/* Scatter of the first pass over windows: the valid pairs, in window order, to their
 * buckets (the same order radix_scatter_first gives the filled windows). */
static void radix_scatter_windows(const ts_pair *src, const uint32_t *counts, uint32_t width,
                                  ts_pair *dst, uint32_t begin, uint32_t end, uint32_t mask,
                                  uint32_t off[RADIX_OFF_SLOTS])
{
    for (uint32_t w = begin; w < end; w++) {
        const ts_pair *win = src + (size_t)w * width;
        for (uint32_t k = 0, c = counts[w]; k < c; k++)
            dst[off[win[k].leaf & mask]++] = win[k];
    }
}

static uint32_t *radix_row(radix_sorter *s, uint32_t chunk)
{
    return s->rows + (size_t)chunk * RADIX_HIST_STRIDE;
}

static void radix_count_task(radix_sorter *s, uint32_t p, uint32_t chunk)
{
    const radix_job *job = &s->job;
    const ts_pair *src = job->buf[job->in[p].buf];
    uint32_t begin, end;
    radix_chunk(job->in[p].m, chunk, job->chunks, &begin, &end);
    if (p == 0 && job->counts)
        radix_count_windows(src, job->counts, job->width, begin, end, job->mask, job->key_limit,
                            radix_row(s, chunk));
    else if (p == 0)
        radix_count_first(src, begin, end, job->mask, job->key_limit, radix_row(s, chunk));
    else
        radix_count(src, begin, end, RADIX_DIGIT_BITS * p, radix_row(s, chunk));
}

/* Pass p's totals; whether it can be skipped; each row turned into its chunk's first output
 * position per bucket: the pairs of smaller buckets plus the bucket's pairs in earlier
 * chunks (which is what keeps the sort stable). Invalid pairs (bucket 256) go last. */
static void radix_prefix_task(radix_sorter *s, uint32_t p)
{
    radix_job *job = &s->job;
    uint32_t total[RADIX_BUCKETS + 1] = {0}, m = job->in[p].m;
    bool bad = false, trivial = false;
    for (uint32_t c = 0; c < job->chunks; c++) {
        const uint32_t *row = radix_row(s, c);
        for (int d = 0; d <= RADIX_BUCKETS; d++)
            total[d] += row[d];
        bad |= row[RADIX_BAD_SLOT] != 0;
    }
    if (p == 0 && job->counts) { /* m counts windows; the pass compacts, so it always runs */
        m = 0;
        for (int d = 0; d < RADIX_BUCKETS; d++)
            m += total[d];
    } else {
        for (int d = 0; d <= RADIX_BUCKETS; d++)
            trivial |= (total[d] == m);
    }
    if (bad) job->bad = true; /* later passes see m = 0 and skip */
    job->skip[p] = trivial || bad;
    job->in[p + 1].buf = job->in[p].buf ^ (job->skip[p] ? 0u : 1u);
    job->in[p + 1].m = bad ? 0 : m - total[RADIX_INVALID_BUCKET];
    if (job->skip[p]) return;
    uint32_t base = 0;
    for (int d = 0; d <= RADIX_BUCKETS; d++) {
        uint32_t run = base;
        for (uint32_t c = 0; c < job->chunks; c++) {
            uint32_t *row = radix_row(s, c);
            uint32_t count = row[d];
            row[d] = run;
            run += count;
        }
        base += total[d];
    }
}

static void radix_scatter_task(radix_sorter *s, uint32_t p, uint32_t chunk)
{
    const radix_job *job = &s->job;
    if (job->skip[p]) return;
    const ts_pair *src = job->buf[job->in[p].buf];
    ts_pair *dst = job->buf[job->in[p].buf ^ 1u];
    uint32_t begin, end, off[RADIX_OFF_SLOTS];
    radix_chunk(job->in[p].m, chunk, job->chunks, &begin, &end);
    memcpy(off, radix_row(s, chunk), sizeof off);
    if (p == 0 && job->counts)
        radix_scatter_windows(src, job->counts, job->width, dst, begin, end, job->mask, off);
    else if (p == 0)
        radix_scatter_first(src, dst, begin, end, job->mask, off);
    else
        radix_scatter(src, dst, begin, end, RADIX_DIGIT_BITS * p, off);
}

/* Tasks phase `phase` has: one prefix, or one per chunk. */
static uint32_t radix_phase_tasks(const radix_job *job, uint32_t phase)
{
    return phase % 3 == 1 ? 1u : job->chunks;
}

/* Waits until every task of `phase` is complete (acquire: their writes are visible). */
static void radix_wait_phase(radix_sorter *s, uint32_t phase)
{
    uint32_t need = radix_phase_tasks(&s->job, phase);
    for (int i = 0; i < RADIX_SPIN_LIMIT; i++) {
        if (atomic_load_explicit(&s->done[phase], memory_order_acquire) >= need) return;
        radix_cpu_relax();
    }
    pthread_mutex_lock(&s->lock);
    while (atomic_load_explicit(&s->done[phase], memory_order_acquire) < need)
        pthread_cond_wait(&s->phased, &s->lock);
    pthread_mutex_unlock(&s->lock);
}

/* Counts one task of `phase` done (release); the last one wakes the sleepers. */
static void radix_complete(radix_sorter *s, uint32_t phase)
{
    uint32_t need = radix_phase_tasks(&s->job, phase);
    if (atomic_fetch_add_explicit(&s->done[phase], 1, memory_order_acq_rel) + 1 == need) {
        pthread_mutex_lock(&s->lock);
        pthread_cond_broadcast(&s->phased);
        pthread_mutex_unlock(&s->lock);
    }
}

static void radix_run_task(radix_sorter *s, uint32_t task)
{
    uint32_t chunks = s->job.chunks, per_pass = 2 * chunks + 1;
    uint32_t p = task / per_pass, k = task % per_pass;
    uint32_t kind = k < chunks ? 0u : (k == chunks ? 1u : 2u); /* count, prefix, scatter */
    uint32_t phase = 3 * p + kind;
    if (phase > 0) radix_wait_phase(s, phase - 1);
    if (kind == 0)
        radix_count_task(s, p, k);
    else if (kind == 1)
        radix_prefix_task(s, p);
    else
        radix_scatter_task(s, p, k - chunks - 1);
    radix_complete(s, phase);
}

/* Claims and runs tasks of call `generation` (which has `tasks` tasks) until none is left.
 * The generation in the counter stops a thread that wakes late from claiming a task of a
 * later call with what it read of an earlier one. */
static void radix_work(radix_sorter *s, uint32_t generation, uint32_t tasks)
{
    uint64_t cur = atomic_load_explicit(&s->next, memory_order_relaxed);
    for (;;) {
        if ((uint32_t)(cur >> 32) != generation || (uint32_t)cur >= tasks) return;
        if (atomic_compare_exchange_weak_explicit(&s->next, &cur, cur + 1, memory_order_relaxed,
                                                  memory_order_relaxed)) {
            radix_run_task(s, (uint32_t)cur);
            cur = atomic_load_explicit(&s->next, memory_order_relaxed);
        }
    }
}

static void *radix_worker_main(void *arg)
{
    radix_sorter *s = arg;
    uint32_t seen = 0;
    pthread_mutex_lock(&s->lock);
    for (;;) {
        while (s->generation == seen && !s->quit)
            pthread_cond_wait(&s->wake, &s->lock);
        if (s->quit) break;
        seen = s->generation;
        uint32_t tasks = s->job.tasks;
        pthread_mutex_unlock(&s->lock);
        radix_work(s, seen, tasks);
        pthread_mutex_lock(&s->lock);
    }
    pthread_mutex_unlock(&s->lock);
    return NULL;
}

/* Publishes the job as a new generation (under the lock: a worker that wakes late reads
 * s->job.tasks), wakes the pool if there is more than one chunk, works on it and returns
 * when its last phase is complete. */
static void radix_dispatch(radix_sorter *s, const radix_job *params)
{
    pthread_mutex_lock(&s->lock);
    s->job = *params;
    uint32_t generation = ++s->generation;
    uint32_t tasks = s->job.tasks;
    for (int ph = 0; ph < RADIX_PHASES; ph++)
        atomic_store_explicit(&s->done[ph], 0, memory_order_relaxed);
    atomic_store_explicit(&s->next, (uint64_t)generation << 32, memory_order_relaxed);
    if (s->job.chunks > 1) pthread_cond_broadcast(&s->wake);
    pthread_mutex_unlock(&s->lock);
    radix_work(s, generation, tasks);
    radix_wait_phase(s, 3 * s->job.passes - 1);
}

/* Stops and joins the started workers, frees everything. */
static void radix_sorter_free(radix_sorter *s)
{
    pthread_mutex_lock(&s->lock);
    s->quit = true;
    pthread_cond_broadcast(&s->wake);
    pthread_mutex_unlock(&s->lock);
    for (int i = 0; i < s->started; i++)
        pthread_join(s->tids[i], NULL);
    pthread_cond_destroy(&s->phased);
    pthread_cond_destroy(&s->wake);
    pthread_mutex_destroy(&s->lock);
    free(s->rows);
    free(s->tids);
    free(s);
}

static int radix_default_threads(void)
{
    long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    return cpus < 1 ? 1 : (cpus > RADIX_MAX_THREADS ? RADIX_MAX_THREADS : (int)cpus);
}

radix_sorter *radix_sorter_create(int threads, ts_error *err)
{
    if (threads <= 0) threads = radix_default_threads();
    if (threads > RADIX_MAX_THREADS) threads = RADIX_MAX_THREADS;
    radix_sorter *s = calloc(1, sizeof *s);
    if (!s) {
        ts_error_set(err, TS_E_MEMORY, "sort: cannot allocate the sorter");
        return NULL;
    }
    s->threads = threads;
    s->grain = RADIX_DEFAULT_GRAIN;
    pthread_mutex_init(&s->lock, NULL);
    pthread_cond_init(&s->wake, NULL);
    pthread_cond_init(&s->phased, NULL);
    atomic_init(&s->next, 0);
    for (int ph = 0; ph < RADIX_PHASES; ph++)
        atomic_init(&s->done[ph], 0);
    size_t row_bytes = (size_t)RADIX_MAX_CHUNKS * RADIX_HIST_STRIDE * sizeof(uint32_t);
    s->rows = aligned_alloc(64, row_bytes);
    s->tids = calloc((size_t)threads, sizeof *s->tids);
    if (!s->rows || !s->tids) {
        ts_error_set(err, TS_E_MEMORY, "sort: cannot allocate %zu bytes of histograms", row_bytes);
        radix_sorter_free(s);
        return NULL;
    }
    for (int i = 1; i < threads; i++) {
        int rc = pthread_create(&s->tids[i - 1], NULL, radix_worker_main, s);
        if (rc != 0) {
            ts_error_set(err, TS_E_MEMORY, "sort: cannot start sort thread %d of %d: %s", i,
                         threads, strerror(rc));
            radix_sorter_free(s);
            return NULL;
        }
        s->started = i;
    }
    return s;
}

void radix_sorter_destroy(radix_sorter *s)
{
    if (s) radix_sorter_free(s);
}

int radix_sorter_threads(const radix_sorter *s)
{
    return s->threads;
}

void radix_sorter_set_grain(radix_sorter *s, uint32_t pairs_per_chunk)
{
    s->grain = pairs_per_chunk ? pairs_per_chunk : 1;
}

/* Chunks for n pairs: at least `grain` pairs each, at most RADIX_MAX_CHUNKS. The same for
 * every pool size, so the work done does not depend on the thread count. */
static uint32_t radix_chunk_count(const radix_sorter *s, uint32_t n)
{
    uint32_t chunks = n / s->grain;
    if (chunks < 1) chunks = 1;
    return chunks < RADIX_MAX_CHUNKS ? chunks : RADIX_MAX_CHUNKS;
}

/* Error path only: names the first pair whose leaf breaks the key_limit contract (pair i of
 * window w: counts NULL means flat input, one pair per window, TS_INVALID ones skipped). */
static int radix_report_bad(const ts_pair *pairs, const uint32_t *counts, uint32_t width,
                            uint32_t n, uint32_t key_limit, ts_error *err)
{
    for (uint32_t w = 0; w < n; w++)
        for (uint32_t k = 0, c = counts ? counts[w] : 1u; k < c; k++) {
            ts_pair pr = pairs[(size_t)w * width + k];
            if (pr.leaf != TS_INVALID && pr.leaf >= key_limit)
                return ts_error_set(err, TS_E_INTERNAL,
                                    "sort: pair %zu has leaf %u >= key_limit %u (window %u)",
                                    (size_t)w * width + k, pr.leaf, key_limit, pr.window);
        }
    return ts_error_set(err, TS_E_INTERNAL, "sort: a leaf is >= key_limit %u", key_limit);
}

/* radix_sort_pairs (counts NULL, width 1) and radix_sort_windows: n inputs, pairs or windows. */
static int radix_sort_run(radix_sorter *s, ts_pair *pairs, ts_pair *scratch, uint32_t n,
                          const uint32_t *counts, uint32_t width, uint32_t key_limit,
                          const ts_pair **sorted, uint32_t *valid_count, ts_error *err)
{
    if (!sorted || !valid_count)
        return ts_error_set(err, TS_E_INTERNAL, "sort: NULL result pointer");
    *sorted = NULL;
    *valid_count = 0;
    if (!s || (n > 0 && (!pairs || !scratch || pairs == scratch)))
        return ts_error_set(err, TS_E_INTERNAL, "sort: bad sorter or buffers");
    if (n == 0) {
        *sorted = pairs;
        return TS_OK;
    }
    uint32_t passes = radix_sort_pass_count(key_limit);
    uint32_t chunks = radix_chunk_count(s, n);
    radix_job params = {
        .buf = {pairs, scratch},
        .n = n,
        .counts = counts,
        .width = width,
        .key_limit = key_limit,
        .passes = passes > 0 ? passes : 1,
        .mask = passes > 0 ? 0xffu : 0u,
        .chunks = chunks,
        .tasks = (passes > 0 ? passes : 1) * (2 * chunks + 1),
        .in = {{.buf = 0, .m = n}},
    };
    radix_dispatch(s, &params);
    const radix_job *job = &s->job;
    if (job->bad) return radix_report_bad(pairs, counts, width, n, key_limit, err);
    *sorted = job->buf[job->in[job->passes].buf];
    *valid_count = job->in[job->passes].m;
    return TS_OK;
}

int radix_sort_pairs(radix_sorter *s, ts_pair *pairs, ts_pair *scratch, uint32_t n,
                     uint32_t key_limit, const ts_pair **sorted, uint32_t *valid_count,
                     ts_error *err)
{
    return radix_sort_run(s, pairs, scratch, n, NULL, 1u, key_limit, sorted, valid_count, err);
}

int radix_sort_windows(radix_sorter *s, ts_pair *pairs, ts_pair *scratch, const uint32_t *counts,
                       uint32_t windows, uint32_t width, uint32_t key_limit, const ts_pair **sorted,
                       uint32_t *valid_count, ts_error *err)
{
    if (windows > 0 && (!counts || width == 0))
        return ts_error_set(err, TS_E_INTERNAL, "sort: windows without counts or width");
    return radix_sort_run(s, pairs, scratch, windows, counts, width, key_limit, sorted, valid_count,
                          err);
}

uint32_t sort_segments(const ts_pair *sorted, uint32_t n, ts_segment *out, uint32_t capacity)
{
    uint32_t count = 0, begin = 0;
    for (uint32_t i = 1; i <= n; i++) {
        if (i < n && sorted[i].leaf == sorted[begin].leaf) continue;
        if (count == capacity) return UINT32_MAX;
        out[count++] = (ts_segment){.patch = sorted[begin].leaf, .begin = begin, .end = i};
        begin = i;
    }
    return count;
}
