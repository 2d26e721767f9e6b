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

static void normalize3(float v[3])
{
    float l = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (l > 0) v[0] /= l, v[1] /= l, v[2] /= l;
}

ts_shade_params render_shade_params(const ts_scene *scene, const ts_camera_params *cam)
{
    ts_shade_params s;
    memset(&s, 0, sizeof s);
    if (scene->light_count > 0) {
        const ts_distant_light *l = &scene->lights[0];
        for (int k = 0; k < 3; ++k) {
            s.light_dir[k] = (float)(l->from[k] - l->to[k]);
            s.light_color[k] = (float)(l->intensity * l->color[k]);
        }
    } else {
        /* From above-left of the camera, a little from behind it. */
        for (int k = 0; k < 3; ++k) {
            s.light_dir[k] = -0.5f * cam->right[k] + 1.0f * cam->up[k] - 0.7f * cam->forward[k];
            s.light_color[k] = 1.0f;
        }
    }
    normalize3(s.light_dir);
    for (int k = 0; k < 3; ++k) s.ambient[k] = 0.08f;
    return s;
}

/* Reads the film back and writes the image (EXR with AOVs, or tone-mapped PNG). */
static int write_output(const ts_render_options *o, ts_pipeline *p, int width, int height,
                        ts_error *err)
{
    size_t npix = (size_t)width * height;
    ts_vec4 *acc = malloc(npix * sizeof *acc), *aov = malloc(npix * sizeof *aov);
    float *px = malloc(npix * 7 * sizeof *px);
    int rc = TS_OK;
    if (!acc || !aov || !px) rc = ts_error_set(err, TS_E_MEMORY, "out of memory (image)");
    cl_command_queue q = p->cl->queue;
    if (!rc && (clEnqueueReadBuffer(q, p->accum, CL_TRUE, 0, npix * sizeof *acc, acc, 0, NULL, NULL) ||
                clEnqueueReadBuffer(q, p->aov_film, CL_TRUE, 0, npix * sizeof *aov, aov, 0, NULL, NULL)))
        rc = ts_error_set(err, TS_E_DEVICE, "reading the image back from the device failed");
    const char *ext = strrchr(o->output_path, '.');
    int exr = ext && strcmp(ext, ".exr") == 0;
    for (size_t i = 0; !rc && i < npix; ++i) {
        float inv = acc[i].w > 0 ? 1.0f / acc[i].w : 0.0f;
        float v[7] = {acc[i].x * inv, acc[i].y * inv, acc[i].z * inv, aov[i].w,
                      aov[i].x, aov[i].y, aov[i].z};
        if (aov[i].w == 0.0f && acc[i].w == 0.0f) v[3] = INFINITY; /* never sampled */
        memcpy(exr ? &px[i * 7] : &px[i * 3], v, (exr ? 7 : 3) * sizeof(float));
    }
    if (!rc && exr) {
        const char *names[] = {"R", "G", "B", "Z", "N.x", "N.y", "N.z"};
        ts_image img = {width, height, 7, names, px};
        ts_image_meta meta[] = {{"tessera:spp", o->spp}, {"tessera:max_lod", (int)p->plan.max_lod}};
        rc = image_write_exr(o->output_path, &img, meta, 2, err);
    } else if (!rc) {
        rc = image_write_png(o->output_path, width, height, px, err);
    }
    free(acc), free(aov), free(px);
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

/* Runs the waves: each is a run of global sample indices [first, first + rays). */
static int render_waves(const ts_render_options *o, ts_pipeline *p, ts_camera_params cam,
                        const ts_shade_params *shade, ts_error *err)
{
    uint64_t total = (uint64_t)cam.width * cam.height * (uint64_t)o->spp;
    uint32_t per_wave = p->plan.ray_capacity;
    p->mode = (ts_trace_mode){(uint32_t)o->spp, o->fixed_lod, o->exact};
    if (o->fixed_lod < 0 && render_lod(p, cam, total, err)) return err->code;
    for (uint64_t first = 0; first < total; first += per_wave) {
        uint32_t n = (uint32_t)(total - first < per_wave ? total - first : per_wave);
        cam.first_sample = (uint32_t)first;
        cam.ray_count = n;
        if (pipeline_camera(p, &cam, err) || pipeline_trace(p, n, err) ||
            pipeline_shade_film(p, shade, (uint32_t)first, n, err))
            return err->code;
        if (!o->quiet)
            fprintf(stderr, "\rtessera: %llu / %llu samples traced", (unsigned long long)(first + n),
                    (unsigned long long)total);
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
    int rc = rib_load(o->scene_path, &scene, o->quiet, err);
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
        uint64_t rays = (uint64_t)width * height * (uint64_t)o->spp;
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
        ts_shade_params shade = render_shade_params(&scene, &cam);
        rc = render_waves(o, &pipe, cam, &shade, err);
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
