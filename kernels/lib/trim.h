/* trim.h — trimmed NURBS (RI Spec 3.2 §5.2, RiTrimCurve), shared by build.cl and the host
 * (host/scene/trim.c, host/ref/dice_build_ref.c). A trimmed patch keeps the part of its
 * parameter square that lies inside its trim curves by the odd winding (even-odd) rule: a
 * point is kept when a ray from it crosses the curves an odd number of times. The curves are
 * polylines, each segment a ts_vec4 (x0, y0, x1, y1) in the patch's own (u, v) square
 * (host/scene/trim.c trim_patch maps the surface's knot space onto it and keeps only the
 * segments a ray from inside the square towards +u can cross). build.cl keeps a micro-quad
 * where its centre is kept and gives the others empty boxes, so no ray finds them in either
 * geometry mode (bottom_level.cl quad_test checks the box before a micro-quad's triangles). */
#ifndef TS_TRIM_H
#define TS_TRIM_H

#include "lib/shared_types.h"

/* 1 when (s, t) is inside the `count` segments from seg by the even-odd rule: each segment
 * whose ends lie on either side of t (half-open: y0 < t or y1 < t, not both) and that the
 * ray from (s, t) towards +u meets to the right of s flips the answer. Float arithmetic in a
 * fixed order (FP_CONTRACT off on both sides): host and device agree bit for bit. */
TS_INLINE ts_u32 trim_keeps(TS_CONST_GLOBAL ts_vec4 *seg, ts_u32 count, float s, float t)
{
    ts_u32 odd = 0u;
    for (ts_u32 k = 0; k < count; ++k) {
        ts_vec4 e = seg[k];
        if ((e.y < t) != (e.w < t)) {
            float x = e.x + (t - e.y) / (e.w - e.y) * (e.z - e.x);
            if (x > s) odd ^= 1u;
        }
    }
    return odd;
}

#endif
