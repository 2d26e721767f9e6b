/* test_rib_daylight.c — Light "PxrEnvDayLight" (issue 39, item 6; docs/rib.md "Daylight"):
 * the light makes the scene's dome, whose map is Preetham's sky baked from its parameters
 * (written to $TESSERA_CACHE_DIR, here a scratch folder), and a distant light towards the
 * sun: the sun's direction from sunDirection when month is 0 and from the date, hour, zone
 * and place otherwise, turned by the CTM; its cone sunSize * 0.55 degrees wide; its colour
 * the disc's radiance through the sky (sky.h) times sunTint, intensity * 2^exposure. Host
 * only: never skips. */
#include "image/image.h"
#include "scene/rib/rib.h"
#include "scene/scene.h"
#include "scene/sky.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

#define DEG (M_PI / 180.0)

static int setup(void **state)
{
    (void)state;
    setenv("TESSERA_CACHE_DIR", test_scratch_dir(), 1);
    return 0;
}

/* The unit direction towards light l's source (from - to). */
static void sun_of(const ts_scene_light *l, double d[3])
{
    double n = 0;
    for (int k = 0; k < 3; k++)
        d[k] = l->from[k] - l->to[k], n += d[k] * d[k];
    for (int k = 0; k < 3; k++)
        d[k] /= sqrt(n);
}

static void assert_dir(const double d[3], double x, double y, double z, double tol)
{
    double n = sqrt(x * x + y * y + z * z);
    if (!(fabs(d[0] - x / n) <= tol && fabs(d[1] - y / n) <= tol && fabs(d[2] - z / n) <= tol))
        fail_msg("direction (%.9f %.9f %.9f), want (%.9f %.9f %.9f)", d[0], d[1], d[2], x / n,
                 y / n, z / n);
}

/* The dome's map, made in memory (no file): SKY_MAP_WIDTH x SKY_MAP_HEIGHT RGB. */
static ts_image dome_map(const ts_scene *s)
{
    assert_non_null(s->dome.map);
    assert_true(s->dome.mapname[0] == '\0');
    assert_int_equal(s->dome.map_width, SKY_MAP_WIDTH);
    assert_int_equal(s->dome.map_height, SKY_MAP_HEIGHT);
    ts_image img = {.width = SKY_MAP_WIDTH,
                    .height = SKY_MAP_HEIGHT,
                    .channels = 3,
                    .channel_names = NULL,
                    .pixels = s->dome.map};
    return img;
}

/* The index of the dome map's brightest texel. */
static size_t map_brightest(const ts_scene *s)
{
    ts_image img = dome_map(s);
    size_t best = 0;
    for (size_t i = 0; i < (size_t)img.width * img.height; i++)
        if (img.pixels[i * img.channels + 1] > img.pixels[best * img.channels + 1]) best = i;
    return best;
}

static size_t texel_of(const double d[3])
{
    double th = acos(d[2]), ph = atan2(d[1], d[0]);
    if (ph < 0) ph += 2 * M_PI;
    return (size_t)(th / M_PI * SKY_MAP_HEIGHT) * SKY_MAP_WIDTH +
           (size_t)(ph / (2 * M_PI) * SKY_MAP_WIDTH);
}

/* sunDirection (month 0): the dome of intensity * 2^exposure with a map, and the sun there
 * with the disc's radiance; no warning. */
static void test_direction(void **state)
{
    (void)state;
    const char *text = "WorldBegin\nLight \"PxrEnvDayLight\" \"d\" \"float intensity\" [2e-5] "
                       "\"float exposure\" [1] \"vector sunDirection\" [0 2 2] "
                       "\"color sunTint\" [1 0.5 0.25] \"float haziness\" [3]\nWorldEnd\n";
    int rc;
    const char *out = test_rib_warnings(text, &rc);
    assert_int_equal(rc, TS_OK);
    if (out[0]) fail_msg("unexpected warnings: %s", out);
    ts_scene s;
    test_parse_rib_ok(text, &s);
    assert_true(s.dome.present);
    assert_true(fabs(s.dome.intensity - 4e-5) <= 1e-18);
    assert_int_equal(s.light_count, 1);
    const ts_scene_light *l = &s.lights[0];
    assert_int_equal(l->kind, SCENE_LIGHT_DISTANT);
    double d[3], rgb[3];
    sun_of(l, d);
    assert_dir(d, 0, 1, 1, 1e-12);
    assert_true(fabs(l->angle - SKY_SUN_DIAMETER_DEG) <= 1e-12);
    /* irradiance = radiance * pi sin^2 of the disc's half angle (a uniform cone facing the
     * surface), scaled by intensity * 2^exposure */
    double sh = sin(0.5 * SKY_SUN_DIAMETER_DEG * DEG);
    assert_true(fabs(l->intensity - 4e-5 * M_PI * sh * sh) <= 1e-12 * l->intensity);
    sky_sun_radiance(3, 45 * DEG, rgb, NULL);
    const double tint[3] = {1, 0.5, 0.25};
    for (int k = 0; k < 3; k++)
        assert_true(fabs(l->color[k] - tint[k] * rgb[k]) <= 1e-9 * rgb[k]);
    /* The sky's brightest texel is around the sun. */
    size_t best = map_brightest(&s), want = texel_of(d);
    assert_true(labs((long)(best / SKY_MAP_WIDTH) - (long)(want / SKY_MAP_WIDTH)) <= 1);
    assert_true(labs((long)(best % SKY_MAP_WIDTH) - (long)(want % SKY_MAP_WIDTH)) <= 1);
    scene_free(&s);
}

/* The CTM turns the light's space (z up) into the world's: a quarter turn of -90 degrees about
 * x (y -> -z, z -> y), as y-up scenes place it, puts the light's zenith on world +y; the sun
 * and the sky go with it, and the light's lower half (world y < 0) is the ground, black by
 * default. */
static void test_transform(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nAttributeBegin\nRotate -90 1 0 0\n"
                      "Light \"PxrEnvDayLight\" \"d\" \"vector sunDirection\" [0 -1 1] "
                      "\"float sunSize\" [2] \"float haziness\" [3]\nAttributeEnd\nWorldEnd\n",
                      &s);
    assert_int_equal(s.light_count, 1);
    double d[3];
    sun_of(&s.lights[0], d);
    assert_dir(d, 0, 1, 1, 1e-12);
    assert_true(fabs(s.lights[0].angle - 2 * SKY_SUN_DIAMETER_DEG) <= 1e-12);
    size_t best = map_brightest(&s), want = texel_of(d);
    assert_true(labs((long)(best / SKY_MAP_WIDTH) - (long)(want / SKY_MAP_WIDTH)) <= 1);
    assert_true(labs((long)(best % SKY_MAP_WIDTH) - (long)(want % SKY_MAP_WIDTH)) <= 1);
    ts_image img = dome_map(&s);
    const double up[3] = {0.1, 0.99, 0.1}, down[3] = {0.1, -0.99, 0.1};
    assert_true(img.pixels[texel_of(up) * img.channels + 2] > 0.0f);
    assert_true(img.pixels[texel_of(down) * img.channels + 0] == 0.0f);
    scene_free(&s);
}

/* A month (1-12) puts the sun where the date, hour, zone and place say, sunDirection
 * ignored: Seattle's solar noon on the June solstice, the sun due south (light space x east,
 * y north) at the elevation sky_solar_position gives (test_sky checks it: 65.8 degrees). */
static void test_date(void **state)
{
    (void)state;
    const char *fmt = "WorldBegin\nLight \"PxrEnvDayLight\" \"d\" \"vector sunDirection\" [%s] "
                      "\"int month\" [6] \"int day\" [21] \"int year\" [2014] \"float hour\" "
                      "[12.184] \"float zone\" [-8] \"float latitude\" [47.6062] "
                      "\"float longitude\" [-122.3321]\nWorldEnd\n";
    double e, a, want[3];
    assert_int_equal(sky_solar_position(2014, 6, 21, 12.184, -8, 47.6062, -122.3321, &e, &a), 0);
    assert_true(fabs(e - 65.83) < 0.5 && fabs(a - 180) < 1.0);
    sky_direction(e, a, want);
    for (int i = 0; i < 2; i++) {
        char text[512];
        snprintf(text, sizeof text, fmt, i ? "1 0 0" : "0 0 1");
        ts_scene s;
        test_parse_rib_ok(text, &s);
        assert_int_equal(s.light_count, 1);
        double d[3];
        sun_of(&s.lights[0], d);
        assert_dir(d, want[0], want[1], want[2], 1e-9);
        scene_free(&s);
    }
    /* The default place and date (Seattle, 20 November 2014, 14:38 PST) with month 11. */
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nLight \"PxrEnvDayLight\" \"d\" \"int month\" [11]\nWorldEnd\n",
                      &s);
    assert_int_equal(sky_solar_position(2014, 11, 20, 14.633333, -8, 47.6019, -122.3318, &e, &a),
                     0);
    sky_direction(e, a, want);
    double d[3];
    sun_of(&s.lights[0], d);
    assert_dir(d, want[0], want[1], want[2], 1e-9);
    scene_free(&s);
}

/* Night, a sunless sky, clamped haziness, groundMode: warnings; bad dates and sizes: errors. */
static void test_warnings_and_errors(void **state)
{
    (void)state;
    int rc;
    const char *out = test_rib_warnings(
        "WorldBegin\nLight \"PxrEnvDayLight\" \"d\" \"vector sunDirection\" [0 1 -0.2]\nWorldEnd\n",
        &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "w.rib:2:1: warning: Light \"PxrEnvDayLight\": the sun is below the "
                             "horizon; the sky is black (Preetham's model has no twilight)\n");
    ts_scene s;
    test_parse_rib_ok(
        "WorldBegin\nLight \"PxrEnvDayLight\" \"d\" \"vector sunDirection\" [0 1 -0.2]\nWorldEnd\n",
        &s);
    assert_int_equal(s.light_count, 0);
    assert_true(s.dome.present);
    scene_free(&s);
    out = test_rib_warnings("WorldBegin\nLight \"PxrEnvDayLight\" \"d\" \"float haziness\" [12] "
                            "\"int groundMode\" [1]\nWorldEnd\n",
                            &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "w.rib:2:50: warning: Light parameter \"groundMode\" is ignored\n"
                             "w.rib:2:1: warning: Light \"PxrEnvDayLight\": haziness is clamped "
                             "to the model's [1.7, 10]\n");
    /* sunTint 0 or sunSize 0: no sun, the sky alone. */
    test_parse_rib_ok("WorldBegin\nLight \"PxrEnvDayLight\" \"d\" \"color sunTint\" [0 0 0]\n"
                      "WorldEnd\n",
                      &s);
    assert_int_equal(s.light_count, 0), assert_true(s.dome.present);
    scene_free(&s);
    test_parse_rib_error(
        "WorldBegin\nLight \"PxrEnvDayLight\" \"d\" \"int month\" [2] "
        "\"int day\" [29] \"int year\" [2014]\nWorldEnd\n",
        "t.rib:2:1: error: Light \"PxrEnvDayLight\": no such date: year 2014, month 2, "
        "day 29 (month 0 uses sunDirection)");
    test_parse_rib_error(
        "WorldBegin\nLight \"PxrEnvDayLight\" \"d\" \"int month\" [13]\n"
        "WorldEnd\n",
        "t.rib:2:1: error: Light \"PxrEnvDayLight\": no such date: year 2014, month 13, "
        "day 20 (month 0 uses sunDirection)");
    test_parse_rib_error("WorldBegin\nLight \"PxrEnvDayLight\" \"d\" \"float sunSize\" [-1]\n"
                         "WorldEnd\n",
                         "t.rib:2:1: error: Light \"PxrEnvDayLight\": sunSize -1 is outside [0, "
                         "327.273)");
    test_parse_rib_error("WorldBegin\nLight \"PxrEnvDayLight\" \"d\" \"vector sunDirection\" "
                         "[0 0 0]\nWorldEnd\n",
                         "t.rib:2:1: error: Light \"PxrEnvDayLight\": sunDirection must not be 0");
}

/* A second dome: the daylight's sky is ignored with the usual warning, its sun still shines. */
static void test_second_dome(void **state)
{
    (void)state;
    const char *text = "WorldBegin\nLight \"PxrDomeLight\" \"a\"\n"
                       "Light \"PxrEnvDayLight\" \"d\"\nWorldEnd\n";
    int rc;
    const char *out = test_rib_warnings(text, &rc);
    assert_string_equal(out, "w.rib:3:1: warning: Light: a second dome light is ignored (one dome "
                             "per scene)\n");
    ts_scene s;
    test_parse_rib_ok(text, &s);
    assert_int_equal(s.light_count, 1);
    assert_true(s.dome.mapname[0] == '\0' && s.dome.intensity == 1.0);
    scene_free(&s);
}

/* RenderMan 20's AreaLightSource "PxrStdEnvDayLight" on Geometry "envsphere" stays a uniform
 * dome of intensity * 2^exposure, and says so. */
static void test_rm20_daylight(void **state)
{
    (void)state;
    const char *text = "WorldBegin\nAttributeBegin\nAreaLightSource \"PxrStdEnvDayLight\" 1 "
                       "\"float exposure\" [1]\nGeometry \"envsphere\"\nAttributeEnd\nWorldEnd\n";
    int rc;
    const char *out = test_rib_warnings(text, &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "w.rib:3:1: warning: AreaLightSource \"PxrStdEnvDayLight\" is drawn "
                             "as a uniform dome of intensity * 2^exposure (its sky and sun are "
                             "not; Light \"PxrEnvDayLight\" draws them)\n");
    ts_scene s;
    test_parse_rib_ok(text, &s);
    assert_true(s.dome.present && s.dome.mapname[0] == '\0');
    assert_true(s.dome.color[0] == 2.0 && s.dome.color[2] == 2.0);
    assert_int_equal(s.light_count, 0);
    scene_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_direction),   cmocka_unit_test(test_transform),
        cmocka_unit_test(test_date),        cmocka_unit_test(test_warnings_and_errors),
        cmocka_unit_test(test_second_dome), cmocka_unit_test(test_rm20_daylight),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
