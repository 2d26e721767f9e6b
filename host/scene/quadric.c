/* quadric.c — the RenderMan quadrics as bicubic Bézier patches (see quadric.h for the
 * construction and its tolerances).
 *
 * A patch is the tensor product of a sweep arc (C_i, S_i), i = 0..3, the Bézier points of a
 * cubic approximating (cos theta, sin theta), and a profile piece Q_j, j = 0..3, a cubic in
 * (x, y, z): point (i, j) is R(C_i, S_i) Q_j = (X C - Y S, X S + Y C, Z). Because the map
 * (C, S) -> rotation-and-scale is linear, the patch is exactly bicubic, and a point of it
 * lies at the angle and (1 + e) times the radius of a point of the true sweep, e the arc's
 * radial error. */
#include "scene/quadric.h"

#include "base/error.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define QUADRIC_PI 3.14159265358979323846
#define QUADRIC_MAX_PIECES 4 /* 360 degrees in pieces of at most 90 */

static const struct {
    const char *name;
    int nargs;
} quadric_info[QUADRIC_KINDS] = {
    {"Sphere", 4},     {"Cone", 3}, {"Cylinder", 4}, {"Hyperboloid", 7},
    {"Paraboloid", 4}, {"Disk", 3}, {"Torus", 5},
};

const char *quadric_name(ts_quadric_kind kind)
{
    return kind < QUADRIC_KINDS ? quadric_info[kind].name : "quadric";
}

int quadric_arg_count(ts_quadric_kind kind)
{
    return kind < QUADRIC_KINDS ? quadric_info[kind].nargs : 0;
}

/* cos and sin of an angle in degrees, exact at multiples of 90 degrees, so that 0 and 360
 * give the same point (a closed sweep's seam) and the poles have x = y = 0 exactly. */
static void quadric_cos_sin(double deg, double *c, double *s)
{
    double r = fmod(deg, 360.0);
    if (r < 0.0) r += 360.0;
    if (r == 0.0) {
        *c = 1.0, *s = 0.0;
    } else if (r == 90.0) {
        *c = 0.0, *s = 1.0;
    } else if (r == 180.0) {
        *c = -1.0, *s = 0.0;
    } else if (r == 270.0) {
        *c = 0.0, *s = -1.0;
    } else {
        *c = cos(r * QUADRIC_PI / 180.0);
        *s = sin(r * QUADRIC_PI / 180.0);
    }
}

/* The Bézier points of the cubic arc of the unit circle from angle a to angle b (degrees,
 * |b - a| <= 90): the ends on the circle, the inner points along the end tangents at
 * k = 4/3 tan((b - a) / 4). */
static void quadric_arc(double a, double b, double out[4][2])
{
    double ca, sa, cb, sb;
    quadric_cos_sin(a, &ca, &sa);
    quadric_cos_sin(b, &cb, &sb);
    double k = 4.0 / 3.0 * tan((b - a) * QUADRIC_PI / 720.0);
    out[0][0] = ca, out[0][1] = sa;
    out[1][0] = ca - k * sa, out[1][1] = sa + k * ca;
    out[2][0] = cb + k * sb, out[2][1] = sb - k * cb;
    out[3][0] = cb, out[3][1] = sb;
}

/* The number of pieces of at most 90 degrees for a sweep of `deg` degrees (at most 360):
 * as few as it needs, or always QUADRIC_MAX_PIECES (ts_quadric.fixed_pieces). */
static int quadric_pieces(double deg, int fixed)
{
    if (fixed) return QUADRIC_MAX_PIECES;
    double n = ceil(fabs(deg) / 90.0 - 1e-12);
    return !(n >= 1.0) ? 1 : n > QUADRIC_MAX_PIECES ? QUADRIC_MAX_PIECES : (int)n;
}

static double quadric_clamp_sweep(double deg)
{
    return deg > 360.0 ? 360.0 : deg < -360.0 ? -360.0 : deg;
}

/* ---- the profile Q(v) --------------------------------------------------------------- */

/* A quadric's profile: `pieces` cubic segments (Bézier points, in x y z) covering v in
 * [j / pieces, (j + 1) / pieces], and what the exact profile needs. */
typedef struct quadric_profile {
    int pieces;
    double q[QUADRIC_MAX_PIECES][4][3];
    double a[7]; /* the quadric's arguments with angles and z ranges resolved */
    ts_quadric_kind kind;
} quadric_profile;

/* The angle of z on a sphere of radius r, degrees: +-90 exactly at the poles. */
static double quadric_sphere_phi(double z, double r)
{
    double t = z / r;
    return t <= -1.0 ? -90.0 : t >= 1.0 ? 90.0 : asin(t) * 180.0 / QUADRIC_PI;
}

/* The exact profile point Q(v) and its derivative dQ/dv. */
static void quadric_profile_eval(const quadric_profile *pr, double v, double Q[3], double dQ[3])
{
    const double *a = pr->a;
    double c, s, rad;
    Q[1] = dQ[1] = 0.0;
    switch (pr->kind) {
    case QUADRIC_SPHERE: /* a: r, phimin, phimax (degrees) */
    case QUADRIC_TORUS:  /* a: R, r, phimin, phimax */
    {
        int torus = pr->kind == QUADRIC_TORUS;
        double r = torus ? a[1] : a[0], lo = a[torus + 1], hi = a[torus + 2];
        quadric_cos_sin(lo + v * (hi - lo), &c, &s);
        rad = (hi - lo) * QUADRIC_PI / 180.0;
        Q[0] = (torus ? a[0] : 0.0) + r * c, Q[2] = r * s;
        dQ[0] = -r * s * rad, dQ[2] = r * c * rad;
        break;
    }
    case QUADRIC_CYLINDER: /* r zmin zmax */
        Q[0] = a[0], Q[2] = a[1] + v * (a[2] - a[1]);
        dQ[0] = 0.0, dQ[2] = a[2] - a[1];
        break;
    case QUADRIC_CONE: /* h r */
        Q[0] = a[1] * (1.0 - v), Q[2] = v * a[0];
        dQ[0] = -a[1], dQ[2] = a[0];
        break;
    case QUADRIC_DISK: /* h r */
        Q[0] = a[1] * (1.0 - v), Q[2] = a[0];
        dQ[0] = -a[1], dQ[2] = 0.0;
        break;
    case QUADRIC_PARABOLOID: /* rmax zmin zmax: rho = rmax sqrt(z / zmax) */
    {
        double z = a[1] + v * (a[2] - a[1]), t = fmax(z / a[2], 0.0);
        Q[0] = a[0] * sqrt(t), Q[2] = z;
        dQ[0] = t > 0.0 ? a[0] * (a[2] - a[1]) / (2.0 * a[2] * sqrt(t)) : INFINITY;
        dQ[2] = a[2] - a[1];
        break;
    }
    default: /* QUADRIC_HYPERBOLOID: the line p1 -> p2 */
        for (int d = 0; d < 3; d++) {
            Q[d] = a[d] + v * (a[3 + d] - a[d]);
            dQ[d] = a[3 + d] - a[d];
        }
        break;
    }
}

/* One profile piece that is a line: Q(0) to Q(1) degree-elevated (exact). */
static void quadric_line_piece(const quadric_profile *pr, double q[4][3])
{
    double q0[3], q1[3], d[3];
    quadric_profile_eval(pr, 0.0, q0, d);
    quadric_profile_eval(pr, 1.0, q1, d);
    for (int j = 0; j < 4; j++)
        for (int k = 0; k < 3; k++)
            q[j][k] = ((3 - j) * q0[k] + j * q1[k]) / 3.0;
}

/* Circle profiles (sphere, torus): pieces of at most 90 degrees of the circle of radius r
 * around (cx, 0) in the xz plane, phi from lo to hi. Shared piece ends come from one array. */
static void quadric_circle_pieces(quadric_profile *pr, double cx, double r, double lo, double hi,
                                  int fixed)
{
    int n = quadric_pieces(hi - lo, fixed);
    double ends[QUADRIC_MAX_PIECES + 1];
    for (int j = 0; j <= n; j++)
        ends[j] = j == n ? hi : lo + j * (hi - lo) / n;
    pr->pieces = n;
    for (int j = 0; j < n; j++) {
        double arc[4][2];
        quadric_arc(ends[j], ends[j + 1], arc);
        for (int k = 0; k < 4; k++) {
            pr->q[j][k][0] = cx + r * arc[k][0];
            pr->q[j][k][1] = 0.0;
            pr->q[j][k][2] = r * arc[k][1];
        }
    }
}

/* The paraboloid's profile z = zmax (rho / rmax)^2 between rho0 and rho1: the quadratic
 * Bézier with its middle point where the end tangents meet, degree-elevated (exact). */
static void quadric_parabola_piece(quadric_profile *pr)
{
    const double rmax = pr->a[0], zmin = pr->a[1], zmax = pr->a[2];
    double k = zmax / (rmax * rmax);
    double r0 = rmax * sqrt(fmax(zmin / zmax, 0.0)), r1 = rmax;
    double m[2] = {0.5 * (r0 + r1), k * r0 * r1};
    double e0[2] = {r0, zmin}, e1[2] = {r1, zmax};
    pr->pieces = 1;
    for (int d = 0; d < 2; d++) {
        int o = d ? 2 : 0;
        pr->q[0][0][o] = e0[d];
        pr->q[0][1][o] = (e0[d] + 2.0 * m[d]) / 3.0;
        pr->q[0][2][o] = (2.0 * m[d] + e1[d]) / 3.0;
        pr->q[0][3][o] = e1[d];
    }
    for (int j = 0; j < 4; j++)
        pr->q[0][j][1] = 0.0;
}

/* Resolves the arguments (sphere z range into angles, sweeps clamped) and builds the
 * profile pieces. Fails for a paraboloid with zmin / zmax < 0. */
static int quadric_profile_make(const ts_quadric *q, quadric_profile *pr, char *why, size_t n)
{
    memset(pr, 0, sizeof *pr);
    pr->kind = q->kind;
    memcpy(pr->a, q->arg, sizeof pr->a);
    double *a = pr->a;
    switch (q->kind) {
    case QUADRIC_SPHERE: {
        double r = a[0];
        if (r == 0.0) break; /* no surface: pieces stays 0 */
        double lo = quadric_sphere_phi(a[1], r), hi = quadric_sphere_phi(a[2], r);
        a[1] = lo, a[2] = hi;
        quadric_circle_pieces(pr, 0.0, r, lo, hi, q->fixed_pieces);
        break;
    }
    case QUADRIC_TORUS:
        a[3] = a[2] + quadric_clamp_sweep(a[3] - a[2]);
        quadric_circle_pieces(pr, a[0], a[1], a[2], a[3], q->fixed_pieces);
        break;
    case QUADRIC_PARABOLOID:
        if (a[2] != 0.0 && a[1] / a[2] < 0.0) {
            snprintf(why, n,
                     "zmin %g and zmax %g lie on opposite sides of 0 (the paraboloid "
                     "z = zmax (r / rmax)^2 has no points there)",
                     a[1], a[2]);
            return TS_E_SCENE;
        }
        if (a[2] != 0.0 && a[0] != 0.0) quadric_parabola_piece(pr);
        break;
    default:
        pr->pieces = 1;
        quadric_line_piece(pr, pr->q[0]);
        break;
    }
    return TS_OK;
}

/* ---- normals and patches ------------------------------------------------------------- */

/* dP/du x dP/dv at (theta, v), up to the positive factor 1 / (pi / 180): with
 * P = R(theta) Q(v), dP/dtheta = R(theta) (-Qy, Qx, 0) sweep and dP/dv = R(theta) Q'(v). */
static void quadric_cross(const quadric_profile *pr, double sweep, double theta, double v,
                          double n[3])
{
    double Q[3], dQ[3], c, s;
    quadric_profile_eval(pr, v, Q, dQ);
    double du[3] = {-Q[1] * sweep, Q[0] * sweep, 0.0};
    double m[3] = {du[1] * dQ[2] - du[2] * dQ[1], du[2] * dQ[0] - du[0] * dQ[2],
                   du[0] * dQ[1] - du[1] * dQ[0]};
    if (!isfinite(m[0]) || !isfinite(m[1]) || !isfinite(m[2])) m[0] = m[1] = m[2] = 0.0;
    quadric_cos_sin(theta, &c, &s);
    n[0] = c * m[0] - s * m[1], n[1] = s * m[0] + c * m[1], n[2] = m[2];
}

/* The unit normal at corner (theta, v) of the surface. On the z axis, where dP/du = 0, it is
 * the axis direction towards the side the surface beside it faces (v nudged inwards). */
static void quadric_normal(const quadric_profile *pr, double sweep, double theta, double v,
                           double scale, double n[3])
{
    double Q[3], dQ[3];
    quadric_profile_eval(pr, v, Q, dQ);
    if (hypot(Q[0], Q[1]) <= 1e-12 * scale) {
        double in[3], vv = v < 0.5 ? v + 1e-4 : v - 1e-4;
        quadric_cross(pr, sweep, theta, vv, in);
        n[0] = n[1] = 0.0, n[2] = in[2] >= 0.0 ? 1.0 : -1.0;
        return;
    }
    quadric_cross(pr, sweep, theta, v, n);
    double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (len > 0.0)
        n[0] /= len, n[1] /= len, n[2] /= len;
    else
        n[0] = n[1] = 0.0, n[2] = 1.0; /* only where the whole surface is degenerate */
}

/* The largest |coordinate| of the profile's control points: the scale of its thresholds. */
static double quadric_scale(const quadric_profile *pr)
{
    double m = 0.0;
    for (int j = 0; j < pr->pieces; j++)
        for (int k = 0; k < 4; k++)
            for (int d = 0; d < 3; d++)
                m = fmax(m, fabs(pr->q[j][k][d]));
    return m;
}

/* Zero area: no sweep, no profile, or dP/du x dP/dv vanishing across the middle. */
static int quadric_degenerate(const quadric_profile *pr, double sweep, double scale)
{
    if (sweep == 0.0 || pr->pieces == 0 || !(scale > 0.0)) return 1;
    for (int k = 1; k <= 3; k++) {
        double n[3];
        quadric_cross(pr, sweep, 0.5 * sweep, 0.25 * k, n);
        if (sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) > 1e-12 * scale * scale) return 0;
    }
    return 1;
}

int quadric_patches(const ts_quadric *q, quadric_patch_fn fn, void *ctx, int *count, char *why,
                    size_t why_len)
{
    quadric_profile pr;
    *count = 0;
    int rc = quadric_profile_make(q, &pr, why, why_len);
    if (rc != TS_OK) return rc;
    const double sweep = quadric_clamp_sweep(q->arg[quadric_arg_count(q->kind) - 1]);
    const double scale = quadric_scale(&pr);
    if (quadric_degenerate(&pr, sweep, scale)) return TS_OK;
    const int nu = quadric_pieces(sweep, q->fixed_pieces), nv = pr.pieces;
    double ends[QUADRIC_MAX_PIECES + 1];
    for (int i = 0; i <= nu; i++)
        ends[i] = i == nu ? sweep : i * sweep / nu;
    for (int i = 0; i < nu; i++) {
        double arc[4][2];
        quadric_arc(ends[i], ends[i + 1], arc);
        for (int j = 0; j < nv; j++) {
            double cp[16][3], n[4][3], uv[4][2];
            for (int jj = 0; jj < 4; jj++)
                for (int ii = 0; ii < 4; ii++) {
                    const double *Q = pr.q[j][jj], C = arc[ii][0], S = arc[ii][1];
                    cp[jj * 4 + ii][0] = Q[0] * C - Q[1] * S;
                    cp[jj * 4 + ii][1] = Q[0] * S + Q[1] * C;
                    cp[jj * 4 + ii][2] = Q[2];
                }
            for (int c = 0; c < 4; c++) {
                int ci = i + (c & 1), cj = j + (c >> 1);
                uv[c][0] = ci == nu ? 1.0 : (double)ci / nu;
                uv[c][1] = cj == nv ? 1.0 : (double)cj / nv;
                quadric_normal(&pr, sweep, ends[ci], uv[c][1], scale, n[c]);
            }
            rc = fn(ctx, (const double(*)[3])cp, (const double(*)[3])n, (const double(*)[2])uv);
            if (rc != TS_OK) return rc;
            (*count)++;
        }
    }
    return TS_OK;
}
