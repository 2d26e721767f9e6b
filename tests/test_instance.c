/* test_instance.c — instances that share their master's dicing (ObjectInstance,
 * host/scene/instance.c, docs/rib.md "Objects"):
 * - which instance patches share: rigid instances of a displaced object do, patch for patch
 *   with the first instance as master; a scaled instance, a mirrored one and one moving
 *   differently from its master stay copies; instances moving like their master share;
 * - the scene packed for other ranks keeps the sharing;
 * - scene/instances_displaced.rib (36 turned instances of the displaced teapot) renders like
 *   the same teapots written out in full, and dices each of its master patches once where
 *   the copies dice every patch: patches_diced = the patches diced as themselves, exactly,
 *   and the arenas' peak a 36th or less;
 * - images, each render against its copies' with the same --seed and the noise measured by
 *   the copies' render with another: the depth (Z) is the copies' at all but a few pixels
 *   (micro-triangles at a fixed m and translated instances: the same, rounding of the moved
 *   ray aside; turned leaf boxes in box mode: within a pixel of the copies' around it), and
 *   the mean colour within four standard deviations of that noise, per 16 x 16 block where
 *   the leaf boxes are the same and over the image where they are turned (the master's
 *   axes, turned, shadow otherwise per block);
 * - a moving object instanced twice, and its copies, render alike in the same sense;
 * - two devices give the one-device image bit for bit (the levels device 0 picks, one m per
 *   master, reach the other).
 * The image checks need an OpenCL device (skipped, 77, without one). */
#include "test_support.h"
#include "image/image.h"
#include "scene/scene.h"
#include "scene/scene_pack.h"

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

/* The whole text of a file of the source tree (malloc'd). */
static char *read_source(const char *rel)
{
    FILE *f = fopen(test_source_path(rel), "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *text = malloc((size_t)n + 1);
    assert_non_null(text);
    assert_int_equal(fread(text, 1, (size_t)n, f), (size_t)n);
    text[n] = '\0';
    fclose(f);
    return text;
}

/* text with every `ObjectInstance "name"` line replaced by the object's requests in an
 * attribute block (what ObjectInstance runs), and the definition removed: the scene written
 * out in full (malloc'd). The definition is `ObjectBegin "name"\n ... ObjectEnd\n`. */
static char *written_out(const char *text, const char *name)
{
    char begin[256], use[256];
    snprintf(begin, sizeof begin, "ObjectBegin \"%s\"\n", name);
    snprintf(use, sizeof use, "ObjectInstance \"%s\"\n", name);
    const char *b = strstr(text, begin), *e = b ? strstr(b, "ObjectEnd\n") : NULL;
    assert_true(b && e);
    size_t body_len = (size_t)(e - b) - strlen(begin);
    char body[4096];
    assert_true(body_len + 40 < sizeof body);
    snprintf(body, sizeof body, "AttributeBegin\n%.*sAttributeEnd\n", (int)body_len,
             b + strlen(begin));
    size_t cap = strlen(text) * 2 + 64 * strlen(body), n = 0;
    char *out = malloc(cap);
    assert_non_null(out);
    for (const char *at = text; *at;) {
        if (at == b) { /* skip the definition */
            at = e + strlen("ObjectEnd\n");
            continue;
        }
        if (strncmp(at, use, strlen(use)) == 0) {
            n += (size_t)snprintf(out + n, cap - n, "%s", body);
            at += strlen(use);
            continue;
        }
        assert_true(n + 1 < cap);
        out[n++] = *at++;
    }
    out[n] = '\0';
    return out;
}

/* Patches that share another's dicing. */
static uint32_t shared_count(const ts_scene *s)
{
    uint32_t n = 0;
    for (uint32_t p = 0; s->shape && p < s->patch_count; p++)
        n += s->shape[p] != p;
    return n;
}

/* The object (the displaced teapot: 32 patches) placed five ways; the first is the master. */
#define TEAPOT_OBJECT                                                                              \
    "WorldBegin\nObjectBegin 1\nScale 0.3 0.3 0.3\nDisplacement \"fbm\" \"amplitude\" [0.1]\n"     \
    "Geometry \"teapot\"\nObjectEnd\n"

/* Rigid instances share, patch for patch; scaled, mirrored and differently moving ones do
 * not. */
static void test_which_instances_share(void **state)
{
    (void)state;
    static const char *const place[5] = {
        "Translate -2 0 0\n",                     /* the master */
        "Translate 0 0 1\nRotate 50 0.3 0.2 1\n", /* rigid: shares */
        "Translate 2 0 0\nScale 1.1 1.1 1.1\n",   /* scaled: a copy */
        "Translate 0 2 0\nScale -1 1 1\n",        /* mirrored: its normals flip, a copy */
        "MotionBegin [0 1]\nTranslate 0 -2 0\nTranslate 0.3 -2 0\nMotionEnd\n", /* moves */
    };
    char text[4096];
    int n = snprintf(text, sizeof text, TEAPOT_OBJECT);
    for (int k = 0; k < 5; k++)
        n += snprintf(text + n, sizeof text - n,
                      "AttributeBegin\n%sObjectInstance 1\nAttributeEnd\n", place[k]);
    snprintf(text + n, sizeof text - n, "WorldEnd\n");
    ts_scene s;
    test_parse_rib_ok(text, &s);
    assert_int_equal(s.patch_count, 5 * 32);
    assert_non_null(s.shape);
    for (uint32_t p = 0; p < s.patch_count; p++) {
        uint32_t want = p >= 32 && p < 64 ? p - 32 : p;
        if (s.shape[p] != want) fail_msg("patch %u: shape %u, want %u", p, s.shape[p], want);
        assert_true(want == p ? s.instance[p] == TS_INVALID : s.instance[p] < s.inst_xform_count);
    }
    assert_int_equal(s.inst_xform_count, 1);
    /* The map moves the instance's points onto the master's. */
    const ts_xform *x = &s.inst_xform[s.instance[40]];
    const ts_vec4 *c = &s.cp[40 * 16 + 5], *m = &s.cp[8 * 16 + 5];
    float mx = x->r0[0] * c->x + x->r0[1] * c->y + x->r0[2] * c->z + x->r0[3];
    float my = x->r1[0] * c->x + x->r1[1] * c->y + x->r1[2] * c->z + x->r1[3];
    assert_true(fabsf(mx - m->x) < 1e-5f && fabsf(my - m->y) < 1e-5f);
    /* Packed for other ranks, the sharing comes back as it was. */
    void *block;
    size_t size;
    ts_error err = {0};
    ts_scene u;
    if (scene_pack(&s, &block, &size, &err) || scene_unpack(block, size, &u, &err))
        fail_msg("%s", err.msg);
    assert_memory_equal(u.shape, s.shape, s.patch_count * sizeof *s.shape);
    assert_memory_equal(u.instance, s.instance, s.patch_count * sizeof *s.instance);
    assert_memory_equal(u.inst_xform, s.inst_xform, s.inst_xform_count * sizeof *s.inst_xform);
    free(block);
    scene_free(&u);
    scene_free(&s);
    /* An object without displacement shares as well; a scene without objects shares nothing
     * (no tables at all: every patch is diced as itself, as before instancing). */
    test_parse_rib_ok("WorldBegin\nObjectBegin 2\nSphere 1 -1 1 360\nObjectEnd\n"
                      "ObjectInstance 2\nTranslate 3 0 0\nRotate 30 0 1 0\nObjectInstance 2\n"
                      "WorldEnd\n",
                      &s);
    assert_true(s.patch_count > 0 && shared_count(&s) == s.patch_count / 2);
    scene_free(&s);
    test_parse_rib_ok("WorldBegin\nSphere 1 -1 1 360\nWorldEnd\n", &s);
    assert_null(s.shape);
    assert_null(s.instance);
    scene_free(&s);
}

/* A master that moves, and an instance moving the same way elsewhere: they share (both time
 * samples map onto the master's by one map); an instance of it that stands still does not,
 * nor would one whose motion is not the master's under that map (a turned instance moved
 * along the same world vector). */
static const char moving_scene[] =
    "Format 64 48 1\nProjection \"perspective\" \"fov\" [40]\nTranslate 0 -0.5 7\n"
    "Rotate -100 1 0 0\nWorldBegin\nLightSource \"distantlight\" 1 \"from\" [1 -2 3] "
    "\"to\" [0 0 0]\nLightSource \"domelight\" 2 \"intensity\" [0.3]\n"
    "Patch \"bilinear\" \"P\" [-6 -6 0  6 -6 0  -6 6 0  6 6 0]\n"
    "ObjectBegin \"spinner\"\nTranslate 0 0 0.5\nScale 0.25 0.25 0.25\n"
    "Displacement \"fbm\" \"amplitude\" [0.1] \"frequency\" [3]\nGeometry \"teapot\"\n"
    "ObjectEnd\n"
    "AttributeBegin\nMotionBegin [0 1]\nTranslate -1.2 0 0\nTranslate -0.9 0.2 0\nMotionEnd\n"
    "ObjectInstance \"spinner\"\nAttributeEnd\n"
    "AttributeBegin\nTranslate 2.4 0 0\nMotionBegin [0 1]\nTranslate -1.2 0 0\n"
    "Translate -0.9 0.2 0\nMotionEnd\nObjectInstance \"spinner\"\nAttributeEnd\n"
    "AttributeBegin\nTranslate 0 1.5 0\nObjectInstance \"spinner\"\nAttributeEnd\n"
    "WorldEnd\n";

static void test_moving_instances_share(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok(moving_scene, &s);
    assert_int_equal(s.patch_count, 1 + 3 * 32);
    for (uint32_t p = 33; p < 65; p++)
        assert_int_equal(s.shape[p], p - 32);
    for (uint32_t p = 65; p < 97; p++)
        assert_int_equal(s.shape[p], p);
    assert_true(s.attr[40].flags & TS_PATCH_MOVING);
    scene_free(&s);
}

/* ---- images ------------------------------------------------------------------------------ */

/* The channel named `name` of pixel i. */
static float channel(const ts_image *img, int i, const char *name)
{
    for (int c = 0; c < img->channels; c++)
        if (strcmp(img->channel_names[c], name) == 0)
            return img->pixels[(size_t)i * img->channels + c];
    fail_msg("no channel %s", name);
    return 0.0f;
}

/* R + G + B of pixel i. */
static double rgb_sum(const ts_image *img, int i)
{
    return channel(img, i, "R") + channel(img, i, "G") + channel(img, i, "B");
}

/* Whether pixel i's depth in a is within `slack` (absolute) of the range of b's depths over
 * the 3 x 3 pixels around i (both missing, or a miss where one of those misses, agree). */
static int depth_near(const ts_image *a, const ts_image *b, int i, double slack)
{
    int w = b->width, h = b->height, x = i % w, y = i / w;
    double za = channel(a, i, "Z"), lo = INFINITY, hi = -INFINITY;
    for (int yy = y > 0 ? y - 1 : y; yy <= y + 1 && yy < h; yy++)
        for (int xx = x > 0 ? x - 1 : x; xx <= x + 1 && xx < w; xx++) {
            double z = channel(b, yy * w + xx, "Z");
            lo = fmin(lo, z), hi = fmax(hi, z);
        }
    if (isinf(za)) return isinf(hi);
    return za >= lo - slack && za <= hi + slack;
}

/* Whether pixel i has the same depth in a and b: relative 1e-4, or both missing. */
static int depth_same(const ts_image *a, const ts_image *b, int i)
{
    float za = channel(a, i, "Z"), zb = channel(b, i, "Z");
    if (isinf(za) || isinf(zb)) return za == zb;
    return fabsf(za - zb) <= 1e-4f * (1.0f + fabsf(zb));
}

/* Whether pixel i's first hit is on the same surface in a and b: both miss, or their
 * depths differ by at most a pixel's width there (z * pixel_angle), the size of a leaf box
 * at the frame's level of detail (docs/rendering.md: a micro-quad about a pixel across). */
static int same_surface(const ts_image *a, const ts_image *b, int i, double pixel_angle)
{
    float za = channel(a, i, "Z"), zb = channel(b, i, "Z");
    if (isinf(za) || isinf(zb)) return za == zb;
    return fabs(za - zb) <= pixel_angle * zb;
}

/* The two-seed bound (STYLE 17: a tolerance from the samples) on the mean R + G + B of the
 * pixels of a rectangle [x0, x1) x [y0, y1) whose first hit is on the same surface in `inst`
 * and `full` (a pixel whose hit moved to another surface, at a silhouette, may take any
 * colour; how many moved is the depth check's). `full` and `inst` are rendered with one seed,
 * `other` is `full` with another. Pixels are independent across pixels and seeds, so
 * sum_i (full_i - other_i)^2 / 2 / n^2 estimates the variance of the mean of n pixels; two
 * independent renders of the same image would differ by its square root times sqrt(2), and
 * inst and full share their random numbers, so theirs is smaller still. Allowed: 4 of those
 * standard deviations (a false failure in ~1 of 15000 rectangles) plus 1e-4 of the mean
 * (float rounding where there is no noise: the sky, the unshadowed floor). Returns
 * |difference| / allowance (<= 1 passes). */
static double mean_ratio(const ts_image *inst, const ts_image *full, const ts_image *other,
                         double pixel_angle, int x0, int y0, int x1, int y1)
{
    double si = 0, sf = 0, d2 = 0, n = 0;
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++) {
            int i = y * full->width + x;
            if (!same_surface(inst, full, i, pixel_angle)) continue;
            double vf = rgb_sum(full, i), vo = rgb_sum(other, i);
            si += rgb_sum(inst, i), sf += vf, d2 += (vf - vo) * (vf - vo), n++;
        }
    if (2 * n < (double)(x1 - x0) * (y1 - y0))
        fail_msg("(%d, %d)-(%d, %d): %g pixels on the same surface", x0, y0, x1, y1, n);
    double mi = si / n, mf = sf / n, var_mean = d2 / 2.0 / (n * n);
    return fabs(mi - mf) / (4.0 * sqrt(2.0 * var_mean) + 1e-4 * fabs(mf) + 1e-6);
}

/* Whether each 16 x 16 block is checked, or the whole image only. */
enum { WHOLE_IMAGE, EVERY_BLOCK };

/* The image's ratio by mean_ratio, and with EVERY_BLOCK the largest of its 16 x 16 blocks'. */
static double image_ratio(const ts_image *inst, const ts_image *full, const ts_image *other,
                          double pixel_angle, int blocks)
{
    double worst = mean_ratio(inst, full, other, pixel_angle, 0, 0, full->width, full->height);
    for (int by = 0; blocks && by + 16 <= full->height; by += 16)
        for (int bx = 0; bx + 16 <= full->width; bx += 16)
            worst =
                fmax(worst, mean_ratio(inst, full, other, pixel_angle, bx, by, bx + 16, by + 16));
    return worst;
}

/* Renders inst.rib and full.rib with `opts` and --seed 1, and full.rib with --seed 2 for the
 * noise, and checks the images: the means by the two-seed bound above (`blocks`: each block's
 * as well as the image's), and the depth (Z: sample 0's first hit, the same ray in both
 * renders) at all but `max_depth_frac` of the pixels: the same (relative 1e-4) where
 * `same_depth` (micro-triangles at a fixed m, or leaf boxes of instances only translated: the
 * same surface, rounding aside), else within a pixel's width of the depths of the 3 x 3
 * pixels around it in full (leaf boxes about a pixel across, turned: a hit moves by about a
 * pixel at most). pixel_angle: the angle a pixel spans (radians). */
static void compare_renders(const char *opts, double pixel_angle, int same_depth, int blocks,
                            double max_depth_frac)
{
    test_tessera_ok(dir, "render '%s' -o '%s' --quiet --seed 1 --stats '%s' %s", path("inst.rib"),
                    path("inst.exr"), path("inst.json"), opts);
    test_tessera_ok(dir, "render '%s' -o '%s' --quiet --seed 1 --stats '%s' %s", path("full.rib"),
                    path("full.exr"), path("full.json"), opts);
    test_tessera_ok(dir, "render '%s' -o '%s' --quiet --seed 2 %s", path("full.rib"),
                    path("other.exr"), opts);
    ts_image a, b, c;
    test_read_image(path("inst.exr"), &a);
    test_read_image(path("full.exr"), &b);
    test_read_image(path("other.exr"), &c);
    assert_int_equal(a.width, b.width);
    assert_int_equal(c.width, b.width);
    int n = a.width * a.height, differ = 0;
    for (int i = 0; i < n; i++) {
        double z = channel(&b, i, "Z");
        differ += same_depth ? !depth_same(&a, &b, i)
                             : !depth_near(&a, &b, i, pixel_angle * (isinf(z) ? 0.0 : z));
    }
    double ratio = image_ratio(&a, &b, &c, pixel_angle, blocks);
    print_message("[ instance ] %s: depth off at %d of %d pixels, mean %.3f of its allowance "
                  "at worst\n",
                  opts, differ, n, ratio);
    if (differ > max_depth_frac * n) fail_msg("%s: depth off at %d of %d pixels", opts, differ, n);
    if (ratio > 1.0) fail_msg("%s: a mean is %.2f of its allowance away", opts, ratio);
    image_free(&a);
    image_free(&b);
    image_free(&c);
}

/* The angle a pixel spans: 2 tan(fov / 2) / the shorter side (host/app/render.c). */
#define PIXEL_INST (2.0 * tan(19.0 * M_PI / 180.0) / 112.0)  /* fov 38, 192x112 */
#define PIXEL_MOVING (2.0 * tan(20.0 * M_PI / 180.0) / 48.0) /* fov 40, 64x48 */

/* scene/instances_displaced.rib against its teapots written out in full. */
static void test_displaced_instances_render(void **state)
{
    (void)state;
    char *text = read_source("scene/instances_displaced.rib");
    char *full = written_out(text, "rough teapot");
    write_scene("inst.rib", text);
    write_scene("full.rib", full);
    ts_scene s;
    test_parse_rib_ok(text, &s);
    uint32_t own = s.patch_count - shared_count(&s);
    assert_int_equal(shared_count(&s), 35 * 32);
    scene_free(&s);
    /* Micro-triangles at m = 4: the diced surfaces themselves. */
    compare_renders("--res 192x112 --spp 4 --lod 4 --intersect triangles", PIXEL_INST, 1,
                    EVERY_BLOCK, 0.005);
    assert_int_equal(test_stats_number(path("inst.json"), "counters.patches_diced"), own);
    assert_int_equal(test_stats_number(path("full.json"), "counters.patches_diced"), own + 35 * 32);
    double peak_inst = test_stats_number(path("inst.json"), "counters.patch_cache_peak_bytes");
    double peak_full = test_stats_number(path("full.json"), "counters.patch_cache_peak_bytes");
    assert_true(peak_inst > 0 && peak_inst * 30 < peak_full);
    /* The default: leaf boxes as geometry, m per patch from the frame (one m for a master and
     * its instances, the finest they ask for). */
    /* Per block the turned leaf boxes shadow otherwise than the copies' (up to 6% of a
     * block's mean, of either sign): the image's mean is checked, and the depth. */
    compare_renders("--res 192x112 --spp 8", PIXEL_INST, 0, WHOLE_IMAGE, 0.005);
    assert_int_equal(test_stats_number(path("inst.json"), "counters.patches_diced"), own);
    free(full);
    free(text);
}

/* Moving instances, shared and not, against their copies. */
static void test_moving_instances_render(void **state)
{
    (void)state;
    char *full = written_out(moving_scene, "spinner");
    write_scene("inst.rib", moving_scene);
    write_scene("full.rib", full);
    compare_renders("--spp 8 --lod 4 --intersect triangles", PIXEL_MOVING, 1, EVERY_BLOCK, 0.01);
    /* The instances are translated, not turned: the same leaf boxes. */
    compare_renders("--spp 8", PIXEL_MOVING, 1, EVERY_BLOCK, 0.01);
    free(full);
}

/* Two devices (PoCL's pthread device twice) render the instanced scene's bits: those of
 * the first alone. Skipped where there are not two (an OpenCL of a GPU driver alone). */
static void test_two_devices_same_bits(void **state)
{
    (void)state;
    char pair[32];
    if (test_pocl_devices(pair, sizeof pair, 2) < 2)
        test_skip("two devices of PoCL's pthread driver are needed");
    char *text = read_source("scene/instances_displaced.rib");
    write_scene("inst.rib", text);
    free(text);
    setenv("POCL_DEVICES", "pthread pthread", 1);
    test_tessera_ok(dir, "render '%s' -o '%s' --quiet --res 96x54 --spp 2 --device %d",
                    path("inst.rib"), path("one.exr"), atoi(pair));
    test_tessera_ok(dir, "render '%s' -o '%s' --quiet --res 96x54 --spp 2 --device %s",
                    path("inst.rib"), path("two.exr"), pair);
    unsetenv("POCL_DEVICES");
    test_assert_same_pixels(path("one.exr"), path("two.exr"));
}

int main(void)
{
    const struct CMUnitTest host[] = {
        cmocka_unit_test(test_which_instances_share),
        cmocka_unit_test(test_moving_instances_share),
    };
    int rc = cmocka_run_group_tests_name("host", host, NULL, NULL);
    const struct CMUnitTest device[] = {
        cmocka_unit_test(test_displaced_instances_render),
        cmocka_unit_test(test_moving_instances_render),
        cmocka_unit_test(test_two_devices_same_bits),
    };
    int rd = TEST_RUN_WITH_DEVICE(device, setup);
    return rc ? rc : rd;
}
