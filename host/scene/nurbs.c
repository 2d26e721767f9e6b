/* nurbs.c — NURBS surfaces as bicubic Bézier patches: knot insertion into Bézier pieces,
 * exact degree elevation, and for rational surfaces polynomial approximation with a
 * rigorous error bound (see nurbs.h). All arithmetic in double, on homogeneous points. */
#include "scene/nurbs.h"

#include "base/error.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- checks ------------------------------------------------------------------------- */

int nurbs_check_knots(int n, int order, const double *knot, double *lo, double *hi, const char *d,
                      char *why, size_t len)
{
    if (order < 2 || order > NURBS_MAX_ORDER) {
        snprintf(why, len, "%sorder %d is not supported (%s)", d, order,
                 order < 2 ? "at least 2: order 1 is a step function" : "at most 4, cubic");
        return TS_E_SCENE;
    }
    if (n < order) {
        snprintf(why, len, "n%s = %d control points are fewer than the %sorder %d", d, n, d, order);
        return TS_E_SCENE;
    }
    for (int k = 1; k < n + order; k++)
        if (!(knot[k] >= knot[k - 1])) {
            snprintf(why, len, "%sknot %d (%g) is less than the one before (%g)", d, k, knot[k],
                     knot[k - 1]);
            return TS_E_SCENE;
        }
    double a = knot[order - 1], b = knot[n];
    if (!(*lo < *hi) || !(*lo < b) || !(*hi > a) || !(a < b)) {
        snprintf(why, len, "%smin %g and %smax %g leave no part of the valid range [%g, %g]", d,
                 *lo, d, *hi, a, b);
        return TS_E_SCENE;
    }
    *lo = fmax(*lo, a), *hi = fmin(*hi, b);
    return TS_OK;
}

int nurbs_check(const ts_nurbs *s, char *why, size_t len)
{
    double lo = s->umin, hi = s->umax;
    int rc = nurbs_check_knots(s->nu, s->uorder, s->uknot, &lo, &hi, "u", why, len);
    lo = s->vmin, hi = s->vmax;
    if (rc == TS_OK) rc = nurbs_check_knots(s->nv, s->vorder, s->vknot, &lo, &hi, "v", why, len);
    for (size_t k = 0; rc == TS_OK && k < (size_t)s->nu * (size_t)s->nv; k++)
        if (!(s->pw[4 * k + 3] > 0.0)) {
            snprintf(why, len, "the weight of control point %zu is %g (weights must be positive)",
                     k, s->pw[4 * k + 3]);
            rc = TS_E_SCENE;
        }
    return rc;
}

/* ---- knot insertion ------------------------------------------------------------------ */

/* A curve of n control points of `dim` doubles each (a whole row or column of the net at
 * once) with its knot vector, growing as knots go in. */
typedef struct nurbs_curve {
    double *knot, *pts;
    int n, p, dim, cap;
} nurbs_curve;

/* Inserts x once (Boehm): the span k with knot[k] <= x, knot[k] < knot[k + 1], p <= k <=
 * n - 1 (the closed span, so x may be its right end), new points
 * Q_i = (1 - a_i) P_{i-1} + a_i P_i, a_i = (x - t_i) / (t_{i+p} - t_i) for k-p < i <= k. */
static void nurbs_insert(nurbs_curve *c, double x)
{
    int k = c->n - 1;
    while (k > c->p && !(c->knot[k] <= x && c->knot[k] < c->knot[k + 1]))
        k--;
    const int dim = c->dim, p = c->p;
    double *P = c->pts;
    /* Points after k shift up by one; points k-p+1..k are blended, from the top down so
     * each P_{i-1} is still the old one. */
    memmove(P + (size_t)(k + 1) * dim, P + (size_t)k * dim, (size_t)(c->n - k) * dim * sizeof *P);
    for (int i = k; i > k - p; i--) {
        double a = (x - c->knot[i]) / (c->knot[i + p] - c->knot[i]);
        for (int d = 0; d < dim; d++)
            P[(size_t)i * dim + d] =
                (1.0 - a) * P[(size_t)(i - 1) * dim + d] + a * P[(size_t)i * dim + d];
    }
    memmove(c->knot + k + 2, c->knot + k + 1, (size_t)(c->n + p - k) * sizeof *c->knot);
    c->knot[k + 1] = x;
    c->n++;
}

/* Raises the multiplicity of x to p (inserting p - s times). */
static void nurbs_raise(nurbs_curve *c, double x)
{
    int s = 0;
    for (int k = 0; k < c->n + c->p + 1; k++)
        s += c->knot[k] == x;
    for (; s < c->p; s++)
        nurbs_insert(c, x);
}

/* Every distinct knot strictly inside (lo, hi), and lo and hi, to multiplicity p. */
static void nurbs_refine(nurbs_curve *c, double lo, double hi)
{
    nurbs_raise(c, lo);
    nurbs_raise(c, hi);
    for (int k = 0; k < c->n + c->p + 1; k++) {
        double x = c->knot[k];
        if (x > lo && x < hi && (k == 0 || c->knot[k - 1] != x)) nurbs_raise(c, x);
    }
}

/* The largest number of points refinement can make: one insertion per knot value per
 * degree, plus the two ends. */
static int nurbs_capacity(int n, int order)
{
    return n + (order - 1) * (n + order + 2);
}

/* Refines the grid in one direction: `lines` curves of n points each (pts[i][line][4]),
 * knots of n + order. On return pts and knot are the refined ones (n updated). */
static int nurbs_refine_dir(double **pts, double **knot, int *n, int order, int lines, double lo,
                            double hi)
{
    int cap = nurbs_capacity(*n, order);
    double *P = realloc(*pts, (size_t)cap * (size_t)lines * 4 * sizeof *P);
    if (!P) return TS_E_MEMORY;
    *pts = P;
    double *K = realloc(*knot, (size_t)(cap + order) * sizeof *K);
    if (!K) return TS_E_MEMORY;
    *knot = K;
    nurbs_curve c = {K, P, *n, order - 1, lines * 4, cap};
    nurbs_refine(&c, lo, hi);
    *n = c.n;
    return TS_OK;
}

/* out[j][i] = in[i][j] for blocks of 4 doubles. */
static void nurbs_transpose(const double *in, int ni, int nj, double *out)
{
    for (int i = 0; i < ni; i++)
        for (int j = 0; j < nj; j++)
            memcpy(out + ((size_t)j * ni + i) * 4, in + ((size_t)i * nj + j) * 4, 4 * sizeof *out);
}

/* ---- Bézier pieces ---------------------------------------------------------------------- */

/* Degree elevation of one Bézier curve of degree p (p + 1 homogeneous points, stride s
 * doubles) to cubic, in place into out[4][4]. */
static void nurbs_elevate(const double *in, int p, size_t s, double out[4][4])
{
    for (int d = 0; d < 4; d++) {
        double a = in[d], b = in[s + d], c = p >= 2 ? in[2 * s + d] : 0.0;
        if (p == 1) {
            out[0][d] = a, out[1][d] = (2 * a + b) / 3, out[2][d] = (a + 2 * b) / 3, out[3][d] = b;
        } else if (p == 2) {
            out[0][d] = a, out[1][d] = (a + 2 * b) / 3, out[2][d] = (2 * b + c) / 3, out[3][d] = c;
        } else {
            for (int k = 0; k < 4; k++)
                out[k][d] = in[k * s + d];
        }
    }
}

/* The homogeneous bicubic net of the piece whose first refined point is (i0, j0): elevated
 * along u row by row, then along v column by column. grid is [j][i][4], nu points a row. */
static void nurbs_piece(const double *grid, int nu, int i0, int j0, int pu, int pv,
                        double h[4][4][4])
{
    double rows[4][4][4]; /* [row j][u k][4], rows j0..j0+pv */
    for (int j = 0; j <= pv; j++)
        nurbs_elevate(grid + ((size_t)(j0 + j) * nu + i0) * 4, pu, 4, rows[j]);
    for (int k = 0; k < 4; k++) {
        double col[4][4];
        nurbs_elevate(&rows[0][k][0], pv, 16, col);
        for (int j = 0; j < 4; j++)
            memcpy(h[j][k], col[j], sizeof col[j]);
    }
}

/* ---- rational pieces --------------------------------------------------------------------- */

static void nurbs_bern3(double t, double b[4])
{
    double s = 1.0 - t;
    b[0] = s * s * s, b[1] = 3.0 * t * s * s, b[2] = 3.0 * t * t * s, b[3] = t * t * t;
}

/* The rational surface N / W of the homogeneous net h at (u, v). */
static void nurbs_eval(const double h[4][4][4], double u, double v, double out[3])
{
    double bu[4], bv[4], acc[4] = {0, 0, 0, 0};
    nurbs_bern3(u, bu);
    nurbs_bern3(v, bv);
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++)
            for (int d = 0; d < 4; d++)
                acc[d] += bu[i] * bv[j] * h[j][i][d];
    out[0] = acc[0] / acc[3], out[1] = acc[1] / acc[3], out[2] = acc[2] / acc[3];
}

/* The blossom f(t1, t2, t3) of the cubic with homogeneous points p[0..3] (stride s). */
static void nurbs_blossom(const double *p, size_t s, double t1, double t2, double t3, double out[4])
{
    for (int d = 0; d < 4; d++) {
        double a[3], b[2];
        for (int k = 0; k < 3; k++)
            a[k] = (1.0 - t1) * p[k * s + d] + t1 * p[(k + 1) * s + d];
        for (int k = 0; k < 2; k++)
            b[k] = (1.0 - t2) * a[k] + t2 * a[k + 1];
        out[d] = (1.0 - t3) * b[0] + t3 * b[1];
    }
}

/* The homogeneous net of h restricted to [u0, u1] x [v0, v1]: the blossoms f(a,a,a),
 * f(a,a,b), f(a,b,b), f(b,b,b) along rows, then columns. */
static void nurbs_subnet(const double h[4][4][4], double u0, double u1, double v0, double v1,
                         double out[4][4][4])
{
    double rows[4][4][4];
    for (int j = 0; j < 4; j++) {
        nurbs_blossom(h[j][0], 4, u0, u0, u0, rows[j][0]);
        nurbs_blossom(h[j][0], 4, u0, u0, u1, rows[j][1]);
        nurbs_blossom(h[j][0], 4, u0, u1, u1, rows[j][2]);
        nurbs_blossom(h[j][0], 4, u1, u1, u1, rows[j][3]);
    }
    for (int i = 0; i < 4; i++) {
        nurbs_blossom(rows[0][i], 16, v0, v0, v0, out[0][i]);
        nurbs_blossom(rows[0][i], 16, v0, v0, v1, out[1][i]);
        nurbs_blossom(rows[0][i], 16, v0, v1, v1, out[2][i]);
        nurbs_blossom(rows[0][i], 16, v1, v1, v1, out[3][i]);
    }
}

/* The bicubic interpolating h's rational surface at the 4 x 4 nodes (thirds) of
 * [u0, u1] x [v0, v1]: values F, then Q = A F A^T with A the inverse of the Bernstein
 * matrix at thirds, whose first and last rows are unit rows (edges depend on edge values
 * only). */
static void nurbs_fit(const double h[4][4][4], double u0, double u1, double v0, double v1,
                      double q[16][3])
{
    static const double A[4][4] = {{1, 0, 0, 0},
                                   {-5.0 / 6.0, 3, -1.5, 1.0 / 3.0},
                                   {1.0 / 3.0, -1.5, 3, -5.0 / 6.0},
                                   {0, 0, 0, 1}};
    const double us[4] = {u0, u0 + (u1 - u0) / 3.0, u0 + 2.0 * (u1 - u0) / 3.0, u1};
    const double vs[4] = {v0, v0 + (v1 - v0) / 3.0, v0 + 2.0 * (v1 - v0) / 3.0, v1};
    double F[4][4][3], G[4][4][3];
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++)
            nurbs_eval(h, us[i], vs[j], F[j][i]);
    for (int j = 0; j < 4; j++) /* along u: G[j][i] = sum A[i][k] F[j][k] */
        for (int i = 0; i < 4; i++)
            for (int d = 0; d < 3; d++) {
                double a = 0.0;
                for (int k = 0; k < 4; k++)
                    a += A[i][k] * F[j][k][d];
                G[j][i][d] = a;
            }
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++)
            for (int d = 0; d < 3; d++) {
                double a = 0.0;
                for (int k = 0; k < 4; k++)
                    a += A[j][k] * G[k][i][d];
                q[j * 4 + i][d] = a;
            }
}

/* The error bound of q against the rational patch of homogeneous net hs:
 * max |c_kl| / min w_ij with c = N - Q W in degree-6 Bernstein form,
 * c_kl = sum_{i+i'=k, j+j'=l} e(i,i') e(j,j') (N_ij - Q_ij W_i'j'),
 * e(i,i') = C(3,i) C(3,i') / C(6,i+i'). */
static double nurbs_bound(const double hs[4][4][4], const double q[16][3])
{
    static const double c3[4] = {1, 3, 3, 1}, c6[7] = {1, 6, 15, 20, 15, 6, 1};
    double wmin = INFINITY, worst = 0.0;
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++)
            wmin = fmin(wmin, hs[j][i][3]);
    for (int l = 0; l <= 6; l++)
        for (int k = 0; k <= 6; k++) {
            double c[3] = {0, 0, 0};
            for (int j = l > 3 ? l - 3 : 0; j <= 3 && j <= l; j++)
                for (int i = k > 3 ? k - 3 : 0; i <= 3 && i <= k; i++) {
                    int i2 = k - i, j2 = l - j;
                    double e = c3[i] * c3[i2] / c6[k] * c3[j] * c3[j2] / c6[l];
                    for (int d = 0; d < 3; d++)
                        c[d] += e * (hs[j][i][d] - q[j * 4 + i][d] * hs[j2][i2][3]);
                }
            worst = fmax(worst, sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]));
        }
    return worst / wmin;
}

/* ---- the whole surface --------------------------------------------------------------------- */

/* The refined surface: grid [j][i][4] of nu x nv homogeneous points, knots, degrees, and
 * the knot spans that are Bézier pieces inside the parameter range. */
typedef struct nurbs_refined {
    double *grid, *uk, *vk;
    int nu, nv, pu, pv;
    int *uspan, *vspan, nus, nvs; /* span s: points s - p .. s, knots [k[s], k[s + 1]] */
} nurbs_refined;

static void nurbs_refined_free(nurbs_refined *r)
{
    free(r->grid), free(r->uk), free(r->vk), free(r->uspan), free(r->vspan);
}

/* The non-empty spans of knots k (n points, degree p) inside [lo, hi]. */
static int nurbs_spans(const double *k, int n, int p, double lo, double hi, int **out)
{
    int count = 0;
    *out = malloc((size_t)(n > 0 ? n : 1) * sizeof **out);
    if (!*out) return -1;
    for (int s = p; s < n; s++)
        if (k[s] < k[s + 1] && k[s] >= lo && k[s + 1] <= hi) (*out)[count++] = s;
    return count;
}

/* Refines the net along u, then along v, and lists the pieces. */
static int nurbs_make_refined(const ts_nurbs *s, nurbs_refined *r)
{
    memset(r, 0, sizeof *r);
    const double ulo = fmax(s->umin, s->uknot[s->uorder - 1]), uhi = fmin(s->umax, s->uknot[s->nu]);
    const double vlo = fmax(s->vmin, s->vknot[s->vorder - 1]), vhi = fmin(s->vmax, s->vknot[s->nv]);
    size_t pts = (size_t)s->nu * (size_t)s->nv;
    double *a = malloc(pts * 4 * sizeof *a), *b = NULL;
    r->uk = malloc((size_t)(s->nu + s->uorder) * sizeof *r->uk);
    r->vk = malloc((size_t)(s->nv + s->vorder) * sizeof *r->vk);
    int rc = a && r->uk && r->vk ? TS_OK : TS_E_MEMORY;
    if (rc == TS_OK) {
        memcpy(r->uk, s->uknot, (size_t)(s->nu + s->uorder) * sizeof *r->uk);
        memcpy(r->vk, s->vknot, (size_t)(s->nv + s->vorder) * sizeof *r->vk);
        nurbs_transpose(s->pw, s->nv, s->nu, a); /* [i][j] */
        r->nu = s->nu, r->nv = s->nv, r->pu = s->uorder - 1, r->pv = s->vorder - 1;
        rc = nurbs_refine_dir(&a, &r->uk, &r->nu, s->uorder, s->nv, ulo, uhi);
    }
    if (rc == TS_OK) {
        b = malloc((size_t)r->nu * (size_t)s->nv * 4 * sizeof *b);
        rc = b ? TS_OK : TS_E_MEMORY;
    }
    if (rc == TS_OK) {
        nurbs_transpose(a, r->nu, s->nv, b); /* [j][i] */
        rc = nurbs_refine_dir(&b, &r->vk, &r->nv, s->vorder, r->nu, vlo, vhi);
    }
    free(a);
    r->grid = b;
    if (rc == TS_OK) {
        r->nus = nurbs_spans(r->uk, r->nu, r->pu, ulo, uhi, &r->uspan);
        r->nvs = nurbs_spans(r->vk, r->nv, r->pv, vlo, vhi, &r->vspan);
        if (r->nus < 0 || r->nvs < 0) rc = TS_E_MEMORY;
    }
    return rc;
}

/* The RI Spec segment (original span) holding parameter x. */
static int nurbs_segment(const double *knot, int n, int order, double x)
{
    int k = n - 1;
    while (k > order - 1 && knot[k] > x)
        k--;
    return k - (order - 1);
}

/* Whether every weight is the same: the surface is polynomial. */
static int nurbs_polynomial(const ts_nurbs *s)
{
    for (size_t k = 1; k < (size_t)s->nu * (size_t)s->nv; k++)
        if (s->pw[4 * k + 3] != s->pw[3]) return 0;
    return 1;
}

/* The diagonal of the box of the dehomogenised control points. */
static double nurbs_diagonal(const ts_nurbs *s)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t k = 0; k < (size_t)s->nu * (size_t)s->nv; k++)
        for (int d = 0; d < 3; d++) {
            double x = s->pw[4 * k + d] / s->pw[4 * k + 3];
            lo[d] = fmin(lo[d], x), hi[d] = fmax(hi[d], x);
        }
    return sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

/* The largest error bound over every sub-square of every piece, each piece split into
 * 2^lu x 2^lv sub-squares; it stops early (returning more than `stop`) once it exceeds
 * `stop`. */
static double nurbs_level_bound(const nurbs_refined *r, int lu, int lv, double stop)
{
    const int mu = 1 << lu, mv = 1 << lv;
    double worst = 0.0;
    for (int b = 0; b < r->nvs; b++)
        for (int a = 0; a < r->nus; a++) {
            double h[4][4][4];
            nurbs_piece(r->grid, r->nu, r->uspan[a] - r->pu, r->vspan[b] - r->pv, r->pu, r->pv, h);
            for (int y = 0; y < mv; y++)
                for (int x = 0; x < mu; x++) {
                    double u0 = (double)x / mu, u1 = (double)(x + 1) / mu;
                    double v0 = (double)y / mv, v1 = (double)(y + 1) / mv, hs[4][4][4], q[16][3];
                    nurbs_fit(h, u0, u1, v0, v1, q);
                    nurbs_subnet(h, u0, u1, v0, v1, hs);
                    worst = fmax(worst, nurbs_bound(hs, q));
                    if (worst > stop) return worst;
                }
        }
    return worst;
}

/* Whether splitting into 2^lu x 2^lv sub-squares stays within NURBS_MAX_PATCHES. */
static int nurbs_level_fits(const nurbs_refined *r, int lu, int lv)
{
    return lu <= NURBS_MAX_LEVEL && lv <= NURBS_MAX_LEVEL &&
           (double)r->nus * r->nvs * (double)(1 << lu) * (double)(1 << lv) <= NURBS_MAX_PATCHES;
}

/* The split levels of rational pieces: from (0, 0), one more level at a time in the
 * direction whose split lowers the bound more, until it is at most tol or no split fits
 * (NURBS_MAX_LEVEL, NURBS_MAX_PATCHES). Sets res->level_u, level_v and bound (absolute). */
static void nurbs_levels(const nurbs_refined *r, double tol, nurbs_result *res)
{
    int lu = 0, lv = 0;
    double b = nurbs_level_bound(r, 0, 0, INFINITY);
    while (b > tol && (nurbs_level_fits(r, lu + 1, lv) || nurbs_level_fits(r, lu, lv + 1))) {
        double bu =
            nurbs_level_fits(r, lu + 1, lv) ? nurbs_level_bound(r, lu + 1, lv, INFINITY) : INFINITY;
        double bv =
            nurbs_level_fits(r, lu, lv + 1) ? nurbs_level_bound(r, lu, lv + 1, bu) : INFINITY;
        if (bu <= bv)
            lu++, b = bu;
        else
            lv++, b = bv;
    }
    res->level_u = lu, res->level_v = lv, res->bound = b;
}

/* Emits piece (a, b) of r as mu x mv sub-squares (1 x 1 and exact when polynomial). */
static int nurbs_emit_piece(const ts_nurbs *s, const nurbs_refined *r, int a, int b, int mu, int mv,
                            int polynomial, nurbs_patch_fn fn, void *ctx, int *count)
{
    double h[4][4][4];
    const int su = r->uspan[a], sv = r->vspan[b];
    nurbs_piece(r->grid, r->nu, su - r->pu, sv - r->pv, r->pu, r->pv, h);
    const double ka = r->uk[su], kb = r->uk[su + 1], la = r->vk[sv], lb = r->vk[sv + 1];
    int seg_u = nurbs_segment(s->uknot, s->nu, s->uorder, 0.5 * (ka + kb));
    int seg_v = nurbs_segment(s->vknot, s->nv, s->vorder, 0.5 * (la + lb));
    for (int y = 0; y < mv; y++)
        for (int x = 0; x < mu; x++) {
            double u0 = (double)x / mu, u1 = (double)(x + 1) / mu;
            double v0 = (double)y / mv, v1 = (double)(y + 1) / mv, q[16][3], uv[4][2];
            if (polynomial) {
                for (int k = 0; k < 16; k++)
                    for (int d = 0; d < 3; d++)
                        q[k][d] = h[k / 4][k % 4][d] / h[k / 4][k % 4][3];
            } else {
                nurbs_fit(h, u0, u1, v0, v1, q);
            }
            for (int c = 0; c < 4; c++) {
                double fu = (c & 1) ? u1 : u0, fv = (c & 2) ? v1 : v0;
                uv[c][0] = fu == 1.0 ? kb : ka + fu * (kb - ka);
                uv[c][1] = fv == 1.0 ? lb : la + fv * (lb - la);
            }
            int rc = fn(ctx, (const double(*)[3])q, (const double(*)[2])uv, seg_u, seg_v);
            if (rc != TS_OK) return rc;
            (*count)++;
        }
    return TS_OK;
}

int nurbs_patches(const ts_nurbs *s, nurbs_patch_fn fn, void *ctx, nurbs_result *res, char *why,
                  size_t why_len)
{
    memset(res, 0, sizeof *res);
    nurbs_refined r;
    int rc = nurbs_make_refined(s, &r);
    if (rc != TS_OK) {
        nurbs_refined_free(&r);
        snprintf(why, why_len, "out of memory refining %d x %d control points", s->nu, s->nv);
        return rc;
    }
    const int polynomial = nurbs_polynomial(s);
    res->rational = !polynomial;
    if (!polynomial) {
        const double diag = nurbs_diagonal(s);
        nurbs_levels(&r, NURBS_TOL_REL * diag, res);
        res->bound = diag > 0.0 ? res->bound / diag : 0.0;
    }
    const int mu = 1 << res->level_u, mv = 1 << res->level_v;
    for (int b = 0; rc == TS_OK && b < r.nvs; b++)
        for (int a = 0; rc == TS_OK && a < r.nus; a++)
            rc = nurbs_emit_piece(s, &r, a, b, mu, mv, polynomial, fn, ctx, &res->patches);
    nurbs_refined_free(&r);
    return rc;
}
