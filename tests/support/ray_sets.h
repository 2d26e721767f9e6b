/* ray_sets.h — the rays a benchmark gives two tracers alike (tools/bench_embree.c): the
 * camera's eye rays and one generation of diffuse bounce rays made from their hits, and
 * files holding rays and hits so that tracers in separate processes read the same ones.
 * Host only; the maths are the kernels' own (lib/rng.h, lib/bsdf.h, lib/patch.h). */
#ifndef TS_RAY_SETS_H
#define TS_RAY_SETS_H

#include "base/error.h"
#include "scene/scene.h"

#include <stddef.h>
#include <stdint.h>

/* count rays as the ray buffers hold them: org.xyz, tnear = org.w; unit dir.xyz, time =
 * dir.w; pixel: the pixel whose eye ray it is or continues (the RNG's key). */
typedef struct ts_ray_set {
    uint32_t count;
    ts_vec4 *org, *dir;
    uint32_t *pixel;
    uint32_t *from; /* the patch a ray leaves + 1 (0 for eye rays): hits on it nearer than
                       org.w are ignored (bottom_level.cl bl_pair; embree_ref_trace) */
} ts_ray_set;

/* Arrays for n rays (count = n); -1 when out of memory. */
int ray_set_alloc(ts_ray_set *r, uint32_t n);
void ray_set_free(ts_ray_set *r);
/* A file: count (4 bytes), count origins, count directions (16 bytes each), count pixels,
 * count `from` patches (4 bytes each).
 * 0, or -1 with a message on stderr. */
int ray_set_save(const char *path, const ts_ray_set *r);
int ray_set_load(const char *path, ts_ray_set *r);
/* count ts_hit records written raw; NULL (and a message) if the size does not match. */
ts_hit *ray_set_load_hits(const char *path, uint32_t count);
/* Rays of `h` that hit something (patch != TS_INVALID). */
uint32_t ray_set_count_hits(const ts_hit *h, uint32_t n);

/* The camera kernel's eye rays (kernels/camera.cl) at w x h, 1 spp: through the pixel
 * centres, time rng_uniform(pixel, 0, 0, 2, seed). */
int ray_set_eye(const ts_scene *s, uint32_t w, uint32_t h, uint32_t seed, ts_ray_set *r,
                ts_error *err);
/* The shade kernel's shading normal (lib/patch.h patch_quad_shading_normal) of hit h on a
 * patch diced at m: the Bézier normal at (u, v), or for a displaced patch the normal of the
 * hit micro-quad from its four diced vertices. */
ts_vec4 ray_set_normal(const ts_scene *s, const ts_hit *h, uint32_t m);
/* One bounce ray per eye-ray hit, as the shade kernel makes them for a matte surface:
 * direction cosine-distributed about the shading normal turned towards the eye
 * (rng_uniform(pixel, 0, 1, 5 | 6, seed)), origin the hit point offset by l / 2^m along
 * it (l the longest side of the patch's box, Hanika §3.3), tnear 0, the eye ray's time. */
int ray_set_bounce(const ts_scene *s, uint32_t m, uint32_t seed, const ts_ray_set *eye,
                   const ts_hit *hit, ts_ray_set *out, ts_error *err);

/* Writes rays [first, first + n) of r into the pipeline's ray buffers as rays 0..n-1 (n at
 * most the plan's ray_capacity): origin, direction, from, a cleared hit, a fresh top-level
 * entry, flags 0, pixel = index, and lists them in active, ready for pipeline_trace. */
struct ts_pipeline;
int ray_set_upload(struct ts_pipeline *p, const ts_ray_set *r, uint32_t first, uint32_t n,
                   ts_error *err);
/* Traces every ray of r through p (in waves of the plan's ray capacity) and reads the
 * closest hits back into hit[0..r->count). */
int ray_set_trace(struct ts_pipeline *p, const ts_ray_set *r, ts_hit *hit, ts_error *err);

/* Whole files: a (and b when bn > 0) written; read with a terminating NUL added. 0 / data,
 * or -1 / NULL with a message on stderr. */
int ray_set_write_file(const char *path, const void *a, size_t an, const void *b, size_t bn);
void *ray_set_read_file(const char *path, size_t *size);

#endif
