#include "pipeline/pipeline.h"
#include "pipeline/bake.h"
#include "pipeline/lights.h"
#include "pipeline/relight.h"
#include "base/memory.h"
#include "base/parallel.h"
#include "lib/patch.h"
#include "lib/quadtree.h"
#include "lib/sample_order.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The fewest patches a thread of the per-patch passes takes (ts_parallel_for): below it a
 * thread's start costs more than it saves. */
#define PATCH_GRAIN 16384u

/* Bytes of one patch's grid and tree at LOD m, one time sample. */
static uint64_t slot_bytes(uint32_t m)
{
    return (uint64_t)quadtree_vertex_count(m) * sizeof(ts_vec4) +
           (uint64_t)quadtree_group_count(m) * TS_GROUP_BYTES;
}

void pipeline_plan_arenas(ts_pipeline_plan *plan, uint32_t patches, uint32_t m)
{
    plan->vert_capacity = 2u * patches * quadtree_vertex_count(m);
    plan->group_capacity = 2u * patches * quadtree_group_count(m);
    plan->max_lod = m;
}

int pipeline_plan(uint64_t memory_bytes, uint64_t rays_wanted, uint32_t max_lod, uint64_t max_alloc,
                  ts_pipeline_plan *plan, ts_error *err)
{
    /* Every field the plan does not set is 0 (host_film, fill_windows: off): callers keep
     * their plan on the stack. */
    *plan = (ts_pipeline_plan){0};
    if (max_lod > TS_LOD_LIMIT)
        return ts_error_set(err, TS_E_USAGE, "--max-lod %u is above the limit %d", max_lod,
                            TS_LOD_LIMIT);
    /* A quarter of the budget for the arenas, split between vertices and boxes in the
     * proportion one patch needs, with room for at least one moving patch at max_lod. */
    uint64_t arena = memory_bytes / 4;
    uint32_t m = max_lod;
    while (m > 0 && 2 * slot_bytes(m) > arena)
        --m;
    if (2 * slot_bytes(m) > arena)
        return ts_error_set(err, TS_E_USAGE, "--memory %llu MB leaves no room for a patch",
                            (unsigned long long)(memory_bytes >> 20));
    uint64_t per = slot_bytes(m), patches = arena / per;
    uint64_t vert_bytes = patches * quadtree_vertex_count(m) * sizeof(ts_vec4);
    uint64_t group_bytes = patches * quadtree_group_count(m) * sizeof(ts_box4);
    if (vert_bytes > max_alloc) patches = max_alloc / (quadtree_vertex_count(m) * sizeof(ts_vec4));
    if (group_bytes > max_alloc) patches = max_alloc / (quadtree_group_count(m) * sizeof(ts_box4));
    if (patches < 2)
        return ts_error_set(err, TS_E_USAGE,
                            "the device's largest buffer cannot hold a patch at m = %u", m);
    uint64_t vcap = patches * quadtree_vertex_count(m), gcap = patches * quadtree_group_count(m);
    plan->vert_capacity = vcap > UINT32_MAX ? UINT32_MAX : (uint32_t)vcap;
    plan->group_capacity = gcap > UINT32_MAX ? UINT32_MAX : (uint32_t)gcap;
    plan->max_lod = m;
    uint64_t rest = memory_bytes - patches * per;
    uint64_t rays =
        rest > TS_WAVE_EXTRA_BYTES ? (rest - TS_WAVE_EXTRA_BYTES) / TS_BYTES_PER_RAY : 0;
    uint64_t biggest_per_ray = TS_PAIRS_PER_RAY * sizeof(ts_hit); /* pair_hit buffer */
    if (rays * biggest_per_ray > max_alloc) rays = max_alloc / biggest_per_ray;
    if (rays > rays_wanted) rays = rays_wanted;
    if (rays > (1u << 25)) rays = 1u << 25; /* pair windows stay below 2^28 */
    if (rays < TS_LOCAL_SIZE && rays < rays_wanted)
        return ts_error_set(err, TS_E_USAGE, "--memory %llu MB leaves no room for rays",
                            (unsigned long long)(memory_bytes >> 20));
    plan->ray_capacity = (uint32_t)rays;
    plan->pair_capacity = (uint32_t)rays * TS_PAIRS_PER_RAY;
    plan->tex_pool_bytes = memory_bytes / 8;
    plan->sort_threads = 0;
    plan->first_n = 0;
    return TS_OK;
}

static int create_kernels(ts_pipeline *p, ts_error *err)
{
    const struct {
        cl_kernel *k;
        const char *name;
    } list[] = {
#define TS_KERNEL_ENTRY(field, name) {&p->field, name},
        TS_PIPELINE_KERNELS(TS_KERNEL_ENTRY)
#undef TS_KERNEL_ENTRY
    };
    for (size_t i = 0; i < sizeof list / sizeof *list; ++i)
        if (!(*list[i].k = dev_kernel_create(p->cl, list[i].name, err))) return err->code;
    return TS_OK;
}

/* The scene's data as the kernels read it (TS_PIPELINE_BUFFERS' contents column reads it as
 * u.NAME): the scene's arrays, or defaults where it has none (no motion: cp1 = cp; no
 * transforms: the identity; no normals: +z; NULL: zeros), and what the host derives. */
typedef struct scene_uploads {
    const void *nodes, *cp, *cp1, *corner_n, *mid_n, *xform, *boxes, *textures;
    const void *instance, *inst_xform; /* scene.h instancing, NULL when nothing is shared */
    const void *trim_seg;              /* scene.h trimmed NURBS, NULL when nothing is trimmed */
    ts_patch_attr *attr;       /* the scene's, with each patch's emitter index (lights_build) */
    const void *attr_src;      /* what the attr buffer holds: attr, or the scene's own array
                                  where that is the same bytes (no emitter) */
    ts_vec4 *flatness;         /* patch_flatness; w: the longest side of the patch's box */
    ts_vec4 *normals;          /* +z corner normals when the scene has none */
    ts_light_table lights;     /* lights.h */
    ts_env_map env;            /* the dome's map; 0 x 0 without one */
    ts_relight_tables relight; /* relight.h */
    const void *relight_patch, *relight_coeffs, *relight_normal; /* the scene's occlusion */
} scene_uploads;

/* Patches [begin, end) of scene_uploads_make: their flatness bounds, w the longest side of
 * the patch's box, for the secondary-ray offset l / 2^m. */
typedef struct patch_flat {
    const ts_scene *scene;
    const ts_box *boxes;
    ts_vec4 *flatness;
} patch_flat;

static void patch_flat_run(void *ctx, size_t begin, size_t end)
{
    const patch_flat *t = ctx;
    const ts_scene *s = t->scene;
    for (size_t i = begin; i < end; ++i) {
        const ts_vec4 *c0 = &s->cp[i * 16], *c1 = s->cp1 ? &s->cp1[i * 16] : c0;
        t->flatness[i] = patch_flatness(c0, c1, 0);
        ts_box b = t->boxes[i];
        t->flatness[i].w = fmaxf(b.hi_x - b.lo_x, fmaxf(b.hi_y - b.lo_y, b.hi_z - b.lo_z));
    }
}

static void scene_uploads_free(scene_uploads *u)
{
    free(u->attr);
    free(u->flatness);
    free(u->normals);
    lights_free(&u->lights);
    env_map_free(&u->env);
    relight_tables_free(&u->relight);
    memset(u, 0, sizeof *u);
}

/* Fills *u for p's scene; boxes: each patch's scene_patch_box. The caller frees *u with
 * scene_uploads_free, also after a failure. */
static int scene_uploads_make(const ts_pipeline *p, const ts_box *boxes, scene_uploads *u,
                              ts_error *err)
{
    static const ts_xform identity = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
    const ts_scene *s = p->scene;
    size_t n = s->patch_count ? s->patch_count : 1;
    memset(u, 0, sizeof *u);
    u->nodes = p->qbvh.nodes;
    u->cp = s->cp;
    u->cp1 = s->cp1 ? s->cp1 : s->cp;
    u->xform = s->xform_count ? (const void *)s->xform : (const void *)&identity;
    u->boxes = s->patch_count ? boxes : NULL;
    u->textures = s->textures;
    u->instance = s->instance;
    u->inst_xform = s->inst_xform;
    u->trim_seg = s->trim_seg_count ? (const void *)s->trim_seg : NULL;
    /* The attributes' copy carries the emitter indices lights_build writes: where no patch
     * emits and every index is TS_INVALID already, the buffer reads the scene's own (and
     * forest-10000 was not 1.7 GB of copy, compared and freed, at its peak). */
    int copy = s->patch_count == 0;
    for (uint32_t i = 0; !copy && i < s->patch_count; ++i) {
        const ts_patch_attr *a = &s->attr[i];
        copy = a->le_r > 0 || a->le_g > 0 || a->le_b > 0 || a->emitter != TS_INVALID;
    }
    u->attr = copy ? calloc(n, sizeof *u->attr) : NULL;
    u->flatness = ts_page_alloc(n * sizeof *u->flatness); /* array_in_place */
    if (u->flatness) memset(u->flatness, 0, n * sizeof *u->flatness);
    /* A scene without normals (hand-built in tests): +z at all nine nodes. */
    int given = s->corner_n && s->mid_n;
    u->normals = given ? NULL : calloc(n * 9, sizeof *u->normals);
    u->corner_n = given ? (const void *)s->corner_n : (const void *)u->normals;
    u->mid_n =
        given ? (const void *)s->mid_n : (const void *)(u->normals ? u->normals + 4 * n : NULL);
    if ((copy && !u->attr) || !u->flatness || !u->corner_n)
        return ts_error_set(err, TS_E_MEMORY, "out of memory");
    for (size_t i = 0; u->normals && i < n * 9; ++i)
        u->normals[i].z = 1.0f;
    if (s->patch_count && u->attr) memcpy(u->attr, s->attr, s->patch_count * sizeof *u->attr);
    patch_flat t = {s, boxes, u->flatness};
    ts_parallel_for(s->patch_count, PATCH_GRAIN, 0, patch_flat_run, &t);
    if (s->dome.present && s->dome.map) {
        ts_image img = {.width = (int)s->dome.map_width,
                        .height = (int)s->dome.map_height,
                        .channels = 3,
                        .channel_names = NULL,
                        .pixels = s->dome.map};
        if (env_map_from_image(&img, &u->env, err)) return err->code;
    } else if (s->dome.present && s->dome.mapname[0] &&
               env_map_load(s->dome.mapname, &u->env, err)) {
        return err->code;
    }
    if (lights_build(s, &u->env, u->attr, &u->lights, err)) return err->code;
    /* Without the copy (no patch emits, every index TS_INVALID) the buffer reads the scene's
     * attributes in place (array_in_place). */
    u->attr_src = u->attr ? u->attr : s->attr;
    if (s->occlusion)
        u->relight_patch = s->occlusion->patch, u->relight_coeffs = s->occlusion->coeffs,
        u->relight_normal = s->occlusion->normal;
    return relight_tables_build(s->occlusion, &u->lights, &u->env, &u->relight, err);
}

/* Whether the device may read the array at `host` in place (CL_MEM_USE_HOST_PTR) instead of a
 * copy: on a device that shares host memory, for the largest arrays the scene keeps anyway
 * (control points and displacement normals: 400 of the 844 bytes a patch's buffers take,
 * docs/benchmarks.md; the attributes' 160 where no patch emits), and for those the pipeline
 * makes to upload (the top-level BVH's nodes, the patch boxes and flatness bounds: about 104
 * bytes a patch, which a copy would hold twice while the buffers are made, forest-10000's peak),
 * when they are SCENE_ALIGN-aligned as both make them. The scene's live as long as the scene,
 * which outlives its pipelines; the pipeline's are then kept until pipeline_destroy; no one
 * writes them while it renders. */
static int array_in_place(const ts_pipeline *p, const void *host)
{
    const ts_scene *s = p->scene;
    if (!host || !p->cl->info.host_unified || ((uintptr_t)host % SCENE_ALIGN) != 0) return 0;
    return host == s->cp || (s->cp1 && host == s->cp1) || (s->corner_n && host == s->corner_n) ||
           (s->mid_n && host == s->mid_n) || (s->attr && host == s->attr) ||
           (p->qbvh.nodes && host == p->qbvh.nodes) || (p->box_host && host == p->box_host) ||
           (p->flatness_host && host == p->flatness_host);
}

/* Element counts of the buffers (TS_PIPELINE_BUFFERS' count column reads them as c.NAME).
 * What the scene lacks counts 1. */
typedef struct buffer_counts {
    size_t rays, paths, pairs, film;               /* the plan, the device films */
    size_t patches, nodes, xforms, textures;       /* the scene */
    size_t moving;                                 /* patches with cp1: all, or 1 */
    size_t instances, inst_xforms;                 /* its instancing tables */
    size_t trim_segs;                              /* its trim segments */
    size_t lights, emitters, env_texels, env_rows; /* lights.h */
    size_t tex_texels, tex_pages;                  /* tile pool, page table */
    size_t verts, groups;                          /* the arenas */
    size_t util_groups;                            /* bottom_level's work-groups */
    size_t relight_patch, relight_coeffs, relight_normal, relight_light; /* relight.h */
} buffer_counts;

static buffer_counts buffer_counts_of(const ts_pipeline *p, const scene_uploads *u)
{
    const ts_scene *s = p->scene;
    const ts_env_map *e = &u->env;
    const ts_occlusion *o = s->occlusion;
    return (buffer_counts){
        .rays = p->plan.ray_capacity,
        .paths = TS_PATHS_OF_RAYS(p->plan.ray_capacity),
        .pairs = p->plan.pair_capacity,
        .film = p->plan.host_film ? 1 : p->pixel_count,
        .patches = s->patch_count ? s->patch_count : 1,
        .moving = s->cp1 && s->patch_count ? s->patch_count : 1,
        .nodes = p->qbvh.node_count,
        .xforms = s->xform_count ? s->xform_count : 1,
        .instances = s->instance ? s->patch_count : 1,
        .inst_xforms = s->inst_xform_count ? s->inst_xform_count : 1,
        .trim_segs = s->trim_seg_count ? s->trim_seg_count : 1,
        .textures = s->texture_count ? s->texture_count : 1,
        .lights = u->lights.light_count ? u->lights.light_count : 1,
        .emitters = u->lights.emitter_count ? u->lights.emitter_count : 1,
        .env_texels = e->width ? (size_t)e->width * e->height : 1,
        .env_rows = e->width ? e->height : 1,
        .tex_texels = (size_t)(p->tex.slots ? p->tex.slots : 1) * TS_TEX_TILE * TS_TEX_TILE,
        .tex_pages = p->tex.pages ? p->tex.pages : 1,
        .verts = p->plan.vert_capacity,
        .groups = p->plan.group_capacity,
        .util_groups = p->util_groups,
        .relight_patch = o ? 2 * (size_t)o->patch_count : 1,
        .relight_coeffs = o ? (size_t)o->point_count * o->bands * o->bands : 1,
        .relight_normal = o ? (size_t)o->point_count * 3 : 1,
        .relight_light = u->relight.light_count ? u->relight.light_count : 1,
    };
}

#define TS_COUNT_ONE(type, name, what) +1

/* Makes every buffer: the ray fields (one entry per ray of the wave), the path fields (one
 * per path, TS_PATHS_OF_RAYS), then
 * TS_PIPELINE_BUFFERS, the scene's uploaded from *uploads; --stats' device_bytes_fixed is the
 * bytes of those outside the budget. */
static int create_buffers(ts_pipeline *p, const buffer_counts *counts, const scene_uploads *uploads,
                          ts_error *err)
{
    const buffer_counts c = *counts;
    const scene_uploads u = *uploads;
    const struct {
        cl_mem *m;
        cl_mem_flags flags;
        size_t bytes;
        const void *contents;
    } list[] = {
    /* clang-format off */
#define TS_RAY_ENTRY(type, name, what)                                                             \
        {&p->ray_##name, CL_MEM_READ_WRITE, c.rays * sizeof(type), NULL},
        TS_RAY_FIELDS(TS_RAY_ENTRY)
#undef TS_RAY_ENTRY
#define TS_PATH_ENTRY(type, name, what)                                                            \
        {&p->path_##name, CL_MEM_READ_WRITE, c.paths * sizeof(type), NULL},
        TS_PATH_FIELDS(TS_PATH_ENTRY)
#undef TS_PATH_ENTRY
#define TS_BUFFER_ENTRY(field, flags, type, count, contents)                                       \
        {&p->field, flags, (count) * sizeof(type), contents},
        TS_PIPELINE_BUFFERS(TS_BUFFER_ENTRY)
#undef TS_BUFFER_ENTRY
        /* clang-format on */
    };
    /* What the budget holds (pipeline_plan): the ray and path fields (the list's first
     * entries), the wave buffers and the arenas; the rest is outside it. */
    const cl_mem *budgeted[] = {&p->grid, &p->groups, &p->tight,
#define TS_BUFFER_ADDRESS(field, flags, type, count, contents) &p->field,
                                TS_PIPELINE_WAVE_BUFFERS(TS_BUFFER_ADDRESS)
#undef TS_BUFFER_ADDRESS
    };
    const size_t ray_entries = 0 TS_RAY_FIELDS(TS_COUNT_ONE) TS_PATH_FIELDS(TS_COUNT_ONE);
    /* What the scene lacks is one zeroed element; the largest is a patch's 16 control
     * points (256 bytes). */
    static const ts_vec4 zeros[16];
    uint64_t *fixed = &p->stats->counters[TS_COUNTER_device_bytes_fixed];
    uint64_t *in_place = &p->stats->counters[TS_COUNTER_device_bytes_in_place];
    *fixed = *in_place = 0;
    for (size_t i = 0; i < sizeof list / sizeof *list; ++i) {
        const void *host = list[i].contents ? list[i].contents : zeros;
        cl_mem_flags flags = list[i].flags;
        if (!(flags & CL_MEM_COPY_HOST_PTR)) host = NULL;
        if (host && array_in_place(p, host)) {
            flags = (flags & ~(cl_mem_flags)CL_MEM_COPY_HOST_PTR) | CL_MEM_USE_HOST_PTR;
            *in_place += list[i].bytes;
        }
        *list[i].m = dev_buffer_create(p->cl, flags, list[i].bytes, (void *)host, err);
        pipeline_note_device_bytes(p);
        if (!*list[i].m) return err->code;
        int in_budget = i < ray_entries;
        for (size_t k = 0; k < sizeof budgeted / sizeof *budgeted; ++k)
            in_budget |= list[i].m == budgeted[k];
        if (!in_budget) *fixed += list[i].bytes ? list[i].bytes : 1;
    }
    return TS_OK;
}

/* Releases the buffers whose size follows the rays of a wave (the ray and path fields,
 * TS_PIPELINE_WAVE_BUFFERS) and makes them again for the plan's ray_capacity and
 * pair_capacity, with no contents. */
static int remake_wave_buffers(ts_pipeline *p, ts_error *err)
{
    const buffer_counts c = {.rays = p->plan.ray_capacity,
                             .paths = TS_PATHS_OF_RAYS(p->plan.ray_capacity),
                             .pairs = p->plan.pair_capacity};
    const struct {
        cl_mem *m;
        cl_mem_flags flags;
        size_t bytes;
    } list[] = {
    /* clang-format off */
#define TS_RAY_ENTRY(type, name, what) {&p->ray_##name, CL_MEM_READ_WRITE, c.rays * sizeof(type)},
        TS_RAY_FIELDS(TS_RAY_ENTRY)
#undef TS_RAY_ENTRY
#define TS_PATH_ENTRY(type, name, what) {&p->path_##name, CL_MEM_READ_WRITE, c.paths * sizeof(type)},
        TS_PATH_FIELDS(TS_PATH_ENTRY)
#undef TS_PATH_ENTRY
#define TS_BUFFER_ENTRY(field, flags, type, count, contents) {&p->field, flags, (count) * sizeof(type)},
        TS_PIPELINE_WAVE_BUFFERS(TS_BUFFER_ENTRY)
#undef TS_BUFFER_ENTRY
        /* clang-format on */
    };
    for (size_t i = 0; i < sizeof list / sizeof *list; ++i)
        dev_buffer_release(p->cl, *list[i].m), *list[i].m = NULL;
    for (size_t i = 0; i < sizeof list / sizeof *list; ++i) {
        *list[i].m = dev_buffer_create(p->cl, list[i].flags, list[i].bytes, NULL, err);
        pipeline_note_device_bytes(p);
        if (!*list[i].m) return err->code;
    }
    return TS_OK;
}

/* The film starts black and "nothing hit"; the LOD counts and leaf utilisation at zero. */
static int clear_buffers(ts_pipeline *p, const buffer_counts *c, ts_error *err)
{
    const ts_vec4 zero = {0, 0, 0, 0};
    const cl_uint zero_u = 0, none = TS_INVALID;
    size_t film = c->film * sizeof(ts_vec4);
    if (dev_fill(p->cl, p->accum, &zero, sizeof zero, 0, film, "the film", err) ||
        dev_fill(p->cl, p->aov_film, &zero, sizeof zero, 0, film, "the AOV film", err) ||
        dev_fill(p->cl, p->albedo_film, &zero, sizeof zero, 0, film, "the albedo film", err) ||
        dev_fill(p->cl, p->lod_counts, &zero_u, sizeof zero_u, 0, c->patches * sizeof(cl_uint),
                 "the LOD counts", err) ||
        dev_fill(p->cl, p->cull_levels, &zero_u, sizeof zero_u, 0, c->patches * sizeof(cl_uint),
                 "the culling levels", err) ||
        dev_fill(p->cl, p->leaving, &zero_u, sizeof zero_u, 0, c->patches * sizeof(cl_uint),
                 "the leaving rays' patches", err) ||
        dev_fill(p->cl, p->utilisation, &zero_u, sizeof zero_u, 0,
                 2 * c->util_groups * sizeof(cl_uint), "the leaf utilisation", err) ||
        dev_fill(p->cl, p->grid_at, &none, sizeof none, 0, 3 * c->patches * sizeof(cl_uint),
                 "the resident grids' table", err))
        return err->code;
    p->util_used = 0;
    return TS_OK;
}

/* Discrete devices: the host copies of the two pair buffers that sort works on
 * (pipeline.h sort_host). TESSERA_SORT_VIA_COPY=1|0 overrides the choice (tests run both
 * paths on PoCL). */
static int create_sort_copies(ts_pipeline *p, ts_error *err)
{
    const char *via_copy = getenv("TESSERA_SORT_VIA_COPY");
    if (!(via_copy && *via_copy ? strcmp(via_copy, "0") != 0 : !p->cl->info.host_unified))
        return TS_OK;
    size_t bytes = (size_t)p->plan.pair_capacity * sizeof(ts_pair);
    for (int i = 0; i < 2; ++i)
        if (!(p->sort_host[i] = ts_page_alloc(bytes)))
            return ts_error_set(err, TS_E_MEMORY, "out of memory (%zu MiB of sort buffers)",
                                2 * bytes >> 20);
    if (!(p->sort_counts = malloc((size_t)p->plan.ray_capacity * sizeof *p->sort_counts + 4)))
        return ts_error_set(err, TS_E_MEMORY, "out of memory (sort counts)");
    return TS_OK;
}

/* Patches [begin, end) of create_host_tables: their boxes and rough levels. */
typedef struct patch_boxes {
    const ts_scene *scene;
    ts_box *boxes;
    uint8_t *rough_lod;
} patch_boxes;

static void patch_boxes_run(void *ctx, size_t begin, size_t end)
{
    const patch_boxes *t = ctx;
    for (size_t i = begin; i < end; ++i) {
        t->boxes[i] = scene_patch_box(t->scene, (uint32_t)i);
        t->rough_lod[i] =
            (uint8_t)scene_patch_rough_lod(t->scene, (uint32_t)i, t->boxes[i], TS_LOD_LIMIT);
    }
}

/* The host's per-patch tables and each patch's box (*boxes, freed by the caller). */
static int create_host_tables(ts_pipeline *p, ts_box **boxes, ts_error *err)
{
    const ts_scene *s = p->scene;
    size_t n = s->patch_count ? s->patch_count : 1;
    *boxes = ts_page_alloc(n * sizeof **boxes); /* array_in_place */
    p->segments_host = malloc(n * sizeof *p->segments_host);
    p->seg_grid = malloc(n);
    p->grid_mark = calloc(n, sizeof *p->grid_mark);
    p->trees_host = malloc(2 * n * sizeof *p->trees_host);
    p->batches = malloc(n * sizeof *p->batches);
    p->patch_lod = malloc(n);
    p->rough_lod = malloc(n);
    p->cull_key = calloc(n, sizeof *p->cull_key);
    p->skel_first_host = malloc(n * sizeof *p->skel_first_host);
    p->skel_key = calloc(n, 1);
    p->pixel_cost = calloc(p->pixel_count ? p->pixel_count : 1, sizeof *p->pixel_cost);
    p->grid_at_host = malloc(3 * n * sizeof *p->grid_at_host);
    if (!*boxes || !p->segments_host || !p->seg_grid || !p->grid_mark || !p->trees_host ||
        !p->batches || !p->patch_lod || !p->rough_lod || !p->cull_key || !p->grid_at_host ||
        !p->pixel_cost || !p->skel_first_host || !p->skel_key)
        return ts_error_set(err, TS_E_MEMORY, "out of memory");
    memset(p->grid_at_host, 0xff, 3 * n * sizeof *p->grid_at_host);
    memset(p->patch_lod, (int)p->plan.max_lod, n);
    patch_boxes t = {s, *boxes, p->rough_lod};
    ts_parallel_for(s->patch_count, PATCH_GRAIN, 0, patch_boxes_run, &t);
    return TS_OK;
}

void pipeline_note_device_bytes(ts_pipeline *p)
{
    uint64_t *peak = &p->stats->counters[TS_COUNTER_device_bytes_peak];
    if (p->cl->mem_peak > *peak) *peak = p->cl->mem_peak;
}

int pipeline_create(ts_pipeline *p, ts_device *cl, const ts_scene *scene,
                    const ts_pipeline_plan *plan, uint32_t pixel_count, ts_stats *stats,
                    ts_error *err)
{
    memset(p, 0, sizeof *p);
    p->cl = cl;
    p->scene = scene;
    p->stats = stats;
    p->plan = *plan;
    p->pixel_count = pixel_count;
    p->mode = (ts_trace_mode){1u, (int)plan->max_lod, 1, 0, 0u, 0, 1.0};
    p->top_level_run = TS_TOP_LEVEL_RUN;
    /* The peak of this pipeline's buffers: the attempt that finishes a render reports its own
     * (as memory_budget_bytes is its own), not one that ran out of memory before it. */
    dev_mem_peak_reset(cl);
    stats->counters[TS_COUNTER_device_bytes_peak] = 0;
    /* One bottom_level launch of every pair, plus one part-filled work-group per batch for
     * many batches (trace.c folds the counters early when an iteration needs more). 8 bytes
     * per 64 pairs: 1/64 of the pair buffers, left out of TS_BYTES_PER_RAY. */
    p->util_groups = plan->pair_capacity / TS_GROUP_SIZE + 256u;
    /* The patch boxes: the top-level BVH's leaves, build's clamp (patch_box) and the
     * secondary-ray offset (flatness w). */
    ts_box *boxes = NULL;
    scene_uploads u = {0};
    int rc = create_host_tables(p, &boxes, err);
    if (rc == TS_OK) rc = qbvh_build(&p->qbvh, boxes, scene->patch_count, plan->sort_threads, err);
    if (rc == TS_OK && !(p->sorter = radix_sorter_create((int)plan->sort_threads, err)))
        rc = err->code;
    if (rc == TS_OK) rc = create_kernels(p, err);
    if (rc == TS_OK) rc = scene_uploads_make(p, boxes, &u, err);
    if (rc == TS_OK) rc = tex_cache_create(&p->tex, scene, plan->tex_pool_bytes, err);
    buffer_counts c = buffer_counts_of(p, &u);
    p->box_host = scene->patch_count ? boxes : NULL, p->flatness_host = u.flatness;
    if (rc == TS_OK) rc = create_buffers(p, &c, &u, err);
    /* What the device reads in place stays until pipeline_destroy has released its buffers
     * and frees it (also after a failure); the rest goes below. */
    if (array_in_place(p, p->box_host))
        boxes = NULL;
    else
        p->box_host = NULL;
    if (array_in_place(p, p->flatness_host))
        u.flatness = NULL;
    else
        p->flatness_host = NULL;
    p->light_count = u.lights.light_count;
    p->unseen_flags = 0;
    for (uint32_t i = 0; i < scene->patch_count; ++i)
        p->unseen_flags |=
            scene->attr[i].flags & (TS_PATCH_NO_SHADOW | TS_PATCH_NO_CAMERA | TS_PATCH_NO_INDIRECT);
    p->relight = u.relight.params;
    scene_uploads_free(&u);
    free(boxes);
    /* The device has the top-level BVH now; the host's nodes are never read again (about 64
     * bytes a patch) unless they are the buffer (array_in_place). node_count stays. */
    if (!array_in_place(p, p->qbvh.nodes)) free(p->qbvh.nodes), p->qbvh.nodes = NULL;
    if (rc == TS_OK)
        rc = tex_cache_upload_initial(&p->tex, cl, p->tex_pool, p->tex_pages, scene, stats, err);
    if (rc == TS_OK) rc = clear_buffers(p, &c, err);
    if (rc == TS_OK) rc = create_sort_copies(p, err);
    if (rc == TS_OK)
        rc = patch_cache_create(&p->cache, scene->patch_count, plan->vert_capacity,
                                plan->group_capacity, err);
    const char *cache_env = getenv("TESSERA_PATCH_CACHE");
    p->cache_off = cache_env && strcmp(cache_env, "0") == 0;
    const char *grid_env = getenv("TESSERA_GRID_NORMALS");
    p->grid_off = grid_env && strcmp(grid_env, "0") == 0;
    if (rc != TS_OK) {
        pipeline_destroy(p);
        return rc;
    }
    stats->counters[TS_COUNTER_micropolygons_potential] = (uint64_t)scene->patch_count
                                                          << (2u * plan->max_lod);
    stats->counters[TS_COUNTER_patch_cache_bytes] = pipeline_arena_bytes(plan);
    return TS_OK;
}

void pipeline_destroy(ts_pipeline *p)
{
    const cl_kernel kernels[] = {
#define TS_KERNEL_HANDLE(field, name) p->field,
        TS_PIPELINE_KERNELS(TS_KERNEL_HANDLE)
#undef TS_KERNEL_HANDLE
    };
    for (size_t i = 0; i < sizeof kernels / sizeof *kernels; ++i)
        if (kernels[i]) clReleaseKernel(kernels[i]);
    const cl_mem buffers[] = {
    /* clang-format off */
#define TS_RAY_HANDLE(type, name, what) p->ray_##name,
        TS_RAY_FIELDS(TS_RAY_HANDLE)
#undef TS_RAY_HANDLE
#define TS_PATH_HANDLE(type, name, what) p->path_##name,
        TS_PATH_FIELDS(TS_PATH_HANDLE)
#undef TS_PATH_HANDLE
#define TS_BUFFER_HANDLE(field, flags, type, count, contents) p->field,
        TS_PIPELINE_BUFFERS(TS_BUFFER_HANDLE)
#undef TS_BUFFER_HANDLE
        /* clang-format on */
    };
    for (size_t i = 0; i < sizeof buffers / sizeof *buffers; ++i)
        dev_buffer_release(p->cl, buffers[i]);
    bake_stage_destroy(p->cl, p->bake);
    if (p->sorter) radix_sorter_destroy(p->sorter);
    free(p->sort_host[0]);
    free(p->sort_host[1]);
    free(p->sort_counts);
    tex_cache_free(&p->tex);
    patch_cache_free(&p->cache);
    free(p->segments_host);
    free(p->seg_grid);
    free(p->grid_mark);
    free(p->trees_host);
    free(p->batches);
    free(p->patch_lod), free(p->rough_lod);
    free(p->cull_key);
    free(p->skel_first_host);
    free(p->skel_key);
    if (p->skel) dev_buffer_release(p->cl, p->skel);
    free(p->pixel_cost);
    free(p->grid_at_host);
    free(p->edge_nb);
    free(p->box_host);
    free(p->flatness_host);
    qbvh_free(&p->qbvh);
    memset(p, 0, sizeof *p);
}

ts_camera_params pipeline_full_frame(const ts_camera_params *cam)
{
    ts_camera_params c = *cam;
    if (c.full_width) {
        c.width = c.full_width, c.height = c.full_height;
        c.crop_x = c.crop_y = 0;
    }
    c.full_width = c.width, c.full_height = c.height;
    return c;
}

int pipeline_camera(ts_pipeline *p, const ts_camera_params *cam, ts_error *err)
{
    ts_camera_params c = *cam;
    if (!c.full_width)
        c.full_width = c.width, c.full_height = c.height; /* the image is the frame */
    ts_order_divs ord = sample_order_divs(c.width * c.height, c.width, c.spp, c.band);
    uint32_t paths = TS_PATHS_OF_RAYS(p->plan.ray_capacity);
    if (dev_set_args(p->k_camera, err, DEV_ARG(c), DEV_ARG(ord), DEV_ARG(p->ray_org),
                     DEV_ARG(p->ray_dir), DEV_ARG(p->ray_hit), DEV_ARG(p->ray_entry),
                     DEV_ARG(p->ray_pixel), DEV_ARG(p->ray_flags), DEV_ARG(p->ray_from),
                     DEV_ARG(p->active), DEV_ARG(p->wave_paths), DEV_ARG(p->path_throughput),
                     DEV_ARG(p->path_mis), DEV_ARG(p->path_state), DEV_ARG(p->radiance),
                     DEV_ARG(paths), (size_t)0))
        return err->code;
    /* Eight rays a work-item where the kernels have CPU lanes (kernels/camera.cl). */
    size_t items = p->cl->cpu_lanes ? ((size_t)c.ray_count + 7) / 8 : c.ray_count;
    return dev_launch(p->cl, p->k_camera, TS_STAGE_camera, items, TS_LOCAL_SIZE, err);
}

int pipeline_lod_count(ts_pipeline *p, uint32_t ray_count, int before_hit, ts_error *err)
{
    uint32_t use_hit = before_hit != 0;
    if (dev_set_args(p->k_lod, err, DEV_ARG(p->qbvh_nodes), DEV_ARG(ray_count), DEV_ARG(p->ray_org),
                     DEV_ARG(p->ray_dir), DEV_ARG(p->ray_hit), DEV_ARG(use_hit),
                     DEV_ARG(p->lod_counts), DEV_ARG(p->count), (size_t)0))
        return err->code;
    return dev_launch(p->cl, p->k_lod, TS_STAGE_lod, ray_count, TS_LOCAL_SIZE, err);
}

/* The smallest m with 4^m >= count / rate^2, at most max_lod (ts_trace_mode dicing_rate;
 * 0, as a zero-initialised mode has it, is 1). At rate 1 the quotient is the count itself,
 * exact in a double, so the comparison is the integer rule 4^m >= count. */
static uint32_t lod_of_count(uint32_t count, uint32_t max_lod, double rate)
{
    if (!(rate > 0.0)) rate = 1.0;
    double need = (double)count / (rate * rate);
    uint32_t m = 0;
    while (m < max_lod && (double)((uint64_t)1 << (2 * m)) < need)
        ++m;
    return m;
}

/* One m for a master and the instances that share its dicing (scene.h instancing): the
 * finest any of them asks for, so the master is diced once per frame for all of them. An
 * instance may thus be diced finer than its copy would be: the only way its image differs
 * from the copy's beyond rounding (docs/rib.md "Objects"). */
static void lod_share(ts_pipeline *p)
{
    const ts_scene *s = p->scene;
    if (!s->shape) return;
    for (uint32_t i = 0; i < s->patch_count; ++i) {
        uint32_t q = s->shape[i];
        if (p->patch_lod[i] > p->patch_lod[q]) p->patch_lod[q] = p->patch_lod[i];
    }
    for (uint32_t i = 0; i < s->patch_count; ++i)
        p->patch_lod[i] = p->patch_lod[s->shape[i]];
}

int pipeline_lod_take_counts(ts_pipeline *p, uint32_t *counts, ts_error *err)
{
    uint32_t n = p->scene->patch_count;
    const cl_uint zero = 0;
    if (n == 0) return TS_OK;
    if (dev_finish(p->cl, p->stats, err) ||
        dev_read(p->cl, p->lod_counts, 0, n * sizeof *counts, counts, "the LOD counts", err) ||
        dev_fill(p->cl, p->lod_counts, &zero, sizeof zero, 0, n * sizeof *counts, "the LOD counts",
                 err))
        return err->code;
    return TS_OK;
}

int pipeline_lod_finish(ts_pipeline *p, ts_lod_rule rule, int before_hit, ts_error *err)
{
    return pipeline_lod_finish_with(p, rule, before_hit, NULL, err);
}

int pipeline_lod_finish_with(ts_pipeline *p, ts_lod_rule rule, int before_hit, const uint32_t *more,
                             ts_error *err)
{
    uint32_t n = p->scene->patch_count;
    if (n == 0) return TS_OK;
    if (dev_finish(p->cl, p->stats, err)) return err->code;
    double t0 = stats_now();
    uint32_t *counts = malloc(n * sizeof *counts);
    int rc = counts ? TS_OK : ts_error_set(err, TS_E_MEMORY, "out of memory");
    if (rc == TS_OK) rc = pipeline_lod_take_counts(p, counts, err);
    for (uint32_t i = 0; rc == TS_OK && more && i < n; ++i)
        counts[i] += more[i]; /* integer sums: the same in any order */
    for (uint32_t i = 0; rc == TS_OK && i < n; ++i) {
        uint32_t m = lod_of_count(counts[i], p->plan.max_lod, p->mode.dicing_rate);
        if (before_hit) { /* p->patch_lod holds m from every crossing */
            uint32_t crossed = p->patch_lod[i];
            uint32_t coarser =
                crossed > TS_LOD_HIDDEN_COARSER ? crossed - TS_LOD_HIDDEN_COARSER : 0u;
            if (rule == TS_LOD_RULE_SEEN)
                m = counts[i] > 0 ? crossed : coarser;
            else
                m = m > coarser ? m : coarser;
        }
        p->patch_lod[i] = (uint8_t)m;
    }
    free(counts);
    if (rc == TS_OK) lod_share(p);
    /* In triangle mode a patch's grid also depends on its neighbours' levels (stitching), so
     * what was diced at the old levels goes, and so do the culling copies of its trees. */
    if (rc == TS_OK && p->mode.exact) {
        patch_cache_clear(&p->cache);
        for (uint32_t i = 0; i < n; ++i)
            if (p->cull_key[i]) p->cull_key[i] = UINT16_MAX;
    }
    /* Otherwise the patch cache keeps its patches (each is keyed by its m, so one whose level
     * changed is simply diced again when a segment asks for it) unless the new levels give its
     * size classes other quotas (pipeline_cache_plan, at the next trace). */
    p->cache_planned = 0;
    p->skel_planned = 0; /* skeletons are laid out by m */
    p->stats->stage_seconds[TS_STAGE_lod] += stats_now() - t0;
    return rc;
}

/* Counts the first sample pass's pixels [begin, end) of the whole frame (one ray each; with a
 * CropWindow the frame's pixels, not only the image's, so that each patch gets the level it
 * has in the whole frame and the image its pixels), wave by wave; pass 1 traces them first
 * and counts only the entries before their hits. */
static int lod_count_pixels(ts_pipeline *p, const ts_camera_params *cam, uint32_t begin,
                            uint32_t end, int pass, ts_error *err)
{
    ts_camera_params c = pipeline_full_frame(cam);
    int part = c.width != cam->width || c.height != cam->height; /* a CropWindow */
    uint32_t cx = cam->crop_x, cy = cam->crop_y;                 /* where the part lies */
    c.band = 0; /* samples [0, pixels) are the first sample pass, whatever the frame's order */
    uint32_t per_wave = p->plan.ray_capacity;
    int rc = TS_OK;
    p->wave = 0;
    p->in_lod = 1;
    for (uint32_t first = begin; rc == TS_OK && first < end; first += per_wave) {
        uint32_t n = end - first < per_wave ? end - first : per_wave;
        c.first_sample = first;
        c.ray_count = n;
        if (pipeline_camera(p, &c, err) || (pass && pipeline_trace(p, n, err)) ||
            pipeline_lod_count(p, n, pass, err))
            rc = err->code;
        /* Pass 0's crossings, one ray a pixel: the pixels' costs (pipeline.h pixel_cost). */
        if (rc == TS_OK && !pass && p->pixel_cost && !part && first + n <= p->pixel_count) {
            uint32_t *cost = p->pixel_cost + first;
            if (dev_read(p->cl, p->count, 0, (size_t)n * sizeof *cost, cost, "the crossings", err))
                rc = err->code;
            for (uint32_t i = 0; rc == TS_OK && i < n; ++i)
                cost[i] += 1u; /* 0: a pixel not counted */
        } else if (rc == TS_OK && !pass && p->pixel_cost && part &&
                   (uint64_t)cam->width * cam->height <= p->pixel_count) { /* the image's part */
            uint32_t *cross = malloc((size_t)n * sizeof *cross);
            if (!cross) rc = ts_error_set(err, TS_E_MEMORY, "out of memory for the crossings");
            if (rc == TS_OK && dev_read(p->cl, p->count, 0, (size_t)n * sizeof *cross, cross,
                                        "the crossings", err))
                rc = err->code;
            for (uint32_t i = 0; rc == TS_OK && i < n; ++i) {
                uint32_t y = (first + i) / c.width, x = (first + i) - y * c.width;
                if (x >= cx && x - cx < cam->width && y >= cy && y - cy < cam->height)
                    p->pixel_cost[(size_t)(y - cy) * cam->width + (x - cx)] = cross[i] + 1u;
            }
            free(cross);
        }
    }
    p->in_lod = 0;
    return rc;
}

int pipeline_lod_count_pixels(ts_pipeline *p, const ts_camera_params *cam, uint32_t begin,
                              uint32_t end, ts_error *err)
{
    return lod_count_pixels(p, cam, begin, end, 0, err);
}

int pipeline_lod(ts_pipeline *p, const ts_camera_params *cam, ts_lod_rule rule, ts_error *err)
{
    uint32_t pixels = pipeline_frame_pixels(cam);
    int rc = TS_OK;
    for (int pass = 0; rc == TS_OK && pass < (rule == TS_LOD_RULE_CROSSED ? 1 : 2); ++pass) {
        rc = lod_count_pixels(p, cam, 0, pixels, pass, err);
        if (rc == TS_OK && pipeline_lod_finish(p, rule, pass, err)) rc = err->code;
    }
    return rc;
}

uint32_t pipeline_patch_lod(const ts_pipeline *p, uint32_t patch)
{
    int fixed = p->mode.fixed_lod;
    if (fixed < 0) return p->patch_lod[patch];
    return (uint32_t)fixed < p->plan.max_lod ? (uint32_t)fixed : p->plan.max_lod;
}

uint64_t pipeline_arena_bytes(const ts_pipeline_plan *plan)
{
    return (uint64_t)plan->vert_capacity * sizeof(ts_vec4) +
           (uint64_t)plan->group_capacity * TS_GROUP_BYTES;
}

/* How many of the frame's patches each size class (patch_cache.h) holds at their levels of
 * detail; an instance that shares its master's dicing counts none of its own. */
static void class_need(const ts_pipeline *p, uint64_t need[TS_CACHE_CLASSES])
{
    memset(need, 0, TS_CACHE_CLASSES * sizeof *need);
    for (uint32_t i = 0; i < p->scene->patch_count; ++i) {
        uint32_t m = pipeline_patch_lod(p, i), q = scene_shape(p->scene, i);
        if (q != i && pipeline_patch_lod(p, q) == m) continue; /* diced as its master */
        need[TS_CACHE_CLASS(m, p->scene->attr[i].flags & TS_PATCH_MOVING ? 2u : 1u)]++;
    }
}

/* The arena entries of need[] patches a class. */
static void need_entries(const uint64_t need[TS_CACHE_CLASSES], uint64_t *verts, uint64_t *groups)
{
    *verts = *groups = 0;
    for (uint32_t m = 0; m <= TS_LOD_LIMIT; ++m)
        for (uint32_t t = 1; t <= 2; ++t) {
            *verts += need[TS_CACHE_CLASS(m, t)] * patch_cache_vert_count(m, t);
            *groups += need[TS_CACHE_CLASS(m, t)] * patch_cache_group_count(m, t);
        }
}

void pipeline_arena_need(const ts_pipeline *p, uint64_t *verts, uint64_t *groups)
{
    uint64_t need[TS_CACHE_CLASSES];
    class_need(p, need);
    need_entries(need, verts, groups);
}

uint64_t pipeline_arena_need_bytes(const ts_pipeline *p)
{
    uint64_t verts, groups;
    pipeline_arena_need(p, &verts, &groups);
    return verts * sizeof(ts_vec4) + groups * TS_GROUP_BYTES;
}

void pipeline_cache_plan(ts_pipeline *p)
{
    if (p->cache_planned && p->planned_fixed_lod == p->mode.fixed_lod) return;
    uint64_t need[TS_CACHE_CLASSES], verts, groups;
    class_need(p, need);
    patch_cache_plan(&p->cache, need);
    need_entries(need, &verts, &groups);
    p->stats->counters[TS_COUNTER_patch_cache_need_bytes] =
        verts * sizeof(ts_vec4) + groups * TS_GROUP_BYTES;
    for (uint32_t m = 0; m <= TS_LOD_LIMIT; ++m)
        p->stats->frame_lod_histogram[m] = need[TS_CACHE_CLASS(m, 1)] + need[TS_CACHE_CLASS(m, 2)];
    p->cache_planned = 1;
    p->planned_fixed_lod = p->mode.fixed_lod;
}

void pipeline_arena_places(const ts_pipeline *p, uint32_t *vert_first, uint32_t *group_first,
                           uint8_t *lod, uint64_t *verts, uint64_t *groups)
{
    *verts = *groups = 0;
    for (uint32_t i = 0; i < p->scene->patch_count; ++i) {
        uint32_t m = pipeline_patch_lod(p, i), q = scene_shape(p->scene, i);
        lod[i] = (uint8_t)m;
        vert_first[i] = group_first[i] = UINT32_MAX;
        if (q != i && pipeline_patch_lod(p, q) == m) continue; /* diced as its master */
        uint64_t times = p->scene->attr[i].flags & TS_PATCH_MOVING ? 2u : 1u;
        /* past UINT32_MAX the caller's check of *verts and *groups refuses the places */
        vert_first[i] = (uint32_t)*verts, group_first[i] = (uint32_t)*groups;
        *verts += times * quadtree_vertex_count(m);
        *groups += times * quadtree_group_count(m);
    }
}

/* The three arena buffers of verts vertices and groups sibling groups (over the caller's host
 * memory grid, tree and tight with CL_MEM_USE_HOST_PTR, or allocated when grid is NULL) into
 * p->grid, p->groups and p->tight, which are NULL; on an error those made are released. */
static int arena_buffers_make(ts_pipeline *p, void *grid, void *tree, void *tight, uint64_t verts,
                              uint64_t groups, ts_error *err)
{
    cl_mem_flags flags = CL_MEM_READ_WRITE | (grid ? CL_MEM_USE_HOST_PTR : 0);
    p->grid = dev_buffer_create(p->cl, flags, verts * sizeof(ts_vec4), grid, err);
    if (p->grid) p->groups = dev_buffer_create(p->cl, flags, groups * sizeof(ts_box4), tree, err);
    if (p->groups)
        p->tight = dev_buffer_create(p->cl, flags, groups * sizeof(ts_tight4), tight, err);
    pipeline_note_device_bytes(p);
    if (p->tight) return TS_OK;
    dev_buffer_release(p->cl, p->grid), p->grid = NULL;
    dev_buffer_release(p->cl, p->groups), p->groups = NULL;
    return err->code;
}

/* New arenas of verts vertices and groups sibling groups (arena_buffers_make) and a patch
 * cache over them (with the fixed places vert_first, group_first and lod when given),
 * replacing the old ones. The old buffers are released before the new ones are made, so the
 * two are never held at once: the arenas never take more than the budget gave them (--stats
 * device_bytes_peak). When the new ones cannot be made, arenas of the old sizes are made
 * again, empty, and the error returned; when not even those can be (p->grid NULL), the
 * pipeline is unusable. */
static int arenas_replace(ts_pipeline *p, void *grid, void *tree, void *tight, uint64_t verts,
                          uint64_t groups, const uint32_t *vert_first, const uint32_t *group_first,
                          const uint8_t *lod, ts_error *err)
{
    uint64_t max_alloc = p->cl->info.max_alloc;
    if (verts > UINT32_MAX || groups > UINT32_MAX || verts * sizeof(ts_vec4) > max_alloc ||
        groups * sizeof(ts_box4) > max_alloc)
        return ts_error_set(err, TS_E_USAGE,
                            "the arenas would exceed the device's largest buffer, %llu MB",
                            (unsigned long long)(max_alloc >> 20));
    if (dev_finish(p->cl, p->stats, err)) return err->code; /* nothing uses the old ones */
    ts_patch_cache cache;
    int rc = vert_first ? patch_cache_create_placed(&cache, p->scene->patch_count, vert_first,
                                                    group_first, lod, err)
                        : patch_cache_create(&cache, p->scene->patch_count, (uint32_t)verts,
                                             (uint32_t)groups, err);
    if (rc) return rc; /* the old ones stay, as they were */
    dev_buffer_release(p->cl, p->grid), p->grid = NULL;
    dev_buffer_release(p->cl, p->groups), p->groups = NULL;
    dev_buffer_release(p->cl, p->tight), p->tight = NULL;
    rc = arena_buffers_make(p, grid, tree, tight, verts, groups, err);
    if (rc) {
        patch_cache_free(&cache);
        ts_error again = {0};
        if (!arena_buffers_make(p, NULL, NULL, NULL, p->plan.vert_capacity, p->plan.group_capacity,
                                &again))
            patch_cache_clear(&p->cache); /* their patches went with the old buffers */
        ts_error_clear(&again);
        p->cache_planned = 0;
        return rc;
    }
    /* The cache's counters go on over the frame. */
    cache.hits = p->cache.hits, cache.misses = p->cache.misses;
    cache.evictions = p->cache.evictions;
    cache.peak_bytes = p->cache.peak_bytes;
    patch_cache_free(&p->cache);
    p->cache = cache;
    p->plan.vert_capacity = (uint32_t)verts;
    p->plan.group_capacity = (uint32_t)groups;
    p->cache_planned = 0; /* an empty cache: its quotas are planned at the next trace */
    p->stats->counters[TS_COUNTER_patch_cache_bytes] = pipeline_arena_bytes(&p->plan);
    return TS_OK;
}

int pipeline_place_arenas(ts_pipeline *p, void *grid, void *tree, void *tight, uint64_t verts,
                          uint64_t groups, const uint32_t *vert_first, const uint32_t *group_first,
                          const uint8_t *lod, ts_error *err)
{
    return arenas_replace(p, grid, tree, tight, verts, groups, vert_first, group_first, lod, err);
}

int pipeline_grow_arenas(ts_pipeline *p, uint64_t verts, uint64_t groups, ts_error *err)
{
    return arenas_replace(p, NULL, NULL, NULL, verts, groups, NULL, NULL, NULL, err);
}

int pipeline_stitch_prepare(ts_pipeline *p, ts_error *err)
{
    if (!p->mode.exact || p->edge_nb) return TS_OK;
    size_t n = p->scene->patch_count ? p->scene->patch_count : 1;
    if (!(p->edge_nb = malloc(4 * n * sizeof *p->edge_nb)))
        return ts_error_set(err, TS_E_MEMORY, "out of memory (the patches' edges)");
    if (scene_edge_neighbours(p->scene, p->edge_nb, err)) {
        free(p->edge_nb), p->edge_nb = NULL;
        return err->code;
    }
    return TS_OK;
}

uint32_t pipeline_stitch_edges(const ts_pipeline *p, uint32_t patch, uint32_t m)
{
    uint32_t edges = 0;
    if (!p->mode.exact || !p->edge_nb) return 0;
    for (uint32_t k = 0; k < 4; ++k) {
        uint32_t nb = p->edge_nb[4 * (size_t)patch + k];
        uint32_t mn = nb == TS_INVALID ? m : pipeline_patch_lod(p, nb);
        if (mn < m) edges |= (m - mn < 15u ? m - mn : 15u) << (4 * k);
    }
    return edges;
}

/* Writes grid_at for shade where the patch cache changed since the last time: vert_first
 * and m of each patch resident in the arenas (its own dicing, not a master's), TS_INVALID
 * elsewhere, or everywhere with TESSERA_GRID_NORMALS=0; and each patch's stitched edges. */
int pipeline_grid_publish(ts_pipeline *p, ts_error *err)
{
    size_t n = p->scene->patch_count ? p->scene->patch_count : 1;
    int changed = 0;
    for (uint32_t i = 0; i < p->scene->patch_count; ++i) {
        const ts_cache_entry *e = &p->cache.entry[i];
        /* entries are per patch diced (its shape); gridded: its vertices too */
        int ok = !p->grid_off && e->resident && e->gridded;
        uint32_t first = ok ? e->vert_first : TS_INVALID, m = ok ? e->lod : TS_INVALID;
        uint32_t edges = pipeline_stitch_edges(p, i, pipeline_patch_lod(p, i));
        uint32_t *at = &p->grid_at_host[3 * (size_t)i];
        if (at[0] != first || at[1] != m || at[2] != edges)
            at[0] = first, at[1] = m, at[2] = edges, changed = 1;
    }
    if (!changed) return TS_OK;
    return dev_write(p->cl, p->grid_at, 0, 3 * n * sizeof *p->grid_at_host, p->grid_at_host,
                     "the resident grids' table", err);
}

int pipeline_resize_rays(ts_pipeline *p, uint32_t rays, ts_error *err)
{
    if (rays < TS_LOCAL_SIZE || rays > (1u << 25))
        return ts_error_set(err, TS_E_INTERNAL, "waves of %u rays", rays);
    if (dev_finish(p->cl, p->stats, err)) return err->code; /* nothing uses the old ones */
    for (int i = 0; i < 2; ++i)
        free(p->sort_host[i]), p->sort_host[i] = NULL;
    free(p->sort_counts), p->sort_counts = NULL;
    p->plan.ray_capacity = rays;
    p->plan.pair_capacity = rays * TS_PAIRS_PER_RAY;
    /* The utilisation counters keep their buffer: a bottom_level launch covers at most
     * util_groups work-groups (trace.c stage_bottom_level), folding between launches. */
    if (remake_wave_buffers(p, err) || create_sort_copies(p, err)) return err->code;
    return TS_OK;
}

int pipeline_lod_rule_parse(const char *name, ts_lod_rule *rule)
{
    static const char *const names[] = {"crossed", "visible", "seen"};
    for (int i = 0; i < 3; ++i)
        if (strcmp(name, names[i]) == 0) {
            *rule = (ts_lod_rule)i;
            return 0;
        }
    return -1;
}
