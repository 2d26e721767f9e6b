#include "test_support.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *test_source_path(const char *rel)
{
    static char buf[8][4096];
    static int next;
    const char *root = getenv("TESSERA_SOURCE_DIR");
    char *out = buf[next++ % 8];
    snprintf(out, sizeof buf[0], "%s/%s", root && *root ? root : "..", rel);
    return out;
}

const char *test_tessera_binary(void)
{
    const char *b = getenv("TESSERA_BINARY");
    return b && *b ? b : "./tessera";
}

void test_open_device(ts_cl *cl)
{
    ts_device_info *list = NULL;
    ts_error err = {0};
    int n = cl_list_devices(&list, &err);
    free(list);
    if (n == 0) {
        fprintf(stderr, "no OpenCL device: skipping\n");
        exit(TS_TEST_SKIP);
    }
    ts_cl_options opt = {.device_index = -1};
    if (n < 0 || cl_open(cl, &opt, &err) != TS_OK) {
        fprintf(stderr, "cl_open: %s\n%s\n", err.msg, err.detail ? err.detail : "");
        fail_msg("cannot open the OpenCL device: %s", err.msg);
    }
}

const char *test_scratch_dir(void)
{
    static char path[4096];
    const char *tmp = getenv("TMPDIR");
    snprintf(path, sizeof path, "%s/tessera-test-XXXXXX", tmp && *tmp ? tmp : "/tmp");
    if (!mkdtemp(path)) fail_msg("mkdtemp failed");
    return path;
}

float test_uniform(uint32_t *state, float lo, float hi)
{
    *state = *state * 1664525u + 1013904223u;
    return lo + (hi - lo) * (float)(*state >> 8) * (1.0f / 16777216.0f);
}
