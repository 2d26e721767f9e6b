/* image_module.h — the table of entry points the image module (libtessera_image.so, built
 * from image_oiio.cpp) hands to the loader (image.c). The module reads every image format
 * OpenImageIO knows (textures, environment maps) and is opened with dlopen on the first
 * such read, not linked: OpenImageIO brings in about 260 shared libraries, whose relocation
 * took 0.17 s of every process's start (docs/benchmarks.md "Process start: OpenImageIO
 * only where it is needed"), whether or not it touched an image.
 *
 * Both sides include this header; a module built from other sources is refused unless its
 * `version` and `size` match (TS_IMAGE_MODULE_VERSION rises with any change below). */
#ifndef TS_IMAGE_MODULE_H
#define TS_IMAGE_MODULE_H

#include "image/image.h"

#define TS_IMAGE_MODULE_VERSION 1
#define TS_IMAGE_MODULE_FILE "libtessera_image.so"
/* The one symbol the module exports: `const ts_image_module *tessera_image_module(void)`. */
#define TS_IMAGE_MODULE_SYMBOL "tessera_image_module"

typedef struct ts_image_module {
    int version; /* TS_IMAGE_MODULE_VERSION */
    size_t size; /* sizeof(ts_image_module) */
    /* The image.h readers of the same names, for files that are not EXR (image.c reads
     * those itself; image_free is plain free(): the module allocates with malloc). */
    int (*read)(const char *path, ts_image *out, ts_error *err);
    int (*read_meta_int)(const char *path, const char *key, int *value, ts_error *err);
    int (*read_meta_string)(const char *path, const char *key, char *buf, size_t size,
                            ts_error *err);
} ts_image_module;

typedef const ts_image_module *(*ts_image_module_fn)(void);

#endif
