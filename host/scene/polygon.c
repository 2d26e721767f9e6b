/* polygon.c — polygons (with holes) as PN Bézier patches (see polygon.h).
 *
 * Quads: the corners are the vertices; each boundary curve is the cubic whose inner
 * control points are the PN edge points b_ij = (2 P_i + P_j - w_ij N_i) / 3, the point a
 * third of the way along the edge projected onto the tangent plane at P_i (Vlachos et al.
 * 2001). The interior points are those of the bilinearly blended Coons patch of the four
 * boundary curves: ruled(u) + ruled(v) - bilinear(corners), which is bicubic and so exact.
 * Like the PN triangle's centre rule E + (E - V) / 2, it reproduces every quadratic
 * (and bilinear) surface from exact boundary curves, keeps a planar quad flat and
 * linearly parametrised, and leaves the corner tangent planes (set by the edge points
 * alone) untouched.
 *
 * Triangles: the cubic PN triangle with barycentric coordinates (1-u)(1-v), u(1-v), v is a
 * bicubic tensor-product patch whose v = 1 edge collapses to the third vertex; row k of
 * its control grid is the degree-(3-k) curve through the triangle points b_(3-k-j, j, k),
 * degree-elevated to a cubic. Its three edges are exactly the PN boundary curves, so a
 * triangle meets a neighbouring quad or triangle without a gap.
 *
 * Other polygons are triangulated in the plane of the outline's Newell normal: holes are
 * joined to the outline by a bridge from their rightmost vertex to a vertex of the outline
 * it can see (Eberly 2002: the ray towards +x, then the reflex vertex nearest its
 * direction inside the triangle it spans), which leaves one loop with the bridge's two
 * ends repeated; that loop is cut into triangles by ear clipping (a fan for whatever is
 * left if no ear is found, as for a self-intersecting loop).
 */
#include "scene/polygon.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- small vector helpers ------------------------------------------------------------ */

static void v_sub(const double a[3], const double b[3], double o[3])
{
    o[0] = a[0] - b[0], o[1] = a[1] - b[1], o[2] = a[2] - b[2];
}

static double v_dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void v_cross(const double a[3], const double b[3], double o[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

static double v_len(const double a[3])
{
    return sqrt(v_dot(a, a));
}

/* ---- PN construction ----------------------------------------------------------------- */

/* The PN edge point near pi on the edge pi -> pj: a third of the way along the edge,
 * projected onto the tangent plane at pi (ni unit). */
static void pn_edge(const double pi[3], const double pj[3], const double ni[3], double o[3])
{
    double d[3];
    v_sub(pj, pi, d);
    double w = v_dot(d, ni);
    for (int k = 0; k < 3; k++)
        o[k] = (2.0 * pi[k] + pj[k] - w * ni[k]) / 3.0;
}

void poly_pn_quad(const double p[4][3], const double n[4][3], double cp[16][3])
{
    /* Polygon order v0 v1 v2 v3 -> corners (0,0) (1,0) (1,1) (0,1). */
    memcpy(cp[0], p[0], sizeof cp[0]);
    memcpy(cp[3], p[1], sizeof cp[0]);
    memcpy(cp[15], p[2], sizeof cp[0]);
    memcpy(cp[12], p[3], sizeof cp[0]);
    pn_edge(p[0], p[1], n[0], cp[1]); /* v = 0: v0 -> v1 */
    pn_edge(p[1], p[0], n[1], cp[2]);
    pn_edge(p[3], p[2], n[3], cp[13]); /* v = 1: v3 -> v2 */
    pn_edge(p[2], p[3], n[2], cp[14]);
    pn_edge(p[0], p[3], n[0], cp[4]); /* u = 0: v0 -> v3 */
    pn_edge(p[3], p[0], n[3], cp[8]);
    pn_edge(p[1], p[2], n[1], cp[7]); /* u = 1: v1 -> v2 */
    pn_edge(p[2], p[1], n[2], cp[11]);
    for (int j = 1; j <= 2; j++)
        for (int i = 1; i <= 2; i++) {
            double s = i / 3.0, t = j / 3.0;
            for (int k = 0; k < 3; k++) {
                double ruled_v = (1.0 - t) * cp[i][k] + t * cp[12 + i][k];
                double ruled_u = (1.0 - s) * cp[4 * j][k] + s * cp[4 * j + 3][k];
                double bilin = (1.0 - s) * (1.0 - t) * cp[0][k] + s * (1.0 - t) * cp[3][k] +
                               (1.0 - s) * t * cp[12][k] + s * t * cp[15][k];
                cp[j * 4 + i][k] = ruled_v + ruled_u - bilin;
            }
        }
}

void poly_pn_triangle(const double p[3][3], const double n[3][3], double cp[16][3])
{
    /* Triangle points b_ijk (i: p0, j: p1, k: p2), Vlachos et al. 2001. */
    double b210[3], b120[3], b021[3], b012[3], b102[3], b201[3], b111[3];
    pn_edge(p[0], p[1], n[0], b210);
    pn_edge(p[1], p[0], n[1], b120);
    pn_edge(p[1], p[2], n[1], b021);
    pn_edge(p[2], p[1], n[2], b012);
    pn_edge(p[2], p[0], n[2], b102);
    pn_edge(p[0], p[2], n[0], b201);
    for (int k = 0; k < 3; k++) {
        double e = (b210[k] + b120[k] + b021[k] + b012[k] + b102[k] + b201[k]) / 6.0;
        double v = (p[0][k] + p[1][k] + p[2][k]) / 3.0;
        b111[k] = e + (e - v) / 2.0;
    }
    for (int k = 0; k < 3; k++) {
        /* Row 0 (v = 0): the cubic edge p0 -> p1. */
        cp[0][k] = p[0][k], cp[1][k] = b210[k], cp[2][k] = b120[k], cp[3][k] = p[1][k];
        /* Row 1: the quadratic b201 b111 b021, elevated. */
        cp[4][k] = b201[k];
        cp[5][k] = (b201[k] + 2.0 * b111[k]) / 3.0;
        cp[6][k] = (2.0 * b111[k] + b021[k]) / 3.0;
        cp[7][k] = b021[k];
        /* Row 2: the line b102 b012, elevated. */
        cp[8][k] = b102[k];
        cp[9][k] = (2.0 * b102[k] + b012[k]) / 3.0;
        cp[10][k] = (b102[k] + 2.0 * b012[k]) / 3.0;
        cp[11][k] = b012[k];
        /* Row 3 (v = 1): collapsed to p2. */
        cp[12][k] = cp[13][k] = cp[14][k] = cp[15][k] = p[2][k];
    }
}

double poly_normal(const double (*p)[3], unsigned n, double out[3])
{
    out[0] = out[1] = out[2] = 0.0;
    for (unsigned k = 0; k < n; k++) {
        const double *a = p[k], *b = p[(k + 1) % n];
        out[0] += (a[1] - b[1]) * (a[2] + b[2]);
        out[1] += (a[2] - b[2]) * (a[0] + b[0]);
        out[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    double l = v_len(out);
    if (l > 0.0 && isfinite(l))
        out[0] /= l, out[1] /= l, out[2] /= l;
    else
        out[0] = out[1] = out[2] = 0.0, l = 0.0;
    return l;
}

/* ---- pieces ---------------------------------------------------------------------------- */

typedef struct poly_ctx {
    const poly_face *f;
    double nrm[3];   /* the polygon's unit normal (its outline's) */
    double (*xy)[2]; /* vertices in the polygon's plane (triangulation only) */
    poly_patch_fn fn;
    void *ctx;
    unsigned skipped;
} poly_ctx;

/* Emits the triangle (n = 3) or quad (n = 4) on polygon vertices idx; a piece of zero area
 * is skipped. A vertex without a usable normal takes the polygon's. */
static int poly_piece(poly_ctx *c, const unsigned *idx, unsigned n)
{
    const poly_face *f = c->f;
    double p[4][3], nn[4][3], fn[3], ext = 0.0;
    for (unsigned k = 0; k < n; k++) {
        memcpy(p[k], f->p[idx[k]], sizeof p[k]);
        const double *v = f->n ? f->n[idx[k]] : c->nrm;
        if (v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0) v = c->nrm;
        memcpy(nn[k], v, sizeof nn[k]);
    }
    for (unsigned k = 1; k < n; k++) {
        double d[3];
        v_sub(p[k], p[0], d);
        ext = fmax(ext, v_len(d));
    }
    double area2 = poly_normal((const double(*)[3])p, n, fn);
    if (!(area2 > 1e-12 * ext * ext)) {
        c->skipped++;
        return TS_OK;
    }
    double cp[16][3], cn[4][3];
    unsigned corner[4];
    if (n == 4) {
        poly_pn_quad((const double(*)[3])p, (const double(*)[3])nn, cp);
        /* Corner order (0,0) (1,0) (0,1) (1,1) = v0 v1 v3 v2. */
        static const int order[4] = {0, 1, 3, 2};
        for (int k = 0; k < 4; k++)
            memcpy(cn[k], nn[order[k]], sizeof cn[k]), corner[k] = idx[order[k]];
    } else {
        poly_pn_triangle((const double(*)[3])p, (const double(*)[3])nn, cp);
        static const int order[4] = {0, 1, 2, 2};
        for (int k = 0; k < 4; k++)
            memcpy(cn[k], nn[order[k]], sizeof cn[k]), corner[k] = idx[order[k]];
    }
    return c->fn(c->ctx, (const double(*)[3])cp, (const double(*)[3])cn, corner);
}

/* Whether the quad on idx is strictly convex about the polygon's normal. */
static int poly_quad_convex(const poly_ctx *c, const unsigned *idx)
{
    for (int k = 0; k < 4; k++) {
        double e1[3], e2[3], x[3];
        v_sub(c->f->p[idx[k]], c->f->p[idx[(k + 3) % 4]], e1);
        v_sub(c->f->p[idx[(k + 1) % 4]], c->f->p[idx[k]], e2);
        v_cross(e1, e2, x);
        if (!(v_dot(x, c->nrm) > 0.0)) return 0;
    }
    return 1;
}

/* ---- triangulation in the polygon's plane --------------------------------------------- */

/* Twice the signed area of (a, b, c): > 0 when they turn counter-clockwise. */
static double cross2(const double *a, const double *b, const double *c)
{
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

/* Whether pt lies inside or on the counter-clockwise triangle (a, b, c). */
static int inside2(const double *a, const double *b, const double *c, const double *pt)
{
    return cross2(a, b, pt) >= 0.0 && cross2(b, c, pt) >= 0.0 && cross2(c, a, pt) >= 0.0;
}

/* Projects every vertex onto the plane of c->nrm, so that a loop counter-clockwise about
 * the normal is counter-clockwise in (x, y). */
static void poly_project(poly_ctx *c)
{
    const double *n = c->nrm;
    double t1[3], t2[3];
    double axis[3] = {0, 0, 0};
    axis[fabs(n[0]) <= fabs(n[1]) && fabs(n[0]) <= fabs(n[2]) ? 0
         : fabs(n[1]) <= fabs(n[2])                           ? 1
                                                              : 2] = 1.0;
    v_cross(axis, n, t1);
    double l = v_len(t1);
    t1[0] /= l, t1[1] /= l, t1[2] /= l;
    v_cross(n, t1, t2);
    for (unsigned k = 0; k < c->f->count; k++)
        c->xy[k][0] = v_dot(c->f->p[k], t1), c->xy[k][1] = v_dot(c->f->p[k], t2);
}

/* Is ring slot k an ear: a strictly convex corner whose triangle holds no other vertex? */
static int poly_is_ear(const poly_ctx *c, const unsigned *ring, unsigned m, unsigned k)
{
    unsigned ia = ring[(k + m - 1) % m], ib = ring[k], ic = ring[(k + 1) % m];
    const double *a = c->xy[ia], *b = c->xy[ib], *cc = c->xy[ic];
    if (!(cross2(a, b, cc) > 0.0)) return 0;
    for (unsigned q = 0; q < m; q++) {
        unsigned iq = ring[q];
        if (iq == ia || iq == ib || iq == ic) continue;
        if (inside2(a, b, cc, c->xy[iq])) return 0;
    }
    return 1;
}

/* Cuts the counter-clockwise loop ring[0..m) into triangles. */
static int poly_ear_clip(poly_ctx *c, unsigned *ring, unsigned m)
{
    int rc = TS_OK;
    unsigned k = 0, misses = 0;
    while (rc == TS_OK && m > 3 && misses < m) {
        if (!poly_is_ear(c, ring, m, k)) {
            k = (k + 1) % m, misses++;
            continue;
        }
        unsigned tri[3] = {ring[(k + m - 1) % m], ring[k], ring[(k + 1) % m]};
        rc = poly_piece(c, tri, 3);
        memmove(ring + k, ring + k + 1, (m - k - 1) * sizeof *ring);
        m--;
        k = (k + m - 1) % m; /* the corner before the ear changed: look at it again */
        misses = 0;
    }
    for (unsigned j = 1; rc == TS_OK && j + 1 < m; j++) { /* the rest as a fan */
        unsigned tri[3] = {ring[0], ring[j], ring[j + 1]};
        rc = poly_piece(c, tri, 3);
    }
    return rc;
}

/* The ring slot the hole vertex hm can see: the nearest crossing of the ray from it
 * towards +x with a ring edge, then the edge's end farther along x, or the reflex vertex
 * inside the triangle they span closest in direction to the ray. m when none. */
static unsigned poly_visible(const poly_ctx *c, const unsigned *ring, unsigned m, unsigned hm)
{
    const double *M = c->xy[hm];
    double best = INFINITY;
    unsigned edge = m;
    for (unsigned i = 0; i < m; i++) {
        const double *A = c->xy[ring[i]], *B = c->xy[ring[(i + 1) % m]];
        if (A[1] == B[1] || M[1] < fmin(A[1], B[1]) || M[1] > fmax(A[1], B[1])) continue;
        double x = A[0] + (M[1] - A[1]) * (B[0] - A[0]) / (B[1] - A[1]);
        if (x >= M[0] && x < best) best = x, edge = i;
    }
    if (edge == m) return m;
    unsigned sa = edge, sb = (edge + 1) % m;
    const double *A = c->xy[ring[sa]], *B = c->xy[ring[sb]];
    if (A[1] == M[1] && A[0] == best) return sa;
    if (B[1] == M[1] && B[0] == best) return sb;
    unsigned sp = A[0] > B[0] ? sa : sb;
    const double I[2] = {best, M[1]}, *P = c->xy[ring[sp]];
    double best_cos = -2.0, best_d = INFINITY;
    unsigned pick = sp;
    for (unsigned q = 0; q < m; q++) {
        const double *R = c->xy[ring[q]];
        if (q == sp || !(cross2(c->xy[ring[(q + m - 1) % m]], R, c->xy[ring[(q + 1) % m]]) < 0.0))
            continue; /* only reflex vertices can hide P */
        int in = cross2(M, I, P) >= 0.0 ? inside2(M, I, P, R) : inside2(M, P, I, R);
        if (!in) continue;
        double dx = R[0] - M[0], dy = R[1] - M[1], d = hypot(dx, dy);
        double cs = d > 0.0 ? dx / d : -2.0;
        if (cs > best_cos || (cs == best_cos && d < best_d)) best_cos = cs, best_d = d, pick = q;
    }
    return pick;
}

/* Of the ring slots holding the same vertex as slot sp (a vertex an earlier bridge
 * repeated), the one whose interior wedge, from its next edge counter-clockwise to its
 * previous one, holds the direction towards M: the bridge must leave from there. */
static unsigned poly_wedge(const poly_ctx *c, const unsigned *ring, unsigned m, unsigned sp,
                           const double *M)
{
    const double *P = c->xy[ring[sp]];
    const double d[2] = {M[0] - P[0], M[1] - P[1]};
    for (unsigned q = 0; q < m; q++) {
        if (ring[q] != ring[sp]) continue;
        const double *A = c->xy[ring[(q + 1) % m]], *B = c->xy[ring[(q + m - 1) % m]];
        const double a[2] = {A[0] - P[0], A[1] - P[1]}, b[2] = {B[0] - P[0], B[1] - P[1]};
        double ab = a[0] * b[1] - a[1] * b[0], ad = a[0] * d[1] - a[1] * d[0],
               db = d[0] * b[1] - d[1] * b[0];
        if (ab >= 0.0 ? (ad >= 0.0 && db >= 0.0) : (ad >= 0.0 || db >= 0.0)) return q;
    }
    return sp;
}

/* Joins the hole (polygon vertices first..first+n) to the ring at the slot its rightmost
 * vertex sees, walking it backwards when `reverse` (the hole must run clockwise): ring =
 * ..., P, M, the hole after M ..., M, P, ... Returns the new length (m when the hole sees
 * nothing: it is left out). */
static unsigned poly_bridge(const poly_ctx *c, unsigned *ring, unsigned m, unsigned first,
                            unsigned n, int reverse)
{
    unsigned hm = 0;
    for (unsigned k = 1; k < n; k++)
        if (c->xy[first + k][0] > c->xy[first + hm][0]) hm = k;
    unsigned sp = poly_visible(c, ring, m, first + hm);
    if (sp == m) return m;
    sp = poly_wedge(c, ring, m, sp, c->xy[first + hm]);
    memmove(ring + sp + n + 3, ring + sp + 1, (m - sp - 1) * sizeof *ring);
    for (unsigned k = 0; k <= n; k++)
        ring[sp + 1 + k] = first + (reverse ? hm + n - k % n : hm + k) % n;
    ring[sp + n + 2] = ring[sp];
    return m + n + 2;
}

/* A hole of the polygon: its first vertex, its length, its largest x in the plane. */
typedef struct poly_hole {
    unsigned first, n;
    double max_x;
} poly_hole;

static int poly_hole_cmp(const void *a, const void *b)
{
    double x = ((const poly_hole *)a)->max_x, y = ((const poly_hole *)b)->max_x;
    return x > y ? -1 : x < y ? 1 : 0;
}

/* Twice the signed area of loop first..first+n in the plane. */
static double poly_area2(const poly_ctx *c, unsigned first, unsigned n)
{
    double a = 0.0;
    for (unsigned k = 0; k < n; k++) {
        const double *p = c->xy[first + k], *q = c->xy[first + (k + 1) % n];
        a += p[0] * q[1] - q[0] * p[1];
    }
    return a;
}

/* The outline into ring, without repeated consecutive points; returns its length. */
static unsigned poly_outline(const poly_face *f, unsigned n, unsigned *ring)
{
    unsigned m = 0;
    for (unsigned k = 0; k < n; k++)
        if (m == 0 || memcmp(f->p[k], f->p[ring[m - 1]], sizeof f->p[0]) != 0) ring[m++] = k;
    while (m > 1 && memcmp(f->p[ring[0]], f->p[ring[m - 1]], sizeof f->p[0]) == 0)
        m--;
    return m;
}

/* Triangulates the polygon: the outline, each hole of non-zero area bridged in (rightmost
 * first, walked clockwise), then ear clipping. */
static int poly_triangulate(poly_ctx *c, ts_error *err)
{
    const poly_face *f = c->f;
    unsigned loops = f->loop_len ? f->loops : 1;
    unsigned *ring = malloc(((size_t)f->count + 2u * loops + 2u) * sizeof *ring);
    poly_hole *holes = malloc((size_t)loops * sizeof *holes);
    c->xy = malloc((size_t)f->count * sizeof *c->xy);
    int rc = TS_OK;
    if (!ring || !holes || !c->xy) {
        rc = ts_error_set(err, TS_E_MEMORY, "polygon: out of memory for %u vertices", f->count);
        goto done;
    }
    poly_project(c);
    unsigned first = f->loop_len ? f->loop_len[0] : f->count, nh = 0;
    unsigned m = poly_outline(f, first, ring);
    for (unsigned l = 1; l < loops; l++) {
        unsigned n = f->loop_len[l];
        if (n >= 3 && poly_area2(c, first, n) != 0.0) {
            holes[nh] = (poly_hole){first, n, -INFINITY};
            for (unsigned k = 0; k < n; k++)
                holes[nh].max_x = fmax(holes[nh].max_x, c->xy[first + k][0]);
            nh++;
        }
        first += n;
    }
    qsort(holes, nh, sizeof *holes, poly_hole_cmp);
    for (unsigned h = 0; h < nh && m >= 3; h++)
        m = poly_bridge(c, ring, m, holes[h].first, holes[h].n,
                        poly_area2(c, holes[h].first, holes[h].n) > 0.0);
    if (m >= 3) rc = poly_ear_clip(c, ring, m);
done:
    free(ring);
    free(holes);
    free(c->xy);
    c->xy = NULL;
    return rc;
}

int poly_patches(const poly_face *f, poly_patch_fn fn, void *ctx, unsigned *skipped, ts_error *err)
{
    poly_ctx c = {.f = f, .fn = fn, .ctx = ctx};
    unsigned outline = f->loop_len ? (f->loops ? f->loop_len[0] : 0) : f->count;
    int holes = f->loop_len && f->loops > 1;
    int rc = TS_OK;
    if (outline < 3 || !(poly_normal(f->p, outline, c.nrm) > 0.0)) {
        c.skipped++; /* points, lines and polygons of zero area are not surfaces */
    } else if (!holes && outline == 3) {
        static const unsigned tri[3] = {0, 1, 2};
        rc = poly_piece(&c, tri, 3);
    } else if (!holes && outline == 4 && poly_quad_convex(&c, (const unsigned[]){0, 1, 2, 3})) {
        static const unsigned quad[4] = {0, 1, 2, 3};
        rc = poly_piece(&c, quad, 4);
    } else {
        rc = poly_triangulate(&c, err);
    }
    if (skipped) *skipped += c.skipped;
    return rc;
}
