#include "app/render.h"
#include "base/hash.h"
#include "base/mat4.h"
#include "image/image.h"
#include "pipeline/pipeline.h"
#include "scene/rib/rib.h"

#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

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

/* What identifies a render and how far it got; stored as EXR metadata for --resume. */
typedef struct ts_job {
    uint64_t total;        /* width * height * spp global samples */
    uint64_t samples_done; /* the film holds samples [0, samples_done) */
    int32_t hash;          /* the scene and the options that change the image */
    int32_t lod;           /* the per-patch levels of detail of the frame (lod stage) */
    int check_lod;         /* 1: lod is that of the samples already in the film */
    uint32_t max_lod;      /* the plan's finest m when lod was taken */
    int lod_mismatch;      /* set by render_waves when the check failed */
} ts_job;

/* Host copies of the films (accum, aov_film, albedo_film: pixel_count ts_vec4 each). */
typedef struct ts_film_state {
    ts_vec4 *accum, *aov, *albedo;
} ts_film_state;

static void film_state_free(ts_film_state *s)
{
    free(s->accum), free(s->aov), free(s->albedo);
    memset(s, 0, sizeof *s);
}

static int film_state_alloc(ts_film_state *s, size_t npix, ts_error *err)
{
    s->accum = calloc(npix, sizeof(ts_vec4));
    s->aov = calloc(npix, sizeof(ts_vec4));
    s->albedo = calloc(npix, sizeof(ts_vec4));
    if (!s->accum || !s->aov || !s->albedo) {
        film_state_free(s);
        return ts_error_set(err, TS_E_MEMORY, "out of memory (film)");
    }
    return TS_OK;
}

/* Copies the films to the device (upload) or from it, blocking. */
static int film_transfer(ts_pipeline *p, ts_film_state *s, int upload, ts_error *err)
{
    size_t bytes = (size_t)p->pixel_count * sizeof(ts_vec4);
    cl_mem dev[3] = {p->accum, p->aov_film, p->albedo_film};
    ts_vec4 *host[3] = {s->accum, s->aov, s->albedo};
    for (int i = 0; i < 3; ++i) {
        cl_int rc = upload ? clEnqueueWriteBuffer(p->cl->queue, dev[i], CL_TRUE, 0, bytes, host[i],
                                                  0, NULL, NULL)
                           : clEnqueueReadBuffer(p->cl->queue, dev[i], CL_TRUE, 0, bytes, host[i],
                                                 0, NULL, NULL);
        if (rc != CL_SUCCESS)
            return ts_error_set(
                err, TS_E_DEVICE, "%s in %s (copying the image %s the device)", dev_error_name(rc),
                upload ? "clEnqueueWriteBuffer" : "clEnqueueReadBuffer", upload ? "to" : "from");
    }
    return TS_OK;
}

/* Extra EXR channels of a partial image: the raw per-pixel sums and sample counts, which
 * --resume loads back into the film (the means R, G, B cannot give the sums bit for bit). */
static const char *const partial_channels[4] = {"tessera.sum.R", "tessera.sum.G", "tessera.sum.B",
                                                "tessera.count"};

/* Reads the film back and writes the image (EXR with AOVs, or tone-mapped PNG). An EXR of
 * an unfinished render (job->samples_done < job->total) also gets the partial channels. */
static int write_output(const ts_render_options *o, ts_pipeline *p, int width, int height,
                        const ts_job *job, ts_error *err)
{
    size_t npix = (size_t)width * height;
    int partial = job->samples_done < job->total;
    ts_vec4 *acc = malloc(npix * sizeof *acc), *aov = malloc(npix * sizeof *aov);
    ts_vec4 *alb = malloc(npix * sizeof *alb);
    float *px = malloc(npix * 14 * sizeof *px);
    int rc = TS_OK;
    if (!acc || !aov || !alb || !px) rc = ts_error_set(err, TS_E_MEMORY, "out of memory (image)");
    cl_command_queue q = p->cl->queue;
    if (!rc &&
        (clEnqueueReadBuffer(q, p->accum, CL_TRUE, 0, npix * sizeof *acc, acc, 0, NULL, NULL) ||
         clEnqueueReadBuffer(q, p->aov_film, CL_TRUE, 0, npix * sizeof *aov, aov, 0, NULL, NULL) ||
         clEnqueueReadBuffer(q, p->albedo_film, CL_TRUE, 0, npix * sizeof *alb, alb, 0, NULL,
                             NULL)))
        rc = ts_error_set(err, TS_E_DEVICE, "reading the image back from the device failed");
    const char *ext = strrchr(o->output_path, '.');
    int exr = ext && strcmp(ext, ".exr") == 0;
    int nch = exr ? (partial ? 14 : 10) : 3;
    for (size_t i = 0; !rc && i < npix; ++i) {
        float inv = acc[i].w > 0 ? 1.0f / acc[i].w : 0.0f;
        float v[14] = {acc[i].x * inv, acc[i].y * inv, acc[i].z * inv, aov[i].w, aov[i].x,
                       aov[i].y,       aov[i].z,       alb[i].x,       alb[i].y, alb[i].z,
                       acc[i].x,       acc[i].y,       acc[i].z,       acc[i].w};
        if (aov[i].w == 0.0f && acc[i].w == 0.0f) v[3] = INFINITY; /* never sampled */
        memcpy(&px[i * nch], v, nch * sizeof(float));
    }
    if (!rc && exr) {
        const char *names[] = {"R",
                               "G",
                               "B",
                               "Z",
                               "N.x",
                               "N.y",
                               "N.z",
                               "albedo.R",
                               "albedo.G",
                               "albedo.B",
                               partial_channels[0],
                               partial_channels[1],
                               partial_channels[2],
                               partial_channels[3]};
        ts_image img = {width, height, nch, names, px};
        /* samples_done < 2^32 (the kernels index samples with 32 bits): stored as its
         * 32-bit pattern in an int attribute. */
        ts_image_meta meta[] = {{"tessera:spp", o->spp},
                                {"tessera:max_lod", (int)p->plan.max_lod},
                                {"tessera:samples_done", (int)(uint32_t)job->samples_done},
                                {"tessera:seed", (int)o->seed},
                                {"tessera:job", job->hash},
                                {"tessera:lod", job->lod}};
        rc = image_write_exr(o->output_path, &img, meta, (int)(sizeof meta / sizeof *meta), err);
    } else if (!rc) {
        rc = image_write_png(o->output_path, width, height, px, err);
    }
    free(acc), free(aov), free(alb), free(px);
    return rc;
}

static int check_output_path(const char *path, ts_error *err)
{
    const char *ext = path ? strrchr(path, '.') : NULL;
    if (!path) return ts_error_set(err, TS_E_USAGE, "no output file: give -o OUT.png or OUT.exr");
    if (!ext || (strcmp(ext, ".exr") != 0 && strcmp(ext, ".png") != 0))
        return ts_error_set(err, TS_E_USAGE, "%s: the output must end in .exr or .png", path);
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

static int32_t fold32(uint64_t h)
{
    return (int32_t)(uint32_t)(h ^ (h >> 32));
}

/* The levels of detail the frame's patches are diced at: what the lod stage decided, or
 * --lod (clamped to the plan like trace.c does). */
static int32_t lod_hash(const ts_pipeline *p, const ts_render_options *o)
{
    uint64_t h = TS_FNV1A_INIT;
    if (o->fixed_lod >= 0) {
        uint32_t m =
            (uint32_t)o->fixed_lod < p->plan.max_lod ? (uint32_t)o->fixed_lod : p->plan.max_lod;
        return fold32(ts_fnv1a(h, &m, sizeof m));
    }
    return fold32(ts_fnv1a(h, p->patch_lod, p->scene->patch_count));
}

/* The job: a hash of the scene file's bytes, the geometry it loaded (archives included),
 * the camera and every option that changes the image (not --memory: the image does not
 * depend on it, and the lod check covers the one way it could). */
static int job_hash(const ts_render_options *o, const ts_scene *s, const ts_camera_params *cam,
                    int32_t *out, ts_error *err)
{
    uint64_t h = TS_FNV1A_INIT;
    FILE *f = fopen(o->scene_path, "rb");
    if (!f) return ts_error_set(err, TS_E_IO, "%s: %s", o->scene_path, strerror(errno));
    unsigned char buf[65536];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, f)) > 0)
        h = ts_fnv1a(h, buf, n);
    fclose(f);
    int32_t opts[] = {
        (int32_t)cam->width, (int32_t)cam->height, o->spp,       o->depth, (int32_t)o->seed,
        o->sampling,         o->max_lod,           o->fixed_lod, o->exact};
    h = ts_fnv1a(h, opts, sizeof opts);
    h = ts_fnv1a(h, cam, sizeof *cam);
    h = ts_fnv1a(h, &s->patch_count, sizeof s->patch_count);
    h = ts_fnv1a(h, s->cp, (size_t)s->patch_count * 16 * sizeof(ts_vec4));
    if (s->cp1) h = ts_fnv1a(h, s->cp1, (size_t)s->patch_count * 16 * sizeof(ts_vec4));
    if (s->corner_n) h = ts_fnv1a(h, s->corner_n, (size_t)s->patch_count * 4 * sizeof(ts_vec4));
    for (uint32_t i = 0; i < s->patch_count; ++i) {
        ts_patch_attr a = s->attr[i];
        a.pad[0] = a.pad[1] = 0;
        h = ts_fnv1a(h, &a, sizeof a);
    }
    if (s->texture_count) { /* texel contents, not file names */
        h = ts_fnv1a(h, s->textures, (size_t)s->texture_count * sizeof(ts_texture));
        h = ts_fnv1a(h, s->tex_pool,
                     (size_t)s->tex_tile_count * TS_TEX_TILE * TS_TEX_TILE * sizeof(ts_vec4));
    }
    if (s->xform) h = ts_fnv1a(h, s->xform, (size_t)s->xform_count * sizeof(ts_xform));
    for (uint32_t i = 0; i < s->light_count; ++i)
        h = ts_fnv1a(h, &s->lights[i], sizeof s->lights[i]);
    double dome[4] = {s->dome.present, s->dome.intensity, s->dome.color[0], s->dome.color[1]};
    h = ts_fnv1a(h, dome, sizeof dome);
    h = ts_fnv1a(h, &s->dome.color[2], sizeof s->dome.color[2]);
    *out = fold32(h);
    return TS_OK;
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
    int32_t lod = lod_hash(p, o);
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

/* --resume: loads the partial EXR at output_path into state and job (samples_done, lod).
 * No file: state stays empty (render from the start). A complete image: *complete = 1. */
static int resume_load(const ts_render_options *o, int width, int height, ts_job *job,
                       ts_film_state *state, int *complete, ts_error *err)
{
    const char *path = o->output_path;
    struct stat st;
    if (stat(path, &st) != 0 && errno == ENOENT) {
        if (!o->quiet)
            fprintf(stderr, "tessera: %s does not exist yet: rendering from the start\n", path);
        return TS_OK;
    }
    ts_error e = {0};
    ts_image img;
    if (image_read(path, &img, &e)) {
        ts_error_set(err, TS_E_IO,
                     "%s (cannot resume from it; render without --resume to start again)", e.msg);
        ts_error_clear(&e);
        return err->code;
    }
    static const char *keys[] = {"tessera:samples_done", "tessera:spp", "tessera:seed",
                                 "tessera:job",          "tessera:lod", "tessera:max_lod"};
    int v[6] = {0};
    int rc = TS_OK;
    for (int k = 0; k < 6 && !rc; ++k)
        if (image_read_meta_int(path, keys[k], &v[k], &e))
            rc = ts_error_set(
                err, TS_E_USAGE,
                "%s: cannot resume: it has no \"%s\" metadata (not from tessera render, "
                "or from an older version); render without --resume",
                path, keys[k]);
    ts_error_clear(&e);
    uint64_t done = (uint32_t)v[0];
    if (!rc && (img.width != width || img.height != height))
        rc = ts_error_set(err, TS_E_USAGE,
                          "%s: cannot resume: it is %dx%d but this command renders "
                          "%dx%d (use the original command, or render without --resume)",
                          path, img.width, img.height, width, height);
    if (!rc && v[1] != o->spp)
        rc = ts_error_set(
            err, TS_E_USAGE,
            "%s: cannot resume: it was rendered with --spp %d, this "
            "command has --spp %d (use the original command, or render without --resume)",
            path, v[1], o->spp);
    if (!rc && (unsigned)v[2] != o->seed)
        rc = ts_error_set(
            err, TS_E_USAGE,
            "%s: cannot resume: it was rendered with --seed %d, this "
            "command has --seed %u (use the original command, or render without --resume)",
            path, v[2], o->seed);
    if (!rc && v[3] != job->hash)
        rc = ts_error_set(
            err, TS_E_USAGE,
            "%s: cannot resume: it was rendered from another scene "
            "or with other --depth, --sampling, --max-lod, --lod or --intersect options "
            "(use the original command, or render without --resume)",
            path);
    if (!rc && done > job->total)
        rc = ts_error_set(err, TS_E_USAGE, "%s: cannot resume: it claims %llu samples of %llu",
                          path, (unsigned long long)done, (unsigned long long)job->total);
    if (!rc && done == job->total) *complete = 1;
    int idx[14];
    static const char *names[14] = {"R",
                                    "G",
                                    "B",
                                    "Z",
                                    "N.x",
                                    "N.y",
                                    "N.z",
                                    "albedo.R",
                                    "albedo.G",
                                    "albedo.B",
                                    "tessera.sum.R",
                                    "tessera.sum.G",
                                    "tessera.sum.B",
                                    "tessera.count"};
    for (int c = 0; c < 14 && !rc && !*complete; ++c) {
        idx[c] = -1;
        for (int k = 0; k < img.channels; ++k)
            if (strcmp(img.channel_names[k], names[c]) == 0) idx[c] = k;
        if (idx[c] < 0)
            rc = ts_error_set(err, TS_E_USAGE, "%s: cannot resume: it has no \"%s\" channel", path,
                              names[c]);
    }
    size_t npix = (size_t)width * height;
    if (!rc && !*complete) rc = film_state_alloc(state, npix, err);
    for (size_t i = 0; !rc && !*complete && i < npix; ++i) {
        const float *px = &img.pixels[i * (size_t)img.channels];
        float count = px[idx[13]];
        /* The film holds sample 0's AOVs once the pixel has a sample, else zeros (which
         * write_output turned into Z = +inf). */
        state->accum[i] = (ts_vec4){px[idx[10]], px[idx[11]], px[idx[12]], count};
        if (count > 0) {
            state->aov[i] = (ts_vec4){px[idx[4]], px[idx[5]], px[idx[6]], px[idx[3]]};
            state->albedo[i] = (ts_vec4){px[idx[7]], px[idx[8]], px[idx[9]], 0.0f};
        }
    }
    image_free(&img);
    if (!rc && !*complete) {
        job->samples_done = done;
        job->lod = v[4];
        job->max_lod = (uint32_t)v[5];
        job->check_lod = 1;
        if (!o->quiet)
            fprintf(stderr, "tessera: resuming %s at sample %llu of %llu\n", path,
                    (unsigned long long)done, (unsigned long long)job->total);
    }
    if (rc) film_state_free(state);
    return rc;
}

/* The smallest budget a retry after an out-of-memory error tries. */
#define TS_MEMORY_FLOOR_MB 16

int render_run(const ts_render_options *o, ts_stats *stats, ts_render_result *result, ts_error *err)
{
    double t0 = stats_now();
    memset(result, 0, sizeof *result);
    if (check_output_path(o->output_path, err)) return err->code;
    const char *ext = strrchr(o->output_path, '.');
    if (o->resume && strcmp(ext, ".exr") != 0)
        return ts_error_set(err, TS_E_USAGE,
                            "--resume needs an .exr output (a PNG cannot hold "
                            "the sums of the samples)");
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
        if (!rc && state.accum) rc = film_transfer(&pipe, &state, 1, err);
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
            if (kept) kept = film_transfer(&pipe, &state, 0, err) == TS_OK;
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
        rc = write_output(o, &pipe, width, height, &job, err);
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
