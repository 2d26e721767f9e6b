/* workers.c — one frame on several devices of one process, a host thread each (workers.h). */
#include "app/workers.h"
#include "base/memory.h"
#include "app/eta.h"
#include "app/interrupt.h"
#include "app/budget.h"
#include "app/render.h"
#include "app/waves.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

struct ts_worker {
    ts_workers *g;
    uint32_t slot; /* in g->w; slot 0 makes the lod */
    int lod_part;  /* the part of the lod pass this device counts (g->lod_parts), or -1 */
    int index;     /* in `tessera devices` */
    ts_device cl;
    ts_pipeline pipe;
    int has_pipe;
    ts_stats stats;   /* this device's stages and counters */
    uint64_t mb;      /* this pipeline's budget */
    uint64_t room_mb; /* how far its arenas may grow (budget_grow_arenas) */
    uint32_t noted_lod;
    pthread_t thread;
    int started;
    long slow_ms;               /* TESSERA_SLOW_DEVICE: a pause after each wave (tests) */
    const ts_unit *cancel_unit; /* the unit being traced, for worker_unit_dropped */
    struct unit_passes *passes; /* its wave's passes, which worker_unit_dropped hands on */
    ts_vec4 *aov_wave;          /* a wave's AOVs and albedo, worker_read_aov_strided's */
    size_t aov_wave_cap;        /* samples aov_wave holds (2 vec4 each) */
    int shares;                 /* computes like device 0: shares built patches through g->share */
    ts_device_stats out;
    int failed, reported; /* failed: err says why; reported: workers_report said so */
    ts_error err;
};

/* "device I (NAME)" for messages. */
static const char *worker_name(const ts_worker *w, char *buf, size_t cap)
{
    snprintf(buf, cap, "device %d (%s)", w->index, w->cl.info.name);
    return buf;
}

/* The memory budget of w's device: --memory, else budget_default from its own memory and,
 * when it shares host memory, its share of the room the process has (share devices use
 * it). Unless quiet, the device and its budget on one line. */
static void worker_budget(ts_worker *w, uint32_t share, uint32_t streams)
{
    const ts_frame *f = &w->g->frame;
    ts_budget_choice c;
    int split = streams > 1; /* the budget shared by the device's streams */
    if (f->opt->memory_mb > 0) {
        budget_fixed((uint64_t)f->opt->memory_mb, &c);
    } else {
        ts_memory_room room;
        ts_memory_room_query(NULL, &room);
        if (room.bytes != UINT64_MAX && share > 1) room.bytes /= share;
        budget_default(&w->cl.info, budget_fixed_bytes(f->scene, 0), &room, &c); /* no film */
        size_t n = strlen(c.why), which = strlen(room.which);
        if (share > 1 && w->cl.info.host_unified && which &&
            strncmp(c.why, room.which, which) == 0) {
            snprintf(c.why + n, sizeof c.why - n, ", shared by %u devices", share);
            split = 0; /* the room is split already: the streams count among the devices */
        }
    }
    if (split) { /* --memory, the device's memory or the cap, split */
        size_t n = strlen(c.why);
        c.mb = c.mb / streams > TS_MEMORY_FLOOR_MB ? c.mb / streams : TS_MEMORY_FLOOR_MB;
        c.room_mb = c.room_mb / streams > c.mb ? c.room_mb / streams : c.mb;
        snprintf(c.why + n, sizeof c.why - n, ", shared by %u streams", streams);
    }
    w->mb = c.mb;
    w->room_mb = c.room_mb;
    w->noted_lod = (uint32_t)f->opt->max_lod;
    if (!f->opt->quiet)
        ts_print_line("tessera: device %d: %s (%s), memory budget %llu MB (%s)", w->index,
                      w->cl.info.name, w->cl.info.platform_name, (unsigned long long)c.mb, c.why);
}

/* Whether devices a and b compute alike: the same platform, device name, version and
 * driver, so that dicing gives the same bits on both (DESIGN.md §4: several devices give the
 * one-device image). */
static int devices_alike(const ts_device_info *a, const ts_device_info *b)
{
    return a->type == b->type && strcmp(a->platform_name, b->platform_name) == 0 &&
           strcmp(a->name, b->name) == 0 && strcmp(a->version, b->version) == 0 &&
           strcmp(a->driver, b->driver) == 0;
}

/* The store of built patches, when at least two devices compute like device 0 and
 * TESSERA_PATCH_SHARE is not "0" (a switch for checks and benchmarks). */
static int workers_share_open(ts_workers *g, ts_error *err)
{
    uint32_t alike = 0;
    for (uint32_t i = 0; i < g->count; ++i)
        alike += g->w[i].shares = devices_alike(&g->w[0].cl.info, &g->w[i].cl.info);
    const char *env = getenv("TESSERA_PATCH_SHARE");
    if (alike < 2 || (env && strcmp(env, "0") == 0)) {
        for (uint32_t i = 0; i < g->count; ++i)
            g->w[i].shares = 0;
        return TS_OK;
    }
    if (patch_share_create(&g->share, g->frame.scene->patch_count, alike, err)) return err->code;
    g->sharing = 1;
    return TS_OK;
}

void workers_streams(int *indices, int *count, int streams)
{
    int n = *count, out = 0, list[TS_DEVICE_MAX];
    for (int s = 0; s < streams; ++s)
        for (int i = 0; i < n && out < TS_DEVICE_MAX; ++i)
            list[out++] = indices[i];
    memcpy(indices, list, (size_t)out * sizeof *list);
    *count = out;
}

unsigned workers_host_cores(const int *indices, int count)
{
    const char *env = getenv("TESSERA_HOST_CORES");
    long set = env && *env ? strtol(env, NULL, 10) : 0;
    if (set > 0) return (unsigned)set;
    if (count < 2) return 0; /* one device: nothing beside it */
    ts_device_info *list = NULL;
    ts_error e = {0};
    int n = dev_list(&list, &e), gpu = 0;
    ts_error_clear(&e);
    for (int i = 0; i < count; ++i)
        if (indices[i] >= 0 && indices[i] < n && !(list[indices[i]].type & CL_DEVICE_TYPE_CPU))
            gpu = 1;
    free(list);
    if (!gpu) return 0;
    long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    return cpus / 4 > 2 ? (unsigned)(cpus / 4) : 2u;
}

int workers_open(ts_workers *g, const ts_frame *frame, const int *indices, int count, ts_error *err)
{
    memset(g, 0, sizeof *g);
    g->frame = *frame;
    g->w = calloc((size_t)count, sizeof *g->w);
    if (!g->w) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    pthread_mutex_init(&g->lock, NULL);
    pthread_cond_init(&g->lod_cond, NULL);
    ts_error first = {0};
    unsigned host = workers_host_cores(indices, count);
    long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    for (int i = 0; i < count; ++i) {
        ts_worker *w = &g->w[g->count];
        ts_device_options dopt = frame->opt->cl;
        dopt.device_index = indices[i];
        dopt.slot = (int)g->count;
        dopt.host_cores = host;
        ts_error e = {0};
        if (dev_open(&w->cl, &dopt, &e)) {
            if (!frame->opt->quiet)
                ts_print_line(
                    "tessera: warning: device %d cannot render: %s; the other devices go on "
                    "without it (render with --device %d alone for the details)",
                    indices[i], e.msg, indices[i]);
            if (!first.code) ts_error_set(&first, e.code, "%s", e.msg);
            ts_error_clear(&e);
            continue;
        }
        if (!frame->opt->quiet && w->cl.cache_note[0])
            ts_print_line("tessera: warning: %s", w->cl.cache_note);
        w->g = g;
        w->slot = g->count++;
        w->index = indices[i];
    }
    if (g->count == 0) {
        ts_error_set(err, first.code ? first.code : TS_E_DEVICE, "%s",
                     first.code ? first.msg : "no device could be opened");
        ts_error_clear(&first);
        return err->code;
    }
    ts_error_clear(&first);
    uint32_t unified = 0;
    for (uint32_t i = 0; i < g->count; ++i)
        unified += g->w[i].cl.info.host_unified ? 1u : 0u;
    for (uint32_t i = 0; i < g->count; ++i) {
        uint32_t streams = 0; /* workers on this device (--streams) */
        for (uint32_t j = 0; j < g->count; ++j)
            streams += g->w[j].index == g->w[i].index;
        worker_budget(&g->w[i],
                      (g->w[i].cl.info.host_unified ? unified : 1u) *
                          (frame->budget_share ? frame->budget_share : 1u),
                      streams);
    }
    if (workers_share_open(g, err)) return err->code;
    g->sort_threads = cpus > (long)g->count ? (uint32_t)(cpus / (long)g->count) : 1u;
    if (host > 0 && host < g->sort_threads) g->sort_threads = host; /* the cores left to it */
    return TS_OK;
}

/* Creates w's pipeline at budget w->mb, halving it when memory runs out (down to
 * TS_MEMORY_FLOOR_MB), with a note each time. Waves of at most one unit: each path also owns
 * a shadow-ray slot. */
static int worker_pipeline(ts_worker *w, ts_error *err)
{
    const ts_frame *f = &w->g->frame;
    char name[300];
    for (;;) {
        ts_pipeline_plan plan;
        uint64_t rays = 2 * f->unit_samples;
        if (pipeline_plan(w->mb << 20, rays, (uint32_t)f->opt->max_lod, w->cl.info.max_alloc, &plan,
                          err))
            return err->code;
        plan.sort_threads = w->g->sort_threads;
        plan.host_film = 1; /* the board merges the units into the host's films */
        if (!f->opt->quiet && plan.max_lod < w->noted_lod)
            ts_print_line("tessera: %s: %llu MB holds patches up to m = %u",
                          worker_name(w, name, sizeof name), (unsigned long long)w->mb,
                          plan.max_lod);
        w->noted_lod = plan.max_lod;
        w->stats.memory_budget_bytes = w->mb << 20;
        if (!pipeline_create(&w->pipe, &w->cl, f->scene, &plan, f->pixel_count, &w->stats, err) &&
            !dev_finish(&w->cl, &w->stats, err)) {
            w->has_pipe = 1;
            w->pipe.mode = waves_trace_mode(f->opt);
            return TS_OK;
        }
        pipeline_destroy(&w->pipe);
        if (!(dev_is_out_of_memory(err) || err->code == TS_E_MEMORY) ||
            w->mb / 2 < TS_MEMORY_FLOOR_MB)
            return err->code;
        if (!f->opt->quiet)
            ts_print_line("tessera: %s could not provide %llu MB (%s); retrying with %llu MB",
                          worker_name(w, name, sizeof name), (unsigned long long)w->mb, err->msg,
                          (unsigned long long)(w->mb / 2));
        ts_error_clear(err);
        w->mb /= 2;
    }
}

/* Adds a pipeline's pixel weights (0: not counted there) into g->pixel_cost, made on first
 * use; called with g->lock held. A weight kept from no part is simply not shown. */
static void pixel_cost_merge(ts_workers *g, const uint32_t *cost)
{
    uint64_t npix = (uint64_t)g->frame.cam.width * g->frame.cam.height;
    if (!cost || npix == 0) return;
    if (!g->pixel_cost && !(g->pixel_cost = calloc(npix, sizeof *g->pixel_cost))) return;
    for (uint64_t i = 0; i < npix; ++i)
        if (cost[i] > g->pixel_cost[i]) g->pixel_cost[i] = cost[i];
}

/* Publishes the frame's levels of detail (patch_lod: patch_count entries, copied), or
 * their failure (patch_lod NULL; why, when known, becomes g->fatal), which ends every
 * thread waiting for them. */
static void lod_publish(ts_workers *g, uint32_t max_lod, const uint8_t *patch_lod,
                        const ts_error *why)
{
    size_t n = g->frame.scene->patch_count ? g->frame.scene->patch_count : 1;
    pthread_mutex_lock(&g->lock);
    if (patch_lod && (g->patch_lod = malloc(n))) {
        memcpy(g->patch_lod, patch_lod, n);
        g->max_lod = max_lod;
        g->lod_state = 1;
    } else {
        if (!g->fatal.code && why && why->code)
            ts_error_set_status(&g->fatal, why->code, why->status, "%s", why->msg);
        else if (!g->fatal.code)
            ts_error_set(&g->fatal, patch_lod ? TS_E_MEMORY : TS_E_INTERNAL, "%s",
                         patch_lod ? "out of memory" : "the frame's levels of detail are missing");
        g->lod_state = -1;
    }
    pthread_cond_broadcast(&g->lod_cond);
    pthread_mutex_unlock(&g->lock);
}

/* The lod pass's pixels in up to LOD_CHUNKS chunks a part of at least LOD_CHUNK_PIXELS
 * pixels (a launch each), dealt out in turn, so that each part counts rows from the whole
 * image (the upper and lower halves of forest-1 at 1920x768, sky and trees, took 0.04 and
 * 0.09 s); a small frame is one chunk a part. */
#define LOD_CHUNKS 8u
#define LOD_CHUNK_PIXELS 65536u

/* Counts part k of the lod pass on w's device (counts left in its buffer): chunks k,
 * k + parts, k + 2 * parts, ... of the pixels. */
static int lod_count_part(ts_worker *w, uint32_t k, ts_error *err)
{
    const ts_frame *f = &w->g->frame;
    uint64_t pixels = pipeline_frame_pixels(&f->cam), parts = w->g->lod_parts;
    uint64_t per = pixels / (parts * LOD_CHUNK_PIXELS);
    uint64_t chunks = parts * (per < 1 ? 1 : per > LOD_CHUNKS ? LOD_CHUNKS : per);
    for (uint64_t j = k; j < chunks; j += parts)
        if (pipeline_lod_count_pixels(&w->pipe, &f->cam, (uint32_t)(pixels * j / chunks),
                                      (uint32_t)(pixels * (j + 1) / chunks), err))
            return err->code;
    return TS_OK;
}

/* A device other than 0 with a part of the lod pass: counts it and adds its counts to
 * g->lod_more, or marks the part abandoned (pipeline_ok 0, or the count failed: err says
 * why) so that device 0 counts it. Never waits for another device. */
static void worker_count_lod_part(ts_worker *w, int pipeline_ok, ts_error *err)
{
    ts_workers *g = w->g;
    uint32_t n = g->frame.scene->patch_count;
    /* TESSERA_FAIL_LOD_PART=1 (a testing aid, docs/errors.md): every part abandoned. */
    const char *fail = getenv("TESSERA_FAIL_LOD_PART");
    int give_up = fail && strcmp(fail, "1") == 0;
    uint32_t *counts = pipeline_ok && !give_up ? malloc((n ? n : 1u) * sizeof *counts) : NULL;
    int ok = counts && !lod_count_part(w, (uint32_t)w->lod_part, err) &&
             !pipeline_lod_take_counts(&w->pipe, counts, err);
    pthread_mutex_lock(&g->lock);
    for (uint32_t i = 0; ok && i < n; ++i)
        g->lod_more[i] += counts[i];
    if (ok) pixel_cost_merge(g, w->pipe.pixel_cost);
    g->lod_part[w->lod_part] = ok ? 1 : -1;
    pthread_cond_broadcast(&g->lod_cond);
    pthread_mutex_unlock(&g->lock);
    free(counts);
}

/* Device 0's part of a split lod pass: its own pixels, then, once every other part is
 * added or abandoned, the abandoned ones; the levels from the sum. */
static int lod_split_levels(ts_worker *w, ts_error *err)
{
    ts_workers *g = w->g;
    if (lod_count_part(w, 0, err)) return err->code;
    for (uint32_t k = 1; k < g->lod_parts; ++k) {
        pthread_mutex_lock(&g->lock);
        while (g->lod_part[k] == 0)
            pthread_cond_wait(&g->lod_cond, &g->lock);
        int abandoned = g->lod_part[k] < 0;
        pthread_mutex_unlock(&g->lock);
        if (abandoned && lod_count_part(w, k, err)) return err->code;
    }
    return pipeline_lod_finish_with(&w->pipe, TS_LOD_RULE_CROSSED, 0, g->lod_more, err);
}

/* Device 0: runs the lod stage (alone, or its part of it and the sum of the parts) and
 * publishes the frame's levels of detail. */
static int worker_make_lod(ts_worker *w, ts_error *err)
{
    const ts_frame *f = &w->g->frame;
    int rc = w->g->lod_parts > 1
                 ? lod_split_levels(w, err) || waves_lod_record(f->opt, &w->pipe, f->job, err)
                 : waves_frame_lod(f->opt, &w->pipe, f->cam, f->job, err);
    if (!rc) {
        pthread_mutex_lock(&w->g->lock);
        pixel_cost_merge(w->g, w->pipe.pixel_cost);
        pthread_mutex_unlock(&w->g->lock);
    }
    lod_publish(w->g, w->pipe.plan.max_lod, rc ? NULL : w->pipe.patch_lod, err);
    return rc ? rc : w->g->lod_state > 0 ? TS_OK : TS_E_MEMORY;
}

/* Waits for the frame's levels of detail and gives them to w's pipeline: they must fit its
 * arenas (a device whose budget holds coarser patches than device 0's cannot take part). */
static int worker_take_lod(ts_worker *w, int *lod_failed, ts_error *err)
{
    ts_workers *g = w->g;
    pthread_mutex_lock(&g->lock);
    while (g->lod_state == 0)
        pthread_cond_wait(&g->lod_cond, &g->lock);
    pthread_mutex_unlock(&g->lock);
    *lod_failed = g->lod_state < 0;
    if (*lod_failed) return TS_E_INTERNAL;
    ts_pipeline *p = &w->pipe;
    char name[300];
    if (p->plan.max_lod < g->max_lod)
        return ts_error_set(err, TS_E_USAGE,
                            "%s: %llu MB holds patches up to m = %u and the frame dices up to m = "
                            "%u (device %d's budget): raise --memory",
                            worker_name(w, name, sizeof name), (unsigned long long)w->mb,
                            p->plan.max_lod, g->max_lod, g->w[0].index);
    p->plan.max_lod = g->max_lod;
    w->stats.counters[TS_COUNTER_micropolygons_potential] = (uint64_t)g->frame.scene->patch_count
                                                            << (2u * g->max_lod);
    memcpy(p->patch_lod, g->patch_lod, g->frame.scene->patch_count);
    patch_cache_clear(&p->cache);
    return TS_OK;
}

/* The AOVs and albedo of the samples 0 among the wave's n samples from `first`, into aov and
 * albedo, in pixel order (bands of one pixel, done.h): a sample 0 every spp samples, so the
 * wave's are read whole and the samples 0 picked out rather than read one by one. */
static int worker_read_aov_strided(ts_worker *w, const ts_sample_order *o, uint64_t first,
                                   uint32_t n, ts_vec4 *aov, ts_vec4 *albedo, ts_error *err)
{
    ts_pipeline *p = &w->pipe;
    if (w->aov_wave_cap < n) { /* kept from wave to wave: a wave's size at most */
        free(w->aov_wave);
        w->aov_wave_cap = 0;
        if (!(w->aov_wave = malloc(2 * (size_t)n * sizeof *w->aov_wave)))
            return ts_error_set(err, TS_E_MEMORY, "out of memory for the AOVs of a unit");
        w->aov_wave_cap = n;
    }
    ts_vec4 *tmp = w->aov_wave;
    int rc = dev_read(&w->cl, p->aov, 0, (size_t)n * sizeof *tmp, tmp, "the AOVs of a unit", err) ||
             dev_read(&w->cl, p->albedo, 0, (size_t)n * sizeof *tmp, tmp + n,
                      "the albedo of a unit", err);
    uint64_t k0, k1, j = 0, end = first + n;
    for (uint64_t k = first; !rc && k < end && sample_order_zero_run(o, k, end - k, &k0, &k1);
         k = k1)
        for (uint64_t q = k0; q < k1; ++q, ++j)
            aov[j] = tmp[q - first], albedo[j] = tmp[n + (q - first)];
    return rc ? err->code : TS_OK;
}

/* Reads the wave's results (n samples from `first`) into the unit's: radiance, and the
 * AOVs of the samples that are their pixels' samples 0 (in runs, sample_order_zero_run;
 * picked from the whole wave's in pixel order). Timed as `film`. */
static int worker_read_wave(ts_worker *w, const ts_unit *u, uint64_t first, uint32_t n,
                            ts_unit_result *r, ts_error *err)
{
    ts_pipeline *p = &w->pipe;
    double t0 = stats_now();
    ts_sample_order o = sample_order_of(&w->g->frame.cam);
    uint64_t at = first - u->first, end = first + n, k0, k1;
    uint64_t j = sample_order_zero_count(&o, u->first, at); /* the unit's AOVs before it */
    int rc = dev_read(&w->cl, p->radiance, 0, (size_t)n * sizeof(ts_vec4), r->radiance + at,
                      "the radiance of a unit", err);
    int strided = o.band == 1u && o.spp > 1u; /* pixel after pixel: every spp-th sample */
    if (!rc && strided)
        rc = worker_read_aov_strided(w, &o, first, n, r->aov + j, r->albedo + j, err);
    for (uint64_t k = first;
         !rc && !strided && k < end && sample_order_zero_run(&o, k, end - k, &k0, &k1);
         k = k1, j += k1 - k0) {
        /* runs that follow on are read at once: at 1 spp every sample is a sample 0, one run
         * a pixel, and a read each made a frame's read-back take longer than its render */
        uint64_t a, b;
        while (k1 < end && sample_order_zero_run(&o, k1, end - k1, &a, &b) && a == k1)
            k1 = b;
        size_t off = (size_t)(k0 - first) * sizeof(ts_vec4), bytes = (k1 - k0) * sizeof(ts_vec4);
        rc = dev_read(&w->cl, p->aov, off, bytes, r->aov + j, "the AOVs of a unit", err) ||
             dev_read(&w->cl, p->albedo, off, bytes, r->albedo + j, "the albedo of a unit", err);
    }
    w->stats.stage_seconds[TS_STAGE_film] += stats_now() - t0;
    return rc ? err->code : TS_OK;
}

/* The passes of the wave a worker traces (render.c's render_pass_ended for one device), handed
 * to the board as they end (ts_unit_source.passes) for the progress line's estimate, and
 * between them the pass in flight's batches (eta.h ts_eta_flight), at most every
 * UNIT_FLIGHT_SECONDS. */
typedef struct unit_passes {
    ts_worker *w;
    const ts_unit *u;
    ts_eta_passes passes;
    double t0, dicing, handed;
    uint64_t mp, evictions; /* the worker's counters as the wave began */
} unit_passes;
#define UNIT_FLIGHT_SECONDS 0.25

/* The passes so far to the board (ts_unit_source.passes). */
static void unit_passes_hand(unit_passes *up)
{
    const ts_unit_source *src = &up->w->g->src;
    up->handed = stats_now();
    if (src->passes) src->passes(src->ctx, up->u, &up->passes);
}

/* The pass in flight as pipeline_trace left it (render.c's wave_progress_print for one
 * device), handed on unless it was less than UNIT_FLIGHT_SECONDS ago. */
static void unit_flight(unit_passes *up, const ts_pipeline *p)
{
    if (stats_now() - up->handed < UNIT_FLIGHT_SECONDS) return;
    waves_flight(p, up->t0, up->dicing, up->mp, up->evictions, &up->passes.flight);
    unit_passes_hand(up);
}

/* 1 when the unit w traces is merged from another device's copy, or the source closed (a
 * stop signal closes the board): pipeline.h cancel. Between its batches, the pass in flight
 * to the board (unit_flight). */
static int worker_unit_dropped(void *ctx)
{
    ts_worker *w = ctx;
    const ts_unit_source *src = &w->g->src;
    if (w->passes) unit_flight(w->passes, &w->pipe);
    return src->closed(src->ctx) || (src->dropped && src->dropped(src->ctx, w->cancel_unit));
}

/* waves_trace_paths' watch: the pass before ended, bounce begins (eta_passes_before). */
static int unit_pass_ended(void *ctx, ts_pipeline *p, uint32_t bounce, uint32_t rays, int after,
                           ts_error *err)
{
    (void)err;
    unit_passes *up = ctx;
    if (after) return TS_OK;
    waves_pass_begins(&up->passes, p, bounce, rays, up->t0, up->dicing);
    unit_passes_hand(up);
    return TS_OK;
}

/* Traces unit u in waves into r. *stopped: 1 the source closed between two waves, 2 another
 * device's copy of u was merged (the unit is not finished). */
static int worker_trace_unit(ts_worker *w, const ts_unit *u, ts_unit_result *r, int *stopped,
                             ts_error *err)
{
    ts_workers *g = w->g;
    ts_pipeline *p = &w->pipe;
    ts_camera_params cam = g->frame.cam;
    uint32_t per_wave = p->plan.ray_capacity / 2;
    uint64_t rays = w->stats.counters[TS_COUNTER_rays] + w->stats.counters[TS_COUNTER_shadow_rays];
    uint64_t evictions = w->stats.counters[TS_COUNTER_patch_cache_evictions];
    double dicing = stats_dicing_seconds(&w->stats);
    unit_passes up = {.w = w, .u = u};
    *stopped = 0;
    for (uint64_t first = u->first; first < u->first + u->count; first += per_wave) {
        if (g->src.closed(g->src.ctx)) return *stopped = 1, TS_OK;
        if (g->src.dropped && g->src.dropped(g->src.ctx, u)) return *stopped = 2, TS_OK;
        uint64_t left = u->first + u->count - first;
        uint32_t n = (uint32_t)(left < per_wave ? left : per_wave);
        cam.first_sample = (uint32_t)first;
        cam.ray_count = n;
        /* A copy of u may be merged from another device meanwhile (a backup, units.h), or a
         * stop signal may close the board: the wave then ends after the trace iteration or
         * the batch it is in. */
        w->cancel_unit = u;
        p->cancel = worker_unit_dropped, p->cancel_ctx = w;
        p->cancelled = 0;
        up.passes = (ts_eta_passes){.depth = (uint32_t)g->frame.opt->depth};
        up.t0 = stats_now(), up.dicing = stats_dicing_seconds(&w->stats);
        up.mp = w->stats.counters[TS_COUNTER_micropolygons_created];
        up.evictions = w->stats.counters[TS_COUNTER_patch_cache_evictions];
        w->passes = &up;
        int rc = pipeline_camera(p, &cam, err) ||
                 waves_trace_paths_watched(g->frame.opt, p, &cam, unit_pass_ended, &up, err);
        p->cancel = NULL, w->passes = NULL;
        if (rc) return err->code;
        if (p->cancelled) return *stopped = g->src.closed(g->src.ctx) ? 1 : 2, TS_OK;
        /* the wave's last pass ended */
        eta_passes_add(&up.passes, stats_now() - up.t0,
                       stats_dicing_seconds(&w->stats) - up.dicing);
        unit_passes_hand(&up);
        if (worker_read_wave(w, u, first, n, r, err)) return err->code;
        for (long ms = 0; ms < w->slow_ms; ms += 10) { /* the test aid, ended by a drop */
            if (g->src.dropped && g->src.dropped(g->src.ctx, u)) return *stopped = 2, TS_OK;
            nanosleep(&(struct timespec){0, 10000000L}, NULL);
        }
    }
    r->rays = w->stats.counters[TS_COUNTER_rays] + w->stats.counters[TS_COUNTER_shadow_rays] - rays;
    /* what the progress line's estimate of squeezed units needs (eta.h eta_units_left) */
    r->dicing = stats_dicing_seconds(&w->stats) - dicing;
    r->passes = up.passes;
    r->evicted = w->stats.counters[TS_COUNTER_patch_cache_evictions] != evictions;
    return TS_OK;
}

/* Once w's pipeline has the frame's levels of detail and its arenas: shares built patches
 * through the store (when w computes like device 0), which may hold as many bytes as the
 * largest arenas of the sharing devices. */
static void worker_share(ts_worker *w)
{
    if (!w->shares || !w->g->sharing) return;
    w->pipe.share = &w->g->share;
    w->pipe.share_owner = w->slot;
    patch_share_allow(&w->g->share, pipeline_arena_bytes(&w->pipe.plan));
}

/* The bytes of the sharing devices' one allocation (g->place_verts and g->place_groups). */
static uint64_t placed_bytes(const ts_workers *g)
{
    return g->place_verts * sizeof(ts_vec4) + g->place_groups * TS_GROUP_BYTES;
}

/* Decides, once for the frame (g->lock held, w's pipeline with the frame's levels), whether
 * the sharing devices' arenas become one host allocation: when every sharing device is a CPU
 * device sharing host memory (PoCL's), the frame's patches fit the room each may grow its
 * arenas to, and TESSERA_SHARED_ARENAS is not "0". Then a patch one device dices lies where
 * the others read it: no copy into the store and out of it, no second arena to fault in. */
static void workers_place(ts_workers *g, ts_worker *w)
{
    g->placed = -1;
    const char *env = getenv("TESSERA_SHARED_ARENAS");
    if (!g->sharing || w->pipe.cache_off || (env && strcmp(env, "0") == 0)) return;
    for (uint32_t i = 0; i < g->count; ++i) /* CPU devices: their memory is the host's (an
                                             * integrated GPU's needs maps to be seen) */
        if (g->w[i].shares &&
            (!g->w[i].cl.info.host_unified || !(g->w[i].cl.info.type & CL_DEVICE_TYPE_CPU)))
            return;
    size_t n = g->frame.scene->patch_count ? g->frame.scene->patch_count : 1;
    g->place_vert = malloc(n * sizeof *g->place_vert);
    g->place_group = malloc(n * sizeof *g->place_group);
    g->place_lod = malloc(n);
    if (!g->place_vert || !g->place_group || !g->place_lod) return;
    pipeline_arena_places(&w->pipe, g->place_vert, g->place_group, g->place_lod, &g->place_verts,
                          &g->place_groups);
    uint64_t need = placed_bytes(g);
    for (uint32_t i = 0; i < g->count; ++i) {
        const ts_worker *o = &g->w[i];
        uint64_t room = (o->room_mb > o->mb ? o->room_mb : o->mb) << 20;
        if (o->shares && need > room) return;
    }
    if (g->place_verts > UINT32_MAX || g->place_groups > UINT32_MAX) return;
    g->arena_grid = ts_page_alloc((g->place_verts ? g->place_verts : 1) * sizeof(ts_vec4));
    g->arena_tree = ts_page_alloc((g->place_groups ? g->place_groups : 1) * sizeof(ts_box4));
    g->arena_tight = ts_page_alloc((g->place_groups ? g->place_groups : 1) * sizeof(ts_tight4));
    if (!g->arena_grid || !g->arena_tree || !g->arena_tight) return;
    patch_share_in_place(&g->share);
    g->placed = 1;
    if (g->frame.opt->quiet) return;
    char list[200] = "";
    for (uint32_t i = 0, used = 0; i < g->count && used < sizeof list; ++i)
        if (g->w[i].shares)
            used += (uint32_t)snprintf(list + used, sizeof list - used, "%s%d", used ? ", " : "",
                                       g->w[i].index);
    ts_print_line("tessera: devices %s share one patch arena of %.1f MB (each patch diced once, "
                  "where every device reads it)",
                  list, (double)need / (1 << 20));
}

/* Binds w's arenas to the sharing devices' allocation when the frame has one (deciding
 * first when no device has). 1: bound; 0: w keeps arenas of its own (and, when the others
 * are bound and w could not be, leaves the store: its blocks would not be where theirs are);
 * -1: w has no arenas left (pipeline_place_arenas), the error in *err. */
static int worker_place(ts_worker *w, ts_error *err)
{
    ts_workers *g = w->g;
    if (!w->shares || !g->sharing) return 0;
    pthread_mutex_lock(&g->lock);
    if (g->placed == 0) workers_place(g, w);
    int placed = g->placed > 0;
    pthread_mutex_unlock(&g->lock);
    if (!placed) return 0;
    ts_error e = {0};
    if (!pipeline_place_arenas(&w->pipe, g->arena_grid, g->arena_tree, g->arena_tight,
                               g->place_verts, g->place_groups, g->place_vert, g->place_group,
                               g->place_lod, &e))
        return 1;
    if (!w->pipe.grid) {
        ts_error_set_status(err, e.code, e.status, "%s", e.msg);
        ts_error_clear(&e);
        return -1;
    }
    char name[300];
    if (!g->frame.opt->quiet)
        ts_print_line("tessera: note: %s dices its own patches (the shared arenas: %s)",
                      worker_name(w, name, sizeof name), e.msg);
    ts_error_clear(&e);
    w->shares = 0;
    return 0;
}

/* After memory ran out in a unit: the pipeline again at half the budget, with the frame's
 * levels of detail. */
static int worker_shrink(ts_worker *w, ts_error *err)
{
    char name[300];
    if (w->mb / 2 < TS_MEMORY_FLOOR_MB) return err->code;
    if (!w->g->frame.opt->quiet)
        ts_print_line("tessera: %s could not provide %llu MB (%s); retrying with %llu MB",
                      worker_name(w, name, sizeof name), (unsigned long long)w->mb, err->msg,
                      (unsigned long long)(w->mb / 2));
    ts_error_clear(err);
    w->out.share_wait_seconds += w->pipe.share_wait_seconds;
    pipeline_destroy(&w->pipe);
    w->has_pipe = 0;
    w->mb /= 2;
    w->room_mb = 0; /* memory ran out: the arenas stay within the smaller budget */
    int lod_failed;
    if (worker_pipeline(w, err) || worker_take_lod(w, &lod_failed, err)) return err->code;
    if (worker_place(w, err) < 0) return err->code;
    worker_share(w);
    return TS_OK;
}

/* Takes units until none is left: traces each and hands it back, or gives it back when
 * the source closed in the middle, another device's copy was merged first (a backup,
 * units.h) or the device failed. */
static int worker_units(ts_worker *w, ts_error *err)
{
    ts_unit_source *src = &w->g->src;
    ts_sample_order order = sample_order_of(&w->g->frame.cam);
    ts_unit u;
    while (src->take(src->ctx, (uint16_t)(w->slot + 1), &u)) {
        double t0 = stats_now();
        ts_unit_result r;
        int stopped = 0, rc = unit_result_alloc(&r, &u, &order, err);
        if (!rc) rc = worker_trace_unit(w, &u, &r, &stopped, err);
        w->out.backup_units += u.backup;
        if (rc || stopped) {
            unit_result_free(&r);
            src->give_back(src->ctx, &u);
            if (!rc && stopped == 2) { /* another device's copy is in the image */
                w->out.busy_seconds += stats_now() - t0;
                w->out.dropped_units++;
                continue;
            }
            if (stopped) return TS_OK;
            if (!(dev_is_out_of_memory(err) || err->code == TS_E_MEMORY) || worker_shrink(w, err))
                return err->code;
            continue;
        }
        w->out.busy_seconds += stats_now() - t0;
        if (src->done(src->ctx, &u, &r)) {
            w->out.units++;
            w->out.samples += u.count;
        } else {
            w->out.dropped_units++;
        }
    }
    return TS_OK;
}

/* 1 when w's frame's patches fit its arenas (grown by `extra` bytes) all at once. */
static int worker_fits(const ts_worker *w, uint64_t extra)
{
    return pipeline_arena_need_bytes(&w->pipe) <= pipeline_arena_bytes(&w->pipe.plan) + extra;
}

/* Once the frame's levels of detail are known: when its patches will not fit w's arenas even
 * grown to w's room, each unit is a wave of its own that dices the scene again, and the plan's
 * rays (two a sample of a unit) left three quarters of the budget unused. The waves then take
 * what the budget holds for w's share of the frame, as one device's render would (rays for
 * it, and p->frame_rays, by which budget_grow_arenas may thin the arenas for fewer waves);
 * worker_regather makes the units as large (on rank 0; another MPI rank's devices trace the
 * units rank 0's board hands them, made large by rank 0's devices when they ask first). */
static int worker_squeeze(ts_worker *w, ts_error *err)
{
    ts_pipeline *p = &w->pipe;
    uint64_t room = w->room_mb > w->mb ? (w->room_mb - w->mb) << 20 : 0;
    uint64_t share = w->g->frame.share_samples;
    if (share <= w->g->frame.unit_samples || worker_fits(w, room)) return TS_OK;
    ts_pipeline_plan plan;
    if (pipeline_plan(w->mb << 20, 2 * share, p->plan.max_lod, w->cl.info.max_alloc, &plan, err))
        return err->code;
    p->frame_rays = 2 * share;
    uint32_t had = p->plan.ray_capacity;
    if (plan.ray_capacity <= had || !pipeline_resize_rays(p, plan.ray_capacity, err)) return TS_OK;
    if (!(dev_is_out_of_memory(err) || err->code == TS_E_MEMORY)) return err->code;
    ts_error_clear(err); /* the device could not: the waves it had */
    return pipeline_resize_rays(p, had, err);
}

/* Once w is set up (or has failed, `skip`): when its frame's patches still do not fit its
 * arenas, the board's units are made as large as a wave of w's (and no larger than a device's
 * share of the frame), before any is handed out (board_regather; the first device to ask
 * decides). Every device asks, so that a board that waits for its devices' word before it
 * hands units to other MPI ranks hears it. */
static void worker_regather(ts_worker *w, int skip)
{
    const ts_unit_source *src = &w->g->src;
    if (!src->regather) return;
    uint64_t wave = w->pipe.plan.ray_capacity / 2, share = w->g->frame.share_samples;
    uint64_t samples = wave < share ? wave : share; /* units_list keeps whole pixels */
    if (skip || worker_fits(w, 0) || samples <= w->g->frame.unit_samples) samples = 0;
    if (src->regather(src->ctx, samples) && !w->g->frame.opt->quiet)
        ts_print_line("tessera: the frame's patches do not fit: units of %llu samples instead "
                      "of %llu, each a wave that dices them again",
                      (unsigned long long)samples, (unsigned long long)w->g->frame.unit_samples);
}

static void *worker_main(void *arg)
{
    ts_worker *w = arg;
    ts_workers *g = w->g;
    double t0 = stats_now();
    int lod_failed = 0, makes_lod = w->slot == 0 && g->makes_lod;
    int rc = worker_pipeline(w, &w->err);
    if (w->lod_part > 0) worker_count_lod_part(w, rc == TS_OK, &w->err);
    if (w->lod_part > 0 && w->err.code) rc = w->err.code;
    if (makes_lod && rc) /* device 0's failure is the frame's: the lod is its */
        lod_publish(g, 0, NULL, &w->err), lod_failed = 1;
    else if (makes_lod)
        lod_failed = (rc = worker_make_lod(w, &w->err)) != TS_OK;
    else if (!rc)
        rc = worker_take_lod(w, &lod_failed, &w->err);
    int placed = rc ? 0 : worker_place(w, &w->err);
    if (placed < 0)
        rc = w->err.code;
    else if (!rc && !placed) /* the frame's patches, once each, if they fit */
        rc = worker_squeeze(w, &w->err) ||
             budget_grow_arenas(&w->pipe, w->room_mb, 1, g->frame.opt->quiet, &w->err);
    worker_regather(w, rc || placed); /* whatever the set-up gave: it opens the board */
    if (!rc) worker_share(w);
    pthread_mutex_lock(&g->lock);
    g->set_up++;
    pthread_mutex_unlock(&g->lock);
    w->out.setup_seconds = stats_now() - t0;
    if (!rc) rc = worker_units(w, &w->err);
    w->out.frame_seconds = stats_now() - t0;
    pthread_mutex_lock(&g->lock);
    if (rc) { /* a failed lod is reported once, as the render's error */
        w->failed = !lod_failed;
        w->reported = lod_failed;
        g->alive--;
    }
    g->running--;
    pthread_mutex_unlock(&g->lock);
    return NULL;
}

/* Splits the lod pass over device 0 and the devices that compute like it (they count the
 * same crossings), when device 0 makes the lod by the crossed rule and the frame has no
 * fixed --lod; else (or without memory for the sums) device 0 counts every pixel. */
static void workers_lod_split(ts_workers *g)
{
    ts_lod_rule rule;
    ts_error e = {0};
    g->lod_parts = 1;
    for (uint32_t i = 0; i < g->count; ++i)
        g->w[i].lod_part = i == 0 ? 0 : -1;
    if (!g->makes_lod || g->frame.opt->fixed_lod >= 0 || waves_lod_rule(&rule, &e) ||
        rule != TS_LOD_RULE_CROSSED)
        return;
    uint32_t parts = 1;
    for (uint32_t i = 1; i < g->count; ++i)
        parts += devices_alike(&g->w[0].cl.info, &g->w[i].cl.info) ? 1u : 0u;
    if (parts < 2) return;
    uint32_t n = g->frame.scene->patch_count;
    g->lod_more = calloc(n ? n : 1u, sizeof *g->lod_more);
    g->lod_part = calloc(parts, 1);
    if (!g->lod_more || !g->lod_part) {
        free(g->lod_more), free(g->lod_part);
        g->lod_more = NULL, g->lod_part = NULL;
        return;
    }
    g->lod_parts = parts;
    for (uint32_t i = 1, k = 1; i < g->count; ++i)
        if (devices_alike(&g->w[0].cl.info, &g->w[i].cl.info)) g->w[i].lod_part = (int)k++;
}

int workers_start(ts_workers *g, ts_unit_source src, int makes_lod, ts_error *err)
{
    g->src = src;
    g->makes_lod = makes_lod;
    workers_lod_split(g);
    g->alive = g->running = g->count;
    for (uint32_t i = 0; i < g->count; ++i) {
        ts_worker *w = &g->w[i];
        w->slow_ms = waves_slow_ms(w->index);
        if (pthread_create(&w->thread, NULL, worker_main, w) != 0) {
            pthread_mutex_lock(&g->lock);
            g->alive -= g->count - i;
            g->running -= g->count - i;
            for (uint32_t j = i; j < g->count; ++j) /* their lod parts: device 0 counts them */
                if (g->w[j].lod_part > 0) g->lod_part[g->w[j].lod_part] = -1;
            pthread_cond_broadcast(&g->lod_cond);
            pthread_mutex_unlock(&g->lock);
            if (i == 0 && makes_lod) lod_publish(g, 0, NULL, NULL);
            return ts_error_set(err, TS_E_MEMORY, "cannot start a thread for device %d", w->index);
        }
        w->started = 1;
    }
    g->started = 1;
    return TS_OK;
}

void workers_lod_set(ts_workers *g, uint32_t max_lod, const uint8_t *patch_lod)
{
    lod_publish(g, max_lod, patch_lod, NULL);
}

int workers_lod_wait(ts_workers *g, uint32_t *max_lod, const uint8_t **patch_lod)
{
    pthread_mutex_lock(&g->lock);
    while (g->lod_state == 0)
        pthread_cond_wait(&g->lod_cond, &g->lock);
    int ok = g->lod_state > 0;
    *max_lod = g->max_lod;
    *patch_lod = g->patch_lod;
    pthread_mutex_unlock(&g->lock);
    return ok;
}

uint32_t workers_alive(ts_workers *g)
{
    pthread_mutex_lock(&g->lock);
    uint32_t n = g->alive;
    pthread_mutex_unlock(&g->lock);
    return n;
}

uint32_t workers_running(ts_workers *g)
{
    pthread_mutex_lock(&g->lock);
    uint32_t n = g->running;
    pthread_mutex_unlock(&g->lock);
    return n;
}

int workers_lod_state(ts_workers *g)
{
    pthread_mutex_lock(&g->lock);
    int state = g->lod_state;
    pthread_mutex_unlock(&g->lock);
    return state;
}

void workers_report(ts_workers *g, ts_error *last)
{
    char name[300];
    pthread_mutex_lock(&g->lock);
    for (uint32_t i = 0; i < g->count; ++i) {
        ts_worker *w = &g->w[i];
        if (!w->failed || w->reported) continue;
        w->reported = 1;
        if (!g->frame.opt->quiet) {
            fputc('\n', stderr); /* end the progress line */
            ts_print_line("tessera: warning: %s stopped: %s; the other devices go on",
                          worker_name(w, name, sizeof name), w->err.msg);
        }
        if (last) {
            ts_error_clear(last);
            ts_error_set_status(last, w->err.code, w->err.status, "%s", w->err.msg);
        }
    }
    pthread_mutex_unlock(&g->lock);
}

void workers_join(ts_workers *g)
{
    for (uint32_t i = 0; i < g->count; ++i)
        if (g->w[i].started) pthread_join(g->w[i].thread, NULL), g->w[i].started = 0;
}

int workers_stats(ts_workers *g, ts_stats *stats, ts_error *err)
{
    for (uint32_t i = 0; i < g->count; ++i) {
        ts_worker *w = &g->w[i];
        w->stats.kernel_build_seconds = w->cl.build_seconds;
        w->out.kernel_seconds = stats_kernel_seconds(&w->stats);
        if (stats_merge(stats, &w->stats, err)) return err->code;
        stats->kernel_cache_hit = (i == 0 || stats->kernel_cache_hit) && w->cl.cache_hit;
        stats->memory_budget_bytes += w->stats.memory_budget_bytes;
        ts_device_stats *d = &w->out;
        snprintf(d->name, sizeof d->name, "%.120s (%.120s)", w->cl.info.name,
                 w->cl.info.platform_name);
        d->index = w->index;
        d->rank = g->frame.rank;
        d->compute_units = w->cl.info.compute_units;
        d->rays = w->stats.counters[TS_COUNTER_rays] + w->stats.counters[TS_COUNTER_shadow_rays];
        d->memory_budget_bytes = w->stats.memory_budget_bytes;
        d->device_bytes_peak = w->stats.counters[TS_COUNTER_device_bytes_peak];
        d->patches_diced = w->stats.counters[TS_COUNTER_patches_diced];
        d->patches_shared = w->stats.counters[TS_COUNTER_patches_shared];
        if (w->has_pipe) d->share_wait_seconds += w->pipe.share_wait_seconds;
        w->pipe.share_wait_seconds = 0;
        memcpy(d->stage_seconds, w->stats.stage_seconds, sizeof d->stage_seconds);
        d->failed = w->failed;
        if (w->failed) snprintf(d->error, sizeof d->error, "%.500s", w->err.msg);
        if (stats_add_device(stats, d, err)) return err->code;
        size_t used = strlen(stats->device);
        snprintf(stats->device + used, sizeof stats->device - used, "%s%s", used ? " + " : "",
                 w->cl.info.name);
    }
    if (g->placed > 0) { /* one allocation for the sharing devices, not one each: its bytes,
                          * and those of the patches any of them placed in it */
        uint64_t bytes = placed_bytes(g), peak = 0;
        for (uint32_t i = 0; i < g->count; ++i)
            if (!g->w[i].shares) {
                bytes += g->w[i].stats.counters[TS_COUNTER_patch_cache_bytes];
                peak += g->w[i].stats.counters[TS_COUNTER_patch_cache_peak_bytes];
            }
        for (uint32_t q = 0; q < g->frame.scene->patch_count; ++q)
            for (uint32_t i = 0; i < g->count; ++i) {
                const ts_worker *o = &g->w[i];
                if (!o->has_pipe || !o->shares || !o->pipe.cache.entry[q].resident) continue;
                peak += (uint64_t)o->pipe.cache.entry[q].vert_count * sizeof(ts_vec4) +
                        (uint64_t)o->pipe.cache.entry[q].group_count * TS_GROUP_BYTES;
                break;
            }
        stats->counters[TS_COUNTER_patch_cache_bytes] = bytes;
        stats->counters[TS_COUNTER_patch_cache_peak_bytes] = peak;
    }
    return TS_OK;
}

void workers_close(ts_workers *g)
{
    if (!g->w) return;
    workers_join(g);
    for (uint32_t i = 0; i < g->count; ++i) {
        ts_worker *w = &g->w[i];
        if (w->has_pipe) pipeline_destroy(&w->pipe);
        free(w->aov_wave);
        dev_close(&w->cl);
        stats_free(&w->stats);
        ts_error_clear(&w->err);
    }
    free(g->w);
    if (g->sharing) patch_share_free(&g->share);
    free(g->arena_grid), free(g->arena_tree), free(g->arena_tight); /* after every pipeline */
    free(g->place_vert), free(g->place_group), free(g->place_lod);
    free(g->patch_lod);
    free(g->lod_more);
    free(g->lod_part);
    free(g->pixel_cost);
    ts_error_clear(&g->fatal);
    pthread_mutex_destroy(&g->lock);
    pthread_cond_destroy(&g->lod_cond);
    memset(g, 0, sizeof *g);
}

/* The job's record of the samples the films hold, from the board. */
static int job_from_board(ts_job *job, ts_board *b, ts_error *err)
{
    done_free(&job->done);
    if (board_held(b, &job->done, err)) return err->code;
    job->samples_done = done_samples(&job->done);
    if (done_is_prefix(&job->done)) done_free(&job->done);
    return TS_OK;
}

/* The progress line: samples of the units finished (merged or not), the share of the
 * frame's weight they hold (eta.h, once the levels and the pixels' weights are made) with the
 * units out credited for the time they have run (for the share of their expected time where
 * eta_units_left estimates the time left, else board_work_in_flight), rays per second, and
 * the time left at the weight per second so far; printed at most every second, from when every
 * device is set up (its notes printed) or a unit is finished. */
typedef struct frame_progress_state {
    ts_eta eta;
    int weighed; /* eta holds the pixels' weights (else samples weigh 1) */
    double t0;
    double shown; /* the weight done the line last showed: it shows no less */
} frame_progress_state;

static int frame_progress(ts_workers *g, ts_board *b, frame_progress_state *st, int lod_state,
                          int set_up)
{
    if (!st->weighed && lod_state > 0) { /* g->pixel_cost is final once the levels are */
        ts_error e = {0};
        eta_free(&st->eta);
        st->weighed = !eta_init(&st->eta, g->pixel_cost, g->frame.cam.width * g->frame.cam.height,
                                (uint32_t)g->frame.opt->spp, g->frame.cam.band, &e);
    }
    uint64_t finished, rays;
    board_progress(b, &finished, &rays);
    if (finished == 0 && !set_up && !board_finished(b)) return 0; /* devices print notes */
    /* nothing merged: no credit either, so done is 0 and the ETA waits for the first unit */
    double now = stats_now();
    double done = board_work_finished(b, &st->eta);
    /* units that dice again (the frame's patches do not fit): as eta_units_left models them,
     * and the units out credited for the share of their expected time they have run */
    pthread_mutex_lock(&g->lock);
    uint32_t failed = (uint32_t)(g->count - g->alive), all = g->frame.devices_all;
    pthread_mutex_unlock(&g->lock);
    all = all > (uint32_t)g->count ? all : (uint32_t)g->count;
    double credit = 0.0;
    double left =
        st->weighed ? board_units_left(b, &st->eta, now, all > failed ? all - failed : 1u, &credit)
                    : -1.0;
    done += left >= 0.0 ? credit : board_work_in_flight(b, &st->eta, now);
    if (done < st->shown) done = st->shown;
    st->shown = done;
    if (left >= 0.0)
        eta_print_left(&st->eta, b->start + finished, b->start, b->total, done, (double)rays,
                       now - st->t0, left, "unit");
    else if (left == TS_ETA_UNITS_EYE_RAYS)
        eta_print_tail(&st->eta, b->start + finished, b->start, b->total, done, (double)rays,
                       now - st->t0, "ETA after eye rays");
    else
        eta_print(&st->eta, b->start + finished, b->start, b->total, done, (double)rays,
                  now - st->t0, "unit");
    return 1;
}

/* Waits for the frame: until every unit is merged, a stop signal closes the board, the lod
 * fails (the render's error), or no device is left (end->all_failed). */
static int frame_wait(ts_workers *g, ts_board *b, const ts_frame_service *service,
                      ts_frame_end *end, ts_error *err)
{
    const ts_frame *f = &g->frame;
    double printed = 0;
    frame_progress_state st = {{0}, 0, stats_now(), 0.0};
    ts_error weights_err = {0};
    int shown = 0, rc = TS_OK, lod_state = 0, set_up = 0;
    eta_init(&st.eta, NULL, 0, 1, 0, &weights_err); /* samples weigh 1 until the levels */
    uint64_t seen = board_changes(b);
    while (!board_finished(b)) {
        if (interrupt_signal()) {
            board_freeze(b);
            if (job_from_board(f->job, b, err)) {
                rc = err->code;
                break;
            }
            if (service && service->on_stop)
                service->on_stop(service->stop_ctx, board_samples_done(b));
            break;
        }
        workers_report(g, &end->failure);
        pthread_mutex_lock(&g->lock);
        lod_state = g->lod_state;
        set_up = g->set_up == g->count;
        pthread_mutex_unlock(&g->lock);
        if (lod_state < 0) {
            rc = ts_error_set_status(err, g->fatal.code, g->fatal.status, "%s", g->fatal.msg);
            break;
        }
        int elsewhere = service && service->poll ? service->poll(service->ctx, b, g, err) : 0;
        if (elsewhere < 0) {
            rc = err->code;
            break;
        }
        if (workers_alive(g) == 0 && elsewhere == 0) {
            end->all_failed = 1;
            break;
        }
        if (service && service->progress) service->progress(service->progress_ctx, b, g);
        if (!f->opt->quiet && !ferror(stderr) && stats_now() - printed >= 1.0) {
            shown |= frame_progress(g, b, &st, lod_state, set_up);
            printed = stats_now();
        }
        board_wait(b, service && service->poll ? service->interval : 0.25, seen);
        seen = board_changes(b);
    }
    /* One more poll once the frame is merged: a frame this process's devices finished
     * before any poll saw its levels of detail (a short --resume) must still send them to
     * the other ranks, which wait for them before they ask for units. */
    if (rc == TS_OK && board_finished(b) && service && service->poll &&
        service->poll(service->ctx, b, g, err) < 0)
        rc = err->code;
    board_close(b);
    workers_join(g);
    workers_report(g, &end->failure);
    if (!f->opt->quiet && !ferror(stderr) && frame_progress(g, b, &st, lod_state, set_up))
        fputc('\n', stderr);
    eta_free(&st.eta);
    return rc;
}

int workers_render(const ts_frame *frame, ts_film_state *film, const int *indices, int count,
                   const ts_frame_service *service, ts_stats *stats, ts_frame_end *end,
                   ts_error *err)
{
    memset(end, 0, sizeof *end);
    ts_job *job = frame->job;
    ts_workers g;
    ts_board b;
    memset(&b, 0, sizeof b);
    ts_sample_order order = sample_order_of(&frame->cam);
    ts_done held = {0};
    int rc = workers_open(&g, frame, indices, count, err);
    if (!rc)
        rc = job_held(job, &held, err) ||
             board_init(&b, film, &order, job->total, frame->unit_samples, &held, err);
    done_free(&held);
    if (!rc && service && service->poll) board_gate(&b); /* other ranks: after our devices' word */
    if (!rc) rc = workers_start(&g, board_source(&b), 1, err);
    if (!rc) rc = frame_wait(&g, &b, service, end, err);
    if (rc && b.state) board_close(&b); /* threads started before a failure end */
    if (rc && g.w && workers_lod_state(&g) == 0) lod_publish(&g, 0, NULL, NULL);
    workers_join(&g);
    if (b.state) {
        end->samples_done = board_samples_done(&b);
        if (!rc) rc = job_from_board(job, &b, err);
        stats->stage_seconds[TS_STAGE_film] += b.merge_seconds;
    }
    stats->unit_samples = b.state ? b.gather : frame->unit_samples; /* board_regather's */
    if (!rc) rc = workers_stats(&g, stats, err);
    board_free(&b);
    workers_close(&g);
    return rc;
}
