/* polygon.h — polygons, with holes, as curved bicubic Bézier patches built from their vertex
 * normals (PN patches, Vlachos et al. 2001): the one construction behind Assimp meshes
 * (mesh.c) and the RIB polygon requests (rib_poly.c).
 *
 * A triangle becomes one bicubic patch with a collapsed edge, a convex quad one patch, any
 * other polygon (concave quads, more vertices, holes) is triangulated by ear clipping in the
 * plane of its Newell normal, holes first joined to the outline by bridge edges (Eberly,
 * "Triangulation by Ear Clipping", 2002). The patches interpolate the vertices, their
 * tangent planes there are perpendicular to the vertex normals, and a patch edge depends
 * only on its two end vertices and their normals, so patches that share an edge (and its
 * normals) meet without a gap. Given no normals, every vertex takes the polygon's own
 * normal: the patches are then flat, the polygon stays a polygon, and neighbouring
 * polygons keep their hard edges. docs/rib.md ("Meshes") has the construction.
 */
#ifndef TS_POLYGON_H
#define TS_POLYGON_H

#include "base/error.h"

/* One polygon: `count` vertices in `loops` loops one after the other, loop 0 the outline,
 * the others holes (any orientation: holes are taken opposite to the outline). */
typedef struct poly_face {
    const double (*p)[3];     /* positions */
    const double (*n)[3];     /* unit normals, or NULL for the polygon's normal everywhere; a
                               * zero normal also takes the polygon's */
    const unsigned *loop_len; /* vertices per loop; NULL: one loop of `count` */
    unsigned loops, count;
} poly_face;

/* Receives one patch: 16 Bézier points (u fastest), its four corner normals in the corner
 * order (0,0), (1,0), (0,1), (1,1), and the polygon vertex (index into p) at each corner;
 * a triangle's collapsed corner (1,1) repeats (0,1). A non-zero return stops
 * poly_patches, which returns it. */
typedef int (*poly_patch_fn)(void *ctx, const double cp[16][3], const double cn[4][3],
                             const unsigned corner[4]);

/* Emits the patches of polygon f through fn. Pieces of zero area are skipped and counted
 * in *skipped (if not NULL); a polygon of zero area emits nothing. Returns TS_OK,
 * TS_E_MEMORY (err set) or fn's code. */
int poly_patches(const poly_face *f, poly_patch_fn fn, void *ctx, unsigned *skipped, ts_error *err);

/* The unit Newell normal of the loop p[0..n): robust for non-planar and concave polygons,
 * oriented by the right-hand rule; zero for a loop of zero area. Returns its length before
 * normalisation (twice the area of a planar loop). */
double poly_normal(const double (*p)[3], unsigned n, double out[3]);

/* The PN patch of a quad: p and n are its four vertices and unit normals in polygon order
 * (v0, v1, v2, v3), which become the corners (u, v) = (0,0), (1,0), (1,1), (0,1).
 * Boundary control points by the PN edge rule b_ij = (2 P_i + P_j - w_ij N_i) / 3 with
 * w_ij = (P_j - P_i) . N_i; interior points from the bilinearly blended Coons patch of the
 * four boundary curves. cp: 16 points, u fastest. */
void poly_pn_quad(const double p[4][3], const double n[4][3], double cp[16][3]);

/* The PN triangle of Vlachos et al. (vertices p, unit normals n, edge points as above,
 * centre point E + (E - V) / 2) written exactly as a bicubic patch with its v = 1 edge
 * collapsed: corners (0,0) = p[0], (1,0) = p[1], (0,1) = (1,1) = p[2]. */
void poly_pn_triangle(const double p[3][3], const double n[3][3], double cp[16][3]);

#endif
