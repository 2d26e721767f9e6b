/* test_dice_build.c — the dice and build kernels against plain-C references on random
 * patches, plain and displaced (fbm, ridged, an image texture): dice vertices vs the shared float
 * evaluation (bitwise) and, undisplaced, vs an independent de Casteljau in double (tolerance); leaf
 * boxes hold the displaced surface at random points of their parameter squares and inner
 * boxes are the union of their children (exact); every vertex lies in the patch's
 * top-level box; build's lane form of the displacement-normal box against the host's, bit for
 * bit, on random normals; triangle mode's stitching across levels of detail against the
 * reference, and the shared edges' vertices the same on both sides. */
#include "test_support.h"
#include "lib/patch.h"
#include "lib/quadtree.h"
#include "image/image.h"
#include "pipeline/pipeline.h"
#include "ref/dice_build_ref.h"

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
            for (int k = 0; k < 3; ++k)
                q[i][k] = (1 - t) * q[i][k] + t * q[i + 1][k];
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

/* Patches in random places; the odd ones carry fbm or ridged displacement of `octaves`
 * octaves in a scaled object space. */
static void random_scene(ts_scene *s, int patches, uint32_t seed, uint32_t octaves)
{
    memset(s, 0, sizeof *s);
    ts_error err = {0};
    const double w2o[16] = {2, 0, 0, 0.5, 0, 1.5, 0, 0, 0, 0, 1, -0.25, 0, 0, 0, 1};
    uint32_t xf;
    assert_int_equal(scene_add_xform(s, w2o, &xf, &err), TS_OK);
    for (int p = 0; p < patches; ++p) {
        double cp[16][3];
        float ox = test_uniform(&seed, -5, 5), oy = test_uniform(&seed, -5, 5),
              oz = test_uniform(&seed, -5, 5);
        for (int j = 0; j < 4; ++j)
            for (int i = 0; i < 4; ++i) {
                cp[j * 4 + i][0] = ox + i + test_uniform(&seed, -0.4f, 0.4f);
                cp[j * 4 + i][1] = oy + j + test_uniform(&seed, -0.4f, 0.4f);
                cp[j * 4 + i][2] = oz + test_uniform(&seed, -1.5f, 1.5f);
            }
        ts_patch_attr a = {.cs_r = 1, .cs_g = 1, .cs_b = 1};
        if (p % 2) {
            a.disp_kind = p % 4 == 1 ? TS_DISP_FBM : TS_DISP_RIDGED;
            /* patch 1 (diced at m = 5) rough: TS_PATCH_ROUGH, tight codes */
            a.disp_octaves = octaves, a.disp_amplitude = p == 1 ? 1.2f : 0.3f;
            a.disp_frequency = 1.7f;
            a.disp_lacunarity = 2.0f, a.disp_gain = 0.5f, a.xform = xf;
        }
        assert_int_equal(scene_add_patch(s, cp, &a, &err), TS_OK);
    }
    assert_int_equal(scene_finalize(s, &err), TS_OK);
}

static int box_equal(ts_box a, ts_box b)
{
    return a.lo_x == b.lo_x && a.lo_y == b.lo_y && a.lo_z == b.lo_z && a.hi_x == b.hi_x &&
           a.hi_y == b.hi_y && a.hi_z == b.hi_z;
}

static int box_contains(ts_box b, ts_vec4 p)
{
    return p.x >= b.lo_x && p.x <= b.hi_x && p.y >= b.lo_y && p.y <= b.hi_y && p.z >= b.lo_z &&
           p.z <= b.hi_z;
}

static int box_inside(ts_box a, ts_box b) /* a within b */
{
    return a.lo_x >= b.lo_x && a.lo_y >= b.lo_y && a.lo_z >= b.lo_z && a.hi_x <= b.hi_x &&
           a.hi_y <= b.hi_y && a.hi_z <= b.hi_z;
}

static double box_span(ts_box b)
{
    return (double)(b.hi_x - b.lo_x) + (b.hi_y - b.lo_y) + (b.hi_z - b.lo_z);
}

/* The tight codes (ts_tight4) of a segment's tree: every node's decoded tight box lies in its
 * box and holds its children's tight boxes; a leaf's holds its micro-quad's four vertices. In
 * triangle mode (tight), and for a patch that is not rough (TS_PATCH_ROUGH), the two boxes are
 * the same. *tight_span and *box_span get the sums of a rough segment's leaves' extents, for
 * the caller to see that the codes do shrink box mode's leaves. */
static void check_codes(const ts_segment *seg, const ts_vec4 *grid, const ts_box4 *nodes,
                        const ts_tight4 *codes, int tight, double *tight_span, double *node_span)
{
    uint32_t pi = seg->patch, m = seg->lod, n = (1u << m) + 1u;
    for (uint32_t l = 0; l <= m; ++l)
        for (uint32_t k = 0; k < (1u << (2 * l)); ++k) {
            ts_box b = quadtree_box(nodes, l, k), t = quadtree_tight_box(nodes, codes, l, k);
            if (!box_inside(t, b))
                fail_msg("patch %u m %u: the tight box of node %u of level %u is not in its box",
                         pi, m, k, l);
            int coded = !tight && (seg->flags & TS_PATCH_ROUGH);
            if (!coded && !box_equal(t, b))
                fail_msg("patch %u m %u: node %u of level %u has a tighter box without codes", pi,
                         m, k, l);
            if (l < m)
                for (uint32_t q = 0; q < 4; ++q)
                    if (!box_inside(quadtree_tight_box(nodes, codes, l + 1, 4 * k + q), t))
                        fail_msg("patch %u m %u: a child's tight box sticks out of node %u of "
                                 "level %u's",
                                 pi, m, k, l);
            if (l < m || b.lo_x > b.hi_x) continue; /* empty: cut out (check_segment) */
            uint32_t i = morton_i(k), j = morton_j(k);
            for (int c = 0; c < 4; ++c)
                if (!box_contains(t, grid[(j + (c >> 1)) * n + i + (c & 1)]))
                    fail_msg("patch %u m %u: a vertex outside leaf %u's tight box", pi, m, k);
            if (coded) *tight_span += box_span(t), *node_span += box_span(b);
        }
}

/* Leaves of cut-out patches (TS_PATCH_CUTOUT) check_segment found cut away and kept. */
static unsigned cut_leaves, kept_cutout_leaves;

static void check_segment(const ts_scene *s, const ts_segment *seg, const ts_vec4 *grid,
                          const ts_box4 *nodes, int tight, uint32_t *seed)
{
    uint32_t pi = seg->patch;
    const ts_vec4 *cp = &s->cp[pi * 16], *cn = &s->corner_n[pi * 4], *mn = &s->mid_n[pi * 5];
    const ts_patch_attr *a = &s->attr[pi];
    const ts_xform *x = &s->xform[a->xform];
    uint32_t m = seg->lod, n = (1u << m) + 1u;
    ts_box ext = scene_patch_box(s, pi);
    double tol = 1e-5 * fmax(ext.hi_x - ext.lo_x, fmax(ext.hi_y - ext.lo_y, ext.hi_z - ext.lo_z));
    for (uint32_t j = 0; j < n; ++j)
        for (uint32_t i = 0; i < n; ++i) {
            ts_vec4 g = grid[j * n + i];
            float u = ldexpf((float)i, -(int)m), v = ldexpf((float)j, -(int)m);
            ts_vec4 same = patch_vertex(cp, cp, cn, mn, a, x, scene_tex_ctx(s), u, v);
            if (memcmp(&g, &same, sizeof g) != 0)
                fail_msg("patch %u m %u vertex (%u,%u): device (%a %a %a %a) host (%a %a %a %a)",
                         pi, m, i, j, g.x, g.y, g.z, g.w, same.x, same.y, same.z, same.w);
            /* The undisplaced point against an independent evaluation. */
            ts_vec4 dn = displace_normal(cn, mn, u, v);
            double r[3];
            reference_point(cp, u, v, r);
            assert_true(fabs(g.x - g.w * dn.x - r[0]) <= tol &&
                        fabs(g.y - g.w * dn.y - r[1]) <= tol &&
                        fabs(g.z - g.w * dn.z - r[2]) <= tol);
            if (a->disp_kind == TS_DISP_NONE) assert_true(g.w == 0.0f);
            assert_true(box_contains(ext, g)); /* the top-level box is conservative */
        }
    /* Leaves: the displaced surface at random points of each micro-quad's parameter square
     * (not only its vertices) lies in the leaf box (Hanika §3.3). */
    uint32_t side = 1u << m;
    for (uint32_t k = 0; k < side * side; ++k) {
        uint32_t i = morton_i(k), j = morton_j(k);
        ts_box b = quadtree_box(nodes, m, k);
        /* A micro-quad its cutout mask removes has an empty box (lib/texture.h) */
        if (!tex_cutout_keeps(a, scene_tex_ctx(s), quadtree_centre(i, m), quadtree_centre(j, m))) {
            if (!(b.lo_x > b.hi_x && b.lo_y > b.hi_y && b.lo_z > b.hi_z))
                fail_msg("patch %u m %u: leaf %u is cut out but its box is not empty", pi, m, k);
            cut_leaves++;
            continue;
        }
        kept_cutout_leaves += (a->flags & TS_PATCH_CUTOUT) != 0u;
        for (int c = 0; c < 4; ++c) {
            ts_vec4 g = grid[(j + (c >> 1)) * n + i + (c & 1)];
            if (!box_contains(b, g)) fail_msg("patch %u m %u: vertex outside leaf %u", pi, m, k);
        }
        /* Texture leaves: more points, their bound is tight (a few texels). Triangle mode's
         * leaves bound only their micro-quad's triangles: its vertices, checked above. */
        int points = tight ? 0 : a->disp_kind == TS_DISP_TEXTURE ? 32 : 4;
        for (int q = 0; q < points; ++q) {
            float u = ((float)i + test_uniform(seed, 0, 1)) * ldexpf(1.0f, -(int)m);
            float v = ((float)j + test_uniform(seed, 0, 1)) * ldexpf(1.0f, -(int)m);
            ts_vec4 p = patch_vertex(cp, cp, cn, mn, a, x, scene_tex_ctx(s), u, v);
            if (!box_contains(b, p))
                fail_msg("patch %u m %u leaf %u: surface point (%g, %g) outside its box", pi, m, k,
                         u, v);
        }
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
                fail_msg("patch %u m %u: node %u of level %u is not the union of its children", pi,
                         m, k, l);
        }
}

/* Patches with an image displacement texture (random texels, 53 x 40) at random corner st:
 * spanning less than a texel up to several periods, negative and large coordinates. Patches
 * 1 and 4 are also cut out by a mask (an RGBA texture of 9 x 7 texels, random alpha and red
 * in [0, 1]): 1 by its alpha, 4 by its red channel (TS_PATCH_CUTOUT_RED). */
static void random_textured_scene(ts_scene *s, int patches, uint32_t seed)
{
    memset(s, 0, sizeof *s);
    ts_error err = {0};
    const int w = 53, h = 40;
    float *px = malloc((size_t)w * h * sizeof *px);
    for (int i = 0; i < w * h; ++i)
        px[i] = test_uniform(&seed, -1.0f, 2.0f);
    ts_image img = {.width = w, .height = h, .channels = 1, .channel_names = NULL, .pixels = px};
    const char *path = test_path_in(test_scratch_dir(), "disp.exr");
    if (image_write_exr(path, &img, NULL, 0, &err)) fail_msg("%s", err.msg);
    free(px);
    uint32_t tex, mask;
    if (scene_add_texture(s, path, TS_TEX_MINMAX, &tex, &err)) fail_msg("%s", err.msg);
    float mpx[9 * 7 * 4];
    for (int i = 0; i < 9 * 7 * 4; ++i)
        mpx[i] = test_uniform(&seed, 0.0f, 1.0f);
    const char *names[4] = {"R", "G", "B", "A"};
    ts_image mimg = {.width = 9, .height = 7, .channels = 4, .channel_names = names, .pixels = mpx};
    const char *mpath = test_path_in(test_scratch_dir(), "mask.exr");
    if (image_write_exr(mpath, &mimg, NULL, 0, &err)) fail_msg("%s", err.msg);
    if (scene_add_texture(s, mpath, TS_TEX_RGB, &mask, &err)) fail_msg("%s", err.msg);
    for (int p = 0; p < patches; ++p) {
        double cp[16][3];
        float ox = test_uniform(&seed, -5, 5), oy = test_uniform(&seed, -5, 5),
              oz = test_uniform(&seed, -5, 5);
        for (int j = 0; j < 4; ++j)
            for (int i = 0; i < 4; ++i) {
                cp[j * 4 + i][0] = ox + i + test_uniform(&seed, -0.4f, 0.4f);
                cp[j * 4 + i][1] = oy + j + test_uniform(&seed, -0.4f, 0.4f);
                /* Even patches flat (normal +-z): their leaf boxes' z extent is the
                 * displacement bound itself, so a bound missing a texel shows. */
                float bend = test_uniform(&seed, -1.5f, 1.5f);
                cp[j * 4 + i][2] = oz + (p % 2 ? bend : 0.0f);
            }
        ts_patch_attr a = {.cs_r = 1,
                           .cs_g = 1,
                           .cs_b = 1,
                           .disp_kind = TS_DISP_TEXTURE,
                           .disp_amplitude = p % 2 ? 0.3f : -0.2f,
                           .disp_offset = 0.5f,
                           .disp_tex = tex};
        if (p == 1 || p == 4) /* cut out by the mask's alpha, or its red */
            a.flags = TS_PATCH_CUTOUT | (p == 4 ? TS_PATCH_CUTOUT_RED : 0u), a.color_tex = mask;
        /* Corner st: a random place, then within a square of side 10^-2.5 .. 10^0.6. */
        float span = powf(10.0f, test_uniform(&seed, -2.5f, 0.6f)), base = p == 3 ? 1000.0f : 0.0f;
        float s0 = base + test_uniform(&seed, -2.0f, 2.0f),
              t0 = base + test_uniform(&seed, -2.0f, 2.0f);
        for (int c = 0; c < 4; ++c) {
            a.st[2 * c] = s0 + span * test_uniform(&seed, 0, 1);
            a.st[2 * c + 1] = t0 + span * test_uniform(&seed, 0, 1);
        }
        assert_int_equal(scene_add_patch(s, cp, &a, &err), TS_OK);
    }
    assert_int_equal(scene_finalize(s, &err), TS_OK);
}

/* Six patches of a scene diced and built as one batch on the device, read back. */
typedef struct diced {
    ts_device cl;
    ts_stats stats;
    ts_pipeline_plan plan;
    ts_pipeline p;
    ts_vec4 *grid;
    ts_box4 *nodes;
    ts_tight4 *codes;
} diced;

/* Segment i dices patch order[i] at lods[i], with box mode's leaves or (tight) triangle
 * mode's; with `stitch`, each patch's level is also the frame's (patch_lod), so edges
 * towards coarser neighbours are stitched (quadtree_stitch). */
static void dice_six(diced *d, ts_scene *s, const uint32_t order[6], const uint32_t lods[6],
                     int tight, int stitch)
{
    test_open_device(&d->cl);
    memset(&d->stats, 0, sizeof d->stats);
    ts_error err = {0};
    d->plan = (ts_pipeline_plan){.ray_capacity = 64, .pair_capacity = 512};
    pipeline_plan_arenas(&d->plan, 6, 5);
    ts_pipeline *p = &d->p;
    if (pipeline_create(p, &d->cl, s, &d->plan, 1, &d->stats, &err)) fail_msg("%s", err.msg);
    p->mode.exact = 1, p->mode.tight = tight;
    if (stitch) p->mode.fixed_lod = -1; /* the levels: patch_lod */
    for (uint32_t i = 0; i < 6; ++i) {
        p->segments_host[i] = (ts_segment){.patch = order[i], .lod = lods[i]};
        if (stitch) p->patch_lod[order[i]] = (uint8_t)lods[i];
    }
    if (pipeline_dice_build(p, 6, &err)) fail_msg("%s", err.msg);
    size_t gbytes = (size_t)d->plan.vert_capacity * sizeof(ts_vec4);
    size_t nbytes = (size_t)d->plan.group_capacity * sizeof(ts_box4);
    size_t cbytes = (size_t)d->plan.group_capacity * sizeof(ts_tight4);
    d->grid = malloc(gbytes), d->nodes = malloc(nbytes), d->codes = malloc(cbytes);
    assert_true(d->grid && d->nodes && d->codes);
    cl_command_queue q = d->cl.queue;
    assert_int_equal(clEnqueueReadBuffer(q, p->grid, CL_TRUE, 0, gbytes, d->grid, 0, NULL, NULL),
                     CL_SUCCESS);
    assert_int_equal(clEnqueueReadBuffer(q, p->groups, CL_TRUE, 0, nbytes, d->nodes, 0, NULL, NULL),
                     CL_SUCCESS);
    assert_int_equal(clEnqueueReadBuffer(q, p->tight, CL_TRUE, 0, cbytes, d->codes, 0, NULL, NULL),
                     CL_SUCCESS);
}

static void diced_free(diced *d)
{
    free(d->grid), free(d->nodes), free(d->codes);
    pipeline_destroy(&d->p);
    dev_close(&d->cl);
    stats_free(&d->stats);
}

/* Dices and builds the six patches of s at LODs lods[] (patch 5 - i gets lods[i]) as one
 * batch, with box mode's leaves or (tight) triangle mode's, and checks every segment against
 * the references: dice_build_ref's grid and trees bit for bit, and the properties above. */
static void dice_build_and_check(ts_scene *s, const uint32_t lods[6], int tight, int want_rough)
{
    static const uint32_t order[6] = {5, 4, 3, 2, 1, 0};
    diced d;
    dice_six(&d, s, order, lods, tight, 0);
    const ts_pipeline *pp = &d.p;
    const ts_stats *stats = &d.stats;
    ts_vec4 *grid = d.grid;
    ts_box4 *nodes = d.nodes;
    ts_tight4 *codes = d.codes;
    uint32_t seed = 77u;
    double tight_span = 0.0, node_span = 0.0;
    for (uint32_t i = 0; i < 6; ++i) {
        const ts_segment *seg = &pp->segments_host[i];
        check_segment(s, seg, grid + seg->vert_first, nodes + seg->group_first, tight, &seed);
        check_codes(seg, grid + seg->vert_first, nodes + seg->group_first, codes + seg->group_first,
                    tight, &tight_span, &node_span);
        uint32_t ng = quadtree_group_count(seg->lod);
        ts_vec4 *hgrid = malloc(2 * quadtree_vertex_count(seg->lod) * sizeof *hgrid);
        ts_box4 *hnodes = malloc(2 * ng * sizeof *hnodes);
        ts_tight4 *hcodes = malloc(2 * ng * sizeof *hcodes);
        assert_true(hgrid && hnodes && hcodes);
        dice_build_ref(s, seg->patch, seg->lod, tight, hgrid, hnodes, hcodes);
        uint32_t times = dice_build_ref_times(s, seg->patch);
        if (memcmp(hnodes, nodes + seg->group_first, times * ng * sizeof *hnodes) ||
            memcmp(hcodes, codes + seg->group_first, times * ng * sizeof *hcodes))
            fail_msg("patch %u m %u: build's trees differ from dice_build_ref's (tight %d)",
                     seg->patch, seg->lod, tight);
        free(hgrid), free(hnodes), free(hcodes);
    }
    /* Box mode's leaves bound every finer dicing of a rough surface: the boxes of the
     * vertices alone are well inside them (in triangle mode they are the same boxes). */
    if (node_span > 0.0) assert_true(tight_span < 0.8 * node_span);
    uint32_t rough = 0;
    for (uint32_t i = 0; i < 6; ++i)
        rough += (pp->segments_host[i].flags & TS_PATCH_ROUGH) != 0u;
    if (want_rough) assert_true(rough > 0u); /* the codes are exercised */
    assert_int_equal(stats->counters[TS_COUNTER_patches_diced], 6);
    uint64_t quads = 0;
    for (uint32_t i = 0; i < 6; ++i)
        quads += 1ull << (2 * lods[i]);
    assert_int_equal(stats->counters[TS_COUNTER_micropolygons_created], quads);
    diced_free(&d);
}

static void test_dice_and_build_match_reference(void **state)
{
    (void)state;
    ts_scene s;
    random_scene(&s, 6, 12345u, 3u);
    const uint32_t lods[6] = {0, 1, 2, 3, 5, 4};
    dice_build_and_check(&s, lods, 0, 1);
    dice_build_and_check(&s, lods, 1, 0);
    scene_free(&s);
}

/* One and two octaves, fbm and ridged: dice's and build's lane forms (noise4.h
 * displace_value_pair's spare lanes, build.cl block_leaves' octave slots) against the
 * reference. */
static void test_dice_few_octaves_match_reference(void **state)
{
    (void)state;
    for (uint32_t octaves = 1; octaves <= 2; ++octaves) {
        ts_scene s;
        random_scene(&s, 6, 777u + octaves, octaves);
        const uint32_t lods[6] = {2, 0, 3, 1, 4, 5};
        dice_build_and_check(&s, lods, 0, 0);
        scene_free(&s);
    }
}

/* Six displaced patches in a 3 x 2 sheet, sharing edges bit for bit (z a function of the
 * shared x, y), fBm on every one. */
static void sheet_scene(ts_scene *s)
{
    memset(s, 0, sizeof *s);
    ts_error err = {0};
    for (int b = 0; b < 2; ++b)
        for (int a = 0; a < 3; ++a) {
            double cp[16][3];
            for (int j = 0; j < 4; ++j)
                for (int i = 0; i < 4; ++i) {
                    double x = a + i / 3.0, y = b + j / 3.0;
                    cp[j * 4 + i][0] = x, cp[j * 4 + i][1] = y;
                    cp[j * 4 + i][2] = 0.3 * sin(1.7 * x) * cos(1.3 * y);
                }
            ts_patch_attr at = {.cs_r = 1, .cs_g = 1, .cs_b = 1, .disp_kind = TS_DISP_FBM};
            at.disp_octaves = 4, at.disp_amplitude = 0.2f, at.disp_frequency = 2.5f;
            at.disp_lacunarity = 2.0f, at.disp_gain = 0.5f;
            assert_int_equal(scene_add_patch(s, cp, &at, &err), TS_OK);
        }
    assert_int_equal(scene_finalize(s, &err), TS_OK);
}

/* Vertex t of edge k (lib/quadtree.h quadtree_stitch's numbering) of an n x n grid. */
static ts_vec4 edge_vertex(const ts_vec4 *g, uint32_t n, uint32_t k, uint32_t t)
{
    return k == 0 ? g[t] : k == 1 ? g[t * n] : k == 2 ? g[t * n + n - 1] : g[(n - 1) * n + t];
}

/* Triangle mode's stitching across levels of detail (dice.cl, quadtree_stitch): each patch of
 * a sheet diced at its own m, the edges towards coarser neighbours get their vertices. The
 * grids and trees equal dice_build_ref_stitched's bit for bit, in both leaf modes (box mode's
 * leaves grown to hold the moved vertices), and along every shared edge the finer patch's
 * vertices, repeats removed, are the coarser one's, bit for bit: the same triangle edges on
 * both sides, so the watertight test opens no crack. Without stitching (m differing) the
 * finer edge has vertices the coarser lacks. */
static void test_stitched_edges_share_vertices(void **state)
{
    (void)state;
    ts_scene s;
    sheet_scene(&s);
    static const uint32_t lods[6] = {4, 2, 3, 5, 3, 1};
    static const uint32_t order[6] = {0, 1, 2, 3, 4, 5};
    for (int tight = 0; tight <= 1; ++tight) {
        diced d;
        dice_six(&d, &s, order, lods, tight, 1);
        const ts_pipeline *pp = &d.p;
        ts_vec4 *grid = d.grid;
        ts_box4 *nodes = d.nodes;
        ts_tight4 *codes = d.codes;
        const ts_vec4 *at[6];
        uint32_t stitched = 0;
        for (uint32_t i = 0; i < 6; ++i) {
            const ts_segment *seg = NULL;
            for (uint32_t k = 0; k < 6; ++k)
                if (pp->segments_host[k].patch == i) seg = &pp->segments_host[k];
            assert_non_null(seg);
            uint32_t m = seg->lod, edges = pipeline_stitch_edges(pp, i, m),
                     ng = quadtree_group_count(m);
            assert_int_equal(seg->flags >> TS_SEG_EDGE_SHIFT, edges);
            stitched += edges != 0;
            at[i] = grid + seg->vert_first;
            ts_vec4 *hgrid = malloc(quadtree_vertex_count(m) * sizeof *hgrid);
            ts_box4 *hnodes = malloc(ng * sizeof *hnodes);
            ts_tight4 *hcodes = malloc(ng * sizeof *hcodes);
            assert_true(hgrid && hnodes && hcodes);
            dice_build_ref_stitched(&s, i, m, tight, edges, hgrid, hnodes, hcodes);
            if (memcmp(hgrid, at[i], quadtree_vertex_count(m) * sizeof *hgrid) ||
                memcmp(hnodes, nodes + seg->group_first, ng * sizeof *hnodes) ||
                memcmp(hcodes, codes + seg->group_first, ng * sizeof *hcodes))
                fail_msg("patch %u m %u edges %x: dice/build differ from the reference (tight %d)",
                         i, m, edges, tight);
            free(hgrid), free(hnodes), free(hcodes);
        }
        assert_true(stitched >= 3);
        /* Every shared edge: the finer side's vertices without repeats are the coarser's. */
        uint32_t shared = 0;
        for (uint32_t i = 0; i < 6; ++i)
            for (uint32_t k = 0; k < 4; ++k) {
                uint32_t nb = pp->edge_nb[4 * i + k];
                if (nb == TS_INVALID || lods[nb] > lods[i] || (lods[nb] == lods[i] && nb < i))
                    continue;
                uint32_t kb = 0; /* the neighbour's edge back to i */
                while (kb < 4 && pp->edge_nb[4 * nb + kb] != i)
                    ++kb;
                assert_true(kb < 4);
                uint32_t n = (1u << lods[i]) + 1u, nn = (1u << lods[nb]) + 1u, len = 0;
                ts_vec4 seq[33];
                for (uint32_t t = 0; t < n; ++t) {
                    ts_vec4 v = edge_vertex(at[i], n, k, t);
                    if (len == 0 || memcmp(&v, &seq[len - 1], sizeof v) != 0) seq[len++] = v;
                }
                assert_int_equal(len, nn);
                int same = 1, reversed = 1;
                for (uint32_t t = 0; t < nn; ++t) {
                    ts_vec4 w = edge_vertex(at[nb], nn, kb, t);
                    same &= memcmp(&seq[t], &w, sizeof w) == 0;
                    reversed &= memcmp(&seq[nn - 1 - t], &w, sizeof w) == 0;
                }
                if (!same && !reversed)
                    fail_msg("edge %u of patch %u (m %u) against patch %u (m %u): vertices differ",
                             k, i, lods[i], nb, lods[nb]);
                ++shared;
            }
        assert_int_equal(shared, 7); /* a 3 x 2 sheet has 7 inner edges */
        diced_free(&d);
    }
    scene_free(&s);
}

static void test_dice_and_build_textured(void **state)
{
    (void)state;
    ts_scene s;
    random_textured_scene(&s, 6, 4242u);
    const uint32_t lods[6] = {0, 1, 2, 3, 4, 2}; /* small: minutes under Oclgrind otherwise */
    cut_leaves = kept_cutout_leaves = 0;
    dice_build_and_check(&s, lods, 0, 0);
    dice_build_and_check(&s, lods, 1, 0);
    assert_true(cut_leaves > 4 && kept_cutout_leaves > 4); /* the masks cut and keep */
    scene_free(&s);
}

/* A random normal node for test_normal_box_lanes: kind 0 near `base` (a smooth patch), 1
 * components from {0, -0, 1, -1, 1/2, random} (exact and signed zeros), 2 `base` or its
 * opposite (half a tube: a box around 0), 3 anything in [-1, 1]^3. w is never read: random, or
 * NaN. */
static ts_vec4 random_node(uint32_t *seed, int kind, ts_vec4 base)
{
    ts_vec4 r;
    float *c = &r.x;
    for (int a = 0; a < 3; ++a) {
        float b = (&base.x)[a];
        if (kind == 0)
            c[a] = b + test_uniform(seed, -0.2f, 0.2f);
        else if (kind == 1) {
            const float pick[5] = {0.0f, -0.0f, 1.0f, -1.0f, 0.5f};
            uint32_t w = (uint32_t)test_uniform(seed, 0.0f, 6.0f);
            c[a] = w < 5u ? pick[w] : test_uniform(seed, -1.0f, 1.0f);
        } else if (kind == 2)
            c[a] = b;
        else
            c[a] = test_uniform(seed, -1.0f, 1.0f);
    }
    if (kind == 2 && test_uniform(seed, 0.0f, 1.0f) < 0.5f) r.x = -r.x, r.y = -r.y, r.z = -r.z;
    r.w = test_uniform(seed, 0.0f, 1.0f) < 0.2f ? NAN : test_uniform(seed, -5.0f, 5.0f);
    return r;
}

/* build's displacement-normal box (displace_normal_box_x4, kernels/lib/noise4.h, x, y, z in
 * float4 lanes) against the host's displace_normal_box (lib/displace.h), bit for bit, through
 * the probe kernel build_normal_box_probe: random nodes of the kinds of random_node, over the
 * micro-quads of m = 0..10 (as build_leaves passes them) and over random rectangles. */
static void test_normal_box_lanes(void **state)
{
    (void)state;
    enum { N = 6000 };
    static ts_vec4 nodes[9 * N];
    static float rect[4 * N];
    static ts_box dev[N];
    uint32_t seed = 31337u;
    for (uint32_t i = 0; i < N; ++i) {
        ts_vec4 base = {test_uniform(&seed, -1, 1), test_uniform(&seed, -1, 1),
                        test_uniform(&seed, -1, 1), 0.0f};
        for (int q = 0; q < 9; ++q)
            nodes[9 * i + q] = random_node(&seed, (int)(i % 4), base);
        float *r = &rect[4 * i];
        if (i % 5 == 4) { /* any rectangle in [0, 1]^2 */
            float a = test_uniform(&seed, 0, 1), b = test_uniform(&seed, 0, 1);
            float c = test_uniform(&seed, 0, 1), d = test_uniform(&seed, 0, 1);
            r[0] = fminf(a, b), r[2] = fmaxf(a, b), r[1] = fminf(c, d), r[3] = fmaxf(c, d);
        } else { /* micro-quad (x, y) at LOD m */
            uint32_t m = (uint32_t)test_uniform(&seed, 0.0f, 11.0f) % 11u, side = 1u << m;
            uint32_t x = (uint32_t)test_uniform(&seed, 0.0f, (float)side) % side;
            uint32_t y = (uint32_t)test_uniform(&seed, 0.0f, (float)side) % side;
            float h = ldexpf(1.0f, -(int)m);
            r[0] = (float)x * h, r[1] = (float)y * h, r[2] = (float)(x + 1u) * h,
            r[3] = (float)(y + 1u) * h;
        }
    }
    ts_device cl;
    test_open_device(&cl);
    ts_error err = {0};
    cl_mem dn =
        dev_buffer_create(&cl, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof nodes, nodes, &err);
    cl_mem dr =
        dev_buffer_create(&cl, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof rect, rect, &err);
    cl_mem dout = dev_buffer_create(&cl, CL_MEM_WRITE_ONLY, sizeof dev, NULL, &err);
    assert_true(dn && dr && dout);
    cl_kernel k = dev_kernel_create(&cl, "build_normal_box_probe", &err);
    assert_non_null(k);
    cl_uint count = N;
    if (dev_set_args(k, &err, DEV_ARG(dn), DEV_ARG(dr), DEV_ARG(count), DEV_ARG(dout), (size_t)0) ||
        dev_launch(&cl, k, TS_STAGE_build, N, TS_LOCAL_SIZE, &err) || dev_finish(&cl, NULL, &err))
        fail_msg("%s", err.msg);
    assert_int_equal(
        clEnqueueReadBuffer(cl.queue, dout, CL_TRUE, 0, sizeof dev, dev, 0, NULL, NULL),
        CL_SUCCESS);
    int all = 0, tight = 0;
    for (uint32_t i = 0; i < N; ++i) {
        const float *r = &rect[4 * i];
        ts_box h = displace_normal_box(&nodes[9 * i], &nodes[9 * i + 4], r[0], r[1], r[2], r[3]);
        if (memcmp(&h, &dev[i], sizeof h))
            fail_msg("item %u (%a %a %a %a): device (%a %a %a, %a %a %a), C (%a %a %a, %a %a %a)",
                     i, r[0], r[1], r[2], r[3], dev[i].lo_x, dev[i].lo_y, dev[i].lo_z, dev[i].hi_x,
                     dev[i].hi_y, dev[i].hi_z, h.lo_x, h.lo_y, h.lo_z, h.hi_x, h.hi_y, h.hi_z);
        all += h.lo_x == -1.0f && h.hi_x == 1.0f && h.lo_y == -1.0f && h.hi_z == 1.0f;
        tight += h.hi_x - h.lo_x < 0.5f;
    }
    /* Both branches ran: boxes around 0 ([-1, 1]^3) and normalised ones. */
    assert_true(all > N / 10 && tight > N / 10);
    clReleaseKernel(k);
    clReleaseMemObject(dn), clReleaseMemObject(dr), clReleaseMemObject(dout);
    dev_close(&cl);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_dice_and_build_match_reference),
                                       cmocka_unit_test(test_dice_few_octaves_match_reference),
                                       cmocka_unit_test(test_dice_and_build_textured),
                                       cmocka_unit_test(test_stitched_edges_share_vertices),
                                       cmocka_unit_test(test_normal_box_lanes)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
