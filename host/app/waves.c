/* waves.c — the lod stage over a frame and the paths of one wave, on one device's pipeline
 * (waves.h). */
#include "app/waves.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int waves_tight_leaves(int exact)
{
    const char *env = getenv("TESSERA_TIGHT_LEAVES");
    return exact && !(env && strcmp(env, "0") == 0);
}

ts_trace_mode waves_trace_mode(const ts_render_options *o)
{
    return (ts_trace_mode){(uint32_t)o->spp,
                           o->fixed_lod,
                           o->exact,
                           o->leaf_group,
                           o->leaf_size == 4   ? 2u
                           : o->leaf_size == 2 ? 1u
                                               : 0u,
                           waves_tight_leaves(o->exact),
                           o->dicing_rate};
}

int waves_lod_rule(ts_lod_rule *rule, ts_error *err)
{
    /* TESSERA_LOD_RULE=visible|seen: the rules measured against the default in
     * docs/benchmarks.md, for experiments. */
    const char *name = getenv("TESSERA_LOD_RULE");
    *rule = TS_LOD_RULE_CROSSED;
    if (name && *name && pipeline_lod_rule_parse(name, rule))
        return ts_error_set(err, TS_E_USAGE,
                            "TESSERA_LOD_RULE=%s: expected crossed, visible or seen", name);
    return TS_OK;
}

int waves_frame_lod(const ts_render_options *o, ts_pipeline *p, ts_camera_params cam, ts_job *job,
                    ts_error *err)
{
    ts_lod_rule rule;
    if (waves_lod_rule(&rule, err)) return err->code;
    if (o->fixed_lod < 0 && pipeline_lod(p, &cam, rule, err)) return err->code;
    return waves_lod_record(o, p, job, err);
}

int waves_lod_record(const ts_render_options *o, ts_pipeline *p, ts_job *job, ts_error *err)
{
    int32_t lod = job_lod_hash(p, o);
    job->lod_mismatch = job->check_lod && lod != job->lod;
    if (job->lod_mismatch)
        return ts_error_set(err, TS_E_USAGE,
                            "%s: cannot resume: this run dices patches at other levels of detail "
                            "than the samples already in the image (patches up to m = %u then, "
                            "m = %u now): resume with the --memory the render was started with",
                            o->output_path, job->max_lod, p->plan.max_lod);
    job->lod = lod;
    job->max_lod = p->plan.max_lod;
    job->check_lod = 1;
    return TS_OK;
}

int waves_trace_paths(const ts_render_options *o, ts_pipeline *p, const ts_camera_params *cam,
                      ts_error *err)
{
    return waves_trace_paths_watched(o, p, cam, NULL, NULL, err);
}

int waves_trace_paths_watched(const ts_render_options *o, ts_pipeline *p,
                              const ts_camera_params *cam, ts_wave_watch watch, void *ctx,
                              ts_error *err)
{
    ts_shade_params sp = {.light_count = p->light_count,
                          .depth = (uint32_t)o->depth,
                          .sampling = (uint32_t)o->sampling,
                          .seed = o->seed,
                          .spp = (uint32_t)o->spp,
                          .band = cam->band};
    uint32_t first = cam->first_sample, n = cam->ray_count;
    uint32_t rays = n, paths = n;
    p->stats->counters[TS_COUNTER_rays] += n;
    for (uint32_t b = 0; rays > 0; ++b) {
        uint32_t shadows;
        sp.bounce = b;
        p->wave = b;
        if (watch && watch(ctx, p, b, rays, 0, err)) return err->code;
        if (pipeline_trace(p, rays, err)) return err->code;
        if (p->cancelled) return TS_OK; /* the wave's results are dropped (pipeline.h) */
        if (watch && watch(ctx, p, b, rays, 1, err)) return err->code;
        if (pipeline_shade(p, &sp, first, n, paths, &paths, &rays, &shadows, err)) return err->code;
        p->stats->counters[TS_COUNTER_rays] += rays - shadows;
        p->stats->counters[TS_COUNTER_shadow_rays] += shadows;
    }
    return TS_OK;
}

long waves_slow_ms(int index)
{
    const char *s = getenv("TESSERA_SLOW_DEVICE");
    while (s && *s) {
        int i = -1;
        long ms = 0;
        if (sscanf(s, "%d:%ld", &i, &ms) != 2) return 0;
        if (i == index && ms > 0) return ms;
        s = strchr(s, ',');
        s = s ? s + 1 : NULL;
    }
    return 0;
}

void waves_flight(const ts_pipeline *p, double t0, double dicing, uint64_t mp, uint64_t evictions,
                  ts_eta_flight *f)
{
    const ts_stats *st = p->stats;
    f->work = p->trace_progress.work, f->done = p->trace_progress.done;
    f->t0 = p->trace_progress.t0 - t0, f->at = stats_now() - t0;
    f->dicing = stats_dicing_seconds(st) - dicing;
    f->mp = (double)(st->counters[TS_COUNTER_micropolygons_created] - mp);
    f->evicted = st->counters[TS_COUNTER_patch_cache_evictions] > evictions;
}

void waves_pass_begins(ts_eta_passes *e, const ts_pipeline *p, uint32_t bounce, uint32_t rays,
                       double t0, double dicing)
{
    eta_passes_before(e, bounce, (double)rays, stats_now() - t0,
                      stats_dicing_seconds(p->stats) - dicing);
    if (bounce > 0) /* trace_progress still holds the pass that ended */
        eta_passes_batches(e, p->trace_progress.work, p->trace_progress.t0 - t0);
}
