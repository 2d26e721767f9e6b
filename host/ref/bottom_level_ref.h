/* bottom_level_ref.h — the plain-C reference of stage `bottom_level` (DESIGN.md §5): the
 * algorithm of kernels/bottom_level.cl's per-ray kernel bottom_level_trace, written again in
 * scalar C — front-to-back traversal of a patch's implicit quad-tree (Hanika §3.2.1) with
 * sibling boxes tested four at a time, leaves as blocks of 2^b x 2^b micro-quads, leaf boxes
 * as geometry (§3.3) or the exact micro-triangles, linear motion (§3.4). It shares only the
 * small maths helpers of kernels/lib (intersect.h, quadtree.h) with the kernel, and returns
 * bitwise the hits the kernel writes to pair_hit (tests/test_bottom_level.c). Also the
 * host's traversal for benchmarks (tools/bench_traversal.c, tools/bench_cache.c). */
#ifndef TS_BOTTOM_LEVEL_REF_H
#define TS_BOTTOM_LEVEL_REF_H

#include "lib/shared_types.h"

#include <stdint.h>

/* One diced patch: its grid(s) ((2^m+1)^2 vertices) and tree(s) (quadtree_group_count(m)
 * sibling groups); g1 and t1 are NULL for a static patch. c0, c1: the trees' tight codes
 * (ts_tight4) when the traversal tests the tight boxes, as the kernel does for the patch a
 * ray leaves in box mode (only with exact, whose triangles lie in them), else NULL. */
typedef struct bl_ref_patch {
    const ts_vec4 *g0, *g1;
    const ts_box4 *t0, *t1;
    const ts_tight4 *c0, *c1;
    uint32_t m, patch;
    uint32_t trimmed; /* TS_SEG_TRIMMED: a micro-quad with an empty box is not there */
} bl_ref_patch;

/* The patch of a segment whose grids, trees and tight codes lie in the arenas `grid`,
 * `groups` and `codes` (codes NULL: the node boxes only). */
bl_ref_patch bottom_level_ref_patch(const ts_segment *seg, const ts_vec4 *grid,
                                    const ts_box4 *groups, const ts_tight4 *codes);

/* Traces one ray through one patch, as bottom_level_trace traces one pair: org.xyz the
 * origin, org.w = tmin; dir.xyz the direction, dir.w = time in [0, 1); only hits below tmax.
 * exact: 1 micro-triangles, 0 leaf boxes; leaf_b: leaves of 2^leaf_b micro-quads a side
 * (clamped to m); any: a shadow ray, done after the first leaf block that has a hit. Returns
 * the closest hit (with any, that block's), or {TS_NO_HIT, 0, 0, TS_INVALID, TS_INVALID}.
 * *tests (if not NULL) gets the micro-quad tests made. */
ts_hit bottom_level_ref_trace(ts_vec4 org, ts_vec4 dir, float tmax, const bl_ref_patch *pt,
                              int exact, int any, uint32_t leaf_b, uint32_t *tests);

/* The arguments of one bottom_level launch (trace.c's stage_bottom_level), host side. */
typedef struct bl_ref_batch {
    const ts_pair
        *pairs; /* sorted pairs; the batch is pairs[pair_first, pair_first + pair_count) */
    uint32_t pair_first, pair_count;
    const ts_segment *segments; /* the batch is segments[seg_first, seg_first + seg_count) */
    uint32_t seg_first, seg_count;
    uint32_t n_per_ray, exact, leaf_b;
    const uint32_t *active;
    const ts_vec4 *org, *dir;
    const ts_hit *hit; /* hit[ray].t is the pair's tmax */
    const uint32_t *ray_flags;
    const uint32_t *ray_from; /* the patch each ray leaves + 1: org.w is its tmin there only */
    const ts_vec4 *grid;
    const ts_box4 *groups;
    const ts_tight4 *codes; /* the tight codes beside groups (the patch a ray leaves) */
    /* Instances (segments whose shape is not their patch): the ray goes into the master's
     * frame by inst_xform[instance[patch]] (lib/instance.h). NULL when no segment has one. */
    const uint32_t *instance;
    const ts_xform *inst_xform;
} bl_ref_batch;

/* Pairs first .. first + count - 1 of the batch (0-based within it): pair_hit[window] gets
 * what bottom_level_trace writes there. Disjoint ranges may run on separate threads.
 * Returns the micro-quad tests made. */
uint64_t bottom_level_ref_pairs(const bl_ref_batch *b, uint32_t first, uint32_t count,
                                ts_hit *pair_hit);

#endif
