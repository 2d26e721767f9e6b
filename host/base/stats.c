#include "base/stats.h"
#include "base/file.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

const char *const ts_stage_names[TS_STAGE_COUNT] = {
#define TS_STAGE_NAME(name, what) #name,
    TS_STAGES(TS_STAGE_NAME)
#undef TS_STAGE_NAME
};
const char *const ts_stage_descriptions[TS_STAGE_COUNT] = {
#define TS_STAGE_WHAT(name, what) what,
    TS_STAGES(TS_STAGE_WHAT)
#undef TS_STAGE_WHAT
};
const char *const ts_counter_names[TS_COUNTER_COUNT] = {
#define TS_COUNTER_NAME(name, what) #name,
    TS_COUNTERS(TS_COUNTER_NAME)
#undef TS_COUNTER_NAME
};

double stats_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int stats_add_iteration(ts_stats *s, const ts_iteration *it, ts_error *err)
{
    if (s->iteration_count == s->iteration_capacity) {
        uint32_t cap = s->iteration_capacity ? 2 * s->iteration_capacity : 64;
        ts_iteration *p = realloc(s->iterations, cap * sizeof *p);
        if (!p) return ts_error_set(err, TS_E_MEMORY, "out of memory (iteration log)");
        s->iterations = p;
        s->iteration_capacity = cap;
    }
    s->iterations[s->iteration_count++] = *it;
    return TS_OK;
}

int stats_add_busy(ts_stats *s, double start, double end, ts_error *err)
{
    if (end < start) end = start;
    if (s->busy_count > 0) {
        ts_busy_span *last = &s->busy[s->busy_count - 1];
        if (start <= last->end && start >= last->start) {
            if (end > last->end) last->end = end;
            return TS_OK;
        }
    }
    if (s->busy_count == s->busy_capacity) {
        uint32_t cap = s->busy_capacity ? 2 * s->busy_capacity : 256;
        ts_busy_span *p = realloc(s->busy, cap * sizeof *p);
        if (!p) return ts_error_set(err, TS_E_MEMORY, "out of memory (kernel spans)");
        s->busy = p;
        s->busy_capacity = cap;
    }
    s->busy[s->busy_count++] = (ts_busy_span){start, end};
    return TS_OK;
}

static int busy_by_start(const void *a, const void *b)
{
    double x = ((const ts_busy_span *)a)->start, y = ((const ts_busy_span *)b)->start;
    return (x > y) - (x < y);
}

double stats_dicing_seconds(const ts_stats *s)
{
    return s->stage_seconds[TS_STAGE_dice] + s->stage_seconds[TS_STAGE_build];
}

double stats_kernel_seconds(const ts_stats *s)
{
    if (s->busy_count == 0) return 0.0;
    ts_busy_span *v = malloc(s->busy_count * sizeof *v);
    if (!v) return 0.0;
    memcpy(v, s->busy, s->busy_count * sizeof *v);
    qsort(v, s->busy_count, sizeof *v, busy_by_start);
    double total = 0.0, start = v[0].start, end = v[0].end;
    for (uint32_t i = 1; i < s->busy_count; ++i) {
        if (v[i].start > end) {
            total += end - start;
            start = v[i].start;
        }
        if (v[i].end > end) end = v[i].end;
    }
    total += end - start;
    free(v);
    return total;
}

double stats_host_serial(double wall, double kernel)
{
    return wall > kernel ? wall - kernel : 0.0;
}

int stats_add_device(ts_stats *s, const ts_device_stats *d, ts_error *err)
{
    ts_device_stats *p = realloc(s->devices, (s->device_count + 1) * sizeof *p);
    if (!p) return ts_error_set(err, TS_E_MEMORY, "out of memory (device stats)");
    s->devices = p;
    s->devices[s->device_count++] = *d;
    return TS_OK;
}

int stats_add_rank(ts_stats *s, const ts_rank_stats *r, ts_error *err)
{
    ts_rank_stats *p = realloc(s->ranks, (s->rank_count + 1) * sizeof *p);
    if (!p) return ts_error_set(err, TS_E_MEMORY, "out of memory (rank stats)");
    s->ranks = p;
    s->ranks[s->rank_count++] = *r;
    return TS_OK;
}

int stats_merge(ts_stats *s, const ts_stats *d, ts_error *err)
{
    for (int i = 0; i < TS_STAGE_COUNT; ++i)
        s->stage_seconds[i] += d->stage_seconds[i];
    for (int i = 0; i < TS_COUNTER_COUNT; ++i) {
        /* Properties of the scene, the same on every device; the rest adds up. */
        if (i == TS_COUNTER_micropolygons_potential || i == TS_COUNTER_texture_tiles ||
            i == TS_COUNTER_patch_cache_need_bytes)
            s->counters[i] = d->counters[i] > s->counters[i] ? d->counters[i] : s->counters[i];
        else
            s->counters[i] += d->counters[i];
    }
    for (int m = 0; m <= TS_LOD_LIMIT; ++m) {
        s->lod_histogram[m] += d->lod_histogram[m];
        /* the frame's, the same on every device that traced it */
        if (d->frame_lod_histogram[m] > s->frame_lod_histogram[m])
            s->frame_lod_histogram[m] = d->frame_lod_histogram[m];
    }
    s->kernel_build_seconds += d->kernel_build_seconds;
    for (uint32_t i = 0; i < d->iteration_count; ++i)
        if (stats_add_iteration(s, &d->iterations[i], err)) return err->code;
    for (uint32_t i = 0; i < d->busy_count; ++i)
        if (stats_add_busy(s, d->busy[i].start, d->busy[i].end, err)) return err->code;
    return TS_OK;
}

uint64_t stats_peak_rss_bytes(void)
{
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) != 0) return 0;
    return (uint64_t)ru.ru_maxrss * 1024u; /* Linux reports kilobytes */
}

static cJSON *stages_json(const double seconds[TS_STAGE_COUNT])
{
    cJSON *stages = cJSON_CreateObject();
    for (int i = 0; i < TS_STAGE_COUNT; ++i)
        cJSON_AddNumberToObject(stages, ts_stage_names[i], seconds[i]);
    return stages;
}

/* "devices" and "ranks" of a render on several (DESIGN.md §4, docs/profiling.md). */
static void stats_devices_json(cJSON *root, const ts_stats *s)
{
    if (s->device_count) {
        cJSON_AddNumberToObject(root, "unit_samples", (double)s->unit_samples);
        cJSON *devs = cJSON_AddArrayToObject(root, "devices");
        for (uint32_t i = 0; i < s->device_count; ++i) {
            const ts_device_stats *d = &s->devices[i];
            cJSON *o = cJSON_CreateObject();
            cJSON_AddStringToObject(o, "name", d->name);
            cJSON_AddNumberToObject(o, "index", d->index);
            cJSON_AddNumberToObject(o, "rank", d->rank);
            cJSON_AddNumberToObject(o, "compute_units", d->compute_units);
            cJSON_AddNumberToObject(o, "units", (double)d->units);
            cJSON_AddNumberToObject(o, "samples", (double)d->samples);
            cJSON_AddNumberToObject(o, "rays", (double)d->rays);
            cJSON_AddNumberToObject(o, "backup_units", (double)d->backup_units);
            cJSON_AddNumberToObject(o, "dropped_units", (double)d->dropped_units);
            cJSON_AddItemToObject(o, "stages", stages_json(d->stage_seconds));
            cJSON_AddNumberToObject(o, "kernel_seconds", d->kernel_seconds);
            cJSON_AddNumberToObject(o, "setup_seconds", d->setup_seconds);
            cJSON_AddNumberToObject(o, "busy_seconds", d->busy_seconds);
            cJSON_AddNumberToObject(o, "frame_seconds", d->frame_seconds);
            cJSON_AddNumberToObject(o, "busy_fraction",
                                    d->frame_seconds > 0 ? d->busy_seconds / d->frame_seconds : 0);
            cJSON_AddNumberToObject(o, "memory_budget_bytes", (double)d->memory_budget_bytes);
            cJSON_AddNumberToObject(o, "device_bytes_peak", (double)d->device_bytes_peak);
            cJSON_AddNumberToObject(o, "patches_diced", (double)d->patches_diced);
            cJSON_AddNumberToObject(o, "patches_shared", (double)d->patches_shared);
            cJSON_AddNumberToObject(o, "share_wait_seconds", d->share_wait_seconds);
            cJSON_AddBoolToObject(o, "failed", d->failed);
            if (d->failed) cJSON_AddStringToObject(o, "error", d->error);
            cJSON_AddItemToArray(devs, o);
        }
    }
    if (s->rank_count) {
        cJSON *ranks = cJSON_AddArrayToObject(root, "ranks");
        for (uint32_t i = 0; i < s->rank_count; ++i) {
            const ts_rank_stats *r = &s->ranks[i];
            cJSON *o = cJSON_CreateObject();
            cJSON_AddNumberToObject(o, "rank", r->rank);
            cJSON_AddStringToObject(o, "host", r->host);
            cJSON_AddNumberToObject(o, "devices", r->devices);
            cJSON_AddNumberToObject(o, "units", (double)r->units);
            cJSON_AddNumberToObject(o, "samples", (double)r->samples);
            cJSON_AddNumberToObject(o, "seconds", r->seconds);
            cJSON_AddNumberToObject(o, "scene_seconds", r->scene_seconds);
            cJSON_AddNumberToObject(o, "kernel_seconds", r->kernel_seconds);
            cJSON_AddNumberToObject(o, "host_serial_seconds", r->host_serial_seconds);
            if (r->error[0]) cJSON_AddStringToObject(o, "error", r->error);
            cJSON_AddItemToArray(ranks, o);
        }
    }
}

static cJSON *stats_to_json(const ts_stats *s)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "device", s->device);
    cJSON_AddNumberToObject(root, "wall_seconds", s->wall_seconds);
    double kernel = stats_kernel_seconds(s);
    cJSON_AddNumberToObject(root, "kernel_seconds", kernel);
    cJSON_AddNumberToObject(root, "host_serial_seconds",
                            stats_host_serial(s->wall_seconds, kernel));
    cJSON_AddNumberToObject(root, "peak_rss_bytes", (double)stats_peak_rss_bytes());
    cJSON_AddNumberToObject(root, "kernel_build_seconds", s->kernel_build_seconds);
    cJSON_AddBoolToObject(root, "kernel_cache_hit", s->kernel_cache_hit);
    cJSON_AddNumberToObject(root, "memory_budget_bytes", (double)s->memory_budget_bytes);
    cJSON_AddItemToObject(root, "stages", stages_json(s->stage_seconds));
    cJSON *counters = cJSON_AddObjectToObject(root, "counters");
    for (int i = 0; i < TS_COUNTER_COUNT; ++i)
        cJSON_AddNumberToObject(counters, ts_counter_names[i], (double)s->counters[i]);
    cJSON_AddNumberToObject(root, "leaf_utilisation",
                            s->counters[TS_COUNTER_leaf_slots]
                                ? (double)s->counters[TS_COUNTER_leaf_tests] /
                                      (double)s->counters[TS_COUNTER_leaf_slots]
                                : 0.0);
    if (s->counters[TS_COUNTER_bake_points]) {
        /* points and rays per second over the waves' wall time (dicing included) */
        double points = (double)s->counters[TS_COUNTER_bake_points];
        double rays = (double)s->counters[TS_COUNTER_rays], t = s->bake.seconds;
        cJSON *bake = cJSON_AddObjectToObject(root, "bake");
        cJSON_AddNumberToObject(bake, "points", points);
        cJSON_AddNumberToObject(bake, "rays", rays);
        cJSON_AddNumberToObject(bake, "rays_per_point", s->bake.rays_per_point);
        cJSON_AddNumberToObject(bake, "bands", s->bake.bands);
        cJSON_AddNumberToObject(bake, "seconds", t);
        cJSON_AddNumberToObject(bake, "points_per_second", t > 0 ? points / t : 0.0);
        cJSON_AddNumberToObject(bake, "rays_per_second", t > 0 ? rays / t : 0.0);
    }
    cJSON *hist = cJSON_AddArrayToObject(root, "lod_histogram");
    for (int m = 0; m <= TS_LOD_LIMIT; ++m)
        cJSON_AddItemToArray(hist, cJSON_CreateNumber((double)s->lod_histogram[m]));
    cJSON *frame = cJSON_AddArrayToObject(root, "frame_lod_histogram");
    for (int m = 0; m <= TS_LOD_LIMIT; ++m)
        cJSON_AddItemToArray(frame, cJSON_CreateNumber((double)s->frame_lod_histogram[m]));
    cJSON *its = cJSON_AddArrayToObject(root, "iterations");
    for (uint32_t i = 0; i < s->iteration_count; ++i) {
        const ts_iteration *it = &s->iterations[i];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddNumberToObject(o, "wave", it->wave);
        cJSON_AddNumberToObject(o, "iteration", it->iteration);
        cJSON_AddNumberToObject(o, "active_rays", (double)it->active_rays);
        cJSON_AddNumberToObject(o, "n_per_ray", it->n_per_ray);
        cJSON_AddNumberToObject(o, "pairs", (double)it->pairs);
        cJSON_AddNumberToObject(o, "segments", it->segments);
        if (it->lod) cJSON_AddBoolToObject(o, "lod", 1);
        cJSON_AddItemToArray(its, o);
    }
    stats_devices_json(root, s);
    return root;
}

int stats_write_json(const ts_stats *s, const char *path, ts_error *err)
{
    cJSON *root = stats_to_json(s);
    char *text = root ? cJSON_Print(root) : NULL;
    cJSON_Delete(root);
    if (!text) return ts_error_set(err, TS_E_MEMORY, "out of memory (stats JSON)");
    /* A hidden temporary beside the target, as images are written (base/file.h). */
    char tmp[8192];
    ts_error why = {0};
    int rc = ts_file_temp_create(path, tmp, sizeof tmp, &why);
    FILE *f = rc ? NULL : fopen(tmp, "wb");
    int ok = f && fputs(text, f) >= 0 && fputc('\n', f) != EOF;
    if (f && fclose(f) != 0) ok = 0;
    free(text);
    if (!rc && !ok) remove(tmp);
    if (ok) rc = ts_file_temp_commit(tmp, path, &why);
    ts_error_clear(&why);
    if (!ok || rc) return ts_error_set(err, TS_E_IO, "%s: cannot write stats", path);
    return TS_OK;
}

void stats_print_table(const ts_stats *s, void *file)
{
    FILE *f = file;
    double total = 0;
    for (int i = 0; i < TS_STAGE_COUNT; ++i)
        total += s->stage_seconds[i];
    fprintf(f, "%-14s %10s %7s\n", "stage", "seconds", "share");
    for (int i = 0; i < TS_STAGE_COUNT; ++i)
        fprintf(f, "%-14s %10.4f %6.1f%%\n", ts_stage_names[i], s->stage_seconds[i],
                total > 0 ? 100.0 * s->stage_seconds[i] / total : 0.0);
    fprintf(f, "%-14s %10.4f   (wall %.3f s, kernel build %.3f s%s)\n", "sum of stages", total,
            s->wall_seconds, s->kernel_build_seconds, s->kernel_cache_hit ? ", cached" : "");
    double kernel = stats_kernel_seconds(s);
    fprintf(f, "kernels ran %.3f s of the wall; the host alone %.3f s\n", kernel,
            stats_host_serial(s->wall_seconds, kernel));
    for (int i = 0; i < TS_COUNTER_COUNT; ++i)
        fprintf(f, "%-24s %llu\n", ts_counter_names[i], (unsigned long long)s->counters[i]);
    if (s->counters[TS_COUNTER_bake_points] && s->bake.seconds > 0)
        fprintf(f, "bake: %.0f points/s, %.3f M rays/s over %.3f s of waves\n",
                (double)s->counters[TS_COUNTER_bake_points] / s->bake.seconds,
                (double)s->counters[TS_COUNTER_rays] / s->bake.seconds / 1e6, s->bake.seconds);
}

void stats_free(ts_stats *s)
{
    free(s->iterations);
    s->iterations = NULL;
    s->iteration_count = s->iteration_capacity = 0;
    free(s->devices);
    s->devices = NULL;
    s->device_count = 0;
    free(s->ranks);
    s->ranks = NULL;
    s->rank_count = 0;
    free(s->busy);
    s->busy = NULL;
    s->busy_count = s->busy_capacity = 0;
}
