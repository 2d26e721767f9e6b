/* test_trace.c — the whole two-level tracer (top_level, sort, dice, build, bottom_level,
 * resolve) on the teapot against a brute-force tracer: every ray against every
 * micro-triangle of every patch diced at the same m (DESIGN.md §5). Also: a tiny pair
 * buffer (N = 1, many iterations) and few slots (many batches) give bit-identical hits. */
#include "test_support.h"
#include "lib/patch.h"
#include "lib/intersect.h"
#include "pipeline/pipeline.h"
#include "app/render.h"
#include "scene/rib/rib.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

enum { W = 96, H = 54, M = 4 };

typedef struct traced {
    ts_vec4 org[W * H], dir[W * H];
    ts_hit hit[W * H];
    ts_stats stats;
} traced;

/* The teapot's eye rays traced with `plan`, the pipeline's cancel hook set to `cancel` (NULL:
 * none); returns whether the hook cancelled the trace. */
static int trace_teapot_hooked(ts_device *cl, const ts_scene *s, const ts_pipeline_plan *plan,
                               traced *out, int (*cancel)(void *ctx), void *ctx)
{
    ts_error err = {0};
    memset(&out->stats, 0, sizeof out->stats);
    ts_pipeline p;
    if (pipeline_create(&p, cl, s, plan, W * H, &out->stats, &err)) fail_msg("%s", err.msg);
    ts_camera_params cam;
    if (render_camera_params(&s->camera, W, H, &cam, &err)) fail_msg("%s", err.msg);
    cam.spp = 1;
    cam.ray_count = W * H;
    p.cancel = cancel, p.cancel_ctx = ctx;
    if (pipeline_camera(&p, &cam, &err) || pipeline_trace(&p, W * H, &err)) fail_msg("%s", err.msg);
    int cancelled = p.cancelled;
    clEnqueueReadBuffer(cl->queue, p.ray_org, CL_TRUE, 0, sizeof out->org, out->org, 0, NULL, NULL);
    clEnqueueReadBuffer(cl->queue, p.ray_dir, CL_TRUE, 0, sizeof out->dir, out->dir, 0, NULL, NULL);
    clEnqueueReadBuffer(cl->queue, p.ray_hit, CL_TRUE, 0, sizeof out->hit, out->hit, 0, NULL, NULL);
    pipeline_destroy(&p);
    return cancelled;
}

static void trace_teapot(ts_device *cl, const ts_scene *s, const ts_pipeline_plan *plan,
                         traced *out)
{
    trace_teapot_hooked(cl, s, plan, out, NULL, NULL);
}

/* Every patch diced at m on the host with the shared evaluation, every ray against every
 * micro-triangle, same split as bottom_level. */
static void brute_force(const ts_scene *s, const traced *t, float *tbest, uint32_t *pbest)
{
    uint32_t n = (1u << M) + 1u;
    ts_vec4 *grid = malloc((size_t)s->patch_count * n * n * sizeof *grid);
    for (uint32_t p = 0; p < s->patch_count; ++p)
        for (uint32_t v = 0; v < n * n; ++v)
            grid[p * n * n + v] =
                patch_vertex(&s->cp[p * 16], &s->cp[p * 16], &s->corner_n[p * 4], &s->mid_n[p * 5],
                             &s->attr[p], &s->xform[s->attr[p].xform], scene_tex_ctx(s),
                             ldexpf((float)(v % n), -M), ldexpf((float)(v / n), -M));
    for (int r = 0; r < W * H; ++r) {
        ts_vec4 o = t->org[r], d = t->dir[r];
        ts_ray_shear sh = ray_shear(d.x, d.y, d.z);
        float best = TS_NO_HIT, b1, b2;
        uint32_t bp = TS_INVALID;
        for (uint32_t p = 0; p < s->patch_count; ++p) {
            const ts_vec4 *g = &grid[p * n * n];
            for (uint32_t j = 0; j + 1 < n; ++j)
                for (uint32_t i = 0; i + 1 < n; ++i) {
                    ts_vec4 v00 = g[j * n + i], v10 = g[j * n + i + 1], v01 = g[(j + 1) * n + i],
                            v11 = g[(j + 1) * n + i + 1];
                    float h = triangle_hit(&sh, o.x, o.y, o.z, v00, v10, v11, o.w, best, &b1, &b2);
                    if (h >= 0) best = h, bp = p;
                    h = triangle_hit(&sh, o.x, o.y, o.z, v00, v11, v01, o.w, best, &b1, &b2);
                    if (h >= 0) best = h, bp = p;
                }
        }
        tbest[r] = best;
        pbest[r] = bp;
    }
    free(grid);
}

static void load_teapot(ts_scene *s)
{
    ts_error err = {0};
    memset(s, 0, sizeof *s);
    if (rib_load(test_source_path("scene/teapot.rib"), s, 1, &err)) fail_msg("%s", err.msg);
    assert_int_equal(s->patch_count, 32);
}

static void test_teapot_matches_brute_force(void **state)
{
    ts_device cl;
    test_open_device(&cl);
    ts_scene s;
    load_teapot(&s);
    static traced t;
    ts_pipeline_plan plan = {.ray_capacity = W * H, .pair_capacity = W * H * 8};
    pipeline_plan_arenas(&plan, 32, M);
    trace_teapot(&cl, &s, &plan, &t);
    float *tb = malloc(W * H * sizeof *tb);
    uint32_t *pb = malloc(W * H * sizeof *pb);
    brute_force(&s, &t, tb, pb);
    int hits = 0, agree = 0, same = 0;
    for (int r = 0; r < W * H; ++r) {
        int got = t.hit[r].patch != TS_INVALID, want = pb[r] != TS_INVALID;
        if (got != want)
            fail_msg("ray %d: two-level %s, brute force %s", r, got ? "hit" : "miss",
                     want ? "hit" : "miss");
        if (!want) continue;
        ++hits;
        /* The same patch at the same t, as test_embree counts agreement: a hit handed to
         * the wrong patch (shaded with its attributes) at the right distance is a bug. */
        int same_patch = t.hit[r].patch == pb[r];
        same += same_patch;
        if (same_patch && fabsf(t.hit[r].t - tb[r]) <= 1e-4f * tb[r]) ++agree;
    }
    assert_true(hits > W * H / 5); /* the teapot fills a good part of the frame */
    /* Rays through a seam shared by two patches may take either (ties at the same t). */
    if (!(same >= 0.999 * hits && agree >= 0.999 * hits))
        fail_msg("of %d hits, %d on brute force's patch, %d on it at its t (want 99.9%%)", hits,
                 same, agree);
    assert_true(t.stats.counters[TS_COUNTER_iterations] >= 1);
    free(tb);
    free(pb);
    scene_free(&s);
    dev_close(&cl);
}

static void test_budget_does_not_change_hits(void **state)
{
    ts_device cl;
    test_open_device(&cl);
    ts_scene s;
    load_teapot(&s);
    static traced a, b;
    /* Roomy: 8 candidates per ray from the first iteration on (Hanika's N = capacity / R);
     * tight: one at first and doubling, as by default where the patches fit (trace.c
     * pairs_per_ray; its cache evicts, which would water-fill the windows instead). */
    ts_pipeline_plan roomy = {.ray_capacity = W * H, .pair_capacity = W * H * 8, .first_n = 8};
    ts_pipeline_plan tight = {.ray_capacity = W * H, .pair_capacity = W * H, .first_n = 1};
    pipeline_plan_arenas(&roomy, 32, M);
    pipeline_plan_arenas(&tight, 1, M); /* one moving patch's room: two static patches a batch */
    trace_teapot(&cl, &s, &roomy, &a);
    trace_teapot(&cl, &s, &tight, &b);
    assert_memory_equal(a.hit, b.hit, sizeof a.hit);
    /* Fewer candidates per ray need more iterations; the log records R and N for each. */
    assert_true(b.stats.counters[TS_COUNTER_iterations] > a.stats.counters[TS_COUNTER_iterations]);
    assert_int_equal(a.stats.iterations[0].n_per_ray, 8);
    assert_int_equal(b.stats.iterations[0].n_per_ray, 1);
    assert_int_equal(b.stats.iterations[0].active_rays, W * H);
    for (uint32_t i = 1; i < b.stats.iteration_count; ++i)
        assert_true(b.stats.iterations[i].active_rays <= b.stats.iterations[i - 1].active_rays);
    stats_free(&a.stats);
    stats_free(&b.stats);
    scene_free(&s);
    dev_close(&cl);
}

/* A patch cache too small for the frame evicts, and patches come back diced again: once its
 * plan says the frame's patches do not fit (from the first iteration on), each iteration
 * fills the pair buffer (Hanika's N) instead of ramping up from one candidate per ray, so
 * fewer iterations dice fewer patches; the hits stay the same (trace.c pipeline_trace). */
static void test_evicting_cache_fills_the_pairs(void **state)
{
    ts_device cl;
    test_open_device(&cl);
    ts_scene s;
    load_teapot(&s);
    static traced ramp, fill;
    ts_pipeline_plan r = {.ray_capacity = W * H, .pair_capacity = W * H * 8, .first_n = 1};
    ts_pipeline_plan f = {.ray_capacity = W * H, .pair_capacity = W * H * 8}; /* the default */
    pipeline_plan_arenas(&r, 1, M); /* room for two static patches a batch: it evicts */
    pipeline_plan_arenas(&f, 1, M);
    trace_teapot(&cl, &s, &r, &ramp);
    trace_teapot(&cl, &s, &f, &fill);
    assert_memory_equal(ramp.hit, fill.hit, sizeof ramp.hit);
    assert_true(ramp.stats.counters[TS_COUNTER_patch_cache_evictions] > 0);
    assert_true(fill.stats.counters[TS_COUNTER_patch_cache_evictions] > 0);
    /* At least the full N (capacity / R) from the first iteration, water-filled (trace.c
     * water_fill: the rays with few candidates leave room to the others); the ramp starts at
     * one. */
    assert_true(fill.stats.iterations[0].n_per_ray >= 8);
    assert_int_equal(ramp.stats.iterations[0].n_per_ray, 1);
    assert_true(fill.stats.counters[TS_COUNTER_iterations] <
                ramp.stats.counters[TS_COUNTER_iterations]);
    assert_true(fill.stats.counters[TS_COUNTER_patch_cache_misses] <
                ramp.stats.counters[TS_COUNTER_patch_cache_misses]);
    stats_free(&ramp.stats);
    stats_free(&fill.stats);
    scene_free(&s);
    dev_close(&cl);
}

/* The cancel hook's view of the queue (trace.c's batch loop): each call, whether launches
 * enqueued before the batches of the last AHEAD calls are still running. */
enum { AHEAD = 4 }; /* trace.c TS_BATCHES_AHEAD */
typedef struct queue_watch {
    ts_device *cl;
    uint64_t finishes[AHEAD];
    size_t before[AHEAD]; /* pending launches at the last AHEAD calls, oldest first */
    int calls, behind;
} queue_watch;

static int watch_queue(void *ctx)
{
    queue_watch *q = ctx;
    ts_device *cl = q->cl;
    size_t from = q->calls >= AHEAD && q->finishes[0] == cl->finishes ? q->before[0] : 0;
    for (size_t i = 0; i < from && i < cl->pending_count; ++i) {
        cl_int status = CL_COMPLETE;
        clGetEventInfo(cl->pending[i].event, CL_EVENT_COMMAND_EXECUTION_STATUS, sizeof status,
                       &status, NULL);
        q->behind += status != CL_COMPLETE;
    }
    memmove(q->finishes, q->finishes + 1, (AHEAD - 1) * sizeof *q->finishes);
    memmove(q->before, q->before + 1, (AHEAD - 1) * sizeof *q->before);
    q->finishes[AHEAD - 1] = cl->finishes, q->before[AHEAD - 1] = cl->pending_count;
    q->calls++;
    return 0;
}

/* A stop signal cannot take back what is enqueued, so the batches of an iteration whose
 * patches do not fit are not enqueued all at once: when the cancel hook is asked after a
 * batch, every launch enqueued before the last few batches has ended (at most
 * TS_BATCHES_AHEAD batches wait in the queue). Thousands of batches enqueued at once kept
 * forest-100 at 1920x768 x 2 with --memory 512 running five seconds after SIGINT. */
static void test_cancel_hook_finds_few_batches_in_flight(void **state)
{
    ts_device cl;
    test_open_device(&cl);
    ts_scene s;
    load_teapot(&s);
    static traced t;
    ts_pipeline_plan plan = {.ray_capacity = W * H, .pair_capacity = W * H * 8};
    pipeline_plan_arenas(&plan, 1, M); /* two static patches a batch: many batches */
    queue_watch q = {.cl = &cl};
    assert_false(trace_teapot_hooked(&cl, &s, &plan, &t, watch_queue, &q));
    assert_true(q.calls > 8);
    assert_int_equal(q.behind, 0);
    stats_free(&t.stats);
    scene_free(&s);
    dev_close(&cl);
}

/* Water-filled windows (plan.fill_windows; trace.c water_fill) with a pair buffer of two a
 * ray: the hits of uniform windows of eight, bit for bit, in fewer iterations than uniform
 * windows of the same two a ray need, and at a cap N above two in the first. */
static void test_water_filled_windows_same_hits(void **state)
{
    ts_device cl;
    test_open_device(&cl);
    ts_scene s;
    load_teapot(&s);
    static traced roomy, uniform, filled;
    ts_pipeline_plan r = {.ray_capacity = W * H, .pair_capacity = W * H * 8, .first_n = 8};
    ts_pipeline_plan u = {.ray_capacity = W * H, .pair_capacity = W * H * 2, .first_n = 2};
    ts_pipeline_plan f = {.ray_capacity = W * H, .pair_capacity = W * H * 2, .fill_windows = 1};
    pipeline_plan_arenas(&r, 32, M);
    pipeline_plan_arenas(&u, 32, M);
    pipeline_plan_arenas(&f, 1, M); /* and a cache that evicts */
    trace_teapot(&cl, &s, &r, &roomy);
    trace_teapot(&cl, &s, &u, &uniform);
    trace_teapot(&cl, &s, &f, &filled);
    assert_memory_equal(roomy.hit, filled.hit, sizeof roomy.hit);
    assert_memory_equal(roomy.hit, uniform.hit, sizeof roomy.hit);
    assert_true(filled.stats.counters[TS_COUNTER_patch_cache_evictions] > 0);
    assert_true(filled.stats.iterations[0].n_per_ray > 2);
    assert_true(filled.stats.counters[TS_COUNTER_iterations] <
                uniform.stats.counters[TS_COUNTER_iterations]);
    stats_free(&roomy.stats);
    stats_free(&uniform.stats);
    stats_free(&filled.stats);
    scene_free(&s);
    dev_close(&cl);
}

/* pipeline_grow_arenas releases the old arenas before it makes the new ones, so the device
 * never holds both (the budget holds the new ones alone: --stats device_bytes_peak); when not
 * even the old sizes can be made again, the pipeline says so (grid NULL) with the
 * out-of-memory error its callers retry on. Every buffer pipeline_create made is counted and
 * pipeline_destroy gives every one back through dev_buffer_release. */
static void test_growing_arenas_never_holds_both(void **state)
{
    ts_device cl;
    test_open_device(&cl);
    ts_scene s;
    load_teapot(&s);
    ts_stats stats = {0};
    ts_error err = {0};
    ts_pipeline_plan plan = {.ray_capacity = W * H, .pair_capacity = W * H * 8};
    pipeline_plan_arenas(&plan, 1, M);
    ts_pipeline p;
    uint64_t base = cl.mem_bytes;
    if (pipeline_create(&p, &cl, &s, &plan, W * H, &stats, &err)) fail_msg("%s", err.msg);
    uint64_t made = cl.mem_bytes, old = pipeline_arena_bytes(&p.plan);
    assert_true(made - base > old + (uint64_t)W * H * TS_BYTES_PER_RAY);
    assert_true(stats.counters[TS_COUNTER_device_bytes_peak] == made);
    uint64_t verts = 4ull * p.plan.vert_capacity, groups = 4ull * p.plan.group_capacity;
    if (pipeline_grow_arenas(&p, verts, groups, &err)) fail_msg("%s", err.msg);
    uint64_t now = pipeline_arena_bytes(&p.plan);
    assert_true(now == 4 * old);
    assert_true(cl.mem_bytes == made - old + now);
    /* made + now had the old ones stayed until the new ones were made */
    assert_true(stats.counters[TS_COUNTER_device_bytes_peak] == made - old + now);
    ts_dev_inject_alloc_error = CL_MEM_OBJECT_ALLOCATION_FAILURE;
    int rc = pipeline_grow_arenas(&p, 2 * verts, 2 * groups, &err);
    ts_dev_inject_alloc_error = CL_SUCCESS;
    assert_int_equal(rc, TS_E_DEVICE);
    assert_true(dev_is_out_of_memory(&err));
    assert_null(p.grid);
    assert_true(cl.mem_bytes == made - old);
    ts_error_clear(&err);
    pipeline_destroy(&p);
    assert_true(cl.mem_bytes == base);
    stats_free(&stats);
    scene_free(&s);
    dev_close(&cl);
}

/* On a device that shares host memory, the buffers of the arrays the host keeps anyway are
 * those arrays (CL_MEM_USE_HOST_PTR, pipeline.c array_in_place): the scene's control points
 * (and cp1's one patch of them, a scene without motion), normals and, where no patch emits,
 * attributes, and the pipeline's top-level BVH nodes, patch boxes and flatness bounds, byte
 * for byte what --stats' device_bytes_in_place counts. With an emitter the attributes are a
 * copy (they carry its index). */
static void test_arrays_read_in_place(void **state)
{
    (void)state;
    ts_device cl;
    test_open_device(&cl);
    if (!cl.info.host_unified) {
        dev_close(&cl);
        skip();
    }
    ts_scene s;
    load_teapot(&s);
    ts_error err = {0};
    ts_pipeline_plan plan = {.ray_capacity = W * H, .pair_capacity = W * H * 8};
    pipeline_plan_arenas(&plan, 1, M);
    uint64_t per_patch = 16 * sizeof(ts_vec4) + 9 * sizeof(ts_vec4) + sizeof(ts_box) +
                         sizeof(ts_vec4); /* cp, normals, box, flatness */
    for (int emits = 0; emits < 2; ++emits) {
        s.attr[3].le_r = emits ? 1.0f : 0.0f;
        ts_stats stats = {0};
        ts_pipeline p;
        if (pipeline_create(&p, &cl, &s, &plan, W * H, &stats, &err)) fail_msg("%s", err.msg);
        uint64_t want = s.patch_count * (per_patch + (emits ? 0 : sizeof(ts_patch_attr))) +
                        16 * sizeof(ts_vec4) + p.qbvh.node_count * sizeof(ts_qbvh_node);
        assert_non_null(p.qbvh.nodes); /* kept: it is the buffer */
        assert_non_null(p.box_host);
        assert_non_null(p.flatness_host);
        assert_int_equal(stats.counters[TS_COUNTER_device_bytes_in_place], want);
        pipeline_destroy(&p);
        stats_free(&stats);
    }
    scene_free(&s);
    dev_close(&cl);
}

/* Bytes of address space this process uses (/proc/self/statm's first field, in pages). */
static uint64_t address_space_in_use(void)
{
    FILE *f = fopen("/proc/self/statm", "r");
    unsigned long long pages = 0;
    if (!f || fscanf(f, "%llu", &pages) != 1) fail_msg("cannot read /proc/self/statm");
    fclose(f);
    return pages * 4096ull;
}

/* When the new arenas cannot be had (the address space capped 256 MB above what the process
 * uses, the new arenas 888 MB), arenas of the old sizes come back, empty: the error is the
 * out-of-memory one the callers note, the device holds what it held, and the pipeline traces
 * the same hits as a fresh one. */
static void test_arenas_that_cannot_grow_come_back(void **state)
{
#if defined(__SANITIZE_ADDRESS__)
    test_skip("AddressSanitizer's shadow memory cannot live under a cap on the address space");
    return;
#endif
    ts_device cl;
    test_open_device(&cl);
    if (!cl.info.host_unified) {
        dev_close(&cl);
        test_skip("device 0 does not allocate from the process's address space");
        return;
    }
    ts_scene s;
    load_teapot(&s);
    static traced fresh, again;
    ts_pipeline_plan plan = {.ray_capacity = W * H, .pair_capacity = W * H * 8};
    pipeline_plan_arenas(&plan, 1, M);
    trace_teapot(&cl, &s, &plan, &fresh);
    ts_error err = {0};
    ts_pipeline p;
    if (pipeline_create(&p, &cl, &s, &plan, W * H, &again.stats, &err)) fail_msg("%s", err.msg);
    uint64_t made = cl.mem_bytes;
    uint32_t verts = p.plan.vert_capacity, groups = p.plan.group_capacity;
    struct rlimit old, cap;
    assert_int_equal(getrlimit(RLIMIT_AS, &old), 0);
    cap = old;
    cap.rlim_cur = address_space_in_use() + (256u << 20);
    if (old.rlim_cur != RLIM_INFINITY && cap.rlim_cur > old.rlim_cur) cap.rlim_cur = old.rlim_cur;
    assert_int_equal(setrlimit(RLIMIT_AS, &cap), 0);
    int rc = pipeline_grow_arenas(&p, 48ull << 20, 1ull << 20, &err); /* 768 + 96 + 24 MB */
    assert_int_equal(setrlimit(RLIMIT_AS, &old), 0);
    if (rc == TS_OK) fail_msg("888 MB of arenas under a 256 MB cap");
    assert_true(dev_is_out_of_memory(&err));
    ts_error_clear(&err);
    assert_non_null(p.grid);
    assert_int_equal(p.plan.vert_capacity, verts);
    assert_int_equal(p.plan.group_capacity, groups);
    assert_true(cl.mem_bytes == made);
    ts_camera_params cam;
    if (render_camera_params(&s.camera, W, H, &cam, &err)) fail_msg("%s", err.msg);
    cam.spp = 1;
    cam.ray_count = W * H;
    if (pipeline_camera(&p, &cam, &err) || pipeline_trace(&p, W * H, &err) ||
        dev_read(&cl, p.ray_hit, 0, sizeof again.hit, again.hit, "the hits", &err))
        fail_msg("%s", err.msg);
    assert_memory_equal(fresh.hit, again.hit, sizeof fresh.hit);
    pipeline_destroy(&p);
    stats_free(&fresh.stats);
    stats_free(&again.stats);
    scene_free(&s);
    dev_close(&cl);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_teapot_matches_brute_force),
        cmocka_unit_test(test_budget_does_not_change_hits),
        cmocka_unit_test(test_evicting_cache_fills_the_pairs),
        cmocka_unit_test(test_cancel_hook_finds_few_batches_in_flight),
        cmocka_unit_test(test_water_filled_windows_same_hits),
        cmocka_unit_test(test_growing_arenas_never_holds_both),
        cmocka_unit_test(test_arrays_read_in_place),
        cmocka_unit_test(test_arenas_that_cannot_grow_come_back),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
