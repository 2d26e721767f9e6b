/* image_exr.h — OpenEXR files read and written with the OpenEXR library itself
 * (image_exr.cpp; Debian libopenexr-dev), for image.c. Renders, resumes and bakes touch
 * only EXR (and write PNG, image_png.c), so they never load OpenImageIO, which costs a
 * process about 0.17 s of start-up (image_module.h). The semantics are image.h's. */
#ifndef TS_IMAGE_EXR_H
#define TS_IMAGE_EXR_H

#include "image/image.h"

/* 1 when the first four bytes of the file at path are OpenEXR's magic number (the file is
 * a regular file: image.c checks that before). */
int image_exr_check_magic(const char *path);

/* image_write_exr_text once path's extension was checked. */
int image_exr_write(const char *path, const ts_image *img, const ts_image_meta *meta,
                    int meta_count, const ts_image_text *text, int text_count, ts_error *err);

/* image_exr_stream_open once path's extension was checked (image_exr_stream_rows,
 * image_exr_stream_next_row and image_exr_stream_close are image_exr.cpp's own). */
int image_exr_open_stream(const char *path, const ts_image *shape, const ts_image_meta *meta,
                          int meta_count, const ts_image_text *text, int text_count,
                          ts_exr_stream **out, ts_error *err);

/* image_read, image_read_meta_int and image_read_meta_string for an EXR file, once image.c
 * checked that path is a readable regular file (they do not check it again). */
int image_exr_read(const char *path, ts_image *out, ts_error *err);
int image_exr_read_meta_int(const char *path, const char *key, int *value, ts_error *err);
int image_exr_read_meta_string(const char *path, const char *key, char *buf, size_t size,
                               ts_error *err);

#endif
