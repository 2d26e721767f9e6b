/* image_exr.cpp — EXR files through the OpenEXR 3 library (image_exr.h). Like the
 * OpenImageIO module (image_oiio.cpp, STYLE.md 11) every entry point is extern "C" and
 * catches every exception, reporting it through ts_error; nothing C++ crosses into the host.
 *
 * Files written: scanline, ZIP-compressed, 32-bit float channels, integer and string
 * attributes, and "tessera:channel_order" (a string vector) because EXR stores channels
 * sorted by name; the files OpenImageIO wrote before (the same layout and attributes) read
 * back the same. Files read: any single-part scanline or tiled EXR, every channel converted
 * to float. */
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfIntAttribute.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <OpenEXR/ImfStringVectorAttribute.h>
#include <OpenEXR/ImfThreading.h>

#include <algorithm>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <vector>

#include <strings.h>
#include <unistd.h>

extern "C" {
#include "base/error.h"
#include "base/file.h"
#include "image/image_exr.h"
}

#include "image/image_guard.h"

namespace
{

const char *const ORDER_ATTR = "tessera:channel_order"; /* string vector, one per channel */
const int MAX_CHANNELS = 1024;

/* OpenEXR compresses and decompresses the lines of a file on its global thread pool, which
 * is empty until set: one thread a processor, as OpenImageIO set it (a 1920x768 image of 10
 * float channels took 0.85 s to write on one thread, 0.49 s on two). Images are written
 * after the devices finish, so the threads take no processor from a render. */
void exr_threads(void)
{
    static std::once_flag once;
    std::call_once(once, [] {
        long n = sysconf(_SC_NPROCESSORS_ONLN);
        Imf::setGlobalThreadCount(n > 1 ? (int)std::min(n, 64L) : 0);
    });
}

/* The C boundary (image_guard.h), naming this file's library; the thread pool set first. */
template <class F> int guarded(const char *path, ts_error *err, F body)
{
    return image_guarded("OpenEXR", path, err, [&] {
        exr_threads();
        return body();
    });
}

int check_size(const char *path, long width, long height, int channels, ts_error *err)
{
    if (width <= 0 || height <= 0 || width > INT_MAX || height > INT_MAX || channels <= 0 ||
        channels > MAX_CHANNELS)
        return image_fail(err, path,
                          "invalid image size " + std::to_string(width) + "x" +
                              std::to_string(height) + "x" + std::to_string(channels));
    return TS_OK;
}

/* The names of img's channels: its own (present, non-empty, distinct: EXR keys channels by
 * name), or OpenImageIO's defaults when it has none (Y for one channel; else R, G, B, A,
 * channel4, channel5, ...), which the files written before this writer used. */
int channel_names(const char *path, const ts_image *img, std::vector<std::string> &names,
                  ts_error *err)
{
    for (int c = 0; c < img->channels; c++) {
        if (!img->channel_names) {
            static const char *const rgba[] = {"R", "G", "B", "A"};
            names.push_back(img->channels == 1 ? std::string("Y")
                            : c < 4            ? std::string(rgba[c])
                                               : "channel" + std::to_string(c));
            continue;
        }
        const char *n = img->channel_names[c];
        if (!n || !*n)
            return image_fail(err, path, "channel " + std::to_string(c) + " has no name");
        for (int d = 0; d < c; d++)
            if (names[d] == n)
                return image_fail(err, path, std::string("duplicate channel name \"") + n + "\"");
        names.push_back(n);
    }
    return TS_OK;
}

/* The header: size, ZIP, float channels, the metadata and the channel order. */
int make_header(const char *path, const ts_image *img, const std::vector<std::string> &names,
                const ts_image_meta *meta, int meta_count, const ts_image_text *text,
                int text_count, Imf::Header &h, ts_error *err)
{
    if (img->full_width > 0) { /* a part of the frame: its data window in the display window */
        if (img->x0 < 0 || img->y0 < 0 || img->x0 + img->width > img->full_width ||
            img->y0 + img->height > img->full_height)
            return image_fail(err, path, "the image does not lie in its frame");
        h = Imf::Header(
            Imath::Box2i(Imath::V2i(0, 0), Imath::V2i(img->full_width - 1, img->full_height - 1)),
            Imath::Box2i(Imath::V2i(img->x0, img->y0),
                         Imath::V2i(img->x0 + img->width - 1, img->y0 + img->height - 1)));
    } else {
        h = Imf::Header(img->width, img->height);
    }
    h.compression() = Imf::ZIP_COMPRESSION;
    for (const std::string &n : names)
        h.channels().insert(n, Imf::Channel(Imf::FLOAT));
    for (int i = 0; i < meta_count; i++) {
        if (!meta || !meta[i].key || !*meta[i].key)
            return image_fail(err, path, "metadata item " + std::to_string(i) + " has no key");
        h.insert(meta[i].key, Imf::IntAttribute(meta[i].value));
    }
    for (int i = 0; i < text_count; i++) {
        if (!text || !text[i].key || !*text[i].key || !text[i].text)
            return image_fail(err, path,
                              "text metadata item " + std::to_string(i) + " is incomplete");
        h.insert(text[i].key, Imf::StringAttribute(text[i].text));
    }
    h.insert(ORDER_ATTR, Imf::StringVectorAttribute(names));
    return TS_OK;
}

/* The frame buffer of rows [first, ...) of an image `width` pixels wide whose pixels (the
 * channels interleaved) start at `rows` and whose data window starts at (x0, y0): OpenEXR
 * addresses pixel (x, y) at base + x * xs + y * ys, so the base lies y0 + first rows and x0
 * pixels before them. */
Imf::FrameBuffer frame_buffer(const std::vector<std::string> &names, int width, const float *rows,
                              int first, int x0, int y0)
{
    size_t xs = sizeof(float) * names.size(), ys = xs * (size_t)width;
    const char *base = (const char *)rows - ((ptrdiff_t)first + y0) * (ptrdiff_t)ys -
                       (ptrdiff_t)x0 * (ptrdiff_t)xs;
    Imf::FrameBuffer fb;
    for (size_t c = 0; c < names.size(); c++)
        fb.insert(names[c], Imf::Slice(Imf::FLOAT, (char *)base + c * sizeof(float), xs, ys));
    return fb;
}

/* The header (channels, metadata) and a temporary beside path to write it to: what every
 * write begins with. */
int write_begin(const char *path, const ts_image *img, const ts_image_meta *meta, int meta_count,
                const ts_image_text *text, int text_count, std::vector<std::string> &names,
                Imf::Header &h, char *tmp, size_t cap, ts_error *err)
{
    if (!img) return image_fail(err, path, "no image given");
    int rc = check_size(path, img->width, img->height, img->channels, err);
    if (!rc) rc = channel_names(path, img, names, err);
    if (!rc) rc = make_header(path, img, names, meta, meta_count, text, text_count, h, err);
    if (!rc) rc = ts_file_temp_create(path, tmp, cap, err);
    return rc;
}

int write_exr(const char *path, const ts_image *img, const ts_image_meta *meta, int meta_count,
              const ts_image_text *text, int text_count, ts_error *err)
{
    if (img && !img->pixels) return image_fail(err, path, "no pixel data");
    std::vector<std::string> names;
    Imf::Header h;
    char tmp[8192];
    int rc =
        write_begin(path, img, meta, meta_count, text, text_count, names, h, tmp, sizeof tmp, err);
    if (rc) return rc;
    try {
        Imf::OutputFile out(tmp, h);
        out.setFrameBuffer(frame_buffer(names, img->width, img->pixels, 0, img->x0, img->y0));
        out.writePixels(img->height);
    } catch (...) {
        unlink(tmp);
        throw; /* guarded reports it */
    }
    return ts_file_temp_commit(tmp, path, err);
}

/* Where OpenImageIO put a channel when a file carries no recorded order (the files other
 * tools wrote: environment maps, textures): by layer (the name up to its last '.'), then
 * R, G, B, A, Z of that layer in that order, then the others in the file's (name) order. */
int channel_rank(const std::string &name)
{
    size_t dot = name.rfind('.');
    std::string leaf = dot == std::string::npos ? name : name.substr(dot + 1);
    static const char *const special[][2] = {
        {"R", "red"}, {"G", "green"}, {"B", "blue"}, {"A", "alpha"}, {"Z", "depth"}};
    for (int k = 0; k < 5; k++)
        if (strcasecmp(leaf.c_str(), special[k][0]) == 0 ||
            strcasecmp(leaf.c_str(), special[k][1]) == 0)
            return k;
    return 5;
}

std::string channel_layer(const std::string &name)
{
    size_t dot = name.rfind('.');
    return dot == std::string::npos ? std::string() : name.substr(0, dot);
}

/* The file's channels in the order to return them: the recorded order when it names
 * exactly the file's channels, else channel_rank's. */
std::vector<std::string> read_order(const Imf::Header &h)
{
    std::vector<std::string> file;
    for (Imf::ChannelList::ConstIterator i = h.channels().begin(); i != h.channels().end(); ++i)
        file.push_back(i.name());
    const Imf::StringVectorAttribute *rec =
        h.findTypedAttribute<Imf::StringVectorAttribute>(ORDER_ATTR);
    if (rec) {
        std::vector<std::string> want = rec->value(), a = want, b = file;
        std::sort(a.begin(), a.end());
        std::sort(b.begin(), b.end());
        if (a == b && std::adjacent_find(a.begin(), a.end()) == a.end()) return want;
    }
    std::stable_sort(file.begin(), file.end(), [](const std::string &x, const std::string &y) {
        std::string lx = channel_layer(x), ly = channel_layer(y);
        if (lx != ly) return lx < ly;
        return channel_rank(x) < channel_rank(y);
    });
    return file;
}

/* One malloc'd block: n + 1 pointers (NULL-terminated) then the names, so that a single
 * free() releases it. NULL if allocation fails. */
const char **names_alloc(const std::vector<std::string> &names)
{
    size_t n = names.size(), bytes = (n + 1) * sizeof(char *);
    for (const std::string &s : names)
        bytes += s.size() + 1;
    char **out = static_cast<char **>(malloc(bytes));
    if (!out) return nullptr;
    char *text = reinterpret_cast<char *>(out + n + 1);
    for (size_t k = 0; k < n; k++) {
        memcpy(text, names[k].c_str(), names[k].size() + 1);
        out[k] = text;
        text += names[k].size() + 1;
    }
    out[n] = nullptr;
    return const_cast<const char **>(out);
}

/* Opens path for reading; image.c checked before that it is a readable regular file
 * (read_check), so a FIFO or /dev/zero never reaches the library. */
std::unique_ptr<Imf::InputFile> open_input(const char *path)
{
    return std::unique_ptr<Imf::InputFile>(new Imf::InputFile(path));
}

int read_exr(const char *path, ts_image *out, ts_error *err)
{
    std::unique_ptr<Imf::InputFile> in = open_input(path);
    const Imf::Header &h = in->header();
    const Imath::Box2i dw = h.dataWindow();
    long width = (long)dw.max.x - dw.min.x + 1, height = (long)dw.max.y - dw.min.y + 1;
    std::vector<std::string> names = read_order(h);
    int rc = check_size(path, width, height, (int)names.size(), err);
    if (rc) return rc;
    for (const std::string &n : names) {
        const Imf::Channel &c = h.channels()[n];
        if (c.xSampling != 1 || c.ySampling != 1)
            return image_fail(err, path, "channel \"" + n + "\" is subsampled (not supported)");
    }
    size_t nc = names.size(), pixel_count = (size_t)width * (size_t)height;
    std::unique_ptr<float, decltype(&free)> px(
        static_cast<float *>(malloc(pixel_count * nc * sizeof(float))), &free);
    if (!px) return ts_error_set(err, TS_E_MEMORY, "%s: out of memory for pixels", path);
    /* Slices address pixel (x, y) of the data window at base + x * xs + y * ys. */
    size_t xs = sizeof(float) * nc, ys = xs * (size_t)width;
    char *origin = (char *)px.get() - (ptrdiff_t)dw.min.x * (ptrdiff_t)xs -
                   (ptrdiff_t)dw.min.y * (ptrdiff_t)ys;
    Imf::FrameBuffer fb;
    for (size_t c = 0; c < nc; c++)
        fb.insert(names[c], Imf::Slice(Imf::FLOAT, origin + c * sizeof(float), xs, ys));
    in->setFrameBuffer(fb);
    in->readPixels(dw.min.y, dw.max.y);
    const char **cn = names_alloc(names);
    if (!cn) return ts_error_set(err, TS_E_MEMORY, "%s: out of memory for names", path);
    out->width = (int)width;
    out->height = (int)height;
    const Imath::Box2i disp = h.displayWindow();
    out->x0 = out->y0 = out->full_width = out->full_height = 0;
    if (dw != disp && disp.min.x == 0 && disp.min.y == 0) { /* a part of a frame at (0, 0) */
        out->x0 = dw.min.x, out->y0 = dw.min.y;
        out->full_width = disp.max.x + 1, out->full_height = disp.max.y + 1;
    }
    out->channels = (int)nc;
    out->channel_names = cn;
    out->pixels = px.release();
    return TS_OK;
}

int read_meta_int(const char *path, const char *key, int *value, ts_error *err)
{
    if (!key || !value) return image_fail(err, path, "no metadata key or destination given");
    std::unique_ptr<Imf::InputFile> in = open_input(path);
    const Imf::IntAttribute *a = in->header().findTypedAttribute<Imf::IntAttribute>(key);
    if (!a) return image_fail(err, path, std::string("no integer metadata \"") + key + "\"");
    *value = a->value();
    return TS_OK;
}

int read_meta_string(const char *path, const char *key, char *buf, size_t size, ts_error *err)
{
    if (!key || !buf || size == 0) return image_fail(err, path, "no metadata key or buffer given");
    std::unique_ptr<Imf::InputFile> in = open_input(path);
    const Imf::StringAttribute *a = in->header().findTypedAttribute<Imf::StringAttribute>(key);
    if (!a) return image_fail(err, path, std::string("no string metadata \"") + key + "\"");
    const std::string &v = a->value();
    size_t n = std::min(v.size(), size - 1);
    memcpy(buf, v.data(), n);
    buf[n] = '\0';
    return TS_OK;
}

} // namespace

/* image.h: the header and the temporary from the start, rows as they come, the name at the
 * end. */
struct ts_exr_stream {
    std::string path;
    std::vector<std::string> names;
    std::unique_ptr<Imf::OutputFile> out;
    int width = 0, height = 0, next = 0, x0 = 0, y0 = 0;
    char tmp[8192] = "";
};

extern "C" int image_exr_open_stream(const char *path, const ts_image *shape,
                                     const ts_image_meta *meta, int meta_count,
                                     const ts_image_text *text, int text_count, ts_exr_stream **out,
                                     ts_error *err)
{
    *out = nullptr;
    return guarded(path, err, [&]() -> int {
        std::unique_ptr<ts_exr_stream> s(new ts_exr_stream);
        Imf::Header h;
        int rc = write_begin(path, shape, meta, meta_count, text, text_count, s->names, h, s->tmp,
                             sizeof s->tmp, err);
        if (rc) return rc;
        try {
            s->out.reset(new Imf::OutputFile(s->tmp, h));
        } catch (...) {
            unlink(s->tmp);
            throw;
        }
        s->path = path;
        s->width = shape->width, s->height = shape->height;
        s->x0 = shape->full_width > 0 ? shape->x0 : 0,
        s->y0 = shape->full_width > 0 ? shape->y0 : 0;
        *out = s.release();
        return TS_OK;
    });
}

extern "C" int image_exr_stream_rows(ts_exr_stream *s, const float *rows, int count, ts_error *err)
{
    return guarded(s->path.c_str(), err, [&]() -> int {
        if (count <= 0) return TS_OK;
        if (count > s->height - s->next)
            return image_fail(err, s->path.c_str(), "more rows written than the image has");
        s->out->setFrameBuffer(frame_buffer(s->names, s->width, rows, s->next, s->x0, s->y0));
        s->out->writePixels(count);
        s->next += count;
        return TS_OK;
    });
}

extern "C" int image_exr_stream_next_row(const ts_exr_stream *s)
{
    return s ? s->next : 0;
}

extern "C" int image_exr_stream_close(ts_exr_stream *s, int commit, ts_error *err)
{
    if (!s) return TS_OK;
    int rc = TS_OK;
    if (commit && s->next != s->height)
        rc = image_fail(err, s->path.c_str(), "the image was closed before its last row");
    if (commit && !rc) /* the line offsets go in as the file closes */
        rc = guarded(s->path.c_str(), err, [&]() -> int {
            s->out.reset();
            return TS_OK;
        });
    s->out.reset(); /* not committed: OpenEXR's destructor throws nothing; the file goes */
    if (rc || !commit)
        unlink(s->tmp);
    else
        rc = ts_file_temp_commit(s->tmp, s->path.c_str(), err);
    delete s;
    return rc;
}

extern "C" int image_exr_check_magic(const char *path)
{
    unsigned char magic[4] = {0};
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    size_t n = fread(magic, 1, 4, f);
    fclose(f);
    return n == 4 && magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 && magic[3] == 0x01;
}

extern "C" int image_exr_write(const char *path, const ts_image *img, const ts_image_meta *meta,
                               int meta_count, const ts_image_text *text, int text_count,
                               ts_error *err)
{
    return guarded(path, err,
                   [&] { return write_exr(path, img, meta, meta_count, text, text_count, err); });
}

extern "C" int image_exr_read(const char *path, ts_image *out, ts_error *err)
{
    return guarded(path, err, [&] { return read_exr(path, out, err); });
}

extern "C" int image_exr_read_meta_int(const char *path, const char *key, int *value, ts_error *err)
{
    return guarded(path, err, [&] { return read_meta_int(path, key, value, err); });
}

extern "C" int image_exr_read_meta_string(const char *path, const char *key, char *buf, size_t size,
                                          ts_error *err)
{
    return guarded(path, err, [&] { return read_meta_string(path, key, buf, size, err); });
}
