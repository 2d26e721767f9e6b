/* nurbs.h — NURBS surfaces (RI Spec 3.2 §5.2, RiNuPatch) as bicubic Bézier patches.
 *
 * The control net is refined by knot insertion (Boehm 1980) until every distinct knot in
 * (umin, umax), and umin and umax themselves, have multiplicity degree in each direction;
 * each non-empty knot span inside [umin, umax] x [vmin, vmax] is then one Bézier piece
 * whose control points are a window of the refined net, so neighbouring pieces share their
 * boundary points exactly. Orders 2 and 3 are degree-elevated to cubic exactly; orders
 * above 4 (and order 1, a step function) are refused.
 *
 * Polynomial NURBS (all weights equal, "P") give exact patches. Rational ones (weights that
 * differ, "Pw") are approximated: each piece, and all pieces alike, is split into
 * 2^Lu x 2^Lv sub-squares of its parameter domain, each replaced by the bicubic
 * interpolating the rational surface at its 4 x 4 nodes (thirds). The levels grow from
 * (0, 0) one at a time, in the direction whose split lowers the bound more, until the
 * error bound of every sub-square is at most NURBS_TOL_REL times the diagonal of the box of
 * the (dehomogenised) control points (a quarter circle of a rational quadratic takes 4
 * sub-squares along it), or no finer split fits NURBS_MAX_LEVEL and NURBS_MAX_PATCHES (the
 * caller then warns with the bound reached). The bound is rigorous: with the rational patch N / W
 * (homogeneous Bézier net of the sub-square), |N / W - Q| = |N - Q W| / W <= max_k |c_k| /
 * min_k w_k, c the degree-6 Bernstein coefficients of N - Q W and w those of W (positive
 * weights). Nodes on an edge depend only on that edge, so neighbours stay crack-free.
 */
#ifndef TS_NURBS_H
#define TS_NURBS_H

#include <stddef.h>

#define NURBS_MAX_ORDER 4
#define NURBS_TOL_REL 1e-4      /* rational pieces: error / box diagonal */
#define NURBS_MAX_LEVEL 4       /* at most 16 sub-squares per direction and rational piece */
#define NURBS_MAX_PATCHES 32768 /* and at most this many patches per rational surface */

/* A NURBS surface as RiNuPatch gives it: nu x nv control points (u fastest) in homogeneous
 * form (x w, y w, z w, w), knot vectors of nu + uorder and nv + vorder values. */
typedef struct ts_nurbs {
    int nu, uorder, nv, vorder;
    const double *uknot, *vknot;
    double umin, umax, vmin, vmax;
    const double *pw;
} ts_nurbs;

/* What nurbs_patches did: patches emitted, the split levels of rational pieces and the
 * largest error bound (relative to the diagonal; 0 for polynomial surfaces). */
typedef struct nurbs_result {
    int patches, level_u, level_v, rational;
    double bound;
} nurbs_result;

/* Receives one patch: 16 object-space Bézier points (u fastest), the knot-space (u, v) of
 * its corners (0,0), (1,0), (0,1), (1,1), and the RI Spec segment (the original knot span,
 * 0 .. nu - uorder) it lies in, per direction. A non-zero return stops nurbs_patches. */
typedef int (*nurbs_patch_fn)(void *ctx, const double cp[16][3], const double uv[4][2], int seg_u,
                              int seg_v);

/* Checks the surface: orders in [2, NURBS_MAX_ORDER], at least `order` control points,
 * non-decreasing knots, positive weights, a parameter range that overlaps the valid one
 * ([knot[order - 1], knot[n]]; umin and umax are clamped to it). Returns TS_OK or
 * TS_E_SCENE with `why` set ("uorder 5 is not supported (at most 4, cubic)"). */
int nurbs_check(const ts_nurbs *s, char *why, size_t why_len);
/* One direction's part of it, also a trim curve's (scene/trim.c): order in [2,
 * NURBS_MAX_ORDER], at least `order` points, knots that do not decrease, and [*lo, *hi]
 * meeting [knot[order - 1], knot[n]], clamped to it; `dir` ("u", "v" or "") begins the names
 * in `why`. */
int nurbs_check_knots(int n, int order, const double *knot, double *lo, double *hi, const char *dir,
                      char *why, size_t why_len);

/* Emits the patches of a checked surface through fn. Returns TS_OK, TS_E_MEMORY (why
 * set) or fn's code. */
int nurbs_patches(const ts_nurbs *s, nurbs_patch_fn fn, void *ctx, nurbs_result *res, char *why,
                  size_t why_len);

#endif
