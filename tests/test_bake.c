/* test_bake.c — `tessera bake` (issue 18, docs/bake.md) against results known in closed
 * form, with tolerances from the ray count:
 *   - an unoccluded point on a plane: c_lm = 2 pi I_l Y_lm(n), I_l = the integral of P_l over
 *     [0, 1] (the hemisphere's projection), for every point and coefficient; with --cosine
 *     the clamped cosine's 2 pi J_l Y_lm(n); with --sphere the same as the hemisphere;
 *   - points under a large occluding disk (radius = height: the cone of 45 degrees about the
 *     normal is blocked): the zonal closed form;
 *   - points in a V-groove of two finite planes: the exact visibility (a ray from the
 *     offset origin misses the other plane) integrated by quadrature;
 * each within 5 sigma of the Monte-Carlo error of independent uniform samples (the variance
 * of the estimator computed by quadrature; the Sobol points do better), per point and for
 * the mean over the points. Also: the file's layout and metadata, the same bits whatever
 * --memory and the thread count, --resume after SIGTERM giving the bits of an
 * uninterrupted bake, --stats, and the errors a user meets. */
#include "test_support.h"
#include "image/image.h"
#include "lib/sh.h"

#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

static char dir[4096];

static int setup(void **state)
{
    snprintf(dir, sizeof dir, "%s", test_scratch_dir());
    return 0;
}

static const char *path(const char *name)
{
    return test_path_in(dir, name);
}

/* A scene seen by a camera at z = -5 looking along +z (RIB camera space), 32x32. */
static void write_scene(const char *name, const char *world)
{
    FILE *f = fopen(path(name), "w");
    assert_non_null(f);
    fprintf(f,
            "Format 32 32 1\nProjection \"perspective\" \"fov\" [40]\nTranslate 0 0 5\n"
            "WorldBegin\n%sWorldEnd\n",
            world);
    fclose(f);
}

static void bake(const char *scene, const char *out, const char *args)
{
    test_tessera_ok(dir, "bake '%s' -o '%s' --quiet %s", path(scene), path(out), args);
}

static int meta_int(const char *name, const char *key)
{
    int v = -1;
    ts_error err = {0};
    if (image_read_meta_int(path(name), key, &v, &err)) fail_msg("%s", err.msg);
    return v;
}

/* A bake file read back: the channels by name. */
typedef struct baked {
    ts_image img;
    int bands, nc;
    int sh[16], patch, u, v, px, py, pz, nx, ny, nz;
} baked;

static int channel(const ts_image *img, const char *name)
{
    for (int c = 0; c < img->channels; ++c)
        if (strcmp(img->channel_names[c], name) == 0) return c;
    fail_msg("no channel %s", name);
    return -1;
}

static void load(const char *name, baked *b)
{
    test_read_image(path(name), &b->img);
    b->bands = meta_int(name, "tessera:bake_bands");
    b->nc = b->bands * b->bands;
    for (int c = 0; c < b->nc; ++c) {
        char n[16];
        snprintf(n, sizeof n, "sh%d", c);
        b->sh[c] = channel(&b->img, n);
    }
    b->patch = channel(&b->img, "patch"), b->u = channel(&b->img, "u");
    b->v = channel(&b->img, "v");
    b->px = channel(&b->img, "P.x"), b->py = channel(&b->img, "P.y");
    b->pz = channel(&b->img, "P.z");
    b->nx = channel(&b->img, "N.x"), b->ny = channel(&b->img, "N.y");
    b->nz = channel(&b->img, "N.z");
}

static const float *pixel(const baked *b, int i)
{
    return &b->img.pixels[(size_t)i * b->img.channels];
}

/* --- references by quadrature ------------------------------------------------------- */

/* Visibility from origin o towards unit w (1 = escapes), for directions above the surface. */
typedef int (*visibility_fn)(const double o[3], const double w[3], const void *ctx);

/* The estimator's mean (c) and the variance of one sample (var) for each coefficient, at a
 * point with normal n whose rays start at o: V times (cosine: n.w), sampled uniformly over
 * the hemisphere, cosine-weighted (cosine) or uniformly over the sphere (sphere). Midpoint
 * rule on an equal-area grid of nz x 2 nz cells over the sphere. */
static void reference(const double o[3], const double n[3], int cosine, int sphere,
                      visibility_fn vis, const void *ctx, int nz, double c[16], double var[16])
{
    double second[16] = {0};
    for (int k = 0; k < 16; ++k)
        c[k] = 0.0;
    int nphi = 2 * nz;
    double dw = 4.0 * M_PI / ((double)nz * nphi);
    for (int i = 0; i < nz; ++i)
        for (int j = 0; j < nphi; ++j) {
            double z = -1.0 + 2.0 * (i + 0.5) / nz, phi = 2.0 * M_PI * (j + 0.5) / nphi;
            double s = sqrt(1.0 - z * z), w[3] = {s * cos(phi), s * sin(phi), z};
            double cn = n[0] * w[0] + n[1] * w[1] + n[2] * w[2];
            if (cn <= 0.0) continue;
            if (vis && !vis(o, w, ctx)) continue;
            double f = cosine ? cn : 1.0;
            /* Density of the direction: 1 / (4 pi), cos / pi, or 1 / (2 pi). */
            double q = sphere ? 1.0 / (4.0 * M_PI) : cosine ? cn / M_PI : 1.0 / (2.0 * M_PI);
            float y[16];
            sh_eval((float)w[0], (float)w[1], (float)w[2], 4u, y);
            for (int k = 0; k < 16; ++k) {
                c[k] += f * y[k] * dw;
                second[k] += f * f * y[k] * y[k] / q * dw;
            }
        }
    for (int k = 0; k < 16; ++k)
        var[k] = fmax(second[k] - c[k] * c[k], 0.0);
}

/* Compares the baked coefficients of `count` points with their references (want[p][k],
 * per-sample variance var[p][k], rays per point): each within 5 sigma (+ rounding), and
 * their mean within 5 sigma of the mean. */
static void compare(const char *what, int count, int nc, const double (*got)[16],
                    const double (*want)[16], const double (*var)[16], int rays, double slack)
{
    for (int k = 0; k < nc; ++k) {
        double sum_err = 0.0, sum_var = 0.0;
        for (int p = 0; p < count; ++p) {
            double sigma = sqrt(var[p][k] / rays), err = got[p][k] - want[p][k];
            if (fabs(err) > 5.0 * sigma + slack)
                fail_msg("%s: point %d, coefficient %d: %.6f, expected %.6f +- %.6f", what, p, k,
                         got[p][k], want[p][k], 5.0 * sigma + slack);
            sum_err += err;
            sum_var += var[p][k] / rays;
        }
        double mean_err = sum_err / count, mean_sigma = sqrt(sum_var) / count;
        if (fabs(mean_err) > 5.0 * mean_sigma + slack)
            fail_msg("%s: coefficient %d: mean error %.6f over %d points, more than 5 sigma "
                     "(%.6f)",
                     what, k, mean_err, count, 5.0 * mean_sigma + slack);
    }
}

/* --- an unoccluded plane ------------------------------------------------------------- */

/* The integrals of P_l and x P_l over [0, 1], l = 0..3. */
static const double legendre_half[4] = {1.0, 0.5, 0.0, -0.125};
static const double legendre_half_x[4] = {0.5, 1.0 / 3.0, 0.125, 0.0};

static const char *const plane_world =
    "Patch \"bilinear\" \"P\" [-1 -1 0  1 -1 0  -1 1 0  1 1 0]\n";

/* Bakes the plane with args and checks every point against the closed form (the cosine's
 * when cosine), with the variance of the sampling scheme. */
static void check_plane(const char *args, int rays, int cosine, int sphere)
{
    write_scene("plane.rib", plane_world);
    bake("plane.rib", "plane.exr", args);
    baked b;
    load("plane.exr", &b);
    assert_int_equal(b.bands, 4);
    int count = 0;
    double(*got)[16] = calloc(4096, sizeof *got), (*want)[16] = calloc(4096, sizeof *want),
    (*var)[16] = calloc(4096, sizeof *var);
    assert_true(got && want && var);
    double ref_c[16], ref_var[16];
    const double up[3] = {0, 0, -1}, origin[3] = {0, 0, 0};
    reference(origin, up, cosine, sphere, NULL, NULL, 400, ref_c, ref_var);
    for (int i = 0; i < b.img.width * b.img.height; ++i) {
        const float *px = pixel(&b, i);
        if (isnan(px[b.patch])) continue;
        /* The camera at z = -5 sees the plane's -z side: the points' normal. */
        assert_float_equal(px[b.nz], -1.0, 1e-6);
        assert_float_equal(px[b.pz], 0.0, 1e-6);
        /* P: the vertex, a quarter micro-quad (m = 3) inside the patch on its boundary. */
        double q = 0.25 / 8.0;
        assert_float_equal(px[b.px], -1.0 + 2.0 * fmin(fmax(px[b.u], q), 1.0 - q), 1e-6);
        assert_float_equal(px[b.py], -1.0 + 2.0 * fmin(fmax(px[b.v], q), 1.0 - q), 1e-6);
        float y[16];
        sh_eval(0.0f, 0.0f, -1.0f, 4u, y);
        for (int k = 0; k < 16; ++k) {
            int l = k < 1 ? 0 : k < 4 ? 1 : k < 9 ? 2 : 3;
            got[count][k] = px[b.sh[k]];
            want[count][k] = 2.0 * M_PI * (cosine ? legendre_half_x : legendre_half)[l] * y[k];
            var[count][k] = ref_var[k];
            /* The quadrature agrees with the closed form. */
            if (fabs(ref_c[k] - want[count][k]) > 2e-3)
                fail_msg("quadrature %g vs closed form %g (coefficient %d)", ref_c[k],
                         want[count][k], k);
        }
        ++count;
    }
    assert_int_equal(count, 9 * 9);
    compare(args, count, 16, (const double(*)[16])got, (const double(*)[16])want,
            (const double(*)[16])var, rays, 1e-4);
    free(got), free(want), free(var);
    image_free(&b.img);
}

static void test_unoccluded_plane(void **state)
{
    check_plane("--lod 3 --bands 4 --rays 256", 256, 0, 0);
    /* c_00 of an unoccluded point is sqrt(pi) exactly (every sample equals it). */
    baked b;
    load("plane.exr", &b);
    for (int i = 0; i < b.img.width * b.img.height; ++i)
        if (!isnan(pixel(&b, i)[b.patch]))
            assert_float_equal(pixel(&b, i)[b.sh[0]], sqrt(M_PI), 2e-5);
    image_free(&b.img);
}

static void test_unoccluded_plane_cosine_and_sphere(void **state)
{
    check_plane("--lod 3 --bands 4 --rays 256 --cosine", 256, 1, 0);
    check_plane("--lod 3 --bands 4 --rays 512 --sphere", 512, 0, 1);
    check_plane("--lod 3 --bands 4 --rays 512 --sphere --cosine", 512, 1, 1);
}

/* --- occluders: a disk, a V-groove ------------------------------------------------------ */

/* A disk of radius r in the plane z = z0, centred on the z axis. */
typedef struct disk {
    double z0, r;
} disk;

static int disk_visible(const double o[3], const double w[3], const void *ctx)
{
    const disk *d = ctx;
    if (w[2] == 0.0) return 1;
    double t = (d->z0 - o[2]) / w[2];
    if (t <= 0.0) return 1;
    double x = o[0] + t * w[0], y = o[1] + t * w[1];
    return x * x + y * y > d->r * d->r;
}

/* The baked coefficients of every point of patch `patch` in b: got[], their normals and ray
 * origins (P + eps N, eps given), up to max points; returns the count. */
static int points_of(const baked *b, int patch, double eps, double (*got)[16], double (*origin)[3],
                     double (*normal)[3], int max)
{
    int count = 0;
    for (int i = 0; i < b->img.width * b->img.height && count < max; ++i) {
        const float *px = pixel(b, i);
        if (isnan(px[b->patch]) || px[b->patch] != (float)patch) continue;
        double n[3] = {px[b->nx], px[b->ny], px[b->nz]};
        for (int c = 0; c < 3; ++c) {
            normal[count][c] = n[c];
            origin[count][c] = (c == 0 ? px[b->px] : c == 1 ? px[b->py] : px[b->pz]) + eps * n[c];
        }
        for (int k = 0; k < b->nc; ++k)
            got[count][k] = px[b->sh[k]];
        ++count;
    }
    return count;
}

static void test_occluding_disk(void **state)
{
    /* A plane of half-size 0.01 at z = 0 and a disk of radius 100 at z = -100 (towards the
     * camera): every point sees the disk across the cone of 45 degrees about its normal -z
     * (to 1e-4 of the angle), the rays' offset 0.02 / 2^4 is negligible. Closed form (zonal):
     * c_lm = 2 pi Y_lm(n) times the integral of P_l over [0, cos 45). */
    enum { RAYS = 1024, MAX = 17 * 17 };
    write_scene("disk.rib", "Patch \"bilinear\" \"P\" [-0.01 -0.01 0  0.01 -0.01 0  -0.01 0.01 0  "
                            "0.01 0.01 0]\nDisk -100 100 360\n");
    bake("disk.rib", "disk.exr", "--lod 4 --bands 4 --rays 1024 --intersect triangles");
    baked b;
    load("disk.exr", &b);
    double a = cos(M_PI / 4.0);
    double ip[4] = {a, a * a / 2.0, (a * a * a - a) / 2.0,
                    (5.0 * a * a * a * a / 4.0 - 3.0 * a * a / 2.0) / 2.0};
    double c[16], var[16];
    const double n[3] = {0, 0, -1}, o[3] = {0, 0, 0};
    const disk d = {-100.0, 100.0};
    reference(o, n, 0, 0, disk_visible, &d, 1000, c, var);
    float y[16];
    sh_eval(0.0f, 0.0f, -1.0f, 4u, y);
    double(*got)[16] = calloc(MAX, sizeof *got), (*want)[16] = calloc(MAX, sizeof *want),
    (*vars)[16] = calloc(MAX, sizeof *vars), (*org)[3] = calloc(MAX, sizeof *org),
    (*nrm)[3] = calloc(MAX, sizeof *nrm);
    int count = points_of(&b, 0, 0.0, got, org, nrm, MAX);
    assert_int_equal(count, MAX);
    for (int p = 0; p < count; ++p)
        for (int k = 0; k < 16; ++k) {
            int l = k < 1 ? 0 : k < 4 ? 1 : k < 9 ? 2 : 3;
            want[p][k] = 2.0 * M_PI * ip[l] * y[k];
            vars[p][k] = var[k];
            if (p == 0 && fabs(c[k] - want[p][k]) > 2e-3)
                fail_msg("disk: quadrature %g vs closed form %g (coefficient %d)", c[k], want[p][k],
                         k);
        }
    /* The disk is bicubic (radial error 2.7e-4) diced at m = 4 (chords of 1/64 turn): its
     * radius is short by about 1e-3 of itself, which moves a coefficient by < 1e-3. */
    compare("disk", count, 16, (const double(*)[16])got, (const double(*)[16])want,
            (const double(*)[16])vars, RAYS, 1e-3);
    free(got), free(want), free(vars), free(org), free(nrm);
    image_free(&b.img);
}

/* Plane B of the groove: x + z = 0, x in [0, 2], y in [-2, 2]. */
static int groove_visible(const double o[3], const double w[3], const void *ctx)
{
    (void)ctx;
    double den = w[0] + w[2];
    if (den == 0.0) return 1;
    double t = -(o[0] + o[2]) / den;
    if (t <= 0.0) return 1;
    double x = o[0] + t * w[0], y = o[1] + t * w[1];
    return !(x >= 0.0 && x <= 2.0 && fabs(y) <= 2.0);
}

static void test_v_groove(void **state)
{
    /* A 90-degree groove opening towards the camera: plane A (patch 0) z = x for x in
     * [-2, 0], plane B z = -x for x in [0, 2], y in [-2, 2]. The points of A look into the
     * groove (normal (1, 0, -1) / sqrt 2); a ray from A's point plus eps n (eps = the longest
     * side of A's box, 4, over 2^4) is blocked exactly when it crosses B. The reference is
     * that visibility integrated by quadrature, point by point (every other point). */
    enum { RAYS = 256, MAX = 17 * 17 };
    write_scene("groove.rib", "Patch \"bilinear\" \"P\" [-2 -2 -2  0 -2 0  -2 2 -2  0 2 0]\n"
                              "Patch \"bilinear\" \"P\" [0 -2 0  2 -2 -2  0 2 0  2 2 -2]\n");
    bake("groove.rib", "groove.exr", "--lod 4 --bands 4 --rays 256 --intersect triangles");
    baked b;
    load("groove.exr", &b);
    double(*all)[16] = calloc(MAX, sizeof *all), (*org)[3] = calloc(MAX, sizeof *org),
    (*nrm)[3] = calloc(MAX, sizeof *nrm);
    int count = points_of(&b, 0, 4.0 / 16.0, all, org, nrm, MAX);
    assert_int_equal(count, MAX);
    double(*got)[16] = calloc(MAX, sizeof *got), (*want)[16] = calloc(MAX, sizeof *want),
    (*var)[16] = calloc(MAX, sizeof *var);
    int used = 0;
    double blocked = 0.0;
    for (int p = 0; p < count; p += 2) {
        /* The apex's points move onto B's plane (n is parallel to B): whether a ray from
         * there meets B at t = 0 is rounding, not geometry. */
        if (fabs(org[p][0] + org[p][2]) < 1e-4) continue;
        assert_float_equal(nrm[p][0], sqrt(0.5), 1e-5);
        assert_float_equal(nrm[p][2], -sqrt(0.5), 1e-5);
        reference(org[p], nrm[p], 0, 0, groove_visible, NULL, 200, want[used], var[used]);
        memcpy(got[used], all[p], sizeof got[used]);
        blocked += sqrt(M_PI) - want[used][0];
        ++used;
    }
    assert_true(blocked / used > 0.2); /* the groove does occlude */
    compare("groove", used, 16, (const double(*)[16])got, (const double(*)[16])want,
            (const double(*)[16])var, RAYS, 4e-3);
    free(all), free(org), free(nrm), free(got), free(want), free(var);
    image_free(&b.img);
}

/* --- the file -------------------------------------------------------------------------- */

static void test_layout_and_metadata(void **state)
{
    /* The teapot at the footprint of a 32x18 image: patches at several m. */
    test_tessera_ok(dir, "bake '%s' -o '%s' --quiet --res 32x18 --rays 16 --stats '%s'",
                    test_source_path("scene/teapot.rib"), path("layout.exr"), path("layout.json"));
    baked b;
    load("layout.exr", &b);
    assert_int_equal(b.bands, 3);
    assert_int_equal(b.img.channels, 9 + 9);
    int patches = meta_int("layout.exr", "tessera:bake_patches");
    assert_int_equal(patches, 32);
    int *count = calloc((size_t)patches, sizeof *count), lods[11] = {0};
    unsigned char *seen = calloc((size_t)patches << 20, 1); /* (patch, i, j) at m <= 10 */
    assert_true(count && seen);
    for (int i = 0; i < b.img.width * b.img.height; ++i) {
        const float *px = pixel(&b, i);
        if (isnan(px[b.patch])) { /* no point: every channel NaN */
            for (int c = 0; c < b.img.channels; ++c)
                assert_true(isnan(px[c]));
            continue;
        }
        int p = (int)px[b.patch];
        assert_true(p >= 0 && p < patches && (float)p == px[b.patch]);
        count[p]++;
        for (int c = 0; c < b.img.channels; ++c)
            assert_true(isfinite(px[c]));
        /* (u, v) on the 2^-10 grid, each point once. */
        double fu = px[b.u] * 1024.0, fv = px[b.v] * 1024.0;
        assert_true(fu == floor(fu) && fv == floor(fv) && fu <= 1024 && fv <= 1024);
        size_t key = ((size_t)p << 20) | ((size_t)fv << 10 | (size_t)fu);
        if (fu < 1024 && fv < 1024) {
            assert_int_equal(seen[key], 0);
            seen[key] = 1;
        }
        /* A unit normal. */
        double nn = px[b.nx] * px[b.nx] + px[b.ny] * px[b.ny] + px[b.nz] * px[b.nz];
        assert_float_equal(nn, 1.0, 1e-5);
    }
    long total = 0;
    for (int p = 0; p < patches; ++p) {
        int m = 0;
        while (m <= 10 && ((1 << m) + 1) * ((1 << m) + 1) != count[p])
            ++m;
        if (m > 10) fail_msg("patch %d has %d points, not a (2^m+1)^2 grid", p, count[p]);
        lods[m]++;
        total += count[p];
    }
    int levels = 0;
    for (int m = 0; m <= 10; ++m)
        levels += lods[m] > 0;
    assert_true(levels >= 2); /* the footprint gives patches different m */
    assert_int_equal(meta_int("layout.exr", "tessera:bake_points"), (int)total);
    assert_int_equal(meta_int("layout.exr", "tessera:bake_done"), (int)total);
    assert_int_equal(meta_int("layout.exr", "tessera:bake_rays"), 16);
    assert_int_equal(meta_int("layout.exr", "tessera:bake_cosine"), 0);
    char text[1024];
    ts_error err = {0};
    assert_int_equal(image_read_meta_string(path("layout.exr"), "tessera:sh_convention", text,
                                            sizeof text, &err),
                     0);
    assert_non_null(strstr(text, "Y_00 = 1/(2 sqrt(pi))"));
    /* --stats: points, rays, points per second. */
    assert_true(test_stats_number(path("layout.json"), "bake.points") == (double)total);
    assert_true(test_stats_number(path("layout.json"), "counters.rays") == 16.0 * total);
    assert_true(test_stats_number(path("layout.json"), "bake.points_per_second") > 0);
    assert_true(test_stats_number(path("layout.json"), "stages.bake") > 0);
    assert_true(test_stats_number(path("layout.json"), "stages.bottom_level") > 0);
    free(count), free(seen);
    image_free(&b.img);
}

static void test_same_bits_whatever_memory_and_threads(void **state)
{
    const char *scene = test_source_path("scene/teapot_displaced.rib");
    const char *args = "--res 24x16 --points 100 --rays 32 --quiet";
    test_tessera_ok(dir, "bake '%s' -o '%s' %s", scene, path("d1.exr"), args);
    test_tessera_ok(dir, "bake '%s' -o '%s' %s --memory 16 --stats '%s'", scene, path("d2.exr"),
                    args, path("d2.json"));
    /* 16 MB holds a few hundred points per wave: many waves, evictions from the patch cache. */
    assert_true(test_stats_number(path("d2.json"), "counters.iterations") >= 8);
    char cmd[9000];
    snprintf(cmd, sizeof cmd, "POCL_MAX_PTHREAD_COUNT=1 '%s' bake '%s' -o '%s' %s 2>/dev/null",
             test_tessera_binary(), scene, path("d3.exr"), args);
    assert_int_equal(system(cmd), 0);
    test_assert_same_pixels(path("d1.exr"), path("d2.exr"));
    test_assert_same_pixels(path("d1.exr"), path("d3.exr"));
    /* A default budget whose arenas cannot hold the patches (its cap lowered to 16 MB: 4 MB
     * of arenas, the teapot's patches at m = 6 need 6 MB): they grow to hold them, each is
     * diced once, and the bits are those of a budget they fit. */
    const char *lod6 = "--lod 6 --rays 4 --quiet";
    test_tessera_ok(dir, "bake '%s' -o '%s' %s --memory 512", scene, path("g1.exr"), lod6);
    setenv("TESSERA_BUDGET_CAP_MB", "16", 1);
    test_tessera_ok(dir, "bake '%s' -o '%s' %s --stats '%s'", scene, path("g2.exr"), lod6,
                    path("g2.json"));
    unsetenv("TESSERA_BUDGET_CAP_MB");
    test_assert_same_pixels(path("g1.exr"), path("g2.exr"));
    assert_true(test_stats_number(path("g2.json"), "counters.patches_diced") == 32.0);
    assert_true(test_stats_number(path("g2.json"), "counters.patch_cache_evictions") == 0.0);
    assert_true(test_stats_number(path("g2.json"), "counters.patch_cache_bytes") > 5.0 * 1048576);
    /* Another seed, other bits. */
    test_tessera_ok(dir, "bake '%s' -o '%s' %s --seed 3", scene, path("d4.exr"), args);
    ts_image x, y;
    test_read_image(path("d1.exr"), &x);
    test_read_image(path("d4.exr"), &y);
    assert_true(memcmp(x.pixels, y.pixels, sizeof(float) * x.width * x.height * x.channels) != 0);
    image_free(&x), image_free(&y);
}

static char *read_text(const char *file)
{
    static char buf[1 << 16];
    FILE *f = fopen(file, "r");
    size_t n = f ? fread(buf, 1, sizeof buf - 1, f) : 0;
    buf[n] = '\0';
    if (f) fclose(f);
    return buf;
}

/* Starts the bake in the background, waits for its first progress line, sends SIGTERM and
 * returns the exit status. */
static int bake_and_interrupt(const char *scene, const char *out, char *const extra[])
{
    char errpath[4300], outpath[4200];
    snprintf(errpath, sizeof errpath, "%s.stderr", path(out));
    snprintf(outpath, sizeof outpath, "%s", path(out));
    const char *bin = test_tessera_binary();
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        int fd = open(errpath, O_WRONLY | O_CREAT | O_TRUNC, 0644),
            nul = open("/dev/null", O_WRONLY);
        if (fd < 0 || nul < 0) _exit(126);
        dup2(fd, 2), dup2(nul, 1);
        char *argv[32] = {(char *)bin, "bake", (char *)scene, "-o", outpath};
        int n = 5;
        for (int i = 0; extra[i] && n < 31; ++i)
            argv[n++] = extra[i];
        argv[n] = NULL;
        execv(bin, argv);
        _exit(127);
    }
    int status = 0, progressed = 0;
    for (int i = 0; i < 6000 && !progressed; ++i) {
        if (waitpid(pid, &status, WNOHANG) == pid)
            fail_msg("the bake ended before it was interrupted:\n%s", read_text(errpath));
        progressed = strstr(read_text(errpath), " points, ") != NULL;
        if (!progressed) nanosleep(&(struct timespec){0, 10000000}, NULL);
    }
    if (!progressed) kill(pid, SIGKILL);
    assert_true(progressed);
    kill(pid, SIGTERM);
    assert_int_equal(waitpid(pid, &status, 0), pid);
    if (!WIFEXITED(status)) fail_msg("the bake died by signal %d", WTERMSIG(status));
    return WEXITSTATUS(status);
}

static void test_resume_after_sigterm(void **state)
{
    const char *scene = test_source_path("scene/teapot.rib");
    char *extra[] = {"--res", "32x18", "--points", "300", "--rays", "64", "--memory", "16", NULL};
    test_tessera_ok(dir,
                    "bake '%s' -o '%s' --quiet --res 32x18 --points 300 --rays 64 "
                    "--memory 16",
                    scene, path("whole.exr"));
    assert_int_equal(bake_and_interrupt(scene, "part.exr", extra), 3);
    assert_non_null(strstr(read_text(path("part.exr.stderr")), "continue with --resume"));
    int points = meta_int("part.exr", "tessera:bake_points");
    int done = meta_int("part.exr", "tessera:bake_done");
    assert_true(done > 0 && done < points);
    /* The unfinished points are NaN, the finished ones are not. */
    baked b;
    load("part.exr", &b);
    int nan_points = 0;
    for (int i = 0; i < b.img.width * b.img.height; ++i)
        if (!isnan(pixel(&b, i)[b.patch])) nan_points += isnan(pixel(&b, i)[b.sh[0]]);
    assert_int_equal(nan_points, points - done);
    image_free(&b.img);
    /* Another seed is refused and leaves the file alone. */
    assert_int_equal(test_run_tessera(dir,
                                      "bake '%s' -o '%s' --quiet --res 32x18 --points 300 "
                                      "--rays 64 --memory 16 --resume --seed 2",
                                      scene, path("part.exr")),
                     1);
    assert_non_null(strstr(read_text(path("stderr.txt")), "cannot resume: it was baked with "
                                                          "another"));
    assert_int_equal(meta_int("part.exr", "tessera:bake_done"), done);
    /* The same command with --resume finishes it: the bits of the uninterrupted bake (with
     * another --memory, which changes no bit). */
    test_tessera_ok(dir, "bake '%s' -o '%s' --quiet --res 32x18 --points 300 --rays 64 --resume",
                    scene, path("part.exr"));
    test_assert_same_pixels(path("whole.exr"), path("part.exr"));
    /* A finished bake is left as it is. */
    assert_int_equal(test_run_tessera(dir,
                                      "bake '%s' -o '%s' --res 32x18 --points 300 "
                                      "--rays 64 --resume",
                                      scene, path("part.exr")),
                     0);
    assert_non_null(strstr(read_text(path("stderr.txt")), "already complete"));
}

static void test_errors(void **state)
{
    const char *scene = test_source_path("scene/one_patch.rib");
    assert_int_equal(test_run_tessera(dir, "bake '%s' -o '%s'", scene, path("x.png")), 1);
    assert_non_null(strstr(read_text(path("stderr.txt")), "a bake is written as .exr"));
    assert_int_equal(test_run_tessera(dir, "bake '%s' -o '%s' --bands 5", scene, path("x.exr")), 1);
    assert_non_null(strstr(read_text(path("stderr.txt")), "bad value '5' for --bands"));
    /* The values and messages of `render` (issue 15, item 8): the same parsers. */
    assert_int_equal(
        test_run_tessera(dir, "bake '%s' -o '%s' --res 32x24junk", scene, path("x.exr")), 1);
    assert_non_null(strstr(read_text(path("stderr.txt")), "bad value '32x24junk' for --res"));
    assert_int_equal(test_run_tessera(dir, "bake '%s' -o '%s' --rays", scene, path("x.exr")), 1);
    assert_non_null(strstr(read_text(path("stderr.txt")), "option --rays needs a value"));
    assert_int_equal(test_run_tessera(dir, "bake '%s' -o '%s' --quiet=1", scene, path("x.exr")), 1);
    assert_non_null(strstr(read_text(path("stderr.txt")), "option --quiet takes no value"));
    assert_int_equal(
        test_run_tessera(dir, "bake '%s' -o '%s' --rays 60000 --memory 8", scene, path("x.exr")),
        1);
    assert_non_null(strstr(read_text(path("stderr.txt")), "raise --memory or lower --rays"));
    assert_int_equal(test_run_tessera(dir, "bake -o '%s'", path("x.exr")), 1);
    assert_non_null(strstr(read_text(path("stderr.txt")), "exactly one scene file"));
    /* --stats naming the scene would overwrite it: refused before anything runs. */
    write_scene("keep.rib", plane_world);
    assert_int_equal(test_run_tessera(dir, "bake '%s' -o '%s' --stats '%s'", path("keep.rib"),
                                      path("x.exr"), path("keep.rib")),
                     1);
    assert_non_null(strstr(read_text(path("stderr.txt")), "--stats names the scene file"));
    assert_int_equal(access(path("x.exr"), F_OK), -1); /* nothing written */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_unoccluded_plane),
        cmocka_unit_test(test_unoccluded_plane_cosine_and_sphere),
        cmocka_unit_test(test_occluding_disk),
        cmocka_unit_test(test_v_groove),
        cmocka_unit_test(test_layout_and_metadata),
        cmocka_unit_test(test_same_bits_whatever_memory_and_threads),
        cmocka_unit_test(test_resume_after_sigterm),
        cmocka_unit_test(test_errors),
    };
    return TEST_RUN_WITH_DEVICE(tests, setup);
}
