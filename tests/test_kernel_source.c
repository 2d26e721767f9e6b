/* test_kernel_source.c — the program text's places map back to kernel files: compilers
 * that ignore #line (NVIDIA reports "<kernel>:LINE:COL") still get kernels/FILE:LINE in
 * the error message. Host only: runs without an OpenCL device. */
#include "test_support.h"
#include "device/kernel_source.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Line number (1-based) of the first line of `text` that contains `needle`, 0 if none. */
static int line_of(const char *text, const char *needle)
{
    int line = 1;
    for (const char *p = text; *p; ++line) {
        size_t len = strcspn(p, "\n");
        const char *h = strstr(p, needle);
        if (h && h < p + len) return line;
        p += len + (p[len] == '\n');
    }
    return 0;
}

static const char *embedded(const char *path)
{
    for (const ts_embedded_file *f = ts_embedded_kernels; f->path; ++f)
        if (strcmp(f->path, path) == 0) return f->text;
    fail_msg("%s is not embedded", path);
    return NULL;
}

static void test_program_lines_map_to_kernel_files(void **state)
{
    ts_error err = {0};
    char *prog = kernel_source_program(NULL, &err);
    assert_non_null(prog);
    /* A line of a stage file and a line of an included header. */
    const struct {
        const char *path, *needle;
    } cases[] = {
        {"film.cl", "__kernel void film"},
        {"lib/intersect.h", "#ifndef TS_INTERSECT_H"},
        {"bottom_level.cl", "void bottom_level_trace(BL_KERNEL_ARGS)"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; ++i) {
        int want = line_of(embedded(cases[i].path), cases[i].needle);
        int physical = line_of(prog, cases[i].needle);
        assert_true(want > 0 && physical > 0);
        char file[256], expect[256];
        int got = kernel_source_locate(prog, physical, file, sizeof file);
        snprintf(expect, sizeof expect, "kernels/%s", cases[i].path);
        assert_string_equal(file, expect);
        assert_int_equal(got, want);
    }
    char file[64];
    assert_int_equal(kernel_source_locate(prog, 1 << 30, file, sizeof file), 0);
    assert_string_equal(file, "");
    free(prog);
}

static void test_nvidia_style_log_is_translated(void **state)
{
    ts_error err = {0};
    char *prog = kernel_source_program(NULL, &err);
    assert_non_null(prog);
    int physical = line_of(prog, "__kernel void film");
    int want = line_of(embedded("film.cl"), "__kernel void film");
    char log[512], expect[512];
    snprintf(log, sizeof log,
             "<kernel>:%d:5: error: use of undeclared identifier 'x'\n"
             "    x = 1;\n<source>:%d:1: note: here\n",
             physical, physical + 1);
    snprintf(expect, sizeof expect,
             "kernels/film.cl:%d:5: error: use of undeclared identifier 'x'\n"
             "    x = 1;\nkernels/film.cl:%d:1: note: here\n",
             want, want + 1);
    char *out = kernel_source_translate_log(prog, log);
    assert_non_null(out);
    assert_string_equal(out, expect);
    free(out);

    /* Logs that already name files (PoCL honours #line), and places outside the text,
     * pass through unchanged. */
    const char *pocl = "kernels/film.cl:15:5: error: use of undeclared identifier 'this'\n"
                       "<kernel>:999999999:1: error: far away\n<kernel>: no number\n";
    out = kernel_source_translate_log(prog, pocl);
    assert_non_null(out);
    assert_string_equal(out, pocl);
    free(out);
    free(prog);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_program_lines_map_to_kernel_files),
        cmocka_unit_test(test_nvidia_style_log_is_translated),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
