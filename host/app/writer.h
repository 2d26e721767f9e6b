/* writer.h — the image (an EXR or a PNG) of a render on one device, written on a thread of
 * its own while the device traces the next wave. One device traces the frame's samples in order,
 * pixel after pixel (done.h, band 1), so when a wave ends every row above its last pixel is final:
 * the host copies those rows from the device's films (render.c) and hands them over, and this
 * thread converts and compresses them (output_stream_rows: ZIP on OpenEXR's threads, or
 * libpng's deflate) while the device goes on. What is left at the end is the last wave's rows,
 * compressed while the pipeline is released, instead of the whole image after the last sample
 * (forest-1 at 1920x768: 0.4 s of host-only time; on a GPU most of a short frame's wall).
 *
 * The file is the finished image (output_stream_open: an EXR of TS_EXR_COMPLETE_CHANNELS),
 * committed only when the frame completes; an interrupted, failed or retried frame ends it
 * uncommitted and render_write writes the image as before. The thread reads only rows handed over,
 * which the host never writes again while it runs: writer_end must be called before anything writes
 * the whole host film (a retry's copy, render_write). */
#ifndef TS_WRITER_H
#define TS_WRITER_H

#include "app/output.h"

#include <pthread.h>

typedef struct ts_writer {
    const ts_render_options *opt;
    const ts_film_state *films; /* the host copy: rows [0, final) hold the finished pixels */
    const ts_camera *cam;       /* Exposure */
    const ts_job *job;          /* its metadata: max_lod and lod recorded before the first row */
    int width, height;
    /* Before the header is written: the job's hash, once the thread computing it is done
     * (render.c render_hash_ready); may be NULL. */
    int (*hash_ready)(void *ctx, ts_error *err);
    void *hash_ctx;
    ts_output_stream stream;
    pthread_t thread;
    pthread_mutex_t lock;
    pthread_cond_t wake;
    int made, running;
    /* Under lock: rows handed over (final), rows written, and the end asked: 0 none, 1 write
     * what is left, 2 stop now. failed: the stream could not be written. */
    int final, written, end, failed;
} ts_writer;

/* Sets w up for o->output_path (no thread yet); fails only without the means to lock. */
int writer_init(ts_writer *w, const ts_render_options *o, const ts_film_state *films,
                const ts_camera *cam, const ts_job *job, int width, int height,
                int (*hash_ready)(void *ctx, ts_error *err), void *hash_ctx, ts_error *err);

/* Rows [0, rows_final) of films are final: the thread (started at the first call) writes
 * those not yet written. A row count at or below the last has no effect. */
void writer_rows(ts_writer *w, int rows_final);

/* Whether writer_rows still takes rows: made, and not ended. */
int writer_taking(const ts_writer *w);

/* Ends the thread and the file: with commit, when the frame is complete (every row handed
 * over), the rest is written and the file becomes the image; otherwise it is removed.
 * Returns 1 when the image is written, else 0: then render_write writes it (and reports what
 * fails; the stream's own errors are dropped). Adds the seconds spent to *film_seconds (may
 * be NULL). Safe to call twice and on a writer never started. */
int writer_end(ts_writer *w, int commit, double *film_seconds);

void writer_free(ts_writer *w);

#endif
