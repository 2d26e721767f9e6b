/* test_rib_subdiv.c — SubdivisionMesh "catmull-clark" (host/scene/rib/rib_subdiv.c,
 * scene/subdiv.c, scene/subdiv_refine.c). Host only: never skips.
 *
 * - Regular faces against the uniform bicubic B-spline of their 4 x 4 neighbourhood,
 *   evaluated here from the B-spline basis (a closed torus-shaped grid; a sheet with
 *   interpolateboundary and a sheet split by a crease, both against the B-spline of the
 *   grid extended by phantom points 2 P0 - P1, which is what the boundary and crease rules
 *   of Catmull-Clark give there): exact to float rounding.
 * - A cube against the true Catmull-Clark limit surface: reference limit points from three
 *   steps of real subdivision plus the limit stencil, computed here, compared with the
 *   patches at the same parameters: within the stated SUBDIV_CUBE_TOL of the edge length.
 * - Crease edges that stay sharp (a fully creased cube stays a cube; normals jump across
 *   a crease), closed meshes watertight, refinement of triangles, holes, boundary faces
 *   without interpolateboundary, primitive variables and errors. */
#include "scene/rib/rib.h"
#include "scene/scene.h"

#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

/* ACC on a cube (all vertices of valence 3): the largest distance between the patches
 * and the Catmull-Clark limit surface at equal parameters, relative to the edge length
 * of the control cube (docs/rib.md states it). */
#define SUBDIV_CUBE_TOL 0.015

/* ---- helpers ------------------------------------------------------------------------------ */

static void bezier_point(const ts_vec4 *cp, double u, double v, double out[3])
{
    const double bu[4] = {(1 - u) * (1 - u) * (1 - u), 3 * u * (1 - u) * (1 - u),
                          3 * u * u * (1 - u), u * u * u};
    const double bv[4] = {(1 - v) * (1 - v) * (1 - v), 3 * v * (1 - v) * (1 - v),
                          3 * v * v * (1 - v), v * v * v};
    out[0] = out[1] = out[2] = 0;
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            double w = bu[i] * bv[j];
            out[0] += w * cp[j * 4 + i].x, out[1] += w * cp[j * 4 + i].y,
                out[2] += w * cp[j * 4 + i].z;
        }
}

/* The uniform cubic B-spline basis at t in [0, 1]. */
static void bspline(double t, double b[4])
{
    double s = 1 - t;
    b[0] = s * s * s / 6, b[1] = (3 * t * t * t - 6 * t * t + 4) / 6;
    b[2] = (-3 * t * t * t + 3 * t * t + 3 * t + 1) / 6, b[3] = t * t * t / 6;
}

/* The B-spline patch of 16 points g[j][i] at (u, v). */
static void bspline_point(const double g[4][4][3], double u, double v, double out[3])
{
    double bu[4], bv[4];
    bspline(u, bu);
    bspline(v, bv);
    out[0] = out[1] = out[2] = 0;
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++)
            for (int d = 0; d < 3; d++)
                out[d] += bu[i] * bv[j] * g[j][i][d];
}

static double dist(const double *a, const double *b)
{
    return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                (a[2] - b[2]) * (a[2] - b[2]));
}

/* Appends printf text to a growing buffer. */
typedef struct textbuf {
    char *s;
    size_t n, cap;
} textbuf;

static void add(textbuf *t, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void add(textbuf *t, const char *fmt, ...)
{
    va_list ap;
    for (;;) {
        va_start(ap, fmt);
        int k = vsnprintf(t->s ? t->s + t->n : NULL, t->s ? t->cap - t->n : 0, fmt, ap);
        va_end(ap);
        if (t->s && t->n + (size_t)k < t->cap) {
            t->n += (size_t)k;
            return;
        }
        t->cap = t->cap * 2 + (size_t)k + 1024;
        t->s = realloc(t->s, t->cap);
        assert_non_null(t->s);
    }
}

/* A grid mesh of (nu + 1) x (nv + 1) points p[j][i] (or nu x nv wrapping in both for a
 * torus) as SubdivisionMesh text, faces row by row, u fastest, counter-clockwise. */
static void grid_rib(textbuf *t, int nu, int nv, int wrap, double (*p)[3], const char *tags)
{
    int pu = wrap ? nu : nu + 1, pv = wrap ? nv : nv + 1;
    add(t, "SubdivisionMesh \"catmull-clark\" [");
    for (int k = 0; k < nu * nv; k++)
        add(t, "4 ");
    add(t, "] [");
    for (int j = 0; j < nv; j++)
        for (int i = 0; i < nu; i++) {
            int i1 = (i + 1) % pu, j1 = (j + 1) % pv;
            add(t, "%d %d %d %d  ", j * pu + i, j * pu + i1, j1 * pu + i1, j1 * pu + i);
        }
    add(t, "] %s \"P\" [", tags ? tags : "");
    for (int k = 0; k < pu * pv; k++)
        add(t, "%.17g %.17g %.17g ", p[k][0], p[k][1], p[k][2]);
    add(t, "]\n");
}

/* ---- regular faces: exact B-spline patches ------------------------------------------------- */

/* Patch `patch` of s against the B-spline of 16 points of the grid gp (pu x pv points,
 * index function idx). Returns the largest distance. */
static double compare_bspline(const ts_scene *s, uint32_t patch, const double g[4][4][3])
{
    double worst = 0;
    for (int j = 0; j <= 6; j++)
        for (int i = 0; i <= 6; i++) {
            double a[3], b[3];
            bezier_point(s->cp + patch * 16, i / 6.0, j / 6.0, a);
            bspline_point(g, i / 6.0, j / 6.0, b);
            worst = fmax(worst, dist(a, b));
        }
    return worst;
}

static void test_regular_torus_exact(void **state)
{
    (void)state;
    /* A torus-shaped grid of 8 x 6 quads, every vertex of valence 4, points jittered. */
    const int nu = 8, nv = 6;
    double p[48][3];
    uint32_t seed = 21;
    for (int j = 0; j < nv; j++)
        for (int i = 0; i < nu; i++) {
            double a = 2 * 3.14159265358979 * i / nu, b = 2 * 3.14159265358979 * j / nv;
            double r = 3 + cos(b) + test_uniform(&seed, -0.2f, 0.2f);
            p[j * nu + i][0] = r * cos(a), p[j * nu + i][1] = r * sin(a);
            p[j * nu + i][2] = sin(b) + test_uniform(&seed, -0.2f, 0.2f);
        }
    textbuf t = {0};
    grid_rib(&t, nu, nv, 1, p, NULL);
    ts_scene s;
    test_parse_rib_ok(t.s, &s);
    assert_int_equal(s.patch_count, nu * nv);
    for (int f = 0; f < nu * nv; f++) {
        int i0 = f % nu, j0 = f / nu;
        double g[4][4][3];
        for (int j = 0; j < 4; j++)
            for (int i = 0; i < 4; i++)
                memcpy(g[j][i], p[((j0 + j - 1 + nv) % nv) * nu + (i0 + i - 1 + nu) % nu],
                       sizeof g[j][i]);
        double w = compare_bspline(&s, (uint32_t)f, (const double(*)[4][3])g);
        if (w > 2e-6) fail_msg("face %d: %.3g from its B-spline patch", f, w);
    }
    scene_free(&s);
    free(t.s);
}

/* The (nu + 1) x (nv + 1) grid p extended by one ring of phantom points 2 P0 - P1 (rows,
 * then columns: corners 4 P00 - 2 P10 - 2 P01 + P11): ext[(j + 1) * (nu + 3) + i + 1]. */
static void extend(const double (*p)[3], int nu, int nv, double (*ext)[3])
{
    const int W = nu + 3, pu = nu + 1;
    for (int j = 0; j <= nv; j++)
        for (int i = 0; i <= nu; i++)
            memcpy(ext[(j + 1) * W + i + 1], p[j * pu + i], sizeof ext[0]);
    for (int i = 1; i <= nu + 1; i++)
        for (int d = 0; d < 3; d++) {
            ext[i][d] = 2 * ext[W + i][d] - ext[2 * W + i][d];
            ext[(nv + 2) * W + i][d] = 2 * ext[(nv + 1) * W + i][d] - ext[nv * W + i][d];
        }
    for (int j = 0; j <= nv + 2; j++)
        for (int d = 0; d < 3; d++) {
            ext[j * W][d] = 2 * ext[j * W + 1][d] - ext[j * W + 2][d];
            ext[j * W + nu + 2][d] = 2 * ext[j * W + nu + 1][d] - ext[j * W + nu][d];
        }
}

/* Faces rows [j_lo, j_hi) of a sheet loaded from s (patch index j * nu + i) against the
 * B-spline of the phantom-extended grid of rows [r0, r0 + rows] of p. */
static void check_sheet(const ts_scene *s, const double (*p)[3], int nu, int r0, int rows,
                        int patch0)
{
    double(*ext)[3] = malloc((size_t)(nu + 3) * (size_t)(rows + 3) * sizeof *ext);
    assert_non_null(ext);
    extend(p + r0 * (nu + 1), nu, rows, ext);
    for (int j0 = 0; j0 < rows; j0++)
        for (int i0 = 0; i0 < nu; i0++) {
            double g[4][4][3];
            for (int j = 0; j < 4; j++)
                for (int i = 0; i < 4; i++)
                    memcpy(g[j][i], ext[(j0 + j) * (nu + 3) + i0 + i], sizeof g[j][i]);
            double w =
                compare_bspline(s, (uint32_t)(patch0 + j0 * nu + i0), (const double(*)[4][3])g);
            if (w > 2e-6) fail_msg("face (%d, %d): %.3g from the B-spline", i0, r0 + j0, w);
        }
    free(ext);
}

static void test_boundary_and_crease_exact(void **state)
{
    (void)state;
    /* A 5 x 4 sheet with interpolateboundary: every face, boundary and corner ones too. */
    const int nu = 5, nv = 4;
    double p[30][3];
    uint32_t seed = 8;
    for (int k = 0; k < 30; k++)
        p[k][0] = k % 6 + test_uniform(&seed, -0.2f, 0.2f),
        p[k][1] = k / 6 + test_uniform(&seed, -0.2f, 0.2f), p[k][2] = test_uniform(&seed, -1, 1);
    textbuf t = {0};
    grid_rib(&t, nu, nv, 0, p, "[\"interpolateboundary\"] [0 0] [] []");
    ts_scene s;
    test_parse_rib_ok(t.s, &s);
    assert_int_equal(s.patch_count, nu * nv);
    check_sheet(&s, (const double(*)[3])p, nu, 0, nv, 0);
    scene_free(&s);
    /* The same sheet creased along the row of points j = 2 (boundary to boundary): the two
     * halves are independent sheets meeting along the crease's B-spline curve. */
    t.n = 0;
    grid_rib(&t, nu, nv, 0, p,
             "[\"interpolateboundary\" \"crease\"] [0 0 6 1] [12 13 14 15 16 17] [10]");
    test_parse_rib_ok(t.s, &s);
    check_sheet(&s, (const double(*)[3])p, nu, 0, 2, 0);
    check_sheet(&s, (const double(*)[3])p, nu, 2, 2, 2 * nu);
    /* Sharp: across the crease the tangent planes differ (they agree without it). */
    double a[3], b[3], c[3], up[3], dn[3];
    bezier_point(s.cp + (1 * nu + 2) * 16, 0.5, 1.0, a); /* on the crease, from below */
    bezier_point(s.cp + (1 * nu + 2) * 16, 0.5, 0.9, b);
    bezier_point(s.cp + (2 * nu + 2) * 16, 0.5, 0.1, c);
    for (int d = 0; d < 3; d++)
        dn[d] = a[d] - b[d], up[d] = c[d] - a[d];
    double cosang = (dn[0] * up[0] + dn[1] * up[1] + dn[2] * up[2]) /
                    (sqrt(dn[0] * dn[0] + dn[1] * dn[1] + dn[2] * dn[2]) *
                     sqrt(up[0] * up[0] + up[1] * up[1] + up[2] * up[2]));
    scene_free(&s);
    assert_true(cosang < 0.999);
    /* Without interpolateboundary, faces touching the boundary give no patch: the inner 3 x 2
     * faces remain, still exact. */
    t.n = 0;
    grid_rib(&t, nu, nv, 0, p, NULL);
    test_parse_rib_ok(t.s, &s);
    assert_int_equal(s.patch_count, 3 * 2);
    for (int f = 0; f < 6; f++) {
        int i0 = 1 + f % 3, j0 = 1 + f / 3;
        double g[4][4][3];
        for (int j = 0; j < 4; j++)
            for (int i = 0; i < 4; i++)
                memcpy(g[j][i], p[(j0 + j - 1) * 6 + i0 + i - 1], sizeof g[j][i]);
        assert_true(compare_bspline(&s, (uint32_t)f, (const double(*)[4][3])g) < 2e-6);
    }
    scene_free(&s);
    free(t.s);
}

/* ---- the cube against real Catmull-Clark subdivision --------------------------------------- */

/* A closed quad mesh with, for each face, the input face it lies in and the (u, v) of its
 * corners there. */
typedef struct qmesh {
    int np, nf;
    double (*p)[3];
    int (*f)[4];
    int *orig;
    double (*uv)[4][2];
} qmesh;

static int edge_find(const int (*e)[2], int ne, int a, int b)
{
    for (int k = 0; k < ne; k++)
        if ((e[k][0] == a && e[k][1] == b) || (e[k][0] == b && e[k][1] == a)) return k;
    return -1;
}

/* One Catmull-Clark step of a closed quad mesh (no creases). */
static void cc_step(const qmesh *in, qmesh *out)
{
    int(*e)[2] = malloc((size_t)in->nf * 4 * sizeof *e), ne = 0;
    int(*fe)[4] = malloc((size_t)in->nf * sizeof *fe);
    for (int f = 0; f < in->nf; f++)
        for (int k = 0; k < 4; k++) {
            int a = in->f[f][k], b = in->f[f][(k + 1) % 4], id = edge_find(e, ne, a, b);
            if (id < 0) e[ne][0] = a, e[ne][1] = b, id = ne++;
            fe[f][k] = id;
        }
    out->np = in->np + in->nf + ne, out->nf = 4 * in->nf;
    out->p = calloc((size_t)out->np, sizeof *out->p);
    out->f = malloc((size_t)out->nf * sizeof *out->f);
    out->orig = malloc((size_t)out->nf * sizeof *out->orig);
    out->uv = malloc((size_t)out->nf * sizeof *out->uv);
    double(*fp)[3] = out->p + in->np, (*ep)[3] = out->p + in->np + in->nf;
    int *nfaces = calloc((size_t)in->np, sizeof *nfaces);
    double(*q)[3] = calloc((size_t)in->np, sizeof *q), (*r)[3] = calloc((size_t)in->np, sizeof *r);
    for (int f = 0; f < in->nf; f++)
        for (int k = 0; k < 4; k++)
            for (int d = 0; d < 3; d++)
                fp[f][d] += in->p[in->f[f][k]][d] / 4;
    for (int f = 0; f < in->nf; f++)
        for (int k = 0; k < 4; k++) {
            int v = in->f[f][k], w = in->f[f][(k + 1) % 4];
            nfaces[v]++;
            for (int d = 0; d < 3; d++) {
                ep[fe[f][k]][d] += (in->p[v][d] + in->p[w][d]) / 8 + fp[f][d] / 4;
                q[v][d] += fp[f][d];
                r[v][d] += (in->p[v][d] + in->p[w][d]) / 2; /* each edge once per vertex */
            }
        }
    for (int v = 0; v < in->np; v++) {
        double n = nfaces[v];
        for (int d = 0; d < 3; d++)
            out->p[v][d] = (q[v][d] / n + 2 * r[v][d] / n + (n - 3) * in->p[v][d]) / n;
    }
    for (int f = 0; f < in->nf; f++)
        for (int k = 0; k < 4; k++) {
            int c = 4 * f + k, km = (k + 3) % 4;
            out->f[c][0] = in->f[f][k], out->f[c][1] = in->np + in->nf + fe[f][k];
            out->f[c][2] = in->np + f, out->f[c][3] = in->np + in->nf + fe[f][km];
            out->orig[c] = in->orig[f];
            const double *a = in->uv[f][k], *b = in->uv[f][(k + 1) % 4], *z = in->uv[f][km];
            for (int d = 0; d < 2; d++) {
                double ctr =
                    (in->uv[f][0][d] + in->uv[f][1][d] + in->uv[f][2][d] + in->uv[f][3][d]) / 4;
                out->uv[c][0][d] = a[d], out->uv[c][1][d] = (a[d] + b[d]) / 2;
                out->uv[c][2][d] = ctr, out->uv[c][3][d] = (z[d] + a[d]) / 2;
            }
        }
    free(e), free(fe), free(nfaces), free(q), free(r);
}

/* The limit position of vertex v of a closed quad mesh. */
static void cc_limit(const qmesh *m, int v, double out[3])
{
    double n = 0, e[3] = {0, 0, 0}, f[3] = {0, 0, 0};
    for (int g = 0; g < m->nf; g++)
        for (int k = 0; k < 4; k++)
            if (m->f[g][k] == v) {
                n++;
                for (int d = 0; d < 3; d++) /* the next vertex: each edge once */
                    e[d] += m->p[m->f[g][(k + 1) % 4]][d], f[d] += m->p[m->f[g][(k + 2) % 4]][d];
            }
    for (int d = 0; d < 3; d++)
        out[d] = (n * n * m->p[v][d] + 4 * e[d] + f[d]) / (n * (n + 5));
}

static void qmesh_free(qmesh *m)
{
    free(m->p), free(m->f), free(m->orig), free(m->uv);
}

static const char *const cube_rib =
    "SubdivisionMesh \"catmull-clark\" [4 4 4 4 4 4]\n"
    "  [0 2 3 1  4 5 7 6  0 1 5 4  2 6 7 3  0 4 6 2  1 3 7 5] %s\n"
    "  \"P\" [-1 -1 -1  1 -1 -1  -1 1 -1  1 1 -1  -1 -1 1  1 -1 1  -1 1 1  1 1 1]";
static const int cube_faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                     {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};

static void test_cube_against_limit(void **state)
{
    (void)state;
    char rib[1024];
    snprintf(rib, sizeof rib, cube_rib, "");
    ts_scene s;
    test_parse_rib_ok(rib, &s);
    assert_int_equal(s.patch_count, 6);
    qmesh m = {8,
               6,
               malloc(8 * sizeof *m.p),
               malloc(6 * sizeof *m.f),
               malloc(6 * sizeof(int)),
               malloc(6 * sizeof *m.uv)};
    for (int v = 0; v < 8; v++)
        m.p[v][0] = v & 1 ? 1 : -1, m.p[v][1] = v & 2 ? 1 : -1, m.p[v][2] = v & 4 ? 1 : -1;
    static const double corners[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (int f = 0; f < 6; f++) {
        memcpy(m.f[f], cube_faces[f], sizeof m.f[f]);
        m.orig[f] = f;
        memcpy(m.uv[f], corners, sizeof corners);
    }
    for (int level = 0; level < 3; level++) {
        qmesh n;
        cc_step(&m, &n);
        qmesh_free(&m);
        m = n;
    }
    double worst = 0, worst_corner = 0;
    for (int f = 0; f < m.nf; f++)
        for (int k = 0; k < 4; k++) {
            double lim[3], pt[3];
            cc_limit(&m, m.f[f][k], lim);
            bezier_point(s.cp + m.orig[f] * 16, m.uv[f][k][0], m.uv[f][k][1], pt);
            double d = dist(lim, pt) / 2; /* relative to the edge length 2 */
            worst = fmax(worst, d);
            int at_corner = (m.uv[f][k][0] == 0 || m.uv[f][k][0] == 1) &&
                            (m.uv[f][k][1] == 0 || m.uv[f][k][1] == 1);
            if (at_corner) worst_corner = fmax(worst_corner, d);
        }
    qmesh_free(&m);
    scene_free(&s);
    /* The corners are limit points exactly; elsewhere within the tolerance, and really an
     * approximation (the test measures it). */
    assert_true(worst_corner < 1e-7);
    if (worst > SUBDIV_CUBE_TOL) fail_msg("cube: %.4g of the edge from the limit", worst);
    assert_true(worst > 1e-4);
}

/* Every non-degenerate edge of every patch is (bit for bit, either direction) an edge of
 * another patch. */
static int open_edges(const ts_scene *s)
{
    static const int edges[4][4] = {{0, 1, 2, 3}, {12, 13, 14, 15}, {0, 4, 8, 12}, {3, 7, 11, 15}};
    int open = 0;
    for (uint32_t p = 0; p < s->patch_count; p++)
        for (int e = 0; e < 4; e++) {
            int found = 0;
            for (uint32_t q = 0; q < s->patch_count && !found; q++)
                for (int f = 0; f < 4 && !found && q != p; f++) {
                    int same = 1, rev = 1;
                    for (int k = 0; k < 4; k++) {
                        same &= memcmp(&s->cp[p * 16 + edges[e][k]], &s->cp[q * 16 + edges[f][k]],
                                       sizeof s->cp[0]) == 0;
                        rev &= memcmp(&s->cp[p * 16 + edges[e][k]],
                                      &s->cp[q * 16 + edges[f][3 - k]], sizeof s->cp[0]) == 0;
                    }
                    found = same || rev;
                }
            open += !found;
        }
    return open;
}

static void test_creases_corners_watertight(void **state)
{
    (void)state;
    char rib[2048];
    ts_scene s;
    /* The smooth cube is closed. */
    snprintf(rib, sizeof rib, cube_rib, "");
    test_parse_rib_ok(rib, &s);
    assert_int_equal(open_edges(&s), 0);
    scene_free(&s);
    /* Every edge creased: the limit is the cube itself, flat faces on |x|, |y| or |z| = 1. */
    snprintf(rib, sizeof rib, cube_rib,
             "[\"crease\" \"crease\" \"crease\" \"crease\" \"crease\" \"crease\"] "
             "[5 1 5 1 2 1 2 1 2 1 2 1] [0 1 3 2 0  4 5 7 6 4  0 4 1 5 2 6 3 7] "
             "[10 10 10 10 10 10]");
    test_parse_rib_ok(rib, &s);
    assert_int_equal(s.patch_count, 6);
    for (uint32_t p = 0; p < 6; p++)
        for (int j = 0; j <= 4; j++)
            for (int i = 0; i <= 4; i++) {
                double x[3];
                bezier_point(s.cp + p * 16, i / 4.0, j / 4.0, x);
                double m = fmax(fabs(x[0]), fmax(fabs(x[1]), fabs(x[2])));
                assert_true(fabs(m - 1) < 1e-6);
            }
    assert_int_equal(open_edges(&s), 0);
    scene_free(&s);
    /* Corners alone: a tagged corner stays where its point is. */
    snprintf(rib, sizeof rib, cube_rib, "[\"corner\"] [1 1] [7] [10]");
    test_parse_rib_ok(rib, &s);
    int found = 0;
    for (uint32_t p = 0; p < s.patch_count; p++)
        for (int c = 0; c < 16; c += 3)
            found |= s.cp[p * 16 + c].x == 1 && s.cp[p * 16 + c].y == 1 && s.cp[p * 16 + c].z == 1;
    assert_true(found);
    scene_free(&s);
    /* A tetrahedron (triangles): refined once into 12 quads, closed. */
    test_parse_rib_ok("SubdivisionMesh \"catmull-clark\" [3 3 3 3] [0 2 1  0 1 3  1 2 3  2 0 3]\n"
                      "  \"P\" [1 1 1  -1 -1 1  -1 1 -1  1 -1 -1]",
                      &s);
    assert_int_equal(s.patch_count, 12);
    assert_int_equal(open_edges(&s), 0);
    scene_free(&s);
    /* Holes: no patch for the tagged faces. */
    snprintf(rib, sizeof rib, cube_rib, "[\"hole\"] [2 0] [1 4] []");
    test_parse_rib_ok(rib, &s);
    assert_int_equal(s.patch_count, 4);
    scene_free(&s);
}

/* RenderMan's HierarchicalSubdivisionMesh: the same mesh and tags as SubdivisionMesh, with
 * nargs three a tag and [stringargs] after the floats; the same patches bit for bit. A
 * hierarchical edit tag is ignored with its warning; nargs two a tag is an error there. */
static void test_hierarchical_form_is_the_same_mesh(void **state)
{
    (void)state;
    char rib[1024], tmp[1024], hier[1100];
    ts_scene a, b;
    const char *const tags[][2] = {
        /* a crease and a hole; nargs two a tag there, three here, and the stringargs */
        {"[\"crease\" \"hole\"] [2 1  1 0] [0 1  3] [10]",
         "[\"crease\" \"hole\"] [2 1 0  1 0 0] [0 1  3] [10] []"},
        /* no tags: the four empty arrays, and the empty stringargs */
        {"", "[] [] [] [] []"},
    };
    const uint32_t patches[] = {5, 6};
    for (int k = 0; k < 2; ++k) {
        snprintf(rib, sizeof rib, cube_rib, tags[k][0]);
        snprintf(tmp, sizeof tmp, cube_rib, tags[k][1]);
        snprintf(hier, sizeof hier, "Hierarchical%s", tmp);
        test_parse_rib_ok(rib, &a);
        test_parse_rib_ok(hier, &b);
        assert_int_equal(a.patch_count, patches[k]);
        assert_int_equal(b.patch_count, a.patch_count);
        assert_memory_equal(a.cp, b.cp, (size_t)a.patch_count * 16 * sizeof *a.cp);
        scene_free(&a), scene_free(&b);
    }
    test_parse_rib_error("HierarchicalSubdivisionMesh \"catmull-clark\" [4] [0 1 2 3] "
                         "[\"corner\"] [1 1] [0] [10] [] \"P\" [0 0 0 1 0 0 1 1 0 0 1 0]",
                         "t.rib:1:70: error: HierarchicalSubdivisionMesh: nargs needs 3 numbers "
                         "per tag (3), got 2");
}

static void test_primitive_variables(void **state)
{
    (void)state;
    char rib[2048];
    ts_scene s;
    snprintf(rib, sizeof rib, cube_rib,
             "\"uniform color Cs\" [1 0 0 0 1 0 0 0 1 1 1 0 0 1 1 1 0 1] "
             "\"facevarying float[2] st\" [0 0 1 0 1 1 0 1  2 0 3 0 3 1 2 1  0 0 1 0 1 1 0 1 "
             "0 0 1 0 1 1 0 1  0 0 1 0 1 1 0 1  0 0 1 0 1 1 0 1]");
    test_parse_rib_ok(rib, &s);
    assert_float_equal(s.attr[1].cs_g, 1, 0);
    assert_float_equal(s.attr[5].cs_b, 1, 0);
    /* Corner order (0,0) (1,0) (0,1) (1,1) = face-vertices 0 1 3 2. */
    const float st1[8] = {2, 0, 3, 0, 2, 1, 3, 1};
    for (int k = 0; k < 8; k++)
        assert_float_equal(s.attr[1].st[k], st1[k], 0);
    scene_free(&s);
}

/* Sheets that meet only at a vertex (a bow tie of two quads): the vertex is split into one
 * sharp corner a fan, so each patch's corner there is the point itself, exactly, and the
 * sheets meet; the first patch is the one its quad alone gives with that vertex tagged a
 * corner; one warning counts the vertices. */
static void test_nonmanifold_vertex_split(void **state)
{
    (void)state;
    const char *bowtie =
        "SubdivisionMesh \"catmull-clark\" [4 4] [0 1 2 3 0 4 5 6] [\"interpolateboundary\"] "
        "[0 0] [] [] \"P\" [0 0 0  1 0 0  1 1 0  0 1 0.5  -1 0 0  -1 -1 0  0 -1 0.5]";
    ts_scene s;
    test_parse_rib_ok(bowtie, &s);
    assert_int_equal(s.patch_count, 2);
    for (uint32_t k = 0; k < 2; k++) {
        const ts_vec4 *cp = &s.cp[16 * k];
        /* the patch corner at the shared vertex (one of the four corners) is (0, 0, 0) */
        int found = 0;
        const int corners[4] = {0, 3, 12, 15};
        for (int c = 0; c < 4; c++)
            found |=
                cp[corners[c]].x == 0.0f && cp[corners[c]].y == 0.0f && cp[corners[c]].z == 0.0f;
        if (!found) fail_msg("patch %u has no corner at the shared vertex", k);
    }
    scene_free(&s);
    /* the same patches as each quad alone with that vertex a corner */
    const char *alone =
        "SubdivisionMesh \"catmull-clark\" [4] [0 1 2 3] [\"interpolateboundary\" \"corner\"] "
        "[0 0 1 1] [0] [10] \"P\" [0 0 0  1 0 0  1 1 0  0 1 0.5]";
    ts_scene one;
    test_parse_rib_ok(bowtie, &s);
    test_parse_rib_ok(alone, &one);
    assert_int_equal(one.patch_count, 1);
    assert_memory_equal(one.cp, s.cp, 16 * sizeof *s.cp);
    scene_free(&one), scene_free(&s);
    int rc;
    assert_string_equal(test_rib_warnings(bowtie, &rc),
                        "w.rib:1:1: warning: SubdivisionMesh: 1 vertex(es) where faces meet only "
                        "at the point (not manifold) are drawn as sharp corners\n");
    assert_int_equal(rc, TS_OK);
}

static void test_errors_and_warnings(void **state)
{
    (void)state;
    test_parse_rib_error("SubdivisionMesh \"loop\" [3] [0 1 2] \"P\" [0 0 0 1 0 0 0 1 0]",
                         "t.rib:1:17: error: SubdivisionMesh: scheme \"loop\" is not supported "
                         "(catmull-clark)");
    test_parse_rib_error("SubdivisionMesh \"catmull-clark\" [3 3] [0 1 2 0 1 3] "
                         "\"P\" [0 0 0 1 0 0 0 1 0 1 1 0]",
                         "t.rib:1:1: error: SubdivisionMesh: edge 0-1 is used twice in the same "
                         "direction (faces 0 and 1): the mesh is not manifold or its faces are not "
                         "consistently oriented");
    test_parse_rib_error(
        "SubdivisionMesh \"catmull-clark\" [4] [0 1 1 2] \"P\" [0 0 0 1 0 0 0 1 0]",
        "t.rib:1:1: error: SubdivisionMesh: face 0 uses vertex 1 twice");
    test_parse_rib_error("SubdivisionMesh \"catmull-clark\" [3] [0 1 3] \"P\" [0 0 0 1 0 0 0 1 0]",
                         "t.rib:1:37: error: SubdivisionMesh: vertex 2 is point 3, but \"P\" has 3 "
                         "points");
    test_parse_rib_error(
        "SubdivisionMesh \"catmull-clark\" [2] [0 1] \"P\" [0 0 0 1 0 0]",
        "t.rib:1:33: error: SubdivisionMesh: nvertices: value 0 is 2, not an integer in "
        "[3, 16777216]");
    test_parse_rib_error(
        "SubdivisionMesh \"catmull-clark\" [3] [0 1 2] [\"crease\"] [2 1] [0 1 2] [1] "
        "\"P\" [0 0 0 1 0 0 0 1 0]",
        "t.rib:1:56: error: SubdivisionMesh: nargs asks for 2 integers and 1 floats, "
        "intargs has 3 and floatargs 1");
    test_parse_rib_error(
        "SubdivisionMesh \"catmull-clark\" [3] [0 1 2] [\"hole\"] [1 0] [4] [] "
        "\"P\" [0 0 0 1 0 0 0 1 0]",
        "t.rib:1:45: error: SubdivisionMesh: tag \"hole\": integer 4 is out of range [0, "
        "1)");
    int rc;
    const char *w = test_rib_warnings(
        "SubdivisionMesh \"catmull-clark\" [4] [0 1 2 3] [\"crease\" \"vertexedit\" \"crease\"] "
        "[2 1 0 0 2 1] [0 1 2 3] [2.5 0] \"P\" [0 0 0 1 0 0 1 1 0 0 1 0]\n",
        &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(w, "w.rib:1:47: warning: SubdivisionMesh: sharpness 2.5 is made infinitely "
                           "sharp (semi-sharp creases and corners are not supported)\n"
                           "w.rib:1:47: warning: SubdivisionMesh tag \"vertexedit\" is ignored\n");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_regular_torus_exact),
        cmocka_unit_test(test_boundary_and_crease_exact),
        cmocka_unit_test(test_cube_against_limit),
        cmocka_unit_test(test_creases_corners_watertight),
        cmocka_unit_test(test_hierarchical_form_is_the_same_mesh),
        cmocka_unit_test(test_primitive_variables),
        cmocka_unit_test(test_nonmanifold_vertex_split),
        cmocka_unit_test(test_errors_and_warnings),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
