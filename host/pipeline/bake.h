/* bake.h — the device side of `tessera bake` (stage `bake`, kernels/bake.cl, docs/bake.md;
 * PantaRay §3, §4.4): waves of points on the patches, N shadow rays each traced by the
 * pipeline's two-level loop, their visibility projected onto real spherical harmonics.
 *
 * The points of patch p are the (2^m+1)^2 vertices of p diced at m = lod[p]; the pipeline
 * dices p at the same m for tracing, so every point is a vertex of the micro-triangles its
 * own rays leave (the origin-patch rule of bottom_level then keeps them from hitting their
 * own patch at the start). Global point g is vertex k = g - point_first[p] of the patch p
 * with point_first[p] <= g < point_first[p + 1], row by row: (i, j) = (k mod n, k div n),
 * n = 2^m + 1. */
#ifndef TS_PIPELINE_BAKE_H
#define TS_PIPELINE_BAKE_H

#include "device/device.h"
#include "lib/shared_types.h"

#include <stdint.h>

struct ts_pipeline;

/* What a bake fixes for all its waves. */
typedef struct ts_bake_setup {
    uint32_t bands, rays, flags, seed; /* ts_bake_params: B, N, TS_BAKE_*, --seed */
    uint32_t orthographic;             /* the camera: eye[] is its forward direction */
    float eye[4];                      /* the camera's position (perspective) */
    const uint32_t *lod;               /* patch_count: each patch's m (<= the plan's max_lod) */
    const uint32_t *point_first;       /* patch_count + 1 prefix sums of (2^m+1)^2 */
} ts_bake_setup;

/* The bake's kernels and buffers on one pipeline (pipeline.h p->bake; pipeline_destroy
 * releases them). Buffers hold one wave: points_per_wave = ray_capacity / N points. */
typedef struct ts_bake_stage {
    ts_bake_params params;
    uint32_t points_per_wave;
    uint32_t *point_first_host; /* copy of the setup's, for chunking by patch */
    cl_kernel k_points, k_rays, k_project;
    cl_mem point_first, lod, point_pos, point_n, point_patch, coeffs;
} ts_bake_stage;

/* Makes p->bake for `setup` on pipeline p: checks that one point's N rays fit a wave, copies
 * the levels of detail into p->patch_lod (the dicing m of every patch: p->mode.fixed_lod is
 * set to -1 and the patch cache cleared) and uploads the point table. TS_E_USAGE when N rays
 * exceed the wave (raise --memory or lower --rays). */
int bake_stage_create(struct ts_pipeline *p, const ts_bake_setup *setup, ts_error *err);
void bake_stage_destroy(ts_device *cl, ts_bake_stage *b);

/* Bakes points [first, first + count) (count <= points_per_wave): bake_points, bake_rays,
 * the two-level loop (pipeline_trace), bake_project. Writes count * B^2 coefficients to
 * coeffs and each point's position (w: the rays' offset) and normal to pos and normal.
 * Counts the points (bake_points) and their N rays (rays). */
int bake_stage_wave(struct ts_pipeline *p, uint32_t first, uint32_t count, float *coeffs,
                    ts_vec4 *pos, ts_vec4 *normal, ts_error *err);

#endif
