/* relight_ref.h — the plain-C reference of the relit term of stage `shade` (render
 * --occlusion; kernels/lib/relight.h, docs/bake.md "Relighting"; DESIGN.md §5): the baked
 * coefficients at a hit, bilinear over the patch's grid, and the domes' irradiance through
 * them, written again in double precision from the definitions. It shares only sh.h's Y_j
 * with the kernel; tests/test_relight_kernels.c compares it with what shade_path adds. */
#ifndef TS_RELIGHT_REF_H
#define TS_RELIGHT_REF_H

#include "lib/shared_types.h"
#include "scene/scene.h"

#include <stdint.h>

/* The B^2 coefficients of occlusion o at (u, v) of patch p for shading normal n into out[]:
 * the grid points around (u, v) whose normal faces n, bilinear weights renormalised (all
 * four when none does). */
void relight_ref_coeffs(const ts_occlusion *o, uint32_t p, double u, double v, const double n[3],
                        double *out);

/* The domes' irradiance e[3] at a point with coefficients c[] and unit shading normal n
 * under parameters rp and the light buffer `light` (shared_types.h ts_relight_params).
 * *scale gets the sum of the absolute values of the terms added (for rounding tolerances). */
void relight_ref_irradiance(const ts_relight_params *rp, const ts_vec4 *light, const double *c,
                            const double n[3], double e[3], double *scale);

#endif
