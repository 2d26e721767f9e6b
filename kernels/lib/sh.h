/* sh.h — real spherical harmonics up to band 3 (16 functions), shared by the bake and
 * relight kernels and the host (the relight tables, tests). The convention is the one
 * `tessera bake` writes into its files (docs/bake.md):
 *   - unit direction (x, y, z) in world space, polar axis +z: z = cos(theta),
 *     x = sin(theta) cos(phi), y = sin(theta) sin(phi);
 *   - orthonormal over the sphere: the integral of Y_lm Y_l'm' over all directions is 1 when
 *     (l, m) = (l', m'), else 0; Y_00 = 1 / (2 sqrt(pi));
 *   - m < 0 takes sin(|m| phi), m > 0 cos(m phi), each times sqrt(2) K_l^|m| P_l^|m|(cos theta),
 *     without the Condon-Shortley phase (-1)^m (Ramamoorthi and Hanrahan 2001, the basis of
 *     PantaRay's pipeline): Y_1-1 = c y, Y_10 = c z, Y_11 = c x with c = sqrt(3 / (4 pi));
 *   - coefficient index l^2 + l + m (0: Y_00; 1..3: Y_1-1, Y_10, Y_11; 4..8 band 2; 9..15
 *     band 3).
 * The polynomials below are those functions on the unit sphere (Sloan 2008, "Stupid
 * spherical harmonics tricks", with the sign of every odd m flipped back). */
#ifndef TS_SH_H
#define TS_SH_H

#include "lib/shared_types.h"

/* Bands the bake supports: B bands hold B^2 coefficients. */
#define TS_SH_MAX_BANDS 4u
#define TS_SH_MAX_COEFFS 16u
/* Index of coefficient (l, m). */
#define TS_SH_INDEX(l, m) ((l) * (l) + (l) + (m))

/* Y_lm(x, y, z) for the first `bands` bands (1..4) into out[0 .. bands^2). (x, y, z) must be a
 * unit vector; out is a private array of at least bands^2 floats. */
TS_INLINE void sh_eval(float x, float y, float z, ts_u32 bands, float *out)
{
    out[0] = 0.282094791773878f; /* 1 / (2 sqrt(pi)) */
    if (bands < 2u) return;
    out[1] = 0.488602511902920f * y; /* sqrt(3 / (4 pi)) */
    out[2] = 0.488602511902920f * z;
    out[3] = 0.488602511902920f * x;
    if (bands < 3u) return;
    out[4] = 1.092548430592079f * x * y; /* sqrt(15 / pi) / 2 */
    out[5] = 1.092548430592079f * y * z;
    out[6] = 0.315391565252520f * (3.0f * z * z - 1.0f); /* sqrt(5 / pi) / 4 */
    out[7] = 1.092548430592079f * x * z;
    out[8] = 0.546274215296040f * (x * x - y * y); /* sqrt(15 / pi) / 4 */
    if (bands < 4u) return;
    out[9] = 0.590043589926644f * y * (3.0f * x * x - y * y); /* sqrt(35 / (2 pi)) / 4 */
    out[10] = 2.890611442640554f * x * y * z;                 /* sqrt(105 / pi) / 2 */
    out[11] = 0.457045799464466f * y * (5.0f * z * z - 1.0f); /* sqrt(21 / (2 pi)) / 4 */
    out[12] = 0.373176332590115f * z * (5.0f * z * z - 3.0f); /* sqrt(7 / pi) / 4 */
    out[13] = 0.457045799464466f * x * (5.0f * z * z - 1.0f);
    out[14] = 1.445305721320277f * z * (x * x - y * y); /* sqrt(105 / pi) / 4 */
    out[15] = 0.590043589926644f * x * (x * x - 3.0f * y * y);
}

/* The zonal coefficients of the clamped cosine max(0, cos(theta)) times sqrt(4 pi / (2l + 1)):
 * the SH projection of max(0, n . w) is sh_cosine_lobe(l) Y_lm(n) (Ramamoorthi and Hanrahan
 * 2001: pi, 2 pi / 3, pi / 4, then 0 for l = 3). */
TS_INLINE float sh_cosine_lobe(ts_u32 l)
{
    return l == 0u   ? 3.14159265358979f
           : l == 1u ? 2.09439510239320f
           : l == 2u ? 0.785398163397448f
                     : 0.0f;
}

#endif
