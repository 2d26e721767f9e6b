#include "pipeline/pipeline.h"
#include "image/image.h"
#include "lib/patch.h"
#include "lib/quadtree.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Bytes of one patch's grid and tree at LOD m, one time sample. */
static uint64_t slot_bytes(uint32_t m)
{
    return (uint64_t)quadtree_vertex_count(m) * sizeof(ts_vec4) +
           (uint64_t)quadtree_group_count(m) * sizeof(ts_box4);
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
    uint64_t rays = rest / TS_BYTES_PER_RAY;
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
    return TS_OK;
}

static int create_kernels(ts_pipeline *p, ts_error *err)
{
    struct {
        cl_kernel *k;
        const char *name;
    } list[] = {
        {&p->k_camera, "camera_generate"},  {&p->k_top_level, "top_level_collect"},
        {&p->k_lod, "lod_count"},           {&p->k_bottom_group, "bottom_level_group"},
        {&p->k_dice, "dice_grid"},          {&p->k_build_leaves, "build_leaves"},
        {&p->k_build_level, "build_level"}, {&p->k_bottom_level, "bottom_level_trace"},
        {&p->k_resolve, "resolve_closest"}, {&p->k_shade, "shade_path"},
        {&p->k_film, "film_accumulate"},
    };
    for (size_t i = 0; i < sizeof list / sizeof *list; ++i)
        if (!(*list[i].k = dev_kernel_create(p->cl, list[i].name, err))) return err->code;
    return TS_OK;
}

/* Area of patch p's undisplaced surface at time 0: |dP/du x dP/dv| on an 8 x 8 midpoint
 * grid. */
static float patch_area(const ts_scene *s, uint32_t p)
{
    double a = 0;
    for (int j = 0; j < 8; ++j)
        for (int i = 0; i < 8; ++i) {
            ts_vec4 n = bezier_cross_derivs(&s->cp[p * 16], (i + 0.5f) / 8, (j + 0.5f) / 8);
            a += sqrt((double)n.x * n.x + (double)n.y * n.y + (double)n.z * n.z) / 64.0;
        }
    return (float)a;
}

/* The dome's environment map for the kernels (lib/lights.h): texels, and the CDFs that
 * sample it by luminance times sin(theta). Without a map: one unused element each. */
typedef struct env_map {
    ts_vec4 *texels;
    float *marginal, *conditional;
    uint32_t width, height;
} env_map;

static int env_load(const char *path, env_map *e, ts_error *err)
{
    memset(e, 0, sizeof *e);
    ts_image img;
    if (image_read(path, &img, err)) return err->code;
    uint32_t w = (uint32_t)img.width, h = (uint32_t)img.height;
    e->texels = malloc((size_t)w * h * sizeof *e->texels);
    e->marginal = malloc(h * sizeof *e->marginal);
    e->conditional = malloc((size_t)w * h * sizeof *e->conditional);
    if (!e->texels || !e->marginal || !e->conditional) {
        image_free(&img);
        return ts_error_set(err, TS_E_MEMORY, "%s: out of memory for the environment map", path);
    }
    double total = 0;
    for (uint32_t y = 0; y < h; ++y) {
        double row = 0, s = sin(M_PI * (y + 0.5) / h);
        for (uint32_t x = 0; x < w; ++x) {
            const float *px = &img.pixels[((size_t)y * w + x) * img.channels];
            float r = px[0], g = img.channels > 2 ? px[1] : r, b = img.channels > 2 ? px[2] : r;
            if (!(r >= 0 && g >= 0 && b >= 0 && r < 1e30f && g < 1e30f && b < 1e30f)) r = g = b = 0;
            e->texels[(size_t)y * w + x] = (ts_vec4){r, g, b, 0};
            row += (0.2126 * r + 0.7152 * g + 0.0722 * b) * s;
            e->conditional[(size_t)y * w + x] = (float)row;
        }
        for (uint32_t x = 0; x < w; ++x) /* cumulative within the row, ending at 1 */
            e->conditional[(size_t)y * w + x] =
                row > 0 ? (float)(e->conditional[(size_t)y * w + x] / row) : (float)(x + 1) / w;
        e->conditional[(size_t)y * w + w - 1] = 1.0f;
        total += row;
        e->marginal[y] = (float)total;
    }
    for (uint32_t y = 0; y < h; ++y)
        e->marginal[y] = total > 0 ? (float)(e->marginal[y] / total) : (float)(y + 1) / h;
    e->marginal[h - 1] = 1.0f;
    e->width = w, e->height = h;
    image_free(&img);
    return TS_OK;
}

/* The lights as the kernels read them (lib/lights.h): every distant light, the dome, and
 * one area light over all emissive patches, which are listed in an emitter table chosen by
 * power (area times brightest channel). attr gets each emitter's index. */
static int build_lights(ts_pipeline *p, ts_patch_attr *attr, ts_light *lights, ts_emitter **em,
                        uint32_t *emitter_count, const env_map *env, ts_error *err)
{
    const ts_scene *s = p->scene;
    uint32_t nl = 0, ne = 0;
    for (uint32_t i = 0; i < s->light_count; ++i) {
        const ts_distant_light *d = &s->lights[i];
        ts_light l = {.type = TS_LIGHT_DISTANT, .cos_max = 1.0f};
        double dir[3] = {d->from[0] - d->to[0], d->from[1] - d->to[1], d->from[2] - d->to[2]};
        double len = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
        double half = 0.5 * d->angle * M_PI / 180.0, e_scale = 1.0;
        if (half > 0) { /* radiance L with L * pi sin^2(half) = E, uniform in the cone */
            l.cos_max = (float)cos(half);
            l.solid_angle = (float)(2 * M_PI * (1 - cos(half)));
            e_scale = 1.0 / (M_PI * sin(half) * sin(half));
        }
        for (int k = 0; k < 3; ++k) {
            l.dir[k] = (float)(dir[k] / len);
            l.radiance[k] = (float)(d->intensity * d->color[k] * e_scale);
        }
        lights[nl++] = l;
    }
    if (s->dome.present) {
        ts_light l = {.type = TS_LIGHT_DOME,
                      .cos_max = 1.0f,
                      .map_width = env->width,
                      .map_height = env->height};
        for (int k = 0; k < 3; ++k)
            l.radiance[k] = (float)(s->dome.intensity * s->dome.color[k]);
        lights[nl++] = l;
    }
    for (uint32_t i = 0; i < s->patch_count; ++i)
        ne += attr[i].le_r > 0 || attr[i].le_g > 0 || attr[i].le_b > 0;
    *em = calloc(ne ? ne : 1, sizeof **em);
    if (!*em) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    double total = 0;
    ne = 0;
    for (uint32_t i = 0; i < s->patch_count; ++i) {
        attr[i].emitter = TS_INVALID;
        float le = fmaxf(attr[i].le_r, fmaxf(attr[i].le_g, attr[i].le_b));
        if (!(le > 0)) continue;
        float area = patch_area(s, i);
        (*em)[ne] = (ts_emitter){i, 0, area * le, area};
        total += area * le;
        attr[i].emitter = ne++;
    }
    double acc = 0;
    for (uint32_t k = 0; k < ne; ++k) {
        (*em)[k].prob = total > 0 ? (float)((*em)[k].prob / total) : 0.0f;
        acc += (*em)[k].prob;
        (*em)[k].cdf = k + 1 == ne ? 1.0f : (float)acc;
    }
    if (ne) lights[nl++] = (ts_light){.type = TS_LIGHT_AREA, .emitter_count = ne, .cos_max = 1.0f};
    *emitter_count = ne;
    p->light_count = nl;
    return TS_OK;
}

/* Patch data as the kernels read it: the scene's arrays, or defaults where the scene has
 * none (no motion: cp1 = cp; no transforms: the identity; no normals: +z). boxes: each
 * patch's scene_patch_box, computed once by pipeline_create. */
static int create_patch_buffers(ts_pipeline *p, const ts_box *boxes, ts_error *err)
{
    const ts_scene *s = p->scene;
    size_t n = s->patch_count ? s->patch_count : 1;
    const cl_mem_flags ro_copy = CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR;
    ts_vec4 *flat = calloc(n, sizeof *flat), *normals = NULL;
    ts_patch_attr *attr = calloc(n, sizeof *attr);
    ts_light lights[66];
    ts_emitter *emitters = NULL;
    uint32_t emitter_count = 0;
    env_map env = {0};
    if (s->dome.present && s->dome.mapname[0] && env_load(s->dome.mapname, &env, err)) {
        free(env.texels), free(env.marginal), free(env.conditional), free(flat), free(attr);
        return err->code;
    }
    if (!flat || !attr) {
        free(flat), free(attr);
        return ts_error_set(err, TS_E_MEMORY, "out of memory");
    }
    if (s->light_count > 64) {
        free(flat), free(attr);
        return ts_error_set(err, TS_E_SCENE, "%u distant lights: at most 64", s->light_count);
    }
    if (s->patch_count) memcpy(attr, s->attr, s->patch_count * sizeof *attr); /* attr: NULL if 0 */
    if (build_lights(p, attr, lights, &emitters, &emitter_count, &env, err)) {
        free(flat), free(attr);
        return err->code;
    }
    /* w: the longest side of the patch's box, for the secondary-ray offset l / 2^m. */
    for (uint32_t i = 0; i < s->patch_count; ++i) {
        flat[i] = patch_flatness(&s->cp[i * 16], s->cp1 ? &s->cp1[i * 16] : &s->cp[i * 16], 0);
        ts_box b = boxes[i];
        flat[i].w = fmaxf(b.hi_x - b.lo_x, fmaxf(b.hi_y - b.lo_y, b.hi_z - b.lo_z));
    }
    const ts_vec4 *cn = s->corner_n;
    if (!cn) {
        normals = calloc(n * 4, sizeof *normals);
        if (!normals) {
            free(flat);
            return ts_error_set(err, TS_E_MEMORY, "out of memory");
        }
        for (size_t i = 0; i < n * 4; ++i)
            normals[i].z = 1.0f;
        cn = normals;
    }
    const ts_xform identity = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
    struct {
        cl_mem *m;
        size_t size;
        const void *host;
    } list[] = {
        {&p->qbvh_nodes, p->qbvh.node_count * sizeof(ts_qbvh_node), p->qbvh.nodes},
        {&p->cp, n * 16 * sizeof(ts_vec4), s->cp},
        {&p->cp1, n * 16 * sizeof(ts_vec4), s->cp1 ? s->cp1 : s->cp},
        {&p->corner_n, n * 4 * sizeof(ts_vec4), cn},
        {&p->attr, n * sizeof(ts_patch_attr), attr},
        {&p->lights, (p->light_count ? p->light_count : 1) * sizeof(ts_light), lights},
        {&p->emitters, (emitter_count ? emitter_count : 1) * sizeof(ts_emitter), emitters},
        {&p->env_texels, (env.width ? (size_t)env.width * env.height : 1) * sizeof(ts_vec4),
         env.texels},
        {&p->env_marginal, (env.width ? env.height : 1) * sizeof(float), env.marginal},
        {&p->env_conditional, (env.width ? (size_t)env.width * env.height : 1) * sizeof(float),
         env.conditional},
        {&p->xform, (s->xform_count ? s->xform_count : 1) * sizeof(ts_xform),
         s->xform_count ? (const void *)s->xform : (const void *)&identity},
        {&p->flatness, n * sizeof(ts_vec4), flat},
        {&p->patch_box, n * sizeof(ts_box), s->patch_count ? boxes : NULL},
        {&p->textures, (s->texture_count ? s->texture_count : 1) * sizeof(ts_texture), s->textures},
    };
    int rc = TS_OK;
    for (size_t i = 0; i < sizeof list / sizeof *list && rc == TS_OK; ++i) {
        /* What the scene lacks (no patch, no map) is one unused zeroed element, so no buffer
         * has size 0; the largest such element is a patch's 16 control points. */
        static const ts_vec4 zeros[16];
        const void *host = list[i].host ? list[i].host : zeros;
        *list[i].m = dev_buffer_create(p->cl, ro_copy, list[i].size, (void *)host, err);
        if (!*list[i].m) rc = err->code;
    }
    free(flat);
    free(normals);
    free(attr);
    free(emitters);
    free(env.texels), free(env.marginal), free(env.conditional);
    if (rc != TS_OK) return rc;
    /* Texture tiles: a pool of tex.slots tiles and the page table (tex_cache.h). */
    if (tex_cache_create(&p->tex, s, p->plan.tex_pool_bytes, err)) return err->code;
    size_t slots = p->tex.slots ? p->tex.slots : 1, pages = p->tex.pages ? p->tex.pages : 1;
    p->tex_pool = dev_buffer_create(p->cl, CL_MEM_READ_ONLY,
                                    slots * TS_TEX_TILE * TS_TEX_TILE * sizeof(ts_vec4), NULL, err);
    p->tex_pages = p->tex_pool ? dev_buffer_create(p->cl, CL_MEM_READ_ONLY,
                                                   pages * sizeof(uint32_t), NULL, err)
                               : NULL;
    if (!p->tex_pages) return err->code;
    return tex_cache_upload_initial(&p->tex, p->cl, p->tex_pool, p->tex_pages, s, p->stats, err);
}

static int create_buffers(ts_pipeline *p, const ts_box *boxes, ts_error *err)
{
    ts_device *cl = p->cl;
    size_t rays = p->plan.ray_capacity, pairs = p->plan.pair_capacity;
    size_t n = p->scene->patch_count ? p->scene->patch_count : 1;
    const cl_mem_flags host_rw = CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR;
    if (create_patch_buffers(p, boxes, err)) return err->code;
    struct {
        cl_mem *m;
        cl_mem_flags flags;
        size_t size;
    } list[] = {
#define TS_RAY_ALLOC(type, name, what) {&p->ray_##name, CL_MEM_READ_WRITE, rays * sizeof(type)},
        TS_RAY_FIELDS(TS_RAY_ALLOC)
#undef TS_RAY_ALLOC
#define TS_PATH_ALLOC(type, name, what) {&p->path_##name, CL_MEM_READ_WRITE, rays * sizeof(type)},
            TS_PATH_FIELDS(TS_PATH_ALLOC)
#undef TS_PATH_ALLOC
                {&p->active, host_rw, rays * sizeof(uint32_t)},
        {&p->wave_paths, host_rw, rays * sizeof(uint32_t)},
        {&p->count, CL_MEM_READ_WRITE, rays * sizeof(uint32_t)},
        {&p->alive, host_rw, rays * sizeof(uint32_t)},
        {&p->pairs[0], host_rw, pairs * sizeof(ts_pair)},
        {&p->pairs[1], host_rw, pairs * sizeof(ts_pair)},
        {&p->pair_hit, CL_MEM_READ_WRITE, pairs * sizeof(ts_hit)},
        {&p->segments, CL_MEM_READ_ONLY, n * sizeof(ts_segment)},
        {&p->trees, CL_MEM_READ_ONLY, 2 * n * sizeof(uint32_t)},
        {&p->lod_counts, CL_MEM_READ_WRITE, n * sizeof(uint32_t)},
        {&p->utilisation, CL_MEM_READ_WRITE, 2 * sizeof(uint32_t)},
        {&p->grid, CL_MEM_READ_WRITE, (size_t)p->plan.vert_capacity * sizeof(ts_vec4)},
        {&p->groups, CL_MEM_READ_WRITE, (size_t)p->plan.group_capacity * sizeof(ts_box4)},
        {&p->radiance, CL_MEM_READ_WRITE, rays * sizeof(ts_vec4)},
        {&p->aov, CL_MEM_READ_WRITE, rays * sizeof(ts_vec4)},
        {&p->albedo, CL_MEM_READ_WRITE, rays * sizeof(ts_vec4)},
        {&p->albedo_film, host_rw, (size_t)p->pixel_count * sizeof(ts_vec4)},
        {&p->accum, host_rw, (size_t)p->pixel_count * sizeof(ts_vec4)},
        {&p->aov_film, host_rw, (size_t)p->pixel_count * sizeof(ts_vec4)},
    };
    for (size_t i = 0; i < sizeof list / sizeof *list; ++i) {
        *list[i].m = dev_buffer_create(cl, list[i].flags, list[i].size, NULL, err);
        if (!*list[i].m) return err->code;
    }
    /* The film starts black and "nothing hit"; the LOD counts at zero. */
    ts_vec4 zero = {0, 0, 0, 0};
    cl_uint zero_u = 0;
    CL_CHECK(clEnqueueFillBuffer(cl->queue, p->accum, &zero, sizeof zero, 0,
                                 (size_t)p->pixel_count * sizeof(ts_vec4), 0, NULL, NULL),
             err);
    CL_CHECK(clEnqueueFillBuffer(cl->queue, p->aov_film, &zero, sizeof zero, 0,
                                 (size_t)p->pixel_count * sizeof(ts_vec4), 0, NULL, NULL),
             err);
    CL_CHECK(clEnqueueFillBuffer(cl->queue, p->albedo_film, &zero, sizeof zero, 0,
                                 (size_t)p->pixel_count * sizeof(ts_vec4), 0, NULL, NULL),
             err);
    CL_CHECK(clEnqueueFillBuffer(cl->queue, p->lod_counts, &zero_u, sizeof zero_u, 0,
                                 n * sizeof(uint32_t), 0, NULL, NULL),
             err);
    CL_CHECK(clEnqueueFillBuffer(cl->queue, p->utilisation, &zero_u, sizeof zero_u, 0,
                                 2 * sizeof(uint32_t), 0, NULL, NULL),
             err);
    return TS_OK;
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
    p->mode = (ts_trace_mode){1u, (int)plan->max_lod, 1, 0, 0u};
    size_t n = scene->patch_count ? scene->patch_count : 1;
    ts_box *boxes = malloc(n * sizeof *boxes);
    p->segments_host = malloc(n * sizeof *p->segments_host);
    p->trees_host = malloc(2 * n * sizeof *p->trees_host);
    p->batches = malloc(n * sizeof *p->batches);
    p->patch_lod = malloc(n);
    if (!boxes || !p->segments_host || !p->trees_host || !p->batches || !p->patch_lod) {
        free(boxes);
        return ts_error_set(err, TS_E_MEMORY, "out of memory");
    }
    memset(p->patch_lod, (int)plan->max_lod, n);
    for (uint32_t i = 0; i < scene->patch_count; ++i)
        boxes[i] = scene_patch_box(scene, i);
    /* The patch boxes: the top-level BVH's leaves, build's clamp (patch_box) and the
     * secondary-ray offset (flatness w). */
    int rc = qbvh_build(&p->qbvh, boxes, scene->patch_count, err);
    if (rc == TS_OK && !(p->sorter = radix_sorter_create(0, err))) rc = err->code;
    if (rc == TS_OK && (create_kernels(p, err) || create_buffers(p, boxes, err))) rc = err->code;
    free(boxes);
    if (rc) return rc;
    /* TESSERA_SORT_VIA_COPY=1|0 overrides the choice (tests run both paths on PoCL). */
    const char *via_copy = getenv("TESSERA_SORT_VIA_COPY");
    if (via_copy && *via_copy ? strcmp(via_copy, "0") != 0 : !cl->info.host_unified) {
        size_t bytes = ((size_t)plan->pair_capacity * sizeof(ts_pair) + 4095) & ~(size_t)4095;
        for (int i = 0; i < 2; ++i)
            if (!(p->sort_host[i] = aligned_alloc(4096, bytes)))
                return ts_error_set(err, TS_E_MEMORY, "out of memory (%zu MiB of sort buffers)",
                                    2 * bytes >> 20);
    }
    stats->counters[TS_COUNTER_micropolygons_potential] = (uint64_t)scene->patch_count
                                                          << (2u * plan->max_lod);
    return TS_OK;
}

void pipeline_destroy(ts_pipeline *p)
{
    cl_kernel ks[] = {p->k_camera,       p->k_lod,         p->k_top_level,    p->k_dice,
                      p->k_build_leaves, p->k_build_level, p->k_bottom_level, p->k_bottom_group,
                      p->k_resolve,      p->k_shade,       p->k_film};
    for (size_t i = 0; i < sizeof ks / sizeof *ks; ++i)
        if (ks[i]) clReleaseKernel(ks[i]);
    cl_mem ms[] = {p->qbvh_nodes,
                   p->cp,
                   p->cp1,
                   p->corner_n,
                   p->attr,
                   p->xform,
                   p->flatness,
                   p->patch_box,
                   p->lod_counts,
                   p->utilisation,
                   p->lights,
                   p->emitters,
                   p->env_texels,
                   p->env_marginal,
                   p->env_conditional,
                   p->textures,
                   p->tex_pages,
                   p->tex_pool,
#define TS_PATH_RELEASE(type, name, what) p->path_##name,
                   TS_PATH_FIELDS(TS_PATH_RELEASE)
#undef TS_PATH_RELEASE
                       p->wave_paths,
                   p->albedo,
                   p->albedo_film,
#define TS_RAY_RELEASE(type, name, what) p->ray_##name,
                   TS_RAY_FIELDS(TS_RAY_RELEASE)
#undef TS_RAY_RELEASE
                       p->active,
                   p->count,
                   p->alive,
                   p->pairs[0],
                   p->pairs[1],
                   p->pair_hit,
                   p->segments,
                   p->trees,
                   p->grid,
                   p->groups,
                   p->radiance,
                   p->aov,
                   p->accum,
                   p->aov_film};
    for (size_t i = 0; i < sizeof ms / sizeof *ms; ++i)
        if (ms[i]) clReleaseMemObject(ms[i]);
    if (p->sorter) radix_sorter_destroy(p->sorter);
    free(p->sort_host[0]);
    free(p->sort_host[1]);
    tex_cache_free(&p->tex);
    free(p->segments_host);
    free(p->trees_host);
    free(p->batches);
    free(p->patch_lod);
    qbvh_free(&p->qbvh);
    memset(p, 0, sizeof *p);
}

#define ARG(x) sizeof(x), &(x)

int pipeline_camera(ts_pipeline *p, const ts_camera_params *cam, ts_error *err)
{
    ts_camera_params c = *cam;
    if (dev_set_args(p->k_camera, err, ARG(c), ARG(p->ray_org), ARG(p->ray_dir), ARG(p->ray_hit),
                     ARG(p->ray_entry), ARG(p->ray_pixel), ARG(p->ray_flags), ARG(p->active),
                     ARG(p->wave_paths), ARG(p->path_throughput), ARG(p->path_mis),
                     ARG(p->radiance), (size_t)0))
        return err->code;
    return dev_launch(p->cl, p->k_camera, TS_STAGE_camera, c.ray_count, TS_LOCAL_SIZE, err);
}

int pipeline_lod_count(ts_pipeline *p, uint32_t ray_count, ts_error *err)
{
    if (dev_set_args(p->k_lod, err, ARG(p->qbvh_nodes), ARG(ray_count), ARG(p->ray_org),
                     ARG(p->ray_dir), ARG(p->lod_counts), (size_t)0))
        return err->code;
    return dev_launch(p->cl, p->k_lod, TS_STAGE_lod, ray_count, TS_LOCAL_SIZE, err);
}

int pipeline_lod_finish(ts_pipeline *p, ts_error *err)
{
    uint32_t n = p->scene->patch_count;
    if (n == 0) return TS_OK;
    if (dev_finish(p->cl, p->stats, err)) return err->code;
    double t0 = stats_now();
    uint32_t *counts = malloc(n * sizeof *counts);
    if (!counts) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    cl_int rc = clEnqueueReadBuffer(p->cl->queue, p->lod_counts, CL_TRUE, 0, n * sizeof *counts,
                                    counts, 0, NULL, NULL);
    cl_uint zero = 0;
    if (rc == CL_SUCCESS)
        rc = clEnqueueFillBuffer(p->cl->queue, p->lod_counts, &zero, sizeof zero, 0,
                                 n * sizeof *counts, 0, NULL, NULL);
    for (uint32_t i = 0; rc == CL_SUCCESS && i < n; ++i) {
        /* Smallest m with 4^m >= R / spp (Hanika §3.3), at most max_lod. */
        uint32_t m = 0;
        while (m < p->plan.max_lod && ((uint64_t)1 << (2 * m)) * p->mode.spp < counts[i])
            ++m;
        p->patch_lod[i] = (uint8_t)m;
    }
    free(counts);
    p->stats->stage_seconds[TS_STAGE_lod] += stats_now() - t0;
    if (rc != CL_SUCCESS)
        return ts_error_set(err, TS_E_DEVICE, "%s reading the LOD counts", dev_error_name(rc));
    return TS_OK;
}
