#include "render.h"
#include "image.h"
#include "pipeline.h"
#include "rib.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void render_options_defaults(ts_render_options *o)
{
    memset(o, 0, sizeof *o);
    o->spp = 1;
    o->depth = 3;
    o->seed = 0;
    o->max_lod = 10;
    o->fixed_lod = -1;
    o->exact = 0;
    o->memory_mb = 1024;
    o->cl.device_index = -1;
}

/* Inverts a row-major 4x4 matrix (Gauss-Jordan with partial pivoting). Returns 0 if
 * singular. */
static int mat4_invert(const double m[16], double out[16])
{
    double a[4][8];
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 8; ++c) a[r][c] = c < 4 ? m[r * 4 + c] : (c - 4 == r);
    for (int c = 0; c < 4; ++c) {
        int piv = c;
        for (int r = c + 1; r < 4; ++r)
            if (fabs(a[r][c]) > fabs(a[piv][c])) piv = r;
        if (fabs(a[piv][c]) < 1e-300) return 0;
        for (int k = 0; k < 8; ++k) {
            double t = a[c][k];
            a[c][k] = a[piv][k];
            a[piv][k] = t;
        }
        double inv = 1.0 / a[c][c];
        for (int k = 0; k < 8; ++k) a[c][k] *= inv;
        for (int r = 0; r < 4; ++r) {
            if (r == c) continue;
            double f = a[r][c];
            for (int k = 0; k < 8; ++k) a[r][k] -= f * a[c][k];
        }
    }
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) out[r * 4 + c] = a[r][c + 4];
    return 1;
}

/* Linear part of row-major m applied to (x, y, z), written as float[4] with w = 0. */
static void mat4_apply_dir(const double m[16], double x, double y, double z, float out[4])
{
    for (int r = 0; r < 3; ++r) out[r] = (float)(m[r * 4 + 0] * x + m[r * 4 + 1] * y + m[r * 4 + 2] * z);
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
    for (int r = 0; r < 3; ++r) out->origin[r] = (float)inv[r * 4 + 3];
    mat4_apply_dir(inv, hx, 0, 0, out->right);
    mat4_apply_dir(inv, 0, hy, 0, out->up);
    mat4_apply_dir(inv, 0, 0, 1, out->forward);
    out->width = (uint32_t)width;
    out->height = (uint32_t)height;
    return TS_OK;
}

/* Reads the film back and writes the image (EXR with AOVs, or tone-mapped PNG). */
static int write_output(const ts_render_options *o, ts_pipeline *p, int width, int height,
                        ts_error *err)
{
    size_t npix = (size_t)width * height;
    ts_vec4 *acc = malloc(npix * sizeof *acc), *aov = malloc(npix * sizeof *aov);
    ts_vec4 *alb = malloc(npix * sizeof *alb);
    float *px = malloc(npix * 10 * sizeof *px);
    int rc = TS_OK;
    if (!acc || !aov || !alb || !px) rc = ts_error_set(err, TS_E_MEMORY, "out of memory (image)");
    cl_command_queue q = p->cl->queue;
    if (!rc && (clEnqueueReadBuffer(q, p->accum, CL_TRUE, 0, npix * sizeof *acc, acc, 0, NULL, NULL) ||
                clEnqueueReadBuffer(q, p->aov_film, CL_TRUE, 0, npix * sizeof *aov, aov, 0, NULL, NULL) ||
                clEnqueueReadBuffer(q, p->albedo_film, CL_TRUE, 0, npix * sizeof *alb, alb, 0, NULL, NULL)))
        rc = ts_error_set(err, TS_E_DEVICE, "reading the image back from the device failed");
    const char *ext = strrchr(o->output_path, '.');
    int exr = ext && strcmp(ext, ".exr") == 0;
    for (size_t i = 0; !rc && i < npix; ++i) {
        float inv = acc[i].w > 0 ? 1.0f / acc[i].w : 0.0f;
        float v[10] = {acc[i].x * inv, acc[i].y * inv, acc[i].z * inv, aov[i].w,
                       aov[i].x, aov[i].y, aov[i].z, alb[i].x, alb[i].y, alb[i].z};
        if (aov[i].w == 0.0f && acc[i].w == 0.0f) v[3] = INFINITY; /* never sampled */
        memcpy(exr ? &px[i * 10] : &px[i * 3], v, (exr ? 10 : 3) * sizeof(float));
    }
    if (!rc && exr) {
        const char *names[] = {"R", "G", "B", "Z", "N.x", "N.y", "N.z", "albedo.R", "albedo.G", "albedo.B"};
        ts_image img = {width, height, 10, names, px};
        ts_image_meta meta[] = {{"tessera:spp", o->spp}, {"tessera:max_lod", (int)p->plan.max_lod}};
        rc = image_write_exr(o->output_path, &img, meta, 2, err);
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
static int render_paths(const ts_render_options *o, ts_pipeline *p, uint32_t first,
                        uint32_t n, ts_error *err)
{
    ts_shade_params sp = {.light_count = p->light_count, .depth = (uint32_t)o->depth,
                          .sampling = (uint32_t)o->sampling, .seed = o->seed,
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

/* Runs the waves: each is a run of global sample indices [first, first + rays). */
static int render_waves(const ts_render_options *o, ts_pipeline *p, ts_camera_params cam,
                        ts_error *err)
{
    uint64_t total = (uint64_t)cam.width * cam.height * (uint64_t)o->spp;
    uint32_t per_wave = p->plan.ray_capacity / 2; /* each path also owns a shadow-ray slot */
    p->mode = (ts_trace_mode){(uint32_t)o->spp, o->fixed_lod, o->exact};
    double t0 = stats_now();
    if (o->fixed_lod < 0 && render_lod(p, cam, total, err)) return err->code;
    for (uint64_t first = 0; first < total; first += per_wave) {
        uint32_t n = (uint32_t)(total - first < per_wave ? total - first : per_wave);
        cam.first_sample = (uint32_t)first;
        cam.ray_count = n;
        if (pipeline_camera(p, &cam, err) || render_paths(o, p, (uint32_t)first, n, err))
            return err->code;
        if (!o->quiet) {
            double dt = stats_now() - t0, done = (double)(first + n);
            double rays = (double)(p->stats->counters[TS_COUNTER_rays] + p->stats->counters[TS_COUNTER_shadow_rays]);
            fprintf(stderr, "\rtessera: %llu / %llu samples, %.2f Mrays/s, ETA %.0f s   ",
                    (unsigned long long)(first + n), (unsigned long long)total,
                    dt > 0 ? rays / dt / 1e6 : 0.0, dt * (total - done) / done);
        }
    }
    if (!o->quiet) fputc('\n', stderr);
    return TS_OK;
}

int render_run(const ts_render_options *o, ts_stats *stats, ts_error *err)
{
    double t0 = stats_now();
    if (check_output_path(o->output_path, err)) return err->code;
    ts_scene scene;
    memset(&scene, 0, sizeof scene);
    ts_cl cl;
    memset(&cl, 0, sizeof cl);
    ts_pipeline pipe;
    memset(&pipe, 0, sizeof pipe);
    int rc = scene_load(o->scene_path, &scene, o->quiet, err);
    int width = o->width ? o->width : scene.camera.has_format ? scene.camera.width : 640;
    int height = o->height ? o->height : scene.camera.has_format ? scene.camera.height : 480;
    ts_camera_params cam;
    ts_pipeline_plan plan;
    if (!rc) rc = render_camera_params(&scene.camera, width, height, &cam, err);
    if (!rc) rc = cl_open(&cl, &o->cl, err);
    if (!rc) {
        snprintf(stats->device, sizeof stats->device, "%.120s (%.120s)", cl.info.name, cl.info.platform_name);
        stats->kernel_build_seconds = cl.build_seconds;
        stats->kernel_cache_hit = cl.cache_hit;
        uint64_t rays = 2 * (uint64_t)width * height * (uint64_t)o->spp; /* + shadow slots */
        rc = pipeline_plan((uint64_t)o->memory_mb << 20, rays, (uint32_t)o->max_lod,
                           cl.info.max_alloc, &plan, err);
    }
    if (!rc && !o->quiet && plan.max_lod < (uint32_t)o->max_lod)
        fprintf(stderr, "tessera: --memory %d MB holds patches up to m = %u; dicing at most that "
                        "finely (raise --memory for --max-lod %d)\n",
                o->memory_mb, plan.max_lod, o->max_lod);
    if (!rc) rc = pipeline_create(&pipe, &cl, &scene, &plan, (uint32_t)(width * height), stats, err);
    if (!rc) {
        cam.spp = (uint32_t)o->spp;
        cam.seed = o->seed;
        rc = render_waves(o, &pipe, cam, err);
    }
    if (!rc) {
        double tw = stats_now();
        rc = write_output(o, &pipe, width, height, err);
        stats->stage_seconds[TS_STAGE_film] += stats_now() - tw;
    }
    pipeline_destroy(&pipe);
    cl_close(&cl);
    scene_free(&scene);
    stats->wall_seconds = stats_now() - t0;
    return rc;
}
