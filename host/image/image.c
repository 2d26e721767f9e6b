/* image.c — image.h for the host. EXR files are read and written with the OpenEXR library
 * (image_exr.cpp) and PNG files written with libpng (image_png.c), both linked; any other
 * format is read through the OpenImageIO module (image_module.h), opened on the first such
 * read. Renders, resumes and bakes without such textures touch only EXR and PNG, so they
 * never pay for OpenImageIO's libraries.
 *
 * Where the module is looked for, first found wins: $TESSERA_IMAGE_MODULE (a path; when
 * set, the only place tried), the running executable's directory, then the build tree's
 * path compiled in as TS_IMAGE_MODULE_PATH (the tests and tools live in other
 * directories of the build). */
#include "image/image.h"
#include "base/file.h"
#include "image/image_exr.h"
#include "image/image_module.h"
#include "image/image_png.h"

#include <errno.h>
#include <strings.h>

#include <dlfcn.h>
#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#ifndef TS_IMAGE_MODULE_PATH
#define TS_IMAGE_MODULE_PATH ""
#endif

static pthread_once_t module_once = PTHREAD_ONCE_INIT;
static const ts_image_module *module_api; /* set once by module_load, then read-only */
static char module_why[1536];             /* why it failed: one line, for every caller */

/* Appends "candidate: reason" (or the reason alone) to module_why. */
static void why_add(const char *candidate, const char *reason)
{
    size_t n = strlen(module_why);
    snprintf(module_why + n, sizeof module_why - n, "%s%s%s%s", n ? "; " : "",
             candidate ? candidate : "", candidate ? ": " : "", reason ? reason : "unknown error");
}

/* Opens candidate and takes its table; 1 when it is a module of this build. */
static int module_try(const char *candidate)
{
    void *lib = dlopen(candidate, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        why_add(NULL, dlerror()); /* "PATH: reason" already */
        return 0;
    }
    ts_image_module_fn entry;
    *(void **)&entry = dlsym(lib, TS_IMAGE_MODULE_SYMBOL);
    const ts_image_module *api = entry ? entry() : NULL;
    if (!api || api->version != TS_IMAGE_MODULE_VERSION || api->size != sizeof *api) {
        why_add(candidate, entry ? "a module of another Tessera version" : dlerror());
        dlclose(lib);
        return 0;
    }
    module_api = api; /* never closed: the process uses it to the end */
    return 1;
}

static void module_load(void)
{
    const char *env = getenv("TESSERA_IMAGE_MODULE");
    if (env && *env) {
        module_try(env);
        return;
    }
    char exe[PATH_MAX];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n > 0) {
        exe[n] = '\0';
        char *slash = strrchr(exe, '/');
        char candidate[PATH_MAX + sizeof TS_IMAGE_MODULE_FILE];
        if (slash) {
            slash[1] = '\0';
            snprintf(candidate, sizeof candidate, "%s%s", exe, TS_IMAGE_MODULE_FILE);
            if (module_try(candidate)) return;
        }
    }
    if (*TS_IMAGE_MODULE_PATH) module_try(TS_IMAGE_MODULE_PATH);
}

/* The module (loaded by the first caller; the others wait for it), or NULL. */
static const ts_image_module *module_get(void)
{
    pthread_once(&module_once, module_load);
    return module_api;
}

/* TS_E_IO "PATH: cannot load the image module (why)". */
static int module_fail(const char *path, ts_error *err)
{
    return ts_error_set(err, TS_E_IO,
                        "%s: cannot load the image module " TS_IMAGE_MODULE_FILE
                        " (%s); set TESSERA_IMAGE_MODULE to its path",
                        path ? path : "(null path)", module_why);
}

/* TS_OK when path ends in ext (case-insensitive); else "unsupported output format". */
static int require_extension(const char *path, const char *ext, ts_error *err)
{
    if (!path) return ts_error_set(err, TS_E_IO, "(null path): no file name given");
    size_t n = strlen(path), e = strlen(ext);
    if (n > e && strcasecmp(path + n - e, ext) == 0) return TS_OK;
    const char *dot = strrchr(path, '.'), *slash = strrchr(path, '/');
    return ts_error_set(err, TS_E_IO, "%s: unsupported output format \"%s\" (expected %s)", path,
                        dot && (!slash || dot > slash) ? dot : "(none)", ext);
}

/* TS_OK when path is a readable regular file (never opening a FIFO or /dev/zero); then
 * *exr says whether it is an EXR file. */
static int read_check(const char *path, int *exr, ts_error *err)
{
    if (!path) return ts_error_set(err, TS_E_IO, "(null path): no file name given");
    if (access(path, R_OK) != 0)
        return ts_error_set(err, TS_E_IO, "%s: cannot read: %s", path, strerror(errno));
    if (ts_file_check_regular(path, err)) return err ? err->code : TS_E_IO;
    *exr = image_exr_check_magic(path);
    return TS_OK;
}

int image_write_exr(const char *path, const ts_image *img, const ts_image_meta *meta,
                    int meta_count, ts_error *err)
{
    return image_write_exr_text(path, img, meta, meta_count, NULL, 0, err);
}

int image_write_exr_text(const char *path, const ts_image *img, const ts_image_meta *meta,
                         int meta_count, const ts_image_text *text, int text_count, ts_error *err)
{
    int rc = require_extension(path, ".exr", err);
    return rc ? rc : image_exr_write(path, img, meta, meta_count, text, text_count, err);
}

int image_exr_stream_open(const char *path, const ts_image *shape, const ts_image_meta *meta,
                          int meta_count, const ts_image_text *text, int text_count,
                          ts_exr_stream **out, ts_error *err)
{
    *out = NULL;
    int rc = require_extension(path, ".exr", err);
    return rc ? rc
              : image_exr_open_stream(path, shape, meta, meta_count, text, text_count, out, err);
}

int image_write_png(const char *path, int width, int height, const float *rgb_linear, ts_error *err)
{
    int rc = require_extension(path, ".png", err);
    return rc ? rc : image_png_write(path, width, height, rgb_linear, err);
}

int image_png_stream_open(const char *path, int width, int height, ts_png_stream **out,
                          ts_error *err)
{
    *out = NULL;
    int rc = require_extension(path, ".png", err);
    return rc ? rc : image_png_open_stream(path, width, height, out, err);
}

int image_read(const char *path, ts_image *out, ts_error *err)
{
    if (!out)
        return ts_error_set(err, TS_E_IO, "%s: no output image given", path ? path : "(null path)");
    memset(out, 0, sizeof *out);
    int exr = 0, rc = read_check(path, &exr, err);
    if (rc || exr) return rc ? rc : image_exr_read(path, out, err);
    const ts_image_module *m = module_get();
    return m ? m->read(path, out, err) : module_fail(path, err);
}

int image_read_meta_int(const char *path, const char *key, int *value, ts_error *err)
{
    int exr = 0, rc = read_check(path, &exr, err);
    if (rc || exr) return rc ? rc : image_exr_read_meta_int(path, key, value, err);
    const ts_image_module *m = module_get();
    return m ? m->read_meta_int(path, key, value, err) : module_fail(path, err);
}

int image_read_meta_string(const char *path, const char *key, char *buf, size_t size, ts_error *err)
{
    int exr = 0, rc = read_check(path, &exr, err);
    if (rc || exr) return rc ? rc : image_exr_read_meta_string(path, key, buf, size, err);
    const ts_image_module *m = module_get();
    return m ? m->read_meta_string(path, key, buf, size, err) : module_fail(path, err);
}

void image_free(ts_image *img)
{
    if (!img) return;
    free(img->pixels);
    free((void *)img->channel_names);
    memset(img, 0, sizeof *img);
}
