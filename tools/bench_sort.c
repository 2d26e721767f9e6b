/* bench_sort.c — throughput of the `sort` stage (host/pipeline/sort.c) against the machine's
 * copy bandwidth measured in the same run (DESIGN.md §6).
 *
 * For key ranges 32, 65536 and 2^21 (1, 2 and 3 passes) it sorts N pairs (8 bytes each),
 * half of them TS_INVALID at random, R times and reports the median. Pairs/s counts all N
 * input pairs, valid or not. Before every repetition the input is restored by a memcpy of
 * the same N * 8 bytes, which is timed: its median over all repetitions is the copy
 * bandwidth, and ratio = median sort time / median memcpy time (1.0 would be a sort as fast
 * as one copy of the pair array). One warm-up repetition per key range is not recorded.
 * The fastest sort is printed too: on a shared machine it is the less noisy figure.
 * sort_segments is timed separately (Mpairs/s and ratio are from the median sort).
 * After the last repetition of each key range the result is verified (outside the timing):
 * exactly the valid input pairs, ascending by leaf, equal leaves in input order, and one
 * segment per distinct leaf covering its pairs; a wrong result exits 1.
 *
 * --size tiny|small|full (tools/bench, issue 8): 2^14 pairs x 3, 2^20 x 15 (default), 2^23
 * x 15; --pairs and --repeat given after it override.
 *
 * usage: bench_sort [--size tiny|small|full] [--pairs N] [--repeat R] [--threads T] [--json PATH]
 */
#include "bench_util.h"
#include "pipeline/sort.h"

#include <cjson/cJSON.h>
#include <getopt.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define BENCH_CASES 3
static const uint32_t bench_key_ranges[BENCH_CASES] = {32, 65536, 1u << 21};

typedef struct bench_options {
    uint32_t pairs;
    int repeat;
    int threads; /* 0: online CPUs */
    const char *json_path;
} bench_options;

typedef struct bench_case {
    uint32_t key_range, passes, valid;
    double sort_s;     /* median seconds per sort */
    double sort_min_s; /* fastest sort: the floor on a noisy machine */
    double segments_s; /* median seconds per sort_segments */
    uint32_t segments;
    int verified; /* bench_verify passed on the last repetition */
} bench_case;

static void bench_defaults(bench_options *o)
{
    *o = (bench_options){.pairs = 1u << 20, .repeat = 15, .threads = 0, .json_path = NULL};
}

/* --size: tiny (seconds, the ctest smoke test), small (the docs' figures), full. */
static int bench_size(const char *name, bench_options *o)
{
    static const struct {
        const char *name;
        uint32_t pairs;
        int repeat;
    } sizes[] = {{"tiny", 1u << 14, 3}, {"small", 1u << 20, 15}, {"full", 1u << 23, 15}};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++)
        if (strcmp(name, sizes[i].name) == 0) {
            o->pairs = sizes[i].pairs;
            o->repeat = sizes[i].repeat;
            return 0;
        }
    fprintf(stderr, "bench_sort: --size must be tiny, small or full, not '%s'\n", name);
    return 1;
}

static int bench_parse(int argc, char **argv, bench_options *o)
{
    static const struct option longopts[] = {
        {"pairs", required_argument, NULL, 'n'},
        {"repeat", required_argument, NULL, 'r'},
        {"threads", required_argument, NULL, 't'},
        {"json", required_argument, NULL, 'j'},
        {"size", required_argument, NULL, 's'},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    int c;
    while ((c = getopt_long(argc, argv, "n:r:t:j:s:h", longopts, NULL)) != -1) {
        switch (c) {
        case 's':
            if (bench_size(optarg, o)) return 1;
            break;
        case 'n':
            o->pairs = (uint32_t)strtoul(optarg, NULL, 0);
            break;
        case 'r':
            o->repeat = atoi(optarg);
            break;
        case 't':
            o->threads = atoi(optarg);
            break;
        case 'j':
            o->json_path = optarg;
            break;
        default:
            fprintf(stderr,
                    "usage: %s [--size tiny|small|full] [--pairs N] [--repeat R] [--threads T] "
                    "[--json PATH]\n",
                    argv[0]);
            return c == 'h' ? 0 : 1;
        }
    }
    if (o->pairs == 0 || o->repeat < 1) {
        fprintf(stderr, "bench_sort: --pairs and --repeat must be positive\n");
        return 1;
    }
    return -1; /* go on */
}

/* Leaves uniform in [0, key_range), each pair TS_INVALID with probability 1/2; window = i. */
static void bench_fill(ts_pair *p, uint32_t n, uint32_t key_range, uint64_t seed)
{
    uint64_t x = seed * 0x9E3779B97F4A7C15ull + 1;
    for (uint32_t i = 0; i < n; i++) {
        x ^= x << 13; /* xorshift64 */
        x ^= x >> 7;
        x ^= x << 17;
        p[i].leaf = (x & 1) ? TS_INVALID : (uint32_t)((x >> 32) % key_range);
        p[i].window = i;
    }
}

/* Checks sorted[0, valid) and segs[0, nseg) against input[0, n) (filled by bench_fill, so
 * input[i].window == i): the valid pairs, ascending by leaf, equal leaves in input order
 * (stable), none lost or duplicated; segments one per distinct leaf, contiguous. */
static int bench_verify(const ts_pair *input, uint32_t n, const ts_pair *sorted, uint32_t valid,
                        const ts_segment *segs, uint32_t nseg, uint32_t key_range)
{
    uint32_t expect = 0;
    for (uint32_t i = 0; i < n; i++)
        expect += input[i].leaf != TS_INVALID;
    if (valid != expect) return 0;
    /* Each output pair is an input pair (its window names it, the leaf matches); windows
     * strictly increase within a leaf, so none repeats; with the count right, every valid
     * input pair appears exactly once, in input order per leaf. */
    for (uint32_t i = 0; i < valid; i++) {
        const ts_pair *p = &sorted[i];
        if (p->leaf >= key_range || p->window >= n || input[p->window].leaf != p->leaf) return 0;
        if (i > 0 && (sorted[i - 1].leaf > p->leaf ||
                      (sorted[i - 1].leaf == p->leaf && sorted[i - 1].window >= p->window)))
            return 0;
    }
    uint32_t at = 0;
    for (uint32_t k = 0; k < nseg; k++) {
        const ts_segment *g = &segs[k];
        if (g->begin != at || g->end <= g->begin || g->end > valid) return 0;
        if (k > 0 && segs[k - 1].patch >= g->patch) return 0;
        for (uint32_t i = g->begin; i < g->end; i++)
            if (sorted[i].leaf != g->patch) return 0;
        at = g->end;
    }
    return at == valid;
}

typedef struct bench_buffers {
    ts_pair *input, *pairs, *scratch; /* n pairs each: n * 8 bytes */
    ts_segment *segments;             /* one per leaf of the largest range, 32 bytes each */
    double *copy_s;                   /* every memcpy sample, BENCH_CASES * repeat */
    int copies;
} bench_buffers;

/* One key range: R times restore (timed memcpy), sort, segments. */
static int bench_run_case(radix_sorter *s, const bench_options *o, bench_buffers *b,
                          uint32_t key_range, bench_case *out, ts_error *err)
{
    size_t bytes = (size_t)o->pairs * sizeof(ts_pair);
    double *sort_s = malloc((size_t)o->repeat * sizeof *sort_s);
    double *seg_s = malloc((size_t)o->repeat * sizeof *seg_s);
    if (!sort_s || !seg_s) {
        free(sort_s);
        free(seg_s);
        return ts_error_set(err, TS_E_MEMORY, "bench_sort: out of memory");
    }
    bench_fill(b->input, o->pairs, key_range, key_range);
    *out = (bench_case){.key_range = key_range, .passes = radix_sort_pass_count(key_range)};
    for (int r = -1; r < o->repeat; r++) { /* r = -1: warm-up, not recorded */
        double t0 = bench_now();
        memcpy(b->pairs, b->input, bytes);
        double t1 = bench_now();
        const ts_pair *sorted = NULL;
        if (radix_sort_pairs(s, b->pairs, b->scratch, o->pairs, key_range, &sorted, &out->valid,
                             err) != TS_OK)
            break;
        double t2 = bench_now();
        out->segments = sort_segments(sorted, out->valid, b->segments, key_range);
        double t3 = bench_now();
        if (r == o->repeat - 1)
            out->verified = bench_verify(b->input, o->pairs, sorted, out->valid, b->segments,
                                         out->segments, key_range);
        if (r < 0) continue;
        b->copy_s[b->copies++] = t1 - t0;
        sort_s[r] = t2 - t1;
        seg_s[r] = t3 - t2;
    }
    if (err->code == TS_OK && !out->verified)
        ts_error_set(err, TS_E_INTERNAL, "key range %u: the sorted output is wrong", key_range);
    if (err->code == TS_OK) {
        out->sort_s = bench_median(sort_s, o->repeat); /* sorts sort_s: [0] is the minimum */
        out->sort_min_s = sort_s[0];
        out->segments_s = bench_median(seg_s, o->repeat);
    }
    free(sort_s);
    free(seg_s);
    return err->code;
}

static int bench_write_json(const char *path, const bench_options *o, int threads, double copy_s,
                            const bench_case *cases)
{
    double bytes = (double)o->pairs * (double)sizeof(ts_pair);
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "benchmark", "sort");
    cJSON_AddNumberToObject(root, "pairs", o->pairs);
    cJSON_AddNumberToObject(root, "pair_bytes", (double)sizeof(ts_pair));
    cJSON_AddNumberToObject(root, "invalid_fraction", 0.5);
    cJSON_AddNumberToObject(root, "repeat", o->repeat);
    cJSON_AddNumberToObject(root, "threads", threads);
    cJSON *copy = cJSON_AddObjectToObject(root, "memcpy");
    cJSON_AddNumberToObject(copy, "bytes", bytes);
    cJSON_AddNumberToObject(copy, "median_seconds", copy_s);
    cJSON_AddNumberToObject(copy, "gb_per_second", bytes / copy_s * 1e-9);
    cJSON *arr = cJSON_AddArrayToObject(root, "cases");
    for (int c = 0; c < BENCH_CASES; c++) {
        cJSON *j = cJSON_CreateObject();
        cJSON_AddNumberToObject(j, "key_range", cases[c].key_range);
        cJSON_AddNumberToObject(j, "passes", cases[c].passes);
        cJSON_AddNumberToObject(j, "valid_pairs", cases[c].valid);
        cJSON_AddNumberToObject(j, "segments", cases[c].segments);
        cJSON_AddBoolToObject(j, "verified", cases[c].verified);
        cJSON_AddNumberToObject(j, "median_seconds", cases[c].sort_s);
        cJSON_AddNumberToObject(j, "min_seconds", cases[c].sort_min_s);
        cJSON_AddNumberToObject(j, "pairs_per_second", o->pairs / cases[c].sort_s);
        cJSON_AddNumberToObject(j, "ratio_to_memcpy", cases[c].sort_s / copy_s);
        cJSON_AddNumberToObject(j, "segments_median_seconds", cases[c].segments_s);
        cJSON_AddItemToArray(arr, j);
    }
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    FILE *f = text ? fopen(path, "w") : NULL;
    int ok = f && fputs(text, f) >= 0 && fputc('\n', f) != EOF;
    if (f && fclose(f) != 0) ok = 0;
    free(text);
    if (!ok) fprintf(stderr, "bench_sort: cannot write %s\n", path);
    return ok ? 0 : 1;
}

static void bench_print(const bench_options *o, int threads, double copy_s, const bench_case *cases)
{
    double bytes = (double)o->pairs * (double)sizeof(ts_pair);
    printf("sort: %u pairs (%.1f MiB), 50%% invalid, %d threads, median of %d\n", o->pairs,
           bytes / (1024.0 * 1024.0), threads, o->repeat);
    printf("memcpy %.1f MiB: %.3f ms, %.2f GB/s\n", bytes / (1024.0 * 1024.0), copy_s * 1e3,
           bytes / copy_s * 1e-9);
    printf("%10s %6s %9s %9s %10s %10s %12s %8s %12s\n", "key_range", "passes", "valid", "segments",
           "sort_ms", "min_ms", "Mpairs/s", "ratio", "segments_ms");
    for (int c = 0; c < BENCH_CASES; c++)
        printf("%10u %6u %9u %9u %10.3f %10.3f %12.1f %8.2f %12.3f\n", cases[c].key_range,
               cases[c].passes, cases[c].valid, cases[c].segments, cases[c].sort_s * 1e3,
               cases[c].sort_min_s * 1e3, o->pairs / cases[c].sort_s * 1e-6,
               cases[c].sort_s / copy_s, cases[c].segments_s * 1e3);
}

int main(int argc, char **argv)
{
    bench_options o;
    bench_defaults(&o);
    int rc = bench_parse(argc, argv, &o);
    if (rc >= 0) return rc;
    ts_error err = {0};
    radix_sorter *s = radix_sorter_create(o.threads, &err);
    size_t n = o.pairs;
    bench_buffers b = {
        .input = malloc(n * sizeof(ts_pair)),
        .pairs = malloc(n * sizeof(ts_pair)),
        .scratch = malloc(n * sizeof(ts_pair)),
        .segments = malloc((size_t)bench_key_ranges[BENCH_CASES - 1] * sizeof(ts_segment)),
        .copy_s = malloc((size_t)BENCH_CASES * (size_t)o.repeat * sizeof(double)),
    };
    bench_case cases[BENCH_CASES];
    if (s && (!b.input || !b.pairs || !b.scratch || !b.segments || !b.copy_s))
        ts_error_set(&err, TS_E_MEMORY, "bench_sort: cannot allocate %zu pairs", n);
    if (s && err.code == TS_OK) {
        memset(b.pairs, 0, n * sizeof(ts_pair)); /* fault the pages in before timing */
        memset(b.scratch, 0, n * sizeof(ts_pair));
        for (int c = 0; c < BENCH_CASES && err.code == TS_OK; c++)
            bench_run_case(s, &o, &b, bench_key_ranges[c], &cases[c], &err);
    }
    rc = err.code != TS_OK;
    if (rc) fprintf(stderr, "bench_sort: %s\n", err.msg);
    if (!rc) {
        int threads = radix_sorter_threads(s);
        double copy_s = bench_median(b.copy_s, b.copies);
        bench_print(&o, threads, copy_s, cases);
        if (o.json_path) rc = bench_write_json(o.json_path, &o, threads, copy_s, cases);
    }
    radix_sorter_destroy(s);
    free(b.input);
    free(b.pairs);
    free(b.scratch);
    free(b.segments);
    free(b.copy_s);
    ts_error_clear(&err);
    return rc;
}
