/* patch_cache.c — the resident set of diced patches (patch_cache.h): slots by size class,
 * least recently used first within a class, every operation O(1). */
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

/* ---- a class's list of unpinned residents, least recently used at the head ------------ */

static void lru_remove(ts_patch_cache *c, uint32_t p)
{
    ts_cache_entry *e = &c->entry[p];
    ts_cache_class *k = &c->cls[TS_CACHE_CLASS(e->lod, e->times)];
    if (e->prev != TS_CACHE_NONE)
        c->entry[e->prev].next = e->next;
    else
        k->lru_head = e->next;
    if (e->next != TS_CACHE_NONE)
        c->entry[e->next].prev = e->prev;
    else
        k->lru_tail = e->prev;
    e->prev = e->next = TS_CACHE_NONE;
}

static void lru_push(ts_patch_cache *c, uint32_t p)
{
    ts_cache_entry *e = &c->entry[p];
    ts_cache_class *k = &c->cls[TS_CACHE_CLASS(e->lod, e->times)];
    e->prev = k->lru_tail, e->next = TS_CACHE_NONE;
    if (k->lru_tail != TS_CACHE_NONE)
        c->entry[k->lru_tail].next = p;
    else
        k->lru_head = p;
    k->lru_tail = p;
}

/* ---- the cache ------------------------------------------------------------------------ */

/* The classes' sizes and empty lists; quotas kept. */
static void classes_reset(ts_patch_cache *c)
{
    c->owed_verts = c->owed_groups = 0;
    for (uint32_t m = 0; m <= TS_LOD_LIMIT; ++m)
        for (uint32_t t = 1; t <= 2; ++t) {
            ts_cache_class *k = &c->cls[TS_CACHE_CLASS(m, t)];
            k->nv = patch_cache_vert_count(m, t), k->ng = patch_cache_group_count(m, t);
            k->slots = k->free_count = 0;
            k->lru_head = k->lru_tail = TS_CACHE_NONE;
            c->owed_verts += (uint64_t)k->quota * k->nv;
            c->owed_groups += (uint64_t)k->quota * k->ng;
        }
    c->verts.top = c->verts.used = 0;
    c->groups.top = c->groups.used = 0;
}

int patch_cache_create(ts_patch_cache *c, uint32_t patch_count, uint32_t vert_capacity,
                       uint32_t group_capacity, ts_error *err)
{
    memset(c, 0, sizeof *c);
    size_t n = patch_count ? patch_count : 1;
    c->patch_count = patch_count;
    c->entry = calloc(n, sizeof *c->entry);
    c->resident_list = malloc(n * sizeof *c->resident_list);
    c->pinned_list = malloc(2 * n * sizeof *c->pinned_list); /* a patch placed again at another
                                                              * m within a batch: twice */
    if (!c->entry || !c->resident_list || !c->pinned_list) {
        patch_cache_free(c);
        return ts_error_set(err, TS_E_MEMORY, "out of memory (patch cache of %u patches)",
                            patch_count);
    }
    c->verts.capacity = vert_capacity, c->groups.capacity = group_capacity;
    classes_reset(c);
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
    free(c->entry), free(c->resident_list), free(c->pinned_list);
    for (uint32_t k = 0; k < TS_CACHE_CLASSES; ++k)
        free(c->cls[k].free_vert), free(c->cls[k].free_group);
    memset(c, 0, sizeof *c);
}

void patch_cache_clear(ts_patch_cache *c)
{
    for (uint32_t k = 0; k < c->resident_count; ++k)
        memset(&c->entry[c->resident_list[k]], 0, sizeof *c->entry);
    c->resident_count = c->pinned_count = c->pinned_now = 0;
    classes_reset(c);
}

/* The quotas need[] gives (patch_cache_plan): all of each class when the frame fits, else
 * the fraction f of each that fits, at least one slot a class that has patches. */
static int plan_quotas(const ts_patch_cache *c, const uint64_t need[TS_CACHE_CLASSES],
                       uint32_t quota[TS_CACHE_CLASSES])
{
    double nv = 0, ng = 0;
    for (uint32_t k = 0; k < TS_CACHE_CLASSES; ++k)
        nv += (double)need[k] * c->cls[k].nv, ng += (double)need[k] * c->cls[k].ng;
    double f = 1.0;
    if (nv > c->verts.capacity) f = (double)c->verts.capacity / nv;
    if (ng > c->groups.capacity && (double)c->groups.capacity / ng < f)
        f = (double)c->groups.capacity / ng;
    for (uint32_t k = 0; k < TS_CACHE_CLASSES; ++k) {
        double q = f < 1.0 ? (double)need[k] * f : (double)need[k];
        quota[k] = need[k] == 0 ? 0u : q < 1.0 ? 1u : q > UINT32_MAX ? UINT32_MAX : (uint32_t)q;
    }
    return f < 1.0;
}

int patch_cache_plan(ts_patch_cache *c, const uint64_t need[TS_CACHE_CLASSES])
{
    if (c->fixed_vert) return 0;
    uint32_t quota[TS_CACHE_CLASSES];
    c->short_of_room = plan_quotas(c, need, quota);
    int same = 1;
    for (uint32_t k = 0; k < TS_CACHE_CLASSES; ++k)
        same &= quota[k] == c->cls[k].quota;
    if (same) return 0;
    for (uint32_t k = 0; k < TS_CACHE_CLASSES; ++k)
        c->cls[k].quota = quota[k];
    patch_cache_clear(c); /* the slots were laid out for the old quotas */
    return 1;
}

/* Patch p's slot back to its class's free list (the list only grows when a slot is first
 * freed; should that fail the slot is lost to this frame: still correct, the cache holds
 * less). */
static void cache_release(ts_patch_cache *c, uint32_t p)
{
    ts_cache_entry *e = &c->entry[p];
    ts_cache_class *k = &c->cls[TS_CACHE_CLASS(e->lod, e->times)];
    if (e->pinned)
        --c->pinned_now;
    else
        lru_remove(c, p);
    if (k->free_count == k->free_capacity) {
        uint32_t cap = k->free_capacity ? 2 * k->free_capacity : 16;
        uint32_t *v = realloc(k->free_vert, cap * sizeof *v);
        if (v) k->free_vert = v;
        uint32_t *g = v ? realloc(k->free_group, cap * sizeof *g) : NULL;
        if (g) k->free_group = g, k->free_capacity = cap;
    }
    if (k->free_count < k->free_capacity) {
        k->free_vert[k->free_count] = e->vert_first;
        k->free_group[k->free_count++] = e->group_first;
    } else {
        --k->slots;
    }
    c->verts.used -= e->vert_count, c->groups.used -= e->group_count;
    uint32_t last = c->resident_list[--c->resident_count];
    c->resident_list[e->at] = last, c->entry[last].at = e->at;
    memset(e, 0, sizeof *e);
}

/* A new slot of class k from the arenas' unused top: within its quota, or from what the
 * quotas leave; `any` ignores the quotas. 0 when there is no room. */
static int slot_from_top(ts_patch_cache *c, ts_cache_class *k, int any, uint32_t *vf, uint32_t *gf)
{
    uint64_t vleft = c->verts.capacity - c->verts.top, gleft = c->groups.capacity - c->groups.top;
    if (k->nv > vleft || k->ng > gleft) return 0;
    int own = k->slots < k->quota;
    uint64_t ov = c->owed_verts - (own ? k->nv : 0), og = c->owed_groups - (own ? k->ng : 0);
    if (!own && !any && (vleft - k->nv < ov || gleft - k->ng < og)) return 0;
    c->owed_verts = ov, c->owed_groups = og;
    *vf = c->verts.top, *gf = c->groups.top;
    c->verts.top += k->nv, c->groups.top += k->ng;
    ++k->slots;
    return 1;
}

/* A slot for a patch of class k: a free one, one from the top, its least recently used
 * unpinned patch's; or, when k has none and nothing is pinned, all of them (a class the
 * plan gave no quota: the cache starts again). 0 when the batch is full. */
static int slot_take(ts_patch_cache *c, ts_cache_class *k, uint32_t *vf, uint32_t *gf)
{
    for (;;) {
        if (k->free_count > 0) {
            --k->free_count;
            *vf = k->free_vert[k->free_count], *gf = k->free_group[k->free_count];
            return 1;
        }
        if (slot_from_top(c, k, k->slots == 0, vf, gf)) return 1;
        if (k->lru_head != TS_CACHE_NONE) { /* one patch's worth: its slot is k's */
            ++c->examined, ++c->evictions;
            cache_release(c, k->lru_head);
            continue;
        }
        if (c->pinned_now > 0 || c->resident_count == 0) return 0;
        c->evictions += c->resident_count;
        c->examined += c->resident_count;
        patch_cache_clear(c);
        return slot_from_top(c, k, 1, vf, gf);
    }
}

/* Patch p resident and pinned at [vf, vf + nv) and [gf, gf + ng): a miss. */
static ts_cache_result cache_place(ts_patch_cache *c, uint32_t p, uint32_t vf, uint32_t nv,
                                   uint32_t gf, uint32_t ng, uint32_t m, uint32_t times,
                                   uint32_t *vert_first, uint32_t *group_first)
{
    c->entry[p] = (ts_cache_entry){
        vf, nv, gf, ng, TS_CACHE_NONE, TS_CACHE_NONE, c->resident_count, (uint8_t)m, (uint8_t)times,
        1,  1,  0};
    c->verts.used += nv, c->groups.used += ng;
    uint64_t bytes =
        (uint64_t)c->verts.used * sizeof(ts_vec4) + (uint64_t)c->groups.used * TS_GROUP_BYTES;
    if (bytes > c->peak_bytes) c->peak_bytes = bytes;
    c->resident_list[c->resident_count++] = p;
    if (c->pinned_count < 2 * c->patch_count) c->pinned_list[c->pinned_count++] = p;
    ++c->pinned_now;
    *vert_first = vf, *group_first = gf;
    ++c->misses;
    return TS_CACHE_MISS;
}

ts_cache_result patch_cache_acquire(ts_patch_cache *c, uint32_t p, uint32_t m, uint32_t times,
                                    uint32_t *vert_first, uint32_t *group_first)
{
    ts_cache_entry *e = &c->entry[p];
    ++c->examined;
    if (e->resident && e->lod == m && e->times == times) {
        if (!e->pinned) {
            lru_remove(c, p);
            e->pinned = 1, ++c->pinned_now;
            if (c->pinned_count < 2 * c->patch_count) c->pinned_list[c->pinned_count++] = p;
        }
        *vert_first = e->vert_first, *group_first = e->group_first;
        ++c->hits;
        return TS_CACHE_HIT;
    }
    uint32_t nv = patch_cache_vert_count(m, times), ng = patch_cache_group_count(m, times);
    if (c->fixed_vert) { /* its own place, always free */
        if (e->resident || c->fixed_lod[p] != m || c->fixed_vert[p] == UINT32_MAX)
            return TS_CACHE_FULL; /* another m than the frame's: not met */
        return cache_place(c, p, c->fixed_vert[p], nv, c->fixed_group[p], ng, m, times, vert_first,
                           group_first);
    }
    if (e->resident) cache_release(c, p); /* another m: its slot is of no use to it */
    if (nv > c->verts.capacity || ng > c->groups.capacity) return TS_CACHE_FULL;
    uint32_t vf, gf;
    if (!slot_take(c, &c->cls[TS_CACHE_CLASS(m, times)], &vf, &gf)) return TS_CACHE_FULL;
    return cache_place(c, p, vf, nv, gf, ng, m, times, vert_first, group_first);
}

void patch_cache_end_batch(ts_patch_cache *c)
{
    for (uint32_t i = 0; i < c->pinned_count; ++i) {
        uint32_t p = c->pinned_list[i];
        ts_cache_entry *e = &c->entry[p];
        if (!e->resident || !e->pinned) continue; /* released, or listed twice */
        e->pinned = 0;
        if (!c->fixed_vert) lru_push(c, p);
    }
    c->pinned_count = c->pinned_now = 0;
}
