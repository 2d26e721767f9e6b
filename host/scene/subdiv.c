/* subdiv.c — Catmull-Clark meshes as bicubic patches (see subdiv.h): the half-edge mesh,
 * its topology and vertex classes, limit positions, and the Loop-Schaefer (ACC) geometry
 * patch of every quad with the crease and boundary rules.
 *
 * Stencils for a vertex v of valence n with edge neighbours e_i and, in each quad around
 * it, the opposite vertex f_i (Loop and Schaefer 2008, §3):
 *   corner (limit) point   (n^2 v + 4 sum e_i + sum f_i) / (n (n + 5))
 *   edge point on v-w      (2n v + 4 w + 2 (x + x') + (y + y')) / (2n + 10)
 *                          x, x': v's other neighbours in the two faces of the edge,
 *                          y, y': w's other neighbours there
 *   inner point in face    (n v + 2 (a + b) + c) / (n + 5), a, b v's neighbours in the
 *                          face, c the opposite vertex
 * For n = 4 these are the B-spline-to-Bézier conversion. Crease and corner vertices use
 * the boundary B-spline instead (subdiv.h): limit (a + 4 v + b) / 6 or v, sharp edge
 * points (2 v + w) / 3, smooth edge points 2/3 limit + 1/3 (y + 4 w + y') / 6, inner
 * points with n = 4. */
#include "scene/subdiv.h"

#include "base/error.h"
#include "scene/subdiv_mesh.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- storage ---------------------------------------------------------------------------- */

int sd_alloc(sd_mesh *m, int np, int nf, int nh, int dim)
{
    memset(m, 0, sizeof *m);
    m->npoints = np, m->nfaces = nf, m->nhalf = nh, m->dim = dim;
    size_t P = (size_t)np + 1, F = (size_t)nf + 1, H = (size_t)nh + 1;
    m->p = malloc(P * sizeof *m->p);
    m->fstart = malloc(F * sizeof *m->fstart), m->fcount = malloc(F * sizeof *m->fcount);
    m->forig = malloc(F * sizeof *m->forig), m->fflags = calloc(F, 1);
    m->from = malloc(H * sizeof *m->from), m->hface = malloc(H * sizeof *m->hface);
    m->twin = malloc(H * sizeof *m->twin), m->hsharp = calloc(H, 1);
    m->corner = calloc(P, 1);
    m->fv = dim > 0 ? malloc(H * (size_t)dim * sizeof *m->fv) : NULL;
    m->vout = malloc(P * sizeof *m->vout), m->valence = calloc(P, sizeof *m->valence);
    m->nsharp = calloc(P, sizeof *m->nsharp), m->sharpnb = malloc(2 * P * sizeof *m->sharpnb);
    m->vclass = calloc(P, 1), m->vbound = calloc(P, 1);
    return m->p && m->fstart && m->fcount && m->forig && m->fflags && m->from && m->hface &&
           m->twin && m->hsharp && m->corner && (dim <= 0 || m->fv) && m->vout && m->valence &&
           m->nsharp && m->sharpnb && m->vclass && m->vbound;
}

void sd_free(sd_mesh *m)
{
    free(m->p), free(m->fstart), free(m->fcount), free(m->forig), free(m->fflags);
    free(m->from), free(m->hface), free(m->twin), free(m->hsharp), free(m->corner), free(m->fv);
    free(m->vout), free(m->valence), free(m->nsharp), free(m->sharpnb), free(m->vclass);
    free(m->vbound);
    memset(m, 0, sizeof *m);
}

/* ---- directed edges: (from, to) -> half-edge, open addressing ----------------------------- */

typedef struct sd_edges {
    uint64_t *key; /* (from + 1) << 32 | (to + 1); 0 empty */
    int *half;
    size_t mask;
} sd_edges;

static uint64_t sd_key(int a, int b)
{
    return ((uint64_t)(uint32_t)(a + 1) << 32) | (uint32_t)(b + 1);
}

static size_t sd_slot(const sd_edges *e, uint64_t k)
{
    uint64_t h = k * 0x9e3779b97f4a7c15ull;
    size_t i = (size_t)(h >> 17) & e->mask;
    while (e->key[i] && e->key[i] != k)
        i = (i + 1) & e->mask;
    return i;
}

/* The twins of every half-edge; TS_E_SCENE when a directed edge appears twice. */
static int sd_twins(sd_mesh *m, char *why, size_t len)
{
    sd_edges e;
    size_t cap = 16;
    while (cap < 2 * (size_t)m->nhalf)
        cap *= 2;
    e.key = calloc(cap, sizeof *e.key), e.half = malloc(cap * sizeof *e.half), e.mask = cap - 1;
    int rc = e.key && e.half ? TS_OK : TS_E_MEMORY;
    for (int h = 0; rc == TS_OK && h < m->nhalf; h++) {
        size_t i = sd_slot(&e, sd_key(m->from[h], sd_to(m, h)));
        if (e.key[i]) {
            snprintf(why, len,
                     "edge %d-%d is used twice in the same direction (faces %d and %d): the mesh "
                     "is not manifold or its faces are not consistently oriented",
                     m->from[h], sd_to(m, h), m->forig[m->hface[e.half[i]]], m->forig[m->hface[h]]);
            rc = TS_E_SCENE;
        }
        e.key[i] = sd_key(m->from[h], sd_to(m, h)), e.half[i] = h;
    }
    for (int h = 0; rc == TS_OK && h < m->nhalf; h++) {
        size_t i = sd_slot(&e, sd_key(sd_to(m, h), m->from[h]));
        m->twin[h] = e.key[i] ? e.half[i] : -1;
    }
    free(e.key), free(e.half);
    return rc;
}

/* ---- topology ------------------------------------------------------------------------------ */

/* Room for np points in every per-vertex array (the new ones zeroed). 0 when out of memory. */
static int sd_grow_points(sd_mesh *m, int np)
{
    size_t P = (size_t)np + 1, old = (size_t)m->npoints + 1;
#define SD_GROW(f, n)                                                                              \
    do {                                                                                           \
        void *q = realloc(m->f, (n)*P * sizeof *m->f);                                             \
        if (!q) return 0;                                                                          \
        m->f = q;                                                                                  \
        memset(m->f + (n)*old, 0, (n) * (P - old) * sizeof *m->f);                                 \
    } while (0)
    SD_GROW(p, 1);
    SD_GROW(corner, 1);
    SD_GROW(vout, 1);
    SD_GROW(valence, 1);
    SD_GROW(nsharp, 1);
    SD_GROW(sharpnb, 2);
    SD_GROW(vclass, 1);
    SD_GROW(vbound, 1);
#undef SD_GROW
    m->npoints = np;
    return 1;
}

/* A vertex whose faces form several fans (sheets that meet at a point: not a manifold there)
 * becomes one vertex a fan: the first fan keeps it, each other fan gets a copy at the same
 * position, and all of them are tagged corners, so each fan is a manifold neighbourhood with
 * the point as its limit and the sheets still meet there (OpenSubdiv makes such a vertex
 * infinitely sharp too). The twins stay as they were: an edge at the vertex lies in one fan.
 * Counts the vertices split in m->split; TS_E_MEMORY when out of memory. */
static int sd_split_fans(sd_mesh *m)
{
    int *fan = malloc(((size_t)m->nhalf + 1) * sizeof *fan);
    unsigned char *seen = calloc((size_t)m->npoints + 1, 1);
    int added = 0, np = m->npoints, rc = fan && seen ? TS_OK : TS_E_MEMORY;
    for (int h = 0; rc == TS_OK && h < m->nhalf; h++)
        fan[h] = -1;
    for (int h = 0; rc == TS_OK && h < m->nhalf; h++) {
        if (fan[h] >= 0) continue;
        int v = m->from[h], id = seen[v] ? np + added++ : v;
        if (seen[v] == 1) m->split++, seen[v] = 2; /* counted once however many fans */
        if (!seen[v]) seen[v] = 1;
        /* the fan's outgoing half-edges: around v one way, then the other from h */
        for (int g = h, n = 0; g >= 0 && fan[g] < 0 && n <= m->nhalf; n++)
            fan[g] = id, g = m->twin[sd_prev(m, g)];
        for (int t = m->twin[h], n = 0; t >= 0 && n <= m->nhalf; n++) {
            int g = sd_next(m, t);
            if (fan[g] >= 0) break;
            fan[g] = id, t = m->twin[g];
        }
    }
    if (rc == TS_OK && added > 0 && !sd_grow_points(m, np + added)) rc = TS_E_MEMORY;
    for (int h = 0; rc == TS_OK && added > 0 && h < m->nhalf; h++) {
        int v = m->from[h], id = fan[h];
        if (id == v) continue;
        memcpy(m->p[id], m->p[v], sizeof m->p[id]);
        m->corner[id] = m->corner[v] = 1;
        m->from[h] = id;
    }
    free(fan), free(seen);
    return rc;
}

/* The faces around v from vout[v], counted; the rotation h -> twin(prev(h)). */
static int sd_fan(const sd_mesh *m, int v)
{
    int h = m->vout[v], count = 0;
    do {
        count++;
        h = m->twin[sd_prev(m, h)];
    } while (h >= 0 && h != m->vout[v] && count <= m->nhalf);
    return count;
}

/* Sharp edges at each vertex (each undirected edge once) and their far ends. */
static void sd_count_sharp(sd_mesh *m)
{
    for (int h = 0; h < m->nhalf; h++) {
        if (!(m->twin[h] < 0 || h < m->twin[h]) || !sd_sharp(m, h)) continue;
        int a = m->from[h], b = sd_to(m, h);
        if (m->nsharp[a] < 2) m->sharpnb[2 * a + m->nsharp[a]] = b;
        if (m->nsharp[b] < 2) m->sharpnb[2 * b + m->nsharp[b]] = a;
        m->nsharp[a]++, m->nsharp[b]++;
    }
}

int sd_topology(sd_mesh *m, char *why, size_t len)
{
    int rc = sd_twins(m, why, len);
    if (rc == TS_OK) rc = sd_split_fans(m);
    if (rc != TS_OK) return rc;
    for (int v = 0; v < m->npoints; v++)
        m->vout[v] = -1;
    for (int h = 0; h < m->nhalf; h++) { /* prefer the outgoing boundary half-edge */
        int v = m->from[h];
        if (m->vout[v] < 0 || m->twin[h] < 0) m->vout[v] = h;
    }
    for (int v = 0; v < m->npoints; v++) { /* one fan a vertex now (sd_split_fans) */
        if (m->vout[v] < 0) continue;
        m->vbound[v] = m->twin[m->vout[v]] < 0;
        m->valence[v] = sd_fan(m, v) + m->vbound[v];
    }
    sd_count_sharp(m);
    for (int v = 0; v < m->npoints; v++) {
        int corner = m->corner[v] || m->nsharp[v] >= 3 ||
                     (m->vbound[v] && m->interp_boundary == 1 && m->valence[v] == 2);
        m->vclass[v] = corner ? SD_CORNER : m->nsharp[v] == 2 ? SD_CREASE : SD_SMOOTH;
    }
    return TS_OK;
}

/* ---- stencils ------------------------------------------------------------------------------ */

static void sd_axpy(double a, const double *x, double *y)
{
    y[0] += a * x[0], y[1] += a * x[1], y[2] += a * x[2];
}

/* The limit position of vertex v. */
static void sd_limit(const sd_mesh *m, int v, double out[3])
{
    const double *pv = m->p[v];
    if (m->vclass[v] == SD_CORNER) {
        memcpy(out, pv, 3 * sizeof *out);
        return;
    }
    out[0] = out[1] = out[2] = 0.0;
    if (m->vclass[v] == SD_CREASE) {
        sd_axpy(4.0 / 6.0, pv, out);
        sd_axpy(1.0 / 6.0, m->p[m->sharpnb[2 * v]], out);
        sd_axpy(1.0 / 6.0, m->p[m->sharpnb[2 * v + 1]], out);
        return;
    }
    const double n = m->valence[v];
    int h = m->vout[v];
    sd_axpy(n * n, pv, out);
    do { /* smooth vertices are interior: each edge is the next of one face */
        int nx = sd_next(m, h);
        sd_axpy(4.0, m->p[m->from[nx]], out);
        sd_axpy(1.0, m->p[m->from[sd_next(m, nx)]], out);
        h = m->twin[sd_prev(m, h)];
    } while (h >= 0 && h != m->vout[v]);
    for (int d = 0; d < 3; d++)
        out[d] /= n * (n + 5.0);
}

/* The edge point of half-edge h nearest its start v (w its end), from v's class and the
 * two faces of the edge. lim: the limit positions. */
static void sd_edge_point(const sd_mesh *m, int h, const double (*lim)[3], double out[3])
{
    const int v = m->from[h], w = sd_to(m, h), t = m->twin[h];
    out[0] = out[1] = out[2] = 0.0;
    if ((sd_sharp(m, h) && m->vclass[v] != SD_SMOOTH) || t < 0) {
        sd_axpy(2.0 / 3.0, m->p[v], out);
        sd_axpy(1.0 / 3.0, m->p[w], out);
        return;
    }
    const int yf = sd_to(m, sd_next(m, h)), yg = m->from[sd_prev(m, t)];
    if (m->vclass[v] == SD_SMOOTH) {
        const double n = m->valence[v], s = 2.0 * n + 10.0;
        const int xf = m->from[sd_prev(m, h)], xg = sd_to(m, sd_next(m, t));
        sd_axpy(2.0 * n / s, m->p[v], out);
        sd_axpy(4.0 / s, m->p[w], out);
        sd_axpy(2.0 / s, m->p[xf], out);
        sd_axpy(2.0 / s, m->p[xg], out);
        sd_axpy(1.0 / s, m->p[yf], out);
        sd_axpy(1.0 / s, m->p[yg], out);
        return;
    }
    sd_axpy(2.0 / 3.0, lim[v], out); /* a smooth edge leaving a crease or corner */
    sd_axpy(4.0 / 18.0, m->p[w], out);
    sd_axpy(1.0 / 18.0, m->p[yf], out);
    sd_axpy(1.0 / 18.0, m->p[yg], out);
}

/* The inner point of quad face corner h (vertex v, neighbours a = next, b = prev, c
 * opposite). */
static void sd_inner_point(const sd_mesh *m, int h, double out[3])
{
    const int v = m->from[h], nx = sd_next(m, h);
    const double n = m->vclass[v] == SD_SMOOTH ? m->valence[v] : 4.0, s = n + 5.0;
    out[0] = out[1] = out[2] = 0.0;
    sd_axpy(n / s, m->p[v], out);
    sd_axpy(2.0 / s, m->p[m->from[nx]], out);
    sd_axpy(2.0 / s, m->p[m->from[sd_prev(m, h)]], out);
    sd_axpy(1.0 / s, m->p[m->from[sd_next(m, nx)]], out);
}

/* ---- patches --------------------------------------------------------------------------------- */

/* Every quad's patch. The limit positions and edge points are computed once each (per
 * vertex, per half-edge) and read by both faces that share them. */
static int sd_emit(const sd_mesh *m, subdiv_patch_fn fn, void *ctx, int *patches)
{
    double(*lim)[3] = malloc(((size_t)m->npoints + 1) * sizeof *lim);
    double(*ep)[3] = malloc(((size_t)m->nhalf + 1) * sizeof *ep);
    int rc = lim && ep ? TS_OK : TS_E_MEMORY;
    for (int v = 0; rc == TS_OK && v < m->npoints; v++)
        if (m->vout[v] >= 0) sd_limit(m, v, lim[v]);
    for (int h = 0; rc == TS_OK && h < m->nhalf; h++)
        sd_edge_point(m, h, (const double(*)[3])lim, ep[h]);
    for (int f = 0; rc == TS_OK && f < m->nfaces; f++) {
        if (m->fflags[f] & SD_NO_PATCH) continue;
        const int h0 = m->fstart[f], h1 = h0 + 1, h2 = h0 + 2, h3 = h0 + 3;
        const int v0 = m->from[h0], v1 = m->from[h1], v2 = m->from[h2], v3 = m->from[h3];
        /* The far end's point of edge h: its twin's near point, or on the boundary the
         * sharp rule from that end. */
        double far[4][3];
        const int hs[4] = {h0, h1, h2, h3};
        for (int k = 0; k < 4; k++) {
            int t = m->twin[hs[k]];
            if (t >= 0) {
                memcpy(far[k], ep[t], sizeof far[k]);
            } else {
                const double *a = m->p[sd_to(m, hs[k])], *b = m->p[m->from[hs[k]]];
                for (int d = 0; d < 3; d++)
                    far[k][d] = 2.0 / 3.0 * a[d] + 1.0 / 3.0 * b[d];
            }
        }
        double cp[16][3];
        memcpy(cp[0], lim[v0], sizeof cp[0]), memcpy(cp[3], lim[v1], sizeof cp[0]);
        memcpy(cp[15], lim[v2], sizeof cp[0]), memcpy(cp[12], lim[v3], sizeof cp[0]);
        memcpy(cp[1], ep[h0], sizeof cp[0]), memcpy(cp[2], far[0], sizeof cp[0]);   /* v0 v1 */
        memcpy(cp[7], ep[h1], sizeof cp[0]), memcpy(cp[11], far[1], sizeof cp[0]);  /* v1 v2 */
        memcpy(cp[14], ep[h2], sizeof cp[0]), memcpy(cp[13], far[2], sizeof cp[0]); /* v2 v3 */
        memcpy(cp[8], ep[h3], sizeof cp[0]), memcpy(cp[4], far[3], sizeof cp[0]);   /* v3 v0 */
        sd_inner_point(m, h0, cp[5]), sd_inner_point(m, h1, cp[6]);
        sd_inner_point(m, h2, cp[10]), sd_inner_point(m, h3, cp[9]);
        double fv[4 * 16];
        const double *fvp = NULL;
        if (m->fv && m->dim <= 16) { /* corner order (0,0) (1,0) (0,1) (1,1): v0 v1 v3 v2 */
            const int order[4] = {h0, h1, h3, h2};
            for (int c = 0; c < 4; c++)
                memcpy(fv + c * m->dim, m->fv + (size_t)order[c] * m->dim, m->dim * sizeof *fv);
            fvp = fv;
        }
        rc = fn(ctx, (const double(*)[3])cp, fvp, m->forig[f]);
        if (rc == TS_OK) (*patches)++;
    }
    free(lim), free(ep);
    return rc;
}

/* ---- building the mesh ----------------------------------------------------------------------- */

/* The half-edge mesh of the input faces (twins and classes not yet made). */
static int sd_build(const subdiv_input *in, sd_mesh *m, char *why, size_t len)
{
    int nh = 0;
    for (int f = 0; f < in->nfaces; f++)
        nh += in->nverts[f];
    if (!sd_alloc(m, in->npoints, in->nfaces, nh, in->fv ? in->fv_dim : 0)) return TS_E_MEMORY;
    m->interp_boundary = in->interp_boundary;
    memcpy(m->p, in->p, (size_t)in->npoints * sizeof *m->p);
    if (in->fv) memcpy(m->fv, in->fv, (size_t)nh * (size_t)in->fv_dim * sizeof *m->fv);
    for (int f = 0, h = 0; f < in->nfaces; f++) {
        m->fstart[f] = h, m->fcount[f] = in->nverts[f], m->forig[f] = f;
        for (int k = 0; k < in->nverts[f]; k++, h++) {
            m->from[h] = in->verts[h], m->hface[h] = f;
            for (int j = m->fstart[f]; j < h; j++)
                if (m->from[j] == m->from[h]) {
                    snprintf(why, len, "face %d uses vertex %d twice", f, m->from[h]);
                    return TS_E_SCENE;
                }
        }
    }
    for (int k = 0; k < in->ncorners; k++)
        m->corner[in->corners[k]] = 1;
    for (int k = 0; k < in->nholes; k++)
        m->fflags[in->holes[k]] |= SD_NO_PATCH;
    return TS_OK;
}

/* Marks the half-edges of the crease edges sharp; returns how many crease edges are not
 * edges of the mesh. Quadratic in the number of creases at worst, through a sorted list. */
static int sd_cmp_pair(const void *a, const void *b)
{
    const int *x = a, *y = b;
    return x[0] != y[0] ? (x[0] > y[0]) - (x[0] < y[0]) : (x[1] > y[1]) - (x[1] < y[1]);
}

static int sd_tag_creases(sd_mesh *m, const int *creases, int n, int *unused)
{
    int(*pairs)[2] = malloc(((size_t)n + 1) * sizeof *pairs);
    unsigned char *hit = calloc((size_t)n + 1, 1);
    if (!pairs || !hit) {
        free(pairs), free(hit);
        return TS_E_MEMORY;
    }
    for (int k = 0; k < n; k++) {
        int a = creases[2 * k], b = creases[2 * k + 1];
        pairs[k][0] = a < b ? a : b, pairs[k][1] = a < b ? b : a;
    }
    qsort(pairs, (size_t)n, sizeof *pairs, sd_cmp_pair);
    for (int h = 0; h < m->nhalf; h++) {
        int a = m->from[h], b = sd_to(m, h), key[2] = {a < b ? a : b, a < b ? b : a};
        int(*found)[2] = bsearch(key, pairs, (size_t)n, sizeof *pairs, sd_cmp_pair);
        if (!found) continue;
        m->hsharp[h] = 1;
        for (int(*q)[2] = found; q >= pairs && sd_cmp_pair(*q, key) == 0; q--)
            hit[q - pairs] = 1; /* duplicates of the pair count as used */
        for (int(*q)[2] = found; q < pairs + n && sd_cmp_pair(*q, key) == 0; q++)
            hit[q - pairs] = 1;
    }
    *unused = 0;
    for (int k = 0; k < n; k++)
        *unused += !hit[k] && pairs[k][0] != pairs[k][1];
    free(pairs), free(hit);
    return TS_OK;
}

int subdiv_patches(const subdiv_input *in, subdiv_patch_fn fn, void *ctx, subdiv_result *res,
                   char *why, size_t len)
{
    memset(res, 0, sizeof *res);
    sd_mesh a, b;
    memset(&b, 0, sizeof b);
    snprintf(why, len, "out of memory for %d faces", in->nfaces);
    int rc = sd_build(in, &a, why, len);
    if (rc == TS_OK) rc = sd_tag_creases(&a, in->creases, in->ncreases, &res->creases_unused);
    if (rc == TS_OK) rc = sd_topology(&a, why, len);
    res->split = a.split;
    for (int f = 0; rc == TS_OK && f < a.nfaces; f++) {
        int quad = a.fcount[f] == 4;
        res->refined |= !quad;
        for (int k = 0; k < a.fcount[f] && in->interp_boundary == 0; k++)
            if (a.vbound[a.from[a.fstart[f] + k]]) a.fflags[f] |= SD_NO_PATCH;
    }
    sd_mesh *m = &a;
    if (rc == TS_OK && res->refined) {
        rc = sd_refine(&a, &b);
        if (rc == TS_OK) rc = sd_topology(&b, why, len);
        m = &b;
    }
    if (rc == TS_OK) rc = sd_emit(m, fn, ctx, &res->patches);
    sd_free(&a);
    sd_free(&b);
    return rc;
}
