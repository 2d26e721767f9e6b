/* image.h — image files in and out behind a C-only interface (image.c): EXR read and
 * written with the OpenEXR library (image_exr.cpp), PNG written with libpng (image_png.c),
 * every other format read through OpenImageIO (image_oiio.cpp), a module opened on the
 * first such read (image_module.h); if it cannot be loaded, that read fails with TS_E_IO
 * "PATH: cannot load the image module ...". No C++ exception crosses the interface.
 *
 * Writes are atomic: the image goes to a hidden temporary next to the target
 * (".NAME.tmp-PID-N", NAME cut to fit NAME_MAX: ts_file_temp_name), which is renamed over
 * the target only after a successful close. On failure the temporary is removed and the
 * target is left as it was (absent or the old file); temporaries of the same target left
 * by a process that no longer runs (killed while writing) are removed before writing. Every failure
 * is TS_E_IO with "PATH: reason" (TS_E_MEMORY if allocation fails), reported through ts_error. */
#ifndef TS_IMAGE_H
#define TS_IMAGE_H

#include "base/error.h"

/* A float image. pixels holds width * height * channels floats, interleaved by pixel,
 * rows top to bottom (row 0 = top). channel_names has `channels` entries; for images
 * from image_read it is also NULL-terminated. */
typedef struct ts_image {
    int width, height, channels;
    const char **channel_names;
    float *pixels;
    /* A part of a larger frame (RIB CropWindow): its top-left pixel (x0, y0) in the frame of
     * full_width x full_height pixels, an EXR's data and display windows; full_width 0: the
     * image is the whole frame. */
    int x0, y0, full_width, full_height;
} ts_image;

/* One integer metadata item, stored as an EXR int attribute, e.g. {"tessera:spp", 16}. */
typedef struct ts_image_meta {
    const char *key;
    int value;
} ts_image_meta;

/* Writes img as OpenEXR: 32-bit float channels named channel_names (distinct, in that
 * order; NULL gives OIIO's defaults R, G, B, A, channel4...), ZIP compression, plus
 * meta_count integer attributes. path must end in ".exr" (else "unsupported output
 * format"). EXR stores channels sorted by name; the given order is kept in the string
 * array attribute "tessera:channel_order", which image_read uses to restore it.
 * Returns TS_OK or the error code. */
int image_write_exr(const char *path, const ts_image *img, const ts_image_meta *meta,
                    int meta_count, ts_error *err);

/* One string metadata item, stored as an EXR string attribute. */
typedef struct ts_image_text {
    const char *key;
    const char *text;
} ts_image_text;

/* image_write_exr with text_count string attributes besides the integer ones. */
int image_write_exr_text(const char *path, const ts_image *img, const ts_image_meta *meta,
                         int meta_count, const ts_image_text *text, int text_count, ts_error *err);

/* An EXR written a band of rows at a time (image_exr_stream_*): the header when it opens,
 * each band's pixels as they become final, the file under its name only when every row is
 * in (written through a temporary beside it, like image_write_exr). */
typedef struct ts_exr_stream ts_exr_stream;

/* Opens the stream of an image of shape's width, height, channels and channel names
 * (shape->pixels is not read), with image_write_exr_text's metadata; *out on success.
 * path must end in ".exr". */
int image_exr_stream_open(const char *path, const ts_image *shape, const ts_image_meta *meta,
                          int meta_count, const ts_image_text *text, int text_count,
                          ts_exr_stream **out, ts_error *err);
/* The next `count` rows, top to bottom: channels interleaved, width * channels floats a row. */
int image_exr_stream_rows(ts_exr_stream *s, const float *rows, int count, ts_error *err);
/* The number of rows written so far. */
int image_exr_stream_next_row(const ts_exr_stream *s);
/* Ends the stream and frees it (NULL: nothing). commit 1: every row must be written; the
 * file takes path's name. commit 0: the temporary is removed, path is left as it was, and
 * err is not touched (it may be NULL). */
int image_exr_stream_close(ts_exr_stream *s, int commit, ts_error *err);

/* Writes 8-bit sRGB PNG (with the sRGB chunk) from rgb_linear (3 floats per pixel, rows top to
 * bottom), tone-mapped by tonemap_srgb8. path must end in ".png". Returns TS_OK or the code. */
int image_write_png(const char *path, int width, int height, const float *rgb_linear,
                    ts_error *err);

/* A PNG written a band of rows at a time, like ts_exr_stream: image_write_png's bytes, the file
 * under its name only when every row is in. */
typedef struct ts_png_stream ts_png_stream;

/* Opens the stream of a width x height image; *out on success. path must end in ".png". */
int image_png_stream_open(const char *path, int width, int height, ts_png_stream **out,
                          ts_error *err);
/* The next `count` rows, top to bottom, 3 linear floats a pixel (tonemap_srgb8). */
int image_png_stream_rows(ts_png_stream *s, const float *rgb_linear, int count, ts_error *err);
/* The number of rows written so far. */
int image_png_stream_next_row(const ts_png_stream *s);
/* Ends the stream and frees it (NULL: nothing), as image_exr_stream_close. */
int image_png_stream_close(ts_png_stream *s, int commit, ts_error *err);

/* Reads the first subimage of any format OIIO knows, all channels converted to float
 * (8-bit PNG values come back as v / 255). Channel order is the one written by
 * image_write_exr where recorded, else OIIO's (by layer; R, G, B, A, Z first in each). On success
 * *out owns its pixels and names: release them with image_free. On failure *out is zeroed. */
int image_read(const char *path, ts_image *out, ts_error *err);

/* Reads the integer metadata item `key` into *value; a missing or non-integer item is
 * TS_E_IO "PATH: no integer metadata \"KEY\"". */
int image_read_meta_int(const char *path, const char *key, int *value, ts_error *err);

/* Reads the string metadata item `key` into buf (size bytes, NUL-terminated, cut short if
 * longer); a missing or non-string item is TS_E_IO "PATH: no string metadata \"KEY\"". */
int image_read_meta_string(const char *path, const char *key, char *buf, size_t size,
                           ts_error *err);

/* Frees what image_read allocated and zeroes *img. Only for images from image_read;
 * NULL and zeroed images are fine. */
void image_free(ts_image *img);

#endif
