/* shade.c — the host side of the `shade` and `film` stages (DESIGN.md §1, Hanika §3.5, §4):
 *   shade -> one launch of shade_path over the wave's paths (kernels/shade.cl), in chunks
 *            whose texture tiles fit the pool when textures are paged; then the host lists
 *            the paths that go on and their next rays (BSDF ray i, shadow ray wave_size + i)
 *   film  -> adds the finished paths to the image (kernels/film.cl)
 * Kernels are timed by their profiling events (dev_launch / dev_finish); the host's list
 * making by the monotonic clock, under `shade`. */
#include "pipeline/pipeline.h"
#include "lib/sample_order.h"

#include <math.h>
#include <stdlib.h>

/* Index of shade_path's path_count argument (the end of the paths it shades). */
#define SHADE_ARG_PATH_END 5u

/* Launches shade over paths [first, end): its path_count argument is the end, so the
 * work-items the rounding adds past the chunk do nothing. */
static int launch_shade_range(ts_pipeline *p, uint32_t first, uint32_t end, ts_error *err)
{
    if (dev_set_arg(p->k_shade, SHADE_ARG_PATH_END, sizeof end, &end, err)) return err->code;
    return dev_launch_range(p->cl, p->k_shade, TS_STAGE_shade, first, end - first, TS_LOCAL_SIZE,
                            err);
}

/* A path of the wave list (its slot k) and the patch its ray hit (UINT32_MAX: none or
 * untextured). */
typedef struct shade_key {
    uint32_t patch, k;
} shade_key;

static int cmp_shade_key(const void *a, const void *b)
{
    const shade_key *x = a, *y = b;
    if (x->patch != y->patch) return x->patch < y->patch ? -1 : 1;
    return (x->k > y->k) - (x->k < y->k);
}

/* The host's copies for shading in patch order: the wave's list (paths) and its rays' hits
 * (hits, wave_size entries); keys and sorted: the list sorted by hit patch. */
typedef struct shade_order {
    uint32_t *paths, *sorted;
    shade_key *keys;
    ts_hit *hits;
} shade_order;

/* Reads the list and the hits, sorts the list by hit patch (stable: by slot within a
 * patch) and writes it to wave_paths in that order. */
static int order_by_patch(ts_pipeline *p, shade_order *o, uint32_t wave_size, uint32_t path_count,
                          ts_error *err)
{
    size_t bytes = (size_t)path_count * sizeof(uint32_t);
    if (dev_read(p->cl, p->wave_paths, 0, bytes, o->paths, "the wave's paths", err) ||
        dev_read(p->cl, p->ray_hit, 0, (size_t)wave_size * sizeof(ts_hit), o->hits,
                 "the wave's hits", err))
        return err->code;
    for (uint32_t k = 0; k < path_count; ++k) {
        uint32_t path = o->paths[k];
        uint32_t patch = path < wave_size ? o->hits[path].patch : TS_INVALID;
        if (patch >= p->scene->patch_count || p->tex.patch_tiles[patch] == 0) patch = UINT32_MAX;
        o->keys[k] = (shade_key){patch, k};
    }
    qsort(o->keys, path_count, sizeof *o->keys, cmp_shade_key);
    for (uint32_t k = 0; k < path_count; ++k)
        o->sorted[k] = o->paths[o->keys[k].k];
    return dev_write(p->cl, p->wave_paths, 0, bytes, o->sorted, "the shade order", err);
}

/* Launches shade over the sorted list in chunks whose hits' tiles fit the pool together:
 * each hit needs level 0 of its patch's textures over the micro-quad around it (the
 * shading normal's differences and the colour lookup). */
static int shade_in_chunks(ts_pipeline *p, const shade_order *o, uint32_t path_count, ts_error *err)
{
    ts_tex_cache *c = &p->tex;
    uint32_t start = 0;
    int rc = TS_OK;
    tex_cache_begin(c);
    for (uint32_t k = 0; rc == TS_OK && k < path_count; ++k) {
        if (o->keys[k].patch == UINT32_MAX) continue;
        ts_hit h = o->hits[o->sorted[k]];
        float hw = 0.5f * ldexpf(1.0f, -(int)TS_PRIM_LOD(h.prim));
        float u0 = fmaxf(h.u - hw, 0.0f), v0 = fmaxf(h.v - hw, 0.0f), u1 = fminf(h.u + hw, 1.0f),
              v1 = fminf(h.v + hw, 1.0f);
        if (c->marked + tex_cache_mark_hit(c, p->scene, h.patch, u0, v0, u1, v1, 1) > c->slots) {
            rc = tex_cache_commit(c, p->cl, p->tex_pool, p->tex_pages, p->scene, p->stats, err);
            if (rc == TS_OK) rc = launch_shade_range(p, start, k, err);
            tex_cache_begin(c);
            start = k;
        }
        tex_cache_mark_hit(c, p->scene, h.patch, u0, v0, u1, v1, 0);
    }
    if (rc == TS_OK)
        rc = tex_cache_commit(c, p->cl, p->tex_pool, p->tex_pages, p->scene, p->stats, err);
    if (rc == TS_OK) rc = launch_shade_range(p, start, path_count, err);
    return rc;
}

/* Puts the list back in path order for the next wave, and alive[k] with it (shade writes
 * it per list slot). Reuses o->sorted as scratch. */
static int restore_path_order(ts_pipeline *p, shade_order *o, uint32_t path_count, ts_error *err)
{
    size_t bytes = (size_t)path_count * sizeof(uint32_t);
    if (dev_read(p->cl, p->alive, 0, bytes, o->sorted, "the alive bits", err)) return err->code;
    for (uint32_t k = 0; k < path_count; ++k)
        o->keys[k].patch = o->sorted[k];
    for (uint32_t k = 0; k < path_count; ++k)
        o->sorted[o->keys[k].k] = o->keys[k].patch;
    if (dev_write(p->cl, p->alive, 0, bytes, o->sorted, "the alive bits", err) ||
        dev_write(p->cl, p->wave_paths, 0, bytes, o->paths, "the wave's paths", err))
        return err->code;
    return TS_OK;
}

/* Launches shade over paths [0, path_count). With paged textures the list is shaded sorted
 * by hit patch, so that a chunk holds the hits of a few patches and their tiles, not a
 * sweep over the image that touches every tile (Pharr et al. 1997: schedule work by the
 * data it needs); shade's results go to each path's own slots (but alive[k], per list
 * slot), so the order changes no bit; the list and alive are put back in path order
 * afterwards. */
static int launch_shade(ts_pipeline *p, uint32_t wave_size, uint32_t path_count, ts_error *err)
{
    if (!p->tex.paged)
        return dev_launch(p->cl, p->k_shade, TS_STAGE_shade, path_count, TS_LOCAL_SIZE, err);
    shade_order o = {
        malloc((size_t)path_count * sizeof *o.paths), malloc((size_t)path_count * sizeof *o.sorted),
        malloc((size_t)path_count * sizeof *o.keys), malloc((size_t)wave_size * sizeof *o.hits)};
    int rc = o.paths && o.sorted && o.keys && o.hits
                 ? TS_OK
                 : ts_error_set(err, TS_E_MEMORY, "out of memory");
    if (rc == TS_OK) rc = order_by_patch(p, &o, wave_size, path_count, err);
    if (rc == TS_OK) rc = shade_in_chunks(p, &o, path_count, err);
    if (rc == TS_OK) rc = restore_path_order(p, &o, path_count, err);
    free(o.paths), free(o.sorted), free(o.keys), free(o.hits);
    return rc;
}

/* The next wave from alive[k] of list slot k (its TS_PATH_TRACED_* bits):
 * compacts wave_paths in place to the paths that go on and lists their rays in active,
 * in path order. */
static int list_next_wave(ts_pipeline *p, uint32_t wave_size, uint32_t path_count,
                          uint32_t *next_paths, uint32_t *next_rays, uint32_t *shadow_rays,
                          ts_error *err)
{
    ts_device *cl = p->cl;
    size_t bytes = (size_t)path_count * sizeof(uint32_t);
    uint32_t *paths =
        dev_map(cl, p->wave_paths, CL_MAP_READ | CL_MAP_WRITE, 0, bytes, "the wave's paths", err);
    uint32_t *alive =
        paths ? dev_map(cl, p->alive, CL_MAP_READ, 0, bytes, "the alive bits", err) : NULL;
    uint32_t *next =
        alive ? dev_map(cl, p->active, CL_MAP_WRITE, 0, 2 * bytes, "the next rays", err) : NULL;
    int rc = next ? TS_OK : err->code;
    uint32_t np = 0, nr = 0, shadows = 0;
    for (uint32_t k = 0; rc == TS_OK && k < path_count; ++k) {
        uint32_t path = paths[k], bits = alive[k];
        if (!bits) continue;
        paths[np++] = path; /* np <= k: compacting in place */
        if (bits & TS_PATH_TRACED_BSDF) next[nr++] = path;
        if (bits & TS_PATH_TRACED_SHADOW) next[nr++] = wave_size + path, ++shadows;
    }
    /* Every map is undone; err keeps the first failure. */
    if (paths && dev_unmap(cl, p->wave_paths, paths, "the wave's paths", err)) rc = err->code;
    if (alive && dev_unmap(cl, p->alive, alive, "the alive bits", err)) rc = err->code;
    if (next && dev_unmap(cl, p->active, next, "the next rays", err)) rc = err->code;
    if (rc == TS_OK) *next_paths = np, *next_rays = nr, *shadow_rays = shadows;
    return rc;
}

int pipeline_shade(ts_pipeline *p, const ts_shade_params *sp, uint32_t first_sample,
                   uint32_t wave_size, uint32_t path_count, uint32_t *next_paths,
                   uint32_t *next_rays, uint32_t *shadow_rays, ts_error *err)
{
    ts_shade_params s = *sp;
    *next_paths = *next_rays = *shadow_rays = 0;
    if (path_count == 0) return TS_OK;
    /* The order's divisors (shade needs each path's sample, not its pixel's row: width 1). */
    ts_order_divs ord = sample_order_divs(p->pixel_count, 1u, s.spp, s.band);
    if (dev_set_args(
            p->k_shade, err, DEV_ARG(s), DEV_ARG(ord), DEV_ARG(first_sample), DEV_ARG(wave_size),
            DEV_ARG(p->wave_paths), DEV_ARG(path_count), DEV_ARG(p->ray_org), DEV_ARG(p->ray_dir),
            DEV_ARG(p->ray_hit), DEV_ARG(p->ray_entry), DEV_ARG(p->ray_flags), DEV_ARG(p->ray_from),
            DEV_ARG(p->ray_pixel), DEV_ARG(p->path_throughput), DEV_ARG(p->path_mis),
            DEV_ARG(p->path_state), DEV_ARG(p->path_pending), DEV_ARG(p->radiance), DEV_ARG(p->aov),
            DEV_ARG(p->albedo), DEV_ARG(p->cp), DEV_ARG(p->corner_n), DEV_ARG(p->mid_n),
            DEV_ARG(p->attr), DEV_ARG(p->xform), DEV_ARG(p->lights), DEV_ARG(p->emitters),
            DEV_ARG(p->env_texels), DEV_ARG(p->env_marginal), DEV_ARG(p->env_conditional),
            DEV_ARG(p->flatness), DEV_ARG(p->textures), DEV_ARG(p->tex_pages), DEV_ARG(p->tex_pool),
            DEV_ARG(p->alive), DEV_ARG(p->relight), DEV_ARG(p->relight_patch),
            DEV_ARG(p->relight_coeffs), DEV_ARG(p->relight_normal), DEV_ARG(p->relight_light),
            DEV_ARG(p->grid), DEV_ARG(p->grid_at), DEV_ARG(p->trim_seg), (size_t)0) ||
        pipeline_grid_publish(p, err) || launch_shade(p, wave_size, path_count, err) ||
        dev_finish(p->cl, p->stats, err))
        return err->code;
    double t0 = stats_now();
    int rc = list_next_wave(p, wave_size, path_count, next_paths, next_rays, shadow_rays, err);
    p->stats->stage_seconds[TS_STAGE_shade] += stats_now() - t0;
    return rc;
}

int pipeline_film(ts_pipeline *p, const ts_camera_params *cam, ts_error *err)
{
    if (cam->ray_count == 0) return TS_OK;
    if (p->plan.host_film)
        return ts_error_set(err, TS_E_INTERNAL, "the films of this pipeline are the host's");
    cl_uint px0, px1; /* the pixels the wave's samples fall in */
    sample_order_pixels(cam->first_sample, cam->ray_count, p->pixel_count, cam->spp, cam->band,
                        &px0, &px1);
    if (dev_set_args(p->k_film, err, DEV_ARG(cam->first_sample), DEV_ARG(cam->ray_count),
                     DEV_ARG(p->pixel_count), DEV_ARG(cam->spp), DEV_ARG(cam->band), DEV_ARG(px0),
                     DEV_ARG(px1), DEV_ARG(p->radiance), DEV_ARG(p->aov), DEV_ARG(p->albedo),
                     DEV_ARG(p->accum), DEV_ARG(p->aov_film), DEV_ARG(p->albedo_film), (size_t)0) ||
        dev_launch(p->cl, p->k_film, TS_STAGE_film, px1 - px0, TS_LOCAL_SIZE, err))
        return err->code;
    return dev_finish(p->cl, p->stats, err);
}
