/* image_png.h — PNG output through libpng (image_png.c), for image.c: image_write_png once
 * path's extension was checked. PNG input (textures) goes through the OpenImageIO module. */
#ifndef TS_IMAGE_PNG_H
#define TS_IMAGE_PNG_H

#include "base/error.h"
#include "image/image.h"

/* Writes width x height pixels of rgb_linear (3 floats a pixel, rows top to bottom) as
 * 8-bit sRGB (tonemap_srgb8) atomically to path. TS_OK or TS_E_IO / TS_E_MEMORY. */
int image_png_write(const char *path, int width, int height, const float *rgb_linear,
                    ts_error *err);

/* image_png_stream_open once path's extension was checked (image_png_stream_rows,
 * image_png_stream_next_row and image_png_stream_close are image_png.c's own). */
int image_png_open_stream(const char *path, int width, int height, ts_png_stream **out,
                          ts_error *err);

#endif
