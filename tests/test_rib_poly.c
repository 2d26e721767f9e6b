/* test_rib_poly.c — the polygon requests (host/scene/rib/rib_poly.c) through the PN patches of
 * scene/polygon.c. Host only: never skips. A cube without "N" stays a cube (flat patches with
 * the face normals, hard edges: three different normals at each corner); a quad with "N"
 * takes them as corner normals and tangent planes; holes and concave outlines are
 * triangulated (areas add up, no surface point in a hole); primitive variables and errors. */
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

static const int corner_cp[4] = {0, 3, 12, 15};

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

/* The unit dP/du x dP/dv a little inside corner c (central differences). */
static void corner_normal(const ts_vec4 *cp, int c, double n[3])
{
    const double h = 1e-5;
    double u = (c & 1) ? 1 - 1e-3 : 1e-3, v = (c & 2) ? 1 - 1e-3 : 1e-3, a[3], b[3], e[3], d[3];
    bezier_point(cp, u + h, v, a);
    bezier_point(cp, u - h, v, b);
    bezier_point(cp, u, v + h, e);
    bezier_point(cp, u, v - h, d);
    double du[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
    double dv[3] = {e[0] - d[0], e[1] - d[1], e[2] - d[2]};
    n[0] = du[1] * dv[2] - du[2] * dv[1];
    n[1] = du[2] * dv[0] - du[0] * dv[2];
    n[2] = du[0] * dv[1] - du[1] * dv[0];
    double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    n[0] /= l, n[1] /= l, n[2] /= l;
}

/* The unit cube [-1, 1]^3 as six quads, counter-clockwise seen from outside. */
static const char *const cube =
    "PointsPolygons [4 4 4 4 4 4] [0 2 3 1  4 5 7 6  0 1 5 4  2 6 7 3  0 4 6 2  1 3 7 5]\n"
    "  \"P\" [-1 -1 -1  1 -1 -1  -1 1 -1  1 1 -1  -1 -1 1  1 -1 1  -1 1 1  1 1 1]\n";

static void test_cube_stays_a_cube(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok(cube, &s);
    assert_int_equal(s.patch_count, 6);
    for (uint32_t p = 0; p < 6; p++) {
        const ts_vec4 *cp = s.cp + p * 16;
        /* The face normal: the axis along which the corners agree. */
        int axis = -1;
        for (int d = 0; d < 3; d++) {
            float v0 = (&cp[0].x)[d];
            int same = 1;
            for (int k = 0; k < 16; k++) /* every control point in the face's plane */
                same &= (&cp[k].x)[d] == v0;
            if (same) axis = d;
        }
        assert_true(axis >= 0);
        double want[3] = {0, 0, 0};
        want[axis] = (&cp[0].x)[axis]; /* outward: the side the face is on */
        for (int c = 0; c < 4; c++) {
            const ts_vec4 *n = &s.corner_n[p * 4 + c];
            assert_float_equal(n->x, want[0], 0);
            assert_float_equal(n->y, want[1], 0);
            assert_float_equal(n->z, want[2], 0);
            double g[3];
            corner_normal(cp, c, g); /* the patch is oriented like its face */
            assert_true(g[0] * want[0] + g[1] * want[1] + g[2] * want[2] > 1 - 1e-9);
        }
        /* Flat and linearly parametrised: the centre is the corners' average. */
        double mid[3];
        bezier_point(cp, 0.5, 0.5, mid);
        for (int d = 0; d < 3; d++) {
            double avg = 0;
            for (int c = 0; c < 4; c++)
                avg += 0.25 * (&cp[corner_cp[c]].x)[d];
            assert_true(fabs(mid[d] - avg) < 1e-6);
        }
    }
    /* Hard edges: each cube corner keeps three different normals (no averaging). */
    int distinct_at_origin_corner = 0;
    double seen[3][3];
    for (uint32_t k = 0; k < 24; k++) {
        const ts_vec4 *x = &s.cp[(k / 4) * 16 + corner_cp[k % 4]];
        if (!(x->x == -1 && x->y == -1 && x->z == -1)) continue;
        const ts_vec4 *n = &s.corner_n[k];
        int dup = 0;
        for (int j = 0; j < distinct_at_origin_corner; j++)
            dup |= seen[j][0] == n->x && seen[j][1] == n->y && seen[j][2] == n->z;
        if (!dup) {
            seen[distinct_at_origin_corner][0] = n->x, seen[distinct_at_origin_corner][1] = n->y;
            seen[distinct_at_origin_corner++][2] = n->z;
        }
    }
    assert_int_equal(distinct_at_origin_corner, 3);
    scene_free(&s);
}

static void test_quad_with_normals(void **state)
{
    (void)state;
    /* A unit square in z = 0 whose normals lean outwards: the patch bulges, its corner
     * normals are the given ones (normalised) and its tangent planes there meet them. */
    ts_scene s;
    test_parse_rib_ok("Polygon \"P\" [0 0 0  1 0 0  1 1 0  0 1 0]\n"
                      "  \"N\" [-1 -1 2  1 -1 2  1 1 2  -1 1 2]",
                      &s);
    assert_int_equal(s.patch_count, 1);
    /* Corner order (0,0) (1,0) (0,1) (1,1) = vertices 0 1 3 2. */
    const double given[4][3] = {{-1, -1, 2}, {1, -1, 2}, {-1, 1, 2}, {1, 1, 2}};
    for (int c = 0; c < 4; c++) {
        double l = sqrt(6.0), g[3];
        const ts_vec4 *n = &s.corner_n[c];
        assert_true(fabs(n->x - given[c][0] / l) < 1e-6 && fabs(n->y - given[c][1] / l) < 1e-6 &&
                    fabs(n->z - given[c][2] / l) < 1e-6);
        corner_normal(s.cp, c, g);
        assert_true(g[0] * given[c][0] / l + g[1] * given[c][1] / l + g[2] * given[c][2] / l >
                    1 - 1e-3);
    }
    double mid[3];
    bezier_point(s.cp, 0.5, 0.5, mid);
    assert_true(mid[2] > 0.05); /* curved: the middle rises towards the normals */
    scene_free(&s);
    /* The same quad without "N" is flat. */
    test_parse_rib_ok("Polygon \"P\" [0 0 0  1 0 0  1 1 0  0 1 0]", &s);
    for (int k = 0; k < 16; k++)
        assert_float_equal(s.cp[k].z, 0.0f, 0);
    scene_free(&s);
}

/* Sum of the areas of flat patches (triangles: corners 0, 3, 12; quads split on a
 * diagonal), and the check that no point of any patch lies strictly inside the box hole
 * [hx0, hx1] x [hy0, hy1] of the z = 0 plane or outside [ox0, ox1] x [oy0, oy1]. */
static double flat_area(const ts_scene *s, const double hole[4], const double outer[4])
{
    double area = 0;
    for (uint32_t p = 0; p < s->patch_count; p++) {
        const ts_vec4 *cp = s->cp + p * 16;
        const ts_vec4 *a = &cp[0], *b = &cp[3], *c = &cp[15], *d = &cp[12];
        double t1 = 0.5 * ((b->x - a->x) * (d->y - a->y) - (b->y - a->y) * (d->x - a->x));
        double t2 = 0.5 * ((c->x - b->x) * (d->y - b->y) - (c->y - b->y) * (d->x - b->x));
        area += t1 + (memcmp(c, d, sizeof *c) == 0 ? 0 : t2);
        for (int j = 0; j <= 8; j++)
            for (int i = 0; i <= 8; i++) {
                double x[3];
                bezier_point(cp, i / 8.0, j / 8.0, x);
                assert_true(fabs(x[2]) < 1e-6);
                if (hole && x[0] > hole[0] + 1e-6 && x[0] < hole[1] - 1e-6 &&
                    x[1] > hole[2] + 1e-6 && x[1] < hole[3] - 1e-6)
                    fail_msg("patch %u: point (%g %g) inside the hole", p, x[0], x[1]);
                assert_true(x[0] > outer[0] - 1e-6 && x[0] < outer[1] + 1e-6 &&
                            x[1] > outer[2] - 1e-6 && x[1] < outer[3] + 1e-6);
            }
    }
    return area;
}

static void test_holes_and_concave(void **state)
{
    (void)state;
    const double outer[4] = {0, 4, 0, 4}, hole[4] = {1, 3, 1.5, 2.5};
    /* A 4 x 4 square with a 2 x 1 hole, the hole given either way round. */
    const char *const ribs[2] = {
        "GeneralPolygon [4 4] \"P\" [0 0 0 4 0 0 4 4 0 0 4 0  1 1.5 0 1 2.5 0 3 2.5 0 3 1.5 0]",
        "GeneralPolygon [4 4] \"P\" [0 0 0 4 0 0 4 4 0 0 4 0  1 1.5 0 3 1.5 0 3 2.5 0 1 2.5 0]",
    };
    for (int k = 0; k < 2; k++) {
        ts_scene s;
        test_parse_rib_ok(ribs[k], &s);
        assert_true(s.patch_count >= 8); /* 8 vertices + 2 bridge ends - 2 */
        assert_true(fabs(flat_area(&s, hole, outer) - 14) < 1e-5);
        for (uint32_t n = 0; n < s.patch_count * 4; n++) /* every triangle faces +z */
            assert_float_equal(s.corner_n[n].z, 1.0f, 0);
        scene_free(&s);
    }
    /* Two holes in PointsGeneralPolygons, sharing the outline's points list. */
    ts_scene s;
    test_parse_rib_ok("PointsGeneralPolygons [3] [4 4 4] [0 1 2 3 4 5 6 7 8 9 10 11]\n"
                      "  \"P\" [0 0 0 4 0 0 4 4 0 0 4 0  0.5 0.5 0 0.5 1.5 0 1.5 1.5 0 1.5 0.5 0"
                      "  2 2 0 2 3 0 3 3 0 3 2 0]",
                      &s);
    assert_true(fabs(flat_area(&s, (const double[]){0.5, 1.5, 0.5, 1.5}, outer) - 14) < 1e-5);
    assert_true(fabs(flat_area(&s, (const double[]){2, 3, 2, 3}, outer) - 14) < 1e-5);
    scene_free(&s);
    /* A concave L-shaped hexagon (area 3) and a concave quad (a dart, area 1.5): both
     * triangulated, nothing outside. */
    test_parse_rib_ok("Polygon \"P\" [0 0 0 2 0 0 2 1 0 1 1 0 1 2 0 0 2 0]", &s);
    assert_int_equal(s.patch_count, 4);
    assert_true(
        fabs(flat_area(&s, (const double[]){1, 2, 1, 2}, (const double[]){0, 2, 0, 2}) - 3) < 1e-6);
    scene_free(&s);
    test_parse_rib_ok("Polygon \"P\" [0 0 0 2 1 0 0 2 0 0.5 1 0]", &s);
    assert_int_equal(s.patch_count, 2);
    assert_true(fabs(flat_area(&s, NULL, (const double[]){0, 2, 0, 2}) - 1.5) < 1e-6);
    scene_free(&s);
    /* A convex pentagon: three triangles; a triangle: one patch with a collapsed edge. */
    test_parse_rib_ok("Polygon \"P\" [0 0 0 2 0 0 3 1 0 1 2 0 -1 1 0]", &s);
    assert_int_equal(s.patch_count, 3);
    scene_free(&s);
    test_parse_rib_ok("Polygon \"P\" [0 0 0 1 0 0 0 1 0]", &s);
    assert_int_equal(s.patch_count, 1);
    assert_memory_equal(&s.cp[12], &s.cp[15], sizeof s.cp[0]);
    scene_free(&s);
}

/* Whether (x, y) lies strictly inside the convex counter-clockwise polygon v[0..n). */
static int inside_convex(const double (*v)[2], int n, double x, double y)
{
    for (int k = 0; k < n; k++) {
        const double *a = v[k], *b = v[(k + 1) % n];
        if ((b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]) <= 1e-6) return 0;
    }
    return 1;
}

static void test_random_holes(void **state)
{
    (void)state;
    /* A 16-gon of radius 10 with convex holes (3 to 6 sides, radius 0.9, random turn and
     * orientation) in random cells of a 4 x 4 grid: the patches cover exactly the
     * outline's area minus the holes', and no surface point falls into a hole. */
    uint32_t seed = 7;
    for (int trial = 0; trial < 25; trial++) {
        char rib[8192];
        double hv[16][6][2];
        int hn[16], nh = 0;
        int len = snprintf(rib, sizeof rib, "GeneralPolygon [16");
        double outer_area = 0.5 * 16 * 100 * sin(2 * 3.14159265358979 / 16), area = outer_area;
        for (int cell = 0; cell < 16; cell++) {
            if (test_uniform(&seed, 0, 1) < 0.5f) continue;
            int n = 3 + (int)test_uniform(&seed, 0, 3.999f);
            double cx = -4.5 + 3 * (cell % 4) + test_uniform(&seed, -0.5f, 0.5f);
            double cy = -4.5 + 3 * (cell / 4) + test_uniform(&seed, -0.5f, 0.5f);
            double turn = test_uniform(&seed, 0, 6.28f);
            for (int k = 0; k < n; k++) {
                double a = turn + 2 * 3.14159265358979 * k / n;
                hv[nh][k][0] = cx + 0.9 * cos(a), hv[nh][k][1] = cy + 0.9 * sin(a);
            }
            hn[nh++] = n;
            area -= 0.5 * n * 0.81 * sin(2 * 3.14159265358979 / n);
            len += snprintf(rib + len, sizeof rib - (size_t)len, " %d", n);
        }
        len += snprintf(rib + len, sizeof rib - (size_t)len, "] \"P\" [");
        for (int k = 0; k < 16; k++) {
            double a = 2 * 3.14159265358979 * k / 16;
            len += snprintf(rib + len, sizeof rib - (size_t)len, "%.17g %.17g 0 ", 10 * cos(a),
                            10 * sin(a));
        }
        for (int h = 0; h < nh; h++) {
            int backwards = test_uniform(&seed, 0, 1) < 0.5f;
            for (int k = 0; k < hn[h]; k++) {
                int q = backwards ? hn[h] - 1 - k : k;
                len += snprintf(rib + len, sizeof rib - (size_t)len, "%.17g %.17g 0 ", hv[h][q][0],
                                hv[h][q][1]);
            }
        }
        snprintf(rib + len, sizeof rib - (size_t)len, "]");
        ts_scene s;
        test_parse_rib_ok(rib, &s);
        double got = flat_area(&s, NULL, (const double[]){-10, 10, -10, 10});
        if (fabs(got - area) > 1e-4) fail_msg("trial %d: area %.9g, want %.9g", trial, got, area);
        for (uint32_t p = 0; p < s.patch_count; p++)
            for (int j = 0; j <= 6; j++)
                for (int i = 0; i <= 6; i++) {
                    double x[3];
                    bezier_point(s.cp + p * 16, i / 6.0, j / 6.0, x);
                    for (int h = 0; h < nh; h++)
                        if (inside_convex((const double(*)[2])hv[h], hn[h], x[0], x[1]))
                            fail_msg("trial %d: patch %u has (%g %g) in hole %d", trial, p, x[0],
                                     x[1], h);
                }
        scene_free(&s);
    }
}

static void test_primitive_variables(void **state)
{
    (void)state;
    ts_scene s;
    /* Two quads sharing an edge: uniform Cs per face, facevarying st per face-vertex. */
    test_parse_rib_ok("PointsPolygons [4 4] [0 1 4 3  1 2 5 4]\n"
                      "  \"P\" [0 0 0 1 0 0 2 0 0 0 1 0 1 1 0 2 1 0]\n"
                      "  \"uniform color Cs\" [1 0 0 0 1 0]\n"
                      "  \"facevarying float[2] st\" [0 0 1 0 1 1 0 1  5 5 6 5 6 6 5 6]",
                      &s);
    assert_int_equal(s.patch_count, 2);
    assert_float_equal(s.attr[0].cs_r, 1, 0);
    assert_float_equal(s.attr[1].cs_g, 1, 0);
    /* Corner order (0,0) (1,0) (0,1) (1,1) = face-vertices 0 1 3 2. */
    const float st1[8] = {5, 5, 6, 5, 5, 6, 6, 6};
    for (int k = 0; k < 8; k++)
        assert_float_equal(s.attr[1].st[k], st1[k], 0);
    scene_free(&s);
    /* Varying Cs on a triangle: the average of its three corners. */
    test_parse_rib_ok("Polygon \"P\" [0 0 0 1 0 0 0 1 0] \"Cs\" [1 0 0 0 1 0 0 0 1]", &s);
    assert_float_equal(s.attr[0].cs_r, 1.0f / 3, 1e-7);
    assert_float_equal(s.attr[0].cs_b, 1.0f / 3, 1e-7);
    scene_free(&s);
}

static void test_errors(void **state)
{
    (void)state;
    test_parse_rib_error("Polygon \"Cs\" [1 0 0]", "t.rib:1:1: error: Polygon: missing \"P\"");
    test_parse_rib_error("Polygon \"P\" [0 0 0 1 0 0]",
                         "t.rib:1:1: error: Polygon: 2 points (at least 3)");
    test_parse_rib_error(
        "PointsPolygons [3 3] [0 1 2 0 2] \"P\" [0 0 0 1 0 0 0 1 0]",
        "t.rib:1:16: error: PointsPolygons: the nvertices add up to 6, but vertices has 5");
    test_parse_rib_error(
        "PointsPolygons [3] [0 1 3] \"P\" [0 0 0 1 0 0 0 1 0]",
        "t.rib:1:20: error: PointsPolygons: vertex 2 is point 3, but \"P\" has 3 points");
    test_parse_rib_error("PointsPolygons [2] [0 1] \"P\" [0 0 0 1 0 0]",
                         "t.rib:1:16: error: PointsPolygons: nvertices 0 is 2 (at least 3)");
    test_parse_rib_error(
        "PointsPolygons [3.5] [0 1 2] \"P\" [0 0 0 1 0 0 0 1 0]",
        "t.rib:1:16: error: PointsPolygons: nvertices: value 0 is 3.5, not an integer in "
        "[0, 16777216]");
    test_parse_rib_error(
        "GeneralPolygon [4 3] \"P\" [0 0 0 1 0 0 1 1 0 0 1 0]",
        "t.rib:1:16: error: GeneralPolygon: the nvertices add up to 7, but \"P\" has 4");
    test_parse_rib_error(
        "PointsGeneralPolygons [1 1] [3] [0 1 2] \"P\" [0 0 0 1 0 0 0 1 0]",
        "t.rib:1:23: error: PointsGeneralPolygons: the nloops add up to 2, but nvertices "
        "has 1");
}

/* A primitive variable other than the position with the wrong number of values: the
 * primitive is drawn without it, with a warning (exporters write such files, and RenderMan
 * renders them); with --strict it is the error. The position's count stays an error. */
static void test_wrong_count_primvar(void **state)
{
    (void)state;
    const char *bad = "WorldBegin\nPolygon \"P\" [0 0 0 1 0 0 0 1 0] \"uniform color Cs\" "
                      "[1 0 0 1 0 0]\nWorldEnd\n";
    int rc;
    const char *w = test_rib_warnings(bad, &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(w, "w.rib:2:52: warning: Polygon: parameter \"Cs\" (uniform) needs 3 "
                           "values, got 6; drawn without it (--strict makes this an error)\n");
    ts_scene s, ref;
    ts_error e = {0};
    assert_int_equal(test_parse_rib(bad, &s, &e), TS_OK);
    test_parse_rib_ok("WorldBegin\nPolygon \"P\" [0 0 0 1 0 0 0 1 0]\nWorldEnd\n", &ref);
    assert_int_equal(s.patch_count, ref.patch_count);
    assert_memory_equal(s.cp, ref.cp, (size_t)16 * s.patch_count * sizeof s.cp[0]);
    assert_memory_equal(s.attr, ref.attr, s.patch_count * sizeof s.attr[0]);
    scene_free(&s);
    scene_free(&ref);
    assert_int_equal(test_parse_rib_strict(bad, &s, &e), TS_E_SCENE);
    assert_string_equal(e.msg, "t.rib:2:52: error: Polygon: parameter \"Cs\" (uniform) needs 3 "
                               "values, got 6");
    ts_error_clear(&e);
    assert_int_equal(test_parse_rib_strict("Sphere 1 -1 1 360 \"Cs\" [1 0 0 0 1 0]", &s, &e),
                     TS_E_SCENE);
    assert_string_equal(e.msg, "t.rib:1:24: error: Sphere: parameter \"Cs\" (varying) needs 12 "
                               "values, got 6");
    ts_error_clear(&e);
    test_parse_rib_error(
        "Polygon \"P\" [0 0 0 1 0 0 0 1 0 1]",
        "t.rib:1:13: error: Polygon: parameter \"P\" (vertex) needs 9 values, got 10");
}

/* "s" and "t" written apart are the texture coordinates "st" = (s, t): the same patches, bit
 * for bit, as "st" with the values interleaved; one of them alone is ignored with a warning. */
static void test_separate_s_t(void **state)
{
    (void)state;
    ts_scene a, b;
    test_parse_rib_ok("WorldBegin\nPointsPolygons [4] [0 1 2 3] \"P\" [0 0 0 1 0 0 1 1 0 0 1 0] "
                      "\"facevarying float s\" [0.1 0.9 0.8 0.2] \"facevarying float t\" "
                      "[0.3 0.35 0.7 0.75]\nWorldEnd\n",
                      &a);
    test_parse_rib_ok("WorldBegin\nPointsPolygons [4] [0 1 2 3] \"P\" [0 0 0 1 0 0 1 1 0 0 1 0] "
                      "\"facevarying float[2] st\" [0.1 0.3 0.9 0.35 0.8 0.7 0.2 0.75]\nWorldEnd\n",
                      &b);
    assert_int_equal(a.patch_count, b.patch_count);
    assert_true(a.patch_count > 0);
    assert_memory_equal(a.attr, b.attr, a.patch_count * sizeof a.attr[0]);
    assert_true(a.attr[0].st[0] != 0.0f || a.attr[0].st[1] != 0.0f);
    scene_free(&a);
    scene_free(&b);
    int rc;
    const char *w = test_rib_warnings("WorldBegin\nPolygon \"P\" [0 0 0 1 0 0 0 1 0] \"s\" "
                                      "[0 1 0]\nWorldEnd\n",
                                      &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(w, "w.rib:2:37: warning: Polygon: \"s\" and \"t\" are read as the texture "
                           "coordinates \"st\" only together and of one class: ignored\n");
}

/* A zero normal in "N" (exporters write them) takes its polygon's normal, as a mesh vertex
 * without a usable normal does, with one warning. */
static void test_zero_normal(void **state)
{
    (void)state;
    int rc;
    const char *out =
        test_rib_warnings("Polygon \"P\" [0 0 0 1 0 0 0 1 0] \"N\" [0 0 1 0 0 0 0 0 1]\n", &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "w.rib:1:37: warning: Polygon: zero normals in \"N\" take their "
                             "polygon's normal\n");
    ts_scene s;
    test_parse_rib_ok("Polygon \"P\" [0 0 0 1 0 0 0 1 0] \"N\" [0 0 1 0 0 0 0 0 1]\n", &s);
    assert_int_equal(s.patch_count, 1);
    for (int c = 0; c < 4; c++)
        assert_true(s.corner_n[c].x == 0.0f && s.corner_n[c].y == 0.0f && s.corner_n[c].z == 1.0f);
    scene_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cube_stays_a_cube),
        cmocka_unit_test(test_wrong_count_primvar),
        cmocka_unit_test(test_separate_s_t),
        cmocka_unit_test(test_zero_normal),
        cmocka_unit_test(test_quad_with_normals),
        cmocka_unit_test(test_holes_and_concave),
        cmocka_unit_test(test_random_holes),
        cmocka_unit_test(test_primitive_variables),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
