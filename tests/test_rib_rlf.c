/* test_rib_rlf.c — RenderMan for Maya's look files (issue 39, item 7; host/scene/rib/rib_rlf.c,
 * rib_look.c): tests/rlf/looks.rib and looks.rlf bind each object's identifier path to a
 * payload, whose Bxdf the object's patch must carry; a missing look file warns (an error with
 * --strict) and leaves the RIB's own shading; malformed ones name the .rlf's line and column;
 * payload requests are reported at the .rlf's lines; the nuggets Tessera does not apply warn.
 * Host only: never skips. */
#include "scene/rib/rib.h"
#include "scene/scene.h"
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define QUAD TEST_RIB_QUAD

static void expect_in(const char *text, const char *needle)
{
    if (!strstr(text, needle)) fail_msg("\"%s\" not in \"%s\"", needle, text);
}

/* A scene of one bound quad: WorldBegin, the ScopeBegin naming `rlf_name`, a default Bxdf,
 * then an object "obj/objShape" with an Inject, written as dir/name. */
static const char *write_scene(const char *dir, const char *name, const char *rlf_name)
{
    char text[4096];
    snprintf(text, sizeof text,
             "Format 8 8 1\nWorldBegin\n##RLF ScopeBegin -name s -rlffilename %s -namespace \n"
             "Bxdf \"PxrDiffuse\" \"default\"\nAttributeBegin\n"
             "Attribute \"identifier\" \"string name\" [\"obj\"]\nAttributeBegin\n"
             "Attribute \"identifier\" \"string name\" [\"objShape\"]\n"
             "##RLF Inject SurfaceShading -attribute sets@,aSG,\n" QUAD
             "AttributeEnd\nAttributeEnd\n" QUAD "##RLF ScopeEnd -name s\nWorldEnd\n",
             rlf_name);
    const char *path = test_path_in(dir, name);
    test_write_text(path, text);
    return path;
}

/* A look file binding obj/objShape to payload aSG = `payload` (its RIB text). */
static void write_look(const char *path, const char *payload)
{
    char text[4096];
    snprintf(text, sizeof text,
             "<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?>\n"
             "<RenderManLookFile Version=\"1\">\n<InjectablePayloads>\n"
             "<Payload Id=\"aSG\"><![CDATA[##RenderMan RIB\n%s]]></Payload>\n"
             "</InjectablePayloads>\n<TightBindings>\n"
             "<Binding Key=\"obj/objShape\" PayloadId=\"aSG\"/>\n</TightBindings>\n"
             "</RenderManLookFile>\n",
             payload);
    test_write_text(path, text);
}

/* ---- bindings ---------------------------------------------------------------------------- */

/* tests/rlf/looks.rib: each quad has the Bxdf its identifier path is bound to. */
static void test_looks_scene(void **state)
{
    (void)state;
    ts_scene s;
    ts_error e;
    char out[8192];
    int rc =
        test_rib_load_capture(test_source_path("tests/rlf/looks.rib"), 1, &s, &e, out, sizeof out);
    if (rc != TS_OK) fail_msg("%s", e.msg);
    assert_int_equal(s.patch_count, 4);
    /* left/leftShape: redSG's PxrDiffuse, through RfM's IfBegin guard */
    assert_int_equal(s.attr[0].material, TS_MAT_MATTE);
    test_assert_cs(&s.attr[0], 0.8, 0.1, 0.1);
    /* mid/midShape: bound twice, the later binding (goldSG, metallic PxrDisney) holds */
    assert_int_equal(s.attr[1].material, TS_MAT_PRINCIPLED);
    test_assert_near(s.attr[1].metallic, 1.0, 0.0);
    test_assert_cs(&s.attr[1], 0.9, 0.6, 0.2);
    /* inner/innerShape: "inner" replaced "group" (set in the same attribute block) */
    assert_int_equal(s.attr[2].material, TS_MAT_GLASS);
    test_assert_near(s.attr[2].ior, 1.33, 1e-6);
    /* floor/floorShape: no binding ("floor" alone is bound): the RIB's PxrDiffuse */
    assert_int_equal(s.attr[3].material, TS_MAT_MATTE);
    test_assert_cs(&s.attr[3], 0.5, 0.5, 0.5);
    expect_in(out, "looks.rib:24:56: warning: Attribute parameter \"id\" is ignored\n");
    assert_null(strstr(out, "looks.rlf")); /* the payloads read without a warning */
    scene_free(&s);
}

/* A payload is scoped by the RIB's attribute block, found beside the RIB when -rlffilename
 * names a file that is not there, and its requests' messages name the .rlf's lines. */
static void test_payload_scope_and_positions(void **state)
{
    (void)state;
    const char *dir = test_scratch_dir();
    write_look(test_path_in(dir, "one.rlf"), "Bxdf \"PxrDiffuse\" \"b\" \"color diffuseColor\" "
                                             "[0.1 0.2 0.3]\n");
    const char *rib = write_scene(dir, "one.rib", "elsewhere/one.0001.rlf"); /* the sibling */
    ts_scene s;
    ts_error e;
    char out[8192];
    assert_int_equal(test_rib_load_capture(rib, 1, &s, &e, out, sizeof out), TS_OK);
    assert_int_equal(s.patch_count, 2);
    test_assert_cs(&s.attr[0], 0.1, 0.2, 0.3);
    test_assert_cs(&s.attr[1], 0.5, 0.5, 0.5); /* after AttributeEnd: the RIB's default again */
    scene_free(&s);
    /* An error inside the payload: at the look file's line 4 (the CDATA starts on line 4
     * after "##RenderMan RIB"; the request is on line 5), column 1. */
    write_look(test_path_in(dir, "one.rlf"), "Bogus 1\n");
    char want[4096];
    assert_int_equal(test_rib_load_capture(rib, 0, &s, &e, out, sizeof out), TS_E_SCENE);
    snprintf(want, sizeof want, "%s:5:1: error: unknown request Bogus",
             test_path_in(dir, "one.rlf"));
    assert_string_equal(e.msg, want);
    /* A payload's column: the second request on the CDATA's own line. */
    test_write_text(test_path_in(dir, "one.rlf"),
                    "<RenderManLookFile>\n<InjectablePayloads>\n"
                    "  <Payload Id=\"aSG\"><![CDATA[Bogus 2]]></Payload>\n"
                    "</InjectablePayloads>\n<TightBindings>\n"
                    "<Binding Key=\"obj/objShape\" PayloadId=\"aSG\"/>\n</TightBindings>\n"
                    "</RenderManLookFile>\n");
    assert_int_equal(test_rib_load_capture(rib, 0, &s, &e, out, sizeof out), TS_E_SCENE);
    snprintf(want, sizeof want, "%s:3:30: error: unknown request Bogus",
             test_path_in(dir, "one.rlf"));
    assert_string_equal(e.msg, want);
}

/* Binary RIB, as RenderMan for Maya 21 writes it: a nugget right after a binary token (here
 * the string "objShape", 0230 then 8 bytes) with no line end before it. */
static void test_binary_rib(void **state)
{
    (void)state;
    const char *dir = test_scratch_dir();
    write_look(test_path_in(dir, "bin.rlf"), "Bxdf \"PxrDiffuse\" \"b\" \"color diffuseColor\" "
                                             "[0.25 0.5 1]\n");
    const char *rib = test_path_in(dir, "bin.rib");
    test_write_text(rib, "\314\001\232WorldBegin\246\001" /* code 1: WorldBegin */
                         "##RLF ScopeBegin -name s -rlffilename bin.rlf\n"
                         "\314\002\236AttributeBegin\246\002" /* code 2: AttributeBegin */
                         "Attribute \"identifier\" \"string name\" [\"obj\"]\n\246\002"
                         "Attribute \"identifier\" \"string name\" \230objShape"
                         "##RLF Inject SurfaceShading -attribute sets@,aSG,\n" QUAD
                         "AttributeEnd\nAttributeEnd\nWorldEnd\n");
    ts_scene s;
    ts_error e;
    char out[8192];
    if (test_rib_load_capture(rib, 1, &s, &e, out, sizeof out) != TS_OK) fail_msg("%s", e.msg);
    assert_int_equal(s.patch_count, 1);
    test_assert_cs(&s.attr[0], 0.25, 0.5, 1);
    scene_free(&s);
}

/* ---- missing and malformed look files -------------------------------------------------- */

static void test_missing_look_file(void **state)
{
    (void)state;
    const char *dir = test_scratch_dir();
    const char *rib = write_scene(dir, "two.rib", "nope.rlf");
    ts_scene s;
    ts_error e;
    char out[8192], want[4096];
    assert_int_equal(test_rib_load_capture(rib, 0, &s, &e, out, sizeof out), TS_OK);
    assert_int_equal(s.patch_count, 2);
    test_assert_cs(&s.attr[0], 0.5, 0.5, 0.5); /* the RIB's own shading */
    snprintf(want, sizeof want,
             "two.rib:3:1: warning: ##RLF ScopeBegin: cannot read look file \"%s\": No such file "
             "or directory; the objects of its scope keep the shading the RIB gives them "
             "(--strict makes this an error)\n",
             test_path_in(dir, "nope.rlf"));
    expect_in(out, want);
    scene_free(&s);
    assert_int_equal(test_rib_load_capture(rib, 1, &s, &e, out, sizeof out), TS_E_SCENE);
    snprintf(want, sizeof want,
             "%s:3:1: error: ##RLF ScopeBegin: cannot read look file \"%s\": No such file or "
             "directory",
             rib, test_path_in(dir, "nope.rlf"));
    assert_string_equal(e.msg, want);
    assert_int_equal(s.patch_count, 0);
}

/* Each malformed file: a warning naming the .rlf's line and column (the error with --strict),
 * and the RIB's shading. */
static void expect_malformed(const char *dir, const char *look, const char *why)
{
    test_write_text(test_path_in(dir, "bad.rlf"), look);
    const char *rib = write_scene(dir, "bad.rib", "bad.rlf");
    ts_scene s;
    ts_error e;
    char out[8192], want[4096];
    assert_int_equal(test_rib_load_capture(rib, 0, &s, &e, out, sizeof out), TS_OK);
    assert_int_equal(s.patch_count, 2);
    test_assert_cs(&s.attr[0], 0.5, 0.5, 0.5);
    const char *path = test_path_in(dir, "bad.rlf");
    snprintf(want, sizeof want, "bad.rib:3:1: warning: ##RLF ScopeBegin: cannot read look file ");
    expect_in(out, want);
    snprintf(want, sizeof want, "\": %s:%s; the objects of its scope keep", path, why);
    expect_in(out, want);
    scene_free(&s);
    assert_int_equal(test_rib_load_capture(rib, 1, &s, &e, out, sizeof out), TS_E_SCENE);
    snprintf(want, sizeof want, "%s:%s", path, why);
    size_t n = strlen(e.msg), k = strlen(want);
    if (n < k || strcmp(e.msg + n - k, want) != 0)
        fail_msg("\"%s\" does not end \"%s\"", e.msg, want);
}

static void test_malformed_look_files(void **state)
{
    (void)state;
    const char *dir = test_scratch_dir();
    expect_malformed(dir, "<RenderManLookFile>\n  <TightBindings>\n  </Tight>\n",
                     "3:5: XML: mismatched tag");
    expect_malformed(dir, "<RenderManLookFile>\n<a b=\"1\" b=\"2\"/></RenderManLookFile>\n",
                     "2:10: XML: duplicate attribute");
    expect_malformed(dir, "<?xml version=\"1.0\"?>\n<RenderManLookFile>",
                     "2:20: XML: no element found");
    expect_malformed(dir, "<?xml version=\"1.0\"?>\n<Look/>\n",
                     "2:1: the root element is <Look>, not <RenderManLookFile>");
    expect_malformed(dir,
                     "<RenderManLookFile><InjectablePayloads>\n<Payload Id=\"a\"/>\n"
                     "  <Payload Id=\"a\"/></InjectablePayloads></RenderManLookFile>\n",
                     "3:3: Payload \"a\" is defined twice (first at 2:1)");
    expect_malformed(dir,
                     "<RenderManLookFile><TightBindings>\n"
                     "  <Binding Key=\"obj/objShape\" PayloadId=\"none\"/>\n"
                     "</TightBindings></RenderManLookFile>\n",
                     "2:3: Binding \"obj/objShape\" names payload \"none\", which the file does "
                     "not define");
    expect_malformed(dir,
                     "<RenderManLookFile><InjectablePayloads>\n"
                     "<Payload Id=\"a\">Bxdf <b/></Payload>\n"
                     "</InjectablePayloads></RenderManLookFile>\n",
                     "2:22: an element <b> inside a Payload (its RIB text)");
    /* A file larger than 64 MiB (sparse: made in no time) is refused before it is read. */
    const char *big = test_path_in(dir, "big.rlf");
    FILE *f = fopen(big, "wb");
    assert_non_null(f);
    assert_int_equal(ftruncate(fileno(f), (off_t)(64 << 20) + 1), 0);
    fclose(f);
    const char *rib = write_scene(dir, "big.rib", "big.rlf");
    ts_scene s;
    ts_error e;
    char out[8192], want[4096];
    assert_int_equal(test_rib_load_capture(rib, 1, &s, &e, out, sizeof out), TS_E_SCENE);
    snprintf(want, sizeof want, "\"%s\": %s: larger than 64 MiB", big, big);
    expect_in(e.msg, want);
}

/* ---- what is not applied ----------------------------------------------------------------- */

static void test_nuggets_not_applied(void **state)
{
    (void)state;
    const char *dir = test_scratch_dir();
    test_write_text(test_path_in(dir, "rules.rlf"),
                    "<RenderManLookFile><RuleSet>\n<Rule FlowControl=\"0\" Id=\"a\"><![CDATA[//*]]>"
                    "</Rule>\n</RuleSet><InjectablePayloads><Payload Id=\"a\">Bxdf \"PxrDiffuse\" "
                    "\"x\" \"color diffuseColor\" [1 0 0]</Payload></InjectablePayloads>"
                    "<StaticEdits/></RenderManLookFile>\n");
    const char *rib = test_path_in(dir, "n.rib");
    test_write_text(rib, "WorldBegin\n##RLF Inject SurfaceShading\n"
                         "##RLF ScopeBegin -name n -rlffilename rules.rlf -namespace ns1\n"
                         "##RLF Inject Displacement\n##RLF Frobnicate\n"
                         "Color [##RLF Inject SurfaceShading\n1 0.5 0.25]\n" QUAD
                         "##RLF ScopeEnd\n##RLF ScopeEnd\nWorldEnd\n");
    ts_scene s;
    ts_error e;
    char out[8192];
    assert_int_equal(test_rib_load_capture(rib, 1, &s, &e, out, sizeof out), TS_OK);
    assert_int_equal(s.patch_count, 1);
    /* no Bxdf: the rule is not applied; a nugget inside an array is a comment */
    test_assert_cs(&s.attr[0], 1, 0.5, 0.25);
    expect_in(out, "n.rib:2:1: warning: ##RLF Inject outside ##RLF ScopeBegin ... ScopeEnd: no "
                   "look file, nothing injected\n");
    expect_in(out, "n.rib:3:1: warning: ##RLF ScopeBegin: -namespace \"ns1\" is not applied "
                   "(keys are matched without it)\n");
    expect_in(out, "its 1 dynamic rules (RuleSet, XPath) are not applied, only its static "
                   "bindings\n");
    expect_in(out, "rules.rlf\": <StaticEdits> is not read\n");
    expect_in(out, "n.rib:4:1: warning: ##RLF Inject Displacement is not applied (SurfaceShading "
                   "is)\n");
    expect_in(out, "n.rib:5:1: warning: ##RLF Frobnicate is ignored (ScopeBegin, ScopeEnd, "
                   "Inject)\n");
    expect_in(out, "n.rib:10:1: warning: ##RLF ScopeEnd without ##RLF ScopeBegin is ignored\n");
    scene_free(&s);
}

/* An ordinary comment is skipped as before; "##RLF" must be followed by a blank. */
static void test_comments_unchanged(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok(
        "##RenderMan RIB\n##RLFX Inject\nWorldBegin # ##RLF Inject\n" QUAD "WorldEnd\n", &s);
    assert_int_equal(s.patch_count, 1);
    scene_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_looks_scene),
        cmocka_unit_test(test_payload_scope_and_positions),
        cmocka_unit_test(test_binary_rib),
        cmocka_unit_test(test_missing_look_file),
        cmocka_unit_test(test_malformed_look_files),
        cmocka_unit_test(test_nuggets_not_applied),
        cmocka_unit_test(test_comments_unchanged),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
