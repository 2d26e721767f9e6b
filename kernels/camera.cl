/* camera.cl — stage `camera`: generates one wave of eye rays.
 * Reads:  ts_camera_params and the sample order's divisors (ts_order_divs, by value); a moving
 *         camera is interpolated to each ray's time.
 * Writes: per ray org (w 0, or with RIB Clipping the distance from the eye to the near plane,
 *         where the ray starts: camera_clip), dir (w = time in [0,1)), hit (cleared; its t the
 *         far plane's distance with Clipping), entry (TS_ENTRY_START), pixel (the frame's:
 *         with a CropWindow the image is a part of it, ts_camera_params; shade keys the
 *         path's sample values by it),
 *         flags (0); active[i] = paths[i] = i; for i < path_count (the path buffers hold half
 *         the rays: a path owns two ray slots) a fresh path state (throughput 1, radiance 0,
 *         its eye-ray slot traced, emission it finds weighted 1). The lod stage's waves of
 *         eye rays alone run past path_count; their path state is never read.
 * Ray i is the frame's sample first_sample + i in the sample order (lib/sample_order.h:
 * bands of p.band pixels, each band's samples one after another), so a wave is a run of
 * the frame's samples and the film can sum each pixel's samples in sample order.
 * RenderMan screen: x right, y up; raster y grows downwards; a perspective or an orthographic
 * projection (ts_camera_params in lib/shared_types.h). One sample per pixel goes through the
 * pixel centre; more are jittered by the sampler's camera set (lib/sampler.h: dimensions 0
 * and 1 the position in the pixel, 2 the time); a thin lens (RIB DepthOfField) takes its point
 * from the lens set. */
#include "lib/shared_types.h"
#include "lib/sample_order.h"
#include "lib/sampler.h"

/* The three floats of vector k (0 origin, 1 right, 2 up, 3 forward, 4 and 5 the lens's x and y
 * half-axes) of the camera at shutter open, or (close = 1) at shutter close (ts_camera_params). */
inline const float *camera_array(const ts_camera_params *c, uint k, int close)
{
    if (k == 4u) return close ? c->lens_x1 : c->lens_x;
    if (k == 5u) return close ? c->lens_y1 : c->lens_y;
    if (close) return k == 0u ? c->origin1 : k == 1u ? c->right1 : k == 2u ? c->up1 : c->forward1;
    return k == 0u ? c->origin : k == 1u ? c->right : k == 2u ? c->up : c->forward;
}

/* A point (*a, *b) of the unit disk from (u, v) in [0, 1)^2, area-preserving (Shirley and
 * Chiu 1997's concentric map: squares to rings, so strata stay compact). */
inline void lens_disk(float u, float v, float *a, float *b)
{
    float x = 2.0f * u - 1.0f, y = 2.0f * v - 1.0f;
    if (x == 0.0f && y == 0.0f) {
        *a = 0.0f, *b = 0.0f;
        return;
    }
    float r, phi;
    if (fabs(x) > fabs(y))
        r = x, phi = M_PI_4_F * (y / x);
    else
        r = y, phi = M_PI_2_F - M_PI_4_F * (x / y);
    *a = r * cos(phi), *b = r * sin(phi);
}

/* Vector k of the camera at time t: interpolated linearly between shutter open and close
 * when it moves. */
inline float3 camera_vector(const ts_camera_params *c, uint k, float t)
{
    const float *a = camera_array(c, k, 0);
    float3 v = (float3)(a[0], a[1], a[2]);
    if (c->moving) {
        const float *b = camera_array(c, k, 1);
        v = (1.0f - t) * v + t * (float3)(b[0], b[1], b[2]);
    }
    return v;
}

/* RIB Clipping (c->clip) of an eye ray whose unnormalised direction (forward + screen
 * offsets along right and up, both perpendicular to forward) has length len and unit
 * components (nx, ny, nz): a camera-space depth z lies z * len along it. The ray starts at
 * depth clip_near, o->w its distance from the eye (shade adds it to the Z channel; the
 * origin-patch rule reads w only for rays that leave a patch), and ends at depth clip_far:
 * *tmax. What lies nearer or farther is not seen by the camera (reflections, shadows and
 * indirect light still see it, as in RenderMan). */
inline void camera_clip(const ts_camera_params *c, float len, float nx, float ny, float nz,
                        ts_vec4 *o, float *tmax)
{
    float tn = c->clip_near * len;
    o->x += nx * tn, o->y += ny * tn, o->z += nz * tn, o->w = tn;
    *tmax = fmin(c->clip_far * len - tn, TS_NO_HIT);
}

#ifdef TS_CPU_LANES
/* camera_vector's component comp (0..2) of vector k at the lanes' times. */
inline float8 camera_vector_x8(const ts_camera_params *c, uint k, uint comp, float8 t)
{
    float8 v = (float8)(camera_array(c, k, 0)[comp]);
    if (c->moving) v = (1.0f - t) * v + t * (float8)(camera_array(c, k, 1)[comp]);
    return v;
}

/* CPU devices (-DTS_CPU_LANES): work-item g makes rays 8 g .. 8 g + 7 in the lanes of uint8
 * and float8 vectors (the host launches ceil(ray_count / 8) work-items, pipeline_camera),
 * each lane the operations of the one-ray form below in their order: the same bits
 * (test_geometry's TESSERA_CPU_LANES=0 case compares them). PoCL vectorises no work-item
 * loop of this kernel itself (its vector-typed values), so the lanes are written out: the
 * stage in half the time (0.40 -> 0.20 s on the default teapot, docs/benchmarks.md). */
inline void camera_generate_x8(const ts_camera_params *c, ts_order_divs ord, __global ts_vec4 *org,
                               __global ts_vec4 *dir, __global ts_hit *hit, __global uint *entry,
                               __global uint *pixel, __global uint *flags, __global uint *from,
                               __global uint *active, __global uint *paths,
                               __global ts_vec4 *throughput, __global float *mis,
                               __global uint *state, __global ts_vec4 *radiance, uint path_count)
{
    uint g = get_global_id(0), i0 = 8u * g;
    if (i0 >= c->ray_count) return;
    uint8 lane = (uint8)(0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u), pix, sample;
    sample_order_at_ready_x8((uint8)(c->first_sample + i0) + lane, ord, &pix, &sample);
    uint8 row = udiv_x8(pix, ord.width);
    uint8 y = row + c->crop_y, x = pix - row * c->width + c->crop_x; /* in the frame */
    pix = y * c->full_width + x; /* the frame's pixel: its sample values' key */
    float8 jx = (float8)(0.5f), jy = (float8)(0.5f);
    ts_sampler_set_x8 cs = sampler_set_x8(pix, sample, TS_SET_CAMERA, c->seed, ord.mask);
    if (c->spp > 1) {
        jx = sampler_set_value_x8(cs, 0u);
        jy = sampler_set_value_x8(cs, 1u);
    }
    float8 time = sampler_set_value_x8(cs, 2u);
    float8 sx = 2.0f * (convert_float8(x) + jx) / (float)c->full_width - 1.0f;
    float8 sy = 1.0f - 2.0f * (convert_float8(y) + jy) / (float)c->full_height;
    float8 e[3], d[3];
    for (uint k = 0u; k < 3u; ++k) {
        float8 eye = camera_vector_x8(c, 0u, k, time), right = camera_vector_x8(c, 1u, k, time);
        float8 up = camera_vector_x8(c, 2u, k, time), fwd = camera_vector_x8(c, 3u, k, time);
        if (c->projection == TS_PROJECTION_ORTHOGRAPHIC)
            e[k] = eye + (sx * right + sy * up), d[k] = fwd;
        else
            e[k] = eye, d[k] = sx * right + sy * up + fwd;
    }
    if (c->dof) { /* the thin lens: camera_generate's operations, lane by lane */
        ts_sampler_set_x8 ls = sampler_set_x8(pix, sample, TS_SET_LENS, c->seed, ord.mask);
        float lu[8], lv[8], la[8], lb[8];
        vstore8(sampler_set_value_x8(ls, 0u), 0, lu), vstore8(sampler_set_value_x8(ls, 1u), 0, lv);
        for (uint l = 0u; l < 8u; ++l)
            lens_disk(lu[l], lv[l], &la[l], &lb[l]);
        float8 a = vload8(0, la), b = vload8(0, lb);
        for (uint k = 0u; k < 3u; ++k) {
            float8 lx = camera_vector_x8(c, 4u, k, time), ly = camera_vector_x8(c, 5u, k, time);
            float8 f = e[k] + c->focal * d[k];
            e[k] = e[k] + (a * lx + b * ly);
            d[k] = (f - e[k]) / c->focal;
        }
    }
    float8 len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]), inv = 1.0f / len;
    float ex[8], ey[8], ez[8], dx[8], dy[8], dz[8], tt[8], ln[8];
    vstore8(e[0], 0, ex), vstore8(e[1], 0, ey), vstore8(e[2], 0, ez);
    vstore8(d[0] * inv, 0, dx), vstore8(d[1] * inv, 0, dy), vstore8(d[2] * inv, 0, dz);
    vstore8(time, 0, tt), vstore8(len, 0, ln);
    uint n = min(8u, c->ray_count - i0);
    for (uint l = 0u; l < n; ++l) {
        uint i = i0 + l;
        ts_vec4 o = {ex[l], ey[l], ez[l], 0.0f};
        float tmax = TS_NO_HIT;
        if (c->clip) camera_clip(c, ln[l], dx[l], dy[l], dz[l], &o, &tmax);
        org[i] = o;
        dir[i] = (ts_vec4){dx[l], dy[l], dz[l], tt[l]};
        hit[i] = (ts_hit){tmax, 0.0f, 0.0f, TS_INVALID, TS_INVALID};
        if (i < path_count) {
            throughput[i] = (ts_vec4){1.0f, 1.0f, 1.0f, 0.0f};
            radiance[i] = (ts_vec4){0.0f, 0.0f, 0.0f, 0.0f};
            mis[i] = 1.0f;
            state[i] = TS_PATH_STATE(TS_PATH_TRACED_BSDF, TS_MIS_ONE);
        }
    }
    if (n == 8u) {
        vstore8((uint8)(TS_ENTRY_START), g, entry), vstore8(pix, g, pixel);
        vstore8((uint8)(0u), g, flags), vstore8((uint8)(0u), g, from);
        vstore8((uint8)(i0) + lane, g, active), vstore8((uint8)(i0) + lane, g, paths);
    } else {
        uint px[8];
        vstore8(pix, 0, px);
        for (uint l = 0u; l < n; ++l) {
            uint i = i0 + l;
            entry[i] = TS_ENTRY_START, pixel[i] = px[l], flags[i] = 0u, from[i] = 0u;
            active[i] = i, paths[i] = i;
        }
    }
}
#endif

__kernel void camera_generate(ts_camera_params cam, ts_order_divs ord, __global ts_vec4 *org,
                              __global ts_vec4 *dir, __global ts_hit *hit, __global uint *entry,
                              __global uint *pixel, __global uint *flags, __global uint *from,
                              __global uint *active, __global uint *paths,
                              __global ts_vec4 *throughput, __global float *mis,
                              __global uint *state, __global ts_vec4 *radiance, uint path_count)
{
#ifdef TS_CPU_LANES
    camera_generate_x8(&cam, ord, org, dir, hit, entry, pixel, flags, from, active, paths,
                       throughput, mis, state, radiance, path_count);
#else
    uint i = get_global_id(0);
    if (i >= cam.ray_count) return;
    uint pix, sample;
    sample_order_at_ready(cam.first_sample + i, ord, &pix, &sample);
    uint row = udiv(pix, ord.width);
    uint y = row + cam.crop_y, x = pix - row * cam.width + cam.crop_x; /* in the frame */
    pix = y * cam.full_width + x; /* the frame's pixel: its sample values' key */
    float jx = 0.5f, jy = 0.5f;
    ts_sampler_set cs = sampler_set(pix, sample, TS_SET_CAMERA, cam.seed, ord.mask);
    if (cam.spp > 1) {
        jx = sampler_set_value(cs, 0u);
        jy = sampler_set_value(cs, 1u);
    }
    /* Time in [0, 1) for motion blur (Hanika §3.4): the camera set's third dimension. */
    float time = sampler_set_value(cs, 2u);
    float3 eye = camera_vector(&cam, 0u, time), right = camera_vector(&cam, 1u, time);
    float3 up = camera_vector(&cam, 2u, time), forward = camera_vector(&cam, 3u, time);
    float sx = 2.0f * ((float)x + jx) / (float)cam.full_width - 1.0f;
    float sy = 1.0f - 2.0f * ((float)y + jy) / (float)cam.full_height;
    float3 d;
    if (cam.projection == TS_PROJECTION_ORTHOGRAPHIC) {
        /* Parallel rays along forward, from the screen point (RIB Projection "orthographic"). */
        eye += sx * right + sy * up;
        d = forward;
    } else {
        d = sx * right + sy * up + forward;
    }
    if (cam.dof) { /* a thin lens: from a point of the lens through the plane of focus */
        ts_sampler_set ls = sampler_set(pix, sample, TS_SET_LENS, cam.seed, ord.mask);
        float a, b;
        lens_disk(sampler_set_value(ls, 0u), sampler_set_value(ls, 1u), &a, &b);
        float3 lx = camera_vector(&cam, 4u, time), ly = camera_vector(&cam, 5u, time);
        float3 f = eye + cam.focal * d;
        eye = eye + (a * lx + b * ly);
        d = (f - eye) / cam.focal;
    }
    ts_vec4 o = {eye.x, eye.y, eye.z, 0.0f};
    float dx = d.x, dy = d.y, dz = d.z;
    float len = sqrt(dx * dx + dy * dy + dz * dz), inv = 1.0f / len;
    float tmax = TS_NO_HIT;
    if (cam.clip) camera_clip(&cam, len, dx * inv, dy * inv, dz * inv, &o, &tmax);
    org[i] = o;
    dir[i] = (ts_vec4){dx * inv, dy * inv, dz * inv, time};
    hit[i] = (ts_hit){tmax, 0.0f, 0.0f, TS_INVALID, TS_INVALID};
    entry[i] = TS_ENTRY_START;
    pixel[i] = pix;
    flags[i] = 0u;
    from[i] = 0u;
    active[i] = i;
    paths[i] = i;
    /* A new path: weight 1, nothing gathered, MIS weight 1 for what the eye ray finds, its
     * BSDF-ray slot traced. */
    if (i >= path_count) return;
    throughput[i] = (ts_vec4){1.0f, 1.0f, 1.0f, 0.0f};
    mis[i] = 1.0f;
    state[i] = TS_PATH_STATE(TS_PATH_TRACED_BSDF, TS_MIS_ONE);
    radiance[i] = (ts_vec4){0.0f, 0.0f, 0.0f, 0.0f};
#endif
}
