/* bake_file.h — the EXR `tessera bake` writes
 * (docs/bake.md "The file"): one tile per patch holding the SH coefficients of its
 * (2^m+1)^2 points, point (i, j) of patch p at pixel (tile_x[p] + i, tile_y[p] + j).
 *
 * Channels, in this order: sh0 .. sh(B^2 - 1) (coefficient l^2 + l + m, lib/sh.h), then
 * `patch` (the patch index), `u`, `v` (the point's parameters i / 2^m, j / 2^m), `P.x P.y
 * P.z` (the point, displaced), `N.x N.y N.z` (the normal its hemisphere is about). Every
 * channel of a pixel that belongs to no point is NaN, and so are sh and P, N of a point not
 * baked yet (an interrupted bake); patch, u, v are set for every point from the start.
 *
 * Tiles are packed in shelves: patches by decreasing m (then by index), left to right in
 * rows of `width` pixels, a new shelf when the next tile does not fit, each shelf as high as
 * its first tile; width is the smallest power of two holding the largest tile and at least
 * the square root of the tiles' total area. Readers need not know this rule: the patch, u
 * and v channels say what each pixel is. */
#ifndef TS_BAKE_FILE_H
#define TS_BAKE_FILE_H

#include "base/error.h"
#include "lib/shared_types.h"
#include "scene/scene.h"

#include <stddef.h>
#include <stdint.h>

/* Channels after the coefficients. */
enum {
    TS_BAKE_CH_PATCH,
    TS_BAKE_CH_U,
    TS_BAKE_CH_V,
    TS_BAKE_CH_PX,
    TS_BAKE_CH_PY,
    TS_BAKE_CH_PZ,
    TS_BAKE_CH_NX,
    TS_BAKE_CH_NY,
    TS_BAKE_CH_NZ,
    TS_BAKE_CH_FIXED /* 9 */
};

/* Where every patch's points are: in the global point list and in the image. */
typedef struct ts_bake_layout {
    uint32_t patch_count;
    uint32_t *lod;             /* m per patch */
    uint32_t *point_first;     /* patch_count + 1 prefix sums of (2^m+1)^2 */
    uint32_t *tile_x, *tile_y; /* per patch: the tile's top-left pixel */
    uint32_t width, height;    /* of the image */
} ts_bake_layout;

/* The metadata of a bake file (EXR int attributes "tessera:..."; docs/bake.md). */
typedef struct ts_bake_meta {
    int32_t bands, rays, flags; /* B, N, TS_BAKE_* (stored as bake_cosine, _sphere, _front) */
    int32_t seed, max_lod;
    int32_t job;      /* the scene's geometry, camera and the options that change the result */
    int32_t lod;      /* the m of every patch */
    int32_t geometry; /* bake_geometry_hash: which geometry the bake belongs to */
    uint32_t points, done, patches;
} ts_bake_meta;

/* The image being baked: the layout and width x height x channels floats. */
typedef struct ts_bake_image {
    ts_bake_layout layout;
    uint32_t bands, coeffs, channels; /* B, B^2, B^2 + TS_BAKE_CH_FIXED */
    float *pixels;
} ts_bake_image;

/* The layout of patches with levels of detail lod[0..n): TS_E_USAGE when the points number
 * 2^32 or more, or the image would exceed 65536 pixels a side (lower --lod or --max-lod). */
int bake_layout_make(const uint32_t *lod, uint32_t n, ts_bake_layout *layout, ts_error *err);
void bake_layout_free(ts_bake_layout *layout);
/* The pixel index (y * width + x) of vertex k of patch p. */
size_t bake_layout_pixel(const ts_bake_layout *layout, uint32_t p, uint32_t k);

/* A NaN image for the layout of lod[0..n) with its patch, u, v channels filled. */
int bake_image_create(ts_bake_image *img, const uint32_t *lod, uint32_t n, uint32_t bands,
                      ts_error *err);
void bake_image_free(ts_bake_image *img);
/* Stores the results of points [first, first + count): coefficients (B^2 each), positions
 * and normals (xyz). */
void bake_image_store(ts_bake_image *img, uint32_t first, uint32_t count, const float *coeffs,
                      const ts_vec4 *pos, const ts_vec4 *normal);
/* Writes the image atomically with its metadata. */
int bake_image_write(const ts_bake_image *img, const char *path, const ts_bake_meta *meta,
                     ts_error *err);
/* --resume: reads the bake at path into img (same layout) when it was made by the same
 * command (meta's job, lod, points, seed and bands; *done gets its points done). TS_E_USAGE
 * naming what differs, TS_E_IO when it cannot be read. */
int bake_image_resume(ts_bake_image *img, const char *path, const ts_bake_meta *meta,
                      uint32_t *done, ts_error *err);

/* Reads the bake at path for relighting scene s (`render --occlusion`; scene_path names s in
 * messages): a complete bake (tessera:bake_done = tessera:bake_points) of s's patch count and
 * geometry (bake_geometry_hash), every patch a full (2^m + 1)^2 grid of points with finite
 * coefficients and normals, found by their patch, u and v channels (not by the shelf rule). TS_E_IO
 * when the file cannot be read, TS_E_USAGE naming the file and what does not fit; *out is freed and
 * zeroed on failure. Free with occlusion_free. */
int bake_occlusion_load(const char *path, const ts_scene *s, const char *scene_path,
                        ts_occlusion *out, ts_error *err);

/* A hash of what the bake's visibility depends on in the scene: the patches, their
 * displacement (functions, parameters, transforms, textures) and normals; not materials or
 * lights. */
int32_t bake_geometry_hash(const ts_scene *s);

#endif
