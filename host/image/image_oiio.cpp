/* image_oiio.cpp — image.h's readers for every format that is not EXR (textures, environment
 * maps: PNG, JPEG, TIFF, PPM, HDR, ...) through OpenImageIO 2.x, built as the image module
 * libtessera_image.so that image.c opens on demand (image_module.h). As STYLE.md 11 asks of
 * the OpenImageIO shim, every entry point catches every exception and reports it through
 * ts_error, so nothing C++ crosses into the C host; the one exported symbol is the C
 * function tessera_image_module (the module is built with hidden visibility, so its own
 * copies of base/error.c and base/file.c stay private to it). */
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include <strings.h>
#include <unistd.h>

extern "C" {
#include "base/error.h"
#include "base/file.h"
#include "image/image.h"
#include "image/image_module.h"
}

#include "image/image_guard.h"

namespace
{

using OIIO::ImageInput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

const char *const ORDER_ATTR = "tessera:channel_order"; /* string[channels] */
const int MAX_CHANNELS = 1024;

/* The C boundary (image_guard.h), naming this file's library. */
template <class F> int guarded(const char *path, ts_error *err, F body)
{
    return image_guarded("OpenImageIO", path, err, body);
}

int check_size(const char *path, int width, int height, int channels, ts_error *err)
{
    if (width <= 0 || height <= 0 || channels <= 0 || channels > MAX_CHANNELS)
        return image_fail(err, path,
                          "invalid image size " + std::to_string(width) + "x" +
                              std::to_string(height) + "x" + std::to_string(channels));
    return TS_OK;
}

/* perm[k] = file channel shown as channel k: the order recorded by write_exr when it names
 * exactly the file's channels, else the file's (OIIO's) order. */
std::vector<int> channel_order(const ImageSpec &spec)
{
    int n = spec.nchannels;
    std::vector<int> perm(n);
    for (int k = 0; k < n; k++)
        perm[k] = k;
    const OIIO::ParamValue *p = spec.find_attribute(ORDER_ATTR);
    if (!p || p->type().basetype != TypeDesc::STRING ||
        (int)p->type().numelements() * p->nvalues() != n)
        return perm;
    const OIIO::ustring *want = static_cast<const OIIO::ustring *>(p->data());
    std::vector<int> found(n, -1);
    std::vector<bool> used(n, false);
    for (int k = 0; k < n; k++) {
        for (int j = 0; j < n && found[k] < 0; j++)
            if (!used[j] && spec.channelnames[j] == want[k].string()) found[k] = j;
        if (found[k] < 0) return perm;
        used[found[k]] = true;
    }
    return found;
}

/* One malloc'd block: n + 1 pointers (NULL-terminated) then the names, so that a single
 * free() releases it. Returns NULL if allocation fails. */
const char **names_alloc(const ImageSpec &spec, const std::vector<int> &perm)
{
    size_t n = perm.size(), bytes = (n + 1) * sizeof(char *);
    for (int j : perm)
        bytes += spec.channelnames[j].size() + 1;
    char **names = static_cast<char **>(malloc(bytes));
    if (!names) return nullptr;
    char *text = reinterpret_cast<char *>(names + n + 1);
    for (size_t k = 0; k < n; k++) {
        const std::string &s = spec.channelnames[perm[k]];
        memcpy(text, s.c_str(), s.size() + 1);
        names[k] = text;
        text += s.size() + 1;
    }
    names[n] = nullptr;
    return const_cast<const char **>(names);
}

/* Reorders interleaved pixels in place so that channel k holds file channel perm[k]. */
void permute_channels(float *px, size_t pixel_count, const std::vector<int> &perm)
{
    size_t n = perm.size();
    std::vector<float> tmp(n);
    for (size_t i = 0; i < pixel_count; i++, px += n) {
        for (size_t k = 0; k < n; k++)
            tmp[k] = px[perm[k]];
        memcpy(px, tmp.data(), n * sizeof(float));
    }
}

/* Opens path for reading into in. OIIO's own message for a missing file gives no reason,
 * so errno's is reported for files that cannot be opened at all. */
int open_input(const char *path, std::unique_ptr<ImageInput> &in, ts_error *err)
{
    if (access(path, R_OK) != 0)
        return image_fail(err, path, std::string("cannot read: ") + strerror(errno));
    /* Only regular files: OIIO spins forever on /dev/zero and blocks on a FIFO. */
    if (ts_file_check_regular(path, err)) return err->code;
    in = ImageInput::open(path);
    if (!in) return image_fail(err, path, "cannot read: " + OIIO::geterror());
    return TS_OK;
}

int read_image(const char *path, ts_image *out, ts_error *err)
{
    std::unique_ptr<ImageInput> in;
    int rc = open_input(path, in, err);
    if (rc) return rc;
    const ImageSpec &spec = in->spec();
    if (spec.deep || spec.depth > 1)
        return image_fail(err, path, "deep and volume images are not supported");
    rc = check_size(path, spec.width, spec.height, spec.nchannels, err);
    if (rc) return rc;
    size_t pixel_count = (size_t)spec.width * (size_t)spec.height;
    std::unique_ptr<float, decltype(&free)> px(
        static_cast<float *>(malloc(pixel_count * spec.nchannels * sizeof(float))), &free);
    if (!px) return ts_error_set(err, TS_E_MEMORY, "%s: out of memory for pixels", path);
    if (!in->read_image(0, 0, 0, spec.nchannels, TypeDesc::FLOAT, px.get()))
        return image_fail(err, path, "cannot read pixels: " + in->geterror());
    std::vector<int> perm = channel_order(spec);
    for (int k = 0; k < spec.nchannels; k++)
        if (perm[k] != k) {
            permute_channels(px.get(), pixel_count, perm);
            break;
        }
    const char **names = names_alloc(spec, perm);
    if (!names) return ts_error_set(err, TS_E_MEMORY, "%s: out of memory for names", path);
    out->width = spec.width;
    out->height = spec.height;
    out->channels = spec.nchannels;
    out->channel_names = names;
    out->pixels = px.release();
    return TS_OK;
}

int read_meta_int(const char *path, const char *key, int *value, ts_error *err)
{
    if (!key || !value) return image_fail(err, path, "no metadata key or destination given");
    std::unique_ptr<ImageInput> in;
    int rc = open_input(path, in, err);
    if (rc) return rc;
    const OIIO::ParamValue *p = in->spec().find_attribute(key, OIIO::TypeInt);
    if (!p) return image_fail(err, path, std::string("no integer metadata \"") + key + "\"");
    *value = p->get_int();
    return TS_OK;
}

int read_meta_string(const char *path, const char *key, char *buf, size_t size, ts_error *err)
{
    if (!key || !buf || size == 0) return image_fail(err, path, "no metadata key or buffer given");
    std::unique_ptr<ImageInput> in;
    int rc = open_input(path, in, err);
    if (rc) return rc;
    const OIIO::ParamValue *p = in->spec().find_attribute(key, OIIO::TypeString);
    if (!p) return image_fail(err, path, std::string("no string metadata \"") + key + "\"");
    std::string v = p->get_string();
    size_t n = std::min(v.size(), size - 1);
    memcpy(buf, v.data(), n);
    buf[n] = '\0';
    return TS_OK;
}

/* The module's entry points: the C boundary (guarded catches every exception). */
int module_read(const char *path, ts_image *out, ts_error *err)
{
    if (!out)
        return ts_error_set(err, TS_E_IO, "%s: no output image given", path ? path : "(null path)");
    memset(out, 0, sizeof *out);
    return guarded(path, err, [&] { return read_image(path, out, err); });
}

int module_read_meta_int(const char *path, const char *key, int *value, ts_error *err)
{
    return guarded(path, err, [&] { return read_meta_int(path, key, value, err); });
}

int module_read_meta_string(const char *path, const char *key, char *buf, size_t size,
                            ts_error *err)
{
    return guarded(path, err, [&] { return read_meta_string(path, key, buf, size, err); });
}

const ts_image_module MODULE = {TS_IMAGE_MODULE_VERSION, sizeof(ts_image_module), module_read,
                                module_read_meta_int, module_read_meta_string};

} // namespace

extern "C" __attribute__((visibility("default"))) const ts_image_module *tessera_image_module(void)
{
    return &MODULE;
}
