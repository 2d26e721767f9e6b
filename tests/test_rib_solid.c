/* test_rib_solid.c — SolidBegin/SolidEnd (RI Spec 3.2 §5.9, host/scene/rib/rib_state.c,
 * docs/rib.md "Solids"): "primitive" and "union" solids are their surfaces, patch for patch
 * the same as without the block; "intersection" and "difference" are drawn as surfaces with a
 * warning; the blocks nest like AttributeBegin (what they change is restored at SolidEnd);
 * the RI Spec's rules on what a block may hold and bad nesting are errors at their place.
 * Host only: never skips. */
#include "scene/rib/rib.h"
#include "scene/scene.h"

#include <stdio.h>
#include <string.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

/* s and t hold the same patches, bit for bit (points and colours). */
static void assert_same_patches(const ts_scene *s, const ts_scene *t)
{
    assert_int_equal(s->patch_count, t->patch_count);
    assert_memory_equal(s->cp, t->cp, (size_t)s->patch_count * 16 * sizeof *s->cp);
    for (uint32_t q = 0; q < s->patch_count; q++)
        assert_true(s->attr[q].cs_r == t->attr[q].cs_r && s->attr[q].cs_g == t->attr[q].cs_g &&
                    s->attr[q].cs_b == t->attr[q].cs_b);
}

#define TWO_SPHERES "Sphere 1 -1 1 360\nTranslate 0.5 0 0\nColor [0 1 0]\nSphere 1 -1 1 360\n"

static void test_union_is_its_surfaces(void **state)
{
    (void)state;
    ts_scene plain, solid;
    test_parse_rib_ok("WorldBegin\nAttributeBegin\n" TWO_SPHERES "AttributeEnd\nSphere 2 -2 2 360\n"
                      "WorldEnd\n",
                      &plain);
    test_parse_rib_ok("WorldBegin\nSolidBegin \"union\"\nSolidBegin \"primitive\"\n"
                      "Sphere 1 -1 1 360\nSolidEnd\nTranslate 0.5 0 0\nColor [0 1 0]\n"
                      "SolidBegin \"primitive\"\nSphere 1 -1 1 360\nSolidEnd\nSolidEnd\n"
                      "Sphere 2 -2 2 360\nWorldEnd\n",
                      &solid);
    /* The union's Translate and Color end with it, as an attribute block's would. */
    assert_same_patches(&plain, &solid);
    scene_free(&plain);
    scene_free(&solid);
    int rc = 0;
    const char *w = test_rib_warnings("WorldBegin\nSolidBegin \"primitive\"\nSphere 1 -1 1 360\n"
                                      "SolidEnd\nWorldEnd\n",
                                      &rc);
    assert_int_equal(rc, 0);
    assert_null(strstr(w, "Solid"));
}

static void test_set_operations_warn(void **state)
{
    (void)state;
    static const char *const ops[] = {"intersection", "difference"};
    for (int i = 0; i < 2; i++) {
        char text[512], want[256];
        snprintf(text, sizeof text,
                 "WorldBegin\nSolidBegin \"%s\"\nSolidBegin \"primitive\"\nSphere 1 -1 1 360\n"
                 "SolidEnd\nSolidBegin \"primitive\"\nTranslate 0.5 0 0\nSphere 1 -1 1 360\n"
                 "SolidEnd\nSolidEnd\nWorldEnd\n",
                 ops[i]);
        snprintf(want, sizeof want,
                 "w.rib:2:1: warning: SolidBegin \"%s\": set operations are not implemented; its "
                 "solids are drawn whole, as surfaces",
                 ops[i]);
        int rc = 0;
        const char *w = test_rib_warnings(text, &rc);
        assert_int_equal(rc, 0);
        if (!strstr(w, want)) fail_msg("warnings: %s", w);
        ts_scene s;
        test_parse_rib_ok(text, &s);
        assert_int_equal(s.patch_count, 16); /* both spheres, 8 patches each */
        scene_free(&s);
    }
}

static void test_errors(void **state)
{
    (void)state;
    test_parse_rib_error("WorldBegin\nSolidBegin \"xor\"\n",
                         "t.rib:2:12: error: SolidBegin: unknown operation \"xor\" (primitive, "
                         "union, intersection or difference)");
    test_parse_rib_error("SolidBegin \"union\"\n",
                         "t.rib:1:1: error: SolidBegin outside the world block");
    test_parse_rib_error("WorldBegin\nSolidBegin \"primitive\"\nSolidBegin \"primitive\"\n",
                         "t.rib:3:1: error: SolidBegin inside the \"primitive\" solid begun at 2:1 "
                         "(a primitive solid holds surfaces, not other solids)");
    test_parse_rib_error("WorldBegin\nSolidBegin \"union\"\nAttributeBegin\nSphere 1 -1 1 360\n",
                         "t.rib:4:1: error: Sphere directly inside the solid begun at 2:1, which "
                         "combines solids (surfaces go in SolidBegin \"primitive\" blocks, RI Spec "
                         "3.2 §5.9)");
    test_parse_rib_error("WorldBegin\nSolidEnd\n",
                         "t.rib:2:1: error: SolidEnd without a matching SolidBegin");
    test_parse_rib_error("WorldBegin\nSolidBegin \"union\"\nAttributeEnd\n",
                         "t.rib:3:1: error: AttributeEnd does not match the SolidBegin at 2:1");
    test_parse_rib_error("WorldBegin\nSolidBegin \"primitive\"\nSphere 1 -1 1 360\nWorldEnd\n",
                         "t.rib:4:1: error: WorldEnd does not match the SolidBegin at 2:1");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_union_is_its_surfaces),
        cmocka_unit_test(test_set_operations_warn),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
