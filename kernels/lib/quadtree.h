/* quadtree.h — indexing of the implicit complete quad-tree over a diced patch
 * (Hanika §3.2.1). Levels 0..m are stored one after another; level l holds 4^l nodes in
 * Morton (Z) order, so the children of node k of level l are 4k..4k+3 of level l+1 and the
 * leaves (level m) are the 4^m micro-quads. Total nodes: (4^(m+1) - 1) / 3. */
#ifndef TS_QUADTREE_H
#define TS_QUADTREE_H

#include "lib/shared_types.h"

/* Index of the first node of level l. */
TS_INLINE ts_u32 quadtree_level_offset(ts_u32 l)
{
    return ((1u << (2u * l)) - 1u) / 3u;
}

TS_INLINE ts_u32 quadtree_node_count(ts_u32 m)
{
    return quadtree_level_offset(m + 1u);
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

/* Micro-quad column i (u) and row j (v) of Morton index k. */
TS_INLINE ts_u32 morton_i(ts_u32 k) { return morton_compact(k); }
TS_INLINE ts_u32 morton_j(ts_u32 k) { return morton_compact(k >> 1); }

#endif
