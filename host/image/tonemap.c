#include "image/tonemap.h"

#include <math.h>

uint8_t tonemap_srgb8(float linear)
{
    /* Written so that NaN fails the comparison and lands on 0. */
    float x = linear > 0.0f ? linear : 0.0f;
    if (x > 1.0f) x = 1.0f;
    float e = x <= 0.0031308f ? 12.92f * x : 1.055f * powf(x, 1.0f / 2.4f) - 0.055f;
    /* e is in [0, 1]; +0.5 then truncation rounds half up; the clamp guards powf ulps. */
    float v = e * 255.0f + 0.5f;
    return (uint8_t)(v < 255.0f ? v : 255.0f);
}

void tonemap_srgb8_buffer(const float *linear, uint8_t *out, size_t count)
{
    for (size_t i = 0; i < count; i++)
        out[i] = tonemap_srgb8(linear[i]);
}
