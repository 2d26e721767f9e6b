/* test_bake_kernels.c — the `bake` stage's kernels (kernels/bake.cl) against their plain-C
 * reference (host/ref/bake_ref.c) on the device, for random inputs: random levels of detail
 * per patch of the displaced teapot (noise displacement), random bands, ray counts (powers of
 * two and not), flags, seeds, camera positions and waves. For every point of the wave:
 * bake_points' position, offset, normal and patch; for every ray bake_rays' origin,
 * direction, whether it is traced and the patch it leaves; and bake_project's coefficients
 * from the device's own directions and hits. Tolerances are rounding: the kernels and the
 * reference evaluate the same expressions, the compilers may contract them differently. */
#include "test_support.h"
#include "pipeline/bake.h"
#include "pipeline/pipeline.h"
#include "ref/bake_ref.h"
#include "scene/scene_load.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static void assert_close(const char *what, uint32_t i, float got, float want, float tol)
{
    if (!(fabsf(got - want) <= tol * (1.0f + fabsf(want))))
        fail_msg("%s %u: device %.9g, reference %.9g", what, i, got, want);
}

static void assert_vec_close(const char *what, uint32_t i, ts_vec4 a, ts_vec4 b, float tol)
{
    assert_close(what, i, a.x, b.x, tol);
    assert_close(what, i, a.y, b.y, tol);
    assert_close(what, i, a.z, b.z, tol);
    assert_close(what, i, a.w, b.w, tol);
}

typedef struct bake_case {
    uint32_t bands, rays, flags, seed, max_m;
    float eye[3];
} bake_case;

/* One wave of points starting at a random point: every output against the reference. */
static uint32_t check_wave(ts_pipeline *p, const ts_scene *s, const uint32_t *lod,
                           const uint32_t *first_of, uint32_t first, uint32_t count)
{
    ts_bake_stage *b = p->bake;
    const ts_bake_params *bp = &b->params;
    uint32_t nc = bp->bands * bp->bands, n = bp->rays;
    size_t rays = (size_t)count * n;
    float *coeffs = malloc(count * nc * sizeof *coeffs), ref_c[16];
    ts_vec4 *pos = malloc(count * sizeof *pos), *nrm = malloc(count * sizeof *nrm);
    ts_vec4 *org = malloc(rays * sizeof *org), *dir = malloc(rays * sizeof *dir);
    ts_hit *hit = malloc(rays * sizeof *hit);
    uint32_t *entry = malloc(rays * sizeof *entry), *from = malloc(rays * sizeof *from);
    uint8_t *escaped = malloc(n);
    assert_true(coeffs && pos && nrm && org && dir && hit && entry && from && escaped);
    ts_error err = {0};
    if (bake_stage_wave(p, first, count, coeffs, pos, nrm, &err)) fail_msg("%s", err.msg);
    cl_command_queue q = p->cl->queue;
    assert_int_equal(
        clEnqueueReadBuffer(q, p->ray_org, CL_TRUE, 0, rays * sizeof *org, org, 0, NULL, NULL),
        CL_SUCCESS);
    clEnqueueReadBuffer(q, p->ray_dir, CL_TRUE, 0, rays * sizeof *dir, dir, 0, NULL, NULL);
    clEnqueueReadBuffer(q, p->ray_hit, CL_TRUE, 0, rays * sizeof *hit, hit, 0, NULL, NULL);
    clEnqueueReadBuffer(q, p->ray_from, CL_TRUE, 0, rays * sizeof *from, from, 0, NULL, NULL);
    uint32_t traced = 0, blocked = 0;
    for (uint32_t i = 0; i < count; ++i) {
        ts_vec4 rp, rn;
        uint32_t patch;
        bake_ref_point(s, bp, lod, first_of, first + i, &rp, &rn, &patch);
        assert_vec_close("point", first + i, pos[i], rp, 1e-4f);
        assert_vec_close("normal", first + i, nrm[i], rn, 1e-4f);
        for (uint32_t k = 0; k < n; ++k) {
            size_t r = (size_t)i * n + k;
            ts_vec4 ro, rd;
            int rt;
            bake_ref_ray(bp, pos[i], nrm[i], first + i, k, &ro, &rd, &rt);
            assert_vec_close("ray origin", (uint32_t)r, org[r], ro, 1e-5f);
            assert_vec_close("ray direction", (uint32_t)r, dir[r], rd, 1e-5f);
            assert_int_equal(from[r], patch + 1u);
            float cn = rd.x * rn.x + rd.y * rn.y + rd.z * rn.z;
            /* untraced rays keep their cleared hit; traced ones may have one */
            if (!rt && fabsf(cn) > 1e-5f) assert_int_equal(hit[r].patch, TS_INVALID);
            traced += (uint32_t)rt;
            blocked += rt && hit[r].patch != TS_INVALID;
            escaped[k] = hit[r].patch == TS_INVALID;
        }
        bake_ref_project(bp, nrm[i], &dir[(size_t)i * n], escaped, ref_c);
        for (uint32_t c = 0; c < nc; ++c)
            assert_close("coefficient", first + i, coeffs[(size_t)i * nc + c], ref_c[c], 2e-5f);
    }
    assert_true(traced > blocked);
    free(coeffs), free(pos), free(nrm), free(org), free(dir), free(hit), free(entry), free(from);
    free(escaped);
    return blocked;
}

static void run_case(ts_device *cl, const ts_scene *s, const bake_case *c, uint32_t *rng)
{
    uint32_t np = s->patch_count;
    uint32_t *lod = malloc(np * sizeof *lod), *first = malloc((np + 1) * sizeof *first);
    assert_true(lod && first);
    first[0] = 0;
    for (uint32_t p = 0; p < np; ++p) {
        lod[p] = (uint32_t)test_uniform(rng, 0.0f, (float)c->max_m + 0.999f);
        first[p + 1] = first[p] + ((1u << lod[p]) + 1u) * ((1u << lod[p]) + 1u);
    }
    ts_stats stats;
    memset(&stats, 0, sizeof stats);
    ts_error err = {0};
    ts_pipeline_plan plan;
    ts_pipeline p;
    if (pipeline_plan(32u << 20, 40000, 6, cl->info.max_alloc, &plan, &err) ||
        pipeline_create(&p, cl, s, &plan, 1, &stats, &err))
        fail_msg("%s", err.msg);
    p.mode = (ts_trace_mode){1u, -1, 0, 0, 0u, 0, 1.0};
    ts_bake_setup setup = {.bands = c->bands,
                           .rays = c->rays,
                           .flags = c->flags,
                           .seed = c->seed,
                           .eye = {c->eye[0], c->eye[1], c->eye[2], 0.0f},
                           .lod = lod,
                           .point_first = first};
    if (bake_stage_create(&p, &setup, &err)) fail_msg("%s", err.msg);
    uint32_t total = first[np], per = p.bake->points_per_wave, blocked = 0;
    for (int w = 0; w < 3; ++w) {
        uint32_t start = (uint32_t)test_uniform(rng, 0.0f, (float)total - 1.0f);
        uint32_t count = per < 200u ? per : 200u;
        if (start + count > total) count = total - start;
        blocked += check_wave(&p, s, lod, first, start, count);
    }
    /* The teapot occludes itself: blocked and escaping rays were both compared. */
    if (blocked == 0) fail_msg("case of %u rays, flags %u: no ray was blocked", c->rays, c->flags);
    pipeline_destroy(&p);
    stats_free(&stats); /* the iterations log pipeline_trace appended to */
    free(lod), free(first);
}

static void test_bake_kernels_vs_reference(void **state)
{
    (void)state;
    ts_device cl;
    test_open_device(&cl);
    ts_scene s;
    memset(&s, 0, sizeof s);
    ts_error err = {0};
    if (scene_load(test_source_path("scene/teapot_displaced.rib"), &s, 1, &err))
        fail_msg("%s", err.msg);
    const bake_case cases[] = {
        {3, 64, 0, 1, 3, {0.0f, -8.0f, 4.0f}},
        {4, 37, TS_BAKE_COSINE, 7, 2, {5.0f, 5.0f, 5.0f}},
        {2, 48, TS_BAKE_SPHERE, 3, 3, {-4.0f, 2.0f, 1.0f}},
        {4, 32, TS_BAKE_SPHERE | TS_BAKE_COSINE | TS_BAKE_FRONT, 11, 2, {0.0f, 0.0f, 9.0f}},
        {1, 16, TS_BAKE_FRONT, 5, 4, {1.0f, 1.0f, 1.0f}},
    };
    uint32_t rng = 12345u;
    for (size_t i = 0; i < sizeof cases / sizeof *cases; ++i)
        run_case(&cl, &s, &cases[i], &rng);
    scene_free(&s);
    dev_close(&cl);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bake_kernels_vs_reference),
    };
    return TEST_RUN_WITH_DEVICE(tests, NULL);
}
