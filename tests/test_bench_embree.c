/* test_bench_embree.c — smoke test of tools/bench_embree.c at --size tiny (issue 8: every
 * benchmark has one): the teapot at m = 3, 64x36 eye rays and their bounce rays. The JSON
 * has its fields, and they are consistent: Embree traced 2 * 32 * 4^3 triangles; Embree and
 * Tessera's micro-triangle mode agree on hit or miss for all but 0.1% of the rays and, where
 * both hit, on the patch and t (|dt| <= 1e-4 t) for >= 99.9% of them (the tolerance of
 * tests/test_embree.c, whose rays are the same kind; disagreements are rays through shared
 * edges and silhouettes); leaf boxes, which contain their micro-triangles, hit every eye ray
 * the triangles hit; every rate, time and memory figure is positive. Skipped (77) without
 * an OpenCL device. */
#include "test_support.h"

#include <cjson/cJSON.h>
#include <libgen.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

static cJSON *root;

static const cJSON *get(const cJSON *o, const char *path)
{
    char buf[256];
    snprintf(buf, sizeof buf, "%s", path);
    for (char *save = NULL, *key = strtok_r(buf, ".", &save); key;
         key = strtok_r(NULL, ".", &save)) {
        o = cJSON_GetObjectItemCaseSensitive(o, key);
        if (!o) fail_msg("JSON has no %s (at %s)", path, key);
    }
    return o;
}

static double number(const cJSON *o, const char *path)
{
    const cJSON *x = get(o, path);
    if (!cJSON_IsNumber(x)) fail_msg("%s is not a number", path);
    return x->valuedouble;
}

static int run_bench(void **state)
{
    const char *dir = test_scratch_dir();
    char bin[4096], json[4200], cmd[16384];
    snprintf(bin, sizeof bin, "%s", test_tessera_binary());
    snprintf(json, sizeof json, "%s/bench.json", dir);
    /* bench_embree is built next to tessera; scene paths are relative to the source tree. */
    snprintf(cmd, sizeof cmd,
             "cd '%s' && '%s/bench_embree' --size tiny --json '%s' > '%s/stdout.txt'",
             test_source_path("."), dirname(bin), json, dir);
    int st = system(cmd);
    if (!WIFEXITED(st) || WEXITSTATUS(st) != 0) {
        snprintf(cmd, sizeof cmd, "cat '%s/stdout.txt'", dir);
        if (system(cmd) != 0) fprintf(stderr, "(no output)\n");
        fail_msg("bench_embree --size tiny exited %d", WIFEXITED(st) ? WEXITSTATUS(st) : -1);
    }
    root = test_read_json(json);
    *state = root;
    return 0;
}

static int free_json(void **state)
{
    cJSON_Delete(root);
    return 0;
}

static void test_fields(void **state)
{
    const cJSON *r = *state;
    assert_string_equal(get(r, "benchmark")->valuestring, "embree");
    assert_string_equal(get(r, "size")->valuestring, "tiny");
    assert_true(number(r, "runs") >= 1);
    const cJSON *cases = get(r, "cases");
    assert_int_equal(cJSON_GetArraySize(cases), 1);
    const cJSON *c = cJSON_GetArrayItem(cases, 0);
    assert_int_equal((int)number(c, "lod"), 3);
    assert_int_equal((int)number(c, "patches"), 32);
    assert_int_equal((int)number(c, "rays.eye"), 64 * 36);
    assert_int_equal((int)number(c, "embree.triangles"), 2 * 32 * 64);
    assert_int_equal((int)number(c, "micro_triangles"), 2 * 32 * 64);
    static const char *const positive[] = {"embree.eye.rays_per_second_1thread",
                                           "embree.eye.rays_per_second_2threads",
                                           "embree.bounce.rays_per_second_1thread",
                                           "embree.bounce.rays_per_second_2threads",
                                           "embree.build_seconds",
                                           "embree.bytes_after_build",
                                           "embree.bytes_peak",
                                           "embree.peak_rss_bytes",
                                           "embree.bytes_per_triangle",
                                           "tessera.triangles.eye.rays_per_second",
                                           "tessera.triangles.bounce.rays_per_second",
                                           "tessera.triangles.eye.rays_per_second_wall",
                                           "tessera.boxes.eye.rays_per_second",
                                           "tessera.boxes.bounce.rays_per_second",
                                           "tessera.peak_rss_bytes",
                                           "tessera.device_buffer_bytes",
                                           "baseline_peak_rss_bytes",
                                           "ratios.eye.embree_2threads_over_tessera_triangles",
                                           "ratios.bounce.embree_1thread_over_tessera_triangles",
                                           "ratios.frame_tessera_triangles_over_embree",
                                           "ratios.peak_rss_embree_over_tessera",
                                           "largest_scene.embree_max_triangles_24GiB",
                                           "largest_scene.tessera_max_peak_rss_bytes"};
    for (size_t i = 0; i < sizeof positive / sizeof *positive; ++i) {
        const cJSON *x = get(positive[i][0] == 'l' ? r : c, positive[i]);
        if (!cJSON_IsNumber(x) || !(x->valuedouble > 0)) fail_msg("%s is not > 0", positive[i]);
    }
    /* Embree's own allocations are part of its process's resident set. */
    assert_true(number(c, "embree.peak_rss_bytes") >= number(c, "embree.bytes_after_build"));
}

static void test_hits_agree(void **state)
{
    const cJSON *c = cJSON_GetArrayItem(get(*state, "cases"), 0);
    static const char *const kinds[2] = {"eye", "bounce"};
    /* Bounce rays start at the eye rays' hits (Embree's): one per hit, but for a cosine
     * sample exactly in the tangent plane. */
    double eye_hits = number(c, "embree.eye.hits"), bounce = number(c, "rays.bounce");
    assert_true(eye_hits >= 0.2 * 64 * 36); /* the teapot fills a good part of the frame */
    assert_true(bounce <= eye_hits && bounce >= 0.99 * eye_hits);
    for (int k = 0; k < 2; ++k) {
        char key[128];
        snprintf(key, sizeof key, "agreement.%s.rays", kinds[k]);
        double rays = number(c, key);
        snprintf(key, sizeof key, "agreement.%s.hit_miss_mismatches", kinds[k]);
        double mismatches = number(c, key);
        snprintf(key, sizeof key, "agreement.%s.both_hit", kinds[k]);
        double both = number(c, key);
        snprintf(key, sizeof key, "agreement.%s.same_patch_and_t", kinds[k]);
        double same = number(c, key);
        snprintf(key, sizeof key, "embree.%s.hits", kinds[k]);
        double he = number(c, key);
        snprintf(key, sizeof key, "tessera.triangles.%s.hits", kinds[k]);
        double ht = number(c, key);
        snprintf(key, sizeof key, "embree.%s.rays", kinds[k]);
        assert_true(number(c, key) == rays);
        printf("%s: %.0f rays, Embree %.0f hits, Tessera %.0f hits, %.0f hit/miss mismatches, "
               "%.0f of %.0f common hits at the same patch and t\n",
               kinds[k], rays, he, ht, mismatches, same, both);
        assert_true(mismatches <= 0.001 * rays);
        assert_true(fabs(he - ht) <= mismatches); /* each count differs by the mismatches only */
        assert_true(both <= he && both <= ht && both >= he - mismatches);
        assert_true(same >= 0.999 * both);
    }
    assert_true(number(c, "tessera.boxes.eye.hits") >= number(c, "tessera.triangles.eye.hits"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fields),
        cmocka_unit_test(test_hits_agree),
    };
    if (!test_has_device()) return TS_TEST_SKIP;
    return cmocka_run_group_tests(tests, run_bench, free_json);
}
