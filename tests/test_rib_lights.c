/* test_rib_lights.c — LightSource as RenderMan files write it (issue 16): pointlight,
 * spotlight, ambientlight with their defaults and the CTM, the names mapped onto them
 * (shadowspot, shadowpoint, shadowdistant, uberlight) with their warnings, and the errors.
 * Host only: never skips. Every test asserts numbers or exact messages. */
#include "scene/rib/rib.h"
#include "scene/scene.h"
#include "lib/lights.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

#define QUAD "Patch \"bilinear\" \"P\" [0 0 0  1 0 0  0 1 0  1 1 0]\n"

static void assert_dvec(const double *v, double x, double y, double z, double tol)
{
    if (!(fabs(v[0] - x) <= tol && fabs(v[1] - y) <= tol && fabs(v[2] - z) <= tol))
        fail_msg("got (%.17g %.17g %.17g), want (%g %g %g)", v[0], v[1], v[2], x, y, z);
}

/* text must fail to parse with exactly msg. */
static void expect_error(const char *text, const char *msg)
{
    ts_scene s;
    ts_error e = {0};
    assert_int_equal(test_parse_rib(text, &s, &e), TS_E_SCENE);
    if (strcmp(e.msg, msg) != 0) fail_msg("got \"%s\", want \"%s\"", e.msg, msg);
    assert_int_equal(s.light_count, 0);
    ts_error_clear(&e);
}

/* pointlight.sl: intensity 1, lightcolor 1, from (0 0 0) in the current space; 1 / d^2. */
static void test_point_light(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nTranslate 1 2 3\nLightSource \"pointlight\" 1\n"
                      "LightSource \"pointlight\" 2 \"float intensity\" [40] \"color lightcolor\" "
                      "[1 0.5 0.25] \"point from\" [0 0 -2]\n" QUAD "WorldEnd\n",
                      &s);
    assert_int_equal(s.light_count, 2);
    const ts_scene_light *a = &s.lights[0], *b = &s.lights[1];
    assert_int_equal(a->kind, SCENE_LIGHT_POINT);
    assert_dvec(a->from, 1, 2, 3, 0);
    assert_true(a->intensity == 1.0);
    assert_dvec(a->color, 1, 1, 1, 0);
    assert_true(a->falloff == 2.0 && a->falloff_dist == 1.0 && a->falloff_min == 0.0);
    assert_dvec(b->from, 1, 2, 1, 0);
    assert_true(b->intensity == 40.0);
    assert_dvec(b->color, 1, 0.5, 0.25, 0);
    scene_free(&s);
}

/* spotlight.sl: from (0 0 0), to (0 0 1), coneangle 30 degrees, conedeltaangle 5 degrees,
 * beamdistribution 2, placed by the CTM; before WorldBegin in camera space, moved to world
 * space at WorldBegin. */
static void test_spot_light(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nRotate 90 0 1 0\nLightSource \"spotlight\" 1\n"
                      "LightSource \"spotlight\" 2 \"intensity\" [300] \"from\" [2 4.5 20] \"to\" "
                      "[0 -1.5 0] \"coneangle\" [0.38] \"conedeltaangle\" [0.5] "
                      "\"beamdistribution\" [1]\n" QUAD "WorldEnd\n",
                      &s);
    assert_int_equal(s.light_count, 2);
    const ts_scene_light *a = &s.lights[0], *b = &s.lights[1];
    assert_int_equal(a->kind, SCENE_LIGHT_SPOT);
    assert_dvec(a->from, 0, 0, 0, 0);
    assert_dvec(a->to, 1, 0, 0, 1e-15); /* Rotate 90 about y takes +z to +x */
    assert_true(fabs(a->cone_angle - M_PI / 6) < 1e-15 && fabs(a->cone_delta - M_PI / 36) < 1e-15);
    assert_true(a->beam == 2.0 && a->falloff == 2.0 && a->falloff_dist == 1.0);
    assert_dvec(b->from, 20, 4.5, -2, 1e-14);
    assert_dvec(b->to, 0, -1.5, 0, 1e-15);
    /* A delta wider than the cone is clamped to it: the soft edge reaches the axis. */
    assert_true(b->cone_angle == 0.38 && b->cone_delta == 0.38 && b->beam == 1.0);
    scene_free(&s);
    test_parse_rib_ok("LightSource \"spotlight\" 1 \"from\" [0 0 0] \"to\" [0 0 1]\n"
                      "Translate 0 0 5\nRotate 90 0 1 0\nWorldBegin\n" QUAD "WorldEnd\n",
                      &s);
    assert_dvec(s.lights[0].from, 5, 0, 0, 1e-12); /* the camera's origin in world space */
    assert_dvec(s.lights[0].to, 4, 0, 0, 1e-12);
    scene_free(&s);
}

/* ambientlight.sl: intensity * lightcolor; several stay separate lights in the scene (the
 * light table adds them up). */
static void test_ambient_light(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nLightSource \"ambientlight\" 1 \"intensity\" [0.2]\n"
                      "LightSource \"ambientlight\" 2 \"lightcolor\" [0.1 0.2 0.3]\n" QUAD
                      "WorldEnd\n",
                      &s);
    assert_int_equal(s.light_count, 2);
    assert_int_equal(s.lights[0].kind, SCENE_LIGHT_AMBIENT);
    assert_true(s.lights[0].intensity == 0.2);
    assert_dvec(s.lights[1].color, 0.1, 0.2, 0.3, 0);
    scene_free(&s);
}

/* Lights with shadow maps are drawn as the standard light they extend, one warning per name
 * and one per parameter they add. */
static void test_shadow_lights_warn(void **state)
{
    (void)state;
    int rc;
    const char *w = test_rib_warnings(
        "LightSource \"shadowspot\" 1 \"intensity\" [5] \"shadowname\" [\"key.shd\"]\n"
        "LightSource \"shadowspot\" 2 \"shadowname\" [\"fill.shd\"]\n"
        "LightSource \"shadowpoint\" 3\nLightSource \"shadowdistant\" 4 \"from\" [0 1 0]\n",
        &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(
        w, "w.rib:1:1: warning: LightSource \"shadowspot\" is drawn as \"spotlight\" (shadows "
           "are ray traced; its shadow map parameters are ignored)\n"
           "w.rib:1:44: warning: LightSource parameter \"shadowname\" is ignored\n"
           "w.rib:3:1: warning: LightSource \"shadowpoint\" is drawn as \"pointlight\" (shadows "
           "are ray traced; its shadow map parameters are ignored)\n"
           "w.rib:4:1: warning: LightSource \"shadowdistant\" is drawn as \"distantlight\" "
           "(shadows are ray traced; its shadow map parameters are ignored)\n");
    ts_scene s;
    test_parse_rib_ok("LightSource \"shadowspot\" 1 \"intensity\" [5] \"coneangle\" [0.25]\n"
                      "LightSource \"shadowpoint\" 3\nLightSource \"shadowdistant\" 4\n",
                      &s);
    assert_int_equal(s.lights[0].kind, SCENE_LIGHT_SPOT);
    assert_true(s.lights[0].intensity == 5.0 && s.lights[0].cone_angle == 0.25);
    assert_int_equal(s.lights[1].kind, SCENE_LIGHT_POINT);
    assert_int_equal(s.lights[2].kind, SCENE_LIGHT_DISTANT);
    scene_free(&s);
    /* Any other light shader: ignored, naming the ones Tessera draws. */
    w = test_rib_warnings("LightSource \"windowlight\" 1\nLightSource \"windowlight\" 2\n", &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(w, "w.rib:1:1: warning: LightSource \"windowlight\" is ignored "
                           "(ambientlight, distantlight, pointlight, spotlight, domelight)\n");
}

/* uberlight (Advanced RenderMan): at the current space's origin looking down +z; "omni" a
 * point light, "spot" (the default) a spot whose round cone has the area of the
 * width x height cross-section; falloff (falloffdist / d)^falloff, none by default. */
static void test_uberlight(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nTranslate 0 4 0\nRotate 90 1 0 0\n"
                      "LightSource \"uberlight\" 1 \"string lighttype\" [\"omni\"] "
                      "\"intensity\" [0.1]\n"
                      "LightSource \"uberlight\" 2 \"width\" [0.25] \"height\" [0.16] "
                      "\"wedge\" [0.05] \"hedge\" [0.14] \"falloff\" [2] \"falloffdist\" [3] "
                      "\"beamdistribution\" [1]\n" QUAD "WorldEnd\n",
                      &s);
    const ts_scene_light *o = &s.lights[0], *u = &s.lights[1];
    assert_int_equal(o->kind, SCENE_LIGHT_POINT);
    assert_dvec(o->from, 0, 4, 0, 0);
    assert_true(o->intensity == 0.1 && o->falloff == 0.0 && o->falloff_min == 0.0);
    assert_int_equal(u->kind, SCENE_LIGHT_SPOT);
    assert_dvec(u->to, 0, 3, 0, 1e-15);                   /* Rotate 90 about x takes +z to -y */
    assert_true(fabs(u->cone_angle - atan(0.3)) < 1e-15); /* sqrt(0.3 * 0.3) */
    assert_true(fabs(u->cone_angle - u->cone_delta - atan(0.2)) < 1e-15); /* sqrt(0.25 0.16) */
    assert_true(u->beam == 1.0 && u->falloff == 2.0 && u->falloff_dist == 3.0 &&
                u->falloff_min == 3.0);
    scene_free(&s);
    int rc;
    const char *w = test_rib_warnings("LightSource \"uberlight\" 1 \"lighttype\" [\"arealight\"] "
                                      "\"roundness\" [0]\nLightSource \"uberlight\" 2 \"width\" "
                                      "[2]\n",
                                      &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(
        w, "w.rib:1:1: warning: LightSource \"uberlight\" is drawn as a spotlight down +z, or a "
           "pointlight for lighttype \"omni\" (shadows are ray traced; cuton, cutoff, shear, "
           "roundness, blockers, slides and noise are ignored)\n"
           "w.rib:1:39: warning: LightSource \"uberlight\": lighttype \"arealight\" is drawn as "
           "\"omni\" (spot or omni)\n"
           "w.rib:1:53: warning: LightSource parameter \"roundness\" is ignored\n"
           "w.rib:2:1: warning: LightSource \"uberlight\": the cross-section is drawn as a circle "
           "of the same area (width x height)\n");
}

/* A coneangle over pi (degrees where radians are due): a warning, and the light spotlight.sl
 * makes of it — lit where cos(angle to the axis) >= cos(coneangle), a hard edge where
 * cos(coneangle - conedeltaangle) is the smaller; with --strict the error. */
static void test_spot_cone_over_pi(void **state)
{
    (void)state;
    const char *text = "WorldBegin\nLightSource \"spotlight\" 1 \"coneangle\" [50]\n"
                       "Patch \"bilinear\" \"P\" [0 0 0 1 0 0 0 1 0 1 1 0]\nWorldEnd\n";
    int rc;
    const char *w = test_rib_warnings(text, &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(w, "w.rib:2:1: warning: LightSource \"spotlight\": coneangle 50 is "
                           "outside (0, pi] (radians): lit as spotlight.sl computes it, where "
                           "cos(angle) >= cos(50) (--strict makes this an error)\n");
    ts_scene s;
    ts_error e = {0};
    assert_int_equal(test_parse_rib(text, &s, &e), TS_OK);
    assert_int_equal(s.light_count, 1);
    assert_true(s.lights[0].cone_angle == 50.0);
    scene_free(&s);
    assert_int_equal(test_parse_rib_strict(text, &s, &e), TS_E_SCENE);
    assert_string_equal(e.msg, "t.rib:2:1: error: LightSource \"spotlight\": coneangle 50 is "
                               "outside (0, pi] (radians)");
    ts_error_clear(&e);
    /* The kernel's falloff (lib/lights.h): cos(50) = 0.96497 > cos(50 - 5 degrees) = 0.93875,
     * a step at cos(50): lit at 10 degrees from the axis, dark at 20. */
    float c_max = (float)cos(50.0), c_in = (float)cos(50.0 - 5.0 * M_PI / 180.0);
    assert_true(c_in < c_max);
    assert_true(light_smoothstep(c_max, c_in, (float)cos(10.0 * M_PI / 180.0)) == 1.0f);
    assert_true(light_smoothstep(c_max, c_in, (float)cos(20.0 * M_PI / 180.0)) == 0.0f);
}

static void test_light_errors(void **state)
{
    (void)state;
    expect_error("LightSource \"shadowspot\" 1 \"coneangle\" [0]\n",
                 "t.rib:1:1: error: LightSource \"shadowspot\": coneangle 0 is outside (0, pi] "
                 "(radians)");
    expect_error("LightSource \"spotlight\" 1 \"conedeltaangle\" [-0.1]\n",
                 "t.rib:1:1: error: LightSource \"spotlight\": conedeltaangle and "
                 "beamdistribution must be >= 0 and finite, got -0.1 and 2");
    expect_error("LightSource \"pointlight\" 1 \"intensity\" [-3]\n",
                 "t.rib:1:1: error: LightSource \"pointlight\": intensity and lightcolor must be "
                 ">= 0 and finite, got -3 and [1 1 1]");
    expect_error("LightSource \"ambientlight\" 1 \"lightcolor\" [1 -1 1]\n",
                 "t.rib:1:1: error: LightSource \"ambientlight\": intensity and lightcolor must "
                 "be >= 0 and finite, got 1 and [1 -1 1]");
    expect_error("LightSource \"spotlight\" 1 \"from\" [1 2 3] \"to\" [1 2 3]\n",
                 "t.rib:1:1: error: LightSource: spotlight \"from\" and \"to\" are the same "
                 "point");
    expect_error("LightSource \"uberlight\" 1 \"width\" [0]\n",
                 "t.rib:1:1: error: LightSource \"uberlight\": width and height must be > 0; "
                 "wedge, hedge, falloff, falloffdist and beamdistribution >= 0 and finite");
    expect_error("LightSource \"pointlight\" 1 \"from\" [0 0]\n",
                 "t.rib:1:35: error: LightSource: parameter \"from\" needs 3 values, got 2");
    expect_error("WorldBegin\nWorldEnd\nLightSource \"pointlight\" 1\n",
                 "t.rib:3:1: error: LightSource after WorldEnd");
}

/* scene/lights.rib loads its four lights: ambient, spot, point, and the uberlight as a point
 * light placed by its own transformation (world (3.2, -0.5, 3)). */
static void test_lights_scene(void **state)
{
    (void)state;
    ts_scene s;
    ts_error e = {0};
    memset(&s, 0, sizeof s);
    if (rib_load(test_source_path("scene/lights.rib"), &s, 1, &e) != TS_OK) fail_msg("%s", e.msg);
    assert_int_equal(s.light_count, 4);
    assert_int_equal(s.lights[0].kind, SCENE_LIGHT_AMBIENT);
    assert_int_equal(s.lights[1].kind, SCENE_LIGHT_SPOT);
    assert_int_equal(s.lights[2].kind, SCENE_LIGHT_POINT);
    assert_int_equal(s.lights[3].kind, SCENE_LIGHT_POINT);
    assert_dvec(s.lights[3].from, 3.2, -0.5, 3, 1e-12);
    assert_dvec(s.lights[3].to, 3.2, -0.5, 2, 1e-12);
    assert_true(s.lights[3].falloff == 0.0);
    assert_false(s.dome.present);
    assert_int_equal(s.patch_count, 1 + 3 * 32);
    scene_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_point_light),   cmocka_unit_test(test_spot_light),
        cmocka_unit_test(test_ambient_light), cmocka_unit_test(test_shadow_lights_warn),
        cmocka_unit_test(test_uberlight),     cmocka_unit_test(test_spot_cone_over_pi),
        cmocka_unit_test(test_light_errors),  cmocka_unit_test(test_lights_scene),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
