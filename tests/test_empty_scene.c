/* test_empty_scene.c — the pipeline on a scene with no patch at all (issue 15, item 8): its
 * buffers are one unused element each, pipeline_create copies no attributes (UBSan used to
 * abort on memcpy(attr, NULL, 0) in the sanitizer build), and every eye ray misses. Built
 * directly, not from RIB, so it holds whatever the loaders come to accept. Also the films of
 * a pipeline whose films are the host's (several devices, plan.host_film): one pixel each. */
#include "test_support.h"
#include "app/render.h"
#include "pipeline/pipeline.h"

#include <string.h>

#define W 16
#define H 8

/* A scene of nothing, its camera at the origin looking down +z. */
static void empty_scene(ts_scene *s)
{
    memset(s, 0, sizeof *s);
    for (int i = 0; i < 4; ++i)
        s->camera.world_to_camera[i * 5] = 1.0; /* the identity */
    s->camera.fov_deg = 40.0;
}

static void test_every_ray_misses(void **state)
{
    (void)state;
    ts_device cl;
    test_open_device(&cl);
    ts_scene s;
    empty_scene(&s);
    ts_error err = {0};
    ts_stats stats;
    memset(&stats, 0, sizeof stats);
    ts_pipeline_plan plan = {.ray_capacity = W * H, .pair_capacity = W * H * 8};
    pipeline_plan_arenas(&plan, 2, 2);
    ts_pipeline p;
    if (pipeline_create(&p, &cl, &s, &plan, W * H, &stats, &err)) fail_msg("%s", err.msg);
    assert_int_equal(stats.counters[TS_COUNTER_micropolygons_potential], 0);
    ts_camera_params cam;
    if (render_camera_params(&s.camera, W, H, &cam, &err)) fail_msg("%s", err.msg);
    cam.spp = 1;
    cam.ray_count = W * H;
    if (pipeline_camera(&p, &cam, &err) || pipeline_lod_count(&p, W * H, 0, &err) ||
        pipeline_lod_finish(&p, TS_LOD_RULE_CROSSED, 0, &err) || pipeline_trace(&p, W * H, &err))
        fail_msg("%s", err.msg);
    static ts_hit hit[W * H];
    if (dev_read(&cl, p.ray_hit, 0, sizeof hit, hit, "hits", &err)) fail_msg("%s", err.msg);
    for (int i = 0; i < W * H; ++i)
        if (hit[i].patch != TS_INVALID) fail_msg("ray %d hit patch %u of none", i, hit[i].patch);
    assert_int_equal(stats.counters[TS_COUNTER_patches_diced], 0);
    pipeline_destroy(&p);
    stats_free(&stats);
    dev_close(&cl);
}

/* The bytes of device buffer m. */
static size_t buffer_bytes(cl_mem m)
{
    size_t bytes = 0;
    assert_int_equal(clGetMemObjectInfo(m, CL_MEM_SIZE, sizeof bytes, &bytes, NULL), CL_SUCCESS);
    return bytes;
}

/* A pipeline of several devices' (plan.host_film: the board merges the samples on the host)
 * holds films of one pixel, not 48 bytes a pixel of the frame, and refuses pipeline_film;
 * one device's holds the frame's. */
static void test_host_film_pipeline_holds_no_film(void **state)
{
    (void)state;
    ts_device cl;
    test_open_device(&cl);
    ts_scene s;
    empty_scene(&s);
    const uint32_t pixels = 1920 * 1080;
    for (int host = 0; host < 2; ++host) {
        ts_error err = {0};
        ts_stats stats;
        memset(&stats, 0, sizeof stats);
        ts_pipeline_plan plan = {.ray_capacity = W * H, .pair_capacity = W * H * 8};
        pipeline_plan_arenas(&plan, 2, 2);
        plan.host_film = host;
        ts_pipeline p;
        if (pipeline_create(&p, &cl, &s, &plan, pixels, &stats, &err)) fail_msg("%s", err.msg);
        size_t want = (host ? 1u : pixels) * sizeof(ts_vec4);
        assert_int_equal(buffer_bytes(p.accum), want);
        assert_int_equal(buffer_bytes(p.aov_film), want);
        assert_int_equal(buffer_bytes(p.albedo_film), want);
        if (host) {
            ts_camera_params cam;
            if (render_camera_params(&s.camera, 1920, 1080, &cam, &err)) fail_msg("%s", err.msg);
            cam.spp = 1;
            cam.ray_count = W * H;
            assert_int_equal(pipeline_film(&p, &cam, &err), TS_E_INTERNAL);
            ts_error_clear(&err);
        }
        pipeline_destroy(&p);
        stats_free(&stats);
    }
    dev_close(&cl);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_ray_misses),
        cmocka_unit_test(test_host_film_pipeline_holds_no_film),
    };
    return TEST_RUN_WITH_DEVICE(tests, NULL);
}
