/* test_rib.c — the RIB loader (host/scene/rib/rib*.c), the basis conversion
 * (host/scene/rib/basis.c) and scene growth (host/scene/scene.c). Host only: never skips. Every
 * test asserts numbers: transformed control points, surface points compared with a direct
 * evaluation of the original basis, patch counts, and the exact "file:line:col: error:" prefix of
 * each scene error. */
#include "scene/rib/basis.h"
#include "scene/rib/rib.h"
#include "scene/scene.h"
#include "base/mat4.h"

#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

/* ---- helpers -------------------------------------------------------------------------- */

/* Parses text that must fail with `code` and a message that is exactly `msg`, or starts
 * with it when msg ends in "...". The scene must be left empty. */
static void expect_error(const char *text, int code, const char *msg)
{
    ts_scene s;
    ts_error e;
    assert_int_equal(test_parse_rib(text, &s, &e), code);
    assert_int_equal(e.code, code);
    size_t n = strlen(msg);
    if (n > 3 && strcmp(msg + n - 3, "...") == 0) {
        if (strncmp(e.msg, msg, n - 3) != 0) fail_msg("got \"%s\", want \"%s\"", e.msg, msg);
    } else if (strcmp(e.msg, msg) != 0) {
        fail_msg("got \"%s\", want \"%s\"", e.msg, msg);
    }
    assert_int_equal(s.patch_count, 0);
    assert_null(s.cp);
    assert_null(s.lights);
}

static void assert_vec(const ts_vec4 *c, double x, double y, double z, double tol)
{
    if (fabs(c->x - x) > tol || fabs(c->y - y) > tol || fabs(c->z - z) > tol)
        fail_msg("got (%g %g %g), want (%g %g %g)", c->x, c->y, c->z, x, y, z);
}

static void assert_dvec(const double *a, double x, double y, double z, double tol)
{
    if (fabs(a[0] - x) > tol || fabs(a[1] - y) > tol || fabs(a[2] - z) > tol)
        fail_msg("got (%g %g %g), want (%g %g %g)", a[0], a[1], a[2], x, y, z);
}

/* p' = M p for a row-major column-vector matrix, w = 1. */
static void mat_apply(const double m[16], const double p[3], double out[3])
{
    for (int i = 0; i < 3; i++)
        out[i] = m[i * 4] * p[0] + m[i * 4 + 1] * p[1] + m[i * 4 + 2] * p[2] + m[i * 4 + 3];
}

static double lcg(uint32_t *s)
{
    *s = *s * 1664525u + 1013904223u;
    return (*s >> 8) * (1.0 / 16777216.0);
}

/* The Bézier patch p of the scene at (u, v), by Bernstein polynomials. */
static void bezier_eval(const ts_scene *s, uint32_t p, double u, double v, double out[3])
{
    const double bu[4] = {(1 - u) * (1 - u) * (1 - u), 3 * u * (1 - u) * (1 - u),
                          3 * u * u * (1 - u), u * u * u};
    const double bv[4] = {(1 - v) * (1 - v) * (1 - v), 3 * v * (1 - v) * (1 - v),
                          3 * v * v * (1 - v), v * v * v};
    out[0] = out[1] = out[2] = 0.0;
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            const ts_vec4 *c = &s->cp[p * 16 + j * 4 + i];
            double w = bu[i] * bv[j];
            out[0] += w * c->x, out[1] += w * c->y, out[2] += w * c->z;
        }
}

/* A bicubic patch in its own bases, straight from the RenderMan definition
 * P(u,v) = sum_ij (U Mu)_i (V Mv)_j G[j][i] with U = (u^3, u^2, u, 1); independent of
 * basis.c so that the conversion is checked, not restated. */
static void direct_eval(const double mu[16], const double mv[16], const double g[16][3], double u,
                        double v, double out[3])
{
    const double U[4] = {u * u * u, u * u, u, 1}, V[4] = {v * v * v, v * v, v, 1};
    double wu[4] = {0}, wv[4] = {0};
    for (int i = 0; i < 4; i++)
        for (int r = 0; r < 4; r++)
            wu[i] += U[r] * mu[r * 4 + i], wv[i] += V[r] * mv[r * 4 + i];
    out[0] = out[1] = out[2] = 0.0;
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++)
            for (int d = 0; d < 3; d++)
                out[d] += wu[i] * wv[j] * g[j * 4 + i][d];
}

/* Appends "[x y z ...]" for n points to a text buffer. */
static void print_points(char *buf, size_t cap, const double (*pts)[3], int n)
{
    size_t len = strlen(buf);
    len += (size_t)snprintf(buf + len, cap - len, "[");
    for (int k = 0; k < n; k++)
        len += (size_t)snprintf(buf + len, cap - len, "%.17g %.17g %.17g\n", pts[k][0], pts[k][1],
                                pts[k][2]);
    snprintf(buf + len, cap - len, "]\n");
}

static void random_grid(uint32_t *seed, double g[16][3])
{
    for (int k = 0; k < 16; k++)
        for (int d = 0; d < 3; d++)
            g[k][d] = 4.0 * lcg(seed) - 2.0;
}

/* The bases of the RenderMan Interface Specification 3.2 (RiBasis, ri.h's Ri*Basis), as the
 * textbook gives them, rows for (u^3, u^2, u, 1): written here, not taken from basis.c, so that
 * a wrong entry there is caught. Hermite's control points are P0, R0, P1, R1. */
/* clang-format off */
static const double textbook_bezier[16] = {-1, 3, -3, 1,   3, -6, 3, 0,   -3, 3, 0, 0,  1, 0, 0, 0};
static const double textbook_bspline[16] = {-1 / 6.0, 3 / 6.0, -3 / 6.0, 1 / 6.0,
                                             3 / 6.0, -6 / 6.0, 3 / 6.0, 0,
                                            -3 / 6.0, 0,        3 / 6.0, 0,
                                             1 / 6.0, 4 / 6.0,  1 / 6.0, 0};
static const double textbook_catmull_rom[16] = {-1 / 2.0, 3 / 2.0, -3 / 2.0, 1 / 2.0,
                                                 2 / 2.0, -5 / 2.0, 4 / 2.0, -1 / 2.0,
                                                -1 / 2.0, 0,        1 / 2.0, 0,
                                                 0,       2 / 2.0,  0,       0};
static const double textbook_hermite[16] = {2, 1, -2, 1,   -3, -2, 3, -1,   0, 1, 0, 0,  1, 0, 0, 0};
static const double textbook_power[16] = {1, 0, 0, 0,   0, 1, 0, 0,   0, 0, 1, 0,   0, 0, 0, 1};
/* clang-format on */

/* Loads `basis_line` + one bicubic patch of grid g and compares 50 random surface points
 * with the direct evaluation in bases mu, mv (row-major 4x4). */
static void check_basis_patch(const char *basis_line, const double *mu, const double *mv)
{
    uint32_t seed = 12345;
    double g[16][3];
    random_grid(&seed, g);
    char text[4096];
    snprintf(text, sizeof text, "WorldBegin\n%s\nPatch \"bicubic\" \"P\" ", basis_line);
    print_points(text, sizeof text, (const double(*)[3])g, 16);
    strncat(text, "WorldEnd\n", sizeof text - strlen(text) - 1);
    ts_scene s;
    test_parse_rib_ok(text, &s);
    assert_int_equal(s.patch_count, 1);
    for (int k = 0; k < 50; k++) {
        double u = lcg(&seed), v = lcg(&seed), a[3], b[3];
        bezier_eval(&s, 0, u, v, a);
        direct_eval(mu, mv, (const double(*)[3])g, u, v, b);
        assert_dvec(a, b[0], b[1], b[2], 1e-5);
    }
    scene_free(&s);
}

#define BILINEAR_UNIT "Patch \"bilinear\" \"P\" [1 0 0  0 1 0  0 0 1  2 3 4]\n"

/* ---- transformations ------------------------------------------------------------------ */

/* Translate then Rotate: the Rotate, written last, acts on points first. */
static void test_translate_then_rotate(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nTranslate 1 2 3\nRotate 90 0 0 1\n" BILINEAR_UNIT "WorldEnd\n",
                      &s);
    assert_int_equal(s.patch_count, 1);
    assert_vec(&s.cp[0], 1, 3, 3, 1e-6);   /* (1,0,0) -> (0,1,0) -> +(1,2,3) */
    assert_vec(&s.cp[3], 0, 2, 3, 1e-6);   /* (0,1,0) -> (-1,0,0) -> ... */
    assert_vec(&s.cp[12], 1, 2, 4, 1e-6);  /* (0,0,1) unchanged by the rotation */
    assert_vec(&s.cp[15], -2, 4, 7, 1e-6); /* (2,3,4) -> (-3,2,4) -> ... */
    scene_free(&s);
}

/* RenderMan's left-handed sense in coordinates: x -> y about z, y -> z about x,
 * z -> x about y. */
static void test_rotate_convention(void **state)
{
    (void)state;
    static const struct {
        const char *rotate;
        double x, y, z;    /* image of (1,0,0) */
        double ux, uy, uz; /* image of (0,0,1) */
    } cases[] = {
        {"Rotate 90 0 0 1", 0, 1, 0, 0, 0, 1},
        {"Rotate 90 1 0 0", 1, 0, 0, 0, -1, 0},
        {"Rotate 90 0 1 0", 0, 0, -1, 1, 0, 0},
        {"Rotate -90 0 0 2", 0, -1, 0, 0, 0, 1},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        char text[512];
        snprintf(text, sizeof text, "WorldBegin\n%s\n%sWorldEnd\n", cases[k].rotate, BILINEAR_UNIT);
        ts_scene s;
        test_parse_rib_ok(text, &s);
        assert_vec(&s.cp[0], cases[k].x, cases[k].y, cases[k].z, 1e-6);
        assert_vec(&s.cp[12], cases[k].ux, cases[k].uy, cases[k].uz, 1e-6);
        scene_free(&s);
    }
}

/* Skew (RI Spec 3.2 §4.3): points move along the second axis, so that the first axis turns
 * by the angle towards it. */
static void test_skew(void **state)
{
    (void)state;
    static const struct {
        const char *skew;
        double x, y, z; /* image of (1,0,0) */
        double a, b, c; /* image of (2,3,4) */
    } cases[] = {
        /* x += y: (0,1,0) turns 45 degrees towards x */
        {"Skew 45 0 1 0 1 0 0", 1, 0, 0, 5, 3, 4},
        /* x turns 30 degrees towards (0,1,1): (1, k/sqrt2, k/sqrt2), k = tan 30 */
        {"Skew 30 2 0 0 0 1 1", 1, 0.408248290463863, 0.408248290463863, 2, 3.816496580927726,
         4.816496580927726},
        /* a negative angle turns it away: y -= tan(30) x */
        {"Skew -30 1 0 0 0 1 0", 1, -0.5773502691896258, 0, 2, 1.845299461620748, 4},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        char text[512];
        snprintf(text, sizeof text, "WorldBegin\n%s\n%sWorldEnd\n", cases[k].skew, BILINEAR_UNIT);
        ts_scene s;
        test_parse_rib_ok(text, &s);
        assert_vec(&s.cp[0], cases[k].x, cases[k].y, cases[k].z, 1e-6);
        assert_vec(&s.cp[15], cases[k].a, cases[k].b, cases[k].c, 1e-6);
        scene_free(&s);
    }
    /* The image of the first axis makes the angle with it (mat4_skew directly). */
    double d1[3] = {1, 2, 0.5}, d2[3] = {-1, 0.3, 2}, m[16];
    assert_true(mat4_skew(20.0, d1, d2, m));
    double w[3] = {m[0] * d1[0] + m[1] * d1[1] + m[2] * d1[2],
                   m[4] * d1[0] + m[5] * d1[1] + m[6] * d1[2],
                   m[8] * d1[0] + m[9] * d1[1] + m[10] * d1[2]};
    double dot = w[0] * d1[0] + w[1] * d1[1] + w[2] * d1[2];
    double lw = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]),
           l1 = sqrt(d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]);
    assert_float_equal(acos(dot / (lw * l1)) * 180.0 / M_PI, 20.0, 1e-9);
    test_parse_rib_error("Skew 90 1 0 0 0 1 0",
                         "t.rib:1:1: error: Skew 90: the axes must be nonzero and not parallel, "
                         "and the angle less than theirs and more than theirs - 180 degrees");
    test_parse_rib_error("Skew 10 1 0 0 2 0 0",
                         "t.rib:1:1: error: Skew 10: the axes must be nonzero and not parallel, "
                         "and the angle less than theirs and more than theirs - 180 degrees");
    test_parse_rib_error("Skew 10 1 0 0", "t.rib:1:1: error: Skew expects 7 numbers, got 4");
}

static void test_scale_and_matrices(void **state)
{
    (void)state;
    ts_scene s;
    /* Scale then Translate: the translation applies first. */
    test_parse_rib_ok("WorldBegin\nScale 2 3 4\nTranslate 1 1 1\n" BILINEAR_UNIT "WorldEnd\n", &s);
    assert_vec(&s.cp[0], 4, 3, 4, 1e-6);
    scene_free(&s);
    /* RIB matrices are for row vectors: the translation is in elements 12..14. */
    test_parse_rib_ok("WorldBegin\nTranslate 100 0 0\n"
                      "ConcatTransform [1 0 0 0  0 1 0 0  0 0 1 0  5 6 7 1]\n" BILINEAR_UNIT
                      "Transform [2 0 0 0  0 2 0 0  0 0 2 0  0 0 1 1]\n" BILINEAR_UNIT
                      "Identity\n" BILINEAR_UNIT "WorldEnd\n",
                      &s);
    assert_int_equal(s.patch_count, 3);
    assert_vec(&s.cp[0], 106, 6, 7, 1e-6);
    assert_vec(&s.cp[16], 2, 0, 1, 1e-6);
    assert_vec(&s.cp[32], 1, 0, 0, 1e-6);
    scene_free(&s);
}

/* The CTM at WorldBegin becomes world_to_camera and the CTM restarts at the identity. */
static void test_world_to_camera(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("Projection \"perspective\" \"fov\" [45]\nTranslate 0 0 10\nRotate 90 0 1 0\n"
                      "WorldBegin\nTranslate 1 0 0\n" BILINEAR_UNIT "WorldEnd\n",
                      &s);
    const double *m = s.camera.world_to_camera;
    double p[3], q[3] = {1, 0, 0};
    mat_apply(m, q, p);
    assert_dvec(p, 0, 0, 9, 1e-12); /* +x turns to -z, then 10 ahead */
    assert_true(fabs(m[3]) < 1e-12 && fabs(m[7]) < 1e-12 && fabs(m[11] - 10) < 1e-12);
    assert_true(m[12] == 0 && m[13] == 0 && m[14] == 0 && m[15] == 1);
    assert_vec(&s.cp[0], 2, 0, 0, 1e-6); /* world space: no camera transform in it */
    assert_true(s.camera.fov_deg == 45.0);
    assert_int_equal(s.camera.has_format, 0);
    scene_free(&s);
    /* Defaults with no camera at all; a file without WorldBegin is world = camera. */
    test_parse_rib_ok(BILINEAR_UNIT, &s);
    assert_true(s.camera.fov_deg == 90.0);
    for (int k = 0; k < 16; k++)
        assert_true(s.camera.world_to_camera[k] == (k % 5 == 0));
    assert_vec(&s.cp[15], 2, 3, 4, 0);
    scene_free(&s);
}

static void test_format_and_projection(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("Format 640 480 1\nProjection \"perspective\" \"float fov\" [30.5]\n", &s);
    assert_int_equal(s.camera.has_format, 1);
    assert_int_equal(s.camera.width, 640);
    assert_int_equal(s.camera.height, 480);
    assert_true(s.camera.fov_deg == 30.5);
    scene_free(&s);
}

/* ---- attributes and blocks ------------------------------------------------------------ */

static void test_blocks_restore_state(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok(
        "WorldBegin\nColor [0.5 0.25 0.125]\n"
        "AttributeBegin\nColor 1 0 0\nTranslate 5 0 0\nBasis \"b-spline\" 1 \"b-spline\" "
        "1\n" BILINEAR_UNIT "AttributeEnd\n" BILINEAR_UNIT
        "TransformBegin\nColor [0 1 0]\nTranslate 0 7 0\n" BILINEAR_UNIT
        "TransformEnd\n" BILINEAR_UNIT "WorldEnd\n",
        &s);
    assert_int_equal(s.patch_count, 4);
    assert_vec(&s.cp[0], 6, 0, 0, 1e-6);
    assert_true(s.attr[0].cs_r == 1.0f && s.attr[0].cs_g == 0.0f && s.attr[0].cs_b == 0.0f);
    assert_vec(&s.cp[16], 1, 0, 0, 0); /* CTM restored */
    assert_true(s.attr[1].cs_r == 0.5f && s.attr[1].cs_g == 0.25f && s.attr[1].cs_b == 0.125f);
    assert_vec(&s.cp[32], 1, 7, 0, 1e-6);
    assert_true(s.attr[2].cs_g == 1.0f);
    assert_vec(&s.cp[48], 1, 0, 0, 0); /* TransformEnd restores the CTM ... */
    assert_true(s.attr[3].cs_g == 1.0f && s.attr[3].cs_r == 0.0f); /* ... but not Color */
    scene_free(&s);
    /* AttributeEnd restores the basis: this grid must come through unchanged (Bézier). */
    test_parse_rib_ok("AttributeBegin\nBasis \"catmull-rom\" 1 \"catmull-rom\" 1\nAttributeEnd\n"
                      "Patch \"bicubic\" \"P\" [0 0 0 1 0 0 2 0 0 3 0 0  0 1 0 1 1 1 2 1 0 3 1 0\n"
                      "0 2 0 1 2 0 2 2 5 3 2 0  0 3 0 1 3 0 2 3 0 3 3 9]\n",
                      &s);
    assert_vec(&s.cp[5], 1, 1, 1, 0);
    assert_vec(&s.cp[10], 2, 2, 5, 0);
    assert_vec(&s.cp[15], 3, 3, 9, 0);
    scene_free(&s);
}

/* ---- bases and patch kinds ------------------------------------------------------------ */

static void test_basis_conversions(void **state)
{
    (void)state;
    check_basis_patch("Basis \"b-spline\" 1 \"b-spline\" 1", textbook_bspline, textbook_bspline);
    check_basis_patch("Basis \"catmull-rom\" 1 \"catmull-rom\" 1", textbook_catmull_rom,
                      textbook_catmull_rom);
    /* Different u and v bases catch a transposed grid. */
    check_basis_patch("Basis \"catmull-rom\" 1 \"bspline\" 1", textbook_catmull_rom,
                      textbook_bspline);
    check_basis_patch("Basis \"hermite\" 2 \"power\" 4", textbook_hermite, textbook_power);
    check_basis_patch("Basis [-1 3 -3 1 3 -6 3 0 -3 0 3 0 1 4 1 0] 1 \"bezier\" 3",
                      (const double[16]){-1, 3, -3, 1, 3, -6, 3, 0, -3, 0, 3, 0, 1, 4, 1, 0},
                      textbook_bezier);
    /* The named table and steps. */
    assert_ptr_equal(basis_by_name("bspline"), &basis_bspline);
    assert_null(basis_by_name("nurbs"));
    assert_int_equal(basis_bezier.step, 3);
    assert_int_equal(basis_bspline.step, 1);
    assert_int_equal(basis_catmull_rom.step, 1);
    assert_int_equal(basis_hermite.step, 2);
    assert_int_equal(basis_power.step, 4);
}

/* Bilinear patches become bicubic Béziers describing exactly the same surface. */
static void test_bilinear_exact(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("Patch \"bilinear\" \"P\" [0 0 0  3 0 1  0 3 2  3 3 -6]\n", &s);
    uint32_t seed = 7;
    for (int k = 0; k < 50; k++) {
        double u = lcg(&seed), v = lcg(&seed), a[3];
        bezier_eval(&s, 0, u, v, a);
        assert_dvec(a, 3 * u, 3 * v, (1 - u) * v * 2 + u * (1 - v) * 1 + u * v * -6, 1e-6);
    }
    assert_vec(&s.cp[1], 1, 0, 1.0 / 3, 1e-7); /* elevated edge point (1/3, 0) */
    scene_free(&s);
}

static void mesh_count(const char *text, uint32_t want)
{
    ts_scene s;
    test_parse_rib_ok(text, &s);
    assert_int_equal(s.patch_count, want);
    scene_free(&s);
}

static void test_patch_mesh_counts(void **state)
{
    (void)state;
    char text[8192], pts[7000] = "";
    double p[42][3];
    for (int k = 0; k < 42; k++)
        p[k][0] = k % 7, p[k][1] = k / 7, p[k][2] = k * 0.01;
    print_points(pts, sizeof pts, (const double(*)[3])p, 28);
    /* Bézier step 3: nonperiodic 7 -> 2, 4 -> 1; periodic 6 -> 2. */
    snprintf(text, sizeof text,
             "PatchMesh \"bicubic\" 7 \"nonperiodic\" 4 \"nonperiodic\" \"P\" %s", pts);
    mesh_count(text, 2);
    /* B-spline step 1: periodic 7 -> 7, nonperiodic 4 -> 1. */
    snprintf(text, sizeof text,
             "Basis \"b-spline\" 1 \"b-spline\" 1\n"
             "PatchMesh \"bicubic\" 7 \"periodic\" 4 \"nonperiodic\" \"P\" %s",
             pts);
    mesh_count(text, 7);
    snprintf(text, sizeof text,
             "Basis \"b-spline\" 1 \"b-spline\" 1\n"
             "PatchMesh \"bicubic\" 7 \"periodic\" 4 \"periodic\" \"P\" %s",
             pts);
    mesh_count(text, 28);
    /* Bilinear: nonperiodic n - 1, periodic n. */
    snprintf(text, sizeof text,
             "PatchMesh \"bilinear\" 7 \"nonperiodic\" 4 \"nonperiodic\" \"P\" %s", pts);
    mesh_count(text, 18);
    snprintf(text, sizeof text, "PatchMesh \"bilinear\" 7 \"periodic\" 4 \"nonperiodic\" \"P\" %s",
             pts);
    mesh_count(text, 21);
    /* The periodic wrap: the last bilinear patch in u runs from point 6 back to point 0. */
    ts_scene s;
    test_parse_rib_ok(text, &s);
    assert_vec(&s.cp[6 * 16 + 0], 6, 0, 0.06, 1e-6);
    assert_vec(&s.cp[6 * 16 + 3], 0, 0, 0, 1e-6);
    scene_free(&s);
    /* A periodic b-spline mesh matches the direct evaluation on its wrapped patch. */
    snprintf(text, sizeof text,
             "Basis \"b-spline\" 1 \"b-spline\" 1\n"
             "PatchMesh \"bicubic\" 7 \"periodic\" 4 \"nonperiodic\" \"P\" %s",
             pts);
    test_parse_rib_ok(text, &s);
    double g[16][3], a[3], b[3];
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++)
            memcpy(g[j * 4 + i], p[j * 7 + (5 + i) % 7], sizeof g[0]);
    bezier_eval(&s, 5, 0.3, 0.6, a);
    direct_eval(textbook_bspline, textbook_bspline, (const double(*)[3])g, 0.3, 0.6, b);
    assert_dvec(a, b[0], b[1], b[2], 1e-5);
    scene_free(&s);
}

/* Height fields (RI Spec 3.2 §5: "Pz", the points' x and y the mesh's surface parameters):
 * the same patches, bit for bit, as "P" with x = i / (nu - 1) (i / nu along a periodic
 * direction), y likewise, and the heights as z. */
static void test_height_field(void **state)
{
    (void)state;
    char text[8192], zs[2000] = "[", pts[7000] = "";
    double p[20][3];
    for (int k = 0; k < 20; k++) {
        double z = 0.25 * (k % 3) - 0.1 * k;
        snprintf(zs + strlen(zs), sizeof zs - strlen(zs), "%s%.17g", k ? " " : "", z);
        p[k][0] = (k % 5) / 4.0, p[k][1] = (k / 5) / 3.0, p[k][2] = z;
    }
    strcat(zs, "]");
    print_points(pts, sizeof pts, (const double(*)[3])p, 20);
    const char *meshes[][2] = {
        {"PatchMesh \"bilinear\" 5 \"nonperiodic\" 4 \"nonperiodic\"", "12"},
        {"Basis \"b-spline\" 1 \"b-spline\" 1\nPatchMesh \"bicubic\" 5 \"nowrap\" 4 \"nowrap\"",
         "2"},
    };
    for (int m = 0; m < 2; m++) {
        ts_scene a, b;
        snprintf(text, sizeof text, "%s \"Pz\" %s\n", meshes[m][0], zs);
        test_parse_rib_ok(text, &a);
        snprintf(text, sizeof text, "%s \"P\" %s\n", meshes[m][0], pts);
        test_parse_rib_ok(text, &b);
        assert_int_equal(a.patch_count, (uint32_t)atoi(meshes[m][1]));
        assert_int_equal(a.patch_count, b.patch_count);
        assert_memory_equal(a.cp, b.cp, (size_t)16 * a.patch_count * sizeof a.cp[0]);
        scene_free(&a);
        scene_free(&b);
    }
    /* Periodic in u: x = i / nu, the last patch wrapping from x = 4/5 back to 0. */
    ts_scene a;
    snprintf(text, sizeof text, "PatchMesh \"bilinear\" 5 \"periodic\" 4 \"nonperiodic\" \"Pz\" %s",
             zs);
    test_parse_rib_ok(text, &a);
    assert_int_equal(a.patch_count, 15);
    assert_vec(&a.cp[4 * 16 + 0], 0.8, 0, p[4][2], 1e-7);
    assert_vec(&a.cp[4 * 16 + 3], 0, 0, p[0][2], 1e-7);
    scene_free(&a);
    /* A single patch: the four corners (0,0), (1,0), (0,1), (1,1). */
    test_parse_rib_ok("Patch \"bilinear\" \"Pz\" [1 2 3 4]\n", &a);
    assert_vec(&a.cp[0], 0, 0, 1, 0);
    assert_vec(&a.cp[3], 1, 0, 2, 0);
    assert_vec(&a.cp[12], 0, 1, 3, 0);
    assert_vec(&a.cp[15], 1, 1, 4, 0);
    scene_free(&a);
    test_parse_rib_error("Patch \"bilinear\" \"Pz\" [1 2 3]",
                         "t.rib:1:23: error: Patch: parameter \"Pz\" needs 4 values, got 3");
    test_parse_rib_error("Patch \"bilinear\" \"P\" [0 0 0 1 0 0 0 1 0 1 1 0] \"Pz\" [1 2 3 4]",
                         "t.rib:1:48: error: Patch: \"Pz\" after the points were given (one of "
                         "\"P\" or \"Pz\")");
    test_parse_rib_error("Patch \"bilinear\" \"st\" [0 0 1 0 0 1 1 1]",
                         "t.rib:1:1: error: Patch: missing \"P\" (or \"Pz\")");
}

/* ---- lexical details ------------------------------------------------------------------ */

static void test_arrays_comments_escapes(void **state)
{
    (void)state;
    ts_scene s;
    /* Arrays across lines with comments inside; "\120" is an octal 'P', "bi\154inear" an
     * octal 'l'; a backslash-newline continues a string. */
    test_parse_rib_ok("# header comment\nWorldBegin # trailing\nPatch \"bi\\154in\\\near\" # c\n"
                      "  \"\\120\" [ 1 0 0 # first point\n   0 1 0\n\n 0 0 1\n 2 3 4 ] WorldEnd",
                      &s);
    assert_int_equal(s.patch_count, 1);
    assert_vec(&s.cp[15], 2, 3, 4, 0);
    scene_free(&s);
    /* CR LF line ends, also after a continuation backslash. */
    test_parse_rib_ok(
        "WorldBegin\r\nPatch \"bil\\\r\ninear\" \"P\" [1 0 0 0 1 0 0 0 1 2 3 4]\r\nWorldEnd\r\n",
        &s);
    assert_int_equal(s.patch_count, 1);
    scene_free(&s);
    /* \n \t \\ \" decode: the projection name comes back in the message. */
    expect_error("Projection \"x\\ty\\\\z\\\"w\\n\"", TS_E_SCENE,
                 "t.rib:1:12: error: unknown projection \"x?y\\z\"w?\" (perspective, "
                 "PxrPerspective, PxrCamera or orthographic)");
    /* Numbers: signs, leading dots, exponents. */
    test_parse_rib_ok("Patch \"bilinear\" \"P\" [+1 -.5 1e1  2.5E-1 0. -0  1 1 1  0 0 0]\n", &s);
    assert_vec(&s.cp[0], 1, -0.5, 10, 0);
    assert_vec(&s.cp[3], 0.25, 0, 0, 0);
    scene_free(&s);
}

/* ---- lights --------------------------------------------------------------------------- */

static void test_lights(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok(
        "WorldBegin\nTranslate 1 2 3\nLightSource \"distantlight\" 1\n"
        "LightSource \"distantlight\" \"key\" \"intensity\" 2 \"lightcolor\" [1 0.5 0.25]\n"
        "  \"point from\" [0 0 0] \"point to\" [1 0 0]\n"
        "LightSource \"distantlight\" \"from\" [0 5 0] \"to\" [0 0 0]\nWorldEnd\n",
        &s);
    assert_int_equal(s.light_count, 3);
    assert_dvec(s.lights[0].from, 1, 2, 3, 0);
    assert_dvec(s.lights[0].to, 1, 2, 4, 0);
    assert_true(s.lights[0].intensity == 1.0);
    assert_dvec(s.lights[0].color, 1, 1, 1, 0);
    assert_true(s.lights[1].intensity == 2.0);
    assert_dvec(s.lights[1].color, 1, 0.5, 0.25, 0);
    assert_dvec(s.lights[1].to, 2, 2, 3, 0);
    assert_dvec(s.lights[2].from, 1, 7, 3, 0);
    scene_free(&s);
    /* Before WorldBegin a light is in camera space and is moved to world space. */
    test_parse_rib_ok("LightSource \"distantlight\" 1 \"from\" [0 0 0] \"to\" [0 0 1]\n"
                      "Translate 0 0 5\nRotate 90 0 1 0\nWorldBegin\nWorldEnd\n",
                      &s);
    assert_dvec(s.lights[0].from, 5, 0, 0, 1e-12); /* camera origin in world space */
    assert_dvec(s.lights[0].to, 4, 0, 0, 1e-12);
    scene_free(&s);
}

/* ---- the scene files ------------------------------------------------------------------ */

/* Asserts that every control point lies in front of the camera and inside the image. */
/* scene_patch_box is the control points' box grown by a few ulps of its magnitude (it must
 * hold the rounded diced vertices): within 1e-5 of the expected bounds (relative to the
 * largest of them), never inside them.
 * NAN skips a bound. */
static void assert_box(ts_box b, float lx, float ly, float lz, float hx, float hy, float hz)
{
    const float got[6] = {b.lo_x, b.lo_y, b.lo_z, b.hi_x, b.hi_y, b.hi_z},
                want[6] = {lx, ly, lz, hx, hy, hz};
    float mag = 1.0f;
    for (int i = 0; i < 6; ++i)
        if (!isnan(want[i])) mag = fmaxf(mag, fabsf(want[i]));
    for (int i = 0; i < 6; ++i) {
        if (isnan(want[i])) continue;
        float grown = i < 3 ? want[i] - got[i] : got[i] - want[i];
        if (!(grown >= 0.0f && grown < 1e-5f * mag))
            fail_msg("box bound %d is %.9g, expected %.9g (grown by less than 1e-5)", i, got[i],
                     want[i]);
    }
}

static void assert_framed(const ts_scene *s, double margin)
{
    double t = tan(0.5 * s->camera.fov_deg * M_PI / 180.0);
    double ax = (double)s->camera.width / s->camera.height;
    for (uint32_t k = 0; k < s->patch_count * 16; k++) {
        double w[3] = {s->cp[k].x, s->cp[k].y, s->cp[k].z}, c[3];
        mat_apply(s->camera.world_to_camera, w, c);
        assert_true(c[2] > 0.0);
        assert_true(fabs(c[0] / c[2]) < margin * t * ax);
        assert_true(fabs(c[1] / c[2]) < margin * t);
    }
}

static void test_teapot_file(void **state)
{
    (void)state;
    ts_scene s;
    ts_error e;
    memset(&s, 0, sizeof s);
    memset(&e, 0, sizeof e);
    const char *path = test_source_path("scene/teapot.rib");
    if (rib_load(path, &s, 1, &e) != TS_OK) fail_msg("%s", e.msg);
    assert_int_equal(s.patch_count, 32);
    assert_vec(&s.cp[0], 1.4f, 0.0f, 2.4f, 0); /* no object transform: exactly the data */
    assert_true(s.cp[0].x == 1.4f && s.cp[0].z == 2.4f && s.cp[0].w == 1.0f);
    for (int k = 0; k < 4; k++) {
        assert_vec(&s.cp[20 * 16 + k], 0, 0, 3.15f, 0); /* lid apex row, degenerate */
        assert_vec(&s.cp[28 * 16 + k], 0, 0, 0, 0);     /* bottom centre row */
    }
    assert_true(s.attr[31].cs_r == 0.8f && s.attr[31].cs_g == 0.55f && s.attr[31].cs_b == 0.35f);
    assert_int_equal(s.camera.width, 1280);
    assert_int_equal(s.camera.height, 720);
    assert_true(s.camera.fov_deg >= 30.0 && s.camera.fov_deg <= 35.0);
    assert_framed(&s, 0.9);
    /* Upright: world +z is camera +y; the light falls downwards, away from the camera. */
    const double *m = s.camera.world_to_camera;
    assert_true(m[6] > 0.9);
    assert_int_equal(s.light_count, 1);
    double d[3], dc[3], o[3] = {0, 0, 0}, oc[3];
    for (int k = 0; k < 3; k++)
        d[k] = s.lights[0].to[k] - s.lights[0].from[k];
    mat_apply(m, d, dc);
    mat_apply(m, o, oc);
    for (int k = 0; k < 3; k++)
        dc[k] -= oc[k];
    assert_true(d[2] < 0.0);                                /* from above in world */
    assert_true(dc[0] > 0.0 && dc[1] < 0.0 && dc[2] > 0.0); /* from upper left front */
    scene_free(&s);
}

static void test_one_patch_file(void **state)
{
    (void)state;
    ts_scene s;
    ts_error e;
    memset(&s, 0, sizeof s);
    memset(&e, 0, sizeof e);
    if (rib_load(test_source_path("scene/one_patch.rib"), &s, 1, &e) != TS_OK)
        fail_msg("%s", e.msg);
    assert_int_equal(s.patch_count, 1);
    assert_int_equal(s.light_count, 1);
    assert_framed(&s, 1.0);
    ts_box b = scene_patch_box(&s, 0);
    assert_box(b, -1.5f, NAN, -0.5f, 1.5f, NAN, 0.0f);
    scene_free(&s);
}

/* ---- errors: exact positions and codes ------------------------------------------------ */

/* One case per error path: the input and the exact message (a "..." end: a prefix). */
static const struct {
    const char *text, *msg;
} error_cases[] = {
    {"Patch \"bicubic\" \"P\" [0 0 0]",
     "t.rib:1:21: error: Patch: parameter \"P\" needs 48 values, got 3"},
    {"WorldBegin\n  AttributeEnd\n",
     "t.rib:2:3: error: AttributeEnd without a matching AttributeBegin"},
    {"TransformBegin\nAttributeEnd\n",
     "t.rib:2:1: error: AttributeEnd does not match the TransformBegin at 1:1"},
    {"WorldBegin\nAttributeBegin\n",
     "t.rib:2:1: error: AttributeBegin is never closed (missing AttributeEnd)"},
    {"WorldBegin\n", "t.rib:1:1: error: WorldBegin is never closed (missing WorldEnd)"},
    {"Display \"x\" \"file\n", "t.rib:1:13: error: unterminated string"},
    {"Color [1 0\n 0\n",
     "t.rib:1:7: error: unterminated array ('[' without ']' before the end of file)"},
    {"Color [1 0 0\nWorldBegin",
     "t.rib:1:7: error: unterminated array ('[' without ']' before WorldBegin at 2:1)"},
    {"  WorldEnd\n", "t.rib:1:3: error: WorldEnd without WorldBegin"},
    {"Patch \"bicubic\" \"Pw\" [0]",
     "t.rib:1:17: error: Patch: rational patches (\"Pw\") are not supported; give \"P\""},
    {"\nNuPatch 4 4 [0 0 0 0 1 1 1 1]", "t.rib:2:1: error: NuPatch expects 2 numbers, got 0"},
    {"Frobnicate 1", "t.rib:1:1: error: unknown request Frobnicate"},
    {"Blobby 1 [8]", "t.rib:1:1: error: Blobby: expected nleaf [code] [floats] [strings]"},
    {"WorldBegin\nBlobby 1 [1001 0 8 1 0] [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1] [\"\"]",
     "t.rib:2:10: error: Blobby: instruction 1 (code[2]): unknown opcode 8"},
    {"WorldBegin\nBlobby 1 [1003 0 0] [] [\"a.z\"]",
     "t.rib:2:10: error: Blobby: instruction 0 (code[0]): a repelling plane (opcode 1003) is not "
     "supported"},
    {"Perspective 30", "t.rib:1:1: error: Perspective is not supported"},
    {"TrimCurve [1]", "t.rib:1:1: error: TrimCurve: missing order (an array of integers)"},
    {"Translate 1 2", "t.rib:1:1: error: Translate expects 3 numbers, got 2"},
    {"Translate 1 2 3 4", "t.rib:1:17: error: too many arguments to Translate"},
    {"Rotate 10 0 0 0", "t.rib:1:1: error: Rotate about a zero-length axis"},
    {"Translate 1.2.3 0 0", "t.rib:1:11: error: malformed number"},
    {"Translate 1e999 0 0", "t.rib:1:11: error: number out of range"},
    {"Color [[1 1 1]]", "t.rib:1:8: error: nested arrays are not allowed"},
    {"Color [1 \"a\" 1]", "t.rib:1:10: error: array mixes numbers and strings"},
    {"Color 1 1 1 ]", "t.rib:1:13: error: ']' without '['"},
    {"1 2 3", "t.rib:1:1: error: expected a request name, found a number"},
    {"Color \x81",
     "t.rib:byte 6: error: binary RIB: an integer (byte 0201) needs 2 more bytes, only 0 are "
     "left (a truncated file)"},
    {"Display \"a\\q\"", "t.rib:1:12: error: unknown escape sequence '\\q'"},
    {"Basis \"nurbs\" 1 \"bezier\" 3", "t.rib:1:7: error: unknown basis ..."},
    {"PatchMesh \"bicubic\" 5 \"nonperiodic\" 4 \"nonperiodic\" \"P\" [0]",
     "t.rib:1:21: error: PatchMesh: nonperiodic nu = 5 is not 4 + k * 3 (the u step)"},
    {"WorldBegin WorldEnd WorldBegin",
     "t.rib:1:21: error: a second WorldBegin: only one world block per file is supported"},
    {"WorldBegin\nFormat 10 10 1\n", "t.rib:2:1: error: Format must come before WorldBegin"},
    {"Projection \"perspective\" \"fov\" [180]",
     "t.rib:1:32: error: fov must be between 0 and 180 degrees, got 180"},
    /* Displacement */
    {"Displacement \"fbm\" \"octaves\" 17",
     "t.rib:1:30: error: Displacement: octaves must be between 1 and 16, got 17"},
    {"Displacement \"ridged\" \"float octaves\" [0.4]",
     "t.rib:1:39: error: Displacement: octaves must be between 1 and 16, got 0.4"},
    {"Displacement \"fbm\" \"frequency\" [0]",
     "t.rib:1:32: error: Displacement: frequency must be positive, got 0"},
    {"Displacement \"fbm\"\n  \"lacunarity\" -2",
     "t.rib:2:16: error: Displacement: lacunarity must be positive, got -2"},
    {"Displacement \"fbm\" \"amplitude\" [1 2]",
     "t.rib:1:32: error: Displacement: parameter \"amplitude\" needs 1 values, got 2"},
    {"Displacement \"fbm\" \"gain\" \"x\"",
     "t.rib:1:27: error: Displacement: parameter \"gain\" needs numbers"},
    {"Displacement 1", "t.rib:1:14: error: Displacement: expected a displacement name (a string)"},
    /* "N" */
    {"Patch \"bilinear\" \"P\" [0 0 0 1 0 0 0 1 0 1 1 0] \"N\" [0 0 1]",
     "t.rib:1:52: error: Patch: parameter \"N\" needs 12 values, got 3"},
    {"Patch \"bilinear\" \"P\" [0 0 0 1 0 0 0 1 0 1 1 0] \"N\" [0 0 1 0 0 1 0 0 0 0 0 1]",
     "t.rib:1:52: error: Patch: normal 2 of \"N\" is zero"},
    {"PatchMesh \"bilinear\" 3 \"nonperiodic\" 2 \"nonperiodic\" \"P\" [0 0 0 1 0 0 2 0 0 0 1 0 1 "
     "1 0 2 1 0] \"N\" [0 0 1 0 0 1 0 0 1 0 0 1]",
     "t.rib:1:100: error: PatchMesh: parameter \"N\" needs 18 values, got 12"},
    /* motion blocks */
    {"WorldBegin\n MotionEnd\nWorldEnd", "t.rib:2:2: error: MotionEnd without MotionBegin"},
    {"MotionBegin [0 1]\nMotionBegin [0 1]",
     "t.rib:2:1: error: MotionBegin inside the motion block at 1:1"},
    {"MotionBegin [0 1]\nColor 1 0 0",
     "t.rib:2:1: error: Color is not allowed in the motion block at 1:1 (only Patch, PatchMesh, "
     "SubdivisionMesh, NuPatch, polygons, quadrics, Points, Curves, Translate, Rotate, Scale, "
     "ConcatTransform "
     "or Transform)"},
    {"MotionBegin [0 1]\nAttributeBegin",
     "t.rib:2:1: error: AttributeBegin is not allowed in the motion block at 1:1 ..."},
    {"MotionBegin [0 1]\nTranslate 1 0 0\n  Rotate 90 0 0 1\nMotionEnd",
     "t.rib:3:3: error: Rotate does not match the Translate at 2:1 in the motion block"},
    {"MotionBegin [0 1]\n" BILINEAR_UNIT "Translate 1 0 0\nMotionEnd",
     "t.rib:3:1: error: Translate does not match the Patch at 2:1 in the motion block"},
    {"MotionBegin [0 1]\nScale 1 1 1\nScale 2 2 2\nScale 3 3 3\nMotionEnd",
     "t.rib:4:1: error: Scale: the motion block at 1:1 already has its 2 samples"},
    {"MotionBegin [0 1]\nTranslate 1 0 0\nMotionEnd",
     "t.rib:3:1: error: MotionEnd: the motion block at 1:1 has 1 sample for 2 times"},
    {"MotionBegin [0 1]\nMotionEnd",
     "t.rib:2:1: error: MotionEnd: the motion block at 1:1 has 0 samples for 2 times"},
    {"WorldBegin\nMotionBegin [0 1]\nTranslate 1 0 0\n",
     "t.rib:2:1: error: MotionBegin is never closed (missing MotionEnd)"},
    {"MotionBegin [0 0.5 1]",
     "t.rib:1:13: error: MotionBegin: exactly 2 times are supported, got 3"},
    {"MotionBegin [1 0]", "t.rib:1:13: error: MotionBegin: the times must increase, got 1 0"},
    {"MotionBegin", "t.rib:1:1: error: MotionBegin expects 2 numbers, got 0"},
    /* A moving camera is read (test_rib_requests.c); its shutter-close sample must be
     * invertible too. */
    {"MotionBegin [0 1]\nScale 1 1 1\nScale 0 1 1\nMotionEnd\nWorldBegin",
     "t.rib:5:1: error: the camera transform is singular"},
    {"MotionBegin [0 1]\nPatch \"bicubic\" \"P\" [0]",
     "t.rib:2:21: error: Patch: parameter \"P\" needs 48 values, got 1"},
};

/* A singular CTM where the surface needs the inverse ("N", noise displacement): RenderMan
 * draws what the transformation makes of the surface, so Tessera draws it flattened, without
 * its "N" and its noise displacement, or nothing where no area is left (Scale 0 0 0), with a
 * warning; with --strict it is the error. */
static void test_singular_transform(void **state)
{
    (void)state;
    const char *flat =
        "WorldBegin\nDisplacement \"fbm\"\nScale 1 1 0\n"
        "Patch \"bilinear\" \"P\" [0 0 0 1 0 0 0 1 1 1 1 1] \"N\" [0 0 1 0 0 1 0 0 1 "
        "0 0 1]\nWorldEnd\n";
    int rc;
    const char *w = test_rib_warnings(flat, &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(w, "w.rib:4:1: warning: Patch: the current transformation is singular: "
                           "the surface is drawn flattened, with its own normals and no noise "
                           "displacement (--strict makes this an error)\n");
    ts_scene s, ref;
    ts_error e = {0};
    assert_int_equal(test_parse_rib(flat, &s, &e), TS_OK);
    test_parse_rib_ok("WorldBegin\nPatch \"bilinear\" \"P\" [0 0 0 1 0 0 0 1 0 1 1 0]\nWorldEnd\n",
                      &ref);
    assert_int_equal(s.patch_count, 1);
    assert_memory_equal(s.cp, ref.cp, 16 * sizeof s.cp[0]);
    assert_int_equal(s.attr[0].disp_kind, TS_DISP_NONE);
    scene_free(&s);
    scene_free(&ref);
    assert_int_equal(test_parse_rib_strict(flat, &s, &e), TS_E_SCENE);
    assert_string_equal(e.msg, "t.rib:4:1: error: Patch: the current transformation is singular; "
                               "\"N\" needs an invertible one");
    ts_error_clear(&e);
    assert_int_equal(
        test_parse_rib_strict("Displacement \"fbm\"\nScale 0 1 1\n" BILINEAR_UNIT, &s, &e),
        TS_E_SCENE);
    assert_string_equal(e.msg, "t.rib:3:1: error: Patch: the current transformation is singular; "
                               "Displacement needs an invertible one");
    ts_error_clear(&e);
    /* No area left: nothing drawn, the rest of the scene is. */
    const char *point =
        "WorldBegin\nAttributeBegin\nDisplacement \"fbm\"\nScale 0 0 0\n" BILINEAR_UNIT
        "AttributeEnd\n" BILINEAR_UNIT "WorldEnd\n";
    w = test_rib_warnings(point, &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(w, "w.rib:5:1: warning: Patch: the current transformation is singular "
                           "and leaves the surface no area: nothing drawn (--strict makes this "
                           "an error)\n");
    assert_int_equal(test_parse_rib(point, &s, &e), TS_OK);
    assert_int_equal(s.patch_count, 1);
    scene_free(&s);
}

static void test_errors(void **state)
{
    (void)state;
    for (size_t k = 0; k < sizeof error_cases / sizeof error_cases[0]; k++)
        expect_error(error_cases[k].text, TS_E_SCENE, error_cases[k].msg);
}

/* Two Patch samples of different types. */
static void test_motion_patch_types(void **state)
{
    (void)state;
    char text[2048] = "MotionBegin [0 1]\n" BILINEAR_UNIT "Patch \"bicubic\" \"P\" [";
    for (int k = 0; k < 48; k++)
        strcat(text, "0 ");
    strcat(text, "]\nMotionEnd\n");
    expect_error(text, TS_E_SCENE,
                 "t.rib:3:7: error: Patch: type bicubic does not match the bilinear Patch at 2:1 "
                 "in the motion block");
}

/* Errors whose input is generated: 47 of 48 numbers, a long string, deep nesting. */
static void test_errors_generated(void **state)
{
    (void)state;
    char text[2048] = "WorldBegin\nPatch \"bicubic\"\n  \"P\" [";
    for (int k = 0; k < 47; k++)
        strcat(text, "1 ");
    strcat(text, "]\nWorldEnd\n");
    expect_error(text, TS_E_SCENE,
                 "t.rib:3:7: error: Patch: parameter \"P\" needs 48 values, got 47");
    /* Strings echoed in messages are printable and cut short. */
    char longtype[160], want[200];
    snprintf(longtype, sizeof longtype, "Patch \"%060d\"", 7);
    snprintf(want, sizeof want,
             "t.rib:1:7: error: Patch: unknown patch type \"%044d...\" (bicubic or bilinear)", 0);
    expect_error(longtype, TS_E_SCENE, want);
    /* Nesting is bounded. */
    char *deep = calloc(1100 * 15 + 1, 1);
    assert_non_null(deep);
    for (int k = 0; k < 1100; k++)
        strcat(deep, "AttributeBegin\n");
    expect_error(deep, TS_E_SCENE,
                 "t.rib:1025:1: error: AttributeBegin nested deeper than 1024 levels");
    free(deep);
}

/* A missing file is an I/O error naming the path. */
static void test_error_missing_file(void **state)
{
    (void)state;
    ts_scene s;
    ts_error e;
    memset(&s, 0, sizeof s);
    memset(&e, 0, sizeof e);
    assert_int_equal(rib_load("/nonexistent/dir/x.rib", &s, 1, &e), TS_E_IO);
    assert_int_equal(e.code, TS_E_IO);
    assert_string_equal(e.msg, "/nonexistent/dir/x.rib: No such file or directory");
}

/* Ignored requests: accepted, one warning per request name. */
static void test_ignored_requests_warn_once(void **state)
{
    (void)state;
    const char *text = "Atmosphere \"fog\"\nAtmosphere \"fog\"\n  Sides 2\nOption \"a\" \"b\" [1]\n"
                       "WorldBegin\nWorldEnd\n";
    int rc = -1;
    const char *out = test_rib_warnings(text, &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "w.rib:1:1: warning: Atmosphere is ignored\n"
                             "w.rib:3:3: warning: Sides is ignored\n"
                             "w.rib:4:1: warning: Option \"a\" is ignored\n");
}

/* Hostile input: truncations and byte flips of the teapot file must load or fail cleanly
 * (run under ASan/valgrind this also checks bounds and leaks). */
static void test_hostile_input(void **state)
{
    (void)state;
    FILE *f = fopen(test_source_path("scene/teapot.rib"), "rb");
    assert_non_null(f);
    static char text[65536];
    size_t len = fread(text, 1, sizeof text, f);
    fclose(f);
    assert_true(len > 1000 && len < sizeof text);
    uint32_t seed = 99;
    for (size_t cut = 0; cut < len; cut += 97) {
        ts_scene s = {0};
        ts_error e = {0};
        int rc = rib_parse_string("cut.rib", text, cut, &s, 1, &e);
        assert_true(rc == TS_OK || rc == TS_E_SCENE);
        if (rc != TS_OK) assert_true(s.patch_count == 0 && strncmp(e.msg, "cut.rib:", 8) == 0);
        scene_free(&s);
    }
    for (int k = 0; k < 300; k++) {
        static char mutated[65536];
        memcpy(mutated, text, len);
        for (int f2 = 0; f2 < 4; f2++)
            mutated[(size_t)(lcg(&seed) * len)] = (char)(lcg(&seed) * 256);
        ts_scene s = {0};
        ts_error e = {0};
        int rc = rib_parse_string("m.rib", mutated, len, &s, 1, &e);
        assert_true(rc == TS_OK || rc == TS_E_SCENE);
        scene_free(&s);
    }
}

/* ---- Displacement, "N", motion blocks --------------------------------------------------- */

/* World point w through patch p's world-to-object transform. */
static void xform_apply(const ts_scene *s, uint32_t p, const ts_vec4 *w, double out[3])
{
    const ts_xform *x = &s->xform[s->attr[p].xform];
    const float *r[3] = {x->r0, x->r1, x->r2};
    for (int i = 0; i < 3; i++)
        out[i] = (double)r[i][0] * w->x + (double)r[i][1] * w->y + (double)r[i][2] * w->z + r[i][3];
}

static void assert_disp(const ts_patch_attr *a, uint32_t kind, float amp, float freq, uint32_t oct,
                        float lac, float gain)
{
    assert_int_equal(a->disp_kind, kind);
    if (kind == TS_DISP_NONE) return;
    if (a->disp_amplitude != amp || a->disp_frequency != freq || a->disp_octaves != oct ||
        a->disp_lacunarity != lac || a->disp_gain != gain)
        fail_msg("got %g %g %u %g %g, want %g %g %u %g %g", a->disp_amplitude, a->disp_frequency,
                 a->disp_octaves, a->disp_lacunarity, a->disp_gain, amp, freq, oct, lac, gain);
}

/* Displacement is an attribute: parameters (typed or not) and defaults, saved by
 * AttributeBegin, off with "null", "" or amplitude 0; the world-to-object transform is the
 * inverse of the CTM at each Patch. */
static void test_displacement(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok(
        "WorldBegin\n"
        "Displacement \"fbm\" \"float amplitude\" [0.2] \"frequency\" [3] \"octaves\" 5.4\n"
        "  \"uniform float lacunarity\" [2.5] \"gain\" 0.4\n"
        "Scale 2 2 2\nTranslate 1 0 0\n" BILINEAR_UNIT
        "AttributeBegin\nDisplacement \"ridged\" \"amplitude\" 0.05\n" BILINEAR_UNIT
        "Displacement \"null\"\n" BILINEAR_UNIT "AttributeEnd\n" BILINEAR_UNIT
        "Displacement \"\"\n" BILINEAR_UNIT "Translate 0 0 1\nDisplacement \"fbm\"\n" BILINEAR_UNIT
        "Displacement \"ridged\" \"amplitude\" [0]\n" BILINEAR_UNIT "WorldEnd\n",
        &s);
    assert_int_equal(s.patch_count, 7);
    assert_disp(&s.attr[0], TS_DISP_FBM, 0.2f, 3.0f, 5, 2.5f, 0.4f);
    assert_disp(&s.attr[1], TS_DISP_RIDGED, 0.05f, 1.0f, 4, 2.0f, 0.5f); /* defaults */
    assert_disp(&s.attr[2], TS_DISP_NONE, 0, 0, 0, 0, 0);
    assert_disp(&s.attr[3], TS_DISP_FBM, 0.2f, 3.0f, 5, 2.5f, 0.4f); /* restored */
    assert_disp(&s.attr[4], TS_DISP_NONE, 0, 0, 0, 0, 0);
    assert_disp(&s.attr[5], TS_DISP_FBM, 0.1f, 1.0f, 4, 2.0f, 0.5f); /* all defaults */
    assert_disp(&s.attr[6], TS_DISP_NONE, 0, 0, 0, 0, 0);
    /* World (4,0,0) = Scale 2 (Translate 1 (1,0,0)) goes back to the object point (1,0,0). */
    assert_true(s.attr[0].xform != 0);
    assert_int_equal(s.attr[3].xform, s.attr[0].xform); /* same CTM: one transform */
    assert_int_equal(s.attr[1].xform, s.attr[0].xform);
    assert_int_equal(s.attr[4].xform, 0);
    const ts_xform *x = &s.xform[s.attr[0].xform];
    assert_true(x->r0[0] == 0.5f && x->r0[1] == 0 && x->r0[3] == -1.0f && x->r1[1] == 0.5f &&
                x->r1[3] == 0 && x->r2[2] == 0.5f && x->r2[3] == 0);
    assert_true(s.attr[5].xform != s.attr[0].xform && s.attr[5].xform != 0);
    for (uint32_t p = 0; p < 7; p += 5) {
        static const double obj[4][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {2, 3, 4}};
        static const int cpk[4] = {0, 3, 12, 15};
        for (int c = 0; c < 4; c++) {
            double o[3];
            xform_apply(&s, p, &s.cp[p * 16 + cpk[c]], o);
            assert_dvec(o, obj[c][0], obj[c][1], obj[c][2], 1e-6);
        }
    }
    /* rib_parse_string finalised the scene: unit corner normals, marked final. */
    assert_true(s.xform_count == 3);
    for (uint32_t k = 0; k < 7 * 4; k++)
        assert_true(s.corner_n[k].w == 0.0f &&
                    fabs(s.corner_n[k].x * s.corner_n[k].x + s.corner_n[k].y * s.corner_n[k].y +
                         s.corner_n[k].z * s.corner_n[k].z - 1.0) < 1e-6);
    scene_free(&s);
    /* Before WorldBegin the CTM ends in camera space: the transform (and the points) are
     * moved to world space at WorldBegin. */
    test_parse_rib_ok("Rotate 90 0 0 1\nDisplacement \"fbm\"\n" BILINEAR_UNIT
                      "Identity\nTranslate 0 0 5\nRotate 90 0 1 0\nWorldBegin\nWorldEnd\n",
                      &s);
    static const double obj[4][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {2, 3, 4}};
    static const int cpk[4] = {0, 3, 12, 15};
    for (int c = 0; c < 4; c++) {
        double o[3];
        xform_apply(&s, 0, &s.cp[cpk[c]], o);
        assert_dvec(o, obj[c][0], obj[c][1], obj[c][2], 1e-5);
    }
    assert_vec(&s.cp[0], 5, 1, 0, 1e-6); /* (1,0,0) -> (0,1,0) in camera -> world */
    scene_free(&s);
}

/* A varying "N" gives the corner normals, by the inverse transpose of the CTM. */
static void test_explicit_normals(void **state)
{
    (void)state;
    ts_scene s;
    const double a = 1 / sqrt(5.0);
    /* Rotate (written first) acts after Scale: n' = R S^-1 n. (1,1,0) -> (0.5,1,0) ->
     * (-1,0.5,0). The second patch shares corners with the first and has no "N": it is
     * averaged on its own and does not change the first's. */
    test_parse_rib_ok(
        "WorldBegin\nRotate 90 0 0 1\nScale 2 1 1\n"
        "Patch \"bilinear\" \"P\" [0 0 0 1 0 0 0 1 0 1 1 1] \"N\" [1 1 0  0 0 3  1 0 0  0 1 0]\n"
        "Patch \"bilinear\" \"P\" [0 0 0 1 0 0 0 1 0 1 1 1]\n"
        "Patch \"bicubic\" \"P\" [0 0 0 1 0 0 2 0 0 3 0 0  0 1 0 1 1 0 2 1 0 3 1 0\n"
        "  0 2 0 1 2 0 2 2 0 3 2 0  0 3 0 1 3 0 2 3 0 3 3 0] \"varying normal N\" [0 0 1 0 0 1 1 0 "
        "1 0 0 -1]\n"
        "WorldEnd\n",
        &s);
    assert_int_equal(s.patch_count, 3);
    assert_vec(&s.corner_n[0], -2 * a, a, 0, 1e-7);
    assert_vec(&s.corner_n[1], 0, 0, 1, 1e-7);
    assert_vec(&s.corner_n[2], 0, 1, 0, 1e-7); /* (1,0,0) -> (0.5,0,0) -> (0,0.5,0) */
    assert_vec(&s.corner_n[3], -1, 0, 0, 1e-7);
    for (int k = 0; k < 4; k++)
        assert_true(s.corner_n[k].w == 0.0f);
    assert_vec(&s.corner_n[8 + 2], 0, a, 2 * a, 1e-7); /* (1,0,1) -> (0.5,0,1) -> (0,0.5,1) */
    assert_vec(&s.corner_n[8 + 3], 0, 0, -1, 1e-7);
    scene_free(&s);
}

/* PatchMesh "N": one normal per corner of the patch grid, wrapping in periodic directions. */
static void mesh_normals(const char *head, int npts, int nn, const int *want, int npatch)
{
    char text[4096], pts[2048] = "", nrm[1024] = "";
    double p[16][3], n[16][3];
    for (int k = 0; k < 16; k++) {
        p[k][0] = k % 4, p[k][1] = k / 4, p[k][2] = 0.1 * k;
        n[k][0] = k + 1, n[k][1] = 0, n[k][2] = 1; /* normal k: x/z = k + 1 */
    }
    print_points(pts, sizeof pts, (const double(*)[3])p, npts);
    print_points(nrm, sizeof nrm, (const double(*)[3])n, nn);
    snprintf(text, sizeof text, "%s \"P\" %s \"N\" %s", head, pts, nrm);
    ts_scene s;
    test_parse_rib_ok(text, &s);
    assert_int_equal(s.patch_count, npatch);
    for (int k = 0; k < npatch * 4; k++) {
        const ts_vec4 *c = &s.corner_n[k];
        double got = c->x / c->z;
        if (fabs(got - (want[k] + 1)) > 1e-5)
            fail_msg("%s: corner %d of patch %d has normal %g, want %d", head, k % 4, k / 4,
                     got - 1, want[k]);
    }
    scene_free(&s);
}

static void test_mesh_normals(void **state)
{
    (void)state;
    /* Bilinear 4 x 4 nonperiodic: 3 x 3 patches, 4 x 4 normals. */
    mesh_normals("PatchMesh \"bilinear\" 4 \"nonperiodic\" 4 \"nonperiodic\"", 16, 16,
                 (const int[]){0, 1,  4, 5, 1,  2,  5, 6, 2,  3,  6, 7,  4,  5,  8,  9,  5,  6,
                               9, 10, 6, 7, 10, 11, 8, 9, 12, 13, 9, 10, 13, 14, 10, 11, 14, 15},
                 9);
    /* Bilinear periodic in u: 4 patches per row, the last wraps to column 0. */
    mesh_normals("PatchMesh \"bilinear\" 4 \"periodic\" 2 \"nonperiodic\"", 8, 8,
                 (const int[]){0, 1, 4, 5, 1, 2, 5, 6, 2, 3, 6, 7, 3, 0, 7, 4}, 4);
    /* Bézier 4 x 4: one patch, 2 x 2 normals. */
    mesh_normals("PatchMesh \"bicubic\" 4 \"nonperiodic\" 4 \"nonperiodic\"", 16, 4,
                 (const int[]){0, 1, 2, 3}, 1);
    /* B-spline periodic in u (4 patches, 4 normals per row), nonperiodic in v (1 patch, 2
     * rows of normals). */
    mesh_normals("Basis \"b-spline\" 1 \"b-spline\" 1\n"
                 "PatchMesh \"bicubic\" 4 \"periodic\" 4 \"nonperiodic\"",
                 16, 8, (const int[]){0, 1, 4, 5, 1, 2, 5, 6, 2, 3, 6, 7, 3, 0, 7, 4}, 4);
    /* Catmull-Rom periodic in both: 4 x 4 patches, 4 x 4 normals. */
    mesh_normals("Basis \"catmull-rom\" 1 \"catmull-rom\" 1\n"
                 "PatchMesh \"bicubic\" 4 \"periodic\" 4 \"periodic\"",
                 16, 16,
                 (const int[]){0,  1,  4,  5,  1,  2,  5,  6,  2,  3,  6,  7,  3,  0,  7,  4,
                               4,  5,  8,  9,  5,  6,  9,  10, 6,  7,  10, 11, 7,  4,  11, 8,
                               8,  9,  12, 13, 9,  10, 13, 14, 10, 11, 14, 15, 11, 8,  15, 12,
                               12, 13, 0,  1,  13, 14, 1,  2,  14, 15, 2,  3,  15, 12, 3,  0},
                 16);
}

/* Moving patches: two Patch samples, or a CTM with two samples, in MotionBegin/MotionEnd. */
static void test_motion(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok(
        "WorldBegin\n" BILINEAR_UNIT "MotionBegin [0 1]\n"
        "Patch \"bilinear\" \"P\" [0 0 0 1 0 0 0 1 0 1 1 0] \"N\" [0 0 1 0 0 1 0 0 1 0 0 1]\n"
        "Patch \"bilinear\" \"P\" [0 0 1 1 0 1 0 1 1 1 1 2]\nMotionEnd\n" BILINEAR_UNIT
        "WorldEnd\n",
        &s);
    assert_int_equal(s.patch_count, 3);
    assert_non_null(s.cp1);
    assert_int_equal(s.attr[0].flags, 0);
    assert_int_equal(s.attr[1].flags, TS_PATCH_MOVING);
    assert_int_equal(s.attr[2].flags, 0);
    assert_vec(&s.cp[16 + 15], 1, 1, 0, 0);
    assert_vec(&s.cp1[16 + 15], 1, 1, 2, 0);
    assert_vec(&s.cp1[16], 0, 0, 1, 0);
    assert_true(memcmp(s.cp1, s.cp, 16 * sizeof(ts_vec4)) == 0);
    assert_true(memcmp(s.cp1 + 32, s.cp + 32, 16 * sizeof(ts_vec4)) == 0);
    assert_vec(&s.corner_n[4], 0, 0, 1, 0); /* "N" of the first sample */
    ts_box b = scene_patch_box(&s, 1);
    assert_box(b, NAN, NAN, 0.0f, NAN, NAN, 2.0f);
    scene_free(&s);
    /* A moving CTM: every patch under it moves; blocks save and restore both samples. */
    test_parse_rib_ok(
        "WorldBegin\nAttributeBegin\nMotionBegin [0 1]\nTranslate 0 0 0\nTranslate 5 0 0\n"
        "MotionEnd\n" BILINEAR_UNIT "TransformBegin\nScale 1 1 2\n" BILINEAR_UNIT
        "TransformEnd\n" BILINEAR_UNIT "AttributeEnd\n" BILINEAR_UNIT
        "MotionBegin [2.5 7]\nRotate 0 0 0 1\nRotate 90 0 0 1\nMotionEnd\n" BILINEAR_UNIT
        "MotionBegin [0 1]\nConcatTransform [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1]\n"
        "ConcatTransform [1 0 0 0 0 1 0 0 0 0 1 0 0 0 3 1]\nMotionEnd\n" BILINEAR_UNIT
        "MotionBegin [0 1]\nTransform [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1]\n"
        "Transform [2 0 0 0 0 2 0 0 0 0 2 0 0 0 0 1]\nMotionEnd\n"
        "MotionBegin [0 1]\n" BILINEAR_UNIT "Patch \"bilinear\" \"P\" [0 0 0 0 0 0 0 0 0 1 1 1]\n"
        "MotionEnd\nMotionBegin [0 1]\nScale 1 1 1\nScale 1 1 1\nMotionEnd\n" BILINEAR_UNIT
        "Identity\n" BILINEAR_UNIT "WorldEnd\n",
        &s);
    assert_int_equal(s.patch_count, 9);
    static const uint32_t flags[9] = {1, 1, 1, 0, 1, 1, 1, 1, 0};
    for (int p = 0; p < 9; p++)
        assert_int_equal(s.attr[p].flags, flags[p]);
    assert_vec(&s.cp[15], 2, 3, 4, 0);
    assert_vec(&s.cp1[15], 7, 3, 4, 0);
    assert_vec(&s.cp[16 + 15], 2, 3, 8, 0); /* TransformBegin: Scale on both samples */
    assert_vec(&s.cp1[16 + 15], 7, 3, 8, 0);
    assert_vec(&s.cp1[32 + 15], 7, 3, 4, 0);   /* TransformEnd restored the moving CTM */
    assert_vec(&s.cp1[48 + 15], 2, 3, 4, 0);   /* AttributeEnd: static again */
    assert_vec(&s.cp[64 + 15], 2, 3, 4, 1e-6); /* [2.5 7]: the first time is shutter open */
    assert_vec(&s.cp1[64 + 15], -3, 2, 4, 1e-6);
    assert_vec(&s.cp[80 + 15], 2, 3, 4, 1e-6);   /* the moving Rotate composed with ... */
    assert_vec(&s.cp1[80 + 15], -3, 2, 7, 1e-6); /* ... a moving ConcatTransform */
    /* Transform samples replace both; the patch samples are moved by them. */
    assert_vec(&s.cp[96 + 15], 2, 3, 4, 0);
    assert_vec(&s.cp1[96 + 15], 2, 2, 2, 0);
    assert_vec(&s.cp1[96 + 0], 0, 0, 0, 0);
    assert_vec(&s.cp1[112 + 15], 4, 6, 8, 0); /* two equal Scale samples: still moving */
    assert_vec(&s.cp1[128 + 15], 2, 3, 4, 0); /* Identity: static */
    scene_free(&s);
    /* A displaced patch under a moving CTM: the transform is the CTM's at shutter open. */
    test_parse_rib_ok("MotionBegin [0 1]\nTranslate 1 0 0\nTranslate 9 0 0\nMotionEnd\n"
                      "Displacement \"fbm\"\n" BILINEAR_UNIT,
                      &s);
    const ts_xform *x = &s.xform[s.attr[0].xform];
    assert_true(x->r0[3] == -1.0f && x->r0[0] == 1.0f);
    scene_free(&s);
}

/* ---- scene.c -------------------------------------------------------------------------- */

static void test_scene_growth_and_box(void **state)
{
    (void)state;
    ts_scene s = {0};
    ts_error e = {0};
    double cp[16][3];
    for (uint32_t p = 0; p < 1000; p++) {
        for (int k = 0; k < 16; k++)
            cp[k][0] = p, cp[k][1] = k, cp[k][2] = -(double)k;
        assert_int_equal(scene_add_patch(&s, (const double(*)[3])cp, NULL, &e), TS_OK);
    }
    assert_int_equal(s.patch_count, 1000);
    assert_true(s.patch_capacity >= 1000);
    assert_vec(&s.cp[999 * 16 + 15], 999, 15, -15, 0);
    assert_true(s.attr[5].cs_r == 1.0f); /* NULL attr: white */
    ts_box b = scene_patch_box(&s, 7);
    assert_box(b, 7, 0, -15, 7, 15, 0);
    ts_box empty = scene_patch_box(&s, 1000);
    assert_true(empty.lo_x > empty.hi_x);
    for (int k = 0; k < 100; k++) {
        ts_scene_light l = {
            .from = {k, 0, 0}, .to = {0, 0, 1}, .intensity = 1, .color = {1, 1, 1}, .angle = 0};
        assert_int_equal(scene_add_light(&s, &l, &e), TS_OK);
    }
    assert_int_equal(s.light_count, 100);
    assert_true(s.lights[99].from[0] == 99);
    scene_free(&s);
    assert_null(s.cp);
    assert_int_equal(s.patch_count, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_translate_then_rotate),
        cmocka_unit_test(test_rotate_convention),
        cmocka_unit_test(test_skew),
        cmocka_unit_test(test_scale_and_matrices),
        cmocka_unit_test(test_world_to_camera),
        cmocka_unit_test(test_format_and_projection),
        cmocka_unit_test(test_blocks_restore_state),
        cmocka_unit_test(test_basis_conversions),
        cmocka_unit_test(test_bilinear_exact),
        cmocka_unit_test(test_patch_mesh_counts),
        cmocka_unit_test(test_height_field),
        cmocka_unit_test(test_arrays_comments_escapes),
        cmocka_unit_test(test_lights),
        cmocka_unit_test(test_teapot_file),
        cmocka_unit_test(test_one_patch_file),
        cmocka_unit_test(test_singular_transform),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_errors_generated),
        cmocka_unit_test(test_error_missing_file),
        cmocka_unit_test(test_ignored_requests_warn_once),
        cmocka_unit_test(test_hostile_input),
        cmocka_unit_test(test_displacement),
        cmocka_unit_test(test_explicit_normals),
        cmocka_unit_test(test_mesh_normals),
        cmocka_unit_test(test_motion),
        cmocka_unit_test(test_motion_patch_types),
        cmocka_unit_test(test_scene_growth_and_box),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
