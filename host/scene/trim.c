/* trim.c — trim curves as polylines, and which part of each NURBS piece they keep (trim.h). */
#include "scene/trim.h"

#include "base/hash.h"
#include "lib/trim.h"
#include "scene/nurbs.h"
#include "scene/scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The point at t of the curve's span k (knot[k] <= t <= knot[k + 1], order - 1 <= k < n) by
 * de Boor's algorithm on the homogeneous points, projected: (u, v) / w. */
static void curve_point(const double *knot, const double *u, const double *v, const double *w,
                        int order, int k, double t, double out[2])
{
    double d[NURBS_MAX_ORDER][3];
    int p = order - 1;
    for (int j = 0; j <= p; j++)
        d[j][0] = u[j + k - p], d[j][1] = v[j + k - p], d[j][2] = w[j + k - p];
    for (int r = 1; r <= p; r++)
        for (int j = p; j >= r; j--) {
            double lo = knot[j + k - p], den = knot[j + 1 + k - r] - lo;
            double a = den > 0.0 ? (t - lo) / den : 0.0;
            for (int c = 0; c < 3; c++)
                d[j][c] = (1.0 - a) * d[j - 1][c] + a * d[j][c];
        }
    out[0] = d[p][0] / d[p][2], out[1] = d[p][1] / d[p][2];
}

/* Appends segment a -> b. */
static int trim_push(trim_set *t, uint32_t *cap, const double a[2], const double b[2])
{
    if (t->count == TRIM_MAX_SEGMENTS) return TS_E_SCENE;
    if (t->count == *cap) {
        uint32_t c = *cap ? *cap * 2u : 64u;
        double(*s)[4] = realloc(t->seg, (size_t)c * sizeof *s);
        if (!s) return TS_E_MEMORY;
        t->seg = s, *cap = c;
    }
    double *s = t->seg[t->count++];
    s[0] = a[0], s[1] = a[1], s[2] = b[0], s[3] = b[1];
    return TS_OK;
}

/* Checks curve k (its knots, weights and range, nurbs_check_knots for all but the weights):
 * the range it is drawn over in [*lo, *hi]. */
static int curve_check(const trim_curves *c, int k, const double *knot, const double *w, double *lo,
                       double *hi, char *why, size_t why_len)
{
    int order = (int)c->order[k], n = (int)c->n[k];
    char what[192];
    *lo = c->min[k], *hi = c->max[k];
    if (nurbs_check_knots(n, order, knot, lo, hi, "", what, sizeof what) != TS_OK) {
        snprintf(why, why_len, "curve %d: %s", k, what);
        return TS_E_SCENE;
    }
    for (int i = 0; i < n; i++)
        if (!(w[i] > 0.0)) {
            snprintf(why, why_len, "curve %d: weight %d is %g (weights must be positive)", k, i,
                     w[i]);
            return TS_E_SCENE;
        }
    return TS_OK;
}

int trim_make(const trim_curves *c, trim_set *out, char *why, size_t why_len)
{
    memset(out, 0, sizeof *out);
    if (why_len) why[0] = '\0';
    uint32_t cap = 0;
    size_t at_knot = 0, at_pt = 0;
    int k = 0, rc = TS_OK;
    for (int l = 0; l < c->nloops && rc == TS_OK; l++) {
        double first[2] = {0, 0}, last[2] = {0, 0};
        int started = 0;
        for (int e = 0; e < (int)c->ncurves[l] && rc == TS_OK; e++, k++) {
            const double *knot = c->knot + at_knot, *u = c->u + at_pt, *v = c->v + at_pt,
                         *w = c->w + at_pt;
            int order = (int)c->order[k], n = (int)c->n[k];
            double lo, hi;
            rc = curve_check(c, k, knot, w, &lo, &hi, why, why_len);
            for (int s = order - 1; s < n && rc == TS_OK; s++) {
                double a = fmax(knot[s], lo), b = fmin(knot[s + 1], hi);
                if (!(a < b)) continue;
                int steps = order == 2 ? 1 : TRIM_SPAN_STEPS;
                for (int i = 0; i <= steps && rc == TS_OK; i++) {
                    double pt[2];
                    curve_point(knot, u, v, w, order, s, a + (b - a) * i / steps, pt);
                    if (!started)
                        first[0] = pt[0], first[1] = pt[1], started = 1;
                    else if (pt[0] != last[0] || pt[1] != last[1]) /* a span's or curve's start */
                        rc = trim_push(out, &cap, last, pt);       /* joins them head to tail */
                    last[0] = pt[0], last[1] = pt[1];
                }
            }
            at_knot += (size_t)n + (size_t)order;
            at_pt += (size_t)n;
        }
        if (rc == TS_OK && started && (last[0] != first[0] || last[1] != first[1]))
            rc = trim_push(out, &cap, last, first); /* the loop, closed */
    }
    if (rc == TS_E_SCENE && !why[0])
        snprintf(why, why_len, "more than %d segments", TRIM_MAX_SEGMENTS);
    if (rc == TS_E_MEMORY) snprintf(why, why_len, "out of memory");
    if (rc != TS_OK) trim_set_free(out);
    return rc;
}

void trim_set_free(trim_set *t)
{
    free(t->seg);
    t->seg = NULL, t->count = 0;
}

/* Whether segment (x0, y0) -> (x1, y1) meets the square [0, 1]^2 (Liang-Barsky clipping). */
static int segment_meets_square(double x0, double y0, double x1, double y1)
{
    double t0 = 0.0, t1 = 1.0;
    const double p[4] = {-(x1 - x0), x1 - x0, -(y1 - y0), y1 - y0};
    const double q[4] = {x0, 1.0 - x0, y0, 1.0 - y0};
    for (int i = 0; i < 4; i++) {
        if (p[i] == 0.0) {
            if (q[i] < 0.0) return 0;
        } else {
            double r = q[i] / p[i];
            if (p[i] < 0.0)
                t0 = fmax(t0, r);
            else
                t1 = fmin(t1, r);
        }
    }
    return t0 <= t1;
}

int trim_piece(const trim_set *t, double u0, double v0, double u1, double v1, ts_vec4 *out,
               uint32_t *count)
{
    double su = 1.0 / (u1 - u0), sv = 1.0 / (v1 - v0);
    uint32_t n = 0;
    int meets = 0;
    for (uint32_t k = 0; k < t->count; k++) {
        const double *s = t->seg[k];
        double x0 = (s[0] - u0) * su, y0 = (s[1] - v0) * sv;
        double x1 = (s[2] - u0) * su, y1 = (s[3] - v0) * sv;
        /* a ray from (x, y) in the square towards +x meets it only if it spans some y in
         * [0, 1] and reaches x >= 0 */
        if (fmax(y0, y1) < 0.0 || fmin(y0, y1) > 1.0 || fmax(x0, x1) < 0.0) continue;
        meets |= segment_meets_square(x0, y0, x1, y1);
        out[n++] = (ts_vec4){(float)x0, (float)y0, (float)x1, (float)y1};
    }
    *count = n;
    if (meets) return TRIM_PARTIAL;
    /* No curve crosses the square: the whole piece is inside or outside, as its centre. */
    *count = 0;
    return trim_keeps(out, n, 0.5f, 0.5f) ? TRIM_KEEP : TRIM_DROP;
}

uint64_t trim_hash(const ts_scene *s, uint64_t h)
{
    if (!s->trim_seg_count) return h;
    for (uint32_t p = 0; p < s->patch_count; ++p) {
        const uint32_t r[2] = {s->attr[p].trim_first, s->attr[p].trim_count};
        h = ts_fnv1a(h, r, sizeof r);
    }
    return ts_fnv1a(h, s->trim_seg, (size_t)s->trim_seg_count * sizeof *s->trim_seg);
}
