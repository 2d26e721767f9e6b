/* image_png.c — 8-bit sRGB PNG output through libpng (image_png.h): the rendered image as
 * tonemap_srgb8 maps it, with the sRGB chunk, written to a temporary and renamed over the
 * target like every output (base/file.h). */
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

/* Writes rows (3 bytes a pixel) to the open file f; 0 or -1 with why in fail. The rows
 * array is passed in: nothing allocated here may leak past the longjmp. */
static int srgb_rows_write(FILE *f, int width, int height, png_bytepp rows, libpng_failure *fail)
{
    png_structp png =
        png_create_write_struct(PNG_LIBPNG_VER_STRING, fail, on_libpng_error, on_libpng_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_write_struct(&png, NULL);
        snprintf(fail->msg, sizeof fail->msg, "out of memory in libpng");
        return -1;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return -1;
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, (png_uint_32)width, (png_uint_32)height, 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_write_info(png, info);
    png_write_image(png, rows);
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    return 0;
}

int image_png_write(const char *path, int width, int height, const float *rgb_linear, ts_error *err)
{
    if (width <= 0 || height <= 0)
        return ts_error_set(err, TS_E_IO, "%s: invalid image size %dx%dx3", path, width, height);
    if (!rgb_linear) return ts_error_set(err, TS_E_IO, "%s: no pixel data", path);
    size_t row = (size_t)width * 3, count = row * (size_t)height;
    uint8_t *srgb = malloc(count);
    png_bytepp rows = malloc(sizeof *rows * (size_t)height);
    if (!srgb || !rows) {
        free(srgb);
        free(rows);
        return ts_error_set(err, TS_E_MEMORY, "%s: out of memory", path);
    }
    tonemap_srgb8_buffer(rgb_linear, srgb, count);
    for (int y = 0; y < height; y++)
        rows[y] = srgb + row * (size_t)y;
    char tmp[8192];
    int rc = ts_file_temp_create(path, tmp, sizeof tmp, err);
    if (!rc) {
        libpng_failure fail = {{0}};
        FILE *f = fopen(tmp, "wb");
        if (!f) snprintf(fail.msg, sizeof fail.msg, "cannot open for writing");
        int bad = !f || srgb_rows_write(f, width, height, rows, &fail) != 0;
        if (f && fclose(f) != 0 && !bad) {
            snprintf(fail.msg, sizeof fail.msg, "cannot finish writing");
            bad = 1;
        }
        if (bad) {
            unlink(tmp);
            rc = ts_error_set(err, TS_E_IO, "%s: %s", path, fail.msg);
        } else {
            rc = ts_file_temp_commit(tmp, path, err);
        }
    }
    free(rows);
    free(srgb);
    return rc;
}
