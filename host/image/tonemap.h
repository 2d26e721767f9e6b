/* tonemap.h — linear scene radiance to 8-bit sRGB display values, the one definition
 * shared by the PNG writer and the tests (plain C, no OIIO). */
#ifndef TS_TONEMAP_H
#define TS_TONEMAP_H

#include <stddef.h>
#include <stdint.h>

/* Clamps linear to [0, 1] (NaN -> 0), applies the sRGB OETF (IEC 61966-2-1: 12.92 x below
 * x = 0.0031308, else 1.055 x^(1/2.4) - 0.055) and rounds to the nearest of 0..255. */
uint8_t tonemap_srgb8(float linear);

/* tonemap_srgb8 on count values (count = pixels * channels); in and out must not overlap. */
void tonemap_srgb8_buffer(const float *linear, uint8_t *out, size_t count);

#endif
