/* test_embree.c — the two-level tracer in exact micro-triangle mode at fixed m against
 * Embree tracing the same micro-triangles (tests/support/embree_ref.h, DESIGN.md §5): on the
 * teapot at m = 5, plain and with fBm displacement, for primary rays from the camera and for
 * incoherent rays from random points of the teapot's bounding box in random directions, hit
 * and miss agree except on at most 0.1% of the rays (edges and silhouettes), and of the rays
 * both hit, >= 99.9% hit the same patch at |t - t_embree| <= 1e-4 t_embree. */
#include "test_support.h"
#include "embree_ref.h"
#include "pipeline/pipeline.h"
#include "app/render.h"
#include "scene/rib/rib.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { W = 128, H = 72, RAYS = W * H, M = 5 };

/* The teapot with fBm displacement: a Displacement attribute right after WorldBegin. */
static const char *const displacement =
    "Displacement \"fbm\" \"float amplitude\" [0.04] \"float frequency\" [3] "
    "\"float octaves\" [4]\n";

typedef struct teapot {
    ts_scene scene;
    ts_embree_ref *ref;
} teapot;

typedef struct fixture {
    ts_device cl;
    teapot plain, displaced;
} fixture;

typedef struct rays {
    ts_vec4 org[RAYS], dir[RAYS];
    ts_hit hit[RAYS], ref[RAYS];
} rays;

/* Loads the teapot (with `insert` after WorldBegin when not NULL) and builds its Embree
 * reference at m; prints what the build cost. */
static int load(teapot *t, const char *insert, ts_error *err)
{
    const char *path = test_source_path("scene/teapot.rib");
    FILE *f = fopen(path, "rb");
    if (!f) return ts_error_set(err, TS_E_IO, "%s: cannot open", path);
    static char text[1 << 20];
    size_t len = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    text[len] = '\0';
    if (insert) {
        char *at = strstr(text, "WorldBegin\n"), *end = text + len;
        size_t add = strlen(insert);
        if (!at || len + add >= sizeof text)
            return ts_error_set(err, TS_E_SCENE, "%s: no WorldBegin", path);
        at += strlen("WorldBegin\n");
        memmove(at + add, at, (size_t)(end - at) + 1);
        memcpy(at, insert, add);
        len += add;
    }
    if (rib_parse_string(path, text, len, &t->scene, 1, err)) return err->code;
    if (t->scene.patch_count != 32)
        return ts_error_set(err, TS_E_SCENE, "teapot: %u patches", t->scene.patch_count);
    if (insert && t->scene.attr[0].disp_kind != TS_DISP_FBM)
        return ts_error_set(err, TS_E_SCENE, "teapot: the displacement did not reach the patches");
    if (embree_ref_create(&t->ref, &t->scene, M, NULL, err)) return err->code;
    const ts_embree_info *info = embree_ref_info(t->ref);
    printf("embree: teapot%s at m = %u: %llu triangles, %llu vertices; tessellate %.3f ms, "
           "BVH build %.3f ms; bytes before build %lld, peak %lld, after build %lld\n",
           insert ? " (displaced)" : "", info->lod, (unsigned long long)info->triangles,
           (unsigned long long)info->vertices, 1e3 * info->tessellate_seconds,
           1e3 * info->build_seconds, (long long)info->bytes_before_build,
           (long long)info->bytes_peak, (long long)info->bytes_after_build);
    return TS_OK;
}

static int setup(void **state)
{
    static fixture f;
    test_open_device(&f.cl); /* exits 77 without a device */
    ts_error err = {0};
    if (load(&f.plain, NULL, &err) || load(&f.displaced, displacement, &err)) {
        fprintf(stderr, "%s\n", err.msg);
        return -1;
    }
    *state = &f;
    return 0;
}

static int teardown(void **state)
{
    fixture *f = *state;
    teapot *t[2] = {&f->plain, &f->displaced};
    for (int k = 0; k < 2; ++k) {
        embree_ref_destroy(t[k]->ref);
        scene_free(&t[k]->scene);
    }
    dev_close(&f->cl);
    return 0;
}

/* A pipeline in exact micro-triangle mode with every patch at m. */
static void create_exact(ts_pipeline *p, ts_device *cl, const ts_scene *scene, ts_stats *stats)
{
    ts_error err = {0};
    ts_pipeline_plan plan = {.ray_capacity = RAYS, .pair_capacity = RAYS * 8};
    pipeline_plan_arenas(&plan, scene->patch_count, M); /* every patch in one batch */
    memset(stats, 0, sizeof *stats);
    if (pipeline_create(p, cl, scene, &plan, RAYS, stats, &err)) fail_msg("%s", err.msg);
    p->mode.fixed_lod = M;
    p->mode.exact = 1;
}

static void read_back(ts_pipeline *p, rays *r)
{
    cl_command_queue q = p->cl->queue;
    assert_int_equal(
        clEnqueueReadBuffer(q, p->ray_org, CL_TRUE, 0, sizeof r->org, r->org, 0, NULL, NULL),
        CL_SUCCESS);
    assert_int_equal(
        clEnqueueReadBuffer(q, p->ray_dir, CL_TRUE, 0, sizeof r->dir, r->dir, 0, NULL, NULL),
        CL_SUCCESS);
    assert_int_equal(
        clEnqueueReadBuffer(q, p->ray_hit, CL_TRUE, 0, sizeof r->hit, r->hit, 0, NULL, NULL),
        CL_SUCCESS);
}

/* Traces the rays read back with Embree and asserts the agreement; prints the numbers and
 * every disagreement (a few at most). */
static void compare(const char *name, teapot *tp, rays *r, int min_hits)
{
    ts_error err = {0};
    if (embree_ref_trace(tp->ref, r->org, r->dir, NULL, RAYS, r->ref, &err))
        fail_msg("%s", err.msg);
    int miss_disagree = 0, both = 0, same_patch = 0, t_close = 0, agree = 0, same_prim = 0;
    double worst = 0.0; /* largest |t - t_embree| / t_embree where the patch agrees */
    for (int k = 0; k < RAYS; ++k) {
        const ts_hit *a = &r->hit[k], *b = &r->ref[k];
        int got = a->patch != TS_INVALID, want = b->patch != TS_INVALID;
        if (got != want) {
            ++miss_disagree;
            printf("%s: ray %d org (%.9g %.9g %.9g) dir (%.9g %.9g %.9g): two-level %s "
                   "(patch %u prim %u t %.9g), embree %s (patch %u prim %u t %.9g)\n",
                   name, k, r->org[k].x, r->org[k].y, r->org[k].z, r->dir[k].x, r->dir[k].y,
                   r->dir[k].z, got ? "hit" : "miss", a->patch, a->prim, a->t,
                   want ? "hit" : "miss", b->patch, b->prim, b->t);
            continue;
        }
        if (!want) continue;
        ++both;
        int patch_ok = a->patch == b->patch, t_ok = fabsf(a->t - b->t) <= 1e-4f * b->t;
        same_patch += patch_ok;
        t_close += t_ok;
        agree += patch_ok && t_ok;
        same_prim += patch_ok && a->prim == b->prim;
        if (patch_ok) worst = fmax(worst, fabs((double)a->t - b->t) / b->t);
        if (!(patch_ok && t_ok))
            printf(
                "%s: ray %d: two-level patch %u prim %u t %.9g, embree patch %u prim %u t %.9g\n",
                name, k, a->patch, a->prim, a->t, b->patch, b->prim, b->t);
    }
    printf("%s: %d rays, hit/miss disagree on %d (%.4f%%); both hit %d: same patch %.4f%%, "
           "t within 1e-4 %.4f%%, both %.4f%%, same micro-triangle %.4f%%; largest relative t "
           "difference %.3g\n",
           name, RAYS, miss_disagree, 100.0 * miss_disagree / RAYS, both, 100.0 * same_patch / both,
           100.0 * t_close / both, 100.0 * agree / both, 100.0 * same_prim / both, worst);
    assert_true(both >= min_hits); /* the comparison covers enough hits to mean something */
    assert_true(miss_disagree <= 0.001 * RAYS);
    assert_true(agree >= 0.999 * both);
}

static void camera_rays(ts_device *cl, teapot *tp, const char *name)
{
    static rays r;
    ts_error err = {0};
    ts_stats stats;
    ts_pipeline p;
    create_exact(&p, cl, &tp->scene, &stats);
    ts_camera_params cam;
    if (render_camera_params(&tp->scene.camera, W, H, &cam, &err)) fail_msg("%s", err.msg);
    cam.spp = 1;
    cam.ray_count = RAYS;
    if (pipeline_camera(&p, &cam, &err) || pipeline_trace(&p, RAYS, &err)) fail_msg("%s", err.msg);
    read_back(&p, &r);
    pipeline_destroy(&p);
    stats_free(&stats);
    compare(name, tp, &r, RAYS / 5); /* the teapot fills a good part of the frame */
}

/* Rays from uniform points of the teapot's bounding box in uniform directions, written
 * into the ray buffers directly. */
static void incoherent_rays(ts_device *cl, teapot *tp, const char *name)
{
    static rays r;
    static ts_u32 entry[RAYS], active[RAYS], pixel[RAYS];
    ts_error err = {0};
    ts_stats stats;
    ts_pipeline p;
    create_exact(&p, cl, &tp->scene, &stats);
    ts_box b = scene_patch_box(&tp->scene, 0);
    for (uint32_t k = 1; k < tp->scene.patch_count; ++k) {
        ts_box x = scene_patch_box(&tp->scene, k);
        b.lo_x = fminf(b.lo_x, x.lo_x), b.lo_y = fminf(b.lo_y, x.lo_y),
        b.lo_z = fminf(b.lo_z, x.lo_z);
        b.hi_x = fmaxf(b.hi_x, x.hi_x), b.hi_y = fmaxf(b.hi_y, x.hi_y),
        b.hi_z = fmaxf(b.hi_z, x.hi_z);
    }
    uint32_t seed = 12345u;
    for (int k = 0; k < RAYS; ++k) {
        r.org[k] =
            (ts_vec4){test_uniform(&seed, b.lo_x, b.hi_x), test_uniform(&seed, b.lo_y, b.hi_y),
                      test_uniform(&seed, b.lo_z, b.hi_z), 0.0f};
        float x, y, z, len2;
        do { /* uniform on the sphere: a point of the unit ball, normalised */
            x = test_uniform(&seed, -1, 1), y = test_uniform(&seed, -1, 1),
            z = test_uniform(&seed, -1, 1);
            len2 = x * x + y * y + z * z;
        } while (!(len2 > 1e-4f && len2 <= 1.0f));
        float inv = 1.0f / sqrtf(len2);
        r.dir[k] = (ts_vec4){x * inv, y * inv, z * inv, 0.0f};
        r.hit[k] = (ts_hit){TS_NO_HIT, 0, 0, TS_INVALID, TS_INVALID};
        entry[k] = TS_ENTRY_START;
        active[k] = pixel[k] = (ts_u32)k;
    }
    cl_command_queue q = cl->queue;
    assert_int_equal(
        clEnqueueWriteBuffer(q, p.ray_org, CL_TRUE, 0, sizeof r.org, r.org, 0, NULL, NULL),
        CL_SUCCESS);
    assert_int_equal(
        clEnqueueWriteBuffer(q, p.ray_dir, CL_TRUE, 0, sizeof r.dir, r.dir, 0, NULL, NULL),
        CL_SUCCESS);
    assert_int_equal(
        clEnqueueWriteBuffer(q, p.ray_hit, CL_TRUE, 0, sizeof r.hit, r.hit, 0, NULL, NULL),
        CL_SUCCESS);
    assert_int_equal(
        clEnqueueWriteBuffer(q, p.ray_entry, CL_TRUE, 0, sizeof entry, entry, 0, NULL, NULL),
        CL_SUCCESS);
    assert_int_equal(
        clEnqueueWriteBuffer(q, p.ray_pixel, CL_TRUE, 0, sizeof pixel, pixel, 0, NULL, NULL),
        CL_SUCCESS);
    /* Closest-hit rays (no TS_RAY_SHADOW): the flags must be written too, or resolve would
     * read whatever the buffer held. */
    cl_uint zero = 0;
    assert_int_equal(clEnqueueFillBuffer(q, p.ray_flags, &zero, sizeof zero, 0,
                                         sizeof(cl_uint) * RAYS, 0, NULL, NULL),
                     CL_SUCCESS);
    assert_int_equal(clEnqueueFillBuffer(q, p.ray_from, &zero, sizeof zero, 0,
                                         sizeof(cl_uint) * RAYS, 0, NULL, NULL),
                     CL_SUCCESS);
    assert_int_equal(
        clEnqueueWriteBuffer(q, p.active, CL_TRUE, 0, sizeof active, active, 0, NULL, NULL),
        CL_SUCCESS);
    if (pipeline_trace(&p, RAYS, &err)) fail_msg("%s", err.msg);
    read_back(&p, &r);
    pipeline_destroy(&p);
    stats_free(&stats);
    compare(name, tp, &r, RAYS / 4); /* from inside its box, many rays meet the teapot */
}

static void test_camera_rays(void **state)
{
    fixture *f = *state;
    camera_rays(&f->cl, &f->plain, "camera");
}

static void test_incoherent_rays(void **state)
{
    fixture *f = *state;
    incoherent_rays(&f->cl, &f->plain, "incoherent");
}

static void test_displaced_camera_rays(void **state)
{
    fixture *f = *state;
    camera_rays(&f->cl, &f->displaced, "displaced camera");
}

static void test_displaced_incoherent_rays(void **state)
{
    fixture *f = *state;
    incoherent_rays(&f->cl, &f->displaced, "displaced incoherent");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_camera_rays),
        cmocka_unit_test(test_incoherent_rays),
        cmocka_unit_test(test_displaced_camera_rays),
        cmocka_unit_test(test_displaced_incoherent_rays),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
