/* subdiv_refine.c — one step of Catmull-Clark subdivision (Catmull and Clark 1978) with
 * infinitely sharp edges and corners (DeRose, Kass and Truong 1998), for meshes with faces
 * other than quads: afterwards every face is a quad (see subdiv_mesh.h).
 *
 *   face point    the average of the face's vertices
 *   edge point    sharp edge: its midpoint; smooth: (v + w + the two face points) / 4
 *   vertex point  corner: v; crease: (a + 6 v + b) / 8 (a, b its sharp neighbours);
 *                 smooth of valence n: (Q + 2 R + (n - 3) v) / n, Q the average of the
 *                 face points around it, R of the midpoints of its edges
 *
 * New points: vertex points 0 .. np-1, face points np .. np+nf-1, then one edge point per
 * edge. Face f gives one quad per corner k: (vertex point of v_k, edge point of edge k,
 * face point, edge point of edge k-1), in f's orientation. */
#include "scene/subdiv_mesh.h"

#include "base/error.h"

#include <stdlib.h>
#include <string.h>

/* Edge numbers: each undirected edge once, both halves sharing it. */
static int sd_edge_ids(const sd_mesh *m, int *eid)
{
    int ne = 0;
    for (int h = 0; h < m->nhalf; h++)
        if (m->twin[h] < 0 || h < m->twin[h]) {
            eid[h] = ne;
            if (m->twin[h] >= 0) eid[m->twin[h]] = ne;
            ne++;
        }
    return ne;
}

static void sd_avg(double *out, const double *a, const double *b, double wa, double wb)
{
    for (int d = 0; d < 3; d++)
        out[d] = wa * a[d] + wb * b[d];
}

/* The vertex point of v into out (face points fp). */
static void sd_vertex_point(const sd_mesh *m, int v, const double (*fp)[3], double out[3])
{
    const double *pv = m->p[v];
    if (m->vout[v] < 0 || m->vclass[v] == SD_CORNER) {
        memcpy(out, pv, 3 * sizeof *out);
        return;
    }
    if (m->vclass[v] == SD_CREASE) {
        const double *a = m->p[m->sharpnb[2 * v]], *b = m->p[m->sharpnb[2 * v + 1]];
        for (int d = 0; d < 3; d++)
            out[d] = (a[d] + 6.0 * pv[d] + b[d]) / 8.0;
        return;
    }
    double q[3] = {0, 0, 0}, r[3] = {0, 0, 0};
    int h = m->vout[v], faces = 0;
    do { /* smooth vertices are interior: faces and edges alternate */
        const double *w = m->p[sd_to(m, h)];
        for (int d = 0; d < 3; d++)
            q[d] += fp[m->hface[h]][d], r[d] += 0.5 * (pv[d] + w[d]);
        faces++;
        h = m->twin[sd_prev(m, h)];
    } while (h >= 0 && h != m->vout[v]);
    const double n = faces;
    for (int d = 0; d < 3; d++)
        out[d] = (q[d] / n + 2.0 * r[d] / n + (n - 3.0) * pv[d]) / n;
}

/* The new points: vertex points, face points, edge points. */
static void sd_new_points(const sd_mesh *in, const int *eid, sd_mesh *out)
{
    const int np = in->npoints, nf = in->nfaces;
    double(*fp)[3] = out->p + np;
    for (int f = 0; f < nf; f++) {
        fp[f][0] = fp[f][1] = fp[f][2] = 0.0;
        for (int k = 0; k < in->fcount[f]; k++)
            for (int d = 0; d < 3; d++)
                fp[f][d] += in->p[in->from[in->fstart[f] + k]][d] / in->fcount[f];
    }
    for (int v = 0; v < np; v++) {
        sd_vertex_point(in, v, (const double(*)[3])fp, out->p[v]);
        out->corner[v] = in->corner[v];
    }
    for (int h = 0; h < in->nhalf; h++) {
        if (!(in->twin[h] < 0 || h < in->twin[h])) continue;
        double *e = out->p[np + nf + eid[h]];
        const double *v = in->p[in->from[h]], *w = in->p[sd_to(in, h)];
        if (sd_sharp(in, h)) {
            sd_avg(e, v, w, 0.5, 0.5);
        } else {
            const double *f = fp[in->hface[h]], *g = fp[in->hface[in->twin[h]]];
            for (int d = 0; d < 3; d++)
                e[d] = 0.25 * (v[d] + w[d] + f[d] + g[d]);
        }
    }
}

/* Face-vertex values of the child quad at corner h of its face: the corner's, the
 * midpoints of its two edges', the face average. */
static void sd_child_fv(const sd_mesh *in, int h, double *out)
{
    const int D = in->dim, f = in->hface[h], nx = sd_next(in, h), pv = sd_prev(in, h);
    const double *a = in->fv + (size_t)h * D, *b = in->fv + (size_t)nx * D,
                 *z = in->fv + (size_t)pv * D;
    for (int d = 0; d < D; d++) {
        double c = 0.0;
        for (int k = 0; k < in->fcount[f]; k++)
            c += in->fv[(size_t)(in->fstart[f] + k) * D + d] / in->fcount[f];
        out[d] = a[d];
        out[D + d] = 0.5 * (a[d] + b[d]);
        out[2 * D + d] = c;
        out[3 * D + d] = 0.5 * (z[d] + a[d]);
    }
}

int sd_refine(const sd_mesh *in, sd_mesh *out)
{
    int *eid = malloc(((size_t)in->nhalf + 1) * sizeof *eid);
    if (!eid) return TS_E_MEMORY;
    const int ne = sd_edge_ids(in, eid), np = in->npoints, nf = in->nfaces;
    if (!sd_alloc(out, np + nf + ne, in->nhalf, 4 * in->nhalf, in->fv ? in->dim : 0)) {
        free(eid);
        sd_free(out);
        return TS_E_MEMORY;
    }
    out->interp_boundary = in->interp_boundary;
    sd_new_points(in, eid, out);
    for (int h = 0; h < in->nhalf; h++) { /* child face h: the quad at corner h */
        const int f = in->hface[h], pv = sd_prev(in, h), o = 4 * h;
        const int quad[4] = {in->from[h], np + nf + eid[h], np + f, np + nf + eid[pv]};
        out->fstart[h] = o, out->fcount[h] = 4;
        out->forig[h] = in->forig[f], out->fflags[h] = in->fflags[f];
        for (int k = 0; k < 4; k++)
            out->from[o + k] = quad[k], out->hface[o + k] = h;
        out->hsharp[o] = in->hsharp[h];      /* half of edge h */
        out->hsharp[o + 3] = in->hsharp[pv]; /* half of edge pv */
        if (in->fv) sd_child_fv(in, h, out->fv + (size_t)o * in->dim);
    }
    free(eid);
    return TS_OK;
}
