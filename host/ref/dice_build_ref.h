/* dice_build_ref.h — plain-C references of stages `dice` and `build` for one patch
 * (kernels/dice.cl, kernels/build.cl): its displaced grid and its implicit quad-tree, with
 * the same shared helpers (lib/patch.h, lib/displace.h, lib/quadtree.h) and the same
 * operation order, so the result is bitwise what the kernels write for that patch
 * (tests/test_bottom_level.c). Used by the host tracer of tools/bench_cache.c. */
#ifndef TS_DICE_BUILD_REF_H
#define TS_DICE_BUILD_REF_H

#include "lib/displace.h"
#include "scene/scene.h"

#include <stdint.h>

/* Time samples of patch p: 2 when it moves (Hanika §3.4), else 1. */
uint32_t dice_build_ref_times(const ts_scene *s, uint32_t p);

/* What build reads for patch p, with the defaults pipeline.c gives the kernels: +z corner and
 * midpoint normals and the identity transform when the scene has none, the flatness bound
 * at m = 0 (patch_flatness), the patch's top-level box (scene_patch_box), every texture tile
 * resident. Points into the scene: valid while it is. */
typedef struct dice_build_ref_patch {
    const ts_vec4 *cp0, *cp1; /* control points of time 0 and 1 (cp1 == cp0 when static) */
    const ts_vec4 *cn, *mn;   /* 4 corner and 5 midpoint displacement normals */
    const ts_patch_attr *a;
    const ts_xform *x;
    ts_vec4 e; /* flatness at m = 0 */
    ts_tex_ctx tex;
    ts_box pb; /* the patch box every leaf box is clamped to */
} dice_build_ref_patch;

dice_build_ref_patch dice_build_ref_patch_of(const ts_scene *s, uint32_t p);

/* Dices patch p at LOD m into grid (times x (2^m+1)^2 vertices, time 0 first), as dice does. */
void dice_build_ref_grid(const ts_scene *s, uint32_t p, uint32_t m, ts_vec4 *grid);

/* Leaf k (Morton order) of the tree of time `time` of a patch at m: the box build_leaves
 * writes (it reads the control points, not the diced grid). With d NULL the displacement interval
 * is build's own (interval arithmetic on the noise over the time-0 undisplaced box, lib/displace.h;
 * the texture's min-max pyramid); a non-NULL d replaces it, so tools/bench_bounds.c can finish a
 * leaf box from another bound the same way. domain, when not NULL, receives the time-0 undisplaced
 * box grown by the flatness bound (the box the noise interval is taken over). */
ts_box dice_build_ref_leaf(const dice_build_ref_patch *q, uint32_t time, uint32_t m, uint32_t k,
                           const ts_interval *d, ts_box *domain);

/* Dices patch p at LOD m into grid (times x (2^m+1)^2 vertices, time 0 first) and builds its
 * trees into groups and their tight codes into codes (times x quadtree_group_count(m) sibling
 * groups each), laid out as a segment of the arenas is. tight: triangle mode's leaves
 * (lib/quadtree.h tight_leaf_box), as build makes them with ts_trace_mode.tight. */
void dice_build_ref(const ts_scene *s, uint32_t p, uint32_t m, int tight, ts_vec4 *grid,
                    ts_box4 *groups, ts_tight4 *codes);
/* dice_build_ref_grid and dice_build_ref with triangle mode's stitching: edges as
 * ts_segment.flags >> TS_SEG_EDGE_SHIFT (lib/quadtree.h quadtree_stitch); 0 is the two above. */
void dice_build_ref_grid_stitched(const ts_scene *s, uint32_t p, uint32_t m, uint32_t edges,
                                  ts_vec4 *grid);
void dice_build_ref_stitched(const ts_scene *s, uint32_t p, uint32_t m, int tight, uint32_t edges,
                             ts_vec4 *grid, ts_box4 *groups, ts_tight4 *codes);

#endif
