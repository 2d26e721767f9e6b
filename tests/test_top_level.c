/* test_top_level.c — the top_level kernel's resumable ordered traversal against brute force:
 * over all iterations a ray emits exactly the patches whose box it meets within tmax, each
 * once (Hanika §3.1), for N = 1, 3 and 100 candidates per iteration and for water-filled
 * windows (trace.c water_fill; the rays whose candidates the counting launch stashed copied,
 * the same pairs as a traversal again), with infinite and finite tmax, and the traversal ends in
 * TS_INVALID, also launched in runs of rays with a cancel hook asked between them (which,
 * when it says stop, leaves the rays after the run untraversed). The reference is a slab test in
 * double written here (not the kernels' box_enter), and the rays must meet a minimum of boxes, so a
 * traversal that rejects every box fails. */
#include "test_support.h"
#include "pipeline/pipeline.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { PATCHES = 300, RAYS = 500 };

static void random_patches(ts_scene *s, uint32_t seed)
{
    memset(s, 0, sizeof *s);
    ts_error err = {0};
    for (int p = 0; p < PATCHES; ++p) {
        double cp[16][3];
        float ox = test_uniform(&seed, -10, 10), oy = test_uniform(&seed, -10, 10),
              oz = test_uniform(&seed, -10, 10), size = test_uniform(&seed, 0.1f, 2.5f);
        for (int k = 0; k < 16; ++k) {
            cp[k][0] = ox + size * test_uniform(&seed, 0, 1);
            cp[k][1] = oy + size * test_uniform(&seed, 0, 1);
            cp[k][2] = oz + size * test_uniform(&seed, 0, 1);
        }
        ts_patch_attr a = {.cs_r = 1, .cs_g = 1, .cs_b = 1};
        assert_int_equal(scene_add_patch(s, cp, &a, &err), TS_OK);
    }
}

/* A top-level BVH of CHAIN_NODES nodes in a chain (for test_deep_tree_every_box_once): node
 * i holds patches 3i .. 3i + 2 in children 0-2 and node i + 1, whose box is the union of the
 * patches after them, in child 3; every box spans most of the cube, so most rays descend to
 * the bottom, far deeper than the 8 levels whose hit masks top_level_collect remembers. */
enum { CHAIN_NODES = PATCHES / 3 };

static void chain_nodes(const ts_scene *s, ts_qbvh_node nodes[CHAIN_NODES])
{
    for (int i = CHAIN_NODES - 1; i >= 0; --i) {
        ts_qbvh_node *n = &nodes[i];
        memset(n, 0, sizeof *n);
        n->parent = i - 1, n->parent_slot = 3u, n->axes = 0u;
        ts_box below = {1, 1, 1, -1, -1, -1}; /* empty */
        if (i + 1 < CHAIN_NODES) {
            const ts_qbvh_node *c = &nodes[i + 1];
            below =
                (ts_box){c->lo_x[0], c->lo_y[0], c->lo_z[0], c->hi_x[0], c->hi_y[0], c->hi_z[0]};
            for (int k = 1; k < 4; ++k)
                if (c->child[k] != TS_CHILD_EMPTY) {
                    below.lo_x = fminf(below.lo_x, c->lo_x[k]),
                    below.hi_x = fmaxf(below.hi_x, c->hi_x[k]);
                    below.lo_y = fminf(below.lo_y, c->lo_y[k]),
                    below.hi_y = fmaxf(below.hi_y, c->hi_y[k]);
                    below.lo_z = fminf(below.lo_z, c->lo_z[k]),
                    below.hi_z = fmaxf(below.hi_z, c->hi_z[k]);
                }
        }
        for (int k = 0; k < 4; ++k) {
            ts_box b = k < 3 ? scene_patch_box(s, (uint32_t)(3 * i + k)) : below;
            n->child[k] = k < 3                 ? ~(ts_i32)(3 * i + k)
                          : i + 1 < CHAIN_NODES ? i + 1
                                                : TS_CHILD_EMPTY;
            n->lo_x[k] = b.lo_x, n->lo_y[k] = b.lo_y, n->lo_z[k] = b.lo_z;
            n->hi_x[k] = b.hi_x, n->hi_y[k] = b.hi_y, n->hi_z[k] = b.hi_z;
        }
    }
}

/* Replaces the pipeline's top-level BVH by the chain (its buffer holds as many nodes). */
static void use_chain(ts_device *cl, ts_pipeline *p, const ts_scene *s)
{
    assert_true(p->qbvh.node_count >= CHAIN_NODES);
    ts_qbvh_node nodes[CHAIN_NODES];
    chain_nodes(s, nodes);
    clEnqueueWriteBuffer(cl->queue, p->qbvh_nodes, CL_TRUE, 0, sizeof nodes, nodes, 0, NULL, NULL);
}

/* Whether the ray org + t dir, 0 <= t <= tmax, meets box x: the slab test in double,
 * written here apart from lib/intersect.h's box_enter (float, reciprocal directions, widened
 * far distance) that the kernel uses. A zero direction component meets its slab when the
 * origin lies in it. *close is set when the answer is within 1e-5 (relative) of turning:
 * the entry and exit distances, or the entry and tmax, nearly equal, or an origin on a face
 * of a slab it does not move across. */
static int slab_hit(ts_vec4 o, ts_vec4 d, ts_box x, float tmax, int *close)
{
    const double org[3] = {o.x, o.y, o.z}, dir[3] = {d.x, d.y, d.z},
                 lo[3] = {x.lo_x, x.lo_y, x.lo_z}, hi[3] = {x.hi_x, x.hi_y, x.hi_z};
    double t0 = 0.0, t1 = tmax;
    *close = 0;
    for (int a = 0; a < 3; ++a) {
        double eps = 1e-5 * (1.0 + fabs(lo[a]) + fabs(hi[a]));
        if (dir[a] == 0.0) {
            if (fabs(org[a] - lo[a]) <= eps || fabs(org[a] - hi[a]) <= eps) *close = 1;
            if (org[a] < lo[a] || org[a] > hi[a]) return 0;
            continue;
        }
        double ta = (lo[a] - org[a]) / dir[a], tb = (hi[a] - org[a]) / dir[a];
        t0 = fmax(t0, fmin(ta, tb));
        t1 = fmin(t1, fmax(ta, tb));
    }
    if (fabs(t1 - t0) <= 1e-5 * (1.0 + fabs(t0) + fabs(t1))) *close = 1;
    return t0 <= t1;
}

/* RAYS random rays from a cube of 24 into p's ray buffers, all active from the top-level root,
 * with infinite or random finite tmax; axis_zeros: every 17th has dir.y = 0 (the 0 * inf
 * path of the slab test). The host copies go to org, dir and hit. */
static void random_rays(ts_device *cl, ts_pipeline *p, uint32_t seed, int finite_tmax,
                        int axis_zeros, ts_vec4 *org, ts_vec4 *dir, ts_hit *hit)
{
    uint32_t entry[RAYS], active[RAYS];
    for (int r = 0; r < RAYS; ++r) {
        org[r] = (ts_vec4){test_uniform(&seed, -12, 12), test_uniform(&seed, -12, 12),
                           test_uniform(&seed, -12, 12), 0};
        float dx = test_uniform(&seed, -1, 1), dy = test_uniform(&seed, -1, 1),
              dz = test_uniform(&seed, -1, 1);
        if (axis_zeros && r % 17 == 0) dy = 0.0f;
        dir[r] = (ts_vec4){dx, dy, dz, 0};
        hit[r] = (ts_hit){finite_tmax ? test_uniform(&seed, 1, 20) : TS_NO_HIT, 0, 0, TS_INVALID,
                          TS_INVALID};
        entry[r] = TS_ENTRY_START;
        active[r] = (uint32_t)r;
    }
    cl_command_queue q = cl->queue;
    clEnqueueWriteBuffer(q, p->ray_org, CL_TRUE, 0, RAYS * sizeof *org, org, 0, NULL, NULL);
    clEnqueueWriteBuffer(q, p->ray_dir, CL_TRUE, 0, RAYS * sizeof *dir, dir, 0, NULL, NULL);
    clEnqueueWriteBuffer(q, p->ray_hit, CL_TRUE, 0, RAYS * sizeof *hit, hit, 0, NULL, NULL);
    clEnqueueWriteBuffer(q, p->ray_entry, CL_TRUE, 0, sizeof entry, entry, 0, NULL, NULL);
    clEnqueueWriteBuffer(q, p->active, CL_TRUE, 0, sizeof active, active, 0, NULL, NULL);
}

/* Over all iterations ray r emitted patch b (seen[r * PATCHES + b]) exactly when the slab
 * test in double says it meets b's box within tmax (either way within rounding of a face or
 * of tmax). The rays meet boxes: with these seeds 210 to 370 meetings a case (500 rays from a
 * cube of 24 through 300 boxes of up to 2.5 in a cube of 20), at least 125 (a quarter of the
 * rays) required, so a traversal that rejects every box cannot pass on an empty check. */
static void assert_every_box_once(const ts_scene *s, const ts_vec4 *org, const ts_vec4 *dir,
                                  const ts_hit *hit, const uint8_t *seen, const char *what)
{
    int wanted = 0, emitted = 0;
    for (int r = 0; r < RAYS; ++r)
        for (uint32_t b = 0; b < PATCHES; ++b) {
            int close = 0;
            int want = slab_hit(org[r], dir[r], scene_patch_box(s, b), hit[r].t, &close);
            int got = seen[(size_t)r * PATCHES + b];
            emitted += got;
            if (close) continue;
            wanted += want;
            if (want != got)
                fail_msg("ray %d patch %u: slab test in double %d, traversal %d (%s)", r, b, want,
                         got, what);
        }
    if (wanted < RAYS / 4 || emitted < wanted)
        fail_msg("%s: %d (ray, box) pairs emitted, %d meetings by the slab test", what, emitted,
                 wanted);
}

/* A cancel hook that never stops the trace and counts how often it was asked. */
/* A pipeline over scene s for RAYS rays and pair_capacity pairs, its stats in *stats. */
static void open_pipeline(ts_device *cl, const ts_scene *s, uint32_t pair_capacity, ts_pipeline *p,
                          ts_stats *stats)
{
    memset(stats, 0, sizeof *stats);
    ts_error err = {0};
    ts_pipeline_plan plan = {.ray_capacity = RAYS, .pair_capacity = pair_capacity};
    pipeline_plan_arenas(&plan, 1, 1);
    if (pipeline_create(p, cl, s, &plan, 1, stats, &err)) fail_msg("%s", err.msg);
}

static int asked;
static int ask_and_go_on(void *ctx)
{
    (void)ctx;
    ++asked;
    return 0;
}

/* With `runs`, top_level is launched in runs of 128 rays with the hook asked between them
 * (pipeline.h top_level_run): the same pairs, the hook asked 3 times a launch of 500. */
static void run_case(ts_device *cl, const ts_scene *s, uint32_t n_per_ray, int finite_tmax,
                     int chain, int runs)
{
    ts_stats stats;
    ts_error err = {0};
    ts_pipeline p;
    open_pipeline(cl, s, RAYS * 100, &p, &stats);
    if (chain) use_chain(cl, &p, s);
    if (runs) p.cancel = ask_and_go_on, p.top_level_run = 128u;
    asked = 0;
    ts_vec4 org[RAYS], dir[RAYS];
    ts_hit hit[RAYS];
    uint32_t entry[RAYS];
    random_rays(cl, &p, 99u + n_per_ray, finite_tmax, 1, org, dir, hit);
    cl_command_queue q = cl->queue;
    uint8_t *seen = calloc((size_t)RAYS * PATCHES, 1);
    ts_pair *pairs = malloc((size_t)RAYS * n_per_ray * sizeof *pairs);
    uint32_t count[RAYS];
    int done = 0;
    int launches = 0;
    for (int it = 0; it < 1000 && !done; ++it, ++launches) {
        if (pipeline_top_level(&p, RAYS, n_per_ray, &err)) fail_msg("%s", err.msg);
        assert_false(p.cancelled);
        clEnqueueReadBuffer(q, p.pairs, CL_TRUE, 0, (size_t)RAYS * n_per_ray * sizeof *pairs, pairs,
                            0, NULL, NULL);
        clEnqueueReadBuffer(q, p.count, CL_TRUE, 0, sizeof count, count, 0, NULL, NULL);
        clEnqueueReadBuffer(q, p.ray_entry, CL_TRUE, 0, sizeof entry, entry, 0, NULL, NULL);
        done = 1;
        for (int r = 0; r < RAYS; ++r) {
            assert_true(count[r] <= n_per_ray);
            for (uint32_t k = 0; k < count[r]; ++k) { /* the rest of the window is unused */
                ts_pair pr = pairs[r * n_per_ray + k];
                assert_int_equal(pr.window, r * n_per_ray + k);
                assert_true(pr.leaf < PATCHES);
                if (seen[(size_t)r * PATCHES + pr.leaf]++)
                    fail_msg("ray %d emitted patch %u twice (N=%u)", r, pr.leaf, n_per_ray);
            }
            if (entry[r] != TS_INVALID)
                done = 0;
            else if (count[r] == 0)
                continue;
        }
    }
    assert_true(done);
    assert_int_equal(asked, runs ? 3 * launches : 0);
    char what[64];
    snprintf(what, sizeof what, "N=%u, finite tmax %d%s%s", n_per_ray, finite_tmax,
             chain ? ", chain" : "", runs ? ", runs" : "");
    assert_every_box_once(s, org, dir, hit, seen, what);
    free(seen);
    free(pairs);
    pipeline_destroy(&p);
    stats_free(&stats);
}

/* Water-filled windows (n_per_ray 0, trace.c water_fill) of at most max_n candidates, with a
 * pair buffer of 1.5 a ray: ray r's window is [first[r], first[r + 1]), filled in order with
 * its next candidates and then TS_INVALID leaves; a ray whose window is shorter than the cap
 * N had no more candidates and ends its traversal in that iteration; over all iterations
 * every box it meets is emitted once, as with uniform windows. */
static void run_filled_case(ts_device *cl, const ts_scene *s, uint32_t max_n, int finite_tmax,
                            int chain)
{
    ts_stats stats;
    ts_error err = {0};
    ts_pipeline p;
    /* (at least a pair a ray: water_fill's contract, as pipeline_plan's three) */
    open_pipeline(cl, s, RAYS * 3 / 2, &p, &stats);
    if (chain) use_chain(cl, &p, s);
    ts_vec4 org[RAYS], dir[RAYS];
    ts_hit hit[RAYS];
    uint32_t entry[RAYS], count[RAYS], first[RAYS + 1];
    random_rays(cl, &p, 5u + (uint32_t)finite_tmax, finite_tmax, 0, org, dir, hit);
    cl_command_queue q = cl->queue;
    uint8_t *seen = calloc((size_t)RAYS * PATCHES, 1);
    ts_pair *pairs = malloc((size_t)p.plan.pair_capacity * sizeof *pairs);
    ts_pair *traversed = malloc((size_t)p.plan.pair_capacity * sizeof *traversed);
    uint32_t entry0[RAYS], entry_t[RAYS], count_t[RAYS];
    int done = 0, iterations = 0, ended_short = 0, capped = 0, stashed = 0;
    for (; iterations < 1000 && !done; ++iterations) {
        uint32_t n = 0, slots = 0, slots_t = 0;
        /* First every ray traversed again by the collecting launch (no stash), from the same
         * start; then, from that start again, as the pipeline runs it: the rays whose
         * candidates the counting launch stashed copied. The same pairs, counts and ends. */
        clEnqueueReadBuffer(q, p.ray_entry, CL_TRUE, 0, sizeof entry0, entry0, 0, NULL, NULL);
        if (pipeline_water_fill(&p, RAYS, max_n, &n, &slots_t, &err)) fail_msg("%s", err.msg);
        p.stash_n = 0;
        if (pipeline_top_level(&p, RAYS, 0, &err)) fail_msg("%s", err.msg);
        clEnqueueReadBuffer(q, p.pairs, CL_TRUE, 0, (size_t)slots_t * sizeof *traversed, traversed,
                            0, NULL, NULL);
        clEnqueueReadBuffer(q, p.count, CL_TRUE, 0, sizeof count_t, count_t, 0, NULL, NULL);
        clEnqueueReadBuffer(q, p.ray_entry, CL_TRUE, 0, sizeof entry_t, entry_t, 0, NULL, NULL);
        clEnqueueWriteBuffer(q, p.ray_entry, CL_TRUE, 0, sizeof entry0, entry0, 0, NULL, NULL);
        if (pipeline_water_fill(&p, RAYS, max_n, &n, &slots, &err)) fail_msg("%s", err.msg);
        uint32_t stash_n = p.stash_n;
        if (pipeline_top_level(&p, RAYS, 0, &err)) fail_msg("%s", err.msg);
        assert_true(n >= 1 && n <= max_n && slots <= p.plan.pair_capacity);
        clEnqueueReadBuffer(q, p.window_first, CL_TRUE, 0, sizeof first, first, 0, NULL, NULL);
        clEnqueueReadBuffer(q, p.pairs, CL_TRUE, 0, (size_t)slots * sizeof *pairs, pairs, 0, NULL,
                            NULL);
        clEnqueueReadBuffer(q, p.count, CL_TRUE, 0, sizeof count, count, 0, NULL, NULL);
        clEnqueueReadBuffer(q, p.ray_entry, CL_TRUE, 0, sizeof entry, entry, 0, NULL, NULL);
        assert_int_equal(slots, slots_t);
        assert_memory_equal(pairs, traversed, (size_t)slots * sizeof *pairs);
        assert_memory_equal(count, count_t, sizeof count);
        assert_memory_equal(entry, entry_t, sizeof entry);
        for (int r = 0; r < RAYS; ++r)
            stashed += count[r] > 0 && count[r] <= stash_n;
        assert_int_equal(first[0], 0);
        assert_int_equal(first[RAYS], slots);
        done = 1;
        for (int r = 0; r < RAYS; ++r) {
            uint32_t len = first[r + 1] - first[r];
            assert_true(len <= n && count[r] <= len);
            for (uint32_t k = 0; k < len; ++k) {
                ts_pair pr = pairs[first[r] + k];
                assert_int_equal(pr.window, first[r] + k);
                if (k >= count[r]) {
                    assert_int_equal(pr.leaf, TS_INVALID);
                    continue;
                }
                assert_true(pr.leaf < PATCHES);
                if (seen[(size_t)r * PATCHES + pr.leaf]++)
                    fail_msg("ray %d emitted patch %u twice (filled, N=%u)", r, pr.leaf, n);
            }
            if (len < n && entry[r] != TS_INVALID) /* it had no more candidates */
                fail_msg("ray %d: %u candidates under the cap %u, traversal not ended", r, len, n);
            ended_short += len < n && len > 0;
            capped += len == n && entry[r] != TS_INVALID;
            if (entry[r] != TS_INVALID) done = 0;
        }
    }
    assert_true(done);
    /* Windows that held all of a ray's candidates occur, and with a cap of two full ones;
     * rays copied from the stash occur. */
    assert_true(ended_short > 0);
    assert_true(stashed > 0);
    assert_true(max_n > 2 || (capped > 0 && iterations > 1));
    char what[64];
    snprintf(what, sizeof what, "filled, cap %u, finite tmax %d%s", max_n, finite_tmax,
             chain ? ", chain" : "");
    assert_every_box_once(s, org, dir, hit, seen, what);
    free(seen);
    free(pairs);
    free(traversed);
    pipeline_destroy(&p);
    stats_free(&stats);
}

static void test_every_box_once(void **state)
{
    ts_device cl;
    test_open_device(&cl);
    ts_scene s;
    random_patches(&s, 7u);
    const uint32_t ns[3] = {1, 3, 100};
    for (int i = 0; i < 3; ++i)
        for (int finite = 0; finite < 2; ++finite)
            run_case(&cl, &s, ns[i], finite, 0, 0);
    for (int finite = 0; finite < 2; ++finite) {
        run_filled_case(&cl, &s, 2, finite, 0);
        run_filled_case(&cl, &s, 100, finite, 0);
    }
    scene_free(&s);
    dev_close(&cl);
}

/* The same through a top-level BVH deeper than the 8 levels whose hit masks
 * top_level_collect remembers (chain_nodes: it tests a node's children again when it climbs
 * above them), from the root and resumed below it. */
static void test_deep_tree_every_box_once(void **state)
{
    ts_device cl;
    test_open_device(&cl);
    ts_scene s;
    random_patches(&s, 7u);
    for (int finite = 0; finite < 2; ++finite) {
        run_case(&cl, &s, 3, finite, 1, 0);
        run_case(&cl, &s, 100, finite, 1, 0);
        run_filled_case(&cl, &s, 100, finite, 1);
    }
    scene_free(&s);
    dev_close(&cl);
}

/* top_level in runs of rays with a cancel hook asked between them: every box once, as in
 * one launch; and a hook that says stop leaves the rays after the first run untraversed
 * (their counts as they were), sets cancelled, and asks no more. */
static int stop_asked(void *ctx)
{
    (void)ctx;
    ++asked;
    return 1;
}

static void test_runs_between_stops(void **state)
{
    ts_device cl;
    test_open_device(&cl);
    ts_scene s;
    random_patches(&s, 7u);
    for (int finite = 0; finite < 2; ++finite)
        run_case(&cl, &s, 3, finite, 0, 1);
    ts_stats stats;
    ts_error err = {0};
    ts_pipeline p;
    open_pipeline(&cl, &s, RAYS * 3, &p, &stats);
    ts_vec4 org[RAYS], dir[RAYS];
    ts_hit hit[RAYS];
    random_rays(&cl, &p, 3u, 0, 0, org, dir, hit);
    uint32_t count[RAYS];
    for (int r = 0; r < RAYS; ++r)
        count[r] = 0xdeadbeefu;
    clEnqueueWriteBuffer(cl.queue, p.count, CL_TRUE, 0, sizeof count, count, 0, NULL, NULL);
    p.cancel = stop_asked, p.top_level_run = 128u, asked = 0;
    if (pipeline_top_level(&p, RAYS, 3, &err)) fail_msg("%s", err.msg);
    assert_true(p.cancelled);
    assert_int_equal(asked, 1);
    clEnqueueReadBuffer(cl.queue, p.count, CL_TRUE, 0, sizeof count, count, 0, NULL, NULL);
    for (int r = 0; r < RAYS; ++r)
        if ((count[r] == 0xdeadbeefu) != (r >= 128)) fail_msg("ray %d: count %x", r, count[r]);
    pipeline_destroy(&p);
    stats_free(&stats);
    scene_free(&s);
    dev_close(&cl);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_every_box_once),
                                       cmocka_unit_test(test_deep_tree_every_box_once),
                                       cmocka_unit_test(test_runs_between_stops)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
