/* test_shading_normal.c — the shading normal of the `shade` kernel where it evaluates it
 * (shade_vertex_at: patch_quad_shading_normal_x4, kernels/lib/noise4.h, which evaluates the
 * hit micro-quad's four corners in SIMD lanes) against its plain-C reference
 * patch_quad_shading_normal (lib/patch.h): bit for bit, through the probe kernel
 * shade_normal_probe (kernels/shade.cl). Where the patch is resident shade reads the corners
 * from the diced grid instead; test_geometry's test_grid_normals_change_no_bit renders both.
 * Scenes: the teapot under fbm displacement with six octaves (three float8 noise
 * evaluations), ridged noise with five (an odd count: the last octave alone), and no
 * displacement (the Bézier normal at (u, v)). Points: random (patch, m, u, v) with m in
 * 0..10 and the micro-quad holding (u, v), the centres of random micro-quads (the leaf-box hits
 * of box mode), and the patch's edges and corners (the last micro-quad of a row or column).
 * Under Oclgrind (tools/check_kernels.sh) only the scene without displacement runs: Oclgrind
 * 21.10's --uninitialized plugin crashes (SIGSEGV in Uninitialized::instructionExecuted) on
 * the noise's float8 lanes, main's code as well as this. */
#include "test_support.h"
#include "lib/patch.h"
#include "pipeline/pipeline.h"
#include "ref/dice_build_ref.h"
#include "scene/rib/rib.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { P = 32, N = 6000 };

/* The teapot with `extra` inserted after WorldBegin. */
static void load(ts_scene *s, const char *extra)
{
    test_parse_scene_with("scene/teapot.rib", extra, s);
    assert_int_equal(s->patch_count, P);
}

static void check_scene(const char *extra)
{
    ts_device cl;
    test_open_device(&cl);
    ts_scene s;
    load(&s, extra);
    ts_stats stats;
    memset(&stats, 0, sizeof stats);
    ts_error err = {0};
    ts_pipeline_plan plan = {.ray_capacity = 64, .pair_capacity = 64};
    pipeline_plan_arenas(&plan, P, 2);
    ts_pipeline p;
    if (pipeline_create(&p, &cl, &s, &plan, 64, &stats, &err)) fail_msg("%s", err.msg);
    static float uv[2 * N];
    static uint32_t pm[4 * N];
    static ts_vec4 dev[N];
    uint32_t seed = 1234u;
    for (uint32_t i = 0; i < N; ++i) {
        uint32_t q = (uint32_t)test_uniform(&seed, 0.0f, (float)P) % P;
        uint32_t m = (uint32_t)test_uniform(&seed, 0.0f, 11.0f) % 11u;
        float u = test_uniform(&seed, 0.0f, 1.0f), v = test_uniform(&seed, 0.0f, 1.0f);
        if (i % 3 == 1) { /* a micro-quad's centre, as box mode reports its hits */
            float side = ldexpf(1.0f, (int)m);
            u = (floorf(u * side) + 0.5f) / side, v = (floorf(v * side) + 0.5f) / side;
        } else if (i % 11 == 2) { /* on the patch's edges and corners */
            u = (float)(i / 11 % 3) * 0.5f, v = (float)(i / 33 % 3) * 0.5f;
        }
        uint32_t side = 1u << m; /* the micro-quad holding (u, v) */
        uint32_t qi = (uint32_t)(u * (float)side), qj = (uint32_t)(v * (float)side);
        uv[2 * i] = u, uv[2 * i + 1] = v, pm[4 * i] = q, pm[4 * i + 1] = m;
        pm[4 * i + 2] = qi < side ? qi : side - 1u, pm[4 * i + 3] = qj < side ? qj : side - 1u;
    }
    cl_mem duv =
        dev_buffer_create(&cl, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof uv, uv, &err);
    cl_mem dpm =
        dev_buffer_create(&cl, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof pm, pm, &err);
    cl_mem dout = dev_buffer_create(&cl, CL_MEM_WRITE_ONLY, sizeof dev, NULL, &err);
    assert_true(duv && dpm && dout);
    cl_kernel k = dev_kernel_create(&cl, "shade_normal_probe", &err);
    assert_non_null(k);
    cl_uint count = N;
    if (dev_set_args(k, &err, DEV_ARG(duv), DEV_ARG(dpm), DEV_ARG(count), DEV_ARG(p.cp),
                     DEV_ARG(p.corner_n), DEV_ARG(p.mid_n), DEV_ARG(p.attr), DEV_ARG(p.xform),
                     DEV_ARG(p.textures), DEV_ARG(p.tex_pages), DEV_ARG(p.tex_pool), DEV_ARG(dout),
                     (size_t)0) ||
        dev_launch(&cl, k, TS_STAGE_shade, N, TS_LOCAL_SIZE, &err) || dev_finish(&cl, NULL, &err))
        fail_msg("%s", err.msg);
    assert_int_equal(
        clEnqueueReadBuffer(cl.queue, dout, CL_TRUE, 0, sizeof dev, dev, 0, NULL, NULL),
        CL_SUCCESS);
    int unit = 0;
    for (uint32_t i = 0; i < N; ++i) {
        uint32_t q = pm[4 * i], m = pm[4 * i + 1], qi = pm[4 * i + 2], qj = pm[4 * i + 3];
        dice_build_ref_patch r = dice_build_ref_patch_of(&s, q);
        ts_vec4 h = patch_quad_shading_normal(r.cp0, r.cn, r.mn, r.a, r.x, r.tex, uv[2 * i],
                                              uv[2 * i + 1], qi, qj, m, 0u);
        if (memcmp(&h, &dev[i], sizeof h))
            fail_msg("patch %u m %u quad (%u, %u) (u, v) = (%a, %a): device (%a %a %a %a), C (%a "
                     "%a %a %a)",
                     q, m, qi, qj, uv[2 * i], uv[2 * i + 1], dev[i].x, dev[i].y, dev[i].z, dev[i].w,
                     h.x, h.y, h.z, h.w);
        unit += fabsf(h.x * h.x + h.y * h.y + h.z * h.z - 1.0f) < 1e-5f;
    }
    assert_true(unit > N * 9 / 10); /* normals, not zeros: the comparison is not empty */
    clReleaseKernel(k);
    clReleaseMemObject(duv), clReleaseMemObject(dpm), clReleaseMemObject(dout);
    pipeline_destroy(&p);
    stats_free(&stats);
    scene_free(&s);
    dev_close(&cl);
}

static void test_fbm(void **state)
{
    check_scene("Displacement \"fbm\" \"float amplitude\" [0.03] \"float frequency\" [5] "
                "\"float octaves\" [6] \"float lacunarity\" [2] \"float gain\" [0.55]\n");
}

static void test_ridged(void **state)
{
    check_scene("Displacement \"ridged\" \"float amplitude\" [0.05] \"float frequency\" [3] "
                "\"float octaves\" [5]\n");
}

static void test_plain(void **state)
{
    check_scene("");
}

/* An argument selects tests by name (cmocka's filter): tools/check_kernels.sh runs test_plain
 * only, see there. */
int main(int argc, char **argv)
{
    if (argc > 1) cmocka_set_test_filter(argv[1]);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fbm),
        cmocka_unit_test(test_ridged),
        cmocka_unit_test(test_plain),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
