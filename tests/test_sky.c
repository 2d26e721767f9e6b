/* test_sky.c — PxrEnvDayLight's daylight model (host/scene/sky.h), host only:
 * - the solar position against published values: the solstice declinations +-23.44 degrees
 *   (the obliquity of the ecliptic, 23.4366 degrees in 2014) give the noon elevation
 *   90 - |latitude -+ 23.44| at Seattle, Greenwich and Sydney; the equation of time (USNO /
 *   NOAA tables: -1.7 min on 21 June, +16.4 min on 3 November, about -7.5 min on 20 March)
 *   gives the time of solar noon; on the equator the 2014 March equinox sun (16:57 UTC)
 *   rises at the declination's -0.18 degree south of east; all within 0.5 degree (0.1 for
 *   the azimuth) or 2 minutes; dates that do not exist are refused;
 * - Preetham's sky against numbers computed separately from the paper's equations (a Python
 *   transcription of its appendix A.2 and section 3, not this code): zenith luminance and
 *   chromaticity, the Perez ratio Y / Y_z at the sun and opposite it, at two turbidities;
 *   then what the paper's model shows: brighter around the sun, a zenith luminance growing
 *   with turbidity, the clear sky's bright horizon band flattening as the haze grows;
 * - the sun's luminous transmittance (Rayleigh and aerosols, the paper's A.2) against the
 *   same separate transcription; the sun redder when low;
 * - the baked map: the sun's texel is the brightest, a rotation moves it, the ground below
 *   the horizon is albedo / pi times the irradiance, and the map's own cosine-weighted
 *   integral over the upper hemisphere is that irradiance. */
#include "scene/sky.h"

#include <math.h>
#include <stdlib.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#define DEG (M_PI / 180.0)

static void assert_close(double got, double want, double tol, const char *what)
{
    if (!(fabs(got - want) <= tol)) fail_msg("%s: got %.9g, want %.9g +- %g", what, got, want, tol);
}

/* The highest elevation of the day (1-second steps around noon) and its hour. */
static void solar_noon(int y, int m, int d, double zone, double lat, double lon, double *elev,
                       double *hour, double *azimuth)
{
    *elev = -90.0;
    for (double h = 10.0; h <= 14.5; h += 1.0 / 3600.0) {
        double e, a;
        assert_int_equal(sky_solar_position(y, m, d, h, zone, lat, lon, &e, &a), 0);
        if (e > *elev) *elev = e, *hour = h, *azimuth = a;
    }
}

static void test_solar_position(void **state)
{
    (void)state;
    const double obliquity = 23.4366;
    double e, h, a;
    /* Seattle, June solstice: noon at 12:00 - (eqtime + 4 lon - 60 zone) / 60 PST, the sun
     * due south at 90 - 47.6062 + 23.4366 degrees. */
    solar_noon(2014, 6, 21, -8, 47.6062, -122.3321, &e, &h, &a);
    assert_close(e, 90 - 47.6062 + obliquity, 0.5, "Seattle solstice noon elevation");
    assert_close(h, 12.0 - (-1.7 + 4 * -122.3321 + 480) / 60.0, 2.0 / 60, "Seattle solar noon");
    assert_close(a, 180.0, 0.5, "Seattle noon azimuth");
    /* Greenwich, December solstice. */
    solar_noon(2014, 12, 21, 0, 51.4769, 0.0, &e, &h, &a);
    assert_close(e, 90 - 51.4769 - obliquity, 0.5, "Greenwich winter noon elevation");
    assert_close(a, 180.0, 0.5, "Greenwich noon azimuth");
    /* Sydney, December solstice: the sun north of the zenith. */
    solar_noon(2014, 12, 21, 10, -33.8688, 151.2093, &e, &h, &a);
    assert_close(e, 90 - (33.8688 - obliquity), 0.5, "Sydney summer noon elevation");
    assert_close(fmod(a + 180.0, 360.0), 180.0, 0.5, "Sydney noon azimuth (north)");
    /* 3 November: the equation of time's largest, +16.4 minutes: noon at 11:43.6 UTC. */
    solar_noon(2014, 11, 3, 0, 0.0, 0.0, &e, &h, &a);
    assert_close(h, 12.0 - 16.4 / 60.0, 2.0 / 60, "solar noon on 3 November");
    /* The March equinox on the equator: noon overhead, sunrise due east at about 6:07. */
    solar_noon(2014, 3, 20, 0, 0.0, 0.0, &e, &h, &a);
    assert_close(e, 90.0, 0.5, "equinox noon on the equator");
    assert_close(h, 12.0 + 7.5 / 60.0, 2.0 / 60, "equinox solar noon");
    double rise = 0;
    for (double t = 5.0; t < 7.0 && !rise; t += 1.0 / 3600.0) {
        assert_int_equal(sky_solar_position(2014, 3, 20, t, 0, 0.0, 0.0, &e, &a), 0);
        if (e >= 0.0) rise = t;
    }
    assert_close(rise, 6.0 + 7.5 / 60.0, 2.0 / 60, "equinox sunrise");
    assert_close(a, 90.0 + 0.18, 0.1, "equinox sunrise azimuth (declination -0.18 deg)");
    /* The direction of (elevation, azimuth): x east, y north, z up. */
    double d[3];
    sky_direction(30.0, 90.0, d);
    assert_close(d[0], cos(30 * DEG), 1e-12, "east x"), assert_close(d[1], 0.0, 1e-12, "east y");
    assert_close(d[2], 0.5, 1e-12, "up");
    sky_direction(0.0, 180.0, d);
    assert_close(d[1], -1.0, 1e-12, "south");
    /* Dates that do not exist. */
    assert_int_equal(sky_solar_position(2014, 2, 29, 12, 0, 0, 0, &e, &a), -1);
    assert_int_equal(sky_solar_position(2016, 2, 29, 12, 0, 0, 0, &e, &a), 0);
    assert_int_equal(sky_solar_position(1900, 2, 29, 12, 0, 0, 0, &e, &a), -1);
    assert_int_equal(sky_solar_position(2014, 13, 1, 12, 0, 0, 0, &e, &a), -1);
    assert_int_equal(sky_solar_position(2014, 4, 31, 12, 0, 0, 0, &e, &a), -1);
}

/* Y / Y_z towards (theta, azimuth phi) with the sun at (theta_s, 0). */
static double sky_ratio(const ts_sky *s, double theta, double phi)
{
    double d[3] = {sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta)}, xyz[3];
    sky_xyz(s, d, xyz);
    return xyz[1] / s->zenith_y;
}

static ts_sky sky_at(double t, double theta_s)
{
    ts_sky s;
    double sun[3] = {sin(theta_s), 0.0, cos(theta_s)};
    sky_init(&s, t, sun);
    return s;
}

static void test_preetham(void **state)
{
    (void)state;
    /* Zenith luminance (cd/m^2) and chromaticity, from a separate transcription. */
    assert_close(sky_zenith_luminance(2, 30 * DEG), 5886.743249, 1e-5, "Y_z(T 2, 30 deg)");
    assert_close(sky_zenith_luminance(6, 60 * DEG), 9585.269810, 1e-5, "Y_z(T 6, 60 deg)");
    assert_close(sky_zenith_luminance(2, 60 * DEG), 3487.327440, 1e-5, "Y_z(T 2, 60 deg)");
    double xy[2];
    sky_zenith_chromaticity(2, 30 * DEG, xy);
    assert_close(xy[0], 0.2514214624, 1e-9, "x_z(T 2, 30 deg)");
    /* The Perez ratio F(theta_s, gamma) / F(0, theta_s) at the sun and opposite it (same
     * zenith angle, gamma = 2 theta_s), sun at 45 degrees. */
    ts_sky s2 = sky_at(2, 45 * DEG), s6 = sky_at(6, 45 * DEG);
    assert_close(sky_ratio(&s2, 45 * DEG, 0.0), 5.155356011, 1e-6, "T 2 at the sun");
    assert_close(sky_ratio(&s2, 45 * DEG, M_PI), 0.8976875630, 1e-6, "T 2 opposite");
    assert_close(sky_ratio(&s6, 45 * DEG, 0.0), 2.914617716, 1e-6, "T 6 at the sun");
    assert_close(sky_ratio(&s6, 45 * DEG, M_PI), 0.6069770525, 1e-6, "T 6 opposite");
    /* Brighter around the sun: 5 degrees from it beats every direction 90 degrees away. */
    for (int k = 0; k < 36; k++) {
        double phi = k * 10 * DEG;
        double d[3] = {sin(45 * DEG) * cos(phi), sin(45 * DEG) * sin(phi), cos(45 * DEG)};
        double g = acos(d[0] * s2.sun[0] + d[2] * s2.sun[2]);
        if (g > 60 * DEG)
            assert_true(sky_ratio(&s2, 40 * DEG, 0.0) > sky_ratio(&s2, 45 * DEG, phi));
    }
    /* The zenith brightens with haze; the clear sky's horizon band (85 degrees from the
     * zenith, 90 degrees of azimuth from the sun) flattens. */
    assert_true(sky_zenith_luminance(6, 30 * DEG) > sky_zenith_luminance(2, 30 * DEG));
    assert_close(sky_ratio(&s2, 85 * DEG, M_PI / 2), 3.376209327, 1e-6, "T 2 horizon / zenith");
    assert_close(sky_ratio(&s6, 85 * DEG, M_PI / 2), 0.6457393232, 1e-6, "T 6 horizon / zenith");
    double last = INFINITY;
    for (double t = 2; t <= 7; t += 1) { /* (it turns up slightly past T 8) */
        ts_sky s = sky_at(t, 45 * DEG);
        double r = sky_ratio(&s, 85 * DEG, M_PI / 2);
        assert_true(r < last);
        last = r;
    }
    /* Nothing below the horizon. */
    double down[3] = {0, 0.6, -0.8}, xyz[3];
    sky_xyz(&s2, down, xyz);
    assert_true(xyz[0] == 0 && xyz[1] == 0 && xyz[2] == 0);
}

static void test_sun(void **state)
{
    (void)state;
    double rgb[3], tau;
    const double want[4][3] = {
        {2, 0, 0.8204539743}, {2, 60, 0.6750850520}, {6, 0, 0.5536005825}, {6, 80, 0.03960909519}};
    for (int i = 0; i < 4; i++) {
        sky_sun_radiance(want[i][0], want[i][1] * DEG, rgb, &tau);
        assert_close(tau, want[i][2], 1e-6, "the sun's luminous transmittance");
        /* The colour's luminance is the disc's: 128 klx over 0.55 degrees' solid angle. */
        double l0 = SKY_SUN_ILLUMINANCE / (2 * M_PI * (1 - cos(0.275 * DEG)));
        assert_close((0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]) / l0, tau, 0.01 * tau,
                     "the sun's luminance");
    }
    /* Redder when low: R / B grows with the zenith angle. */
    double hi[3], lo[3];
    sky_sun_radiance(2, 20 * DEG, hi, NULL);
    sky_sun_radiance(2, 85 * DEG, lo, NULL);
    assert_true(lo[0] / lo[2] > 1.5 * hi[0] / hi[2]);
}

/* The texel whose centre is nearest the world direction d. */
static size_t texel_of(const double d[3])
{
    double th = acos(d[2]), ph = atan2(d[1], d[0]);
    if (ph < 0) ph += 2 * M_PI;
    size_t x = (size_t)(ph / (2 * M_PI) * SKY_MAP_WIDTH), y = (size_t)(th / M_PI * SKY_MAP_HEIGHT);
    return y * SKY_MAP_WIDTH + x;
}

static void test_bake(void **state)
{
    (void)state;
    float *rgb = malloc((size_t)SKY_MAP_WIDTH * SKY_MAP_HEIGHT * 3 * sizeof *rgb);
    assert_non_null(rgb);
    double sun[3];
    sky_direction(35.0, 120.0, sun);
    ts_sky s;
    sky_init(&s, 3.0, sun);
    sky_bake_args a = {.sky = &s,
                       .to_world = {1, 0, 0, 0, 1, 0, 0, 0, 1},
                       .sky_tint = {1, 1, 1},
                       .sun_rgb = {1e9, 1e9, 1e9},
                       .sun_solid_angle = 7e-5,
                       .ground = {0.5, 0.25, 0}};
    double lux = sky_bake(&a, rgb);
    /* The brightest texel is the sun's (its disc is not in the map: the circumsolar sky). */
    size_t best = 0, n = (size_t)SKY_MAP_WIDTH * SKY_MAP_HEIGHT;
    for (size_t i = 1; i < n; i++)
        if (rgb[3 * i + 1] > rgb[3 * best + 1]) best = i;
    size_t want = texel_of(sun);
    assert_true(best / SKY_MAP_WIDTH == want / SKY_MAP_WIDTH &&
                labs((long)(best % SKY_MAP_WIDTH) - (long)(want % SKY_MAP_WIDTH)) <= 1);
    /* The map's cosine-weighted integral over the upper hemisphere, plus the sun, is the
     * irradiance the ground reflects: ground = albedo / pi E. */
    double e[3] = {0, 0, 0};
    for (int y = 0; y < SKY_MAP_HEIGHT / 2; y++) {
        double th = (y + 0.5) * M_PI / SKY_MAP_HEIGHT;
        double w = cos(th) * sin(th) * (M_PI / SKY_MAP_HEIGHT) * (2 * M_PI / SKY_MAP_WIDTH);
        for (int x = 0; x < SKY_MAP_WIDTH; x++)
            for (int k = 0; k < 3; k++)
                e[k] += w * rgb[3 * ((size_t)y * SKY_MAP_WIDTH + x) + k];
    }
    for (int k = 0; k < 3; k++)
        e[k] += 1e9 * 7e-5 * sun[2];
    double lum = 0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2];
    assert_close(lum, lux, 0.01 * lux, "irradiance from the map");
    const float *g = &rgb[3 * (n - 1)];
    assert_close(g[0], 0.5 * e[0] / M_PI, 0.01 * g[0], "ground red");
    assert_close(g[1], 0.25 * e[1] / M_PI, 0.01 * g[1], "ground green");
    assert_true(g[2] == 0.0f);
    /* A quarter turn about world z (light x -> world y) moves the sun's texel with it. */
    sky_bake_args r = a;
    const double q[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
    for (int k = 0; k < 9; k++)
        r.to_world[k] = q[k];
    assert_close(sky_bake(&r, rgb), lux, 1e-9 * lux, "the rotated irradiance");
    best = 0;
    for (size_t i = 1; i < n; i++)
        if (rgb[3 * i + 1] > rgb[3 * best + 1]) best = i;
    double turned[3] = {-sun[1], sun[0], sun[2]};
    want = texel_of(turned);
    assert_true(best / SKY_MAP_WIDTH == want / SKY_MAP_WIDTH &&
                labs((long)(best % SKY_MAP_WIDTH) - (long)(want % SKY_MAP_WIDTH)) <= 1);
    free(rgb);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_solar_position),
        cmocka_unit_test(test_preetham),
        cmocka_unit_test(test_sun),
        cmocka_unit_test(test_bake),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
