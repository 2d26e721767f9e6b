/* forest.h — a procedural forest of L-system trees made of bicubic Bézier patches, on a
 * displaced terrain, generated in memory when the scene loads (Hanika §4, Figs. 1 and 7).
 *
 * Each tree is the derivation of a stochastic parametric L-system (apices that grow a
 * segment, sprout lateral apices and continue), read by a 3D turtle: every segment is a
 * generalised cylinder, a ring of 4-8 patches around a cubic Bézier spine with a tapering
 * radius, sharing its end ring exactly with the next segment of the same branch; the
 * branch tips carry leaves (small curved patches, green). Bark is displaced with ridged
 * noise, the terrain (a grid of bicubic patches over rolling hills) with fBm. Everything is
 * a pure function of (trees, seed, detail): a counter-based hash drives every random
 * choice, and the shape of tree i depends only on (seed, detail, i), so the patch count
 * grows linearly with the number of trees. See docs/rib.md ("Procedural forest").
 */
#ifndef TS_FOREST_H
#define TS_FOREST_H

#include "base/error.h"
#include "scene/scene.h"

#include <stddef.h>
#include <stdint.h>

#define FOREST_MAX_TREES 100000
#define FOREST_MAX_DETAIL 3

typedef struct forest_params {
    int trees;     /* 1..FOREST_MAX_TREES (default 100) */
    uint32_t seed; /* any (default 1) */
    int detail;    /* 0..FOREST_MAX_DETAIL (default 1): L-system iterations = 5 + detail;
                      detail 1 gives about 1000 patches per tree */
    int threads;   /* trees generated on this many threads (0: every online processor); the
                      same scene on any number */
} forest_params;

/* What forest_generate added. */
typedef struct forest_counts {
    uint64_t bark, leaves, terrain; /* patches */
    double extent;                  /* side of the square the trees stand in, object units */
} forest_counts;

void forest_params_default(forest_params *fp);

/* Parses "trees=1000 seed=1 detail=1" (any order, any subset, separated by spaces or
 * commas) on top of fp. Returns 0, or -1 with a one-line reason in why. */
int forest_parse_params(const char *text, forest_params *fp, char *why, size_t why_size);

/* Appends the forest, moved by object_to_world (row-major, column vectors, affine and
 * invertible), to s: terrain centred on the object-space origin in the x-z plane with y
 * up, trees on a jittered grid about 7 units apart, each some 8-12 units tall. base (or
 * NULL) supplies the material fields of ts_patch_attr; colours, displacement and the
 * world-to-object transform (added to s) are the forest's own. Corner normals are given
 * explicitly (no scene_finalize averaging needed). counts may be NULL; s may be NULL to
 * count the patches without storing them (the same counts, no memory). Errors:
 * TS_E_MEMORY, TS_E_SCENE (a transform that is not affine/invertible or leaves the float
 * range). Does not call scene_finalize. */
int forest_generate(const forest_params *fp, const double object_to_world[16],
                    const ts_patch_attr *base, ts_scene *s, forest_counts *counts, ts_error *err);

#endif
