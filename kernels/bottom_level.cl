/* bottom_level.cl — stage `bottom_level` (Hanika §3.2.1-3.4): each sorted (ray, patch) pair
 * of a batch traverses its patch's quad-tree front to back.
 * Reads:  pairs[pair_first ..), the batch's segments (found by binary search on begin), ray
 *         org/dir (dir.w = time), hit.t as tmax, the grid(s) and tree(s) of the segment.
 * Writes: pair_hit[pair.window]: the closest hit in this patch below tmax, or t = TS_NO_HIT;
 *         for a shadow ray (TS_RAY_SHADOW) the closest hit of the first leaf block, in visiting
 *         order, that has one: it only asks whether anything is in the way.
 * Geometry, by `exact`:
 *   0 (default): the leaf boxes themselves (§3.3): conservative over each micro-quad's
 *     parameter square, so patches diced at different m leave no holes; the hit is the
 *     ray's entry into the box, (u, v) the square's centre.
 *   1: the two micro-triangles of each micro-quad (split along (i,j)-(i+1,j+1)), with the
 *     watertight test of lib/intersect.h; for cross-checks at a fixed m.
 *   The patch a secondary ray leaves (ray_from = patch + 1) is always its micro-triangles,
 *   with hits nearer than org.w ignored (the origin-patch rule, bl_pair); in box mode its
 *   traversal tests the nodes' tight boxes (the ts_tight4 codes: the boxes of the diced
 *   vertices, which hold the triangles) instead of the boxes that bound every finer dicing.
 * Instances (ObjectInstance, host/scene/instance.c): a segment whose shape is not its patch
 *   traverses its master's grid and tree with the ray moved into the master's frame by the
 *   patch's transform, inst_xform[instance[patch]] (lib/instance.h: t is unchanged); the hit
 *   keeps the segment's own patch, so shading sees the instance.
 * Skeletons: a TS_SEG_SKELETON segment has no tree in the arenas; its pairs traverse the
 *   patch's kept skeleton and make the leaves, or for a ray that leaves the patch the
 *   vertices, of the blocks they enter (bl_skeleton, CPU devices), the same hits.
 * Motion (§3.4): a moving segment has a tree and a grid per time sample; boxes and vertices
 * are interpolated linearly at the ray's time.
 * Sibling boxes are tested four at a time (SoA groups, lib/quadtree.h). Stack: at most 3
 * entries per level plus one.
 * Leaves are blocks of 2^b x 2^b micro-quads (`leaf_b`; traversal stops b levels above m),
 * intersected by one of two kernels that return identical hits:
 *   bottom_level_trace: each work-item loops over its blocks' micro-quads (per-ray leaves);
 *   bottom_level_group: PantaRay's warp-wide leaf intersection (Pantaleoni et al. 2010,
 *     §4.4, Fig. 8) on a work-group: each round every work-item advances to its next block,
 *     an exclusive scan in local memory gives each (ray, micro-quad) task a slot, every
 *     work-item runs tasks with the owner's ray copied through local memory, and each owner
 *     folds its results back in order. Every work-item reaches every barrier.
 * Identical hits: both visit blocks in the same order (nearest first, the same culling) and
 * test each micro-quad with quad_test; of hits at the same distance (leaf boxes entered at
 * one distance, triangles met on a shared edge) the one with the larger prim wins
 * (hit_nearer), so that the hits do not depend on the visiting order at all (leaf sizes, leaf
 * modes, skeletons). Both count leaf-stage utilisation: micro-quad tests over work-item slots
 * (a work-group in lockstep for the per-ray kernel). */
#include "lib/shared_types.h"
#include "lib/instance.h"
#include "lib/intersect.h"
#include "lib/prefetch.h"
#include "lib/quadtree.h"
#include "lib/leaf4.h"

#define BL_STACK (3 * TS_LOD_LIMIT + 2)
#define BL_WG TS_GROUP_SIZE /* work-group size of bottom_level_group */
#define BL_MAX_BLOCK 16u    /* micro-quads in the largest leaf block (4 x 4) */
/* the vertices of a skeleton's block of leaves */
#define BL_SKEL_VERTS (((1u << TS_SKELETON_DROP) + 1u) * ((1u << TS_SKELETON_DROP) + 1u))

/* Index (within the batch) of the segment holding sorted pair p: the last with begin <= p. */
inline uint segment_of(__global const ts_segment *seg, uint count, uint p)
{
    uint lo = 0, hi = count;
    while (hi - lo > 1u) {
        uint mid = (lo + hi) / 2u;
        if (seg[mid].begin <= p)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* Vertex v of the grid at the ray's time (g1 == 0 for a static patch). */
inline float4 vertex_at(__global const float4 *g0, __global const float4 *g1, uint v, float time)
{
    float4 p = g0[v];
    if (g1) p = p + time * (g1[v] - p);
    return p;
}

/* Whether a hit at distance e (a leaf box's entry, or a micro-triangle's prim) is the patch's
 * hit rather than *best: it is nearer, or as near as a hit already (best->patch set) with a
 * larger prim. Adjacent leaf boxes often share the plane a ray enters by (their clamp to the
 * patch box, or their common faces), and a ray through a shared edge can meet two triangles
 * at one distance; a fixed rule makes the hit the same whatever order the leaves are visited
 * in: every leaf size and leaf mode, a skeleton's blocks (bl_skeleton), and the C reference
 * (host/ref/bottom_level_ref.c). The larger index is the one the traversal mostly met first
 * anyway (children of equal entry are expanded last child first): with the smaller one,
 * forest-100 960x384 changed at 1.8% of its pixels, and test_instance's displaced instances
 * drifted from their copies by 1.5 of the noise allowance (a bias in the hits' (u, v)); with the
 * larger, 0.06% changed. A hit at exactly the tmax the pair began with stays the earlier one's
 * (best->patch unset). */
inline int hit_nearer(float e, uint prim, const ts_hit *best)
{
    return e < best->t || (e == best->t && best->patch != TS_INVALID && prim > best->prim);
}

/* The tmax a triangle is tested below: best->t, or just past it where an equal hit may win
 * (hit_nearer). */
inline float triangle_tmax(const ts_hit *best)
{
    return best->patch != TS_INVALID ? nextafter(best->t, INFINITY) : best->t;
}

/* Tests the micro-triangles of micro-quad (i, j) of a patch diced at m, its vertices p00, p10,
 * p01, p11 (at the ray's time); updates *best. The vertices are made relative to the origin and
 * permuted to the shear's axes with one shuffle each (the host reference, triangle_hit, does
 * the same arithmetic). */
TS_INLINE_ALWAYS void quad_triangles(float4 p00, float4 p10, float4 p01, float4 p11, uint m, uint i,
                                     uint j, float4 o4, float tmin, uint4 perm,
                                     const ts_ray_shear *sh, ts_hit *best, uint patch)
{
    float4 v00 = shuffle(p00 - o4, perm), v10 = shuffle(p10 - o4, perm);
    float4 v01 = shuffle(p01 - o4, perm), v11 = shuffle(p11 - o4, perm);
    float b1, b2, scale = ldexp(1.0f, -(int)m);
    uint quad = j * (1u << m) + i, prim = TS_PRIM(m, 2u * quad);
    float t = triangle_hit_permuted(sh, v00.x, v00.y, v00.z, v10.x, v10.y, v10.z, v11.x, v11.y,
                                    v11.z, tmin, triangle_tmax(best), &b1, &b2);
    if (t >= 0.0f && hit_nearer(t, prim, best)) {
        *best = (ts_hit){t, ((float)i + b1 + b2) * scale, ((float)j + b2) * scale, patch, prim};
    }
    t = triangle_hit_permuted(sh, v00.x, v00.y, v00.z, v11.x, v11.y, v11.z, v01.x, v01.y, v01.z,
                              tmin, triangle_tmax(best), &b1, &b2);
    if (t >= 0.0f && hit_nearer(t, prim + 1u, best)) {
        *best =
            (ts_hit){t, ((float)i + b1) * scale, ((float)j + b1 + b2) * scale, patch, prim + 1u};
    }
}

/* quad_triangles of micro-quad k (Morton order) with its vertices from the grid(s). */
inline void leaf_triangles(__global const float4 *g0, __global const float4 *g1, float time, uint m,
                           uint k, float4 o4, float tmin, uint4 perm, const ts_ray_shear *sh,
                           ts_hit *best, uint patch)
{
    uint i = morton_i(k), j = morton_j(k), n = (1u << m) + 1u;
    quad_triangles(vertex_at(g0, g1, j * n + i, time), vertex_at(g0, g1, j * n + i + 1u, time),
                   vertex_at(g0, g1, (j + 1u) * n + i, time),
                   vertex_at(g0, g1, (j + 1u) * n + i + 1u, time), m, i, j, o4, tmin, perm, sh,
                   best, patch);
}

/* A leaf box hit at entry distance e (box mode). */
inline void leaf_box(uint m, uint k, float e, ts_hit *best, uint patch)
{
    uint i = morton_i(k), j = morton_j(k), prim = TS_PRIM(m, 2u * (j * (1u << m) + i));
    if (!hit_nearer(e, prim, best)) return;
    *best = (ts_hit){e, quadtree_centre(i, m), quadtree_centre(j, m), patch, prim};
}

/* Slab test of four boxes in float4 lanes. Returns the entry distances, -1 in lanes that
 * miss; *raw gets the entries before clamping to tmin (below tmin when the ray starts inside
 * the box). */
TS_INLINE_ALWAYS float4 slab4(float4 lx, float4 ly, float4 lz, float4 hx, float4 hy, float4 hz,
                              float4 o, float4 inv, float tmin, float tmax, float4 *raw)
{
    float4 tx0 = (lx - o.x) * inv.x, tx1 = (hx - o.x) * inv.x;
    float4 ty0 = (ly - o.y) * inv.y, ty1 = (hy - o.y) * inv.y;
    float4 tz0 = (lz - o.z) * inv.z, tz1 = (hz - o.z) * inv.z;
    float4 in = TS_MAX(TS_MAX(TS_MIN(tx0, tx1), TS_MIN(ty0, ty1)), TS_MIN(tz0, tz1));
    float4 tn = TS_MAX(in, (float4)(tmin));
    float4 tf = TS_MIN(TS_MIN(TS_MAX(tx0, tx1), TS_MAX(ty0, ty1)),
                       TS_MIN(TS_MAX(tz0, tz1), (float4)(tmax)));
    tf *= 1.0000003576f;
    *raw = in;
    return select((float4)(-1.0f), tn, tn <= tf && lx <= hx);
}

/* Slab test of the four boxes of sibling group g (and of its time-1 twin g1, interpolated
 * at `time`, when g1 != 0): slab4's entries. */
TS_INLINE_ALWAYS float4 group_enter(__global const ts_box4 *g, __global const ts_box4 *g1,
                                    float time, float4 o, float4 inv, float tmin, float tmax,
                                    float4 *raw)
{
    float4 lx = vload4(0, g->lo_x), ly = vload4(0, g->lo_y), lz = vload4(0, g->lo_z);
    float4 hx = vload4(0, g->hi_x), hy = vload4(0, g->hi_y), hz = vload4(0, g->hi_z);
    if (g1) {
        lx += time * (vload4(0, g1->lo_x) - lx), ly += time * (vload4(0, g1->lo_y) - ly);
        lz += time * (vload4(0, g1->lo_z) - lz), hx += time * (vload4(0, g1->hi_x) - hx);
        hy += time * (vload4(0, g1->hi_y) - hy), hz += time * (vload4(0, g1->hi_z) - hz);
    }
    return slab4(lx, ly, lz, hx, hy, hz, o, inv, tmin, tmax, raw);
}

/* The four tight boxes of sibling group g, its codes c, as float4 lanes (lib/quadtree.h
 * box4_tight_lane, lane by lane). */
inline void group_tight_boxes(__global const ts_box4 *g, __global const ts_tight4 *c, float4 *lx,
                              float4 *ly, float4 *lz, float4 *hx, float4 *hy, float4 *hz)
{
    float4 bx = vload4(0, g->lo_x), by = vload4(0, g->lo_y), bz = vload4(0, g->lo_z);
    float4 ex = vload4(0, g->hi_x), ey = vload4(0, g->hi_y), ez = vload4(0, g->hi_z);
    float4 sx = (ex - bx) * (1.0f / 255.0f), sy = (ey - by) * (1.0f / 255.0f),
           sz = (ez - bz) * (1.0f / 255.0f);
    tight4_decode(c, bx, by, bz, ex, ey, ez, sx, sy, sz, lx, ly, lz, hx, hy, hz);
}

/* group_enter on the tight boxes of g (and g1), their codes c (and c1): the displaced patch a
 * ray leaves, in box mode. Apart from group_enter, whose path every other pair takes. */
inline float4 group_enter_tight(__global const ts_box4 *g, __global const ts_box4 *g1,
                                __global const ts_tight4 *c, __global const ts_tight4 *c1,
                                float time, float4 o, float4 inv, float tmin, float tmax,
                                float4 *raw)
{
    float4 lx, ly, lz, hx, hy, hz;
    group_tight_boxes(g, c, &lx, &ly, &lz, &hx, &hy, &hz);
    if (g1) {
        float4 mx, my, mz, nx, ny, nz;
        group_tight_boxes(g1, c1, &mx, &my, &mz, &nx, &ny, &nz);
        lx += time * (mx - lx), ly += time * (my - ly), lz += time * (mz - lz);
        hx += time * (nx - hx), hy += time * (ny - hy), hz += time * (nz - hz);
    }
    return slab4(lx, ly, lz, hx, hy, hz, o, inv, tmin, tmax, raw);
}

/* One ray, as the leaf tests need it. */
typedef struct bl_ray {
    float4 o4;  /* origin, w = 0 */
    float4 inv; /* reciprocal direction (safe_reciprocal), w = time */
    ts_ray_shear sh;
    uint4 perm;
    float tmin;
} bl_ray;

/* One diced patch: its grid(s) and tree(s); the second of each only when it moves. c0, c1:
 * the trees' tight codes, when the traversal tests the tight boxes (the patch a ray leaves,
 * in box mode), else 0. */
typedef struct bl_patch {
    __global const float4 *g0, *g1;
    __global const ts_box4 *t0, *t1;
    __global const ts_tight4 *c0, *c1;
    uint m, patch;
    uint trimmed;  /* TS_SEG_TRIMMED: micro-quads its trim removes have empty boxes */
    uint shape;    /* the patch diced (itself, or the master an instance shares) */
    uint skeleton; /* TS_SEG_SKELETON: no tree in the arenas; traced by bl_skeleton */
} bl_patch;

/* The traversal of one ray through one patch's tree, stopped at blocks of level L. */
typedef struct bl_trav {
    uint stack[BL_STACK];
    float stack_t[BL_STACK];
    int sp;
    uint blk[4];          /* the hit blocks of the last node expanded, nearest first */
    float blt[4], blr[4]; /* their entry distances, clamped to tmin and raw */
    uint qn, qi;          /* how many, and the next to visit */
    float root_raw;       /* the root's raw entry, for a root that is itself the block */
} bl_trav;

/* tmin: 0, or org.w for the patch the ray leaves (the self distance, see bl_pair). */
inline bl_ray bl_ray_make(ts_vec4 o, ts_vec4 d, float tmin)
{
    bl_ray r;
    r.o4 = (float4)(o.x, o.y, o.z, 0.0f);
    r.inv = (float4)(safe_reciprocal(d.x), safe_reciprocal(d.y), safe_reciprocal(d.z), d.w);
    r.sh = ray_shear(d.x, d.y, d.z);
    r.perm = (uint4)((uint)r.sh.kx, (uint)r.sh.ky, (uint)r.sh.kz, 3u);
    r.tmin = tmin;
    return r;
}

inline bl_patch bl_patch_make(ts_segment seg, __global const ts_vec4 *grid,
                              __global const ts_box4 *groups)
{
    bl_patch pt;
    int moving = (seg.flags & TS_PATCH_MOVING) != 0u;
    pt.m = seg.lod;
    pt.patch = seg.patch;
    pt.g0 = (__global const float4 *)(grid + seg.vert_first);
    pt.g1 = moving ? pt.g0 + quadtree_vertex_count(seg.lod) : 0;
    pt.t0 = groups + seg.group_first;
    pt.t1 = moving ? pt.t0 + quadtree_group_count(seg.lod) : 0;
    pt.c0 = pt.c1 = 0;
    pt.trimmed = (seg.flags & TS_SEG_TRIMMED) != 0u;
    pt.shape = seg.shape;
    pt.skeleton = (seg.flags & TS_SEG_SKELETON) != 0u;
    return pt;
}

/* Tests micro-quad qi (level m, Morton order) against the ray; a hit closer than best->t
 * replaces *best. Exact: its two triangles. Boxes: its leaf box, unless the ray starts
 * inside it (the ray is leaving the surface there, Hanika §3.3). */
inline void quad_test(const bl_ray *r, const bl_patch *pt, uint qi, uint exact, ts_hit *best)
{
    float time = r->inv.w;
    if (exact) {
        if (pt->trimmed && quadtree_leaf_empty(pt->t0, pt->m, qi)) return; /* lib/trim.h */
        leaf_triangles(pt->g0, pt->g1, time, pt->m, qi, r->o4, r->tmin, r->perm, &r->sh, best,
                       pt->patch);
        return;
    }
    uint grp = pt->m == 0u ? 0u : quadtree_group_offset(pt->m) + (qi >> 2),
         lane = pt->m == 0u ? 0u : (qi & 3u);
    float4 raw, e = group_enter(pt->t0 + grp, pt->t1 ? pt->t1 + grp : 0, time, r->o4, r->inv,
                                r->tmin, best->t, &raw);
    float el = lane == 0u ? e.x : lane == 1u ? e.y : lane == 2u ? e.z : e.w;
    float rl = lane == 0u ? raw.x : lane == 1u ? raw.y : lane == 2u ? raw.z : raw.w;
    if (el >= 0.0f && rl >= r->tmin) leaf_box(pt->m, qi, el, best, pt->patch);
}

/* Starts the traversal at the root. The root's own box is tested only where it decides
 * something: when it is itself the block (L = 0), or when the patch moves. A static root
 * above the blocks is expanded untested: its children lie inside it, and the slab test is
 * monotone in the box's planes (each rounding is), so a ray that misses the root, or enters
 * it beyond tmax, misses its children or enters them beyond tmax too, and they are culled
 * when expanded: the same blocks in the same order (top_level's cull_enter has already
 * dropped nearly every pair whose ray misses the patch's upper levels). */
inline void bl_trav_start(bl_trav *s, const bl_ray *r, const bl_patch *pt, float tmax, uint L)
{
    s->sp = 0, s->qn = 0, s->qi = 0, s->root_raw = 0.0f;
    if (L > 0u && !pt->t1) {
        s->stack[0] = 0u, s->stack_t[0] = -INFINITY, s->sp = 1;
        return;
    }
    float4 raw;
    float te = (pt->c0 ? group_enter_tight(pt->t0, pt->t1, pt->c0, pt->c1, r->inv.w, r->o4, r->inv,
                                           r->tmin, tmax, &raw)
                       : group_enter(pt->t0, pt->t1, r->inv.w, r->o4, r->inv, r->tmin, tmax, &raw))
                   .x;
    s->root_raw = raw.x;
    if (te >= 0.0f) s->stack[0] = 0u, s->stack_t[0] = te, s->sp = 1;
}

/* The children a ray enters (entry e[q] >= 0, q = 0..3), sorted by entry, farthest first:
 * their entries in tc, their lanes in id; returns how many. Of equal entries the earlier lane
 * comes first (is visited later). Unrolled: the four children's tests stay in registers (no order
 * change). */
TS_INLINE_ALWAYS uint children_far_first(const float e[4], float tc[4], uint id[4])
{
    uint nc = 0u;
#pragma unroll
    for (uint q = 0; q < 4u; ++q) {
        if (e[q] < 0.0f) continue;
        uint at = nc++;
        while (at > 0u && tc[at - 1u] < e[q]) {
            tc[at] = tc[at - 1u], id[at] = id[at - 1u];
            --at;
        }
        tc[at] = e[q], id[at] = q;
    }
    return nc;
}

/* The next block of level L to visit (its index), or -1 when the traversal is done:
 * blocks are taken from the last expanded node nearest first, skipping those that start
 * beyond tmax; then the stack is popped and nodes expanded front to back. *te and *raw get
 * the block box's entry distance (clamped to tmin, and raw), so a block that is a single
 * leaf box (leaf_b = 0, box mode) needs no second test. */
TS_INLINE_ALWAYS int bl_next_block_any(bl_trav *s, const bl_ray *r, const bl_patch *pt, uint L,
                                       float tmax, float *te, float *raw, const uint tight)
{
    uint next = TS_INVALID;
    for (;;) {
        while (s->qi < s->qn && s->blt[s->qi] > tmax)
            ++s->qi;
        if (s->qi < s->qn) {
            *te = s->blt[s->qi], *raw = s->blr[s->qi];
            return (int)s->blk[s->qi++];
        }
        uint node;
        if (next != TS_INVALID) { /* the nearest child of the node just expanded */
            node = next, next = TS_INVALID;
        } else {
            if (s->sp == 0) return -1;
            --s->sp;
            if (s->stack_t[s->sp] > tmax) continue;
            node = s->stack[s->sp];
        }
        uint level = node >> 24, k = node & 0xffffffu;
        if (level == L) { /* the root itself is the block */
            s->blk[0] = k, s->blt[0] = s->stack_t[s->sp], s->blr[0] = s->root_raw, s->qn = 1,
            s->qi = 0;
            continue;
        }
        uint grp = quadtree_group_offset(level + 1u) + k;
        __global const ts_box4 *g0 = pt->t0 + grp, *g1 = pt->t1 ? pt->t1 + grp : 0;
        float4 raw, e4 = tight ? group_enter_tight(g0, g1, pt->c0 + grp, pt->c1 ? pt->c1 + grp : 0,
                                                   r->inv.w, r->o4, r->inv, r->tmin, tmax, &raw)
                               : group_enter(g0, g1, r->inv.w, r->o4, r->inv, r->tmin, tmax, &raw);
        float e[4] = {e4.x, e4.y, e4.z, e4.w}, er[4] = {raw.x, raw.y, raw.z, raw.w};
        /* Children that are hit, farthest first (a child's raw entry is er[its lane], read only
         * where the children are blocks). */
        float tc[4];
        uint id[4], nc = children_far_first(e, tc, id);
        if (level + 1u == L) { /* the children are blocks: visit them nearest first */
            for (uint q = 0; q < nc; ++q)
                s->blk[q] = 4u * k + id[nc - 1u - q], s->blt[q] = tc[nc - 1u - q],
                s->blr[q] = er[id[nc - 1u - q]];
            s->qn = nc, s->qi = 0;
            continue;
        }
        if (nc == 0u) continue;
        for (uint q = 0; q + 1u < nc; ++q) {
            s->stack[s->sp] = ((level + 1u) << 24) | (4u * k + id[q]);
            s->stack_t[s->sp] = tc[q];
            ++s->sp;
        }
        /* The nearest is expanded next, as if pushed and popped at once. */
        if (!(tc[nc - 1u] > tmax)) next = ((level + 1u) << 24) | (4u * k + id[nc - 1u]);
    }
}

inline int bl_next_block_tight(bl_trav *s, const bl_ray *r, const bl_patch *pt, uint L, float tmax,
                               float *te, float *raw)
{
    return bl_next_block_any(s, r, pt, L, tmax, te, raw, 1u);
}

/* bl_next_block_any for the pairs that test node boxes, and for those that test tight boxes
 * (pt->c0 set): two copies, so the common one carries no branch per sibling group. */
inline int bl_next_block(bl_trav *s, const bl_ray *r, const bl_patch *pt, uint L, float tmax,
                         float *te, float *raw)
{
    return pt->c0 ? bl_next_block_tight(s, r, pt, L, tmax, te, raw)
                  : bl_next_block_any(s, r, pt, L, tmax, te, raw, 0u);
}

/* Which active ray's candidate window holds slot w (top_level.cl): w / n_per_ray, or with
 * water-filled windows (n_per_ray 0) the i with window_first[i] <= w < window_first[i + 1]:
 * the last i with window_first[i] <= w, by binary search over [0, active_count). */
inline uint window_owner(uint w, uint n_per_ray, __global const uint *window_first,
                         uint active_count)
{
    if (n_per_ray != 0u) return w / n_per_ray;
    uint lo = 0u, hi = active_count; /* window_first[lo] <= w < window_first[hi] */
    while (hi - lo > 1u) {
        uint mid = lo + (hi - lo) / 2u;
        if (window_first[mid] <= w)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* The pair of work-item gid: its ray, its patch, and whether it is to be traced at all (a
 * shadow ray is not stopped by the light it aims at); *shadow: a shadow ray, which any hit
 * answers, so its traversal ends after the first block where it finds one. */
inline int bl_pair(uint gid, __global const ts_pair *pairs, uint pair_first,
                   __global const ts_segment *segments, uint seg_first, uint seg_count,
                   uint n_per_ray, __global const uint *window_first, uint active_count,
                   __global const uint *active, __global const ts_vec4 *org,
                   __global const ts_vec4 *dir, __global const ts_hit *hit,
                   __global const uint *ray_flags, __global const uint *ray_from,
                   __global const ts_vec4 *grid, __global const ts_box4 *groups,
                   __global const ts_tight4 *codes, __global const uint *instance,
                   __global const ts_xform *inst_xform, bl_ray *r, bl_patch *pt, ts_hit *best,
                   uint *window, uint *exact, uint *shadow)
{
    ts_pair pr = pairs[pair_first + gid];
    __global const ts_segment *batch = segments + seg_first;
    ts_segment seg = batch[segment_of(batch, seg_count, pair_first + gid)];
    uint ray = active[window_owner(pr.window, n_per_ray, window_first, active_count)];
    uint flags = ray_flags[ray];
    *window = pr.window;
    *shadow = (flags & TS_RAY_SHADOW) != 0u;
    ts_vec4 o = org[ray], d = dir[ray];
    if (seg.shape != seg.patch) instance_ray(inst_xform + instance[seg.patch], &o, &d);
    /* The origin-patch rule (issue 13): a secondary ray meets the patch it leaves as that
     * patch's micro-triangles, watertight within the patch, whatever the mode: its leaf
     * boxes, grown to bound every finer dicing, surround the ray's origin and would stop it
     * at once (4x more bounce hits than the true surface on the displaced teapot). Hits
     * there nearer than org.w (one micro-quad) are ignored. Other patches are leaf boxes in
     * box mode, which keeps neighbours at different levels of detail hole-free. */
    int leaving = ray_from[ray] == seg.patch + 1u;
    *r = bl_ray_make(o, d, leaving ? o.w : 0.0f);
    *pt = bl_patch_make(seg, grid, groups);
    /* In box mode a displaced patch's tight boxes cull it (the boxes of the diced vertices,
     * which hold the triangles); in triangle mode the node boxes are those already, and an
     * undisplaced patch's are near them (its codes are 0). */
    if (leaving && !*exact && (seg.flags & TS_PATCH_ROUGH) != 0u) {
        pt->c0 = codes + seg.group_first;
        pt->c1 = pt->t1 ? pt->c0 + quadtree_group_count(seg.lod) : 0;
    }
    *exact = *exact || leaving;
    *best = (ts_hit){hit[ray].t, 0.0f, 0.0f, TS_INVALID, TS_INVALID};
    return !((flags & TS_RAY_SHADOW) && (flags >> 1) == seg.patch + 1u);
}

#ifdef TS_CPU_LANES
/* The leaves' inputs of a patch traced through its skeleton (block_leaf_boxes'). */
typedef struct bl_leaf_src {
    __global const ts_patch_attr *a;
    __global const ts_xform *ax;
    __global const ts_vec4 *cp, *cn, *mn;
    ts_vec4 e;
    ts_box pbox;
} bl_leaf_src;

/* A pair of a TS_SEG_SKELETON segment (a static, noise-displaced or undisplaced patch at
 * m >= 4 without its tree in the arenas): the ray traverses the skeleton sk (build.cl
 * build_skeleton: levels 1 .. m - 2, each group decoded inside its parent's decoded box, the
 * root's the patch box) nearest first, and at a node of level m - 2, a block of 4 x 4 leaves:
 *   a ray that does not leave the patch makes its 16 leaf boxes, four 2 x 2 blocks by
 *   block_leaf_boxes (what build_leaves stores: the same bits), and tests them as the tree's
 *   leaves are (slab4, leaf_box); of equal entries the larger micro-quad wins (hit_nearer);
 *   a ray that leaves it (`leaving`: the origin-patch rule, bl_pair) makes the block's 25
 *   vertices, patch_vertex_x8 at the grid's parameters (what dice stores: the same bits), and
 *   tests the 16 micro-quads' triangles (quad_triangles) in Morton order.
 * Every skeleton box holds its tree box, which holds its leaves, its leaves' tight boxes and
 * so its triangles, so every leaf or triangle the tree's traversal could reach within tmax
 * is reached here too, and of equal distances the larger prim wins (hit_nearer) whatever the
 * order: the same hit as through the tree. A shadow ray stops after the first block with a
 * hit. Returns the micro-quads tested. */
inline uint bl_skeleton(const bl_ray *r, uint m, uint patch, __global const ts_tight4 *sk,
                        const bl_leaf_src *src, uint shadow, uint leaving, ts_hit *best)
{
    const ts_tex_ctx no_tex = {0, 0, 0}; /* skeletons are not texture-displaced */
    uint L = m - TS_SKELETON_DROP, tests = 0u, sp = 0u;
    float h = ldexp(1.0f, -(int)m), s = ldexp(1.0f, -2 * (int)m);
    /* the noise's octaves, for the leaf boxes of a noise-displaced patch only */
    float freq[TS_DISP_MAX_OCTAVES], weight[TS_DISP_MAX_OCTAVES];
    uint octaves = !leaving && displace_is_noise(src->a) ? displace_octaves(src->a) : 0u;
    if (octaves) displace_octave_steps(src->a, octaves, octaves, freq, weight);
    float vlo[4 * TS_DISP_MAX_OCTAVES], vhi[4 * TS_DISP_MAX_OCTAVES];
    noise_tasks tasks;
    tasks.n = 0u;
    uint node[BL_STACK];
    float node_t[BL_STACK];
    ts_box node_b[BL_STACK];
    node[0] = 0u, node_t[0] = 0.0f, node_b[0] = src->pbox, sp = 1u;
    while (sp > 0u) {
        --sp;
        if (node_t[sp] > best->t) continue;
        uint level = node[sp] >> 24, k = node[sp] & 0xffffffu;
        ts_box d = node_b[sp];
        if (level == L && leaving) { /* a block's vertices, as dice makes them, and triangles */
            uint side = 1u << TS_SKELETON_DROP, i0 = morton_i(k) * side, j0 = morton_j(k) * side;
            float4 v[BL_SKEL_VERTS];
            for (uint j = 0; j <= side; ++j)
                for (uint i = 0; i <= side; ++i) {
                    ts_vec4 p = patch_vertex_x8(src->cp, src->cp, src->cn, src->mn, src->a, src->ax,
                                                no_tex, quadtree_vertex_param(i0 + i, m),
                                                quadtree_vertex_param(j0 + j, m));
                    v[j * (side + 1u) + i] = (float4)(p.x, p.y, p.z, p.w);
                }
            for (uint q = 0; q < side * side; ++q) { /* Morton order, as the tree's blocks */
                uint i = morton_i(q), j = morton_j(q), at = j * (side + 1u) + i;
                quad_triangles(v[at], v[at + 1u], v[at + side + 1u], v[at + side + 2u], m, i0 + i,
                               j0 + j, r->o4, r->tmin, r->perm, &r->sh, best, patch);
            }
            tests += side * side;
            if (shadow && best->patch != TS_INVALID) break;
            continue;
        }
        if (level == L) { /* a block: its leaves, 2 x 2 at a time in Morton order */
            for (uint sb = 0; sb < (1u << (2u * TS_SKELETON_DROP)) / 4u; ++sb) {
                uint k1 = (k << (2u * TS_SKELETON_DROP)) + 4u * sb;
                block_box4 b = block_leaf_boxes(src->a, src->ax, src->cp, src->cp, src->cn, src->mn,
                                                src->e, s, h, morton_i(k1), morton_j(k1), src->pbox,
                                                freq, weight, octaves, &tasks, vlo, vhi);
                float4 raw, e4 = slab4(b.lx, b.ly, b.lz, b.hx, b.hy, b.hz, r->o4, r->inv, r->tmin,
                                       best->t, &raw);
                float e[4] = {e4.x, e4.y, e4.z, e4.w}, er[4] = {raw.x, raw.y, raw.z, raw.w};
                for (uint q = 0; q < 4u; ++q)
                    if (e[q] >= 0.0f && er[q] >= r->tmin) leaf_box(m, k1 + q, e[q], best, patch);
                tests += 4u;
            }
            if (shadow && best->patch != TS_INVALID) break;
            continue;
        }
        /* The children: group offset(level + 1) + k of the tree, entry - 1 of the skeleton. */
        __global const ts_tight4 *c = sk + quadtree_group_offset(level + 1u) + k - 1u;
        float4 lx, ly, lz, hx, hy, hz;
        tight4_decode(c, (float4)(d.lo_x), (float4)(d.lo_y), (float4)(d.lo_z), (float4)(d.hi_x),
                      (float4)(d.hi_y), (float4)(d.hi_z), (float4)(tight_step(d.lo_x, d.hi_x)),
                      (float4)(tight_step(d.lo_y, d.hi_y)), (float4)(tight_step(d.lo_z, d.hi_z)),
                      &lx, &ly, &lz, &hx, &hy, &hz);
        float4 raw, e4 = slab4(lx, ly, lz, hx, hy, hz, r->o4, r->inv, r->tmin, best->t, &raw);
        float e[4] = {e4.x, e4.y, e4.z, e4.w};
        float bl[24];
        block_spill((block_box4){lx, ly, lz, hx, hy, hz}, bl);
        /* the children entered, farthest pushed first so that the nearest is popped next */
        float tc[4];
        uint id[4], nc = children_far_first(e, tc, id);
        for (uint j = 0; j < nc; ++j) {
            uint q = id[j];
            node[sp] = ((level + 1u) << 24) | (4u * k + q), node_t[sp] = tc[j];
            node_b[sp] = block_box(bl + q);
            ++sp;
        }
    }
    return tests;
}
#endif

/* The arguments of both bottom_level kernels, which the host binds alike (trace.c). */
#define BL_KERNEL_ARGS                                                                             \
    __global const ts_pair *pairs, uint pair_first, uint pair_count,                               \
        __global const ts_segment *segments, uint seg_first, uint seg_count, uint n_per_ray,       \
        __global const uint *window_first, uint active_count, uint exact, uint leaf_b,             \
        __global const uint *active, __global const ts_vec4 *org, __global const ts_vec4 *dir,     \
        __global const ts_hit *hit, __global const uint *ray_flags, __global const uint *ray_from, \
        __global const ts_vec4 *grid, __global const ts_box4 *groups,                              \
        __global const ts_tight4 *codes, __global const uint *instance,                            \
        __global const ts_xform *inst_xform, __global ts_hit *pair_hit,                            \
        __global uint *utilisation, uint group_base, __global const ts_tight4 *skel,               \
        __global const uint *skel_first, __global const ts_vec4 *cp,                               \
        __global const ts_vec4 *corner_n, __global const ts_vec4 *mid_n,                           \
        __global const ts_patch_attr *attr, __global const ts_xform *xform,                        \
        __global const ts_vec4 *flatness, __global const ts_box *patch_box

__kernel __attribute__((reqd_work_group_size(BL_WG, 1, 1))) void bottom_level_trace(BL_KERNEL_ARGS)
{
    uint gid = get_global_id(0), tests = 0;
#ifdef TS_PREFETCH_AT /* the rays of the pairs ahead (lib/prefetch.h) */
    if (n_per_ray != 0u && gid + 2u * TS_PREFETCH_AHEAD < pair_count)
        TS_PREFETCH_AT(active +
                       pairs[pair_first + gid + 2u * TS_PREFETCH_AHEAD].window / n_per_ray);
    if (gid + TS_PREFETCH_AHEAD < pair_count) {
        uint ahead = active[window_owner(pairs[pair_first + gid + TS_PREFETCH_AHEAD].window,
                                         n_per_ray, window_first, active_count)];
        TS_PREFETCH_AT(org + ahead), TS_PREFETCH_AT(dir + ahead), TS_PREFETCH_AT(hit + ahead);
        TS_PREFETCH_AT(ray_flags + ahead), TS_PREFETCH_AT(ray_from + ahead);
    }
#endif
    if (gid < pair_count) {
        bl_ray r;
        bl_patch pt;
        ts_hit best;
        uint window, ex = exact, shadow;
        if (bl_pair(gid, pairs, pair_first, segments, seg_first, seg_count, n_per_ray, window_first,
                    active_count, active, org, dir, hit, ray_flags, ray_from, grid, groups, codes,
                    instance, inst_xform, &r, &pt, &best, &window, &ex, &shadow)) {
#ifdef TS_CPU_LANES
            if (pt.skeleton) {
                bl_leaf_src src;
                src.a = attr + pt.shape, src.ax = xform + src.a->xform;
                src.cp = cp + (size_t)pt.shape * 16u, src.cn = corner_n + (size_t)pt.shape * 4u;
                src.mn = mid_n + (size_t)pt.shape * 5u, src.e = flatness[pt.shape];
                src.pbox = patch_box[pt.shape];
                tests += bl_skeleton(&r, pt.m, pt.patch, skel + skel_first[pt.shape], &src, shadow,
                                     ex, &best);
            } else
#endif
            {
                uint b = min(leaf_b, pt.m), L = pt.m - b, nq = 1u << (2u * b);
                bl_trav s;
                bl_trav_start(&s, &r, &pt, best.t, L);
                float te, raw;
                for (int k; (k = bl_next_block(&s, &r, &pt, L, best.t, &te, &raw)) >= 0;) {
                    /* A shadow ray needs any hit, not the closest: done after the first block
                     * that has one (resolve retires it at its first hit). */
                    if (shadow && best.patch != TS_INVALID) break;
                    if (!ex && b == 0u) { /* the block is one leaf box, already tested */
                        if (raw >= r.tmin) leaf_box(pt.m, (uint)k, te, &best, pt.patch);
                        ++tests;
                        continue;
                    }
                    for (uint q = 0; q < nq; ++q, ++tests)
                        quad_test(&r, &pt, ((uint)k << (2u * b)) + q, ex, &best);
                }
            }
        }
        if (best.patch == TS_INVALID) best.t = TS_NO_HIT;
        pair_hit[window] = best;
    }
    /* Utilisation of a work-group in lockstep: its tests over (size x the longest loop), in
     * the work-group's own two words (the host multiplies the longest loop by the size).
     * Global atomics, no barrier: with a barrier PoCL splits the kernel into two work-item
     * loops and keeps every work-item's private state apart; bottom_level took 8-12% longer
     * on the demo (issue 13). The two words are touched by this work-group only, so the
     * atomics find their cache line uncontended. */
    if (tests > 0u) {
        __global uint *u = utilisation + 2u * (group_base + (uint)get_group_id(0));
        atomic_add(&u[0], tests);
        atomic_max(&u[1], tests);
    }
}

__kernel __attribute__((reqd_work_group_size(BL_WG, 1, 1))) void bottom_level_group(BL_KERNEL_ARGS)
{
    /* The owners' rays and blocks, and one result slot per task (PantaRay Fig. 8). */
    __local float4 l_o4[BL_WG], l_inv[BL_WG], l_shear[BL_WG];
    __local uint4 l_meta[BL_WG]; /* m | moving << 8 | exact << 9 | trimmed << 10 | b << 16, patch,
                                    vert, group */
    __local uint l_block[BL_WG], l_perm[BL_WG], l_first[BL_WG + 1];
    __local uint l_prim[BL_WG]; /* the owner's best micro-quad so far, TS_INVALID if none */
    __local ts_hit l_res[BL_WG * BL_MAX_BLOCK];
    uint lid = get_local_id(0), gid = get_global_id(0);
    bl_ray r;
    bl_patch pt;
    ts_hit best;
    bl_trav s;
    uint window = 0, b = 0, L = 0, done = 1, count = 0, useful = 0, slots = 0, ex = exact,
         shadow = 0;
    if (gid < pair_count) {
        done =
            !bl_pair(gid, pairs, pair_first, segments, seg_first, seg_count, n_per_ray,
                     window_first, active_count, active, org, dir, hit, ray_flags, ray_from, grid,
                     groups, codes, instance, inst_xform, &r, &pt, &best, &window, &ex, &shadow);
        b = min(leaf_b, pt.m), L = pt.m - b;
        if (!done) bl_trav_start(&s, &r, &pt, best.t, L);
    }
    for (;;) {
        /* 1. Each work-item advances to its next block and posts its micro-quads. */
        float te, raw; /* (the group kernel re-tests single leaf boxes in its tasks) */
        /* A shadow ray stops at its first block with a hit, as in bottom_level_trace. */
        if (shadow && best.patch != TS_INVALID) done = 1;
        int k = done ? -1 : bl_next_block(&s, &r, &pt, L, best.t, &te, &raw);
        if (k < 0) done = 1;
        count = done ? 0u : 1u << (2u * b);
        if (!done) {
            l_o4[lid] = (float4)(r.o4.x, r.o4.y, r.o4.z, r.tmin);
            l_inv[lid] = r.inv;
            l_shear[lid] = (float4)(r.sh.sx, r.sh.sy, r.sh.sz, best.t);
            l_perm[lid] = (uint)r.sh.kx | ((uint)r.sh.ky << 2) | ((uint)r.sh.kz << 4);
            l_meta[lid] =
                (uint4)(pt.m | ((pt.g1 != 0) << 8) | (ex << 9) | (pt.trimmed << 10) | (b << 16),
                        pt.patch, (uint)(pt.g0 - (__global const float4 *)grid),
                        (uint)(pt.t0 - groups));
            l_block[lid] = (uint)k;
            l_prim[lid] = best.patch != TS_INVALID ? best.prim : TS_INVALID;
        }
        l_first[lid + 1u] = count;
        barrier(CLK_LOCAL_MEM_FENCE);
        /* 2. Exclusive scan of the task counts (one work-item: 64 additions). */
        if (lid == 0u) {
            l_first[0] = 0u;
            for (uint i = 1u; i <= BL_WG; ++i)
                l_first[i] += l_first[i - 1u];
        }
        barrier(CLK_LOCAL_MEM_FENCE);
        uint total = l_first[BL_WG];
        if (total == 0u) break; /* the same for every work-item */
        /* 3. Every work-item runs tasks: the owner's ray comes through local memory. */
        for (uint j = lid; j < total; j += BL_WG) {
            uint lo = 0u, hi = BL_WG;
            while (hi - lo > 1u) { /* the owner: the last with l_first <= j */
                uint mid = (lo + hi) / 2u;
                if (l_first[mid] <= j)
                    lo = mid;
                else
                    hi = mid;
            }
            uint4 meta = l_meta[lo];
            bl_ray tr;
            tr.o4 = (float4)(l_o4[lo].xyz, 0.0f);
            tr.tmin = l_o4[lo].w;
            tr.inv = l_inv[lo];
            uint pm = l_perm[lo];
            tr.sh.kx = (int)(pm & 3u), tr.sh.ky = (int)((pm >> 2) & 3u),
            tr.sh.kz = (int)((pm >> 4) & 3u);
            tr.sh.sx = l_shear[lo].x, tr.sh.sy = l_shear[lo].y, tr.sh.sz = l_shear[lo].z;
            tr.perm = (uint4)(tr.sh.kx, tr.sh.ky, tr.sh.kz, 3u);
            bl_patch tp;
            tp.m = meta.x & 0xffu, tp.patch = meta.y, tp.trimmed = (meta.x >> 10) & 1u;
            tp.g0 = (__global const float4 *)grid + meta.z;
            tp.g1 = (meta.x >> 8) & 1u ? tp.g0 + quadtree_vertex_count(tp.m) : 0;
            tp.t0 = groups + meta.w;
            tp.t1 = (meta.x >> 8) & 1u ? tp.t0 + quadtree_group_count(tp.m) : 0;
            uint tb = meta.x >> 16;
            /* From the owner's best so far, so that a leaf box as near as it with a larger
             * micro-quad wins (hit_nearer); a task that finds nothing better returns it. */
            uint bp = l_prim[lo];
            ts_hit h = {l_shear[lo].w, 0.0f, 0.0f, bp == TS_INVALID ? TS_INVALID : meta.y, bp};
            quad_test(&tr, &tp, (l_block[lo] << (2u * tb)) + (j - l_first[lo]), (meta.x >> 9) & 1u,
                      &h);
            l_res[j] = h;
        }
        barrier(CLK_LOCAL_MEM_FENCE);
        /* 4. Each owner folds its results in order: of equal distances the larger prim wins
         * (hit_nearer), so the order does not matter. */
        for (uint j = l_first[lid]; j < l_first[lid] + count; ++j)
            if (l_res[j].patch != TS_INVALID && hit_nearer(l_res[j].t, l_res[j].prim, &best))
                best = l_res[j];
        useful += total, slots += (total + BL_WG - 1u) / BL_WG * BL_WG;
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (gid < pair_count) {
        if (best.patch == TS_INVALID) best.t = TS_NO_HIT;
        pair_hit[window] = best;
    }
    if (lid == 0u && slots > 0u) { /* the work-group's own two words (see above) */
        __global uint *u = utilisation + 2u * (group_base + (uint)get_group_id(0));
        u[0] = useful, u[1] = slots / BL_WG;
    }
}
