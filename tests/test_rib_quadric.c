/* test_rib_quadric.c — the quadric requests (host/scene/rib/rib_quadric.c, scene/quadric.c).
 * Host only: never skips. Every surface point of every patch is compared with the analytic
 * quadric, computed here independently (the meridian profile of the surface of revolution
 * and the distance to it in the (rho, z) half-plane), against the tolerance quadric.h
 * states; also patch counts of partial sweeps, corner normals (unit, outward, agreeing with
 * the patch's own orientation), a closed sphere and torus being watertight (shared edges
 * identical), primitive variables and errors. */
#include "scene/rib/rib.h"
#include "scene/scene.h"

#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

#define PI 3.14159265358979323846

/* ---- the analytic surfaces ------------------------------------------------------------ */

/* A quadric as a surface of revolution: the meridian (rho(t), z(t)), t in [0, 1], swept from
 * angle 0 to sweep degrees. */
typedef struct analytic {
    int kind; /* 0 sphere, 1 cylinder, 2 cone, 3 disk, 4 paraboloid, 5 hyperboloid, 6 torus */
    double a[7];
    double sweep;
} analytic;

static void meridian(const analytic *q, double t, double *rho, double *z)
{
    const double *a = q->a;
    switch (q->kind) {
    case 0: { /* r zmin zmax */
        double lo = asin(fmax(-1, fmin(1, a[1] / a[0]))), hi = asin(fmax(-1, fmin(1, a[2] / a[0])));
        double phi = lo + t * (hi - lo);
        *rho = a[0] * cos(phi), *z = a[0] * sin(phi);
        break;
    }
    case 1:
        *rho = a[0], *z = a[1] + t * (a[2] - a[1]);
        break;
    case 2: /* h r */
        *rho = a[1] * (1 - t), *z = t * a[0];
        break;
    case 3:
        *rho = a[1] * (1 - t), *z = a[0];
        break;
    case 4: /* rmax zmin zmax */
        *z = a[1] + t * (a[2] - a[1]);
        *rho = a[0] * sqrt(*z / a[2]);
        break;
    case 5: {
        double x = a[0] + t * (a[3] - a[0]), y = a[1] + t * (a[4] - a[1]);
        *rho = hypot(x, y), *z = a[2] + t * (a[5] - a[2]);
        break;
    }
    default: { /* R r phimin phimax */
        double phi = (a[2] + t * (a[3] - a[2])) * PI / 180;
        *rho = a[0] + a[1] * cos(phi), *z = a[1] * sin(phi);
        break;
    }
    }
}

/* Distance from (rho, z) to the meridian: dense samples, then a golden-section search. */
static double meridian_distance(const analytic *q, double rho, double z)
{
    const int n = 2000;
    double best = INFINITY, bt = 0;
    for (int k = 0; k <= n; k++) {
        double r, h, t = (double)k / n;
        meridian(q, t, &r, &h);
        double d = hypot(r - rho, h - z);
        if (d < best) best = d, bt = t;
    }
    double lo = fmax(0, bt - 1.0 / n), hi = fmin(1, bt + 1.0 / n);
    for (int it = 0; it < 60; it++) {
        double t1 = hi - 0.618 * (hi - lo), t2 = lo + 0.618 * (hi - lo), r1, h1, r2, h2;
        meridian(q, t1, &r1, &h1);
        meridian(q, t2, &r2, &h2);
        if (hypot(r1 - rho, h1 - z) < hypot(r2 - rho, h2 - z))
            hi = t2;
        else
            lo = t1;
    }
    double r, h;
    meridian(q, 0.5 * (lo + hi), &r, &h);
    return fmin(best, hypot(r - rho, h - z));
}

/* ---- helpers ---------------------------------------------------------------------------- */

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

/* dP/du x dP/dv of the Bézier patch at (u, v), by central differences. */
static void bezier_normal(const ts_vec4 *cp, double u, double v, double n[3])
{
    const double h = 1e-5;
    double a[3], b[3], c[3], d[3];
    bezier_point(cp, fmin(1, u + h), v, a);
    bezier_point(cp, fmax(0, u - h), v, b);
    bezier_point(cp, u, fmin(1, v + h), c);
    bezier_point(cp, u, fmax(0, v - h), d);
    double du[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
    double dv[3] = {c[0] - d[0], c[1] - d[1], c[2] - d[2]};
    n[0] = du[1] * dv[2] - du[2] * dv[1];
    n[1] = du[2] * dv[0] - du[0] * dv[2];
    n[2] = du[0] * dv[1] - du[1] * dv[0];
}

/* Loads `rib` and checks every patch against q: 17 x 17 points per patch within
 * tol_rel * size of the surface, and inside the sweep. Returns the largest distance / size. */
static double check_surface(const char *rib, const analytic *q, double size, double tol_rel,
                            uint32_t want_patches)
{
    ts_scene s;
    test_parse_rib_ok(rib, &s);
    assert_int_equal(s.patch_count, want_patches);
    double worst = 0;
    for (uint32_t p = 0; p < s.patch_count; p++)
        for (int j = 0; j <= 16; j++)
            for (int i = 0; i <= 16; i++) {
                double x[3];
                bezier_point(s.cp + p * 16, i / 16.0, j / 16.0, x);
                double rho = hypot(x[0], x[1]);
                double d = meridian_distance(q, rho, x[2]) / size;
                worst = fmax(worst, d);
                if (d > tol_rel)
                    fail_msg("%s: patch %u (%d/16, %d/16): distance %.3g * size > %.3g", rib, p, i,
                             j, d, tol_rel);
                if (rho > 1e-6 * size) { /* inside the sweep (1e-3 radians of slack) */
                    double th = atan2(x[1], x[0]) * 180 / PI, lo = fmin(0, q->sweep),
                           hi = fmax(0, q->sweep);
                    if (fabs(q->sweep) < 360 && th < lo - 0.06) th += 360;
                    if (fabs(q->sweep) < 360 && (th < lo - 0.06 || th > hi + 0.06))
                        fail_msg("%s: patch %u: angle %g outside [%g, %g]", rib, p, th, lo, hi);
                }
            }
    scene_free(&s);
    return worst;
}

/* ---- tests ------------------------------------------------------------------------------ */

static void test_surfaces_within_tolerance(void **state)
{
    (void)state;
    /* The stated tolerances (quadric.h): 2.73e-4 of rho_max for line and parabola profiles,
     * 5.5e-4 r for the sphere, 2.73e-4 (R + 2 r) for the torus. */
    const analytic sphere = {0, {2, -2, 2}, 360};
    double w = check_surface("Sphere 2 -2 2 360", &sphere, 2, 5.5e-4, 8);
    /* The approximation error is really measured (the test can fail): the cubic arc's
     * radial error 2.7e-4 shows. */
    assert_true(w > 2.0e-4);
    const analytic part = {0, {1.5, -0.7, 1.2}, 250};
    check_surface("Sphere 1.5 -0.7 1.2 250", &part, 1.5, 5.5e-4, 3); /* phi -28..53 */
    const analytic cyl = {1, {0.8, -1, 2}, 360};
    check_surface("Cylinder 0.8 -1 2 360", &cyl, 0.8, 2.73e-4, 4);
    const analytic cone = {2, {2, 1}, 135};
    check_surface("Cone 2 1 135", &cone, 1, 2.73e-4, 2);
    const analytic disk = {3, {0.5, 3}, 360};
    check_surface("Disk 0.5 3 360", &disk, 3, 2.73e-4, 4);
    const analytic para = {4, {1, 0.25, 2}, 300};
    check_surface("Paraboloid 1 0.25 2 300", &para, 1, 2.73e-4, 4);
    const analytic para0 = {4, {1, 0, 1}, 360};
    check_surface("Paraboloid [1 0 1 360]", &para0, 1, 2.73e-4, 4);
    const analytic hyp = {5, {1, -0.5, -1, 0.5, 1, 1}, 360};
    check_surface("Hyperboloid [1 -0.5 -1] [0.5 1 1] 360", &hyp, hypot(1, 0.5), 2.73e-4, 4);
    const analytic torus = {6, {2, 0.5, 0, 360}, 360};
    check_surface("Torus 2 0.5 0 360 360", &torus, 3, 2.73e-4, 16);
    const analytic half = {6, {1, 0.25, -90, 90}, 200};
    check_surface("Torus 1 0.25 -90 90 200", &half, 1.5, 2.73e-4, 3 * 2);
    /* A transformed sphere: the points are moved by the CTM (Translate then Scale). */
    const analytic small = {0, {1, -1, 1}, 360};
    check_surface("Translate 0 0 0\nScale 1 1 1\nSphere 1 -1 1 360", &small, 1, 5.5e-4, 8);
}

static void test_patch_counts(void **state)
{
    (void)state;
    static const struct {
        const char *rib;
        uint32_t patches;
    } cases[] = {
        {"Sphere 1 -1 1 360", 8},     /* 4 sweep pieces x 2 profile pieces (180 degrees) */
        {"Sphere 1 -1 1 90", 2},      /* one sweep piece */
        {"Sphere 1 -1 1 90.5", 4},    /* just over 90: two */
        {"Sphere 1 0 1 360", 4},      /* the upper half: phi 0..90 */
        {"Sphere 1 -0.5 0.5 270", 3}, /* phi -30..30: one profile piece */
        {"Sphere 1 -5 5 720", 8},     /* z clamped to the radius, thetamax to 360 */
        {"Cylinder 1 0 1 45", 1},
        {"Cone 1 1 -360", 4},
        {"Disk 0 1 180", 2},
        {"Torus 1 0.3 0 360 360", 16},
        {"Torus 1 0.3 0 180 180", 4},
        {"Torus 1 0.3 45 90 30", 1},
        {"Hyperboloid 1 0 0 1 1 1 360", 4},
        {"Paraboloid 1 0 1 360", 4},
        {"Sphere 0 -1 1 360", 0},           /* zero radius: nothing (with a warning) */
        {"Sphere 0 -0 1 360", 0},           /* z / r = 0 / 0 once gave NaN angles (the fuzzer) */
        {"Sphere 1 -1 1 0", 0},             /* no sweep */
        {"Cylinder 1 1 1 360", 0},          /* no height */
        {"Hyperboloid 0 0 0 0 0 1 360", 0}, /* a line on the axis */
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        ts_scene s;
        test_parse_rib_ok(cases[k].rib, &s);
        if (s.patch_count != cases[k].patches)
            fail_msg("%s: %u patches, want %u", cases[k].rib, s.patch_count, cases[k].patches);
        scene_free(&s);
    }
    int rc;
    const char *w = test_rib_warnings("Sphere 0 -1 1 360", &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(w, "w.rib:1:1: warning: Sphere of zero area is skipped\n");
}

/* Corner normals: unit length, perpendicular to the surface and on the side of the patch's
 * own dP/du x dP/dv where that is defined; `outward` checks the direction at each corner. */
static void check_normals(const char *rib, int flipped,
                          void (*outward)(const double p[3], double n_want[3]))
{
    ts_scene s;
    test_parse_rib_ok(rib, &s);
    assert_true(s.patch_count > 0);
    static const int corner_cp[4] = {0, 3, 12, 15};
    for (uint32_t p = 0; p < s.patch_count; p++)
        for (int c = 0; c < 4; c++) {
            const ts_vec4 *n = &s.corner_n[p * 4 + c], *x = &s.cp[p * 16 + corner_cp[c]];
            double len = sqrt((double)n->x * n->x + (double)n->y * n->y + (double)n->z * n->z);
            assert_true(fabs(len - 1) < 1e-6);
            double pt[3] = {x->x, x->y, x->z}, want[3];
            outward(pt, want);
            double dot = (n->x * want[0] + n->y * want[1] + n->z * want[2]) * (flipped ? -1 : 1);
            if (dot < 1 - 1e-5)
                fail_msg(
                    "%s: patch %u corner %d at (%g %g %g): normal (%g %g %g), want %s(%g %g %g)",
                    rib, p, c, pt[0], pt[1], pt[2], n->x, n->y, n->z, flipped ? "-" : "", want[0],
                    want[1], want[2]);
            /* The patch's own normal a little inside the corner agrees in orientation. */
            double g[3], u = (c & 1) ? 0.98 : 0.02, v = (c & 2) ? 0.98 : 0.02;
            bezier_normal(s.cp + p * 16, u, v, g);
            assert_true(g[0] * n->x + g[1] * n->y + g[2] * n->z > 0);
        }
    scene_free(&s);
}

static void out_sphere(const double p[3], double n[3])
{
    double l = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    n[0] = p[0] / l, n[1] = p[1] / l, n[2] = p[2] / l;
}

static void out_cylinder(const double p[3], double n[3])
{
    double l = hypot(p[0], p[1]);
    n[0] = p[0] / l, n[1] = p[1] / l, n[2] = 0;
}

static void out_up(const double p[3], double n[3])
{
    (void)p;
    n[0] = n[1] = 0, n[2] = 1;
}

/* The unit cone 2 (height) 1 (radius): outward normal (2 cos, 2 sin, 1) / sqrt(5); the
 * apex takes the axis. */
static void out_cone(const double p[3], double n[3])
{
    double l = hypot(p[0], p[1]);
    if (l < 1e-6) {
        out_up(p, n);
        return;
    }
    n[0] = 2 * p[0] / l / sqrt(5), n[1] = 2 * p[1] / l / sqrt(5), n[2] = 1 / sqrt(5);
}

/* The torus R = 2, r = 0.5: away from the tube's centre line. */
static void out_torus(const double p[3], double n[3])
{
    double l = hypot(p[0], p[1]);
    double c[3] = {2 * p[0] / l, 2 * p[1] / l, 0}, d[3] = {p[0] - c[0], p[1] - c[1], p[2]};
    out_sphere(d, n);
}

static void test_normals(void **state)
{
    (void)state;
    check_normals("Sphere 1 -1 1 360", 0, out_sphere);
    check_normals("Sphere 1 -0.3 0.9 200", 0, out_sphere);
    check_normals("Sphere 1 -1 1 -360", 1, out_sphere); /* a negative sweep flips them */
    check_normals("Cylinder 1 -1 1 300", 0, out_cylinder);
    check_normals("Disk 0.5 1 360", 0, out_up);
    check_normals("Cone 2 1 360", 0, out_cone);
    check_normals("Torus 2 0.5 0 360 360", 0, out_torus);
    /* Under a non-uniform scale normals move by the inverse transpose: the ellipsoid
     * x^2 / 4 + y^2 + z^2 = 1 has normal (x / 4, y, z) normalised. */
    ts_scene s;
    test_parse_rib_ok("Scale 2 1 1\nSphere 1 -1 1 360", &s);
    for (uint32_t k = 0; k < s.patch_count * 4; k++) {
        const ts_vec4 *x = &s.cp[(k / 4) * 16 + (int[]){0, 3, 12, 15}[k % 4]];
        double want[3] = {x->x / 4.0, x->y, x->z},
               l = sqrt(want[0] * want[0] + want[1] * want[1] + want[2] * want[2]);
        const ts_vec4 *n = &s.corner_n[k];
        assert_true(fabs(n->x - want[0] / l) < 1e-6 && fabs(n->y - want[1] / l) < 1e-6 &&
                    fabs(n->z - want[2] / l) < 1e-6);
    }
    scene_free(&s);
}

/* The number of non-degenerate boundary edges (four control points) of the patches that
 * are, bit for bit, a boundary edge of no other patch (in either direction). */
static int open_edges(const char *rib)
{
    ts_scene s;
    test_parse_rib_ok(rib, &s);
    static const int edges[4][4] = {{0, 1, 2, 3}, {12, 13, 14, 15}, {0, 4, 8, 12}, {3, 7, 11, 15}};
    int open = 0;
    for (uint32_t p = 0; p < s.patch_count; p++)
        for (int e = 0; e < 4; e++) {
            const ts_vec4 *a = s.cp + p * 16;
            int degenerate = 1;
            for (int k = 1; k < 4; k++)
                degenerate &= memcmp(&a[edges[e][k]], &a[edges[e][0]], sizeof *a) == 0;
            if (degenerate) continue; /* a pole */
            int found = 0;
            for (uint32_t q = 0; q < s.patch_count && !found; q++)
                for (int f = 0; f < 4 && !found && q != p; f++) {
                    const ts_vec4 *b = s.cp + q * 16;
                    int same = 1, rev = 1;
                    for (int k = 0; k < 4; k++) {
                        same &= memcmp(&a[edges[e][k]], &b[edges[f][k]], sizeof *a) == 0;
                        rev &= memcmp(&a[edges[e][k]], &b[edges[f][3 - k]], sizeof *a) == 0;
                    }
                    found = same || rev;
                }
            open += !found;
        }
    scene_free(&s);
    return open;
}

static void test_watertight(void **state)
{
    (void)state;
    assert_int_equal(open_edges("Sphere 1 -1 1 360"), 0);
    assert_int_equal(open_edges("Rotate 30 1 1 0\nTranslate 0.1 0.2 0.3\nSphere 3.7 -3.7 3.7 360"),
                     0);
    assert_int_equal(open_edges("Torus 2 0.5 0 360 360"), 0);
    assert_int_equal(open_edges("Rotate 10 0 1 1\nTorus 1.3 0.41 -180 180 360"), 0);
    /* Open surfaces are found open: a 270 degree sphere has two seams of two pieces each, a
     * cylinder its top and bottom circles (4 pieces each). */
    assert_int_equal(open_edges("Sphere 1 -1 1 270"), 4);
    assert_int_equal(open_edges("Cylinder 1 0 1 360"), 8);
}

static void test_primitive_variables(void **state)
{
    (void)state;
    ts_scene s;
    /* Default st: the quadric's (u, v) at each patch's corners. */
    test_parse_rib_ok("Sphere 1 -1 1 360", &s);
    assert_int_equal(s.patch_count, 8);
    /* Patch 3 is the second profile piece of the second sweep piece: u 0.25..0.5, v 0.5..1. */
    const float want[8] = {0.25f, 0.5f, 0.5f, 0.5f, 0.25f, 1, 0.5f, 1};
    for (int k = 0; k < 8; k++)
        assert_float_equal(s.attr[3].st[k], want[k], 0);
    scene_free(&s);
    /* Varying st and Cs blend bilinearly over the whole quadric. */
    test_parse_rib_ok("Cylinder 1 0 1 360 \"st\" [0 0 2 0 0 1 2 1] \"varying color Cs\" "
                      "[1 0 0 1 0 0 0 0 1 0 0 1]",
                      &s);
    assert_int_equal(s.patch_count, 4);
    assert_float_equal(s.attr[1].st[0], 0.5f, 1e-7); /* corner (0,0) of piece 1: u = 0.25 */
    assert_float_equal(s.attr[1].st[2], 1.0f, 1e-7);
    assert_float_equal(s.attr[1].st[5], 1.0f, 1e-7);
    assert_float_equal(s.attr[1].cs_r, 0.5f, 1e-7); /* v runs 0..1 on every patch */
    assert_float_equal(s.attr[1].cs_b, 0.5f, 1e-7);
    scene_free(&s);
    test_parse_rib_ok("Color 0.2 0.3 0.4\nDisk 0 1 360 \"constant color Cs\" [0.9 0.8 0.7]", &s);
    assert_float_equal(s.attr[0].cs_r, 0.9f, 1e-7);
    scene_free(&s);
}

static void test_errors(void **state)
{
    (void)state;
    test_parse_rib_error("Sphere 1 -1", "t.rib:1:1: error: Sphere expects 4 numbers, got 2");
    test_parse_rib_error("Torus [1 2 3 4 5 6]", "t.rib:1:7: error: Torus expects 5 numbers, got 6");
    test_parse_rib_error("Cone 1 \"x\" 1", "t.rib:1:8: error: Cone expects 3 numbers, got 1");
    test_parse_rib_error(
        "Paraboloid 1 -1 1 360",
        "t.rib:1:1: error: Paraboloid: zmin -1 and zmax 1 lie on opposite sides of 0 "
        "(the paraboloid z = zmax (r / rmax)^2 has no points there)");
    test_parse_rib_error("WorldBegin\nWorldEnd\nDisk 0 1 360",
                         "t.rib:3:1: error: Disk after WorldEnd");
    {
        ts_scene s;
        ts_error e = {0};
        assert_int_equal(test_parse_rib_strict("Scale 1 1 0\nSphere 1 -1 1 360", &s, &e),
                         TS_E_SCENE);
        assert_string_equal(e.msg, "t.rib:2:1: error: Sphere: the current transformation is "
                                   "singular; \"N\" needs an invertible one");
        ts_error_clear(&e);
        /* Not strict: the sphere flattened to a disk, z = 0 everywhere (test_rib.c
         * test_singular_transform has the warning). */
        assert_int_equal(test_parse_rib("Scale 1 1 0\nSphere 1 -1 1 360", &s, &e), TS_OK);
        assert_true(s.patch_count > 0);
        for (uint32_t k = 0; k < 16 * s.patch_count; k++)
            assert_true(s.cp[k].z == 0.0f);
        scene_free(&s);
    }
    /* In a motion block a quadric deforms (test_rib_deform.c): it needs its second sample. */
    test_parse_rib_error("MotionBegin [0 1]\nSphere 1 -1 1 360\nMotionEnd\n",
                         "t.rib:3:1: error: MotionEnd: the motion block at 1:1 has 1 sample for 2 "
                         "times");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_surfaces_within_tolerance),
        cmocka_unit_test(test_patch_counts),
        cmocka_unit_test(test_normals),
        cmocka_unit_test(test_watertight),
        cmocka_unit_test(test_primitive_variables),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
