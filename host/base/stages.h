/* stages.h — the pipeline's stage names, one list for the enum, the --stats keys, the
 * timing slots and docs/ (tests/test_stages.c checks that docs/stages.md names the same
 * stages in the same order). Order = data flow (DESIGN.md §1). */
#ifndef TS_STAGES_H
#define TS_STAGES_H

/* clang-format off */
#define TS_STAGES(X)                                                                        \
    X(camera, "generate the wave's rays")                                                   \
    X(lod, "count the frame's eye rays per patch box, choose m per patch")                   \
    X(bake, "bake points and their rays; SH projection of the rays' visibility")             \
    X(top_level, "traverse the top-level QBVH, append (leaf, ray) candidates")              \
    X(sort, "radix sort the candidates by leaf, cut per-patch segments")                    \
    X(dice, "evaluate the (2^m+1)^2 displaced vertices of each patch segment")             \
    X(build, "implicit quad-tree boxes, bottom-up min-max")                                 \
    X(bottom_level, "trace each (ray, patch) pair through the patch's quad-tree")           \
    X(resolve, "closest hit per ray, retire finished rays")                                 \
    X(shade, "shade hits, write colour and AOVs per ray")                                   \
    X(film, "accumulate samples into the image, write it")
/* clang-format on */

typedef enum ts_stage {
#define TS_STAGE_ENUM(name, what) TS_STAGE_##name,
    TS_STAGES(TS_STAGE_ENUM)
#undef TS_STAGE_ENUM
        TS_STAGE_COUNT
} ts_stage;

extern const char *const ts_stage_names[TS_STAGE_COUNT];
extern const char *const ts_stage_descriptions[TS_STAGE_COUNT];

#endif
