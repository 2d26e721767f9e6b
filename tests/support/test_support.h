/* test_support.h — shared by the tests: where the source tree is, opening the OpenCL device
 * (or skipping with exit code 77 when there is none), scratch directories. */
#ifndef TS_TEST_SUPPORT_H
#define TS_TEST_SUPPORT_H

#include "cl_runtime.h"

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

/* Exit code that ctest reports as "skipped" (SKIP_RETURN_CODE in tests/CMakeLists.txt). */
#define TS_TEST_SKIP 77

/* Path of `rel` inside the source tree ($TESSERA_SOURCE_DIR, set by ctest). */
const char *test_source_path(const char *rel);
/* Path of the tessera binary ($TESSERA_BINARY). */
const char *test_tessera_binary(void);
/* Opens the default device with the embedded kernels; exits 77 (skip) when the machine has
 * no OpenCL device at all, fails the test on any other error. */
void test_open_device(ts_cl *cl);
/* A fresh directory under $TMPDIR; the path is static storage. */
const char *test_scratch_dir(void);
/* Deterministic uniform floats in [lo, hi). */
float test_uniform(uint32_t *state, float lo, float hi);

#endif
