/* image_oiio.cpp — image.h implemented with OpenImageIO 2.x. The project's only C++ file
 * (STYLE.md 11): every entry point is extern "C", catches every exception and reports it
 * through ts_error, so nothing C++ crosses into the C host. */
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include <fcntl.h>
#include <strings.h>
#include <unistd.h>

extern "C" {
#include "base/error.h"
#include "base/file.h"
#include "image/image.h"
#include "image/tonemap.h"
}

namespace
{

using OIIO::ImageInput;
using OIIO::ImageOutput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

const char *const ORDER_ATTR = "tessera:channel_order"; /* string[channels] */
const int MAX_CHANNELS = 1024;

int io_fail(ts_error *err, const char *path, std::string why)
{
    /* OIIO messages may span lines; ts_error holds one. */
    for (char &c : why)
        if (c == '\n' || c == '\r') c = ' ';
    while (!why.empty() && why.back() == ' ')
        why.pop_back();
    return ts_error_set(err, TS_E_IO, "%s: %s", path, why.c_str());
}

/* Runs body, turning any exception into a ts_error: the C boundary of this file. */
template <class F> int guarded(const char *path, ts_error *err, F body)
{
    if (!path) return ts_error_set(err, TS_E_IO, "(null path): no file name given");
    try {
        return body();
    } catch (const std::bad_alloc &) {
        return ts_error_set(err, TS_E_MEMORY, "%s: out of memory", path);
    } catch (const std::exception &e) {
        return io_fail(err, path, std::string("OpenImageIO exception: ") + e.what());
    } catch (...) {
        return io_fail(err, path, "unknown exception in OpenImageIO");
    }
}

/* Fails with "unsupported output format" unless path ends in ext (case-insensitive). */
int require_extension(const char *path, const char *ext, ts_error *err)
{
    size_t n = strlen(path), e = strlen(ext);
    if (n > e && strcasecmp(path + n - e, ext) == 0) return TS_OK;
    const char *dot = strrchr(path, '.'), *slash = strrchr(path, '/');
    std::string got = dot && (!slash || dot > slash) ? dot : "(none)";
    return io_fail(err, path, "unsupported output format \"" + got + "\" (expected " + ext + ")");
}

/* A hidden temporary next to the target, ".BASE.tmp-PID-N" (ts_file_temp_name: BASE cut
 * short to fit NAME_MAX), created with O_EXCL and the caller's umask; unlinked on
 * destruction unless commit() renamed it over the target. Stale temporaries of the same
 * target, left by a process that was killed while writing, are removed first. */
class temp_file
{
  public:
    std::string name;
    temp_file() = default;
    temp_file(const temp_file &) = delete;
    temp_file &operator=(const temp_file &) = delete;
    ~temp_file()
    {
        if (!name.empty() && !committed_) unlink(name.c_str());
    }
    int create(const char *path, ts_error *err);
    int commit(const char *path, ts_error *err);

  private:
    bool committed_ = false;
};

int temp_file::create(const char *path, ts_error *err)
{
    static std::atomic<unsigned> counter{0};
    ts_file_remove_stale_temps(path); /* left by a render killed while it wrote */
    int last_errno = 0;
    for (int attempt = 0; attempt < 100; attempt++) {
        char cand[8192];
        if (ts_file_temp_name(path, (long)getpid(), counter++, cand, sizeof cand) != 0)
            return io_fail(err, path, "the path is too long");
        int fd = open(cand, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0) {
            close(fd); /* OIIO reopens it by name */
            name = cand;
            return TS_OK;
        }
        last_errno = errno;
        if (errno != EEXIST) break; /* a temporary of a live process: try the next */
    }
    return io_fail(err, path,
                   std::string("cannot create a temporary file beside it: ") +
                       strerror(last_errno));
}

int temp_file::commit(const char *path, ts_error *err)
{
    /* Flush the data before the rename makes it visible, so a crash cannot leave a
     * truncated file under the target name. */
    int fd = open(name.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0 || fsync(fd) != 0) {
        int e = errno;
        if (fd >= 0) close(fd);
        return io_fail(err, path, std::string("cannot sync temporary file: ") + strerror(e));
    }
    close(fd);
    if (rename(name.c_str(), path) != 0)
        return io_fail(err, path,
                       std::string("cannot rename temporary file over it: ") + strerror(errno));
    committed_ = true;
    return TS_OK;
}

/* Writes pixels (of type `type`, laid out as spec says) with OIIO's writer `format`
 * ("openexr", "png") atomically to path. The writer is chosen by name, so the temporary's
 * file name needs no particular extension. */
int write_atomic(const char *path, const char *format, const ImageSpec &spec, TypeDesc type,
                 const void *pixels, ts_error *err)
{
    temp_file tmp; /* declared first: destroyed after the writer has closed the file */
    std::unique_ptr<ImageOutput> out = ImageOutput::create(format);
    if (!out)
        return io_fail(err, path,
                       std::string("no OpenImageIO writer for ") + format + ": " +
                           OIIO::geterror());
    int rc = tmp.create(path, err);
    if (rc) return rc;
    if (!out->open(tmp.name, spec))
        return io_fail(err, path, "cannot open for writing: " + out->geterror());
    if (!out->write_image(type, pixels))
        return io_fail(err, path, "cannot write pixels: " + out->geterror());
    if (!out->close()) return io_fail(err, path, "cannot finish writing: " + out->geterror());
    out.reset();
    return tmp.commit(path, err);
}

int check_size(const char *path, int width, int height, int channels, ts_error *err)
{
    if (width <= 0 || height <= 0 || channels <= 0 || channels > MAX_CHANNELS)
        return io_fail(err, path,
                       "invalid image size " + std::to_string(width) + "x" +
                           std::to_string(height) + "x" + std::to_string(channels));
    return TS_OK;
}

/* Channel names must be present, non-empty and distinct: EXR keys channels by name. */
int check_names(const char *path, const ts_image *img, ts_error *err)
{
    if (!img->channel_names) return TS_OK;
    for (int c = 0; c < img->channels; c++) {
        const char *n = img->channel_names[c];
        if (!n || !*n) return io_fail(err, path, "channel " + std::to_string(c) + " has no name");
        for (int d = 0; d < c; d++)
            if (strcmp(n, img->channel_names[d]) == 0)
                return io_fail(err, path, std::string("duplicate channel name \"") + n + "\"");
    }
    return TS_OK;
}

int write_exr(const char *path, const ts_image *img, const ts_image_meta *meta, int meta_count,
              const ts_image_text *text, int text_count, ts_error *err)
{
    int rc = require_extension(path, ".exr", err);
    if (!rc && !img) rc = io_fail(err, path, "no image given");
    if (!rc) rc = check_size(path, img->width, img->height, img->channels, err);
    if (!rc && !img->pixels) rc = io_fail(err, path, "no pixel data");
    if (!rc) rc = check_names(path, img, err);
    if (rc) return rc;
    ImageSpec spec(img->width, img->height, img->channels, TypeDesc::FLOAT);
    if (img->channel_names)
        spec.channelnames.assign(img->channel_names, img->channel_names + img->channels);
    spec.attribute("compression", "zip");
    for (int i = 0; i < meta_count; i++) {
        if (!meta || !meta[i].key || !*meta[i].key)
            return io_fail(err, path, "metadata item " + std::to_string(i) + " has no key");
        spec.attribute(meta[i].key, meta[i].value);
    }
    for (int i = 0; i < text_count; i++) {
        if (!text || !text[i].key || !*text[i].key || !text[i].text)
            return io_fail(err, path, "text metadata item " + std::to_string(i) + " is incomplete");
        spec.attribute(text[i].key, text[i].text);
    }
    /* EXR sorts channels by name on disk; record ours so image_read can restore it. */
    std::vector<OIIO::ustring> order(spec.channelnames.begin(), spec.channelnames.end());
    spec.attribute(ORDER_ATTR, TypeDesc(TypeDesc::STRING, img->channels), order.data());
    return write_atomic(path, "openexr", spec, TypeDesc::FLOAT, img->pixels, err);
}

int write_png(const char *path, int width, int height, const float *rgb, ts_error *err)
{
    int rc = require_extension(path, ".png", err);
    if (!rc) rc = check_size(path, width, height, 3, err);
    if (!rc && !rgb) rc = io_fail(err, path, "no pixel data");
    if (rc) return rc;
    size_t count = (size_t)width * (size_t)height * 3;
    std::vector<uint8_t> srgb(count);
    tonemap_srgb8_buffer(rgb, srgb.data(), count);
    ImageSpec spec(width, height, 3, TypeDesc::UINT8);
    spec.attribute("oiio:ColorSpace", "sRGB");
    return write_atomic(path, "png", spec, TypeDesc::UINT8, srgb.data(), err);
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
        return io_fail(err, path, std::string("cannot read: ") + strerror(errno));
    /* Only regular files: OIIO spins forever on /dev/zero and blocks on a FIFO. */
    if (ts_file_check_regular(path, err)) return err->code;
    in = ImageInput::open(path);
    if (!in) return io_fail(err, path, "cannot read: " + OIIO::geterror());
    return TS_OK;
}

int read_image(const char *path, ts_image *out, ts_error *err)
{
    std::unique_ptr<ImageInput> in;
    int rc = open_input(path, in, err);
    if (rc) return rc;
    const ImageSpec &spec = in->spec();
    if (spec.deep || spec.depth > 1)
        return io_fail(err, path, "deep and volume images are not supported");
    rc = check_size(path, spec.width, spec.height, spec.nchannels, err);
    if (rc) return rc;
    size_t pixel_count = (size_t)spec.width * (size_t)spec.height;
    std::unique_ptr<float, decltype(&free)> px(
        static_cast<float *>(malloc(pixel_count * spec.nchannels * sizeof(float))), &free);
    if (!px) return ts_error_set(err, TS_E_MEMORY, "%s: out of memory for pixels", path);
    if (!in->read_image(0, 0, 0, spec.nchannels, TypeDesc::FLOAT, px.get()))
        return io_fail(err, path, "cannot read pixels: " + in->geterror());
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
    if (!key || !value) return io_fail(err, path, "no metadata key or destination given");
    std::unique_ptr<ImageInput> in;
    int rc = open_input(path, in, err);
    if (rc) return rc;
    const OIIO::ParamValue *p = in->spec().find_attribute(key, OIIO::TypeInt);
    if (!p) return io_fail(err, path, std::string("no integer metadata \"") + key + "\"");
    *value = p->get_int();
    return TS_OK;
}

int read_meta_string(const char *path, const char *key, char *buf, size_t size, ts_error *err)
{
    if (!key || !buf || size == 0) return io_fail(err, path, "no metadata key or buffer given");
    std::unique_ptr<ImageInput> in;
    int rc = open_input(path, in, err);
    if (rc) return rc;
    const OIIO::ParamValue *p = in->spec().find_attribute(key, OIIO::TypeString);
    if (!p) return io_fail(err, path, std::string("no string metadata \"") + key + "\"");
    std::string v = p->get_string();
    size_t n = std::min(v.size(), size - 1);
    memcpy(buf, v.data(), n);
    buf[n] = '\0';
    return TS_OK;
}

} // namespace

extern "C" int image_write_exr(const char *path, const ts_image *img, const ts_image_meta *meta,
                               int meta_count, ts_error *err)
{
    return guarded(path, err, [&] { return write_exr(path, img, meta, meta_count, NULL, 0, err); });
}

extern "C" int image_write_exr_text(const char *path, const ts_image *img,
                                    const ts_image_meta *meta, int meta_count,
                                    const ts_image_text *text, int text_count, ts_error *err)
{
    return guarded(path, err,
                   [&] { return write_exr(path, img, meta, meta_count, text, text_count, err); });
}

extern "C" int image_write_png(const char *path, int width, int height, const float *rgb_linear,
                               ts_error *err)
{
    return guarded(path, err, [&] { return write_png(path, width, height, rgb_linear, err); });
}

extern "C" int image_read(const char *path, ts_image *out, ts_error *err)
{
    if (!out)
        return ts_error_set(err, TS_E_IO, "%s: no output image given", path ? path : "(null path)");
    memset(out, 0, sizeof *out);
    return guarded(path, err, [&] { return read_image(path, out, err); });
}

extern "C" int image_read_meta_int(const char *path, const char *key, int *value, ts_error *err)
{
    return guarded(path, err, [&] { return read_meta_int(path, key, value, err); });
}

extern "C" int image_read_meta_string(const char *path, const char *key, char *buf, size_t size,
                                      ts_error *err)
{
    return guarded(path, err, [&] { return read_meta_string(path, key, buf, size, err); });
}

extern "C" void image_free(ts_image *img)
{
    if (!img) return;
    free(img->pixels);
    free(const_cast<char **>(img->channel_names));
    memset(img, 0, sizeof *img);
}
