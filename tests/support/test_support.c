#include "test_support.h"
#include "image/image.h"
#include "scene/rib/rib.h"

#include <unistd.h>

#include <cjson/cJSON.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <sys/wait.h>
#include <stdlib.h>
#include <string.h>

const char *test_source_path(const char *rel)
{
    static char buf[8][4096];
    static int next;
    const char *root = getenv("TESSERA_SOURCE_DIR");
    char *out = buf[next++ % 8];
    if (root && *root) {
        snprintf(out, sizeof buf[0], "%s/%s", root, rel);
        return out;
    }
    static const char *const tries[] = {".", "..", "../.."};
    for (size_t i = 0; i < 3; i++) {
        snprintf(out, sizeof buf[0], "%s/%s", tries[i], rel);
        if (access(out, R_OK) == 0) return out;
    }
    return rel;
}

int test_parse_rib(const char *text, ts_scene *s, ts_error *e)
{
    memset(s, 0, sizeof *s);
    memset(e, 0, sizeof *e);
    return rib_parse_string("t.rib", text, strlen(text), s, 1, e);
}

int test_parse_rib_strict(const char *text, ts_scene *s, ts_error *e)
{
    ts_load_options lo;
    scene_load_options_defaults(&lo);
    lo.quiet = 1;
    lo.strict = 1;
    memset(s, 0, sizeof *s);
    memset(e, 0, sizeof *e);
    return rib_parse_string_with("t.rib", text, strlen(text), &lo, s, e);
}

void test_parse_rib_ok(const char *text, ts_scene *s)
{
    ts_error e;
    if (test_parse_rib(text, s, &e) != TS_OK) fail_msg("unexpected error: %s", e.msg);
}

void test_parse_rib_error(const char *text, const char *msg)
{
    ts_scene s;
    ts_error e;
    assert_int_equal(test_parse_rib(text, &s, &e), TS_E_SCENE);
    if (strcmp(e.msg, msg) != 0) fail_msg("got \"%s\", want \"%s\"", e.msg, msg);
    assert_int_equal(s.patch_count, 0);
}

/* stderr into a temporary file, until capture_end puts it back and reads what was written
 * into out (cap bytes, NUL-ended). */
typedef struct capture {
    FILE *tmp;
    int saved;
} capture;

static capture capture_begin(void)
{
    capture c = {tmpfile(), -1};
    assert_non_null(c.tmp);
    fflush(stderr);
    c.saved = dup(fileno(stderr));
    assert_true(c.saved >= 0);
    assert_true(dup2(fileno(c.tmp), fileno(stderr)) >= 0);
    return c;
}

static void capture_end(capture c, char *out, size_t cap)
{
    fflush(stderr);
    dup2(c.saved, fileno(stderr));
    close(c.saved);
    rewind(c.tmp);
    size_t got = fread(out, 1, cap - 1, c.tmp);
    out[got] = '\0';
    fclose(c.tmp);
}

const char *test_rib_warnings(const char *text, int *rc)
{
    static char out[4096];
    ts_scene s;
    ts_error e;
    memset(&s, 0, sizeof s);
    memset(&e, 0, sizeof e);
    capture c = capture_begin();
    *rc = rib_parse_string("w.rib", text, strlen(text), &s, 0, &e);
    capture_end(c, out, sizeof out);
    scene_free(&s);
    return out;
}

int test_rib_load_capture(const char *path, int strict, ts_scene *s, ts_error *e, char *out,
                          size_t cap)
{
    ts_load_options lo;
    scene_load_options_defaults(&lo);
    lo.strict = strict;
    memset(s, 0, sizeof *s);
    memset(e, 0, sizeof *e);
    capture c = capture_begin();
    int rc = rib_load_with(path, &lo, s, e);
    capture_end(c, out, cap);
    return rc;
}

ts_patch_attr test_rib_one_patch(const char *body)
{
    static char text[20000];
    snprintf(text, sizeof text, "WorldBegin\nColor [1 0 0]\n%s\n" TEST_RIB_QUAD "WorldEnd\n", body);
    ts_scene s;
    test_parse_rib_ok(text, &s);
    assert_int_equal(s.patch_count, 1);
    ts_patch_attr a = s.attr[0];
    scene_free(&s);
    return a;
}

const char *test_rib_body_warnings(const char *body)
{
    static char text[20000];
    snprintf(text, sizeof text, "WorldBegin\n%s\n" TEST_RIB_QUAD "WorldEnd\n", body);
    int rc;
    const char *out = test_rib_warnings(text, &rc);
    assert_int_equal(rc, TS_OK);
    return out;
}

void test_assert_near(double got, double want, double tol)
{
    if (!(fabs(got - want) <= tol)) fail_msg("got %.9g, want %.9g (+- %g)", got, want, tol);
}

void test_assert_cs(const ts_patch_attr *a, double r, double g, double b)
{
    test_assert_near(a->cs_r, r, 1e-6), test_assert_near(a->cs_g, g, 1e-6);
    test_assert_near(a->cs_b, b, 1e-6);
}

const char *test_tessera_binary(void)
{
    const char *b = getenv("TESSERA_BINARY");
    return b && *b ? b : "./tessera";
}

void test_open_device(ts_device *cl)
{
    ts_device_info *list = NULL;
    ts_error err = {0};
    int n = dev_list(&list, &err);
    free(list);
    if (n == 0) {
        fprintf(stderr, "no OpenCL device: skipping\n");
        exit(TS_TEST_SKIP);
    }
    ts_device_options opt = {.device_index = -1};
    if (n < 0 || dev_open(cl, &opt, &err) != TS_OK) {
        fprintf(stderr, "dev_open: %s\n%s\n", err.msg, err.detail ? err.detail : "");
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

int test_run_tessera(const char *dir, const char *fmt, ...)
{
    char args[8192], cmd[16384];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(args, sizeof args, fmt, ap);
    va_end(ap);
    snprintf(cmd, sizeof cmd, "'%s' %s 2>'%s/stderr.txt' >/dev/null", test_tessera_binary(), args,
             dir);
    int st = system(cmd);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

/* Point (s, t) in [-1,1]^2 of cube face f, on the sphere of radius r. */
static void sphere_point(int f, double s, double t, double r, double out[3])
{
    double c[3];
    int axis = f / 2;
    double sign = f % 2 ? -1.0 : 1.0;
    c[axis] = sign;
    c[(axis + 1) % 3] = sign * s;
    c[(axis + 2) % 3] = t;
    double len = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    for (int k = 0; k < 3; ++k)
        out[k] = r * c[k] / len;
}

void test_write_sphere_patches(void *file, int k, double r)
{
    FILE *f = file;
    /* Cubic through samples at 0, 1/3, 2/3, 1 -> Bézier control points. */
    static const double to_bezier[4][4] = {
        {1, 0, 0, 0}, {-5.0 / 6, 3, -1.5, 1.0 / 3}, {1.0 / 3, -1.5, 3, -5.0 / 6}, {0, 0, 0, 1}};
    for (int face = 0; face < 6; ++face)
        for (int b = 0; b < k; ++b)
            for (int a = 0; a < k; ++a) {
                double sample[4][4][3], cp[4][4][3] = {{{0}}};
                for (int j = 0; j < 4; ++j)
                    for (int i = 0; i < 4; ++i) {
                        /* Integer numerators keep shared points bit-identical across faces. */
                        double s = (double)(3 * a + i) / (1.5 * k) - 1.0;
                        double t = (double)(3 * b + j) / (1.5 * k) - 1.0;
                        sphere_point(face, s, t, r, sample[j][i]);
                    }
                for (int j = 0; j < 4; ++j)
                    for (int i = 0; i < 4; ++i)
                        for (int q = 0; q < 4; ++q)
                            for (int p = 0; p < 4; ++p)
                                for (int c = 0; c < 3; ++c)
                                    cp[j][i][c] +=
                                        to_bezier[j][q] * to_bezier[i][p] * sample[q][p][c];
                fprintf(f, "Patch \"bicubic\" \"P\" [");
                for (int j = 0; j < 4; ++j)
                    for (int i = 0; i < 4; ++i)
                        fprintf(f, " %.17g %.17g %.17g", cp[j][i][0], cp[j][i][1], cp[j][i][2]);
                fprintf(f, " ]\n");
            }
}

cJSON *test_read_json(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) fail_msg("%s: cannot open", path);
    static char text[1 << 20];
    size_t n = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    if (n == sizeof text - 1) fail_msg("%s: larger than %zu bytes", path, sizeof text - 1);
    text[n] = '\0';
    cJSON *root = cJSON_Parse(text);
    if (!root) fail_msg("%s: not JSON", path);
    return root;
}

double test_stats_number(const char *json_path, const char *key)
{
    cJSON *root = test_read_json(json_path), *v = root;
    char part[256];
    const char *p = key;
    while (v && *p) {
        size_t len = strcspn(p, ".");
        snprintf(part, sizeof part, "%.*s", (int)len, p);
        v = cJSON_IsArray(v) ? cJSON_GetArrayItem(v, atoi(part))
                             : cJSON_GetObjectItemCaseSensitive(v, part);
        p += len + (p[len] == '.');
    }
    if (!cJSON_IsNumber(v)) fail_msg("%s: no number at %s", json_path, key);
    double d = v->valuedouble;
    cJSON_Delete(root);
    return d;
}

const char *test_path_in(const char *dir, const char *name)
{
    static char buf[4][4400];
    static int next;
    char *p = buf[next++ % 4];
    snprintf(p, sizeof buf[0], "%s/%s", dir, name);
    return p;
}

const char *test_stderr_of(const char *dir)
{
    static char buf[1 << 16];
    FILE *f = fopen(test_path_in(dir, "stderr.txt"), "r");
    size_t n = f ? fread(buf, 1, sizeof buf - 1, f) : 0;
    buf[n] = '\0';
    if (f) fclose(f);
    return buf;
}

void test_expect_in_stderr(const char *dir, const char *needle)
{
    const char *err = test_stderr_of(dir);
    if (!strstr(err, needle)) fail_msg("stderr lacks \"%s\":\n%s", needle, err);
}

void test_tessera_ok(const char *dir, const char *fmt, ...)
{
    char args[8192];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(args, sizeof args, fmt, ap);
    va_end(ap);
    int rc = test_run_tessera(dir, "%s", args);
    if (rc != 0) {
        char cmd[4500];
        snprintf(cmd, sizeof cmd, "cat '%s/stderr.txt' >&2", dir);
        if (system(cmd) != 0) fprintf(stderr, "(no stderr)\n");
        fail_msg("tessera %s exited %d", args, rc);
    }
}

void test_read_image(const char *path, struct ts_image *img)
{
    ts_error err = {0};
    if (image_read(path, img, &err)) fail_msg("%s", err.msg);
}

double test_assert_device_bytes_in_budget(const char *json_path, double pixels, double patches)
{
    double budget = test_stats_number(json_path, "memory_budget_bytes");
    double peak = test_stats_number(json_path, "counters.device_bytes_peak");
    double fixed = test_stats_number(json_path, "counters.device_bytes_fixed");
    double films = 48.0 * pixels, most = films + 2048.0 * patches + budget / 64 + 65536.0;
    if (!(peak <= budget + fixed))
        fail_msg("%s: device_bytes_peak %.0f > memory_budget_bytes %.0f + device_bytes_fixed %.0f "
                 "(by %.0f)",
                 json_path, peak, budget, fixed, peak - budget - fixed);
    if (!(fixed >= films && fixed <= most))
        fail_msg("%s: device_bytes_fixed %.0f outside [%.0f, %.0f] (the films and the scene)",
                 json_path, fixed, films, most);
    return budget + fixed - peak;
}

void test_assert_same_pixels(const char *path_a, const char *path_b)
{
    ts_image a, b;
    test_read_image(path_a, &a);
    test_read_image(path_b, &b);
    assert_int_equal(a.width, b.width);
    assert_int_equal(a.height, b.height);
    assert_int_equal(a.channels, b.channels);
    assert_memory_equal(a.pixels, b.pixels, sizeof(float) * a.width * a.height * a.channels);
    image_free(&a);
    image_free(&b);
}

int test_has_device(void)
{
    ts_device_info *list = NULL;
    ts_error err = {0};
    int n = dev_list(&list, &err);
    free(list);
    if (n <= 0) fprintf(stderr, "skipped: no OpenCL device%s%s\n", err.msg[0] ? ": " : "", err.msg);
    return n > 0;
}

void test_skip(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("skipped: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    skip();
}

void test_parse_scene_with(const char *rel, const char *extra, struct ts_scene *s)
{
    static char path[4096], text[1 << 20];
    snprintf(path, sizeof path, "%s", test_source_path(rel));
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    size_t n = fread(text, 1, sizeof text - 401, f), len = strlen(extra);
    fclose(f);
    assert_true(len <= 400);
    text[n] = '\0';
    char *wb = strstr(text, "WorldBegin\n");
    assert_non_null(wb);
    size_t at = (size_t)(wb - text) + strlen("WorldBegin\n");
    memmove(text + at + len, text + at, n - at + 1);
    memcpy(text + at, extra, len);
    n += len;
    memset(s, 0, sizeof *s);
    ts_error err = {0};
    if (rib_parse_string(path, text, n, s, 1, &err)) fail_msg("%s", err.msg);
}

/* PoCL's CPU device name prefixes and their drivers (PoCL 4 renamed pthread to cpu and
 * basic to cpu-minimal), cpu-minimal- before cpu-, which it starts with. */
static const char *const pocl_names[][2] = {
    {"pthread-", "pthread"}, {"basic-", "basic"}, {"cpu-minimal-", "basic"}, {"cpu-", "pthread"}};

static int pocl_name_index(const char *name)
{
    for (int i = 0; i < (int)(sizeof pocl_names / sizeof *pocl_names); ++i)
        if (strncmp(name, pocl_names[i][0], strlen(pocl_names[i][0])) == 0) return i;
    return -1;
}

const char *test_pocl_driver(const char *name)
{
    int i = pocl_name_index(name);
    return i < 0 ? NULL : pocl_names[i][1];
}

const char *test_pocl_prefix(const char *name)
{
    int i = pocl_name_index(name);
    return i < 0 ? "" : pocl_names[i][0];
}

int test_devices_named(const char *pocl, const char *driver, char *out, size_t cap, int want,
                       char *name, size_t name_cap)
{
    char cmd[4200], line[1024];
    snprintf(cmd, sizeof cmd, "POCL_DEVICES='%s' '%s' devices 2>/dev/null", pocl,
             test_tessera_binary());
    FILE *p = popen(cmd, "r");
    int found = 0, index;
    out[0] = '\0';
    if (name && name_cap) name[0] = '\0';
    while (p && fgets(line, sizeof line, p)) {
        const char *colon = strchr(line, ':');
        if (found == want || sscanf(line, "%d: ", &index) != 1 || !colon) continue;
        const char *d = test_pocl_driver(colon + 2);
        int match =
            driver ? d && strcmp(d, driver) == 0 : strstr(line, "PoCL") && strstr(line, "[CPU");
        if (!match) continue;
        if (name && found == 0) {
            snprintf(name, name_cap, "%s", colon + 2);
            name[strcspn(name, "\n")] = '\0';
        }
        size_t used = strlen(out);
        snprintf(out + used, cap - used, "%s%d", found ? "," : "", index);
        ++found;
    }
    if (p) pclose(p);
    return found;
}

int test_pocl_devices(char *out, size_t cap, int want)
{
    return test_devices_named("pthread pthread", NULL, out, cap, want, NULL, 0);
}

void test_write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    assert_int_equal(fclose(f), 0);
}

/* The Cook-Torrance lobe's albedo at cos(theta_o) = co, written here in double apart from
 * bsdf.h: int f cos_i dw_i with f = D(h) G1(o) G1(i) / (4 cos_o cos_i), GGX D and separable
 * Smith G1 (Walter et al. 2007, eqs. 33 and 34), by the midpoint rule over the half vector h
 * (dw_i = 4 (wo.h) dw_h), with theta_h = atan(alpha t / (1 - t)) for t in (0, 1) so that the
 * nodes follow the lobe's width; phi over [0, pi] twice by symmetry. Four times the nodes
 * each way move it by less than 1e-5; the check allows 1e-3 besides 5 standard errors. */
static double ggx_d_ref(double c, double alpha)
{
    double a2 = alpha * alpha, d = c * c * (a2 - 1.0) + 1.0;
    return c > 0.0 ? a2 / (M_PI * d * d) : 0.0;
}
static double ggx_g1_ref(double c, double alpha)
{
    return c > 0.0 ? 2.0 / (1.0 + sqrt(1.0 + alpha * alpha * (1.0 - c * c) / (c * c))) : 0.0;
}
double test_ggx_albedo(double co, double alpha)
{
    enum { NT = 2048, NP = 256 };
    const double so = sqrt(1.0 - co * co); /* wo = (so, 0, co) */
    double sum = 0.0;
    for (int i = 0; i < NT; i++) {
        double t = (i + 0.5) / NT, x = alpha * t / (1.0 - t);
        double th = atan(x), dth = alpha / ((1.0 - t) * (1.0 - t)) / (1.0 + x * x);
        double ch = cos(th), sh = sin(th), d = ggx_d_ref(ch, alpha);
        for (int j = 0; j < NP; j++) {
            double ph = (j + 0.5) * M_PI / NP;
            double oh = so * sh * cos(ph) + co * ch, ci = 2.0 * oh * ch - co;
            if (oh <= 0.0 || ci <= 0.0) continue;
            /* f cos_i 4 (wo.h) = D G1(o) G1(i) (wo.h) / cos_o */
            sum += d * ggx_g1_ref(co, alpha) * ggx_g1_ref(ci, alpha) * oh / co * sh * dth;
        }
    }
    return sum * (1.0 / NT) * (2.0 * M_PI / NP);
}
