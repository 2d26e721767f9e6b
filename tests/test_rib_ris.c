/* test_rib_ris.c — RIB as RenderMan 21-26 writes it (issue 39 items 2, 7, 8): Integrator,
 * Option "Ri", Camera, Projection "PxrPerspective", DisplayFilter/SampleFilter/Hider;
 * IfBegin/ElseIf/Else/IfEnd with their expressions, ScopedCoordinateSystem, Procedural2
 * "DelayedReadArchive2", Option "searchpath". Host only: never skips; every test asserts the
 * parsed values or exact messages. */
#include "scene/rib/rib.h"
#include "scene/scene.h"
#include "scene/scene_load.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

#define QUAD TEST_RIB_QUAD

/* ---- the RIS frame ---------------------------------------------------------------------- */

static void test_integrator(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("Integrator \"PxrPathTracer\" \"handle\" \"int maxPathLength\" [7] "
                      "\"int numLightSamples\" [2]\nWorldBegin\n" QUAD "WorldEnd\n",
                      &s);
    assert_int_equal(s.camera.has_depth, 1);
    assert_int_equal(s.camera.depth, 7);
    scene_free(&s);
    test_parse_rib_ok("WorldBegin\n" QUAD "WorldEnd\n", &s);
    assert_int_equal(s.camera.has_depth, 0);
    scene_free(&s);
    int rc;
    const char *out = test_rib_warnings("Integrator \"PxrVCM\" \"h\" \"int maxPathLength\" [5]\n"
                                        "Integrator \"PxrVCM\" \"h\"\nWorldBegin\nWorldEnd\n",
                                        &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "w.rib:1:12: warning: Integrator \"PxrVCM\" renders as PxrPathTracer "
                             "(path tracing)\n");
    /* PxrPathTracer's sample counts and roulette steer the noise only: no word; what biases
     * the image (clampLuminance) warns */
    out = test_rib_warnings("Integrator \"PxrPathTracer\" \"h\" \"int numLightSamples\" [4] "
                            "\"int numBxdfSamples\" [2] \"int rouletteDepth\" [3] "
                            "\"float clampLuminance\" [10]\nWorldBegin\nWorldEnd\n",
                            &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "w.rib:1:107: warning: Integrator parameter \"clampLuminance\" is "
                             "ignored\n");
    test_parse_rib_error("Integrator \"PxrPathTracer\" \"h\" \"int maxPathLength\" [2.5]",
                         "t.rib:1:52: error: Integrator: maxPathLength must be an integer in [0, "
                         "64], got 2.5");
    test_parse_rib_error("WorldBegin Integrator \"PxrPathTracer\" \"h\"",
                         "t.rib:1:12: error: Integrator must come before WorldBegin");
}

static void test_option_ri(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("Option \"Ri\" \"int FormatResolution\" [320 200] \"float "
                      "FormatPixelAspectRatio\" [1] \"float CropWindow\" [0.25 0.75 0 0.5] "
                      "\"float Shutter\" [0 0.5] \"float[4] ScreenWindow\" [-2 2 -1 1]\n"
                      "WorldBegin\n" QUAD "WorldEnd\n",
                      &s);
    assert_int_equal(s.camera.has_format, 1);
    assert_int_equal(s.camera.width, 320);
    assert_int_equal(s.camera.height, 200);
    assert_true(s.camera.crop[0] == 0.25 && s.camera.crop[1] == 0.75 && s.camera.crop[2] == 0 &&
                s.camera.crop[3] == 0.5);
    assert_true(s.camera.shutter[0] == 0 && s.camera.shutter[1] == 0.5);
    assert_int_equal(s.camera.has_screen, 1);
    assert_true(s.camera.screen[0] == -2 && s.camera.screen[3] == 1);
    scene_free(&s);
    /* An aspect alone keeps the Format given before; a resolution alone the default aspect. */
    test_parse_rib_ok("Format 64 48 1\nOption \"Ri\" \"float FormatPixelAspectRatio\" [1]\n"
                      "WorldBegin\n" QUAD "WorldEnd\n",
                      &s);
    assert_int_equal(s.camera.width, 64);
    assert_int_equal(s.camera.height, 48);
    scene_free(&s);
    /* The checks of the classic requests, at the option's value. */
    test_parse_rib_error("Option \"Ri\" \"float CropWindow\" [0.5 0.25 0 1]",
                         "t.rib:1:32: error: CropWindow: need 0 <= min < max <= 1 on both axes, "
                         "got 0.5 0.25 0 1");
    test_parse_rib_error("Option \"Ri\" \"int FormatResolution\" [0.5 10]",
                         "t.rib:1:36: error: Format: xresolution must be an integer in [1, 65536] "
                         "(or -1: the default), got 0.5");
    test_parse_rib_error("Option \"Ri\" \"float Shutter\" [1]",
                         "t.rib:1:29: error: Option: parameter \"Shutter\" needs 2 values, got 1");
    int rc;
    const char *out = test_rib_warnings(
        "Option \"Ri\" \"float FormatPixelAspectRatio\" [2] \"int PixelVariance\" [1]\n"
        "Option \"Ri\" \"float Shutter\" [0 1]\nWorldBegin\nWorldEnd\n",
        &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "w.rib:1:48: warning: Option parameter \"PixelVariance\" is ignored\n"
                             "w.rib:1:44: warning: Format pixel aspect ratio is ignored\n");
}

static void test_camera_projection(void **state)
{
    (void)state;
    ts_scene s;
    /* Camera names the camera's coordinate system; PxrPerspective's fov is the fov. */
    test_parse_rib_ok("Projection \"PxrPerspective\" \"float fov\" [35] \"float fStop\" [2.8]\n"
                      "Translate 0 0 5\nCamera \"main\" \"float[2] shutterOpening\" [0 1]\n"
                      "WorldBegin\nCoordSysTransform \"main\"\n" QUAD "WorldEnd\n",
                      &s);
    assert_true(s.camera.fov_deg == 35.0);
    assert_int_equal(s.camera.projection, TS_PROJECTION_PERSPECTIVE);
    /* The patch placed in the camera's frame: at the camera, 5 units behind the origin. */
    assert_true(s.cp[0].x == 0.0f && s.cp[0].y == 0.0f && s.cp[0].z == -5.0f);
    scene_free(&s);
    /* PxrCamera (RenderMan 22+) the same: its fov, a pinhole */
    test_parse_rib_ok("Projection \"PxrCamera\" \"float fov\" [28]\nWorldBegin\n" QUAD "WorldEnd\n",
                      &s);
    assert_true(s.camera.fov_deg == 28.0);
    assert_int_equal(s.camera.projection, TS_PROJECTION_PERSPECTIVE);
    scene_free(&s);
    int rc;
    const char *out = test_rib_warnings(
        "Projection \"PxrPerspective\" \"float fov\" [35] \"float fStop\" [2.8] "
        "\"float focalDistance\" [3]\nCamera \"c\" \"float[2] shutterOpening\" [0.1 0.9]\n"
        "DisplayFilter \"PxrBackgroundDisplayFilter\" \"bg\"\n"
        "DisplayFilter \"PxrBackgroundDisplayFilter\" \"bg2\"\n"
        "SampleFilter \"PxrCryptomatte\" \"c\"\nHider \"raytrace\" \"int minsamples\" [4]\n"
        "WorldBegin\nWorldEnd\n",
        &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(
        out, "w.rib:1:66: warning: Projection \"PxrPerspective\": depth of field needs fStop, "
             "focalLength and focalDistance together: the camera stays as it was\n"
             "w.rib:2:12: warning: Camera parameter \"shutterOpening\" is ignored\n"
             "w.rib:3:1: warning: DisplayFilter \"PxrBackgroundDisplayFilter\" is ignored\n"
             "w.rib:5:1: warning: SampleFilter \"PxrCryptomatte\" is ignored\n"
             "w.rib:6:1: warning: Hider \"raytrace\" is ignored\n");
    /* RenderMan for Maya's shutterOpening [0 1] is Tessera's shutter: no word */
    out = test_rib_warnings(
        "Camera \"world\" \"float[2] shutteropening\" [0 1]\nWorldBegin\nWorldEnd\n", &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "");
}

/* ---- structure ---------------------------------------------------------------------------- */

/* The patches a text makes (0 on error, which fails the test). */
static uint32_t patches_of(const char *text)
{
    ts_scene s;
    test_parse_rib_ok(text, &s);
    uint32_t n = s.patch_count;
    scene_free(&s);
    return n;
}

/* A condition under Option "user" pass = "beauty", frame = 3: 1 patch when true, 2 when false. */
static uint32_t cond(const char *expr)
{
    char text[2048];
    snprintf(text, sizeof text,
             "Option \"user\" \"string pass\" [\"beauty\"] \"int frame\" [3]\nWorldBegin\n" QUAD
             "IfBegin \"%s\"\nElse\n" QUAD "IfEnd\nWorldEnd\n",
             expr);
    return patches_of(text);
}

static void test_conditions(void **state)
{
    (void)state;
    assert_int_equal(cond("1"), 1);
    assert_int_equal(cond("0"), 2);
    assert_int_equal(cond("$pass == 'beauty'"), 1);
    assert_int_equal(cond("$user:pass == 'beauty'"), 1);
    assert_int_equal(cond("$pass != 'beauty'"), 2);
    assert_int_equal(cond("$frame > 2 && $frame < 4"), 1);
    assert_int_equal(cond("$frame >= 4 || $frame <= 2"), 2);
    assert_int_equal(cond("!($frame == 3)"), 2);
    assert_int_equal(cond("$pass =~ 'bea.*'"), 1);
    assert_int_equal(cond("$pass =~ '^shadow'"), 2);
    assert_int_equal(cond("$pass =~ '^b[a-z]{2,3}uty$'"), 1); /* small counts are fine */
    assert_int_equal(cond("$pass =~ '^(b|e|a){3}ut[{]?y'"), 1);
    /* What makes glibc's matcher slow is refused: a back-reference (40 s on 255 bytes) and
     * nested counts (copied per count: this one did not compile in minutes). */
    test_parse_rib_error(
        "IfBegin \"'aa' =~ '(a*)*\\\\1b'\"",
        "t.rib:1:9: error: IfBegin: condition \"'aa' =~ '(a*)*\\1b'\": a regular "
        "expression '(a*)*\\1b' with a back-reference (\\1 to \\9): not supported");
    test_parse_rib_error("IfBegin \"'a' =~ '((a{1,255}){1,255}){1,255}'\"",
                         "t.rib:1:9: error: IfBegin: condition \"'a' =~ "
                         "'((a{1,255}){1,255}){1,255}'\": a regular expression "
                         "'((a{1,255}){1,255}){1,255}' with repetition counts {m,n} that "
                         "multiply past 1000: not supported");
    assert_int_equal(cond("defined(pass) && !defined(nothing)"), 1);
    assert_int_equal(cond("$nothing"), 2);   /* undefined: the empty string, false */
    assert_int_equal(cond("10 < 9"), 2);     /* numbers compare as numbers */
    assert_int_equal(cond("'10' < '9'"), 1); /* strings as strings */
    /* ElseIf chains, nesting, a branch not taken is not evaluated. */
    const char *chain = "Option \"user\" \"int n\" [2]\nWorldBegin\n"
                        "IfBegin \"$n == 1\"\n" QUAD "ElseIf \"$n == 2\"\n" QUAD QUAD
                        "  IfBegin \"$n == 2\"\n" QUAD "  IfEnd\n"
                        "ElseIf \"$n >= 2\"\n" QUAD "Else\n" QUAD "IfEnd\n"
                        "IfBegin \"0\"\n  IfBegin \"((( bad\"\n" QUAD "  IfEnd\nIfEnd\nWorldEnd\n";
    assert_int_equal(patches_of(chain), 3);
    /* Attribute "user" is scoped to its attribute block. */
    const char *scoped =
        "Option \"user\" \"string a\" [\"x\"]\nWorldBegin\nAttributeBegin\n"
        "Attribute \"user\" \"string a\" [\"y\"]\nIfBegin \"$a == 'y'\"\n" QUAD
        "IfEnd\nAttributeEnd\nIfBegin \"$a == 'x'\"\n" QUAD QUAD "IfEnd\nWorldEnd\n";
    assert_int_equal(patches_of(scoped), 3);
    test_parse_rib_error("IfBegin \"1 ==\"", "t.rib:1:9: error: IfBegin: condition \"1 ==\": an "
                                             "operand missing at the end");
    test_parse_rib_error("IfBegin \"(1\"", "t.rib:1:9: error: IfBegin: condition \"(1\": '(' "
                                           "without ')'");
    test_parse_rib_error("IfBegin \"1 2\"", "t.rib:1:9: error: IfBegin: condition \"1 2\": "
                                            "unexpected '2' after the expression");
    test_parse_rib_error("IfBegin \"1\"\nWorldBegin WorldEnd",
                         "t.rib:1:1: error: IfBegin without IfEnd before the end of the file");
    test_parse_rib_error("IfEnd", "t.rib:1:1: error: IfEnd without IfBegin");
    test_parse_rib_error("IfBegin \"1\" Else Else IfEnd",
                         "t.rib:1:18: error: a second Else (IfBegin at 1:1)");
    test_parse_rib_error("IfBegin \"1\" Else ElseIf \"1\" IfEnd",
                         "t.rib:1:18: error: ElseIf after Else (IfBegin at 1:1)");
}

static void test_scoped_coordinate_system(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nTranslate 1 0 0\nCoordinateSystem \"a\"\nAttributeBegin\n"
                      "Translate 0 2 0\nScopedCoordinateSystem \"a\"\nIdentity\n"
                      "CoordSysTransform \"a\"\n" QUAD "AttributeEnd\nIdentity\n"
                      "CoordSysTransform \"a\"\n" QUAD "WorldEnd\n",
                      &s);
    assert_int_equal(s.patch_count, 2);
    assert_true(s.cp[0].x == 1.0f && s.cp[0].y == 2.0f);   /* the scoped system */
    assert_true(s.cp[16].x == 1.0f && s.cp[16].y == 0.0f); /* the outer one again */
    scene_free(&s);
    test_parse_rib_error("WorldBegin\nAttributeBegin\nScopedCoordinateSystem \"b\"\nAttributeEnd\n"
                         "CoordSysTransform \"b\"\nWorldEnd\n",
                         "t.rib:5:19: error: CoordSysTransform: no coordinate system \"b\" "
                         "(CoordinateSystem \"b\" must come before; or world, camera, object)");
}

/* Resource "attributes": save and restore the graphics state by name, whole or by subset;
 * a save inside ResourceBegin/ResourceEnd is forgotten at ResourceEnd; the errors. */
static void test_attribute_resources(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nAttributeBegin\nColor [1 0 0]\nTranslate 0 0 5\n"
                      "Resource \"red\" \"attributes\" \"string operation\" \"save\"\n"
                      "AttributeEnd\nResourceBegin\nColor [0 1 0]\n"
                      "Resource \"red\" \"attributes\" \"string operation\" [\"save\"]\n"
                      "ResourceEnd\n"
                      "Resource \"red\" \"attributes\" \"string operation\" \"restore\" "
                      "\"string subset\" \"shading\"\n" QUAD
                      "Resource \"red\" \"attributes\" \"string operation\" \"restore\"\n" QUAD
                      "Color [0 0 1]\nIdentity\n"
                      "Resource \"red\" \"attributes\" \"string operation\" \"restore\" "
                      "\"string subset\" \"transform\"\n" QUAD "WorldEnd\n",
                      &s);
    assert_int_equal(s.patch_count, 3);
    /* the shading alone: red (the green save ended with its block), not moved */
    assert_true(s.attr[0].cs_r == 1.0f && s.attr[0].cs_g == 0.0f && s.cp[0].z == 0.0f);
    /* all: red and moved */
    assert_true(s.attr[1].cs_r == 1.0f && s.cp[16].z == 5.0f);
    /* the transform alone: moved, the blue kept */
    assert_true(s.attr[2].cs_b == 1.0f && s.attr[2].cs_r == 0.0f && s.cp[32].z == 5.0f);
    scene_free(&s);
    test_parse_rib_error("WorldBegin\nResourceBegin\n"
                         "Resource \"a\" \"attributes\" \"string operation\" \"save\"\n"
                         "ResourceEnd\n"
                         "Resource \"a\" \"attributes\" \"string operation\" \"restore\"\n",
                         "t.rib:5:10: error: Resource \"a\" is restored but was never saved (or "
                         "its ResourceBegin block has ended)");
    test_parse_rib_error("WorldBegin\nResourceEnd\n",
                         "t.rib:2:1: error: ResourceEnd without a ResourceBegin");
    test_parse_rib_error("WorldBegin\nResource \"a\" \"attributes\" \"string operation\" "
                         "\"keep\"\n",
                         "t.rib:2:46: error: Resource: operation \"keep\" is not save or restore");
}

/* An empty texture name is no texture, as RenderMan's shaders take it: untextured, no
 * warning (it was an error: "" names the file's own directory). */
static void test_empty_texture_name(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok(
        "WorldBegin\nSurface \"plastic\" \"string texturename\" [\"\"]\n" QUAD "WorldEnd\n", &s);
    assert_int_equal(s.patch_count, 1);
    assert_int_equal(s.attr[0].flags & TS_PATCH_COLOR_TEX, 0);
    scene_free(&s);
    int rc;
    const char *w = test_rib_warnings("Surface \"matte\" \"string texturename\" [\"\"]", &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(w, "");
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

/* A relative archive name not beside the file naming it is found in the working directory,
 * as RenderMan finds it (RenderMan for Maya: paths relative to the project, rendered from
 * there); beside the file still comes first. */
static void test_relative_names_from_the_working_directory(void **state)
{
    (void)state;
    const char *dir = test_scratch_dir();
    char cmd[4500], path[4500], top[4500], old[4096];
    snprintf(cmd, sizeof cmd, "mkdir -p '%s/proj/rib' '%s/proj/archives'", dir, dir);
    assert_int_equal(system(cmd), 0);
    snprintf(path, sizeof path, "%s/proj/archives/part.rib", dir);
    write_text(path, QUAD QUAD QUAD);
    snprintf(top, sizeof top, "%s/proj/rib/top.rib", dir);
    write_text(top, "WorldBegin\nReadArchive \"archives/part.rib\"\nWorldEnd\n");
    assert_non_null(getcwd(old, sizeof old));
    snprintf(path, sizeof path, "%s/proj", dir);
    assert_int_equal(chdir(path), 0);
    ts_scene s;
    memset(&s, 0, sizeof s);
    ts_error err = {0};
    int rc = scene_load(top, &s, 1, &err);
    assert_int_equal(chdir(old), 0);
    if (rc) fail_msg("%s", err.msg);
    assert_int_equal(s.patch_count, 3);
    scene_free(&s);
    /* beside the file first: a part.rib there wins */
    snprintf(cmd, sizeof cmd, "mkdir -p '%s/proj/rib/archives'", dir);
    assert_int_equal(system(cmd), 0);
    snprintf(path, sizeof path, "%s/proj/rib/archives/part.rib", dir);
    write_text(path, QUAD);
    snprintf(path, sizeof path, "%s/proj", dir);
    assert_int_equal(chdir(path), 0);
    memset(&s, 0, sizeof s);
    rc = scene_load(top, &s, 1, &err);
    assert_int_equal(chdir(old), 0);
    if (rc) fail_msg("%s", err.msg);
    assert_int_equal(s.patch_count, 1);
    scene_free(&s);
}

static void test_procedural2_and_searchpath(void **state)
{
    (void)state;
    const char *dir = test_scratch_dir();
    char sub[4400], path[4500], top[4500];
    snprintf(sub, sizeof sub, "%s/archives", dir);
    char cmd[4500];
    snprintf(cmd, sizeof cmd, "mkdir -p '%s'", sub);
    assert_int_equal(system(cmd), 0);
    snprintf(path, sizeof path, "%s/part.rib", sub);
    write_text(path, QUAD QUAD);
    snprintf(top, sizeof top, "%s/top.rib", dir);
    /* Procedural2 with a bound function name and without; the archive found through the
     * searchpath ("&" keeps the previous one). */
    write_text(top, "Option \"searchpath\" \"string archive\" [\"nowhere:@\"]\n"
                    "Option \"searchpath\" \"string archive\" [\"archives:&\"]\nWorldBegin\n"
                    "Procedural2 \"DelayedReadArchive2\" \"SimpleBound\" \"string filename\" "
                    "[\"part.rib\"] \"float[6] bound\" [0 1 0 1 0 0]\n"
                    "Procedural2 \"DelayedReadArchive2\" \"string filename\" [\"part.rib\"]\n"
                    "ReadArchive \"part.rib\"\nWorldEnd\n");
    ts_scene s;
    ts_error e = {0};
    memset(&s, 0, sizeof s);
    if (rib_load(top, &s, 1, &e) != TS_OK) fail_msg("%s", e.msg);
    assert_int_equal(s.patch_count, 6);
    scene_free(&s);
    test_parse_rib_error("WorldBegin Procedural2 \"MyPlugin\" \"SimpleBound\"",
                         "t.rib:1:24: error: Procedural2 \"MyPlugin\" is not supported (a compiled "
                         "plug-in; DelayedReadArchive2 is read)");
    test_parse_rib_error("WorldBegin Procedural2 \"DelayedReadArchive2\" \"SimpleBound\"",
                         "t.rib:1:12: error: Procedural2 \"DelayedReadArchive2\" without \"string "
                         "filename\"");
}

/* PatchMesh wrap modes as older exporters spell them: "nowrap" and "wrap" give the patches of
 * "nonperiodic" and "periodic", point for point. */
/* Which patches cast shadows: Attribute "visibility" "transmission" (an int, or before
 * RenderMan 16 a string) and BMRT's Attribute "render" "casts_shadows" set
 * TS_PATCH_NO_SHADOW on the patches that follow, until the block ends
 * (test_rib_render.c test_casts_no_shadow renders it). */
static void test_shadow_attributes(void **state)
{
    (void)state;
    static const struct {
        const char *attr;
        int none;
    } cases[] = {
        {"Attribute \"visibility\" \"int transmission\" [0]", 1},
        {"Attribute \"visibility\" \"int transmission\" [1]", 0},
        {"Attribute \"visibility\" \"transmission\" \"transparent\"", 1},
        {"Attribute \"visibility\" \"string transmission\" [\"opaque\"]", 0},
        {"Attribute \"render\" \"casts_shadows\" [\"none\"]", 1},
        {"Attribute \"render\" \"casts_shadows\" \"shade\"", 0},
        {"Attribute \"render\" \"casts_shadows\" \"none\"\n"
         "Attribute \"render\" \"casts_shadows\" \"Os\"",
         0},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        char text[512];
        snprintf(text, sizeof text,
                 "WorldBegin\n" QUAD "AttributeBegin\n%s\n" QUAD "AttributeEnd\n" QUAD "WorldEnd\n",
                 cases[k].attr);
        ts_scene s;
        test_parse_rib_ok(text, &s);
        assert_int_equal(s.patch_count, 3);
        assert_int_equal(s.attr[0].flags & TS_PATCH_NO_SHADOW, 0);
        assert_int_equal(s.attr[1].flags & TS_PATCH_NO_SHADOW,
                         cases[k].none ? TS_PATCH_NO_SHADOW : 0);
        assert_int_equal(s.attr[2].flags & TS_PATCH_NO_SHADOW, 0); /* the block ended */
        scene_free(&s);
    }
    /* "camera" 0: unseen by the camera, also until the block ends */
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nAttributeBegin\nAttribute \"visibility\" \"int camera\" [0] "
                      "\"int transmission\" [0] \"int indirect\" [0]\n" QUAD "AttributeEnd\n" QUAD
                      "WorldEnd\n",
                      &s);
    const uint32_t all = TS_PATCH_NO_CAMERA | TS_PATCH_NO_SHADOW | TS_PATCH_NO_INDIRECT;
    assert_int_equal(s.attr[0].flags & all, all);
    assert_int_equal(s.attr[1].flags & all, 0);
    scene_free(&s);
    int rc;
    const char *w =
        test_rib_warnings("WorldBegin\nAttribute \"render\" \"casts_shadows\" \"shade\" "
                          "\"integer truedisplacement\" [1]\n" QUAD "WorldEnd\n",
                          &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(w, "w.rib:2:36: warning: Attribute \"render\" \"casts_shadows\" \"shade\": "
                           "the shadow is opaque (Tessera's shadows do not read the surface's "
                           "opacity)\n"
                           "w.rib:2:44: warning: Attribute \"render\" \"truedisplacement\" is "
                           "ignored\n");
    test_parse_rib_error("Attribute \"visibility\" \"transmission\" \"glass\"",
                         "t.rib:1:39: error: Attribute \"visibility\": unknown \"transmission\" "
                         "\"glass\" (none, transparent, opaque, Os, shade or shader)");
    test_parse_rib_error("Attribute \"visibility\" \"transmission\" [0 1]",
                         "t.rib:1:39: error: Attribute \"visibility\": \"transmission\" takes one "
                         "value (0 or 1, or a string: none/transparent, opaque, Os, shade/shader)");
}

static void test_patch_mesh_wrap_spellings(void **state)
{
    (void)state;
    static const char *const pairs[2][2] = {{"nonperiodic", "nowrap"}, {"periodic", "wrap"}};
    for (int k = 0; k < 2; k++) {
        ts_scene a, b;
        char text[1024];
        for (int f = 0; f < 2; f++) {
            snprintf(text, sizeof text,
                     "WorldBegin\nPatchMesh \"bilinear\" 3 \"%s\" 2 \"nonperiodic\" \"P\" "
                     "[0 0 0 1 0 0 2 0 1  0 1 0 1 1 0 2 1 1]\nWorldEnd\n",
                     pairs[k][f]);
            test_parse_rib_ok(text, f ? &b : &a);
        }
        assert_int_equal(a.patch_count, k ? 3 : 2);
        assert_int_equal(b.patch_count, a.patch_count);
        assert_memory_equal(a.cp, b.cp, a.patch_count * 16 * sizeof(ts_vec4));
        scene_free(&a);
        scene_free(&b);
    }
    test_parse_rib_error("WorldBegin PatchMesh \"bilinear\" 2 \"clamp\" 2 \"nowrap\" \"P\" [0]",
                         "t.rib:1:35: error: PatchMesh: uwrap must be \"periodic\" or "
                         "\"nonperiodic\" (or \"wrap\", \"nowrap\")");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_integrator),
        cmocka_unit_test(test_option_ri),
        cmocka_unit_test(test_camera_projection),
        cmocka_unit_test(test_conditions),
        cmocka_unit_test(test_scoped_coordinate_system),
        cmocka_unit_test(test_attribute_resources),
        cmocka_unit_test(test_empty_texture_name),
        cmocka_unit_test(test_relative_names_from_the_working_directory),
        cmocka_unit_test(test_procedural2_and_searchpath),
        cmocka_unit_test(test_patch_mesh_wrap_spellings),
        cmocka_unit_test(test_shadow_attributes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
