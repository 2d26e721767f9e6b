/* intersect.h — ray-box and ray-triangle tests shared by the kernels and the host
 * references. Both are written for bitwise agreement between host and device (no FMA,
 * fixed operation order). */
#ifndef TS_INTERSECT_H
#define TS_INTERSECT_H

#include "lib/shared_types.h"

#ifndef __OPENCL_C_VERSION__
#include <math.h>
#endif

/* Slab test of [tmin, tmax] against a box, with reciprocal direction `inv` (±inf for a zero
 * component). Returns the entry distance, or -1 for a miss. tfar is widened by 1 + 2*gamma(3)
 * (Ize 2013, "Robust BVH ray traversal") so rounding never culls a box the ray touches. */
TS_INLINE float box_enter(float ox, float oy, float oz, float ix, float iy, float iz,
                          float lox, float loy, float loz, float hix, float hiy, float hiz,
                          float tmin, float tmax)
{
    float tx0 = (lox - ox) * ix, tx1 = (hix - ox) * ix;
    float ty0 = (loy - oy) * iy, ty1 = (hiy - oy) * iy;
    float tz0 = (loz - oz) * iz, tz1 = (hiz - oz) * iz;
    /* fmin/fmax drop the NaN of 0 * inf (origin on a slab plane, zero direction). */
    float tn = fmax(fmax(fmin(tx0, tx1), fmin(ty0, ty1)), fmax(fmin(tz0, tz1), tmin));
    float tf = fmin(fmin(fmax(tx0, tx1), fmax(ty0, ty1)), fmin(fmax(tz0, tz1), tmax));
    tf *= 1.0000003576f; /* 1 + 2 * gamma(3), gamma(n) = n*eps/(1 - n*eps), eps = 2^-24 */
    return (lox <= hix && tn <= tf) ? tn : -1.0f;
}

TS_INLINE float safe_reciprocal(float d)
{
    return d != 0.0f ? 1.0f / d : (signbit(d) ? -INFINITY : INFINITY);
}

/* Per-ray set-up of the watertight ray-triangle test (Woop, Benthin, Wald 2013,
 * "Watertight Ray/Triangle Intersection"): kz is the dominant axis of the direction, kx, ky
 * the others (swapped when d[kz] < 0 to keep the winding), and the shear that maps the ray
 * onto +z. Micro-triangles of one grid share edges exactly, so a watertight test leaves no
 * crack between them. */
typedef struct ts_ray_shear {
    int kx, ky, kz;
    float sx, sy, sz;
} ts_ray_shear;

TS_INLINE float vec_axis(float x, float y, float z, int k)
{
    return k == 0 ? x : k == 1 ? y : z;
}

TS_INLINE ts_ray_shear ray_shear(float dx, float dy, float dz)
{
    ts_ray_shear s;
    float ax = fabs(dx), ay = fabs(dy), az = fabs(dz);
    s.kz = ax > ay ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2);
    s.kx = s.kz == 2 ? 0 : s.kz + 1;
    s.ky = s.kx == 2 ? 0 : s.kx + 1;
    float dk = vec_axis(dx, dy, dz, s.kz);
    if (dk < 0.0f) {
        int t = s.kx;
        s.kx = s.ky;
        s.ky = t;
    }
    s.sx = vec_axis(dx, dy, dz, s.kx) / dk;
    s.sy = vec_axis(dx, dy, dz, s.ky) / dk;
    s.sz = 1.0f / dk;
    return s;
}

/* Returns t in (tmin, tmax) and the barycentrics (b1, b2) of p1, p2, or -1 for a miss.
 * Double-sided. An edge or vertex hit counts for every triangle sharing it, so no ray
 * passes between two triangles of a grid. */
TS_INLINE float triangle_hit(const ts_ray_shear *s, float ox, float oy, float oz, ts_vec4 p0,
                             ts_vec4 p1, ts_vec4 p2, float tmin, float tmax, float *b1_out,
                             float *b2_out)
{
    float ax = vec_axis(p0.x - ox, p0.y - oy, p0.z - oz, s->kx);
    float ay = vec_axis(p0.x - ox, p0.y - oy, p0.z - oz, s->ky);
    float az = vec_axis(p0.x - ox, p0.y - oy, p0.z - oz, s->kz);
    float bx = vec_axis(p1.x - ox, p1.y - oy, p1.z - oz, s->kx);
    float by = vec_axis(p1.x - ox, p1.y - oy, p1.z - oz, s->ky);
    float bz = vec_axis(p1.x - ox, p1.y - oy, p1.z - oz, s->kz);
    float cx = vec_axis(p2.x - ox, p2.y - oy, p2.z - oz, s->kx);
    float cy = vec_axis(p2.x - ox, p2.y - oy, p2.z - oz, s->ky);
    float cz = vec_axis(p2.x - ox, p2.y - oy, p2.z - oz, s->kz);
    ax = ax - s->sx * az;
    ay = ay - s->sy * az;
    bx = bx - s->sx * bz;
    by = by - s->sy * bz;
    cx = cx - s->sx * cz;
    cy = cy - s->sy * cz;
    float u = cx * by - cy * bx, v = ax * cy - ay * cx, w = bx * ay - by * ax;
    if ((u < 0.0f || v < 0.0f || w < 0.0f) && (u > 0.0f || v > 0.0f || w > 0.0f)) return -1.0f;
    float det = u + v + w;
    if (det == 0.0f) return -1.0f;
    float t_scaled = u * (s->sz * az) + v * (s->sz * bz) + w * (s->sz * cz);
    float inv = 1.0f / det;
    float t = t_scaled * inv;
    if (!(t > tmin && t < tmax)) return -1.0f;
    *b1_out = v * inv;
    *b2_out = w * inv;
    return t;
}

#endif
