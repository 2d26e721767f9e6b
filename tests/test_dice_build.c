/* test_dice_build.c — the dice and build kernels against plain-C references on random
 * patches: dice vertices vs an independent de Casteljau evaluation in double (tolerance)
 * and vs the shared float evaluation (bitwise); quad-tree leaf boxes vs their micro-quad's
 * vertices and inner boxes vs the union of their children (exact). */
#include "test_support.h"
#include "lib/bezier.h"
#include "lib/quadtree.h"
#include "pipeline.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* de Casteljau on 4 points, double precision: independent of lib/bezier.h. */
static void casteljau(const double p[4][3], double t, double out[3])
{
    double q[4][3];
    memcpy(q, p, sizeof q);
    for (int r = 3; r > 0; --r)
        for (int i = 0; i < r; ++i)
            for (int k = 0; k < 3; ++k) q[i][k] = (1 - t) * q[i][k] + t * q[i + 1][k];
    memcpy(out, q[0], sizeof q[0]);
}

static void reference_point(const ts_vec4 *cp, double u, double v, double out[3])
{
    double rows[4][3];
    for (int j = 0; j < 4; ++j) {
        double row[4][3];
        for (int i = 0; i < 4; ++i) {
            row[i][0] = cp[j * 4 + i].x, row[i][1] = cp[j * 4 + i].y, row[i][2] = cp[j * 4 + i].z;
        }
        casteljau(row, u, rows[j]);
    }
    casteljau(rows, v, out);
}

static void random_scene(ts_scene *s, int patches, uint32_t seed)
{
    memset(s, 0, sizeof *s);
    ts_error err = {0};
    for (int p = 0; p < patches; ++p) {
        double cp[16][3];
        float ox = test_uniform(&seed, -5, 5), oy = test_uniform(&seed, -5, 5), oz = test_uniform(&seed, -5, 5);
        for (int j = 0; j < 4; ++j)
            for (int i = 0; i < 4; ++i) {
                cp[j * 4 + i][0] = ox + i + test_uniform(&seed, -0.4f, 0.4f);
                cp[j * 4 + i][1] = oy + j + test_uniform(&seed, -0.4f, 0.4f);
                cp[j * 4 + i][2] = oz + test_uniform(&seed, -1.5f, 1.5f);
            }
        ts_patch_attr a = {1, 1, 1, 0};
        assert_int_equal(scene_add_patch(s, cp, &a, &err), TS_OK);
    }
}

static int box_equal(ts_box a, ts_box b)
{
    return a.lo_x == b.lo_x && a.lo_y == b.lo_y && a.lo_z == b.lo_z && a.hi_x == b.hi_x &&
           a.hi_y == b.hi_y && a.hi_z == b.hi_z;
}

static void check_segment(const ts_scene *s, const ts_segment *seg, const ts_vec4 *grid,
                          const ts_box4 *nodes)
{
    const ts_vec4 *cp = &s->cp[seg->patch * 16];
    uint32_t m = seg->lod, n = (1u << m) + 1u;
    ts_box ext = {1e30f, 1e30f, 1e30f, -1e30f, -1e30f, -1e30f};
    for (int k = 0; k < 16; ++k) {
        ext.lo_x = fminf(ext.lo_x, cp[k].x), ext.hi_x = fmaxf(ext.hi_x, cp[k].x);
        ext.lo_y = fminf(ext.lo_y, cp[k].y), ext.hi_y = fmaxf(ext.hi_y, cp[k].y);
        ext.lo_z = fminf(ext.lo_z, cp[k].z), ext.hi_z = fmaxf(ext.hi_z, cp[k].z);
    }
    double tol = 1e-5 * fmax(ext.hi_x - ext.lo_x, fmax(ext.hi_y - ext.lo_y, ext.hi_z - ext.lo_z));
    for (uint32_t j = 0; j < n; ++j)
        for (uint32_t i = 0; i < n; ++i) {
            ts_vec4 g = grid[j * n + i];
            ts_vec4 same = bezier_eval(cp, ldexpf((float)i, -(int)m), ldexpf((float)j, -(int)m));
            if (memcmp(&g, &same, sizeof g) != 0)
                fail_msg("patch %u m %u vertex (%u,%u): device (%a %a %a) host (%a %a %a)", seg->patch,
                         m, i, j, g.x, g.y, g.z, same.x, same.y, same.z);
            double r[3];
            reference_point(cp, ldexp(i, -(int)m), ldexp(j, -(int)m), r);
            assert_true(fabs(g.x - r[0]) <= tol && fabs(g.y - r[1]) <= tol && fabs(g.z - r[2]) <= tol);
        }
    /* Leaves: exactly the box of the micro-quad's four vertices. */
    uint32_t side = 1u << m;
    for (uint32_t k = 0; k < side * side; ++k) {
        uint32_t i = morton_i(k), j = morton_j(k);
        ts_vec4 v[4] = {grid[j * n + i], grid[j * n + i + 1], grid[(j + 1) * n + i], grid[(j + 1) * n + i + 1]};
        ts_box b = {v[0].x, v[0].y, v[0].z, v[0].x, v[0].y, v[0].z};
        for (int q = 1; q < 4; ++q) {
            b.lo_x = fminf(b.lo_x, v[q].x), b.hi_x = fmaxf(b.hi_x, v[q].x);
            b.lo_y = fminf(b.lo_y, v[q].y), b.hi_y = fmaxf(b.hi_y, v[q].y);
            b.lo_z = fminf(b.lo_z, v[q].z), b.hi_z = fmaxf(b.hi_z, v[q].z);
        }
        assert_true(box_equal(b, quadtree_box(nodes, m, k)));
    }
    /* Inner nodes: exactly the union of their four children. */
    for (uint32_t l = 0; l < m; ++l)
        for (uint32_t k = 0; k < (1u << (2 * l)); ++k) {
            ts_box u = quadtree_box(nodes, l + 1, 4 * k);
            for (uint32_t q = 1; q < 4; ++q) {
                ts_box c = quadtree_box(nodes, l + 1, 4 * k + q);
                u.lo_x = fminf(u.lo_x, c.lo_x), u.hi_x = fmaxf(u.hi_x, c.hi_x);
                u.lo_y = fminf(u.lo_y, c.lo_y), u.hi_y = fmaxf(u.hi_y, c.hi_y);
                u.lo_z = fminf(u.lo_z, c.lo_z), u.hi_z = fmaxf(u.hi_z, c.hi_z);
            }
            if (!box_equal(u, quadtree_box(nodes, l, k)))
                fail_msg("patch %u m %u: node %u of level %u is not the union of its children",
                         seg->patch, m, k, l);
        }
}

static void test_dice_and_build_match_reference(void **state)
{
    ts_cl cl;
    test_open_device(&cl);
    ts_scene s;
    random_scene(&s, 6, 12345u);
    ts_stats stats;
    memset(&stats, 0, sizeof stats);
    ts_error err = {0};
    ts_pipeline_plan plan = {.ray_capacity = 64, .pair_capacity = 512, .slot_count = 6, .max_lod = 5};
    ts_pipeline p;
    if (pipeline_create(&p, &cl, &s, &plan, 1, &stats, &err)) fail_msg("%s", err.msg);
    const uint32_t lods[6] = {0, 1, 2, 3, 5, 4};
    for (uint32_t i = 0; i < 6; ++i)
        p.segments_host[i] = (ts_segment){.patch = 5 - i, .slot = (i + 2) % 6, .lod = lods[i]};
    if (pipeline_dice_build(&p, 6, &err)) fail_msg("%s", err.msg);
    size_t gbytes = 6 * (size_t)p.verts_per_slot * sizeof(ts_vec4);
    size_t nbytes = 6 * (size_t)p.groups_per_slot * sizeof(ts_box4);
    ts_vec4 *grid = malloc(gbytes);
    ts_box4 *nodes = malloc(nbytes);
    assert_int_equal(clEnqueueReadBuffer(cl.queue, p.grid, CL_TRUE, 0, gbytes, grid, 0, NULL, NULL), CL_SUCCESS);
    assert_int_equal(clEnqueueReadBuffer(cl.queue, p.nodes, CL_TRUE, 0, nbytes, nodes, 0, NULL, NULL), CL_SUCCESS);
    for (uint32_t i = 0; i < 6; ++i) {
        const ts_segment *seg = &p.segments_host[i];
        check_segment(&s, seg, grid + (size_t)seg->slot * p.verts_per_slot,
                      nodes + (size_t)seg->slot * p.groups_per_slot);
    }
    assert_int_equal(stats.counters[TS_COUNTER_patches_diced], 6);
    assert_int_equal(stats.counters[TS_COUNTER_micropolygons_created], 1 + 4 + 16 + 64 + 1024 + 256);
    free(grid);
    free(nodes);
    pipeline_destroy(&p);
    scene_free(&s);
    cl_close(&cl);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_dice_and_build_match_reference)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
