/* patch_cache.c — the resident set of diced patches (patch_cache.h). */
#include "pipeline/patch_cache.h"

#include "lib/quadtree.h"

#include <stdlib.h>
#include <string.h>

uint32_t patch_cache_vert_count(uint32_t m, uint32_t times)
{
    return times * quadtree_vertex_count(m);
}

uint32_t patch_cache_group_count(uint32_t m, uint32_t times)
{
    return times * quadtree_group_count(m);
}

/* ---- one arena: a sorted, coalesced free list, first fit ------------------------------ */

static void arena_reset(ts_cache_arena *a)
{
    a->free_count = a->capacity > 0;
    a->free[0] = (ts_cache_block){0, a->capacity};
    a->used = 0;
}

static int arena_init(ts_cache_arena *a, uint32_t capacity)
{
    memset(a, 0, sizeof *a);
    a->capacity = capacity;
    a->free_capacity = 64;
    a->free = malloc(a->free_capacity * sizeof *a->free);
    if (!a->free) return 0;
    arena_reset(a);
    return 1;
}

/* First fit; returns 0 when no free block holds count entries. */
static int arena_alloc(ts_cache_arena *a, uint32_t count, uint32_t *first)
{
    for (uint32_t i = 0; i < a->free_count; ++i) {
        ts_cache_block *b = &a->free[i];
        if (b->count < count) continue;
        *first = b->first;
        b->first += count, b->count -= count;
        if (b->count == 0) {
            memmove(b, b + 1, (a->free_count - i - 1) * sizeof *b);
            --a->free_count;
        }
        a->used += count;
        return 1;
    }
    return 0;
}

/* Returns [first, first + count) to the free list, merging it with its neighbours. At most
 * one block is added, so the list needs room for one more only when nothing merges. */
static int arena_release(ts_cache_arena *a, uint32_t first, uint32_t count)
{
    uint32_t lo = 0, hi = a->free_count; /* the first free block after `first` */
    while (lo < hi) {
        uint32_t mid = (lo + hi) / 2;
        if (a->free[mid].first < first)
            lo = mid + 1;
        else
            hi = mid;
    }
    int left = lo > 0 && a->free[lo - 1].first + a->free[lo - 1].count == first;
    int right = lo < a->free_count && first + count == a->free[lo].first;
    a->used -= count;
    if (left && right) {
        a->free[lo - 1].count += count + a->free[lo].count;
        memmove(&a->free[lo], &a->free[lo + 1], (a->free_count - lo - 1) * sizeof *a->free);
        --a->free_count;
    } else if (left) {
        a->free[lo - 1].count += count;
    } else if (right) {
        a->free[lo].first = first, a->free[lo].count += count;
    } else {
        if (a->free_count == a->free_capacity) {
            ts_cache_block *grown = realloc(a->free, 2 * a->free_capacity * sizeof *grown);
            if (!grown) return 0;
            a->free = grown, a->free_capacity *= 2;
        }
        memmove(&a->free[lo + 1], &a->free[lo], (a->free_count - lo) * sizeof *a->free);
        a->free[lo] = (ts_cache_block){first, count};
        ++a->free_count;
    }
    return 1;
}

/* ---- the cache ------------------------------------------------------------------------ */

int patch_cache_create(ts_patch_cache *c, uint32_t patch_count, uint32_t vert_capacity,
                       uint32_t group_capacity, ts_error *err)
{
    memset(c, 0, sizeof *c);
    size_t n = patch_count ? patch_count : 1;
    c->patch_count = patch_count;
    c->entry = calloc(n, sizeof *c->entry);
    c->resident_list = malloc(n * sizeof *c->resident_list);
    int ok = c->entry && c->resident_list && arena_init(&c->verts, vert_capacity) &&
             arena_init(&c->groups, group_capacity);
    if (!ok) {
        patch_cache_free(c);
        return ts_error_set(err, TS_E_MEMORY, "out of memory (patch cache of %u patches)",
                            patch_count);
    }
    return TS_OK;
}

int patch_cache_create_placed(ts_patch_cache *c, uint32_t patch_count, const uint32_t *fixed_vert,
                              const uint32_t *fixed_group, const uint8_t *fixed_lod, ts_error *err)
{
    if (patch_cache_create(c, patch_count, 0, 0, err)) return err->code;
    c->fixed_vert = fixed_vert, c->fixed_group = fixed_group, c->fixed_lod = fixed_lod;
    return TS_OK;
}

void patch_cache_free(ts_patch_cache *c)
{
    free(c->entry), free(c->resident_list), free(c->verts.free), free(c->groups.free);
    memset(c, 0, sizeof *c);
}

void patch_cache_clear(ts_patch_cache *c)
{
    for (uint32_t k = 0; k < c->resident_count; ++k)
        memset(&c->entry[c->resident_list[k]], 0, sizeof *c->entry);
    c->resident_count = 0;
    arena_reset(&c->verts);
    arena_reset(&c->groups);
}

/* Frees patch p's blocks. The free lists only grow when a released block merges with
 * nothing; should that allocation fail the blocks are lost to this frame (still correct:
 * the cache just holds less). */
static void cache_release(ts_patch_cache *c, uint32_t p)
{
    ts_cache_entry *e = &c->entry[p];
    arena_release(&c->verts, e->vert_first, e->vert_count);
    arena_release(&c->groups, e->group_first, e->group_count);
    for (uint32_t k = 0; k < c->resident_count; ++k)
        if (c->resident_list[k] == p) {
            c->resident_list[k] = c->resident_list[--c->resident_count];
            break;
        }
    memset(e, 0, sizeof *e);
}

/* Evicts the least recently used unpinned patch; 0 when every resident patch is pinned. */
static int cache_evict_one(ts_patch_cache *c)
{
    uint32_t victim = UINT32_MAX;
    uint64_t oldest = UINT64_MAX;
    for (uint32_t k = 0; k < c->resident_count; ++k) {
        const ts_cache_entry *e = &c->entry[c->resident_list[k]];
        if (!e->pinned && e->last_use < oldest) oldest = e->last_use, victim = c->resident_list[k];
    }
    if (victim == UINT32_MAX) return 0;
    cache_release(c, victim);
    ++c->evictions;
    return 1;
}

/* Patch p resident and pinned at [vf, vf + nv) and [gf, gf + ng) (the arenas' used counts
 * already hold them): a miss. */
static ts_cache_result cache_place(ts_patch_cache *c, uint32_t p, uint32_t vf, uint32_t nv,
                                   uint32_t gf, uint32_t ng, uint32_t m, uint32_t times,
                                   uint32_t *vert_first, uint32_t *group_first)
{
    c->entry[p] = (ts_cache_entry){vf, nv, gf, ng, c->clock, (uint8_t)m, (uint8_t)times, 1, 1};
    uint64_t bytes =
        (uint64_t)c->verts.used * sizeof(ts_vec4) + (uint64_t)c->groups.used * TS_GROUP_BYTES;
    if (bytes > c->peak_bytes) c->peak_bytes = bytes;
    c->resident_list[c->resident_count++] = p;
    *vert_first = vf, *group_first = gf;
    ++c->misses;
    return TS_CACHE_MISS;
}

ts_cache_result patch_cache_acquire(ts_patch_cache *c, uint32_t p, uint32_t m, uint32_t times,
                                    uint32_t *vert_first, uint32_t *group_first)
{
    ts_cache_entry *e = &c->entry[p];
    if (e->resident && e->lod == m && e->times == times) {
        e->pinned = 1, e->last_use = c->clock;
        *vert_first = e->vert_first, *group_first = e->group_first;
        ++c->hits;
        return TS_CACHE_HIT;
    }
    uint32_t nv = patch_cache_vert_count(m, times), ng = patch_cache_group_count(m, times);
    if (c->fixed_vert) { /* its own place, always free */
        if (e->resident || c->fixed_lod[p] != m || c->fixed_vert[p] == UINT32_MAX)
            return TS_CACHE_FULL; /* another m than the frame's: not met */
        c->verts.used += nv, c->groups.used += ng;
        return cache_place(c, p, c->fixed_vert[p], nv, c->fixed_group[p], ng, m, times, vert_first,
                           group_first);
    }
    if (e->resident) cache_release(c, p); /* another m: its blocks are of no use */
    if (nv > c->verts.capacity || ng > c->groups.capacity) return TS_CACHE_FULL;
    uint32_t vf, gf;
    for (;;) {
        if (arena_alloc(&c->verts, nv, &vf)) {
            if (arena_alloc(&c->groups, ng, &gf)) break;
            arena_release(&c->verts, vf, nv); /* merges back: never needs to grow */
        }
        if (!cache_evict_one(c)) return TS_CACHE_FULL;
    }
    return cache_place(c, p, vf, nv, gf, ng, m, times, vert_first, group_first);
}

void patch_cache_end_batch(ts_patch_cache *c)
{
    for (uint32_t k = 0; k < c->resident_count; ++k)
        c->entry[c->resident_list[k]].pinned = 0;
    ++c->clock;
}
