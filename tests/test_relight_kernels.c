/* test_relight_kernels.c — the relit term of the `shade` kernel (render --occlusion,
 * kernels/lib/relight.h) against its plain-C reference (host/ref/relight_ref.c), and the
 * mapped dome's G table (host/pipeline/relight.c) against direct integration over the map.
 *
 * Kernel vs reference: a scene of matte, plastic and metal patches under a uniform dome, an
 * ambient light and a mapped dome (a random 24 x 12 map), with random baked occlusions
 * (random m per patch, bands 1..4, with and without the cosine, random coefficients). The
 * eye rays of a 24 x 18 image are traced by the pipeline; after shade at bounce 0 (depth 1)
 * a path that hit holds exactly the relit term (the other lights' samples wait in pending,
 * the domes take no part in them), so radiance = Kd Cs / pi E from the reference at the
 * hit's (patch, u, v) with the kernel's shading normal (the AOV). Tolerance: rounding,
 * 2e-5 of the sum of the terms' magnitudes.
 *
 * Table vs direct integration: G_j(n) interpolated from the table against the sum over the
 * map's texels of L Y_j max(0, n . w) dw at random normals, through the coefficients of an
 * unoccluded hemisphere about n (E = the band-limited irradiance): the table's error
 * (cells of the map, bilinear interpolation between tabulated normals), stated in
 * docs/bake.md. */
#include "test_support.h"
#include "app/render.h"
#include "image/image.h"
#include "lib/sh.h"
#include "pipeline/pipeline.h"
#include "pipeline/relight.h"
#include "ref/relight_ref.h"
#include "scene/scene_load.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAP_W 24
#define MAP_H 12
#define IMG_W 24
#define IMG_H 18

static const char *dir;

/* A random environment map (texels in [0, 2), a bright spot) and the scene using it. */
static void write_scene(uint32_t *rng, char *scene_path, size_t size)
{
    float px[MAP_W * MAP_H * 3];
    for (int i = 0; i < MAP_W * MAP_H * 3; ++i)
        px[i] = test_uniform(rng, 0.0f, 2.0f);
    for (int k = 0; k < 3; ++k)
        px[(3 * MAP_W + 5) * 3 + k] = 40.0f;
    ts_image img = {
        .width = MAP_W, .height = MAP_H, .channels = 3, .channel_names = NULL, .pixels = px};
    ts_error err = {0};
    if (image_write_exr(test_path_in(dir, "env.exr"), &img, NULL, 0, &err)) fail_msg("%s", err.msg);
    snprintf(scene_path, size, "%s", test_path_in(dir, "relight.rib"));
    FILE *f = fopen(scene_path, "w");
    assert_non_null(f);
    fprintf(f,
            "Format %d %d 1\nProjection \"perspective\" \"fov\" [50]\n"
            "LightSource \"domelight\" 1 \"float intensity\" [0.7] \"color lightcolor\" [1 0.8 0.6]"
            " \"string mapname\" [\"env.exr\"]\n"
            "LightSource \"ambientlight\" 2 \"intensity\" [0.3]\n"
            "LightSource \"distantlight\" 3 \"intensity\" [2] \"from\" [0 1 -1] \"to\" [0 0 0]\n"
            "Translate 0 0 6\nWorldBegin\n"
            "Color [0.8 0.5 0.3]\n"
            "Patch \"bilinear\" \"P\" [-2 -2 -2  0 -2 0  -2 2 -2  0 2 0]\n"
            "Surface \"plastic\" \"Kd\" [0.6] \"Ks\" [0.3]\nColor [0.3 0.6 0.9]\n"
            "Patch \"bilinear\" \"P\" [0 -2 0  2 -2 -2  0 2 0  2 2 -2]\n"
            "Surface \"metal\"\n"
            "Patch \"bicubic\" \"P\" [-1 -2.5 -1  0 -2.5 -1.5  1 -2.5 -1.5  2 -2.5 -1"
            "  -1 -2 -1.5  0 -2 -2  1 -2 -2  2 -2 -1.5  -1 -1.5 -1.5  0 -1.5 -2  1 -1.5 -2"
            "  2 -1.5 -1.5  -1 -1 -1  0 -1 -1.5  1 -1 -1.5  2 -1 -1]\n"
            "WorldEnd\n",
            IMG_W, IMG_H);
    fclose(f);
}

/* A random occlusion of s's patches: m in [0, 3], coefficients in [-1, 1]. */
static void random_occlusion(const ts_scene *s, uint32_t bands, uint32_t cosine, uint32_t *rng,
                             ts_occlusion *o)
{
    memset(o, 0, sizeof *o);
    o->bands = bands, o->cosine = cosine, o->patch_count = s->patch_count;
    o->patch = malloc(2 * s->patch_count * sizeof *o->patch);
    assert_non_null(o->patch);
    for (uint32_t p = 0; p < s->patch_count; ++p) {
        uint32_t m = (uint32_t)test_uniform(rng, 0.0f, 3.999f), side = (1u << m) + 1u;
        o->patch[2 * p] = o->point_count, o->patch[2 * p + 1] = m;
        o->point_count += side * side;
    }
    size_t n = (size_t)o->point_count * bands * bands;
    o->coeffs = malloc(n * sizeof *o->coeffs);
    o->normal = malloc((size_t)o->point_count * 3 * sizeof *o->normal);
    assert_true(o->coeffs && o->normal);
    for (size_t k = 0; k < n; ++k)
        o->coeffs[k] = test_uniform(rng, -1.0f, 1.0f);
    /* random unit normals: some points face the shading normal, some do not */
    for (uint32_t k = 0; k < o->point_count; ++k) {
        float v[3], len;
        do {
            for (int c = 0; c < 3; ++c)
                v[c] = test_uniform(rng, -1.0f, 1.0f);
            len = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        } while (!(len > 0.1f && len <= 1.0f));
        for (int c = 0; c < 3; ++c)
            o->normal[3 * k + c] = v[c] / len;
    }
}

static void read_vec4(ts_pipeline *p, cl_mem m, uint32_t n, ts_vec4 *out)
{
    assert_int_equal(
        clEnqueueReadBuffer(p->cl->queue, m, CL_TRUE, 0, n * sizeof *out, out, 0, NULL, NULL),
        CL_SUCCESS);
}

/* One occlusion: trace the eye rays, shade bounce 0, compare every hit. Returns the hits. */
static uint32_t check_case(ts_device *cl, ts_scene *s, const ts_occlusion *o)
{
    s->occlusion = o;
    ts_stats stats;
    memset(&stats, 0, sizeof stats);
    ts_error err = {0};
    ts_pipeline_plan plan;
    ts_pipeline p;
    uint32_t n = IMG_W * IMG_H;
    if (pipeline_plan(32u << 20, 2 * n, 5, cl->info.max_alloc, &plan, &err) ||
        pipeline_create(&p, cl, s, &plan, n, &stats, &err))
        fail_msg("%s", err.msg);
    p.mode = (ts_trace_mode){1u, 3, 0, 0, 0u, 0, 1.0};
    ts_camera_params cam;
    if (render_camera_params(&s->camera, IMG_W, IMG_H, &cam, &err)) fail_msg("%s", err.msg);
    cam.spp = 1, cam.ray_count = n;
    ts_shade_params sp = {.light_count = p.light_count, .depth = 1, .spp = 1};
    uint32_t np, nr, ns;
    ts_hit *hits = malloc(n * sizeof *hits);
    ts_vec4 *rad = malloc(n * sizeof *rad), *aov = malloc(n * sizeof *aov),
            *alb = malloc(n * sizeof *alb);
    assert_true(hits && rad && aov && alb);
    if (pipeline_camera(&p, &cam, &err) || pipeline_trace(&p, n, &err)) fail_msg("%s", err.msg);
    assert_int_equal(clEnqueueReadBuffer(cl->queue, p.ray_hit, CL_TRUE, 0, n * sizeof *hits, hits,
                                         0, NULL, NULL),
                     CL_SUCCESS);
    if (pipeline_shade(&p, &sp, 0, n, n, &np, &nr, &ns, &err)) fail_msg("%s", err.msg);
    read_vec4(&p, p.radiance, n, rad);
    read_vec4(&p, p.aov, n, aov);
    read_vec4(&p, p.albedo, n, alb);
    /* The light table as uploaded, for the reference. */
    ts_vec4 *light = malloc(TS_RELIGHT_TABLE_FIRST * sizeof *light +
                            (size_t)TS_RELIGHT_TABLE_W * TS_RELIGHT_TABLE_H * 16 * sizeof *light);
    size_t lbytes;
    assert_non_null(light);
    assert_int_equal(clGetMemObjectInfo(p.relight_light, CL_MEM_SIZE, sizeof lbytes, &lbytes, NULL),
                     CL_SUCCESS);
    assert_int_equal(
        clEnqueueReadBuffer(cl->queue, p.relight_light, CL_TRUE, 0, lbytes, light, 0, NULL, NULL),
        CL_SUCCESS);
    assert_int_equal(p.relight.bands, o->bands);
    assert_int_equal(p.relight.table_w, o->cosine ? 0u : TS_RELIGHT_TABLE_W);
    uint32_t hit_count = 0, lit = 0;
    for (uint32_t i = 0; i < n; ++i) {
        if (hits[i].patch == TS_INVALID) continue;
        ++hit_count;
        double c[16], e[3], scale, nn[3] = {aov[i].x, aov[i].y, aov[i].z};
        relight_ref_coeffs(o, hits[i].patch, hits[i].u, hits[i].v, nn, c);
        relight_ref_irradiance(&p.relight, light, c, nn, e, &scale);
        const double albedo[3] = {alb[i].x, alb[i].y, alb[i].z},
                     got[3] = {rad[i].x, rad[i].y, rad[i].z};
        for (int k = 0; k < 3; ++k) {
            double want = albedo[k] / M_PI * e[k], tol = 2e-5 * (albedo[k] / M_PI * scale + 1e-3);
            if (!(fabs(got[k] - want) <= tol))
                fail_msg("path %u (patch %u, u %g, v %g) channel %d: kernel %.9g, reference %.9g",
                         i, hits[i].patch, hits[i].u, hits[i].v, k, got[k], want);
        }
        lit += albedo[0] > 0.0 && fabs(got[0]) > 1e-3;
    }
    assert_true(lit > hit_count / 4); /* not all metal or black */
    free(hits), free(rad), free(aov), free(alb), free(light);
    pipeline_destroy(&p);
    stats_free(&stats);
    s->occlusion = NULL;
    return hit_count;
}

/* write_scene's random scene from *rng, loaded into *s (in a fresh scratch directory). */
static void load_random_scene(uint32_t *rng, ts_scene *s)
{
    dir = test_scratch_dir();
    char path[4096];
    write_scene(rng, path, sizeof path);
    memset(s, 0, sizeof *s);
    ts_error err = {0};
    if (scene_load(path, s, 1, &err)) fail_msg("%s", err.msg);
}

static void test_shade_relit_vs_reference(void **state)
{
    (void)state;
    ts_device cl;
    test_open_device(&cl);
    uint32_t rng = 4242u;
    ts_scene s;
    load_random_scene(&rng, &s);
    const uint32_t cases[][2] = {{3, 0}, {4, 0}, {1, 0}, {2, 1}, {4, 1}};
    for (size_t k = 0; k < sizeof cases / sizeof *cases; ++k) {
        ts_occlusion o;
        random_occlusion(&s, cases[k][0], cases[k][1], &rng, &o);
        assert_true(check_case(&cl, &s, &o) > IMG_W * IMG_H / 3);
        occlusion_free(&o);
    }
    scene_free(&s);
    dev_close(&cl);
}

/* G_j(n) summed over the map's texels directly (the definition). */
static void direct_g(const ts_light *dome, const ts_env_map *env, const double n[3], uint32_t nc,
                     double (*g)[3])
{
    memset(g, 0, nc * sizeof *g);
    for (uint32_t y = 0; y < env->height; ++y)
        for (uint32_t x = 0; x < env->width; ++x) {
            double t0 = M_PI * y / env->height, t1 = M_PI * (y + 1) / env->height;
            /* 8 x 8 sub-samples a texel: the cosine's kink at the horizon */
            for (int sy = 0; sy < 8; ++sy)
                for (int sx = 0; sx < 8; ++sx) {
                    double ct = cos(t0) + (cos(t1) - cos(t0)) * (sy + 0.5) / 8.0;
                    double st = sqrt(fmax(0.0, 1.0 - ct * ct));
                    double ph = 2.0 * M_PI * (x + (sx + 0.5) / 8.0) / env->width;
                    double w[3] = {st * cos(ph), st * sin(ph), ct};
                    double cosine = n[0] * w[0] + n[1] * w[1] + n[2] * w[2];
                    if (cosine <= 0.0) continue;
                    double da = 2.0 * M_PI / env->width * (cos(t0) - cos(t1)) / 64.0;
                    float ys[16];
                    sh_eval((float)w[0], (float)w[1], (float)w[2], 4, ys);
                    const ts_vec4 *t = &env->texels[(size_t)y * env->width + x];
                    double l[3] = {dome->radiance[0] * t->x, dome->radiance[1] * t->y,
                                   dome->radiance[2] * t->z};
                    for (uint32_t j = 0; j < nc; ++j)
                        for (int k = 0; k < 3; ++k)
                            g[j][k] += l[k] * ys[j] * cosine * da;
                }
        }
}

static void test_table_vs_direct_integration(void **state)
{
    (void)state;
    uint32_t rng = 99u;
    ts_scene s;
    ts_error err = {0};
    load_random_scene(&rng, &s);
    ts_env_map env;
    ts_light_table lights;
    ts_patch_attr *attr = calloc(s.patch_count, sizeof *attr);
    assert_non_null(attr);
    if (env_map_load(s.dome.mapname, &env, &err) || lights_build(&s, &env, attr, &lights, &err))
        fail_msg("%s", err.msg);
    ts_occlusion o = {.bands = 4, .cosine = 0};
    ts_relight_tables t;
    if (relight_tables_build(&o, &lights, &env, &t, &err)) fail_msg("%s", err.msg);
    const ts_light *dome = NULL;
    for (uint32_t i = 0; i < lights.light_count; ++i)
        if (lights.lights[i].type == TS_LIGHT_DOME && lights.lights[i].map_width)
            dome = &lights.lights[i];
    assert_non_null(dome);
    ts_relight_params map_only = t.params;
    map_only.uniform[0] = map_only.uniform[1] = map_only.uniform[2] = 0.0f;
    double worst[5] = {0};
    for (int trial = 0; trial < 60; ++trial) {
        double n[3], len = 0;
        for (int k = 0; k < 3; ++k)
            n[k] = test_uniform(&rng, -1.0f, 1.0f), len += n[k] * n[k];
        for (int k = 0; k < 3; ++k)
            n[k] /= sqrt(len);
        double g[16][3];
        direct_g(dome, &env, n, 16, g);
        for (uint32_t bands = 1; bands <= 4; ++bands) {
            /* an unoccluded hemisphere about n: 2 pi I_l Y_j(n), I_l = 1, 1/2, 0, -1/8 */
            static const double il[4] = {1.0, 0.5, 0.0, -0.125};
            float ys[16];
            sh_eval((float)n[0], (float)n[1], (float)n[2], 4, ys);
            double c[16];
            for (uint32_t j = 0; j < bands * bands; ++j)
                c[j] = 2.0 * M_PI * il[j < 1 ? 0 : j < 4 ? 1 : j < 9 ? 2 : 3] * ys[j];
            /* the table holds 16 entries a normal; the reference reads bands^2 of them */
            ts_relight_params rp = map_only;
            rp.bands = 4;
            double c4[16] = {0}, e[3], scale;
            memcpy(c4, c, bands * bands * sizeof *c);
            relight_ref_irradiance(&rp, t.light, c4, n, e, &scale);
            for (int k = 0; k < 3; ++k) {
                double want = 0.0;
                for (uint32_t j = 0; j < bands * bands; ++j)
                    want += c[j] * g[j][k];
                double rel = fabs(e[k] - want) / want;
                if (rel > worst[bands]) worst[bands] = rel;
            }
        }
    }
    printf("G table vs direct integration, worst relative error of E over 60 normals: "
           "%.4f (1 band) %.4f (2) %.4f (3) %.4f (4)\n",
           worst[1], worst[2], worst[3], worst[4]);
    for (int b = 1; b <= 4; ++b)
        assert_true(worst[b] < 0.01);
    relight_tables_free(&t);
    lights_free(&lights);
    env_map_free(&env);
    free(attr);
    scene_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_table_vs_direct_integration),
        cmocka_unit_test(test_shade_relit_vs_reference),
    };
    return TEST_RUN_WITH_DEVICE(tests, NULL);
}
