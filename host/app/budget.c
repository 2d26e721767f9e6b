/* budget.c — the default memory budget (budget.h). */
#include "app/budget.h"
#include "pipeline/qbvh.h"
#include "pipeline/relight.h"
#include "lib/sh.h"

#include <stdio.h>

uint64_t budget_fixed_bytes(const ts_scene *scene, uint64_t pixel_count)
{
    uint64_t per_patch = 2 * 16 * sizeof(ts_vec4) /* cp, cp1 */ + 4 * sizeof(ts_vec4) /* normals */
                         + sizeof(ts_patch_attr) + sizeof(ts_vec4) /* flatness */ + sizeof(ts_box) +
                         sizeof(ts_qbvh_node) /* at most one node a patch */ + sizeof(ts_segment) +
                         2 * sizeof(uint32_t) /* trees */ + sizeof(uint32_t) /* lod counts */;
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

/* Half of what `total` leaves beside `fixed`, less the texture pool's eighth on top, in MB. */
static uint64_t half_room_mb(uint64_t total, uint64_t fixed)
{
    uint64_t left = total > fixed ? total - fixed : 0;
    return left / 2 / 9 * 8 >> 20;
}

void budget_default(const ts_device_info *dev, uint64_t fixed_bytes, const ts_memory_room *room,
                    ts_budget_choice *out)
{
    out->mb = TS_BUDGET_CAP_MB;
    snprintf(out->why, sizeof out->why, "the default's cap of %u MB", TS_BUDGET_CAP_MB);
    uint64_t mb = half_room_mb(dev->global_mem, fixed_bytes);
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
}
