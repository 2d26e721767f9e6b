/* image_png.c — 8-bit sRGB PNG output through libpng (image_png.h): the rendered image as
 * tonemap_srgb8 maps it, with the sRGB chunk, written to a temporary and renamed over the
 * target like every output (base/file.h), a band of rows at a time (image_png_write: all
 * of them at once). */
#include "image/image_png.h"
#include "base/file.h"
#include "image/tonemap.h"

#include <png.h>
#include <setjmp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* libpng's error handler: keeps the message for the ts_error, then leaves through longjmp
 * (libpng requires that it never returns). */
typedef struct libpng_failure {
    char msg[512];
} libpng_failure;

static void on_libpng_error(png_structp png, png_const_charp msg)
{
    libpng_failure *f = png_get_error_ptr(png);
    snprintf(f->msg, sizeof f->msg, "%s", msg ? msg : "libpng error");
    png_longjmp(png, 1);
}

static void on_libpng_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg; /* nothing a user can act on when writing */
}

struct ts_png_stream {
    png_structp png;
    png_infop info;
    FILE *f;
    uint8_t *row; /* one row of sRGB bytes */
    int width, height, next;
    libpng_failure fail;
    char path[4096], tmp[8192];
};

/* Frees s and removes its temporary (a stream not committed). */
static void png_stream_drop(ts_png_stream *s)
{
    if (s->png) png_destroy_write_struct(&s->png, &s->info);
    if (s->f) fclose(s->f);
    unlink(s->tmp);
    free(s->row);
    free(s);
}

int image_png_open_stream(const char *path, int width, int height, ts_png_stream **out,
                          ts_error *err)
{
    *out = NULL;
    if (width <= 0 || height <= 0)
        return ts_error_set(err, TS_E_IO, "%s: invalid image size %dx%dx3", path, width, height);
    ts_png_stream *s = calloc(1, sizeof *s);
    if (!s || !(s->row = malloc((size_t)width * 3))) {
        free(s);
        return ts_error_set(err, TS_E_MEMORY, "%s: out of memory", path);
    }
    s->width = width, s->height = height;
    snprintf(s->path, sizeof s->path, "%s", path);
    if (ts_file_temp_create(path, s->tmp, sizeof s->tmp, err)) {
        free(s->row);
        free(s);
        return err->code;
    }
    s->f = fopen(s->tmp, "wb");
    s->png = s->f ? png_create_write_struct(PNG_LIBPNG_VER_STRING, &s->fail, on_libpng_error,
                                            on_libpng_warning)
                  : NULL;
    s->info = s->png ? png_create_info_struct(s->png) : NULL;
    if (!s->info) {
        const char *why = s->f ? "out of memory in libpng" : "cannot open for writing";
        int rc = ts_error_set(err, TS_E_IO, "%s: %s", path, why);
        png_stream_drop(s);
        return rc;
    }
    if (setjmp(png_jmpbuf(s->png))) {
        int rc = ts_error_set(err, TS_E_IO, "%s: %s", path, s->fail.msg);
        png_stream_drop(s);
        return rc;
    }
    png_init_io(s->png, s->f);
    png_set_IHDR(s->png, s->info, (png_uint_32)width, (png_uint_32)height, 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB_gAMA_and_cHRM(s->png, s->info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_write_info(s->png, s->info);
    *out = s;
    return TS_OK;
}

int image_png_stream_rows(ts_png_stream *s, const float *rgb_linear, int count, ts_error *err)
{
    if (count < 0 || count > s->height - s->next)
        return ts_error_set(err, TS_E_INTERNAL, "%s: %d rows past row %d of %d", s->path, count,
                            s->next, s->height);
    if (setjmp(png_jmpbuf(s->png)))
        return ts_error_set(err, TS_E_IO, "%s: %s", s->path, s->fail.msg);
    size_t row = (size_t)s->width * 3;
    for (int y = 0; y < count; y++) {
        tonemap_srgb8_buffer(rgb_linear + row * (size_t)y, s->row, row);
        png_write_row(s->png, s->row);
        s->next++;
    }
    return TS_OK;
}

int image_png_stream_next_row(const ts_png_stream *s)
{
    return s->next;
}

int image_png_stream_close(ts_png_stream *s, int commit, ts_error *err)
{
    if (!s) return TS_OK;
    if (!commit) {
        png_stream_drop(s);
        return TS_OK;
    }
    if (s->next != s->height) {
        int rc = ts_error_set(err, TS_E_INTERNAL, "%s: %d of %d rows written", s->path, s->next,
                              s->height);
        png_stream_drop(s);
        return rc;
    }
    if (setjmp(png_jmpbuf(s->png))) {
        int rc = ts_error_set(err, TS_E_IO, "%s: %s", s->path, s->fail.msg);
        png_stream_drop(s);
        return rc;
    }
    png_write_end(s->png, s->info);
    png_destroy_write_struct(&s->png, &s->info);
    FILE *f = s->f;
    s->f = NULL;
    if (fclose(f) != 0) {
        int rc = ts_error_set(err, TS_E_IO, "%s: cannot finish writing", s->path);
        png_stream_drop(s);
        return rc;
    }
    int rc = ts_file_temp_commit(s->tmp, s->path, err);
    free(s->row);
    free(s);
    return rc;
}

/* The whole image: a stream of all its rows. */
int image_png_write(const char *path, int width, int height, const float *rgb_linear, ts_error *err)
{
    if (!rgb_linear) return ts_error_set(err, TS_E_IO, "%s: no pixel data", path);
    ts_png_stream *s = NULL;
    int rc = image_png_open_stream(path, width, height, &s, err);
    if (!rc) rc = image_png_stream_rows(s, rgb_linear, height, err);
    int closed = s ? image_png_stream_close(s, rc == TS_OK, rc ? NULL : err) : TS_OK;
    return rc ? rc : closed;
}
