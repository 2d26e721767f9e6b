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

/* The parameter of vertex column (or row) i of a patch diced at LOD m, i 2^-m exactly: where
 * dice evaluates its vertices and every reference and shading normal evaluates them again;
 * one expression, so they agree to the bit (shade reads a resident grid's vertices or
 * evaluates them, lib/patch.h patch_quad_shading_normal). */
TS_INLINE float quadtree_vertex_param(ts_u32 i, ts_u32 m)
{
    return ldexp((float)i, -(int)m);
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
TS_INLINE ts_box tight_leaf_box(TS_CONST_GLOBAL ts_vec4 *g, ts_u32 n, ts_u32 i, ts_u32 j)
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
