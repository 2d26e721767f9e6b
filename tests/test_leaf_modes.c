/* test_leaf_modes.c — work-group-wide leaf intersection (PantaRay Fig. 8 on work-groups,
 * issue 6): the per-ray and the work-group variants of bottom_level return identical hits
 * (patch, micro-polygon, t bitwise) on the teapot and on a displaced teapot, for leaf blocks
 * of 1, 2 and 4 micro-quads a side, in both geometry modes; the leaf size changes no hit
 * distance; the utilisation counters are consistent. */
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
                if (ray.hit[i].patch != TS_INVALID)
                    assert_true(ray.hit[i].t == ref.hit[i].t), ++hits;
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

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_teapot),
        cmocka_unit_test(test_displaced_teapot),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
