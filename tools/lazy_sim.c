/* lazy_sim.c — bench_cache --lazy: what dicing a batch's patches only when one of their rays
 * still needs them would save, replayed on each iteration Tessera traced (ts_pipeline's
 * iteration_watch, host/pipeline/trace.c).
 *
 * An iteration dices every patch its pairs name that is not resident (a miss), in batches
 * that fit the arenas, and only then folds each ray's hits (resolve). A patch whose every pair
 * belongs to a ray that has already met a surface nearer than the patch's box, in a batch
 * traced before, cannot change any hit: dicing it is wasted. The replay walks the iteration's
 * segments in chunks, tests each missed patch against the running closest hits of its pairs'
 * rays (a pair is needed when its ray enters the patch's top-level box within that distance;
 * a shadow ray that is already occluded needs nothing), and folds the hits of the needed and
 * resident patches after each chunk (pair_hit: each pair's hit does not depend on the order).
 * Two orders:
 *   batch order: Tessera's batches as they ran (the walk over the patches, resident ones
 *     where the last walk left them);
 *   near first: resident patches first, then the misses by the least distance at which any of
 *     their pairs' rays enters the patch box, in chunks of the batches' mean size.
 * The hits are those of the real trace either way, so the image would not change. The test
 * uses the patch box alone (not the trees' upper levels by which top_level culls), so it
 * skips a little less than a kernel could. */
#include "bench_cache.h"
#include "lib/intersect.h"
#include "pipeline/pipeline.h"

#include <math.h>
#include <stdlib.h>

/* The iteration's device buffers, mapped, and each ray's running closest hit. */
typedef struct replay {
    ts_pipeline *p;
    uint32_t active, n_per_ray; /* windows: n_per_ray each, or window_first's when 0 */
    const uint32_t *act, *window_first, *flags;
    const ts_vec4 *org, *dir;
    const ts_hit *hit, *pair_hit;
    const ts_pair *pairs;
    float *near;   /* per active ray */
    uint32_t *ray; /* per pair slot: the active ray whose window holds it */
    ts_box *box;   /* per segment: its patch's top-level box */
    uint8_t *miss; /* per segment: diced this iteration */
} replay;

/* Each pair slot's ray (windows of n_per_ray slots, or window_first's) and each segment's
 * patch box, once for the iteration. */
static void replay_index(replay *r, uint32_t segs)
{
    for (uint32_t i = 0; i < r->active; ++i) {
        uint32_t w0 = r->n_per_ray ? i * r->n_per_ray : r->window_first[i];
        uint32_t w1 = r->n_per_ray ? w0 + r->n_per_ray : r->window_first[i + 1u];
        for (uint32_t w = w0; w < w1; ++w)
            r->ray[w] = i;
    }
    for (uint32_t g = 0; g < segs; ++g)
        r->box[g] = scene_patch_box(r->p->scene, r->p->segments_host[g].patch);
}

/* Where ray i enters box b within [0, tmax] (negative: it does not). */
static float replay_enter(const replay *r, uint32_t i, ts_box b, float tmax)
{
    uint32_t ray = r->act[i];
    ts_vec4 o = r->org[ray], d = r->dir[ray];
    return box_enter(o.x, o.y, o.z, safe_reciprocal(d.x), safe_reciprocal(d.y),
                     safe_reciprocal(d.z), b.lo_x, b.lo_y, b.lo_z, b.hi_x, b.hi_y, b.hi_z, 0.0f,
                     tmax);
}

/* 1 when a pair of segment g belongs to a ray that may still meet the patch nearer than its
 * closest hit so far (the slab test widened as top_level widens it). The sorted pairs are
 * valid ones (sort drops the windows' TS_INVALID fill). */
static int replay_needed(const replay *r, uint32_t g)
{
    const ts_segment *s = &r->p->segments_host[g];
    for (uint32_t k = s->begin; k < s->end; ++k) {
        uint32_t i = r->ray[r->pairs[k].window], ray = r->act[i];
        int occluded = (r->flags[ray] & TS_RAY_SHADOW) && r->near[i] < r->hit[ray].t;
        if (!occluded && replay_enter(r, i, r->box[g], r->near[i] * 1.0000004f) >= 0.0f) return 1;
    }
    return 0;
}

/* Folds segment s's pairs' hits into their rays' closest hits. */
static void replay_fold(const replay *r, const ts_segment *s)
{
    for (uint32_t k = s->begin; k < s->end; ++k) {
        uint32_t w = r->pairs[k].window, i = r->ray[w];
        if (r->pair_hit[w].t < r->near[i]) r->near[i] = r->pair_hit[w].t;
    }
}

/* Replays segments order[0..n) in chunks ending at ends[0..chunks) (the last at n): returns the
 * misses a lazy trace dices, and their micro-quads through *mp. */
static uint64_t replay_order(replay *r, const uint32_t *order, const uint32_t *ends,
                             uint32_t chunks, uint8_t *need, uint64_t *mp)
{
    for (uint32_t i = 0; i < r->active; ++i)
        r->near[i] = r->hit[r->act[i]].t;
    uint64_t diced = 0;
    for (uint32_t c = 0, c0 = 0; c < chunks; c0 = ends[c++]) {
        for (uint32_t j = c0; j < ends[c]; ++j) {
            const ts_segment *s = &r->p->segments_host[order[j]];
            need[j] = !r->miss[order[j]] || replay_needed(r, order[j]);
            if (r->miss[order[j]] && need[j]) diced++, *mp += 1ull << (2u * s->lod);
        }
        for (uint32_t j = c0; j < ends[c]; ++j)
            if (need[j]) replay_fold(r, &r->p->segments_host[order[j]]);
    }
    return diced;
}

typedef struct keyed {
    float key;
    uint32_t seg;
} keyed;

static int keyed_cmp(const void *a, const void *b)
{
    const keyed *x = a, *y = b;
    int by_key = (x->key > y->key) - (x->key < y->key);
    return by_key ? by_key : (x->seg > y->seg) - (x->seg < y->seg);
}

/* The near-first order: resident segments, then misses by their pairs' least entry. */
static void replay_near_first(const replay *r, uint32_t segs, keyed *k, uint32_t *order)
{
    for (uint32_t g = 0; g < segs; ++g) {
        const ts_segment *s = &r->p->segments_host[g];
        float best = INFINITY;
        for (uint32_t j = s->begin; r->miss[g] && j < s->end; ++j) {
            float t = replay_enter(r, r->ray[r->pairs[j].window], r->box[g], INFINITY);
            if (t >= 0.0f && t < best) best = t;
        }
        k[g] = (keyed){r->miss[g] ? best : -1.0f, g};
    }
    qsort(k, segs, sizeof *k, keyed_cmp);
    for (uint32_t g = 0; g < segs; ++g)
        order[g] = k[g].seg;
}

static int replay_map(replay *r, cl_mem pairs, uint32_t valid, ts_error *err)
{
    ts_pipeline *p = r->p;
    size_t slots = p->plan.ray_capacity;
    if (!(r->act = dev_map(p->cl, p->active, CL_MAP_READ, 0, r->active * sizeof(uint32_t),
                           "the active rays", err)) ||
        (!r->n_per_ray &&
         !(r->window_first = dev_map(p->cl, p->window_first, CL_MAP_READ, 0,
                                     (r->active + 1u) * sizeof(uint32_t), "the windows", err))) ||
        !(r->org =
              dev_map(p->cl, p->ray_org, CL_MAP_READ, 0, slots * sizeof(ts_vec4), "rays", err)) ||
        !(r->dir =
              dev_map(p->cl, p->ray_dir, CL_MAP_READ, 0, slots * sizeof(ts_vec4), "rays", err)) ||
        !(r->hit =
              dev_map(p->cl, p->ray_hit, CL_MAP_READ, 0, slots * sizeof(ts_hit), "hits", err)) ||
        !(r->flags = dev_map(p->cl, p->ray_flags, CL_MAP_READ, 0, slots * sizeof(uint32_t),
                             "ray flags", err)) ||
        !(r->pairs = dev_map(p->cl, pairs, CL_MAP_READ, 0, (valid ? valid : 1u) * sizeof(ts_pair),
                             "the pairs", err)) ||
        !(r->pair_hit = dev_map(p->cl, p->pair_hit, CL_MAP_READ, 0,
                                (size_t)p->plan.pair_capacity * sizeof(ts_hit), "pair hits", err)))
        return err->code;
    return TS_OK;
}

/* Every map undone; err keeps the first failure. */
static void replay_unmap(replay *r, cl_mem pairs, ts_error *err)
{
    ts_pipeline *p = r->p;
    struct {
        cl_mem m;
        const void *at;
    } maps[] = {{p->active, r->act},  {p->window_first, r->window_first},
                {p->ray_org, r->org}, {p->ray_dir, r->dir},
                {p->ray_hit, r->hit}, {p->ray_flags, r->flags},
                {pairs, r->pairs},    {p->pair_hit, r->pair_hit}};
    for (size_t i = 0; i < sizeof maps / sizeof maps[0]; ++i)
        if (maps[i].at) dev_unmap(p->cl, maps[i].m, (void *)maps[i].at, "a buffer", err);
}

int lazy_watch(void *ctx, ts_pipeline *p, uint32_t active, uint32_t n_per_ray, cl_mem pairs,
               uint32_t valid, uint32_t segs, ts_error *err)
{
    lazy_counts *c = ctx;
    uint32_t nb = p->batch_count ? p->batch_count : 1u;
    replay r = {.p = p, .active = active, .n_per_ray = n_per_ray};
    uint32_t *order = calloc(segs, sizeof *order), *ends = calloc(nb, sizeof *ends);
    keyed *k = malloc((size_t)segs * sizeof *k);
    uint8_t *need = malloc(segs);
    r.near = malloc((size_t)(active ? active : 1u) * sizeof *r.near);
    r.miss = calloc(segs, 1);
    r.ray = malloc((size_t)p->plan.pair_capacity * sizeof *r.ray);
    r.box = malloc((size_t)segs * sizeof *r.box);
    int rc = order && ends && k && need && r.near && r.miss && r.ray && r.box
                 ? replay_map(&r, pairs, valid, err)
                 : ts_error_set(err, TS_E_MEMORY, "out of memory for the lazy replay");
    if (!rc) {
        replay_index(&r, segs);
        for (uint32_t b = 0; b < p->batch_count; ++b)
            for (uint32_t t = 0; t < p->batches[b].tree_count; ++t)
                r.miss[TS_TREE_SEGMENT(p->trees_host[p->batches[b].tree_first + t])] = 1;
        for (uint32_t g = 0; g < segs; ++g)
            if (r.miss[g]) c->misses++, c->misses_mp += 1ull << (2u * p->segments_host[g].lod);
        /* The batches as they ran: each a run of consecutive segments. */
        uint32_t n = 0;
        for (uint32_t b = 0; b < p->batch_count; ++b) {
            for (uint32_t j = 0; j < p->batches[b].seg_count; ++j)
                order[n++] = p->batches[b].seg_first + j;
            ends[b] = n;
        }
        c->batch_order += replay_order(&r, order, ends, p->batch_count, need, &c->batch_order_mp);
        /* Near first, in chunks of the batches' mean size. */
        replay_near_first(&r, segs, k, order);
        uint32_t chunk = (segs + nb - 1u) / nb;
        for (uint32_t b = 0; b < nb; ++b)
            ends[b] = (b + 1u) * chunk < segs ? (b + 1u) * chunk : segs;
        c->near_first += replay_order(&r, order, ends, nb, need, &c->near_first_mp);
    }
    replay_unmap(&r, pairs, err);
    free(order), free(ends), free(k), free(need), free(r.near), free(r.miss), free(r.ray),
        free(r.box);
    return rc ? err->code : TS_OK;
}
