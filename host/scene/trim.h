/* trim.h — trim curves of NURBS surfaces (RI Spec 3.2 §5.2, RiTrimCurve) on the host.
 *
 * A trim curve is a set of closed loops, each of NURBS curves joined head to tail, in the
 * homogeneous parameter space (u w, v w, w) of the surfaces that follow it. Each curve is
 * turned into a polyline once (trim_make: TRIM_SPAN_STEPS chords per non-empty knot span of
 * order 3 or 4, one per span of order 2, whose rational segments are straight), so a trim is
 * a set of segments in knot space. Where a loop does not end where it began, a closing
 * segment joins it. A point of the surface is kept when it lies inside an odd number of
 * loops' crossings (the odd winding rule; lib/trim.h trim_keeps), as Aqsis reads it: a lone
 * loop keeps what it encloses, a loop inside it cuts a hole.
 *
 * Each Bézier piece of a trimmed NuPatch (a rectangle of knot space) is then either kept
 * whole, dropped whole (no segment crosses it: the centre decides), or given the segments
 * that can decide its micro-quads (trim_piece), mapped onto its own (u, v) square. */
#ifndef TS_TRIM_H_HOST
#define TS_TRIM_H_HOST

#include "base/error.h"
#include "lib/shared_types.h"

#include <stddef.h>
#include <stdint.h>

#define TRIM_SPAN_STEPS 16      /* chords per knot span of a curve of order 3 or 4 */
#define TRIM_MAX_SEGMENTS 65536 /* segments of one TrimCurve at most */

/* RiTrimCurve's arguments (rib_trim.c reads them): nloops loops of ncurves[l] curves; curve c
 * of order[c] with n[c] control points (u, v, w) and n[c] + order[c] knots, drawn over
 * [min[c], max[c]] (clamped to its valid range). The arrays concatenate every curve's values
 * in loop order. */
typedef struct trim_curves {
    int nloops;
    const double *ncurves, *order, *n; /* whole numbers (rib_int_array checked them) */
    const double *knot, *min, *max, *u, *v, *w;
} trim_curves;

/* A trim as segments (x0, y0, x1, y1) in knot space, doubles; a loop's segments follow each
 * other. */
typedef struct trim_set {
    double (*seg)[4];
    uint32_t count;
} trim_set;

/* Checks the curves (as a NURBS direction is checked, nurbs_check_knots: orders 2 to 4, at
 * least `order` points, knots that do not decrease, a parameter range that meets the valid one;
 * and positive weights, at most TRIM_MAX_SEGMENTS segments) and makes the polylines.
 * TS_E_SCENE with `why` set ("curve 3: order 5 is not supported (at most 4, cubic)");
 * TS_E_MEMORY. */
int trim_make(const trim_curves *c, trim_set *out, char *why, size_t why_len);
void trim_set_free(trim_set *t);

/* What trim_piece decided for a piece. */
enum { TRIM_DROP = 0, TRIM_KEEP = 1, TRIM_PARTIAL = 2 };

/* The piece spanning knot space [u0, u1] x [v0, v1] (u0 < u1, v0 < v1): TRIM_DROP or
 * TRIM_KEEP when no segment meets its rectangle (its centre inside or not), else
 * TRIM_PARTIAL with the *count segments a ray from a point of its square towards +u can cross,
 * mapped to the square ((u - u0) / (u1 - u0), (v - v0) / (v1 - v0)), in out (room for
 * t->count). */
int trim_piece(const trim_set *t, double u0, double v0, double u1, double v1, ts_vec4 *out,
               uint32_t *count);

/* h folded with the scene's trims (each patch's segment range, the segments), when it has any:
 * the hashes of baked files and of resumable renders (scene.h trim_seg). */
struct ts_scene;
uint64_t trim_hash(const struct ts_scene *s, uint64_t h);

#endif
