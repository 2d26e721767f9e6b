/* texture.c — image textures into the scene (scene.h, lib/texture.h): read through
 * OpenImageIO (image.h), converted to float texels, the min-max pyramid of displacement
 * textures built, every level cut into TS_TEX_TILE x TS_TEX_TILE tiles appended to the
 * scene's tile pool. */
#include "image/image.h"
#include "scene/scene.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

ts_tex_ctx scene_tex_ctx(const ts_scene *s)
{
    ts_tex_ctx c = {s->textures, s->tex_pages, s->tex_pool};
    return c;
}

ts_interval scene_texture_range(const ts_scene *s, uint32_t index)
{
    const ts_texture *t = &s->textures[index];
    ts_vec4 v = tex_texel(scene_tex_ctx(s), t, t->levels - 1u, 0u, 0u);
    ts_interval r = {v.x, v.y};
    return r;
}

/* Level k + 1 of a min-max pyramid from level k (w x h): each texel the min of its up to
 * 2 x 2 children's minima (x) and the max of their maxima (y). */
static void texture_reduce(const ts_vec4 *src, uint32_t w, uint32_t h, ts_vec4 *dst)
{
    uint32_t w2 = (w + 1u) / 2u, h2 = (h + 1u) / 2u;
    for (uint32_t y = 0; y < h2; y++)
        for (uint32_t x = 0; x < w2; x++) {
            ts_vec4 r = src[(size_t)(2u * y) * w + 2u * x];
            for (uint32_t c = 1; c < 4; c++) {
                uint32_t cx = 2u * x + (c & 1u), cy = 2u * y + (c >> 1);
                if (cx >= w || cy >= h) continue;
                ts_vec4 q = src[(size_t)cy * w + cx];
                r.x = fminf(r.x, q.x), r.y = fmaxf(r.y, q.y);
            }
            dst[(size_t)y * w2 + x] = r;
        }
}

/* Appends level (w x h texels) to the pool as tiles, row-major; zero beyond its edge. */
static void texture_tile(ts_scene *s, const ts_vec4 *level, uint32_t w, uint32_t h)
{
    uint32_t tx = (w + TS_TEX_TILE - 1u) / TS_TEX_TILE, ty = (h + TS_TEX_TILE - 1u) / TS_TEX_TILE;
    for (uint32_t j = 0; j < ty; j++)
        for (uint32_t i = 0; i < tx; i++) {
            uint32_t slot = s->tex_tile_count++;
            ts_vec4 *tile = s->tex_pool + (size_t)slot * TS_TEX_TILE * TS_TEX_TILE;
            memset(tile, 0, (size_t)TS_TEX_TILE * TS_TEX_TILE * sizeof *tile);
            for (uint32_t y = 0; y < TS_TEX_TILE && j * TS_TEX_TILE + y < h; y++)
                for (uint32_t x = 0; x < TS_TEX_TILE && i * TS_TEX_TILE + x < w; x++)
                    tile[y * TS_TEX_TILE + x] =
                        level[(size_t)(j * TS_TEX_TILE + y) * w + i * TS_TEX_TILE + x];
            s->tex_pages[slot] = slot;
        }
}

/* Grows the per-texture arrays by one and the pool by `tiles` tiles. */
static int texture_reserve(ts_scene *s, uint32_t tiles, const char *path, ts_error *err)
{
    uint32_t n = s->texture_count;
    ts_texture *t = realloc(s->textures, (n + 1u) * sizeof *t);
    if (t) s->textures = t;
    char **src = t ? realloc(s->tex_source, (n + 1u) * sizeof *src) : NULL;
    if (src) s->tex_source = src;
    size_t total = (size_t)s->tex_tile_count + tiles;
    ts_vec4 *pool = src && total <= UINT32_MAX / (TS_TEX_TILE * TS_TEX_TILE)
                        ? realloc(s->tex_pool, total * TS_TEX_TILE * TS_TEX_TILE * sizeof *pool)
                        : NULL;
    if (pool) s->tex_pool = pool;
    uint32_t *pages = pool ? realloc(s->tex_pages, total * sizeof *pages) : NULL;
    if (pages) s->tex_pages = pages;
    if (!pages) return ts_error_set(err, TS_E_MEMORY, "%s: out of memory for the texture", path);
    return TS_OK;
}

int scene_add_texture(ts_scene *s, const char *path, uint32_t kind, uint32_t *index, ts_error *err)
{
    for (uint32_t i = 0; i < s->texture_count; i++)
        if (s->textures[i].kind == kind && strcmp(s->tex_source[i], path) == 0) {
            *index = i;
            return TS_OK;
        }
    ts_image img;
    if (image_read(path, &img, err)) return err->code;
    uint32_t w = (uint32_t)img.width, h = (uint32_t)img.height, ch = (uint32_t)img.channels;
    if (w < 1u || h < 1u || w > (1u << (TS_TEX_MAX_LEVELS - 1u)) ||
        h > (1u << (TS_TEX_MAX_LEVELS - 1u))) {
        image_free(&img);
        return ts_error_set(err, TS_E_IO, "%s: texture of %u x %u texels (1 to %u a side)", path, w,
                            h, 1u << (TS_TEX_MAX_LEVELS - 1u));
    }
    ts_texture t = {.width = w, .height = h, .levels = 1u, .kind = kind};
    if (kind == TS_TEX_MINMAX)
        while (tex_dim(w, t.levels - 1u) > 1u || tex_dim(h, t.levels - 1u) > 1u)
            t.levels++;
    uint32_t tiles = 0;
    for (uint32_t k = 0; k < t.levels; k++) {
        t.level_page[k] = s->tex_tile_count + tiles;
        tiles += ((tex_dim(w, k) + TS_TEX_TILE - 1u) / TS_TEX_TILE) *
                 ((tex_dim(h, k) + TS_TEX_TILE - 1u) / TS_TEX_TILE);
    }
    char *source = malloc(strlen(path) + 1);
    ts_vec4 *cur = malloc((size_t)w * h * sizeof *cur),
            *next = malloc((size_t)w * h * sizeof *next);
    int rc = source && cur && next
                 ? texture_reserve(s, tiles, path, err)
                 : ts_error_set(err, TS_E_MEMORY, "%s: out of memory for the texture", path);
    for (size_t i = 0; rc == TS_OK && i < (size_t)w * h; i++) {
        const float *px = img.pixels + i * ch;
        /* grey, grey and alpha, RGB, RGBA: the alpha a cutout reads (tex_cutout_keeps) */
        float r = px[0], g = ch >= 3 ? px[1] : r, b = ch >= 3 ? px[2] : r;
        float alpha = ch == 2 ? px[1] : ch >= 4 ? px[3] : 1.0f;
        if (!(fabsf(r) <= 3.0e38f && fabsf(g) <= 3.0e38f && fabsf(b) <= 3.0e38f &&
              fabsf(alpha) <= 3.0e38f))
            rc = ts_error_set(err, TS_E_IO, "%s: texel (%zu, %zu) is not a finite number", path,
                              i % w, i / w);
        cur[i] = kind == TS_TEX_MINMAX ? (ts_vec4){r, r, 0.0f, 0.0f} : (ts_vec4){r, g, b, alpha};
    }
    image_free(&img);
    if (rc == TS_OK) {
        uint32_t lw = w, lh = h;
        for (uint32_t k = 0; k < t.levels; k++) {
            texture_tile(s, cur, lw, lh);
            if (k + 1u == t.levels) break;
            texture_reduce(cur, lw, lh, next);
            ts_vec4 *swap = cur;
            cur = next, next = swap;
            lw = (lw + 1u) / 2u, lh = (lh + 1u) / 2u;
        }
        strcpy(source, path);
        s->tex_source[s->texture_count] = source;
        s->textures[s->texture_count] = t;
        *index = s->texture_count++;
        source = NULL;
    }
    free(source), free(cur), free(next);
    return rc;
}
