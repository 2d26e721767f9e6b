/* cache_tracer.c — bench_cache's baseline (bench_cache.h cache_trace): a tracer without
 * reordering, one ray at a time through LRU caches of diced patches (Pharr and Hanrahan 1996;
 * Hanika et al. 2010, Table 2). */
#include "bench_cache.h"
#include "ref/bottom_level_ref.h"
#include "ref/dice_build_ref.h"
#include "lib/intersect.h"
#include "lib/quadtree.h"
#include "base/stats.h"
#include "pipeline/qbvh.h"

#include <stdlib.h>
#include <string.h>

static const uint32_t cache_sizes[BENCH_CACHES] = {10, 100, 1000};

static int lru_init(lru *c, uint32_t cap, uint32_t patches)
{
    *c = (lru){.cap = cap};
    c->slot_of = malloc(patches * sizeof *c->slot_of);
    c->patch_of = malloc(cap * sizeof *c->patch_of);
    c->prev = malloc(cap * sizeof *c->prev), c->next = malloc(cap * sizeof *c->next);
    if (!c->slot_of || !c->patch_of || !c->prev || !c->next) return 1;
    memset(c->slot_of, 0xff, patches * sizeof *c->slot_of);
    return 0;
}

void lru_free(lru *c)
{
    free(c->slot_of), free(c->patch_of), free(c->prev), free(c->next);
}

static void lru_unlink(lru *c, uint32_t s)
{
    if (s == c->head)
        c->head = c->next[s];
    else
        c->next[c->prev[s]] = c->next[s];
    if (s == c->tail)
        c->tail = c->prev[s];
    else
        c->prev[c->next[s]] = c->prev[s];
}

static void lru_push_front(lru *c, uint32_t s)
{
    c->prev[s] = UINT32_MAX, c->next[s] = c->size > 1 ? c->head : UINT32_MAX;
    if (c->size > 1)
        c->prev[c->head] = s;
    else
        c->tail = s;
    c->head = s;
}

/* Patch p is needed diced at m: a hit moves it to the front; a miss dices it (counted),
 * evicting the least recently used patch when the cache is full. */
static void lru_access(lru *c, uint32_t p, uint32_t m)
{
    int32_t s = c->slot_of[p];
    if (s >= 0) {
        if ((uint32_t)s != c->head) {
            lru_unlink(c, (uint32_t)s);
            lru_push_front(c, (uint32_t)s);
        }
        return;
    }
    c->dicings++, c->micropolygons += 1ull << (2u * m);
    uint32_t slot;
    if (c->size < c->cap) {
        slot = c->size++;
    } else {
        slot = c->tail;
        c->slot_of[c->patch_of[slot]] = -1;
        lru_unlink(c, slot);
    }
    c->slot_of[p] = (int32_t)slot, c->patch_of[slot] = p;
    lru_push_front(c, slot);
}

/* The host's diced patches (a memo of real dicing work, not the simulated cache): grids,
 * trees and their tight codes (which a ray leaving a rough patch tests, as the kernel does). */
typedef struct memo {
    ts_vec4 **grid;
    ts_box4 **groups;
    ts_tight4 **codes;
    uint64_t bytes, limit, dicings;
    uint32_t count;
} memo;

static void memo_clear(memo *mm)
{
    for (uint32_t i = 0; i < mm->count; ++i) {
        free(mm->grid[i]), free(mm->groups[i]), free(mm->codes[i]);
        mm->grid[i] = NULL, mm->groups[i] = NULL, mm->codes[i] = NULL;
    }
    mm->bytes = 0;
}

/* Patch p diced at m; codes: with its tight codes (the patch a ray leaves in box mode). */
static int memo_get(memo *mm, const ts_scene *s, uint32_t p, uint32_t m, int codes,
                    bl_ref_patch *out)
{
    uint32_t times = dice_build_ref_times(s, p);
    if (!mm->grid[p]) {
        size_t gb = times * quadtree_vertex_count(m) * sizeof(ts_vec4),
               nb = times * quadtree_group_count(m) * sizeof(ts_box4),
               cb = times * quadtree_group_count(m) * sizeof(ts_tight4);
        if (mm->bytes + gb + nb + cb > mm->limit) memo_clear(mm);
        mm->grid[p] = malloc(gb), mm->groups[p] = malloc(nb), mm->codes[p] = malloc(cb);
        if (!mm->grid[p] || !mm->groups[p] || !mm->codes[p]) return 1;
        dice_build_ref(s, p, m, 0, mm->grid[p], mm->groups[p], mm->codes[p]);
        mm->bytes += gb + nb + cb;
        mm->dicings++;
    }
    uint32_t nv = quadtree_vertex_count(m), ng = quadtree_group_count(m), two = times == 2;
    *out = (bl_ref_patch){mm->grid[p],
                          two ? mm->grid[p] + nv : NULL,
                          mm->groups[p],
                          two ? mm->groups[p] + ng : NULL,
                          codes ? mm->codes[p] : NULL,
                          codes && two ? mm->codes[p] + ng : NULL,
                          m,
                          p,
                          s->attr[p].trim_count > 0};
    return 0;
}

/* A binary min-heap of (entry distance, QBVH item): item >= 0 a node, < 0 a leaf ~patch. */
typedef struct heap_item {
    float t;
    int32_t item;
} heap_item;

typedef struct heap {
    heap_item *v;
    uint32_t n, cap;
} heap;

static int heap_push(heap *h, float t, int32_t item)
{
    if (h->n == h->cap) {
        uint32_t cap = h->cap ? 2 * h->cap : 256;
        heap_item *v = realloc(h->v, cap * sizeof *v);
        if (!v) return 1;
        h->v = v, h->cap = cap;
    }
    uint32_t i = h->n++;
    while (i > 0 && h->v[(i - 1) / 2].t > t)
        h->v[i] = h->v[(i - 1) / 2], i = (i - 1) / 2;
    h->v[i] = (heap_item){t, item};
    return 0;
}

static heap_item heap_pop(heap *h)
{
    heap_item top = h->v[0], last = h->v[--h->n];
    uint32_t i = 0;
    for (;;) {
        uint32_t c = 2 * i + 1;
        if (c >= h->n) break;
        if (c + 1 < h->n && h->v[c + 1].t < h->v[c].t) ++c;
        if (!(h->v[c].t < last.t)) break;
        h->v[i] = h->v[c], i = c;
    }
    if (h->n) h->v[i] = last;
    return top;
}

/* The patches ray r passes through (top_level.cl): a shadow ray those that cast no shadow, an
 * eye ray those the camera does not see, a bounce's BSDF ray those indirect rays do not see. */
static uint32_t unseen_flags(const bench_ray *r)
{
    return (r->flags & TS_RAY_SHADOW) ? TS_PATCH_NO_SHADOW
           : r->from == 0u            ? TS_PATCH_NO_CAMERA
                                      : TS_PATCH_NO_INDIRECT;
}

/* Ray r through patch p, as bottom_level_ref_pairs traces a pair (box mode, leaves of one
 * micro-quad): the patch it leaves is micro-triangles with org.w its tmin (tested in its
 * tight boxes when rough), a shadow ray is not stopped by the light it aims at and ends at
 * its first hit. */
static int trace_patch(const ts_scene *s, const bench_ray *r, uint32_t p, uint32_t m, memo *mm,
                       float tmax, ts_hit *out)
{
    int leaving = r->from == p + 1u, shadow = (r->flags & TS_RAY_SHADOW) != 0u;
    *out = (ts_hit){TS_NO_HIT, 0, 0, TS_INVALID, TS_INVALID};
    if (shadow && (r->flags >> 1) == p + 1u) return 0;
    bl_ref_patch pt;
    if (memo_get(mm, s, p, m, leaving && (s->attr[p].flags & TS_PATCH_ROUGH), &pt)) return 1;
    ts_vec4 o = r->org;
    if (!leaving) o.w = 0.0f;
    *out = bottom_level_ref_trace(o, r->dir, tmax, &pt, leaving, shadow, 0u, NULL);
    return 0;
}

/* One ray, one at a time: patches in order of entry distance until the nearest entry left
 * is beyond the closest hit (a shadow ray: until its first hit); each is looked up in every
 * cache and intersected. */
static int trace_one(const ts_scene *s, const ts_qbvh *q, const uint8_t *lod, const bench_ray *r,
                     memo *mm, heap *h, bench_result *res, ts_hit *out)
{
    ts_vec4 o = r->org, d = r->dir;
    float ix = safe_reciprocal(d.x), iy = safe_reciprocal(d.y), iz = safe_reciprocal(d.z);
    ts_hit best = {r->tmax, 0, 0, TS_INVALID, TS_INVALID};
    uint32_t unseen = unseen_flags(r);
    int shadow = (r->flags & TS_RAY_SHADOW) != 0u;
    h->n = 0;
    if (heap_push(h, 0.0f, 0)) return 1;
    while (h->n && !(h->v[0].t > best.t) && !(shadow && best.patch != TS_INVALID)) {
        heap_item it = heap_pop(h);
        if (it.item < 0) {
            uint32_t p = (uint32_t)~it.item, m = lod[p];
            if (s->attr[p].flags & unseen) continue;
            res->lookups++;
            if (!res->seen[p]) res->seen[p] = 1, res->reached++;
            if (res->by_pass && res->pass_seen[p] != res->pass_now) {
                res->pass_seen[p] = res->pass_now, res->pass_reached++;
                res->pass_reached_mp += 1ull << (2u * m);
            }
            for (int c = 0; c < BENCH_CACHES; ++c)
                lru_access(&res->cache[c], p, m);
            ts_hit hh;
            if (trace_patch(s, r, p, m, mm, best.t, &hh)) return 1;
            if (hh.patch != TS_INVALID && hh.t < best.t) best = hh;
            continue;
        }
        const ts_qbvh_node *nd = &q->nodes[it.item];
        for (int c = 0; c < 4; ++c) {
            int32_t child = nd->child[c];
            if (child == TS_CHILD_EMPTY) continue;
            float te = box_enter(o.x, o.y, o.z, ix, iy, iz, nd->lo_x[c], nd->lo_y[c], nd->lo_z[c],
                                 nd->hi_x[c], nd->hi_y[c], nd->hi_z[c], 0.0f, best.t);
            if (te >= 0.0f && heap_push(h, te, child)) return 1;
        }
    }
    *out = best;
    return 0;
}

/* Tallies how the two tracers' answers for ray r compare: hit or not (for a shadow ray,
 * occluded or not: its first hit need not be the nearest), and for the others the
 * distance. */
static void compare_hits(const bench_ray *r, const ts_hit *hc, bench_result *res)
{
    const ts_hit *hr = &r->hit;
    int c = hc->patch != TS_INVALID, t = hr->patch != TS_INVALID;
    res->hits_cache += c, res->hits_reorder += t;
    res->answers_equal += c == t;
    if (!c || !t || (r->flags & TS_RAY_SHADOW)) return;
    res->hits_compared++;
    res->hit_t_equal += hc->t == hr->t;
    res->t_reorder_nearer += hr->t < hc->t;
    res->t_cache_nearer += hc->t < hr->t;
}

int cache_trace(const ts_scene *s, const uint8_t *lod, const bench_ray *rays, uint64_t count,
                uint64_t memo_mb, bench_result *res, ts_error *err)
{
    uint32_t np = s->patch_count;
    ts_box *boxes = malloc((np ? np : 1) * sizeof *boxes);
    if (!boxes) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    for (uint32_t i = 0; i < np; ++i)
        boxes[i] = scene_patch_box(s, i);
    ts_qbvh q;
    int rc = qbvh_build(&q, boxes, np, 0, err);
    free(boxes);
    if (rc) return rc;
    memo mm = {calloc(np ? np : 1, sizeof(ts_vec4 *)),
               calloc(np ? np : 1, sizeof(ts_box4 *)),
               calloc(np ? np : 1, sizeof(ts_tight4 *)),
               0,
               memo_mb << 20,
               0,
               np};
    heap h = {0};
    res->seen = calloc(np ? np : 1, 1);
    res->pass_seen = res->by_pass ? calloc(np ? np : 1, sizeof *res->pass_seen) : NULL;
    if (!res->seen || (res->by_pass && !res->pass_seen))
        rc = ts_error_set(err, TS_E_MEMORY, "out of memory");
    for (int c = 0; c < BENCH_CACHES && !rc; ++c)
        if (lru_init(&res->cache[c], cache_sizes[c], np ? np : 1))
            rc = ts_error_set(err, TS_E_MEMORY, "out of memory");
    if (!mm.grid || !mm.groups || !mm.codes) rc = ts_error_set(err, TS_E_MEMORY, "out of memory");
    double t0 = stats_now();
    for (uint64_t k = 0; k < count && !rc; ++k) {
        ts_hit hc;
        res->pass_now = rays[k].pass + 1;
        if (trace_one(s, &q, lod, &rays[k], &mm, &h, res, &hc)) {
            rc = ts_error_set(err, TS_E_MEMORY, "out of memory in the cache tracer");
            break;
        }
        compare_hits(&rays[k], &hc, res);
    }
    res->cache_seconds = stats_now() - t0;
    res->host_dicings = mm.dicings;
    memo_clear(&mm);
    free(mm.grid), free(mm.groups), free(mm.codes), free(h.v);
    free(res->seen), res->seen = NULL;
    free(res->pass_seen), res->pass_seen = NULL;
    qbvh_free(&q);
    return rc;
}
