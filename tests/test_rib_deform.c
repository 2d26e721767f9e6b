/* test_rib_deform.c — surfaces that deform in a motion block (docs/rib.md "Motion blur"):
 * two samples of PatchMesh, SubdivisionMesh, a quadric or a polygon mesh make one set of
 * moving patches, the first sample's points at shutter open and the second's at shutter
 * close, patch for patch; samples that make different patches are errors; a Shutter other
 * than the block's times takes its part of the motion (test_shutter). Host only: never
 * skips. */
#include "scene/rib/rib.h"
#include "scene/scene.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

/* Every patch moves, and its shutter-close points are f(its shutter-open points). */
static void expect_moved(const ts_scene *s, void (*f)(const ts_vec4 *a, double out[3]), double tol)
{
    assert_non_null(s->cp1);
    for (uint32_t q = 0; q < s->patch_count; q++) {
        assert_true(s->attr[q].flags & TS_PATCH_MOVING);
        for (int k = 0; k < 16; k++) {
            const ts_vec4 *a = &s->cp[(size_t)q * 16 + (size_t)k],
                          *b = &s->cp1[(size_t)q * 16 + (size_t)k];
            double want[3];
            f(a, want);
            if (fabs(b->x - want[0]) > tol || fabs(b->y - want[1]) > tol ||
                fabs(b->z - want[2]) > tol)
                fail_msg("patch %u point %d: (%g %g %g), want (%g %g %g)", q, k, b->x, b->y, b->z,
                         want[0], want[1], want[2]);
        }
    }
}

static void up_one(const ts_vec4 *a, double out[3])
{
    out[0] = a->x, out[1] = a->y, out[2] = a->z + 1.0;
}

static void doubled(const ts_vec4 *a, double out[3])
{
    out[0] = 2.0 * a->x, out[1] = 2.0 * a->y, out[2] = 2.0 * a->z;
}

#define CUBE_FACES "[4 4 4 4 4 4] [0 1 3 2  2 3 5 4  4 5 7 6  6 7 1 0  1 7 5 3  6 0 2 4]"
#define CUBE_P(h)                                                                                  \
    "\"P\" [-" h " -" h " " h "  " h " -" h " " h "  -" h " " h " " h "  " h " " h " " h "  -" h   \
    " " h " -" h "  " h " " h " -" h "  -" h " -" h " -" h "  " h " -" h " -" h "]\n"

static void test_patch_mesh_and_subdivision(void **state)
{
    (void)state;
    ts_scene s, still;
    /* A 3 x 3 bilinear PatchMesh (4 patches) lifted by 1 at shutter close. */
    test_parse_rib_ok("WorldBegin\nMotionBegin [0 1]\n"
                      "PatchMesh \"bilinear\" 3 \"nonperiodic\" 3 \"nonperiodic\" \"P\" "
                      "[0 0 0 1 0 0 2 0 0  0 1 0 1 1 0.5 2 1 0  0 2 0 1 2 0 2 2 0]\n"
                      "PatchMesh \"bilinear\" 3 \"nonperiodic\" 3 \"nonperiodic\" \"P\" "
                      "[0 0 1 1 0 1 2 0 1  0 1 1 1 1 1.5 2 1 1  0 2 1 1 2 1 2 2 1]\n"
                      "MotionEnd\nWorldEnd\n",
                      &s);
    assert_int_equal(s.patch_count, 4);
    expect_moved(&s, up_one, 1e-6);
    scene_free(&s);
    /* A Catmull-Clark cube, its vertices twice as far out at shutter close: the ACC patches
     * are linear in the vertices, so every control point doubles; shutter open is the static
     * cube's, patch for patch. */
    test_parse_rib_ok("WorldBegin\nMotionBegin [0 1]\n"
                      "SubdivisionMesh \"catmull-clark\" " CUBE_FACES
                      " " CUBE_P("1") "SubdivisionMesh \"catmull-clark\" " CUBE_FACES
                                      " " CUBE_P("2") "MotionEnd\nWorldEnd\n",
                      &s);
    test_parse_rib_ok("WorldBegin\nSubdivisionMesh \"catmull-clark\" " CUBE_FACES
                      " " CUBE_P("1") "WorldEnd\n",
                      &still);
    assert_int_equal(s.patch_count, 6);
    assert_int_equal(still.patch_count, 6);
    assert_memory_equal(s.cp, still.cp, 6 * 16 * sizeof *s.cp);
    expect_moved(&s, doubled, 1e-6);
    scene_free(&s);
    scene_free(&still);
}

/* A sphere whose radius and thetamax change: in a motion block a quadric is always 4 x 4
 * patches, so the samples match; the shutter-close corners lie on the smaller sphere. */
static void test_quadric(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nMotionBegin [0 1]\nSphere 0.5 -0.5 0.5 360\n"
                      "Sphere 0.4 -0.4 0.4 270\nMotionEnd\nWorldEnd\n",
                      &s);
    assert_int_equal(s.patch_count, 16);
    static const int corner[4] = {0, 3, 12, 15};
    for (uint32_t q = 0; q < s.patch_count; q++) {
        assert_true(s.attr[q].flags & TS_PATCH_MOVING);
        for (int c = 0; c < 4; c++) {
            const ts_vec4 *a = &s.cp[q * 16 + (uint32_t)corner[c]];
            const ts_vec4 *b = &s.cp1[q * 16 + (uint32_t)corner[c]];
            assert_true(fabs(sqrt(a->x * a->x + a->y * a->y + a->z * a->z) - 0.5) < 1e-6);
            assert_true(fabs(sqrt(b->x * b->x + b->y * b->y + b->z * b->z) - 0.4) < 1e-6);
        }
    }
    scene_free(&s);
    /* Outside a motion block the sphere keeps its fewest pieces. */
    test_parse_rib_ok("WorldBegin\nSphere 0.5 -0.5 0.5 360\nWorldEnd\n", &s);
    assert_int_equal(s.patch_count, 8);
    scene_free(&s);
}

/* Patch q's corner 0 (point 0) at shutter open and close. */
static void expect_corner(const ts_scene *s, uint32_t q, const double open[3],
                          const double close[3], int moving)
{
    const ts_vec4 *a = &s->cp[(size_t)q * 16], *b = s->cp1 ? &s->cp1[(size_t)q * 16] : a;
    assert_int_equal((s->attr[q].flags & TS_PATCH_MOVING) != 0, moving);
    if (fabs(a->x - open[0]) > 1e-6 || fabs(a->y - open[1]) > 1e-6 || fabs(a->z - open[2]) > 1e-6 ||
        fabs(b->x - close[0]) > 1e-6 || fabs(b->y - close[1]) > 1e-6 ||
        fabs(b->z - close[2]) > 1e-6)
        fail_msg("patch %u: (%g %g %g) -> (%g %g %g), want (%g %g %g) -> (%g %g %g)", q, a->x, a->y,
                 a->z, b->x, b->y, b->z, open[0], open[1], open[2], close[0], close[1], close[2]);
}

#define FLAT_P "\"P\" [0 0 0 1 0 0 0 1 0 1 1 0]"
#define LIFTED_P "\"P\" [0 0 4 1 0 4 0 1 4 1 1 4]"

/* Shutter open close with a motion block of other times [t0 t1]: Tessera's two time samples
 * are the block's motion at open and close (a = (time - t0) / (t1 - t0) of the way), for a
 * moving transformation (the geometry's and the camera's), a Patch block, a deforming mesh,
 * and a deforming mesh under a moving transformation; an instant (Shutter 0 0, as RenderMan
 * for Maya writes it) leaves nothing moving; a Shutter past the block's times warns. */
static void test_shutter(void **state)
{
    (void)state;
    ts_scene s;
    /* A transformation from x = 0 to x = 4 over [0 1], seen from 0.25 to 0.75: x 1 to 3. */
    test_parse_rib_ok("Shutter 0.25 0.75\nWorldBegin\nMotionBegin [0 1]\nTranslate 0 0 0\n"
                      "Translate 4 0 0\nMotionEnd\nPatch \"bilinear\" " FLAT_P "\nWorldEnd\n",
                      &s);
    expect_corner(&s, 0, (double[3]){1, 0, 0}, (double[3]){3, 0, 0}, 1);
    scene_free(&s);
    /* The same over [2 4] seen from 3 to 4: x 2 to 4. */
    test_parse_rib_ok("Shutter 3 4\nWorldBegin\nMotionBegin [2 4]\nTranslate 0 0 0\n"
                      "Translate 4 0 0\nMotionEnd\nPatch \"bilinear\" " FLAT_P "\nWorldEnd\n",
                      &s);
    expect_corner(&s, 0, (double[3]){2, 0, 0}, (double[3]){4, 0, 0}, 1);
    scene_free(&s);
    /* An instant: RenderMan for Maya's Shutter 0 0 sees the block's first sample, still. */
    test_parse_rib_ok("Shutter 0 0\nWorldBegin\nMotionBegin [0 1]\nTranslate 0 0 0\n"
                      "Translate 4 0 0\nMotionEnd\nPatch \"bilinear\" " FLAT_P "\nWorldEnd\n",
                      &s);
    expect_corner(&s, 0, (double[3]){0, 0, 0}, (double[3]){0, 0, 0}, 0);
    scene_free(&s);
    /* A Patch block, z 0 to 4, seen from 0.5 to 1: z 2 to 4; in an instant, still. */
    test_parse_rib_ok("Shutter 0.5 1\nWorldBegin\nMotionBegin [0 1]\nPatch \"bilinear\" " FLAT_P
                      "\nPatch \"bilinear\" " LIFTED_P "\nMotionEnd\nWorldEnd\n",
                      &s);
    expect_corner(&s, 0, (double[3]){0, 0, 2}, (double[3]){0, 0, 4}, 1);
    scene_free(&s);
    test_parse_rib_ok("Shutter 0.5 0.5\nWorldBegin\nMotionBegin [0 1]\nPatch \"bilinear\" " FLAT_P
                      "\nPatch \"bilinear\" " LIFTED_P "\nMotionEnd\nWorldEnd\n",
                      &s);
    expect_corner(&s, 0, (double[3]){0, 0, 2}, (double[3]){0, 0, 2}, 0);
    scene_free(&s);
    /* A deforming PatchMesh, z 0 to 4, seen from 0.5 to 1: z 2 to 4. */
    const char *mesh = "MotionBegin [0 1]\nPatchMesh \"bilinear\" 2 \"nonperiodic\" 2 "
                       "\"nonperiodic\" " FLAT_P "\nPatchMesh \"bilinear\" 2 \"nonperiodic\" 2 "
                       "\"nonperiodic\" " LIFTED_P "\nMotionEnd\n";
    char text[1024];
    snprintf(text, sizeof text, "Shutter 0.5 1\nWorldBegin\n%sWorldEnd\n", mesh);
    test_parse_rib_ok(text, &s);
    expect_corner(&s, 0, (double[3]){0, 0, 2}, (double[3]){0, 0, 4}, 1);
    scene_free(&s);
    /* ... and under a transformation that moves x 0 to 4 meanwhile: at 0.5 x 2 and z 2, at 1
     * x 4 and z 4 (the surface at each time under that time's transformation). */
    snprintf(text, sizeof text,
             "Shutter 0.5 1\nWorldBegin\nMotionBegin [0 1]\nTranslate 0 0 0\nTranslate 4 0 0\n"
             "MotionEnd\n%sWorldEnd\n",
             mesh);
    test_parse_rib_ok(text, &s);
    expect_corner(&s, 0, (double[3]){2, 0, 2}, (double[3]){4, 0, 4}, 1);
    scene_free(&s);
    /* In an instant the deforming mesh is still too. */
    snprintf(text, sizeof text, "Shutter 0 0\nWorldBegin\n%sWorldEnd\n", mesh);
    test_parse_rib_ok(text, &s);
    expect_corner(&s, 0, (double[3]){0, 0, 0}, (double[3]){0, 0, 0}, 0);
    scene_free(&s);
    /* The camera: world_to_camera moves z by 0 to 2 over [0 1]; seen from 0 to 0.5: 0 to 1. */
    test_parse_rib_ok("Shutter 0 0.5\nMotionBegin [0 1]\nTranslate 0 0 0\nTranslate 0 0 2\n"
                      "MotionEnd\nWorldBegin\nWorldEnd\n",
                      &s);
    assert_true(s.camera.moving);
    assert_true(s.camera.world_to_camera[11] == 0.0 && s.camera.world_to_camera1[11] == 1.0);
    scene_free(&s);
    /* Without a Shutter, or with the block's own times, the block spans the exposure, without
     * a word; a Shutter reaching past the block's times warns once. */
    const char *moving = "WorldBegin\nMotionBegin [0 1]\nTranslate 0 0 0\nTranslate 1 0 0\n"
                         "MotionEnd\nMotionBegin [0 1]\nTranslate 0 0 0\nTranslate 1 0 0\n"
                         "MotionEnd\nWorldEnd\n";
    int rc;
    const char *out;
    for (int k = 0; k < 3; k++) {
        static const char *const shutter[3] = {"", "Shutter 0 1\n", "Shutter 0 0\n"};
        snprintf(text, sizeof text, "%s%s", shutter[k], moving);
        out = test_rib_warnings(text, &rc);
        assert_int_equal(rc, TS_OK);
        assert_string_equal(out, "");
    }
    snprintf(text, sizeof text, "Shutter 0 2\n%s", moving);
    out = test_rib_warnings(text, &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "w.rib:3:1: warning: Shutter 0 2 reaches past the motion block [0 1]: "
                             "its motion is spread over the whole exposure (RenderMan holds it "
                             "still outside the block)\n");
}

static void test_errors(void **state)
{
    (void)state;
    test_parse_rib_error(
        "WorldBegin\nMotionBegin [0 1]\n"
        "PatchMesh \"bilinear\" 2 \"nonperiodic\" 2 \"nonperiodic\" \"P\" [0 0 0 1 0 0 0 1 0 1 1 "
        "0]\n"
        "PatchMesh \"bilinear\" 3 \"nonperiodic\" 2 \"nonperiodic\" \"P\" "
        "[0 0 0 1 0 0 2 0 0 0 1 0 1 1 0 2 1 0]\nMotionEnd\n",
        "t.rib:4:1: error: PatchMesh: the second sample makes more patches than the first at "
        "3:1, 1 (the samples must have the same topology)");
    test_parse_rib_error(
        "WorldBegin\nMotionBegin [0 1]\n"
        "PatchMesh \"bilinear\" 3 \"nonperiodic\" 2 \"nonperiodic\" \"P\" "
        "[0 0 0 1 0 0 2 0 0 0 1 0 1 1 0 2 1 0]\n"
        "PatchMesh \"bilinear\" 2 \"nonperiodic\" 2 \"nonperiodic\" \"P\" [0 0 0 1 0 0 0 1 0 1 1 "
        "0]\n"
        "MotionEnd\n",
        "t.rib:3:1: error: MotionEnd: the second PatchMesh of the motion block at 2:1 makes 1 "
        "patches, the first 2 (the samples must have the same topology)");
    test_parse_rib_error("WorldBegin\nMotionBegin [0 1]\n"
                         "Polygon \"P\" [0 0 0 1 0 0 1 1 0 0.5 1.5 0 0 1 0]\n",
                         "t.rib:3:1: error: Polygon in a motion block: polygon 0 has more than 4 "
                         "vertices; only triangles and quads without holes move (the two samples "
                         "could be triangulated differently)");
    test_parse_rib_error("WorldBegin\nMotionBegin [0 1]\nSphere 1 -1 1 360\nCone 1 1 360\n",
                         "t.rib:4:1: error: Cone does not match the Sphere at 3:1 in the motion "
                         "block");
    test_parse_rib_error(
        "WorldBegin\nMotionBegin [0 1]\nColor 1 0 0\n",
        "t.rib:3:1: error: Color is not allowed in the motion block at 2:1 (only "
        "Patch, PatchMesh, SubdivisionMesh, NuPatch, polygons, quadrics, Points, Curves, "
        "Translate, Rotate, Scale, ConcatTransform or Transform)");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_patch_mesh_and_subdivision),
        cmocka_unit_test(test_quadric),
        cmocka_unit_test(test_shutter),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
