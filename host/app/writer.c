/* writer.c — the image of a one-device render written beside its waves (writer.h). */
#include "app/writer.h"

#include <string.h>

int writer_init(ts_writer *w, const ts_render_options *o, const ts_film_state *films,
                const ts_camera *cam, const ts_job *job, int width, int height,
                int (*hash_ready)(void *ctx, ts_error *err), void *hash_ctx, ts_error *err)
{
    memset(w, 0, sizeof *w);
    w->opt = o, w->films = films, w->cam = cam, w->job = job;
    w->width = width, w->height = height;
    w->hash_ready = hash_ready, w->hash_ctx = hash_ctx;
    if (pthread_mutex_init(&w->lock, NULL)) return ts_error_set(err, TS_E_MEMORY, "no mutex");
    if (pthread_cond_init(&w->wake, NULL)) {
        pthread_mutex_destroy(&w->lock);
        return ts_error_set(err, TS_E_MEMORY, "no condition variable");
    }
    w->made = 1;
    return TS_OK;
}

/* The thread: opens the file at the first rows (the job's hash ready first), then writes the
 * rows handed over, one band of TS_OUTPUT_STREAM_ROWS at a time so that a stop (end = 2)
 * waits for one band at most. Stops for good at the first failure. */
static void *writer_run(void *arg)
{
    ts_writer *w = arg;
    pthread_mutex_lock(&w->lock);
    for (;;) {
        while (!w->end && w->final == w->written)
            pthread_cond_wait(&w->wake, &w->lock);
        if (w->end == 2 || w->final == w->written) break;
        int target = w->final, at = w->written;
        pthread_mutex_unlock(&w->lock);
        ts_error e = {0};
        int rc = TS_OK;
        if (!output_stream_is_open(&w->stream))
            rc = (w->hash_ready && w->hash_ready(w->hash_ctx, &e)) ||
                 output_stream_open(w->opt, w->width, w->height, w->job, &w->stream, &e);
        if (!rc)
            rc =
                output_stream_rows(&w->stream, w->films, w->cam, target, TS_OUTPUT_STREAM_ROWS, &e);
        pthread_mutex_lock(&w->lock);
        ts_error_clear(&e); /* render_write writes the image instead, and says what fails */
        if (rc) {
            w->failed = 1;
            break;
        }
        w->written = target - at < TS_OUTPUT_STREAM_ROWS ? target : at + TS_OUTPUT_STREAM_ROWS;
    }
    pthread_mutex_unlock(&w->lock);
    return NULL;
}

void writer_rows(ts_writer *w, int rows_final)
{
    if (!w->made) return;
    pthread_mutex_lock(&w->lock);
    if (rows_final > w->final && !w->end) {
        w->final = rows_final;
        if (!w->running && !w->failed)
            w->running = pthread_create(&w->thread, NULL, writer_run, w) == 0;
        pthread_cond_signal(&w->wake);
    }
    pthread_mutex_unlock(&w->lock);
}

int writer_taking(const ts_writer *w)
{
    return w->made && !w->end; /* end is set by writer_end alone, on the caller's thread */
}

int writer_end(ts_writer *w, int commit, double *film_seconds)
{
    if (!w->made) return 0;
    pthread_mutex_lock(&w->lock);
    commit = commit && w->running && w->final == w->height;
    if (!w->end) w->end = commit ? 1 : 2;
    pthread_cond_signal(&w->wake);
    pthread_mutex_unlock(&w->lock);
    if (w->running) pthread_join(w->thread, NULL), w->running = 0;
    commit = commit && !w->failed && w->written == w->height;
    int committed = 0;
    if (output_stream_is_open(&w->stream)) {
        ts_error e = {0};
        committed = !output_stream_close(&w->stream, commit, commit ? &e : NULL) && commit;
        ts_error_clear(&e);
    }
    if (film_seconds) *film_seconds += w->stream.seconds;
    w->stream.seconds = 0;
    return committed;
}

void writer_free(ts_writer *w)
{
    if (!w->made) return;
    writer_end(w, 0, NULL);
    pthread_cond_destroy(&w->wake);
    pthread_mutex_destroy(&w->lock);
    w->made = 0;
}
