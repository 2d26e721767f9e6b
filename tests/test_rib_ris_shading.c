/* test_rib_ris_shading.c — RenderMan 21-26 shading requests (issue 39): Bxdf onto the
 * materials, Pattern (PxrTexture, PxrManifold2D) and its connections, Displace
 * "PxrDisplace", Light (dome, distant and area lights), LightFilter, each with its numbers
 * and its exact warnings and errors. Host only: never skips. */
#include "scene/rib/rib.h"
#include "scene/scene.h"
#include "image/image.h"
#include "lib/bsdf.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

#define QUAD TEST_RIB_QUAD
#define SCHLICK(f0) ((f0) + (1.0 - (f0)) / 21.0) /* hemispherical mean, edge colour 1 */

static void assert_le(const ts_patch_attr *a, double r, double g, double b)
{
    test_assert_near(a->le_r, r, 1e-5 * r + 1e-7), test_assert_near(a->le_g, g, 1e-5 * g + 1e-7);
    test_assert_near(a->le_b, b, 1e-5 * b + 1e-7);
}

/* ---- Bxdf --------------------------------------------------------------------------- */

static void test_bxdf_diffuse(void **state)
{
    (void)state;
    ts_patch_attr a =
        test_rib_one_patch("Bxdf \"PxrDiffuse\" \"d\" \"color diffuseColor\" [0.2 0.4 0.6]");
    assert_int_equal(a.material, TS_MAT_MATTE);
    test_assert_near(a.kd, 1.0, 0),
        test_assert_cs(&a, 0.2, 0.4, 0.6);               /* Color [1 0 0] is not used */
    a = test_rib_one_patch("Bxdf \"PxrDiffuse\" \"d\""); /* RenderMan's default colour */
    test_assert_cs(&a, 0.5, 0.5, 0.5);
    a = test_rib_one_patch("Bxdf \"LamaDiffuse\" \"d\" \"color color\" [0.1 0.2 0.3]");
    assert_int_equal(a.material, TS_MAT_MATTE), test_assert_cs(&a, 0.1, 0.2, 0.3);
    /* An attribute: AttributeEnd restores the Surface before it. */
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nSurface \"plastic\"\nAttributeBegin\nBxdf \"PxrDiffuse\" \"d\"\n"
                      "AttributeEnd\n" QUAD "WorldEnd\n",
                      &s);
    assert_int_equal(s.attr[0].material, TS_MAT_PLASTIC);
    test_assert_cs(&s.attr[0], 1, 1, 1);
    scene_free(&s);
}

/* PxrSurface with refractionGain: glass of index glassIor (1.5), GGX alpha glassRoughness^2
 * (0.1: smooth), tinted by refractionGain * refractionColor; with diffuse or specular lobes
 * beside it one warning says they are not drawn. */
static void test_bxdf_surface_glass(void **state)
{
    (void)state;
    ts_patch_attr a =
        test_rib_one_patch("Bxdf \"PxrSurface\" \"g\" \"float diffuseGain\" [0] "
                           "\"float refractionGain\" [1] \"color diffuseColor\" [1 1 1]");
    assert_int_equal(a.material, TS_MAT_GLASS);
    test_assert_near(a.ior, 1.5, 0), test_assert_cs(&a, 1, 1, 1);
    assert_true(a.roughness <= TS_GLASS_SMOOTH);
    assert_string_equal(
        test_rib_body_warnings("Bxdf \"PxrSurface\" \"g\" \"float diffuseGain\" [0] "
                               "\"float refractionGain\" [1]"),
        "");
    a = test_rib_one_patch(
        "Bxdf \"PxrSurface\" \"g\" \"float diffuseGain\" [0] \"float refractionGain\" "
        "[0.5] \"color refractionColor\" [1 0.8 0.6] \"float glassIor\" [1.33] "
        "\"float glassRoughness\" [0.5]");
    assert_int_equal(a.material, TS_MAT_GLASS);
    test_assert_near(a.ior, 1.33, 1e-6), test_assert_near(a.roughness, 0.25, 1e-7);
    test_assert_cs(&a, 0.5, 0.4, 0.3);
    assert_string_equal(
        test_rib_body_warnings("Bxdf \"PxrSurface\" \"g\" \"float refractionGain\" [1]"),
        "w.rib:2:1: warning: Bxdf \"PxrSurface\": with refractionGain it is drawn "
        "as glass: its diffuse and specular lobes are not drawn\n");
    /* refractionGain 0 (the default): PxrSurface as before */
    a = test_rib_one_patch("Bxdf \"PxrSurface\" \"g\" \"float glassIor\" [1.33]");
    assert_int_equal(a.material, TS_MAT_MATTE);
}

/* PxrLMDiffuse: its frontColor (default PxrDiffuse's 0.5), its other parameters warned about
 * as unread; PxrLightEmission, RenderMan 20's light geometry: it reflects nothing and emits
 * its AreaLightSource's light, without a warning. */
static void test_bxdf_lm_diffuse_light_emission(void **state)
{
    (void)state;
    ts_patch_attr a =
        test_rib_one_patch("Bxdf \"PxrLMDiffuse\" \"d\" \"color frontColor\" [0.2 0.4 0.6]");
    assert_int_equal(a.material, TS_MAT_MATTE);
    test_assert_near(a.kd, 1.0, 0), test_assert_cs(&a, 0.2, 0.4, 0.6);
    a = test_rib_one_patch("Bxdf \"PxrLMDiffuse\" \"d\"");
    test_assert_cs(&a, 0.5, 0.5, 0.5);
    const char *w =
        test_rib_body_warnings("Bxdf \"PxrLMDiffuse\" \"d\" \"color backColor\" [1 1 1]");
    if (!strstr(w, "w.rib:2:") || !strstr(w, "backColor"))
        fail_msg("backColor not warned about: %s", w);
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nAttributeBegin\nBxdf \"PxrLightEmission\" \"e\"\n"
                      "AreaLightSource \"PxrStdAreaLight\" \"r\" \"float exposure\" [1]\n" QUAD
                      "AttributeEnd\nWorldEnd\n",
                      &s);
    assert_int_equal(s.patch_count, 1);
    test_assert_near(s.attr[0].kd, 0.0, 0), assert_le(&s.attr[0], 2, 2, 2);
    scene_free(&s);
    assert_string_equal(test_rib_body_warnings("Bxdf \"PxrLightEmission\" \"e\""), "");
}

/* PxrLMGlass: glass of index eta, its transmission tinted by refractionColor, GGX alpha
 * roughness^2 (its layers and reflection colour warned about as unread); PxrLMMetal: a
 * conductor, PxrConductor's parameters (its specularColor the face colour). */
static void test_bxdf_lm_glass_metal(void **state)
{
    (void)state;
    ts_patch_attr a = test_rib_one_patch("Bxdf \"PxrLMGlass\" \"g\" \"float eta\" [1.4] "
                                         "\"color refractionColor\" [0.9 0.8 0.7] "
                                         "\"float roughness\" [0.5]");
    assert_int_equal(a.material, TS_MAT_GLASS);
    test_assert_near(a.ior, 1.4, 1e-6), test_assert_near(a.roughness, 0.25, 1e-7);
    test_assert_cs(&a, 0.9, 0.8, 0.7);
    a = test_rib_one_patch("Bxdf \"PxrLMGlass\" \"g\"");
    assert_int_equal(a.material, TS_MAT_GLASS);
    test_assert_near(a.ior, 1.5, 0), test_assert_cs(&a, 1, 1, 1);
    assert_true(a.roughness <= TS_GLASS_SMOOTH);
    const char *w =
        test_rib_body_warnings("Bxdf \"PxrLMGlass\" \"g\" \"color reflectionColor\" [1 1 1]");
    if (!strstr(w, "w.rib:2:") || !strstr(w, "reflectionColor"))
        fail_msg("reflectionColor not warned about: %s", w);
    a = test_rib_one_patch("Bxdf \"PxrLMMetal\" \"m\" \"color specularColor\" [1 0.75 0.3]");
    assert_int_equal(a.material, TS_MAT_METAL);
    test_assert_cs(&a, SCHLICK(1.0), SCHLICK(0.75), SCHLICK(0.3));
}

/* A body defining two Bxdfs (defs1, defs2) and a LamaMix of handles h1 and h2 at mix. */
static void lama_mix(char body[1024], const char *defs1, const char *defs2, const char *h1,
                     const char *h2, const char *mix)
{
    snprintf(body, 1024,
             "%s%sBxdf \"LamaMix\" \"mix\" \"reference bxdf material1\" [\"%s\"] "
             "\"reference bxdf material2\" [\"%s\"] \"float mix\" [%s]",
             defs1, defs2, h1, h2, mix);
}

/* LamaMix: (1 - mix) material1 + mix material2 of the Bxdfs its references name. Exact where
 * Tessera's materials hold it (two mattes: their Kd Cs mixed; two metals or two glasses of one
 * roughness and index: their tints mixed; mix 0 or 1: one of them; the emissions mixed);
 * mattes, metals and principled BRDFs together: one principled BRDF of mixed parameters, with a
 * warning; glass with another material: the larger share, with a warning; a handle no Bxdf
 * defines: PxrDiffuse's default, with a warning. */
static void test_bxdf_lama_mix(void **state)
{
    (void)state;
    const char *red = "Bxdf \"LamaDiffuse\" \"red\" \"color color\" [0.8 0 0]\n";
    const char *blue = "Bxdf \"PxrDiffuse\" \"blue\" \"color diffuseColor\" [0 0 0.4] "
                       "\"float diffuseGain\" [0.5]\n";
    const char *gold = "Bxdf \"LamaConductor\" \"gold\" \"color reflectivity\" [1 0.8 0.4] "
                       "\"float roughness\" [0.3] \"color edgeColor\" [1 1 1]\n";
    const char *silver = "Bxdf \"LamaConductor\" \"silver\" \"color reflectivity\" [0.9 0.9 "
                         "0.9] \"float roughness\" [0.3] \"color edgeColor\" [1 1 1]\n";
    const char *glass = "Bxdf \"LamaDielectric\" \"glass\" \"float IOR\" [1.5]\n";
    char body[1024];
    /* two mattes: Kd Cs mixed, 0.25 of the way */
    lama_mix(body, red, blue, "red:bxdf_out", "blue", "0.25");
    ts_patch_attr a = test_rib_one_patch(body);
    assert_int_equal(a.material, TS_MAT_MATTE);
    test_assert_near(a.kd, 1.0, 0), test_assert_cs(&a, 0.6, 0.0, 0.05);
    assert_string_equal(test_rib_body_warnings(body), "");
    /* two metals of one roughness: their tints mixed */
    lama_mix(body, gold, silver, "gold", "silver", "0.5");
    a = test_rib_one_patch(body);
    assert_int_equal(a.material, TS_MAT_METAL), test_assert_near(a.roughness, 0.09, 1e-7);
    test_assert_cs(&a, 0.5 * (SCHLICK(1.0) + SCHLICK(0.9)), 0.5 * (SCHLICK(0.8) + SCHLICK(0.9)),
                   0.5 * (SCHLICK(0.4) + SCHLICK(0.9)));
    /* mix 0 and 1 (and beyond: clamped) are the materials themselves; 0.5 is the default */
    lama_mix(body, red, gold, "red", "gold", "1.5");
    a = test_rib_one_patch(body);
    assert_int_equal(a.material, TS_MAT_METAL),
        test_assert_cs(&a, SCHLICK(1.0), SCHLICK(0.8), SCHLICK(0.4));
    /* a matte and a metal: a principled BRDF, metallic = mix, the metal's roughness */
    lama_mix(body, red, gold, "red", "gold", "0.25");
    a = test_rib_one_patch(body);
    assert_int_equal(a.material, TS_MAT_PRINCIPLED);
    test_assert_near(a.metallic, 0.25, 1e-7), test_assert_near(a.roughness, 0.09, 1e-7);
    test_assert_cs(&a, 0.75 * 0.8 + 0.25 * SCHLICK(1.0), 0.25 * SCHLICK(0.8), 0.25 * SCHLICK(0.4));
    assert_string_equal(test_rib_body_warnings(body),
                        "w.rib:4:1: warning: Bxdf \"LamaMix\": materials of different kinds are "
                        "drawn as one principled BRDF of their mixed parameters (an "
                        "approximation)\n");
    /* glass and a matte: the larger share */
    lama_mix(body, red, glass, "red", "glass", "0.75");
    a = test_rib_one_patch(body);
    assert_int_equal(a.material, TS_MAT_GLASS);
    assert_string_equal(test_rib_body_warnings(body),
                        "w.rib:4:1: warning: Bxdf \"LamaMix\": glass with another material cannot "
                        "be mixed: it is drawn as material2, the larger share\n");
    /* a matte and an emitter: exact, the matte's share reflecting, the emitter's emitting */
    lama_mix(body, red, "Bxdf \"LamaEmission\" \"glow\" \"color color\" [2 1 0]\n", "red", "glow",
             "0.25");
    a = test_rib_one_patch(body);
    assert_int_equal(a.material, TS_MAT_MATTE), assert_le(&a, 0.5, 0.25, 0);
    test_assert_near(a.kd * a.cs_r, 0.6, 1e-6);
    assert_string_equal(test_rib_body_warnings(body), "");
    /* a handle no Bxdf defines, and an unknown parameter */
    snprintf(body, sizeof body,
             "%sBxdf \"LamaMix\" \"mix\" \"reference bxdf material1\" [\"red\"] "
             "\"reference bxdf material2\" [\"gone\"] \"float mix\" [0.5] \"int x\" [1]",
             red);
    a = test_rib_one_patch(body);
    assert_int_equal(a.material, TS_MAT_MATTE), test_assert_cs(&a, 0.65, 0.25, 0.25);
    const char *w = test_rib_body_warnings(body);
    if (!strstr(w, "\"material2\" is connected to \"gone\", which no Bxdf defines: it is "
                   "PxrDiffuse's default") ||
        !strstr(w, "Bxdf \"LamaMix\" parameter \"x\" is ignored"))
        fail_msg("warnings: %s", w);
}

/* A body defining Bxdfs defs and a Lama node of the inputs args. */
static void lama_node(char body[1024], const char *defs, const char *node, const char *args)
{
    snprintf(body, 1024, "%sBxdf \"%s\" \"n\" %s", defs, node, args);
}

/* The Lama nodes' defaults where they differ from the Pxr Bxdfs' (MaterialX's ND_lama_*):
 * LamaDiffuse 0.18; LamaConductor gold by IOR and extinction (physical Fresnel, to 1 at the
 * edge), its artistic face and edge colours under fresnelMode 1, times its tint; LamaMix's mix
 * 0 (material1); LamaDielectric's transmissionTint tints the glass. */
static void test_bxdf_lama_defaults(void **state)
{
    (void)state;
    ts_patch_attr a = test_rib_one_patch("Bxdf \"LamaDiffuse\" \"d\"");
    assert_int_equal(a.material, TS_MAT_MATTE), test_assert_cs(&a, 0.18, 0.18, 0.18);
    /* silent: the names of AOVs, and the shadowing of a bump Tessera does not draw */
    assert_string_equal(test_rib_body_warnings("Bxdf \"LamaDiffuse\" \"d\" \"string lobeName\" "
                                               "[\"diffuse\"] \"string matte\" [\"\"] \"int "
                                               "bumpShadowing\" [1]"),
                        "");
    a = test_rib_one_patch("Bxdf \"LamaConductor\" \"c\"");
    const double n[3] = {0.18, 0.42, 1.37}, k[3] = {3.42, 2.35, 1.77};
    double f0[3];
    for (int c = 0; c < 3; c++)
        f0[c] = ((n[c] - 1) * (n[c] - 1) + k[c] * k[c]) / ((n[c] + 1) * (n[c] + 1) + k[c] * k[c]);
    assert_int_equal(a.material, TS_MAT_METAL), test_assert_near(a.roughness, 0.01, 1e-7);
    test_assert_cs(&a, SCHLICK(f0[0]), SCHLICK(f0[1]), SCHLICK(f0[2]));
    a = test_rib_one_patch("Bxdf \"LamaConductor\" \"c\" \"int fresnelMode\" [1] \"color tint\" "
                           "[0.5 1 1]");
    test_assert_cs(&a, 0.5 * (0.945 + (0.9979 - 0.945) / 21), 0.7772 + (0.9813 - 0.7772) / 21,
                   0.3737 + (0.7523 - 0.3737) / 21);
    const char *physical = "Bxdf \"LamaConductor\" \"c\" \"int fresnelMode\" [0] \"color "
                           "reflectivity\" [1 1 1]";
    a = test_rib_one_patch(physical);
    test_assert_cs(&a, SCHLICK(f0[0]), SCHLICK(f0[1]), SCHLICK(f0[2]));
    assert_string_equal(test_rib_body_warnings(physical),
                        "w.rib:2:1: warning: Bxdf \"LamaConductor\": \"reflectivity\" is not read "
                        "under fresnelMode 0 (physical: IOR and extinction)\n");
    a = test_rib_one_patch("Bxdf \"LamaDielectric\" \"g\" \"color transmissionTint\" [1 0.5 0.25]");
    assert_int_equal(a.material, TS_MAT_GLASS), test_assert_cs(&a, 1, 0.5, 0.25);
    char body[1024];
    lama_node(body,
              "Bxdf \"LamaDiffuse\" \"r\" \"color color\" [0.8 0 0]\n"
              "Bxdf \"LamaDiffuse\" \"b\" \"color color\" [0 0 0.8]\n",
              "LamaMix",
              "\"reference bxdf material1\" [\"r\"] \"reference bxdf material2\" [\"b\"]");
    a = test_rib_one_patch(body);
    test_assert_cs(&a, 0.8, 0, 0);
    assert_string_equal(test_rib_body_warnings(body), "");
}

#define RED "Bxdf \"LamaDiffuse\" \"red\" \"color color\" [0.8 0 0]\n"
#define BLUE "Bxdf \"LamaDiffuse\" \"blue\" \"color color\" [0 0 0.4]\n"
#define GLOW "Bxdf \"LamaEmission\" \"glow\" \"color color\" [2 1 0]\n"

/* LamaAdd: weight1 material1 + weight2 material2. Two mattes: their Kd Cs weighted and added;
 * a matte and an emitter: the matte scaled, emitting the emitter's share; the default weights
 * (1, 0): material1 itself; one input: it scaled; weights over 1 in sum: drawn at 1, warned. */
static void test_bxdf_lama_add(void **state)
{
    (void)state;
    char body[1024];
    const char *both = "\"reference bxdf material1\" [\"red\"] \"reference bxdf material2\" "
                       "[\"%s\"] \"float weight1\" [%s] \"float weight2\" [%s]";
    char args[256];
    snprintf(args, sizeof args, both, "blue", "0.5", "0.25");
    lama_node(body, RED BLUE, "LamaAdd", args);
    ts_patch_attr a = test_rib_one_patch(body);
    assert_int_equal(a.material, TS_MAT_MATTE);
    test_assert_near(a.kd * a.cs_r, 0.5 * 0.8, 1e-6), test_assert_near(a.kd * a.cs_g, 0, 0);
    test_assert_near(a.kd * a.cs_b, 0.25 * 0.4, 1e-6);
    assert_string_equal(test_rib_body_warnings(body), "");
    snprintf(args, sizeof args, both, "glow", "0.5", "0.5");
    lama_node(body, RED GLOW, "LamaAdd", args);
    a = test_rib_one_patch(body);
    assert_int_equal(a.material, TS_MAT_MATTE), assert_le(&a, 1, 0.5, 0);
    test_assert_near(a.kd * a.cs_r, 0.4, 1e-6);
    assert_string_equal(test_rib_body_warnings(body), "");
    lama_node(body, RED BLUE, "LamaAdd",
              "\"reference bxdf material1\" [\"red\"] \"reference bxdf material2\" [\"blue\"]");
    a = test_rib_one_patch(body);
    test_assert_near(a.kd, 1, 0), test_assert_cs(&a, 0.8, 0, 0);
    lama_node(body, BLUE, "LamaAdd",
              "\"reference bxdf material2\" [\"blue\"] \"float weight2\" [0.5]");
    a = test_rib_one_patch(body);
    test_assert_near(a.kd * a.cs_b, 0.2, 1e-6);
    snprintf(args, sizeof args, both, "blue", "1", "0.5");
    lama_node(body, RED BLUE, "LamaAdd", args);
    a = test_rib_one_patch(body);
    test_assert_near(a.kd * a.cs_r, 0.8 / 1.5, 1e-6),
        test_assert_near(a.kd * a.cs_b, 0.2 / 1.5, 1e-6);
    assert_string_equal(test_rib_body_warnings(body),
                        "w.rib:4:1: warning: Bxdf \"LamaAdd\": weights summing to 1.5 would "
                        "reflect more light than arrives: the sum is drawn at weight 1\n");
}

/* LamaLayer: a glass top over a reflecting base is a clear coat on the base as a principled
 * BRDF (4 c / c(0.04) at topMix 1: a whole Fresnel coat for index 1.5), its gloss from the
 * top's roughness; another top covers the base by topMix (a mix); no top: the base. */
static void test_bxdf_lama_layer(void **state)
{
    (void)state;
    char body[1024];
    const char *glass = "Bxdf \"LamaDielectric\" \"coat\" \"float IOR\" [%s] \"float roughness\" "
                        "[%s] \"color transmissionTint\" [%s]\n";
    char defs[512];
    snprintf(defs, sizeof defs, glass, "1.5", "0", "1 1 1");
    strcat(defs, RED);
    lama_node(body, defs, "LamaLayer",
              "\"reference bxdf materialBase\" [\"red\"] \"reference bxdf materialTop\" "
              "[\"coat:bxdf_out\"]");
    ts_patch_attr a = test_rib_one_patch(body);
    assert_int_equal(a.material, TS_MAT_PRINCIPLED);
    test_assert_near(a.clearcoat, 4, 1e-6), test_assert_near(a.clearcoat_gloss, 1, 1e-6);
    test_assert_near(a.metallic, 0, 0), test_assert_near(a.specular, 0, 0);
    test_assert_cs(&a, 0.8, 0, 0);
    assert_string_equal(test_rib_body_warnings(body), "");
    /* half the top, index 2, roughness 0.3 (alpha 0.09), tinted: warned */
    snprintf(defs, sizeof defs, glass, "2", "0.3", "1 0.5 0.5");
    strcat(defs, RED);
    lama_node(body, defs, "LamaLayer",
              "\"reference bxdf materialBase\" [\"red\"] \"reference bxdf materialTop\" "
              "[\"coat\"] \"float topMix\" [0.5] \"float topThickness\" [0.1]");
    a = test_rib_one_patch(body);
    double f0 = 1.0 / 9.0;
    test_assert_near(a.clearcoat, 0.5 * 4 * SCHLICK(f0) / SCHLICK(0.04), 1e-6);
    test_assert_near(a.clearcoat_gloss, (0.1 - 0.09) / 0.09, 1e-5);
    assert_string_equal(test_rib_body_warnings(body),
                        "w.rib:4:1: warning: Bxdf \"LamaLayer\": the glass top's tint is not "
                        "drawn (the coat is clear)\n");
    /* a matte top covers a matte base by topMix: their Kd Cs mixed */
    lama_node(body, RED BLUE, "LamaLayer",
              "\"reference bxdf materialBase\" [\"red\"] \"reference bxdf materialTop\" "
              "[\"blue\"] \"float topMix\" [0.25]");
    a = test_rib_one_patch(body);
    assert_int_equal(a.material, TS_MAT_MATTE), test_assert_cs(&a, 0.6, 0, 0.1);
    /* no top: the base; no base: the top, by topMix */
    lama_node(body, RED, "LamaLayer", "\"reference bxdf materialBase\" [\"red\"]");
    a = test_rib_one_patch(body);
    test_assert_cs(&a, 0.8, 0, 0);
    lama_node(body, BLUE, "LamaLayer",
              "\"reference bxdf materialTop\" [\"blue\"] \"float topMix\" [0.5]");
    a = test_rib_one_patch(body);
    test_assert_near(a.kd * a.cs_b, 0.2, 1e-6);
    /* a sheen top is not drawn: the base as it is, one warning (at the LamaSheen) */
    lama_node(body, RED "Bxdf \"LamaSheen\" \"fuzz\" \"color color\" [1 1 1]\n", "LamaLayer",
              "\"reference bxdf materialBase\" [\"red\"] \"reference bxdf materialTop\" "
              "[\"fuzz\"]");
    a = test_rib_one_patch(body);
    assert_int_equal(a.material, TS_MAT_MATTE), test_assert_cs(&a, 0.8, 0, 0);
    assert_string_equal(test_rib_body_warnings(body),
                        "w.rib:3:1: warning: Bxdf \"LamaSheen\": the sheen lobe is not drawn: "
                        "alone it reflects nothing, as a LamaLayer's top it leaves the base as it "
                        "is\n");
    /* LamaSSS: its Lambertian lobe (0.18 by default); a radius warns */
    a = test_rib_one_patch("Bxdf \"LamaSSS\" \"s\"");
    assert_int_equal(a.material, TS_MAT_MATTE), test_assert_cs(&a, 0.18, 0.18, 0.18);
    assert_string_equal(test_rib_body_warnings("Bxdf \"LamaSSS\" \"s\" \"color sssRadius\" [1 0.5 "
                                               "0.2] \"float sssScale\" [0.1]"),
                        "w.rib:2:20: warning: Bxdf \"LamaSSS\": \"sssRadius\" is not 0, but "
                        "subsurface scattering is not supported (its Lambertian lobe is drawn)\n");
    /* a glass top over gold: a coated metal */
    snprintf(defs, sizeof defs, glass, "1.5", "0", "1 1 1");
    strcat(defs, "Bxdf \"LamaConductor\" \"gold\" \"int fresnelMode\" [1]\n");
    lama_node(body, defs, "LamaLayer",
              "\"reference bxdf materialBase\" [\"gold\"] \"reference bxdf materialTop\" "
              "[\"coat\"]");
    a = test_rib_one_patch(body);
    assert_int_equal(a.material, TS_MAT_PRINCIPLED), test_assert_near(a.metallic, 1, 0);
    test_assert_near(a.clearcoat, 4, 1e-6);
}

/* LamaSurface, the end of a Lama network: its materialFront (here a LamaLayer) on the surface,
 * silent about its feature switches; a different materialBack and a presence below 1 warn.
 * Without a materialFront it is read as before, a matte of its diffuse colour. */
static void test_bxdf_lama_surface(void **state)
{
    (void)state;
    char body[1024];
    lama_node(body,
              RED "Bxdf \"LamaDielectric\" \"coat\"\n"
                  "Bxdf \"LamaLayer\" \"paint\" \"reference bxdf materialBase\" [\"red\"] "
                  "\"reference bxdf materialTop\" [\"coat\"]\n",
              "LamaSurface",
              "\"reference bxdf materialFront\" [\"paint:bxdf_out\"] \"int computePresence\" [0] "
              "\"int materialSides\" [1] \"string lobeName\" [\"x\"]");
    ts_patch_attr a = test_rib_one_patch(body);
    assert_int_equal(a.material, TS_MAT_PRINCIPLED), test_assert_near(a.clearcoat, 4, 1e-6);
    test_assert_cs(&a, 0.8, 0, 0);
    assert_string_equal(test_rib_body_warnings(body), "");
    lama_node(body, RED BLUE, "LamaSurface",
              "\"reference bxdf materialFront\" [\"red\"] \"reference bxdf materialBack\" "
              "[\"blue\"] \"float presence\" [0.5]");
    a = test_rib_one_patch(body);
    assert_int_equal(a.material, TS_MAT_MATTE), test_assert_cs(&a, 0.8, 0, 0);
    assert_string_equal(test_rib_body_warnings(body),
                        "w.rib:4:1: warning: Bxdf \"LamaSurface\": materialBack is not drawn: both "
                        "sides of the surface show materialFront\n"
                        "w.rib:4:1: warning: Bxdf \"LamaSurface\": a \"presence\" below 1 that is "
                        "not a texture (partial transparency) is not supported: the surface "
                        "renders opaque\n");
    a = test_rib_one_patch("Bxdf \"LamaSurface\" \"s\" \"color diffuseColor\" [0.1 0.2 0.3]");
    assert_int_equal(a.material, TS_MAT_MATTE), test_assert_cs(&a, 0.1, 0.2, 0.3);
}

/* Diffuse transmission (TS_MAT_TRANSLUCENT, Kd Cs reflected and Ks Cs transmitted):
 * LamaTranslucent transmits all (Kd 0, Ks 1, Cs its colour, 0.18 by default); LamaMix of a
 * matte and a translucent sheet is one sheet, exact when their colours are proportional (Cs the
 * sum of the two albedos, Kd and Ks their shares), else one warning; PxrSurface's
 * diffuseTransmitGain beside its diffuse lobe alone likewise, and beside a specular lobe it is
 * not drawn (one warning); a translucent sheet with a metal: the larger share. */
static void test_bxdf_translucent(void **state)
{
    (void)state;
    ts_patch_attr a = test_rib_one_patch("Bxdf \"LamaTranslucent\" \"t\"");
    assert_int_equal(a.material, TS_MAT_TRANSLUCENT);
    test_assert_near(a.kd, 0, 0), test_assert_near(a.ks, 1, 0),
        test_assert_cs(&a, 0.18, 0.18, 0.18);
    char body[1024];
    lama_mix(body, RED, "Bxdf \"LamaTranslucent\" \"leaf\" \"color color\" [0.4 0 0]\n", "red",
             "leaf", "0.5");
    a = test_rib_one_patch(body);
    assert_int_equal(a.material, TS_MAT_TRANSLUCENT), test_assert_cs(&a, 0.6, 0, 0);
    test_assert_near(a.kd, 2.0 / 3.0, 1e-6), test_assert_near(a.ks, 1.0 / 3.0, 1e-6);
    assert_string_equal(test_rib_body_warnings(body), "");
    lama_mix(body, RED, "Bxdf \"LamaTranslucent\" \"leaf\" \"color color\" [0 0.4 0]\n", "red",
             "leaf", "0.5");
    a = test_rib_one_patch(body);
    test_assert_cs(&a, 0.4, 0.2, 0), test_assert_near(a.kd, 2.0 / 3.0, 1e-6);
    assert_string_equal(test_rib_body_warnings(body),
                        "w.rib:4:1: warning: Bxdf \"LamaMix\": the reflected and transmitted "
                        "colours differ and are drawn as one, their sum (each lobe keeps its mean "
                        "albedo: an approximation)\n");
    const char *leaf = "Bxdf \"PxrSurface\" \"s\" \"float diffuseGain\" [0.5] \"color "
                       "diffuseColor\" [0.5 0.5 0.5] \"float diffuseTransmitGain\" [0.5] \"color "
                       "diffuseTransmitColor\" [0.5 0.5 0.5]";
    a = test_rib_one_patch(leaf);
    assert_int_equal(a.material, TS_MAT_TRANSLUCENT), test_assert_cs(&a, 0.5, 0.5, 0.5);
    test_assert_near(a.kd, 0.5, 1e-6), test_assert_near(a.ks, 0.5, 1e-6);
    assert_string_equal(test_rib_body_warnings(leaf), "");
    const char *shiny = "Bxdf \"PxrSurface\" \"s\" \"color specularFaceColor\" [0.04 0.04 0.04] "
                        "\"color specularEdgeColor\" [1 1 1] \"float diffuseTransmitGain\" [1]";
    a = test_rib_one_patch(shiny);
    assert_int_equal(a.material, TS_MAT_PRINCIPLED);
    assert_string_equal(test_rib_body_warnings(shiny),
                        "w.rib:2:1: warning: Bxdf \"PxrSurface\": \"diffuseTransmitGain\" is not "
                        "0, but diffuse transmission is drawn only beside a diffuse lobe alone (no "
                        "specular lobe or clear coat)\n");
    lama_mix(body, "Bxdf \"LamaConductor\" \"gold\"\n", "Bxdf \"LamaTranslucent\" \"leaf\"\n",
             "gold", "leaf", "0.75");
    a = test_rib_one_patch(body);
    assert_int_equal(a.material, TS_MAT_TRANSLUCENT);
    assert_string_equal(test_rib_body_warnings(body),
                        "w.rib:4:1: warning: Bxdf \"LamaMix\": a translucent sheet with another "
                        "material cannot be mixed: it is drawn as material2, the larger share\n");
}

/* PxrSurface onto the principled BRDF: Cs = diffuseGain diffuseColor, specular =
 * specularFaceColor / 0.08, GGX alpha = specularRoughness^2, clearcoat 4 c / c(0.04) with c
 * the coat's hemispherical mean Schlick Fresnel, gloss from clearcoatRoughness; a conductor
 * (metallic 1, Cs = specularFaceColor) when there is no diffuse lobe; the glow emits
 * glowGain * glowColor. */
static void test_bxdf_surface(void **state)
{
    (void)state;
    ts_patch_attr a =
        test_rib_one_patch("Bxdf \"PxrSurface\" \"s\" \"float diffuseGain\" [0.8] "
                           "\"color diffuseColor\" [0.5 0.25 0.125] \"color "
                           "specularFaceColor\" [0.04 0.04 0.04] \"color specularEdgeColor\" "
                           "[1 1 1] \"float specularRoughness\" [0.3] \"float glowGain\" [2] "
                           "\"color glowColor\" [1 0.5 0]");
    assert_int_equal(a.material, TS_MAT_PRINCIPLED);
    test_assert_near(a.specular, 0.5, 1e-7), test_assert_near(a.metallic, 0, 0);
    test_assert_near(a.clearcoat, 0, 0), test_assert_near(a.kd, 1, 0), test_assert_near(a.ks, 0, 0);
    test_assert_near(a.roughness, 0.09, 1e-7);
    test_assert_cs(&a, 0.4, 0.2, 0.1);
    assert_le(&a, 2, 1, 0);
    /* RenderMan's defaults: no specular (face and edge colours 0), diffuse 0.18. */
    a = test_rib_one_patch("Bxdf \"PxrSurface\" \"s\"");
    assert_int_equal(a.material, TS_MAT_MATTE);
    test_assert_near(a.kd, 1.0, 0), test_assert_cs(&a, 0.18, 0.18, 0.18), assert_le(&a, 0, 0, 0);
    /* A clear coat alone: specular 0 under it, Schlick F0 0.04 to 1 is clearcoat 4. */
    a = test_rib_one_patch(
        "Bxdf \"PxrSurface\" \"s\" \"color clearcoatFaceColor\" [0.03 0.03 0.03] "
        "\"color clearcoatEdgeColor\" [1 1 1] \"float clearcoatRoughness\" [0.2]");
    assert_int_equal(a.material, TS_MAT_PRINCIPLED), test_assert_near(a.specular, 0, 0);
    test_assert_near(a.clearcoat, 4 * SCHLICK(0.03) / SCHLICK(0.04), 1e-6);
    test_assert_near(a.clearcoat_gloss, (0.1 - 0.04) / 0.09, 1e-6),
        test_assert_cs(&a, 0.18, 0.18, 0.18);
    a = test_rib_one_patch("Bxdf \"PxrSurface\" \"s\" \"color clearcoatFaceColor\" [0.5 0.5 0.5] "
                           "\"color clearcoatEdgeColor\" [1 1 1]");
    test_assert_near(a.clearcoat, 4, 0), test_assert_near(a.clearcoat_gloss, 1, 1e-7);
    /* No diffuse lobe and a bright face colour: a conductor of that colour. */
    a = test_rib_one_patch("Bxdf \"PxrSurface\" \"s\" \"float diffuseGain\" [0] \"color "
                           "specularFaceColor\" [0.9 0.6 0.2] \"color specularEdgeColor\" [1 1 1]");
    assert_int_equal(a.material, TS_MAT_PRINCIPLED), test_assert_near(a.metallic, 1, 0);
    test_assert_near(a.kd, 0, 0), test_assert_cs(&a, 0.9, 0.6, 0.2);
    /* What the principled BRDF does not draw of it, one warning each. */
    assert_string_equal(
        test_rib_body_warnings(
            "Bxdf \"PxrSurface\" \"s\" \"color specularFaceColor\" [0.3 0.2 0.2] "
            "\"color specularEdgeColor\" [0.5 0.5 0.5] \"color clearcoatFaceColor\" [0.04 "
            "0.04 0.04] \"float clearcoatRoughness\" [0.5] \"float clearcoatThickness\" [1]"),
        "w.rib:2:180: warning: Bxdf \"PxrSurface\": \"clearcoatThickness\" is not 0, but the clear "
        "coat's absorption is not drawn\n"
        "w.rib:2:1: warning: Bxdf \"PxrSurface\": the specular colour is drawn grey (its mean)\n"
        "w.rib:2:1: warning: Bxdf \"PxrSurface\": a specularFaceColor above 0.08 over a diffuse "
        "lobe is drawn as 0.08 (a dielectric's F0 up to index 1.8)\n"
        "w.rib:2:1: warning: Bxdf \"PxrSurface\": specularEdgeColor is drawn as 1 (Schlick's "
        "Fresnel to white)\n"
        "w.rib:2:1: warning: Bxdf \"PxrSurface\": clearcoatRoughness above 0.32 is drawn as 0.32 "
        "(GGX alpha 0.1)\n");
    /* Lobes Tessera does not draw: silent while their weight is 0, else one warning; the
     * parameters Tessera does not read warn once each. A presence of 1 (opaque, what is
     * drawn) is silent, another one warns. */
    assert_string_equal(
        test_rib_body_warnings("Bxdf \"PxrSurface\" \"s\" \"float subsurfaceGain\" [0] "
                               "\"color subsurfaceColor\" [1 0 0] \"float fuzzGain\" "
                               "[0.5] \"float presence\" [1] \"int specularFresnelMode\" [1]"),
        "w.rib:2:82: warning: Bxdf \"PxrSurface\": \"fuzzGain\" is not 0, "
        "but the fuzz lobe is not drawn\n"
        "w.rib:2:126: warning: Bxdf parameter \"specularFresnelMode\" is ignored\n");
    /* What RenderMan for Maya writes on every PxrSurface at the values Tessera draws: silent */
    assert_string_equal(
        test_rib_body_warnings("Bxdf \"PxrSurface\" \"s\" \"int specularFresnelMode\" [0] "
                               "\"color specularIor\" [1.8 1.8 1.8] \"float specularAnisotropy\" "
                               "[0] \"int diffuseDoubleSided\" [1] \"color irradianceTint\" [1 1 "
                               "1] \"color shadowColor\" [0 0 0] \"int maxContinuationHits\" [4]"),
        "");
    /* RenderMan for Maya's bookkeeping and the values that are what is drawn: silent. */
    assert_string_equal(
        test_rib_body_warnings("Bxdf \"PxrDisney\" \"d\" \"normal bumpNormal\" [0 0 0] "
                               "\"string __instanceid\" [\"PxrDisney1_0\"] \"int "
                               "inputAOV\" [0] \"int presenceCached\" [1]"),
        "");
    int rc;
    assert_string_equal(test_rib_warnings("WorldBegin\nLight \"PxrDistantLight\" \"l\" \"string "
                                          "__instanceid\" [\"l_0\"]\nWorldEnd\n",
                                          &rc),
                        "");
    assert_int_equal(rc, TS_OK);
    assert_string_equal(
        test_rib_body_warnings("Bxdf \"PxrSurface\" \"s\" \"normal bumpNormal\" [0 0 1]"),
        "w.rib:2:23: warning: Bxdf parameter \"bumpNormal\" is ignored\n");
    assert_string_equal(
        test_rib_body_warnings("Bxdf \"PxrSurface\" \"s\" \"float presence\" [0.5]"),
        "w.rib:2:23: warning: Bxdf \"PxrSurface\": a \"presence\" below 1 that is not a "
        "texture (partial transparency) is not supported: the surface renders opaque\n");
}

/* PxrDisney: every parameter of Burley 2012 lands in the principled attribute (roughness
 * squared: GGX alpha), with RenderMan's defaults; out of [0, 1] clamped with a warning. */
static void test_bxdf_disney_conductor_constant(void **state)
{
    (void)state;
    ts_patch_attr a = test_rib_one_patch(
        "Bxdf \"PxrDisney\" \"d\" \"color baseColor\" [0.9 0.6 0.2] \"float metallic\" [0.25] "
        "\"float roughness\" [0.5] \"float specular\" [0.3] \"float specularTint\" [0.4] \"float "
        "sheen\" [0.6] \"float sheenTint\" [0.2] \"float clearcoat\" [0.7] \"float "
        "clearcoatGloss\" [0.8]");
    assert_int_equal(a.material, TS_MAT_PRINCIPLED);
    test_assert_near(a.roughness, 0.25, 1e-7), test_assert_cs(&a, 0.9, 0.6, 0.2);
    test_assert_near(a.metallic, 0.25, 1e-7), test_assert_near(a.specular, 0.3, 1e-7);
    test_assert_near(a.specular_tint, 0.4, 1e-7), test_assert_near(a.sheen, 0.6, 1e-7);
    test_assert_near(a.sheen_tint, 0.2, 1e-7), test_assert_near(a.clearcoat, 0.7, 1e-7);
    test_assert_near(a.clearcoat_gloss, 0.8, 1e-7);
    test_assert_near(a.kd, 0.75, 1e-7), test_assert_near(a.ks, 0, 0); /* Kd: the diffuse weight */
    /* RenderMan's defaults: specular 0.5 (F0 0.04), roughness 0.25, sheenTint 0.5, gloss 1 */
    a = test_rib_one_patch("Bxdf \"PxrDisney\" \"d\"");
    assert_int_equal(a.material, TS_MAT_PRINCIPLED), test_assert_cs(&a, 0.2, 0.5, 0.8);
    test_assert_near(a.specular, 0.5, 0), test_assert_near(a.roughness, 0.0625, 1e-7);
    test_assert_near(a.metallic, 0, 0), test_assert_near(a.specular_tint, 0, 0);
    test_assert_near(a.sheen, 0, 0), test_assert_near(a.sheen_tint, 0.5, 0);
    test_assert_near(a.clearcoat, 0, 0), test_assert_near(a.clearcoat_gloss, 1, 0);
    assert_string_equal(
        test_rib_body_warnings(
            "Bxdf \"PxrDisney\" \"d\" \"float metallic\" [1.5] \"float subsurface\" [0.5]"),
        "w.rib:2:45: warning: Bxdf \"PxrDisney\": \"subsurface\" is not 0, but subsurface "
        "scattering is not supported\n"
        "w.rib:2:1: warning: Bxdf \"PxrDisney\": \"metallic\" outside [0, 1] is clamped to it\n");
    /* A name that differs in case only (made where file names ignore case) is read as the
     * Bxdf, with one warning. */
    a = test_rib_one_patch("Bxdf \"PXRDisney\" \"d\" \"float metallic\" [0.25]");
    assert_int_equal(a.material, TS_MAT_PRINCIPLED), test_assert_near(a.metallic, 0.25, 1e-7);
    assert_string_equal(test_rib_body_warnings("Bxdf \"PXRDisney\" \"d\""),
                        "w.rib:2:6: warning: Bxdf \"PXRDisney\" is read as PxrDisney (the names "
                        "differ in case only)\n");
    /* PxrConductor: Cs is the normal-incidence Fresnel of eta + i kappa, edge colour 1. */
    a = test_rib_one_patch(
        "Bxdf \"PxrConductor\" \"c\" \"color eta\" [0.2 0.2 0.2] \"color kappa\" [3 3 "
        "3] \"float roughness\" [0.1]");
    double f0 = (0.8 * 0.8 + 9) / (1.2 * 1.2 + 9);
    assert_int_equal(a.material, TS_MAT_METAL), test_assert_near(a.roughness, 0.01, 1e-7);
    test_assert_cs(&a, SCHLICK(f0), SCHLICK(f0), SCHLICK(f0));
    a = test_rib_one_patch(
        "Bxdf \"LamaConductor\" \"c\" \"color reflectivity\" [0.9 0.5 0.1] \"color "
        "edgeColor\" [0.9 0.5 0.1]");
    test_assert_cs(&a, 0.9, 0.5, 0.1);
    /* PxrConstant emits its colour and reflects nothing. */
    a = test_rib_one_patch("Bxdf \"PxrConstant\" \"k\" \"color emitColor\" [2 1 0.5]");
    test_assert_near(a.kd, 0, 0), test_assert_near(a.ks, 0, 0), assert_le(&a, 2, 1, 0.5);
}

static void test_bxdf_fallbacks(void **state)
{
    (void)state;
    /* Dielectrics: glass of their ior, white, smooth or rough by roughness; an ior outside
     * [1, 4] replaced by 1.5 with one warning. */
    ts_patch_attr a = test_rib_one_patch("Bxdf \"PxrDielectric\" \"g\" \"float ior\" [1.33]");
    assert_int_equal(a.material, TS_MAT_GLASS);
    test_assert_near(a.kd, 0, 0), test_assert_near(a.ks, 0, 0), test_assert_near(a.ior, 1.33, 1e-6);
    test_assert_cs(&a, 1, 1, 1);
    a = test_rib_one_patch("Bxdf \"LamaDielectric\" \"g\"");
    assert_int_equal(a.material, TS_MAT_GLASS), test_assert_near(a.ior, 1.5, 0);
    assert_string_equal(test_rib_body_warnings("Bxdf \"LamaDielectric\" \"g\""), "");
    /* roughness 0 is smooth glass (alpha at the 0.01 floor, lib/bsdf.h TS_GLASS_SMOOTH); 0.2
     * is rough glass of GGX alpha 0.04, without a warning */
    assert_true(a.roughness <= TS_GLASS_SMOOTH);
    a = test_rib_one_patch("Bxdf \"PxrGlass\" \"g\" \"float roughness\" [0.2]");
    assert_int_equal(a.material, TS_MAT_GLASS), test_assert_near(a.roughness, 0.04, 1e-7);
    assert_string_equal(test_rib_body_warnings("Bxdf \"PxrGlass\" \"g\" \"float roughness\" [0.2]"),
                        "");
    assert_string_equal(test_rib_body_warnings("Bxdf \"PxrDielectric\" \"g\" \"float ior\" [0.5]"),
                        "w.rib:2:1: warning: Bxdf \"PxrDielectric\": ior 0.5 outside [1, 4]: 1.5 "
                        "instead\n");
    /* The classic Surface "glass": eta, default 1.5, in [1, 4]. */
    a = test_rib_one_patch("Surface \"glass\" \"float eta\" [1.33]");
    assert_int_equal(a.material, TS_MAT_GLASS), test_assert_near(a.ior, 1.33, 1e-6);
    a = test_rib_one_patch("Surface \"glass\"");
    test_assert_near(a.ior, 1.5, 0), assert_true(a.roughness <= TS_GLASS_SMOOTH);
    a = test_rib_one_patch("Surface \"plastic\"");
    test_assert_near(a.ior, 0, 0); /* 0 but for glass: the job hash of older files holds */
    test_parse_rib_error("WorldBegin\nSurface \"glass\" \"float eta\" [5]\n",
                         "t.rib:2:1: error: Surface \"glass\": eta must be in [1, 4] (the index "
                         "of refraction inside), got 5");
    /* An unknown Bxdf: PxrDiffuse's default, one warning. */
    a = test_rib_one_patch("Bxdf \"MyOSLBxdf\" \"x\" \"float k\" [3]");
    assert_int_equal(a.material, TS_MAT_MATTE), test_assert_cs(&a, 0.5, 0.5, 0.5);
    assert_string_equal(
        test_rib_body_warnings("Bxdf \"MyOSLBxdf\" \"x\"\nBxdf \"MyOSLBxdf\" \"y\""),
        "w.rib:2:6: warning: Bxdf \"MyOSLBxdf\" is unknown: it renders as "
        "PxrDiffuse (matte) of its default colour\n");
    test_parse_rib_error("WorldBegin Bxdf \"PxrSurface\" \"s\" \"float diffuseGain\" [-1]",
                         "t.rib:1:12: error: Bxdf \"PxrSurface\": Kd and Ks must be >= 0 and "
                         "finite, got -1 0");
    test_parse_rib_error("WorldBegin Bxdf \"PxrSurface\" \"s\" \"color diffuseColor\" [1 1]",
                         "t.rib:1:55: error: Bxdf: parameter \"diffuseColor\" needs 3 values, "
                         "got 2");
}

/* ---- Pattern ------------------------------------------------------------------------ */

/* A 2 x 2 image at dir/name (PPM, or PNG when the name ends so). */
static const char *write_image(const char *name)
{
    static char path[4096];
    snprintf(path, sizeof path, "%s/%s", test_scratch_dir(), name);
    size_t n = strlen(path);
    if (n > 4 && strcmp(path + n - 4, ".png") == 0) {
        const float rgb[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
        ts_error e = {0};
        assert_int_equal(image_write_png(path, 2, 2, rgb, &e), TS_OK);
    } else {
        test_write_text(path, "P3 2 2 255\n255 0 0 0 255 0 0 0 255 255 255 255\n");
    }
    return path;
}

static void test_pattern_texture(void **state)
{
    (void)state;
    const char *img = write_image("ris_colour.ppm");
    char text[8192];
    ts_scene s;
    /* PxrTexture into diffuseColor: the image is the colour (Cs 1); RenderMan's invertT 1
     * flips t. */
    snprintf(text, sizeof text,
             "WorldBegin\nPattern \"PxrTexture\" \"tex\" \"string filename\" [\"%s\"]\n"
             "Bxdf \"PxrDiffuse\" \"d\" \"reference color diffuseColor\" [\"tex:resultRGB\"]\n" QUAD
             "WorldEnd\n",
             img);
    test_parse_rib_ok(text, &s);
    assert_int_equal(s.texture_count, 1);
    assert_true(s.attr[0].flags & TS_PATCH_COLOR_TEX);
    assert_int_equal(s.attr[0].color_tex, 0), test_assert_cs(&s.attr[0], 1, 1, 1);
    const float flipped[8] = {0, 1, 1, 1, 0, 0, 1, 0};
    for (int k = 0; k < 8; k++)
        test_assert_near(s.attr[0].st[k], flipped[k], 0);
    scene_free(&s);
    /* A PxrManifold2D: s' = scaleS s + offsetS, t' = scaleT t + offsetT. */
    snprintf(text, sizeof text,
             "WorldBegin\nPattern \"PxrManifold2D\" \"m\" \"float scaleS\" [2] \"float offsetT\" "
             "[0.5]\nPattern \"PxrTexture\" \"tex\" \"string filename\" [\"%s\"] \"int invertT\" "
             "[0] \"reference struct manifold\" [\"m:result\"]\n"
             "Bxdf \"PxrSurface\" \"d\" \"reference color diffuseColor\" [\"tex:resultRGB\"]\n" QUAD
             "WorldEnd\n",
             img);
    test_parse_rib_ok(text, &s);
    const float mapped[8] = {0, 0.5f, 2, 0.5f, 0, 1.5f, 2, 1.5f};
    for (int k = 0; k < 8; k++)
        test_assert_near(s.attr[0].st[k], mapped[k], 0);
    scene_free(&s);
}

/* The warnings of loading RIB `text` from a file (textures are read), the scene in *s. */
static const char *load_warnings(const char *text, ts_scene *s)
{
    static char out[4096];
    char path[4096];
    snprintf(path, sizeof path, "%s/load_warnings.rib", test_scratch_dir());
    test_write_text(path, text);
    ts_error e;
    if (test_rib_load_capture(path, 0, s, &e, out, sizeof out) != TS_OK) fail_msg("%s", e.msg);
    return out;
}

/* presence from a PxrTexture: its alpha (resultA) or first channel (resultR) cuts the patch
 * out (TS_PATCH_CUTOUT, the texture in color_tex: the colour's own, or alone when the colour
 * is not textured; the RGB texture keeps the alpha in w); a mask other than the colour's
 * texture, or on an emitter, warns and the surface stays opaque; LamaSurface's presence alike. */
static void test_presence_cutout(void **state)
{
    (void)state;
    char img[4096]; /* write_image returns its own buffer */
    snprintf(img, sizeof img, "%s", write_image("ris_mask.ppm"));
    const char *other = write_image("ris_other.png");
    char text[8192];
    ts_scene s;
    snprintf(text, sizeof text,
             "WorldBegin\nPattern \"PxrTexture\" \"tex\" \"string filename\" [\"%s\"]\n"
             "Bxdf \"PxrSurface\" \"d\" \"reference color diffuseColor\" [\"tex:resultRGB\"] "
             "\"reference float presence\" [\"tex:resultA\"]\n" QUAD "WorldEnd\n",
             img);
    test_parse_rib_ok(text, &s);
    uint32_t f = s.attr[0].flags;
    assert_true((f & TS_PATCH_COLOR_TEX) && (f & TS_PATCH_CUTOUT) && !(f & TS_PATCH_CUTOUT_RED));
    assert_int_equal(s.attr[0].color_tex, 0);
    test_assert_near(s.textures[0].kind, TS_TEX_RGB, 0);
    scene_free(&s);
    /* a mask alone (the colour constant): resultR of the texture, Cs as it is */
    snprintf(text, sizeof text,
             "WorldBegin\nPattern \"PxrTexture\" \"m\" \"string filename\" [\"%s\"]\n"
             "Bxdf \"PxrDiffuse\" \"d\" \"color diffuseColor\" [0.5 0.25 1] "
             "\"reference float presence\" [\"m:resultR\"]\n" QUAD "WorldEnd\n",
             img);
    test_parse_rib_ok(text, &s);
    f = s.attr[0].flags;
    assert_true(!(f & TS_PATCH_COLOR_TEX) && (f & TS_PATCH_CUTOUT) && (f & TS_PATCH_CUTOUT_RED));
    test_assert_cs(&s.attr[0], 0.5, 0.25, 1);
    scene_free(&s);
    /* another texture than the colour's: opaque, one warning */
    snprintf(text, sizeof text,
             "WorldBegin\nPattern \"PxrTexture\" \"c\" \"string filename\" [\"%s\"]\n"
             "Pattern \"PxrTexture\" \"m\" \"string filename\" [\"%s\"]\n"
             "Bxdf \"PxrSurface\" \"d\" \"reference color diffuseColor\" [\"c:resultRGB\"] "
             "\"reference float presence\" [\"m:resultA\"]\n" QUAD "WorldEnd\n",
             img, other);
    const char *w = load_warnings(text, &s);
    if (!strstr(w, "Bxdf \"PxrSurface\": \"presence\" from another texture (or manifold) than its "
                   "colour's is not drawn: the surface renders opaque"))
        fail_msg("warnings: %s", w);
    assert_false(s.attr[0].flags & TS_PATCH_CUTOUT);
    scene_free(&s);
    /* an emitter: opaque, one warning */
    snprintf(text, sizeof text,
             "WorldBegin\nPattern \"PxrTexture\" \"m\" \"string filename\" [\"%s\"]\n"
             "Bxdf \"PxrSurface\" \"d\" \"float glowGain\" [1] \"reference float presence\" "
             "[\"m:resultA\"]\n" QUAD "WorldEnd\n",
             img);
    w = load_warnings(text, &s);
    if (!strstr(w, "\"presence\" on a surface that emits is not drawn"))
        fail_msg("warnings: %s", w);
    assert_false(s.attr[0].flags & TS_PATCH_CUTOUT);
    scene_free(&s);
    /* LamaSurface's presence */
    snprintf(text, sizeof text,
             "WorldBegin\nPattern \"PxrTexture\" \"m\" \"string filename\" [\"%s\"]\n"
             "Bxdf \"LamaDiffuse\" \"leaf\" \"color color\" [0.2 0.5 0.1]\n"
             "Bxdf \"LamaSurface\" \"s\" \"reference bxdf materialFront\" [\"leaf\"] "
             "\"reference float presence\" [\"m:resultA\"]\n" QUAD "WorldEnd\n",
             img);
    test_parse_rib_ok(text, &s);
    assert_true(s.attr[0].flags & TS_PATCH_CUTOUT), test_assert_cs(&s.attr[0], 0.2, 0.5, 0.1);
    scene_free(&s);
}

/* RenderMan's .tex files: the sibling image of the same name is read instead; none: the
 * missing-file warning and the untextured colour (an error with --strict). */
static void test_pattern_tex_sibling(void **state)
{
    (void)state;
    const char *png = write_image("ris_wood.png");
    char tex[4096], text[8192];
    snprintf(tex, sizeof tex, "%.*s.tex", (int)(strlen(png) - 4), png);
    snprintf(text, sizeof text,
             "WorldBegin\nPattern \"PxrTexture\" \"t\" \"string filename\" [\"%s\"]\nBxdf "
             "\"PxrDiffuse\" \"d\" \"reference color diffuseColor\" [\"t:resultRGB\"]\n" QUAD
             "WorldEnd\n",
             tex);
    ts_scene s;
    test_parse_rib_ok(text, &s);
    assert_int_equal(s.texture_count, 1);
    assert_string_equal(s.tex_source[0], png);
    scene_free(&s);
    int rc;
    const char *out =
        test_rib_warnings("WorldBegin\nPattern \"PxrTexture\" \"t\" \"string "
                          "filename\" [\"nowhere/x.tex\"]\nBxdf \"PxrDiffuse\" \"d\" "
                          "\"reference color diffuseColor\" [\"t:resultRGB\"]\n" QUAD "WorldEnd\n",
                          &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "w.rib:2:44: warning: Bxdf: cannot read texture \"nowhere/x.tex\": a "
                             "RenderMan .tex, which Tessera cannot read, and no .tx, .exr, .png, "
                             ".tif, .tiff or .jpg of the same name beside it; rendered with its "
                             "colour parameter's default (--strict makes this an error)\n");
    ts_error e;
    assert_int_equal(test_parse_rib_strict("WorldBegin\nPattern \"PxrTexture\" \"t\" \"string "
                                           "filename\" [\"nowhere/x.tex\"]\nBxdf \"PxrDiffuse\" "
                                           "\"d\" \"reference color diffuseColor\" "
                                           "[\"t:resultRGB\"]\n" QUAD "WorldEnd\n",
                                           &s, &e),
                     TS_E_SCENE);
    assert_non_null(strstr(e.msg, "t.rib:2:44: error: Bxdf: cannot read texture"));
    ts_error_clear(&e);
}

/* A pattern Tessera does not draw (an OSL shader), or a handle no Pattern defines: the
 * parameter keeps its default, with one warning. */
static void test_pattern_unknown(void **state)
{
    (void)state;
    ts_patch_attr a =
        test_rib_one_patch("Pattern \"MyNoise\" \"n\" \"float freq\" [4]\nBxdf \"PxrDiffuse\" "
                           "\"d\" \"reference color diffuseColor\" [\"n:resultRGB\"]");
    test_assert_cs(&a, 0.5, 0.5, 0.5);
    assert_int_equal(a.flags & TS_PATCH_COLOR_TEX, 0);
    assert_string_equal(
        test_rib_body_warnings("Pattern \"MyNoise\" \"n\"\nBxdf \"PxrDiffuse\" \"d\" "
                               "\"reference color diffuseColor\" [\"n:resultRGB\"]\n"
                               "Bxdf \"PxrDiffuse\" \"d\" \"reference color diffuseColor\" "
                               "[\"gone:resultRGB\"]"),
        "w.rib:3:54: warning: Pattern \"MyNoise\" is not supported: the parameters "
        "connected to it keep their defaults (docs/rib.md lists the patterns drawn)\n"
        "w.rib:4:54: warning: Bxdf: \"diffuseColor\" is connected to "
        "\"gone:resultRGB\", which no Pattern defines: it keeps its default\n");
}

/* ---- Displace ----------------------------------------------------------------------- */

static void test_displace(void **state)
{
    (void)state;
    const char *img = write_image("ris_height.ppm");
    char text[8192];
    snprintf(text, sizeof text,
             "WorldBegin\nAttribute \"displacementbound\" \"float sphere\" [0.5] \"string "
             "coordinatesystem\" [\"object\"]\nPattern \"PxrTexture\" \"h\" \"string filename\" "
             "[\"%s\"]\nDisplace \"PxrDisplace\" \"d\" \"float dispAmount\" [0.2] \"reference "
             "float dispScalar\" [\"h:resultR\"]\n" QUAD "WorldEnd\n",
             img);
    ts_scene s;
    test_parse_rib_ok(text, &s);
    assert_int_equal(s.attr[0].disp_kind, TS_DISP_TEXTURE);
    test_assert_near(s.attr[0].disp_amplitude, 0.2, 1e-7),
        test_assert_near(s.attr[0].disp_offset, 0, 0);
    test_assert_near(s.attr[0].st[1], 1, 0); /* invertT */
    scene_free(&s);
    int rc;
    const char *out = test_rib_warnings(text, &rc); /* displacementbound: read silently */
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "");
    ts_patch_attr a =
        test_rib_one_patch("Displace \"PxrDisplace\" \"d\" \"float dispAmount\" [0.2] "
                           "\"float dispScalar\" [1]");
    assert_int_equal(a.disp_kind, TS_DISP_NONE);
    assert_string_equal(
        test_rib_body_warnings("Displace \"PxrDisplace\" \"d\" \"float dispScalar\" [1]\n"
                               "Displace \"MyDisp\" \"d\""),
        "w.rib:2:1: warning: Displace \"PxrDisplace\": a constant dispScalar (a "
        "uniform offset of the surface) is not drawn: no displacement\n"
        "w.rib:3:10: warning: Displace \"MyDisp\" is unknown: no displacement "
        "(PxrDisplace)\n");
}

/* ---- Light -------------------------------------------------------------------------- */

static void test_light_dome_distant(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nLight \"PxrDomeLight\" \"dome\" \"float intensity\" [2] "
                      "\"float exposure\" [1] \"color lightColor\" [1 0.5 0.25]\n" QUAD
                      "WorldEnd\n",
                      &s);
    assert_int_equal(s.dome.present, 1);
    for (int k = 0; k < 3; k++)
        test_assert_near(s.dome.intensity * s.dome.color[k], 4.0 / (1 << k), 1e-12);
    scene_free(&s);
    /* PxrDistantLight: radiance 50000 in a cone of 0.53 degrees down -z: irradiance
     * L pi sin^2(0.265 deg); normalize: irradiance L. */
    test_parse_rib_ok("WorldBegin\nRotate 90 1 0 0\nLight \"PxrDistantLight\" \"sun\"\n"
                      "Light \"PxrDistantLight\" \"sun2\" \"float intensity\" [3] \"float "
                      "angleExtent\" [10] \"int normalize\" [1]\n" QUAD "WorldEnd\n",
                      &s);
    assert_int_equal(s.light_count, 2);
    double h = 0.265 * M_PI / 180;
    test_assert_near(s.lights[0].intensity * s.lights[0].color[0], 50000 * M_PI * sin(h) * sin(h),
                     1e-9);
    test_assert_near(s.lights[0].angle, 0.53, 0);
    /* -z rotated 90 degrees about x is +y: light travels along +y. */
    test_assert_near(s.lights[0].to[1] - s.lights[0].from[1], 1, 1e-12);
    test_assert_near(s.lights[1].intensity * s.lights[1].color[1], 3, 1e-12);
    scene_free(&s);
    /* A missing map: a uniform sky, warned. */
    assert_string_equal(
        test_rib_body_warnings("Light \"PxrDomeLight\" \"d\" \"string lightColorMap\" "
                               "[\"nowhere/sky.tex\"]\nLightFilter \"PxrBlockerLightFilter\" "
                               "\"b\"\nLight \"PxrPortalLight\" \"p\""),
        "w.rib:2:49: warning: Light: cannot read \"nowhere/sky.tex\": a RenderMan "
        ".tex, which Tessera cannot read, and no .tx, .exr, .png, .tif, .tiff or "
        ".jpg of the same name beside it; a uniform sky of the light's colour "
        "(--strict makes this an error)\n"
        "w.rib:3:1: warning: LightFilter \"PxrBlockerLightFilter\" is ignored\n"
        "w.rib:4:1: warning: Light \"PxrPortalLight\" is ignored (PxrDomeLight, "
        "PxrDistantLight, PxrRectLight, PxrDiskLight, PxrSphereLight, "
        "PxrCylinderLight, PxrEnvDayLight)\n");
}

/* A light's controls that make no difference to what Tessera draws are silent at those values
 * (RenderMan for Maya writes them on every light: a cone of 90 degrees, black shadows, no
 * shadow distance or falloff, empty subsets and light groups, any sample count); other values
 * still warn. */
static void test_light_neutral_controls(void **state)
{
    (void)state;
    assert_string_equal(
        test_rib_body_warnings(
            "Light \"PxrRectLight\" \"r\" \"float coneAngle\" [90] \"float coneSoftness\" [0] "
            "\"color shadowColor\" [0 0 0] \"float shadowDistance\" [-1] \"float shadowFalloff\" "
            "[-1] \"float shadowFalloffGamma\" [1] \"float intensityNearDist\" [0] "
            "\"string lightGroup\" [\"key\"] \"string shadowSubset\" [\"\"] "
            "\"string shadowExcludeSubset\" [\"\"] \"string iesProfile\" [\"\"] "
            "\"float iesProfileScale\" [0] \"int fixedSampleCount\" [0] \"float emissionFocus\" "
            "[0] "
            "\"color emissionFocusTint\" [0 0 0] \"float colorMapSaturation\" [1]"),
        "");
    const char *w = test_rib_body_warnings("Light \"PxrRectLight\" \"r\" \"float coneAngle\" [12] "
                                           "\"color shadowColor\" [0.5 0 0] "
                                           "\"string shadowSubset\" [\"set\"]");
    if (!strstr(w, "\"coneAngle\" is ignored") || !strstr(w, "\"shadowColor\" is ignored") ||
        !strstr(w, "\"shadowSubset\" is ignored"))
        fail_msg("not warned: %s", w);
}

/* Area lights are emissive patches of radiance intensity 2^exposure lightColor that reflect
 * nothing, in RenderMan's shapes; the current Surface and Color are left as they were. */
static void test_light_shapes(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok(
        "WorldBegin\nSurface \"plastic\"\nAttributeBegin\nTranslate 0 0 5\nScale 2 4 1\n"
        "Light \"PxrRectLight\" \"r\" \"float intensity\" [3] \"float exposure\" "
        "[-1] \"color lightColor\" [1 0.5 1]\nAttributeEnd\n" QUAD "WorldEnd\n",
        &s);
    assert_int_equal(s.patch_count, 2);
    assert_le(&s.attr[0], 1.5, 0.75, 1.5);
    test_assert_near(s.attr[0].kd, 0, 0), test_assert_near(s.attr[0].ks, 0, 0);
    const ts_vec4 *c0 = &s.cp[0], *c3 = &s.cp[15];
    test_assert_near(c0->x, -1, 1e-6), test_assert_near(c0->y, -2, 1e-6),
        test_assert_near(c0->z, 5, 1e-6);
    test_assert_near(c3->x, 1, 1e-6), test_assert_near(c3->y, 2, 1e-6);
    assert_int_equal(s.attr[1].material, TS_MAT_PLASTIC), assert_le(&s.attr[1], 0, 0, 0);
    scene_free(&s);
    /* A sphere of diameter 1, a disk and a cylinder: every patch emits L. */
    const char *shapes[3] = {"PxrSphereLight", "PxrDiskLight", "PxrCylinderLight"};
    for (int k = 0; k < 3; k++) {
        char text[1024];
        snprintf(text, sizeof text,
                 "WorldBegin\nLight \"%s\" \"l\" \"float intensity\" [2] \"int "
                 "enableTemperature\" [1] \"float temperature\" [3000]\nWorldEnd\n",
                 shapes[k]);
        test_parse_rib_ok(text, &s);
        assert_true(s.patch_count >= 1);
        for (uint32_t i = 0; i < s.patch_count; i++) {
            const ts_patch_attr *a = &s.attr[i];
            /* 3000 K: reddish, luminance 2. */
            test_assert_near(0.2126 * a->le_r + 0.7152 * a->le_g + 0.0722 * a->le_b, 2, 1e-4);
            assert_true(a->le_r > a->le_g && a->le_g > a->le_b && a->le_b > 0);
            for (int j = 0; j < 16; j++) {
                const ts_vec4 *q = &s.cp[16 * i + j];
                double r = k == 2 ? sqrt(q->y * q->y + q->z * q->z)
                                  : sqrt(q->x * q->x + q->y * q->y + q->z * q->z);
                assert_true(r <= 0.5 * 1.35 + (k == 2 ? 0 : 0.72)); /* control points near */
                if (k == 1) test_assert_near(q->z, 0, 1e-12);
                if (k == 2) assert_true(fabs(q->x) <= 0.5 + 1e-12);
            }
        }
        scene_free(&s);
    }
    /* 6500 K is near white. */
    test_parse_rib_ok("WorldBegin\nLight \"PxrRectLight\" \"r\" \"int enableTemperature\" [1]\n"
                      "WorldEnd\n",
                      &s);
    test_assert_near(s.attr[0].le_r, 1, 0.06), test_assert_near(s.attr[0].le_g, 1, 0.06);
    test_assert_near(s.attr[0].le_b, 1, 0.06);
    scene_free(&s);
    test_parse_rib_error("WorldBegin\nLight \"PxrRectLight\" \"r\" \"float intensity\" [-1]",
                         "t.rib:2:1: error: Light \"PxrRectLight\": intensity, 2^exposure and "
                         "lightColor must be >= 0 and finite, got -1, 1 and [1 1 1]");
}

/* RenderMan 20's RIS lights: AreaLightSource "PxrStd...Light" (also by RenderMan for Maya's
 * path-named instance) sets the radiance, then Geometry "rectlight" draws the RIS rect light
 * and "distantlight" and "envsphere" the distant light and the dome; ordinary geometry under
 * it emits; a light shape without light in effect warns and draws nothing. */
static void test_renderman_20_lights(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok(
        "WorldBegin\nAttributeBegin\nAreaLightSource \"PxrStdAreaLight\" \"r\" "
        "\"float exposure\" [1] \"color lightColor\" [1 0.5 0.25] \"string rman__Shape\" "
        "[\"rect\"]\nGeometry \"rectlight\"\n" QUAD "AttributeEnd\n"
        "AttributeBegin\nAreaLightSource \"shaders/PxrStdEnvMapLightShape1_rfm\" \"e\" "
        "\"float intensity\" [0.5]\nGeometry \"envsphere\" \"constant float[2] resolution\" "
        "[64 32]\nAttributeEnd\nAttributeBegin\nAreaLightSource \"PxrStdAreaLight\" \"d\" "
        "\"float exposure\" [2]\nGeometry \"distantlight\" \"constant float anglesubtended\" "
        "[3]\nAttributeEnd\n" QUAD "WorldEnd\n",
        &s);
    /* the rect light's patch and the quad under the same AreaLightSource emit 2 (1 .5 .25) */
    assert_int_equal(s.patch_count, 3);
    assert_le(&s.attr[0], 2, 1, 0.5), assert_le(&s.attr[1], 2, 1, 0.5);
    assert_le(&s.attr[2], 0, 0, 0); /* after the blocks: no light */
    assert_int_equal(s.dome.present, 1);
    for (int k = 0; k < 3; k++)
        test_assert_near(s.dome.intensity * s.dome.color[k], 0.5, 1e-12);
    assert_int_equal(s.light_count, 1);
    double h = 1.5 * M_PI / 180; /* radiance 4 in a cone of 3 degrees */
    test_assert_near(s.lights[0].intensity * s.lights[0].color[0], 4 * M_PI * sin(h) * sin(h),
                     1e-9);
    test_assert_near(s.lights[0].angle, 3, 0);
    scene_free(&s);
    assert_string_equal(test_rib_body_warnings("Geometry \"spherelight\""),
                        "w.rib:2:1: warning: Geometry \"spherelight\" emits nothing: no "
                        "AreaLightSource \"PxrStdAreaLight\", \"PxrStdEnvMapLight\" or "
                        "\"PxrStdEnvDayLight\" with light is in effect\n");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bxdf_diffuse),
        cmocka_unit_test(test_bxdf_surface),
        cmocka_unit_test(test_bxdf_disney_conductor_constant),
        cmocka_unit_test(test_bxdf_fallbacks),
        cmocka_unit_test(test_bxdf_lm_diffuse_light_emission),
        cmocka_unit_test(test_bxdf_surface_glass),
        cmocka_unit_test(test_bxdf_lm_glass_metal),
        cmocka_unit_test(test_bxdf_lama_mix),
        cmocka_unit_test(test_bxdf_lama_defaults),
        cmocka_unit_test(test_bxdf_lama_add),
        cmocka_unit_test(test_bxdf_lama_layer),
        cmocka_unit_test(test_bxdf_translucent),
        cmocka_unit_test(test_bxdf_lama_surface),
        cmocka_unit_test(test_pattern_texture),
        cmocka_unit_test(test_presence_cutout),
        cmocka_unit_test(test_pattern_tex_sibling),
        cmocka_unit_test(test_pattern_unknown),
        cmocka_unit_test(test_displace),
        cmocka_unit_test(test_light_dome_distant),
        cmocka_unit_test(test_light_shapes),
        cmocka_unit_test(test_light_neutral_controls),
        cmocka_unit_test(test_renderman_20_lights),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
