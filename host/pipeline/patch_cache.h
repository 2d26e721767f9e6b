/* patch_cache.h — which diced and built patches the device arenas hold (DESIGN.md §1, issue
 * 13: "dice once when it fits, reorder when it doesn't").
 *
 * The arenas (the grid buffer of ts_vec4 vertices, and the group buffer of ts_box4 tree
 * nodes with its twin `tight` of ts_tight4 codes at the same indices, pipeline.h) are divided
 * into blocks, one pair per resident patch: its (2^m+1)^2 vertices and its
 * quadtree_group_count(m) sibling groups, twice for a moving patch. A patch
 * stays resident across iterations, waves and sample passes until its space is needed, so
 * when the frame's working set fits every patch is diced once per frame; when it does not,
 * the wavefront reordering bounds the memory (Hanika §3) and the cache only removes repeats.
 *
 * Allocation by size class: a patch's blocks depend only on (m, time samples), so every
 * class (TS_CACHE_CLASSES of them) has slots of one size, a free list of slots and a list of
 * its unpinned resident patches in the order they were last used. A slot comes from the
 * class's free list, else from the unused top of the arenas, else from its least recently
 * used unpinned patch, which is evicted: exactly one patch's worth, never a scan. So that a
 * class finds slots of its own, patch_cache_plan gives each class a quota from the frame's
 * patches at their levels of detail: all of them when they fit, the same fraction of each
 * class when they do not (Hanika §4: the memory is fixed, the geometry is not). The unused
 * top beyond the quotas is anyone's. Every operation is O(1) but patch_cache_clear and
 * patch_cache_end_batch, which visit the resident and the batch's patches once.
 *
 * A patch the current batch uses is pinned (the sort lists every patch an iteration needs
 * before anything is diced): it leaves its class's list until the batch ends.
 *
 * Entries are indexed by the patch diced: a segment's shape (ts_segment.shape), so every
 * instance that shares its master's dicing finds the master's entry (trace.c).
 *
 * The cache is host bookkeeping only: it never touches OpenCL. The dicing result of a patch
 * does not depend on where it is placed, so the image does not depend on the cache. */
#ifndef TS_PATCH_CACHE_H
#define TS_PATCH_CACHE_H

#include "base/error.h"
#include "lib/shared_types.h"

#include <stdint.h>

/* Bytes of one sibling group across the two group arenas: its boxes and their tight codes. */
#define TS_GROUP_BYTES (sizeof(ts_box4) + sizeof(ts_tight4))

/* Size classes: (m, time samples), m in [0, TS_LOD_LIMIT], 1 or 2 samples. */
#define TS_CACHE_CLASSES (2 * (TS_LOD_LIMIT + 1))
#define TS_CACHE_CLASS(m, times) (2u * (m) + (times)-1u)
#define TS_CACHE_NONE UINT32_MAX

/* One arena: entries [0, top) are handed out as slots, [top, capacity) are unused. */
typedef struct ts_cache_arena {
    uint32_t capacity; /* entries (vertices or sibling groups) */
    uint32_t top;      /* the unused part's first entry */
    uint32_t used;     /* entries resident patches hold */
} ts_cache_arena;

/* One size class: its slots' size, how many it holds and may take, its free slots and its
 * unpinned residents from least to most recently used (an intrusive list through the
 * entries). */
typedef struct ts_cache_class {
    uint32_t nv, ng;                  /* a slot's vertices and sibling groups */
    uint32_t quota;                   /* slots patch_cache_plan gives it */
    uint32_t slots;                   /* slots it holds, resident or free */
    uint32_t lru_head, lru_tail;      /* patches, TS_CACHE_NONE when empty */
    uint32_t *free_vert, *free_group; /* its free slots' places */
    uint32_t free_count, free_capacity;
} ts_cache_class;

/* A resident patch. */
typedef struct ts_cache_entry {
    uint32_t vert_first, vert_count;
    uint32_t group_first, group_count;
    uint32_t prev, next; /* its class's list while resident and unpinned */
    uint32_t at;         /* its index in resident_list */
    uint8_t lod;         /* m it was diced at */
    uint8_t times;       /* 1, or 2 for a moving patch */
    uint8_t resident;
    uint8_t pinned;
    uint8_t gridded; /* its vertices were diced too, not only its trees (trace.c; 0 until then) */
} ts_cache_entry;

typedef struct ts_patch_cache {
    ts_cache_arena verts, groups;
    ts_cache_class cls[TS_CACHE_CLASSES];
    uint64_t owed_verts, owed_groups; /* entries the quotas still claim of the unused top */
    int short_of_room; /* the last plan's patches did not all fit: quotas are shares */
    /* Fixed places (patch_cache_create_placed): patch p's blocks at fixed_vert[p] and
     * fixed_group[p] when diced at fixed_lod[p]; not owned. NULL: slots by size class. */
    const uint32_t *fixed_vert, *fixed_group;
    const uint8_t *fixed_lod;
    ts_cache_entry *entry; /* one per patch */
    uint32_t patch_count;
    uint32_t *resident_list; /* patches holding space (patch_cache_clear) */
    uint32_t resident_count;
    uint32_t *pinned_list; /* patches pinned since the batch began (some released since) */
    uint32_t pinned_count, pinned_now;
    /* Counters for --stats (summed over the frame). */
    uint64_t hits, misses, evictions;
    uint64_t examined;   /* entries looked at by acquire: one a hit or miss, one a victim */
    uint64_t peak_bytes; /* the most bytes of both arenas resident patches held at once */
} ts_patch_cache;

/* An empty cache for patch_count patches over arenas of vert_capacity vertices and
 * group_capacity sibling groups. */
int patch_cache_create(ts_patch_cache *c, uint32_t patch_count, uint32_t vert_capacity,
                       uint32_t group_capacity, ts_error *err);
/* A cache whose every patch has a place of its own, given in advance: patch p (a shape,
 * diced at fixed_lod[p] with its own `times`) at vertex fixed_vert[p] and group
 * fixed_group[p] of arenas that hold the frame's patches once each (pipeline_place_arenas:
 * several devices of one process in one host allocation). Nothing is ever evicted, and a
 * patch lies at the same place on every device that uses the same arrays. The arrays are the
 * caller's and must outlive the cache; acquiring a patch at another m than its fixed_lod is
 * TS_CACHE_FULL (the frame's levels of detail are fixed). */
int patch_cache_create_placed(ts_patch_cache *c, uint32_t patch_count, const uint32_t *fixed_vert,
                              const uint32_t *fixed_group, const uint8_t *fixed_lod, ts_error *err);
void patch_cache_free(ts_patch_cache *c);
/* Forgets every resident patch (the levels of detail changed): all space is free again. */
void patch_cache_clear(ts_patch_cache *c);

/* Quotas for the frame: need[k] patches of class k (TS_CACHE_CLASS(m, times)) at the
 * frame's levels of detail. When they all fit, each class may hold all of its patches (each
 * is diced once); otherwise each class gets the same fraction of its patches (at least one
 * slot). When the quotas change, the cache is cleared first (between batches: nothing may be
 * pinned). Returns 1 when it cleared. A placed cache ignores it. */
int patch_cache_plan(ts_patch_cache *c, const uint64_t need[TS_CACHE_CLASSES]);

/* The outcome of patch_cache_acquire. */
typedef enum ts_cache_result {
    TS_CACHE_HIT,  /* resident at this m: no dicing needed */
    TS_CACHE_MISS, /* space reserved at *vert_first / *group_first: dice it there */
    TS_CACHE_FULL, /* no space even after evicting every unpinned patch: end the batch */
} ts_cache_result;

/* Makes patch p (diced at m, `times` time samples) usable by the current batch and pins it.
 * Sets its places in the arenas on a hit or a miss. A patch resident at another m is
 * released first. On TS_CACHE_FULL nothing changes but evictions made while trying. */
ts_cache_result patch_cache_acquire(ts_patch_cache *c, uint32_t p, uint32_t m, uint32_t times,
                                    uint32_t *vert_first, uint32_t *group_first);
/* Unpins every patch: the batch's launches are enqueued and the next batch may evict. */
void patch_cache_end_batch(ts_patch_cache *c);

/* Vertices and sibling groups one patch at m with `times` samples needs. */
uint32_t patch_cache_vert_count(uint32_t m, uint32_t times);
uint32_t patch_cache_group_count(uint32_t m, uint32_t times);

#endif
