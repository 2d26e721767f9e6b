/* test_rib_curves.c — Points as spheres and Curves as ribbons facing the camera
 * (host/scene/rib/rib_curves.c, docs/rib.md "Points and curves"): the spheres' corners lie at
 * half the width from their point, a ribbon's centre line is the curve's Bézier form and its
 * rows are the width wide, across the curve and the view; sizes that make no segments and
 * negative widths are errors. Host only: never skips. */
#include "scene/rib/rib.h"
#include "scene/scene.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

static double dist(const ts_vec4 *a, const double b[3])
{
    double d[3] = {a->x - b[0], a->y - b[1], a->z - b[2]};
    return sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
}

static void test_points(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nPoints \"P\" [0 0 5  1 2 5] \"width\" [0.2 0.4]\n"
                      "Points \"P\" [3 0 5] \"constantwidth\" [0.5]\nWorldEnd\n",
                      &s);
    assert_int_equal(s.patch_count, 24); /* 8 patches a sphere */
    const double centre[3][3] = {{0, 0, 5}, {1, 2, 5}, {3, 0, 5}}, radius[3] = {0.1, 0.2, 0.25};
    static const int corner[4] = {0, 3, 12, 15};
    for (uint32_t q = 0; q < 24; q++)
        for (int c = 0; c < 4; c++) {
            double d = dist(&s.cp[q * 16 + (uint32_t)corner[c]], centre[q / 8]);
            if (fabs(d - radius[q / 8]) > 1e-6) fail_msg("patch %u: %g from its point", q, d);
        }
    scene_free(&s);
    /* One colour per point; an empty Points (a particle system's empty frame) adds nothing. */
    test_parse_rib_ok("WorldBegin\nPoints \"P\" [0 0 5  1 0 5] \"Cs\" [1 0 0  0 0 1]\n"
                      "Points \"P\" []\nWorldEnd\n",
                      &s);
    assert_int_equal(s.patch_count, 16);
    assert_true(s.attr[0].cs_r == 1.0f && s.attr[0].cs_b == 0.0f);
    assert_true(s.attr[8].cs_r == 0.0f && s.attr[8].cs_b == 1.0f);
    scene_free(&s);
}

/* The camera at the world origin looking down +z (no camera transformation). */
static void test_linear_ribbon(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nCurves \"linear\" [2] \"nonperiodic\" \"P\" [-1 0 5  1 0 5] "
                      "\"constantwidth\" [0.2]\nWorldEnd\n",
                      &s);
    assert_int_equal(s.patch_count, 1);
    /* Across x (the curve) and z (the view): along y, 0.2 wide, corners on the ends. */
    const double want[4][3] = {{-1, -0.1, 5}, {-1, 0.1, 5}, {1, -0.1, 5}, {1, 0.1, 5}};
    static const int corner[4] = {0, 3, 12, 15};
    for (int c = 0; c < 4; c++)
        if (dist(&s.cp[corner[c]], want[c]) > 1e-6)
            fail_msg("corner %d at (%g %g %g)", c, s.cp[corner[c]].x, s.cp[corner[c]].y,
                     s.cp[corner[c]].z);
    scene_free(&s);
}

/* Two Bézier segments (7 vertices, step 3) with varying widths 0.1, 0.3, 0.5: row k of
 * segment j is centred on the curve's Bézier point and w = the width at t = k / 3 wide. The
 * same curve as a b-spline of 5 vertices (step 1) makes 2 segments too. */
static void test_cubic_ribbon(void **state)
{
    (void)state;
    ts_scene s;
    const double P[7][3] = {{0, 0, 6},  {1, 1, 6},  {2, 1, 6}, {3, 0, 6},
                            {4, -1, 7}, {5, -1, 7}, {6, 0, 7}};
    test_parse_rib_ok("WorldBegin\nBasis \"bezier\" 3 \"bezier\" 3\n"
                      "Curves \"cubic\" [7] \"nonperiodic\" \"P\" [0 0 6  1 1 6  2 1 6  3 0 6  "
                      "4 -1 7  5 -1 7  6 0 7] \"width\" [0.1 0.3 0.5]\nWorldEnd\n",
                      &s);
    assert_int_equal(s.patch_count, 2);
    const double w[2][2] = {{0.1, 0.3}, {0.3, 0.5}};
    for (int j = 0; j < 2; j++)
        for (int k = 0; k < 4; k++) {
            const ts_vec4 *a = &s.cp[j * 16 + k * 4], *b = &s.cp[j * 16 + k * 4 + 3];
            double mid[3] = {0.5 * (a->x + b->x), 0.5 * (a->y + b->y), 0.5 * (a->z + b->z)};
            double d[3] = {mid[0] - P[3 * j + k][0], mid[1] - P[3 * j + k][1],
                           mid[2] - P[3 * j + k][2]};
            double across = dist(a, (double[3]){b->x, b->y, b->z});
            double want = w[j][0] + (w[j][1] - w[j][0]) * k / 3.0;
            if (sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) > 1e-5 || fabs(across - want) > 1e-5)
                fail_msg("segment %d row %d: centre off by %g, %g wide (want %g)", j, k,
                         sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]), across, want);
        }
    scene_free(&s);
    test_parse_rib_ok("WorldBegin\nBasis \"b-spline\" 1 \"b-spline\" 1\n"
                      "Curves \"cubic\" [5] \"nonperiodic\" \"P\" [0 0 6  1 1 6  2 0 6  3 1 6  "
                      "4 0 6]\nWorldEnd\n",
                      &s);
    assert_int_equal(s.patch_count, 2);
    scene_free(&s);
}

/* In a motion block Points and Curves deform like the other surfaces (test_rib_deform.c). */
static void test_motion(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nMotionBegin [0 1]\n"
                      "Curves \"linear\" [2] \"nonperiodic\" \"P\" [0 0 5 1 0 5] "
                      "\"constantwidth\" [0.1]\n"
                      "Curves \"linear\" [2] \"nonperiodic\" \"P\" [0 1 5 1 1 5] "
                      "\"constantwidth\" [0.1]\nMotionEnd\n"
                      "MotionBegin [0 1]\nPoints \"P\" [0 0 5] \"constantwidth\" [0.1]\n"
                      "Points \"P\" [0 0 6] \"constantwidth\" [0.2]\nMotionEnd\nWorldEnd\n",
                      &s);
    assert_int_equal(s.patch_count, 1 + 16);
    for (uint32_t q = 0; q < s.patch_count; q++)
        assert_true(s.attr[q].flags & TS_PATCH_MOVING);
    /* The ribbon's centre line moved up by 1 (its side turns with the view). */
    assert_true(fabs(0.5 * (s.cp1[0].y + s.cp1[3].y) - 0.5 * (s.cp[0].y + s.cp[3].y) - 1.0) < 1e-6);
    scene_free(&s);
}

static void test_errors(void **state)
{
    (void)state;
    test_parse_rib_error("WorldBegin\nCurves \"cubic\" [5] \"nonperiodic\" \"P\" [0 0 0 1 0 0 2 0 "
                         "0 3 0 0 4 0 0]\n",
                         "t.rib:2:16: error: Curves: curve 0 has 5 vertices, which do not make "
                         "nonperiodic cubic segments (4 + k * the v step)");
    test_parse_rib_error("WorldBegin\nCurves \"spline\" [2] \"nonperiodic\" \"P\" [0 0 0 1 0 0]\n",
                         "t.rib:2:8: error: Curves: unknown type \"spline\" (linear or cubic)");
    test_parse_rib_error("WorldBegin\nCurves \"linear\" [2] \"nonperiodic\" \"P\" [0 0 0 1 0 0] "
                         "\"constantwidth\" [-1]\n",
                         "t.rib:2:1: error: Curves: widths must be >= 0 and finite, got -1");
    test_parse_rib_error("WorldBegin\nCurves \"linear\" [2] \"nonperiodic\" \"P\" [0 0 0 1 0 0 2 0 "
                         "0]\n",
                         "t.rib:2:39: error: Curves: parameter \"P\" needs 6 values, got 9");
    test_parse_rib_error("WorldBegin\nPoints \"width\" [1]\n",
                         "t.rib:2:1: error: Points: missing \"P\"");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_points),       cmocka_unit_test(test_linear_ribbon),
        cmocka_unit_test(test_cubic_ribbon), cmocka_unit_test(test_motion),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
