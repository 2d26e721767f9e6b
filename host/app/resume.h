/* resume.h — what makes a render resumable (--resume, docs/rendering.md "Interrupting and
 * resuming"): the job that identifies it, the EXR channels and metadata that carry its
 * finished samples (output.c writes them, resume_load reads them back), and the host copy
 * of the films that holds those samples while the device has none. */
#ifndef TS_RESUME_H
#define TS_RESUME_H

#include "app/done.h"
#include "app/options.h"
#include "pipeline/pipeline.h"
#include "scene/scene.h"

#include <stdint.h>

/* The channels of the EXR `tessera render` writes, in file order: the mean of the samples,
 * the AOVs of sample 0 (hit distance, normal, albedo), and, in the image of an unfinished
 * render only, the raw per-pixel sums and sample counts that --resume loads back into the
 * film (the means cannot give the sums bit for bit). */
/* clang-format off */
#define TS_EXR_CHANNELS(X)                                                                  \
    X(R, "R")                                                                               \
    X(G, "G")                                                                               \
    X(B, "B")                                                                               \
    X(Z, "Z")                                                                               \
    X(N_X, "N.x")                                                                           \
    X(N_Y, "N.y")                                                                           \
    X(N_Z, "N.z")                                                                           \
    X(ALBEDO_R, "albedo.R")                                                                 \
    X(ALBEDO_G, "albedo.G")                                                                 \
    X(ALBEDO_B, "albedo.B")                                                                 \
    X(SUM_R, "tessera.sum.R")                                                               \
    X(SUM_G, "tessera.sum.G")                                                               \
    X(SUM_B, "tessera.sum.B")                                                               \
    X(COUNT, "tessera.count")
/* clang-format on */

typedef enum ts_exr_channel {
#define TS_EXR_CHANNEL_ENUM(id, name) TS_EXR_##id,
    TS_EXR_CHANNELS(TS_EXR_CHANNEL_ENUM)
#undef TS_EXR_CHANNEL_ENUM
        TS_EXR_PARTIAL_CHANNELS,            /* 14: every channel, an unfinished render's image */
    TS_EXR_COMPLETE_CHANNELS = TS_EXR_SUM_R /* 10: a finished render's image */
} ts_exr_channel;

extern const char *const ts_exr_channel_names[TS_EXR_PARTIAL_CHANNELS];

/* The EXR's integer metadata, in the order --resume checks it (the first one missing is
 * the one its message names). samples_done < 2^32 (the kernels index samples with 32 bits)
 * is stored as its 32-bit pattern. */
/* clang-format off */
#define TS_EXR_METAS(X)                                                                     \
    X(samples_done, "tessera:samples_done")                                                 \
    X(spp, "tessera:spp")                                                                   \
    X(seed, "tessera:seed")                                                                 \
    X(job, "tessera:job")                                                                   \
    X(lod, "tessera:lod")                                                                   \
    X(max_lod, "tessera:max_lod")
/* clang-format on */

typedef enum ts_exr_meta {
#define TS_EXR_META_ENUM(id, key) TS_EXR_META_##id,
    TS_EXR_METAS(TS_EXR_META_ENUM)
#undef TS_EXR_META_ENUM
        TS_EXR_META_COUNT
} ts_exr_meta;

extern const char *const ts_exr_meta_keys[TS_EXR_META_COUNT];

/* The sample order's band (ts_job.band), written with the others; an image without it is
 * from before the order had bands: one band, pass after pass. */
#define TS_EXR_META_BAND "tessera:band"
/* A string: the runs of the order's samples an unfinished image holds ("first-end ...",
 * done.h), written when they are not the prefix [0, tessera:samples_done) (several devices
 * or ranks stopped with units merged past one not finished). */
#define TS_EXR_META_DONE "tessera:done"

/* What identifies a render and how far it got; stored as EXR metadata for --resume. */
typedef struct ts_job {
    uint64_t total;        /* width * height * spp global samples */
    uint64_t samples_done; /* how many samples the film holds: [0, samples_done) of the
                              order, unless done says otherwise */
    ts_done done;          /* which, when they are not such a prefix (several devices or
                              ranks stopped with later units merged); empty: the prefix */
    uint32_t band;         /* the order's pixels a band (lib/sample_order.h); 0: one band */
    int has_band;          /* 1: band is set (by the first wave, or by --resume) */
    int32_t hash;          /* the scene and the options that change the image */
    int32_t lod;           /* the per-patch levels of detail of the frame (lod stage) */
    int check_lod;         /* 1: lod is that of the samples already in the film */
    uint32_t max_lod;      /* the plan's finest m when lod was taken */
    int lod_mismatch;      /* 1: check_lod was set and this run's lod hash differed */
    int full_width, full_height, crop_x, crop_y; /* a CropWindow's frame and where the image
                                                    lies in it (an EXR's windows); 0: none */
} ts_job;

/* The job hash: the scene file's bytes, the geometry it loaded (archives included), the
 * camera and every option that changes the image (not --memory: the image does not depend
 * on it, and the lod hash covers the one way it could). Fails when the scene file cannot
 * be read again. */
int job_hash(const ts_render_options *o, const ts_scene *s, const ts_camera_params *cam,
             int32_t *out, ts_error *err);
/* The job hash as images written before 2026-11-30 have it: FNV-1a over every byte, where
 * job_hash takes the XXH3 digests of the large pieces (the scene file, the patches' arrays
 * and attributes, the textures). --resume accepts either. */
int job_hash_legacy(const ts_render_options *o, const ts_scene *s, const ts_camera_params *cam,
                    int32_t *out, ts_error *err);

/* The lod hash: the levels of detail the frame's patches are diced at, as the lod stage
 * left them in p->patch_lod, or --lod (clamped to the plan like trace.c does). */
int32_t job_lod_hash(const ts_pipeline *p, const ts_render_options *o);

/* The frame's sample order for job: pixel after pixel (done.h sample_order_band_pixel, which
 * TESSERA_SAMPLE_BAND_ROWS turns into bands of rows), unless the samples already traced
 * (--resume, a retry) had an order of their own; recorded in job->band and cam->band. */
void job_choose_band(ts_job *job, ts_camera_params *cam);

/* The samples the film of job holds, into *held (empty before): job->done, or the prefix
 * [0, job->samples_done). TS_E_MEMORY when it cannot. */
int job_held(const ts_job *job, ts_done *held, ts_error *err);

/* Host copies of the films (accum, aov_film, albedo_film: pixel_count ts_vec4 each): the
 * samples a resumed image holds, or those finished before an out-of-memory retry. All
 * NULL while there are none. */
typedef struct ts_film_state {
    ts_vec4 *accum, *aov, *albedo;
} ts_film_state;

/* Allocates npix zeroed pixels per film; on failure the state stays empty (TS_E_MEMORY). */
int film_state_alloc(ts_film_state *s, size_t npix, ts_error *err);
void film_state_free(ts_film_state *s);
/* Copies the films to the device (upload = 1) or from it (0), blocking. */
int film_state_transfer(ts_pipeline *p, ts_film_state *s, int upload, ts_error *err);
/* Copies pixels [first, first + count) of the films from the device, blocking. */
int film_state_read_pixels(ts_pipeline *p, ts_film_state *s, size_t first, size_t count,
                           ts_error *err);

/* --resume: loads the partial EXR at o->output_path, rendered width x height with the job
 * job->hash of job->total samples (or its legacy form, job_hash_legacy of the scene and
 * camera), into *state and the job (samples_done, lod, max_lod, check_lod). No file: a note on
 * stderr (unless quiet), state stays empty (render from the start). A complete image: *complete =
 * 1, state stays empty. An image of another command, or not from tessera: TS_E_USAGE (TS_E_IO when
 * it cannot be read) naming what differs. */
int resume_load(const ts_render_options *o, int width, int height, const ts_scene *scene,
                const ts_camera_params *cam, ts_job *job, ts_film_state *state, int *complete,
                ts_error *err);

#endif
