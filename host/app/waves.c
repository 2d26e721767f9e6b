/* waves.c — the lod stage over a frame and the paths of one wave, on one device's pipeline
 * (waves.h). */
#include "app/waves.h"

ts_trace_mode waves_trace_mode(const ts_render_options *o)
{
    return (ts_trace_mode){(uint32_t)o->spp, o->fixed_lod, o->exact, o->leaf_group,
                           o->leaf_size == 4   ? 2u
                           : o->leaf_size == 2 ? 1u
                                               : 0u};
}

/* The lod stage: all eye rays of the frame, wave by wave, counted per patch box. */
static int waves_lod(ts_pipeline *p, ts_camera_params cam, uint64_t total, ts_error *err)
{
    uint32_t per_wave = p->plan.ray_capacity;
    for (uint64_t first = 0; first < total; first += per_wave) {
        uint32_t n = (uint32_t)(total - first < per_wave ? total - first : per_wave);
        cam.first_sample = (uint32_t)first;
        cam.ray_count = n;
        if (pipeline_camera(p, &cam, err) || pipeline_lod_count(p, n, err)) return err->code;
    }
    return pipeline_lod_finish(p, err);
}

int waves_frame_lod(const ts_render_options *o, ts_pipeline *p, ts_camera_params cam, ts_job *job,
                    ts_error *err)
{
    if (o->fixed_lod < 0 && waves_lod(p, cam, job->total, err)) return err->code;
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

int waves_trace_paths(const ts_render_options *o, ts_pipeline *p, uint32_t first, uint32_t n,
                      ts_error *err)
{
    ts_shade_params sp = {.light_count = p->light_count,
                          .depth = (uint32_t)o->depth,
                          .sampling = (uint32_t)o->sampling,
                          .seed = o->seed,
                          .spp = (uint32_t)o->spp};
    uint32_t rays = n, paths = n;
    p->stats->counters[TS_COUNTER_rays] += n;
    for (uint32_t b = 0; rays > 0; ++b) {
        uint32_t shadows;
        sp.bounce = b;
        p->wave = b;
        if (pipeline_trace(p, rays, err) ||
            pipeline_shade(p, &sp, first, n, paths, &paths, &rays, &shadows, err))
            return err->code;
        p->stats->counters[TS_COUNTER_rays] += rays - shadows;
        p->stats->counters[TS_COUNTER_shadow_rays] += shadows;
    }
    return TS_OK;
}
