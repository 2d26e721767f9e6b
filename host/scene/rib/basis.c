/* basis.c — the standard RenderMan bases (RI Spec 3.2, RiBasis and ri.h's Ri*Basis
 * constants) and the change of basis to Bézier used when patches are loaded. */
#include "scene/rib/basis.h"

#include <string.h>

/* clang-format off */
const ts_basis basis_bezier = {{
    -1,  3, -3, 1,
     3, -6,  3, 0,
    -3,  3,  0, 0,
     1,  0,  0, 0}, 3};

const ts_basis basis_bspline = {{
    -1.0 / 6,  3.0 / 6, -3.0 / 6, 1.0 / 6,
     3.0 / 6, -6.0 / 6,  3.0 / 6, 0,
    -3.0 / 6,  0,        3.0 / 6, 0,
     1.0 / 6,  4.0 / 6,  1.0 / 6, 0}, 1};

const ts_basis basis_catmull_rom = {{
    -0.5,  1.5, -1.5,  0.5,
     1.0, -2.5,  2.0, -0.5,
    -0.5,  0,    0.5,  0,
     0,    1,    0,    0}, 1};

/* Control points ordered P0, R0 (tangent at P0), P1, R1. */
const ts_basis basis_hermite = {{
     2,  1, -2,  1,
    -3, -2,  3, -1,
     0,  1,  0,  0,
     1,  0,  0,  0}, 2};

/* P(t) = G0 t^3 + G1 t^2 + G2 t + G3. */
const ts_basis basis_power = {{
    1, 0, 0, 0,
    0, 1, 0, 0,
    0, 0, 1, 0,
    0, 0, 0, 1}, 4};

/* Inverse of the Bézier matrix: row i gives Bézier point i as a combination of the power
 * coefficients (t^3, t^2, t, 1). Exact up to the rounding of 1/3 and 2/3. */
static const double bezier_inverse[16] = {
    0, 0,       0,       1,
    0, 0,       1.0 / 3, 1,
    0, 1.0 / 3, 2.0 / 3, 1,
    1, 1,       1,       1};
/* clang-format on */

const ts_basis *basis_by_name(const char *name)
{
    static const struct {
        const char *name;
        const ts_basis *basis;
    } table[] = {
        {"bezier", &basis_bezier},   {"b-spline", &basis_bspline},
        {"bspline", &basis_bspline}, {"catmull-rom", &basis_catmull_rom},
        {"hermite", &basis_hermite}, {"power", &basis_power},
    };
    if (!name) return NULL;
    for (size_t i = 0; i < sizeof table / sizeof table[0]; i++)
        if (strcmp(name, table[i].name) == 0) return table[i].basis;
    return NULL;
}

ts_basis basis_from_matrix(const double m[16], int step)
{
    ts_basis b;
    memcpy(b.m, m, sizeof b.m);
    b.step = step;
    return b;
}

int basis_is_bezier(const ts_basis *b)
{
    for (int k = 0; k < 16; k++)
        if (b->m[k] != basis_bezier.m[k]) return 0;
    return 1;
}

void basis_weights(const double m[16], double t, double w[4])
{
    const double powers[4] = {t * t * t, t * t, t, 1.0};
    for (int i = 0; i < 4; i++) {
        double s = 0.0;
        for (int r = 0; r < 4; r++)
            s += powers[r] * m[r * 4 + i];
        w[i] = s;
    }
}

/* c = Mb^-1 · m: row i holds the weights of the 4 input points in Bézier point i. */
static void basis_change_to_bezier(const ts_basis *b, double c[16])
{
    if (basis_is_bezier(b)) {
        for (int k = 0; k < 16; k++)
            c[k] = (k % 5 == 0) ? 1.0 : 0.0;
        return;
    }
    for (int i = 0; i < 4; i++)
        for (int k = 0; k < 4; k++) {
            double s = 0.0;
            for (int r = 0; r < 4; r++)
                s += bezier_inverse[i * 4 + r] * b->m[r * 4 + k];
            c[i * 4 + k] = s;
        }
}

void basis_grid_to_bezier(const ts_basis *u, const ts_basis *v, const double in[16][3],
                          double out[16][3])
{
    double cu[16], cv[16], rows[16][3];
    basis_change_to_bezier(u, cu);
    basis_change_to_bezier(v, cv);
    /* Along u, within each row j: rows(i, j) = sum_k cu[i][k] in(k, j). */
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++)
            for (int d = 0; d < 3; d++) {
                double s = 0.0;
                for (int k = 0; k < 4; k++)
                    s += cu[i * 4 + k] * in[j * 4 + k][d];
                rows[j * 4 + i][d] = s;
            }
    /* Along v, within each column i: out(i, j) = sum_l cv[j][l] rows(i, l). */
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++)
            for (int d = 0; d < 3; d++) {
                double s = 0.0;
                for (int l = 0; l < 4; l++)
                    s += cv[j * 4 + l] * rows[l * 4 + i][d];
                out[j * 4 + i][d] = s;
            }
}
