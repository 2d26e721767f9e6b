/* test_pathtrace.c — the path tracer against results known in closed form (issue 5):
 * - furnace: a closed white matte object (Kd 1, Color 1) under a uniform domelight of
 *   radiance 1 reflects radiance 1 everywhere, seen from outside; also when displaced
 *   (non-convex: interreflections);
 * - a diffuse plane under a sun at angle theta has radiance Kd E cos(theta) / pi, and under
 *   a uniform dome Kd L in every sample (cosine-weighted dome sampling);
 * - light sampling, BSDF sampling and their MIS combination converge to the same mean;
 * - the same command gives the same bits, whatever --memory or the thread count;
 * - shadow rays are counted apart;
 * - a plane under RenderMan's pointlight and spotlight has radiance Kd / pi times their
 *   irradiance I cos / d^2 (times the spot's beam and edge) in every pixel; with a sun and
 *   ambient light too, chosen one per vertex by weight, the image mean is the sum;
 * - ambientlight lights surfaces like a uniform dome (Kd L) and leaves the background black.
 * Tolerances come from the sample counts. */
#include "test_support.h"
#include "image/image.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static char dir[4096];

static int setup(void **state)
{
    snprintf(dir, sizeof dir, "%s", test_scratch_dir());
    return 0;
}

static const char *path(const char *name)
{
    return test_path_in(dir, name);
}

static void render(const char *scene, const char *out, const char *extra)
{
    test_tessera_ok(dir, "render '%s' -o '%s' --quiet %s", path(scene), path(out), extra);
}

static void load(const char *name, ts_image *img)
{
    test_read_image(path(name), img);
}

/* A white sphere (optionally displaced) at distance 4 under a uniform dome of radiance 1. */
static void write_furnace(const char *name, int displaced)
{
    FILE *f = fopen(path(name), "w");
    assert_non_null(f);
    fprintf(f, "Format 64 64 1\nProjection \"perspective\" \"fov\" [40]\n"
               "LightSource \"domelight\" 1 \"float intensity\" [1]\nTranslate 0 0 4\nWorldBegin\n"
               "Color [1 1 1]\nSurface \"matte\" \"float Kd\" [1]\n");
    if (displaced)
        fprintf(f, "Displacement \"fbm\" \"float amplitude\" [0.08] \"float frequency\" [3] "
                   "\"float octaves\" [3]\n");
    test_write_sphere_patches(f, 2, 1.0);
    fputs("WorldEnd\n", f);
    fclose(f);
}

/* The furnace sphere rendered with `sampling` (--sampling mis, the default, or light).
 * Convex and white under a dome of radiance 1: every path leaves after one bounce with
 * radiance 1. Under MIS a uniform dome is left to the cosine-weighted BSDF rays and under
 * light sampling it is sampled cosine-weighted about the normal: either way a sample is
 * Kd L = 1 exactly when its ray escapes (as on the plane of test_plane_under_a_uniform_dome),
 * and at the sphere's interior points every ray escapes, so each pixel well inside the
 * outline, and each pixel of the dome, is 1 to rounding (1e-3). Near the outline rays
 * graze the micro-polygons and a sample is 1 or 0 (sigma <= 0.5 per sample): the object's
 * mean is 1 within 5 sigma / sqrt(SPP * pixels). Displaced (non-convex: interreflections,
 * Russian roulette, per sample in [0, 1.6], sigma <= 0.8) only the mean is checked. */
static void check_furnace(int displaced, const char *sampling)
{
    enum { SPP = 64 };
    char args[128];
    snprintf(args, sizeof args, "--spp %d --sampling %s%s", SPP, sampling,
             displaced ? " --depth 12" : "");
    write_furnace("furnace.rib", displaced);
    render("furnace.rib", "furnace.exr", args);
    ts_image img;
    load("furnace.exr", &img);
    double sum = 0;
    int object = 0;
    for (int i = 0; i < img.width * img.height; ++i) {
        const float *px = &img.pixels[i * img.channels];
        int hit = !isinf(px[3]); /* Z: sample 0 hit the sphere (others may miss at the rim) */
        /* The outline is at 0.709 of the half-height (1 / sqrt(4^2 - 1) / tan 20 deg), at
         * most 0.82 displaced (radius 1.14: fBm of amplitude 0.08, 3 octaves); a pixel more than
         * 0.04 (1.3 pixels) inside or outside has all its samples on the sphere or all on the dome.
         * At the rim, paths graze the micro-polygons. */
        double sx = (i % img.width + 0.5) / (img.width / 2) - 1,
               sy = (i / img.width + 0.5) / (img.height / 2) - 1, r = sqrt(sx * sx + sy * sy);
        int checked = r > (displaced ? 0.86 : 0.75) || (r < 0.67 && !displaced);
        for (int c = 0; c < 3; ++c) {
            if (hit) sum += px[c] / 3.0;
            if (checked && fabs(px[c] - 1.0) > 1e-3)
                fail_msg("%s: %s pixel %d channel %d: %.6f, furnace expects 1 +- 1e-3", sampling,
                         hit ? "object" : "background", i, c, px[c]);
        }
        object += hit;
    }
    image_free(&img);
    assert_true(object > 500);
    double mean = sum / object, tol = 5 * (displaced ? 0.8 : 0.5) / sqrt((double)SPP * object);
    if (fabs(mean - 1.0) > tol)
        fail_msg("%s: object mean %.5f, expected 1 +- %.5f", sampling, mean, tol);
}

static void test_furnace(void **state)
{
    check_furnace(0, "mis");
}
static void test_furnace_light_sampling(void **state)
{
    check_furnace(0, "light");
}
static void test_furnace_displaced(void **state)
{
    check_furnace(1, "mis");
}

/* A white glass sphere (Surface "glass", eta 1.5) in the furnace: a path that enters leaves
 * again (radiance scaled by 1/1.5^2 going in and 1.5^2 going out), each reflection weighs 1,
 * so every path that escapes carries the dome's 1 and Russian roulette keeps the mean: the
 * sphere's mean is 1 within 5 sigma (samples in [0, 2.25] from the rare internal bounces,
 * sigma < 1), the dome exactly 1, and the pixels well inside the outline 1 on average too
 * (so the glass is clear, not a mirror: a mirror's centre would show the camera's side of
 * the dome, also 1, but the mean of the transmitted-only paths is checked through the
 * sphere's AOV albedo being 0, Kd 0). --depth 32: internal bounces are not cut short. */
static void test_glass_furnace(void **state)
{
    (void)state;
    enum { SPP = 64 };
    FILE *f = fopen(path("glass.rib"), "w");
    assert_non_null(f);
    fprintf(f, "Format 64 64 1\nProjection \"perspective\" \"fov\" [40]\n"
               "LightSource \"domelight\" 1 \"float intensity\" [1]\nTranslate 0 0 4\n"
               "WorldBegin\nColor [1 1 1]\nSurface \"glass\" \"float eta\" [1.5]\n");
    test_write_sphere_patches(f, 2, 1.0);
    fputs("WorldEnd\n", f);
    fclose(f);
    char args[64];
    snprintf(args, sizeof args, "--spp %d --depth 32", SPP);
    render("glass.rib", "glass.exr", args);
    ts_image img;
    load("glass.exr", &img);
    double sum = 0;
    int object = 0;
    for (int i = 0; i < img.width * img.height; ++i) {
        const float *px = &img.pixels[i * img.channels];
        int hit = !isinf(px[3]);
        /* beyond the outline (0.709 of the half-height) by 1.3 pixels: all dome */
        double sx = (i % img.width + 0.5) / (img.width / 2) - 1,
               sy = (i / img.width + 0.5) / (img.height / 2) - 1;
        int dome = sqrt(sx * sx + sy * sy) > 0.75;
        for (int c = 0; c < 3; ++c) {
            if (hit) sum += px[c] / 3.0;
            if (dome && fabs(px[c] - 1.0) > 1e-3)
                fail_msg("glass: dome pixel %d channel %d: %.6f, expected 1", i, c, px[c]);
        }
        if (hit) assert_true(px[7] == 0.0f && px[8] == 0.0f && px[9] == 0.0f); /* albedo */
        object += hit;
    }
    image_free(&img);
    assert_true(object > 500);
    double mean = sum / object, tol = 5.0 / sqrt((double)SPP * object);
    if (fabs(mean - 1.0) > tol) fail_msg("glass: object mean %.5f, expected 1 +- %.5f", mean, tol);
}

/* A matte plane under a uniform dome of radiance L and nothing else: its radiance is Kd L
 * (irradiance pi L). The dome is sampled cosine-weighted about the normal (light sampling)
 * or found by cosine-weighted BSDF rays (MIS: a uniform dome is left to them), so every
 * sample is Kd L exactly: each pixel must equal it to rounding, in both modes (uniform
 * sphere sampling, as before issue 14, was off by up to 100% per sample). */
static void test_plane_under_a_uniform_dome(void **state)
{
    const double l = 0.6, kd = 0.7;
    FILE *f = fopen(path("dome.rib"), "w");
    assert_non_null(f);
    fprintf(f,
            "Format 32 32 1\nProjection \"perspective\" \"fov\" [30]\nTranslate 0 0 5\n"
            "WorldBegin\nLightSource \"domelight\" 1 \"float intensity\" [%g]\n"
            "Color [1 1 1]\nSurface \"matte\" \"float Kd\" [%g]\n"
            "Patch \"bilinear\" \"P\" [-5 -5 0  5 -5 0  -5 5 0  5 5 0]\nWorldEnd\n",
            l, kd);
    fclose(f);
    const char *modes[2] = {"--sampling light", "--sampling mis"};
    for (int m = 0; m < 2; ++m) {
        char args[256];
        snprintf(args, sizeof args, "--spp 4 --depth 1 %s", modes[m]);
        render("dome.rib", "dome.exr", args);
        ts_image img;
        load("dome.exr", &img);
        for (int i = 0; i < img.width * img.height; ++i)
            for (int c = 0; c < 3; ++c) {
                float v = img.pixels[i * img.channels + c];
                if (fabs(v - kd * l) > kd * l * 1e-5)
                    fail_msg("%s: pixel %d: %g, want Kd L = %g", modes[m], i, v, kd * l);
            }
        image_free(&img);
    }
}

static void test_plane_under_the_sun(void **state)
{
    /* Plane z = 0 seen from above; sun at 50 degrees from the normal, E = 3, Kd 0.7. */
    const double theta = 50.0 * M_PI / 180.0, e = 3.0, kd = 0.7;
    for (int cone = 0; cone < 2; ++cone) {
        FILE *f = fopen(path("sun.rib"), "w");
        assert_non_null(f);
        fprintf(f,
                "Format 32 32 1\nProjection \"perspective\" \"fov\" [30]\nTranslate 0 0 5\n"
                "WorldBegin\nLightSource \"distantlight\" 1 \"float intensity\" [%g] "
                "\"point from\" [%.17g 0 %.17g] \"point to\" [0 0 0] \"float angle\" [%g]\n"
                "Color [1 1 1]\nSurface \"matte\" \"float Kd\" [%g]\n"
                "Patch \"bilinear\" \"P\" [-5 -5 0  5 -5 0  -5 5 0  5 5 0]\nWorldEnd\n",
                e, sin(theta), -cos(theta), cone ? 4.0 : 0.0, kd);
        fclose(f);
        render("sun.rib", "sun.exr", "--spp 16");
        ts_image img;
        load("sun.exr", &img);
        double want = kd * e * cos(theta) / M_PI, sum = 0;
        int n = img.width * img.height;
        for (int i = 0; i < n; ++i) {
            float v = img.pixels[i * img.channels];
            /* A delta sun is sampled exactly: only rounding. In a 4-degree cone a pixel also
             * catches rare BSDF rays that find the sun (MIS weight ~1e-3, value ~0.4): only
             * the image mean is tight there. */
            if (!cone && fabs(v - want) > want * 1e-4)
                fail_msg("pixel %d: %g, want %g", i, v, want);
            sum += v;
        }
        image_free(&img);
        if (cone) assert_true(fabs(sum / n - want) < want * 2e-3);
    }
}

/* Mean of channel 0 over the image, and the variance of that mean estimated from two
 * renders with different seeds (per pixel (a - b)^2 / 2 is an unbiased variance). */
static void mean_and_var(const char *a, const char *b, double *mean, double *var)
{
    ts_image x, y;
    load(a, &x);
    load(b, &y);
    int n = x.width * x.height;
    double s = 0, v = 0;
    for (int i = 0; i < n; ++i) {
        double p = x.pixels[i * x.channels], q = y.pixels[i * y.channels];
        s += 0.5 * (p + q);
        v += 0.5 * (p - q) * (p - q);
    }
    *mean = s / n;
    *var = v / ((double)n * n) / 2.0; /* of the mean of the two renders */
    image_free(&x);
    image_free(&y);
}

/* Renders `scene` with light sampling, BSDF sampling and MIS, each with two seeds (32 spp,
 * the given depth), and fails unless the three image means agree within 5 sigma of the
 * two-seed variance estimates; var gets those variances. Leaves the MIS seed-1 render in
 * a.exr. */
static void estimators_agree(const char *scene, int depth, double var[3])
{
    const char *modes[] = {"light", "bsdf", "mis"};
    double mean[3];
    for (int m = 0; m < 3; ++m) {
        char args[256];
        snprintf(args, sizeof args, "--spp 32 --depth %d --sampling %s --seed 2", depth, modes[m]);
        render(scene, "b.exr", args);
        snprintf(args, sizeof args, "--spp 32 --depth %d --sampling %s --seed 1", depth, modes[m]);
        render(scene, "a.exr", args);
        mean_and_var("a.exr", "b.exr", &mean[m], &var[m]);
    }
    for (int i = 0; i < 3; ++i)
        for (int j = i + 1; j < 3; ++j) {
            double tol = 5 * sqrt(var[i] + var[j]);
            if (fabs(mean[i] - mean[j]) > tol)
                fail_msg("%s: %s mean %g vs %s mean %g: more than 5 sigma (%g)", scene, modes[i],
                         mean[i], modes[j], mean[j], tol);
        }
}

static void test_light_bsdf_and_mis_agree(void **state)
{
    FILE *f = fopen(path("mis.rib"), "w");
    assert_non_null(f);
    fputs(
        "Format 40 40 1\nProjection \"perspective\" \"fov\" [35]\nTranslate 0 0 6\nRotate -30 1 0 "
        "0\n"
        "WorldBegin\nLightSource \"domelight\" 2 \"float intensity\" [0.2]\n"
        "AttributeBegin\nAreaLightSource \"arealight\" 3 \"float intensity\" [6]\n"
        "Patch \"bilinear\" \"P\" [-0.6 -0.6 2  0.6 -0.6 2  -0.6 0.6 2  0.6 0.6 2]\nAttributeEnd\n"
        "Color [0.9 0.8 0.7]\nSurface \"plastic\" \"float Kd\" [0.5] \"float Ks\" [0.4] "
        "\"float roughness\" [0.3]\n"
        "Patch \"bilinear\" \"P\" [-3 -3 0  3 -3 0  -3 3 0  3 3 0]\nWorldEnd\n",
        f);
    fclose(f);
    double var[3];
    estimators_agree("mis.rib", 2, var);
    /* MIS should be no noisier than the worse of the two alone. */
    assert_true(var[2] <= fmax(var[0], var[1]));
}

static void test_same_bits_whatever_memory_and_threads(void **state)
{
    write_furnace("det.rib", 1);
    render("det.rib", "d1.exr", "--spp 8 --depth 3 --seed 7");
    render("det.rib", "d2.exr", "--spp 8 --depth 3 --seed 7 --memory 16");
    int rc = test_run_tessera(dir, "render '%s' -o '%s' --quiet --spp 8 --depth 3 --seed 7",
                              path("det.rib"), path("d3.exr"));
    assert_int_equal(rc, 0);
    char cmd[8800];
    snprintf(cmd, sizeof cmd,
             "POCL_MAX_PTHREAD_COUNT=1 '%s' render '%s' -o '%s' --quiet --spp 8 "
             "--depth 3 --seed 7 2>/dev/null",
             test_tessera_binary(), path("det.rib"), path("d4.exr"));
    assert_int_equal(system(cmd), 0);
    const char *others[] = {"d2.exr", "d3.exr", "d4.exr"};
    for (int k = 0; k < 3; ++k)
        test_assert_same_pixels(path("d1.exr"), path(others[k]));
    /* A different seed gives a different image. */
    render("det.rib", "d5.exr", "--spp 8 --depth 3 --seed 8");
    ts_image a, b;
    load("d1.exr", &a);
    load("d5.exr", &b);
    assert_true(memcmp(a.pixels, b.pixels, sizeof(float) * a.width * a.height * a.channels) != 0);
    image_free(&a);
    image_free(&b);
}

static void test_shadow_rays_are_counted(void **state)
{
    /* Under a uniform dome alone, light sampling traces shadow rays; MIS traces none (the
     * dome is left to BSDF rays, lib/lights.h). */
    write_furnace("count.rib", 0);
    char args[4400];
    snprintf(args, sizeof args, "--spp 2 --sampling light --stats '%s'", path("count.json"));
    render("count.rib", "c.exr", args);
    double rays = test_stats_number(path("count.json"), "counters.rays");
    double shadow = test_stats_number(path("count.json"), "counters.shadow_rays");
    assert_true(rays >= 64 * 64 * 2);
    assert_true(shadow > 0 && shadow <= rays);
    snprintf(args, sizeof args, "--spp 2 --stats '%s'", path("count.json"));
    render("count.rib", "c.exr", args);
    assert_true(test_stats_number(path("count.json"), "counters.shadow_rays") == 0.0);
}

/* A lat-long map of w x h: constant 1, or black with a bright patch around the direction
 * +y (phi = 90 degrees, theta = 90 degrees: the middle row, a quarter of the way across). */
static void write_env(const char *name, int w, int h, int spot)
{
    float *px = calloc((size_t)w * h * 3, sizeof *px);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float v = spot ? 0.05f : 1.0f;
            if (spot && abs(y - h / 2) <= 1 && abs(x - w / 4) <= 1) v = 200.0f;
            for (int c = 0; c < 3; ++c)
                px[((size_t)y * w + x) * 3 + c] = v;
        }
    const char *names[] = {"R", "G", "B"};
    ts_image img = {.width = w, .height = h, .channels = 3, .channel_names = names, .pixels = px};
    ts_error err = {0};
    if (image_write_exr(path(name), &img, NULL, 0, &err)) fail_msg("%s", err.msg);
    free(px);
}

static void test_environment_map(void **state)
{
    enum { SPP = 64 };
    /* A constant map is the uniform dome: the furnace still reflects exactly 1. */
    write_env("white.exr", 32, 16, 0);
    FILE *f = fopen(path("env.rib"), "w");
    assert_non_null(f);
    fprintf(f, "Format 48 48 1\nProjection \"perspective\" \"fov\" [40]\n"
               "LightSource \"domelight\" 1 \"string mapname\" [\"white.exr\"]\nTranslate 0 0 4\n"
               "WorldBegin\nColor [1 1 1]\n");
    test_write_sphere_patches(f, 2, 1.0);
    fputs("WorldEnd\n", f);
    fclose(f);
    render("env.rib", "env.exr", "--spp 64");
    ts_image img;
    load("env.exr", &img);
    double sum = 0;
    int n = 0;
    for (int i = 0; i < img.width * img.height; ++i)
        if (!isinf(img.pixels[i * img.channels + 3])) sum += img.pixels[i * img.channels], ++n;
    image_free(&img);
    assert_true(n > 300 && fabs(sum / n - 1.0) < 5 * 0.8 / sqrt((double)SPP * n));
    /* A bright spot towards +y (world = camera space here: up on screen) lights the upper
     * half, and the three estimators agree. */
    write_env("spot.exr", 64, 32, 1);
    f = fopen(path("spot.rib"), "w");
    assert_non_null(f);
    fprintf(f, "Format 48 48 1\nProjection \"perspective\" \"fov\" [40]\n"
               "LightSource \"domelight\" 1 \"string mapname\" [\"spot.exr\"]\nTranslate 0 0 4\n"
               "WorldBegin\nColor [0.8 0.8 0.8]\n");
    test_write_sphere_patches(f, 2, 1.0);
    fputs("WorldEnd\n", f);
    fclose(f);
    double var[3];
    estimators_agree("spot.rib", 1, var);
    load("a.exr", &img); /* mis, seed 1 */
    double top = 0, bottom = 0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            *(y < img.height / 2 ? &top : &bottom) +=
                img.pixels[((size_t)y * img.width + x) * img.channels];
    image_free(&img);
    assert_true(top > 3 * bottom);
}

/* The local-light scenes: an orthographic camera looking down +z at the plane z = 0 (the
 * screen window [-4, 4]^2 over 64 x 64 pixels, world = camera space but for the camera 10
 * back), a matte plane of Kd 0.7 over [-h, h]^2, and `lights` (RIB text). */
static void write_light_plane(const char *name, double h, const char *lights)
{
    FILE *f = fopen(path(name), "w");
    assert_non_null(f);
    fprintf(f,
            "Format 64 64 1\nProjection \"orthographic\"\nScreenWindow -4 4 -4 4\n"
            "Translate 0 0 10\nWorldBegin\n%sColor [1 1 1]\nSurface \"matte\" \"Kd\" [0.7]\n"
            "Patch \"bilinear\" \"P\" [%g %g 0  %g %g 0  %g %g 0  %g %g 0]\nWorldEnd\n",
            lights, -h, -h, h, -h, -h, h, h, h);
    fclose(f);
}

/* The plane's point at the centre of pixel (x, y) (the camera sample when spp = 1). */
static void pixel_point(int x, int y, double q[3])
{
    q[0] = -4 + 8 * (x + 0.5) / 64, q[1] = 4 - 8 * (y + 0.5) / 64, q[2] = 0;
}

/* Irradiance on the plane (normal -z, towards the lights at z < 0) at q from RenderMan's
 * spotlight at `from` towards `to` (spotlight.sl in double), or its pointlight when
 * cone <= 0. */
static double local_irradiance(const double from[3], const double to[3], double intensity,
                               double cone, double delta, double beam, const double q[3])
{
    double l[3] = {from[0] - q[0], from[1] - q[1], from[2] - q[2]};
    double d2 = l[0] * l[0] + l[1] * l[1] + l[2] * l[2], d = sqrt(d2);
    double e = intensity / d2 * (-l[2] / d); /* cos at the surface */
    if (cone <= 0) return e;
    double a[3] = {to[0] - from[0], to[1] - from[1], to[2] - from[2]};
    double al = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    double c = -(l[0] * a[0] + l[1] * a[1] + l[2] * a[2]) / (d * al);
    double lo = cos(cone), hi = cos(cone - delta), t = (c - lo) / (hi - lo);
    if (c < lo) return 0.0;
    return e * pow(c, beam) * (c >= hi ? 1.0 : t * t * (3 - 2 * t));
}

/* Every pixel of a plane lit by one point or spot light is Kd / pi times its irradiance: a
 * delta light is sampled exactly, so only float rounding separates them (1 spp: the pixel
 * centre). The spot's image must hold pixels in its full cone, on its soft edge and
 * outside. */
static void test_point_and_spot_on_a_plane(void **state)
{
    const double kd = 0.7, from[2][3] = {{1, -0.5, -3}, {0.5, 0.5, -4}}, to[3] = {0, 0, 0};
    const char *rib[2] = {
        "LightSource \"pointlight\" 1 \"intensity\" [9] \"from\" [1 -0.5 -3]\n",
        "LightSource \"spotlight\" 1 \"intensity\" [40] \"from\" [0.5 0.5 -4] \"to\" [0 0 0] "
        "\"coneangle\" [0.4] \"conedeltaangle\" [0.1] \"beamdistribution\" [2]\n"};
    for (int spot = 0; spot < 2; ++spot) {
        write_light_plane("local.rib", 5, rib[spot]);
        render("local.rib", "local.exr", "--spp 1 --depth 1");
        ts_image img;
        load("local.exr", &img);
        int inside = 0, edge = 0, dark = 0;
        for (int y = 0; y < 64; ++y)
            for (int x = 0; x < 64; ++x) {
                double q[3];
                pixel_point(x, y, q);
                double e = local_irradiance(from[spot], to, spot ? 40 : 9, spot ? 0.4 : 0, 0.1, 2,
                                            q),
                       full = local_irradiance(from[spot], to, spot ? 40 : 9, spot ? 0.4 : 0, 0.0,
                                               2, q);
                double want = kd * e / M_PI, v = img.pixels[((size_t)y * 64 + x) * img.channels];
                if (fabs(v - want) > 2e-4 * want + 1e-7)
                    fail_msg("%s: pixel (%d, %d): %.7g, want %.7g", spot ? "spot" : "point", x, y,
                             v, want);
                inside += e > 0 && e == full, edge += e > 0 && e < full, dark += e == 0;
            }
        image_free(&img);
        if (spot) assert_true(inside > 200 && edge > 200 && dark > 1000);
    }
}

/* A sun, a point light, a spot and an ambient light together: one light is chosen per
 * vertex by weight (the ambient one is left to BSDF rays), so pixels are noisy, but the image
 * mean is Kd / pi times the sum of the irradiances plus Kd L, within 5 sigma of the mean's
 * variance estimated from two seeds (32 spp each). */
static void test_mixed_lights_mean(void **state)
{
    const double kd = 0.7, theta = 40 * M_PI / 180, sun = 1.5, amb = 0.2;
    const double pf[3] = {-1.5, 1, -2.5}, sf[3] = {1, 0, -4}, st[3] = {1.5, -0.5, 0},
                 none[3] = {0, 0, 0};
    char lights[1024];
    snprintf(lights, sizeof lights,
             "LightSource \"distantlight\" 1 \"intensity\" [%g] \"from\" [0 %.17g %.17g] "
             "\"to\" [0 0 0]\n"
             "LightSource \"pointlight\" 2 \"intensity\" [6] \"from\" [-1.5 1 -2.5]\n"
             "LightSource \"spotlight\" 3 \"intensity\" [30] \"from\" [1 0 -4] \"to\" [1.5 -0.5 "
             "0] \"coneangle\" [0.5] \"conedeltaangle\" [0.2]\n"
             "LightSource \"ambientlight\" 4 \"intensity\" [%g]\n",
             sun, -sin(theta), -cos(theta), amb);
    write_light_plane("mix.rib", 5, lights);
    render("mix.rib", "a.exr", "--spp 32 --seed 1");
    render("mix.rib", "b.exr", "--spp 32 --seed 2");
    double mean, var, want = 0;
    mean_and_var("a.exr", "b.exr", &mean, &var);
    for (int y = 0; y < 64; ++y)
        for (int x = 0; x < 64; ++x) {
            double q[3];
            pixel_point(x, y, q);
            double e = sun * cos(theta) + local_irradiance(pf, none, 6, 0, 0, 0, q) +
                       local_irradiance(sf, st, 30, 0.5, 0.2, 2, q);
            want += (kd * e / M_PI + kd * amb) / (64 * 64);
        }
    assert_true(var > 0); /* the choice of light is random */
    if (fabs(mean - want) > 5 * sqrt(var))
        fail_msg("image mean %.6f, want %.6f +- %.6f (5 sigma)", mean, want, 5 * sqrt(var));
}

/* ambientlight lights a matte plane like a uniform dome of radiance L (Kd L in every sample,
 * with light or MIS sampling) but eye rays do not see it: the background stays black, or
 * shows only the domelight. */
static void test_ambient_light(void **state)
{
    const double kd = 0.7, amb = 0.3, dome = 0.2;
    const char *modes[2] = {"--spp 4 --depth 1 --sampling light", "--spp 4 --depth 1"};
    for (int with_dome = 0; with_dome < 2; ++with_dome) {
        char lights[256];
        snprintf(lights, sizeof lights, "LightSource \"ambientlight\" 1 \"intensity\" [%g]\n%s",
                 amb, with_dome ? "LightSource \"domelight\" 2 \"intensity\" [0.2]\n" : "");
        write_light_plane("amb.rib", 2, lights);
        for (int m = 0; m < 2; ++m) {
            render("amb.rib", "amb.exr", modes[m]);
            ts_image img;
            load("amb.exr", &img);
            int plane = 0, sky = 0;
            for (int y = 0; y < 64; ++y)
                for (int x = 0; x < 64; ++x) {
                    const float *px = &img.pixels[((size_t)y * 64 + x) * img.channels];
                    double q[3], want;
                    pixel_point(x, y, q);
                    if (fabs(q[0]) < 1.9 && fabs(q[1]) < 1.9)
                        want = kd * (amb + (with_dome ? dome : 0)), ++plane;
                    else if (fabs(q[0]) > 2.1 || fabs(q[1]) > 2.1)
                        want = with_dome ? dome : 0.0, ++sky;
                    else
                        continue; /* pixels the plane's edge crosses */
                    if (fabs(px[0] - want) > 1e-5 * want + 1e-7)
                        fail_msg("%s, %s: pixel (%d, %d): %g, want %g", modes[m],
                                 with_dome ? "with a dome" : "alone", x, y, px[0], want);
                }
            image_free(&img);
            assert_true(plane == 900 && sky > 2900);
        }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_furnace),
        cmocka_unit_test(test_furnace_light_sampling),
        cmocka_unit_test(test_furnace_displaced),
        cmocka_unit_test(test_glass_furnace),
        cmocka_unit_test(test_plane_under_the_sun),
        cmocka_unit_test(test_light_bsdf_and_mis_agree),
        cmocka_unit_test(test_same_bits_whatever_memory_and_threads),
        cmocka_unit_test(test_shadow_rays_are_counted),
        cmocka_unit_test(test_plane_under_a_uniform_dome),
        cmocka_unit_test(test_environment_map),
        cmocka_unit_test(test_point_and_spot_on_a_plane),
        cmocka_unit_test(test_mixed_lights_mean),
        cmocka_unit_test(test_ambient_light),
    };
    return TEST_RUN_WITH_DEVICE(tests, setup);
}
