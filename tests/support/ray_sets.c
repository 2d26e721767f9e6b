/* ray_sets.c — eye and bounce rays shared by two tracers, and their files (ray_sets.h). */
#include "ray_sets.h"
#include "pipeline/pipeline.h"
#include "lib/bsdf.h"
#include "lib/patch.h"
#include "lib/rng.h"
#include "app/render.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int ray_set_write_file(const char *path, const void *a, size_t an, const void *b, size_t bn)
{
    FILE *f = fopen(path, "wb");
    int ok = f && fwrite(a, 1, an, f) == an && (!bn || fwrite(b, 1, bn, f) == bn);
    if (f && fclose(f)) ok = 0;
    if (!ok) fprintf(stderr, "ray_sets: cannot write %s: %s\n", path, strerror(errno));
    return ok ? 0 : -1;
}

/* Reads a whole file; NULL (and a message) if it cannot. */
void *ray_set_read_file(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    void *data = NULL;
    long n = -1;
    if (f && fseek(f, 0, SEEK_END) == 0 && (n = ftell(f)) >= 0 && fseek(f, 0, SEEK_SET) == 0 &&
        (data = malloc((size_t)n + 1)) && fread(data, 1, (size_t)n, f) != (size_t)n) {
        free(data);
        data = NULL;
    }
    if (f) fclose(f);
    if (!data)
        fprintf(stderr, "ray_sets: cannot read %s\n", path);
    else
        ((char *)data)[n] = '\0', *size = (size_t)n;
    return data;
}

void ray_set_free(ts_ray_set *r)
{
    free(r->org), free(r->dir), free(r->pixel), free(r->from);
    memset(r, 0, sizeof *r);
}

int ray_set_alloc(ts_ray_set *r, uint32_t n)
{
    r->count = n;
    r->org = malloc((n ? n : 1) * sizeof *r->org);
    r->dir = malloc((n ? n : 1) * sizeof *r->dir);
    r->pixel = malloc((n ? n : 1) * sizeof *r->pixel);
    r->from = calloc(n ? n : 1, sizeof *r->from);
    return r->org && r->dir && r->pixel && r->from ? 0 : -1;
}

int ray_set_save(const char *path, const ts_ray_set *r)
{
    size_t n = r->count;
    size_t bytes = 4 + 2 * n * sizeof(ts_vec4) + n * 8;
    unsigned char *buf = malloc(bytes);
    if (!buf) return -1;
    memcpy(buf, &r->count, 4);
    memcpy(buf + 4, r->org, n * sizeof(ts_vec4));
    memcpy(buf + 4 + n * sizeof(ts_vec4), r->dir, n * sizeof(ts_vec4));
    memcpy(buf + 4 + 2 * n * sizeof(ts_vec4), r->pixel, n * 4);
    memcpy(buf + 4 + 2 * n * sizeof(ts_vec4) + n * 4, r->from, n * 4);
    int rc = ray_set_write_file(path, buf, bytes, NULL, 0);
    free(buf);
    return rc;
}

int ray_set_load(const char *path, ts_ray_set *r)
{
    size_t size = 0;
    unsigned char *buf = ray_set_read_file(path, &size);
    if (!buf) return -1;
    uint32_t n = 0;
    if (size >= 4) memcpy(&n, buf, 4);
    if (size != 4 + 2 * (size_t)n * sizeof(ts_vec4) + (size_t)n * 8 || ray_set_alloc(r, n)) {
        fprintf(stderr, "ray_sets: %s: not a ray file\n", path);
        free(buf);
        return -1;
    }
    memcpy(r->org, buf + 4, (size_t)n * sizeof(ts_vec4));
    memcpy(r->dir, buf + 4 + (size_t)n * sizeof(ts_vec4), (size_t)n * sizeof(ts_vec4));
    memcpy(r->pixel, buf + 4 + 2 * (size_t)n * sizeof(ts_vec4), (size_t)n * 4);
    memcpy(r->from, buf + 4 + 2 * (size_t)n * sizeof(ts_vec4) + (size_t)n * 4, (size_t)n * 4);
    free(buf);
    return 0;
}

ts_hit *ray_set_load_hits(const char *path, uint32_t count)
{
    size_t size = 0;
    ts_hit *h = ray_set_read_file(path, &size);
    if (h && size != (size_t)count * sizeof(ts_hit)) {
        fprintf(stderr, "ray_sets: %s: %zu bytes, expected %u hits\n", path, size, count);
        free(h);
        return NULL;
    }
    return h;
}

uint32_t ray_set_count_hits(const ts_hit *h, uint32_t n)
{
    uint32_t k = 0;
    for (uint32_t i = 0; i < n; ++i)
        k += h[i].patch != TS_INVALID;
    return k;
}

/* The camera kernel's eye rays (kernels/camera.cl) at 1 spp: pixel centres, time from the
 * RNG. */
int ray_set_eye(const ts_scene *s, uint32_t w, uint32_t h, uint32_t seed, ts_ray_set *r,
                ts_error *err)
{
    ts_camera_params p;
    if (render_camera_params(&s->camera, (int)w, (int)h, &p, err)) return err->code;
    if (ray_set_alloc(r, w * h)) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    for (uint32_t pix = 0; pix < w * h; ++pix) {
        uint32_t x = pix % w, y = pix / w;
        float sx = 2.0f * ((float)x + 0.5f) / (float)w - 1.0f;
        float sy = 1.0f - 2.0f * ((float)y + 0.5f) / (float)h;
        float time = rng_uniform(pix, 0, 0, 2, seed);
        ts_camera_params c = p;
        for (int k = 0; k < 3 && p.moving; k++) { /* camera.cl camera_at_time */
            c.origin[k] = (1.0f - time) * p.origin[k] + time * p.origin1[k];
            c.right[k] = (1.0f - time) * p.right[k] + time * p.right1[k];
            c.up[k] = (1.0f - time) * p.up[k] + time * p.up1[k];
            c.forward[k] = (1.0f - time) * p.forward[k] + time * p.forward1[k];
        }
        float dx = sx * c.right[0] + sy * c.up[0] + c.forward[0];
        float dy = sx * c.right[1] + sy * c.up[1] + c.forward[1];
        float dz = sx * c.right[2] + sy * c.up[2] + c.forward[2];
        float inv = 1.0f / sqrtf(dx * dx + dy * dy + dz * dz);
        r->org[pix] = (ts_vec4){c.origin[0], c.origin[1], c.origin[2], 0.0f};
        r->dir[pix] = (ts_vec4){dx * inv, dy * inv, dz * inv, time};
        r->pixel[pix] = pix;
    }
    return TS_OK;
}

/* The shading normal of hit h on a patch diced at m, as shade computes it (lib/patch.h
 * patch_quad_shading_normal: the hit micro-quad's, from TS_PRIM_INDEX), with pipeline.c's
 * defaults for missing normals and transforms. */
ts_vec4 ray_set_normal(const ts_scene *s, const ts_hit *h, uint32_t m)
{
    uint32_t patch = h->patch, q = TS_PRIM_INDEX(h->prim) >> 1;
    const ts_vec4 *cp = &s->cp[(size_t)patch * 16u];
    const ts_patch_attr *a = &s->attr[patch];
    static const ts_vec4 up[5] = {
        {0, 0, 1, 0}, {0, 0, 1, 0}, {0, 0, 1, 0}, {0, 0, 1, 0}, {0, 0, 1, 0}};
    const ts_vec4 *n = s->corner_n ? &s->corner_n[(size_t)patch * 4u] : up;
    const ts_vec4 *mid = s->mid_n ? &s->mid_n[(size_t)patch * 5u] : up;
    static const ts_xform identity = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
    const ts_xform *x = s->xform ? &s->xform[a->xform] : &identity;
    return patch_quad_shading_normal(cp, n, mid, a, x, scene_tex_ctx(s), h->u, h->v,
                                     q & ((1u << m) - 1u), q >> m, m, 0u);
}

/* One generation of diffuse bounce rays from the hits of `eye` (see the top of the file). */
int ray_set_bounce(const ts_scene *s, uint32_t m, uint32_t seed, const ts_ray_set *eye,
                   const ts_hit *hit, ts_ray_set *out, ts_error *err)
{
    if (ray_set_alloc(out, eye->count)) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    uint32_t n = 0;
    for (uint32_t k = 0; k < eye->count; ++k) {
        const ts_hit *h = &hit[k];
        if (h->patch == TS_INVALID) continue;
        ts_vec4 o4 = eye->org[k], d4 = eye->dir[k];
        ts_v3 d = v3(d4.x, d4.y, d4.z), wo = v3_scale(d, -1.0f);
        ts_vec4 n4 = ray_set_normal(s, h, m);
        ts_v3 nn = v3(n4.x, n4.y, n4.z);
        if (v3_dot(nn, wo) < 0.0f) nn = v3_scale(nn, -1.0f);
        ts_v3 p = v3(o4.x + h->t * d.x, o4.y + h->t * d.y, o4.z + h->t * d.z);
        ts_box b = scene_patch_box(s, h->patch);
        float l = fmaxf(b.hi_x - b.lo_x, fmaxf(b.hi_y - b.lo_y, b.hi_z - b.lo_z));
        float eps = l * ldexpf(1.0f, -(int)m);
        uint32_t pix = eye->pixel[k];
        ts_v3 wi =
            sample_cosine(nn, rng_uniform(pix, 0, 1, 5, seed), rng_uniform(pix, 0, 1, 6, seed));
        if (!(v3_dot(nn, wi) > 0.0f)) continue;
        /* As shade.cl: offset eps along the normal, hits on the patch left ignored nearer
         * than eps. */
        out->org[n] = (ts_vec4){p.x + eps * nn.x, p.y + eps * nn.y, p.z + eps * nn.z, eps};
        out->from[n] = h->patch + 1u;
        out->dir[n] = (ts_vec4){wi.x, wi.y, wi.z, d4.w};
        out->pixel[n] = pix;
        ++n;
    }
    out->count = n;
    return TS_OK;
}

int ray_set_upload(ts_pipeline *p, const ts_ray_set *r, uint32_t first, uint32_t n, ts_error *err)
{
    uint32_t *idx = malloc((n ? n : 1) * sizeof *idx), *zero = calloc(n ? n : 1, sizeof *zero);
    ts_hit *clear = malloc((n ? n : 1) * sizeof *clear);
    int rc = idx && zero && clear ? TS_OK : ts_error_set(err, TS_E_MEMORY, "out of memory");
    for (uint32_t i = 0; rc == TS_OK && i < n; ++i) {
        idx[i] = i;
        clear[i] = (ts_hit){TS_NO_HIT, 0.0f, 0.0f, TS_INVALID, TS_INVALID};
    }
    ts_device *d = p->cl;
    if (rc == TS_OK &&
        (dev_write(d, p->ray_org, 0, n * sizeof(ts_vec4), r->org + first, "origins", err) ||
         dev_write(d, p->ray_dir, 0, n * sizeof(ts_vec4), r->dir + first, "directions", err) ||
         dev_write(d, p->ray_from, 0, n * sizeof(uint32_t), r->from + first, "from", err) ||
         dev_write(d, p->ray_hit, 0, n * sizeof(ts_hit), clear, "hits", err) ||
         dev_write(d, p->ray_entry, 0, n * sizeof(uint32_t), zero, "entries", err) ||
         dev_write(d, p->ray_flags, 0, n * sizeof(uint32_t), zero, "flags", err) ||
         dev_write(d, p->ray_pixel, 0, n * sizeof(uint32_t), idx, "pixels", err) ||
         dev_write(d, p->active, 0, n * sizeof(uint32_t), idx, "the active list", err)))
        rc = err->code;
    free(idx), free(zero), free(clear);
    return rc;
}

int ray_set_trace(ts_pipeline *p, const ts_ray_set *r, ts_hit *hit, ts_error *err)
{
    uint32_t cap = p->plan.ray_capacity;
    for (uint32_t first = 0; first < r->count; first += cap) {
        uint32_t n = r->count - first < cap ? r->count - first : cap;
        if (ray_set_upload(p, r, first, n, err) || pipeline_trace(p, n, err) ||
            dev_read(p->cl, p->ray_hit, 0, n * sizeof(ts_hit), hit + first, "the hits", err))
            return err->code;
    }
    return TS_OK;
}
