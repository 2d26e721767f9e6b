/* test_rib_archive.c — the RIB requests real files write beyond the basic subset
 * (host/scene/rib/rib_options.c, host/scene/rib/rib_archive.c, primitive variables in
 * host/scene/rib/rib_geom.c): PixelSamples, Clipping, Shutter, CropWindow, "Cs"/"N" of every
 * storage class, ReadArchive and Procedural (DelayedReadArchive, DynamicLoad "mesh" and "forest"),
 * archives inside zip files ("a.zip!b.rib").
 * Every error path asserts its exact "file:line:col: error:" message. Host only: never skips. */
#include "scene/rib/rib.h"
#include "scene/scene.h"
#include "test_support.h"

#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zip.h>

/* ---- helpers -------------------------------------------------------------------------- */

/* The message must be exactly msg, or start with it when msg ends in "...". */
static void assert_msg(const char *got, const char *msg)
{
    size_t n = strlen(msg);
    if (n > 3 && strcmp(msg + n - 3, "...") == 0) {
        if (strncmp(got, msg, n - 3) != 0) fail_msg("got \"%s\", want \"%s\"", got, msg);
    } else if (strcmp(got, msg) != 0) {
        fail_msg("got \"%s\", want \"%s\"", got, msg);
    }
}

static void expect_error(const char *text, const char *msg)
{
    ts_scene s;
    ts_error e;
    assert_int_equal(test_parse_rib(text, &s, &e), TS_E_SCENE);
    assert_msg(e.msg, msg);
    assert_int_equal(s.patch_count, 0);
}

/* Loads the file at path strictly (--strict: a missing archive or mesh is an error too);
 * must fail with TS_E_SCENE and message msg. */
static void expect_file_error(const char *path, const char *msg)
{
    ts_scene s;
    ts_error e;
    ts_load_options lo;
    scene_load_options_defaults(&lo);
    lo.quiet = lo.strict = 1;
    memset(&s, 0, sizeof s);
    memset(&e, 0, sizeof e);
    assert_int_equal(rib_load_with(path, &lo, &s, &e), TS_E_SCENE);
    assert_msg(e.msg, msg);
    assert_int_equal(s.patch_count, 0);
}

static void write_file(const char *dir, const char *name, const char *text)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    if (!f) fail_msg("cannot write %s", path);
    fputs(text, f);
    fclose(f);
}

static void assert_cs(const ts_scene *s, uint32_t p, double r, double g, double b)
{
    const ts_patch_attr *a = &s->attr[p];
    if (fabs(a->cs_r - r) > 1e-6 || fabs(a->cs_g - g) > 1e-6 || fabs(a->cs_b - b) > 1e-6)
        fail_msg("patch %u: colour (%g %g %g), want (%g %g %g)", p, a->cs_r, a->cs_g, a->cs_b, r, g,
                 b);
}

static void assert_n(const ts_scene *s, size_t k, double x, double y, double z)
{
    const ts_vec4 *n = &s->corner_n[k];
    double l = sqrt(x * x + y * y + z * z);
    if (fabs(n->x - x / l) > 1e-6 || fabs(n->y - y / l) > 1e-6 || fabs(n->z - z / l) > 1e-6)
        fail_msg("corner normal %zu: (%g %g %g), want (%g %g %g)", k, n->x, n->y, n->z, x / l,
                 y / l, z / l);
}

#define UNIT_P "\"P\" [0 0 0 1 0 0 0 1 0 1 1 0]"

/* ---- options -------------------------------------------------------------------------- */

static void test_pixel_samples(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nWorldEnd\n", &s);
    assert_int_equal(s.camera.spp, 0); /* not given: the command line decides */
    scene_free(&s);
    test_parse_rib_ok("PixelSamples 2 3\nWorldBegin\nWorldEnd\n", &s);
    assert_int_equal(s.camera.spp, 6);
    scene_free(&s);
    test_parse_rib_ok("PixelSamples [4 4]\n", &s);
    assert_int_equal(s.camera.spp, 16);
    scene_free(&s);
    test_parse_rib_ok("PixelSamples 1.4 2.6\n", &s); /* rounded */
    assert_int_equal(s.camera.spp, 3);
    scene_free(&s);
    expect_error("PixelSamples 0 1", "t.rib:1:1: error: PixelSamples: xsamples must be between 1 "
                                     "and 256, got 0");
    expect_error("PixelSamples 1 300", "t.rib:1:1: error: PixelSamples: ysamples must be between 1 "
                                       "and 256, got 300");
    expect_error("PixelSamples 2", "t.rib:1:1: error: PixelSamples expects 2 numbers, got 1");
    expect_error("PixelSamples 2 2 2", "t.rib:1:18: error: too many arguments to PixelSamples");
    expect_error("WorldBegin\n  PixelSamples 2 2",
                 "t.rib:2:3: error: PixelSamples must come before WorldBegin");
}

static void test_clipping_shutter_crop(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nWorldEnd\n", &s); /* RenderMan defaults */
    assert_true(s.camera.clip_near == 1e-10 && s.camera.clip_far == 1e30);
    assert_true(s.camera.shutter[0] == 0.0 && s.camera.shutter[1] == 0.0);
    assert_true(s.camera.crop[0] == 0.0 && s.camera.crop[1] == 1.0);
    assert_true(s.camera.crop[2] == 0.0 && s.camera.crop[3] == 1.0);
    scene_free(&s);
    test_parse_rib_ok(
        "Clipping 0.1 1000\nShutter 0 0.5\nCropWindow 0.25 0.75 0 0.5\nWorldBegin\nWorldEnd\n", &s);
    assert_true(s.camera.clip_near == 0.1 && s.camera.clip_far == 1000.0);
    assert_true(s.camera.shutter[0] == 0.0 && s.camera.shutter[1] == 0.5);
    assert_true(s.camera.crop[0] == 0.25 && s.camera.crop[1] == 0.75);
    assert_true(s.camera.crop[2] == 0.0 && s.camera.crop[3] == 0.5);
    scene_free(&s);
    expect_error("Clipping 1 0.5", "t.rib:1:1: error: Clipping: need 0 < near < far, got 1 0.5");
    expect_error("Clipping 0 1", "t.rib:1:1: error: Clipping: need 0 < near < far, got 0 1");
    expect_error("Shutter 1 0", "t.rib:1:1: error: Shutter: the close time must not precede the "
                                "open time, got 1 0");
    expect_error("CropWindow 0 1 0.5 0.5", "t.rib:1:1: error: CropWindow: need 0 <= min < max <= 1 "
                                           "on both axes, got 0 1 0.5 0.5");
    expect_error("CropWindow 0 1.5 0 1", "t.rib:1:1: error: CropWindow: need 0 <= min < max <= 1 "
                                         "on both axes, got 0 1.5 0 1");
    expect_error("CropWindow 0 1 0", "t.rib:1:1: error: CropWindow expects 4 numbers, got 3");
    expect_error("WorldBegin\nClipping 1 2", "t.rib:2:1: error: Clipping must come before "
                                             "WorldBegin");
    expect_error("WorldBegin\nShutter 0 1", "t.rib:2:1: error: Shutter must come before "
                                            "WorldBegin");
    /* Clipping, Shutter and CropWindow are applied, without a word (test_rib_render's
     * test_clipping and test_crop_window, test_rib_deform's test_shutter);
     * Option and Attribute once per name.
     * Attribute "identifier" "name" is read (look files' paths, rib_rlf.c), "id" is not. */
    int rc;
    const char *out =
        test_rib_warnings("Clipping 0.1 10\nClipping 0.2 10\nShutter 0 1\nShutter 0 1\n"
                          "CropWindow 0 0.5 0 1\nOption \"hair\" \"minwidth\" [0.5]\n"
                          "Option \"searchpath\" \"foo\" \"x\"\nWorldBegin\n"
                          "Attribute \"identifier\" \"name\" \"a\" \"float id\" [3]\n"
                          "Attribute \"dice\" \"binary\" [1]\nWorldEnd\n",
                          &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "w.rib:6:1: warning: Option \"hair\" is ignored\n"
                             "w.rib:7:21: warning: Option parameter \"foo\" is ignored\n"
                             "w.rib:9:35: warning: Attribute parameter \"id\" is ignored\n"
                             "w.rib:10:1: warning: Attribute \"dice\" is ignored\n");
    /* Options that change neither the image nor what is read, and the search paths of what
     * Tessera never loads: no word (RenderMan for Maya writes them in every frame). */
    out = test_rib_warnings("Option \"limits\" \"bucketsize\" [16 16]\nOption \"statistics\" "
                            "\"endofframe\" [1]\nOption \"searchpath\" \"shader\" \"x\" "
                            "\"rixplugin\" \"y\"\nWorldBegin\nWorldEnd\n",
                            &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "");
    /* The whole window leaves nothing out. */
    out = test_rib_warnings("CropWindow 0 1 0 1\nWorldBegin\nWorldEnd\n", &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "");
    /* Shutter is applied to motion blocks: test_rib_deform's test_shutter. */
}

/* ---- primitive variables ------------------------------------------------------------- */

static void test_cs_classes(void **state)
{
    (void)state;
    ts_scene s;
    /* Patch: constant, uniform, varying (average of the corners), facevarying, vertex. */
    test_parse_rib_ok(
        "Color [0.1 0.2 0.3]\n"
        "Patch \"bilinear\" " UNIT_P "\n"
        "Patch \"bilinear\" " UNIT_P " \"constant color Cs\" [1 0.5 0.25]\n"
        "Patch \"bilinear\" " UNIT_P " \"uniform color Cs\" [0.5 0.25 1]\n"
        "Patch \"bilinear\" " UNIT_P " \"Cs\" [1 0 0  0 1 0  0 0 1  1 1 1]\n"
        "Patch \"bilinear\" " UNIT_P " \"facevarying color Cs\" [1 0 0 1 0 0 0 0 0 0 0 0]\n"
        "Patch \"bilinear\" " UNIT_P " \"vertex color Cs\" [0 0 0 0 0 0 0 0 1 0 0 1]\n",
        &s);
    assert_int_equal(s.patch_count, 6);
    assert_cs(&s, 0, 0.1, 0.2, 0.3); /* the current Color */
    assert_cs(&s, 1, 1, 0.5, 0.25);
    assert_cs(&s, 2, 0.5, 0.25, 1);
    assert_cs(&s, 3, 0.5, 0.5, 0.5);
    assert_cs(&s, 4, 0.5, 0, 0);
    assert_cs(&s, 5, 0, 0, 0.5);
    scene_free(&s);
    /* A bicubic patch with vertex Cs: the corners of its Bezier form, averaged. In the
     * B-spline basis a constant grid stays constant. */
    char text[4096] = "Basis \"b-spline\" 1 \"b-spline\" 1\nPatch \"bicubic\" \"P\" [";
    for (int k = 0; k < 16; k++) {
        char v[64];
        snprintf(v, sizeof v, "%d %d 0 ", k % 4, k / 4);
        strcat(text, v);
    }
    strcat(text, "] \"vertex color Cs\" [");
    for (int k = 0; k < 16; k++)
        strcat(text, "0.25 0.5 0.75 ");
    strcat(text, "]\n");
    test_parse_rib_ok(text, &s);
    assert_int_equal(s.patch_count, 1);
    assert_cs(&s, 0, 0.25, 0.5, 0.75);
    scene_free(&s);
    /* PatchMesh: a bilinear 3 x 2 grid of vertices is 2 x 1 patches; varying colours are per
     * grid corner, uniform per patch. */
    test_parse_rib_ok(
        "PatchMesh \"bilinear\" 3 \"nonperiodic\" 2 \"nonperiodic\" \"P\" [0 0 0 1 0 0 2 0 0 "
        "0 1 0 1 1 0 2 1 0] \"Cs\" [1 0 0 0 0 0 0 0 1 1 0 0 0 0 0 0 0 1]\n"
        "PatchMesh \"bilinear\" 3 \"nonperiodic\" 2 \"nonperiodic\" \"P\" [0 0 0 1 0 0 2 0 0 "
        "0 1 0 1 1 0 2 1 0] \"uniform color Cs\" [0 1 0 0 0 1]\n",
        &s);
    assert_int_equal(s.patch_count, 4);
    assert_cs(&s, 0, 0.5, 0, 0);
    assert_cs(&s, 1, 0, 0, 0.5);
    assert_cs(&s, 2, 0, 1, 0);
    assert_cs(&s, 3, 0, 0, 1);
    scene_free(&s);
    /* Wrong counts name the class's count. */
    expect_error("Patch \"bilinear\" " UNIT_P " \"Cs\" [1 0 0]",
                 "t.rib:1:53: error: Patch: parameter \"Cs\" needs 12 values, got 3");
    expect_error("Patch \"bilinear\" " UNIT_P " \"uniform color Cs\" [1 0 0 1 0 0]",
                 "t.rib:1:67: error: Patch: parameter \"Cs\" (uniform) needs 3 values, got 6");
    expect_error(
        "PatchMesh \"bilinear\" 3 \"nonperiodic\" 2 \"nonperiodic\" \"P\" [0 0 0 1 0 0 2 0 "
        "0 0 1 0 1 1 0 2 1 0] \"facevarying color Cs\" [1 0 0]",
        "t.rib:1:119: error: PatchMesh: parameter \"Cs\" (facevarying) needs 24 "
        "values, got 3");
    expect_error("Patch \"bilinear\" " UNIT_P " \"Cs\" \"red\"",
                 "t.rib:1:53: error: Patch: parameter \"Cs\" needs numbers");
}

static void test_n_classes_and_st(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok(
        "Patch \"bilinear\" " UNIT_P " \"uniform normal N\" [0 0 -2]\n"
        "Patch \"bilinear\" " UNIT_P " \"constant normal N\" [1 0 1]\n"
        "Patch \"bilinear\" " UNIT_P " \"vertex normal N\" [0 0 1 0 1 1 1 0 1 1 1 1]\n"
        "Patch \"bilinear\" " UNIT_P " \"st\" [0 0 1 0 0 1 1 1] \"varying float s\" [0 1 0 1]\n",
        &s);
    assert_int_equal(s.patch_count, 4);
    for (int c = 0; c < 4; c++) {
        assert_n(&s, (size_t)c, 0, 0, -1);
        assert_n(&s, 4u + (size_t)c, 1, 0, 1);
    }
    assert_n(&s, 8, 0, 0, 1);
    assert_n(&s, 9, 0, 1, 1);
    assert_n(&s, 10, 1, 0, 1);
    assert_n(&s, 11, 1, 1, 1);
    scene_free(&s);
    expect_error("Patch \"bilinear\" " UNIT_P " \"uniform normal N\" [0 0 0]",
                 "t.rib:1:67: error: Patch: normal 0 of \"N\" is zero");
    /* Variables other than "P", "N", "Cs", "st" are accepted with one warning each. */
    int rc;
    const char *out =
        test_rib_warnings("Patch \"bilinear\" " UNIT_P " \"varying float s\" [0 1 0 1]\n"
                          "Patch \"bilinear\" " UNIT_P " \"varying float s\" [0 1 0 1]\n",
                          &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "w.rib:1:48: warning: Patch parameter \"s\" is ignored\n");
    /* NuPatch "Pw": weights must be positive. */
    expect_error("NuPatch 2 2 [0 0 1 1] 0 1 2 2 [0 0 1 1] 0 1 \"Pw\" [0 0 0 1  1 0 0 1  0 1 0 0  1 "
                 "1 0 1]",
                 "t.rib:1:1: error: NuPatch: the weight of control point 2 is 0 (weights must be "
                 "positive)");
}

/* ---- ReadArchive and Procedural ------------------------------------------------------- */

static void test_read_archive(void **state)
{
    (void)state;
    const char *dir = test_scratch_dir();
    char path[4096], sub[4096], want[8192];
    snprintf(sub, sizeof sub, "%s/sub", dir);
    assert_int_equal(mkdir(sub, 0755), 0);
    /* main.rib -> sub/a.rib -> (relative to sub/) b.rib; attributes set inside an archive
     * hold after it, as if its text stood in place of the request. */
    write_file(dir, "main.rib",
               "Format 64 32 1\nWorldBegin\nReadArchive \"sub/a.rib\"\n"
               "Patch \"bilinear\" " UNIT_P "\nWorldEnd\n");
    write_file(dir, "sub/a.rib",
               "Color [0 1 0]\nPatch \"bilinear\" " UNIT_P "\nReadArchive \"b.rib\"\n");
    write_file(dir, "sub/b.rib", "# b\nTranslate 0 0 5\nPatch \"bilinear\" " UNIT_P "\n");
    snprintf(path, sizeof path, "%s/main.rib", dir);
    ts_scene s;
    ts_error e;
    memset(&s, 0, sizeof s);
    memset(&e, 0, sizeof e);
    if (rib_load(path, &s, 1, &e) != TS_OK) fail_msg("%s", e.msg);
    assert_int_equal(s.patch_count, 3);
    assert_cs(&s, 0, 0, 1, 0);
    assert_true(s.cp[16].z == 5.0f); /* b.rib's Translate */
    assert_true(s.cp[32].z == 5.0f); /* ... still in effect after the archive */
    assert_cs(&s, 2, 0, 1, 0);
    assert_int_equal(s.camera.width, 64);
    scene_free(&s);

    /* An error inside an archive names the archive's file, line and column. */
    write_file(dir, "sub/b.rib", "# b\n  Frobnicate 1\n");
    snprintf(want, sizeof want, "%s/sub/b.rib:2:3: error: unknown request Frobnicate", dir);
    expect_file_error(path, want);
    write_file(dir, "sub/b.rib", "Patch \"bilinear\" \"P\" [0 0 0]\n");
    snprintf(want, sizeof want,
             "%s/sub/b.rib:1:22: error: Patch: parameter \"P\" needs 12 values, got 3", dir);
    expect_file_error(path, want);

    /* A cycle, through a relative path, and a file that includes itself. */
    write_file(dir, "sub/b.rib", "\n\nReadArchive \"../main.rib\"\n");
    snprintf(want, sizeof want,
             "%s/sub/b.rib:3:13: error: ReadArchive: \"../main.rib\" is already being read (an "
             "include cycle)",
             dir);
    expect_file_error(path, want);
    write_file(dir, "self.rib", "ReadArchive \"self.rib\"\n");
    snprintf(path, sizeof path, "%s/self.rib", dir);
    snprintf(want, sizeof want,
             "%s/self.rib:1:13: error: ReadArchive: \"self.rib\" is already being read (an "
             "include cycle)",
             dir);
    expect_file_error(path, want);

    /* A missing archive; a name that is not a string. */
    write_file(dir, "missing.rib", "WorldBegin\nReadArchive \"nope.rib\"\n");
    snprintf(path, sizeof path, "%s/missing.rib", dir);
    snprintf(want, sizeof want,
             "%s/missing.rib:2:13: error: ReadArchive: cannot read \"%s/nope.rib\": No such file "
             "or directory",
             dir, dir);
    expect_file_error(path, want);
    expect_error("ReadArchive 3",
                 "t.rib:1:13: error: ReadArchive: expected a file name (a string)");
    expect_error("ReadArchive \"a\" \"b\"", "t.rib:1:17: error: too many arguments to ReadArchive");
    expect_error("MotionBegin [0 1]\nReadArchive \"a.rib\"",
                 "t.rib:2:1: error: ReadArchive is not allowed in the motion block at 1:1 (only "
                 "Patch, PatchMesh, SubdivisionMesh, NuPatch, polygons, quadrics, Points, Curves, "
                 "Translate, "
                 "Rotate, Scale, ConcatTransform or Transform)");

    /* Depth: a chain of 20 distinct files stops at 16. */
    for (int k = 0; k < 20; k++) {
        char name[64], text[128];
        snprintf(name, sizeof name, "d%02d.rib", k);
        snprintf(text, sizeof text, "ReadArchive \"d%02d.rib\"\n", k + 1);
        write_file(dir, name, text);
    }
    snprintf(path, sizeof path, "%s/d00.rib", dir);
    snprintf(want, sizeof want,
             "%s/d16.rib:1:13: error: ReadArchive: archives nested deeper than 16 levels", dir);
    expect_file_error(path, want);
}

/* A two-quad OBJ with normals, for DynamicLoad "mesh". */
static const char *const two_quads_obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\n"
                                         "vn 0 0 1\n"
                                         "f 1//1 2//1 3//1 4//1\nf 2//1 5//1 6//1 3//1\n";

/* Not strict (RenderMan's way), an archive or mesh file that is not there is skipped with one
 * warning each, naming it: the scene is the one without the request. Strict, the same text is
 * the error at the file name (expect_file_error above checks the messages). */
/* A zip file with one member: RenderMan for Maya's archives. */
static void write_zip(const char *dir, const char *name, const char *member, const char *text)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    zipFile z = zipOpen64(path, APPEND_STATUS_CREATE);
    assert_non_null(z);
    assert_int_equal(zipOpenNewFileInZip64(z, member, NULL, NULL, 0, NULL, 0, NULL, Z_DEFLATED,
                                           Z_DEFAULT_COMPRESSION, 0),
                     ZIP_OK);
    assert_int_equal(zipWriteInFileInZip(z, text, (unsigned)strlen(text)), ZIP_OK);
    assert_int_equal(zipCloseFileInZip(z), ZIP_OK);
    assert_int_equal(zipClose(z, NULL), ZIP_OK);
}

/* "archive.zip!member.rib" (RenderMan for Maya 21+): the member read as an archive, by
 * ReadArchive and DelayedReadArchive2; an error inside names "zip!member"; a missing member
 * is a missing file (a warning and skipped, an error when strict); a file that is not a zip
 * is an error. */
static void test_zip_archives(void **state)
{
    (void)state;
    const char *dir = test_scratch_dir();
    char path[4096], want[8192];
    write_zip(dir, "parts.zip", "cube/part.rib",
              "Color [0 1 0]\nPatch \"bilinear\" " UNIT_P "\nPatch \"bilinear\" " UNIT_P "\n");
    write_file(dir, "main.rib",
               "WorldBegin\nReadArchive \"parts.zip!cube/part.rib\"\n"
               "Procedural2 \"DelayedReadArchive2\" \"SimpleBound\" \"string filename\" "
               "[\"parts.zip!cube/part.rib\"]\nWorldEnd\n");
    snprintf(path, sizeof path, "%s/main.rib", dir);
    ts_scene s;
    ts_error e;
    memset(&s, 0, sizeof s);
    memset(&e, 0, sizeof e);
    if (rib_load(path, &s, 1, &e) != TS_OK) fail_msg("%s", e.msg);
    assert_int_equal(s.patch_count, 4);
    assert_cs(&s, 0, 0, 1, 0);
    scene_free(&s);
    /* an error inside the member names it */
    write_zip(dir, "bad.zip", "x.rib", "\n  Frobnicate 1\n");
    write_file(dir, "bad.rib", "WorldBegin\nReadArchive \"bad.zip!x.rib\"\nWorldEnd\n");
    snprintf(path, sizeof path, "%s/bad.rib", dir);
    snprintf(want, sizeof want, "%s/bad.zip!x.rib:2:3: error: unknown request Frobnicate", dir);
    expect_file_error(path, want);
    /* a missing member: the missing-file rule */
    write_file(dir, "nomember.rib",
               "WorldBegin\nPatch \"bilinear\" " UNIT_P "\nReadArchive \"parts.zip!none.rib\"\n"
               "WorldEnd\n");
    snprintf(path, sizeof path, "%s/nomember.rib", dir);
    snprintf(want, sizeof want,
             "%s/nomember.rib:3:13: error: ReadArchive: cannot read \"%s/parts.zip\": the zip has "
             "no member \"none.rib\"",
             dir, dir);
    expect_file_error(path, want);
    memset(&s, 0, sizeof s);
    assert_int_equal(rib_load(path, &s, 1, &e), TS_OK);
    assert_int_equal(s.patch_count, 1);
    scene_free(&s);
    /* not a zip */
    write_file(dir, "fake.zip", "this is not a zip file\n");
    write_file(dir, "fake.rib", "WorldBegin\nReadArchive \"fake.zip!a.rib\"\nWorldEnd\n");
    snprintf(path, sizeof path, "%s/fake.rib", dir);
    snprintf(want, sizeof want,
             "%s/fake.rib:2:13: error: ReadArchive: cannot read \"%s/fake.zip\": not a zip file",
             dir, dir);
    expect_file_error(path, want);
}

static void test_missing_archive_skipped(void **state)
{
    (void)state;
    const char *dir = test_scratch_dir();
    char text[8192], want[8192];
    snprintf(text, sizeof text,
             "WorldBegin\nPatch \"bilinear\" " UNIT_P "\nReadArchive \"%s/nope.rib\"\n"
             "Procedural \"DelayedReadArchive\" [\"%s/gone.rib\"] [0 1 0 1 0 1]\n"
             "Procedural \"DynamicLoad\" [\"mesh\" \"%s/none.obj\"] [0 1 0 1 0 1]\n"
             "Procedural2 \"DelayedReadArchive2\" \"SimpleBound\" \"string filename\" "
             "[\"%s/lost.rib\"]\nTranslate 0 0 1\nPatch \"bilinear\" " UNIT_P "\nWorldEnd\n",
             dir, dir, dir, dir);
    int rc;
    const char *w = test_rib_warnings(text, &rc);
    assert_int_equal(rc, TS_OK);
    /* Each file's warning, as the strict error's text with "; skipped (...)" after it. */
    const char *names[] = {"nope.rib", "gone.rib", "none.obj", "lost.rib"};
    const char *reqs[] = {"ReadArchive", "Procedural", "Procedural", "Procedural2"};
    for (int k = 0; k < 4; k++) {
        if (k == 2)
            snprintf(want, sizeof want,
                     "warning: Procedural \"mesh\": %s/none.obj: No such file or directory; "
                     "skipped (--strict makes this an error)\n",
                     dir);
        else
            snprintf(want, sizeof want,
                     "warning: %s: cannot read \"%s/%s\": No such file or directory; skipped "
                     "(--strict makes this an error)\n",
                     reqs[k], dir, names[k]);
        if (!strstr(w, want)) fail_msg("\"%s\" not in \"%s\"", want, w);
    }
    char *line = strstr(w, "w.rib:3:13: warning: ReadArchive: cannot read");
    assert_non_null(line);
    ts_scene s, ref;
    ts_error e;
    assert_int_equal(test_parse_rib(text, &s, &e), TS_OK);
    test_parse_rib_ok("WorldBegin\nPatch \"bilinear\" " UNIT_P "\nTranslate 0 0 1\n"
                      "Patch \"bilinear\" " UNIT_P "\nWorldEnd\n",
                      &ref);
    assert_int_equal(s.patch_count, 2);
    assert_int_equal(ref.patch_count, 2);
    assert_memory_equal(s.cp, ref.cp, 32 * sizeof s.cp[0]);
    scene_free(&s);
    scene_free(&ref);
    assert_int_equal(test_parse_rib_strict(text, &s, &e), TS_E_SCENE);
    snprintf(want, sizeof want,
             "t.rib:3:13: error: ReadArchive: cannot read \"%s/nope.rib\": No such file or "
             "directory",
             dir);
    assert_string_equal(e.msg, want);
}

static void test_procedural(void **state)
{
    (void)state;
    const char *dir = test_scratch_dir();
    char path[4096], want[8192], sub[4096];
    snprintf(sub, sizeof sub, "%s/m", dir);
    assert_int_equal(mkdir(sub, 0755), 0);
    write_file(dir, "m/quads.obj", two_quads_obj);
    write_file(dir, "m/part.rib", "Patch \"bilinear\" " UNIT_P "\n");
    /* Paths relative to the RIB file; the mesh moved by the CTM with the current Color. */
    write_file(dir, "scene.rib",
               "WorldBegin\nColor [0.5 0.5 1]\nTranslate 0 0 3\n"
               "Procedural \"DynamicLoad\" [\"mesh\" \"m/quads.obj\"] [0 2 0 1 0 0]\n"
               "Procedural \"DelayedReadArchive\" [\"m/part.rib\"] [0 1 0 1 0 0]\n"
               "Procedural \"DynamicLoad\" [\"forest\" \"trees=1 seed=2 detail=0\"] "
               "[-20 20 -5 20 -20 20]\nWorldEnd\n");
    snprintf(path, sizeof path, "%s/scene.rib", dir);
    ts_scene s;
    ts_error e;
    memset(&s, 0, sizeof s);
    memset(&e, 0, sizeof e);
    if (rib_load(path, &s, 1, &e) != TS_OK) fail_msg("%s", e.msg);
    assert_true(s.patch_count > 3 + 100);
    assert_cs(&s, 0, 0.5, 0.5, 1);
    assert_true(s.cp[0].z == 3.0f && s.cp[15].x == 1.0f && s.cp[15].y == 1.0f);
    assert_true(s.cp[16 + 3].x == 2.0f);
    assert_true(s.cp[32 + 15].z == 3.0f); /* the archive's patch, under the Translate */
    assert_n(&s, 0, 0, 0, 1);
    scene_free(&s);

    /* Error paths. */
    write_file(dir, "bad.rib",
               "WorldBegin\nProcedural \"DynamicLoad\" [\"mesh\" \"m/none.obj\"] "
               "[0 1 0 1 0 1]\n");
    snprintf(path, sizeof path, "%s/bad.rib", dir);
    snprintf(
        want, sizeof want,
        "%s/bad.rib:2:26: error: Procedural \"mesh\": %s/m/none.obj: No such file or directory",
        dir, dir);
    expect_file_error(path, want);
    write_file(dir, "m/junk.obj", "this is not a mesh\n");
    write_file(dir, "bad.rib",
               "Procedural \"DynamicLoad\" [\"mesh\" \"m/junk.obj\"] [0 1 0 1 0 1]\n");
    snprintf(want, sizeof want, "%s/bad.rib:1:26: error: Procedural \"mesh\": %s/m/junk.obj: ...",
             dir, dir);
    expect_file_error(path, want);
    expect_error("Procedural \"DynamicLoad\" [\"forest\" \"trees=10 leaves=3\"] [0 1 0 1 0 1]",
                 "t.rib:1:26: error: Procedural \"forest\": unknown parameter \"leaves\" (trees, "
                 "seed, detail)");
    expect_error("Procedural \"DynamicLoad\" [\"forest\" \"trees=0\"] [0 1 0 1 0 1]",
                 "t.rib:1:26: error: Procedural \"forest\": trees must be in [1, 100000], got 0");
    expect_error("Procedural \"DynamicLoad\" [\"forest\" \"detail=x\"] [0 1 0 1 0 1]",
                 "t.rib:1:26: error: Procedural \"forest\": detail needs an integer");
    expect_error("Procedural \"DynamicLoad\" [\"forest\" \"trees\"] [0 1 0 1 0 1]",
                 "t.rib:1:26: error: Procedural \"forest\": expected key=value, got \"trees\"");
    expect_error("Procedural \"DynamicLoad\" [\"sphere.so\" \"1\"] [0 1 0 1 0 1]",
                 "t.rib:1:26: error: Procedural \"DynamicLoad\": \"sphere.so\" is a DSO "
                 "procedural (compiled plug-in code), which Tessera cannot run (built-in "
                 "generators: mesh, forest)");
    expect_error(
        "Procedural \"DynamicLoad\" [\"mesh\"] [0 1 0 1 0 1]",
        "t.rib:1:26: error: Procedural \"DynamicLoad\": [\"mesh\" \"file\"] takes one file "
        "name");
    expect_error("Procedural \"DynamicLoad\" [\"forest\" \"trees=1\"] [0 1 0 1]",
                 "t.rib:1:47: error: Procedural: expected a bound [xmin xmax ymin ymax zmin zmax]");
    expect_error("Procedural \"DynamicLoad\" [\"forest\" \"trees=1\"]",
                 "t.rib:1:1: error: Procedural: expected a bound [xmin xmax ymin ymax zmin zmax]");
    expect_error("Procedural \"DynamicLoad\" \"forest\" [0 1 0 1 0 1]",
                 "t.rib:1:26: error: Procedural: expected an array of strings after "
                 "\"DynamicLoad\"");
    expect_error("Procedural \"RunProgram\" [\"gen\"] [0 1 0 1 0 1]",
                 "t.rib:1:25: error: Procedural \"RunProgram\" takes a program and a data block: "
                 "[\"program\" \"data\"]");
    expect_error("Procedural \"Magic\" [\"x\"] [0 1 0 1 0 1]",
                 "t.rib:1:12: error: unknown procedural \"Magic\" (DelayedReadArchive, "
                 "RunProgram or DynamicLoad)");
    expect_error("WorldBegin\nWorldEnd\nProcedural \"DynamicLoad\" [\"forest\" \"\"] [0 1 0 1 0 1]",
                 "t.rib:3:1: error: Procedural after WorldEnd");
    expect_error("MotionBegin [0 1]\nTranslate 0 0 0\nTranslate 1 0 0\nMotionEnd\n"
                 "Procedural \"DynamicLoad\" [\"forest\" \"\"] [0 1 0 1 0 1]",
                 "t.rib:5:1: error: Procedural under a moving transformation is not supported");
}

/* ArchiveBegin "name" ... ArchiveEnd: its requests recorded, not run, then run in place by
 * each ReadArchive "name" (the state flowing in and out, as a file archive's), before a
 * file of that name; nested definitions are made when the archive is read; errors name
 * the archive's own lines. */
static void test_inline_archive(void **state)
{
    (void)state;
    ts_scene s, ref;
    test_parse_rib_ok("ArchiveBegin \"quad\" \"string __handleid\" [\"q\"]\n"
                      "Color [1 0 0]\nPatch \"bilinear\" " UNIT_P "\nArchiveEnd\n"
                      "ArchiveBegin \"outer\"\nArchiveBegin \"inner\"\nTranslate 0 0 2\n"
                      "ReadArchive \"quad\"\nArchiveEnd\nReadArchive \"inner\"\nArchiveEnd\n"
                      "WorldBegin\nReadArchive \"quad\"\nTranslate 0 0 1\nColor [0 1 0]\n"
                      "ReadArchive \"quad\"\nAttributeBegin\nReadArchive \"outer\"\nAttributeEnd\n"
                      "Patch \"bilinear\" " UNIT_P "\nWorldEnd\n",
                      &s);
    test_parse_rib_ok("WorldBegin\nColor [1 0 0]\nPatch \"bilinear\" " UNIT_P "\n"
                      "Translate 0 0 1\nColor [0 1 0]\nColor [1 0 0]\nPatch \"bilinear\" " UNIT_P
                      "\nAttributeBegin\nTranslate 0 0 2\nPatch \"bilinear\" " UNIT_P "\n"
                      "AttributeEnd\nPatch \"bilinear\" " UNIT_P "\nWorldEnd\n",
                      &ref);
    assert_int_equal(s.patch_count, 4);
    assert_int_equal(ref.patch_count, 4);
    assert_memory_equal(s.cp, ref.cp, 4 * 16 * sizeof s.cp[0]);
    for (uint32_t k = 0; k < 4; k++) /* the archive's Color holds after it */
        assert_cs(&s, k, 1, 0, 0);
    assert_true(s.cp[32].z == 3.0f);
    scene_free(&s);
    scene_free(&ref);

    expect_error("ArchiveEnd", "t.rib:1:1: error: ArchiveEnd without ArchiveBegin");
    expect_error("WorldBegin\nArchiveBegin \"a\"\nSphere 1 -1 1 360\n",
                 "t.rib:2:1: error: ArchiveBegin is never closed (missing ArchiveEnd)");
    expect_error("ArchiveBegin \"a\"\nReadArchive \"a\"\nArchiveEnd\nWorldBegin\n"
                 "ReadArchive \"a\"\nWorldEnd\n",
                 "t.rib:2:1: error: ReadArchive: \"a\" is already being read (an include cycle)");
    expect_error("ArchiveBegin \"a\"\nArchiveBegin \"a\"\nArchiveEnd\nArchiveEnd\nWorldBegin\n"
                 "ReadArchive \"a\"\nWorldEnd\n",
                 "t.rib:2:1: error: ArchiveBegin \"a\" while that archive is being read");
    expect_error("ArchiveBegin \"a\"\nSphere 1 -1\nArchiveEnd\nWorldBegin\nReadArchive \"a\"\n",
                 "t.rib:2:1: error: Sphere expects 4 numbers, got 2");
    expect_error("ArchiveBegin \"a\"\nNoSuchRequest 1\nArchiveEnd\n",
                 "t.rib:2:1: error: unknown request NoSuchRequest");

    /* Reads are copies, bounded: an archive read ten times inside one read ten times ... */
    char text[4096] = "ArchiveBegin \"a0\"\nIdentity\nArchiveEnd\n";
    for (int k = 1; k <= 8; k++) {
        size_t n = strlen(text);
        snprintf(text + n, sizeof text - n, "ArchiveBegin \"a%d\"\n", k);
        for (int r = 0; r < 10; r++) {
            n = strlen(text);
            snprintf(text + n, sizeof text - n, "ReadArchive \"a%d\"\n", k - 1);
        }
        n = strlen(text);
        snprintf(text + n, sizeof text - n, "ArchiveEnd\n");
    }
    strcat(text, "WorldBegin\nReadArchive \"a8\"\nWorldEnd\n");
    setenv("TESSERA_MAX_INLINE_REQUESTS", "100000", 1);
    ts_error e;
    assert_int_equal(test_parse_rib(text, &s, &e), TS_E_SCENE);
    assert_non_null(strstr(e.msg, "error: ReadArchive: inline archives read again run more than "
                                  "100000 requests or add more than "));
    setenv("TESSERA_MAX_INLINE_REQUESTS", "1000", 1); /* the patches' bound is met first */
    setenv("TESSERA_MAX_INSTANCED_PATCHES", "3", 1);
    expect_error("ArchiveBegin \"q\"\nPatch \"bilinear\" " UNIT_P "\nArchiveEnd\nWorldBegin\n"
                 "ReadArchive \"q\"\nReadArchive \"q\"\nReadArchive \"q\"\n"
                 "ReadArchive \"q\"\nWorldEnd\n",
                 "t.rib:8:1: error: ReadArchive: inline archives read again run more than "
                 "1000 requests or add more than 3 patches (each read is a copy)");
    unsetenv("TESSERA_MAX_INLINE_REQUESTS");
    unsetenv("TESSERA_MAX_INSTANCED_PATCHES");
}

/* ---- Procedural "RunProgram" ------------------------------------------------------ */

/* A helper program (RI Spec 3.2 §5.7): for each request line "detail data" it logs its
 * process id, the detail and the data to log.txt beside it, then answers a red patch scaled
 * by data (inside its own block state: the Color and Scale must not leak), a nested
 * RunProgram of itself for "nest", an error for "bad", an open block for "open", a closing
 * one for "close", nothing at all for "quit" (it exits with status 3), for "utf8" a patch
 * ended by \377 as Python 3 writes it (UTF-8: C3 BF, which also stands in a string and a
 * comment before it), and for "linger"
 * a patch, after which it sleeps for an hour instead of reading its end of input (were it
 * waited for, the test would hang). */
static const char gen_sh[] =
    "#!/bin/sh\n"
    "cd \"$(dirname \"$0\")\"\n"
    "while read -r detail data; do\n"
    "  echo \"$$ $detail $data\" >> log.txt\n"
    "  case $data in\n"
    "  quit) exit 3 ;;\n"
    "  nest) echo 'Procedural \"RunProgram\" [\"gen.sh\" \"2\"] [0 1 0 1 0 0]' ;;\n"
    "  bad) printf 'Color [1 0 0]\\nSphere 1 -1\\n' ;;\n"
    "  open) echo 'AttributeBegin' ;;\n"
    "  close) echo 'AttributeEnd' ;;\n"
    "  utf8) printf '# \303\277 in a comment\nAttribute \"identifier\" \"name\" \"\303\277\"\n'\n"
    "     echo 'Patch \"bilinear\" \"P\" [0 0 0 1 0 0 0 1 0 1 1 0]'\n"
    "     printf '\303\277'; continue ;;\n"
    "  linger) echo 'Patch \"bilinear\" \"P\" [0 0 0 1 0 0 0 1 0 1 1 0]' ;;\n"
    "  *) printf 'Color [1 0 0]\\nScale %s %s %s\\n' $data $data $data\n"
    "     echo 'Patch \"bilinear\" \"P\" [0 0 0 1 0 0 0 1 0 1 1 0]' ;;\n"
    "  esac\n"
    "  printf '\\377'\n"
    "  if [ \"$data\" = linger ]; then exec sleep 3600; fi\n"
    "done\n";

/* Writes dir/name as write_file does, executable. */
static void write_program(const char *dir, const char *name, const char *text)
{
    char path[4096];
    write_file(dir, name, text);
    snprintf(path, sizeof path, "%s/%s", dir, name);
    assert_int_equal(chmod(path, 0755), 0);
}

/* Loads dir/name with programs on (strict or not): test_rib_load_capture. */
static int load_programs(const char *dir, const char *name, int strict, ts_scene *s, ts_error *e,
                         char *warn, size_t cap)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    return test_rib_load_capture(path, strict, s, e, warn, cap);
}

/* The lines of dir/log.txt: process ids, details and data of the requests the helper read. */
static int read_log(const char *dir, long pid[8], double detail[8], char data[8][16])
{
    char path[4096];
    snprintf(path, sizeof path, "%s/log.txt", dir);
    FILE *f = fopen(path, "r");
    int n = 0;
    while (f && n < 8 && fscanf(f, "%ld %lf %15s", &pid[n], &detail[n], data[n]) == 3)
        n++;
    if (f) fclose(f);
    return n;
}

#define PROGRAM_HEAD "Format 320 240 1\nProjection \"perspective\" \"fov\" [60]\nTranslate 0 0 5\n"

/* RunProgram runs the helper beside the file once for all its requests (each answered in
 * place, inside a block of its own), tells it each bound's raster area (the detail), finds it
 * along Option "searchpath" "procedural", and reaps it at the end, killed if it lingers. */
static void test_run_program(void **state)
{
    (void)state;
    const char *dir = test_scratch_dir();
    char warn[4096], sub[4096], path[4096];
    write_program(dir, "gen.sh", gen_sh);
    write_file(dir, "scene.rib",
               PROGRAM_HEAD "WorldBegin\nLightSource \"distantlight\" 1\n"
                            "Procedural \"RunProgram\" [\"gen.sh\" \"1\"] "
                            "[0 1 0 1 0 0]\nTranslate -1.5 0 0\n"
                            "Procedural \"RunProgram\" [\"gen.sh\" \"0.5\"] [0 0.5 0 0.5 0 0]\n"
                            "Procedural \"RunProgram\" [\"gen.sh\" \"nest\"] [0 1 0 1 0 0]\n"
                            "Patch \"bilinear\" " UNIT_P "\n"
                            "Procedural \"RunProgram\" [\"gen.sh\" \"utf8\"] [0 1 0 1 0 0]\n"
                            "WorldEnd\n");
    ts_scene s;
    ts_error e;
    if (load_programs(dir, "scene.rib", 0, &s, &e, warn, sizeof warn) != TS_OK)
        fail_msg("%s", e.msg);
    assert_string_equal(warn, "");
    assert_int_equal(s.patch_count, 5);
    assert_cs(&s, 0, 1, 0, 0); /* the answers' patches, red */
    assert_cs(&s, 1, 1, 0, 0);
    assert_cs(&s, 2, 1, 0, 0);
    assert_cs(&s, 3, 1, 1, 1); /* neither their Color nor their Scale leaks */
    assert_true(s.cp[15].x == 1.0f && s.cp[15].y == 1.0f && s.cp[15].z == 0.0f);
    assert_true(s.cp[16].x == -1.5f && s.cp[16 + 15].x == -1.0f);
    assert_true(s.cp[32 + 15].x == 0.5f); /* the nested answer's patch, Scale 2 */
    assert_true(s.cp[48 + 15].x == -0.5f);
    scene_free(&s);
    long pid[8];
    double detail[8];
    char data[8][16];
    assert_int_equal(read_log(dir, pid, detail, data), 5);
    /* One process answered all five (the nested request included), each told the raster
     * area of its bound: a unit square 5 units ahead under a 60-degree view of 320 x 240 is
     * 320 / (2 * 4/3 * 5 tan 30) = 41.57 pixels wide and as tall. */
    const char *want[] = {"1", "0.5", "nest", "2", "utf8"};
    double side = 320.0 / (2.0 * 4.0 / 3.0 * 5.0 * tan(M_PI / 6.0));
    double area[] = {side * side, side * side / 4, side * side, side * side, side * side};
    for (int k = 0; k < 5; k++) {
        assert_int_equal(pid[k], pid[0]);
        assert_string_equal(data[k], want[k]);
        if (fabs(detail[k] - area[k]) > 1e-3 * area[k])
            fail_msg("request %d: detail %g, want %g", k, detail[k], area[k]);
    }
    assert_int_equal(kill((pid_t)pid[0], 0), -1); /* reaped at the end of the parse */

    /* Along the procedural search path; a helper that lingers after its input closes is
     * killed, not waited for. */
    snprintf(sub, sizeof sub, "%s/bin", dir);
    assert_int_equal(mkdir(sub, 0755), 0);
    write_program(dir, "bin/gen.sh", gen_sh);
    snprintf(path, sizeof path, "%s/gen.sh", dir);
    assert_int_equal(unlink(path), 0);
    write_file(dir, "scene.rib",
               PROGRAM_HEAD "Option \"searchpath\" \"procedural\" [\"bin\"]\nWorldBegin\n"
                            "Procedural \"RunProgram\" [\"gen.sh\" \"linger\"] [0 1 0 1 0 0]\n"
                            "WorldEnd\n");
    if (load_programs(dir, "scene.rib", 0, &s, &e, warn, sizeof warn) != TS_OK)
        fail_msg("%s", e.msg);
    assert_int_equal(s.patch_count, 1);
    scene_free(&s);
    assert_int_equal(read_log(sub, pid, detail, data), 1);
    assert_string_equal(data[0], "linger");
    assert_int_equal(kill((pid_t)pid[0], 0), -1);
}

/* What goes wrong: a program that is not there or cannot run (skipped with a warning, an
 * error when strict), one that ends without finishing its answer, an answer with an error
 * (named by the program and its answer's number), an answer that leaves a block open or
 * closes one it did not open, and programs turned off (rib_parse_string; --no-programs). */
static void test_run_program_errors(void **state)
{
    (void)state;
    const char *dir = test_scratch_dir();
    char warn[4096], want[8192];
    write_program(dir, "gen.sh", gen_sh);
    write_file(dir, "plain.sh", gen_sh);                 /* not executable */
    write_program(dir, "lost.sh", "#!/no/such/shell\n"); /* its interpreter is not there */
    ts_scene s;
    ts_error e;
    write_file(dir, "scene.rib",
               "WorldBegin\nPatch \"bilinear\" " UNIT_P "\n"
               "Procedural \"RunProgram\" [\"no-such-program\" \"1\"] [0 1 0 1 0 0]\n"
               "Procedural \"RunProgram\" [\"plain.sh\" \"1\"] [0 1 0 1 0 0]\n"
               "Procedural \"RunProgram\" [\"lost.sh\" \"1\"] [0 1 0 1 0 0]\nWorldEnd\n");
    assert_int_equal(load_programs(dir, "scene.rib", 0, &s, &e, warn, sizeof warn), TS_OK);
    assert_int_equal(s.patch_count, 1);
    scene_free(&s);
    snprintf(want, sizeof want,
             "%s/scene.rib:3:25: warning: Procedural: cannot read the program \"no-such-program\": "
             "No such file or directory; skipped (--strict makes this an error)\n",
             dir);
    if (!strstr(warn, want)) fail_msg("\"%s\" not in \"%s\"", want, warn);
    if (!strstr(warn, "plain.sh\": Permission denied (not executable: chmod +x it, or name its "
                      "interpreter, e.g. \"python3 plain.sh\"); skipped"))
        fail_msg("no not-executable warning in \"%s\"", warn);
    snprintf(want, sizeof want,
             "%s/scene.rib:5:25: warning: Procedural: cannot read the program \"%s/lost.sh\": "
             "its interpreter \"/no/such/shell\" (its #! line) is not there; skipped",
             dir, dir);
    if (!strstr(warn, want)) fail_msg("\"%s\" not in \"%s\"", want, warn);
    assert_int_equal(load_programs(dir, "scene.rib", 1, &s, &e, warn, sizeof warn), TS_E_SCENE);
    snprintf(want, sizeof want,
             "%s/scene.rib:3:25: error: Procedural: cannot read the program \"no-such-program\": "
             "No such file or directory",
             dir);
    assert_string_equal(e.msg, want);

    static const struct {
        const char *data, *msg;
    } bad[] = {
        {"quit", "error: Procedural \"RunProgram\": \"gen.sh\" did not finish its answer with "
                 "\\377: it exited with status 3"},
        {"bad", "gen.sh[1]:2:1: error: Sphere expects 4 numbers, got 2"},
        {"open", "error: Procedural \"RunProgram\": the answer of \"gen.sh\" leaves the block "
                 "begun at 1:1 open"},
        {"close", "error: Procedural \"RunProgram\": the answer of \"gen.sh\" ends a block it did "
                  "not begin"},
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        char text[1024];
        snprintf(text, sizeof text,
                 "WorldBegin\nProcedural \"RunProgram\" [\"gen.sh\" \"%s\"] [0 1 0 1 0 0]\n"
                 "Patch \"bilinear\" " UNIT_P "\nWorldEnd\n",
                 bad[k].data);
        write_file(dir, "scene.rib", text);
        assert_int_equal(load_programs(dir, "scene.rib", 0, &s, &e, warn, sizeof warn), TS_E_SCENE);
        assert_int_equal(s.patch_count, 0);
        if (k == 1) {
            assert_msg(e.msg, bad[k].msg);
        } else {
            snprintf(want, sizeof want, "%s/scene.rib:2:25: %s", dir, bad[k].msg);
            assert_string_equal(e.msg, want);
        }
    }

    /* Programs off: rib_parse_string never runs one. */
    int rc;
    const char *w = test_rib_warnings("WorldBegin\nPatch \"bilinear\" " UNIT_P "\n"
                                      "Procedural \"RunProgram\" [\"gen.sh\" \"1\"] "
                                      "[0 1 0 1 0 0]\nWorldEnd\n",
                                      &rc);
    assert_int_equal(rc, TS_OK);
    if (!strstr(w, "w.rib:3:25: warning: Procedural \"RunProgram\": \"gen.sh\" is not run "
                   "(programs are off: --no-programs); skipped\n"))
        fail_msg("no warning in \"%s\"", w);
}

/* DepthOfField fstop focallength focaldistance and a perspective Projection's fStop,
 * focalLength and focalDistance: the camera's lens; DepthOfField alone or an infinite fstop
 * (the classic exporters' "DepthOfField 1e+38 1e-10 1") is a pinhole; values not above 0 are
 * errors; a Projection that gives only some of the three warns and leaves the lens. */
static void test_depth_of_field_request(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("DepthOfField 2.8 0.1 5\nWorldBegin\nWorldEnd\n", &s);
    assert_true(s.camera.fstop == 2.8 && s.camera.focal_length == 0.1 &&
                s.camera.focal_distance == 5.0);
    scene_free(&s);
    test_parse_rib_ok("DepthOfField 2.8 0.1 5\nDepthOfField\nWorldBegin\nWorldEnd\n", &s);
    assert_true(s.camera.fstop == 0.0);
    scene_free(&s);
    test_parse_rib_ok("DepthOfField 1e+38 1e-10 1\nWorldBegin\nWorldEnd\n", &s);
    assert_true(s.camera.fstop == 0.0);
    scene_free(&s);
    test_parse_rib_ok("Projection \"perspective\" \"fov\" [45] \"float fStop\" [4] "
                      "\"float focalLength\" [1] \"float focalDistance\" [20]\n"
                      "WorldBegin\nWorldEnd\n",
                      &s);
    assert_true(s.camera.fstop == 4.0 && s.camera.focal_length == 1.0 &&
                s.camera.focal_distance == 20.0 && s.camera.fov_deg == 45.0);
    scene_free(&s);
    expect_error("DepthOfField 0 1 5", "t.rib:1:1: error: DepthOfField: need fstop, focallength "
                                       "and focaldistance above 0 (fstop 1e+30 for a pinhole), "
                                       "got 0 1 5");
    expect_error("DepthOfField 2 1", "t.rib:1:1: error: DepthOfField expects 3 numbers, got 2");
    expect_error("DepthOfField 1e-30 1 5", "t.rib:1:1: error: DepthOfField: a lens 1e+30 across "
                                           "focused at 5 is beyond the range rays can hold (1e18)");
    expect_error("WorldBegin\nDepthOfField 2 1 5", "t.rib:2:1: error: DepthOfField must come "
                                                   "before WorldBegin");
    int rc;
    const char *out = test_rib_warnings(
        "Projection \"PxrCamera\" \"float fStop\" [4]\nWorldBegin\nWorldEnd\n", &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "w.rib:1:24: warning: Projection \"PxrCamera\": depth of field needs "
                             "fStop, focalLength and focalDistance together: the camera stays as "
                             "it was\n");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pixel_samples),
        cmocka_unit_test(test_zip_archives),
        cmocka_unit_test(test_clipping_shutter_crop),
        cmocka_unit_test(test_depth_of_field_request),
        cmocka_unit_test(test_cs_classes),
        cmocka_unit_test(test_n_classes_and_st),
        cmocka_unit_test(test_read_archive),
        cmocka_unit_test(test_procedural),
        cmocka_unit_test(test_inline_archive),
        cmocka_unit_test(test_run_program),
        cmocka_unit_test(test_run_program_errors),
        cmocka_unit_test(test_missing_archive_skipped),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
