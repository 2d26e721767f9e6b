/* bottom_level_ref.c — scalar C version of kernels/bottom_level.cl's bottom_level_trace
 * (see bottom_level_ref.h). Where the kernel works on float4 (group_enter's four sibling
 * lanes, vertex interpolation), this code does the same operations lane by lane in the same
 * order; tessera_fp compiles it without contraction into fused multiply-adds, as the kernels
 * are (FP_CONTRACT OFF), so every distance rounds the same. */
#include "ref/bottom_level_ref.h"
#include "lib/instance.h"
#include "lib/intersect.h"
#include "lib/quadtree.h"

#include <math.h>
#include <stddef.h>

#define BL_REF_STACK (3 * TS_LOD_LIMIT + 2)

/* One ray as the tests need it (the kernel's bl_ray). */
typedef struct ref_ray {
    float o[3], inv[3], time, tmin;
    ts_ray_shear sh;
} ref_ray;

static ref_ray ref_ray_make(ts_vec4 o, ts_vec4 d)
{
    ref_ray r;
    r.o[0] = o.x, r.o[1] = o.y, r.o[2] = o.z;
    r.inv[0] = safe_reciprocal(d.x), r.inv[1] = safe_reciprocal(d.y),
    r.inv[2] = safe_reciprocal(d.z);
    r.time = d.w;
    r.tmin = o.w;
    r.sh = ray_shear(d.x, d.y, d.z);
    return r;
}

/* Lane q of sibling group g: its box, or with codes c its tight box (the kernel's
 * group_boxes). */
static ts_box lane_box(const ts_box4 *g, const ts_tight4 *c, uint32_t q)
{
    if (c) return box4_tight_lane(g, c, q);
    ts_box b = {g->lo_x[q], g->lo_y[q], g->lo_z[q], g->hi_x[q], g->hi_y[q], g->hi_z[q]};
    return b;
}

/* Lane q of the kernel's group_enter: the slab test of box q of sibling group g (and of its
 * time-1 twin g1, interpolated at the ray's time). Returns the entry clamped to tmin, or -1
 * for a miss; *raw gets the unclamped entry. */
static float lane_enter(const ts_box4 *g, const ts_box4 *g1, const ts_tight4 *c,
                        const ts_tight4 *c1, uint32_t q, const ref_ray *r, float tmax, float *raw)
{
    ts_box b = lane_box(g, c, q);
    float lx = b.lo_x, ly = b.lo_y, lz = b.lo_z, hx = b.hi_x, hy = b.hi_y, hz = b.hi_z;
    if (g1) {
        float t = r->time;
        ts_box b1 = lane_box(g1, c1, q);
        lx = lx + t * (b1.lo_x - lx), ly = ly + t * (b1.lo_y - ly);
        lz = lz + t * (b1.lo_z - lz), hx = hx + t * (b1.hi_x - hx);
        hy = hy + t * (b1.hi_y - hy), hz = hz + t * (b1.hi_z - hz);
    }
    float tx0 = (lx - r->o[0]) * r->inv[0], tx1 = (hx - r->o[0]) * r->inv[0];
    float ty0 = (ly - r->o[1]) * r->inv[1], ty1 = (hy - r->o[1]) * r->inv[1];
    float tz0 = (lz - r->o[2]) * r->inv[2], tz1 = (hz - r->o[2]) * r->inv[2];
    float in = TS_MAX(TS_MAX(TS_MIN(tx0, tx1), TS_MIN(ty0, ty1)), TS_MIN(tz0, tz1));
    float tn = TS_MAX(in, r->tmin);
    float tf = TS_MIN(TS_MIN(TS_MAX(tx0, tx1), TS_MAX(ty0, ty1)), TS_MIN(TS_MAX(tz0, tz1), tmax));
    tf *= 1.0000003576f;
    *raw = in;
    return (tn <= tf && lx <= hx) ? tn : -1.0f;
}

/* Vertex v at the ray's time. */
static ts_vec4 vertex_at(const bl_ref_patch *pt, uint32_t v, float time)
{
    ts_vec4 p = pt->g0[v];
    if (pt->g1) {
        ts_vec4 q = pt->g1[v];
        p.x = p.x + time * (q.x - p.x), p.y = p.y + time * (q.y - p.y);
        p.z = p.z + time * (q.z - p.z), p.w = p.w + time * (q.w - p.w);
    }
    return p;
}

/* Whether a hit at distance e (leaf box entry or triangle) of prim replaces *best: nearer, or
 * as near as a hit already with a larger prim, whatever the visiting order (the kernel's
 * hit_nearer). */
static int hit_nearer(float e, uint32_t prim, const ts_hit *best)
{
    return e < best->t || (e == best->t && best->patch != TS_INVALID && prim > best->prim);
}

/* The tmax a triangle is tested below: best->t, or just past it where an equal hit may win. */
static float triangle_tmax(const ts_hit *best)
{
    return best->patch != TS_INVALID ? nextafterf(best->t, INFINITY) : best->t;
}

/* The two micro-triangles of micro-quad k, split along (i,j)-(i+1,j+1). */
static void leaf_triangles(const ref_ray *r, const bl_ref_patch *pt, uint32_t k, ts_hit *best)
{
    uint32_t m = pt->m, i = morton_i(k), j = morton_j(k), n = (1u << m) + 1u;
    ts_vec4 v00 = vertex_at(pt, j * n + i, r->time), v10 = vertex_at(pt, j * n + i + 1u, r->time);
    ts_vec4 v01 = vertex_at(pt, (j + 1u) * n + i, r->time);
    ts_vec4 v11 = vertex_at(pt, (j + 1u) * n + i + 1u, r->time);
    float b1 = 0.0f, b2 = 0.0f, scale = ldexpf(1.0f, -(int)m);
    uint32_t quad = j * (n - 1u) + i, prim = TS_PRIM(m, 2u * quad);
    float t = triangle_hit(&r->sh, r->o[0], r->o[1], r->o[2], v00, v10, v11, r->tmin,
                           triangle_tmax(best), &b1, &b2);
    if (t >= 0.0f && hit_nearer(t, prim, best))
        *best = (ts_hit){t, ((float)i + b1 + b2) * scale, ((float)j + b2) * scale, pt->patch, prim};
    t = triangle_hit(&r->sh, r->o[0], r->o[1], r->o[2], v00, v11, v01, r->tmin, triangle_tmax(best),
                     &b1, &b2);
    if (t >= 0.0f && hit_nearer(t, prim + 1u, best))
        *best = (ts_hit){t, ((float)i + b1) * scale, ((float)j + b1 + b2) * scale, pt->patch,
                         prim + 1u};
}

/* Leaf box k hit at entry e: the hit is the entry, (u, v) the centre of its square. Of equal
 * entries the larger micro-quad index wins, whatever the visiting order (hit_nearer). */
static void leaf_box(uint32_t m, uint32_t k, float e, ts_hit *best, uint32_t patch)
{
    uint32_t i = morton_i(k), j = morton_j(k), prim = TS_PRIM(m, 2u * (j * (1u << m) + i));
    if (!hit_nearer(e, prim, best)) return;
    float scale = ldexpf(1.0f, -(int)m);
    *best = (ts_hit){e, ((float)i + 0.5f) * scale, ((float)j + 0.5f) * scale, patch, prim};
}

/* Micro-quad qi against the ray (the kernel's quad_test). */
static void quad_test(const ref_ray *r, const bl_ref_patch *pt, uint32_t qi, int exact,
                      ts_hit *best)
{
    if (exact) {
        if (pt->trimmed && quadtree_leaf_empty(pt->t0, pt->m, qi)) return; /* lib/trim.h */
        leaf_triangles(r, pt, qi, best);
        return;
    }
    uint32_t grp = pt->m == 0u ? 0u : quadtree_group_offset(pt->m) + (qi >> 2);
    uint32_t lane = pt->m == 0u ? 0u : (qi & 3u);
    float raw, e = lane_enter(pt->t0 + grp, pt->t1 ? pt->t1 + grp : NULL, NULL, NULL, lane, r,
                              best->t, &raw);
    if (e >= 0.0f && raw >= r->tmin) leaf_box(pt->m, qi, e, best, pt->patch);
}

/* Traversal state (the kernel's bl_trav). */
typedef struct ref_trav {
    uint32_t stack[BL_REF_STACK];
    float stack_t[BL_REF_STACK];
    int sp;
    uint32_t blk[4];
    float blt[4], blr[4];
    uint32_t qn, qi;
    float root_raw;
} ref_trav;

static void trav_start(ref_trav *s, const ref_ray *r, const bl_ref_patch *pt, float tmax)
{
    float raw, te = lane_enter(pt->t0, pt->t1, pt->c0, pt->c1, 0u, r, tmax, &raw);
    s->sp = 0, s->qn = 0, s->qi = 0, s->root_raw = raw;
    if (te >= 0.0f) s->stack[0] = 0u, s->stack_t[0] = te, s->sp = 1;
}

/* Node `level`/k expanded: its hit children, sorted by entry distance, farthest first. */
static uint32_t children_hit(const ref_ray *r, const bl_ref_patch *pt, uint32_t level, uint32_t k,
                             float tmax, float tc[4], float tr[4], uint32_t id[4])
{
    uint32_t grp = quadtree_group_offset(level + 1u) + k, nc = 0;
    const ts_box4 *g = pt->t0 + grp, *g1 = pt->t1 ? pt->t1 + grp : NULL;
    const ts_tight4 *c = pt->c0 ? pt->c0 + grp : NULL, *c1 = pt->c1 ? pt->c1 + grp : NULL;
    for (uint32_t q = 0; q < 4u; ++q) {
        float raw, e = lane_enter(g, g1, c, c1, q, r, tmax, &raw);
        if (e < 0.0f) continue;
        uint32_t at = nc++;
        while (at > 0u && tc[at - 1u] < e) {
            tc[at] = tc[at - 1u], tr[at] = tr[at - 1u], id[at] = id[at - 1u];
            --at;
        }
        tc[at] = e, tr[at] = raw, id[at] = 4u * k + q;
    }
    return nc;
}

/* The next block of level L (its index), or -1 when done (the kernel's bl_next_block). */
static int next_block(ref_trav *s, const ref_ray *r, const bl_ref_patch *pt, uint32_t L, float tmax,
                      float *te, float *raw)
{
    for (;;) {
        while (s->qi < s->qn && s->blt[s->qi] > tmax)
            ++s->qi;
        if (s->qi < s->qn) {
            *te = s->blt[s->qi], *raw = s->blr[s->qi];
            return (int)s->blk[s->qi++];
        }
        if (s->sp == 0) return -1;
        --s->sp;
        if (s->stack_t[s->sp] > tmax) continue;
        uint32_t level = s->stack[s->sp] >> 24, k = s->stack[s->sp] & 0xffffffu;
        if (level == L) { /* the root itself is the block */
            s->blk[0] = k, s->blt[0] = s->stack_t[s->sp], s->blr[0] = s->root_raw, s->qn = 1,
            s->qi = 0;
            continue;
        }
        float tc[4], tr[4];
        uint32_t id[4], nc = children_hit(r, pt, level, k, tmax, tc, tr, id);
        if (level + 1u == L) { /* the children are blocks: nearest first */
            for (uint32_t q = 0; q < nc; ++q)
                s->blk[q] = id[nc - 1u - q], s->blt[q] = tc[nc - 1u - q],
                s->blr[q] = tr[nc - 1u - q];
            s->qn = nc, s->qi = 0;
            continue;
        }
        for (uint32_t q = 0; q < nc; ++q) {
            s->stack[s->sp] = ((level + 1u) << 24) | id[q];
            s->stack_t[s->sp] = tc[q];
            ++s->sp;
        }
    }
}

bl_ref_patch bottom_level_ref_patch(const ts_segment *seg, const ts_vec4 *grid,
                                    const ts_box4 *groups, const ts_tight4 *codes)
{
    int moving = (seg->flags & TS_PATCH_MOVING) != 0u;
    bl_ref_patch pt;
    pt.m = seg->lod;
    pt.patch = seg->patch;
    pt.g0 = grid + seg->vert_first;
    pt.g1 = moving ? pt.g0 + quadtree_vertex_count(seg->lod) : NULL;
    pt.t0 = groups + seg->group_first;
    pt.t1 = moving ? pt.t0 + quadtree_group_count(seg->lod) : NULL;
    pt.c0 = codes ? codes + seg->group_first : NULL;
    pt.c1 = codes && moving ? pt.c0 + quadtree_group_count(seg->lod) : NULL;
    pt.trimmed = (seg->flags & TS_SEG_TRIMMED) != 0u;
    return pt;
}

ts_hit bottom_level_ref_trace(ts_vec4 org, ts_vec4 dir, float tmax, const bl_ref_patch *pt,
                              int exact, int any, uint32_t leaf_b, uint32_t *tests)
{
    ref_ray r = ref_ray_make(org, dir);
    ts_hit best = {tmax, 0.0f, 0.0f, TS_INVALID, TS_INVALID};
    uint32_t b = leaf_b < pt->m ? leaf_b : pt->m, L = pt->m - b, nq = 1u << (2u * b), n = 0;
    ref_trav s;
    trav_start(&s, &r, pt, best.t);
    float te, raw;
    for (int k; (k = next_block(&s, &r, pt, L, best.t, &te, &raw)) >= 0;) {
        if (any && best.patch != TS_INVALID) break;
        if (!exact && b == 0u) { /* the block is one leaf box, already tested */
            if (raw >= r.tmin) leaf_box(pt->m, (uint32_t)k, te, &best, pt->patch);
            ++n;
            continue;
        }
        for (uint32_t q = 0; q < nq; ++q, ++n)
            quad_test(&r, pt, ((uint32_t)k << (2u * b)) + q, exact, &best);
    }
    if (best.patch == TS_INVALID) best.t = TS_NO_HIT;
    if (tests) *tests = n;
    return best;
}

/* The segment (index within the batch) of sorted pair p: the last with begin <= p. */
static uint32_t segment_of(const ts_segment *seg, uint32_t count, uint32_t p)
{
    uint32_t lo = 0, hi = count;
    while (hi - lo > 1u) {
        uint32_t mid = (lo + hi) / 2u;
        if (seg[mid].begin <= p)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

uint64_t bottom_level_ref_pairs(const bl_ref_batch *b, uint32_t first, uint32_t count,
                                ts_hit *pair_hit)
{
    const ts_segment *batch = b->segments + b->seg_first;
    uint64_t tests = 0;
    for (uint32_t g = first; g < first + count; ++g) {
        ts_pair pr = b->pairs[b->pair_first + g];
        const ts_segment *seg = &batch[segment_of(batch, b->seg_count, b->pair_first + g)];
        uint32_t ray = b->active[pr.window / b->n_per_ray], flags = b->ray_flags[ray];
        ts_hit h = {TS_NO_HIT, 0.0f, 0.0f, TS_INVALID, TS_INVALID};
        /* A shadow ray is not stopped by the light it aims at. */
        if (!((flags & TS_RAY_SHADOW) && (flags >> 1) == seg->patch + 1u)) {
            bl_ref_patch pt = bottom_level_ref_patch(seg, b->grid, b->groups, NULL);
            uint32_t n = 0;
            /* bottom_level.cl bl_pair: the patch a ray leaves is micro-triangles, with org.w
             * its tmin; org.w is 0 elsewhere. */
            ts_vec4 o = b->org[ray], d = b->dir[ray];
            if (seg->shape != seg->patch) /* an instance: the master's frame */
                instance_ray(b->inst_xform + b->instance[seg->patch], &o, &d);
            int leaving = b->ray_from[ray] == seg->patch + 1u;
            if (!leaving) o.w = 0.0f;
            if (leaving && !b->exact && (seg->flags & TS_PATCH_ROUGH))
                /* box mode: its tight boxes cull it (bottom_level.cl bl_pair) */
                pt = bottom_level_ref_patch(seg, b->grid, b->groups, b->codes);
            h = bottom_level_ref_trace(o, d, b->hit[ray].t, &pt, (int)b->exact || leaving,
                                       (flags & TS_RAY_SHADOW) != 0u, b->leaf_b, &n);
            tests += n;
        }
        pair_hit[pr.window] = h;
    }
    return tests;
}
