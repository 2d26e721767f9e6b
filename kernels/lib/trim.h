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
#include "lib/texture.h"

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

/* Whether micro-quads of patch a may be removed: it is trimmed (trim_count) or cut out by a
 * mask (TS_PATCH_CUTOUT); the segments diced from it get TS_SEG_TRIMMED. */
TS_INLINE int patch_has_holes(TS_CONST_GLOBAL ts_patch_attr *a)
{
    return a->trim_count != 0u || (a->flags & TS_PATCH_CUTOUT) != 0u;
}

/* Whether patch a keeps its point (u, v): inside its trim curves (trim_keeps, when it has any)
 * and where its cutout mask keeps it (lib/texture.h tex_cutout_keeps). build_leaves and the
 * host's reference ask it at each micro-quad's centre. */
TS_INLINE int patch_keeps(TS_CONST_GLOBAL ts_patch_attr *a, TS_CONST_GLOBAL ts_vec4 *trim_seg,
                          ts_tex_ctx tex, float u, float v)
{
    return (a->trim_count == 0u || trim_keeps(trim_seg + a->trim_first, a->trim_count, u, v)) &&
           tex_cutout_keeps(a, tex, u, v);
}

#endif
