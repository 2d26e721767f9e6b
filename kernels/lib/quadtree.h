/* quadtree.h — indexing of the implicit complete quad-tree over a diced patch
 * (Hanika §3.2.1). Level l holds 4^l nodes in Morton (Z) order, so the children of node k
 * of level l are 4k..4k+3 of level l+1 and the leaves (level m) are the 4^m micro-quads.
 * Storage is by sibling group (ts_box4, SoA): group 0 holds the root in lane 0 (lanes 1-3
 * empty); level l >= 1 holds its 4^(l-1) groups from quadtree_group_offset(l), node k in
 * group k / 4, lane k % 4. So the children of node k of level l are exactly group
 * quadtree_group_offset(l + 1) + k: one load for four boxes. */
#ifndef TS_QUADTREE_H
#define TS_QUADTREE_H

#include "lib/shared_types.h"

/* Index of the first node of level l. */
TS_INLINE ts_u32 quadtree_level_offset(ts_u32 l)
{
    return ((1u << (2u * l)) - 1u) / 3u;
}

/* First sibling group of level l (l >= 1); level 0 is group 0. */
TS_INLINE ts_u32 quadtree_group_offset(ts_u32 l)
{
    return l == 0u ? 0u : 1u + quadtree_level_offset(l - 1u);
}

/* Sibling groups of a tree of depth m: the root's group plus levels 1..m. */
TS_INLINE ts_u32 quadtree_group_count(ts_u32 m)
{
    return 1u + quadtree_level_offset(m);
}

/* The box of node k of level l. */
TS_INLINE ts_box quadtree_box(TS_CONST_GLOBAL ts_box4 *groups, ts_u32 l, ts_u32 k)
{
    TS_CONST_GLOBAL ts_box4 *g = groups + (l == 0u ? 0u : quadtree_group_offset(l) + (k >> 2));
    ts_u32 q = l == 0u ? 0u : (k & 3u);
    ts_box b = {g->lo_x[q], g->lo_y[q], g->lo_z[q], g->hi_x[q], g->hi_y[q], g->hi_z[q]};
    return b;
}

/* How many of levels 1 and 2 of a tree of depth m, traced in blocks of 2^b x 2^b
 * micro-quads, top_level may cull by (TS_CULL_GROUPS): bottom_level tests a level's boxes
 * on every path to a leaf only down to the block level m - b (below it, a block's
 * micro-quads are intersected without their ancestors' boxes). */
TS_INLINE ts_u32 quadtree_cull_levels(ts_u32 m, ts_u32 b)
{
    ts_u32 blocks = m - (b < m ? b : m);
    return blocks < 2u ? blocks : 2u;
}

/* Grid vertices of a patch diced at m: (2^m + 1)^2. */
TS_INLINE ts_u32 quadtree_vertex_count(ts_u32 m)
{
    ts_u32 n = (1u << m) + 1u;
    return n * n;
}

/* Keeps the even bits of x, packed: Morton decode of one coordinate. */
TS_INLINE ts_u32 morton_compact(ts_u32 x)
{
    x &= 0x55555555u;
    x = (x ^ (x >> 1)) & 0x33333333u;
    x = (x ^ (x >> 2)) & 0x0f0f0f0fu;
    x = (x ^ (x >> 4)) & 0x00ff00ffu;
    x = (x ^ (x >> 8)) & 0x0000ffffu;
    return x;
}

/* The parameter of micro-quad column (or row) i's centre at LOD m: the (u, v) bottom_level
 * gives every leaf-box hit. */
TS_INLINE float quadtree_centre(ts_u32 i, ts_u32 m)
{
    return ((float)i + 0.5f) * ldexp(1.0f, -(int)m);
}

/* Whether leaf k of a tree of depth m has an empty box (lo > hi): a micro-quad a trim curve
 * removed (build.cl, lib/trim.h). */
TS_INLINE int quadtree_leaf_empty(TS_CONST_GLOBAL ts_box4 *groups, ts_u32 m, ts_u32 k)
{
    ts_u32 at = m == 0u ? 0u : quadtree_group_offset(m) + (k >> 2), q = m == 0u ? 0u : (k & 3u);
    return groups[at].lo_x[q] > groups[at].hi_x[q];
}

/* The parameter of vertex column (or row) i of a patch diced at LOD m, i 2^-m exactly: where
 * dice evaluates its vertices and every reference and shading normal evaluates them again;
 * one expression, so they agree to the bit (shade reads a resident grid's vertices or
 * evaluates them, lib/patch.h patch_quad_shading_normal). */
TS_INLINE float quadtree_vertex_param(ts_u32 i, ts_u32 m)
{
    return ldexp((float)i, -(int)m);
}

/* Triangle mode's stitching across levels of detail: the vertex (i, j) of a patch diced at m
 * whose edge k borders a patch diced e_k levels coarser (edges: e_k in bits 4k..4k+3) is
 * moved to the vertex of the coarser grid at or before it along that edge, index rounded
 * down to a multiple of 2^e_k. The edge's vertices are then the coarser patch's own, each
 * repeated (the triangles between two copies have no area), so the two patches' triangles
 * meet on the same edges with the same vertex bits and the watertight test leaves no crack
 * between them. Corners stay where they are; edges = 0 changes nothing. */
TS_INLINE void quadtree_stitch(ts_u32 edges, ts_u32 m, ts_u32 *i, ts_u32 *j)
{
    ts_u32 n = 1u << m, e;
    if (edges == 0u) return;
    if (*j == 0u && (e = edges & 15u) != 0u) *i &= ~((1u << e) - 1u);
    if (*j == n && (e = (edges >> 12) & 15u) != 0u) *i &= ~((1u << e) - 1u);
    if (*i == 0u && (e = (edges >> 4) & 15u) != 0u) *j &= ~((1u << e) - 1u);
    if (*i == n && (e = (edges >> 8) & 15u) != 0u) *j &= ~((1u << e) - 1u);
}

/* The parameters of the four corners of micro-quad (i, j) of a patch diced at m, where dice
 * puts them: corner c (at (i + (c & 1), j + (c >> 1))) in pu[c], pv[c], moved by
 * quadtree_stitch (edges 0: the grid's own parameters). */
TS_INLINE void quadtree_quad_corners(ts_u32 edges, ts_u32 m, ts_u32 i, ts_u32 j, float pu[4],
                                     float pv[4])
{
    for (ts_u32 c = 0; c < 4u; ++c) {
        ts_u32 ci = i + (c & 1u), cj = j + (c >> 1);
        quadtree_stitch(edges, m, &ci, &cj);
        pu[c] = quadtree_vertex_param(ci, m), pv[c] = quadtree_vertex_param(cj, m);
    }
}

/* The smallest box holding boxes a and b. */
TS_INLINE ts_box box_union(ts_box a, ts_box b)
{
    ts_box r = {fmin(a.lo_x, b.lo_x), fmin(a.lo_y, b.lo_y), fmin(a.lo_z, b.lo_z),
                fmax(a.hi_x, b.hi_x), fmax(a.hi_y, b.hi_y), fmax(a.hi_z, b.hi_z)};
    return r;
}

/* The largest |coordinate| of box b: the scale of the few ulps a leaf box is grown by. */
TS_INLINE float box_magnitude(ts_box b)
{
    return fmax(fmax(fabs(b.lo_x), fabs(b.hi_x)),
                fmax(fmax(fabs(b.lo_y), fabs(b.hi_y)), fmax(fabs(b.lo_z), fabs(b.hi_z))));
}

/* The box of micro-quad (i, j)'s four diced vertices in grid g (rows of n), grown by a few
 * ulps of its largest coordinate: the leaf box of triangle mode (`--intersect triangles`,
 * build.cl and host/ref/dice_build_ref.c), where the geometry is the micro-quad's two
 * triangles, which lie in it; a box-mode leaf must bound every finer dicing's surface
 * instead (Hanika §3.3). */
TS_INLINE_ALWAYS ts_box tight_leaf_box(TS_CONST_GLOBAL ts_vec4 *g, ts_u32 n, ts_u32 i, ts_u32 j)
{
    TS_CONST_GLOBAL ts_vec4 *r0 = g + j * n + i, *r1 = r0 + n;
    ts_vec4 p[4] = {r0[0], r0[1], r1[0], r1[1]};
    ts_box b = {p[0].x, p[0].y, p[0].z, p[0].x, p[0].y, p[0].z};
    for (int c = 1; c < 4; ++c) {
        b.lo_x = fmin(b.lo_x, p[c].x), b.lo_y = fmin(b.lo_y, p[c].y), b.lo_z = fmin(b.lo_z, p[c].z);
        b.hi_x = fmax(b.hi_x, p[c].x), b.hi_y = fmax(b.hi_y, p[c].y), b.hi_z = fmax(b.hi_z, p[c].z);
    }
    float e = 4e-7f * box_magnitude(b);
    b.lo_x -= e, b.lo_y -= e, b.lo_z -= e, b.hi_x += e, b.hi_y += e, b.hi_z += e;
    return b;
}

/* The step of a node box's tight codes along one axis: its extent over 255 (ts_box4). */
TS_INLINE float tight_step(float lo, float hi)
{
    return (hi - lo) * (1.0f / 255.0f);
}

/* The code of a face that lies d inside the node box's face (scale = 1 / step, 0 for an
 * empty or flat box): floor(d / step) less one, within [0, 255], a step short of the face so
 * that decoding's rounding cannot cross it (tight_code_lo and _hi check, and fall back to 0,
 * the node box's own face). */
TS_INLINE ts_u32 tight_guess(float d, float scale)
{
    float g = floor(d * scale) - 1.0f;
    return g >= 255.0f ? 255u : g > 0.0f ? (ts_u32)g : 0u;
}

/* A tight lower face t as a code: lo + c * step <= t, so decoded it holds what t held. */
TS_INLINE ts_u32 tight_code_lo(float lo, float step, float scale, float t)
{
    ts_u32 c = tight_guess(t - lo, scale);
    return lo + (float)c * step <= t ? c : 0u;
}

/* A tight upper face t as a code: hi - c * step >= t. */
TS_INLINE ts_u32 tight_code_hi(float hi, float step, float scale, float t)
{
    ts_u32 c = tight_guess(hi - t, scale);
    return hi - (float)c * step >= t ? c : 0u;
}

/* 1 / step, or 0 for an empty or flat box (step <= 0). */
TS_INLINE float tight_scale(float step)
{
    return step > 0.0f ? 1.0f / step : 0.0f;
}

/* Box t, which lies in box b, as the codes of lane q of c: each face of t a whole number of
 * b's steps inside b's face, rounded outwards (tight_code_lo, _hi), so that decoding relative
 * to b gives a box that holds t. The tight codes of a tree node (quadtree_store) and the
 * culling copies inside the patch box (build.cl cull_encode). */
TS_INLINE_ALWAYS void tight_store_lane(TS_GLOBAL ts_tight4 *c, ts_u32 q, ts_box b, ts_box t)
{
    float sx = tight_step(b.lo_x, b.hi_x), sy = tight_step(b.lo_y, b.hi_y),
          sz = tight_step(b.lo_z, b.hi_z);
    float rx = tight_scale(sx), ry = tight_scale(sy), rz = tight_scale(sz);
    c->lo_x[q] = (ts_u8)tight_code_lo(b.lo_x, sx, rx, t.lo_x);
    c->lo_y[q] = (ts_u8)tight_code_lo(b.lo_y, sy, ry, t.lo_y);
    c->lo_z[q] = (ts_u8)tight_code_lo(b.lo_z, sz, rz, t.lo_z);
    c->hi_x[q] = (ts_u8)tight_code_hi(b.hi_x, sx, rx, t.hi_x);
    c->hi_y[q] = (ts_u8)tight_code_hi(b.hi_y, sy, ry, t.hi_y);
    c->hi_z[q] = (ts_u8)tight_code_hi(b.hi_z, sz, rz, t.hi_z);
}

/* Stores box b as node k of level l of the tree at groups, and t (the box of the node's diced
 * vertices) as its tight codes at codes (the same index), or codes 0 (the box itself) unless
 * coded: build.cl and host/ref/dice_build_ref.c. The root group's lanes 1-3 are empty
 * (lo > hi, never hit; codes 0). Each lane writes only its own bytes, so the four siblings'
 * work-items do not race. */
TS_INLINE_ALWAYS void quadtree_store(TS_GLOBAL ts_box4 *groups, TS_GLOBAL ts_tight4 *codes,
                                     ts_u32 l, ts_u32 k, ts_box b, ts_box t, ts_u32 coded)
{
    ts_u32 at = l == 0u ? 0u : quadtree_group_offset(l) + (k >> 2), q = l == 0u ? 0u : (k & 3u);
    TS_GLOBAL ts_box4 *g = groups + at;
    TS_GLOBAL ts_tight4 *c = codes + at;
    g->lo_x[q] = b.lo_x, g->lo_y[q] = b.lo_y, g->lo_z[q] = b.lo_z;
    g->hi_x[q] = b.hi_x, g->hi_y[q] = b.hi_y, g->hi_z[q] = b.hi_z;
    if (coded) {
        tight_store_lane(c, q, b, t);
    } else {
        c->lo_x[q] = c->lo_y[q] = c->lo_z[q] = 0;
        c->hi_x[q] = c->hi_y[q] = c->hi_z[q] = 0;
    }
    if (l == 0u) {
        for (ts_u32 e = 1u; e < 4u; ++e) {
            g->lo_x[e] = g->lo_y[e] = g->lo_z[e] = 1e30f;
            g->hi_x[e] = g->hi_y[e] = g->hi_z[e] = -1e30f;
            c->lo_x[e] = c->lo_y[e] = c->lo_z[e] = 0;
            c->hi_x[e] = c->hi_y[e] = c->hi_z[e] = 0;
        }
    }
}

/* The tight box of lane q of sibling group g, its codes c, decoded (bottom_level.cl
 * group_boxes does the same arithmetic in float4 lanes): it holds the node's diced vertices
 * and lies in the node's box. */
TS_INLINE ts_box box4_tight_lane(TS_CONST_GLOBAL ts_box4 *g, TS_CONST_GLOBAL ts_tight4 *c, ts_u32 q)
{
    float sx = tight_step(g->lo_x[q], g->hi_x[q]), sy = tight_step(g->lo_y[q], g->hi_y[q]),
          sz = tight_step(g->lo_z[q], g->hi_z[q]);
    ts_box b = {g->lo_x[q] + (float)c->lo_x[q] * sx, g->lo_y[q] + (float)c->lo_y[q] * sy,
                g->lo_z[q] + (float)c->lo_z[q] * sz, g->hi_x[q] - (float)c->hi_x[q] * sx,
                g->hi_y[q] - (float)c->hi_y[q] * sy, g->hi_z[q] - (float)c->hi_z[q] * sz};
    return b;
}

#ifdef __OPENCL_C_VERSION__
/* The four tight boxes of codes c in float4 lanes, decoded inside the base boxes b (lower
 * planes) to e (upper planes) of steps s: box4_tight_lane's arithmetic lane by lane. The node
 * boxes of a sibling group (bottom_level.cl group_tight_boxes) and the culling copies, four
 * inside one patch box (top_level.cl cull4_hits). */
inline void tight4_decode(__global const ts_tight4 *c, float4 bx, float4 by, float4 bz, float4 ex,
                          float4 ey, float4 ez, float4 sx, float4 sy, float4 sz, float4 *lx,
                          float4 *ly, float4 *lz, float4 *hx, float4 *hy, float4 *hz)
{
    *lx = bx + convert_float4(vload4(0, c->lo_x)) * sx;
    *ly = by + convert_float4(vload4(0, c->lo_y)) * sy;
    *lz = bz + convert_float4(vload4(0, c->lo_z)) * sz;
    *hx = ex - convert_float4(vload4(0, c->hi_x)) * sx;
    *hy = ey - convert_float4(vload4(0, c->hi_y)) * sy;
    *hz = ez - convert_float4(vload4(0, c->hi_z)) * sz;
}
#endif

/* The tight box of node k of level l. */
TS_INLINE ts_box quadtree_tight_box(TS_CONST_GLOBAL ts_box4 *groups,
                                    TS_CONST_GLOBAL ts_tight4 *codes, ts_u32 l, ts_u32 k)
{
    ts_u32 at = l == 0u ? 0u : quadtree_group_offset(l) + (k >> 2);
    return box4_tight_lane(groups + at, codes + at, l == 0u ? 0u : (k & 3u));
}

/* The union of the tight boxes of node k of level l's four children: its own tight box
 * (build.cl build_level, host/ref/dice_build_ref.c). */
TS_INLINE ts_box quadtree_tight_union(TS_CONST_GLOBAL ts_box4 *groups,
                                      TS_CONST_GLOBAL ts_tight4 *codes, ts_u32 l, ts_u32 k)
{
    ts_box t = quadtree_tight_box(groups, codes, l + 1u, 4u * k);
    for (ts_u32 q = 1u; q < 4u; ++q) {
        ts_box u = quadtree_tight_box(groups, codes, l + 1u, 4u * k + q);
        t.lo_x = fmin(t.lo_x, u.lo_x), t.lo_y = fmin(t.lo_y, u.lo_y), t.lo_z = fmin(t.lo_z, u.lo_z);
        t.hi_x = fmax(t.hi_x, u.hi_x), t.hi_y = fmax(t.hi_y, u.hi_y), t.hi_z = fmax(t.hi_z, u.hi_z);
    }
    return t;
}

/* Micro-quad column i (u) and row j (v) of Morton index k. */
TS_INLINE ts_u32 morton_i(ts_u32 k)
{
    return morton_compact(k);
}
TS_INLINE ts_u32 morton_j(ts_u32 k)
{
    return morton_compact(k >> 1);
}

#endif
