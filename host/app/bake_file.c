/* bake_file.c — the bake's EXR (bake_file.h, docs/bake.md): the tile layout, the image that
 * collects the waves' results, its metadata and --resume. */
#include "app/bake_file.h"
#include "base/hash.h"
#include "image/image.h"
#include "lib/sh.h"
#include "lib/texture.h"
#include "scene/trim.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The side of the largest image the layout makes. */
#define TS_BAKE_MAX_SIDE 65536u
/* Patch indices are stored in a float channel: exact up to 2^24. */
#define TS_BAKE_MAX_PATCHES (1u << 24)

/* Integer metadata keys, in the order --resume checks them. */
#define META_POINTS "tessera:bake_points"
#define META_DONE "tessera:bake_done"
#define META_BANDS "tessera:bake_bands"
#define META_RAYS "tessera:bake_rays"
#define META_COSINE "tessera:bake_cosine"
#define META_SPHERE "tessera:bake_sphere"
#define META_FRONT "tessera:bake_front"
#define META_SEED "tessera:seed"
#define META_JOB "tessera:job"
#define META_LOD "tessera:lod"
#define META_GEOMETRY "tessera:geometry"
#define META_PATCHES "tessera:bake_patches"
#define META_MAX_LOD "tessera:max_lod"

/* What the file says about its convention and layout, for people (docs/bake.md). */
static const char *const convention_text =
    "c_lm = integral over the sphere of V(w) Y_lm(w) dw, times max(0, N.w) when "
    "tessera:bake_cosine = 1; V = 1 where a ray from P escapes, 0 where it is blocked or w is "
    "below the surface (N.w <= 0); real spherical harmonics without the Condon-Shortley phase, "
    "Y_00 = 1/(2 sqrt(pi)), polar axis +z (world space), channel shK holds coefficient K = "
    "l*l + l + m";
static const char *const layout_text =
    "one tile per patch: point (i, j) of the patch diced at m, at (u, v) = (i, j) / 2^m, in "
    "pixel (x0 + i, y0 + j) of its (2^m+1) x (2^m+1) tile; channels patch, u, v name each "
    "pixel's point; every channel of a pixel that is no point is NaN, and sh, P, N of points "
    "not baked yet (tessera:bake_done < tessera:bake_points)";

static const char *const fixed_names[TS_BAKE_CH_FIXED] = {"patch", "u",   "v",   "P.x", "P.y",
                                                          "P.z",   "N.x", "N.y", "N.z"};
static const char *const sh_names[TS_SH_MAX_COEFFS] = {
    "sh0", "sh1", "sh2",  "sh3",  "sh4",  "sh5",  "sh6",  "sh7",
    "sh8", "sh9", "sh10", "sh11", "sh12", "sh13", "sh14", "sh15"};

void bake_layout_free(ts_bake_layout *l)
{
    free(l->lod), free(l->point_first), free(l->tile_x), free(l->tile_y);
    memset(l, 0, sizeof *l);
}

/* The tiles' places: by decreasing m (then patch index), in shelves of l->width. */
static void layout_pack(ts_bake_layout *l)
{
    uint32_t x = 0, y = 0, shelf = 0;
    for (int m = TS_LOD_LIMIT; m >= 0; --m)
        for (uint32_t p = 0; p < l->patch_count; ++p) {
            if (l->lod[p] != (uint32_t)m) continue;
            uint32_t s = (1u << m) + 1u;
            if (x + s > l->width) y += shelf, x = 0, shelf = 0;
            if (shelf == 0) shelf = s;
            l->tile_x[p] = x, l->tile_y[p] = y;
            x += s;
        }
    l->height = y + shelf;
}

int bake_layout_make(const uint32_t *lod, uint32_t n, ts_bake_layout *l, ts_error *err)
{
    memset(l, 0, sizeof *l);
    if (n == 0) return ts_error_set(err, TS_E_USAGE, "the scene has no patches to bake");
    if (n > TS_BAKE_MAX_PATCHES)
        return ts_error_set(err, TS_E_USAGE, "%u patches: a bake names at most %u", n,
                            TS_BAKE_MAX_PATCHES);
    l->patch_count = n;
    l->lod = malloc(n * sizeof *l->lod);
    l->point_first = malloc((n + 1) * sizeof *l->point_first);
    l->tile_x = malloc(n * sizeof *l->tile_x);
    l->tile_y = malloc(n * sizeof *l->tile_y);
    if (!l->lod || !l->point_first || !l->tile_x || !l->tile_y) {
        bake_layout_free(l);
        return ts_error_set(err, TS_E_MEMORY, "out of memory (bake layout)");
    }
    uint64_t total = 0;
    uint32_t largest = 1;
    for (uint32_t p = 0; p < n; ++p) {
        uint32_t s = (1u << lod[p]) + 1u;
        l->lod[p] = lod[p];
        l->point_first[p] = (uint32_t)total;
        total += (uint64_t)s * s;
        largest = s > largest ? s : largest;
        if (total >= ((uint64_t)1 << 32)) {
            bake_layout_free(l);
            return ts_error_set(err, TS_E_USAGE,
                                "the bake would have 2^32 points or more; lower --lod, --max-lod "
                                "or --res");
        }
    }
    l->point_first[n] = (uint32_t)total;
    uint32_t side = (uint32_t)ceil(sqrt((double)total));
    l->width = 1;
    while (l->width < largest || l->width < side)
        l->width <<= 1;
    layout_pack(l);
    if (l->width > TS_BAKE_MAX_SIDE || l->height > TS_BAKE_MAX_SIDE) {
        bake_layout_free(l);
        return ts_error_set(err, TS_E_USAGE,
                            "the bake's image would exceed %u pixels a side; lower --lod, "
                            "--max-lod or --res",
                            TS_BAKE_MAX_SIDE);
    }
    return TS_OK;
}

size_t bake_layout_pixel(const ts_bake_layout *l, uint32_t p, uint32_t k)
{
    uint32_t n = (1u << l->lod[p]) + 1u;
    return (size_t)(l->tile_y[p] + k / n) * l->width + l->tile_x[p] + k % n;
}

void bake_image_free(ts_bake_image *img)
{
    bake_layout_free(&img->layout);
    free(img->pixels);
    memset(img, 0, sizeof *img);
}

int bake_image_create(ts_bake_image *img, const uint32_t *lod, uint32_t n, uint32_t bands,
                      ts_error *err)
{
    memset(img, 0, sizeof *img);
    if (bake_layout_make(lod, n, &img->layout, err)) return err->code;
    const ts_bake_layout *l = &img->layout;
    img->bands = bands;
    img->coeffs = bands * bands;
    img->channels = img->coeffs + TS_BAKE_CH_FIXED;
    size_t count = (size_t)l->width * l->height * img->channels;
    img->pixels = malloc(count * sizeof *img->pixels);
    if (!img->pixels) {
        bake_image_free(img);
        return ts_error_set(err, TS_E_MEMORY, "out of memory (a bake image of %ux%u)", l->width,
                            l->height);
    }
    for (size_t i = 0; i < count; ++i)
        img->pixels[i] = NAN;
    for (uint32_t p = 0; p < n; ++p) {
        uint32_t m = l->lod[p], s = (1u << m) + 1u;
        for (uint32_t k = 0; k < s * s; ++k) {
            float *px = &img->pixels[bake_layout_pixel(l, p, k) * img->channels + img->coeffs];
            px[TS_BAKE_CH_PATCH] = (float)p;
            px[TS_BAKE_CH_U] = ldexpf((float)(k % s), -(int)m);
            px[TS_BAKE_CH_V] = ldexpf((float)(k / s), -(int)m);
        }
    }
    return TS_OK;
}

void bake_image_store(ts_bake_image *img, uint32_t first, uint32_t count, const float *coeffs,
                      const ts_vec4 *pos, const ts_vec4 *normal)
{
    const ts_bake_layout *l = &img->layout;
    uint32_t lo = 0, hi = l->patch_count; /* the patch of point `first` */
    while (hi - lo > 1) {
        uint32_t mid = (lo + hi) / 2;
        if (l->point_first[mid] <= first)
            lo = mid;
        else
            hi = mid;
    }
    uint32_t p = lo, nc = img->coeffs;
    for (uint32_t i = 0; i < count; ++i) {
        uint32_t g = first + i;
        while (g >= l->point_first[p + 1])
            ++p;
        float *px = &img->pixels[bake_layout_pixel(l, p, g - l->point_first[p]) * img->channels];
        memcpy(px, &coeffs[(size_t)i * nc], nc * sizeof *px);
        px[nc + TS_BAKE_CH_PX] = pos[i].x, px[nc + TS_BAKE_CH_PY] = pos[i].y;
        px[nc + TS_BAKE_CH_PZ] = pos[i].z;
        px[nc + TS_BAKE_CH_NX] = normal[i].x, px[nc + TS_BAKE_CH_NY] = normal[i].y;
        px[nc + TS_BAKE_CH_NZ] = normal[i].z;
    }
}

/* The channel names of a bake with nc coefficients, into names[nc + TS_BAKE_CH_FIXED]. */
static void channel_names(uint32_t nc, const char **names)
{
    for (uint32_t c = 0; c < nc; ++c)
        names[c] = sh_names[c];
    for (uint32_t c = 0; c < TS_BAKE_CH_FIXED; ++c)
        names[nc + c] = fixed_names[c];
}

int bake_image_write(const ts_bake_image *img, const char *path, const ts_bake_meta *m,
                     ts_error *err)
{
    const char *names[TS_SH_MAX_COEFFS + TS_BAKE_CH_FIXED];
    channel_names(img->coeffs, names);
    ts_image out = {.width = (int)img->layout.width,
                    .height = (int)img->layout.height,
                    .channels = (int)img->channels,
                    .channel_names = names,
                    .pixels = img->pixels};
    const ts_image_meta meta[] = {
        {META_POINTS, (int)m->points},
        {META_DONE, (int)m->done},
        {META_BANDS, m->bands},
        {META_RAYS, m->rays},
        {META_COSINE, !!(m->flags & TS_BAKE_COSINE)},
        {META_SPHERE, !!(m->flags & TS_BAKE_SPHERE)},
        {META_FRONT, !!(m->flags & TS_BAKE_FRONT)},
        {META_SEED, m->seed},
        {META_JOB, m->job},
        {META_LOD, m->lod},
        {META_GEOMETRY, m->geometry},
        {META_PATCHES, (int)m->patches},
        {META_MAX_LOD, m->max_lod},
    };
    const ts_image_text text[] = {{"tessera:sh_convention", convention_text},
                                  {"tessera:bake_layout", layout_text}};
    return image_write_exr_text(path, &out, meta, (int)(sizeof meta / sizeof *meta), text,
                                (int)(sizeof text / sizeof *text), err);
}

/* Reads the integer metadata of a bake; fails naming the first item missing. */
static int read_meta(const char *path, ts_bake_meta *m, ts_error *err)
{
    const struct {
        const char *key;
        int32_t *dst;
    } items[] = {
        {META_POINTS, (int32_t *)&m->points},
        {META_DONE, (int32_t *)&m->done},
        {META_BANDS, &m->bands},
        {META_RAYS, &m->rays},
        {META_SEED, &m->seed},
        {META_JOB, &m->job},
        {META_LOD, &m->lod},
        {META_GEOMETRY, &m->geometry},
        {META_PATCHES, (int32_t *)&m->patches},
        {META_MAX_LOD, &m->max_lod},
    };
    const char *flag_keys[3] = {META_COSINE, META_SPHERE, META_FRONT};
    const int32_t flag_bits[3] = {TS_BAKE_COSINE, TS_BAKE_SPHERE, TS_BAKE_FRONT};
    ts_error e = {0};
    memset(m, 0, sizeof *m);
    for (size_t i = 0; i < sizeof items / sizeof *items; ++i) {
        int v;
        if (image_read_meta_int(path, items[i].key, &v, &e)) {
            ts_error_clear(&e);
            return ts_error_set(err, TS_E_USAGE,
                                "%s: not a bake of tessera bake: it has no \"%s\" metadata", path,
                                items[i].key);
        }
        *items[i].dst = v;
    }
    for (int i = 0; i < 3; ++i) {
        int v;
        if (image_read_meta_int(path, flag_keys[i], &v, &e)) {
            ts_error_clear(&e);
            return ts_error_set(err, TS_E_USAGE,
                                "%s: not a bake of tessera bake: it has no \"%s\" metadata", path,
                                flag_keys[i]);
        }
        if (v) m->flags |= flag_bits[i];
    }
    if (m->bands < 1 || m->bands > (int32_t)TS_SH_MAX_BANDS || m->done > m->points)
        return ts_error_set(err, TS_E_USAGE, "%s: its bake metadata is inconsistent", path);
    return TS_OK;
}

/* Positions of the bake's channels in img (nc coefficients, then the fixed ones), idx[]. */
static int find_channels(const char *path, const ts_image *img, uint32_t nc, int *idx,
                         ts_error *err)
{
    const char *names[TS_SH_MAX_COEFFS + TS_BAKE_CH_FIXED];
    channel_names(nc, names);
    for (uint32_t c = 0; c < nc + TS_BAKE_CH_FIXED; ++c) {
        idx[c] = -1;
        for (int k = 0; k < img->channels; ++k)
            if (strcmp(img->channel_names[k], names[c]) == 0) idx[c] = k;
        if (idx[c] < 0)
            return ts_error_set(err, TS_E_USAGE, "%s: a bake file needs a \"%s\" channel", path,
                                names[c]);
    }
    return TS_OK;
}

/* Reads path as an image with its metadata; TS_E_IO when it cannot be read. */
static int read_bake(const char *path, ts_image *img, ts_bake_meta *m, const char *advice,
                     ts_error *err)
{
    ts_error e = {0};
    if (image_read(path, img, &e)) {
        ts_error_set(err, TS_E_IO, "%s%s", e.msg, advice);
        ts_error_clear(&e);
        return err->code;
    }
    if (read_meta(path, m, err)) {
        image_free(img);
        return err->code;
    }
    return TS_OK;
}

int bake_image_resume(ts_bake_image *img, const char *path, const ts_bake_meta *want,
                      uint32_t *done, ts_error *err)
{
    ts_image in;
    ts_bake_meta m;
    if (read_bake(path, &in, &m, " (cannot resume from it; bake without --resume)", err))
        return err->code;
    const char *what = m.job != want->job       ? "another scene, camera or options"
                       : m.seed != want->seed   ? "another --seed"
                       : m.bands != want->bands ? "another --bands"
                       : m.lod != want->lod || m.points != want->points
                           ? "other levels of detail (--lod, --points, --max-lod, --memory)"
                           : NULL;
    int rc = TS_OK;
    if (what)
        rc = ts_error_set(err, TS_E_USAGE,
                          "%s: cannot resume: it was baked with %s (use the original command, "
                          "or bake without --resume)",
                          path, what);
    if (!rc && (in.width != (int)img->layout.width || in.height != (int)img->layout.height))
        rc = ts_error_set(err, TS_E_USAGE, "%s: cannot resume: it is %dx%d, this bake is %ux%u",
                          path, in.width, in.height, img->layout.width, img->layout.height);
    int idx[TS_SH_MAX_COEFFS + TS_BAKE_CH_FIXED];
    if (!rc) rc = find_channels(path, &in, img->coeffs, idx, err);
    const ts_bake_layout *l = &img->layout;
    for (uint32_t p = 0; !rc && p < l->patch_count; ++p)
        for (uint32_t k = 0; k < l->point_first[p + 1] - l->point_first[p]; ++k) {
            if (l->point_first[p] + k >= m.done) break;
            size_t px = bake_layout_pixel(l, p, k);
            const float *src = &in.pixels[px * (size_t)in.channels];
            float *dst = &img->pixels[px * img->channels];
            for (uint32_t c = 0; c < img->channels; ++c)
                dst[c] = src[idx[c]];
        }
    if (!rc) *done = m.done;
    image_free(&in);
    return rc;
}

int32_t bake_geometry_hash(const ts_scene *s)
{
    uint64_t h = TS_FNV1A_INIT;
    size_t n = s->patch_count;
    h = ts_fnv1a(h, &s->patch_count, sizeof s->patch_count);
    h = ts_fnv1a(h, s->cp, n * 16 * sizeof(ts_vec4));
    if (s->cp1) h = ts_fnv1a(h, s->cp1, n * 16 * sizeof(ts_vec4));
    if (s->corner_n) h = ts_fnv1a(h, s->corner_n, n * 4 * sizeof(ts_vec4));
    if (s->mid_n) h = ts_fnv1a(h, s->mid_n, n * 5 * sizeof(ts_vec4));
    for (size_t i = 0; i < n; ++i) {
        const ts_patch_attr *a = &s->attr[i];
        const ts_u32 u[] = {a->flags & TS_PATCH_MOVING, a->disp_kind, a->disp_octaves, a->xform,
                            a->disp_kind == TS_DISP_TEXTURE ? a->disp_tex : 0u};
        const float f[] = {a->disp_amplitude, a->disp_frequency, a->disp_lacunarity, a->disp_gain,
                           a->disp_offset};
        h = ts_fnv1a(h, u, sizeof u);
        h = ts_fnv1a(h, f, sizeof f);
        if (a->disp_kind == TS_DISP_TEXTURE) h = ts_fnv1a(h, a->st, sizeof a->st);
    }
    if (s->xform) h = ts_fnv1a(h, s->xform, (size_t)s->xform_count * sizeof(ts_xform));
    h = trim_hash(s, h);
    for (uint32_t t = 0; t < s->texture_count; ++t) { /* displacement textures' texels */
        const ts_texture *x = &s->textures[t];
        if (x->kind != TS_TEX_MINMAX) continue;
        h = ts_fnv1a(h, x, sizeof *x);
        for (uint32_t k = 0; k < x->levels; ++k) {
            uint32_t ty = (tex_dim(x->height, k) + TS_TEX_TILE - 1u) >> TS_TEX_TILE_LOG2;
            size_t tiles = (size_t)tex_tiles_x(x, k) * ty;
            h = ts_fnv1a(h, &s->tex_pool[(size_t)x->level_page[k] * TS_TEX_TILE * TS_TEX_TILE],
                         tiles * TS_TEX_TILE * TS_TEX_TILE * sizeof(ts_vec4));
        }
    }
    return (int32_t)(uint32_t)(h ^ (h >> 32));
}

/* The metadata of a bake for relighting scene s (scene_path): complete, of s's patches and
 * geometry. */
static int occlusion_check_meta(const char *path, const ts_bake_meta *m, const ts_scene *s,
                                const char *scene_path, ts_error *err)
{
    if (m->done < m->points)
        return ts_error_set(err, TS_E_USAGE,
                            "%s: an interrupted bake (%u of %u points baked): finish it with "
                            "tessera bake --resume before relighting with it",
                            path, m->done, m->points);
    if (m->patches != s->patch_count)
        return ts_error_set(err, TS_E_USAGE,
                            "%s: baked from a scene of %u patches, but %s has %u: bake this "
                            "scene for --occlusion",
                            path, m->patches, scene_path, s->patch_count);
    if (m->geometry != bake_geometry_hash(s))
        return ts_error_set(err, TS_E_USAGE,
                            "%s: baked from other geometry than %s (tessera:geometry differs: "
                            "patches, normals or displacement changed): bake this scene for "
                            "--occlusion",
                            path, scene_path);
    return TS_OK;
}

/* m with (2^m + 1)^2 = count, or -1. */
static int grid_lod(uint32_t count)
{
    for (int m = 0; m <= TS_LOD_LIMIT; ++m) {
        uint32_t n = (1u << m) + 1u;
        if (n * n == count) return m;
    }
    return -1;
}

/* Pass 1: each patch's m from its number of points (a pixel whose patch channel is NaN is no
 * point), and the patch table's first points. */
static int occlusion_count(const char *path, const ts_image *in, const int *idx, uint32_t nc,
                           const ts_bake_meta *m, ts_occlusion *o, ts_error *err)
{
    uint32_t *count = calloc(m->patches ? m->patches : 1, sizeof *count);
    if (!count) return ts_error_set(err, TS_E_MEMORY, "out of memory (%s)", path);
    int rc = TS_OK;
    size_t pixels = (size_t)in->width * in->height;
    for (size_t k = 0; !rc && k < pixels; ++k) {
        float pf = in->pixels[k * in->channels + idx[nc + TS_BAKE_CH_PATCH]];
        if (isnan(pf)) continue;
        if (!(pf >= 0.0f && pf < (float)m->patches && pf == floorf(pf)))
            rc = ts_error_set(err, TS_E_USAGE,
                              "%s: pixel (%zu, %zu) names patch %g, not one of the %u baked", path,
                              k % (size_t)in->width, k / (size_t)in->width, pf, m->patches);
        else
            ++count[(uint32_t)pf];
    }
    uint32_t first = 0;
    for (uint32_t p = 0; !rc && p < m->patches; ++p) {
        int lod = grid_lod(count[p]);
        if (lod < 0)
            rc = ts_error_set(err, TS_E_USAGE,
                              "%s: patch %u has %u points, not the (2^m + 1)^2 of a grid", path, p,
                              count[p]);
        o->patch[2 * p] = first, o->patch[2 * p + 1] = (uint32_t)lod;
        first += count[p];
    }
    if (!rc && first != m->points)
        rc =
            ts_error_set(err, TS_E_USAGE, "%s: it holds %u points, its tessera:bake_points says %u",
                         path, first, m->points);
    free(count);
    return rc;
}

/* Pass 2: every point's coefficients into its place, each grid point once, all finite. */
static int occlusion_fill(const char *path, const ts_image *in, const int *idx, uint32_t nc,
                          ts_occlusion *o, ts_error *err)
{
    uint8_t *seen = calloc(o->point_count ? o->point_count : 1, 1);
    if (!seen) return ts_error_set(err, TS_E_MEMORY, "out of memory (%s)", path);
    int rc = TS_OK;
    size_t pixels = (size_t)in->width * in->height;
    for (size_t k = 0; !rc && k < pixels; ++k) {
        const float *px = &in->pixels[k * in->channels];
        float pf = px[idx[nc + TS_BAKE_CH_PATCH]];
        if (isnan(pf)) continue;
        uint32_t p = (uint32_t)pf, m = o->patch[2 * p + 1], n = 1u << m;
        float x = px[idx[nc + TS_BAKE_CH_U]] * (float)n, y = px[idx[nc + TS_BAKE_CH_V]] * (float)n;
        uint32_t slot = 0;
        int ok = x >= 0.0f && y >= 0.0f && x <= (float)n && y <= (float)n && x == floorf(x) &&
                 y == floorf(y);
        if (ok) slot = o->patch[2 * p] + (uint32_t)y * (n + 1u) + (uint32_t)x, ok = !seen[slot];
        for (uint32_t c = 0; ok && c < nc; ++c)
            ok = isfinite(px[idx[c]]);
        for (uint32_t c = 0; ok && c < 3; ++c)
            ok = isfinite(px[idx[nc + TS_BAKE_CH_NX + c]]);
        if (!ok) {
            rc = ts_error_set(err, TS_E_USAGE,
                              "%s: pixel (%zu, %zu) is not a baked vertex of patch %u's grid "
                              "(u, v, a repeated point or a coefficient that is not finite)",
                              path, k % (size_t)in->width, k / (size_t)in->width, p);
            break;
        }
        seen[slot] = 1;
        for (uint32_t c = 0; c < nc; ++c)
            o->coeffs[(size_t)slot * nc + c] = px[idx[c]];
        for (uint32_t c = 0; c < 3; ++c)
            o->normal[(size_t)slot * 3 + c] = px[idx[nc + TS_BAKE_CH_NX + c]];
    }
    free(seen);
    return rc;
}

int bake_occlusion_load(const char *path, const ts_scene *s, const char *scene_path,
                        ts_occlusion *out, ts_error *err)
{
    memset(out, 0, sizeof *out);
    ts_image in;
    ts_bake_meta m;
    if (read_bake(path, &in, &m, " (--occlusion reads the EXR that tessera bake writes)", err))
        return err->code;
    uint32_t nc = (uint32_t)(m.bands * m.bands);
    int idx[TS_SH_MAX_COEFFS + TS_BAKE_CH_FIXED];
    int rc = occlusion_check_meta(path, &m, s, scene_path, err);
    if (!rc) rc = find_channels(path, &in, nc, idx, err);
    if (!rc) {
        out->bands = (uint32_t)m.bands;
        out->cosine = !!(m.flags & TS_BAKE_COSINE);
        out->patch_count = m.patches;
        out->point_count = m.points;
        out->patch = malloc(2 * (size_t)(m.patches ? m.patches : 1) * sizeof *out->patch);
        out->coeffs = malloc((size_t)(m.points ? m.points : 1) * nc * sizeof *out->coeffs);
        out->normal = malloc((size_t)(m.points ? m.points : 1) * 3 * sizeof *out->normal);
        if (!out->patch || !out->coeffs || !out->normal)
            rc = ts_error_set(err, TS_E_MEMORY, "out of memory (%s)", path);
    }
    if (!rc) rc = occlusion_count(path, &in, idx, nc, &m, out, err);
    if (!rc) rc = occlusion_fill(path, &in, idx, nc, out, err);
    image_free(&in);
    if (rc) occlusion_free(out);
    return rc;
}
