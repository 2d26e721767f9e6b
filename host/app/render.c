#include "app/render.h"
#include "app/output.h"
#include "app/resume.h"
#include "base/mat4.h"
#include "pipeline/pipeline.h"
#include "scene/scene_load.h"

#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Linear part of m applied to (x, y, z), as float[4] with w = 0. */
static void camera_axis(const double m[16], double x, double y, double z, float out[4])
{
    double d[3] = {x, y, z}, r[3];
    mat4_dir(m, d, r);
    for (int k = 0; k < 3; ++k)
        out[k] = (float)r[k];
    out[3] = 0.0f;
}

int render_camera_params(const ts_camera *cam, int width, int height, ts_camera_params *out,
                         ts_error *err)
{
    memset(out, 0, sizeof *out);
    double inv[16];
    if (!mat4_invert(cam->world_to_camera, inv))
        return ts_error_set(err, TS_E_SCENE, "the camera transform is singular");
    if (!(cam->fov_deg > 0.0 && cam->fov_deg < 180.0))
        return ts_error_set(err, TS_E_SCENE, "fov %g is outside (0, 180) degrees", cam->fov_deg);
    double t = tan(0.5 * cam->fov_deg * M_PI / 180.0);
    double aspect = (double)width / (double)height;
    double hx = aspect >= 1.0 ? aspect * t : t, hy = aspect >= 1.0 ? t : t / aspect;
    for (int r = 0; r < 3; ++r)
        out->origin[r] = (float)inv[r * 4 + 3];
    camera_axis(inv, hx, 0, 0, out->right);
    camera_axis(inv, 0, hy, 0, out->up);
    camera_axis(inv, 0, 0, 1, out->forward);
    out->width = (uint32_t)width;
    out->height = (uint32_t)height;
    return TS_OK;
}

/* The lod stage: all eye rays of the frame, wave by wave, counted per patch box. */
static int render_lod(ts_pipeline *p, ts_camera_params cam, uint64_t total, ts_error *err)
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

/* Traces one wave of paths from the eye: eye rays, then each bounce's rays (BSDF and
 * shadow rays together, Hanika §3.5: rays grouped by generation) until none is left or the
 * depth is reached. */
static int render_paths(const ts_render_options *o, ts_pipeline *p, uint32_t first, uint32_t n,
                        ts_error *err)
{
    ts_shade_params sp = {.light_count = p->light_count,
                          .depth = (uint32_t)o->depth,
                          .sampling = (uint32_t)o->sampling,
                          .seed = o->seed,
                          .light_prob = 0.5f};
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
    return pipeline_film(p, first, n, err);
}

/* SIGINT and SIGTERM while samples are traced: the handler only records the signal; the
 * wave loop stops at the next wave boundary and the finished samples are written. */
static volatile sig_atomic_t stop_signal;
static int stop_handlers_installed;
static struct sigaction stop_old_int, stop_old_term;

static void on_stop_signal(int sig)
{
    stop_signal = sig;
}

static void stop_handlers_install(void)
{
    if (stop_handlers_installed) return;
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_stop_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    stop_signal = 0;
    sigaction(SIGINT, &sa, &stop_old_int);
    sigaction(SIGTERM, &sa, &stop_old_term);
    stop_handlers_installed = 1;
}

static void stop_handlers_restore(void)
{
    if (!stop_handlers_installed) return;
    sigaction(SIGINT, &stop_old_int, NULL);
    sigaction(SIGTERM, &stop_old_term, NULL);
    stop_handlers_installed = 0;
}

/* Runs the waves: each is a run of global sample indices [first, first + rays). The lod
 * stage counts the whole frame's eye rays even when the film already holds samples
 * [0, job->samples_done) (--resume, a retry): it is deterministic, so it gives the levels
 * of detail those samples were traced with, which job->check_lod verifies. Stops early
 * (job->samples_done < job->total) when a stop signal came. */
static int render_waves(const ts_render_options *o, ts_pipeline *p, ts_camera_params cam,
                        ts_job *job, ts_error *err)
{
    uint64_t total = job->total, start = job->samples_done;
    uint32_t per_wave = p->plan.ray_capacity / 2; /* each path also owns a shadow-ray slot */
    p->mode = (ts_trace_mode){(uint32_t)o->spp, o->fixed_lod, o->exact, o->leaf_group,
                              o->leaf_size == 4   ? 2u
                              : o->leaf_size == 2 ? 1u
                                                  : 0u};
    if (o->fixed_lod < 0 && render_lod(p, cam, total, err)) return err->code;
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
    stop_handlers_install();
    double t0 = stats_now();
    for (uint64_t first = start; first < total; first += per_wave) {
        uint32_t n = (uint32_t)(total - first < per_wave ? total - first : per_wave);
        cam.first_sample = (uint32_t)first;
        cam.ray_count = n;
        if (pipeline_camera(p, &cam, err) || render_paths(o, p, (uint32_t)first, n, err)) {
            if (!o->quiet && first > start) fputc('\n', stderr); /* end the progress line */
            return err->code;
        }
        job->samples_done = first + n;
        if (!o->quiet) {
            double dt = stats_now() - t0, done = (double)(first + n - start);
            double rays = (double)(p->stats->counters[TS_COUNTER_rays] +
                                   p->stats->counters[TS_COUNTER_shadow_rays]);
            fprintf(stderr, "\rtessera: %llu / %llu samples, %.2f Mrays/s, ETA %.0f s   ",
                    (unsigned long long)(first + n), (unsigned long long)total,
                    dt > 0 ? rays / dt / 1e6 : 0.0, dt * (double)(total - first - n) / done);
        }
        if (stop_signal) break;
    }
    if (!o->quiet) fputc('\n', stderr);
    return TS_OK;
}

/* The smallest budget a retry after an out-of-memory error tries. */
#define TS_MEMORY_FLOOR_MB 16

int render_run(const ts_render_options *o, ts_stats *stats, ts_render_result *result, ts_error *err)
{
    double t0 = stats_now();
    memset(result, 0, sizeof *result);
    if (output_check(o, err)) return err->code;
    ts_scene scene;
    memset(&scene, 0, sizeof scene);
    ts_device cl;
    memset(&cl, 0, sizeof cl);
    ts_pipeline pipe;
    memset(&pipe, 0, sizeof pipe);
    ts_film_state state = {0};
    ts_job job = {0};
    int complete = 0;
    int rc = scene_load(o->scene_path, &scene, o->quiet, err);
    /* Samples per pixel: --spp, else the scene's PixelSamples, else 1. */
    ts_render_options effective = *o;
    if (effective.spp <= 0) effective.spp = !rc && scene.camera.spp > 0 ? scene.camera.spp : 1;
    o = &effective;
    int width = o->width ? o->width : scene.camera.has_format ? scene.camera.width : 640;
    int height = o->height ? o->height : scene.camera.has_format ? scene.camera.height : 480;
    ts_camera_params cam;
    ts_pipeline_plan plan;
    if (!rc) rc = render_camera_params(&scene.camera, width, height, &cam, err);
    if (!rc) {
        cam.spp = (uint32_t)o->spp;
        cam.seed = o->seed;
        job.total = (uint64_t)width * height * (uint64_t)o->spp;
        rc = job_hash(o, &scene, &cam, &job.hash, err);
    }
    if (!rc && o->resume) rc = resume_load(o, width, height, &job, &state, &complete, err);
    if (!rc && complete) {
        result->outcome = TS_RENDER_UP_TO_DATE;
        result->samples_done = result->samples_total = job.total;
        scene_free(&scene);
        return TS_OK;
    }
    if (!rc) rc = dev_open(&cl, &o->cl, err);
    if (!rc) {
        snprintf(stats->device, sizeof stats->device, "%.120s (%.120s)", cl.info.name,
                 cl.info.platform_name);
        stats->kernel_build_seconds = cl.build_seconds;
        stats->kernel_cache_hit = cl.cache_hit;
    }
    /* Plan, create, render; when the device runs out of memory, halve the budget and go
     * on from the samples finished so far (kept in `state`). */
    uint64_t rays = 2 * (uint64_t)width * height * (uint64_t)o->spp; /* + shadow slots */
    uint64_t budget = (uint64_t)o->memory_mb, first_budget = budget;
    uint32_t noted_lod = (uint32_t)o->max_lod;
    ts_error oom = {0}; /* the last out-of-memory error, while retrying */
    while (!rc) {
        rc = pipeline_plan(budget << 20, rays, (uint32_t)o->max_lod, cl.info.max_alloc, &plan, err);
        if (rc && oom.code) { /* a retry's budget that holds nothing: the memory error stands */
            ts_error_clear(err);
            rc = ts_error_set(err, TS_E_DEVICE,
                              "%s: the device could not provide %llu MB, and "
                              "%llu MB cannot hold the render; lower --max-lod or --res, or free "
                              "device memory",
                              oom.msg, (unsigned long long)budget * 2, (unsigned long long)budget);
            break;
        }
        if (!rc && !o->quiet && plan.max_lod < noted_lod)
            fprintf(stderr,
                    "tessera: %s%llu MB holds patches up to m = %u; dicing at most "
                    "that finely (raise --memory for --max-lod %d)\n",
                    budget == first_budget ? "--memory " : "", (unsigned long long)budget,
                    plan.max_lod, o->max_lod);
        if (!rc) noted_lod = plan.max_lod;
        if (!rc)
            rc = pipeline_create(&pipe, &cl, &scene, &plan, (uint32_t)(width * height), stats, err);
        if (!rc && state.accum) rc = film_state_transfer(&pipe, &state, 1, err);
        if (!rc) rc = dev_finish(&cl, stats, err); /* the buffers' first use */
        uint64_t before = job.samples_done;
        if (!rc) rc = render_waves(o, &pipe, cam, &job, err);
        if (!rc || !dev_is_out_of_memory(err)) break;
        /* Out of device memory: keep the finished waves, retry with half the budget. */
        ts_error_clear(&oom);
        ts_error_set(&oom, err->code, "%s", err->msg);
        ts_error_clear(err);
        int kept = 1;
        if (job.samples_done > before) {
            if (!state.accum) kept = film_state_alloc(&state, (size_t)width * height, err) == TS_OK;
            if (kept) kept = film_state_transfer(&pipe, &state, 0, err) == TS_OK;
            ts_error_clear(err);
        }
        if (!kept || budget / 2 < TS_MEMORY_FLOOR_MB) {
            if (!kept)
                rc = ts_error_set(err, TS_E_DEVICE,
                                  "%s: the device ran out of memory after %llu "
                                  "samples; render again with a lower --memory or --max-lod",
                                  oom.msg, (unsigned long long)job.samples_done);
            else if (budget == first_budget)
                rc = ts_error_set(err, TS_E_DEVICE,
                                  "%s: the device could not provide %llu MB; "
                                  "lower --memory or --max-lod, or free device memory",
                                  oom.msg, (unsigned long long)budget);
            else
                rc = ts_error_set(err, TS_E_DEVICE,
                                  "%s: the device could not provide even %llu MB "
                                  "(retried down from %llu MB); lower --max-lod or --res, or free "
                                  "device memory",
                                  oom.msg, (unsigned long long)budget,
                                  (unsigned long long)first_budget);
            break;
        }
        if (!o->quiet)
            fprintf(stderr,
                    "tessera: the device could not provide %llu MB (%s); retrying with %llu MB\n",
                    (unsigned long long)budget, oom.msg, (unsigned long long)(budget / 2));
        pipeline_destroy(&pipe);
        budget /= 2;
        rc = TS_OK;
    }
    if (rc && job.lod_mismatch && oom.code) {
        /* Samples finished before the retry, at levels of detail the smaller budget cannot
         * reproduce: the image would mix them. */
        ts_error_clear(err);
        rc = ts_error_set(err, TS_E_DEVICE,
                          "%s: the device ran out of memory after %llu samples, "
                          "and the budget that fits dices at other levels of detail; render again "
                          "with a lower --memory or --max-lod",
                          oom.msg, (unsigned long long)job.samples_done);
    }
    if (!rc) {
        double tw = stats_now();
        rc = output_write(o, &pipe, width, height, &job, err);
        stats->stage_seconds[TS_STAGE_film] += stats_now() - tw;
    }
    if (!rc) {
        result->outcome = job.samples_done < job.total ? TS_RENDER_INTERRUPTED : TS_RENDER_COMPLETE;
        result->samples_done = job.samples_done;
        result->samples_total = job.total;
        result->signal = stop_signal;
    }
    stop_handlers_restore();
    film_state_free(&state);
    pipeline_destroy(&pipe);
    dev_close(&cl);
    scene_free(&scene);
    stats->wall_seconds = stats_now() - t0;
    return rc;
}
