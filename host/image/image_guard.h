/* image_guard.h — C++ only (image_exr.cpp, image_oiio.cpp): the C boundary of the image code
 * (STYLE.md 11). Every entry point runs its body through image_guarded, so no exception
 * reaches the C host; failures become TS_E_IO "PATH: reason" on one line. */
#ifndef TS_IMAGE_GUARD_H
#define TS_IMAGE_GUARD_H

#include <new>
#include <stdexcept>
#include <string>

extern "C" {
#include "base/error.h"
}

/* TS_E_IO "PATH: why", why made one line (library messages may span several). */
inline int image_fail(ts_error *err, const char *path, std::string why)
{
    for (char &c : why)
        if (c == '\n' || c == '\r') c = ' ';
    while (!why.empty() && why.back() == ' ')
        why.pop_back();
    return ts_error_set(err, TS_E_IO, "%s: %s", path, why.c_str());
}

/* Runs body, turning any exception into a ts_error that names the library (`library`). */
template <class F> int image_guarded(const char *library, const char *path, ts_error *err, F body)
{
    if (!path) return ts_error_set(err, TS_E_IO, "(null path): no file name given");
    try {
        return body();
    } catch (const std::bad_alloc &) {
        return ts_error_set(err, TS_E_MEMORY, "%s: out of memory", path);
    } catch (const std::exception &e) {
        return image_fail(err, path, std::string(library) + ": " + e.what());
    } catch (...) {
        return image_fail(err, path, std::string("unknown exception in ") + library);
    }
}

#endif
