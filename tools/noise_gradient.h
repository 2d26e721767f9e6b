/* noise_gradient.h — a proven bound G >= |grad noise3| (kernels/lib/noise.h) for every choice
 * of the lattice gradients, so a Lipschitz bound on the noise is conservative (issue 13
 * item 4, tools/bench_bounds.c). A numerical sup over points and directions is an estimate,
 * not a bound: this one is interval arithmetic over a cover of the cell by sub-cubes, on
 * the noise's own definition (its 12 gradients, its quintic fade). Header-only, double
 * precision. */
#ifndef TS_NOISE_GRADIENT_H
#define TS_NOISE_GRADIENT_H

#include "lib/noise.h"

#include <math.h>

static inline double ngrad_fade(double t)
{
    return t * t * t * (t * (t * 6 - 15) + 10);
}

static inline double ngrad_dfade(double t)
{
    return 30 * t * t * (1 - t) * (1 - t);
}

static inline void ngrad_imul(double a0, double a1, double b0, double b1, double *lo, double *hi)
{
    double p[4] = {a0 * b0, a0 * b1, a1 * b0, a1 * b1};
    *lo = fmin(fmin(p[0], p[1]), fmin(p[2], p[3]));
    *hi = fmax(fmax(p[0], p[1]), fmax(p[2], p[3]));
}

/* Upper bound of |d noise3 / dx_i| over the sub-cube lo..hi of the lattice cell, for every
 * choice of the 12 gradients (lib/noise.h noise_gradient) at its 8 corners. noise3 =
 * sum_c w_c (g_c . (x - c)), w_c the product of fade weights, so d/dx_i = sum_c [dw_c/dx_i
 * (g_c . (x - c)) + w_c g_ci]; each term is bounded by interval arithmetic over the
 * sub-cube (fade rises on [0, 1]; fade' rises to 1/2, then falls), maximised over g. */
static inline double ngrad_cube_bound(const double lo[3], const double hi[3], int axis)
{
    double w[3][2][2], dw[2][2]; /* [axis][corner side][lo, hi] */
    for (int a = 0; a < 3; ++a) {
        double f0 = ngrad_fade(lo[a]), f1 = ngrad_fade(hi[a]);
        w[a][0][0] = 1 - f1, w[a][0][1] = 1 - f0, w[a][1][0] = f0, w[a][1][1] = f1;
    }
    double d0 = ngrad_dfade(lo[axis]), d1 = ngrad_dfade(hi[axis]);
    double dlo = fmin(d0, d1),
           dhi = lo[axis] <= 0.5 && hi[axis] >= 0.5 ? ngrad_dfade(0.5) : fmax(d0, d1);
    dw[1][0] = dlo, dw[1][1] = dhi, dw[0][0] = -dhi, dw[0][1] = -dlo;
    double sum = 0;
    for (int c = 0; c < 8; ++c) {
        int s[3] = {c & 1, (c >> 1) & 1, c >> 2};
        double wl = 1, wh = 1, gl = 1, gh = 1; /* w_c and dw_c/dx_axis */
        for (int a = 0; a < 3; ++a) {
            ngrad_imul(wl, wh, w[a][s[a]][0], w[a][s[a]][1], &wl, &wh);
            if (a == axis)
                ngrad_imul(gl, gh, dw[s[a]][0], dw[s[a]][1], &gl, &gh);
            else
                ngrad_imul(gl, gh, w[a][s[a]][0], w[a][s[a]][1], &gl, &gh);
        }
        double best = 0;
        for (ts_u32 h = 0; h < 12u; ++h) {
            float gf[3];
            noise_gradient(h, &gf[0], &gf[1], &gf[2]);
            double rl = 0, rh = 0; /* g . (x - c) */
            for (int a = 0; a < 3; ++a) {
                double e0 = gf[a] * (lo[a] - s[a]), e1 = gf[a] * (hi[a] - s[a]);
                rl += fmin(e0, e1), rh += fmax(e0, e1);
            }
            double tl, th;
            ngrad_imul(gl, gh, rl, rh, &tl, &th);
            double wl2 = fmin(wl * gf[axis], wh * gf[axis]),
                   wh2 = fmax(wl * gf[axis], wh * gf[axis]);
            best = fmax(best, fmax(fabs(tl + wl2), fabs(th + wh2)));
        }
        sum += best;
    }
    return sum;
}

/* A proven bound G >= |grad noise3| everywhere: per axis the largest ngrad_cube_bound over
 * n^3 sub-cubes covering the cell (every cell is the same up to the gradient
 * choice, which the bound maximises over), then the norm of the three; the 1e-6 covers the
 * double rounding. comp[] receives the three per-axis bounds. */
static inline double noise_gradient_bound(int n, double comp[3])
{
    comp[0] = comp[1] = comp[2] = 0;
    for (int x = 0; x < n; ++x)
        for (int y = 0; y < n; ++y)
            for (int z = 0; z < n; ++z) {
                double lo[3] = {(double)x / n, (double)y / n, (double)z / n};
                double hi[3] = {(double)(x + 1) / n, (double)(y + 1) / n, (double)(z + 1) / n};
                for (int a = 0; a < 3; ++a)
                    comp[a] = fmax(comp[a], ngrad_cube_bound(lo, hi, a));
            }
    return sqrt(comp[0] * comp[0] + comp[1] * comp[1] + comp[2] * comp[2]) * (1 + 1e-6);
}

#endif
