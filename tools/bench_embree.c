/* bench_embree.c — Tessera against Embree 3 on the same micro-polygons (issue 8 item 2,
 * DESIGN.md §6): rays/s and peak memory of the two-level tracer at a fixed m next to Embree
 * tracing every patch of the scene tessellated at that m (tests/support/embree_ref.h: the
 * same vertices, the same two triangles per micro-quad).
 *
 * Rays, identical for both tracers:
 *   eye     the camera's rays at W x H, 1 spp, through the pixel centres (what the camera
 *           kernel generates, computed on the host);
 *   bounce  one generation of diffuse rays: at every eye-ray hit, a cosine-distributed
 *           direction about the shading normal (facing the eye), origin offset by
 *           l / 2^m along it (l the longest side of the patch's box), random numbers
 *           rng_uniform(pixel, 0, 1, 5 | 6, seed): what the shade kernel does for a matte
 *           surface. The hits come from Embree (from Tessera's micro-triangles when Embree
 *           is not run), and both tracers trace the resulting rays.
 * Each tracer runs in a process of its own (this program started again with --child), so
 * its peak resident set (wait4's ru_maxrss) is its own; a third child that only loads the
 * scene and the rays gives the baseline both include.
 *   embree   embree_ref (robust, medium-quality BVH; Embree's build uses all cores through
 *            its own threads), traced with rtcIntersect1 one ray at a time, on 1 thread and
 *            on 2 pthreads (each tracing half the rays: both cores, like Tessera on PoCL).
 *            Times: tessellation, BVH build, trace; memory: Embree's own allocations
 *            (rtcSetDeviceMemoryMonitorFunction) and the process's peak.
 *   tessera  the wavefront two-level loop (pipeline_trace) with every patch at m, planned
 *            from --memory like `tessera render`; micro-triangles (--intersect triangles:
 *            the same geometry as Embree) and leaf boxes (the default). Time = the trace
 *            stages' seconds (top_level + sort + dice + build + bottom_level + resolve,
 *            profiling events) and the wall time of pipeline_trace. Tessera dices on every
 *            trace: there is no separate build.
 * Timings are medians of --runs repetitions inside each child. Hits are compared ray by
 * ray (Embree vs micro-triangles): hit/miss disagreements, and of the rays both hit, the
 * share at the same patch with |t - t_embree| <= 1e-4 t_embree (tests/test_embree.c).
 *
 * usage: bench_embree [--size tiny|small|full] [--scene PATH] [--lod M]... [--res WxH]
 *                     [--runs R] [--memory MB] [--seed S] [--only embree|tessera]
 *                     [--json PATH] [--keep DIR]
 * Sizes: tiny = teapot at m = 3, 64x36, 1 run (the smoke test, seconds); small =
 * teapot_displaced at m = 6, 7, 8, 640x360, 3 runs (a few minutes); full = teapot_displaced
 * at m = 6..10, 1280x720 (m = 10: 67 M triangles, ~7.5 GiB for Embree), then forest-100 at
 * m = 6 with Tessera alone (917 M triangles, ~100 GiB for Embree), 3 runs (an hour or more).
 * --scene/--lod/--res replace the size's cases by one scene at each --lod given; --only runs
 * one tracer (Tessera alone makes the bounce rays from its own micro-triangle hits). The
 * last line (and "largest_scene" in the JSON) extrapolates Embree's peak resident set,
 * linear in the triangles (the slope between the two largest cases), to 24 GiB and to
 * --memory. Exit 77 when there is no OpenCL device (the smoke test skips).
 */
#include "bench_util.h"
#include "device/device.h"
#include "embree_ref.h"
#include "ray_sets.h"
#include "pipeline/pipeline.h"
#include "app/render.h"
#include "scene/scene_load.h"
#include "base/stats.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <getopt.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define MAX_RUNS 51
#define MAX_CASES 8

typedef struct bench_case {
    const char *scene;
    uint32_t lod, width, height;
    int embree; /* 0: Tessera only (a scene Embree could not hold) */
} bench_case;

typedef struct config {
    const char *size;
    bench_case cases[MAX_CASES];
    int case_count;
    int runs, memory_mb;
    uint32_t seed;
    const char *json_path, *keep_dir, *only;
} config;

/* ---------------------------------------------------------------- small helpers */

/* A /proc/self/status field in bytes ("VmRSS: %llu kB"), 0 if unknown. */
static uint64_t proc_status(const char *format)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    unsigned long long kb = 0;
    while (f && fgets(line, sizeof line, f))
        if (sscanf(line, format, &kb) == 1) break;
    if (f) fclose(f);
    return (uint64_t)kb * 1024u;
}

/* Resident set now. */
static uint64_t rss_now(void)
{
    return proc_status("VmRSS: %llu kB");
}

/* Peak resident set of this process's address space (VmHWM). Not getrusage: ru_maxrss
 * survives execve and would include the parent's peak at the fork. */
static uint64_t rss_peak(void)
{
    return proc_status("VmHWM: %llu kB");
}

static const char *path_in(const char *dir, const char *name)
{
    static char buf[4][4096];
    static int next;
    char *p = buf[next++ % 4];
    snprintf(p, sizeof buf[0], "%s/%s", dir, name);
    return p;
}

/* ---------------------------------------------------------------- child: embree */

typedef struct trace_job {
    ts_embree_ref *ref;
    const ts_ray_set *r;
    ts_hit *hit;
    uint32_t first, count;
    int rc;
    ts_error err;
} trace_job;

static void *trace_thread(void *arg)
{
    trace_job *j = arg;
    j->rc = embree_ref_trace(j->ref, j->r->org + j->first, j->r->dir + j->first,
                             j->r->from + j->first, j->count, j->hit + j->first, &j->err);
    return NULL;
}

/* Traces r with `threads` pthreads, each a contiguous share; returns the wall seconds or
 * -1 on an error. */
static double embree_trace(ts_embree_ref *ref, const ts_ray_set *r, ts_hit *hit, int threads,
                           ts_error *err)
{
    trace_job jobs[2];
    pthread_t tid[2];
    double t0 = bench_now();
    for (int i = 0; i < threads; ++i) {
        uint32_t a = (uint32_t)((uint64_t)r->count * i / threads);
        uint32_t b = (uint32_t)((uint64_t)r->count * (i + 1) / threads);
        jobs[i] = (trace_job){ref, r, hit, a, b - a, 0, {0}};
        if (i > 0 && pthread_create(&tid[i], NULL, trace_thread, &jobs[i])) {
            ts_error_set(err, TS_E_INTERNAL, "pthread_create failed");
            return -1;
        }
    }
    trace_thread(&jobs[0]);
    for (int i = 1; i < threads; ++i)
        pthread_join(tid[i], NULL);
    double t = bench_now() - t0;
    for (int i = 0; i < threads; ++i)
        if (jobs[i].rc) {
            ts_error_set(err, jobs[i].rc, "%s", jobs[i].err.msg);
            return -1;
        }
    return t;
}

static void add_kind(cJSON *parent, const char *name, uint32_t rays_n, uint32_t hits,
                     const char *keys[], const double *values, int n)
{
    cJSON *o = cJSON_AddObjectToObject(parent, name);
    cJSON_AddNumberToObject(o, "rays", rays_n);
    cJSON_AddNumberToObject(o, "hits", hits);
    for (int i = 0; i < n; ++i)
        cJSON_AddNumberToObject(o, keys[i], values[i]);
}

static int write_json(const char *path, cJSON *root)
{
    char *text = cJSON_Print(root);
    int rc = text ? ray_set_write_file(path, text, strlen(text), "\n", 1) : -1;
    free(text);
    return rc;
}

static int child_embree(const ts_scene *s, uint32_t m, const char *dir, int runs, uint32_t seed,
                        ts_error *err)
{
    ts_ray_set eye = {0}, bounce = {0};
    if (ray_set_load(path_in(dir, "eye.rays"), &eye))
        return ts_error_set(err, TS_E_IO, "no eye rays");
    uint64_t rss_before = rss_now();
    ts_hit *eye_hit = malloc((eye.count ? eye.count : 1) * sizeof *eye_hit), *bounce_hit = NULL;
    double tess[MAX_RUNS], build[MAX_RUNS], te[2][MAX_RUNS], tb[2][MAX_RUNS];
    ts_embree_info info = {0};
    int rc = eye_hit ? TS_OK : ts_error_set(err, TS_E_MEMORY, "out of memory");
    for (int run = 0; run < runs && !rc; ++run) {
        ts_embree_ref *ref = NULL;
        if ((rc = embree_ref_create(&ref, s, m, NULL, err))) break;
        info = *embree_ref_info(ref);
        tess[run] = info.tessellate_seconds;
        build[run] = info.build_seconds;
        for (int th = 0; th < 2 && !rc; ++th)
            if ((te[th][run] = embree_trace(ref, &eye, eye_hit, th + 1, err)) < 0) rc = err->code;
        if (!rc && run == 0) {
            rc = ray_set_bounce(s, m, seed, &eye, eye_hit, &bounce, err);
            if (!rc) rc = ray_set_save(path_in(dir, "bounce.rays"), &bounce) ? TS_E_IO : TS_OK;
            if (!rc &&
                !(bounce_hit = malloc((bounce.count ? bounce.count : 1) * sizeof *bounce_hit)))
                rc = ts_error_set(err, TS_E_MEMORY, "out of memory");
        }
        for (int th = 0; th < 2 && !rc; ++th)
            if ((tb[th][run] = embree_trace(ref, &bounce, bounce_hit, th + 1, err)) < 0)
                rc = err->code;
        embree_ref_destroy(ref);
    }
    if (!rc && (ray_set_write_file(path_in(dir, "embree_eye.hits"), eye_hit,
                                   eye.count * sizeof(ts_hit), NULL, 0) ||
                ray_set_write_file(path_in(dir, "embree_bounce.hits"), bounce_hit,
                                   bounce.count * sizeof(ts_hit), NULL, 0)))
        rc = ts_error_set(err, TS_E_IO, "cannot write the hits");
    if (!rc) {
        cJSON *root = cJSON_CreateObject();
        cJSON_AddNumberToObject(root, "triangles", (double)info.triangles);
        cJSON_AddNumberToObject(root, "vertices", (double)info.vertices);
        cJSON_AddNumberToObject(root, "tessellate_seconds", bench_median(tess, runs));
        cJSON_AddNumberToObject(root, "build_seconds", bench_median(build, runs));
        cJSON_AddNumberToObject(root, "bytes_before_build", (double)info.bytes_before_build);
        cJSON_AddNumberToObject(root, "bytes_peak", (double)info.bytes_peak);
        cJSON_AddNumberToObject(root, "bytes_after_build", (double)info.bytes_after_build);
        cJSON_AddNumberToObject(root, "rss_before_bytes", (double)rss_before);
        cJSON_AddNumberToObject(root, "peak_rss_bytes", (double)rss_peak());
        const char *keys[2] = {"seconds_1thread", "seconds_2threads"};
        double e[2] = {bench_median(te[0], runs), bench_median(te[1], runs)};
        double b[2] = {bench_median(tb[0], runs), bench_median(tb[1], runs)};
        add_kind(root, "eye", eye.count, ray_set_count_hits(eye_hit, eye.count), keys, e, 2);
        add_kind(root, "bounce", bounce.count, ray_set_count_hits(bounce_hit, bounce.count), keys,
                 b, 2);
        if (write_json(path_in(dir, "embree.json"), root))
            rc = ts_error_set(err, TS_E_IO, "cannot write json");
        cJSON_Delete(root);
    }
    free(eye_hit), free(bounce_hit);
    ray_set_free(&eye), ray_set_free(&bounce);
    return rc;
}

/* ---------------------------------------------------------------- child: tessera */

/* Traces r through the pipeline in chunks of the plan's wave size; adds the trace stages'
 * seconds to *stage_s and pipeline_trace's wall time to *wall_s. */
static int tessera_trace(ts_pipeline *p, ts_stats *stats, const ts_ray_set *r, ts_hit *hit,
                         double *stage_s, double *wall_s, uint64_t *iterations,
                         double per_stage[TS_STAGE_COUNT], ts_error *err)
{
    static const ts_stage traced[] = {TS_STAGE_top_level, TS_STAGE_sort,         TS_STAGE_dice,
                                      TS_STAGE_build,     TS_STAGE_bottom_level, TS_STAGE_resolve};
    uint32_t cap = p->plan.ray_capacity;
    stats_free(stats);
    memset(stats, 0, sizeof *stats);
    *wall_s = 0;
    int rc = TS_OK;
    for (uint32_t first = 0; first < r->count && !rc; first += cap) {
        uint32_t n = r->count - first < cap ? r->count - first : cap;
        if ((rc = ray_set_upload(p, r, first, n, err))) break;
        double t0 = bench_now();
        rc = pipeline_trace(p, n, err);
        if (!rc) rc = dev_finish(p->cl, stats, err);
        *wall_s += bench_now() - t0;
        if (!rc)
            rc = dev_read(p->cl, p->ray_hit, 0, n * sizeof(ts_hit), hit + first, "the hits", err);
    }
    *stage_s = 0;
    for (size_t i = 0; i < sizeof traced / sizeof *traced; ++i)
        *stage_s += stats->stage_seconds[traced[i]];
    *iterations = stats->counters[TS_COUNTER_iterations];
    for (int i = 0; i < TS_STAGE_COUNT; ++i)
        per_stage[i] = stats->stage_seconds[i];
    return rc;
}

/* Device bytes of the plan: arenas, rays and pairs, and the scene's patch data. */
static double plan_bytes(const ts_pipeline_plan *plan, const ts_scene *s)
{
    double arenas = (double)plan->vert_capacity * sizeof(ts_vec4) +
                    (double)plan->group_capacity * sizeof(ts_box4);
    double ray_bytes = (double)plan->ray_capacity * TS_BYTES_PER_RAY;
    double patch = (double)s->patch_count * (2 * 16 * sizeof(ts_vec4) + 4 * sizeof(ts_vec4) +
                                             sizeof(ts_patch_attr) + sizeof(ts_vec4));
    return arenas + ray_bytes + patch;
}

static int child_tessera(const ts_scene *s, uint32_t m, const char *dir, int runs, int memory_mb,
                         uint32_t seed, ts_error *err)
{
    ts_ray_set r[2] = {{0}, {0}};
    if (ray_set_load(path_in(dir, "eye.rays"), &r[0]))
        return ts_error_set(err, TS_E_IO, "no eye rays");
    int have_bounce = access(path_in(dir, "bounce.rays"), R_OK) == 0;
    if (have_bounce && ray_set_load(path_in(dir, "bounce.rays"), &r[1]))
        return ts_error_set(err, TS_E_IO, "bad bounce rays");
    ts_device cl;
    ts_device_options opt = {.device_index = -1};
    if (dev_open(&cl, &opt, err)) return err->code;
    uint64_t rss_before = rss_now();
    uint32_t most = r[0].count > 1 ? r[0].count : 1;
    ts_pipeline_plan plan;
    ts_stats stats;
    memset(&stats, 0, sizeof stats);
    ts_pipeline p;
    int rc = pipeline_plan((uint64_t)memory_mb << 20, most, m, cl.info.max_alloc, &plan, err);
    if (!rc && plan.max_lod < m)
        rc = ts_error_set(err, TS_E_USAGE, "--memory %d MB holds patches up to m = %u only",
                          memory_mb, plan.max_lod);
    if (!rc) rc = pipeline_create(&p, &cl, s, &plan, most, &stats, err);
    if (rc) {
        dev_close(&cl);
        return rc;
    }
    p.mode.fixed_lod = (int)m;
    ts_hit *hit[2][2] = {{NULL, NULL}, {NULL, NULL}}; /* [mode][kind] */
    double stage[2][2][MAX_RUNS], wall[2][2][MAX_RUNS], each[TS_STAGE_COUNT] = {0};
    static double per_stage[2][2][TS_STAGE_COUNT][MAX_RUNS];
    uint64_t iters[2][2] = {{0}};
    for (int mode = 0; mode < 2 && !rc; ++mode) /* 0 triangles, 1 boxes */
        for (int kind = 0; kind < 2 && !rc; ++kind) {
            if (kind == 1 && !have_bounce) { /* no Embree: bounce from the micro-triangles */
                rc = ray_set_bounce(s, m, seed, &r[0], hit[0][0], &r[1], err);
                if (!rc) rc = ray_set_save(path_in(dir, "bounce.rays"), &r[1]) ? TS_E_IO : TS_OK;
                have_bounce = 1;
                if (rc) break;
            }
            p.mode.exact = mode == 0;
            p.mode.tight = p.mode.exact; /* as tessera render --intersect triangles */
            hit[mode][kind] = malloc((r[kind].count ? r[kind].count : 1) * sizeof(ts_hit));
            if (!hit[mode][kind]) rc = ts_error_set(err, TS_E_MEMORY, "out of memory");
            for (int run = 0; run < runs && !rc; ++run) {
                /* Every eye run is a new frame: its patches are diced and built again (the
                 * patch cache keeps them for the frame's bounce rays, as in tessera render,
                 * not across frames), as Embree tessellates and builds in every run. */
                if (kind == 0) patch_cache_clear(&p.cache);
                rc = tessera_trace(&p, &stats, &r[kind], hit[mode][kind], &stage[mode][kind][run],
                                   &wall[mode][kind][run], &iters[mode][kind], each, err);
                for (int i = 0; i < TS_STAGE_COUNT; ++i)
                    per_stage[mode][kind][i][run] = each[i];
            }
        }
    if (!rc && (ray_set_write_file(path_in(dir, "tessera_eye.hits"), hit[0][0],
                                   r[0].count * sizeof(ts_hit), NULL, 0) ||
                ray_set_write_file(path_in(dir, "tessera_bounce.hits"), hit[0][1],
                                   r[1].count * sizeof(ts_hit), NULL, 0)))
        rc = ts_error_set(err, TS_E_IO, "cannot write the hits");
    if (!rc) {
        cJSON *root = cJSON_CreateObject();
        cJSON_AddStringToObject(root, "device", cl.info.name);
        cJSON_AddNumberToObject(root, "memory_mb", memory_mb);
        cJSON_AddNumberToObject(root, "device_buffer_bytes", plan_bytes(&plan, s));
        cJSON_AddNumberToObject(root, "wave_rays", plan.ray_capacity);
        cJSON_AddNumberToObject(root, "rss_before_bytes", (double)rss_before);
        cJSON_AddNumberToObject(root, "peak_rss_bytes", (double)rss_peak());
        static const char *const modes[2] = {"triangles", "boxes"}, *const kinds[2] = {"eye",
                                                                                       "bounce"};
        const char *keys[3] = {"trace_seconds", "wall_seconds", "iterations"};
        for (int mode = 0; mode < 2; ++mode) {
            cJSON *o = cJSON_AddObjectToObject(root, modes[mode]);
            for (int kind = 0; kind < 2; ++kind) {
                double v[3] = {bench_median(stage[mode][kind], runs),
                               bench_median(wall[mode][kind], runs), (double)iters[mode][kind]};
                add_kind(o, kinds[kind], r[kind].count,
                         ray_set_count_hits(hit[mode][kind], r[kind].count), keys, v, 3);
                cJSON *st = cJSON_AddObjectToObject(
                    cJSON_GetObjectItemCaseSensitive(o, kinds[kind]), "stage_seconds");
                for (int i = TS_STAGE_top_level; i <= TS_STAGE_resolve; ++i)
                    cJSON_AddNumberToObject(st, ts_stage_names[i],
                                            bench_median(per_stage[mode][kind][i], runs));
            }
        }
        if (write_json(path_in(dir, "tessera.json"), root))
            rc = ts_error_set(err, TS_E_IO, "cannot write json");
        cJSON_Delete(root);
    }
    for (int i = 0; i < 4; ++i)
        free(hit[i / 2][i % 2]);
    pipeline_destroy(&p);
    stats_free(&stats);
    dev_close(&cl);
    ray_set_free(&r[0]), ray_set_free(&r[1]);
    return rc;
}

/* ---------------------------------------------------------------- the parent */

/* Runs this program as `--child WHAT` on the case (it writes DIR/WHAT.json, with its peak
 * resident set). 0 on success. */
static int run_child(const char *what, const bench_case *c, const config *cfg, const char *dir)
{
    char lod[16], runs[16], mem[16], seed[16];
    snprintf(lod, sizeof lod, "%u", c->lod);
    snprintf(runs, sizeof runs, "%d", cfg->runs);
    snprintf(mem, sizeof mem, "%d", cfg->memory_mb);
    snprintf(seed, sizeof seed, "%u", cfg->seed);
    char *argv[] = {
        "bench_embree", "--child", (char *)what, "--scene", (char *)c->scene, "--lod", lod,
        "--runs",       runs,      "--memory",   mem,       "--seed",         seed,    "--keep",
        (char *)dir,    NULL};
    fflush(NULL);
    pid_t pid = fork();
    if (pid < 0) return -1;
    if (pid == 0) {
        execv("/proc/self/exe", argv);
        _exit(127);
    }
    int status = 0;
    if (waitpid(pid, &status, 0) != pid) return -1;
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        fprintf(stderr, "bench_embree: the %s child failed (%s %d)\n", what,
                WIFEXITED(status) ? "exit" : "signal",
                WIFEXITED(status) ? WEXITSTATUS(status) : WTERMSIG(status));
        return -1;
    }
    return 0;
}

static cJSON *load_json(const char *path)
{
    size_t n = 0;
    char *text = ray_set_read_file(path, &n);
    cJSON *j = text ? cJSON_Parse(text) : NULL;
    free(text);
    if (!j) fprintf(stderr, "bench_embree: %s: not JSON\n", path);
    return j;
}

static double num(const cJSON *o, const char *a, const char *b, const char *c)
{
    const cJSON *x = cJSON_GetObjectItemCaseSensitive(o, a);
    if (b) x = cJSON_GetObjectItemCaseSensitive(x, b);
    if (c) x = cJSON_GetObjectItemCaseSensitive(x, c);
    return cJSON_IsNumber(x) ? x->valuedouble : 0.0;
}

/* Ray-by-ray agreement of Embree's hits and Tessera's micro-triangle hits. */
static cJSON *agreement(const ts_hit *a, const ts_hit *b, uint32_t n)
{
    uint32_t mismatch = 0, both = 0, agree = 0;
    for (uint32_t k = 0; k < n; ++k) {
        int ha = a[k].patch != TS_INVALID, hb = b[k].patch != TS_INVALID;
        if (ha != hb) {
            ++mismatch;
            continue;
        }
        if (!ha) continue;
        ++both;
        agree += a[k].patch == b[k].patch && fabsf(a[k].t - b[k].t) <= 1e-4f * b[k].t;
    }
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "rays", n);
    cJSON_AddNumberToObject(o, "hit_miss_mismatches", mismatch);
    cJSON_AddNumberToObject(o, "both_hit", both);
    cJSON_AddNumberToObject(o, "same_patch_and_t", agree);
    return o;
}

static const char *mib(double bytes, char *buf)
{
    snprintf(buf, 32, "%.1f", bytes / 1048576.0);
    return buf;
}

/* The table of rays/s: each kind of ray, each tracer. */
static void print_rates(const cJSON *e, const cJSON *t, const uint32_t counts[2])
{
    static const char *const kinds[2] = {"eye", "bounce"};
    printf("%-7s %-26s %10s %9s %10s %12s\n", "rays", "tracer", "count", "hits", "seconds",
           "M rays/s");
    for (int k = 0; k < 2; ++k) {
        if (e) {
            const cJSON *x = cJSON_GetObjectItemCaseSensitive(e, kinds[k]);
            printf("%-7s %-26s %10u %9.0f %10.4f %12.4g\n", kinds[k], "embree 1 thread", counts[k],
                   num(x, "hits", NULL, NULL), num(x, "seconds_1thread", NULL, NULL),
                   1e-6 * num(x, "rays_per_second_1thread", NULL, NULL));
            printf("%-7s %-26s %10u %9.0f %10.4f %12.4g\n", kinds[k], "embree 2 threads", counts[k],
                   num(x, "hits", NULL, NULL), num(x, "seconds_2threads", NULL, NULL),
                   1e-6 * num(x, "rays_per_second_2threads", NULL, NULL));
        }
        for (int md = 0; t && md < 2; ++md) {
            const cJSON *x = cJSON_GetObjectItemCaseSensitive(
                cJSON_GetObjectItemCaseSensitive(t, md ? "boxes" : "triangles"), kinds[k]);
            printf("%-7s %-26s %10u %9.0f %10.4f %12.4g\n", kinds[k],
                   md ? "tessera boxes (stages)" : "tessera triangles (stages)", counts[k],
                   num(x, "hits", NULL, NULL), num(x, "trace_seconds", NULL, NULL),
                   1e-6 * num(x, "rays_per_second", NULL, NULL));
            printf("%-7s %-26s %10u %9.0f %10.4f %12.4g\n", kinds[k],
                   md ? "tessera boxes (wall)" : "tessera triangles (wall)", counts[k],
                   num(x, "hits", NULL, NULL), num(x, "wall_seconds", NULL, NULL),
                   1e-6 * num(x, "rays_per_second_wall", NULL, NULL));
        }
    }
}

/* Ray-by-ray agreement (o.agreement) and the ratios of rates, frame times and memory
 * (o.ratios) of the Embree and Tessera results e and t; prints them. 0, or -1 when the hit
 * files cannot be read. */
static int compare(cJSON *o, const cJSON *e, const cJSON *t, const uint32_t counts[2],
                   double peak_base, const char *dir)
{
    static const char *const kinds[2] = {"eye", "bounce"};
    double peak_e = num(e, "peak_rss_bytes", NULL, NULL),
           peak_t = num(t, "peak_rss_bytes", NULL, NULL);
    int rc = 0;
    cJSON *ag = cJSON_AddObjectToObject(o, "agreement"),
          *ratios = cJSON_AddObjectToObject(o, "ratios");
    for (int k = 0; k < 2; ++k) {
        ts_hit *ha = ray_set_load_hits(path_in(dir, k ? "embree_bounce.hits" : "embree_eye.hits"),
                                       counts[k]);
        ts_hit *hb = ray_set_load_hits(path_in(dir, k ? "tessera_bounce.hits" : "tessera_eye.hits"),
                                       counts[k]);
        if (!ha || !hb)
            rc = -1;
        else
            cJSON_AddItemToObject(ag, kinds[k], agreement(ha, hb, counts[k]));
        free(ha), free(hb);
        if (rc) break;
        const cJSON *ex = cJSON_GetObjectItemCaseSensitive(e, kinds[k]);
        const cJSON *tx = cJSON_GetObjectItemCaseSensitive(
            cJSON_GetObjectItemCaseSensitive(t, "triangles"), kinds[k]);
        const cJSON *bx = cJSON_GetObjectItemCaseSensitive(
            cJSON_GetObjectItemCaseSensitive(t, "boxes"), kinds[k]);
        double t_tri = num(tx, "rays_per_second", NULL, NULL),
               t_box = num(bx, "rays_per_second", NULL, NULL);
        cJSON *r = cJSON_AddObjectToObject(ratios, kinds[k]);
        /* How many times Embree's rays/s is Tessera's. */
        cJSON_AddNumberToObject(r, "embree_1thread_over_tessera_triangles",
                                t_tri > 0 ? num(ex, "rays_per_second_1thread", NULL, NULL) / t_tri
                                          : 0);
        cJSON_AddNumberToObject(r, "embree_2threads_over_tessera_triangles",
                                t_tri > 0 ? num(ex, "rays_per_second_2threads", NULL, NULL) / t_tri
                                          : 0);
        cJSON_AddNumberToObject(r, "embree_2threads_over_tessera_boxes",
                                t_box > 0 ? num(ex, "rays_per_second_2threads", NULL, NULL) / t_box
                                          : 0);
    }
    /* A frame: Embree's tessellation + build + both traces (2 threads) against Tessera's
     * trace stages for both (it dices as it goes). */
    double ef = num(e, "tessellate_seconds", NULL, NULL) + num(e, "build_seconds", NULL, NULL) +
                num(e, "eye", "seconds_2threads", NULL) +
                num(e, "bounce", "seconds_2threads", NULL);
    double tf = num(t, "triangles", "eye", "trace_seconds") +
                num(t, "triangles", "bounce", "trace_seconds");
    double bf =
        num(t, "boxes", "eye", "trace_seconds") + num(t, "boxes", "bounce", "trace_seconds");
    cJSON_AddNumberToObject(ratios, "frame_embree_seconds", ef);
    cJSON_AddNumberToObject(ratios, "frame_tessera_triangles_seconds", tf);
    cJSON_AddNumberToObject(ratios, "frame_tessera_boxes_seconds", bf);
    cJSON_AddNumberToObject(ratios, "frame_tessera_triangles_over_embree", ef > 0 ? tf / ef : 0);
    cJSON_AddNumberToObject(ratios, "peak_rss_embree_over_tessera",
                            peak_t > 0 ? peak_e / peak_t : 0);
    double pe = peak_e - peak_base, pt = peak_t - peak_base;
    cJSON_AddNumberToObject(ratios, "peak_rss_above_baseline_embree_over_tessera",
                            pt > 0 ? pe / pt : 0);
    for (int k = 0; k < 2 && !rc; ++k) {
        const cJSON *x = cJSON_GetObjectItemCaseSensitive(ag, kinds[k]);
        printf("agreement %-6s: %u rays, hit/miss mismatches %.0f, both hit %.0f, same patch and t "
               "%.0f\n",
               kinds[k], counts[k], num(x, "hit_miss_mismatches", NULL, NULL),
               num(x, "both_hit", NULL, NULL), num(x, "same_patch_and_t", NULL, NULL));
    }
    printf("ratios: Embree 2 threads / Tessera triangles rays/s: eye %.2f, bounce %.2f; "
           "frame (Embree incl. build) Tessera/Embree time %.2f; peak RSS Embree/Tessera %.2f\n",
           num(ratios, "eye", "embree_2threads_over_tessera_triangles", NULL),
           num(ratios, "bounce", "embree_2threads_over_tessera_triangles", NULL),
           num(ratios, "frame_tessera_triangles_over_embree", NULL, NULL),
           num(ratios, "peak_rss_embree_over_tessera", NULL, NULL));

    return rc;
}

/* One case: rays, children, comparison. Adds the case's object to `cases`. */
static int run_case(const bench_case *c, const config *cfg, const char *dir, cJSON *cases)
{
    ts_scene s;
    ts_error err = {0};
    memset(&s, 0, sizeof s);
    if (scene_load(c->scene, &s, 1, &err)) {
        fprintf(stderr, "bench_embree: %s\n", err.msg);
        return -1;
    }
    ts_ray_set eye = {0};
    if (ray_set_eye(&s, c->width, c->height, cfg->seed, &eye, &err) ||
        ray_set_save(path_in(dir, "eye.rays"), &eye)) {
        fprintf(stderr, "bench_embree: %s\n", err.msg);
        scene_free(&s);
        return -1;
    }
    remove(path_in(dir, "bounce.rays"));
    uint32_t patches = s.patch_count;
    scene_free(&s);
    int do_embree = c->embree && (!cfg->only || !strcmp(cfg->only, "embree"));
    int do_tessera = !cfg->only || !strcmp(cfg->only, "tessera");
    double peak_base = 0, peak_e = 0, peak_t = 0;
    printf("\n== %s at m = %u, %ux%u: %u patches, %.4g micro-triangles ==\n", c->scene, c->lod,
           c->width, c->height, patches, 2.0 * patches * (double)(1u << (2 * c->lod)));
    if (run_child("baseline", c, cfg, dir) || (do_embree && run_child("embree", c, cfg, dir)) ||
        (do_tessera && run_child("tessera", c, cfg, dir))) {
        ray_set_free(&eye);
        return -1;
    }
    cJSON *base = load_json(path_in(dir, "baseline.json"));
    cJSON *e = do_embree ? load_json(path_in(dir, "embree.json")) : NULL;
    cJSON *t = do_tessera ? load_json(path_in(dir, "tessera.json")) : NULL;
    if (!base || (do_embree && !e) || (do_tessera && !t)) {
        cJSON_Delete(base), cJSON_Delete(e), cJSON_Delete(t);
        ray_set_free(&eye);
        return -1;
    }
    peak_base = num(base, "peak_rss_bytes", NULL, NULL);
    cJSON_Delete(base);
    if (e) peak_e = num(e, "peak_rss_bytes", NULL, NULL);
    if (t) peak_t = num(t, "peak_rss_bytes", NULL, NULL);
    ts_ray_set bounce = {0};
    if (ray_set_load(path_in(dir, "bounce.rays"), &bounce)) {
        ray_set_free(&eye);
        return -1;
    }
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "scene", c->scene);
    cJSON_AddNumberToObject(o, "lod", c->lod);
    cJSON_AddNumberToObject(o, "width", c->width);
    cJSON_AddNumberToObject(o, "height", c->height);
    cJSON_AddNumberToObject(o, "patches", patches);
    cJSON_AddNumberToObject(o, "micro_triangles", 2.0 * patches * (double)(1u << (2 * c->lod)));
    cJSON *nr = cJSON_AddObjectToObject(o, "rays");
    cJSON_AddNumberToObject(nr, "eye", eye.count);
    cJSON_AddNumberToObject(nr, "bounce", bounce.count);
    cJSON_AddStringToObject(o, "bounce_hits_from", do_embree ? "embree" : "tessera_triangles");
    cJSON_AddNumberToObject(o, "baseline_peak_rss_bytes", peak_base);
    static const char *const kinds[2] = {"eye", "bounce"};
    uint32_t counts[2] = {eye.count, bounce.count};
    char b1[32], b2[32], b3[32];
    if (e) {
        double tri = num(e, "triangles", NULL, NULL);
        cJSON_AddNumberToObject(e, "bytes_per_triangle",
                                tri > 0 ? num(e, "bytes_after_build", NULL, NULL) / tri : 0);
        cJSON_AddNumberToObject(e, "peak_rss_bytes_per_triangle",
                                tri > 0 ? (peak_e - peak_base) / tri : 0);
        for (int k = 0; k < 2; ++k) {
            cJSON *x = cJSON_GetObjectItemCaseSensitive(e, kinds[k]);
            double s1 = num(x, "seconds_1thread", NULL, NULL),
                   s2 = num(x, "seconds_2threads", NULL, NULL);
            cJSON_AddNumberToObject(x, "rays_per_second_1thread", s1 > 0 ? counts[k] / s1 : 0);
            cJSON_AddNumberToObject(x, "rays_per_second_2threads", s2 > 0 ? counts[k] / s2 : 0);
        }
        cJSON_AddItemToObject(o, "embree", e);
        printf("embree: %.4g triangles; tessellate %.3f s, BVH build %.3f s (Embree threads); "
               "Embree bytes %s MiB after build (peak %s MiB), %.1f B/triangle; peak RSS %s MiB\n",
               tri, num(e, "tessellate_seconds", NULL, NULL), num(e, "build_seconds", NULL, NULL),
               mib(num(e, "bytes_after_build", NULL, NULL), b1),
               mib(num(e, "bytes_peak", NULL, NULL), b2), num(e, "bytes_per_triangle", NULL, NULL),
               mib(peak_e, b3));
    }
    if (t) {
        static const char *const modes[2] = {"triangles", "boxes"};
        for (int md = 0; md < 2; ++md)
            for (int k = 0; k < 2; ++k) {
                cJSON *x = cJSON_GetObjectItemCaseSensitive(
                    cJSON_GetObjectItemCaseSensitive(t, modes[md]), kinds[k]);
                double st = num(x, "trace_seconds", NULL, NULL),
                       w = num(x, "wall_seconds", NULL, NULL);
                cJSON_AddNumberToObject(x, "rays_per_second", st > 0 ? counts[k] / st : 0);
                cJSON_AddNumberToObject(x, "rays_per_second_wall", w > 0 ? counts[k] / w : 0);
            }
        cJSON_AddItemToObject(o, "tessera", t);
        printf(
            "tessera: --memory %d MB, device buffers %s MiB (plan), wave %g rays; peak RSS %s MiB "
            "(baseline without a tracer %s MiB)\n",
            cfg->memory_mb, mib(num(t, "device_buffer_bytes", NULL, NULL), b1),
            num(t, "wave_rays", NULL, NULL), mib(peak_t, b2), mib(peak_base, b3));
    }
    print_rates(e, t, counts);
    int rc = e && t ? compare(o, e, t, counts, peak_base, dir) : 0;
    ray_set_free(&eye), ray_set_free(&bounce);
    cJSON_AddItemToArray(cases, o);
    return rc;
}

/* Largest scene within 24 GiB and within --memory: Embree's bytes per triangle from the
 * two cases with the most triangles (the slope of peak RSS, so fixed costs drop out), and
 * Tessera's peaks. */
static void scaling(cJSON *root, const config *cfg)
{
    const cJSON *cases = cJSON_GetObjectItemCaseSensitive(root, "cases"), *c;
    double tri[2] = {0, 0}, peak[2] = {0, 0}, base = 0, monitor = 0, tess_peak = 0;
    cJSON_ArrayForEach(c, cases)
    {
        const cJSON *e = cJSON_GetObjectItemCaseSensitive(c, "embree");
        double tp = num(c, "tessera", "peak_rss_bytes", NULL);
        if (tp > tess_peak) tess_peak = tp;
        if (!e) continue;
        double n = num(e, "triangles", NULL, NULL), p = num(e, "peak_rss_bytes", NULL, NULL);
        if (n > tri[1]) {
            tri[0] = tri[1], peak[0] = peak[1];
            tri[1] = n, peak[1] = p, base = num(c, "baseline_peak_rss_bytes", NULL, NULL);
            monitor = num(e, "bytes_peak", NULL, NULL) / n;
        } else if (n > tri[0]) {
            tri[0] = n, peak[0] = p;
        }
    }
    if (!(tri[1] > 0)) return;
    cJSON *s = cJSON_AddObjectToObject(root, "largest_scene");
    /* With one case: the growth over the baseline process (scene and rays loaded). */
    double slope = tri[0] > 0 && tri[1] > tri[0] ? (peak[1] - peak[0]) / (tri[1] - tri[0])
                                                 : (peak[1] - base) / tri[1];
    double fixed = peak[1] - slope * tri[1];
    double gib24 = 24.0 * 1073741824.0, budget = (double)cfg->memory_mb * 1048576.0;
    double fit24 = slope > 0 ? (gib24 - fixed) / slope : 0,
           fit_budget = slope > 0 ? (budget - fixed) / slope : 0;
    cJSON_AddNumberToObject(s, "embree_peak_rss_bytes_per_triangle", slope);
    cJSON_AddNumberToObject(s, "embree_fixed_bytes", fixed);
    cJSON_AddNumberToObject(s, "embree_monitor_peak_bytes_per_triangle", monitor);
    cJSON_AddNumberToObject(s, "embree_max_triangles_24GiB", fit24);
    cJSON_AddNumberToObject(s, "embree_max_triangles_budget", fit_budget > 0 ? fit_budget : 0);
    cJSON_AddNumberToObject(s, "budget_bytes", budget);
    cJSON_AddNumberToObject(s, "tessera_max_peak_rss_bytes", tess_peak);
    printf(
        "\nlargest scene: Embree peak RSS grows %.1f B per triangle (Embree's own peak %.1f B), "
        "fixed "
        "%.0f MiB: 24 GiB holds %.3g triangles (%.3g micro-quads), --memory %d MB %.3g; Tessera's "
        "peak RSS stayed <= %.0f MiB at every m above\n",
        slope, monitor, fixed / 1048576.0, fit24, fit24 / 2, cfg->memory_mb,
        fit_budget > 0 ? fit_budget : 0, tess_peak / 1048576.0);
}

static void usage(void)
{
    fprintf(stderr,
            "usage: bench_embree [--size tiny|small|full] [--scene PATH] [--lod M]... [--res WxH]\n"
            "                    [--runs R] [--memory MB] [--seed S] [--only embree|tessera]\n"
            "                    [--json PATH] [--keep DIR]\n");
}

static int set_size(config *c, const char *size)
{
    c->size = size;
    if (!strcmp(size, "tiny")) {
        c->cases[0] = (bench_case){"scene/teapot.rib", 3, 64, 36, 1};
        c->case_count = 1;
        c->runs = 1;
    } else if (!strcmp(size, "small")) {
        for (uint32_t m = 6; m <= 8; ++m)
            c->cases[m - 6] = (bench_case){"scene/teapot_displaced.rib", m, 640, 360, 1};
        c->case_count = 3;
        c->runs = 3;
    } else if (!strcmp(size, "full")) {
        /* m = 10: 67 M triangles, ~7.5 GiB for Embree; forest-100 at m = 6 would be 917 M
         * triangles, ~100 GiB for Embree: Tessera alone (~15 minutes). */
        for (uint32_t m = 6; m <= 10; ++m)
            c->cases[m - 6] = (bench_case){"scene/teapot_displaced.rib", m, 1280, 720, 1};
        c->cases[5] = (bench_case){"scene/forest-100.rib", 6, 320, 128, 0};
        c->case_count = 6;
        c->runs = 3;
    } else {
        return -1;
    }
    return 0;
}

int main(int argc, char **argv)
{
    config cfg = {.memory_mb = 1024, .seed = 0};
    set_size(&cfg, "tiny");
    const char *child = NULL, *scene = NULL, *size = "tiny";
    uint32_t lods[MAX_CASES], lod_count = 0, w = 0, h = 0;
    int runs = 0, c;
    enum {
        O_SIZE = 256,
        O_SCENE,
        O_LOD,
        O_RES,
        O_RUNS,
        O_MEM,
        O_SEED,
        O_ONLY,
        O_JSON,
        O_KEEP,
        O_CHILD
    };
    static const struct option opts[] = {
        {"size", required_argument, 0, O_SIZE},   {"scene", required_argument, 0, O_SCENE},
        {"lod", required_argument, 0, O_LOD},     {"res", required_argument, 0, O_RES},
        {"runs", required_argument, 0, O_RUNS},   {"memory", required_argument, 0, O_MEM},
        {"seed", required_argument, 0, O_SEED},   {"only", required_argument, 0, O_ONLY},
        {"json", required_argument, 0, O_JSON},   {"keep", required_argument, 0, O_KEEP},
        {"child", required_argument, 0, O_CHILD}, {0, 0, 0, 0}};
    while ((c = getopt_long(argc, argv, "", opts, NULL)) != -1) {
        char *end = NULL;
        long v = 0;
        switch (c) {
        case O_SIZE:
            size = optarg;
            break;
        case O_SCENE:
            scene = optarg;
            break;
        case O_LOD:
            v = strtol(optarg, &end, 10);
            if (*end || v < 0 || v > TS_LOD_LIMIT || lod_count == MAX_CASES) {
                fprintf(stderr, "bench_embree: --lod %s: 0..%d, at most %d\n", optarg, TS_LOD_LIMIT,
                        MAX_CASES);
                return 1;
            }
            lods[lod_count++] = (uint32_t)v;
            break;
        case O_RES:
            if (sscanf(optarg, "%ux%u", &w, &h) != 2 || w < 1 || h < 1 || w > 8192 || h > 8192) {
                fprintf(stderr, "bench_embree: --res %s: WxH\n", optarg);
                return 1;
            }
            break;
        case O_RUNS:
            runs = atoi(optarg);
            if (runs < 1 || runs > MAX_RUNS) {
                fprintf(stderr, "bench_embree: --runs 1..%d\n", MAX_RUNS);
                return 1;
            }
            break;
        case O_MEM:
            cfg.memory_mb = atoi(optarg);
            if (cfg.memory_mb < 16) {
                fprintf(stderr, "bench_embree: --memory MB >= 16\n");
                return 1;
            }
            break;
        case O_SEED:
            cfg.seed = (uint32_t)strtoul(optarg, NULL, 10);
            break;
        case O_ONLY:
            cfg.only = optarg;
            break;
        case O_JSON:
            cfg.json_path = optarg;
            break;
        case O_KEEP:
            cfg.keep_dir = optarg;
            break;
        case O_CHILD:
            child = optarg;
            break;
        default:
            usage();
            return 1;
        }
    }
    if (optind != argc || set_size(&cfg, size) ||
        (cfg.only && strcmp(cfg.only, "embree") && strcmp(cfg.only, "tessera"))) {
        usage();
        return 1;
    }
    if (runs) cfg.runs = runs;
    if (child) { /* one tracer on one case, in this process */
        if (!scene || lod_count != 1 || !cfg.keep_dir) {
            fprintf(stderr, "bench_embree: --child needs --scene, one --lod and --keep\n");
            return 1;
        }
        ts_scene s;
        ts_error err = {0};
        memset(&s, 0, sizeof s);
        int rc = scene_load(scene, &s, 1, &err);
        if (!rc && !strcmp(child, "embree"))
            rc = child_embree(&s, lods[0], cfg.keep_dir, cfg.runs, cfg.seed, &err);
        else if (!rc && !strcmp(child, "tessera"))
            rc = child_tessera(&s, lods[0], cfg.keep_dir, cfg.runs, cfg.memory_mb, cfg.seed, &err);
        else if (!rc && !strcmp(child, "baseline")) {
            ts_ray_set r = {0};
            rc = ray_set_load(path_in(cfg.keep_dir, "eye.rays"), &r) ? TS_E_IO : TS_OK;
            ray_set_free(&r);
            cJSON *root = cJSON_CreateObject();
            cJSON_AddNumberToObject(root, "peak_rss_bytes", (double)rss_peak());
            if (!rc && write_json(path_in(cfg.keep_dir, "baseline.json"), root))
                rc = ts_error_set(&err, TS_E_IO, "cannot write json");
            cJSON_Delete(root);
        } else if (!rc)
            rc = ts_error_set(&err, TS_E_USAGE, "--child %s: embree, tessera or baseline", child);
        scene_free(&s);
        if (rc) fprintf(stderr, "bench_embree (%s): %s\n", child, err.msg);
        return rc ? 1 : 0;
    }
    if (scene || lod_count || w) {
        if (!scene || !lod_count) {
            fprintf(stderr, "bench_embree: --scene needs at least one --lod\n");
            return 1;
        }
        for (uint32_t i = 0; i < lod_count; ++i)
            cfg.cases[i] = (bench_case){scene, lods[i], w ? w : 640, h ? h : 360, 1};
        cfg.case_count = (int)lod_count;
        cfg.size = "custom";
    }
    ts_device_info *list = NULL;
    ts_error err = {0};
    int n = dev_list(&list, &err);
    free(list);
    if (n <= 0 && (!cfg.only || strcmp(cfg.only, "embree"))) {
        fprintf(stderr, "bench_embree: no OpenCL device%s%s: skipping\n", n < 0 ? ": " : "",
                n < 0 ? err.msg : "");
        return 77;
    }
    char tmp[] = "/tmp/bench_embree.XXXXXX";
    const char *dir = cfg.keep_dir;
    if (!dir && !(dir = mkdtemp(tmp))) {
        fprintf(stderr, "bench_embree: mkdtemp: %s\n", strerror(errno));
        return 1;
    }
    if (cfg.keep_dir) mkdir(dir, 0777);
    printf("bench_embree: size %s, %d run(s) per measurement (medians), --memory %d MB, seed %u\n",
           cfg.size, cfg.runs, cfg.memory_mb, cfg.seed);
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "benchmark", "embree");
    cJSON_AddStringToObject(root, "size", cfg.size);
    cJSON_AddNumberToObject(root, "runs", cfg.runs);
    cJSON_AddNumberToObject(root, "memory_mb", cfg.memory_mb);
    cJSON_AddNumberToObject(root, "seed", cfg.seed);
    cJSON_AddStringToObject(root, "embree_trace",
                            "rtcIntersect1 per ray; 1 thread and 2 pthreads (half the rays each)");
    cJSON *cases = cJSON_AddArrayToObject(root, "cases");
    int rc = 0;
    for (int i = 0; i < cfg.case_count && !rc; ++i)
        rc = run_case(&cfg.cases[i], &cfg, dir, cases);
    if (!rc) scaling(root, &cfg);
    if (!rc && cfg.json_path && write_json(cfg.json_path, root)) rc = -1;
    cJSON_Delete(root);
    if (!cfg.keep_dir) {
        static const char *const files[] = {
            "baseline.json",      "eye.rays",         "bounce.rays",
            "embree.json",        "tessera.json",     "embree_eye.hits",
            "embree_bounce.hits", "tessera_eye.hits", "tessera_bounce.hits"};
        for (size_t i = 0; i < sizeof files / sizeof *files; ++i)
            remove(path_in(dir, files[i]));
        rmdir(dir);
    }
    return rc ? 1 : 0;
}
