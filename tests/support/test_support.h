/* test_support.h — shared by the tests: where the source tree is, opening the OpenCL device
 * (or skipping with exit code 77 when there is none), scratch directories. */
#ifndef TS_TEST_SUPPORT_H
#define TS_TEST_SUPPORT_H

#include "device/device.h"
#include "lib/shared_types.h"

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

/* Exit code that ctest reports as "skipped" (SKIP_RETURN_CODE in tests/CMakeLists.txt). */
#define TS_TEST_SKIP 77

/* Path of `rel` inside the source tree: $TESSERA_SOURCE_DIR (set by ctest), else the first
 * of ., .., ../.. that holds it. */
const char *test_source_path(const char *rel);
/* Parses RIB text named "t.rib" into a zeroed scene (quiet); returns the loader's code. */
struct ts_scene;
int test_parse_rib(const char *text, struct ts_scene *s, ts_error *e);
/* The same, strict (rib_parse_string_with, as `tessera render --strict`): a missing texture
 * or archive is an error. */
int test_parse_rib_strict(const char *text, struct ts_scene *s, ts_error *e);
/* Parses the source tree's scene file `rel` (under 1 MB) with `extra` (at most 400 bytes)
 * inserted after its WorldBegin line into *s; fails the test on an error. */
void test_parse_scene_with(const char *rel, const char *extra, struct ts_scene *s);
/* The same for text that must load: fails the test with the loader's message otherwise. */
void test_parse_rib_ok(const char *text, struct ts_scene *s);
/* The same for text that must fail: TS_E_SCENE, exactly the message `msg`, no patch kept. */
void test_parse_rib_error(const char *text, const char *msg);

/* Parses RIB text as file "w.rib" into a scratch scene (freed) with stderr captured; sets
 * *rc to rib_parse_string's status and returns what it printed (warnings), a static buffer. */
const char *test_rib_warnings(const char *text, int *rc);
/* Loads the file at path (rib_load_with with the default options, strict or not: programs
 * run) into *s with stderr captured: returns the loader's code, what it printed in out (cap
 * bytes) and its message in *e. The caller frees *s. */
int test_rib_load_capture(const char *path, int strict, struct ts_scene *s, ts_error *e, char *out,
                          size_t cap);
/* A unit bilinear quad (z = 0), the geometry of RIB fragments in the tests. */
#define TEST_RIB_QUAD "Patch \"bilinear\" \"P\" [0 0 0  1 0 0  0 1 0  1 1 0]\n"
/* The attributes of the one patch a quad gets in a world block after `Color [1 0 0]` and
 * `body` (Bxdf, Pattern, ... requests); fails the test on a load error or another count. */
ts_patch_attr test_rib_one_patch(const char *body);
/* What `body` prints (its warnings) in a world block with a quad after it; fails the test
 * unless it loads. A static buffer. */
const char *test_rib_body_warnings(const char *body);
/* Fails the test unless |got - want| <= tol. */
void test_assert_near(double got, double want, double tol);
/* Fails the test unless patch attributes a have the colour (r, g, b) within 1e-6. */
void test_assert_cs(const ts_patch_attr *a, double r, double g, double b);
/* Path of the tessera binary ($TESSERA_BINARY). */
const char *test_tessera_binary(void);
/* Opens the default device with the embedded kernels; exits 77 (skip) when the machine has
 * no OpenCL device at all, fails the test on any other error. */
void test_open_device(ts_device *cl);
/* A fresh directory under $TMPDIR; the path is static storage. */
const char *test_scratch_dir(void);
/* Runs `tessera ARGS` (printf-style) with $TESSERA_CACHE_DIR kept, stdout discarded and
 * stderr saved to dir/stderr.txt; returns the exit status (-1 if it did not exit). */
int test_run_tessera(const char *dir, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Writes a closed sphere of radius r around the origin as RIB patches to f: a cube whose
 * six faces are each split into k x k bicubic patches interpolating the sphere at thirds,
 * so neighbouring patches share their boundary control points exactly. */
void test_write_sphere_patches(void *file, int k, double r);

/* The albedo int f cos_i dw_i of the GGX Cook-Torrance lobe (GGX D, separable Smith G,
 * alpha = roughness, no Fresnel: lib/bsdf.h's model) seen at cos(theta_o) = co, by a
 * quadrature in double written apart from bsdf.h (error below 1e-5). */
double test_ggx_albedo(double co, double alpha);
/* Writes text to the file at path (created or truncated); fails the test if it cannot. */
void test_write_text(const char *path, const char *text);
/* Reads a number from a --stats JSON file: `path` like "counters.rays" or
 * "lod_histogram.3"; fails the test if absent. */
double test_stats_number(const char *json_path, const char *key);

/* What a render's --stats file says of its device buffers (pipeline.h device_bytes_peak):
 * they never held more than the memory budget (memory_budget_bytes: rays, candidates, patch
 * arenas) plus what lies outside it (device_bytes_fixed), and that outside part is the three
 * films of `pixels` pixels (48 bytes a pixel) and the scene's buffers, at most 2 KiB a patch
 * of `patches`, with the texture pool (none in the scenes these tests render) and the leaf
 * utilisation words (1/64 of the candidate buffers, so of the budget), and 64 KiB for the
 * scene's small tables. Fails the test otherwise; returns the slack, budget + fixed - peak. */
double test_assert_device_bytes_in_budget(const char *json_path, double pixels, double patches);

/* Parses the JSON file at path (fails the test if it cannot); cJSON_Delete the result. */
struct cJSON *test_read_json(const char *path);
/* `dir/name` (static storage, four in rotation). */
const char *test_path_in(const char *dir, const char *name);
/* What the last test_run_tessera in dir wrote to stderr (dir/stderr.txt; "" if none), in
 * static storage of 64 KiB (longer text is cut). */
const char *test_stderr_of(const char *dir);
/* Fails the test, printing that stderr, unless it contains needle. */
void test_expect_in_stderr(const char *dir, const char *needle);
/* Runs `tessera ARGS` (printf-style) with test_run_tessera; on a non-zero exit prints its
 * stderr and fails the test. */
void test_tessera_ok(const char *dir, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Reads an image with image_read or fails the test (free it with image_free). */
struct ts_image;
void test_read_image(const char *path, struct ts_image *img);

/* The two image files hold the same pixels bit for bit: same size, same channels, same
 * float values (fails the test otherwise). */
void test_assert_same_pixels(const char *path_a, const char *path_b);
/* The main() of a test that runs `tessera` or opens a device: exits 77 (skipped) when the
 * machine has no OpenCL device, else runs the group. */
#define TEST_RUN_WITH_DEVICE(tests, setup)                                                         \
    (test_has_device() ? cmocka_run_group_tests(tests, setup, NULL) : TS_TEST_SKIP)
int test_has_device(void);
/* Inside a cmocka test: prints "skipped: <why>" on stderr and skips the test (cmocka's
 * skip()), so that a test that cannot run says why instead of passing silently. Where no test
 * of a program can run, main() prints why and returns TS_TEST_SKIP (77) instead. */
void test_skip(const char *fmt, ...);
/* The PoCL driver a device name belongs to: "pthread" for PoCL 3's pthread-... and PoCL 4's
 * and later cpu-... (the driver renamed), "basic" for basic-... and cpu-minimal-...; NULL for
 * any other device. POCL_DEVICES takes the old names in every version. */
const char *test_pocl_driver(const char *name);
/* The name prefix of that driver's devices in the PoCL of device `name` ("pthread-" or
 * "cpu-", "basic-" or "cpu-minimal-"): a substring that names them alone, for the variables
 * that match device names (TESSERA_FAIL_BUILD, TESSERA_FAIL_LAUNCH_DEVICE). */
const char *test_pocl_prefix(const char *name);
/* The indices of up to `want` devices that `tessera devices` lists with POCL_DEVICES=pocl
 * (set it the same way for the renders that use them) of PoCL's driver `driver` ("pthread"
 * or "basic", test_pocl_driver), or, with driver NULL, that are PoCL CPU devices, as "I,J"
 * in out; returns how many. The first one's name goes to name (name_cap bytes) unless NULL. */
int test_devices_named(const char *pocl, const char *driver, char *out, size_t cap, int want,
                       char *name, size_t name_cap);
/* test_devices_named("pthread pthread", NULL, ...): tests of several alike devices skip with
 * fewer than 2 (a machine whose OpenCL is a GPU driver alone). */
int test_pocl_devices(char *out, size_t cap, int want);
/* Deterministic uniform floats in [lo, hi). */
float test_uniform(uint32_t *state, float lo, float hi);

#endif
