/* bake_ref.h — the plain-C reference of stage `bake` (kernels/bake.cl; DESIGN.md §5): the
 * three kernels bake_points, bake_rays and bake_project written again in scalar C for one
 * point, one ray or one point's projection. It shares the small maths helpers of
 * kernels/lib (patch.h's displaced vertex and shading normal, sampler.h, bsdf.h's frames,
 * sh.h) with the kernels, and the patch data dice_build_ref_patch_of gives (the defaults
 * pipeline.c uploads), so results agree with the kernels' to rounding
 * (tests/test_bake_kernels.c). */
#ifndef TS_BAKE_REF_H
#define TS_BAKE_REF_H

#include "lib/shared_types.h"
#include "scene/scene.h"

#include <stdint.h>

/* Global point g of a bake with levels lod[] and prefix sums point_first[] (patch_count + 1
 * entries; bp->patch_count patches): its patch, its position (xyz displaced, w the rays'
 * offset eps = l / 2^m) and its normal (unit, faceforwarded to bp->eye unless
 * TS_BAKE_FRONT). */
void bake_ref_point(const ts_scene *s, const ts_bake_params *bp, const uint32_t *lod,
                    const uint32_t *point_first, uint32_t g, ts_vec4 *pos, ts_vec4 *normal,
                    uint32_t *patch);

/* Ray k of global point g at pos, normal on patch: origin (w = eps), direction, and whether it
 * is traced (0: below the surface, V = 0). */
void bake_ref_ray(const ts_bake_params *bp, ts_vec4 pos, ts_vec4 normal, uint32_t g, uint32_t k,
                  ts_vec4 *org, ts_vec4 *dir, int *traced);

/* The B^2 coefficients (bp->bands) of a point with normal n from its bp->rays directions
 * dir[] and whether each escaped (escaped[k] != 0: the ray hit nothing). */
void bake_ref_project(const ts_bake_params *bp, ts_vec4 n, const ts_vec4 *dir,
                      const uint8_t *escaped, float *coeffs);

#endif
