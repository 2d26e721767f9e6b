/* subdiv_mesh.h — the half-edge mesh behind scene/subdiv.c and its Catmull-Clark step
 * (scene/subdiv_refine.c); private to those two files.
 *
 * Face f owns half-edges fstart[f] .. fstart[f] + fcount[f] - 1, one per corner, in the
 * face's order: half-edge h runs from vertex from[h] to the from of the next half-edge of
 * its face. twin[h] is the half-edge running the other way in the neighbouring face, -1 on
 * the boundary. Per-face-vertex values (dim numbers) live with the half-edge of the corner.
 */
#ifndef TS_SUBDIV_MESH_H
#define TS_SUBDIV_MESH_H

#include <stddef.h>

/* Face flags: no patch (a "hole" tag, or a face on the boundary without
 * interpolateboundary); kept by refinement for the children. */
#define SD_NO_PATCH 1u

/* Vertex classes (subdiv.h). */
enum { SD_SMOOTH, SD_CREASE, SD_CORNER };

typedef struct sd_mesh {
    int npoints, nfaces, nhalf;
    double (*p)[3];
    int *fstart, *fcount, *forig; /* per face: first half-edge, count, input face */
    unsigned char *fflags;
    int *from, *hface, *twin; /* per half-edge */
    unsigned char *hsharp;    /* per half-edge: its edge is tagged sharp (both halves) */
    unsigned char *corner;    /* per vertex: tagged corner */
    double *fv;               /* per half-edge: dim values, or NULL */
    int dim;
    int interp_boundary;
    int split; /* vertices sd_topology split into one a fan (non-manifold: sheets at a point) */
    /* Derived by sd_topology. */
    int *vout;             /* per vertex: an outgoing half-edge (the boundary one), -1 unused */
    int *valence;          /* edges at the vertex */
    int *nsharp, *sharpnb; /* sharp edges at the vertex, and its first two sharp neighbours */
    unsigned char *vclass, *vbound;
} sd_mesh;

static inline int sd_next(const sd_mesh *m, int h)
{
    int f = m->hface[h];
    return h + 1 < m->fstart[f] + m->fcount[f] ? h + 1 : m->fstart[f];
}

static inline int sd_prev(const sd_mesh *m, int h)
{
    int f = m->hface[h];
    return h > m->fstart[f] ? h - 1 : m->fstart[f] + m->fcount[f] - 1;
}

static inline int sd_to(const sd_mesh *m, int h)
{
    return m->from[sd_next(m, h)];
}

/* Edge h is sharp: tagged, or on the boundary. */
static inline int sd_sharp(const sd_mesh *m, int h)
{
    return m->hsharp[h] || m->twin[h] < 0;
}

/* Allocates the arrays of a mesh of np points, nf faces and nh half-edges (dim values per
 * half-edge when dim > 0); 0 when out of memory. */
int sd_alloc(sd_mesh *m, int np, int nf, int nh, int dim);
void sd_free(sd_mesh *m);

/* Twins, vertices split into one a fan (sheets meeting at a point: sharp corners), one outgoing
 * half-edge per vertex, valences, sharp edges and vertex classes. Fails (TS_E_SCENE, why) for
 * an edge of more than two faces or inconsistently oriented faces. */
int sd_topology(sd_mesh *m, char *why, size_t len);

/* One Catmull-Clark step (subdiv_refine.c): every face of `in` (after sd_topology) becomes
 * quads in `out` (before sd_topology), sharp edges and corners carried to the children,
 * face flags and input faces inherited, face-vertex values interpolated linearly. */
int sd_refine(const sd_mesh *in, sd_mesh *out);

#endif
