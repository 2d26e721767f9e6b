/* bake.c — the host side of stage `bake` (bake.h, kernels/bake.cl): per wave of points,
 *   bake_points  (in ranges whose texture tiles fit the pool when textures are paged)
 *   bake_rays    N shadow rays per point into the pipeline's ray buffers
 *   pipeline_trace  top_level -> sort -> dice -> build -> bottom_level -> resolve
 *   bake_project the B^2 coefficients per point, read back with the points.
 * Kernels are timed by their profiling events under `bake`; the read-back by the monotonic
 * clock. */
#include "pipeline/bake.h"
#include "pipeline/pipeline.h"

#include <stdlib.h>
#include <string.h>

void bake_stage_destroy(ts_device *cl, ts_bake_stage *b)
{
    if (!b) return;
    const cl_kernel k[] = {b->k_points, b->k_rays, b->k_project};
    for (size_t i = 0; i < sizeof k / sizeof *k; ++i)
        if (k[i]) clReleaseKernel(k[i]);
    const cl_mem m[] = {b->point_first, b->lod,         b->point_pos,
                        b->point_n,     b->point_patch, b->coeffs};
    for (size_t i = 0; i < sizeof m / sizeof *m; ++i)
        dev_buffer_release(cl, m[i]);
    free(b->point_first_host);
    free(b);
}

/* Kernels and buffers of b for a scene of n patches (n + 1 prefix sums). */
static int bake_stage_make(ts_pipeline *p, ts_bake_stage *b, const ts_bake_setup *s, uint32_t n,
                           ts_error *err)
{
    ts_device *cl = p->cl;
    size_t np = b->points_per_wave, nc = (size_t)s->bands * s->bands;
    const cl_mem_flags ro = CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, rw = CL_MEM_READ_WRITE;
    if (!(b->k_points = dev_kernel_create(cl, "bake_points", err)) ||
        !(b->k_rays = dev_kernel_create(cl, "bake_rays", err)) ||
        !(b->k_project = dev_kernel_create(cl, "bake_project", err)) ||
        !(b->point_first =
              dev_buffer_create(cl, ro, (n + 1) * sizeof(uint32_t), (void *)s->point_first, err)) ||
        !(b->lod =
              dev_buffer_create(cl, ro, (n ? n : 1) * sizeof(uint32_t), (void *)s->lod, err)) ||
        !(b->point_pos = dev_buffer_create(cl, rw, np * sizeof(ts_vec4), NULL, err)) ||
        !(b->point_n = dev_buffer_create(cl, rw, np * sizeof(ts_vec4), NULL, err)) ||
        !(b->point_patch = dev_buffer_create(cl, rw, np * sizeof(uint32_t), NULL, err)) ||
        !(b->coeffs = dev_buffer_create(cl, rw, np * nc * sizeof(float), NULL, err))) {
        pipeline_note_device_bytes(p);
        return err->code;
    }
    pipeline_note_device_bytes(p);
    return TS_OK;
}

int bake_stage_create(ts_pipeline *p, const ts_bake_setup *s, ts_error *err)
{
    uint32_t n = p->scene->patch_count;
    if (s->bands < 1 || s->bands > 4 || s->rays < 1)
        return ts_error_set(err, TS_E_INTERNAL, "bake: %u bands, %u rays", s->bands, s->rays);
    if (p->plan.ray_capacity < s->rays)
        return ts_error_set(err, TS_E_USAGE,
                            "--memory holds %u rays per wave, fewer than one point's %u rays; "
                            "raise --memory or lower --rays",
                            p->plan.ray_capacity, s->rays);
    ts_bake_stage *b = calloc(1, sizeof *b);
    if (!b) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    p->bake = b;
    b->points_per_wave = p->plan.ray_capacity / s->rays;
    b->params = (ts_bake_params){.rays = s->rays,
                                 .bands = s->bands,
                                 .flags = s->flags,
                                 .seed = s->seed,
                                 .patch_count = n,
                                 .orthographic = s->orthographic};
    memcpy(b->params.eye, s->eye, sizeof b->params.eye);
    b->point_first_host = malloc((n + 1) * sizeof(uint32_t));
    if (!b->point_first_host) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    memcpy(b->point_first_host, s->point_first, (n + 1) * sizeof(uint32_t));
    for (uint32_t i = 0; i < n; ++i) {
        if (s->lod[i] > p->plan.max_lod)
            return ts_error_set(err, TS_E_INTERNAL, "bake: patch %u at m = %u above max_lod %u", i,
                                s->lod[i], p->plan.max_lod);
        p->patch_lod[i] = (uint8_t)s->lod[i];
    }
    p->mode.fixed_lod = -1; /* dice each patch at its points' m */
    patch_cache_clear(&p->cache);
    return bake_stage_make(p, b, s, n, err);
}

/* The patch holding global point g (the last p with point_first[p] <= g). */
static uint32_t patch_of(const uint32_t *first, uint32_t n, uint32_t g)
{
    uint32_t lo = 0, hi = n;
    while (hi - lo > 1) {
        uint32_t mid = (lo + hi) / 2;
        if (first[mid] <= g)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* bake_points over points [start, end) of the wave. */
static int launch_points(ts_pipeline *p, uint32_t start, uint32_t end, ts_error *err)
{
    ts_bake_stage *b = p->bake;
    if (dev_set_args(b->k_points, err, DEV_ARG(b->params), DEV_ARG(end), DEV_ARG(b->point_first),
                     DEV_ARG(b->lod), DEV_ARG(p->cp), DEV_ARG(p->corner_n), DEV_ARG(p->mid_n),
                     DEV_ARG(p->attr), DEV_ARG(p->xform), DEV_ARG(p->flatness),
                     DEV_ARG(p->textures), DEV_ARG(p->tex_pages), DEV_ARG(p->tex_pool),
                     DEV_ARG(b->point_pos), DEV_ARG(b->point_n), DEV_ARG(b->point_patch),
                     (size_t)0))
        return err->code;
    return dev_launch_range(p->cl, b->k_points, TS_STAGE_bake, start, end - start, TS_LOCAL_SIZE,
                            err);
}

/* bake_points over the wave's count points. With paged textures, in runs of whole patches
 * whose tiles fit the pool together (tex_cache_mark_patch covers every (u, v) of a patch;
 * the pool holds any one patch's). */
static int bake_points_wave(ts_pipeline *p, uint32_t count, ts_error *err)
{
    if (!p->tex.paged) return launch_points(p, 0, count, err);
    ts_bake_stage *b = p->bake;
    uint32_t first = b->params.first_point, n = b->params.patch_count, start = 0;
    ts_tex_cache *c = &p->tex;
    tex_cache_begin(c);
    for (uint32_t i = 0; i < count;) {
        uint32_t patch = patch_of(b->point_first_host, n, first + i);
        uint32_t end = b->point_first_host[patch + 1] - first;
        if (end > count) end = count;
        if (c->marked + c->patch_tiles[patch] > c->slots) {
            if (tex_cache_commit(c, p->cl, p->tex_pool, p->tex_pages, p->scene, p->stats, err) ||
                launch_points(p, start, i, err))
                return err->code;
            tex_cache_begin(c);
            start = i;
        }
        tex_cache_mark_patch(c, p->scene, patch);
        i = end;
    }
    if (tex_cache_commit(c, p->cl, p->tex_pool, p->tex_pages, p->scene, p->stats, err))
        return err->code;
    return launch_points(p, start, count, err);
}

static int bake_rays_wave(ts_pipeline *p, ts_error *err)
{
    ts_bake_stage *b = p->bake;
    size_t rays = (size_t)b->params.point_count * b->params.rays;
    if (dev_set_args(b->k_rays, err, DEV_ARG(b->params), DEV_ARG(b->point_pos), DEV_ARG(b->point_n),
                     DEV_ARG(b->point_patch), DEV_ARG(p->ray_org), DEV_ARG(p->ray_dir),
                     DEV_ARG(p->ray_hit), DEV_ARG(p->ray_entry), DEV_ARG(p->ray_flags),
                     DEV_ARG(p->ray_from), DEV_ARG(p->active), (size_t)0))
        return err->code;
    return dev_launch(p->cl, b->k_rays, TS_STAGE_bake, rays, TS_LOCAL_SIZE, err);
}

static int bake_project_wave(ts_pipeline *p, ts_error *err)
{
    ts_bake_stage *b = p->bake;
    if (dev_set_args(b->k_project, err, DEV_ARG(b->params), DEV_ARG(b->point_n),
                     DEV_ARG(p->ray_dir), DEV_ARG(p->ray_hit), DEV_ARG(b->coeffs), (size_t)0))
        return err->code;
    return dev_launch(p->cl, b->k_project, TS_STAGE_bake, b->params.point_count, TS_LOCAL_SIZE,
                      err);
}

int bake_stage_wave(ts_pipeline *p, uint32_t first, uint32_t count, float *coeffs, ts_vec4 *pos,
                    ts_vec4 *normal, ts_error *err)
{
    ts_bake_stage *b = p->bake;
    if (!b || count == 0 || count > b->points_per_wave)
        return ts_error_set(err, TS_E_INTERNAL, "bake: a wave of %u points", count);
    b->params.first_point = first;
    b->params.point_count = count;
    uint32_t rays = count * b->params.rays;
    if (bake_points_wave(p, count, err) || bake_rays_wave(p, err) ||
        dev_finish(p->cl, p->stats, err) || pipeline_trace(p, rays, err) ||
        bake_project_wave(p, err) || dev_finish(p->cl, p->stats, err))
        return err->code;
    double t0 = stats_now();
    size_t nc = (size_t)b->params.bands * b->params.bands;
    int rc =
        dev_read(p->cl, b->coeffs, 0, count * nc * sizeof(float), coeffs, "the coefficients",
                 err) ||
        dev_read(p->cl, b->point_pos, 0, count * sizeof(ts_vec4), pos, "the bake points", err) ||
        dev_read(p->cl, b->point_n, 0, count * sizeof(ts_vec4), normal, "the bake normals", err);
    p->stats->stage_seconds[TS_STAGE_bake] += stats_now() - t0;
    p->stats->counters[TS_COUNTER_bake_points] += count;
    p->stats->counters[TS_COUNTER_rays] += rays;
    return rc ? err->code : TS_OK;
}
