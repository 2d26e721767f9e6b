/* embree_ref.h — a reference tracer on Embree 3 for cross-checks and benchmarks (DESIGN.md
 * §5): every patch of a scene diced at one fixed m into the same micro-triangles as the
 * bottom level (same vertices: embree_ref_vertex; same split: micro-quad (i, j) gives
 * triangles (v00, v10, v11) and (v00, v11, v01)), one Embree triangle mesh per patch with
 * geomID = patch index and primID = the bottom level's micro-triangle index
 * 2 * (j * 2^m + i) + (0 | 1) (returned as ts_hit.prim = TS_PRIM(m, primID)). A moving patch
 * (Hanika §3.4) gets its grids at both time samples, interpolated linearly at the ray's time
 * (dir.w) by Embree. Embree is a dependency of the tests and benchmarks only, never of the
 * renderer; none of its types appear here. */
#ifndef TS_EMBREE_REF_H
#define TS_EMBREE_REF_H

#include "base/error.h"
#include "scene/scene.h"

#include <stdint.h>

typedef struct ts_embree_options {
    int robust;  /* 1: RTC_SCENE_FLAG_ROBUST (watertight edges, no missed seams) */
    int quality; /* 0 low, 1 medium, 2 high: RTC_BUILD_QUALITY_* of the BVH */
} ts_embree_options;

/* Robust, medium quality: what embree_ref_create uses when given NULL options. */
#define TS_EMBREE_DEFAULTS ((ts_embree_options){1, 1})

/* What building the reference cost, for benchmarks. Bytes are Embree's own allocations as
 * its memory monitor reports them (rtcSetDeviceMemoryMonitorFunction): geometry buffers and
 * the BVH. */
typedef struct ts_embree_info {
    uint32_t lod;                 /* m */
    uint64_t triangles, vertices; /* over all patches (vertices: both time samples) */
    double tessellate_seconds;    /* host dicing and filling Embree's buffers */
    double build_seconds;         /* rtcCommitScene: the BVH build, wall clock */
    int64_t bytes_before_build;   /* held after the buffers are filled, before the build */
    int64_t bytes_peak;           /* the most held at any time up to the end of the build */
    int64_t bytes_after_build;    /* held once the scene is committed (buffers + BVH) */
} ts_embree_info;

typedef struct ts_embree_ref ts_embree_ref;

/* Dices every patch of `scene` at m (0 .. TS_LOD_LIMIT) and builds the Embree scene. Embree
 * errors come back through err (TS_E_INTERNAL, or TS_E_MEMORY for Embree's out-of-memory),
 * never as an abort. The scene's data is copied: it may be freed afterwards. */
int embree_ref_create(ts_embree_ref **out, const ts_scene *scene, uint32_t m,
                      const ts_embree_options *opt, ts_error *err);
void embree_ref_destroy(ts_embree_ref *r);
const ts_embree_info *embree_ref_info(const ts_embree_ref *r);

/* Closest hit of each of `count` rays: origin org[i].xyz, direction dir[i].xyz (unit, as the
 * ray buffers hold them), tnear = 0, tfar = infinity, time = dir[i].w; with from (NULL:
 * none) hits on patch from[i] - 1 nearer than org[i].w are ignored, as bottom_level does
 * for the patch a ray leaves (an Embree context filter). hit[i] gets
 * t, the patch parameters (u, v) of the hit point (as bottom_level computes them), patch and
 * prim = TS_PRIM(m, micro-triangle); t = TS_NO_HIT and patch = prim = TS_INVALID on a miss. */
int embree_ref_trace(ts_embree_ref *r, const ts_vec4 *org, const ts_vec4 *dir, const uint32_t *from,
                     uint32_t count, ts_hit *hit, ts_error *err);

/* Diced vertex (i, j) of patch p at m and time sample `time` (0: scene cp, 1: cp1 of a
 * moving patch): lib/patch.h patch_vertex at u = i * 2^-m, v = j * 2^-m exactly, as the
 * dice kernel computes it; w = 1. */
ts_vec4 embree_ref_vertex(const ts_scene *scene, uint32_t p, uint32_t m, uint32_t i, uint32_t j,
                          uint32_t time);

#endif
