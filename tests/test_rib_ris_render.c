/* test_rib_ris_render.c — RenderMan 21-26 lights and Bxdfs (issue 39) through the whole
 * renderer, against results known in closed form:
 * - PxrDomeLight furnace: a white PxrDiffuse sphere under a dome of radiance
 *   intensity 2^exposure = 1 is 1 wherever every path escapes;
 * - PxrDisney furnace (the principled BRDF): a white dielectric sphere reflects nearly all the
 *   dome gives it and never more, a white sphere of every lobe at most all of it, by BSDF and
 *   by light sampling alike;
 * - a PxrDiffuse plane lit by a PxrRectLight (Lambert's polygon formula for the irradiance)
 *   and by a PxrSphereLight (pi L sin^2 of the sphere's half angle, times the cosine): the
 *   image's mean is Kd / pi times the irradiance's mean over the pixel centres;
 * - the same plane under PxrEnvDayLight at Seattle's solar noon on the June solstice and in
 *   the evening: Kd / pi times the sun's irradiance (the loaded distant light's) times its
 *   cosine plus the sky's (the baked map integrated against the cosine), and noon brighter.
 * - LamaTranslucent: the plane lit from behind is 0.7 / pi times the far side's irradiance,
 *   black lit from the front; a sphere of half-reflecting, half-transmitting white sheets is
 *   a furnace (1 everywhere).
 * - presence from a texture's alpha: the plane kept where the alpha is 1 (its albedo under a
 *   dome of 1), cut away where it is 0 (the dome), in both geometry modes.
 * Needs an OpenCL device (skipped, 77, without one). */
#include "test_support.h"
#include "image/image.h"
#include "scene/rib/rib.h"
#include "scene/scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static char dir[4096];

static int setup(void **state)
{
    (void)state;
    if (!test_has_device()) test_skip("no OpenCL device");
    snprintf(dir, sizeof dir, "%s", test_scratch_dir());
    setenv("TESSERA_CACHE_DIR", dir, 1); /* where PxrEnvDayLight's sky maps go */
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

/* A white PxrDiffuse sphere of radius 1 at distance 4 under PxrDomeLight of radiance
 * 0.5 * 2^1 = 1: convex and white, so every path leaves after one bounce with radiance 1;
 * the pixels well inside the outline (r < 0.67 of the half-height, as test_pathtrace's
 * furnace) and those of the dome are 1 to rounding. */
static void test_dome_furnace(void **state)
{
    (void)state;
    FILE *f = fopen(path("ris_furnace.rib"), "w");
    assert_non_null(f);
    fprintf(f, "Format 48 48 1\nProjection \"PxrPerspective\" \"fov\" [40]\nTranslate 0 0 4\n"
               "WorldBegin\nLight \"PxrDomeLight\" \"dome\" \"float intensity\" [0.5] "
               "\"float exposure\" [1]\nBxdf \"PxrDiffuse\" \"white\" \"color diffuseColor\" "
               "[1 1 1]\n");
    test_write_sphere_patches(f, 2, 1.0);
    fputs("WorldEnd\n", f);
    fclose(f);
    render("ris_furnace.rib", "ris_furnace.exr", "--spp 16");
    ts_image img;
    test_read_image(path("ris_furnace.exr"), &img);
    int checked = 0;
    for (int i = 0; i < img.width * img.height; ++i) {
        double sx = (i % img.width + 0.5) / (img.width / 2) - 1,
               sy = (i / img.width + 0.5) / (img.height / 2) - 1, r = sqrt(sx * sx + sy * sy);
        if (!(r > 0.75 || r < 0.67)) continue;
        for (int c = 0; c < 3; ++c)
            if (fabs(img.pixels[(size_t)i * img.channels + c] - 1.0) > 1e-3)
                fail_msg("pixel %d channel %d: %.6f, the furnace expects 1 +- 1e-3", i, c,
                         img.pixels[(size_t)i * img.channels + c]);
        checked++;
    }
    image_free(&img);
    assert_true(checked > 1500);
}

/* The mean and largest pixel over the inside of a sphere of radius 1 at distance 4 (fov 40:
 * r < 0.67 of the half-height), channel 0 (the furnaces are grey). */
static void sphere_pixels(const char *exr, double *mean, double *hi)
{
    ts_image img;
    test_read_image(path(exr), &img);
    double sum = 0.0;
    int n = 0;
    *hi = 0.0;
    for (int i = 0; i < img.width * img.height; ++i) {
        double sx = (i % img.width + 0.5) / (img.width / 2) - 1,
               sy = (i / img.width + 0.5) / (img.height / 2) - 1;
        if (sqrt(sx * sx + sy * sy) >= 0.67) continue;
        double v = img.pixels[(size_t)i * img.channels];
        sum += v, n++, *hi = fmax(*hi, v);
    }
    image_free(&img);
    assert_true(n > 1000);
    *mean = sum / n;
}

/* White PxrDisney spheres under a dome of radiance 1: the pixel is the albedo of the point
 * seen, at most 1. A dielectric with specular 0 and no coat or sheen reflects 0.97 to 1 of it
 * (the diffuse layer takes what the specular lobe leaves, less the table's margin); one of
 * every lobe (metallic 0.5, sheen, clearcoat) less, and never more. --sampling light gives
 * the same means through bsdf_eval (the light samples' weights) as BSDF sampling does. */
static void test_disney_furnace(void **state)
{
    (void)state;
    const char *sets[2] = {"\"float specular\" [0] \"float roughness\" [0.5]",
                           "\"float metallic\" [0.5] \"float roughness\" [0.4] \"float sheen\" [1] "
                           "\"float clearcoat\" [1] \"float clearcoatGloss\" [0.5]"};
    double means[2][2];
    for (int k = 0; k < 2; k++) {
        FILE *f = fopen(path("disney_furnace.rib"), "w");
        assert_non_null(f);
        fprintf(f,
                "Format 64 64 1\nProjection \"PxrPerspective\" \"fov\" [40]\nTranslate 0 0 4\n"
                "WorldBegin\nLight \"PxrDomeLight\" \"dome\" \"float intensity\" [1]\n"
                "Bxdf \"PxrDisney\" \"white\" \"color baseColor\" [1 1 1] %s\n",
                sets[k]);
        test_write_sphere_patches(f, 2, 1.0);
        fputs("WorldEnd\n", f);
        fclose(f);
        for (int light = 0; light < 2; light++) {
            render("disney_furnace.rib", "disney_furnace.exr",
                   light ? "--spp 64 --sampling light" : "--spp 64");
            double hi;
            sphere_pixels("disney_furnace.exr", &means[k][light], &hi);
            /* a pixel of 64 BSDF samples: the noise stays under 0.1 above its albedo (light
             * samples of a uniform dome on a glossy coat make fireflies: their mean only) */
            if (!light && hi > 1.1) fail_msg("set %d sampling %d: a pixel of %g", k, light, hi);
        }
        if (fabs(means[k][0] - means[k][1]) > 0.01)
            fail_msg("set %d: mean %g by BSDF sampling, %g by light sampling", k, means[k][0],
                     means[k][1]);
    }
    if (!(means[0][0] >= 0.97 && means[0][0] <= 1.002))
        fail_msg("white dielectric: mean %g, want 0.97 to 1", means[0][0]);
    if (!(means[1][0] <= 1.002 && means[1][0] > 0.5))
        fail_msg("every lobe: mean %g, want at most 1", means[1][0]);
}

#define PLANE_DIFFUSE "Bxdf \"PxrDiffuse\" \"d\" \"color diffuseColor\" [0.7 0.7 0.7]"

/* The plane z = 0 of material bxdf (PLANE_DIFFUSE: Kd 0.7; seen orthographically through
 * [-4, 4]^2 from z < 0) and a light placed from z = -2 beside the window, centred at x = 6. */
static void write_plane(const char *name, const char *light, const char *bxdf)
{
    FILE *f = fopen(path(name), "w");
    assert_non_null(f);
    fprintf(f,
            "Format 64 64 1\nProjection \"orthographic\"\nScreenWindow -4 4 -4 4\n"
            "Translate 0 0 10\nWorldBegin\nAttributeBegin\nTranslate 6 0 -2\n%s\nAttributeEnd\n"
            "%s\nPatch \"bilinear\" \"P\" [-5 -5 0  5 -5 0  -5 5 0  5 5 0]\nWorldEnd\n",
            light, bxdf);
    fclose(f);
}

/* The plane's point at the centre of pixel (x, y). */
static void pixel_point(int x, int y, double q[3])
{
    q[0] = -4 + 8 * (x + 0.5) / 64, q[1] = 4 - 8 * (y + 0.5) / 64, q[2] = 0;
}

/* Irradiance at q (normal -z) from a Lambertian polygon of radiance L (Lambert 1760): L / 2
 * times |sum over edges of the angle the edge subtends times n . the unit normal of the
 * plane through q and the edge|. */
static double polygon_irradiance(const double v[][3], int n, double L, const double q[3])
{
    double sum = 0;
    for (int i = 0; i < n; i++) {
        const double *p0 = v[i], *p1 = v[(i + 1) % n];
        double a[3] = {p0[0] - q[0], p0[1] - q[1], p0[2] - q[2]};
        double b[3] = {p1[0] - q[0], p1[1] - q[1], p1[2] - q[2]};
        double la = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        double lb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
        double c[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                       a[0] * b[1] - a[1] * b[0]};
        double lc = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        double theta = acos(fmin(1.0, (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (la * lb)));
        sum += theta * (-c[2] / lc); /* n = (0, 0, -1) */
    }
    return 0.5 * L * fabs(sum);
}

/* Renders `light` over the plane of material bxdf and compares the image's mean with 0.7 / pi
 * times the mean of irradiance(q) over the pixel centres (0 when irradiance is NULL). The estimate
 * of each pixel is unbiased and the irradiance varies smoothly across a pixel, so the two agree
 * within the noise of 64 x 64 x SPP light samples; `tol` is relative. */
static void check_plane(const char *light, const char *bxdf,
                        double (*irradiance)(const double q[3]), int spp, const char *extra,
                        double tol)
{
    write_plane("ris_plane.rib", light, bxdf);
    char args[256];
    snprintf(args, sizeof args, "--spp %d --depth 1 %s", spp, extra);
    render("ris_plane.rib", "ris_plane.exr", args);
    ts_image img;
    test_read_image(path("ris_plane.exr"), &img);
    double got = 0, want = 0;
    for (int y = 0; y < 64; ++y)
        for (int x = 0; x < 64; ++x) {
            double q[3];
            pixel_point(x, y, q);
            want += irradiance ? 0.7 / M_PI * irradiance(q) : 0.0;
            got += img.pixels[((size_t)y * 64 + x) * img.channels];
        }
    image_free(&img);
    if (!(fabs(got - want) <= tol * want) || (!irradiance && got != 0.0))
        fail_msg("%s: image mean %.6g, closed form %.6g (+- %g relative)", light, got / 4096,
                 want / 4096, tol);
}

/* PxrRectLight of radiance 3 * 2^-1 * 2 = 3, a 2 x 2 square (Scale 2 2 1) turned to face
 * the plane with its -z side (RenderMan's emitting side). */
static double rect_irradiance(const double q[3])
{
    const double v[4][3] = {{5, -1, -2}, {7, -1, -2}, {7, 1, -2}, {5, 1, -2}};
    return polygon_irradiance(v, 4, 3.0, q);
}

/* PxrSphereLight of radiance 4, radius 0.5 at (6, 0, -2): above every point's horizon, so
 * E = pi L (r / d)^2 cos, cos = 2 / d. Checked with BSDF sampling alone, on a finely diced
 * sphere (--lod 9): light sampling of a curved emitter patch overestimates it (the sampled
 * patch does not shadow its own samples, so points of it behind its front count; +12 % here
 * at --lod 10), and coarse dicing of a light no eye ray sees shadows samples (-20 % at the
 * default level): docs/rib.md "RIS shading" says so. */
static double sphere_irradiance(const double q[3])
{
    double c[3] = {6 - q[0], -q[1], -2 - q[2]}, d2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    return M_PI * 4.0 * 0.25 / d2 * (2.0 / sqrt(d2));
}

static void test_rect_light(void **state)
{
    (void)state;
    check_plane("Rotate 180 1 0 0\nScale 2 2 1\nLight \"PxrRectLight\" \"r\" \"float intensity\" "
                "[3] \"float exposure\" [-1] \"color lightColor\" [2 2 2]",
                PLANE_DIFFUSE, rect_irradiance, 32, "", 0.01);
}

static void test_sphere_light(void **state)
{
    (void)state;
    check_plane("Light \"PxrSphereLight\" \"s\" \"float intensity\" [4]", PLANE_DIFFUSE,
                sphere_irradiance, 256, "--sampling bsdf --lod 9", 0.03);
}

/* The irradiance on the plane's lit side (normal -z) from the scene's sun and dome: the
 * distant light's intensity * color * cos for a sun above that side, and the dome's map
 * (intensity times texels) integrated against the cosine over the hemisphere z < 0; red. */
static double daylight_irradiance(const char *rib)
{
    ts_scene s = {0};
    ts_error e = {0};
    if (rib_load(path(rib), &s, 1, &e) != TS_OK) fail_msg("%s", e.msg);
    assert_true(s.dome.present && s.dome.map);
    ts_image map = {.width = (int)s.dome.map_width,
                    .height = (int)s.dome.map_height,
                    .channels = 3,
                    .channel_names = NULL,
                    .pixels = s.dome.map};
    double sky = 0;
    for (int y = 0; y < map.height; y++) {
        double th = (y + 0.5) * M_PI / map.height, c = -cos(th);
        if (c <= 0) continue;
        double w = c * sin(th) * (M_PI / map.height) * (2 * M_PI / map.width);
        for (int x = 0; x < map.width; x++)
            sky += w * map.pixels[((size_t)y * map.width + x) * map.channels];
    }

    double sun = 0;
    if (s.light_count) {
        assert_int_equal(s.light_count, 1);
        const ts_scene_light *l = &s.lights[0];
        double d[3] = {l->from[0] - l->to[0], l->from[1] - l->to[1], l->from[2] - l->to[2]};
        double c = -d[2] / sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        sun = c > 0 ? l->intensity * l->color[0] * c : 0;
    }
    double total = s.dome.intensity * s.dome.color[0] * sky + sun;
    scene_free(&s);
    return total;
}

/* The same square light behind the plane (at z = 2, emitting towards -z): the irradiance on
 * the plane's far side. */
static double rect_behind_irradiance(const double q[3])
{
    const double v[4][3] = {{5, -1, 2}, {7, -1, 2}, {7, 1, 2}, {5, 1, 2}};
    return polygon_irradiance(v, 4, 3.0, q);
}

/* LamaTranslucent (TS_MAT_TRANSLUCENT), a thin sheet that transmits all it scatters: lit from
 * behind by the square light, the side the camera sees is 0.7 / pi times the irradiance on
 * the far side; lit from the front it is black, and so is a PxrDiffuse plane lit from
 * behind. LamaMix of the two at 0.5 under the light in front: half the diffuse plane. */
static void test_translucent_sheet(void **state)
{
    (void)state;
    const char *behind = "Translate 0 0 4\nScale 2 2 1\nLight \"PxrRectLight\" \"r\" \"float "
                         "intensity\" [3] \"float exposure\" [-1] \"color lightColor\" [2 2 2]";
    const char *front = "Rotate 180 1 0 0\nScale 2 2 1\nLight \"PxrRectLight\" \"r\" \"float "
                        "intensity\" [3] \"float exposure\" [-1] \"color lightColor\" [2 2 2]";
    const char *sheet = "Bxdf \"LamaTranslucent\" \"t\" \"color color\" [0.7 0.7 0.7]";
    check_plane(behind, sheet, rect_behind_irradiance, 32, "", 0.01);
    check_plane(front, sheet, NULL, 4, "", 0.0);
    check_plane(behind, PLANE_DIFFUSE, NULL, 4, "", 0.0);
    check_plane(front,
                "Bxdf \"LamaDiffuse\" \"d\" \"color color\" [1.4 1.4 1.4]\n" /* 0.7 at mix 0.5 */
                "Bxdf \"LamaTranslucent\" \"t\" \"color color\" [0.5 0.5 0.5]\n"
                "Bxdf \"LamaMix\" \"m\" \"reference bxdf material1\" [\"d\"] \"reference bxdf "
                "material2\" [\"t\"] \"float mix\" [0.5]",
                rect_irradiance, 32, "", 0.01);
}

/* A sphere of thin translucent sheets (LamaMix of a white LamaDiffuse and a white
 * LamaTranslucent: half reflected, half transmitted, nothing lost) under a dome of radiance
 * 1: inside and out every path keeps its throughput and leaves with radiance 1, so BSDF
 * sampling gives 1 in every pixel; light sampling (the dome sampled on the side each vertex
 * chooses, lib/bsdf.h translucent_front_prob) gives 1 on average. */
static void test_translucent_furnace(void **state)
{
    (void)state;
    FILE *f = fopen(path("sheet_furnace.rib"), "w");
    assert_non_null(f);
    fprintf(f, "Format 64 64 1\nProjection \"PxrPerspective\" \"fov\" [40]\nTranslate 0 0 4\n"
               "WorldBegin\nLight \"PxrDomeLight\" \"dome\" \"float intensity\" [1]\n"
               "Bxdf \"LamaDiffuse\" \"d\" \"color color\" [1 1 1]\n"
               "Bxdf \"LamaTranslucent\" \"t\" \"color color\" [1 1 1]\n"
               "Bxdf \"LamaMix\" \"m\" \"reference bxdf material1\" [\"d\"] \"reference bxdf "
               "material2\" [\"t\"] \"float mix\" [0.5]\n");
    test_write_sphere_patches(f, 2, 1.0);
    fputs("WorldEnd\n", f);
    fclose(f);
    render("sheet_furnace.rib", "sheet_furnace.exr", "--spp 4 --depth 40");
    double mean, hi;
    sphere_pixels("sheet_furnace.exr", &mean, &hi);
    if (!(fabs(mean - 1.0) < 1e-3 && hi < 1.001))
        fail_msg("BSDF sampling: mean %.6f, largest %.6f, want 1", mean, hi);
    render("sheet_furnace.rib", "sheet_furnace.exr", "--spp 64 --depth 40 --sampling light");
    sphere_pixels("sheet_furnace.exr", &mean, &hi);
    if (!(fabs(mean - 1.0) < 0.01)) fail_msg("light sampling: mean %.6f, want 1", mean);
}

/* presence from a texture's alpha (TS_PATCH_CUTOUT): the plane z = 0 seen orthographically,
 * coloured 0.7 by an RGBA texture whose alpha is 1 on u < 0.5 and 0 beyond, under a dome of
 * radiance 1 (depth 1: every BSDF sample of the plane finds the dome). Where the plane is
 * kept a pixel is its albedo, 0.7; where it is cut away the eye ray finds the dome, 1 — in box
 * and in triangle mode. The columns within a texel of the mask's edge are not checked. */
static void test_cutout(void **state)
{
    (void)state;
    enum { W = 8 };
    float px[W * W * 4];
    for (int i = 0; i < W * W; i++) {
        px[4 * i] = px[4 * i + 1] = px[4 * i + 2] = 0.7f;
        px[4 * i + 3] = i % W < W / 2 ? 1.0f : 0.0f;
    }
    const char *names[4] = {"R", "G", "B", "A"};
    ts_image tex = {.width = W, .height = W, .channels = 4, .channel_names = names, .pixels = px};
    ts_error err = {0};
    if (image_write_exr(path("cutout.exr"), &tex, NULL, 0, &err)) fail_msg("%s", err.msg);
    FILE *f = fopen(path("cutout.rib"), "w");
    assert_non_null(f);
    fprintf(f, "Format 64 64 1\nProjection \"orthographic\"\nScreenWindow -4 4 -4 4\n"
               "Translate 0 0 10\nWorldBegin\nLight \"PxrDomeLight\" \"dome\" \"float intensity\" "
               "[1]\nPattern \"PxrTexture\" \"t\" \"string filename\" [\"cutout.exr\"]\n"
               "Bxdf \"PxrDiffuse\" \"d\" \"reference color diffuseColor\" [\"t:resultRGB\"] "
               "\"reference float presence\" [\"t:resultA\"]\n"
               "Patch \"bilinear\" \"P\" [-5 -5 0  5 -5 0  -5 5 0  5 5 0]\nWorldEnd\n");
    fclose(f);
    for (int mode = 0; mode < 2; mode++) {
        render("cutout.rib", "cutout.exr.out.exr",
               mode ? "--spp 4 --depth 1 --intersect triangles" : "--spp 4 --depth 1");
        ts_image img;
        test_read_image(path("cutout.exr.out.exr"), &img);
        int kept = 0, cut = 0;
        for (int y = 0; y < 64; y++)
            for (int x = 0; x < 64; x++) {
                /* u = (q + 5) / 10 at the pixel centre q = -4 + 8 (x + 0.5) / 64 */
                double q = -4 + 8 * (x + 0.5) / 64, u = (q + 5) / 10;
                if (u > 0.4 && u < 0.6) continue;
                double want = u < 0.5 ? 0.7 : 1.0,
                       got = img.pixels[((size_t)y * 64 + x) * img.channels];
                if (fabs(got - want) > 1e-3)
                    fail_msg("mode %d pixel (%d, %d), u %.3f: %.6f, want %.1f (%s)", mode, x, y, u,
                             got, want, u < 0.5 ? "kept" : "cut away");
                kept += u < 0.5, cut += u >= 0.5;
            }
        image_free(&img);
        assert_true(kept > 1000 && cut > 1000);
    }
}

/* PxrEnvDayLight turned so that its zenith is the lit side's normal (-z), at Seattle on 21
 * June 2014 at `hour` PST: the image's mean is 0.7 / pi times the irradiance. */
static double check_daylight(double hour)
{
    char light[512];
    snprintf(light, sizeof light,
             "Rotate 180 1 0 0\nLight \"PxrEnvDayLight\" \"d\" \"int month\" [6] \"int day\" "
             "[21] \"int year\" [2014] \"float hour\" [%g] \"float zone\" [-8] "
             "\"float latitude\" [47.6062] \"float longitude\" [-122.3321]",
             hour);
    write_plane("ris_day.rib", light, PLANE_DIFFUSE);
    double want = 0.7 / M_PI * daylight_irradiance("ris_day.rib");
    render("ris_day.rib", "ris_day.exr", "--spp 16 --depth 1");
    ts_image img;
    test_read_image(path("ris_day.exr"), &img);
    double got = 0;
    for (int i = 0; i < 64 * 64; ++i)
        got += img.pixels[(size_t)i * img.channels] / 4096.0;
    image_free(&img);
    if (!(fabs(got - want) <= 0.02 * want))
        fail_msg("daylight at %g h: image mean %.6g, expected %.6g (+- 2 %%)", hour, got, want);
    return got;
}

static void test_daylight(void **state)
{
    (void)state;
    double noon = check_daylight(12.184), evening = check_daylight(19.0);
    if (!(noon > 2.0 * evening))
        fail_msg("noon %.6g is not brighter than evening %.6g", noon, evening);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_dome_furnace),
        cmocka_unit_test(test_disney_furnace),
        cmocka_unit_test(test_rect_light),
        cmocka_unit_test(test_sphere_light),
        cmocka_unit_test(test_daylight),
        cmocka_unit_test(test_translucent_sheet),
        cmocka_unit_test(test_translucent_furnace),
        cmocka_unit_test(test_cutout),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
