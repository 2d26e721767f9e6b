/* budget.c — the default memory budget (budget.h). */
#include "app/budget.h"
#include "base/error.h"
#include "pipeline/qbvh.h"
#include "pipeline/relight.h"
#include "lib/quadtree.h"
#include "lib/sh.h"

#include <stdio.h>
#include <stdlib.h>

uint64_t budget_fixed_bytes(const ts_scene *scene, uint64_t pixel_count)
{
    /* The per-patch buffers of pipeline.h's TS_PIPELINE_BUFFERS (cp1 only with motion). */
    uint64_t per_patch = (scene->cp1 ? 2 : 1) * 16 * sizeof(ts_vec4) /* cp, cp1 */ +
                         9 * sizeof(ts_vec4) /* corner and mid normals */ + sizeof(ts_patch_attr) +
                         sizeof(ts_vec4) /* flatness */ + sizeof(ts_box) +
                         sizeof(ts_qbvh_node) /* at most one node a patch */ + sizeof(ts_segment) +
                         2 * sizeof(uint32_t) /* trees */ + sizeof(uint32_t) /* lod counts */ +
                         TS_CULL_GROUPS * sizeof(ts_tight4) + sizeof(uint32_t) /* culling */ +
                         sizeof(uint32_t) /* leaving */ + 3 * sizeof(uint32_t) /* grid_at */ +
                         sizeof(uint32_t) /* skel_first */;
    const ts_occlusion *o = scene->occlusion; /* --occlusion's points and tables (relight.h) */
    uint64_t occlusion =
        o ? (uint64_t)o->point_count * (o->bands * o->bands + 3) * sizeof(float) +
                (uint64_t)o->patch_count * 2 * sizeof(uint32_t) +
                (TS_RELIGHT_TABLE_FIRST +
                 (uint64_t)TS_RELIGHT_TABLE_W * TS_RELIGHT_TABLE_H * TS_SH_MAX_COEFFS) *
                    sizeof(ts_vec4)
          : 0;
    return 3 * sizeof(ts_vec4) * pixel_count + per_patch * scene->patch_count + occlusion;
}

/* The value of environment variable `name` when it is a number in [lo, hi], else hi (the
 * testing aids that lower a limit). */
static unsigned long env_lower(const char *name, unsigned long lo, unsigned long hi)
{
    const char *env = getenv(name);
    if (!env || !*env) return hi;
    char *end;
    unsigned long v = strtoul(env, &end, 10);
    return !*end && v >= lo && v <= hi ? v : hi;
}

/* Half of what `total` leaves beside `fixed`, less the texture pool's eighth on top, in MB. */
static uint64_t half_room_mb(uint64_t total, uint64_t fixed)
{
    uint64_t left = total > fixed ? total - fixed : 0;
    return left / 2 / 9 * 8 >> 20;
}

/* Whether the device's global memory bounds the room: not on a CPU device that shares host
 * memory when the process's room is known. Its buffers are the process's memory, and the size
 * it reports is the implementation's guess, which it does not enforce (PoCL 3.1: its NUMA
 * node's memory as hwloc sees it less 2 GiB, 4.75 or 9.96 GiB on one 24 GiB virtual machine as
 * its memory came online; 7.5 GB of buffers run there): the process's room
 * (ts_memory_room_query) is the real one. */
static int global_mem_bounds(const ts_device_info *dev, const ts_memory_room *room)
{
    return !(dev->host_unified && (dev->type & CL_DEVICE_TYPE_CPU) && room->bytes != UINT64_MAX);
}

void budget_default(const ts_device_info *dev, uint64_t fixed_bytes, const ts_memory_room *room,
                    ts_budget_choice *out)
{
    unsigned cap = (unsigned)env_lower("TESSERA_BUDGET_CAP_MB", TS_MEMORY_FLOOR_MB,
                                       TS_BUDGET_CAP_MB); /* a testing aid */
    out->mb = cap;
    snprintf(out->why, sizeof out->why, "the default's cap of %u MB", cap);
    int global = global_mem_bounds(dev, room);
    uint64_t mb = global ? half_room_mb(dev->global_mem, fixed_bytes) : UINT64_MAX;
    if (mb < out->mb) {
        out->mb = mb;
        snprintf(out->why, sizeof out->why, "the device's %llu MB of global memory",
                 (unsigned long long)(dev->global_mem >> 20));
    }
    mb = 4 * (dev->max_alloc >> 20);
    if (mb < out->mb) {
        out->mb = mb;
        snprintf(out->why, sizeof out->why, "the device's largest buffer, %llu MB",
                 (unsigned long long)(dev->max_alloc >> 20));
    }
    if (dev->host_unified && room->bytes != UINT64_MAX) {
        mb = half_room_mb(room->bytes, fixed_bytes);
        if (mb < out->mb) {
            out->mb = mb;
            if (room->limit == room->bytes) /* MemAvailable: no use to subtract */
                snprintf(out->why, sizeof out->why, "%s %llu MB", room->which,
                         (unsigned long long)(room->bytes >> 20));
            else
                snprintf(out->why, sizeof out->why, "%s: %llu MB of %llu MB left", room->which,
                         (unsigned long long)(room->bytes >> 20),
                         (unsigned long long)(room->limit >> 20));
        }
    }
    if (out->mb < TS_MEMORY_FLOOR_MB) out->mb = TS_MEMORY_FLOOR_MB;
    /* The room beside the cap: the device's and the process's halves (the largest buffer
     * limits each arena by itself, in budget_grow_arenas). */
    out->room_mb = global ? half_room_mb(dev->global_mem, fixed_bytes) : UINT64_MAX;
    if (dev->host_unified && room->bytes != UINT64_MAX) {
        mb = half_room_mb(room->bytes, fixed_bytes);
        if (mb < out->room_mb) out->room_mb = mb;
    }
    if (out->room_mb < out->mb) out->room_mb = out->mb;
}

void budget_fixed(uint64_t mb, ts_budget_choice *out)
{
    out->mb = out->room_mb = mb;
    snprintf(out->why, sizeof out->why, "--memory");
}

/* New arenas of verts and groups entries (pipeline_grow_arenas); when they cannot be had
 * the old sizes stay, a note says why unless quiet, and 0 is returned. 1: grown; -1: not
 * even the old sizes could be made again (the error in *err). */
static int arenas_grow(ts_pipeline *p, uint64_t verts, uint64_t groups, int quiet, ts_error *err)
{
    uint64_t have = pipeline_arena_bytes(&p->plan);
    if (!pipeline_grow_arenas(p, verts, groups, err)) return 1;
    if (!p->grid) return -1;
    if (!quiet)
        ts_print_line("tessera: note: the patch cache stays at %llu MB (%s)",
                      (unsigned long long)(have >> 20), err->msg);
    ts_error_clear(err);
    return 0;
}

/* The arenas within the budget (budget_grow_arenas' trade): when the frame's patches fit in
 * TS_TRADE_ARENA_PART of what the plan gave the arenas and the waves together, the patch
 * cache takes what they need and the waves keep the rest. Not when they do not fit: then
 * the patches are diced again in every wave whatever the cache holds, and fewer rays a wave
 * means more waves to dice them in (forest-100 at --memory 512: 684 k dicings with the
 * arenas at three quarters against 566 k with the plan's quarter; docs/benchmarks.md).
 * Returns 1 when it traded, with the note printed unless quiet; 0 when it did not. */
static int trade_rays(ts_pipeline *p, uint64_t verts, uint64_t groups, int quiet, ts_error *err)
{
    uint64_t have = pipeline_arena_bytes(&p->plan);
    uint64_t need = verts * sizeof(ts_vec4) + groups * TS_GROUP_BYTES;
    uint64_t rays_bytes = (uint64_t)p->plan.ray_capacity * TS_BYTES_PER_RAY;
    uint64_t total = have + rays_bytes;
    if (need > total / TS_TRADE_ARENA_DIV * TS_TRADE_ARENA_PART) return 0;
    uint64_t arena = need;
    uint64_t rays = (total - arena) / TS_BYTES_PER_RAY;
    if (rays > p->plan.ray_capacity) rays = p->plan.ray_capacity;
    if (rays < TS_LOCAL_SIZE) return 0;
    /* Never fewer entries than the plan's (which hold a moving patch at max_lod). */
    uint64_t v = verts, g = groups;
    if (v < p->plan.vert_capacity) v = p->plan.vert_capacity;
    if (g < p->plan.group_capacity) g = p->plan.group_capacity;
    uint32_t old_rays = p->plan.ray_capacity;
    if (pipeline_resize_rays(p, (uint32_t)rays, err)) return -1;
    int grown = arenas_grow(p, v, g, quiet, err);
    if (grown < 0) return -1;
    if (!grown) return 1; /* smaller waves, the old arenas */
    uint64_t now = pipeline_arena_bytes(&p->plan);
    if (!quiet)
        ts_print_line("tessera: the frame's patches need %llu MB at their levels of detail: "
                      "the patch cache takes %llu MB of the %llu MB budget instead of %llu MB, "
                      "waves %u rays instead of %u (--memory sets the budget)",
                      (unsigned long long)(need >> 20), (unsigned long long)(now >> 20),
                      (unsigned long long)(p->stats->memory_budget_bytes >> 20),
                      (unsigned long long)(have >> 20), p->plan.ray_capacity, old_rays);
    return 1;
}

/* The frame's patches (verts and groups entries, need bytes) do not fit the room: the arenas take
 * all of it (extra bytes beyond the budget's arenas), split as the patches need, and the patch
 * cache's size classes each get the same share of their patches (patch_cache_plan); so a frame
 * 5% over the room keeps 95% of its patches, not the plan's quarter of the budget. */
static int take_the_room(ts_pipeline *p, uint64_t verts, uint64_t groups, uint64_t need,
                         uint64_t extra, int quiet, ts_error *err)
{
    uint64_t have = pipeline_arena_bytes(&p->plan);
    double share = (double)(have + extra) / (double)need;
    uint64_t v = (uint64_t)(share * (double)verts), g = (uint64_t)(share * (double)groups);
    if (v < p->plan.vert_capacity) v = p->plan.vert_capacity; /* a moving patch at max_lod */
    if (g < p->plan.group_capacity) g = p->plan.group_capacity;
    int grown = extra > 0 ? arenas_grow(p, v, g, quiet, err) : 1;
    if (grown <= 0) return grown < 0 ? err->code : TS_OK;
    uint64_t now = pipeline_arena_bytes(&p->plan);
    p->stats->memory_budget_bytes += now - have;
    if (!quiet)
        ts_print_line("tessera: the frame's patches need %llu MB at their levels of detail, "
                      "more than the %llu MB there is room for: the patch cache takes all of it "
                      "(%.0f%% of the patches at once) and dices the others again when they "
                      "return (--memory sets the budget)",
                      (unsigned long long)(need >> 20), (unsigned long long)(now >> 20),
                      100.0 * (double)now / (double)need);
    return TS_OK;
}

/* The frame's patches are all resident (each is diced once): waves larger than
 * TS_FIT_WAVE_RAYS would only hold memory, so they are made that size (only where `trade`
 * allows waves to be resized). */
static int fit_waves(ts_pipeline *p, int trade, ts_error *err)
{
    uint32_t cap = (uint32_t)env_lower("TESSERA_FIT_WAVE_RAYS", 2 * TS_LOCAL_SIZE,
                                       TS_FIT_WAVE_RAYS); /* a testing aid: a lower cap */
    if (!trade || p->plan.ray_capacity <= cap) return TS_OK;
    return pipeline_resize_rays(p, cap, err);
}

/* The arenas hold under 1 / TS_THIN_NEED_DIV of the frame's patches: few come back resident
 * whatever they hold, and each wave dices the rest again. Three quarters of them go to the
 * rays when that makes fewer waves of the frame's frame_rays rays (0: unknown, nothing done),
 * keeping room for two moving patches at the frame's finest level; the smaller arenas are
 * made before the larger waves, so the device never holds more than the budget. */
static int thin_arenas(ts_pipeline *p, uint64_t need, uint64_t frame_rays, int quiet, ts_error *err)
{
    uint64_t have = pipeline_arena_bytes(&p->plan);
    if (frame_rays == 0 || need / TS_THIN_NEED_DIV <= have) return TS_OK;
    uint64_t v = p->plan.vert_capacity / 4u, g = p->plan.group_capacity / 4u;
    uint32_t m = 0; /* still room for a moving patch at the frame's finest level */
    for (uint32_t i = 0; i < p->scene->patch_count; ++i) {
        uint32_t l = pipeline_patch_lod(p, i);
        if (l > m) m = l;
    }
    if (v < 2u * quadtree_vertex_count(m) || g < 2u * quadtree_group_count(m)) return TS_OK;
    uint64_t freed = have - (v * sizeof(ts_vec4) + g * TS_GROUP_BYTES);
    uint64_t rays = p->plan.ray_capacity + freed / TS_BYTES_PER_RAY;
    if (rays > (1u << 25)) rays = 1u << 25;
    uint64_t before = (frame_rays + p->plan.ray_capacity - 1) / p->plan.ray_capacity;
    uint64_t after = (frame_rays + rays - 1) / rays;
    if (after >= before) return TS_OK;
    /* The skeletons (trace.c skeleton_prepare) from the freed bytes too, as many as the waves
     * leave room for while they stay as few: a pass then traces a patch's few rays through its
     * kept skeleton instead of dicing it again. */
    uint64_t skel = pipeline_skeleton_bytes(p), room = 0;
    uint64_t least = (frame_rays + after - 1) / after; /* the rays a wave needs for `after` */
    if (skel > 0 && least < rays) {
        room = (rays - least) * TS_BYTES_PER_RAY;
        if (room > skel) room = skel;
        rays -= (room + TS_BYTES_PER_RAY - 1) / TS_BYTES_PER_RAY;
    }
    uint32_t old_rays = p->plan.ray_capacity;
    int grown = arenas_grow(p, v, g, quiet, err); /* smaller first: the budget holds both */
    if (grown < 0) return err->code;
    if (!grown) return TS_OK;
    if (pipeline_resize_rays(p, (uint32_t)rays, err)) return err->code;
    if (room) p->skel_room = room;
    if (!quiet)
        ts_print_line("tessera: the frame's patches need %llu MB, %llu times what the patch cache "
                      "holds: it takes %.1f MB instead of %.1f MB, and waves %u rays instead of "
                      "%u (%llu waves instead of %llu)",
                      (unsigned long long)(need >> 20), (unsigned long long)(need / have),
                      (double)pipeline_arena_bytes(&p->plan) / 1048576.0, (double)have / 1048576.0,
                      p->plan.ray_capacity, old_rays, (unsigned long long)after,
                      (unsigned long long)before);
    return TS_OK;
}

/* The frame's patches do not fit the arenas and thin_arenas kept no room for skeletons (it
 * did not thin them): up to 1 / TS_SKELETON_ARENA_DIV of the arenas goes to the skeletons
 * (trace.c skeleton_prepare), at most what the frame's trees would take, keeping room for two
 * moving patches at the frame's finest level. The patch cache then holds a little less, and a
 * pass traces a patch's few rays through its skeleton instead of dicing it again. */
static int skeleton_room(ts_pipeline *p, int quiet, ts_error *err)
{
    uint64_t have = pipeline_arena_bytes(&p->plan), skel = pipeline_skeleton_bytes(p);
    if (p->skel_room || skel == 0 || have == 0) return TS_OK;
    uint64_t room = have / TS_SKELETON_ARENA_DIV < skel ? have / TS_SKELETON_ARENA_DIV : skel;
    double keep = (double)(have - room) / (double)have;
    uint64_t v = (uint64_t)(keep * (double)p->plan.vert_capacity),
             g = (uint64_t)(keep * (double)p->plan.group_capacity);
    uint32_t m = 0;
    for (uint32_t i = 0; i < p->scene->patch_count; ++i) {
        uint32_t l = pipeline_patch_lod(p, i);
        if (l > m) m = l;
    }
    if (v < 2u * quadtree_vertex_count(m) || g < 2u * quadtree_group_count(m)) return TS_OK;
    int grown = arenas_grow(p, v, g, quiet, err);
    if (grown <= 0) return grown < 0 ? err->code : TS_OK;
    uint64_t freed = have - pipeline_arena_bytes(&p->plan);
    p->skel_room = freed < skel ? freed : skel;
    return TS_OK;
}

int budget_grow_arenas(ts_pipeline *p, uint64_t room_mb, int trade, int quiet, ts_error *err)
{
    p->skel_room = 0; /* thin_arenas or skeleton_room make room for skeletons */
    uint64_t mb = p->stats->memory_budget_bytes >> 20;
    uint64_t verts, groups;
    pipeline_arena_need(p, &verts, &groups);
    uint64_t have = pipeline_arena_bytes(&p->plan);
    uint64_t need = verts * sizeof(ts_vec4) + groups * TS_GROUP_BYTES;
    if (need <= have) return fit_waves(p, trade, err);
    if (!trade && room_mb <= mb) return TS_OK;
    uint64_t extra = room_mb > mb ? (room_mb - mb) << 20 : 0;
    if (need - have > extra) {
        int traded = trade ? trade_rays(p, verts, groups, quiet, err) : 0;
        if (traded < 0) return err->code;
        if (traded)
            return pipeline_arena_bytes(&p->plan) >= need ? fit_waves(p, trade, err) : TS_OK;
        if (take_the_room(p, verts, groups, need, extra, quiet, err)) return err->code;
        if (trade && thin_arenas(p, need, p->frame_rays, quiet, err)) return err->code;
        return skeleton_room(p, quiet, err);
    }
    int grown = arenas_grow(p, verts, groups, quiet, err);
    if (grown <= 0) return grown < 0 ? err->code : TS_OK;
    if (fit_waves(p, trade, err)) return err->code;
    uint64_t now = pipeline_arena_bytes(&p->plan);
    if (!quiet)
        ts_print_line("tessera: the frame's patches need %llu MB at their levels of detail: "
                      "the patch cache grows from %llu to %llu MB to dice each once "
                      "(--memory sets the budget)",
                      (unsigned long long)(need >> 20), (unsigned long long)(have >> 20),
                      (unsigned long long)(now >> 20));
    p->stats->memory_budget_bytes += now - have;
    return TS_OK;
}
