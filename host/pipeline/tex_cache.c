/* tex_cache.c — the device's texture tile pool (tex_cache.h). */
#include "pipeline/tex_cache.h"

#include <stdlib.h>
#include <string.h>

#define TILE_TEXELS (TS_TEX_TILE * TS_TEX_TILE)
#define TILE_BYTES ((size_t)TILE_TEXELS * sizeof(ts_vec4))

static void mark_page(ts_tex_cache *c, uint32_t page)
{
    if (c->page_mark[page] == c->request) return;
    c->page_mark[page] = c->request;
    c->marked++;
}

/* Marks the tiles of levels 0..last of texture id holding the texels tex_range or a
 * bilinear lookup reads for any (s, t) in [s0, s1] x [t0, t1] (one texel of padding on
 * each side over tex_span's, for the rounding of st at the points inside). */
static void mark_rect(ts_tex_cache *c, const ts_scene *s, uint32_t id, float s0, float t0, float s1,
                      float t1, uint32_t last, uint32_t *count)
{
    const ts_texture *t = &s->textures[id];
    ts_i32 ax = 0, bx = 0, ay = 0, by = 0;
    int part_x = tex_span(s0, s1, t->width, &ax, &bx);
    int part_y = tex_span(t0, t1, t->height, &ay, &by);
    if (part_x) ax -= 1, bx += 1, part_x = bx - ax + 1 < (ts_i32)t->width;
    if (part_y) ay -= 1, by += 1, part_y = by - ay + 1 < (ts_i32)t->height;
    if (last > t->levels - 1u) last = t->levels - 1u;
    for (uint32_t k = 0; k <= last; k++) {
        ts_u32 rx[4], ry[4];
        int nx = tex_level_ranges(!part_x, ax, bx, t->width, k, rx);
        int ny = tex_level_ranges(!part_y, ay, by, t->height, k, ry);
        uint32_t tiles_x = tex_tiles_x(t, k);
        for (int q = 0; q < ny; q++)
            for (uint32_t ty = ry[2 * q] >> TS_TEX_TILE_LOG2;
                 ty <= ry[2 * q + 1] >> TS_TEX_TILE_LOG2; ty++)
                for (int r = 0; r < nx; r++)
                    for (uint32_t tx = rx[2 * r] >> TS_TEX_TILE_LOG2;
                         tx <= rx[2 * r + 1] >> TS_TEX_TILE_LOG2; tx++)
                        if (count)
                            ++*count; /* counting only: an upper bound (no deduplication) */
                        else
                            mark_page(c, t->level_page[k] + ty * tiles_x + tx);
    }
}

/* The box of the st of parameter square [u0, u1] x [v0, v1] (its corners: st is bilinear). */
static void st_box(const ts_patch_attr *a, float u0, float v0, float u1, float v1, float lo[2],
                   float hi[2])
{
    float uv[4][2] = {{u0, v0}, {u1, v0}, {u0, v1}, {u1, v1}};
    lo[0] = lo[1] = INFINITY, hi[0] = hi[1] = -INFINITY;
    for (int k = 0; k < 4; k++) {
        float st[2];
        tex_patch_st(a, uv[k][0], uv[k][1], &st[0], &st[1]);
        for (int d = 0; d < 2; d++)
            lo[d] = fminf(lo[d], st[d]), hi[d] = fmaxf(hi[d], st[d]);
    }
}

void tex_cache_begin(ts_tex_cache *c)
{
    c->request++;
    c->marked = 0;
}

void tex_cache_mark_patch(ts_tex_cache *c, const ts_scene *s, uint32_t p)
{
    const ts_patch_attr *a = &s->attr[p];
    uint32_t colour = a->flags & (TS_PATCH_COLOR_TEX | TS_PATCH_CUTOUT); /* build reads a mask */
    if (a->disp_kind != TS_DISP_TEXTURE && !colour) return;
    float lo[2], hi[2];
    st_box(a, 0.0f, 0.0f, 1.0f, 1.0f, lo, hi);
    if (a->disp_kind == TS_DISP_TEXTURE)
        mark_rect(c, s, a->disp_tex, lo[0], lo[1], hi[0], hi[1], TS_TEX_MAX_LEVELS, NULL);
    if (colour) mark_rect(c, s, a->color_tex, lo[0], lo[1], hi[0], hi[1], 0u, NULL);
}

uint32_t tex_cache_mark_hit(ts_tex_cache *c, const ts_scene *s, uint32_t p, float u0, float v0,
                            float u1, float v1, int count_only)
{
    const ts_patch_attr *a = &s->attr[p];
    uint32_t n = 0;
    if (a->disp_kind != TS_DISP_TEXTURE && !(a->flags & TS_PATCH_COLOR_TEX)) return 0;
    float lo[2], hi[2];
    st_box(a, u0, v0, u1, v1, lo, hi);
    if (a->disp_kind == TS_DISP_TEXTURE)
        mark_rect(c, s, a->disp_tex, lo[0], lo[1], hi[0], hi[1], 0u, count_only ? &n : NULL);
    if (a->flags & TS_PATCH_COLOR_TEX)
        mark_rect(c, s, a->color_tex, lo[0], lo[1], hi[0], hi[1], 0u, count_only ? &n : NULL);
    return n;
}

int tex_cache_create(ts_tex_cache *c, const ts_scene *s, uint64_t pool_bytes, ts_error *err)
{
    memset(c, 0, sizeof *c);
    c->pages = s->tex_tile_count;
    size_t np = c->pages ? c->pages : 1, npatch = s->patch_count ? s->patch_count : 1;
    c->page_mark = calloc(np, sizeof *c->page_mark);
    c->patch_tiles = calloc(npatch, sizeof *c->patch_tiles);
    if (!c->page_mark || !c->patch_tiles)
        return ts_error_set(err, TS_E_MEMORY, "out of memory for the texture cache");
    for (uint32_t p = 0; p < s->patch_count && c->pages; p++) {
        tex_cache_begin(c);
        tex_cache_mark_patch(c, s, p);
        c->patch_tiles[p] = c->marked;
        if (c->marked > c->max_patch_tiles) c->max_patch_tiles = c->marked;
    }
    uint64_t budget = pool_bytes / TILE_BYTES;
    c->slots = pool_bytes == 0 || budget >= c->pages ? c->pages : (uint32_t)budget;
    /* One patch always fits, with room for the rounding of a hit's st box (tex_cache.h). */
    if (c->slots < c->max_patch_tiles + TS_TEX_CACHE_SLACK)
        c->slots = c->max_patch_tiles + TS_TEX_CACHE_SLACK;
    if (c->slots > c->pages) c->slots = c->pages;
    c->paged = c->slots < c->pages;
    size_t ns = c->slots ? c->slots : 1;
    c->page_slot = malloc(np * sizeof *c->page_slot);
    c->slot_page = malloc(ns * sizeof *c->slot_page);
    c->slot_stamp = calloc(ns, sizeof *c->slot_stamp);
    if (!c->page_slot || !c->slot_page || !c->slot_stamp)
        return ts_error_set(err, TS_E_MEMORY, "out of memory for the texture cache");
    for (uint32_t i = 0; i < np; i++)
        c->page_slot[i] = c->paged || i >= c->pages ? TS_INVALID : i;
    for (uint32_t i = 0; i < ns; i++)
        c->slot_page[i] = c->paged || i >= c->pages ? TS_INVALID : i;
    return TS_OK;
}

void tex_cache_free(ts_tex_cache *c)
{
    free(c->page_slot), free(c->slot_page), free(c->slot_stamp), free(c->page_mark);
    free(c->patch_tiles);
    memset(c, 0, sizeof *c);
}

int tex_cache_upload_initial(ts_tex_cache *c, ts_device *cl, cl_mem pool, cl_mem page_table,
                             const ts_scene *s, ts_stats *stats, ts_error *err)
{
    stats->counters[TS_COUNTER_texture_pool_tiles] = c->slots;
    stats->counters[TS_COUNTER_texture_tiles] = c->pages;
    if (c->pages == 0) return TS_OK;
    if (!c->paged) {
        if (dev_write(cl, pool, 0, (size_t)c->pages * TILE_BYTES, s->tex_pool, "the texture tiles",
                      err))
            return err->code;
        stats->counters[TS_COUNTER_texture_tiles_uploaded] += c->pages;
        stats->counters[TS_COUNTER_texture_bytes_uploaded] += (uint64_t)c->pages * TILE_BYTES;
    }
    return dev_write(cl, page_table, 0, (size_t)c->pages * sizeof(uint32_t), c->page_slot,
                     "the texture page table", err);
}

int tex_cache_commit(ts_tex_cache *c, ts_device *cl, cl_mem pool, cl_mem page_table,
                     const ts_scene *s, ts_stats *stats, ts_error *err)
{
    if (!c->paged || c->marked == 0) return TS_OK;
    if (c->marked > c->slots)
        return ts_error_set(err, TS_E_INTERNAL, "texture request of %u tiles for a pool of %u",
                            c->marked, c->slots);
    /* Marked pages already resident stay; their slots are this request's. */
    for (uint32_t i = 0; i < c->slots; i++)
        if (c->slot_page[i] != TS_INVALID && c->page_mark[c->slot_page[i]] == c->request)
            c->slot_stamp[i] = c->request;
    int moved = 0;
    uint32_t hand = 0;
    for (uint32_t page = 0; page < c->pages; page++) {
        if (c->page_mark[page] != c->request || c->page_slot[page] != TS_INVALID) continue;
        /* A free slot, else the least recently used slot this request does not need. */
        uint32_t best = TS_INVALID;
        for (uint32_t k = 0; k < c->slots; k++) {
            uint32_t i = (hand + k) % c->slots;
            if (c->slot_stamp[i] == c->request) continue;
            if (c->slot_page[i] == TS_INVALID) {
                best = i;
                break;
            }
            if (best == TS_INVALID || c->slot_stamp[i] < c->slot_stamp[best]) best = i;
        }
        if (best == TS_INVALID)
            return ts_error_set(err, TS_E_INTERNAL, "texture pool: no slot left");
        hand = best + 1;
        if (c->slot_page[best] != TS_INVALID) c->page_slot[c->slot_page[best]] = TS_INVALID;
        c->slot_page[best] = page;
        c->slot_stamp[best] = c->request;
        c->page_slot[page] = best;
        if (dev_write(cl, pool, (size_t)best * TILE_BYTES, TILE_BYTES,
                      s->tex_pool + (size_t)page * TILE_TEXELS, "a texture tile", err))
            return err->code;
        stats->counters[TS_COUNTER_texture_tiles_uploaded] += 1;
        stats->counters[TS_COUNTER_texture_bytes_uploaded] += TILE_BYTES;
        moved = 1;
    }
    if (!moved) return TS_OK;
    return dev_write(cl, page_table, 0, (size_t)c->pages * sizeof(uint32_t), c->page_slot,
                     "the texture page table", err);
}
