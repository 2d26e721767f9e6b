/* test_stages.c — docs/stages.md names the same stages, in the same order, as the
 * TS_STAGES list that drives the enum, the --stats keys and the timing table (STYLE.md 4);
 * docs/profiling.md names every --stats counter of the TS_COUNTERS list. */
#include "test_support.h"
#include "base/stages.h"
#include "base/stats.h"

#include <math.h>

#include <stdio.h>
#include <string.h>

/* The lines of docs/stages.md that `format` (one %63[a-z_] conversion) reads a stage name
 * from name the stages of host/base/stages.h, each once, in order; `what` names them in the
 * message. */
static void check_docs_stage_lines(const char *format, const char *what)
{
    FILE *f = fopen(test_source_path("docs/stages.md"), "r");
    assert_non_null(f);
    char line[4096];
    int next = 0;
    while (fgets(line, sizeof line, f)) {
        char name[64];
        if (sscanf(line, format, name) != 1) continue;
        if (next >= TS_STAGE_COUNT) fail_msg("docs/stages.md: an extra %s, %s", what, name);
        if (strcmp(name, ts_stage_names[next]) != 0)
            fail_msg("docs/stages.md %s %d is %s, host/base/stages.h says %s", what, next + 1, name,
                     ts_stage_names[next]);
        ++next;
    }
    fclose(f);
    assert_int_equal(next, TS_STAGE_COUNT);
}

static void test_docs_name_the_stages_in_order(void **state)
{
    check_docs_stage_lines("| `%63[a-z_]` |", "table row"); /* rows start "| `name` |" */
}

static void test_docs_detail_each_stage_in_order(void **state)
{
    /* Below the one-line table, each stage has a "### `name`" section, in the same order. */
    check_docs_stage_lines("### `%63[a-z_]`", "detail section");
}

static void test_each_stage_has_a_kernel_file_or_host_file(void **state)
{
    /* Device stages live in kernels/<stage>.cl; sort is the host's radix sort. */
    for (int i = 0; i < TS_STAGE_COUNT; ++i) {
        char rel[128];
        if (strcmp(ts_stage_names[i], "sort") == 0)
            snprintf(rel, sizeof rel, "host/pipeline/sort.c");
        else
            snprintf(rel, sizeof rel, "kernels/%s.cl", ts_stage_names[i]);
        FILE *f = fopen(test_source_path(rel), "r");
        if (!f) fail_msg("stage %s has no %s", ts_stage_names[i], rel);
        fclose(f);
    }
}

/* --stats "kernel_seconds" is the union of the devices' busy spans: two devices' overlapping
 * spans count once, a gap not at all, and a span inside another adds nothing. */
static void test_kernel_seconds_are_the_union_of_the_spans(void **state)
{
    ts_stats a = {0}, b = {0}, frame = {0};
    ts_error err = {0};
    /* device a: [1, 2] and [2, 3] touch (merged: one span), then [5, 6] */
    assert_int_equal(stats_add_busy(&a, 1.0, 2.0, &err), TS_OK);
    assert_int_equal(stats_add_busy(&a, 2.0, 3.0, &err), TS_OK);
    assert_int_equal(stats_add_busy(&a, 5.0, 6.0, &err), TS_OK);
    assert_int_equal(a.busy_count, 2);
    assert_true(fabs(stats_kernel_seconds(&a) - 3.0) < 1e-12);
    /* device b: [2.5, 4] overlaps a's first span, [5.2, 5.8] lies inside a's second */
    assert_int_equal(stats_add_busy(&b, 2.5, 4.0, &err), TS_OK);
    assert_int_equal(stats_add_busy(&b, 5.2, 5.8, &err), TS_OK);
    assert_true(fabs(stats_kernel_seconds(&b) - 2.1) < 1e-12);
    assert_int_equal(stats_merge(&frame, &a, &err), TS_OK);
    assert_int_equal(stats_merge(&frame, &b, &err), TS_OK);
    /* [1, 4] and [5, 6] */
    assert_true(fabs(stats_kernel_seconds(&frame) - 4.0) < 1e-12);
    stats_free(&a), stats_free(&b), stats_free(&frame);
    assert_true(stats_kernel_seconds(&frame) == 0.0);
}

static void test_profiling_doc_names_every_counter(void **state)
{
    FILE *f = fopen(test_source_path("docs/profiling.md"), "rb");
    assert_non_null(f);
    static char text[1 << 18];
    size_t n = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    assert_true(n < sizeof text - 1); /* read whole */
    text[n] = 0;
    for (int i = 0; i < TS_COUNTER_COUNT; ++i) {
        char quoted[80];
        snprintf(quoted, sizeof quoted, "`%s`", ts_counter_names[i]);
        if (!strstr(text, quoted))
            fail_msg("docs/profiling.md does not name the --stats counter %s", quoted);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_docs_name_the_stages_in_order),
        cmocka_unit_test(test_docs_detail_each_stage_in_order),
        cmocka_unit_test(test_each_stage_has_a_kernel_file_or_host_file),
        cmocka_unit_test(test_kernel_seconds_are_the_union_of_the_spans),
        cmocka_unit_test(test_profiling_doc_names_every_counter),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
