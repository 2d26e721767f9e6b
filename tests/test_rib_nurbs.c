/* test_rib_nurbs.c — NuPatch (host/scene/rib/rib_nurbs.c, scene/nurbs.c). Host only: never
 * skips. Every patch is compared, at 9 x 9 points, with a direct de Boor evaluation of the
 * NURBS written here (the triangular scheme on homogeneous points, independent of the
 * loader's knot insertion): polynomial surfaces of every order 2..4, with interior double
 * knots, unclamped knot vectors and partial parameter ranges, to float rounding; rational
 * ones (circles, a sphere, random weights) within the stated NURBS_TOL_REL of their size.
 * Also piece counts, shared edges, primitive variables and errors. */
#include "scene/nurbs.h"
#include "scene/rib/rib.h"
#include "scene/scene.h"

#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

/* ---- a NURBS and its de Boor evaluation -------------------------------------------------- */

typedef struct nurbs {
    int nu, uo, nv, vo;
    double uk[32], vk[32];
    double umin, umax, vmin, vmax;
    double pw[32 * 32][4]; /* homogeneous, u fastest */
    int rational;
} nurbs;

/* de Boor on one curve: n homogeneous points (stride s), knots t, order o, at x. */
static void de_boor(const double *pts, size_t s, const double *t, int n, int o, double x,
                    double out[4])
{
    int p = o - 1, k = n - 1;
    while (k > p && !(t[k] <= x && t[k] < t[k + 1]))
        k--;
    double d[4][4];
    for (int j = 0; j <= p; j++)
        memcpy(d[j], pts + (size_t)(k - p + j) * s, sizeof d[j]);
    for (int r = 1; r <= p; r++)
        for (int j = p; j >= r; j--) {
            int i = k - p + j;
            double a = (x - t[i]) / (t[i + p + 1 - r] - t[i]);
            for (int c = 0; c < 4; c++)
                d[j][c] = (1 - a) * d[j - 1][c] + a * d[j][c];
        }
    memcpy(out, d[p], sizeof d[p]);
}

static void nurbs_point(const nurbs *s, double u, double v, double out[3])
{
    double col[32][4], h[4];
    for (int j = 0; j < s->nv; j++)
        de_boor(s->pw[j * s->nu], 4, s->uk, s->nu, s->uo, u, col[j]);
    de_boor(col[0], 4, s->vk, s->nv, s->vo, v, h);
    out[0] = h[0] / h[3], out[1] = h[1] / h[3], out[2] = h[2] / h[3];
}

/* The RIB text of s. */
static void nurbs_rib(const nurbs *s, const char *extra, char *buf, size_t cap)
{
    size_t n = 0;
    n += (size_t)snprintf(buf + n, cap - n, "NuPatch %d %d [", s->nu, s->uo);
    for (int k = 0; k < s->nu + s->uo; k++)
        n += (size_t)snprintf(buf + n, cap - n, "%.17g ", s->uk[k]);
    n +=
        (size_t)snprintf(buf + n, cap - n, "] %.17g %.17g %d %d [", s->umin, s->umax, s->nv, s->vo);
    for (int k = 0; k < s->nv + s->vo; k++)
        n += (size_t)snprintf(buf + n, cap - n, "%.17g ", s->vk[k]);
    n += (size_t)snprintf(buf + n, cap - n, "] %.17g %.17g \"%s\" [", s->vmin, s->vmax,
                          s->rational ? "Pw" : "P");
    for (int k = 0; k < s->nu * s->nv; k++)
        for (int d = 0; d < (s->rational ? 4 : 3); d++)
            n += (size_t)snprintf(buf + n, cap - n, "%.17g ", s->pw[k][d]);
    snprintf(buf + n, cap - n, "] %s", extra ? extra : "");
}

static void bezier_point(const ts_vec4 *cp, double u, double v, double out[3])
{
    const double bu[4] = {(1 - u) * (1 - u) * (1 - u), 3 * u * (1 - u) * (1 - u),
                          3 * u * u * (1 - u), u * u * u};
    const double bv[4] = {(1 - v) * (1 - v) * (1 - v), 3 * v * (1 - v) * (1 - v),
                          3 * v * v * (1 - v), v * v * v};
    out[0] = out[1] = out[2] = 0;
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            double w = bu[i] * bv[j];
            out[0] += w * cp[j * 4 + i].x, out[1] += w * cp[j * 4 + i].y,
                out[2] += w * cp[j * 4 + i].z;
        }
}

/* Loads s and compares every patch with de Boor at 9 x 9 points, the patch's parameters
 * mapped linearly onto the knot-space rectangle of its corners' "st" (the default st is
 * the knot (u, v)). Returns the largest distance relative to the control box diagonal and
 * fails above tol_rel; *patches gets the count. */
static double check_nurbs(const nurbs *s, double tol_rel, uint32_t *patches)
{
    static char rib[1 << 17];
    nurbs_rib(s, NULL, rib, sizeof rib);
    ts_scene sc;
    test_parse_rib_ok(rib, &sc);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int k = 0; k < s->nu * s->nv; k++)
        for (int d = 0; d < 3; d++)
            lo[d] = fmin(lo[d], s->pw[k][d] / s->pw[k][3]),
            hi[d] = fmax(hi[d], s->pw[k][d] / s->pw[k][3]);
    double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                       (hi[2] - lo[2]) * (hi[2] - lo[2]));
    double worst = 0, covered = 0;
    for (uint32_t p = 0; p < sc.patch_count; p++) {
        const float *st = sc.attr[p].st; /* corners (0,0) (1,0) (0,1) (1,1) */
        double u0 = st[0], u1 = st[2], v0 = st[1], v1 = st[5];
        assert_true(u0 >= s->umin - 1e-6 && u1 <= s->umax + 1e-6 && u0 < u1);
        assert_true(v0 >= s->vmin - 1e-6 && v1 <= s->vmax + 1e-6 && v0 < v1);
        covered += (u1 - u0) * (v1 - v0);
        for (int j = 0; j <= 8; j++)
            for (int i = 0; i <= 8; i++) {
                double a[3], b[3];
                bezier_point(sc.cp + p * 16, i / 8.0, j / 8.0, a);
                nurbs_point(s, u0 + i / 8.0 * (u1 - u0), v0 + j / 8.0 * (v1 - v0), b);
                double d = sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                                (a[2] - b[2]) * (a[2] - b[2])) /
                           diag;
                worst = fmax(worst, d);
                if (d > tol_rel)
                    fail_msg("patch %u at (%d/8, %d/8): %.3g of the size from de Boor (> %.3g)", p,
                             i, j, d, tol_rel);
            }
    }
    /* The patches tile the whole parameter range (st holds floats: 1e-6 of slack). */
    double want = (s->umax - s->umin) * (s->vmax - s->vmin);
    assert_true(fabs(covered - want) <= 1e-6 * want + 1e-6);
    *patches = sc.patch_count;
    scene_free(&sc);
    return worst;
}

static void random_net(nurbs *s, uint32_t *seed, int rational)
{
    s->rational = rational;
    for (int k = 0; k < s->nu * s->nv; k++) {
        double w = rational ? test_uniform(seed, 0.4f, 2.5f) : 1.0;
        s->pw[k][0] = (k % s->nu + test_uniform(seed, -0.3f, 0.3f)) * w;
        s->pw[k][1] = (k / s->nu + test_uniform(seed, -0.3f, 0.3f)) * w;
        s->pw[k][2] = test_uniform(seed, -1, 1) * w;
        s->pw[k][3] = w;
    }
}

/* ---- tests --------------------------------------------------------------------------------- */

static void test_polynomial_exact(void **state)
{
    (void)state;
    uint32_t seed = 3, patches;
    /* Cubic x cubic, clamped, an interior double knot in u, the whole range: 4 pieces in u
     * (the non-empty spans), 3 in v. */
    nurbs a = {.nu = 8,
               .uo = 4,
               .nv = 6,
               .vo = 4,
               .uk = {0, 0, 0, 0, 1, 2, 2, 3, 4, 4, 4, 4},
               .vk = {0, 0, 0, 0, 0.5, 2, 3, 3, 3, 3},
               .umin = 0,
               .umax = 4,
               .vmin = 0,
               .vmax = 3};
    random_net(&a, &seed, 0);
    double w = check_nurbs(&a, 2e-7, &patches);
    assert_int_equal(patches, 4 * 3);
    assert_true(w < 2e-7);
    /* Uniform (unclamped) cubic knots with a partial range inside: umin and umax cut spans. */
    nurbs b = {.nu = 7,
               .uo = 4,
               .nv = 5,
               .vo = 4,
               .uk = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10},
               .vk = {0, 1, 2, 3, 4, 5, 6, 7, 8},
               .umin = 3.25,
               .umax = 6.5,
               .vmin = 3,
               .vmax = 5};
    random_net(&b, &seed, 0);
    check_nurbs(&b, 2e-7, &patches);
    assert_int_equal(patches, 4 * 2); /* u: [3.25,4] [4,5] [5,6] [6,6.5]; v: [3,4] [4,5] */
    /* Quadratic x linear (degree-elevated exactly), and linear x quadratic. */
    nurbs c = {.nu = 5,
               .uo = 3,
               .nv = 3,
               .vo = 2,
               .uk = {0, 0, 0, 1, 3, 4, 4, 4},
               .vk = {0, 0, 1, 2, 2},
               .umin = 0,
               .umax = 4,
               .vmin = 0,
               .vmax = 2};
    random_net(&c, &seed, 0);
    check_nurbs(&c, 2e-7, &patches);
    assert_int_equal(patches, 3 * 2);
    nurbs d = {.nu = 2,
               .uo = 2,
               .nv = 4,
               .vo = 3,
               .uk = {0, 0, 1, 1},
               .vk = {0, 0, 0, 0.3, 1, 1, 1},
               .umin = 0,
               .umax = 1,
               .vmin = 0,
               .vmax = 1};
    random_net(&d, &seed, 0);
    check_nurbs(&d, 2e-7, &patches);
    assert_int_equal(patches, 2);
    /* "Pw" with every weight 2: polynomial, exact. */
    nurbs e = a;
    e.rational = 1;
    for (int k = 0; k < e.nu * e.nv; k++)
        for (int q = 0; q < 4; q++)
            e.pw[k][q] *= 2;
    check_nurbs(&e, 2e-7, &patches);
    assert_int_equal(patches, 12);
}

/* The rational quadratic full circle of radius r in the xy plane (9 points, weights 1 and
 * sqrt(2)/2) as the u direction, swept linearly (cylinder) or as a semicircle in v (sphere). */
static void circle_u(nurbs *s, double r)
{
    static const double k[12] = {0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1};
    static const double xy[9][2] = {{1, 0},   {1, 1},  {0, 1},  {-1, 1}, {-1, 0},
                                    {-1, -1}, {0, -1}, {1, -1}, {1, 0}};
    s->nu = 9, s->uo = 3, s->umin = 0, s->umax = 1, s->rational = 1;
    memcpy(s->uk, k, sizeof k);
    for (int j = 0; j < s->nv; j++)
        for (int i = 0; i < 9; i++) {
            double w = (i % 2) ? sqrt(0.5) : 1.0;
            double *q = s->pw[j * 9 + i];
            q[0] = xy[i][0] * r * w, q[1] = xy[i][1] * r * w, q[3] = w;
        }
}

static void test_rational_within_tolerance(void **state)
{
    (void)state;
    uint32_t patches;
    /* A cylinder: the circle swept along z (linear in v). */
    nurbs cyl = {.nv = 2, .vo = 2, .vk = {0, 0, 1, 1}, .vmin = 0, .vmax = 1};
    circle_u(&cyl, 2);
    for (int i = 0; i < 9; i++)
        cyl.pw[9 + i][0] = cyl.pw[i][0], cyl.pw[9 + i][1] = cyl.pw[i][1],
                   cyl.pw[9 + i][3] = cyl.pw[i][3], cyl.pw[i][2] = 0,
                   cyl.pw[9 + i][2] = 3 * cyl.pw[i][3];
    double w = check_nurbs(&cyl, NURBS_TOL_REL, &patches);
    assert_true(patches >= 4 && patches % 4 == 0);
    assert_true(w > 1e-7); /* really an approximation, and really measured */
    /* The patches lie on the cylinder of radius 2 within the tolerance too. */
    static char rib[1 << 17];
    nurbs_rib(&cyl, NULL, rib, sizeof rib);
    ts_scene sc;
    test_parse_rib_ok(rib, &sc);
    double diag = sqrt(16 + 16 + 9);
    for (uint32_t p = 0; p < sc.patch_count; p++)
        for (int j = 0; j <= 8; j++)
            for (int i = 0; i <= 8; i++) {
                double x[3];
                bezier_point(sc.cp + p * 16, i / 8.0, j / 8.0, x);
                assert_true(fabs(hypot(x[0], x[1]) - 2) <= NURBS_TOL_REL * diag);
            }
    scene_free(&sc);
    /* A sphere: the circle times a rational quadratic semicircle in v. */
    nurbs sph = {.nv = 5, .vo = 3, .vk = {0, 0, 0, 0.5, 0.5, 1, 1, 1}, .vmin = 0, .vmax = 1};
    circle_u(&sph, 1);
    static const double rz[5][2] = {{0, -1}, {1, -1}, {1, 0}, {1, 1}, {0, 1}};
    for (int j = 0; j < 5; j++)
        for (int i = 0; i < 9; i++) {
            double wu = (i % 2) ? sqrt(0.5) : 1.0, wv = (j % 2) ? sqrt(0.5) : 1.0;
            double *q = sph.pw[j * 9 + i];
            double x = q[0] / q[3], y = q[1] / q[3]; /* the unit circle's point */
            q[0] = x * rz[j][0] * wu * wv, q[1] = y * rz[j][0] * wu * wv;
            q[2] = rz[j][1] * wu * wv, q[3] = wu * wv;
        }
    check_nurbs(&sph, NURBS_TOL_REL, &patches);
    assert_true(patches >= 8);
    /* Random weights in [0.4, 2.5] on a cubic net. */
    uint32_t seed = 11;
    nurbs r = {.nu = 5,
               .uo = 4,
               .nv = 4,
               .vo = 4,
               .uk = {0, 0, 0, 0, 0.6, 1, 1, 1, 1},
               .vk = {0, 0, 0, 0, 1, 1, 1, 1},
               .umin = 0,
               .umax = 1,
               .vmin = 0,
               .vmax = 1};
    random_net(&r, &seed, 1);
    check_nurbs(&r, NURBS_TOL_REL, &patches);
}

/* Shared boundaries of neighbouring patches are bit for bit the same: every patch edge is
 * another patch's, except those on the outline of the parameter range [lo, hi]^2 (found
 * from the corners' default st, the knot values). */
static void check_shared_edges(const char *rib, double lo, double hi)
{
    ts_scene s;
    test_parse_rib_ok(rib, &s);
    static const int edges[4][4] = {{0, 1, 2, 3}, {12, 13, 14, 15}, {0, 4, 8, 12}, {3, 7, 11, 15}};
    int open = 0, outline = 0;
    for (uint32_t p = 0; p < s.patch_count; p++) {
        const float *st = s.attr[p].st;
        outline += (st[1] == (float)lo) + (st[5] == (float)hi) + (st[0] == (float)lo) +
                   (st[2] == (float)hi);
        for (int e = 0; e < 4; e++) {
            int found = 0;
            for (uint32_t q = 0; q < s.patch_count && !found; q++)
                for (int f = 0; f < 4 && !found && q != p; f++) {
                    int same = 1;
                    for (int k = 0; k < 4; k++)
                        same &= memcmp(&s.cp[p * 16 + edges[e][k]], &s.cp[q * 16 + edges[f][k]],
                                       sizeof s.cp[0]) == 0;
                    found = same;
                }
            open += !found;
        }
    }
    assert_true(outline >= 4);
    assert_int_equal(open, outline);
    scene_free(&s);
}

static void test_shared_edges(void **state)
{
    (void)state;
    static char rib[1 << 17];
    uint32_t seed = 5;
    nurbs a = {.nu = 6,
               .uo = 4,
               .nv = 5,
               .vo = 3,
               .uk = {0, 0, 0, 0, 1, 2, 3, 3, 3, 3},
               .vk = {0, 0, 0, 1, 2, 3, 3, 3},
               .umin = 0,
               .umax = 3,
               .vmin = 0,
               .vmax = 3};
    random_net(&a, &seed, 0);
    nurbs_rib(&a, NULL, rib, sizeof rib);
    ts_scene s;
    test_parse_rib_ok(rib, &s);
    assert_int_equal(s.patch_count, 9); /* a 3 x 3 grid of pieces */
    scene_free(&s);
    check_shared_edges(rib, 0, 3);
    random_net(&a, &seed, 1); /* rational: each piece split alike */
    nurbs_rib(&a, NULL, rib, sizeof rib);
    test_parse_rib_ok(rib, &s);
    assert_true(s.patch_count > 9 && s.patch_count % 9 == 0);
    scene_free(&s);
    check_shared_edges(rib, 0, 3);
}

static void test_primitive_variables(void **state)
{
    (void)state;
    /* Bilinear 3 x 2 points: 2 segments in u, 1 in v. Uniform Cs per segment, varying st
     * at the segment corners (3 x 2), knots u 0 1 2. */
    ts_scene s;
    test_parse_rib_ok("NuPatch 3 2 [0 0 1 2 2] 0 2 2 2 [0 0 1 1] 0 1\n"
                      "  \"P\" [0 0 0 1 0 0 2 0 0 0 1 0 1 1 0 2 1 0]\n"
                      "  \"uniform color Cs\" [1 0 0 0 0 1]\n"
                      "  \"st\" [0 0 10 0 20 0 0 5 10 5 20 5]",
                      &s);
    assert_int_equal(s.patch_count, 2);
    assert_float_equal(s.attr[0].cs_r, 1, 0);
    assert_float_equal(s.attr[1].cs_b, 1, 0);
    const float st1[8] = {10, 0, 20, 0, 10, 5, 20, 5};
    for (int k = 0; k < 8; k++)
        assert_float_equal(s.attr[1].st[k], st1[k], 1e-6);
    scene_free(&s);
    /* Without "st": the knot values; under a partial range they start at umin. */
    test_parse_rib_ok("NuPatch 3 2 [0 0 1 2 2] 0.5 2 2 2 [0 0 1 1] 0 1\n"
                      "  \"P\" [0 0 0 1 0 0 2 0 0 0 1 0 1 1 0 2 1 0]",
                      &s);
    assert_int_equal(s.patch_count, 2);
    assert_float_equal(s.attr[0].st[0], 0.5f, 0);
    assert_float_equal(s.attr[0].st[2], 1.0f, 0);
    assert_float_equal(s.attr[1].st[2], 2.0f, 0);
    scene_free(&s);
}

static void test_errors(void **state)
{
    (void)state;
    test_parse_rib_error("NuPatch 5 5 [0 0 0 0 0 1 1 1 1 1] 0 1 2 2 [0 0 1 1] 0 1 \"P\" ["
                         "0 0 0 1 0 0 2 0 0 3 0 0 4 0 0 0 1 0 1 1 0 2 1 0 3 1 0 4 1 0]",
                         "t.rib:1:1: error: NuPatch: uorder 5 is not supported (at most 4, cubic)");
    test_parse_rib_error(
        "NuPatch 2 1 [0 1 2] 0 1 2 2 [0 0 1 1] 0 1 \"P\" [0 0 0 1 0 0 0 1 0 1 1 0]",
        "t.rib:1:1: error: NuPatch: uorder 1 is not supported (at least 2: order 1 is a "
        "step function)");
    test_parse_rib_error(
        "NuPatch 2 3 [0 0 0 1 1] 0 1 2 2 [0 0 1 1] 0 1 \"P\" [0 0 0 1 0 0 0 1 0 1 1 0]",
        "t.rib:1:1: error: NuPatch: nu = 2 control points are fewer than the uorder 3");
    test_parse_rib_error(
        "NuPatch 2 2 [0 1 0 1] 0 1 2 2 [0 0 1 1] 0 1 \"P\" [0 0 0 1 0 0 0 1 0 1 1 0]",
        "t.rib:1:1: error: NuPatch: uknot 2 (0) is less than the one before (1)");
    test_parse_rib_error(
        "NuPatch 2 2 [0 0 1] 0 1 2 2 [0 0 1 1] 0 1 \"P\" [0 0 0 1 0 0 0 1 0 1 1 0]",
        "t.rib:1:13: error: NuPatch: uknot needs nu + uorder = 4 values, got 3");
    test_parse_rib_error(
        "NuPatch 2 2 [0 0 1 1] 2 3 2 2 [0 0 1 1] 0 1 \"P\" [0 0 0 1 0 0 0 1 0 1 1 0]",
        "t.rib:1:1: error: NuPatch: umin 2 and umax 3 leave no part of the valid range "
        "[0, 1]");
    test_parse_rib_error(
        "NuPatch 2 2 [0 0 1 1] 0 1 2 2 [0 0 1 1] 0 1 \"P\" [0 0 0 1 0 0 0 1 0]",
        "t.rib:1:49: error: NuPatch: parameter \"P\" (vertex) needs 12 values, got 9");
    test_parse_rib_error("NuPatch 2 2 [0 0 1 1] 0 1 2 2 [0 0 1 1] 0 1",
                         "t.rib:1:1: error: NuPatch: missing \"P\" or \"Pw\"");
    test_parse_rib_error(
        "NuPatch 2 2 [0 0 1 1] 0 1 2 2 [0 0 1 1] 0 1 \"P\" [0 0 0 1 0 0 0 1 0 1 1 0] "
        "\"vertex color Cs\" [1 1 1 1 1 1 1 1 1 1 1 1]",
        "t.rib:1:75: error: NuPatch: \"Cs\" of class vertex is not supported (constant, "
        "uniform or varying)");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_polynomial_exact), cmocka_unit_test(test_rational_within_tolerance),
        cmocka_unit_test(test_shared_edges),     cmocka_unit_test(test_primitive_variables),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
