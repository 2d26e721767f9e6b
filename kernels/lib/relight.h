/* relight.h — relighting with a baked occlusion (`tessera render --occlusion`, docs/bake.md
 * "Relighting"; PantaRay §3: lighting by dot products with precomputed SH visibility).
 * Shared by the shade kernel and the host (host/pipeline/relight.c builds the tables; the
 * plain-C reference host/ref/relight_ref.c recomputes what these give, tests/
 * test_relight_kernels.c compares them).
 *   the points: patch p's (2^m + 1)^2 baked vertices, point (i, j) at (u, v) = (i, j) / 2^m;
 *     patch table entry 2p = the first point of p, 2p + 1 = m; coefficients B^2 floats a
 *     point (lib/sh.h order); normals 3 floats a point (the bake's N);
 *   at a hit (u, v) the B^2 coefficients are interpolated bilinearly between the four
 *     points around it, those whose baked normal faces the shading normal (relight_coeffs);
 *   the irradiance from the domes, E(n) = integral of L(w) V(w) max(0, n . w) dw with V
 *     the band-limited visibility the coefficients describe (relight_irradiance):
 *     - a file baked with --cosine holds T_j = integral of V max(0, N . w) Y_j (Sloan et al.
 *       2002's diffuse transfer about the baked normal N): E = sum_j T_j L_j, L_j the
 *       domes' projection (light entries [0, 16));
 *     - a file without holds V_j = integral of V Y_j: E = sum_j V_j G_j(n) with
 *       G_j(n) = integral of L(w) Y_j(w) max(0, n . w) dw. For a uniform dome of radiance
 *       L, G_j(n) = L A_l Y_j(n) exactly (Funk-Hecke; A_l = pi, 2 pi / 3, pi / 4, 0:
 *       sh_cosine_lobe, Ramamoorthi and Hanrahan 2001); for the mapped dome G is
 *       tabulated over normals by the host and interpolated bilinearly (relight_table).
 * ts_relight_params (shared_types.h) says which, and where the tables are. */
#ifndef TS_RELIGHT_H
#define TS_RELIGHT_H

#include "lib/bsdf.h"
#include "lib/sh.h"
#include "lib/shared_types.h"

/* The band l of coefficient j < 16. */
TS_INLINE ts_u32 relight_band(ts_u32 j)
{
    return j < 1u ? 0u : j < 4u ? 1u : j < 9u ? 2u : 3u;
}

/* The nc coefficients at (u, v) of `patch` for shading normal n into out[0 .. nc): bilinear
 * between the grid points (i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1) around (u, v) 2^m,
 * leaving out the points whose baked normal faces away from n (N . n <= 0: the hemisphere of
 * the surface's other side, a vertex behind a silhouette whose normal the bake turned towards
 * the camera) and renormalising the others' weights; all four when every one faces away. */
TS_INLINE void relight_coeffs(TS_CONST_GLOBAL ts_u32 *patch_tab, TS_CONST_GLOBAL float *coeffs,
                              TS_CONST_GLOBAL float *normal, ts_u32 nc, ts_u32 patch, float u,
                              float v, ts_v3 sn, float *out)
{
    ts_u32 first = patch_tab[2u * patch], m = patch_tab[2u * patch + 1u], n = 1u << m;
    float x = fmin(fmax(u, 0.0f), 1.0f) * (float)n, y = fmin(fmax(v, 0.0f), 1.0f) * (float)n;
    ts_u32 i = (ts_u32)x, j = (ts_u32)y;
    i = i < n ? i : n - 1u;
    j = j < n ? j : n - 1u;
    float fx = x - (float)i, fy = y - (float)j;
    size_t p00 = (size_t)first + (size_t)j * (n + 1u) + i, row = n + 1u;
    size_t pt[4] = {p00, p00 + 1u, p00 + row, p00 + row + 1u};
    float w[4] = {(1.0f - fx) * (1.0f - fy), fx * (1.0f - fy), (1.0f - fx) * fy, fx * fy};
    float kept = 0.0f;
    for (int q = 0; q < 4; ++q) {
        TS_CONST_GLOBAL float *nq = normal + pt[q] * 3u;
        if (nq[0] * sn.x + nq[1] * sn.y + nq[2] * sn.z > 0.0f) kept += w[q];
    }
    for (int q = 0; q < 4; ++q) {
        TS_CONST_GLOBAL float *nq = normal + pt[q] * 3u;
        int faces = nq[0] * sn.x + nq[1] * sn.y + nq[2] * sn.z > 0.0f;
        w[q] = kept > 0.0f ? (faces ? w[q] / kept : 0.0f) : w[q];
    }
    for (ts_u32 k = 0; k < nc; ++k)
        out[k] = w[0] * coeffs[pt[0] * nc + k] + w[1] * coeffs[pt[1] * nc + k] +
                 w[2] * coeffs[pt[2] * nc + k] + w[3] * coeffs[pt[3] * nc + k];
}

/* Adds sum_j c_j G_j(n) of the mapped dome's table to e[0..3): bilinear between the four
 * tabulated normals around n (wrapping in phi, clamped in theta). */
TS_INLINE void relight_table(ts_relight_params rp, TS_CONST_GLOBAL ts_vec4 *light, const float *c,
                             ts_v3 n, float e[3])
{
    ts_u32 w = rp.table_w, h = rp.table_h, nc = rp.bands * rp.bands;
    float z = fmin(fmax(n.z, -1.0f), 1.0f), theta = acos(z), phi = atan2(n.y, n.x);
    if (phi < 0.0f) phi += 2.0f * TS_PI;
    float x = phi / (2.0f * TS_PI) * (float)w - 0.5f;
    float y = fmin(fmax(theta / TS_PI * (float)h - 0.5f, 0.0f), (float)(h - 1u));
    float xf = floor(x), yf = floor(y);
    float fx = x - xf, fy = y - yf;
    ts_u32 x0 = (ts_u32)((ts_i32)xf + (ts_i32)w) % w, x1 = (x0 + 1u) % w;
    ts_u32 y0 = (ts_u32)yf, y1 = y0 + 1u < h ? y0 + 1u : y0;
    TS_CONST_GLOBAL ts_vec4 *t = light + TS_RELIGHT_TABLE_FIRST;
    TS_CONST_GLOBAL ts_vec4 *g00 = t + ((size_t)y0 * w + x0) * nc;
    TS_CONST_GLOBAL ts_vec4 *g10 = t + ((size_t)y0 * w + x1) * nc;
    TS_CONST_GLOBAL ts_vec4 *g01 = t + ((size_t)y1 * w + x0) * nc;
    TS_CONST_GLOBAL ts_vec4 *g11 = t + ((size_t)y1 * w + x1) * nc;
    float w00 = (1.0f - fx) * (1.0f - fy), w10 = fx * (1.0f - fy), w01 = (1.0f - fx) * fy,
          w11 = fx * fy;
    for (ts_u32 j = 0; j < nc; ++j) {
        e[0] += c[j] * (w00 * g00[j].x + w10 * g10[j].x + w01 * g01[j].x + w11 * g11[j].x);
        e[1] += c[j] * (w00 * g00[j].y + w10 * g10[j].y + w01 * g01[j].y + w11 * g11[j].y);
        e[2] += c[j] * (w00 * g00[j].z + w10 * g10[j].z + w01 * g01[j].z + w11 * g11[j].z);
    }
}

/* The domes' irradiance e (rgb) at a point with coefficients c[0 .. B^2) and shading normal
 * n (unit): see the banner. */
TS_INLINE void relight_irradiance(ts_relight_params rp, TS_CONST_GLOBAL ts_vec4 *light,
                                  const float *c, ts_v3 n, float e[3])
{
    ts_u32 nc = rp.bands * rp.bands;
    e[0] = e[1] = e[2] = 0.0f;
    if (rp.cosine) {
        for (ts_u32 j = 0; j < nc; ++j)
            e[0] += c[j] * light[j].x, e[1] += c[j] * light[j].y, e[2] += c[j] * light[j].z;
        return;
    }
    float y[TS_SH_MAX_COEFFS], s = 0.0f;
    sh_eval(n.x, n.y, n.z, rp.bands, y);
    for (ts_u32 j = 0; j < nc; ++j)
        s += sh_cosine_lobe(relight_band(j)) * c[j] * y[j];
    e[0] = rp.uniform[0] * s, e[1] = rp.uniform[1] * s, e[2] = rp.uniform[2] * s;
    if (rp.table_w) relight_table(rp, light, c, n, e);
}

#endif
