/* tools/noise_bound.c — computes the bound NOISE_BOUND of kernels/lib/noise.h: the maximum
 * over a lattice cell of B(x) = sum over the 8 corners c of fade-weight w_c(x) times the
 * largest |g . (x - c)| over the 12 gradients g (the sum of the two largest components of
 * |x - c|), sampled on an N^3 grid. Build: cc -O2 tools/noise_bound.c -lm; run: ./a.out [N]. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

static double fade(double t)
{
    return t * t * t * (t * (t * 6 - 15) + 10);
}

int main(int argc, char **argv)
{
    int n = argc > 1 ? atoi(argv[1]) : 200;
    double best = 0;
    for (int a = 0; a <= n; a++)
        for (int b = 0; b <= n; b++)
            for (int c = 0; c <= n; c++) {
                double x = (double)a / n, y = (double)b / n, z = (double)c / n, s = 0;
                for (int k = 0; k < 8; k++) {
                    int dx = k & 1, dy = (k >> 1) & 1, dz = k >> 2;
                    double ox = fabs(x - dx), oy = fabs(y - dy), oz = fabs(z - dz);
                    double w = (dx ? fade(x) : 1 - fade(x)) * (dy ? fade(y) : 1 - fade(y)) *
                               (dz ? fade(z) : 1 - fade(z));
                    s += w * fmax(ox + oy, fmax(ox + oz, oy + oz));
                }
                if (s > best) best = s;
            }
    printf("max B over a %d^3 grid: %.6f (grid spacing %.4f)\n", n, best, 1.0 / n);
    return 0;
}
