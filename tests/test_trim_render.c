/* test_trim_render.c — trimmed NURBS (TrimCurve) through the whole renderer, against areas
 * known in closed form: a constant-coloured unit square facing an orthographic camera,
 * trimmed to a ring (a circle of radius 0.4 with a hole of radius 0.15, a rational quadratic
 * each), covers pi (0.4^2 - 0.15^2) of the square's pixels in both geometry modes (boxes and
 * triangles) within the pixels along the two circles; and under a distant light straight
 * above, the same ring as an occluder lets the light through its hole and around it, so the
 * floor below is lit exactly where the ring is not (the same count); as an area light the
 * ring lights a floor alike by light and by BSDF sampling. Needs an OpenCL device
 * (skipped, 77, without one); the host side: tests/test_trim.c. */
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

enum { N = 96 }; /* pixels a side; the square fills the frame */

/* The ring's TrimCurve: two loops of one rational quadratic circle each, of radii 0.4 and
 * 0.15 about (0.5, 0.5) of the unit square; the u, v and w arrays concatenate the loops. */
static void ring_trim(char *out, size_t cap)
{
    static const double x[9] = {1, 1, 0, -1, -1, -1, 0, 1, 1},
                        y[9] = {0, 1, 1, 1, 0, -1, -1, -1, 0};
    static const double radius[2] = {0.4, 0.15};
    const char *knots = "0 0 0 .25 .25 .5 .5 .75 .75 1 1 1";
    int n = snprintf(out, cap, "TrimCurve [1 1] [3 3] [%s %s] [0 0] [1 1] [9 9]", knots, knots);
    for (int a = 0; a < 3; a++) {
        n += snprintf(out + n, cap - (size_t)n, " [");
        for (int l = 0; l < 2; l++)
            for (int k = 0; k < 9; k++) {
                double w = k % 2 ? sqrt(0.5) : 1.0;
                double c = 0.5 + radius[l] * (a == 0 ? x[k] : y[k]);
                n += snprintf(out + n, cap - (size_t)n, "%.17g ", a == 2 ? w : c * w);
            }
        n += snprintf(out + n, cap - (size_t)n, "]");
    }
    snprintf(out + n, cap - (size_t)n, "\n");
}

/* Renders text and counts the pixels whose channel `ch` is above half. */
static int count_bright(const char *text, const char *opts, const char *ch)
{
    test_write_text(test_path_in(dir, "ring.rib"), text);
    test_tessera_ok(dir, "render '%s' -o '%s' --quiet --spp 1 %s", test_path_in(dir, "ring.rib"),
                    test_path_in(dir, "ring.exr"), opts);
    ts_image img;
    test_read_image(test_path_in(dir, "ring.exr"), &img);
    int c = -1, n = 0;
    for (int k = 0; k < img.channels; k++)
        if (strcmp(img.channel_names[k], ch) == 0) c = k;
    assert_true(c >= 0);
    assert_int_equal(img.width * img.height, N * N);
    for (int i = 0; i < N * N; i++)
        n += img.pixels[(size_t)i * img.channels + c] > 0.5f;
    image_free(&img);
    return n;
}

static const char *quad =
    "NuPatch 2 2 [0 0 1 1] 0 1 2 2 [0 0 1 1] 0 1 \"P\" [-1 -1 0  1 -1 0  -1 1 0  1 1 0]\n";

/* The ring's area in pixels, and the slack: a pixel along either circle either way. */
static void expect_ring(int n)
{
    double area = M_PI * (0.16 - 0.0225) * N * N, edge = 2.0 * M_PI * (0.4 + 0.15) * N;
    if (!(fabs(n - area) <= edge))
        fail_msg("%d pixels, the ring covers %.1f (within %.1f)", n, area, edge);
}

static void test_ring_coverage(void **state)
{
    (void)state;
    char trim[4096], text[8192];
    ring_trim(trim, sizeof trim);
    const char *fmt = "Format %d %d 1\nProjection \"orthographic\"\nScreenWindow -1 1 -1 1\n"
                      "Translate 0 0 5\nWorldBegin\nSurface \"constant\"\nColor [1 1 1]\n%s%s"
                      "WorldEnd\n";
    snprintf(text, sizeof text, fmt, N, N, trim, quad);
    int boxes = count_bright(text, "", "R"),
        tris = count_bright(text, "--intersect triangles", "R");
    expect_ring(boxes);
    expect_ring(tris);
    snprintf(text, sizeof text, fmt, N, N, "", quad); /* without the trim: the whole square */
    assert_int_equal(count_bright(text, "", "R"), N * N);
}

/* A matte floor at z = 0 and the trimmed square 1 nearer the camera (which looks down +z),
 * lit by a distant light shining along +z. The camera does not see the ring (Attribute
 * "visibility" "camera" 0), so every pixel shows the floor, lit but where the ring's shadow
 * falls straight behind it: the dark pixels are the ring's. */
static void test_ring_shadow(void **state)
{
    (void)state;
    char trim[4096], text[8192];
    ring_trim(trim, sizeof trim);
    snprintf(text, sizeof text,
             "Format %d %d 1\nProjection \"orthographic\"\nScreenWindow -1 1 -1 1\n"
             "Translate 0 0 5\nWorldBegin\n"
             "LightSource \"distantlight\" 1 \"intensity\" [3] \"from\" [0 0 0] \"to\" [0 0 1]\n"
             "AttributeBegin\nAttribute \"visibility\" \"int camera\" [0]\nTranslate 0 0 -1\n"
             "%s%sAttributeEnd\n"
             "Patch \"bilinear\" \"P\" [-1 -1 0  1 -1 0  -1 1 0  1 1 0]\nWorldEnd\n",
             N, N, trim, quad);
    int lit = count_bright(text, "--depth 1", "G");
    expect_ring(N * N - lit);
}

/* The mean red of a matte floor lit only by the unit square (trimmed to the ring or not) as an
 * area light 1 above it, unseen by the camera, under --sampling `sampling`. */
static double floor_mean(int trimmed, const char *sampling)
{
    char trim[4096], text[8192];
    ring_trim(trim, sizeof trim);
    snprintf(text, sizeof text,
             "Format 16 16 1\nProjection \"orthographic\"\nScreenWindow -2 2 -2 2\n"
             "Translate 0 0 5\nWorldBegin\nAttributeBegin\n"
             "Attribute \"visibility\" \"int camera\" [0]\n"
             "AreaLightSource \"arealight\" 1 \"intensity\" [4]\nTranslate 0 0 -1\n%s%s"
             "AttributeEnd\nPatch \"bilinear\" \"P\" [-2 -2 0  2 -2 0  -2 2 0  2 2 0]\n"
             "WorldEnd\n",
             trimmed ? trim : "", quad);
    test_write_text(test_path_in(dir, "lit.rib"), text);
    /* --lod 6: the ring's micro-quads (what BSDF rays meet) follow its curves to 1/64 of the
     * square; unseen by the camera, it would be diced at m = 3 (8 x 8 micro-quads), whose
     * centres keep 10% more of it than the curves do (light sampling tests the curves) */
    test_tessera_ok(dir, "render '%s' -o '%s' --quiet --spp 256 --depth 1 --lod 6 --sampling %s",
                    test_path_in(dir, "lit.rib"), test_path_in(dir, "lit.exr"), sampling);
    ts_image img;
    test_read_image(test_path_in(dir, "lit.exr"), &img);
    double sum = 0.0;
    for (int i = 0; i < img.width * img.height; i++)
        sum += img.pixels[(size_t)i * img.channels];
    double mean = sum / (img.width * img.height);
    image_free(&img);
    return mean;
}

/* A trimmed emitter gives the light of what is left of it: light sampling (whose samples on
 * the removed part give nothing) agrees with BSDF sampling (whose rays meet the ring as
 * trimmed), and both are well below the whole square's. */
static void test_trimmed_emitter(void **state)
{
    (void)state;
    double light = floor_mean(1, "light"), bsdf = floor_mean(1, "bsdf");
    double whole = floor_mean(0, "light");
    if (!(fabs(light - bsdf) <= 0.05 * bsdf))
        fail_msg("the ring lights the floor %g by light sampling, %g by BSDF sampling", light,
                 bsdf);
    if (!(light > 0.25 * whole && light < 0.65 * whole))
        fail_msg("the ring gives %g of the whole square's %g", light, whole);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ring_coverage),
        cmocka_unit_test(test_ring_shadow),
        cmocka_unit_test(test_trimmed_emitter),
    };
    return TEST_RUN_WITH_DEVICE(tests, setup);
}
