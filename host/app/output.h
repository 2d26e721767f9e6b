/* output.h — the image `tessera render` writes to -o: the path checked before anything
 * runs, then the films (their host copy) written as an EXR (float RGB, AOVs, and what
 * --resume needs; channels and metadata in resume.h) or a tone-mapped PNG. */
#ifndef TS_OUTPUT_H
#define TS_OUTPUT_H

#include "app/options.h"
#include "app/resume.h"
#include "image/image.h"
#include "pipeline/pipeline.h"

/* The output paths, before any work: -o given, ending in .exr or .png, and .exr for
 * --resume (a PNG cannot hold the sums of the samples); -o and --stats writable (their
 * directories exist and take new files: TS_E_IO), not the same file, and neither the scene
 * file (TS_E_USAGE). */
int output_check(const ts_render_options *o, ts_error *err);
/* The part of output_check that any command writing an output and a --stats file makes
 * (`tessera bake` too): writable, not the same file, not the scene file. stats may be NULL. */
int output_check_paths(const char *output_path, const char *stats_path, const char *scene_path,
                       ts_error *err);

/* After the scene is loaded, before the render: neither -o nor --stats names a file the
 * scene read (its textures, its environment map). TS_E_USAGE otherwise. */
int output_check_inputs(const ts_render_options *o, const ts_scene *scene, ts_error *err);
/* The same for any command's output and --stats paths (stats may be NULL). */
int output_check_inputs_paths(const char *output_path, const char *stats_path,
                              const ts_scene *scene, ts_error *err);

/* Writes o->output_path, width x height, atomically (image.h), from the host copy of the
 * films (resume.h). An EXR of an unfinished render (job->samples_done < job->total) gets all
 * TS_EXR_PARTIAL_CHANNELS, a finished one TS_EXR_COMPLETE_CHANNELS; both get the
 * TS_EXR_METAS from o and job (job->max_lod: the finest m of the samples in the films). The
 * scene camera's Exposure, if any, applies to R, G, B (of the EXR and the PNG); the sums and
 * counts are the film's. */
int output_write(const ts_render_options *o, const ts_film_state *films, const ts_camera *cam,
                 int width, int height, const ts_job *job, ts_error *err);

/* The EXR written while the frame renders: on several devices or ranks its rows are final
 * as soon as the units holding their pixels' samples are merged (the pixels are in order,
 * units.h), on one device when the wave holding their last pixel ends (writer.h); each band
 * is converted and compressed then, beside the devices,
 * instead of the whole image after the last sample (0.24 s for 1920x768 on 2 cores). It is
 * the finished image's file (TS_EXR_COMPLETE_CHANNELS, samples_done = job->total), so it
 * is kept only if the frame completes; an interrupted or failed frame closes it without
 * committing and output_write writes the partial image as before. */
typedef struct ts_output_stream {
    ts_exr_stream *exr; /* an .exr; NULL: not open */
    ts_png_stream *png; /* a .png (the one-device writer); NULL: not open */
    float *rows;        /* one band of converted rows */
    int width, height;
    double seconds; /* spent opening, converting, writing and closing (the film stage) */
} ts_output_stream;

/* The rows output_stream_rows converts and writes at a time (a few MB). */
#define TS_OUTPUT_STREAM_ROWS 64

/* Opens the stream of o->output_path (an .exr: image_exr_stream_open, with job's metadata:
 * job->max_lod and job->lod must be the frame's, once the lod stage recorded them; a .png:
 * image_png_stream_open). */
int output_stream_open(const ts_render_options *o, int width, int height, const ts_job *job,
                       ts_output_stream *s, ts_error *err);
/* Writes rows [written, rows_final) from the films (every sample of their pixels merged),
 * at most max_rows of them (0: all). */
int output_stream_rows(ts_output_stream *s, const ts_film_state *films, const ts_camera *cam,
                       int rows_final, int max_rows, ts_error *err);
/* Whether s is open. */
int output_stream_is_open(const ts_output_stream *s);
/* Ends the stream (see image_exr_stream_close); s->seconds stays for the stats. */
int output_stream_close(ts_output_stream *s, int commit, ts_error *err);

#endif
