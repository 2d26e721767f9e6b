/* test_lights.c — the light tables of host/pipeline/lights.c, as the shade kernel samples
 * them (kernels/lib/lights.h): emitter probabilities by power that sum to 1 with a CDF
 * ending at exactly 1, distant lights as cones of the right radiance and solid angle, and
 * the environment map's marginal and conditional CDFs. Host only: never skips. */
#include "pipeline/lights.h"
#include "lib/lights.h"

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

static void assert_near(double got, double want, double tol, const char *what)
{
    if (!(fabs(got - want) <= tol))
        fail_msg("%s: got %.9g, want %.9g (tol %g)", what, got, want, tol);
}

/* Patch p of cp: the flat rectangle [x0, x0 + sx] x [0, sy] at z = 0 as a Bézier patch
 * whose control points are evenly spaced, so dP/du = (sx, 0, 0), dP/dv = (0, sy, 0) and
 * its area is sx * sy. */
static void flat_patch(ts_vec4 *cp, uint32_t p, float x0, float sx, float sy)
{
    for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i)
            cp[p * 16 + j * 4 + i] = (ts_vec4){x0 + sx * i / 3.0f, sy * j / 3.0f, 0.0f, 1.0f};
}

/* Checks an emitter table: probabilities sum to 1, the CDF is non-decreasing, follows the
 * running sum and ends at exactly 1. */
static void assert_emitter_cdf(const ts_light_table *t)
{
    double sum = 0;
    for (uint32_t k = 0; k < t->emitter_count; ++k) {
        sum += t->emitters[k].prob;
        if (k > 0) assert_true(t->emitters[k].cdf >= t->emitters[k - 1].cdf);
        assert_near(t->emitters[k].cdf, sum, 1e-6, "cdf = running sum of prob");
    }
    assert_near(sum, 1.0, 1e-6, "sum of emitter probabilities");
    assert_true(t->emitters[t->emitter_count - 1].cdf == 1.0f);
}

static void test_emitters_by_power(void **state)
{
    (void)state;
    ts_vec4 cp[3 * 16];
    ts_patch_attr attr[3];
    memset(attr, 0, sizeof attr);
    attr[0].le_r = attr[0].le_g = attr[0].le_b = 1.0f;
    attr[2].le_g = 2.0f, attr[2].le_b = 0.5f;
    flat_patch(cp, 0, 0.0f, 1.0f, 1.0f); /* area 1, power 1 */
    flat_patch(cp, 1, 2.0f, 3.0f, 3.0f); /* does not emit */
    flat_patch(cp, 2, 6.0f, 2.0f, 1.0f); /* area 2, brightest channel 2: power 4 */
    ts_scene s = {.patch_count = 3, .cp = cp, .attr = attr};
    ts_light_table t;
    ts_error err = {0};
    assert_int_equal(lights_build(&s, NULL, attr, &t, &err), TS_OK);
    assert_int_equal(t.light_count, 1);
    assert_int_equal(t.lights[0].type, TS_LIGHT_AREA);
    assert_int_equal(t.lights[0].emitter_count, 2);
    assert_int_equal(t.emitter_count, 2);
    assert_int_equal(attr[0].emitter, 0);
    assert_int_equal(attr[1].emitter, TS_INVALID);
    assert_int_equal(attr[2].emitter, 1);
    assert_int_equal(t.emitters[0].patch, 0);
    assert_int_equal(t.emitters[1].patch, 2);
    assert_near(t.emitters[0].area, 1.0, 1e-6, "area of the unit square");
    assert_near(t.emitters[1].area, 2.0, 1e-6, "area of the 2 x 1 rectangle");
    assert_near(t.emitters[0].prob, 0.2, 1e-6, "prob of power 1 of 5");
    assert_near(t.emitters[1].prob, 0.8, 1e-6, "prob of power 4 of 5");
    assert_emitter_cdf(&t);
    lights_free(&t);
}

static void test_many_emitters_cdf_ends_at_one(void **state)
{
    (void)state;
    enum { N = 37 };
    static ts_vec4 cp[N * 16];
    ts_patch_attr attr[N];
    memset(attr, 0, sizeof attr);
    uint32_t seed = 12345;
    for (uint32_t p = 0; p < N; ++p) {
        seed = seed * 1664525u + 1013904223u;
        float size = 0.1f + (float)(seed >> 8) / 16777216.0f;
        flat_patch(cp, p, 3.0f * p, size, 0.7f * size);
        attr[p].le_r = (float)(p % 5) * 0.3f; /* every fifth patch does not emit */
        attr[p].le_b = (float)(p % 5) * 0.1f;
    }
    ts_scene s = {.patch_count = N, .cp = cp, .attr = attr};
    ts_light_table t;
    ts_error err = {0};
    assert_int_equal(lights_build(&s, NULL, attr, &t, &err), TS_OK);
    assert_int_equal(t.emitter_count, N - (N + 4) / 5);
    assert_emitter_cdf(&t);
    for (uint32_t k = 0; k < t.emitter_count; ++k) {
        uint32_t p = t.emitters[k].patch;
        assert_int_equal(attr[p].emitter, k);
        double want = t.emitters[k].area * attr[p].le_r /
                      (t.emitters[0].area * attr[t.emitters[0].patch].le_r);
        assert_near(t.emitters[k].prob / t.emitters[0].prob, want, 1e-5 * want,
                    "prob ratio = power ratio");
    }
    lights_free(&t);
}

/* 41 emitters of equal power: each prob is the float nearest 1/41, and their running sum
 * misses 1 by more than float rounding hides; the table's last cdf is 1 all the same. */
static void test_equal_emitters_cdf_ends_at_one(void **state)
{
    (void)state;
    enum { N = 41 };
    static ts_vec4 cp[N * 16];
    ts_patch_attr attr[N];
    memset(attr, 0, sizeof attr);
    double sum = 0;
    for (uint32_t p = 0; p < N; ++p) {
        flat_patch(cp, p, 0.0f, 1.0f, 1.0f);
        attr[p].le_g = 1.0f;
    }
    ts_scene s = {.patch_count = N, .cp = cp, .attr = attr};
    ts_light_table t;
    ts_error err = {0};
    assert_int_equal(lights_build(&s, NULL, attr, &t, &err), TS_OK);
    assert_int_equal(t.emitter_count, N);
    for (uint32_t k = 0; k < N; ++k) {
        assert_true(t.emitters[k].prob == (float)(1.0 / N));
        sum += t.emitters[k].prob;
    }
    assert_true((float)sum != 1.0f); /* what the last entry would be without the fix-up */
    assert_emitter_cdf(&t);
    lights_free(&t);
}

static void test_no_emitter(void **state)
{
    (void)state;
    ts_scene s = {0};
    ts_light_table t;
    ts_error err = {0};
    assert_int_equal(lights_build(&s, NULL, NULL, &t, &err), TS_OK);
    assert_int_equal(t.light_count, 0);
    assert_int_equal(t.emitter_count, 0);
    assert_non_null(t.emitters); /* one zeroed entry, uploaded as is */
    lights_free(&t);
}

static void test_distant_lights_and_dome(void **state)
{
    (void)state;
    const double a = 2.0, h = 0.5 * a * M_PI / 180.0; /* angular diameter, half angle */
    ts_scene_light d[2] = {
        {.from = {-1, 1, -1},
         .to = {0, 0, 0},
         .intensity = 2.5,
         .color = {1, 0.95, 0.85},
         .angle = a},
        {.from = {0, 0, 5}, .to = {0, 0, 1}, .intensity = 3.0, .color = {1, 1, 1}, .angle = 0.0},
    };
    ts_scene s = {.lights = d, .light_count = 2};
    s.dome = (ts_dome_light){.present = 1, .intensity = 0.35, .color = {0.8, 0.9, 1}};
    ts_env_map env = {.width = 32, .height = 16};
    ts_light_table t;
    ts_error err = {0};
    assert_int_equal(lights_build(&s, &env, NULL, &t, &err), TS_OK);
    assert_int_equal(t.light_count, 3);
    /* The sun: a cone of half angle a / 2 towards from - to. */
    const ts_light *sun = &t.lights[0];
    assert_int_equal(sun->type, TS_LIGHT_DISTANT);
    double r3 = 1.0 / sqrt(3.0);
    assert_near(sun->dir[0], -r3, 1e-7, "sun dir x");
    assert_near(sun->dir[1], r3, 1e-7, "sun dir y");
    assert_near(sun->dir[2], -r3, 1e-7, "sun dir z");
    assert_near(sun->cos_max, cos(h), 1e-7, "cos of the half angle");
    assert_near(sun->solid_angle, 2 * M_PI * (1 - cos(h)), 1e-6 * 2 * M_PI * (1 - cos(h)),
                "solid angle 2 pi (1 - cos(a/2))");
    for (int k = 0; k < 3; ++k) {
        double e = 2.5 * d[0].color[k], l = e / (M_PI * sin(h) * sin(h));
        assert_near(sun->radiance[k], l, 1e-6 * l, "radiance E / (pi sin^2(a/2))");
        /* The cone gives the irradiance E at normal incidence: L pi sin^2(a/2) = E. */
        assert_near(sun->radiance[k] * M_PI * sin(h) * sin(h), e, 1e-6 * e, "irradiance");
    }
    /* Angle 0: a delta light of irradiance E along +z. */
    const ts_light *delta = &t.lights[1];
    assert_int_equal(delta->type, TS_LIGHT_DISTANT);
    assert_true(delta->cos_max == 1.0f && delta->solid_angle == 0.0f);
    assert_true(delta->dir[0] == 0.0f && delta->dir[1] == 0.0f && delta->dir[2] == 1.0f);
    for (int k = 0; k < 3; ++k)
        assert_near(delta->radiance[k], 3.0, 1e-7, "delta light irradiance");
    /* The dome last, with its map's size. */
    const ts_light *dome = &t.lights[2];
    assert_int_equal(dome->type, TS_LIGHT_DOME);
    assert_int_equal(dome->map_width, 32);
    assert_int_equal(dome->map_height, 16);
    for (int k = 0; k < 3; ++k)
        assert_near(dome->radiance[k], 0.35 * s.dome.color[k], 1e-7, "dome radiance");
    lights_free(&t);
}

/* Light selection (lib/lights.h, issue 14): the probabilities of the lights that take part
 * sum to 1, a uniform dome (and the ambient one) takes part only under --sampling light, the
 * weights are the lights' luminance contributions (a sun E / pi, a point light I / (pi d^2),
 * the dome L), and light_select picks each light as often as light_select_prob says
 * (stratified u: within 2 / N), with every kind of light in the list. */
static void test_light_selection(void **state)
{
    (void)state;
    ts_vec4 cp[16];
    ts_patch_attr attr[1];
    memset(attr, 0, sizeof attr);
    attr[0].le_r = attr[0].le_g = attr[0].le_b = 4.0f;
    flat_patch(cp, 0, 0.0f, 1.0f, 1.0f);
    ts_scene_light d[5] = {
        {.from = {-1, 1, -1},
         .to = {0, 0, 0},
         .intensity = 2.5,
         .color = {1, 0.95, 0.85},
         .angle = 2.0},
        {.from = {0, 0, 5}, .to = {0, 0, 1}, .intensity = 1.0, .color = {1, 1, 1}, .angle = 0.0},
        {.from = {0.5, 0.5, 2},
         .intensity = 3,
         .color = {1, 1, 1},
         .kind = SCENE_LIGHT_POINT,
         .falloff = 2,
         .falloff_dist = 1},
        {.from = {0, 0, 3},
         .to = {0, 0, 0},
         .intensity = 5,
         .color = {1, 1, 1},
         .kind = SCENE_LIGHT_SPOT,
         .cone_angle = 0.4,
         .cone_delta = 0.1,
         .beam = 2,
         .falloff = 2,
         .falloff_dist = 1},
        {.intensity = 0.1, .color = {1, 1, 1}, .kind = SCENE_LIGHT_AMBIENT},
    };
    ts_scene s = {.patch_count = 1, .cp = cp, .attr = attr, .lights = d, .light_count = 5};
    s.dome = (ts_dome_light){.present = 1, .intensity = 0.35, .color = {1, 1, 1}};
    ts_light_table t;
    ts_error err = {0};
    assert_int_equal(lights_build(&s, NULL, attr, &t, &err), TS_OK);
    /* 2 suns, the point and spot lights, the dome, the ambient dome, the area light */
    assert_int_equal(t.light_count, 7);
    double lum = 0.2126 * 1 + 0.7152 * 0.95 + 0.0722 * 0.85;
    assert_near(t.lights[0].weight, 2.5 * lum / M_PI, 1e-6, "sun weight E / pi");
    assert_near(t.lights[1].weight, 1.0 / M_PI, 1e-6, "delta sun weight E / pi");
    /* The point light 2 from the box's centre (0.5, 0.5, 0); the spot 3. */
    assert_near(t.lights[2].weight, 3.0 / (M_PI * 4), 1e-5, "point weight I / (pi d^2)");
    assert_near(t.lights[3].weight, 5.0 / (M_PI * (9 + 0.5)), 1e-5, "spot weight I / (pi d^2)");
    assert_near(t.lights[4].weight, 0.35, 1e-6, "dome weight L");
    assert_near(t.lights[5].weight, 0.1, 1e-6, "ambient weight L");
    assert_true(t.lights[6].weight > 0.0f);
    const ts_u32 modes[2] = {TS_SAMPLING_MIS, TS_SAMPLING_LIGHT};
    enum { N = 100000 };
    for (int m = 0; m < 2; ++m) {
        double sum = 0;
        for (ts_u32 i = 0; i < t.light_count; ++i)
            sum += light_select_prob(t.lights, t.light_count, modes[m], i);
        assert_near(sum, 1.0, 1e-6, "selection probabilities sum to 1");
        for (ts_u32 i = 4; i <= 5; ++i) { /* the uniform domes */
            float dome = light_select_prob(t.lights, t.light_count, modes[m], i);
            assert_true(m == 0 ? dome == 0.0f : dome > 0.0f);
        }
        uint32_t count[7] = {0, 0, 0, 0, 0, 0, 0};
        for (int k = 0; k < N; ++k) {
            float prob;
            ts_u32 li = light_select(t.lights, t.light_count, modes[m], (k + 0.5f) / N, &prob);
            assert_true(li < t.light_count);
            assert_near(prob, light_select_prob(t.lights, t.light_count, modes[m], li), 1e-7,
                        "the probability returned is the light's");
            count[li]++;
        }
        for (ts_u32 i = 0; i < t.light_count; ++i)
            assert_near((double)count[i] / N,
                        light_select_prob(t.lights, t.light_count, modes[m], i), 2.0 / N + 1e-5,
                        "chosen as often as its probability");
    }
    /* No light takes part (a uniform dome alone, MIS): nothing is chosen. */
    ts_scene dome_only = {0};
    dome_only.dome = s.dome;
    lights_free(&t);
    assert_int_equal(lights_build(&dome_only, NULL, NULL, &t, &err), TS_OK);
    float prob = 1.0f;
    assert_int_equal(light_select(t.lights, t.light_count, TS_SAMPLING_MIS, 0.5f, &prob),
                     t.light_count);
    assert_true(prob == 0.0f);
    lights_free(&t);
}

static void test_too_many_lights(void **state)
{
    (void)state;
    ts_scene_light d[TS_MAX_SCENE_LIGHTS + 2];
    for (uint32_t i = 0; i <= TS_MAX_SCENE_LIGHTS; ++i)
        d[i] = (ts_scene_light){
            .from = {0, 0, 1}, .to = {0, 0, 0}, .intensity = 1, .color = {1, 1, 1}, .angle = 0};
    d[TS_MAX_SCENE_LIGHTS + 1] = (ts_scene_light){.intensity = 1, .kind = SCENE_LIGHT_AMBIENT};
    ts_scene s = {.lights = d, .light_count = TS_MAX_SCENE_LIGHTS};
    ts_light_table t;
    ts_error err = {0};
    assert_int_equal(lights_build(&s, NULL, NULL, &t, &err), TS_OK);
    assert_int_equal(t.light_count, TS_MAX_SCENE_LIGHTS);
    lights_free(&t);
    s.light_count = TS_MAX_SCENE_LIGHTS + 1;
    assert_int_equal(lights_build(&s, NULL, NULL, &t, &err), TS_E_SCENE);
    assert_string_equal(err.msg, "257 distant, point and spot lights: at most 256");
    lights_free(&t);
    /* Ambient lights do not count: they add up into one dome. */
    d[TS_MAX_SCENE_LIGHTS] = d[TS_MAX_SCENE_LIGHTS + 1];
    s.light_count = TS_MAX_SCENE_LIGHTS + 2;
    assert_int_equal(lights_build(&s, NULL, NULL, &t, &err), TS_OK);
    assert_int_equal(t.light_count, TS_MAX_SCENE_LIGHTS + 1);
    lights_free(&t);
}

/* RenderMan's spotlight.sl, in double: what a spot light at the origin with unit axis `axis`
 * gives at point q (irradiance on a surface facing it, per unit intensity). */
static double spotlight_sl(const double axis[3], double cone, double delta, double beam,
                           const double q[3])
{
    double d2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2], d = sqrt(d2);
    double c = (q[0] * axis[0] + q[1] * axis[1] + q[2] * axis[2]) / d;
    if (c < cos(cone)) return 0.0; /* illuminate(from, A, coneangle) */
    double a = cos(cone), b = cos(cone - delta), t = (c - a) / (b - a);
    double smooth = c >= b ? 1.0 : t * t * (3 - 2 * t);
    return pow(c, beam) / d2 * smooth;
}

/* Point and spot lights (RenderMan's pointlight and spotlight): the table keeps position,
 * intensity, axis and cone; light_sample gives a delta sample towards the light whose value
 * is I / d^2 (times the spot's beam and smoothstep edge, 0 outside the cone) to within float
 * rounding of the formula evaluated in double; the weight is I falloff(d) / pi at the typical
 * distance (the light's distance to the scene's box centre, or half its diagonal). */
static void test_point_and_spot_lights(void **state)
{
    (void)state;
    ts_vec4 cp[16];
    ts_patch_attr attr[1];
    memset(attr, 0, sizeof attr);
    flat_patch(cp, 0, -1.0f, 2.0f, 2.0f); /* [-1, 1] x [0, 2] at z = 0: half diagonal sqrt 2 */
    const double cone = 0.5, delta = 0.15, beam = 2.0;
    ts_scene_light d[2] = {
        {.from = {0.5, 1, 3},
         .intensity = 6,
         .color = {1, 0.5, 0.25},
         .kind = SCENE_LIGHT_POINT,
         .falloff = 2,
         .falloff_dist = 1},
        {.from = {0, 1, 40},
         .to = {0, 1.5, 37},
         .intensity = 900,
         .color = {1, 1, 1},
         .kind = SCENE_LIGHT_SPOT,
         .cone_angle = cone,
         .cone_delta = delta,
         .beam = beam,
         .falloff = 2,
         .falloff_dist = 1},
    };
    ts_scene s = {.patch_count = 1, .cp = cp, .attr = attr, .lights = d, .light_count = 2};
    ts_light_table t;
    ts_error err = {0};
    assert_int_equal(lights_build(&s, NULL, attr, &t, &err), TS_OK);
    assert_int_equal(t.light_count, 2);
    const ts_light *pt = &t.lights[0], *sp = &t.lights[1];
    assert_int_equal(pt->type, TS_LIGHT_POINT);
    assert_int_equal(sp->type, TS_LIGHT_SPOT);
    assert_true(pt->pos[0] == 0.5f && pt->pos[1] == 1.0f && pt->pos[2] == 3.0f);
    assert_true(pt->radiance[0] == 6.0f && pt->radiance[1] == 3.0f && pt->radiance[2] == 1.5f);
    double len = sqrt(0.25 + 9.0);
    assert_near(sp->dir[1], 0.5 / len, 1e-7, "spot axis y");
    assert_near(sp->dir[2], -3.0 / len, 1e-7, "spot axis z");
    assert_near(sp->cos_max, cos(cone), 1e-7, "cos(coneangle)");
    assert_near(sp->cos_inner, cos(cone - delta), 1e-7, "cos(coneangle - conedeltaangle)");
    /* Weights: the point light sits near the box (box centre (0, 1, 0) at distance sqrt(9.25)
     * > sqrt 2), the spot 40 away. */
    double box_margin = 1e-4; /* scene_patch_box grows the box by a few ulps */
    double lum = 0.2126 * 1 + 0.7152 * 0.5 + 0.0722 * 0.25;
    assert_near(pt->weight, 6 * lum / (M_PI * 9.25), box_margin, "point weight I / (pi d^2)");
    assert_near(sp->weight, 900 / (M_PI * 1600), box_margin, "spot weight I / (pi d^2)");
    /* Samples from points on and off the plane, inside, on the edge of and outside the cone. */
    /* Two points inside the spot's full cone (0.35 rad), three on its soft edge, three
     * outside (behind the spot too). */
    const double pts[][3] = {{0, 1, 0},    {0.3, 2, 0.1}, {0, -12, 0}, {20, 1, 0},
                             {-15, -3, 0}, {-25, 0, 0},   {30, 30, 1}, {0, 1, 45}};
    double axis[3] = {0, 0.5 / len, -3.0 / len};
    int inside = 0, edge = 0, outside = 0;
    for (size_t k = 0; k < sizeof pts / sizeof pts[0]; ++k) {
        ts_v3 p = v3((float)pts[k][0], (float)pts[k][1], (float)pts[k][2]), n = v3(0, 0, 1);
        ts_light_sample ls = light_sample(t.lights, 0, 0.25f, (ts_env){0}, t.emitters, cp, attr, p,
                                          n, 0.3f, 0.6f, 0.9f);
        double to[3] = {0.5 - pts[k][0], 1 - pts[k][1], 3 - pts[k][2]};
        double d2 = to[0] * to[0] + to[1] * to[1] + to[2] * to[2];
        assert_true(ls.delta && ls.pdf == 0.25f && ls.patch == TS_INVALID);
        assert_near(ls.dist, sqrt(d2), 1e-6 * sqrt(d2), "distance to the point light");
        assert_near(ls.dir.x, to[0] / sqrt(d2), 1e-6, "direction to the point light");
        for (int c = 0; c < 3; ++c)
            assert_near(ls.le[c], 6 * d[0].color[c] / d2, 1e-6 * 6 / d2, "point: I / d^2");
        ls = light_sample(t.lights, 1, 0.5f, (ts_env){0}, t.emitters, cp, attr, p, n, 0.3f, 0.6f,
                          0.9f);
        double q[3] = {pts[k][0] - 0, pts[k][1] - 1, pts[k][2] - 40};
        double want = 900 * spotlight_sl(axis, cone, delta, beam, q);
        double c = (q[0] * axis[0] + q[1] * axis[1] + q[2] * axis[2]) /
                   sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
        inside += c > cos(cone - delta), outside += c < cos(cone);
        edge += c <= cos(cone - delta) && c >= cos(cone);
        if (want == 0.0) {
            assert_true(ls.pdf == 0.0f); /* no light sample outside the cone */
            continue;
        }
        assert_true(ls.delta && ls.pdf == 0.5f);
        /* float cosines: the smoothstep's slope ~ 1 / (cos(cone - delta) - cos(cone)) */
        assert_near(ls.le[0], want, 2e-5 * want / (cos(cone - delta) - cos(cone)),
                    "spot: I cos^beam smoothstep / d^2");
    }
    assert_true(inside == 2 && edge == 3 && outside == 3);
    lights_free(&t);
}

/* A falloff other than 1 / d^2 (uberlight): (d0 / max(d, dmin))^k, and none at all (k = 0). */
static void test_light_falloff(void **state)
{
    (void)state;
    ts_scene_light d[2] = {
        {.from = {0, 0, 0},
         .intensity = 2,
         .color = {1, 1, 1},
         .kind = SCENE_LIGHT_POINT,
         .falloff = 1,
         .falloff_dist = 3,
         .falloff_min = 3},
        {.from = {0, 0, 0},
         .intensity = 2,
         .color = {1, 1, 1},
         .kind = SCENE_LIGHT_POINT,
         .falloff = 0,
         .falloff_dist = 1},
    };
    ts_scene s = {.lights = d, .light_count = 2};
    ts_light_table t;
    ts_error err = {0};
    assert_int_equal(lights_build(&s, NULL, NULL, &t, &err), TS_OK);
    const float dist[] = {0.5f, 3.0f, 12.0f};
    for (int k = 0; k < 3; ++k) {
        ts_v3 p = v3(0, dist[k], 0);
        ts_light_sample a = light_sample(t.lights, 0, 1.0f, (ts_env){0}, t.emitters, NULL, NULL, p,
                                         v3(0, -1, 0), 0, 0, 0);
        ts_light_sample b = light_sample(t.lights, 1, 1.0f, (ts_env){0}, t.emitters, NULL, NULL, p,
                                         v3(0, -1, 0), 0, 0, 0);
        assert_near(a.le[0], 2 * 3 / fmax(dist[k], 3), 1e-6, "linear falloff, held near");
        assert_near(b.le[0], 2, 1e-7, "no falloff");
    }
    lights_free(&t);
}

/* Ambient lights add up into one uniform dome, after the domelight, that eye rays do not see
 * (light_escape with eye = 1) and every other ray does; its weight is L. */
static void test_ambient_lights(void **state)
{
    (void)state;
    ts_scene_light d[3] = {
        {.intensity = 0.2, .color = {1, 1, 1}, .kind = SCENE_LIGHT_AMBIENT},
        {.from = {0, 0, 1}, .to = {0, 0, 0}, .intensity = 1, .color = {1, 1, 1}},
        {.intensity = 0.5, .color = {0.2, 0.4, 0.6}, .kind = SCENE_LIGHT_AMBIENT},
    };
    ts_scene s = {.lights = d, .light_count = 3};
    s.dome = (ts_dome_light){.present = 1, .intensity = 0.1, .color = {1, 1, 1}};
    ts_light_table t;
    ts_error err = {0};
    assert_int_equal(lights_build(&s, NULL, NULL, &t, &err), TS_OK);
    assert_int_equal(t.light_count, 3); /* the sun, the dome, the ambient dome */
    const ts_light *amb = &t.lights[2];
    assert_int_equal(amb->type, TS_LIGHT_DOME);
    assert_int_equal(amb->flags, TS_LIGHT_NOT_SEEN);
    assert_int_equal(amb->map_width, 0);
    const double want[3] = {0.3, 0.4, 0.5};
    for (int k = 0; k < 3; ++k)
        assert_near(amb->radiance[k], want[k], 1e-7, "ambient radiance: the sum");
    assert_near(amb->weight, 0.2126 * 0.3 + 0.7152 * 0.4 + 0.0722 * 0.5, 1e-7, "weight L");
    assert_int_equal(t.lights[1].flags, 0u);
    float le[3], pdf;
    light_escape(t.lights, t.light_count, TS_SAMPLING_MIS, (ts_env){0}, v3(0, 1, 0), 1, le, &pdf);
    assert_near(le[0], 0.1, 1e-7, "an eye ray sees the dome only");
    light_escape(t.lights, t.light_count, TS_SAMPLING_MIS, (ts_env){0}, v3(0, 1, 0), 0, le, &pdf);
    assert_near(le[0], 0.4, 1e-7, "a bounce ray sees the dome and the ambient light");
    assert_near(le[2], 0.6, 1e-7, "a bounce ray sees the dome and the ambient light");
    /* Under --sampling light both uniform domes take part, with the sun: probabilities sum
     * to 1. */
    double sum = 0;
    for (ts_u32 i = 0; i < t.light_count; ++i)
        sum += light_select_prob(t.lights, t.light_count, TS_SAMPLING_LIGHT, i);
    assert_near(sum, 1.0, 1e-6, "selection probabilities sum to 1");
    lights_free(&t);
}

/* An image of w x h with `channels` channels, every value v. */
static float *fill_image(ts_image *img, int w, int h, int channels, float v)
{
    float *px = malloc((size_t)w * h * channels * sizeof *px);
    assert_non_null(px);
    for (size_t i = 0; i < (size_t)w * h * channels; ++i)
        px[i] = v;
    *img = (ts_image){.width = w, .height = h, .channels = channels, .pixels = px};
    return px;
}

/* Every CDF of the map is non-decreasing and ends at exactly 1. */
static void assert_env_cdfs(const ts_env_map *e)
{
    for (uint32_t y = 0; y < e->height; ++y) {
        const float *row = e->conditional + (size_t)y * e->width;
        for (uint32_t x = 1; x < e->width; ++x)
            assert_true(row[x] >= row[x - 1]);
        assert_true(row[e->width - 1] == 1.0f);
        if (y > 0) assert_true(e->marginal[y] >= e->marginal[y - 1]);
    }
    assert_true(e->marginal[e->height - 1] == 1.0f);
}

static void test_env_constant_map_is_uniform(void **state)
{
    (void)state;
    enum { W = 128, H = 64 };
    ts_image img;
    float *px = fill_image(&img, W, H, 3, 2.0f);
    ts_env_map e;
    ts_error err = {0};
    assert_int_equal(env_map_from_image(&img, &e, &err), TS_OK);
    assert_int_equal(e.width, W);
    assert_int_equal(e.height, H);
    assert_env_cdfs(&e);
    assert_true(e.texels[5].x == 2.0f && e.texels[5].y == 2.0f && e.texels[5].z == 2.0f);
    /* Within a row: uniform over the columns. */
    for (uint32_t y = 0; y < H; y += 7)
        for (uint32_t x = 0; x < W; ++x)
            assert_near(e.conditional[(size_t)y * W + x], (x + 1.0) / W, 1e-6, "conditional");
    /* Over rows: by sin(theta), which is uniform over the sphere. */
    double total = 0, acc = 0;
    for (uint32_t y = 0; y < H; ++y)
        total += sin(M_PI * (y + 0.5) / H);
    for (uint32_t y = 0; y < H; ++y) {
        acc += sin(M_PI * (y + 0.5) / H);
        assert_near(e.marginal[y], acc / total, 1e-6, "marginal");
    }
    /* So the density of every direction (lib/lights.h env_lookup: p(texel) W H /
     * (2 pi^2 sin theta)) is the uniform sphere's 1 / 4 pi, up to the midpoint rule's
     * error in the sum of sin(theta) (pi^2 / 24 H^2). */
    for (uint32_t y = 0; y < H; y += 9) {
        double pr = e.marginal[y] - (y ? e.marginal[y - 1] : 0.0f);
        double pc = e.conditional[(size_t)y * W];
        double pdf = pr * pc * W * H / (2 * M_PI * M_PI * sin(M_PI * (y + 0.5) / H));
        assert_near(pdf, 1 / (4 * M_PI), 1e-3 / (4 * M_PI), "density of a constant map");
    }
    env_map_free(&e);
    free(px);
}

static void test_env_bright_texel_owns_the_jump(void **state)
{
    (void)state;
    enum { W = 16, H = 8, BX = 5, BY = 3 };
    ts_image img;
    float *px = fill_image(&img, W, H, 3, 0.0f);
    for (int c = 0; c < 3; ++c)
        px[((size_t)BY * W + BX) * 3 + c] = 10.0f;
    ts_env_map e;
    ts_error err = {0};
    assert_int_equal(env_map_from_image(&img, &e, &err), TS_OK);
    assert_env_cdfs(&e);
    /* The marginal is 0 before the bright row and 1 from it on (to float rounding of the
     * running sum): all of its jump is in that row. */
    for (uint32_t y = 0; y < H; ++y)
        if (y < BY)
            assert_true(e.marginal[y] == 0.0f);
        else
            assert_near(e.marginal[y], 1.0, 1e-7, "marginal from the bright row on");
    /* In that row, all of the conditional's jump is at the bright column. */
    for (uint32_t x = 0; x < W; ++x)
        if (x < BX)
            assert_true(e.conditional[BY * W + x] == 0.0f);
        else
            assert_near(e.conditional[BY * W + x], 1.0, 1e-7, "conditional from the column on");
    /* Rows without weight are uniform (never sampled, but still valid CDFs). */
    for (uint32_t x = 0; x < W; ++x)
        assert_near(e.conditional[0 * W + x], (x + 1.0) / W, 1e-7, "black row");
    env_map_free(&e);
    free(px);
}

static void test_env_black_and_invalid_texels(void **state)
{
    (void)state;
    enum { W = 8, H = 4 };
    ts_image img;
    float *px = fill_image(&img, W, H, 1, 0.0f); /* one channel: grey */
    px[1 * W + 2] = NAN;
    px[2 * W + 3] = -1.0f;
    px[3 * W + 4] = INFINITY;
    ts_env_map e;
    ts_error err = {0};
    assert_int_equal(env_map_from_image(&img, &e, &err), TS_OK);
    assert_env_cdfs(&e);
    /* Invalid texels are black, so the map has no weight: uniform CDFs everywhere. */
    assert_true(e.texels[1 * W + 2].x == 0.0f && e.texels[2 * W + 3].y == 0.0f &&
                e.texels[3 * W + 4].z == 0.0f);
    for (uint32_t y = 0; y < H; ++y)
        assert_near(e.marginal[y], (y + 1.0) / H, 1e-7, "uniform marginal");
    env_map_free(&e);
    /* Grey from the one channel. */
    px[0] = 0.5f;
    assert_int_equal(env_map_from_image(&img, &e, &err), TS_OK);
    assert_true(e.texels[0].x == 0.5f && e.texels[0].y == 0.5f && e.texels[0].z == 0.5f);
    assert_near(e.marginal[0], 1.0, 1e-7, "marginal of the one lit row");
    assert_near(e.conditional[0], 1.0, 1e-7, "conditional of the one lit texel");
    env_map_free(&e);
    free(px);
}

/* Random maps of 16 sizes: every CDF ends at exactly 1 (where the normalised running sums
 * alone would often end a float below it), and each row's share of the marginal is its
 * luminance times sin(theta). */
static void test_env_random_maps_cdfs_end_at_one(void **state)
{
    (void)state;
    uint32_t seed = 99;
    for (int w = 5; w < 21; ++w) {
        int h = 3 + w % 7;
        ts_image img;
        float *px = fill_image(&img, w, h, 3, 0.0f);
        for (size_t i = 0; i < (size_t)w * h * 3; ++i) {
            seed = seed * 1664525u + 1013904223u;
            px[i] = (float)(seed >> 8) / 16777216.0f * 3.7f;
        }
        ts_env_map e;
        ts_error err = {0};
        assert_int_equal(env_map_from_image(&img, &e, &err), TS_OK);
        assert_env_cdfs(&e);
        double row[16], total = 0;
        for (int y = 0; y < h; ++y) {
            row[y] = 0;
            for (int x = 0; x < w; ++x) {
                const float *t = &px[((size_t)y * w + x) * 3];
                row[y] += 0.2126 * t[0] + 0.7152 * t[1] + 0.0722 * t[2];
            }
            row[y] *= sin(M_PI * (y + 0.5) / h);
            total += row[y];
        }
        for (int y = 0; y < h; ++y) {
            double pr = e.marginal[y] - (y ? e.marginal[y - 1] : 0.0f);
            assert_near(pr, row[y] / total, 1e-6, "row probability");
        }
        env_map_free(&e);
        free(px);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_emitters_by_power),
        cmocka_unit_test(test_many_emitters_cdf_ends_at_one),
        cmocka_unit_test(test_equal_emitters_cdf_ends_at_one),
        cmocka_unit_test(test_no_emitter),
        cmocka_unit_test(test_distant_lights_and_dome),
        cmocka_unit_test(test_light_selection),
        cmocka_unit_test(test_too_many_lights),
        cmocka_unit_test(test_point_and_spot_lights),
        cmocka_unit_test(test_light_falloff),
        cmocka_unit_test(test_ambient_lights),
        cmocka_unit_test(test_env_constant_map_is_uniform),
        cmocka_unit_test(test_env_bright_texel_owns_the_jump),
        cmocka_unit_test(test_env_black_and_invalid_texels),
        cmocka_unit_test(test_env_random_maps_cdfs_end_at_one),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
