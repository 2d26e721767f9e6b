/* test_bottom_level.c — the bottom_level kernels against their plain-C reference
 * (host/ref/bottom_level_ref.c, DESIGN.md §5), and dice/build against theirs
 * (host/ref/dice_build_ref.c): the real pipeline stages on the device dice the teapot's patches
 * at LODs 0..5, then every (ray, patch) pair of a 48 x 27 frame is traced by the kernel and
 * by the C reference; the hit records (t, u, v, patch, prim) must agree bitwise for every
 * pair, in both geometry modes (leaf boxes, micro-triangles), leaf blocks of 1, 2 and 4
 * micro-quads a side, and both kernels (per ray, work-group). Rays carry jittered
 * directions, random times, and some a tmin > 0 or a finite tmax, so culling, the
 * inside-the-box rule and motion interpolation are covered. Scenes: the teapot, a displaced
 * (fbm) teapot, and the displaced teapot moving over the shutter; and the displaced teapot
 * as an object instanced twice (ObjectInstance, the second turned), whose second instance's
 * segments trace the first's dicing through the ray moved into its frame (lib/instance.h); and
 * the displaced teapot with every other patch trimmed to a ring (lib/trim.h: its removed
 * micro-quads have empty boxes, which the triangles' test honours too). */
#include "test_support.h"
#include "ref/bottom_level_ref.h"
#include "ref/dice_build_ref.h"
#include "lib/quadtree.h"
#include "pipeline/pipeline.h"
#include "app/render.h"
#include "scene/rib/rib.h"
#include "scene/scene.h"

#include <math.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { W = 48, H = 27, R = W * H, P = 32, M = 5 };

/* The teapot; displaced: fbm on every patch; moving: and translated over the shutter. */
static void load(ts_scene *s, int displaced, int moving)
{
    char extra[400] = "";
    if (displaced)
        strcat(extra, "Displacement \"fbm\" \"float amplitude\" [0.15] \"float frequency\" [3] "
                      "\"float octaves\" [3]\n"); /* rough at m = 5: tight codes */
    if (moving)
        strcat(extra, "MotionBegin [0 1]\nTranslate 0 0 0\nTranslate 0.15 -0.1 0.05\nMotionEnd\n");
    test_parse_scene_with("scene/teapot.rib", extra, s);
    assert_int_equal(s->patch_count, P);
}

static void read_buffer(ts_device *cl, cl_mem m, size_t bytes, void *host)
{
    assert_int_equal(clEnqueueReadBuffer(cl->queue, m, CL_TRUE, 0, bytes, host, 0, NULL, NULL),
                     CL_SUCCESS);
}

static void write_buffer(ts_device *cl, cl_mem m, size_t bytes, const void *host)
{
    assert_int_equal(clEnqueueWriteBuffer(cl->queue, m, CL_TRUE, 0, bytes, host, 0, NULL, NULL),
                     CL_SUCCESS);
}

/* The rays of the frame at 4 spp (jittered, with times), then some given a tmin > 0 and some
 * a finite tmax around the teapot's depth; written back to the device. */
static void make_rays(ts_device *cl, ts_pipeline *p, const ts_scene *s, ts_vec4 *org, ts_vec4 *dir,
                      ts_hit *hit, uint32_t *flags, uint32_t *from, uint32_t *active)
{
    ts_error err = {0};
    ts_camera_params cam;
    if (render_camera_params(&s->camera, W, H, &cam, &err)) fail_msg("%s", err.msg);
    cam.spp = 4;
    cam.ray_count = R;
    cam.first_sample = 2u * R; /* the third sample pass: jittered */
    if (pipeline_camera(p, &cam, &err) || dev_finish(cl, p->stats, &err)) fail_msg("%s", err.msg);
    read_buffer(cl, p->ray_org, R * sizeof *org, org);
    read_buffer(cl, p->ray_dir, R * sizeof *dir, dir);
    read_buffer(cl, p->ray_hit, R * sizeof *hit, hit);
    read_buffer(cl, p->ray_flags, R * sizeof *flags, flags);
    read_buffer(cl, p->active, R * sizeof *active, active);
    uint32_t seed = 99u;
    for (int i = 0; i < R; ++i) {
        /* Leaving patch (i / 5) % P: hits on it nearer than org.w are ignored there only. */
        from[i] = i % 5 == 2 || i % 5 == 3 ? (uint32_t)(i / 5) % P + 1u : 0u;
        if (i % 5 == 2 || i % 5 == 4)
            org[i].w = test_uniform(&seed, 7.5f, 10.5f); /* teapot depth */
        if (i % 3 == 1) hit[i].t = test_uniform(&seed, 6.0f, 12.0f);
        /* Shadow rays, which any hit answers (the first leaf block with one); some aim at a
         * patch's light, which does not stop them. */
        if (i % 7 == 3) flags[i] = TS_RAY_SHADOW;
        if (i % 7 == 5) flags[i] = TS_RAY_SHADOW | (((uint32_t)(i / 7) % P + 1u) << 1);
    }
    write_buffer(cl, p->ray_flags, R * sizeof *flags, flags);
    write_buffer(cl, p->ray_from, R * sizeof *from, from);
    write_buffer(cl, p->ray_org, R * sizeof *org, org);
    write_buffer(cl, p->ray_hit, R * sizeof *hit, hit);
}

/* Trims every other patch of s to the ring between circles of radii 0.15 and 0.4 about the
 * centre of its (u, v) square: two 32-gons, the inner one a hole (the even-odd rule). */
static void trim_ring(ts_scene *s)
{
    ts_vec4 seg[64];
    for (int k = 0; k < 64; ++k) {
        double r = k < 32 ? 0.4 : 0.15, a0 = 2.0 * M_PI * (k % 32) / 32.0,
               a1 = 2.0 * M_PI * (k % 32 + 1) / 32.0;
        seg[k] = (ts_vec4){(float)(0.5 + r * cos(a0)), (float)(0.5 + r * sin(a0)),
                           (float)(0.5 + r * cos(a1)), (float)(0.5 + r * sin(a1))};
    }
    uint32_t first;
    ts_error err = {0};
    if (scene_add_trim(s, seg, 64, &first, &err)) fail_msg("%s", err.msg);
    for (uint32_t q = 0; q < s->patch_count; q += 2)
        s->attr[q].trim_first = first, s->attr[q].trim_count = 64;
}

static void check_scene(int displaced, int moving, int trimmed)
{
    ts_device cl;
    test_open_device(&cl);
    ts_scene s;
    load(&s, displaced, moving);
    if (trimmed) trim_ring(&s);
    ts_stats stats;
    memset(&stats, 0, sizeof stats);
    ts_error err = {0};
    ts_pipeline_plan plan = {.ray_capacity = R, .pair_capacity = R * P};
    pipeline_plan_arenas(&plan, P, M);
    ts_pipeline p;
    if (pipeline_create(&p, &cl, &s, &plan, R, &stats, &err)) fail_msg("%s", err.msg);
    static ts_vec4 org[R], dir[R];
    static ts_hit hit[R], dev[R * P], ref[R * P];
    static uint32_t flags[R], from[R], active[R];
    make_rays(&cl, &p, &s, org, dir, hit, flags, from, active);
    /* Patch q at m = q % 6, its pairs [q R, (q + 1) R): every ray, window = ray * P + q. */
    static ts_pair pairs[R * P];
    for (uint32_t q = 0; q < P; ++q) {
        p.segments_host[q] =
            (ts_segment){.patch = q, .begin = q * R, .end = (q + 1) * R, .lod = q % (M + 1)};
        for (uint32_t r = 0; r < R; ++r)
            pairs[q * R + r] = (ts_pair){q, r * P + q};
    }
    if (pipeline_dice_build(&p, P, &err)) fail_msg("%s", err.msg);
    write_buffer(&cl, p.pairs, sizeof pairs, pairs);
    size_t gbytes = (size_t)plan.vert_capacity * sizeof(ts_vec4),
           nbytes = (size_t)plan.group_capacity * sizeof(ts_box4);
    size_t cbytes = (size_t)plan.group_capacity * sizeof(ts_tight4);
    ts_vec4 *grid = malloc(gbytes), *hgrid = malloc(gbytes);
    ts_box4 *groups = malloc(nbytes), *hgroups = malloc(nbytes);
    ts_tight4 *codes = malloc(cbytes), *hcodes = malloc(cbytes);
    assert_true(grid && hgrid && groups && hgroups && codes && hcodes);
    read_buffer(&cl, p.grid, gbytes, grid);
    read_buffer(&cl, p.groups, nbytes, groups);
    read_buffer(&cl, p.tight, cbytes, codes);
    uint32_t rough = 0, empty = 0; /* patches with tight codes; trimmed leaves */
    /* dice and build: the host references write the same bits. */
    for (uint32_t q = 0; q < P; ++q) {
        const ts_segment *sg = &p.segments_host[q];
        uint32_t times = dice_build_ref_times(&s, q);
        assert_int_equal(times, moving ? 2u : 1u);
        assert_int_equal(sg->flags & TS_PATCH_MOVING, moving ? TS_PATCH_MOVING : 0u);
        rough += (sg->flags & TS_PATCH_ROUGH) != 0u;
        assert_int_equal(sg->flags & TS_SEG_TRIMMED, trimmed && q % 2 == 0 ? TS_SEG_TRIMMED : 0u);
        for (uint32_t k = 0; trimmed && k < (1u << (2u * sg->lod)); ++k)
            empty += quadtree_leaf_empty(groups + sg->group_first, sg->lod, k);
        dice_build_ref(&s, q, sg->lod, 0, hgrid, hgroups, hcodes);
        if (memcmp(hgrid, grid + sg->vert_first,
                   times * quadtree_vertex_count(sg->lod) * sizeof *grid))
            fail_msg("patch %u m %u: the host dice reference differs from dice_grid", q, sg->lod);
        if (memcmp(hgroups, groups + sg->group_first,
                   times * quadtree_group_count(sg->lod) * sizeof *groups) ||
            memcmp(hcodes, codes + sg->group_first,
                   times * quadtree_group_count(sg->lod) * sizeof *codes))
            fail_msg("patch %u m %u: the host build reference differs from build", q, sg->lod);
    }
    if (displaced) assert_true(rough > 0u); /* the tight traversal is compared too */
    if (trimmed) assert_true(empty > 0u);
    bl_ref_batch b = {
        pairs, 0,   R * P, p.segments_host, 0,    P,    P,      0,     0,          active,
        org,   dir, hit,   flags,           from, grid, groups, codes, s.instance, s.inst_xform};
    /* The shadow rays' any-hit answers are not all the closest hits, so the comparison
     * below sees where the kernels stop: the reference with every ray a closest-hit ray. */
    {
        static uint32_t none[R];
        static ts_hit closest[R * P], any[R * P];
        bl_ref_batch c = b;
        c.ray_flags = none;
        bottom_level_ref_pairs(&b, 0, R * P, any);
        bottom_level_ref_pairs(&c, 0, R * P, closest);
        uint32_t earlier = 0;
        for (uint32_t w = 0; w < R * P; ++w)
            if ((flags[w / P] & TS_RAY_SHADOW) && any[w].patch != TS_INVALID) {
                assert_true(closest[w].patch != TS_INVALID && closest[w].t <= any[w].t);
                earlier += closest[w].t < any[w].t;
            }
        assert_true(earlier > 0u);
    }
    uint64_t hits_boxes = 0, hits_exact = 0;
    for (int group = 0; group < 2; ++group)
        for (int exact = 0; exact < 2; ++exact)
            for (uint32_t lb = 0; lb <= 2; ++lb) {
                p.mode.exact = exact, p.mode.leaf_b = lb, p.mode.leaf_group = group;
                if (pipeline_bottom_level(&p, P, &err)) fail_msg("%s", err.msg);
                read_buffer(&cl, p.pair_hit, sizeof dev, dev);
                b.exact = (uint32_t)exact, b.leaf_b = lb;
                memset(ref, 0xab, sizeof ref);
                assert_true(bottom_level_ref_pairs(&b, 0, R * P, ref) > 0);
                uint64_t n = 0;
                for (uint32_t w = 0; w < R * P; ++w) {
                    const ts_hit *d = &dev[w], *h = &ref[w];
                    if (memcmp(d, h, sizeof *d))
                        fail_msg("%s kernel, %s, leaf %u, ray %u patch %u: device (%a %a %a %u %x) "
                                 "C (%a %a %a %u %x)",
                                 group ? "group" : "per-ray", exact ? "triangles" : "boxes",
                                 1u << lb, w / P, w % P, d->t, d->u, d->v, d->patch, d->prim, h->t,
                                 h->u, h->v, h->patch, h->prim);
                    n += h->patch != TS_INVALID;
                }
                *(exact ? &hits_exact : &hits_boxes) += n;
            }
    /* Something was hit in both modes: the teapot covers a good part of the frame. */
    assert_true(hits_boxes > (uint64_t)R && hits_exact > (uint64_t)R);
    free(grid), free(hgrid), free(groups), free(hgroups), free(codes), free(hcodes);
    pipeline_destroy(&p);
    stats_free(&stats);
    scene_free(&s);
    dev_close(&cl);
}

/* The displaced teapot as object 1, instanced twice: the second instance's 32 patches
 * share the first's dicing. */
static void load_instanced(ts_scene *s)
{
    FILE *f = fopen(test_source_path("scene/teapot.rib"), "rb");
    assert_non_null(f);
    static char text[1 << 20];
    size_t n = fread(text, 1, sizeof text - 1000, f);
    fclose(f);
    text[n] = '\0';
    char *wb = strstr(text, "WorldBegin\n"), *we = strstr(text, "WorldEnd");
    assert_true(wb && we);
    static const char head[] = "ObjectBegin 1\nDisplacement \"fbm\" \"float amplitude\" [0.05] "
                               "\"float frequency\" [3] \"float octaves\" [3]\n";
    static const char tail[] =
        "ObjectEnd\nAttributeBegin\nTranslate -0.8 0.3 0\nObjectInstance 1\nAttributeEnd\n"
        "AttributeBegin\nTranslate 1.2 -0.2 0.3\nRotate 35 0.2 0.1 1\nObjectInstance 1\n"
        "AttributeEnd\nWorldEnd\n";
    size_t at = (size_t)(wb - text) + strlen("WorldBegin\n"), end = (size_t)(we - text);
    memmove(text + at + strlen(head), text + at, end - at);
    memcpy(text + at, head, strlen(head));
    end += strlen(head);
    memcpy(text + end, tail, sizeof tail);
    memset(s, 0, sizeof *s);
    ts_error err = {0};
    if (rib_parse_string("teapot.rib", text, strlen(text), s, 1, &err)) fail_msg("%s", err.msg);
    assert_int_equal(s->patch_count, 2 * P);
    assert_non_null(s->shape);
}

/* Instances: every (ray, patch) pair of both instances, the kernels against the reference;
 * the second instance's segments use the first's grids and trees. */
static void test_instances(void **state)
{
    (void)state;
    enum { Q = 2 * P };
    ts_device cl;
    test_open_device(&cl);
    ts_scene s;
    load_instanced(&s);
    ts_stats stats;
    memset(&stats, 0, sizeof stats);
    ts_error err = {0};
    ts_pipeline_plan plan = {.ray_capacity = R, .pair_capacity = R * Q};
    pipeline_plan_arenas(&plan, Q, M);
    ts_pipeline p;
    if (pipeline_create(&p, &cl, &s, &plan, R, &stats, &err)) fail_msg("%s", err.msg);
    static ts_vec4 org[R], dir[R];
    static ts_hit hit[R], dev[R * Q], ref[R * Q];
    static uint32_t flags[R], from[R], active[R];
    make_rays(&cl, &p, &s, org, dir, hit, flags, from, active);
    for (int i = 3; i < R; i += 5) /* some leave a patch of the second instance */
        from[i] += P;
    write_buffer(&cl, p.ray_from, R * sizeof *from, from);
    static ts_pair pairs[R * Q];
    p.mode.fixed_lod = -1; /* each master and its instance at m = (q mod 32) mod 6 */
    for (uint32_t q = 0; q < Q; ++q) {
        p.patch_lod[q] = (uint8_t)((q % P) % (M + 1));
        p.segments_host[q] =
            (ts_segment){.patch = q, .begin = q * R, .end = (q + 1) * R, .lod = p.patch_lod[q]};
        for (uint32_t r = 0; r < R; ++r)
            pairs[q * R + r] = (ts_pair){q, r * Q + q};
    }
    if (pipeline_dice_build(&p, Q, &err)) fail_msg("%s", err.msg);
    uint64_t diced = stats.counters[TS_COUNTER_patches_diced];
    assert_int_equal(diced, P); /* the masters only */
    write_buffer(&cl, p.pairs, sizeof pairs, pairs);
    size_t gbytes = (size_t)plan.vert_capacity * sizeof(ts_vec4),
           nbytes = (size_t)plan.group_capacity * sizeof(ts_box4);
    size_t cbytes = (size_t)plan.group_capacity * sizeof(ts_tight4);
    ts_vec4 *grid = malloc(gbytes), *hgrid = malloc(gbytes);
    ts_box4 *groups = malloc(nbytes), *hgroups = malloc(nbytes);
    ts_tight4 *codes = malloc(cbytes), *hcodes = malloc(cbytes);
    assert_true(grid && hgrid && groups && hgroups && codes && hcodes);
    read_buffer(&cl, p.grid, gbytes, grid);
    read_buffer(&cl, p.groups, nbytes, groups);
    read_buffer(&cl, p.tight, cbytes, codes);
    for (uint32_t q = 0; q < Q; ++q) { /* each segment holds its shape's dicing */
        const ts_segment *sg = &p.segments_host[q];
        assert_int_equal(sg->shape, q % P);
        /* the pipeline's default mode is exact: edges towards coarser masters are stitched */
        dice_build_ref_stitched(&s, sg->shape, sg->lod, 0,
                                pipeline_stitch_edges(&p, sg->shape, sg->lod), hgrid, hgroups,
                                hcodes);
        if (memcmp(hgrid, grid + sg->vert_first, quadtree_vertex_count(sg->lod) * sizeof *grid) ||
            memcmp(hgroups, groups + sg->group_first,
                   quadtree_group_count(sg->lod) * sizeof *groups) ||
            memcmp(hcodes, codes + sg->group_first, quadtree_group_count(sg->lod) * sizeof *codes))
            fail_msg("segment %u: not the dicing of patch %u", q, sg->shape);
    }
    bl_ref_batch b = {
        pairs, 0,   R * Q, p.segments_host, 0,    Q,    Q,      0,     0,          active,
        org,   dir, hit,   flags,           from, grid, groups, codes, s.instance, s.inst_xform};
    uint64_t hits[2] = {0, 0};
    for (int group = 0; group < 2; ++group)
        for (int exact = 0; exact < 2; ++exact) {
            p.mode.exact = exact, p.mode.leaf_b = 1, p.mode.leaf_group = group;
            if (pipeline_bottom_level(&p, Q, &err)) fail_msg("%s", err.msg);
            read_buffer(&cl, p.pair_hit, sizeof dev, dev);
            b.exact = (uint32_t)exact, b.leaf_b = 1;
            bottom_level_ref_pairs(&b, 0, R * Q, ref);
            for (uint32_t w = 0; w < R * Q; ++w) {
                if (memcmp(&dev[w], &ref[w], sizeof dev[w]))
                    fail_msg("%s kernel, %s, ray %u patch %u: device (%a %u) C (%a %u)",
                             group ? "group" : "per-ray", exact ? "triangles" : "boxes", w / Q,
                             w % Q, dev[w].t, dev[w].patch, ref[w].t, ref[w].patch);
                hits[w % Q >= P] += ref[w].patch != TS_INVALID;
            }
        }
    /* Both instances are hit, the second through the first's dicing, under their own ids. */
    assert_true(hits[0] > (uint64_t)R && hits[1] > (uint64_t)R);
    free(grid), free(hgrid), free(groups), free(hgroups), free(codes), free(hcodes);
    pipeline_destroy(&p);
    stats_free(&stats);
    scene_free(&s);
    dev_close(&cl);
}

/* The culling copy (build.cl build_cull) of a batch that dices only instance patches: each
 * segment dices its master's shape, so the entry written is the master's (its tree is in the
 * master's frame) and the instance's stays 0, never culled by boxes of another frame. */
static void test_instance_cull(void **state)
{
    (void)state;
    ts_device cl;
    test_open_device(&cl);
    ts_scene s;
    load_instanced(&s);
    ts_stats stats;
    memset(&stats, 0, sizeof stats);
    ts_error err = {0};
    ts_pipeline_plan plan = {.ray_capacity = R, .pair_capacity = R * P};
    pipeline_plan_arenas(&plan, 2 * P, M);
    ts_pipeline p;
    if (pipeline_create(&p, &cl, &s, &plan, R, &stats, &err)) fail_msg("%s", err.msg);
    p.mode.fixed_lod = -1;
    p.mode.leaf_b = 1;
    for (uint32_t q = 0; q < 2 * P; ++q)
        p.patch_lod[q] = (uint8_t)((q % P) % (M + 1));
    for (uint32_t k = 0; k < P; ++k) /* the second instance's patches only */
        p.segments_host[k] =
            (ts_segment){.patch = P + k, .begin = k, .end = k + 1, .lod = p.patch_lod[P + k]};
    if (pipeline_dice_build(&p, P, &err)) fail_msg("%s", err.msg);
    static cl_uint levels[2 * P];
    static ts_tight4 cull[2 * P * TS_CULL_GROUPS];
    size_t gbytes = (size_t)plan.group_capacity * sizeof(ts_box4);
    ts_box4 *groups = malloc(gbytes);
    assert_non_null(groups);
    read_buffer(&cl, p.cull_levels, sizeof levels, levels);
    read_buffer(&cl, p.cull, sizeof cull, cull);
    read_buffer(&cl, p.groups, gbytes, groups);
    for (uint32_t k = 0; k < P; ++k) {
        const ts_segment *sg = &p.segments_host[k];
        assert_int_equal(sg->shape, k);
        if (levels[P + k] != 0) fail_msg("instance patch %u has a culling entry", P + k);
        uint32_t want = quadtree_cull_levels(sg->lod, 1);
        if (levels[k] != want)
            fail_msg("master %u: %u culling levels, want %u", k, levels[k], want);
        /* The groups below the root, as codes in the patch box: decoded, each box holds the
         * tree's and is within two steps (1/255 of the patch box) of it. */
        uint32_t n = quadtree_group_count(want) - 1u;
        ts_box pb = scene_patch_box(&s, k);
        for (uint32_t g = 0; g < n; ++g)
            for (uint32_t q = 0; q < 4u; ++q) {
                const ts_box4 *t = groups + sg->group_first + 1 + g;
                const ts_tight4 *c = &cull[k * TS_CULL_GROUPS + g];
                float lo[3] = {t->lo_x[q], t->lo_y[q], t->lo_z[q]};
                float hi[3] = {t->hi_x[q], t->hi_y[q], t->hi_z[q]};
                float plo[3] = {pb.lo_x, pb.lo_y, pb.lo_z}, phi[3] = {pb.hi_x, pb.hi_y, pb.hi_z};
                const uint8_t *clo[3] = {c->lo_x, c->lo_y, c->lo_z};
                const uint8_t *ch[3] = {c->hi_x, c->hi_y, c->hi_z};
                for (int a = 0; a < 3; ++a) {
                    float step = tight_step(plo[a], phi[a]);
                    float dl = plo[a] + (float)clo[a][q] * step;
                    float dh = phi[a] - (float)ch[a][q] * step;
                    if (!(dl <= lo[a] && dh >= hi[a] && lo[a] - dl <= 2.0f * step + 1e-6f &&
                          dh - hi[a] <= 2.0f * step + 1e-6f))
                        fail_msg("master %u, culling group %u lane %u axis %d: decoded [%g, %g], "
                                 "the tree's [%g, %g], step %g",
                                 k, g, q, a, dl, dh, lo[a], hi[a], step);
                }
            }
    }
    free(groups);
    pipeline_destroy(&p);
    stats_free(&stats);
    scene_free(&s);
    dev_close(&cl);
}

static void test_teapot(void **state)
{
    check_scene(0, 0, 0);
}
static void test_displaced_teapot(void **state)
{
    check_scene(1, 0, 0);
}
static void test_moving_displaced_teapot(void **state)
{
    check_scene(1, 1, 0);
}
static void test_trimmed_displaced_teapot(void **state)
{
    check_scene(1, 0, 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_teapot),
        cmocka_unit_test(test_displaced_teapot),
        cmocka_unit_test(test_moving_displaced_teapot),
        cmocka_unit_test(test_trimmed_displaced_teapot),
        cmocka_unit_test(test_instances),
        cmocka_unit_test(test_instance_cull),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
