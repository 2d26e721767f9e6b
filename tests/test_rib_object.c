/* test_rib_object.c — ObjectBegin / ObjectEnd / ObjectInstance (host/scene/rib/rib_object.c,
 * issue 16): an object instanced three times under different transformations and attributes
 * gives the patches of its requests written out in full at each instance, bit for bit
 * (points, normals, attributes, transforms, motion); the object's own attribute changes
 * end with it; handles are numbers or strings and a definition may be replaced; and every
 * misuse (nested objects, unknown handles, unbalanced or unclosed definitions, requests a
 * definition may not hold, too many instanced patches) is one exact error. Host only. */
#include "scene/rib/rib.h"
#include "scene/scene.h"
#include "test_support.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The object's body, used both in ObjectBegin 7 ... ObjectEnd and written out in full. It
 * mixes the kinds of geometry and its own attributes and transformations. */
#define BODY                                                                                       \
    "  AttributeBegin\n"                                                                           \
    "    Color [1 0 0]\n"                                                                          \
    "    Translate 0 0 1\n"                                                                        \
    "    Sphere 0.5 -0.5 0.5 300\n"                                                                \
    "  AttributeEnd\n"                                                                             \
    "  Rotate 30 0 0 1\n"                                                                          \
    "  Patch \"bicubic\" \"P\" [0 0 0  1 0 0.2  2 0 0  3 0 0.1  0 1 0  1 1 0.5  2 1 0  3 1 0 "     \
    "0 2 0.3  1 2 0  2 2 0.4  3 2 0  0 3 0  1 3 0.2  2 3 0  3 3 0.1]\n"                            \
    "  PointsPolygons [3 3] [0 1 2  0 2 3] \"P\" [0 0 0  1 0 0  1 1 0.5  0 1 0]\n"                 \
    "  Displacement \"fbm\" \"amplitude\" [0.05]\n"                                                \
    "  Geometry \"teapot\"\n"

/* The three placements, each with its own transformation and attributes. */
static const char *const placements[3] = {
    "Translate -3 0 0\nColor [0.2 0.4 0.6]\n",
    "Translate 3 1 0\nRotate 45 1 1 0\nScale 0.5 0.5 0.5\nSurface \"plastic\"\n",
    "MotionBegin [0 1]\nTranslate 0 4 0\nTranslate 0.5 4 0\nMotionEnd\nOpacity [1 1 1]\n",
};

/* Both scenes of one test: with the object instanced, and written out. */
static void build_scenes(char *inst, char *full, size_t n)
{
    int a = snprintf(inst, n, "WorldBegin\nObjectBegin 7\n" BODY "ObjectEnd\n");
    int b = snprintf(full, n, "WorldBegin\n");
    for (int k = 0; k < 3; k++) {
        a += snprintf(inst + a, n - a, "AttributeBegin\n%sObjectInstance 7\nAttributeEnd\n",
                      placements[k]);
        b += snprintf(full + b, n - b,
                      "AttributeBegin\n%sAttributeBegin\n" BODY "AttributeEnd\nAttributeEnd\n",
                      placements[k]);
    }
    snprintf(inst + a, n - a, "Patch \"bilinear\" \"P\" [0 0 0  1 0 0  0 1 0  1 1 0]\nWorldEnd\n");
    snprintf(full + b, n - b, "Patch \"bilinear\" \"P\" [0 0 0  1 0 0  0 1 0  1 1 0]\nWorldEnd\n");
}

static void assert_same_scene(const ts_scene *a, const ts_scene *b)
{
    uint32_t n = a->patch_count;
    assert_int_equal(n, b->patch_count);
    assert_memory_equal(a->cp, b->cp, (size_t)n * 16 * sizeof(ts_vec4));
    assert_non_null(a->cp1); /* the third instance moves */
    assert_non_null(b->cp1);
    assert_memory_equal(a->cp1, b->cp1, (size_t)n * 16 * sizeof(ts_vec4));
    assert_memory_equal(a->corner_n, b->corner_n, (size_t)n * 4 * sizeof(ts_vec4));
    assert_memory_equal(a->mid_n, b->mid_n, (size_t)n * 5 * sizeof(ts_vec4));
    assert_memory_equal(a->attr, b->attr, (size_t)n * sizeof(ts_patch_attr));
    assert_int_equal(a->xform_count, b->xform_count);
    assert_memory_equal(a->xform, b->xform, (size_t)a->xform_count * sizeof(ts_xform));
}

/* Three instances equal the same requests written out in full, bit for bit; the last patch,
 * after them, has the Color and CTM of the world block (nothing leaks from the instances). */
static void test_instances_equal_written_out(void **state)
{
    (void)state;
    static char inst[16384], full[16384];
    build_scenes(inst, full, sizeof inst);
    ts_scene a, b;
    test_parse_rib_ok(inst, &a);
    test_parse_rib_ok(full, &b);
    assert_true(a.patch_count > 3 * 32);
    assert_same_scene(&a, &b);
    const ts_patch_attr *last = &a.attr[a.patch_count - 1];
    assert_true(last->cs_r == 1.0f && last->cs_g == 1.0f && last->cs_b == 1.0f);
    assert_int_equal(last->disp_kind, TS_DISP_NONE);
    assert_true(a.cp[(size_t)(a.patch_count - 1) * 16 + 15].x == 1.0f);
    /* The instance's attributes reach the object: the second placement's plastic. */
    int plastic = 0;
    for (uint32_t p = 0; p < a.patch_count; p++)
        plastic += a.attr[p].material == TS_MAT_PLASTIC;
    assert_true(plastic > 32 && plastic < (int)a.patch_count / 2);
    scene_free(&a);
    scene_free(&b);
}

/* Handles: numbers and strings are different handles; a second definition of a handle
 * replaces the first; an object may be defined before WorldBegin and in an archive. */
static void test_handles_and_redefinition(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("ObjectBegin 1\nGeometry \"teapot\"\nObjectEnd\n"
                      "ObjectBegin \"1\"\nSphere 1 -1 1 360\nObjectEnd\n"
                      "WorldBegin\nObjectInstance 1\nObjectInstance \"1\"\n"
                      "ObjectBegin 1\nPatch \"bilinear\" \"P\" [0 0 0  1 0 0  0 1 0  1 1 0]\n"
                      "ObjectEnd\nObjectInstance 1\nWorldEnd\n",
                      &s);
    ts_scene t;
    test_parse_rib_ok("WorldBegin\nGeometry \"teapot\"\nSphere 1 -1 1 360\n"
                      "Patch \"bilinear\" \"P\" [0 0 0  1 0 0  0 1 0  1 1 0]\nWorldEnd\n",
                      &t);
    assert_int_equal(s.patch_count, t.patch_count);
    assert_memory_equal(s.cp, t.cp, (size_t)s.patch_count * 16 * sizeof(ts_vec4));
    scene_free(&s);
    scene_free(&t);
    /* Defined in an archive, instanced in the file that read it. */
    const char *dir = test_scratch_dir();
    char path[4200];
    snprintf(path, sizeof path, "%s/part.rib", dir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("ObjectBegin \"cup\"\nGeometry \"teapot\"\nObjectEnd\n", f);
    fclose(f);
    snprintf(path, sizeof path, "%s/main.rib", dir);
    f = fopen(path, "w");
    assert_non_null(f);
    fputs("ReadArchive \"part.rib\"\nWorldBegin\nObjectInstance \"cup\"\nTranslate 5 0 0\n"
          "ObjectInstance \"cup\"\nWorldEnd\n",
          f);
    fclose(f);
    ts_error e = {0};
    memset(&s, 0, sizeof s);
    if (rib_load(path, &s, 1, &e) != TS_OK) fail_msg("%s", e.msg);
    assert_int_equal(s.patch_count, 64);
    assert_true(s.cp[32 * 16].x == s.cp[0].x + 5.0f);
    scene_free(&s);
}

/* text must fail with exactly msg (the scene left empty). */
static void expect_error(const char *text, const char *msg)
{
    ts_scene s;
    ts_error e = {0};
    assert_int_equal(test_parse_rib(text, &s, &e), TS_E_SCENE);
    if (strcmp(e.msg, msg) != 0) fail_msg("got \"%s\", want \"%s\"", e.msg, msg);
    assert_int_equal(s.patch_count, 0);
    ts_error_clear(&e);
}

#define OBJ "ObjectBegin 1\nSphere 1 -1 1 360\nObjectEnd\n"

/* An instance of an object never defined: RenderMan reports it and goes on, and so does
 * Tessera, drawing nothing for it with a warning; with --strict it is the error. */
static void test_object_undefined(void **state)
{
    (void)state;
    int rc;
    const char *w = test_rib_warnings(OBJ "WorldBegin\nObjectInstance 2\nObjectInstance 1\n"
                                          "ObjectInstance 2\nWorldEnd\n",
                                      &rc);
    assert_int_equal(rc, TS_OK);
    const char *want = "w.rib:5:1: warning: ObjectInstance: object 2 is not defined (ObjectBegin 2 "
                       "... ObjectEnd must come before); nothing drawn (--strict makes this an "
                       "error)\n";
    if (!strstr(w, want)) fail_msg("\"%s\" not in \"%s\"", want, w);
    if (strstr(strstr(w, want) + strlen(want), "object 2")) fail_msg("warned twice: \"%s\"", w);
    ts_scene s;
    ts_error e = {0};
    assert_int_equal(
        test_parse_rib(OBJ "WorldBegin\nObjectInstance 2\nObjectInstance 1\nWorldEnd\n", &s, &e),
        TS_OK);
    ts_scene ref;
    test_parse_rib_ok(OBJ "WorldBegin\nObjectInstance 1\nWorldEnd\n", &ref);
    assert_int_equal(s.patch_count, ref.patch_count);
    assert_true(s.patch_count > 0);
    assert_memory_equal(s.cp, ref.cp, (size_t)16 * s.patch_count * sizeof s.cp[0]);
    scene_free(&s);
    scene_free(&ref);
    assert_int_equal(test_parse_rib_strict(OBJ "WorldBegin\nObjectInstance 2\n", &s, &e),
                     TS_E_SCENE);
    assert_string_equal(e.msg, "t.rib:5:1: error: ObjectInstance: object 2 is not defined "
                               "(ObjectBegin 2 ... ObjectEnd must come before)");
    ts_error_clear(&e);
    assert_int_equal(test_parse_rib_strict(OBJ "ObjectInstance \"1\"\n", &s, &e), TS_E_SCENE);
    assert_string_equal(e.msg, "t.rib:4:1: error: ObjectInstance: object \"1\" is not defined "
                               "(ObjectBegin \"1\" ... ObjectEnd must come before)");
    ts_error_clear(&e);
}

static void test_object_errors(void **state)
{
    (void)state;
    expect_error("ObjectBegin 1\nObjectBegin 2\n",
                 "t.rib:2:1: error: ObjectBegin inside the definition of the object begun at 1:1 "
                 "(objects do not nest)");
    expect_error(OBJ "ObjectBegin 2\nObjectInstance 1\nObjectEnd\n",
                 "t.rib:5:1: error: ObjectInstance inside the definition of the object begun at "
                 "4:1 (objects do not nest)");
    expect_error("ObjectEnd\n", "t.rib:1:1: error: ObjectEnd without ObjectBegin");
    expect_error("WorldBegin\nObjectBegin 1\nSphere 1 -1 1 360\n",
                 "t.rib:2:1: error: ObjectBegin is never closed (missing ObjectEnd)");
    expect_error("ObjectBegin\n", "t.rib:1:1: error: ObjectBegin takes one handle, a number or a "
                                  "string");
    expect_error("ObjectBegin [1 2]\n", "t.rib:1:1: error: ObjectBegin takes one handle, a "
                                        "number or a string");
    expect_error("ObjectBegin 1\nWorldBegin\n",
                 "t.rib:2:1: error: WorldBegin inside the definition of the object begun at 1:1 "
                 "(an object holds geometry, transformations and attributes)");
    expect_error("ObjectBegin 1\nFormat 10 10 1\n",
                 "t.rib:2:1: error: Format inside the definition of the object begun at 1:1 (an "
                 "object holds geometry, transformations and attributes)");
    expect_error("ObjectBegin 1\nAttributeEnd\n",
                 "t.rib:2:1: error: AttributeEnd without a matching Begin in the object begun at "
                 "1:1");
    expect_error("AttributeBegin\nObjectBegin 1\nAttributeBegin\nTransformBegin\nObjectEnd\n",
                 "t.rib:5:1: error: ObjectEnd: 2 AttributeBegin/TransformBegin blocks of the "
                 "object begun at 2:1 are never closed");
    expect_error("ObjectBegin 1\nMotionBegin [0 1]\nTranslate 0 0 0\nTranslate 1 0 0\nObjectEnd\n",
                 "t.rib:5:1: error: ObjectEnd: the MotionBegin at 2:1 is never closed");
    /* Unknown requests are refused where they are written, instanced or not. */
    expect_error("ObjectBegin 1\nPerspective 30\nObjectEnd\n",
                 "t.rib:2:1: error: Perspective is not supported");
    expect_error("ObjectBegin 1\nSpheer 1 -1 1 360\nObjectEnd\n",
                 "t.rib:2:1: error: unknown request Spheer");
    /* A request of the object that fails when it runs names the instance. */
    expect_error("ObjectBegin 1\nSphere 1 -1 1\nObjectEnd\nWorldBegin\nObjectInstance 1\n",
                 "t.rib:2:1: error: Sphere expects 4 numbers, got 3 (in object 1, instanced at "
                 "t.rib:5:1)");
    expect_error(OBJ "WorldBegin\nWorldEnd\nObjectInstance 1\n",
                 "t.rib:6:1: error: ObjectInstance after WorldEnd");
    expect_error(
        OBJ "MotionBegin [0 1]\nObjectInstance 1\n",
        "t.rib:5:1: error: ObjectInstance is not allowed in the motion block at 4:1 "
        "(only Patch, PatchMesh, SubdivisionMesh, NuPatch, polygons, quadrics, Points, Curves, "
        "Translate, Rotate, Scale, ConcatTransform or Transform)");
}

/* An object begun in an archive must end there. */
static void test_object_ends_in_its_file(void **state)
{
    (void)state;
    const char *dir = test_scratch_dir();
    char path[4200];
    snprintf(path, sizeof path, "%s/open.rib", dir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("ObjectBegin 3\nSphere 1 -1 1 360\n", f);
    fclose(f);
    snprintf(path, sizeof path, "%s/main.rib", dir);
    f = fopen(path, "w");
    assert_non_null(f);
    fputs("WorldBegin\nReadArchive \"open.rib\"\nObjectEnd\nWorldEnd\n", f);
    fclose(f);
    ts_scene s;
    ts_error e = {0};
    memset(&s, 0, sizeof s);
    assert_int_equal(rib_load(path, &s, 1, &e), TS_E_SCENE);
    char want[4400];
    snprintf(want, sizeof want,
             "%s/open.rib:1:1: error: ObjectBegin is never closed (missing ObjectEnd)", dir);
    assert_string_equal(e.msg, want);
    ts_error_clear(&e);
    /* An archive read by an instance may not define or instance objects: here it would
     * redefine the object whose instance reads it. */
    snprintf(path, sizeof path, "%s/again.rib", dir);
    f = fopen(path, "w");
    assert_non_null(f);
    fputs("ObjectBegin 1\nSphere 1 -1 1 360\nObjectEnd\n", f);
    fclose(f);
    snprintf(path, sizeof path, "%s/main2.rib", dir);
    f = fopen(path, "w");
    assert_non_null(f);
    fputs("ObjectBegin 1\nReadArchive \"again.rib\"\nObjectEnd\nWorldBegin\nObjectInstance 1\n"
          "WorldEnd\n",
          f);
    fclose(f);
    memset(&s, 0, sizeof s);
    assert_int_equal(rib_load(path, &s, 1, &e), TS_E_SCENE);
    snprintf(want, sizeof want,
             "%s/again.rib:1:1: error: ObjectBegin inside an instance of object 1 (objects do "
             "not nest) (in object 1, instanced at %s/main2.rib:5:1)",
             dir, dir);
    assert_string_equal(e.msg, want);
    ts_error_clear(&e);
}

/* The patches instances add are bounded ($TESSERA_MAX_INSTANCED_PATCHES lowers the bound
 * for this test): 3 teapots of 32 patches fit in 100, the fourth does not. */
static void test_instanced_patch_bound(void **state)
{
    (void)state;
    const char *text = "ObjectBegin 1\nGeometry \"teapot\"\nObjectEnd\nWorldBegin\n"
                       "ObjectInstance 1\nObjectInstance 1\nObjectInstance 1\nObjectInstance 1\n"
                       "WorldEnd\n";
    setenv("TESSERA_MAX_INSTANCED_PATCHES", "100", 1);
    expect_error(text, "t.rib:8:1: error: ObjectInstance: instances add more than 100 patches "
                       "(each instance is a copy of its object's patches)");
    setenv("TESSERA_MAX_INSTANCED_PATCHES", "128", 1);
    ts_scene s;
    test_parse_rib_ok(text, &s);
    assert_int_equal(s.patch_count, 128);
    scene_free(&s);
    unsetenv("TESSERA_MAX_INSTANCED_PATCHES");
}

/* aqsis/examples/features/objectinstance/singlepolygon.rib (a K-3D export): one quad
 * instanced twelve times, each under its own Transform. */
static void test_corpus_instances(void **state)
{
    (void)state;
    ts_scene s;
    ts_error e = {0};
    memset(&s, 0, sizeof s);
    if (rib_load(test_source_path("tests/rib-corpus/aqsis/examples/features/objectinstance/"
                                  "singlepolygon.rib"),
                 &s, 1, &e) != TS_OK)
        fail_msg("%s", e.msg);
    assert_int_equal(s.patch_count % 12, 0);
    uint32_t per = s.patch_count / 12;
    assert_true(per >= 1);
    /* Instance k sits k units up z (the last two both at 10), the same quad otherwise. */
    const float dz[12] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 10};
    for (uint32_t k = 0; k < 12; k++)
        for (uint32_t i = 0; i < per * 16; i++) {
            const ts_vec4 *a = &s.cp[i], *b = &s.cp[(size_t)k * per * 16 + i];
            if (!(a->x == b->x && a->y == b->y && b->z - a->z == dz[k]))
                fail_msg("instance %u, point %u: (%g %g %g) vs (%g %g %g)", k, i, b->x, b->y, b->z,
                         a->x, a->y, a->z);
        }
    scene_free(&s);
}

/* scene/instances.rib: nine instances of one table-with-teapot object after the floor; each
 * instance's table keeps the definition's colour, its teapot takes the instance's. */
static void test_instances_scene(void **state)
{
    (void)state;
    ts_scene s;
    ts_error e = {0};
    memset(&s, 0, sizeof s);
    if (rib_load(test_source_path("scene/instances.rib"), &s, 1, &e) != TS_OK)
        fail_msg("%s", e.msg);
    ts_scene floor;
    test_parse_rib_ok("Disk 0 9 360\n", &floor);
    uint32_t f = floor.patch_count, per = (s.patch_count - f) / 9;
    scene_free(&floor);
    assert_int_equal(s.patch_count, f + 9 * per);
    assert_int_equal(per, 8 + 32); /* Cylinder and Disk, teapot */
    for (uint32_t k = 0; k < 9; k++) {
        const ts_patch_attr *table = &s.attr[f + k * per], *pot = &s.attr[f + k * per + per - 1];
        assert_true(table->cs_r == 0.55f && table->cs_g == 0.4f && table->cs_b == 0.3f);
        if (k > 0)
            assert_false(pot->cs_r == s.attr[f + per - 1].cs_r &&
                         pot->cs_b == s.attr[f + per - 1].cs_b);
    }
    scene_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_instances_equal_written_out),
        cmocka_unit_test(test_handles_and_redefinition),
        cmocka_unit_test(test_object_undefined),
        cmocka_unit_test(test_object_errors),
        cmocka_unit_test(test_object_ends_in_its_file),
        cmocka_unit_test(test_instanced_patch_bound),
        cmocka_unit_test(test_corpus_instances),
        cmocka_unit_test(test_instances_scene),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
