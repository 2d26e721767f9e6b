/* test_rib_ris_patterns.c — the maths Pattern nodes folded at load (rib_pattern.c
 * pattern_maths: PxrMix, PxrToFloat, PxrToFloat3, PxrExposure, PxrClamp, PxrInvert): each formula
 * against hand values through PxrDiffuse's diffuseColor (the patch's Cs) and diffuseGain (its Kd),
 * their defaults, a chain of three, a cycle, a chain past the depth limit, an unknown pattern's and
 * a PxrTexture's input, and the exact warnings and errors. Host only: never skips. */
#include "scene/rib/rib.h"
#include "scene/scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

#define QUAD TEST_RIB_QUAD
#define DIFFUSE(node) "Bxdf \"PxrDiffuse\" \"d\" \"reference color diffuseColor\" [\"" node "\"]"

/* PxrMix: (1 - mix) color1 + mix color2; clampMix clamps mix into [0, 1]. */
static void test_mix(void **state)
{
    (void)state;
    ts_patch_attr a =
        test_rib_one_patch("Pattern \"PxrMix\" \"m\" \"color color1\" [0.2 0.4 0.6] \"color "
                           "color2\" [1 0 0.5] \"float mix\" [0.25]\n" DIFFUSE("m:resultRGB"));
    assert_int_equal(a.material, TS_MAT_MATTE);
    test_assert_cs(&a, 0.75 * 0.2 + 0.25, 0.75 * 0.4, 0.75 * 0.6 + 0.25 * 0.5);
    /* no output named: resultRGB; resultG: the float in all three channels */
    a = test_rib_one_patch(
        "Pattern \"PxrMix\" \"m\" \"color color1\" [0.2 0.4 0.6] \"float mix\" [0.5]\n"
        "Bxdf \"PxrDiffuse\" \"d\" \"reference color diffuseColor\" [\"m\"]");
    test_assert_cs(&a, 0.6, 0.7, 0.8);
    a = test_rib_one_patch(
        "Pattern \"PxrMix\" \"m\" \"color color1\" [0.2 0.4 0.6] \"float mix\" [0.5]\n" DIFFUSE(
            "m:resultG"));
    test_assert_cs(&a, 0.7, 0.7, 0.7);
    /* outside [0, 1] mix extrapolates, unless clampMix */
    a = test_rib_one_patch(
        "Pattern \"PxrMix\" \"m\" \"color color1\" [0.2 0.2 0.2] \"color color2\" [0.4 "
        "0.4 0.4] \"float mix\" [1.5]\n" DIFFUSE("m:resultRGB"));
    test_assert_cs(&a, 0.5, 0.5, 0.5);
    a = test_rib_one_patch(
        "Pattern \"PxrMix\" \"m\" \"color color1\" [0.2 0.2 0.2] \"color color2\" [0.4 "
        "0.4 0.4] \"float mix\" [1.5] \"int clampMix\" [1]\n" DIFFUSE("m:resultRGB"));
    test_assert_cs(&a, 0.4, 0.4, 0.4);
    /* a float parameter reads a float output: diffuseGain = resultB */
    a = test_rib_one_patch(
        "Pattern \"PxrMix\" \"m\" \"color color2\" [0 0 0.25] \"float mix\" [1]\n"
        "Bxdf \"PxrDiffuse\" \"d\" \"reference float diffuseGain\" [\"m:resultB\"]");
    test_assert_near(a.kd, 0.25, 1e-7);
}

/* The documented defaults: color1 0, color2 1, mix 0; PxrToFloat input 0, mode 0. */
static void test_defaults(void **state)
{
    (void)state;
    ts_patch_attr a = test_rib_one_patch("Pattern \"PxrMix\" \"m\"\n" DIFFUSE("m:resultRGB"));
    test_assert_cs(&a, 0, 0, 0);
    a = test_rib_one_patch("Pattern \"PxrMix\" \"m\" \"float mix\" [1]\n" DIFFUSE("m:resultRGB"));
    test_assert_cs(&a, 1, 1, 1);
    a = test_rib_one_patch("Pattern \"PxrToFloat\" \"f\"\n" DIFFUSE("f:resultF"));
    test_assert_cs(&a, 0, 0, 0);
    a = test_rib_one_patch(
        "Pattern \"PxrToFloat\" \"f\" \"color input\" [0.1 0.2 0.9]\n" DIFFUSE("f"));
    test_assert_cs(&a, 0.1, 0.1, 0.1);
}

/* PxrToFloat: channel `mode` of input, or (mode 4) its mean; mode 3 (luminance) warns. */
static void test_to_float(void **state)
{
    (void)state;
    ts_patch_attr a =
        test_rib_one_patch("Pattern \"PxrToFloat\" \"f\" \"color input\" [0.1 0.2 0.9] \"int "
                           "mode\" [1]\n" DIFFUSE("f:resultF"));
    test_assert_cs(&a, 0.2, 0.2, 0.2);
    a = test_rib_one_patch(
        "Pattern \"PxrToFloat\" \"f\" \"color input\" [0.1 0.2 0.9] \"int mode\" [2]\n"
        "Bxdf \"PxrDiffuse\" \"d\" \"reference float diffuseGain\" [\"f:resultF\"]");
    test_assert_near(a.kd, 0.9, 1e-7);
    a = test_rib_one_patch(
        "Pattern \"PxrToFloat\" \"f\" \"color input\" [0.1 0.2 0.9] \"int mode\" [4]\n" DIFFUSE(
            "f:resultF"));
    test_assert_cs(&a, 0.4, 0.4, 0.4);
    const char *luminance = "Pattern \"PxrToFloat\" \"f\" \"color input\" [0.1 0.2 0.9] \"int "
                            "mode\" [3]\n" DIFFUSE("f:resultF");
    a = test_rib_one_patch(luminance);
    test_assert_cs(&a, 0.5, 0.5, 0.5); /* PxrDiffuse's default */
    assert_string_equal(test_rib_body_warnings(luminance),
                        "w.rib:3:54: warning: Pattern \"PxrToFloat\": mode 3 is not folded "
                        "(luminance, whose weights the docs do not give): what it feeds keeps its "
                        "default\n");
}

/* Three nodes: a PxrMix into a PxrToFloat whose resultF is the mix of a second PxrMix. */
static void test_chain(void **state)
{
    (void)state;
    ts_patch_attr a = test_rib_one_patch(
        "Pattern \"PxrMix\" \"a\" \"color color1\" [0.2 0.4 0.6] \"color color2\" [0.6 0.8 1] "
        "\"float mix\" [0.5]\n"
        "Pattern \"PxrToFloat\" \"f\" \"reference color input\" [\"a:resultRGB\"] \"int mode\" "
        "[4]\n"
        "Pattern \"PxrMix\" \"b\" \"color color1\" [1 0 0] \"color color2\" [0 0 1] \"reference "
        "float mix\" [\"f:resultF\"]\n" DIFFUSE("b:resultRGB"));
    /* a = (0.4 0.6 0.8), f = 0.6, b = 0.4 (1 0 0) + 0.6 (0 0 1) */
    test_assert_cs(&a, 0.4, 0, 0.6);
    /* the same node read twice (color1 and color2) */
    a = test_rib_one_patch(
        "Pattern \"PxrMix\" \"a\" \"color color1\" [0.2 0.4 0.6]\n"
        "Pattern \"PxrMix\" \"b\" \"reference color color1\" [\"a:resultRGB\"] "
        "\"reference color color2\" [\"a:resultR\"] \"float mix\" [0.5]\n" DIFFUSE("b:resultRGB"));
    test_assert_cs(&a, 0.2, 0.3, 0.4);
}

/* RenderMan 22's plugins: PxrToFloat3 (input in all channels, or inputR/G/B when one is
 * connected), PxrExposure (times 2^stops), PxrClamp (into [min, max]; modulus warns) and
 * PxrInvert (RGB: 1 - c on the channels asked, clamped into [0, 1]; HSL/HSV warn). */
static void test_plugins(void **state)
{
    (void)state;
    ts_patch_attr a = test_rib_one_patch("Pattern \"PxrToFloat3\" \"t\" \"float input\" [0.3] "
                                         "\"float inputR\" [0.9]\n" DIFFUSE("t:resultRGB"));
    test_assert_cs(&a, 0.3, 0.3, 0.3);
    a = test_rib_one_patch(
        "Pattern \"PxrMix\" \"m\" \"color color1\" [0.2 0.4 0.6]\n"
        "Pattern \"PxrToFloat3\" \"t\" \"float input\" [0.3] \"reference float inputR\" "
        "[\"m:resultB\"] \"float inputG\" [0.5]\n" DIFFUSE("t:resultRGB"));
    test_assert_cs(&a, 0.6, 0.5, 0);
    a = test_rib_one_patch("Pattern \"PxrExposure\" \"e\" \"color inputRGB\" [0.1 0.2 0.05] "
                           "\"float stops\" [2]\n" DIFFUSE("e:resultRGB"));
    test_assert_cs(&a, 0.4, 0.8, 0.2);
    a = test_rib_one_patch("Pattern \"PxrClamp\" \"c\" \"color inputRGB\" [-0.5 0.5 1.5] \"color "
                           "min\" [0 0.6 0] \"color max\" [1 1 0.8]\n" DIFFUSE("c:resultRGB"));
    test_assert_cs(&a, 0, 0.6, 0.8);
    const char *modulus = "Pattern \"PxrClamp\" \"c\" \"color inputRGB\" [0.5 0.5 0.5] \"int "
                          "modulus\" [1]\n" DIFFUSE("c:resultRGB");
    a = test_rib_one_patch(modulus);
    test_assert_cs(&a, 0.5, 0.5, 0.5); /* PxrDiffuse's default */
    assert_string_equal(test_rib_body_warnings(modulus),
                        "w.rib:3:54: warning: Pattern \"PxrClamp\": modulus 1 is not folded: what "
                        "it feeds keeps its default\n");
    a = test_rib_one_patch("Pattern \"PxrInvert\" \"i\" \"color inputRGB\" [0.25 1.5 0.6] \"int "
                           "invertChannel2\" [0]\n" DIFFUSE("i:resultRGB"));
    test_assert_cs(&a, 0.75, 0, 0.6);
    const char *hsv = "Pattern \"PxrInvert\" \"i\" \"color inputRGB\" [0.25 0.5 0.6] \"int "
                      "colorModel\" [2]\n" DIFFUSE("i:resultRGB");
    assert_string_equal(test_rib_body_warnings(hsv),
                        "w.rib:3:54: warning: Pattern \"PxrInvert\": colorModel 2 (HSL or HSV) is "
                        "not folded: what it feeds keeps its default\n");
}

/* A cycle: the connection that closes it keeps its default, with one warning. */
static void test_cycle(void **state)
{
    (void)state;
    const char *cycle = "Pattern \"PxrMix\" \"a\" \"reference color color1\" [\"b:resultRGB\"]\n"
                        "Pattern \"PxrMix\" \"b\" \"reference color color1\" [\"a:resultRGB\"] "
                        "\"float mix\" [0.5]\n" DIFFUSE("a:resultRGB");
    /* b = 0.5 (color1's default 0) + 0.5 (color2 1); a = b (mix 0) */
    ts_patch_attr a = test_rib_one_patch(cycle);
    test_assert_cs(&a, 0.5, 0.5, 0.5);
    assert_string_equal(test_rib_body_warnings(cycle),
                        "w.rib:4:54: warning: Pattern \"a\" is reached again through its own "
                        "inputs (a cycle): that connection takes its literal value or default\n");
    /* a node that is its own input */
    a = test_rib_one_patch(
        "Pattern \"PxrMix\" \"s\" \"reference color color2\" [\"s\"] \"float mix\" [1]\n" DIFFUSE(
            "s"));
    test_assert_cs(&a, 1, 1, 1);
}

/* A chain of `len` PxrMix nodes n0 .. n(len-1), each (mix 0) its color1: the previous node;
 * n0's colour is 0.7. The Bxdf reads the last. */
static const char *chain_of(int len)
{
    static char text[16384];
    size_t at = (size_t)snprintf(text, sizeof text,
                                 "Pattern \"PxrMix\" \"n0\" \"color color1\" [0.7 0.7 0.7]\n");
    for (int k = 1; k < len; k++)
        at += (size_t)snprintf(text + at, sizeof text - at,
                               "Pattern \"PxrMix\" \"n%d\" \"reference color color1\" "
                               "[\"n%d:resultRGB\"]\n",
                               k, k - 1);
    snprintf(text + at, sizeof text - at,
             "Bxdf \"PxrDiffuse\" \"d\" \"reference color diffuseColor\" [\"n%d\"]", len - 1);
    return text;
}

/* Up to 64 nodes fold; past that the 65th's consumer keeps its default, with a warning. */
static void test_depth(void **state)
{
    (void)state;
    ts_patch_attr a = test_rib_one_patch(chain_of(64));
    test_assert_cs(&a, 0.7, 0.7, 0.7);
    a = test_rib_one_patch(chain_of(70));
    test_assert_cs(&a, 0, 0, 0); /* n6's color1 is its default, 0 */
    assert_string_equal(test_rib_body_warnings(chain_of(70)),
                        "w.rib:72:54: warning: Pattern: a chain of more than 64 nodes (at \"n5\") "
                        "is not folded: what it feeds keeps its default\n");
}

/* An input connected to a pattern Tessera does not fold (an OSL shader), to a PxrTexture, or
 * to no node: its literal value or default, one warning each; the network still folds. */
static void test_unfolded_inputs(void **state)
{
    (void)state;
    const char *osl = "Pattern \"MyNoise\" \"n\" \"float freq\" [4]\n"
                      "Pattern \"PxrMix\" \"m\" \"reference color color1\" [\"n:resultRGB\"] "
                      "\"color color1\" [0.2 0.3 0.4] \"reference color color2\" [\"n:resultRGB\"] "
                      "\"float mix\" [0.5]\n" DIFFUSE("m:resultRGB");
    /* color1 its literal value, color2 its default (1) */
    ts_patch_attr a = test_rib_one_patch(osl);
    test_assert_cs(&a, 0.6, 0.65, 0.7);
    assert_string_equal(test_rib_body_warnings(osl),
                        "w.rib:4:54: warning: Pattern \"MyNoise\" is not supported: the parameters "
                        "connected to it keep their defaults (docs/rib.md lists the patterns "
                        "drawn)\n");
    /* A PxrTexture feeding PxrMix is not drawn through it: the input's default, no texture. */
    const char *tex = "Pattern \"PxrTexture\" \"t\" \"string filename\" [\"wood.tex\"]\n"
                      "Pattern \"PxrMix\" \"m\" \"reference color color2\" [\"t:resultRGB\"] "
                      "\"float mix\" [0.5] \"color color1\" [0 0.5 0]\n" DIFFUSE("m:resultRGB");
    a = test_rib_one_patch(tex);
    test_assert_cs(&a, 0.5, 0.75, 0.5);
    assert_int_equal(a.flags & TS_PATCH_COLOR_TEX, 0);
    assert_string_equal(test_rib_body_warnings(tex),
                        "w.rib:4:54: warning: Pattern \"PxrMix\": a PxrTexture through PxrMix is "
                        "not drawn: \"color2\" takes its default\n");
    const char *gone =
        "Pattern \"PxrMix\" \"m\" \"reference float mix\" [\"gone:resultF\"]\n" DIFFUSE(
            "m:resultRGB");
    a = test_rib_one_patch(gone);
    test_assert_cs(&a, 0, 0, 0);
    assert_string_equal(test_rib_body_warnings(gone),
                        "w.rib:3:54: warning: Pattern \"PxrMix\": \"mix\" is connected to "
                        "\"gone:resultF\", which no Pattern defines: it takes its default\n");
}

/* Outputs a parameter cannot read: a colour into a float, an output the node lacks. */
static void test_outputs(void **state)
{
    (void)state;
    const char *rgb = "Pattern \"PxrMix\" \"m\" \"float mix\" [1]\nBxdf \"PxrDiffuse\" \"d\" "
                      "\"reference float diffuseGain\" [\"m:resultRGB\"]";
    ts_patch_attr a = test_rib_one_patch(rgb);
    test_assert_near(a.kd, 1, 0); /* PxrDiffuse's default gain */
    assert_string_equal(test_rib_body_warnings(rgb),
                        "w.rib:3:53: warning: Bxdf \"PxrDiffuse\": float \"diffuseGain\" is "
                        "connected to a colour output: it keeps its default (resultR, resultG, "
                        "resultB or resultF would be read)\n");
    const char *alpha = "Pattern \"PxrMix\" \"m\" \"float mix\" [1]\n" DIFFUSE("m:resultA");
    a = test_rib_one_patch(alpha);
    test_assert_cs(&a, 0.5, 0.5, 0.5);
    assert_string_equal(
        test_rib_body_warnings(alpha),
        "w.rib:3:54: warning: Pattern \"PxrMix\" has no output \"resultA\" "
        "(resultRGB, resultR, resultG, resultB): what it feeds keeps its default\n");
    const char *inner = "Pattern \"PxrMix\" \"a\"\nPattern \"PxrMix\" \"b\" \"reference float "
                        "mix\" [\"a:resultRGB\"] \"float mix\" [1]\n" DIFFUSE("b");
    a = test_rib_one_patch(inner);
    test_assert_cs(&a, 1, 1, 1); /* mix its literal value 1: color2 */
    assert_string_equal(test_rib_body_warnings(inner),
                        "w.rib:4:54: warning: Pattern \"PxrMix\": float \"mix\" is connected to "
                        "colour output \"a:resultRGB\": it takes its value\n");
    /* a Pattern parameter the node does not have */
    assert_string_equal(
        test_rib_body_warnings("Pattern \"PxrMix\" \"m\" \"float amount\" [1]\n" DIFFUSE("m")),
        "w.rib:2:22: warning: Pattern \"PxrMix\" parameter \"amount\" is "
        "ignored\n");
}

/* Values that are not finite: a literal input (binary RIB's IEEE infinity; ASCII's
 * overflows in the lexer), and a result out of float range. */
static void test_not_finite(void **state)
{
    (void)state;
    /* ASCII RIB cannot write one (the lexer's "number out of range") */
    test_parse_rib_error("WorldBegin\nPattern \"PxrMix\" \"m\" \"float mix\" [1e999]\n",
                         "t.rib:2:35: error: number out of range");
    test_parse_rib_error("WorldBegin\nPattern \"PxrMix\" \"m\" \"color color1\" [3e38 0 0] \"float "
                         "mix\" [-3e38]\n" DIFFUSE("m:resultRGB") "\n" QUAD,
                         "t.rib:3:54: error: Bxdf: \"diffuseColor\" is connected to "
                         "\"m:resultRGB\", whose value must be finite, got 9e+76");
}

/* Displace reads a folded constant as a literal dispScalar (not drawn: a uniform offset). */
static void test_displace(void **state)
{
    (void)state;
    assert_string_equal(
        test_rib_body_warnings("Pattern \"PxrToFloat\" \"f\" \"color input\" [0.5 0 0]\n"
                               "Displace \"PxrDisplace\" \"d\" \"reference float dispScalar\" "
                               "[\"f:resultF\"]"),
        "w.rib:3:1: warning: Displace \"PxrDisplace\": a constant dispScalar (a "
        "uniform offset of the surface) is not drawn: no displacement\n");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mix),      cmocka_unit_test(test_defaults),
        cmocka_unit_test(test_to_float), cmocka_unit_test(test_chain),
        cmocka_unit_test(test_plugins),  cmocka_unit_test(test_cycle),
        cmocka_unit_test(test_depth),    cmocka_unit_test(test_unfolded_inputs),
        cmocka_unit_test(test_outputs),  cmocka_unit_test(test_not_finite),
        cmocka_unit_test(test_displace),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
