/* test_layout.c — the device lays out every shared struct exactly as the host does
 * (STYLE.md 2): kernels/layout.cl writes sizeof/offsetof of each TS_LAYOUT_FIELDS entry. */
#include "test_support.h"
#include "lib/shared_types.h"

#include <stddef.h>

static void test_layout_matches_host(void **state)
{
    ts_device cl;
    test_open_device(&cl);
    ts_error err = {0};
    static const struct {
        const char *name;
        unsigned size, offset;
    } host[] = {
#define HOST_LAYOUT(type, field)                                                                   \
    {#type "." #field, (unsigned)sizeof(type), (unsigned)offsetof(type, field)},
        TS_LAYOUT_FIELDS(HOST_LAYOUT)
#undef HOST_LAYOUT
    };
    enum { N = sizeof host / sizeof *host };
    cl_mem out = dev_buffer_create(&cl, CL_MEM_WRITE_ONLY, 2 * N * sizeof(cl_uint), NULL, &err);
    assert_non_null(out);
    cl_kernel k = dev_kernel_create(&cl, "layout_probe", &err);
    assert_non_null(k);
    assert_int_equal(dev_set_args(k, &err, sizeof out, &out, (size_t)0), TS_OK);
    assert_int_equal(dev_launch(&cl, k, TS_STAGE_camera, 1, 1, &err), TS_OK);
    assert_int_equal(dev_finish(&cl, NULL, &err), TS_OK);
    cl_uint dev[2 * N];
    assert_int_equal(clEnqueueReadBuffer(cl.queue, out, CL_TRUE, 0, sizeof dev, dev, 0, NULL, NULL),
                     CL_SUCCESS);
    for (int i = 0; i < N; ++i) {
        if (dev[2 * i] != host[i].size || dev[2 * i + 1] != host[i].offset)
            fail_msg("%s: device sizeof %u offset %u, host %u %u", host[i].name, dev[2 * i],
                     dev[2 * i + 1], host[i].size, host[i].offset);
    }
    clReleaseKernel(k);
    clReleaseMemObject(out);
    dev_close(&cl);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_layout_matches_host)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
