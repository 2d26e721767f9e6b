/* test_rib_render.c — RIB requests of issue 16 through the whole renderer, against results
 * known in closed form:
 * - Projection "orthographic" with a ScreenWindow: a square facing the camera covers exactly
 *   the pixels whose centres fall on it, all at the same depth;
 * - Exposure gain gamma: each colour is (gain c)^(1/gamma) of the same render without it;
 * - Surface "metal" under a uniform dome reflects at most Cs, tinted by Cs;
 * - Surface "constant" is its colour, with no light in the scene;
 * - the public RIB files of tests/rib-corpus/ render, one of them to a known motion blur,
 *   one lit by its pointlights alone;
 * - an object instanced three times, each a copy (no instance is a rigid move of the first,
 *   so none shares its dicing), renders bit for bit like its requests written out
 *   (instances that share: tests/test_instance.c);
 * - a moving camera blurs a static patch as the patch moving the other way would be;
 * - a CropWindow's image is the whole frame's pixels there, bit for bit;
 * - DepthOfField: a card in focus as through a pinhole, one farther blurred over its circle
 *   of confusion.
 * Needs an OpenCL device (skipped, 77, without one). */
#include "test_support.h"
#include "image/image.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static char dir[4096];

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "%s", test_scratch_dir());
    return 0;
}

static const char *path(const char *name)
{
    return test_path_in(dir, name);
}

static void write_scene(const char *name, const char *text)
{
    test_write_text(path(name), text);
}

static void render(const char *scene, const char *out, const char *extra)
{
    test_tessera_ok(dir, "render '%s' -o '%s' --quiet %s", path(scene), path(out), extra);
}

/* The channel named `name` of pixel i. */
static float channel(const ts_image *img, int i, const char *name)
{
    for (int c = 0; c < img->channels; c++)
        if (strcmp(img->channel_names[c], name) == 0)
            return img->pixels[(size_t)i * img->channels + c];
    fail_msg("no channel %s", name);
    return 0.0f;
}

/* A 2 x 2 square at depth 5 seen orthographically through the window [-2, 2]^2 on 64 x 64
 * pixels: pixel x's centre is at -2 + 4 (x + 0.5) / 64, inside [-1, 1] for x = 16..47, so
 * exactly 32 x 32 pixels see it, all at distance 5 (Z), and the camera's rotation about its
 * axis does not change that. */
static void test_orthographic_window(void **state)
{
    (void)state;
    write_scene("ortho.rib",
                "Format 64 64 1\nProjection \"orthographic\"\nScreenWindow -2 2 -2 2\n"
                "Rotate 90 0 0 1\nTranslate 0 0 5\n"
                "WorldBegin\nLightSource \"domelight\" 1\n"
                "Patch \"bilinear\" \"P\" [-1 -1 0  1 -1 0  -1 1 0  1 1 0]\nWorldEnd\n");
    render("ortho.rib", "ortho.exr", "--spp 1 --lod 2");
    ts_image img;
    test_read_image(path("ortho.exr"), &img);
    assert_int_equal(img.width, 64);
    int hits = 0;
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++) {
            float z = channel(&img, y * 64 + x, "Z");
            int inside = x >= 16 && x < 48 && y >= 16 && y < 48;
            if (inside != isfinite(z)) fail_msg("pixel (%d %d): Z %g", x, y, z);
            if (!inside) continue;
            hits++;
            if (fabsf(z - 5.0f) > 1e-4f) fail_msg("pixel (%d %d): Z %g, want 5", x, y, z);
        }
    assert_int_equal(hits, 32 * 32);
    image_free(&img);
}

/* Exposure 2 2: R G B become sqrt(2 c) of the image without it, pixel by pixel; the AOVs are
 * the same. */
static void test_exposure(void **state)
{
    (void)state;
    const char *body = "Format 32 24 1\nProjection \"perspective\" \"fov\" [40]\nTranslate 0 0 4\n"
                       "WorldBegin\nLightSource \"domelight\" 1 \"intensity\" [0.7]\n"
                       "LightSource \"distantlight\" 2 \"intensity\" [2] \"from\" [1 1 -1]\n"
                       "Color [0.9 0.5 0.2]\n"
                       "Patch \"bilinear\" \"P\" [-1 -1 0  1 -1 0  -1 1 1  1 1 1]\nWorldEnd\n";
    char text[1024];
    write_scene("plain.rib", body);
    snprintf(text, sizeof text, "Exposure 2 2\n%s", body);
    write_scene("exposed.rib", text);
    render("plain.rib", "plain.exr", "--spp 2");
    render("exposed.rib", "exposed.exr", "--spp 2");
    ts_image a, b;
    test_read_image(path("plain.exr"), &a);
    test_read_image(path("exposed.exr"), &b);
    assert_int_equal(a.channels, b.channels);
    int lit = 0;
    for (int i = 0; i < a.width * a.height; i++)
        for (int c = 0; c < a.channels; c++) {
            float va = a.pixels[(size_t)i * a.channels + c],
                  vb = b.pixels[(size_t)i * b.channels + c];
            const char *name = a.channel_names[c];
            int colour = strcmp(name, "R") == 0 || strcmp(name, "G") == 0 || strcmp(name, "B") == 0;
            float want = colour ? sqrtf(2.0f * va) : va;
            lit += colour && va > 0.0f;
            if (!(fabsf(vb - want) <= 1e-6f * (1.0f + want)) && !(isinf(va) && va == vb))
                fail_msg("pixel %d %s: %g, want %g", i, name, vb, want);
        }
    assert_true(lit > 100);
    image_free(&a);
    image_free(&b);
}

/* Surface "metal" on a convex sphere under a uniform dome of radiance 1: every path leaves
 * after one reflection, so a pixel is the GGX lobe's albedo times Cs — tinted by Cs channel
 * for channel, and in the mean the albedo a Cook-Torrance quadrature gives. */
static void test_metal_furnace(void **state)
{
    (void)state;
    FILE *f = fopen(path("metal.rib"), "w");
    assert_non_null(f);
    fprintf(f,
            "Format 32 32 1\nProjection \"perspective\" \"fov\" [40]\n"
            "Translate 0 0 4\nWorldBegin\nLightSource \"domelight\" 1 \"float intensity\" [1]\n"
            "Color [1 0.5 0.25]\nSurface \"metal\" \"float Ks\" [1] \"float roughness\" [0.3]\n");
    test_write_sphere_patches(f, 2, 1.0);
    fputs("WorldEnd\n", f);
    fclose(f);
    render("metal.rib", "metal.exr", "--spp 16");
    ts_image img;
    test_read_image(path("metal.exr"), &img);
    double sum = 0, want = 0, res = 0, res2 = 0;
    int hits = 0;
    const double tan20 = tan(20.0 * M_PI / 180.0);
    double table[65]; /* the lobe's albedo at cos = k / 64, linearly interpolated below */
    for (int k = 0; k < 65; k++)
        table[k] = test_ggx_albedo(fmax(k / 64.0, 1e-3), 0.3);
    for (int i = 0; i < img.width * img.height; i++) {
        /* The sphere's outline is at 0.71 of the half-height (1 / sqrt(4^2 - 1) / tan 20°):
         * pixels well inside it have no sample of the dome behind. */
        double sx = (i % 32 + 0.5) / 16 - 1, sy = (i / 32 + 0.5) / 16 - 1;
        if (sx * sx + sy * sy > 0.6 * 0.6) continue;
        assert_true(isfinite(channel(&img, i, "Z")));
        float r = channel(&img, i, "R"), g = channel(&img, i, "G"), b = channel(&img, i, "B");
        if (fabsf(g - 0.5f * r) > 1e-5f * (1 + r) || fabsf(b - 0.25f * r) > 1e-5f * (1 + r))
            fail_msg("pixel %d: (%g %g %g), want r : g : b = 1 : 0.5 : 0.25", i, r, g, b);
        /* The pixel's expectation: the lobe's albedo (test_ggx_albedo, a quadrature in the
         * test) at the cosine between the view ray and the unit sphere's normal at distance
         * 4, averaged over 4 x 4 points of the pixel. */
        double a = 0;
        for (int k = 0; k < 16; k++) {
            double px = (i % 32 + (k % 4 + 0.5) / 4) / 16 - 1,
                   py = (i / 32 + (k / 4 + 0.5) / 4) / 16 - 1;
            double d[3] = {px * tan20, py * tan20, 1}, l = sqrt(d[0] * d[0] + d[1] * d[1] + 1);
            double hb = 4 * d[2] / l, t = hb - sqrt(hb * hb - 15); /* |t d/l - (0,0,4)| = 1 */
            double z = t * d[2] / l - 4; /* the normal (x, y, z) of the hit; cos = -n.d/l */
            double co = -(t * d[0] / l * d[0] + t * d[1] / l * d[1] + z * d[2]) / l;
            double at = fmin(fmax(co, 0.0), 1.0) * 64;
            int k0 = (int)fmin(at, 63.0);
            a += (table[k0] + (at - k0) * (table[k0 + 1] - table[k0])) / 16;
        }
        sum += r, want += a, hits++;
        res += r - a, res2 += (r - a) * (r - a);
    }
    assert_true(hits > 250);
    /* The mean over 250+ pixels of 16 samples against the Cook-Torrance quadrature: 5
     * standard errors of the pixels' residuals (their spread is the Monte Carlo noise), plus
     * 2e-3 for the Bezier sphere's normals (within 1e-3 of the sphere's). */
    double m = res / hits, se = sqrt(fmax(res2 / hits - m * m, 0) / hits), tol = 5 * se + 2e-3;
    if (fabs(m) > tol)
        fail_msg("mean red %g, Cook-Torrance quadrature %g (tol %g)", sum / hits, want / hits, tol);
    image_free(&img);
}

/* Surface "constant": the surface's colour, lit by nothing (here there is no light at all). */
static void test_constant(void **state)
{
    (void)state;
    write_scene("constant.rib",
                "Format 16 16 1\nProjection \"perspective\" \"fov\" [40]\nTranslate 0 0 3\n"
                "WorldBegin\nColor [0.3 0.6 0.9]\nSurface \"constant\"\n"
                "Patch \"bilinear\" \"P\" [-1 -1 0  1 -1 0  -1 1 0  1 1 0]\nWorldEnd\n");
    render("constant.rib", "constant.exr", "--spp 2");
    ts_image img;
    test_read_image(path("constant.exr"), &img);
    int hits = 0;
    for (int i = 0; i < img.width * img.height; i++) {
        /* The square spans +-0.92 of the screen: pixels 2..13 lie wholly on it. */
        if (i % 16 < 2 || i % 16 > 13 || i / 16 < 2 || i / 16 > 13) continue;
        hits++;
        if (fabsf(channel(&img, i, "R") - 0.3f) > 1e-6f ||
            fabsf(channel(&img, i, "G") - 0.6f) > 1e-6f ||
            fabsf(channel(&img, i, "B") - 0.9f) > 1e-6f)
            fail_msg("pixel %d: (%g %g %g), want (0.3 0.6 0.9)", i, channel(&img, i, "R"),
                     channel(&img, i, "G"), channel(&img, i, "B"));
    }
    assert_true(hits > 100);
    image_free(&img);
}

/* A 32x8 image whose columns' green ramps from 0 at the left to 1 at the right: each
 * column's mean is its centre x within Monte Carlo error (512 samples a column: 5 sigma <=
 * 0.11). */
static void assert_columns_ramp(const char *name)
{
    ts_image img;
    test_read_image(path(name), &img);
    for (int x = 0; x < 32; x++) {
        double sum = 0;
        for (int y = 0; y < 8; y++)
            sum += channel(&img, y * 32 + x, "G");
        double want = (x + 0.5) / 32;
        if (fabs(sum / 8 - want) > 0.12)
            fail_msg("%s: column %d: %g, want %g", name, x, sum / 8, want);
    }
    image_free(&img);
}

/* The public RIB files of tests/rib-corpus/ render (exit status 0, an image of the size
 * asked for); in mb_noise_test.rib a constant-white patch moves across an orthographic
 * window during the shutter, covering screen x for the part x of it, so each column's
 * brightness is its x (motion blur, orthographic ScreenWindow and constant together). */
static void test_corpus_renders(void **state)
{
    (void)state;
    static const char *const files[] = {
        "aqsis/tools/displays/exr/tst.rib",
        "aqsis/tools/displays/xpm/teapotgeom.rib",
        "aqsis/prototypes/newcore/scenes/tenpatch.rib",
        "aqsis/prototypes/newcore/scenes/simpledeformation.rib",
        "aqsis/examples/features/textures/sticky.rib",
        "aqsis/examples/features/objectinstance/singlepolygon.rib",
    };
    char rel[256];
    for (size_t k = 0; k < sizeof files / sizeof files[0]; k++) {
        snprintf(rel, sizeof rel, "tests/rib-corpus/%s", files[k]);
        test_tessera_ok(dir, "render '%s' -o '%s' --quiet --res 24x18 --spp 1 --max-lod 2",
                        test_source_path(rel), path("corpus.exr"));
        ts_image img;
        test_read_image(path("corpus.exr"), &img);
        assert_true(img.width == 24 && img.height == 18);
        if (k == 1) { /* teapotgeom.rib: lit by its pointlights only */
            double sum = 0;
            for (int i = 0; i < img.width * img.height; i++)
                sum += img.pixels[(size_t)i * img.channels];
            assert_true(sum > 0.5);
        }
        image_free(&img);
    }
    snprintf(rel, sizeof rel, "tests/rib-corpus/aqsis/prototypes/newcore/scenes/mb_noise_test.rib");
    test_tessera_ok(dir, "render '%s' -o '%s' --quiet --res 32x8 --spp 64 --max-lod 2",
                    test_source_path(rel), path("blur.exr"));
    assert_columns_ramp("blur.exr");
}

/* A moving camera (MotionBegin around the camera transformation): a static constant-white
 * patch covering world x in [1, 2], an orthographic window over screen x in [0, 1], the camera
 * moving from x = 0 to x = 1 during the shutter. Screen x = s sees world x = s + t at time t,
 * the patch for t >= 1 - s: each column's brightness is its s, the mirror of mb_noise_test.rib's
 * moving patch. At shutter open alone (the first sample twice) the window sees none of it. */
static void test_moving_camera(void **state)
{
    (void)state;
    const char *head = "Format 32 8 1\nProjection \"orthographic\"\n"
                       "ScreenWindow 0 1 -0.125 0.125\nMotionBegin [0 1]\n";
    const char *world = "MotionEnd\nWorldBegin\nSurface \"constant\"\n"
                        "Patch \"bilinear\" \"P\" [1 -1 0  2 -1 0  1 1 0  2 1 0]\nWorldEnd\n";
    char text[1024];
    snprintf(text, sizeof text, "%sTranslate 0 0 5\nTranslate -1 0 5\n%s", head, world);
    write_scene("camblur.rib", text);
    render("camblur.rib", "camblur.exr", "--spp 64 --max-lod 2");
    assert_columns_ramp("camblur.exr");
    snprintf(text, sizeof text, "%sTranslate 0 0 5\nTranslate 0 0 5\n%s", head, world);
    write_scene("camstill.rib", text);
    render("camstill.rib", "camstill.exr", "--spp 4 --max-lod 2");
    ts_image img;
    test_read_image(path("camstill.exr"), &img);
    for (int i = 0; i < 32 * 8; i++)
        if (channel(&img, i, "G") != 0.0f) fail_msg("pixel %d: %g", i, channel(&img, i, "G"));
    image_free(&img);
}

/* An instance that cannot share its master's dicing is a copy of its object: the image of an
 * object instanced three times (different transformations, scaled so that none is a rigid move
 * of the first, colours and surfaces, one displaced) is bit for bit the image of the same
 * requests written out in full at each instance. */
static void test_object_instances_render(void **state)
{
    (void)state;
    static const char head[] =
        "Format 48 32 1\nProjection \"perspective\" \"fov\" [40]\nTranslate 0 -0.5 9\n"
        "Rotate -100 1 0 0\nWorldBegin\nLightSource \"distantlight\" 1 \"from\" [1 -2 3] "
        "\"to\" [0 0 0]\nLightSource \"pointlight\" 2 \"intensity\" [20] \"from\" [0 -3 3]\n"
        "Patch \"bilinear\" \"P\" [-6 -6 0  6 -6 0  -6 6 0  6 6 0]\n";
    static const char body[] = "Sphere 0.6 -0.6 0.6 360\nTranslate 0 0 0.6\nScale 0.3 0.3 0.3\n"
                               "Displacement \"fbm\" \"amplitude\" [0.1]\nGeometry \"teapot\"\n";
    static const char *const place[3] = {"Translate -2.5 0 0.6\nColor [0.8 0.2 0.2]\n",
                                         "Translate 0 0 0.6\nRotate 40 0 0 1\nScale 0.9 0.9 0.9\n"
                                         "Surface \"metal\"\n",
                                         "Translate 2.5 0 0.6\nScale 1.2 1.2 1.2\n"};
    char inst[4096], full[4096];
    int a = snprintf(inst, sizeof inst, "%sObjectBegin \"thing\"\n%sObjectEnd\n", head, body);
    int b = snprintf(full, sizeof full, "%s", head);
    for (int k = 0; k < 3; k++) {
        a += snprintf(inst + a, sizeof inst - a,
                      "AttributeBegin\n%sObjectInstance \"thing\"\nAttributeEnd\n", place[k]);
        b += snprintf(full + b, sizeof full - b, "AttributeBegin\n%s%sAttributeEnd\n", place[k],
                      body);
    }
    snprintf(inst + a, sizeof inst - a, "WorldEnd\n");
    snprintf(full + b, sizeof full - b, "WorldEnd\n");
    write_scene("inst.rib", inst);
    write_scene("full.rib", full);
    render("inst.rib", "inst.exr", "--spp 4 --max-lod 4");
    render("full.rib", "full.exr", "--spp 4 --max-lod 4");
    test_assert_same_pixels(path("inst.exr"), path("full.exr"));
    ts_image img; /* and it is an image of something: the three objects are lit */
    test_read_image(path("inst.exr"), &img);
    double sum = 0;
    for (int i = 0; i < img.width * img.height; i++)
        sum += img.pixels[(size_t)i * img.channels];
    image_free(&img);
    assert_true(sum > 1.0);
}

/* A plane under a distant light (a delta: the matte plane's radiance is the same constant
 * wherever it is lit, no noise) and a black occluder beside the camera's view whose shadow
 * falls on the plane's left quarter (x < -0.5). By default that quarter is dark; with
 * Attribute "visibility" "transmission" [0] (or BMRT's "render" "casts_shadows" "none") on
 * the occluder, shadow rays pass through it and the whole plane is lit alike. The occluder
 * stays visible to other rays: it is black, so it reflects nothing onto the plane. */
static void shadow_scene(const char *name, const char *occluder_attr)
{
    char text[2048];
    snprintf(text, sizeof text,
             "Format 32 32 1\nProjection \"orthographic\"\nScreenWindow -1 1 -1 1\n"
             "Translate 0 0 5\nWorldBegin\n"
             "LightSource \"distantlight\" 1 \"from\" [0 0 0] \"to\" [1 0 1] \"intensity\" [2]\n"
             "AttributeBegin\n%s\nColor [0 0 0]\n"
             "Patch \"bilinear\" \"P\" [-3 -3 -1  -1.5 -3 -1  -3 3 -1  -1.5 3 -1]\nAttributeEnd\n"
             "Patch \"bilinear\" \"P\" [-1 -1 0  1 -1 0  -1 1 0  1 1 0]\nWorldEnd\n",
             occluder_attr);
    write_scene(name, text);
}

static void test_casts_no_shadow(void **state)
{
    (void)state;
    const char *attrs[] = {"", "Attribute \"visibility\" \"int transmission\" [0]",
                           "Attribute \"render\" \"casts_shadows\" [\"none\"]",
                           "Attribute \"visibility\" \"transmission\" \"transparent\"",
                           "Attribute \"render\" \"casts_shadows\" \"opaque\""};
    for (int k = 0; k < 5; k++) {
        char scene[64], out[64];
        snprintf(scene, sizeof scene, "shadow%d.rib", k);
        snprintf(out, sizeof out, "shadow%d.exr", k);
        shadow_scene(scene, attrs[k]);
        render(scene, out, "--spp 1 --lod 6"); /* secondary rays leave 2 / 2^6 above it */
        ts_image img;
        test_read_image(path(out), &img);
        int casts = k == 0 || k == 4;
        float lit = channel(&img, 16 * 32 + 24, "R"); /* x = 0.53: lit in every variant */
        assert_true(lit > 0.1f);
        for (int y = 1; y < 31; y++)
            for (int x = 1; x < 31; x++) {
                float v = channel(&img, y * 32 + x, "R"), px = -1.0f + (x + 0.5f) / 16.0f;
                int shadowed = casts && px < -0.5f - 0.07f;
                if (px > -0.5f - 0.07f && px < -0.5f + 0.07f) continue; /* the shadow's edge */
                if (shadowed ? v != 0.0f : fabsf(v - lit) > 1e-5f * lit)
                    fail_msg("%s: pixel (%d %d) %g, want %g", attrs[k], x, y, v,
                             shadowed ? 0.0f : lit);
            }
        image_free(&img);
    }
}

/* Attribute "visibility" "camera" [0]: eye rays pass through a red constant card over the
 * left half of a green constant plane, which then shows whole; without it the card covers
 * the left half. Constant surfaces are seen in their colour exactly. */
static void test_camera_invisible(void **state)
{
    (void)state;
    for (int k = 0; k < 2; k++) {
        char text[1024];
        snprintf(text, sizeof text,
                 "Format 16 16 1\nProjection \"orthographic\"\nScreenWindow -1 1 -1 1\n"
                 "Translate 0 0 5\nWorldBegin\nSurface \"constant\"\nAttributeBegin\n%s\n"
                 "Color [1 0 0]\nPatch \"bilinear\" \"P\" [-2 -2 -1  0 -2 -1  -2 2 -1  0 2 -1]\n"
                 "AttributeEnd\nColor [0 1 0]\n"
                 "Patch \"bilinear\" \"P\" [-2 -2 0  2 -2 0  -2 2 0  2 2 0]\nWorldEnd\n",
                 k ? "Attribute \"visibility\" \"int camera\" [0]" : "");
        write_scene("card.rib", text);
        render("card.rib", "card.exr", "--spp 1");
        ts_image img;
        test_read_image(path("card.exr"), &img);
        for (int i = 0; i < 256; i++) {
            int card = !k && i % 16 < 8;
            float r = channel(&img, i, "R"), g = channel(&img, i, "G");
            if (r != (card ? 1.0f : 0.0f) || g != (card ? 0.0f : 1.0f))
                fail_msg("%s: pixel %d (%g %g), want the %s", k ? "unseen card" : "card", i, r, g,
                         card ? "card" : "plane");
        }
        image_free(&img);
    }
}

/* Clipping near far: the camera sees camera-space depths in [near, far] only. A red card at
 * depth 4 over the left half of a green plane at depth 5, orthographic (each pixel's Z is
 * its depth, to a few ulps): without Clipping the card and the plane; with Clipping 4.5 10
 * the card is clipped (the plane everywhere, Z still 5: the ray starts at the near plane and
 * Z counts from the eye); with Clipping 0.1 4.5 the plane is (nothing right of the card, Z
 * infinite).
 * Through a perspective camera Clipping 1 10 changes no pixel's colour and its Z by at most a
 * few ulps. */
static void test_clipping(void **state)
{
    (void)state;
    const char *clip[] = {"", "Clipping 4.5 10", "Clipping 0.1 4.5"};
    for (int k = 0; k < 3; k++) {
        char text[1024];
        snprintf(text, sizeof text,
                 "Format 16 16 1\nProjection \"orthographic\"\nScreenWindow -1 1 -1 1\n%s\n"
                 "Translate 0 0 5\nWorldBegin\nSurface \"constant\"\nColor [1 0 0]\n"
                 "Patch \"bilinear\" \"P\" [-2 -2 -1  0 -2 -1  -2 2 -1  0 2 -1]\nColor [0 1 0]\n"
                 "Patch \"bilinear\" \"P\" [-2 -2 0  2 -2 0  -2 2 0  2 2 0]\nWorldEnd\n",
                 clip[k]);
        write_scene("clip.rib", text);
        render("clip.rib", "clip.exr", "--spp 1");
        ts_image img;
        test_read_image(path("clip.exr"), &img);
        for (int i = 0; i < 256; i++) {
            int left = i % 16 < 8, card = left && k != 1, plane = !card && k != 2;
            float r = channel(&img, i, "R"), g = channel(&img, i, "G"), z = channel(&img, i, "Z");
            float want_z = card ? 4.0f : plane ? 5.0f : INFINITY;
            int z_ok = isinf(want_z) ? isinf(z) : fabsf(z - want_z) <= 1e-5f * want_z;
            if (r != (card ? 1.0f : 0.0f) || g != (plane ? 1.0f : 0.0f) || !z_ok)
                fail_msg("'%s': pixel %d (%g %g, Z %g), want %s", clip[k], i, r, g, z,
                         card    ? "the card"
                         : plane ? "the plane"
                                 : "nothing");
        }
        image_free(&img);
    }
    ts_image img[2];
    for (int k = 0; k < 2; k++) {
        char text[1024];
        snprintf(text, sizeof text,
                 "Format 16 16 1\nProjection \"perspective\" \"fov\" [60]\n%s\n"
                 "Translate 0 0 5\nWorldBegin\nSurface \"constant\"\nColor [0 1 0]\n"
                 "Patch \"bilinear\" \"P\" [-9 -9 0  9 -9 0  -9 9 0  9 9 0]\nWorldEnd\n",
                 k ? "Clipping 1 10" : "");
        write_scene("clip.rib", text);
        render("clip.rib", k ? "clip1.exr" : "clip0.exr", "--spp 1");
        test_read_image(path(k ? "clip1.exr" : "clip0.exr"), &img[k]);
    }
    for (int i = 0; i < 256; i++) {
        float z0 = channel(&img[0], i, "Z"), z1 = channel(&img[1], i, "Z");
        assert_true(channel(&img[0], i, "G") == 1.0f && channel(&img[1], i, "G") == 1.0f);
        if (!(z0 >= 5.0f && fabsf(z1 - z0) <= 4e-6f * z0))
            fail_msg("perspective pixel %d: Z %.9g clipped against %.9g", i, z1, z0);
    }
    image_free(&img[0]), image_free(&img[1]);
}

/* Attribute "visibility" "indirect" [0] on an emitter beside the view that lights a matte
 * plane: the bounces' BSDF rays pass through it, so with --sampling bsdf the plane stays
 * black (lit without the attribute), and under the default MIS light sampling counts whole
 * there: the plane's mean is the same as without the attribute, within the noise. */
static double plane_mean(int unseen, const char *sampling)
{
    char text[1024], opts[64];
    snprintf(text, sizeof text,
             "Format 16 16 1\nProjection \"orthographic\"\nScreenWindow -1 1 -1 1\n"
             "Translate 0 0 5\nWorldBegin\nAttributeBegin\n%s\n"
             "AreaLightSource \"arealight\" 1 \"intensity\" [4]\n"
             "Patch \"bilinear\" \"P\" [1.2 -1 -0.6  2.2 -1 -0.6  1.2 1 -0.6  2.2 1 -0.6]\n"
             "AttributeEnd\nPatch \"bilinear\" \"P\" [-1 -1 0  1 -1 0  -1 1 0  1 1 0]\nWorldEnd\n",
             unseen ? "Attribute \"visibility\" \"int indirect\" [0]" : "");
    write_scene("indirect.rib", text);
    /* --lod 7: secondary rays leave 2 / 2^7 above the plane (coarser, that offset makes BSDF
     * and light sampling see the emitter differently) */
    snprintf(opts, sizeof opts, "--spp 256 --depth 1 --lod 7 --sampling %s", sampling);
    render("indirect.rib", "indirect.exr", opts);
    ts_image img;
    test_read_image(path("indirect.exr"), &img);
    double sum = 0.0;
    for (int i = 0; i < 256; i++)
        sum += channel(&img, i, "R");
    image_free(&img);
    return sum / 256.0;
}

static void test_indirect_invisible(void **state)
{
    (void)state;
    double bsdf = plane_mean(0, "bsdf"), unseen_bsdf = plane_mean(1, "bsdf");
    double mis = plane_mean(0, "mis"), unseen_mis = plane_mean(1, "mis");
    assert_true(bsdf > 0.01);
    if (unseen_bsdf != 0.0) fail_msg("BSDF rays found the unseen emitter: %g", unseen_bsdf);
    if (!(fabs(unseen_mis - mis) <= 0.03 * mis))
        fail_msg("light sampling alone %g, MIS %g: not the same light", unseen_mis, mis);
    if (!(fabs(bsdf - mis) <= 0.05 * mis)) fail_msg("BSDF sampling %g, MIS %g", bsdf, mis);
}

/* CropWindow (and --crop) renders a part of the frame: the image is the pixels from column
 * ceil(W xmin) to ceil(W xmax) - 1 and rows likewise, and each of them is the whole frame's
 * pixel bit for bit, in every channel (the same rays, sample values and levels of detail: the
 * lod pass counts the whole frame), on one device and on two. A window that holds no pixel is
 * an error that names it. */
static void test_crop_window(void **state)
{
    (void)state;
    const char *teapot = test_source_path("scene/teapot.rib");
    char text[4096];
    snprintf(text, sizeof text, "CropWindow 0.3 0.8 0.25 0.7\nReadArchive \"%s\"\n", teapot);
    write_scene("crop.rib", text);
    test_tessera_ok(dir, "render '%s' -o '%s' --quiet --res 48x27 --spp 4", teapot,
                    path("whole.exr"));
    render("crop.rib", "crop.exr", "--res 48x27 --spp 4");
    test_tessera_ok(dir, "render '%s' -o '%s' --quiet --res 48x27 --spp 4 --crop 0.3,0.8,0.25,0.7",
                    teapot, path("crop_cli.exr"));
    char pair[32];
    int two = test_pocl_devices(pair, sizeof pair, 2) >= 2; /* PoCL's pthread driver twice */
    if (two) {
        setenv("POCL_DEVICES", "pthread pthread", 1);
        char opts[96];
        snprintf(opts, sizeof opts, "--res 48x27 --spp 4 --device %s", pair);
        render("crop.rib", "crop_two.exr", opts);
        unsetenv("POCL_DEVICES");
    }
    ts_image whole, part;
    test_read_image(path("whole.exr"), &whole);
    const char *parts[] = {"crop.exr", "crop_cli.exr", "crop_two.exr"};
    for (int k = 0; k < 2 + two; k++) {
        test_read_image(path(parts[k]), &part);
        /* columns ceil(14.4) = 15 .. ceil(38.4) - 1 = 38, rows ceil(6.75) = 7 .. 18 */
        assert_int_equal(part.width, 24);
        assert_int_equal(part.height, 12);
        /* where it lies in the frame: the EXR's data window in its display window */
        assert_true(part.x0 == 15 && part.y0 == 7);
        assert_true(part.full_width == 48 && part.full_height == 27);
        assert_int_equal(part.channels, whole.channels);
        int lit = 0;
        for (int y = 0; y < 12; y++)
            for (int x = 0; x < 24; x++)
                for (int c = 0; c < part.channels; c++) {
                    float a = part.pixels[((size_t)y * 24 + (size_t)x) * (size_t)part.channels + c];
                    float b = whole.pixels[((size_t)(y + 7) * 48 + (size_t)(x + 15)) *
                                               (size_t)whole.channels +
                                           c];
                    lit += c == 0 && a > 0.0f;
                    if (memcmp(&a, &b, sizeof a) != 0)
                        fail_msg("%s: pixel (%d, %d) channel %s is %.9g, the frame's %.9g",
                                 parts[k], x, y, part.channel_names[c], a, b);
                }
        assert_true(lit > 24); /* the teapot is in it */
        image_free(&part);
    }
    image_free(&whole);
    render("crop.rib", "crop.png", "--res 48x27 --spp 4"); /* a PNG is the part alone */
    test_read_image(path("crop.png"), &part);
    assert_true(part.width == 24 && part.height == 12 && part.full_width == 0);
    image_free(&part);
    write_scene("empty.rib", "CropWindow 0.501 0.502 0 1\nWorldBegin\nSphere 1 -1 1 360\n"
                             "WorldEnd\n");
    assert_int_not_equal(test_run_tessera(dir, "render '%s' -o '%s' --quiet --res 48x27",
                                          path("empty.rib"), path("empty.exr")),
                         0);
    test_expect_in_stderr(dir, "CropWindow 0.501 0.502 0 1 holds no pixel of the 48x27 frame");
    assert_int_not_equal(test_run_tessera(dir, "render '%s' -o '%s' --quiet --crop 0.5,0.4,0,1",
                                          teapot, path("bad.exr")),
                         0);
    test_expect_in_stderr(dir, "bad value '0.5,0.4,0,1' for --crop");
}

/* DepthOfField fstop focallength focaldistance: a thin lens. A constant card at the focal
 * distance renders bit for bit as through a pinhole (every ray of a sample meets the plane of
 * focus where the pinhole's does); a card twice as far is blurred over the circle of confusion,
 * A |z - f| / (z f) radians across (A = focallength / fstop the aperture), and keeps its light
 * (the image's sum, within the noise); the CPU lanes and the one-ray form agree bit for bit;
 * Projection "perspective"'s fStop, focalLength and focalDistance are the same lens. */
static void test_depth_of_field(void **state)
{
    (void)state;
    const char *scene =
        "Format 192 128 1\nProjection \"perspective\" \"fov\" [40] %s\n%s\n"
        "Translate 0 0 5\nWorldBegin\nSurface \"constant\"\nColor [1 0 0]\n"
        "Patch \"bilinear\" \"P\" [-1.2 -0.5 0  -0.2 -0.5 0  -1.2 0.5 0  -0.2 0.5 0]\n"
        "Color [0 1 0]\nTranslate 0 0 5\n"
        "Patch \"bilinear\" \"P\" [0.5 -1 0  2.5 -1 0  0.5 1 0  2.5 1 0]\nWorldEnd\n";
    const char *variant[4][2] = {{"", ""},
                                 {"", "DepthOfField 2 1 5"},
                                 {"\"float fStop\" [2] \"float focalLength\" [1] "
                                  "\"float focalDistance\" [5]",
                                  ""},
                                 {"", "DepthOfField 2 1 5"}};
    const char *out[4] = {"pin.exr", "dof.exr", "proj.exr", "lanes.exr"};
    for (int k = 0; k < 4; k++) {
        char text[2048];
        snprintf(text, sizeof text, scene, variant[k][0], variant[k][1]);
        write_scene("dof.rib", text);
        if (k == 3) setenv("TESSERA_CPU_LANES", "0", 1);
        render("dof.rib", out[k], "--spp 64");
        if (k == 3) unsetenv("TESSERA_CPU_LANES");
    }
    test_assert_same_pixels(path("dof.exr"), path("proj.exr"));
    test_assert_same_pixels(path("dof.exr"), path("lanes.exr"));
    ts_image pin, dof;
    test_read_image(path("pin.exr"), &pin);
    test_read_image(path("dof.exr"), &dof);
    double sum_pin = 0.0, sum_dof = 0.0;
    for (int i = 0; i < 192 * 128; i++) {
        float r0 = channel(&pin, i, "R"), r1 = channel(&dof, i, "R");
        if (memcmp(&r0, &r1, sizeof r0) != 0)
            fail_msg("pixel %d: the card in focus is %.9g, through a pinhole %.9g", i, r1, r0);
        sum_pin += channel(&pin, i, "G"), sum_dof += channel(&dof, i, "G");
    }
    /* the far card's left edge (near x = 105) along the middle row: pixels part-covered */
    int soft_pin = 0, soft_dof = 0;
    for (int x = 0; x < 192; x++) {
        float g0 = channel(&pin, 64 * 192 + x, "G"), g1 = channel(&dof, 64 * 192 + x, "G");
        soft_pin += g0 > 0.03f && g0 < 0.97f && x < 122;
        soft_dof += g1 > 0.03f && g1 < 0.97f && x < 122;
    }
    /* the circle of confusion: 0.5 |10 - 5| / (10 * 5) = 0.05 rad; 128 pixels span
     * 2 tan(20 degrees) */
    double coc = 0.05 * 128.0 / (2.0 * tan(20.0 * M_PI / 180.0));
    if (!(soft_pin <= 1 && fabs(soft_dof - coc) <= 2.0))
        fail_msg("the far edge is %d pixels soft through the lens (%.1f wanted), %d through a "
                 "pinhole",
                 soft_dof, coc, soft_pin);
    if (fabs(sum_dof - sum_pin) > 0.01 * sum_pin)
        fail_msg("the far card's light: %g through the lens, %g through a pinhole", sum_dof,
                 sum_pin);
    image_free(&pin), image_free(&dof);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_orthographic_window),
        cmocka_unit_test(test_exposure),
        cmocka_unit_test(test_metal_furnace),
        cmocka_unit_test(test_constant),
        cmocka_unit_test(test_corpus_renders),
        cmocka_unit_test(test_object_instances_render),
        cmocka_unit_test(test_moving_camera),
        cmocka_unit_test(test_casts_no_shadow),
        cmocka_unit_test(test_camera_invisible),
        cmocka_unit_test(test_indirect_invisible),
        cmocka_unit_test(test_clipping),
        cmocka_unit_test(test_crop_window),
        cmocka_unit_test(test_depth_of_field),
    };
    return TEST_RUN_WITH_DEVICE(tests, setup);
}
