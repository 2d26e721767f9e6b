/* test_geometry.c — the complete two-level algorithm as a user runs it (issue 3):
 * - hole-free: a closed sphere of fbm-displaced Bézier patches seen from inside through a
 *   160-degree lens, so ray density and therefore m vary widely between neighbours: with leaf
 *   boxes as geometry (Hanika §3.3) no ray escapes, nor with exact micro-triangles, more
 *   strongly displaced, whose edges towards coarser neighbours are stitched;
 * - the memory budget changes nothing: two very different --memory values give bitwise
 *   identical images; neither does the patch cache, which dices every patch once when the
 *   frame's patches fit and evicts when they do not;
 * - bounded memory: a scene of more than 10^10 potential micro-polygons renders in < 2 GiB;
 * - the lod rules (issue 13, item 3): a patch wholly hidden behind another is diced two
 *   levels coarser under TESSERA_LOD_RULE=seen and =visible than under the default, and that
 *   changes no pixel; --dicing-rate D dices at the smallest m with 4^m >= R / D^2: D = 2 one
 *   level coarser, D = 1/2 one finer, D = 1 the default's bits;
 * - motion blur (§3.4): a moving patch's image equals the average of the patch rendered
 *   static at many times, within a tolerance derived from the sample count. */
#include "test_support.h"
#include "image/image.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char dir[4096];

static int setup(void **state)
{
    snprintf(dir, sizeof dir, "%s", test_scratch_dir());
    return 0;
}

static const char *path(const char *name)
{
    return test_path_in(dir, name);
}

static void render_ok(const char *args)
{
    test_tessera_ok(dir, "%s", args);
}

static void load(const char *name, ts_image *img)
{
    test_read_image(path(name), img);
}

/* A closed sphere of 54 fBm-displaced patches (amplitude a, `octaves` octaves) seen from
 * inside through a 160-degree lens, written to `name`. */
static void write_inside_sphere(const char *name, int res, double a, int octaves)
{
    FILE *f = fopen(path(name), "w");
    assert_non_null(f);
    fprintf(f,
            "Format %d %d 1\nProjection \"perspective\" \"fov\" [160]\nWorldBegin\n"
            "Displacement \"fbm\" \"float amplitude\" [%g] \"float frequency\" [3] "
            "\"float octaves\" [%d]\n",
            res, res, a, octaves);
    test_write_sphere_patches(f, 3, 1.0);
    fputs("WorldEnd\n", f);
    fclose(f);
}

/* The pixels of an EXR whose eye ray escaped (Z = +inf). */
static int escaped_pixels(const char *exr)
{
    ts_image img;
    load(exr, &img);
    int escaped = 0;
    for (int i = 0; i < img.width * img.height; ++i)
        escaped += isinf(img.pixels[i * img.channels + 3]);
    image_free(&img);
    return escaped;
}

/* How many levels of detail a render's dicings used (its lod_histogram). */
static int levels_used(const char *json)
{
    int levels = 0;
    char key[64];
    for (int m = 0; m <= 10; ++m) {
        snprintf(key, sizeof key, "lod_histogram.%d", m);
        levels += test_stats_number(path(json), key) > 0;
    }
    return levels;
}

static void test_displaced_sphere_is_hole_free_from_inside(void **state)
{
    write_inside_sphere("sphere.rib", 160, 0.06, 4);
    char args[16384];
    snprintf(args, sizeof args, "render '%s' -o '%s' --max-lod 7 --stats '%s' --quiet",
             path("sphere.rib"), path("sphere.exr"), path("sphere.json"));
    render_ok(args);
    assert_int_equal(escaped_pixels("sphere.exr"), 0);
    /* Neighbours really were diced at different levels of detail. */
    assert_true(levels_used("sphere.json") >= 3);
}

/* Triangle mode across levels of detail: the same closed sphere, displaced 2.5x more with
 * six octaves, seen from inside at levels 6 to 8 side by side. The edges of a patch towards
 * a coarser neighbour take the neighbour's vertices (dice.cl, quadtree_stitch), so the
 * watertight triangle test lets no ray out between them (before the stitching two rays of
 * 196,608 escaped here in the three seeds). */
static void test_triangles_hole_free_across_levels(void **state)
{
    write_inside_sphere("sphere_tri.rib", 256, 0.15, 6);
    int escaped = 0;
    for (int seed = 1; seed <= 3; ++seed) {
        char args[16384];
        snprintf(args, sizeof args,
                 "render '%s' -o '%s' --spp 2 --depth 0 --seed %d --max-lod 8 --intersect "
                 "triangles --stats '%s' --quiet",
                 path("sphere_tri.rib"), path("sphere_tri.exr"), seed, path("sphere_tri.json"));
        render_ok(args);
        escaped += escaped_pixels("sphere_tri.exr");
    }
    assert_int_equal(escaped, 0);
    assert_true(levels_used("sphere_tri.json") >= 3);
}

static void test_memory_budget_does_not_change_the_image(void **state)
{
    /* 2 spp at 256x144 = 73,728 rays: three waves in 16 MB, one in 1024 MB. */
    char args[16384];
    const char *common = "--res 256x144 --spp 2 --max-lod 6 --quiet";
    snprintf(args, sizeof args, "render '%s' -o '%s' --memory 16 --stats '%s' %s",
             test_source_path("scene/teapot.rib"), path("small.exr"), path("small.json"), common);
    render_ok(args);
    snprintf(args, sizeof args, "render '%s' -o '%s' --memory 1024 --stats '%s' %s",
             test_source_path("scene/teapot.rib"), path("big.exr"), path("big.json"), common);
    render_ok(args);
    test_assert_same_pixels(path("small.exr"), path("big.exr"));
    /* The small budget really split the work: more iterations or waves. */
    assert_true(test_stats_number(path("small.json"), "counters.iterations") >
                test_stats_number(path("big.json"), "counters.iterations"));
}

/* The level one_patch.rib's single patch was diced at (its lod_histogram's one entry). */
static int one_patch_level(const char *json)
{
    int level = -1;
    char key[64];
    for (int m = 0; m <= 10; ++m) {
        snprintf(key, sizeof key, "lod_histogram.%d", m);
        double n = test_stats_number(path(json), key);
        if (n > 0) {
            assert_true(n == 1 && level < 0); /* diced once, at one level */
            level = m;
        }
    }
    assert_true(level >= 0);
    return level;
}

static void test_dicing_rate_scales_the_micro_quads(void **state)
{
    /* One patch filling most of a 128x128 view: between 4^6 and 4^7 first-pass eye rays
     * cross its box, so the default rule gives m = 7; D = 2 asks for R / 4 micro-quads and
     * D = 1/2 for 4 R: one level each way, whatever R is. */
    const char *runs[4][3] = {{"rate_default", "", ""},
                              {"rate_1", "--dicing-rate 1", ""},
                              {"rate_2", "--dicing-rate 2", ""},
                              {"rate_half", "--dicing-rate 0.5", ""}};
    char args[16384], exr[64], json[64];
    for (int i = 0; i < 4; ++i) {
        snprintf(exr, sizeof exr, "%s.exr", runs[i][0]);
        snprintf(json, sizeof json, "%s.json", runs[i][0]);
        snprintf(args, sizeof args, "render '%s' -o '%s' --stats '%s' --res 128x128 --quiet %s",
                 test_source_path("scene/one_patch.rib"), path(exr), path(json), runs[i][1]);
        render_ok(args);
    }
    int m = one_patch_level("rate_default.json");
    assert_int_equal(m, 7);
    assert_int_equal(one_patch_level("rate_1.json"), m);
    assert_int_equal(one_patch_level("rate_2.json"), m - 1);
    assert_int_equal(one_patch_level("rate_half.json"), m + 1);
    test_assert_same_pixels(path("rate_default.exr"), path("rate_1.exr"));
}

static void test_sort_by_copy_matches_mapped_sort(void **state)
{
    /* Discrete devices sort a host copy of the pairs (pipeline.h sort_host); CPU devices
     * sort the mapped buffers. Both paths, forced on this device, give the same bits. */
    char args[16384];
    const char *common = "--res 160x90 --spp 2 --max-lod 6 --quiet";
    const char *names[2][2] = {{"mapped.exr", "0"}, {"copied.exr", "1"}};
    for (int i = 0; i < 2; ++i) {
        setenv("TESSERA_SORT_VIA_COPY", names[i][1], 1);
        snprintf(args, sizeof args, "render '%s' -o '%s' %s",
                 test_source_path("scene/teapot_displaced.rib"), path(names[i][0]), common);
        render_ok(args);
    }
    unsetenv("TESSERA_SORT_VIA_COPY");
    test_assert_same_pixels(path("mapped.exr"), path("copied.exr"));
}

/* The patch cache (issue 13): the displaced teapot's 32 patches are diced once per frame
 * when they fit the arenas (the rest are hits), again and again when a small budget makes
 * the cache evict (at --lod 7 they need 24 MB, more than three quarters of --memory 12, so
 * the plan's quarter stays; budget.h), and
 * once per batch with the cache off; all three images are the same bits. */
static void test_patch_cache_dices_once_and_changes_no_bit(void **state)
{
    char args[16384];
    const char *common = "--res 192x108 --spp 2 --lod 7 --quiet";
    const char *runs[3][3] = {{"fits.exr", "fits.json", "--memory 512"},
                              {"evicts.exr", "evicts.json", "--memory 12"},
                              {"off.exr", "off.json", "--memory 512"}};
    for (int i = 0; i < 3; ++i) {
        if (i == 2) setenv("TESSERA_PATCH_CACHE", "0", 1);
        snprintf(args, sizeof args, "render '%s' -o '%s' --stats '%s' %s %s",
                 test_source_path("scene/teapot_displaced.rib"), path(runs[i][0]), path(runs[i][1]),
                 runs[i][2], common);
        render_ok(args);
    }
    unsetenv("TESSERA_PATCH_CACHE");
    test_assert_same_pixels(path("fits.exr"), path("evicts.exr"));
    test_assert_same_pixels(path("fits.exr"), path("off.exr"));
    double diced = test_stats_number(path("fits.json"), "counters.patches_diced");
    double hits = test_stats_number(path("fits.json"), "counters.patch_cache_hits");
    assert_true(diced == 32.0);     /* every patch once */
    assert_true(hits >= 2 * diced); /* four waves: the later three hit */
    assert_true(test_stats_number(path("fits.json"), "counters.patch_cache_evictions") == 0.0);
    assert_true(test_stats_number(path("evicts.json"), "counters.patch_cache_evictions") > 0.0);
    assert_true(test_stats_number(path("evicts.json"), "counters.patches_diced") > diced);
    assert_true(test_stats_number(path("off.json"), "counters.patch_cache_hits") == 0.0);
    assert_true(test_stats_number(path("off.json"), "counters.patches_diced") > 3 * diced);
}

/* A frame whose patches do not fit builds a missed patch without its vertices when no ray of
 * the iteration leaves it (trace.c plan_batches, top_level's leaving marks): in box mode only
 * the rays leaving a patch read them (the origin-patch rule), and build reads the control
 * points. The same bits as the frame that fits, where every patch is diced whole, for noise
 * displacement and none, and for instances sharing their master's dicing (the shape's
 * vertices are diced when any of its segments needs them); some misses are built without
 * their vertices, not all (the bounces leave the patches they hit, and those need them). */
static void test_squeezed_frames_skip_unread_vertices(void **state)
{
    (void)state;
    const struct {
        const char *scene, *lod, *squeeze;
    } runs[] = {{"scene/teapot_displaced.rib", "--lod 6", "--memory 8"},
                {"scene/teapot.rib", "--lod 7", "--memory 12"},
                {"scene/instances.rib", "--lod 6", "--memory 8"}};
    for (size_t r = 0; r < sizeof runs / sizeof runs[0]; ++r) {
        for (int squeezed = 0; squeezed < 2; ++squeezed) {
            char args[16384];
            snprintf(args, sizeof args,
                     "render '%s' -o '%s' --stats '%s' %s %s --res 192x108 --spp 2 --quiet",
                     test_source_path(runs[r].scene), path(squeezed ? "sq.exr" : "fit.exr"),
                     path(squeezed ? "sq.json" : "fit.json"), runs[r].lod,
                     squeezed ? runs[r].squeeze : "--memory 512");
            render_ok(args);
        }
        test_assert_same_pixels(path("fit.exr"), path("sq.exr"));
        double diced = test_stats_number(path("sq.json"), "counters.patches_diced");
        double skipped = test_stats_number(path("sq.json"), "counters.grids_skipped");
        assert_true(test_stats_number(path("sq.json"), "counters.patch_cache_evictions") > 0.0);
        assert_true(skipped > 0.0 && skipped < diced);
        assert_true(test_stats_number(path("fit.json"), "counters.grids_skipped") == 0.0);
    }
}

/* A squeezed frame traces a missed patch with few pairs through the kept skeleton of its tree
 * (trace.c plan_batches, build.cl build_skeleton, bottom_level.cl bl_skeleton): the leaves its
 * rays enter made in bottom_level with the same bits as build's, and for the rays that leave
 * the patch the vertices with dice's bits, so the same hits and pixels as the frame that fits,
 * and as the same squeezed frame without skeletons (TESSERA_SKELETON_PAIR_LEAVES=0). With 1,
 * every segment whose tree has a skeleton takes it; with the default, some. forest-1 has all
 * three kinds of tree (ridged bark, fBm ground, undisplaced leaves) and at --memory 16 thins
 * its arenas (as test_thin_arenas_make_fewer_waves), which keeps room for the skeletons within
 * the budget (skeleton_bytes); at twice the arenas it is not thinned, and the skeletons take a
 * part of the arenas. The reference, --memory 2048, fits. Leaving out a block's first micro-quad
 * for the rays that leave the patch, or growing an undisplaced leaf box, fails it. */
static void test_squeezed_frames_trace_skeletons(void **state)
{
    (void)state;
    const char *scene = test_source_path("scene/forest-1.rib");
    const int lods[] = {6, 5};
    const char *leaves[] = {"", "1", "0"}; /* the default, every segment it may, none */
    for (size_t r = 0; r < sizeof lods / sizeof lods[0]; ++r) {
        char args[16384];
        snprintf(args, sizeof args,
                 "render '%s' -o '%s' --stats '%s' --lod %d --memory 2048 --res 160x90 --spp 4 "
                 "--quiet",
                 scene, path("fit.exr"), path("fit.json"), lods[r]);
        render_ok(args);
        assert_true(test_stats_number(path("fit.json"), "counters.patch_cache_evictions") == 0.0);
        assert_true(test_stats_number(path("fit.json"), "counters.skeleton_segments") == 0.0);
        double kept[3];
        for (int k = 0; k < 3; ++k) {
            setenv("TESSERA_SKELETON_PAIR_LEAVES", leaves[k], 1);
            snprintf(args, sizeof args,
                     "render '%s' -o '%s' --stats '%s' --lod %d --memory 16 --res 160x90 --spp 4 "
                     "--quiet",
                     scene, path("sq.exr"), path("sq.json"), lods[r]);
            render_ok(args);
            unsetenv("TESSERA_SKELETON_PAIR_LEAVES");
            test_assert_same_pixels(path("fit.exr"), path("sq.exr"));
            kept[k] = test_stats_number(path("sq.json"), "counters.skeleton_segments");
            double bytes = test_stats_number(path("sq.json"), "counters.skeleton_bytes");
            assert_true(kept[k] > 0.0 ? bytes > 0.0 : 1);
            test_assert_device_bytes_in_budget(path("sq.json"), 160.0 * 90, 1110);
        }
        print_message("[ skeleton ] --lod %d: %g segments through skeletons (default), %g (all), "
                      "%g (off)\n",
                      lods[r], kept[0], kept[1], kept[2]);
        assert_true(kept[0] > 0.0 && kept[1] > kept[0] && kept[2] == 0.0);
        /* not thinned (the patches need twice the arenas, --memory 512 at --lod 6, 128 at 5):
         * the skeletons' room taken from the arenas (budget.c skeleton_room) */
        snprintf(args, sizeof args,
                 "render '%s' -o '%s' --stats '%s' --lod %d --memory %d --res 160x90 --spp 4 "
                 "--quiet",
                 scene, path("sq.exr"), path("sq.json"), lods[r], lods[r] == 6 ? 512 : 128);
        render_ok(args);
        test_assert_same_pixels(path("fit.exr"), path("sq.exr"));
        assert_true(test_stats_number(path("sq.json"), "counters.skeleton_segments") > 0.0);
        assert_true(test_stats_number(path("sq.json"), "counters.patch_cache_evictions") > 0.0);
        test_assert_device_bytes_in_budget(path("sq.json"), 160.0 * 90, 1110);
    }
}

/* Shading normals from the diced grid (pipeline_grid_publish): shade reads the hit
 * micro-quad's four vertices from the grid where its patch is resident, and evaluates them
 * where it is not (TESSERA_GRID_NORMALS=0: everywhere). The images are the same bits in
 * leaf-box and triangle modes, with noise and texture displacement, moving patches, instances
 * sharing their master's dicing (the master's grid is not the instance's: evaluated), and
 * under a budget the patches do not fit (--memory 12: evicted before shade, some of each). */
static void test_grid_normals_change_no_bit(void **state)
{
    char args[16384];
    /* motion.rib's deforming surfaces under noise displacement */
    FILE *in = fopen(test_source_path("scene/motion.rib"), "r"), *f = fopen(path("mdisp.rib"), "w");
    assert_true(in && f);
    char line[1024];
    while (fgets(line, sizeof line, in)) {
        fputs(line, f);
        if (strncmp(line, "WorldBegin", 10) == 0)
            fputs("Displacement \"fbm\" \"float amplitude\" [0.05] \"float frequency\" [4]\n", f);
    }
    fclose(in), fclose(f);
    const char *runs[][5] = {
        {"scene/teapot_displaced.rib", "gn_box_on", "1", "--memory 512", ""},
        {"scene/teapot_displaced.rib", "gn_box_off", "0", "--memory 512", ""},
        {"scene/teapot_displaced.rib", "gn_tri_on", "1", "--memory 512", "--intersect triangles"},
        {"scene/teapot_displaced.rib", "gn_tri_off", "0", "--memory 512", "--intersect triangles"},
        {"scene/instances_displaced.rib", "gn_inst_on", "1", "--memory 512", ""},
        {"scene/instances_displaced.rib", "gn_inst_off", "0", "--memory 512", ""},
        {"scene/textured.rib", "gn_tex_on", "1", "--memory 512", ""},
        {"scene/textured.rib", "gn_tex_off", "0", "--memory 512", ""},
        {NULL, "gn_motion_on", "1", "--memory 512", ""},
        {NULL, "gn_motion_off", "0", "--memory 512", ""},
        {"scene/teapot_displaced.rib", "gn_small", "1", "--memory 12", ""},
    };
    enum { RUNS = sizeof runs / sizeof runs[0] };
    char exr[RUNS][64];
    for (int i = 0; i < RUNS; ++i) {
        snprintf(exr[i], sizeof exr[i], "%s.exr", runs[i][1]);
        const char *scene = runs[i][0] ? test_source_path(runs[i][0]) : path("mdisp.rib");
        setenv("TESSERA_GRID_NORMALS", runs[i][2], 1);
        snprintf(args, sizeof args,
                 "render '%s' -o '%s' --res 192x108 --spp 4 --lod 7 --quiet %s %s", scene,
                 path(exr[i]), runs[i][3], runs[i][4]);
        render_ok(args);
    }
    unsetenv("TESSERA_GRID_NORMALS");
    for (int i = 0; i + 1 < RUNS; i += 2) /* on against off */
        test_assert_same_pixels(path(exr[i]), path(exr[i + 1]));
    test_assert_same_pixels(path(exr[0]), path(exr[RUNS - 1])); /* evicted before shade */
    /* Triangle mode at the ray-driven levels: edges towards coarser neighbours are stitched,
     * and shade's evaluated corners move as dice's did (quadtree_stitch). */
    for (int i = 0; i < 2; ++i) {
        setenv("TESSERA_GRID_NORMALS", i ? "0" : "1", 1);
        snprintf(args, sizeof args,
                 "render '%s' -o '%s' --res 192x108 --spp 4 --intersect triangles --quiet "
                 "--stats '%s'",
                 test_source_path("scene/teapot_displaced.rib"),
                 path(i ? "gn_stitch_off.exr" : "gn_stitch_on.exr"), path("gn_stitch.json"));
        render_ok(args);
    }
    unsetenv("TESSERA_GRID_NORMALS");
    test_assert_same_pixels(path("gn_stitch_on.exr"), path("gn_stitch_off.exr"));
    assert_true(levels_used("gn_stitch.json") >= 2); /* neighbours at different levels */
}

/* Triangle mode's leaf boxes (tight: the box of each micro-quad's four diced vertices)
 * against box mode's (bounding every finer dicing's surface, TESSERA_TIGHT_LEAVES=0): the
 * triangles are the same, so every hit is, and the images are the same bits: noise and
 * texture displacement, moving patches, instances, and the bake's visibility. */
static void test_tight_leaves_change_no_bit(void **state)
{
    char args[16384];
    const char *runs[][3] = {
        {"scene/teapot_displaced.rib", "tl_td", "render"},
        {"scene/textured.rib", "tl_tex", "render"},
        {"scene/motion.rib", "tl_motion", "render"},
        {"scene/instances_displaced.rib", "tl_inst", "render"},
        {"scene/teapot_displaced.rib", "tl_bake", "bake"},
    };
    enum { RUNS = sizeof runs / sizeof runs[0] };
    for (int i = 0; i < RUNS; ++i) {
        char on[64], off[64], son[64], soff[64];
        snprintf(on, sizeof on, "%s_on.exr", runs[i][1]);
        snprintf(off, sizeof off, "%s_off.exr", runs[i][1]);
        snprintf(son, sizeof son, "%s_on.json", runs[i][1]);
        snprintf(soff, sizeof soff, "%s_off.json", runs[i][1]);
        const char *size = strcmp(runs[i][2], "bake") == 0 ? "--res 40x24" : "--res 160x90 --spp 2";
        for (int tight = 1; tight >= 0; --tight) {
            if (!tight) setenv("TESSERA_TIGHT_LEAVES", "0", 1);
            snprintf(args, sizeof args,
                     "%s '%s' -o '%s' %s --intersect triangles --quiet --stats '%s'", runs[i][2],
                     test_source_path(runs[i][0]), path(tight ? on : off), size,
                     path(tight ? son : soff));
            render_ok(args);
            unsetenv("TESSERA_TIGHT_LEAVES");
        }
        test_assert_same_pixels(path(on), path(off));
        /* The tight boxes are the ones traversed: fewer micro-quads tested. */
        if (strcmp(runs[i][0], "scene/teapot_displaced.rib") == 0 &&
            strcmp(runs[i][2], "render") == 0)
            assert_true(test_stats_number(path(son), "counters.leaf_tests") <
                        0.5 * test_stats_number(path(soff), "counters.leaf_tests"));
    }
}

/* The kernels as a GPU builds them (TESSERA_CPU_LANES=0: no -DTS_CPU_LANES, so
 * lib/bezier.h sums the control points in scalars instead of float4 lanes, and camera.cl
 * makes one ray a work-item instead of eight in lanes) give the bits of a CPU device's: the
 * form GPUs run is compiled and checked here, where CI has no GPU. Odd sizes leave the last
 * work-item of camera's lanes fewer than eight rays; a moving and an orthographic camera. */
static void test_cpu_lanes_change_no_bit(void **state)
{
    char args[16384];
    const char *runs[][3] = {
        {"render", "scene/teapot_displaced.rib", "--res 160x90 --spp 2 --depth 2"},
        {"render", "scene/textured.rib", "--res 97x55 --spp 3 --intersect triangles"},
        {"render", "scene/motion.rib", "--res 61x37 --spp 5"},            /* a moving camera */
        {"render", "scene/teapots.rib", "--res 45x29 --spp 1 --frame 2"}, /* orthographic */
        {"bake", "scene/teapot_displaced.rib", "--res 40x24"},
    };
    enum { RUNS = sizeof runs / sizeof runs[0] };
    for (int i = 0; i < RUNS; ++i) {
        char exr[2][32];
        for (int lanes = 1; lanes >= 0; --lanes) {
            snprintf(exr[lanes], sizeof exr[lanes], "lanes%d_%d.exr", i, lanes);
            if (!lanes) setenv("TESSERA_CPU_LANES", "0", 1);
            snprintf(args, sizeof args, "%s '%s' -o '%s' %s --quiet", runs[i][0],
                     test_source_path(runs[i][1]), path(exr[lanes]), runs[i][2]);
            render_ok(args);
            unsetenv("TESSERA_CPU_LANES");
        }
        test_assert_same_pixels(path(exr[1]), path(exr[0]));
    }
}

/* A default budget whose arenas are too small for the frame's patches (its cap lowered to
 * 16 MB: 4 MB of arenas, where the displaced teapot's patches need 6.7 MB at 320x180):
 * after the lod stage the arenas grow to hold them all, each is diced once, nothing is
 * evicted, and the image is that of a budget they fit. --memory 16 does not grow: the
 * budget is split again instead (budget.h's trade), the arenas taking the 6.7 MB from the
 * rays of a wave, so each patch is diced once there too, within the 16 MB. */
static void test_arenas_grow_to_the_frames_patches(void **state)
{
    char args[16384];
    const char *common = "--res 320x180 --spp 1 --max-lod 6";
    const char *runs[3][3] = {{"big.exr", "big.json", "--memory 512 --quiet"},
                              {"grows.exr", "grows.json", ""},
                              {"fixed.exr", "fixed.json", "--memory 16"}};
    setenv("TESSERA_BUDGET_CAP_MB", "16", 1);
    for (int i = 0; i < 3; ++i) {
        snprintf(args, sizeof args, "render '%s' -o '%s' --stats '%s' %s %s",
                 test_source_path("scene/teapot_displaced.rib"), path(runs[i][0]), path(runs[i][1]),
                 runs[i][2], common);
        render_ok(args);
        if (i == 1) test_expect_in_stderr(dir, "the patch cache grows from 3 to 6 MB");
        if (i == 2)
            test_expect_in_stderr(dir, "the patch cache takes 6 MB of the 16 MB budget instead "
                                       "of 3 MB, waves ");
    }
    unsetenv("TESSERA_BUDGET_CAP_MB");
    test_assert_same_pixels(path("big.exr"), path("grows.exr"));
    test_assert_same_pixels(path("big.exr"), path("fixed.exr"));
    assert_true(test_stats_number(path("grows.json"), "counters.patches_diced") == 32.0);
    assert_true(test_stats_number(path("grows.json"), "counters.patch_cache_evictions") == 0.0);
    assert_true(test_stats_number(path("grows.json"), "memory_budget_bytes") > 16.0 * 1048576);
    assert_true(test_stats_number(path("grows.json"), "counters.patch_cache_bytes") >
                5.0 * 1048576);
    assert_true(test_stats_number(path("fixed.json"), "memory_budget_bytes") == 16.0 * 1048576);
    assert_true(test_stats_number(path("fixed.json"), "counters.patches_diced") == 32.0);
    assert_true(test_stats_number(path("fixed.json"), "counters.patch_cache_evictions") == 0.0);
    /* What the device held stayed within each budget, also while the arenas grew (the old
     * ones go before the new ones are made): the grown budget of the default, and the 16 MB of
     * --memory, where the waves shrank by what the arenas took. 16 MB fills up with rays (the
     * 320x180 frame wants more), so the device held all of the budget but a few hundred bytes
     * (336 on PoCL): the count misses none of the budget's buffers. */
    for (int i = 0; i < 3; ++i)
        test_assert_device_bytes_in_budget(path(runs[i][1]), 320.0 * 180, 32);
    assert_true(test_assert_device_bytes_in_budget(path("fixed.json"), 320.0 * 180, 32) <
                64.0 * 1024);
}

/* Once the frame's patches all fit, waves are cut to TS_FIT_WAVE_RAYS (app/budget.h; the
 * testing aid TESSERA_FIT_WAVE_RAYS lowers it to 8192 rays, 4096 paths): the same pixels as
 * one wave of the whole frame; a frame whose patches do not fit keeps its larger waves,
 * which bound how often they are diced again. */
static void test_waves_are_cut_once_the_patches_fit(void **state)
{
    char args[16384];
    const char *scene = test_source_path("scene/teapot_displaced.rib");
    snprintf(args, sizeof args, "render '%s' -o '%s' --stats '%s' --res 160x90 --spp 2 --quiet",
             scene, path("whole.exr"), path("whole.json"));
    render_ok(args);
    setenv("TESSERA_FIT_WAVE_RAYS", "8192", 1);
    snprintf(args, sizeof args, "render '%s' -o '%s' --stats '%s' --res 160x90 --spp 2 --quiet",
             scene, path("cut.exr"), path("cut.json"));
    render_ok(args);
    snprintf(args, sizeof args,
             "render '%s' -o '%s' --stats '%s' --res 160x90 --spp 2 --memory 16 --lod 8 "
             "--quiet",
             scene, path("squeezed.exr"), path("squeezed.json"));
    render_ok(args);
    unsetenv("TESSERA_FIT_WAVE_RAYS");
    test_assert_same_pixels(path("whole.exr"), path("cut.exr"));
    /* The first eye rays: every path of the frame at once, then 4096 a wave. */
    assert_true(test_stats_number(path("whole.json"), "iterations.0.active_rays") ==
                160.0 * 90 * 2);
    assert_true(test_stats_number(path("cut.json"), "iterations.0.active_rays") == 4096.0);
    assert_true(test_stats_number(path("cut.json"), "counters.patch_cache_evictions") == 0.0);
    assert_true(test_stats_number(path("squeezed.json"), "counters.patch_cache_evictions") > 0.0);
    assert_true(test_stats_number(path("squeezed.json"), "iterations.0.active_rays") > 4096.0);
}

/* A frame whose patches need far more than the patch arenas hold (forest-1 at m = 6, 260 MB,
 * in a 16 MB budget; at m = 4, 16 MB, four times the arenas) gives three quarters of the
 * arenas to the rays when that makes fewer waves (app/budget.c thin_arenas): 2 waves instead
 * of 3, the budget kept, the pixels of a budget that holds every patch. */
static void test_thin_arenas_make_fewer_waves(void **state)
{
    static const struct {
        int lod;
        const char *note;
    } cases[] = {
        {6, "times what the patch cache holds: it takes 0.9 MB instead of 3.5 MB, and waves 66064 "
            "rays instead of 54543 (2 waves instead of 3)"},
        /* four times the arenas (TS_THIN_NEED_DIV): thinned too */
        {4, "the frame's patches need 16 MB, 4 times what the patch cache holds: it takes 0.9 MB "
            "instead of 3.5 MB, and waves 66064 rays instead of 54543 (2 waves instead of 3)"},
    };
    char args[16384], roomy[64], thin[64], json[64];
    const char *scene = test_source_path("scene/forest-1.rib");
    setenv("TESSERA_SKELETON_PAIR_LEAVES", "0", 1); /* no room kept for skeletons: the rays' */
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        snprintf(roomy, sizeof roomy, "roomy%d.exr", cases[k].lod);
        snprintf(thin, sizeof thin, "thin%d.exr", cases[k].lod);
        snprintf(json, sizeof json, "thin%d.json", cases[k].lod);
        snprintf(args, sizeof args,
                 "render '%s' -o '%s' --res 160x90 --spp 4 --lod %d --memory 512 --quiet", scene,
                 path(roomy), cases[k].lod);
        render_ok(args);
        snprintf(args, sizeof args,
                 "render '%s' -o '%s' --stats '%s' --res 160x90 --spp 4 --lod %d --memory 16",
                 scene, path(thin), path(json), cases[k].lod);
        render_ok(args);
        test_expect_in_stderr(dir, cases[k].note);
        test_assert_same_pixels(path(roomy), path(thin));
        assert_true(test_stats_number(path(json), "iterations.0.active_rays") == 33032.0);
        assert_true(test_stats_number(path(json), "memory_budget_bytes") == 16.0 * 1048576);
        test_assert_device_bytes_in_budget(path(json), 160.0 * 90, 1110);
    }
    unsetenv("TESSERA_SKELETON_PAIR_LEAVES");
}

/* The lowest level any dicing of the render used (lod_histogram). */
static int lowest_level(const char *json)
{
    char key[64];
    for (int m = 0; m <= 10; ++m) {
        snprintf(key, sizeof key, "lod_histogram.%d", m);
        if (test_stats_number(json, key) > 0) return m;
    }
    fail_msg("%s: no dicing", json);
    return -1;
}

static void test_hidden_patch_is_diced_coarser_under_the_seen_rules(void **state)
{
    (void)state;
    /* A flat square facing the camera, and 0.2 behind it a smaller one that it hides wholly;
     * lit from the camera's side, so the hidden one casts no shadow on anything seen. The
     * hidden one lies left of the front one's centre (x 0..1 against -1..3) and their depths
     * differ less than that, so the top level splits them on x and a ray that crosses both
     * (rightwards) gets the hidden one as its first candidate: it is diced. (A hidden patch
     * that came second would never be: the first candidate's hit culls it, trace.c.) */
    FILE *f = fopen(path("hidden.rib"), "w");
    assert_non_null(f);
    fputs("Format 96 96 1\nProjection \"perspective\" \"fov\" [40]\n"
          "LightSource \"distantlight\" 1 \"from\" [0 0 0] \"to\" [0 0 1]\n"
          "Translate 0 0 4\nWorldBegin\n"
          "Patch \"bilinear\" \"P\" [-1 -1 0  3 -1 0  -1 1 0  3 1 0]\n"
          "Patch \"bilinear\" \"P\" [0 -0.8 0.2  1 -0.8 0.2  0 0.8 0.2  1 0.8 0.2]\n"
          "WorldEnd\n",
          f);
    fclose(f);
    const char *rules[] = {"crossed", "seen", "visible"};
    char name[64], json[64];
    for (int i = 0; i < 3; ++i) {
        setenv("TESSERA_LOD_RULE", rules[i], 1);
        snprintf(name, sizeof name, "hidden_%s.exr", rules[i]);
        snprintf(json, sizeof json, "hidden_%s.json", rules[i]);
        char out[4200], stats[4200];
        snprintf(out, sizeof out, "%s", path(name));
        snprintf(stats, sizeof stats, "%s", path(json));
        test_tessera_ok(dir, "render '%s' -o '%s' --spp 2 --max-lod 8 --stats '%s' --quiet",
                        path("hidden.rib"), out, stats);
    }
    unsetenv("TESSERA_LOD_RULE");
    /* Under the default both squares are diced at the levels their box crossings give: the
     * hidden one's box is crossed by every ray that meets it, so it is not coarse. */
    int crossed = lowest_level(path("hidden_crossed.json"));
    assert_true(crossed >= 3);
    assert_int_equal(lowest_level(path("hidden_seen.json")), crossed - 2);
    assert_int_equal(lowest_level(path("hidden_visible.json")), crossed - 2);
    test_assert_same_pixels(path("hidden_crossed.exr"), path("hidden_seen.exr"));
    test_assert_same_pixels(path("hidden_crossed.exr"), path("hidden_visible.exr"));

    setenv("TESSERA_LOD_RULE", "nearest", 1);
    int rc =
        test_run_tessera(dir, "render '%s' -o '%s' --quiet", path("hidden.rib"), path("bad.exr"));
    unsetenv("TESSERA_LOD_RULE");
    assert_int_not_equal(rc, 0);
    FILE *e = fopen(path("stderr.txt"), "r");
    assert_non_null(e);
    char line[512] = "";
    if (!fgets(line, sizeof line, e)) line[0] = 0;
    fclose(e);
    assert_non_null(strstr(line, "TESSERA_LOD_RULE=nearest: expected crossed, visible or seen"));
    assert_int_equal(access(path("bad.exr"), F_OK), -1);
}

static void test_ten_billion_potential_micropolygons_in_fixed_memory(void **state)
{
    /* A 100 x 100 field of displaced patches: 10^4 patches at m = 10 is 1.05 * 10^10
     * potential micro-quads. */
    FILE *f = fopen(path("field.rib"), "w");
    assert_non_null(f);
    fprintf(f, "Format 192 108 1\nProjection \"perspective\" \"fov\" [50]\n"
               "Translate 0 -2 60\nRotate -35 1 0 0\nWorldBegin\n"
               "Displacement \"ridged\" \"float amplitude\" [0.3] \"float frequency\" [0.8] "
               "\"float octaves\" [5]\n");
    for (int b = 0; b < 100; ++b)
        for (int a = 0; a < 100; ++a) {
            fputs("Patch \"bilinear\" \"P\" [", f);
            for (int c = 0; c < 4; ++c)
                fprintf(f, " %d %d 0", a - 50 + (c & 1), b - 50 + (c >> 1));
            fputs(" ]\n", f);
        }
    fputs("WorldEnd\n", f);
    fclose(f);
    char args[16384];
    snprintf(args, sizeof args, "render '%s' -o '%s' --memory 512 --stats '%s' --quiet",
             path("field.rib"), path("field.exr"), path("field.json"));
    render_ok(args);
    double potential = test_stats_number(path("field.json"), "counters.micropolygons_potential");
    double created = test_stats_number(path("field.json"), "counters.micropolygons_created");
    double rss = test_stats_number(path("field.json"), "peak_rss_bytes");
    assert_true(potential > 1e10);
    assert_true(created > 0 && created < potential / 100);
    assert_true(rss < 2.0 * 1024 * 1024 * 1024);
    /* The device's buffers stay within --memory 512 beside the films and the 10^4 patches'
     * own data, whatever the 10^10 micro-quads would take. */
    test_assert_device_bytes_in_budget(path("field.json"), 192.0 * 108, 1e4);
}

/* One unit patch at depth 4 facing the camera, moving by (dx, 0, 0) over the shutter when
 * `moving`, else translated by t * dx. */
static void write_patch_scene(const char *name, int moving, double dx, double t)
{
    FILE *f = fopen(path(name), "w");
    assert_non_null(f);
    /* A delta sun from the camera's side: the patch has radiance Kd E / pi = 1, the
     * background 0. */
    fprintf(f, "Format 48 32 1\nProjection \"perspective\" \"fov\" [40]\nWorldBegin\n"
               "LightSource \"distantlight\" 1 \"float intensity\" [3.14159265358979] "
               "\"point from\" [0 0 0] \"point to\" [0 0 1]\n");
    if (moving)
        fprintf(f, "MotionBegin [0 1]\nTranslate 0 0 0\nTranslate %.17g 0 0\nMotionEnd\n", dx);
    else
        fprintf(f, "Translate %.17g 0 0\n", t * dx);
    fputs("Patch \"bilinear\" \"P\" [-1.2 -0.6 4  -0.2 -0.6 4  -1.2 0.6 4  -0.2 0.6 4]\nWorldEnd\n",
          f);
    fclose(f);
}

static void test_motion_blur_is_the_time_average(void **state)
{
    enum { SPP = 256, STEPS = 32 };
    const double dx = 1.2;
    char args[16384];
    write_patch_scene("moving.rib", 1, dx, 0);
    snprintf(args, sizeof args, "render '%s' -o '%s' --spp %d --lod 3 --quiet", path("moving.rib"),
             path("moving.exr"), SPP);
    render_ok(args);
    ts_image mov, st;
    load("moving.exr", &mov);
    int npix = mov.width * mov.height;
    double *avg = calloc((size_t)npix, sizeof *avg);
    for (int k = 0; k < STEPS; ++k) {
        write_patch_scene("static.rib", 0, dx, (k + 0.5) / STEPS);
        snprintf(args, sizeof args, "render '%s' -o '%s' --spp 16 --lod 3 --seed %d --quiet",
                 path("static.rib"), path("static.exr"), k);
        render_ok(args);
        load("static.exr", &st);
        for (int i = 0; i < npix; ++i)
            avg[i] += st.pixels[i * st.channels] / STEPS;
        image_free(&st);
    }
    /* Each pixel of the moving render averages SPP samples of a value in [0, vmax]; its
     * standard deviation is at most vmax / (2 sqrt(SPP)). The static average adds less
     * (STEPS * 16 samples) plus the time quadrature error of a step function, at most
     * vmax / STEPS per pixel. Allow 5 standard deviations plus the quadrature error. */
    double vmax = 0, worst = 0, blurred = 0;
    for (int i = 0; i < npix; ++i)
        vmax = fmax(vmax, avg[i]);
    double sigma = vmax / (2.0 * sqrt((double)SPP)) * sqrt(1.0 + (double)SPP / (STEPS * 16.0));
    double tol = 5.0 * sigma + vmax / STEPS;
    /* The sums over the image: a sample is 0 or vmax (covered or not), so a pixel of mean m
     * has variance m (vmax - m) per sample; the sums' variances add those over SPP moving
     * samples and STEPS * 16 static ones. The patch stays in the frame, so its covered area,
     * and the static sum, do not depend on t: the time quadrature adds nothing to the sum. */
    double sum_mov = 0, sum_avg = 0, var_sum = 0;
    for (int i = 0; i < npix; ++i) {
        double m = mov.pixels[i * mov.channels];
        worst = fmax(worst, fabs(m - avg[i]));
        blurred += m > 0.2 * vmax && m < 0.8 * vmax; /* partly covered over the shutter */
        sum_mov += m, sum_avg += avg[i];
        var_sum +=
            fmax(m * (vmax - m), 0.0) / SPP + fmax(avg[i] * (vmax - avg[i]), 0.0) / (STEPS * 16.0);
    }
    image_free(&mov);
    free(avg);
    if (worst > tol) fail_msg("largest pixel difference %g > tolerance %g", worst, tol);
    double sum_tol = 5.0 * sqrt(var_sum) + 1e-4 * sum_avg;
    if (fabs(sum_mov - sum_avg) > sum_tol)
        fail_msg("the moving image sums to %g, the time average to %g (tolerance %g)", sum_mov,
                 sum_avg, sum_tol);
    assert_true(blurred >= 32); /* a visible smear, so the comparison means something */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_displaced_sphere_is_hole_free_from_inside),
        cmocka_unit_test(test_memory_budget_does_not_change_the_image),
        cmocka_unit_test(test_sort_by_copy_matches_mapped_sort),
        cmocka_unit_test(test_dicing_rate_scales_the_micro_quads),
        cmocka_unit_test(test_triangles_hole_free_across_levels),
        cmocka_unit_test(test_patch_cache_dices_once_and_changes_no_bit),
        cmocka_unit_test(test_squeezed_frames_skip_unread_vertices),
        cmocka_unit_test(test_squeezed_frames_trace_skeletons),
        cmocka_unit_test(test_grid_normals_change_no_bit),
        cmocka_unit_test(test_tight_leaves_change_no_bit),
        cmocka_unit_test(test_cpu_lanes_change_no_bit),
        cmocka_unit_test(test_arenas_grow_to_the_frames_patches),
        cmocka_unit_test(test_waves_are_cut_once_the_patches_fit),
        cmocka_unit_test(test_thin_arenas_make_fewer_waves),
        cmocka_unit_test(test_hidden_patch_is_diced_coarser_under_the_seen_rules),
        cmocka_unit_test(test_ten_billion_potential_micropolygons_in_fixed_memory),
        cmocka_unit_test(test_motion_blur_is_the_time_average),
    };
    return TEST_RUN_WITH_DEVICE(tests, setup);
}
