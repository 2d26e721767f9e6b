/* test_bench_cache.c — smoke test of tools/bench_cache.c at --size tiny (forest-1): the
 * reordering vs caching counts are consistent: dicings(reorder) <= dicings(cache 10),
 * cache 1000 <= cache 100 <= cache 10, a cache never dices more often than it is looked up
 * nor fewer times than the patches it must hold at least once, micro-polygons follow the
 * dicings, and the wavefront tracer and the one-ray-at-a-time tracer hit the same rays; for
 * the eye rays alone and, with --paths, for every ray of the paths. */
#include "test_support.h"

#include <cjson/cJSON.h>
#include <libgen.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static double number(const cJSON *o, const char *key)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    if (!cJSON_IsNumber(v)) fail_msg("bench_cache JSON: no number '%s'", key);
    return v->valuedouble;
}

/* Runs bench_cache at --size tiny on `scene` with `extra` arguments; its JSON. */
static cJSON *run_tiny_on(const char *scene, const char *extra, const char *name)
{
    char bin[4096], cmd[16384];
    snprintf(bin, sizeof bin, "%s", test_tessera_binary());
    const char *json = test_path_in(test_scratch_dir(), name);
    snprintf(cmd, sizeof cmd,
             "'%s/bench_cache' --size tiny %s --scene '%s' --json '%s' > /dev/null 2>&1",
             dirname(bin), extra, test_source_path(scene), json);
    assert_int_equal(system(cmd), 0); /* the program's own checks passed */
    cJSON *root = test_read_json(json);
    assert_string_equal(cJSON_GetObjectItem(root, "benchmark")->valuestring, "cache");
    assert_true(number(root, "spp") >= 1);
    return root;
}

static cJSON *run_tiny(const char *extra, const char *name)
{
    return run_tiny_on("scene/forest-1.rib", extra, name);
}

/* The counts of one scene's run that hold for eye rays and for whole paths alike. */
static void check_counts(const cJSON *s)
{
    const cJSON *ro = cJSON_GetObjectItem(s, "reorder"), *ca = cJSON_GetObjectItem(s, "cache");
    assert_int_equal(cJSON_GetArraySize(ca), 3);
    double d[3], mp[3], lookups = number(s, "cache_lookups");
    const int entries[3] = {10, 100, 1000};
    for (int i = 0; i < 3; ++i) {
        const cJSON *c = cJSON_GetArrayItem(ca, i);
        assert_int_equal((int)number(c, "entries"), entries[i]);
        d[i] = number(c, "dicings"), mp[i] = number(c, "micropolygons");
        assert_true(d[i] > 0 && d[i] <= lookups);
        assert_true(mp[i] >= d[i]); /* at least one micro-quad per dicing */
    }
    assert_true(d[2] <= d[1] && d[1] <= d[0]);
    assert_true(mp[2] <= mp[1] && mp[1] <= mp[0]);
    double reorder = number(ro, "dicings");
    assert_true(reorder > 0 && reorder <= d[0]);
    assert_true(number(ro, "micropolygons") >= reorder);
    assert_true(fabs(number(s, "ratio_reorder_to_cache_1000") - reorder / d[2]) <=
                1e-9 * reorder / d[2]);
    /* Both tracers find the closest hit among the same micro-geometry. */
    double hits = number(ro, "hits");
    assert_true(hits > 0.05 * number(s, "rays"));
    assert_true(number(s, "cache_hits") == hits);
    assert_true(number(s, "hits_compared") <= hits);
    assert_true(number(s, "hit_t_equal") >= 0.99 * number(s, "hits_compared"));
    /* The program's own verdicts, as reported. */
    const cJSON *ck = cJSON_GetObjectItem(s, "checks");
    assert_true(cJSON_IsTrue(cJSON_GetObjectItem(ck, "reorder_le_cache_10")));
    assert_true(cJSON_IsTrue(cJSON_GetObjectItem(ck, "cache_1000_le_100_le_10")));
    assert_true(cJSON_IsTrue(cJSON_GetObjectItem(ck, "same_rays_hit")));
}

static void test_tiny(void **state)
{
    (void)state;
    cJSON *root = run_tiny("", "cache.json");
    assert_string_equal(cJSON_GetObjectItem(root, "rays")->valuestring, "eye");
    const cJSON *scenes = cJSON_GetObjectItem(root, "scenes");
    assert_int_equal(cJSON_GetArraySize(scenes), 1);
    const cJSON *s = cJSON_GetArrayItem(scenes, 0);
    assert_true(number(s, "rays") ==
                number(root, "width") * number(root, "height") * number(root, "spp"));
    assert_true(number(s, "eye_rays") == number(s, "rays"));
    assert_true(number(s, "hits_compared") == number(cJSON_GetObjectItem(s, "reorder"), "hits"));
    assert_null(cJSON_GetObjectItem(cJSON_GetObjectItem(s, "reorder"), "lazy")); /* no --lazy */
    check_counts(s);
    cJSON_Delete(root);
}

/* --paths: every ray of the paths `tessera render` traces (Hanika's Table 2 counts path
 * tracing's rays), each one's answer the same in both tracers: a shadow ray occluded or not,
 * the others' hits at the same distances. */
static void test_tiny_paths(void **state)
{
    (void)state;
    cJSON *root = run_tiny("--paths", "cache_paths.json");
    assert_string_equal(cJSON_GetObjectItem(root, "rays")->valuestring, "paths");
    const cJSON *s = cJSON_GetArrayItem(cJSON_GetObjectItem(root, "scenes"), 0);
    double eye = number(s, "eye_rays"), bsdf = number(s, "bsdf_rays"),
           shadow = number(s, "shadow_rays"), rays = number(s, "rays");
    assert_true(eye == number(root, "width") * number(root, "height") * number(root, "spp"));
    assert_true(bsdf > 0.1 * eye && shadow > 0.1 * eye); /* the sun lights the tree */
    assert_true(rays == eye + bsdf + shadow);
    assert_true(number(s, "answers_equal") == rays);
    check_counts(s);
    /* The eye rays are among them, with the same hits: the patches reached are a superset. */
    cJSON *eye_root = run_tiny("", "cache_eye.json");
    const cJSON *e = cJSON_GetArrayItem(cJSON_GetObjectItem(eye_root, "scenes"), 0);
    assert_true(number(s, "patches_reached") > number(e, "patches_reached"));
    cJSON_Delete(eye_root);
    /* As the waves list them, pass by pass (a bounce of a wave): each pass's patches once,
     * summed, lie above the patches reached at all (the bounces reach patches the eye rays
     * reached) and at most the lookups; other orders do not count them. */
    assert_null(cJSON_GetObjectItem(s, "patches_reached_per_pass"));
    cJSON *wave_root = run_tiny("--paths --order wave", "cache_wave.json");
    const cJSON *w = cJSON_GetArrayItem(cJSON_GetObjectItem(wave_root, "scenes"), 0);
    double per_pass = number(w, "patches_reached_per_pass");
    assert_true(number(w, "patches_reached") == number(s, "patches_reached"));
    assert_true(per_pass > number(w, "patches_reached"));
    assert_true(per_pass <= number(w, "cache_lookups"));
    /* and their micro-quads, 4^m a patch at its frame level m <= max_lod */
    double mp = number(w, "micropolygons_reached_per_pass");
    assert_true(mp >= per_pass && mp <= per_pass * pow(4.0, number(w, "max_lod")));
    assert_null(cJSON_GetObjectItem(s, "micropolygons_reached_per_pass"));
    cJSON_Delete(wave_root);
    cJSON_Delete(root);
}

/* --lazy: every iteration replayed as a trace that dices a patch only when one of its rays
 * still needs it. forest-100 at 160x64 with --memory 24 takes several batches an iteration:
 * the replay sees the patches the reordering diced, and dicing lazily near first leaves a
 * good part of them (a lazy trace in the batches' own order, some). */
static void test_tiny_lazy(void **state)
{
    (void)state;
    cJSON *root = run_tiny_on("scene/forest-100.rib", "--paths --lazy --memory 24", "lazy.json");
    const cJSON *s = cJSON_GetArrayItem(cJSON_GetObjectItem(root, "scenes"), 0);
    const cJSON *ro = cJSON_GetObjectItem(s, "reorder"), *lz = cJSON_GetObjectItem(ro, "lazy");
    double diced = number(lz, "diced"), batch = number(lz, "batch_order"),
           near = number(lz, "near_first");
    assert_true(diced == number(ro, "dicings"));
    assert_true(batch > 0 && batch < diced);
    assert_true(near > 0 && near < 0.9 * diced);
    /* in micro-quads: the reordering's own count, and less near first */
    double mp = number(lz, "diced_micropolygons");
    assert_true(mp == number(ro, "micropolygons"));
    assert_true(number(lz, "near_first_micropolygons") < mp);
    assert_true(number(lz, "batch_order_micropolygons") <= mp);
    cJSON_Delete(root);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_tiny),
                                       cmocka_unit_test(test_tiny_paths),
                                       cmocka_unit_test(test_tiny_lazy)};
    return TEST_RUN_WITH_DEVICE(tests, NULL);
}
