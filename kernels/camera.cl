/* camera.cl — stage `camera`: generates one wave of eye rays.
 * Reads:  ts_camera_params and the sample order's divisors (ts_order_divs, by value); a moving
 *         camera is interpolated to each ray's time.
 * Writes: per ray org, dir (w = time in [0,1)), hit (cleared), entry (TS_ENTRY_START), pixel,
 *         flags (0); active[i] = paths[i] = i; a fresh path state (throughput 1, radiance 0,
 *         its eye-ray slot traced, emission it finds weighted 1).
 * Ray i is the frame's sample first_sample + i in the sample order (lib/sample_order.h:
 * bands of p.band pixels, each band's samples one after another), so a wave is a run of
 * the frame's samples and the film can sum each pixel's samples in sample order.
 * RenderMan screen: x right, y up; raster y grows downwards; a perspective or an orthographic
 * projection (ts_camera_params in lib/shared_types.h). One sample per pixel goes through the
 * pixel centre; more are jittered by the sampler's camera set (lib/sampler.h: dimensions 0
 * and 1 the position in the pixel, 2 the time). */
#include "lib/shared_types.h"
#include "lib/sample_order.h"
#include "lib/sampler.h"

/* Vector k (0 origin, 1 right, 2 up, 3 forward) of the camera at time t: interpolated
 * linearly between shutter open and close when it moves (ts_camera_params). */
inline float3 camera_vector(const ts_camera_params *c, uint k, float t)
{
    const float *a = k == 0u ? c->origin : k == 1u ? c->right : k == 2u ? c->up : c->forward;
    float3 v = (float3)(a[0], a[1], a[2]);
    if (c->moving) {
        const float *b = k == 0u   ? c->origin1
                         : k == 1u ? c->right1
                         : k == 2u ? c->up1
                                   : c->forward1;
        v = (1.0f - t) * v + t * (float3)(b[0], b[1], b[2]);
    }
    return v;
}

__kernel void camera_generate(ts_camera_params cam, ts_order_divs ord, __global ts_vec4 *org,
                              __global ts_vec4 *dir, __global ts_hit *hit, __global uint *entry,
                              __global uint *pixel, __global uint *flags, __global uint *from,
                              __global uint *active, __global uint *paths,
                              __global ts_vec4 *throughput, __global float *mis,
                              __global uint *state, __global ts_vec4 *radiance)
{
    uint i = get_global_id(0);
    if (i >= cam.ray_count) return;
    uint pix, sample;
    sample_order_at_ready(cam.first_sample + i, ord, &pix, &sample);
    uint y = udiv(pix, ord.width), x = pix - y * cam.width;
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
    float sx = 2.0f * ((float)x + jx) / (float)cam.width - 1.0f;
    float sy = 1.0f - 2.0f * ((float)y + jy) / (float)cam.height;
    float3 d;
    if (cam.projection == TS_PROJECTION_ORTHOGRAPHIC) {
        /* Parallel rays along forward, from the screen point (RIB Projection "orthographic"). */
        eye += sx * right + sy * up;
        d = forward;
    } else {
        d = sx * right + sy * up + forward;
    }
    ts_vec4 o = {eye.x, eye.y, eye.z, 0.0f};
    float dx = d.x, dy = d.y, dz = d.z;
    float inv = 1.0f / sqrt(dx * dx + dy * dy + dz * dz);
    org[i] = o;
    dir[i] = (ts_vec4){dx * inv, dy * inv, dz * inv, time};
    hit[i] = (ts_hit){TS_NO_HIT, 0.0f, 0.0f, TS_INVALID, TS_INVALID};
    entry[i] = TS_ENTRY_START;
    pixel[i] = pix;
    flags[i] = 0u;
    from[i] = 0u;
    active[i] = i;
    paths[i] = i;
    /* A new path: weight 1, nothing gathered, MIS weight 1 for what the eye ray finds, its
     * BSDF-ray slot traced. */
    throughput[i] = (ts_vec4){1.0f, 1.0f, 1.0f, 0.0f};
    mis[i] = 1.0f;
    state[i] = TS_PATH_STATE(TS_PATH_TRACED_BSDF, TS_MIS_ONE);
    radiance[i] = (ts_vec4){0.0f, 0.0f, 0.0f, 0.0f};
}
