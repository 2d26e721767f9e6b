/* texture.h — image textures for displacement and colour (DESIGN.md §2, docs/rendering.md),
 * shared by the dice, build and shade kernels and the host (patch boxes, references).
 *
 * Texture coordinates (s, t) wrap (repeat) with period 1 in both directions. A lookup is
 * bilinear at level 0 between the four texels around (s W - 1/2, t H - 1/2) (texel centres
 * at (i + 1/2) / W). Displacement textures (TS_TEX_MINMAX) carry a min-max pyramid:
 * tex_range bounds every bilinear lookup over an st rectangle by the minimum and maximum
 * of a few texels of the level whose texels are about as large as the rectangle — a convex
 * combination never leaves the range of the texels it mixes.
 * Texels live in tiles of a pool reached through a page table (shared_types.h ts_texture),
 * so the host may keep only some tiles on the device; a lookup of a tile that is not
 * resident returns NaN (never read out of bounds). */
#ifndef TS_TEXTURE_H
#define TS_TEXTURE_H

#include "lib/noise.h" /* ts_interval */
#include "lib/shared_types.h"

/* Where the textures live: descriptors, page table, tile pool. */
typedef struct ts_tex_ctx {
    TS_CONST_GLOBAL ts_texture *tex;
    TS_CONST_GLOBAL ts_u32 *pages;
    TS_CONST_GLOBAL ts_vec4 *pool;
} ts_tex_ctx;

/* ceil(n / 2^k) for n >= 1: the size of level k. */
TS_INLINE ts_u32 tex_dim(ts_u32 n, ts_u32 k)
{
    return ((n - 1u) >> k) + 1u;
}

/* Tiles along x of level k. */
TS_INLINE ts_u32 tex_tiles_x(TS_CONST_GLOBAL ts_texture *t, ts_u32 k)
{
    return (tex_dim(t->width, k) + TS_TEX_TILE - 1u) >> TS_TEX_TILE_LOG2;
}

/* The page-table entry of texel (x, y) of level k (in range). */
TS_INLINE ts_u32 tex_page(TS_CONST_GLOBAL ts_texture *t, ts_u32 k, ts_u32 x, ts_u32 y)
{
    return t->level_page[k] + (y >> TS_TEX_TILE_LOG2) * tex_tiles_x(t, k) + (x >> TS_TEX_TILE_LOG2);
}

/* Texel (x, y) of level k (in range); NaN when its tile is not resident. */
TS_INLINE ts_vec4 tex_texel(ts_tex_ctx c, TS_CONST_GLOBAL ts_texture *t, ts_u32 k, ts_u32 x,
                            ts_u32 y)
{
    ts_u32 slot = c.pages[tex_page(t, k, x, y)];
    if (slot == TS_INVALID) {
        ts_vec4 nan4 = {NAN, NAN, NAN, NAN};
        return nan4;
    }
    const ts_u32 mask = TS_TEX_TILE - 1u;
    return c.pool[slot * (TS_TEX_TILE * TS_TEX_TILE) + (y & mask) * TS_TEX_TILE + (x & mask)];
}

/* i mod n in [0, n). */
TS_INLINE ts_u32 tex_wrap(ts_i32 i, ts_u32 n)
{
    ts_i32 r = i % (ts_i32)n;
    return (ts_u32)(r < 0 ? r + (ts_i32)n : r);
}

/* Beyond this |s| or |t| the fractional part has too few bits to address texels: lookups
 * read (0, 0) and tex_range answers the whole texture. */
#define TS_TEX_COORD_MAX 4194304.0f

/* s in [0, 1): its fractional part (0 for NaN or huge values). */
TS_INLINE float tex_frac(float s)
{
    if (!(fabs(s) < TS_TEX_COORD_MAX)) return 0.0f;
    return s - floor(s);
}

/* The bilinear lookup at level 0 of texture id at (s, t). */
TS_INLINE ts_vec4 tex_bilinear(ts_tex_ctx c, ts_u32 id, float s, float t)
{
    TS_CONST_GLOBAL ts_texture *tx = c.tex + id;
    float x = tex_frac(s) * (float)tx->width - 0.5f, y = tex_frac(t) * (float)tx->height - 0.5f;
    float x0 = floor(x), y0 = floor(y), fx = x - x0, fy = y - y0;
    ts_u32 i0 = tex_wrap((ts_i32)x0, tx->width), i1 = tex_wrap((ts_i32)x0 + 1, tx->width);
    ts_u32 j0 = tex_wrap((ts_i32)y0, tx->height), j1 = tex_wrap((ts_i32)y0 + 1, tx->height);
    ts_vec4 a = tex_texel(c, tx, 0u, i0, j0), b = tex_texel(c, tx, 0u, i1, j0);
    ts_vec4 d = tex_texel(c, tx, 0u, i0, j1), e = tex_texel(c, tx, 0u, i1, j1);
    float w00 = (1.0f - fx) * (1.0f - fy), w10 = fx * (1.0f - fy), w01 = (1.0f - fx) * fy,
          w11 = fx * fy;
    ts_vec4 r = {w00 * a.x + w10 * b.x + w01 * d.x + w11 * e.x,
                 w00 * a.y + w10 * b.y + w01 * d.y + w11 * e.y,
                 w00 * a.z + w10 * b.z + w01 * d.z + w11 * e.z,
                 w00 * a.w + w10 * b.w + w01 * d.w + w11 * e.w};
    return r;
}

/* Texture coordinates at (u, v) of a patch: the bilinear interpolation of its corner st. */
TS_INLINE void tex_patch_st(TS_CONST_GLOBAL ts_patch_attr *a, float u, float v, float *s, float *t)
{
    float w00 = (1.0f - u) * (1.0f - v), w10 = u * (1.0f - v), w01 = (1.0f - u) * v, w11 = u * v;
    *s = w00 * a->st[0] + w10 * a->st[2] + w01 * a->st[4] + w11 * a->st[6];
    *t = w00 * a->st[1] + w10 * a->st[3] + w01 * a->st[5] + w11 * a->st[7];
}

/* Whether a cut-out patch (TS_PATCH_CUTOUT) is there at (u, v): its mask (texture color_tex
 * at the point's st, bilinear at level 0: the alpha, or with TS_PATCH_CUTOUT_RED the first
 * channel) is at least 0.5. 1 for a patch without a cutout. build_leaves asks it at each
 * micro-quad's centre. */
TS_INLINE int tex_cutout_keeps(TS_CONST_GLOBAL ts_patch_attr *a, ts_tex_ctx tex, float u, float v)
{
    if (!(a->flags & TS_PATCH_CUTOUT)) return 1;
    float s, t;
    tex_patch_st(a, u, v, &s, &t);
    ts_vec4 c = tex_bilinear(tex, a->color_tex, s, t);
    return ((a->flags & TS_PATCH_CUTOUT_RED) ? c.x : c.w) >= 0.5f;
}

/* The surface colour at (u, v): Cs, times the colour texture at the point's st when the
 * patch has one (TS_PATCH_COLOR_TEX). */
TS_INLINE void tex_surface_colour(TS_CONST_GLOBAL ts_patch_attr *a, ts_tex_ctx tex, float u,
                                  float v, float cs[3])
{
    cs[0] = a->cs_r, cs[1] = a->cs_g, cs[2] = a->cs_b;
    if (!(a->flags & TS_PATCH_COLOR_TEX)) return;
    float s, t;
    tex_patch_st(a, u, v, &s, &t);
    ts_vec4 c = tex_bilinear(tex, a->color_tex, s, t);
    cs[0] *= c.x, cs[1] *= c.y, cs[2] *= c.z;
}

/* The level-0 texels a bilinear lookup at any s in [lo, hi] reads, along one axis of n
 * texels: [*a, *b] before wrapping; 0 when that covers the whole axis. The margin (in
 * texels) covers the rounding of st between the corners that bound it and the points
 * dice evaluates (tex_patch_st, tex_frac, the products with n). */
TS_INLINE int tex_span(float lo, float hi, ts_u32 n, ts_i32 *a, ts_i32 *b)
{
    if (!(hi - lo < 1.0f) || !(fabs(lo) < TS_TEX_COORD_MAX) || !(fabs(hi) < TS_TEX_COORD_MAX))
        return 0;
    float base = floor(lo), fn = (float)n;
    float margin = 1e-3f + 4e-6f * fn * (fmax(fabs(lo), fabs(hi)) + 1.0f);
    *a = (ts_i32)floor((lo - base) * fn - 0.5f - margin);
    *b = (ts_i32)floor((hi - base) * fn - 0.5f + margin) + 1;
    return *b - *a + 1 < (ts_i32)n;
}

/* Level-k texel ranges covering level-0 span [a, b] of an axis of n texels (wrapped):
 * one or two ranges [r[0], r[1]], [r[2], r[3]]; returns how many. whole: every texel. */
TS_INLINE int tex_level_ranges(int whole, ts_i32 a, ts_i32 b, ts_u32 n, ts_u32 k, ts_u32 r[4])
{
    if (whole) {
        r[0] = 0u, r[1] = tex_dim(n, k) - 1u;
        return 1;
    }
    ts_u32 aw = tex_wrap(a, n), len = (ts_u32)(b - a);
    if (aw + len < n) {
        r[0] = aw >> k, r[1] = (aw + len) >> k;
        return 1;
    }
    r[0] = aw >> k, r[1] = (n - 1u) >> k;
    r[2] = 0u, r[3] = (aw + len - n) >> k;
    return 2;
}

/* An interval holding the first channel of tex_bilinear(id, s, t) for every (s, t) in
 * [s0, s1] x [t0, t1], from the min-max level whose texels are at least as large as the
 * rectangle's level-0 span (at most 4 x 4 texels read). Rounded outwards. */
TS_INLINE ts_interval tex_range(ts_tex_ctx c, ts_u32 id, float s0, float t0, float s1, float t1)
{
    TS_CONST_GLOBAL ts_texture *tx = c.tex + id;
    ts_i32 ax = 0, bx = 0, ay = 0, by = 0;
    int part_x = tex_span(s0, s1, tx->width, &ax, &bx);
    int part_y = tex_span(t0, t1, tx->height, &ay, &by);
    /* The finest level at which each partial span covers at most 2 texels per wrapped
     * range and each whole axis at most 4 texels. */
    ts_u32 k = 0u, top = tx->levels - 1u;
    while (k < top &&
           ((part_x && (ts_u32)(bx - ax) >= (1u << k)) ||
            (part_y && (ts_u32)(by - ay) >= (1u << k)) || (!part_x && tex_dim(tx->width, k) > 4u) ||
            (!part_y && tex_dim(tx->height, k) > 4u)))
        ++k;
    ts_u32 rx[4], ry[4];
    int nx = tex_level_ranges(!part_x, ax, bx, tx->width, k, rx);
    int ny = tex_level_ranges(!part_y, ay, by, tx->height, k, ry);
    ts_interval r = {INFINITY, -INFINITY};
    int missing = 0;
    for (int q = 0; q < ny; ++q)
        for (ts_u32 y = ry[2 * q]; y <= ry[2 * q + 1]; ++y)
            for (int p = 0; p < nx; ++p)
                for (ts_u32 x = rx[2 * p]; x <= rx[2 * p + 1]; ++x) {
                    ts_vec4 v = tex_texel(c, tx, k, x, y);
                    r.lo = fmin(r.lo, v.x), r.hi = fmax(r.hi, v.y);
                    missing |= !(v.x == v.x) || !(v.y == v.y); /* not resident */
                }
    if (missing) r.lo = r.hi = NAN;
    /* The bilinear weights sum to 1 up to rounding: a few ulps of the largest texel. */
    float slack = 4e-7f * fmax(fabs(r.lo), fabs(r.hi));
    r.lo -= slack, r.hi += slack;
    return r;
}

#endif
