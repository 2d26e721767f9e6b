/* camera.cl — stage `camera`: generates one wave of eye rays.
 * Reads:  ts_camera_params (by value); a moving camera is interpolated to each ray's time.
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

/* A moving camera at time t: each of its vectors interpolated linearly between shutter open
 * and close (ts_camera_params). */
static void camera_at_time(ts_camera_params *c, float t)
{
    for (int k = 0; k < 3; k++) {
        c->origin[k] = (1.0f - t) * c->origin[k] + t * c->origin1[k];
        c->right[k] = (1.0f - t) * c->right[k] + t * c->right1[k];
        c->up[k] = (1.0f - t) * c->up[k] + t * c->up1[k];
        c->forward[k] = (1.0f - t) * c->forward[k] + t * c->forward1[k];
    }
}

__kernel void camera_generate(ts_camera_params cam, __global ts_vec4 *org, __global ts_vec4 *dir,
                              __global ts_hit *hit, __global uint *entry, __global uint *pixel,
                              __global uint *flags, __global uint *from, __global uint *active,
                              __global uint *paths, __global ts_vec4 *throughput,
                              __global float *mis, __global uint *state, __global ts_vec4 *radiance)
{
    uint i = get_global_id(0);
    ts_camera_params p = cam;
    if (i >= p.ray_count) return;
    uint npix = p.width * p.height;
    uint pix, sample;
    sample_order_at(p.first_sample + i, npix, p.spp, p.band, &pix, &sample);
    uint x = pix % p.width, y = pix / p.width;
    float jx = 0.5f, jy = 0.5f;
    ts_sampler_set cs = sampler_set(pix, sample, TS_SET_CAMERA, p.seed, sampler_mask(p.spp));
    if (p.spp > 1) {
        jx = sampler_set_value(cs, 0u);
        jy = sampler_set_value(cs, 1u);
    }
    /* Time in [0, 1) for motion blur (Hanika §3.4): the camera set's third dimension. */
    float time = sampler_set_value(cs, 2u);
    if (p.moving) camera_at_time(&p, time);
    float sx = 2.0f * ((float)x + jx) / (float)p.width - 1.0f;
    float sy = 1.0f - 2.0f * ((float)y + jy) / (float)p.height;
    float dx, dy, dz;
    ts_vec4 o = {p.origin[0], p.origin[1], p.origin[2], 0.0f};
    if (p.projection == TS_PROJECTION_ORTHOGRAPHIC) {
        /* Parallel rays along forward, from the screen point (RIB Projection "orthographic"). */
        o.x += sx * p.right[0] + sy * p.up[0];
        o.y += sx * p.right[1] + sy * p.up[1];
        o.z += sx * p.right[2] + sy * p.up[2];
        dx = p.forward[0], dy = p.forward[1], dz = p.forward[2];
    } else {
        dx = sx * p.right[0] + sy * p.up[0] + p.forward[0];
        dy = sx * p.right[1] + sy * p.up[1] + p.forward[1];
        dz = sx * p.right[2] + sy * p.up[2] + p.forward[2];
    }
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
