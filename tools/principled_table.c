/* principled_table.c — writes kernels/lib/principled_table.h: the directional albedo of the GGX
 * lobe (separable Smith G) on a 33 x 33 grid of sqrt(cos(theta_o)) and roughness (0.1 to 1:
 * GGX alpha 0.01 to 1, Tessera's range), with Fresnel 1 (E1) and with Schlick's (1 - wo.h)^5 (E2),
 * so that a lobe of Schlick Fresnel F0 has albedo F0 E1 + (1 - F0) E2 (Karis 2013's split). Also
 * each row's cosine-weighted mean over the hemisphere of the interpolant (linear in sqrt(cos)), 2
 * int E(mu) mu dmu, exact for that interpolant. lib/principled.h reads them (docs/rendering.md
 * "Principled"). Run: cc -O2 tools/principled_table.c -lm -o principled_table &&
 *      ./principled_table > kernels/lib/principled_table.h && tools/check_format.sh --fix */
#include <math.h>
#include <stdio.h>

#define N 32 /* intervals of each axis */

static double ggx_d(double c, double a)
{
    if (c <= 0.0) return 0.0;
    double a2 = a * a, d = c * c * (a2 - 1.0) + 1.0;
    return a2 / (M_PI * d * d);
}

static double ggx_g1(double c, double a)
{
    if (c <= 0.0) return 0.0;
    double t2 = (1.0 - c * c) / (c * c);
    return 2.0 / (1.0 + sqrt(1.0 + a * a * t2));
}

/* E1 and E2 at cos(theta_o) = co for GGX alpha a > 0 by quadrature over the half vector
 * (tan theta_h = a t / (1 - t), as tests/support's test_ggx_albedo). */
static void albedo(double co, double a, double *e1, double *e2)
{
    enum { NT = 2048, NP = 256 };
    const double so = sqrt(1.0 - co * co);
    double s1 = 0.0, s2 = 0.0;
    if (co <= 0.0) {
        *e1 = *e2 = 0.0;
        return;
    }
    for (int i = 0; i < NT; i++) {
        double t = (i + 0.5) / NT, x = a * t / (1.0 - t);
        double th = atan(x), dth = a / ((1.0 - t) * (1.0 - t)) / (1.0 + x * x);
        double ch = cos(th), sh = sin(th), d = ggx_d(ch, a);
        for (int j = 0; j < NP; j++) {
            double ph = (j + 0.5) * M_PI / NP;
            double oh = so * sh * cos(ph) + co * ch, ci = 2.0 * oh * ch - co;
            if (oh <= 0.0 || ci <= 0.0) continue;
            double w = d * ggx_g1(co, a) * ggx_g1(ci, a) * oh / co * sh * dth;
            double f = pow(1.0 - oh, 5.0);
            s1 += w, s2 += w * f;
        }
    }
    *e1 = s1 * (1.0 / NT) * (2.0 * M_PI / NP);
    *e2 = s2 * (1.0 / NT) * (2.0 * M_PI / NP);
}

int main(void)
{
    static double e[2][N + 1][N + 1];
    for (int j = 0; j <= N; j++) {
        double r = 0.1 + 0.9 * j / N, a = r * r;
        for (int i = 0; i <= N; i++) {
            double mu = (double)i * i / ((double)N * N);
            if (i == 0) {
                /* Grazing: E is 0 at mu = 0 but near E(1 / N) just above it; the column holds
                 * the largest value over [0, 1 / N] so the interpolant stays above E there. */
                e[0][j][0] = e[1][j][0] = 0.0;
                for (int k = 1; k <= 16; k++) {
                    double e1, e2;
                    albedo(k / (16.0 * N * N), a, &e1, &e2);
                    e[0][j][0] = fmax(e[0][j][0], e1), e[1][j][0] = fmax(e[1][j][0], e2);
                }
            } else {
                albedo(mu, a, &e[0][j][i], &e[1][j][i]);
            }
        }
    }
    /* How far the interpolant raised by TS_PRINCIPLED_MARGIN (lib/principled.h: E + m (1 - E))
     * falls below the albedo at the cells' centres, at worst: to stderr. */
    double worst = 0.0;
    for (int j = 0; j < N; j++)
        for (int i = 0; i < N; i++) {
            double r = 0.1 + 0.9 * (j + 0.5) / N, mu = (i + 0.5) * (i + 0.5) / ((double)N * N),
                   t[2];
            albedo(mu, r * r, &t[0], &t[1]);
            for (int k = 0; k < 2; k++) {
                double in =
                    0.25 * (e[k][j][i] + e[k][j][i + 1] + e[k][j + 1][i] + e[k][j + 1][i + 1]);
                worst = fmax(worst, t[k] - (in + 0.02 * (1.0 - in)));
            }
        }
    fprintf(stderr, "the albedo above the raised interpolant by at most %g\n", worst);
    printf("/* principled_table.h — written by tools/principled_table.c; do not edit. The GGX "
           "lobe's\n * directional albedo TS_PRINCIPLED_E[k][j][i]: k = 0 with Fresnel 1, k = 1 "
           "with Schlick's\n * (1 - wo.h)^5; roughness 0.1 + 0.9 j / %d (GGX alpha its square, "
           "0.01 to 1), cos(theta_o) =\n * (i / %d)^2 (column 0: the largest value over [0, "
           "1 / %d^2]). TS_PRINCIPLED_EAVG[k][j]:\n * 2 int E(mu) mu dmu of row j interpolated "
           "linearly in sqrt(mu), exactly. */\n",
           N, N, N);
    printf("#ifndef TS_PRINCIPLED_TABLE_H\n#define TS_PRINCIPLED_TABLE_H\n\n");
    printf("#define TS_PRINCIPLED_N %d\n\n", N);
    printf("TS_CONSTANT_TABLE float TS_PRINCIPLED_E[2][%d][%d] = {\n", N + 1, N + 1);
    for (int k = 0; k < 2; k++) {
        printf("    {\n");
        for (int j = 0; j <= N; j++) {
            printf("        {");
            for (int i = 0; i <= N; i++)
                printf("%.7ef%s%s", e[k][j][i], i < N ? "," : "",
                       i % 4 == 3 && i < N ? "\n         "
                       : i < N             ? " "
                                           : "");
            printf("},\n");
        }
        printf("    },\n");
    }
    printf("};\n\nTS_CONSTANT_TABLE float TS_PRINCIPLED_EAVG[2][%d] = {\n", N + 1);
    for (int k = 0; k < 2; k++) {
        printf("    {");
        for (int j = 0; j <= N; j++) {
            double s = 0.0;
            for (int i = 0; i < N; i++) { /* 4 int E s^3 ds of the linear piece, exactly */
                double a = (double)i / N, b = (double)(i + 1) / N, ya = e[k][j][i],
                       yb = e[k][j][i + 1];
                double s4 = (pow(b, 4) - pow(a, 4)) / 4.0;
                double s5 = (pow(b, 5) - pow(a, 5)) / 5.0 - a * s4;
                s += ya * s4 + (yb - ya) / (b - a) * s5;
            }
            printf("%.7ef%s%s", 4.0 * s, j < N ? "," : "",
                   j % 4 == 3 && j < N ? "\n     "
                   : j < N             ? " "
                                       : "");
        }
        printf("},\n");
    }
    printf("};\n\n#endif\n");
    return 0;
}
