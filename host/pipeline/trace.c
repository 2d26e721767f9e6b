/* trace.c — the two-level loop of one wave (Hanika §3.1-3.2, DESIGN.md §1):
 *   while rays are active:
 *     top_level   -> up to N (leaf, window) candidates per active ray, N = capacity / R
 *     sort        -> candidates by leaf, segments [begin, end) per patch
 *     per batch of segments that fit the arenas: dice -> build -> bottom_level
 *     resolve     -> closest hit per ray; rays whose traversal is finished retire
 * Host stages (sort, the compaction in resolve) are timed on the monotonic clock; kernels by
 * their profiling events (dev_launch / dev_finish). */
#include "pipeline/pipeline.h"
#include "lib/quadtree.h"

#include <stdlib.h>

#include <string.h>

static int stage_top_level(ts_pipeline *p, uint32_t active_count, uint32_t n_per_ray, ts_error *err)
{
    if (dev_set_args(p->k_top_level, err, DEV_ARG(p->qbvh_nodes), DEV_ARG(p->active),
                     DEV_ARG(active_count), DEV_ARG(n_per_ray), DEV_ARG(p->ray_org),
                     DEV_ARG(p->ray_dir), DEV_ARG(p->ray_hit), DEV_ARG(p->ray_entry),
                     DEV_ARG(p->pairs[0]), DEV_ARG(p->count), (size_t)0))
        return err->code;
    if (dev_launch(p->cl, p->k_top_level, TS_STAGE_top_level, active_count, TS_LOCAL_SIZE, err))
        return err->code;
    return dev_finish(p->cl, p->stats, err);
}

/* Gives each segment its LOD: --lod's, clamped to max_lod, or its patch's from the lod
 * stage. */
static void assign_lods(ts_pipeline *p, uint32_t segs)
{
    int fixed = p->mode.fixed_lod;
    for (uint32_t i = 0; i < segs; ++i) {
        ts_segment *s = &p->segments_host[i];
        s->lod = fixed >= 0
                     ? ((uint32_t)fixed < p->plan.max_lod ? (uint32_t)fixed : p->plan.max_lod)
                     : p->patch_lod[s->patch];
    }
}

/* Gives each segment (its LOD set) its arena place and cuts the segments into batches
 * that fit the arenas; lists each batch's trees (segment, time) by decreasing m. */
static void plan_batches(ts_pipeline *p, uint32_t segs)
{
    uint32_t vused = 0, gused = 0, tused = 0, ntrees = 0;
    p->batch_count = 0;
    ts_batch *b = NULL;
    for (uint32_t i = 0; i < segs; ++i) {
        ts_segment *s = &p->segments_host[i];
        const ts_patch_attr *a = &p->scene->attr[s->patch];
        s->flags = a->flags & TS_PATCH_MOVING;
        s->pad = 0;
        uint32_t times = s->flags ? 2u : 1u;
        uint32_t nv = times * quadtree_vertex_count(s->lod),
                 ng = times * quadtree_group_count(s->lod);
        /* Texture tiles: the batch's patches' needs add up to at most the pool (an over-count
         * where they share tiles; each alone fits, tex_cache_create sized the pool so). */
        uint32_t nt = p->tex.paged ? p->tex.patch_tiles[s->patch] : 0u;
        if (!b || vused + nv > p->plan.vert_capacity || gused + ng > p->plan.group_capacity ||
            tused + nt > p->tex.slots) {
            b = &p->batches[p->batch_count++];
            *b = (ts_batch){i, 0, ntrees, 0};
            vused = gused = tused = 0;
        }
        s->vert_first = vused;
        s->group_first = gused;
        vused += nv, gused += ng, tused += nt;
        b->seg_count++;
        for (uint32_t t = 0; t < times; ++t)
            p->trees_host[ntrees++] = (i << 1) | t, b->tree_count++;
    }
    /* Counting sort of each batch's trees by decreasing m (stable). */
    for (uint32_t k = 0; k < p->batch_count; ++k) {
        ts_batch *bk = &p->batches[k];
        uint32_t *list = &p->trees_host[bk->tree_first], count[TS_LOD_LIMIT + 1] = {0};
        uint32_t tmp[2 * 64],
            *scratch = bk->tree_count <= 128 ? tmp : malloc(bk->tree_count * sizeof *scratch);
        if (!scratch) continue; /* unsorted: build_level then visits idle trees, still correct */
        for (uint32_t t = 0; t < bk->tree_count; ++t)
            count[p->segments_host[TS_TREE_SEGMENT(list[t])].lod]++;
        uint32_t start[TS_LOD_LIMIT + 1], at = 0;
        for (int m = TS_LOD_LIMIT; m >= 0; --m)
            start[m] = at, at += count[m];
        for (uint32_t t = 0; t < bk->tree_count; ++t)
            scratch[start[p->segments_host[TS_TREE_SEGMENT(list[t])].lod]++] = list[t];
        memcpy(list, scratch, bk->tree_count * sizeof *list);
        if (scratch != tmp) free(scratch);
    }
}

/* Discrete devices: reads the window into host memory, sorts it there and writes back
 * only the valid pairs, sorted, into pairs[0]: one window read and one write of the valid
 * part over the bus instead of reading and writing both mapped buffers whole. */
static int sort_via_copy(ts_pipeline *p, uint32_t n, uint32_t *sorted_buffer, uint32_t *valid,
                         uint32_t *segs, ts_error *err)
{
    cl_command_queue q = p->cl->queue;
    ts_pair *a = p->sort_host[0], *b = p->sort_host[1];
    CL_CHECK(clEnqueueReadBuffer(q, p->pairs[0], CL_TRUE, 0, (size_t)n * sizeof(ts_pair), a, 0,
                                 NULL, NULL),
             err);
    const ts_pair *sorted = NULL;
    int rc = radix_sort_pairs(p->sorter, a, b, n, p->scene->patch_count, &sorted, valid, err);
    if (rc) return rc;
    *segs = sort_segments(sorted, *valid, p->segments_host, p->scene->patch_count);
    if (*segs == UINT32_MAX)
        return ts_error_set(err, TS_E_INTERNAL, "sort: more segments than patches");
    if (*valid)
        CL_CHECK(clEnqueueWriteBuffer(q, p->pairs[0], CL_TRUE, 0, (size_t)*valid * sizeof(ts_pair),
                                      sorted, 0, NULL, NULL),
                 err);
    *sorted_buffer = 0;
    return TS_OK;
}

/* Sorts the candidate windows on the host through mapped buffers (zero copy on CPU
 * devices). */
static int sort_mapped(ts_pipeline *p, uint32_t n, uint32_t *sorted_buffer, uint32_t *valid,
                       uint32_t *segment_count, ts_error *err)
{
    cl_command_queue q = p->cl->queue;
    cl_int rc0, rc1;
    size_t bytes = (size_t)n * sizeof(ts_pair);
    ts_pair *a = clEnqueueMapBuffer(q, p->pairs[0], CL_TRUE, CL_MAP_READ | CL_MAP_WRITE, 0, bytes,
                                    0, NULL, NULL, &rc0);
    ts_pair *b = clEnqueueMapBuffer(q, p->pairs[1], CL_TRUE, CL_MAP_READ | CL_MAP_WRITE, 0, bytes,
                                    0, NULL, NULL, &rc1);
    CL_CHECK(rc0, err);
    CL_CHECK(rc1, err);
    const ts_pair *sorted = NULL;
    int rc = radix_sort_pairs(p->sorter, a, b, n, p->scene->patch_count, &sorted, valid, err);
    uint32_t segs = 0;
    if (rc == TS_OK) {
        segs = sort_segments(sorted, *valid, p->segments_host, p->scene->patch_count);
        if (segs == UINT32_MAX)
            rc = ts_error_set(err, TS_E_INTERNAL, "sort: more segments than patches");
    }
    *sorted_buffer = sorted == b ? 1u : 0u;
    CL_CHECK(clEnqueueUnmapMemObject(q, p->pairs[0], a, 0, NULL, NULL), err);
    CL_CHECK(clEnqueueUnmapMemObject(q, p->pairs[1], b, 0, NULL, NULL), err);
    *segment_count = segs;
    return rc;
}

/* Sorts the candidate windows on the host (radix_sort.c), by mapping the buffers or, on
 * discrete devices, by copying (pipeline.h sort_host). Sets *sorted_buffer (0 or 1: which
 * pairs buffer holds the result), and the segment table; returns the segment count through
 * *segment_count. */
static int stage_sort(ts_pipeline *p, uint32_t n, uint32_t *sorted_buffer, uint32_t *valid,
                      uint32_t *segment_count, ts_error *err)
{
    double t0 = stats_now();
    cl_command_queue q = p->cl->queue;
    uint32_t segs = 0;
    int rc = p->sort_host[0] ? sort_via_copy(p, n, sorted_buffer, valid, &segs, err)
                             : sort_mapped(p, n, sorted_buffer, valid, &segs, err);
    if (rc) return rc;
    assign_lods(p, segs);
    plan_batches(p, segs);
    if (segs) {
        CL_CHECK(clEnqueueWriteBuffer(q, p->segments, CL_TRUE, 0, segs * sizeof(ts_segment),
                                      p->segments_host, 0, NULL, NULL),
                 err);
        uint32_t trees =
            p->batches[p->batch_count - 1].tree_first + p->batches[p->batch_count - 1].tree_count;
        CL_CHECK(clEnqueueWriteBuffer(q, p->trees, CL_TRUE, 0, trees * sizeof(uint32_t),
                                      p->trees_host, 0, NULL, NULL),
                 err);
    }
    *segment_count = segs;
    p->stats->stage_seconds[TS_STAGE_sort] += stats_now() - t0;
    return TS_OK;
}

/* The LOD of tree t of batch b. */
static uint32_t tree_lod(const ts_pipeline *p, const ts_batch *b, uint32_t t)
{
    return p->segments_host[TS_TREE_SEGMENT(p->trees_host[b->tree_first + t])].lod;
}

/* How many trees from t on share tree t's LOD (*m): one launch of dice or build_leaves
 * each (trees are listed by decreasing m). */
static uint32_t tree_run(const ts_pipeline *p, const ts_batch *b, uint32_t t, uint32_t *m)
{
    uint32_t run = 0;
    *m = tree_lod(p, b, t);
    while (t + run < b->tree_count && tree_lod(p, b, t + run) == *m)
        ++run;
    return run;
}

/* Makes the texture tiles the batch's dice and build read resident (tex_cache.h). */
static int batch_textures(ts_pipeline *p, const ts_batch *b, ts_error *err)
{
    if (!p->tex.paged) return TS_OK;
    tex_cache_begin(&p->tex);
    for (uint32_t i = b->seg_first; i < b->seg_first + b->seg_count; ++i)
        tex_cache_mark_patch(&p->tex, p->scene, p->segments_host[i].patch);
    return tex_cache_commit(&p->tex, p->cl, p->tex_pool, p->tex_pages, p->scene, p->stats, err);
}

/* Dices each tree run of one LOD with one launch. */
static int stage_dice(ts_pipeline *p, const ts_batch *b, ts_error *err)
{
    if (batch_textures(p, b, err)) return err->code;
    for (uint32_t t = 0; t < b->tree_count;) {
        uint32_t m, run = tree_run(p, b, t, &m);
        uint32_t first = b->tree_first + t;
        if (dev_set_args(p->k_dice, err, DEV_ARG(p->trees), DEV_ARG(first), DEV_ARG(run),
                         DEV_ARG(m), DEV_ARG(p->segments), DEV_ARG(p->cp), DEV_ARG(p->cp1),
                         DEV_ARG(p->corner_n), DEV_ARG(p->attr), DEV_ARG(p->xform),
                         DEV_ARG(p->textures), DEV_ARG(p->tex_pages), DEV_ARG(p->tex_pool),
                         DEV_ARG(p->grid), (size_t)0) ||
            dev_launch(p->cl, p->k_dice, TS_STAGE_dice, (size_t)run * quadtree_vertex_count(m),
                       TS_LOCAL_SIZE, err))
            return err->code;
        t += run;
    }
    for (uint32_t i = b->seg_first; i < b->seg_first + b->seg_count; ++i) {
        p->stats->counters[TS_COUNTER_patches_diced] += 1;
        p->stats->counters[TS_COUNTER_micropolygons_created] += 1ull
                                                                << (2u * p->segments_host[i].lod);
        p->stats->lod_histogram[p->segments_host[i].lod] += 1;
    }
    return TS_OK;
}

/* Leaves per LOD run, then one launch per level over the trees deeper than it. */
static int stage_build(ts_pipeline *p, const ts_batch *b, ts_error *err)
{
    uint32_t top = 0;
    for (uint32_t t = 0; t < b->tree_count;) {
        uint32_t m, run = tree_run(p, b, t, &m);
        if (t == 0) top = m;
        uint32_t first = b->tree_first + t;
        if (dev_set_args(p->k_build_leaves, err, DEV_ARG(p->trees), DEV_ARG(first), DEV_ARG(run),
                         DEV_ARG(m), DEV_ARG(p->segments), DEV_ARG(p->grid), DEV_ARG(p->corner_n),
                         DEV_ARG(p->attr), DEV_ARG(p->xform), DEV_ARG(p->flatness),
                         DEV_ARG(p->patch_box), DEV_ARG(p->textures), DEV_ARG(p->tex_pages),
                         DEV_ARG(p->tex_pool), DEV_ARG(p->groups), (size_t)0) ||
            dev_launch(p->cl, p->k_build_leaves, TS_STAGE_build, (size_t)run << (2u * m),
                       TS_LOCAL_SIZE, err))
            return err->code;
        t += run;
    }
    for (uint32_t level = top; level-- > 0;) {
        uint32_t deeper = 0; /* trees with m > level: a prefix of the list */
        while (deeper < b->tree_count && tree_lod(p, b, deeper) > level)
            ++deeper;
        if (dev_set_args(p->k_build_level, err, DEV_ARG(p->trees), DEV_ARG(b->tree_first),
                         DEV_ARG(deeper), DEV_ARG(level), DEV_ARG(p->segments), DEV_ARG(p->groups),
                         (size_t)0) ||
            dev_launch(p->cl, p->k_build_level, TS_STAGE_build, (size_t)deeper << (2u * level),
                       TS_LOCAL_SIZE, err))
            return err->code;
    }
    return TS_OK;
}

static int stage_bottom_level(ts_pipeline *p, uint32_t sorted_buffer, const ts_batch *b,
                              uint32_t n_per_ray, ts_error *err)
{
    const ts_segment *s = p->segments_host;
    uint32_t first = b->seg_first, count = b->seg_count, exact = p->mode.exact ? 1u : 0u;
    uint32_t pair_first = s[first].begin, pair_count = s[first + count - 1].end - pair_first;
    uint32_t leaf_b = p->mode.leaf_b;
    cl_kernel k = p->mode.leaf_group ? p->k_bottom_group : p->k_bottom_level;
    if (dev_set_args(k, err, DEV_ARG(p->pairs[sorted_buffer]), DEV_ARG(pair_first),
                     DEV_ARG(pair_count), DEV_ARG(p->segments), DEV_ARG(first), DEV_ARG(count),
                     DEV_ARG(n_per_ray), DEV_ARG(exact), DEV_ARG(leaf_b), DEV_ARG(p->active),
                     DEV_ARG(p->ray_org), DEV_ARG(p->ray_dir), DEV_ARG(p->ray_hit),
                     DEV_ARG(p->ray_flags), DEV_ARG(p->grid), DEV_ARG(p->groups),
                     DEV_ARG(p->pair_hit), DEV_ARG(p->utilisation), (size_t)0))
        return err->code;
    return dev_launch(p->cl, k, TS_STAGE_bottom_level, pair_count, TS_LOCAL_SIZE, err);
}

/* Folds candidate hits into each ray's closest hit, then compacts the active list on the
 * host (kept in order, so results never depend on timing). Returns the new active count. */
static int stage_resolve(ts_pipeline *p, uint32_t active_count, uint32_t n_per_ray,
                         uint32_t *still_active, ts_error *err)
{
    if (dev_set_args(p->k_resolve, err, DEV_ARG(p->active), DEV_ARG(active_count),
                     DEV_ARG(n_per_ray), DEV_ARG(p->count), DEV_ARG(p->pair_hit),
                     DEV_ARG(p->ray_hit), DEV_ARG(p->ray_entry), DEV_ARG(p->ray_flags),
                     DEV_ARG(p->alive), (size_t)0) ||
        dev_launch(p->cl, p->k_resolve, TS_STAGE_resolve, active_count, TS_LOCAL_SIZE, err) ||
        dev_finish(p->cl, p->stats, err))
        return err->code;
    double t0 = stats_now();
    cl_command_queue q = p->cl->queue;
    size_t bytes = (size_t)active_count * sizeof(uint32_t);
    cl_int rc0, rc1;
    uint32_t *act = clEnqueueMapBuffer(q, p->active, CL_TRUE, CL_MAP_READ | CL_MAP_WRITE, 0, bytes,
                                       0, NULL, NULL, &rc0);
    uint32_t *alive =
        clEnqueueMapBuffer(q, p->alive, CL_TRUE, CL_MAP_READ, 0, bytes, 0, NULL, NULL, &rc1);
    CL_CHECK(rc0, err);
    CL_CHECK(rc1, err);
    uint32_t n = 0;
    for (uint32_t i = 0; i < active_count; ++i)
        if (alive[i]) act[n++] = act[i];
    CL_CHECK(clEnqueueUnmapMemObject(q, p->active, act, 0, NULL, NULL), err);
    CL_CHECK(clEnqueueUnmapMemObject(q, p->alive, alive, 0, NULL, NULL), err);
    *still_active = n;
    /* Leaf utilisation of this iteration's bottom_level launches (32-bit counters, reset). */
    cl_uint util[2] = {0, 0};
    CL_CHECK(clEnqueueReadBuffer(q, p->utilisation, CL_TRUE, 0, sizeof util, util, 0, NULL, NULL),
             err);
    p->stats->counters[TS_COUNTER_leaf_tests] += util[0];
    p->stats->counters[TS_COUNTER_leaf_slots] += util[1];
    cl_uint zero = 0;
    CL_CHECK(
        clEnqueueFillBuffer(q, p->utilisation, &zero, sizeof zero, 0, sizeof util, 0, NULL, NULL),
        err);
    p->stats->stage_seconds[TS_STAGE_resolve] += stats_now() - t0;
    return TS_OK;
}

int pipeline_top_level(ts_pipeline *p, uint32_t active_count, uint32_t n_per_ray, ts_error *err)
{
    return stage_top_level(p, active_count, n_per_ray, err);
}

int pipeline_dice_build(ts_pipeline *p, uint32_t count, ts_error *err)
{
    plan_batches(p, count); /* the caller set each segment's LOD */
    if (p->batch_count != 1)
        return ts_error_set(err, TS_E_INTERNAL,
                            "pipeline_dice_build: the segments do not fit one batch");
    CL_CHECK(clEnqueueWriteBuffer(p->cl->queue, p->segments, CL_TRUE, 0, count * sizeof(ts_segment),
                                  p->segments_host, 0, NULL, NULL),
             err);
    CL_CHECK(clEnqueueWriteBuffer(p->cl->queue, p->trees, CL_TRUE, 0,
                                  p->batches[0].tree_count * sizeof(uint32_t), p->trees_host, 0,
                                  NULL, NULL),
             err);
    if (stage_dice(p, &p->batches[0], err) || stage_build(p, &p->batches[0], err)) return err->code;
    return dev_finish(p->cl, p->stats, err);
}

int pipeline_bottom_level(ts_pipeline *p, uint32_t n_per_ray, ts_error *err)
{
    if (p->batch_count != 1)
        return ts_error_set(err, TS_E_INTERNAL, "pipeline_bottom_level: no single batch diced");
    if (stage_bottom_level(p, 0u, &p->batches[0], n_per_ray, err)) return err->code;
    return dev_finish(p->cl, p->stats, err);
}

/* N per ray for R active rays: capacity / R, clipped to [1, 100] (Hanika §3.1, Table 3). */
static uint32_t pairs_per_ray(uint32_t capacity, uint32_t active)
{
    uint32_t n = capacity / (active ? active : 1);
    return n < 1 ? 1 : n > TS_N_MAX ? TS_N_MAX : n;
}

int pipeline_trace(ts_pipeline *p, uint32_t ray_count, ts_error *err)
{
    uint32_t active = ray_count;
    for (uint32_t it = 0; active > 0; ++it) {
        uint32_t n_per_ray = pairs_per_ray(p->plan.pair_capacity, active);
        uint32_t sorted_buffer = 0, valid = 0, segs = 0;
        if (stage_top_level(p, active, n_per_ray, err) ||
            stage_sort(p, active * n_per_ray, &sorted_buffer, &valid, &segs, err))
            return err->code;
        for (uint32_t k = 0; k < (segs ? p->batch_count : 0); ++k) {
            const ts_batch *b = &p->batches[k];
            if (stage_dice(p, b, err) || stage_build(p, b, err) ||
                stage_bottom_level(p, sorted_buffer, b, n_per_ray, err))
                return err->code;
        }
        ts_iteration rec = {p->wave, it, active, n_per_ray, valid, segs};
        if (stats_add_iteration(p->stats, &rec, err)) return err->code;
        p->stats->counters[TS_COUNTER_pairs] += valid;
        p->stats->counters[TS_COUNTER_iterations] += 1;
        if (stage_resolve(p, active, n_per_ray, &active, err)) return err->code;
    }
    return TS_OK;
}

/* Launches shade over paths [first, end): its path_count argument (index 5) is the end, so
 * the work-items the rounding adds past the chunk do nothing. */
static int launch_shade_range(ts_pipeline *p, uint32_t first, uint32_t end, ts_error *err)
{
    CL_CHECK(clSetKernelArg(p->k_shade, 5, sizeof end, &end), err);
    return dev_launch_range(p->cl, p->k_shade, TS_STAGE_shade, first, end - first, TS_LOCAL_SIZE,
                            err);
}

/* A path of the wave list and the patch its ray hit (UINT32_MAX: none or untextured). */
typedef struct shade_key {
    uint32_t patch, k;
} shade_key;

static int cmp_shade_key(const void *a, const void *b)
{
    const shade_key *x = a, *y = b;
    if (x->patch != y->patch) return x->patch < y->patch ? -1 : 1;
    return (x->k > y->k) - (x->k < y->k);
}

/* Launches shade over paths [0, path_count). With paged textures, the paths go in chunks
 * whose hits' tiles fit the pool together: each hit needs level 0 of its patch's textures
 * over the micro-quad around it (the shading normal's differences and the colour lookup).
 * The path list is shaded sorted by hit patch, so that a chunk holds the hits of a few
 * patches and their tiles, not a sweep over the image that touches every tile (Pharr et
 * al. 1997: schedule work by the data it needs); shade's results go to each path's own
 * slots (but alive[k], per list slot), so the order changes no bit; the list and alive
 * are put back in path order afterwards for the next wave. */
static int launch_shade(ts_pipeline *p, uint32_t wave_size, uint32_t path_count, ts_error *err)
{
    if (!p->tex.paged)
        return dev_launch(p->cl, p->k_shade, TS_STAGE_shade, path_count, TS_LOCAL_SIZE, err);
    cl_command_queue q = p->cl->queue;
    uint32_t *paths = malloc((size_t)path_count * sizeof *paths);
    uint32_t *sorted = malloc((size_t)path_count * sizeof *sorted);
    shade_key *keys = malloc((size_t)path_count * sizeof *keys);
    ts_hit *hits = malloc((size_t)wave_size * sizeof *hits);
    int rc =
        paths && sorted && keys && hits ? TS_OK : ts_error_set(err, TS_E_MEMORY, "out of memory");
    cl_int r0 = CL_SUCCESS, r1 = CL_SUCCESS;
    if (rc == TS_OK) {
        r0 = clEnqueueReadBuffer(q, p->wave_paths, CL_TRUE, 0, (size_t)path_count * sizeof *paths,
                                 paths, 0, NULL, NULL);
        r1 = clEnqueueReadBuffer(q, p->ray_hit, CL_TRUE, 0, (size_t)wave_size * sizeof *hits, hits,
                                 0, NULL, NULL);
        if (r0 != CL_SUCCESS || r1 != CL_SUCCESS)
            rc = ts_error_set(err, TS_E_DEVICE, "%s reading the wave's hits",
                              dev_error_name(r0 != CL_SUCCESS ? r0 : r1));
    }
    ts_tex_cache *c = &p->tex;
    if (rc == TS_OK) {
        for (uint32_t k = 0; k < path_count; ++k) {
            uint32_t patch = paths[k] < wave_size ? hits[paths[k]].patch : TS_INVALID;
            if (patch >= p->scene->patch_count || c->patch_tiles[patch] == 0) patch = UINT32_MAX;
            keys[k] = (shade_key){patch, k};
        }
        qsort(keys, path_count, sizeof *keys, cmp_shade_key);
        for (uint32_t k = 0; k < path_count; ++k)
            sorted[k] = paths[keys[k].k];
        r0 = clEnqueueWriteBuffer(q, p->wave_paths, CL_TRUE, 0, (size_t)path_count * sizeof *sorted,
                                  sorted, 0, NULL, NULL);
        if (r0 != CL_SUCCESS)
            rc = ts_error_set(err, TS_E_DEVICE, "%s writing the shade order", dev_error_name(r0));
    }
    uint32_t start = 0;
    tex_cache_begin(c);
    for (uint32_t k = 0; rc == TS_OK && k < path_count; ++k) {
        if (keys[k].patch == UINT32_MAX) continue;
        ts_hit h = hits[sorted[k]];
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
    if (rc == TS_OK) { /* back to path order: the list, and alive[k] (written per list slot) */
        size_t bytes = (size_t)path_count * sizeof(uint32_t);
        r0 = clEnqueueReadBuffer(q, p->alive, CL_TRUE, 0, bytes, sorted, 0, NULL, NULL);
        for (uint32_t k = 0; r0 == CL_SUCCESS && k < path_count; ++k)
            keys[k].patch = sorted[k];
        for (uint32_t k = 0; r0 == CL_SUCCESS && k < path_count; ++k)
            sorted[keys[k].k] = keys[k].patch;
        if (r0 == CL_SUCCESS)
            r0 = clEnqueueWriteBuffer(q, p->alive, CL_TRUE, 0, bytes, sorted, 0, NULL, NULL);
        if (r0 == CL_SUCCESS)
            r0 = clEnqueueWriteBuffer(q, p->wave_paths, CL_TRUE, 0, bytes, paths, 0, NULL, NULL);
        if (r0 != CL_SUCCESS)
            rc = ts_error_set(err, TS_E_DEVICE, "%s restoring the path order", dev_error_name(r0));
    }
    free(paths), free(sorted), free(keys), free(hits);
    return rc;
}

int pipeline_shade(ts_pipeline *p, const ts_shade_params *sp, uint32_t first_sample,
                   uint32_t wave_size, uint32_t path_count, uint32_t *next_paths,
                   uint32_t *next_rays, uint32_t *shadow_rays, ts_error *err)
{
    ts_shade_params s = *sp;
    *next_paths = *next_rays = *shadow_rays = 0;
    if (path_count == 0) return TS_OK;
    if (dev_set_args(p->k_shade, err, DEV_ARG(s), DEV_ARG(first_sample), DEV_ARG(p->pixel_count),
                     DEV_ARG(wave_size), DEV_ARG(p->wave_paths), DEV_ARG(path_count),
                     DEV_ARG(p->ray_org), DEV_ARG(p->ray_dir), DEV_ARG(p->ray_hit),
                     DEV_ARG(p->ray_entry), DEV_ARG(p->ray_flags), DEV_ARG(p->ray_pixel),
                     DEV_ARG(p->path_throughput), DEV_ARG(p->path_mis), DEV_ARG(p->path_pending),
                     DEV_ARG(p->radiance), DEV_ARG(p->aov), DEV_ARG(p->albedo), DEV_ARG(p->cp),
                     DEV_ARG(p->corner_n), DEV_ARG(p->attr), DEV_ARG(p->xform), DEV_ARG(p->lights),
                     DEV_ARG(p->emitters), DEV_ARG(p->env_texels), DEV_ARG(p->env_marginal),
                     DEV_ARG(p->env_conditional), DEV_ARG(p->flatness), DEV_ARG(p->textures),
                     DEV_ARG(p->tex_pages), DEV_ARG(p->tex_pool), DEV_ARG(p->alive), (size_t)0) ||
        launch_shade(p, wave_size, path_count, err) || dev_finish(p->cl, p->stats, err))
        return err->code;
    /* The next wave: the paths that go on and their rays, in path order. */
    double t0 = stats_now();
    cl_command_queue q = p->cl->queue;
    size_t bytes = (size_t)path_count * sizeof(uint32_t);
    cl_int rc0, rc1, rc2;
    uint32_t *paths = clEnqueueMapBuffer(q, p->wave_paths, CL_TRUE, CL_MAP_READ | CL_MAP_WRITE, 0,
                                         bytes, 0, NULL, NULL, &rc0);
    uint32_t *alive =
        clEnqueueMapBuffer(q, p->alive, CL_TRUE, CL_MAP_READ, 0, bytes, 0, NULL, NULL, &rc1);
    uint32_t *next =
        clEnqueueMapBuffer(q, p->active, CL_TRUE, CL_MAP_WRITE, 0, 2 * bytes, 0, NULL, NULL, &rc2);
    CL_CHECK(rc0, err);
    CL_CHECK(rc1, err);
    CL_CHECK(rc2, err);
    uint32_t np = 0, nr = 0, shadows = 0;
    for (uint32_t k = 0; k < path_count; ++k) {
        uint32_t path = paths[k], bits = alive[k];
        if (!bits) continue;
        paths[np++] = path; /* np <= k: compacting in place */
        if (bits & 1u) next[nr++] = path;
        if (bits & 2u) next[nr++] = wave_size + path, ++shadows;
    }
    CL_CHECK(clEnqueueUnmapMemObject(q, p->wave_paths, paths, 0, NULL, NULL), err);
    CL_CHECK(clEnqueueUnmapMemObject(q, p->alive, alive, 0, NULL, NULL), err);
    CL_CHECK(clEnqueueUnmapMemObject(q, p->active, next, 0, NULL, NULL), err);
    *next_paths = np;
    *next_rays = nr;
    *shadow_rays = shadows;
    p->stats->stage_seconds[TS_STAGE_shade] += stats_now() - t0;
    return TS_OK;
}

int pipeline_film(ts_pipeline *p, uint32_t first_sample, uint32_t ray_count, ts_error *err)
{
    if (dev_set_args(p->k_film, err, DEV_ARG(first_sample), DEV_ARG(ray_count),
                     DEV_ARG(p->pixel_count), DEV_ARG(p->radiance), DEV_ARG(p->aov),
                     DEV_ARG(p->albedo), DEV_ARG(p->accum), DEV_ARG(p->aov_film),
                     DEV_ARG(p->albedo_film), (size_t)0) ||
        dev_launch(p->cl, p->k_film, TS_STAGE_film, p->pixel_count, TS_LOCAL_SIZE, err))
        return err->code;
    return dev_finish(p->cl, p->stats, err);
}
