/* render.c — `tessera render`: load the scene, set up the camera and the job, take back
 * what --resume finds, open the device, then plan, create and trace the frame in waves of
 * samples (again with half the memory when the device runs out), and write the image. */
#include "app/render.h"
#include "app/eta.h"
#include "app/bake_file.h"
#include "app/budget.h"
#include "app/interrupt.h"
#include "app/output.h"
#include "app/resume.h"
#include "app/waves.h"
#include "app/workers.h"
#include "app/writer.h"
#include "base/mat4.h"
#include "pipeline/pipeline.h"
#include "scene/scene_load.h"

#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* Linear part of m applied to (x, y, z), as float[4] with w = 0. */
static void camera_axis(const double m[16], double x, double y, double z, float out[4])
{
    double d[3] = {x, y, z}, r[3];
    mat4_dir(m, d, r);
    for (int k = 0; k < 3; ++k)
        out[k] = (float)r[k];
    out[3] = 0.0f;
}

/* The eye and the scaled axes (ts_camera_params) of the camera whose world_to_camera is w2c:
 * the screen window's half-sizes hx, hy and centre cx, cy in camera-space units. */
static int camera_vectors(const double w2c[16], int ortho, double hx, double hy, double cx,
                          double cy, float origin[4], float right[4], float up[4], float forward[4],
                          ts_error *err)
{
    double inv[16];
    if (!mat4_invert(w2c, inv))
        return ts_error_set(err, TS_E_SCENE, "the camera transform is singular");
    double eye[3] = {cx, cy, 0.0}, at[3]; /* orthographic rays start on the window at z = 0 */
    if (ortho && !mat4_point(inv, eye, at))
        return ts_error_set(err, TS_E_SCENE, "the camera transform is singular");
    for (int r = 0; r < 3; ++r)
        origin[r] = ortho ? (float)at[r] : (float)inv[r * 4 + 3];
    camera_axis(inv, hx, 0, 0, right);
    camera_axis(inv, 0, hy, 0, up);
    if (ortho)
        camera_axis(inv, 0, 0, 1, forward);
    else
        camera_axis(inv, cx, cy, 1, forward); /* (0, 0, 1) for the default window */
    return TS_OK;
}

int render_camera_params(const ts_camera *cam, int width, int height, ts_camera_params *out,
                         ts_error *err)
{
    memset(out, 0, sizeof *out);
    int ortho = cam->projection == TS_PROJECTION_ORTHOGRAPHIC;
    if (!ortho && !(cam->fov_deg > 0.0 && cam->fov_deg < 180.0))
        return ts_error_set(err, TS_E_SCENE, "fov %g is outside (0, 180) degrees", cam->fov_deg);
    /* Screen units in camera space: tan(fov / 2) on the plane z = 1, or 1 (orthographic). */
    double t = ortho ? 1.0 : tan(0.5 * cam->fov_deg * M_PI / 180.0);
    double aspect = (double)width / (double)height;
    double hx = aspect >= 1.0 ? aspect * t : t, hy = aspect >= 1.0 ? t : t / aspect;
    double cx = 0.0, cy = 0.0; /* the window's centre */
    if (cam->has_screen) {
        const double *w = cam->screen; /* left right bottom top */
        hx = 0.5 * (w[1] - w[0]) * t, hy = 0.5 * (w[3] - w[2]) * t;
        cx = 0.5 * (w[0] + w[1]) * t, cy = 0.5 * (w[2] + w[3]) * t;
    }
    if (camera_vectors(cam->world_to_camera, ortho, hx, hy, cx, cy, out->origin, out->right,
                       out->up, out->forward, err))
        return err->code;
    if (cam->moving) {
        if (camera_vectors(cam->world_to_camera1, ortho, hx, hy, cx, cy, out->origin1, out->right1,
                           out->up1, out->forward1, err))
            return err->code;
        out->moving = 1;
    }
    if (cam->fstop > 0.0 && cam->focal_length > 0.0 && cam->focal_distance > 0.0) {
        /* A thin lens: its half-axes, the camera's unit x and y times the radius */
        double r = 0.5 * cam->focal_length / cam->fstop, inv[16];
        for (int k = 0; k < 1 + cam->moving; ++k) {
            if (!mat4_invert(k ? cam->world_to_camera1 : cam->world_to_camera, inv))
                return ts_error_set(err, TS_E_SCENE, "the camera transform is singular");
            camera_axis(inv, r, 0, 0, k ? out->lens_x1 : out->lens_x);
            camera_axis(inv, 0, r, 0, k ? out->lens_y1 : out->lens_y);
        }
        out->dof = 1;
        out->focal = (float)cam->focal_distance;
    }
    out->width = (uint32_t)width;
    out->height = (uint32_t)height;
    out->projection = ortho ? TS_PROJECTION_ORTHOGRAPHIC : TS_PROJECTION_PERSPECTIVE;
    /* RIB Clipping, where it leaves something out: RenderMan's defaults (TS_CLIP_*_DEFAULT) and
     * scenes without it (0, 0) clip nothing, and their eye rays stay as they were. */
    if (cam->clip_near > 0.0 && cam->clip_far > cam->clip_near &&
        (cam->clip_near > TS_CLIP_NEAR_DEFAULT || cam->clip_far < TS_CLIP_FAR_DEFAULT)) {
        out->clip = 1;
        out->clip_near = (float)cam->clip_near;
        out->clip_far = cam->clip_far < TS_CLIP_FAR_DEFAULT ? (float)cam->clip_far : INFINITY;
    }
    return TS_OK;
}

/* SIGINT, SIGTERM and SIGHUP (a closed terminal or ssh session) while samples are traced:
 * app/interrupt.h records the signal; the wave loop stops at the next wave boundary and the
 * finished samples are written. render_run installs the handlers around the waves, the MPI
 * ranks other than 0 around their render. */

/* The progress of render_waves' frame: samples [start, done) finished of [start, total), the
 * wave in flight, and the weights the estimate uses (eta.h). */
typedef struct wave_progress {
    const ts_render_options *o;
    ts_pipeline *p;
    ts_eta eta;
    ts_eta_waves waves; /* what the finished waves took */
    uint64_t start, total, done, wave_end, per_wave;
    double t0, wave_t0, printed;
    double wave_dicing;      /* stages dice and build's seconds when the wave began */
    uint64_t wave_mp;        /* the micro-polygons created then */
    uint64_t wave_evictions; /* the patch cache's evictions then */
    ts_eta_passes passes;    /* the wave's passes begun and ended (render_pass_ended) */
    double shown;            /* the most weight the line has shown done: it never goes back */
    double *after;           /* the weights of the waves after the one in flight that dice */
    uint32_t after_count;    /* (eta_waves_works, once a wave) */
} wave_progress;

/* The frame's micro-polygons at their levels (the patch cache's plan, pipeline.c
 * frame_lod_histogram) less those diced so far: what a frame that fits has yet to dice. */
static double frame_mp_left(const ts_pipeline *p)
{
    double need = 0.0;
    for (uint32_t m = 0; m <= TS_LOD_LIMIT; ++m)
        need += (double)p->stats->frame_lod_histogram[m] * (double)((uint64_t)1 << (2u * m));
    double made = (double)p->stats->counters[TS_COUNTER_micropolygons_created];
    return need > made ? need - made : 0.0;
}

/* The progress line: samples finished, the share of the frame's weight they hold, rays per
 * second, and the time left as the finished waves predict it (eta.h ts_eta_waves: the weight
 * per second, and a squeezed frame's dicing a wave; in a squeezed frame's wave, from its
 * passes once eta_waves_project can; in the frame's first wave, from its own passes and the
 * work of its batches the device has run: eta_wave_alone). Inside a wave (the cancel hook, between
 * batches) the wave in flight is credited for the share of its expected time it has run, at most
 * 90% of its weight, so that the line moves while a long wave runs without claiming what is not
 * finished. Stops for good once stderr fails (a closed pipe: EPIPE, SIGPIPE being ignored by
 * main); the render goes on. */
static void wave_progress_print(wave_progress *w, int in_wave)
{
    if (w->o->quiet || ferror(stderr)) return;
    double now = stats_now();
    w->waves.mp_left = frame_mp_left(w->p);
    if (in_wave) /* what the first wave is projected from (eta_wave_alone) */
        waves_flight(w->p, w->wave_t0, w->wave_dicing, w->wave_mp, w->wave_evictions,
                     &w->passes.flight);
    double done = eta_work(&w->eta, w->done) - eta_work(&w->eta, w->start);
    /* in a wave and after it, the waves after are those after wave_end (done is wave_end) */
    double wave = in_wave ? eta_work(&w->eta, w->wave_end) - eta_work(&w->eta, w->done) : 0.0;
    double after = eta_work(&w->eta, w->total) - eta_work(&w->eta, w->wave_end);
    double elapsed = now - w->wave_t0, projected;
    double left = eta_waves_left_passes(&w->waves, wave, elapsed, after, w->after, w->after_count,
                                        in_wave ? &w->passes : NULL, &projected);
    double expect = projected > 0.0 ? projected : eta_waves_expect(&w->waves, wave);
    if (in_wave && expect > 0.0) {
        double credit = wave * elapsed / expect;
        done += credit < 0.9 * wave ? credit : 0.9 * wave;
    }
    /* A wave projected longer than it was expected (eta_waves_project) is credited less than
     * before: the share shown holds until the wave catches up. */
    if (done < w->shown) done = w->shown;
    w->shown = done;
    double rays = (double)(w->p->stats->counters[TS_COUNTER_rays] +
                           w->p->stats->counters[TS_COUNTER_shadow_rays]);
    /* Until a quarter of the first wave's eye rays' work has run there is no estimate; the
     * pass in flight shows it moving. */
    if (in_wave && left < 0.0) {
        char pass[32] = "wave 1: eye rays";
        if (w->passes.started > 1)
            snprintf(pass, sizeof pass, "wave 1: bounce %u/%d", w->passes.started - 1, w->o->depth);
        eta_print_tail(&w->eta, w->done, w->start, w->total, done, rays, now - w->t0, pass);
    } else
        eta_print_left(&w->eta, w->done, w->start, w->total, done, rays, now - w->t0, left, "wave");
    w->printed = now;
}

/* Wave [first, w->wave_end) began: what it will be measured against. */
static void wave_progress_begin(wave_progress *w, uint64_t first, uint32_t n)
{
    w->wave_end = first + n, w->wave_t0 = stats_now();
    w->wave_dicing = stats_dicing_seconds(w->p->stats);
    w->wave_mp = w->p->stats->counters[TS_COUNTER_micropolygons_created];
    w->wave_evictions = w->p->stats->counters[TS_COUNTER_patch_cache_evictions];
    double all = eta_work(&w->eta, w->total) - eta_work(&w->eta, w->start);
    w->passes = (ts_eta_passes){
        .depth = (uint32_t)w->o->depth,
        .share =
            all > 0.0 ? (eta_work(&w->eta, w->wave_end) - eta_work(&w->eta, first)) / all : 0.0};
    w->after_count = eta_waves_works(&w->eta, w->wave_end, w->total, w->per_wave, w->after);
}

/* The wave in flight's last pass ended now: its seconds and dicing seconds so far. */
static void wave_progress_pass(wave_progress *w)
{
    eta_passes_add(&w->passes, stats_now() - w->wave_t0,
                   stats_dicing_seconds(w->p->stats) - w->wave_dicing);
}

/* waves_trace_paths' watch (waves.h): before bounce b > 0 is traced, pass b - 1 (the bounce
 * before it, traced and shaded) has ended; b is in flight. */
static int render_pass_ended(void *ctx, ts_pipeline *p, uint32_t bounce, uint32_t rays, int after,
                             ts_error *err)
{
    (void)err;
    wave_progress *w = ctx;
    if (!after) waves_pass_begins(&w->passes, p, bounce, rays, w->wave_t0, w->wave_dicing);
    return TS_OK;
}

/* The wave that began at `first` is finished (its film and rows handed on): what it took. */
static void wave_progress_end(wave_progress *w, uint64_t first)
{
    wave_progress_pass(w); /* the last pass, and the film */
    eta_waves_done_diced(
        &w->waves, eta_work(&w->eta, w->wave_end) - eta_work(&w->eta, first),
        stats_now() - w->wave_t0, stats_dicing_seconds(w->p->stats) - w->wave_dicing,
        w->p->stats->counters[TS_COUNTER_patch_cache_evictions] > w->wave_evictions, &w->passes,
        (double)(w->p->stats->counters[TS_COUNTER_micropolygons_created] - w->wave_mp));
    w->done = w->wave_end;
}

/* The pipeline's cancel hook (pipeline.h) while the waves run: a stop signal ends the wave
 * between two of its batches, and its samples are dropped; the progress line moves every
 * second meanwhile. */
static int render_stop_asked(void *ctx)
{
    wave_progress *w = ctx;
    if (stats_now() - w->printed >= 1.0) wave_progress_print(w, 1);
    return interrupt_signal() != 0;
}

/* Runs the waves: each is a run of the frame's samples [first, first + rays) in its sample
 * order, from job->samples_done on. After the lod stage the arenas grow to hold the frame's
 * patches as far as room_mb allows (budget_grow_arenas). Stops early
 * (job->samples_done < job->total) when a stop signal came. After each wave, wave_done(ctx)
 * (the image's finished rows to the writer). */
static int render_waves(const ts_render_options *o, ts_pipeline *p, ts_camera_params cam,
                        ts_job *job, uint64_t room_mb, void (*wave_done)(void *ctx), void *ctx,
                        ts_error *err)
{
    uint64_t total = job->total, start = job->samples_done;
    p->mode = waves_trace_mode(o);
    if (waves_frame_lod(o, p, cam, job, err)) return err->code;
    p->frame_rays = 2u * (total - start);
    if (budget_grow_arenas(p, room_mb, 1, o->quiet, err)) return err->code;
    uint32_t per_wave = p->plan.ray_capacity / 2; /* each path also owns a shadow-ray slot */
    /* Pixel after pixel: a wave holds the samples of about per_wave / spp consecutive pixels,
     * the rows a band of rows would give it, each pixel's samples together (done.h). */
    job_choose_band(job, &cam);
    wave_progress w = {.o = o,
                       .p = p,
                       .start = start,
                       .total = total,
                       .done = start,
                       .wave_end = start,
                       .per_wave = per_wave ? per_wave : 1};
    if (eta_init(&w.eta, o->fixed_lod < 0 ? p->pixel_cost : NULL, cam.width * cam.height,
                 (uint32_t)o->spp, cam.band, err))
        return err->code;
    w.after = malloc(((total - start) / w.per_wave + 1) * sizeof *w.after);
    if (!w.after) {
        eta_free(&w.eta);
        return ts_error_set(err, TS_E_MEMORY, "out of memory (progress weights)");
    }
    interrupt_install();
    w.t0 = w.printed = stats_now();
    long slow_ms = waves_slow_ms(o->cl.device_index);
    int rc = TS_OK;
    for (uint64_t first = start; first < total; first += per_wave) {
        uint32_t n = (uint32_t)(total - first < per_wave ? total - first : per_wave);
        cam.first_sample = (uint32_t)first;
        cam.ray_count = n;
        wave_progress_begin(&w, first, n);
        p->cancel = render_stop_asked, p->cancel_ctx = &w, p->cancelled = 0;
        rc = pipeline_camera(p, &cam, err) ||
             waves_trace_paths_watched(o, p, &cam, render_pass_ended, &w, err);
        p->cancel = NULL;
        if (!rc && p->cancelled) break; /* a stop signal: the wave is not finished */
        if (rc || pipeline_film(p, &cam, err)) {
            rc = err->code;
            break;
        }
        job->samples_done = first + n;
        wave_done(ctx);
        wave_progress_end(&w, first);
        wave_progress_print(&w, 0);
        for (long ms = 0; ms < slow_ms && !interrupt_signal(); ms += 10) /* the test aid */
            nanosleep(&(struct timespec){0, 10000000L}, NULL);
        if (interrupt_signal()) break;
    }
    eta_free(&w.eta);
    free(w.after);
    if (!o->quiet && !ferror(stderr) && (rc == TS_OK || w.done > start)) fputc('\n', stderr);
    return rc;
}

/* Everything one render holds: zeroed by render_init, filled step by step by render_run,
 * freed by render_free whatever step failed. */
typedef struct ts_render {
    ts_render_options opt; /* the command's options, spp resolved from the scene */
    ts_stats *stats;
    int width, height; /* the image's pixels: the frame's, or the part a CropWindow names */
    int full_width, full_height, crop_x, crop_y; /* the frame, and where the image lies in it */
    ts_scene scene;
    ts_occlusion occlusion; /* --occlusion's bake, attached to scene.occlusion */
    ts_camera_params cam;
    ts_job job;
    /* job.hash computed on a thread of its own while the devices are set up and render
     * (render_start_job; 6 s of single-threaded hashing for forest-10000): hash_pending until
     * render_hash_ready has joined it, under hash_lock (the image may be written from the
     * board's thread); hash_err its error. */
    pthread_t hash_thread;
    pthread_mutex_t hash_lock;
    int hash_pending, hash_lock_made;
    ts_error hash_err;
    /* The host copy of the films: the samples [0, job.samples_done) the device's films lack
     * (resumed, or kept over a retry), and the image render_write writes. Its pages are
     * touched on a thread of their own while the devices open (render_films_touch):
     * touch_pending until joined. */
    ts_film_state state;
    pthread_t touch_thread;
    int touch_pending;
    /* The devices --device names (dev_select): one renders alone (cl, pipe); several share
     * the frame (workers.h), merging into state (films_on_host). */
    int devices[TS_DEVICE_MAX], device_count;
    int films_on_host;
    /* Rank 0 of several MPI ranks (NULL: alone): the units' size it told them. */
    ts_ranks *ranks;
    /* The image was written when the stop signal came (render_write_early): written is 1,
     * and early holds its error, if any. */
    int written;
    ts_error early;
    /* The image written while several devices render (output.h): open once the frame's levels
     * are known; stream_off once it cannot be (bands of rows, a failure: written at the end). */
    ts_output_stream stream;
    int stream_off;
    /* The image written while one device renders (writer.h); rows_sent:
     * the image's rows copied from the device's films into state for it. */
    ts_writer writer;
    int rows_sent;
    uint64_t unit_samples;
    ts_device cl;
    ts_pipeline pipe;
    /* Set when memory ran out at the smallest budget with samples finished: why. The
     * finished samples (in state) are written as a partial image. */
    ts_error stopped;
} ts_render;

static void render_init(ts_render *r, const ts_render_options *o, ts_stats *stats)
{
    memset(r, 0, sizeof *r);
    r->opt = *o;
    r->stats = stats;
}

static int render_hash_ready(ts_render *r, ts_error *err);

static void render_films_touched(ts_render *r);

static void render_free(ts_render *r)
{
    render_films_touched(r); /* a failure while the devices opened */
    ts_error e = {0};
    render_hash_ready(r, &e); /* a failure before the image was written */
    ts_error_clear(&e);
    ts_error_clear(&r->hash_err);
    if (r->hash_lock_made) pthread_mutex_destroy(&r->hash_lock);
    output_stream_close(&r->stream, 0, NULL); /* a failure before the frame's end */
    writer_free(&r->writer);
    ts_error_clear(&r->early);
    ts_error_clear(&r->stopped);
    film_state_free(&r->state);
    done_free(&r->job.done);
    pipeline_destroy(&r->pipe);
    dev_close(&r->cl);
    scene_free(&r->scene);
    occlusion_free(&r->occlusion);
}

/* The most samples an image may have: the kernels index them (and the film its pixels)
 * with 32 bits. */
#define TS_SAMPLE_LIMIT UINT32_MAX

/* The image size and sample count, in 64 bits: width * height * spp must fit the kernels'
 * 32-bit sample index (a 65536x65536 image used to overflow into a 0-pixel film). res and
 * spp name where the numbers came from (--res or the scene's Format, --spp or its
 * PixelSamples). */
static int render_check_size(const ts_render *r, const char *res, const char *spp, ts_error *err)
{
    const ts_render_options *o = &r->opt;
    uint64_t samples = (uint64_t)r->width * (uint64_t)r->height * (uint64_t)o->spp;
    if (r->width < 1 || r->height < 1)
        return ts_error_set(err, TS_E_USAGE, "%s %dx%d is not an image size", res, r->width,
                            r->height);
    if (samples > TS_SAMPLE_LIMIT)
        return ts_error_set(err, TS_E_USAGE,
                            "%s %dx%d at %s %d is %llu samples; at most %llu (2^32 - 1) fit one "
                            "image (the kernels index samples with 32 bits): lower the resolution "
                            "or the samples per pixel",
                            res, r->width, r->height, spp, o->spp, (unsigned long long)samples,
                            (unsigned long long)TS_SAMPLE_LIMIT);
    return TS_OK;
}

/* The part of the frame rendered: --crop, else the scene's CropWindow (RI Spec 3.2 §4.1.1:
 * columns ceil(W xmin) to ceil(W xmax) - 1, rows likewise from the top), else all of it; the
 * image is that part (width x height), full_width x full_height the frame. */
static int render_crop(ts_render *r, ts_error *err)
{
    const double *c = r->opt.crop_given ? r->opt.crop : r->scene.camera.crop;
    r->full_width = r->width, r->full_height = r->height, r->crop_x = r->crop_y = 0;
    /* The whole frame, or a camera that never had a window (a mesh's automatic one: 0 0 0 0). */
    if ((c[0] <= 0.0 && c[1] >= 1.0 && c[2] <= 0.0 && c[3] >= 1.0) || !(c[0] < c[1] && c[2] < c[3]))
        return TS_OK;
    int x0 = (int)ceil(r->width * c[0]), x1 = (int)ceil(r->width * c[1]);
    int y0 = (int)ceil(r->height * c[2]), y1 = (int)ceil(r->height * c[3]);
    if (x1 <= x0 || y1 <= y0)
        return ts_error_set(err, TS_E_USAGE, "%s %g %g %g %g holds no pixel of the %dx%d frame",
                            r->opt.crop_given ? "--crop" : "CropWindow", c[0], c[1], c[2], c[3],
                            r->width, r->height);
    r->crop_x = x0, r->crop_y = y0, r->width = x1 - x0, r->height = y1 - y0;
    return TS_OK;
}

/* The scene (its --frame, for a RIB animation), and what it decides that the command line
 * left open: samples per pixel (--spp, else the scene's PixelSamples, else 1) and the image
 * size (--res, else the scene's Format, else 640x480). */
static int render_load_scene(ts_render *r, ts_error *err)
{
    ts_render_options *o = &r->opt;
    ts_load_options lo;
    render_load_options(o, &lo);
    if (scene_load_with(o->scene_path, &lo, &r->scene, err)) return err->code;
    const ts_camera *c = &r->scene.camera;
    const char *spp = o->spp > 0 ? "--spp" : c->spp > 0 ? "PixelSamples" : "spp";
    const char *res = o->width ? "--res" : c->has_format ? "Format" : "size";
    if (o->spp <= 0) o->spp = c->spp > 0 ? c->spp : 1;
    if (!o->depth_given && c->has_depth) o->depth = c->depth; /* Integrator maxPathLength */
    r->width = o->width ? o->width : c->has_format ? c->width : 640;
    r->height = o->height ? o->height : c->has_format ? c->height : 480;
    if (render_check_size(r, res, spp, err)) return err->code;
    return render_crop(r, err);
}

/* --occlusion: the bake to relight with, checked against the scene and attached to it (so
 * every device's pipeline uploads it). One process: the MPI ranks would receive the scene
 * without it. */
static int render_load_occlusion(ts_render *r, ts_error *err)
{
    const ts_render_options *o = &r->opt;
    if (r->ranks)
        return ts_error_set(err, TS_E_USAGE,
                            "--occlusion renders in one process: run it without mpirun "
                            "(several devices of one process may share it: --device)");
    if (bake_occlusion_load(o->occlusion_path, &r->scene, o->scene_path, &r->occlusion, err))
        return err->code;
    r->scene.occlusion = &r->occlusion;
    int domes = r->scene.dome.present;
    for (uint32_t i = 0; i < r->scene.light_count; ++i)
        domes |= r->scene.lights[i].kind == SCENE_LIGHT_AMBIENT;
    if (!domes && !o->quiet)
        ts_print_line("tessera: warning: %s has no domelight or ambientlight: --occlusion "
                      "changes nothing",
                      o->scene_path);
    return TS_OK;
}

/* Writes the host copy of the films once, zeros over calloc's untouched pages, so that the
 * pages are faulted in here rather than while the first waves' rows are copied in (2.8 µs a
 * 4 KB page on this 2-core machine: 35 ms of a 1920x768 frame's 70 MB, with no kernel
 * running) or merged. */
static void *render_films_touch_run(void *arg)
{
    const ts_render *r = arg;
    ts_vec4 *films[3] = {r->state.accum, r->state.aov, r->state.albedo};
    for (int i = 0; i < 3; ++i)
        memset(films[i], 0, (size_t)r->width * r->height * sizeof(ts_vec4));
    return NULL;
}

/* Starts render_films_touch_run while the devices open (the platform's start and the kernels'
 * binary read: 50-70 ms on PoCL, on one core). Where no thread starts the pages are faulted
 * in as before, when first written. */
static void render_films_touch(ts_render *r)
{
    r->touch_pending = pthread_create(&r->touch_thread, NULL, render_films_touch_run, r) == 0;
}

/* Joins render_films_touch's thread, before the films are first written. */
static void render_films_touched(ts_render *r)
{
    if (r->touch_pending) pthread_join(r->touch_thread, NULL), r->touch_pending = 0;
}

static void *render_hash_run(void *arg)
{
    ts_render *r = arg;
    job_hash(&r->opt, &r->scene, &r->cam, &r->job.hash, &r->hash_err);
    return NULL;
}

/* Waits for the job's hash when a thread computes it (render_start_job): before anything
 * reads job.hash (the image's metadata). Returns its error, if any; once joined, at once. */
static int render_hash_ready(ts_render *r, ts_error *err)
{
    if (!r->hash_lock_made) return TS_OK;
    pthread_mutex_lock(&r->hash_lock);
    if (r->hash_pending) pthread_join(r->hash_thread, NULL), r->hash_pending = 0;
    int rc = r->hash_err.code;
    if (rc) ts_error_set(err, rc, "%s", r->hash_err.msg);
    pthread_mutex_unlock(&r->hash_lock);
    return rc;
}

/* The camera kernel's parameters and the job: its width * height * spp samples and the
 * hash that --resume checks. The hash (of the scene file and every patch's data) is only
 * written with the image unless --resume compares it now or ranks are told it: then it is
 * computed at once, else on a thread of its own while the render goes on. */
static int render_start_job(ts_render *r, ts_error *err)
{
    if (render_camera_params(&r->scene.camera, r->full_width, r->full_height, &r->cam, err))
        return err->code;
    if (r->width != r->full_width || r->height != r->full_height) { /* a part of the frame */
        r->cam.full_width = r->cam.width, r->cam.full_height = r->cam.height;
        r->cam.width = (uint32_t)r->width, r->cam.height = (uint32_t)r->height;
        r->cam.crop_x = (uint32_t)r->crop_x, r->cam.crop_y = (uint32_t)r->crop_y;
        r->job.full_width = r->full_width, r->job.full_height = r->full_height;
        r->job.crop_x = r->crop_x, r->job.crop_y = r->crop_y;
    }
    r->cam.spp = (uint32_t)r->opt.spp;
    r->cam.seed = r->opt.seed;
    r->job.total = (uint64_t)r->width * r->height * (uint64_t)r->opt.spp;
    if (!r->opt.resume && !r->ranks && pthread_mutex_init(&r->hash_lock, NULL) == 0) {
        r->hash_lock_made = 1;
        r->hash_pending = pthread_create(&r->hash_thread, NULL, render_hash_run, r) == 0;
        if (r->hash_pending) return TS_OK;
    }
    return job_hash(&r->opt, &r->scene, &r->cam, &r->job.hash, err);
}

static int render_open_device(ts_render *r, ts_error *err)
{
    r->opt.cl.host_cores = workers_host_cores(&r->opt.cl.device_index, 1);
    if (dev_open(&r->cl, &r->opt.cl, err)) return err->code;
    if (!r->opt.quiet && r->cl.cache_note[0])
        ts_print_line("tessera: warning: %s", r->cl.cache_note);
    snprintf(r->stats->device, sizeof r->stats->device, "%.120s (%.120s)", r->cl.info.name,
             r->cl.info.platform_name);
    r->stats->kernel_build_seconds = r->cl.build_seconds;
    r->stats->kernel_cache_hit = r->cl.cache_hit;
    /* Each film (16 bytes a pixel) is one buffer, outside the budget. */
    uint64_t film = (uint64_t)r->width * (uint64_t)r->height * sizeof(ts_vec4);
    if (film > r->cl.info.max_alloc)
        return ts_error_set(err, TS_E_USAGE,
                            "%dx%d needs film buffers of %llu MB; the device's largest buffer is "
                            "%llu MB (CL_DEVICE_MAX_MEM_ALLOC_SIZE): lower the resolution",
                            r->width, r->height, (unsigned long long)(film >> 20),
                            (unsigned long long)(r->cl.info.max_alloc >> 20));
    return TS_OK;
}

/* The memory budget over the attempts of one render. */
typedef struct ts_budget {
    uint64_t mb, first_mb; /* this attempt's budget and the first one's, in MB */
    uint64_t room_mb;      /* how far the arenas may grow (budget_grow_arenas) */
    uint32_t noted_lod;    /* the finest m the user knows the render dices at */
    ts_error oom;          /* the last out-of-memory error; code 0 before the first */
} ts_budget;

/* The memory plan for b->mb, with a note when it dices less finely than the user knows.
 * A retry's budget that holds nothing fails with the out-of-memory error that led to it. */
static int render_plan(ts_render *r, ts_budget *b, ts_pipeline_plan *plan, ts_error *err)
{
    const ts_render_options *o = &r->opt;
    uint64_t rays = 2 * (uint64_t)r->width * r->height * (uint64_t)o->spp; /* + shadow slots */
    uint64_t frame = (uint64_t)r->full_width * r->full_height; /* the lod pass's eye rays */
    if (rays < frame) rays = frame; /* a small CropWindow: its lod waves as large as before */
    if (pipeline_plan(b->mb << 20, rays, (uint32_t)o->max_lod, r->cl.info.max_alloc, plan, err)) {
        if (!b->oom.code) return err->code;
        ts_error_clear(err);
        return ts_error_set(err, TS_E_DEVICE,
                            "%s: the device could not provide %llu MB, and "
                            "%llu MB cannot hold the render; lower --max-lod or --res, or free "
                            "device memory",
                            b->oom.msg, (unsigned long long)b->mb * 2, (unsigned long long)b->mb);
    }
    if (!o->quiet && plan->max_lod < b->noted_lod)
        ts_print_line("tessera: %s%llu MB holds patches up to m = %u; dicing at most "
                      "that finely (raise --memory for --max-lod %d)",
                      b->mb == b->first_mb && o->memory_mb ? "--memory " : "",
                      (unsigned long long)b->mb, plan->max_lod, o->max_lod);
    b->noted_lod = plan->max_lod;
    return TS_OK;
}

static int render_hash_wait(void *ctx, ts_error *err)
{
    return render_hash_ready(ctx, err);
}

/* The writer (writer.h) for a render on one device (an .exr or a .png: output_check made
 * sure); without it (no means to lock) render_write writes the image at the end. */
static void render_writer_start(ts_render *r)
{
    ts_error e = {0};
    writer_init(&r->writer, &r->opt, &r->state, &r->scene.camera, &r->job, r->width, r->height,
                render_hash_wait, r, &e);
    ts_error_clear(&e);
}

/* After each wave on one device: the rows whose pixels now hold every sample (in the sample
 * order, job.band pixels a band: whole bands are final) are copied from the films into
 * r->state and handed to the writer. A copy that fails ends the writer: the device's error
 * comes back from its next call. */
static void render_wave_done(void *ctx)
{
    ts_render *r = ctx;
    if (!writer_taking(&r->writer)) return;
    double t0 = stats_now();
    uint64_t npix = (uint64_t)r->width * (uint64_t)r->height, spp = (uint64_t)r->opt.spp;
    uint64_t band = r->job.band && r->job.band < npix ? r->job.band : npix;
    uint64_t pixels =
        r->job.samples_done >= r->job.total ? npix : r->job.samples_done / (band * spp) * band;
    int rows = (int)(pixels / (uint64_t)r->width);
    if (rows > r->rows_sent) {
        ts_error e = {0};
        size_t first = (size_t)r->rows_sent * (size_t)r->width;
        if (film_state_read_pixels(&r->pipe, &r->state, first,
                                   (size_t)(rows - r->rows_sent) * (size_t)r->width, &e)) {
            writer_end(&r->writer, 0, &r->stats->stage_seconds[TS_STAGE_film]);
        } else {
            r->rows_sent = rows;
            writer_rows(&r->writer, rows);
        }
        ts_error_clear(&e);
    }
    r->stats->stage_seconds[TS_STAGE_film] += stats_now() - t0;
}

/* After the frame on one device (ok: without error): when every row went to the writer, the
 * pipeline is released while it writes the last ones, and the image is written once it
 * commits them (r->written); else (interrupted, out of memory, a writer that failed)
 * render_write writes it. The film stage counts the release and the writer's own seconds
 * (writer_end), not the wait for it, which they overlap. */
static void render_writer_finish(ts_render *r, int ok)
{
    double *film = &r->stats->stage_seconds[TS_STAGE_film];
    int complete = ok && r->writer.made && !r->stopped.code &&
                   r->job.samples_done == r->job.total && r->rows_sent == r->height;
    if (!complete) {
        writer_end(&r->writer, 0, film);
        return;
    }
    double t0 = stats_now();
    pipeline_destroy(&r->pipe);
    *film += stats_now() - t0;
    r->films_on_host = 1; /* every row is in r->state */
    r->written = writer_end(&r->writer, 1, film);
}

/* One attempt at budget b->mb: plan, create the pipeline, give its films the samples
 * already finished, trace the rest. */
static int render_attempt(ts_render *r, ts_budget *b, ts_error *err)
{
    ts_pipeline_plan plan;
    r->stats->memory_budget_bytes = b->mb << 20;
    if (render_plan(r, b, &plan, err) ||
        pipeline_create(&r->pipe, &r->cl, &r->scene, &plan,
                        (uint32_t)((uint64_t)r->width * r->height), r->stats, err) ||
        (r->job.samples_done > 0 && film_state_transfer(&r->pipe, &r->state, 1, err)) ||
        dev_finish(&r->cl, r->stats, err)) /* the buffers' first use */
        return err->code;
    return render_waves(&r->opt, &r->pipe, r->cam, &r->job, b->room_mb, render_wave_done, r, err);
}

/* After an attempt that started at sample `before` ran out of memory: copies the samples it
 * finished into r->state (allocated before the first attempt, when memory was there), since
 * its films go with its pipeline. 0 when that failed. */
static int render_keep_samples(ts_render *r, uint64_t before)
{
    if (r->job.samples_done <= before) return 1;
    ts_error e = {0};
    int kept = !film_state_transfer(&r->pipe, &r->state, 0, &e);
    ts_error_clear(&e);
    return kept;
}

/* The error that ends a render out of memory: samples lost, or no smaller budget to try. */
static int render_give_up(const ts_render *r, const ts_budget *b, int kept, ts_error *err)
{
    if (!kept)
        return ts_error_set(err, TS_E_DEVICE,
                            "%s: the device ran out of memory after %llu "
                            "samples; render again with a lower --memory or --max-lod",
                            b->oom.msg, (unsigned long long)r->job.samples_done);
    if (b->mb == b->first_mb)
        return ts_error_set(err, TS_E_DEVICE,
                            "%s: the device could not provide %llu MB; "
                            "lower --memory or --max-lod, or free device memory",
                            b->oom.msg, (unsigned long long)b->mb);
    return ts_error_set(err, TS_E_DEVICE,
                        "%s: the device could not provide even %llu MB "
                        "(retried down from %llu MB); lower --max-lod or --res, or free "
                        "device memory",
                        b->oom.msg, (unsigned long long)b->mb, (unsigned long long)b->first_mb);
}

/* The first attempt's budget: --memory, else budget_default for this device, scene and
 * image under the process's limits. Announced in the progress header. */
static void render_choose_budget(const ts_render *r, ts_budget_choice *c)
{
    if (r->opt.memory_mb > 0) {
        budget_fixed((uint64_t)r->opt.memory_mb, c);
    } else {
        ts_memory_room room;
        ts_memory_room_query(NULL, &room);
        uint64_t pixels = (uint64_t)r->width * (uint64_t)r->height;
        budget_default(&r->cl.info, budget_fixed_bytes(&r->scene, pixels), &room, c);
    }
    if (r->opt.quiet) return;
    if (r->width != r->full_width || r->height != r->full_height) /* a CropWindow */
        ts_print_line("tessera: %dx%d at (%d, %d) of the %dx%d frame, %d spp, memory budget "
                      "%llu MB (%s)",
                      r->width, r->height, r->crop_x, r->crop_y, r->full_width, r->full_height,
                      r->opt.spp, (unsigned long long)c->mb, c->why);
    else
        ts_print_line("tessera: %dx%d, %d spp, memory budget %llu MB (%s)", r->width, r->height,
                      r->opt.spp, (unsigned long long)c->mb, c->why);
}

/* Memory ran out, on the device (dev_is_out_of_memory) or on the host (the sort's host
 * buffers and the device's own allocations on CPU devices grow with the budget too): a
 * smaller budget may fit. */
static int render_out_of_memory(const ts_error *err)
{
    return dev_is_out_of_memory(err) || err->code == TS_E_MEMORY;
}

/* Plan, create, render; when memory runs out (render_out_of_memory), keep the finished
 * samples, halve the budget and go on from them, down to TS_MEMORY_FLOOR_MB. When no budget
 * is left (or the one that fits dices at other levels of detail than the samples already
 * traced), the finished samples are kept for render_write in r->state and the reason in
 * r->stopped; only when there are none does the render fail. */
static int render_with_retry(ts_render *r, ts_error *err)
{
    ts_budget_choice choice;
    render_choose_budget(r, &choice);
    ts_budget b = {.mb = choice.mb,
                   .first_mb = choice.mb,
                   .noted_lod = (uint32_t)r->opt.max_lod,
                   .room_mb = choice.room_mb};
    int rc, kept = 1, gave_up = 0;
    for (;;) {
        uint64_t before = r->job.samples_done;
        rc = render_attempt(r, &b, err);
        if (!rc || !render_out_of_memory(err)) break;
        ts_error_clear(&b.oom);
        ts_error_set(&b.oom, err->code, "%s", err->msg);
        ts_error_clear(err);
        writer_end(&r->writer, 0, &r->stats->stage_seconds[TS_STAGE_film]); /* before the copy */
        kept = render_keep_samples(r, before);
        /* With no sample in the film yet, the smaller budget may dice at other levels of
         * detail: there is nothing for them to disagree with. */
        if (r->job.samples_done == 0) r->job.check_lod = 0;
        if (!kept || b.mb / 2 < TS_MEMORY_FLOOR_MB) {
            rc = render_give_up(r, &b, kept, err);
            gave_up = 1;
            break;
        }
        if (!r->opt.quiet)
            ts_print_line(
                "tessera: the device could not provide %llu MB (%s); retrying with %llu MB",
                (unsigned long long)b.mb, b.oom.msg, (unsigned long long)(b.mb / 2));
        pipeline_destroy(&r->pipe);
        b.mb /= 2;
        b.room_mb = 0; /* memory ran out: the arenas stay within the smaller budget */
    }
    if (rc && r->job.lod_mismatch && b.oom.code) {
        /* Samples finished before the retry, at levels of detail the smaller budget cannot
         * reproduce: the image would mix them. */
        ts_error_clear(err);
        rc = ts_error_set(err, TS_E_DEVICE,
                          "%s: the device ran out of memory after %llu samples, "
                          "and the budget that fits dices at other levels of detail; render again "
                          "with a lower --memory or --max-lod",
                          b.oom.msg, (unsigned long long)r->job.samples_done);
        gave_up = 1;
    }
    if (rc && gave_up && kept && r->job.samples_done > 0) {
        ts_error_set(&r->stopped, err->code, "%s", err->msg);
        ts_error_clear(err);
        rc = TS_OK;
    }
    return rc;
}

/* The devices --device (or TESSERA_DEVICE) names: one (the device of render_open_device),
 * or several (render_on_devices). Without any OpenCL device, dev_open says so. */
static int render_select_devices(ts_render *r, ts_error *err)
{
    ts_device_info *list = NULL;
    int n = dev_list(&list, err);
    free(list);
    if (n < 0) return err->code;
    r->device_count = 1;
    if (n == 0) return TS_OK;
    if (dev_select(&r->opt.cl, n, r->devices, &r->device_count, err)) return err->code;
    r->opt.cl.device_index = r->devices[0];
    workers_streams(r->devices, &r->device_count, r->opt.streams);
    return TS_OK;
}

static int render_write(ts_render *r, ts_error *err);

/* A stop signal during a render on several devices or ranks: the merged samples
 * [0, samples_done) are written at once, while the devices end their waves (under mpirun
 * a SIGTERM may be followed by SIGKILL within a second, ranks.h). */
static void render_write_early(void *ctx, uint64_t samples_done)
{
    ts_render *r = ctx;
    r->job.samples_done = samples_done;
    r->written = 1;
    render_write(r, &r->early);
}

/* The waiting thread, after each merge of a render on several devices: the EXR's rows whose
 * pixels have every sample merged (pixel after pixel: the samples [0, prefix) are pixels
 * [0, prefix / spp)) written now (output.h), the stream opened first once the frame's
 * levels of detail are recorded (its header carries them). A stream that fails is dropped:
 * render_write writes the image at the end, and reports what still fails then. */
static void render_progress(void *ctx, ts_board *b, ts_workers *g)
{
    ts_render *r = ctx;
    if (r->stream_off) return;
    ts_error e = {0};
    if (!output_stream_is_open(&r->stream) &&
        (workers_lod_state(g) <= 0 || render_hash_ready(r, &e) ||
         output_stream_open(&r->opt, r->width, r->height, &r->job, &r->stream, &e))) {
        r->stream_off = e.code != 0;
        ts_error_clear(&e);
        return;
    }
    /* One band of rows a call at most (about 20 ms at 1920 pixels a row): the waiting thread
     * goes back soon to its other work (an MPI rank 0 polls the other ranks every 2 ms); the
     * calls come after every merge, more often than bands of rows become final. */
    uint64_t pixels = board_prefix(b) / (uint64_t)r->opt.spp;
    if (output_stream_rows(&r->stream, &r->state, &r->scene.camera, (int)(pixels / r->width),
                           TS_OUTPUT_STREAM_ROWS, &e)) {
        output_stream_close(&r->stream, 0, NULL);
        r->stream_off = 1;
        ts_error_clear(&e);
    }
}

/* After the frame on several devices: a stream of a finished frame takes its last rows and
 * becomes the image (r->written); any other is removed, and render_write writes the image. */
static void render_stream_end(ts_render *r, int finished)
{
    if (output_stream_is_open(&r->stream)) {
        ts_error e = {0};
        int commit = finished && !r->written && !r->stream_off &&
                     !output_stream_rows(&r->stream, &r->state, &r->scene.camera, r->height, 0, &e);
        ts_error_clear(&e);
        if (!output_stream_close(&r->stream, commit, commit ? &e : NULL) && commit) r->written = 1;
        ts_error_clear(&e);
    }
    /* its time, also when render_progress dropped it mid-frame */
    r->stats->stage_seconds[TS_STAGE_film] += r->stream.seconds;
    r->stream.seconds = 0;
}

/* The devices of every MPI rank, each rank counted with as many as this one
 * (ts_frame.devices_all). */
static uint32_t render_devices_all(const ts_render *r)
{
    return (uint32_t)r->device_count * (r->ranks ? (uint32_t)r->ranks->size : 1u);
}

/* A device's share of the samples the frame has left: of every device of every MPI rank
 * (ts_frame.share_samples, ts_rank_start.share_samples). */
static uint64_t render_share_samples(const ts_render *r)
{
    uint64_t devices = render_devices_all(r);
    return (r->job.total - r->job.samples_done + devices - 1) / devices;
}

/* The frame on several devices (workers.h): their units merged into r->state. When every
 * device failed after samples were merged, they are kept for render_write (r->stopped says
 * why); with none merged the render fails with the last device's error. */
static int render_on_devices(ts_render *r, ts_error *err)
{
    ts_frame f = {.opt = &r->opt,
                  .scene = &r->scene,
                  .cam = r->cam,
                  .pixel_count = (uint32_t)((uint64_t)r->width * r->height),
                  .job = &r->job,
                  .budget_share = r->ranks ? (uint32_t)r->ranks->node_ranks : 1u};
    uint64_t start = r->job.samples_done;
    if (r->ranks)
        f.unit_samples = r->unit_samples;
    else
        units_plan(r->job.total - start, (uint32_t)r->device_count, &f.unit_samples);
    f.share_samples = render_share_samples(r);
    f.devices_all = render_devices_all(r);
    job_choose_band(&r->job, &r->cam); /* units_list gathers units of whole pixels */
    f.cam = r->cam;
    if (!r->opt.quiet && r->ranks)
        ts_print_line(
            "tessera: %dx%d, %d spp on %d ranks (%d devices on rank 0), in units of %llu samples",
            r->width, r->height, r->opt.spp, r->ranks->size, r->device_count,
            (unsigned long long)f.unit_samples);
    else if (!r->opt.quiet)
        ts_print_line("tessera: %dx%d, %d spp on %d devices, in units of %llu samples", r->width,
                      r->height, r->opt.spp, r->device_count, (unsigned long long)f.unit_samples);
    r->films_on_host = 1;
    interrupt_install();
    ts_frame_end end;
    ts_frame_service service = {0};
#ifdef TESSERA_HAVE_MPI
    if (r->ranks) service = ranks_service(r->ranks, r->stats);
#endif
    service.on_stop = render_write_early;
    service.stop_ctx = r;
    /* The image's rows as they are final (an .exr or a .png: output_check): units follow the
     * pixels (one-pixel bands). */
    r->stream_off = f.cam.band != 1u;
    service.progress = render_progress;
    service.progress_ctx = r;
    int rc =
        workers_render(&f, &r->state, r->devices, r->device_count, &service, r->stats, &end, err);
#ifdef TESSERA_HAVE_MPI
    if (!rc && r->ranks && !interrupt_signal()) rc = ranks_finish(r->ranks, r->stats, err);
#endif
    render_stream_end(r, !rc && !end.all_failed && !interrupt_signal() &&
                             end.samples_done == r->job.total);
    if (rc) {
        ts_error_clear(&end.failure);
        return rc;
    }
    r->job.samples_done = end.samples_done;
    if (end.all_failed && end.samples_done == start) {
        rc = ts_error_set_status(err, end.failure.code ? end.failure.code : TS_E_DEVICE,
                                 end.failure.status, "%s",
                                 end.failure.code ? end.failure.msg : "every device failed");
    } else if (end.all_failed) {
        ts_error_set(&r->stopped, end.failure.code ? end.failure.code : TS_E_DEVICE,
                     "every device failed, the last one with: %s",
                     end.failure.code ? end.failure.msg : "an unknown error");
    }
    ts_error_clear(&end.failure);
    return rc;
}

#ifdef TESSERA_HAVE_MPI
/* Rank 0 of several: tells the other ranks how the frame starts (its size, samples, the
 * units, the camera and the scene), or, when this rank failed (rc) or has nothing to do,
 * that there is no frame. Returns rc, else the broadcast's own status. */
static int render_tell_ranks(ts_render *r, int rc, int up_to_date, ts_error *err)
{
    ts_rank_start s;
    memset(&s, 0, sizeof s);
    s.status = rc || up_to_date;
    s.scene_load = r->opt.mpi_scene_load;
    r->ranks->quiet = r->opt.quiet;
    if (!s.status) {
        s.width = r->width, s.height = r->height, s.spp = r->opt.spp;
        s.job_hash = r->job.hash;
        s.total = r->job.total, s.start = r->job.samples_done;
        units_plan(s.total - s.start, (uint32_t)(r->ranks->size * r->device_count),
                   &r->unit_samples);
        s.unit_samples = r->unit_samples;
        s.share_samples = render_share_samples(r);
        job_choose_band(&r->job, &r->cam);
        s.cam = r->cam;
    }
    int told = ranks_start(r->ranks, &s, &r->scene, err);
    return rc ? rc : told;
}
#endif

/* The image file, timed as part of the film stage. The films are copied to the host and the
 * pipeline released first, so that the budget's memory is free again while the image is
 * encoded (under a memory limit the encoder would otherwise fail). After memory ran out at
 * the smallest budget (r->stopped), r->state already holds the finished samples. */
static int render_write(ts_render *r, ts_error *err)
{
    double t0 = stats_now();
    int rc = TS_OK;
    if (!r->stopped.code && !r->films_on_host)
        rc = film_state_transfer(&r->pipe, &r->state, 0, err);
    pipeline_destroy(&r->pipe);
    if (!rc) rc = render_hash_ready(r, err);
    if (!rc)
        rc = output_write(&r->opt, &r->state, &r->scene.camera, r->width, r->height, &r->job, err);
    r->stats->stage_seconds[TS_STAGE_film] += stats_now() - t0;
    return rc;
}

/* How the render ended, for main() to report. */
static void render_result(const ts_render *r, int up_to_date, ts_render_result *out)
{
    out->samples_total = r->job.total;
    if (up_to_date) {
        out->outcome = TS_RENDER_UP_TO_DATE;
        out->samples_done = r->job.total;
        return;
    }
    out->outcome = r->stopped.code && r->films_on_host  ? TS_RENDER_DEVICES_FAILED
                   : r->stopped.code                    ? TS_RENDER_OUT_OF_MEMORY
                   : r->job.samples_done < r->job.total ? TS_RENDER_INTERRUPTED
                                                        : TS_RENDER_COMPLETE;
    out->samples_done = r->job.samples_done;
    out->signal = interrupt_signal();
    snprintf(out->reason, sizeof out->reason, "%s", r->stopped.msg);
}

int render_run(const ts_render_options *o, ts_ranks *ranks, ts_stats *stats,
               ts_render_result *result, ts_error *err)
{
    double t0 = stats_now();
    memset(result, 0, sizeof *result);
    ts_render r;
    render_init(&r, o, stats);
    r.ranks = ranks && ranks->size > 1 ? ranks : NULL;
    int up_to_date = 0;
    int rc = output_check(o, err);
    if (!rc) rc = render_load_scene(&r, err);
    if (r.ranks) r.ranks->scene_seconds = stats_now() - t0;
    if (!rc) rc = output_check_inputs(o, &r.scene, err);
    if (!rc && o->occlusion_path) rc = render_load_occlusion(&r, err);
    if (!rc) rc = render_start_job(&r, err);
    if (!rc && o->resume)
        rc = resume_load(&r.opt, r.width, r.height, &r.scene, &r.cam, &r.job, &r.state, &up_to_date,
                         err);
    /* The host copy of the films (48 bytes a pixel), its pages touched while the devices open
     * (render_films_touch), where it takes at most half the memory there is room for; else,
     * or where it cannot be had yet, below, after the device's own checks (a film larger than
     * its largest buffer is the error to report first, not a failed allocation). */
    if (!rc && !up_to_date && !r.state.accum) {
        ts_memory_room room;
        ts_memory_room_query(NULL, &room);
        uint64_t bytes = 3u * sizeof(ts_vec4) * (uint64_t)r.width * (uint64_t)r.height;
        ts_error e = {0};
        if (bytes <= room.bytes / 2 &&
            film_state_alloc(&r.state, (size_t)r.width * r.height, &e) == TS_OK)
            render_films_touch(&r);
        ts_error_clear(&e);
    }
    if (!rc && !up_to_date) rc = render_select_devices(&r, err);
#ifdef TESSERA_HAVE_MPI
    if (r.ranks) rc = render_tell_ranks(&r, rc, up_to_date, err);
#endif
    /* One device traces from the first sample the film lacks on: when --resume found an
     * image whose samples are not such a prefix (units of several devices or ranks merged
     * past a gap), the units the film lacks go through the board, one device or several. */
    int alone = r.device_count == 1 && !r.ranks && done_is_prefix(&r.job.done);
    if (!rc && !up_to_date && alone) rc = render_open_device(&r, err);
    render_films_touched(&r);
    /* Before the device takes its budget: the retry and the image write need the host copy
     * when memory is scarcest. --resume or render_films_touch's allocation made it. */
    if (!rc && !up_to_date && !r.state.accum)
        rc = film_state_alloc(&r.state, (size_t)r.width * r.height, err);
    if (!rc && !up_to_date && alone) {
        render_writer_start(&r);
        rc = render_with_retry(&r, err);
        render_writer_finish(&r, rc == TS_OK);
    } else if (!rc && !up_to_date) {
        rc = render_on_devices(&r, err);
    }
    if (!rc && !up_to_date && !r.written) rc = render_write(&r, err);
    if (!rc && r.early.code) rc = ts_error_set(err, r.early.code, "%s", r.early.msg);
    if (!rc) render_result(&r, up_to_date, result);
    interrupt_restore(); /* after the write: a signal until then only stops the waves */
    render_free(&r);
    stats->wall_seconds = stats_now() - t0;
    return rc;
}
