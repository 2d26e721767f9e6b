/* output.c — the image `tessera render` writes (output.h): every channel of
 * ts_exr_channel computed per pixel from the three films, then an EXR or a PNG. */
#include "app/output.h"
#include "base/file.h"
#include "base/stats.h"
#include "image/image.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

int output_check(const ts_render_options *o, ts_error *err)
{
    const char *path = o->output_path, *ext = path ? strrchr(path, '.') : NULL;
    if (!path || !*path)
        return ts_error_set(err, TS_E_USAGE, "no output file: give -o OUT.png or OUT.exr");
    if (!ext || (strcmp(ext, ".exr") != 0 && strcmp(ext, ".png") != 0))
        return ts_error_set(err, TS_E_USAGE, "%s: the output must end in .exr or .png", path);
    if (ext == path || ext[-1] == '/') /* "-o .png": a hidden file with no name */
        return ts_error_set(err, TS_E_USAGE, "%s: the output needs a name before %s", path, ext);
    if (o->resume && strcmp(ext, ".exr") != 0)
        return ts_error_set(err, TS_E_USAGE,
                            "--resume needs an .exr output (a PNG cannot hold "
                            "the sums of the samples)");
    return output_check_paths(path, o->stats_path, o->scene_path, err);
}

int output_check_paths(const char *path, const char *stats, const char *scene_path, ts_error *err)
{
    if (ts_file_check_writable(path, err) || (stats && ts_file_check_writable(stats, err)))
        return err->code;
    if (stats && ts_file_same(stats, path))
        return ts_error_set(err, TS_E_USAGE,
                            "%s: --stats and -o name the same file (the JSON would replace the "
                            "image)",
                            stats);
    if (ts_file_same(path, scene_path))
        return ts_error_set(err, TS_E_USAGE,
                            "%s: -o names the scene file (it would be overwritten)", path);
    if (stats && ts_file_same(stats, scene_path))
        return ts_error_set(err, TS_E_USAGE,
                            "%s: --stats names the scene file (it would be overwritten)", stats);
    return TS_OK;
}

/* Fails when the output or the stats file is input, a file the scene read. */
static int output_check_input(const char *output_path, const char *stats_path, const char *input,
                              const char *what, ts_error *err)
{
    if (ts_file_same(output_path, input))
        return ts_error_set(err, TS_E_USAGE,
                            "%s: -o names %s the scene reads (it would be "
                            "overwritten)",
                            output_path, what);
    if (stats_path && ts_file_same(stats_path, input))
        return ts_error_set(err, TS_E_USAGE,
                            "%s: --stats names %s the scene reads (it would be "
                            "overwritten)",
                            stats_path, what);
    return TS_OK;
}

int output_check_inputs(const ts_render_options *o, const ts_scene *scene, ts_error *err)
{
    const char *occ = o->occlusion_path;
    if (occ && ts_file_same(o->output_path, occ))
        return ts_error_set(err, TS_E_USAGE,
                            "%s: -o names the --occlusion file (it would be overwritten)",
                            o->output_path);
    if (occ && o->stats_path && ts_file_same(o->stats_path, occ))
        return ts_error_set(err, TS_E_USAGE,
                            "%s: --stats names the --occlusion file (it would be overwritten)",
                            o->stats_path);
    return output_check_inputs_paths(o->output_path, o->stats_path, scene, err);
}

int output_check_inputs_paths(const char *out, const char *stats, const ts_scene *scene,
                              ts_error *err)
{
    for (uint32_t i = 0; i < scene->texture_count; ++i)
        if (output_check_input(out, stats, scene->tex_source[i], "a texture", err))
            return err->code;
    for (uint32_t i = 0; i < scene->input_count; ++i)
        if (output_check_input(out, stats, scene->input_source[i], "a file", err)) return err->code;
    if (scene->dome.present && scene->dome.mapname[0] &&
        output_check_input(out, stats, scene->dome.mapname, "the environment map", err))
        return err->code;
    return TS_OK;
}

/* One pixel's channels (ts_exr_channel order) from its accum, aov_film and albedo_film. */
static void output_pixel(ts_vec4 acc, ts_vec4 aov, ts_vec4 alb, float v[TS_EXR_PARTIAL_CHANNELS])
{
    float inv = acc.w > 0 ? 1.0f / acc.w : 0.0f;
    v[TS_EXR_R] = acc.x * inv;
    v[TS_EXR_G] = acc.y * inv;
    v[TS_EXR_B] = acc.z * inv;
    v[TS_EXR_Z] = aov.w == 0.0f && acc.w == 0.0f ? INFINITY : aov.w; /* never sampled */
    v[TS_EXR_N_X] = aov.x;
    v[TS_EXR_N_Y] = aov.y;
    v[TS_EXR_N_Z] = aov.z;
    v[TS_EXR_ALBEDO_R] = alb.x;
    v[TS_EXR_ALBEDO_G] = alb.y;
    v[TS_EXR_ALBEDO_B] = alb.z;
    v[TS_EXR_SUM_R] = acc.x;
    v[TS_EXR_SUM_G] = acc.y;
    v[TS_EXR_SUM_B] = acc.z;
    v[TS_EXR_COUNT] = acc.w;
}

/* RIB Exposure: the colour channels c become (gain c)^(1 / gamma) (RI Spec §4.1.3); the
 * sums and counts --resume reads stay as they are. */
static void output_exposure(const ts_camera *cam, float v[TS_EXR_PARTIAL_CHANNELS])
{
    if (!cam->has_exposure) return;
    for (int k = TS_EXR_R; k <= TS_EXR_B; k++) {
        double c = cam->exposure_gain * (double)v[k];
        v[k] = c > 0.0 ? (float)pow(c, 1.0 / cam->exposure_gamma) : 0.0f;
    }
}

/* Pixels [first, first + count) of the image, nch channels each (ts_exr_channel order; a PNG's
 * R, G, B), into px. */
static void output_pixels(const ts_film_state *films, const ts_camera *cam, int nch, size_t first,
                          size_t count, float *px)
{
    for (size_t i = first; i < first + count; ++i) {
        float v[TS_EXR_PARTIAL_CHANNELS];
        output_pixel(films->accum[i], films->aov[i], films->albedo[i], v);
        output_exposure(cam, v);
        memcpy(&px[(i - first) * nch], v, nch * sizeof(float));
    }
}

/* The TS_EXR_METAS of an image holding `samples_done` samples of job. */
enum { OUTPUT_METAS = 7 };
static void output_metas(const ts_render_options *o, const ts_job *job, uint64_t samples_done,
                         ts_image_meta meta[OUTPUT_METAS])
{
    ts_image_meta m[OUTPUT_METAS] = {
        {ts_exr_meta_keys[TS_EXR_META_spp], o->spp},
        {ts_exr_meta_keys[TS_EXR_META_max_lod], (int)job->max_lod},
        {ts_exr_meta_keys[TS_EXR_META_samples_done], (int)(uint32_t)samples_done},
        {ts_exr_meta_keys[TS_EXR_META_seed], (int)o->seed},
        {ts_exr_meta_keys[TS_EXR_META_job], job->hash},
        {ts_exr_meta_keys[TS_EXR_META_lod], job->lod},
        {TS_EXR_META_BAND, (int)job->band}};
    memcpy(meta, m, sizeof m);
}

/* The EXR image of nch of the channels ts_exr_channel_names (image_write_exr reads only the
 * names) over pixels px, where job says it lies in its frame (a CropWindow). */
static ts_image output_exr_image(const ts_job *job, int width, int height, int nch, float *px)
{
    return (ts_image){.width = width,
                      .height = height,
                      .channels = nch,
                      .channel_names = (const char **)ts_exr_channel_names,
                      .pixels = px,
                      .x0 = job->crop_x,
                      .y0 = job->crop_y,
                      .full_width = job->full_width,
                      .full_height = job->full_height};
}

int output_write(const ts_render_options *o, const ts_film_state *films, const ts_camera *cam,
                 int width, int height, const ts_job *job, ts_error *err)
{
    size_t npix = (size_t)width * height;
    int partial = job->samples_done < job->total;
    const char *ext = strrchr(o->output_path, '.');
    int exr = ext && strcmp(ext, ".exr") == 0;
    int nch = !exr ? 3 : partial ? TS_EXR_PARTIAL_CHANNELS : TS_EXR_COMPLETE_CHANNELS;
    float *px = malloc(npix * (size_t)nch * sizeof *px);
    if (!px) return ts_error_set(err, TS_E_MEMORY, "out of memory (image)");
    output_pixels(films, cam, nch, 0, npix, px);
    int rc;
    if (exr) {
        ts_image img = output_exr_image(job, width, height, nch, px);
        ts_image_meta meta[OUTPUT_METAS];
        output_metas(o, job, job->samples_done, meta);
        /* Samples merged past a gap (several devices or ranks stopped): which ones. */
        char *done = NULL;
        size_t size = 64 + 48 * (size_t)job->done.count;
        if (partial && !done_is_prefix(&job->done) && !(done = malloc(size)))
            rc = ts_error_set(err, TS_E_MEMORY, "out of memory");
        else if (done && !done_format(&job->done, done, size))
            rc = ts_error_set(err, TS_E_INTERNAL, "the runs of finished samples do not fit");
        else {
            ts_image_text text = {TS_EXR_META_DONE, done};
            rc = image_write_exr_text(o->output_path, &img, meta, OUTPUT_METAS, &text, done ? 1 : 0,
                                      err);
        }
        free(done);
    } else {
        rc = image_write_png(o->output_path, width, height, px, err);
    }
    free(px);
    return rc;
}

int output_stream_open(const ts_render_options *o, int width, int height, const ts_job *job,
                       ts_output_stream *s, ts_error *err)
{
    memset(s, 0, sizeof *s);
    double t0 = stats_now();
    s->rows =
        malloc((size_t)TS_OUTPUT_STREAM_ROWS * width * TS_EXR_COMPLETE_CHANNELS * sizeof *s->rows);
    if (!s->rows) return ts_error_set(err, TS_E_MEMORY, "out of memory (image rows)");
    const char *ext = strrchr(o->output_path, '.');
    int rc;
    if (ext && strcmp(ext, ".png") == 0) {
        rc = image_png_stream_open(o->output_path, width, height, &s->png, err);
    } else {
        ts_image shape = output_exr_image(job, width, height, TS_EXR_COMPLETE_CHANNELS, NULL);
        ts_image_meta meta[OUTPUT_METAS];
        output_metas(o, job, job->total, meta);
        rc = image_exr_stream_open(o->output_path, &shape, meta, OUTPUT_METAS, NULL, 0, &s->exr,
                                   err);
    }
    if (rc) {
        free(s->rows);
        memset(s, 0, sizeof *s);
        return err->code;
    }
    s->width = width, s->height = height;
    s->seconds = stats_now() - t0;
    return TS_OK;
}

int output_stream_is_open(const ts_output_stream *s)
{
    return s->exr || s->png;
}

int output_stream_rows(ts_output_stream *s, const ts_film_state *films, const ts_camera *cam,
                       int rows_final, int max_rows, ts_error *err)
{
    double t0 = stats_now();
    int rc = TS_OK;
    int at = s->png ? image_png_stream_next_row(s->png) : image_exr_stream_next_row(s->exr);
    int nch = s->png ? 3 : TS_EXR_COMPLETE_CHANNELS; /* a PNG's R, G, B */
    if (max_rows > 0 && rows_final - at > max_rows) rows_final = at + max_rows;
    while (!rc && at < rows_final) {
        int n = rows_final - at < TS_OUTPUT_STREAM_ROWS ? rows_final - at : TS_OUTPUT_STREAM_ROWS;
        output_pixels(films, cam, nch, (size_t)at * s->width, (size_t)n * s->width, s->rows);
        rc = s->png ? image_png_stream_rows(s->png, s->rows, n, err)
                    : image_exr_stream_rows(s->exr, s->rows, n, err);
        at += n;
    }
    s->seconds += stats_now() - t0;
    return rc;
}

int output_stream_close(ts_output_stream *s, int commit, ts_error *err)
{
    double t0 = stats_now();
    int rc = s->png ? image_png_stream_close(s->png, commit, err)
                    : image_exr_stream_close(s->exr, commit, err);
    free(s->rows);
    double seconds = s->seconds + stats_now() - t0;
    memset(s, 0, sizeof *s);
    s->seconds = seconds;
    return rc;
}
