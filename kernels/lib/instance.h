/* instance.h — a ray moved into the frame of the master patch an instance shares its dicing
 * with (ObjectInstance, host/scene/instance.c, docs/rib.md "Objects").
 *
 * An instance patch p whose shape is another patch q (ts_segment.shape) is traced through
 * q's diced grid and tree: its ray goes through the affine map A (world of p -> world of q,
 * rigid: host/scene/instance.c only shares where A's linear part is orthonormal). The
 * direction is mapped by A's linear part and not normalised, so a distance t along the
 * moved ray is the same t along the original one: hits, tmin (org.w) and tmax need no
 * conversion. w of both (tmin, time) is kept. Used by kernels/bottom_level.cl and by its
 * host reference (host/ref/bottom_level_ref.c), so both round the same. */
#ifndef TS_INSTANCE_H
#define TS_INSTANCE_H

#include "lib/shared_types.h"

/* o and d (xyz) through x: o as a point, d as a direction. */
TS_INLINE void instance_ray(TS_CONST_GLOBAL ts_xform *x, ts_vec4 *o, ts_vec4 *d)
{
    float ox = x->r0[0] * o->x + x->r0[1] * o->y + x->r0[2] * o->z + x->r0[3];
    float oy = x->r1[0] * o->x + x->r1[1] * o->y + x->r1[2] * o->z + x->r1[3];
    float oz = x->r2[0] * o->x + x->r2[1] * o->y + x->r2[2] * o->z + x->r2[3];
    float dx = x->r0[0] * d->x + x->r0[1] * d->y + x->r0[2] * d->z;
    float dy = x->r1[0] * d->x + x->r1[1] * d->y + x->r1[2] * d->z;
    float dz = x->r2[0] * d->x + x->r2[1] * d->y + x->r2[2] * d->z;
    o->x = ox, o->y = oy, o->z = oz;
    d->x = dx, d->y = dy, d->z = dz;
}

#endif
