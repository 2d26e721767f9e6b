/* mat4.c — 4x4 matrices of doubles, row-major, acting on column vectors (base/mat4.h). */
#include "base/mat4.h"

#include <float.h>
#include <math.h>
#include <string.h>

void mat4_identity(double m[16])
{
    for (int k = 0; k < 16; k++)
        m[k] = (k % 5 == 0) ? 1.0 : 0.0;
}

/* ctm = ctm · t, so t acts on points first: RI Spec §4.3, "the new transformation is
 * applied to points before the old current transformation". */
void mat4_concat(double ctm[16], const double t[16])
{
    double r[16];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            double s = 0.0;
            for (int k = 0; k < 4; k++)
                s += ctm[i * 4 + k] * t[k * 4 + j];
            r[i * 4 + j] = s;
        }
    memcpy(ctm, r, sizeof r);
}

/* Rotate deg (degrees) about (x, y, z), RI Spec §4.3 RiRotate. RenderMan spaces are
 * left-handed, so a positive angle turns clockwise seen from the positive end of the axis
 * looking at the origin (the left-hand rule). Written in coordinates that is the ordinary
 * axis-angle (Rodrigues) matrix, the same numbers as pbrt's Rotate: only the picture of
 * "clockwise" depends on handedness, not the matrix. Rotate 90 0 0 1 takes +x to +y,
 * Rotate 90 1 0 0 takes +y to +z, Rotate 90 0 1 0 takes +z to +x. Returns 0 for a
 * zero-length axis. */
int mat4_rotate(double deg, double x, double y, double z, double m[16])
{
    double len = sqrt(x * x + y * y + z * z);
    if (!(len > 0.0) || !isfinite(len)) return 0;
    x /= len, y /= len, z /= len;
    double rad = deg * (3.14159265358979323846 / 180.0);
    double c = cos(rad), s = sin(rad), t = 1.0 - c;
    /* clang-format off */
    const double r[16] = {x * x * t + c,     x * y * t - z * s, x * z * t + y * s, 0,
                          x * y * t + z * s, y * y * t + c,     y * z * t - x * s, 0,
                          x * z * t - y * s, y * z * t + x * s, z * z * t + c,     0,
                          0,                 0,                 0,                 1};
    /* clang-format on */
    memcpy(m, r, sizeof r);
    return 1;
}

int mat4_skew(double deg, const double d1[3], const double d2[3], double m[16])
{
    double l1 = sqrt(d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]);
    double l2 = sqrt(d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2]);
    if (!(l1 > 0.0) || !(l2 > 0.0) || !isfinite(l1) || !isfinite(l2) || !isfinite(deg)) return 0;
    double a[3], b[3], n[3];
    for (int k = 0; k < 3; k++)
        a[k] = d1[k] / l1, b[k] = d2[k] / l2;
    double c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; /* cos phi */
    for (int k = 0; k < 3; k++)
        n[k] = a[k] - c * b[k];
    double s = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]); /* sin phi */
    if (!(s > 1e-12)) return 0;                               /* parallel axes */
    for (int k = 0; k < 3; k++)
        n[k] /= s;
    double phi = atan2(s, c), psi = phi - deg * (3.14159265358979323846 / 180.0);
    if (!(psi > 0.0 && psi < 3.14159265358979323846)) return 0;
    double k = cos(psi) / sin(psi) - c / s; /* cot(phi - angle) - cot(phi) */
    mat4_identity(m);
    for (int r = 0; r < 3; r++)
        for (int q = 0; q < 3; q++)
            m[r * 4 + q] += k * b[r] * n[q];
    return 1;
}

/* Gauss-Jordan with partial pivoting. Returns 0 when m is singular or not finite. */
int mat4_invert(const double m[16], double inv[16])
{
    double a[4][8];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 8; j++)
            a[i][j] = j < 4 ? m[i * 4 + j] : (j - 4 == i);
    for (int c = 0; c < 4; c++) {
        int piv = c;
        for (int r = c + 1; r < 4; r++)
            if (fabs(a[r][c]) > fabs(a[piv][c])) piv = r;
        if (!(fabs(a[piv][c]) > 1e-300) || !isfinite(a[piv][c])) return 0;
        for (int j = 0; j < 8; j++) {
            double tmp = a[c][j];
            a[c][j] = a[piv][j];
            a[piv][j] = tmp;
        }
        double d = a[c][c];
        for (int j = 0; j < 8; j++)
            a[c][j] /= d;
        for (int r = 0; r < 4; r++) {
            if (r == c) continue;
            double f = a[r][c];
            for (int j = 0; j < 8; j++)
                a[r][j] -= f * a[c][j];
        }
    }
    for (int i = 0; i < 16; i++)
        inv[i] = a[i / 4][4 + i % 4];
    for (int i = 0; i < 16; i++)
        if (!isfinite(inv[i])) return 0;
    return 1;
}

/* Affine up to the scale of w: bottom row (0 0 0 w), w != 0. Patches stay polynomial only
 * under affine maps. */
int mat4_is_affine(const double m[16])
{
    return m[12] == 0.0 && m[13] == 0.0 && m[14] == 0.0 && m[15] != 0.0 && isfinite(m[15]);
}

/* Maps a point by an affine m. Returns 0 when the result is not a finite float. */
int mat4_point(const double m[16], const double p[3], double out[3])
{
    for (int i = 0; i < 3; i++) {
        double v =
            (m[i * 4] * p[0] + m[i * 4 + 1] * p[1] + m[i * 4 + 2] * p[2] + m[i * 4 + 3]) / m[15];
        if (!(fabs(v) <= FLT_MAX)) return 0;
        out[i] = v;
    }
    return 1;
}

/* n' = (L^-1)^T n with L^-1 the linear part of inv / inv[15]: column i of inv is row i of
 * its transpose. */
void mat4_normal(const double inv[16], const double n[3], double out[3])
{
    for (int i = 0; i < 3; i++)
        out[i] = (inv[i] * n[0] + inv[4 + i] * n[1] + inv[8 + i] * n[2]) / inv[15];
}

void mat4_dir(const double m[16], const double d[3], double out[3])
{
    for (int i = 0; i < 3; i++)
        out[i] = m[i * 4] * d[0] + m[i * 4 + 1] * d[1] + m[i * 4 + 2] * d[2];
}
