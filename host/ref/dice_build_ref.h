/* dice_build_ref.h — plain-C references of stages `dice` and `build` for one patch
 * (kernels/dice.cl, kernels/build.cl): its displaced grid and its implicit quad-tree, with
 * the same shared helpers (lib/patch.h, lib/displace.h, lib/quadtree.h) and the same
 * operation order, so the result is bitwise what the kernels write for that patch
 * (tests/test_bottom_level.c). Used by the host tracer of tools/bench_cache.c. */
#ifndef TS_DICE_BUILD_REF_H
#define TS_DICE_BUILD_REF_H

#include "scene/scene.h"

#include <stdint.h>

/* Time samples of patch p: 2 when it moves (Hanika §3.4), else 1. */
uint32_t dice_build_ref_times(const ts_scene *s, uint32_t p);

/* Dices patch p at LOD m into grid (times x (2^m+1)^2 vertices, time 0 first) and builds its
 * trees into groups (times x quadtree_group_count(m) sibling groups), laid out as a segment
 * of the arenas is. */
void dice_build_ref(const ts_scene *s, uint32_t p, uint32_t m, ts_vec4 *grid, ts_box4 *groups);

#endif
