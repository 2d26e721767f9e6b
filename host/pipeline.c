#include "pipeline.h"
#include "lib/quadtree.h"

#include <stdlib.h>
#include <string.h>

static uint64_t slot_bytes(uint32_t m)
{
    return (uint64_t)quadtree_vertex_count(m) * sizeof(ts_vec4) +
           (uint64_t)quadtree_group_count(m) * sizeof(ts_box4);
}

int pipeline_plan(uint64_t memory_bytes, uint64_t rays_wanted, uint32_t max_lod,
                  uint64_t max_alloc, ts_pipeline_plan *plan, ts_error *err)
{
    if (max_lod > TS_LOD_LIMIT)
        return ts_error_set(err, TS_E_USAGE, "--max-lod %u is above the limit %d", max_lod,
                            TS_LOD_LIMIT);
    uint64_t per_slot = slot_bytes(max_lod);
    uint64_t slots = memory_bytes / 4 / per_slot;
    if (slots < 1) slots = 1;
    if (slots > 256) slots = 256; /* more slots than this only lengthens batches */
    uint64_t node_bytes = (uint64_t)quadtree_group_count(max_lod) * sizeof(ts_box4);
    if (slots * node_bytes > max_alloc) slots = max_alloc / node_bytes;
    if (slots < 1 || per_slot > memory_bytes)
        return ts_error_set(err, TS_E_USAGE,
                            "--memory %llu MB cannot hold one patch slot at --max-lod %u "
                            "(%llu MB); raise --memory or lower --max-lod",
                            (unsigned long long)(memory_bytes >> 20), max_lod,
                            (unsigned long long)((per_slot + (1 << 20) - 1) >> 20));
    uint64_t rest = memory_bytes - slots * per_slot;
    uint64_t rays = rest / TS_BYTES_PER_RAY;
    uint64_t biggest_per_ray = TS_PAIRS_PER_RAY * sizeof(ts_hit); /* pair_hit buffer */
    if (rays * biggest_per_ray > max_alloc) rays = max_alloc / biggest_per_ray;
    if (rays > rays_wanted) rays = rays_wanted;
    if (rays > (1u << 28)) rays = 1u << 28; /* indices stay far from 32-bit overflow */
    if (rays < TS_LOCAL_SIZE && rays < rays_wanted)
        return ts_error_set(err, TS_E_USAGE, "--memory %llu MB leaves no room for rays",
                            (unsigned long long)(memory_bytes >> 20));
    plan->ray_capacity = (uint32_t)rays;
    plan->pair_capacity = (uint32_t)rays * TS_PAIRS_PER_RAY;
    plan->slot_count = (uint32_t)slots;
    plan->max_lod = max_lod;
    return TS_OK;
}

static int create_kernels(ts_pipeline *p, ts_error *err)
{
    struct {
        cl_kernel *k;
        const char *name;
    } list[] = {
        {&p->k_camera, "camera_generate"},   {&p->k_top_level, "top_level_collect"},
        {&p->k_dice, "dice_grid"},           {&p->k_build_leaves, "build_leaves"},
        {&p->k_build_level, "build_level"},  {&p->k_bottom_level, "bottom_level_trace"},
        {&p->k_resolve, "resolve_closest"},  {&p->k_shade, "shade_lambert"},
        {&p->k_film, "film_accumulate"},
    };
    for (size_t i = 0; i < sizeof list / sizeof *list; ++i)
        if (!(*list[i].k = cl_kernel_create(p->cl, list[i].name, err))) return err->code;
    return TS_OK;
}

static int create_buffers(ts_pipeline *p, ts_error *err)
{
    ts_cl *cl = p->cl;
    const ts_scene *s = p->scene;
    size_t rays = p->plan.ray_capacity, pairs = p->plan.pair_capacity;
    size_t slots = p->plan.slot_count;
    const cl_mem_flags ro_copy = CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR;
    const cl_mem_flags host_rw = CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR;
    struct {
        cl_mem *m;
        cl_mem_flags flags;
        size_t size;
        void *host;
    } list[] = {
        {&p->qbvh_nodes, ro_copy, p->qbvh.node_count * sizeof(ts_qbvh_node), p->qbvh.nodes},
        {&p->cp, ro_copy, (size_t)s->patch_count * 16 * sizeof(ts_vec4), s->cp},
        {&p->attr, ro_copy, (size_t)s->patch_count * sizeof(ts_patch_attr), s->attr},
#define TS_RAY_ALLOC(type, name, what) {&p->ray_##name, CL_MEM_READ_WRITE, rays * sizeof(type), NULL},
        TS_RAY_FIELDS(TS_RAY_ALLOC)
#undef TS_RAY_ALLOC
        {&p->active, host_rw, rays * sizeof(uint32_t), NULL},
        {&p->count, CL_MEM_READ_WRITE, rays * sizeof(uint32_t), NULL},
        {&p->alive, host_rw, rays * sizeof(uint32_t), NULL},
        {&p->pairs[0], host_rw, pairs * sizeof(ts_pair), NULL},
        {&p->pairs[1], host_rw, pairs * sizeof(ts_pair), NULL},
        {&p->pair_hit, CL_MEM_READ_WRITE, pairs * sizeof(ts_hit), NULL},
        {&p->segments, CL_MEM_READ_ONLY, (s->patch_count ? s->patch_count : 1) * sizeof(ts_segment), NULL},
        {&p->grid, CL_MEM_READ_WRITE, slots * p->verts_per_slot * sizeof(ts_vec4), NULL},
        {&p->nodes, CL_MEM_READ_WRITE, slots * p->groups_per_slot * sizeof(ts_box4), NULL},
        {&p->radiance, CL_MEM_READ_WRITE, rays * sizeof(ts_vec4), NULL},
        {&p->aov, CL_MEM_READ_WRITE, rays * sizeof(ts_vec4), NULL},
        {&p->accum, host_rw, (size_t)p->pixel_count * sizeof(ts_vec4), NULL},
        {&p->aov_film, host_rw, (size_t)p->pixel_count * sizeof(ts_vec4), NULL},
    };
    for (size_t i = 0; i < sizeof list / sizeof *list; ++i) {
        *list[i].m = cl_buffer_create(cl, list[i].flags, list[i].size, list[i].host, err);
        if (!*list[i].m) return err->code;
    }
    /* The film starts black; the aov film starts as "nothing hit". */
    ts_vec4 zero = {0, 0, 0, 0};
    CL_CHECK(clEnqueueFillBuffer(cl->queue, p->accum, &zero, sizeof zero, 0,
                                 (size_t)p->pixel_count * sizeof(ts_vec4), 0, NULL, NULL),
             err);
    CL_CHECK(clEnqueueFillBuffer(cl->queue, p->aov_film, &zero, sizeof zero, 0,
                                 (size_t)p->pixel_count * sizeof(ts_vec4), 0, NULL, NULL),
             err);
    return TS_OK;
}

int pipeline_create(ts_pipeline *p, ts_cl *cl, const ts_scene *scene, const ts_pipeline_plan *plan,
                    uint32_t pixel_count, ts_stats *stats, ts_error *err)
{
    memset(p, 0, sizeof *p);
    p->cl = cl;
    p->scene = scene;
    p->stats = stats;
    p->plan = *plan;
    p->pixel_count = pixel_count;
    p->verts_per_slot = quadtree_vertex_count(plan->max_lod);
    p->leaves_per_slot = 1u << (2u * plan->max_lod);
    p->groups_per_slot = quadtree_group_count(plan->max_lod);
    ts_box *boxes = malloc((scene->patch_count ? scene->patch_count : 1) * sizeof *boxes);
    p->segments_host = malloc((scene->patch_count ? scene->patch_count : 1) * sizeof(ts_segment));
    if (!boxes || !p->segments_host) {
        free(boxes);
        return ts_error_set(err, TS_E_MEMORY, "out of memory");
    }
    for (uint32_t i = 0; i < scene->patch_count; ++i) boxes[i] = scene_patch_box(scene, i);
    int rc = qbvh_build(&p->qbvh, boxes, scene->patch_count, err);
    free(boxes);
    if (rc) return rc;
    if (!(p->sorter = radix_sorter_create(0, err))) return err->code;
    if (create_kernels(p, err) || create_buffers(p, err)) return err->code;
    stats->counters[TS_COUNTER_micropolygons_potential] =
        (uint64_t)scene->patch_count << (2u * plan->max_lod);
    return TS_OK;
}

void pipeline_destroy(ts_pipeline *p)
{
    cl_kernel ks[] = {p->k_camera, p->k_top_level, p->k_dice, p->k_build_leaves, p->k_build_level,
                      p->k_bottom_level, p->k_resolve, p->k_shade, p->k_film};
    for (size_t i = 0; i < sizeof ks / sizeof *ks; ++i)
        if (ks[i]) clReleaseKernel(ks[i]);
    cl_mem ms[] = {p->qbvh_nodes, p->cp, p->attr,
#define TS_RAY_RELEASE(type, name, what) p->ray_##name,
                   TS_RAY_FIELDS(TS_RAY_RELEASE)
#undef TS_RAY_RELEASE
                   p->active, p->count, p->alive, p->pairs[0], p->pairs[1], p->pair_hit,
                   p->segments, p->grid, p->nodes, p->radiance, p->aov, p->accum, p->aov_film};
    for (size_t i = 0; i < sizeof ms / sizeof *ms; ++i)
        if (ms[i]) clReleaseMemObject(ms[i]);
    if (p->sorter) radix_sorter_destroy(p->sorter);
    free(p->segments_host);
    qbvh_free(&p->qbvh);
    memset(p, 0, sizeof *p);
}

#define ARG(x) sizeof(x), &(x)

int pipeline_camera(ts_pipeline *p, const ts_camera_params *cam, ts_error *err)
{
    ts_camera_params c = *cam;
    if (cl_set_args(p->k_camera, err, ARG(c), ARG(p->ray_org), ARG(p->ray_dir), ARG(p->ray_hit),
                    ARG(p->ray_entry), ARG(p->ray_pixel), ARG(p->active), (size_t)0))
        return err->code;
    return cl_launch(p->cl, p->k_camera, TS_STAGE_camera, c.ray_count, TS_LOCAL_SIZE, err);
}
