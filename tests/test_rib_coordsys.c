/* test_rib_coordsys.c — named coordinate systems (host/scene/rib/rib_coordsys.c, docs/rib.md
 * "Named coordinate systems"): CoordSysTransform puts back the transformation CoordinateSystem
 * marked, or the standard world, camera and object spaces. Checked on where a unit patch's
 * first control point (object space (0, 0, 0)) lands. Host only: never skips. */
#include "scene/rib/rib.h"
#include "scene/scene.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

#define QUAD "Patch \"bilinear\" \"P\" [0 0 0  1 0 0  0 1 0  1 1 0]\n"

/* The world position of patch q's first control point (its object-space origin). */
static void expect_origin_at(const ts_scene *s, uint32_t q, double x, double y, double z)
{
    const ts_vec4 *c = &s->cp[(size_t)q * 16];
    if (fabs(c->x - x) > 1e-5 || fabs(c->y - y) > 1e-5 || fabs(c->z - z) > 1e-5)
        fail_msg("patch %u at (%g %g %g), want (%g %g %g)", q, c->x, c->y, c->z, x, y, z);
}

static void test_named_systems(void **state)
{
    (void)state;
    ts_scene s;
    /* The camera 5 units back (world_to_camera translates by +5 in z). A system marked in
     * the world block comes back after other transformations; marked again, it takes the
     * new one; one marked before WorldBegin (camera space) is moved to world space. */
    test_parse_rib_ok("Translate 1 0 0\nCoordinateSystem \"early\"\nTranslate -1 0 5\n"
                      "WorldBegin\n"
                      "Translate 1 2 3\nCoordinateSystem \"a\"\nIdentity\nRotate 90 0 0 1\n"
                      "CoordSysTransform \"a\"\n" QUAD "CoordSysTransform \"camera\"\n" QUAD
                      "Translate 7 7 7\nCoordSysTransform \"world\"\n" QUAD
                      "Translate 0 1 0\nCoordSysTransform \"object\"\n" QUAD
                      "CoordSysTransform \"early\"\n" QUAD
                      "Translate 4 0 0\nCoordinateSystem \"a\"\nIdentity\n"
                      "CoordSysTransform \"a\"\n" QUAD "WorldEnd\n",
                      &s);
    assert_int_equal(s.patch_count, 6);
    expect_origin_at(&s, 0, 1, 2, 3);  /* "a" */
    expect_origin_at(&s, 1, 0, 0, -5); /* "camera": the eye */
    expect_origin_at(&s, 2, 0, 0, 0);  /* "world" */
    expect_origin_at(&s, 3, 0, 1, 0);  /* "object": as it was */
    expect_origin_at(&s, 4, 1, 0, -5); /* "early": camera-space T(1 0 0) */
    expect_origin_at(&s, 5, 5, 0, -5); /* "a" marked again: "early" then 4 along x */
    scene_free(&s);
    /* Before WorldBegin "camera" is the identity (the CTM maps to camera space). */
    test_parse_rib_ok("Translate 0 0 5\nTransformBegin\nCoordSysTransform \"camera\"\n" QUAD
                      "TransformEnd\nWorldBegin\nWorldEnd\n",
                      &s);
    expect_origin_at(&s, 0, 0, 0, -5);
    scene_free(&s);
}

/* A system marked under a moving CTM keeps both samples: patches read after it move. */
static void test_moving_system(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nMotionBegin [0 1]\nTranslate 0 0 0\nTranslate 2 0 0\n"
                      "MotionEnd\nCoordinateSystem \"m\"\nIdentity\n" QUAD
                      "CoordSysTransform \"m\"\n" QUAD "WorldEnd\n",
                      &s);
    assert_int_equal(s.patch_count, 2);
    assert_false(s.attr[0].flags & TS_PATCH_MOVING);
    assert_true(s.attr[1].flags & TS_PATCH_MOVING);
    assert_non_null(s.cp1);
    assert_true(fabs(s.cp1[16].x - 2.0f) < 1e-6 && fabs(s.cp[16].x) < 1e-6);
    scene_free(&s);
}

static void test_errors(void **state)
{
    (void)state;
    test_parse_rib_error("WorldBegin\nCoordSysTransform \"lamp\"\n" QUAD "WorldEnd\n",
                         "t.rib:2:19: error: CoordSysTransform: no coordinate system \"lamp\" "
                         "(CoordinateSystem \"lamp\" must come before; or world, camera, object)");
    test_parse_rib_error("WorldBegin\nCoordSysTransform \"raster\"\n",
                         "t.rib:2:19: error: CoordSysTransform \"raster\": a projective space is "
                         "not supported (world, camera, object or a CoordinateSystem name)");
    test_parse_rib_error("CoordSysTransform \"world\"\n",
                         "t.rib:1:19: error: CoordSysTransform \"world\" before WorldBegin (world "
                         "space is defined at WorldBegin)");
    test_parse_rib_error("CoordinateSystem 3\n",
                         "t.rib:1:18: error: CoordinateSystem: expected a coordinate system name "
                         "(a string)");
    test_parse_rib_error(
        "WorldBegin\nMotionBegin [0 1]\nCoordSysTransform \"world\"\n",
        "t.rib:3:1: error: CoordSysTransform is not allowed in the motion block "
        "at 2:1 (only Patch, PatchMesh, SubdivisionMesh, NuPatch, polygons, "
        "quadrics, Points, Curves, Translate, Rotate, Scale, ConcatTransform or Transform)");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_named_systems),
        cmocka_unit_test(test_moving_system),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
