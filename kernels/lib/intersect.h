/* intersect.h — ray-box and ray-triangle tests shared by the kernels and the host
 * references. Both are written for bitwise agreement between host and device (no FMA,
 * fixed operation order). */
#ifndef TS_INTERSECT_H
#define TS_INTERSECT_H

#include "lib/shared_types.h"

#ifndef __OPENCL_C_VERSION__
#include <math.h>
#endif

/* Minimum and maximum without NaN handling: one instruction each, where OpenCL's fmin/fmax
 * cost a compare, an unordered check and a blend. Safe here because no operand is NaN: see
 * safe_reciprocal. */
#define TS_MIN(a, b) ((a) < (b) ? (a) : (b))
#define TS_MAX(a, b) ((a) > (b) ? (a) : (b))

/* Slab test of [tmin, tmax] against a box, with reciprocal direction `inv` from
 * safe_reciprocal. Returns the entry distance, or -1 for a miss. tfar is widened by
 * 1 + 2*gamma(3) (Ize 2013, "Robust BVH ray traversal") so rounding never culls a box the
 * ray touches. */
TS_INLINE float box_enter(float ox, float oy, float oz, float ix, float iy, float iz, float lox,
                          float loy, float loz, float hix, float hiy, float hiz, float tmin,
                          float tmax)
{
    float tx0 = (lox - ox) * ix, tx1 = (hix - ox) * ix;
    float ty0 = (loy - oy) * iy, ty1 = (hiy - oy) * iy;
    float tz0 = (loz - oz) * iz, tz1 = (hiz - oz) * iz;
    float tn = TS_MAX(TS_MAX(TS_MIN(tx0, tx1), TS_MIN(ty0, ty1)), TS_MAX(TS_MIN(tz0, tz1), tmin));
    float tf = TS_MIN(TS_MIN(TS_MAX(tx0, tx1), TS_MAX(ty0, ty1)), TS_MIN(TS_MAX(tz0, tz1), tmax));
    tf *= 1.0000003576f; /* 1 + 2 * gamma(3), gamma(n) = n*eps/(1 - n*eps), eps = 2^-24 */
    return (lox <= hix && tn <= tf) ? tn : -1.0f;
}

/* 1/d, with zero (and tiny) components mapped to +-1e30 instead of infinity, so a slab
 * product is never 0 * inf = NaN: a ray with origin on a slab plane and no motion across it
 * gets the interval [0, +-big] there, i.e. it is inside that slab. */
TS_INLINE float safe_reciprocal(float d)
{
    float r = d != 0.0f ? 1.0f / d : 1e30f;
    return fabs(r) < 1e30f ? r : (signbit(d) ? -1e30f : 1e30f);
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

/* The watertight test on vertices already relative to the ray origin and permuted to
 * (kx, ky, kz) (ray_shear). Returns t in (tmin, tmax) and the barycentrics (b1, b2) of the
 * second and third vertex, or -1 for a miss. Double-sided. An edge or vertex hit counts
 * for every triangle sharing it, so no ray passes between two triangles of a grid. */
TS_INLINE float triangle_hit_permuted(const ts_ray_shear *s, float ax, float ay, float az, float bx,
                                      float by, float bz, float cx, float cy, float cz, float tmin,
                                      float tmax, float *b1_out, float *b2_out)
{
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

/* triangle_hit_permuted for world-space vertices p0, p1, p2 and ray origin o. */
TS_INLINE float triangle_hit(const ts_ray_shear *s, float ox, float oy, float oz, ts_vec4 p0,
                             ts_vec4 p1, ts_vec4 p2, float tmin, float tmax, float *b1_out,
                             float *b2_out)
{
    float ax = p0.x - ox, ay = p0.y - oy, az = p0.z - oz;
    float bx = p1.x - ox, by = p1.y - oy, bz = p1.z - oz;
    float cx = p2.x - ox, cy = p2.y - oy, cz = p2.z - oz;
    return triangle_hit_permuted(s, vec_axis(ax, ay, az, s->kx), vec_axis(ax, ay, az, s->ky),
                                 vec_axis(ax, ay, az, s->kz), vec_axis(bx, by, bz, s->kx),
                                 vec_axis(bx, by, bz, s->ky), vec_axis(bx, by, bz, s->kz),
                                 vec_axis(cx, cy, cz, s->kx), vec_axis(cx, cy, cz, s->ky),
                                 vec_axis(cx, cy, cz, s->kz), tmin, tmax, b1_out, b2_out);
}

#endif
