/* test_bench_traversal.c — smoke test of tools/bench_traversal.c at --size tiny: it runs,
 * the OpenCL and the C traversals agree on every hit record (the JSON counts the records
 * compared and those that differ; the program fails when any does), both rates are positive and the
 * ratios are the rates' ratios. */
#include "test_support.h"

#include <cjson/cJSON.h>
#include <libgen.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static cJSON *run_bench(void)
{
    char bin[4096], cmd[16384];
    snprintf(bin, sizeof bin, "%s", test_tessera_binary());
    const char *json = test_path_in(test_scratch_dir(), "traversal.json");
    snprintf(cmd, sizeof cmd,
             "'%s/bench_traversal' --size tiny --scene '%s' --json '%s' > /dev/null", dirname(bin),
             test_source_path("scene/teapot.rib"), json);
    assert_int_equal(system(cmd), 0);
    cJSON *root = test_read_json(json);
    return root;
}

static double number(const cJSON *o, const char *key)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    if (!cJSON_IsNumber(v)) fail_msg("bench_traversal JSON: no number '%s'", key);
    return v->valuedouble;
}

static void test_tiny(void **state)
{
    cJSON *root = run_bench();
    assert_string_equal(cJSON_GetObjectItem(root, "benchmark")->valuestring, "traversal");
    double pairs = number(root, "pairs");
    assert_true(pairs > 1000);
    const cJSON *modes = cJSON_GetObjectItem(root, "modes");
    assert_int_equal(cJSON_GetArraySize(modes), 2);
    const cJSON *m;
    cJSON_ArrayForEach(m, modes)
    {
        /* Every record of every run (the warm-up and --repeat timed ones) compared, none
         * differing; hits_agree says the same. */
        const cJSON *d = cJSON_GetObjectItem(m, "differing_records");
        assert_non_null(d);
        double ocl = number(d, "opencl_vs_c"), thr = number(d, "c_threads_vs_c");
        if (ocl != 0 || thr != 0)
            fail_msg("%s: %g hit records differ OpenCL vs C, %g C threads vs C",
                     cJSON_GetObjectItem(m, "intersect")->valuestring, ocl, thr);
        assert_true(number(m, "records_compared") == pairs * (number(root, "repeat") + 1));
        assert_true(cJSON_IsTrue(cJSON_GetObjectItem(m, "hits_agree")));
        assert_true(number(m, "hits") > 0 && number(m, "hits") <= pairs);
        double rate[4];
        const char *names[4] = {"opencl", "opencl_wall", "c_1thread", "c_threads"};
        for (int i = 0; i < 4; ++i) {
            const cJSON *r = cJSON_GetObjectItem(m, names[i]);
            assert_non_null(r);
            rate[i] = number(r, "mtraversals_per_second");
            assert_true(rate[i] > 0);
            assert_true(number(r, "min_seconds") <= number(r, "median_seconds"));
        }
        /* Cores really used (CPU seconds per wall second) are measured. */
        assert_true(number(m, "opencl_cores_used") > 0 && number(m, "c_threads_cores_used") > 0);
        assert_true(number(m, "micro_quad_tests") >= number(m, "hits"));
        double r1 = number(m, "ratio_c_1thread_to_opencl"),
               rt = number(m, "ratio_c_threads_to_opencl");
        assert_true(r1 > 0 && rt > 0);
        assert_true(fabs(r1 - rate[2] / rate[0]) <= 1e-9 * r1);
        assert_true(fabs(rt - rate[3] / rate[0]) <= 1e-9 * rt);
    }
    cJSON_Delete(root);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_tiny)};
    return TEST_RUN_WITH_DEVICE(tests, NULL);
}
