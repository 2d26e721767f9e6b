/* budget.h — the memory budget of `tessera render` (docs/rendering.md "The memory budget"):
 * --memory when given, else a default sized from what the device and the process may
 * still use, so that a render under a memory limit starts at a budget that fits instead of
 * halving its way down from a fixed 1024 MB. */
#ifndef TS_BUDGET_H
#define TS_BUDGET_H

#include "base/memory.h"
#include "device/device.h"
#include "pipeline/pipeline.h"
#include "scene/scene.h"

/* The default's cap: beyond it waves rarely gain (the patch cache grows past it when the
 * frame's patches need it, budget_grow_arenas). TESSERA_BUDGET_CAP_MB lowers it (a testing
 * aid: the image does not depend on it). */
#define TS_BUDGET_CAP_MB 1024u
/* The smallest budget: the default never goes below it, and an out-of-memory retry stops
 * there. */
#define TS_MEMORY_FLOOR_MB 16u

typedef struct ts_budget_choice {
    uint64_t mb;      /* the budget for rays, candidates and patch slots, in MB */
    uint64_t room_mb; /* what the device and the process's limits allow, the cap aside: how
                         far the patch cache may grow to hold the frame's patches
                         (budget_grow_arenas); mb with --memory */
    char why[192];    /* what set it, for the progress header: "--memory", "the default's cap
                         of 1024 MB", "RLIMIT_AS: 612 MB of 1000 MB left", ... */
} ts_budget_choice;

/* Bytes the device holds for a render beside the budget: the three films (16 bytes a pixel
 * each) and the scene's patch data (control points at both times, corner normals,
 * attributes, flatness, boxes, the top-level BVH, the per-patch lists). */
uint64_t budget_fixed_bytes(const ts_scene *scene, uint64_t pixel_count);

/* The default budget: the smallest of TS_BUDGET_CAP_MB; half of what the device's global
 * memory leaves beside the fixed bytes, less the texture pool's eighth on top (x 8/9; not on
 * a CPU device sharing host memory when the process's room is known: that room bounds it); four
 * times the device's largest buffer (the patch arenas are a quarter of the budget, in
 * single buffers); and, on a device that shares host memory, the same half of the room
 * the process's limits leave (room, from ts_memory_room_query, minus the fixed bytes).
 * The other half stays free for what the budget does not count: the driver's threads and
 * compiler, the image encoder, other users of the device. Never below
 * TS_MEMORY_FLOOR_MB. */
void budget_default(const ts_device_info *dev, uint64_t fixed_bytes, const ts_memory_room *room,
                    ts_budget_choice *out);

/* --memory MB: the budget, which never grows (room_mb = mb). */
void budget_fixed(uint64_t mb, ts_budget_choice *out);

/* Dice once when it fits (issue 13): after the lod stage, when the frame's patches at their
 * levels of detail (pipeline_arena_need) need more than the arenas p's budget gave (the
 * budget --stats records, p->stats->memory_budget_bytes), the arenas grow to hold them all,
 * as far as room_mb (ts_budget_choice.room_mb) allows beside the rest of that budget, and the
 * growth is added to memory_budget_bytes; so that each patch is diced once per frame instead
 * of again in every wave. When there is not that room (--memory, room_mb no larger than the
 * budget, or not enough of it) and `trade` is set, the budget is split again instead (Hanika
 * §4's trade of rays per wave against patch memory) when the frame's patches fit in
 * TS_TRADE_ARENA_PART / TS_TRADE_ARENA_DIV of what the plan gave the arenas and the waves
 * together: the arenas take what they need and the waves the rest (pipeline_resize_rays),
 * so the budget's total stays. When they do not fit even so, the plan's split stays: rays
 * per wave then bound how often the patches are diced again. When they fit, waves are cut to
 * TS_FIT_WAVE_RAYS. `trade` only between waves, and only
 * where nothing was sized by the rays of a wave (a bake's points per wave are). The image does not
 * depend on any of it. Notes on stderr unless quiet; TS_E_* in *err only when the pipeline is left
 * unusable. */
/* Once the frame's patches are all resident, waves of at most this many rays (a million
 * paths): larger ones dice nothing less and only hold memory (forest-1000 1920x768 x 32 in
 * the default budget: waves of 3.3 M rays, 5.16 GiB peak, 160.6 s; of 2.1 M, 4.96 GiB,
 * 165.5 s, the same within this machine's noise; docs/benchmarks.md). */
#define TS_FIT_WAVE_RAYS (1u << 21)
/* A frame whose patches need more than this many times the patch arenas (after any growth)
 * gives three quarters of the arenas to the rays when that makes fewer waves (budget.c
 * thin_arenas; forest-100 1920x768 x 2 at --memory 512, 15 times: 3 waves instead of 4, 534 K
 * dicings and 89.0 s against 571 K and 98.7 s; at --memory 1600, 4.4 times: 1 wave instead of
 * 2, 306 K and 38.4 s against 380 K and 48.6 s, which the earlier bound of 8 left undone;
 * docs/benchmarks.md). Trading rays for arenas (TS_TRADE_ARENA_PART) takes the frames whose
 * patches need under three times the plan's arenas. */
#define TS_THIN_NEED_DIV 4u
/* A frame whose patches do not fit and whose arenas are not thinned gives up to
 * 1 / TS_SKELETON_ARENA_DIV of them to skeletons (budget.c skeleton_room; forest-100 960x384
 * x 1 at --memory 1024 .. 128, 2.7 MB of skeletons: 2.80-3.08 s against 3.22-4.34 s without;
 * docs/benchmarks.md). */
#define TS_SKELETON_ARENA_DIV 8u
#define TS_TRADE_ARENA_PART 3u
#define TS_TRADE_ARENA_DIV 4u
int budget_grow_arenas(ts_pipeline *p, uint64_t room_mb, int trade, int quiet, ts_error *err);

#endif
