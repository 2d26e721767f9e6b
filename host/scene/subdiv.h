/* subdiv.h — Catmull-Clark subdivision surfaces (RI Spec 3.2 §5.3, RiSubdivisionMesh
 * "catmull-clark") as bicubic Bézier patches, one per quad.
 *
 * A mesh with faces that are not quads first gets one step of real Catmull-Clark
 * subdivision (with the crease rules below), after which every face is a quad. Each quad
 * then becomes the bicubic patch of Loop and Schaefer's approximation (ACC, "Approximating
 * Catmull-Clark Subdivision Surfaces with Bicubic Patches", 2008): corner points are the
 * limit positions of its vertices, edge points come from the two faces of the edge, inner
 * points from the face, with stencils that reduce to the B-spline-to-Bézier conversion
 * where the vertices have valence 4. So:
 *   - a regular face (four smooth valence-4 vertices, creases and boundaries only as the
 *     B-spline rules below allow) is exactly its bicubic B-spline patch, i.e. exactly the
 *     Catmull-Clark limit surface there;
 *   - faces at extraordinary vertices are approximated; neighbours share corner points
 *     and edge curves bit for bit (each is computed once, from data both faces see), so
 *     the surface has no cracks.
 *
 * Sharp features (infinitely sharp, DeRose et al. 1998): an edge is sharp when a "crease"
 * tags it or it lies on the boundary. A vertex with 3 or more sharp edges, or tagged
 * "corner", or a boundary vertex of a single face under interpolateboundary 1, is a corner
 * (limit = the vertex); with exactly 2 it is a crease vertex (limit (a + 4 v + b) / 6 on
 * the cubic B-spline through the crease); with 0 or 1 (a dart) it is smooth. On sharp
 * edges the edge points are those of that B-spline, (2 v + w) / 3; smooth edges leaving a
 * crease vertex take 2/3 of its limit and 1/3 of the far side's B-spline average, which is
 * exact for regular boundary and crease configurations. Without interpolateboundary, faces
 * touching the boundary give no patch (they only steer their neighbours), as in RenderMan.
 * Faces tagged "hole" give no patch either.
 */
#ifndef TS_SUBDIV_H
#define TS_SUBDIV_H

#include <stddef.h>

/* A mesh as RiSubdivisionMesh gives it, tags already resolved. */
typedef struct subdiv_input {
    int nfaces;
    const int *nverts; /* vertices per face (>= 3) */
    const int *verts;  /* the faces' vertex indices, one after the other */
    int npoints;
    const double (*p)[3];
    const int *creases; /* ncreases sharp edges as vertex pairs (2 ncreases ints) */
    int ncreases;
    const int *corners; /* vertices tagged as corners */
    int ncorners;
    const int *holes; /* faces that give no patch */
    int nholes;
    int interp_boundary; /* 0: boundary faces give no patch; 1: edges and corners; 2: edges */
    const double *fv;    /* fv_dim values per face-vertex carried to the patches, or NULL */
    int fv_dim;
} subdiv_input;

/* What subdiv_patches did. */
typedef struct subdiv_result {
    int patches;
    int refined;        /* 1 when the mesh had faces other than quads */
    int creases_unused; /* crease edges that are not edges of the mesh */
    int split;          /* vertices whose faces form several fans, split into sharp corners */
} subdiv_result;

/* Receives one patch: 16 object-space Bézier points (u fastest), the face-vertex values
 * at its corners (0,0), (1,0), (0,1), (1,1) (4 fv_dim values, linearly interpolated over a
 * refined face; NULL without fv) and the input face it lies in. A non-zero return stops
 * subdiv_patches. */
typedef int (*subdiv_patch_fn)(void *ctx, const double cp[16][3], const double *fv, int face);

/* Emits the patches of mesh m through fn (corner normals are left to scene_finalize: the
 * patches share their corners exactly). A vertex whose faces form several fans (sheets that
 * meet only there) is split into one sharp corner a fan, at its position (res->split counts
 * them). Returns TS_OK, fn's code, TS_E_MEMORY, or TS_E_SCENE with `why` set for an edge of
 * more than two faces or inconsistently oriented faces ("edge 3-7 is used twice in the same
 * direction (faces 2 and 5) ...") or a face that repeats a vertex. Indices must be in range
 * (the caller checks them). */
int subdiv_patches(const subdiv_input *m, subdiv_patch_fn fn, void *ctx, subdiv_result *res,
                   char *why, size_t why_len);

#endif
