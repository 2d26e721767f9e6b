/* test_forest.c — the procedural forest (host/scene/forest.c): deterministic, linear in the
 * number of trees, at least 10^11 / 10^12 potential micro-polygons (4^10 per patch) for
 * 100 / 1000 trees (counted without storing, as the scene would hold them), finite patches
 * with unit corner normals, and watertight rings around each branch segment. Host only;
 * nothing is rendered. */
#include "scene/forest.h"
#include "scene/scene.h"
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const double identity[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

static void generate(int trees, uint32_t seed, int detail, ts_scene *s, forest_counts *c)
{
    forest_params fp = {trees, seed, detail, 0};
    ts_error e = {0};
    memset(s, 0, sizeof *s);
    if (forest_generate(&fp, identity, NULL, s, c, &e) != TS_OK) fail_msg("%s", e.msg);
    if (scene_finalize(s, &e) != TS_OK) fail_msg("%s", e.msg);
}

static forest_counts count_only(int trees, uint32_t seed, int detail)
{
    forest_params fp = {trees, seed, detail, 0};
    forest_counts c;
    ts_error e = {0};
    if (forest_generate(&fp, identity, NULL, NULL, &c, &e) != TS_OK) fail_msg("%s", e.msg);
    return c;
}

static uint64_t total(const forest_counts *c)
{
    return c->bark + c->leaves + c->terrain;
}

/* Same parameters, same patches, bit for bit; another seed, another forest. */
static void test_deterministic(void **state)
{
    (void)state;
    ts_scene a, b, c;
    forest_counts ca, cb, cc;
    generate(5, 42, 1, &a, &ca);
    generate(5, 42, 1, &b, &cb);
    assert_int_equal(a.patch_count, b.patch_count);
    assert_int_equal(a.patch_count, total(&ca));
    assert_memory_equal(a.cp, b.cp, (size_t)a.patch_count * 16 * sizeof *a.cp);
    assert_memory_equal(a.corner_n, b.corner_n, (size_t)a.patch_count * 4 * sizeof *a.corner_n);
    assert_memory_equal(a.attr, b.attr, (size_t)a.patch_count * sizeof *a.attr);
    assert_int_equal(a.xform_count, b.xform_count);
    assert_memory_equal(a.xform, b.xform, a.xform_count * sizeof *a.xform);
    /* Counting without storing gives the same numbers. */
    forest_counts co = count_only(5, 42, 1);
    assert_true(co.bark == ca.bark && co.leaves == ca.leaves && co.terrain == ca.terrain);
    generate(5, 43, 1, &c, &cc);
    size_t n = (size_t)(a.patch_count < c.patch_count ? a.patch_count : c.patch_count) * 16;
    assert_true(a.patch_count != c.patch_count || memcmp(a.cp, c.cp, n * sizeof *a.cp) != 0);
    scene_free(&a);
    scene_free(&b);
    scene_free(&c);
}

/* The scene's patch arrays are made as large as the forest at once (its trees counted first,
 * on threads, scene_reserve_patches), instead of doubling as they are added: the capacity is
 * the patch count exactly, also after patches that came before; the forest is the one added
 * patch by patch (a scene of one tree, then the forest of seven, against seven alone). */
static void test_arrays_sized_at_once(void **state)
{
    (void)state;
    ts_scene a, b;
    forest_counts ca, cb;
    generate(7, 5, 1, &a, &ca);
    assert_int_equal(a.patch_capacity, a.patch_count);
    forest_params one = {1, 9, 1, 0}, seven = {7, 5, 1, 0};
    ts_error e = {0};
    memset(&b, 0, sizeof b);
    assert_int_equal(forest_generate(&one, identity, NULL, &b, NULL, &e), TS_OK);
    uint32_t first = b.patch_count;
    assert_int_equal(b.patch_capacity, first);
    assert_int_equal(forest_generate(&seven, identity, NULL, &b, &cb, &e), TS_OK);
    assert_int_equal(b.patch_capacity, b.patch_count);
    assert_int_equal(b.patch_count - first, a.patch_count);
    assert_memory_equal(b.cp + (size_t)first * 16, a.cp, (size_t)a.patch_count * 16 * sizeof *a.cp);
    assert_memory_equal(b.attr + first, a.attr, (size_t)a.patch_count * sizeof *a.attr);
    scene_free(&a);
    scene_free(&b);
}

/* The trees are added on threads, each into the slots its count gives it: on one thread, on
 * three (chunks of 4, 4 and 5 trees) and on every processor, the same scene byte for byte. */
static void test_same_on_threads(void **state)
{
    (void)state;
    ts_scene s[3];
    forest_counts c[3];
    const int threads[3] = {1, 3, 0};
    for (int k = 0; k < 3; k++) {
        forest_params fp = {13, 4, 1, threads[k]};
        ts_error e = {0};
        memset(&s[k], 0, sizeof s[k]);
        if (forest_generate(&fp, identity, NULL, &s[k], &c[k], &e) != TS_OK) fail_msg("%s", e.msg);
    }
    for (int k = 1; k < 3; k++) {
        size_t n = s[0].patch_count;
        assert_int_equal(s[k].patch_count, n);
        assert_int_equal(c[k].bark, c[0].bark);
        assert_int_equal(c[k].leaves, c[0].leaves);
        assert_memory_equal(s[k].cp, s[0].cp, n * 16 * sizeof *s[0].cp);
        assert_memory_equal(s[k].corner_n, s[0].corner_n, n * 4 * sizeof *s[0].corner_n);
        assert_memory_equal(s[k].mid_n, s[0].mid_n, n * 5 * sizeof *s[0].mid_n);
        assert_memory_equal(s[k].attr, s[0].attr, n * sizeof *s[0].attr);
    }
    for (int k = 0; k < 3; k++)
        scene_free(&s[k]);
}

/* Tree i's shape depends on (seed, detail, i) only: the tree patches of n trees are a sum
 * over trees, so they grow linearly, about 1000 per tree at detail 1. */
static void test_linear_in_trees(void **state)
{
    (void)state;
    forest_counts c50 = count_only(50, 1, 1), c200 = count_only(200, 1, 1);
    double per50 = (double)(c50.bark + c50.leaves) / 50,
           per200 = (double)(c200.bark + c200.leaves) / 200;
    printf("patches per tree: %.1f (50 trees), %.1f (200 trees); terrain %llu, %llu\n", per50,
           per200, (unsigned long long)c50.terrain, (unsigned long long)c200.terrain);
    assert_true(per50 > 800 && per50 < 1400);
    assert_true(fabs(per200 - per50) < 0.08 * per50);
    /* One more tree, more patches. */
    forest_counts c1 = count_only(1, 9, 1), c2 = count_only(2, 9, 1);
    assert_true(c2.bark + c2.leaves > c1.bark + c1.leaves);
    /* detail grows the trees. */
    forest_counts d0 = count_only(20, 1, 0), d2 = count_only(20, 1, 2);
    forest_counts d1 = count_only(20, 1, 1);
    assert_true(d0.bark + d0.leaves < d1.bark + d1.leaves);
    assert_true(d1.bark + d1.leaves < d2.bark + d2.leaves);
}

/* micropolygons_potential = patches * 4^10 (TS_LOD_LIMIT). */
static void test_potential(void **state)
{
    (void)state;
    double per_patch = pow(4.0, TS_LOD_LIMIT);
    forest_counts c100 = count_only(100, 1, 1), c1000 = count_only(1000, 1, 1);
    double p100 = (double)total(&c100) * per_patch, p1000 = (double)total(&c1000) * per_patch;
    printf("100 trees: %llu patches, %.3g micro-polygons; 1000 trees: %llu patches, %.3g\n",
           (unsigned long long)total(&c100), p100, (unsigned long long)total(&c1000), p1000);
    assert_true(p100 >= 1e11);
    assert_true(p1000 >= 1e12);
}

/* Every patch finite, corner normals unit length, sane attributes; boxes finite; the
 * patches around a branch segment share their side edges exactly. */
static void test_patches_valid(void **state)
{
    (void)state;
    ts_scene s;
    forest_counts c;
    /* Placed by a transform: scaled by 2, moved. */
    forest_params fp = {12, 3, 1, 0};
    const double m[16] = {2, 0, 0, 10, 0, 2, 0, -1, 0, 0, 2, 5, 0, 0, 0, 1};
    ts_error e = {0};
    memset(&s, 0, sizeof s);
    if (forest_generate(&fp, m, NULL, &s, &c, &e) != TS_OK) fail_msg("%s", e.msg);
    assert_int_equal(s.patch_count, total(&c));
    for (size_t k = 0; k < (size_t)s.patch_count * 16; k++)
        assert_true(isfinite(s.cp[k].x) && isfinite(s.cp[k].y) && isfinite(s.cp[k].z) &&
                    s.cp[k].w == 1.0f);
    for (size_t k = 0; k < (size_t)s.patch_count * 4; k++) {
        const ts_vec4 *n = &s.corner_n[k];
        assert_true(fabs(sqrt(n->x * n->x + n->y * n->y + n->z * n->z) - 1.0) < 1e-5);
    }
    uint32_t displaced = 0, green = 0;
    for (uint32_t p = 0; p < s.patch_count; p++) {
        const ts_patch_attr *a = &s.attr[p];
        assert_true(a->cs_r >= 0 && a->cs_r <= 1 && a->cs_g >= 0 && a->cs_g <= 1 && a->cs_b >= 0 &&
                    a->cs_b <= 1);
        assert_true(a->xform < s.xform_count);
        if (a->disp_kind != TS_DISP_NONE) {
            displaced++;
            assert_true(a->disp_amplitude > 0 && a->disp_amplitude < 1 && a->disp_octaves >= 1);
        }
        green += a->cs_g > a->cs_r + 0.1f;
        ts_box b = scene_patch_box(&s, p);
        assert_true(isfinite(b.lo_x) && isfinite(b.hi_y) && b.lo_x <= b.hi_x && b.lo_z <= b.hi_z);
    }
    assert_int_equal(displaced, c.bark + c.terrain);
    assert_true(green >= c.leaves);
    /* Bark rings: consecutive bark patches of one segment share their side edge (u = 1 of
     * one is u = 0 of the next), the last closing on the first. Count shared side edges. */
    uint32_t first = (uint32_t)c.terrain, shared = 0;
    for (uint32_t p = first; p + 1 < s.patch_count; p++) {
        int same = 1;
        for (int j = 0; j < 4 && same; j++) {
            const ts_vec4 *x = &s.cp[(size_t)p * 16 + (size_t)j * 4 + 3];
            const ts_vec4 *y = &s.cp[(size_t)(p + 1) * 16 + (size_t)j * 4];
            same = x->x == y->x && x->y == y->y && x->z == y->z;
        }
        shared += same;
    }
    /* Every segment of n >= 4 patches has n - 1 such neighbours in emission order. */
    assert_true(shared >= c.bark * 3 / 4 - 1);
    scene_free(&s);
}

static void test_params(void **state)
{
    (void)state;
    forest_params fp;
    char why[160];
    forest_params_default(&fp);
    assert_true(fp.trees == 100 && fp.seed == 1 && fp.detail == 1);
    assert_int_equal(forest_parse_params("trees=1000 seed=7, detail=2", &fp, why, sizeof why), 0);
    assert_true(fp.trees == 1000 && fp.seed == 7 && fp.detail == 2);
    assert_int_equal(forest_parse_params("", &fp, why, sizeof why), 0);
    static const struct {
        const char *text, *why;
    } bad[] = {
        {"trees=0", "trees must be in [1, 100000], got 0"},
        {"trees=100001", "trees must be in [1, 100000], got 100001"},
        {"seed=-1", "seed must be in [0, 4294967295], got -1"},
        {"detail=4", "detail must be in [0, 3], got 4"},
        {"trees=1x", "trees needs an integer"},
        {"trees", "expected key=value, got \"trees\""},
        {"height=3", "unknown parameter \"height\" (trees, seed, detail)"},
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        assert_int_equal(forest_parse_params(bad[k].text, &fp, why, sizeof why), -1);
        assert_string_equal(why, bad[k].why);
    }
    /* A singular placement is an error. */
    const double flat[16] = {1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    forest_params one = {1, 1, 0, 0};
    ts_scene s;
    memset(&s, 0, sizeof s);
    ts_error e = {0};
    assert_int_equal(forest_generate(&one, flat, NULL, &s, NULL, &e), TS_E_SCENE);
    assert_string_equal(e.msg, "forest: the transformation must be affine and invertible");
    scene_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_deterministic),   cmocka_unit_test(test_linear_in_trees),
        cmocka_unit_test(test_potential),       cmocka_unit_test(test_patches_valid),
        cmocka_unit_test(test_params),          cmocka_unit_test(test_arrays_sized_at_once),
        cmocka_unit_test(test_same_on_threads),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
