/* test_texture.c — image textures (host/scene/texture.c, lib/texture.h, docs/rendering.md):
 * the min-max pyramid against brute force, tex_range against bilinear lookups at random
 * points of random st rectangles (wrapping, negative and large coordinates), the RIB
 * requests and their errors (file:line:col), and two renders: a colour texture seen through
 * the albedo AOV, a constant displacement texture equal to a moved plane (Z AOV), and
 * paging (a tile pool smaller than the textures) giving the same image as full residency. */
#include "image/image.h"
#include "scene/rib/rib.h"
#include "scene/scene.h"
#include "lib/displace.h"
#include "lib/texture.h"

#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

static char dir[4096];

/* Writes a w x h texture of `channels` channels from f(x, y, c) as dir/name (EXR). */
static const char *write_texture(const char *name, int w, int h, int channels,
                                 float (*f)(int x, int y, int c, uint32_t *seed), uint32_t seed)
{
    float *px = malloc((size_t)w * h * channels * sizeof *px);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < channels; c++)
                px[((size_t)y * w + x) * channels + c] = f(x, y, c, &seed);
    ts_image img = {
        .width = w, .height = h, .channels = channels, .channel_names = NULL, .pixels = px};
    ts_error e = {0};
    const char *path = test_path_in(dir, name);
    if (image_write_exr(path, &img, NULL, 0, &e)) fail_msg("%s", e.msg);
    free(px);
    return path;
}

static float random_texel(int x, int y, int c, uint32_t *seed)
{
    (void)x, (void)y, (void)c;
    return test_uniform(seed, -2.0f, 3.0f);
}

/* Quadrants, rows from the top: red | green over blue | white. */
static float quadrant_texel(int x, int y, int c, uint32_t *seed)
{
    (void)seed;
    static const float q[4][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
    return q[(y >= 32) * 2 + (x >= 32)][c];
}

static float ramp_texel(int x, int y, int c, uint32_t *seed)
{
    (void)y, (void)c, (void)seed;
    return (float)x;
}

static float constant_texel(int x, int y, int c, uint32_t *seed)
{
    (void)x, (void)y, (void)c, (void)seed;
    return 0.75f;
}

/* Level-0 value of texel (x, y) straight from the pool. */
static float level0(const ts_scene *s, uint32_t id, uint32_t x, uint32_t y)
{
    return tex_texel(scene_tex_ctx(s), &s->textures[id], 0u, x, y).x;
}

static void test_pyramid(void **state)
{
    (void)state;
    const int w = 45, h = 29;
    const char *path = write_texture("r.exr", w, h, 1, random_texel, 7u);
    ts_scene s = {0};
    ts_error e = {0};
    uint32_t id, again;
    if (scene_add_texture(&s, path, TS_TEX_MINMAX, &id, &e)) fail_msg("%s", e.msg);
    assert_int_equal(scene_add_texture(&s, path, TS_TEX_MINMAX, &again, &e), TS_OK);
    assert_int_equal(again, id); /* read once */
    const ts_texture *t = &s.textures[id];
    assert_int_equal(t->levels, 7); /* 45 -> 23 -> 12 -> 6 -> 3 -> 2 -> 1 */
    ts_image img;
    test_read_image(path, &img);
    float gmin = INFINITY, gmax = -INFINITY;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            float v = img.pixels[y * w + x];
            assert_true(level0(&s, id, (uint32_t)x, (uint32_t)y) == v);
            gmin = fminf(gmin, v), gmax = fmaxf(gmax, v);
        }
    /* Every texel of every level: exactly the min and max over the level-0 texels it covers. */
    for (uint32_t k = 1; k < t->levels; k++)
        for (uint32_t y = 0; y < tex_dim(h, k); y++)
            for (uint32_t x = 0; x < tex_dim(w, k); x++) {
                float lo = INFINITY, hi = -INFINITY;
                for (uint32_t yy = y << k; yy < ((y + 1) << k) && yy < (uint32_t)h; yy++)
                    for (uint32_t xx = x << k; xx < ((x + 1) << k) && xx < (uint32_t)w; xx++)
                        lo = fminf(lo, img.pixels[yy * w + xx]),
                        hi = fmaxf(hi, img.pixels[yy * w + xx]);
                ts_vec4 v = tex_texel(scene_tex_ctx(&s), t, k, x, y);
                if (v.x != lo || v.y != hi)
                    fail_msg("level %u texel (%u %u): %g %g, want %g %g", k, x, y, v.x, v.y, lo,
                             hi);
            }
    ts_interval g = scene_texture_range(&s, id);
    assert_true(g.lo == gmin && g.hi == gmax);
    /* A lookup at a texel centre is the texel; halfway between two it is their mean; the
     * texture repeats with period 1. */
    float v = tex_bilinear(scene_tex_ctx(&s), id, 3.5f / w, 4.5f / h).x;
    assert_float_equal(v, img.pixels[4 * w + 3], 1e-5);
    v = tex_bilinear(scene_tex_ctx(&s), id, 4.0f / w, 4.5f / h).x;
    assert_float_equal(v, 0.5f * (img.pixels[4 * w + 3] + img.pixels[4 * w + 4]), 1e-6);
    assert_float_equal(tex_bilinear(scene_tex_ctx(&s), id, 2.0f + 3.5f / w, -1.0f + 4.5f / h).x,
                       img.pixels[4 * w + 3], 1e-5);
    /* Across the wrap: texel 0 and texel w - 1. */
    v = tex_bilinear(scene_tex_ctx(&s), id, 0.0f, 4.5f / h).x;
    assert_float_equal(v, 0.5f * (img.pixels[4 * w] + img.pixels[4 * w + w - 1]), 1e-6);
    image_free(&img);
    scene_free(&s);
}

/* tex_range holds every bilinear lookup in its rectangle, and is much tighter than the
 * global range for small rectangles (the pyramid works). */
static void test_range_conservative(void **state)
{
    (void)state;
    const char *path = write_texture("big.exr", 200, 77, 1, random_texel, 99u);
    ts_scene s = {0};
    ts_error e = {0};
    uint32_t id;
    if (scene_add_texture(&s, path, TS_TEX_MINMAX, &id, &e)) fail_msg("%s", e.msg);
    ts_tex_ctx c = scene_tex_ctx(&s);
    ts_interval g = scene_texture_range(&s, id);
    uint32_t seed = 5u;
    int tight = 0;
    for (int r = 0; r < 3000; r++) {
        /* Sizes from a fraction of a texel to more than the period; places incl. negative. */
        float size = powf(10.0f, test_uniform(&seed, -4.0f, 0.3f));
        float s0 = test_uniform(&seed, -3.0f, 3.0f), t0 = test_uniform(&seed, -3.0f, 3.0f);
        if (r % 10 == 0) s0 += 1000.0f; /* large coordinates */
        float s1 = s0 + size * test_uniform(&seed, 0.0f, 1.0f),
              t1 = t0 + size * test_uniform(&seed, 0.0f, 1.0f);
        ts_interval b = tex_range(c, id, s0, t0, s1, t1);
        assert_true(b.lo >= g.lo - 1e-5f && b.hi <= g.hi + 1e-5f);
        if (b.hi - b.lo < 0.5f * (g.hi - g.lo)) tight++;
        for (int q = 0; q < 20; q++) {
            float a = test_uniform(&seed, 0.0f, 1.0f), d = test_uniform(&seed, 0.0f, 1.0f);
            if (q < 4) a = (float)(q & 1), d = (float)(q >> 1); /* the corners */
            float ss = s0 + a * (s1 - s0), tt = t0 + d * (t1 - t0);
            float v = tex_bilinear(c, id, ss, tt).x;
            if (!(v >= b.lo && v <= b.hi))
                fail_msg("rect [%.9g %.9g] x [%.9g %.9g]: lookup at (%.9g %.9g) = %.9g outside "
                         "[%.9g %.9g]",
                         s0, s1, t0, t1, ss, tt, v, b.lo, b.hi);
        }
    }
    assert_true(tight > 50);
    scene_free(&s);
    /* On a ramp (texel value = its column) a rectangle spanning n columns gets a range of at
     * most about 4 n columns: the pyramid level is chosen by the rectangle's size. */
    path = write_texture("ramp.exr", 200, 64, 1, ramp_texel, 0u);
    memset(&s, 0, sizeof s);
    if (scene_add_texture(&s, path, TS_TEX_MINMAX, &id, &e)) fail_msg("%s", e.msg);
    c = scene_tex_ctx(&s);
    for (int r = 0; r < 1000; r++) {
        float size = powf(10.0f, test_uniform(&seed, -4.0f, -1.0f));
        float s0 = test_uniform(&seed, 0.05f, 0.8f), t0 = test_uniform(&seed, 0.1f, 0.9f);
        ts_interval b = tex_range(c, id, s0, t0, s0 + size, t0 + 0.01f);
        float cols = size * 200.0f + 2.0f;
        if (!(b.hi - b.lo <= 4.0f * cols + 1.0f))
            fail_msg("range %g for %g columns", b.hi - b.lo, cols);
        assert_true(b.lo <= s0 * 200.0f && b.hi >= (s0 + size) * 200.0f - 1.0f);
    }
    scene_free(&s);
}

/* Parses `text` (after the texture paths are put in) that must fail with a message
 * starting with `want`, strict as `--strict` (a missing texture is then an error too). */
static void expect_rib_error(const char *text, const char *want)
{
    ts_scene s;
    ts_error e;
    assert_int_not_equal(test_parse_rib_strict(text, &s, &e), TS_OK);
    if (strncmp(e.msg, want, strlen(want)) != 0)
        fail_msg("got \"%s\", want \"%s...\"", e.msg, want);
}

#define PLANE "Patch \"bilinear\" \"P\" [-1 -1 0 1 -1 0 -1 1 0 1 1 0]"

static void test_rib_requests(void **state)
{
    (void)state;
    const char *rgb = write_texture("q.exr", 64, 64, 3, quadrant_texel, 0u);
    char text[16384];
    /* Displacement "texture" and Surface texturename with "st": attributes with their ids. */
    snprintf(text, sizeof text,
             "WorldBegin\nDisplacement \"texture\" \"string texturename\" [\"%s\"] \"float "
             "amplitude\" [0.5] "
             "\"float offset\" [0.25]\nSurface \"plastic\" \"string texturename\" \"%s\"\n" PLANE
             " \"varying float[2] st\" [0 0 2 0 0 3 2 3]\nAttributeBegin\nDisplacement \"null\"\n"
             "Surface \"matte\"\n" PLANE "\nAttributeEnd\n" PLANE "\nWorldEnd\n",
             rgb, rgb);
    ts_scene s;
    test_parse_rib_ok(text, &s);
    assert_int_equal(s.patch_count, 3);
    assert_int_equal(s.texture_count, 2); /* one file, read as two kinds */
    const ts_patch_attr *a = &s.attr[0];
    assert_int_equal(a->disp_kind, TS_DISP_TEXTURE);
    assert_int_equal(s.textures[a->disp_tex].kind, TS_TEX_MINMAX);
    assert_true(a->flags & TS_PATCH_COLOR_TEX);
    assert_int_equal(s.textures[a->color_tex].kind, TS_TEX_RGB);
    assert_true(a->disp_amplitude == 0.5f && a->disp_offset == 0.25f);
    const float st[8] = {0, 0, 2, 0, 0, 3, 2, 3}, uv[8] = {0, 0, 1, 0, 0, 1, 1, 1};
    assert_memory_equal(a->st, st, sizeof st);
    assert_int_equal(s.attr[1].disp_kind, TS_DISP_NONE);
    assert_false(s.attr[1].flags & TS_PATCH_COLOR_TEX);
    assert_memory_equal(s.attr[1].st, uv, sizeof uv); /* default: the corners' (u, v) */
    assert_memory_equal(&s.attr[2], a, offsetof(ts_patch_attr, st)); /* restored */
    /* The top-level box holds the largest displacement the texture allows: first channel
     * in [0, 1], offset 0.25, amplitude 0.5: |d| <= 0.375 along +-z. */
    ts_box b = scene_patch_box(&s, 0);
    assert_float_equal(b.hi_z, 0.375f, 1e-5);
    assert_float_equal(b.lo_z, -0.375f, 1e-5);
    scene_free(&s);
    /* Colour of the quadrant texture at st: (s, t) = (0.25, 0.75) is the bottom-left
     * quadrant (rows from the top): blue. */
    snprintf(text, sizeof text, "Surface \"matte\" \"texturename\" \"%s\"\n" PLANE "\n", rgb);
    test_parse_rib_ok(text, &s);
    float cs[3];
    tex_surface_colour(&s.attr[0], scene_tex_ctx(&s), 0.25f, 0.75f, cs);
    assert_true(cs[0] == 0.0f && cs[1] == 0.0f && cs[2] == 1.0f);
    scene_free(&s);

    /* Errors: file:line:col of the file name, naming the texture. */
    expect_rib_error("WorldBegin\nDisplacement \"texture\" \"texturename\" \"no-such.exr\"\n",
                     "t.rib:2:38: error: Displacement: cannot read texture \"no-such.exr\": ");
    expect_rib_error("Surface \"matte\" \"Kd\" 0.5 \"texturename\" [\"no-such.png\"]\n",
                     "t.rib:1:40: error: Surface: cannot read texture \"no-such.png\": ");
    expect_rib_error("Displacement \"texture\" \"amplitude\" 1\n",
                     "t.rib:1:1: error: Displacement \"texture\": missing \"texturename\"");
    expect_rib_error("Displacement \"texture\" \"texturename\" 3\n",
                     "t.rib:1:38: error: Displacement: expected a texture file name");
    expect_rib_error(PLANE " \"vertex float[2] st\" [0 0 1 0 0 1 1 1]\n",
                     "t.rib:1:52: error: Patch: \"st\" of class vertex is not supported");
    expect_rib_error(PLANE " \"st\" [0 0 1 0 0 1]\n", "t.rib:1:57: error: ");
    /* A texel that is not a number. */
    float bad[4] = {0, NAN, 0, 0};
    ts_image img = {.width = 2, .height = 2, .channels = 1, .channel_names = NULL, .pixels = bad};
    ts_error e = {0};
    const char *nan_path = test_path_in(dir, "nan.exr");
    if (image_write_exr(nan_path, &img, NULL, 0, &e)) fail_msg("%s", e.msg);
    snprintf(text, sizeof text, "Displacement \"texture\" \"texturename\" \"%s\"\n", nan_path);
    char want[8192];
    snprintf(want, sizeof want, "t.rib:1:38: error: Displacement: cannot read texture \"");
    expect_rib_error(text, want);
    /* Not strict either: the file is there, it is no texture Tessera can use. */
    ts_scene s1;
    assert_int_equal(test_parse_rib(text, &s1, &e), TS_E_SCENE);
    assert_non_null(strstr(e.msg, "texel (1, 0) is not a finite number"));
    ts_scene s2 = {0};
    uint32_t id;
    assert_int_equal(scene_add_texture(&s2, nan_path, TS_TEX_MINMAX, &id, &e), TS_E_IO);
    assert_non_null(strstr(e.msg, "texel (1, 0) is not a finite number"));
    scene_free(&s2);
}

/* Fails unless `text` holds `part`. */
static void expect_in(const char *text, const char *part)
{
    if (!strstr(text, part)) fail_msg("\"%s\" not in \"%s\"", part, text);
}

/* A texture that is not there, not strict (RenderMan's way): one warning naming the file and
 * what the scene does without it, and the scene is exactly the one written without the
 * texture (Cs alone, no displacement); a domelight's missing map leaves a uniform sky. Strict
 * (--strict), each is the error at the file name's line and column. */
static void test_missing_texture(void **state)
{
    (void)state;
    const char *missing =
        "WorldBegin\n"
        "Displacement \"texture\" \"texturename\" \"no-such.exr\" \"amplitude\" 0.5\n"
        "Surface \"matte\" \"texturename\" [\"no-such.png\"]\n" PLANE "\n"
        "LightSource \"domelight\" 1 \"string mapname\" [\"no-sky.exr\"]\n"
        "WorldEnd\n";
    const char *without = "WorldBegin\nDisplacement \"null\"\nSurface \"matte\"\n" PLANE "\n"
                          "LightSource \"domelight\" 1\nWorldEnd\n";
    int rc;
    const char *w = test_rib_warnings(missing, &rc);
    assert_int_equal(rc, TS_OK);
    expect_in(w, "w.rib:2:38: warning: Displacement: cannot read texture \"no-such.exr\": ");
    expect_in(w, "No such file or directory; no displacement (--strict makes this an error)\n");
    expect_in(w, "w.rib:3:31: warning: Surface: cannot read texture \"no-such.png\": ");
    expect_in(w, "; rendered with Cs alone, untextured (--strict makes this an error)\n");
    expect_in(w, "w.rib:5:44: warning: LightSource: cannot read \"no-sky.exr\": No such file or "
                 "directory; a uniform sky of the light's colour (--strict makes this an "
                 "error)\n");
    ts_scene a, b;
    ts_error e;
    assert_int_equal(test_parse_rib(missing, &a, &e), TS_OK);
    assert_int_equal(test_parse_rib(without, &b, &e), TS_OK);
    assert_int_equal(a.patch_count, 1);
    assert_int_equal(a.patch_count, b.patch_count);
    assert_int_equal(a.texture_count, 0);
    assert_int_equal(a.attr[0].disp_kind, TS_DISP_NONE);
    assert_int_equal(a.attr[0].flags & TS_PATCH_COLOR_TEX, 0);
    assert_memory_equal(a.attr, b.attr, sizeof a.attr[0]);
    assert_memory_equal(a.cp, b.cp, 16 * sizeof a.cp[0]);
    assert_true(a.dome.present && a.dome.mapname[0] == '\0');
    assert_memory_equal(&a.dome, &b.dome, sizeof a.dome);
    scene_free(&a);
    scene_free(&b);
    assert_int_equal(test_parse_rib_strict(missing, &a, &e), TS_E_SCENE);
    expect_in(e.msg, "t.rib:2:38: error: Displacement: cannot read texture \"no-such.exr\": ");
    assert_int_equal(test_parse_rib_strict(strstr(missing, "Surface"), &a, &e), TS_E_SCENE);
    expect_in(e.msg, "t.rib:1:31: error: Surface: cannot read texture \"no-such.png\": ");
    assert_int_equal(test_parse_rib_strict(strstr(missing, "LightSource"), &a, &e), TS_E_SCENE);
    assert_string_equal(e.msg, "t.rib:1:44: error: LightSource: cannot read \"no-sky.exr\": No "
                               "such file or directory");
}

/* A flat patch facing the camera, filling the middle of a 64 x 64 image; the camera at
 * z = -5 looks down +z, so world +x is image right and +y image up. */
static void write_scene(const char *name, const char *attrs, double z)
{
    FILE *f = fopen(test_path_in(dir, name), "w");
    assert_non_null(f);
    fprintf(f,
            "Format 64 64 1\nProjection \"perspective\" \"fov\" [40]\nPixelSamples 1 1\n"
            "Translate 0 0 5\nWorldBegin\nLightSource \"domelight\" 1 \"intensity\" [1]\n%s\n"
            "Patch \"bilinear\" \"P\" [-1 -1 %g 1 -1 %g -1 1 %g 1 1 %g]\nWorldEnd\n",
            attrs, z, z, z, z);
    fclose(f);
}

static float channel_at(const ts_image *img, const char *name, int x, int y)
{
    for (int c = 0; c < img->channels; c++)
        if (strcmp(img->channel_names[c], name) == 0)
            return img->pixels[((size_t)y * img->width + x) * img->channels + c];
    fail_msg("no channel %s", name);
    return 0;
}

/* The albedo AOV at each quadrant of the patch is Kd Cs times the texture's quadrant:
 * (u, v) = (s, t) by default and t runs down the texture's rows, so the image's top-left
 * (u small, v large) shows the texture's bottom-left. */
static void test_render_colour(void **state)
{
    (void)state;
    write_texture("q.exr", 64, 64, 3, quadrant_texel, 0u);
    write_scene("colour.rib",
                "Color [0.5 1 1]\nSurface \"matte\" \"Kd\" 0.8 \"texturename\" \"q.exr\"", 0.0);
    test_tessera_ok(dir, "render '%s' -o '%s' --quiet", test_path_in(dir, "colour.rib"),
                    test_path_in(dir, "colour.exr"));
    ts_image img;
    test_read_image(test_path_in(dir, "colour.exr"), &img);
    /* The patch spans +-1 at distance 5 with 40 degrees across 64 pixels: +-17.6 pixels
     * around the centre; sample each quadrant's middle (+-9 pixels). */
    static const struct {
        int x, y;
        float r, g, b;
    } want[4] = {{23, 23, 0, 0, 1}, {41, 23, 1, 1, 1}, {23, 41, 1, 0, 0}, {41, 41, 0, 1, 0}};
    for (int k = 0; k < 4; k++) {
        float r = channel_at(&img, "albedo.R", want[k].x, want[k].y);
        float g = channel_at(&img, "albedo.G", want[k].x, want[k].y);
        float b = channel_at(&img, "albedo.B", want[k].x, want[k].y);
        if (fabsf(r - 0.8f * 0.5f * want[k].r) > 1e-5f || fabsf(g - 0.8f * want[k].g) > 1e-5f ||
            fabsf(b - 0.8f * want[k].b) > 1e-5f)
            fail_msg("pixel (%d %d): albedo %g %g %g", want[k].x, want[k].y, r, g, b);
    }
    /* Under a uniform dome of radiance 1 an unoccluded Lambertian plane reflects its
     * albedo, in every sample (the dome is found by cosine-weighted rays, each weighing
     * Kd Cs L exactly): every pixel of the middle of the blue quadrant is 0.8 to rounding. */
    for (int y = 19; y < 28; y++)
        for (int x = 19; x < 28; x++) {
            float b = channel_at(&img, "B", x, y);
            if (fabsf(b - 0.8f) > 1e-5f * 0.8f)
                fail_msg("pixel (%d %d): blue radiance %.7f, want Kd Cs L = 0.8", x, y, b);
        }
    assert_true(channel_at(&img, "R", 23, 23) == 0.0f);
    image_free(&img);
}

/* A constant displacement texture (0.75, offset 0.25, amplitude 0.4) moves the plane by
 * 0.2 along its normal (+z, away from the camera): the same depths as a plane at z = 0.2. */
static void test_render_constant_displacement(void **state)
{
    (void)state;
    write_texture("c.exr", 5, 3, 1, constant_texel, 0u);
    write_scene(
        "disp.rib",
        "Displacement \"texture\" \"texturename\" \"c.exr\" \"amplitude\" 0.4 \"offset\" 0.25",
        0.0);
    write_scene("moved.rib", "", 0.2);
    write_scene("flat.rib", "", 0.0);
    const char *names[3] = {"disp", "moved", "flat"};
    ts_image img[3];
    for (int k = 0; k < 3; k++) {
        char rib[64], exr[64];
        snprintf(rib, sizeof rib, "%s.rib", names[k]);
        snprintf(exr, sizeof exr, "%s.exr", names[k]);
        test_tessera_ok(dir, "render '%s' -o '%s' --spp 1 --quiet --stats '%s'",
                        test_path_in(dir, rib), test_path_in(dir, exr),
                        test_path_in(dir, "s.json"));
        test_read_image(test_path_in(dir, exr), &img[k]);
    }
    int covered = 0;
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++) {
            float zd = channel_at(&img[0], "Z", x, y), zm = channel_at(&img[1], "Z", x, y);
            float zf = channel_at(&img[2], "Z", x, y);
            if (!isfinite(zm)) continue;
            covered++;
            if (!(fabsf(zd - zm) < 1e-4f) || !(zd - zf > 0.19f && zd - zf < 0.21f))
                fail_msg("pixel (%d %d): Z %g, moved plane %g, flat %g", x, y, zd, zm, zf);
        }
    assert_true(covered > 900);
    for (int k = 0; k < 3; k++)
        image_free(&img[k]);
}

static float wave_texel(int x, int y, int c, uint32_t *seed)
{
    (void)seed;
    return 0.5f + 0.25f * sinf(0.11f * (float)x + (float)c) * cosf(0.07f * (float)y) +
           0.2f * sinf(0.031f * (float)(x + y));
}

/* Paging: with --memory 16 the tile pool (2 MiB, 128 tiles, raised to what the most
 * demanding patch needs) is smaller than the scene's 602 tiles, so tiles move in and out
 * per batch and per chunk of shaded paths; the image must be bit-identical to the one
 * rendered with every tile resident. */
static void test_render_paged(void **state)
{
    (void)state;
    write_texture("h512.exr", 512, 512, 1, wave_texel, 0u);
    write_texture("c512.exr", 512, 512, 3, wave_texel, 0u);
    FILE *f = fopen(test_path_in(dir, "paged.rib"), "w");
    assert_non_null(f);
    fprintf(
        f, "Format 64 36 1\nProjection \"perspective\" \"fov\" [30]\n"
           "LightSource \"distantlight\" 1 \"intensity\" [2] \"from\" [1.5 1 -0.4] \"to\" [0 0 0]\n"
           "Translate 0 0 8.5\nRotate -130 1 0 0\nRotate 25 0 0 1\nWorldBegin\n"
           "Surface \"matte\" \"texturename\" \"c512.exr\"\n"
           "Displacement \"texture\" \"texturename\" \"h512.exr\" \"amplitude\" 0.2\n"
           "PatchMesh \"bilinear\" 5 \"nonperiodic\" 5 \"nonperiodic\" \"P\" [");
    for (int j = 0; j < 5; j++)
        for (int i = 0; i < 5; i++)
            fprintf(f, " %d %d 0", i - 2, j - 2);
    fprintf(f, "] \"st\" [");
    for (int j = 0; j < 5; j++)
        for (int i = 0; i < 5; i++)
            fprintf(f, " %g %g", 0.5 * i, 2 - 0.5 * j);
    fprintf(f, "]\nWorldEnd\n");
    fclose(f);
    const char *mem[2] = {"256", "16"};
    ts_image img[2];
    double pool[2], tiles[2], up[2], bytes[2];
    for (int k = 0; k < 2; k++) {
        char exr[32], json[32];
        snprintf(exr, sizeof exr, "paged%d.exr", k);
        snprintf(json, sizeof json, "paged%d.json", k);
        test_tessera_ok(dir, "render '%s' -o '%s' --spp 1 --memory %s --quiet --stats '%s'",
                        test_path_in(dir, "paged.rib"), test_path_in(dir, exr), mem[k],
                        test_path_in(dir, json));
        test_read_image(test_path_in(dir, exr), &img[k]);
        const char *js = test_path_in(dir, json);
        pool[k] = test_stats_number(js, "counters.texture_pool_tiles");
        tiles[k] = test_stats_number(js, "counters.texture_tiles");
        up[k] = test_stats_number(js, "counters.texture_tiles_uploaded");
        bytes[k] = test_stats_number(js, "counters.texture_bytes_uploaded");
    }
    /* 512^2 displacement with its pyramid: 256 + 64 + 16 + 4 + 1 + 1 + 1 + 1 + 1 + 1 tiles;
     * colour: 256. */
    assert_true(tiles[0] == 602 && tiles[1] == 602);
    assert_true(pool[0] == 602 && up[0] == 602); /* all resident, uploaded once */
    assert_true(pool[1] < 602 && pool[1] >= 128);
    assert_true(up[1] > 0 && bytes[1] == up[1] * 32 * 32 * 16);
    assert_int_equal(img[0].width * img[0].height * img[0].channels,
                     img[1].width * img[1].height * img[1].channels);
    size_t n = (size_t)img[0].width * img[0].height * img[0].channels;
    int lit = 0;
    for (size_t i = 0; i < n; i++) {
        if (memcmp(&img[0].pixels[i], &img[1].pixels[i], sizeof(float)) != 0)
            fail_msg("value %zu (channel %s): %g resident, %g paged", i,
                     img[0].channel_names[i % img[0].channels], img[0].pixels[i], img[1].pixels[i]);
        lit += img[0].pixels[i] > 0.0f && isfinite(img[0].pixels[i]);
    }
    assert_true(lit > 1000);
    for (int k = 0; k < 2; k++)
        image_free(&img[k]);
}

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "%s", test_scratch_dir());
    return 0;
}

int main(void)
{
    const struct CMUnitTest host[] = {
        cmocka_unit_test(test_pyramid),
        cmocka_unit_test(test_range_conservative),
        cmocka_unit_test(test_rib_requests),
        cmocka_unit_test(test_missing_texture),
    };
    const struct CMUnitTest device[] = {
        cmocka_unit_test(test_render_colour),
        cmocka_unit_test(test_render_constant_displacement),
        cmocka_unit_test(test_render_paged),
    };
    int rc = cmocka_run_group_tests(host, setup, NULL);
    if (rc) return rc;
    return TEST_RUN_WITH_DEVICE(device, setup);
}
