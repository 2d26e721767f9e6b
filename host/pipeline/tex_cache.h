/* tex_cache.h — which texture tiles live on the device (docs/rendering.md, Image textures;
 * Pharr et al. 1997: a fixed pool of tiles, loaded on demand, least recently used out).
 *
 * The scene keeps every tile of every texture level on the host (scene.h tex_pool). The
 * device holds a pool of `slots` tiles and the page table (one entry per tile of the
 * scene: its slot or TS_INVALID). When the pool holds every tile (`paged` = 0) they are
 * uploaded once with the identity table. Otherwise each request (one dice/build batch, one
 * chunk of shade's paths) marks the tiles it will read, and tex_cache_commit makes them
 * resident: tiles already there stay, missing ones go to free slots or evict the least
 * recently used tiles this request does not need, and the page table is rewritten. */
#ifndef TS_TEX_CACHE_H
#define TS_TEX_CACHE_H

#include "device/device.h"
#include "scene/scene.h"
#include "base/stats.h"

#include <stdint.h>

/* Slots beyond the most demanding patch's tiles: a hit's parameter square can reach a tile
 * or two past the patch's own st box through rounding; requests keep this much free. */
#define TS_TEX_CACHE_SLACK 16u

typedef struct ts_tex_cache {
    uint32_t pages;        /* tiles in the scene: entries of the page table */
    uint32_t slots;        /* tiles the device pool holds */
    int paged;             /* slots < pages: tiles move in and out */
    uint32_t *page_slot;   /* host copy of the page table */
    uint32_t *slot_page;   /* the page each slot holds, TS_INVALID when free */
    uint64_t *slot_stamp;  /* request that last used the slot (LRU) */
    uint64_t *page_mark;   /* request that last marked the page */
    uint64_t request;      /* current request number (starts at 1) */
    uint32_t marked;       /* pages marked by the current request */
    uint32_t *patch_tiles; /* per patch: an upper bound of the pages one request for it marks */
    uint32_t max_patch_tiles;
} ts_tex_cache;

/* Sizes the pool: every tile if they fit in pool_bytes (or pool_bytes is 0), else
 * pool_bytes worth of tiles but at least what the most demanding patch needs plus
 * TS_TEX_CACHE_SLACK. Counts each patch's tiles (tex_cache_mark_patch). */
int tex_cache_create(ts_tex_cache *c, const ts_scene *s, uint64_t pool_bytes, ts_error *err);
void tex_cache_free(ts_tex_cache *c);
/* Starts a request: nothing marked. */
void tex_cache_begin(ts_tex_cache *c);
/* Marks the tiles that dice and build read for patch p (its displacement texture, every
 * level, over the patch's st rectangle) and that shade reads anywhere on it (colour,
 * level 0). */
void tex_cache_mark_patch(ts_tex_cache *c, const ts_scene *s, uint32_t p);
/* Marks the tiles shade reads at a hit on patch p within parameter square
 * [u0, u1] x [v0, v1] (level 0 of its displacement and colour textures); with count_only,
 * marks nothing and returns an upper bound of how many it would mark. */
uint32_t tex_cache_mark_hit(ts_tex_cache *c, const ts_scene *s, uint32_t p, float u0, float v0,
                            float u1, float v1, int count_only);
/* Makes every marked tile resident and uploads what moved (tiles, then the page table)
 * with blocking writes on the in-order queue, so kernels launched before still read the
 * old contents. Counts uploads in stats. Fails (TS_E_INTERNAL) if more tiles are marked
 * than the pool holds: callers keep requests within `slots`. */
int tex_cache_commit(ts_tex_cache *c, ts_device *cl, cl_mem pool, cl_mem page_table,
                     const ts_scene *s, ts_stats *stats, ts_error *err);
/* Uploads the pool and page table the first time (every tile when not paged, else an
 * empty table). */
int tex_cache_upload_initial(ts_tex_cache *c, ts_device *cl, cl_mem pool, cl_mem page_table,
                             const ts_scene *s, ts_stats *stats, ts_error *err);

#endif
