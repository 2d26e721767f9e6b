/* resume.c — the job and lod hashes that identify a render, the host copy of the films,
 * and --resume: an unfinished render's EXR read back into them (resume.h). */
#include "app/resume.h"
#include "base/hash.h"
#include "image/image.h"
#include "lib/sample_order.h"
#include "scene/trim.h"

#include <errno.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <xxhash.h>

const char *const ts_exr_channel_names[TS_EXR_PARTIAL_CHANNELS] = {
#define TS_EXR_CHANNEL_NAME(id, name) name,
    TS_EXR_CHANNELS(TS_EXR_CHANNEL_NAME)
#undef TS_EXR_CHANNEL_NAME
};

const char *const ts_exr_meta_keys[TS_EXR_META_COUNT] = {
#define TS_EXR_META_KEY(id, key) key,
    TS_EXR_METAS(TS_EXR_META_KEY)
#undef TS_EXR_META_KEY
};

static int32_t fold32(uint64_t h)
{
    return (int32_t)(uint32_t)(h ^ (h >> 32));
}

int32_t job_lod_hash(const ts_pipeline *p, const ts_render_options *o)
{
    uint64_t h = TS_FNV1A_INIT;
    if (o->fixed_lod >= 0) {
        uint32_t m =
            (uint32_t)o->fixed_lod < p->plan.max_lod ? (uint32_t)o->fixed_lod : p->plan.max_lod;
        return fold32(ts_fnv1a(h, &m, sizeof m));
    }
    return fold32(ts_fnv1a(h, p->patch_lod, p->scene->patch_count));
}

/* A job hash fed piece by piece: FNV-1a over every byte (legacy: the hash of images written
 * before 2026-11-30, which --resume still accepts), or FNV-1a over the small pieces and the
 * XXH3 digests of the large ones (the scene file, the patches' arrays and attributes, the
 * textures: forest-10000's 7 GB took 7.6 s of a core with FNV-1a a byte at a time, against
 * the top-level BVH's build for the other). */
typedef struct job_hasher {
    int legacy;
    uint64_t h;
    XXH3_state_t *x; /* the large piece being fed (job_part); NULL when legacy */
} job_hasher;

static void job_small(job_hasher *j, const void *p, size_t n)
{
    j->h = ts_fnv1a(j->h, p, n);
}

/* A large piece, fed in parts: job_part_begin, job_part (any number), job_part_end. */
static void job_part_begin(job_hasher *j)
{
    if (!j->legacy) XXH3_64bits_reset(j->x);
}

static void job_part(job_hasher *j, const void *p, size_t n)
{
    if (j->legacy)
        j->h = ts_fnv1a(j->h, p, n);
    else
        XXH3_64bits_update(j->x, p, n);
}

static void job_part_end(job_hasher *j)
{
    if (j->legacy) return;
    uint64_t d = XXH3_64bits_digest(j->x);
    j->h = ts_fnv1a(j->h, &d, sizeof d);
}

/* A large piece in one part. */
static void job_large(job_hasher *j, const void *p, size_t n)
{
    job_part_begin(j);
    job_part(j, p, n);
    job_part_end(j);
}

static int job_hash_of(const ts_render_options *o, const ts_scene *s, const ts_camera_params *cam,
                       int legacy, int32_t *out, ts_error *err)
{
    job_hasher j = {legacy, TS_FNV1A_INIT, legacy ? NULL : XXH3_createState()};
    if (!legacy && !j.x) return ts_error_set(err, TS_E_MEMORY, "out of memory (the job's hash)");
    FILE *f = fopen(o->scene_path, "rb");
    if (!f) {
        XXH3_freeState(j.x);
        return ts_error_set(err, TS_E_IO, "%s: %s", o->scene_path, strerror(errno));
    }
    job_part_begin(&j);
    unsigned char buf[65536];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, f)) > 0)
        job_part(&j, buf, n);
    fclose(f);
    job_part_end(&j);
    int32_t opts[] = {
        (int32_t)cam->width, (int32_t)cam->height, o->spp,       o->depth, (int32_t)o->seed,
        o->sampling,         o->max_lod,           o->fixed_lod, o->exact};
    job_small(&j, opts, sizeof opts);
    /* --dicing-rate only when it is not the default, so files rendered before it resume. */
    if (o->dicing_rate != 1.0) job_small(&j, &o->dicing_rate, sizeof o->dicing_rate);
    ts_camera_params c = *cam; /* the order's bands and the wave do not change the image */
    c.band = c.first_sample = c.ray_count = 0;
    /* A static camera's bytes as they were before moving cameras (so that files written then
     * still resume), and the shutter-close vectors of a moving one. */
    job_small(&j, &c, offsetof(ts_camera_params, moving));
    if (c.moving)
        job_small(&j, &c.moving,
                  offsetof(ts_camera_params, crop_x) - offsetof(ts_camera_params, moving));
    else if (c.clip)
        job_small(&j, &c.clip, 3 * sizeof c.clip); /* clip, near, far */
    if (c.full_width) /* a CropWindow: where the image lies in which frame */
        job_small(&j, &c.crop_x, 4 * sizeof c.crop_x);
    if (c.dof) /* a thin lens: its half-axes, and the plane of focus */
        job_small(&j, &c.lens_x,
                  offsetof(ts_camera_params, pad2) - offsetof(ts_camera_params, lens_x));
    job_small(&j, &s->patch_count, sizeof s->patch_count);
    job_large(&j, s->cp, (size_t)s->patch_count * 16 * sizeof(ts_vec4));
    if (s->cp1) job_large(&j, s->cp1, (size_t)s->patch_count * 16 * sizeof(ts_vec4));
    if (s->corner_n) job_large(&j, s->corner_n, (size_t)s->patch_count * 4 * sizeof(ts_vec4));
    if (s->mid_n) job_large(&j, s->mid_n, (size_t)s->patch_count * 5 * sizeof(ts_vec4));
    job_part_begin(&j);
    for (uint32_t i = 0; i < s->patch_count; ++i) {
        ts_patch_attr a = s->attr[i];
        a.trim_first = 0; /* hashed with the trim segments below, where there are any */
        /* The principled fields only where they are read, as the 128 bytes before them. */
        size_t bytes =
            a.material == TS_MAT_PRINCIPLED ? sizeof a : offsetof(ts_patch_attr, metallic);
        job_part(&j, &a, bytes);
    }
    job_part_end(&j);
    if (s->texture_count) { /* texel contents, not file names */
        job_small(&j, s->textures, (size_t)s->texture_count * sizeof(ts_texture));
        job_large(&j, s->tex_pool,
                  (size_t)s->tex_tile_count * TS_TEX_TILE * TS_TEX_TILE * sizeof(ts_vec4));
    }
    if (s->xform) job_small(&j, s->xform, (size_t)s->xform_count * sizeof(ts_xform));
    j.h = trim_hash(s, j.h);
    for (uint32_t i = 0; i < s->light_count; ++i)
        job_small(&j, &s->lights[i], sizeof s->lights[i]);
    double dome[4] = {s->dome.present, s->dome.intensity, s->dome.color[0], s->dome.color[1]};
    job_small(&j, dome, sizeof dome);
    job_small(&j, &s->dome.color[2], sizeof s->dome.color[2]);
    const ts_occlusion *occ = s->occlusion; /* --occlusion: the baked coefficients relit with */
    if (occ) {
        const uint32_t head[] = {occ->bands, occ->cosine, occ->patch_count, occ->point_count};
        job_small(&j, head, sizeof head);
        job_large(&j, occ->patch, 2 * (size_t)occ->patch_count * sizeof *occ->patch);
        job_large(&j, occ->coeffs,
                  (size_t)occ->point_count * occ->bands * occ->bands * sizeof *occ->coeffs);
        job_large(&j, occ->normal, (size_t)occ->point_count * 3 * sizeof *occ->normal);
    }
    XXH3_freeState(j.x);
    *out = fold32(j.h);
    return TS_OK;
}

int job_hash(const ts_render_options *o, const ts_scene *s, const ts_camera_params *cam,
             int32_t *out, ts_error *err)
{
    return job_hash_of(o, s, cam, 0, out, err);
}

int job_hash_legacy(const ts_render_options *o, const ts_scene *s, const ts_camera_params *cam,
                    int32_t *out, ts_error *err)
{
    return job_hash_of(o, s, cam, 1, out, err);
}

void job_choose_band(ts_job *job, ts_camera_params *cam)
{
    if (!job->has_band) job->band = sample_order_band_pixel(cam->width, cam->height, cam->spp);
    job->has_band = 1;
    cam->band = job->band;
}

int job_held(const ts_job *job, ts_done *held, ts_error *err)
{
    if (job->done.count == 0) return done_add(held, 0, job->samples_done, err);
    for (uint32_t i = 0; i < job->done.count; ++i)
        if (done_add(held, job->done.r[i].first, job->done.r[i].end, err)) return err->code;
    return TS_OK;
}

void film_state_free(ts_film_state *s)
{
    free(s->accum), free(s->aov), free(s->albedo);
    memset(s, 0, sizeof *s);
}

int film_state_alloc(ts_film_state *s, size_t npix, ts_error *err)
{
    s->accum = calloc(npix, sizeof(ts_vec4));
    s->aov = calloc(npix, sizeof(ts_vec4));
    s->albedo = calloc(npix, sizeof(ts_vec4));
    if (!s->accum || !s->aov || !s->albedo) {
        film_state_free(s);
        return ts_error_set(err, TS_E_MEMORY,
                            "out of memory for the host copy of the films (%zu pixels, %zu MB)",
                            npix, 3 * npix * sizeof(ts_vec4) >> 20);
    }
    return TS_OK;
}

/* Pixels [first, first + count) of the three films, to the device or from it, blocking. */
static int film_state_copy(ts_pipeline *p, ts_film_state *s, int upload, size_t first, size_t count,
                           ts_error *err)
{
    size_t at = first * sizeof(ts_vec4), bytes = count * sizeof(ts_vec4);
    cl_mem dev[3] = {p->accum, p->aov_film, p->albedo_film};
    ts_vec4 *host[3] = {s->accum + first, s->aov + first, s->albedo + first};
    for (int i = 0; i < 3; ++i) {
        cl_int rc = upload ? clEnqueueWriteBuffer(p->cl->queue, dev[i], CL_TRUE, at, bytes, host[i],
                                                  0, NULL, NULL)
                           : clEnqueueReadBuffer(p->cl->queue, dev[i], CL_TRUE, at, bytes, host[i],
                                                 0, NULL, NULL);
        if (rc != CL_SUCCESS)
            return ts_error_set(
                err, TS_E_DEVICE, "%s in %s (copying the image %s the device)", dev_error_name(rc),
                upload ? "clEnqueueWriteBuffer" : "clEnqueueReadBuffer", upload ? "to" : "from");
    }
    return TS_OK;
}

int film_state_transfer(ts_pipeline *p, ts_film_state *s, int upload, ts_error *err)
{
    return film_state_copy(p, s, upload, 0, p->pixel_count, err);
}

int film_state_read_pixels(ts_pipeline *p, ts_film_state *s, size_t first, size_t count,
                           ts_error *err)
{
    return film_state_copy(p, s, 0, first, count, err);
}

/* Reads every ts_exr_meta_keys item of path into v; fails naming the first one missing. */
static int resume_read_meta(const char *path, int v[TS_EXR_META_COUNT], ts_error *err)
{
    ts_error e = {0};
    int rc = TS_OK;
    for (int k = 0; k < TS_EXR_META_COUNT && !rc; ++k)
        if (image_read_meta_int(path, ts_exr_meta_keys[k], &v[k], &e))
            rc = ts_error_set(
                err, TS_E_USAGE,
                "%s: cannot resume: it has no \"%s\" metadata (not from tessera render, "
                "or from an older version); render without --resume",
                path, ts_exr_meta_keys[k]);
    ts_error_clear(&e);
    return rc;
}

/* Whether hash is this command's job hash as images written before 2026-11-30 have it
 * (job_hash_legacy), computed only for such an image. */
static int resume_legacy_job(const ts_render_options *o, const ts_scene *s,
                             const ts_camera_params *cam, int32_t hash)
{
    int32_t legacy = 0;
    ts_error e = {0};
    int same = s && cam && job_hash_legacy(o, s, cam, &legacy, &e) == TS_OK && legacy == hash;
    ts_error_clear(&e);
    return same;
}

/* The image img with metadata v was made by this command: same size, --spp, --seed and job
 * hash (or its legacy form: resume_legacy_job), and no more samples than the job has. */
static int resume_check_job(const ts_render_options *o, int width, int height, const ts_image *img,
                            const int v[TS_EXR_META_COUNT], const ts_job *job, const ts_scene *s,
                            const ts_camera_params *cam, ts_error *err)
{
    const char *path = o->output_path;
    uint64_t done = (uint32_t)v[TS_EXR_META_samples_done];
    if (img->width != width || img->height != height)
        return ts_error_set(err, TS_E_USAGE,
                            "%s: cannot resume: it is %dx%d but this command renders "
                            "%dx%d (use the original command, or render without --resume)",
                            path, img->width, img->height, width, height);
    if (v[TS_EXR_META_spp] != o->spp)
        return ts_error_set(
            err, TS_E_USAGE,
            "%s: cannot resume: it was rendered with --spp %d, this "
            "command has --spp %d (use the original command, or render without --resume)",
            path, v[TS_EXR_META_spp], o->spp);
    if ((unsigned)v[TS_EXR_META_seed] != o->seed)
        return ts_error_set(
            err, TS_E_USAGE,
            "%s: cannot resume: it was rendered with --seed %d, this "
            "command has --seed %u (use the original command, or render without --resume)",
            path, v[TS_EXR_META_seed], o->seed);
    if (v[TS_EXR_META_job] != job->hash && !resume_legacy_job(o, s, cam, v[TS_EXR_META_job]))
        return ts_error_set(
            err, TS_E_USAGE,
            "%s: cannot resume: it was rendered from another scene "
            "or with other --depth, --sampling, --max-lod, --lod, --dicing-rate or --intersect "
            "options "
            "(use the original command, or render without --resume)",
            path);
    if (done > job->total)
        return ts_error_set(err, TS_E_USAGE, "%s: cannot resume: it claims %llu samples of %llu",
                            path, (unsigned long long)done, (unsigned long long)job->total);
    return TS_OK;
}

/* Finds every ts_exr_channel of a partial image in img: idx[c] is its position. */
static int resume_find_channels(const char *path, const ts_image *img,
                                int idx[TS_EXR_PARTIAL_CHANNELS], ts_error *err)
{
    for (int c = 0; c < TS_EXR_PARTIAL_CHANNELS; ++c) {
        idx[c] = -1;
        for (int k = 0; k < img->channels; ++k)
            if (strcmp(img->channel_names[k], ts_exr_channel_names[c]) == 0) idx[c] = k;
        if (idx[c] < 0)
            return ts_error_set(err, TS_E_USAGE, "%s: cannot resume: it has no \"%s\" channel",
                                path, ts_exr_channel_names[c]);
    }
    return TS_OK;
}

/* The count channel agrees with the samples the image holds (held: tessera:done, else the
 * first tessera:samples_done of the order), pixel by pixel (done_pixel_count). A
 * hand-edited or damaged file that disagrees would otherwise be resumed and count samples
 * twice (or never). Counts are whole floats below 2^24, exact. */
static int resume_check_counts(const char *path, const ts_image *img, int count_channel,
                               const ts_done *held, const ts_sample_order *order, uint64_t done,
                               ts_error *err)
{
    uint64_t npix = (uint64_t)img->width * (uint64_t)img->height;
    for (uint64_t i = 0; i < npix; ++i) {
        float count = img->pixels[i * (uint64_t)img->channels + (uint64_t)count_channel];
        uint64_t want = done_pixel_count(held, order, (uint32_t)i);
        if (count != (float)want)
            return ts_error_set(err, TS_E_USAGE,
                                "%s: cannot resume: pixel (%llu, %llu) holds %g samples where "
                                "\"tessera:samples_done\" %llu means %llu (a damaged or edited "
                                "file); render without --resume",
                                path, (unsigned long long)(i % (uint64_t)img->width),
                                (unsigned long long)(i / (uint64_t)img->width), (double)count,
                                (unsigned long long)done, (unsigned long long)want);
    }
    return TS_OK;
}

/* The runs of samples the image at path holds: its "tessera:done" (checked against
 * samples_done), else [0, samples_done). */
static int resume_held(const char *path, const ts_sample_order *order, uint64_t total,
                       uint64_t samples_done, ts_done *held, ts_error *err)
{
    size_t size = (size_t)1 << 20;
    char *text = malloc(size);
    if (!text) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    ts_error e = {0};
    int rc = TS_OK;
    if (image_read_meta_string(path, TS_EXR_META_DONE, text, size, &e) != TS_OK)
        rc = done_add(held, 0, samples_done, err); /* a prefix */
    else if (done_parse(text, order, total, held, &e) || done_samples(held) != samples_done)
        rc = ts_error_set(err, TS_E_USAGE,
                          "%s: cannot resume: its \"%s\" metadata does not give the %llu "
                          "samples of \"tessera:samples_done\" (a damaged or edited file); "
                          "render without --resume",
                          path, TS_EXR_META_DONE, (unsigned long long)samples_done);
    ts_error_clear(&e);
    free(text);
    return rc;
}

/* The films as the render left them: the sums and counts, and sample 0's AOVs where the
 * pixel has a sample, else zeros (which output_write turned into Z = +inf). */
static void resume_fill_films(const ts_image *img, const int idx[TS_EXR_PARTIAL_CHANNELS],
                              ts_film_state *state)
{
    size_t npix = (size_t)img->width * img->height;
    for (size_t i = 0; i < npix; ++i) {
        const float *px = &img->pixels[i * (size_t)img->channels];
        float count = px[idx[TS_EXR_COUNT]];
        state->accum[i] =
            (ts_vec4){px[idx[TS_EXR_SUM_R]], px[idx[TS_EXR_SUM_G]], px[idx[TS_EXR_SUM_B]], count};
        if (count > 0) {
            state->aov[i] = (ts_vec4){px[idx[TS_EXR_N_X]], px[idx[TS_EXR_N_Y]], px[idx[TS_EXR_N_Z]],
                                      px[idx[TS_EXR_Z]]};
            state->albedo[i] = (ts_vec4){px[idx[TS_EXR_ALBEDO_R]], px[idx[TS_EXR_ALBEDO_G]],
                                         px[idx[TS_EXR_ALBEDO_B]], 0.0f};
        }
    }
}

int resume_load(const ts_render_options *o, int width, int height, const ts_scene *scene,
                const ts_camera_params *cam, ts_job *job, ts_film_state *state, int *complete,
                ts_error *err)
{
    const char *path = o->output_path;
    struct stat st;
    if (stat(path, &st) != 0 && errno == ENOENT) {
        if (!o->quiet)
            ts_print_line("tessera: %s does not exist yet: rendering from the start", path);
        return TS_OK;
    }
    ts_image img;
    ts_error e = {0};
    if (image_read(path, &img, &e)) {
        ts_error_set(err, TS_E_IO,
                     "%s (cannot resume from it; render without --resume to start again)", e.msg);
        ts_error_clear(&e);
        return err->code;
    }
    int v[TS_EXR_META_COUNT] = {0}, idx[TS_EXR_PARTIAL_CHANNELS];
    int rc = resume_read_meta(path, v, err);
    if (!rc) rc = resume_check_job(o, width, height, &img, v, job, scene, cam, err);
    if (!rc && (uint32_t)v[TS_EXR_META_samples_done] == job->total) *complete = 1;
    if (!rc && !*complete) rc = resume_find_channels(path, &img, idx, err);
    /* Without the band: an image from before the order had bands, pass after pass. */
    int band = 0;
    if (!rc && image_read_meta_int(path, TS_EXR_META_BAND, &band, &e)) {
        ts_error_clear(&e);
        band = 0;
    }
    if (!rc && !*complete && (band < 0 || (uint64_t)band > (uint64_t)width * (uint64_t)height))
        rc = ts_error_set(err, TS_E_USAGE,
                          "%s: cannot resume: its \"%s\" metadata %d is not a band of its %dx%d "
                          "pixels (a damaged or edited file); render without --resume",
                          path, TS_EXR_META_BAND, band, width, height);
    ts_sample_order order = {(uint32_t)width * (uint32_t)height, (uint32_t)o->spp, (uint32_t)band};
    ts_done held = {0};
    uint64_t done = (uint32_t)v[TS_EXR_META_samples_done];
    if (!rc && !*complete) rc = resume_held(path, &order, job->total, done, &held, err);
    if (!rc && !*complete)
        rc = resume_check_counts(path, &img, idx[TS_EXR_COUNT], &held, &order, done, err);
    if (!rc && !*complete) rc = film_state_alloc(state, (size_t)width * height, err);
    if (!rc && !*complete) {
        resume_fill_films(&img, idx, state);
        job->samples_done = (uint32_t)v[TS_EXR_META_samples_done];
        job->band = (uint32_t)band;
        job->has_band = 1;
        if (!done_is_prefix(&held)) job->done = held, memset(&held, 0, sizeof held);
        job->lod = v[TS_EXR_META_lod];
        job->max_lod = (uint32_t)v[TS_EXR_META_max_lod];
        job->check_lod = 1;
        if (!o->quiet)
            ts_print_line("tessera: resuming %s at sample %llu of %llu", path,
                          (unsigned long long)job->samples_done, (unsigned long long)job->total);
    }
    done_free(&held);
    image_free(&img);
    return rc;
}
