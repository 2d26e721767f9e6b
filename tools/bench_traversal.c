/* bench_traversal.c — OpenCL on PoCL vs plain C: the bottom-level traversal, same algorithm,
 * same rays, same diced patches (issue 8 item 4, DESIGN.md §6).
 *
 * The teapot's 32 patches are diced and built once by the real dice and build stages at a
 * fixed m. The pairs are every (eye ray, patch) whose top-level box the ray enters, sorted by
 * patch, as the first iteration of a frame at 1 spp would give them (tmax = no hit). Then, R
 * times after one warm-up, the same pairs are traced by
 *   opencl:     the per-ray kernel bottom_level_trace on the default device (PoCL), timed by
 *               its profiling event (and by the wall clock around launch + finish);
 *   c_1thread:  host/ref/bottom_level_ref.c on one thread;
 *   c_threads:  the same on T pthreads (default 2, PoCL's thread count on this machine)
 *               taking chunks of 1024 pairs from a shared counter;
 * and the medians are reported as M traversals/s with the ratios C / OpenCL, and how many
 * cores each parallel variant really got (process CPU time over wall time: the machine is
 * shared). Every run's hit
 * records must agree bitwise between the three (the benchmark fails otherwise). Both
 * geometry modes (leaf boxes, micro-triangles) at leaf size 1.
 *
 * usage: bench_traversal [--size tiny|small|full] [--repeat R] [--threads T] [--json PATH]
 *                        [--scene RIB]   (default scene/teapot.rib, relative to the cwd)
 *   tiny: 64x36, m = 3; small: 640x360, m = 6; full: 1280x720, m = 8 (the foundation
 *   benchmark's teapot). */
#include "bench_util.h"
#include "ref/bottom_level_ref.h"
#include "lib/intersect.h"
#include "pipeline/pipeline.h"
#include "app/render.h"
#include "scene/rib/rib.h"

#include <cjson/cJSON.h>
#include <getopt.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct bench_options {
    const char *size, *json_path, *scene;
    int width, height, lod, repeat, threads;
} bench_options;

typedef struct bench_timing {
    double median_s, min_s;
} bench_timing;

typedef struct bench_mode {
    const char *name;
    int exact;
    uint64_t hits, tests;
    /* Hit records compared (pairs x runs, the warm-up included) and how many differed
     * bitwise: OpenCL against C on one thread, C on threads against C on one thread. */
    uint64_t compared, differ_opencl, differ_threads;
    bench_timing ocl_kernel, ocl_wall, c1, ct;
    double ocl_cores, ct_cores; /* process CPU seconds over wall seconds, medians */
} bench_mode;

static bench_timing bench_stats(double *v, int n)
{
    double median = bench_median(v, n); /* sorts v: v[0] is the minimum */
    return (bench_timing){median, v[0]};
}

static int bench_parse(int argc, char **argv, bench_options *o)
{
    static const struct option longopts[] = {
        {"size", required_argument, NULL, 's'},
        {"repeat", required_argument, NULL, 'r'},
        {"threads", required_argument, NULL, 't'},
        {"json", required_argument, NULL, 'j'},
        {"scene", required_argument, NULL, 'S'},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    *o = (bench_options){.size = "small", .scene = "scene/teapot.rib", .repeat = 0, .threads = 2};
    int c;
    while ((c = getopt_long(argc, argv, "s:r:t:j:h", longopts, NULL)) != -1) {
        switch (c) {
        case 's':
            o->size = optarg;
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
        case 'S':
            o->scene = optarg;
            break;
        default:
            fprintf(stderr,
                    "usage: %s [--size tiny|small|full] [--repeat R] [--threads T] [--json PATH] "
                    "[--scene RIB]\n",
                    argv[0]);
            return c == 'h' ? 0 : 1;
        }
    }
    int r;
    if (!strcmp(o->size, "tiny"))
        o->width = 64, o->height = 36, o->lod = 3, r = 3;
    else if (!strcmp(o->size, "small"))
        o->width = 640, o->height = 360, o->lod = 6, r = 9;
    else if (!strcmp(o->size, "full"))
        o->width = 1280, o->height = 720, o->lod = 8, r = 9;
    else {
        fprintf(stderr, "bench_traversal: --size must be tiny, small or full, not '%s'\n", o->size);
        return 1;
    }
    if (o->repeat == 0) o->repeat = r;
    if (o->repeat < 1 || o->threads < 1 || o->threads > 64) {
        fprintf(stderr, "bench_traversal: --repeat must be positive and --threads in 1..64\n");
        return 1;
    }
    return -1;
}

/* The C traversal on several threads: chunks of pairs from a shared counter. */
typedef struct bench_pool {
    const bl_ref_batch *batch;
    ts_hit *out;
    atomic_uint next;
    uint32_t count;
} bench_pool;

static void *bench_worker(void *arg)
{
    bench_pool *pool = arg;
    for (;;) {
        uint32_t first = atomic_fetch_add(&pool->next, 1024u);
        if (first >= pool->count) return NULL;
        uint32_t n = pool->count - first < 1024u ? pool->count - first : 1024u;
        bottom_level_ref_pairs(pool->batch, first, n, pool->out);
    }
}

static int bench_threads(const bl_ref_batch *b, uint32_t count, int threads, ts_hit *out)
{
    bench_pool pool = {b, out, 0, count};
    pthread_t tid[64];
    for (int i = 1; i < threads; ++i)
        if (pthread_create(&tid[i], NULL, bench_worker, &pool)) return 1;
    bench_worker(&pool);
    for (int i = 1; i < threads; ++i)
        pthread_join(tid[i], NULL);
    return 0;
}

typedef struct bench_setup {
    ts_device cl;
    ts_scene scene;
    ts_stats stats;
    ts_pipeline p;
    ts_vec4 *org, *dir;
    ts_hit *hit;
    uint32_t *flags, *active, rays, pair_count;
    ts_pair *pairs;
    ts_vec4 *grid;
    ts_box4 *groups;
    ts_tight4 *codes;
} bench_setup;

/* Eye rays through pixel centres; the pairs (patch, ray) whose patch box the ray enters;
 * every patch diced and built at o->lod by the pipeline's stages. */
static int bench_prepare(const bench_options *o, bench_setup *s, ts_error *err)
{
    ts_device_options clo = {.device_index = -1};
    if (dev_open(&s->cl, &clo, err) || rib_load(o->scene, &s->scene, 1, err)) return err->code;
    uint32_t np = s->scene.patch_count, rays = (uint32_t)(o->width * o->height);
    s->rays = rays;
    /* Pairs per patch: count first (for the buffer sizes). */
    ts_camera_params cam;
    if (render_camera_params(&s->scene.camera, o->width, o->height, &cam, err)) return err->code;
    cam.spp = 1, cam.ray_count = rays;
    ts_pipeline_plan probe = {.ray_capacity = rays, .pair_capacity = rays};
    pipeline_plan_arenas(&probe, np, (uint32_t)o->lod);
    if (pipeline_create(&s->p, &s->cl, &s->scene, &probe, rays, &s->stats, err) ||
        pipeline_camera(&s->p, &cam, err) || dev_finish(&s->cl, &s->stats, err))
        return err->code;
    s->org = malloc(rays * sizeof *s->org), s->dir = malloc(rays * sizeof *s->dir);
    if (!s->org || !s->dir) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    CL_CHECK(clEnqueueReadBuffer(s->cl.queue, s->p.ray_org, CL_TRUE, 0, rays * sizeof *s->org,
                                 s->org, 0, NULL, NULL),
             err);
    CL_CHECK(clEnqueueReadBuffer(s->cl.queue, s->p.ray_dir, CL_TRUE, 0, rays * sizeof *s->dir,
                                 s->dir, 0, NULL, NULL),
             err);
    pipeline_destroy(&s->p);
    size_t cap = (size_t)rays * 4;
    s->pairs = malloc(cap * sizeof *s->pairs);
    uint32_t n = 0;
    for (uint32_t q = 0; q < np; ++q) {
        ts_box b = scene_patch_box(&s->scene, q);
        for (uint32_t r = 0; r < rays; ++r) {
            ts_vec4 og = s->org[r], d = s->dir[r];
            if (box_enter(og.x, og.y, og.z, safe_reciprocal(d.x), safe_reciprocal(d.y),
                          safe_reciprocal(d.z), b.lo_x, b.lo_y, b.lo_z, b.hi_x, b.hi_y, b.hi_z,
                          og.w, TS_NO_HIT) < 0.0f)
                continue;
            if (n == cap) s->pairs = realloc(s->pairs, (cap *= 2) * sizeof *s->pairs);
            if (!s->pairs) return ts_error_set(err, TS_E_MEMORY, "out of memory");
            s->pairs[n] = (ts_pair){q, r}; /* window: the ray for now */
            ++n;
        }
    }
    s->pair_count = n;
    /* n_per_ray = 1: window g is pair g, active[g] its ray; ray buffers sized for the pairs. */
    uint32_t slots = n > rays ? n : rays;
    s->active = malloc(slots * sizeof *s->active);
    s->hit = malloc(rays * sizeof *s->hit);
    s->flags = calloc(rays, sizeof *s->flags);
    if (!s->active || !s->hit || !s->flags) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    for (uint32_t g = 0; g < n; ++g)
        s->active[g] = s->pairs[g].window, s->pairs[g].window = g;
    for (uint32_t r = 0; r < rays; ++r)
        s->hit[r] = (ts_hit){TS_NO_HIT, 0, 0, TS_INVALID, TS_INVALID};
    ts_pipeline_plan plan = {.ray_capacity = slots, .pair_capacity = n ? n : 1};
    pipeline_plan_arenas(&plan, np, (uint32_t)o->lod);
    stats_free(&s->stats); /* the probe's */
    memset(&s->stats, 0, sizeof s->stats);
    if (pipeline_create(&s->p, &s->cl, &s->scene, &plan, rays, &s->stats, err)) return err->code;
    uint32_t begin = 0;
    for (uint32_t q = 0; q < np; ++q) {
        uint32_t end = begin;
        while (end < n && s->pairs[end].leaf == q)
            ++end;
        s->p.segments_host[q] =
            (ts_segment){.patch = q, .begin = begin, .end = end, .lod = (uint32_t)o->lod};
        begin = end;
    }
    if (pipeline_dice_build(&s->p, np, err)) return err->code;
    cl_command_queue qu = s->cl.queue;
    CL_CHECK(clEnqueueWriteBuffer(qu, s->p.pairs, CL_TRUE, 0, n * sizeof *s->pairs, s->pairs, 0,
                                  NULL, NULL),
             err);
    CL_CHECK(clEnqueueWriteBuffer(qu, s->p.active, CL_TRUE, 0, n * sizeof *s->active, s->active, 0,
                                  NULL, NULL),
             err);
    CL_CHECK(clEnqueueWriteBuffer(qu, s->p.ray_org, CL_TRUE, 0, rays * sizeof *s->org, s->org, 0,
                                  NULL, NULL),
             err);
    CL_CHECK(clEnqueueWriteBuffer(qu, s->p.ray_dir, CL_TRUE, 0, rays * sizeof *s->dir, s->dir, 0,
                                  NULL, NULL),
             err);
    CL_CHECK(clEnqueueWriteBuffer(qu, s->p.ray_hit, CL_TRUE, 0, rays * sizeof *s->hit, s->hit, 0,
                                  NULL, NULL),
             err);
    /* Eye rays: no patch left, flags 0 (s->flags is all zeros). */
    CL_CHECK(clEnqueueWriteBuffer(qu, s->p.ray_from, CL_TRUE, 0, rays * sizeof *s->flags, s->flags,
                                  0, NULL, NULL),
             err);
    CL_CHECK(clEnqueueWriteBuffer(qu, s->p.ray_flags, CL_TRUE, 0, rays * sizeof *s->flags, s->flags,
                                  0, NULL, NULL),
             err);
    size_t gbytes = (size_t)plan.vert_capacity * sizeof(ts_vec4),
           nbytes = (size_t)plan.group_capacity * sizeof(ts_box4);
    size_t cbytes = (size_t)plan.group_capacity * sizeof(ts_tight4);
    s->grid = malloc(gbytes), s->groups = malloc(nbytes), s->codes = malloc(cbytes);
    if (!s->grid || !s->groups || !s->codes) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    CL_CHECK(clEnqueueReadBuffer(qu, s->p.grid, CL_TRUE, 0, gbytes, s->grid, 0, NULL, NULL), err);
    CL_CHECK(clEnqueueReadBuffer(qu, s->p.groups, CL_TRUE, 0, nbytes, s->groups, 0, NULL, NULL),
             err);
    CL_CHECK(clEnqueueReadBuffer(qu, s->p.tight, CL_TRUE, 0, cbytes, s->codes, 0, NULL, NULL), err);
    return TS_OK;
}

/* Bitwise comparison of two hit arrays; returns the number of differing records. */
static uint64_t bench_diff(const ts_hit *a, const ts_hit *b, uint32_t n)
{
    uint64_t d = 0;
    for (uint32_t i = 0; i < n; ++i)
        d += memcmp(&a[i], &b[i], sizeof *a) != 0;
    return d;
}

/* One geometry mode: R timed runs of each of the three after a warm-up. */
static int bench_mode_run(const bench_options *o, bench_setup *s, bench_mode *m, ts_error *err)
{
    uint32_t n = s->pair_count;
    ts_hit *dev = malloc(n * sizeof *dev), *c1 = malloc(n * sizeof *c1),
           *ct = malloc(n * sizeof *ct);
    double *tk = malloc((size_t)o->repeat * 6 * sizeof *tk), *tw = tk + o->repeat,
           *t1 = tw + o->repeat, *tt = t1 + o->repeat;
    double *uo = tt + o->repeat, *ut = uo + o->repeat; /* cores used */
    if (!dev || !c1 || !ct || !tk) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    s->p.mode.exact = m->exact, s->p.mode.leaf_b = 0, s->p.mode.leaf_group = 0;
    bl_ref_batch b = {s->pairs, 0,
                      n,        s->p.segments_host,
                      0,        s->scene.patch_count,
                      1,        (uint32_t)m->exact,
                      0,        s->active,
                      s->org,   s->dir,
                      s->hit,   s->flags,
                      s->flags, /* ray_from: all 0 */
                      s->grid,  s->groups,
                      s->codes, NULL,
                      NULL}; /* no instances */
    uint64_t bad = 0;
    for (int r = -1; r < o->repeat && !bad; ++r) {
        double k0 = s->stats.stage_seconds[TS_STAGE_bottom_level], c0 = bench_cpu(),
               w0 = bench_now();
        if (pipeline_bottom_level(&s->p, 1, err)) break;
        double w1 = bench_now(), c1t = bench_cpu();
        m->tests = bottom_level_ref_pairs(&b, 0, n, c1);
        double c2t = bench_cpu(), w2 = bench_now();
        if (bench_threads(&b, n, o->threads, ct)) {
            ts_error_set(err, TS_E_INTERNAL, "pthread_create failed");
            break;
        }
        double w3 = bench_now(), c3t = bench_cpu();
        if (clEnqueueReadBuffer(s->cl.queue, s->p.pair_hit, CL_TRUE, 0, n * sizeof *dev, dev, 0,
                                NULL, NULL)) {
            ts_error_set(err, TS_E_DEVICE, "reading pair_hit");
            break;
        }
        uint64_t d_ocl = bench_diff(dev, c1, n), d_thr = bench_diff(c1, ct, n);
        m->compared += n, m->differ_opencl += d_ocl, m->differ_threads += d_thr;
        bad = d_ocl + d_thr;
        if (r < 0) continue;
        tk[r] = s->stats.stage_seconds[TS_STAGE_bottom_level] - k0, tw[r] = w1 - w0,
        t1[r] = w2 - w1, tt[r] = w3 - w2;
        uo[r] = (c1t - c0) / (w1 - w0), ut[r] = (c3t - c2t) / (w3 - w2);
    }
    if (bad && !err->code)
        ts_error_set(err, TS_E_INTERNAL, "%s: %llu hit records differ between OpenCL and C",
                     m->name, (unsigned long long)bad);
    if (!err->code) {
        m->hits = 0;
        for (uint32_t i = 0; i < n; ++i)
            m->hits += c1[i].patch != TS_INVALID;
        m->ocl_kernel = bench_stats(tk, o->repeat), m->ocl_wall = bench_stats(tw, o->repeat);
        m->c1 = bench_stats(t1, o->repeat), m->ct = bench_stats(tt, o->repeat);
        m->ocl_cores = bench_stats(uo, o->repeat).median_s,
        m->ct_cores = bench_stats(ut, o->repeat).median_s;
    }
    free(dev), free(c1), free(ct), free(tk);
    return err->code;
}

static void add_rate(cJSON *j, const char *name, bench_timing t, double n)
{
    cJSON *o = cJSON_AddObjectToObject(j, name);
    cJSON_AddNumberToObject(o, "median_seconds", t.median_s);
    cJSON_AddNumberToObject(o, "min_seconds", t.min_s);
    cJSON_AddNumberToObject(o, "mtraversals_per_second", n / t.median_s * 1e-6);
}

static int bench_json(const bench_options *o, const bench_setup *s, const bench_mode *modes, int nm)
{
    cJSON *root = cJSON_CreateObject();
    double n = s->pair_count;
    cJSON_AddStringToObject(root, "benchmark", "traversal");
    cJSON_AddStringToObject(root, "size", o->size);
    cJSON_AddStringToObject(root, "scene", o->scene);
    cJSON_AddStringToObject(root, "device", s->cl.info.name);
    cJSON_AddNumberToObject(root, "device_compute_units", s->cl.info.compute_units);
    cJSON_AddNumberToObject(root, "width", o->width);
    cJSON_AddNumberToObject(root, "height", o->height);
    cJSON_AddNumberToObject(root, "lod", o->lod);
    cJSON_AddNumberToObject(root, "rays", s->rays);
    cJSON_AddNumberToObject(root, "pairs", n);
    cJSON_AddNumberToObject(root, "repeat", o->repeat);
    cJSON_AddNumberToObject(root, "threads", o->threads);
    cJSON *arr = cJSON_AddArrayToObject(root, "modes");
    for (int i = 0; i < nm; ++i) {
        const bench_mode *m = &modes[i];
        cJSON *j = cJSON_CreateObject();
        cJSON_AddStringToObject(j, "intersect", m->name);
        cJSON_AddNumberToObject(j, "hits", (double)m->hits);
        cJSON_AddNumberToObject(j, "micro_quad_tests", (double)m->tests);
        cJSON_AddNumberToObject(j, "records_compared", (double)m->compared);
        cJSON *d = cJSON_AddObjectToObject(j, "differing_records");
        cJSON_AddNumberToObject(d, "opencl_vs_c", (double)m->differ_opencl);
        cJSON_AddNumberToObject(d, "c_threads_vs_c", (double)m->differ_threads);
        cJSON_AddBoolToObject(j, "hits_agree", m->differ_opencl == 0 && m->differ_threads == 0);
        add_rate(j, "opencl", m->ocl_kernel, n);
        add_rate(j, "opencl_wall", m->ocl_wall, n);
        add_rate(j, "c_1thread", m->c1, n);
        add_rate(j, "c_threads", m->ct, n);
        cJSON_AddNumberToObject(j, "opencl_cores_used", m->ocl_cores);
        cJSON_AddNumberToObject(j, "c_threads_cores_used", m->ct_cores);
        cJSON_AddNumberToObject(j, "ratio_c_1thread_to_opencl",
                                m->ocl_kernel.median_s / m->c1.median_s);
        cJSON_AddNumberToObject(j, "ratio_c_threads_to_opencl",
                                m->ocl_kernel.median_s / m->ct.median_s);
        cJSON_AddItemToArray(arr, j);
    }
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    FILE *f = text ? fopen(o->json_path, "w") : NULL;
    int ok = f && fputs(text, f) >= 0 && fputc('\n', f) != EOF;
    if (f && fclose(f) != 0) ok = 0;
    free(text);
    if (!ok) fprintf(stderr, "bench_traversal: cannot write %s\n", o->json_path);
    return ok ? 0 : 1;
}

static void bench_print(const bench_options *o, const bench_setup *s, const bench_mode *modes,
                        int nm)
{
    double n = s->pair_count;
    printf("traversal: %s, %dx%d eye rays, %u patches at m = %d, %u (ray, patch) pairs, device %s "
           "(%u compute units), C on %d threads, median of %d\n",
           o->scene, o->width, o->height, s->scene.patch_count, o->lod, s->pair_count,
           s->cl.info.name, s->cl.info.compute_units, o->threads, o->repeat);
    printf("%-10s %8s %12s %12s %12s %12s %9s %9s %10s\n", "intersect", "hits", "OpenCL M/s",
           "(wall) M/s", "C 1thr M/s", "C thr M/s", "C1/OCL", "Cthr/OCL", "cores O/C");
    for (int i = 0; i < nm; ++i) {
        const bench_mode *m = &modes[i];
        printf("%-10s %8llu %12.2f %12.2f %12.2f %12.2f %9.2f %9.2f %4.2f/%4.2f\n", m->name,
               (unsigned long long)m->hits, n / m->ocl_kernel.median_s * 1e-6,
               n / m->ocl_wall.median_s * 1e-6, n / m->c1.median_s * 1e-6,
               n / m->ct.median_s * 1e-6, m->ocl_kernel.median_s / m->c1.median_s,
               m->ocl_kernel.median_s / m->ct.median_s, m->ocl_cores, m->ct_cores);
    }
    for (int i = 0; i < nm; ++i)
        printf("%s: %llu hit records compared, %llu differ OpenCL vs C, %llu C threads vs C\n",
               modes[i].name, (unsigned long long)modes[i].compared,
               (unsigned long long)modes[i].differ_opencl,
               (unsigned long long)modes[i].differ_threads);
    printf("cores O/C: process CPU seconds per wall second while OpenCL / the C threads ran\n");
}

int main(int argc, char **argv)
{
    bench_options o;
    int rc = bench_parse(argc, argv, &o);
    if (rc >= 0) return rc;
    static bench_setup s;
    ts_error err = {0};
    bench_mode modes[2] = {{.name = "boxes", .exact = 0}, {.name = "triangles", .exact = 1}};
    if (!bench_prepare(&o, &s, &err) && s.pair_count == 0)
        ts_error_set(&err, TS_E_INTERNAL, "no ray enters a patch box");
    for (int i = 0; i < 2 && !err.code; ++i)
        bench_mode_run(&o, &s, &modes[i], &err);
    rc = err.code != TS_OK;
    if (rc)
        fprintf(stderr, "bench_traversal: %s\n", err.msg);
    else {
        bench_print(&o, &s, modes, 2);
        if (o.json_path) rc = bench_json(&o, &s, modes, 2);
    }
    if (s.p.cl) pipeline_destroy(&s.p);
    free(s.org), free(s.dir), free(s.hit), free(s.flags), free(s.active), free(s.pairs),
        free(s.grid), free(s.groups), free(s.codes);
    scene_free(&s.scene);
    if (s.cl.context) dev_close(&s.cl);
    stats_free(&s.stats);
    return rc;
}
