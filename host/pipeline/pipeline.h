/* pipeline.h — the wavefront two-level tracer on one OpenCL device (DESIGN.md §1): the
 * buffers of a fixed memory budget, and one function per stage. pipeline_trace runs the
 * loop top_level -> sort -> dice -> build -> bottom_level -> resolve until no ray of the wave
 * is active. Memory is fixed at creation: it depends on the budget, never on the scene's
 * micro-polygon count (Hanika §4). */
#ifndef TS_PIPELINE_H
#define TS_PIPELINE_H

#include "device/device.h"
#include "pipeline/patch_cache.h"
#include "pipeline/patch_share.h"
#include "pipeline/qbvh.h"
#include "pipeline/sort.h"
#include "scene/scene.h"
#include "base/stats.h"
#include "pipeline/tex_cache.h"

/* Candidate pairs reserved per ray of a full wave (Hanika Table 3 starts at N = 8). Three:
 * a full wave's rays emit two to three candidates each on average (forest-100's bounces),
 * and the bytes a ray does not reserve for pairs make the waves larger, so a frame whose
 * patches do not fit needs fewer passes over them (forest-100 1920x768 x 2 at --memory 512:
 * 848 K dicings with eight, 633 K with three; docs/benchmarks.md); where they fit, N ramps
 * up from one anyway (trace.c pairs_per_ray). */
#define TS_PAIRS_PER_RAY 3u
/* The most candidates a ray gets in a water-filled window (trace.c water_fill): beyond a
 * dozen or so they lie mostly behind the ray's closest hit and dice patches for nothing. */
#define TS_FILL_MAX 16u
/* pipeline.h top_level_run: one launch over a squeezed forest-1000's 3.8 M first-bounce rays
 * (its counting launch and its collecting one, 6 s before the pass's first batch) kept a stop
 * waiting 4-6 s; a run of this many is 0.1-0.3 s there, and on a GPU a launch large enough
 * to fill it. */
#define TS_TOP_LEVEL_RUN (1u << 18)
/* N is clipped to [1, 100] (Hanika Table 3). */
#define TS_N_MAX 100u
/* Work-group size of every launch: one size, so PoCL compiles each kernel once. */
#define TS_LOCAL_SIZE ((size_t)TS_GROUP_SIZE)

/* Bytes of device memory one ray costs: an entry of every ray field, of active, count, alive,
 * wave_paths and window_first, TS_PAIRS_PER_RAY candidates (pairs, pairs_scratch, pair_hit;
 * TS_PIPELINE_BUFFERS), and half an entry of every path field and of radiance, aov and
 * albedo: a path owns two ray slots, its BSDF ray's and its shadow ray's (TS_PATHS_OF_RAYS). */
#define TS_FIELD_BYTES(type, name, what) +sizeof(type)
#define TS_BYTES_PER_RAY                                                                           \
    (0 TS_RAY_FIELDS(TS_FIELD_BYTES) + 5 * sizeof(ts_u32) +                                        \
     TS_PAIRS_PER_RAY * (2 * sizeof(ts_pair) + sizeof(ts_hit)) +                                   \
     (0 TS_PATH_FIELDS(TS_FIELD_BYTES) + 3 * sizeof(ts_vec4) + 1) / 2)
/* What the wave buffers hold beyond rays x TS_BYTES_PER_RAY, at most: window_first's last
 * entry, and the last path of an odd number of rays (pipeline_plan keeps it out of the
 * rays' share). */
#define TS_WAVE_EXTRA_BYTES 64u
/* The paths of a wave of `rays` ray slots: each path traces a ray and its shadow ray. */
#define TS_PATHS_OF_RAYS(rays) (((rays) + 1u) / 2u)

typedef struct ts_pipeline_plan {
    uint32_t ray_capacity;   /* rays per wave */
    uint32_t pair_capacity;  /* (leaf, ray) candidates per iteration */
    uint32_t vert_capacity;  /* ts_vec4 entries of the vertex arena (diced grids) */
    uint32_t group_capacity; /* ts_box4 entries of the group arena (quad-trees) */
    uint32_t max_lod;        /* the finest m; the arenas hold at least one moving patch at it */
    uint64_t tex_pool_bytes; /* texture tile pool (tex_cache.h); 0: every tile resident */
    uint32_t sort_threads;   /* threads of the host sort (sort.h) and of the top-level BVH's
                                build (qbvh.h); 0: every online CPU. Several
                                devices in one process share the CPUs (app/workers.c) */
    uint32_t first_n;        /* candidates per ray in a wave's first iteration, doubled each
                                iteration up to pair_capacity / R (trace.c pairs_per_ray);
                                0: 1, and pair_capacity / R at once after the patch cache
                                first evicts (pipeline_trace). Changes no hit, only the work
                                (tests compare them) */
    int fill_windows;        /* 1: water-filled candidate windows in every iteration (tests);
                                0: only where Hanika's full N is used, when the frame's
                                patches do not fit (trace.c water_fill). The same hits */
    int host_film;           /* 1: the films are the host's (several devices, app/units.h merges
                                each wave's samples there): the device films are one pixel
                                and pipeline_film is not called */
} ts_pipeline_plan;

/* Splits a budget of `memory_bytes` between the patch arenas (a quarter) and rays, and sets
 * the texture tile pool to an eighth of it (on top; tex_cache.h), for
 * waves of at most `rays_wanted`, within the device's single-allocation limit. If the
 * arenas cannot hold one moving patch at max_lod, max_lod is lowered until they can (the
 * caller reports it: plan->max_lod < max_lod). Returns TS_E_USAGE when nothing fits. */
int pipeline_plan(uint64_t memory_bytes, uint64_t rays_wanted, uint32_t max_lod, uint64_t max_alloc,
                  ts_pipeline_plan *plan, ts_error *err);

/* Arena sizes that hold `patches` moving patches at LOD m, for tests. */
void pipeline_plan_arenas(ts_pipeline_plan *plan, uint32_t patches, uint32_t m);

/* How the bottom level picks the LOD and what it intersects (DESIGN.md §2-3). */
typedef struct ts_trace_mode {
    uint32_t spp;       /* samples per pixel, for the LOD rule 4^m >= R / spp */
    int fixed_lod;      /* >= 0: every patch at this m (cross-checks); -1: per patch from the lod
                           stage's counts (pipeline_lod_*) */
    int exact;          /* 1: micro-triangles, stitched where patches diced at different m
                           share an edge (pipeline_stitch_edges); 0: leaf boxes as geometry,
                           hole-free across LODs whatever the edges (Hanika §3.3) */
    int leaf_group;     /* 1: work-group-wide leaf intersection (PantaRay Fig. 8); 0: per ray */
    uint32_t leaf_b;    /* leaves are blocks of 2^leaf_b x 2^leaf_b micro-quads (0..2) */
    int tight;          /* 1 (with exact): each leaf box is the box of its micro-quad's diced
                           vertices (build.cl tight_leaf_box), which bounds its two triangles;
                           0: it bounds the surface over the micro-quad's parameter square and
                           so every finer dicing (box mode needs that; the origin-patch rule's
                           triangles are tested inside such boxes too) */
    double dicing_rate; /* the lod stage's micro-quad size in pixels across (like Cycles'
                           dicing rate): patch p at the smallest m with 4^m >= R_p / rate^2
                           (R_p: its count); 1 (or 0) is Hanika's rule 4^m >= R / spp */
} ts_trace_mode;

/* The pipeline's kernels, X(field, kernel function name): pipeline_create makes each,
 * pipeline_destroy releases them. */
/* clang-format off */
#define TS_PIPELINE_KERNELS(X)                                                                  \
    X(k_camera, "camera_generate")                                                              \
    X(k_lod, "lod_count")                                                                       \
    X(k_top_level, "top_level_collect")                                                         \
    X(k_dice, "dice_grid")                                                                      \
    X(k_build_leaves, "build_leaves")                                                           \
    X(k_build_level, "build_level")                                                             \
    X(k_build_cull, "build_cull")                                                               \
    X(k_build_skeleton, "build_skeleton")                                                       \
    X(k_bottom_level, "bottom_level_trace")                                                     \
    X(k_bottom_group, "bottom_level_group")                                                     \
    X(k_resolve, "resolve_closest")                                                             \
    X(k_shade, "shade_path")                                                                    \
    X(k_film, "film_accumulate")
/* clang-format on */

/* Flags of the buffer list besides CL_MEM_READ_ONLY and CL_MEM_READ_WRITE: the scene's data,
 * read only and uploaded at creation; buffers the host maps or transfers every iteration. */
#define TS_MEM_SCENE (CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR)
#define TS_MEM_HOST_RW (CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR)

/* The pipeline's buffers besides the ray and path fields (TS_RAY_FIELDS, TS_PATH_FIELDS):
 * X(field, flags, element type, count, contents). count (elements) and contents (what a
 * TS_MEM_SCENE buffer starts with; NULL: zeros) are expressions over pipeline.c's
 * buffer_counts c and scene_uploads u; what the scene lacks is one unused element, so no
 * buffer has size 0. pipeline_create makes every buffer, pipeline_destroy releases them.
 *   qbvh_nodes: the top-level BVH (qbvh.h); cp, cp1: control points at times 0 and 1 (a
 *     static scene's cp1 is one patch's worth, never read: dice reads cp1 only for the
 *     second time sample of a moving patch); corner_n, mid_n: displacement normals at the
 *     corners and the edge midpoints and centre (scene.h; +z if the scene has none);
 *     attr: with each patch's emitter index; xform: world to object (the identity if none);
 *     flatness: patch_flatness, w = the longest side of the patch's box (secondary-ray
 *     offset l / 2^m); patch_box: scene_patch_box (build clamps leaf boxes to it); lights,
 *     emitters, env_*: lights.h; instance, inst_xform: scene.h's instancing tables (one
 *     zeroed element each when no instance shares its master's dicing); textures, tex_pool,
 *     tex_pages: descriptors, the tile pool and its page table (tex_cache.h); relight_*: the
 *     baked occlusion of `render --occlusion` (scene.h ts_occlusion: its patch table,
 *     coefficients and normals) and relight.h's light tables, one zeroed element each without
 *     one.
 *   lod_counts: eye rays entering each patch box (lod); segments, trees: the sorted
 *     segments and the batches' tree lists; grid, groups: the vertex and group arenas;
 *     utilisation: bottom_level's micro-quad tests and work-item slots, two words per
 *     work-group of the iteration's launches (util_groups of them; trace.c folds them);
 *     cull, cull_levels: levels 1 and 2 of each built patch's tree and how many of them
 *     top_level culls candidates by (TS_CULL_GROUPS; build.cl build_cull).
 *   active: the rays being traced; count: candidates per active ray; alive: what goes on
 *     after resolve and shade; wave_paths: the paths being shaded; window_first: where each
 *     active ray's candidate window starts when they are water-filled (trace.c water_fill);
 *     radiance: per path; aov, albedo: at the eye hit.
 *   pairs: top_level's candidates, sorted by sort; pairs_scratch: the radix sort's other
 *     buffer (it may end there); pair_hit: bottom_level's hit per candidate.
 *   accum, aov_film, albedo_film: the film (sums per pixel). */
/* clang-format off */
#define TS_PIPELINE_BUFFERS(X)                                                                  \
    /* The scene, read only, uploaded at creation (Hanika §4: only these grow with it). */      \
    X(qbvh_nodes,      TS_MEM_SCENE,      ts_qbvh_node,  c.nodes,        u.nodes)               \
    X(cp,              TS_MEM_SCENE,      ts_vec4,       16 * c.patches, u.cp)                  \
    X(cp1,             TS_MEM_SCENE,      ts_vec4,       16 * c.moving,  u.cp1)                  \
    X(corner_n,        TS_MEM_SCENE,      ts_vec4,       4 * c.patches,  u.corner_n)            \
    X(mid_n,           TS_MEM_SCENE,      ts_vec4,       5 * c.patches,  u.mid_n)               \
    X(attr,            TS_MEM_SCENE,      ts_patch_attr, c.patches,      u.attr_src)            \
    X(xform,           TS_MEM_SCENE,      ts_xform,      c.xforms,       u.xform)               \
    X(trim_seg,        TS_MEM_SCENE,      ts_vec4,       c.trim_segs,    u.trim_seg)            \
    X(flatness,        TS_MEM_SCENE,      ts_vec4,       c.patches,      u.flatness)            \
    X(patch_box,       TS_MEM_SCENE,      ts_box,        c.patches,      u.boxes)               \
    X(instance,        TS_MEM_SCENE,      ts_u32,        c.instances,    u.instance)            \
    X(inst_xform,      TS_MEM_SCENE,      ts_xform,      c.inst_xforms,  u.inst_xform)          \
    X(lights,          TS_MEM_SCENE,      ts_light,      c.lights,       u.lights.lights)       \
    X(emitters,        TS_MEM_SCENE,      ts_emitter,    c.emitters,     u.lights.emitters)     \
    X(env_texels,      TS_MEM_SCENE,      ts_vec4,       c.env_texels,   u.env.texels)          \
    X(env_marginal,    TS_MEM_SCENE,      float,         c.env_rows,     u.env.marginal)        \
    X(env_conditional, TS_MEM_SCENE,      float,         c.env_texels,   u.env.conditional)     \
    X(textures,        TS_MEM_SCENE,      ts_texture,    c.textures,     u.textures)            \
    X(tex_pool,        CL_MEM_READ_ONLY,  ts_vec4,       c.tex_texels,   NULL)                  \
    X(tex_pages,       CL_MEM_READ_ONLY,  ts_u32,        c.tex_pages,    NULL)                  \
    X(relight_patch,   TS_MEM_SCENE,      ts_u32,        c.relight_patch, u.relight_patch)      \
    X(relight_coeffs,  TS_MEM_SCENE,      float,         c.relight_coeffs, u.relight_coeffs)    \
    X(relight_normal,  TS_MEM_SCENE,      float,         c.relight_normal, u.relight_normal)    \
    X(relight_light,   TS_MEM_SCENE,      ts_vec4,       c.relight_light, u.relight.light)      \
    /* Per patch, and the batch being diced. */                                                 \
    X(lod_counts,      CL_MEM_READ_WRITE, ts_u32,        c.patches,      NULL)                  \
    X(segments,        CL_MEM_READ_ONLY,  ts_segment,    c.patches,      NULL)                  \
    X(trees,           CL_MEM_READ_ONLY,  ts_u32,        2 * c.patches,  NULL)                  \
    X(grid,            CL_MEM_READ_WRITE, ts_vec4,       c.verts,        NULL)                  \
    X(groups,          CL_MEM_READ_WRITE, ts_box4,       c.groups,       NULL)                  \
    X(tight,           CL_MEM_READ_WRITE, ts_tight4,     c.groups,       NULL)                  \
    X(utilisation,     CL_MEM_READ_WRITE, ts_u32,        2 * c.util_groups, NULL)               \
    X(cull,            CL_MEM_READ_WRITE, ts_tight4,     TS_CULL_GROUPS * c.patches, NULL)      \
    X(cull_levels,     CL_MEM_READ_WRITE, ts_u32,        c.patches,      NULL)                  \
    X(skel_first,      CL_MEM_READ_ONLY,  ts_u32,        c.patches,      NULL)                  \
    /* The last iteration in which a ray leaving the patch had it among its candidates. */     \
    X(leaving,         TS_MEM_HOST_RW,    ts_u32,        c.patches,      NULL)                  \
    /* Where each patch's diced grid is resident, for shade (pipeline_grid_publish). */        \
    X(grid_at,         CL_MEM_READ_ONLY,  ts_u32,        3 * c.patches,  NULL)                  \
    /* Per pixel: the film. */                                                                  \
    X(accum,           TS_MEM_HOST_RW,    ts_vec4,       c.film,         NULL)                  \
    X(aov_film,        TS_MEM_HOST_RW,    ts_vec4,       c.film,         NULL)                  \
    X(albedo_film,     TS_MEM_HOST_RW,    ts_vec4,       c.film,         NULL)                  \
    TS_PIPELINE_WAVE_BUFFERS(X)
/* The buffers of TS_PIPELINE_BUFFERS whose size follows the rays of a wave (the plan's
 * ray_capacity and pair_capacity), made again by pipeline_resize_rays. */
#define TS_PIPELINE_WAVE_BUFFERS(X)                                                             \
    /* Per ray or path of a wave (beside the ray and path fields). */                           \
    X(active,          TS_MEM_HOST_RW,    ts_u32,        c.rays,         NULL)                  \
    X(count,           CL_MEM_READ_WRITE, ts_u32,        c.rays,         NULL)                  \
    X(alive,           TS_MEM_HOST_RW,    ts_u32,        c.rays,         NULL)                  \
    X(wave_paths,      TS_MEM_HOST_RW,    ts_u32,        c.rays,         NULL)                  \
    X(window_first,    TS_MEM_HOST_RW,    ts_u32,        c.rays + 1,     NULL)                  \
    X(radiance,        CL_MEM_READ_WRITE, ts_vec4,       c.paths,        NULL)                  \
    X(aov,             CL_MEM_READ_WRITE, ts_vec4,       c.paths,        NULL)                  \
    X(albedo,          CL_MEM_READ_WRITE, ts_vec4,       c.paths,        NULL)                  \
    /* Per (leaf, ray) candidate of an iteration. */                                            \
    X(pairs,           TS_MEM_HOST_RW,    ts_pair,       c.pairs,        NULL)                  \
    X(pairs_scratch,   TS_MEM_HOST_RW,    ts_pair,       c.pairs,        NULL)                  \
    X(pair_hit,        CL_MEM_READ_WRITE, ts_hit,        c.pairs,        NULL)
/* clang-format on */

/* A run of segments traced together: all of them resident in the arenas at once (the patch
 * cache pinned them); its trees are those of the segments that were not resident and are
 * diced and built first. */
typedef struct ts_batch {
    uint32_t seg_first, seg_count;
    uint32_t tree_first, tree_count; /* the misses' trees in the tree list (trace.c tree_key:
                                        by decreasing m, each m's to dice first) */
    double work; /* its misses' micro-quads and its segments' pairs (trace_progress) */
    int sorted;  /* its trees in trace.c's tree_key order (else dice dices them all) */
    /* Its trees whose skeletons are kept once built (trace.c stage_build_skeleton), listed
     * after all the batches' trees in the tree list, by decreasing m. */
    uint32_t skel_tree_first, skel_tree_count;
} ts_batch;

typedef struct ts_pipeline {
    ts_device *cl;
    /* Set by pipeline_create to {spp 1, fixed_lod max_lod, exact 1, leaf_group 0, leaf_b 0}
     * (every patch at max_lod, micro-triangles: the cross-checks' mode); callers may
     * change it (render.c sets it from the options). */
    ts_trace_mode mode;
    const ts_scene *scene;
    ts_stats *stats;
    ts_pipeline_plan plan;
    uint32_t pixel_count;
    /* The ray slots the frame's remaining samples take (two a sample: its path's rays), set by
     * the render before budget_grow_arenas (app/budget.c thin_arenas); 0: unknown. */
    uint64_t frame_rays;
    ts_qbvh qbvh; /* its nodes freed once uploaded (qbvh_nodes), or kept while the device
                     reads them in place; node_count and depth kept */
    /* The patch boxes and flatness bounds the pipeline made for patch_box and flatness, kept
     * while the device reads them in place (a device that shares host memory: one copy of
     * them instead of two when the buffers are made); NULL otherwise. */
    ts_box *box_host;
    ts_vec4 *flatness_host;
    radix_sorter *sorter;
    /* Discrete devices: host copies of the two pair buffers, so sort reads the window once
     * and writes back only the valid pairs instead of mapping both buffers (NULL on devices
     * that share host memory, where the mapped buffers are sorted in place), and of the
     * windows' pair counts (ray_capacity entries). */
    ts_pair *sort_host[2];
    uint32_t *sort_counts;
    ts_segment *segments_host; /* one per patch at most */
    uint32_t *trees_host;      /* two per patch at most */
    ts_batch *batches;         /* one per patch at most */
    uint32_t batch_count;
    /* Work-group entries of `utilisation`: how many there are, and how many this
     * iteration's bottom_level launches have used (folded into the stats by resolve). */
    uint32_t util_groups, util_used;
    uint8_t *patch_lod; /* m of each patch for this frame (lod stage); max_lod until counted */
    uint8_t *rough_lod; /* the least m at which each patch is rough (scene_patch_rough, which
                           grows with m), TS_LOD_LIMIT + 1 if none: plan_batches' flag */
    /* What each patch's entry of cull was built for (trace.c cull_key: its m and leaf size;
     * 0: none), so that an entry is reset when its patch's m or the leaf size changes. */
    uint16_t *cull_key;
    /* Skeletons (trace.c skeleton_prepare, build.cl build_skeleton, bottom_level.cl
     * bl_skeleton): where the frame's patches do not fit, each static, noise-displaced or
     * undisplaced tree at m >= TS_SKELETON_MIN_LOD keeps its levels 1 .. m - 2 as codes in skel
     * (skel_groups ts_tight4 entries) from skel_first_host[shape] (TS_INVALID: no place; the
     * places are given in turn, skel_used of skel_cap groups) once built, and skel_key[shape]
     * says the m it was kept at (0: none), so that a later pass may trace a few rays through it
     * without dicing the patch. skel_on: this trace may; skel_planned: laid out for the frame's
     * levels of detail (cleared by the lod stage). */
    cl_mem skel;
    uint64_t skel_groups, skel_used, skel_cap;
    uint32_t *skel_first_host;
    uint8_t *skel_key;
    int skel_on, skel_planned;
    /* The budget's bytes for skeletons (app/budget.c: thin_arenas takes them from the arenas it
     * thins, skeleton_room from arenas it does not); 0: none, skeletons off. */
    uint64_t skel_room;
    /* Which diced patches the grid and groups arenas hold, kept across iterations, waves and
     * sample passes (patch_cache.h); cleared when the levels of detail change. With
     * cache_off (TESSERA_PATCH_CACHE=0, for checks) it is cleared before every batch, so
     * every segment is diced again as before the cache. */
    ts_patch_cache cache;
    int cache_off;
    /* Whether the cache's quotas are planned for the frame's levels of detail
     * (pipeline_cache_plan): cleared by pipeline_lod_finish_with, new arenas and
     * pipeline_dice_build; planned_fixed_lod is the --lod they were planned at. */
    int cache_planned, planned_fixed_lod;
    uint32_t sweep; /* iterations planned: odd ones walk the segments backwards (trace.c) */
    /* When the frame's patches do not fit, an iteration's misses are diced whole only where a
     * ray leaves the patch (top_level marks leaving[patch] with the iteration's stamp; trace.c
     * leave_stamp), the others built without their vertices: leave_stamp the last stamp,
     * seg_grid[i] whether segment i's shape has its vertices diced this iteration (the cache
     * entry's `gridded` says it only while the patch is resident), grid_mark[q] the last stamp
     * with which a segment of shape q needed them. */
    uint32_t leave_stamp;
    /* Water-filled windows (trace.c water_fill): the counting launch of top_level keeps each
     * ray's first stash_n candidates in pairs_scratch (free until sort), and the collecting
     * launch copies them for a ray that has no more instead of traversing again; 0: none. */
    uint32_t stash_n;
    uint8_t *seg_grid;
    uint32_t *grid_mark;
    /* Per pixel (pixel_count), 1 + the leaf boxes its first-pass eye ray crossed in the lod
     * stage (kernels/lod.cl), 0 where this device did not count it: what the progress line
     * weighs the samples by (app/eta.h). */
    uint32_t *pixel_cost;
    /* The table shade last got in grid_at (pipeline_grid_publish): vert_first and m of each
     * patch resident in the arenas, TS_INVALID elsewhere, and the patch's stitched edges
     * (pipeline_stitch_edges); grid_off (TESSERA_GRID_NORMALS=0, for checks) publishes no
     * grid, so shade evaluates every normal. */
    uint32_t *grid_at_host;
    int grid_off;
    /* The patch across each edge of each patch (scene_edge_neighbours), for triangle mode's
     * stitching; made by pipeline_stitch_prepare, NULL until then and in box mode. */
    uint32_t *edge_nb;
    /* The store this device shares built patches through with the devices of its process
     * that compute alike (patch_share.h; app/workers.c sets it once the frame's levels of
     * detail are known), and its slot there; NULL: every miss is diced here. */
    ts_patch_share *share;
    uint32_t share_owner;
    double share_wait_seconds; /* waiting for other devices' claims (monotonic clock) */
    ts_tex_cache tex;          /* which tiles tex_pool holds (tex_cache.h) */
    uint32_t light_count;      /* entries of the lights buffer (lights.h) */
    uint32_t unseen_flags;     /* TS_PATCH_NO_SHADOW, _CAMERA, _INDIRECT where some patch has
                                  them: top_level reads patch attributes only then */
    /* Relighting with the scene's baked occlusion (relight.h; bands 0: none). */
    ts_relight_params relight;
    uint32_t wave;   /* the wave of paths being traced (stats iterations) */
    uint32_t in_lod; /* 1 while pipeline_lod traces its pass (stats iterations) */
    /* Asked after each iteration of pipeline_trace and between its batches when set
     * (app/workers.c: a unit that may be backed up, or a board closed by a stop signal;
     * app/render.c: a stop signal): 1 leaves the trace unfinished and sets cancelled, which
     * waves_trace_paths reads to end the wave (its results are dropped). Batches end with no
     * claim of the share store open, so nothing waits for this device. */
    int (*cancel)(void *ctx);
    void *cancel_ctx;
    int cancelled;
    /* The most rays a launch of top_level takes while cancel is set, so that a stop is
     * honoured between such runs too (TS_TOP_LEVEL_RUN; tests lower it). */
    uint32_t top_level_run;
    /* The pass pipeline_trace is tracing, for the cancel hook's progress line (app/eta.h
     * eta_wave_alone): the work of its iterations' batches so far, and of those the device
     * has finished (a batch's work: its misses' micro-quads and its segments' pairs, which
     * cost about alike: 193 and 190 ns in forest-100 at --memory 512), and when its first
     * batch was enqueued (stats_now; 0 before). */
    struct {
        double work, done, t0;
    } trace_progress;
    /* Called by pipeline_trace after each iteration's batches are traced, before resolve,
     * when set (tools/bench_cache --lazy, which replays the iteration in other orders; NULL in
     * a render): the iteration's rays (active[0..active), windows of n_per_ray pairs, or
     * window_first's when 0), its `valid` pairs sorted by patch in `pairs` (pairs or
     * pairs_scratch), and its segments and batches in segments_host, batches and trees_host;
     * pair_hit holds each pair's hit. */
    int (*iteration_watch)(void *ctx, struct ts_pipeline *p, uint32_t active, uint32_t n_per_ray,
                           cl_mem pairs, uint32_t valid, uint32_t segs, ts_error *err);
    void *iteration_ctx;
    /* Stages only some commands run, with their own kernels and buffers, made on demand
     * (bake.h: `tessera bake`) and released by pipeline_destroy; NULL otherwise. */
    struct ts_bake_stage *bake;
#define TS_KERNEL_FIELD(field, name) cl_kernel field;
    TS_PIPELINE_KERNELS(TS_KERNEL_FIELD)
#undef TS_KERNEL_FIELD
#define TS_BUFFER_FIELD(field, flags, type, count, contents) cl_mem field;
    TS_PIPELINE_BUFFERS(TS_BUFFER_FIELD)
#undef TS_BUFFER_FIELD
#define TS_RAY_BUFFER(type, name, what) cl_mem ray_##name;
    TS_RAY_FIELDS(TS_RAY_BUFFER)
#undef TS_RAY_BUFFER
#define TS_PATH_BUFFER(type, name, what) cl_mem path_##name;
    TS_PATH_FIELDS(TS_PATH_BUFFER)
#undef TS_PATH_BUFFER
} ts_pipeline;

/* Creates buffers and kernels for `scene` on `cl` with an image of pixel_count pixels: the
 * scene's data uploaded, the film and the LOD counts cleared. On failure everything made so
 * far is released and *p zeroed (pipeline_destroy on it does nothing). */
int pipeline_create(ts_pipeline *p, ts_device *cl, const ts_scene *scene,
                    const ts_pipeline_plan *plan, uint32_t pixel_count, ts_stats *stats,
                    ts_error *err);
void pipeline_destroy(ts_pipeline *p);
/* Raises --stats' device_bytes_peak to the most bytes p's device buffers (dev_buffer_create,
 * dev_buffer_release) have held at once since pipeline_create; called after every buffer
 * the pipeline and its stages make. */
void pipeline_note_device_bytes(ts_pipeline *p);

/* The bytes the skeletons of the frame's patches would take (trace.c skeleton_prepare's
 * layout at the levels of detail the lod stage gave them), 0 where this device and mode trace
 * none (not a CPU device built with the lanes, triangle mode, leaves of several micro-quads,
 * the group leaf kernel, shared dicings, paged textures). */
uint64_t pipeline_skeleton_bytes(const ts_pipeline *p);

/* camera: generates rays (and paths) first_sample .. first_sample + ray_count; lists them
 * in active and wave_paths. A wave holds at most ray_capacity / 2 paths: each path also
 * owns a shadow-ray slot. */
int pipeline_camera(ts_pipeline *p, const ts_camera_params *cam, ts_error *err);
/* The camera of the whole frame whose part (a CropWindow) cam renders, or cam itself, with
 * full_width and full_height filled in. */
ts_camera_params pipeline_full_frame(const ts_camera_params *cam);
/* The whole frame's pixels: the lod pass counts them all (pipeline_lod_count_pixels). */
static inline uint32_t pipeline_frame_pixels(const ts_camera_params *cam)
{
    return cam->full_width ? cam->full_width * cam->full_height : cam->width * cam->height;
}
/* How the lod stage picks each patch's m (pipeline_lod; docs/benchmarks.md "LOD rules"
 * has the measurement behind the default). */
typedef enum ts_lod_rule {
    /* Every crossing: the smallest m with 4^m >= the number of first-pass eye rays whose
     * traversal enters the patch's box, occluded or not (Hanika §3.3: R / spp). The default. */
    TS_LOD_RULE_CROSSED,
    /* Only crossings before each ray's closest hit: m = max(m_visible, m_crossed - 2). Fewer
     * micro-polygons, but a patch partly hidden gets fewer than one per pixel it shows. */
    TS_LOD_RULE_VISIBLE,
    /* m_crossed for a patch some eye ray reaches before its closest hit, m_crossed - 2 for
     * one no eye ray does (seen only by shadow and bounce rays). */
    TS_LOD_RULE_SEEN,
} ts_lod_rule;

/* How many levels coarser the visible and seen rules dice a patch hidden from the eye at
 * the most (like Cycles' offscreen dicing scale; 4^2 = 16 times fewer micro-polygons). */
#define TS_LOD_HIDDEN_COARSER 2u

/* lod: pipeline_lod_count adds the wave's rays (from pipeline_camera; when before_hit
 * traced, so ray_hit holds their closest hits, and only box entries before it count) to
 * the per-patch counts; pipeline_lod_finish turns them into patch_lod by `rule` (after the
 * first count, before_hit = 0: m_crossed, clamped to [0, max_lod]) and clears them. */
int pipeline_lod_count(ts_pipeline *p, uint32_t ray_count, int before_hit, ts_error *err);
int pipeline_lod_finish(ts_pipeline *p, ts_lod_rule rule, int before_hit, ts_error *err);
/* pipeline_lod_finish with `more` (patch_count counts, or NULL) added to this device's:
 * the counts other devices made over other pixels of the same pass (app/workers.c). */
int pipeline_lod_finish_with(ts_pipeline *p, ts_lod_rule rule, int before_hit, const uint32_t *more,
                             ts_error *err);
/* Reads this device's counts into counts (patch_count entries) and clears them. */
int pipeline_lod_take_counts(ts_pipeline *p, uint32_t *counts, ts_error *err);
/* The crossed rule's counts over pixels [begin, end) of the first sample pass only (one
 * ray each, wave by wave), left in this device's counts: the frame's counts are the sums
 * over any split of the pixels into ranges. */
int pipeline_lod_count_pixels(ts_pipeline *p, const ts_camera_params *cam, uint32_t begin,
                              uint32_t end, ts_error *err);
/* The whole lod stage over the frame's first sample pass (cam: the frame's camera; one ray
 * per pixel), wave by wave: every crossing, then, for the visible and seen rules, the pass
 * traced at those levels and counted again before the hits. Deterministic: the levels do
 * not depend on the waves. */
int pipeline_lod(ts_pipeline *p, const ts_camera_params *cam, ts_lod_rule rule, ts_error *err);

/* The arena entries the frame's patches take when every one is resident at once: vertices
 * and sibling groups at the level each is diced at (--lod's, else the lod stage's), twice
 * for a moving patch; an instance that shares its master's dicing takes none of its own. */
void pipeline_arena_need(const ts_pipeline *p, uint64_t *verts, uint64_t *groups);
/* Their bytes: pipeline_arena_need's entries at the arenas' sizes. */
uint64_t pipeline_arena_need_bytes(const ts_pipeline *p);
/* The patch cache's quotas (patch_cache_plan) from the frame's patches at their levels of
 * detail, when these changed since the last plan (a new lod stage, --lod, new arenas); the
 * cache is cleared when the quotas change. Between batches only. */
void pipeline_cache_plan(ts_pipeline *p);
/* The level patch `patch` is diced at: --lod's (p->mode.fixed_lod, clamped to the plan's
 * max_lod), else the lod stage's p->patch_lod. */
uint32_t pipeline_patch_lod(const ts_pipeline *p, uint32_t patch);
/* The bytes of plan's two arenas (vertices and sibling groups). */
uint64_t pipeline_arena_bytes(const ts_pipeline_plan *plan);
/* New arenas of verts vertices and groups sibling groups (each within the device's largest
 * buffer), replacing the old ones, and an empty patch cache over them. The old ones are
 * released first (never both at once: the budget holds the new ones alone). When the new ones
 * cannot be had, arenas of the old sizes are made again, empty, with the error in *err; when
 * not even those can be, p->grid is NULL and the pipeline is unusable (pipeline_destroy). */
int pipeline_grow_arenas(ts_pipeline *p, uint64_t verts, uint64_t groups, ts_error *err);
/* The places of the frame's patches when every one is resident at once (pipeline_arena_need's
 * count, in patch order): vert_first[i], group_first[i] and lod[i] of each patch i diced as
 * itself, UINT32_MAX where an instance shares its master's dicing; *verts and *groups: the
 * arenas' entries. Every array has patch_count entries (at least one). */
void pipeline_arena_places(const ts_pipeline *p, uint32_t *vert_first, uint32_t *group_first,
                           uint8_t *lod, uint64_t *verts, uint64_t *groups);
/* Arenas of verts vertices and groups sibling groups over host memory the caller owns
 * (grid: verts ts_vec4, tree: groups ts_box4, tight: groups ts_tight4, each 4096-aligned;
 * CL_MEM_USE_HOST_PTR, zero copy on devices that share host memory), replacing the old ones,
 * and a patch cache with the fixed places of pipeline_arena_places (patch_cache_create_placed;
 * the arrays are the caller's too). Devices of one process that compute alike bind the same
 * memory: a patch one of them dices is where the others read it (app/workers.c). The memory
 * must outlive the pipeline. Failures as pipeline_grow_arenas'. */
int pipeline_place_arenas(ts_pipeline *p, void *grid, void *tree, void *tight, uint64_t verts,
                          uint64_t groups, const uint32_t *vert_first, const uint32_t *group_first,
                          const uint8_t *lod, ts_error *err);
/* Tells shade, before each shade launch, where the patch cache holds each patch's diced grid
 * (grid_at: vert_first and m; written only when it changed). A displaced patch's shading
 * normal is its hit micro-quad's, from the quad's four vertices (lib/patch.h
 * patch_quad_shading_normal): shade reads them from the grid where the patch is resident at
 * the hit's m and evaluates them (the same bits) where it is not, so the image does not depend
 * on the cache, --memory or TESSERA_GRID_NORMALS=0 (none published, for checks). */
int pipeline_grid_publish(ts_pipeline *p, ts_error *err);
/* Triangle mode's stitching of patch `patch` diced at m (lib/quadtree.h quadtree_stitch): for
 * each edge k, in bits 4k..4k+3, how many levels coarser the patch across it is diced; 0 in
 * box mode, where the leaf boxes keep neighbours at different levels hole-free. */
uint32_t pipeline_stitch_edges(const ts_pipeline *p, uint32_t patch, uint32_t m);
/* In triangle mode, the table of which patch lies across each edge (p->edge_nb, 16 bytes a
 * patch), once; pipeline_trace and pipeline_dice_build call it. TS_E_MEMORY without it. */
int pipeline_stitch_prepare(ts_pipeline *p, ts_error *err);
/* Waves of `rays` rays from now on: every buffer sized by the plan's ray_capacity and
 * pair_capacity (the ray and path fields, TS_PIPELINE_WAVE_BUFFERS, the sort's host copies)
 * is released and made again at the new size; nothing in them is kept, so it is called
 * between waves. rays in [TS_LOCAL_SIZE, 2^25]. The image does not depend on it. On failure
 * the pipeline has no wave buffers and only pipeline_destroy may follow. */
int pipeline_resize_rays(ts_pipeline *p, uint32_t rays, ts_error *err);
/* "crossed", "visible" or "seen" (TESSERA_LOD_RULE); -1 for another name. */
int pipeline_lod_rule_parse(const char *name, ts_lod_rule *rule);

/* The two-level loop over the rays listed in active[0..ray_count) (camera lists them all):
 * returns when every ray's closest hit is known (or, for a shadow ray, any hit). */
int pipeline_trace(ts_pipeline *p, uint32_t ray_count, ts_error *err);
/* Single stages, for tests of one kernel against its C reference. pipeline_top_level runs
 * top_level once over active[0..active_count) and waits; pipeline_dice_build dices and
 * builds segments_host[0..count) (patch and lod set by the caller; they must fit the
 * arenas together) as one batch and waits. */
int pipeline_top_level(ts_pipeline *p, uint32_t active_count, uint32_t n_per_ray, ts_error *err);
/* The water-filled windows of the next top_level over active[0..active_count) (then run with
 * n_per_ray 0): window_first, the cap N through *n_fill and the slots through *slots; at
 * most max_n candidates a ray (trace.c water_fill). */
int pipeline_water_fill(ts_pipeline *p, uint32_t active_count, uint32_t max_n, uint32_t *n_fill,
                        uint32_t *slots, ts_error *err);
int pipeline_dice_build(ts_pipeline *p, uint32_t count, ts_error *err);
/* bottom_level (p->mode's kernel, exact and leaf_b) over the batch pipeline_dice_build made:
 * the pairs in `pairs` from segments_host[0].begin to the last segment's end, sorted by
 * segment, rays named by active[window / n_per_ray]; waits. Hits go to pair_hit[window]. */
int pipeline_bottom_level(ts_pipeline *p, uint32_t n_per_ray, ts_error *err);
/* shade: one path-tracing step for the paths wave_paths[0..path_count) of a wave of
 * wave_size paths (path i traces ray i and its shadow ray wave_size + i). Lists the paths
 * that go on in wave_paths and their rays in active; returns the counts. */
int pipeline_shade(ts_pipeline *p, const ts_shade_params *sp, uint32_t first_sample,
                   uint32_t wave_size, uint32_t path_count, uint32_t *next_paths,
                   uint32_t *next_rays, uint32_t *shadow_rays, ts_error *err);
/* film: adds the wave's finished paths (the samples cam->first_sample .. + cam->ray_count of
 * the frame's order, cam->spp and cam->band) to the image. */
int pipeline_film(ts_pipeline *p, const ts_camera_params *cam, ts_error *err);

#endif
