/* test_leaf_modes.c — work-group-wide leaf intersection (PantaRay Fig. 8 on work-groups,
 * issue 6): the per-ray and the work-group variants of bottom_level return identical hits
 * (patch, micro-polygon, t bitwise) on the teapot and on a displaced teapot, for leaf blocks
 * of 1, 2 and 4 micro-quads a side, in both geometry modes; the leaf size changes no hit
 * distance; the utilisation counters are consistent, also after the waves were made larger. */
#include "test_support.h"
#include "pipeline/pipeline.h"
#include "app/render.h"
#include "scene/rib/rib.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { W = 64, H = 36, M = 5 };

typedef struct run {
    ts_hit hit[W * H];
    double tests, slots;
} run;

static void load(ts_scene *s, int displaced)
{
    FILE *f = fopen(test_source_path("scene/teapot.rib"), "rb");
    assert_non_null(f);
    static char text[1 << 20];
    size_t n = fread(text, 1, sizeof text - 200, f);
    fclose(f);
    text[n] = '\0';
    if (displaced) { /* fbm on every patch: insert it right after WorldBegin */
        char *wb = strstr(text, "WorldBegin\n");
        assert_non_null(wb);
        const char *d = "Displacement \"fbm\" \"float amplitude\" [0.05] \"float frequency\" [3] "
                        "\"float octaves\" [3]\n";
        size_t at = (size_t)(wb - text) + strlen("WorldBegin\n");
        memmove(text + at + strlen(d), text + at, n - at + 1);
        memcpy(text + at, d, strlen(d));
        n += strlen(d);
    }
    memset(s, 0, sizeof *s);
    ts_error err = {0};
    if (rib_parse_string("teapot.rib", text, n, s, 1, &err)) fail_msg("%s", err.msg);
}

static void trace(ts_device *cl, const ts_scene *s, int exact, int group, uint32_t leaf_b, run *out)
{
    ts_error err = {0};
    ts_stats stats;
    memset(&stats, 0, sizeof stats);
    ts_pipeline_plan plan = {.ray_capacity = W * H, .pair_capacity = W * H * 8};
    pipeline_plan_arenas(&plan, 32, M);
    ts_pipeline p;
    if (pipeline_create(&p, cl, s, &plan, W * H, &stats, &err)) fail_msg("%s", err.msg);
    p.mode = (ts_trace_mode){1u, M, exact, group, leaf_b, 0, 1.0};
    ts_camera_params cam;
    if (render_camera_params(&s->camera, W, H, &cam, &err)) fail_msg("%s", err.msg);
    cam.spp = 1;
    cam.ray_count = W * H;
    if (pipeline_camera(&p, &cam, &err) || pipeline_trace(&p, W * H, &err)) fail_msg("%s", err.msg);
    clEnqueueReadBuffer(cl->queue, p.ray_hit, CL_TRUE, 0, sizeof out->hit, out->hit, 0, NULL, NULL);
    out->tests = (double)stats.counters[TS_COUNTER_leaf_tests];
    out->slots = (double)stats.counters[TS_COUNTER_leaf_slots];
    pipeline_destroy(&p);
    stats_free(&stats);
}

static void check_scene(int displaced)
{
    ts_device cl;
    test_open_device(&cl);
    ts_scene s;
    load(&s, displaced);
    static run ray, group, ref;
    int box_hits = 0;
    for (int exact = 0; exact < 2; ++exact)
        for (uint32_t b = 0; b <= 2; ++b) {
            int hits = 0;
            trace(&cl, &s, exact, 0, b, &ray);
            trace(&cl, &s, exact, 1, b, &group);
            for (int i = 0; i < W * H; ++i) {
                const ts_hit *a = &ray.hit[i], *g = &group.hit[i];
                if (a->patch != g->patch || a->prim != g->prim || memcmp(&a->t, &g->t, sizeof a->t))
                    fail_msg("ray %d (exact %d, leaf %u): per-ray (%u, %u, %a), group (%u, %u, %a)",
                             i, exact, 1u << b, a->patch, a->prim, a->t, g->patch, g->prim, g->t);
            }
            if (b == 0) memcpy(&ref, &ray, sizeof ref);
            for (int i = 0; i < W * H; ++i) { /* the leaf size moves no hit */
                assert_int_equal(ray.hit[i].patch == TS_INVALID, ref.hit[i].patch == TS_INVALID);
                if (ray.hit[i].patch == TS_INVALID) continue;
                assert_true(ray.hit[i].t == ref.hit[i].t), ++hits;
                /* Leaf boxes: the same box too, the larger micro-quad of equal entries
                 * (bottom_level.cl hit_nearer), whatever order the leaf size visits them in. */
                if (!exact &&
                    (ray.hit[i].patch != ref.hit[i].patch || ray.hit[i].prim != ref.hit[i].prim))
                    fail_msg("ray %d (leaf %u): (%u, %#x) against leaf 1's (%u, %#x)", i, 1u << b,
                             ray.hit[i].patch, ray.hit[i].prim, ref.hit[i].patch, ref.hit[i].prim);
            }
            /* Utilisation: tests fill at most every slot, and something was tested. */
            assert_true(ray.tests > 0 && ray.tests <= ray.slots);
            assert_true(group.tests > 0 && group.tests <= group.slots);
            /* Both variants test the same micro-quads. */
            assert_true(ray.tests == group.tests);
            /* Each configuration hits, not only their sum: the teapot fills a good part of
             * the frame (test_trace: over a fifth); the exact triangles hit at most what the
             * conservative leaf boxes hit, and nearly as much (597 of 620 rays here, 598 of
             * 657 displaced, whose boxes bound the displacement's range): at least 85%. */
            if (exact == 0) box_hits = hits;
            if (hits <= W * H / 5 || (exact && (hits > box_hits || hits < 0.85 * box_hits)))
                fail_msg("exact %d, leaf %u: %d hits of %d rays (leaf boxes: %d)", exact, 1u << b,
                         hits, W * H, box_hits);
        }
    scene_free(&s);
    dev_close(&cl);
}

static void test_teapot(void **state)
{
    check_scene(0);
}
static void test_displaced_teapot(void **state)
{
    check_scene(1);
}

/* Waves made larger after creation (pipeline_resize_rays, as budget_grow_arenas and a squeezed
 * frame on several devices do): the leaf counters keep the buffer made for the creation's
 * waves, a work-group an entry, so a batch with more pairs than it has entries is traced in
 * several bottom_level launches (a single launch wrote past it). The hits and the counts are
 * those of a pipeline made at the larger size, in both leaf modes. */
static void test_larger_waves_keep_their_counters(void **state)
{
    (void)state;
    enum { W2 = 512, H2 = 288 };
    ts_device cl;
    test_open_device(&cl);
    ts_scene s;
    load(&s, 0);
    ts_error err = {0};
    static ts_hit hit[2][W2 * H2];
    for (int group = 0; group < 2; ++group) {
        double tests[2], slots[2], pairs = 0;
        uint32_t entries = 0;
        for (int resized = 0; resized < 2; ++resized) {
            ts_stats stats;
            memset(&stats, 0, sizeof stats);
            uint32_t big = W2 * H2, rays = resized ? TS_LOCAL_SIZE : big;
            ts_pipeline_plan plan = {.ray_capacity = rays,
                                     .pair_capacity = rays * TS_PAIRS_PER_RAY};
            pipeline_plan_arenas(&plan, s.patch_count, M); /* one batch: every pair in it */
            ts_pipeline p;
            if (pipeline_create(&p, &cl, &s, &plan, big, &stats, &err)) fail_msg("%s", err.msg);
            if (resized && pipeline_resize_rays(&p, big, &err)) fail_msg("%s", err.msg);
            p.mode = (ts_trace_mode){1u, M, 0, (uint32_t)group, 0u, 0, 1.0};
            ts_camera_params cam;
            if (render_camera_params(&s.camera, W2, H2, &cam, &err)) fail_msg("%s", err.msg);
            cam.spp = 1;
            cam.ray_count = big;
            if (pipeline_camera(&p, &cam, &err) || pipeline_trace(&p, big, &err))
                fail_msg("%s", err.msg);
            clEnqueueReadBuffer(cl.queue, p.ray_hit, CL_TRUE, 0, sizeof hit[resized], hit[resized],
                                0, NULL, NULL);
            tests[resized] = (double)stats.counters[TS_COUNTER_leaf_tests];
            slots[resized] = (double)stats.counters[TS_COUNTER_leaf_slots];
            if (resized) pairs = (double)stats.counters[TS_COUNTER_pairs], entries = p.util_groups;
            pipeline_destroy(&p);
            stats_free(&stats);
        }
        assert_true(pairs > 2.0 * entries * TS_GROUP_SIZE); /* several launches a batch */
        assert_memory_equal(hit[0], hit[1], sizeof hit[0]);
        assert_true(tests[0] > 0 && tests[1] == tests[0] && slots[1] == slots[0]);
    }
    scene_free(&s);
    dev_close(&cl);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_teapot),
        cmocka_unit_test(test_displaced_teapot),
        cmocka_unit_test(test_larger_waves_keep_their_counters),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
