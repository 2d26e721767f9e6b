/* relight_ref.c — the relit term's plain-C reference (relight_ref.h). */
#include "ref/relight_ref.h"
#include "lib/sh.h"

#include <math.h>

void relight_ref_coeffs(const ts_occlusion *o, uint32_t p, double u, double v, const double n[3],
                        double *out)
{
    uint32_t nc = o->bands * o->bands, first = o->patch[2 * p], m = o->patch[2 * p + 1];
    uint32_t side = (1u << m) + 1u;
    double x = fmin(fmax(u, 0.0), 1.0) * (side - 1), y = fmin(fmax(v, 0.0), 1.0) * (side - 1);
    double i0 = fmin(floor(x), side - 2.0), j0 = fmin(floor(y), side - 2.0);
    double fx = x - i0, fy = y - j0, w[4], kept = 0.0;
    uint32_t point[4];
    int faces[4];
    for (int q = 0; q < 4; ++q) {
        int di = q & 1, dj = q >> 1;
        point[q] = first + ((uint32_t)j0 + dj) * side + (uint32_t)i0 + di;
        w[q] = (di ? fx : 1.0 - fx) * (dj ? fy : 1.0 - fy);
        const float *nq = &o->normal[(size_t)point[q] * 3];
        faces[q] = nq[0] * n[0] + nq[1] * n[1] + nq[2] * n[2] > 0.0;
        kept += faces[q] ? w[q] : 0.0;
    }
    for (uint32_t k = 0; k < nc; ++k) {
        double s = 0.0;
        for (int q = 0; q < 4; ++q) {
            double wq = kept > 0.0 ? (faces[q] ? w[q] / kept : 0.0) : w[q];
            s += wq * o->coeffs[(size_t)point[q] * nc + k];
        }
        out[k] = s;
    }
}

/* The zonal coefficients of max(0, cos) per band, Ramamoorthi and Hanrahan 2001 eq. 8:
 * A_0 = pi, A_1 = 2 pi / 3, A_2 = pi / 4, A_3 = 0. */
static double cosine_lobe(uint32_t j)
{
    uint32_t l = j < 1 ? 0 : j < 4 ? 1 : j < 9 ? 2 : 3;
    return l == 0 ? M_PI : l == 1 ? 2.0 * M_PI / 3.0 : l == 2 ? M_PI / 4.0 : 0.0;
}

/* Adds sum_j c_j G_j(n) from the table: the entries at the four tabulated normals around n
 * (lat-long, texel centres, wrapping in phi, clamped in theta), weighted bilinearly. */
static void table_term(const ts_relight_params *rp, const ts_vec4 *light, const double *c,
                       const double n[3], double e[3], double *scale)
{
    uint32_t w = rp->table_w, h = rp->table_h, nc = rp->bands * rp->bands;
    double theta = acos(fmin(fmax(n[2], -1.0), 1.0)), phi = atan2(n[1], n[0]);
    if (phi < 0.0) phi += 2.0 * M_PI;
    double x = phi / (2.0 * M_PI) * w - 0.5;
    double y = fmin(fmax(theta / M_PI * h - 0.5, 0.0), h - 1.0);
    double x0 = floor(x), y0 = floor(y);
    for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
            uint32_t col = (uint32_t)(((long)x0 + dx + (long)w) % (long)w);
            uint32_t row = (uint32_t)fmin(y0 + dy, h - 1.0);
            double wgt = (dx ? x - x0 : 1.0 - (x - x0)) * (dy ? y - y0 : 1.0 - (y - y0));
            const ts_vec4 *g = light + TS_RELIGHT_TABLE_FIRST + ((size_t)row * w + col) * nc;
            for (uint32_t j = 0; j < nc; ++j) {
                double t[3] = {g[j].x, g[j].y, g[j].z};
                for (int k = 0; k < 3; ++k) {
                    e[k] += c[j] * wgt * t[k];
                    *scale += fabs(c[j] * wgt * t[k]);
                }
            }
        }
}

void relight_ref_irradiance(const ts_relight_params *rp, const ts_vec4 *light, const double *c,
                            const double n[3], double e[3], double *scale)
{
    uint32_t nc = rp->bands * rp->bands;
    e[0] = e[1] = e[2] = 0.0;
    *scale = 0.0;
    if (rp->cosine) {
        for (uint32_t j = 0; j < nc; ++j) {
            double l[3] = {light[j].x, light[j].y, light[j].z};
            for (int k = 0; k < 3; ++k)
                e[k] += c[j] * l[k], *scale += fabs(c[j] * l[k]);
        }
        return;
    }
    float y[TS_SH_MAX_COEFFS];
    sh_eval((float)n[0], (float)n[1], (float)n[2], rp->bands, y);
    for (uint32_t j = 0; j < nc; ++j)
        for (int k = 0; k < 3; ++k) {
            double t = rp->uniform[k] * cosine_lobe(j) * c[j] * y[j];
            e[k] += t, *scale += fabs(t);
        }
    if (rp->table_w) table_term(rp, light, c, n, e, scale);
}
